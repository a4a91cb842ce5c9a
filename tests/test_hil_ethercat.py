"""The ethercat backend at the process-data level: the real master code (exoleg's
EthercatBackend, written against pysoem's Master/slave interface) against a simulated
segment -- without a network interface and EPOS4 drives, nothing closer to the hardware
can run here. References: the CiA 402 objects' indexes and sizes (0x6040 u16, 0x6071
i16, 0x6060 i8, 0x6041 u16, 0x6064 i32, 0x6077 i16, 0x6061 i8), the ETG's PDO mapping
and assignment objects (0x1600, 0x1A00, 0x1C12, 0x1C13) and the CiA 402 transitions."""

from __future__ import annotations

import struct
from pathlib import Path

import numpy as np
import pytest

from conftest import BUS_WAIT, REALTIME
from exoleg.errors import ParameterError
from exoleg.hw import cia402
from exoleg.hw.master import LOSS_RUN
from exoleg.runtime.session import run
from exoleg.session_log import read_log

ENABLED = cia402.State.OPERATION_ENABLED.value[1]


def hil(duration: float, folder: Path, **kw):  # type: ignore[no-untyped-def]
    return run("ethercat", duration, folder, realtime=REALTIME, bus_timeout=BUS_WAIT, **kw)


def test_mapping_arming_walking_and_torque_over_process_data(tmp_path: Path) -> None:
    seen: dict[str, object] = {}

    def inject(k: int, rig) -> None:  # type: ignore[no-untyped-def]
        seen["rig"] = rig
        if k == 100:
            seen["al"] = [s.state for s in rig.slaves]

    res, path = hil(2.0, tmp_path, arm=True, walk_after=1.0, inject=inject)
    assert res.stopped_by.startswith("duration, after a controlled stop to STANDING")
    rig = seen["rig"]
    # the PDO mapping each drive received, against the CiA 402 objects written out here
    rx = [0x6040_00_10, 0x6071_00_10, 0x6060_00_08]
    # + digital inputs (0x60FD u32: the E-stop chain's interlock, bit 3)
    tx = [0x6041_00_10, 0x6064_00_20, 0x6077_00_10, 0x6061_00_08, 0x60FD_00_20]
    for s in rig.slaves[:3]:  # type: ignore[attr-defined]
        writes = {(i, sub): d for i, sub, d in s.sdo_log}
        assert [struct.unpack("<I", writes[0x1600, k + 1])[0] for k in range(3)] == rx
        assert [struct.unpack("<I", writes[0x1A00, k + 1])[0] for k in range(5)] == tx
        assert writes[0x1600, 0] == bytes([3]) and writes[0x1A00, 0] == bytes([5])
        assert struct.unpack("<H", writes[0x1C12, 1])[0] == 0x1600
        assert struct.unpack("<H", writes[0x1C13, 1])[0] == 0x1A00
        # process data sized by those entries: 16+16+8 bits out, 16+32+16+8+32 bits in
        assert len(s.output) == 5 and len(s.input) == 13
        assert s.state == 1  # INIT: the master closed the segment at the end
    assert seen["al"] == [8, 8, 8, 8]  # every slave in OP while the session ran
    _, c, _ = read_log(path)
    for j in ("hip", "knee", "ankle"):
        states = list(dict.fromkeys(c[f"state_{j}"].astype(int)))
        assert states == [0x40, 0x21, 0x23, ENABLED], (j, states)  # transitions 2, 3, 4
    walking = c["mode"] == 2
    assert np.degrees(np.ptp(c["q_meas_knee"][walking])) > 30  # torque reached the plant


def test_no_torque_without_arming(tmp_path: Path) -> None:
    _, path = hil(0.5, tmp_path)
    _, c, _ = read_log(path)
    for j in ("hip", "knee", "ankle"):
        assert np.all(c[f"state_{j}"] == 0x40) and np.all(c[f"u_{j}"] == 0.0)


@pytest.mark.parametrize("what,text", [
    ("fault", "device fault: "),
    ("silent", "device fault: EtherCAT working counter 7, expected 10"),
    ("jump", "device fault: implausible joint reading: joint 1"),
])
def test_faults_take_torque_off(tmp_path: Path, what: str, text: str) -> None:
    def inject(k: int, rig) -> None:  # type: ignore[no-untyped-def]
        if k == 600:
            if what == "fault":
                rig.fault("knee")
            elif what == "silent":
                rig.silent.add("hip")
            else:
                rig.jump[1] = 0.5

    res, path = hil(2.0, tmp_path, arm=True, walk_after=0.5, inject=inject)
    assert res.stopped_by.startswith(text), res.stopped_by
    if what == "fault":  # the EMCY or the Fault statusword, whichever comes first
        assert ("EMCY from the knee drive (slave 2): 0x2310" in res.stopped_by
                or "the knee drive (slave 2) is in FAULT" in res.stopped_by)
    assert len(read_log(path)[1]["t"]) <= 603  # within two ticks


@pytest.mark.parametrize("fault,text", [
    # the units exoleg wrote before issue 21: mN m from the drive's 15 A (an EPOS4 holds
    # uN m from the motor's nominal current, device-datasheets.md S3)
    ("old units", r"hip drive \(slave 3\): 0x6076: motor rated torque 1068 uN m; the "
                  r"device file's motor gives 458528 uN m \(I_N x k_t\) \(mN m from the "
                  r"drive's current\?"),
    ("current limit", r"knee drive \(slave 2\): 0x3001 sub 2 \(output current limit\): "
                      r"30000 mA; the device file says 14500 mA"),
    # the hip's drive commissioned for the EC 90 flat 90 W (12 pole pairs, S1) while the
    # device file's hip is the 160 W (11, S2): it would commutate the motor wrongly
    ("pole pairs", r"hip drive \(slave 3\): 0x3001 sub 3 \(pole pairs\): 12; the device "
                   r"file says 11"),
    ("product", r"ankle drive \(slave 1\): 0x1018 sub 2: product code 0x65510000"),
    ("offset", r"knee drive \(slave 2\): \(homing\): the joint reads"),
    ("order", r"ankle drive \(slave 1\): \(identity\): is 'exoleg foot board'"),
    ("missing", r"EtherCAT segment: \(start-up\): 3 slaves found"),
    # a published EPOS4 configuration's 10 ms against the 1 kHz loop (realtime.md)
    ("interpolation", r"hip drive \(slave 3\): 0x60C2: interpolation period 10 ms \(sub 1 "
                      r"= 10, sub 2 = -3\); the loop's period is 1 ms: set sub 1 = 1, sub 2 "
                      r"= -3"),
    ("enabled", r"knee drive \(slave 2\): 0x6041: the drive is in OPERATION_ENABLED before "
                r"the session \(another master may be driving it"),
    ("stale target", r"ankle drive \(slave 1\): 0x607A: target position 0 counts, not the "
                     r"position actual value"),
])
def test_start_up_refuses_a_misconfigured_segment(tmp_path: Path, fault: str,
                                                  text: str) -> None:
    def inject(k: int, rig) -> None:  # type: ignore[no-untyped-def]
        if k != -1:
            return
        if fault == "old units":  # k_t x 15 A in mN m, as exoleg wrote it before
            rig.slaves[2].objects[0x6076, 0] = struct.pack("<I", round(0.0712 * 15 * 1000))
        elif fault == "current limit":
            rig.slaves[1].objects[0x3001, 2] = struct.pack("<I", 30000)
        elif fault == "pole pairs":  # an UNSIGNED8, as the EPOS4 holds it
            rig.slaves[2].objects[0x3001, 3] = struct.pack("<B", 12)
        elif fault == "product":
            rig.slaves[0].id = 0x65510000
        elif fault == "offset":
            rig.slaves[1].objects[0x6064, 0] = struct.pack(
                "<i", rig.scaling["knee"].to_counts(2.0))
        elif fault == "interpolation":
            rig.slaves[2].objects[0x60C2, 1] = struct.pack("<B", 10)
        elif fault == "enabled":
            rig.drives["knee"].state = cia402.State.OPERATION_ENABLED
            rig.slaves[1].objects[0x6041, 0] = struct.pack(
                "<H", cia402.STATUSWORD[cia402.State.OPERATION_ENABLED])
        elif fault == "stale target":  # a drive that does not take the target written
            s = rig.slaves[0]
            s.objects.pop((0x607A, 0))
            s.objects[0x607A, 0] = struct.pack("<i", 0)
            write = s.sdo_write
            s.sdo_write = lambda i, sub, data: None if (i, sub) == (0x607A, 0) else \
                write(i, sub, data)
            s.objects[0x6064, 0] = struct.pack("<i", rig.scaling["ankle"].to_counts(0.2))
        elif fault == "order":
            rig.slaves.insert(0, rig.slaves.pop())
        else:
            rig.slaves.pop(0)

    with pytest.raises(ParameterError, match=text):
        hil(1.0, tmp_path, arm=True, inject=inject)


def test_a_wrong_pdo_mapping_stops_at_safe_op() -> None:
    """A drive that does not take the mapping stays in PRE-OP; the master says which."""
    import exoleg
    from exoleg.hw.ethercat_backend import EthercatBackend
    from exoleg.hw.ethercat_sim import SimulatedSegment
    from exoleg.runtime.sim_backend import SimBackend
    from exoleg.system.config import DeviceConfig

    sim = SimBackend.built(exoleg.paper_leg(), 30.0)
    seg = SimulatedSegment(sim)
    b = EthercatBackend(sim.dev.actuators, master=seg)
    real = b._mapper

    def short_mapper(slave):  # type: ignore[no-untyped-def]
        config = real(slave)
        return lambda pos: (config(pos), slave.sdo_log.pop())  # the last write is lost
    b._mapper = short_mapper  # type: ignore[method-assign]
    s = DeviceConfig.load().safety
    with pytest.raises(ParameterError, match=r"did not reach SAFE-OP: slave 1 in state 2 "
                                             r"\(AL status 0x001D\)"):
        b.start_up(s.lower, s.upper, s.hard_margin)


def test_a_missing_interface_is_a_clear_error(tmp_path: Path) -> None:
    pytest.importorskip("pysoem", reason="pysoem (exoleg[hw])")
    with pytest.raises(ParameterError, match="--interface: cannot open 'exoleg-nonexistent0' "
                                             "for EtherCAT"):
        run("ethercat", 1.0, tmp_path, interface="exoleg-nonexistent0", realtime=False)


def test_every_target_is_defined_before_the_drives_are_enabled(tmp_path: Path) -> None:
    # as on the CAN bus (test_hil_canopen.py): targets a previous master left -- 40 % of
    # the rated torque, a position 1 rad away -- are set to 0 and to where each joint is
    # before any drive is enabled
    from exoleg.hw.ethercat_backend import SLAVE_POS
    from exoleg.hw.rig import JOINT_ORDER

    seen: dict[str, tuple[float, float]] = {}

    def inject(k: int, rig) -> None:  # type: ignore[no-untyped-def]
        def obj(j: str, index: int, f: str) -> int:
            return int(struct.unpack(f, rig.slaves[SLAVE_POS[j] - 1].objects[index, 0])[0])

        if k == -1:
            for j in JOINT_ORDER:
                o = rig.slaves[SLAVE_POS[j] - 1].objects
                o[0x6071, 0] = struct.pack("<h", 400)
                o[0x607A, 0] = struct.pack("<i", rig.scaling[j].to_counts(1.0))
        if k == 0:  # the first cycle: target position against position actual, rad
            seen.update({j: (rig.scaling[j].to_rad(obj(j, 0x607A, "<i")),
                             rig.scaling[j].to_rad(obj(j, 0x6064, "<i")))
                         for j in JOINT_ORDER})

    res, _ = hil(0.3, tmp_path, arm=True, inject=inject)
    assert res.stopped_by == "duration", res.stopped_by
    assert set(seen) == set(JOINT_ORDER)
    for j, (target, actual) in seen.items():
        assert abs(target - actual) < 1e-3, j  # (a tick's motion at most)


def test_a_lost_exchange_is_held_counted_and_three_in_a_row_are_a_fault(
        tmp_path: Path) -> None:
    # the hip's slave out of single exchanges (the working counter short): the last
    # inputs held for that tick, counted for every drive (which slave is not known),
    # the walk goes on; out for good: a fault at the third exchange in a row
    # (exoleg.hw.master.LOSS_RUN)
    import json

    def inject(k: int, rig) -> None:  # type: ignore[no-untyped-def]
        if k in (300, 600) or k >= 900:
            rig.silent.add("hip")
        elif k in (301, 601):
            rig.silent.discard("hip")

    res, _ = hil(1.2, tmp_path / "s", arm=True, inject=inject)
    assert res.stopped_by.startswith("device fault: EtherCAT working counter 7, expected "
                                     f"10: a slave did not answer the process data, "
                                     f"{LOSS_RUN} cycles in a row"), res.stopped_by
    pdo = json.loads((tmp_path / "s" / "run.json").read_text())["process_data"]
    assert pdo["missing"] == dict.fromkeys(("hip", "knee", "ankle"), 2 + LOSS_RUN)
    assert res.ticks == 901 + LOSS_RUN  # (silenced after tick 900: lost from 901)


def test_the_hardware_estop_is_honoured_within_a_tick(tmp_path: Path) -> None:
    # Issue 20, point 2: the E-stop chain (the drives' STO) read in each drive's
    # interlock input (0x60FD bit 3), mapped in the cyclic process data.
    from exoleg.errors import ParameterError

    def inject(k: int, rig) -> None:  # type: ignore[no-untyped-def]
        if k == 600:
            rig.hardware_estop()

    res, path = hil(2.0, tmp_path, arm=True, walk_after=0.3, inject=inject)
    assert res.stopped_by.startswith("device fault: hardware E-stop: the E-stop chain is "
                                     "open (interlock input 0x60FD bit 3 of the hip drive "
                                     "(slave 3))"), res.stopped_by
    assert len(read_log(path)[1]["t"]) == 601  # seen at the next exchange

    def pressed(k: int, rig) -> None:  # type: ignore[no-untyped-def]
        if k == -1:
            rig.hardware_estop()

    with pytest.raises(ParameterError, match=r"0x60FD: the hardware E-stop is pressed"):
        hil(1.0, tmp_path / "again", arm=True, inject=pressed)
