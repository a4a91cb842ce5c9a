"""The simulated drives and foot board around a simulated device, for every transport: the
CAN rig (:class:`exoleg.hw.canopen_backend.SimulatedRig`) and the EtherCAT segment
(:class:`exoleg.hw.ethercat_backend.SimulatedSegment`) put this on their bus. One
:meth:`DriveRig.cycle` is one bus cycle: the drives' CiA 402 state machines take their
controlwords, the torques of the drives in Operation Enabled act on the plant for one
tick, and the sensors are read for the answers. Fault injection lives here too, so it is
the same on both buses."""

from __future__ import annotations

import struct
from typing import Any

import numpy as np

from exoleg.hw import cia402
from exoleg.hw.units import JointScaling

#: the drives in the order of the controller's joint vectors
JOINT_ORDER = ("hip", "knee", "ankle")
#: foot board data: four uint16 FSR counts (heel, met1, met5, hallux); int16 gyro
#: (mrad/s), int16 accel x, y (cm/s^2) -- little endian
FOOT_FSR = struct.Struct("<4H")
FOOT_IMU = struct.Struct("<3h")


class DriveRig:
    """``cycle(controlwords, targets)``, then ``drive(i)`` and ``foot()`` for the answers.

    Fault injection: ``fault(joint)`` puts a drive in Fault; ``jump`` (rad) adds to the
    encoders' readings; ``frozen`` makes the foot board repeat its last data;
    ``hardware_estop(pressed)`` opens the E-stop chain (every drive's STO and interlock
    input)."""

    def __init__(self, device: Any, offsets: dict[str, int] | None = None) -> None:
        self.dev = device  # a SimBackend: the plant, its sensors and its drives' model
        self.drives = {j: cia402.Drive() for j in JOINT_ORDER}
        self.scaling = {j: JointScaling.of(device.dev.actuators[i], (offsets or {}).get(j, 0))
                        for i, j in enumerate(JOINT_ORDER)}
        self.jump = np.zeros(3)
        self.frozen = False
        self.sensors = device.read(0.0)  # the device as it starts
        self._foot: tuple[bytes, bytes] | None = None

    def cycle(self, controlwords: list[int], targets: list[int]) -> None:
        tau = np.zeros(3)
        for i, j in enumerate(JOINT_ORDER):
            d = self.drives[j]
            d.controlword(int(controlwords[i]))
            if d.torque_allowed:
                tau[i] = self.scaling[j].to_nm(int(targets[i]))
        dev = self.dev
        dev.write(tau, True)  # the drives' own state machines gate the torque
        self.sensors = dev.read((dev.k + 1) * dev.period)

    def position(self, i: int) -> int:
        """Drive ``i``'s position actual value (0x6064), encoder counts."""
        j = JOINT_ORDER[i]
        return self.scaling[j].to_counts(float(self.sensors["q"][i] + self.jump[i]))

    def drive(self, i: int) -> tuple[int, int, int]:
        """Drive ``i``'s answer: statusword, position actual (counts), torque actual
        (0x6077, per mille): the torque the drive controls -- its motor's (from the
        current) for a rigid unit, the measured joint torque (the deflection's encoder
        times the stiffness, or the torque sensor) its torque loop closes on for a
        compliant one."""
        j = JOINT_ORDER[i]
        return (self.drives[j].statusword, self.position(i),
                self.scaling[j].to_per_mille(float(self.dev.S[0]["joint_torque"][i])))

    def foot(self) -> tuple[bytes, bytes]:
        """The foot board's FSR and IMU data (:data:`FOOT_FSR`, :data:`FOOT_IMU`)."""
        if not self.frozen or self._foot is None:
            s = self.sensors
            c = np.clip(np.round(s["fsr"]), 0, 65535).astype(int)
            g = int(np.clip(round(1000 * s["gyro"]), -32768, 32767))
            a = np.clip(np.round(100 * np.asarray(s["accel"])), -32768, 32767).astype(int)
            self._foot = (FOOT_FSR.pack(*c), FOOT_IMU.pack(g, *a))
        return self._foot

    def fault(self, joint: str) -> None:
        self.drives[joint].fault()

    def hardware_estop(self, pressed: bool = True) -> None:
        """The hardware E-stop pressed (or released): the chain opens every drive's STO
        input -- no torque from the next cycle, whatever the master commands -- and its
        monitoring contact reads in each drive's interlock input (0x60FD)."""
        for d in self.drives.values():
            d.sto = bool(pressed)

    def inputs(self, i: int) -> int:
        """Drive ``i``'s digital inputs (0x60FD)."""
        return self.drives[JOINT_ORDER[i]].digital_inputs

