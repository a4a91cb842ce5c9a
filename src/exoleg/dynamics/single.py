"""One state from Python, cheap enough for a user's own loop.

The generated kernels are wrapped as numba ``cfunc`` s with one C signature::

    int32 k(double *a, double *b, double *c, double *p, double g, double *out)

(``a``, ``b``, ``c``: up to three state vectors (3,), ``p`` the leg's parameters
(``N_PARAMS``,), ``out`` the result; returns 1 when every output is finite). The small C
extension :mod:`exoleg.dynamics._onecall` calls them by address: it checks that each
argument is one C-contiguous float64 state, allocates the result and calls the
kernel, about 0.1 us in all, where a numba dispatcher call alone costs about 0.3 us.
It returns None for anything else (lists, batches, other dtypes, a non-finite
result) and :class:`~exoleg.LegModel` then takes its general path.

The physics stays in the generated kernels; the C file holds no formula. Without
a C compiler at install time the extension is absent, :func:`call` is None and
every call takes the general path (same results, a few microseconds per call).
The cfuncs are compiled (or loaded from numba's cache) on first use, not at import.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from functools import cache
from typing import Any

from numba import carray, cfunc, njit, types

from exoleg.dynamics import kernels as K

try:
    from exoleg.dynamics._onecall import call
except ImportError:  # built without a C compiler: LegModel uses its general path
    call = None

#: shape codes of ``_onecall.call``
VECTOR, MATRIX, POINTS = 0, 1, 2

_D = types.CPointer(types.float64)
_SIG = types.int32(_D, _D, _D, _D, types.float64, _D)


@njit(inline="always")
def _finite(o):  # type: ignore[no-untyped-def]
    for v in o.flat:
        if not math.isfinite(v):
            return 0
    return 1


def _mass_matrix() -> Any:
    @cfunc(_SIG, cache=True)
    def f(a, b, c, p, g, out):  # type: ignore[no-untyped-def]
        o = carray(out, (3, 3))
        K.mass_matrix(carray(a, 3), carray(p, K.N_PARAMS), o)
        return _finite(o)
    return f


def _coriolis_matrix() -> Any:
    @cfunc(_SIG, cache=True)
    def f(a, b, c, p, g, out):  # type: ignore[no-untyped-def]
        o = carray(out, (3, 3))
        K.coriolis_matrix(carray(a, 3), carray(b, 3), carray(p, K.N_PARAMS), o)
        return _finite(o)
    return f


def _mass_matrix_dot() -> Any:
    @cfunc(_SIG, cache=True)
    def f(a, b, c, p, g, out):  # type: ignore[no-untyped-def]
        o = carray(out, (3, 3))
        K.mass_matrix_dot(carray(a, 3), carray(b, 3), carray(p, K.N_PARAMS), o)
        return _finite(o)
    return f


def _coriolis_dq() -> Any:
    @cfunc(_SIG, cache=True)
    def f(a, b, c, p, g, out):  # type: ignore[no-untyped-def]
        o = carray(out, 3)
        K.coriolis_dq(carray(a, 3), carray(b, 3), carray(p, K.N_PARAMS), o)
        return _finite(o)
    return f


def _gravity() -> Any:
    @cfunc(_SIG, cache=True)
    def f(a, b, c, p, g, out):  # type: ignore[no-untyped-def]
        o = carray(out, 3)
        K.gravity(carray(a, 3), carray(p, K.N_PARAMS), g, o)
        return _finite(o)
    return f


def _forward_dynamics() -> Any:
    @cfunc(_SIG, cache=True)
    def f(a, b, c, p, g, out):  # type: ignore[no-untyped-def]
        o = carray(out, 3)
        K.forward_dynamics(carray(a, 3), carray(b, 3), carray(c, 3), carray(p, K.N_PARAMS), g, o)
        return _finite(o)
    return f


def _inverse_dynamics() -> Any:
    @cfunc(_SIG, cache=True)
    def f(a, b, c, p, g, out):  # type: ignore[no-untyped-def]
        o = carray(out, 3)
        K.inverse_dynamics(carray(a, 3), carray(b, 3), carray(c, 3), carray(p, K.N_PARAMS), g, o)
        return _finite(o)
    return f


#: the parameter vector's layout (the generated kernels' declaration)
_PER_LINK = len(K.LINK_PARAMS)
_A, _CX, _CY = (K.LINK_PARAMS.index(n) for n in ("a", "cx", "cy"))


def _forward_kinematics() -> Any:
    @cfunc(_SIG, cache=True)
    def f(a, b, c, p_, g, out):  # type: ignore[no-untyped-def]
        """Rows of out (8, 2): hip, knee, ankle, toe, com_thigh, com_shank, com_foot
        (x, y, m) and (phi, 0): what kinematics.forward_kinematics gives for one state,
        by its formula (sin and cos of the absolute angles, which the IK inverts to
        5.5e-13 rad; the compiled plant and controller use the generated kinematics)."""
        q = carray(a, 3)
        p = carray(p_, K.N_PARAMS)
        o = carray(out, (8, 2))
        x = 0.0
        y = 0.0
        phi = 0.0
        o[0, 0] = 0.0
        o[0, 1] = 0.0
        for i in range(3):
            phi += q[i] + K.OFFSETS[i]
            cs = math.cos(phi)
            sn = math.sin(phi)
            cx = p[_PER_LINK * i + _CX]
            cy = p[_PER_LINK * i + _CY]
            o[4 + i, 0] = x + cs * cx - sn * cy
            o[4 + i, 1] = y + sn * cx + cs * cy
            x += p[_PER_LINK * i + _A] * cs
            y += p[_PER_LINK * i + _A] * sn
            o[i + 1, 0] = x
            o[i + 1, 1] = y
        o[7, 0] = phi - (K.OFFSETS[0] + K.OFFSETS[1] + K.OFFSETS[2])
        o[7, 1] = 0.0
        return _finite(o)
    return f


_BUILDERS: dict[str, Callable[[], Any]] = {
    "mass_matrix": _mass_matrix, "coriolis_matrix": _coriolis_matrix,
    "mass_matrix_dot": _mass_matrix_dot, "coriolis_dq": _coriolis_dq, "gravity": _gravity,
    "forward_dynamics": _forward_dynamics, "inverse_dynamics": _inverse_dynamics,
    "forward_kinematics": _forward_kinematics,
}
NAMES = tuple(_BUILDERS)


@cache
def _compiled(name: str) -> Any:
    return _BUILDERS[name]()  # kept here: the address is valid while the cfunc lives


class _Addresses:
    """``ADDRESS.gravity``: the address of that kernel's cfunc, built (or loaded from
    numba's cache) on first access, then a plain attribute."""

    def __getattr__(self, name: str) -> int:
        if name not in _BUILDERS:
            raise AttributeError(name)
        addr = int(_compiled(name).address)
        setattr(self, name, addr)
        return addr


ADDRESS: Any = _Addresses()
