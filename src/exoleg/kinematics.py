"""Kinematics of the leg (paper section 3): D-H transforms, forward and inverse kinematics,
Jacobians.

Conventions (``docs/conventions.md``): sagittal plane, x forward, y up, hip at
the origin; q = (hip, knee, ankle) in rad; q = 0 is quiet standing. Link ``i``'s
absolute angle is ``phi_i = sum_{k<=i} (q_k + offset_k)`` with the D-H offsets
(-pi/2, 0, +pi/2) of Table 3. Hip flexion > 0, knee flexion < 0, ankle
dorsiflexion > 0.

Everything here is plain numpy and broadcasts over leading axes: ``q`` may be
``(3,)`` or ``(..., 3)``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from exoleg.errors import ParameterError, UnreachableError

F64 = NDArray[np.float64]
Branch = Literal["flexed", "extended"]

#: Names of the points :func:`forward_kinematics` returns, in order.
POINTS = ("hip", "knee", "ankle", "toe", "com_thigh", "com_shank", "com_foot")


def dh_transform(theta: ArrayLike, a: float) -> F64:
    """Homogeneous D-H transform with d = alpha = 0 (paper eqs 1-3): shape (..., 4, 4)."""
    th = np.asarray(theta, dtype=float)
    c, s = np.cos(th), np.sin(th)
    T = np.zeros(th.shape + (4, 4))
    T[..., 0, 0], T[..., 0, 1], T[..., 0, 3] = c, -s, a * c
    T[..., 1, 0], T[..., 1, 1], T[..., 1, 3] = s, c, a * s
    T[..., 2, 2] = T[..., 3, 3] = 1.0
    return T


def link_angles(q: ArrayLike, offsets: Sequence[float]) -> F64:
    """Absolute link angles phi (..., 3), rad: cumulative sums of q + offsets."""
    return np.cumsum(np.asarray(q, dtype=float) + np.asarray(offsets), axis=-1)


def _rot(phi: F64, v: F64) -> F64:
    """Rotate the 2-vector v (broadcast) by phi."""
    c, s = np.cos(phi), np.sin(phi)
    return np.stack([c * v[..., 0] - s * v[..., 1], s * v[..., 0] + c * v[..., 1]], axis=-1)


def forward_kinematics(q: ArrayLike, lengths: ArrayLike, coms: ArrayLike,
                       offsets: Sequence[float]) -> dict[str, F64]:
    """Positions of the joints, the toe and every COM (paper eqs 5-6).

    Returns a dict of :data:`POINTS` -> (..., 2) arrays (m), plus ``"phi"``: the foot
    orientation Phi = q1 + q2 + q3 (...,) in rad (the sum of the offsets is 0).
    """
    phi = link_angles(q, offsets)
    a = np.asarray(lengths, dtype=float)
    c = np.asarray(coms, dtype=float)
    unit = np.stack([np.cos(phi), np.sin(phi)], axis=-1)  # (..., 3, 2)
    joints = [np.zeros(phi.shape[:-1] + (2,))]
    for i in range(3):
        joints.append(joints[-1] + a[i] * unit[..., i, :])
    out = {"hip": joints[0], "knee": joints[1], "ankle": joints[2], "toe": joints[3]}
    for i, name in enumerate(("com_thigh", "com_shank", "com_foot")):
        out[name] = joints[i] + _rot(phi[..., i], c[i])
    out["phi"] = phi[..., 2] - float(np.sum(offsets))
    return out


def point_jacobian(point: F64, joints: Sequence[F64], upto: int) -> F64:
    """Planar linear Jacobian (..., 2, 3) of ``point`` on link ``upto`` (0-based).

    Column j (j <= upto) is z x (point - joint_j); later columns are zero.
    """
    J = np.zeros(point.shape[:-1] + (2, 3))
    for j in range(upto + 1):
        r = point - joints[j]
        J[..., 0, j] = -r[..., 1]
        J[..., 1, j] = r[..., 0]
    return J


def jacobians(q: ArrayLike, lengths: ArrayLike, coms: ArrayLike,
              offsets: Sequence[float]) -> dict[str, F64]:
    """Linear Jacobians d(position)/dq (..., 2, 3) of the toe and every COM.

    The angular Jacobian of link i is the row [1]*(i+1) + [0]*(2-i) (planar chain).
    """
    fk = forward_kinematics(q, lengths, coms, offsets)
    joints = [fk["hip"], fk["knee"], fk["ankle"]]
    return {
        "toe": point_jacobian(fk["toe"], joints, 2),
        "com_thigh": point_jacobian(fk["com_thigh"], joints, 0),
        "com_shank": point_jacobian(fk["com_shank"], joints, 1),
        "com_foot": point_jacobian(fk["com_foot"], joints, 2),
    }


def _wrap(x: F64) -> F64:
    """Angle into (-pi, pi]."""
    return np.pi - np.mod(np.pi - x, 2 * np.pi)


def inverse_kinematics(x: ArrayLike, y: ArrayLike, phi: ArrayLike, lengths: ArrayLike,
                       branch: Branch = "flexed") -> F64:
    """Joint angles (..., 3) that put the toe at (x, y) with foot orientation phi.

    The exact inverse of :func:`forward_kinematics` (paper eqs 8-14, with the
    ankle at (x - a3 cos phi, y - a3 sin phi): eq 7 as printed does not invert
    eqs 5-6, see ``docs/conventions.md``). ``branch="flexed"`` returns the knee
    flexed (q2 <= 0, the paper's root of eq 10); ``"extended"`` the other root.
    Angles are wrapped into (-pi, pi]. Raises :class:`UnreachableError` when the
    ankle is farther from the hip than a1 + a2 or nearer than abs(a1 - a2).
    """
    if branch not in ("flexed", "extended"):
        raise ParameterError("inverse_kinematics", "branch",
                             f"unknown {branch!r} (allowed: 'flexed', 'extended')")
    a1, a2, a3 = (float(v) for v in np.asarray(lengths, dtype=float))
    X, Y, P = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (x, y, phi)))
    if not (np.all(np.isfinite(X)) and np.all(np.isfinite(Y)) and np.all(np.isfinite(P))):
        raise ParameterError("inverse_kinematics", "x/y/phi", "must be finite numbers")
    ax = X - a3 * np.cos(P)
    ay = -(Y - a3 * np.sin(P))  # eq 8 measures y downward
    c2 = (ax * ax + ay * ay - a1 * a1 - a2 * a2) / (2 * a1 * a2)
    bad = np.abs(c2) > 1.0 + 1e-12
    if np.any(bad):
        r = np.hypot(ax, ay)[bad].ravel()[0]
        raise UnreachableError(
            f"inverse_kinematics: target out of reach: the ankle would be {r:.4f} m from the "
            f"hip; reachable distances are {abs(a1 - a2):.4f} to {a1 + a2:.4f} m "
            f"(a1={a1}, a2={a2}, a3={a3})"
        )
    t2 = np.arccos(np.clip(c2, -1.0, 1.0))
    if branch == "flexed":
        t2 = -t2
    t1 = np.arctan2(ax, ay) - np.arctan2(a2 * np.sin(t2), a1 + a2 * np.cos(t2))
    t3 = P - t1 - t2
    return np.stack([_wrap(t1), t2, _wrap(t3)], axis=-1)
