"""Leg parameter files: read and write a :class:`~exoleg.LegModel` as TOML.

Format (SI units throughout; comments allowed)::

    g = 9.81                      # m/s^2
    name = "my leg"               # optional
    armature = [0.0, 0.0, 0.0]    # optional: reflected actuator inertia per joint, kg m^2

    [[link]]                      # thigh, then shank, then foot
    name = "thigh"
    length = 0.3011               # m, joint to joint
    mass = 2.2625                 # kg          } either these three ...
    com = [0.1044, 0.00016]       # m, link frame, from the proximal joint
    izz = 0.01802                 # kg m^2 about the COM

    [[link.part]]                 # ... or welded parts (composed by the SMS method)
    name = "human"
    mass = 1.99
    com = [0.13, 0.0]
    izz = 0.019

A link gives either ``mass``/``com``/``izz`` or at least one ``part``, not both.

An optional ``[fit]`` table records how the leg was made for a child (``exoleg fit``)::

    [fit]
    fits = false                  # the device does not fit this child
    note = "upper telescope (hip-knee): child 41.2 cm, allowed 27.0-40.0 cm"
    height_m = 1.52               # the child it was fitted for (optional)
    mass_kg = 41.0

Values must be plausible for a child's leg with the device on it (:data:`PLAUSIBLE`):
a file with a 1e300 kg thigh or a centre of mass metres off its link is refused.
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

from exoleg import checks as _check
from exoleg.errors import ParameterError
from exoleg.inertia import RigidBody, compose
from exoleg.io import read_text, toml_string
from exoleg.params.records import LINKS, Link, com_offset

#: What a leg file may hold, SI units. A link of a child's leg with the device on it:
#: the heaviest is the thigh of a 97th-percentile 12-year-old (about 60 kg body mass,
#: Brooks 2011 / WHO 2007) -- 0.1 of body mass (Jensen 1986-89 fractions) plus the SLE's
#: share of 5.2 kg (paper section 2.1), under 10 kg; 25 kg leaves room for adult legs.
#: Lengths: the device's links are 0.235-0.46 m (Table 1); 0.03-1.2 m spans any leg.
#: The COM lies on or near its link: at most one link length from the segment between
#: the joints. Izz about the COM is at most m a^2 (a thin rod about its centre is m a^2/12,
#: a disc of radius a m a^2/2). g: 0 (no gravity) to 30 m/s^2.
#: Armature: a rotor of at most 1e-3 kg m^2 (the largest flat motors) through 200:1 is 40.
PLAUSIBLE = {"mass_kg": (0.0, 25.0), "length_m": (0.03, 1.2), "g": (0.0, 30.0),
             "armature_kg_m2": (0.0, 40.0)}
#: How far off its link's axis a COM may lie, as a share of the link's length: a
#: segment's mass lies within it, and no leg segment is wider than half its length (a
#: thigh of 50 cm girth -- an obese adolescent's -- has a radius of 8 cm on its 35 cm;
#: the shipped legs' largest offset is the foot's 3 cm on 23.5 cm, 0.13).
AXIS_SHARE = 0.5

_LINK_KEYS = ("name", "length", "mass", "com", "izz", "part")
_PART_KEYS = ("name", "mass", "com", "izz")


def _body(where: str, t: dict[str, Any], name: str) -> RigidBody:
    c = _check.vector(where, "com", t["com"], 2)
    return RigidBody(mass=_check.positive(where, "mass", t["mass"], "kg"),
                     com=(float(c[0]), float(c[1])),
                     izz=_check.positive(where, "izz", t["izz"], "kg m^2"), name=name)


def parse_leg(data: dict[str, Any], where: str) -> tuple[list[Link], float, str]:
    """Links, g and name from a parsed leg file (``where`` names it in errors)."""
    if isinstance(data, dict) and "child" in data and "link" not in data:
        raise ParameterError(where, "(file)", "a child file (exoleg fit's child.toml), not "
                             "a leg file: the leg is fit's leg.toml (a child file goes with "
                             "--child)")
    _check.keys(where, data, ["link"], ["g", "name", "fit", "armature"])
    g = _check.finite(where, "g", data.get("g", 9.81))
    lo, hi = PLAUSIBLE["g"]
    if not lo <= g <= hi:
        raise ParameterError(where, "g", f"{g} m/s^2 is not plausible (allowed {lo:g}-{hi:g})")
    name = data.get("name", Path(where).stem)
    if not isinstance(name, str):
        raise ParameterError(where, "name", f"expected a string, got {name!r}")
    raw = data["link"]
    if not isinstance(raw, list) or len(raw) != 3:
        n = len(raw) if isinstance(raw, list) else "not a list"
        raise ParameterError(where, "link", f"need exactly 3 [[link]] tables (thigh, shank, foot), "
                                            f"got {n}")
    links = []
    for i, t in enumerate(raw):
        w = f"{where} link[{i}]"
        if not isinstance(t, dict):
            raise ParameterError(where, f"link[{i}]", "must be a table")
        lname = str(t.get("name", LINKS[i]))
        if "part" in t:
            _check.keys(w, t, ["length", "part"], ["name"])
            parts = []
            length = _check.positive(w, "length", t["length"], "m")
            if not isinstance(t["part"], list):
                raise ParameterError(w, "part", f"expected [[link.part]] tables (each with "
                                     f"mass, com, izz), got {type(t['part']).__name__} "
                                     f"{str(t['part'])[:40]!r}")
            for j, pt in enumerate(t["part"]):
                wp = f"{w} part[{j}]"
                _check.keys(wp, pt, ["mass", "com", "izz"], ["name"])
                b = _body(wp, pt, str(pt.get("name", f"part{j}")))
                _plausible(wp, b.mass, length, b.com, b.izz)
                parts.append(b)
            if not parts:
                raise ParameterError(w, "part", "needs at least one part")
            c = compose(parts)
            _plausible(w, c.mass, length, c.com, c.izz)
            links.append(Link.from_parts(length, parts, name=lname))
        else:
            _check.keys(w, t, ["length", "mass", "com", "izz"], ["name"])
            b = _body(w, t, lname)
            length = _check.positive(w, "length", t["length"], "m")
            # the file's bounds (a child's leg with the device) before the record's own
            # (any leg), so that the error names the file
            _plausible(w, b.mass, length, b.com, b.izz)
            links.append(Link(mass=b.mass, length=length, com=b.com, izz=b.izz, name=lname))
    return links, g, name


def _plausible(where: str, mass: float, length: float, com: tuple[float, float],
               izz: float) -> None:
    """Refuse values no child's leg with the device on it can have (:data:`PLAUSIBLE`)."""
    lo, hi = PLAUSIBLE["mass_kg"]
    if not lo < mass <= hi:
        raise ParameterError(where, "mass", f"{mass:g} kg is not plausible for a link "
                                            f"(allowed {lo:g}-{hi:g} kg)")
    lo, hi = PLAUSIBLE["length_m"]
    if not lo <= length <= hi:
        raise ParameterError(where, "length", f"{length:g} m is not plausible for a link "
                                              f"(allowed {lo:g}-{hi:g} m)")
    x, y = com
    off = com_offset(com, length)
    if off > length:
        raise ParameterError(where, "com", f"({x:g}, {y:g}) m is {off:.3g} m from its "
                                           f"{length:g} m link; allowed at most one link length")
    if abs(y) > AXIS_SHARE * length:
        raise ParameterError(where, "com", f"({x:g}, {y:g}) m lies {abs(y):.3g} m off the "
                                           f"{length:g} m link's axis; allowed at most "
                                           f"{AXIS_SHARE:g} of its length "
                                           f"({AXIS_SHARE * length:.3g} m): a segment's mass "
                                           "lies within it")
    if izz > mass * length * length:
        raise ParameterError(where, "izz", f"{izz:g} kg m^2 is more than m a^2 = "
                                           f"{mass * length * length:.3g} kg m^2 (allowed 0 to "
                                           "m a^2 about the COM)")


def parse_fit(data: dict[str, Any], where: str) -> dict[str, Any]:
    """The optional ``[fit]`` table: ``{"fits": bool, "note": str}`` with the fitted
    child's ``height_m`` and ``mass_kg`` when it gives them, or {}."""
    fit = data.get("fit")
    if fit is None:
        return {}
    if not isinstance(fit, dict):
        raise ParameterError(where, "fit", "must be a table: [fit] fits = true/false, note = '...'")
    _check.keys(f"{where} [fit]", fit, ["fits"], ["note", "height_m", "mass_kg"])
    if not isinstance(fit["fits"], bool):
        raise ParameterError(where, "fit.fits", f"expected true or false, got {fit['fits']!r}")
    if not isinstance(fit.get("note", ""), str):
        raise ParameterError(where, "fit.note", "expected a string")
    child = {name: _check.within(f"{where} [fit]", name, fit[name], lo, hi, unit)
             for name, (lo, hi, unit) in (("height_m", (0.7, 2.0, "m")),
                                          ("mass_kg", (8.0, 150.0, "kg"))) if name in fit}
    return {"fits": fit["fits"], "note": fit.get("note", ""), **child}


def parse_armature(data: dict[str, Any], where: str) -> list[float]:
    """The optional ``armature`` (3 values, kg m^2, each 0 to :data:`PLAUSIBLE`'s bound)."""
    arm = _check.vector(where, "armature", data.get("armature", [0.0, 0.0, 0.0]), 3)
    lo, hi = PLAUSIBLE["armature_kg_m2"]
    bad = [a for a in arm if not lo <= a <= hi]
    if bad:
        raise ParameterError(where, "armature", f"{bad[0]:g} kg m^2 is not plausible "
                                                f"(allowed {lo:g}-{hi:g} per joint)")
    return [float(a) for a in arm]


def read_leg_file(path: str | Path) -> tuple[list[Link], float, str, dict[str, Any]]:
    """Parse and validate a leg file: (links, g, name, meta); errors name the file and the
    field (a missing, binary or oversized file, a folder, bad TOML, implausible values).
    ``meta`` holds the ``[fit]`` record (``fits``, ``note``) when there is one and
    ``armature`` when it is not zero."""
    return parse_leg_text(read_text(path, "leg parameter file (TOML)"), str(path))


def parse_leg_text(text: str, where: str) -> tuple[list[Link], float, str, dict[str, Any]]:
    """:func:`read_leg_file` of a leg file's text (``where``: what errors name)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ParameterError(where, "(syntax)", f"not valid TOML: {e}") from None
    links, g, name = parse_leg(data, where)
    meta = parse_fit(data, where)
    arm = parse_armature(data, where)
    if any(arm):
        meta = {**meta, "armature": arm}
    return links, g, name, meta


def _printable(text: str) -> str:
    """``text`` with its control characters (but tab) as ``\\uXXXX``: a TOML comment
    may hold none."""
    return "".join(f"\\u{ord(c):04X}" if (c < " " and c != "\t") or c == "\x7f" else c
                   for c in text)


def format_leg(links: list[Link] | tuple[Link, ...], g: float, name: str,
               header: str = "", fit: dict[str, Any] | None = None,
               armature: Any = None) -> str:
    """TOML text of a leg (full float precision, so a round trip is exact); ``fit``: the
    optional ``[fit]`` table (``{"fits": bool, "note": str}``)."""
    # a comment holds no control character (TOML): those of a name are written escaped
    out = [f"# {_printable(ln)}" for ln in header.splitlines()] if header else []
    out += ["# exoleg leg parameters; SI units (kg, m, kg m^2). COM in the link frame,",
            "# from the proximal joint; izz about the COM.",
            f"name = {toml_string(name)}", f"g = {g!r}"]
    if armature is not None and any(float(a) for a in armature):
        out.append("armature = [" + ", ".join(repr(float(a)) for a in armature)
                   + "]  # kg m^2, reflected actuator inertia per joint")
    out.append("")
    if fit:
        out += ["[fit]", f"fits = {'true' if fit['fits'] else 'false'}",
                f"note = {toml_string(str(fit.get('note', '')))}"]
        out += [f"{k} = {float(fit[k])!r}" for k in ("height_m", "mass_kg") if k in fit]
        out.append("")
    for lk in links:
        out += ["[[link]]", f"name = {toml_string(lk.name)}", f"length = {lk.length!r}"]
        if lk.parts:
            for b in lk.parts:
                out += ["", "[[link.part]]", f"name = {toml_string(b.name)}", f"mass = {b.mass!r}",
                        f"com = [{b.com[0]!r}, {b.com[1]!r}]", f"izz = {b.izz!r}"]
        else:
            out += [f"mass = {lk.mass!r}", f"com = [{lk.com[0]!r}, {lk.com[1]!r}]",
                    f"izz = {lk.izz!r}"]
        out.append("")
    return "\n".join(out)
