"""The safety layer's watch over the cuffs' torque: the interaction reading through a
cuff's low-pass, against its limit per kg of the child, and the responses (the support
falls, a controlled stop, torque off). Compiled; :mod:`exoleg.control.safety` declares
the fields of its ``LIMITS`` and ``STATE`` records this module reads and keeps, and the
walking controller (:mod:`exoleg.control.hierarchy`), which knows the child's mass and
what a support is, calls it each tick."""

from __future__ import annotations

import math

from numba import njit

from exoleg.tick import Fault


@njit(cache=True)
def cuff_check(lim, state, cuff, mass, walking):  # type: ignore[no-untyped-def]
    """The cuffs' torque ``cuff`` (3,) N m (the interaction reading), through the cuffs'
    critically damped second-order low-pass (``cuff_read``: two first-order stages, each
    exact over a tick for a held input, from the first finite reading), against each
    joint's limit (``cuff_limit`` x the child's ``mass`` kg), while armed: beyond it,
    ``walking``, the joint's support share (``cuff_share``) falls by ``cuff_rate`` a tick
    (standing, the support holds the child up: it stays), else it comes back as fast;
    beyond it for longer than ``cuff_stop`` s the walking controller stops; beyond
    ``cuff_off`` x the limit torque off, latched (CUFF_TORQUE, with the reading and the
    level it crossed). NaN (no cuff sensor) is not watched. Returns the stage reached:
    0 within, 1 beyond the limit, 2 beyond it for too long, 3 torque off."""
    L = lim[0]
    s = state[0]
    stage = 0
    for i in range(3):
        if math.isfinite(cuff[i]):
            if not math.isfinite(s.cuff_read[1, i]):
                s.cuff_read[0, i] = s.cuff_read[1, i] = cuff[i]
            s.cuff_read[0, i] += (1.0 - L.cuff_keep) * (cuff[i] - s.cuff_read[0, i])
            s.cuff_read[1, i] += (1.0 - L.cuff_keep) * (s.cuff_read[0, i] - s.cuff_read[1, i])
        else:
            s.cuff_read[0, i] = s.cuff_read[1, i] = cuff[i]  # no sensor: not watched
        limit = L.cuff_limit[i] * mass
        c = abs(s.cuff_read[1, i])
        if s.armed and s.fault == Fault.NONE and c > limit:  # NaN is never beyond
            if walking:
                s.cuff_share[i] = max(0.0, s.cuff_share[i] - L.cuff_rate)
            s.cuff_over[i] += L.dt
            stage = max(stage, 1)
            if s.cuff_over[i] > L.cuff_stop - 0.5 * L.dt:  # so many ticks, whatever rounding
                stage = max(stage, 2)
            if c > L.cuff_off * limit:
                s.fault = Fault.CUFF_TORQUE
                s.fault_joint = i
                s.fault_value = s.cuff_read[1, i]
                s.fault_limit = math.copysign(L.cuff_off * limit, s.cuff_read[1, i])
                s.armed = False
                stage = 3
        else:
            s.cuff_share[i] = min(1.0, s.cuff_share[i] + L.cuff_rate)
            s.cuff_over[i] = 0.0
    return stage
