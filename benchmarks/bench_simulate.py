"""Benchmark: the paper's 12 s scenario (12,000 RK4 steps at 1 ms, PD + gravity compensation at
1 kHz) through exoleg, MuJoCo and Pinocchio, in one run.

Run: ``python benchmarks/bench_simulate.py``. Targets: issue 3 -- exoleg's compiled path
<= 3 ms and >= 35x faster than MuJoCo in the same run; issue 10 -- ``exoleg.simulate()``
end to end within 2x of its compiled loop and >= 25x faster than MuJoCo's rollout.

* exoleg loop: the compiled closed loop alone (controller + RK4, per-step
  diagnostics off), as a batch or real-time loop would run it.
* exoleg simulate(): the public call end to end (validation, reference sampling, the
  stability and range-of-motion pre-checks, the loop); its diagnostics (energies,
  Lyapunov function, verification signal) are computed when first read, which the
  next row times as well.
* MuJoCo: ``mj_step`` with its RK4 integrator in a Python loop; the same compiled
  control law sets ``qfrc_applied`` each step.
* Pinocchio: RK4 in a Python loop with four ``pin.aba`` per step and the control
  law in numpy with ``pin.computeGeneralizedGravity``.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import numpy as np

import exoleg
from exoleg.control import PDGravity
from exoleg.reference.paper import paper_reference
from exoleg.sim.closed_loop import _run

N = 12_000
DT = 1e-3


def best(fn: Callable[[], object], repeat: int) -> float:
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
    ref = paper_reference()
    t = np.arange(N + 1) * DT
    Qr, DQr, DDQr = (np.ascontiguousarray(a) for a in ref.sample(t))
    Q, DQ, DDQ, U = (np.zeros((N + 1, 3)) for _ in range(4))
    SAT = np.zeros(N + 1, dtype=np.int64)

    def exo_loop() -> None:
        Q[0], DQ[0] = 0.0, 0.0
        _run(leg.p, leg.g, (ctrl.kind, *ctrl.law_args()), (Qr, DQr, DDQr), (DT, 1, 0, N),
             (Q, DQ, DDQ, U, SAT), (np.zeros(3), np.zeros(1, np.int64)))

    rows = [("exoleg compiled loop", best(exo_loop, 15))]
    rows.append(("exoleg simulate() end to end", best(
        lambda: exoleg.simulate(leg, ctrl, ref, 12.0, DT, q0=np.zeros(3)), 15)))
    rows.append(("  + reading every diagnostic", best(
        lambda: exoleg.simulate(leg, ctrl, ref, 12.0, DT, q0=np.zeros(3)).verification, 15)))
    q_exo = Q.copy()
    try:
        from exoleg.validate.engines import MujocoLeg

        eng = MujocoLeg(leg, timestep=DT)
        out: dict[str, np.ndarray] = {}

        def mj() -> None:
            out["q"] = eng.closed_loop(ctrl, Qr, DQr, DDQr, 1, np.zeros(3), np.zeros(3))

        rows.append(("MuJoCo mj_step loop (RK4)", best(mj, 3)))
        print(f"MuJoCo vs exoleg trajectory: max {np.degrees(np.abs(out['q'] - q_exo).max()):.1e} deg")
    except ImportError:
        print("MuJoCo not installed: skipped")
    try:
        import pinocchio as pin

        from exoleg.validate.engines import PinocchioLeg

        pm = PinocchioLeg(leg)
        model, data = pm.model, pm.data
        kp, kd = ctrl.Kp, ctrl.Kd

        def pino() -> None:
            q, v = np.zeros(3), np.zeros(3)
            for k in range(N):
                u = kp * (Qr[k] - q) - kd * v + pin.computeGeneralizedGravity(model, data, q)
                a1 = pin.aba(model, data, q, v, u)
                a2 = pin.aba(model, data, q + 0.5 * DT * v, v + 0.5 * DT * a1, u)
                a3 = pin.aba(model, data, q + 0.5 * DT * (v + 0.5 * DT * a1), v + 0.5 * DT * a2, u)
                a4 = pin.aba(model, data, q + DT * (v + 0.5 * DT * a2), v + DT * a3, u)
                q = q + DT / 6 * (v + 2 * (v + 0.5 * DT * a1) + 2 * (v + 0.5 * DT * a2)
                                  + (v + DT * a3))
                v = v + DT / 6 * (a1 + 2 * a2 + 2 * a3 + a4)

        rows.append(("Pinocchio ABA, RK4 in Python", best(pino, 2)))
    except ImportError:
        print("Pinocchio not installed: skipped")

    base = rows[0][1]
    print(f"\n{'12 s paper scenario, 12,000 steps':<34} {'wall ms':>9} {'x exoleg loop':>14}")
    for name, sec in rows:
        print(f"{name:<34} {sec * 1e3:>9.2f} {sec / base:>14.1f}")
    print(f"\ntarget: exoleg loop <= 3 ms: {base * 1e3:.2f} ms "
          f"({'meets' if base <= 3e-3 else 'MISSES'})")
    sim = dict(rows)["exoleg simulate() end to end"]
    print(f"target: simulate() <= 2x its loop: {sim / base:.2f}x "
          f"({'meets' if sim <= 2 * base else 'MISSES'})")
    for name, sec in rows:
        if name.startswith("MuJoCo"):
            print(f"target: loop >= 35x MuJoCo: {sec / base:.1f}x "
                  f"({'meets' if sec / base >= 35 else 'MISSES'})")
            print(f"target: simulate() >= 25x MuJoCo: {sec / sim:.1f}x "
                  f"({'meets' if sec / sim >= 25 else 'MISSES'})")


if __name__ == "__main__":
    main()
