"""The leg model: links and gravity as data, the equations of motion as compiled kernels."""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from exoleg import checks as _check
from exoleg import kinematics
from exoleg.dynamics import kernels as K
from exoleg.dynamics.single import ADDRESS as _A
from exoleg.dynamics.single import MATRIX as _MAT
from exoleg.dynamics.single import POINTS as _PTS
from exoleg.dynamics.single import VECTOR as _VEC
from exoleg.dynamics.single import call as _call
from exoleg.errors import ParameterError
from exoleg.params.records import JOINTS, Link

F64 = NDArray[np.float64]


_UNITS = {"q": "rad", "dq": "rad/s", "ddq": "rad/s^2", "tau": "N m"}
#: kernel -> (its state arguments, whether it takes g, shape of one result)
_SIGNATURES: dict[str, tuple[tuple[str, ...], bool, tuple[int, ...]]] = {
    "mass_matrix": (("q",), False, (3, 3)),
    "coriolis_matrix": (("q", "dq"), False, (3, 3)),
    "coriolis_dq": (("q", "dq"), False, (3,)),
    "gravity": (("q",), True, (3,)),
    "mass_matrix_dot": (("q", "dq"), False, (3, 3)),
    "forward_dynamics": (("q", "dq", "tau"), True, (3,)),
    "inverse_dynamics": (("q", "dq", "ddq"), True, (3,)),
    "regressor": (("q", "dq", "ddq"), True, (3, K.N_INERTIAL)),
    "kinetic_energy": (("q", "dq"), False, ()),
    "potential_energy": (("q",), True, ()),
}


#: The parameter vector's layout, from the generated kernels' declaration
#: (:data:`exoleg.dynamics.derive.LINK_PARAMS`: per link, then the joints' armatures).
_PER_LINK = len(K.LINK_PARAMS)
_LINKS = _PER_LINK * K.N_JOINTS
_SLOT = {n: i for i, n in enumerate(K.LINK_PARAMS)}


def _link_value(link: Link, name: str) -> float:
    """A link's value for the parameter ``name`` of :data:`K.LINK_PARAMS`."""
    return {"m": link.mass, "a": link.length, "cx": link.com[0], "cy": link.com[1],
            "I": link.izz}[name]


class LegModel:
    """The coupled child + exoskeleton leg: three links on the paper's D-H chain (Table 3).

    Every method takes joint vectors ordered (hip, knee, ankle) in rad (rad/s,
    rad/s^2, N m) of shape ``(3,)`` or ``(N, 3)``; results broadcast the same way.
    Equations: M (eq 17), C in Christoffel form (eq 18), G (eq 19), forward
    dynamics (eq 20), inverse dynamics (eq 16).

    Parameters
    ----------
    links : sequence of Link
        Thigh, shank, foot (each a :class:`~exoleg.params.records.Link`).
    g : float, default 9.81
        Gravitational acceleration, m/s^2 (gravity along -y).
    name : str, default "leg"
        A label used in reports.
    armature : array_like, optional
        Per joint, the actuator's rotor inertia reflected through its gear, N^2 J
        (kg m^2), added to M's diagonal; default none (the paper's model).
    """

    __slots__ = ("_k", "_p", "g", "links", "name")

    def __init__(self, links: Sequence[Link], g: float = 9.81, name: str = "leg",
                 armature: ArrayLike | None = None) -> None:
        links = tuple(links)
        if len(links) != K.N_JOINTS:
            raise ParameterError(
                f"LegModel {name!r}",
                "links",
                f"need exactly {K.N_JOINTS} links (thigh, shank, foot), got {len(links)}",
            )
        for i, lk in enumerate(links):
            if not isinstance(lk, Link):
                raise ParameterError(
                    f"LegModel {name!r}",
                    f"links[{i}]",
                    f"expected an exoleg.Link, got {type(lk).__name__}",
                )
        self.links: tuple[Link, ...] = links
        self.g: float = _check.finite(f"LegModel {name!r}", "g", g)
        if self.g < 0:
            raise ParameterError(f"LegModel {name!r}", "g", f"must be >= 0 m/s^2, got {self.g}")
        self.name = name
        arm = np.zeros(K.N_JOINTS) if armature is None else _check.vector(
            f"LegModel {name!r}", "armature", armature, K.N_JOINTS)
        if np.any(arm < 0):
            raise ParameterError(f"LegModel {name!r}", "armature",
                                 f"must be >= 0 kg m^2 per joint, got {arm.tolist()}")
        p = np.concatenate([np.array([[_link_value(lk, n) for n in K.LINK_PARAMS]
                                      for lk in links]).ravel(), arm])
        p.setflags(write=False)
        self._p = p
        self._k: tuple[float, ...] | None = None

    # ------------------------------------------------------------------ data
    @property
    def p(self) -> F64:
        """Parameter vector (18,): per link ``m, a, cx, cy, Izz``, then the three joint
        armatures (read-only)."""
        return self._p

    @property
    def coefficients(self) -> tuple[float, ...]:
        """The parameter-only coefficients of the stepper's kernels, from p and g
        (see :func:`exoleg.dynamics.kernels.coefficients`)."""
        if self._k is None:
            self._k = tuple(K.coefficients(self._p, self.g))
        return self._k

    @property
    def lengths(self) -> F64:
        """Link lengths a1, a2, a3 (m)."""
        return self._p[_SLOT["a"]:_LINKS:_PER_LINK].copy()

    @property
    def coms(self) -> F64:
        """COMs (3, 2) in each link frame, from the proximal joint (m)."""
        return self._p[:_LINKS].reshape(K.N_JOINTS, _PER_LINK)[:, _SLOT["cx"]:_SLOT["cy"] + 1
                                                                ].copy()

    @property
    def armature(self) -> F64:
        """Reflected actuator inertia per joint, kg m^2 (added to M's diagonal)."""
        return self._p[_LINKS:].copy()

    def with_armature(self, armature: ArrayLike) -> LegModel:
        """The same leg with this armature.

        Parameters
        ----------
        armature : array_like
            Per joint, kg m^2 (N^2 J of each actuator).

        Returns
        -------
        LegModel
            A new model; this one is unchanged.
        """
        return LegModel(self.links, g=self.g, name=self.name, armature=armature)

    @property
    def offsets(self) -> tuple[float, ...]:
        """D-H joint offsets (rad) of the compiled chain."""
        return tuple(K.OFFSETS)

    @property
    def has_parts(self) -> bool:
        """Whether every link carries its welded parts (a detailed model)."""
        return all(lk.parts for lk in self.links)

    def lumped(self) -> LegModel:
        """The same leg with each link as one body (the paper's simplified form).

        Returns
        -------
        LegModel
            A new model: each welded link composed into one body.
        """
        return LegModel([lk.lumped() for lk in self.links], g=self.g, name=self.name,
                        armature=self.armature)

    def with_links(self, **changes: Link) -> LegModel:
        """A copy with some links replaced, by name: ``leg.with_links(foot=new_foot)``.

        Parameters
        ----------
        **changes : Link
            The new links by their names (thigh, shank, foot); an unknown name is a
            ParameterError naming the links there are.

        Returns
        -------
        LegModel
            A new model; this one is unchanged.
        """
        names = [lk.name for lk in self.links]
        for k in changes:
            if k not in names:
                raise ParameterError(
                    f"LegModel {self.name!r}", k, f"no such link (links: {', '.join(names)})"
                )
        return LegModel([changes.get(lk.name, lk) for lk in self.links], g=self.g, name=self.name,
                        armature=self.armature)

    def __repr__(self) -> str:
        m = ", ".join(f"{lk.name} {lk.mass:.3f} kg" for lk in self.links)
        return f"LegModel({self.name!r}: {m}; g={self.g})"

    # ------------------------------------------------------------ validation
    def _vec(self, field: str, x: ArrayLike, unit: str) -> F64:
        """``x`` as floats of shape (3,) or (..., 3); finiteness is checked by ``_run``."""
        a = np.asarray(x, dtype=np.float64)
        if a.ndim == 0 or a.shape[-1] != 3:
            raise ParameterError(
                f"LegModel {self.name!r}",
                field,
                f"expected 3 values ({', '.join(JOINTS)}) in {unit}, shape (3,) or (N, 3); "
                f"got shape {a.shape}",
            )
        return a

    def _run(self, name: str, values: tuple[ArrayLike, ...]) -> F64:
        """Evaluate kernel ``name``: directly for one state, by its gufunc for a batch.

        A non-finite input is named in the error. It is looked for only when the
        result is not finite (NaN and inf propagate through every kernel), which
        keeps a single call cheap.
        """
        fields, gravity, shape = _SIGNATURES[name]
        args = tuple(self._vec(f, v, _UNITS[f]) for f, v in zip(fields, values, strict=True))
        extra = (self._p, self.g) if gravity else (self._p,)
        if all(a.ndim == 1 for a in args):
            kernel = getattr(K, name)
            if shape:
                out: F64 = np.empty(shape)
                kernel(*args, *extra, out)
            else:  # energies return a scalar
                out = np.asarray(kernel(*args, *extra), dtype=np.float64)
        else:
            out = K.gufunc(name)(*args, *extra)
        if not np.isfinite(out).all():
            for f, a in zip(fields, args, strict=True):
                bad = np.argwhere(~np.isfinite(a))
                if len(bad):
                    raise ParameterError(
                        f"LegModel {self.name!r}",
                        f,
                        f"must be finite {_UNITS[f]}; {JOINTS[bad[0][-1]]} is {a[tuple(bad[0])]}",
                    )
            raise ParameterError(
                f"LegModel {self.name!r}", name, "result is not finite: inputs too large"
            )
        return out

    # -------------------------------------------------------------- dynamics
    def M(self, q: ArrayLike) -> F64:
        """Inertia matrix M(q) (eq 17).

        Parameters
        ----------
        q : array_like
            Joint angles (hip, knee, ankle), rad, shape ``(3,)`` or ``(N, 3)``.

        Returns
        -------
        ndarray
            Shape ``(..., 3, 3)``, kg m^2.
        """
        out = None if _call is None else _call(_A.mass_matrix, _MAT, self.g, self._p, q)
        if out is not None:  # else not one float64 state, or not finite: the general path
            return out
        return self._run("mass_matrix", (q,))

    def C(self, q: ArrayLike, dq: ArrayLike) -> F64:
        """Coriolis/centripetal matrix in Christoffel form (eq 18).

        Parameters
        ----------
        q : array_like
            Joint angles (hip, knee, ankle), rad, shape ``(3,)`` or ``(N, 3)``.
        dq : array_like
            Joint rates, rad/s, the shape of ``q``.

        Returns
        -------
        ndarray
            Shape ``(..., 3, 3)``, N m s/rad.
        """
        out = None if _call is None else _call(_A.coriolis_matrix, _MAT, self.g, self._p, q, dq)
        if out is not None:  # else not one float64 state, or not finite: the general path
            return out
        return self._run("coriolis_matrix", (q, dq))

    def Cdq(self, q: ArrayLike, dq: ArrayLike) -> F64:
        """The Coriolis and centripetal torques C(q, dq) dq.

        Parameters
        ----------
        q : array_like
            Joint angles (hip, knee, ankle), rad, shape ``(3,)`` or ``(N, 3)``.
        dq : array_like
            Joint rates, rad/s, the shape of ``q``.

        Returns
        -------
        ndarray
            Shape ``(..., 3)``, N m.
        """
        out = None if _call is None else _call(_A.coriolis_dq, _VEC, self.g, self._p, q, dq)
        if out is not None:  # else not one float64 state, or not finite: the general path
            return out
        return self._run("coriolis_dq", (q, dq))

    def G(self, q: ArrayLike) -> F64:
        """Gravity torque vector G(q) (eq 19).

        Parameters
        ----------
        q : array_like
            Joint angles (hip, knee, ankle), rad, shape ``(3,)`` or ``(N, 3)``.

        Returns
        -------
        ndarray
            Shape ``(..., 3)``, N m.
        """
        out = None if _call is None else _call(_A.gravity, _VEC, self.g, self._p, q)
        if out is not None:  # else not one float64 state, or not finite: the general path
            return out
        return self._run("gravity", (q,))

    def Mdot(self, q: ArrayLike, dq: ArrayLike) -> F64:
        """Time derivative of M along (q, dq).

        Parameters
        ----------
        q : array_like
            Joint angles (hip, knee, ankle), rad, shape ``(3,)`` or ``(N, 3)``.
        dq : array_like
            Joint rates, rad/s, the shape of ``q``.

        Returns
        -------
        ndarray
            Shape ``(..., 3, 3)``, kg m^2/s.
        """
        out = None if _call is None else _call(_A.mass_matrix_dot, _MAT, self.g, self._p, q, dq)
        if out is not None:  # else not one float64 state, or not finite: the general path
            return out
        return self._run("mass_matrix_dot", (q, dq))

    def forward_dynamics(self, q: ArrayLike, dq: ArrayLike, tau: ArrayLike) -> F64:
        """Joint accelerations M^-1 (tau - C dq - G) (eq 20).

        Parameters
        ----------
        q : array_like
            Joint angles (hip, knee, ankle), rad, shape ``(3,)`` or ``(N, 3)``.
        dq : array_like
            Joint rates, rad/s, the shape of ``q``.
        tau : array_like
            Joint torques, N m, the shape of ``q``.

        Returns
        -------
        ndarray
            Shape ``(..., 3)``, rad/s^2.
        """
        out = None if _call is None else _call(_A.forward_dynamics, _VEC, self.g, self._p,
                                               q, dq, tau)
        if out is not None:  # else not one float64 state, or not finite: the general path
            return out
        return self._run("forward_dynamics", (q, dq, tau))

    def inverse_dynamics(self, q: ArrayLike, dq: ArrayLike, ddq: ArrayLike) -> F64:
        """Joint torques M ddq + C dq + G (eq 16).

        Parameters
        ----------
        q : array_like
            Joint angles (hip, knee, ankle), rad, shape ``(3,)`` or ``(N, 3)``.
        dq : array_like
            Joint rates, rad/s, the shape of ``q``.
        ddq : array_like
            Joint accelerations, rad/s^2, the shape of ``q``.

        Returns
        -------
        ndarray
            Shape ``(..., 3)``, N m.
        """
        out = None if _call is None else _call(_A.inverse_dynamics, _VEC, self.g, self._p,
                                               q, dq, ddq)
        if out is not None:  # else not one float64 state, or not finite: the general path
            return out
        return self._run("inverse_dynamics", (q, dq, ddq))

    def regressor(self, q: ArrayLike, dq: ArrayLike, ddq: ArrayLike) -> F64:
        """The regressor Y: the joint torques M ddq + C dq + G = Y :meth:`inertial`,
        linear in the inertial parameters, the geometry (the links' lengths) inside Y
        (:func:`exoleg.dynamics.derive.regressor`).

        Parameters
        ----------
        q : array_like
            Joint angles (hip, knee, ankle), rad, shape ``(3,)`` or ``(N, 3)``.
        dq : array_like
            Joint rates, rad/s, the shape of ``q``.
        ddq : array_like
            Joint accelerations, rad/s^2, the shape of ``q``.

        Returns
        -------
        ndarray
            Shape ``(..., 3, 15)``.
        """
        return self._run("regressor", (q, dq, ddq))

    def inertial(self) -> F64:
        """The inertial parameters the regressor multiplies: per link m, m cx, m cy
        and the inertia about its proximal joint I + m (cx^2 + cy^2)
        (:data:`~exoleg.dynamics.kernels.BARYCENTRIC`), then the joints' armatures.

        Returns
        -------
        ndarray
            Shape ``(15,)``: kg, kg m, kg m, kg m^2 per link, then kg m^2 per joint.
        """
        out = []
        for link in self.links:
            m, cx, cy = link.mass, link.com[0], link.com[1]
            out += [m, m * cx, m * cy, link.izz + m * (cx * cx + cy * cy)]
        return np.array(out + list(self.armature), dtype=np.float64)

    def kinetic_energy(self, q: ArrayLike, dq: ArrayLike) -> F64:
        """Kinetic energy.

        Parameters
        ----------
        q : array_like
            Joint angles (hip, knee, ankle), rad, shape ``(3,)`` or ``(N, 3)``.
        dq : array_like
            Joint rates, rad/s, the shape of ``q``.

        Returns
        -------
        ndarray
            Shape ``(...)``, J.
        """
        return self._run("kinetic_energy", (q, dq))

    def potential_energy(self, q: ArrayLike) -> F64:
        """Gravitational potential energy, zero at the hip's height.

        Parameters
        ----------
        q : array_like
            Joint angles (hip, knee, ankle), rad, shape ``(3,)`` or ``(N, 3)``.

        Returns
        -------
        ndarray
            Shape ``(...)``, J.
        """
        return self._run("potential_energy", (q,))

    # ------------------------------------------------------------ kinematics
    def fk(self, q: ArrayLike) -> dict[str, F64]:
        """Forward kinematics (paper eqs 5-6).

        Parameters
        ----------
        q : array_like
            Joint angles (hip, knee, ankle), rad, shape ``(3,)`` or ``(N, 3)``.

        Returns
        -------
        dict of str to ndarray
            Named positions ``(..., 2)`` in m -- hip, knee, ankle, toe, com_thigh,
            com_shank, com_foot -- and ``phi``, the foot orientation (rad).
        """
        out = None if _call is None else _call(_A.forward_kinematics, _PTS, self.g, self._p, q)
        if out is not None:
            fk = dict(zip(kinematics.POINTS, out, strict=False))  # row 7 is (phi, 0)
            fk["phi"] = out[7, 0]
            return fk
        qa = self._vec("q", q, "rad")
        if not np.all(np.isfinite(qa)):
            raise ParameterError(f"LegModel {self.name!r}", "q", "must be finite rad")
        return kinematics.forward_kinematics(qa, self.lengths, self.coms, K.OFFSETS)

    def jacobians(self, q: ArrayLike) -> dict[str, F64]:
        """Linear Jacobians of the toe and each link's centre of mass.

        Parameters
        ----------
        q : array_like
            Joint angles (hip, knee, ankle), rad, shape ``(3,)`` or ``(N, 3)``.

        Returns
        -------
        dict of str to ndarray
            Shape ``(..., 2, 3)`` each, m/rad, by point name.
        """
        return kinematics.jacobians(self._vec("q", q, "rad"), self.lengths, self.coms, K.OFFSETS)

    def ik(
        self,
        x: ArrayLike,
        y: ArrayLike,
        phi: ArrayLike,
        branch: Literal["flexed", "extended"] = "flexed",
    ) -> F64:
        """Joint angles putting the toe at (x, y) with the foot's orientation phi (exact,
        paper eqs 8-14; :func:`exoleg.kinematics.inverse_kinematics`).

        Parameters
        ----------
        x, y : array_like
            The toe's position in the hip frame, m (scalars or ``(N,)``).
        phi : array_like
            The foot's orientation, rad.
        branch : {"flexed", "extended"}, default "flexed"
            The knee's solution: flexed (q2 <= 0) or extended.

        Returns
        -------
        ndarray
            Joint angles ``(..., 3)``, rad; an unreachable toe is an UnreachableError.
        """
        return kinematics.inverse_kinematics(x, y, phi, self.lengths, branch=branch)
