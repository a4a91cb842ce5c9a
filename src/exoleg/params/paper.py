"""Loaders for the paper's tables shipped in ``exoleg/data/paper`` (one TOML file per table).

Each loader validates its file and raises :class:`~exoleg.errors.ParameterError`
naming the file, the field and what is allowed. Values come back in SI units
and radians; the files state their units once.
"""

from __future__ import annotations

import math
import tomllib
from functools import cache
from importlib import resources
from typing import Any, Literal

import numpy as np

from exoleg import checks as _check
from exoleg.errors import ParameterError
from exoleg.inertia import RigidBody, remainder
from exoleg.params.records import JOINTS, LINKS, Actuator, Gains, Link, RangeOfMotion

Variant = Literal["simplified", "detailed"]


@cache
def _raw(name: str) -> tuple[str, dict[str, Any]]:
    where = f"exoleg/data/paper/{name}"
    text = resources.files("exoleg").joinpath("data", "paper", name).read_text()
    try:
        return where, tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ParameterError(where, "(syntax)", str(e)) from None


def _table(where: str, data: dict[str, Any], key: str) -> dict[str, Any]:
    t = data.get(key)
    if not isinstance(t, dict):
        raise ParameterError(where, key, "missing table")
    return t


def device() -> dict[str, Any]:
    """The device's adjustment data (``data/paper/device.toml``: telescope ranges,
    footplate length and thickness, tube density), SI units."""
    return _raw("device.toml")[1]


def dh_offsets() -> tuple[float, float, float]:
    """D-H joint angle offsets (rad), paper Table 3."""
    where, d = _raw("dh.toml")
    _check.keys(where, d, ["source", "joints", "links", "offset"])
    o = _check.vector(where, "offset", d["offset"], 3)
    return float(o[0]), float(o[1]), float(o[2])


def _columns(variant: Variant) -> dict[str, Any]:
    where, d = _raw("table5.toml")
    _check.keys(where, d, ["source", "detailed", "simplified"], ["errata"])
    if variant not in ("simplified", "detailed"):
        raise ParameterError(where, "variant",
                             f"unknown {variant!r} (allowed: simplified, detailed)")
    col = dict(_table(where, d, variant))
    col.update(d.get("errata", {}).get(variant, {}))
    w = f"{where} [{variant}]"
    _check.keys(w, col, ["mass", "length", "izz", "lc"])
    out: dict[str, Any] = {
        "mass": _check.vector(w, "mass", col["mass"], 3),
        "length": _check.vector(w, "length", col["length"], 3),
        "izz": _check.vector(w, "izz", col["izz"], 3),
        "lc": np.array([_check.vector(w, f"lc[{i}]", r, 3) for i, r in enumerate(col["lc"])]),
    }
    for i in range(3):
        _check.positive(w, f"mass[{i}]", out["mass"][i], "kg")
        _check.positive(w, f"length[{i}]", out["length"][i], "m")
        _check.positive(w, f"izz[{i}]", out["izz"][i], "kg m^2")
    return out


def table5_links(variant: Variant = "simplified") -> tuple[Link, Link, Link]:
    """The three lumped links of Table 5 (``"simplified"`` or ``"detailed"`` column).

    The COM is converted from the table's offset from the link mid-point to the
    position from the proximal joint: ``(a/2 + lcx, lcy)``.
    """
    col = _columns(variant)
    return tuple(  # type: ignore[return-value]
        Link(mass=col["mass"][i], length=col["length"][i],
             com=(col["length"][i] / 2 + col["lc"][i][0], col["lc"][i][1]),
             izz=col["izz"][i], name=LINKS[i])
        for i in range(3)
    )


def table4() -> dict[str, dict[str, np.ndarray]]:
    """Table 4: ``{"human": {"mass", "length"}, "sle": {...}}``, kg and m."""
    where, d = _raw("table4.toml")
    _check.keys(where, d, ["source", "human", "sle"])
    out = {}
    for part in ("human", "sle"):
        t = _table(where, d, part)
        w = f"{where} [{part}]"
        _check.keys(w, t, ["mass", "length"])
        out[part] = {k: _check.vector(w, k, t[k], 3) for k in ("mass", "length")}
        for i in range(3):
            _check.positive(w, f"mass[{i}]", out[part]["mass"][i], "kg")
    return out


def detailed_links() -> tuple[Link, Link, Link]:
    """The detailed model: each link a human body and an SLE body welded together.

    Human masses are Table 4's; their COM and inertia follow ``detailed_split.toml``
    (the paper does not print them); the SLE body is the remainder, so each
    link composes to Table 5's detailed column.
    """
    where, d = _raw("detailed_split.toml")
    _check.keys(where, d, ["source", "human"])
    h = _table(where, d, "human")
    _check.keys(f"{where} [human]", h, ["com", "radius_of_gyration"])
    m_h = table4()["human"]["mass"]
    links = []
    for i, total in enumerate(table5_links("detailed")):
        com = _check.vector(where, f"human.com[{i}]", h["com"][i], 2)
        human = RigidBody.from_radius_of_gyration(
            float(m_h[i]), (float(com[0]), float(com[1])), h["radius_of_gyration"][i],
            name=f"{LINKS[i]}_human")
        sle = remainder(total.body, human, name=f"{LINKS[i]}_sle")
        links.append(Link.from_parts(total.length, (human, sle), name=total.name))
    return tuple(links)  # type: ignore[return-value]


def actuators() -> tuple[Actuator, Actuator, Actuator]:
    """Table 2: the hip, knee and ankle actuation units (velocity in rad/s)."""
    where, d = _raw("table2_actuators.toml")
    _check.keys(where, d, ["source", *JOINTS])
    out = []
    for j in JOINTS:
        t = _table(where, d, j)
        w = f"{where} [{j}]"
        _check.keys(w, t, ["mass", "power", "gear_ratio", "max_torque", "max_velocity_deg_s",
                           "motor", "gear"])
        out.append(Actuator(joint=j, mass=t["mass"], power=t["power"], gear_ratio=t["gear_ratio"],
                            max_torque=t["max_torque"],
                            max_velocity=math.radians(_check.finite(w, "max_velocity_deg_s",
                                                                    t["max_velocity_deg_s"])),
                            motor=t["motor"], gear=t["gear"]))
    return tuple(out)  # type: ignore[return-value]


def range_of_motion() -> RangeOfMotion:
    """Section 2.1 range of motion in exoleg's signs (hip reading swapped, see the file)."""
    where, d = _raw("range_of_motion.toml")
    _check.keys(where, d, ["source", "lower_deg", "upper_deg"])
    return RangeOfMotion(lower=np.radians(_check.vector(where, "lower_deg", d["lower_deg"], 3)),
                         upper=np.radians(_check.vector(where, "upper_deg", d["upper_deg"], 3)))


def controller_gains() -> Gains:
    """The paper's PD gains (Fig. 12) and control rate."""
    where, d = _raw("controller.toml")
    _check.keys(where, d, ["source", "kp", "kd", "rate_hz", "g"])
    return Gains(kp=_check.vector(where, "kp", d["kp"], 3),
                 kd=_check.vector(where, "kd", d["kd"], 3), rate_hz=d["rate_hz"])


def gravity() -> float:
    """g used by the paper (Appendix B), m/s^2."""
    where, d = _raw("controller.toml")
    return _check.positive(where, "g", d.get("g"), "m/s^2")


def sizing() -> dict[str, Any]:
    """Table 1 and the device's adjustment ranges, as printed (cm where the keys say so)."""
    where, d = _raw("table1_sizing.toml")
    _check.keys(where, d, ["source", "cp_min", "cp_max", "td_min", "td_max", "device",
                           "demand_per_kg"])
    return d
