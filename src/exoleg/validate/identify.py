"""Identification over simulated children (``exoleg validate --identify``).

For each child of the design range (8-12 years, both sexes, typically developing and
GMFCS I-IV, percentiles 10-90 of their growth charts), the **fitted** leg is exoleg's
model of them (:func:`exoleg.sizing.personalized_leg`, the device's actuators), and the
**true** leg the same with each link's mass, centre of mass and inertia off the tables
as a child's are (mass and inertia x N(1, 0.15), the centre of mass N(0, 2 cm) along the
link and N(0, 0.5 cm) across; the link lengths are the telescopes', known). The plan is
designed on the fitted leg (:func:`exoleg.identify.plan.design_plan`), the true leg
driven through it; what the identification reads is what the device would measure:

* the joint angles through the 20-bit encoders (:func:`exoleg.device.actuator.encode`),
  their rates and accelerations by a zero-phase quadratic fit over 41 ms (a
  Savitzky-Golay differentiator: the identification runs offline on the recording);
* the joint torques: the true leg's inverse dynamics plus the actuators' friction, with
  noise of 1 % of each actuator's continuous torque per sample (the drive's current
  measurement through k_t N; a choice, above the EPOS4's current resolution).

* the child's own torques against the drives': each child as an actor
  (:class:`~exoleg.child.model.ChildModel`, relaxed): their passive moments (with the
  shipped contracture for a child with CP) and their level's spasticity (tone,
  short-range stiffness, the delayed stretch reflex; none for a typically developing
  child), computed on the true motion; held at their model by the estimate, computed on
  the encoders' angles and rates (as ``exoleg identify`` does: the model is the
  simulator's own here, so what this measures is the signals' part, not a model's
  error).

Measured: G of the identified leg
against the true one over a grid of the plan's range of motion (9 x 9 x 9), RMS and
largest as a share of the largest |G|; the base parameters' relative errors (median);
and the fitted leg's G error beside them. The plan is played offline, not through the
runtime's loop and drives.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from exoleg.device.actuator import encode
from exoleg.dynamics.model import LegModel
from exoleg.identify.signals import HALF_WINDOW, derivatives

F64 = NDArray[np.float64]

#: The torque noise, a share of each actuator's continuous torque (one SD per sample).
TORQUE_NOISE = 0.01


@dataclass(frozen=True)
class IdentifyRun:
    child: str
    g_rms_pct: float
    g_max_pct: float
    prior_g_max_pct: float
    base_error_pct: float
    condition: float


@njit(cache=True)
def _encoded(par, q):  # type: ignore[no-untyped-def]
    """The encoder's readings (:func:`~exoleg.device.actuator.encode`) of the angles q."""
    out = np.empty_like(q)
    for k in range(len(q)):
        out[k] = encode(par, q[k])
    return out


def _true_leg(fitted: LegModel, rng: np.random.Generator) -> LegModel:
    links = []
    for lk in fitted.links:
        k = max(0.5, rng.normal(1.0, 0.15))
        links.append(dataclasses.replace(
            lk, mass=lk.mass * k, com=(lk.com[0] + rng.normal(0, 0.02),
                                       lk.com[1] + rng.normal(0, 0.005)),
            izz=lk.izz * max(0.5, rng.normal(1.0, 0.15)), parts=()))
    return LegModel(links, g=fitted.g, name=f"{fitted.name} (true)", armature=fitted.armature)


def run_child(child: object, seed: int, candidates: int = 4) -> IdentifyRun:
    """One child: design, drive, measure, identify, compare."""
    from exoleg.control.safety import SafetyLimits
    from exoleg.device import with_actuators
    from exoleg.device.actuator import paper_actuators
    from exoleg.child.model import ChildModel
    from exoleg.identify.base import actuator_friction, base_parameters, friction_columns
    from exoleg.identify.device import child_torques
    from exoleg.validate.gait_phase import SPASTICITY
    from exoleg.identify.estimate import identify_leg
    from exoleg.identify.plan import condition, design_plan, plan_limits
    from exoleg.sizing import personalized_leg

    rng = np.random.default_rng(seed)
    acts = paper_actuators()
    fitted = with_actuators(personalized_leg(child))  # type: ignore[arg-type]
    true = _true_leg(fitted, rng)
    lim = plan_limits(SafetyLimits.paper(), acts)
    plan = design_plan(fitted, acts, lim, candidates=candidates, seed=seed)
    dt = 1e-3
    _, q, dq, ddq = plan.sample(dt)
    theta, smooth = actuator_friction(acts)
    actor = ChildModel.of(child, "predictcpgait" if getattr(child, "gmfcs", None) else "none",
                          SPASTICITY[getattr(child, "gmfcs", None) or 0])
    tau = (true.inverse_dynamics(q, dq, ddq) + friction_columns(dq, smooth) @ theta
           - child_torques(actor, dt, q, dq)  # the drives work against the child's own
           + rng.normal(size=q.shape) * TORQUE_NOISE * np.array([a.continuous_torque
                                                                 for a in acts]))
    enc = np.stack([_encoded(a.record(), q[:, j]) for j, a in enumerate(acts)], axis=1)
    # the child's own held at their model, on what the device measures (the encoders'
    # angles and their rates), as exoleg identify does
    tau = tau + child_torques(actor, dt, enc, np.gradient(enc, dt, axis=0))
    qm, dqm, ddqm = derivatives(enc, dt)
    tm = tau[HALF_WINDOW:-HALF_WINDOW]
    step = 10  # every 10 ms: the smoothing leaves little between
    r = identify_leg(fitted, qm[::step], dqm[::step], ddqm[::step], tm[::step], smooth)
    grid = np.stack(np.meshgrid(*(np.linspace(lim.lower[j], lim.upper[j], 9)
                                  for j in range(3)), indexing="ij"), axis=-1).reshape(-1, 3)
    g_true = true.G(grid)
    scale = float(np.abs(g_true).max())
    err = r.leg.G(grid) - g_true
    truth = base_parameters(true).of(true.inertial())
    size = np.maximum(np.abs(truth), 1e-3 * np.abs(truth).max())
    return IdentifyRun(child=str(getattr(child, "name", "child")),
                       g_rms_pct=100 * float(np.sqrt(np.mean(err**2))) / scale,
                       g_max_pct=100 * float(np.abs(err).max()) / scale,
                       prior_g_max_pct=100 * float(np.abs(fitted.G(grid) - g_true).max())
                       / scale,
                       base_error_pct=100 * float(np.median(np.abs(r.values - truth) / size)),
                       condition=condition(plan, fitted))


def children(n: int, seed: int = 0) -> list[Any]:
    """``n`` children of the design range: ages 8-12, both sexes, typically developing
    and GMFCS I-IV, percentiles 10-90, drawn with ``seed``."""
    from exoleg.sizing.population import population_child

    rng = np.random.default_rng(seed)
    out: list[Any] = []
    for _ in range(n):
        group = [None, 1, 2, 3, 4][int(rng.integers(5))]
        c, _ = population_child(group, ["female", "male"][int(rng.integers(2))],
                                float(rng.uniform(8.0, 12.0)), float(rng.uniform(10, 90)))
        out.append(c)
    return out


def evaluate(n: int = 100, seed: int = 0) -> list[IdentifyRun]:
    """:func:`run_child` over :func:`children` (n of them)."""
    return [run_child(c, seed + i) for i, c in enumerate(children(n, seed))]


def summary(runs: list[IdentifyRun]) -> list[list[str]]:
    """Rows (measure, median, 95th percentile, worst) over the runs."""
    rows = []
    for label, key in (("G error RMS, % of max |G|", "g_rms_pct"),
                       ("G error max, % of max |G|", "g_max_pct"),
                       ("base parameters' error (median), %", "base_error_pct"),
                       ("the fitted leg's G error max, %", "prior_g_max_pct"),
                       ("the plan's condition number", "condition")):
        v = np.array([getattr(r, key) for r in runs])
        rows.append([label, f"{np.median(v):.3g}", f"{np.percentile(v, 95):.3g}",
                     f"{v.max():.3g}"])
    return rows
