"""A device backend of your own for exoleg (docs/extending/device.md): the device worn
with some of its actuation units mounted the other way round.

exoleg's joint angles and torques follow one convention (docs/conventions.md: flexion and
dorsiflexion positive). An actuation unit mounted mirrored -- the same device moved to
the child's other leg, a motor turned to clear the cuff -- measures its angle and turns
its torque the other way. This backend sits between the loop and the device's own
backend and gives the loop exoleg's convention: each joint's reading and command times
its mounting sign (+1 as the convention, -1 mirrored). Everything else -- configuring,
the quick stop, the log -- is the device's own.
"""

import numpy as np

#: the readings that turn with a joint (the foot board's FSRs and IMU do not)
TURNING = ("q", "dq", "interaction")


class Mounted:
    """``device`` (a Device backend) with each joint's mounting ``signs`` (3,)."""

    def __init__(self, device, signs):
        signs = np.asarray(signs, dtype=float)
        if signs.shape != (3,) or not np.all(np.abs(signs) == 1.0):
            raise ValueError(f"signs: +1 or -1 per joint (hip, knee, ankle), got {signs}")
        self.device, self.signs = device, signs
        self.columns = device.columns  # the log keeps what the device itself measured

    def configure(self, limits):
        return [*self.device.configure(limits), f"mounting signs {self.signs.tolist()}"]

    def warm_up(self):
        self.device.warm_up()

    def read(self, t):
        r = dict(self.device.read(t))
        for name in TURNING:
            if name in r:
                r[name] = self.signs * np.asarray(r[name], dtype=float)
        return r

    def write(self, tau, enable):
        self.device.write(self.signs * np.asarray(tau, dtype=float), enable)

    def safe(self):
        self.device.safe()

    def deactivate(self):
        self.device.deactivate()

    def record(self):
        return self.device.record()
