"""Excitation plans: the motion identification drives the leg through.

A plan is data: per joint a finite Fourier series about a centre posture,

    q_j(t) = c_j + sum_k a_jk sin(k w t) + b_jk cos(k w t),   w = 2 pi / period,

played for a whole number of periods (periodic: it starts and ends at the same posture
with the same rates, so the samples of each period weigh alike; Swevers et al. 1997),
at rest at the start of each period (zero velocity and acceleration: the first
harmonic's coefficients set by the others), so that a minimum-jerk move from the posture
the device stands in joins it without a jolt (:class:`PlanReference`).
:func:`design_plan` draws candidate coefficients, scales each to the limits and keeps
the one whose base regressor is best conditioned (the smallest condition number of the
stacked, column-scaled Y_b: the estimate's sensitivity to noise). Every candidate kept
stays inside :func:`plan_limits` -- the safety layer's range of motion less a margin,
the child's comfortable speed, the actuators' speed and the torque the safety layer
allows (with the model's inverse dynamics and friction) -- and :func:`check_plan` says
what a plan exceeds, so that no plan runs unchecked.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from exoleg.control.safety import SafetyLimits
from exoleg.device.actuator import ActuatorModel
from exoleg.dynamics.kernels import N_JOINTS
from exoleg.dynamics.model import LegModel
from exoleg.errors import ParameterError
from exoleg.identify.base import (
    BaseParameters,
    actuator_friction,
    base_parameters,
    friction_columns,
)
from exoleg.params.records import JOINTS

F64 = NDArray[np.float64]

#: The child's comfort: the plan's joint speeds at most this, rad/s (about 60 deg/s -- a
#: slow, deliberate movement, a quarter of walking's peak knee speed).
COMFORT_SPEED = 1.0
#: Kept inside the range of motion by this, rad (5 deg).
RANGE_MARGIN = np.radians(5.0)
#: The torque the plan may use: this share of what the safety layer allows (the rest for
#: the tracking controller's corrections).
TORQUE_SHARE = 0.6


@dataclass(frozen=True)
class Plan:
    """A periodic excitation: ``period`` s, played ``periods`` times; per joint the centre
    posture ``centre`` (3,) rad and the coefficients ``a``, ``b`` (3, K) rad."""

    period: float
    periods: int
    centre: F64
    a: F64
    b: F64

    def __post_init__(self) -> None:
        if not (np.isfinite(self.period) and 2.0 <= self.period <= 60.0):
            raise ParameterError("Plan", "period", f"{self.period!r} s is outside 2-60 s")
        if not (isinstance(self.periods, int) and 1 <= self.periods <= 20):
            raise ParameterError("Plan", "periods", f"expected 1-20, got {self.periods!r}")
        for name in ("centre", "a", "b"):
            v = np.asarray(getattr(self, name), dtype=float)
            if not np.isfinite(v).all():
                raise ParameterError("Plan", name, "holds a value that is not finite")
            object.__setattr__(self, name, v)

    @property
    def duration(self) -> float:
        return self.period * self.periods

    def sample(self, dt: float = 1e-3) -> tuple[F64, F64, F64, F64]:
        """(t, q, dq, ddq) every ``dt`` s over the whole plan."""
        return self.at(np.arange(0.0, self.duration + 0.5 * dt, dt))

    def at(self, t: F64) -> tuple[F64, F64, F64, F64]:
        """(t, q, dq, ddq) at the times ``t`` (s from the plan's start). The harmonics'
        sines and cosines by the angle-addition recurrence from the first's (a sine and a
        cosine per sample, not one per harmonic: the plan's checks sample two minutes at
        1 kHz hundreds of times; within 1e-12 rad of the direct ones)."""
        w = 2 * np.pi / self.period
        n = self.a.shape[1]
        kw = np.arange(1, n + 1) * w
        x = w * np.asarray(t, dtype=float)
        s, c = np.empty((x.size, n)), np.empty((x.size, n))
        s1, c1 = np.sin(x), np.cos(x)
        s[:, 0], c[:, 0] = s1, c1
        for j in range(1, n):
            s[:, j] = s[:, j - 1] * c1 + c[:, j - 1] * s1
            c[:, j] = c[:, j - 1] * c1 - s[:, j - 1] * s1
        q = self.centre + s @ self.a.T + c @ self.b.T
        dq = c @ (self.a * kw).T - s @ (self.b * kw).T
        ddq = -(s @ (self.a * kw**2).T + c @ (self.b * kw**2).T)
        return t, q, dq, ddq


#: The minimum-jerk moves into the plan from the standing posture and back: at least
#: this long (s), and long enough that their peak speed (1.875 x the mean) stays within
#: this share of :data:`COMFORT_SPEED`.
RAMP_S = 2.0
RAMP_SPEED_SHARE = 0.8


@dataclass(frozen=True)
class PlanReference:
    """What the device follows to play ``plan``: a minimum-jerk move over ``ramp`` s from
    the posture ``start`` (rad, the device's standing posture) to the plan's first
    posture, the plan, and the move back (a :class:`~exoleg.reference.steps.Reference`:
    ``sample(t)``). The plan must start at rest (:func:`design_plan`'s do). ``ramp``
    None: :data:`RAMP_S`, or longer for a long move (:data:`RAMP_SPEED_SHARE`)."""

    plan: Plan
    start: F64
    ramp: float | None = None
    _ramp: float = field(init=False, repr=False, compare=False)
    _moves: Any = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        from exoleg.reference.minjerk import MinJerk

        _, q, dq, ddq = self.plan.sample(self.plan.period)  # t = 0 and one period on
        if np.abs(dq[0]).max() > 1e-9 or np.abs(ddq[0]).max() > 1e-9:
            raise ParameterError("PlanReference", "plan", "does not start at rest (a "
                                 "minimum-jerk move cannot join it without a jolt)")
        start = np.asarray(self.start, dtype=float)
        if start.shape != (3,) or not np.isfinite(start).all():
            raise ParameterError("PlanReference", "start", "expected 3 finite angles (rad)")
        far = float(np.abs(q[0] - start).max())
        r = (round(max(RAMP_S, 1.875 * far / (RAMP_SPEED_SHARE * COMFORT_SPEED)), 1)
             if self.ramp is None else float(self.ramp))
        if not (np.isfinite(r) and 1.0 <= r <= 30.0):
            raise ParameterError("PlanReference", "ramp", f"{r!r} s is outside 1-30 s")
        object.__setattr__(self, "start", start)
        object.__setattr__(self, "_ramp", r)
        d = self.plan.duration
        object.__setattr__(self, "_moves", MinJerk(
            np.array([0.0, r, r + d, 2 * r + d]), np.stack([start, q[0], q[0], start])))

    @property
    def duration(self) -> float:
        """From the start of the move in to the end of the move back, s."""
        return self.plan.duration + 2 * self._ramp

    @property
    def window(self) -> tuple[float, float]:
        """When the plan itself plays, s from the reference's start."""
        return self._ramp, self._ramp + self.plan.duration

    def sample(self, t: ArrayLike) -> tuple[F64, F64, F64]:
        tt = np.atleast_1d(np.asarray(t, dtype=float))
        start, end = self.window
        inside = (tt >= start) & (tt <= end)
        if inside.all():  # within the plan (every tick but the moves'): the plan alone
            return self.plan.at(tt - start)[1:]
        q, dq, ddq = self._moves.sample(tt)
        if inside.any():
            _, pq, pdq, pddq = self.plan.at(tt[inside] - start)
            q[inside], dq[inside], ddq[inside] = pq, pdq, pddq
        return q, dq, ddq


@dataclass(frozen=True)
class Limits:
    """What a plan must stay within: the range (rad), speed (rad/s) and torque (N m) per
    joint."""

    lower: F64
    upper: F64
    speed: F64
    torque: F64


def plan_limits(safety: SafetyLimits, actuators: tuple[ActuatorModel, ...]) -> Limits:
    """The safety layer's range of motion less :data:`RANGE_MARGIN`, the smaller of the
    child's comfort and the actuators' speed, and :data:`TORQUE_SHARE` of the torque the
    safety layer allows."""
    lo = np.asarray(safety.lower) + RANGE_MARGIN
    hi = np.asarray(safety.upper) - RANGE_MARGIN
    speed = np.minimum(COMFORT_SPEED, [a.max_velocity for a in actuators])
    torque = TORQUE_SHARE * np.asarray(safety.max_torque)
    return Limits(lo, hi, np.asarray(speed, dtype=float), torque)


def _torques(leg: LegModel, actuators: tuple[ActuatorModel, ...], q: F64, dq: F64, ddq: F64) -> F64:
    theta, smoothing = actuator_friction(actuators)
    out: F64 = leg.inverse_dynamics(q, dq, ddq) + friction_columns(dq, smoothing) @ theta
    return out


def check_plan(plan: Plan | PlanReference, leg: LegModel,
               actuators: tuple[ActuatorModel, ...], limits: Limits,
               dt: float = 1e-3) -> list[str]:
    """What the plan exceeds ([] when nothing), each named with its joint, its worst value
    and the limit. For the reference playing a plan, its moves in and out too (their
    range the safety layer's own: the posture the device stands in may lie within the
    plan's margin)."""
    if isinstance(plan, PlanReference):
        t = np.arange(0.0, plan.duration + 0.5 * dt, dt)
        q, dq, ddq = plan.sample(t)
        moving = (t < plan.window[0]) | (t > plan.window[1])
    else:
        _, q, dq, ddq = plan.sample(dt)
        moving = np.zeros(len(q), dtype=bool)
    tau = _torques(leg, actuators, q, dq, ddq)
    lower = np.where(moving[:, None], limits.lower - RANGE_MARGIN, limits.lower)
    upper = np.where(moving[:, None], limits.upper + RANGE_MARGIN, limits.upper)
    out = []
    for j, name in enumerate(JOINTS):
        if (q[:, j] < lower[:, j] - 1e-9).any() or (q[:, j] > upper[:, j] + 1e-9).any():
            out.append(f"{name}: {np.degrees(q[:, j].min()):.1f} to "
                       f"{np.degrees(q[:, j].max()):.1f} deg leaves "
                       f"{np.degrees(limits.lower[j]):.1f} to "
                       f"{np.degrees(limits.upper[j]):.1f} deg")
        if np.abs(dq[:, j]).max() > limits.speed[j] + 1e-9:
            out.append(f"{name}: {np.degrees(np.abs(dq[:, j]).max()):.0f} deg/s over "
                       f"{np.degrees(limits.speed[j]):.0f} deg/s")
        if np.abs(tau[:, j]).max() > limits.torque[j] + 1e-9:
            out.append(f"{name}: {np.abs(tau[:, j]).max():.1f} N m over "
                       f"{limits.torque[j]:.1f} N m")
    return out


def condition(plan: Plan, leg: LegModel, dt: float = 0.01,
              base: BaseParameters | None = None) -> float:
    """The condition number of the plan's base regressor (stacked over its samples, each
    column scaled to unit norm); ``base``: ``leg``'s base parameters, if already found."""
    b = base_parameters(leg) if base is None else base
    _, q, dq, ddq = plan.sample(dt)
    W = b.regressor(leg.regressor(q, dq, ddq)).reshape(-1, len(b.columns))
    W = W / np.linalg.norm(W, axis=0)
    return float(np.linalg.cond(W))


def _fit(plan: Plan, leg: LegModel, actuators: tuple[ActuatorModel, ...], limits: Limits
         ) -> Plan | None:
    """The plan as it is if it fits the limits, else its amplitudes (about the centre)
    scaled down to just within them (bisection); None if only a tiny one fits. Checked
    over one of its periods (the others repeat it; the plan chosen is checked whole)."""
    def scaled(s: float, periods: int = 1) -> Plan:
        return Plan(plan.period, periods, plan.centre, plan.a * s, plan.b * s)

    if not check_plan(scaled(1.0), leg, actuators, limits, dt=0.005):
        return plan
    lo, hi = 0.0, 1.0
    for _ in range(14):
        s = 0.5 * (lo + hi)
        if check_plan(scaled(s), leg, actuators, limits, dt=0.005):
            hi = s
        else:
            lo = s
    return scaled(lo, plan.periods) if lo > 0.02 else None


def design_plan(leg: LegModel, actuators: tuple[ActuatorModel, ...], limits: Limits,
                duration: float = 120.0, harmonics: int = 5, candidates: int = 40,
                seed: int = 0, start: F64 | None = None) -> Plan:
    """The best-conditioned of ``candidates`` random plans within ``limits``, ``duration``
    s long (at most 2 minutes of device time: the issue's bound), ``harmonics`` per
    joint, the period a fifth of the duration; given ``start`` (the device's standing
    posture, rad), the moves into the plan and back from it within ``limits`` too
    (:class:`PlanReference`)."""
    if not (np.isfinite(duration) and 10.0 <= duration <= 120.0):
        raise ParameterError("design_plan", "duration", f"{duration!r} s is outside 10-120 s")
    if not (isinstance(harmonics, int) and 1 <= harmonics <= 10):
        raise ParameterError("design_plan", "harmonics", f"expected 1-10, got {harmonics!r}")
    rng = np.random.default_rng(seed)
    periods = 5
    centre = 0.5 * (limits.lower + limits.upper)
    half = 0.5 * (limits.upper - limits.lower)
    best: tuple[float, Plan] | None = None
    base = base_parameters(leg)
    for _ in range(candidates):
        k = np.arange(1, harmonics + 1)
        a = rng.normal(size=(N_JOINTS, harmonics)) * half[:, None] / k
        b = rng.normal(size=(N_JOINTS, harmonics)) * half[:, None] / k
        # at rest at t = 0: dq(0) = w sum k a_k = 0, ddq(0) = -w^2 sum k^2 b_k = 0
        a[:, 0] = -(a[:, 1:] * k[1:]).sum(axis=1)
        b[:, 0] = -(b[:, 1:] * k[1:] ** 2).sum(axis=1)
        c = centre + rng.uniform(-0.3, 0.3, N_JOINTS) * half
        fitted = _fit(Plan(duration / periods, periods, c, a, b), leg, actuators, limits)
        if fitted is None:
            continue
        cond = condition(fitted, leg, base=base)
        if best is None or cond < best[0]:
            best = (cond, fitted)
    if best is None:
        raise ParameterError("design_plan", "limits", "no plan fits within these limits")
    # the candidates were checked every 5 ms; the device runs every 1 ms: a peak between
    # two coarse samples scales the plan down a little more
    plan = best[1]
    for _ in range(50):
        if not (check_plan(plan, leg, actuators, limits, dt=1e-3)
                or (start is not None and check_plan(PlanReference(plan, start), leg,
                                                      actuators, limits, dt=1e-3))):
            return plan
        plan = Plan(plan.period, plan.periods, plan.centre, plan.a * 0.99, plan.b * 0.99)
    raise ParameterError("design_plan", "limits", "no plan fits within these limits")
