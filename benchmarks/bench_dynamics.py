"""Benchmark: exoleg's compiled dynamics against Pinocchio and MuJoCo on the same leg, same run.

Run: ``make bench`` (or ``python benchmarks/bench_dynamics.py``). Prints wall
time per evaluation and ratios. Targets (issue 2): forward dynamics <= 150 ns
and G <= 50 ns per evaluation in the compiled path; import + paper leg <= 1 s.

* exoleg compiled: the generated kernel called inside a numba loop over
  N random states (how the simulator uses it), time / N.
* exoleg Python API: ``leg.forward_dynamics(q, dq, tau)`` per call (one state).
* Pinocchio: ``pin.aba`` / ``pin.computeGeneralizedGravity`` from Python per call.
* MuJoCo: ``mj_forward`` per call (forward dynamics; it also computes positions,
  energy is off) and ``mj_rne`` at zero velocity and acceleration for G.
"""

from __future__ import annotations

import subprocess
import sys
import time

import numpy as np
from numba import njit

import exoleg
from exoleg.dynamics import kernels as K

N = 200_000
REPEAT = 7


@njit(cache=True)
def _loop_fd(Q, DQ, T, p, g, out):  # type: ignore[no-untyped-def]
    for i in range(Q.shape[0]):
        K.forward_dynamics(Q[i], DQ[i], T[i], p, g, out[i])


@njit(cache=True)
def _loop_g(Q, p, g, out):  # type: ignore[no-untyped-def]
    for i in range(Q.shape[0]):
        K.gravity(Q[i], p, g, out[i])


def best(fn, n, repeat=REPEAT):  # type: ignore[no-untyped-def]
    fn()
    t = min(_timed(fn) for _ in range(repeat))
    return t / n


def _timed(fn):  # type: ignore[no-untyped-def]
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def main() -> None:
    leg = exoleg.paper_leg()
    rng = np.random.default_rng(0)
    Q, DQ, T = (rng.uniform(-3, 3, (N, 3)) for _ in range(3))
    out = np.empty((N, 3))
    rows: list[tuple[str, str, float]] = []
    rows.append(("forward dynamics", "exoleg compiled loop",
                 best(lambda: _loop_fd(Q, DQ, T, leg.p, leg.g, out), N)))
    rows.append(("G", "exoleg compiled loop", best(lambda: _loop_g(Q, leg.p, leg.g, out), N)))
    n_py = 20_000
    q, dq, tau = Q[0], DQ[0], T[0]

    def py_fd() -> None:
        for _ in range(n_py):
            leg.forward_dynamics(q, dq, tau)

    def py_g() -> None:
        for _ in range(n_py):
            leg.G(q)

    rows.append(("forward dynamics", "exoleg Python API", best(py_fd, n_py, 3)))
    rows.append(("G", "exoleg Python API", best(py_g, n_py, 3)))

    try:
        import pinocchio as pin

        from exoleg.validate.engines import PinocchioLeg

        pm = PinocchioLeg(leg)
        model, data = pm.model, pm.data

        def pin_fd() -> None:
            for _ in range(n_py):
                pin.aba(model, data, q, dq, tau)

        def pin_g() -> None:
            for _ in range(n_py):
                pin.computeGeneralizedGravity(model, data, q)

        rows.append(("forward dynamics", "Pinocchio aba (Python)", best(pin_fd, n_py, 3)))
        rows.append(("G", "Pinocchio computeGeneralizedGravity", best(pin_g, n_py, 3)))
    except ImportError:
        print("Pinocchio not installed: skipped")
    try:
        import mujoco

        from exoleg.validate.engines import MujocoLeg

        mm = MujocoLeg(leg)
        m, d = mm.model, mm.data
        d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, dq, tau
        res = np.zeros(3)

        def mj_fd() -> None:
            for _ in range(n_py):
                mujoco.mj_forward(m, d)

        def mj_g() -> None:
            d.qvel[:] = 0
            d.qacc[:] = 0
            for _ in range(n_py):
                mujoco.mj_rne(m, d, 0, res)

        rows.append(("forward dynamics", "MuJoCo mj_forward (Python)", best(mj_fd, n_py, 3)))
        mujoco.mj_forward(m, d)
        rows.append(("G", "MuJoCo mj_rne (Python)", best(mj_g, n_py, 3)))
    except ImportError:
        print("MuJoCo not installed: skipped")

    print(f"{'quantity':<18} {'implementation':<38} {'ns/eval':>10} {'x exoleg compiled':>18}")
    base = {k: v for k, who, v in rows if who == "exoleg compiled loop"}
    for k, who, v in rows:
        print(f"{k:<18} {who:<38} {v * 1e9:>10.1f} {v / base[k]:>18.1f}")
    targets = {"forward dynamics": 150e-9, "G": 50e-9}
    for k, t in targets.items():
        verdict = "meets" if base[k] <= t else "MISSES"
        print(f"target {k}: <= {t * 1e9:.0f} ns: {base[k] * 1e9:.1f} ns ({verdict})")

    code = ("import time; t=time.perf_counter(); import exoleg; exoleg.paper_leg(); "
            "print(time.perf_counter()-t)")
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True)  # warm caches
    ts = [float(subprocess.run([sys.executable, "-c", code], check=True, capture_output=True,
                               text=True).stdout) for _ in range(3)]
    print(f"import exoleg + paper_leg(): {min(ts):.3f} s (target <= 1 s)")


if __name__ == "__main__":
    main()
