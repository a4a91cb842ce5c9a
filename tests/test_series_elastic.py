"""Compliant actuation units: a series spring (or a stiff gear with a joint torque sensor)
between the gear and the link, the drive closing its torque loop on the measured torque.

References: the two-mass model of a series-elastic actuator (Pratt & Williamson 1995;
the loop's closed forms in :attr:`exoleg.device.actuator.ActuatorModel.torque_loop_gains`)
linearised about the hanging leg and integrated exactly (matrix exponential) with the
leg's own mass matrix and gravity -- independent of the walking plant's RK4, its
torque loop sampled per plant step, its current loop and its encoders -- and, for the
buses, the simulated device's own run (the tick contract).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from exoleg.device.actuator import (
    ActuatorModel,
    actuator_text,
    load_actuator,
    paper_actuators,
    parse_actuator,
)
from exoleg.errors import ParameterError
from exoleg.params.records import JOINTS

SPRING = {"compliance": "series_spring", "series_stiffness": 300.0, "series_damping": 0.5,
          "torque_loop_bandwidth": 30.0, "torque_loop_damping": 0.7, "deflection_bits": 20}
SOURCES = {k: "choice: a test unit" for k in SPRING if k != "compliance"}


def _unit(a: ActuatorModel, series: dict[str, float] | None = None, **change: float) -> str:
    """``a``'s file text with ``change`` and the ``series`` figures."""
    import tomllib

    from exoleg.io import toml_string

    data = tomllib.loads(actuator_text(a))
    data.update(change)
    if series:
        data.update(series)
        data["sources"].update({k: "choice: a test unit" for k in series if k != "compliance"})
    lines = [f"{k} = {toml_string(v) if isinstance(v, str) else repr(v)}"
             for k, v in data.items() if k != "sources"]
    lines.append("[sources]")
    lines += [f"{k} = {toml_string(v)}" for k, v in data["sources"].items()]
    return "\n".join(lines) + "\n"


def _folder(tmp: Path, series: dict[str, dict[str, float]], frictionless: bool = False) -> Path:
    """A device folder with the shipped units, ``series`` figures per joint, and no
    friction when ``frictionless``."""
    (tmp / "actuators").mkdir(parents=True)
    change = dict(no_load_current=0.0, backdriving_torque=0.0,
                  viscous_friction=0.0) if frictionless else {}
    for j, a in zip(JOINTS, paper_actuators(), strict=True):
        (tmp / "actuators" / f"{j}.toml").write_text(_unit(a, series.get(j), **change))
    return tmp


def test_a_compliant_unit_reads_back_exactly_and_its_loop_is_the_one_asked(
        tmp_path: Path) -> None:
    knee = paper_actuators()[1]
    path = tmp_path / "knee.toml"
    path.write_text(_unit(knee, SPRING))
    a = load_actuator(path)
    assert a.compliance == "series_spring" and a.compliant
    (tmp_path / "again.toml").write_text(actuator_text(a))
    assert load_actuator(tmp_path / "again.toml") == a
    # the loop's closed forms, exact identities (link held): w_b^2 = K (1 + kp) / B and
    # 2 zeta w_b B = c + kd K; the link feels B / (1 + kp) = K / w_b^2
    kp, kd = a.torque_loop_gains
    B, K, c = a.reflected_inertia, a.series_stiffness, a.series_damping
    wb = 2 * math.pi * a.torque_loop_bandwidth
    assert math.isclose(math.sqrt(K * (1 + kp) / B), wb, rel_tol=1e-12)
    assert math.isclose((c + kd * K) / (2 * wb * B), a.torque_loop_damping, rel_tol=1e-12)
    assert math.isclose(a.apparent_inertia, B / (1 + kp), rel_tol=1e-12)
    assert a.link_inertia == 0.0 and knee.link_inertia == knee.reflected_inertia
    # the record's rows are the ones the plant and the loop read
    r = a.record()[0]
    assert (r["stiffness"], r["kp"], r["kd"], r["inertia"]) == (K, kp, kd, B)
    assert r["deflection"] == 2 * math.pi / 2**20
    assert knee.record()[0]["stiffness"] == 0.0  # a rigid unit: no spring


@pytest.mark.parametrize("series, field, said", [
    ({**SPRING, "compliance": "rubber"}, "compliance", "unknown 'rubber'"),
    ({"series_stiffness": 300.0}, "series_stiffness", "a rigid unit has no series"),
    ({k: v for k, v in SPRING.items() if k != "deflection_bits"}, "deflection_bits",
     "missing"),
    # the knee's rotor (0.222 kg m^2) on 300 N m/rad resonates at 5.85 Hz with the link
    # held: a loop slower than that adds inertia
    ({**SPRING, "torque_loop_bandwidth": 4.0}, "torque_loop_bandwidth", "below the rotor"),
    # the current loop's 200 Hz: the torque loop around it at most a third
    ({**SPRING, "torque_loop_bandwidth": 80.0}, "torque_loop_bandwidth", "above a third"),
    ({**SPRING, "series_damping": 90.0}, "series_damping", "alone damps"),
    ({**SPRING, "series_stiffness": 1e7}, "series_stiffness", "outside 10-1e+06"),
])
def test_a_compliant_unit_written_wrongly_is_refused_naming_the_field(
        tmp_path: Path, series: dict[str, float], field: str, said: str) -> None:
    import tomllib

    data = tomllib.loads(_unit(paper_actuators()[1], series))
    with pytest.raises(ParameterError) as e:
        parse_actuator(data, "knee.toml")
    assert e.value.field == field and said in str(e.value), str(e.value)


def _two_mass(dev, q_eq: np.ndarray, a: ActuatorModel, j: int
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The hanging leg linearised about ``q_eq`` with joint ``j``'s compliant unit ``a``
    (rotor, spring, current loop, torque loop; the other joints' drives giving nothing),
    as x' = A x + b tau_d with the spring's torque s x: (A, b, s), the state (q - q_eq
    (3), dq (3), the rotor's angle - q_eq[j], its speed, the motor's torque)."""
    leg = dev.plant.leg  # the links with the armature they carry
    M = leg.M(q_eq)
    Kg = np.empty((3, 3))
    for i in range(3):  # gravity's stiffness about the hanging posture
        d = np.zeros(3)
        d[i] = 1e-6
        Kg[:, i] = (leg.G(q_eq + d) - leg.G(q_eq - d)) / 2e-6
    Mi = np.linalg.inv(M)
    kp, kd = a.torque_loop_gains
    B, K, c = a.reflected_inertia, a.series_stiffness, a.series_damping
    Tc = 1.0 / (2 * math.pi * a.current_loop_bandwidth)
    A = np.zeros((9, 9))
    b = np.zeros(9)
    A[0:3, 3:6] = np.eye(3)
    A[3:6, 0:3] = -Mi @ Kg
    s = np.zeros(9)  # the spring's torque as a row: K (theta - q_j) + c (w - dq_j)
    s[6], s[j], s[7], s[3 + j] = K, -K, c, -c
    A[3:6] += np.outer(Mi[:, j], s)
    A[6, 7] = 1.0
    A[7] = -s / B
    A[7, 8] += 1.0 / B
    # the current loop follows the torque loop's command
    # (1 + kp) tau_d - kp K (theta - q_j) - kd K (w - dq_j)
    cmd = np.zeros(9)
    cmd[6], cmd[j], cmd[7], cmd[3 + j] = -kp * K, kp * K, -kd * K, kd * K
    A[8] = cmd / Tc
    A[8, 8] -= 1.0 / Tc
    b[8] = (1 + kp) / Tc
    return A, b, s


def _hanging(tmp_path: Path, u: Any, n: int) -> tuple[Any, np.ndarray, np.ndarray, np.ndarray]:
    """The paper's leg hanging at rest from a step (the foot clear of the belt), a
    frictionless series-spring knee driven by the joint torque ``u(k)`` (N m) at tick k:
    (the two-mass model about that rest, (A, b, s), and the knee's angle and the spring's
    torque at each of the ``n`` ticks' ends) -- the simulated device as the runtime runs it."""
    from scipy.optimize import fsolve

    import exoleg
    from exoleg.runtime.sim_backend import SimBackend
    from exoleg.system.config import DeviceConfig

    folder = _folder(tmp_path, {"knee": SPRING}, frictionless=True)
    cfg = DeviceConfig.load(folder, noise_scale=0.0)
    b = SimBackend.built(exoleg.paper_leg(), 27.5, config=cfg, step=0.3)
    a, leg, D = cfg.actuators[1], b.dev.plant.leg, b.S[0]
    q_eq = fsolve(leg.G, np.zeros(3))  # the leg hanging at rest
    assert np.max(np.abs(leg.G(q_eq))) < 1e-9
    D["x"][1:4], D["x"][5:8] = q_eq, 0.0
    D["rotor"][:] = [*q_eq, 0.0, 0.0, 0.0]
    D["vm"][:] = 0.0
    q, spring = np.empty(n), np.empty(n)
    b.read(0.0)
    for k in range(n):
        b.write(np.array([0.0, u(k), 0.0]), True)
        b.read((k + 1) * b.period)  # the plant stepped one tick under the command
        x, r = D["x"], D["rotor"]
        q[k] = x[2]
        spring[k] = a.series_stiffness * (r[1] - x[2]) + a.series_damping * (r[4] - x[6])
    return (_two_mass(b.dev, q_eq, a, 1), q_eq), q, spring, (np.arange(n) + 1) * b.period


def test_the_simulated_series_spring_follows_the_two_mass_model(tmp_path: Path) -> None:
    from scipy.linalg import expm

    step = 0.5  # the loop asks (1 + kp) 0.5 = 13 N m at once: within the drive
    ((A, b, s), q_eq), q, spring, t = _hanging(tmp_path, lambda k: step, 300)
    z_inf = -np.linalg.solve(A, b * step)  # the rest under the step
    z = np.array([z_inf - expm(A * ti) @ z_inf for ti in t])  # from rest, exactly
    q_lin, s_lin = z[:, 1] + q_eq[1], z @ s
    # measured against the linear model (a 0.5 N m step on the knee of the hanging paper
    # leg, 300 ms, 9 plant steps a tick): the spring's torque within 0.0030 N m, the knee
    # within 1.8e-5 rad -- what the torque loop's sampling at each plant step and the
    # deflection's 20-bit encoder make
    assert np.max(np.abs(spring - s_lin)) < 0.005, np.max(np.abs(spring - s_lin))
    assert np.max(np.abs(q - q_lin)) < 3e-5, np.max(np.abs(q - q_lin))
    assert abs(spring[-1] - step) < 0.005  # the loop holds the torque asked


def test_a_compliant_devices_walk_does_not_depend_on_its_plant_step(tmp_path: Path) -> None:
    """The plant's step is a numerical choice: a walk must not depend on it. The 10-year-old
    girl walking 4 strides transparent on the shipped units with series springs (links that
    carry no rotor: a light foot), at the device's own steps a tick (9) and at 16: the
    cuffs' residual per joint within 5 % -- measured 0.5 / 3.1 / 0.6 %; with the sole's
    friction held over each step explicitly (before
    :func:`~exoleg.world.plant.implicit_friction`) 1.1 / 7.2 / 37 %, the foot chattering
    at the step's rate."""
    from exoleg.child.model import ChildModel
    from exoleg.control.transparency import SupportMode
    from exoleg.sim.walk import simulate_walk
    from exoleg.sizing import personalized_leg
    from exoleg.sizing.child import population_child

    folder = _folder(tmp_path, {j: SPRING for j in JOINTS})
    c, _ = population_child(None, "female", 10.0, 50.0)
    rms = []
    for substeps in (1, 16):  # 1: the device's own (its fewest are more)
        r = simulate_walk(personalized_leg(c), c.mass, strides=4, child=ChildModel.of(c),
                          support_mode=SupportMode.TRANSPARENT, device=folder,
                          substeps=substeps)
        sel = r.t >= r.walk_start + 2 * r.stride_time
        rms.append(np.sqrt(np.mean(r.interaction[sel] ** 2, axis=0)))
    assert np.all(np.abs(rms[0] - rms[1]) <= 0.05 * rms[1]), rms


def test_validate_bounds_a_series_elastic_device_by_its_rotors(tmp_path: Path) -> None:
    """``validate --transparency`` on a device of series springs names, per joint, what
    any law leaves behind them (:func:`~exoleg.validate.transparency.rotor_floor`: the
    rotor following the link within its motor's current limit, the walk known ahead):
    a bound the law's residual on the same walk is above -- measured on the shipped
    units with 300 N m/rad springs, 4 strides: 0.179 / 0.085 / 0.037 against 0.742 /
    0.197 / 0.209 N m/kg (a rigid unit has none: NaN, tests/test_transparency.py)."""
    from exoleg.validate.transparency import evaluate

    v = evaluate(strides=4, device=_folder(tmp_path, {j: SPRING for j in JOINTS}))
    law = v.rows[-1]["rms_Nm_per_kg"]
    for f in v.floors:
        assert 0.0 < f["floor_rotor_Nm_per_kg"] < law[f["joint"]], (f, law)
    # the rigid gear's mode under the law is not a spring's: none is said for them
    assert all(g["alone"] is None and g["worn"] is None for g in v.gears)


@pytest.mark.parametrize("hz", [5.0, 30.0, 60.0])
def test_the_torque_loops_frequency_response_is_the_two_mass_models(tmp_path: Path,
                                                                     hz: float) -> None:
    """The spring's torque over the torque asked, sinusoidal at ``hz`` (held over each
    1 ms tick, as the controller's command is), against the two-mass model's transfer
    function s (jw - A)^-1 b times the hold's own response e^(-jwh/2) sinc(wh/2)."""
    amp, n = 0.3, 700
    w = 2 * math.pi * hz
    ((A, b, s), _), _, spring, t = _hanging(tmp_path, lambda k: amp * math.sin(w * k * 1e-3),
                                            n)
    # the response's first harmonic over the last 0.4 s (the transient gone: the slowest
    # closed-loop pole decays within 0.1 s)
    keep = t > t[-1] - 0.4  # t: the ticks' ends; the command sin(w k h) held from k h on
    X = np.column_stack([np.sin(w * t[keep]), np.cos(w * t[keep])])
    cs, cc = np.linalg.lstsq(X, spring[keep], rcond=None)[0]
    measured = complex(cs, cc) / amp  # x(t) = Im(H e^{jwt}) for u = sin(wt)
    h = 1e-3
    hold = np.exp(-1j * w * h / 2) * np.sinc(w * h / 2 / np.pi)
    model = complex(s @ np.linalg.solve(1j * w * np.eye(9) - A, b)) * hold
    # measured: at 5 / 30 / 60 Hz the gain within -0.28 / +0.74 / +1.8 % and the phase
    # within 0.08 / 0.67 / 0.20 deg of the model's (the loop sampled at each plant step)
    assert abs(abs(measured) / abs(model) - 1) < 0.03, (abs(measured), abs(model))
    assert abs(np.degrees(np.angle(measured / model))) < 1.5, np.angle(measured / model)


def test_a_series_elastic_device_gets_the_same_ticks_on_every_device(tmp_path: Path) -> None:
    """The tick contract (tests/test_tick_contract.py) on a device with a series-spring
    knee: the walking hierarchy on the simulated device and on both buses' rigs,
    which answer each drive's torque actual value (0x6077) with the torque its loop
    measures."""
    pytest.importorskip("canopen", reason="python-canopen (exoleg[hw])")
    pytest.importorskip("pysoem", reason="pysoem (exoleg[hw])")
    from conftest import BUS_WAIT, REALTIME
    from exoleg.runtime.session import run
    from exoleg.session_log import read_log

    folder = _folder(tmp_path / "device", {j: SPRING for j in ("knee",)})
    cols = {}
    for backend in ("sim", "canopen", "ethercat"):
        res, path = run(backend, 2.0, tmp_path / backend, arm=True, walk_after=0.5,
                        realtime=REALTIME,
                        bus_timeout=None if backend == "sim" else BUS_WAIT,
                        channel="contract-series", device=folder)
        assert res.stopped_by.startswith("duration"), (backend, res.stopped_by)
        cols[backend] = read_log(path)[1]
    sim, can, cat = cols["sim"], cols["canopen"], cols["ethercat"]
    for name in set(can) & set(cat):
        if name not in ("late", "bus_us"):
            assert np.array_equal(can[name], cat[name], equal_nan=True), name
    for c in (sim, can, cat):
        assert np.all(c["safety_status"].astype(int) & 2 == 0)  # no fault anywhere
    assert sim["u_knee"][0] == can["u_knee"][0]
    # the buses' per-mille torque targets (0.015 N m at the knee) pass through the knee's
    # torque loop ((1 + kp) = 26 times at once): measured over 2 s, hip / knee / ankle
    # apart by at most 0.93 / 13.2 / 0.60 mrad from the simulated device's
    for j, bound in (("hip", 5e-3), ("knee", 2e-2), ("ankle", 5e-3)):
        d = np.max(np.abs(sim[f"q_meas_{j}"] - can[f"q_meas_{j}"]))
        assert d < bound, (j, d)
    assert np.all(np.isfinite(can["tau_meas_knee"]))


def test_a_compliant_drive_answers_the_torque_its_loop_measures(tmp_path: Path) -> None:
    """The simulated rig's torque actual value (0x6077): a compliant knee's is the
    spring's torque as its deflection encoder reads it, not the motor's (which also
    accelerates the rotor); a rigid hip's is its motor's."""
    import exoleg
    from exoleg.hw import cia402
    from exoleg.hw.rig import DriveRig
    from exoleg.runtime.sim_backend import SimBackend
    from exoleg.system.config import DeviceConfig

    cfg = DeviceConfig.load(_folder(tmp_path, {"knee": SPRING}), noise_scale=0.0)
    rig = DriveRig(SimBackend.built(exoleg.paper_leg(), 27.5, config=cfg, step=0.3))
    for cw in (cia402.SHUTDOWN, cia402.SWITCH_ON_CMD):
        rig.cycle([cw] * 3, [0, 0, 0])
    target = [rig.scaling[j].to_per_mille(t) for j, t in
              zip(("hip", "knee", "ankle"), (2.0, 3.0, 0.0), strict=True)]
    for _ in range(40):  # 40 ms: the knee's rotor still accelerating behind its spring
        rig.cycle([cia402.ENABLE_OPERATION_CMD] * 3, target)
    S, dev = rig.dev.S[0], rig.dev
    knee, hip = rig.scaling["knee"], rig.scaling["hip"]
    assert rig.drive(1)[2] == knee.to_per_mille(float(S["joint_torque"][1]))
    assert rig.drive(0)[2] == hip.to_per_mille(float(dev.tau[0]))
    # the knee's motor and spring torques differ by the rotor's inertia torque here
    # (measured after 40 ms of a 3 N m target, 197 per mille: the spring 181, the motor 638)
    assert abs(knee.to_per_mille(float(dev.tau[1])) - rig.drive(1)[2]) > 100


@pytest.mark.parametrize("command", [["simulate", "--actuators"],
                                     ["identify", "--duration", "10"]])
def test_what_models_rigid_units_only_refuses_a_compliant_one(
        tmp_path: Path, capsys: pytest.CaptureFixture[str], command: list[str]) -> None:
    """The paper's scenario (the leg in the air, each rotor on its link) and
    identification (each rotor an armature in its regressor) model rigid units: a device
    folder with a series spring is said, not simulated or identified wrongly."""
    from exoleg.cli import main

    folder = _folder(tmp_path / "device", {"knee": SPRING})
    out = tmp_path / "out"
    assert main([*command, "--device", str(folder), "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "knee.toml" in err and "compliance" in err and "series_spring" in err, err
    assert not (out / "summary.json").exists() and not (out / "identify.json").exists()
