"""Bad input on the newer surfaces (issue 44, the first cases): special files refused
before they are read, a walk that would never come refused, a recording's clock checked,
names that survive their own file.

Reference: the issue's audit -- a named pipe given as ``--child``, to ``detect`` or to
``log summary`` blocked forever; ``--walk-after`` later than ``--duration`` was accepted
and the walk never came; ``detect`` found 0 events, exit 0, on a recording whose times
are negative or run backwards; ``fit --name`` with a quote, a backslash, a control
character or a newline wrote a ``child.toml`` no command loads.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import exoleg
from conftest import EXOLEG, REALTIME
from exoleg.cli import main

#: sessions of seconds ask for the loop's real-time settings where the OS permits them
#: (conftest.REALTIME; at normal priority a session elsewhere in the suite was stalled
#: 292 ms with its workers on both cores, beyond the then 250 ms overrun limit)
NO_RT = [] if REALTIME else ["--no-realtime"]


def _exoleg(*args: str, timeout: float = 60) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "exoleg.cli", *args], capture_output=True,
                          text=True, check=False, timeout=timeout)


@pytest.mark.parametrize("argv", [
    ["simulate", "--walk", "--strides", "1", "--child", "{fifo}", "--out", "{tmp}/o"],
    ["detect", "{fifo}", "--out", "{tmp}/e.csv"],
    ["log", "summary", "{fifo}"],
    ["fit", "--age", "10", "--sex", "male", "--height", "140", "--mass", "32",
     "--no-simulate", "--device", "{tmp}/dev", "--out", "{tmp}/o"],
])
def test_a_named_pipe_is_refused_before_it_is_read(tmp_path: Path, argv: list[str]) -> None:
    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    (tmp_path / "dev" / "actuators").mkdir(parents=True)
    os.mkfifo(tmp_path / "dev" / "actuators" / "hip.toml")
    args = [a.format(fifo=fifo, tmp=tmp_path) for a in argv]
    r = _exoleg(*args, timeout=60)  # before: blocked until the timeout
    assert r.returncode == 2, r.stderr
    assert "is a named pipe" in r.stderr and "give a regular file" in r.stderr
    assert len(r.stderr.strip().splitlines()) == 1


def test_a_walk_after_the_session_ends_is_refused(tmp_path: Path,
                                                  capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["run", "--backend", "sim", "--duration", "1", "--arm", "--walk-after", "2",
                 "--no-realtime", "--out", str(tmp_path / "s")]) == 2
    err = capsys.readouterr().err
    assert "--walk-after: 2 s is not before the session's end (1 s)" in err
    assert not (tmp_path / "s" / "session.log").exists()


@pytest.fixture(scope="module")
def walk() -> exoleg.sim.walk.WalkResult:
    from exoleg.sim.walk import simulate_walk

    return simulate_walk(exoleg.paper_leg(), 30.0, strides=3, seed=3)


def _csv(path: Path, t: np.ndarray, fsr: np.ndarray) -> Path:
    from exoleg.tick import SENSOR_POINTS

    cols = {"t": t, **{s: fsr[:, i] for i, s in enumerate(SENSOR_POINTS)}}
    with path.open("w") as f:
        f.write(",".join(cols) + "\n")
        for k in range(len(t)):
            f.write(",".join(format(cols[n][k], ".9g") for n in cols) + "\n")
    return path


def test_a_recording_that_starts_at_any_time_gives_the_same_events(walk, tmp_path: Path  # type: ignore[no-untyped-def]
                                                                    ) -> None:
    # the detector's clock is the time since the recording's start: a clock that reads
    # -5 s at the start (a logger's own epoch) shifts the events, it does not lose them
    times = {}
    for shift in (0.0, -5.0, 1000.0):
        rec = _csv(tmp_path / f"r{shift:g}.csv", walk.t + shift, walk.fsr)
        out = tmp_path / f"e{shift:g}.csv"
        assert main(["detect", str(rec), "--counts", "--out", str(out)]) == 0
        rows = [ln.split(",") for ln in out.read_text().splitlines()[1:]]
        times[shift] = np.array([float(t) for t, _ in rows]) - shift
    assert len(times[0.0]) >= 12
    for shift in (-5.0, 1000.0):
        assert np.allclose(times[shift], times[0.0], atol=1e-6)


def test_a_session_log_whose_clock_runs_backwards_is_refused(tmp_path: Path,
                                                            capsys: pytest.CaptureFixture[str]
                                                            ) -> None:
    from exoleg.session_log import SessionLog

    cols = ["t"] + [f"fsr_{s}" for s in ("heel", "met1", "met5", "hallux")]
    log = SessionLog(tmp_path / "session.log", cols, {"period": 1e-3})
    for k, t in enumerate([0.0, 0.001, 0.002, 0.0015, 0.004]):
        log.append(np.array([t, 100.0 + k, 0.0, 0.0, 0.0]))
    log.close()
    assert main(["detect", str(tmp_path), "--out", str(tmp_path / "e.csv")]) == 2
    err = capsys.readouterr().err
    assert "t: tick 3: 0.0015 s does not follow 0.002 s" in err
    assert not (tmp_path / "e.csv").exists()


@pytest.mark.parametrize("name", ['Ada "A." Lovelace', "back\\slash", "line\nbreak = 1",
                                  "bell\x07", "del\x7f", "tab\tand é"])
def test_a_childs_name_survives_its_own_file(tmp_path: Path, name: str) -> None:
    from exoleg.child.model import ChildModel

    assert main(["fit", "--age", "10", "--sex", "male", "--height", "140", "--mass", "32",
                 "--no-simulate", "--name", name, "--out", str(tmp_path / "f")]) == 0
    child = ChildModel.load(tmp_path / "f" / "child.toml")
    assert child.name == name
    leg = exoleg.load_leg(tmp_path / "f" / "leg.toml")
    assert name in leg.name


def test_a_blank_name_in_the_console_is_the_default_and_its_child_file_loads(
        tmp_path: Path) -> None:
    # every child model now refuses a blank name (a child file with one loaded as the
    # child's name): the console's form, which kept "   " as the name, writes 'child',
    # and a record kept with one before still makes a child model
    from exoleg.child.model import ChildModel
    from exoleg.hmi.child_form import actor_model, fit_of_form

    child, _, actor, _ = fit_of_form({"age": "10", "height": "140", "mass": "32",
                                      "sex": "male", "name": "   "})
    assert child.name == "child"
    model = actor_model({"name": "  ", "age": 10, "height": 1.4, "mass": 32, "sex": "male",
                         "gmfcs": 0}, actor)
    model.save(tmp_path / "child.toml")
    assert ChildModel.load(tmp_path / "child.toml").name == "child"
    # a name longer than any name is refused where a child is made, said as such (any
    # characters are kept: test_a_childs_name_survives_its_own_file)
    from exoleg.errors import ParameterError
    from exoleg.sizing import Child

    with pytest.raises(ParameterError, match="name: 101 characters: a child's name has at "
                                             "most 100"):
        Child(age=10, sex="male", height=1.4, mass=32, name="a" * 101)


@pytest.mark.parametrize("command", [["run", "--backend", "sim", "--duration", "0.1",
                                      "--no-realtime"], ["simulate", "--walk", "--strides", "1"]])
def test_a_body_mass_beside_a_child_file_that_says_otherwise_is_refused(
        tmp_path: Path, command: list[str], capsys: pytest.CaptureFixture[str]) -> None:
    assert main(["fit", "--age", "10", "--sex", "male", "--height", "140", "--mass", "32",
                 "--no-simulate", "--out", str(tmp_path / "f")]) == 0
    capsys.readouterr()
    assert main([*command, "--child", str(tmp_path / "f" / "child.toml"), "--body-mass", "45",
                 "--out", str(tmp_path / "o")]) == 2
    assert "--body-mass: 45 kg, but the child file says 32 kg" in capsys.readouterr().err


def test_a_log_whose_records_do_not_hold_what_its_header_names_is_not_summarised(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    from exoleg.runtime.loop import LOG_HEAD, LOG_TAIL
    from exoleg.session_log import SessionLog

    cols = LOG_HEAD + LOG_TAIL
    log = SessionLog(tmp_path / "session.log", cols, {"period": 1e-3})
    for k in range(5):
        row = np.zeros(len(cols))
        row[0] = k * 1e-3
        if k == 3:
            row[cols.index("mode")] = np.nan
        log.append(row)
    log.close()
    assert main(["log", "summary", str(tmp_path)]) == 2
    assert "mode: tick 3 holds nan: the log is damaged" in capsys.readouterr().err


def test_a_diverged_pendulum_test_is_refused_not_written(tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]
                                                         ) -> None:
    # the audit's case: severe spasticity with the predictcpgait contracture at its top
    # level (1.5) reported a resting angle of -5.3e32 deg, exit 0
    assert main(["fit", "--age", "10", "--sex", "male", "--height", "140", "--mass", "32",
                 "--gmfcs", "2", "--spasticity", "severe", "--contracture", "predictcpgait",
                 "--no-simulate", "--out", str(tmp_path / "f")]) == 0
    child = tmp_path / "f" / "child.toml"
    child.write_text(child.read_text().replace("contracture_level = 1 ",
                                               "contracture_level = 1.5 "))
    capsys.readouterr()
    assert main(["assess", "--child", str(child), "--test", "pendulum", "--out",
                 str(tmp_path / "p")]) == 1  # a run that failed (exit 1), not a bad option
    err = capsys.readouterr().err
    assert err.startswith("exoleg: failed: the pendulum test of") and "diverged" in err
    assert "level 1.5" in err
    assert not (tmp_path / "p").exists()


@pytest.mark.parametrize("command", [["hmi"], ["run", "--backend", "sim", "--duration", "1",
                                                "--hmi"]])
def test_a_certificate_the_server_cannot_use_is_said_at_once(tmp_path: Path,
                                                             command: list[str]) -> None:
    # before: "did not start within 60 s" (exoleg run --hmi) -- the child process died
    pem = tmp_path / "cert.pem"
    pem.write_text("-----BEGIN CERTIFICATE-----\nnot a certificate\n-----END CERTIFICATE-----\n")
    r = _exoleg(*command, "--tls-cert", str(pem), "--tls-key", str(pem), "--out" if
                command[0] == "run" else "--sessions", str(tmp_path / "o"), timeout=30)
    assert r.returncode == 2, r.stderr
    assert "cannot serve https" in r.stderr and len(r.stderr.strip().splitlines()) == 1


@pytest.mark.parametrize("as_file", [False, True])
def test_a_scheduler_that_is_not_dasks_is_said_within_its_bound(
        tmp_path: Path, as_file: bool, monkeypatch: pytest.MonkeyPatch,
        capsys: pytest.CaptureFixture[str]) -> None:
    # before: a server that accepts the connection and says nothing held the sweep forever
    import json
    import socket
    import threading
    import time

    from exoleg.study import engine

    monkeypatch.setattr(engine, "SCHEDULER_ANSWER_S", 1.0)
    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(8)
    held: list[socket.socket] = []
    threading.Thread(target=lambda: held.append(server.accept()[0]), daemon=True).start()
    address = f"tcp://127.0.0.1:{server.getsockname()[1]}"
    where = address
    if as_file:
        where = str(tmp_path / "scheduler.json")
        Path(where).write_text(json.dumps({"address": address}))
    t0 = time.monotonic()
    study = Path(__file__).parents[1] / "examples" / "sweep-small.toml"
    assert main(["sweep", str(study), "--out", str(tmp_path / "s"), "--scheduler", where]) == 2
    assert time.monotonic() - t0 < 10.0
    err = capsys.readouterr().err
    assert "said nothing as Dask within 1 s" in err
    assert not (tmp_path / "s").exists()
    server.close()


def test_a_file_that_is_not_a_scheduler_file_is_said(tmp_path: Path,
                                                     capsys: pytest.CaptureFixture[str]
                                                     ) -> None:
    bad = tmp_path / "scheduler.json"
    bad.write_text("[1, 2]")
    study = Path(__file__).parents[1] / "examples" / "sweep-small.toml"
    assert main(["sweep", str(study), "--out", str(tmp_path / "s"), "--scheduler",
                 str(bad)]) == 2
    assert "not a Dask scheduler file" in capsys.readouterr().err


def test_a_log_summary_reads_as_people_read(tmp_path: Path,
                                            capsys: pytest.CaptureFixture[str]) -> None:
    # before: raw dictionaries, mode numbers and unrounded floats
    # ("late_p50_us 0.028016...")
    assert main(["run", "--backend", "sim", "--duration", "3", "--arm", "--walk-after", "1",
                 *NO_RT, "--out", str(tmp_path / "s")]) == 0
    capsys.readouterr()
    assert main(["log", "summary", str(tmp_path / "s")]) == 0
    out = capsys.readouterr().out
    import re

    rows = dict(m.groups() for ln in out.splitlines()
                if (m := re.match(r"\s*(\w+)\s{2,}(\S.*?)\s*$", ln)))
    assert "standing" in rows["ticks_per_mode"] and "walking" in rows["ticks_per_mode"]
    assert "{" not in out and "}" not in out
    assert rows["winding_max_C"].startswith("hip ")

    for number in re.findall(r"\d+\.\d+", out):
        assert len(number.replace(".", "").lstrip("0")) <= 4, number


def test_a_walk_asked_at_once_waits_for_the_foots_contact(tmp_path: Path,
                                                          capsys: pytest.CaptureFixture[str]
                                                          ) -> None:
    # Issue 44: `run --arm --walk-after 0` (or 0.001) faulted the ankle 0.655 s in
    # (HARD_LIMIT): the gait started before the detector knew the foot's contact (the
    # FSRs' 8 ms debounce), from an unknown phase. The walk now waits for it: through the
    # CLI no fault; by fault injection into the controller the mode stays STANDING until
    # the detector has a phase, then walks, and a foot board that never says is refused.
    from exoleg.control.hierarchy import WALK_WAIT, WalkController
    from exoleg.device import with_actuators
    from exoleg.tick import Command, Fault, Mode, Phase

    assert main(["run", "--backend", "sim", "--arm", "--walk-after", "0", "--duration", "2",
                 *NO_RT, "--out", str(tmp_path / "run")]) == 0
    assert "FAULT" not in capsys.readouterr().out
    ctl = WalkController(with_actuators(exoleg.paper_leg()), 20.0)
    q = ctl.gains.standing.copy()
    loaded = {"q": q, "dq": np.zeros(3), "fsr": np.array([1500.0, 800, 600, 300])}
    out = ctl.update(loaded, Command.ARM, 0.0)
    out = ctl.update(loaded, Command.WALK, 0.001)
    assert out["mode"] == Mode.STANDING and out["phase"] == Phase.UNKNOWN
    k = 2
    while out["mode"] == Mode.STANDING:
        out = ctl.update(loaded, Command.NONE, k * 1e-3)
        k += 1
    assert out["mode"] == Mode.WALKING and out["phase"] != Phase.UNKNOWN
    assert k * 1e-3 <= 0.012 and out["fault"] == Fault.NONE  # the 8 ms debounce, and a tick
    # a board that never reads a contact either way: the walk waits WALK_WAIT, then is
    # refused, and the device stands
    ctl = WalkController(with_actuators(exoleg.paper_leg()), 20.0)
    ctl.st[0]["phase"] = Phase.UNKNOWN
    ctl.update(loaded, Command.ARM, 0.0)
    refused = None
    for k in range(1, int(WALK_WAIT * 1e3) + 5):
        ctl.st[0]["phase"] = Phase.UNKNOWN  # fault injection: the detector never knows
        out = ctl.update(loaded, Command.WALK if k == 1 else Command.NONE, k * 1e-3)
        assert out["mode"] == Mode.STANDING
        refused = refused or (out["refused"] == Command.WALK and k)
    assert refused and 0.0 < (refused - 1) * 1e-3 - WALK_WAIT <= 0.0015  # asked at k = 1


def test_no_command_writes_over_a_file_it_did_not_write(tmp_path: Path,
                                                        capsys: pytest.CaptureFixture[str]
                                                        ) -> None:
    # Issue 44: `identify --out FITDIR` replaced the fit's leg.toml; `assess --out WALKDIR`
    # a walk's summary.json. An output folder records which command wrote each file
    # (.exoleg-outputs.json): a file another command -- or the user -- put there is never
    # written over, and the refusal comes before any work (identification: before the
    # plan moves the child); a command's own files from its last run it replaces, and
    # removes those it no longer writes.
    from exoleg.io import OUTPUTS

    fit = tmp_path / "fit"
    child = ["--age", "10", "--sex", "female", "--height", "138", "--mass", "32"]
    assert main(["fit", *child, "--no-simulate", "--out", str(fit)]) == 0
    leg = (fit / "leg.toml").read_text()
    assert main(["identify", "--backend", "sim", "--leg", str(fit / "leg.toml"),
                 "--out", str(fit)]) == 2
    err = capsys.readouterr().err
    assert "leg.toml is there already (written by exoleg fit): exoleg identify does not " \
           "write over it -- name another folder with --out" in err
    assert (fit / "leg.toml").read_text() == leg and not (fit / "session").exists()
    walk = tmp_path / "walk"
    assert main(["simulate", "--walk", "--strides", "1", "--out", str(walk)]) == 0
    summary = (walk / "summary.json").read_text()
    assert main(["assess", "--child", str(fit / "child.toml"), "--test", "pendulum",
                 "--out", str(walk)]) == 2
    assert "summary.json is there already (written by exoleg simulate)" in \
        capsys.readouterr().err
    assert (walk / "summary.json").read_text() == summary
    # the user's own file, never recorded: refused too
    mine = tmp_path / "mine"
    mine.mkdir()
    (mine / "fit.json").write_text("my notes")
    assert main(["fit", *child, "--no-simulate", "--out", str(mine)]) == 2
    assert "fit.json is there already (not recorded as exoleg's: yours, or an older " \
           "exoleg's)" in capsys.readouterr().err
    assert (mine / "fit.json").read_text() == "my notes"
    # the same command again: its own files replaced; an assessment's figure of another
    # test, no longer described by the new summary, removed
    out = tmp_path / "assess"
    for test in ("pendulum", "stretch"):
        assert main(["assess", "--child", str(fit / "child.toml"), "--test", test,
                     "--out", str(out)]) == 0
    assert (out / "stretch.png").exists() and not (out / "pendulum.png").exists()
    assert '"stretch.png": "exoleg assess"' in (out / OUTPUTS).read_text()


def test_a_dead_foot_board_stops_the_walk_as_on_the_device(tmp_path: Path,
                                                            capsys: pytest.CaptureFixture[str]
                                                            ) -> None:
    # Issue 44: `simulate --walk --sensor-fault board:dead` walked on blind (every gait
    # event missed, the knee 53 deg RMS off, no fault, no note). The simulated walk now
    # watches the foot board as the runtime does (runtime.watch.SensorWatch: its four
    # FSRs and the gyro repeating bit for bit for FROZEN_S) and takes the torque off.
    from exoleg.device.sensors import FROZEN_S

    out = tmp_path / "dead"
    assert main(["simulate", "--walk", "--strides", "3", "--sensor-fault", "board:dead@2",
                 "--out", str(out)]) == 1
    said = capsys.readouterr().out
    assert f"the foot board's readings froze -- every sensor repeating bit for bit for " \
           f"{FROZEN_S:g} s -- at t = {2 + FROZEN_S:.3f} s" in said
    import json

    figures = json.loads((out / "summary.json").read_text())["figures"]
    assert figures["safety_fault"] and figures["board_frozen_s"] == pytest.approx(2.25)
    # ideal sensors (no noise) repeat while standing: not watched, no false stop
    assert main(["simulate", "--walk", "--strides", "2", "--noise", "0", "--out",
                 str(tmp_path / "ideal")]) == 0


def test_a_child_file_beside_another_childs_leg_is_refused(tmp_path: Path,
                                                           capsys: pytest.CaptureFixture[str]
                                                           ) -> None:
    # Issue 44: a 1.80 m / 70 kg child.toml walked, ran and was identified on a leg fitted
    # for 1.40 m / 32 kg. exoleg fit now writes the child's height and mass into the leg's
    # [fit] record, and every command that takes both compares them.
    small, big = tmp_path / "small", tmp_path / "big"
    assert main(["fit", "--age", "10", "--sex", "female", "--height", "140", "--mass", "32",
                 "--no-simulate", "--out", str(small)]) == 0
    assert main(["fit", "--age", "12", "--sex", "male", "--height", "150", "--mass", "45",
                 "--no-simulate", "--out", str(big)]) == 0
    capsys.readouterr()
    says = (f"the child file is for a 1.50 m, 45 kg child; {small / 'leg.toml'} was fitted "
            "for 1.40 m, 32 kg")
    for argv in (["simulate", "--walk", "--strides", "1", "--out", str(tmp_path / "w")],
                 ["run", "--backend", "sim", "--duration", "0.2", "--no-realtime", "--out",
                  str(tmp_path / "r")],
                 ["identify", "--backend", "sim", "--out", str(tmp_path / "i")]):
        assert main([*argv, "--leg", str(small / "leg.toml"), "--child",
                     str(big / "child.toml")]) == 2, argv
        assert says in capsys.readouterr().err, argv
    assert not any((tmp_path / n).exists() for n in ("w", "r", "i"))


@pytest.mark.parametrize(("height", "mass", "z"), [(0.70, 150.0, "+50.8"), (1.40, 15.0, "-7.3")])
def test_a_height_and_mass_no_child_has_together_are_refused(tmp_path: Path,
                                                             capsys: pytest.CaptureFixture[str],
                                                             height: float, mass: float,
                                                             z: str) -> None:
    # Issue 44: a 150 kg child of 0.70 m was accepted. Reference: the WHO 2007 BMI-for-age
    # reference shipped (data/growth), and the WHO's flag for implausible values, |z| > 5.
    child = tmp_path / "child.toml"
    child.write_text(f'[child]\nname = "x"\nage_years = 10\nheight_m = {height}\n'
                     f'mass_kg = {mass}\nsex = "female"\n')
    assert main(["assess", "--child", str(child), "--test", "pendulum", "--out",
                 str(tmp_path / "a")]) == 2
    err = capsys.readouterr().err
    assert f"{z} SD from the WHO 2007 reference at 10 y: not a child's" in err
    assert not (tmp_path / "a").exists()


def test_a_number_where_a_table_belongs_is_named(tmp_path: Path,
                                                 capsys: pytest.CaptureFixture[str]) -> None:
    # Issue 44: internal errors (a TypeError, no field) when a file held a number where a
    # table or list belongs: a leg file's `part = 5`, a child.toml whose table is an
    # integer. Each is one line naming the file, the field and what is allowed.
    leg = tmp_path / "leg.toml"
    leg.write_text('name = "x"\n[[link]]\nname = "thigh"\nlength = 0.3\npart = 5\n'
                   + "".join(f'[[link]]\nname = "{n}"\nlength = 0.3\nmass = 1.0\n'
                             'com = [0.1, 0.0]\nizz = 0.01\n' for n in ("shank", "foot")))
    assert main(["export", "--leg", str(leg), "--out", str(tmp_path / "x.urdf")]) == 2
    assert "link[0]: part: expected [[link.part]] tables (each with mass, com, izz), got " \
           "int '5'" in capsys.readouterr().err
    child = tmp_path / "child.toml"
    for text, says in (("child = 5\n", "[child]: (table): expected a table of age_years"),
                       ('effort = 5\n[child]\nage_years = 10\nheight_m = 1.38\nmass_kg = 32\n'
                        'sex = "female"\n', "[effort]: (table): expected a table of on")):
        child.write_text(text)
        assert main(["assess", "--child", str(child), "--test", "pendulum", "--out",
                     str(tmp_path / "a")]) == 2
        assert says in capsys.readouterr().err


def test_a_centre_of_mass_outside_its_segment_is_refused(tmp_path: Path,
                                                         capsys: pytest.CaptureFixture[str]
                                                         ) -> None:
    # Issue 44: a child's thigh whose centre of mass lay 0.29 m off the axis of its 0.31 m
    # link was accepted (the rule allowed one link length from it). A segment's mass lies
    # within it: at most half the link's length off its axis (leg_file.AXIS_SHARE).
    from exoleg.params.leg_file import parse_leg_text

    text = ('name = "x"\n' + "".join(
        f'[[link]]\nname = "{n}"\nlength = 0.31\nmass = 2.0\ncom = [0.12, {y}]\nizz = 0.02\n'
        for n, y in (("thigh", 0.29), ("shank", 0.0), ("foot", 0.0))))
    with pytest.raises(exoleg.ParameterError, match=r"lies 0.29 m off the 0.31 m link's axis; "
                       r"allowed at most 0.5 of its length \(0.155 m\)"):
        parse_leg_text(text, "leg.toml")
    parse_leg_text(text.replace("0.29", "0.15"), "leg.toml")  # within: accepted


def test_a_study_of_a_million_runs_starts_at_once(tmp_path: Path) -> None:
    # Issue 44: a study of 1.5-1.9 million runs took 65 s and 2.1 GB before its first
    # task: every run's values were built first. The runs are now built task by task from
    # their index (study.spec.Runs: the grid decoded, last axis fastest). Reference: the
    # same grid's runs from itertools.product, at indices spread over the study, and every
    # run of a small study as before (expand).
    import itertools
    import time as clock

    from exoleg.study.engine import tasks_of
    from exoleg.study.spec import load_study

    ages = [round(8.0 + 0.04 * i, 2) for i in range(100)]
    pct = [float(p) for p in range(1, 100)]
    buses = [10.0 + 2.5 * k for k in range(15)]
    study = tmp_path / "big.toml"
    study.write_text('[study]\nname = "big"\nsampling = "grid"\nruns_per_task = 8\n[axes]\n'
                     f"age = {ages}\npercentile = {pct}\nbus_voltage = {buses}\n"
                     'sex = ["female", "male"]\nspeed = ["Slow", "Free", "Fast", "VeryFast", '
                     '"VerySlow"]\n')
    import tracemalloc

    s = load_study(study)
    tracemalloc.start()
    t0 = clock.perf_counter()
    tasks = tasks_of(s)
    first = tasks[0]
    took = clock.perf_counter() - t0
    peak = tracemalloc.get_traced_memory()[1]
    tracemalloc.stop()
    n = 100 * 99 * 15 * 2 * 5
    assert len(tasks) == n // 8 and first[0][0] == 0
    # measured: 0.2 ms and 9 kB (every run built first: 1.5 GB and 12 s, traced)
    assert peak < 10e6 and took < 1.0, (peak, took)
    grid = list(itertools.product(ages, pct, buses, ["female", "male"],
                                  ["Slow", "Free", "Fast", "VeryFast", "VerySlow"]))
    for i in (0, 1, 7, 12345, n // 2, n - 1):
        t, j = divmod(i, 8)
        rid, run = tasks[t][j]
        assert rid == i
        assert (run["age"], run["percentile"], run["bus_voltage"], run["sex"],
                run["speed"]) == grid[i]


def test_a_studys_cost_is_said_before_it_starts(tmp_path: Path,
                                                terminal_ctrl_c: Any) -> None:
    # Issue 44: a study's cost (runs, memory, time) said before it starts. A study of
    # TIME_FROM_RUNS runs or more has one run timed here first; the line comes before
    # the cluster (its dashboard's line).
    from exoleg.study.engine import TIME_FROM_RUNS

    study = tmp_path / "s.toml"
    study.write_text('[study]\nname = "cost"\nsampling = "grid"\nstrides = 3\n[axes]\n'
                     "age = [8, 9, 10, 11, 12]\nsex = [\"female\", \"male\"]\n"
                     "percentile = [10, 25, 50, 75, 90]\nspeed = [\"Slow\", \"Free\"]\n"
                     "group = [\"TD\", \"GMFCS I\"]\n")
    n = 5 * 2 * 5 * 2 * 2
    assert n >= TIME_FROM_RUNS
    # read as it is printed, and the study interrupted once its cluster is said: the
    # lines are what comes before it (run whole, its 200 runs took 18 s of the suite)
    p = subprocess.Popen([EXOLEG, "sweep", str(study), "--out", str(tmp_path / "out"),
                          "--workers", "1"], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, preexec_fn=terminal_ctrl_c,
                         env={**os.environ, "PYTHONUNBUFFERED": "1"})
    try:
        lines = [p.stdout.readline().rstrip("\n") for _ in range(3)]  # type: ignore[union-attr]
        p.send_signal(signal.SIGINT)
        _, err = p.communicate(timeout=120)
    finally:
        p.kill()
    assert p.returncode == 130 and "Traceback" not in err, (p.returncode, err)
    assert f"{n:,} runs of 3 strides" in lines[0], lines
    cost = lines[1]
    assert cost.startswith("cost: results about 0.2 MB; one run takes "), cost  # 1 kB a row
    assert f"(measured): {n:,} runs on 1 worker(s), about " in cost, cost
    assert lines[2].startswith("Dask's dashboard")  # said before the cluster starts


def test_damaged_study_files_are_named_and_recomputed(tmp_path: Path,
                                                      capsys: pytest.CaptureFixture[str]
                                                      ) -> None:
    # Issue 44: a damaged Parquet file, study.toml or study.json gave internal errors
    # (ArrowInvalid, UnicodeDecodeError, JSONDecodeError) under --summary and --out.
    import shutil

    study = tmp_path / "s.toml"
    study.write_text('[study]\nname = "d"\nsampling = "grid"\nstrides = 2\nruns_per_task = 2\n'
                     '[axes]\nage = [8, 10]\nsex = ["female", "male"]\n')
    out = tmp_path / "out"
    assert main(["sweep", str(study), "--out", str(out), "--workers", "1"]) == 0
    whole = (out / "data" / "task-000001.parquet").read_bytes()
    (out / "data" / "task-000001.parquet").write_bytes(b"not parquet")
    capsys.readouterr()
    assert main(["sweep", "--summary", str(out)]) == 2
    assert ("1 result file(s) damaged (data/task-000001.parquet): run the study again"
            in capsys.readouterr().err)
    # the same command computes the damaged task again: the same rows as before
    assert main(["sweep", str(study), "--out", str(out), "--workers", "1"]) == 0
    assert "task(s) 1 had damaged result files" in capsys.readouterr().out
    assert (out / "data" / "task-000001.parquet").read_bytes() != b"not parquet"
    import pandas as pd
    import pyarrow as pa
    import pyarrow.parquet as pq

    again = pq.read_table(out / "data" / "task-000001.parquet").to_pandas()
    pd.testing.assert_frame_equal(again, pq.read_table(pa.BufferReader(whole)).to_pandas())
    # study.json damaged: the summary asks for the axes; given them, it summarises
    (out / "study.json").write_text("{not json")
    assert main(["sweep", "--summary", str(out)]) == 2
    assert "study.json: missing or damaged" in capsys.readouterr().err
    assert main(["sweep", "--summary", str(out), "--x", "age", "--y", "sex"]) == 0
    # study.toml not text: another study's folder, refused
    other = tmp_path / "other"
    shutil.copytree(out, other)
    (other / "study.toml").write_bytes(b"\xff\xfe\x00bad")
    capsys.readouterr()
    assert main(["sweep", str(study), "--out", str(other), "--workers", "1"]) == 2
    assert "holds another study" in capsys.readouterr().err
