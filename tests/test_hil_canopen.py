"""Hardware in the loop on a virtual CAN bus: the real master code (python-canopen
RemoteNodes, PDOs, SYNC, CiA 402 over controlwords) against simulated EPOS4 nodes and a
simulated foot board. References: CiA 402's states and transitions; the bus protocol
of exoleg.hw.canopen_backend (what each node must answer every SYNC)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("canopen", reason="python-canopen (exoleg[hw])")

from exoleg.hw import cia402  # noqa: E402
from exoleg.runtime.log import read_log  # noqa: E402
from exoleg.runtime.session import run  # noqa: E402

ENABLED = cia402.State.OPERATION_ENABLED.value[1]


def test_arming_walking_and_torque_over_the_bus(tmp_path: Path) -> None:
    res, path = run("canopen", 2.0, tmp_path, arm=True, walk_after=1.0, realtime=False,
                    channel="hil-walk")
    assert res.stopped_by == "duration"
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

    res, path = run("canopen", 2.0, tmp_path, arm=True, walk_after=0.5, realtime=False,
                    channel="hil-fault", inject=inject)
    assert res.stopped_by.startswith("device fault: the knee drive (node 2) is in FAULT")
    _, c, _ = read_log(path)
    assert len(c["t"]) <= 603  # stopped within two ticks of the fault (the bus's delay)


def test_silent_node_is_a_fault(tmp_path: Path) -> None:
    def inject(k: int, rig) -> None:  # type: ignore[no-untyped-def]
        if k == 300:
            rig.silent.add("hip")

    res, _ = run("canopen", 1.0, tmp_path, arm=True, realtime=False, channel="hil-silent",
                 inject=inject)
    assert res.stopped_by.startswith("device fault: no PDO from the hip drive (node 3)")


def test_silent_foot_board_is_a_fault(tmp_path: Path) -> None:
    def inject(k: int, rig) -> None:  # type: ignore[no-untyped-def]
        if k == 300:
            rig.silent.add("foot")

    res, _ = run("canopen", 1.0, tmp_path, arm=True, realtime=False, channel="hil-foot",
                 inject=inject)
    assert res.stopped_by.startswith("device fault: no frame from the foot board")


def test_no_torque_without_arming(tmp_path: Path) -> None:
    res, path = run("canopen", 0.5, tmp_path, realtime=False, channel="hil-disarmed")
    _, c, _ = read_log(path)
    for j in ("hip", "knee", "ankle"):
        assert np.all(c[f"state_{j}"] == 0x40)  # never leaves switch on disabled
        assert np.all(c[f"u_{j}"] == 0.0)
