"""The control laws, compiled: one function used by the simulator's loop and by Python callers.

``kind``: 0 plain PD, 1 PD + gravity compensation (paper eq 23), 2 computed torque.
``pc`` is the controller's own model parameter vector (it may differ from the
plant's, to study model error), ``gc`` its g. ``scale`` multiplies the torque (the
paper doubles the torque applied to its detailed model). ``limit`` holds per-joint torque
limits (inf = none); the return value says whether any joint saturated.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from exoleg.dynamics.kernels import coriolis_dq, gravity, mass_matrix

PD_KIND = 0
PD_GRAVITY_KIND = 1
COMPUTED_TORQUE_KIND = 2


@njit(cache=True)
def control_law(kind, kp, kd, pc, gc, scale, limit, q, dq, q_ref, dq_ref, ddq_ref, u, work):  # type: ignore[no-untyped-def]
    """Write the torque into ``u`` (3,); ``work`` is scratch (5, 3). Returns saturation flags
    as a bit mask (bit i set when joint i was clipped)."""
    e = work[0]
    de = work[1]
    for i in range(3):
        e[i] = q_ref[i] - q[i]
        de[i] = dq_ref[i] - dq[i]
    if kind == COMPUTED_TORQUE_KIND:
        a = work[2]
        h = work[3]
        g = work[4]
        for i in range(3):
            a[i] = ddq_ref[i] + kp[i] * e[i] + kd[i] * de[i]
        M = np.empty((3, 3))
        mass_matrix(q, pc, M)
        coriolis_dq(q, dq, pc, h)
        gravity(q, pc, gc, g)
        for i in range(3):
            u[i] = M[i, 0] * a[0] + M[i, 1] * a[1] + M[i, 2] * a[2] + h[i] + g[i]
    else:
        for i in range(3):
            u[i] = kp[i] * e[i] + kd[i] * de[i]
        if kind == PD_GRAVITY_KIND:
            g = work[4]
            gravity(q, pc, gc, g)
            for i in range(3):
                u[i] += g[i]
    mask = 0
    for i in range(3):
        u[i] *= scale
        if u[i] > limit[i]:
            u[i] = limit[i]
            mask |= 1 << i
        elif u[i] < -limit[i]:
            u[i] = -limit[i]
            mask |= 1 << i
    return mask
