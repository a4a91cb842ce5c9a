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

A child serves when both hold. The verification set: the design's population with the
masses asked (``[verify] mass_kg``), and the held-out children (not in the design set).
"""

from __future__ import annotations

import math
import re
from pathlib import Path
from typing import Any

import numpy as np

from exoleg.params.records import JOINTS

#: The verification's two walks: the study's controller and its strides' key in the
#: design file's [verify] table.
MODES = {"transparent": "strides_transparent", "aan": "strides_assist"}
#: The 10-year-old girl's transparent walk that chooses the springs and names the chosen
#: device's floors, strides (its first two settle: validate.transparency.SETTLE_STRIDES).
GIRL_STRIDES = 10


def design_set(design: Any) -> list[tuple[int, str, float, float, Any]]:
    """The design's population within ``design.verify_mass`` kg: (group, sex, age,
    percentile, the chart's child) each."""
    from exoleg.sizing.child import population_child

    lo, hi = design.verify_mass
    kids = [(g, s, a, p, population_child(g or None, s, a, p)[0]) for g in design.groups
            for s in design.sexes for a in design.ages for p in design.percentiles]
    return [k for k in kids if lo <= k[4].mass <= hi]


def children(design: Any) -> list[dict[str, Any]]:
    """The verification set as chart children (age, sex, group, percentile): the design's
    population within ``design.verify_mass`` kg, then the held-out children."""
    from exoleg.study.spec import GROUPS

    out = [{"age": a, "sex": s, "group": GROUPS[g], "percentile": p, "held_out": False}
           for g, s, a, p, _ in design_set(design)]
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


def device_files(design: Any, found: dict[str, Any]) -> dict[str, str]:
    """The device folder of a choice (:func:`~exoleg.design.study.choose`'s): each file's
    path in the folder and its text -- the chosen units, the transparency, assistance and
    impedance set for them."""
    return {**{f"actuators/{j}.toml": text for j, text in found["text"].items()},
            "transparency.toml": transparency_text(found["units"]),
            "assist.toml": assist_text(design.alpha),
            "walking_control.toml": walking_control_text(found["units"])}


def walk_springs(design: Any, found: dict[str, Any], work: Path) -> list[dict[str, Any]]:
    """The springs of the compliant joints chosen in the walking loop: the chosen device
    with the stiffnesses the screen lets serve (:func:`~exoleg.design.study.spring_options`)
    walked in the transparent mode, :data:`GIRL_STRIDES` strides, by two children -- the
    10-year-old girl (P50; :func:`exoleg.validate.transparency.girl_walk`, the floors'
    walk) and the lightest child of the design set within the verification's masses --,
    first every compliant joint's k-th stiffness together, then each joint's alone from
    the best so far; the springs whose worse child's RMS cuff torque summed over the
    joints is least, with no fault, are chosen (``found`` updated in place; the trial
    folders go under ``work``). One row per walk of both.

    Why the loop: the screen ranks the softest spring first (the least apparent inertia
    K / w_b^2 the torque loop leaves), but on the walk a soft spring asks its rotor to
    travel the deflection too, and a motor at its current limit then leaves more: the
    first design (272 N m/rad everywhere) left the girl 0.245 / 0.121 / 0.079 N m/kg, with
    830 N m/rad everywhere 0.229 / 0.107 / 0.068. Why together first: the joints' springs
    do not act apart -- the knee's alone at 475 N m/rad took its own residual from 0.121
    to 0.107 and the ankle's from 0.079 to 0.123. Why the lightest child too: springs
    chosen on the girl alone (32 kg) lowered the population's median residual by 3-5 % and
    raised the lightest children's (the 18.6 kg boy's hip 0.396 -> 0.484; measured)."""
    from exoleg.control.safety import Limited
    from exoleg.design.study import choose, spring_options
    from exoleg.validate.transparency import girl_walk, residual, transparent_walk

    options = spring_options(found["rows"], found["chosen"])
    trials: list[dict[str, Any]] = []
    if not options:
        return trials
    light = min((k[4] for k in design_set(design)), key=lambda c: c.mass, default=None)

    def walk(chosen: dict[str, dict[str, Any]], joint: str) -> float:
        """Walk ``chosen`` with both children; its row (``joint``: the joint varied, or
        "all"); the larger child's sum of the joints' residuals (inf on a fault)."""
        folder = work / f"trial-{len(trials)}"
        for name, text in device_files(design, choose(design, found["rows"], chosen)).items():
            (folder / name).parent.mkdir(parents=True, exist_ok=True)
            (folder / name).write_text(text)
        runs = {"": girl_walk(GIRL_STRIDES, design.stride_time, device=folder)[2]}
        if light is not None:
            runs["lightest_"] = transparent_walk(light, GIRL_STRIDES, design.stride_time,
                                                 device=folder)[1]
        row: dict[str, Any] = {"joint": joint, "chosen": False, "fault": any(
            bool(np.any(r.safety_status & Limited.FAULT)) for r in runs.values()),
            **{f"stiffness_Nm_per_rad_{j}": float(chosen[j]["stiffness_Nm_per_rad"])
               for j in JOINTS}}
        for who, r in runs.items():
            row.update({f"{who}residual_Nm_per_kg_{j}": float(v)
                        for j, v in zip(JOINTS, residual(r), strict=True)})
        row["worse_sum_Nm_per_kg"] = max(sum(row[f"{who}residual_Nm_per_kg_{j}"]
                                             for j in JOINTS) for who in runs)
        trials.append(row)
        return math.inf if row["fault"] else float(row["worse_sum_Nm_per_kg"])

    best, least, at = dict(found["chosen"]), math.inf, -1
    steps = max(len(rows) for rows in options.values())
    for k in range(steps):  # every compliant joint's k-th spring (its stiffest past its own)
        trial = {**found["chosen"], **{j: rows[min(k, len(rows) - 1)]
                                       for j, rows in options.items()}}
        if (total := walk(trial, "all")) < least:
            best, least, at = trial, total, len(trials) - 1
    for j, rows in options.items():  # then each joint's alone, from the best so far
        start = dict(best)
        for row in rows:
            if row is start[j]:
                continue
            if (total := walk({**start, j: row}, j)) < least:
                best, least, at = {**start, j: row}, total, len(trials) - 1
    if at >= 0:
        trials[at]["chosen"] = True
        found.update(choose(design, found["rows"], best))
    return trials


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
    transparent = (not tr["error"] and bool(tr["walked"])
                   and all(v <= design.goal for v in residual.values()))
    assisted = (not aan["error"] and bool(aan["walked"])
                and int(aan["ticks_torque_clipped"]) == 0
                and all(winding[j] < limits[j] for j in JOINTS))
    return {**kid, "mass_kg": float(tr["mass_kg"]),
            **{f"transparent_residual_Nm_per_kg_{j}": v for j, v in residual.items()},
            "transparent_fault": tr["fault"] or tr["error"],
            "transparent_met": transparent,
            "assist_ticks_clipped": int(aan["ticks_torque_clipped"]),
            **{f"assist_winding_max_C_{j}": v for j, v in winding.items()},
            "assist_fault": aan["fault"] or aan["error"], "assist_met": assisted,
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
                     "residual_worst_Nm_per_kg": {
                         j: float(np.nanmax([r[f"transparent_residual_Nm_per_kg_{j}"]
                                             for r in sel])) for j in JOINTS}}
    return out
