"""Gait-phase detection from the foot board's force sensors and its IMU, together or alone.

**The FSRs.** Each FSR reading is normalised by its running maximum (a floor keeps an
unloaded start from dividing by nothing); the heel region is the heel sensor, the
forefoot the largest of the metatarsal and hallux sensors; the foot is lifted when
neither is loaded and the sum of all four is under the off threshold of its own running
maximum (a load spread over several sensors, each below its threshold, is still a foot on
the ground). A region is loaded above ``contact_on`` and unloaded below ``contact_off``
(hysteresis; the heel below ``heel_off``: its running maximum is its landing's), and a
change counts only once it has held for ``debounce_ms``:

    swing --(either region loaded)--> initial contact (IC)
    IC: heel and forefoot loaded --> foot flat (FF)
    FF: heel unloaded, forefoot loaded --> heel off (HO)
    any stance phase: the foot lifted --> toe off (TO) --> swing

An initial contact after a toe-walking approach (forefoot first) counts too. A sensor
the foot's lift leaves loaded (a strap's preload, drift) holds the stance while nothing
else reads the swing; its landing is still seen (:func:`_held_landing`): the contact
counts and the sensor's swing reading becomes its offset. A foot resting on one point
longer than a swing lasts is not a held swing; a shorter rest, the FSRs alone cannot
tell from one.

**Fused with the foot's gyroscope** (its sagittal rate, rad/s; foot-gyro detection:
Catalfamo et al. 2010; in children with CP, Behboodi et al. 2019):

* the toe off is timed by the foot's turn: the last load is under the toes' tips, on no
  sensor, so the FSRs read the foot lifted 30-90 ms early; the toe off is when, the FSRs
  reading it lifted, the foot's toe-down turn has passed its steepest (its rate of
  change eased to ``slope_eased`` of the steepest since), or -- the hallux's sensor
  working -- the foot has rolled ``toe_roll`` over its toes since, or, lifted late, the
  turn has eased ``gyro_rise`` from its fastest. The controller's stance model ends at
  the lift (``bearing``). A foot not turning is on the ground whatever the sensors under
  it read (load under the midfoot, between them);
* a foot swinging forward (faster than half the last swing's fastest turn, within
  ``gyro_swing_floor``-``gyro_swing``: the running calibration, slow walking swings
  slowly) for ``gyro_swing_ms`` is in swing whatever the FSRs read: a stance they hold
  on to (a sensor preloaded by the strap, drift) ends with a toe off there, and each
  sensor's reading then is its offset (its baseline; a lower reading in a later swing
  lowers it);
* the strike: the accelerometer's reading jumping from its mean over ``impact_ms`` by
  more than ``impact`` and ``impact_ratio`` times the largest jump since the foot swung
  forward (a running calibration), once the forward turn has eased below
  ``impact_swing`` of its fastest, is the foot striking the ground: the initial contact
  when the heel's sensor read no load last stance (failed, or a child landing on the
  forefoot: the FSRs would see the contact only as the forefoot loads).

**The IMU alone** (:func:`~exoleg.control.gait_imu._imu_path`, its own phases from the
gyroscope and the accelerometer; its initial contact the strike) runs beside them and
decides when the FSRs cannot: their readings missing (NaN), frozen (a loaded reading unchanged for
``frozen_ms``: noise always moves a live one) or silent (nothing loaded for
``fsr_silent_strides`` strides the IMU has walked).
The gyroscope is not used when missing, saturated (at its range) or frozen; the FSRs then
decide alone. The accelerometer is not used when missing or frozen (at its range it
reads a strike). The state says which source it rests on (``source``: :class:`Source`).
When the IMU takes over, an event its path has passed and the FSRs' had not said (a toe
off while the frozen board held the stance) is said then: every stance ends in a toe
off, every swing in a contact; when the FSRs are back, their path takes up the IMU's
phase (its own is from before they were lost).

**The unassisted foot's insole**, when fitted (:func:`_other_bears`): walking has no
flight, so while the other foot does not bear the body the device's foot does -- no
lift its FSRs read, no toe off the IMU alone would say; while it bears the body alone
(``other_full``), a sensor the FSRs alone hold since the lift (settled for
``min_swing``) is a swing.

The stride time is the mean of the last ``strides_averaged`` IC-to-IC intervals that lie
within ``stride_accept`` times the expected one; the gait percentage is the time since
the last IC over it. Thresholds, hysteresis, debounce and stride rules are data
(``data/device/gait_phase.toml``); the update is compiled (:func:`detect`).
"""

from __future__ import annotations

import math

import numpy as np
from numba import njit

from exoleg.control.gait_imu import _eased, _imu_path, _lasting
from exoleg.control.gait_settings import SETTINGS, DetectorSettings
from exoleg.control.gait_state import (
    EVENT_NAMES,
    HISTORY,
    PHASE_NAMES,
    SOURCE_NAMES,
    STATE,
    Event,
    Phase,
    Source,
    new_state,
)

# what the detector says (its state, gait_state) and reads (its settings), re-exported
__all__ = ["EVENT_NAMES", "HISTORY", "PHASE_NAMES", "SETTINGS", "SOURCE_NAMES", "STATE",
           "DetectorSettings", "Event", "Phase", "Source", "detect", "forefoot",
           "gait_fraction", "new_state", "stride_time"]


@njit(inline="always")
def _region(raw_was, loaded, since, value, on, off, t, debounce):  # type: ignore[no-untyped-def]
    """One region's hysteresis and debounce: (raw, loaded, since) after ``value``."""
    raw = value > (off if raw_was else on)
    if loaded != raw:
        if since < 0.0:
            since = t
        if t - since >= debounce - 1e-12:
            loaded = raw
            since = -1.0
    else:
        since = -1.0
    return raw, loaded, since


@njit(inline="always")
def _stride(D, s):  # type: ignore[no-untyped-def]
    n = min(s.n_stride, D.strides_averaged)
    if n == 0:
        return D.expected_stride
    acc = 0.0
    for i in range(n):
        acc += s.history[i]
    return acc / n


@njit(cache=True)
def stride_time(d, st):  # type: ignore[no-untyped-def]
    """The current stride estimate, s: the mean of the last accepted strides, or the
    expected one before any."""
    return _stride(d[0], st[0])


@njit(inline="always")
def _swing_level(D, s):  # type: ignore[no-untyped-def]
    """The forward turn (rad/s) that is a swing: half the last swing's fastest, within
    ``gyro_swing_floor``-``gyro_swing`` (the running calibration: slow walking swings
    slowly)."""
    return min(D.gyro_swing, max(D.gyro_swing_floor, 0.5 * s.peak))


@njit(inline="always")
def _normalised(D, s, counts, i):  # type: ignore[no-untyped-def]
    """Sensor i's reading above its baseline over its running maximum's."""
    return max(counts[i] - s.base[i], 0.0) / max(s.max[i] - s.base[i], D.floor)


@njit(inline="always")
def _loads(D, s, counts):  # type: ignore[no-untyped-def]
    """The heel's, the hallux's and the forefoot's (its largest sensor's) normalised
    loads."""
    hallux = _normalised(D, s, counts, 3)
    return (_normalised(D, s, counts, 0), hallux,
            max(_normalised(D, s, counts, 1), _normalised(D, s, counts, 2), hallux))


@njit(cache=True)
def forefoot(st, counts):  # type: ignore[no-untyped-def]
    """The forefoot's load: the metatarsal heads' and the hallux's sensors' ``counts``
    (ADC counts), each above its baseline (the detector's own, ``st``), summed."""
    s = st[0]
    load = 0.0
    for i in range(1, 4):
        load += max(counts[i] - s.base[i], 0.0)
    return load


@njit(inline="always")
def _contact(D, s, t, h, f, hallux):  # type: ignore[no-untyped-def]
    """An initial contact read by the FSRs (the heel region ``h``, the forefoot's ``f``,
    the hallux's normalised reading): its events and the phase it starts."""
    s.t_ic_f = t
    s.stance_min = 0.0
    s.hallux_now = hallux > D.contact_on
    s.heel_now = h
    s.held = -1
    s.stance_mask = 0
    if h and f:
        return Event.IC | Event.FF, Phase.FLAT
    return Event.IC, Phase.LOADING


@njit(inline="always")
def _held_landing(D, s, counts, t):  # type: ignore[no-untyped-def]
    """A sensor the foot's lift left loaded (a strap's preload, drift) while nothing read
    the swing: one sensor alone loaded and steady (its reading's mean over ``held_time``
    within ``held_band`` of its span above its lowest) for ``min_swing``, after another
    bore this stance; then a load -- on another sensor, or on it by ``contact_on`` of its
    span above that lowest -- held for ``debounce`` and within ``held_swing`` of the
    stride (a swing is shorter: held longer, the foot rests on it) is the foot landing.
    Returns whether it landed; its lowest is then its offset."""
    held = s.held
    n = 0
    one = -1
    other = False
    for i in range(4):
        x = _normalised(D, s, counts, i)
        if x > D.contact_on:
            s.stance_mask |= 1 << i
            other = other or i != held
        if x >= D.contact_off:
            n += 1
            one = i
    if n == 0:  # the foot lifted off every sensor: the usual toe off
        s.held = -1
        return False
    if held >= 0 and t - s.held_since >= D.min_swing - 1e-12:
        span = max(s.max[held] - s.held_min, D.floor)
        # held longer than a swing can last, the foot rests on it: no landing until a lift
        if t - s.held_since <= D.held_swing * _stride(D, s) and \
                (other or (counts[held] - s.held_min) / span > D.contact_on):
            if s.held_hit < 0.0:
                s.held_hit = t
            if t - s.held_hit >= D.debounce - 1e-12:
                s.base[held] = s.held_min
                s.held_hit = -1.0
                return True
        else:
            s.held_hit = -1.0
        return False
    if n >= 2 and held >= 0:
        # another sensor loaded beside the held one: held for the debounce, the held
        # swing is over; noise on an unloaded sensor -- a tick or two at 3x the
        # datasheet's -- is not (it restarted the wait for min_swing, and a GMFCS III
        # girl's first landing after the walk's start went unseen)
        if s.held_extra < 0.0:
            s.held_extra = t
        if t - s.held_extra >= D.debounce - 1e-12:
            s.held, s.held_extra = -1, -1.0
        return False
    s.held_extra = -1.0
    if n == 1 and s.stance_mask & ~(1 << one):
        if one == held:
            dt = t - s.held_t
            s.held_mean += dt / (D.held_time + dt) * (counts[one] - s.held_mean)
            s.held_t = t
        if one != held or (s.held_mean - s.held_min) \
                / max(s.max[one] - s.held_min, D.floor) > D.held_band:
            s.held, s.held_since, s.held_t = one, t, t  # (again) from here
            s.held_mean = s.held_min = counts[one]
            s.held_ref, s.held_low = counts[one], t
        s.held_min = min(s.held_min, s.held_mean)
        # still falling (a push-off unloading slowly), by held_band of its span since
        # held_low: not yet settled
        if (s.held_ref - s.held_mean) / max(s.max[one] - s.held_min, D.floor) > D.held_band:
            s.held_ref, s.held_low = s.held_mean, t
    else:
        s.held = -1
    return False


@njit(inline="always")
def _fsr_path(D, s, counts, gyro, gyro_ok, strike, t, bears):  # type: ignore[no-untyped-def]
    """The FSRs' path, the gyroscope fused when it reads: this tick's events. ``strike``:
    the foot's IMU reads the foot striking the ground (:func:`detect`) -- the initial
    contact when the heel's sensor read no load last stance (failed, or a child landing
    on the forefoot). ``bears``: whether the other foot bears the body (or is not read):
    while it does not, this foot does, whatever its sensors read (:func:`_other_bears`)."""
    total = 0.0
    for i in range(4):
        if counts[i] > s.max[i]:
            s.max[i] = counts[i]
        total += counts[i]
    if total > s.total_max:
        s.total_max = total
    base = s.base[0] + s.base[1] + s.base[2] + s.base[3]
    heel, hallux, fore = _loads(D, s, counts)
    if hallux > D.contact_on:
        s.hallux_now = True
    s.heel_raw, s.heel, s.heel_since = _region(s.heel_raw, s.heel, s.heel_since, heel,
                                               D.contact_on, D.heel_off, t, D.debounce)
    s.fore_raw, s.fore, s.fore_since = _region(s.fore_raw, s.fore, s.fore_since, fore,
                                               D.contact_on, D.contact_off, t, D.debounce)
    h = s.heel
    f = s.fore
    if s.heel_raw or s.fore_raw:
        s.t_loaded = t
    if h:
        s.heel_now = True
    # the whole foot unloaded, too: a load spread over several sensors, each below its own
    # threshold, is still a foot on the ground
    lifted = bears and not h and not f and \
        (total - base) / max(s.total_max - base, D.floor) < D.contact_off
    swinging, s.swing_since = _lasting(gyro_ok and gyro > _swing_level(D, s), s.swing_since,
                                       t, D.gyro_swing_time)
    phase = s.phase_f
    if phase == Phase.SWING:  # a reading in swing is at most the sensor's offset
        for i in range(4):
            if counts[i] < s.base[i]:
                s.base[i] = counts[i]
    ev = 0
    if phase <= Phase.SWING:  # swing or unknown
        if (h or f or (strike and not s.heel_last)) and not swinging \
                and (phase == Phase.UNKNOWN or t - s.t_to_f >= D.min_swing):
            ev, phase = _contact(D, s, t, h, f, hallux)
        s.lift = False
        s.unloaded = False
    elif _held_landing(D, s, counts, t):  # the stance held was a swing: a contact again
        heel, hallux, fore = _loads(D, s, counts)  # the held sensor rebased
        s.heel = s.heel_raw = heel > D.contact_on
        s.fore = s.fore_raw = fore > D.contact_on
        s.heel_since = s.fore_since = -1.0
        ev, phase = _contact(D, s, t, s.heel, s.fore, hallux)
        s.lift = False
        s.unloaded = False
    else:
        # the FSRs read the foot lifted and it turns: the weight is off the foot, its
        # toes' tips (on no sensor) alone bearing -- the controller's swing from here
        if lifted and (not gyro_ok or abs(gyro) > D.gyro_turning) \
                and t - s.t_ic_f >= D.min_stance:
            s.unloaded = True
        if gyro_ok and t - s.t_ic_f >= D.min_stance:  # not the turn as the foot lands
            s.stance_min = min(s.stance_min, gyro)
        if lifted and not s.lift:
            s.lift_min = np.inf
            s.steepest = 0.0
            s.lift_angle = s.angle
        s.lift = lifted
        if lifted and gyro_ok:
            s.lift_min = min(s.lift_min, gyro)
            s.steepest = min(s.steepest, s.slope)
        to = False
        if lifted and not gyro_ok:
            to = True
        elif lifted:  # a still foot is on the ground whatever the sensors under it read
            # with the gyroscope, the toe off is when the foot's toe-down turn has passed
            # its steepest since the lift
            to = s.lift_min < -D.gyro_turning and (
                _eased(D, s.slope, s.steepest)
                # rolled over the toes' tips by toe_roll since the hallux's sensor
                # unloaded (it read a load last stance: not failed)
                or (s.hallux_last and s.lift_angle - s.angle >= D.toe_roll)
                # lifted late, the turn's fastest past (as deep as this stance's deepest)
                or (s.lift_min <= D.push_depth * s.stance_min
                    and gyro >= s.lift_min + D.gyro_rise))
            to = to or gyro > D.gyro_turning
        # the FSRs alone, one sensor held since the lift (a strap's preload, drift:
        # :func:`_held_landing`), settled (no longer falling) for a swing's first part
        # (min_swing), while the other foot bears the body alone (``other_full`` of its
        # largest load): the foot swings (a push-off on one sensor unloads it)
        held_off = not gyro_ok and s.held >= 0 and t - s.held_low >= D.min_swing \
            and s.other_share >= D.other_full
        # the gyroscope or the other foot reads a swing the FSRs do not
        rebase = not to and (swinging or held_off)
        if (to or rebase) and t - s.t_ic_f >= D.min_stance:
            ev |= Event.TO
            s.t_to_f = t
            s.hallux_last = s.hallux_now
            s.heel_last = s.heel_now
            phase = Phase.SWING
            if rebase:  # the FSRs' readings now are their offsets
                for i in range(4):
                    s.base[i] = counts[i]
                if held_off:
                    s.base[s.held] = s.held_min
                s.held = -1
                s.heel = s.fore = s.heel_raw = s.fore_raw = False
                s.heel_since = s.fore_since = -1.0
        elif phase == Phase.LOADING and h and f:
            ev |= Event.FF
            phase = Phase.FLAT
        elif phase == Phase.FLAT and f and not h:
            ev |= Event.HO
            phase = Phase.PUSH
    s.phase_f = phase
    return ev


@njit(inline="always")
def _other_bears(D, s, other, t):  # type: ignore[no-untyped-def]
    """Whether the unassisted foot bears the body: its insole's four readings' sum above
    the calibration floor and ``other_bears`` of the largest sum it has read. Walking
    has no flight: while the other foot is off the ground (or barely on it), the device's
    foot bears the body, and a lift its own sensors read is load between them. True
    when its insole is not fitted, not reading (NaN), or silent -- unloaded for
    ``fsr_silent_strides`` strides since it last bore (or since the detector started),
    which no swing lasts: a cable off; the foot's own sensors decide then, as without
    it (until it is silent, a dead insole holds the foot's stance: its first toe off is
    missed)."""
    s.other_share = 0.0
    if D.other_foot == 0.0:
        return True
    total = other[0] + other[1] + other[2] + other[3]
    if not math.isfinite(total):
        return True
    s.other_max = max(s.other_max, total)
    s.other_share = total / max(s.other_max, D.floor)
    if total >= max(D.floor, D.other_bears * s.other_max):
        s.other_t = t
        return True
    return t - s.other_t > D.fsr_silent_strides * _stride(D, s)


@njit(cache=True)
def detect(d, st, counts, gyro, acc, t, other):  # type: ignore[no-untyped-def]
    """One reading of the four FSRs (ADC counts: heel, met1, met5, hallux; NaN: none), the
    foot's gyroscope (its sagittal rate, rad/s; NaN: none) and accelerometer (x, y
    specific force in the foot frame, m/s^2; NaN: none) at time t, and the unassisted
    foot's insole's four (``other``; read when :data:`SETTINGS` says it is fitted).
    ``d``: :data:`SETTINGS`, ``st``: :data:`STATE` (updated). Returns the events (bits of
    :class:`Event`) of this tick."""
    D = d[0]
    s = st[0]
    bears = _other_bears(D, s, other, t)
    # the sources' health: a reading missing (NaN), at its range (saturated) or unchanged
    # for frozen_time (a sensor's noise always moves it) is not used
    gyro_ok = math.isfinite(gyro) and abs(gyro) < D.gyro_range
    if gyro != s.gyro_last:  # a new reading: the turn's rate of change (rad/s^2) since
        # the last one, smoothed over slope_time (a board sending slower than the
        # controller's rate repeats its readings)
        if gyro_ok and math.isfinite(s.gyro_last) and t > s.gyro_same:
            dt = t - s.gyro_same
            s.slope += dt / (D.slope_time + dt) * ((gyro - s.gyro_last) / dt - s.slope)
            s.angle += 0.5 * (gyro + s.gyro_last) * dt
        else:
            s.slope = 0.0
        s.gyro_same = t
        s.gyro_last = gyro
    gyro_ok = gyro_ok and t - s.gyro_same < D.frozen_time
    fsr_ok = True
    loaded = False
    same = True
    for i in range(4):
        fsr_ok = fsr_ok and math.isfinite(counts[i])
        loaded = loaded or counts[i] > D.floor
        same = same and counts[i] == s.fsr_last[i]
        s.fsr_last[i] = counts[i]
    if not same:
        s.fsr_same = t
    # frozen loaded: a board holding its last reading (its noise would move it)
    fsr_ok = fsr_ok and not (loaded and t - s.fsr_same >= D.frozen_time)
    acc_dev = 0.0  # the accelerometer's |specific force| less g (0: none reading)
    jump = 0.0  # its reading's departure from its mean over impact_time (m/s^2)
    # the accelerometer reads: finite and not frozen (at its range it reads an impact)
    acc_ok = math.isfinite(acc[0]) and math.isfinite(acc[1])
    if acc[0] != s.acc_last[0] or acc[1] != s.acc_last[1]:
        s.acc_same = t
        s.acc_last[0], s.acc_last[1] = acc[0], acc[1]
    acc_ok = acc_ok and t - s.acc_same < D.frozen_time
    if acc_ok:
        saturated = abs(acc[0]) >= D.accel_range or abs(acc[1]) >= D.accel_range
        acc_dev = D.accel_range if saturated else \
            math.sqrt(acc[0] * acc[0] + acc[1] * acc[1]) - 9.80665
        dt = t - s.acc_t
        if dt > D.impact_time * 10.0:  # the first reading, or after a gap: the mean anew
            s.acc_mean[0], s.acc_mean[1] = acc[0], acc[1]
        jump = math.inf if saturated else \
            math.hypot(acc[0] - s.acc_mean[0], acc[1] - s.acc_mean[1])
        a = dt / (D.impact_time + dt)
        s.acc_mean[0] += a * (acc[0] - s.acc_mean[0])
        s.acc_mean[1] += a * (acc[1] - s.acc_mean[1])
        s.acc_t = t
    # the foot striking the ground: an impact -- a jump beyond impact and impact_ratio
    # times the largest since the foot swung forward -- once its forward swing has eased
    strike = acc_ok and gyro_ok and jump > max(D.impact, D.impact_ratio * s.swing_jump) \
        and gyro < D.impact_swing * s.peak_now
    if s.phase_i == Phase.SWING and s.swung and acc_ok:
        # the jumps of the last impact_time to 2 impact_time are not yet the swing's:
        # they may be the strike's rise
        if t - s.jump_t >= D.impact_time:
            s.swing_jump = max(s.swing_jump, s.jumps[1])
            s.jumps[1], s.jumps[0], s.jump_t = s.jumps[0], 0.0, t
        s.jumps[0] = max(s.jumps[0], min(jump, D.accel_range))  # a saturation: the range
    ev_f = _fsr_path(D, s, counts, gyro, gyro_ok, strike, t, bears) if fsr_ok else 0
    ev_i = 0
    if gyro_ok:
        ev_i = _imu_path(D, s, gyro, acc_dev, strike, acc_ok, t, bears)
    # silent: the FSRs have read nothing loaded for fsr_silent_strides strides the IMU
    # has walked (their cable off, the board reading zeros)
    if fsr_ok and gyro_ok and s.t_ic_i > s.t_loaded:
        T = _stride(D, s)
        if s.t_ic_i > s.t_loaded + 0.5 * T:
            fsr_ok = t - s.t_loaded < D.fsr_silent_strides * T
    s.bearing = False
    was, imu_was = s.phase, s.source == Source.IMU
    if fsr_ok:
        ev = ev_f
        s.phase = s.phase_f
        s.source = Source.FSR_IMU if gyro_ok else Source.FSR
        s.bearing = s.phase >= Phase.LOADING and not s.unloaded
    elif gyro_ok:
        ev = ev_i
        s.phase = s.phase_i
        s.source = Source.IMU
        # the weight off the foot (the controller's swing from here) as the push-off's
        # toe-down turn passes unload_turn of the last push-off's fastest
        s.bearing = s.phase >= Phase.LOADING and not (
            s.phase == Phase.PUSH and s.push_last < 0.0 and gyro < D.unload_turn * s.push_last)
    else:
        ev = 0
        s.phase = Phase.UNKNOWN
        s.source = Source.NONE
    imu_now = s.source == Source.IMU
    if was != Phase.UNKNOWN and s.phase != Phase.UNKNOWN and imu_was != imu_now:
        if imu_now:
            # the IMU takes over (the FSRs frozen, silent or missing): an event its path
            # passed that the FSRs' had not said is said now, so every stance ends in a
            # toe off and every swing in an initial contact
            if was >= Phase.LOADING and s.phase == Phase.SWING:
                ev |= Event.TO
            elif was == Phase.SWING and s.phase >= Phase.LOADING:
                ev |= Event.IC
        else:
            # the FSRs back: their path takes up the IMU's phase (its own is from before
            # they were lost), this tick still the IMU's
            s.phase_f, s.t_ic_f, s.t_to_f = s.phase_i, s.t_ic_i, s.t_to_i
            s.phase, ev = s.phase_i, ev_i
            s.bearing = s.phase >= Phase.LOADING
    if ev & Event.IC:
        dt = t - s.t_ic
        expected = _stride(D, s)
        if D.accept_lo * expected <= dt <= D.accept_hi * expected:
            for i in range(HISTORY - 1, 0, -1):
                s.history[i] = s.history[i - 1]
            s.history[0] = dt
            s.n_stride += 1
        s.t_ic = t
    return ev


@njit(cache=True)
def gait_fraction(d, st, t):  # type: ignore[no-untyped-def]
    """Fraction of the gait cycle since the last initial contact, in [0, 1)."""
    if st[0].t_ic < -1e8:
        return 0.0
    x = (t - st[0].t_ic) / _stride(d[0], st[0])
    return min(x, 0.999999)
