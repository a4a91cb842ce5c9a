"""The fixed-step closed-loop simulator: RK4 plant, sampled controller with zero-order hold."""

from __future__ import annotations

import logging
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from exoleg.control.controllers import Controller
from exoleg.control.laws import control_law
from exoleg.dynamics.kernels import forward_dynamics
from exoleg.dynamics.model import LegModel
from exoleg.errors import ParameterError, SimulationError
from exoleg.params.records import JOINTS
from exoleg.reference.steps import Reference
from exoleg.sim.integrators import rk4_step

F64 = NDArray[np.float64]
log = logging.getLogger(__name__)


@njit(cache=True)
def _run(p, g, kind, kp, kd, pc, gc, limit, Qr, DQr, DDQr, q0, dq0, dt, hold,  # type: ignore[no-untyped-def]
         Q, DQ, DDQ, U, SAT):
    """Integrate len(Q)-1 steps; returns the index of the first non-finite state, or -1."""
    Q[0] = q0
    DQ[0] = dq0
    work = np.empty((8, 3))
    cwork = np.empty((5, 3))
    u = np.zeros(3)
    mask = 0
    n = Q.shape[0] - 1
    for k in range(n):
        if k % hold == 0:
            mask = control_law(kind, kp, kd, pc, gc, limit, Q[k], DQ[k], Qr[k], DQr[k], DDQr[k],
                               u, cwork)
        U[k] = u
        SAT[k] = mask
        rk4_step(Q[k], DQ[k], u, p, g, dt, Q[k + 1], DQ[k + 1], DDQ[k], work)
        for i in range(3):
            if not (np.isfinite(Q[k + 1, i]) and np.isfinite(DQ[k + 1, i])):
                return k + 1
    U[n] = u
    SAT[n] = mask
    forward_dynamics(Q[n], DQ[n], u, p, g, DDQ[n])
    return -1


@dataclass(frozen=True)
class SimResult:
    """Named time series of a run; arrays (N,) or (N, 3), joints ordered (hip, knee, ankle).

    t s; q rad; dq rad/s; ddq rad/s^2; u N m (held torque); q_ref rad; error = q_ref - q;
    kinetic, potential J; lyapunov V of eq 26 (J); verification dq^T (Mdot - 2C) dq (W);
    saturated (N, 3) bool.
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
    saturated: NDArray[np.bool_]

    def to_csv(self, path: str | Path) -> Path:
        """Write every series as columns (angles in rad) with a header line."""
        cols = {"t": self.t[:, None]}
        for name in ("q", "dq", "ddq", "u", "q_ref", "error", "saturated"):
            cols.update({name: getattr(self, name)})
        for name in ("kinetic", "potential", "lyapunov", "verification"):
            cols[name] = getattr(self, name)[:, None]
        header, data = [], []
        for name, arr in cols.items():
            if arr.shape[1] == 3:
                header += [f"{name}_{j}" for j in JOINTS]
            else:
                header.append(name)
            data.append(arr.astype(float))
        p = Path(path)
        np.savetxt(p, np.hstack(data), delimiter=",", header=",".join(header), comments="",
                   fmt="%.17g")
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
             control_dt: float | None = None) -> SimResult:
    """Simulate the closed loop for ``duration`` s with RK4 steps of ``dt`` s.

    The controller runs every ``control_dt`` s (default ``dt``, i.e. 1 kHz at 1 ms; it
    must be a whole multiple of ``dt``) and its torque is held in between. q0, dq0
    default to the reference's first posture at rest. Raises
    :class:`~exoleg.errors.SimulationError` naming the time and joint if the state
    stops being finite, and refuses gains the sampled loop cannot keep stable
    (h * lambda >= 2).
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
    t = np.arange(n + 1) * dt
    Qr, DQr, DDQr = (np.ascontiguousarray(a) for a in reference.sample(t))
    q_init = Qr[0].copy() if q0 is None else np.asarray(q0, dtype=float)
    dq_init = np.zeros(3) if dq0 is None else np.asarray(dq0, dtype=float)
    for nm, v in (("q0", q_init), ("dq0", dq_init)):
        if v.shape != (3,) or not np.all(np.isfinite(v)):
            raise ParameterError("simulate", nm, f"expected 3 finite values, got {v!r}")
    postures = np.vstack([q_init, np.unique(Qr, axis=0)])
    margin = sampled_stability(leg, controller.Kd, hold * dt, postures)
    if margin >= 2.0:
        raise ParameterError("simulate", "Kd/control_dt",
                             f"h * lambda(M^-1 Kd) = {margin:.3f} >= 2: the sampled loop is "
                             f"unstable; largest stable control step {2 * hold * dt / margin:.2e} s")
    if margin > 1.8:
        log.warning("sampled loop near its stability edge: h * lambda = %.3f (limit 2)", margin)
    Q, DQ, DDQ, U = (np.empty((n + 1, 3)) for _ in range(4))
    SAT = np.zeros(n + 1, dtype=np.int64)
    pc, gc = controller.model_params()
    bad = _run(leg.p, leg.g, controller.kind, controller.Kp, controller.Kd, pc, gc,
               controller.saturation, Qr, DQr, DDQr, q_init, dq_init, dt, hold, Q, DQ, DDQ, U, SAT)
    if bad >= 0:
        j = [JOINTS[i] for i in range(3) if not (np.isfinite(Q[bad, i]) and np.isfinite(DQ[bad, i]))]
        raise SimulationError(f"state became non-finite at t = {t[bad]:.6g} s ({', '.join(j)})")
    err = Qr - Q
    T = leg.kinetic_energy(Q, DQ)
    V = 0.5 * np.einsum("ni,ni->n", DQ, np.einsum("nij,nj->ni", leg.M(Q), DQ)) + 0.5 * np.einsum(
        "ni,i,ni->n", err, controller.Kp, err)
    N = leg.Mdot(Q, DQ) - 2 * leg.C(Q, DQ)
    verification = np.einsum("ni,nij,nj->n", DQ, N, DQ)
    sat = ((SAT[:, None] >> np.arange(3)) & 1).astype(bool)
    return SimResult(t=t, q=Q, dq=DQ, ddq=DDQ, u=U, q_ref=Qr, error=err, kinetic=T,
                     potential=leg.potential_energy(Q), lyapunov=V, verification=verification,
                     saturated=sat)
