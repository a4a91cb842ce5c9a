"""Compiled kernels of the leg's dynamics: the scalar kernels and broadcasting gufuncs.

The scalar kernels (``mass_matrix``, ``gravity``, ``forward_dynamics``, ...) come
from ``_generated.py`` (see :mod:`exoleg.dynamics.codegen`) and are meant to be
called from other numba code (the simulator's loop); each writes into an
``out`` array. Those that take the posture have a ``*_trig`` twin given the joints'
sin and cos (``joint_trig(q)``) instead of taking them from libm: a caller that
evaluates several at one posture takes them once (the same bits). The ``gu_*``
gufuncs wrap them for numpy callers and broadcast over leading axes:
``gufunc("mass_matrix")(q (..., 3), p (18,)) -> (..., 3, 3)``.
They are built (or loaded from numba's cache) on first use, not at import.

``p`` is the parameter vector, link by link ``(m, a, cx, cy, Izz)``, then the three
joint armatures; see :meth:`exoleg.LegModel.p`.
"""

from __future__ import annotations

from collections.abc import Callable
from functools import cache
from pathlib import Path
from typing import Any

import numpy as np
from numba import guvectorize, njit

from exoleg._cache import building
from exoleg.dynamics._generated import (
    BARYCENTRIC,
    JOINT_PARAMS,
    LINK_PARAMS,
    N_COEFFICIENTS,
    N_INERTIAL,
    N_JOINTS,
    N_PARAMS,
    OFFSETS,
    coefficients,
    com_points,
    coriolis_dq,
    coriolis_dq_trig,
    coriolis_matrix,
    diagnostics,
    foot_point,
    foot_point_jacobian,
    foot_point_jacobian_trig,
    foot_point_trig,
    forward_dynamics,
    forward_dynamics_sc,
    gravity,
    gravity_sc,
    gravity_trig,
    inverse_dynamics,
    inverse_dynamics_sc,
    joint_points,
    joint_trig,
    kinetic_energy,
    links_mass,
    mass_height,
    mass_height_terms,
    mass_height_terms_trig,
    mass_matrix,
    mass_matrix_dot,
    mass_matrix_trig,
    potential_energy,
    regressor,
)

__all__ = [
    "BARYCENTRIC",
    "JOINT_PARAMS",
    "LINK_PARAMS",
    "N_COEFFICIENTS",
    "N_INERTIAL",
    "N_JOINTS",
    "N_PARAMS",
    "OFFSETS",
    "coefficients",
    "com_points",
    "coriolis_dq", "coriolis_dq_trig",
    "coriolis_matrix",
    "diagnostics",
    "forward_dynamics",
    "forward_dynamics_sc",
    "foot_point", "foot_point_jacobian", "foot_point_jacobian_trig", "foot_point_trig",
    "gravity", "gravity_sc", "gravity_trig",
    "gufunc",
    "inverse_dynamics", "inverse_dynamics_sc",
    "joint_points", "joint_trig",
    "kinetic_energy",
    "links_mass",
    "mass_height", "mass_height_terms", "mass_height_terms_trig",
    "mass_matrix", "mass_matrix_trig",
    "mass_matrix_dot",
    "potential_energy",
    "regressor",
]

_V = "float64[:]"
_M = "float64[:, :]"


def _build_mass_matrix() -> Any:
    @guvectorize([f"void({_V}, {_V}, {_M})"], "(n),(k)->(n,n)", cache=True)
    def gu(q, p, out):  # type: ignore[no-untyped-def]
        mass_matrix(q, p, out)
    return gu


def _build_coriolis_matrix() -> Any:
    @guvectorize([f"void({_V}, {_V}, {_V}, {_M})"], "(n),(n),(k)->(n,n)", cache=True)
    def gu(q, dq, p, out):  # type: ignore[no-untyped-def]
        coriolis_matrix(q, dq, p, out)
    return gu


def _build_mass_matrix_dot() -> Any:
    @guvectorize([f"void({_V}, {_V}, {_V}, {_M})"], "(n),(n),(k)->(n,n)", cache=True)
    def gu(q, dq, p, out):  # type: ignore[no-untyped-def]
        mass_matrix_dot(q, dq, p, out)
    return gu


def _build_coriolis_dq() -> Any:
    @guvectorize([f"void({_V}, {_V}, {_V}, {_V})"], "(n),(n),(k)->(n)", cache=True)
    def gu(q, dq, p, out):  # type: ignore[no-untyped-def]
        coriolis_dq(q, dq, p, out)
    return gu


def _build_gravity() -> Any:
    @guvectorize([f"void({_V}, {_V}, float64, {_V})"], "(n),(k),()->(n)", cache=True)
    def gu(q, p, g, out):  # type: ignore[no-untyped-def]
        gravity(q, p, g, out)
    return gu


def _build_forward_dynamics() -> Any:
    @guvectorize([f"void({_V}, {_V}, {_V}, {_V}, float64, {_V})"], "(n),(n),(n),(k),()->(n)",
                 cache=True)
    def gu(q, dq, tau, p, g, out):  # type: ignore[no-untyped-def]
        forward_dynamics(q, dq, tau, p, g, out)
    return gu


def _build_inverse_dynamics() -> Any:
    @guvectorize([f"void({_V}, {_V}, {_V}, {_V}, float64, {_V})"], "(n),(n),(n),(k),()->(n)",
                 cache=True)
    def gu(q, dq, ddq, p, g, out):  # type: ignore[no-untyped-def]
        inverse_dynamics(q, dq, ddq, p, g, out)
    return gu


@njit(cache=True)
def regressor_rows(Q, DQ, DDQ, p, g, out):  # type: ignore[no-untyped-def]
    """:func:`regressor` per row of the states (N, 3) into out (N, 3, N_INERTIAL)."""
    for k in range(Q.shape[0]):
        regressor(Q[k], DQ[k], DDQ[k], p, g, out[k])


def _build_regressor() -> Any:
    # the regressor's column count is not an input's dimension, which a gufunc needs:
    # a compiled loop over the broadcast states instead
    def call(q, dq, ddq, p, g):  # type: ignore[no-untyped-def]
        q, dq, ddq = np.broadcast_arrays(q, dq, ddq)
        shape = q.shape[:-1]
        rows = [np.ascontiguousarray(a.reshape(-1, N_JOINTS)) for a in (q, dq, ddq)]
        out = np.empty((len(rows[0]), N_JOINTS, N_INERTIAL))
        regressor_rows(*rows, p, g, out)
        return out.reshape(*shape, N_JOINTS, N_INERTIAL)
    return call


def _build_kinetic_energy() -> Any:
    @guvectorize([f"void({_V}, {_V}, {_V}, float64[:])"], "(n),(n),(k)->()", cache=True)
    def gu(q, dq, p, out):  # type: ignore[no-untyped-def]
        out[0] = kinetic_energy(q, dq, p)
    return gu


def _build_potential_energy() -> Any:
    @guvectorize([f"void({_V}, {_V}, float64, float64[:])"], "(n),(k),()->()", cache=True)
    def gu(q, p, g, out):  # type: ignore[no-untyped-def]
        out[0] = potential_energy(q, p, g)
    return gu


_BUILDERS: dict[str, Callable[[], Any]] = {
    name[len("_build_"):]: f for name, f in globals().items() if name.startswith("_build_")
}


#: where numba caches this module's gufuncs (beside its source)
_CACHE_FOLDER = Path(__file__).resolve().parent / "__pycache__"


@cache
def gufunc(name: str) -> Any:
    """The broadcasting gufunc of kernel ``name`` (e.g. ``"mass_matrix"``), built once,
    one process at a time (:func:`exoleg._cache.building`: numba's gufunc cache is not
    safe when two processes build the same gufunc at once)."""
    with building(_CACHE_FOLDER):
        return _BUILDERS[name]()
