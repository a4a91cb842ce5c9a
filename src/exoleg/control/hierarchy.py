"""The paper's control hierarchy (Fig. 7) for walking: supervisor, phase-scheduled
impedance with the gravity model of the current pendulum, a gait reference that follows
the child's detected phase and cadence, and the safety layer -- one compiled tick.

* **Supervisor** (:class:`Mode`): DISARMED -> (arm) STANDING -> (walk) WALKING ->
  (stand) STANDING; disarm from anywhere; an E-stop or a safety fault -> FAULT, which
  only reset leaves (to DISARMED). Transitions happen on explicit commands
  (:class:`Command`) or detected faults, never on a timer.
* **Reference**: standing, a standing posture; walking, normative gait (Schwartz 2008)
  at the gait fraction the detector measures since the child's last initial contact,
  over the child's own stride time (mean of the last strides) -- not a clock.
* **Impedance**: the inertial feedforward M(q) ddq_ref of the controller's model (with
  the actuators' reflected inertia), PD with gains per phase (stance, swing:
  ``data/device/walking_control.toml``) plus gravity compensation from the controller's
  model: in swing the hanging
  leg's G(q) (the paper's eq 19); in stance the inverted pendulum's -- G(q) less
  ``support`` times the body weight carried at the centre of pressure the FSRs measure,
  ``G(q) - support J_cop(q)^T (0, m g)``.
* **Safety layer** (:func:`exoleg.control.safety.safety_step`) last, always.

:class:`WalkController` holds the explicit state (arrays) and offers the one contract
``step(sensors, t) -> commands``; the simulator's compiled loop calls the same compiled
tick (:func:`walk_control_step`), so the code that runs in simulation is the code the
runtime will run.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from enum import IntEnum
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from exoleg.control import gait_phase as gp
from exoleg.control.safety import SafetyLimits, safety_step
from exoleg.dynamics.kernels import OFFSETS, gravity, mass_matrix
from exoleg.dynamics.model import LegModel
from exoleg.errors import ParameterError
from exoleg.params import _check

F64 = NDArray[np.float64]


class Mode(IntEnum):
    DISARMED = 0
    STANDING = 1
    WALKING = 2
    FAULT = 3


class Command(IntEnum):
    NONE = 0
    ARM = 1
    STAND = 2
    WALK = 3
    DISARM = 4
    ESTOP = 5
    RESET = 6


@dataclass(frozen=True)
class WalkGains:
    """Impedance per phase (N m/rad, N m s/rad; hip, knee, ankle), the standing posture
    (rad) and the stance support level (0: none -- transparency -- to 1: the body weight
    carried through the leg's joints)."""

    kp_stance: F64
    kd_stance: F64
    kp_swing: F64
    kd_swing: F64
    standing: F64
    support: float

    def __post_init__(self) -> None:
        w = "WalkGains"
        for name in ("kp_stance", "kd_stance", "kp_swing", "kd_swing"):
            v = _check.vector(w, name, list(getattr(self, name)), 3)
            if np.any(v < 0) or np.any(v > 1e4):
                raise ParameterError(w, name, f"gains are 0-1e4 per joint, got {v.tolist()}")
            object.__setattr__(self, name, v)
        object.__setattr__(self, "standing", _check.vector(w, "standing", list(self.standing), 3))
        s = _check.finite(w, "support", self.support)
        if not 0.0 <= s <= 1.0:
            raise ParameterError(w, "support", f"{s:g} is outside 0-1")
        object.__setattr__(self, "support", s)

    @classmethod
    def default(cls, folder: str | Path | None = None) -> WalkGains:
        """From ``walking_control.toml`` (a device folder's, :mod:`exoleg.device.files`,
        or the package's)."""
        from exoleg.device.files import load

        where, d = load("walking_control.toml", folder)
        names = ("kp_stance", "kd_stance", "kp_swing", "kd_swing", "standing_deg")
        _check.keys(where, d, [*names, "support"], ["source"])
        vec = {n: _check.vector(where, n, d[n], 3) for n in names}
        try:
            return cls(kp_stance=vec["kp_stance"], kd_stance=vec["kd_stance"],
                       kp_swing=vec["kp_swing"], kd_swing=vec["kd_swing"],
                       standing=np.radians(vec["standing_deg"]),
                       support=_check.finite(where, "support", d["support"]))
        except ParameterError as e:  # a range checked by the record: name the file
            raise ParameterError(where, e.field, e.problem) from None

    def params(self, body_mass: float) -> F64:
        return np.array([*self.kp_stance, *self.kd_stance, *self.kp_swing, *self.kd_swing,
                         *self.standing, self.support, body_mass, START_FRACTION])


C_KP_ST, C_KD_ST, C_KP_SW, C_KD_SW, C_STAND = 0, 3, 6, 9, 12
C_SUPPORT, C_BODY, C_START = 15, 16, 17
#: Walking starts at this fraction of the cycle (mid-stance: the gait nearest to standing).
START_FRACTION = 0.3
# supervisor state: mode; info out: mode, phase, gait fraction, events, safety status,
# q_ref (3)
SUP_SIZE = 2
INFO_SIZE = 8


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
def stance_gravity(p, g, q, fx, sole, counts, weight, out):  # type: ignore[no-untyped-def]
    """G(q) - J_cop(q)^T (0, weight): the stance leg holding ``weight`` N up at the centre
    of pressure the four FSR readings give (their x positions ``fx`` on the foot, at
    ``sole`` -- negative -- on the foot frame's y axis; the foot's middle when nothing
    is measured). Hip and knee carry the weight through the ankle, the ankle the moment
    of the pressure's lever about it; the ankle's impedance sets where the pressure sits."""
    gravity(q, p, g, out)
    tot = counts[0] + counts[1] + counts[2] + counts[3]
    if tot > 0.0:
        cx = (counts[0] * fx[0] + counts[1] * fx[1] + counts[2] * fx[2]
              + counts[3] * fx[3]) / tot
    else:
        cx = 0.5 * (fx[0] + fx[3])
    phi = 0.0
    jx = np.zeros(3)
    for i in range(3):
        phi += q[i] + OFFSETS[i]
        if i < 2:
            jx[i + 1] = jx[i] + p[5 * i + 1] * math.cos(phi)
    px = jx[2] + math.cos(phi) * cx - math.sin(phi) * sole
    for j in range(3):  # J^T (0, W): W times the x lever of the pressure about joint j
        out[j] -= (px - jx[j]) * weight


@njit(cache=True)
def walk_control_step(cp, gq, gdq, p, g, fx, sole, d, st, lim, sst, sup, qm, vm, counts,  # type: ignore[no-untyped-def]
                      t, command, u, info):
    """One control tick. Inputs: the controller's parameters ``cp`` (:meth:`WalkGains
    .params`), gait tables ``gq``, ``gdq`` (K, 3) (rad, rad per cycle), its leg model
    ``p``, ``g``; the FSR positions ``fx`` (4,) and sole height; the detector's settings
    ``d`` and state ``st``; the safety limits ``lim`` and state ``sst``; the supervisor
    state ``sup``; the measured joint angles and rates ``qm``, ``vm``; the FSR counts;
    the time; the operator's command. Writes the torque to the drives into ``u`` and
    ``info`` (mode, phase, gait fraction, events, safety status, q_ref)."""
    mode = int(sup[0])
    # the supervisor
    if command == 1 and mode == 0 and sst[1] == 0:        # arm
        sst[0] = 1.0
        mode = 1
    elif command == 3 and mode == 1:                      # walk: from mid-stance, where the
        mode = 2                                          # gait is nearest to standing
        st[gp.S_T_IC] = t - cp[C_START] * gp.stride_time(d, st)
    elif command == 2 and mode == 2:                      # stand
        mode = 1
    elif command == 4:                                    # disarm
        sst[0] = 0.0
        if mode != 3:
            mode = 0
    elif command == 5:                                    # E-stop
        if sst[1] == 0:
            sst[1] = 1.0
            sst[2] = -1.0
        sst[0] = 0.0
        mode = 3
    elif command == 6 and mode == 3 and sst[1] != 0:      # reset (the caller checked the
        for i in range(sst.shape[0]):                     # state is sane: SafetyLayer.reset)
            sst[i] = 0.0
        mode = 0
    ev = gp.detect(d, st, counts, t)
    phase = int(st[gp.S_PHASE])
    stance = phase >= 1 or mode == 1
    qr = np.empty(3)
    dqr = np.empty(3)
    ddqr = np.zeros(3)
    x = 0.0
    if mode == 2:
        x = gp.gait_fraction(d, st, t)
        _gait(gq, gdq, x, gp.stride_time(d, st), qr, dqr, ddqr)
    else:
        for j in range(3):
            qr[j] = cp[C_STAND + j]
            dqr[j] = 0.0
    # inertial feedforward M(q) ddq_ref: with the actuators' reflected inertia in the
    # controller's model, what it takes to follow the gait's accelerations
    M = np.empty((3, 3))
    mass_matrix(qm, p, M)
    G = np.empty(3)
    if stance:
        stance_gravity(p, g, qm, fx, sole, counts,
                       cp[C_SUPPORT] * (cp[C_BODY] + p[0] + p[5] + p[10]) * g, G)
    else:
        gravity(qm, p, g, G)
    cmd = np.empty(3)
    for j in range(3):
        kp = cp[C_KP_ST + j] if stance else cp[C_KP_SW + j]
        kd = cp[C_KD_ST + j] if stance else cp[C_KD_SW + j]
        cmd[j] = (kp * (qr[j] - qm[j]) + kd * (dqr[j] - vm[j]) + G[j]
                  + M[j, 0] * ddqr[0] + M[j, 1] * ddqr[1] + M[j, 2] * ddqr[2])
    status = safety_step(lim, sst, qm, vm, cmd, False, u)
    if sst[1] != 0:
        mode = 3
    sup[0] = mode
    info[0] = mode
    info[1] = phase
    info[2] = x
    info[3] = ev
    info[4] = status
    info[5], info[6], info[7] = qr[0], qr[1], qr[2]


def gait_tables(speed: str = "Free", sd: float = 0.0, samples: int = 201) -> tuple[F64, F64]:
    """Normative gait over one cycle: q (samples, 3) rad, and (samples, 6) its first and
    second derivatives per unit cycle (divide by T and T^2 for a stride of T s)."""
    from exoleg.reference.gait import SchwartzGait2008

    g = SchwartzGait2008(stride_time=1.0, speed=speed, sd=sd)
    x = np.linspace(0.0, 1.0, samples)
    q, dq, ddq = g.sample(x)
    return np.ascontiguousarray(q), np.ascontiguousarray(np.hstack([dq, ddq]))


class WalkController:
    """The hierarchy with its state, behind ``step(sensors, t) -> commands``.

    ``sensors``: a mapping with ``q`` and ``dq`` (measured, rad, rad/s, (3,)) and ``fsr``
    (four ADC counts); optional ``command`` (:class:`Command`). ``sole``: the sensors'
    depth below the ankle joint, m (ankle height + footplate). Returns a dict: ``tau``
    (3,) N m for the drives, ``mode``, ``phase``, ``gait_fraction``, ``events``,
    ``safety_status``, ``q_ref``.
    """

    def __init__(self, leg: LegModel, body_mass: float, gains: WalkGains | None = None,
                 detector: gp.DetectorSettings | None = None,
                 safety: SafetyLimits | None = None, speed: str = "Free",
                 expected_stride: float = 1.1, fsr_floor_counts: float = 200.0,
                 sole: float = 0.073) -> None:
        from exoleg.device.walking import SENSOR_X

        self.leg = leg
        self.gains = WalkGains.default() if gains is None else gains
        self.detector = gp.DetectorSettings.default() if detector is None else detector
        self.safety = SafetyLimits.paper() if safety is None else safety
        self.cp = self.gains.params(body_mass)
        self.gq, self.gdq = gait_tables(speed)
        self.d = self.detector.params(fsr_floor_counts, expected_stride)
        self.st = gp.new_state(self.d)
        self.lim = self.safety.as_tuple()
        self.sst = np.zeros(6)
        self.sup = np.zeros(SUP_SIZE)
        self.fx = np.array(SENSOR_X) * float(leg.lengths[2])
        self.sole = -float(sole)  # the sensors' y in the foot frame: below the ankle
        self.u = np.zeros(3)
        self.info = np.zeros(INFO_SIZE)

    _SLOTS = {"kp_stance": C_KP_ST, "kd_stance": C_KD_ST, "kp_swing": C_KP_SW,
              "kd_swing": C_KD_SW}

    def gains_now(self) -> dict[str, list[float]]:
        """The gains in force (N m/rad, N m s/rad per joint) and the support level."""
        out = {k: [float(x) for x in self.cp[i:i + 3]] for k, i in self._SLOTS.items()}
        out["support"] = [float(self.cp[C_SUPPORT])]
        return out

    def set_gains(self, change: dict[str, list[float]]) -> None:
        """Change gains between ticks: all of ``change`` or, if any value is unknown,
        not finite or outside what :class:`WalkGains` allows, none (ParameterError).
        The operator interface's tighter bounds are its own (checked before)."""
        where = "WalkController.set_gains"
        now = self.gains_now()
        for k in change:
            if k not in now:
                raise ParameterError(where, k, f"unknown gain (allowed: {', '.join(now)})")
        new: dict[str, Any] = {**now, **change}
        try:  # WalkGains checks each vector (3 finite values) and its range
            g = WalkGains(**{k: new[k] for k in self._SLOTS}, standing=self.gains.standing,
                          support=_check.vector(where, "support", new["support"], 1)[0])
        except ParameterError as e:
            raise ParameterError(where, e.field, e.problem) from None
        self.cp[:C_STAND] = np.concatenate([g.kp_stance, g.kd_stance, g.kp_swing,
                                            g.kd_swing])
        self.cp[C_SUPPORT] = g.support

    def warm_up(self) -> None:
        """Compile (or load from numba's cache) the tick on copies of the state."""
        walk_control_step(self.cp, self.gq, self.gdq, self.leg.p, self.leg.g, self.fx,
                          self.sole, self.d, self.st.copy(), self.lim, self.sst.copy(),
                          self.sup.copy(), np.zeros(3), np.zeros(3), np.zeros(4), 0.0, 0,
                          np.zeros(3), np.zeros(INFO_SIZE))

    def step(self, sensors: dict[str, ArrayLike], t: float) -> dict[str, object]:
        command = int(np.asarray(sensors.get("command", Command.NONE)))
        walk_control_step(self.cp, self.gq, self.gdq, self.leg.p, self.leg.g, self.fx,
                          self.sole, self.d, self.st, self.lim, self.sst, self.sup,
                          np.asarray(sensors["q"], dtype=float),
                          np.asarray(sensors["dq"], dtype=float),
                          np.asarray(sensors["fsr"], dtype=float), float(t), command,
                          self.u, self.info)
        return {"tau": self.u.copy(), "mode": Mode(int(self.info[0])),
                "phase": gp.Phase(int(self.info[1])), "gait_fraction": float(self.info[2]),
                "events": int(self.info[3]), "safety_status": int(self.info[4]),
                "q_ref": self.info[5:8].copy()}
