"""A child's record over time (issue 42): their sessions from the console's records
(``records.sqlite`` in the sessions folder), each with the figures kept when it ended
(``figures.json``; computed from its log where an older session has none), and what
changed beyond the Gait Profile Score's minimal clinically important difference."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from exoleg.errors import ExolegError, ParameterError
from exoleg.hmi.settings import kept_settings
from exoleg.io import read_record
from exoleg.reference.scores import GPS_MCID_DEG

#: the figures a child's history trends, by their key in a session's figures
TRENDED = ("walk_time_s", "steps", "cadence_steps_per_min", "stance_percent", "gps_deg")


def kept_figures(folder: Path) -> dict[str, Any] | None:
    """A session's figures (:func:`~exoleg.runtime.figures.session_figures`) as kept
    when it ended (``figures.json``), computed from its log where it has none; None for
    a log that holds nothing to read."""
    from exoleg.runtime.figures import session_figures

    kept = read_record(folder / "figures.json")
    if kept:
        return kept  # (absent or damaged: from the log)
    try:
        return session_figures(folder)
    except (ExolegError, ValueError):
        return None  # a session whose log holds nothing to read (listed, without figures)


def expected_stride(registry: Any, root: Path, child_id: str,
                    device: str | Path | None = None) -> tuple[float | None, str]:
    """The stride child ``child_id``'s next session's walking controller expects until it
    has measured theirs, from the records (``registry``: a
    :class:`~exoleg.hmi.registry.Registry`, or None; ``root``: the sessions folder), and
    that said: the mean stride of their latest session whose figures (``figures.json``,
    kept as it ended) hold at least as many whole strides as the detector averages
    (``gait_phase.toml`` ``strides_averaged``, the ``device`` folder's or the shipped
    one's), within the strides a child can walk --
    or None, and why, where the controller expects the planned 1.1 s. A child's first
    stride, timed at 1.1 s while they walk theirs, led their swinging leg: the reference
    reached their toe off late and their toe caught the belt (docs/design.md)."""
    from exoleg.control.gait_settings import DetectorSettings
    from exoleg.reference.gait import STRIDE_TIME_RANGE

    need = DetectorSettings.default(device).strides_averaged
    lo, hi = STRIDE_TIME_RANGE
    for s in reversed([] if registry is None else registry.sessions_of(child_id)):
        fig = read_record(root / s["name"] / "figures.json")
        stride, n = fig.get("stride_time_s"), fig.get("strides")
        if not (isinstance(stride, list) and stride and isinstance(n, int) and n >= need):
            continue  # (too few strides, not walked, or no figures kept)
        mean = stride[0]
        if isinstance(mean, (int, float)) and not isinstance(mean, bool) and lo <= mean <= hi:
            return float(mean), (f"expecting their {mean:.2f} s strides (session "
                                 f"{s['name']}: {n} strides)")
    return None, ("expecting 1.1 s strides until theirs are measured (no session of "
                  f"theirs with {need} whole strides)")


def child_history(sessions: str | Path, child_id: str) -> dict[str, Any]:
    """A child's sessions over time with their figures and the trend.

    Parameters
    ----------
    sessions : str or Path
        The console's sessions folder (``exoleg hmi --sessions``).
    child_id : str
        The child's pseudonymous id (``C3f9a01bc``).

    Returns
    -------
    dict
        ``child_id``, ``name``, ``sessions`` (oldest first: ``name``, ``started``,
        ``operator``, ``note``, the trended figures and ``assistance`` -- per joint the
        support level's mean over the gait phases, 1 the impedance's full support --,
        None where a session has none), ``settings`` (what their next session starts
        with: the settings their last session ended with, or None) and ``settings_text``
        (that said),
        ``gps_change_deg`` (the last GPS less the first) and ``beyond_mcid`` (whether
        that change exceeds the GPS's minimal clinically important difference; None
        with fewer than two scored sessions).
    """
    from exoleg.hmi.registry import FILE, Registry

    root = Path(sessions)
    if not (root / FILE).is_file():
        raise ParameterError(str(root), FILE, "no records here (the console's sessions "
                             "folder, exoleg hmi --sessions, holds them)")
    reg = Registry(root / FILE)
    try:
        if not reg.exists(child_id):
            ids = ", ".join(c["id"] for c in reg.children()) or "none"
            raise ParameterError(str(root), child_id, f"no such child (children: {ids})")
        name = next(c["name"] for c in reg.children() if c["id"] == child_id)
        rows = []
        for s in reg.sessions_of(child_id):
            fig = kept_figures(root / s["name"]) or {}
            rows.append({**s, **{k: fig.get(k) for k in TRENDED},
                         "assistance": _assistance(fig.get("assistance"))})
        settings, said = kept_settings(reg, child_id)
    finally:
        reg.close()
    return {"child_id": child_id, "name": name, "sessions": rows, **_change(rows),
            "settings": settings, "settings_text": said}


def _assistance(by_phase: dict[str, dict[str, float | None]] | None
                ) -> dict[str, float | None] | None:
    """Per joint, the support level's mean over the gait phases a session walked."""
    if not by_phase:
        return None
    return {j: (float(np.mean(v)) if (v := [x for x in p.values() if x is not None])
                else None) for j, p in by_phase.items()}


def _change(rows: list[dict[str, Any]]) -> dict[str, Any]:
    """The GPS's change from the first scored session to the last, and whether it is
    beyond the MCID (None with fewer than two)."""
    scored = [r["gps_deg"] for r in rows if r["gps_deg"] is not None]
    change = scored[-1] - scored[0] if len(scored) >= 2 else None
    return {"gps_change_deg": change,
            "beyond_mcid": None if change is None else abs(change) > GPS_MCID_DEG}


def history_until(folder: str | Path) -> dict[str, Any] | None:
    """The history (:func:`child_history`) of the child a session ran on, up to that
    session, when the console's records beside it hold one; None for a session run
    without them (``exoleg run``)."""
    from exoleg.hmi.registry import FILE, Registry

    root = Path(folder)
    if not (root.parent / FILE).is_file():
        return None
    try:
        reg = Registry(root.parent / FILE)
        try:
            rec = reg.session(root.name)
        finally:
            reg.close()
        if not rec or not rec["child_id"]:
            return None
        h = child_history(root.parent, rec["child_id"])
    except ExolegError:
        return None
    names = [s["name"] for s in h["sessions"]]
    if root.name in names:  # up to this session, not after it
        h["sessions"] = h["sessions"][:names.index(root.name) + 1]
        h.update(_change(h["sessions"]))
    return h
