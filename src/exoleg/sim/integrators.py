"""Fixed-step integrators for the leg, compiled with numba.

``rk4_step`` is the classical fourth-order Runge-Kutta step of the state
(q, dq) under a torque held constant over the step (zero-order hold), the
dynamics being :func:`exoleg.dynamics.kernels.forward_dynamics` (eq 20).
"""

from __future__ import annotations

import numpy as np
from numba import njit
from numpy.typing import NDArray

from exoleg.dynamics.kernels import forward_dynamics

F64 = NDArray[np.float64]


@njit(cache=True)
def rk4_step(q, dq, tau, p, g, h, q_out, dq_out, ddq_out, work):  # type: ignore[no-untyped-def]
    """One RK4 step of size ``h``; writes the new state and the acceleration at the start.

    All vectors have length 3; ``ddq_out`` receives ddq(q, dq, tau) at the step's start.
    ``work`` is caller-owned scratch of shape (8, 3) (no allocation per step).
    """
    k1, k2, k3, k4, qt, dqt, v2, v3 = work[0], work[1], work[2], work[3], work[4], work[5], \
        work[6], work[7]
    forward_dynamics(q, dq, tau, p, g, k1)
    for i in range(3):
        ddq_out[i] = k1[i]
        qt[i] = q[i] + 0.5 * h * dq[i]
        dqt[i] = dq[i] + 0.5 * h * k1[i]
    forward_dynamics(qt, dqt, tau, p, g, k2)
    v2[:] = dqt
    for i in range(3):
        qt[i] = q[i] + 0.5 * h * v2[i]
        dqt[i] = dq[i] + 0.5 * h * k2[i]
    forward_dynamics(qt, dqt, tau, p, g, k3)
    v3[:] = dqt
    for i in range(3):
        qt[i] = q[i] + h * v3[i]
        dqt[i] = dq[i] + h * k3[i]
    forward_dynamics(qt, dqt, tau, p, g, k4)
    for i in range(3):
        q_out[i] = q[i] + h / 6.0 * (dq[i] + 2.0 * v2[i] + 2.0 * v3[i] + dqt[i])
        dq_out[i] = dq[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i])


@njit(cache=True)
def rollout(p, g, q0, dq0, tau, h, n_steps):  # type: ignore[no-untyped-def]
    """Integrate ``n_steps`` RK4 steps under a constant torque; returns Q, DQ (n_steps+1, 3)."""
    Q = np.empty((n_steps + 1, 3))
    DQ = np.empty((n_steps + 1, 3))
    Q[0] = q0
    DQ[0] = dq0
    ddq = np.empty(3)
    work = np.empty((8, 3))
    for k in range(n_steps):
        rk4_step(Q[k], DQ[k], tau, p, g, h, Q[k + 1], DQ[k + 1], ddq, work)
    return Q, DQ
