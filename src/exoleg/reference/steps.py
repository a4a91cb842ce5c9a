"""Step references (the paper's scenario changes the posture every 3 s, section 6)."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from exoleg.errors import ParameterError

F64 = NDArray[np.float64]


class Reference(Protocol):
    """What the simulator needs of a reference: :meth:`sample`."""

    def sample(self, t: ArrayLike) -> tuple[F64, F64, F64]:
        """q_ref, dq_ref, ddq_ref at times ``t``.

        Parameters
        ----------
        t : array_like
            Times, s, ``(N,)``.

        Returns
        -------
        q_ref, dq_ref, ddq_ref : ndarray
            Each ``(N, 3)``: rad, rad/s, rad/s^2.
        """
        ...


@dataclass(frozen=True)
class Steps:
    """Piecewise-constant postures: ``postures[i]`` holds from ``times[i]`` on; the first
    before ``times[0]``; dq_ref = ddq_ref = 0 (paper section 5: q_ref is a step input).

    Parameters
    ----------
    times : ndarray
        s, increasing, (n,).
    postures : ndarray
        rad, (n, 3).
    """

    times: F64
    postures: F64

    def __post_init__(self) -> None:
        t = np.asarray(self.times, dtype=float)
        p = np.asarray(self.postures, dtype=float)
        if t.ndim != 1 or len(t) == 0 or not np.all(np.isfinite(t)) or np.any(np.diff(t) <= 0):
            raise ParameterError("Steps", "times",
                                 f"expected increasing finite times in s, got {self.times!r}")
        if p.shape != (len(t), 3) or not np.all(np.isfinite(p)):
            raise ParameterError("Steps", "postures",
                                 f"expected {len(t)} postures of 3 finite angles (rad), got shape "
                                 f"{p.shape}")
        object.__setattr__(self, "times", t)
        object.__setattr__(self, "postures", p)

    def sample(self, t: ArrayLike) -> tuple[F64, F64, F64]:
        """The reference at times ``t``.

        Parameters
        ----------
        t : array_like
            Times, s, ``(N,)``.

        Returns
        -------
        q_ref, dq_ref, ddq_ref : ndarray
            Each ``(N, 3)``: rad, rad/s, rad/s^2.
        """
        tt = np.asarray(t, dtype=float)
        idx = np.clip(np.searchsorted(self.times, tt, side="right") - 1, 0, len(self.times) - 1)
        q = self.postures[idx]
        return q, np.zeros_like(q), np.zeros_like(q)
