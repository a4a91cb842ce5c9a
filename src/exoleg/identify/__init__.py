"""Identification of the child + device leg from the device's own sensors (issue 25):
the regressor's base parameters and the actuators' friction columns (:mod:`.base`)."""
