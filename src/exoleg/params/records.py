"""What a link, an actuator, a range of motion and a set of gains are: typed records, SI units.

Records validate themselves on construction and raise
:class:`~exoleg.errors.ParameterError` naming the field and what is allowed.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from exoleg import checks as _check
from exoleg.errors import ParameterError
from exoleg.inertia import RigidBody, compose

#: Joint names, in the order of every joint vector (q is hip, knee, ankle).
JOINTS = ("hip", "knee", "ankle")
#: Link names, in order.
LINKS = ("thigh", "shank", "foot")


#: What a link of any leg (a child's, an adult's, with or without the device) can be: its
#: length and mass; its COM within one link length of the joint-to-joint segment; its
#: centroidal inertia at most that of its mass two lengths from the COM (a slender rod's
#: is m L^2 / 12). A leg file holds a child's leg with the device and is held to tighter
#: bounds (:data:`exoleg.params.leg_file.PLAUSIBLE`).
LINK_LENGTH_M = (0.01, 2.0)
LINK_MASS_KG = (1e-3, 100.0)


def com_offset(com: tuple[float, float], length: float) -> float:
    """How far a COM lies from its link's joint-to-joint segment, m."""
    x, y = com
    return math.hypot(x - min(max(x, 0.0), length), y)


def _plausible(where: str, m: float, a: float, com: tuple[float, float], izz: float) -> None:
    lo, hi = LINK_LENGTH_M
    if not lo <= a <= hi:
        raise ParameterError(where, "length", f"{a:g} m is outside {lo:g}-{hi:g} m")
    lo, hi = LINK_MASS_KG
    if not lo <= m <= hi:
        raise ParameterError(where, "mass", f"{m:g} kg is outside {lo:g}-{hi:g} kg")
    x, y = com
    off = com_offset(com, a)
    if off > a:
        raise ParameterError(where, "com", f"({x:g}, {y:g}) m is outside the link's reach: "
                             f"{off:.3g} m from its {a:g} m segment (at most one length)")
    top = m * (2 * a) ** 2
    if izz > top:
        raise ParameterError(where, "izz", f"{izz:g} kg m^2 is more than a {m:g} kg body "
                             f"within two lengths of its COM can have ({top:.3g} kg m^2)")


@dataclass(frozen=True)
class Link:
    """One link of the leg, lumped into a single rigid body.

    Parameters
    ----------
    mass : float
        kg, > 0.
    length : float
        Joint-to-joint length a_i, m, > 0 (for the foot: ankle to toe).
    com : (float, float)
        The COM in the link frame, from the proximal joint, m; the link frame's x axis
        points along the link, y is x turned +90 deg.
    izz : float
        Centroidal moment of inertia about z, kg m^2, > 0.
    name : str, default "link"
        A label, e.g. ``"thigh"``.
    parts : tuple of RigidBody, default ()
        The welded bodies this link is made of (e.g. human and SLE), if known; when given,
        mass, com and izz must be their composition (see :meth:`from_parts`).
    """

    mass: float
    length: float
    com: tuple[float, float]
    izz: float
    name: str = "link"
    parts: tuple[RigidBody, ...] = field(default=())

    def __post_init__(self) -> None:
        where = f"Link {self.name!r}"
        body = RigidBody(mass=self.mass, com=self.com, izz=self.izz, name=self.name)
        object.__setattr__(self, "mass", body.mass)
        object.__setattr__(self, "com", body.com)
        object.__setattr__(self, "izz", body.izz)
        a = _check.positive(where, "length", self.length, "m")
        object.__setattr__(self, "length", a)
        object.__setattr__(self, "parts", tuple(self.parts))
        _plausible(where, body.mass, a, body.com, body.izz)
        if self.parts:
            c = compose(self.parts)
            tol = 1e-9
            scale = max(abs(self.com[0]), abs(self.com[1]), self.length)
            if (abs(c.mass - self.mass) > tol * self.mass
                    or abs(c.izz - self.izz) > tol * self.izz
                    or max(abs(c.com[0] - self.com[0]), abs(c.com[1] - self.com[1])) > tol * scale):
                raise ParameterError(
                    where, "parts",
                    f"compose to mass {c.mass}, com {c.com}, izz {c.izz}, which differ from the "
                    f"link's mass {self.mass}, com {self.com}, izz {self.izz}; "
                    "use Link.from_parts to build a link from its parts",
                )

    @classmethod
    def from_parts(cls, length: float, parts: tuple[RigidBody, ...] | list[RigidBody],
                   name: str = "link") -> Link:
        """A link whose mass properties are the SMS composition of ``parts``.

        Parameters
        ----------
        length : float
            m.
        parts : sequence of RigidBody
            The welded bodies.
        name : str, default "link"
            A label.

        Returns
        -------
        Link
        """
        c = compose(parts, name=name)
        return cls(mass=c.mass, length=length, com=c.com, izz=c.izz, name=name,
                   parts=tuple(parts))

    @property
    def body(self) -> RigidBody:
        """The lumped body."""
        return RigidBody(mass=self.mass, com=self.com, izz=self.izz, name=self.name)

    def lumped(self) -> Link:
        """This link without its parts (the paper's simplified, single-body form).

        Returns
        -------
        Link
        """
        return Link(mass=self.mass, length=self.length, com=self.com, izz=self.izz, name=self.name)


@dataclass(frozen=True)
class Actuator:
    """One joint's actuation unit (paper Table 2).

    Parameters
    ----------
    joint : str
        hip, knee or ankle.
    mass : float
        kg.
    power : float
        W.
    gear_ratio : float
        Output:input, e.g. 100 for 100:1.
    max_torque : float
        N m.
    max_velocity : float
        rad/s.
    motor, gear : str, default ""
        The models' names.
    """

    joint: str
    mass: float
    power: float
    gear_ratio: float
    max_torque: float
    max_velocity: float
    motor: str = ""
    gear: str = ""

    def __post_init__(self) -> None:
        where = f"Actuator {self.joint!r}"
        for f in ("mass", "power", "gear_ratio", "max_torque", "max_velocity"):
            object.__setattr__(self, f, _check.positive(where, f, getattr(self, f)))


@dataclass(frozen=True)
class RangeOfMotion:
    """Joint limits, ordered (hip, knee, ankle); ``lower < upper`` per joint.

    Parameters
    ----------
    lower, upper : ndarray
        rad, (3,).
    """

    lower: NDArray[np.float64]
    upper: NDArray[np.float64]

    def __post_init__(self) -> None:
        lo = _check.vector("RangeOfMotion", "lower", list(self.lower), len(JOINTS))
        hi = _check.vector("RangeOfMotion", "upper", list(self.upper), len(JOINTS))
        for i, j in enumerate(JOINTS):
            if not lo[i] < hi[i]:
                raise ParameterError("RangeOfMotion", j,
                                     f"lower limit {lo[i]} rad must be below upper {hi[i]} rad")
        object.__setattr__(self, "lower", lo)
        object.__setattr__(self, "upper", hi)

    def contains(self, q: NDArray[np.float64]) -> NDArray[np.bool_]:
        """Whether each configuration lies within the limits.

        Parameters
        ----------
        q : ndarray
            Joint angles, rad, ``(..., 3)``.

        Returns
        -------
        ndarray of bool
            Shape ``(...)``.
        """
        q = np.asarray(q, dtype=float)
        return np.all((q >= self.lower) & (q <= self.upper), axis=-1)


@dataclass(frozen=True)
class Gains:
    """Diagonal PD gains.

    Parameters
    ----------
    kp : ndarray
        N m/rad (hip, knee, ankle).
    kd : ndarray
        N m s/rad.
    rate_hz : float, default 1000.0
        The control rate, Hz.
    """

    kp: NDArray[np.float64]
    kd: NDArray[np.float64]
    rate_hz: float = 1000.0

    def __post_init__(self) -> None:
        kp = _check.vector("Gains", "kp", list(self.kp), len(JOINTS))
        kd = _check.vector("Gains", "kd", list(self.kd), len(JOINTS))
        if np.any(kp < 0) or np.any(kd < 0):
            raise ParameterError("Gains", "kp/kd", f"must be >= 0, got kp={kp}, kd={kd}")
        object.__setattr__(self, "kp", kp)
        object.__setattr__(self, "kd", kd)
        object.__setattr__(self, "rate_hz", _check.positive("Gains", "rate_hz", self.rate_hz, "Hz"))
