"""The one place the system is built: from a device configuration
(:class:`~exoleg.system.config.DeviceConfig`), the child + device leg, the child and their
body mass, the controller -- and, when the device is simulated, the simulated device it
drives, made for the same leg, child and treadmill. ``exoleg simulate --walk``, ``exoleg
run`` (every backend), ``identify``, the validation and the sweeps all build here, so a
device folder's files reach each of them alike."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from exoleg.child.interaction import device_leg
from exoleg.child.model import ChildModel
from exoleg.control.hierarchy import WalkController
from exoleg.control.transparency import SupportMode, support_mode_of
from exoleg.device.actuator import params_array
from exoleg.device.ground import ANKLE_HEIGHT, Ground
from exoleg.dynamics.model import LegModel
from exoleg.entry import CONTROLLERS, WALKING_CONTROLLERS
from exoleg.errors import ParameterError
from exoleg.reference.gait import STRIDE_TIME_RANGE
from exoleg.system.config import DeviceConfig
from exoleg.tick import Controller
from exoleg.world.device import SimulatedDevice


@dataclass(frozen=True)
class System:
    """What :func:`build` made: the configuration, the controller and, when simulated,
    the device it drives (None: a real device's drives are the runtime's)."""

    config: DeviceConfig
    controller: Controller
    device: SimulatedDevice | None = None


def walk_controller(config: DeviceConfig, leg: LegModel, body_mass: float,
                    depth: float, speed: str = "Free", stride_time: float = 1.1,
                    support_mode: SupportMode = SupportMode.IMPEDANCE) -> WalkController:
    """The walking hierarchy for the child + device ``leg`` (without actuators: theirs
    are added) and a child of ``body_mass`` kg, its FSRs ``depth`` m below the
    ankle joint, expecting strides of ``stride_time`` s of the ``speed`` gait, starting
    in ``support_mode`` (the transparent mode's model: the device alone at ``leg``'s
    telescope settings, :func:`~exoleg.child.interaction.device_leg`)."""
    if not isinstance(config, DeviceConfig):
        raise ParameterError("walk_controller", "config",
                             f"expected DeviceConfig, got {type(config).__name__}")
    if not (np.isfinite(depth) and 0.0 <= depth <= 0.3):
        raise ParameterError("walk_controller", "depth", f"{depth!r} m is outside 0-0.3 m")
    return WalkController(config.leg(leg), body_mass, config.gains, config.detector,
                          config.safety, speed, stride_time, config.fsr_floor_counts, depth,
                          config.sensors.gyro_range, config.sensors.accel_range,
                          device_leg(leg, config.actuators).p, params_array(config.actuators),
                          config.transparency, support_mode, config.assist,
                          config.sensors.other_foot)


def build(config: DeviceConfig, leg: LegModel, body_mass: float,
          controller: str = "impedance", *, simulated: bool = True,
          child: ChildModel | None = None, model: LegModel | None = None,
          speed: str = "Free", stride_time: float = 1.1,
          ankle_height: float = ANKLE_HEIGHT, ground: Ground | None = None,
          step: float = 0.0, reference: Any = None,
          expected_stride: float | None = None) -> System:
    """The controller called ``controller`` (:data:`~exoleg.entry.CONTROLLERS`, or
    ``FILE.py:NAME`` / ``MODULE:NAME``: a law of your own,
    :func:`~exoleg.control.tracking.law_factory`, behind the same supervisor and safety
    layer as the paper's laws) for the device ``config`` and the child + device ``leg``
    (without actuators: theirs are added) of a child of ``body_mass`` kg, and,
    ``simulated``, the device it drives.

    The walking hierarchy expects strides of ``expected_stride`` s (the child's own
    cadence, e.g. their last session's; default ``stride_time``, the walk planned) of the
    ``speed`` gait until it has measured the child's; a law of the paper follows
    ``reference`` (default the paper's scenario, section 6) on the leg with the actuators'
    reflected inertia. ``model``: the leg the controller is
    given when it is not the one the simulated device carries (identification's truth).
    The simulated device: the treadmill's ``ground`` (default the device folder's
    ``walking.toml``), the ankle ``ankle_height`` m above the sole, the ``child`` as an
    actor (:class:`~exoleg.child.model.ChildModel`; None: a passive leg), on a ``step``
    that high (m) with the leg hanging (see :meth:`SimulatedDevice.of`)."""
    w = "build"
    if not isinstance(config, DeviceConfig):
        raise ParameterError(w, "config", f"expected DeviceConfig, got {type(config).__name__}")
    own = None
    if controller not in CONTROLLERS:
        if ":" not in str(controller):
            raise ParameterError(w, "controller", f"unknown {controller!r} (allowed: "
                                 + ", ".join(CONTROLLERS) + ", or FILE.py:NAME or "
                                 "MODULE:NAME for a law of your own)")
        from exoleg.control.tracking import law_factory

        own = law_factory(controller)  # before the device is made: a bad name says so
    if expected_stride is None:
        expected_stride = stride_time
    lo, hi = STRIDE_TIME_RANGE
    if not (isinstance(expected_stride, (int, float)) and not isinstance(expected_stride, bool)
            and lo <= expected_stride <= hi):
        raise ParameterError(w, "expected_stride", f"{expected_stride!r} s is outside "
                             f"{lo:g}-{hi:g} s (a stride a child can walk)")
    gr = Ground.default(config.folder) if ground is None else ground
    dev = None
    if simulated:  # first: it checks the child's and the treadmill's figures
        dev = SimulatedDevice.of(leg, body_mass, config.actuators, config.sensors, gr,
                                 config.gains.standing, speed=speed, stride_time=stride_time,
                                 ankle_height=ankle_height, child=child, step=step,
                                 folder=config.folder)
    ctl: Any
    if controller in WALKING_CONTROLLERS:
        ctl = walk_controller(config, leg if model is None else model, body_mass,
                              ankle_height + gr.sole, speed, float(expected_stride),
                              support_mode_of(controller))
        support = ctl.starting_support()
    else:
        from exoleg.control.controllers import law_named
        from exoleg.control.tracking import TrackingController
        from exoleg.reference.paper import paper_reference

        believed = config.leg(leg if model is None else model)
        law: Any
        if own is None:
            law = law_named(controller, believed)
        else:
            try:
                law = own(believed)
            except Exception as e:  # the user's code: what failed, in one line
                raise ParameterError(w, "controller", f"{controller!r}: making the law "
                                     f"failed: {type(e).__name__}: {e}") from None
        ctl = TrackingController(law,
                                 paper_reference() if reference is None else reference,
                                 config.safety)
        support = config.gains.support  # what the impedance holds a child standing with
    if dev is not None:  # the child leaves the device the support it starts with
        dev = dataclasses.replace(dev, child_support=support)
    return System(config, ctl, dev)
