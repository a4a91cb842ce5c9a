"""The command line: exit codes and messages, each command run as the console command
runs it (the ``here`` fixture: :func:`exoleg.cli.main` in this process, its output read at
the descriptors). What only a process of its own shows (Ctrl-C, a closed pipe, SIGTERM) is
in tests/test_honest_outputs.py and tests/test_bad_inputs.py."""

import numpy as np
import pytest


def test_validate_passes_and_prints_table(here):
    r = here("validate", "--quick")
    assert r.returncode == 0, r.stdout + r.stderr
    assert "M vs Appendix B" in r.stdout and "0 failed" in r.stdout


def test_bad_option_exits_2(here):
    r = here("validate", "--bogus")
    assert r.returncode == 2 and "unrecognized arguments" in r.stderr


def test_simulate_default_writes_everything(tmp_path, here):
    import json

    r = here("simulate", "--out", str(tmp_path), "--duration", "6")
    assert r.returncode == 0, r.stderr
    for name in ("timeseries.csv", "summary.json", "fig13.png", "fig14.png", "fig15.png"):
        assert (tmp_path / name).exists(), name
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["figures"]["exoleg_vs_MuJoCo_max_deg"] < 1e-11
    assert "detailed (2x torque) vs simplified" in r.stdout


def test_simulate_gait_with_leg_file(tmp_path, here):
    import exoleg

    leg = exoleg.save_leg(exoleg.paper_leg(), tmp_path / "leg.toml")
    r = here("simulate", "--reference", "gait", "--stride-time", "1.5", "--duration", "3",
            "--leg", str(leg), "--out", str(tmp_path / "o"), "--no-engine")
    assert r.returncode == 0, r.stderr
    assert "within Table 2" in r.stdout


def test_simulate_bad_options_are_one_line_exit_2(tmp_path, here):
    for args in (["--kp", "1,2"], ["--dt", "-1"], ["--reference", "jog"],
                 ["--leg", str(tmp_path / "missing.toml")],
                 ["--kd", "12,12,40"]):
        r = here("simulate", "--out", str(tmp_path), "--no-engine", *args)
        assert r.returncode == 2, (args, r.stderr)
        assert len(r.stderr.strip().splitlines()) == 1 and "error" in r.stderr, (args, r.stderr)


def test_fit_writes_leg_file_that_simulate_accepts(tmp_path, here):
    import exoleg

    r = here("fit", "--age", "8", "--sex", "female", "--height", "110", "--mass", "19.1",
            "--gmfcs", "4", "--out", str(tmp_path), "--no-simulate", "--write-leg")
    assert r.returncode == 0, r.stderr
    assert "DOES NOT FIT" in r.stdout and "62.8 cm" in r.stdout  # Table 1 rule: 62.8 cm
    leg = exoleg.load_leg(tmp_path / "leg.toml")
    assert leg.has_parts and leg.lengths[2] == 0.235
    assert (tmp_path / "fit.json").exists()


def test_fit_bad_child_is_one_line_exit_2(tmp_path, here):
    r = here("fit", "--age", "9", "--sex", "female", "--height", "200", "--mass", "24",
            "--gmfcs", "3", "--out", str(tmp_path))
    assert r.returncode == 2 and "height" in r.stderr and len(r.stderr.strip().splitlines()) == 1


def test_population_writes_table_and_plot(tmp_path, here):
    r = here("population", "--ages", "8,12", "--percentiles", "10,50,90", "--no-simulate",
            "--out", str(tmp_path))
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "coverage.csv").exists() and (tmp_path / "coverage.png").exists()
    assert "GMFCS IV female 8 y" in r.stdout


def test_simulate_with_actuators(tmp_path, here):
    import json

    r = here("simulate", "--actuators", "--duration", "3", "--out", str(tmp_path))
    assert r.returncode == 0, r.stderr
    for name in ("timeseries.csv", "summary.json", "actuators.png"):
        assert (tmp_path / name).exists(), name
    figs = json.loads((tmp_path / "summary.json").read_text())["figures"]
    # reflected inertia (N^2 J) shrinks the sampled margin of the paper's gains
    assert figs["sampled_stability_h_lambda"] < 0.1 < figs["sampled_stability_without_actuators"]
    assert [p["joint"] for p in figs["peaks"]] == ["hip", "knee", "ankle"]
    header = (tmp_path / "timeseries.csv").read_text().splitlines()[0].split(",")
    assert {"tau_ankle", "u_safe_knee", "envelope_hip", "motor_speed_hip",
            "safety_status"} <= set(header)
    assert "armature kg m^2" in r.stdout
    # the motors' and gears' figures: the winding from 25 degC, the gear's load against
    # its momentary peak (S10: 108 / 70 / 108 N m)
    assert [p["momentary_peak_Nm"] for p in figs["peaks"]] == [108.0, 70.0, 108.0]
    assert all(25.0 <= p["winding_max_C"] < p["winding_limit_C"] for p in figs["peaks"])


def test_simulate_with_a_hip_variant(tmp_path, here):
    import json

    # Reference: data/device/hip-variants/ec90flat-90w.toml (S1: the 90 W frame's 3060
    # g cm^2 rotor, reflected through 1:100 with the gear's 79 g cm^2: 3.139 kg m^2)
    r = here("simulate", "--actuators", "--duration", "1", "--no-engine",
            "--hip-motor", "ec90flat-90w", "--out", str(tmp_path))
    assert r.returncode == 0, r.stderr
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert "90 W" in summary["actuators"][0]["motor"]
    hip = summary["figures"]["peaks"][0]
    assert hip["reflected_inertia_kg_m2"] == pytest.approx(100**2 * (3060e-7 + 0.079e-4))
    r = here("simulate", "--hip-motor", "ec90flat-90w", "--out", str(tmp_path / "x"))
    assert r.returncode == 2 and "goes with --walk or --actuators" in r.stderr


def test_simulate_with_actuators_bad_options(tmp_path, here):
    for args, text in ((["--saturate"], "does not apply with --actuators"),
                       (["--dt", "0.0003"], "must divide the control period")):
        r = here("simulate", "--actuators", "--out", str(tmp_path), *args)
        assert r.returncode == 2 and text in r.stderr, r.stderr


def test_simulate_walk(tmp_path, here):
    import json

    r = here("simulate", "--walk", "--strides", "3", "--out", str(tmp_path))
    assert r.returncode == 0, r.stderr
    for name in ("timeseries.csv", "summary.json", "walk.png"):
        assert (tmp_path / name).exists(), name
    figs = json.loads((tmp_path / "summary.json").read_text())["figures"]
    assert not figs["safety_fault"]
    assert [row["event"] for row in figs["gait_phase_detection"]] == [
        "initial contact", "foot flat", "heel off", "toe off"]
    assert figs["swing_touches_s"] == []  # the paper's leg lands once a stride
    header = (tmp_path / "timeseries.csv").read_text().splitlines()[0].split(",")
    assert {"fsr_heel", "phase", "true_events", "gyro", "motor_speed_knee", "power_ankle",
            "pelvis"} <= set(header)
    assert "gait-phase detection" in r.stdout


def test_simulate_walk_with_a_sensor_fault(tmp_path, here):
    # the heel's sensor dead from 1.5 s: the controller read 0 from then (the
    # timeseries' readings are what it read) and summary.json names the fault
    import json

    r = here("simulate", "--walk", "--strides", "2", "--sensor-fault", "heel:dead@1.5",
            "--out", str(tmp_path))
    assert r.returncode == 0, r.stderr
    assert "heel reads 0 from 1.5 s" in r.stdout
    figs = json.loads((tmp_path / "summary.json").read_text())["figures"]
    assert figs["sensor_faults"] == ["heel reads 0 from 1.5 s"]
    data = np.genfromtxt(tmp_path / "timeseries.csv", delimiter=",", names=True)
    after = data["t"] >= 1.5
    assert np.all(data["fsr_heel"][after] == 0.0) and data["fsr_heel"][~after].max() > 100.0


def test_simulate_walk_with_a_child_under_assist_as_needed(tmp_path, here):
    # the issue's summary fields and figures: the cuffs' torque per kg per joint, one
    # support value per stride (0-1), the safety layer's events (a list)
    import json

    from exoleg.child.model import ChildModel

    ChildModel("c", 10.0, 1.4, 32.0).save(tmp_path / "child.toml")
    r = here("simulate", "--walk", "--child", str(tmp_path / "child.toml"), "--controller",
            "aan", "--strides", "6", "--out", str(tmp_path / "w"))
    assert r.returncode == 0, r.stderr
    assert (tmp_path / "w" / "support.png").exists()
    figs = json.loads((tmp_path / "w" / "summary.json").read_text())["figures"]
    assert figs["controller"] == "aan"
    assert set(figs["interaction_torque_rms_per_kg"]) == {"hip", "knee", "ankle"}
    s = figs["support_by_stride"]
    assert len(s) >= 4 and all(0.0 <= v <= 1.0 for v in s) and s[-1] < s[0]
    assert isinstance(figs["safety_events"], list)
    header = (tmp_path / "w" / "timeseries.csv").read_text().splitlines()[0].split(",")
    assert {"support_mode", "support_level_hip", "transparent_inertia_knee"} <= set(header)
    assert figs["assist_law"] == "error" and "assist_gain_by_stride" not in figs
    # OpenExo's law from a device folder holding only its assist.toml: K per stride, in
    # its clip (assist.toml: 0.75-1.25), 1 where nothing is asked (hip and knee)
    from importlib import resources

    dev = tmp_path / "device"
    dev.mkdir()
    text = resources.files("exoleg").joinpath("data", "device", "assist.toml").read_text()
    (dev / "assist.toml").write_text(text.replace('law = "error"', 'law = "proportional"'))
    r = here("simulate", "--walk", "--child", str(tmp_path / "child.toml"), "--controller",
            "aan", "--strides", "3", "--device", str(dev), "--out", str(tmp_path / "p"))
    assert r.returncode == 0, r.stderr
    figs = json.loads((tmp_path / "p" / "summary.json").read_text())["figures"]
    k = figs["assist_gain_by_stride"]
    assert figs["assist_law"] == "proportional" and k["hip"] == k["knee"] == [1.0] * len(
        k["ankle"]) and all(0.75 <= x <= 1.25 for x in k["ankle"])
    for args, text in ((["--controller", "aan"], "does not go with the paper's scenario"),
                       (["--walk", "--controller", "pd"], "does not go with --walk"),
                       (["--walk", "--controller", "transparent"], "give --child")):
        r = here("simulate", *args, "--out", str(tmp_path / "x"))
        assert r.returncode == 2 and text in r.stderr, (args, r.stderr)


def test_simulate_walk_bad_options(tmp_path, here):
    for args, text in ((["--walk", "--kp", "1,2,3"], "does not apply with --walk"),
                       (["--walk", "--reference", "gait"], "does not apply with --walk"),
                       (["--walk", "--duration", "5"], "does not apply with --walk"),
                       (["--walk", "--actuators"], "not allowed with argument"),
                       (["--device", "."], "goes with --walk or --actuators"),
                       (["--walk", "--strides", "0"], "0 is outside 1-10000"),
                       (["--walk", "--strides", "many"], "expected a whole number"),
                       (["--walk", "--body-mass", "500"], "outside 10-150"),
                       (["--strides", "3"], "goes with --walk"),
                       (["--sensor-fault", "heel:dead"], "goes with --walk"),
                       (["--walk", "--sensor-fault", "toe:dead"], "'toe' is not one of heel"),
                       (["--walk", "--sensor-fault", "heel:dead@soon"], "not a number"),
                       (["--walk", "--sensor-fault", "heel:offset=2"], "2 is outside -1-1"),
                       (["--walk", "--sensor-fault", "heel dead"], "no ':' between"),
                       # accepted, and changed nothing: a value the kind has no use for, a
                       # fault after the walk, an insole the other foot does not wear
                       (["--walk", "--sensor-fault", "heel:missing=0.5"], "missing takes no "
                        "value"),
                       (["--walk", "--strides", "2", "--sensor-fault", "heel:dead@9"],
                        "starts after the walk ends (3.2 s)"),
                       (["--walk", "--strides", "2", "--sensor-fault", "insole:dead@1"],
                        "no insole is fitted to the other foot")):
        r = here("simulate", "--out", str(tmp_path), *args)
        assert r.returncode == 2 and text in r.stderr, (args, r.stderr)
        assert len(r.stderr.strip().splitlines()) == 1


def test_validate_gait_phase_table(here):
    r = here("validate", "--gait-phase", "--strides", "3")
    assert r.returncode in (0, 1), r.stderr  # 1: a walk was stopped by the safety layer
    assert "gait-phase detection (FSRs and the foot's gyroscope) against the true " \
        "contacts" in r.stdout
    assert "sensor faults, replayed through the detector" in r.stdout
    assert "walking slowly, strides of 4 s" in r.stdout
    assert "strides of 4 s: each source alone" in r.stdout
    assert "walking, then a controlled stop (x1 noise): both sources and each alone" in r.stdout
    assert "sensor faults injected into the walks (closed loop" in r.stdout
    assert "Catalfamo" in r.stdout
