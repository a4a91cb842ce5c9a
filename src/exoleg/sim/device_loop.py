"""The closed loop with the device's actuators and safety layer in it.

Where :func:`exoleg.simulate` drives the leg with ideal torques from perfect state
feedback, :func:`simulate_device` runs what the device would do, every control tick
(1 kHz by default):

1. **encoders**: each joint angle quantised (:func:`exoleg.device.drive.encode`);
   the velocity is their finite difference over the tick through the first-order
   low-pass of the actuator file;
2. **controller**: the same compiled law as :func:`exoleg.simulate` (PD, PD + gravity
   compensation, computed torque) on the *measured* state;
3. **safety layer** (:func:`exoleg.control.safety.safety_step`): range of motion,
   torque and torque-rate limits, overspeed, non-finite values, arming;
4. **drive**: the command clipped to the actuator's torque-speed envelope at the
   measured speed, then its current loop (first order, exact over each plant step);
5. **plant**: the leg with each actuator's reflected inertia as armature, the
   actuators' friction (viscous + smooth Coulomb) in every RK4 stage, integrated in
   ``substeps`` steps per tick with the current loop's mean torque held over each.

Everything runs in one compiled function; the result (:class:`DeviceResult`) keeps
every signal as a time series for the figures and the CSV/Parquet output.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from exoleg.control.controllers import Controller
from exoleg.control.laws import law
from exoleg.control.safety import SafetyLayer, SafetyLimits, safety_step
from exoleg.device.actuator import ActuatorModel, paper_actuators, params_array, with_actuators
from exoleg.device.drive import current_loop, drive_limit, encode, filter_gain, friction
from exoleg.dynamics.kernels import coefficients, forward_dynamics_sc
from exoleg.dynamics.model import LegModel
from exoleg.errors import ParameterError, SimulationError
from exoleg.params.records import JOINTS
from exoleg.reference.steps import Reference
from exoleg.sim.series import TimeSeries

F64 = NDArray[np.float64]


@njit(inline="always")
def _accel(coef, A, q, v, t):  # type: ignore[no-untyped-def]
    """Joint accelerations at the angles q and rates v under motor torques t (3-tuples)
    minus the actuators' friction at v."""
    q0, q1, q2 = q
    v0, v1, v2 = v
    t0, t1, t2 = t
    return forward_dynamics_sc((math.sin(q0), math.cos(q0), math.sin(q1), math.cos(q1),
                                math.sin(q2), math.cos(q2)), (v0, v1, v2),
                               (t0 - friction(A[0:1], v0), t1 - friction(A[1:2], v1),
                                t2 - friction(A[2:3], v2)), coef)


@njit(inline="always")
def _rk4(coef, A, q, v, t, h):  # type: ignore[no-untyped-def]
    """One RK4 step from the angles q and rates v (3-tuples) with the motor torques t held
    and friction evaluated in every stage."""
    q0, q1, q2 = q
    v0, v1, v2 = v
    a0, a1, a2 = _accel(coef, A, q, v, t)
    hh = 0.5 * h
    b0, b1, b2 = _accel(coef, A, (q0 + hh * v0, q1 + hh * v1, q2 + hh * v2),
                        (v0 + hh * a0, v1 + hh * a1, v2 + hh * a2), t)
    c0, c1, c2 = _accel(coef, A, (q0 + hh * (v0 + hh * a0), q1 + hh * (v1 + hh * a1),
                                  q2 + hh * (v2 + hh * a2)),
                        (v0 + hh * b0, v1 + hh * b1, v2 + hh * b2), t)
    d0, d1, d2 = _accel(coef, A, (q0 + h * (v0 + hh * b0), q1 + h * (v1 + hh * b1),
                                  q2 + h * (v2 + hh * b2)),
                        (v0 + h * c0, v1 + h * c1, v2 + h * c2), t)
    s = h / 6.0
    nq0 = q0 + s * (v0 + 2 * (v0 + hh * a0) + 2 * (v0 + hh * b0) + (v0 + h * c0))
    nq1 = q1 + s * (v1 + 2 * (v1 + hh * a1) + 2 * (v1 + hh * b1) + (v1 + h * c1))
    nq2 = q2 + s * (v2 + 2 * (v2 + hh * a2) + 2 * (v2 + hh * b2) + (v2 + h * c2))
    nv0 = v0 + s * (a0 + 2 * b0 + 2 * c0 + d0)
    nv1 = v1 + s * (a1 + 2 * b1 + 2 * c1 + d1)
    nv2 = v2 + s * (a2 + 2 * b2 + 2 * c2 + d2)
    return nq0, nq1, nq2, nv0, nv1, nv2


@njit(cache=True, error_model="numpy")
def _run_device(p, g, c, A, safety, ref, span, series):  # type: ignore[no-untyped-def]
    """Run every tick: the leg ``p`` under gravity ``g``, the law ``c`` (kind, Kp, Kd,
    model coefficients, scale, saturation: :func:`~exoleg.control.laws.law`'s), the
    actuators' records ``A``, the safety layer's (limits, state), the reference ``ref``
    (Qr, DQr, DDQr), ``span`` (the tick, the plant's substeps) and the ``series`` written
    (Q, DQ, QM, DQM, UC, US, TAU, FR, STATUS, ENV: arrays (n+1, 3) but STATUS (n+1,)).
    Returns the first tick with a non-finite plant state, or -1."""
    kind, kp, kd, kc, scale, limit = c
    lim, state = safety
    Qr, DQr, DDQr = ref
    h, sub = span
    Q, DQ, QM, DQM, UC, US, TAU, FR, STATUS, ENV = series
    coef = coefficients(p, g)
    n = Q.shape[0] - 1
    hs = h / sub
    b = np.empty(3)
    qm_prev = np.empty(3)
    vm = np.zeros(3)
    tau_a = np.zeros(3)
    tau_cmd = np.zeros(3)
    mean = np.zeros(3)
    u_cmd = np.empty(3)
    u_safe = np.empty(3)
    for i in range(3):
        b[i] = filter_gain(A[i:i + 1], h)
        qm_prev[i] = encode(A[i:i + 1], Q[0, i])
        vm[i] = DQ[0, i]  # the filter starts settled on the initial velocity
    for k in range(n + 1):
        # 1. encoders and the filtered finite-difference velocity
        for i in range(3):
            qm = encode(A[i:i + 1], Q[k, i])
            if k > 0:
                vm[i] += b[i] * ((qm - qm_prev[i]) / h - vm[i])
            qm_prev[i] = qm
            QM[k, i] = qm
            DQM[k, i] = vm[i]
        # 2. the controller on the measured state
        q0, q1, q2 = QM[k, 0], QM[k, 1], QM[k, 2]
        u_cmd[0], u_cmd[1], u_cmd[2], _ = law(
            (kind, kp, kd, kc, scale, limit),
            (math.sin(q0), math.cos(q0), math.sin(q1), math.cos(q1), math.sin(q2),
             math.cos(q2)), (q0, q1, q2), (vm[0], vm[1], vm[2]),
            (Qr[k, 0], Qr[k, 1], Qr[k, 2]), (DQr[k, 0], DQr[k, 1], DQr[k, 2]),
            (DDQr[k, 0], DDQr[k, 1], DDQr[k, 2]))
        # 3. the safety layer
        STATUS[k] = safety_step(lim, state, QM[k], vm, u_cmd, False, u_safe)
        # 4. the drive: the torque-speed envelope at the measured speed (braking: the
        #    current's limit)
        for i in range(3):
            e = drive_limit(A[i:i + 1], vm[i], u_safe[i])
            ENV[k, i] = e
            tau_cmd[i] = min(max(u_safe[i], -e), e)
            UC[k, i] = u_cmd[i]
            US[k, i] = u_safe[i]
        if k == n:
            for i in range(3):
                TAU[k, i] = tau_a[i]
                FR[k, i] = friction(A[i:i + 1], DQ[k, i])
            break
        # 5. the plant, with the current loop's mean torque held over each substep
        x0, x1, x2 = Q[k, 0], Q[k, 1], Q[k, 2]
        v0, v1, v2 = DQ[k, 0], DQ[k, 1], DQ[k, 2]
        acc0 = acc1 = acc2 = 0.0
        fr0 = fr1 = fr2 = 0.0
        for _ in range(sub):
            for i in range(3):
                tau_a[i], mean[i] = current_loop(A[i:i + 1], tau_a[i], tau_cmd[i], hs)
            fr0 += friction(A[0:1], v0)
            fr1 += friction(A[1:2], v1)
            fr2 += friction(A[2:3], v2)
            acc0 += mean[0]
            acc1 += mean[1]
            acc2 += mean[2]
            x0, x1, x2, v0, v1, v2 = _rk4(coef, A, (x0, x1, x2), (v0, v1, v2),
                                          (mean[0], mean[1], mean[2]), hs)
        TAU[k, 0], TAU[k, 1], TAU[k, 2] = acc0 / sub, acc1 / sub, acc2 / sub
        FR[k, 0], FR[k, 1], FR[k, 2] = fr0 / sub, fr1 / sub, fr2 / sub
        Q[k + 1, 0], Q[k + 1, 1], Q[k + 1, 2] = x0, x1, x2
        DQ[k + 1, 0], DQ[k + 1, 1], DQ[k + 1, 2] = v0, v1, v2
        if not (math.isfinite(x0) and math.isfinite(x1) and math.isfinite(x2)
                and math.isfinite(v0) and math.isfinite(v1) and math.isfinite(v2)):
            return k + 1
    return -1


@dataclass(frozen=True)
class DeviceResult(TimeSeries):
    """Time series of a device run, (N,) or (N, 3), joints (hip, knee, ankle), SI units.

    t s; q, dq the true state (rad, rad/s); q_meas, dq_meas what the encoders and the
    velocity filter gave the controller; q_ref; u_command the controller's torque;
    u_safe after the safety layer; tau the drive's delivered torque (mean over each
    tick, after the envelope and the current loop); friction the actuators' friction
    torque (mean over each tick); envelope the torque available at the measured speed;
    status the safety layer's bits per tick (:class:`exoleg.control.safety.Limited`);
    motor_speed = N dq (rad/s), power = tau dq (W). ``leg`` is the plant (with the
    armature), ``actuators`` the three units, ``fault`` the safety layer's latched
    fault at the end ('' for none).
    """

    t: F64
    q: F64
    dq: F64
    q_meas: F64
    dq_meas: F64
    q_ref: F64
    u_command: F64
    u_safe: F64
    tau: F64
    friction: F64
    envelope: F64
    status: NDArray[np.int64]
    leg: LegModel = field(repr=False)
    actuators: tuple[ActuatorModel, ...] = field(repr=False)
    fault: str = ""
    stability_margin: float = float("nan")

    @property
    def motor_speed(self) -> F64:
        return self.dq * np.array([a.ratio for a in self.actuators])

    @property
    def power(self) -> F64:
        return self.tau * self.dq

    @property
    def error(self) -> F64:
        return self.q_ref - self.q

    def columns(self) -> dict[str, F64]:
        """Every series as named 1-D columns (``q_hip``, ``tau_ankle``, ...)."""
        cols: dict[str, F64] = {"t": self.t}
        for name in ("q", "dq", "q_meas", "dq_meas", "q_ref", "error", "u_command", "u_safe",
                     "tau", "friction", "envelope", "motor_speed", "power"):
            arr = getattr(self, name)
            for i, j in enumerate(JOINTS):
                cols[f"{name}_{j}"] = arr[:, i].astype(float)
        cols["safety_status"] = self.status.astype(float)
        return cols



def device_parts(device: str | Path | None, actuators: tuple[ActuatorModel, ...] | None,
                 safety: SafetyLimits | None, control_dt: float
                 ) -> tuple[Path | None, tuple[ActuatorModel, ...], NDArray[np.void],
                            SafetyLimits]:
    """The device folder checked (None: the shipped files), the actuators and their
    parameter array, and the safety limits at ``control_dt`` -- each given, or read from
    the folder."""
    from exoleg.device.files import check_folder

    folder = None if device is None else check_folder(device)
    acts = paper_actuators(folder) if actuators is None else tuple(actuators)
    for a in acts:
        if a.compliant:
            raise ParameterError(f"actuators/{a.joint}.toml", "compliance",
                                 f"{a.compliance}: the paper's scenario steps rigid units "
                                 "only (the leg in the air, each rotor on its link); a "
                                 "compliant unit walks (exoleg simulate --walk, exoleg run)")
    lim = SafetyLimits.paper(control_dt, folder, acts) if safety is None else safety
    return folder, acts, params_array(acts), lim


def simulate_device(leg: LegModel, controller: Controller, reference: Reference,
                    duration: float, actuators: tuple[ActuatorModel, ...] | None = None,
                    safety: SafetyLimits | None = None, control_dt: float = 1e-3,
                    substeps: int = 1, q0: ArrayLike | None = None,
                    dq0: ArrayLike | None = None,
                    device: str | Path | None = None) -> DeviceResult:
    """Run ``controller`` on the device for ``duration`` s (see the module docstring).

    ``leg``: the child + device model without actuators (its armature is replaced by
    the actuators' reflected inertia); ``actuators`` default to the paper's
    (:func:`exoleg.device.actuator.paper_actuators`), ``safety`` to
    :meth:`SafetyLimits.paper` at ``control_dt``. The safety layer starts armed (this
    is a simulation; the runtime arms on the operator's command). ``substeps``: plant
    steps per control tick. Refuses what :func:`exoleg.simulate` refuses (duration,
    memory, range of motion of the start and reference) with the same messages.
    ``device``: a device folder (:mod:`exoleg.device.files`) for the actuators and limits.
    """
    from exoleg.sim.closed_loop import check_inputs, check_run, sampled_stability

    check_inputs("simulate_device", leg, controller, reference)
    if not (isinstance(substeps, int) and 1 <= substeps <= 1000):
        raise ParameterError("simulate_device", "substeps",
                             f"expected a whole number 1-1000, got {substeps!r}")
    _, acts, A, lim = device_parts(device, actuators, safety, control_dt)
    if abs(lim.dt - control_dt) > 1e-12:
        raise ParameterError("simulate_device", "safety",
                             f"its dt {lim.dt} s differs from control_dt {control_dt} s")
    plant = with_actuators(leg, acts)
    t, Qr, DQr, DDQr, q_init, dq_init, _ = check_run(reference, duration, control_dt, q0, dq0,
                                                     bytes_per_step=8 * (1 + 3 * 16 + 1))
    n = len(t) - 1
    margin = sampled_stability(plant, controller, control_dt,
                               np.vstack([q_init, Qr[:: max(1, len(Qr) // 500)]]))
    Q, DQ, QM, DQM, UC, US, TAU, FR, ENV = (np.zeros((n + 1, 3)) for _ in range(9))
    STATUS = np.zeros(n + 1, dtype=np.int64)
    Q[0], DQ[0] = q_init, dq_init
    layer = SafetyLayer(lim)
    layer.arm()
    bad = _run_device(plant.p, plant.g, (controller.kind, *controller.law_args()), A,
                      (lim.record(), layer.state), (Qr, DQr, DDQr), (control_dt, substeps),
                      (Q, DQ, QM, DQM, UC, US, TAU, FR, STATUS, ENV))
    if bad >= 0:
        raise SimulationError(f"state became non-finite at t = {t[bad]:.6g} s")
    fault = layer.fault
    return DeviceResult(t=t, q=Q, dq=DQ, q_meas=QM, dq_meas=DQM, q_ref=Qr, u_command=UC,
                        u_safe=US, tau=TAU, friction=FR, envelope=ENV, status=STATUS,
                        leg=plant, actuators=acts,
                        fault="" if fault == 0 else f"{fault.name} ({layer.fault_joint})",
                        stability_margin=margin)


__all__ = ["DeviceResult", "simulate_device"]
