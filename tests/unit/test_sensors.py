"""The FSRs' hysteresis and drift against the sheet's figures (Tekscan FlexiForce, S11 of
shared/design/device-datasheets.md: hysteresis < 4.5 % of full scale, drift < 5 % per
logarithmic time under a constant load) and the model's own definition."""

from __future__ import annotations

import numpy as np
import pytest

from exoleg.device.sensors import FootSensors, fsr_response

SENS = FootSensors.default()
REC = SENS.record()
FS = SENS.fsr_full_scale


def _memory() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    return np.zeros(4), np.zeros(4), np.zeros((4, 3))


def test_the_shipped_figures_are_the_sheets() -> None:
    assert (SENS.fsr_hysteresis, SENS.fsr_drift) == (0.045, 0.05)  # S11, the bounds


def test_hysteresis_loop_is_the_sheets_width_at_half_scale() -> None:
    # a load to full scale and back, the drift set aside (its own test, below)
    rec = REC.copy()
    rec[0]["drift"] = 0.0
    last, memory, creep = _memory()
    up, down = {}, {}
    forces = np.linspace(0.0, FS, 2001)
    for f in forces:
        up[round(f / FS, 4)] = fsr_response(rec, last, memory, creep, 0, f, 1e-3)
    for f in forces[::-1]:
        down[round(f / FS, 4)] = fsr_response(rec, last, memory, creep, 0, f, 1e-3)
    gap = np.array([down[k] - up[k] for k in up])
    # widest at half scale, the sheet's 4.5 % of full scale; the curves meet at the ends
    assert gap.max() == pytest.approx(0.045, rel=1e-9)
    assert abs(down[0.5] - up[0.5] - 0.045) < 1e-4
    assert up[0.0] == down[0.0] == 0.0
    assert up[1.0] == pytest.approx(down[1.0], abs=1e-4)
    assert np.all(gap >= -1e-6)  # unloading reads above loading


def test_drift_is_the_sheets_per_decade_under_a_constant_load() -> None:
    # held at half scale: the reading rises by about 5 % a decade of time between 1 and
    # 100 s (three first-order creep states), and relaxes once unloaded
    last, memory, creep = _memory()
    h = 1e-3
    reading = {}
    for k in range(1, 100_001):
        r = fsr_response(REC, last, memory, creep, 0, 0.5 * FS, h)
        if k in (1000, 10_000, 100_000):
            reading[k * h] = r
    for a, b in ((1.0, 10.0), (10.0, 100.0)):
        assert 0.04 <= reading[b] / reading[a] - 1.0 <= 0.055, (a, b, reading)
    for _ in range(300_000):  # 300 s unloaded: the creep relaxes
        fsr_response(REC, last, memory, creep, 0, 0.0, h)
    # the slowest state (100 s) keeps at most exp(-3) = 5.0 % of its 5 %: below 0.3 %
    assert np.all(np.abs(creep[0]) < 0.05 * 0.06)


def test_the_boards_counts_read_back_as_newtons() -> None:
    """FootSensors.newtons inverts the board's response (fsr_counts, noise-free): within
    one count's force (the ADC's quantization) over the FSR's range; 0 at 0."""
    from exoleg.device.sensors import FootSensors

    b = FootSensors.default(noise_scale=0.0)
    for force in np.linspace(0.0, b.fsr_full_scale, 60):
        c = b.counts(force)
        step = b.newtons(c + 1) - b.newtons(c)  # one count's force there
        assert abs(b.newtons(c) - force) <= step, (force, c)
    assert b.newtons(0.0) == 0.0


def test_the_other_foots_load_rolls_from_heel_to_toes() -> None:
    # other_loads by hand from its definition (sensors.toml [other_foot]: the heel's share
    # falls to none by heel_until, the hallux takes up to half of the forefoot's from
    # hallux_from, the metatarsal heads the rest 55 / 45): the whole load on the insole
    # at every point of the stance, all on the heel at the strike, half on the hallux at
    # the toe off, none beyond the stance's ends
    from exoleg.device.sensors import other_loads

    assert (SENS.other_foot, SENS.other_heel_until, SENS.other_hallux_from) == (
        False, 0.6, 0.5)  # not on the paper's device
    out = np.zeros(4)
    for p, want in ((0.0, [400, 0, 0, 0]), (0.3, [200, 110, 90, 0]),
                    (0.75, [0, 165, 135, 100]), (1.0, [0, 110, 90, 200]),
                    (-1.0, [400, 0, 0, 0]), (2.0, [0, 110, 90, 200])):
        other_loads(REC, 400.0, p, out)
        assert out == pytest.approx(want, abs=1e-9), p
    for p in np.linspace(0.0, 1.0, 41):
        other_loads(REC, 400.0, p, out)
        assert out.sum() == pytest.approx(400.0, rel=1e-12) and np.all(out >= 0.0)
    other_loads(REC, -5.0, 0.5, out)  # the support never pulls
    assert np.all(out == 0.0)
