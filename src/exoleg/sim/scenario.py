"""Scenarios: a closed-loop run with the comparisons the paper reports (section 6, Figs 13-15).

The paper's scenario: the leg starts at rest in quiet standing (q = 0); the
reference changes every 3 s between a stance and a swing posture, two 6 s gait
cycles (12 s; Fig. 16 calls 6-9 s stance and 9-12 s swing); PD impedance control
with gravity compensation (eq 23) at 1 kHz, RK4 at 1 ms. The paper prints its
reference only in figures, so exoleg takes the postures from normative gait
(Schwartz 2008, free speed, mean): mid-stance at 30 % of the cycle and
mid-swing at 73 % (largest knee flexion).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from exoleg.control.controllers import Controller
from exoleg.dynamics.model import LegModel
from exoleg.params import paper
from exoleg.params.records import JOINTS
from exoleg.reference.paper import (  # noqa: F401  (their old home, for one release)
    SEGMENT,
    STANCE_FRACTION,
    SWING_FRACTION,
    paper_postures,
    paper_reference,
)
from exoleg.reference.steps import Reference
from exoleg.sim.closed_loop import SimResult, simulate

F64 = NDArray[np.float64]



class Engine(Protocol):
    """An independent engine that steps a leg under a sampled controller
    (:class:`exoleg.validate.engines.MujocoLeg`)."""

    name: str

    def closed_loop(self, controller: Any, q_ref: F64, dq_ref: F64, ddq_ref: F64, hold: int,
                    q0: F64, dq0: F64) -> F64:
        """q (N, 3) at every step under ``controller`` sampled every ``hold`` steps."""
        ...


@dataclass(frozen=True)
class Peaks:
    """Per-joint peaks over a run against Table 2: torque N m, speed rad/s, power W."""

    torque: F64
    speed: F64
    power: F64
    torque_limit: F64
    speed_limit: F64
    power_limit: F64

    @classmethod
    def of(cls, res: SimResult) -> Peaks:
        acts = paper.actuators()
        return cls(torque=np.max(np.abs(res.u), axis=0), speed=np.max(np.abs(res.dq), axis=0),
                   power=np.max(np.abs(res.u * res.dq), axis=0),
                   torque_limit=np.array([a.max_torque for a in acts]),
                   speed_limit=np.array([a.max_velocity for a in acts]),
                   power_limit=np.array([a.power for a in acts]))

    def table(self) -> list[dict[str, Any]]:
        """Rows per joint with peaks, limits and the fraction of each limit used."""
        return [{"joint": j,
                 "torque_Nm": float(self.torque[i]), "torque_limit_Nm": float(self.torque_limit[i]),
                 "speed_deg_s": float(np.degrees(self.speed[i])),
                 "speed_limit_deg_s": float(np.degrees(self.speed_limit[i])),
                 "power_W": float(self.power[i]), "power_limit_W": float(self.power_limit[i]),
                 "within_limits": bool(self.torque[i] <= self.torque_limit[i]
                                       and self.speed[i] <= self.speed_limit[i]
                                       and self.power[i] <= self.power_limit[i])}
                for i, j in enumerate(JOINTS)]


@dataclass(frozen=True)
class ScenarioReport:
    """A run and its comparisons. Angles in the figures are in degrees (as the paper plots)."""

    result: SimResult
    controller: Controller
    reference_changes: F64
    detailed: SimResult | None = None
    engine_q: F64 | None = None
    engine_name: str = ""
    notes: list[str] = field(default_factory=list)

    @property
    def peaks(self) -> Peaks:
        return Peaks.of(self.result)

    def segment_end_errors(self) -> F64:
        """Max abs(q_ref - q) over joints (deg) just before each reference change and at the end."""
        t = self.result.t
        ends = [c for c in self.reference_changes if t[0] < c <= t[-1]] + [t[-1] + 1e-12]
        idx = [int(np.searchsorted(t, c - 1e-9)) - 1 for c in ends]
        return np.degrees(np.max(np.abs(self.result.error[idx]), axis=1))

    def lyapunov_rise(self) -> float:
        """Largest increase of V (eq 26) between consecutive steps within a segment, J."""
        t, V = self.result.t, self.result.lyapunov
        seg = np.searchsorted(self.reference_changes, t, side="right")
        same = seg[1:] == seg[:-1]
        dV = np.diff(V)[same]
        return float(max(0.0, dV.max())) if len(dV) else 0.0

    def verification_relative(self) -> float:
        """max abs(dq^T (Mdot - 2C) dq) / max abs(dq^T Mdot dq) over the run (machine precision
        when the model is right)."""
        r = self.result
        return float(np.max(np.abs(r.verification)) / max(np.max(r.verification_scale), 1e-300))

    def figures(self) -> dict[str, Any]:
        """The figures of the paper's section 6, measured on this run."""
        r = self.result
        out: dict[str, Any] = {
            "tracking_error_at_segment_ends_deg": self.segment_end_errors().tolist(),
            "verification_max_abs": float(np.max(np.abs(r.verification))),
            "verification_relative": self.verification_relative(),
            "lyapunov_max_rise_within_segments_J": self.lyapunov_rise(),
            "sampled_stability_h_lambda": r.stability_margin,
            "saturated_steps": int(r.saturated.any(axis=1).sum()),
            "peaks": self.peaks.table(),
        }
        if self.detailed is not None:
            out["detailed_vs_simplified_max_deg"] = float(
                np.degrees(np.max(np.abs(self.detailed.q - r.q))))
        if self.engine_q is not None:
            out[f"exoleg_vs_{self.engine_name}_max_deg"] = float(
                np.degrees(np.max(np.abs(self.engine_q - r.q))))
        return out


def run_scenario(leg: LegModel, controller: Controller, reference: Reference, duration: float,
                 dt: float = 1e-3, control_dt: float | None = None,
                 q0: ArrayLike | None = None, dq0: ArrayLike | None = None,
                 detailed: LegModel | None = None, detailed_scale: float = 2.0,
                 engine: Engine | None = None, changes: ArrayLike | None = None,
                 progress: Callable[[str, float], None] | None = None,
                 beyond_range_of_motion: bool = False) -> ScenarioReport:
    """Simulate ``leg`` under ``controller`` and compare as the paper did.

    ``detailed``: a second plant (e.g. the welded detailed model) driven by the same
    controller with its torque times ``detailed_scale`` (paper Fig. 13D).
    ``engine``: an independent engine stepping the same leg under the same sampled
    controller (Fig. 13E: MuJoCo's own RK4 on the exported MJCF,
    :func:`exoleg.validate.engines.scenario_engine`); None skips it. ``changes``: times at which the
    reference jumps (for the per-segment figures); defaults to the Steps' times.
    ``beyond_range_of_motion``: see :func:`~exoleg.sim.closed_loop.simulate`.
    """
    def tick(stage: str) -> Callable[[float], None] | None:
        return None if progress is None else (lambda f: progress(stage, f))

    q0a = None if q0 is None else np.asarray(q0, dtype=float)
    res = simulate(leg, controller, reference, duration, dt, q0a, dq0, control_dt,
                   progress=tick("simulate"), beyond_range_of_motion=beyond_range_of_motion)
    hold = int(round((control_dt or dt) / dt))
    ch = (np.asarray(changes, dtype=float) if changes is not None
          else np.asarray(getattr(reference, "times", [0.0]), dtype=float))
    notes: list[str] = list(res.notes)
    det = None
    if detailed is not None:
        det = simulate(detailed, controller.scaled(detailed_scale * controller.scale), reference,
                       duration, dt, res.q[0], res.dq[0], control_dt, progress=tick("detailed"),
                       beyond_range_of_motion=beyond_range_of_motion)
    eq, ename = None, ""
    if engine is not None:
        if progress is not None:
            progress(engine.name, 0.0)
        _, dqr, ddqr = reference.sample(res.t)
        eq = engine.closed_loop(controller, res.q_ref, dqr, ddqr, hold, res.q[0], res.dq[0])
        ename = engine.name
        if progress is not None:
            progress(engine.name, 1.0)
    return ScenarioReport(result=res, controller=controller, reference_changes=ch, detailed=det,
                          engine_q=eq, engine_name=ename, notes=notes)
