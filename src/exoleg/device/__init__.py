"""The device below the controller: actuators (motor, gear, drive, encoder) as data and
their compiled behaviour. The closed loop that runs them is
:func:`exoleg.sim.device_loop.simulate_device`."""

from exoleg.device.actuator import ActuatorModel, load_actuator, paper_actuators, with_actuators

__all__ = ["ActuatorModel", "load_actuator", "paper_actuators", "with_actuators"]
