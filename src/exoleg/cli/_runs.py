"""What the simulations' variants share (``exoleg simulate``, ``--actuators``,
``--walk``): the actuators the options ask for and a run's outputs written together."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

from exoleg.io import OutputFolder


def device_actuators(args: argparse.Namespace) -> Any:
    """The actuators ``--hip-motor`` asks for (the device folder's, or the shipped, knee and
    ankle), or None: the device folder's or the shipped ones."""
    if args.hip_motor is None:
        return None
    from exoleg.device.actuator import hip_variant, paper_actuators

    _, knee, ankle = paper_actuators(args.device)
    return hip_variant(args.hip_motor), knee, ankle


def settings(args: argparse.Namespace) -> dict[str, Any]:
    """The options a run was given, for its summary (paths and arrays as text)."""
    import numpy as np

    return {k: (str(v) if isinstance(v, (Path, np.ndarray)) else v)
            for k, v in vars(args).items() if k != "func"}


def write_run(args: argparse.Namespace, result: Any, figure: Any, stem: str, t0: float,
               summary: dict[str, Any], more: dict[str, Any] | None = None) -> str:
    """A run's outputs, committed together: the time series (``--format``), its figure
    (PNG, and SVG with ``--svg``) and ``more`` figures (stem -> a function of the path),
    and ``summary.json`` (the settings, ``summary``, the files, the wall time). Returns
    the line that says what was written."""
    with OutputFolder(args.out, owner="exoleg simulate") as out:
        name = "timeseries.parquet" if args.format == "parquet" else "timeseries.csv"
        (result.to_parquet if args.format == "parquet" else result.to_csv)(out.stage(name))
        files = [name]
        draw = {stem: lambda path: figure(result, path), **(more or {})}
        for name, fn in draw.items():
            for fmt in ("png", "svg") if args.svg else ("png",):
                fn(out.stage(f"{name}.{fmt}"))
                files.append(f"{name}.{fmt}")
        record = {"settings": settings(args), **summary, "files": files,
                  "wall_time_s": time.perf_counter() - t0}
        out.stage("summary.json").write_text(json.dumps(record, indent=2, default=str))
        out.commit(last="summary.json")
    return (f"\nwrote {out.folder}/: " + ", ".join(["summary.json", *files])
            + f"  ({record['wall_time_s']:.1f} s)")
