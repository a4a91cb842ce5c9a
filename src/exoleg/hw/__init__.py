"""Hardware: what the transports (CANopen, EtherCAT) share, written once -- the CiA 402
drive state machine (:mod:`exoleg.hw.cia402`) and the unit conversions between the
joint's SI units and the drive's counts and per-mille torque (:mod:`exoleg.hw.units`)."""
