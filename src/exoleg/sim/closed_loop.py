"""The fixed-step closed-loop simulator: RK4 plant, sampled controller with zero-order hold."""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from exoleg.control.controllers import Controller
from exoleg.control.laws import law
from exoleg.dynamics.kernels import coefficients, diagnostics, forward_dynamics_sc
from exoleg.dynamics.model import LegModel
from exoleg.errors import ParameterError, SimulationError
from exoleg.params.records import JOINTS
from exoleg.reference.steps import Reference
from exoleg.sim.integrators import RESYNC, next_sincos, rk4_sc, sincos3

if TYPE_CHECKING:
    import pyarrow as pa

F64 = NDArray[np.float64]
log = logging.getLogger(__name__)


@njit(cache=True)
def _diagnose(p, g, kp_eff, Q, DQ, Qr, E):  # type: ignore[no-untyped-def]
    """E[k, 0..4] = kinetic, potential, Lyapunov V (eq 26), dq^T (Mdot - 2C) dq and
    dq^T Mdot dq (the size of the terms that cancel in the former) at every state k."""
    for k in range(Q.shape[0]):
        kin, pot, ver, mdq = diagnostics(Q[k], DQ[k], p, g)
        vq = 0.0
        for i in range(3):
            e = Qr[k, i] - Q[k, i]
            vq += 0.5 * kp_eff[i] * e * e
        E[k, 0], E[k, 1], E[k, 2], E[k, 3], E[k, 4] = kin, pot, kin + vq, ver, mdq


def _energies(leg: LegModel, controller: Controller, Q: F64, DQ: F64, Qr: F64) -> F64:
    """:func:`_diagnose` over a run: (N, 5)."""
    E = np.empty((len(Q), 5))
    _diagnose(leg.p, leg.g, tuple(map(float, controller.scale * controller.Kp)), Q, DQ, Qr, E)
    return E


def warm_up() -> None:
    """Compile, or load from numba's cache, the kernels a scenario needs besides the
    stepper :func:`_run`: the per-state diagnostics and the control law an engine
    comparison calls from Python. The command line does this in its second process
    while the first compiles the stepper (numba compiles on one core; cold, the two
    together take several seconds)."""
    from exoleg import paper_leg
    from exoleg.control import PDGravity
    from exoleg.control.laws import control_law

    leg = paper_leg()
    ctrl = PDGravity(leg)
    states = np.zeros((2, 3))  # the argument types simulate() and the engines pass
    _energies(leg, ctrl, states, states, states)
    z = np.zeros(3)
    control_law(ctrl.kind, *ctrl.law_args(), z, z, z, z, z, np.zeros(3))


@njit(cache=True, error_model="numpy")
def _run(p, g, kind, kp, kd, kc, scale, limit, Qr, DQr, DDQr, dt, hold,  # type: ignore[no-untyped-def]
         Q, DQ, DDQ, U, SAT, k0, k1, u, mask):
    """Integrate steps k0 .. k1-1 from the state in Q[k0], DQ[k0].

    ``kp``, ``kd``, ``limit`` and ``kc`` are tuples (passed by value). ``u`` (3,) and
    ``mask`` (1,) carry the held torque and saturation flags between calls (so a run can
    be done in chunks). Returns the index of the first non-finite state, or -1.
    """
    coef = coefficients(p, g)
    q0, q1, q2 = Q[k0, 0], Q[k0, 1], Q[k0, 2]
    v0, v1, v2 = DQ[k0, 0], DQ[k0, 1], DQ[k0, 2]
    s0, c0, s1, c1, s2, c2 = sincos3(q0, q1, q2)
    held = k0 % hold  # steps since the controller last sampled
    for k in range(k0, k1):
        if held == hold:
            held = 0
        held += 1
        if held == 1:
            u[0], u[1], u[2], mask[0] = law(
                kind, kp, kd, kc, scale, limit, s0, c0, s1, c1, s2, c2, q0, q1, q2, v0, v1, v2,
                Qr[k, 0], Qr[k, 1], Qr[k, 2], DQr[k, 0], DQr[k, 1], DQr[k, 2],
                DDQr[k, 0], DDQr[k, 1], DDQr[k, 2])
        U[k, 0], U[k, 1], U[k, 2] = u[0], u[1], u[2]
        SAT[k] = mask[0]
        qn, vn, a = rk4_sc(s0, c0, s1, c1, s2, c2, q0, q1, q2, v0, v1, v2, u[0], u[1], u[2],
                           coef, dt)
        s0, c0, s1, c1, s2, c2 = next_sincos(s0, c0, s1, c1, s2, c2, q0, q1, q2, qn, k + 1)
        q0, q1, q2 = qn
        v0, v1, v2 = vn
        Q[k + 1, 0], Q[k + 1, 1], Q[k + 1, 2] = qn
        DQ[k + 1, 0], DQ[k + 1, 1], DQ[k + 1, 2] = vn
        DDQ[k, 0], DDQ[k, 1], DDQ[k, 2] = a
        if not (np.isfinite(q0) and np.isfinite(q1) and np.isfinite(q2) and np.isfinite(v0)
                and np.isfinite(v1) and np.isfinite(v2)):
            return k + 1
    n = Q.shape[0] - 1
    if k1 == n:
        U[n, 0], U[n, 1], U[n, 2] = u[0], u[1], u[2]  # (not U[n] = u: its shape check
        SAT[n] = mask[0]                                # compiles numba's string formatting)
        DDQ[n, 0], DDQ[n, 1], DDQ[n, 2] = forward_dynamics_sc(
            s0, c0, s1, c1, s2, c2, v0, v1, v2, u[0], u[1], u[2], coef)
    return -1


@dataclass(frozen=True)
class SimResult:
    """Named time series of a run; arrays (N,) or (N, 3), joints ordered (hip, knee, ankle).

    t s; q rad; dq rad/s; ddq rad/s^2; u N m (held torque); q_ref rad; error = q_ref - q;
    kinetic, potential J; lyapunov V of eq 26 (J); verification dq^T (Mdot - 2C) dq (W) and
    verification_scale |dq^T Mdot dq| (W), the size of what cancels in it; saturated (N, 3);
    stability_margin: the largest h * lambda(M^-1 Kd) checked before the run (< 2 stable).
    """

    t: F64
    q: F64
    dq: F64
    ddq: F64
    u: F64
    q_ref: F64
    error: F64
    kinetic: F64
    potential: F64
    lyapunov: F64
    verification: F64
    verification_scale: F64
    saturated: NDArray[np.bool_]
    stability_margin: float = float("nan")

    def columns(self) -> dict[str, F64]:
        """Every series as named 1-D columns (``q_hip``, ``u_ankle``, ...), SI units, rad."""
        cols: dict[str, F64] = {"t": self.t}
        for name in ("q", "dq", "ddq", "u", "q_ref", "error", "saturated"):
            arr = getattr(self, name)
            for i, j in enumerate(JOINTS):
                cols[f"{name}_{j}"] = arr[:, i].astype(float)
        for name in ("kinetic", "potential", "lyapunov", "verification", "verification_scale"):
            cols[name] = getattr(self, name)
        return cols

    def table(self) -> pa.Table:
        """:meth:`columns` as an Arrow table."""
        import pyarrow as pa

        return pa.table(self.columns())

    def to_csv(self, path: str | Path) -> Path:
        """Write :meth:`columns` as CSV with a header line. Each number is written as the
        shortest decimal that reads back as the same float (nothing is lost)."""
        import pyarrow.csv as pcsv

        table = self.table()
        p = Path(path)
        with p.open("wb") as f:  # the header unquoted, as every CSV reader expects it
            f.write((",".join(table.column_names) + "\n").encode())
            pcsv.write_csv(table, f, pcsv.WriteOptions(include_header=False))
        return p

    def to_parquet(self, path: str | Path) -> Path:
        """Write :meth:`columns` as Parquet."""
        import pyarrow.parquet as pq

        p = Path(path)
        pq.write_table(self.table(), p)
        return p


def sampled_stability(leg: LegModel, Kd: ArrayLike, h: float, postures: ArrayLike) -> float:
    """Largest h * lambda_max(M(q)^-1 Kd) over the postures: a held velocity feedback is
    stable only while this is < 2 (``docs/conventions.md``, "Sampled control")."""
    P = np.atleast_2d(np.asarray(postures, dtype=float))
    lam = [np.max(np.real(np.linalg.eigvals(np.linalg.solve(leg.M(q), np.diag(Kd)))))
           for q in P]
    return float(h * max(lam))


def simulate(leg: LegModel, controller: Controller, reference: Reference, duration: float,
             dt: float = 1e-3, q0: ArrayLike | None = None, dq0: ArrayLike | None = None,
             control_dt: float | None = None,
             progress: Callable[[float], None] | None = None) -> SimResult:
    """Simulate the closed loop for ``duration`` s with RK4 steps of ``dt`` s.

    The controller runs every ``control_dt`` s (default ``dt``, i.e. 1 kHz at 1 ms; it
    must be a whole multiple of ``dt``) and its torque is held in between. q0, dq0
    default to the reference's first posture at rest. Raises
    :class:`~exoleg.errors.SimulationError` naming the time and joint if the state
    stops being finite, and refuses gains the sampled loop cannot keep stable
    (h * lambda >= 2). ``progress``, if given, is called with the fraction done
    (the run is then done in about 100 chunks; the result is the same bit for bit).
    """
    for nm, v in (("duration", duration), ("dt", dt)):
        if not (np.isfinite(v) and v > 0):
            raise ParameterError("simulate", nm, f"must be a finite time > 0 s, got {v!r}")
    cdt = dt if control_dt is None else control_dt
    hold = int(round(cdt / dt))
    if hold < 1 or abs(hold * dt - cdt) > 1e-9 * cdt:
        raise ParameterError("simulate", "control_dt",
                             f"must be a whole multiple of dt = {dt} s, got {cdt!r}")
    n = int(round(duration / dt))
    t: F64 = (np.arange(n + 1) * dt).astype(np.float64)
    Qr, DQr, DDQr = (np.ascontiguousarray(a, dtype=np.float64) for a in reference.sample(t))
    for name, arr in (("q_ref", Qr), ("dq_ref", DQr), ("ddq_ref", DDQr)):
        if arr.shape != (n + 1, 3):
            raise ParameterError("simulate", "reference",
                                 f"sample(t) returned {name} of shape {arr.shape}, expected "
                                 f"({n + 1}, 3)")
        nonfinite = np.argwhere(~np.isfinite(arr))
        if len(nonfinite):
            ks, js = int(nonfinite[0][0]), int(nonfinite[0][1])
            raise ParameterError("simulate", "reference",
                                 f"{name} is not finite at t = {t[ks]:.6g} s ({JOINTS[js]}): "
                                 f"{arr[ks, js]}; references must be finite numbers")
    q_init = Qr[0].copy() if q0 is None else np.asarray(q0, dtype=float)
    dq_init = np.zeros(3) if dq0 is None else np.asarray(dq0, dtype=float)
    for name, vec in (("q0", q_init), ("dq0", dq_init)):
        if vec.shape != (3,) or not np.all(np.isfinite(vec)):
            raise ParameterError("simulate", name, f"expected 3 finite values, got {vec!r}")
    # the stability margin depends on the posture: check the start and ~200 reference samples
    postures = np.vstack([q_init, Qr[:: max(1, len(Qr) // 200)]])
    margin = sampled_stability(leg, controller.scale * controller.Kd, hold * dt, postures)
    if margin >= 2.0:
        raise ParameterError("simulate", "Kd/control_dt",
                             f"h * lambda(M^-1 Kd) = {margin:.3f} >= 2: the sampled loop is "
                             f"unstable; largest stable control step {2 * hold * dt / margin:.2e} s")
    if margin > 1.8:
        log.warning("sampled loop near its stability edge: h * lambda = %.3f (limit 2)", margin)
    Q, DQ, DDQ, U = (np.empty((n + 1, 3)) for _ in range(4))
    SAT = np.zeros(n + 1, dtype=np.int64)
    Q[0], DQ[0] = q_init, dq_init
    u, mask = np.zeros(3), np.zeros(1, dtype=np.int64)
    # chunks start where the stepper re-anchors its carried sin/cos anyway, so a run with
    # progress reports is bit for bit the run without
    chunk = n if progress is None else RESYNC * max(1, n // (100 * RESYNC))
    bad = -1
    for k0 in range(0, n, chunk):
        k1 = min(n, k0 + chunk)
        bad = _run(leg.p, leg.g, controller.kind, *controller.law_args(), Qr, DQr, DDQr, dt,
                   hold, Q, DQ, DDQ, U, SAT, k0, k1, u, mask)
        if progress is not None:
            progress(k1 / n)
        if bad >= 0:
            break
    if bad >= 0:
        j = [JOINTS[i] for i in range(3) if not (np.isfinite(Q[bad, i]) and np.isfinite(DQ[bad, i]))]
        raise SimulationError(f"state became non-finite at t = {t[bad]:.6g} s ({', '.join(j)})")
    E = _energies(leg, controller, Q, DQ, Qr)
    err = Qr - Q
    sat = ((SAT[:, None] >> np.arange(3)) & 1).astype(bool)
    return SimResult(t=t, q=Q, dq=DQ, ddq=DDQ, u=U, q_ref=Qr, error=err, kinetic=E[:, 0],
                     potential=E[:, 1], lyapunov=E[:, 2], verification=E[:, 3],
                     verification_scale=np.abs(E[:, 4]), saturated=sat,
                     stability_margin=margin)
