"""Named layouts for compiled code: every state, parameter and output vector that a
compiled function reads is a numpy structured dtype declared once beside the function
that reads it, and everything else (sizes, slots, log columns, link fields, result
series) is derived from that declaration.

Compiled code takes a layout as a one-element structured array (``rec = a[0]`` inside;
fields by name, ``rec.fault``, ``rec.prev[i]``): numba compiles the field access to the
same load at a constant offset as a hand-kept slot index, keeps caching it, and a
one-element array costs a tenth of a record scalar to pass from Python (measured:
0.06 us against 0.5 us per argument, numba 0.68). A batch (one record per tick) is a
structured array of any length, and ``batch[k]`` passes a record by reference between
compiled functions.

Enumerations (modes, commands, phases, faults, status bits) are :class:`enum.IntEnum`
in compiled code too: numba takes their members as integer constants.
"""

from __future__ import annotations

import functools
from collections.abc import Mapping, Sequence
from enum import IntEnum

import numpy as np
from numpy.typing import NDArray

F8 = np.float64
I8 = np.int64


def new(dtype: np.dtype) -> NDArray[np.void]:
    """One zeroed record of ``dtype``, as the one-element array compiled code takes."""
    return np.zeros(1, dtype)


def column_names(dtype: np.dtype, labels: Mapping[int, Sequence[str]] | None = None,
                 prefix: str = "") -> list[str]:
    """Flat column names of a record: a scalar field is its name; a vector field of n
    values is ``name_label`` for the labels given for n (e.g. 3: the joints), or
    ``name_0`` ... otherwise."""
    out: list[str] = []
    for name in dtype.names or ():
        sub = dtype[name]
        n = int(np.prod(sub.shape)) if sub.shape else 0
        if n == 0:
            out.append(prefix + name)
        else:
            lab = (labels or {}).get(n) or [str(i) for i in range(n)]
            out.extend(f"{prefix}{name}_{x}" for x in lab)
    return out


@functools.cache
def _words(dtype: np.dtype) -> tuple[int, NDArray[np.intp]]:
    """A record of 8-byte numbers as words: (how many, the positions of the integer
    ones); a ValueError for any other layout."""
    pos = 0
    ints: list[int] = []
    for name in dtype.names or ():
        sub, offset = dtype.fields[name][:2]  # type: ignore[index]
        n = int(np.prod(sub.shape)) if sub.shape else 1
        if offset != 8 * pos or sub.base.itemsize != 8 or sub.base.kind not in "fi":
            raise ValueError(f"field {name!r} ({sub}) is not a packed 8-byte number")
        if sub.base.kind == "i":
            ints.extend(range(pos, pos + n))
        pos += n
    if 8 * pos != dtype.itemsize:
        raise ValueError(f"{dtype} has padding")
    return pos, np.array(ints, dtype=np.intp)


def float_columns(records: NDArray[np.void]) -> NDArray[np.float64]:
    """Records of packed 8-byte numbers (float64 and int64 fields, scalars or vectors) as
    their :func:`column_names`' columns, float64, the integers converted -- what
    ``numpy.lib.recfunctions.structured_to_unstructured(records, dtype=float)`` gives,
    in a few microseconds instead of 50 (the session's drain did it 500 times a
    second)."""
    n, ints = _words(records.dtype)
    words = np.ascontiguousarray(records).view(np.int64).reshape(len(records), n)
    out = words.view(np.float64).copy()
    if ints.size:
        out[:, ints] = words[:, ints]
    return out


def enum_table(*enums: type[IntEnum]) -> dict[str, dict[str, int]]:
    """The names and values of enumerations, for a page or a log reader that must not
    keep its own copy."""
    return {e.__name__: {m.name: int(m.value) for m in e} for e in enums}
