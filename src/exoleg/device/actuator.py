"""Actuators: motor + strain-wave gear + drive per joint, as data; their compiled behaviour is
:mod:`exoleg.device.drive`'s.

An :class:`ActuatorModel` is one file (``data/device/actuators/{hip,knee,ankle}.toml``),
each figure with its source id from ``shared/design/device-datasheets.md`` (the
motors' and gears' sheets, maxon's EPOS4 configuration), Table 2, or a labelled choice.
What it does, at the joint (SI units):

* **reflected inertia** ``N^2 (J_rotor + J_gear_input)``: the leg's armature
  (:func:`with_actuators` puts it into the model, the exports and the engines);
* **torque from current** ``tau = N eta k_t i``;
* **torque-speed envelope** (:func:`~exoleg.device.drive.envelope`), voltage-limited at
  the bus voltage: the current the winding can still draw at motor speed ``w_m = N |w|``,
  ``min(I_limit, (V_bus - k_t w_m) / R)`` (the back-EMF constant is k_t in SI units),
  times ``N eta k_t``; capped by the gear's **repeated peak torque** (its working limit;
  the momentary peak is for collisions and E-stops, never commanded); zero beyond the
  motor's maximum permissible speed. That is the motoring envelope; a torque against the
  motion (:func:`~exoleg.device.drive.drive_limit`: braking, the back-EMF helping the
  current) is limited by the current and the gear only, at any speed -- the drive brakes a
  joint the load has driven past its speed, as a four-quadrant drive does;
* **friction** (:func:`~exoleg.device.drive.friction`): Coulomb from the motor's no-load
  current (``N k_t I_0``) and the gear's backdriving torque, smoothed near zero speed
  (``tanh(w / w_s)``, so the dynamics stay integrable), plus a viscous term;
* **the drive's current loop** (:func:`~exoleg.device.drive.current_loop`): first order
  with the loop's closed-loop bandwidth, discretised exactly over each plant step
  (zero-order hold of the command), returning the mean torque over the step;
* **the winding's temperature** (:mod:`exoleg.device.thermal`: ``thermal_matrix``,
  ``thermal_hold``, ``copper_loss``, ``winding_temperature``): maxon's two-node model
  (winding and housing, their thermal resistances and time constants) heated by the copper
  loss ``R(T_w) i^2``, the winding's resistance rising with its temperature as copper's
  does (:data:`COPPER_ALPHA`); the safety layer runs the same model every tick to derate a
  hot motor;
* **encoder** (:func:`~exoleg.device.drive.encode`): the absolute joint encoder's
  quantisation (2^bits per turn); the velocity is the finite difference of encoder
  readings over the control period through a first-order low-pass of
  ``velocity_filter_hz`` (:func:`~exoleg.device.drive.filter_gain`);
* **compliance** (optional, :data:`COMPLIANCE`, :data:`SERIES_FIELDS`): a series spring
  between the gear and the link, or the stiff gear with a joint torque sensor -- the rotor
  (inertia B = N^2 J) a body of its own on the stiffness K
  (:func:`~exoleg.device.drive.series_torque`), the drive closing a torque loop on the
  measured torque (:func:`~exoleg.device.drive.torque_loop`) whose gains follow from its
  natural frequency and damping (:attr:`ActuatorModel.torque_loop_gains`); the link then
  feels K / w_b^2 of the rotor (:attr:`ActuatorModel.apparent_inertia`) and 1 / (1 + kp)
  of its friction (:func:`~exoleg.device.drive.link_friction`). The walking plant steps
  the rotors with the leg (:func:`exoleg.world.plant.walking_step_series`).
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from exoleg import checks as _check
from exoleg.dynamics.model import LegModel
from exoleg.entry import HIP_VARIANTS
from exoleg.errors import ParameterError
from exoleg.io import read_text
from exoleg.layout import F8, new
from exoleg.params.records import JOINTS

F64 = NDArray[np.float64]

#: (field, unit, lower, upper) of every number of an actuator file, grouped as the file
#: groups them (motor, gear, drive, encoder, friction); the bounds are what a pediatric
#: exoskeleton's actuation unit can mean (a bad file is refused naming the field and
#: this range).
FIELDS: tuple[tuple[str, str, float, float], ...] = (
    # motor (24 V windings in the sheets)
    ("torque_constant", "N m/A", 1e-4, 10.0),
    ("rotor_inertia", "kg m^2", 0.0, 1e-2),
    ("nominal_current", "A", 0.01, 100.0),
    ("terminal_resistance", "ohm", 1e-3, 100.0),
    ("terminal_inductance", "H", 1e-7, 1.0),
    ("no_load_current", "A", 0.0, 20.0),
    ("max_speed_rpm", "rpm", 100.0, 100000.0),
    ("thermal_resistance_winding", "K/W", 0.01, 100.0),
    ("thermal_resistance_housing", "K/W", 0.01, 100.0),
    ("thermal_time_constant_winding", "s", 0.1, 1e4),
    ("thermal_time_constant_motor", "s", 1.0, 1e5),
    ("max_winding_temperature", "degC", 40.0, 250.0),
    ("pole_pairs", "", 1.0, 64.0),
    ("power", "W", 1.0, 10000.0),
    # gear
    ("ratio", "", 1.0, 1000.0),
    ("efficiency", "", 0.05, 1.0),
    ("gear_input_inertia", "kg m^2", 0.0, 1e-2),
    ("gear_rated_torque", "N m", 0.01, 1000.0),
    ("repeated_peak_torque", "N m", 0.01, 1000.0),
    ("momentary_peak_torque", "N m", 0.01, 2000.0),
    ("max_input_speed_rpm", "rpm", 100.0, 20000.0),
    ("backdriving_torque", "N m", 0.0, 50.0),
    ("gear_stiffness", "N m/rad", 100.0, 1e7),
    # drive
    ("continuous_current", "A", 0.01, 500.0),
    ("peak_current", "A", 0.01, 500.0),
    ("bus_voltage", "V", 5.0, 100.0),
    ("current_loop_rate", "Hz", 100.0, 1e6),
    ("current_loop_bandwidth", "Hz", 1.0, 1e5),
    ("product_code", "", 0.0, 2.0**32 - 1),
    # encoder
    ("encoder_bits", "bit", 8.0, 32.0),
    ("velocity_filter_hz", "Hz", 1.0, 1e5),
    # friction beyond the motor's no-load current and the gear's backdriving torque
    ("viscous_friction", "N m s/rad", 0.0, 50.0),
    ("friction_smoothing", "rad/s", 1e-5, 10.0),
)
#: What sits between the gear's output and the link (an actuator file's ``compliance``):
#: nothing (``rigid``: motor, gear and link turn as one body); a ``series_spring`` whose
#: deflection an encoder reads; or the gear's own and a joint torque sensor's twist
#: (``torque_sensor``: the same two-mass model, stiff). Either compliant kind closes the
#: drive's torque loop on the measured torque.
COMPLIANCE = ("rigid", "series_spring", "torque_sensor")
#: (field, unit, lower, upper) of a compliant unit's figures, absent from a rigid one's
#: file: the series stiffness (the spring's, or the gear's and the sensor's in series)
#: and damping at the joint, the torque loop's natural frequency and damping ratio, the
#: deflection's resolution in bits per turn (an encoder across the spring; a torque
#: sensor's resolution expressed as the twist it resolves).
SERIES_FIELDS: tuple[tuple[str, str, float, float], ...] = (
    ("series_stiffness", "N m/rad", 10.0, 1e6),
    ("series_damping", "N m s/rad", 0.0, 100.0),
    ("torque_loop_bandwidth", "Hz", 1.0, 1000.0),
    ("torque_loop_damping", "", 0.1, 2.0),
    ("deflection_bits", "bit", 8.0, 32.0),
)
#: the fields that are whole numbers
WHOLE = ("pole_pairs", "product_code", "encoder_bits", "deflection_bits")
_NAMES = ("joint", "motor", "gear", "drive")
#: The largest reflected inertia at a joint a file may give, kg m^2: six times the
#: paper's hip (3.2 kg m^2: its motor and harmonic drive through 1:100); more would be
#: a unit slip (g cm^2 as kg m^2) or a ratio typed wrong, and the plant meaningless.
MAX_REFLECTED = 20.0
RPM = 2.0 * math.pi / 60.0
#: Copper's temperature coefficient of resistance, 1/K (annealed copper, IEC 60028:
#: 0.00393 at 20 degC); maxon's catalogues give the terminal resistance at 25 degC.
COPPER_ALPHA = 0.00393
#: The temperature at which the actuator files' terminal resistances hold, degC.
R_REFERENCE_C = 25.0


@dataclass(frozen=True)
class ActuatorModel:
    """One joint's actuation unit (see the module docstring; units as in :data:`FIELDS`,
    speeds in rpm at the motor as the sheets give them). ``sources`` names where each
    figure comes from."""

    joint: str
    motor: str
    gear: str
    drive: str
    torque_constant: float
    rotor_inertia: float
    nominal_current: float
    terminal_resistance: float
    terminal_inductance: float
    no_load_current: float
    max_speed_rpm: float
    thermal_resistance_winding: float
    thermal_resistance_housing: float
    thermal_time_constant_winding: float
    thermal_time_constant_motor: float
    max_winding_temperature: float
    pole_pairs: int
    power: float
    ratio: float
    efficiency: float
    gear_input_inertia: float
    gear_rated_torque: float
    repeated_peak_torque: float
    momentary_peak_torque: float
    max_input_speed_rpm: float
    backdriving_torque: float
    gear_stiffness: float
    continuous_current: float
    peak_current: float
    bus_voltage: float
    current_loop_rate: float
    current_loop_bandwidth: float
    product_code: int
    encoder_bits: int
    velocity_filter_hz: float
    viscous_friction: float
    friction_smoothing: float
    sources: dict[str, str] = field(default_factory=dict, compare=False)
    compliance: str = "rigid"
    series_stiffness: float = 0.0
    series_damping: float = 0.0
    torque_loop_bandwidth: float = 0.0
    torque_loop_damping: float = 0.0
    deflection_bits: int = 0

    @property
    def compliant(self) -> bool:
        """Whether a spring or a torque sensor sits between the gear and the link."""
        return self.compliance != "rigid"

    @property
    def torque_loop_gains(self) -> tuple[float, float]:
        """The drive's torque loop on the measured torque tau_s = K delta (delta the
        deflection), ``tau_m = (1 + kp) tau_d - kp tau_s - kd K d(delta)/dt``: with the
        link held, B delta'' + (c + kd K) delta' + K (1 + kp) delta = (1 + kp) tau_d, so
        the loop's natural frequency is w_b = sqrt(K (1 + kp) / B) and its damping ratio
        zeta = (c + kd K) / (2 w_b B), B the reflected inertia: kp = B w_b^2 / K - 1,
        kd = (2 zeta w_b B - c) / K. (0, 0) for a rigid unit."""
        if not self.compliant:
            return 0.0, 0.0
        B, K = self.reflected_inertia, self.series_stiffness
        wb = 2.0 * math.pi * self.torque_loop_bandwidth
        return B * wb * wb / K - 1.0, (2.0 * self.torque_loop_damping * wb * B
                                       - self.series_damping) / K

    @property
    def apparent_inertia(self) -> float:
        """The inertia the link feels of its actuator, kg m^2: rigid, the reflected
        inertia N^2 J; compliant, below the torque loop's bandwidth, B / (1 + kp) =
        K / w_b^2 (Pratt & Williamson 1995: a series-elastic actuator's output impedance)."""
        if not self.compliant:
            return self.reflected_inertia
        wb = 2.0 * math.pi * self.torque_loop_bandwidth
        return self.series_stiffness / (wb * wb)

    @property
    def link_inertia(self) -> float:
        """The armature the link itself carries, kg m^2: the reflected inertia when
        rigid, none when compliant (the rotor is then a body of its own behind the
        spring)."""
        return 0.0 if self.compliant else self.reflected_inertia

    @property
    def reflected_inertia(self) -> float:
        """N^2 (J_rotor + J_gear_input), kg m^2 at the joint."""
        return self.ratio**2 * (self.rotor_inertia + self.gear_input_inertia)

    @property
    def joint_torque_constant(self) -> float:
        """N eta k_t: joint torque per ampere of motor current, N m/A."""
        return self.ratio * self.efficiency * self.torque_constant

    @property
    def current_limited_torque(self) -> float:
        """N eta k_t I_limit: the most the drive's configured current limit gives, N m."""
        return self.joint_torque_constant * self.peak_current

    @property
    def torque_limit(self) -> float:
        """The working peak joint torque: the current-limited one or the gear's repeated
        peak, the lower, N m."""
        return min(self.repeated_peak_torque, self.current_limited_torque)

    @property
    def continuous_torque(self) -> float:
        """N eta k_t I_N, N m: what the motor gives continuously (its nominal current,
        the thermal limit; the drive's continuous current is higher)."""
        return self.joint_torque_constant * self.nominal_current

    @property
    def no_load_speed(self) -> float:
        """The joint speed at which the bus voltage is all back-EMF (no torque left),
        rad/s: V_bus / (k_t N)."""
        return self.bus_voltage / self.torque_constant / self.ratio

    @property
    def permissible_speed(self) -> float:
        """The motor's maximum permissible speed through the gear, rad/s at the joint (a
        mechanical limit: a backdriven joint may turn faster than the no-load speed)."""
        return self.max_speed_rpm * RPM / self.ratio

    @property
    def max_velocity(self) -> float:
        """The fastest the joint turns, rad/s: the no-load speed at the bus voltage or the
        motor's maximum permissible speed through the gear, the lower."""
        return min(self.no_load_speed, self.permissible_speed)

    @property
    def coulomb_friction(self) -> float:
        """Coulomb friction at the joint, N m: the motor's drag at its no-load current
        through the gear (N k_t I_0) plus the gear's backdriving torque."""
        return self.ratio * self.torque_constant * self.no_load_current + \
            self.backdriving_torque

    @property
    def rated_motor_torque(self) -> float:
        """The motor's rated torque as an EPOS4 takes it (0x6076): k_t I_N, N m."""
        return self.torque_constant * self.nominal_current

    @property
    def encoder_resolution(self) -> float:
        """rad per count."""
        return 2 * math.pi / 2**self.encoder_bits

    def record(self) -> NDArray[np.void]:
        """The figures the compiled functions take.

        Returns
        -------
        ndarray
            A one-element :data:`ACTUATOR` record.
        """
        r = new(ACTUATOR)
        r[0] = (self.torque_limit, self.joint_torque_constant, self.peak_current,
                self.bus_voltage, self.torque_constant * self.ratio, self.terminal_resistance,
                self.permissible_speed, self.coulomb_friction,
                self.viscous_friction, self.friction_smoothing, self.current_loop_bandwidth,
                self.encoder_resolution, self.velocity_filter_hz,
                self.series_stiffness if self.compliant else 0.0, self.series_damping,
                self.reflected_inertia, *self.torque_loop_gains,
                2 * math.pi / 2**self.deflection_bits if self.compliant else 0.0)
        return r

    def thermal(self) -> NDArray[np.void]:
        """The two-node thermal model's figures.

        Returns
        -------
        ndarray
            A one-element :data:`THERMAL` record.
        """
        r = new(THERMAL)
        rw, rh = self.thermal_resistance_winding, self.thermal_resistance_housing
        r[0] = (rw, rh, self.thermal_time_constant_winding / rw,
                self.thermal_time_constant_motor / rh, self.terminal_resistance)
        return r


#: An actuator as the compiled functions read it (:meth:`ActuatorModel.record`), joint
#: side: the working torque limit (N m), N eta k_t (N m/A), the current limit (A), the
#: bus voltage (V), the back-EMF constant at the joint N k_t (V s/rad), the winding's
#: resistance (ohm), the motor's maximum permissible speed at the joint (rad/s), Coulomb
#: (N m) and viscous (N m s/rad) friction and the Coulomb term's smoothing speed
#: (rad/s), the current loop's bandwidth (Hz), the encoder's resolution (rad), the
#: velocity filter's cut-off (Hz); a compliant unit's series stiffness (N m/rad; 0: a
#: rigid unit) and damping (N m s/rad), the rotor's reflected inertia (kg m^2), the
#: torque loop's gains kp and kd (s) (:attr:`ActuatorModel.torque_loop_gains`) and the
#: deflection's resolution (rad).
ACTUATOR = np.dtype([("torque", F8), ("kt_joint", F8), ("current", F8), ("voltage", F8),
                     ("ke_joint", F8), ("resistance", F8), ("speed", F8),
                     ("coulomb", F8), ("viscous", F8), ("smoothing", F8), ("bandwidth", F8),
                     ("resolution", F8), ("filter_hz", F8), ("stiffness", F8),
                     ("series_damping", F8), ("inertia", F8), ("kp", F8), ("kd", F8),
                     ("deflection", F8)])
#: The motor's two thermal nodes (:meth:`ActuatorModel.thermal`): winding-housing and
#: housing-ambient resistances (K/W), the winding's and the housing's heat capacities
#: (J/K: each time constant over its resistance) and the winding's resistance (ohm).
THERMAL = np.dtype([("r_wh", F8), ("r_ha", F8), ("c_w", F8), ("c_h", F8),
                    ("resistance", F8)])



def _parameters() -> str:
    """ActuatorModel's numpydoc Parameters section, from :data:`FIELDS` (one table of
    the figures, their units and plausible ranges)."""
    rows = ["joint, motor, gear, drive : str", "    The joint and the parts' names."]
    for name, unit, lo, hi in FIELDS:
        kind = "int" if name in WHOLE else "float"
        rows += [f"{name} : {kind}", f"    {unit or 'dimensionless'}; {lo:g} to {hi:g}."]
    rows += ["sources : dict of str to str", "    Per figure, the datasheet it comes from.",
             "compliance : str", "    What sits between the gear and the link: "
             + ", ".join(COMPLIANCE) + " (default rigid, with none of the figures below)."]
    for name, unit, lo, hi in SERIES_FIELDS:
        kind = "int" if name in WHOLE else "float"
        rows += [f"{name} : {kind}", f"    {unit or 'dimensionless'}; {lo:g} to {hi:g} "
                 "(a compliant unit's)."]
    return "\n".join(f"    {r}" for r in ["", "Parameters", "----------", *rows, ""])


ActuatorModel.__doc__ = (ActuatorModel.__doc__ or "").rstrip() + "\n" + _parameters()

def figure(where: str, row: tuple[str, str, float, float], value: Any) -> Any:
    """One number of an actuator file checked against its ``row`` of :data:`FIELDS` or
    :data:`SERIES_FIELDS` (field, unit, range); a whole number as an int."""
    name, unit, lo, hi = row
    v = _check.finite(where, name, value)
    if not lo <= v <= hi:
        raise ParameterError(where, name, f"{v:g} {unit} is outside {lo:g}-{hi:g} {unit}"
                             .replace("  ", " "))
    if name in WHOLE:
        if v != int(v):
            raise ParameterError(where, name, f"expected a whole number, got {v}")
        return int(v)
    return v


def parse_actuator(data: dict[str, Any], where: str) -> ActuatorModel:
    """An actuator from a parsed file; errors name the file, the field and the range."""
    _check.keys(where, data, [*_NAMES, *(f[0] for f in FIELDS)],
                ["sources", "compliance", *(f[0] for f in SERIES_FIELDS)])
    vals: dict[str, Any] = {}
    for name in _NAMES:
        if not isinstance(data[name], str):
            raise ParameterError(where, name, f"expected a string, got {data[name]!r}")
        vals[name] = data[name]
    if vals["joint"] not in JOINTS:
        raise ParameterError(where, "joint", f"unknown {vals['joint']!r} (allowed: "
                                             + ", ".join(JOINTS) + ")")
    for row in FIELDS:
        vals[row[0]] = figure(where, row, data[row[0]])
    if vals["current_loop_bandwidth"] > vals["current_loop_rate"] / 2:
        raise ParameterError(where, "current_loop_bandwidth",
                             f"{vals['current_loop_bandwidth']:g} Hz is above half the loop "
                             f"rate ({vals['current_loop_rate'] / 2:g} Hz)")
    if vals["peak_current"] > 2 * vals["continuous_current"]:
        raise ParameterError(where, "peak_current", f"{vals['peak_current']:g} A is above "
                             "the drive's peak, twice its continuous current "
                             f"({2 * vals['continuous_current']:g} A)")
    if vals["nominal_current"] > vals["peak_current"]:
        raise ParameterError(where, "nominal_current", "the motor's nominal current must "
                             "not exceed the drive's current limit (peak_current)")
    if not vals["gear_rated_torque"] <= vals["repeated_peak_torque"] <= \
            vals["momentary_peak_torque"]:
        raise ParameterError(where, "repeated_peak_torque", "a gear's ratings go rated <= "
                             "repeated peak <= momentary peak")
    reflected = (vals["rotor_inertia"] + vals["gear_input_inertia"]) * vals["ratio"] ** 2
    if reflected > MAX_REFLECTED:
        raise ParameterError(where, "rotor_inertia/gear_input_inertia/ratio",
                             f"reflected inertia {reflected:.4g} kg m^2 at the joint is not "
                             f"a child's exoskeleton joint (allowed up to {MAX_REFLECTED:g}; "
                             "the paper's hip: 3.2)")
    sources = data.get("sources", {})
    if not isinstance(sources, dict):
        raise ParameterError(where, "sources", "must be a table of field = \"source\"")
    vals.update(_series(data, where, vals))
    fields = FIELDS + (SERIES_FIELDS if vals.get("compliance", "rigid") != "rigid" else ())
    missing = [f[0] for f in fields if f[0] not in sources]
    if missing:
        raise ParameterError(where, f"sources.{missing[0]}", "every figure names its source "
                             "(a sheet's id, Table 2, the paper, or \"choice: why\")")
    return ActuatorModel(sources={k: str(v) for k, v in sources.items()}, **vals)


def _series(data: dict[str, Any], where: str, vals: dict[str, Any]) -> dict[str, Any]:
    """A compliant unit's figures (:data:`SERIES_FIELDS`), checked: all of them when
    ``compliance`` is not rigid, none when it is; the torque loop above the rotor's
    resonance on the spring with the link held (a loop below it would add inertia, not
    hide it), at most a third of the current loop's bandwidth (the inner loop of a
    cascade must be the faster), and not needing negative damping."""
    kind = data.get("compliance", "rigid")
    given = [f[0] for f in SERIES_FIELDS if f[0] in data]
    if kind not in COMPLIANCE:
        raise ParameterError(where, "compliance", f"unknown {kind!r} (allowed: "
                             + ", ".join(COMPLIANCE) + ")")
    if kind == "rigid":
        if given:
            raise ParameterError(where, given[0], "a rigid unit has no series figures "
                                 "(set compliance = \"series_spring\" or \"torque_sensor\")")
        return {}
    out: dict[str, Any] = {"compliance": kind}
    for row in SERIES_FIELDS:
        if row[0] not in data:
            raise ParameterError(where, row[0], f"missing: a {kind} unit needs "
                                 + ", ".join(f[0] for f in SERIES_FIELDS))
        out[row[0]] = figure(where, row, data[row[0]])
    B = (vals["rotor_inertia"] + vals["gear_input_inertia"]) * vals["ratio"] ** 2
    f0 = math.sqrt(out["series_stiffness"] / B) / (2 * math.pi) if B > 0 else math.inf
    fb = out["torque_loop_bandwidth"]
    if fb < f0:
        raise ParameterError(where, "torque_loop_bandwidth", f"{fb:g} Hz is below the rotor's "
                             f"resonance on the series stiffness with the link held "
                             f"({f0:.3g} Hz): allowed {f0:.3g}-"
                             f"{vals['current_loop_bandwidth'] / 3:g} Hz")
    if fb > vals["current_loop_bandwidth"] / 3:
        raise ParameterError(where, "torque_loop_bandwidth", f"{fb:g} Hz is above a third of "
                             f"the current loop's {vals['current_loop_bandwidth']:g} Hz")
    wb = 2 * math.pi * fb
    if 2 * out["torque_loop_damping"] * wb * B < out["series_damping"]:
        raise ParameterError(where, "series_damping", f"{out['series_damping']:g} N m s/rad "
                             "alone damps the torque loop beyond torque_loop_damping "
                             f"{out['torque_loop_damping']:g}: raise that or lower this")
    return out


def actuator_text(a: ActuatorModel, header: str = "") -> str:
    """An actuator file's TOML text (:func:`parse_actuator` reads it back exactly): the
    names, every figure of :data:`FIELDS` at full precision with its unit, and the
    ``[sources]`` table. ``header``: comment lines above."""
    from exoleg.io import toml_string

    out = [f"# {ln}" for ln in header.splitlines()]
    out += [f"{k} = {toml_string(str(getattr(a, k)))}" for k in _NAMES]
    fields = FIELDS
    if a.compliant:
        out.append(f"compliance = {toml_string(a.compliance)}")
        fields = FIELDS + SERIES_FIELDS
    for name, unit, _, _ in fields:
        v = getattr(a, name)
        text = str(int(v)) if name in WHOLE else repr(float(v))
        out.append(f"{name} = {text}" + (f"  # {unit}" if unit else ""))
    out += ["", "[sources]"]
    out += [f"{k} = {toml_string(a.sources.get(k, ''))}" for k, *_ in fields]
    return "\n".join(out) + "\n"


def load_actuator(path: str | Path) -> ActuatorModel:
    """Read an actuator file (format: ``data/device/actuators/hip.toml``).

    Parameters
    ----------
    path : str or Path
        The TOML file: every figure of :data:`FIELDS` within its range, with its source.

    Returns
    -------
    ActuatorModel
        A ParameterError names the key of anything missing, implausible or unsourced.
    """
    text = read_text(path, "actuator file (TOML)")
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ParameterError(str(path), "(syntax)", f"not valid TOML: {e}") from None
    return parse_actuator(data, str(path))


def paper_actuators(folder: str | Path | None = None
                    ) -> tuple[ActuatorModel, ActuatorModel, ActuatorModel]:
    """The three actuation units (hip, knee, ankle).

    Parameters
    ----------
    folder : str or Path, optional
        A device folder (:mod:`exoleg.device.files`): its ``actuators/*.toml`` where it
        has them; default (and for the others) the shipped files.

    Returns
    -------
    tuple of ActuatorModel
        Hip, knee, ankle.
    """
    from exoleg.device.files import load

    out = []
    for j in JOINTS:
        where, data = load(f"actuators/{j}.toml", folder)
        a = parse_actuator(data, where)
        if a.joint != j:
            raise ParameterError(where, "joint", f"is {a.joint!r}; this file is the {j}'s")
        out.append(a)
    return tuple(out)  # type: ignore[return-value]




def hip_variant(name: str) -> ActuatorModel:
    """The hip actuation unit with the motor variant ``name`` (:data:`HIP_VARIANTS`)."""
    from importlib import resources

    if name not in HIP_VARIANTS:
        raise ParameterError("hip variant", name, "unknown (allowed: "
                             + ", ".join(sorted(HIP_VARIANTS)) + ")")
    return load_actuator(str(resources.files("exoleg").joinpath(
        "data", "device", "hip-variants", f"{name}.toml")))


def with_actuators(leg: LegModel, actuators: tuple[ActuatorModel, ...] | None = None,
                   link: bool = False) -> LegModel:
    """``leg`` with each actuator's reflected inertia as its joint's armature.

    Parameters
    ----------
    leg : LegModel
        The child + device leg.
    actuators : tuple of ActuatorModel, optional
        Hip, knee, ankle; default the shipped ones.

    link : bool
        The armature the links themselves carry (:attr:`ActuatorModel.link_inertia`:
        none at a compliant joint, whose rotor is a body of its own -- the walking
        plant's); default what a model of the device should hold, the inertia each link
        feels (:attr:`ActuatorModel.apparent_inertia`: the reflected inertia of a rigid
        unit, K / w_b^2 of a compliant one).

    Returns
    -------
    LegModel
        A new model, the armature on M's diagonal.
    """
    acts = paper_actuators() if actuators is None else actuators
    return leg.with_armature([a.link_inertia if link else a.apparent_inertia for a in acts])


def params_array(actuators: tuple[ActuatorModel, ...]) -> NDArray[np.void]:
    """The three actuators (3,) of :data:`ACTUATOR`, for the compiled loop (``A[i:i + 1]``
    is joint i's record)."""
    if len(actuators) != 3 or [a.joint for a in actuators] != list(JOINTS):
        raise ParameterError("actuators", "joint",
                             "need the hip, knee and ankle actuators, in that order")
    return np.concatenate([a.record() for a in actuators])
