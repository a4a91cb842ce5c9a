"""Planar rigid-body inertia and its composition: the paper's SMS method (Appendix C).

The paper's "Simscape Multibody Simplification" replaces every group of welded
bodies between two joints by one equivalent body whose mass, centre of mass
and centroidal inertia an inertia sensor measured. Here that is computed:
masses add, the COM is the mass-weighted mean and the inertia about the new
COM follows from the parallel-axis theorem. Only ``izz`` enters the planar
dynamics (paper section 6), so bodies carry ``izz`` alone.

Units: kg, m, kg m^2. COMs are ``(x, y)`` in the link frame, measured from the
link's proximal joint (``docs/conventions.md``).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np

from exoleg import checks as _check
from exoleg.errors import ParameterError

#: Relative slack allowed when a remainder's inertia comes out at rounding level.
_REL_EPS = 1e-12


@dataclass(frozen=True)
class RigidBody:
    """One rigid body on a link.

    Parameters
    ----------
    mass : float
        kg, > 0.
    com : (float, float)
        The centre of mass in the link frame, from the proximal joint, m.
    izz : float
        Moment of inertia about the z axis through the COM, kg m^2, > 0.
    name : str, default "body"
        A label (e.g. ``"human"``, ``"sle"``, ``"hip actuator"``).
    """

    mass: float
    com: tuple[float, float]
    izz: float
    name: str = "body"

    def __post_init__(self) -> None:
        where = f"RigidBody {self.name!r}"
        object.__setattr__(self, "mass", _check.positive(where, "mass", self.mass, "kg"))
        c = _check.vector(where, "com", self.com, 2)
        object.__setattr__(self, "com", (float(c[0]), float(c[1])))
        object.__setattr__(self, "izz", _check.positive(where, "izz", self.izz, "kg m^2"))

    @property
    def izz_origin(self) -> float:
        """Moment of inertia about the link frame's origin (the proximal joint), kg m^2."""
        x, y = self.com
        return self.izz + self.mass * (x * x + y * y)

    @classmethod
    def from_radius_of_gyration(cls, mass: float, com: tuple[float, float], radius: float,
                                name: str = "body") -> RigidBody:
        """A body with centroidal inertia ``mass * radius**2``.

        Parameters
        ----------
        mass : float
            kg.
        com : (float, float)
            m, in the link frame.
        radius : float
            The radius of gyration about the COM, m.
        name : str, default "body"
            A label.

        Returns
        -------
        RigidBody
        """
        r = _check.positive(f"RigidBody {name!r}", "radius_of_gyration", radius, "m")
        return cls(mass=mass, com=com, izz=mass * r * r, name=name)


def compose(bodies: Iterable[RigidBody], name: str = "composite") -> RigidBody:
    """Combine welded bodies into one equivalent body (SMS method, paper Appendix C).

    Mass is the sum, the COM the mass-weighted mean, and ``izz`` is taken about
    the new COM by the parallel-axis theorem.

    Parameters
    ----------
    bodies : iterable of RigidBody
        The welded bodies.
    name : str, default "composite"
        The result's label.

    Returns
    -------
    RigidBody
    """
    parts = list(bodies)
    if not parts:
        raise ParameterError("compose", "bodies", "need at least one body, got none")
    m = np.array([b.mass for b in parts])
    c = np.array([b.com for b in parts])
    mass = float(m.sum())
    com = (m[:, None] * c).sum(axis=0) / mass
    d2 = ((c - com) ** 2).sum(axis=1)
    izz = float(sum(b.izz for b in parts) + (m * d2).sum())
    return RigidBody(mass=mass, com=(float(com[0]), float(com[1])), izz=izz, name=name)


def remainder(total: RigidBody, part: RigidBody, name: str = "remainder") -> RigidBody:
    """The body that, welded to ``part``, composes to ``total`` (inverse of :func:`compose`).

    Parameters
    ----------
    total : RigidBody
        The composite.
    part : RigidBody
        The part known.
    name : str, default "remainder"
        The result's label.

    Returns
    -------
    RigidBody
        A ParameterError if no physical body remains (mass or inertia <= 0).
    """
    mass = total.mass - part.mass
    if mass <= 0.0:
        raise ParameterError(
            f"remainder {name!r}", "mass",
            f"part mass {part.mass} kg is not less than the total {total.mass} kg",
        )
    ct, cp = np.array(total.com), np.array(part.com)
    com = (total.mass * ct - part.mass * cp) / mass
    izz = (total.izz - part.izz - part.mass * float(((cp - ct) ** 2).sum())
           - mass * float(((com - ct) ** 2).sum()))
    if izz <= _REL_EPS * total.izz:
        raise ParameterError(
            f"remainder {name!r}", "izz",
            f"no physical body remains: izz would be {izz:.3e} kg m^2 (must be > 0); "
            "the part is too spread out for the total",
        )
    return RigidBody(mass=mass, com=(float(com[0]), float(com[1])), izz=izz, name=name)
