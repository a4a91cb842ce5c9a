"""Device folders: the user's device files replace the shipped ones, and a bad one is one
error naming the file, the field and what is allowed (table-driven)."""

from __future__ import annotations

import subprocess
import sys
import tomllib
from importlib import resources
from pathlib import Path

import pytest

from exoleg.control.gait_phase import DetectorSettings
from exoleg.control.hierarchy import WalkGains
from exoleg.control.safety import SafetyLimits
from exoleg.device.actuator import paper_actuators
from exoleg.device.ground import Ground
from exoleg.device.sensors import FootSensors
from exoleg.errors import ParameterError

LOADERS = {
    "safety.toml": lambda f: SafetyLimits.paper(1e-3, f),
    "walking.toml": Ground.default,
    "sensors.toml": lambda f: FootSensors.default(1.0, f),
    "gait_phase.toml": DetectorSettings.default,
    "walking_control.toml": WalkGains.default,
    "actuators/ankle.toml": lambda f: paper_actuators(f),
}


def _shipped(name: str) -> str:
    return resources.files("exoleg").joinpath("data", "device", *name.split("/")).read_text()


def _folder(tmp_path: Path, name: str, text: str) -> Path:
    p = tmp_path / "device" / name
    p.parent.mkdir(parents=True, exist_ok=True)
    p.write_text(text)
    return tmp_path / "device"


@pytest.mark.parametrize("name,old,new,field", [
    ("safety.toml", "hard_margin_deg = 5.0", "hard_margin_deg = 90.0", "hard_margin_deg"),
    ("safety.toml", "overspeed_factor = 1.2", "overspeed_factor = nan", "overspeed_factor"),
    ("walking.toml", "stiffness = 80000.0", "stiffness = 1e12", "stiffness"),
    ("walking.toml", "share = 0.35", "share = 0.45", "sole"),
    ("walking.toml", 'region = "met5"', 'region = "arch"', "region"),
    ("walking.toml", "x = 0.38,", "x = 0.40,", "sole"),
    ("walking.toml", "lift_mm = 0.5", "lift_mm = 50.0", "lift_mm"),
    ("walking.toml", "friction = 0.8", "friction = \"high\"", "friction"),
    ("walking.toml", 'landing = "drop"', 'landing = "soft"', "landing"),
    ("walking.toml", 'landing = "drop"', "landing = 1", "landing"),
    ("sensors.toml", "adc_bits = 12", "adc_bits = 12.5", "adc_bits"),
    ("sensors.toml", "full_scale_N = 445.0", "full_scale_N = -1.0", "full_scale_N"),
    ("sensors.toml", "fitted = false", "fitted = 1", "fitted"),
    ("sensors.toml", "heel_until = 0.6", "heel_until = 0.0", "heel_until"),
    ("sensors.toml", "hallux_from = 0.5", "hallux_from = 0.5\nsize = 3", "size"),
    ("gait_phase.toml", "debounce_ms = 8.0", "debounce_ms = 1e9", "debounce_ms"),
    ("gait_phase.toml", "other_bears = 0.1", "other_bears = 1.5", "other_bears"),
    ("gait_phase.toml", "other_full = 0.4", "other_full = 0.08", "other_full"),
    ("gait_phase.toml", "imu_toe_eased = 0.6", "imu_toe_eased = 0", "imu_toe_eased"),
    ("gait_phase.toml", "imu_slow_stride_s = 1.5", "imu_slow_stride_s = \"slow\"",
     "imu_slow_stride_s"),
    ("gait_phase.toml", "contact_off = 0.15", "contact_off = 0.5", "contact_on/contact_off"),
    ("gait_phase.toml", "heel_off = 0.03", "heel_off = 0.3", "heel_off"),
    ("gait_phase.toml", "heel_off = 0.03", "heel_off = -0.1", "heel_off"),
    ("walking_control.toml", "support = 1.0", "support = 7.0", "support"),
    ("walking_control.toml", "kp_swing = [765.0, 152.0, 420.0]", "kp_swing = [1, 2]",
     "kp_swing"),
    ("actuators/ankle.toml", "ratio = 120.0", "ratio = 0.5", "ratio"),
    ("safety.toml", "torque_fraction = 1.0", "torque_fraction = 1.0\nextra = 3", "extra"),
], ids=lambda v: v if isinstance(v, str) and len(v) < 25 else None)
def test_bad_device_file_is_named(tmp_path: Path, name: str, old: str, new: str,
                                  field: str) -> None:
    text = _shipped(name)
    assert old in text, (name, old)
    folder = _folder(tmp_path, name, text.replace(old, new))
    with pytest.raises(ParameterError) as e:
        LOADERS[name](folder)
    assert name.split("/")[-1] in str(e.value) and field in str(e.value), str(e.value)


@pytest.mark.parametrize("name", list(LOADERS))
def test_binary_or_bad_toml_device_files(tmp_path: Path, name: str) -> None:
    folder = _folder(tmp_path, name, "")
    (folder / name).write_bytes(b"\x00\x01\x02")
    with pytest.raises(ParameterError, match="binary"):
        LOADERS[name](folder)
    (folder / name).write_text("= broken")
    with pytest.raises(ParameterError, match="not valid TOML"):
        LOADERS[name](folder)


def test_a_folder_from_before_the_heels_own_threshold_keeps_its_heel_off(tmp_path: Path
                                                                          ) -> None:
    # a gait_phase.toml written before heel_off: the heel unloads at its contact_off, as
    # it did
    text = "\n".join(line for line in _shipped("gait_phase.toml").splitlines()
                     if not line.startswith("heel_off")).replace("contact_off = 0.15",
                                                                 "contact_off = 0.12")
    old = DetectorSettings.default(_folder(tmp_path, "gait_phase.toml", text))
    assert old.heel_off == old.contact_off == 0.12
    assert DetectorSettings.default().heel_off == 0.03


def test_device_folder_replaces_what_it_holds(tmp_path: Path) -> None:
    text = _shipped("sensors.toml").replace("noise = 0.005", "noise = 0.0")
    folder = _folder(tmp_path, "sensors.toml", text)
    assert FootSensors.default(1.0, folder).fsr_noise == 0.0
    assert FootSensors.default(1.0).fsr_noise == 0.005
    # the rest comes from the package
    assert Ground.default(folder) == Ground.default()
    tomllib.loads(text)


def test_unknown_file_in_a_device_folder_is_refused(tmp_path: Path) -> None:
    import exoleg
    from exoleg.sim.walk import simulate_walk

    folder = _folder(tmp_path, "sensor.toml", "x = 1")  # a typo of sensors.toml
    with pytest.raises(ParameterError, match="sensor.toml: unknown device file"):
        simulate_walk(exoleg.paper_leg(), 30.0, strides=1, device=folder)


def test_a_copy_of_the_shipped_folder_is_told_what_to_leave_out(tmp_path: Path) -> None:
    # copying the package's data/device whole brings its hip variants and the drives'
    # object dictionary along: each refused by name with what to do instead
    import shutil
    from importlib import resources

    from exoleg.device.files import check_folder

    mine = tmp_path / "mine"
    with resources.as_file(resources.files("exoleg") / "data" / "device") as shipped:
        shutil.copytree(shipped, mine)
    with pytest.raises(ParameterError, match=r"(hip-variants: the shipped hip motor's "
                                             r"variants.*actuators/hip.toml|canopen: the "
                                             r"simulated drives' object dictionary)"):
        check_folder(mine)
    shutil.rmtree(mine / "hip-variants")
    with pytest.raises(ParameterError, match="canopen: .*remove this folder"):
        check_folder(mine)
    shutil.rmtree(mine / "canopen")
    assert check_folder(mine) == mine  # the rest is the device's own files


def test_cli_device_folder(tmp_path: Path) -> None:
    folder = _folder(tmp_path, "actuators/knee.toml",
                     _shipped("actuators/knee.toml").replace("efficiency = 0.8",
                                                             "efficiency = 2.0"))
    r = subprocess.run([sys.executable, "-m", "exoleg.cli", "simulate", "--walk", "--strides",
                        "1", "--device", str(folder), "--out", str(tmp_path / "o")],
                       capture_output=True, text=True, check=False)
    assert r.returncode == 2 and "knee.toml: efficiency: 2 is outside 0.05-1" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1
    r = subprocess.run([sys.executable, "-m", "exoleg.cli", "simulate", "--device", str(folder),
                        "--out", str(tmp_path / "o")], capture_output=True, text=True,
                       check=False)
    assert r.returncode == 2 and "--device: goes with --walk or --actuators" in r.stderr
