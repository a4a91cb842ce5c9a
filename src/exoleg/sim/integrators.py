"""Fixed-step integrators for the leg, compiled with numba.

``rk4_sc`` is the classical fourth-order Runge-Kutta step of the state (q, dq)
under a torque held constant over the step (zero-order hold), the dynamics being
the generated forward dynamics (eq 20); ``next_sincos`` carries the joint angles'
sin/cos from step to step; ``rollout`` is the passive (constant-torque) loop.
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from exoleg.dynamics.kernels import coefficients, forward_dynamics_sc

F64 = NDArray[np.float64]


# sin and cos of an angle increment |d| <= 0.1 rad come from their Taylor series, which
# is exact to double precision there and much cheaper than libm; the coefficients are
# multiplications (a division per term, the divider being slow and not pipelined, cost
# more than the rest of the step's trig). Increments of a 1 ms step are mostly below
# 0.008 rad (8 rad/s, 460 deg/s), where a shorter series is as exact.
_SMALL, _TINY = 0.1, 0.008
_S3, _S5, _S7, _S9, _S11 = -1 / 6, 1 / 120, -1 / 5040, 1 / 362880, -1 / 39916800
_C2, _C4, _C6, _C8, _C10, _C12 = -1 / 2, 1 / 24, -1 / 720, 1 / 40320, -1 / 3628800, 1 / 479001600


@njit(cache=True, error_model="numpy")
def _sincos_small(d):  # type: ignore[no-untyped-def]
    """(sin d, cos d). Truncation error: for |d| <= 0.008, Taylor to d^5 / d^6, below
    d^7/7! = 4.2e-19 and d^8/8! = 4.2e-22; for |d| <= 0.1, to d^11 / d^12, below 1e-22;
    beyond, libm."""
    z = d * d
    if abs(d) <= _TINY:
        return d + d * z * (_S3 + z * _S5), 1.0 + z * (_C2 + z * (_C4 + z * _C6))
    if abs(d) > _SMALL:
        return math.sin(d), math.cos(d)
    sn = d + d * z * (_S3 + z * (_S5 + z * (_S7 + z * (_S9 + z * _S11))))
    cs = 1.0 + z * (_C2 + z * (_C4 + z * (_C6 + z * (_C8 + z * (_C10 + z * _C12)))))
    return sn, cs


@njit(cache=True)
def _shift(s, c, d):  # type: ignore[no-untyped-def]
    """(sin(x + d), cos(x + d)) from s = sin x, c = cos x."""
    sd, cd = _sincos_small(d)
    return s * cd + c * sd, c * cd - s * sd


#: A loop that carries sin/cos of the joint angles from step to step (:func:`next_sincos`)
#: takes them from libm at every RESYNC-th step, so their rounding cannot accumulate.
RESYNC = 16


@njit(inline="always", cache=True)
def sincos3(q0, q1, q2):  # type: ignore[no-untyped-def]
    """(sin q0, cos q0, sin q1, cos q1, sin q2, cos q2) from libm."""
    return math.sin(q0), math.cos(q0), math.sin(q1), math.cos(q1), math.sin(q2), math.cos(q2)


@njit(cache=True)
def next_sincos(sc, q, qn, k):  # type: ignore[no-untyped-def]
    """:func:`sincos3` of the joint angles ``qn`` (a 3-tuple) after step k, given ``sc`` =
    (s0, c0, s1, c1, s2, c2), the sin, cos of ``q`` (a 3-tuple) before it: by angle
    addition of the increments qn_i - q_i (a few roundings, no libm call), except at every
    :data:`RESYNC`-th step, where libm re-anchors them."""
    s0, c0, s1, c1, s2, c2 = sc
    q0, q1, q2 = q
    if k % RESYNC == 0:
        return sincos3(qn[0], qn[1], qn[2])
    u0, w0 = _shift(s0, c0, qn[0] - q0)
    u1, w1 = _shift(s1, c1, qn[1] - q1)
    u2, w2 = _shift(s2, c2, qn[2] - q2)
    return u0, w0, u1, w1, u2, w2


@njit(inline="always", cache=True, error_model="numpy")
def rk4_sc(sc, q, v, t, k, h):  # type: ignore[no-untyped-def]
    """One RK4 step on scalars; returns (q', dq', ddq at the start), each a 3-tuple.

    ``q``, ``v``, ``t``: the angles, rates and the torque held over the step (3-tuples);
    ``sc`` = (s0, c0, s1, c1, s2, c2), sin, cos of q_i (a caller that needs them too, e.g.
    for G in the control law, computes them once, or carries them by
    :func:`next_sincos`); ``k`` the leg's coefficients
    (:func:`exoleg.dynamics.kernels.coefficients`, a tuple).

    Scalars and tuples only, so nothing is allocated or reference-counted. Stages 2-4
    evaluate at angles q + c x (x the previous stage's velocity, c = h/2, h/2, h); their
    sin/cos follow by angle addition from sin/cos of the small increment, so libm is not
    called. The stages are a loop, so the compiler inlines the dynamics once, not thrice.
    """
    s0, c0, s1, c1, s2, c2 = sc
    q0, q1, q2 = q
    v0, v1, v2 = v
    t0, t1, t2 = t
    a0, a1, a2 = forward_dynamics_sc(sc, v, t, k)
    x0, x1, x2 = v0, v1, v2  # the previous stage's velocity (x) and acceleration (y)
    y0, y1, y2 = a0, a1, a2
    sq0, sq1, sq2 = v0, v1, v2  # weighted sums of the stages' velocities, accelerations
    sv0, sv1, sv2 = a0, a1, a2
    for stage in range(3):
        c, wt = (0.5 * h, 2.0) if stage < 2 else (h, 1.0)  # step fraction, RK4 weight
        u0, w0 = _shift(s0, c0, c * x0)
        u1, w1 = _shift(s1, c1, c * x1)
        u2, w2 = _shift(s2, c2, c * x2)
        x0, x1, x2 = v0 + c * y0, v1 + c * y1, v2 + c * y2
        y0, y1, y2 = forward_dynamics_sc((u0, w0, u1, w1, u2, w2), (x0, x1, x2), t, k)
        sq0, sq1, sq2 = sq0 + wt * x0, sq1 + wt * x1, sq2 + wt * x2
        sv0, sv1, sv2 = sv0 + wt * y0, sv1 + wt * y1, sv2 + wt * y2
    s = h / 6.0
    qn = (q0 + s * sq0, q1 + s * sq1, q2 + s * sq2)
    vn = (v0 + s * sv0, v1 + s * sv1, v2 + s * sv2)
    return qn, vn, (a0, a1, a2)


@njit(cache=True)
def rollout(p, g, q0, dq0, tau, h, n_steps):  # type: ignore[no-untyped-def]
    """Integrate ``n_steps`` RK4 steps under a constant torque; returns Q, DQ (n_steps+1, 3)."""
    Q = np.empty((n_steps + 1, 3))
    DQ = np.empty((n_steps + 1, 3))
    Q[0] = q0
    DQ[0] = dq0
    q0_, q1_, q2_ = Q[0, 0], Q[0, 1], Q[0, 2]
    v0_, v1_, v2_ = DQ[0, 0], DQ[0, 1], DQ[0, 2]
    t0_, t1_, t2_ = tau[0], tau[1], tau[2]
    coef = coefficients(p, g)
    s0, c0, s1, c1, s2, c2 = sincos3(q0_, q1_, q2_)
    for k in range(n_steps):
        qn, vn, _ = rk4_sc((s0, c0, s1, c1, s2, c2), (q0_, q1_, q2_), (v0_, v1_, v2_),
                           (t0_, t1_, t2_), coef, h)
        s0, c0, s1, c1, s2, c2 = next_sincos((s0, c0, s1, c1, s2, c2), (q0_, q1_, q2_), qn,
                                             k + 1)
        q0_, q1_, q2_ = qn
        v0_, v1_, v2_ = vn
        Q[k + 1, 0], Q[k + 1, 1], Q[k + 1, 2] = qn
        DQ[k + 1, 0], DQ[k + 1, 1], DQ[k + 1, 2] = vn
    return Q, DQ
