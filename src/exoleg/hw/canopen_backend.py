"""The ``canopen`` backend: the three drives as CiA 402 nodes and the foot board as a CAN
node, driven over python-canopen / python-can -- on a real machine a SocketCAN interface,
in tests a virtual bus on which :class:`~exoleg.hw.canopen_sim.SimulatedRig` answers:
simulated EPOS4 nodes (``data/device/canopen/epos4_sim.eds``, the CiA 402 state machine
of :mod:`exoleg.hw.cia402`, cyclic synchronous torque by PDO on every SYNC) and a
simulated foot board, around the simulated device of :mod:`exoleg.world.device`. The
master code here is what would drive the real nodes: hardware-in-the-loop of the whole
protocol stack.

Node ids: ankle 1, knee 2, hip 3 (the paper's chain, ankle -> knee -> hip), foot board
16. Per tick the master sends each drive its RPDO1 (controlword 0x6040, target torque
0x6071 per mille of rated torque), then SYNC; each drive answers with TPDO1 (statusword
0x6041, position actual 0x6064 in encoder counts, torque actual 0x6077) and the foot board
with two frames (:data:`FOOT_FSR_COB`, :data:`FOOT_IMU_COB`). The torque commanded at a
tick acts from the next SYNC (the bus's one-cycle delay).

Foot board frames (little endian): ``0x180 + 16``: four uint16 FSR counts (heel, met1,
met5, hallux); ``0x280 + 16``: int16 gyro (mrad/s), int16 accel x, y (cm/s^2).
"""

from __future__ import annotations

import struct
import threading
import time
from importlib import resources
from typing import Any

import numpy as np
from numpy.typing import NDArray

from exoleg.errors import ParameterError
from exoleg.hw import cia402
from exoleg.hw.master import DriveMaster
from exoleg.hw.rig import FOOT_FSR, FOOT_IMU, JOINT_ORDER

F64 = NDArray[np.float64]
DRIVE_IDS = {"ankle": 1, "knee": 2, "hip": 3}
FOOT_ID = 16
#: TPDO1 of every drive, as the EDS maps it: statusword (0x6041, u16), position actual
#: (0x6064, i32, counts), torque actual (0x6077, i16, per mille), little-endian -- unpacked
#: at once each tick (three PDO variables decoded one by one cost the loop's thread more)
TPDO1_MAP = ((0x6041, 16), (0x6064, 32), (0x6077, 16))
TPDO1 = struct.Struct("<Hih")
FOOT_FSR_COB = 0x180 + FOOT_ID
FOOT_IMU_COB = 0x280 + FOOT_ID
#: the drives' heartbeat period, ms; the master calls a node lost after HEARTBEAT_LOST
#: of them without one
HEARTBEAT_MS = 50
HEARTBEAT_LOST = 3
#: so long without a heartbeat, s, is a lost node
HEARTBEAT_LOST_S = HEARTBEAT_LOST * HEARTBEAT_MS / 1000.0


def eds_path() -> str:
    return str(resources.files("exoleg").joinpath("data", "device", "canopen",
                                                  "epos4_sim.eds"))


def _network(interface: str, channel: str) -> Any:
    try:
        import canopen
    except ImportError as e:
        raise ImportError("python-canopen is needed for the canopen backend: pip install "
                          "'exoleg[hw]'") from e
    net = canopen.Network()
    try:
        net.connect(interface=interface, channel=channel, receive_own_messages=False)
    except Exception as e:  # python-can raises many kinds for a missing interface
        raise ParameterError("exoleg run", "--interface",
                             f"cannot open {interface!r} channel {channel!r}: {e}") from None
    return net


class CanopenBackend(DriveMaster):
    """The master side: ``read`` sends the pending commands and SYNC and waits for every
    node's answer (``timeout`` s: a missing PDO is held and counted, a run or a rate of
    them a fault, :meth:`~exoleg.hw.master.DriveMaster.pdo_loss`); ``write`` stages the
    torques and its enable flag the CiA 402 walk towards Operation Enabled or away from
    it."""

    def __init__(self, actuators: tuple[Any, ...], period: float = 1e-3,
                 interface: str = "virtual", channel: str = "exoleg", timeout: float = 5e-3,
                 offsets: dict[str, int] | None = None) -> None:
        import canopen

        super().__init__(actuators, period, timeout, offsets)
        self.net = _network(interface, channel)
        self.nodes: dict[str, Any] = {}
        for j in JOINT_ORDER:
            node = canopen.RemoteNode(DRIVE_IDS[j], eds_path())
            self.net.add_node(node)
            node.rpdo.read(from_od=True)
            node.tpdo.read(from_od=True)
            mapped = tuple((v.index, v.length) for v in node.tpdo[1].map)
            if mapped != TPDO1_MAP:
                raise ParameterError(f"{j} drive (node {DRIVE_IDS[j]})", "TPDO1",
                                     f"maps {[(hex(i), n) for i, n in mapped]}; the master "
                                     f"reads {[(hex(i), n) for i, n in TPDO1_MAP]}")
            node.tpdo[1].subscribe()
            node.tpdo[2].add_callback(self._on_inputs(j))  # event-driven: on a change
            node.emcy.add_callback(self.on_emcy(j))
            self.nodes[j] = node
        self.inputs = dict.fromkeys(JOINT_ORDER, 0)  # each drive's 0x60FD, last sent
        self.foot = threading.Event()
        self.net.subscribe(FOOT_FSR_COB, self._on_fsr)
        self.net.subscribe(FOOT_IMU_COB, self._on_imu)
        #: when the cyclic exchange began (the first read): a drive's silence is counted
        #: from there -- the start-up has checked every drive answers, and compiling
        #: before the clock starts may hold the interpreter longer than a heartbeat
        self.cycling: float | None = None

    def _on_inputs(self, joint: str) -> Any:
        def on(pdo: Any) -> None:
            self.inputs[joint] = int(pdo["Digital inputs"].raw)
        return on

    def _on_fsr(self, can_id: int, data: bytes, timestamp: float) -> None:
        self.fsr[:] = FOOT_FSR.unpack(bytes(data))

    def _on_imu(self, can_id: int, data: bytes, timestamp: float) -> None:
        g, ax, ay = FOOT_IMU.unpack(bytes(data))
        self.gyro = g / 1000.0
        self.accel[:] = ax / 100.0, ay / 100.0
        self.foot.set()

    def start_up(self, lower: F64, upper: F64, margin: float) -> list[str]:
        """Before any motion: every drive answers (SDO), is a CiA 402 servo drive of the
        product the device file names (0x1018), is configured for the file's motor as
        maxon configures it (0x6076 in uN m, 0x3001) and set to cyclic
        synchronous torque (0x6060 = 10) with the loop's interpolation period (0x60C2),
        idle (0x6041) and its targets defined (0x6071 = 0, 0x607A = where it is); the
        leg, read from the absolute encoders (the homing), is within its range of motion
        (``lower``/``upper`` rad, plus ``margin``).
        Raises ParameterError naming the node and what is wrong; returns what it checked."""
        def configure(j: str) -> cia402.DriveObjects:
            sdo = self.nodes[j].sdo
            sdo[0x6060].raw = cia402.CST
            counts = int(sdo[0x6064].raw)
            sdo[0x6071].raw = 0  # every target defined before Operation Enabled
            sdo[0x607A].raw = counts
            self.inputs[j] = int(sdo[0x60FD].raw)
            return cia402.DriveObjects(
                device_type=int(sdo[0x1000].raw), product_code=int(sdo[0x1018][2].raw),
                rated_unm=int(sdo[0x6076].raw), nominal_ma=int(sdo[0x3001][1].raw),
                limit_ma=int(sdo[0x3001][2].raw), pole_pairs=int(sdo[0x3001][3].raw),
                winding_ds=int(sdo[0x3001][4].raw), kt_unm_a=int(sdo[0x3001][5].raw),
                mode=int(sdo[0x6060].raw),
                counts=counts, inputs=self.inputs[j], statusword=int(sdo[0x6041].raw),
                interpolation=(int(sdo[0x60C2][1].raw), int(sdo[0x60C2][2].raw)),
                target_torque=int(sdo[0x6071].raw), target_counts=int(sdo[0x607A].raw))

        where = {j: f"{j} drive (node {DRIVE_IDS[j]})" for j in JOINT_ORDER}
        return self.check_drives(JOINT_ORDER, where, configure, lower, upper, margin)

    def safe(self) -> None:
        """Torque off now: zero torque and quick stop to every drive, with a SYNC."""
        self.tau[:] = 0.0
        self.enabled = False
        for j in JOINT_ORDER:
            rp = self.nodes[j].rpdo[1]
            rp["Controlword"].raw = cia402.QUICK_STOP_CMD
            rp["Target torque"].raw = 0
            rp.transmit()
        self.net.sync.transmit()

    def read(self, t: float) -> dict[str, Any]:
        t0 = time.perf_counter()
        for i, j in enumerate(JOINT_ORDER):
            rp = self.nodes[j].rpdo[1]
            rp["Controlword"].raw, rp["Target torque"].raw = self.command(i)
            rp.transmit()
            self.nodes[j].tpdo[1].is_received = False
        self.foot.clear()
        self.net.sync.transmit()
        fault = ""
        q = self.q_prev.copy()  # a drive's answer missing: its last held
        missing = []
        for i, j in enumerate(JOINT_ORDER):
            tp = self.nodes[j].tpdo[1]
            with tp.receive_condition:
                if not tp.is_received:
                    tp.receive_condition.wait(self.timeout)
            if not tp.is_received:
                missing.append(j)
                continue
            status, counts, torque = TPDO1.unpack(bytes(tp.data))
            state = cia402.decode(status)
            self.states[i] = state
            fault = cia402.interlock_fault(f"{j} drive (node {DRIVE_IDS[j]})",
                                           self.inputs[j])
            if not fault and state in (cia402.State.FAULT,
                                       cia402.State.FAULT_REACTION_ACTIVE):
                fault = f"the {j} drive (node {DRIVE_IDS[j]}) is in {state.name}"
            if fault:
                break
            q[i] = self.scaling[j].to_rad(counts)
            self.tau_meas[i] = self.scaling[j].to_nm(torque)
        fault = fault or self.pdo_loss(tuple(missing), {
            j: f"no PDO from the {j} drive (node {DRIVE_IDS[j]}) within "
               f"{self.timeout * 1e3:g} ms" for j in missing})
        if not fault:
            now = time.time()
            if self.cycling is None:
                self.cycling = now
            for j in JOINT_ORDER:
                last = max(self.nodes[j].nmt.timestamp or 0.0, self.cycling)
                if now - last > HEARTBEAT_LOST_S:
                    fault = (f"no heartbeat from the {j} drive (node {DRIVE_IDS[j]}) for "
                             f"{(now - last) * 1e3:.0f} ms")
                    break
        if not fault and self.emcy:
            j, err = self.emcy[0]
            fault = (f"EMCY from the {j} drive (node {DRIVE_IDS[j]}): 0x{err.code:04X} "
                     f"{err.get_desc()}")
        if not fault and not self.foot.wait(self.timeout):
            fault = f"no frame from the foot board (node {FOOT_ID}) within " \
                    f"{self.timeout * 1e3:g} ms"
        return self.sensed(q, fault, t0)

    def close(self) -> None:
        self.net.disconnect()
