"""Normative children's gait (Schwartz et al. 2008) as a smooth periodic joint reference.

The mean (or mean + k SD) joint angles of a speed group, sampled every 2 % of
the cycle, are fitted by a truncated Fourier series (a smooth periodic curve
with analytic velocity and acceleration) and played at a chosen stride time.
Signs: q1 = hip flexion, q2 = -(knee flexion), q3 = ankle dorsiflexion, rad.
"""

from __future__ import annotations

import csv
from dataclasses import dataclass
from functools import cache
from importlib import resources

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from exoleg.errors import ParameterError
from exoleg.reference.minjerk import min_jerk

F64 = NDArray[np.float64]
SPEED_GROUPS = ("VerySlow", "Slow", "Free", "Fast", "VeryFast")
_ANGLES = (("hip_flexion", 1.0), ("knee_flexion", -1.0), ("ankle_dorsiflexion", 1.0))


@cache
def _table() -> dict[tuple[str, str], tuple[F64, F64, F64]]:
    text = resources.files("exoleg").joinpath("data", "gait",
                                              "schwartz2008_sagittal_mean_sd.csv").read_text()
    rows: dict[tuple[str, str], list[tuple[float, float, float]]] = {}
    for r in csv.DictReader(text.splitlines()):
        rows.setdefault((r["speed_group"], r["variable"]), []).append(
            (float(r["pct_gait_cycle"]), float(r["mean"]), float(r["sd"])))
    out = {}
    for k, v in rows.items():
        a = np.array(sorted(v))
        out[k] = (a[:, 0], a[:, 1], a[:, 2])
    return out


#: Schwartz 2008's sagittal moments (internal; extensors and plantarflexors positive) and
#: the sign that makes each exoleg's (a torque positive towards q's positive direction:
#: hip flexion, knee extension, dorsiflexion)
_MOMENTS = (("hip_moment_sagittal", -1.0), ("knee_moment_sagittal", 1.0),
            ("ankle_moment_sagittal", -1.0))


def gait_moments(x: ArrayLike, speed: str = "Free") -> F64:
    """Schwartz 2008's mean internal joint moments of a speed group at cycle fractions
    ``x`` (0-1, the printed samples interpolated linearly), N m/kg in exoleg's signs:
    (len(x), 3), hip, knee, ankle."""
    pct = 100.0 * np.asarray(x, dtype=float)
    out = np.empty(pct.shape + (3,))
    for j, (var, sign) in enumerate(_MOMENTS):
        p, mean, _ = schwartz2008(var, speed)
        out[..., j] = sign * np.interp(pct, p, mean)
    return out


def cycle_event(event: str, speed: str = "Free") -> tuple[float, float]:
    """A Schwartz 2008 gait-cycle event for a speed group (``schwartz2008_cycle_events.csv``:
    "Opposite Foot Off", "Opposite Foot Contact", "Ipsilateral Foot Off", "Double
    Support"): its mean and SD as fractions of the cycle."""
    if speed not in SPEED_GROUPS:
        raise ParameterError("cycle_event", "speed",
                             f"unknown {speed!r} (allowed: {', '.join(SPEED_GROUPS)})")
    text = resources.files("exoleg").joinpath("data", "gait",
                                              "schwartz2008_cycle_events.csv").read_text()
    for r in csv.DictReader(text.splitlines()):
        if r["parameter"].split("[")[0].strip() == event:
            return float(r[f"{speed}_mean"]), float(r[f"{speed}_sd"])
    raise ParameterError("cycle_event", "event", f"unknown {event!r}")


def schwartz2008(variable: str, speed: str = "Free") -> tuple[F64, F64, F64]:
    """A Schwartz 2008 variable for a speed group, as printed.

    Parameters
    ----------
    variable : str
        The variable's name in the data file (e.g. a joint's angle or moment).
    speed : str, default "Free"
        The speed group.

    Returns
    -------
    percent, mean, sd : ndarray
        % of the gait cycle, the mean and the SD, in the printed units.
    """
    if speed not in SPEED_GROUPS:
        raise ParameterError("schwartz2008", "speed",
                             f"unknown {speed!r} (allowed: {', '.join(SPEED_GROUPS)})")
    key = (speed, variable)
    if key not in _table():
        names = sorted({v for _, v in _table()})
        raise ParameterError("schwartz2008", "variable",
                             f"unknown {variable!r} (allowed: {', '.join(names)})")
    return _table()[key]


#: Stride times a child can walk, s: 8-12-year-olds walk at about 0.9-1.3 s per stride
#: (Schwartz 2008's very fast to very slow groups), children with CP slower; 0.4-4 s
#: covers both with room. A stride of 1e308 s is a frozen reference, not a gait.
STRIDE_TIME_RANGE = (0.4, 4.0)
#: The longest stride Schwartz 2008's speed groups describe for 8-12-year-olds, s (its
#: very slow group: :data:`STRIDE_TIME_RANGE`'s note; their free speed's near 1.1 s,
#: as Hausdorff et al. 1999 measured at 11-14 y: 1.07 s): a slower walk's gait-cycle
#: events are not in its tables -- its stance lasts longer (the very slow group's foot
#: off is 0.68 of the cycle, the free speed's 0.59).
SLOWEST_GROUP_STRIDE = 1.3

#: Mid-stance as a fraction of the gait cycle (Schwartz 2008): the posture nearest to
#: standing, where a walk starts and the paper's scenario takes its stance posture.
MID_STANCE = 0.30
#: A walk from standing starts at rest: the belt and the gait come up to their pace
#: together over this long, s (:func:`start_pace`), the leg moving from the posture stood
#: in into the gait (:func:`start_blend`). Started at full pace at once, the belt dragged
#: the standing foot from rest to its speed in a tick (the cuffs read 119 / 57 N m at
#: hip / knee: a GMFCS I girl of 9 on the example design), and the gait's mid-stance,
#: 2-8 deg from the standing posture and moving, was stepped into: every assisted walk's
#: torque clipped in its first 10-60 ms. Over 0.2 s, bringing a 1:120 hip's rotor to the
#: gait's rate still clipped it; over 0.4 s none of four children's walks on that design
#: clipped in their first 0.5 s (0.8 s: about as many clipped ticks later, and more
#: gait-phase checks moved). A measured choice, not a source's.
START_RAMP = 0.4


@njit(cache=True)
def start_pace(tau):  # type: ignore[no-untyped-def]
    """``tau`` s after a walk's start: the gait's time elapsed (s), its pace b (0-1: the
    share of the belt's speed and of the gait's rates) and the pace's first and second
    derivatives (1/s, 1/s^2). The pace rises as a minimum-jerk move over
    :data:`START_RAMP` (Flash & Hogan 1985), so the gait's time lags the clock's by half
    the ramp from its end on."""
    if tau >= START_RAMP:
        return tau - 0.5 * START_RAMP, 1.0, 0.0, 0.0
    s = max(tau, 0.0) / START_RAMP
    b, b1, b2 = min_jerk(s)
    # its integral, the gait's time: s^4 (5/2 - 3 s + s^2), T / 2 at the ramp's end
    return (START_RAMP * s ** 4 * (2.5 - 3.0 * s + s * s), b, b1 / START_RAMP,
            b2 / (START_RAMP * START_RAMP))


@njit(cache=True)
def start_blend(q0, g, dg, ddg, pace):  # type: ignore[no-untyped-def]
    """A joint's reference at a walk's start: from the posture ``q0`` stood in into the
    gait (``g``, ``dg``, ``ddg``: its angle and rates at full pace, at the gait's time
    :func:`start_pace` gives), weighted by the pace b: q0 + b (gait - q0), the gait
    played at pace b. ``pace``: :func:`start_pace`'s (b, b', b''). Returns q, dq, ddq:
    at rest on q0 at the start, the gait's own from the ramp's end."""
    b, b1, b2 = pace
    v = b * dg  # the gait's rates played at pace b (its time's rate)
    a = b * b * ddg + b1 * dg
    d = g - q0
    return q0 + b * d, b1 * d + b * v, b2 * d + 2.0 * b1 * v + b * a


def pelvic_tilt(speed: str = "Free") -> float:
    """The pelvis's mean anterior tilt over the gait cycle (Schwartz 2008), rad: the hip
    flexion a gait lab reads with the thigh vertical."""
    _, tilt, _ = schwartz2008("pelvis_tilt", speed)
    return float(np.radians(np.mean(tilt[:-1])))


def gait_angles(speed: str = "Free", sd: float = 0.0, upright: bool = False
                ) -> tuple[F64, F64]:
    """The gait's joint angles over the cycle, mean + sd * SD, in exoleg's signs.

    Parameters
    ----------
    speed : str, default "Free"
        The speed group.
    sd : float, default 0.0
        How many SD from the mean.
    upright : bool, default False
        The hip angle from an upright pelvis: the printed hip flexion less the pelvis's
        mean anterior tilt (:func:`pelvic_tilt`), as a device whose hip is zeroed with the
        child standing reads it.

    Returns
    -------
    percent : ndarray
        % of the cycle, (51,).
    q : ndarray
        (51, 3), rad.
    """
    cols = []
    pct = np.zeros(0)
    for var, sign in _ANGLES:
        pct, mean, s = schwartz2008(var, speed)
        cols.append(sign * np.radians(mean + sd * s))
    q = np.stack(cols, axis=1)
    if upright:
        q[:, 0] -= pelvic_tilt(speed)
    return pct, q


@dataclass(frozen=True)
class SchwartzGait2008:
    """Periodic normative gait reference (Schwartz, Rozumalski & Trost 2008).

    Parameters
    ----------
    stride_time : float, default 1.0
        s per gait cycle, within :data:`STRIDE_TIME_RANGE`.
    speed : str, default "Free"
        The speed group (VerySlow, Slow, Free, Fast, VeryFast).
    sd : float, default 0.0
        mean + sd * SD (e.g. -1, 0, 1).
    harmonics : int, default 10
        Fourier harmonics kept (1-24); 10 keeps the fit within 0.25 deg of every printed
        sample (Free, mean); the residual floor is the 100 % sample, which does not close
        exactly onto the 0 % one.
    phase : float, default 0.0
        The fraction of the cycle at t = 0 (0 = heel strike).
    upright : bool, default False
        The hip from an upright pelvis (:func:`gait_angles`): the gait the walking plant
        walks and its device tracks.
    """

    stride_time: float = 1.0
    speed: str = "Free"
    sd: float = 0.0
    harmonics: int = 10
    phase: float = 0.0
    upright: bool = False

    def __post_init__(self) -> None:
        lo, hi = STRIDE_TIME_RANGE
        if not (np.isfinite(self.stride_time) and lo <= self.stride_time <= hi):
            raise ParameterError("SchwartzGait2008", "stride_time",
                                 f"{self.stride_time!r} s is not a stride a child walks "
                                 f"(allowed {lo:g}-{hi:g} s)")
        if not (1 <= int(self.harmonics) <= 24):
            raise ParameterError("SchwartzGait2008", "harmonics",
                                 f"must be 1-24, got {self.harmonics!r}")
        if not np.isfinite(self.sd) or abs(self.sd) > 3:
            raise ParameterError("SchwartzGait2008", "sd", f"must be within +-3, got {self.sd!r}")
        gait_angles(self.speed, 0.0)  # validates the speed group

    @property
    def coefficients(self) -> tuple[F64, F64, F64]:
        """(a0 (3,), a (K, 3), b (K, 3)): q(x) = a0 + sum a_k cos(2 pi k x) + b_k sin(2 pi k x)."""
        _, q = gait_angles(self.speed, self.sd, self.upright)
        samples = q[:-1]  # 0..98 %: 100 % repeats 0 % of the next cycle
        n = len(samples)
        F = np.fft.rfft(samples, axis=0) / n
        K = int(self.harmonics)
        return F[0].real, 2 * F[1:K + 1].real, -2 * F[1:K + 1].imag

    def fit_residual(self) -> float:
        """The Fourier fit's largest departure from the printed samples.

        Returns
        -------
        float
            rad.
        """
        pct, q = gait_angles(self.speed, self.sd, self.upright)
        fq, _, _ = self._eval(pct / 100.0)
        return float(np.max(np.abs(fq - q)))

    def _eval(self, x: F64) -> tuple[F64, F64, F64]:
        a0, a, b = self.coefficients
        k = np.arange(1, len(a) + 1)
        w = 2 * np.pi * np.outer(x, k)  # (N, K)
        c, s = np.cos(w), np.sin(w)
        q = a0 + c @ a + s @ b
        dq = (-s * k) @ a + (c * k) @ b
        ddq = (-c * k**2) @ a + (-s * k**2) @ b
        return q, dq, ddq

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
        q, dx, ddx = self._eval(tt / self.stride_time + self.phase)
        w = 2 * np.pi / self.stride_time
        return q, dx * w, ddx * w * w

    def posture_at(self, fraction: float) -> F64:
        """Joint angles at a fraction of the gait cycle.

        Parameters
        ----------
        fraction : float
            0 = heel strike, 1 the next.

        Returns
        -------
        ndarray
            (3,), rad.
        """
        q, _, _ = self._eval(np.array([fraction]))
        return q[0]
