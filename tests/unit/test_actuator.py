"""Actuator models against analytic solutions and the paper's Table 2.

References: Table 2 (ratio, peak torque, maximum velocity, power); the analytic step
response of a first-order loop; the definition of quantisation; the shipped files'
own figures (reflected inertia N^2 J).
"""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from exoleg.device.actuator import (
    current_loop,
    encode,
    envelope,
    filter_gain,
    friction,
    load_actuator,
    paper_actuators,
)
from exoleg.errors import ParameterError
from exoleg.params import paper

ACTS = paper_actuators()
HIP, KNEE, ANKLE = ACTS
PAR = {a.joint: a.record() for a in ACTS}
DATA = Path(__file__).resolve().parents[2] / "src" / "exoleg" / "data" / "device" / "actuators"


def test_table2_figures_are_the_paper_s() -> None:
    for a, t2 in zip(ACTS, paper.actuators(), strict=True):
        assert (a.ratio, a.peak_torque, a.power) == (t2.gear_ratio, t2.max_torque, t2.power)
        assert a.max_velocity == pytest.approx(t2.max_velocity, rel=1e-15)
        assert a.sources["ratio"] == "Table 2" and a.sources["peak_torque"] == "Table 2"


def test_reflected_inertia_is_n_squared_j() -> None:
    # hip: 100^2 x (3.06e-4 + 7.9e-6) kg m^2 = 3.139 kg m^2
    assert HIP.reflected_inertia == pytest.approx(3.139, rel=1e-12)
    assert ANKLE.reflected_inertia == pytest.approx(120**2 * (1.21e-4 + 7.9e-6), rel=1e-12)


def test_envelope_corners() -> None:
    p = PAR["hip"]
    wmax = math.radians(300)
    assert envelope(p, 0.0) == HIP.torque_limit == 150.0           # Table 2 peak
    assert envelope(p, 0.1) == 150.0
    assert envelope(p, wmax) == pytest.approx(3 * 220.0 / wmax)     # peak power at max speed
    assert envelope(p, -wmax) == envelope(p, wmax)
    assert envelope(p, 1.1 * wmax) == 0.0                           # no-load speed
    assert envelope(p, 1.05 * wmax) == pytest.approx(0.5 * 3 * 220.0 / wmax)
    assert envelope(p, 100.0) == 0.0
    # continuous across the corner, never increasing with speed
    w = np.linspace(0, 1.2 * wmax, 5001)
    e = np.array([envelope(p, x) for x in w])
    assert np.all(np.diff(e) <= 1e-12) and np.all(e >= 0)


def test_current_limited_peak_binds_where_the_drive_is_weaker() -> None:
    # knee: N eta k_t I_peak = 50 x 0.8 x 0.0534 x 30 = 64.08 N m, below Table 2's 70
    assert KNEE.current_limited_torque == pytest.approx(64.08, rel=1e-12)
    assert KNEE.torque_limit == pytest.approx(64.08) and envelope(PAR["knee"], 0.0) == 64.08


def test_friction_is_odd_smooth_and_saturates() -> None:
    p = PAR["knee"]
    for w in (1e-4, 0.01, 0.3, 5.0):
        assert friction(p, -w) == -friction(p, w)
    assert friction(p, 0.0) == 0.0
    assert friction(p, 10.0) == pytest.approx(0.5 + 0.05 * 10.0, rel=1e-12)  # tanh(1000) = 1


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
    p = tmp_path / "a.toml"
    p.write_text("\n".join(lines))
    return p


@pytest.mark.parametrize("field,value,text", [
    ("ratio", 0.0, "ratio: 0 is outside 1-1000"),
    ("efficiency", 1.5, "efficiency: 1.5 is outside 0.05-1"),
    ("rotor_inertia", -1e-4, "rotor_inertia"),
    ("peak_current", "nan", "finite"),
    ("current_loop_bandwidth", 20000.0, "above half the loop rate"),
    ("encoder_bits", 20.5, "whole number"),
    ("joint", "elbow", "unknown 'elbow'"),
])
def test_bad_actuator_files_are_named(tmp_path: Path, field: str, value: object,
                                      text: str) -> None:
    v = float("nan") if value == "nan" else value
    with pytest.raises(ParameterError, match=text):
        load_actuator(_write(tmp_path, **{field: v}))


def test_actuator_file_round_trip(tmp_path: Path) -> None:
    a = load_actuator(_write(tmp_path))
    assert dataclasses.replace(a, sources=HIP.sources) == HIP
