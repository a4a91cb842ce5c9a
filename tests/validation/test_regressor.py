"""The joint-torque regressor (exoleg.dynamics.derive.regressor, the generated kernel):
tau = Y(q, dq, ddq) pi, linear in the inertial parameters pi.

References: the leg's own inverse dynamics (M ddq + C dq + G, itself checked against
Pinocchio and MuJoCo in test_model_validation); Pinocchio's own regressor
(computeJointTorqueRegressor, Featherstone's recursive algorithm on the exported URDF,
its ten standard parameters per body), column by column through the linear map from
exoleg's parameters to Pinocchio's.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import exoleg
from exoleg.device import with_actuators
from exoleg.dynamics.model import LegModel

LEG = with_actuators(exoleg.paper_leg())
angles = st.lists(st.floats(-3.0, 3.0), min_size=3, max_size=3)
rates = st.lists(st.floats(-20.0, 20.0), min_size=3, max_size=3)


@settings(max_examples=200, deadline=None)
@given(q=angles, dq=rates, ddq=rates)
def test_y_pi_is_the_inverse_dynamics(q: list[float], dq: list[float], ddq: list[float]
                                      ) -> None:
    # measured: 3.6e-15 N m at most over 50 random states (the kernels' rounding)
    tau = LEG.inverse_dynamics(q, dq, ddq)
    y = LEG.regressor(q, dq, ddq) @ LEG.inertial()
    assert np.abs(y - tau).max() <= 1e-12 * (1.0 + np.abs(tau).max())


def test_batches_broadcast_like_one_state() -> None:
    rng = np.random.default_rng(0)
    q, dq, ddq = rng.normal(size=(3, 7, 2, 3))
    Y = LEG.regressor(q, dq, ddq)
    assert Y.shape == (7, 2, 3, 15)
    assert np.array_equal(Y[4, 1], LEG.regressor(q[4, 1], dq[4, 1], ddq[4, 1]))
    with pytest.raises(exoleg.ParameterError, match="ddq"):
        LEG.regressor(q[0, 0], dq[0, 0], [np.nan, 0.0, 0.0])


def _with_inertial(leg: LegModel, pi: np.ndarray) -> LegModel:
    """``leg`` with the inertial parameters ``pi`` (the layout of LegModel.inertial)."""
    links = []
    for i, link in enumerate(leg.links):
        m, mx, my, zz = pi[4 * i:4 * i + 4]
        cx, cy = mx / m, my / m
        links.append(dataclasses.replace(link, mass=m, com=(cx, cy),
                                         izz=zz - m * (cx * cx + cy * cy), parts=()))
    return LegModel(links, g=leg.g, name=leg.name, armature=pi[12:])


def test_the_regressor_agrees_with_pinocchios_column_by_column() -> None:
    pin = pytest.importorskip("pinocchio", reason="Pinocchio (exoleg[validate])")
    from exoleg.validate.engines import PinocchioLeg

    def pin_params(leg: LegModel) -> np.ndarray:
        model = PinocchioLeg(leg).model
        return np.concatenate([model.inertias[i].toDynamicParameters()
                               for i in range(1, model.njoints)])

    model = PinocchioLeg(LEG).model
    data = model.createData()
    base = LEG.inertial()
    p0 = pin_params(LEG)
    # exoleg's parameters to Pinocchio's: linear (exact differences, one column each)
    steps = [0.1, 0.01, 0.01, 0.01] * 3
    T = np.stack([(pin_params(_with_inertial(LEG, base + h * np.eye(15)[j])) - p0) / h
                  for j, h in enumerate(steps)], axis=1)
    rng = np.random.default_rng(7)
    worst = 0.0
    for _ in range(20):
        q, dq, ddq = rng.uniform(-2, 2, 3), rng.uniform(-8, 8, 3), rng.uniform(-40, 40, 3)
        Yp = np.array(pin.computeJointTorqueRegressor(model, data, q, dq, ddq))
        Y = LEG.regressor(q, dq, ddq)
        worst = max(worst, float(np.abs(Y[:, :12] - Yp @ T).max() / np.abs(Y).max()))
        # the torques: Pinocchio's regressor has no armature; exoleg's last three columns
        tau = Yp @ p0 + LEG.armature * ddq
        assert np.allclose(Y @ base, tau, rtol=0, atol=1e-10 * np.abs(tau).max())
        assert np.array_equal(Y[:, 12:], np.diag(ddq))
    assert worst < 1e-10, worst  # measured 7.3e-16 (columns), torques 2.3e-16


def _khalil(leg: LegModel, static: bool) -> dict[str, dict[str, float]]:
    """Khalil & Dombre's regrouping of a planar chain on a fixed base (Modeling,
    Identification and Control of Robots, 2002, ch. 12): the masses beyond joint j+1 join
    link j's first moment along the link (times a_j) and its inertia (times a_j^2); the
    first joint's armature joins link 0's inertia."""
    a = leg.lengths
    rules: dict[str, dict[str, float]] = {}
    for j in range(3):
        beyond = {f"m{k}": 1.0 for k in range(j + 1, 3)}
        rules[f"MX{j}R"] = {f"MX{j}": 1.0, **{k: a[j] * v for k, v in beyond.items()}}
        rules[f"MY{j}R"] = {f"MY{j}": 1.0}
        if not static:
            rules[f"ZZ{j}R"] = {f"ZZ{j}": 1.0, **{k: a[j] ** 2 * v for k, v in beyond.items()},
                                **({"arm0": 1.0} if j == 0 else {})}
    if not static:
        rules["arm1R"], rules["arm2R"] = {"arm1": 1.0}, {"arm2": 1.0}
    return rules


@pytest.mark.parametrize("who", ["paper", "8 y girl", "12 y boy"])
def test_the_base_parameters_are_khalil_and_dombres_regrouping(who: str) -> None:
    # 9 inertial base parameters and 2 armatures in motion, 6 from static postures (the
    # issue's count); each one the rule's combination to 1e-9 (measured 1e-15)
    from exoleg.identify.base import NAMES, base_parameters
    from exoleg.sizing import Child, personalized_leg

    leg = LEG if who == "paper" else with_actuators(personalized_leg(
        Child(age=8, sex="female", height=1.26, mass=25.0) if who == "8 y girl"
        else Child(age=12, sex="male", height=1.52, mass=40.0)))
    for static, count in ((False, 11), (True, 6)):
        b = base_parameters(leg, static=static)
        assert len(b.columns) == count
        rules = _khalil(leg, static)
        assert set(b.names) == set(rules)
        for name, row in zip(b.names, b.K, strict=True):
            want = np.zeros(15)
            for k, v in rules[name].items():
                want[NAMES.index(k)] = v
            assert np.abs(row - want).max() < 1e-9, (name, row, want)
        # the base regressor times the base parameters is the torque
        rng = np.random.default_rng(3)
        q, dq, ddq = rng.normal(size=(3, 40, 3))
        if static:
            dq[:] = ddq[:] = 0.0
        Y = leg.regressor(q, dq, ddq)
        tau = Y @ leg.inertial()
        assert np.abs(b.regressor(Y) @ b.of(leg.inertial()) - tau).max() < 1e-12 * (
            1 + np.abs(tau).max())


def test_friction_columns_are_the_actuators_friction() -> None:
    # reference: the actuators' own friction model (exoleg.device.drive.friction)
    from exoleg.device.actuator import paper_actuators
    from exoleg.device.drive import friction
    from exoleg.identify.base import actuator_friction, friction_columns

    acts = paper_actuators()
    dq = np.linspace(-3.0, 3.0, 61)[:, None] * np.array([1.0, -0.5, 2.0])
    theta, smooth = actuator_friction(acts)
    F = friction_columns(dq, smooth)
    want = np.stack([[friction(a.record(), float(w[j])) for j, a in enumerate(acts)]
                     for w in dq])
    assert np.abs(F @ theta - want).max() < 1e-12
