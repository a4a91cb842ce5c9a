"""Benchmark: the device layers (issue 11) -- the controller tick and the closed loop with
actuators, encoders and the safety layer -- against MuJoCo stepping the same leg.

Run: ``python benchmarks/bench_device.py``. Targets (issue 11, raised by issue 37): the
controller tick (impedance law + safety layer, and the full walking hierarchy) <= 1 us
compiled; 60 s of the device loop >= 100x real time and of walking with the full device
>= 200x on one core; MuJoCo on the same model where comparable.

* controller tick: the compiled PD + gravity compensation law and the safety layer's
  tick on measured states, in a compiled loop over 1,000,000 ticks, per tick;
* exoleg device loop: :func:`exoleg.sim.device_loop.simulate_device`, 60 s (the
  paper's step schedule repeated) at 1 kHz, one plant step per tick, end to end;
* MuJoCo: the same leg with the actuators' armature from the MJCF export, ``mj_step``
  (RK4, 1 ms) with the same compiled law setting the torque each step from Python: the
  plant and controller without the encoders, drive model and safety layer, which
  MuJoCo does not have -- so a lower bound on what it would cost.

* walking: :func:`exoleg.sim.walk.simulate_walk`, 60 s of treadmill walking with the
  whole device (contacts, FSR/IMU/encoders, gait-phase detection, the hierarchy, the
  safety layer, the drives), 2 plant steps per 1 ms tick; the full walking controller
  tick (:func:`exoleg.control.hierarchy.walk_control_step`: supervisor, detection,
  reference, impedance with the gravity model and inertial feedforward, safety),
  compiled, per tick;
* MuJoCo walking: the same plant (leg, armature, pelvis on a slider) stepped by
  ``mj_step`` at the same 0.5 ms with the contact and support forces of exoleg's law
  applied through ``mj_applyFT`` each step and a PD on the joints, from Python -- the
  plant only: MuJoCo has no sensors, detector, drives or safety layer here.
"""

from __future__ import annotations

import time

import numpy as np
from numba import njit

import exoleg
from exoleg.control import PDGravity
from exoleg.control.hierarchy import walk_control_step
from exoleg.control.laws import law
from exoleg.control.safety import SafetyLayer, SafetyLimits, safety_step
from exoleg.device import paper_actuators, with_actuators
from exoleg.reference import Steps
from exoleg.reference.paper import paper_reference
from exoleg.sim.device_loop import simulate_device
from exoleg.tick import OUTPUT, SENSORS, Command

DURATION = 60.0
TICKS = 1_000_000


@njit  # not cached: numba would keep stale code when only exoleg's kernels change
def _ticks(kind, kp, kd, kc, scale, limit, lim, state, Q, V, R, out):  # type: ignore[no-untyped-def]
    u = np.empty(3)
    us = np.empty(3)
    acc = 0.0
    for k in range(Q.shape[0]):
        q0, q1, q2 = Q[k, 0], Q[k, 1], Q[k, 2]
        u[0], u[1], u[2], _ = law((kind, kp, kd, kc, scale, limit),
                                  (np.sin(q0), np.cos(q0), np.sin(q1), np.cos(q1), np.sin(q2),
                                   np.cos(q2)), (q0, q1, q2), (V[k, 0], V[k, 1], V[k, 2]),
                                  (R[k, 0], R[k, 1], R[k, 2]), (0.0, 0.0, 0.0),
                                  (0.0, 0.0, 0.0))
        safety_step(lim, state, Q[k], V[k], u, False, us)
        acc += us[0] + us[1] + us[2]
    out[0] = acc


def _walk_ticks(ctl, n: int) -> None:  # type: ignore[no-untyped-def]
    """``n`` ticks of ``ctl`` walking, its clock going on from its last call (a
    controller's time never runs backwards: its detector divides by the time since)."""
    sens = np.zeros(1, SENSORS)
    sens[0]["q"] = [0.03, -0.05, 0.02]
    sens[0]["fsr"] = [1500.0, 800.0, 600.0, 300.0]
    k0 = getattr(ctl, "_bench_ticks", 0)
    _walk_loop(ctl.compiled(), sens, np.zeros(1, OUTPUT), k0, n)
    ctl._bench_ticks = k0 + n


@njit  # not cached: numba would keep stale code when only exoleg's kernels change
def _walk_loop(ctl, sens, out, k0, n):  # type: ignore[no-untyped-def]
    for k in range(k0, k0 + n):
        sens[0].command = Command.WALK if k == 10 else Command.NONE
        walk_control_step(ctl, sens, k * 1e-3, out)


def best(fn, repeat: int) -> float:  # type: ignore[no-untyped-def]
    fn()
    ts = []
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t0)
    return min(ts)


def main() -> None:
    leg = exoleg.paper_leg()
    ctrl = PDGravity(leg)
    rng = np.random.default_rng(0)
    lim = SafetyLimits.paper()
    Q = rng.uniform(lim.lower + 0.05, lim.upper - 0.05, (TICKS, 3))
    V = rng.uniform(-1.0, 1.0, (TICKS, 3))
    R = Q + rng.normal(0.0, 0.01, (TICKS, 3))
    layer = SafetyLayer(lim)
    layer.arm()
    out = np.zeros(1)
    tick = best(lambda: _ticks(ctrl.kind, *ctrl.law_args(), lim.record(), layer.state, Q, V,
                               R, out), 5) / TICKS

    base = paper_reference()
    ref = Steps(np.arange(20) * 3.0, np.tile(base.postures, (5, 1)))
    loop = best(lambda: simulate_device(leg, ctrl, ref, DURATION, q0=np.zeros(3)), 3)
    rows = [("controller tick (law + safety), compiled", tick, None),
            (f"exoleg device loop, {DURATION:g} s at 1 kHz", loop, DURATION / loop)]
    try:
        import mujoco

        from exoleg.control.laws import control_law
        from exoleg.export.writers import to_mjcf

        plant = with_actuators(leg, paper_actuators())
        m = mujoco.MjModel.from_xml_string(to_mjcf(plant, timestep=1e-3))
        m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_LIMIT
        d = mujoco.MjData(m)
        t = np.arange(int(DURATION * 1000) + 1) * 1e-3
        Qr, DQr, DDQr = ref.sample(t)
        args = (ctrl.kind, *ctrl.law_args())
        u = np.zeros(3)

        def mj() -> None:
            mujoco.mj_resetData(m, d)
            for k in range(len(t) - 1):
                control_law(args, d.qpos, d.qvel, (Qr[k], DQr[k], DDQr[k]), u)
                d.qfrc_applied[:] = u
                mujoco.mj_step(m, d)

        sec = best(mj, 1)
        rows.append((f"MuJoCo mj_step + law, {DURATION:g} s (no drive/safety)", sec,
                     DURATION / sec))
    except ImportError:
        print("MuJoCo not installed: skipped")

    # walking
    from exoleg.control.hierarchy import WalkController
    from exoleg.sim.walk import simulate_walk

    strides = int(round(DURATION / 1.1))
    walk = best(lambda: simulate_walk(leg, 30.0, strides=strides), 2)
    walked = 1.0 + strides * 1.1
    rows.append((f"exoleg walking, {walked:g} s (full device)", walk, walked / walk))
    ctl = WalkController(with_actuators(leg), 20.0)
    ctl.update({"q": ctl.gains.standing, "dq": np.zeros(3), "fsr": np.full(4, 1000.0)},
               Command.ARM, 0.0)
    wtick = best(lambda: _walk_ticks(ctl, 200_000), 3) / 200_000
    rows.insert(1, ("walking controller tick (full hierarchy), compiled", wtick, None))
    import dataclasses

    from exoleg.control.transparency import SupportMode
    from exoleg.system.build import walk_controller
    from exoleg.system.config import DeviceConfig

    def support_tick(cfg: DeviceConfig, mode: SupportMode) -> float:
        """The walking controller's tick (s) in a support mode, compiled."""
        c = walk_controller(cfg, leg, 20.0, 0.073, support_mode=mode)
        c.update({"q": c.gains.standing, "dq": np.zeros(3), "fsr": np.full(4, 1000.0),
                  "interaction": np.zeros(3)}, Command.ARM, 0.0)
        return best(lambda: _walk_ticks(c, 200_000), 3) / 200_000

    cfg = DeviceConfig.load()
    ttick = support_tick(cfg, SupportMode.TRANSPARENT)
    rows.insert(2, ("walking controller tick, transparent mode, compiled", ttick, None))
    # half the support: both laws computed every tick
    half = dataclasses.replace(cfg, assist=dataclasses.replace(cfg.assist,
                                                               start=np.full(3, 0.5)))
    atick = support_tick(half, SupportMode.AAN)
    rows.insert(3, ("walking controller tick, assist-as-needed, compiled", atick, None))
    # OpenExo's proportional law: the transparent law and the cuffs' torque asked
    ptick = support_tick(dataclasses.replace(half, assist=half.assist.with_law(
        "proportional")), SupportMode.AAN)
    rows.insert(4, ("walking controller tick, proportional assistance, compiled", ptick,
                    None))
    wtick = max(wtick, ttick, atick, ptick)
    try:
        import mujoco

        from exoleg.export.writers import to_mjcf
        from exoleg.layout import new
        from exoleg.world.plant import STEP, WalkingPlant, contact_buffers, step_contacts

        plant = WalkingPlant.of(with_actuators(leg), 20.0, 0.8)
        m = mujoco.MjModel.from_xml_string(to_mjcf(plant.leg, timestep=5e-4,
                                                   pelvis_mass=plant.body_mass))
        m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_LIMIT
        d = mujoco.MjData(m)
        foot = m.body("foot").id
        p, w = plant.leg.p, plant.record()
        pts, F, gen = contact_buffers()
        work = new(STEP)[0]
        x = np.zeros(8)
        n_steps = int(walked / 5e-4)

        def mj_walk() -> None:
            mujoco.mj_resetData(m, d)
            d.qpos[0] = plant.standing_height
            for _ in range(n_steps):
                x[:4], x[4:] = d.qpos, d.qvel
                step_contacts(p, w, x, pts, F, gen, (5e-4, work))
                mujoco.mj_forward(m, d)
                qfrc = np.zeros(4)
                for i in range(w["n"][0]):
                    mujoco.mj_applyFT(m, d, np.array([F[i, 0], F[i, 1], 0.0]), np.zeros(3),
                                      np.array([pts[i, 0], pts[i, 1], 0.0]), foot, qfrc)
                qfrc[0] += gen[0] - F[:, 1].sum()
                qfrc[1:] += -400.0 * d.qpos[1:] - 40.0 * d.qvel[1:]
                d.qfrc_applied[:] = qfrc
                mujoco.mj_step(m, d)

        t_mj = time.perf_counter()
        mj_walk()
        sec = time.perf_counter() - t_mj  # one run: it takes seconds
        rows.append((f"MuJoCo walking plant, {walked:g} s (plant + contacts)", sec,
                     walked / sec))
    except ImportError:
        pass

    print(f"{'':<52} {'wall':>12} {'x real time':>12}")
    for name, sec, rt in rows:
        wall = f"{sec * 1e9:.0f} ns" if sec < 1e-3 else f"{sec * 1e3:.1f} ms"
        print(f"{name:<52} {wall:>12} {'' if rt is None else f'{rt:,.0f}':>12}")
    print(f"\ntarget: controller tick <= 1 us: law + safety {tick * 1e9:.0f} ns, full walking "
          f"hierarchy {wtick * 1e9:.0f} ns ({'meets' if max(tick, wtick) <= 1e-6 else 'MISSES'})")
    print(f"target: 60 s of walking with the full device >= 200x real time: "
          f"{walked / walk:,.0f}x ({'meets' if walked / walk >= 200 else 'MISSES'})")
    print(f"target: device loop >= 100x real time: {DURATION / loop:,.0f}x "
          f"({'meets' if DURATION / loop >= 100 else 'MISSES'})")
    for name, sec, _ in rows:
        if name.startswith("MuJoCo mj_step"):
            print(f"exoleg device loop vs MuJoCo (plant + law only): {sec / loop:.1f}x faster")
        elif name.startswith("MuJoCo walking"):
            print(f"exoleg walking (full device) vs MuJoCo (walking plant only): "
                  f"{sec / walk:.1f}x faster")


if __name__ == "__main__":
    main()
