"""An actuation unit's compiled behaviour at its joint, on its record
(:data:`~exoleg.device.actuator.ACTUATOR`, ``par`` a one-element slice): the drive's
torque-speed envelope and its braking limit, friction, the current loop, a compliant
unit's spring and torque loop, the encoder and the velocity filter. The figures and what
they mean: :mod:`exoleg.device.actuator`."""

from __future__ import annotations

import math

from numba import njit


@njit(cache=True)
def envelope(par, w):  # type: ignore[no-untyped-def]
    """Largest joint torque (N m, >= 0) the actuator ``par`` (:data:`ACTUATOR`)
    delivers at joint speed ``w`` (rad/s): the current the bus voltage can still drive
    against the back-EMF, ``(V - N k_t |w|) / R``, within the current limit, times
    N eta k_t; within the working limit (the gear's repeated peak); zero beyond the
    motor's maximum permissible speed. The same both ways (the braking quadrant, which
    the back-EMF helps, is taken as the motoring one: conservative)."""
    P = par[0]
    s = abs(w)
    if s > P.speed:
        return 0.0
    i = min(P.current, max(0.0, (P.voltage - P.ke_joint * s) / P.resistance))
    return min(P.torque, P.kt_joint * i)


@njit(cache=True)
def drive_limit(par, w, u):  # type: ignore[no-untyped-def]
    """Largest torque (N m, >= 0) the drive delivers in the direction of the command
    ``u`` at joint speed ``w``: :func:`envelope` while motoring (``u`` along ``w``); while
    braking (``u`` against ``w``, the back-EMF driving the current with the bus) the
    current limit's torque within the gear's working limit, at any speed."""
    if u * w < 0.0:
        P = par[0]
        return min(P.torque, P.kt_joint * P.current)
    return envelope(par, w)


@njit(cache=True)
def friction(par, w):  # type: ignore[no-untyped-def]
    """Friction torque at the joint, N m, opposing the speed w: viscous plus smooth
    Coulomb (the motor's no-load drag and the gear's backdriving torque, tanh over
    ``friction_smoothing``)."""
    P = par[0]
    return P.viscous * w + P.coulomb * math.tanh(w / P.smoothing)


@njit(cache=True)
def link_friction(par, w):  # type: ignore[no-untyped-def]
    """The friction the link feels at speed w, N m: a rigid unit's own (:func:`friction`);
    behind a compliant unit's torque loop, 1 / (1 + kp) of its rotor's (the loop rejects
    a disturbance on the motor's side so, below its bandwidth)."""
    f = friction(par, w)
    P = par[0]
    return f / (1.0 + P.kp) if P.stiffness > 0.0 else f


@njit(cache=True)
def current_loop(par, tau, tau_cmd, h):  # type: ignore[no-untyped-def]
    """The drive's torque (current) loop over a step of ``h`` s with the command held:
    first order of bandwidth f_c, exactly discretised. Returns (torque at the end of the
    step, mean torque over the step)."""
    T = 1.0 / (2.0 * math.pi * par[0].bandwidth)
    e = math.exp(-h / T)
    end = tau_cmd + (tau - tau_cmd) * e
    mean = tau_cmd + (tau - tau_cmd) * (T / h) * (1.0 - e)
    return end, mean


@njit(cache=True, inline="always")
def series_torque(par, q, dq, qr, wr):  # type: ignore[no-untyped-def]
    """The torque a compliant unit's spring (or gear and sensor) passes to its link, N m:
    K (theta_r - q) + c (w_r - dq), the rotor's angle ``qr`` and speed ``wr`` on the
    joint's side of the gear, the link's ``q`` and ``dq``."""
    P = par[0]
    return P.stiffness * (qr - q) + P.series_damping * (wr - dq)


@njit(cache=True)
def torque_loop(par, tau_d, q, dq, qr, wr):  # type: ignore[no-untyped-def]
    """A compliant unit's drive closing its torque loop on the measured torque (the
    deflection ``qr - q`` as its encoder resolves it, times the stiffness) towards the
    joint torque ``tau_d`` (:attr:`ActuatorModel.torque_loop_gains`; the deflection's rate
    from the rotor's and the link's speeds). Returns (the motor's torque command within
    the drive's limit at the rotor's speed -- the current loop's input --, the torque the
    spring passes, the measured torque), N m at the joint."""
    P = par[0]
    d = qr - q
    measured = P.stiffness * math.floor(d / P.deflection + 0.5) * P.deflection
    cmd = (1.0 + P.kp) * tau_d - P.kp * measured - P.kd * P.stiffness * (wr - dq)
    e = drive_limit(par, wr, cmd)
    return min(max(cmd, -e), e), series_torque(par, q, dq, qr, wr), measured


@njit(cache=True)
def encode(par, q):  # type: ignore[no-untyped-def]
    """The joint encoder's reading of angle q (rad): quantised to 2pi / 2^bits."""
    r = par[0].resolution
    return math.floor(q / r + 0.5) * r


@njit(cache=True)
def filter_gain(par, h):  # type: ignore[no-untyped-def]
    """Gain b of the velocity low-pass y += b (x - y) sampled every h s (exact for a
    first-order filter of ``velocity_filter_hz`` with the input held)."""
    return 1.0 - math.exp(-2.0 * math.pi * par[0].filter_hz * h)
