"""exoleg: model, control and simulation of a pediatric single-leg exoskeleton.

The device and its model are those of Sarajchi & Sirlantzis, *Design and
Control of a Single-Leg Exoskeleton with Gravity Compensation for Children
with Unilateral Cerebral Palsy*, Sensors 2023, 23, 6103. Conventions (frames,
signs, units): ``docs/conventions.md``. SI units and radians throughout.

>>> import exoleg
>>> leg = exoleg.paper_leg("simplified")
>>> leg.G([0.0, 0.0, 0.0]).shape
(3,)
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Literal

from exoleg import _cache
from exoleg.errors import ExolegError, ParameterError, SimulationError, UnreachableError

_cache.guard()

if TYPE_CHECKING:
    from exoleg import control, reference
    from exoleg.dynamics.model import LegModel
    from exoleg.inertia import RigidBody, compose, remainder
    from exoleg.params.records import JOINTS, LINKS, Actuator, Gains, Link, RangeOfMotion
    from exoleg.sim.closed_loop import SimResult, simulate

__version__ = "0.1.0"

#: What ``import exoleg`` offers, loaded on first use so that the import -- and the
#: command line's start -- stay quick (numba alone takes 0.2 s to import): name -> module.
_LAZY = {
    "LegModel": "exoleg.dynamics.model", "SimResult": "exoleg.sim.closed_loop",
    "simulate": "exoleg.sim.closed_loop", "RigidBody": "exoleg.inertia",
    "compose": "exoleg.inertia", "remainder": "exoleg.inertia",
    **{n: "exoleg.params.records" for n in ("JOINTS", "LINKS", "Actuator", "Gains", "Link",
                                             "RangeOfMotion")},
    # subpackages: ``exoleg.sizing.Child``, ``exoleg.export.write_urdf`` after ``import exoleg``
    **{n: f"exoleg.{n}" for n in ("child", "control", "dynamics", "export", "io", "kinematics",
                                  "params", "plots", "reference", "sim", "sizing",
                                  "study", "validate")},
}


def __getattr__(name: str) -> object:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module 'exoleg' has no attribute {name!r}")
    import importlib

    mod = importlib.import_module(module)
    value = mod if module == f"exoleg.{name}" else getattr(mod, name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_LAZY))


def paper_leg(variant: Literal["simplified", "detailed"] = "simplified",
              g: float | None = None) -> LegModel:
    """The paper's coupled child + SLE leg.

    ``"simplified"``: Table 5's simplified column (one body per link, a3 = 0.235 m,
    see ``exoleg/data/paper/table5.toml``). ``"detailed"``: each link a human and an
    SLE body welded together (Table 4 masses), composing to Table 5's detailed
    column (twice the simplified masses and inertias).

    Parameters
    ----------
    variant : {"simplified", "detailed"}, default "simplified"
        Which of Table 5's columns.
    g : float, optional
        Gravitational acceleration, m/s^2; default the paper's 9.81.

    Returns
    -------
    LegModel
    """
    from exoleg.dynamics.model import LegModel
    from exoleg.params import paper as _paper

    grav = _paper.gravity() if g is None else g
    if variant == "simplified":
        return LegModel(_paper.table5_links("simplified"), g=grav, name="paper simplified")
    if variant == "detailed":
        return LegModel(_paper.detailed_links(), g=grav, name="paper detailed")
    raise ParameterError("paper_leg", "variant",
                         f"unknown {variant!r} (allowed: 'simplified', 'detailed')")


def load_leg(path: str | Path) -> LegModel:
    """Read a leg parameter file (format: :mod:`exoleg.params.leg_file`).

    Parameters
    ----------
    path : str or Path
        The TOML file (``exoleg fit`` and :func:`save_leg` write them).

    Returns
    -------
    LegModel
        A ParameterError names the key of anything missing or implausible.
    """
    from exoleg.dynamics.model import LegModel
    from exoleg.params.leg_file import read_leg_file

    links, g, name, meta = read_leg_file(path)
    return LegModel(links, g=g, name=name, armature=meta.get("armature"))


def save_leg(leg: LegModel, path: str | Path, header: str = "",
             fit: dict[str, object] | None = None) -> Path:
    """Write ``leg`` as a leg parameter file that :func:`load_leg` reads back exactly
    (written whole or not at all).

    Parameters
    ----------
    leg : LegModel
        The leg.
    path : str or Path
        The TOML file to write.
    header : str, default ""
        A comment at the file's top.
    fit : dict, optional
        The optional ``[fit]`` record, ``{"fits": bool, "note": str}`` (see
        :mod:`exoleg.params.leg_file`).

    Returns
    -------
    Path
        The file written.
    """
    from exoleg.io import atomic_path
    from exoleg.params.leg_file import format_leg

    text = format_leg(leg.links, leg.g, leg.name, header=header, fit=fit,
                      armature=leg.armature)
    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)


__all__ = [
    "JOINTS", "LINKS", "Actuator", "ExolegError", "Gains", "LegModel", "Link",
    "ParameterError", "RangeOfMotion", "RigidBody", "SimResult", "SimulationError",
    "UnreachableError", "compose", "control", "load_leg", "paper_leg", "reference", "remainder",
    "save_leg", "simulate",
]
