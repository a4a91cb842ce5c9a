"""Clinical tests on the simulated child, without the device: the pendulum (Wartenberg)
test and an instrumented stretch (``exoleg assess``).

**Pendulum**: the child lies supine, the thigh supported horizontally (the hip at
``hip_flexion`` degrees anatomically, 0 supine), the knee at the table's edge; the
shank and foot (the ankle held where it rests relaxed, its passive moment's zero with
the knee extended) are released from full extension and swing
under gravity, their passive moments and, if spastic, their reflexes:
I ddq = G(q) + tau_passive(q, dq) + tau_reflex, with I and G the child's own shank and
foot (:mod:`exoleg.sizing.personal`'s segments for their age, sex and height). RK4 at
1 kHz, the passive moments in every stage, the reflexes per tick.
Figures (as White et al. 2007 and Szopa et al. 2014 report them): the peak knee
velocity of the first swing (deg/s) and its time (s); the first swing (deg: the knee
flexion at the first reversal); the relaxation index A1 / A0 (the first swing over the
resting angle, both from full extension; Bajd & Vodovnik: below 1.6 spastic).

**Stretch**: the knee extended at a constant speed from 90 deg flexion to the end of
its passive range -- where the slowest stretch's passive resistance reaches 10 N m (R2),
as an examiner stops there -- (hip at ``hip_flexion``, 90 deg: the popliteal
position), slow (5 deg/s) and fast; the resistance is what the examiner's hand feels, the passive
moment plus the reflex (the shank's weight excluded, as instrumented tests subtract
it). Figures: the peak resistance against stretch speed; the catch angle (Tardieu R1:
the knee flexion at which the fastest stretch's resistance exceeds the slowest's at the
same angle by half of its largest excess; None when that excess stays below 1 N m)
and the slow stretch's end of range (R2: where the passive resistance reaches 10 N m).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from exoleg.child.compiled import child_records, child_tick
from exoleg.child.model import ChildModel
from exoleg.child.passive import passive_torque
from exoleg.errors import SimulationError

F64 = NDArray[np.float64]


def child_leg(child: ChildModel) -> Any:
    """The child's own leg (no device): thigh, shank and foot for their age, sex and
    height, at their estimated dimensions."""
    from exoleg.dynamics.model import LegModel
    from exoleg.params.records import LINKS, Link
    from exoleg.sizing.anthropometry import estimate_dimensions
    from exoleg.sizing.personal import human_bodies

    c = child.sizing_child()
    d = estimate_dimensions(c)
    bodies = human_bodies(c, d)
    lengths = (d.thigh, d.shank, 0.5 * d.foot_length)
    links = [Link.from_parts(lengths[i], (bodies[i],), name=LINKS[i]) for i in range(3)]
    return LegModel(links, name=f"{child.name} (no device)")


@dataclass(frozen=True)
class Pendulum:
    """A pendulum test: time (s), knee flexion (deg, + flexion) and its rate (deg/s),
    the reflexes' knee torque held over each tick (N m, exoleg's sign); its figures; the
    posture it ran in (hip and ankle, rad, exoleg's q)."""

    t: F64
    knee: F64
    rate: F64
    reflex: F64
    peak_velocity: float
    time_to_peak: float
    first_swing: float
    resting: float
    relaxation_index: float
    hip: float = 0.0
    ankle: float = 0.0

    def summary(self) -> dict[str, float]:
        return {"peak_knee_velocity_deg_s": self.peak_velocity,
                "time_to_peak_s": self.time_to_peak, "first_swing_deg": self.first_swing,
                "resting_angle_deg": self.resting, "relaxation_index": self.relaxation_index}


def ankle_neutral(P: NDArray[np.void], hip: float = 0.0) -> float:
    """Where the relaxed ankle rests with the knee extended: its passive moment's zero,
    rad (exoleg's q3: dorsiflexion positive), searched over -40..30 deg."""
    from exoleg.child.curves import bisect_root

    q, out = np.zeros(3), np.zeros(3)

    def moment(a: float) -> float:
        q[:] = hip, 0.0, math.radians(a)
        passive_torque(P, q, np.zeros(3), out)
        return float(out[2])

    a = bisect_root(moment, -40.0, 30.0)
    return math.radians(0.0 if math.isnan(a) else a)


def pendulum(child: ChildModel, duration: float = 10.0, h: float = 1e-3,
             hip_flexion: float = 0.0, ankle_plantarflexion: float | None = None
             ) -> Pendulum:
    """The pendulum test of ``child`` (see the module); the ankle held where it rests
    relaxed (:func:`ankle_neutral`) unless ``ankle_plantarflexion`` (deg) is given."""
    leg = child_leg(child)
    relaxed = child.with_(effort=False)
    P, C, CS = child_records(relaxed, h)
    n = int(round(duration / h))
    hip = math.radians(hip_flexion)
    ank = (ankle_neutral(P, hip) if ankle_plantarflexion is None
           else -math.radians(ankle_plantarflexion))
    geo = np.array([math.pi / 2, 0.0, ank])  # the thigh horizontal, forward
    I = float(leg.M(geo)[1, 1])  # noqa: E741 -- independent of the knee angle
    qa, dqa, out = np.zeros(3), np.zeros(3), np.zeros(3)

    def accel(q2: float, dq2: float, reflex: float) -> float:
        geo[1] = q2
        qa[:] = hip, q2, ank
        dqa[:] = 0.0, dq2, 0.0
        passive_torque(P, qa, dqa, out)
        return (-float(leg.G(geo)[1]) + out[1] + reflex) / I

    q, dq = 0.0, 0.0
    Q, V, RF = np.empty(n + 1), np.empty(n + 1), np.zeros(n + 1)
    tick = np.zeros(3)
    for k in range(n + 1):
        Q[k], V[k] = q, dq
        if k == n:
            break
        qa[:] = hip, q, ank
        dqa[:] = 0.0, dq, 0.0
        child_tick((P, C, CS), qa, dqa, h, False, (0.0, 0.0, 0.0), False, tick)
        r = RF[k] = tick[1]
        k1q, k1v = dq, accel(q, dq, r)
        k2q, k2v = dq + 0.5 * h * k1v, accel(q + 0.5 * h * k1q, dq + 0.5 * h * k1v, r)
        k3q, k3v = dq + 0.5 * h * k2v, accel(q + 0.5 * h * k2q, dq + 0.5 * h * k2v, r)
        k4q, k4v = dq + h * k3v, accel(q + h * k3q, dq + h * k3v, r)
        q += h / 6 * (k1q + 2 * k2q + 2 * k3q + k4q)
        dq += h / 6 * (k1v + 2 * k2v + 2 * k3v + k4v)
    t: F64 = np.arange(n + 1, dtype=np.float64) * h
    knee, rate = -np.degrees(Q), -np.degrees(V)  # flexion positive
    beyond = ~np.isfinite(knee) | (np.abs(knee) > 180.0)
    if beyond.any():  # a knee swings within +-180 deg: the run diverged, no result
        k = int(np.argmax(beyond))
        raise SimulationError(
            f"the pendulum test of {child.name or 'the child'} diverged: the knee reached "
            f"{knee[k]:.3g} deg at {t[k]:.2f} s (a knee swings within +-180 deg); the "
            f"model does not hold {child.spasticity.level} spasticity with contracture "
            f"'{child.contracture.name}' at level {child.contracture.level:g} stable: "
            "lower the level or the spasticity (nothing was written)")
    rev = np.nonzero((rate[1:] <= 0.0) & (rate[:-1] > 0.0))[0]
    end = int(rev[0]) + 1 if rev.size else n
    kp = int(np.argmax(rate[:end + 1]))
    resting = float(np.mean(knee[-int(round(1.0 / h)):]))
    first = float(knee[end])
    return Pendulum(t, knee, rate, RF, float(rate[kp]), float(t[kp]), first, resting,
                    first / resting if resting > 1e-9 else math.nan, hip, ank)


@dataclass(frozen=True)
class Stretch:
    """An instrumented stretch: per speed (deg/s) the knee flexion (deg) and the
    resistance (N m, against extension) over the stretch, its passive and reflex parts;
    the figures."""

    speeds: tuple[float, ...]
    angle: list[F64]
    resistance: list[F64]
    reflex: list[F64]
    peak_resistance: tuple[float, ...]
    catch_angle: float | None
    end_of_range: float

    def summary(self) -> dict[str, Any]:
        return {"speeds_deg_s": list(self.speeds),
                "peak_resistance_Nm": list(self.peak_resistance),
                "catch_angle_deg": self.catch_angle,
                "slow_end_of_range_deg": self.end_of_range}


def stretch(child: ChildModel, speeds: tuple[float, ...] = (5.0, 30.0, 60.0, 90.0, 120.0,
                                                             180.0),
            hip_flexion: float = 90.0, h: float = 1e-3) -> Stretch:
    """The instrumented knee-flexor stretch of ``child`` (see the module)."""
    hip = math.radians(hip_flexion)
    angles, res, refl, peaks = [], [], [], []
    catch: float | None = None
    end = math.nan
    for v in speeds:
        P, C, CS = child_records(child.with_(effort=False), h)
        n = int(round(90.0 / v / h))
        knee: F64 = 90.0 - v * h * np.arange(n + 1, dtype=np.float64)  # flexion, deg
        r_all, x_all = np.empty(n + 1), np.empty(n + 1)
        q, dq = np.zeros(3), np.zeros(3)
        out, tick = np.zeros(3), np.zeros(3)
        for k in range(n + 1):
            q[:] = hip, -math.radians(knee[k]), 0.0
            dq[:] = 0.0, math.radians(v), 0.0  # extending the knee: q2 rises
            passive_torque(P, q, dq, out)
            child_tick((P, C, CS), q, dq, h, False, (0.0, 0.0, 0.0), False, tick)
            # the moment the leg opposes extension with (- tau2), the hand feels it
            r_all[k] = -(out[1] + tick[1])
            x_all[k] = -tick[1]
        if v == speeds[0]:
            passive = r_all - x_all
            above = np.nonzero(passive >= 10.0)[0]
            end = float(knee[above[0]]) if above.size else float(knee[-1])
            if end >= knee[0] - 5.0:  # no range to stretch through
                raise SimulationError(
                    f"the stretch of {child.name or 'the child'}: their knee flexors resist "
                    f"{passive[0]:.1f} N m at {knee[0]:g} deg flexion already -- the end "
                    f"of the range (10 N m) comes within 5 deg of the stretch's start, "
                    "so no velocity-dependent resistance can be measured (contracture "
                    f"'{child.contracture.name}' at level {child.contracture.level:g}: "
                    "lower it, or test the pendulum)")
        # the examiner's hand stops at the end of the range the slowest stretch found
        keep = knee >= end
        angles.append(knee[keep])
        res.append(r_all[keep])
        refl.append(x_all[keep])
        peaks.append(float(r_all[keep].max()))
    # the velocity-dependent resistance: the fastest stretch's less the slowest's at the
    # same angle; the catch where it first reaches half its largest (none below 1 N m)
    extra = res[-1] - np.interp(angles[-1], angles[0][::-1], res[0][::-1])
    top = float(extra.max())
    if top >= 1.0:
        catch = float(angles[-1][int(np.nonzero(extra >= 0.5 * top)[0][0])])
    return Stretch(tuple(speeds), angles, res, refl, tuple(peaks), catch, end)
