"""The motor's two-node thermal model (winding and housing, maxon's thermal
resistances and time constants from the actuator file; copper's resistance rising with
the winding's temperature): the exact step for a held loss, used by the safety layer's
estimate (:mod:`exoleg.control.motor_watch`) and by the walks' judgement of a run
(:func:`winding_temperature`), and the time a current takes to reach the winding's
limit. The figures' sources: ``docs/device.md``."""

from __future__ import annotations

import math

import numpy as np
from numba import njit
from numpy.typing import NDArray

from exoleg.device.actuator import COPPER_ALPHA, R_REFERENCE_C, ActuatorModel

F64 = NDArray[np.float64]


@njit(cache=True)
def thermal_matrix(th, h, phi):  # type: ignore[no-untyped-def]
    """The two thermal nodes' step over ``h`` s, e^{A h} of C_w T_w' = -(T_w - T_h) /
    R_wh, C_h T_h' = (T_w - T_h) / R_wh - T_h / R_ha, written row by row into ``phi``
    (4,): by its two eigenvalues, exactly."""
    P = th[0]
    a11 = -1.0 / (P.c_w * P.r_wh)
    a12 = 1.0 / (P.c_w * P.r_wh)
    a21 = 1.0 / (P.c_h * P.r_wh)
    a22 = -1.0 / (P.c_h * P.r_wh) - 1.0 / (P.c_h * P.r_ha)
    tr, det = a11 + a22, a11 * a22 - a12 * a21
    disc = math.sqrt(max(tr * tr / 4.0 - det, 0.0))
    l1, l2 = tr / 2.0 + disc, tr / 2.0 - disc
    e1, e2 = math.exp(l1 * h), math.exp(l2 * h)
    # e^{Ah} = (e1 (A - l2 I) - e2 (A - l1 I)) / (l1 - l2)
    d = l1 - l2
    phi[0] = (e1 * (a11 - l2) - e2 * (a11 - l1)) / d
    phi[1] = (e1 - e2) * a12 / d
    phi[2] = (e1 - e2) * a21 / d
    phi[3] = (e1 * (a22 - l2) - e2 * (a22 - l1)) / d


@njit(cache=True)
def thermal_hold(phi, r_wh, r_ha, ambient, winding, housing, loss):  # type: ignore[no-untyped-def]
    """The winding's and housing's temperatures (degC) after one step of the matrix
    ``phi`` (:func:`thermal_matrix`) with the copper ``loss`` (W) and the ambient held:
    each node relaxes towards the steady state of that loss, T_a + loss (R_wh + R_ha) and
    T_a + loss R_ha. Exact for a held loss."""
    sw = ambient + loss * (r_wh + r_ha)
    sh = ambient + loss * r_ha
    xw, xh = winding - sw, housing - sh
    return sw + phi[0] * xw + phi[1] * xh, sh + phi[2] * xw + phi[3] * xh


@njit(cache=True)
def copper_loss(r25, alpha, winding, current):  # type: ignore[no-untyped-def]
    """The winding's loss (W) at ``current`` (A): its resistance at 25 degC ``r25``
    (ohm), risen by ``alpha`` per K (:data:`COPPER_ALPHA`; 0: held at 25 degC's) to the
    winding's temperature ``winding`` (degC)."""
    return r25 * max(0.0, 1.0 + alpha * (winding - R_REFERENCE_C)) * current * current


@njit(cache=True)
def thermal_step(th, T, current, ambient, h):  # type: ignore[no-untyped-def]
    """Advance the motor's two thermal nodes ``T`` (2,: winding, housing, degC) over h s
    at a constant motor current (A) and ambient temperature (degC), the resistance at
    25 degC's: C_w T_w' = R i^2 - (T_w - T_h) / R_wh, C_h T_h' = (T_w - T_h) / R_wh -
    (T_h - T_a) / R_ha. Exact for the step."""
    P = th[0]
    phi = np.empty(4)
    thermal_matrix(th, h, phi)
    T[0], T[1] = thermal_hold(phi, P.r_wh, P.r_ha, ambient, T[0], T[1],
                              P.resistance * current * current)


@njit(cache=True)
def _temperatures(th, currents, dt, ambient, alpha, out):  # type: ignore[no-untyped-def]
    P = th[0]
    phi = np.empty(4)
    thermal_matrix(th, dt, phi)
    tw = th_ = ambient
    for k in range(len(currents)):
        tw, th_ = thermal_hold(phi, P.r_wh, P.r_ha, ambient, tw, th_,
                               copper_loss(P.resistance, alpha, tw, currents[k]))
        out[k, 0] = tw
        out[k, 1] = th_


def winding_temperature(actuator: ActuatorModel, joint_torque: F64, dt: float,
                        ambient: float = 25.0, alpha: float = COPPER_ALPHA) -> F64:
    """The winding's and housing's temperatures (N, 2; degC) through a series of joint
    torques (N m, every ``dt`` s) from ``ambient``: the current each needs,
    ``|tau| / (N eta k_t)``, heating the two nodes (:func:`thermal_hold`) with the
    winding's resistance at its temperature at the start of each step (``alpha``: 1/K;
    0 keeps it at 25 degC's)."""
    tau = np.abs(np.asarray(joint_torque, dtype=float))
    out = np.empty((len(tau), 2))
    _temperatures(actuator.thermal(), tau / actuator.joint_torque_constant, float(dt),
                  float(ambient), float(alpha), out)
    return out


def time_to_winding_limit(actuator: ActuatorModel, current: float, ambient: float = 25.0,
                          alpha: float = COPPER_ALPHA, dt: float = 0.01) -> float:
    """How long a constant motor ``current`` (A) may flow from ``ambient`` before the
    winding reaches its maximum temperature, s (inf when its steady state stays below):
    exact steps of ``dt`` s with the loss held at the step's start temperature (``alpha``
    0: a constant loss, the two-node solution itself), the crossing found within its step
    by bisection."""
    th = actuator.thermal()
    P = th[0]
    limit = actuator.max_winding_temperature
    r_wh, r_ha, r25 = float(P["r_wh"]), float(P["r_ha"]), float(P["resistance"])
    # the steady state: T - T_a = R_25 (1 + alpha (T - 25)) i^2 R_th, solved for T
    gain = r25 * current**2 * (r_wh + r_ha)
    if alpha * gain >= 1.0:
        steady = math.inf  # thermal runaway: the loss outgrows the cooling
    else:
        steady = (ambient + gain * (1.0 - alpha * R_REFERENCE_C)) / (1.0 - alpha * gain)
    if steady <= limit:
        return math.inf

    phi_dt, phi = np.empty(4), np.empty(4)
    thermal_matrix(th, dt, phi_dt)

    def step(tw: float, th_: float, m: NDArray[np.float64]) -> tuple[float, float]:
        return thermal_hold(m, r_wh, r_ha, ambient, tw, th_,
                            copper_loss(r25, alpha, tw, current))

    tw = th_ = ambient
    start = 0.0
    while True:
        nw, nh = step(tw, th_, phi_dt)
        if nw >= limit:
            break
        tw, th_, start = nw, nh, start + dt
    lo, hi = 0.0, dt
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        thermal_matrix(th, mid, phi)
        lo, hi = (mid, hi) if step(tw, th_, phi)[0] < limit else (lo, mid)
    return start + hi
