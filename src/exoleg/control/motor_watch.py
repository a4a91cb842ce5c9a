"""The safety layer's watch over the actuation units: each motor's winding temperature
and each gear's load, estimated every tick from what the layer allowed and what the
encoders measured (compiled; :func:`exoleg.control.safety.safety_step` calls them on its
own ``LIMITS`` and ``STATE`` records, whose motor and gear fields this module fills and
keeps).

* **Windings**: maxon's two-node model of each motor (the actuator file's thermal
  resistances and time constants) heated by the copper loss of the current the allowed
  torque draws, ``|u| / (N eta k_t)``, the resistance at the winding's temperature
  (:func:`exoleg.device.thermal.copper_loss`), one exact step per tick with the loss
  held (:func:`exoleg.device.thermal.thermal_hold`). They start at the ambient.
* **Gears**: the torque a gear transmits is the torque allowed last tick less the
  rotor's inertia torque, the inertia the link feels of it (N^2 (J_rotor + J_gear), or
  K / w_b^2 behind a series spring's torque loop) times the
  measured acceleration (the rates' difference over the tick); its peak is kept and
  each time it goes beyond the gear's momentary peak is counted. The acceleration is
  also kept low-passed (``acc``): the layer's limit on what the gear carries
  (:func:`exoleg.control.safety.safety_step`) rests on it, not on a tick's spike.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from exoleg.device.actuator import COPPER_ALPHA
from exoleg.device.thermal import copper_loss, thermal_hold, thermal_matrix


def watch_limits(r: NDArray[np.void], actuators: tuple[Any, ...], dt: float,
                 derate_band: float, max_torque: NDArray[np.float64]) -> None:
    """Fill the motor and gear fields of the safety layer's ``LIMITS`` record ``r`` for
    ``actuators`` at a tick of ``dt`` s: each motor's step matrix over one tick, joint
    torque per ampere, resistance at 25 degC, thermal resistances, winding limit and
    where derating starts (``derate_band`` K below), the continuous torque it derates to
    (within ``max_torque``); each gear's momentary and repeated peaks, the reflected
    inertia and the motor's drag at the joint (N k_t I_0, smoothed as the actuator's
    Coulomb friction)."""
    for i, a in enumerate(actuators):
        thermal_matrix(a.thermal(), dt, r["phi"][0, i])
        r["kt_joint"][0, i] = a.joint_torque_constant
        r["r25"][0, i] = a.terminal_resistance
        r["r_wh"][0, i] = a.thermal_resistance_winding
        r["r_ha"][0, i] = a.thermal_resistance_housing
        r["winding_limit"][0, i] = a.max_winding_temperature
        r["derate_from"][0, i] = a.max_winding_temperature - derate_band
        r["continuous"][0, i] = min(a.continuous_torque, max_torque[i])
        r["momentary"][0, i] = a.momentary_peak_torque
        r["repeated"][0, i] = a.repeated_peak_torque
        r["inertia"][0, i] = a.apparent_inertia
        r["drag"][0, i] = a.ratio * a.torque_constant * a.no_load_current
        r["smoothing"][0, i] = a.friction_smoothing
    r["dt"] = dt


@njit(cache=True)
def motors_tick(lim, state, dq, u):  # type: ignore[no-untyped-def]
    """The windings after a tick that allowed ``u`` (3,), and the rates ``dq`` kept for
    the next tick's gear check (the first tick sets the temperatures to the ambient)."""
    L = lim[0]
    s = state[0]
    if not s.started:
        s.started = True
        for i in range(3):
            s.winding[i] = L.ambient
            s.housing[i] = L.ambient
            s.dq_prev[i] = dq[i] if math.isfinite(dq[i]) else 0.0
        return
    for i in range(3):
        loss = copper_loss(L.r25[i], COPPER_ALPHA, s.winding[i], u[i] / L.kt_joint[i])
        s.winding[i], s.housing[i] = thermal_hold(L.phi[i], L.r_wh[i], L.r_ha[i], L.ambient,
                                                  s.winding[i], s.housing[i], loss)
        s.dq_prev[i] = dq[i] if math.isfinite(dq[i]) else s.dq_prev[i]


@njit(cache=True)
def gear_check(lim, state, dq):  # type: ignore[no-untyped-def]
    """Each gear's transmitted torque this tick, kept in ``state`` with its peak and the
    times it went beyond the gear's momentary peak. Returns the first joint beyond it
    (-1 for none)."""
    L = lim[0]
    s = state[0]
    over = -1
    if not s.started:
        return over
    for i in range(3):
        a = (dq[i] - s.dq_prev[i]) / L.dt
        if math.isfinite(a):  # a non-finite rate is the NONFINITE check's
            s.acc[i] = L.acc_keep * s.acc[i] + (1.0 - L.acc_keep) * a
        g = s.prev[i] - L.inertia[i] * a
        if not math.isfinite(g):
            g = 0.0
        if abs(g) > L.momentary[i]:
            if abs(s.gear[i]) <= L.momentary[i]:
                s.gear_events[i] += 1
            if over < 0:
                over = i
        s.gear[i] = g
        if abs(g) > s.gear_peak[i]:
            s.gear_peak[i] = abs(g)
    return over
