"""Batched closed-loop runs: many legs at once, in parallel, keeping only per-joint peaks.

Used for population studies: each leg follows the same reference under PD + gravity
compensation (paper eq 23, the controller using the leg's own model) with RK4 at a
fixed step; the torque, speed and power peaks are recorded from step ``start`` on.
"""

from __future__ import annotations

import numpy as np
from numba import njit, prange
from numpy.typing import NDArray

from exoleg.control.laws import Law, law
from exoleg.dynamics.kernels import coefficients
from exoleg.errors import SimulationError
from exoleg.sim.integrators import next_sincos, rk4_sc, sincos3

F64 = NDArray[np.float64]


@njit(cache=True, error_model="numpy")
def _one(p, g, gains, ref, dt, start, out, limit):  # type: ignore[no-untyped-def]
    """One leg ``p``: the paper's PD + gravity of ``gains`` (Kp, Kd) following ``ref``
    (Qr, DQr, from its first state (q_init, dq_init)); writes its peaks from step
    ``start`` into out (3, 3); NaN if the state became non-finite."""
    kp, kd = gains
    Qr, DQr, q_init, dq_init = ref
    k_leg = coefficients(p, g)
    q0, q1, q2 = q_init[0], q_init[1], q_init[2]
    v0, v1, v2 = dq_init[0], dq_init[1], dq_init[2]
    s0, c0, s1, c1, s2, c2 = sincos3(q0, q1, q2)
    # peaks in locals (stores into ``out`` at every step would be kept in memory)
    t0 = t1 = t2 = w0 = w1 = w2 = e0 = e1 = e2 = 0.0
    for k in range(Qr.shape[0] - 1):
        u0, u1, u2, _ = law((Law.PD_GRAVITY, kp, kd, k_leg, 1.0, limit),
                            (s0, c0, s1, c1, s2, c2), (q0, q1, q2), (v0, v1, v2),
                            (Qr[k, 0], Qr[k, 1], Qr[k, 2]), (DQr[k, 0], DQr[k, 1], DQr[k, 2]),
                            (0.0, 0.0, 0.0))
        if k >= start:
            t0, t1, t2 = max(t0, abs(u0)), max(t1, abs(u1)), max(t2, abs(u2))
            w0, w1, w2 = max(w0, abs(v0)), max(w1, abs(v1)), max(w2, abs(v2))
            e0, e1, e2 = max(e0, abs(u0 * v0)), max(e1, abs(u1 * v1)), max(e2, abs(u2 * v2))
        qn, vn, _ = rk4_sc((s0, c0, s1, c1, s2, c2), (q0, q1, q2), (v0, v1, v2), (u0, u1, u2),
                           k_leg, dt)
        s0, c0, s1, c1, s2, c2 = next_sincos((s0, c0, s1, c1, s2, c2), (q0, q1, q2), qn, k + 1)
        q0, q1, q2 = qn
        v0, v1, v2 = vn
        if not (np.isfinite(q0) and np.isfinite(q1) and np.isfinite(q2)):
            out[:, :] = np.nan
            return
    out[0, 0], out[0, 1], out[0, 2] = t0, t1, t2
    out[1, 0], out[1, 1], out[1, 2] = w0, w1, w2
    out[2, 0], out[2, 1], out[2, 2] = e0, e1, e2


@njit(parallel=True, cache=True)
def _batch(P, g, gains, ref, dt, start):  # type: ignore[no-untyped-def]
    """Every leg of ``P`` (n, 18) as :func:`_one`, in parallel: peaks (n, 3, 3).
    ``gains``: (Kp, Kd) tuples; ``ref``: (2, N, 3) the reference's angles and rates, from
    its first sample. (Arrays, not a tuple of them: numba's parallel loop takes none.)"""
    n = P.shape[0]
    out = np.zeros((n, 3, 3))  # [leg, (torque, speed, power), joint]
    limit = (np.inf, np.inf, np.inf)
    kp, kd = gains
    Qr, DQr = ref[0], ref[1]
    for c in prange(n):
        _one(P[c], g, (kp, kd), (Qr, DQr, Qr[0], DQr[0]), dt, start, out[c], limit)
    return out


def batch_gait_peaks(P: F64, g: float, kp: F64, kd: F64, q_ref: F64, dq_ref: F64, dt: float,
                     start: int = 0) -> F64:
    """Peaks (n, 3, 3): [leg, (abs(torque) N m, abs(speed) rad/s, abs(power) W), joint] of n legs
    (parameter vectors ``P`` (n, 18)) tracking ``q_ref``, ``dq_ref`` (N, 3) sampled every
    ``dt`` s, from the reference's first state; peaks from step ``start`` on."""
    P = np.ascontiguousarray(P, dtype=np.float64)
    out = _batch(P, float(g), (tuple(map(float, kp)), tuple(map(float, kd))),
                 np.ascontiguousarray(np.stack([q_ref, dq_ref]), dtype=np.float64), float(dt),
                 int(start))
    bad = np.flatnonzero(np.isnan(out[:, 0, 0]))
    if len(bad):
        raise SimulationError(f"batch run: legs {bad.tolist()[:10]} became non-finite")
    return out
