"""Actuator demand and margins per joint: what the child needs against what the device's
actuation units give (:func:`device_limits`, from their datasheets; the paper's Table 2
is reported beside them, :func:`table2_limits`).

Sources of demand (each a row of torque N m, speed rad/s, power W per joint; NaN where a
source says nothing):

* ``paper per-kg``: the paper's figures for typically developing children walking
  (section 2.2: 0.7, 0.5, 1.2 N m/kg and 0.8, 0.7, 3 W/kg) times body mass;
* ``Schwartz 2008``: peak abs(moment) and abs(power) over the gait cycle of the chosen speed
  group, and peak abs(angular speed) of its joint angles played at the chosen stride
  time, at a *gait* percentile (independent of the child's growth percentile) taken
  from the data's own spread: a peak's percentile is the largest over the cycle of
  abs(mean) + z SD (:func:`peak_percentile`; z from the percentile), a
  speed's percentile the mean's peak speed scaled as the joint's excursion is at that
  percentile (:func:`excursion_spread`) -- monotonic in the percentile, as the data's
  spread is (a curve of mean + z SD at every phase is not: its peak speed and peak
  moments fell and rose again across percentiles);
* ``gravity compensation``: the largest abs(G_i(q)) of the personalized model over the
  device's range of motion (a 13^3 grid);
* ``simulated gait``: peaks of the personalized leg, with the actuators' reflected
  inertia, tracking the normative gait under the paper's controller (PD + gravity
  compensation, 1 kHz, RK4 1 ms), second stride.

A margin is limit / demand: >= 1 means the actuator covers the demand.
"""

from __future__ import annotations

from dataclasses import dataclass
from statistics import NormalDist
from typing import Any

import numpy as np
from numpy.typing import NDArray

from exoleg.device.actuator import ActuatorModel, paper_actuators, with_actuators
from exoleg.device.drive import envelope
from exoleg.dynamics.model import LegModel
from exoleg.errors import ParameterError
from exoleg.params import paper
from exoleg.params.records import JOINTS
from exoleg.reference.gait import SchwartzGait2008, schwartz2008
from exoleg.sim.batch import batch_gait_peaks
from exoleg.sizing.child import Child

F64 = NDArray[np.float64]
QUANTITIES = ("torque", "speed", "power")


#: display units of each quantity: (unit, factor from SI)
DISPLAY = {"torque": ("N m", 1.0), "speed": ("deg/s", 180.0 / np.pi), "power": ("W", 1.0)}


@dataclass(frozen=True)
class Exceedance:
    """A demand over one of the device's limits (SI units: N m, rad/s, W)."""

    source: str
    quantity: str
    joint: str
    demand: float
    limit: float

    @property
    def ratio(self) -> float:
        """demand / limit (> 1)."""
        return self.demand / self.limit

    def __str__(self) -> str:
        unit, k = DISPLAY[self.quantity]
        return (f"{self.joint} {self.quantity} {self.demand * k:.3g} {unit} over the "
                f"{self.limit * k:.3g} {unit} limit by {100 * (self.ratio - 1):.0f} % "
                f"({self.source})")


@dataclass(frozen=True)
class Demand:
    """Per-source demand (source -> (3 quantities, 3 joints)) and the device's limits (3,
    3): :func:`device_limits`."""

    rows: dict[str, F64]
    limits: F64

    def margins(self) -> dict[str, F64]:
        """limit / demand per source, (3 quantities, 3 joints); NaN where no demand."""
        with np.errstate(divide="ignore", invalid="ignore"):
            return {k: np.where(v > 0, self.limits / v, np.inf) for k, v in self.rows.items()}

    def exceedances(self) -> list[Exceedance]:
        """Every demand over its limit (margin < 1), largest ratio first."""
        out = []
        for src, v in self.rows.items():
            for i, qn in enumerate(QUANTITIES):
                for j, joint in enumerate(JOINTS):
                    if np.isfinite(v[i, j]) and v[i, j] > self.limits[i, j]:
                        out.append(Exceedance(src, qn, joint, float(v[i, j]),
                                              float(self.limits[i, j])))
        return sorted(out, key=lambda e: -e.ratio)

    def smallest_margin(self) -> tuple[float, str, str, str]:
        """(margin, source, quantity, joint) of the tightest margin."""
        best = (np.inf, "", "", "")
        for src, m in self.margins().items():
            if np.all(np.isnan(m)):
                continue
            i, j = np.unravel_index(np.nanargmin(m), m.shape)
            if m[i, j] < best[0]:
                best = (float(m[i, j]), src, QUANTITIES[i], JOINTS[j])
        return best

    def table(self) -> list[dict[str, Any]]:
        """Rows for reports: source, quantity, per joint demand, limit and margin."""
        out = []
        margins = self.margins()
        for src, v in self.rows.items():
            for i, qn in enumerate(QUANTITIES):
                if np.all(np.isnan(v[i])):
                    continue
                out.append({"source": src, "quantity": qn,
                            **{f"{j}": float(v[i, k]) for k, j in enumerate(JOINTS)},
                            **{f"{j}_margin": float(margins[src][i, k])
                               for k, j in enumerate(JOINTS)}})
        return out


def table2_limits() -> F64:
    """(torque N m, speed rad/s, power W) x (hip, knee, ankle) as the paper's Table 2
    prints them (above what its parts give: :func:`device_limits`)."""
    a = paper.actuators()
    return np.array([[x.max_torque for x in a], [x.max_velocity for x in a], [x.power for x in a]])


def device_limits(actuators: tuple[ActuatorModel, ...] | None = None) -> F64:
    """(torque N m, speed rad/s, power W) x (hip, knee, ankle) of the actuation units
    (None: the shipped ones, their datasheets): the working torque (the gear's repeated
    peak or the drive's current limit), the fastest joint speed at the bus voltage, and
    the largest mechanical power along the voltage-limited envelope (torque x speed)."""
    acts = paper_actuators() if actuators is None else actuators
    out = np.empty((3, 3))
    for j, a in enumerate(acts):
        par = a.record()
        w = np.linspace(0.0, a.max_velocity, 2001)
        out[:, j] = (a.torque_limit, a.max_velocity,
                     max(envelope(par, float(x)) * float(x) for x in w))
    return out


def peak_percentile(mean: F64, sd: F64, z: float) -> float:
    """The peak of abs(a gait variable) over the cycle at a percentile (z: its normal
    score): the largest over the cycle's phases of abs(mean) + z SD, each phase's value
    at that percentile of the children's spread there (never below zero). Increasing in
    z, as each phase's value is; at z = 0 the mean curve's peak."""
    return max(0.0, float(np.max(np.abs(mean) + z * sd)))


def excursion_spread(speed: str) -> F64:
    """Per joint, the spread of the joint's excursion over the cycle as a fraction of the
    mean's (3,): the SDs of the angle at the mean curve's highest and lowest phases taken
    as independent, sqrt(sd_max^2 + sd_min^2) / (max - min) -- the wider of the bounds
    the data allow (a child's whole curve shifted, the two perfectly correlated, would
    give abs(sd_max - sd_min)): a design's demand is not understated. A child at a gait
    percentile z moves each joint through (1 + z spread) times the mean's excursion in
    the same time: their angular speeds scale so."""
    out = np.empty(3)
    for j, var in enumerate(("hip_flexion", "knee_flexion", "ankle_dorsiflexion")):
        _, mean, sd = schwartz2008(var, speed)
        hi, lo = int(np.argmax(mean)), int(np.argmin(mean))
        out[j] = float(np.hypot(sd[hi], sd[lo]) / (mean[hi] - mean[lo]))
    return out


def schwartz_demand(mass: float, speed: str, z: float, stride_time: float) -> F64:
    """Schwartz 2008 peaks (3 quantities, 3 joints) at the gait percentile of normal score
    ``z`` (:func:`peak_percentile`, :func:`excursion_spread`), for this body mass."""
    out = np.full((3, 3), np.nan)
    for j, joint in enumerate(JOINTS):
        for i, var in ((0, f"{joint}_moment_sagittal"), (2, f"{joint}_power")):
            _, mean, sd = schwartz2008(var, speed)
            out[i, j] = mass * peak_percentile(mean, sd, z)
    _, dq = gait_reference(speed, z, stride_time, stride_time / 400, strides=1)
    out[1] = np.max(np.abs(dq), axis=0)
    return out


def gravity_demand(leg: LegModel, n: int = 13) -> F64:
    """Largest abs(G_i(q)) (3,) over an n^3 grid of the device's range of motion, N m."""
    rom = paper.range_of_motion()
    axes = [np.linspace(rom.lower[i], rom.upper[i], n) for i in range(3)]
    Q = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
    return np.max(np.abs(leg.G(Q)), axis=0)


def gait_reference(speed: str, z: float, stride_time: float, dt: float = 1e-3,
                   strides: int = 2) -> tuple[F64, F64]:
    """q_ref, dq_ref (N, 3) of ``strides`` cycles of normative gait sampled every dt, at
    the gait percentile of normal score ``z``: each joint's excursion about its cycle
    mean scaled by 1 + z :func:`excursion_spread` (the mean gait at z = 0)."""
    g = SchwartzGait2008(stride_time=stride_time, speed=speed)
    t = np.arange(int(round(strides * stride_time / dt)) + 1) * dt
    q, dq, _ = g.sample(t)
    scale = 1.0 + z * excursion_spread(speed)
    if np.any(scale <= 0.0):
        raise ParameterError("gait_reference", "z", f"{z:g}: a joint's excursion would "
                             "vanish (allowed: above -1 / its spread)")
    level = g.sample(np.linspace(0.0, stride_time, 400, endpoint=False))[0].mean(axis=0)
    return level + (q - level) * scale, dq * scale


def simulated_gait_peaks(P: F64, g: float, speed: str = "Free", z: float = 0.0,
                         stride_time: float = 1.1, dt: float = 1e-3) -> F64:
    """Peaks (n, 3, 3) of legs ``P`` (n, 18) tracking two strides of normative gait under
    the paper's controller; the second stride counts (the first settles the start)."""
    q, dq = gait_reference(speed, z, stride_time, dt)
    gains = paper.controller_gains()
    return batch_gait_peaks(P, g, gains.kp, gains.kd, q, dq, dt,
                            start=int(round(stride_time / dt)))


def build_demand(mass: float, leg: LegModel, percentile: float = 50.0, speed: str = "Free",
                 stride_time: float = 1.1, simulated: F64 | None = None,
                 grid: int = 13, limits: F64 | None = None) -> Demand:
    """Demand per source for a child of ``mass`` kg wearing the device (``leg``: the
    personalized model); ``simulated``: its simulated-gait peaks (3, 3), if run;
    ``limits``: the device's (None: :func:`device_limits` of the shipped actuators)."""
    z = NormalDist().inv_cdf(percentile / 100.0)
    t = paper.sizing()["demand_per_kg"]
    nan3 = np.full(3, np.nan)
    rows: dict[str, F64] = {
        "paper per-kg": np.array([mass * np.array(t["torque"]), nan3,
                                  mass * np.array(t["power"])]),
        f"Schwartz 2008 {speed} P{percentile:g}": schwartz_demand(mass, speed, z, stride_time),
        "gravity compensation": np.array([gravity_demand(leg, grid), nan3, nan3]),
    }
    if simulated is not None:
        rows["simulated gait"] = simulated
    return Demand(rows=rows, limits=device_limits() if limits is None else limits)


def actuator_demand(child: Child, leg: LegModel, percentile: float = 50.0, speed: str = "Free",
                    stride_time: float = 1.1, simulate: bool = True,
                    actuators: tuple[ActuatorModel, ...] | None = None) -> Demand:
    """Demand per source for ``child`` wearing the device (``leg``: its personalized model,
    to which the ``actuators``' reflected inertia is added for the simulated gait, this
    percentile's gait; None: the shipped actuators) against those actuators' limits."""
    acts = paper_actuators() if actuators is None else actuators
    sim = None
    if simulate:
        z = NormalDist().inv_cdf(percentile / 100.0)
        sim = simulated_gait_peaks(with_actuators(leg, acts).p[None, :], leg.g, speed, z,
                                   stride_time)[0]
    return build_demand(child.mass, leg, percentile, speed, stride_time, sim,
                        limits=device_limits(acts))
