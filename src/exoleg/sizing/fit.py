"""Device fit: telescope settings that put the device's joints on the child's, and the verdict.

The upper telescope sets the hip-knee joint-centre distance (Table 1: 27-40 cm); the
lower telescope the knee axis to the sole (33-46 cm), i.e. the knee-ankle distance plus
the ankle height: Table 4's SLE shank link is 32.02 cm joint to joint, below the 33 cm
minimum, so the lower range cannot be a joint-to-joint length, while 32.02 cm plus an
ankle height lies inside it. The footplate is 23.5 cm long. A child fits when both
settings lie within their ranges and the foot is not longer than the footplate.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

from exoleg.params import paper
from exoleg.params.paper import device
from exoleg.sizing.anthropometry import (
    Dimensions,
    LegLengthMethod,
    estimate_dimensions,
    table1_estimate,
)
from exoleg.sizing.child import Child


@dataclass(frozen=True)
class Miss:
    """Where the device does not fit.

    Parameters
    ----------
    what : str
        The part (e.g. the lower telescope).
    child : float
        The child's value, m.
    allowed : (float, float)
        The device's range, m.
    by : float
        By how much, m: > 0 the child is larger than the device allows, < 0 smaller.
    """

    what: str
    child: float
    allowed: tuple[float, float]
    by: float


@dataclass(frozen=True)
class DeviceFit:
    """The verdict for one child.

    Parameters
    ----------
    fits : bool
        True when nothing misses.
    upper, lower : float
        The hip-knee and knee-to-sole telescope settings, m (the child's values, clipped to
        the device's range when outside).
    link_lengths : (float, float, float)
        The model's joint-to-joint lengths (hip-knee, knee-ankle, footplate), m.
    dimensions : Dimensions
        The child's dimensions used.
    misses : list of Miss
        What does not fit, by how much.
    paper_rule : dict
        The paper's own check -- Table 1 leg length (by its rule) against the device's
        60-86 cm -- for comparison.
    range_of_motion : dict
        The device's limits (rad) and the child's normative gait range (Schwartz 2008
        free speed, mean +- 2 SD; rad) per joint.
    """

    fits: bool
    upper: float
    lower: float
    link_lengths: tuple[float, float, float]
    dimensions: Dimensions
    misses: list[Miss] = field(default_factory=list)
    paper_rule: dict[str, Any] = field(default_factory=dict)
    range_of_motion: dict[str, Any] = field(default_factory=dict)


def _gait_rom() -> tuple[np.ndarray, np.ndarray]:
    """Per-joint range of normative gait, mean +- 2 SD (Schwartz 2008, free speed), rad."""
    from exoleg.reference.gait import gait_angles

    curves = np.stack([gait_angles("Free", k)[1] for k in (-2.0, 2.0)])  # (2, 51, 3)
    return curves.min(axis=(0, 1)), curves.max(axis=(0, 1))


def fit_device(child: Child, leg_length_method: LegLengthMethod = "linear") -> DeviceFit:
    """Telescope settings and the fit verdict for ``child``.

    Parameters
    ----------
    child : Child
        The child (measured values used as given).
    leg_length_method : {"linear", "drillis", "table1"}, default "linear"
        How the clinical leg length is estimated when not measured.

    Returns
    -------
    DeviceFit
    """
    d = estimate_dimensions(child, leg_length_method)
    dev = device()
    misses = []
    settings = []
    for what, value, rng in (("upper telescope (hip-knee)", d.thigh, dev["upper_range_m"]),
                             ("lower telescope (knee-sole)", d.shank + d.ankle_height,
                              dev["lower_range_m"])):
        lo, hi = float(rng[0]), float(rng[1])
        settings.append(min(max(value, lo), hi))
        if value < lo or value > hi:
            misses.append(Miss(what, value, (lo, hi), value - (hi if value > hi else lo)))
    plate = float(dev["footplate_length_m"])
    if d.foot_length > plate:
        misses.append(Miss("footplate (foot length)", d.foot_length, (0.0, plate),
                           d.foot_length - plate))
    t1 = paper.sizing()
    ll_t1, fl_t1 = table1_estimate(child.height, child.sex)
    lo_ll, hi_ll = (v / 100 for v in t1["device"]["leg_length_cm"])
    rom = paper.range_of_motion()
    g_lo, g_hi = _gait_rom()
    return DeviceFit(
        fits=not misses, upper=settings[0], lower=settings[1],
        link_lengths=(settings[0], settings[1] - d.ankle_height, plate), dimensions=d,
        misses=misses,
        paper_rule={"leg_length": ll_t1, "foot_length": fl_t1,
                    "device_leg_length": (lo_ll, hi_ll),
                    "fits": bool(lo_ll <= ll_t1 <= hi_ll and fl_t1 <= plate)},
        range_of_motion={"device_lower": rom.lower, "device_upper": rom.upper,
                         "gait_lower": g_lo, "gait_upper": g_hi,
                         "gait_within_device": bool(np.all(g_lo >= rom.lower)
                                                    and np.all(g_hi <= rom.upper))})
