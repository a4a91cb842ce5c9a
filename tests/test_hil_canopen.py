"""Hardware in the loop on a virtual CAN bus: the real master code (python-canopen
RemoteNodes, PDOs, SYNC, CiA 402 over controlwords) against simulated EPOS4 nodes and a
simulated foot board. References: CiA 402's states and transitions; the bus protocol
of exoleg.hw.canopen_backend (what each node must answer every SYNC)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("canopen", reason="python-canopen (exoleg[hw])")

from conftest import BUS_WAIT, REALTIME  # noqa: E402
from exoleg.hw import cia402  # noqa: E402
from exoleg.runtime.session import run  # noqa: E402
from exoleg.session_log import read_log  # noqa: E402

ENABLED = cia402.State.OPERATION_ENABLED.value[1]


def hil(duration: float, folder: Path, **kw):  # type: ignore[no-untyped-def]
    """A session on the canopen backend over the virtual bus (the suite's waits and
    real-time settings, conftest)."""
    return run("canopen", duration, folder, realtime=REALTIME, bus_timeout=BUS_WAIT, **kw)


def test_arming_walking_and_torque_over_the_bus(tmp_path: Path) -> None:
    res, path = hil(2.0, tmp_path, arm=True, walk_after=1.0, channel="hil-walk")
    # walking at the end: a controlled stop first (runtime.loop.STOP_GRACE_S)
    assert res.stopped_by.startswith("duration, after a controlled stop to STANDING")
    _, c, _ = read_log(path)
    for j in ("hip", "knee", "ankle"):
        states = c[f"state_{j}"]
        # switch on disabled -> ready -> switched on -> operation enabled (transitions 2-4)
        seen = list(dict.fromkeys(states.astype(int)))
        assert seen == [0x40, 0x21, 0x23, ENABLED], (j, seen)
    # torque reached the plant through the drives: the knee swings in the walk
    walking = c["mode"] == 2
    assert np.degrees(np.ptp(c["q_meas_knee"][walking])) > 30
    assert np.all(np.isfinite(c["bus_us"])) and np.median(c["bus_us"]) < 5000


def test_drive_fault_takes_torque_off(tmp_path: Path) -> None:
    def inject(k: int, rig) -> None:  # type: ignore[no-untyped-def]
        if k == 600:
            rig.fault("knee")

    res, path = hil(2.0, tmp_path, arm=True, walk_after=0.5, channel="hil-fault",
                    inject=inject)
    # the EMCY message or the Fault statusword, whichever the master sees first
    assert res.stopped_by.startswith(("device fault: EMCY from the knee drive (node 2): "
                                      "0x2310", "device fault: the knee drive (node 2) is in "
                                      "FAULT")), res.stopped_by
    _, c, _ = read_log(path)
    assert len(c["t"]) <= 603  # stopped within two ticks of the fault (the bus's delay)


def test_silent_node_is_a_fault(tmp_path: Path) -> None:
    def inject(k: int, rig) -> None:  # type: ignore[no-untyped-def]
        if k == 300:
            rig.silent.add("hip")

    res, _ = hil(1.0, tmp_path, arm=True, channel="hil-silent",
                 inject=inject)
    assert res.stopped_by.startswith("device fault: no PDO from the hip drive (node 3)")


@pytest.mark.parametrize("every", [0, 50])
def test_lost_pdos_are_counted_and_a_rate_of_them_is_a_fault(tmp_path: Path,
                                                             every: int) -> None:
    # the hip's answer dropped at single cycles: held for that tick, counted, the walk
    # goes on; dropped every 50th cycle (2 %, above exoleg.hw.master's 1 % of 1,000):
    # a device fault once the 11th is lost
    import json

    from exoleg.hw.master import LOSS_MAX

    drops = {300, 600, 900} if not every else set(range(every, 1000, every))

    def inject(k: int, rig) -> None:  # type: ignore[no-untyped-def]
        if k in drops:
            rig.silent.add("hip")
        elif k - 1 in drops:
            rig.silent.discard("hip")

    res, _ = run("canopen", 1.2, tmp_path / "s", realtime=REALTIME, bus_timeout=0.02,
                 arm=True, channel=f"hil-loss-{every}", inject=inject)
    pdo = json.loads((tmp_path / "s" / "run.json").read_text())["process_data"]
    if not every:
        assert res.stopped_by == "duration", res.stopped_by
        # (the host may have delayed an answer past 20 ms too: at least the drops)
        assert pdo["missing"]["hip"] >= 3 and pdo["cycles"] == res.ticks
        assert pdo["received"]["hip"] == pdo["cycles"] - pdo["missing"]["hip"]
    else:
        assert res.stopped_by.startswith(f"device fault: process data lost in "
                                         f"{LOSS_MAX + 1} of the last "), res.stopped_by
        assert sum(pdo["missing"].values()) >= LOSS_MAX + 1  # (the host's delays too)


def test_silent_foot_board_is_a_fault(tmp_path: Path) -> None:
    def inject(k: int, rig) -> None:  # type: ignore[no-untyped-def]
        if k == 300:
            rig.silent.add("foot")

    res, _ = hil(1.0, tmp_path, arm=True, channel="hil-foot",
                 inject=inject)
    assert res.stopped_by.startswith("device fault: no frame from the foot board")


def test_no_torque_without_arming(tmp_path: Path) -> None:
    res, path = hil(0.5, tmp_path, channel="hil-disarmed")
    _, c, _ = read_log(path)
    for j in ("hip", "knee", "ankle"):
        assert np.all(c[f"state_{j}"] == 0x40)  # never leaves switch on disabled
        assert np.all(c[f"u_{j}"] == 0.0)


def test_frozen_foot_board_is_a_fault(tmp_path: Path) -> None:
    def inject(k: int, rig) -> None:  # type: ignore[no-untyped-def]
        if k == 300:
            rig.frozen = True

    res, path = hil(2.0, tmp_path, arm=True, channel="hil-frozen",
                    inject=inject)
    assert res.stopped_by.startswith("device fault: the foot board's readings froze")
    # frozen for FROZEN_S (250 ticks) after tick 300, give or take the bus's few ticks
    from exoleg.runtime.watch import FROZEN_S

    frozen = round(FROZEN_S / 1e-3)
    assert 300 + frozen <= len(read_log(path)[1]["t"]) <= 300 + frozen + 10


def test_implausible_encoder_jump_is_a_fault(tmp_path: Path) -> None:
    def inject(k: int, rig) -> None:  # type: ignore[no-untyped-def]
        if k == 300:
            rig.jump[1] = 0.5  # the knee's reading jumps half a radian

    res, _ = hil(1.0, tmp_path, arm=True, channel="hil-jump",
                 inject=inject)
    assert res.stopped_by.startswith("device fault: implausible joint reading: joint 1")


def test_lost_heartbeat_is_a_fault(tmp_path: Path) -> None:
    def inject(k: int, rig) -> None:  # type: ignore[no-untyped-def]
        if k == 300:
            rig.nodes["ankle"].nmt.stop_heartbeat()

    res, path = hil(2.0, tmp_path, arm=True, channel="hil-heartbeat", inject=inject)
    assert res.stopped_by.startswith("device fault: no heartbeat from the ankle drive (node 1)")
    # lost after 3 periods of 50 ms: within 300 + 150 + 50 (the last beat) ticks
    assert len(read_log(path)[1]["t"]) <= 300 + 200 + 20


def test_heartbeat_is_counted_from_the_first_exchange() -> None:
    """A heartbeat last seen before the cyclic exchange began (compiling before the
    clock starts held the interpreter 249 ms in a CI run, and the first tick called the
    ankle drive lost) is not a fault; silence over the exchange is, after HEARTBEAT_LOST
    periods (CiA 301's heartbeat consumer)."""
    import time

    import exoleg
    from exoleg.hw.canopen_backend import HEARTBEAT_LOST_S, CanopenBackend
    from exoleg.hw.canopen_sim import SimulatedRig
    from exoleg.runtime.sim_backend import SimBackend
    from exoleg.system.config import DeviceConfig

    config = DeviceConfig.load()
    sim = SimBackend.built(exoleg.paper_leg(), 30.0, 1e-3, config=config)
    sim.configure(config.safety)
    rig = SimulatedRig(sim, "virtual", "hil-first")
    master = CanopenBackend(config.actuators, 1e-3, "virtual", "hil-first", BUS_WAIT)
    try:
        master.configure(config.safety)
        rig.nodes["ankle"].nmt.stop_heartbeat()
        master.nodes["ankle"].nmt.timestamp = time.time() - 0.3  # stale before the loop
        assert "fault" not in master.read(0.0)
        t0 = time.perf_counter()
        fault = ""
        while not fault and time.perf_counter() - t0 < 2 * HEARTBEAT_LOST_S:
            time.sleep(1e-3)
            fault = master.read(0.0).get("fault", "")
        assert fault.startswith("no heartbeat from the ankle drive (node 1)"), fault
        assert time.perf_counter() - t0 >= HEARTBEAT_LOST_S
    finally:
        master.deactivate()
        rig.close()


@pytest.mark.parametrize("fault,text", [
    # the units exoleg wrote before issue 21 (mN m from the drive's 15 A); an EPOS4 holds
    # uN m from the motor's nominal current (device-datasheets.md, S3)
    ("old units", "hip drive (node 3): 0x6076: motor rated torque 1068 uN m; the device "
                  "file's motor gives 458528 uN m (I_N x k_t) (mN m from the drive's"),
    ("nominal", "knee drive (node 2): 0x3001 sub 1 (nominal current): 15000 mA; the device "
                "file says 7250 mA"),
    # the hip's drive commissioned for the 90 W frame's 12 pole pairs (S1); the file's
    # 160 W has 11 (S2)
    ("pole pairs", "hip drive (node 3): 0x3001 sub 3 (pole pairs): 12; the device file "
                   "says 11"),
    ("offset", "knee drive (node 2): (homing): the joint reads"),
    # the interpolation period of a published EPOS4 configuration (10 ms) against the
    # 1 kHz loop's (realtime.md; EPOS4 firmware specification, 0x60C2)
    ("interpolation", "hip drive (node 3): 0x60C2: interpolation period 10 ms (sub 1 = 10, "
                      "sub 2 = -3); the loop's period is 1 ms: set sub 1 = 1, sub 2 = -3"),
    ("enabled", "knee drive (node 2): 0x6041: the drive is in OPERATION_ENABLED before the "
                "session (another master may be driving it"),
    ("fault", "ankle drive (node 1): 0x6041: the drive is in FAULT before the session "
              "(clear its fault first)"),
])
def test_start_up_refuses_a_misconfigured_device(tmp_path: Path, fault: str,
                                                  text: str) -> None:
    from exoleg.errors import ParameterError

    def inject(k: int, rig) -> None:  # type: ignore[no-untyped-def]
        if k == -1 and fault == "interpolation":
            rig.nodes["hip"].sdo[0x60C2][1].raw = 10
        if k == -1 and fault in ("enabled", "fault"):
            j, state = (("knee", cia402.State.OPERATION_ENABLED) if fault == "enabled"
                        else ("ankle", cia402.State.FAULT))
            rig.drives[j].state = state
            rig.nodes[j].sdo[0x6041].raw = cia402.STATUSWORD[state]
        if k == -1 and fault == "old units":
            rig.nodes["hip"].sdo[0x6076].raw = round(0.0712 * 15 * 1000)
        if k == -1 and fault == "nominal":
            rig.nodes["knee"].sdo[0x3001][1].raw = 15000
        if k == -1 and fault == "pole pairs":
            rig.nodes["hip"].sdo[0x3001][3].raw = 12
        if k == -1 and fault == "offset":
            rig.jump[1] = 2.0  # the knee's encoder reads 115 deg off
            rig.nodes["knee"].sdo[0x6064].raw = rig.scaling["knee"].to_counts(2.0)

    with pytest.raises(ParameterError, match=text.replace("(", r"\(").replace(")", r"\)")):
        hil(1.0, tmp_path, arm=True, channel=f"hil-start-{fault}", inject=inject)


def test_every_target_is_defined_before_the_drives_are_enabled(tmp_path: Path) -> None:
    # Targets left by a previous master (a torque of 40 % of the rated, a position far
    # from the joint): the start-up sets the torque to 0 and the position to where each
    # joint is before any drive is enabled (ethercat_driver_ros2's drives moved at launch
    # to targets defaulting to 0, realtime.md); a drive that kept a stale torque target
    # would be refused (0x6071), so the session would not start
    from exoleg.hw.rig import JOINT_ORDER

    seen: dict[str, tuple[float, float]] = {}

    def inject(k: int, rig) -> None:  # type: ignore[no-untyped-def]
        if k == -1:
            for j in JOINT_ORDER:
                rig.nodes[j].sdo[0x6071].raw = 400
                rig.nodes[j].sdo[0x607A].raw = rig.scaling[j].to_counts(1.0)
        if k == 0:  # the first cycle: target position against position actual, rad
            seen.update({j: (rig.scaling[j].to_rad(int(rig.nodes[j].sdo[0x607A].raw)),
                             rig.scaling[j].to_rad(int(rig.nodes[j].sdo[0x6064].raw)))
                         for j in JOINT_ORDER})

    res, _ = hil(0.3, tmp_path, arm=True, channel="hil-targets", inject=inject)
    assert res.stopped_by == "duration", res.stopped_by
    for j, (target, actual) in seen.items():
        assert abs(target - actual) < 1e-3, j  # (a tick's motion at most)


def test_the_bus_holds_with_the_cpus_busy(tmp_path: Path, sched_fifo: None,
                                          monkeypatch: pytest.MonkeyPatch) -> None:
    """`exoleg run --backend canopen --interface virtual` as the README runs it (real-time
    settings, the simulated nodes' default bus timeout) while one process per CPU spins.
    Reference, measured: with the loop pinned to a shared CPU and the bus threads at
    normal priority, a node's answer missed 5 ms within 0.1 s under three spinning
    processes, and in 1 run of 3 under one (the README's example failed in CI so);
    realtime_settings and SIMULATED_BUS_TIMEOUT_S held 10 runs of 10 s under three. Its
    threads above the suite's other sessions' (conftest.alone): the load under test is
    the spinning processes, as on a device; beside other workers' sessions at its own
    priorities the foot board's frame missed its 20 ms once in CI. A virtual machine's
    host can take its CPUs from every priority (/proc/stat's steal): a bus timeout while
    the host took at least that long is asked once more (test_realtime's rule), and a
    failure says how much the host took -- the foot board's frame missed its 20 ms once
    more in CI on 2026-12-07, on a host whose steal had risen that night."""
    import os
    import subprocess
    import sys

    from conftest import ALONE_IO_PRIORITY, alone, host_steal
    from exoleg.runtime.session import SIMULATED_BUS_TIMEOUT_S, SessionResult

    alone(monkeypatch)

    def loaded(attempt: int) -> tuple[SessionResult, float]:
        hogs = [subprocess.Popen([sys.executable, "-c", "while True: pass"])
                for _ in range(os.cpu_count() or 2)]
        taken = host_steal()
        try:
            res, _ = run("canopen", 3.0, tmp_path / str(attempt), arm=True, walk_after=1.0,
                         channel=f"hil-load-{attempt}",
                         bus_timeout=SIMULATED_BUS_TIMEOUT_S)  # the default, not the suite's
        finally:
            for h in hogs:
                h.kill()
                h.wait()
        return res, host_steal() - taken

    res, stolen = loaded(1)
    if "within" in res.stopped_by and stolen >= SIMULATED_BUS_TIMEOUT_S:
        res, stolen = loaded(2)
    assert res.stopped_by.startswith("duration, after a controlled stop"), \
        (res.stopped_by, f"the host took {stolen * 1e3:.0f} ms of the CPUs meanwhile")
    # the master's and the nodes' receivers, and the three drives' heartbeat producers
    assert f"5 bus threads SCHED_FIFO priority {ALONE_IO_PRIORITY}" in res.realtime, \
        res.realtime


def test_the_hardware_estop_is_honoured_within_a_tick(tmp_path: Path) -> None:
    # Issue 20, point 2: a hardware E-stop input. The chain opens every drive's STO (no
    # torque in hardware, whatever the master sends) and its monitoring contact reads
    # in the interlock input (0x60FD bit 3, CiA 402), sent by an event-driven TPDO2.
    from exoleg.errors import ParameterError

    seen: dict[str, object] = {}

    def inject(k: int, rig) -> None:  # type: ignore[no-untyped-def]
        seen["rig"] = rig
        if k == 600:
            rig.hardware_estop()

    res, path = hil(2.0, tmp_path, arm=True, walk_after=0.3, channel="hil-sto",
                    inject=inject)
    assert res.stopped_by == ("device fault: hardware E-stop: the E-stop chain is open "
                              "(interlock input 0x60FD bit 3 of the hip drive (node 3)); "
                              "the drives' STO has taken the torque off"), res.stopped_by
    _, c, _ = read_log(path)
    assert len(c["t"]) == 601  # pressed after tick 600, seen at the read of tick 601
    rig = seen["rig"]
    assert not any(d.torque_allowed for d in rig.drives.values())  # STO, in hardware
    # pressed before the start: the session is refused before any motion
    def pressed(k: int, rig) -> None:  # type: ignore[no-untyped-def]
        if k == -1:
            rig.hardware_estop()

    with pytest.raises(ParameterError, match=r"0x60FD: the hardware E-stop is pressed"):
        hil(1.0, tmp_path / "again", arm=True, channel="hil-sto-start", inject=pressed)
