"""The base parameters: what of the inertial parameters the joint torques can tell.

``tau = Y(q, dq, ddq) pi`` (:meth:`exoleg.LegModel.regressor`) has 15 columns for the
planar three-joint leg, but some are zero or combinations of others whatever the motion:
the torques see only the **base parameters** ``pi_b = K pi``, with ``tau = Y_b pi_b``
and ``Y_b`` some of Y's columns. They are found numerically (Gautier 1991): Y stacked
over random states, its rank ``r`` the number of base parameters, ``r`` independent
columns kept in an order of preference (:data:`PREFERENCE`), the others
written in them (``K = [I, R11^-1 R12]`` in pivoted order). For the planar chain on a
fixed base this is Khalil & Dombre's regrouping: for link j the next links' mass joins
its first moment along the link, ``MXR_j = MX_j + a_j M_(j+1..)``, and its inertia,
``ZZR_j = ZZ_j + a_j^2 M_(j+1..)``; ``MY_j`` stays; the masses and the first joint's
armature (its rotor turns with link 0) vanish into them -- 9 inertial base parameters
and 2 armatures in motion, 6 (the first moments) from static postures alone.

The actuators' friction adds two columns per joint (:func:`friction_columns`): viscous
``dq`` and Coulomb ``tanh(dq / w_s)`` (the actuators' model,
:func:`exoleg.device.drive.friction`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from exoleg.device.actuator import ActuatorModel
from exoleg.dynamics.kernels import BARYCENTRIC, N_JOINTS
from exoleg.dynamics.model import LegModel
from exoleg.errors import ParameterError

F64 = NDArray[np.float64]

#: The inertial parameters' names, in the regressor's column order.
NAMES = tuple(f"{p}{i}" for i in range(N_JOINTS) for p in BARYCENTRIC) + tuple(
    f"arm{i}" for i in range(N_JOINTS))


@dataclass(frozen=True)
class BaseParameters:
    """``pi_b = K pi`` (K: (r, 15)), the independent columns ``columns`` of Y (r,) whose
    product with pi_b is the torque, and their names (the independent parameter each one
    is named after; the others it absorbs are K's off-pivot entries)."""

    K: F64
    columns: tuple[int, ...]

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(NAMES[c] + "R" for c in self.columns)

    def of(self, pi: ArrayLike) -> F64:
        """The base parameters (r,) of the inertial parameters ``pi`` (15,)."""
        return np.asarray(self.K @ np.asarray(pi, dtype=float))

    def regressor(self, Y: ArrayLike) -> F64:
        """Y_b (..., 3, r): the independent columns of ``Y`` (..., 3, 15)."""
        return np.asarray(Y)[..., list(self.columns)]


#: Which column stands for a group, first come first: per link its inertia, then its first
#: moments, then the armatures of the joints that turn a rotor of their own, the masses
#: last (Khalil & Dombre's choice: the masses and the first joint's armature vanish
#: into the inertias and first moments).
PREFERENCE = tuple(f"{p}{i}" for i in range(N_JOINTS) for p in ("ZZ", "MX", "MY")) + tuple(
    f"arm{i}" for i in range(1, N_JOINTS)) + ("arm0",) + tuple(f"m{i}" for i in range(N_JOINTS))


def base_parameters(leg: LegModel, static: bool = False, samples: int = 200,
                    seed: int = 0, tol: float = 1e-9) -> BaseParameters:
    """The base parameters of ``leg``'s regressor over random states (joint angles within
    +-pi, rates 2 rad/s, accelerations 10 rad/s^2; ``static``: at rest, gravity alone) --
    the geometry (the links' lengths) decides them, not the state. The independent
    columns are taken in :data:`PREFERENCE`'s order, each kept when it raises the rank
    (its residual against those kept above ``tol`` of its norm); the others are written
    in them by least squares (exactly: they are combinations)."""
    if not (isinstance(samples, int) and 10 <= samples <= 100_000):
        raise ParameterError("base_parameters", "samples", f"expected 10-100000, got "
                             f"{samples!r}")
    rng = np.random.default_rng(seed)
    q = rng.uniform(-np.pi, np.pi, (samples, N_JOINTS))
    dq = np.zeros_like(q) if static else rng.uniform(-2.0, 2.0, q.shape)
    ddq = np.zeros_like(q) if static else rng.uniform(-10.0, 10.0, q.shape)
    W = leg.regressor(q, dq, ddq).reshape(-1, len(NAMES))
    kept: list[int] = []
    basis = np.zeros((W.shape[0], 0))
    for name in PREFERENCE:
        c = NAMES.index(name)
        col = W[:, c]
        size = float(np.linalg.norm(col))
        if size == 0.0:
            continue
        resid = col - basis @ (basis.T @ col)
        if np.linalg.norm(resid) > tol * size:
            kept.append(c)
            basis = np.column_stack([basis, resid / np.linalg.norm(resid)])
    cols = sorted(kept)
    # every column of W in the kept ones: W = W[:, cols] K
    K, *_ = np.linalg.lstsq(W[:, cols], W, rcond=None)
    K[np.abs(K) < 1e-12] = 0.0
    return BaseParameters(K=np.asarray(K, dtype=np.float64), columns=tuple(cols))


def friction_columns(dq: ArrayLike, smoothing: ArrayLike) -> F64:
    """The friction's regressor (..., 3, 6): per joint its viscous (``dq``) and Coulomb
    (``tanh(dq / smoothing)``) columns, joint by joint -- the friction torque of
    :func:`exoleg.device.drive.friction` is these times (viscous, Coulomb)."""
    v = np.asarray(dq, dtype=float)
    w = np.asarray(smoothing, dtype=float)
    out = np.zeros((*v.shape[:-1], N_JOINTS, 2 * N_JOINTS))
    for j in range(N_JOINTS):
        out[..., j, 2 * j] = v[..., j]
        out[..., j, 2 * j + 1] = np.tanh(v[..., j] / w[j])
    return out


def actuator_friction(actuators: Sequence[ActuatorModel]) -> tuple[F64, F64]:
    """The actuators' friction in :func:`friction_columns`' terms: its coefficients (6,),
    joint by joint viscous (N m s/rad) and Coulomb (N m), and the Coulomb term's smoothing
    speeds (3,) rad/s -- ``friction_columns(dq, smoothing) @ coefficients`` is their
    friction torque."""
    theta = np.ravel([[a.viscous_friction, a.coulomb_friction] for a in actuators])
    return theta, np.array([a.friction_smoothing for a in actuators])
