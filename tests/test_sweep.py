"""Studies at scale (``exoleg sweep``): the study file, its sampling, the runs' rows, and
the engine on three Dask schedulers -- a LocalCluster of processes, threads in this
process, and a scheduler with workers started as separate processes on loopback --
which must give the same dataset; an interrupted study resumed with no task computed
twice (by counting the tasks computed).

References: the device files (data/device: a gear's ratings by ratio, S10); the motor's
no-load speed V / (k_t N) (device-datasheets.md D); simulate_walk for a run's figures;
the definition of a Latin hypercube (one draw per stratum and axis).
"""

from __future__ import annotations

import contextlib
import importlib.util
import json
import os
import signal
import subprocess
import sys
import time
from collections.abc import Iterator, Sequence
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from conftest import EXOLEG
from exoleg.errors import ParameterError
from exoleg.study.spec import parse_study

ROOT = Path(__file__).resolve().parents[1]
needs_dask = pytest.mark.skipif(
    importlib.util.find_spec("distributed") is None,
    reason="Dask's distributed is not installed (pip install exoleg[study])")
#: Six runs of one stride in three tasks: small enough to run on three schedulers.
TINY = """
[study]
name = "tiny"
strides = 1
runs_per_task = 2
partition_by = "hip_motor"

[axes]
hip_motor = ["ec90flat-90w", "ec90flat-160w"]
age = [8, 10, 12]
"""


def cli(*args: str, **kw: object) -> subprocess.CompletedProcess[str]:
    return subprocess.run([sys.executable, "-m", "exoleg.cli", *args], capture_output=True,
                          text=True, check=False, timeout=600, **kw)  # type: ignore[call-overload]


# ------------------------------------------------------------------- the study file
@pytest.mark.parametrize("text, key", [
    ("[axes]\nheight_cm = [120]\n", "axes.height_cm"),                  # unknown axis
    ("[axes]\nage = []\n", "axes.age"),                                 # empty grid
    ("[axes]\nage = [30]\n", "axes.age"),                               # out of range
    ("[axes]\nspeed = [\"Slow\", \"Slow\"]\n", "axes.speed"),            # the runs twice
    ("[axes]\nseed = {min = 0, max = 2, steps = 5}\n", "axes.seed"),  # 0, 0 (rounded), ...
    ("[axes]\nhip_motor = [\"ec90flat-220w\"]\n", "axes.hip_motor"),    # not a variant
    ("[axes]\nhip_ratio = [80]\n", "axes.hip_ratio"),                   # no ratings for 80
    ("[study]\nsampling = \"sobol\"\n", "study.sampling"),
    ("[study]\nsampling = \"lhs\"\n[axes]\nage = {min = 8, max = 12}\n", "study.samples"),
    ("[study]\nstrides = 0\n", "study.strides"),
    ("[study]\nname = \"  \"\n", "study.name"),                   # blank (was accepted)
    ("[[profiles]]\nname = \"\"\nage = 9\nsex = \"female\"\nheight = 1.3\nmass = 27\n",
     "profiles[0].name"),                                             # blank: failed in a run
    ("[study]\nwho = 1\n", "study.who"),
    ("[axes]\nage = {min = 8, max = 12}\n", "axes.age.steps"),           # a grid's range
    ("[axes]\nseed = {min = 0, max = 2000000, steps = 2000000}\n"
     "age = {min = 8, max = 12, steps = 5}\n", "axes"),                 # 10 M runs
    ("[[profiles]]\nage = 9\nsex = \"female\"\nheight = 1.3\nmass = 300\n", "profiles[0]"),
    ("[study]\npartition_by = \"colour\"\n", "study.partition_by"),
    ("[study]\nsampling = \"list\"\n", "runs"),
    ("[axes]\nspasticity = [\"mild\"]\n", "axes.spasticity"),      # on a passive leg
    ("[axes]\nchild = [\"actor\"]\ncrouch = [7]\n", "axes.crouch"),  # no such cluster
    ("[axes]\ncontroller = [\"transparent\"]\n", "axes.controller"),  # a passive leg
    ("[axes]\ncontroller = [\"pid\"]\n", "axes.controller"),          # no such mode
    ("[axes]\nassist_law = [\"emken\"]\n", "axes.assist_law"),         # no such law
])
def test_a_bad_study_is_refused_naming_the_key(text: str, key: str) -> None:
    with pytest.raises(ParameterError) as e:
        parse_study(text, "s.toml")
    assert e.value.field.startswith(key), (e.value.field, str(e.value))


def test_a_bad_study_file_is_one_line_exit_2(tmp_path: Path, here: Any) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("[axes]\nage = [30]\n")
    r = here("sweep", str(bad), "--out", str(tmp_path / "o"))
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert "axes.age: 30 is outside 2-20" in r.stderr
    assert not (tmp_path / "o").exists()  # nothing written
    binary = tmp_path / "bin.toml"
    binary.write_bytes(b"\x00\x01\xff" * 10)
    r = here("sweep", str(binary), "--out", str(tmp_path / "o"))
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    good = tmp_path / "good.toml"
    good.write_text(TINY)
    (tmp_path / "afile").write_text("x")
    r = here("sweep", str(good), "--out", str(tmp_path / "afile"))
    assert r.returncode == 2 and "--out: is a file" in r.stderr, r.stderr


@needs_dask
def test_a_scheduler_that_does_not_answer_is_one_line_and_nothing_is_written(
        tmp_path: Path) -> None:
    good = _write(tmp_path / "good.toml", TINY)
    r = cli("sweep", str(good), "--out", str(tmp_path / "o"), "--scheduler",
            "tcp://127.0.0.1:9")  # the discard port: nothing listens
    assert r.returncode == 2 and r.stderr.count("\n") == 1, r.stderr
    assert "--scheduler: 'tcp://127.0.0.1:9': no Dask scheduler answers there" in r.stderr
    assert not (tmp_path / "o").exists()


def test_grids_samples_and_lists() -> None:
    grid = parse_study("[axes]\nage = [8, 10]\nspeed = [\"Slow\", \"Free\", \"Fast\"]\n")
    runs = grid.runs()
    assert len(runs) == 6 and [(r["age"], r["speed"]) for r in runs[:3]] == [
        (8.0, "Slow"), (8.0, "Free"), (8.0, "Fast")]  # the last axis fastest
    assert all(r["hip_motor"] == "ec90flat-160w" and r["bus_voltage"] == 24.0 for r in runs)
    # a Latin hypercube of n draws puts exactly one draw in each of n equal strata
    lhs = parse_study("[study]\nsampling = \"lhs\"\nsamples = 40\nseed = 3\n[axes]\n"
                      "age = {min = 8, max = 12}\nbus_voltage = {min = 20, max = 48}\n")
    for name, lo, hi in (("age", 8, 12), ("bus_voltage", 20, 48)):
        x = np.array([r[name] for r in lhs.runs()])
        assert sorted(np.floor((x - lo) / (hi - lo) * 40).astype(int)) == list(range(40))
    assert lhs.runs() == lhs.runs()  # the same seed, the same sample
    listed = parse_study("[study]\nsampling = \"list\"\n[[runs]]\nage = 9\n[[runs]]\n"
                         "age = 11\nhip_motor = \"ec90flat-90w\"\n")
    assert [(r["age"], r["hip_motor"]) for r in listed.runs()] == [
        (9.0, "ec90flat-160w"), (11.0, "ec90flat-90w")]


def test_a_run_names_its_device_variant_and_its_row_holds_the_walk() -> None:
    from exoleg.device.actuator import paper_actuators
    from exoleg.study.runs import device_variant, run_one

    run = parse_study("[axes]\nhip_ratio = [50]\nbus_voltage = [36]\n").runs()[0]
    hip, knee, ankle = device_variant(run)
    shipped_knee = paper_actuators()[1]  # the CSF-17-50 (S10)
    assert hip.ratio == 50 and hip.repeated_peak_torque == shipped_knee.repeated_peak_torque
    assert hip.momentary_peak_torque == 70.0 and "EC 90 flat 160 W" in hip.motor
    assert hip.bus_voltage == knee.bus_voltage == ankle.bus_voltage == 36.0
    # no-load joint speed V / (k_t N) at 36 V, the 160 W hip's k_t through 1:50
    assert np.degrees(hip.max_velocity) == pytest.approx(
        min(np.degrees(36.0 / (0.0712 * 50)), 5000 * 6 / 50), rel=1e-12)
    row = run_one(7, 3, run, strides=1)
    assert row["run"] == 7 and row["task"] == 3 and row["error"] == ""
    assert row["hip_ratio"] == 50.0 and row["torque_limit_Nm_hip"] == pytest.approx(
        min(34.0, 50 * 0.8 * 0.0712 * 12.88))  # the 50:1 gear's repeated peak binds
    assert row["peak_torque_Nm_hip"] <= row["torque_limit_Nm_hip"] + 1e-9
    assert row["steps"] >= 1 and np.isfinite(row["winding_max_C_knee"])
    # the reflected inertia (3.25 kg m^2 at the hip, 1:100; 0.81 at 1:50) keeps
    # h lambda(M^-1 Kd) far below 2: 0.034 in the paper's scenario (docs/device.md)
    assert 0.005 < row["stability_margin"] < 0.2
    # a child the growth charts refuse (300 kg at 9 y: beyond +5 SD) is a row with its
    # error and no figures, not a lost run
    bad = {**run, "profile": {"name": "x", "age": 9.0, "sex": "female", "height": 1.3,
                              "mass": 300.0, "gmfcs": None}}
    row = run_one(8, 3, bad, strides=1)
    assert row["error"].startswith("ParameterError") and "mass" in row["error"]
    assert row["steps"] == -1 and np.isnan(row["peak_torque_Nm_hip"]) and not row["walked"]


def test_impairments_are_axes_and_the_cuffs_torque_is_in_every_row() -> None:
    # the child as an actor (issue 22) in a study: spasticity, crouch, contracture and
    # strength act on the actor only; every row keeps the interaction torque per kg
    from exoleg.study.runs import actor, run_one

    study = parse_study('[axes]\nchild = ["passive", "actor"]\ngroup = ["GMFCS II"]\n'
                        'spasticity = ["moderate"]\ncrouch = [2]\nstrength = [0.5]\n')
    passive, acting = study.runs()
    assert actor(passive, object()) is None
    rows = [run_one(i, 0, run, strides=2) for i, run in enumerate((passive, acting))]
    assert all(r["error"] == "" and r["walked"] for r in rows)
    # measured: passive 1.45 / 0.76 / 0.62, actor 1.97 / 1.00 / 0.69 N m/kg RMS; the
    # bounds are those figures' order (a row of zeros or of the impact spikes fails)
    for r in rows:
        assert all(0.3 < r[f"interaction_rms_Nm_per_kg_{j}"] < 5.0
                   for j in ("hip", "knee", "ankle"))
    assert rows[0]["interaction_rms_Nm_per_kg_knee"] != rows[1]["interaction_rms_Nm_per_kg_knee"]
    from exoleg.study.runs import _child

    child = actor(acting, _child(acting))
    assert (child.gmfcs, child.spasticity.level, child.crouch, child.strength_scale) == (
        2, "moderate", 2, 0.5)
    assert child.strength_fraction == pytest.approx(0.65 * 0.5)  # effort.toml's GMFCS II


def test_support_modes_are_an_axis_and_a_row_keeps_the_support_and_the_safety_events() -> None:
    # issue 23 in a study: the controller's support mode is an axis; a row keeps the
    # support of its first and last strides and the safety layer's events, as
    # simulate --walk's summary.json has them (support_by_stride, safety_events)
    from exoleg.child.model import ChildModel
    from exoleg.control.transparency import SupportMode
    from exoleg.sim.metrics import safety_events, support_by_stride
    from exoleg.sim.walk import simulate_walk
    from exoleg.sizing import personalized_leg
    from exoleg.study.runs import _child, run_one

    study = parse_study('[axes]\nchild = ["actor"]\ncontroller = ["impedance", "aan"]\n')
    imp, aan = study.runs()
    rows = [run_one(i, 0, run, strides=4) for i, run in enumerate((imp, aan))]
    assert all(r["error"] == "" for r in rows)
    # each row's support, recomputed here from the same walk: the row's figures are its
    # first and last strides'. The impedance supports fully (1) but where the cuffs'
    # limit lowered it for a moment (a safety event of the row's, measured: to
    # 0.999998); assist-as-needed's falls (a typically developing girl of 10 tracks
    # within the deadband: measured 0.96 -> 0.80 over 4 strides)
    c = _child(aan)
    for row, mode in ((rows[0], SupportMode.IMPEDANCE), (rows[1], SupportMode.AAN)):
        r = simulate_walk(personalized_leg(c), c.mass, strides=4, child=ChildModel.of(c),
                          support_mode=mode)
        s = support_by_stride(r.t, r.support_level, r.strikes())
        assert (row["support_first"], row["support_last"]) == (s[0], s[-1])
    assert all(x == 1.0 for x in (rows[0]["support_first"], rows[0]["support_last"])) or \
        "cuff" in rows[0]["safety_event_kinds"].split(",")
    assert min(rows[0]["support_first"], rows[0]["support_last"]) >= 0.999
    assert rows[1]["support_last"] < rows[1]["support_first"] < 1.0
    events = safety_events(r.t, r.safety_status, r.walk_start)
    assert rows[1]["safety_events"] == len(events)
    assert rows[1]["safety_event_kinds"] == ",".join(e["event"] for e in events)
    # a listed run asking a passive leg to walk transparent is a row with its error
    row = run_one(2, 0, {**imp, "child": "passive", "controller": "transparent"}, 1)
    assert "transparent needs child" in row["error"] and row["safety_events"] == -1


# ------------------------------------------------------------------ the engine
@contextlib.contextmanager
def _cluster(tmp_path: Path, host: str, tls: Sequence[str] = (), nworkers: int = 1
             ) -> Iterator[tuple[Path, str]]:
    """A Dask scheduler on ``host`` (loopback) and ``nworkers`` workers, each a process of
    its own (``tls``: Dask's TLS options for both), until the block ends: yields the
    scheduler's file and address."""
    sched_file = tmp_path / "scheduler.json"
    env = {**os.environ, "PYTHONWARNINGS": "ignore"}
    sched = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_scheduler",
                              "--host", host, "--port", "0", "--no-dashboard",
                              "--scheduler-file", str(sched_file), *tls], env=env,
                             stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    work = None
    try:
        for _ in range(600):
            if sched_file.exists() and sched_file.stat().st_size:
                break
            time.sleep(0.05)
        address = json.loads(sched_file.read_text())["address"]
        work = subprocess.Popen([sys.executable, "-m", "distributed.cli.dask_worker", address,
                                 "--nworkers", str(nworkers), "--nthreads", "1",
                                 "--no-dashboard", *tls], env=env,
                                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        yield sched_file, address
    finally:
        for proc in (work, sched):
            if proc is not None:
                proc.terminate()
                proc.wait(timeout=30)


def _table(out: Path) -> dict[str, list[object]]:
    from exoleg.study.engine import read_results

    t = read_results(out)
    cols = t.to_pydict()
    return {k: [None if isinstance(v, float) and v != v else v for v in vals]
            for k, vals in cols.items()}


def _write(path: Path, text: str) -> Path:
    path.write_text(text)
    return path


@needs_dask
def test_the_small_sweep_on_three_schedulers_interrupted_and_resumed(
        tmp_path: Path, terminal_ctrl_c: Any, here: Any) -> None:
    """The shipped small study (64 runs in 16 tasks) three times: (1) on the default
    LocalCluster through the command line, interrupted by a real SIGINT once some tasks
    are done and run again -- every task computed exactly once, counted in tasks.log;
    (2) on threads in this process; (3) on a scheduler and two workers started as
    processes of their own on loopback. The three datasets are identical."""
    from exoleg.study.engine import dask_client, execute

    example = ROOT / "examples" / "sweep-small.toml"
    small = example.read_text()
    # 1. LocalCluster, interrupted and resumed
    out = tmp_path / "local"
    p = subprocess.Popen([EXOLEG, "sweep", str(example), "--out", str(out), "--workers",
                          "2"], stdout=subprocess.PIPE,
                         stderr=subprocess.PIPE, text=True, preexec_fn=terminal_ctrl_c)
    deadline = time.monotonic() + 300
    while time.monotonic() < deadline and p.poll() is None:
        if len(list((out / ".tasks").glob("task-*"))) >= 3:
            break
        time.sleep(0.05)
    p.send_signal(signal.SIGINT)
    said, err = p.communicate(timeout=120)
    assert p.returncode == 130, (err, said[-2000:])
    assert "run the same command to go on" in err
    first = len(list((out / ".tasks").glob("task-*")))
    assert 3 <= first < 16
    r = cli("sweep", str(example), "--out", str(out), "--workers", "2")
    assert r.returncode == 0, r.stderr
    assert f"({first} done: resuming)" in r.stdout
    computed = [int(line.split()[1]) for line in (out / "tasks.log").read_text().splitlines()]
    assert sorted(computed) == list(range(16))  # each task once, none twice
    # 2. threads in this process
    with dask_client(workers=2, processes=False) as c:
        execute(parse_study(small, str(example)), tmp_path / "inprocess", client=c)
    # 3. a scheduler and two workers, each a process of its own, on loopback
    with _cluster(tmp_path, "127.0.0.1", nworkers=2) as (sched_file, _):
        r = cli("sweep", str(example), "--out", str(tmp_path / "remote"), "--scheduler",
                str(sched_file))
        assert r.returncode == 0, r.stderr
    tables = [_table(tmp_path / d) for d in ("local", "inprocess", "remote")]
    assert tables[0]["run"] == list(range(64)) and not any(tables[0]["error"])
    assert tables[0] == tables[1] == tables[2]
    # the study and exoleg's version travel with the data
    import pyarrow.parquet as pq

    part = next((tmp_path / "remote" / "data").rglob("*.parquet"))
    meta = pq.read_schema(part).metadata
    assert meta[b"exoleg.study"].decode() == small and meta[b"exoleg.version"]
    # another study in the same folder is refused; the summary reads it
    r = here("sweep", str(_write(tmp_path / "t.toml", TINY)), "--out", str(out))
    assert r.returncode == 2 and "holds another study" in r.stderr
    r = here("sweep", "--summary", str(out), "--x", "age", "--y", "group")
    assert r.returncode == 0, r.stderr
    assert (out / "summary-age-group.csv").exists() and (out / "summary-age-group.png").exists()
    lines = (out / "summary-age-group.csv").read_text().splitlines()
    assert len(lines) == 1 + 4 * 2  # ages x groups
    r = here("sweep", "--summary", str(out), "--x", "colour")
    assert r.returncode == 2 and "--x: 'colour' is not a column" in r.stderr
    # a device beside a summary was dropped without a word (the runs hold theirs)
    r = here("sweep", "--summary", str(out), "--device", str(tmp_path))
    assert r.returncode == 2 and "--workers or --device (the study's runs" in r.stderr
    # one axis twice is refused; one axis given, the other is a default that differs (the
    # study sweeps hip_motor, speed, ...: --y hip_motor alone tabled hip_motor twice)
    from exoleg.study.summary import summarise

    with pytest.raises(ParameterError, match="--y: 'age' is --x too"):
        summarise(out, "age", "age")
    assert (summarise(out, y="hip_motor").x, summarise(out, x="speed").y) == ("speed",
                                                                              "hip_motor")


@needs_dask
def test_a_tls_scheduler_with_dasks_settings_and_without(tmp_path: Path) -> None:
    """Issue 44: a ``tls://`` address gave a TypeError about an SSL context. Without
    Dask's TLS settings it is one line naming them; with them (a certificate authority
    and a certificate made here with openssl, a scheduler and a worker started with them
    on loopback) the tiny study runs there, rows identical to a local cluster's."""
    import shutil

    if shutil.which("openssl") is None:
        pytest.skip("openssl is not installed (it makes the test's certificates)")
    study = _write(tmp_path / "tiny.toml", TINY)
    r = cli("sweep", str(study), "--out", str(tmp_path / "no"), "--scheduler",
            "tls://127.0.0.1:9")
    assert r.returncode == 2 and "needs Dask's TLS settings" in r.stderr, r.stderr
    assert not (tmp_path / "no").exists()
    d = tmp_path / "tls"
    d.mkdir()

    def ssl(*args: str) -> None:
        subprocess.run(["openssl", *args], cwd=d, check=True, capture_output=True)

    ssl("req", "-x509", "-newkey", "rsa:2048", "-nodes", "-keyout", "ca.key", "-out",
        "ca.pem", "-days", "1", "-subj", "/CN=exoleg test CA")
    ssl("req", "-newkey", "rsa:2048", "-nodes", "-keyout", "key.pem", "-out", "req.csr",
        "-subj", "/CN=127.0.0.1")
    (d / "ext.cnf").write_text("subjectAltName=IP:127.0.0.1\n")
    ssl("x509", "-req", "-in", "req.csr", "-CA", "ca.pem", "-CAkey", "ca.key",
        "-CAcreateserial", "-out", "cert.pem", "-days", "1", "-extfile", "ext.cnf")
    tls = ["--tls-ca-file", str(d / "ca.pem"), "--tls-cert", str(d / "cert.pem"),
           "--tls-key", str(d / "key.pem")]
    with _cluster(tmp_path, "tls://127.0.0.1", tls) as (_, address):
        assert address.startswith("tls://127.0.0.1:")
        settings = {"DASK_DISTRIBUTED__COMM__TLS__CA_FILE": str(d / "ca.pem"),
                    "DASK_DISTRIBUTED__COMM__TLS__CLIENT__CERT": str(d / "cert.pem"),
                    "DASK_DISTRIBUTED__COMM__TLS__CLIENT__KEY": str(d / "key.pem")}
        r = cli("sweep", str(study), "--out", str(tmp_path / "over-tls"), "--scheduler",
                address, env={**os.environ, **settings})
        assert r.returncode == 0, r.stderr
    r = cli("sweep", str(study), "--out", str(tmp_path / "local"), "--workers", "1")
    assert r.returncode == 0, r.stderr
    assert _table(tmp_path / "over-tls") == _table(tmp_path / "local")
