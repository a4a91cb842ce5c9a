"""Controller records: the paper's PD impedance + gravity compensation, plain PD,
computed torque."""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from exoleg.control import laws
from exoleg.dynamics.kernels import N_COEFFICIENTS
from exoleg.dynamics.model import LegModel
from exoleg.entry import LAWS
from exoleg.errors import ParameterError
from exoleg.params import paper

F64 = NDArray[np.float64]


def _gains(name: str, field_name: str, value: ArrayLike | None, default: F64) -> F64:
    v = default if value is None else np.asarray(value, dtype=float)
    if v.shape != (3,) or not np.all(np.isfinite(v)) or np.any(v < 0):
        raise ParameterError(name, field_name,
                             f"expected 3 finite gains >= 0 (hip, knee, ankle), got {value!r}")
    return v


def _limits(name: str, value: ArrayLike | bool | None) -> F64:
    """Torque limits: None/False = none; True = Table 2's maxima; or 3 values in N m."""
    if value is None or value is False:
        return np.full(3, np.inf)
    if value is True:
        return np.array([a.max_torque for a in paper.actuators()])
    v = np.asarray(value, dtype=float)
    if v.shape != (3,) or np.any(~(v > 0)):
        raise ParameterError(name, "saturation",
                             f"expected True (Table 2 limits) or 3 limits > 0 N m, got {value!r}")
    return v


@dataclass(frozen=True)
class Controller:
    """A control law as a record: its gains, the model it believes in, its limits.

    Parameters
    ----------
    Kp, Kd : ndarray
        Per joint stiffness and damping (PD laws: N m/rad, N m s/rad; computed torque:
        1/s^2, 1/s).
    model : LegModel, optional
        The leg model the law believes in (None for plain PD).
    saturation : ndarray
        Torque limits per joint, N m (infinite: none).
    kind : exoleg.control.laws.Law
        Which compiled law (:class:`exoleg.control.laws.Law`).
    name : str
        A label.
    scale : float, default 1.0
        The torque's factor before saturation (:meth:`scaled`).
    """

    Kp: F64
    Kd: F64
    model: LegModel | None = None
    saturation: F64 = field(default_factory=lambda: np.full(3, np.inf))
    kind: laws.Law = laws.Law.PD
    name: str = "controller"
    scale: float = 1.0

    def scaled(self, factor: float) -> Controller:
        """The same controller with its torque multiplied by ``factor`` (before saturation).

        Parameters
        ----------
        factor : float
            > 0.

        Returns
        -------
        Controller
        """
        if not (np.isfinite(factor) and factor > 0):
            raise ParameterError(self.name, "scale", f"must be > 0, got {factor!r}")
        return replace(self, scale=float(factor))

    def torque(self, q: ArrayLike, dq: ArrayLike, q_ref: ArrayLike, dq_ref: ArrayLike | None = None,
               ddq_ref: ArrayLike | None = None) -> tuple[F64, int]:
        """The law's torque for one state.

        Parameters
        ----------
        q, dq : array_like
            Joint angles (rad) and rates (rad/s), (3,).
        q_ref : array_like
            The reference's angles, rad, (3,).
        dq_ref, ddq_ref : array_like, optional
            Its rates and accelerations; default 0.

        Returns
        -------
        tau : ndarray
            Joint torques (3,), N m.
        saturated : int
            Bit i set where joint i's torque was saturated.
        """
        z = np.zeros(3)
        args = [np.asarray(v, dtype=float) if v is not None else z
                for v in (q, dq, q_ref, dq_ref, ddq_ref)]
        for nm, a in zip(("q", "dq", "q_ref", "dq_ref", "ddq_ref"), args, strict=True):
            if a.shape != (3,) or not np.all(np.isfinite(a)):
                raise ParameterError(self.name, nm, f"expected 3 finite values, got {a!r}")
        u = np.empty(3)
        mask = laws.control_law(self.call_args(), args[0], args[1],
                                (args[2], args[3], args[4]), u)
        return u, int(mask)

    def law_args(self) -> tuple[tuple[float, ...], tuple[float, ...], tuple[float, ...], float,
                                tuple[float, ...]]:
        """The record as the compiled laws take it (:func:`exoleg.control.laws.law`;
        tuples are passed by value).

        Returns
        -------
        tuple
            (Kp, Kd, model coefficients, scale, saturation).
        """
        return (tuple(map(float, self.Kp)), tuple(map(float, self.Kd)), self.coefficients,
                self.scale, tuple(map(float, self.saturation)))

    def call_args(self) -> tuple[int, F64, F64, F64, float, F64]:
        """The record as :func:`exoleg.control.laws.control_law` takes it when called
        from Python each tick: arrays, not :meth:`law_args`' tuples -- numba types a
        tuple of floats (and the law's enum) in Python at every call (60 us measured),
        arrays in C (1 us).

        Returns
        -------
        tuple
            (law, Kp, Kd, model coefficients, scale, saturation).
        """
        kp, kd, kc, scale, limit = self.law_args()
        return (int(self.kind), np.array(kp), np.array(kd), np.array(kc), float(scale),
                np.array(limit))

    @property
    def coefficients(self) -> tuple[float, ...]:
        """The coefficients of the controller's model (:attr:`LegModel.coefficients`);
        zeros when it uses none."""
        if self.model is None:
            return (0.0,) * N_COEFFICIENTS
        return self.model.coefficients


def PDGravity(model: LegModel, Kp: ArrayLike | None = None, Kd: ArrayLike | None = None,  # noqa: N802
              saturation: ArrayLike | bool | None = None) -> Controller:
    """PD impedance control with gravity compensation (paper eq 23):
    u = Kp (q_ref - q) + Kd (dq_ref - dq) + G(q), G from ``model``.

    Parameters
    ----------
    model : LegModel
        The leg whose G(q) is compensated.
    Kp : array_like, optional
        N m/rad per joint; default the paper's diag(80, 80, 50).
    Kd : array_like, optional
        N m s/rad per joint; default the paper's diag(12, 12, 2).
    saturation : array_like or bool, optional
        Torque limits per joint, N m; True: the paper's Table 2; default none.

    Returns
    -------
    Controller
        A frozen record; :meth:`Controller.torque` evaluates it.
    """
    g = paper.controller_gains()
    return Controller(_gains("PDGravity", "Kp", Kp, g.kp), _gains("PDGravity", "Kd", Kd, g.kd),
                      model, _limits("PDGravity", saturation), laws.Law.PD_GRAVITY, "PDGravity")


def PD(Kp: ArrayLike | None = None, Kd: ArrayLike | None = None,  # noqa: N802
       saturation: ArrayLike | bool | None = None) -> Controller:
    """Plain PD without gravity compensation: the baseline that shows what G buys.

    Parameters
    ----------
    Kp : array_like, optional
        N m/rad per joint; default the paper's.
    Kd : array_like, optional
        N m s/rad per joint; default the paper's.
    saturation : array_like or bool, optional
        Torque limits per joint, N m; True: the paper's Table 2; default none.

    Returns
    -------
    Controller
        A frozen record; :meth:`Controller.torque` evaluates it.
    """
    g = paper.controller_gains()
    return Controller(_gains("PD", "Kp", Kp, g.kp), _gains("PD", "Kd", Kd, g.kd), None,
                      _limits("PD", saturation), laws.Law.PD, "PD")


def ComputedTorque(model: LegModel, Kp: ArrayLike, Kd: ArrayLike,  # noqa: N802
                   saturation: ArrayLike | bool | None = None) -> Controller:
    """Computed torque: u = M(q)(ddq_ref + Kp e + Kd de) + C dq + G, from ``model``.

    Parameters
    ----------
    model : LegModel
        The leg whose dynamics are inverted.
    Kp : array_like
        1/s^2 per joint (the error dynamics' stiffness).
    Kd : array_like
        1/s per joint.
    saturation : array_like or bool, optional
        Torque limits per joint, N m; True: the paper's Table 2; default none.

    Returns
    -------
    Controller
        A frozen record; :meth:`Controller.torque` evaluates it.
    """
    return Controller(_gains("ComputedTorque", "Kp", Kp, np.zeros(3)),
                      _gains("ComputedTorque", "Kd", Kd, np.zeros(3)), model,
                      _limits("ComputedTorque", saturation), laws.Law.COMPUTED_TORQUE,
                      "ComputedTorque")


#: Computed torque's default gains, 1/s^2 and 1/s: error dynamics of 20 rad/s, damped
#: critically (Kd = 2 sqrt(Kp)).
CT_GAINS = (400.0, 40.0)


def law_named(name: str, model: LegModel, Kp: ArrayLike | None = None,  # noqa: N803
              Kd: ArrayLike | None = None, saturation: ArrayLike | bool | None = None
              ) -> Controller:
    """The law called ``name`` (:data:`LAWS`) on ``model`` with its defaults where the
    gains are not given."""
    if name == "pd-gravity":
        return PDGravity(model, Kp, Kd, saturation=saturation)
    if name == "pd":
        return PD(Kp, Kd, saturation=saturation)
    if name == "computed-torque":
        return ComputedTorque(model, [CT_GAINS[0]] * 3 if Kp is None else Kp,
                              [CT_GAINS[1]] * 3 if Kd is None else Kd, saturation=saturation)
    raise ParameterError("controller", "name", f"unknown {name!r} (allowed: "
                         + ", ".join(LAWS) + ")")
