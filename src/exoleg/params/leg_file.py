"""Leg parameter files: read and write a :class:`~exoleg.LegModel` as TOML.

Format (SI units throughout; comments allowed)::

    g = 9.81                      # m/s^2
    name = "my leg"               # optional

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
"""

from __future__ import annotations

import tomllib
from pathlib import Path
from typing import Any

from exoleg.errors import ParameterError
from exoleg.inertia import RigidBody
from exoleg.params import _check
from exoleg.params.records import LINKS, Link

_LINK_KEYS = ("name", "length", "mass", "com", "izz", "part")
_PART_KEYS = ("name", "mass", "com", "izz")


def _body(where: str, t: dict[str, Any], name: str) -> RigidBody:
    c = _check.vector(where, "com", t["com"], 2)
    return RigidBody(mass=_check.positive(where, "mass", t["mass"], "kg"),
                     com=(float(c[0]), float(c[1])),
                     izz=_check.positive(where, "izz", t["izz"], "kg m^2"), name=name)


def parse_leg(data: dict[str, Any], where: str) -> tuple[list[Link], float, str]:
    """Links, g and name from a parsed leg file (``where`` names it in errors)."""
    _check.keys(where, data, ["link"], ["g", "name"])
    g = _check.finite(where, "g", data.get("g", 9.81))
    if g < 0:
        raise ParameterError(where, "g", f"must be >= 0 m/s^2, got {g}")
    name = str(data.get("name", Path(where).stem))
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
            for j, pt in enumerate(t["part"]):
                wp = f"{w} part[{j}]"
                _check.keys(wp, pt, ["mass", "com", "izz"], ["name"])
                parts.append(_body(wp, pt, str(pt.get("name", f"part{j}"))))
            if not parts:
                raise ParameterError(w, "part", "needs at least one part")
            links.append(Link.from_parts(_check.positive(w, "length", t["length"], "m"), parts,
                                         name=lname))
        else:
            _check.keys(w, t, ["length", "mass", "com", "izz"], ["name"])
            b = _body(w, t, lname)
            links.append(Link(mass=b.mass, length=_check.positive(w, "length", t["length"], "m"),
                              com=b.com, izz=b.izz, name=lname))
    return links, g, name


def read_leg_file(path: str | Path) -> tuple[list[Link], float, str]:
    """Parse and validate a leg file; errors name the file and the field."""
    p = Path(path)
    where = str(p)
    try:
        data = tomllib.loads(p.read_text())
    except FileNotFoundError:
        raise ParameterError(where, "(file)", "no such file") from None
    except tomllib.TOMLDecodeError as e:
        raise ParameterError(where, "(syntax)", f"not valid TOML: {e}") from None
    return parse_leg(data, where)


def format_leg(links: list[Link] | tuple[Link, ...], g: float, name: str,
               header: str = "") -> str:
    """TOML text of a leg (full float precision, so a round trip is exact)."""
    out = [f"# {ln}" for ln in header.splitlines()] if header else []
    out += ["# exoleg leg parameters; SI units (kg, m, kg m^2). COM in the link frame,",
            "# from the proximal joint; izz about the COM.",
            f"name = {name!r}".replace("'", '"'), f"g = {g!r}", ""]
    for lk in links:
        out += ["[[link]]", f'name = "{lk.name}"', f"length = {lk.length!r}"]
        if lk.parts:
            for b in lk.parts:
                out += ["", "[[link.part]]", f'name = "{b.name}"', f"mass = {b.mass!r}",
                        f"com = [{b.com[0]!r}, {b.com[1]!r}]", f"izz = {b.izz!r}"]
        else:
            out += [f"mass = {lk.mass!r}", f"com = [{lk.com[0]!r}, {lk.com[1]!r}]",
                    f"izz = {lk.izz!r}"]
        out.append("")
    return "\n".join(out)
