"""Bad input, table-driven: every command and option, every class of malformed value.

Each case asserts exactly what a user sees: exit status 2 (a bad input) and one line on
stderr naming what was wrong -- never a traceback, never a result. The table's last
column is the text the message must contain. Input classes: wrong type, NaN, inf, huge,
negative, zero, empty, binary file, folder, unreadable, unwritable, out of range,
options that do not apply.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path
from typing import Any

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from exoleg.cli import main

FIT = ["fit", "--age", "9.5", "--sex", "female", "--height", "125", "--mass", "24", "--gmfcs",
       "3", "--no-simulate"]


@pytest.fixture(scope="module")
def files(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    d = tmp_path_factory.mktemp("inputs")
    out = {
        "binary": d / "binary.toml", "empty": d / "empty.toml", "latin1": d / "latin1.toml",
        "huge": d / "huge.toml", "folder": d / "folder", "afile": d / "afile",
        "unreadable": d / "unreadable.toml", "readonly": d / "readonly",
        "bad_toml": d / "bad.toml", "heavy": d / "heavy.toml", "com_off": d / "com.toml",
        "two_links": d / "two.toml", "quote_name": d / "quote.toml",
    }
    out["binary"].write_bytes(bytes(range(256)) * 10)
    out["empty"].write_text("")
    out["latin1"].write_bytes("name = \"caf\xe9\"\n".encode("latin-1"))
    out["huge"].write_text("# " + "x" * (2 << 20))
    out["folder"].mkdir()
    out["afile"].write_text("not a folder")
    out["unreadable"].write_text("g = 9.81")
    out["unreadable"].chmod(0)
    out["readonly"].mkdir()
    out["readonly"].chmod(0o555)
    out["bad_toml"].write_text("g = = 9.81")
    import exoleg
    from exoleg.params.leg_file import format_leg

    good = format_leg(exoleg.paper_leg().links, 9.81, "ok")
    out["heavy"].write_text(re.sub(r"mass = [0-9.e-]+", "mass = 1e300", good, count=1))
    out["com_off"].write_text(re.sub(r"com = \[[0-9.e-]+", "com = [5.1", good, count=1))
    out["two_links"].write_text(good[: good.rindex("[[link]]")])
    out["quote_name"].write_text(good.replace('name = "ok"', 'name = 42'))
    # a sessions folder whose children's records are not a database (issue 20, point 6)
    out["bad_records"] = d / "bad-records"
    out["bad_records"].mkdir()
    (out["bad_records"] / "records.sqlite").write_bytes(b"not sqlite\0" * 50)
    # a leg for a child the device does not fit (exoleg fit --write-leg)
    out["child_file"] = d / "child.toml"
    out["child_file"].write_text('[child]\nage_years = 10\nheight_m = 1.38\nmass_kg = 32\n'
                                 'sex = "female"\n')
    out["unfit"] = d / "unfit.toml"
    out["unfit"].write_text(format_leg(exoleg.paper_leg().links, 9.81, "tall", fit={
        "fits": False, "note": "thigh 45 cm is beyond the upper telescope (27-40 cm)"}))
    # device folders whose values make the plant or the controller meaningless
    import shutil
    from importlib import resources

    shipped = Path(str(resources.files("exoleg").joinpath("data", "device")))
    for name, file, old, new in (
            ("inertia", "actuators/hip.toml", "ratio = 100.0", "ratio = 1000.0"),
            ("rate", "safety.toml", "max_torque_rate = [3000.0, 1400.0, 3400.0]",
             "max_torque_rate = [1e30, 1400.0, 3400.0]"),
            ("contact", "walking.toml", "damping = 1500.0                # N s/m: well",
             "damping = 900000.0                # N s/m: well")):
        folder = d / f"device-{name}"
        shutil.copytree(shipped, folder,
                        ignore=shutil.ignore_patterns("canopen", "hip-variants",
                                                      "__pycache__"))
        text = (folder / file).read_text()
        assert old in text, (file, old)
        (folder / file).write_text(text.replace(old, new))
        if name == "inertia":  # and a rotor that makes 1e4 kg m^2 at the joint
            t = (folder / file).read_text()
            (folder / file).write_text(re.sub(r"rotor_inertia = [0-9.e-]+",
                                              "rotor_inertia = 1e-2", t))
        out[f"device_{name}"] = folder
    return out


def _run(args: list[str], cwd: Path | None = None) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "exoleg.cli", *args], capture_output=True,
                          text=True, check=False, cwd=cwd, timeout=300)


# (case, arguments, the text the one-line message must contain); {name} -> files[name]
CASES: list[tuple[str, list[str], str]] = [
    # simulate: numbers
    ("duration NaN", ["simulate", "--duration", "nan"], "finite"),
    ("duration inf", ["simulate", "--duration", "inf"], "finite"),
    ("duration negative", ["simulate", "--duration", "-1"], "must be > 0"),
    ("duration zero", ["simulate", "--duration", "0"], "must be > 0"),
    ("duration below one step", ["simulate", "--duration", "1e-9"], "less than one step"),
    ("duration huge: memory", ["simulate", "--duration", "1e7"], "GiB"),
    ("duration word", ["simulate", "--duration", "long"], "expected comma-separated numbers"),
    ("duration empty", ["simulate", "--duration", ""], "expected comma-separated numbers"),
    ("dt huge", ["simulate", "--dt", "1"], "outside 1e-06-0.01"),
    ("dt tiny", ["simulate", "--dt", "1e-300"], "outside 1e-06-0.01"),
    ("control rate not a multiple", ["simulate", "--control-rate", "300"], "whole multiple"),
    ("control rate too slow to be stable", ["simulate", "--control-rate", "2"], ">= 2"),
    ("kp two values", ["simulate", "--kp", "1,2"], "expected 3"),
    ("kd NaN", ["simulate", "--kd", "nan,1,1"], "finite"),
    ("kd negative", ["simulate", "--kd", "-1,1,1"], "gains >= 0"),
    ("kd unstable at 1 kHz", ["simulate", "--kd", "12,12,40"], "unstable"),
    ("q0 beyond range of motion", ["simulate", "--q0", "1000,0,0"], "hip at 1000 deg"),
    ("knee hyperextended", ["simulate", "--q0", "0,90,0"], "knee at 90 deg"),
    ("posture beyond range of motion", ["simulate", "--reference", "steps", "--postures",
                                        "0,500,0"], "knee at 500 deg"),
    ("postures with gait", ["simulate", "--reference", "gait", "--postures", "0,0,0"],
     "--postures: does not apply"),
    ("stride time with steps", ["simulate", "--stride-time", "1.1"], "does not apply"),
    ("stride time huge", ["simulate", "--reference", "gait", "--stride-time", "1e308"],
     "outside 0.4-4"),
    ("sd huge", ["simulate", "--reference", "gait", "--sd", "40"], "outside -3-3"),
    ("times without matching postures", ["simulate", "--reference", "steps", "--times", "0,3",
                                         "--postures", "0,0,0"], "one time per posture"),
    ("unknown reference", ["simulate", "--reference", "jog"], "invalid choice"),
    # simulate: files
    ("leg missing", ["simulate", "--leg", "{afile}.missing"], "no such file"),
    ("leg binary", ["simulate", "--leg", "{binary}"], "binary file"),
    ("leg folder", ["simulate", "--leg", "{folder}"], "is a folder"),
    ("leg not UTF-8", ["simulate", "--leg", "{latin1}"], "not UTF-8"),
    ("leg huge", ["simulate", "--leg", "{huge}"], "at most"),
    ("leg empty", ["simulate", "--leg", "{empty}"], "link: missing"),
    ("leg bad TOML", ["simulate", "--leg", "{bad_toml}"], "not valid TOML"),
    ("leg mass 1e300", ["simulate", "--leg", "{heavy}"], "not plausible"),
    ("leg COM 5 m off", ["simulate", "--leg", "{com_off}"], "from its"),
    ("leg two links", ["simulate", "--leg", "{two_links}"], "exactly 3"),
    ("leg name not a string", ["simulate", "--leg", "{quote_name}"], "expected a string"),
    ("out is a file", ["simulate", "--out", "{afile}"], "not a folder"),
    ("out under a file", ["simulate", "--out", "{afile}/sub"], "cannot be created"),
    # fit
    ("age NaN", [*FIT[:2], "nan", *FIT[3:]], "finite"),
    ("age 200", [*FIT[:2], "200", *FIT[3:]], "outside 2-20"),
    ("height negative", [*FIT[:6], "-125", *FIT[7:]], "outside 50-220"),
    ("height implausible for age", [*FIT[:6], "200", *FIT[7:]], "height"),
    ("mass implausible for age", [*FIT[:8], "150", *FIT[9:]], "mass"),
    ("gmfcs 3.0", [*FIT[:10], "3.0", *FIT[11:]], "invalid int value"),
    ("gmfcs 7", [*FIT[:10], "7", *FIT[11:]], "invalid choice"),
    ("thigh 5 m", [*FIT, "--thigh", "500"], "outside 1-200"),
    ("thigh implausible for height", [*FIT, "--thigh", "60"], "plausible 23.0-38.3 cm"),
    ("percentile 100", [*FIT, "--percentile", "100"], "between 0 and 100"),
    ("sex unknown", [*FIT[:4], "other", *FIT[5:]], "invalid choice"),
    # population
    ("ages out of the charts", ["population", "--ages", "30", "--no-simulate"], "2-20 years"),
    ("percentiles 0", ["population", "--percentiles", "0,50", "--no-simulate"], "between 0"),
    # a value twice counted its children twice in every share (was accepted)
    ("ages twice", ["population", "--ages", "8,9,8.0", "--no-simulate"],
     "8 is given twice (each age once)"),
    ("percentiles twice", ["population", "--percentiles", "50,50", "--no-simulate"],
     "50 is given twice (each percentile once)"),
    ("population stride", ["population", "--stride-time", "0", "--no-simulate"], "outside"),
    # export
    ("assess child binary", ["assess", "--child", "{binary}", "--test", "pendulum", "--out",
                             "{folder}/a"], "binary"),
    ("assess child folder", ["assess", "--child", "{folder}", "--test", "pendulum"],
     "folder"),
    ("assess child bad toml", ["assess", "--child", "{bad_toml}", "--test", "stretch"],
     "TOML"),
    ("assess child is a leg file", ["assess", "--child", "{heavy}", "--test", "stretch"],
     "child"),
    ("assess unknown test", ["assess", "--child", "{heavy}", "--test", "reflex"],
     "invalid choice"),
    ("simulate child binary", ["simulate", "--walk", "--child", "{binary}"], "binary"),
    ("simulate child without walk", ["simulate", "--child", "{heavy}"], "--walk"),
    ("fit crouch out of range", FIT + ["--crouch", "7"], "invalid choice"),
    ("fit spasticity unknown", FIT + ["--spasticity", "extreme"], "invalid choice"),
    # a blank name was written into the child's files as their name
    ("fit blank name", FIT + ["--name", "  "], "'  ' is blank: give the child's name"),
    ("export leg binary", ["export", "--leg", "{binary}", "--out", "{folder}/x.urdf"], "binary"),
    ("export out is a folder", ["export", "--out", "{folder}"], "is a folder"),
    # a child file given as the leg: "link: missing (required fields: link)"
    ("export a child file as the leg", ["export", "--leg", "{child_file}", "--out",
                                        "{folder}/x.urdf"], "a child file (exoleg fit's "
     "child.toml), not a leg file"),
    # a session's log was written over with the URDF (exit 0)
    ("export over a log", ["export", "--out", "{folder}/session.log"], "session.log: the leg "
     "is written as a .urdf or .xml file"),
    # the operator interface (each refused before it listens)
    ("hmi port 80", ["hmi", "--port", "80"], "outside 1024-65535"),
    ("hmi sessions is a file", ["hmi", "--sessions", "{afile}"], "not a folder"),
    ("hmi half a TLS pair", ["hmi", "--tls-cert", "{afile}"], "give both or neither"),
    ("hmi TLS files missing", ["hmi", "--tls-cert", "{folder}/c", "--tls-key",
                               "{folder}/k"], "no such file"),
    ("hmi interface on sim", ["hmi", "--interface", "virtual"], "goes with --backend"),
    ("hmi records damaged", ["hmi", "--sessions", "{bad_records}", "--port", "18781"],
     "not an exoleg records database"),
    ("run bus timeout on sim", ["run", "--duration", "1", "--bus-timeout", "5"],
     "goes with --backend"),
    ("run bus timeout 0", ["run", "--backend", "canopen", "--duration", "1", "--bus-timeout",
                           "0"], "outside 0.1-50 ms"),
    ("run hmi half a TLS pair", ["run", "--duration", "1", "--hmi", "--tls-key", "{afile}"],
     "give both or neither"),
    # options that do not apply to the backend or the mode (issue 20, point 8)
    ("run channel on sim", ["run", "--duration", "1", "--channel", "can0"],
     "--channel: goes with --backend"),
    ("run channel on ethercat", ["run", "--backend", "ethercat", "--duration", "1",
                                 "--channel", "can0"], "goes with --backend canopen"),
    ("run seed on a real bus", ["run", "--backend", "canopen", "--interface", "socketcan",
                                "--duration", "1", "--seed", "3"], "not on a real bus"),
    ("run hmi port without hmi", ["run", "--duration", "1", "--hmi-port", "9000"],
     "--hmi-port: goes with --hmi"),
    ("run tls without hmi", ["run", "--duration", "1", "--tls-cert", "{afile}"],
     "--tls-cert: goes with --hmi"),
    # the stride the walking controller expects: a child's, and only the walking one's
    ("run expected stride 0", ["run", "--duration", "1", "--expected-stride", "0"],
     "outside 0.4-4 s"),
    ("run expected stride nan", ["run", "--duration", "1", "--expected-stride", "nan"],
     "--expected-stride: numbers must be finite, got 'nan'"),
    ("simulate expected stride without walk", ["simulate", "--expected-stride", "1.2"],
     "exoleg simulate: --expected-stride: goes with --walk"),
    ("simulate expected stride 5", ["simulate", "--walk", "--expected-stride", "5"],
     "outside 0.4-4 s"),
    ("run expected stride of a law", ["run", "--duration", "1", "--controller", "pd",
                                      "--expected-stride", "1.2"],
     "the stride the walking controller expects: not 'pd'"),
    ("export variant with a leg", ["export", "--leg", "{heavy}", "--variant", "simplified",
                                   "--out", "{folder}/x.urdf"], "not with --leg"),
    # a leg for a child the device does not fit: the device is not set to it
    ("run an unfit leg", ["run", "--duration", "1", "--leg", "{unfit}"],
     "does not fit (thigh 45 cm"),
    ("export an unfit leg", ["export", "--leg", "{unfit}", "--out", "{folder}/x.urdf"],
     "does not fit"),
    # device files whose values make the plant or the controller meaningless
    ("device reflected inertia 1e4", ["simulate", "--walk", "--strides", "1", "--device",
                                      "{device_inertia}"], "reflected inertia 1.001e+04 kg m^2"),
    ("device torque rate 1e30", ["simulate", "--walk", "--strides", "1", "--device",
                                 "{device_rate}"], "max_torque_rate"),
    ("device contact diverges", ["simulate", "--walk", "--strides", "1", "--device",
                                 "{device_contact}"], "[contact] stiffness/damping"),
    # the design's population walks on the sweep engine
    ("design no workers", ["design", "{folder}/none.toml", "--workers", "0"],
     "0 is outside 1-256"),
    ("design workers and a scheduler", ["design", "{folder}/none.toml", "--workers", "2",
                                        "--scheduler", "tcp://127.0.0.1:1"],
     "sizes the local cluster"),
    # a validation with too few strides to judge (the first ones are left out): it once
    # printed NaN (the real CP child's match at 3 strides) or failed inside (transparency
    # at 1)
    ("validate transparency 2 strides", ["validate", "--transparency", "--strides", "2"],
     "strides: 2: the first 2 are left out (the child settles into the walk); allowed 3-1000"),
    ("validate cp-child 3 strides", ["validate", "--cp-child", "--strides", "3"],
     "allowed 4-1000"),
    # validate: one check at a time, each option with a check that takes it (a second
    # check, --children or --strides without theirs, --quick beside a check: dropped)
    ("validate two checks", ["validate", "--cp-child", "--identify"],
     "--identify: one check at a time: --cp-child and --identify were both given"),
    ("validate children alone", ["validate", "--children", "3"],
     "--children: goes with --identify"),
    ("validate strides alone", ["validate", "--strides", "5"],
     "--strides: goes with --gait-phase or --transparency or --cp-child"),
    ("validate quick with a check", ["validate", "--transparency", "--quick"],
     "--quick: goes with the model's checks (exoleg validate alone)"),
    # any command
    ("unknown option", ["validate", "--bogus"], "unrecognized arguments"),
    ("no command", [], "required"),
]


@pytest.mark.parametrize("case,args,text", CASES, ids=[c[0] for c in CASES])
def test_bad_input_is_one_line_exit_2(files: dict[str, Path], tmp_path: Path, case: str,
                                      args: list[str], text: str, here: Any) -> None:
    argv = [a.format(**{k: str(v) for k, v in files.items()}) for a in args]
    if argv and argv[0] in ("simulate", "fit", "population") and "--out" not in argv:
        argv += ["--out", str(tmp_path / "out")]
    if argv and argv[0] == "simulate" and "--walk" not in argv:
        argv.append("--no-engine")
    # in this process (the ``here`` fixture): each is refused before it starts anything
    r = here(*argv)
    assert r.returncode == 2, (case, r.returncode, r.stdout, r.stderr)
    lines = r.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith(("exoleg: error:", "usage:")) or (
        len(lines) == 2 and lines[0].startswith("usage:")), (case, r.stderr)
    assert "Traceback" not in r.stderr
    assert text in r.stderr, (case, r.stderr)
    out = tmp_path / "out"
    assert not out.exists() or not [p for p in out.iterdir()], (case, "wrote a result")


def test_unreadable_and_unwritable_as_a_user(files: dict[str, Path], tmp_path: Path) -> None:
    """Permission errors, run as an unprivileged user where the tests run as root."""
    if os.geteuid() != 0:
        cases = [(["simulate", "--leg", str(files["unreadable"]), "--no-engine",
                   "--out", str(tmp_path / "o")], "permission denied"),
                 (["simulate", "--no-engine", "--out", str(files["readonly"] / "o")],
                  "permission denied")]
        for args, text in cases:
            r = _run(args)
            assert r.returncode == 2 and text in r.stderr, r.stderr
        return
    try:
        import pwd

        nobody = pwd.getpwnam("nobody")
    except KeyError:
        pytest.skip("no unprivileged user to run as")
    tmp_path.chmod(0o777)
    secret = tmp_path / "secret.toml"
    secret.write_text("g = 9.81")
    secret.chmod(0)
    locked = tmp_path / "locked"
    locked.mkdir(mode=0o555)
    # everything the command imports is imported before the privileges are dropped (the
    # interpreter's own files may not be readable by that user)
    code = ("import sys, os, multiprocessing, concurrent.futures.process, rich.console, "
            "rich.table, "
            "rich.box, exoleg.cli, exoleg.sim.scenario, exoleg.io, exoleg.params.leg_file; "
            f"os.setgid({nobody.pw_gid}); os.setuid({nobody.pw_uid}); "
            "sys.exit(exoleg.cli.main(sys.argv[1:]))")
    for args, text in ((["simulate", "--leg", str(secret), "--out", str(tmp_path / "o")],
                        "permission denied"),
                       (["simulate", "--out", str(locked / "o")], "permission denied")):
        r = subprocess.run([sys.executable, "-c", code, *args, "--no-engine"],
                           capture_output=True, text=True, check=False,
                           env={**os.environ, "HOME": str(tmp_path)})
        assert r.returncode == 2 and text in r.stderr, (args, r.stderr)
        assert len(r.stderr.strip().splitlines()) == 1


@settings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(text=st.one_of(st.text(max_size=12), st.sampled_from(
    ["nan", "inf", "-inf", "1e400", "-0", "0x10", "1,2", "1e-320", "", " ", "١٢"])))
def test_any_text_for_a_number_option_is_a_clean_error_or_accepted(text: str) -> None:
    """Property: any text typed for a numeric option parses or is refused with exit 2 and
    one line -- never a traceback. (argparse's own exit is SystemExit(2).)"""
    import contextlib
    import io

    for opt in ("--duration", "--dt", "--stride-time", "--kp", "--q0"):
        err = io.StringIO()
        with contextlib.redirect_stderr(err), contextlib.suppress(SystemExit):
            parser_only(["simulate", opt, text])
        msg = err.getvalue()
        assert "Traceback" not in msg
        assert msg == "" or (msg.startswith("exoleg: error:") and msg.count("\n") == 1), msg


def parser_only(argv: list[str]) -> None:
    from exoleg.cli import build_parser

    build_parser().parse_args(argv)


def test_piped_into_head_exits_cleanly(tmp_path: Path) -> None:
    # BrokenPipeError: the reader stops early; no traceback, exit 0
    r = subprocess.run(f"{sys.executable} -m exoleg.cli validate --quick | head -1",
                       shell=True, capture_output=True, text=True, check=False)
    assert r.returncode == 0 and "Traceback" not in r.stderr and r.stderr == "", r.stderr


def test_unexpected_error_is_one_line(monkeypatch: pytest.MonkeyPatch,
                                      capsys: pytest.CaptureFixture[str]) -> None:
    import exoleg.cli.validate as cli

    def boom(args: object) -> int:
        raise ZeroDivisionError("a bug")

    monkeypatch.delenv("EXOLEG_DEBUG", raising=False)
    monkeypatch.setattr(cli, "cmd_validate", boom)
    assert main(["validate"]) == 1
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "internal error: ZeroDivisionError: a bug" in err


def test_cli_ranges_are_the_library_s() -> None:
    # the parser keeps its own copy (no numpy at start-up): it must not drift
    from exoleg.cli import _common as cli
    from exoleg.reference.gait import STRIDE_TIME_RANGE

    assert cli.STRIDE_TIME_RANGE == STRIDE_TIME_RANGE


def test_a_killed_simulate_leaves_no_worker_nor_staging(tmp_path: Path) -> None:
    # Issue 20, point 8: `exoleg simulate` killed left its worker process running and
    # its staging folder behind. SIGTERM unwinds it now (as Ctrl-C), and the worker ends
    # with its parent however the parent ends (SIGKILL too).
    import signal
    import time

    for sig in (signal.SIGTERM, signal.SIGKILL):
        out = tmp_path / f"out-{sig.name}"
        p = subprocess.Popen([sys.executable, "-m", "exoleg.cli", "simulate", "--duration",
                              "600", "--no-engine", "--out", str(out)],
                             stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        kids: list[int] = []
        deadline = time.time() + 60
        while time.time() < deadline and not kids:  # the worker is up
            kids = [int(x) for x in Path(f"/proc/{p.pid}/task/{p.pid}/children")
                    .read_text().split()] if p.poll() is None else []
            time.sleep(0.1)
        assert kids, "the worker never started"
        time.sleep(0.3)
        p.send_signal(sig)
        _, err = p.communicate(timeout=60)
        assert "Traceback" not in err, err
        gone = time.time() + 5
        while time.time() < gone and any(Path(f"/proc/{k}").exists() for k in kids):
            time.sleep(0.1)
        assert not any(Path(f"/proc/{k}").exists() for k in kids), (sig, kids)
        if sig == signal.SIGTERM:  # unwound: nothing staged is left, the exit says so
            assert p.returncode == 130 and "interrupted" in err
            assert not list(out.glob(".exoleg-staging-*")), list(out.iterdir())
