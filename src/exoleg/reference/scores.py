"""The Gait Profile Score and Gait Variable Scores against the shipped normative gait.

Baker et al. 2009 (Gait Posture 30:265-269): a gait variable's score (GVS) is the RMS
difference, over one gait cycle sampled every 2 % (51 points), between a child's
joint-angle curve and the normative mean curve; the Gait Profile Score (GPS) is the RMS
of the GVSs. Baker's GPS takes nine kinematic variables (the pelvis's three, the hip's
three, knee flexion, ankle dorsiflexion, foot progression); the device measures three
of them -- the sagittal hip, knee and ankle -- so exoleg's GPS is over those three
(``GPS-3``), and is not comparable in absolute value with a nine-variable GPS. Its
minimal clinically important difference, 1.6 deg (Baker et al. 2012, Dev Med Child
Neurol 54:1013; for the nine-variable GPS), is the one clinics use.

The normative gait: Schwartz, Rozumalski & Trost 2008 (``data/gait``), a speed group's
mean: the clinical hip angle (thigh on pelvis) for a gait lab's kinematics, or the hip as
the device reads it, zeroed with the child standing (``upright``: the printed hip less
the pelvis's mean anterior tilt, as exoleg's walking reference). Curves in degrees,
clinical signs
(hip flexion, knee flexion, ankle dorsiflexion positive) -- or exoleg's q (rad) through
:func:`clinical_degrees`.
"""

from __future__ import annotations

from functools import cache

import numpy as np
from numpy.typing import ArrayLike, NDArray

from exoleg.errors import ParameterError

F64 = NDArray[np.float64]

#: The cycle's samples: 0-100 % in steps of 2 (Baker 2009; the normative data's grid).
PERCENT = np.arange(0.0, 100.0 + 1e-9, 2.0)
#: The variables exoleg's GPS is over (the device's three joints, sagittal).
VARIABLES = ("hip flexion", "knee flexion", "ankle dorsiflexion")
#: The minimal clinically important difference of the GPS, deg (Baker et al. 2012).
GPS_MCID_DEG = 1.6


def clinical_degrees(q: ArrayLike) -> F64:
    """exoleg's joint angles (rad; knee flexion negative) as clinical degrees (hip
    flexion, knee flexion, ankle dorsiflexion, each positive).

    Parameters
    ----------
    q : array_like
        ``(..., 3)`` rad, exoleg's signs (docs/conventions.md).

    Returns
    -------
    ndarray
        ``(..., 3)`` degrees, clinical signs.
    """
    d = np.degrees(np.asarray(q, dtype=float))
    return d * np.array([1.0, -1.0, 1.0])


@cache
def normative_cycle(speed: str = "Free", upright: bool = False) -> tuple[F64, F64]:
    """The normative gait's mean and SD over the cycle, clinical degrees.

    Parameters
    ----------
    speed : str, default "Free"
        Schwartz 2008's speed group.
    upright : bool, default False
        The hip as a device zeroed with the child standing reads it: the printed hip
        flexion less the pelvis's mean anterior tilt
        (:func:`exoleg.reference.gait.gait_angles`); False: the clinical hip angle
        (thigh on pelvis), as a gait lab's kinematics give it.

    Returns
    -------
    mean, sd : ndarray
        ``(51, 3)`` each, degrees: hip flexion, knee flexion, ankle dorsiflexion.
    """
    from exoleg.reference.gait import gait_angles, schwartz2008

    pct, q = gait_angles(speed, upright=upright)
    sds = [schwartz2008(n, speed)[2] for n in ("hip_flexion", "knee_flexion",
                                                 "ankle_dorsiflexion")]
    if not np.allclose(pct, PERCENT):
        raise ParameterError("data/gait", speed, "not on the 2 % grid")
    return clinical_degrees(q), np.stack(sds, axis=1)


def gait_scores(cycle: ArrayLike, speed: str = "Free", upright: bool = False
                ) -> tuple[F64, float]:
    """The Gait Variable Scores and the Gait Profile Score of one gait cycle.

    Parameters
    ----------
    cycle : array_like
        ``(51, 3)``: hip flexion, knee flexion, ankle dorsiflexion over 0-100 % of the
        cycle in steps of 2, clinical degrees (:func:`clinical_degrees`).
    speed : str, default "Free"
        The normative gait's speed group.
    upright : bool, default False
        Against the hip a device zeroed standing reads (:func:`normative_cycle`).

    Returns
    -------
    gvs : ndarray
        ``(3,)`` deg: the RMS difference from the normative mean, per variable.
    gps : float
        deg: the RMS of the GVSs.
    """
    c = np.asarray(cycle, dtype=float)
    if c.shape != (len(PERCENT), 3) or not np.all(np.isfinite(c)):
        raise ParameterError("gait_scores", "cycle", f"expected {len(PERCENT)} finite "
                             f"samples of 3 angles (0-100 % in steps of 2), got shape "
                             f"{c.shape}")
    mean, _ = normative_cycle(speed, upright)
    gvs = np.sqrt(np.mean((c - mean) ** 2, axis=0))
    return gvs, float(np.sqrt(np.mean(gvs**2)))


def cycle_of(t: ArrayLike, q: ArrayLike, contacts: ArrayLike) -> F64:
    """The mean gait cycle of a walk: each stride (one initial contact to the next)
    resampled to :data:`PERCENT` by linear interpolation, then averaged.

    Parameters
    ----------
    t : array_like
        ``(N,)`` s, increasing.
    q : array_like
        ``(N, 3)`` clinical degrees.
    contacts : array_like
        The initial contacts' times, s (at least two: one whole stride).

    Returns
    -------
    ndarray
        ``(51, 3)`` degrees.
    """
    tt, qq = np.asarray(t, dtype=float), np.asarray(q, dtype=float)
    ic = np.asarray(contacts, dtype=float)
    ic = ic[(ic >= tt[0]) & (ic <= tt[-1])]
    if len(ic) < 2:
        raise ParameterError("cycle_of", "contacts", f"{len(ic)} initial contact(s) within "
                             "the walk: a cycle needs two (one whole stride)")
    strides = []
    for a, b in zip(ic[:-1], ic[1:], strict=True):
        at = a + PERCENT / 100.0 * (b - a)
        strides.append(np.stack([np.interp(at, tt, qq[:, j]) for j in range(3)], axis=1))
    return np.mean(strides, axis=0)


@cache
def cp_child_cycle() -> F64:
    """The shipped child with CP's right-leg gait cycle (predictcpgait subject 1,
    Falisse et al. 2020; :func:`exoleg.reference.cp_child.cp_child_gait`, its 100 samples
    over the cycle interpolated linearly onto the 2 % grid).

    Returns
    -------
    ndarray
        ``(51, 3)`` clinical degrees over :data:`PERCENT`.
    """
    from exoleg.reference.cp_child import cp_child_gait

    g = cp_child_gait()
    x = np.linspace(0.0, 100.0, len(g.t))  # sample k at k/99 of the cycle
    return np.stack([np.interp(PERCENT, x, c) for c in clinical_degrees(g.q).T], axis=1)


#: Sangeux et al. 2015's mid-stance: 20 % to 45 % of the cycle (samples 20-44 %)
MID_STANCE = (20.0, 45.0)
#: Their classes by (ankle, knee) score: beyond +-1 SD of the normative mean
PATTERNS = ("within normal limits", "true equinus", "jump", "apparent equinus",
            "crouch", "knee recurvatum", "undetermined")


def sagittal_pattern(cycle: ArrayLike, speed: str = "Free") -> tuple[str, float, float]:
    """A gait cycle's sagittal pattern by Sangeux, Rodda & Graham's plantarflexor-knee
    extension couple index (Gait Posture 2015, 41:586-591).

    The ankle's and the knee's scores are their mean z-scores against the normative gait
    over mid-stance (:data:`MID_STANCE`): (angle - normative mean) / normative SD,
    averaged. Beyond +-1 they are abnormal: the ankle below -1 (plantarflexed) with the
    knee not above +1 is *true equinus*, with the knee above +1 *jump*; the ankle within
    +-1 with the knee above +1 *apparent equinus*; the ankle above +1 (dorsiflexed) with
    the knee above +1 *crouch*; both within +-1 *within normal limits*; the knee below -1
    with the ankle within +-1 *knee recurvatum*; anything else *undetermined*.

    Parameters
    ----------
    cycle : array_like
        ``(51, 3)`` clinical degrees over 0-100 % in steps of 2 (:func:`gait_scores`).
    speed : str, default "Free"
        The normative gait's speed group.

    Returns
    -------
    pattern : str
        One of :data:`PATTERNS`.
    ankle, knee : float
        The two scores.
    """
    c = np.asarray(cycle, dtype=float)
    if c.shape != (len(PERCENT), 3) or not np.all(np.isfinite(c)):
        raise ParameterError("sagittal_pattern", "cycle", f"expected {len(PERCENT)} finite "
                             f"samples of 3 angles, got shape {c.shape}")
    mean, sd = normative_cycle(speed)
    mid = (PERCENT >= MID_STANCE[0]) & (PERCENT < MID_STANCE[1])
    z = np.mean((c[mid] - mean[mid]) / sd[mid], axis=0)
    knee, ankle = float(z[1]), float(z[2])
    if abs(ankle) <= 1 and abs(knee) <= 1:
        pattern = "within normal limits"
    elif ankle < -1:
        pattern = "true equinus" if knee <= 1 else "jump"
    elif ankle > 1:
        pattern = "crouch" if knee > 1 else "undetermined"
    elif knee > 1:
        pattern = "apparent equinus"
    else:
        pattern = "knee recurvatum"
    return pattern, ankle, knee
