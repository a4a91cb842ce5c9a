"""A study's results over two of its axes: for each pair of values, how many runs, how
many walked (no safety fault) and the tightest figures -- a coverage table and a heat map,
the population heat map generalised to any two axes."""

from __future__ import annotations

from collections import Counter, defaultdict
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from exoleg.errors import ParameterError
from exoleg.params.records import JOINTS

#: A cell's figures (:func:`summarise`).
CELL = ("runs", "walked", "walked_fraction", "failed", "clipped_fraction",
        "tracking_error_deg", "winding_max_C", "gear_beyond_momentary_runs",
        "stability_margin", "interaction_rms_Nm_per_kg", "support_first", "support_last",
        "safety_event_runs", "commonest_fault")


@dataclass(frozen=True)
class Summary:
    """Cells over axes ``x`` and ``y`` (values in the order found): ``cells[(xv, yv)]``
    is a dict of :data:`CELL`."""

    x: str
    y: str
    xs: list[Any]
    ys: list[Any]
    cells: dict[tuple[Any, Any], dict[str, Any]]

    def rows(self) -> list[dict[str, Any]]:
        """One dict per cell, axis values first (for CSV or a table)."""
        return [{self.x: xv, self.y: yv, **self.cells[(xv, yv)]}
                for yv in self.ys for xv in self.xs if (xv, yv) in self.cells]


def default_axes(out: str | Path) -> tuple[str, str]:
    """The study's first two swept axes (one swept: it and the group; none: group)."""
    import json

    try:
        swept = json.loads((Path(out) / "study.json").read_text(encoding="utf-8"))["swept"]
    except (OSError, ValueError, KeyError, TypeError):
        raise ParameterError(str(out), "study.json", "missing or damaged (it names the "
                             "axes the study sweeps): give the axes with --x and --y") from None
    axes = [*swept, "group", "sex"]
    x = axes[0]
    y = next(a for a in axes[1:] if a != x)
    return x, y


def summarise(out: str | Path, x: str | None = None, y: str | None = None) -> Summary:
    """The coverage of the study in ``out`` over axes ``x`` and ``y`` (default: the first
    two it sweeps). ``clipped_fraction``: the share of ticks in which the safety layer
    clipped a joint's torque at its limit, the cell's mean; ``tracking_error_deg``: the
    largest joint's RMS tracking error, the cell's mean over the runs that walked;
    ``winding_max_C``: the hottest winding the safety layer estimated;
    ``stability_margin``: the largest sampled-loop h lambda (stable below 2);
    ``interaction_rms_Nm_per_kg``: the largest joint's RMS cuff torque per kg, the mean
    over the runs that walked (NaN for a passive leg); ``support_first``/``_last``: the
    support of the first and the last stride (0-1, mean over joints), the cell's mean;
    ``safety_event_runs``: the runs in which the safety layer acted (clipped, limited,
    derated) while walking."""
    from exoleg.study.engine import read_results

    table = read_results(out)
    if x is not None and x == y:
        raise ParameterError("exoleg sweep --summary", "--y", f"{y!r} is --x too: a table "
                             "over one axis twice is its diagonal (name two axes)")
    if x is None or y is None:
        dx, dy = default_axes(out)
        if x is None:
            x = dx if dx != y else dy
        if y is None:
            y = dy if dy != x else dx
    for name, axis in (("--x", x), ("--y", y)):
        if axis not in table.column_names:
            raise ParameterError("exoleg sweep --summary", name, f"{axis!r} is not a column "
                                 "of the study (axes: " + ", ".join(_axes(table)) + ")")
    cols = table.to_pydict()
    n = table.num_rows
    groups: dict[tuple[Any, Any], list[int]] = defaultdict(list)
    for i in range(n):
        groups[(cols[x][i], cols[y][i])].append(i)

    def worst(prefix: str, i: int) -> float:
        return max(cols[f"{prefix}_{j}"][i] for j in JOINTS)

    def mean(values: list[float]) -> float:
        v = [x for x in values if np.isfinite(x)]
        return float(np.mean(v)) if v else float("nan")

    cells = {}
    for key, idx in groups.items():
        ok = [i for i in idx if not cols["error"][i]]
        walked = [i for i in ok if cols["walked"][i]]
        clipped = [cols["ticks_torque_clipped"][i] / cols["ticks"][i] for i in ok]
        faults = Counter(cols["fault"][i] for i in ok if cols["fault"][i])
        cells[key] = {
            "runs": len(idx), "walked": len(walked),
            "walked_fraction": len(walked) / len(idx),
            "failed": len(idx) - len(ok),
            "clipped_fraction": float(np.mean(clipped)) if clipped else float("nan"),
            "tracking_error_deg": float(np.mean([worst("rms_tracking_error_deg", i)
                                                 for i in walked])) if walked else
            float("nan"),
            "winding_max_C": max((worst("safety_winding_max_C", i) for i in ok),
                                 default=float("nan")),
            "gear_beyond_momentary_runs": sum(1 for i in ok
                                              if cols["ticks_gear_beyond_momentary"][i] > 0),
            "stability_margin": max((cols["stability_margin"][i] for i in ok),
                                    default=float("nan")),
            "interaction_rms_Nm_per_kg": mean([worst("interaction_rms_Nm_per_kg", i)
                                               for i in walked]),
            "support_first": mean([cols["support_first"][i] for i in ok]),
            "support_last": mean([cols["support_last"][i] for i in ok]),
            "safety_event_runs": sum(1 for i in ok if cols["safety_events"][i] > 0),
            "commonest_fault": faults.most_common(1)[0][0] if faults else ""}
    xs = sorted({k[0] for k in cells}, key=_order)
    ys = sorted({k[1] for k in cells}, key=_order)
    return Summary(x=x, y=y, xs=xs, ys=ys, cells=cells)


def _order(v: Any) -> tuple[int, Any]:
    return (0, v) if isinstance(v, int | float) else (1, str(v))


def _axes(table: Any) -> list[str]:
    from exoleg.study.spec import AXES

    return [c for c in table.column_names if c in AXES or c == "profile"]
