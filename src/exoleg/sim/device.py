"""Moved to :mod:`exoleg.world.device` (the simulated world's floor); this path re-exports
it for one release. What the simulated device is built with is
:func:`exoleg.system.build.build`'s."""

from exoleg.world.device import (  # noqa: F401
    DEVICE,
    SimulatedDevice,
    device_actuate,
    device_sense,
    device_state,
)
