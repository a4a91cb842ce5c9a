"""The treadmill's scenery around the simulated device: the belt's speed matched to the
normative gait, and the other leg -- an actor, not a model -- holding the pelvis up while
this leg swings (see :func:`other_leg_support`)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from exoleg.dynamics.model import LegModel

F64 = NDArray[np.float64]


def belt_speed_for(leg: LegModel, speed: str, stride_time: float) -> float:
    """The belt speed that matches the normative gait's stance: the ankle's mean backward
    speed relative to the hip between 15 % and 45 % of the cycle (mid-stance), m/s."""
    from exoleg.reference.gait import SchwartzGait2008

    gait = SchwartzGait2008(stride_time=stride_time, speed=speed, upright=True)
    t = np.linspace(0.15, 0.45, 61) * stride_time
    ankle = leg.fk(gait.sample(t)[0])["ankle"][:, 0]
    return float(max(0.0, -(ankle[-1] - ankle[0]) / (t[-1] - t[0])))


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


def other_leg_support(leg: LegModel, sole: F64, speed: str, clearance: float,
                      carry: float = 0.01, samples: int = 201) -> F64:
    """The other leg's support height over this leg's cycle (samples,), m.

    The other leg is an actor, not a model: while this leg swings it holds the pelvis
    where this leg's normative swing posture clears the belt by ``clearance`` (what a
    child's pelvis and other leg do, by rising and hip hiking: fixed at the hip's x, the
    normative joint angles alone would scuff the toe); through this leg's stance it
    stays ``carry`` below this leg's stance height, so this leg carries the body."""
    from exoleg.reference.gait import SchwartzGait2008

    gait = SchwartzGait2008(stride_time=1.0, speed=speed, upright=True)
    x = np.linspace(0.0, 1.0, samples)
    hh = hip_height(leg, gait.sample(x)[0], sole)
    swing = (x >= SWING[0]) & (x <= SWING[1])
    h = np.where(swing, np.max(hh[swing]) + clearance, hh - carry)
    k = max(1, samples // 40)  # smoothed over 5 % of the cycle, circularly
    pad = np.concatenate([h[-k:], h, h[:k]])
    return np.convolve(pad, np.ones(2 * k + 1) / (2 * k + 1), mode="same")[k:-k]
