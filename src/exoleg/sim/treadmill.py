"""Moved to :mod:`exoleg.world.treadmill` (the simulated world's floor); this path
re-exports it for one release."""

from exoleg.world.treadmill import (  # noqa: F401
    belt_speed_for,
    hip_height,
    other_leg_support,
)
