"""Walking with the full device: plant with contacts, sensors, the control hierarchy,
the safety layer and the actuators, in one compiled loop.

Every control tick (1 kHz):

1. the foot board reads its four FSRs (the contacts' true normal forces through
   :func:`exoleg.device.sensors.fsr_counts`) and its IMU; the encoders read the joints;
2. the controller tick (:func:`exoleg.control.hierarchy.walk_control_step`): gait-phase
   detection, supervisor, reference at the detected phase, phase-scheduled impedance
   with the current pendulum's gravity model, safety layer;
3. the drives: envelope at the measured speed, current loop;
4. the plant (:mod:`exoleg.device.walking`): ``substeps`` RK4 steps per tick with the
   contact and support forces of each step's start, the actuators' friction in every
   stage.

The operator's commands come as a schedule (arm at 0, walk after ``standing`` seconds
of quiet stance in which the FSRs calibrate). The true contact events (from the
noise-free contact forces) are kept beside the detected ones for
:func:`detection_table`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from exoleg.control import gait_phase as gp
from exoleg.control.contract import OUTPUT, SENSOR_POINTS, SENSORS, Command, Mode
from exoleg.control.hierarchy import (
    START_FRACTION,
    WalkController,
    WalkGains,
    walk_control_step,
)
from exoleg.control.safety import SafetyLimits
from exoleg.device.actuator import (
    ActuatorModel,
    current_loop,
    encode,
    envelope,
    filter_gain,
    with_actuators,
)
from exoleg.device.sensors import FootSensors, draw_noise, fsr_counts, imu
from exoleg.device.walking import (
    Ground,
    WalkingPlant,
    contact_forces,
    contact_points,
    step_contacts,
    walking_step,
)
from exoleg.dynamics.kernels import OFFSETS
from exoleg.dynamics.model import LegModel
from exoleg.errors import ParameterError, SimulationError
from exoleg.layout import F8, new
from exoleg.params.records import JOINTS
from exoleg.sim.series import TimeSeries

F64 = NDArray[np.float64]

#: A region of the foot is loaded, for the true events, above this normal force, N.
TRUE_CONTACT_N = 5.0


@njit(inline="always")
def _imu_point(p, x, px, py):  # type: ignore[no-untyped-def]
    """Velocity (vx, vy) of the point (px, py) of the foot frame, world frame."""
    phi = 0.0
    jx = np.zeros(4)
    jy = np.zeros(4)
    for i in range(3):
        phi += x[1 + i] + OFFSETS[i]
        jx[i + 1] = jx[i] + p[5 * i + 1] * math.cos(phi)
        jy[i + 1] = jy[i] + p[5 * i + 1] * math.sin(phi)
    c, s = math.cos(phi), math.sin(phi)
    X = jx[2] + c * px - s * py
    Y = jy[2] + s * px + c * py
    vx = 0.0
    vy = x[4]
    for j in range(3):
        vx += -(Y - jy[j]) * x[5 + j]
        vy += (X - jx[j]) * x[5 + j]
    return vx, vy, phi


#: A simulated device's state (:func:`device_sense`, :func:`device_actuate`): the plant
#: state x = (y, q0, q1, q2, dy, dq0, dq1, dq2), the drives' torques (N m), the encoders'
#: last readings (rad), the filtered rates (rad/s), the IMU point's last velocity (m/s),
#: the other leg's timing (this leg loaded, its last toe off and strike, s) and the
#: belt's speed while walking (m/s).
DEVICE = np.dtype([("x", F8, 8), ("tau", F8, 3), ("qm", F8, 3), ("vm", F8, 3),
                   ("v_imu", F8, 2), ("loaded", np.bool_), ("t_off", F8), ("t_strike", F8),
                   ("belt", F8)])


def device_state(plant: WalkingPlant, A: NDArray[np.void], x0: F64, imu_x: float,
                 imu_y: float) -> NDArray[np.void]:
    """A simulated device's state at rest in ``x0`` (8,) (:data:`DEVICE`)."""
    S = new(DEVICE)
    r = S[0]
    r["x"] = x0
    r["qm"] = [encode(A[i:i + 1], x0[1 + i]) for i in range(3)]
    r["vm"] = x0[5:8]
    vx, vy, _ = _imu_point(plant.leg.p, x0, imu_x, imu_y)
    r["v_imu"] = vx, vy
    r["loaded"] = True
    r["t_off"] = r["t_strike"] = -1e9
    r["belt"] = plant.belt_speed
    return S


@njit(cache=True, error_model="numpy")
def device_sense(p, w, A, sens, imu_x, imu_y, S, h, first, fsr_noise, imu_noise,  # type: ignore[no-untyped-def]
                 imu_bias, out, fn):
    """What the device's sensors read now into ``out`` (:data:`SENSORS`, its ``command``
    left alone): FSR counts, encoder angles and filtered rates, IMU (gyro, accel x, y);
    and the true normal forces ``fn`` (4,). ``S``: :data:`DEVICE`."""
    D = S[0]
    o = out[0]
    x = D.x
    pts = np.empty((4, 4))
    F = np.empty((4, 2))
    contact_points(p, w, x[0], x[1:4], x[5:8], x[4], pts)
    contact_forces(w, pts, F)
    for i in range(4):
        fn[i] = F[i, 1]
        o.fsr[i] = fsr_counts(sens, F[i, 1], fsr_noise[i])
    vx, vy, phi = _imu_point(p, x, imu_x, imu_y)
    ax = 0.0 if first else (vx - D.v_imu[0]) / h
    ay = 0.0 if first else (vy - D.v_imu[1]) / h
    D.v_imu[0], D.v_imu[1] = vx, vy
    o.gyro, o.accel[0], o.accel[1] = imu(sens, x[5] + x[6] + x[7], ax, ay, phi, w[0].g,
                                         imu_bias[0], imu_bias[1], imu_bias[2],
                                         imu_noise[0], imu_noise[1], imu_noise[2])
    for i in range(3):
        a = A[i:i + 1]
        q = encode(a, x[1 + i])
        if not first:
            D.vm[i] += filter_gain(a, h) * ((q - D.qm[i]) / h - D.vm[i])
        D.qm[i] = q
        o.q[i] = q
        o.dq[i] = D.vm[i]


@njit(cache=True, error_model="numpy")
def device_actuate(p, w, A, S, h, sub, u, fn, walking, t, t_walk, stride, support,  # type: ignore[no-untyped-def]
                   stand_support, env, tau):
    """The drives and ``sub`` plant steps over one tick of ``h`` s under the torque command
    ``u`` (3,): the envelope at the measured speed (into ``env``), the current loop (the
    mean torque delivered into ``tau``), contacts held per step. The treadmill runs and the
    other leg (an actor) keeps time with this leg's true foot strikes (from ``fn``) while
    ``walking``. Returns (the other leg's mean force on the pelvis, 1 if the state is
    still finite)."""
    D = S[0]
    W = w[0]
    total = fn[0] + fn[1] + fn[2] + fn[3]
    if total > 5.0 and not D.loaded and t - D.t_off > 0.3 * stride:
        D.t_strike = t
    if total > 5.0:
        D.loaded = True
    elif D.loaded:
        D.loaded = False
        D.t_off = t
    if walking and t >= t_walk:
        W.belt_speed = D.belt
        if D.t_strike > t_walk:
            xc = min((t - D.t_strike) / stride, 0.999)
        else:
            xc = min(START_FRACTION + (t - t_walk) / stride, 0.999)
        W.support_height = support[min(int(xc * (support.shape[0] - 1) + 0.5),
                                       support.shape[0] - 1)]
    else:
        W.belt_speed = 0.0
        W.support_height = stand_support
    for i in range(3):
        env[i] = envelope(A[i:i + 1], D.vm[i])
    x = D.x
    pts = np.empty((4, 4))
    F = np.empty((4, 2))
    gen = np.empty(4)
    mean = np.empty(3)
    acc = np.zeros(3)
    supp = 0.0
    hs = h / sub
    for _ in range(sub):
        for i in range(3):
            tc = min(max(u[i], -env[i]), env[i])
            D.tau[i], mean[i] = current_loop(A[i:i + 1], D.tau[i], tc, hs)
            acc[i] += mean[i]
        supp += step_contacts(p, w, x, pts, F, gen)
        walking_step(p, w, A, x, mean, gen, hs)
    for i in range(3):
        tau[i] = acc[i] / sub
    ok = 1
    for i in range(8):
        if not math.isfinite(x[i]):
            ok = 0
    return supp / sub, ok


@njit(cache=True, error_model="numpy")
def _run_walk(p, w, A, ctl, sens, fsr_noise, imu_noise, imu_bias, imu_x, imu_y, commands,  # type: ignore[no-untyped-def]
              h, sub, support, stand_support, t_walk, stride, S, X, SENS, FN, OUT, TAU, ENV,
              SUP):
    """The walking run: per tick k the device's readings into ``SENS[k]``, the
    controller's tick (``ctl``: :meth:`WalkController.compiled`) into ``OUT[k]``, the
    drives and the plant. Returns -1, or the tick whose state became non-finite."""
    cp, gq, gdq, cp_p, d, st, lim, sst, sup = ctl
    n = X.shape[0] - 1
    for k in range(n + 1):
        t = k * h
        sk = SENS[k:k + 1]
        ok_ = OUT[k:k + 1]
        # 1. the foot board and the encoders
        device_sense(p, w, A, sens, imu_x, imu_y, S, h, k == 0, fsr_noise[k], imu_noise[k],
                     imu_bias, sk, FN[k])
        sk[0].command = commands[k]
        # 2. the controller tick (supervisor, detection, reference, impedance, safety)
        walk_control_step(cp, gq, gdq, cp_p, d, st, lim, sst, sup, sk, t, ok_)
        if k == n:
            for i in range(3):
                ENV[k, i] = envelope(A[i:i + 1], SENS[k].dq[i])
                TAU[k, i] = S[0].tau[i]
            break
        # 3. the drives and 4. the plant
        SUP[k], ok = device_actuate(p, w, A, S, h, sub, OUT[k].tau, FN[k],
                                    OUT[k].mode == Mode.WALKING, t, t_walk, stride, support,
                                    stand_support, ENV[k], TAU[k])
        for i in range(8):
            X[k + 1, i] = S[0].x[i]
        if not ok:
            return k + 1
    return -1


@dataclass(frozen=True)
class WalkResult(TimeSeries):
    """A walking run's time series, SI units; joints (hip, knee, ankle), FSRs
    (:data:`SENSOR_POINTS`). ``pelvis`` height m; q, dq true; q_meas, dq_meas; q_ref;
    fsr (counts) and contact_force (true normal force, N) per sensor; gyro rad/s,
    accel (2) m/s^2 (foot frame); mode, phase, gait_fraction, events (bits), safety
    status per tick; u_safe (to the drives), tau (delivered), envelope; support (the
    other leg's force on the pelvis, N)."""

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
    plant: WalkingPlant = field(repr=False)
    actuators: tuple[ActuatorModel, ...] = field(repr=False)
    walk_start: float = 0.0
    stride_time: float = 1.1

    @property
    def motor_speed(self) -> F64:
        return self.dq * np.array([a.ratio for a in self.actuators])

    @property
    def power(self) -> F64:
        return self.tau * self.dq

    def true_events(self) -> NDArray[np.int64]:
        """Event bits per tick from the true contact forces (> TRUE_CONTACT_N): the same
        definitions as the detector's, without noise, thresholds on counts or debounce."""
        return true_events(self.contact_force)

    def columns(self) -> dict[str, F64]:
        cols: dict[str, F64] = {"t": self.t, "pelvis": self.pelvis}
        for name in ("q", "dq", "q_meas", "dq_meas", "q_ref", "u_safe", "tau", "envelope",
                     "motor_speed", "power"):
            arr = getattr(self, name)
            for i, j in enumerate(JOINTS):
                cols[f"{name}_{j}"] = arr[:, i].astype(float)
        for i, s in enumerate(SENSOR_POINTS):
            cols[f"fsr_{s}"] = self.fsr[:, i]
            cols[f"contact_force_{s}"] = self.contact_force[:, i]
        cols["gyro"] = self.gyro
        cols["accel_x"], cols["accel_y"] = self.accel[:, 0], self.accel[:, 1]
        for name in ("mode", "phase", "events", "safety_status"):
            cols[name] = getattr(self, name).astype(float)
        cols["gait_fraction"] = self.gait_fraction
        cols["true_events"] = self.true_events().astype(float)
        cols["support"] = self.support
        return cols



def true_events(force: F64, threshold: float = TRUE_CONTACT_N, dt: float = 1e-3,
                min_swing: float = 0.15, min_stance: float = 0.15) -> NDArray[np.int64]:
    """Event bits (IC 1, FF 2, HO 4, TO 8) per sample from contact forces (N, 4), sampled
    every ``dt`` s: the detector's definitions on the true forces, without noise,
    normalisation or debounce; a stride's contact (IC) needs ``min_swing`` s without one
    before it, its toe off ``min_stance`` s after its IC (a toe tapping the belt in early
    swing is not a stride)."""
    heel = force[:, 0] > threshold
    fore = force[:, 1:].max(axis=1) > threshold
    out = np.zeros(len(force), dtype=np.int64)
    phase = 0  # swing
    k_ic = k_to = -10**9
    for k in range(len(force)):
        h, f = heel[k], fore[k]
        if phase == 0:
            if (h or f) and (k - k_to) * dt >= min_swing:
                k_ic = k
                out[k] |= 1
                phase = 1
                if h and f:
                    out[k] |= 2
                    phase = 2
        elif not h and not f:
            if (k - k_ic) * dt >= min_stance:
                out[k] |= 8
                phase = 0
                k_to = k
        elif phase == 1 and h and f:
            out[k] |= 2
            phase = 2
        elif phase == 2 and f and not h:
            out[k] |= 4
            phase = 3
    return out


def belt_speed_for(leg: LegModel, speed: str, stride_time: float) -> float:
    """The belt speed that matches the normative gait's stance: the ankle's mean backward
    speed relative to the hip between 15 % and 45 % of the cycle (mid-stance), m/s."""
    from exoleg.reference.gait import SchwartzGait2008

    gait = SchwartzGait2008(stride_time=stride_time, speed=speed)
    t = np.linspace(0.15, 0.45, 61) * stride_time
    ankle = leg.fk(gait.sample(t)[0])["ankle"][:, 0]
    return float(max(0.0, -(ankle[-1] - ankle[0]) / (t[-1] - t[0])))


def hip_height(leg: LegModel, q: F64, depth: float) -> F64:
    """Height of the hip above the belt for postures q (N, 3) with the lowest of the
    foot's four sensor points on it, m."""
    from exoleg.device.walking import SENSOR_X

    fk = leg.fk(q)
    phi = fk["phi"]
    a3 = float(leg.lengths[2])
    low = np.min([fk["ankle"][:, 1] + np.sin(phi) * x * a3 - np.cos(phi) * depth
                  for x in SENSOR_X], axis=0)
    return -low


#: This leg's swing, as fractions of its cycle (Schwartz 2008: toe off near 60 %),
#: during which the other leg holds the pelvis high enough for it to clear the belt.
SWING = (0.58, 0.95)


def other_leg_support(leg: LegModel, depth: float, speed: str, clearance: float,
                      carry: float = 0.01, samples: int = 201) -> F64:
    """The other leg's support height over this leg's cycle (samples,), m.

    The other leg is an actor, not a model: while this leg swings it holds the pelvis
    where this leg's normative swing posture clears the belt by ``clearance`` (what a
    child's pelvis and other leg do, by rising and hip hiking: fixed at the hip's x, the
    normative joint angles alone would scuff the toe); through this leg's stance it
    stays ``carry`` below this leg's stance height, so this leg carries the body."""
    from exoleg.reference.gait import SchwartzGait2008

    gait = SchwartzGait2008(stride_time=1.0, speed=speed)
    x = np.linspace(0.0, 1.0, samples)
    hh = hip_height(leg, gait.sample(x)[0], depth)
    swing = (x >= SWING[0]) & (x <= SWING[1])
    h = np.where(swing, np.max(hh[swing]) + clearance, hh - carry)
    k = max(1, samples // 40)  # smoothed over 5 % of the cycle, circularly
    pad = np.concatenate([h[-k:], h, h[:k]])
    return np.convolve(pad, np.ones(2 * k + 1) / (2 * k + 1), mode="same")[k:-k]


@dataclass(frozen=True)
class SimulatedDevice:
    """Everything a simulated walking device is made of, and the controller made for it
    (:func:`prepare_walk`): the plant, its actuators (``A``, their compiled parameters),
    the sensors, the other leg's support table, the controller and the start state."""

    leg: LegModel
    plant: WalkingPlant
    actuators: tuple[ActuatorModel, ...]
    A: NDArray[np.void]
    sensors: FootSensors
    support: F64
    depth: float
    imu_x: float
    controller: WalkController
    x0: F64
    stride_time: float
    safety: SafetyLimits

    def state(self) -> NDArray[np.void]:
        """A fresh device state at the start posture (:data:`DEVICE`)."""
        return device_state(self.plant, self.A, self.x0, self.imu_x, -self.depth)


def prepare_walk(leg: LegModel, body_mass: float, speed: str = "Free",
                 stride_time: float = 1.1, noise_scale: float = 1.0,
                 ankle_height: float = 0.05, actuators: tuple[ActuatorModel, ...] | None = None,
                 gains: WalkGains | None = None, safety: SafetyLimits | None = None,
                 ground: Ground | None = None, sensors: FootSensors | None = None,
                 control_dt: float = 1e-3, device: str | Path | None = None
                 ) -> SimulatedDevice:
    """The simulated device and its controller for ``leg`` (without actuators; theirs are
    added) and a child of ``body_mass`` kg (see :func:`simulate_walk`)."""
    from exoleg.control.gait_phase import DetectorSettings
    from exoleg.device.walking import body_weight_share
    from exoleg.entry import BODY_MASS
    from exoleg.reference.gait import SchwartzGait2008
    from exoleg.sim.device_loop import device_parts

    for name, v, lo, hi in (("body_mass", body_mass, *BODY_MASS[:2]),
                            ("control_dt", control_dt, 1e-4, 1e-2),
                            ("ankle_height", ankle_height, 0.0, 0.2)):
        if not (np.isfinite(v) and lo <= v <= hi):
            raise ParameterError("simulate_walk", name, f"{v!r} is outside {lo:g}-{hi:g}")
    SchwartzGait2008(stride_time=stride_time, speed=speed)  # checks both
    folder, acts, A, lim = device_parts(device, actuators, safety, control_dt)
    plant_leg = with_actuators(leg, acts)
    share = body_weight_share(body_mass)
    gr = Ground.default(folder) if ground is None else ground
    depth = ankle_height + gr.sole
    plant = WalkingPlant.of(plant_leg, share, belt_speed_for(leg, speed, stride_time), gr,
                            ankle_height)
    sens = FootSensors.default(noise_scale, folder) if sensors is None else sensors
    ctl = WalkController(plant_leg, share,
                         WalkGains.default(folder) if gains is None else gains,
                         DetectorSettings.default(folder), lim, speed, stride_time,
                         float(fsr_counts(sens.record(), 20.0, 0.0)), depth)
    q0 = ctl.gains.standing
    fk = leg.fk(q0)
    x0 = np.zeros(8)
    x0[0] = (-min(fk["ankle"][1], fk["toe"][1]) + depth
             - 0.5 * share * leg.g / (4 * gr.stiffness))
    x0[1:4] = q0
    return SimulatedDevice(leg=leg, plant=plant, actuators=acts, A=A, sensors=sens,
                           support=other_leg_support(leg, depth, speed, gr.support_drop),
                           depth=depth, imu_x=sens.imu_position * float(leg.lengths[2]),
                           controller=ctl, x0=x0, stride_time=stride_time, safety=lim)


def simulate_walk(leg: LegModel, body_mass: float, strides: int = 10, speed: str = "Free",
                  stride_time: float = 1.1, standing: float = 1.0, noise_scale: float = 1.0,
                  seed: int = 0, ankle_height: float = 0.05,
                  actuators: tuple[ActuatorModel, ...] | None = None,
                  gains: WalkGains | None = None, safety: SafetyLimits | None = None,
                  ground: Ground | None = None, sensors: FootSensors | None = None,
                  substeps: int = 2, control_dt: float = 1e-3,
                  device: str | Path | None = None) -> WalkResult:
    """Walk ``leg`` (without actuators; theirs are added) on the treadmill for ``strides``
    strides of ``stride_time`` s after ``standing`` s of quiet stance; ``body_mass`` is
    the child's (the pelvis carries :func:`exoleg.device.walking.body_weight_share`).
    ``noise_scale`` multiplies the sensors' noise (0: ideal); ``seed`` fixes it.
    ``device``: a device folder (:mod:`exoleg.device.files`) whose files replace the
    shipped actuators, sensors, detector settings, gains, safety limits and ground."""
    if not (isinstance(strides, int) and 1 <= strides <= 10000):
        raise ParameterError("simulate_walk", "strides", f"expected 1-10000, got {strides!r}")
    if not (isinstance(substeps, int) and 1 <= substeps <= 100):
        raise ParameterError("simulate_walk", "substeps", f"expected 1-100, got {substeps!r}")
    if not (np.isfinite(standing) and 0.2 <= standing <= 60.0):
        raise ParameterError("simulate_walk", "standing", f"{standing!r} is outside 0.2-60")
    dev = prepare_walk(leg, body_mass, speed, stride_time, noise_scale, ankle_height,
                       actuators, gains, safety, ground, sensors, control_dt, device)
    ctl, plant, sens = dev.controller, dev.plant, dev.sensors
    n = int(round((standing + strides * stride_time) / control_dt))
    commands = np.zeros(n + 1, dtype=np.int64)
    commands[0] = Command.ARM
    commands[int(round(standing / control_dt))] = Command.WALK
    X = np.zeros((n + 1, 8))
    X[0] = dev.x0
    fsr_noise, imu_noise, bias = draw_noise(sens, n + 1, seed)
    TAU, ENV = np.zeros((n + 1, 3)), np.zeros((n + 1, 3))
    SENS, OUT = np.zeros(n + 1, SENSORS), np.zeros(n + 1, OUTPUT)
    FN = np.zeros((n + 1, 4))
    SUP = np.zeros(n + 1)
    bad = _run_walk(plant.leg.p, plant.record(), dev.A, ctl.compiled(), sens.record(),
                    fsr_noise, imu_noise, bias, dev.imu_x, -dev.depth, commands, control_dt,
                    substeps, dev.support, plant.support_height, standing, stride_time,
                    dev.state(), X, SENS, FN, OUT, TAU, ENV, SUP)
    if bad >= 0:
        raise SimulationError(f"walking state became non-finite at t = {bad * control_dt:.4g} s")
    t: F64 = np.arange(n + 1, dtype=np.float64) * control_dt
    return WalkResult(t=t, pelvis=X[:, 0], q=X[:, 1:4], dq=X[:, 5:8], q_meas=SENS["q"],
                      dq_meas=SENS["dq"], q_ref=OUT["q_ref"], fsr=SENS["fsr"],
                      contact_force=FN, gyro=SENS["gyro"], accel=SENS["accel"],
                      mode=OUT["mode"], phase=OUT["phase"],
                      gait_fraction=OUT["gait_fraction"], events=OUT["events"],
                      safety_status=OUT["safety_status"], u_safe=OUT["tau"], tau=TAU,
                      envelope=ENV, support=SUP, plant=plant, actuators=dev.actuators,
                      walk_start=standing, stride_time=stride_time)


def detection_table(results: list[WalkResult], window: float = 0.2) -> list[dict[str, Any]]:
    """Detected against true events over runs: per event, the number of true events, the
    mean and worst timing error (detected - true, s), missed and false rates. A detected
    event matches the nearest true event of its kind within ``window`` s."""
    rows = []
    for bit, name in gp.EVENT_NAMES.items():
        errs: list[float] = []
        n_true = n_det = missed = false = 0
        for r in results:
            walking = r.t >= r.walk_start
            tt = r.t[walking & ((r.true_events() & bit) > 0)]
            td = r.t[walking & ((r.events & bit) > 0)]
            n_true += len(tt)
            n_det += len(td)
            used = np.zeros(len(td), dtype=bool)
            for x in tt:
                cand = np.where(~used & (np.abs(td - x) <= window))[0]
                if not len(cand):
                    missed += 1
                    continue
                j = cand[np.argmin(np.abs(td[cand] - x))]
                used[j] = True
                errs.append(float(td[j] - x))
            false += int((~used).sum())
        e = np.array(errs)
        rows.append({"event": name, "true": n_true, "detected": n_det,
                     "mean_error_ms": float(1e3 * e.mean()) if len(e) else float("nan"),
                     "mean_abs_error_ms": float(1e3 * np.abs(e).mean()) if len(e) else float("nan"),
                     "worst_error_ms": float(1e3 * e[np.argmax(np.abs(e))]) if len(e)
                     else float("nan"),
                     "missed_rate": missed / n_true if n_true else float("nan"),
                     "false_rate": false / n_det if n_det else float("nan")})
    return rows


__all__ = ["WalkResult", "detection_table", "simulate_walk", "true_events"]
