"""The operator interface's child form: its fields as the page labels them, and the
child as an actor (:mod:`exoleg.child`) the form sets -- checked, turned into the model
the simulated device carries, and said in words."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from exoleg.entry import typed_number

#: the child form's fields as the page labels them (errors are said in the form's words)
FORM_LABELS = {"age": "Age (years)", "height": "Height (cm)", "mass": "Mass (kg)",
               "thigh": "Thigh (hip-knee, cm)", "shank": "Shank (knee-ankle, cm)",
               "leg_length": "Leg length (cm)", "foot_length": "Foot length (cm)",
               "ankle_height": "Ankle height (cm)", "spasticity": "Spasticity",
               "crouch": "Crouch", "contracture": "Contracture",
               "contracture_level": "Contracture level (0-1.5)",
               "strength": "Strength (x the GMFCS level's typical)"}
#: what the simulated device carries the child as, when the form leaves it (docs/child.md)
ACTOR_DEFAULTS = {"spasticity": "none", "crouch": 0, "contracture": "none",
                  "contracture_level": 1.0, "strength": 1.0}


def actor_settings(body: dict[str, Any]) -> dict[str, Any]:
    """The child-as-an-actor settings of the child form (:data:`ACTOR_DEFAULTS` where it
    leaves one empty), checked: ValueError in the form's words when one is not allowed."""
    from exoleg.child.model import CROUCH_CLUSTERS, LEVELS, STRENGTH_SCALE
    from exoleg.child.passive import CONTRACTURE_LEVELS, child_data

    out = dict(ACTOR_DEFAULTS)
    for k in out:
        v = body.get(k)
        if v in (None, ""):
            continue
        label = FORM_LABELS[k]
        if k == "spasticity":
            if v not in LEVELS:
                raise ValueError(f"{label}: {str(v)[:20]!r} is not a level (allowed: "
                                 + ", ".join(LEVELS) + ")")
            out[k] = v
        elif k == "contracture":
            names = ["none", *sorted(child_data("contracture.toml"))]
            if v not in names:
                raise ValueError(f"{label}: {str(v)[:20]!r} is not a preset (allowed: "
                                 + ", ".join(names) + ")")
            out[k] = v
        elif k == "crouch":
            if str(v) not in {str(c) for c in CROUCH_CLUSTERS}:
                raise ValueError(f"{label}: {str(v)[:20]!r} is not a cluster (allowed: none, "
                                 f"1-{max(CROUCH_CLUSTERS)})")
            out[k] = int(v)
        else:
            lo, hi = CONTRACTURE_LEVELS if k == "contracture_level" else STRENGTH_SCALE
            x = typed_number(label, v)
            if not lo <= x <= hi:
                raise ValueError(f"{label}: {x:g} is outside {lo:g}-{hi:g}")
            out[k] = x
    return out


def actor_model(child: dict[str, Any], actor: dict[str, Any]) -> Any:
    """The fitted child (a fit record's ``child``) as the simulated device carries them
    (:class:`~exoleg.child.model.ChildModel`) with the form's ``actor`` settings; None
    for GMFCS V, which the child model does not cover."""
    from exoleg.child.model import ChildModel, Spasticity
    from exoleg.child.passive import Contracture

    gm = int(child.get("gmfcs") or 0)
    if gm > 4:
        return None
    a = {**ACTOR_DEFAULTS, **actor}
    return ChildModel(str(child.get("name") or "").strip() or "child", float(child["age"]),
                      float(child["height"]), float(child["mass"]), gm,
                      Contracture.preset(a["contracture"], float(a["contracture_level"])),
                      Spasticity.preset(a["spasticity"]), True, int(a["crouch"]),
                      str(child["sex"]), float(a["strength"]))


def actor_text(child: dict[str, Any], actor: dict[str, Any]) -> str:
    """The actor settings as the pages say them."""
    gm = int(child.get("gmfcs") or 0)
    a = {**ACTOR_DEFAULTS, **actor}
    strength = ("typically developing strength" if not gm else f"GMFCS {gm} strength")
    if a["strength"] != 1.0:
        strength += f" x {a['strength']:g}"
    contracture = ("no contracture" if a["contracture"] == "none" else
                   f"contracture {a['contracture']} at {a['contracture_level']:g}")
    crouch = "no crouch" if not a["crouch"] else f"crouch cluster {a['crouch']}"
    spasticity = ("no spasticity" if a["spasticity"] == "none" else
                  f"{a['spasticity']} spasticity")
    return f"{strength}, {spasticity}, {contracture}, {crouch}"


def fit_of_form(body: dict[str, Any], device_dir: str | None = None
                ) -> tuple[Any, Any, dict[str, Any], list[str]]:
    """The child the form describes (age y, height cm, mass kg, optional measured
    dimensions cm, GMFCS level, side, name) fitted to the device (the shipped one, or
    the files of ``device_dir``): the :class:`~exoleg.sizing.Child`, its fit report
    (:func:`~exoleg.design.report.fit_report`), the actor settings
    (:func:`actor_settings`) and the warnings the child's figures raised. ValueError or
    ParameterError in the form's words on a value that is not allowed."""
    import warnings

    from exoleg.design.report import fit_report
    from exoleg.device.actuator import paper_actuators
    from exoleg.entry import CHILD_ENTRY, MEASURED
    from exoleg.sizing import Child

    def typed(k: str, v: Any, kind: str) -> float:
        lo, hi, unit = CHILD_ENTRY[kind]
        label = FORM_LABELS.get(k, k)
        x = typed_number(label, v)
        if not lo <= x <= hi:
            raise ValueError(f"{label}: {x:g} is outside {lo:g}-{hi:g} {unit}")
        return x

    values: dict[str, Any] = {k: typed(k, body.get(k), k) for k in ("age", "height", "mass")}
    for k in MEASURED:
        if body.get(k) not in (None, ""):
            values[k] = typed(k, body[k], "measured") / 100
    gmfcs = str(body.get("gmfcs") or "0")
    if gmfcs not in ("0", "1", "2", "3", "4", "5"):
        raise ValueError(f"GMFCS level: {gmfcs[:10]!r} is not a level (allowed: 1-5, or "
                         "typically developing)")
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        child = Child(age=values.pop("age"), sex=str(body.get("sex", "")),  # type: ignore[arg-type]
                      height=values.pop("height") / 100, mass=values.pop("mass"),
                      gmfcs=int(gmfcs) or None,
                      affected_side=str(body.get("side", "right")),  # type: ignore[arg-type]
                      name=str(body.get("name") or "").strip()[:60] or "child",
                      **values)  # Child checks sex and side and names what is allowed
    rep = fit_report(child, actuators=None if device_dir is None
                     else paper_actuators(device_dir))
    return child, rep, actor_settings(body), [str(w.message) for w in caught]


def write_actor(record: dict[str, Any], folder: Path) -> str | None:
    """The child of fit ``record`` as the simulated device carries them, with the fit's
    actor settings (:func:`actor_model`), written to ``folder``/child.toml; its path, or
    None when the child is not modelled (GMFCS V)."""
    model = actor_model(record["child"], record.get("actor", {}))
    if model is None:
        return None
    (folder / "child.toml").write_text(model.to_toml(), encoding="utf-8")
    return str(folder / "child.toml")
