"""The gait-phase detector's state and what it says (:mod:`exoleg.control.gait_phase`):
its phases, events and sources, and the state record the compiled detector updates
(:data:`STATE`) -- data, the detector's algorithm apart."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from exoleg.layout import F8, I8, new
from exoleg.tick import (  # noqa: F401  (the detector's vocabulary, declared with the contract)
    EVENT_NAMES,
    PHASE_NAMES,
    SOURCE_NAMES,
    Event,
    Phase,
    Source,
)

#: Strides remembered (the most :attr:`DetectorSettings.strides_averaged` allows).
HISTORY = 10
#: The detector's state. What it says: the phase (:class:`Phase`); whether the foot bears
#: weight (a stance phase, and the FSRs not reading it lifted and turning: from then its
#: toes' tips alone bear until the toe off -- the controller's stance model follows
#: this); the time of the last initial contact (s); the strides accepted and
#: their times (newest first, s); the source it rests on (:class:`Source`). The FSRs'
#: path: its phase and times; per region (heel, forefoot) the raw and the debounced
#: loaded flags and since when the raw one differs (s, -1: it does not); the running
#: maxima per sensor and of their sum (counts); each sensor's baseline (its offset,
#: counts); since when the gyroscope has read a swing (s, -1: it does not); whether the
#: FSRs read the foot lifted, whether it is unloaded (lifted and turning), the fastest
#: toe-down turn since the lift and in this stance (rad/s), the turn's rate of change and
#: its steepest since the lift (rad/s^2), the foot's angle turned (rad; the gyroscope
#: integrated) now and at the lift, whether the hallux's sensor read a load this stance
#: and the last, and the heel's; when any region last read loaded (s). The IMU's
#: path: its phase and times, whether it has seen the swing since its toe off, the
#: fastest forward swing of this and of the last stride, the fastest toe-down turn and
#: its steepest rate since heel off and the last push-off's fastest (rad/s), since when
#: the foot is still (s, -1: it is not), the
#: accelerometer's mean over the impact time (m/s^2), when it was last updated (s), its
#: reading's largest jump from it in this swing (m/s^2), and the largest in the last two
#: impact times (the newest first) and when the newer began (s). The
#: sources' health: the last readings (FSRs, gyroscope, accelerometer) and since when they
#: have not changed (s). A held sensor (the FSRs' path): the sensors loaded this stance
#: (bits), the one alone loaded (-1: none), since when (s), its reading's mean and lowest
#: (counts), the mean's last update (s), since when a landing reads (s, -1: none), and
#: since when another sensor reads loaded beside it (s, -1: none).
#: The unassisted foot's insole: the largest sum of its four readings (counts), when it
#: last bore the body (s; 0 before it has: the detector's start).
STATE = np.dtype([("phase", I8), ("bearing", np.bool_), ("t_ic", F8),
                  ("n_stride", I8), ("history", F8, HISTORY), ("source", I8),
                  ("phase_f", I8), ("t_ic_f", F8), ("t_to_f", F8),
                  ("heel_raw", np.bool_), ("fore_raw", np.bool_),
                  ("heel", np.bool_), ("fore", np.bool_), ("heel_since", F8),
                  ("fore_since", F8), ("max", F8, 4), ("total_max", F8), ("base", F8, 4),
                  ("swing_since", F8), ("lift", np.bool_), ("unloaded", np.bool_),
                  ("lift_min", F8), ("stance_min", F8),
                  ("angle", F8), ("lift_angle", F8), ("hallux_now", np.bool_),
                  ("hallux_last", np.bool_), ("heel_now", np.bool_), ("heel_last", np.bool_),
                  ("slope", F8),
                  ("steepest", F8),
                  ("t_loaded", F8),
                  ("phase_i", I8), ("t_ic_i", F8), ("t_ho_i", F8), ("t_to_i", F8),
                  ("swung", np.bool_),
                  ("peak_now", F8), ("peak", F8), ("turn_min", F8), ("steep_i", F8),
                  ("still_since", F8), ("acc_mean", F8, 2), ("acc_t", F8),
                  ("acc_last", F8, 2), ("acc_same", F8), ("swing_jump", F8), ("push_last", F8),
                  ("jumps", F8, 2), ("jump_t", F8),
                  ("gyro_last", F8), ("gyro_same", F8), ("fsr_last", F8, 4),
                  ("fsr_same", F8), ("stance_mask", I8), ("held", I8), ("held_since", F8),
                  ("held_mean", F8), ("held_min", F8), ("held_t", F8), ("held_hit", F8),
                  ("held_ref", F8), ("held_low", F8), ("held_extra", F8),
                  ("other_max", F8), ("other_t", F8), ("other_share", F8)])


def new_state(settings: NDArray[np.void]) -> NDArray[np.void]:
    """A detector's state before its first reading: phase unknown, running maxima at the
    floor, no strides."""
    s = new(STATE)
    s["phase"] = s["phase_f"] = s["phase_i"] = Phase.UNKNOWN
    s["heel_since"] = s["fore_since"] = s["swing_since"] = s["still_since"] = -1.0
    s["held"], s["held_hit"], s["held_extra"] = -1, -1.0, -1.0
    for name in ("t_ic", "t_ic_f", "t_to_f", "t_ic_i", "t_ho_i", "t_to_i", "t_loaded",
                 "acc_t"):
        s[name] = -1e9
    s["max"] = settings[0]["floor"]
    s["total_max"] = settings[0]["floor"]
    s["peak"] = 2.0 * settings[0]["gyro_swing"]  # the first swing's level: gyro_swing
    s["gyro_last"] = s["fsr_last"] = s["acc_last"] = np.nan
    s["source"] = Source.NONE
    s["heel_last"] = True  # until a stance says otherwise
    s["other_max"] = 0.0  # the other foot's: none read yet
    return s
