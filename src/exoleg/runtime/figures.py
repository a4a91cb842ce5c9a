"""A session as a clinician reads it (issue 42): computed once from the session's own
records (``session.log``, ``run.json``) -- time armed and walking, steps, cadence, stride
time and stance, each joint's range of motion and its mean gait cycle against the
normative band, the Gait Variable Scores and the Gait Profile Score
(:mod:`exoleg.reference.scores`), the device's assistance per joint and gait phase, the
cuffs' torque per kg of the child against the limit the safety layer enforces, and how
the session ended in plain words.

Angles in clinical degrees (hip flexion, knee flexion, ankle dorsiflexion positive);
torques per kg of the child's body mass; times in s and min.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

import numpy as np

from exoleg.errors import ParameterError
from exoleg.io import read_record
from exoleg.params.records import JOINTS
from exoleg.reference import scores
from exoleg.session_log import check_records, check_session, read_log
from exoleg.tick import ARMED_MODES, WALKING_MODES, Event, Mode, Phase

#: The gait phases assistance is reported over, in the cycle's order.
PHASES = ((Phase.LOADING, "loading"), (Phase.FLAT, "mid-stance"), (Phase.PUSH, "push-off"),
          (Phase.SWING, "swing"))


def stop_in_words(stopped_by: str) -> str:
    """How a session ended (``run.json``'s ``stopped_by``) in a clinician's words.

    Parameters
    ----------
    stopped_by : str
        The runtime's own words (:func:`exoleg.runtime.loop.run_session`).

    Returns
    -------
    str
        One sentence; the runtime's words follow it in the report.
    """
    s = stopped_by.lower()
    if not s.strip():  # (a killed session's process writes no run.json)
        return ("Not recorded: the session's run.json is missing or unreadable (its "
                "process may have been stopped before it ended).")
    if "e-stop" in s or "estop" in s:
        first = "stopped by the emergency stop: the motors were switched off at once"
    elif "a fault" in s or "device fault" in s:
        first = "the device stopped itself on a fault and switched its motors off"
    elif "overrun" in s or "loop error" in s or "controller error" in s:
        first = "the control computer stopped the session and switched the motors off"
    elif s.startswith("duration"):
        first = "the planned time ended"
    elif "link" in s:
        first = "the connection to the console was lost"
    elif "interrupted" in s or "signal" in s:
        first = "stopped from the computer (the session was interrupted)"
    else:
        first = "the session ended"
    if "controlled stop" in s and "standing" in s:
        first += "; the device brought the leg to standing, then switched off"
    return first[0].upper() + first[1:] + "."


def _strides(t: np.ndarray, events: np.ndarray, walking: np.ndarray
             ) -> tuple[np.ndarray, np.ndarray, list[float]]:
    """The device leg's initial contacts (times), its whole strides walked (start, end:
    walking from one initial contact to the next) and each stride's stance share."""
    ev = events.astype(np.int64)
    k_ic = np.nonzero((ev & Event.IC) > 0)[0]
    to = t[(ev & Event.TO) > 0]
    whole, stance = [], []
    for a, b in zip(k_ic[:-1], k_ic[1:], strict=True):
        if walking[a:b + 1].all():
            whole.append((t[a], t[b]))
            off = to[(to > t[a]) & (to < t[b])]
            if len(off):
                stance.append(float((off[0] - t[a]) / (t[b] - t[a])))
    return t[k_ic], np.array(whole).reshape(-1, 2), stance


def _run_record(root: Path) -> dict[str, Any]:
    """A session's ``run.json`` as the figures read it: ``stopped_by`` a text and
    ``device`` a record, or left out -- a missing, unreadable or damaged file (a list, a
    field of another type) reads as not recorded, which the report says
    (:func:`stop_in_words`), never an error that loses the session's other figures."""
    return {k: v for k, v in read_record(root / "run.json").items()
            if not (k == "stopped_by" and not isinstance(v, str))
            and not (k == "device" and not isinstance(v, dict))}


def _cuff_limits(header: dict[str, Any], run: dict[str, Any]) -> list[float]:
    """The cuffs' torque limit per joint (N m/kg; nan: not watched or not known) the
    session ran with: its log's record of the device (written as it started), else its
    device folder's safety file as it is now (a log from before the limit was recorded),
    else not known -- a folder since moved or changed does not stop the report."""
    from exoleg.control.safety import SafetyLimits

    devices = [d for d in (header.get("device"), run.get("device")) if isinstance(d, dict)]
    for device in devices:
        said = device.get("cuff_limit_Nm_per_kg")
        if isinstance(said, list) and len(said) == len(JOINTS):
            return [float(x) if isinstance(x, (int, float)) and not isinstance(x, bool)
                    and math.isfinite(x) and x > 0 else math.nan for x in said]
    folder = devices[0].get("folder") if devices else None
    try:
        return [float(x) for x in SafetyLimits.paper(
            folder=folder if isinstance(folder, str) else None).cuff_limit]
    except ParameterError:
        return [math.nan] * len(JOINTS)


def session_figures(folder: str | Path) -> dict[str, Any]:
    """The clinician's figures of one recorded session.

    Parameters
    ----------
    folder : str or Path
        A session's folder (``session.log`` and ``run.json``, as ``exoleg run`` and the
        console write them).

    Returns
    -------
    dict
        JSON-ready: ``up_time_s``, ``walk_time_s``, ``initial_contacts`` (the device's
        leg's), ``strides`` (whole strides walked), ``steps`` (either foot's: two an
        initial contact), ``cadence_steps_per_min`` (120 / the mean stride time),
        ``stride_time_s`` (mean, SD), ``stance_percent`` (mean), per joint ``rom_deg``
        and ``normative_rom_deg``, ``in_band_percent`` (the share of the mean cycle
        within the normative mean +- 2 SD), ``gvs_deg``, ``gps_deg``, ``cycle_deg`` (51 x
        3, the mean cycle; None without two initial contacts), ``assistance`` (per
        joint, per phase: the support level's mean while walking, 1 the impedance's
        full support, 0 transparent), ``cuffs`` (per joint: peak and RMS N m/kg against
        the limit), ``stopped_by`` and ``stopped_in_words``, ``safety_events``.
    """
    from exoleg.sim.metrics import safety_events

    root = Path(folder)
    path = root / "session.log"
    if not path.is_file():
        raise ParameterError(str(root), "session.log", "no session log here (a session's "
                             "folder holds session.log and run.json)")
    header, cols, _ = read_log(path)
    check_session(path, header)
    check_records(path, cols)
    run = _run_record(root)
    t, mode = cols["t"], cols["mode"].astype(np.int64)
    period = float(header.get("period", 1e-3))
    walking = np.isin(mode, [int(m) for m in WALKING_MODES])
    armed = np.isin(mode, [int(m) for m in ARMED_MODES])
    ic, whole, stance = _strides(t, cols["events"], walking)
    stride = whole[:, 1] - whole[:, 0]
    out: dict[str, Any] = {
        "up_time_s": float(armed.sum() * period), "walk_time_s": float(walking.sum() * period),
        # the device's leg's initial contacts; a step is either foot's: two a stride
        "initial_contacts": int(len(ic)), "strides": int(len(stride)),
        "steps": int(2 * len(ic)),
        "cadence_steps_per_min": float(120.0 / stride.mean()) if len(stride) else None,
        "stride_time_s": [float(stride.mean()), float(stride.std())] if len(stride) else None,
        "stance_percent": float(100 * np.mean(stance)) if stance else None,
        "stopped_by": run.get("stopped_by", ""),
        "stopped_in_words": stop_in_words(run.get("stopped_by", "")),
        "safety_events": safety_events(t, cols["safety_status"].astype(np.int64)),
        "faulted": bool(np.any(mode == Mode.FAULT)),
    }
    names = [f"q_meas_{j}" for j in JOINTS]
    if all(n in cols for n in names) and len(whole):
        q = scores.clinical_degrees(np.stack([cols[n] for n in names], axis=1))
        cycle = np.mean([scores.cycle_of(t, q, w) for w in whole], axis=0)
        # the device's hip is zeroed with the child standing: against the upright hip
        gvs, gps = scores.gait_scores(cycle, upright=True)
        mean, sd = scores.normative_cycle(upright=True)
        inside = (cycle >= mean - 2 * sd) & (cycle <= mean + 2 * sd)
        out.update(cycle_deg=cycle.tolist(), gvs_deg=dict(zip(JOINTS, gvs.tolist(), strict=True)),
                   gps_deg=gps, rom_deg=dict(zip(JOINTS, np.ptp(cycle, 0).tolist(), strict=True)),
                   normative_rom_deg=dict(zip(JOINTS, np.ptp(mean, 0).tolist(), strict=True)),
                   in_band_percent=dict(zip(JOINTS, (100 * inside.mean(0)).tolist(),
                                            strict=True)))
    else:
        out.update(cycle_deg=None, gvs_deg=None, gps_deg=None, rom_deg=None,
                   normative_rom_deg=None, in_band_percent=None)
    levels = [f"support_level_{j}" for j in JOINTS]
    if all(n in cols for n in levels) and walking.any():
        phase = cols["phase"].astype(np.int64)
        out["assistance"] = {
            j: {name: float(np.mean(cols[lv][walking & (phase == p)]))
                if np.any(walking & (phase == p)) else None for p, name in PHASES}
            for j, lv in zip(JOINTS, levels, strict=True)}
    else:
        out["assistance"] = None
    mass = float(header.get("body_mass", math.nan))
    cuff = [f"cuff_{j}" for j in JOINTS]
    limits = _cuff_limits(header, run)
    if all(n in cols for n in cuff) and mass > 0 and np.any(np.isfinite(cols[cuff[0]])):
        out["cuffs"] = {
            j: {"peak_Nm_per_kg": float(np.nanmax(np.abs(cols[c])) / mass),
                "rms_Nm_per_kg": float(np.sqrt(np.nanmean(cols[c][walking] ** 2)) / mass)
                if walking.any() else None,
                "limit_Nm_per_kg": float(lim) if np.isfinite(lim) else None}
            for j, c, lim in zip(JOINTS, cuff, limits, strict=True)}
    else:
        out["cuffs"] = None  # not measured (the buses' drives have no cuff sensor)
    out["body_mass_kg"] = mass if math.isfinite(mass) else None
    out["child"] = header.get("child")
    out["started"] = float(header.get("started", run.get("started", 0.0)) or 0.0)
    out["duration_s"] = float(len(t) * period)
    out["period_s"] = period
    return out
