"""The signals identification reads, from what a device measures: the encoders'
angles differentiated offline (zero phase: the whole recording is at hand)."""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]

#: The differentiator's half window, samples (of 1 ms: 41 ms in all).
HALF_WINDOW = 20


def derivatives(q: F64, dt: float, half: int = HALF_WINDOW) -> tuple[F64, F64, F64]:
    """(q, dq, ddq) smoothed by a local quadratic fit over 2 half + 1 samples (zero phase;
    the first and last ``half`` samples dropped)."""
    x = np.arange(-half, half + 1) * dt
    V = np.vander(x, 3, increasing=True)           # 1, x, x^2
    P = np.linalg.pinv(V)                           # rows: value, slope, half curvature
    out = []
    for row, scale in ((0, 1.0), (1, 1.0), (2, 2.0)):
        kernel = P[row][::-1] * scale
        out.append(np.stack([np.convolve(q[:, j], kernel, mode="valid")
                             for j in range(q.shape[1])], axis=1))
    return out[0], out[1], out[2]
