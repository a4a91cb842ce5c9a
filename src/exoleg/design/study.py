"""``exoleg design``: the actuation chosen for a population of children (issue 39).

A design file (``examples/design-population.toml``) names the population (ages, sexes,
groups -- typically developing or a GMFCS level --, height percentiles: each child the
growth charts' mass at the same percentile, :func:`~exoleg.sizing.child.population_child`),
the assistance asked (``alpha``: the share of the child's joint moment the device gives,
per joint), the constraints (bus voltages, the zero-torque goal in N m/kg, the ambient)
and the held-out children walked on the chosen device. Per joint, every catalogue motor
and gear on every bus (:mod:`exoleg.design.catalogue`) is screened with every child
(:mod:`exoleg.design.screen`: the closed forms along the normative gait at the stride
time asked, the unit carrying the device's own links -- fitted to each child -- in every
mode and the share of the child's moment on top while it assists; the friction left to
the walking loop); a candidate serves a child when the drive's current, the bus voltage,
the motor's speed and its winding's steady temperature all hold, and the gear's repeated
peak carries what it delivers. The Pareto set over (children served, the worst
zero-torque residual, the thermal margin) is kept; on the one bus the drives share, the
candidate serving the most children at each joint, then leaving the least residual, is
chosen, and written as a device folder every command takes (``--device DIR``). The
held-out children then walk on it and on the shipped device in the full loop
(:func:`~exoleg.sim.walk.simulate_walk`).
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from exoleg import checks as _check
from exoleg.design import screen as sc
from exoleg.design.catalogue import (
    BUS_RANGE,
    CURRENT_LIMIT,
    candidate,
    catalogue,
    series_options,
)
from exoleg.errors import ParameterError
from exoleg.params.records import JOINTS
from exoleg.reference.gait import SPEED_GROUPS

SEXES = ("female", "male")
#: The ages (y) and growth-chart percentiles a design's children may take
AGES, PERCENTILES = (5.0, 18.0), (1.0, 99.0)
#: The design file's tables and their fields (required, optional).
TABLES = {"population": (["ages", "sexes", "groups", "percentiles"], ["speed", "stride_time"]),
          "assistance": (["alpha"], []),
          "constraints": (["bus_voltage", "transparency_Nm_per_kg"],
                          ["ambient", "torque_loop_hz", "torque_loop_gain_max",
                           "spring_deflection_deg"]),
          "verify": (["held_out"], ["strides", "mass_kg", "strides_transparent",
                                    "strides_assist"])}

#: The most a compliant unit's torque loop may amplify its torque error
#: (:attr:`~exoleg.device.actuator.ActuatorModel.torque_loop_gains`' kp = B w_b^2 / K - 1:
#: the loop asked, w_b, over the rotor's own mode on its spring, sqrt(K / B), squared,
#: less one). A choice, measured in the walking loop on the example's population: at 28
#: (the EC 60 flat through 1:50 on 272 N m/rad, a 30 Hz loop) the units walk; at 73 (1:100
#: on 427 N m/rad) the hip's drive is at its limit in 44 % of a transparent walk's ticks;
#: at 115 (1:100 on 272 N m/rad) a torque error of half a newton metre saturates the motor
#: and the passive leg's walk stops OVERSPEED at the ankle within two strides.
LOOP_GAIN_MAX = 30.0


@dataclass(frozen=True)
class Design:
    """A design file's contents (SI units; groups 0 for typically developing)."""

    ages: tuple[float, ...]
    sexes: tuple[str, ...]
    groups: tuple[int, ...]
    percentiles: tuple[float, ...]
    alpha: tuple[float, float, float]
    buses: tuple[float, ...]
    goal: float
    held_out: tuple[dict[str, Any], ...]
    speed: str = "Free"
    stride_time: float = 1.1
    ambient: float = 25.0
    strides: int = 10
    source: str = ""
    loop_hz: float = 30.0
    loop_gain_max: float = LOOP_GAIN_MAX
    deflection_deg: float = 10.0
    verify_mass: tuple[float, float] = (20.0, 40.0)
    strides_transparent: int = 10
    strides_assist: int = 40

    @classmethod
    def load(cls, path: str | Path) -> Design:
        import tomllib

        from exoleg.io import read_text

        where = str(path)
        try:
            d = tomllib.loads(read_text(path, "design file (TOML)"))
        except tomllib.TOMLDecodeError as e:
            raise ParameterError(where, "(syntax)", f"not valid TOML: {e}") from None
        _check.keys(where, d, list(TABLES), ["description"])
        for name, (req, opt) in TABLES.items():
            _check.keys(f"{where} [{name}]", d[name], req, opt)
        p, a, c, v = (d[k] for k in TABLES)

        def numbers(table: str, key: str, lo: float, hi: float, unit: str,
                    distinct: bool = True) -> tuple[float, ...]:
            raw = d[table][key]
            vals = raw if isinstance(raw, list) else [raw]
            if not vals:
                raise ParameterError(f"{where} [{table}]", key, "needs at least one value")
            out = tuple(_check.within(f"{where} [{table}]", key, x, lo, hi, unit) for x in vals)
            twice = _check.repeated(out)
            if distinct and twice is not None:  # a child or a bus counted twice in each share
                raise ParameterError(f"{where} [{table}]", key, f"lists {twice:g} twice")
            return out

        def one(table: str, key: str, lo: float, hi: float, unit: str,
                default: float) -> float:  # a single number: a list is not one
            t = d[table]
            return default if key not in t else _check.within(f"{where} [{table}]", key,
                                                               t[key], lo, hi, unit)

        def count(table: str, key: str, hi: int, default: int) -> int:
            t = d[table]
            return default if key not in t else _check.whole(f"{where} [{table}]", key,
                                                              t[key], 1, hi)

        sexes = tuple(p["sexes"]) if isinstance(p["sexes"], list) else (p["sexes"],)
        if not sexes or any(s not in SEXES for s in sexes):
            raise ParameterError(f"{where} [population]", "sexes", f"{p['sexes']!r}: "
                                 "allowed female, male")
        if _check.repeated(sexes) is not None:
            raise ParameterError(f"{where} [population]", "sexes", f"{p['sexes']!r}: "
                                 "each at most once")
        groups = numbers("population", "groups", 0, 4, "")
        if any(g != int(g) for g in groups):
            raise ParameterError(f"{where} [population]", "groups", "whole numbers: 0 "
                                 "(typically developing), 1-4 (GMFCS level)")
        speed = p.get("speed", "Free")
        if speed not in SPEED_GROUPS:
            raise ParameterError(f"{where} [population]", "speed", f"{speed!r}: allowed "
                                 f"{', '.join(SPEED_GROUPS)} (Schwartz et al. 2008's groups)")
        if not isinstance(d.get("description", ""), str):
            raise ParameterError(where, "description", f"{d['description']!r}: expected text")
        alpha = numbers("assistance", "alpha", 0.0, 1.0, "", distinct=False)  # per joint
        if len(alpha) != 3:
            raise ParameterError(f"{where} [assistance]", "alpha", "3 shares (hip, knee, "
                                 "ankle), each 0-1")
        held = v["held_out"]
        if not isinstance(held, list) or not held or not all(isinstance(h, dict)
                                                            for h in held):
            raise ParameterError(f"{where} [verify]", "held_out", "a list of children: "
                                 "{age, sex, group, percentile}")
        return cls(ages=numbers("population", "ages", *AGES, "y"), sexes=sexes,
                   groups=tuple(int(g) for g in groups),
                   percentiles=numbers("population", "percentiles", *PERCENTILES, ""),
                   alpha=(alpha[0], alpha[1], alpha[2]),
                   buses=numbers("constraints", "bus_voltage", *BUS_RANGE, "V"),
                   goal=_check.within(f"{where} [constraints]", "transparency_Nm_per_kg",
                                      c["transparency_Nm_per_kg"], 0.001, 1.0, "N m/kg"),
                   held_out=tuple(_held_out(f"{where} [verify] held_out[{i}]", h)
                                  for i, h in enumerate(held)),
                   speed=speed, stride_time=one("population", "stride_time", 0.6, 2.0, "s",
                                                1.1),
                   ambient=one("constraints", "ambient", -20.0, 60.0, "degC", 25.0),
                   strides=count("verify", "strides", 100, 10), source=where,
                   loop_hz=one("constraints", "torque_loop_hz", 1.0, 1000.0, "Hz", 30.0),
                   loop_gain_max=one("constraints", "torque_loop_gain_max", 1.0, 1000.0, "",
                                     LOOP_GAIN_MAX),
                   deflection_deg=one("constraints", "spring_deflection_deg", 0.5, 45.0,
                                      "deg", 10.0),
                   verify_mass=_mass_window(where, v),
                   strides_transparent=count("verify", "strides_transparent", 200, 10),
                   strides_assist=count("verify", "strides_assist", 200, 40))

    def children(self) -> list[Any]:
        """The population, each child from the growth charts."""
        from exoleg.sizing.child import population_child

        return [population_child(g or None, s, a, p)[0] for g in self.groups
                for s in self.sexes for a in self.ages for p in self.percentiles]


#: Springs tried per candidate: stiffnesses spaced evenly on a log scale over the range a
#: spring may take (the catalogue's, above what carries the peak within the deflection).
SPRING_STEPS = 8
#: Harmonics of a joint moment kept in its second derivative (a walking moment's content
#: lies within its first ten: below 9 Hz at a 1.1 s stride; the digitised curves' higher
#: harmonics are their 2 % sampling's, which differentiating twice would amplify).
MOMENT_HARMONICS = 10


def _held_out(where: str, h: dict[str, Any]) -> dict[str, Any]:
    """A held-out child of [verify] held_out, each field checked as the population's."""
    _check.keys(where, h, ["age", "sex", "group", "percentile"])
    if h["sex"] not in SEXES:
        raise ParameterError(where, "sex", f"{h['sex']!r}: allowed female, male")
    return {"age": _check.within(where, "age", h["age"], *AGES, "y"), "sex": h["sex"],
            "group": _check.whole(where, "group", h["group"], 0, 4),
            "percentile": _check.within(where, "percentile", h["percentile"], *PERCENTILES)}


def _mass_window(where: str, v: dict[str, Any]) -> tuple[float, float]:
    """[verify] mass_kg: the verification set's masses, [lowest, highest] kg."""
    raw = v.get("mass_kg", [20.0, 40.0])
    if not (isinstance(raw, list) and len(raw) == 2):
        raise ParameterError(f"{where} [verify]", "mass_kg", f"{raw!r}: expected [lowest, "
                             "highest] kg, e.g. [20, 40]")
    lo, hi = (_check.within(f"{where} [verify]", "mass_kg", x, 10.0, 120.0, "kg") for x in raw)
    if lo >= hi:
        raise ParameterError(f"{where} [verify]", "mass_kg", f"{lo:g} is not below {hi:g}")
    return lo, hi


def _series(design: Design, parts: tuple[Any, Any, float], B: float, gear: Any,
            peak: float) -> list[tuple[Any, float, str]]:
    """A candidate's series elements: (element or None for rigid, stiffness N m/rad, why
    it cannot serve -- '' when it can). Springs of :data:`SPRING_STEPS` stiffnesses from
    the softest that carries the ``peak`` asked (N m) within the design's deflection to
    the catalogue's stiffest; the torque sensor on the gear's own stiffness. The torque
    loop must be above the rotor's resonance on that stiffness with the link held
    (sqrt(K / B), B the reflected inertia), ask a gain B w_b^2 / K - 1 of at most the
    design's ``torque_loop_gain_max`` (:data:`LOOP_GAIN_MAX`), and be at most a third of
    the current loop's bandwidth. ``parts``: (the spring, the torque sensor, the joint's
    current loop bandwidth, Hz)."""
    spring, sensor, inner = parts
    wb = 2.0 * math.pi * design.loop_hz
    lo = max(spring.figures["stiffness_min"], peak / math.radians(design.deflection_deg))
    hi = spring.figures["stiffness_max"]
    springs = [float(k) for k in np.geomspace(lo, hi, SPRING_STEPS)] if lo <= hi else [lo]
    out: list[tuple[Any, float, str]] = [(None, 0.0, "")]
    for part, K in [(spring, k) for k in springs] + [(sensor, gear.figures["gear_stiffness"])]:
        why = ""
        if part is spring and K > hi:
            why = (f"a spring of {K:.0f} N m/rad (the peak within "
                   f"{design.deflection_deg:g} deg) is stiffer than the catalogue's {hi:g}")
        elif K > B * wb * wb:
            why = (f"the rotor resonates at {math.sqrt(K / B) / (2 * math.pi):.1f} Hz on "
                   f"{K:.0f} N m/rad, above the {design.loop_hz:g} Hz torque loop")
        elif B * wb * wb / K - 1.0 > design.loop_gain_max:
            why = (f"the {design.loop_hz:g} Hz torque loop on the rotor's "
                   f"{math.sqrt(K / B) / (2 * math.pi):.1f} Hz on {K:.0f} N m/rad needs a "
                   f"gain of {B * wb * wb / K - 1.0:.0f}, above {design.loop_gain_max:g}")
        elif design.loop_hz > inner / 3:
            why = f"the torque loop is above a third of the current loop's {inner:g} Hz"
        out.append((part, float(K), why))
    return out


def screen_joint(design: Design, joint: int, masses: np.ndarray,
                 carried: np.ndarray | None = None) -> list[dict[str, Any]]:
    """Every catalogue candidate at ``joint`` with every child of ``masses``: one row per
    candidate (motor, gear, series element, bus) with the share of children it serves and
    its worst figures over them. ``carried`` (C, S) N m: what the device's own links ask
    of the joint along the gait, child by child
    (:func:`~exoleg.design.screen.carried_torque`; None: not counted)."""
    from exoleg.device.actuator import paper_actuators

    motors, gears = catalogue()
    tau, qd, qdd = sc.population_gait(masses, joint, design.stride_time, design.speed)

    def dd(x: np.ndarray) -> np.ndarray:
        return sc.periodic_second_derivative(x, design.stride_time, MOMENT_HARMONICS)

    tau_dd = dd(tau)
    own = None if carried is None else (carried, dd(carried))
    assisting = design.alpha[joint] * tau + (0.0 if carried is None else carried)
    peak = float(max(np.max(np.abs(assisting)),
                     0.0 if carried is None else np.max(np.abs(carried))))
    opts = series_options()  # read once per joint, not per candidate
    parts = (opts["series_spring"], opts["torque_sensor"],
             paper_actuators()[joint].current_loop_bandwidth)
    rows = []
    for m, g, bus in itertools.product(motors, gears, design.buses):
        f = m.figures
        B = (f["rotor_inertia"] + g.figures["gear_input_inertia"]) * g.figures["ratio"] ** 2
        for part, K, why in _series(design, parts, B, g, peak):
            r = sc.screen({"kt": f["torque_constant"], "rotor_inertia": f["rotor_inertia"],
                           "r25": f["terminal_resistance"],
                           "r_th": f["thermal_resistance_winding"]
                           + f["thermal_resistance_housing"],
                           "max_speed": f["max_speed_rpm"] * math.pi / 30,
                           "max_winding_temperature": f["max_winding_temperature"]},
                          g.figures["ratio"], g.figures["efficiency"],
                          g.figures["gear_input_inertia"], tau, qd, qdd, design.alpha[joint],
                          masses, bus, CURRENT_LIMIT * f["nominal_current"], design.ambient,
                          None if part is None else sc.loop_inertia(K, design.loop_hz),
                          None if part is None else (K, tau_dd), own)
            transparent = r["residual_per_kg"] <= design.goal
            serves = (r["fits"] & (r["gear_torque_peak"] <= g.figures["repeated_peak_torque"])
                      & (why == ""))
            rows.append({"joint": JOINTS[joint], "motor": m.name, "gear": g.name,
                         "ratio": g.figures["ratio"], "bus_V": bus,
                         "series": "rigid" if part is None else part.kind,
                         "stiffness_Nm_per_rad": K, "why_not": why,
                         "reflected_inertia_kg_m2": B,
                         "served": float(np.mean(serves)),
                         "transparent": float(np.mean(transparent & serves)),
                         "residual_worst_Nm_per_kg": float(np.max(r["residual_per_kg"])),
                         "winding_worst_C": float(np.max(r["winding"])),
                         "thermal_margin_K": float(f["max_winding_temperature"]
                                                   - np.max(r["winding"])),
                         "current_peak_A": float(np.max(r["current_peak"])),
                         "voltage_peak_V": float(np.max(r["voltage_peak"])),
                         "motor_speed_peak_rpm": float(np.max(r["motor_speed_peak"])
                                                       * 30 / math.pi),
                         "gear_torque_peak_Nm": float(np.max(r["gear_torque_peak"])),
                         "_parts": (m, g, None if part is None else
                                    (part, K, design.loop_hz))})
    _pareto(rows)
    return rows


def _rank(r: dict[str, Any]) -> tuple[float, float, float, float]:
    """A candidate's merit, larger better: children served, then the least worst
    residual, then the lightest rotor (reflected inertia), then the largest thermal
    margin. The rotor before the heat: behind a spring the residual no longer depends on
    it, but the motor still drags it through the walk's own accelerations, which the
    normative gait's understate -- the hip's EC 60 flat at 1:100 (0.91 kg m^2) behind a
    272 N m/rad spring saturated its motor in 66 % of a transparent walk's ticks and left
    0.55 / 0.25 / 0.19 N m/kg at hip / knee / ankle; at 1:50 (0.22 kg m^2), 31 % and
    0.29 / 0.14 / 0.09 (measured, a 10-year-old girl)."""
    return (r["served"], -r["residual_worst_Nm_per_kg"], -r["reflected_inertia_kg_m2"],
            r["thermal_margin_K"])


def _pareto(rows: list[dict[str, Any]]) -> None:
    """Mark each row on the Pareto front of :func:`_rank`'s figures."""
    for r in rows:
        k = _rank(r)
        r["pareto"] = not any(all(a >= b for a, b in zip(_rank(o), k, strict=True))
                              and _rank(o) != k for o in rows)


def verify(design: Design, device: Path | None) -> list[dict[str, Any]]:
    """The held-out children walked ``design.strides`` strides as actors
    (:class:`~exoleg.child.model.ChildModel`) in assist-as-needed -- the mode the device is
    chosen for: it gives a share of their moments, not all of a passive leg's -- on
    ``device`` (None: the shipped one, its own assistance): fault, tracking, the foot's
    touches of the belt in swing and the windings."""
    from exoleg.child.model import ChildModel
    from exoleg.sim.walk import simulate_walk
    from exoleg.sizing import personalized_leg
    from exoleg.sizing.child import population_child
    from exoleg.tick import Fault, SupportMode

    out = []
    for h in design.held_out:
        c, _ = population_child(h["group"] or None, h["sex"], h["age"], h["percentile"])
        r = simulate_walk(personalized_leg(c), c.mass, strides=design.strides,
                          stride_time=design.stride_time, device=device,
                          child=ChildModel.of(c), support_mode=SupportMode.AAN)
        walking = r.t >= r.walk_start
        faults = sorted({Fault(int(f)).name for f in r.fault[r.fault != 0]})
        err = np.degrees(np.sqrt(np.mean((r.q - r.q_ref)[walking] ** 2, axis=0)))
        out.append({"device": "designed" if device is not None else "shipped",
                    "age": c.age, "sex": c.sex, "group": h["group"],
                    "percentile": h["percentile"], "mass_kg": c.mass,
                    "fault": ", ".join(faults), "walked": not faults,
                    "swing_touches": len(r.swing_touches()),
                    **{f"tracking_rms_deg_{j}": float(err[i]) for i, j in enumerate(JOINTS)},
                    **{f"winding_max_C_{j}": float(np.max(r.winding_temp[:, i]))
                       for i, j in enumerate(JOINTS)}})
    return out


def carried_demand(design: Design, masses: np.ndarray, carried: np.ndarray
                   ) -> list[dict[str, Any]]:
    """Per joint, what the units carry along the gait, worst over the children (N m): the
    share of the child's moment asked (``alpha tau``), the device's own links
    (``carried``, (C, 3, S)) and the two together while assisting -- each its peak and
    RMS."""
    out = []
    for j, joint in enumerate(JOINTS):
        tau = design.alpha[j] * sc.population_gait(masses, j, design.stride_time,
                                                   design.speed)[0]
        both = tau + carried[:, j]
        out.append({"joint": joint, **{
            f"{name}_{kind}_Nm": float(np.max(f(x)))
            for name, x in (("child_share", tau), ("links", carried[:, j]),
                            ("together", both))
            for kind, f in (("peak", lambda a: np.max(np.abs(a), axis=-1)),
                            ("rms", sc.rms))}})
    return out


def run_design(design: Design) -> dict[str, Any]:
    """Screen and choose: the rows, the chosen unit per joint and its actuator file's
    text (the CLI writes them, and verifies the choice)."""
    from exoleg.child.interaction import device_links
    from exoleg.device.actuator import actuator_text
    from exoleg.sizing import personalized_leg

    children = design.children()
    masses = np.array([c.mass for c in children])
    carried = sc.carried_torque([device_links(personalized_leg(c)) for c in children],
                                design.stride_time, design.speed)
    rows = [r for j in range(3) for r in screen_joint(design, j, masses, carried[:, j])]
    # one bus for the device (its drives share it): the bus whose best candidates serve
    # the most children at the joint that serves fewest, then the lower voltage
    best: dict[float, dict[str, dict[str, Any]]] = {}
    for bus in design.buses:
        for j in JOINTS:
            at = [r for r in rows if r["joint"] == j and r["bus_V"] == bus]
            best.setdefault(bus, {})[j] = max(at, key=_rank)
    bus = max(design.buses, key=lambda b: (min(r["served"] for r in best[b].values()), -b))
    chosen = best[bus]
    for r in rows:
        r["chosen"] = any(r is c for c in chosen.values())
    units = {}
    for j in JOINTS:
        m, g, series = chosen[j]["_parts"]
        units[j] = candidate(j, m, g, chosen[j]["bus_V"], series)
    return {"rows": rows, "chosen": chosen, "units": units, "children": len(children),
            "demand": carried_demand(design, masses, carried),
            "text": {j: actuator_text(a, f"exoleg design ({design.source}): the {j}'s unit "
                                         "chosen for the population") for j, a in units.items()}}
