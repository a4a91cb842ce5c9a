"""The tick contract: what a device's sensors give a controller each tick and what a
controller gives back, each declared once as a record (:mod:`exoleg.layout`), with every
enumeration the records hold.

A leaf of the house (it imports only the ground and data floors): the parts (the
simulated and real devices), the controllers, the runs, the runtime, the session log's
readers and the pages all take their fields and names from here, and nothing here
depends on how a controller or a device works. The compiled walking loop fills one
:data:`SENSORS` and one :data:`OUTPUT` record per tick, the Python controllers take a
:data:`SENSORS` mapping and return the :data:`OUTPUT` fields, and the session log, the
result series and the operator page take their columns and names from here.

Joint vectors are (hip, knee, ankle); the FSRs (heel, met1, met5, hallux).
"""

from __future__ import annotations

from collections.abc import Mapping
from enum import IntEnum
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from exoleg import checks as _check
from exoleg.errors import ParameterError
from exoleg.layout import F8, I8, column_names
from exoleg.params.records import JOINTS

#: The four FlexiForce A201 points under the footplate (see :mod:`exoleg.world.plant`).
SENSOR_POINTS = ("heel", "met1", "met5", "hallux")


class Mode(IntEnum):
    """The supervisor's mode. STOPPING: a stand asked while walking, the walk going on to
    the controller's stopping point (the walking hierarchy: the next mid-stance)."""

    DISARMED = 0
    STANDING = 1
    WALKING = 2
    FAULT = 3
    STOPPING = 4


class Command(IntEnum):
    """An operator's command for a tick. IMPEDANCE, TRANSPARENT and AAN choose the walking
    controller's support mode (:class:`SupportMode`),
    blended over a ramp."""

    NONE = 0
    ARM = 1
    STAND = 2
    WALK = 3
    DISARM = 4
    ESTOP = 5
    RESET = 6
    IMPEDANCE = 7
    TRANSPARENT = 8
    AAN = 9


# -- the gait-phase detector's phases, events and sources (:mod:`exoleg.control.gait_phase`)

class Phase(IntEnum):
    UNKNOWN = -1
    SWING = 0
    LOADING = 1   # initial contact to foot flat
    FLAT = 2      # foot flat to heel off
    PUSH = 3      # heel off to toe off


class Event(IntEnum):
    """Bits of a tick's events."""

    IC = 1
    FF = 2
    HO = 4
    TO = 8


class Source(IntEnum):
    """What the detector rests on."""

    FSR = 0          # the FSRs alone (no gyroscope reading)
    FSR_IMU = 1      # the FSRs, their toe off timed and confirmed by the foot's turn
    IMU = 2          # the foot's IMU alone (the FSRs missing, frozen or silent)
    NONE = 3         # neither reads


EVENT_NAMES = {Event.IC: "initial contact", Event.FF: "foot flat", Event.HO: "heel off",
               Event.TO: "toe off"}
SOURCE_NAMES = {Source.FSR: "the FSRs alone", Source.FSR_IMU: "the FSRs and the foot's IMU",
                Source.IMU: "the foot's IMU alone", Source.NONE: "no sensor reading"}
PHASE_NAMES = {Phase.UNKNOWN: "unknown", Phase.SWING: "swing", Phase.LOADING: "loading",
               Phase.FLAT: "foot flat", Phase.PUSH: "push-off"}


# -- the safety layer's faults and status bits (:mod:`exoleg.control.safety`)

class Fault(IntEnum):
    """Why the torque is off (latched until :meth:`SafetyLayer.reset`)."""

    NONE = 0
    ESTOP = 1
    NONFINITE = 2
    OVERSPEED = 3
    HARD_LIMIT = 4
    OVERTEMPERATURE = 5     # a motor's estimated winding temperature beyond its limit
    GEAR_OVERLOAD = 6       # a gear's estimated torque beyond its momentary peak ("fault")
    CUFF_TORQUE = 7         # the cuffs' torque beyond its torque-off level


class Limited(IntEnum):
    """Bits of a tick's status: what the layer changed in the command this tick."""

    DISARMED = 1        # torque zero: not armed
    FAULT = 2           # torque zero: a latched fault (see Fault)
    SOFT_LIMIT = 4      # a joint beyond its range of motion had its outward torque removed
    TORQUE = 8          # clipped to the maximum torque
    RATE = 16           # the torque the gear carries limited by the torque rate
    DERATED = 32        # a motor's winding is hot: its torque limit derated
    GEAR_PEAK = 64      # a gear's estimated torque beyond its momentary peak
    GEAR = 128          # the torque the gear carries held at its repeated peak
    CUFF = 256          # the cuffs' torque beyond its limit: the support falls
    CUFF_STOP = 512     # the cuffs' torque beyond its stop level: a controlled stop


#: What each status bit means, as the operator reads it.
LIMITED_TEXT = {Limited.DISARMED: "disarmed: torque zero",
                Limited.FAULT: "FAULT: torque off (latched)",
                Limited.SOFT_LIMIT: "beyond the soft range-of-motion limit",
                Limited.TORQUE: "torque clipped", Limited.RATE: "torque rate limited",
                Limited.DERATED: "motor hot: torque derated",
                Limited.GEAR_PEAK: "gear beyond its momentary peak torque",
                Limited.GEAR: "gear's torque held at its repeated peak",
                Limited.CUFF: "cuffs' torque beyond its limit: support reduced",
                Limited.CUFF_STOP: "cuffs' torque beyond its stop level: controlled stop"}


# -- the walking controller's support modes (:mod:`exoleg.control.transparency`)

class SupportMode(IntEnum):
    """How the walking controller supports the child (``exoleg simulate --walk
    --controller``, ``exoleg run --controller``)."""

    IMPEDANCE = 0
    TRANSPARENT = 1
    AAN = 2


#: What the device reads each tick: joint angles (rad) and rates (rad/s) as measured
#: (encoders and their filter), the four FSRs (ADC counts), the foot IMU's gyro (rad/s)
#: and accelerations (m/s^2, foot frame), the operator's command (:class:`Command`),
#: and the torque the cuffs transmit to the child per joint (N m,
#: :mod:`exoleg.child.interaction`: the simulated device's own; NaN where a device has
#: no cuff or joint-torque sensor, as the drives on the buses have not), and the
#: unassisted foot's insole, four FSRs in :data:`SENSOR_POINTS`' order (ADC counts; NaN
#: where none is fitted).
SENSORS = np.dtype([("q", F8, 3), ("dq", F8, 3), ("fsr", F8, 4), ("gyro", F8),
                    ("accel", F8, 2), ("command", I8), ("interaction", F8, 3),
                    ("fsr_other", F8, 4)])

#: What a controller gives each tick: the torque to the drives (N m), the supervisor's
#: mode (:class:`Mode`), the gait phase (:class:`Phase`), the
#: what the detector rests on (:class:`Source`), the
#: gait fraction, the tick's events (bits of :class:`Event`),
#: the safety layer's status bits (:class:`Limited`), the
#: reference (rad), the fault latched (:class:`Fault`), its
#: joint (-1: none), the value that latched it and the limit it crossed (rad, rad/s: the
#: safety layer's STATE), and the command refused this tick (:class:`Command`; NONE if
#: none was, e.g. a reset while a fault still holds), per joint the safety layer's
#: estimates: the motor's winding temperature (degC) and the gear's transmitted torque
#: (N m), the support mode in force (:class:`SupportMode`;
#: a law that is not the walking controller's: IMPEDANCE) and the support level per joint
#: (0: transparent, 1: the impedance's full support; between while a change blends), and
#: the cuffs' torque as the safety layer checks it (N m: the interaction reading through
#: the cuffs' low-pass; NaN where not measured).
OUTPUT = np.dtype([("tau", F8, 3), ("mode", I8), ("phase", I8), ("gait_source", I8),
                   ("gait_fraction", F8),
                   ("events", I8), ("safety_status", I8), ("q_ref", F8, 3), ("fault", I8),
                   ("fault_joint", I8), ("fault_value", F8), ("fault_limit", F8),
                   ("refused", I8), ("winding_temp", F8, 3), ("gear_torque", F8, 3),
                   ("support_mode", I8), ("support_level", F8, 3), ("cuff", F8, 3)])

LABELS = {3: JOINTS, 4: SENSOR_POINTS}
#: The modes in which the drives are enabled (torque may flow), and those in which the
#: child walks (the treadmill runs).
ARMED_MODES = frozenset((Mode.STANDING, Mode.WALKING, Mode.STOPPING))
WALKING_MODES = frozenset((Mode.WALKING, Mode.STOPPING))
_COMMANDS = frozenset(int(m) for m in Command)


class Controller(Protocol):
    """What every controller offers the loop, in simulation and on every device."""

    def update(self, sensors: Mapping[str, Any], command: int, t: float) -> dict[str, Any]:
        """One tick: the :data:`SENSORS` fields read this tick, the operator's command
        (:class:`Command`) and the time (s) -> the :data:`OUTPUT` fields."""
        ...

    def warm_up(self) -> None:
        """Compile (or load from the cache) before the clock starts."""
        ...

    def gains_now(self) -> dict[str, list[float]]:
        """The gains an operator may change, in force now."""
        ...

    def set_gains(self, change: dict[str, list[float]]) -> None:
        """Change gains between ticks, all or none."""
        ...


class TickRecords:
    """One tick's :data:`SENSORS` and :data:`OUTPUT` records (one-element arrays, what the
    compiled ticks take) with views of their fields, so that a controller fills the one
    and reads the other from Python in a few microseconds."""

    def __init__(self, where: str) -> None:
        self.where = where
        self.sens = np.zeros(1, SENSORS)
        self.out = np.zeros(1, OUTPUT)
        self._in = {n: self.sens[n][0] if SENSORS[n].shape else self.sens[n]
                    for n in SENSORS.names or ()}
        self._out = {n: self.out[n][0] if OUTPUT[n].shape else self.out[n]
                     for n in OUTPUT.names or ()}
        kinds = output_kinds()
        self._conv: list[tuple[str, NDArray[Any], Any]] = []
        for n, v in self._out.items():
            conv = (None if OUTPUT[n].shape else kinds[n].__getitem__ if n in kinds
                    else int if OUTPUT[n].kind == "i" else float)
            self._conv.append((n, v, conv))

    def read(self, sensors: Mapping[str, Any], command: Any) -> None:
        """Check one tick's readings and command and put them into :attr:`sens`: ``q``,
        ``dq`` (3) and ``fsr`` (4) required, ``gyro`` and ``accel`` optional (0),
        ``interaction`` (3) and ``fsr_other`` (4) optional (NaN: not measured); a wrong
        shape or kind, or an unknown command, is a ParameterError naming the field."""
        w, v = self.where, self._in
        if not isinstance(sensors, Mapping):
            raise ParameterError(w, "sensors", f"expected a mapping of readings, got "
                                 f"{type(sensors).__name__}")
        v["q"][:] = _check.reading(w, "q", sensors.get("q"), 3)
        v["dq"][:] = _check.reading(w, "dq", sensors.get("dq"), 3)
        v["fsr"][:] = _check.reading(w, "fsr", sensors.get("fsr"), 4)
        if "accel" in sensors:
            v["accel"][:] = _check.reading(w, "accel", sensors["accel"], 2)
        for name, n in (("interaction", 3), ("fsr_other", 4)):  # NaN: not measured
            x = sensors.get(name)
            v[name][:] = np.nan if x is None else _check.reading(w, name, x, n)
        g = sensors.get("gyro", 0.0)
        v["gyro"][0] = g if type(g) is float else _check.reading(w, "gyro", [g], 1)[0]
        if isinstance(command, bool) or not isinstance(command, (int, np.integer)) \
                or int(command) not in _COMMANDS:
            raise ParameterError(w, "command", f"{command!r} is not a command (allowed: "
                                 + ", ".join(f"{m.value} {m.name}" for m in Command) + ")")
        v["command"][:] = command

    def result(self) -> dict[str, Any]:
        """:attr:`out` as a mapping: vectors as arrays (copies), modes, phases, faults and
        commands as their enumerations (:func:`output_kinds`), the rest as numbers."""
        return {n: (v.copy() if conv is None else conv(v[0])) for n, v, conv in self._conv}


def output_kinds() -> dict[str, dict[int, IntEnum]]:
    """The output fields that hold an enumeration, each as value -> member."""
    return {name: {int(m): m for m in kind} for name, kind in
            (("mode", Mode), ("phase", Phase), ("gait_source", Source), ("fault", Fault),
             ("refused", Command), ("support_mode", SupportMode))}


def output_columns() -> list[str]:
    """The flat names of :data:`OUTPUT` (``tau_hip`` ... ``refused``)."""
    return column_names(OUTPUT, LABELS)


def name_of(kind: type[IntEnum], value: int) -> str:
    """A logged value of an enumeration as people read it (``walking``), or the number
    itself when it names no member."""
    try:
        return kind(int(value)).name.lower()
    except ValueError:
        return str(value)
