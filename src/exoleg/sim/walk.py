"""Walking with the full device: plant with contacts, sensors, the control hierarchy,
the safety layer and the actuators, in one compiled loop.

Every control tick (1 kHz):

1. the foot board reads its four FSRs (the contacts' true normal forces through
   :func:`exoleg.device.sensors.fsr_counts`) and its IMU; the encoders read the joints;
2. the controller tick (:func:`exoleg.control.hierarchy.walk_control_step`): gait-phase
   detection, supervisor, reference at the detected phase, phase-scheduled impedance
   with the current pendulum's gravity model, safety layer;
3. the drives: envelope at the measured speed, current loop;
4. the plant (:mod:`exoleg.world.plant`): ``substeps`` RK4 steps per tick with the
   contact and support forces of each step's start, the actuators' friction in every
   stage.

The operator's commands come as a schedule (arm at 0, walk after ``standing`` seconds
of quiet stance in which the FSRs calibrate). The true contact events (from the
noise-free contact forces) are kept beside the detected ones for
:func:`detection_table`.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, NamedTuple, cast

import numpy as np
from numba import njit
from numpy.typing import NDArray

from exoleg.child.model import ChildModel
from exoleg.child.passive import passive_moments
from exoleg.control.hierarchy import WalkController, WalkGains, walk_control_step
from exoleg.control.safety import SafetyLimits
from exoleg.control.transparency import PARTS, SupportMode, TransparencySettings
from exoleg.device.actuator import ActuatorModel
from exoleg.device.drive import drive_limit
from exoleg.device.faults import SensorFault, apply_faults, fault_records
from exoleg.device.ground import ANKLE_HEIGHT, Ground
from exoleg.device.sensors import FROZEN_S, FootSensors, draw_noise
from exoleg.dynamics.model import LegModel
from exoleg.errors import ParameterError, SimulationError
from exoleg.params.records import JOINTS
from exoleg.sim.events import true_events
from exoleg.sim.series import TimeSeries
from exoleg.system.build import build
from exoleg.system.config import DeviceConfig
from exoleg.tick import OUTPUT, SENSOR_POINTS, SENSORS, Command, Mode
from exoleg.world.device import device_actuate, device_sense
from exoleg.world.plant import WalkingPlant

F64 = NDArray[np.float64]

class World(NamedTuple):
    """The simulated device as the compiled run reads it (:func:`_run_walk`): the plant's
    leg parameters and record, the actuators' records, the child's records
    (:meth:`~exoleg.world.device.SimulatedDevice.child_records`), the foot board's, where
    the IMU sits on the foot (m), the other leg's support table and standing height, the
    expected stride (s)."""

    p: F64
    w: NDArray[np.void]
    A: NDArray[np.void]
    K: tuple[Any, ...]
    sens: NDArray[np.void]
    imu_x: float
    imu_y: float
    support: F64
    stand_support: float
    stride: float


class Plan(NamedTuple):
    """What a walk is given tick by tick: the operator's command per tick, the sensor
    faults (:data:`~exoleg.device.faults.FAULT`), the sensors' noise per tick and the
    IMU's bias, the tick (s), the plant's substeps per tick, and after how many ticks of
    foot-board readings repeated bit for bit the board is frozen (0: not watched -- ideal,
    noise-free sensors repeat)."""

    commands: NDArray[np.int64]
    faults: NDArray[np.void]
    fsr_noise: F64
    imu_noise: F64
    imu_bias: F64
    h: float
    sub: int
    frozen: int


class Series(NamedTuple):
    """What a walk records per tick (:class:`WalkResult` is made of it): the plant's state
    ``X`` (n+1, 8), the readings ``SENS`` (:data:`SENSORS`), the true normal force under
    each sensor's region ``FN``, the controller's ``OUT`` (:data:`OUTPUT`), the torque
    delivered ``TAU`` and the drives' envelope ``ENV``, the other leg's support ``SUP``,
    the child's muscles' torque ``CH``, the transparent law's parts and wall and the
    proportional assistance's gain ``PA`` (n+1, 6, 3), the child's stance share ``SH``."""

    X: F64
    SENS: NDArray[np.void]
    FN: F64
    OUT: NDArray[np.void]
    TAU: F64
    ENV: F64
    SUP: F64
    CH: F64
    PA: F64
    SH: F64


@njit(cache=True, error_model="numpy")
def _run_walk(world, ctl, plan, S, series):  # type: ignore[no-untyped-def]
    """The walking run (``world``: :class:`World`, ``plan``: :class:`Plan`, ``series``:
    :class:`Series`, ``S``: the simulated device's state): per tick k the device's
    readings into ``SENS[k]``, the controller's tick (``ctl``:
    :meth:`WalkController.compiled`) into ``OUT[k]`` -- the readings with the sensor
    faults --, the drives, the child and the plant, and what the series keep of them.
    The foot board is watched as the runtime watches it
    (:class:`~exoleg.runtime.watch.SensorWatch`): frozen, the torque goes off (an E-stop
    from that tick on). Returns (-1, or the tick whose state became non-finite; -1, or
    the tick the board was found frozen)."""
    p, w, A, K, sens, imu_x, imu_y, support, stand_support, stride = world
    commands, F, fsr_noise, imu_noise, imu_bias, h, sub, frozen = plan
    same = 0
    froze = -1
    X, SENS, FN, OUT, TAU, ENV, SUP, CH, PA, SH = series
    ss, as_ = ctl[12], ctl[14]  # the support mode's and assist-as-needed's states
    n = X.shape[0] - 1
    for k in range(n + 1):
        t = k * h
        sk = SENS[k:k + 1]
        ok_ = OUT[k:k + 1]
        # 1. the foot board and the encoders
        device_sense((p, w, A), (sens, imu_x, imu_y), S, h, k == 0,
                     (fsr_noise[k], imu_noise[k], imu_bias), sk, FN[k])
        apply_faults(F, sk, t)
        if frozen > 0 and froze < 0:
            alike = k > 0 and SENS[k].gyro == SENS[k - 1].gyro
            for i in range(4):
                alike = alike and SENS[k].fsr[i] == SENS[k - 1].fsr[i]
            same = same + 1 if alike else 0
            if same >= frozen:
                froze = k
        sk[0].command = commands[k] if froze < 0 else Command.ESTOP
        # 2. the controller tick (supervisor, detection, reference, impedance, safety)
        walk_control_step(ctl, sk, t, ok_)
        for i in range(3):
            for m in range(4):
                PA[k, m, i] = ss[0].parts[m, i]
            PA[k, 4, i] = ss[0].wall[i]
            PA[k, 5, i] = as_[0].k[i]
        SH[k] = K[2][0].share0
        if k == n:
            for i in range(3):
                ENV[k, i] = drive_limit(A[i:i + 1], SENS[k].dq[i], OUT[k].tau[i])
                TAU[k, i] = S[0].tau[i]
            break
        # 3. the drives and 4. the plant
        walking = OUT[k].mode == Mode.WALKING or OUT[k].mode == Mode.STOPPING
        SUP[k], ok = device_actuate((p, w, A), K, S, (h, sub), OUT[k].tau, FN[k],
                                    (walking, t, stride, support, stand_support),
                                    (ENV[k], TAU[k]))
        for i in range(8):
            X[k + 1, i] = S[0].x[i]
        for i in range(3):
            CH[k, i] = S[0].child[i]
        if not ok:
            return k + 1, froze
    return -1, froze


@dataclass(frozen=True)
class WalkResult(TimeSeries):
    """A walking run's time series, SI units; joints (hip, knee, ankle), FSRs
    (:data:`SENSOR_POINTS`). ``pelvis`` height m; q, dq true; q_meas, dq_meas; q_ref;
    fsr (counts) and contact_force (true normal force, N) per sensor; gyro rad/s,
    accel (2) m/s^2 (foot frame); mode, phase, gait_fraction, events (bits), safety
    status per tick; u_safe (to the drives), tau (delivered), envelope; support (the
    other leg's force on the pelvis, N); the safety layer's estimates per joint:
    winding_temp (degC) and gear_torque (N m); the fault latched and its joint per tick
    (:class:`~exoleg.control.safety.Fault`, -1 for none); the child: ``interaction`` (the
    cuffs' torque, N m, :mod:`exoleg.child.interaction`: the rigid model's, impacts and
    all), ``cuff`` (that reading through the cuffs' low-pass, as the safety layer checks
    it against its limit, N m), ``child_torque`` (their
    muscles' reflexes and effort, N m) and ``passive`` (their passive moments, N m); the
    support mode per tick (:class:`~exoleg.control.transparency.SupportMode`), the
    support level per joint (0 transparent - 1 the impedance's full support) and the
    transparent law's torque per part (``transparent_parts`` (n, 4, 3):
    :data:`~exoleg.control.transparency.PARTS`; zero while it is not computed) and its
    wall's (``wall``), N m -- its interaction part includes the torque an assistance
    law asks at the cuffs --; the proportional assistance's gain K per joint
    (``assist_gain``, :mod:`exoleg.control.assist`; 1 where it does not adapt); the
    child's share of the normative stance moments they drive (``child_share``: a
    learning child's changes stride by stride)."""

    t: F64
    pelvis: F64
    q: F64
    dq: F64
    q_meas: F64
    dq_meas: F64
    q_ref: F64
    fsr: F64
    contact_force: F64
    gyro: F64
    accel: F64
    mode: NDArray[np.int64]
    phase: NDArray[np.int64]
    gait_fraction: F64
    events: NDArray[np.int64]
    safety_status: NDArray[np.int64]
    u_safe: F64
    tau: F64
    envelope: F64
    support: F64
    winding_temp: F64
    gear_torque: F64
    fault: NDArray[np.int64]
    fault_joint: NDArray[np.int64]
    interaction: F64
    cuff: F64
    child_torque: F64
    passive: F64
    support_mode: NDArray[np.int64]
    support_level: F64
    transparent_parts: F64
    wall: F64
    assist_gain: F64
    child_share: F64
    plant: WalkingPlant = field(repr=False)
    actuators: tuple[ActuatorModel, ...] = field(repr=False)
    walk_start: float = 0.0
    stride_time: float = 1.1
    body_mass: float = 30.0
    #: when the foot board's readings were found frozen (s; the torque off from then,
    #: as the runtime's watch does), -1 for never
    board_frozen: float = -1.0
    #: the cuffs' torque limit the safety layer held them to, N m per kg of the child
    cuff_limit: F64 = field(default_factory=lambda: np.full(3, np.inf), repr=False)
    #: the unassisted foot's insole, counts per sensor (:data:`SENSOR_POINTS`; NaN where
    #: none is fitted: ``sensors.toml [other_foot]``)
    fsr_other: F64 = field(default_factory=lambda: np.full((0, 4), np.nan), repr=False)

    @property
    def motor_speed(self) -> F64:
        return self.dq * np.array([a.ratio for a in self.actuators])

    @property
    def power(self) -> F64:
        return self.tau * self.dq

    def true_events(self) -> NDArray[np.int64]:
        """Event bits per tick from the true contact forces (> TRUE_CONTACT_N): the same
        definitions as the detector's, without noise, thresholds on counts or debounce; a
        stride's contact lands ahead of the hip (a toe scuffing the belt in swing is not
        one)."""
        ankle_x = self.plant.leg.fk(self.q)["ankle"][:, 0]
        return true_events(self.contact_force, ahead=ankle_x > 0.0)

    def swing_touches(self) -> F64:
        """When the foot touched the belt in swing while walking (s): a load of any region
        above :data:`~exoleg.sim.events.TRUE_CONTACT_N` that lasts less than a stance
        (:data:`~exoleg.sim.events.MIN_STANCE_S`, :func:`~exoleg.sim.events.loads`) -- the
        toe catching the belt, a light foot chattering on it."""
        from exoleg.sim.events import touches

        return touches(self.contact_force, self.t, self.walk_start)

    def strikes(self) -> F64:
        """When the foot truly struck the belt while walking (s): the strides' bounds."""
        from exoleg.control.gait_phase import Event

        return self.t[((self.true_events() & Event.IC) != 0) & (self.t >= self.walk_start)]

    def columns(self) -> dict[str, F64]:
        cols: dict[str, F64] = {"t": self.t, "pelvis": self.pelvis}
        for name in ("q", "dq", "q_meas", "dq_meas", "q_ref", "u_safe", "tau", "envelope",
                     "motor_speed", "power", "winding_temp", "gear_torque", "interaction",
                     "cuff", "child_torque", "passive", "wall", "support_level", "assist_gain"):
            arr = getattr(self, name)
            for i, j in enumerate(JOINTS):
                cols[f"{name}_{j}"] = arr[:, i].astype(float)
        for i, s in enumerate(SENSOR_POINTS):
            cols[f"fsr_{s}"] = self.fsr[:, i]
            cols[f"contact_force_{s}"] = self.contact_force[:, i]
        if np.isfinite(self.fsr_other).any():
            for i, s in enumerate(SENSOR_POINTS):
                cols[f"fsr_other_{s}"] = self.fsr_other[:, i]
        cols["gyro"] = self.gyro
        cols["accel_x"], cols["accel_y"] = self.accel[:, 0], self.accel[:, 1]
        for name in ("mode", "phase", "events", "safety_status", "fault", "fault_joint"):
            cols[name] = getattr(self, name).astype(float)
        cols["gait_fraction"] = self.gait_fraction
        cols["true_events"] = self.true_events().astype(float)
        cols["support"] = self.support
        cols["support_mode"] = self.support_mode.astype(float)
        for m, part in enumerate(PARTS):
            for i, j in enumerate(JOINTS):
                cols[f"transparent_{part}_{j}"] = self.transparent_parts[:, m, i]
        return cols


def check_step(plant: WalkingPlant, h: float, folder: Path | None) -> None:
    """Refuses (ParameterError naming the ground's file and field) a contact the plant's
    RK4 step of ``h`` s would integrate into divergence
    (:meth:`~exoleg.world.plant.WalkingPlant.step_problem`)."""
    why = plant.step_problem(h)
    if why:
        where = "walking.toml" if folder is None else f"{folder}/walking.toml"
        raise ParameterError(where, "[contact] stiffness/damping", why)


def simulate_walk(leg: LegModel, body_mass: float, strides: int = 10, speed: str = "Free",
                  stride_time: float = 1.1, standing: float = 1.0, noise_scale: float = 1.0,
                  seed: int = 0, ankle_height: float = ANKLE_HEIGHT,
                  actuators: tuple[ActuatorModel, ...] | None = None,
                  gains: WalkGains | None = None, safety: SafetyLimits | None = None,
                  ground: Ground | None = None, sensors: FootSensors | None = None,
                  substeps: int = 2, control_dt: float = 1e-3,
                  device: str | Path | None = None, child: ChildModel | None = None,
                  commands: NDArray[np.int64] | None = None, model: LegModel | None = None,
                  support_mode: SupportMode = SupportMode.IMPEDANCE,
                  assist_law: str | None = None,
                  faults: Sequence[SensorFault] = (),
                  transparency: TransparencySettings | None = None,
                  expected_stride: float | None = None) -> WalkResult:
    """Walk ``leg`` (without actuators; theirs are added) on the treadmill for ``strides``
    strides of ``stride_time`` s after ``standing`` s of quiet stance; ``body_mass`` is
    the child's (the pelvis carries :func:`exoleg.world.plant.body_weight_share`).
    ``noise_scale`` multiplies the sensors' noise (0: ideal); ``seed`` fixes it.
    ``device``: a device folder (:mod:`exoleg.device.files`) whose files replace the
    shipped actuators, sensors, detector settings, gains, safety limits and ground.
    ``child``: the child as an actor (:class:`~exoleg.child.model.ChildModel`; None: a
    passive leg). ``commands``: the operator's command per tick (default: arm at 0, walk
    after ``standing`` s). ``model``: the leg the controller is given (default ``leg``:
    the controller knows the leg it walks). ``support_mode``: the controller's
    (:class:`~exoleg.control.transparency.SupportMode`: the paper's impedance, the
    device transparent, or assist-as-needed); ``assist_law``: assist-as-needed's law
    (:data:`~exoleg.control.assist.LAWS`; None: the device folder's ``assist.toml``).
    ``faults``: the foot board's sensor faults (:class:`~exoleg.device.faults.SensorFault`)
    in what the controller reads; the result's readings are the faulted ones.
    ``transparency``: the transparent law's settings (None: the device folder's
    ``transparency.toml``), e.g. with some of its parts left out. ``expected_stride``: the
    stride the controller expects until it has measured the child's (s; a child's later
    session: their own; None: ``stride_time``, the walk planned)."""
    if not (isinstance(strides, int) and 1 <= strides <= 10000):
        raise ParameterError("simulate_walk", "strides", f"expected 1-10000, got {strides!r}")
    if not (isinstance(substeps, int) and 1 <= substeps <= 100):
        raise ParameterError("simulate_walk", "substeps", f"expected 1-100, got {substeps!r}")
    if not (np.isfinite(standing) and 0.2 <= standing <= 60.0):
        raise ParameterError("simulate_walk", "standing", f"{standing!r} is outside 0.2-60")
    if not isinstance(leg, LegModel):  # before the device files are read
        raise ParameterError("simulate_walk", "leg", "expected a LegModel (exoleg.paper_leg(), "
                             f"exoleg.load_leg(...)), got {type(leg).__name__}")
    cfg = DeviceConfig.load(device, control_dt, noise_scale, actuators, safety, sensors, gains)
    if assist_law is not None:
        cfg = dataclasses.replace(cfg, assist=cfg.assist.with_law(assist_law))
    if transparency is not None:
        if not isinstance(transparency, TransparencySettings):
            raise ParameterError("simulate_walk", "transparency", "expected "
                                 "TransparencySettings, got " + type(transparency).__name__)
        cfg = dataclasses.replace(cfg, transparency=transparency)
    system = build(cfg, leg, body_mass, SupportMode(support_mode).name.lower(), child=child,
                   model=model, speed=speed, stride_time=stride_time,
                   ankle_height=ankle_height, ground=ground, expected_stride=expected_stride)
    ctl, dev = cast(WalkController, system.controller), system.device
    assert dev is not None  # simulated
    plant, sens = dev.plant, dev.sensors
    substeps = dev.substeps_for(control_dt, substeps)
    check_step(plant, control_dt / substeps, dev.folder)
    n = int(round((standing + strides * stride_time) / control_dt))
    if commands is None:
        commands = np.zeros(n + 1, dtype=np.int64)
        commands[0] = Command.ARM
        commands[int(round(standing / control_dt))] = Command.WALK
    elif np.shape(commands) != (n + 1,):
        raise ParameterError("simulate_walk", "commands", f"expected one per tick ({n + 1}), "
                             f"got shape {np.shape(commands)}")
    for f in faults:  # a fault that would change nothing is a mistake, said
        if f.start >= n * control_dt:
            raise ParameterError("simulate_walk", "faults", f"{f}: starts after the walk "
                                 f"ends ({n * control_dt:g} s)")
        if f.channel == "insole" and not sens.other_foot:
            raise ParameterError("simulate_walk", "faults", f"{f}: no insole is fitted to "
                                 "the other foot (sensors.toml [other_foot] fitted)")
    X = np.zeros((n + 1, 8))
    X[0] = dev.x0
    fsr_noise, imu_noise, bias = draw_noise(sens, n + 1, seed)
    TAU, ENV = np.zeros((n + 1, 3)), np.zeros((n + 1, 3))
    SENS, OUT = np.zeros(n + 1, SENSORS), np.zeros(n + 1, OUTPUT)
    FN = np.zeros((n + 1, 4))
    SUP = np.zeros(n + 1)
    CH = np.zeros((n + 1, 3))
    PA = np.zeros((n + 1, len(PARTS) + 2, 3))
    SH = np.zeros(n + 1)
    K = dev.child_records(control_dt)
    world = World(plant.leg.p, plant.record(), dev.A, K, sens.record(), dev.imu_x, -dev.depth,
                  dev.support, plant.support_height, stride_time)
    frozen = max(1, int(round(FROZEN_S / control_dt))) if noise_scale > 0.0 else 0
    plan = Plan(commands, fault_records(faults, sens), fsr_noise, imu_noise, bias,
                control_dt, substeps, frozen)
    bad, froze = _run_walk(world, ctl.compiled(), plan, dev.state(),
                           Series(X, SENS, FN, OUT, TAU, ENV, SUP, CH, PA, SH))
    if bad >= 0:
        raise SimulationError(f"walking state became non-finite at t = {bad * control_dt:.4g} s")
    t: F64 = np.arange(n + 1, dtype=np.float64) * control_dt
    return WalkResult(t=t, pelvis=X[:, 0], q=X[:, 1:4], dq=X[:, 5:8], q_meas=SENS["q"],
                      dq_meas=SENS["dq"], q_ref=OUT["q_ref"], fsr=SENS["fsr"],
                      contact_force=FN, gyro=SENS["gyro"], accel=SENS["accel"],
                      mode=OUT["mode"], phase=OUT["phase"],
                      gait_fraction=OUT["gait_fraction"], events=OUT["events"],
                      safety_status=OUT["safety_status"], u_safe=OUT["tau"], tau=TAU,
                      envelope=ENV, support=SUP, winding_temp=OUT["winding_temp"],
                      gear_torque=OUT["gear_torque"], fault=OUT["fault"],
                      fault_joint=OUT["fault_joint"],
                      interaction=np.vstack([SENS["interaction"][1:], SENS["interaction"][-1:]]),
                      cuff=OUT["cuff"],
                      child_torque=CH, passive=passive_moments(K[0], X[:, 1:4], X[:, 5:8]),
                      support_mode=OUT["support_mode"], support_level=OUT["support_level"],
                      transparent_parts=PA[:, :len(PARTS)],
                      wall=PA[:, len(PARTS)], assist_gain=PA[:, len(PARTS) + 1],
                      child_share=SH, plant=plant, actuators=dev.actuators, walk_start=standing,
                      stride_time=stride_time, body_mass=body_mass,
                      board_frozen=froze * control_dt if froze >= 0 else -1.0,
                      cuff_limit=cfg.safety.cuff_limit, fsr_other=SENS["fsr_other"])



__all__ = ["WalkResult", "simulate_walk"]
