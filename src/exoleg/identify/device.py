"""Identification on the device (``exoleg identify``): an excitation plan played through
the runtime -- the same session, supervisor, safety layer and drives as every other
(:func:`exoleg.runtime.session.run`) -- and the leg identified from what the session
logged: the encoders' angles and the drives' torque from their current.

The session: the plan designed on the fitted leg (:func:`~exoleg.identify.plan.design_plan`)
is followed by the paper's PD + gravity law as a reference with minimum-jerk moves from
the device's standing posture and back (:class:`~exoleg.identify.plan.PlanReference`,
checked whole by :func:`~exoleg.identify.plan.check_plan` before the session starts);
armed and started as any session, E-stop and faults as always. The child relaxes (their
own effort off); on the simulated device they stand on a step beside the belt, the
device's leg hanging free (:data:`STEP_M`).

The estimate (:func:`estimate_from_log`): the logged angles differentiated by a local
quadratic fit over 41 ms (:func:`~exoleg.identify.signals.derivatives`), the torque
at the same samples, the relaxed child's own torques held at their model -- the
passive moments, and a spastic child's tone and stretch reflexes replayed over the
recording (:func:`child_torques`; added back: the drives work against them) -- then
:func:`~exoleg.identify.estimate.identify_leg` with the fitted leg as the prior on every
period of the plan but the last, which is held out to say how well the identified leg
predicts torque it was not fitted to.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from exoleg.child.compiled import child_tick
from exoleg.child.model import ChildModel
from exoleg.dynamics.model import LegModel
from exoleg.errors import ParameterError, SimulationError
from exoleg.identify.estimate import Identified
from exoleg.identify.plan import Plan, PlanReference
from exoleg.params.records import JOINTS

F64 = NDArray[np.float64]

#: On the simulated device, the step the child stands on beside the belt (m): the
#: device's foot clear of the belt over any posture of the range of motion.
STEP_M = 0.3
#: The plan starts this long after the arming (s), on the command line.
START_AFTER_S = 1.0
#: From the operator interface, the operator has this long to arm and start the plan (s).
OPERATOR_WAIT_S = 600.0
#: The drives' measured torque in a session log: the buses' torque actual value, or the
#: simulated device's delivered torque.
TORQUE_COLUMNS = ("tau_meas_", "tau_")


@dataclass(frozen=True)
class Measured:
    """What a session logged of a plan, ready for the estimate: time from the reference's
    start (s), angles, rates, accelerations (rad, rad/s, rad/s^2), the drives' torque
    (N m) with the child's own at their model added, and which samples are held out."""

    t: F64
    q: F64
    dq: F64
    ddq: F64
    tau: F64
    held_out: NDArray[np.bool_]


@dataclass(frozen=True)
class DeviceIdentification:
    """An identification on the device: the estimate, the plan and its reference, the
    plan's condition number, the held-out torque's prediction error (RMS per joint, N m,
    and as a share of its RMS, %), the measured signals and what the stage adds
    (``details``)."""

    identified: Identified
    reference: PlanReference
    condition: float
    held_out_rms: F64
    held_out_pct: F64
    measured: Measured
    predicted: F64
    details: dict[str, Any] = dataclasses.field(default_factory=dict)

    def summary(self) -> dict[str, Any]:
        """What ``identify.json`` holds of it (with :attr:`details`: the stage, and the
        device alone's SDs or the child's share)."""
        r = self.identified
        plan = {"period_s": self.reference.plan.period,
                "periods": self.reference.plan.periods,
                "duration_s": self.reference.duration, "condition_number": self.condition}
        return {**self.details, "plan": plan,
                "samples": r.samples,
                "residual_rms_nm": dict(zip(JOINTS, r.residual_rms.tolist(), strict=True)),
                "held_out_rms_nm": dict(zip(JOINTS, self.held_out_rms.tolist(), strict=True)),
                "held_out_pct": dict(zip(JOINTS, self.held_out_pct.tolist(), strict=True))}


@njit(cache=True)
def _muscles(P, C, CS, q, dq, h, out):  # type: ignore[no-untyped-def]
    """The child's muscles (:func:`~exoleg.child.compiled.child_tick`, relaxed: standing, not
    walking, unloaded) over the recorded angles and rates, tick by tick, into out."""
    for k in range(q.shape[0]):
        child_tick((P, C, CS), q[k], dq[k], h, False, (0.0, 0.0, 0.0), False, out[k])


def child_torques(child: ChildModel, period: float, q: F64, dq: F64) -> F64:
    """The relaxed ``child``'s own joint torques at their model over a recording of the
    angles ``q`` and rates ``dq`` (N, 3) every ``period`` s: their passive moments
    (elastic and viscous) and their muscles' -- tone, short-range stiffness and the
    delayed stretch reflex of the spastic groups (none for a child without spasticity)."""
    from exoleg.child.compiled import child_records
    from exoleg.child.passive import passive_moments

    P, C, CS = child_records(dataclasses.replace(child, effort=False), period)
    out = np.zeros_like(q)
    _muscles(P, C, CS, np.ascontiguousarray(q), np.ascontiguousarray(dq), period, out)
    total: F64 = out + passive_moments(P, q, dq)
    return total


def estimate_from_log(cols: dict[str, F64], period: float, reference: PlanReference,
                      prior: LegModel, friction_smoothing: F64,
                      child: ChildModel | None = None, prior_sds: F64 | None = None
                      ) -> tuple[Measured, Identified]:
    """The leg identified from a session log's columns (:func:`~exoleg.session_log.read_log`)
    of ``reference`` played at ``period`` s: the plan's clock from the first WALKING tick
    (the tracking controller's reference runs from there), its last period held out;
    ``child``: the relaxed child's own torques at their model (:func:`child_torques`, on
    the encoders' angles and the drives' filtered rates) added to the drives' torque
    (the drives work against them); ``prior_sds``: the prior's SDs (default
    :func:`~exoleg.identify.estimate.prior_sd`)."""
    from exoleg.identify.estimate import identify_leg
    from exoleg.identify.signals import HALF_WINDOW, derivatives
    from exoleg.tick import Mode

    where = "exoleg identify"
    walking = np.flatnonzero(cols["mode"] == Mode.WALKING)
    if len(walking) == 0:
        raise ParameterError(where, "session", "the plan never started (no WALKING tick)")
    first = int(walking[0])
    n = int(round(reference.duration / period)) + 1
    if first + n > len(cols["mode"]) or not np.all(cols["mode"][first:first + n]
                                                  == Mode.WALKING):
        raise ParameterError(where, "session", "the plan did not play through once started "
                             "(stopped or paused: a plan is played whole)")
    prefix = next((p for p in TORQUE_COLUMNS if f"{p}hip" in cols), None)
    if prefix is None:
        raise ParameterError(where, "session", "the log holds no drive torque ("
                             + ", ".join(f"{p}hip" for p in TORQUE_COLUMNS) + ")")
    sl = slice(first, first + n)
    q = np.stack([cols[f"q_meas_{j}"][sl] for j in JOINTS], axis=1)
    tau = np.stack([cols[f"{prefix}{j}"][sl] for j in JOINTS], axis=1)
    if child is not None:
        dqm = np.stack([cols[f"dq_meas_{j}"][sl] for j in JOINTS], axis=1)
        tau = tau + child_torques(child, period, q, dqm)
    qs, dq, ddq = derivatives(q, period)
    # the torque as measured, at the filter's centre samples: smoothed too, its noise
    # is correlated over the samples kept and weighs the data above the prior (in
    # exoleg validate --identify one child of 100 came out with a thigh not a body)
    ts = tau[HALF_WINDOW:-HALF_WINDOW]
    t = np.arange(HALF_WINDOW, n - HALF_WINDOW, dtype=np.float64) * period
    plan = reference.plan
    start, end = reference.window
    held = (t >= start + (plan.periods - 1) * plan.period) & (t <= end)
    m = Measured(t=t, q=qs, dq=dq, ddq=ddq, tau=ts, held_out=held)
    step = 10  # every 10 ms: the smoothing leaves little between
    fit = ~held
    r = identify_leg(prior, qs[fit][::step], dq[fit][::step], ddq[fit][::step],
                     ts[fit][::step], friction_smoothing, prior_sds=prior_sds)
    return m, r


def predicted_torque(r: Identified, friction_smoothing: F64, q: F64, dq: F64,
                     ddq: F64) -> F64:
    """The drives' torque the identified leg and friction predict (N m)."""
    from exoleg.identify.base import friction_columns

    out: F64 = (r.leg.inverse_dynamics(q, dq, ddq)
                + friction_columns(dq, friction_smoothing) @ r.friction.ravel())
    return out


#: What ``identify.json`` says of an identification of the device alone (its ``stage``).
DEVICE_ALONE = "device alone"


def load_device(folder: str | Path) -> tuple[LegModel, F64]:
    """An identification of the device alone (``exoleg identify --device-alone``'s
    folder): the identified device (its ``leg.toml``) and its parameters' SDs (its
    ``identify.json``); a ParameterError naming what is missing or wrong."""
    import json

    import exoleg
    from exoleg.dynamics.kernels import N_INERTIAL
    from exoleg.io import read_text

    where = "exoleg identify --identified-device"
    d = Path(folder)
    text = read_text(d / "identify.json", "record of an identification of the device "
                     "alone, written by exoleg identify --device-alone")
    try:
        info = json.loads(text)
    except ValueError as e:
        raise ParameterError(where, str(d / "identify.json"), f"is not JSON: {e}") from None
    if not isinstance(info, dict) or info.get("stage") != DEVICE_ALONE:
        raise ParameterError(where, str(d), "is not an identification of the device alone "
                             "(exoleg identify --device-alone writes one)")
    sd = np.asarray(info.get("inertial_sd", []), dtype=float)
    if sd.shape != (N_INERTIAL,) or not np.all(np.isfinite(sd)) or np.any(sd <= 0):
        raise ParameterError(where, str(d / "identify.json"), f"inertial_sd: expected "
                             f"{N_INERTIAL} positive SDs")
    return exoleg.load_leg(d / "leg.toml"), sd


#: What an identification writes into its folder.
IDENTIFY_FILES = ("leg.toml", "parameters.csv", "identify.png", "identify.json")


def identify_device(backend: str, out: str | Path, leg: LegModel | None = None,
                    child: Any = None, body_mass: float | None = None,
                    duration: float = 120.0, seed: int = 0, interface: str | None = None,
                    channel: str = "exoleg", realtime: bool = True,
                    truth: LegModel | None = None, candidates: int = 20,
                    device_alone: bool = False,
                    identified_device: str | Path | None = None,
                    link: Any = None, arm: bool = True, session: str | Path | None = None,
                    figure: Callable[[DeviceIdentification, Path], Any] | None = None,
                    device: str | Path | None = None) -> DeviceIdentification:
    """Design a plan for the fitted ``leg`` (the child + device model, without the
    actuators: the device file's are added), play it on ``backend`` in a session under
    ``out``/session, identify the leg from the log and write into ``out``: the
    identified leg file (``leg.toml``), the parameters with their 95 % intervals
    (``parameters.csv``), ``identify.json`` and, given ``figure`` (the faces give
    :func:`exoleg.plots.identify.identify_figure`), the held-out torque figure
    (``identify.png``). ``child``: the :class:`~exoleg.child.model.ChildModel` in the
    device (relaxed: their effort off; their passive moments held at their model);
    ``truth``: on a simulated device, the leg it carries when not the model's (what a
    child's real segments are: the test of this).

    Staged (:mod:`exoleg.identify.staged`): ``device_alone`` identifies the device with
    no child in it, at ``leg``'s telescope settings (the prior its model,
    :func:`~exoleg.child.interaction.device_leg`); ``identified_device``, the folder of
    such an identification, makes it the device's share of the prior, and
    ``identify.json`` then holds the child's share of the base parameters. ``device``: a
    folder of device files replacing the shipped ones (the actuators the plan is designed
    for and the session drives with)."""
    import exoleg
    from exoleg.child.interaction import device_leg
    from exoleg.identify.base import actuator_friction
    from exoleg.identify.plan import check_plan, condition, design_plan, plan_limits
    from exoleg.io import OutputFolder, refuse_overwrite, write_json
    from exoleg.runtime.loop import ENDS, REFERENCE_PLAYED
    from exoleg.runtime.session import DEFAULT_BODY_MASS, check_folder, run, simulated
    from exoleg.session_log import read_log
    from exoleg.system.config import DeviceConfig

    where = "exoleg identify"
    if link is None and not simulated(backend, interface):
        raise ParameterError(where, "--interface", "on a real device the operator arms the "
                             "device and starts the plan: identify from the operator "
                             "interface (exoleg hmi), or here on the sim backend or "
                             "simulated nodes (canopen --interface virtual, ethercat "
                             "--interface fake)")
    if device_alone and (child is not None or identified_device is not None):
        raise ParameterError(where, "--device-alone", "no child is in the device alone (no "
                             "--child), and it is the first stage (no "
                             "--identified-device)")
    # the first stage's record read before anything is written
    first = None if identified_device is None else load_device(identified_device)
    folder = Path(out)
    # before the plan: a fit's leg.toml, or any file of the user's, in the folder asked
    # is kept, and so is a recorded session
    refuse_overwrite(folder, "exoleg identify", IDENTIFY_FILES)
    leg = exoleg.paper_leg() if leg is None else leg
    config = DeviceConfig.load(device)
    acts = config.actuators
    for a in acts:
        if a.compliant:
            raise ParameterError(f"actuators/{a.joint}.toml", "compliance",
                                 f"{a.compliance}: identification models every unit as "
                                 "rigid (its rotor an armature of the link, its friction "
                                 "the link's); a compliant unit's drive answers the "
                                 "spring's torque, which its regressor does not hold")
    fitted = config.leg(leg)
    stage = DEVICE_ALONE if device_alone else "leg"
    prior_sds = None
    if device_alone:
        fitted = device_leg(fitted, acts)
        leg = LegModel(fitted.links, g=fitted.g, name=f"{fitted.name} ({leg.name})")
    elif first is not None:
        from exoleg.identify.staged import staged_prior

        dev, dev_sd = first
        fitted, prior_sds = staged_prior(fitted, device_leg(fitted, acts), dev, dev_sd)
        stage = "leg on the identified device"
    mass = (child.mass if child is not None else DEFAULT_BODY_MASS) if body_mass is None \
        else body_mass
    limits = plan_limits(config.safety, acts)
    plan: Plan = design_plan(fitted, acts, limits, duration=duration, candidates=candidates,
                             seed=seed, start=config.gains.standing)
    ref = PlanReference(plan, config.gains.standing)
    problems = check_plan(ref, fitted, acts, limits)
    if problems:
        raise ParameterError(where, "plan", "; ".join(problems))
    relaxed = None if child is None else dataclasses.replace(child, effort=False)
    session = folder / "session" if session is None else Path(session)
    check_folder(session)  # made once everything asked is known to be right
    wait = START_AFTER_S if link is None else OPERATOR_WAIT_S
    res, path = run(backend, wait + ref.duration + 1.0, session,
                    arm=arm or link is None, walk_after=START_AFTER_S if link is None else None,
                    leg=leg if truth is None else truth, body_mass=mass, seed=seed,
                    realtime=realtime, interface=interface, channel=channel,
                    controller="pd-gravity", child=relaxed, reference=ref, step=STEP_M,
                    model=None if truth is None else leg, link=link, device=device)
    if not res.stopped_by.startswith(ENDS[REFERENCE_PLAYED]):
        raise SimulationError(f"{where}: the session stopped before the plan's end: "
                              f"{res.stopped_by} (its log: {path})")
    header, cols, _ = read_log(path)
    _, smooth = actuator_friction(acts)
    try:
        m, r = estimate_from_log(cols, header["period"], ref, fitted, smooth, child,
                                 prior_sds)
    except ParameterError as e:
        hint = (" -- or the child's own torques are not their model's (relaxed? their "
                "spasticity and contracture as in the child file?)" if child is not None
                else "")
        raise ParameterError(where, "estimate", f"{e.field}: {e.problem}{hint}; the "
                             f"session's log is kept: {path}") from None
    pred = predicted_torque(r, smooth, m.q, m.dq, m.ddq)
    err = (pred - m.tau)[m.held_out]
    rms = np.sqrt(np.mean(err**2, axis=0))
    held = 100 * rms / np.sqrt(np.mean(m.tau[m.held_out] ** 2, axis=0))
    extra: dict[str, Any] = {"stage": stage,
                             "device_folder": None if device is None else str(device)}
    if device_alone:
        extra["inertial_sd"] = np.asarray(r.inertial_sd).tolist()
    elif identified_device is not None:
        from exoleg.identify.base import base_parameters
        from exoleg.identify.staged import child_share

        b = base_parameters(fitted)
        extra["identified_device"] = str(identified_device)
        extra["child_share"] = dict(zip(b.names, b.of(child_share(r.leg, dev)).tolist(),
                                        strict=True))
    ident = DeviceIdentification(identified=r, reference=ref,
                                 condition=condition(plan, fitted), held_out_rms=rms,
                                 held_out_pct=held, measured=m, predicted=pred,
                                 details=extra)
    with OutputFolder(folder, owner="exoleg identify", will_write=IDENTIFY_FILES) as o:
        exoleg.save_leg(r.leg, o.stage("leg.toml"), header=f"identified on the device "
                        f"({backend}, {stage}) from {r.samples} samples; prior: {leg.name}")
        _write_parameters(r, o.stage("parameters.csv"))
        if figure is not None:
            figure(ident, o.stage("identify.png"))
        write_json(o.stage("identify.json"), {**ident.summary(), "backend": backend,
                                              "session": str(path), "prior": leg.name})
        o.commit(last="identify.json")
    return ident


def _write_parameters(r: Identified, path: Path) -> None:
    import pyarrow as pa

    from exoleg.io import write_csv_table

    rows = r.table()
    write_csv_table(pa.table({k: [row[k] for row in rows] for k in rows[0]}), path)
