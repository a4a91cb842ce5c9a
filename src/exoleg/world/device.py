"""The simulated walking device, one tick at a time: its sensors read from the plant
(:func:`device_sense`: the foot board's FSRs and IMU from the contacts, the encoders and
the velocity filter), its drives and the plant stepped under a command
(:func:`device_actuate`: the envelope, the current loop, ``substeps`` RK4 steps with the
contact and support forces of each step's start, the actuators' friction in every
stage), and how it is made for a leg and a child (:meth:`SimulatedDevice.of`) from the
device's parts and the treadmill's scenery (:mod:`exoleg.world.treadmill`); the
controller it is driven by is the assembly's (:func:`exoleg.system.build.build`).
``exoleg simulate --walk`` loops over these in one compiled run (:mod:`exoleg.sim.walk`);
the runtime's ``sim`` backend calls them each tick (:mod:`exoleg.runtime.sim_backend`)."""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from exoleg.child.compiled import child_records, child_tick
from exoleg.child.interaction import device_leg, interaction_torque
from exoleg.child.model import ChildModel, intended_gait, real_gait_toe_off
from exoleg.device.actuator import ActuatorModel, params_array, with_actuators
from exoleg.device.drive import (
    current_loop,
    drive_limit,
    encode,
    filter_gain,
    friction,
    torque_loop,
)
from exoleg.device.ground import ANKLE_HEIGHT, SOLE_MAX, Ground
from exoleg.device.sensors import FootSensors, fsr_counts, fsr_response, imu, other_loads
from exoleg.dynamics.kernels import foot_point, foot_point_trig, joint_trig
from exoleg.dynamics.model import LegModel
from exoleg.errors import ParameterError
from exoleg.layout import F8, new
from exoleg.reference.gait import MID_STANCE, SchwartzGait2008, start_pace
from exoleg.sizing.anthropometry import body_weight_share
from exoleg.world.plant import (
    STEP,
    WalkingPlant,
    contact_forces,
    contact_points,
    sole_loads,
    step_contacts,
    support_force,
    walking_step,
    walking_step_series,
)
from exoleg.world.treadmill import SWING, belt_speed_for, other_leg_support

F64 = NDArray[np.float64]


@njit(inline="always", cache=True)
def _imu_point(p, x, sc, px, py):  # type: ignore[no-untyped-def]
    """Velocity (vx, vy) of the point (px, py) of the foot frame, world frame, and the
    foot's angle, for the plant state x (the generated kinematics; ``sc``: its joints' sin
    and cos)."""
    _, _, vx, vy, phi = foot_point_trig(sc, x[1:4], x[5:8], p, px, py)
    return vx, x[4] + vy, phi


#: A simulated device's state (:func:`device_sense`, :func:`device_actuate`): the plant
#: state x = (y, q0, q1, q2, dy, dq0, dq1, dq2), the drives' torques (N m), the encoders'
#: last readings (rad), the filtered rates (rad/s), the IMU point's last velocity (m/s),
#: the other leg's timing (this leg loaded, its last toe off and strike, s; whether the
#: device walked last tick and when this walk started, s), the
#: belt's speed while walking (m/s), and the FSRs' memory (their last normalised force,
#: hysteresis direction and creep states: :func:`~exoleg.device.sensors.fsr_response`),
#: the child's muscles' torque over the last tick (reflexes and effort, N m; their
#: passive moments act in the plant) and the cuffs' torque (the interaction torque,
#: :mod:`exoleg.child.interaction`; NaN when the device's own links are unknown); the
#: rotors' angles and speeds at the joint's side of the gear (6,: a compliant unit's
#: rotor is a body of its own; a rigid unit's follows its link) and the joint torque a
#: compliant unit measured over the last tick (its deflection times its stiffness, N m;
#: a rigid unit's motor torque); then the work arrays of a tick (the sole's points and
#: forces, the generalized forces, the sensors' loads, the tick's first state, the drives'
#: and the motion's rows), kept here so that no tick allocates; the unassisted foot's
#: insole: where this leg is in its cycle (the other leg keeps time with it, 0-1), the
#: load on each of its sensors (N) and their memory, as the foot's own.
DEVICE = np.dtype([("x", F8, 8), ("tau", F8, 3), ("qm", F8, 3), ("vm", F8, 3),
                   ("v_imu", F8, 2), ("loaded", np.bool_), ("t_off", F8), ("t_strike", F8),
                   ("walking", np.bool_), ("t_start", F8), ("xc", F8),
                   ("other_load", F8, 4), ("other_last", F8, 4), ("other_memory", F8, 4),
                   ("other_creep", F8, (4, 3)),
                   ("belt", F8), ("fsr_last", F8, 4), ("fsr_memory", F8, 4),
                   ("fsr_creep", F8, (4, 3)), ("child", F8, 3), ("interaction", F8, 3),
                   ("rotor", F8, 6), ("joint_torque", F8, 3),
                   ("pts", F8, (SOLE_MAX, 4)), ("forces", F8, (SOLE_MAX, 2)), ("gen", F8, 4),
                   ("carried", F8, 4), ("x0", F8, 8), ("work", F8, (9, 3)),
                   ("step", STEP)])


def device_state(plant: WalkingPlant, A: NDArray[np.void], x0: F64, imu_x: float,
                 imu_y: float) -> NDArray[np.void]:
    """A simulated device's state at rest in ``x0`` (8,) (:data:`DEVICE`)."""
    S = new(DEVICE)
    r = S[0]
    r["x"] = x0
    r["qm"] = [encode(A[i:i + 1], x0[1 + i]) for i in range(3)]
    r["vm"] = x0[5:8]
    vx, vy, _ = _imu_point(plant.leg.p, x0, joint_trig(x0[1:4]), imu_x, imu_y)
    r["v_imu"] = vx, vy
    r["loaded"] = True
    r["t_off"] = r["t_strike"] = -1e9
    r["belt"] = plant.belt_speed
    r["interaction"] = np.nan
    r["rotor"] = np.concatenate([x0[1:4], x0[5:8]])
    return S


@njit(cache=True, error_model="numpy")
def device_sense(dev, board, S, h, first, noise, out, fn):  # type: ignore[no-untyped-def]
    """What the device's sensors read now into ``out`` (:data:`SENSORS`, its ``command``
    left alone): FSR counts (each from its own sole element's load), encoder angles and
    filtered rates, IMU (gyro, accel x, y); and the true normal force under each sensor's
    region of the foot ``fn`` (4,). ``dev``: (the plant's parameters, its world, the
    actuators' records); ``board``: (the foot board's record, the IMU's x and y on the
    foot); ``noise``: this tick's (FSR unit normals (4,), IMU noise (3,), the IMU's bias
    (3,)); ``S``: :data:`DEVICE`; a tick of ``h`` s, the ``first``."""
    p, w, A = dev
    sens, imu_x, imu_y = board
    fsr_noise, imu_noise, imu_bias = noise
    D = S[0]
    o = out[0]
    x = D.x
    pts, F, carried = D.pts, D.forces, D.carried
    sc = joint_trig(x[1:4])
    contact_points(p, w, x[0], x[1:4], sc, x[5:8], x[4], pts)
    contact_forces(w, pts, F)
    sole_loads(w, F, fn, carried)
    for i in range(4):
        read = fsr_response(sens, D.fsr_last, D.fsr_memory, D.fsr_creep, i, carried[i], h)
        o.fsr[i] = fsr_counts(sens, read * sens[0].full_scale, fsr_noise[i])
    _other_foot(w, sens, D, h, fsr_noise, o.fsr_other)
    vx, vy, phi = _imu_point(p, x, sc, imu_x, imu_y)
    ax = 0.0 if first else (vx - D.v_imu[0]) / h
    ay = 0.0 if first else (vy - D.v_imu[1]) / h
    D.v_imu[0], D.v_imu[1] = vx, vy
    for i in range(3):
        o.interaction[i] = D.interaction[i]
    o.gyro, o.accel[0], o.accel[1] = imu(sens, x[5] + x[6] + x[7], ax, ay, phi, w[0].g,
                                         imu_bias, imu_noise)
    for i in range(3):
        a = A[i:i + 1]
        q = encode(a, x[1 + i])
        if not first:
            D.vm[i] += filter_gain(a, h) * ((q - D.qm[i]) / h - D.vm[i])
        D.qm[i] = q
        o.q[i] = q
        o.dq[i] = D.vm[i]


@njit(inline="always")
def _other_foot(w, sens, D, h, noise, out):  # type: ignore[no-untyped-def]
    """The unassisted foot's insole (fitted: the board's ``other``; else NaN) into ``out``
    (4,): the other leg's load on the pelvis (:func:`~exoleg.world.plant.support_force`)
    over its four sensors along its stance -- which spans this leg's swing
    (:data:`~exoleg.world.treadmill.SWING`; standing, the foot flat, half on the heel)
    -- through the FSRs' response, with the noise's last four draws."""
    b = sens[0]
    if b.other == 0.0:
        for i in range(4):
            out[i] = np.nan
        return
    x = D.x
    if D.walking:
        d = D.xc - SWING[0]
        if d < -0.25:  # this leg's stance's first part: the other foot's last
            d += 1.0
        progress = d / (SWING[1] - SWING[0])
    else:
        progress = 0.5 * b.heel_until
    other_loads(sens, support_force(w, x[0], x[4]), progress, D.other_load)
    for i in range(4):
        read = fsr_response(sens, D.other_last, D.other_memory, D.other_creep, i,
                            D.other_load[i], h)
        out[i] = fsr_counts(sens, read * b.full_scale, noise[4 + i])


@njit(cache=True, error_model="numpy")
def device_actuate(dev, K, S, step, u, fn, scene, into):  # type: ignore[no-untyped-def]
    """The drives and ``sub`` plant steps over one tick of ``h`` s (``step``: (h, sub))
    under the torque command ``u`` (3,): the envelope at the measured speed (into
    ``env``), the current loop (the mean torque delivered into ``tau``; ``into``: (env,
    tau)), contacts held per step (the sole's friction as the step meets it:
    :func:`~exoleg.world.plant.implicit_friction`). ``dev``: (the plant's parameters,
    its world, the actuators' records); ``scene``: (``walking``, the time ``t`` s, the
    ``stride`` time, the other leg's ``support`` over the cycle, its ``stand_support``
    height). The treadmill runs and the other leg (an actor) keeps time with this leg's
    true foot strikes (from ``fn``) while ``walking``; each walk's start (``walking``
    again after standing) restarts their clock at mid-stance (where the controller starts
    a walk) until this walk's first strike. The child (``K``:
    :meth:`SimulatedDevice.child_records`) acts too: their passive moments in every
    stage, their reflexes and effort held over the tick; the cuffs' torque of the tick
    into the state. Returns (the other leg's mean force on the
    pelvis, 1 if the state is still finite)."""
    p, w, A = dev
    h, sub = step
    walking, t, stride, support, stand_support = scene
    env, tau = into
    P, C, CS, pd = K
    D = S[0]
    W = w[0]
    total = fn[0] + fn[1] + fn[2] + fn[3]
    # a strike: the foot lands ahead of the hip, a while after its last toe off; a toe
    # scuffing the belt behind the hip in swing is neither a strike nor a toe off
    if total > 5.0 and not D.loaded and t - D.t_off > 0.3 * stride:
        if foot_point(D.x[1:4], D.x[5:8], p, 0.0, 0.0)[0] > 0.0:
            D.t_strike = t
    if total > 5.0:
        D.loaded = True
    elif D.loaded:
        D.loaded = False
        if D.t_strike > D.t_off:
            D.t_off = t
    xc = pace = rate = 0.0
    if walking and not D.walking:  # a walk starts (again)
        D.t_start = t
    D.walking = walking
    if walking:
        # from rest: the belt and the child's gait come up to pace together, as the
        # controller's reference does (start_pace)
        elapsed, pace, rate, _ = start_pace(t - D.t_start)
        W.belt_speed = pace * D.belt
        if D.t_strike >= D.t_start:
            xc = (t - D.t_strike) / stride
        else:
            xc = MID_STANCE + elapsed / stride
        if xc >= 0.999 and D.loaded:
            # the cycle has run out with the foot already down (it landed behind the hip:
            # no strike): the child takes it as their stance, a stride from here -- waiting
            # for a strike that cannot come, they stood still on the moving belt to the
            # walk's end, the mode still WALKING
            D.t_strike = t
            xc = 0.0
        xc = min(xc, 0.999)
        # the other leg's support, from standing's as the pace rises (it lifts that foot
        # as the walk gets under way, not in the walk's first tick)
        W.support_height = stand_support + pace * (
            support[min(int(xc * (support.shape[0] - 1) + 0.5), support.shape[0] - 1)]
            - stand_support)
    else:
        W.belt_speed = 0.0
        W.support_height = stand_support
    D.xc = xc
    for i in range(3):
        env[i] = drive_limit(A[i:i + 1], D.vm[i], u[i])
    x = D.x
    child_tick((P, C, CS), x[1:4], x[5:8], h, walking, (xc, pace, rate), D.loaded,
               D.child)
    x0 = D.x0
    x0[:] = x
    pts, F, gen = D.pts, D.forces, D.gen
    # by row: the joints' torque in a substep, its sum over the tick, the tick's mean
    # posture, rates and accelerations, the link's torque; with compliant units, what
    # their drives and the child apply and the measured torque's sum
    work = D.work
    work[:] = 0.0
    V, drive = work[:6], work[6:]
    joint, acc, qm, dqm, ddq, link = V[0], V[1], V[2], V[3], V[4], V[5]
    series = A[0].stiffness > 0.0 or A[1].stiffness > 0.0 or A[2].stiffness > 0.0
    supp = 0.0
    hs = h / sub
    for _ in range(sub):
        for i in range(3):
            tc = min(max(u[i], -env[i]), env[i])
            if series and A[i].stiffness > 0.0:
                tc, passed, measured = torque_loop(A[i:i + 1], tc, x[1 + i], x[5 + i],
                                                   D.rotor[i], D.rotor[3 + i])
                link[i] += passed
                drive[2, i] += measured
            D.tau[i], mean = current_loop(A[i:i + 1], D.tau[i], tc, hs)
            acc[i] += mean
            if series:  # the motors' and the child's torques apart: a rotor between
                drive[0, i], drive[1, i] = mean, D.child[i]
            else:
                joint[i] = mean + D.child[i]
        supp += step_contacts(p, w, x, pts, F, gen, (hs, D.step))
        if series:
            walking_step_series(p, w, A, P, (x, D.rotor), drive[:2], gen, (hs, D.step))
        else:
            walking_step(p, w, A, P, x, joint, gen, (hs, D.step))
    for i in range(3):
        tau[i] = acc[i] / sub
        D.joint_torque[i] = drive[2, i] / sub if A[i].stiffness > 0.0 else tau[i]
    if pd.shape[0] > 0:  # the cuffs' torque over the tick, from its mean accelerations
        for i in range(3):
            qm[i] = 0.5 * (x0[1 + i] + x[1 + i])
            dqm[i] = 0.5 * (x0[5 + i] + x[5 + i])
            ddq[i] = (x[5 + i] - x0[5 + i]) / h
            # what reaches the link: a rigid unit's torque less its friction, a compliant
            # unit's spring (its friction is the rotor's, behind it)
            link[i] = (link[i] / sub if A[i].stiffness > 0.0
                       else tau[i] - friction(A[i:i + 1], dqm[i]))
        interaction_torque(pd, W.g, V[2:5], (x[4] - x0[4]) / h, link, D.interaction,
                           (D.step.M, D.step.V))  # (the steps are done with them)
    ok = 1
    for i in range(8):
        if not math.isfinite(x[i]):
            ok = 0
    return supp / sub, ok


@dataclass(frozen=True)
class SimulatedDevice:
    """Everything a simulated walking device is made of (:meth:`of`): the child + device
    ``leg`` (without actuators), the actuators and foot board, the plant, the actuators'
    compiled parameters (``A``), the other leg's support table, the start state, and the
    child in it."""

    leg: LegModel
    actuators: tuple[ActuatorModel, ...]
    sensors: FootSensors
    plant: WalkingPlant
    A: NDArray[np.void]
    support: F64
    depth: float
    imu_x: float
    x0: F64
    stride_time: float
    speed: str = "Free"
    child: ChildModel | None = None
    device_p: F64 | None = None
    step: float = 0.0  # m: the child on a step, the leg hanging (the belt never runs)
    child_support: float = 0.0  # the stance support the controller starts with (0-1)
    folder: Path | None = None  # the device folder its files came from (None: shipped)

    @classmethod
    def of(cls, leg: LegModel, body_mass: float, actuators: tuple[ActuatorModel, ...],
           sensors: FootSensors, ground: Ground, standing: F64, *, speed: str = "Free",
           stride_time: float = 1.1, ankle_height: float = ANKLE_HEIGHT,
           child: ChildModel | None = None, step: float = 0.0, child_support: float = 0.0,
           folder: Path | None = None) -> SimulatedDevice:
        """The device for ``leg`` (without actuators; theirs are added) and a child of
        ``body_mass`` kg (the pelvis carries their body-weight share), at rest in the
        ``standing`` posture (3,) rad on the treadmill's ``ground``, its FSRs the ankle's
        height and the footplate below the ankle joint. ``child``: the child as an actor
        (:class:`~exoleg.child.model.ChildModel`; None: a passive leg, as the paper's),
        who leaves the device ``child_support`` of their stance.
        ``step`` > 0 (m): the child stands on a step this high beside the belt, on the
        other leg, the device's leg hanging free above the belt (identification's
        setting)."""
        from exoleg.entry import BODY_MASS

        w = "simulate_walk"
        if not isinstance(leg, LegModel):
            raise ParameterError(w, "leg", f"expected a LegModel (exoleg.paper_leg(), "
                                 f"exoleg.load_leg(...)), got {type(leg).__name__}")
        for name, v, lo, hi in (("body_mass", body_mass, *BODY_MASS[:2]),
                                ("ankle_height", ankle_height, 0.0, 0.2)):
            if not (np.isfinite(v) and lo <= v <= hi):
                raise ParameterError(w, name, f"{v!r} is outside {lo:g}-{hi:g}")
        SchwartzGait2008(stride_time=stride_time, speed=speed)  # checks both
        share = body_weight_share(body_mass)
        depth = ankle_height + ground.sole
        # the treadmill's scenery -- the belt's speed and the other leg's support -- is
        # the gait's the child walks: the normative one's, or a real child's they intend
        # (its stance and swing: a crouched child's hip extends slower on the belt)
        gait, swing_from = None, SWING[0]
        if child is not None and child.gait != "normative":
            gait = intended_gait(child, stride_time, speed)[0]
            swing_from = real_gait_toe_off(child.gait)
        plant = WalkingPlant.of(with_actuators(leg, actuators, link=True), share,
                                belt_speed_for(leg, speed, stride_time, gait), ground,
                                ankle_height)
        if step:  # the other leg holds the pelvis that much higher
            plant = dataclasses.replace(plant, support_height=plant.support_height + step)
        fk = leg.fk(standing)
        x0 = np.zeros(8)
        x0[0] = (-min(fk["ankle"][1], fk["toe"][1]) + depth
                 - 0.5 * share * leg.g / ground.stiffness) if not step else (
            plant.support_height - (share + plant.leg_mass) * leg.g / ground.support_stiffness)
        x0[1:4] = standing
        return cls(leg=leg, actuators=tuple(actuators), sensors=sensors, plant=plant,
                   A=params_array(tuple(actuators)),
                   support=other_leg_support(leg, plant.points, speed, ground.support_drop,
                                             gait=gait, swing_from=swing_from,
                                             landing=ground.landing),
                   depth=depth, imu_x=sensors.imu_position * float(leg.lengths[2]), x0=x0,
                   stride_time=stride_time, speed=speed, child=child,
                   device_p=device_leg(leg, actuators, link=True).p, step=float(step),
                   child_support=float(child_support), folder=folder)

    def substeps_for(self, tick: float, asked: int) -> int:
        """The plant's steps per control tick of ``tick`` s: ``asked``, or more for a
        device of compliant units, whose light links need the sole's friction resolved
        (:meth:`~exoleg.world.plant.WalkingPlant.fewest_substeps`)."""
        if not any(a.compliant for a in self.actuators):
            return asked
        return max(asked, self.plant.fewest_substeps(tick))

    def state(self) -> NDArray[np.void]:
        """A fresh device state at the start posture (:data:`DEVICE`)."""
        return device_state(self.plant, self.A, self.x0, self.imu_x, -self.depth)

    def child_records(self, h: float) -> tuple[Any, ...]:
        """The child's compiled records, a fresh memory, and the device alone's parameters
        (for the cuffs' torque), as :func:`device_actuate` takes them. The child leaves
        the device the stance support its controller starts with (:attr:`child_support`:
        none when transparent, assist-as-needed's starting share of it)."""
        q0 = self.x0[1:4]
        P, C, CS = child_records(self.child, h, self.stride_time, self.speed, q0,
                                 float(self.leg.lengths[0] + self.leg.lengths[1]),
                                 np.diag(self.plant.leg.M(q0)),
                                 self.child_support)
        pd = np.zeros(0) if self.device_p is None else self.device_p
        return P, C, CS, pd
