"""The paper's scenario reference (section 6): the leg starts at rest in quiet standing;
the reference changes every 3 s between a stance and a swing posture, two 6 s gait cycles
(12 s). The paper prints its reference only in figures, so the postures are normative
gait's (Schwartz 2008, free speed, mean): mid-stance at 30 % of the cycle and mid-swing
at 73 % (largest knee flexion)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from exoleg.reference.gait import MID_STANCE, SchwartzGait2008
from exoleg.reference.steps import Steps

F64 = NDArray[np.float64]

STANCE_FRACTION = MID_STANCE  # mid-stance, fraction of the gait cycle (Schwartz 2008)
SWING_FRACTION = 0.73   # mid-swing: largest knee flexion
SEGMENT = 3.0           # s between reference changes (paper section 6)


def paper_postures() -> tuple[F64, F64]:
    """(stance, swing) postures (3,) rad, from Schwartz 2008 free-speed mean gait."""
    g = SchwartzGait2008()
    return g.posture_at(STANCE_FRACTION), g.posture_at(SWING_FRACTION)


def paper_reference() -> Steps:
    """Stance, swing, stance, swing, changing every 3 s from t = 0."""
    stance, swing = paper_postures()
    times = np.arange(4, dtype=np.float64) * SEGMENT
    return Steps(times=times, postures=np.stack([stance, swing, stance, swing]))
