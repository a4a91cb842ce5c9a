"""The gait-phase detector's path on the foot's IMU alone (:func:`_imu_path`: its own
phases from the gyroscope and the accelerometer, run beside the FSRs' in
:func:`exoleg.control.gait_phase.detect`, which decides when the FSRs cannot), and the
toe-down turn's rule both paths time their toe off by (:func:`_eased`)."""

from __future__ import annotations

from numba import njit

from exoleg.control.gait_state import Event, Phase


@njit(inline="always")
def _lasting(cond, since, t, need):  # type: ignore[no-untyped-def]
    """A condition that must hold ``need`` s: (held that long, its start: -1 when it does
    not hold)."""
    if not cond:
        return False, -1.0
    if since < 0.0:
        since = t
    return t - since >= need - 1e-12, since


@njit(inline="always")
def _eased(D, slope, steepest):  # type: ignore[no-untyped-def]
    """A toe-down turn past its steepest: its rate of change (``slope``, rad/s^2) eased to
    ``slope_eased`` of the ``steepest`` since, which was beyond ``slope_floor``."""
    return steepest < -D.slope_floor and slope > D.slope_eased * steepest


@njit(inline="always")
def _imu_path(D, s, gyro, acc_dev, strike, acc_ok, t, bears):  # type: ignore[no-untyped-def]
    """The foot IMU's path (a reading gyroscope; ``acc_dev``: the accelerometer's
    |specific force| less g, m/s^2, 0 without one; ``strike``: the foot striking the
    ground, :func:`detect`; ``acc_ok``: whether the accelerometer reads; ``bears``:
    whether the other foot bears the body, :func:`_other_bears` -- no toe off while it
    does not): this tick's events.

    A foot still (turning slower than ``gyro_still``, its specific force within
    ``accel_still`` of g) for ``still_time`` is flat on the ground; after a swing (the foot
    turning forward faster than ``gyro_swing_floor``), the strike is an initial contact
    (without the accelerometer: turning toe-down faster than ``gyro_contact`` and
    ``contact_fraction`` of the last swing's fastest turn -- which a foot turned toe-down
    in the air, a controller ahead of the foot, also does); from flat, turning toe-down
    faster than ``gyro_heel_off`` is heel off; from heel off, the toe-down turn past its
    steepest (as the fused toe off, :func:`detect`) and still faster than
    ``gyro_turning`` is toe off, no sooner than ``push_ms`` after heel off -- and, when
    the walk's planned stride (``expected_stride``) is ``imu_slow_stride`` or longer,
    once the turn has also eased to ``imu_toe_eased`` of its deepest: slow walking turns
    toe-down twice, the heel's rise and then the toes' roll-off, and the toes leave at
    the second (the steepest rule alone said toe off at the first, 170-330 ms early at
    4 s strides); a foot still again since heel off is flat (a jolt as walking starts is
    not a push-off)."""
    still, s.still_since = _lasting(abs(gyro) < D.gyro_still and abs(acc_dev) < D.accel_still,
                                    s.still_since, t, D.still_time)
    phase = s.phase_i
    ev = 0
    if phase <= Phase.SWING:
        if gyro > s.peak_now:
            s.peak_now = gyro
        if gyro > D.gyro_swing_floor:
            s.swung = True
        contact = False
        if phase == Phase.UNKNOWN:
            contact = still
        elif s.swung and t - s.t_to_i >= D.min_swing:
            if acc_ok:
                contact = strike
            else:
                contact = gyro < -max(D.gyro_contact, D.contact_fraction * s.peak)
        if contact:
            ev |= Event.IC
            if phase == Phase.SWING:
                s.peak = s.peak_now
            s.t_ic_i = t
            phase = Phase.LOADING
            if still:
                ev |= Event.FF
                phase = Phase.FLAT
    else:
        if phase == Phase.LOADING and still:
            ev |= Event.FF
            phase = Phase.FLAT
        elif phase == Phase.FLAT and gyro < -D.gyro_heel_off:
            ev |= Event.HO
            phase = Phase.PUSH
            s.turn_min = gyro
            s.steep_i = 0.0
            s.t_ho_i = t
        elif phase == Phase.PUSH and still and s.still_since > s.t_ho_i:
            # still again since heel off, the heel down again: no push-off (a jolt)
            phase = Phase.FLAT
        elif phase == Phase.LOADING and t - s.t_ic_i < D.min_stance:
            s.turn_min = 0.0  # the turn as the foot lands is not the push-off's
            s.steep_i = 0.0
        elif phase != Phase.FLAT:
            s.turn_min = min(s.turn_min, gyro)
            s.steep_i = min(s.steep_i, s.slope)
            if s.turn_min < -D.gyro_turning and _eased(D, s.slope, s.steep_i) and \
                    gyro < -D.gyro_turning and bears and (phase == Phase.LOADING
                                                          or t - s.t_ho_i >= D.push_time) \
                    and (D.expected_stride < D.imu_slow_stride
                         or gyro > D.imu_toe_eased * s.turn_min):
                ev |= Event.TO
                s.t_to_i = t
                s.push_last = s.turn_min
                s.swung = False
                s.swing_jump = s.jumps[0] = s.jumps[1] = 0.0
                s.peak_now = gyro
                phase = Phase.SWING
    s.phase_i = phase
    return ev
