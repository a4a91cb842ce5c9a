"""The ``ethercat`` backend: the same CiA 402 logic as the ``canopen`` backend
(:mod:`exoleg.hw.cia402`, :mod:`exoleg.hw.units`) over CANopen-over-EtherCAT, with pysoem
(SOEM) as the master -- the paper's arrangement (§2.4: EPOS4 drives chained on EtherCAT,
the foot sensors and IMU bridged into it).

The segment, in the paper's chain order: slave 1 the ankle drive, 2 the knee, 3 the hip,
4 the foot board. Before SAFE-OP the master writes each drive's PDO mapping by CoE SDO
(:data:`RX_MAP`, :data:`TX_MAP`), so the process data below is a contract, not an
assumption about the drive's defaults:

* drive outputs (RxPDO 0x1600, 5 bytes): controlword 0x6040 u16, target torque 0x6071
  i16 (per mille of rated torque), modes of operation 0x6060 i8;
* drive inputs (TxPDO 0x1A00, 13 bytes): statusword 0x6041 u16, position actual 0x6064
  i32 (counts), torque actual 0x6077 i16, modes of operation display 0x6061 i8, digital
  inputs 0x60FD u32 (bit 3, the interlock: the hardware E-stop chain, whose STO takes
  the drives' torque off in hardware -- the master stops within the tick it reads it);
* foot board inputs (14 bytes): four uint16 FSR counts and three int16 IMU values, the
  layout of the CAN frames (:mod:`exoleg.hw.rig`).

Per tick: outputs written, one ``send_processdata``/``receive_processdata`` exchange; a
working counter below the expected one (a slave silent, or out of OP), a drive in Fault
or an EMCY is a fault. The torque commanded at a tick acts from the next exchange. EMCY
messages come with mailbox traffic (SOEM reads them there); the statusword's Fault state,
in the process data, is the check every tick.

Without a network interface and the drives, nothing here can reach real hardware: the
tests (and ``--interface fake``) stop at the process-data level, with
:class:`~exoleg.hw.ethercat_sim.SimulatedSegment` standing in for ``pysoem.Master`` -- it
records the SDO writes and checks the PDO mapping the master wrote against the layout
above, and answers the exchanges from the simulated device
(:class:`exoleg.hw.rig.DriveRig`). What it cannot show: the EPOS4's own object
dictionary, distributed clocks, real bus timing.
"""

from __future__ import annotations

import struct
import time
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from exoleg.errors import ParameterError
from exoleg.hw import cia402
from exoleg.hw.master import DriveMaster
from exoleg.hw.rig import JOINT_ORDER

F64 = NDArray[np.float64]
#: EtherCAT application-layer states (ETG.1000.6)
INIT, PREOP, SAFEOP, OP = 1, 2, 4, 8
#: position on the segment (1-based, the paper's chain ankle -> knee -> hip), foot last
SLAVE_POS = {"ankle": 1, "knee": 2, "hip": 3}
FOOT_POS = 4
#: maxon's EtherCAT vendor id and the name its EPOS4 drives report (check against the
#: ESI file of your drives)
MAXON_VENDOR_ID = 0x000000FB
DRIVE_NAME = "EPOS4"
FOOT_NAME = "exoleg foot board"
RX = struct.Struct("<Hhb")
TX = struct.Struct("<HihbI")
FOOT_IN = struct.Struct("<4H3h")
#: PDO mapping entries (index << 16 | subindex << 8 | bits)
RX_MAP = (0x60400010, 0x60710010, 0x60600008)
TX_MAP = (0x60410010, 0x60640020, 0x60770010, 0x60610008, 0x60FD0020)


def pdo_mapping_writes() -> list[tuple[int, int, bytes]]:
    """The CoE SDO writes (index, subindex, data) that map a drive's PDOs: each mapping
    object cleared, its entries written, its count set; then the sync managers' PDO
    assignment (0x1C12 outputs -> 0x1600, 0x1C13 inputs -> 0x1A00)."""
    w: list[tuple[int, int, bytes]] = []
    for obj, entries in ((0x1600, RX_MAP), (0x1A00, TX_MAP)):
        w.append((obj, 0, bytes([0])))
        w += [(obj, k + 1, struct.pack("<I", e)) for k, e in enumerate(entries)]
        w.append((obj, 0, bytes([len(entries)])))
    for sm, obj in ((0x1C12, 0x1600), (0x1C13, 0x1A00)):
        w += [(sm, 0, bytes([0])), (sm, 1, struct.pack("<H", obj)), (sm, 0, bytes([1]))]
    return w


def _open_master(interface: str) -> Any:
    try:
        import pysoem
    except ImportError as e:
        raise ImportError("pysoem is needed for the ethercat backend: pip install "
                          "'exoleg[hw]'") from e
    master = pysoem.Master()
    try:
        master.open(interface)
    except Exception as e:  # pysoem raises ConnectionError for a missing interface
        raise ParameterError("exoleg run", "--interface",
                             f"cannot open {interface!r} for EtherCAT: {e} (it needs a "
                             "network interface wired to the drives, and raw-socket "
                             "permission: root or CAP_NET_RAW)") from None
    return master


class EthercatBackend(DriveMaster):
    """The master side, the same interface as the canopen backend: ``start_up`` brings
    the segment to OP after checking every slave, ``read`` exchanges one cycle of
    process data, ``write`` stages the torques and the CiA 402 walk.
    ``master``: a ``pysoem.Master``-like object to use (a :class:`SimulatedSegment`);
    without one, pysoem opens ``interface``."""

    def __init__(self, actuators: tuple[Any, ...], period: float = 1e-3,
                 interface: str = "eth0", master: Any = None, timeout: float = 5e-3,
                 offsets: dict[str, int] | None = None) -> None:
        super().__init__(actuators, period, timeout, offsets)
        self.master = master if master is not None else _open_master(interface)
        self.slaves: dict[str, Any] = {}
        self.foot_slave: Any = None

    def start_up(self, lower: F64, upper: F64, margin: float) -> list[str]:
        """Discover the segment (four slaves: three EPOS4 drives, the foot board, in the
        chain's order), check every drive as the canopen backend does
        (:func:`cia402.check_drive`: device type, rated torque, cyclic synchronous
        torque, the interpolation period, idle, the targets defined, homing within the
        range of motion), map the PDOs, and bring the segment
        to OP -- the drives stay in Switch On Disabled until the operator arms. Raises
        ParameterError naming the slave and what is wrong; returns what it checked."""
        m = self.master
        n = m.config_init()
        if n != FOOT_POS:
            raise ParameterError("EtherCAT segment", "(start-up)", f"{n} slaves found; the "
                                 f"device has {FOOT_POS} (ankle, knee, hip drives, foot "
                                 "board): check the cabling")
        where = {j: f"{j} drive (slave {SLAVE_POS[j]})" for j in JOINT_ORDER}

        def configure(j: str) -> cia402.DriveObjects:
            s = m.slaves[SLAVE_POS[j] - 1]
            if s.man != MAXON_VENDOR_ID or DRIVE_NAME not in s.name:
                raise ParameterError(where[j], "(identity)", f"is {s.name!r} of vendor "
                                     f"0x{s.man:08X}, not a maxon {DRIVE_NAME}: check the "
                                     "chain's order")
            s.sdo_write(0x6060, 0, struct.pack("<b", cia402.CST))

            def sdo(index: int, sub: int, f: str) -> int:
                return int(struct.unpack(f, s.sdo_read(index, sub, struct.calcsize(f)))[0])

            def motor(sub: int) -> int:  # the motor data, 0x3001, in its sub's type
                return sdo(0x3001, sub, cia402.MOTOR_DATA_TYPES[sub])

            counts = sdo(0x6064, 0, "<i")
            s.sdo_write(0x6071, 0, struct.pack("<h", 0))  # every target defined first
            s.sdo_write(0x607A, 0, struct.pack("<i", counts))
            read = cia402.DriveObjects(
                device_type=sdo(0x1000, 0, "<I"), product_code=int(s.id),
                rated_unm=sdo(0x6076, 0, "<I"), nominal_ma=motor(1), limit_ma=motor(2),
                pole_pairs=motor(3), winding_ds=motor(4), kt_unm_a=motor(5),
                mode=sdo(0x6060, 0, "<b"),
                counts=counts, inputs=sdo(0x60FD, 0, "<I"),
                statusword=sdo(0x6041, 0, "<H"),
                interpolation=(sdo(0x60C2, 1, "<B"), sdo(0x60C2, 2, "<b")),
                target_torque=sdo(0x6071, 0, "<h"), target_counts=sdo(0x607A, 0, "<i"))
            s.config_func = self._mapper(s)
            s.add_emergency_callback(self.on_emcy(j))
            self.slaves[j] = s
            return read

        along = tuple(sorted(JOINT_ORDER, key=SLAVE_POS.__getitem__))  # the segment's order
        done = self.check_drives(along, where, configure, lower, upper, margin)
        self.foot_slave = m.slaves[FOOT_POS - 1]
        if FOOT_NAME not in self.foot_slave.name:
            raise ParameterError(f"slave {FOOT_POS}", "(identity)",
                                 f"is {self.foot_slave.name!r}, not the {FOOT_NAME}")
        m.config_map()
        if m.state_check(SAFEOP, 50_000) != SAFEOP:
            raise ParameterError("EtherCAT segment", "(start-up)", "did not reach SAFE-OP: "
                                 + self._al_status())
        m.state = OP
        m.send_processdata()       # valid outputs (Switch On Disabled, no torque) before OP
        m.receive_processdata(2000)
        m.write_state()
        if m.state_check(OP, 50_000) != OP:
            raise ParameterError("EtherCAT segment", "(start-up)", "did not reach OP: "
                                 + self._al_status())
        done.append(f"EtherCAT segment in OP, expected working counter {m.expected_wkc}")
        return done

    def _mapper(self, slave: Any) -> Any:
        def config(_pos: int) -> None:
            for index, sub, data in pdo_mapping_writes():
                slave.sdo_write(index, sub, data)
        return config

    def _al_status(self) -> str:
        self.master.read_state()
        bad = [f"slave {k + 1} in state {s.state} (AL status 0x{s.al_status:04X})"
               for k, s in enumerate(self.master.slaves) if s.state != self.master.state]
        return "; ".join(bad) or "no slave reports why"

    def _exchange(self) -> int:
        # the wire's wait without the interpreter lock (pysoem >= 1.1.13): the console's
        # and the log's Python threads run meanwhile, and do not hold up the exchange
        self.master.send_processdata(release_gil=True)
        return int(self.master.receive_processdata(int(self.timeout * 1e6), release_gil=True))

    def safe(self) -> None:
        """Torque off now: zero torque and quick stop to every drive, in one exchange."""
        self.tau[:] = 0.0
        self.enabled = False
        for j in JOINT_ORDER:
            self.slaves[j].output = RX.pack(cia402.QUICK_STOP_CMD, 0, cia402.CST)
        self._exchange()

    def read(self, t: float) -> dict[str, Any]:
        t0 = time.perf_counter()
        for i, j in enumerate(JOINT_ORDER):
            self.slaves[j].output = RX.pack(*self.command(i), cia402.CST)
        wkc = self._exchange()
        fault = ""
        q = self.q_prev.copy()
        if wkc < self.master.expected_wkc:  # which slave is not known: counted for all
            fault = self.pdo_loss(JOINT_ORDER, dict.fromkeys(
                JOINT_ORDER, f"EtherCAT working counter {wkc}, expected "
                             f"{self.master.expected_wkc}: a slave did not answer the "
                             "process data"))
        else:
            self.pdo_loss((), {})
            for i, j in enumerate(JOINT_ORDER):
                status, counts, torque, _, inputs = TX.unpack(bytes(self.slaves[j].input))
                state = cia402.decode(status)
                self.states[i] = state
                fault = fault or cia402.interlock_fault(
                    f"{j} drive (slave {SLAVE_POS[j]})", inputs)
                if state in (cia402.State.FAULT, cia402.State.FAULT_REACTION_ACTIVE):
                    fault = fault or (f"the {j} drive (slave {SLAVE_POS[j]}) is in "
                                      f"{state.name}")
                q[i] = self.scaling[j].to_rad(counts)
                self.tau_meas[i] = self.scaling[j].to_nm(torque)
            v = FOOT_IN.unpack(bytes(self.foot_slave.input))
            self.fsr[:] = v[:4]
            self.gyro = v[4] / 1000.0
            self.accel[:] = v[5] / 100.0, v[6] / 100.0
        if not fault and self.emcy:
            j, msg = self.emcy[0]
            fault = (f"EMCY from the {j} drive (slave {SLAVE_POS[j]}): "
                     f"0x{msg.error_code:04X}")
        return self.sensed(q, fault, t0)

    def close(self) -> None:
        """Segment to INIT (the drives' outputs stop, the drives' fault reaction takes
        the torque off), interface closed."""
        m = self.master
        try:
            m.state = INIT
            m.write_state()
        finally:
            m.close()


@dataclass
class Emergency:
    """An EMCY as pysoem hands it to the callback (the fields the master reads)."""

    slave_pos: int
    error_code: int
    error_reg: int = 0
