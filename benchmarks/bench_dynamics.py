"""Benchmark: exoleg's dynamics against Pinocchio and MuJoCo on the same leg, same run.

Run: ``make bench`` (or ``python benchmarks/bench_dynamics.py``). Prints wall time
per evaluation and ratios.

Targets: issue 2 -- the compiled kernels, forward dynamics <= 150 ns and G <= 50 ns
per evaluation inside a compiled loop; import + paper leg <= 1 s. Issue 10 -- the
Python API per call for one state (M, C, G, forward and inverse dynamics, fk) at or
below Pinocchio's per call for the same quantity, from Python, in the same run;
batched calls as fast as before.

Per-call rows, one state, called from Python in a loop (best of 3 x 20,000 calls):

* exoleg: ``leg.M(q)``, ``leg.C(q, dq)``, ``leg.G(q)``, ``leg.forward_dynamics``,
  ``leg.inverse_dynamics``, ``leg.fk(q)`` (a dict of 7 points and the foot angle);
* Pinocchio: ``crba``, ``computeCoriolisMatrix``, ``computeGeneralizedGravity``,
  ``aba``, ``rnea``; fk as ``framesForwardKinematics`` plus reading the same points
  (joint and toe frame translations, each body's COM placed by its joint);
* MuJoCo: ``mj_fwdPosition`` + ``mj_fullM`` (M); ``mj_fwdPosition`` + ``mj_rne`` at
  zero velocity (G); ``mj_forward`` (forward dynamics); ``mj_inverse`` (inverse
  dynamics); ``mj_kinematics`` plus reading the same points (fk). MuJoCo has no
  Coriolis matrix.
"""

from __future__ import annotations

import subprocess
import sys
import time
from collections.abc import Callable

import numpy as np
from numba import njit

import exoleg
from exoleg.dynamics import kernels as K

N = 200_000
N_PY = 20_000
REPEAT = 7


@njit  # not cached: numba would keep stale code when only exoleg's kernels change
def _loop_fd(Q, DQ, T, p, g, out):  # type: ignore[no-untyped-def]
    for i in range(Q.shape[0]):
        K.forward_dynamics(Q[i], DQ[i], T[i], p, g, out[i])


@njit  # not cached: numba would keep stale code when only exoleg's kernels change
def _loop_g(Q, p, g, out):  # type: ignore[no-untyped-def]
    for i in range(Q.shape[0]):
        K.gravity(Q[i], p, g, out[i])


def best(fn: Callable[[], object], n: int, repeat: int = REPEAT) -> float:
    """Best time per evaluation (s) of ``fn`` doing ``n`` evaluations."""
    fn()
    return min(_timed(fn) for _ in range(repeat)) / n


def _timed(fn: Callable[[], object]) -> float:
    t0 = time.perf_counter()
    fn()
    return time.perf_counter() - t0


def per_call(f: Callable[[], object]) -> float:
    def loop() -> None:
        for _ in range(N_PY):
            f()
    return best(loop, N_PY, 3)


def main() -> None:
    leg = exoleg.paper_leg()
    rng = np.random.default_rng(0)
    Q, DQ, T = (rng.uniform(-3, 3, (N, 3)) for _ in range(3))
    out = np.empty((N, 3))
    compiled = {"forward dynamics": best(lambda: _loop_fd(Q, DQ, T, leg.p, leg.g, out), N),
                "G": best(lambda: _loop_g(Q, leg.p, leg.g, out), N)}
    batched = {"leg.forward_dynamics(Q, DQ, T)": best(lambda: leg.forward_dynamics(Q, DQ, T), N, 3),
               "leg.G(Q)": best(lambda: leg.G(Q), N, 3), "leg.M(Q)": best(lambda: leg.M(Q), N, 3)}
    q, dq, tau = Q[0].copy(), DQ[0].copy(), T[0].copy()
    calls: dict[str, dict[str, float]] = {
        "M": {"exoleg": per_call(lambda: leg.M(q))},
        "C": {"exoleg": per_call(lambda: leg.C(q, dq))},
        "G": {"exoleg": per_call(lambda: leg.G(q))},
        "forward dynamics": {"exoleg": per_call(lambda: leg.forward_dynamics(q, dq, tau))},
        "inverse dynamics": {"exoleg": per_call(lambda: leg.inverse_dynamics(q, dq, tau))},
        "fk (7 points + foot angle)": {"exoleg": per_call(lambda: leg.fk(q))},
    }
    try:
        import pinocchio as pin

        from exoleg.validate.engines import PinocchioLeg

        pm = PinocchioLeg(leg)
        model, data = pm.model, pm.data
        frames = [model.getFrameId(n) for n in ("hip", "knee", "ankle", "toe")]
        levers = [(j, model.inertias[j].lever) for j in (1, 2, 3)]

        def pin_fk() -> object:
            pin.framesForwardKinematics(model, data, q)
            pts = [data.oMf[f].translation for f in frames]
            pts += [data.oMi[j].act(c) for j, c in levers]
            return pts

        for key, f in (("M", lambda: pin.crba(model, data, q)),
                       ("C", lambda: pin.computeCoriolisMatrix(model, data, q, dq)),
                       ("G", lambda: pin.computeGeneralizedGravity(model, data, q)),
                       ("forward dynamics", lambda: pin.aba(model, data, q, dq, tau)),
                       ("inverse dynamics", lambda: pin.rnea(model, data, q, dq, tau)),
                       ("fk (7 points + foot angle)", pin_fk)):
            calls[key]["Pinocchio"] = per_call(f)
    except ImportError:
        print("Pinocchio not installed: skipped")
    try:
        import mujoco

        from exoleg.validate.engines import MujocoLeg

        mm = MujocoLeg(leg)
        m, d = mm.model, mm.data
        full = np.zeros((3, 3))
        res = np.zeros(3)
        bodies = [m.body(n).id for n in ("thigh", "shank", "foot")]
        toe = m.site("toe").id

        def mj_m() -> None:
            d.qpos[:] = q
            mujoco.mj_fwdPosition(m, d)
            mujoco.mj_fullM(m, d, full)

        def mj_g() -> None:
            d.qpos[:] = q
            d.qvel[:] = 0.0
            mujoco.mj_fwdPosition(m, d)
            mujoco.mj_rne(m, d, 0, res)

        def mj_fd() -> None:
            d.qpos[:], d.qvel[:], d.qfrc_applied[:] = q, dq, tau
            mujoco.mj_forward(m, d)

        def mj_id() -> None:
            d.qpos[:], d.qvel[:], d.qacc[:] = q, dq, tau
            mujoco.mj_inverse(m, d)

        def mj_fk() -> object:
            d.qpos[:] = q
            mujoco.mj_kinematics(m, d)
            return ([d.xpos[b].copy() for b in bodies] + [d.site_xpos[toe].copy()]
                    + [d.xipos[b].copy() for b in bodies])

        for key, f in (("M", mj_m), ("G", mj_g), ("forward dynamics", mj_fd),
                       ("inverse dynamics", mj_id), ("fk (7 points + foot angle)", mj_fk)):
            calls[key]["MuJoCo"] = per_call(f)
    except ImportError:
        print("MuJoCo not installed: skipped")

    print("Per call, one state, from Python (ns; ratio = other / exoleg):")
    print(f"{'quantity':<28} {'exoleg':>8} {'Pinocchio':>10} {'ratio':>6} {'MuJoCo':>8} "
          f"{'ratio':>6}  verdict (<= Pinocchio)")
    for key, row in calls.items():
        e = row["exoleg"]
        cells = []
        for who in ("Pinocchio", "MuJoCo"):
            v = row.get(who)
            cells += [f"{v * 1e9:.0f}" if v else "-", f"{v / e:.2f}" if v else "-"]
        verdict = ("meets" if e <= row["Pinocchio"] else "MISSES") if "Pinocchio" in row else "-"
        print(f"{key:<28} {e * 1e9:>8.0f} {cells[0]:>10} {cells[1]:>6} {cells[2]:>8} "
              f"{cells[3]:>6}  {verdict}")

    print("\nCompiled and batched (ns per state):")
    for k, v in compiled.items():
        target = {"forward dynamics": 150e-9, "G": 50e-9}[k]
        print(f"{k:<16} compiled loop {v * 1e9:12.1f}  (target <= {target * 1e9:.0f} ns: "
              f"{'meets' if v <= target else 'MISSES'})")
    for k, v in batched.items():
        print(f"batched {k:<31} {v * 1e9:7.1f}  ({N:,} states)")

    code = ("import time; t=time.perf_counter(); import exoleg; exoleg.paper_leg(); "
            "print(time.perf_counter()-t)")
    subprocess.run([sys.executable, "-c", code], check=True, capture_output=True)  # warm caches
    ts = [float(subprocess.run([sys.executable, "-c", code], check=True, capture_output=True,
                               text=True).stdout) for _ in range(3)]
    print(f"\nimport exoleg + paper_leg(): {min(ts):.3f} s (target <= 1 s)")


if __name__ == "__main__":
    main()
