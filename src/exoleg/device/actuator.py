"""Actuators: motor + strain-wave gear + drive per joint, as data, and their compiled behaviour.

An :class:`ActuatorModel` is one file (``data/device/actuators/{hip,knee,ankle}.toml``,
each figure with its source: Table 2, the paper's text, the manufacturer's catalogue,
or exoleg's documented choice). What it does, at the joint (SI units):

* **reflected inertia** ``N^2 (J_rotor + J_gear_input)``: the leg's armature
  (:func:`with_actuators` puts it into the model, the exports and the engines);
* **torque from current** ``tau = N eta k_t i``, the drive's current limited to its peak;
* **torque-speed envelope** (:func:`envelope`): the peak torque (Table 2, or what the
  drive's peak current gives, whichever is lower) up to the speed where the peak power
  (``peak_power_factor`` times Table 2's rated power) runs out, ``P / |w|`` beyond,
  falling linearly to zero between Table 2's maximum velocity and ``no_load_factor``
  times it;
* **friction** (:func:`friction`): viscous ``b w`` plus Coulomb ``tau_c tanh(w / w_s)``
  (smooth near zero speed, so the dynamics stay integrable);
* **the drive's current loop** (:func:`current_loop`): first order with the loop's
  closed-loop bandwidth, discretised exactly over each plant step (zero-order hold of
  the command), returning the mean torque over the step;
* **encoder** (:func:`encode`): the absolute joint encoder's quantisation (2^bits per
  turn); the velocity is the finite difference of encoder readings over the control
  period through a first-order low-pass of ``velocity_filter_hz`` (:func:`filter_gain`).
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from exoleg.dynamics.model import LegModel
from exoleg.errors import ParameterError
from exoleg.io import read_text
from exoleg.layout import F8, new
from exoleg.params import _check
from exoleg.params.records import JOINTS

F64 = NDArray[np.float64]

#: (field, unit, lower, upper) of every number of an actuator file; the bounds are what
#: a pediatric exoskeleton's actuation unit can mean (a bad file is refused naming the
#: field and this range).
FIELDS: tuple[tuple[str, str, float, float], ...] = (
    ("ratio", "", 1.0, 1000.0),
    ("efficiency", "", 0.05, 1.0),
    ("rotor_inertia", "kg m^2", 0.0, 1e-2),
    ("gear_input_inertia", "kg m^2", 0.0, 1e-2),
    ("torque_constant", "N m/A", 1e-4, 10.0),
    ("peak_current", "A", 0.01, 500.0),
    ("continuous_current", "A", 0.01, 500.0),
    ("current_loop_rate", "Hz", 100.0, 1e6),
    ("current_loop_bandwidth", "Hz", 1.0, 1e5),
    ("peak_torque", "N m", 0.01, 1000.0),
    ("max_velocity_deg_s", "deg/s", 1.0, 5000.0),
    ("power", "W", 1.0, 10000.0),
    ("peak_power_factor", "", 1.0, 10.0),
    ("no_load_factor", "", 1.0, 3.0),
    ("coulomb_friction", "N m", 0.0, 50.0),
    ("viscous_friction", "N m s/rad", 0.0, 50.0),
    ("friction_smoothing", "rad/s", 1e-5, 10.0),
    ("encoder_bits", "bit", 8.0, 32.0),
    ("velocity_filter_hz", "Hz", 1.0, 1e5),
)
_NAMES = ("joint", "motor", "gear", "drive")
#: The largest reflected inertia at a joint a file may give, kg m^2: six times the
#: paper's hip (3.1 kg m^2: its motor and harmonic drive through 1:100); more would be
#: a unit slip (g cm^2 as kg m^2) or a ratio typed wrong, and the plant meaningless.
MAX_REFLECTED = 20.0


@dataclass(frozen=True)
class ActuatorModel:
    """One joint's actuation unit (see the module docstring; units as in :data:`FIELDS`,
    ``max_velocity`` in rad/s). ``sources`` names where each figure comes from."""

    joint: str
    motor: str
    gear: str
    drive: str
    ratio: float
    efficiency: float
    rotor_inertia: float
    gear_input_inertia: float
    torque_constant: float
    peak_current: float
    continuous_current: float
    current_loop_rate: float
    current_loop_bandwidth: float
    peak_torque: float
    max_velocity: float
    power: float
    peak_power_factor: float
    no_load_factor: float
    coulomb_friction: float
    viscous_friction: float
    friction_smoothing: float
    encoder_bits: int
    velocity_filter_hz: float
    sources: dict[str, str] = field(default_factory=dict, compare=False)

    @property
    def reflected_inertia(self) -> float:
        """N^2 (J_rotor + J_gear_input), kg m^2 at the joint."""
        return self.ratio**2 * (self.rotor_inertia + self.gear_input_inertia)

    @property
    def current_limited_torque(self) -> float:
        """N eta k_t I_peak: the most the drive's peak current gives at the joint, N m."""
        return self.ratio * self.efficiency * self.torque_constant * self.peak_current

    @property
    def torque_limit(self) -> float:
        """The peak joint torque: Table 2's or the current-limited one, the lower, N m."""
        return min(self.peak_torque, self.current_limited_torque)

    @property
    def continuous_torque(self) -> float:
        """N eta k_t I_continuous, N m: what the drive gives continuously."""
        return self.ratio * self.efficiency * self.torque_constant * self.continuous_current

    @property
    def encoder_resolution(self) -> float:
        """rad per count."""
        return 2 * math.pi / 2**self.encoder_bits

    def record(self) -> NDArray[np.void]:
        """The figures the compiled functions take (:data:`ACTUATOR`)."""
        r = new(ACTUATOR)
        r[0] = (self.torque_limit, self.max_velocity, self.peak_power_factor * self.power,
                self.no_load_factor, self.coulomb_friction, self.viscous_friction,
                self.friction_smoothing, self.current_loop_bandwidth, self.encoder_resolution,
                self.velocity_filter_hz, self.ratio)
        return r


#: An actuator as the compiled functions read it (:meth:`ActuatorModel.record`), joint
#: side: torque limit (N m), speed limit (rad/s), peak power (W), the no-load speed as a
#: multiple of the speed limit, Coulomb (N m) and viscous (N m s/rad) friction and the
#: Coulomb term's smoothing speed (rad/s), the current loop's bandwidth (Hz), the
#: encoder's resolution (rad), the velocity filter's cut-off (Hz), the gear ratio.
ACTUATOR = np.dtype([("torque", F8), ("speed", F8), ("power", F8), ("no_load", F8),
                     ("coulomb", F8), ("viscous", F8), ("smoothing", F8), ("bandwidth", F8),
                     ("resolution", F8), ("filter_hz", F8), ("ratio", F8)])


def parse_actuator(data: dict[str, Any], where: str) -> ActuatorModel:
    """An actuator from a parsed file; errors name the file, the field and the range."""
    _check.keys(where, data, [*_NAMES, *(f[0] for f in FIELDS)], ["sources"])
    vals: dict[str, Any] = {}
    for name in _NAMES:
        if not isinstance(data[name], str):
            raise ParameterError(where, name, f"expected a string, got {data[name]!r}")
        vals[name] = data[name]
    if vals["joint"] not in JOINTS:
        raise ParameterError(where, "joint", f"unknown {vals['joint']!r} (allowed: "
                                             + ", ".join(JOINTS) + ")")
    for name, unit, lo, hi in FIELDS:
        v = _check.finite(where, name, data[name])
        if not lo <= v <= hi:
            raise ParameterError(where, name, f"{v:g} {unit} is outside {lo:g}-{hi:g} {unit}"
                                 .replace("  ", " "))
        vals[name] = v
    if vals["current_loop_bandwidth"] > vals["current_loop_rate"] / 2:
        raise ParameterError(where, "current_loop_bandwidth",
                             f"{vals['current_loop_bandwidth']:g} Hz is above half the loop "
                             f"rate ({vals['current_loop_rate'] / 2:g} Hz)")
    if vals["continuous_current"] > vals["peak_current"]:
        raise ParameterError(where, "continuous_current", "must not exceed peak_current")
    reflected = (vals["rotor_inertia"] + vals["gear_input_inertia"]) * vals["ratio"] ** 2
    if reflected > MAX_REFLECTED:
        raise ParameterError(where, "rotor_inertia/gear_input_inertia/ratio",
                             f"reflected inertia {reflected:.4g} kg m^2 at the joint is not "
                             f"a child's exoskeleton joint (allowed up to {MAX_REFLECTED:g}; "
                             "the paper's hip: 3.1)")
    bits = vals.pop("encoder_bits")
    if bits != int(bits):
        raise ParameterError(where, "encoder_bits", f"expected a whole number, got {bits}")
    sources = data.get("sources", {})
    if not isinstance(sources, dict):
        raise ParameterError(where, "sources", "must be a table of field = \"source\"")
    return ActuatorModel(max_velocity=math.radians(vals.pop("max_velocity_deg_s")),
                         encoder_bits=int(bits), sources={k: str(v) for k, v in sources.items()},
                         **vals)


def load_actuator(path: str | Path) -> ActuatorModel:
    """Read an actuator file (format: ``data/device/actuators/hip.toml``)."""
    text = read_text(path, "actuator file (TOML)")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ParameterError(str(path), "(syntax)", f"not valid TOML: {e}") from None
    return parse_actuator(data, str(path))


def paper_actuators(folder: str | Path | None = None
                    ) -> tuple[ActuatorModel, ActuatorModel, ActuatorModel]:
    """The three actuation units (hip, knee, ankle): a device folder's ``actuators/*.toml``
    where it has them (:mod:`exoleg.device.files`), else the paper's shipped files."""
    from exoleg.device.files import load

    out = []
    for j in JOINTS:
        where, data = load(f"actuators/{j}.toml", folder)
        a = parse_actuator(data, where)
        if a.joint != j:
            raise ParameterError(where, "joint", f"is {a.joint!r}; this file is the {j}'s")
        out.append(a)
    return tuple(out)  # type: ignore[return-value]


def with_actuators(leg: LegModel, actuators: tuple[ActuatorModel, ...] | None = None) -> LegModel:
    """``leg`` with each actuator's reflected inertia as its joint's armature."""
    acts = paper_actuators() if actuators is None else actuators
    return leg.with_armature([a.reflected_inertia for a in acts])


def params_array(actuators: tuple[ActuatorModel, ...]) -> NDArray[np.void]:
    """The three actuators (3,) of :data:`ACTUATOR`, for the compiled loop (``A[i:i + 1]``
    is joint i's record)."""
    if len(actuators) != 3 or [a.joint for a in actuators] != list(JOINTS):
        raise ParameterError("actuators", "joint",
                             "need the hip, knee and ankle actuators, in that order")
    return np.concatenate([a.record() for a in actuators])


# ------------------------------------------------------------------ compiled behaviour
@njit(cache=True)
def envelope(par, w):  # type: ignore[no-untyped-def]
    """Largest joint torque (N m, >= 0) the actuator ``par`` (:data:`ACTUATOR`)
    delivers at joint speed ``w`` (rad/s)."""
    P = par[0]
    s = abs(w)
    t = P.torque
    if s > 0.0:
        t = min(t, P.power / s)
    wmax = P.speed
    if s > wmax:
        w0 = P.no_load * wmax
        corner = min(P.torque, P.power / wmax)
        t = corner * max(0.0, (w0 - s) / (w0 - wmax))
    return t


@njit(cache=True)
def friction(par, w):  # type: ignore[no-untyped-def]
    """Friction torque at the joint, N m, opposing the speed w: viscous plus smooth
    Coulomb (tanh over ``friction_smoothing``)."""
    P = par[0]
    return P.viscous * w + P.coulomb * math.tanh(w / P.smoothing)


@njit(cache=True)
def current_loop(par, tau, tau_cmd, h):  # type: ignore[no-untyped-def]
    """The drive's torque (current) loop over a step of ``h`` s with the command held:
    first order of bandwidth f_c, exactly discretised. Returns (torque at the end of the
    step, mean torque over the step)."""
    T = 1.0 / (2.0 * math.pi * par[0].bandwidth)
    e = math.exp(-h / T)
    end = tau_cmd + (tau - tau_cmd) * e
    mean = tau_cmd + (tau - tau_cmd) * (T / h) * (1.0 - e)
    return end, mean


@njit(cache=True)
def encode(par, q):  # type: ignore[no-untyped-def]
    """The joint encoder's reading of angle q (rad): quantised to 2pi / 2^bits."""
    r = par[0].resolution
    return math.floor(q / r + 0.5) * r


@njit(cache=True)
def filter_gain(par, h):  # type: ignore[no-untyped-def]
    """Gain b of the velocity low-pass y += b (x - y) sampled every h s (exact for a
    first-order filter of ``velocity_filter_hz`` with the input held)."""
    return 1.0 - math.exp(-2.0 * math.pi * par[0].filter_hz * h)
