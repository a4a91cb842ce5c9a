"""Identification of the leg's inertial parameters (exoleg.identify.estimate).

References: the true leg the torques were made from (its gravity torque and base
parameters); statistics of least squares (noise-free data recovers the truth to
rounding, noisy data within its standard deviations).
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
from hypothesis import example, given, settings
from hypothesis import strategies as st

import exoleg
from exoleg.device import with_actuators
from exoleg.device.actuator import paper_actuators
from exoleg.errors import ParameterError
from exoleg.identify.base import base_parameters
from exoleg.identify.estimate import identify_leg
from exoleg.sizing import Child, personalized_leg

ACTS = paper_actuators()
TRUE = with_actuators(personalized_leg(Child(age=10, sex="male", height=1.40, mass=32.0)))
#: the prior: the same child's model estimated 10 % heavy, the COMs 1 cm off along the
#: links, the rotors 2 % light (their datasheets' spread) -- G off by 13 % of its largest
PRIOR = exoleg.LegModel([dataclasses.replace(lk, mass=lk.mass * 1.1,
                                             com=(lk.com[0] + 0.01, lk.com[1]), parts=())
                         for lk in TRUE.links], g=TRUE.g, armature=TRUE.armature * 0.98)
FRICTION = np.array([[a.viscous_friction, a.coulomb_friction] for a in ACTS])
SMOOTH = np.array([a.friction_smoothing for a in ACTS])


def _excitation(seconds: float = 60.0, dt: float = 0.01, seed: int = 0
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Five harmonics of 0.1 Hz per joint about a mid-range posture."""
    t = np.arange(0.0, seconds, dt)
    w = 2 * np.pi * 0.1
    rng = np.random.default_rng(seed)
    q, dq, ddq = (np.zeros((len(t), 3)) for _ in range(3))
    for j, (amp, centre) in enumerate(((0.6, 0.3), (0.7, -0.7), (0.35, 0.0))):
        for k in range(1, 6):
            a, b = rng.normal(size=2) * amp / k
            s, c = np.sin(k * w * t), np.cos(k * w * t)
            q[:, j] += a * s + b * c
            dq[:, j] += k * w * (a * c - b * s)
            ddq[:, j] -= (k * w) ** 2 * (a * s + b * c)
        q[:, j] += centre
    return q, dq, ddq


def _torques(q: np.ndarray, dq: np.ndarray, ddq: np.ndarray) -> np.ndarray:
    return (TRUE.inverse_dynamics(q, dq, ddq) + FRICTION[:, 0] * dq
            + FRICTION[:, 1] * np.tanh(dq / SMOOTH))


def test_noise_free_data_recovers_the_truth() -> None:
    # the issue: noise-free recovery to 1e-6. Measured: G 9.0e-12 N m, friction 1.2e-11 (the
    # prior's rows weigh 1e-6 of the data's)
    q, dq, ddq = _excitation()
    r = identify_leg(PRIOR, q, dq, ddq, _torques(q, dq, ddq), SMOOTH)
    assert np.abs(r.leg.G(q) - TRUE.G(q)).max() < 1e-6
    assert np.abs(r.friction - FRICTION).max() < 1e-6
    b = base_parameters(TRUE)
    assert np.abs(r.values - b.of(TRUE.inertial())).max() < 1e-6
    # the identified leg's torques are the truth's, its full parameters the prior's
    # moved least: what the data cannot see stays the prior's
    assert np.abs(r.leg.inverse_dynamics(q, dq, ddq) - TRUE.inverse_dynamics(q, dq, ddq)
                  ).max() < 1e-6


def test_noisy_torques_within_the_goal_and_their_standard_deviations(tmp_path: Path
                                                                     ) -> None:
    # 0.5 N m of torque noise per sample (the drives' current noise through k_t N is
    # smaller); the goal for G over the range of motion: RMS <= 1 %, max <= 3 %
    # of max |G|. Measured: 0.079 % and 0.22 % (prior: 13 %); every base parameter within
    # 4 SD of the truth (the worst 1.8 SD). Accelerations here are exact: from encoders
    # they are estimated, which the measurement through the runtime will carry.
    q, dq, ddq = _excitation()
    rng = np.random.default_rng(1)
    r = identify_leg(PRIOR, q, dq, ddq, _torques(q, dq, ddq) + rng.normal(0, 0.5, q.shape),
                     SMOOTH)
    scale = np.abs(TRUE.G(q)).max()
    err = r.leg.G(q) - TRUE.G(q)
    assert np.sqrt(np.mean(err**2)) / scale < 0.01 and np.abs(err).max() / scale < 0.03
    truth = base_parameters(TRUE).of(TRUE.inertial())
    assert np.all(np.abs(r.values - truth) <= 4 * r.sd), (r.values - truth) / r.sd
    assert np.allclose(r.residual_rms, 0.5, rtol=0.05)
    # the identified leg is a leg file every command takes
    exoleg.save_leg(r.leg, tmp_path / "leg.toml")
    back = exoleg.load_leg(tmp_path / "leg.toml")
    assert np.allclose(back.G(q[:50]), r.leg.G(q[:50]), rtol=0, atol=1e-9)
    rows = r.table()
    assert rows[0]["parameter"] == "MX0R" and rows[0]["low95"] < rows[0]["value"]


def test_what_cannot_identify_is_refused() -> None:
    q, dq, ddq = _excitation(seconds=20.0)
    tau = _torques(q, dq, ddq)
    hip_only = [x.copy() for x in (q, dq, ddq)]
    for x in hip_only:
        x[:, 1:] = 0.0
    with pytest.raises(ParameterError, match="excite every joint"):
        identify_leg(PRIOR, *hip_only, tau, SMOOTH)
    with pytest.raises(ParameterError, match="samples"):
        identify_leg(PRIOR, q[:5], dq[:5], ddq[:5], tau[:5], SMOOTH)
    bad = tau.copy()
    bad[3, 1] = np.nan
    with pytest.raises(ParameterError, match="tau: holds a value that is not finite"):
        identify_leg(PRIOR, q, dq, ddq, bad, SMOOTH)
    with pytest.raises(ParameterError, match="expected shape"):
        identify_leg(PRIOR, q[:, :2], dq, ddq, tau, SMOOTH)


@settings(max_examples=6, deadline=None)
@given(seed=st.integers(0, 10_000), child=st.sampled_from(["8 y girl", "10 y boy",
                                                           "12 y boy"]))
@example(seed=2464, child="10 y boy")  # its move in from standing beyond the hip's torque
@example(seed=1015, child="12 y boy")  # checked every 5 ms, its hip torque peaked between
def test_an_excitation_plan_stays_within_the_safety_bounds(seed: int, child: str) -> None:
    # the issue: the plan never leaves the safety bounds, and takes <= 2 min of device
    # time. The bounds: the safety layer's range of motion less 5 deg, 60 deg/s (the
    # child's comfort, under the actuators' speed), 60 % of the torque the layer allows,
    # checked at 1 kHz with the model's torques (measured for the 10-year-old: condition
    # number 7.7 with 40 candidates)
    from exoleg.control.safety import SafetyLimits
    from exoleg.identify.plan import check_plan, design_plan, plan_limits

    who = {"8 y girl": Child(age=8, sex="female", height=1.26, mass=25.0),
           "10 y boy": Child(age=10, sex="male", height=1.40, mass=32.0),
           "12 y boy": Child(age=12, sex="male", height=1.52, mass=40.0)}[child]
    leg = with_actuators(personalized_leg(who))
    lim = plan_limits(SafetyLimits.paper(), ACTS)
    from exoleg.system.config import DeviceConfig

    standing = DeviceConfig.load().gains.standing
    plan = design_plan(leg, ACTS, lim, candidates=4, seed=seed, start=standing)
    assert plan.duration <= 120.0
    assert check_plan(plan, leg, ACTS, lim, dt=1e-3) == []
    _, q, dq, ddq = plan.sample(1e-3)
    assert np.all(q >= lim.lower - 1e-9) and np.all(q <= lim.upper + 1e-9)
    assert np.all(np.abs(dq) <= lim.speed + 1e-9)
    # periodic: it ends where it started, at the same rates -- at rest, so the
    # minimum-jerk moves from the device's standing posture join it without a jolt
    assert np.allclose(q[0], q[-1], atol=1e-9) and np.allclose(dq[0], dq[-1], atol=1e-9)
    assert np.abs(dq[0]).max() < 1e-9 and np.abs(ddq[0]).max() < 1e-9
    # what the device follows, moves in and out included, within the bounds too (the
    # moves within the safety layer's range itself: the standing knee is within 5 deg of
    # its end); continuous to the acceleration at the joins (finite differences)
    from exoleg.identify.plan import RANGE_MARGIN, PlanReference

    ref = PlanReference(plan, standing)
    assert check_plan(ref, leg, ACTS, lim, dt=1e-3) == []
    t = np.arange(0.0, ref.duration, 1e-3)
    rq, rdq, rddq = ref.sample(t)
    assert np.all(rq >= lim.lower - RANGE_MARGIN - 1e-9)
    assert np.all(rq <= lim.upper + RANGE_MARGIN + 1e-9)
    assert np.all(np.abs(rdq) <= lim.speed + 1e-9)
    assert np.allclose(rq[0], ref.start) and np.allclose(rq[-1], ref.start)
    assert np.abs(np.diff(rdq, axis=0)).max() / 1e-3 <= 1.01 * np.abs(rddq).max()


def test_the_designed_plan_identifies_the_leg() -> None:
    from exoleg.control.safety import SafetyLimits
    from exoleg.identify.plan import design_plan, plan_limits

    plan = design_plan(TRUE, ACTS, plan_limits(SafetyLimits.paper(), ACTS), candidates=8)
    _, q, dq, ddq = plan.sample(0.01)
    r = identify_leg(PRIOR, q, dq, ddq, _torques(q, dq, ddq), SMOOTH)
    assert np.abs(r.leg.G(q) - TRUE.G(q)).max() < 1e-6


def test_simulated_children_identified_within_the_goal() -> None:
    # exoleg validate --identify's pipeline on three children of the design range (GMFCS
    # IV, typically developing, GMFCS II): their segments off the tables, 20-bit encoders
    # differentiated over 41 ms, torque noise 1 % of continuous, each child's passive
    # moments and their level's spasticity against the drives, held at their model. The
    # issue's goal: G RMS <= 1 %, max <= 3 % of max |G|. Measured on these three (their
    # segments 15 % off the tables, the device's links 5 % off its model): RMS
    # 0.019-0.032 %, max 0.048-0.063 %, the fitted legs 0.91-5.9 % off. (With the prior
    # on the inertia about the joint rather than the centre of mass, one child in ten
    # came out with a foot that is not a body.)
    from exoleg.validate.identify import children, run_child

    for i, c in enumerate(children(3)):
        r = run_child(c, i)
        assert r.g_rms_pct <= 1.0 and r.g_max_pct <= 3.0, r
        assert r.g_max_pct < r.prior_g_max_pct / 10, r


def test_control_with_the_identified_leg_as_with_the_true_one() -> None:
    # The issue: gravity compensation with the identified leg tracks as well as with the
    # true leg (walking RMS error within 10 %). The walking controller on a GMFCS IV
    # 9-year-old's true leg (passive), given the true, identified or fitted model: the
    # tracking RMS with the identified G 0.83 % from the true G's at worst over the
    # joints, with the fitted G 1.2 % (measured). Walking is impedance-dominated; the
    # paper's PD + gravity holding its postures shows G itself: the identified leg holds
    # them 0.018 deg from where the true leg's law does, the fitted 0.23 deg (K_p^-1 of
    # its 5.9 % error in G).
    from exoleg.validate.identify import children, identify_child, posture_errors, walking_tracking

    c = identify_child(children(1)[0], 0)
    walk = walking_tracking(c)
    assert walk, "the device carries this child"
    assert np.all(np.abs(walk["identified"] / walk["true"] - 1) <= 0.10), walk
    held = posture_errors(c)
    assert held["identified"] < np.radians(0.05) < np.radians(0.15) < held["fitted"], held
