"""The operator interface: a web page on the machine beside the device
(see :mod:`exoleg.hmi.server`)."""
