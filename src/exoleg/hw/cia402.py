"""The CiA 402 drive state machine (IEC 61800-7-201 / CiA 402 part 2), written once for
every transport and for the simulated drives.

* :func:`decode` turns a statusword (object 0x6041) into a :class:`State`;
* :class:`Drive` is the drive's side: it takes controlwords (0x6040) and faults and
  moves through the states as the standard's transition table says, and gives the
  statusword back -- the simulated EPOS4 node's state machine;
* :func:`controlword_towards` is the master's side: the next controlword on the way
  from a state to Operation Enabled (arming) or to Switch On Disabled (disarming),
  one transition per call, as a drive must be walked through them.

Quick stop and fault reset follow the standard: the quick-stop bit is active low, a
fault reset acts on the rising edge of bit 7.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum
from typing import Any

# controlword bits (0x6040)
SWITCH_ON, ENABLE_VOLTAGE, QUICK_STOP, ENABLE_OPERATION, FAULT_RESET = 1, 2, 4, 8, 128
# the standard's device control commands
SHUTDOWN = ENABLE_VOLTAGE | QUICK_STOP                          # 0x0006
SWITCH_ON_CMD = SWITCH_ON | ENABLE_VOLTAGE | QUICK_STOP         # 0x0007
ENABLE_OPERATION_CMD = SWITCH_ON_CMD | ENABLE_OPERATION         # 0x000F
DISABLE_VOLTAGE = 0x0000
QUICK_STOP_CMD = ENABLE_VOLTAGE                                 # 0x0002
DISABLE_OPERATION = SWITCH_ON_CMD                               # 0x0007
FAULT_RESET_CMD = FAULT_RESET                                   # 0x0080


class State(Enum):
    """The states, with (mask, value) of their statusword bits 0-3, 5, 6."""

    NOT_READY_TO_SWITCH_ON = (0x4F, 0x00)
    SWITCH_ON_DISABLED = (0x4F, 0x40)
    READY_TO_SWITCH_ON = (0x6F, 0x21)
    SWITCHED_ON = (0x6F, 0x23)
    OPERATION_ENABLED = (0x6F, 0x27)
    QUICK_STOP_ACTIVE = (0x6F, 0x07)
    FAULT_REACTION_ACTIVE = (0x4F, 0x0F)
    FAULT = (0x4F, 0x08)


#: the statusword a drive reports in each state (voltage enabled bit 4 where it is)
STATUSWORD = {
    State.NOT_READY_TO_SWITCH_ON: 0x0000, State.SWITCH_ON_DISABLED: 0x0040,
    State.READY_TO_SWITCH_ON: 0x0031, State.SWITCHED_ON: 0x0033,
    State.OPERATION_ENABLED: 0x0037, State.QUICK_STOP_ACTIVE: 0x0017,
    State.FAULT_REACTION_ACTIVE: 0x001F, State.FAULT: 0x0018,
}


def decode(statusword: int) -> State:
    """The state a statusword reports. Raises ValueError for a word no state matches."""
    for s in State:
        mask, value = s.value
        if statusword & mask == value:
            return s
    raise ValueError(f"statusword 0x{statusword:04X} matches no CiA 402 state")


def _command(cw: int) -> str:
    """The device control command a controlword carries (bits 0-3, 7)."""
    if cw & FAULT_RESET:
        return "fault_reset"
    if not cw & ENABLE_VOLTAGE:
        return "disable_voltage"
    if not cw & QUICK_STOP:
        return "quick_stop"
    if not cw & SWITCH_ON:
        return "shutdown"
    if cw & ENABLE_OPERATION:
        return "enable_operation"
    return "switch_on"  # also "disable operation" from Operation Enabled


#: Digital inputs (0x60FD), bit 3: the interlock (CiA 402), wired to the monitoring
#: contact of the hardware E-stop chain -- the chain that opens the drives' STO inputs.
INTERLOCK = 1 << 3


class Drive:
    """A drive's CiA 402 state machine. Starts in Switch On Disabled (after its own
    Not Ready To Switch On self-test). ``torque_allowed`` only in Operation Enabled and
    with its STO input closed: ``sto`` True is the hardware E-stop pressed -- the power
    stage is off whatever the master commands (Safe Torque Off), and the digital inputs
    (:attr:`digital_inputs`, 0x60FD) show the :data:`INTERLOCK` bit."""

    def __init__(self) -> None:
        self.state = State.SWITCH_ON_DISABLED
        self._last_cw = 0
        self.sto = False

    @property
    def statusword(self) -> int:
        return STATUSWORD[self.state]

    @property
    def torque_allowed(self) -> bool:
        return self.state is State.OPERATION_ENABLED and not self.sto

    @property
    def digital_inputs(self) -> int:
        """The digital inputs object (0x60FD) as the drive reports it."""
        return INTERLOCK if self.sto else 0

    def fault(self) -> None:
        """A drive fault (overcurrent, a lost SYNC, ...): the torque goes off and the drive
        is in Fault (its fault reaction -- Fault Reaction Active -- completes within the
        tick here, as the torque is simply removed)."""
        self.state = State.FAULT

    def controlword(self, cw: int) -> State:
        """Apply a controlword; returns the new state (transitions of CiA 402 Fig. 4)."""
        cmd = _command(cw)
        rising_reset = bool(cw & FAULT_RESET) and not self._last_cw & FAULT_RESET
        self._last_cw = cw
        s = self.state
        if s is State.FAULT:
            if rising_reset:
                self.state = State.SWITCH_ON_DISABLED                  # 15
            return self.state
        if cmd == "fault_reset":
            return self.state
        if cmd == "disable_voltage":
            if s is not State.NOT_READY_TO_SWITCH_ON:
                self.state = State.SWITCH_ON_DISABLED                  # 7, 9, 10, 12
        elif cmd == "quick_stop":
            if s is State.OPERATION_ENABLED:
                self.state = State.QUICK_STOP_ACTIVE                   # 11
            elif s in (State.READY_TO_SWITCH_ON, State.SWITCHED_ON):
                self.state = State.SWITCH_ON_DISABLED                  # 7, 10
            elif s is State.QUICK_STOP_ACTIVE:
                pass
        elif cmd == "shutdown":
            if s in (State.SWITCH_ON_DISABLED, State.SWITCHED_ON, State.OPERATION_ENABLED):
                self.state = State.READY_TO_SWITCH_ON                  # 2, 6, 8
            elif s is State.QUICK_STOP_ACTIVE:
                self.state = State.SWITCH_ON_DISABLED                  # 12
        elif cmd == "switch_on":
            if s is State.READY_TO_SWITCH_ON:
                self.state = State.SWITCHED_ON                         # 3
            elif s is State.OPERATION_ENABLED:
                self.state = State.SWITCHED_ON                         # 5
            elif s is State.QUICK_STOP_ACTIVE:
                self.state = State.SWITCH_ON_DISABLED                  # 12
        elif cmd == "enable_operation":
            if s is State.SWITCHED_ON:
                self.state = State.OPERATION_ENABLED                   # 4
            elif s is State.READY_TO_SWITCH_ON:
                self.state = State.SWITCHED_ON                         # 3 (EPOS: 3 then 4)
            elif s is State.QUICK_STOP_ACTIVE:
                self.state = State.OPERATION_ENABLED                   # 16
        return self.state


def controlword_towards(state: State, enable: bool) -> int:
    """The master's next controlword from ``state`` towards Operation Enabled
    (``enable``) or Switch On Disabled (not): one transition per call."""
    if state is State.FAULT:
        return FAULT_RESET_CMD if enable else DISABLE_VOLTAGE
    if not enable:
        return QUICK_STOP_CMD if state is State.OPERATION_ENABLED else DISABLE_VOLTAGE
    return {State.SWITCH_ON_DISABLED: SHUTDOWN, State.READY_TO_SWITCH_ON: SWITCH_ON_CMD,
            State.SWITCHED_ON: ENABLE_OPERATION_CMD,
            State.OPERATION_ENABLED: ENABLE_OPERATION_CMD,
            State.QUICK_STOP_ACTIVE: DISABLE_VOLTAGE,
            State.FAULT_REACTION_ACTIVE: DISABLE_VOLTAGE,
            State.NOT_READY_TO_SWITCH_ON: DISABLE_VOLTAGE}[state]


#: CiA 402 device type of a servo drive (object 0x1000)
SERVO_DEVICE_TYPE = 0x00020192
#: modes of operation (0x6060): cyclic synchronous torque
CST = 10


def interlock_fault(where: str, inputs: int) -> str:
    """The fault a drive's digital inputs (0x60FD) report: the hardware E-stop pressed
    ('' when not)."""
    if not int(inputs) & INTERLOCK:
        return ""
    return (f"hardware E-stop: the E-stop chain is open (interlock input 0x60FD bit 3 of "
            f"the {where}); the drives' STO has taken the torque off")


#: the EPOS4 50/15's product code (0x1018 sub 2; device-datasheets.md, S3)
EPOS4_50_15 = 0x65520000


@dataclass(frozen=True)
class DriveObjects:
    """What the master reads of a drive at start-up, over any bus: device type
    (0x1000), product code (0x1018 sub 2), motor rated torque (0x6076, uN m), the motor
    data (0x3001 sub 1-5: nominal current and output current limit, mA; pole pairs; the
    winding's thermal time constant, 0.1 s; torque constant, uN m/A), the mode of
    operation after setting CST (0x6060), the position (0x6064, counts), the digital
    inputs (0x60FD), the statusword (0x6041), the interpolation period (0x60C2 sub 1
    value, sub 2 index: value x 10^index s) and the targets read back after the master
    set them (0x6071 target torque, per mille; 0x607A target position, counts)."""

    device_type: int
    product_code: int
    rated_unm: int
    nominal_ma: int
    limit_ma: int
    pole_pairs: int
    winding_ds: int
    kt_unm_a: int
    mode: int
    counts: int
    inputs: int = 0
    statusword: int = STATUSWORD[State.SWITCH_ON_DISABLED]
    interpolation: tuple[int, int] = (1, -3)
    target_torque: int = 0
    target_counts: int | None = None


#: The EPOS4's motor data (0x3001) sub-indices' types as struct formats: nominal current
#: and output current limit UNSIGNED32 (mA), pole pairs UNSIGNED8, the winding's thermal
#: time constant UNSIGNED16 (0.1 s), torque constant UNSIGNED32 (uN m/A) -- the shipped
#: EDS's (data/device/canopen)
MOTOR_DATA_TYPES = {1: "<I", 2: "<I", 3: "<B", 4: "<H", 5: "<I"}

#: the states a drive may be found in before the session (none acting on a target)
IDLE_STATES = (State.SWITCH_ON_DISABLED, State.READY_TO_SWITCH_ON, State.SWITCHED_ON)


def interpolation_period(value: int, index: int) -> float:
    """The interpolation period 0x60C2 holds (sub 1 ``value``, sub 2 ``index``), s."""
    return float(value) * 10.0 ** int(index)


def interpolation_of(period: float) -> tuple[int, int]:
    """0x60C2's (value, index) for ``period`` s: in ms (index -3) when whole, else in
    us (index -6)."""
    ms = period * 1e3
    return (int(round(ms)), -3) if abs(ms - round(ms)) < 1e-9 else \
        (int(round(period * 1e6)), -6)


def check_drive(where: str, read: DriveObjects, want: Any, q: float, lower: float,
                upper: float, margin: float, period: float = 1e-3) -> str:
    """The start-up check of one drive, the same over every transport: a CiA 402 servo
    drive (0x1000) of the product the device file names (0x1018 sub 2), configured for
    the device file's motor as maxon configures it (``want``: the file's
    :class:`~exoleg.hw.units.MotorData` and rated torque -- 0x6076 in uN m = I_N x k_t,
    0x3001's nominal current and current limit in mA, the pole pairs it commutates
    with, the winding's time constant its I2t protection heats by and the torque
    constant it turns a torque into current by), in cyclic synchronous torque
    (0x6060), its hardware E-stop released (0x60FD), and the joint -- read from its
    absolute encoder, the homing -- within its range of motion (``lower``/``upper`` rad,
    plus ``margin``). Then what makes it safe to enable (the lessons of
    ethercat_driver_ros2 and ros2_canopen, realtime.md): its interpolation period (0x60C2)
    is the loop's ``period`` s (a drive expecting its SYNC every 10 ms, as a published
    EPOS4 configuration has it, is refused); it is idle -- not in Operation Enabled, Quick
    Stop or Fault (0x6041): nothing acts on a target before the operator arms --; and the
    targets the master set hold: torque 0 (0x6071) and the position where the joint is
    (0x607A, for a drive that falls back to a position mode). Raises ParameterError
    naming the drive (``where``) and the object; returns what it checked."""
    from math import degrees

    from exoleg.errors import ParameterError

    if read.device_type != SERVO_DEVICE_TYPE:
        raise ParameterError(where, "0x1000", f"device type 0x{read.device_type:08X}, not a "
                             f"CiA 402 servo drive (0x{SERVO_DEVICE_TYPE:08X})")
    if read.product_code != want.product_code:
        raise ParameterError(where, "0x1018 sub 2", f"product code 0x{read.product_code:08X}"
                             f"; the device file names 0x{want.product_code:08X}")
    if read.rated_unm != want.rated_unm:
        old = " (mN m from the drive's current? EPOS4 holds uN m from the motor's nominal " \
              "current)" if read.rated_unm < want.rated_unm / 10 else ""
        raise ParameterError(where, "0x6076", f"motor rated torque {read.rated_unm} uN m; "
                             f"the device file's motor gives {want.rated_unm} uN m (I_N x "
                             f"k_t){old}: torques would be scaled wrongly")
    for name, got, expected, unit in (
            ("sub 1 (nominal current)", read.nominal_ma, want.nominal_current_ma, " mA"),
            ("sub 2 (output current limit)", read.limit_ma, want.current_limit_ma, " mA"),
            ("sub 3 (pole pairs)", read.pole_pairs, want.pole_pairs, ""),
            ("sub 4 (winding's thermal time constant)", read.winding_ds,
             want.winding_time_constant_ds, " x 0.1 s"),
            ("sub 5 (torque constant)", read.kt_unm_a, want.torque_constant_unm_a,
             " uN m/A")):
        if got != expected:
            raise ParameterError(where, f"0x3001 {name}", f"{got}{unit}; the device file "
                                 f"says {expected}{unit}")
    if read.mode != CST:
        raise ParameterError(where, "0x6060", f"mode {read.mode} after setting cyclic "
                             f"synchronous torque ({CST})")
    if interlock_fault(where, read.inputs):
        raise ParameterError(where, "0x60FD", "the hardware E-stop is pressed (interlock "
                             "input open): release it before the session")
    every = interpolation_period(*read.interpolation)
    if abs(every - period) > 1e-9 * period:
        value, index = interpolation_of(period)
        raise ParameterError(where, "0x60C2", f"interpolation period {every * 1e3:g} ms (sub 1 "
                             f"= {read.interpolation[0]}, sub 2 = {read.interpolation[1]}); "
                             f"the loop's period is {period * 1e3:g} ms: set sub 1 = {value}, "
                             f"sub 2 = {index}")
    try:
        state = decode(read.statusword)
    except ValueError as e:
        raise ParameterError(where, "0x6041", str(e)) from None
    if state not in IDLE_STATES:
        raise ParameterError(where, "0x6041", f"the drive is in {state.name} before the "
                             "session (" + ("clear its fault first" if state in (
                                 State.FAULT, State.FAULT_REACTION_ACTIVE) else
                                 "another master may be driving it: disable it first")
                             + "); the session starts from Switch On Disabled")
    if read.target_torque != 0:
        raise ParameterError(where, "0x6071", f"target torque {read.target_torque} per mille "
                             "after the master set 0: a stale target would act at enable")
    if read.target_counts is not None and read.target_counts != read.counts:
        raise ParameterError(where, "0x607A", f"target position {read.target_counts} counts, "
                             f"not the position actual value {read.counts} the master set: "
                             "the drive would move at enable in a position mode")
    if not lower - margin <= q <= upper + margin:
        raise ParameterError(where, "(homing)", f"the joint reads {degrees(q):.1f} deg, "
                             f"outside its range of motion {degrees(lower):.0f} to "
                             f"{degrees(upper):.0f} deg: check the encoder offset before "
                             "any motion")
    return (f"{where}: CiA 402 servo 0x{read.product_code:08X}, rated torque "
            f"{read.rated_unm} uN m, I_N {read.nominal_ma} mA, CST, interpolation "
            f"{every * 1e3:g} ms, {state.name}, targets torque 0 and position "
            f"{read.counts} counts, at {degrees(q):.1f} deg")
