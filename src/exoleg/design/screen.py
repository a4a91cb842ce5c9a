"""The analytic screen of actuation candidates over a population (issue 39's first
stage): closed forms for one joint's actuation unit -- a motor through a rigid gear --
along a child's periodic gait, vectorised over candidates and children.

A joint asks, at each instant of the stride, the share ``alpha`` of the child's joint
moment ``tau`` (N m) while it moves with acceleration ``qdd`` (rad/s^2) and rate ``qd``
(rad/s), and carries the device's own links beyond it (:func:`carried_torque`: added to
``alpha tau`` below when counted). Through a gear of ratio N and efficiency eta (on the
delivered torque), a motor of rotor inertia J (rotor and gear input, kg m^2) and torque
constant k_t gives

    tau_m = J N qdd + alpha tau / (N eta)                      motor torque, N m
    i     = tau_m / k_t                                        winding current, A
    V     = R i + k_t N qd                                     terminal voltage, V

and, in the zero-torque (transparent) mode with the rotor not compensated, leaves the
child the reflected inertia's torque J N^2 qdd. Closed forms (Pasch and Seering's
optimal ratio, as applied to a periodic task -- ASME J Dyn Sys Meas Control 139(10):
101013, 2017; ``shared/design/actuation-design.md``):

* the ratio that minimises the RMS motor torque (and current):
  ``N* = sqrt(alpha rms(tau) / (eta J rms(qdd)))`` -- where the inertial RMS
  ``J N*^2 rms(qdd)`` equals ``alpha rms(tau) / eta`` exactly;
* the largest ratio a transparency goal allows: ``N_max = sqrt(goal / (J rms(qdd)))``,
  goal the residual RMS in N m (N m/kg x the child's mass);
* the winding's steady temperature at an RMS current I, through the motor's two thermal
  resistances R_th with copper's resistance R(T) = R_25 (1 + a (T - 25)):
  ``T = (T_a + R_th R_25 I^2 (1 - 25 a)) / (1 - R_th R_25 a I^2)`` (infinite when the
  denominator is not positive: no steady state, the winding runs away).

Every function takes numpy arrays that broadcast: candidates along some axes, children
along others, the gait's samples along the last.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from exoleg.device.actuator import COPPER_ALPHA

F64 = NDArray[np.float64]


def rms(x: ArrayLike, axis: int = -1) -> F64:
    """Root mean square along ``axis`` (a periodic signal's uniform samples over a
    period, the endpoint left out)."""
    a = np.asarray(x, dtype=float)
    return np.sqrt(np.mean(a * a, axis=axis))


def optimal_ratio(inertia: ArrayLike, alpha: ArrayLike, tau: ArrayLike, qdd: ArrayLike,
                  efficiency: ArrayLike = 1.0) -> F64:
    """N* = sqrt(alpha rms(tau) / (eta J rms(qdd))): the ratio that minimises the RMS
    motor torque along the gait (``tau``, ``qdd``: samples on the last axis)."""
    return np.sqrt(np.asarray(alpha) * rms(tau)
                   / (np.asarray(efficiency) * np.asarray(inertia) * rms(qdd)))


def transparency_ratio(inertia: ArrayLike, goal: ArrayLike, qdd: ArrayLike) -> F64:
    """N_max = sqrt(goal / (J rms(qdd))): the largest ratio whose reflected inertia leaves
    at most ``goal`` N m RMS to the child in the zero-torque mode (rotor uncompensated)."""
    return np.sqrt(np.asarray(goal) / (np.asarray(inertia) * rms(qdd)))


def motor_torque(inertia: ArrayLike, ratio: ArrayLike, alpha: ArrayLike, tau: ArrayLike,
                 qdd: ArrayLike, efficiency: ArrayLike = 1.0,
                 spring: tuple[ArrayLike, ArrayLike] | None = None) -> F64:
    """tau_m = J N qdd + alpha tau / (N eta) at each sample, N m (the last axis: the
    gait's samples; the others broadcast). ``spring`` = (K, tau_dd): behind a series
    stiffness K (N m/rad) the rotor turns by the deflection alpha tau / K more than the
    link, so the motor also drives J N alpha tau_dd / K (tau_dd the moment's second
    derivative, N m/s^2): the softer the spring, the more of the motor's torque goes to
    winding it (the large-force bandwidth of a series-elastic actuator, Robinson et al.
    1999)."""
    J, N = np.asarray(inertia)[..., None], np.asarray(ratio)[..., None]
    a, eta = np.asarray(alpha)[..., None], np.asarray(efficiency)[..., None]
    out = J * N * np.asarray(qdd) + a * np.asarray(tau) / (N * eta)
    if spring is not None:
        K, tau_dd = spring
        out = out + J * N * a * np.asarray(tau_dd) / np.asarray(K)[..., None]
    return out


def periodic_second_derivative(x: ArrayLike, period: float, harmonics: int) -> F64:
    """d^2x/dt^2 of a periodic signal's uniform samples over one ``period`` s (the last
    axis), through its Fourier series kept to ``harmonics`` harmonics (measured gait
    curves carry noise that differentiation would amplify)."""
    a = np.asarray(x, dtype=float)
    n = a.shape[-1]
    X = np.fft.rfft(a, axis=-1)
    k = np.arange(X.shape[-1])
    X = X * np.where(k <= harmonics, -(2.0 * np.pi * k / period) ** 2, 0.0)
    return np.fft.irfft(X, n=n, axis=-1)


def residual(inertia: ArrayLike, ratio: ArrayLike, qdd: ArrayLike) -> F64:
    """RMS of the reflected inertia's torque J N^2 qdd, N m: what the zero-torque mode
    leaves the child with the rotor uncompensated."""
    return np.asarray(inertia) * np.asarray(ratio) ** 2 * rms(qdd)


def loop_inertia(stiffness: ArrayLike, loop_hz: ArrayLike) -> F64:
    """K / w_b^2, kg m^2: the inertia a compliant unit's rotor leaves the link behind a
    torque loop of natural frequency ``loop_hz`` on a series stiffness K (Pratt &
    Williamson 1995; :attr:`exoleg.device.actuator.ActuatorModel.apparent_inertia`)."""
    wb = 2.0 * np.pi * np.asarray(loop_hz, dtype=float)
    return np.asarray(stiffness, dtype=float) / (wb * wb)


def winding_temperature(current_rms: ArrayLike, r25: ArrayLike, r_th: ArrayLike,
                        ambient: ArrayLike = 25.0, alpha_cu: float = COPPER_ALPHA) -> F64:
    """The winding's steady temperature, degC, at an RMS current (A) through the motor's
    winding-to-ambient thermal resistance ``r_th`` (K/W, the two in series), its
    resistance at 25 degC ``r25`` (ohm) rising with copper's ``alpha_cu`` (1/K); inf
    where no steady state exists."""
    k = np.asarray(r_th) * np.asarray(r25) * np.asarray(current_rms) ** 2
    den = 1.0 - k * alpha_cu
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (np.asarray(ambient) + k * (1.0 - 25.0 * alpha_cu)) / den
    return np.where(den > 0.0, t, np.inf)


def terminal_voltage(current: ArrayLike, resistance: ArrayLike, kt: ArrayLike,
                     ratio: ArrayLike, qd: ArrayLike) -> F64:
    """V = R i + k_t N qd at each sample, V (inductance left out: a walking gait's
    current changes over tens of milliseconds, the windings' L/R is under 1 ms)."""
    R, k, N = (np.asarray(x)[..., None] for x in (resistance, kt, ratio))
    return R * np.asarray(current) + k * N * np.asarray(qd)


def population_gait(masses: ArrayLike, joint: int, stride_time: float = 1.1,
                    speed: str = "Free", samples: int = 100) -> tuple[F64, F64, F64]:
    """One joint's demand over a stride for children of ``masses`` kg (C,): the child's
    joint moment (C, samples) -- Schwartz et al. 2008's mean sagittal moment per kg at
    ``speed`` (exoleg's signs, :func:`~exoleg.reference.gait.gait_moments`), times the
    mass -- and the normative gait's rate and acceleration at that joint (samples,), at
    ``stride_time`` s. ``joint``: 0 hip, 1 knee, 2 ankle."""
    from exoleg.reference.gait import gait_moments

    x = np.arange(samples) / samples
    _, qd, qdd = normative_gait(stride_time, speed, samples)
    per_kg = gait_moments(x, speed)[:, joint]
    return (np.asarray(masses, dtype=float)[:, None] * per_kg[None, :], qd[:, joint],
            qdd[:, joint])


def normative_gait(stride_time: float = 1.1, speed: str = "Free", samples: int = 100
                   ) -> tuple[F64, F64, F64]:
    """The normative gait the walking plant's child intends (Schwartz et al. 2008's mean
    angles of ``speed``, the hip's from an upright pelvis) over one stride of
    ``stride_time`` s at ``samples`` uniform instants: q, qd, qdd, each (samples, 3)."""
    from exoleg.reference.gait import SchwartzGait2008

    x = np.arange(samples) / samples
    return SchwartzGait2008(stride_time=stride_time, speed=speed, upright=True).sample(
        x * stride_time)


def carried_torque(devices: Any, stride_time: float = 1.1, speed: str = "Free",
                   samples: int = 100) -> F64:
    """What the device's own links ask of its joints along :func:`normative_gait`, for
    each of ``devices`` (the device's links alone fitted to each child,
    :func:`~exoleg.child.interaction.device_links`): their inverse dynamics (gravity and
    inertia, no rotor), N m, (C, 3, samples). The drives carry it in every mode -- the
    transparent one compensates it, assistance gives its share on top."""
    q, qd, qdd = normative_gait(stride_time, speed, samples)
    return np.stack([d.inverse_dynamics(q, qd, qdd).T for d in devices])


def screen(motor: dict[str, ArrayLike], ratio: ArrayLike, efficiency: ArrayLike,
           gear_inertia: ArrayLike, tau: F64, qd: F64, qdd: F64, alpha: float,
           masses: ArrayLike, bus_voltage: ArrayLike, peak_current: ArrayLike,
           ambient: float = 25.0, apparent: ArrayLike | None = None,
           spring: tuple[ArrayLike, F64] | None = None,
           carried: tuple[F64, F64] | None = None) -> dict[str, NDArray[Any]]:
    """Every candidate with every child, one joint: ``motor``'s figures as arrays that
    broadcast over the candidates (``kt`` N m/A, ``rotor_inertia`` kg m^2, ``r25`` ohm,
    ``r_th`` K/W winding to ambient, ``max_speed`` rad/s at the motor), the gear's
    ``ratio``, ``efficiency`` and ``gear_inertia`` (kg m^2 at its input) likewise;
    ``tau`` (C, S) the children's joint moments, ``qd``, ``qdd`` (S,) the gait's rate
    and acceleration, ``alpha`` the share of the moment the device gives, ``masses``
    (C,) kg. Candidate axes first, children next: each result has the candidates' shape
    plus (C,). Returns the RMS and peak current (A), the winding's steady temperature
    (degC), the peak terminal voltage (V), the motor's peak speed (rad/s), the gear's peak
    output torque (N m), the zero-torque residual (N m/kg: the inertia the link feels of
    the rotor -- ``apparent``, kg m^2 per candidate, or J N^2 by default -- times the
    gait's RMS acceleration; a compliant unit's rotor follows the link and winds its
    spring: ``spring`` = (K per candidate, the moments' second derivative (C, S)), see
    :func:`motor_torque`), and ``fits``: within the
    drive's ``peak_current``, the ``bus_voltage``, the motor's speed and winding limit
    (``max_winding_temperature`` in ``motor``). ``carried`` = (the torque the device's
    own links ask of the joint, :func:`carried_torque`, and its second derivative), each
    (C, S) N m: the unit then delivers ``alpha tau + carried`` while it assists and
    ``carried`` alone in the transparent mode, and each figure is the worse of the two
    (the current's RMS and the winding's of the worse mode sustained)."""
    J = np.asarray(motor["rotor_inertia"]) + np.asarray(gear_inertia)
    N = np.asarray(ratio, dtype=float)
    shape = np.broadcast_shapes(J.shape, N.shape, np.shape(efficiency),
                                np.shape(motor["kt"]), np.shape(bus_voltage),
                                np.shape(peak_current),
                                () if apparent is None else np.shape(apparent),
                                () if spring is None else np.shape(spring[0]))
    c = (slice(None),) * len(shape) + (None,)  # a candidate axis's value per child

    def per(x: Any) -> F64:
        """``x`` on the candidates' axes, with one for the children."""
        return np.broadcast_to(np.asarray(x, dtype=float), shape)[c]

    Jc, Nc, eta, kt, r25 = per(J), per(N), per(efficiency), per(motor["kt"]), per(motor["r25"])
    K = None if spring is None else per(spring[0])
    a = float(alpha)
    # (the torque the unit delivers, its second derivative) in each mode: assisting, and
    # transparent when the device's own links are counted
    loads: list[tuple[F64, F64 | None]] = [
        (a * np.asarray(tau), None if spring is None else a * np.asarray(spring[1]))]
    if carried is not None:
        c_tau, c_dd = (np.asarray(x, dtype=float) for x in carried)
        loads = [(loads[0][0] + c_tau, None if spring is None else a * spring[1] + c_dd),
                 (c_tau, None if spring is None else c_dd)]

    def figures(load: F64, load_dd: F64 | None) -> tuple[F64, F64, F64, F64]:
        """One mode's RMS and peak current, peak voltage and the gear's peak torque."""
        i = motor_torque(Jc, Nc, 1.0, load, qdd, eta,
                         None if K is None or load_dd is None else (K, load_dd)) / kt[..., None]
        return (rms(i), np.max(np.abs(i), axis=-1),
                np.max(np.abs(terminal_voltage(i, r25, kt, Nc, qd)), axis=-1),
                np.broadcast_to(np.max(np.abs(load), axis=-1), i.shape[:-1]))

    i_rms, i_peak, v_peak, gear_peak = (np.max(np.stack(x), axis=0)
                                        for x in zip(*(figures(*m) for m in loads), strict=True))
    m = np.asarray(masses, dtype=float)
    out = {
        "current_rms": i_rms,
        "current_peak": i_peak,
        "winding": winding_temperature(i_rms, r25, per(motor["r_th"]), ambient),
        "voltage_peak": v_peak,
        "motor_speed_peak": np.broadcast_to(Nc * np.max(np.abs(qd)), i_rms.shape),
        "gear_torque_peak": gear_peak,
        "residual_per_kg": np.broadcast_to(
            residual(Jc, Nc, qdd) if apparent is None else per(apparent) * rms(qdd),
            i_rms.shape) / m,
    }
    limit_speed, limit_temp = per(motor["max_speed"]), per(motor["max_winding_temperature"])
    bus, drive = per(bus_voltage), per(peak_current)
    out["fits"] = ((out["current_peak"] <= drive) & (out["voltage_peak"] <= bus)
                   & (out["motor_speed_peak"] <= limit_speed)
                   & (out["winding"] <= limit_temp))
    return out
