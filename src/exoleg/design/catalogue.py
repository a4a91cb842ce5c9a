"""The parts ``exoleg design`` chooses from, as data, each figure with its source.

The catalogue is read from the actuation units the package ships
(``data/device/actuators/*.toml`` and ``data/device/hip-variants/*.toml``): each unit's
motor (the motor's figures, :data:`MOTOR`) and gear (:data:`GEAR`) are parts, with the
sources those files give figure by figure; and from the motors no unit carries
(``data/design/motors.toml``: the EC 45 flat 70 W, maxon's 2019 sheet). A motor whose
defining figures -- torque constant, rotor inertia, nominal current, terminal
resistance -- come from no datasheet (a "choice" or an unverified derivation) is left
out: the hip variant "260 W class" is not in the catalogue. A candidate joint is the
shipped unit of that joint with a catalogue motor and gear in place (its drive, encoder
and friction kept), its drive's current limit set at 2 x the motor's nominal current as
maxon configures it (S3), on a chosen bus voltage (the EPOS4 50/15 takes 10-50 V: its
sheet).

Between the gear and the link a candidate may carry a series element
(``data/design/series.toml``, :func:`series_options`): a torsion spring the design sizes
within the stiffness range published springs span, its deflection read by absolute
encoders, or the gear's own stiffness read by a joint torque sensor; either closes the
drive's torque loop on the measured torque (:mod:`exoleg.device.actuator`).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from importlib import resources
from typing import Any

from exoleg import checks as _check
from exoleg.device.actuator import FIELDS, ActuatorModel, figure, load_actuator, paper_actuators
from exoleg.errors import ParameterError

_NAMES = [f[0] for f in FIELDS]
#: The figures of an actuation unit that are its motor's, and its gear's.
MOTOR = tuple(_NAMES[:_NAMES.index("ratio")])
GEAR = tuple(_NAMES[_NAMES.index("ratio"):_NAMES.index("continuous_current")])
#: A motor's figures that must come from a sheet for it to be in the catalogue.
DEFINING = ("torque_constant", "rotor_inertia", "nominal_current", "terminal_resistance")
#: The drive's current limit, x the motor's nominal current, as maxon configures it (S3).
CURRENT_LIMIT = 2.0
#: The bus voltages the drive (maxon EPOS4 50/15) takes, V: its supply range.
BUS_RANGE = (10.0, 50.0)


@dataclass(frozen=True)
class Part:
    """A catalogue motor or gear: its name, figures (as :data:`FIELDS`) and sources."""

    kind: str                   # "motor" or "gear"
    name: str
    figures: dict[str, float]
    sources: dict[str, str]


def _sheet(source: str) -> bool:
    s = source.strip().lower()
    return not (s.startswith("choice") or "unverified" in s)


def _motors_file() -> list[Part]:
    """The catalogue's own motors (``data/design/motors.toml``), each figure checked as
    an actuator file's and sourced."""
    import tomllib

    where = "data/design/motors.toml"
    text = (resources.files("exoleg") / "data" / "design" / "motors.toml").read_text()
    rows = {f[0]: f for f in FIELDS}
    out = []
    for key, d in tomllib.loads(text).items():
        w = f"{where} [{key}]"
        _check.keys(w, d, ["name", *MOTOR, "sources"])
        _check.keys(f"{w} sources", d["sources"], MOTOR)
        out.append(Part("motor", str(d["name"]),
                        {k: float(figure(w, rows[k], d[k])) for k in MOTOR},
                        {k: str(d["sources"][k]) for k in MOTOR}))
    return out


def catalogue() -> tuple[tuple[Part, ...], tuple[Part, ...]]:
    """(motors, gears): the shipped actuation units' and the catalogue's own motors
    (``data/design/motors.toml``), each once, sources kept."""
    root = resources.files("exoleg") / "data" / "device"
    units = list(paper_actuators())
    for f in sorted((root / "hip-variants").iterdir(), key=lambda p: p.name):
        if f.name.endswith(".toml"):
            units.append(load_actuator(str(f)))
    motors: dict[str, Part] = {}
    gears: dict[str, Part] = {}
    for a in units:
        m = Part("motor", a.motor, {k: float(getattr(a, k)) for k in MOTOR},
                 {k: a.sources.get(k, "") for k in MOTOR})
        if all(_sheet(m.sources[k]) for k in DEFINING):
            motors.setdefault(a.motor, m)
        gears.setdefault(a.gear, Part("gear", a.gear, {k: float(getattr(a, k)) for k in GEAR},
                                      {k: a.sources.get(k, "") for k in GEAR}))
    for m in _motors_file():
        if all(_sheet(m.sources[k]) for k in DEFINING):
            motors.setdefault(m.name, m)
    return tuple(motors.values()), tuple(gears.values())


def series_options() -> dict[str, Part]:
    """The series elements (``data/design/series.toml``): ``series_spring`` and
    ``torque_sensor``, their figures and sources."""
    import tomllib

    text = (resources.files("exoleg") / "data" / "design" / "series.toml").read_text()
    data = tomllib.loads(text)
    return {kind: Part(kind, kind.replace("_", " "),
                       {k: float(v) for k, v in d.items() if k != "sources"},
                       dict(d["sources"])) for kind, d in data.items()}


def candidate(joint: str, motor: Part, gear: Part, bus_voltage: float,
              series: tuple[Part, float, float] | None = None) -> ActuatorModel:
    """The shipped ``joint`` unit with ``motor`` and ``gear`` in place, its drive's
    current limit at 2 x the motor's nominal current, on ``bus_voltage`` V; with
    ``series`` = (the element, its stiffness N m/rad, the torque loop's frequency Hz), a
    compliant unit of that element."""
    if not BUS_RANGE[0] <= bus_voltage <= BUS_RANGE[1]:
        raise ParameterError("exoleg design", "bus_voltage", f"{bus_voltage:g} V is outside "
                             f"the drive's {BUS_RANGE[0]:g}-{BUS_RANGE[1]:g} V")
    base = {a.joint: a for a in paper_actuators()}[joint]
    figures: dict[str, Any] = {**motor.figures, **gear.figures}
    figures["pole_pairs"] = int(round(figures["pole_pairs"]))
    peak = CURRENT_LIMIT * motor.figures["nominal_current"]
    sources = {**base.sources, **motor.sources, **gear.sources,
               "peak_current": "S3 (maxon's own configuration sets 2 x I_N)",
               "bus_voltage": "exoleg design: the bus chosen (the EPOS4 50/15: 10-50 V)"}
    if series is not None:
        part, stiffness, loop_hz = series
        figures.update(compliance=part.kind, series_stiffness=float(stiffness),
                       series_damping=part.figures["damping"],
                       torque_loop_bandwidth=float(loop_hz),
                       torque_loop_damping=part.figures["torque_loop_damping"],
                       deflection_bits=int(part.figures["deflection_bits"]))
        sized = ("exoleg design: the softest spring within the range "
                 f"({part.sources['stiffness_min']}; {part.sources['stiffness_max']}) that "
                 "carries the peak asked within the design's deflection"
                 if part.kind == "series_spring" else
                 f"the gear's torsional stiffness ({gear.sources.get('gear_stiffness', '')})")
        sources.update(series_stiffness=sized, series_damping=part.sources["damping"],
                       torque_loop_bandwidth="exoleg design: the design file's torque loop",
                       torque_loop_damping=part.sources["torque_loop_damping"],
                       deflection_bits=part.sources["deflection_bits"])
    return dataclasses.replace(base, motor=motor.name, gear=gear.name, peak_current=peak,
                               bus_voltage=float(bus_voltage), sources=sources, **figures)
