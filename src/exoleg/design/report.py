"""One child's fitting, whole: the geometric fit, the personalized leg, the actuator
demand against the device's actuation units (their datasheets), the verdict and the
record kept with the child (``fit.json``).
``exoleg fit`` prints and writes it; the operator interface shows it and keeps it with a
session."""

from __future__ import annotations

import dataclasses
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from exoleg.design.demand import Demand, Exceedance, actuator_demand, table2_limits
from exoleg.dynamics.model import LegModel
from exoleg.sizing.anthropometry import LegLengthMethod
from exoleg.sizing.child import Child
from exoleg.sizing.fit import DeviceFit, fit_device
from exoleg.sizing.personal import personalized_leg


@dataclass(frozen=True)
class FitReport:
    child: Child
    fit: DeviceFit
    leg: LegModel
    demand: Demand
    over: list[Exceedance]

    @property
    def verdict(self) -> str:
        if self.fit.fits and not self.over:
            return "FITS"
        if self.fit.fits:
            return "FITS geometrically, but the actuators are short of the demand"
        return "DOES NOT FIT"

    @property
    def notes(self) -> list[str]:
        """What does not fit and every demand over the device's limits, one line each."""
        return ([f"{m.what}: child {m.child * 100:.2f} cm, allowed {m.allowed[0] * 100:.1f}-"
                 f"{m.allowed[1] * 100:.1f} cm" for m in self.fit.misses]
                + [f"demand over the device's limit: {e}" for e in self.over])

    def record(self, leg_file_written: bool) -> dict[str, Any]:
        """The JSON record (SI units) of ``fit.json``."""
        mg, src, qn, joint = self.demand.smallest_margin()
        return _finite(json.loads(json.dumps({
            "child": dataclasses.asdict(self.child), "charts": self.child.charts,
            "dimensions_m": dataclasses.asdict(self.fit.dimensions),
            "fits": self.fit.fits, "within_limits": not self.over, "verdict": self.verdict,
            "exceedances": [dataclasses.asdict(e) | {"ratio": e.ratio, "text": str(e)}
                            for e in self.over],
            "settings_m": {"upper": self.fit.upper, "lower": self.fit.lower},
            "link_lengths_m": list(self.fit.link_lengths),
            "misses": [dataclasses.asdict(m) for m in self.fit.misses],
            "paper_rule": self.fit.paper_rule,
            "range_of_motion_rad": self.fit.range_of_motion,
            "demand": self.demand.table(), "limits": self.demand.limits,
            "table2_limits": table2_limits(),
            "smallest_margin": {"margin": mg, "source": src, "quantity": qn, "joint": joint},
            "notes": self.notes, "leg_file_written": leg_file_written}, default=jsonable)))

    def leg_text(self) -> str:
        """The personalized leg file's text, marked when the device does not fit the
        child."""
        from exoleg.params.leg_file import format_leg

        c = self.child
        header = (f"personalized leg of {c.name} ({c.age:g} y {c.sex}, {c.height:.3f} m, "
                  f"{c.mass:.1f} kg) made by exoleg fit")
        if not self.fit.fits:
            header += ("\nTHE DEVICE DOES NOT FIT THIS CHILD: written on request "
                       "(--write-leg); telescope settings clamped to the device's range")
        return format_leg(self.leg.links, self.leg.g, self.leg.name, header=header,
                          fit={"fits": self.fit.fits, "note": "; ".join(self.notes),
                               "height_m": c.height, "mass_kg": c.mass},
                          armature=self.leg.armature)

    def save_leg(self, path: str | Path) -> Path:
        """The personalized leg file (:meth:`leg_text`), written whole or not at all."""
        from exoleg.io import atomic_path

        with atomic_path(path) as tmp:
            tmp.write_text(self.leg_text(), encoding="utf-8")
        return Path(path)


def fit_report(child: Child, leg_length_method: LegLengthMethod = "linear",
               percentile: float = 50.0, speed: str = "Free", stride_time: float = 1.1,
               simulate: bool = True, actuators: tuple[Any, ...] | None = None) -> FitReport:
    """Fit the device to ``child``; the demand is this gait percentile's at ``speed``,
    against ``actuators`` (None: the shipped ones; a device folder's:
    :func:`~exoleg.device.actuator.paper_actuators`)."""
    fit = fit_device(child, leg_length_method)
    leg = personalized_leg(child, fit)
    demand = actuator_demand(child, leg, percentile=percentile, speed=speed,
                             stride_time=stride_time, simulate=simulate, actuators=actuators)
    return FitReport(child, fit, leg, demand, demand.exceedances())


def _finite(x: Any) -> Any:
    """The record with non-finite numbers (a margin where there is no demand) as null:
    JSON has no infinity."""
    if isinstance(x, float):
        return x if np.isfinite(x) else None
    if isinstance(x, dict):
        return {k: _finite(v) for k, v in x.items()}
    if isinstance(x, list):
        return [_finite(v) for v in x]
    return x


def jsonable(o: Any) -> Any:
    """numpy values as JSON values (``json.dumps(default=...)``)."""
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, (np.floating, np.integer, np.bool_)):
        return o.item()
    return str(o)
