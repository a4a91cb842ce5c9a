"""The simulated side of the CAN bus, for hardware in the loop: EPOS4 nodes (python-canopen
LocalNodes from the same EDS as the master's RemoteNodes) and the foot board, answering
every SYNC from a simulated device (:class:`~exoleg.hw.rig.DriveRig`). The master
(:mod:`exoleg.hw.canopen_backend`) talks to them exactly as to real nodes."""

from __future__ import annotations

import threading
from typing import Any

from exoleg.hw import cia402
from exoleg.hw.canopen_backend import (
    DRIVE_IDS,
    FOOT_FSR_COB,
    FOOT_IMU_COB,
    HEARTBEAT_MS,
    _network,
    eds_path,
)
from exoleg.hw.rig import JOINT_ORDER, DriveRig
from exoleg.hw.units import MotorData


class SimulatedRig(DriveRig):
    """The simulated drives and foot board on the CAN bus (:class:`DriveRig`): on each
    SYNC, one bus cycle, then every node sends its PDO -- the silent ones excepted (fault
    injection: ``silent`` holds joints or ``"foot"``)."""

    def __init__(self, device: Any, interface: str = "virtual", channel: str = "exoleg",
                 offsets: dict[str, int] | None = None) -> None:
        import canopen

        super().__init__(device, offsets)
        self.net = _network(interface, channel)
        self.nodes: dict[str, Any] = {}
        for j in JOINT_ORDER:
            node = canopen.LocalNode(DRIVE_IDS[j], eds_path())
            self.net.add_node(node)
            node.rpdo.read(from_od=True)
            node.tpdo.read(from_od=True)
            node.rpdo[1].subscribe()
            self.nodes[j] = node
            inputs: Any = node.sdo[0x60FD]
            inputs.raw = 0
            # configured as maxon configures a drive for the device file's motor (a real
            # drive: by its commissioning)
            m = MotorData.of(device.dev.actuators[JOINT_ORDER.index(j)])
            rated: Any = node.sdo[0x6076]
            rated.raw = m.rated_unm
            motor: Any = node.sdo[0x3001]
            for sub, value in m.subs().items():
                motor[sub].raw = value
            pos: Any = node.sdo[0x6064]
            pos.raw = self.position(JOINT_ORDER.index(j))
            # its cyclic modes expect the SYNC every period (commissioned so)
            interpolation: Any = node.sdo[0x60C2]
            interpolation[1].raw, interpolation[2].raw = cia402.interpolation_of(
                device.period)
            node.nmt.start_heartbeat(HEARTBEAT_MS)
        self.silent: set[str] = set()
        self.sent_inputs = [0, 0, 0]  # TPDO2 (0x60FD) is sent when the inputs change
        self.lock = threading.Lock()
        self.net.subscribe(0x80, self._on_sync)

    def _on_sync(self, can_id: int, data: bytes, timestamp: float) -> None:
        with self.lock:
            rps = [self.nodes[j].rpdo[1] for j in JOINT_ORDER]
            self.cycle([int(rp["Controlword"].raw) for rp in rps],
                       [int(rp["Target torque"].raw) for rp in rps])
            for i, j in enumerate(JOINT_ORDER):
                status, counts, torque = self.drive(i)
                self.nodes[j].sdo[0x6064].raw = counts  # for SDO reads (start-up)
                self.nodes[j].sdo[0x6041].raw = status
                if j in self.silent:
                    continue
                inputs = self.inputs(i)
                if inputs != self.sent_inputs[i]:  # event-driven TPDO2, before TPDO1
                    self.sent_inputs[i] = inputs
                    self.nodes[j].tpdo[2]["Digital inputs"].raw = inputs
                    self.nodes[j].tpdo[2].transmit()
                tp = self.nodes[j].tpdo[1]
                tp["Statusword"].raw = status
                tp["Position actual value"].raw = counts
                tp["Torque actual value"].raw = torque
                tp.transmit()
            if "foot" not in self.silent:
                fsr, imu = self.foot()
                self.net.send_message(FOOT_FSR_COB, fsr)
                self.net.send_message(FOOT_IMU_COB, imu)

    def fault(self, joint: str, code: int = 0x2310) -> None:
        """Inject a drive fault (default 0x2310, continuous overcurrent): the drive goes
        to Fault and sends its EMCY message."""
        with self.lock:
            super().fault(joint)
            self.nodes[joint].emcy.send(code)

    def hardware_estop(self, pressed: bool = True) -> None:
        """:meth:`DriveRig.hardware_estop`, seen by SDO at once (a start-up check) and by
        the event-driven TPDO2 at the next SYNC."""
        with self.lock:
            super().hardware_estop(pressed)
            for i, j in enumerate(JOINT_ORDER):
                self.nodes[j].sdo[0x60FD].raw = self.inputs(i)

    def close(self) -> None:
        for node in self.nodes.values():
            node.nmt.stop_heartbeat()
        self.net.disconnect()
