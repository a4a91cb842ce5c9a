"""The treadmill's scenery around the simulated device: the belt's speed matched to the
normative gait, and the other leg -- an actor, not a model -- holding the pelvis up while
this leg swings (see :func:`other_leg_support`)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from exoleg.device.ground import check_landing
from exoleg.dynamics.model import LegModel

F64 = NDArray[np.float64]


def belt_speed_for(leg: LegModel, speed: str, stride_time: float,
                   gait: F64 | None = None) -> float:
    """The belt speed that matches the normative gait's stance -- or ``gait``'s, a gait
    cycle q (samples, 3) over fractions 0-1 of the cycle: the ankle's mean backward speed
    relative to the hip between 15 % and 45 % of the cycle (mid-stance), m/s."""
    from exoleg.reference.gait import SchwartzGait2008

    x = np.linspace(0.15, 0.45, 61)
    t = x * stride_time
    if gait is None:
        q = SchwartzGait2008(stride_time=stride_time, speed=speed, upright=True).sample(t)[0]
    else:
        q = _cycle_at(gait, x)
    ankle = leg.fk(q)["ankle"][:, 0]
    return float(max(0.0, -(ankle[-1] - ankle[0]) / (t[-1] - t[0])))


def _cycle_at(gait: F64, x: F64) -> F64:
    """A gait cycle's q (samples over fractions 0-1, 3) at fractions ``x``, linearly."""
    grid = np.linspace(0.0, 1.0, len(gait))
    return np.stack([np.interp(x, grid, gait[:, j]) for j in range(3)], axis=1)


def hip_height(leg: LegModel, q: F64, sole: F64) -> F64:
    """Height of the hip above the belt for postures q (N, 3) with the lowest of the
    sole's points ``sole`` (n, 2: foot frame, m; :attr:`WalkingPlant.points`) on it, m."""
    fk = leg.fk(q)
    phi = fk["phi"]
    low = np.min([fk["ankle"][:, 1] + np.sin(phi) * px + np.cos(phi) * py
                  for px, py in sole], axis=0)
    return -low


#: This leg's swing, as fractions of its cycle (Schwartz 2008: toe off near 60 %),
#: during which the other leg holds the pelvis high enough for it to clear the belt.
SWING = (0.58, 0.95)
#: Where ``handover`` starts tapering the clearance to none by the cycle's end (exoleg's
#: choice: the toe's least clearance over the belt comes before, near mid-swing).
TAPER_FROM = 0.8


def other_leg_support(leg: LegModel, sole: F64, speed: str, clearance: float,
                      carry: float = 0.01, samples: int = 201, gait: F64 | None = None,
                      swing_from: float = SWING[0], landing: str = "drop") -> F64:
    """The other leg's support height over this leg's cycle (samples,), m.

    The other leg is an actor, not a model: while this leg swings (``swing_from`` to
    :data:`SWING`'s end) it holds the pelvis where this leg's swing posture -- the
    normative gait's, or ``gait``'s (a cycle's q over fractions 0-1) -- clears the belt
    by ``clearance`` (what a child's pelvis and other leg do, by rising and hip hiking:
    fixed at the hip's x, the joint angles alone would scuff the toe); through this leg's
    stance it stays ``carry`` below this leg's stance height, so this leg carries the
    body. ``landing`` (:data:`~exoleg.device.ground.LANDINGS`): how it lets the pelvis down
    onto this leg."""
    from exoleg.reference.gait import SchwartzGait2008, cycle_event

    check_landing("other_leg_support", landing)
    x = np.linspace(0.0, 1.0, samples)
    q = (SchwartzGait2008(stride_time=1.0, speed=speed, upright=True).sample(x)[0]
         if gait is None else _cycle_at(gait, x))
    hh = hip_height(leg, q, sole)
    if landing == "drop":
        swing = (x >= swing_from) & (x <= SWING[1])
        h = np.where(swing, np.max(hh[swing]) + clearance, hh - carry)
    else:
        # through the swing as high as the rest of it needs, the clearance tapered to
        # none: the heel reaches the belt with the pelvis at this leg's own height there
        rest = np.maximum.accumulate(hh[::-1])[::-1]
        taper = np.clip((1.0 - x) / (1.0 - TAPER_FROM), 0.0, 1.0)
        h = np.where(x >= swing_from, rest + clearance * taper, hh - carry)
        # then down to the stance's support over the double support
        double = cycle_event("Opposite Foot Off", speed)[0]
        early = x < double
        h[early] = hh[-1] + (hh[early] - carry - hh[-1]) * (x[early] / double)
    k = max(1, samples // 40)  # smoothed over 5 % of the cycle, circularly
    pad = np.concatenate([h[-k:], h, h[:k]])
    return np.convolve(pad, np.ones(2 * k + 1) / (2 * k + 1), mode="same")[k:-k]
