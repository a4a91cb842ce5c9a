"""Actuator models against analytic solutions and the paper's Table 2.

References: the motors', gears' and drive's sheets (shared/design/device-datasheets.md,
transcribed in SHEETS and GEARS below); Table 2 (ratio, power); the motor's equations
(back-EMF, winding resistance); the analytic step response of a first-order loop; the
two-node thermal model solved by numpy's eigendecomposition; the definition of
quantisation.
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from exoleg.device.actuator import load_actuator, paper_actuators
from exoleg.device.drive import current_loop, drive_limit, encode, envelope, filter_gain, friction
from exoleg.errors import ParameterError
from exoleg.params import paper

ACTS = paper_actuators()
HIP, KNEE, ANKLE = ACTS
PAR = {a.joint: a.record() for a in ACTS}
DATA = Path(__file__).resolve().parents[2] / "src" / "exoleg" / "data" / "device" / "actuators"


#: the sheets' figures (shared/design/device-datasheets.md, checked 2026-12-01), by motor:
#: kt N m/A, rotor inertia kg m^2, I_N A, R ohm, L H, no-load speed at 24 V rpm, max
#: permissible speed rpm, winding and motor time constants s
SHEETS = {"EC 90 flat 160 W": (0.0712, 3.17e-4, 6.44, 0.213, 0.232e-3, 3170, 5000, 69.8, 260),
          "EC 60 flat 150 W": (0.0525, 8.1e-5, 7.25, 0.293, 0.279e-3, 4300, 6000, 16.1, 69.9)}
#: The maxon sheets' thermal resistances (line 18 winding-housing, line 17 housing-ambient:
#: the sheet prints 17 first), no-load current and pole pairs (line 29), read from the
#: sheets themselves (S1: May 2017 p. 271, part 323772; S2: June 2025 p. 324, part
#: 515458, the 24 V windings): until 2026-12-08 the files had the two resistances
#: swapped, the 160 W's no-load current the 90 W's and 12 pole pairs for both
SHEETS_MORE = {"EC 90 flat 160 W": (3.71, 2.37, 0.658, 11),
               "EC 90 flat 90 W": (2.6, 1.91, 0.544, 12)}
#: size-17 CSF gear ratings (S10): rated, repeated peak, momentary peak torque, N m
GEARS = {100: (24.0, 54.0, 108.0), 50: (16.0, 34.0, 70.0)}
SOURCE_IDS = ("S1", "S2", "S3", "S4", "S5", "S10", "D", "Table 2", "paper", "choice")


def test_the_files_carry_the_sheets_figures() -> None:
    for a in ACTS:
        sheet = SHEETS["EC 90 flat 160 W" if a.joint == "hip" else "EC 60 flat 150 W"]
        kt, j, i_n, r, ind, _, n_max, tw, tm = sheet
        assert (a.torque_constant, a.rotor_inertia, a.nominal_current, a.terminal_resistance,
                a.terminal_inductance, a.max_speed_rpm, a.thermal_time_constant_winding,
                a.thermal_time_constant_motor) == (kt, j, i_n, r, ind, n_max, tw, tm)
        if a.ratio in GEARS:
            assert (a.gear_rated_torque, a.repeated_peak_torque,
                    a.momentary_peak_torque) == GEARS[int(a.ratio)]
        assert a.gear_input_inertia == 0.079e-4  # S10
        assert a.current_loop_bandwidth == 200.0 and a.product_code == 0x65520000  # D, S3
        assert a.peak_current == pytest.approx(2 * a.nominal_current)  # S3: 2 x I_N
        # every figure names a source of the sheet, Table 2, the paper, or a choice
        for name, src in a.sources.items():
            assert src.startswith(SOURCE_IDS), (a.joint, name, src)
        assert not any("catalogue*" in src for src in a.sources.values())
    for t2, a in zip(paper.actuators(), ACTS, strict=True):
        assert a.ratio == t2.gear_ratio and a.power == t2.power  # Table 2


def test_no_load_speed_at_24_v_is_the_sheets() -> None:
    # V / k_t, the speed where the back-EMF takes the whole bus, against the sheets'
    # no-load speeds (which also carry the no-load current's drop: within 2.5 %)
    for a in ACTS:
        sheet = SHEETS["EC 90 flat 160 W" if a.joint == "hip" else "EC 60 flat 150 W"]
        rpm = a.no_load_speed * a.ratio / (2 * math.pi / 60)
        assert rpm == pytest.approx(sheet[5], rel=0.025)
    # device-datasheets.md (D): 191 / 516 / 215 deg/s at the joints, with the drop
    for a, d in zip(ACTS, (191, 516, 215), strict=True):
        assert math.degrees(a.max_velocity) == pytest.approx(d, rel=0.025)


def test_reflected_inertia_is_n_squared_j() -> None:
    # N^2 (J_rotor + J_gear_input); device-datasheets.md: knee 0.22, ankle 1.28 kg m^2
    assert HIP.reflected_inertia == pytest.approx(100**2 * (3.17e-4 + 7.9e-6), rel=1e-12)
    assert KNEE.reflected_inertia == pytest.approx(0.222, abs=0.001)
    assert ANKLE.reflected_inertia == pytest.approx(1.280, abs=0.001)


def test_continuous_torque_is_the_motors_nominal_current() -> None:
    # N eta k_t I_N: device-datasheets.md's 34-37 / 15 / 37 N m (not the drive's 15 A)
    assert HIP.continuous_torque == pytest.approx(100 * 0.8 * 0.0712 * 6.44, rel=1e-12)
    for a, lo, hi in ((HIP, 34, 37.5), (KNEE, 14.5, 15.5), (ANKLE, 36, 37.5)):
        assert lo <= a.continuous_torque <= hi


def test_envelope_against_the_motor_equations() -> None:
    for a in ACTS:
        p = PAR[a.joint]
        # stall: the current limit through the gear, within the gear's repeated peak
        assert envelope(p, 0.0) == min(a.ratio * 0.8 * a.torque_constant * a.peak_current,
                                       a.repeated_peak_torque)
        # no torque at the no-load speed of the bus voltage, V / (k_t N)
        w0 = a.bus_voltage / (a.torque_constant * a.ratio)
        assert envelope(p, w0) == 0.0 and envelope(p, 0.99 * w0) > 0.0
        # between, the winding's current (V - k_t N w) / R times N eta k_t
        w = 0.97 * w0
        i = (a.bus_voltage - a.torque_constant * a.ratio * w) / a.terminal_resistance
        assert envelope(p, w) == pytest.approx(min(a.torque_limit, a.joint_torque_constant
                                                   * min(i, a.peak_current)), rel=1e-12)
        assert envelope(p, -w) == envelope(p, w)
        e = np.array([envelope(p, x) for x in np.linspace(0, 1.2 * w0, 3001)])
        assert np.all(np.diff(e) <= 1e-12) and np.all(e >= 0)  # never rising with speed
    # at 48 V the motor's maximum permissible speed binds first (Table 2's 300 deg/s at
    # the hip: 5000 rpm / 100), above the no-load speed at 24 V
    fast = dataclasses.replace(HIP, bus_voltage=48.0)
    w_max = 5000 * 2 * math.pi / 60 / 100
    assert fast.max_velocity == pytest.approx(w_max) and math.degrees(w_max) == \
        pytest.approx(300.0)
    assert envelope(fast.record(), 0.999 * w_max) > 0 and envelope(fast.record(),
                                                                   1.001 * w_max) == 0


def test_the_consoles_envelope_is_the_drives() -> None:
    """The console draws each drive's envelope (/api/info) from the envelope's Python
    source, not its compiled code (the console's start loads none of numba): to the bit
    the compiled function the loop limits torque with, at every speed it sends, from
    stall to beyond the drive's top speed."""
    import exoleg
    from exoleg.hmi.views import device_info

    for a, shown in zip(ACTS, device_info(exoleg.paper_leg())["actuators"], strict=True):
        want = [envelope(a.record(), w) for w in shown["envelope_speed"]]
        assert shown["envelope_torque"] == want, a.joint
        assert want[0] > 0.0 and want[-1] == 0.0


@given(w=st.floats(-40.0, 40.0), u=st.floats(-200.0, 200.0))
def test_the_drive_brakes_at_any_speed(w: float, u: float) -> None:
    # Reference: a DC motor's four quadrants. Motoring (torque along the speed) the
    # back-EMF opposes the bus: the envelope. Braking (torque against it) the back-EMF
    # drives the current with the bus: only the current limit and the gear bind, even
    # beyond the no-load or permissible speed (up to 40 rad/s here, 10 x the ankle's).
    for a in ACTS:
        p = PAR[a.joint]
        limit = drive_limit(p, w, u)
        if u * w < 0.0:
            assert limit == min(a.torque_limit, a.joint_torque_constant * a.peak_current)
        else:
            assert limit == envelope(p, w)


def test_the_gear_binds_before_table_2() -> None:
    # the working limit: the gear's repeated peak (hip 54 < Table 2's 150; knee: the
    # current limit 50 x 0.8 x 0.0525 x 14.5 = 30.45 below the gear's 34)
    assert HIP.torque_limit == 54.0 and ANKLE.torque_limit == 54.0
    assert KNEE.torque_limit == pytest.approx(30.45, rel=1e-12)
    from exoleg.control.safety import SafetyLimits

    np.testing.assert_allclose(SafetyLimits.paper().max_torque, [54.0, 30.45, 54.0])


def test_friction_is_odd_smooth_and_saturates() -> None:
    p = PAR["knee"]
    for w in (1e-4, 0.01, 0.3, 5.0):
        assert friction(p, -w) == -friction(p, w)
    assert friction(p, 0.0) == 0.0
    # Coulomb: N k_t I_0 (the motor's no-load drag) + the gear's backdriving torque
    coulomb = 50 * 0.0525 * 0.493 + 1.7
    assert KNEE.coulomb_friction == pytest.approx(coulomb, rel=1e-12)
    assert friction(p, 10.0) == pytest.approx(coulomb + 0.05 * 10.0, rel=1e-12)


def _two_node(a, current: float, t: float, ambient: float = 25.0) -> np.ndarray:  # type: ignore[no-untyped-def]
    """The two-node model's solution, exp(A t) x0 by numpy's eigendecomposition of the
    system augmented with its constant input (the reference)."""
    rw, rh = a.thermal_resistance_winding, a.thermal_resistance_housing
    cw, ch = a.thermal_time_constant_winding / rw, a.thermal_time_constant_motor / rh
    q = a.terminal_resistance * current**2
    A = np.array([[-1 / (cw * rw), 1 / (cw * rw), 0.0],
                  [1 / (ch * rw), -1 / (ch * rw) - 1 / (ch * rh), ambient / (ch * rh)],
                  [0.0, 0.0, 0.0]])
    A[0, 2] = q / cw
    lam, V = np.linalg.eig(A)
    x = V @ np.diag(np.exp(lam * t)) @ np.linalg.solve(V, np.array([ambient, ambient, 1.0]))
    return np.real(x[:2])


def test_winding_temperature_against_the_two_node_solution() -> None:
    from exoleg.device.thermal import thermal_step, time_to_winding_limit

    for a in ACTS:
        th = a.thermal()
        for current, t in ((a.nominal_current, 30.0), (2 * a.nominal_current, 600.0)):
            T = np.array([25.0, 25.0])
            thermal_step(th, T, current, 25.0, t)
            np.testing.assert_allclose(T, _two_node(a, current, t), rtol=1e-10)
            chained = np.array([25.0, 25.0])
            for _ in range(1000):
                thermal_step(th, chained, current, 25.0, t / 1000)
            np.testing.assert_allclose(chained, T, rtol=1e-10)  # exact per step
        # steady state: T_a + R i^2 (R_wh + R_ha)
        steady = 25 + a.terminal_resistance * a.nominal_current**2 * (
            a.thermal_resistance_winding + a.thermal_resistance_housing)
        T = np.array([25.0, 25.0])
        thermal_step(th, T, a.nominal_current, 25.0, 1e6)
        assert T[0] == pytest.approx(steady, rel=1e-9)
        # I^2 t: the time to the winding's limit at the current limit, against the
        # reference's crossing on a 0.01 s grid
        limit_t = time_to_winding_limit(a, a.peak_current, alpha=0.0)
        ts = np.arange(0.0, 2 * limit_t, 0.01)
        temps = np.array([_two_node(a, a.peak_current, x)[0] for x in ts])
        crossing = ts[np.argmax(temps >= a.max_winding_temperature)]
        assert limit_t == pytest.approx(crossing, abs=0.011)
        assert time_to_winding_limit(a, 0.5 * a.nominal_current) == math.inf


def copper_rk4(a, current: float, t_end: float, h: float = 1e-3,  # type: ignore[no-untyped-def]
               ambient: float = 25.0, alpha: float = 0.00393) -> tuple[np.ndarray, np.ndarray]:
    """The two-node model with the winding's resistance R_25 (1 + alpha (T_w - 25)),
    integrated by classical RK4 in numpy (the reference for the nonlinear case): times
    and winding temperatures."""
    rw, rh = a.thermal_resistance_winding, a.thermal_resistance_housing
    cw, ch = a.thermal_time_constant_winding / rw, a.thermal_time_constant_motor / rh

    def f(x: np.ndarray) -> np.ndarray:
        loss = a.terminal_resistance * (1 + alpha * (x[0] - 25.0)) * current**2
        return np.array([(loss - (x[0] - x[1]) / rw) / cw,
                         ((x[0] - x[1]) / rw - (x[1] - ambient) / rh) / ch])

    n = int(round(t_end / h))
    x = np.array([ambient, ambient])
    out = np.empty(n + 1)
    out[0] = x[0]
    for k in range(n):
        k1 = f(x)
        k2 = f(x + h / 2 * k1)
        k3 = f(x + h / 2 * k2)
        k4 = f(x + h * k3)
        x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        out[k + 1] = x[0]
    return np.arange(n + 1) * h, out


def test_the_winding_s_resistance_rises_with_its_temperature() -> None:
    from exoleg.device.thermal import time_to_winding_limit, winding_temperature

    for a in (HIP, KNEE):
        # at the current limit: the time to the winding's limit against RK4's crossing
        ts, ref = copper_rk4(a, a.peak_current, 1.2 * time_to_winding_limit(a, a.peak_current))
        crossing = ts[np.argmax(ref >= a.max_winding_temperature)]
        limit_t = time_to_winding_limit(a, a.peak_current)
        assert limit_t == pytest.approx(crossing, abs=0.02)  # measured: < 0.01 s
        # hotter copper dissipates more: sooner than at 25 degC's resistance
        assert limit_t < time_to_winding_limit(a, a.peak_current, alpha=0.0)
        # a series of torques: within 2e-3 K of RK4 (measured 5e-4 K at the knee, the
        # loss held over each 1 ms step)
        tau = np.full(20000, a.joint_torque_constant * a.peak_current)
        T = winding_temperature(a, tau, 1e-3)[:, 0]
        np.testing.assert_allclose(T, copper_rk4(a, a.peak_current, 20.0)[1][1:], atol=2e-3)
    # the steady state at I_N, T = (T_a + g (1 - 25 alpha)) / (1 - alpha g) with
    # g = R_25 I_N^2 R_th, below the winding's limit: the motor may run at I_N for ever
    g = HIP.terminal_resistance * HIP.nominal_current**2 * (
        HIP.thermal_resistance_winding + HIP.thermal_resistance_housing)
    steady = (25 + g * (1 - 25 * 0.00393)) / (1 - 0.00393 * g)
    assert steady == pytest.approx(93.08, abs=0.01) and steady < HIP.max_winding_temperature
    long = winding_temperature(HIP, np.full(20000, HIP.continuous_torque), 1.0)[-1, 0]
    assert long == pytest.approx(steady, abs=0.01)  # 20000 s: the slow mode long settled
    assert time_to_winding_limit(HIP, HIP.nominal_current) == math.inf


def test_current_loop_matches_the_analytic_step_response() -> None:
    # tau' = (tau_c - tau) / T, T = 1/(2 pi f_c): end value and mean over a step of h
    p = PAR["ankle"]
    T = 1 / (2 * math.pi * ANKLE.current_loop_bandwidth)
    for h in (1e-5, 1e-4, 1e-3):
        end, mean = current_loop(p, 2.0, 10.0, h)
        assert end == pytest.approx(10.0 - 8.0 * math.exp(-h / T), rel=1e-14)
        t = np.linspace(0.0, h, 200001)
        ref = np.trapezoid(10.0 - 8.0 * np.exp(-t / T), t) / h  # numeric mean
        assert mean == pytest.approx(ref, rel=1e-9)
    # chained steps equal one long step (exact discretisation)
    tau = 0.0
    for _ in range(10):
        tau, _ = current_loop(p, tau, 5.0, 1e-4)
    assert tau == pytest.approx(current_loop(p, 0.0, 5.0, 1e-3)[0], rel=1e-13)


@given(q=st.floats(-10.0, 10.0))
def test_encoder_quantises_to_half_a_count(q: float) -> None:
    p = PAR["hip"]
    r = 2 * math.pi / 2**20
    m = encode(p, q)
    assert abs(m - q) <= r / 2 * (1 + 1e-9)
    assert abs(m / r - round(m / r)) < 1e-6  # a whole number of counts


def test_velocity_filter_gain() -> None:
    # y += b (x - y): after one tick a step reaches 1 - exp(-2 pi f h) of the way
    assert filter_gain(PAR["hip"], 1e-3) == pytest.approx(1 - math.exp(-2 * math.pi * 0.1))


def _write(tmp_path: Path, **changes: object) -> Path:
    import tomllib

    d = tomllib.loads((DATA / "hip.toml").read_text())
    d.update(changes)
    lines = []
    for k, v in d.items():
        if k == "sources":
            continue
        lines.append(f"{k} = {v!r}".replace("'", '"') if isinstance(v, str) else f"{k} = {v}")
    lines.append("[sources]")
    lines += [f'{k} = "{v}"' for k, v in d["sources"].items()]
    p = tmp_path / "a.toml"
    p.write_text("\n".join(lines))
    return p


@pytest.mark.parametrize("field,value,text", [
    ("ratio", 0.0, "ratio: 0 is outside 1-1000"),
    ("efficiency", 1.5, "efficiency: 1.5 is outside 0.05-1"),
    ("rotor_inertia", -1e-4, "rotor_inertia"),
    ("peak_current", "nan", "finite"),
    ("peak_current", 40.0, "above the drive's peak"),
    ("nominal_current", 20.0, "must not exceed the drive's current limit"),
    ("repeated_peak_torque", 500.0, "rated <= repeated peak <= momentary peak"),
    ("current_loop_bandwidth", 20000.0, "above half the loop rate"),
    ("encoder_bits", 20.5, "whole number"),
    ("pole_pairs", 7.5, "whole number"),
    ("joint", "elbow", "unknown 'elbow'"),
])
def test_bad_actuator_files_are_named(tmp_path: Path, field: str, value: object,
                                      text: str) -> None:
    v = float("nan") if value == "nan" else value
    with pytest.raises(ParameterError, match=text):
        load_actuator(_write(tmp_path, **{field: v}))


def test_actuator_file_round_trip(tmp_path: Path) -> None:
    a = load_actuator(_write(tmp_path))
    assert a == HIP and a.sources == HIP.sources


def test_a_figure_without_a_source_is_refused(tmp_path: Path) -> None:
    text = (DATA / "hip.toml").read_text()
    (tmp_path / "a.toml").write_text(text.replace('\nterminal_resistance = "S2"', ""))
    with pytest.raises(ParameterError, match="sources.terminal_resistance: every figure "
                                             "names its source"):
        load_actuator(tmp_path / "a.toml")


def test_hip_variants_load_and_differ_as_the_sheets_say() -> None:
    from exoleg.device.actuator import hip_variant

    v90, v160, v260 = (hip_variant(n) for n in ("ec90flat-90w", "ec90flat-160w",
                                                 "ec90flat-260w"))
    assert v160 == HIP  # the shipped hip is the 160 W, the paper's assumption
    assert v90.torque_constant == 0.0705 and v90.nominal_current == 6.06  # S1
    for v, sheet in ((v160, "EC 90 flat 160 W"), (v90, "EC 90 flat 90 W")):
        assert (v.thermal_resistance_winding, v.thermal_resistance_housing,
                v.no_load_current, v.pole_pairs) == SHEETS_MORE[sheet]
    # the 260 W class takes the 160 W's thermal figures and pole pairs (its file: choice)
    w, h, _, pairs = SHEETS_MORE["EC 90 flat 160 W"]
    assert (v260.thermal_resistance_winding, v260.thermal_resistance_housing,
            v260.pole_pairs) == (w, h, pairs)
    assert v260.reflected_inertia == pytest.approx(100**2 * (5.06e-4 + 7.9e-6))  # ~5.1
    with pytest.raises(ParameterError, match="allowed: ec90flat-160w, ec90flat-260w, "
                                             "ec90flat-90w"):
        hip_variant("ec90flat-220w")
