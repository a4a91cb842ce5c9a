"""``exoleg identify``: an excitation plan played through the runtime on a bus, the leg
identified from the session's log.

References: the true leg the simulated device carries (a child's segments off the
tables: its gravity torque), and the torque of the plan's last period, held out of the
fit."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import exoleg
from conftest import REALTIME
from exoleg.errors import ParameterError

pytest.importorskip("canopen", reason="python-canopen (exoleg[hw])")


def _grid() -> np.ndarray:
    """9 x 9 x 9 postures over the safety layer's range of motion."""
    from exoleg.control.safety import SafetyLimits

    s = SafetyLimits.paper()
    axes = [np.linspace(s.lower[j], s.upper[j], 9) for j in range(3)]
    return np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)


def test_a_spastic_child_identified_in_stages_over_the_can_bus(tmp_path: Path) -> None:
    """Li et al. 2022's stages. The device alone first (no child; the simulated device
    carries the true device, its links off their model by 5 %), then a GMFCS II
    10-year-old with contracture and moderate spasticity, relaxed in it (their segments
    off the tables by 15 %, 2 cm), over CANopen on the virtual bus, torque from the
    drives' torque actual value; the device identified is the device's share of the
    prior. Plans of 10 s (the shortest; a clinic's are 120 s). Measured: G of the
    identified leg 0.26 % of max |G| off the truth at worst over the range of motion (the
    fitted leg's 1.6 %: the issue's goal is 1 %); the child's share of the base
    parameters 2.2 % off (median), against 12.1 % for one stage from the same log (the
    leg less the device's model); held-out torque 1.1 / 3.0 / 0.8 % of its RMS."""
    import pandas as pd

    from exoleg.child.interaction import device_leg
    from exoleg.child.model import ChildModel, Spasticity
    from exoleg.child.passive import Contracture
    from exoleg.identify.base import actuator_friction, base_parameters
    from exoleg.identify.device import estimate_from_log, identify_device
    from exoleg.identify.staged import child_share
    from exoleg.plots.identify import identify_figure
    from exoleg.session_log import read_log
    from exoleg.sizing import personalized_leg
    from exoleg.system.config import DeviceConfig
    from exoleg.validate.identify import true_legs

    child = ChildModel("c", 10.0, 1.38, 32.0, gmfcs=2,
                       contracture=Contracture.preset("predictcpgait"),
                       spasticity=Spasticity.preset("moderate"))
    fitted = personalized_leg(child.sizing_child())  # the child's segments + the device's
    acts = DeviceConfig.load().actuators
    model = DeviceConfig.load().leg(fitted)
    truth, device_truth = true_legs(model, acts, np.random.default_rng(5))
    device = identify_device("sim", tmp_path / "device", leg=fitted, duration=10.0,
                             truth=device_truth, realtime=REALTIME, candidates=4,
                             device_alone=True)
    assert device.summary()["stage"] == "device alone"
    r = identify_device("canopen", tmp_path / "leg", leg=fitted, child=child, duration=10.0,
                        truth=truth, realtime=REALTIME, candidates=4, channel="identify",
                        identified_device=tmp_path / "device", figure=identify_figure)
    grid = _grid()
    g = truth.G(grid)
    scale = np.abs(g).max()
    err = np.abs(r.identified.leg.G(grid) - g).max() / scale
    prior = np.abs(model.G(grid) - g).max() / scale
    assert err < 0.006 and 0.01 < prior, (err, prior)
    assert np.all(r.held_out_pct < 6.0), r.held_out_pct
    # the child's share: staged against one stage on the same log
    b = base_parameters(model)
    share = b.of(child_share(truth, device_truth))
    floor = np.maximum(np.abs(share), 1e-2 * np.abs(share).max())
    staged = np.median(np.abs(np.array(list(r.summary()["child_share"].values())) - share)
                       / floor)
    header, cols, _ = read_log(tmp_path / "leg" / "session" / "session.log")
    _, one = estimate_from_log(cols, header["period"], r.reference, model,
                               actuator_friction(acts)[1], child)
    single = np.median(np.abs(b.of(child_share(one.leg, device_leg(model, acts))) - share)
                       / floor)
    assert staged < single / 2, (staged, single)
    # what it wrote: the leg file loads and is the identified leg; the parameters with
    # their intervals; the summary; the figure; the session's log
    out = tmp_path / "leg"
    back = exoleg.load_leg(out / "leg.toml")
    assert np.allclose(back.G(grid), r.identified.leg.G(grid), rtol=0, atol=1e-9)
    table = pd.read_csv(out / "parameters.csv")
    assert len(table) == 11 + 6  # 9 inertial + 2 armatures in motion; friction per joint
    assert np.all((table["low95"] < table["value"]) & (table["value"] < table["high95"]))
    assert (out / "identify.png").stat().st_size > 10_000
    assert (out / "identify.json").exists()
    assert (out / "session" / "session.log").exists()
    # a second identification into the same folder keeps the first's session
    with pytest.raises(ParameterError, match="recorded session"):
        identify_device("canopen", out, leg=fitted, duration=10.0, realtime=REALTIME,
                        channel="identify")
    # the stages need the device identified at this child's telescope settings
    with pytest.raises(ParameterError, match="identify the device alone with its "
                                             "telescopes set for this child"):
        identify_device("sim", tmp_path / "other", duration=10.0, realtime=REALTIME,
                        identified_device=tmp_path / "device", figure=identify_figure)


def test_identify_refuses_what_it_cannot_do(tmp_path: Path) -> None:
    def run(*args: str) -> subprocess.CompletedProcess[str]:
        return subprocess.run([sys.executable, "-m", "exoleg.cli", "identify", *args,
                               "--out", str(tmp_path / "o")], capture_output=True,
                              text=True, check=False)

    for args, text in (
            (("--backend", "canopen", "--interface", "socketcan", "--channel", "can0"),
             "on a real device the operator arms the device and starts the plan"),
            (("--backend", "canopen", "--interface", "socketcan", "--sim-leg", "x.toml"),
             "--sim-leg: the simulated device's leg"),
            (("--channel", "can0",), "--channel: goes with --backend canopen or ethercat"),
            (("--duration", "300",), "300 is outside 10-120"),
            (("--leg", str(tmp_path)), "is a folder"),
            # a folder with no identification of the device alone in it
            (("--identified-device", str(tmp_path)), "no such file (expected a record of "
             "an identification of the device alone, written by exoleg identify "
             "--device-alone)")):
        r = run(*args)
        assert r.returncode == 2, (args, r.stdout, r.stderr)
        assert text in r.stderr, (args, r.stderr)
        assert "Traceback" not in r.stderr
    assert not (tmp_path / "o").exists()  # nothing written
