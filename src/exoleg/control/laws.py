"""The control laws, compiled: one implementation for the simulator's loop and for Python callers.

``kind`` (:class:`Law`): plain PD, PD + gravity compensation (paper eq 23), computed
torque.
``kc`` holds the coefficients of the controller's own model
(:func:`exoleg.dynamics.kernels.coefficients` of its parameters and g; it may
differ from the plant's, to study model error). ``scale`` multiplies the torque
(the paper doubles the torque applied to its detailed model). ``limit`` holds
per-joint torque limits (inf = none). Each law returns the saturation flags as a
bit mask (bit i set when joint i was clipped).
"""

from __future__ import annotations

import math
from enum import IntEnum

from numba import njit

from exoleg.dynamics.kernels import gravity_sc, inverse_dynamics_sc


class Law(IntEnum):
    """Which law a :class:`~exoleg.control.controllers.Controller` record runs."""

    PD = 0
    PD_GRAVITY = 1
    COMPUTED_TORQUE = 2


@njit(inline="always", cache=True)
def _clip(u, limit):  # type: ignore[no-untyped-def]
    """(u clipped to +-limit, 1 if clipped else 0)."""
    if u > limit:
        return limit, 1
    if u < -limit:
        return -limit, 1
    return u, 0


@njit(inline="always", cache=True)
def law(c, sc, q, v, r, w, a):  # type: ignore[no-untyped-def]
    """Any law on scalars (each argument a tuple, inlined: nothing is built at run time):
    ``c`` the law (kind, Kp, Kd, model coefficients, scale, saturation: a controller's
    ``kind`` and :meth:`~exoleg.control.controllers.Controller.law_args`); the state q, v
    (3 each) with ``sc`` = (s0, c0, s1, c1, s2, c2), the sines and cosines of q; the
    reference r, its rate w and acceleration a (3 each). Returns (u0, u1, u2, mask).

    PD: Kp (r - q) + Kd (w - v); PD + gravity compensation adds G(q); computed torque
    is M(q) (a + Kp (r - q) + Kd (w - v)) + C(q, v) v + G(q)."""
    kind, kp, kd, kc, scale, limit = c
    s0, c0, s1, c1, s2, c2 = sc
    q0, q1, q2 = q
    v0, v1, v2 = v
    r0, r1, r2 = r
    w0, w1, w2 = w
    a0, a1, a2 = a
    u0 = kp[0] * (r0 - q0) + kd[0] * (w0 - v0)
    u1 = kp[1] * (r1 - q1) + kd[1] * (w1 - v1)
    u2 = kp[2] * (r2 - q2) + kd[2] * (w2 - v2)
    if kind == Law.PD_GRAVITY:
        g0, g1, g2 = gravity_sc(s0, c0, s1, c1, s2, c2, kc)
        u0 += g0
        u1 += g1
        u2 += g2
    elif kind == Law.COMPUTED_TORQUE:
        u0, u1, u2 = inverse_dynamics_sc((s0, c0, s1, c1, s2, c2), (v0, v1, v2),
                                         (a0 + u0, a1 + u1, a2 + u2), kc)
    u0, m0 = _clip(scale * u0, limit[0])
    u1, m1 = _clip(scale * u1, limit[1])
    u2, m2 = _clip(scale * u2, limit[2])
    return u0, u1, u2, m0 | (m1 << 1) | (m2 << 2)


@njit(cache=True)
def control_law(params, q, dq, ref, u):  # type: ignore[no-untyped-def]
    """:func:`law` on arrays (3,): ``params`` its record (kind, kp, kd, kc, scale,
    limit), ``ref`` the reference (q_ref, dq_ref, ddq_ref); writes the torque into ``u``;
    returns the saturation mask."""
    q_ref, dq_ref, ddq_ref = ref
    u[0], u[1], u[2], mask = law(
        params,
        (math.sin(q[0]), math.cos(q[0]), math.sin(q[1]), math.cos(q[1]), math.sin(q[2]),
         math.cos(q[2])), (q[0], q[1], q[2]), (dq[0], dq[1], dq[2]),
        (q_ref[0], q_ref[1], q_ref[2]), (dq_ref[0], dq_ref[1], dq_ref[2]),
        (ddq_ref[0], ddq_ref[1], ddq_ref[2]))
    return mask
