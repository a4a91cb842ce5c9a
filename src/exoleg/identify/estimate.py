"""Estimating the leg's inertial parameters from joint motion and torque.

Given samples of the joint angles, rates, accelerations and torques, the base parameters
and the actuators' friction are the weighted least-squares solution of

    tau = Y_b(q, dq, ddq) pi_b + F(dq) theta

(:mod:`exoleg.identify.base`), each joint's rows weighted by the inverse of its noise
(the residual's standard deviation per joint of an ordinary fit first: Gautier &
Poignet's two-step weighting), with the parameters' standard deviations from the
weighted residual. The full parameters -- what a leg file holds -- are the prior's (the
fitted model's) moved as little as possible to match the identified base parameters:
``pi = pi_0 + K^T (K K^T)^-1 (pi_b - K pi_0)``, the least-norm change; the data cannot
see the rest. The result is checked for physical consistency (per link m > 0 and
m ZZ >= MX^2 + MY^2, the planar case of Wensing et al. 2017) and refused, naming the
link, when it is not.
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
    residual's RMS per joint (N m) and the number of samples."""

    names: tuple[str, ...]
    values: F64
    sd: F64
    friction: F64
    friction_sd: F64
    leg: LegModel
    residual_rms: F64
    samples: int

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
                 base: BaseParameters | None = None) -> Identified:
    """The leg identified from samples (N, 3) of q, dq, ddq (rad, rad/s, rad/s^2) and the
    joint torques tau (N m): base parameters by weighted least squares, friction with
    them when ``friction_smoothing`` (rad/s per joint: the Coulomb term's) is given, the
    full parameters from ``prior`` (the fitted leg, its geometry the regressor's)."""
    Q, DQ, DDQ, TAU = _states(q, dq, ddq, tau)
    n = len(Q)
    b = base_parameters(prior) if base is None else base
    Yb = b.regressor(prior.regressor(Q, DQ, DDQ))                      # (N, 3, r)
    blocks = [Yb]
    if friction_smoothing is not None:
        blocks.append(friction_columns(DQ, friction_smoothing))
    A = np.concatenate(blocks, axis=2)                                  # (N, 3, r + 6)
    cols = A.shape[2]
    if n * N_JOINTS < 2 * cols:
        raise ParameterError("identify", "samples", f"{n} samples give {n * N_JOINTS} "
                             f"equations for {cols} unknowns: give at least "
                             f"{-(-2 * cols // N_JOINTS)}")
    # step 1: ordinary least squares; step 2: rows weighted by each joint's residual SD
    x, *_ = np.linalg.lstsq(A.reshape(-1, cols), TAU.ravel(), rcond=None)
    res = TAU - A @ x
    sd = np.sqrt(np.maximum(np.mean(res**2, axis=0), 1e-30))            # (3,)
    W = (A / sd[None, :, None]).reshape(-1, cols)
    w_tau = (TAU / sd[None, :]).ravel()
    x, *_ = np.linalg.lstsq(W, w_tau, rcond=None)
    rank = np.linalg.matrix_rank(W)
    if rank < cols:
        raise ParameterError("identify", "excitation", f"the motion identifies {rank} of "
                             f"the {cols} parameters: excite every joint (speeds and "
                             "accelerations in both directions)")
    res_w = w_tau - W @ x
    sigma2 = float(res_w @ res_w) / max(1, len(w_tau) - cols)
    cov = sigma2 * np.linalg.inv(W.T @ W)
    stdev = np.sqrt(np.diag(cov))
    r = len(b.columns)
    pi_b = x[:r]
    leg = _with_base(prior, b, pi_b)
    residual = TAU - A @ x
    fr = x[r:].reshape(-1, 2) if cols > r else np.zeros((0, 2))
    fr_sd = stdev[r:].reshape(-1, 2) if cols > r else np.zeros((0, 2))
    return Identified(names=b.names, values=pi_b, sd=stdev[:r], friction=fr,
                      friction_sd=fr_sd, leg=leg,
                      residual_rms=np.sqrt(np.mean(residual**2, axis=0)), samples=n)


def _with_base(prior: LegModel, b: BaseParameters, pi_b: F64) -> LegModel:
    """``prior`` moved least to have the base parameters ``pi_b``; refused (naming the
    link) when the result is not a physical body."""
    pi0 = prior.inertial()
    K = b.K
    pi = pi0 + K.T @ np.linalg.solve(K @ K.T, pi_b - K @ pi0)
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
    return LegModel(links, g=prior.g, name=f"{prior.name} (identified)", armature=arm)
