"""Minimum-jerk transitions between postures (Flash & Hogan 1985: s = 10 tau^3 - 15 tau^4
+ 6 tau^5)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from exoleg.reference.steps import Steps

F64 = NDArray[np.float64]


@njit(cache=True)
def min_jerk(s):  # type: ignore[no-untyped-def]
    """The minimum-jerk rise from 0 to 1 at ``s`` in [0, 1] of it (a number or an array):
    its value, and its first and second derivatives in s -- at rest at both ends."""
    return (s * s * s * (10.0 - 15.0 * s + 6.0 * s * s), 30.0 * s * s * (1.0 - s) ** 2,
            60.0 * s * (1.0 - s) * (1.0 - 2.0 * s))


@dataclass(frozen=True)
class MinJerk:
    """Minimum-jerk moves between postures: from ``postures[i]`` at ``times[i]`` to
    ``postures[i+1]`` at ``times[i+1]`` (zero velocity and acceleration at both ends);
    the first posture holds before ``times[0]``, the last after ``times[-1]``.

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
        s = Steps(self.times, self.postures)  # same validation
        object.__setattr__(self, "times", s.times)
        object.__setattr__(self, "postures", s.postures)

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
        tt = np.atleast_1d(np.asarray(t, dtype=float))
        T, P = self.times, self.postures
        i = np.clip(np.searchsorted(T, tt, side="right") - 1, 0, len(T) - 1)
        moving = (tt >= T[0]) & (i < len(T) - 1)
        j = np.minimum(i + 1, len(T) - 1)
        dur = np.where(moving, T[j] - T[i], 1.0)
        tau = np.where(moving, (tt - T[i]) / dur, 0.0)
        s, ds, dds = min_jerk(tau)
        delta = P[j] - P[i]
        q = P[i] + s[:, None] * delta
        return q, (ds / dur)[:, None] * delta, (dds / dur**2)[:, None] * delta
