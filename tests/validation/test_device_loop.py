"""The closed loop with actuators and the safety layer (exoleg.sim.device_loop).

References: MuJoCo stepping the same leg with the same armature under the torques the
drives delivered (its own RK4); the work-energy theorem (the energy the motors put in,
less what friction took, is the change of T + V); numpy's eigenvalues for the sampled
margin with reflected inertia; the paper's scenario without actuators (exoleg.simulate).
"""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

import exoleg
from exoleg.control import PDGravity
from exoleg.control.safety import SafetyLimits
from exoleg.device import paper_actuators, with_actuators
from exoleg.reference.paper import paper_reference
from exoleg.sim.closed_loop import sampled_stability
from exoleg.sim.device_loop import simulate_device

LEG = exoleg.paper_leg()
CTRL = PDGravity(LEG)
ACTS = paper_actuators()
NO_FRICTION = tuple(dataclasses.replace(a, no_load_current=0.0, backdriving_torque=0.0,
                                        viscous_friction=0.0)
                    for a in ACTS)


def test_plant_with_armature_agrees_with_mujoco() -> None:
    mujoco = pytest.importorskip("mujoco", reason="MuJoCo (exoleg[validate])")
    from exoleg.export.writers import to_mjcf

    r = simulate_device(LEG, CTRL, paper_reference(), 6.0, actuators=NO_FRICTION,
                        q0=np.zeros(3))
    m = mujoco.MjModel.from_xml_string(to_mjcf(r.leg, timestep=1e-3))
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_LIMIT
    assert np.array_equal(m.dof_armature, r.leg.armature)
    d = mujoco.MjData(m)
    q = [d.qpos.copy()]
    for k in range(len(r.t) - 1):
        d.qfrc_applied[:] = r.tau[k]  # the drives' mean torque over the tick, held
        mujoco.mj_step(m, d)
        q.append(d.qpos.copy())
    diff = np.abs(np.array(q) - r.q).max()
    assert diff < 1e-12  # measured 8.6e-16 rad


def test_energy_balance_with_friction() -> None:
    # With one plant step per tick the drive's torque is held over the step: the motors'
    # work is tau . dq exactly; friction's is integrated by the trapezoid rule (O(h^2)).
    r = simulate_device(LEG, CTRL, paper_reference(), 6.0, q0=np.zeros(3))
    E = r.leg.kinetic_energy(r.q, r.dq) + r.leg.potential_energy(r.q)
    w_motor = np.sum(r.tau[:-1] * np.diff(r.q, axis=0))
    fv = np.array([[a.viscous_friction * v
                    + a.coulomb_friction * math.tanh(v / a.friction_smoothing)
                    for a, v in zip(ACTS, row, strict=True)] for row in r.dq]) * r.dq
    w_friction = np.sum(0.5 * (fv[1:] + fv[:-1]) * 1e-3)
    gap = (E[-1] - E[0]) - (w_motor - w_friction)
    assert abs(gap) < 1e-5 * (abs(w_motor) + w_friction)  # measured 9.1e-7 relative
    assert w_friction > 0


def test_reflected_inertia_and_the_sampled_margin() -> None:
    # Reference: numpy's eigenvalues of (M + diag(N^2 J))^-1 Kd.
    plant = with_actuators(LEG)
    q = np.array([0.3, -0.8, 0.1])
    Ma = LEG.M(q) + np.diag([a.reflected_inertia for a in ACTS])
    want = 1e-3 * max(np.linalg.eigvals(np.linalg.solve(Ma, np.diag(CTRL.Kd))).real)
    assert sampled_stability(plant, CTRL, 1e-3, q) == pytest.approx(want, rel=1e-12)
    # the paper's scenario: 1.445 without the actuators, 0.034 with them (0.027 with the
    # rotor inertias exoleg had before the datasheets, issue 21)
    r = simulate_device(LEG, CTRL, paper_reference(), 12.0, q0=np.zeros(3))
    ideal = exoleg.simulate(LEG, CTRL, paper_reference(), 12.0, q0=np.zeros(3))
    assert ideal.stability_margin == pytest.approx(1.445, abs=1e-3)
    assert r.stability_margin == pytest.approx(0.0341, abs=1e-3)


def test_encoders_and_safety_shape_what_the_drives_get() -> None:
    r = simulate_device(LEG, CTRL, paper_reference(), 3.0, q0=np.zeros(3))
    res = 2 * math.pi / 2**20
    assert np.abs(r.q_meas - r.q).max() <= res / 2 * (1 + 1e-9)
    # the step at t = 0 asks for a torque jump; the safety layer ramps it (16 = RATE)
    assert r.status[0] & 16
    assert np.all(np.abs(np.diff(r.u_safe, axis=0)) <= SafetyLimits.paper().max_torque_rate
                  * 1e-3 * (1 + 1e-12))
    assert np.all(np.abs(r.tau) <= r.envelope + 1e-12)
    assert r.fault == ""


def test_overspeed_trips_the_safety_layer_and_torque_stays_off() -> None:
    lim = dataclasses.replace(SafetyLimits.paper(), max_speed=np.array([0.5, 0.5, 0.5]))
    r = simulate_device(LEG, CTRL, paper_reference(), 2.0, safety=lim, q0=np.zeros(3))
    assert r.fault.startswith("OVERSPEED")
    k = int(np.argmax(np.abs(r.dq_meas).max(axis=1) > 0.5))
    assert np.all(r.u_safe[k:] == 0.0) and np.all(r.status[k:] & 2)


def test_deterministic() -> None:
    a = simulate_device(LEG, CTRL, paper_reference(), 1.0, q0=np.zeros(3))
    b = simulate_device(LEG, CTRL, paper_reference(), 1.0, q0=np.zeros(3))
    assert np.array_equal(a.q, b.q) and np.array_equal(a.tau, b.tau)


def test_refuses_what_simulate_refuses() -> None:
    with pytest.raises(exoleg.ParameterError, match="knee at 90 deg"):
        simulate_device(LEG, CTRL, paper_reference(), 1.0, q0=[0.0, math.radians(90), 0.0])
    with pytest.raises(exoleg.ParameterError, match="substeps"):
        simulate_device(LEG, CTRL, paper_reference(), 1.0, substeps=0)
