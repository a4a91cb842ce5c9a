"""The safety layer: always between a controller and the drives.

Every tick it takes the measured state (q rad, dq rad/s), the controller's torque
command (N m) and the E-stop input, and gives the torque the drives may apply:

* **no motion without arming**: disarmed, the torque is zero;
* **E-stop**: torque zero the same tick, latched; only :meth:`SafetyLayer.reset` (with
  the E-stop input released) and then :meth:`SafetyLayer.arm` bring torque back;
* **non-finite** state or command: torque zero, latched fault;
* **overspeed**: abs(dq) above each actuation unit's own speed limit (its motor's maximum
  permissible speed through its gear's ratio) times ``overspeed_factor``: torque zero,
  latched fault;
* **range of motion**: beyond the device's range of motion (soft limit) no torque that
  pushes further out; beyond it by ``hard_margin``: torque zero, latched fault;
* **what each part carries**, each limit on the quantity the part is rated for: the
  command, what the motor and drive give, within Table 2's maximum per joint and each
  unit's working limit (its drive set at its gear's repeated peak or its current limit,
  the lower), its **rate** within ``max_torque_rate`` (a step of the command reaches
  the gear and the child before the rotor moves: it comes as a ramp); the torque the
  gear carries -- the command less the rotor's inertia torque (reflected inertia x the
  measured acceleration, low-passed at ``accel_filter_hz``) and the motor's drag --
  within the gear's repeated peak torque (a rotor slowing down loads its gear beyond
  the command; unloading it is never held back by the rate);
* **the cuffs' torque** (:func:`cuff_check`, called by the walking controller, which
  knows the child's mass and what a support is): the interaction reading through a
  cuff's own low-pass (``cuff_bandwidth``: a strap on soft tissue passes no impact
  spike of the rigid model's estimate), per joint against ``cuff_limit`` N m per kg of
  the child; beyond it the support falls towards transparent (``cuff_share``, over
  ``cuff_ramp`` s); beyond it for longer than ``cuff_stop`` s (a quasi-static push, not
  relieved by the support's fall) a controlled stop; beyond ``cuff_off`` x the limit
  torque off, latched (CUFF_TORQUE); a device without a cuff sensor (NaN) is not
  watched;
* **motor temperature**: each motor's winding and housing temperatures estimated from
  the torque the layer allows (the current it draws, copper losses with the winding's
  resistance at its temperature, maxon's two-node model, exact per tick); above
  ``winding limit - derate_band`` the torque limit falls linearly to the motor's
  continuous torque (N eta k_t I_N) at the winding limit; beyond the limit: torque off,
  latched (OVERTEMPERATURE), and a reset only once the winding has cooled by the band;
* **gear overload**: each gear's transmitted torque estimated from the torque allowed
  last tick less the rotor's inertia torque (reflected inertia x the measured
  acceleration); above the gear's momentary peak torque (its hard limit, for impacts)
  the tick is marked, counted and its peak kept, and -- when ``gear_overload = "fault"``
  -- torque off, latched (GEAR_OVERLOAD). The shipped device marks and counts: torque
  off cannot unload a gear overloaded by its own rotor's inertia at an impact, and would
  drop a child in stance (``docs/device.md``).

The limits are data (:class:`SafetyLimits`, defaults from ``data/device/safety.toml``,
the paper's range of motion and Table 2); the state is explicit (:class:`SafetyLayer`
holds it as one small array); the tick is compiled (:func:`safety_step`) so that the
simulator, the runtime and the hardware-in-the-loop tests run the same code.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from exoleg import checks as _check
from exoleg.control.cuff_watch import cuff_check  # noqa: F401  (the layer's, by name)
from exoleg.control.motor_watch import gear_check, motors_tick, watch_limits
from exoleg.device.actuator import paper_actuators, params_array
from exoleg.errors import ParameterError
from exoleg.layout import F8, I8, new
from exoleg.params.records import JOINTS
from exoleg.tick import LIMITED_TEXT, Fault, Limited  # noqa: F401  (declared with the contract)

F64 = NDArray[np.float64]


#: The largest torque-rate limit a device file may set, N m/s: Table 2's largest torque
#: (168 N m) through a 1 kHz current loop's rise (about 0.35 ms) is 4.8e5 N m/s; a limit
#: above that of the drive itself limits nothing.
MAX_TORQUE_RATE = 5e5

#: The safety layer's limits as the compiled tick reads them (:meth:`SafetyLimits.record`):
#: per joint the range of motion (rad), the torque clip (N m), the largest torque change
#: in one tick (N m) and the overspeed threshold (rad/s); the hard margin (rad); per
#: motor its thermal model -- joint torque per ampere (N m/A), the winding's resistance
#: at 25 degC (ohm), winding-housing and housing-ambient resistances (K/W), the two nodes'
#: step matrix over one tick (``phi``: [[a, b], [c, d]] row by row), the temperature at
#: which derating starts and the winding's limit (degC), the continuous torque it derates
#: to (N m) -- and the ambient temperature (degC); per gear its momentary peak (N m) and
#: the reflected inertia behind it (kg m^2); the tick (s); whether a gear overload is a
#: fault; per gear its repeated peak (N m: the limit on the torque it carries), the
#: motor's drag at the joint N k_t I_0 (N m) and its smoothing speed (rad/s); the share
#: of the acceleration estimate kept each tick (its first-order low-pass); the cuffs'
#: torque limit per joint (N m/kg), the support's change per tick while beyond it or
#: below (a fraction of 1), how long beyond it stops a walk (s), the torque-off level
#: (a multiple of the limit) and the share each of the cuff reading's two low-pass
#: stages keeps per tick.
LIMITS = np.dtype([("lower", F8, 3), ("upper", F8, 3), ("max_torque", F8, 3),
                   ("max_step", F8, 3), ("max_speed", F8, 3), ("hard_margin", F8),
                   ("kt_joint", F8, 3), ("r25", F8, 3), ("r_wh", F8, 3), ("r_ha", F8, 3),
                   ("phi", F8, (3, 4)), ("derate_from", F8, 3), ("winding_limit", F8, 3),
                   ("continuous", F8, 3), ("ambient", F8), ("momentary", F8, 3),
                   ("inertia", F8, 3), ("dt", F8), ("gear_fault", np.bool_),
                   ("repeated", F8, 3), ("drag", F8, 3), ("smoothing", F8, 3),
                   ("acc_keep", F8), ("cuff_limit", F8, 3), ("cuff_rate", F8),
                   ("cuff_stop", F8), ("cuff_off", F8), ("cuff_keep", F8)])
#: The safety layer's state: armed, the latched fault (:class:`Fault`), its joint (-1
#: for none or an E-stop), the value that latched it and the limit it crossed (rad for
#: HARD_LIMIT, rad/s for OVERSPEED, degC for OVERTEMPERATURE, N m for GEAR_OVERLOAD; 0
#: for the others), the torque allowed last tick (N m); per motor the estimated winding
#: and housing temperatures (degC); per gear the estimated transmitted torque this tick,
#: the largest abs(value) so far (N m) and how many times it went beyond the momentary peak;
#: the measured rates of the last tick (rad/s); whether the layer has ticked (the
#: estimates start then: temperatures at ambient); per joint the low-passed measured
#: acceleration (rad/s^2), the share of the support the cuffs' torque leaves (1: all,
#: falling while beyond its limit), how long it has been beyond its limit (s) and the
#: cuffs' torque through the two stages of the cuffs' low-pass (N m; the second is the
#: reading the limit is checked on; NaN until a reading is a number).
STATE = np.dtype([("armed", np.bool_), ("fault", I8), ("fault_joint", I8),
                  ("fault_value", F8), ("fault_limit", F8), ("prev", F8, 3),
                  ("winding", F8, 3), ("housing", F8, 3), ("gear", F8, 3),
                  ("gear_peak", F8, 3), ("gear_events", I8, 3), ("dq_prev", F8, 3),
                  ("started", np.bool_), ("acc", F8, 3), ("cuff_share", F8, 3),
                  ("cuff_over", F8, 3), ("cuff_read", F8, (2, 3))])


def new_state() -> NDArray[np.void]:
    """The safety layer's state at power-up: disarmed, no fault, no torque (the motors'
    temperatures start at the ambient on the first tick)."""
    s = new(STATE)
    s[0]["fault_joint"] = -1
    s[0]["cuff_share"] = 1.0
    s[0]["cuff_read"] = np.nan
    return s


#: What a gear overload does (``gear_overload`` in ``safety.toml``).
GEAR_RESPONSES = ("warn", "fault")


@dataclass(frozen=True)
class SafetyLimits:
    """The safety layer's limits, per joint (hip, knee, ankle), SI units.

    lower, upper: soft limits, rad (the range of motion); hard_margin: rad beyond them;
    max_torque N m; max_torque_rate N m/s; max_speed rad/s (the overspeed threshold);
    dt: the tick, s (for the torque rate). ``actuators``: the three actuation units
    whose motors' temperatures and gears' loads the layer watches (None: the shipped
    ones); ``ambient`` degC, the air around the motors; ``derate_band`` K, how far below
    the winding limit derating starts; ``gear_fault``: a gear beyond its momentary peak
    is a fault (True) or marked and counted (False); ``accel_filter_hz``: the cut-off of
    the measured acceleration's low-pass, from which the layer estimates the rotor's
    inertia torque (and so what the gear carries); ``cuff_limit`` N m per kg of the
    child per joint (infinite: not watched), ``cuff_ramp`` s, ``cuff_stop`` s,
    ``cuff_off`` (a multiple of the limit) and ``cuff_bandwidth`` Hz: the cuffs' torque's
    limit, the responses and the reading's low-pass (:func:`cuff_check`).
    """

    lower: F64
    upper: F64
    hard_margin: float
    max_torque: F64
    max_torque_rate: F64
    max_speed: F64
    dt: float = 1e-3
    source: str = field(default="", compare=False)
    actuators: tuple[Any, ...] | None = None
    ambient: float = 25.0
    derate_band: float = 15.0
    gear_fault: bool = False
    accel_filter_hz: float = 30.0
    cuff_limit: F64 = field(default_factory=lambda: np.full(3, np.inf))
    cuff_ramp: float = 0.5
    cuff_stop: float = 0.5
    cuff_off: float = 3.0
    cuff_bandwidth: float = 20.0

    def __post_init__(self) -> None:
        w = "SafetyLimits"
        lo = _check.vector(w, "lower", list(self.lower), 3)
        hi = _check.vector(w, "upper", list(self.upper), 3)
        for i, j in enumerate(JOINTS):
            if not lo[i] < hi[i]:
                raise ParameterError(w, f"lower/upper ({j})",
                                     f"lower {lo[i]} rad must be below upper {hi[i]} rad")
        object.__setattr__(self, "lower", lo)
        object.__setattr__(self, "upper", hi)
        hm = _check.finite(w, "hard_margin", self.hard_margin)
        if not 0 <= hm <= math.radians(45):
            raise ParameterError(w, "hard_margin", f"{hm} rad is outside 0-0.785 rad (0-45 deg)")
        object.__setattr__(self, "hard_margin", hm)
        for name in ("max_torque", "max_torque_rate", "max_speed"):
            v = _check.vector(w, name, list(getattr(self, name)), 3)
            if np.any(v <= 0):
                raise ParameterError(w, name, f"must be > 0 per joint, got {v.tolist()}")
            object.__setattr__(self, name, v)
        dt = _check.positive(w, "dt", self.dt, "s")
        if dt > 0.1:
            raise ParameterError(w, "dt", f"{dt} s is not a control tick (allowed up to 0.1 s)")
        object.__setattr__(self, "dt", dt)
        acts = paper_actuators() if self.actuators is None else tuple(self.actuators)
        params_array(acts)  # hip, knee, ankle actuators, in that order
        object.__setattr__(self, "actuators", acts)
        for name, lo_, hi_, unit in (("ambient", -20.0, 60.0, "degC"),
                                     ("derate_band", 1.0, 60.0, "K"),
                                     ("accel_filter_hz", 1.0, 0.5 / dt, "Hz"),
                                     ("cuff_ramp", dt, 60.0, "s"),
                                     ("cuff_stop", dt, 60.0, "s"),
                                     ("cuff_off", 1.0, 10.0, "x the limit"),
                                     ("cuff_bandwidth", 1.0, 0.5 / dt, "Hz")):
            x = _check.finite(w, name, getattr(self, name))
            if not lo_ <= x <= hi_:
                raise ParameterError(w, name, f"{x:g} {unit} is outside {lo_:g}-{hi_:g} {unit}")
            object.__setattr__(self, name, x)
        hot = [a.joint for a in acts if a.max_winding_temperature - self.derate_band
               <= self.ambient]
        if hot:
            raise ParameterError(w, "ambient/derate_band", f"the {hot[0]} motor would derate "
                                 f"at the ambient {self.ambient:g} degC: its winding limit "
                                 "less the band must lie above it")
        cl = _check.vector(w, "cuff_limit", list(np.nan_to_num(
            np.asarray(self.cuff_limit, dtype=float), posinf=1e300)), 3)
        if np.any(cl <= 0.0):
            raise ParameterError(w, "cuff_limit", f"{cl.tolist()} N m/kg: must be > 0 per "
                                 "joint (infinite: not watched)")
        object.__setattr__(self, "cuff_limit", np.where(cl >= 1e300, np.inf, cl))
        if not isinstance(self.gear_fault, bool | np.bool_):
            raise ParameterError(w, "gear_fault", f"expected True or False, got "
                                 f"{self.gear_fault!r}")

    @classmethod
    def paper(cls, dt: float = 1e-3, folder: str | Path | None = None,
              actuators: tuple[Any, ...] | None = None) -> SafetyLimits:
        """The defaults: the paper's range of motion and Table 2, with ``safety.toml``'s
        margins, rates and thermal settings (a device folder's,
        :mod:`exoleg.device.files`, or the package's), watching ``actuators`` (None: the
        folder's)."""
        from exoleg.device.files import load
        from exoleg.params import paper

        where, d = load("safety.toml", folder)
        numbers = {"hard_margin_deg": (0.0, 45.0, "deg"), "torque_fraction": (0.01, 1.0, ""),
                   "overspeed_factor": (0.1, 3.0, ""),
                   "ambient_temperature": (-20.0, 60.0, "degC"),
                   "derate_band": (1.0, 60.0, "K"), "accel_filter_hz": (1.0, 500.0, "Hz")}
        others = ("max_torque_rate", "gear_overload", "cuffs")
        _check.keys(where, d, [*numbers, *others], ["source"])
        v = _check.ranged(where, {k: x for k, x in d.items() if k not in others}, numbers)
        cuffs = d["cuffs"]
        if not isinstance(cuffs, dict):
            raise ParameterError(where, "cuffs", "expected a table [cuffs] (limit_Nm_per_kg, "
                                 "ramp_s, stop_after_s, off_at)")
        c = _check.ranged(f"{where} [cuffs]", {k: x for k, x in cuffs.items()
                                               if k != "limit_Nm_per_kg"},
                          {"ramp_s": (1e-3, 60.0, "s"), "stop_after_s": (1e-3, 60.0, "s"),
                           "off_at": (1.0, 10.0, ""), "bandwidth_hz": (1.0, 500.0, "Hz")})
        per_kg = _check.vector(f"{where} [cuffs]", "limit_Nm_per_kg",
                               cuffs.get("limit_Nm_per_kg"), 3)
        if not np.all((per_kg > 0.0) & (per_kg <= 20.0)):
            raise ParameterError(f"{where} [cuffs]", "limit_Nm_per_kg",
                                 f"{per_kg.tolist()}: each 0-20 N m/kg")
        rate = _check.vector(where, "max_torque_rate", d["max_torque_rate"], 3)
        if not np.all((rate >= 1.0) & (rate <= MAX_TORQUE_RATE)):
            raise ParameterError(where, "max_torque_rate", f"{rate.tolist()} N m/s: each "
                                 f"rate must be 1-{MAX_TORQUE_RATE:g} N m/s (above, the "
                                 "limit limits nothing: the drives' current loops are "
                                 "slower)")
        response = d.get("gear_overload")
        if response not in GEAR_RESPONSES:
            raise ParameterError(where, "gear_overload", f"{response!r}: allowed "
                                 + ", ".join(f'"{r}"' for r in GEAR_RESPONSES))
        rom = paper.range_of_motion()
        table2 = paper.actuators()
        acts = paper_actuators(folder) if actuators is None else tuple(actuators)
        # the command: Table 2's torque within what each drive gives at its current
        # limit (the gear's repeated peak limits the torque the gear carries, below; its
        # momentary peak is for collisions, never commanded)
        working = np.array([a.torque_limit for a in acts])
        try:
            return cls(lower=rom.lower, upper=rom.upper,
                       hard_margin=math.radians(v["hard_margin_deg"]),
                       max_torque=np.minimum(v["torque_fraction"] * np.array(
                           [a.max_torque for a in table2]), working),
                       max_torque_rate=rate,
                       max_speed=v["overspeed_factor"] * np.array(
                           [a.permissible_speed for a in acts]),
                       dt=dt, source=str(d.get("source", where)), actuators=acts,
                       ambient=v["ambient_temperature"], derate_band=v["derate_band"],
                       gear_fault=response == "fault", accel_filter_hz=v["accel_filter_hz"],
                       cuff_limit=per_kg, cuff_ramp=c["ramp_s"],
                       cuff_stop=c["stop_after_s"], cuff_off=c["off_at"],
                       cuff_bandwidth=c["bandwidth_hz"])
        except ParameterError as e:  # a range checked by the record: name the file
            raise ParameterError(where, e.field, e.problem) from None

    def record(self) -> NDArray[np.void]:
        """The limits as the compiled tick takes them (:data:`LIMITS`)."""
        r = new(LIMITS)
        r["lower"], r["upper"], r["max_torque"] = self.lower, self.upper, self.max_torque
        r["max_step"] = self.max_torque_rate * self.dt
        r["max_speed"], r["hard_margin"] = self.max_speed, self.hard_margin
        watch_limits(r, self.actuators or (), self.dt, self.derate_band, self.max_torque)
        r["ambient"], r["gear_fault"] = self.ambient, self.gear_fault
        r["acc_keep"] = math.exp(-2.0 * math.pi * self.accel_filter_hz * self.dt)
        r["cuff_limit"], r["cuff_rate"] = self.cuff_limit, self.dt / self.cuff_ramp
        r["cuff_stop"], r["cuff_off"] = self.cuff_stop, self.cuff_off
        r["cuff_keep"] = math.exp(-2.0 * math.pi * self.cuff_bandwidth * self.dt)
        return r


@njit(cache=True)
def check_state(lim, state, q, dq, u_cmd):  # type: ignore[no-untyped-def]
    """The fault the measured state ``q``, ``dq``, the command ``u_cmd`` (3,) and the
    motors' estimated temperatures (``state``) latch (:class:`Fault`; NONE when sane) and
    its joint, joint by joint: a non-finite value, overspeed, beyond the hard margin, a
    winding beyond its limit (:func:`safety_step` keeps the value and the limit it
    crossed once a fault latches: worked out there, the check stays lean)."""
    L = lim[0]
    for i in range(3):
        if not (math.isfinite(q[i]) and math.isfinite(dq[i]) and math.isfinite(u_cmd[i])):
            return Fault.NONFINITE, i
        if abs(dq[i]) > L.max_speed[i]:
            return Fault.OVERSPEED, i
        if q[i] < L.lower[i] - L.hard_margin or q[i] > L.upper[i] + L.hard_margin:
            return Fault.HARD_LIMIT, i
        if state[0].winding[i] > L.winding_limit[i]:
            return Fault.OVERTEMPERATURE, i
    return Fault.NONE, -1


@njit(cache=True)
def arm(state):  # type: ignore[no-untyped-def]
    """Allow torque; refused (returns False) while a fault is latched."""
    s = state[0]
    if s.fault != Fault.NONE:
        return False
    s.armed = True
    return True


@njit(cache=True)
def disarm(state):  # type: ignore[no-untyped-def]
    """No torque from the next tick on (the torque rate does not apply to stopping)."""
    state[0].armed = False


@njit(cache=True)
def estop(state):  # type: ignore[no-untyped-def]
    """E-stop: torque off from the next tick, latched (an earlier fault stays the one
    latched), disarmed."""
    s = state[0]
    if s.fault == Fault.NONE:
        s.fault = Fault.ESTOP
        s.fault_joint = -1
    s.armed = False


@njit(cache=True)
def reset(lim, state, q, dq):  # type: ignore[no-untyped-def]
    """Clear a latched fault, disarmed, if the state ``q``, ``dq`` is sane
    (:func:`check_state`). Returns the fault that still holds and its joint (NONE, -1
    when cleared); the state is unchanged then. After an overtemperature the winding must
    have cooled below where derating starts."""
    f, j = check_state(lim, state, q, dq, np.zeros(3))
    if f != Fault.NONE:
        return f, j
    s = state[0]
    for i in range(3):
        if s.fault == Fault.OVERTEMPERATURE and s.winding[i] > lim[0].derate_from[i]:
            return Fault.OVERTEMPERATURE, i
    s.armed = False
    s.fault = Fault.NONE
    s.fault_joint = -1
    s.fault_value = 0.0
    s.fault_limit = 0.0
    for i in range(3):
        s.prev[i] = 0.0
    return Fault.NONE, -1


@njit(cache=True)
def safety_step(lim, state, q, dq, u_cmd, estop_input, u):  # type: ignore[no-untyped-def]
    """One tick. ``lim``: :data:`LIMITS` (:meth:`SafetyLimits.record`); ``state``:
    :data:`STATE`; ``q``, ``dq``, ``u_cmd`` (3,); ``estop_input`` bool. Writes the
    allowed torque into ``u`` (3,) and returns the status bits (:class:`Limited`). The
    output is finite and within the limits for any input."""
    L = lim[0]
    s = state[0]
    status = 0
    if estop_input and s.fault == Fault.NONE:
        s.fault = Fault.ESTOP
        s.fault_joint = -1
    over = gear_check(lim, state, dq)
    if over >= 0:
        status |= Limited.GEAR_PEAK
    if s.fault == Fault.NONE:
        f, j = check_state(lim, state, q, dq, u_cmd)
        if f == Fault.NONE and over >= 0 and L.gear_fault:
            f, j = Fault.GEAR_OVERLOAD, over
        if f != Fault.NONE:
            s.fault = f
            s.fault_joint = j
            # the value that latched it and the limit it crossed (signed; 0, 0 for a
            # non-finite value), for the operator: worked out here, inline (a returned
            # 4-tuple or a call cost the 1 kHz tick 30 %: benchmarks/bench_device.py)
            if f == Fault.OVERSPEED:
                s.fault_value = dq[j]
                s.fault_limit = math.copysign(L.max_speed[j], dq[j])
            elif f == Fault.HARD_LIMIT:
                s.fault_value = q[j]
                s.fault_limit = L.lower[j] - L.hard_margin if q[j] < L.lower[j] else \
                    L.upper[j] + L.hard_margin
            elif f == Fault.OVERTEMPERATURE:
                s.fault_value = s.winding[j]
                s.fault_limit = L.winding_limit[j]
            elif f == Fault.GEAR_OVERLOAD:
                s.fault_value = s.gear[j]
                s.fault_limit = math.copysign(L.momentary[j], s.gear[j])
            else:
                s.fault_value = 0.0
                s.fault_limit = 0.0
    if s.fault != Fault.NONE or not s.armed:
        status |= Limited.FAULT if s.fault != Fault.NONE else Limited.DISARMED
        for i in range(3):
            u[i] = 0.0
            s.prev[i] = 0.0
        motors_tick(lim, state, dq, u)
        return status
    for i in range(3):
        v = u_cmd[i]
        if (q[i] > L.upper[i] and v > 0.0) or (q[i] < L.lower[i] and v < 0.0):
            v = 0.0  # no torque that pushes further out of the range of motion
            status |= Limited.SOFT_LIMIT
        tmax = L.max_torque[i]
        hot = s.winding[i] - L.derate_from[i]
        if hot > 0.0:  # derate linearly to the continuous torque at the winding limit
            status |= Limited.DERATED
            tmax -= min(hot / (L.winding_limit[i] - L.derate_from[i]), 1.0) * \
                (tmax - L.continuous[i])
        if v > tmax:
            v = tmax
            status |= Limited.TORQUE
        elif v < -tmax:
            v = -tmax
            status |= Limited.TORQUE
        step = L.max_step[i]  # a step of the command reaches the gear before the rotor moves
        if v > s.prev[i] + step:
            v = s.prev[i] + step
            status |= Limited.RATE
        elif v < s.prev[i] - step:
            v = s.prev[i] - step
            status |= Limited.RATE
        # what the motor side takes of the command: the rotor's inertia torque and the
        # motor's drag; the rest the gear carries to the joint (its protection after the
        # rate: unloading a gear is never held back; within the drive's limit still)
        side = L.inertia[i] * s.acc[i] + L.drag[i] * math.tanh(dq[i] / L.smoothing[i])
        if v - side > L.repeated[i]:
            v = max(side + L.repeated[i], -tmax)
            status |= Limited.GEAR
        elif v - side < -L.repeated[i]:
            v = min(side - L.repeated[i], tmax)
            status |= Limited.GEAR
        u[i] = v
        s.prev[i] = v
    motors_tick(lim, state, dq, u)
    return status


class SafetyLayer:
    """The safety layer with its state: arm, disarm, E-stop, reset, and one :meth:`step`
    per control tick (compiled, :func:`safety_step`). Starts disarmed."""

    def __init__(self, limits: SafetyLimits | None = None) -> None:
        self.limits = SafetyLimits.paper() if limits is None else limits
        if not isinstance(self.limits, SafetyLimits):
            raise ParameterError("SafetyLayer", "limits",
                                 f"expected SafetyLimits, got {type(self.limits).__name__}")
        self._lim = self.limits.record()
        self.state = new_state()

    # ------------------------------------------------------------------ commands
    @property
    def armed(self) -> bool:
        return bool(self.state[0]["armed"])

    @property
    def fault(self) -> Fault:
        return Fault(int(self.state[0]["fault"]))

    @property
    def fault_joint(self) -> str:
        """The joint of the latched fault ('' for none or for an E-stop)."""
        return joint_name(self.fault, int(self.state[0]["fault_joint"]))

    @property
    def temperatures(self) -> F64:
        """The motors' estimated (winding, housing) temperatures (3, 2), degC."""
        st = self.state[0]
        return np.stack([st["winding"], st["housing"]], axis=1)

    @property
    def gear_torque(self) -> F64:
        """Each gear's estimated transmitted torque this tick (3,), N m."""
        return np.array(self.state[0]["gear"])

    def arm(self) -> None:
        """Allow torque. Refused while a fault is latched (:meth:`reset` first)."""
        if not arm(self.state):
            raise ParameterError("SafetyLayer", "arm",
                                 f"refused: {fault_text(self.fault, self.fault_joint)} is "
                                 "latched; reset() first")

    def disarm(self) -> None:
        """No torque from the next tick on (the torque rate does not apply to stopping)."""
        disarm(self.state)

    def estop(self) -> None:
        """E-stop from a command (as the input would): torque off from the next tick, latched."""
        estop(self.state)

    def reset(self, q: ArrayLike, dq: ArrayLike, estop_input: bool = False) -> None:
        """Clear a latched fault, disarmed: only with the E-stop input released and the
        state finite, within the range of motion plus the hard margin, below overspeed."""
        qa = _check.reading("SafetyLayer.reset", "q", q, 3)
        va = _check.reading("SafetyLayer.reset", "dq", dq, 3)
        if estop_input:
            raise ParameterError("SafetyLayer", "reset", "refused: the E-stop is still pressed")
        f, j = reset(self._lim, self.state, qa, va)
        if f != Fault.NONE:
            raise ParameterError("SafetyLayer", "reset", f"refused: {still_holds(f, j)}")

    # ---------------------------------------------------------------------- tick
    def step(self, q: ArrayLike, dq: ArrayLike, u_cmd: ArrayLike,
             estop: bool = False) -> tuple[F64, int]:
        """The torque allowed this tick (3,) N m and the status bits (:class:`Limited`)."""
        w = "SafetyLayer.step"
        u = np.empty(3)
        status = safety_step(self._lim, self.state, _check.reading(w, "q", q, 3),
                             _check.reading(w, "dq", dq, 3),
                             _check.reading(w, "u_cmd", u_cmd, 3), bool(estop), u)
        return u, int(status)


def joint_name(fault: Fault, joint: int) -> str:
    """The joint a latched fault names ('' for none, an E-stop, or no joint)."""
    return JOINTS[joint] if fault not in (Fault.NONE, Fault.ESTOP) and 0 <= joint < 3 else ""


def fault_text(fault: Fault, joint: str = "") -> str:
    """A fault as people read it: ``OVERSPEED (ankle)``."""
    return f"{fault.name}{f' ({joint})' if joint else ''}"


def fault_event(fault: int, joint: int) -> str:
    """A latched fault as an event of a session: "an E-stop", or "a fault: OVERSPEED
    (knee)"."""
    f = Fault(int(fault))
    return "an E-stop" if f == Fault.ESTOP else \
        f"a fault: {fault_text(f, joint_name(f, int(joint)))}"


def fault_detail(fault: int, joint: int, value: float, limit: float) -> str:
    """A latched fault as the operator reads it ('' for none): its kind, joint, the value
    against its limit, and what going on needs, e.g. "OVERSPEED at the knee: 5.21 rad/s
    (299 deg/s) against its limit of 4.00 rad/s (229 deg/s). To go on: ..."."""
    f = Fault(int(fault))
    if f == Fault.NONE:
        return ""
    jn = joint_name(f, int(joint))
    at = f" at the {jn}" if jn else ""
    if f == Fault.ESTOP:
        return "E-stop. To go on: Reset (with the E-stop released), then Arm."
    if f == Fault.NONFINITE:
        return (f"a reading or command that is not a number (NaN or infinite){at}. To go "
                "on: Reset once every reading is a number again, then Arm.")
    if f == Fault.OVERTEMPERATURE:
        return (f"OVERTEMPERATURE{at}: the motor's winding at {value:.0f} degC (estimated) "
                f"beyond its limit of {limit:.0f} degC. To go on: let it cool (Reset is "
                "refused until it is below where derating starts), then Arm.")
    if f == Fault.CUFF_TORQUE:
        return (f"CUFF_TORQUE{at}: the cuffs' torque at {abs(value):.0f} N m beyond its "
                f"torque-off level of {abs(limit):.0f} N m (the child pushing against the "
                "device, or the device against the child). To go on: check the child and "
                "the straps, then Reset and Arm.")
    if f == Fault.GEAR_OVERLOAD:
        return (f"GEAR_OVERLOAD{at}: {abs(value):.0f} N m through the gear (estimated) "
                f"beyond its momentary peak of {abs(limit):.0f} N m. To go on: have the gear "
                "inspected, then Reset and Arm.")
    unit, deg = ("rad/s", "deg/s") if f == Fault.OVERSPEED else ("rad", "deg")
    word = "beyond" if f == Fault.HARD_LIMIT else "against"
    return (f"{f.name}{at}: {value:.2f} {unit} ({math.degrees(value):.0f} {deg}) {word} "
            f"its limit of {limit:.2f} {unit} ({math.degrees(limit):.0f} {deg}). To go on: "
            "Reset once the joint is back within its limit and still, then Arm.")


def still_holds(fault: int, joint: int) -> str:
    """Why a reset was refused: ``HARD_LIMIT still holds (hip)``."""
    f = Fault(int(fault))
    jn = joint_name(f, int(joint))
    return f"{f.name} still holds{f' ({jn})' if jn else ''}"
