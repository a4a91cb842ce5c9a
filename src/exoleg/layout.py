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


def enum_table(*enums: type[IntEnum]) -> dict[str, dict[str, int]]:
    """The names and values of enumerations, for a page or a log reader that must not
    keep its own copy."""
    return {e.__name__: {m.name: int(m.value) for m in e} for e in enums}
