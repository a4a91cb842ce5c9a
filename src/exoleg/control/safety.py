"""The safety layer: always between a controller and the drives.

Every tick it takes the measured state (q rad, dq rad/s), the controller's torque
command (N m) and the E-stop input, and gives the torque the drives may apply:

* **no motion without arming**: disarmed, the torque is zero;
* **E-stop**: torque zero the same tick, latched; only :meth:`SafetyLayer.reset` (with
  the E-stop input released) and then :meth:`SafetyLayer.arm` bring torque back;
* **non-finite** state or command: torque zero, latched fault;
* **overspeed**: |dq| above Table 2's maximum velocity times ``overspeed_factor``:
  torque zero, latched fault;
* **range of motion**: beyond the device's range of motion (soft limit) no torque that
  pushes further out; beyond it by ``hard_margin``: torque zero, latched fault;
* **torque** clipped to Table 2's maximum per joint and **torque rate** to
  ``max_torque_rate`` (so a step in the command reaches the drives as a ramp).

The limits are data (:class:`SafetyLimits`, defaults from ``data/device/safety.toml``,
the paper's range of motion and Table 2); the state is explicit (:class:`SafetyLayer`
holds it as one small array); the tick is compiled (:func:`safety_step`) so that the
simulator, the runtime and the hardware-in-the-loop tests run the same code.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import IntEnum
from pathlib import Path

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from exoleg.errors import ParameterError
from exoleg.params import _check
from exoleg.params.records import JOINTS

F64 = NDArray[np.float64]


class Fault(IntEnum):
    """Why the torque is off (latched until :meth:`SafetyLayer.reset`)."""

    NONE = 0
    ESTOP = 1
    NONFINITE = 2
    OVERSPEED = 3
    HARD_LIMIT = 4


class Limited(IntEnum):
    """Bits of a tick's status: what the layer changed in the command this tick."""

    DISARMED = 1        # torque zero: not armed
    FAULT = 2           # torque zero: a latched fault (see Fault)
    SOFT_LIMIT = 4      # a joint beyond its range of motion had its outward torque removed
    TORQUE = 8          # clipped to the maximum torque
    RATE = 16           # limited by the torque rate


# state array layout
_ARMED, _FAULT, _FAULT_JOINT, _PREV = 0, 1, 2, 3
STATE_SIZE = 6


@dataclass(frozen=True)
class SafetyLimits:
    """The safety layer's limits, per joint (hip, knee, ankle), SI units.

    lower, upper: soft limits, rad (the range of motion); hard_margin: rad beyond them;
    max_torque N m; max_torque_rate N m/s; max_speed rad/s (the overspeed threshold);
    dt: the tick, s (for the torque rate).
    """

    lower: F64
    upper: F64
    hard_margin: float
    max_torque: F64
    max_torque_rate: F64
    max_speed: F64
    dt: float = 1e-3
    source: str = field(default="", compare=False)

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

    @classmethod
    def paper(cls, dt: float = 1e-3, folder: str | Path | None = None) -> SafetyLimits:
        """The defaults: the paper's range of motion and Table 2, with ``safety.toml``'s
        margins and rates (a device folder's, :mod:`exoleg.device.files`, or the
        package's)."""
        from exoleg.device.files import load
        from exoleg.params import paper

        where, d = load("safety.toml", folder)
        v = _check.ranged(where, {k: x for k, x in d.items() if k != "max_torque_rate"},
                          {"hard_margin_deg": (0.0, 45.0, "deg"),
                           "torque_fraction": (0.01, 1.0, ""),
                           "overspeed_factor": (0.1, 3.0, "")})
        if "max_torque_rate" not in d:
            raise ParameterError(where, "max_torque_rate", "missing (3 rates, N m/s)")
        rate = _check.vector(where, "max_torque_rate", d["max_torque_rate"], 3)
        rom = paper.range_of_motion()
        acts = paper.actuators()
        try:
            return cls(lower=rom.lower, upper=rom.upper,
                       hard_margin=math.radians(v["hard_margin_deg"]),
                       max_torque=v["torque_fraction"] * np.array([a.max_torque for a in acts]),
                       max_torque_rate=rate,
                       max_speed=v["overspeed_factor"] * np.array([a.max_velocity for a in acts]),
                       dt=dt, source=str(d.get("source", where)))
        except ParameterError as e:  # a range checked by the record: name the file
            raise ParameterError(where, e.field, e.problem) from None

    def as_tuple(self) -> tuple[float, ...]:
        """The limits as the compiled tick takes them: lower, upper, max torque, max torque
        change per tick, max speed (3 each), then the hard margin."""
        return (*map(float, self.lower), *map(float, self.upper), *map(float, self.max_torque),
                *map(float, self.max_torque_rate * self.dt), *map(float, self.max_speed),
                float(self.hard_margin))


@njit(cache=True)
def safety_step(lim, state, q, dq, u_cmd, estop, u):  # type: ignore[no-untyped-def]
    """One tick. ``lim``: :meth:`SafetyLimits.as_tuple`; ``state`` (6,): armed, fault,
    fault joint, previous torque (3); ``q``, ``dq``, ``u_cmd`` (3,); ``estop`` bool.
    Writes the allowed torque into ``u`` (3,) and returns the status bits (:class:`Limited`).
    The output is finite and within the limits for any input."""
    status = 0
    if estop and state[_FAULT] == 0:
        state[_FAULT] = 1  # Fault.ESTOP
        state[_FAULT_JOINT] = -1
    if state[_FAULT] == 0:
        for i in range(3):
            if not (math.isfinite(q[i]) and math.isfinite(dq[i]) and math.isfinite(u_cmd[i])):
                state[_FAULT] = 2  # Fault.NONFINITE
                state[_FAULT_JOINT] = i
                break
            if abs(dq[i]) > lim[12 + i]:
                state[_FAULT] = 3  # Fault.OVERSPEED
                state[_FAULT_JOINT] = i
                break
            if q[i] < lim[i] - lim[15] or q[i] > lim[3 + i] + lim[15]:
                state[_FAULT] = 4  # Fault.HARD_LIMIT
                state[_FAULT_JOINT] = i
                break
    if state[_FAULT] != 0 or state[_ARMED] == 0:
        status |= 2 if state[_FAULT] != 0 else 1
        for i in range(3):
            u[i] = 0.0
            state[_PREV + i] = 0.0
        return status
    for i in range(3):
        v = u_cmd[i]
        if (q[i] > lim[3 + i] and v > 0.0) or (q[i] < lim[i] and v < 0.0):
            v = 0.0  # no torque that pushes further out of the range of motion
            status |= 4
        tmax = lim[6 + i]
        if v > tmax:
            v = tmax
            status |= 8
        elif v < -tmax:
            v = -tmax
            status |= 8
        step = lim[9 + i]
        prev = state[_PREV + i]
        if v > prev + step:
            v = prev + step
            status |= 16
        elif v < prev - step:
            v = prev - step
            status |= 16
        u[i] = v
        state[_PREV + i] = v
    return status


class SafetyLayer:
    """The safety layer with its state: arm, disarm, E-stop, reset, and one :meth:`step`
    per control tick (compiled, :func:`safety_step`). Starts disarmed."""

    def __init__(self, limits: SafetyLimits | None = None) -> None:
        self.limits = SafetyLimits.paper() if limits is None else limits
        self._lim = self.limits.as_tuple()
        self.state = np.zeros(STATE_SIZE)
        self._u = np.zeros(3)

    # ------------------------------------------------------------------ commands
    @property
    def armed(self) -> bool:
        return bool(self.state[_ARMED])

    @property
    def fault(self) -> Fault:
        return Fault(int(self.state[_FAULT]))

    @property
    def fault_joint(self) -> str:
        """The joint of the latched fault ('' for none or for an E-stop)."""
        j = int(self.state[_FAULT_JOINT])
        return JOINTS[j] if self.fault not in (Fault.NONE, Fault.ESTOP) and j >= 0 else ""

    def arm(self) -> None:
        """Allow torque. Refused while a fault is latched (:meth:`reset` first)."""
        if self.fault != Fault.NONE:
            raise ParameterError("SafetyLayer", "arm", f"refused: {self.fault.name} is latched"
                                 f"{' (' + self.fault_joint + ')' if self.fault_joint else ''}; "
                                 "reset() first")
        self.state[_ARMED] = 1.0

    def disarm(self) -> None:
        """No torque from the next tick on (the torque rate does not apply to stopping)."""
        self.state[_ARMED] = 0.0

    def estop(self) -> None:
        """E-stop from a command (as the input would): torque off from the next tick, latched."""
        if self.state[_FAULT] == 0:
            self.state[_FAULT] = float(Fault.ESTOP)
            self.state[_FAULT_JOINT] = -1
        self.state[_ARMED] = 0.0

    def reset(self, q: ArrayLike, dq: ArrayLike, estop_input: bool = False) -> None:
        """Clear a latched fault, disarmed: only with the E-stop input released and the
        state finite, within the range of motion plus the hard margin, below overspeed."""
        qa, va = np.asarray(q, dtype=float), np.asarray(dq, dtype=float)
        if estop_input:
            raise ParameterError("SafetyLayer", "reset", "refused: the E-stop is still pressed")
        probe, u, z = np.zeros(STATE_SIZE), np.zeros(3), np.zeros(3)
        probe[_ARMED] = 1.0
        safety_step(self._lim, probe, qa, va, z, False, u)
        if probe[_FAULT] != 0:
            f = Fault(int(probe[_FAULT]))
            j = JOINTS[int(probe[_FAULT_JOINT])]
            raise ParameterError("SafetyLayer", "reset", f"refused: {f.name} still holds "
                                 f"({j})")
        self.state[:] = 0.0

    # ---------------------------------------------------------------------- tick
    def step(self, q: ArrayLike, dq: ArrayLike, u_cmd: ArrayLike,
             estop: bool = False) -> tuple[F64, int]:
        """The torque allowed this tick (3,) N m and the status bits (:class:`Limited`)."""
        u = np.empty(3)
        status = safety_step(self._lim, self.state, np.asarray(q, dtype=float),
                             np.asarray(dq, dtype=float), np.asarray(u_cmd, dtype=float),
                             bool(estop), u)
        return u, int(status)
