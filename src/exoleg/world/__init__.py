"""The simulated world: the walking plant (the leg and pelvis on the treadmill's belt,
:mod:`~exoleg.world.plant`), the treadmill's scenery (:mod:`~exoleg.world.treadmill`) and
the simulated device that senses and actuates it (:mod:`~exoleg.world.device`).

The controllers' sibling floor: neither imports the other (what a simulated device is
built with comes from the assembly, :mod:`exoleg.system.build`)."""
