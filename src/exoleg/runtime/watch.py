"""The loop's watch on what the safety layer cannot see in the values themselves: a
frozen foot board and an implausible jump of a joint reading."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from exoleg.device.sensors import FROZEN_S

F64 = NDArray[np.float64]


#: A joint reading is implausible when it moves more than this far in one tick, rad (0.1
#: rad in 1 ms is 5700 deg/s, eight times the fastest joint of Table 2). (A frozen foot
#: board: :data:`~exoleg.device.sensors.FROZEN_S`.)
JUMP_RAD = 0.1
def frozen_text(ticks: int) -> str:
    """A frozen foot board, said."""
    return f"the foot board's readings froze for {ticks} ticks"


def jump_text(joint: int, jump: float) -> str:
    """An implausible joint reading, said."""
    return (f"implausible joint reading: joint {joint} moved {jump:.3g} rad in one tick "
            f"(at most {JUMP_RAD} rad)")


class SensorWatch:
    """Faults the safety layer cannot see in the values themselves: a frozen sensor and
    an implausible jump of a joint reading (a bad encoder frame, a wrong offset)."""

    def __init__(self, period: float) -> None:
        self.limit = max(1, int(round(FROZEN_S / period)))
        self.same = 0
        self.last: F64 | None = None
        self.q_last: F64 | None = None

    def check(self, sensors: dict[str, Any]) -> str:
        foot = np.concatenate([np.asarray(sensors["fsr"], dtype=float),
                               [float(sensors.get("gyro", 0.0))]])
        if self.last is not None and np.array_equal(foot, self.last):
            self.same += 1
            if self.same >= self.limit:
                return frozen_text(self.same)
        else:
            self.same = 0
        self.last = foot
        q = np.asarray(sensors["q"], dtype=float)
        if self.q_last is not None:
            jump = np.abs(q - self.q_last)
            if np.any(jump > JUMP_RAD):
                i = int(np.argmax(jump))
                return jump_text(i, float(jump[i]))
        self.q_last = q
        return ""
