"""Small validators shared by every parameter record and loader.

Each raises :class:`~exoleg.errors.ParameterError` naming where the value came
from, the field and what is allowed, so a bad file never surfaces as a
traceback from deep inside numpy or as a silent NaN.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from exoleg.errors import ParameterError


def finite(where: str, field: str, value: Any) -> float:
    """Return ``value`` as a float; it must be a finite real number."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.floating, np.integer)):
        raise ParameterError(where, field, f"expected a number, got {value!r}")
    x = float(value)
    if not math.isfinite(x):
        raise ParameterError(where, field, f"must be a finite number, got {x!r}")
    return x


def whole(where: str, field: str, value: Any, lo: int, hi: int) -> int:
    """Return ``value`` as an int; it must be a whole number within ``lo``-``hi`` (6.0 is,
    6.5 and ``true`` are not)."""
    x = finite(where, field, value)
    if x != int(x) or not lo <= x <= hi:
        raise ParameterError(where, field, f"{value!r}: expected a whole number "
                             f"{lo}-{hi}")
    return int(x)


def name(where: str, field: str, value: Any) -> str:
    """Return ``value``, a child's name: text, not blank, at most :data:`NAME_MAX`
    characters (any characters: their files escape them, ``tests/test_bad_input_
    surfaces.py``)."""
    if not isinstance(value, str) or not value.strip():
        raise ParameterError(where, field, f"{value!r}: the child's name as text, not blank")
    if len(value) > NAME_MAX:
        raise ParameterError(where, field, f"{len(value)} characters: a child's name has at "
                                           f"most {NAME_MAX}")
    return value


#: The longest child's name the records take, in characters.
NAME_MAX = 100


def positive(where: str, field: str, value: Any, unit: str = "") -> float:
    """Return ``value`` as a float; it must be finite and > 0."""
    x = finite(where, field, value)
    if x <= 0.0:
        u = f" {unit}" if unit else ""
        raise ParameterError(where, field, f"must be > 0{u}, got {x!r}")
    return x


def within(where: str, field: str, value: Any, lo: float, hi: float, unit: str = "",
           why: str = "") -> float:
    """Return ``value`` as a float; it must be finite and within ``lo``-``hi`` (the error
    says the range in ``unit``, and ``why`` when given)."""
    x = finite(where, field, value)
    if not lo <= x <= hi:
        u = f" {unit}" if unit else ""
        raise ParameterError(where, field, f"{x:g}{u} is outside {lo:g}-{hi:g}{u}"
                             + (f" ({why})" if why else ""))
    return x


def vector_within(where: str, field: str, value: Any, n: int, lo: float, hi: float,
                  scale: float = 1.0) -> NDArray[np.float64]:
    """Return ``value`` as a finite float vector of length ``n``, each element times
    ``scale`` (the unit people read: degrees for radians) within ``lo``-``hi``."""
    v = vector(where, field, value, n)
    if np.any(v * scale < lo) or np.any(v * scale > hi):
        raise ParameterError(where, field, f"{(v * scale).tolist()} is outside "
                             f"{lo:g}-{hi:g} per element")
    return v


def vector(where: str, field: str, value: Any, n: int) -> NDArray[np.float64]:
    """Return ``value`` as a finite float vector of length ``n``."""
    if isinstance(value, (str, bytes)) or not isinstance(value, (Sequence, np.ndarray)):
        raise ParameterError(where, field, f"expected a list of {n} numbers, got {value!r}")
    if len(value) != n:
        raise ParameterError(where, field, f"expected {n} numbers, got {len(value)}")
    return np.array([finite(where, f"{field}[{i}]", v) for i, v in enumerate(value)])


def reading(where: str, field: str, value: Any, n: int) -> NDArray[np.float64]:
    """Return a measured or commanded vector of ``n`` numbers as floats. Non-finite values
    pass (the safety layer latches a fault on them); anything but ``n`` real numbers --
    another length, a table, text, booleans -- is refused, naming the field."""
    if type(value) is np.ndarray and value.dtype == np.float64 and value.shape == (n,):
        return value  # the loop's own readings: as they are
    try:
        a = np.asarray(value)
    except (TypeError, ValueError):
        a = np.asarray(None)
    if a.shape != (n,) or a.dtype.kind not in "fiu":
        got = f"shape {a.shape} of {a.dtype}" if a.dtype != object else repr(value)[:60]
        raise ParameterError(where, field, f"expected {n} numbers, got {got}")
    return a if a.dtype == np.float64 else a.astype(np.float64)


def repeated(values: Sequence[Any]) -> Any:
    """The first value listed again in ``values`` (equal, as 8 and 8.0 are), or None."""
    return next((v for i, v in enumerate(values) if v in values[:i]), None)


def keys(where: str, table: Mapping[str, Any], required: Iterable[str],
         optional: Iterable[str] = ()) -> None:
    """Check a table has every required key and no unknown one (and is a table)."""
    req = list(required)
    if not isinstance(table, Mapping):
        raise ParameterError(where, "(table)", f"expected a table of "
                             f"{', '.join(req + list(optional)) or 'fields'}, got "
                             f"{type(table).__name__} {str(table)[:40]!r}")
    allowed = set(req) | set(optional)
    for k in req:
        if k not in table:
            raise ParameterError(where, k, "missing (required fields: " + ", ".join(req) + ")")
    for k in table:
        if k not in allowed:
            raise ParameterError(
                where, k, "unknown field (allowed: " + ", ".join(sorted(allowed)) + ")"
            )


def ranged(where: str, table: Any, spec: Mapping[str, tuple[float, float, str]],
           optional: Iterable[str] = ("source",)) -> dict[str, float]:
    """The numbers of ``table`` named in ``spec`` (name -> (lower, upper, unit)), each
    finite and within its range; no key missing, none unknown (``optional`` aside)."""
    if not isinstance(table, Mapping):
        raise ParameterError(where, "(table)", f"expected a table of {', '.join(spec)}")
    keys(where, table, spec, optional)
    return {name: within(where, name, table[name], lo, hi, unit)
            for name, (lo, hi, unit) in spec.items()}
