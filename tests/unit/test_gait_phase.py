"""Gait-phase detection on synthetic force-sensor sequences (reference: the sequences'
own construction -- where each region is loaded is known to the millisecond)."""

from __future__ import annotations

import numpy as np
import pytest

from exoleg.control import gait_phase as gp

SET = gp.DetectorSettings.default()
FLOOR = 200.0
D = SET.record(FLOOR, 1.0)


def _walk(strides: int, T: float = 1.0, dt: float = 1e-3, noise: float = 0.0,
          seed: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """Counts (N, 4) of a heel-strike gait: heel 0-30 %, forefoot 10-60 %, swing 60-100 %;
    and the times."""
    t = np.arange(int(strides * T / dt)) * dt
    x = (t / T) % 1.0
    heel = (x < 0.30) * 2000.0
    fore = ((x >= 0.10) & (x < 0.60)) * 1800.0
    c = np.stack([heel, fore, 0.8 * fore, 0.6 * fore], axis=1)
    c += np.random.default_rng(seed).normal(0.0, noise, c.shape)
    return np.clip(c, 0.0, 4095.0), t


def _run(counts: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    st = gp.new_state(D)
    ev = np.array([gp.detect(D, st, c, np.nan, tt) for c, tt in zip(counts, t, strict=True)])
    return ev, st


def test_events_at_the_constructed_times_plus_the_debounce() -> None:
    counts, t = _walk(5)
    ev, _ = _run(counts, t)
    deb = SET.debounce
    for bit, frac in ((gp.Event.FF, 0.10), (gp.Event.HO, 0.30), (gp.Event.TO, 0.60)):
        times = t[(ev & bit) > 0]
        assert len(times) == 5, bit
        assert np.allclose(times % 1.0, frac + deb, atol=1.5e-3), (bit, times)
    ic = t[(ev & gp.Event.IC) > 0]
    # the first contact is at t = 0 + debounce; then every stride
    assert np.allclose(ic, np.arange(5) + deb, atol=1.5e-3)


def test_stride_time_is_the_mean_of_the_last_strides() -> None:
    counts, t = _walk(6, T=1.2)
    _, st = _run(counts, t)
    assert gp.stride_time(D, st) == pytest.approx(1.2, abs=2e-3)


def test_hysteresis_and_debounce_keep_noise_from_chattering() -> None:
    # noise of 5 % of the loaded reading: no extra events
    counts, t = _walk(5, noise=100.0, seed=3)
    ev, _ = _run(counts, t)
    for bit in gp.Event:
        assert ((ev & bit) > 0).sum() == 5, bit


def test_toe_walking_still_gives_initial_contact() -> None:
    counts, t = _walk(3)
    counts[:, 0] = 0.0  # no heel: forefoot first (a crouch or equinus gait)
    ev, _ = _run(counts, t)
    assert ((ev & gp.Event.IC) > 0).sum() == 3
    assert ((ev & gp.Event.FF) > 0).sum() == 0


def test_strides_out_of_range_are_rejected() -> None:
    counts, t = _walk(4)
    _, st = _run(counts, t)
    n = st[0]["n_stride"]
    # a stride of 3 s (3 x the expected 1 s, beyond 1.75 x) is not averaged in
    more, t2 = _walk(2)
    quiet = np.zeros((2000, 4))
    seq = np.vstack([counts, quiet, more])
    times = np.arange(len(seq)) * 1e-3
    _, st2 = _run(seq, times)
    assert st2[0]["n_stride"] == n + 1  # the gap stride is rejected, the next one counts


def test_bad_settings_are_named() -> None:
    from exoleg.errors import ParameterError

    with pytest.raises(ParameterError, match="contact_on/contact_off"):
        gp.DetectorSettings(0.1, 0.2, 20.0, 0.008, 0.15, 0.15, 3, (0.25, 1.75))
    with pytest.raises(ParameterError, match="stride_accept"):
        gp.DetectorSettings(0.25, 0.15, 20.0, 0.008, 0.15, 0.15, 3, (1.2, 1.75))


def _gyro(t: np.ndarray, T: float = 1.0) -> np.ndarray:
    """The foot's sagittal rate for :func:`_walk`'s gait, rad/s: still in stance, turning
    toe-down from push-off (50 %) through toe off (60 %) to 62 % (as the simulated walks'
    feet do: their fastest toe-down turn 30 ms after toe off), then swinging forward (a
    half sine of 6 rad/s)."""
    x = (t / T) % 1.0
    return np.where(x < 0.5, 0.0, np.where(x < 0.62, -4.0,
                                           6.0 * np.sin(np.pi * (x - 0.62) / 0.38)))


def _fused(counts: np.ndarray, gyro: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    st = gp.new_state(D)
    ev = np.array([gp.detect(D, st, c, g, tt) for c, g, tt in zip(counts, gyro, t, strict=True)])
    return ev, st


def test_the_gyroscope_ends_a_stance_a_preloaded_sensor_holds_on_to() -> None:
    # reference: the gait's construction (swing from 60 % of each 1 s stride). A strap
    # preloading the first metatarsal sensor by 25 % of full scale: the FSRs alone never
    # see the foot lift; with the gyroscope, the first swing ends the stance once the
    # foot has swung forward faster than 3 rad/s for 50 ms (sin > 0.5 from 68.3 % of the
    # stride), the readings then become the sensors' offsets, and every later
    # toe off is the FSRs' again (60 % + the debounce), confirmed by the foot turning.
    counts, t = _walk(5)
    counts[:, 1] = np.minimum(counts[:, 1] + 0.25 * 4095, 4095)
    alone, _ = _run(counts, t)
    assert not np.any(alone & gp.Event.TO)  # the FSRs alone: one endless stance
    ev, st = _fused(counts, _gyro(t), t)
    to = t[(ev & gp.Event.TO) > 0]
    assert to[0] == pytest.approx(0.62 + 0.38 / 6 + SET.gyro_swing_time, abs=2e-3)
    assert np.allclose(to[1:] % 1.0, 0.6 + SET.debounce, atol=2e-3)
    assert len(to) == 5 and st[0]["source"] == gp.Source.FSR_IMU
    ic = t[(ev & gp.Event.IC) > 0]
    assert np.allclose(ic[1:] % 1.0, SET.debounce, atol=2e-3) and len(ic) == 5


def test_a_still_foot_is_on_the_ground_whatever_the_fsrs_read() -> None:
    # load under the midfoot, between the sensors, 30-40 % of the stride: the FSRs read
    # nothing. Alone they call it a toe off (then an initial contact); with the gyroscope
    # reading a still foot there is none -- and without a gyroscope reading (NaN, or at
    # its range: saturated) the detector is the FSRs' alone.
    counts, t = _walk(4)
    x = t % 1.0
    counts[(x >= 0.30) & (x < 0.40)] = 0.0
    alone, _ = _run(counts, t)
    assert np.sum((alone & gp.Event.TO) > 0) == 8  # two a stride: one of them false
    ev, _ = _fused(counts, _gyro(t), t)
    to = t[(ev & gp.Event.TO) > 0]
    assert len(to) == 4 and np.allclose(to % 1.0, 0.6 + SET.debounce, atol=2e-3)
    d = SET.record(FLOOR, 1.0, gyro_range=5.0)  # the swing's 6 rad/s is beyond it
    st = gp.new_state(d)
    sat = np.array([gp.detect(d, st, c, g, tt) for c, g, tt in
                    zip(counts, np.clip(_gyro(t), -5.0, 5.0), t, strict=True)])
    assert np.sum((sat & gp.Event.TO) > 0) >= 4


def test_a_baseline_follows_a_strap_loosened() -> None:
    # the preload of the test above, gone after 3 strides (the strap loosened): the
    # baseline the gyroscope's swing set falls to the swing's readings, and the sensor
    # counts its load again -- every stride still has its toe off at 60 % + the debounce
    counts, t = _walk(6)
    pre = t < 3.0
    counts[pre, 1] = np.minimum(counts[pre, 1] + 0.25 * 4095, 4095)
    ev, st = _fused(counts, _gyro(t), t)
    to = t[(ev & gp.Event.TO) > 0]
    assert len(to) == 6 and np.allclose(to[1:] % 1.0, 0.6 + SET.debounce, atol=2e-3)
    assert st[0]["base"][1] == 0.0
