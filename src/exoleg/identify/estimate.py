"""Estimating the leg's inertial parameters from joint motion and torque.

Given samples of the joint angles, rates, accelerations and torques,

    tau = Y(q, dq, ddq) pi + F(dq) theta

(:mod:`exoleg.identify.base`). An ordinary least-squares fit on the base parameters
first says whether the motion excites every one and how noisy each joint's torque is
(Gautier & Poignet's two-step weighting: each joint's rows are then weighted by the
inverse of its residual's SD). The full parameters -- what a leg file holds -- are then
estimated with the fitted model as a prior (Gaussian, SDs :func:`prior_sd`: the rotors'
inertia from their datasheets trusted more than a child's segment from anthropometric
tables): the data
decide what they can tell, the prior the rest (a maximum a posteriori estimate,
``(W^T W + P) pi = W^T tau_w + P pi_0``); the base parameters and their SDs are the
full estimate's, ``K pi`` and ``K C K^T``. The result is checked for physical consistency (per link
m > 0 and m ZZ >= MX^2 + MY^2, the planar case of Wensing et al. 2017) and refused,
naming the link, when it is not.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from exoleg.dynamics.kernels import N_JOINTS
from exoleg.dynamics.model import LegModel
from exoleg.errors import ParameterError
from exoleg.identify.base import BaseParameters, base_parameters, friction_columns

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class Identified:
    """An identification: the base parameters (``names``, ``values``, their standard
    deviations ``sd``), the friction per joint (viscous N m s/rad, Coulomb N m) and its
    SD, the leg with the identified parameters (``leg``: the prior's moved to them), the
    residual's RMS per joint (N m), the number of samples, and the SDs of the leg's
    parameters in :func:`prior_sd`'s terms (``inertial_sd``: mass, first moments, inertia
    about the centre of mass per link, then the armatures)."""

    names: tuple[str, ...]
    values: F64
    sd: F64
    friction: F64
    friction_sd: F64
    leg: LegModel
    residual_rms: F64
    samples: int
    inertial_sd: F64 | None = None

    def table(self) -> list[dict[str, float | str]]:
        """One row per estimated parameter: name, value, SD, 95 % interval."""
        rows: list[dict[str, float | str]] = []
        names = [*self.names, *(f"{k}{j}" for j in range(N_JOINTS)
                                for k in ("viscous", "coulomb"))]
        vals = np.concatenate([self.values, self.friction.ravel()])
        sds = np.concatenate([self.sd, self.friction_sd.ravel()])
        for n, v, s in zip(names, vals, sds, strict=True):
            rows.append({"parameter": n, "value": float(v), "sd": float(s),
                         "low95": float(v - 1.96 * s), "high95": float(v + 1.96 * s)})
        return rows


def _states(q: ArrayLike, dq: ArrayLike, ddq: ArrayLike, tau: ArrayLike
            ) -> tuple[F64, F64, F64, F64]:
    arrays = []
    for name, a in (("q", q), ("dq", dq), ("ddq", ddq), ("tau", tau)):
        x = np.asarray(a, dtype=float)
        if x.ndim != 2 or x.shape[1] != N_JOINTS:
            raise ParameterError("identify", name, f"expected shape (N, {N_JOINTS}), got "
                                 f"{x.shape}")
        if not np.isfinite(x).all():
            raise ParameterError("identify", name, "holds a value that is not finite")
        arrays.append(x)
    if len({len(x) for x in arrays}) != 1:
        raise ParameterError("identify", "samples", "q, dq, ddq and tau differ in length")
    return arrays[0], arrays[1], arrays[2], arrays[3]


def identify_leg(prior: LegModel, q: ArrayLike, dq: ArrayLike, ddq: ArrayLike,
                 tau: ArrayLike, friction_smoothing: ArrayLike | None = None,
                 base: BaseParameters | None = None,
                 prior_sds: ArrayLike | None = None
                 ) -> Identified:
    """The leg identified from samples (N, 3) of q, dq, ddq (rad, rad/s, rad/s^2) and the
    joint torques tau (N m): base parameters by weighted least squares, friction with
    them when ``friction_smoothing`` (rad/s per joint: the Coulomb term's) is given, the
    full parameters from ``prior`` (the fitted leg, its geometry the regressor's) and
    their SDs ``prior_sds`` (:func:`prior_sd`'s layout; default :func:`prior_sd`)."""
    Q, DQ, DDQ, TAU = _states(q, dq, ddq, tau)
    n = len(Q)
    b = base_parameters(prior) if base is None else base
    Y = prior.regressor(Q, DQ, DDQ)                                     # (N, 3, 15)
    n_pi = Y.shape[2]
    fric = ([] if friction_smoothing is None
            else [friction_columns(DQ, friction_smoothing)])            # (N, 3, 6)
    A = np.concatenate([b.regressor(Y), *fric], axis=2)                 # base + friction
    cols = A.shape[2]
    if n * N_JOINTS < 2 * cols:
        raise ParameterError("identify", "samples", f"{n} samples give {n * N_JOINTS} "
                             f"equations for {cols} unknowns: give at least "
                             f"{-(-2 * cols // N_JOINTS)}")
    # step 1: ordinary least squares on the base parameters (and friction): is every one
    # excited, and how noisy is each joint's torque
    x, _, rank, _ = np.linalg.lstsq(A.reshape(-1, cols), TAU.ravel(), rcond=None)
    if rank < cols:
        raise ParameterError("identify", "excitation", f"the motion identifies {rank} of "
                             f"the {cols} parameters: excite every joint (speeds and "
                             "accelerations in both directions)")
    res = TAU - A @ x
    floor = 1e-6 * float(np.sqrt(np.mean(TAU**2)))
    sd = np.sqrt(np.maximum(np.mean(res**2, axis=0), floor**2))       # (3,)
    # step 2: the full parameters, each joint's rows weighted by its noise, with the
    # prior on what a body is made of -- mass, first moments, the inertia about the centre
    # of mass (a child's segment's, from the tables), the rotors' armature: prior_sd --
    # so that the estimate stays a body where the data cannot tell; the friction's prior
    # weak (zero, SD 10 N m and 10 N m s/rad). Gauss-Newton on the data's rows (linear:
    # reduced once to their QR's triangle) and the prior's (the centroidal inertia's is
    # not linear), from the prior.
    F = np.concatenate([Y, *fric], axis=2)
    nf = F.shape[2] - n_pi
    Qw, Rw = np.linalg.qr((F / sd[None, :, None]).reshape(-1, F.shape[2]))
    cw = Qw.T @ (TAU / sd[None, :]).ravel()
    x0 = np.concatenate([prior.inertial(), np.zeros(nf)])
    sdp = prior_sd(prior) if prior_sds is None else _check_sd(prior_sds, n_pi)

    def prior_rows(x: NDArray[np.floating]) -> tuple[F64, F64]:
        r: F64 = np.concatenate([(x[:n_pi] - x0[:n_pi]) / sdp, 0.1 * x[n_pi:]])
        J: F64 = np.diag(np.concatenate([1.0 / sdp, np.full(nf, 0.1)]))
        for i in range(N_JOINTS):  # the fourth of each link's: its centroidal inertia
            m, mx, my, zz = x[4 * i:4 * i + 4]
            k = 4 * i + 3
            r[k] = (zz - (mx * mx + my * my) / m - prior.links[i].izz) / sdp[k]
            J[k, 4 * i:4 * i + 4] = [(mx * mx + my * my) / (m * m) / sdp[k],
                                     -2 * mx / m / sdp[k], -2 * my / m / sdp[k], 1.0 / sdp[k]]
        return r, J

    x = x0.copy()
    for _ in range(8):
        rp, Jp = prior_rows(x)
        step, *_ = np.linalg.lstsq(np.vstack([Rw, Jp]),
                                   -np.concatenate([Rw @ x - cw, rp]), rcond=None)
        x = x + step
        if np.abs(step).max() <= 1e-12 * (1.0 + np.abs(x).max()):
            break
    _, R = np.linalg.qr(np.vstack([Rw, prior_rows(x)[1]]))
    Ri = np.linalg.inv(R)
    cov = Ri @ Ri.T                                                     # (J^T J)^-1
    pi = x[:n_pi]
    K = b.K
    base_sd = np.sqrt(np.diag(K @ cov[:n_pi, :n_pi] @ K.T))
    # the posterior's SDs in the prior's terms (the centroidal inertia linearised): what
    # a later identification may take as its prior's (identify.staged)
    D = prior_rows(x)[1][:n_pi, :n_pi] * sdp[:, None]
    post_sd = np.sqrt(np.diag(D @ cov[:n_pi, :n_pi] @ D.T))
    residual = TAU - F @ x
    return Identified(names=b.names, values=np.asarray(K @ pi, dtype=np.float64),
                      sd=np.asarray(base_sd, dtype=np.float64),
                      friction=np.asarray(x[n_pi:].reshape(-1, 2), dtype=np.float64),
                      friction_sd=np.asarray(np.sqrt(np.diag(cov))[n_pi:].reshape(-1, 2),
                                             dtype=np.float64),
                      leg=leg_of(prior, np.asarray(pi, dtype=np.float64)),
                      residual_rms=np.sqrt(np.mean(residual**2, axis=0)), samples=n,
                      inertial_sd=np.asarray(post_sd, dtype=np.float64))


#: How far the prior is trusted, one SD: a link's mass, first moments and inertia about
#: its centre of mass ("I") this share of their size (a child's segments differ from the
#: tables by 10-20 %), the first moments at least 2 cm x the mass; the rotors' reflected
#: inertia from their datasheets, 2 %.
PRIOR_SD = {"m": 0.15, "MX": 0.15, "MY": 0.15, "I": 0.15, "arm": 0.02}
PRIOR_COM_SD = 0.02


def prior_sd(prior: LegModel) -> F64:
    """One SD (15,) per inertial parameter of the prior (:data:`PRIOR_SD`), in the
    regressor's order -- but in each link's fourth place the SD of its inertia about the
    centre of mass, on which the prior is (not on ZZ, the inertia about the joint)."""
    pi0 = prior.inertial()
    out = np.empty_like(pi0)
    for i, link in enumerate(prior.links):
        m = pi0[4 * i]
        out[4 * i] = PRIOR_SD["m"] * m
        for k, name in ((1, "MX"), (2, "MY")):
            out[4 * i + k] = max(PRIOR_SD[name] * abs(pi0[4 * i + k]), PRIOR_COM_SD * m)
        out[4 * i + 3] = PRIOR_SD["I"] * link.izz
    out[4 * N_JOINTS:] = PRIOR_SD["arm"] * np.abs(pi0[4 * N_JOINTS:])
    return np.maximum(out, 1e-9)


def _check_sd(sd: ArrayLike, n: int) -> F64:
    v = np.asarray(sd, dtype=np.float64)
    if v.shape != (n,) or not np.all(np.isfinite(v)) or np.any(v <= 0):
        raise ParameterError("identify", "prior_sds", f"expected {n} positive finite SDs "
                             "(prior_sd's layout)")
    return v


def leg_of(prior: LegModel, pi: F64, name: str | None = None) -> LegModel:
    """The leg with the inertial parameters ``pi`` (the regressor's order) and ``prior``'s
    geometry, called ``name`` (default: the prior's, identified); refused (naming the
    link) when it is not a physical body."""
    links = []
    for i, link in enumerate(prior.links):
        m, mx, my, zz = pi[4 * i:4 * i + 4]
        if not (m > 0 and m * zz >= mx * mx + my * my):
            raise ParameterError("identify", f"link {link.name}",
                                 f"the identified parameters are not a body (m {m:.4g} kg, "
                                 f"m ZZ {m * zz:.4g} < MX^2 + MY^2 {mx * mx + my * my:.4g}): "
                                 "more excitation, or a closer prior")
        cx, cy = mx / m, my / m
        links.append(dataclasses.replace(link, mass=float(m), com=(float(cx), float(cy)),
                                         izz=float(zz - m * (cx * cx + cy * cy)), parts=()))
    arm = pi[4 * N_JOINTS:]
    if np.any(arm < 0):
        raise ParameterError("identify", "armature", f"identified {np.round(arm, 4).tolist()}"
                             " kg m^2: an armature is never negative")
    return LegModel(links, g=prior.g, name=name or f"{prior.name} (identified)", armature=arm)
