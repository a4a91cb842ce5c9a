"""The runtime: the fixed-rate loop that drives the device (or a simulated one), its
timing statistics and its crash-safe session log. Backends: ``sim`` (the simulated
device of :mod:`exoleg.world.device`, stepped in real time in process)."""
