"""The simulated EtherCAT segment, for hardware in the loop: it stands in for
``pysoem.Master`` at the process-data level -- the slaves' identities and CoE objects,
the PDO mapping the master writes (checked), the AL states, one process-data exchange
per cycle answered from a simulated device (:class:`~exoleg.hw.rig.DriveRig`) -- so
the master (:mod:`exoleg.hw.ethercat_backend`) runs unchanged against it."""

from __future__ import annotations

import struct
import threading
from typing import Any

from exoleg.hw import cia402
from exoleg.hw.ethercat_backend import (
    DRIVE_NAME,
    FOOT_IN,
    FOOT_NAME,
    FOOT_POS,
    INIT,
    MAXON_VENDOR_ID,
    OP,
    PREOP,
    RX,
    SAFEOP,
    SLAVE_POS,
    TX,
    Emergency,
    pdo_mapping_writes,
)
from exoleg.hw.rig import JOINT_ORDER, DriveRig
from exoleg.hw.units import MotorData


class _Slave:
    """One simulated slave at the process-data level, with pysoem's slave attributes."""

    def __init__(self, name: str, man: int, n_in: int, objects: dict[tuple[int, int], bytes],
                 product: int = 0) -> None:
        self.name, self.man, self.id, self.rev = name, man, product, 0
        self.input = bytes(n_in)
        self.output = b""
        self.objects = dict(objects)        # (index, subindex) -> value
        self.sdo_log: list[tuple[int, int, bytes]] = []
        self.config_func: Any = None
        self.callbacks: list[Any] = []
        self.state = INIT
        self.al_status = 0
        self.answers = True                 # False: it drops out of the exchange

    def sdo_read(self, index: int, subindex: int, size: int = 0) -> bytes:
        if (index, subindex) not in self.objects:
            raise RuntimeError(f"SDO abort 0x06020000 (object 0x{index:04X}:{subindex} "
                               "does not exist)")
        return self.objects[index, subindex]

    def sdo_write(self, index: int, subindex: int, data: bytes) -> None:
        self.sdo_log.append((index, subindex, bytes(data)))
        if (index, subindex) in self.objects:
            self.objects[index, subindex] = bytes(data)

    def add_emergency_callback(self, callback: Any) -> None:
        self.callbacks.append(callback)


class SimulatedSegment(DriveRig):
    """Stands in for ``pysoem.Master`` on a segment of three simulated EPOS4 drives and a
    foot board around a simulated device (:class:`DriveRig`). Every exchange is one bus
    cycle. A slave goes to SAFE-OP only if the PDO mapping its master wrote is
    :func:`pdo_mapping_writes`. Fault injection: ``fault(joint, code)`` (Fault and an
    EMCY), ``silent`` (slaves out of the exchange: the working counter drops), and the
    rig's ``jump`` and ``frozen``."""

    def __init__(self, device: Any, offsets: dict[str, int] | None = None) -> None:
        super().__init__(device, offsets)
        self.slaves: list[Any] = [None] * FOOT_POS
        # the drives' cyclic modes expect the SYNC every period (commissioned so)
        value, index = cia402.interpolation_of(device.period)
        for i, j in enumerate(JOINT_ORDER):
            # configured as maxon configures a drive for the device file's motor
            m = MotorData.of(device.dev.actuators[i])
            objects = {(0x1000, 0): struct.pack("<I", cia402.SERVO_DEVICE_TYPE),
                       (0x6076, 0): struct.pack("<I", m.rated_unm),
                       (0x6060, 0): struct.pack("<b", 0),
                       (0x6064, 0): struct.pack("<i", self.position(i)),
                       (0x60FD, 0): struct.pack("<I", 0),
                       (0x6041, 0): struct.pack("<H", self.drives[j].statusword),
                       (0x6071, 0): struct.pack("<h", 0),
                       (0x607A, 0): struct.pack("<i", 0),
                       (0x60C2, 1): struct.pack("<B", value),
                       (0x60C2, 2): struct.pack("<b", index),
                       **{(0x3001, k): struct.pack(cia402.MOTOR_DATA_TYPES[k], v)
                          for k, v in m.subs().items()}}
            self.slaves[SLAVE_POS[j] - 1] = _Slave(DRIVE_NAME, MAXON_VENDOR_ID, TX.size,
                                                   objects, m.product_code)
        self.slaves[FOOT_POS - 1] = _Slave(FOOT_NAME, 0, FOOT_IN.size, {})
        self.state = INIT
        self.expected_wkc = 0
        self.silent: set[str] = set()
        self.lock = threading.Lock()
        self._answer()

    def config_init(self) -> int:
        for s in self.slaves:
            s.state = PREOP
        return len(self.slaves)

    def config_map(self) -> int:
        for k, s in enumerate(self.slaves):
            if s.config_func is not None:
                s.config_func(k + 1)
            drive = s.name == DRIVE_NAME
            ok = not drive or [w for w in s.sdo_log if w[0] in (0x1600, 0x1A00, 0x1C12,
                                                                0x1C13)] == pdo_mapping_writes()
            s.state, s.al_status = (SAFEOP, 0) if ok else (PREOP, 0x001D)  # invalid output
        self.state = SAFEOP                                                # configuration
        # SOEM's expectation: 2 per slave with outputs, 1 per slave with inputs
        self.expected_wkc = 3 * (2 + 1) + 1
        return 3 * (RX.size + TX.size) + FOOT_IN.size  # the IO map's bytes

    def state_check(self, state: int, timeout: int = 50_000) -> int:
        return min(s.state for s in self.slaves)

    def read_state(self) -> int:
        return min(s.state for s in self.slaves)

    def write_state(self) -> None:
        for s in self.slaves:
            if self.state == OP and s.state == SAFEOP:
                s.state = OP
            elif self.state < s.state:
                s.state = self.state

    def send_processdata(self, release_gil: bool | None = None) -> int:
        with self.lock:
            if self.state_check(OP) == OP:
                cws, targets = [], []
                for j in JOINT_ORDER:
                    out = self.slaves[SLAVE_POS[j] - 1].output
                    cw, target, _ = RX.unpack(out) if len(out) == RX.size else (0, 0, 0)
                    cws.append(cw)
                    targets.append(target)
                self.cycle(cws, targets)
                self._answer()
        return 1

    def _answer(self) -> None:
        for i, j in enumerate(JOINT_ORDER):
            s = self.slaves[SLAVE_POS[j] - 1]
            status, counts, torque = self.drive(i)
            s.objects[0x6064, 0] = struct.pack("<i", counts)  # for SDO reads (start-up)
            s.objects[0x60FD, 0] = struct.pack("<I", self.inputs(i))
            s.objects[0x6041, 0] = struct.pack("<H", status)
            if j not in self.silent:
                s.input = TX.pack(status, counts, torque, cia402.CST, self.inputs(i))
        if "foot" not in self.silent:
            fsr, imu = self.foot()
            self.slaves[FOOT_POS - 1].input = fsr + imu

    def receive_processdata(self, timeout: int = 2000, release_gil: bool | None = None) -> int:
        if self.state_check(SAFEOP) < SAFEOP:
            return 0
        drives = [j for j in JOINT_ORDER if j not in self.silent]
        return 3 * len(drives) + ("foot" not in self.silent)

    def fault(self, joint: str, code: int = 0x2310) -> None:
        """A drive fault (default 0x2310, continuous overcurrent) with its EMCY."""
        with self.lock:
            super().fault(joint)
            for cb in self.slaves[SLAVE_POS[joint] - 1].callbacks:
                cb(Emergency(SLAVE_POS[joint], code))

    def hardware_estop(self, pressed: bool = True) -> None:
        """:meth:`DriveRig.hardware_estop`, in the next exchange's inputs and by SDO."""
        with self.lock:
            super().hardware_estop(pressed)
            self._answer()

    def close(self) -> None:
        self.state = INIT
