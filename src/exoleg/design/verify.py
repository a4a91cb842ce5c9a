"""The chosen device verified in the walking loop over the population, through the sweep
engine (:mod:`exoleg.study.engine`: Dask, local or ``--scheduler``; resumable).

Two studies on the design's device folder, every child of the design's verification set
walking as an actor (:class:`~exoleg.child.model.ChildModel`) with the whole device --
contacts, sensors, detection, hierarchy, safety layer, drives --:

* **transparent**: ``strides_transparent`` strides; the cuffs' RMS torque per kg at every
  joint within the design's goal, and no fault;
* **assist-as-needed**: ``strides_assist`` strides of Emken's law bounded to ``alpha`` of
  the impedance's support (the device folder's ``assist.toml``); no torque clipped, no
  fault (an overspeed is one), every winding below its limit.

In both the foot must not touch the belt in swing (the study's ``swing_touches``: a load
shorter than a stance -- the toe catching the belt, a trip on a child); a row from
before that count (-1) is not judged served.

A child serves when both hold. The verification set: the design's population with the
masses asked (``[verify] mass_kg``), and the held-out children (not in the design set).
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np

from exoleg.params.records import JOINTS

#: The verification's two walks: the study's controller and its strides' key in the
#: design file's [verify] table.
MODES = {"transparent": "strides_transparent", "aan": "strides_assist"}


def children(design: Any) -> list[dict[str, Any]]:
    """The verification set as chart children (age, sex, group, percentile): the design's
    population within ``design.verify_mass`` kg, then the held-out children."""
    from exoleg.sizing.child import population_child
    from exoleg.study.spec import GROUPS

    lo, hi = design.verify_mass
    out = []
    for g in design.groups:
        for s in design.sexes:
            for a in design.ages:
                for p in design.percentiles:
                    c = population_child(g or None, s, a, p)[0]
                    if lo <= c.mass <= hi:
                        out.append({"age": a, "sex": s, "group": GROUPS[g], "percentile": p,
                                    "held_out": False})
    for h in design.held_out:
        out.append({"age": float(h["age"]), "sex": str(h["sex"]),
                    "group": GROUPS[int(h["group"])], "percentile": float(h["percentile"]),
                    "held_out": True})
    return out


def study_text(design: Any, mode: str, kids: list[dict[str, Any]]) -> str:
    """The verification study of ``mode`` (:data:`MODES`) as a study file (list
    sampling: one run per child)."""
    from exoleg.io import toml_string

    strides = getattr(design, MODES[mode])
    lines = ["[study]", f"name = {toml_string('verify-' + mode)}", 'sampling = "list"',
             f"strides = {int(strides)}", "runs_per_task = 2", 'partition_by = "group"',
             f"description = {toml_string('exoleg design: ' + design.source)}", ""]
    for k in kids:
        lines += ["[[runs]]", f"age = {k['age']!r}", f"sex = {toml_string(k['sex'])}",
                  f"group = {toml_string(k['group'])}", f"percentile = {k['percentile']!r}",
                  'child = "actor"', f"controller = {toml_string(mode)}",
                  f"stride_time = {design.stride_time!r}",
                  f"speed = {toml_string(design.speed)}", ""]
    return "\n".join(lines)


def _shipped(name: str, vectors: Any, header: str) -> str:
    """The shipped ``data/device/<name>`` with each ``key = [...]`` line of ``vectors``
    (key -> function of the shipped values giving the new ones) rewritten, under the
    comment ``header``."""
    from importlib import resources

    text = (resources.files("exoleg") / "data" / "device" / name).read_text()
    for key, new in vectors.items():
        m = re.search(rf"(?m)^{key}\s*=\s*\[([^\]]*)\]", text)
        assert m is not None, key  # the shipped file has each key once
        vals = new(np.array([float(v) for v in m.group(1).split(",")]))
        text = (text[:m.start()] + f"{key} = [" + ", ".join(f"{v:.6g}" for v in vals) + "]"
                + text[m.end():])
    return f"# exoleg design: {header}\n" + text


def assist_text(alpha: tuple[float, float, float]) -> str:
    """The shipped ``assist.toml`` with assist-as-needed bounded to ``alpha`` of the
    impedance's support per joint, and starting there."""
    return _shipped("assist.toml", {k: lambda _: np.array(alpha) for k in
                                    ("support_max", "start")},
                    "assist-as-needed bounded to the design's alpha (the share of the "
                    "child's moment the device gives) and starting there")


def transparency_text(units: dict[str, Any]) -> str:
    """The shipped ``transparency.toml`` with the cuffs' torque feedback halved at the
    joints whose unit is compliant: its loop already closes on the joint's torque, and at
    the rigid units' gain of 2 the two loops in series saturated the motors in 48 % of a
    transparent walk's ticks, against 15 % at 1 (measured, a series-spring device)."""
    half = np.array([0.5 if units[j].compliant else 1.0 for j in JOINTS])
    return _shipped("transparency.toml", {"kp_interaction": lambda kp: kp * half},
                    "the cuffs' feedback halved at compliant joints")


def walking_control_text(units: dict[str, Any]) -> str:
    """The shipped ``walking_control.toml`` with each joint's impedance set for the
    chosen unit the way the shipped gains were set for theirs (that file's comment:
    Kp = J w^2, Kd = 2 zeta J w, J the joint's inertia dominated by the rotor): the gains
    scaled by J' / J, J' the paper's leg's link inertia at standing plus the inertia the
    link feels of the chosen unit
    (:attr:`~exoleg.device.actuator.ActuatorModel.apparent_inertia`), J the same with the
    shipped unit -- the same closed-loop frequency and damping on the new inertia.
    (Unscaled, a series-elastic ankle's damping held over the 1 ms tick met
    h lambda(M^-1 Kd) = 8.7-11.6, far beyond the 2 a sampled damping holds at: measured.)"""
    import exoleg
    from exoleg.device.actuator import paper_actuators

    link = np.diag(exoleg.paper_leg().M(np.zeros(3)))
    shipped = np.array([a.apparent_inertia for a in paper_actuators()])
    chosen = np.array([units[j].apparent_inertia for j in JOINTS])
    scale = (link + chosen) / (link + shipped)
    return _shipped("walking_control.toml",
                    {k: lambda v: v * scale for k in ("kp_stance", "kd_stance", "kp_swing",
                                                      "kd_swing")},
                    "the impedance scaled to the chosen units' inertia (x "
                    + ", ".join(f"{f:.3g}" for f in scale) + " at hip, knee, ankle)")


def run(design: Any, device: Path, out: Path, scheduler: str | None = None,
        workers: int | None = None) -> list[dict[str, Any]]:
    """Both studies into ``out``/``verify-<mode>`` on the sweep engine (resumed when
    there), judged: one row per child with both walks' figures and whether it is
    served."""
    from exoleg.study.engine import execute, read_results
    from exoleg.study.spec import parse_study

    kids = children(design)
    tables = {}
    for mode in MODES:
        where = out / f"verify-{mode}"
        study = parse_study(study_text(design, mode, kids), str(where / "study.toml"))
        execute(study.on_device(str(device.resolve())), where, scheduler, workers=workers)
        rows = read_results(where).to_pylist()
        tables[mode] = sorted(rows, key=lambda r: r["run"])
    limits = _winding_limits(device)
    return [_judge(design, k, tables["transparent"][i], tables["aan"][i], limits)
            for i, k in enumerate(kids)]


def _winding_limits(device: Path) -> dict[str, float]:
    from exoleg.device.actuator import paper_actuators

    return {a.joint: a.max_winding_temperature for a in paper_actuators(device)}


def _judge(design: Any, kid: dict[str, Any], tr: dict[str, Any], aan: dict[str, Any],
           limits: dict[str, float]) -> dict[str, Any]:
    """One child's verdict from their two rows."""
    residual = {j: float(tr[f"interaction_rms_Nm_per_kg_{j}"]) for j in JOINTS}
    winding = {j: float(aan[f"winding_max_C_{j}"]) for j in JOINTS}
    # -1: not counted (a row from before the count; missing or null in its dataset)
    touches = [-1 if w.get("swing_touches") is None else int(w["swing_touches"])
               for w in (tr, aan)]
    transparent = (not tr["error"] and bool(tr["walked"]) and touches[0] == 0
                   and all(v <= design.goal for v in residual.values()))
    assisted = (not aan["error"] and bool(aan["walked"]) and touches[1] == 0
                and int(aan["ticks_torque_clipped"]) == 0
                and all(winding[j] < limits[j] for j in JOINTS))
    return {**kid, "mass_kg": float(tr["mass_kg"]),
            **{f"transparent_residual_Nm_per_kg_{j}": v for j, v in residual.items()},
            "transparent_fault": tr["fault"] or tr["error"],
            "transparent_swing_touches": touches[0],
            "transparent_met": transparent,
            "assist_ticks_clipped": int(aan["ticks_torque_clipped"]),
            **{f"assist_winding_max_C_{j}": v for j, v in winding.items()},
            "assist_fault": aan["fault"] or aan["error"], "assist_swing_touches": touches[1],
            "assist_met": assisted,
            "served": transparent and assisted}


def summary(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """Shares of the verification set served, per walk and both, and the worst residual
    per joint (design set and held-out apart)."""
    out: dict[str, Any] = {}
    for name, sel in (("design_set", [r for r in rows if not r["held_out"]]),
                      ("held_out", [r for r in rows if r["held_out"]])):
        if not sel:
            continue
        out[name] = {"children": len(sel),
                     "transparent_met": float(np.mean([r["transparent_met"] for r in sel])),
                     "assist_met": float(np.mean([r["assist_met"] for r in sel])),
                     "served": float(np.mean([r["served"] for r in sel])),
                     "touched_in_swing": float(np.mean([
                         r["transparent_swing_touches"] != 0 or r["assist_swing_touches"] != 0
                         for r in sel])),
                     "residual_worst_Nm_per_kg": {
                         j: float(np.nanmax([r[f"transparent_residual_Nm_per_kg_{j}"]
                                             for r in sel])) for j in JOINTS}}
    return out
