"""Identification over simulated children (``exoleg validate --identify``).

For each child of the design range (8-12 years, both sexes, typically developing and
GMFCS I-IV, percentiles 10-90 of their growth charts), the **fitted** leg is exoleg's
model of them (:func:`exoleg.sizing.personalized_leg`: their segments from the tables
and the device's parts, with its actuators), and the **true** leg the child's segments
off the tables as a child's are (:data:`CHILD_SPREAD`: mass and inertia x N(1, 0.15),
the centre of mass N(0, 2 cm) along the link, a quarter of it across) on a device whose
links are off its model by less (:data:`DEVICE_SPREAD`); the link lengths are the
telescopes', known. Plans are designed on the models (:func:`design_plan`), the true
legs driven through them; what the identification reads is what the device would
measure:

* the joint angles through the 20-bit encoders (:func:`exoleg.device.drive.encode`),
  their rates and accelerations by a zero-phase quadratic fit over 41 ms (a
  Savitzky-Golay differentiator: the identification runs offline on the recording);
* the joint torques: the true leg's inverse dynamics plus the actuators' friction, with
  noise of 1 % of each actuator's continuous torque per sample (the drive's current
  measurement through k_t N; a choice, above the EPOS4's current resolution);
* the child's own torques against the drives': each child as an actor
  (:class:`~exoleg.child.model.ChildModel`, relaxed): their passive moments (with the
  shipped contracture for a child with CP) and their level's spasticity (tone,
  short-range stiffness, the delayed stretch reflex; none for a typically developing
  child), computed on the true motion; held at their model by the estimate, computed on
  the encoders' angles and rates (as ``exoleg identify`` does: the model is the
  simulator's own here, so what this measures is the signals' part, not a model's
  error).

Identified in one stage (the fitted leg the prior) and staged (the device alone first,
its plan of its own; then the device with the child, the identified device its share of
the prior: :mod:`exoleg.identify.staged`). Measured: G of the identified leg against the
true one over a grid of the plan's range of motion (9 x 9 x 9), RMS and largest as a
share of the largest abs(G); the base parameters' relative errors (median); the fitted
leg's G error beside them; the child's share of the base parameters, one stage and
staged; and, given each model, the walking controller on the true leg and the paper's
PD + gravity holding its postures. Offline: ``exoleg identify`` plays a plan through the
runtime's loop and drives.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from exoleg.device.drive import encode
from exoleg.dynamics.model import LegModel
from exoleg.identify.signals import HALF_WINDOW, derivatives

F64 = NDArray[np.float64]

#: The torque noise, a share of each actuator's continuous torque (one SD per sample).
TORQUE_NOISE = 0.01
#: How a child's segments differ from the tables (mass and inertia SD, share; centre of
#: mass SD along the link, m), and how the device's links differ from its model.
CHILD_SPREAD = (0.15, 0.02)
DEVICE_SPREAD = (0.05, 0.005)
#: A child the device carries walking: with the true leg's model, the tracking error's
#: RMS within this at every joint, deg (the shipped device's walks: 2-6 deg)
CARRIED_DEG = 10.0


@dataclass(frozen=True)
class IdentifyRun:
    """One child's measures: G's error (RMS and largest, % of max abs(G)), the fitted leg's,
    the base parameters' (median, %), the plan's condition number; the child's share of
    the base parameters' error (median, %: the leg's less the device's model, one stage;
    less the device identified, staged) and G's largest error staged; and the controllers
    given the identified or the fitted leg on the true one: the walking tracking RMS's
    largest departure from the true leg's over the joints (%; NaN when the device does
    not carry the child: the true leg's walk faulted), the paper's postures held (their
    largest departure from where the true leg's law holds them, deg)."""

    child: str
    g_rms_pct: float
    g_max_pct: float
    prior_g_max_pct: float
    base_error_pct: float
    condition: float
    child_one_stage_pct: float = float("nan")
    child_staged_pct: float = float("nan")
    staged_g_max_pct: float = float("nan")
    walk_true_deg: float = float("nan")
    walk_identified_pct: float = float("nan")
    walk_fitted_pct: float = float("nan")
    hold_identified_deg: float = float("nan")
    hold_fitted_deg: float = float("nan")


@njit(cache=True)
def _encoded(par, q):  # type: ignore[no-untyped-def]
    """The encoder's readings (:func:`~exoleg.device.drive.encode`) of the angles q."""
    out = np.empty_like(q)
    for k in range(len(q)):
        out[k] = encode(par, q[k])
    return out


def _perturbed(leg: LegModel, rng: np.random.Generator, share: float, along: float
               ) -> LegModel:
    """``leg`` with each link's mass and inertia x N(1, ``share``) (at least half) and its
    centre of mass moved N(0, ``along``) along the link and a quarter of it across."""
    links = [dataclasses.replace(
        lk, mass=lk.mass * max(0.5, rng.normal(1.0, share)),
        com=(lk.com[0] + rng.normal(0, along), lk.com[1] + rng.normal(0, along / 4)),
        izz=lk.izz * max(0.5, rng.normal(1.0, share)), parts=()) for lk in leg.links]
    return LegModel(links, g=leg.g, name=leg.name, armature=leg.armature)


def true_legs(fitted: LegModel, actuators: tuple[Any, ...], rng: np.random.Generator
              ) -> tuple[LegModel, LegModel]:
    """A child's true leg in the device and the true device alone, for the ``fitted`` leg
    (with the actuators): the child's segments off the tables (:data:`CHILD_SPREAD`), the
    device's links off its model (:data:`DEVICE_SPREAD`), the rotors as modelled."""
    from exoleg.child.interaction import device_leg
    from exoleg.identify.estimate import leg_of
    from exoleg.identify.staged import child_share

    model = device_leg(fitted, actuators)
    device = _perturbed(model, rng, *DEVICE_SPREAD)
    child = _perturbed(leg_of(fitted, child_share(fitted, model)), rng, *CHILD_SPREAD)
    pi = child.inertial() + device.inertial()
    return leg_of(fitted, pi, f"{fitted.name} (true)"), device


@dataclass(frozen=True)
class ChildIdentification:
    """One simulated child's identification: their mass (kg), fitted leg (the prior), true
    leg, the estimate, the plan and the limits it was designed within; and staged (Li et
    al. 2022): the device alone's model, true and identified legs, the child + device leg
    identified on the identified device (``staged``)."""

    mass: float
    fitted: LegModel
    true: LegModel
    identified: Any
    plan: Any
    limits: Any
    device_model: LegModel
    device_true: LegModel
    device: Any
    staged: Any


def _measured(true: LegModel, plan: Any, actuators: tuple[Any, ...], rng: np.random.Generator,
              actor: Any = None) -> tuple[F64, F64, F64, F64]:
    """What the device measures driving ``true`` through ``plan`` (every 10 ms): the
    encoders' angles differentiated, and the drives' torque with its noise -- against the
    ``actor``'s own torques, which are held at their model on the encoders' readings."""
    from exoleg.identify.base import actuator_friction, friction_columns
    from exoleg.identify.device import child_torques

    dt = 1e-3
    _, q, dq, ddq = plan.sample(dt)
    theta, smooth = actuator_friction(actuators)
    tau = (true.inverse_dynamics(q, dq, ddq) + friction_columns(dq, smooth) @ theta
           + rng.normal(size=q.shape) * TORQUE_NOISE * np.array([a.continuous_torque
                                                                 for a in actuators]))
    enc = np.stack([_encoded(a.record(), q[:, j]) for j, a in enumerate(actuators)], axis=1)
    if actor is not None:
        # the drives work against the child's own; held at their model, on what the
        # device measures (the encoders' angles and their rates), as exoleg identify does
        tau = (tau - child_torques(actor, dt, q, dq)
               + child_torques(actor, dt, enc, np.gradient(enc, dt, axis=0)))
    qm, dqm, ddqm = derivatives(enc, dt)
    tm = tau[HALF_WINDOW:-HALF_WINDOW]
    step = 10  # every 10 ms: the smoothing leaves little between
    return qm[::step], dqm[::step], ddqm[::step], tm[::step]


def identify_child(child: object, seed: int, candidates: int = 4) -> ChildIdentification:
    """One child: design, drive, measure, identify -- in one stage, and staged."""
    from exoleg.child.interaction import device_leg
    from exoleg.child.model import ChildModel
    from exoleg.control.safety import SafetyLimits
    from exoleg.device import with_actuators
    from exoleg.device.actuator import paper_actuators
    from exoleg.identify.base import actuator_friction
    from exoleg.identify.estimate import identify_leg
    from exoleg.identify.plan import design_plan, plan_limits
    from exoleg.identify.staged import staged_prior
    from exoleg.sizing import personalized_leg
    from exoleg.validate.gait_phase import SPASTICITY

    rng = np.random.default_rng(seed)
    acts = paper_actuators()
    fitted = with_actuators(personalized_leg(child))  # type: ignore[arg-type]
    true, device_true = true_legs(fitted, acts, rng)
    lim = plan_limits(SafetyLimits.paper(), acts)
    _, smooth = actuator_friction(acts)
    # the device alone, no child in it: its own plan
    device_model = device_leg(fitted, acts)
    device_plan = design_plan(device_model, acts, lim, candidates=candidates, seed=seed)
    device = identify_leg(device_model, *_measured(device_true, device_plan, acts, rng),
                          smooth)
    # the device with the child
    plan = design_plan(fitted, acts, lim, candidates=candidates, seed=seed)
    level = getattr(child, "gmfcs", None)
    actor = ChildModel.of(child, "predictcpgait" if level else "none", SPASTICITY[level or 0])
    data = _measured(true, plan, acts, rng, actor)
    r = identify_leg(fitted, *data, smooth)
    prior, sds = staged_prior(fitted, device_model, device.leg, device.inertial_sd)
    staged = identify_leg(prior, *data, smooth, prior_sds=sds)
    return ChildIdentification(float(child.mass), fitted, true, r, plan, lim,  # type: ignore[attr-defined]
                               device_model, device_true, device, staged)


def run_child(child: object, seed: int, candidates: int = 4, control: bool = False
              ) -> IdentifyRun:
    """One child: :func:`identify_child`, then G and the base parameters against the
    truth; with ``control``, the controllers on the true leg given each model
    (:func:`walking_tracking`, :func:`posture_errors`)."""
    from exoleg.identify.base import base_parameters
    from exoleg.identify.plan import condition
    from exoleg.identify.staged import child_share

    c = identify_child(child, seed, candidates)
    fitted, true, r, lim = c.fitted, c.true, c.identified, c.limits
    grid = np.stack(np.meshgrid(*(np.linspace(lim.lower[j], lim.upper[j], 9)
                                  for j in range(3)), indexing="ij"), axis=-1).reshape(-1, 3)
    g_true = true.G(grid)
    scale = float(np.abs(g_true).max())
    err = r.leg.G(grid) - g_true
    base = base_parameters(true)
    truth = base.of(true.inertial())
    size = np.maximum(np.abs(truth), 1e-3 * np.abs(truth).max())
    # the child's share of the base parameters (what the motion tells of the child):
    # the leg's less the device's model (one stage) or less the device identified
    share = base.of(child_share(true, c.device_true))
    floor = np.maximum(np.abs(share), 1e-2 * np.abs(share).max())
    more: dict[str, float] = {
        "child_one_stage_pct": 100 * float(np.median(np.abs(
            base.of(child_share(r.leg, c.device_model)) - share) / floor)),
        "child_staged_pct": 100 * float(np.median(np.abs(
            base.of(child_share(c.staged.leg, c.device.leg)) - share) / floor)),
        "staged_g_max_pct": 100 * float(np.abs(c.staged.leg.G(grid) - g_true).max()) / scale}
    if control:
        walk = walking_tracking(c)
        if walk:
            more["walk_true_deg"] = float(np.degrees(walk["true"].max()))
            for name in ("identified", "fitted"):
                more[f"walk_{name}_pct"] = 100 * float(np.abs(walk[name] / walk["true"]
                                                              - 1).max())
        hold = posture_errors(c)
        more["hold_identified_deg"] = float(np.degrees(hold["identified"]))
        more["hold_fitted_deg"] = float(np.degrees(hold["fitted"]))
    return IdentifyRun(child=str(getattr(child, "name", "child")),
                       g_rms_pct=100 * float(np.sqrt(np.mean(err**2))) / scale,
                       g_max_pct=100 * float(np.abs(err).max()) / scale,
                       prior_g_max_pct=100 * float(np.abs(fitted.G(grid) - g_true).max())
                       / scale,
                       base_error_pct=100 * float(np.median(np.abs(r.values - truth) / size)),
                       condition=condition(c.plan, fitted), **more)


def _models(c: ChildIdentification) -> tuple[LegModel, dict[str, LegModel]]:
    """The child's true leg (without actuators) and the three models of it."""
    bare = LegModel(c.true.links, g=c.true.g, name="true")
    return bare, {name: LegModel(m.links, g=m.g, name=name) for name, m in
                  (("true", bare), ("identified", c.identified.leg), ("fitted", c.fitted))}


def walking_tracking(c: ChildIdentification, strides: int = 10) -> dict[str, F64]:
    """The walking controller on the child's true leg (passive: the controller's models
    alone carry it) given each model of it -- ``true``, ``identified``, ``fitted`` -- ->
    the tracking error's RMS per joint (rad) over the strides after the first two; {}
    when the walk with the true leg faults or tracks worse than :data:`CARRIED_DEG` at
    a joint (the device does not carry this child)."""
    from exoleg.sim.walk import simulate_walk
    from exoleg.tick import Mode

    bare, models = _models(c)
    out = {}
    for name, model in models.items():
        w = simulate_walk(bare, c.mass, strides=strides, model=model)
        walking = w.mode == Mode.WALKING
        first = int(np.flatnonzero(walking)[0]) + int(round(2 * 1.1 / 1e-3))
        walking[:first] = False
        e = w.q[walking] - w.q_ref[walking]
        out[name] = np.sqrt(np.mean(e**2, axis=0))
        if name == "true" and (np.any(w.fault) or np.degrees(out[name].max()) > CARRIED_DEG):
            return {}
    return out


def posture_errors(c: ChildIdentification) -> dict[str, float]:
    """The paper's PD + gravity law (eq 23) holding its stance and swing postures (section
    6, 3 s each) on the child's true leg with the actuators, given the ``identified`` or
    the ``fitted`` model of it -> the largest departure over the joints and postures
    from where it holds them given the true leg (rad; each the mean over the last 0.5 s
    of its 3 s): K_p^-1 times the model's error in G."""
    from exoleg.control.controllers import law_named
    from exoleg.device import with_actuators
    from exoleg.reference.paper import SEGMENT, paper_reference
    from exoleg.sim.closed_loop import simulate

    bare, models = _models(c)
    plant = with_actuators(bare)
    ref = paper_reference()
    held = {}
    for name, model in models.items():
        r = simulate(plant, law_named("pd-gravity", with_actuators(model)), ref,
                     4 * SEGMENT, beyond_range_of_motion=True)
        held[name] = np.stack([r.q[(r.t > (k + 1) * SEGMENT - 0.5)
                                   & (r.t <= (k + 1) * SEGMENT - 1e-9)].mean(axis=0)
                               for k in range(4)])
    return {name: float(np.abs(held[name] - held["true"]).max())
            for name in ("identified", "fitted")}


def children(n: int, seed: int = 0) -> list[Any]:
    """``n`` children of the design range: ages 8-12, both sexes, typically developing
    and GMFCS I-IV, percentiles 10-90, drawn with ``seed``."""
    from exoleg.sizing.child import population_child

    rng = np.random.default_rng(seed)
    out: list[Any] = []
    for _ in range(n):
        group = [None, 1, 2, 3, 4][int(rng.integers(5))]
        c, _ = population_child(group, ["female", "male"][int(rng.integers(2))],
                                float(rng.uniform(8.0, 12.0)), float(rng.uniform(10, 90)))
        out.append(c)
    return out


def _one(job: tuple[Any, int, bool]) -> IdentifyRun:
    return run_child(job[0], job[1], control=job[2])


def evaluate(n: int = 100, seed: int = 0, control: bool = True,
             progress: Callable[[float], None] | None = None) -> list[IdentifyRun]:
    """:func:`run_child` over :func:`children` (n of them), on every CPU; ``progress``
    is told the share done."""
    import multiprocessing
    import os
    from concurrent.futures import ProcessPoolExecutor

    jobs = [(c, seed + i, control) for i, c in enumerate(children(n, seed))]
    out = []
    # spawned: a forked worker called the parent's compiled code at address 0 (numba's
    # machine code is not kept across a fork)
    with ProcessPoolExecutor(max_workers=min(len(jobs), os.cpu_count() or 1),
                             mp_context=multiprocessing.get_context("spawn")) as pool:
        for r in pool.map(_one, jobs):
            out.append(r)
            if progress is not None:
                progress(len(out) / len(jobs))
    return out


def summary(runs: list[IdentifyRun]) -> list[list[str]]:
    """Rows (measure, median, 95th percentile, worst) over the runs."""
    rows = []
    for label, key in (("G error RMS, % of max |G|", "g_rms_pct"),
                       ("G error max, % of max |G|", "g_max_pct"),
                       ("base parameters' error (median), %", "base_error_pct"),
                       ("the fitted leg's G error max, %", "prior_g_max_pct"),
                       ("the plan's condition number", "condition"),
                       ("staged: G error max, % of max |G|", "staged_g_max_pct"),
                       ("the child's share of the base parameters, error (median) %: "
                        "one stage", "child_one_stage_pct"),
                       ("the child's share of the base parameters, error (median) %: "
                        "staged", "child_staged_pct"),
                       ("walking tracking RMS with the true G, worst joint, deg",
                        "walk_true_deg"),
                       ("walking tracking RMS, identified G vs true, largest |change| %",
                        "walk_identified_pct"),
                       ("walking tracking RMS, fitted G vs true, largest |change| %",
                        "walk_fitted_pct"),
                       ("the paper's postures held, identified G vs true, deg",
                        "hold_identified_deg"),
                       ("the paper's postures held, fitted G vs true, deg",
                        "hold_fitted_deg")):
        v = np.array([getattr(r, key) for r in runs])
        v = v[np.isfinite(v)]
        if len(v) == 0:
            continue
        rows.append([label, f"{np.median(v):.3g}", f"{np.percentile(v, 95):.3g}",
                     f"{v.max():.3g}"])
    return rows
