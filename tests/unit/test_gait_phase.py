"""Gait-phase detection on synthetic force-sensor sequences (reference: the sequences'
own construction -- where each region is loaded is known to the millisecond)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from exoleg.control import gait_phase as gp
from exoleg.device.sensors import FootSensors

SET = gp.DetectorSettings.default()
FLOOR = 200.0
D = SET.record(FLOOR, 1.0)
NO_ACC = np.full(2, np.nan)  # no accelerometer reading
NO_OTHER = np.full(4, np.nan)  # no insole under the other foot
_BOARD = FootSensors.default()
TOP = float(2**_BOARD.adc_bits - 1)  # the ADC's full scale, counts


def _noisy(counts: np.ndarray, seed: int) -> np.ndarray:
    """``counts`` with the datasheet's FSR noise (sensors.toml), within the ADC's range: a
    loaded reading unchanged for frozen_time is a frozen board."""
    rng = np.random.default_rng(seed)
    return np.clip(counts + rng.normal(0.0, _BOARD.fsr_noise * TOP, counts.shape), 0.0, TOP)


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
    """The FSRs alone (no gyroscope reading): event bits per tick and the final state."""
    ev, _, st = _fused(counts, np.full(len(t), np.nan), t)
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


def test_a_heel_bearing_little_after_its_landing_is_not_off() -> None:
    # the heel's running maximum is its landing's: at full scale for 40 ms, then it bears
    # 8 % of that (the simulated walks' heel: 25-45 N after a 500 N landing) until 30 %
    # of the stride, the forefoot loaded from 10 %. Foot flat at 10 % and heel off at 30 %
    # (+ the debounce; reference: the sequence's construction). At contact_off (0.15) the
    # heel read as off as its landing ended, before the forefoot loaded: no foot flat and
    # no heel off in any stride
    counts, t = _walk(5)
    x = t % 1.0
    counts[:, 0] = np.where(x < 0.04, TOP, np.where(x < 0.30, 0.08 * TOP, 0.0))
    ev, _ = _run(counts, t)
    for bit, frac in ((gp.Event.FF, 0.10), (gp.Event.HO, 0.30)):
        at = t[(ev & bit) > 0]
        assert len(at) == 5 and np.allclose(at % 1.0, frac + SET.debounce, atol=1.5e-3), at
    late = dataclasses.replace(SET, heel_off=SET.contact_off)
    ev, _, _ = _fused(counts, np.full(len(t), np.nan), t, d=late.record(FLOOR, 1.0))
    assert not np.any(ev & (gp.Event.FF | gp.Event.HO))
    assert ((ev & gp.Event.TO) > 0).sum() == 5


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
        dataclasses.replace(SET, contact_on=0.1, contact_off=0.2)
    with pytest.raises(ParameterError, match="stride_accept"):
        dataclasses.replace(SET, stride_accept=(1.2, 1.75))


def _gyro(t: np.ndarray, T: float = 1.0) -> np.ndarray:
    """The foot's sagittal rate for :func:`_walk`'s gait, rad/s, shaped as the simulated
    walks' feet turn: a toe-down slap as the heel lands (0-6 %), still at foot flat, a
    toe-down turn from heel rise (50 %) growing to 4 rad/s at 64 % -- after the toe off
    at 60 %: the toes' tips, on no sensor, leave last -- then a forward swing (a half
    sine of 6 rad/s)."""
    x = (t / T) % 1.0
    slap = -2.0 * np.sin(np.pi * np.clip(x, 0.0, 0.06) / 0.06)
    turn = -2.0 * (1.0 - np.cos(np.pi * (x - 0.5) / 0.14))
    swing = 6.0 * np.sin(np.pi * (x - 0.64) / 0.36) \
        - 4.0 * np.cos(0.5 * np.pi * np.minimum((x - 0.64) / 0.04, 1.0))
    return np.where(x < 0.06, slap, np.where(x < 0.5, 0.0, np.where(x < 0.64, turn, swing)))


#: Where the toe-down turn of :func:`_gyro` has eased to half its steepest since the
#: FSRs' lift at 60 % + the debounce: turn' ~ sin(pi (x - 0.5) / 0.14), steepest at the
#: lift (past 57 %), half of it at sin = sin(lift) / 2; plus the slope's smoothing
#: (``slope_time``) as a lag
_LIFT = 0.6 + SET.debounce
_TO = 0.5 + 0.14 / np.pi * (np.pi - np.arcsin(0.5 * np.sin(np.pi * (_LIFT - 0.5) / 0.14)))


def _ticks(counts: np.ndarray, gyro: np.ndarray, t: np.ndarray, acc: np.ndarray = NO_ACC,
           d: np.ndarray = D) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Event bits, the source and whether the leg bears at each tick, and the final state
    (``acc``: the accelerometer, one reading or one per tick)."""
    st = gp.new_state(d)
    ev = np.empty(len(t), dtype=np.int64)
    src = np.empty(len(t), dtype=np.int64)
    bearing = np.empty(len(t), dtype=bool)
    for k in range(len(t)):
        ev[k] = gp.detect(d, st, counts[k], gyro[k], acc[k] if acc.ndim == 2 else acc, t[k],
                          NO_OTHER)
        src[k], bearing[k] = st[0]["source"], st[0]["bearing"]
    return ev, src, bearing, st


def _fused(counts: np.ndarray, gyro: np.ndarray, t: np.ndarray, acc: np.ndarray = NO_ACC,
           d: np.ndarray = D) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Event bits and the source at each tick, and the final state (:func:`_ticks`)."""
    ev, src, _, st = _ticks(counts, gyro, t, acc, d)
    return ev, src, st


def _times(ev: np.ndarray, t: np.ndarray, bit: gp.Event) -> np.ndarray:
    return t[(ev & bit) > 0]


def test_the_gyroscope_times_the_toe_off_the_fsrs_read_early() -> None:
    # reference: the gait's construction (:data:`_TO`). The FSRs alone call the toe off
    # at their lift (60 % + the debounce); fused, it is when the foot's toe-down turn has
    # eased past its steepest, within the slope's smoothing after the constructed time
    counts, t = _walk(4)
    ev, src, _ = _fused(counts, _gyro(t), t)
    to = _times(ev, t, gp.Event.TO) % 1.0
    assert len(to) == 4
    assert np.all((to >= _TO) & (to <= _TO + 2 * SET.slope_time)), (to, _TO)
    assert np.allclose(_times(ev, t, gp.Event.IC) % 1.0, SET.debounce, atol=2e-3)
    assert np.all(src == gp.Source.FSR_IMU)


def test_a_toe_walker_fused() -> None:
    # reference: the gait's construction. A toe walker (equinus: the forefoot strikes, the
    # heel never bears): the foot turns heel-down at up to 2 rad/s as the forefoot takes
    # the load (0-15 % of the stride; toe-up, the swing's sense) where a heel striker's
    # slaps toe-down. One contact and one toe off a stride, at the constructed times as
    # for the heel striker, and no foot flat
    _, t = _walk(4)
    x = t % 1.0
    counts = _noisy(np.outer(x < 0.6, [0.0, 1800.0, 1440.0, 1080.0]), 2)  # forefoot, 0-60 %
    g = _gyro(t)
    g = np.where(x < 0.15, 2.0 * np.sin(np.pi * x / 0.15), np.where(x < 0.5, 0.0, g))
    ev, src, _ = _fused(counts, g, t)
    assert np.allclose(_times(ev, t, gp.Event.IC), np.arange(4) + SET.debounce, atol=2e-3)
    to = _times(ev, t, gp.Event.TO) % 1.0
    assert len(to) == 4 and np.all((to >= _TO) & (to <= _TO + 2 * SET.slope_time)), to
    assert not np.any(ev & gp.Event.FF)  # the heel never bears
    assert np.all(src == gp.Source.FSR_IMU)


def test_the_gyroscope_ends_a_stance_a_preloaded_sensor_holds_on_to() -> None:
    # reference: the gait's construction. A strap preloading the first metatarsal sensor
    # by 25 % of full scale: the FSRs alone do not see the first swing (no toe off), but
    # the landing after it -- the preloaded sensor alone loaded and steady for min_swing,
    # then the heel loaded -- is a contact, the sensor's swing reading its offset, and
    # every later event is at its constructed time; with the gyroscope, the first swing
    # ends the stance once the foot has swung forward faster than 3 rad/s for 50 ms, the
    # readings then become the sensors' offsets, and every later toe off is the fused one
    counts, t = _walk(5)
    counts[:, 1] = np.minimum(counts[:, 1] + 0.25 * 4095, 4095)
    alone, st = _run(counts, t)
    assert np.allclose(_times(alone, t, gp.Event.IC), np.arange(5) + SET.debounce, atol=1e-6)
    assert np.allclose(_times(alone, t, gp.Event.TO), np.arange(1, 5) + 0.6 + SET.debounce,
                       atol=1.5e-3)
    assert st[0]["base"][1] == pytest.approx(0.25 * 4095)
    g = _gyro(t)
    ev, src, _ = _fused(counts, g, t)
    to = _times(ev, t, gp.Event.TO)
    first_fast = t[np.argmax((g > SET.gyro_swing) & (t < 1.0))]
    assert to[0] == pytest.approx(first_fast + SET.gyro_swing_time, abs=2e-3)
    assert len(to) == 5 and np.all((to[1:] % 1.0 >= _TO) & (to[1:] % 1.0 <= _TO + 0.012))
    assert np.all(src == gp.Source.FSR_IMU)
    assert np.allclose(_times(ev, t, gp.Event.IC)[1:] % 1.0, SET.debounce, atol=2e-3)


def _resting(rest: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The FSRs alone over a stride of :func:`_walk` (1 s), then a landing, flat, and the
    foot resting on its heel alone, toes up, with a steady load for ``rest`` s (as a held
    swing's preloaded sensor reads), the forefoot down again for 1 s, and the heel alone
    again for 1 s; with the datasheet's noise (:func:`_noisy`). Event bits, whether the
    leg bears, and the times."""
    counts, _ = _walk(2)
    counts = counts[:1300]  # stride 2: heel strike, flat, heel off at 1.3 s ...
    n = int(round(rest * 1e3))
    heel = np.tile([1500.0, 0.0, 0.0, 0.0], (n, 1))  # ... the heel alone, steady
    down = np.tile([1500.0, 1800.0, 1440.0, 1080.0], (1000, 1))  # the forefoot down
    seq = np.vstack([counts, heel, down, heel[:1000]])
    seq[1100:1300, 0] = 1500.0  # flat until the forefoot lifts at 1.3 s
    t = np.arange(len(seq)) * 1e-3
    ev, _, bearing, _ = _ticks(_noisy(seq, 1), np.full(len(t), np.nan), t)
    return ev, bearing, t


@pytest.mark.parametrize("rest", [0.6, 1.2])
def test_a_foot_resting_on_one_sensor_is_not_a_swing(rest: float) -> None:
    # reference: the sequence's construction. Resting on the heel longer than half a
    # stride (0.6 and 1.2 s against the 1 s strides) is not a held swing (a swing is
    # shorter: held_swing): the leg bears from the landing to the end, no toe off, no
    # contact but the landing. Without that bound the forefoot's load was read as a
    # contact and the heel's resting load became its offset: the heel alone again then
    # read as the foot lifted, a toe off under a loaded leg (both rests; bounded by the
    # stride, the 0.6 s one)
    ev, bearing, t = _resting(rest)
    assert np.allclose(_times(ev, t, gp.Event.TO), [0.6 + SET.debounce], atol=1.5e-3)
    assert np.all(bearing[t >= 1.0 + SET.debounce])
    assert np.allclose(_times(ev, t, gp.Event.IC), [SET.debounce, 1.0 + SET.debounce],
                       atol=1.5e-3)


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
    ev, _, _ = _fused(counts, _gyro(t), t)
    assert len(_times(ev, t, gp.Event.TO)) == 4
    d = SET.record(FLOOR, 1.0, gyro_range=5.0)  # the swing's 6 rad/s is beyond it
    sat, src, _ = _fused(counts, np.clip(_gyro(t), -5.0, 5.0), t, d=d)
    assert np.sum((sat & gp.Event.TO) > 0) >= 4
    assert gp.Source.FSR in src  # says so while the gyroscope reads at its range


def test_a_baseline_follows_a_strap_loosened() -> None:
    # the preload of the test above, gone after 3 strides (the strap loosened): the
    # baseline the gyroscope's swing set falls to the swing's readings, and the sensor
    # counts its load again -- every later stride has its fused toe off
    counts, t = _walk(6)
    pre = t < 3.0
    counts[pre, 1] = np.minimum(counts[pre, 1] + 0.25 * 4095, 4095)
    ev, _, st = _fused(counts, _gyro(t), t)
    to = _times(ev, t, gp.Event.TO)
    assert len(to) == 6 and np.all((to[1:] % 1.0 >= _TO) & (to[1:] % 1.0 <= _TO + 0.012))
    assert st[0]["base"][1] == 0.0


@pytest.mark.parametrize("fault", ["missing", "zeros", "frozen"])
def test_the_imu_walks_on_when_the_fsrs_are_lost(fault: str) -> None:
    # reference: the gait's construction. From 2 s the FSRs are lost: their readings
    # missing (NaN: at once), reading zeros (silent: fsr_silent_strides strides after they
    # last read a load, at 60 % of the stride before), or frozen at a loaded reading
    # (frozen_ms after they stopped changing). The IMU alone
    # then gives an initial contact as the slap's toe-down turn passes the contact
    # threshold (0.12 x the 6 rad/s swing: 0.72 rad/s, at 0.65 % of the stride) and the
    # toe off as the push-off's turn eases past its steepest (half of it past 57 %); the
    # detector says it rests on the IMU, and on both again once the FSRs read.
    counts, t = _walk(8)
    lost = (t >= 2.0) & (t < 6.0)
    if fault == "missing":
        counts[lost] = np.nan
    elif fault == "zeros":
        counts[lost] = 0.0
    else:
        counts[lost] = counts[np.argmax(t >= 1.5)]  # held at a loaded reading
    ev, src, _ = _fused(counts, _gyro(t), t)
    onset = {"missing": 2.0, "zeros": 1.6 + SET.fsr_silent_strides * 1.0,
             "frozen": 2.0 + SET.frozen_time}[fault]
    imu = t[src == gp.Source.IMU]
    assert imu[0] == pytest.approx(onset, abs=2e-3) and imu[-1] == pytest.approx(6.0, abs=2e-3)
    k = (t > imu[0] + 0.05) & (t < 6.0)
    ic = _times(ev[k], t[k], gp.Event.IC)
    to = _times(ev[k], t[k], gp.Event.TO)
    ic_at = np.arcsin(0.12 * 6.0 / 2.0) / np.pi * 0.06
    to_at = 0.5 + 0.14 / np.pi * (np.pi - np.pi / 6)
    strides = np.arange(8.0)
    assert np.allclose(ic, [x for x in strides + ic_at if imu[0] + 0.05 < x < 6.0],
                       atol=2e-3), ic
    want = np.array([x for x in strides + to_at if imu[0] + 0.05 < x < 6.0])
    assert len(to) == len(want), to
    assert np.all((to >= want) & (to <= want + 2 * SET.slope_time)), to
    assert src[-1] == gp.Source.FSR_IMU  # the FSRs read again


def test_a_stance_the_fsrs_held_ends_in_a_toe_off_when_the_imu_takes_over() -> None:
    # reference: the gait's construction. The board frozen at a loaded reading from
    # 2.15 s (15 % of a stance) is set aside frozen_ms later, at 2.65 s: after the IMU's
    # own toe off (61.7 %, test above) and before the foot's forward swing could end the
    # FSRs' stance (faster than 3 rad/s for 50 ms: past 75 %). The hand-over says the toe
    # off the IMU passed then -- every stride keeps one toe off (the stride was left
    # without one before) -- and the later ones are the IMU's own
    counts, t = _walk(6)
    counts = _noisy(counts, 4)
    lost = t >= 2.15
    counts[lost] = counts[np.argmax(lost)]
    ev, src, _ = _fused(counts, _gyro(t), t)
    handover = 2.15 + SET.frozen_time
    assert t[np.argmax(src == gp.Source.IMU)] == pytest.approx(handover, abs=2e-3)
    to = _times(ev, t, gp.Event.TO)
    to_at = 0.5 + 0.14 / np.pi * (np.pi - np.pi / 6)
    assert len(to) == 6, to
    assert to[2] == pytest.approx(handover, abs=2e-3)
    assert np.all((to[3:] % 1.0 >= to_at) & (to[3:] % 1.0 <= to_at + 2 * SET.slope_time)), to
    assert len(_times(ev, t, gp.Event.IC)) == 6


@pytest.mark.parametrize("fault", ["missing", "zeros", "frozen"])
def test_the_fsrs_back_in_mid_stance_take_up_the_imus_phase(fault: str) -> None:
    # reference: the gait's construction. The FSRs lost from 2 s (as above) and back at
    # 6.3 s, 30 % into a stance the IMU is walking: their path takes up the IMU's phase,
    # so the stance goes on -- one contact and one toe off a stride, at the FSRs' and the
    # fused times (before, their path, left in its swing from before, said a second
    # contact there, and the hand-over a toe off)
    counts, t = _walk(9)
    counts = _noisy(counts, 1)
    lost = (t >= 2.0) & (t < 6.3)
    counts[lost] = {"missing": np.nan, "zeros": 0.0}.get(fault, counts[np.argmax(t >= 1.5)])
    ev, src, _ = _fused(counts, _gyro(t), t)
    assert src[-1] == gp.Source.FSR_IMU
    late = t >= 5.8
    ic, to = _times(ev[late], t[late], gp.Event.IC), _times(ev[late], t[late], gp.Event.TO)
    assert np.allclose(ic, [6.0 + SET.debounce, 7.0 + SET.debounce, 8.0 + SET.debounce],
                       atol=2e-3), ic
    assert len(to) == 3 and np.all((to % 1.0 >= _TO) & (to % 1.0 <= _TO + 2 * SET.slope_time)), to


def _other_foot(t: np.ndarray, on: float, off: float, seed: int = 5) -> np.ndarray:
    """The unassisted foot's insole (counts, (N, 4)) loaded from ``on`` to ``off`` of each
    stride of :func:`_walk` (past 1: into the next), with the FSRs' noise."""
    x = (t % 1.0)
    down = (x >= on) | (x < off - 1.0) if off > 1.0 else (x >= on) & (x < off)
    return _noisy(np.outer(down, [1500.0, 1200.0, 1000.0, 800.0]), seed)


def _with_other(counts: np.ndarray, gyro: np.ndarray, t: np.ndarray,
                other: np.ndarray) -> np.ndarray:
    """Event bits per tick, the detector reading the other foot's insole too."""
    d = SET.record(FLOOR, 1.0, other_foot=True)
    st = gp.new_state(d)
    return np.array([gp.detect(d, st, counts[k], gyro[k], NO_ACC, t[k], other[k])
                     for k in range(len(t))])


def test_the_other_foot_bearing_alone_ends_a_stance_a_preloaded_sensor_holds() -> None:
    # reference: the gait's construction. The strap's preload of the test above, the
    # gyroscope failed, the other foot's insole fitted (the other foot down from 50 % of
    # the stride to 110 %: double support at each end). The FSRs alone missed the first
    # swing's toe off; now the preloaded sensor, alone and settled since the lift (60 %)
    # for min_swing while the other foot bears alone, is a swing: the toe off said at
    # 60 % + min_swing, its reading then the sensor's offset; the later ones at the lift
    counts, t = _walk(5)
    counts[:, 1] = np.minimum(counts[:, 1] + 0.25 * 4095, 4095)
    ev = _with_other(counts, np.full(len(t), np.nan), t, _other_foot(t, 0.5, 1.1))
    to = _times(ev, t, gp.Event.TO)
    assert len(to) == 5, to
    assert to[0] == pytest.approx(0.6 + SET.min_swing, abs=2e-3)
    assert np.allclose(to[1:] % 1.0, 0.6 + SET.debounce, atol=1.5e-3)
    assert np.allclose(_times(ev, t, gp.Event.IC), np.arange(5) + SET.debounce, atol=1.5e-3)
    # a push-off on the hallux alone, unloading slowly over 40-60 % while the other foot
    # bears alone, is not a held sensor (it falls): the toe off stays at the lift
    x = t % 1.0
    push = np.stack([(x < 0.3) * 2000.0, (x >= 0.1) & (x < 0.4), (x >= 0.1) & (x < 0.4),
                     (x >= 0.1) & (x < 0.6)], axis=1).astype(float)
    push[:, 1:3] *= 1800.0
    push[:, 3] *= np.where(x < 0.4, 1800.0, 1800.0 * (0.6 - x) / 0.2 + 300.0)
    ev = _with_other(_noisy(push, 6), np.full(len(t), np.nan), t, _other_foot(t, 0.35, 1.1))
    to = _times(ev, t, gp.Event.TO) % 1.0  # the hallux's last 300 counts in its noise
    assert len(to) == 5 and np.all((to >= 0.6) & (to <= 0.6 + SET.debounce + 2e-3)), to


def test_the_imu_says_no_toe_off_while_the_other_foot_is_off_the_ground() -> None:
    # reference: the gait's construction; walking has no flight. The IMU alone (the FSRs
    # failed) would say the toe off at 61.7 % (test above); with the other foot landing
    # only at 65 %, the toe off waits for it (the toe-down turn still past its steepest)
    counts, t = _walk(4)
    ev = _with_other(np.full_like(counts, np.nan), _gyro(t), t, _other_foot(t, 0.65, 1.1))
    to = _times(ev, t, gp.Event.TO)
    assert len(to) >= 3 and np.allclose(to[-3:] % 1.0, 0.65, atol=2e-3), to


def test_a_frozen_gyroscope_leaves_the_fsrs_alone() -> None:
    # the gyroscope held at its last reading from 1.5 s (a board repeating a stale
    # frame): after frozen_ms the FSRs decide alone, and say so
    counts, t = _walk(4)
    g = _gyro(t)
    g[t >= 1.5] = g[np.argmax(t >= 1.5)]
    ev, src, _ = _fused(counts, g, t)
    assert np.all(src[t >= 1.5 + SET.frozen_time + 1e-3] == gp.Source.FSR)
    late = t > 2.5
    assert np.allclose(_times(ev[late], t[late], gp.Event.TO) % 1.0, _LIFT, atol=2e-3)


def test_the_accelerometer_keeps_a_jolted_foot_off_the_ground() -> None:
    # the IMU alone, standing up from an unknown phase: a foot still in rotation but
    # jolted (its specific force 5 m/s^2 off g) is not yet flat; once its specific force
    # is g's it is (reference: the rule, still_ms after both settle)
    t = np.arange(1000) * 1e-3
    acc = np.stack([np.zeros_like(t), 9.80665 + np.where(t < 0.3, 5.0, 0.0)], axis=1)
    ev, src, _ = _fused(np.full((len(t), 4), np.nan), 1e-3 * np.sin(50 * t), t, acc)
    assert _times(ev, t, gp.Event.FF)[0] == pytest.approx(0.3 + SET.still_time, abs=2e-3)
    assert np.all(src == gp.Source.IMU)


def test_the_toe_off_once_the_foot_has_rolled_over_its_toes() -> None:
    # reference: the construction. The foot turns toe-down at a steady 6 rad/s from 55 %
    # to 70 % of the stride (no easing to time it by): once its hallux's sensor has read
    # a load in the last stance, the toe off is when it has rolled toe_roll (10 deg) past
    # the FSRs' lift (60 % + the debounce): 29 ms later; the first stride (no stance
    # before) and every stride with the hallux's sensor failed wait for the turn to ease
    # (the swing from 70 %)
    counts, t = _walk(4)
    x = t % 1.0
    g = np.where(x < 0.55, 0.0, np.where(x < 0.70, -6.0, 6.0 * np.sin(np.pi * (x - 0.7) / 0.3)))
    g += np.random.default_rng(0).normal(0.0, 1e-3, len(t))  # a live sensor's noise
    roll = _LIFT + SET.toe_roll / 6.0
    ev, _, _ = _fused(counts, g, t)
    to = _times(ev, t, gp.Event.TO) % 1.0
    assert to[0] == pytest.approx(0.70, abs=2e-3)
    assert np.allclose(to[1:], roll, atol=2e-3), (to, roll)
    counts[:, 3] = 0.0  # the hallux's sensor failed
    ev, _, _ = _fused(counts, g, t)
    assert np.allclose(_times(ev, t, gp.Event.TO) % 1.0, 0.70, atol=2e-3)


def test_a_jolt_of_a_standing_foot_is_not_a_push_off() -> None:
    # the IMU alone (the FSRs reading NaN), the foot flat and still, then jolted toe-down
    # at 2 rad/s for 20 ms (as when walking starts) and still again: heel off at most,
    # then flat again -- no toe off (a push-off lasts push_ms and ends turning)
    t = np.arange(2000) * 1e-3
    g = 1e-3 * np.sin(50 * t) - 2.0 * np.sin(np.pi * np.clip((t - 1.0) / 0.02, 0.0, 1.0))
    ev, _, st = _fused(np.full((len(t), 4), np.nan), g, t, np.array([0.0, 9.80665]))
    assert not np.any(ev & gp.Event.TO)
    assert st[0]["phase"] == gp.Phase.FLAT and st[0]["source"] == gp.Source.IMU


def _strike_walk(strides: int = 4) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(counts, gyroscope, accelerometer, t) of :func:`_walk`'s gait with the foot turned
    toe-down in the air from 90 % of the stride (1.5 rad/s: a controller ahead of the
    foot) and struck at 0 %: the specific force 30 m/s^2 off its mean for 3 ms; in swing
    it sways by 4 m/s^2 (smoothly: no jump beyond 1 m/s^2 from its 10 ms mean); a live
    sensor's noise on both."""
    counts, t = _walk(strides)
    x = t % 1.0
    g = np.where(x >= 0.9, -1.5, _gyro(t))
    acc = np.zeros((len(t), 2))
    acc[:, 1] = 9.80665 + np.where(x >= 0.64, 4.0 * np.sin(np.pi * (x - 0.64) / 0.36), 0.0)
    acc[(x < 0.003) & (t > 0.5), 1] += 30.0
    rng = np.random.default_rng(1)
    return counts, g + rng.normal(0.0, 1e-3, len(t)), acc + rng.normal(0.0, 1e-3, acc.shape), t


def test_the_imu_takes_the_contact_at_the_strike_not_at_a_foot_turned_in_the_air() -> None:
    # reference: the construction. The IMU alone (the FSRs reading NaN): with the
    # accelerometer the initial contact is the strike (its jump beyond impact = 10 m/s^2
    # and twice the swing's largest, at 0 % of each stride); without it, the toe-down turn
    # past max(0.5, 0.12 x 6) rad/s -- at 90 %, 100 ms early: in a closed loop this is what
    # set the controller ahead of the foot (exoleg validate --gait-phase measured the IMU
    # alone's contact 105 ms off before the strike was used, 1 ms after)
    counts, g, acc, t = _strike_walk()
    lost = np.full_like(counts, np.nan)
    ev, src, _ = _fused(lost, g, t, acc)
    assert np.all(src == gp.Source.IMU)
    ic = _times(ev, t, gp.Event.IC)[1:]  # the first: standing still, from an unknown phase
    assert np.allclose(ic, [1.0, 2.0, 3.0], atol=1.5e-3), ic
    ev, _, _ = _fused(lost, g, t)
    assert np.allclose(_times(ev, t, gp.Event.IC)[1:], [0.9, 1.9, 2.9, 3.9], atol=1.5e-3)


def test_a_failed_heel_sensor_leaves_the_contact_to_the_strike() -> None:
    # reference: the construction. The heel's sensor reads 0: in the first stance the
    # FSRs see the contact as the forefoot loads (10 % + the debounce); that stance read
    # no heel load, so from the next the strike (0 %) is the contact
    counts, g, acc, t = _strike_walk()
    counts[:, 0] = 0.0
    ev, src, _ = _fused(counts, g, t, acc)
    assert np.all(src[t > 0.2] == gp.Source.FSR_IMU)
    ic = _times(ev, t, gp.Event.IC)
    assert np.allclose(ic[ic > 0.09], [0.10 + SET.debounce, 1.0, 2.0, 3.0], atol=1.5e-3), ic
    # with the heel's sensor working the FSRs' contact stands (heel loaded + debounce)
    counts, g, acc, t = _strike_walk()
    ev, _, _ = _fused(counts, g, t, acc)
    assert np.allclose(_times(ev, t, gp.Event.IC), np.arange(4.0) + SET.debounce, atol=1.5e-3)


def test_a_heel_off_is_said_once() -> None:
    # the IMU alone, the foot flat and still, then turning toe-down at 0.45 rad/s: faster
    # than gyro_heel_off (0.4) yet slower than gyro_still (0.5) -- one heel off, not one
    # every other tick (the foot was still before the heel off, not since)
    t = np.arange(2000) * 1e-3
    g = 1e-3 * np.sin(50 * t) - np.where(t >= 1.0, 0.45, 0.0)
    ev, _, st = _fused(np.full((len(t), 4), np.nan), g, t, np.array([0.0, 9.80665]))
    assert len(_times(ev, t, gp.Event.HO)) == 1
    assert st[0]["phase"] == gp.Phase.PUSH


def test_the_imu_alone_lets_the_weight_off_before_the_toe_off() -> None:
    # reference: the construction. The IMU alone (the FSRs reading NaN): from the second
    # stride the stance model ends ("bearing", the controller's swing from there) as the
    # push-off's turn -2 (1 - cos(pi (x - 0.5) / 0.14)) passes unload_turn (0.65) of the
    # last push-off's fastest (its reading at the toe off, the turn's fastest so far),
    # before its toe off -- as the fused stance model ends at the FSRs' lift. In the first
    # stride (no push-off before) it ends at the toe off
    counts, t = _walk(4)
    g = _gyro(t)
    ev, _, bearing, _ = _ticks(np.full_like(counts, np.nan), g, t)
    off = t[1:][bearing[:-1] & ~bearing[1:]]
    to = _times(ev, t, gp.Event.TO)
    fastest = g[(t > 0.5) & (t <= to[0])].min()
    x = 0.5 + 0.14 * np.arccos(1.0 - SET.unload_turn * -fastest / 2.0) / np.pi
    assert off[0] == pytest.approx(to[0], abs=1.5e-3)
    assert np.allclose(off[1:] % 1.0, x, atol=1.5e-3), (off, x)
    assert np.all(to[1:] % 1.0 > x + 0.01)
