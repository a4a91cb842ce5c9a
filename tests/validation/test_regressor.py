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
