"""The paper's control hierarchy (Fig. 7) for walking: supervisor, phase-scheduled
impedance with the gravity model of the current pendulum, a gait reference that follows
the child's detected phase and cadence, and the safety layer -- one compiled tick.

* **Supervisor** (:class:`Mode`, :mod:`exoleg.control.supervisor`): DISARMED -> (arm)
  STANDING -> (walk) WALKING -> (stand) STOPPING -> STANDING at the next stance with the
  foot under the hip; disarm from anywhere; an E-stop or a safety fault -> FAULT, which
  only reset leaves (to DISARMED). Transitions happen on explicit commands
  (:class:`Command`), detected faults or the stop reaching its point.
* **Reference**: standing, a standing posture; walking, normative gait (Schwartz 2008)
  at the gait fraction the detector measures since the child's last initial contact,
  over the child's own stride time (mean of the last strides) -- not a clock. A walk's
  first swing is timed from its toe off (the rest of the cycle over the swing the gait
  gives it; strides within the gait data's speeds): a child's first stance from standing
  runs slower than the gait.
* **Impedance**: the inertial feedforward M(q) ddq_ref of the controller's model (with
  the actuators' reflected inertia), PD with gains per phase (stance, swing:
  ``data/device/walking_control.toml``) plus gravity compensation from the controller's
  model: in swing the hanging
  leg's G(q) (the paper's eq 19); in stance the inverted pendulum's -- G(q) less
  ``support`` times the body weight carried at the centre of pressure the FSRs measure,
  ``G(q) - support J_cop(q)^T (0, m g)``.
* **Support** (:mod:`exoleg.control.transparency`, :mod:`exoleg.control.assist`): the
  impedance's share of the torque per joint, the device made transparent the rest --
  1 in the impedance mode, 0 in the transparent one, adapted stride by stride in
  assist-as-needed; the operator's commands change the mode, blended over a ramp.
* **Safety layer** (:func:`exoleg.control.safety.safety_step`) last, always.

:class:`WalkController` holds the explicit state (records) and offers the one contract
``update(sensors, command, t) -> output``; the simulator's compiled loop calls the same compiled
tick (:func:`walk_control_step`), so the code that runs in simulation is the code the
runtime will run.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from exoleg import checks as _check
from exoleg.control import gait_phase as gp
from exoleg.control import safety as sf
from exoleg.control.assist import (
    PROPORTIONAL,
    AssistSettings,
    assist_level,
    assist_moment,
    assist_stride,
    assist_track,
)
from exoleg.control.gears import LAW_TUNABLE
from exoleg.control.safety import SafetyLimits, safety_step
from exoleg.control.supervisor import SUPERVISOR, report, settle, supervise
from exoleg.control.transparency import (
    SupportMode,
    TransparencySettings,
    new_support_state,
    support_command,
    support_mix,
    support_switch,
    track_rates,
    transparent_torque,
)
from exoleg.control.walk_gains import BOUNDS, TUNABLE, WalkGains
from exoleg.device.actuator import ACTUATOR
from exoleg.dynamics.kernels import (
    foot_point,
    foot_point_jacobian,
    gravity,
    links_mass,
    mass_matrix,
)
from exoleg.dynamics.model import LegModel
from exoleg.errors import ParameterError
from exoleg.layout import F8, new
from exoleg.reference.gait import (
    SLOWEST_GROUP_STRIDE,
    START_RAMP,
    cycle_event,
    start_blend,
    start_pace,
)
from exoleg.reference.minjerk import min_jerk
from exoleg.sizing.anthropometry import body_weight_share
from exoleg.tick import OUTPUT, SENSORS, Command, Mode, TickRecords

F64 = NDArray[np.float64]


#: The reference's state: when the stop was asked (s); where the blend to the standing
#: posture started -- its time (s; negative: none under way) and the reference's posture
#: then (rad; or the posture the last walk started from, which it blends from into the
#: gait: start_blend); when the last walk started from standing (s; negative: none); when
#: a walk was asked that waits for the foot's contact to be known (s; negative: none
#: waiting); the stance ankle's x from the hip as measured the last tick (m, ahead > 0);
#: whether the walk's first toe off is still to come (1) and the first swing's timing from
#: it: its cycle's origin (s) and stride (s; 0: not timed so).
#: Then the tick's work (it allocates nothing): the reference, the gravity torque, the
#: impedance's command, assist-as-needed's levels and error, the support levels, the
#: torques asked at the cuffs and of the transparent law, the mass matrix and the centre
#: of pressure's Jacobian.
REFERENCE = np.dtype([("t_stop", F8), ("t_stand", F8), ("q_from", F8, 3),
                      ("t_walk", F8), ("t_asked", F8), ("ankle", F8),
                      ("first_off_due", F8), ("swing_t0", F8), ("swing_T", F8)]
                     + [(n, F8, 3) for n in ("qr", "dqr", "ddqr", "gravity", "command",
                                             "aan", "error", "level", "tau_ref", "tr")]
                     + [("M", F8, (3, 3)), ("J", F8, (2, 3))])
#: A stop gives up waiting for the stance ankle to pass under the hip after this many
#: strides, and stands from wherever the gait is (a child who stopped stepping, or whose
#: foot lands behind the hip, never passes it).
STOP_WAIT_STRIDES = 1.5
#: A stride this far past its estimate (strides) has the reference's rate and
#: acceleration fade out over the next OVERRUN_FADE: the reference waits for the initial
#: contact at the cycle's end, still.
OVERRUN_GRACE = 0.1
OVERRUN_FADE = 0.1
#: A walk asked before the foot's contact is known waits this long for it, s, then is
#: refused (the FSRs' debounce is 8 ms: gait_phase.toml).
WALK_WAIT = 0.5


def new_reference() -> NDArray[np.void]:
    """The reference's state before the first tick: no stand under way."""
    r = new(REFERENCE)
    r[0]["t_stand"] = -1.0
    r[0]["t_walk"] = -1.0
    r[0]["t_asked"] = -1.0
    return r


@njit(inline="always")
def standing_hold(mode, t_stand, t_walk, blend, ramp, t):  # type: ignore[no-untyped-def]
    """How much of the impedance holds the standing posture, whatever the support mode
    (0-1, a floor under the support level): the device stands the child. Standing, all
    of it -- rising with the stand's blend to the posture (``blend`` s from ``t_stand``),
    at once when armed into standing; walking, falling from it over the support modes'
    ``ramp`` s from the walk's start (``t_walk``); stopping and otherwise, none. (A
    transparent stand left the leg 12-32 deg from the standing posture, and a walk from
    there faulted.)"""
    if mode == Mode.STANDING:
        if t_stand >= 0.0 and t - t_stand < blend:
            return (t - t_stand) / blend
        return 1.0
    if mode == Mode.WALKING and t_walk >= 0.0 and t - t_walk < ramp:
        return 1.0 - (t - t_walk) / ramp
    return 0.0


@njit(inline="always")
def _stand_blend(q0, q1, T, s, out_q, out_dq, out_ddq):  # type: ignore[no-untyped-def]
    """The minimum-jerk move from posture q0 to q1 over T s, at rest at both ends, at s
    in [0, 1] of it: q, dq, ddq into the outs. (Carrying the gait's rate into the
    blend overshot the standing posture with the foot held on the stopped belt, and the
    knee was pushed past its limit.)"""
    b, b1, b2 = min_jerk(s)
    for j in range(3):
        d = q1[j] - q0[j]
        out_q[j] = q0[j] + d * b
        out_dq[j] = d * b1 / T
        out_ddq[j] = d * b2 / (T * T)


@njit(inline="always")
def first_swing(x, T, foot_off, lo, hi):  # type: ignore[no-untyped-def]
    """The stride (s) a walk's first swing is played over from its toe off at cycle
    fraction ``x`` of the reference (of a stride of ``T`` s): the rest of the cycle,
    1 - x, over the swing the gait gives it, (1 - ``foot_off``) T -- the reference ends
    the cycle when the gait's foot lands, from where the foot left. Within ``lo``-``hi``
    times T (the strides the detector accepts).

    A child's first stance from standing runs slower than the gait (their leg comes up to
    pace from rest): at its toe off the reference had run on past the foot, and played
    on at its rate it led the swinging leg -- the knee extended early and the toe caught
    the belt. Timed so only where the gait's foot off describes the walk: strides up to
    :data:`~exoleg.reference.gait.SLOWEST_GROUP_STRIDE` (a slower walk's stance is longer
    in every stride, not behind)."""
    return min(max((1.0 - foot_off) * T / max(1.0 - x, 1e-6), lo * T), hi * T)


@njit(inline="always")
def _gait(gq, gdq, x, T, out_q, out_dq, out_ddq):  # type: ignore[no-untyped-def]
    """Normative gait at cycle fraction x: q, dq, ddq (tables ``gq`` (K, 3) and ``gdq``
    (K, 6): first and second derivatives per unit cycle, sampled uniformly on [0, 1])."""
    n = gq.shape[0] - 1
    s = x * n
    i = min(int(s), n - 1)
    f = s - i
    for j in range(3):
        out_q[j] = gq[i, j] + f * (gq[i + 1, j] - gq[i, j])
        out_dq[j] = (gdq[i, j] + f * (gdq[i + 1, j] - gdq[i, j])) / T
        out_ddq[j] = (gdq[i, 3 + j] + f * (gdq[i + 1, 3 + j] - gdq[i, 3 + j])) / (T * T)


@njit(cache=True)
def stance_gravity(p, g, q, fx, sole, counts, weight, into):  # type: ignore[no-untyped-def]
    """G(q) - J_cop(q)^T (0, weight): the stance leg holding ``weight`` N up at the centre
    of pressure the four FSR readings give (their x positions ``fx`` on the foot, at
    ``sole`` -- negative -- on the foot frame's y axis; the foot's middle when nothing
    is measured). Hip and knee carry the weight through the ankle, the ankle the moment
    of the pressure's lever about it; the ankle's impedance sets where the pressure sits.
    ``into``: (out (3,), a (2, 3) to work in)."""
    out, J = into
    gravity(q, p, g, out)
    tot = counts[0] + counts[1] + counts[2] + counts[3]
    if tot > 0.0:
        cx = (counts[0] * fx[0] + counts[1] * fx[1] + counts[2] * fx[2]
              + counts[3] * fx[3]) / tot
    else:
        cx = 0.5 * (fx[0] + fx[3])
    foot_point_jacobian(q, p, cx, sole, J)  # the pressure's point (generated kinematics)
    for j in range(3):  # J^T (0, W): W times the x lever of the pressure about joint j
        out[j] -= J[1, j] * weight


@njit(cache=True)
def walk_control_step(ctl, sens, t, out):  # type: ignore[no-untyped-def]
    """One control tick. ``ctl``: the controller's records (:meth:`WalkController.compiled`)
    -- ``cp``: the controller's parameters (:data:`~exoleg.control.walk_gains.PARAMS`); ``gq``,
    ``gdq``: the gait tables (K, 3), (K, 6) (rad, rad per cycle); ``p``: its leg model's
    parameter vector; ``d``, ``st``: the detector's settings and state
    (:data:`~exoleg.control.gait_phase.SETTINGS`, ``STATE``); ``lim``, ``sst``: the
    safety layer's (:data:`~exoleg.control.safety.LIMITS`, ``STATE``); ``sup``: the
    supervisor's (:data:`SUPERVISOR`); ``ref``: the reference's (:data:`REFERENCE`);
    ``tp``, ``A``, ``ss``: the transparent mode's parameters, the actuators' records and
    the support mode's state (:mod:`exoleg.control.transparency`); ``ap``, ``as_``:
    assist-as-needed's parameters and state (:mod:`exoleg.control.assist`); ``sens``:
    this tick's readings and command (:data:`~exoleg.control.contract.SENSORS`);
    ``t`` s. Writes ``out`` (:data:`~exoleg.control.contract.OUTPUT`). Every record is a
    one-element array.

    A stand from walking is a controlled stop (the supervisor's STOPPING): the walk goes on
    until the stance ankle, as measured, next passes under the hip (the treadmill keeps
    running, as the hip is held in x; at most
    :data:`STOP_WAIT_STRIDES` strides), then the reference moves from the gait's
    posture there to the standing posture over ``stand_blend`` s (:func:`_stand_blend`);
    while it moves the detected phase chooses the stance or swing model and gains. An
    E-stop or a fault stays immediate."""
    cp, gq, gdq, p, d, st, lim, sst, sup, ref, tp, A, ss, ap, as_ = ctl
    C = cp[0]
    s = sens[0]
    o = out[0]
    before = sup[0].mode
    command, refused = support_command(tp, ss, s.command, before)
    if command != Command.NONE:
        refused = supervise(sup, lim, sst, command, s.q, s.dq)
    # the cuffs' torque: beyond its limit the support falls; beyond the stop level a
    # controlled stop (a walk stands at its next stopping point); beyond torque off, the
    # safety layer's fault
    cuffs = sf.cuff_check(lim, sst, s.interaction, C.child_mass,
                          sup[0].mode == Mode.WALKING or sup[0].mode == Mode.STOPPING)
    if cuffs >= 2 and sup[0].mode == Mode.WALKING:
        supervise(sup, lim, sst, Command.STAND, s.q, s.dq)
    mode = sup[0].mode
    R = ref[0]
    # a walk asked before the detector knows the foot's contact (the FSRs' debounce after
    # arming) waits for it: a gait begun from an unknown phase took the swing's model
    # with the foot loaded and faulted the ankle (issue 44: walk-after 0 -> HARD_LIMIT);
    # after WALK_WAIT s of not knowing, the walk is refused
    if mode == Mode.WALKING and before == Mode.STANDING and st[0].phase == gp.Phase.UNKNOWN:
        sup[0].mode = mode = Mode.STANDING
        R.t_asked = t
    elif R.t_asked >= 0.0:
        if mode != Mode.STANDING or command != Command.NONE:
            R.t_asked = -1.0  # another command, or the mode left: the wait is over
        elif st[0].phase != gp.Phase.UNKNOWN:
            sup[0].mode = mode = Mode.WALKING
            R.t_asked = -1.0
        elif t - R.t_asked > WALK_WAIT:
            refused = Command.WALK
            R.t_asked = -1.0
    if mode == Mode.WALKING and before == Mode.STANDING:
        # walking starts from mid-stance, where the gait is nearest to standing, at rest:
        # its pace rises over START_RAMP s, which its time lags by half (start_pace)
        st[0].t_ic = t - C.start_fraction * gp.stride_time(d, st) + 0.5 * START_RAMP
        R.t_stand = -1.0
        R.t_walk = t
        R.first_off_due, R.swing_T = 1.0, 0.0
        for j in range(3):
            R.q_from[j] = R.qr[j]  # the posture the last tick stood in
    elif mode == Mode.STOPPING and before == Mode.WALKING:
        R.t_stop = t
    elif mode != Mode.STANDING and mode != Mode.STOPPING:
        R.t_stand = -1.0
    qm = s.q
    vm = s.dq
    ev = gp.detect(d, st, s.fsr, s.gyro, s.accel, t, s.fsr_other)
    phase = st[0].phase
    qr, dqr, ddqr, G, cmd = R.qr, R.dqr, R.ddqr, R.gravity, R.command
    aan, err, level, tau_ref, tr = R.aan, R.error, R.level, R.tau_ref, R.tr
    for j in range(3):
        ddqr[j] = 0.0
        tau_ref[j] = 0.0
    x = 0.0
    if mode == Mode.WALKING or mode == Mode.STOPPING:
        x = gp.gait_fraction(d, st, t)
        T = gp.stride_time(d, st)
        t0 = st[0].t_ic
        ramp = R.t_walk >= 0.0 and t - R.t_walk < START_RAMP
        if ev & gp.Event.IC:
            R.swing_T = 0.0
        elif ev & gp.Event.TO and R.first_off_due > 0.0:
            R.first_off_due = 0.0
            if not ramp and T <= SLOWEST_GROUP_STRIDE:
                R.swing_T = first_swing(x, T, C.foot_off, d[0].accept_lo, d[0].accept_hi)
                R.swing_t0 = t - x * R.swing_T
        if R.swing_T > 0.0:
            T, t0 = R.swing_T, R.swing_t0
            x = min((t - t0) / T, 0.999999)
        if ramp:  # the walk's start: from the posture stood in into the gait, at rest
            elapsed, b, b1, b2 = start_pace(t - R.t_walk)
            x = C.start_fraction + elapsed / T
        _gait(gq, gdq, x, T, qr, dqr, ddqr)
        if ramp:
            for j in range(3):
                qr[j], dqr[j], ddqr[j] = start_blend(R.q_from[j], qr[j], dqr[j], ddqr[j],
                                                     (b, b1, b2))
        # a stride past its estimate: the reference waits at the cycle's end for the
        # initial contact, still -- its rate and acceleration fade out (a late contact's
        # few per cent untouched), or the impedance pushes the gait's end-of-swing rate at
        # a leg that waits (a weak child's knee held flexed at the drive's limit, the foot
        # in the air, for the rest of the walk)
        over = (t - t0) / T - 1.0 - OVERRUN_GRACE
        if over > 0.0:
            fade = max(0.0, 1.0 - over / OVERRUN_FADE)
            for j in range(3):
                dqr[j] *= fade
                ddqr[j] *= fade
        # the stance ankle as measured, ahead of the hip (> 0) or not: a stop stands as it
        # passes under the hip (at the reference's fraction where the normative ankle
        # does, a child whose stance lagged it stood with the foot ahead, the hip held
        # 12 deg flexed)
        ankle = foot_point(qm, vm, p, 0.0, 0.0)[0]
        under = phase >= gp.Phase.LOADING and R.ankle > 0.0 >= ankle
        R.ankle = ankle
        if mode == Mode.STOPPING and (under or t - R.t_stop > STOP_WAIT_STRIDES * T):
            mode = Mode.STANDING  # foot under the hip (or tired of waiting): stand here
            sup[0].mode = mode
            R.t_stand = t
            for j in range(3):
                R.q_from[j] = qr[j]
    blending = mode == Mode.STANDING and R.t_stand >= 0.0 and t - R.t_stand < C.stand_blend
    # the stance model while the foot bears weight (the detector's: from the FSRs' lift
    # on, the toes' tips alone bear it until the toe off)
    stance = st[0].bearing or (mode == Mode.STANDING and not blending)
    if blending:
        _stand_blend(R.q_from, C.standing, C.stand_blend, (t - R.t_stand) / C.stand_blend,
                     qr, dqr, ddqr)
    elif not (mode == Mode.WALKING or mode == Mode.STOPPING):
        for j in range(3):
            qr[j] = C.standing[j]
            dqr[j] = 0.0
    # inertial feedforward M(q) ddq_ref: with the actuators' reflected inertia in the
    # controller's model, what it takes to follow the gait's accelerations
    M = R.M
    mass_matrix(qm, p, M)
    if stance:
        stance_gravity(p, C.g, qm, C.fsr_x, C.sole, s.fsr,
                       C.support * (C.body_mass + links_mass(p)) * C.g, (G, R.J))
    else:
        gravity(qm, p, C.g, G)
    for j in range(3):
        kp = C.kp_stance[j] if stance else C.kp_swing[j]
        kd = C.kd_stance[j] if stance else C.kd_swing[j]
        cmd[j] = (kp * (qr[j] - qm[j]) + kd * (dqr[j] - vm[j]) + G[j]
                  + M[j, 0] * ddqr[0] + M[j, 1] * ddqr[1] + M[j, 2] * ddqr[2])
    # the support mode: each a share of the impedance above (its support level: 1
    # impedance, 0 transparent, assist-as-needed's per joint), the rest the device made
    # transparent (with the proportional law's torque asked at the cuffs); a change of
    # mode blended over the transparent mode's ramp from the mix in force
    w = support_switch(tp, ss, t)
    S = ss[0]
    if tp[0].known:
        track_rates(tp, ss, vm, lim[0].dt)
    if S.mode == SupportMode.AAN:
        if sup[0].mode == Mode.WALKING:
            for j in range(3):
                err[j] = qr[j] - qm[j]
            assist_track(as_, x, err)
            if ev & gp.Event.IC:
                assist_stride(ap, as_, t, C.support_min, C.support_max)
        assist_level(ap, as_, x, t, C.support_min, C.support_max, aan)
    wa = support_mix(ss, w, aan, level)
    hold = standing_hold(mode, R.t_stand, R.t_walk, C.stand_blend, tp[0].ramp, t)
    share = sst[0].cuff_share
    for j in range(3):
        if level[j] < hold:
            level[j] = hold
        level[j] *= share[j]
    # tau_ref: the torque asked at the cuffs (the proportional law's; zero unless)
    if ap[0].law == PROPORTIONAL and wa > 0.0 and (sup[0].mode == Mode.WALKING
                                        or sup[0].mode == Mode.STOPPING):
        assist_moment(ap, as_, gp.forefoot(st, s.fsr), st[0].bearing, s.interaction,
                      tau_ref)
        for j in range(3):
            tau_ref[j] *= wa * share[j]  # blended with the mode, as the levels
    if level[0] < 1.0 or level[1] < 1.0 or level[2] < 1.0:
        L = lim[0]
        transparent_torque((tp, A, ss), C.g, (qm, vm), (s.interaction, tau_ref),
                           (L.lower, L.upper), L.dt,
                           sup[0].mode != Mode.DISARMED and sup[0].mode != Mode.FAULT, tr)
        for j in range(3):
            cmd[j] = level[j] * cmd[j] + (1.0 - level[j]) * tr[j]
    status = safety_step(lim, sst, qm, vm, cmd, False, o.tau)
    if cuffs >= 1:
        status |= sf.Limited.CUFF
    if cuffs >= 2:
        status |= sf.Limited.CUFF_STOP
    settle(sup, sst)
    report(sup, sst, refused, status, out)
    o.phase = phase
    o.gait_source = st[0].source
    o.support_mode = S.mode
    for j in range(3):
        o.support_level[j] = level[j]
    o.gait_fraction = x
    o.events = ev
    for j in range(3):
        o.q_ref[j] = qr[j]


#: The tick as Python calls it (numba's dispatcher has no signature for a type checker).
_tick: Callable[..., None] = walk_control_step


def gait_tables(speed: str = "Free", sd: float = 0.0, samples: int = 201) -> tuple[F64, F64]:
    """Normative gait over one cycle: q (samples, 3) rad, and (samples, 6) its first and
    second derivatives per unit cycle (divide by T and T^2 for a stride of T s)."""
    from exoleg.reference.gait import SchwartzGait2008

    g = SchwartzGait2008(stride_time=1.0, speed=speed, sd=sd, upright=True)
    x = np.linspace(0.0, 1.0, samples)
    q, dq, ddq = g.sample(x)
    return np.ascontiguousarray(q), np.ascontiguousarray(np.hstack([dq, ddq]))


class WalkController:
    """The hierarchy with its state, behind ``update(sensors, command, t) -> output``,
    for the child + device ``leg`` and a child of ``body_mass`` kg (its stance support
    carries their body-weight share at the pelvis, assist-as-needed measures in N m/kg of
    it).

    ``sensors``: a mapping of :data:`~exoleg.control.contract.SENSORS` fields -- ``q``
    and ``dq`` (measured, rad, rad/s, (3,)) and ``fsr`` (four ADC counts) required;
    ``gyro`` and ``accel`` optional; ``command``: the operator's
    (:class:`~exoleg.control.contract.Command`). ``sole``: the
    sensors' depth below the ankle joint, m (ankle height + footplate). ``device_p``,
    ``actuators``: the device alone's parameters and the actuators' records (what the
    transparent law compensates; without them only the impedance mode is offered),
    ``transparency``, ``assist``: those laws' settings, ``support_mode``: the mode it
    starts in; ``other_foot``: whether the unassisted foot's insole is fitted (its
    readings, ``fsr_other``, bound the foot's stance: :func:`~exoleg.control.gait_phase.detect`).
    Returns the
    :data:`~exoleg.control.contract.OUTPUT` fields as a dict (:meth:`TickRecords.result`):
    ``tau`` (3,) N m for the drives, ``mode``, ``phase``, ``gait_fraction``, ``events``,
    ``safety_status``, ``q_ref``, ``fault``, ``fault_joint``, ``fault_value``,
    ``fault_limit``, ``refused``, ``support_mode``, ``support_level``.
    """

    def __init__(self, leg: LegModel, body_mass: float, gains: WalkGains | None = None,
                 detector: gp.DetectorSettings | None = None,
                 safety: SafetyLimits | None = None, speed: str = "Free",
                 expected_stride: float = 1.1, fsr_floor_counts: float = 200.0,
                 sole: float = 0.073, gyro_range: float = math.inf,
                 accel_range: float = math.inf, device_p: F64 | None = None,
                 actuators: NDArray[np.void] | None = None,
                 transparency: TransparencySettings | None = None,
                 support_mode: SupportMode = SupportMode.IMPEDANCE,
                 assist: AssistSettings | None = None, other_foot: bool = False) -> None:
        from exoleg.device.sensors import SENSOR_X

        w = "WalkController"
        for name, v, kind in (("leg", leg, LegModel), ("gains", gains, WalkGains),
                              ("detector", detector, gp.DetectorSettings),
                              ("safety", safety, SafetyLimits)):
            if v is not None and not isinstance(v, kind):
                raise ParameterError(w, name, f"expected {kind.__name__}, got "
                                     f"{type(v).__name__}")
        _check.positive(w, "body_mass", body_mass, "kg")
        self.leg = leg
        self.gains = WalkGains.default() if gains is None else gains
        self.detector = gp.DetectorSettings.default() if detector is None else detector
        self.safety = SafetyLimits.paper() if safety is None else safety
        # the stance support carries the pelvis: the child's body less both legs
        self.cp = self.gains.record(body_weight_share(body_mass), leg.g,
                                    np.array(SENSOR_X) * float(leg.lengths[2]),
                                    -float(sole))  # the sensors' y in the foot frame
        self.gq, self.gdq = gait_tables(speed)
        self.d = self.detector.record(fsr_floor_counts, expected_stride, gyro_range,
                                      accel_range, other_foot)
        self.st = gp.new_state(self.d)
        self.lim, self.sst, self.sup = self.safety.record(), sf.new_state(), new(SUPERVISOR)
        self.ref = new_reference()
        self.transparency = (TransparencySettings.default() if transparency is None
                             else transparency)
        if (device_p is None) != (actuators is None):
            raise ParameterError(w, "device_p", "the device alone's parameters and the "
                                 "actuators' records go together (the transparent mode's)")
        if device_p is None and support_mode != SupportMode.IMPEDANCE:
            raise ParameterError(w, "support_mode", "the transparent mode needs the device "
                                 "alone's parameters and the actuators' records")
        self.tp = self.transparency.record(device_p)
        self.A = np.zeros(3, ACTUATOR) if actuators is None else actuators
        self.assist = AssistSettings.default() if assist is None else assist
        self.ss = new_support_state(support_mode, self.assist.first_level())
        self.ap, self.as_ = self.assist.record(body_mass), self.assist.state()
        # the speed group's foot off (Schwartz 2008): where the gait's swing starts
        self.cp[0]["foot_off"] = cycle_event("Ipsilateral Foot Off", speed)[0]
        self.cp[0]["support_min"] = self.assist.support_min
        self.cp[0]["support_max"] = self.assist.support_max
        self.io = TickRecords("WalkController.update")

    def starting_support(self) -> float:
        """The share of the child's stance the device carries before the first tick: its
        stance support times the support mode's first level (none when transparent)."""
        return float(self.gains.support * np.mean(self.ss[0]["level"]))

    def gains_now(self, record: tuple[NDArray[np.void], NDArray[np.void]] | None = None
                  ) -> dict[str, list[float]]:
        """The gains in force (N m/rad, N m s/rad per joint), the support level, the
        bounds on assist-as-needed's support and the transparent law's inertia share and
        acceleration estimate (Hz) (:data:`TUNABLE`); of ``record`` (the parameters and
        the transparent law's, :meth:`gains_record`'s) when given."""
        cp, tp = (self.cp, self.tp) if record is None else record
        c, t = cp[0], tp[0]
        return {k: [float(x) for x in np.atleast_1d(t[k] if k in LAW_TUNABLE else c[k])]
                for k in TUNABLE}

    def set_gains(self, change: dict[str, list[float]]) -> None:
        """Change gains between ticks: all of ``change`` or, if any value is unknown,
        not finite or outside what :class:`WalkGains`, :class:`AssistSettings` and
        :class:`TransparencySettings` allow, none (ParameterError). The operator
        interface's tighter bounds are its own (checked before)."""
        self.cp[:], self.tp[:] = self.gains_record(change)

    def gains_record(self, change: dict[str, list[float]],
                     record: tuple[NDArray[np.void], NDArray[np.void]] | None = None
                     ) -> tuple[NDArray[np.void], NDArray[np.void]]:
        """The controller's parameters (:data:`~exoleg.control.walk_gains.PARAMS`) and the
        transparent law's (:data:`~exoleg.control.transparency.TRANSPARENCY`) with
        ``change`` made, copies, for a loop that swaps them in between ticks; made on
        ``record`` (default those in force), checked as :meth:`set_gains` checks."""
        import dataclasses

        where = "WalkController.set_gains"
        base = (self.cp, self.tp) if record is None else record
        now = self.gains_now(base)
        for k in change:
            if k not in now:
                raise ParameterError(where, k, f"unknown gain (allowed: {', '.join(now)})")
        new_: dict[str, Any] = {**now, **change}
        try:  # the settings' records check each vector (3 finite values), its range
            g = WalkGains(**{k: new_[k] for k in WalkGains.TUNABLE if k != "support"},
                          standing=self.gains.standing,
                          support=_check.vector(where, "support", new_["support"], 1)[0],
                          stand_blend=self.gains.stand_blend)
            a = dataclasses.replace(self.assist, **{k: new_[k] for k in BOUNDS})
            law = dataclasses.replace(self.transparency, **{k: new_[k] for k in LAW_TUNABLE})
        except ParameterError as e:
            raise ParameterError(where, e.field, e.problem) from None
        cp, tp = base[0].copy(), base[1].copy()
        for k in WalkGains.TUNABLE:
            cp[0][k] = getattr(g, k)
        for k in BOUNDS:
            cp[0][k] = getattr(a, k)
        for k in LAW_TUNABLE:
            tp[0][k] = getattr(law, k)
        return cp, tp

    def compiled(self) -> tuple[Any, ...]:
        """The records :func:`walk_control_step` takes as its first argument, in order:
        parameters, gait tables, leg model, detector settings and state, safety limits and
        state, supervisor state, reference state, the transparent mode's parameters, the
        actuators' records, the support mode's state, assist-as-needed's parameters and
        state (the state records are this controller's own)."""
        return (self.cp, self.gq, self.gdq, self.leg.p, self.d, self.st, self.lim, self.sst,
                self.sup, self.ref, self.tp, self.A, self.ss, self.ap, self.as_)

    def warm_up(self) -> None:
        """Compile (or load from numba's cache) the tick on copies of the state."""
        cp, gq, gdq, p, d, st, lim, sst, sup, ref, tp, A, ss, ap, as_ = self.compiled()
        _tick((cp, gq, gdq, p, d, st.copy(), lim, sst.copy(), sup.copy(), ref.copy(), tp,
               A, ss.copy(), ap, as_.copy()), new(SENSORS), 0.0, new(OUTPUT))

    def update(self, sensors: Mapping[str, Any], command: int, t: float) -> dict[str, Any]:
        """One tick on ``sensors`` with the operator's ``command`` at ``t`` s (the
        :class:`~exoleg.control.contract.Controller` contract; see the class)."""
        self.io.read(sensors, command)
        _tick(self.compiled(), self.io.sens, float(t), self.io.out)
        return self.io.result()

