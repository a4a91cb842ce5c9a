"""Benchmark: the device layers (issue 11) -- the controller tick and the closed loop with
actuators, encoders and the safety layer -- against MuJoCo stepping the same leg.

Run: ``python benchmarks/bench_device.py``. Targets (issue 11): the controller tick
(impedance law + safety layer) <= 2 us compiled; 60 s of the device loop >= 100x real
time on one core; MuJoCo on the same model where comparable.

* controller tick: the compiled PD + gravity compensation law and the safety layer's
  tick on measured states, in a compiled loop over 1,000,000 ticks, per tick;
* exoleg device loop: :func:`exoleg.sim.device_loop.simulate_device`, 60 s (the
  paper's step schedule repeated) at 1 kHz, one plant step per tick, end to end;
* MuJoCo: the same leg with the actuators' armature from the MJCF export, ``mj_step``
  (RK4, 1 ms) with the same compiled law setting the torque each step from Python: the
  plant and controller without the encoders, drive model and safety layer, which
  MuJoCo does not have -- so a lower bound on what it would cost.

Contacts, sensors (FSR, IMU) and gait phases are not modelled yet (see the closing note
of issue 11): the walking benchmark is not possible before them.
"""

from __future__ import annotations

import time

import numpy as np
from numba import njit

import exoleg
from exoleg.control import PDGravity
from exoleg.control.laws import law
from exoleg.control.safety import SafetyLayer, SafetyLimits, safety_step
from exoleg.device import paper_actuators, with_actuators
from exoleg.reference import Steps
from exoleg.sim.device_loop import simulate_device
from exoleg.sim.scenario import paper_reference

DURATION = 60.0
TICKS = 1_000_000


@njit(cache=True)
def _ticks(kind, kp, kd, kc, scale, limit, lim, state, Q, V, R, out):  # type: ignore[no-untyped-def]
    u = np.empty(3)
    us = np.empty(3)
    acc = 0.0
    for k in range(Q.shape[0]):
        q0, q1, q2 = Q[k, 0], Q[k, 1], Q[k, 2]
        u[0], u[1], u[2], _ = law(kind, kp, kd, kc, scale, limit, np.sin(q0), np.cos(q0),
                                  np.sin(q1), np.cos(q1), np.sin(q2), np.cos(q2), q0, q1, q2,
                                  V[k, 0], V[k, 1], V[k, 2], R[k, 0], R[k, 1], R[k, 2],
                                  0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
        safety_step(lim, state, Q[k], V[k], u, False, us)
        acc += us[0] + us[1] + us[2]
    out[0] = acc


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
    tick = best(lambda: _ticks(ctrl.kind, *ctrl.law_args(), lim.as_tuple(), layer.state, Q, V,
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
                control_law(*args, d.qpos, d.qvel, Qr[k], DQr[k], DDQr[k], u)
                d.qfrc_applied[:] = u
                mujoco.mj_step(m, d)

        sec = best(mj, 1)
        rows.append((f"MuJoCo mj_step + law, {DURATION:g} s (no drive/safety)", sec,
                     DURATION / sec))
    except ImportError:
        print("MuJoCo not installed: skipped")

    print(f"{'':<52} {'wall':>12} {'x real time':>12}")
    for name, sec, rt in rows:
        wall = f"{sec * 1e9:.0f} ns" if sec < 1e-3 else f"{sec * 1e3:.1f} ms"
        print(f"{name:<52} {wall:>12} {'' if rt is None else f'{rt:,.0f}':>12}")
    print(f"\ntarget: controller tick <= 2 us: {tick * 1e9:.0f} ns "
          f"({'meets' if tick <= 2e-6 else 'MISSES'})")
    print(f"target: device loop >= 100x real time: {DURATION / loop:,.0f}x "
          f"({'meets' if DURATION / loop >= 100 else 'MISSES'})")
    for name, sec, _ in rows:
        if name.startswith("MuJoCo"):
            print(f"exoleg device loop vs MuJoCo (plant + law only): {sec / loop:.1f}x faster")


if __name__ == "__main__":
    main()
