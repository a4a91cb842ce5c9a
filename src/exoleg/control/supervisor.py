"""The supervisor every controller shares (compiled): the operator's commands against
the mode, through the safety layer's own arm, E-stop and reset.

DISARMED -> (arm) STANDING -> (walk) WALKING -> (stand) STOPPING -> STANDING, the last
step the controller's once it has reached where it can stop (walk again while stopping
goes back to WALKING); disarm from anywhere;
an E-stop or a latched safety fault -> FAULT, which only a reset leaves (to DISARMED),
and only when the state is sane again (:func:`exoleg.control.safety.reset`). Disarm is
refused while the child walks (WALKING, STOPPING): stand first -- a controlled stop --
or E-stop, which is always immediate. Transitions
happen on explicit commands (:class:`~exoleg.control.contract.Command`) or detected
faults, never on a timer. A command that does not apply in the mode is refused (and
reported in the tick's output), never silently dropped.
"""

from __future__ import annotations

import numpy as np
from numba import njit

from exoleg.control import safety as sf
from exoleg.layout import I8
from exoleg.tick import Command, Mode

#: The supervisor's state: its mode (:class:`~exoleg.control.contract.Mode`).
SUPERVISOR = np.dtype([("mode", I8)])


@njit(cache=True)
def supervise(sup, lim, sst, command, q, dq):  # type: ignore[no-untyped-def]
    """Apply ``command`` to the supervisor ``sup`` (:data:`SUPERVISOR`) and the safety
    layer (``lim``, ``sst``) at the measured ``q``, ``dq``. Returns the command refused
    (NONE if it applied or none came)."""
    mode = sup[0].mode
    refused = Command.NONE
    if command == Command.ARM:
        if mode == Mode.DISARMED and sf.arm(sst):
            mode = Mode.STANDING
        else:
            refused = command
    elif command == Command.WALK:
        if mode == Mode.STANDING or mode == Mode.STOPPING:
            mode = Mode.WALKING
        else:
            refused = command
    elif command == Command.STAND:
        if mode == Mode.WALKING:
            mode = Mode.STOPPING  # a controlled stop: the controller ends it
        elif mode != Mode.STOPPING:
            refused = command
    elif command == Command.DISARM:
        if mode == Mode.WALKING or mode == Mode.STOPPING:
            refused = command  # no torque off mid-stride: stand first, or E-stop
        else:
            sf.disarm(sst)
            if mode != Mode.FAULT:
                mode = Mode.DISARMED
    elif command == Command.ESTOP:
        sf.estop(sst)
        mode = Mode.FAULT
    elif command == Command.RESET:
        refused = command
        if mode == Mode.FAULT and sst[0].fault != sf.Fault.NONE:
            held, _ = sf.reset(lim, sst, q, dq)
            if held == sf.Fault.NONE:
                mode = Mode.DISARMED
                refused = Command.NONE
    elif command != Command.NONE:
        refused = command
    sup[0].mode = mode
    return refused


@njit(cache=True)
def settle(sup, sst):  # type: ignore[no-untyped-def]
    """After the safety layer's tick: a latched fault puts the supervisor in FAULT.
    Returns the mode."""
    if sst[0].fault != sf.Fault.NONE:
        sup[0].mode = Mode.FAULT
    return sup[0].mode


@njit(cache=True)
def report(sup, sst, refused, status, out):  # type: ignore[no-untyped-def]
    """The supervisor's and the safety layer's part of the tick's output record."""
    o = out[0]
    o.mode = sup[0].mode
    o.safety_status = status
    o.fault = sst[0].fault
    o.fault_joint = sst[0].fault_joint
    o.fault_value = sst[0].fault_value
    o.fault_limit = sst[0].fault_limit
    o.refused = refused
    for j in range(3):
        o.winding_temp[j] = sst[0].winding[j]
        o.gear_torque[j] = sst[0].gear[j]
        o.cuff[j] = sst[0].cuff_read[1, j]


#: The commands that apply in each mode (:func:`supervise` refuses the others; a reset
#: also needs the fault to no longer hold, the E-stop applies everywhere). The pages
#: enable their buttons by it.
APPLIES: dict[Mode, tuple[Command, ...]] = {
    Mode.DISARMED: (Command.ARM, Command.DISARM, Command.ESTOP),
    Mode.STANDING: (Command.WALK, Command.DISARM, Command.ESTOP),
    Mode.WALKING: (Command.STAND, Command.ESTOP),
    Mode.STOPPING: (Command.WALK, Command.STAND, Command.ESTOP),
    Mode.FAULT: (Command.RESET, Command.DISARM, Command.ESTOP),
}


def refusal(command: int, mode: int) -> str:
    """Why the supervisor refused ``command`` in ``mode``, as the operator reads it."""
    c, m = Command(int(command)), Mode(int(mode))
    why = {Command.ARM: "arming needs DISARMED (after a fault: reset first)",
           Command.WALK: "walking starts from STANDING, once the foot's contact is known "
                         "(the foot board reads nothing: check its sensors)",
           Command.STAND: "stand applies while walking",
           Command.DISARM: "disarm is refused while walking: stand first (a controlled "
                           "stop), or E-stop",
           Command.RESET: "reset applies in FAULT, once the fault no longer holds",
           Command.IMPEDANCE: "a support mode is chosen outside FAULT",
           Command.TRANSPARENT: "a support mode is chosen outside FAULT; the transparent "
                                "one needs the walking controller and its device's model",
           Command.AAN: "a support mode is chosen outside FAULT; assist-as-needed needs "
                        "the walking controller and its device's model"}
    return f"{c.name.lower()} refused in {m.name}: {why.get(c, 'not a command here')}"

