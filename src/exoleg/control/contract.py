"""The tick contract: what a device's sensors give a controller each tick and what a
controller gives back, each declared once as a record (:mod:`exoleg.layout`).

Every layer reads these declarations instead of keeping its own list: the compiled
walking loop fills one :data:`SENSORS` and one :data:`OUTPUT` record per tick, the
Python controllers take a :data:`SENSORS` mapping and return the :data:`OUTPUT` fields,
and the session log, the result series and the operator page take their columns and
names from here and from the enumerations below.

Joint vectors are (hip, knee, ankle); the FSRs (heel, met1, met5, hallux).
"""

from __future__ import annotations

from enum import IntEnum
from typing import Any

import numpy as np
from numpy.typing import NDArray

from exoleg.layout import F8, I8, column_names, enum_table
from exoleg.params.records import JOINTS

#: The four FlexiForce A201 points under the footplate (see :mod:`exoleg.device.walking`).
SENSOR_POINTS = ("heel", "met1", "met5", "hallux")


class Mode(IntEnum):
    """The supervisor's mode."""

    DISARMED = 0
    STANDING = 1
    WALKING = 2
    FAULT = 3


class Command(IntEnum):
    """An operator's command for a tick."""

    NONE = 0
    ARM = 1
    STAND = 2
    WALK = 3
    DISARM = 4
    ESTOP = 5
    RESET = 6


#: What the device reads each tick: joint angles (rad) and rates (rad/s) as measured
#: (encoders and their filter), the four FSRs (ADC counts), the foot IMU's gyro (rad/s)
#: and accelerations (m/s^2, foot frame), and the operator's command (:class:`Command`).
SENSORS = np.dtype([("q", F8, 3), ("dq", F8, 3), ("fsr", F8, 4), ("gyro", F8),
                    ("accel", F8, 2), ("command", I8)])

#: What a controller gives each tick: the torque to the drives (N m), the supervisor's
#: mode (:class:`Mode`), the gait phase (:class:`~exoleg.control.gait_phase.Phase`), the
#: gait fraction, the tick's events (bits of :class:`~exoleg.control.gait_phase.Event`),
#: the safety layer's status bits (:class:`~exoleg.control.safety.Limited`), the
#: reference (rad), the fault latched (:class:`~exoleg.control.safety.Fault`) and its
#: joint (-1: none), and the command refused this tick (:class:`Command`; NONE if none
#: was, e.g. a reset while a fault still holds).
OUTPUT = np.dtype([("tau", F8, 3), ("mode", I8), ("phase", I8), ("gait_fraction", F8),
                   ("events", I8), ("safety_status", I8), ("q_ref", F8, 3), ("fault", I8),
                   ("fault_joint", I8), ("refused", I8)])

LABELS = {3: JOINTS, 4: SENSOR_POINTS}


def output_columns() -> list[str]:
    """The flat names of :data:`OUTPUT` (``tau_hip`` ... ``refused``)."""
    return column_names(OUTPUT, LABELS)


def output_dict(rec: NDArray[np.void]) -> dict[str, Any]:
    """One :data:`OUTPUT` record (a one-element array) as a mapping: vectors as arrays
    (copies), modes, phases, faults and commands as their enumerations."""
    from exoleg.control.gait_phase import Phase
    from exoleg.control.safety import Fault

    r = rec[0]
    kinds: dict[str, type[IntEnum]] = {"mode": Mode, "phase": Phase, "fault": Fault,
                                       "refused": Command}
    out: dict[str, Any] = {}
    for name in OUTPUT.names or ():
        v = r[name]
        if name in kinds:
            out[name] = kinds[name](int(v))
        elif OUTPUT.fields[name][0].shape:
            out[name] = np.array(v, dtype=float)
        elif OUTPUT.fields[name][0].kind == "i":
            out[name] = int(v)
        else:
            out[name] = float(v)
    return out


def enums() -> dict[str, dict[str, int]]:
    """Every enumeration a page or a log reader shows, by name (served to the page)."""
    from exoleg.control.gait_phase import Event, Phase
    from exoleg.control.safety import Fault, Limited

    return enum_table(Mode, Command, Phase, Event, Fault, Limited)
