"""The device contract (exoleg.runtime.contract.check_device) on every shipped backend --
the simulated device, the CANopen master against simulated EPOS4 nodes on python-can's
virtual bus, the EtherCAT master against simulated slaves -- on devices that break it
(each departure named), and on the guide's own backend, examples/devices/mounting.py
(docs/extending/device.md).

Reference for the mounted backend: the device itself. Mounting a unit mirrored twice is
mounting it as it was, so a session through Mounted(Mounted(device, s), s) must be the
device's own session to the bit."""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import exoleg
from conftest import REALTIME, SIM_OVERRUN, Taken
from exoleg.runtime.contract import check_device
from exoleg.runtime.loop import LOG_HEAD, LOG_TAIL, run_session
from exoleg.runtime.sim_backend import SimBackend
from exoleg.session_log import SessionLog, read_log
from exoleg.system.config import DeviceConfig
from exoleg.tick import Command

ROOT = Path(__file__).resolve().parents[1]
CONFIG = DeviceConfig.load(None)


def _sim() -> SimBackend:
    return SimBackend.built(exoleg.paper_leg(), 30.0, controller="pd-gravity")


def test_the_simulated_device_keeps_the_contract() -> None:
    assert check_device(_sim(), CONFIG.safety) == []


def test_the_canopen_master_keeps_the_contract() -> None:
    pytest.importorskip("canopen", reason="python-canopen (exoleg[hw])")
    from exoleg.hw.canopen_backend import HEARTBEAT_LOST_S, CanopenBackend
    from exoleg.hw.canopen_sim import SimulatedRig

    def check() -> tuple[list[str], Taken]:
        """The contract's departures, and what the host and other processes' real-time
        threads took meanwhile."""
        sim = _sim()
        sim.warm_up()
        rig = SimulatedRig(sim, "virtual", "contract-suite")
        try:
            master = CanopenBackend(CONFIG.actuators, 1e-3, "virtual", "contract-suite",
                                    SIM_OVERRUN)
            with Taken(os.getpid()) as taken:
                return check_device(master, CONFIG.safety), taken
        finally:
            rig.close()

    found, taken = check()
    if taken.worth(HEARTBEAT_LOST_S) and any("no heartbeat" in f for f in found):
        # the simulated nodes' heartbeats (normal priority, this process) held up for
        # longer than the master waits, while the host or the suite's other files'
        # real-time sessions had the CPUs (a full suite: 261 ms, the limit 150): the
        # contract's question is not asked; once more
        found, taken = check()
    assert found == [], (found, str(taken))


def test_the_ethercat_master_keeps_the_contract() -> None:
    pytest.importorskip("pysoem", reason="pysoem (exoleg[hw])")
    from exoleg.hw.ethercat_backend import EthercatBackend
    from exoleg.hw.ethercat_sim import SimulatedSegment

    sim = _sim()
    sim.warm_up()
    seg = SimulatedSegment(sim)
    try:
        master = EthercatBackend(CONFIG.actuators, 1e-3, "fake", master=seg,
                                 timeout=SIM_OVERRUN)
        assert check_device(master, CONFIG.safety) == []
    finally:
        seg.close()


class _Broken:
    """The simulated device with one departure from the contract."""

    def __init__(self, how: str) -> None:
        self.dev, self.how = _sim(), how
        self.columns = list(self.dev.columns)
        if how == "columns":  # a name of the loop's own
            self.columns[0] = "u_hip"
        self.released = False

    def configure(self, limits: Any) -> Any:
        return self.dev.configure(limits)

    def warm_up(self) -> None:
        self.dev.warm_up()

    def read(self, t: float) -> Any:
        r = dict(self.dev.read(t))
        if self.how == "nan" and t > 0.01:
            r["q"] = np.array([0.1, np.nan, 0.0])
        if self.how == "fsr":
            r["fsr"] = r["fsr"][:3]
        if self.how == "missing":
            del r["dq"]
        return r

    def write(self, tau: Any, enable: bool) -> None:
        self.dev.write(tau, enable)

    def safe(self) -> None:
        self.dev.safe()

    def deactivate(self) -> None:
        self.released = True

    def record(self) -> Any:
        rec = self.dev.record()
        return rec[:-1] if self.how == "record" else rec


@pytest.mark.parametrize("how, said", [
    ("nan", "read at tick 11: q: [0.1, nan, 0.0] is not finite"),
    ("fsr", "fsr: shape (3,), expected (4,)"),
    ("missing", "dq missing"),
    ("record", "record: expected"),
    ("columns", "['u_hip'] are the loop's own log columns")])
def test_the_contract_names_what_a_device_breaks(how: str, said: str) -> None:
    dev = _Broken(how)
    problems = check_device(dev, CONFIG.safety)
    assert len(problems) == 1 and said in problems[0], problems
    assert dev.released  # released however the check ends


def _mounting() -> Any:
    spec = importlib.util.spec_from_file_location("mounting",
                                                  ROOT / "examples" / "devices" / "mounting.py")
    assert spec is not None and spec.loader is not None
    mod = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(mod)
    return mod


def _session(device: Any, sim: SimBackend, path: Path) -> dict[str, np.ndarray]:
    device.configure(CONFIG.safety)
    log = SessionLog(path, LOG_HEAD + device.columns + LOG_TAIL, {"period": 1e-3})

    def scenery(out: dict[str, Any]) -> None:
        sim.walking = int(out["mode"]) in (2, 4)

    res = run_session(device, sim.controller, 2.0, 1e-3, log,
                      {0: int(Command.ARM), 500: int(Command.WALK)}, realtime=REALTIME,
                      overrun=SIM_OVERRUN, scenery=scenery)
    device.deactivate()
    assert res.stopped_by.startswith("duration"), res.stopped_by
    return read_log(path)[1]


def test_the_guides_backend_keeps_the_contract_and_the_session(tmp_path: Path) -> None:
    Mounted = _mounting().Mounted
    signs = (1, -1, -1)
    assert check_device(Mounted(_sim(), signs), CONFIG.safety) == []
    plain = _sim()
    alone = _session(plain, plain, tmp_path / "plain.log")
    inner = _sim()
    twice = _session(Mounted(Mounted(inner, signs), signs), inner, tmp_path / "twice.log")
    for name in alone:
        if name != "late":
            assert np.array_equal(alone[name], twice[name], equal_nan=True), name
    with pytest.raises(ValueError, match=r"\+1 or -1 per joint"):
        Mounted(_sim(), (1, 0, 1))
