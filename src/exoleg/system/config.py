"""The device as configured, apart from any simulation of it: its actuators, safety
limits, foot board, gait-phase detector and walking gains, read once from the package's
``data/device`` files or a user's device folder (:mod:`exoleg.device.files`), each file
checked by its own loader.

One :class:`DeviceConfig` is what the assembly builds from
(:func:`exoleg.system.build.build`: the controller and, simulated, the device), and what
the drive masters are configured with (their actuators' scaling and the start-up check
against the range of motion), so configuring real drives never builds a simulator.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

from exoleg.control.assist import AssistSettings
from exoleg.control.gait_phase import DetectorSettings
from exoleg.control.hierarchy import WalkGains
from exoleg.control.safety import SafetyLimits
from exoleg.control.transparency import TransparencySettings
from exoleg.device.actuator import ActuatorModel, paper_actuators, params_array, with_actuators
from exoleg.device.sensors import FSR_FLOOR_N, FootSensors
from exoleg.dynamics.model import LegModel
from exoleg.errors import ParameterError


@dataclass(frozen=True)
class DeviceConfig:
    """The device's parts as data (SI units inside each record)."""

    actuators: tuple[ActuatorModel, ...]
    safety: SafetyLimits
    sensors: FootSensors
    detector: DetectorSettings
    gains: WalkGains
    folder: Path | None = None
    transparency: TransparencySettings = field(default_factory=TransparencySettings.default)
    assist: AssistSettings = field(default_factory=AssistSettings.default)

    def __post_init__(self) -> None:
        w = "DeviceConfig"
        for name, kind in (("safety", SafetyLimits), ("sensors", FootSensors),
                           ("detector", DetectorSettings), ("gains", WalkGains),
                           ("transparency", TransparencySettings),
                           ("assist", AssistSettings)):
            if not isinstance(getattr(self, name), kind):
                raise ParameterError(w, name, f"expected {kind.__name__}, got "
                                     f"{type(getattr(self, name)).__name__}")
        params_array(tuple(self.actuators))  # hip, knee, ankle, in that order

    @classmethod
    def load(cls, folder: str | Path | None = None, control_dt: float = 1e-3,
             noise_scale: float = 1.0, actuators: tuple[ActuatorModel, ...] | None = None,
             safety: SafetyLimits | None = None, sensors: FootSensors | None = None,
             gains: WalkGains | None = None) -> DeviceConfig:
        """The device of ``folder`` (None: the shipped files) at a control tick of
        ``control_dt`` s; the records given replace the files'. ``noise_scale``
        multiplies the foot board's noise figures (0: ideal; a simulation's choice)."""
        from exoleg.device.files import check_folder

        if not (isinstance(control_dt, (int, float)) and 1e-4 <= control_dt <= 1e-2):
            raise ParameterError("DeviceConfig", "control_dt",
                                 f"{control_dt!r} s is outside 1e-4-0.01 s")
        where = None if folder is None else check_folder(folder)
        acts = paper_actuators(where) if actuators is None else tuple(actuators)
        return cls(actuators=acts,
                   safety=(SafetyLimits.paper(control_dt, where, acts) if safety is None
                           else safety),
                   sensors=(FootSensors.default(noise_scale, where) if sensors is None
                            else sensors),
                   detector=DetectorSettings.default(where),
                   gains=WalkGains.default(where) if gains is None else gains, folder=where,
                   transparency=TransparencySettings.default(where),
                   assist=AssistSettings.default(where))

    @property
    def fsr_floor_counts(self) -> float:
        """The detector's calibration floor in ADC counts (:data:`FSR_FLOOR_N`)."""
        return self.sensors.counts(FSR_FLOOR_N)

    def summary(self) -> dict[str, object]:
        """What a run's record says of the device it ran on: its folder (None: the shipped
        files), each actuation unit's motor, gear, ratio and torque limit (N m), and the
        cuffs' torque limit per joint it watched (N m/kg; None: not watched) -- so a
        session's report reads the limit it ran with, whatever became of the folder."""
        return {"folder": None if self.folder is None else str(self.folder),
                "actuators": [{"joint": a.joint, "motor": a.motor, "gear": a.gear,
                               "ratio": a.ratio, "torque_limit_Nm": a.torque_limit}
                              for a in self.actuators],
                "cuff_limit_Nm_per_kg": [float(x) if math.isfinite(x) else None
                                         for x in self.safety.cuff_limit]}

    def leg(self, leg: LegModel) -> LegModel:
        """``leg`` with the actuators' reflected inertia (the device's leg model)."""
        return with_actuators(leg, self.actuators)
