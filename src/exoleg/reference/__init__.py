"""Joint references: anything with ``sample(t) -> (q_ref, dq_ref, ddq_ref)``, each (N, 3).

Units rad, rad/s, rad/s^2; joints ordered (hip, knee, ankle).
"""

from exoleg.reference.gait import SPEED_GROUPS, SchwartzGait2008, gait_angles, schwartz2008
from exoleg.reference.minjerk import MinJerk
from exoleg.reference.steps import Reference, Steps

__all__ = ["SPEED_GROUPS", "MinJerk", "Reference", "SchwartzGait2008", "Steps", "gait_angles",
           "schwartz2008"]
