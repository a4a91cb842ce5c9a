"""The support modes of the walking controller, and the transparent (zero-torque) one.

:class:`SupportMode`: how much the device does for the child. ``IMPEDANCE`` is the
paper's phase-scheduled impedance (:mod:`exoleg.control.hierarchy`); ``AAN`` mixes it
with the transparent law by a support adapted to the child (:mod:`exoleg.control.assist`);
``TRANSPARENT`` lets the child move as if the device were not there: the drives deliver what the
device's own links, its motors' rotors (the reflected inertia, hip 3.2 kg m^2) and its
friction take, so that the cuffs pass (ideally) no torque::

    tau = G_d(q) + C_d(q, dq) dq + M_d(q) ddq^ + f(dq + lead ddq^)
          - kp tau_int - ki \\int tau_int

with M_d, C_d, G_d the device alone (:func:`exoleg.child.interaction.device_leg`: its
links at the child's telescope settings with the rotors as armature), f the actuators'
friction (:func:`exoleg.device.drive.link_friction`), ddq^ the joint acceleration
estimated from the measured rates (their difference per tick, low-passed), ``lead``
the drive's lag the friction's speed is taken ahead by, and the last terms the feedback
of the cuffs' torque ``tau_int`` measured (the :data:`SENSORS` field ``interaction``,
what a joint torque sensor between the drive and the cuff -- or a cuff load cell --
reads; the device has none today: on the buses the reading is NaN and the mode is the
model's feedforward alone). Each part can be switched off (:attr:`TransparencySettings.parts`)
so that one run shows what each contributes (``exoleg validate --transparency``).

A change of support mode is blended over ``ramp`` s (the two laws' torques mixed
linearly), never a step: :func:`support_blend`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from exoleg import checks as _check
from exoleg.control.gears import LAW_TUNABLE
from exoleg.device.drive import link_friction
from exoleg.dynamics.kernels import N_PARAMS, coriolis_dq, gravity, mass_matrix
from exoleg.entry import SUPPORT_MODES
from exoleg.errors import ParameterError
from exoleg.layout import F8, I8, new
from exoleg.tick import Command, Mode, SupportMode

F64 = NDArray[np.float64]


#: The names people type for the support modes (:data:`exoleg.entry.SUPPORT_MODES`).
SUPPORT_NAMES = {n: SupportMode[n.upper()] for n in SUPPORT_MODES}


def support_mode_of(controller: str) -> SupportMode:
    """The support mode a walking controller called ``controller`` starts in
    (:data:`exoleg.entry.WALKING_CONTROLLERS`: ``walk`` is the impedance)."""
    return SUPPORT_NAMES.get(controller, SupportMode.IMPEDANCE)
#: The parts of the transparent law, in the order they are added.
PARTS = ("gravity", "inertia", "friction", "interaction")
#: (field in the file, unit, lower, upper) of the transparent mode's scalar settings.
_SCALARS = (("lead_ms", "ms", 0.0, 20.0), ("ramp_s", "s", 0.05, 5.0))
#: (field in the file, name in the settings and the record, lower, upper) of its
#: per-joint settings
_VECTORS = (("accel_filter_hz", "accel_filter_hz", 1.0, 500.0),
            ("inertia_share", "inertia_share", 0.0, 1.0),
            ("kp_interaction", "kp", 0.0, 20.0), ("ki_interaction", "ki", 0.0, 1000.0),
            ("integral_limit", "integral_limit", 0.0, 100.0),
            ("wall_stiffness", "wall_stiffness", 0.0, 1e4),
            ("wall_damping", "wall_damping", 0.0, 500.0))
#: those that may be one number for every joint
_ONE_FOR_ALL = ("accel_filter_hz", "inertia_share")


@dataclass(frozen=True)
class TransparencySettings:
    """The transparent mode's settings (``data/device/transparency.toml``): which parts
    act (:data:`PARTS`); the acceleration estimate's low-pass (Hz) and the share of the
    device's inertia compensated with it, both per joint; the lead (s) the friction's speed
    is taken ahead by; the cuffs' torque feedback's proportional (dimensionless) and integral
    (1/s) gains per joint with the integral's bound (N m); the wall at the range of
    motion's ends (N m/rad, N m s/rad per joint); the blend between support modes (s)."""

    parts: tuple[bool, bool, bool, bool]
    accel_filter_hz: F64
    inertia_share: F64
    lead: float
    kp: F64
    ki: F64
    integral_limit: F64
    wall_stiffness: F64
    wall_damping: F64
    ramp: float

    def __post_init__(self) -> None:
        w = "TransparencySettings"
        if len(self.parts) != len(PARTS) or not all(isinstance(b, bool) for b in self.parts):
            raise ParameterError(w, "parts", f"expected {len(PARTS)} true/false "
                                 f"({', '.join(PARTS)}), got {self.parts!r}")
        for (_, unit, lo, hi), name, scale in zip(
                _SCALARS, ("lead", "ramp"), (1e3, 1.0), strict=True):
            _check.within(w, name, _check.finite(w, name, getattr(self, name)) * scale,
                          lo, hi, unit)
        for _, name, lo, hi in _VECTORS:
            object.__setattr__(self, name, _check.vector_within(
                w, name, list(getattr(self, name)), 3, lo, hi))

    @classmethod
    def default(cls, folder: str | Path | None = None) -> TransparencySettings:
        """From ``transparency.toml`` (a device folder's, :mod:`exoleg.device.files`, or
        the package's)."""
        from exoleg.device.files import load

        where, d = load("transparency.toml", folder)
        _check.keys(where, d, ["parts", *(f[0] for f in _SCALARS), *(f[0] for f in _VECTORS)],
                    ["source"])
        parts = d["parts"]
        if not isinstance(parts, dict):
            raise ParameterError(where, "parts", f"expected a table of {', '.join(PARTS)}")
        _check.keys(f"{where} [parts]", parts, PARTS)
        for p in PARTS:
            if not isinstance(parts[p], bool):
                raise ParameterError(f"{where} [parts]", p, f"expected true or false, got "
                                     f"{parts[p]!r}")
        for field, _, lo, hi in _VECTORS:  # one for every joint, or one each
            one = d[field]
            if field in _ONE_FOR_ALL and isinstance(one, int | float) and not isinstance(
                    one, bool):
                d = {**d, field: [_check.within(where, field, one, lo, hi)] * 3}
        v = {name: _check.vector(where, field, d[field], 3) for field, name, *_ in _VECTORS}
        x = {name: _check.finite(where, name, d[name]) for name, *_ in _SCALARS}
        try:
            return cls(parts=tuple(parts[p] for p in PARTS), lead=x["lead_ms"] / 1e3,
                       ramp=x["ramp_s"], **v)
        except ParameterError as e:  # a range checked by the record: name the file
            raise ParameterError(where, e.field, e.problem) from None

    def with_parts(self, *names: str) -> TransparencySettings:
        """These settings with only the parts ``names`` acting."""
        for n in names:
            if n not in PARTS:
                raise ParameterError("TransparencySettings", "parts", f"unknown {n!r} "
                                     f"(allowed: {', '.join(PARTS)})")
        import dataclasses

        return dataclasses.replace(self, parts=tuple(p in names for p in PARTS))  # type: ignore[arg-type]

    def record(self, device_p: F64 | None) -> NDArray[np.void]:
        """What the compiled tick reads (:data:`TRANSPARENCY`) for the device alone's
        parameters ``device_p`` (:func:`~exoleg.child.interaction.device_leg`; None: not
        known, the transparent mode refused and the law inert -- only the settings an
        operator may change, :data:`~exoleg.control.gears.LAW_TUNABLE`, there to be
        read and changed)."""
        r = new(TRANSPARENCY)
        for name in LAW_TUNABLE:
            r[name] = getattr(self, name)
        if device_p is None:
            return r
        if np.shape(device_p) != (N_PARAMS,):
            raise ParameterError("TransparencySettings.record", "device_p",
                                 f"expected a leg's {N_PARAMS} parameters, got shape "
                                 f"{np.shape(device_p)}")
        r["parts"] = [1.0 if b else 0.0 for b in self.parts]
        for name in ("lead", "kp", "ki", "integral_limit", "wall_stiffness", "wall_damping",
                     "ramp"):
            r[name] = getattr(self, name)
        r["device_p"], r["known"] = device_p, True
        return r


#: The transparent law's parameters (:meth:`TransparencySettings.record`): the parts
#: acting (1/0, :data:`PARTS`), the acceleration filter (Hz) and the inertia's share
#: compensated per joint, the lead (s), the cuffs' torque feedback (kp, ki 1/s, the integral's
#: bound N m), the wall (N m/rad, N m s/rad), the support modes' blend (s), the device
#: alone's parameters and whether they are known (not: the mode refused).
TRANSPARENCY = np.dtype([("parts", F8, 4), ("accel_filter_hz", F8, 3),
                         ("inertia_share", F8, 3),
                         ("lead", F8), ("kp", F8, 3), ("ki", F8, 3),
                         ("integral_limit", F8, 3), ("wall_stiffness", F8, 3),
                         ("wall_damping", F8, 3), ("ramp", F8),
                         ("device_p", F8, N_PARAMS), ("known", np.bool_)])
#: Its state: the support mode asked (:class:`SupportMode`: by the operator's command,
#: :func:`support_command`) and the one in force, when the blend started (s; negative:
#: none under way), the mix in force (the support level per joint, 0-1, and the weight of
#: assist-as-needed's own torque) and the one the blend started from, the rates last
#: measured (rad/s), the acceleration estimate (rad/s^2), the cuffs' torque integral
#: (N m), whether a tick has run (the first has no rate before it), and the last tick's
#: torque of each part of the transparent law (:data:`PARTS`, N m per joint) and of its
#: wall; the device alone's mass matrix, worked in by the law (no allocation a tick).
SUPPORT_STATE = np.dtype([("asked", I8), ("mode", I8), ("t_switch", F8),
                          ("level", F8, 3), ("assist", F8), ("from_level", F8, 3),
                          ("from_assist", F8),
                          ("dq_last", F8, 3), ("ddq", F8, 3), ("integral", F8, 3),
                          ("started", np.bool_), ("parts", F8, (4, 3)), ("wall", F8, 3),
                          ("M", F8, (3, 3))])


def new_support_state(mode: SupportMode = SupportMode.IMPEDANCE,
                      aan: ArrayLike = (1.0, 1.0, 1.0)) -> NDArray[np.void]:
    """The support state before the first tick, in ``mode``, its mix that mode's levels:
    the impedance's 1, transparent 0, assist-as-needed's ``aan`` (3,) (its law's first,
    :meth:`~exoleg.control.assist.AssistSettings.first_level`)."""
    s = new(SUPPORT_STATE)
    s["asked"] = s["mode"] = int(mode)
    s["t_switch"] = -1.0
    s["level"] = s["from_level"] = (1.0 if mode == SupportMode.IMPEDANCE else
                                    0.0 if mode == SupportMode.TRANSPARENT else aan)
    s["assist"] = s["from_assist"] = 1.0 if mode == SupportMode.AAN else 0.0
    return s


@njit(cache=True)
def track_rates(tp, ss, dq, h):  # type: ignore[no-untyped-def]
    """The joint acceleration estimate of :data:`SUPPORT_STATE` ``ss``: the measured
    rates' difference per tick of ``h`` s through each joint's low-pass of ``tp``, every
    tick (whether or not the transparent law acts: no stale rate when it starts)."""
    T = tp[0]
    S = ss[0]
    for j in range(3):
        if S.started:
            b = 1.0 - math.exp(-2.0 * math.pi * T.accel_filter_hz[j] * h)
            S.ddq[j] += b * ((dq[j] - S.dq_last[j]) / h - S.ddq[j])
        S.dq_last[j] = dq[j]
    S.started = True


@njit(cache=True)
def transparent_torque(law, g, motion, cuff, rom, h, armed, out):  # type: ignore[no-untyped-def]
    """The transparent law's torque (N m) into ``out`` (3,) at the measured ``motion``
    (q, dq), the cuffs' ``cuff`` (tau_int, tau_ref): their torque read this tick (NaN: no
    sensor, the feedback off) and the torque asked at them (0: transparent; an
    assistance law's otherwise -- added ahead, and the feedback acts on ``tau_int -
    tau_ref``), the range of motion ``rom`` (lower, upper, rad), gravity ``g``, a tick of
    ``h`` s. ``law``: (:data:`TRANSPARENCY`, the actuators' records,
    :data:`SUPPORT_STATE` -- the acceleration estimate :func:`track_rates` keeps; the
    integral advances here, each part's torque is kept). The integral runs only while
    ``armed``, within its bound. Beyond the range of motion a wall (stiffness, and
    damping against the motion outwards) pushes back."""
    tp, A, ss = law
    q, dq = motion
    tau_int, tau_ref = cuff
    lower, upper = rom
    T = tp[0]
    S = ss[0]
    P = S.parts
    for j in range(3):
        for i in range(4):
            P[i, j] = 0.0
    pd = T.device_p
    if T.parts[0] != 0.0:
        gravity(q, pd, g, P[0])
    if T.parts[1] != 0.0:
        M = S.M  # (the device alone's mass matrix, worked in here: no allocation)
        mass_matrix(q, pd, M)
        coriolis_dq(q, dq, pd, P[1])
        for j in range(3):
            P[1, j] += T.inertia_share[j] * (M[j, 0] * S.ddq[0] + M[j, 1] * S.ddq[1]
                                             + M[j, 2] * S.ddq[2])
    for j in range(3):
        if T.parts[2] != 0.0:
            P[2, j] = link_friction(A[j:j + 1], dq[j] + T.lead * S.ddq[j])
        P[3, j] = tau_ref[j]
        if T.parts[3] != 0.0 and armed and math.isfinite(tau_int[j]):
            e = tau_int[j] - tau_ref[j]
            lim = T.integral_limit[j]
            S.integral[j] = min(max(S.integral[j] + T.ki[j] * h * e, -lim), lim)
            P[3, j] -= T.kp[j] * e + S.integral[j]
        else:
            S.integral[j] = 0.0
        w = 0.0
        if q[j] > upper[j]:
            w = -T.wall_stiffness[j] * (q[j] - upper[j]) - T.wall_damping[j] * max(dq[j], 0.0)
        elif q[j] < lower[j]:
            w = T.wall_stiffness[j] * (lower[j] - q[j]) - T.wall_damping[j] * min(dq[j], 0.0)
        S.wall[j] = w
        out[j] = P[0, j] + P[1, j] + P[2, j] + P[3, j] + w


#: The operator's commands that choose a support mode, and the mode each asks: in the
#: modes' order from IMPEDANCE on (:func:`support_command` reads it so).
SUPPORT_COMMANDS = {Command(Command.IMPEDANCE + m): m for m in SupportMode}
#: The supervisor's modes in which the walking controller takes them (the transparent
#: one with the device's model known); the supervisor itself refuses them.
SUPPORT_APPLIES = (Mode.DISARMED, Mode.STANDING, Mode.WALKING, Mode.STOPPING)


@njit(cache=True)
def support_command(tp, ss, command, mode):  # type: ignore[no-untyped-def]
    """Take the operator's ``command`` if it chooses a support mode (in any supervisor
    ``mode`` but FAULT; the transparent and assist-as-needed ones only with the device's
    model known):
    returns (the command left for the supervisor -- NONE when this took it --, the
    command refused here or NONE)."""
    asked = command - Command.IMPEDANCE  # SUPPORT_COMMANDS
    if asked < 0 or asked > SupportMode.AAN:
        return command, Command.NONE
    if mode == Mode.FAULT or (asked != SupportMode.IMPEDANCE and not tp[0].known):
        return Command.NONE, command
    ss[0].asked = asked
    return Command.NONE, Command.NONE


@njit(cache=True)
def support_switch(tp, ss, t):  # type: ignore[no-untyped-def]
    """The support mode asked (the state's ``asked``) put in force at ``t`` s, and the
    blend's weight (0-1) of the mode in force against the mix it blends from: a change
    starts a blend of ``ramp`` s from the mix in force at the tick it was asked (a change
    asked mid-blend blends on from where the blend is: never a step)."""
    S = ss[0]
    if S.asked != S.mode:
        for j in range(3):
            S.from_level[j] = S.level[j]
        S.from_assist = S.assist
        S.mode = S.asked
        S.t_switch = t
    if S.t_switch < 0.0:
        return 1.0
    w = (t - S.t_switch) / tp[0].ramp
    if w >= 1.0:
        S.t_switch = -1.0
        return 1.0
    return w


@njit(cache=True)
def support_mix(ss, w, aan, out):  # type: ignore[no-untyped-def]
    """The support level per joint (0-1, the impedance's share) into ``out`` (3,): the
    mode in force's -- 1 impedance, 0 transparent, assist-as-needed's ``aan`` (3,) --
    weighed ``w`` against the mix it blends from. Returns the weight (0-1) of
    assist-as-needed's own torque (its proportional law's) blended the same way. Both
    kept as the mix in force."""
    S = ss[0]
    for j in range(3):
        now = aan[j]
        if S.mode == SupportMode.IMPEDANCE:
            now = 1.0
        elif S.mode == SupportMode.TRANSPARENT:
            now = 0.0
        S.level[j] = w * now + (1.0 - w) * S.from_level[j]
        out[j] = S.level[j]
    S.assist = w * (1.0 if S.mode == SupportMode.AAN else 0.0) + (1.0 - w) * S.from_assist
    return S.assist
