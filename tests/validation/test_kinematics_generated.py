"""The kinematics generated with the dynamics (exoleg.dynamics.codegen: joint_points,
foot_point, foot_point_jacobian, mass_height_terms, mass_height) against Pinocchio on the
exported URDF: joint placements and the toe frame (forwardKinematics), a point of the
foot's frame and its linear Jacobian (an operational frame on the ankle joint,
getFrameJacobian in LOCAL_WORLD_ALIGNED), the links' centre of mass, its Jacobian and
its drift acceleration (centerOfMass, jacobianCenterOfMass)."""

from __future__ import annotations

import numpy as np
import pytest

import exoleg
from exoleg.dynamics.kernels import (
    foot_point,
    foot_point_jacobian,
    joint_points,
    mass_height,
    mass_height_terms,
)
from exoleg.export.writers import to_urdf
from exoleg.validate.checks import random_leg

pin = pytest.importorskip("pinocchio", reason="Pinocchio (exoleg[validate])")

#: measured worst differences over these legs and states (float64 round-off of both
#: engines): points 2.2e-16 m, velocities 9.4e-16 m/s, Jacobians 2.2e-16 m, Y 1.8e-15 and
#: its gradient 1.1e-15 kg m, b 2.8e-14 kg m/s^2 (random legs up to ~30 kg, |dq| <= 4)
TOL = 1e-12


def _legs() -> list[exoleg.LegModel]:
    rng = np.random.default_rng(5)
    return [exoleg.paper_leg("simplified"), exoleg.paper_leg("detailed"),
            *(random_leg(rng) for _ in range(3))]


@pytest.mark.parametrize("leg", _legs(), ids=lambda lg: lg.name)
def test_generated_kinematics_match_pinocchio(leg: exoleg.LegModel) -> None:
    model = pin.buildModelFromXML(to_urdf(leg))
    ankle = model.getJointId("ankle")
    px, py = 0.05, -0.073  # a sensor point under the ankle, in the foot's frame
    frame = model.addFrame(pin.Frame("point", ankle, 0, pin.SE3(np.eye(3), np.array(
        [px, py, 0.0])), pin.FrameType.OP_FRAME))
    data = model.createData()
    mass = sum(lk.mass for lk in leg.links)
    rng = np.random.default_rng(17)
    pts, J = np.empty((4, 2)), np.empty((2, 3))
    for _ in range(25):
        q, dq = rng.uniform(-2.5, 2.5, 3), rng.uniform(-4, 4, 3)
        pin.forwardKinematics(model, data, q, dq)
        pin.updateFramePlacements(model, data)
        joint_points(q, leg.p, pts)
        for i, name in enumerate(("hip", "knee", "ankle")):
            assert np.allclose(pts[i], data.oMi[model.getJointId(name)].translation[:2],
                               atol=TOL), name
        toe = data.oMf[model.getFrameId("toe")].translation[:2]
        assert np.allclose(pts[3], toe, atol=TOL)
        x, y, vx, vy, _ = foot_point(q, dq, leg.p, px, py)
        assert np.allclose([x, y], data.oMf[frame].translation[:2], atol=TOL)
        v = pin.getFrameVelocity(model, data, frame, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        assert np.allclose([vx, vy], v.linear[:2], atol=TOL)
        pin.computeJointJacobians(model, data, q)
        Jp = pin.getFrameJacobian(model, data, frame, pin.ReferenceFrame.LOCAL_WORLD_ALIGNED)
        foot_point_jacobian(q, leg.p, px, py, J)
        assert np.allclose(J, Jp[:2], atol=TOL)
        # the links' mass height: Y = m y_com, dY/dq = m Jcom_y, b = m (ddy_com at ddq = 0)
        com = pin.centerOfMass(model, data, q, dq, np.zeros(3))
        Jc = pin.jacobianCenterOfMass(model, data, q)
        *grad, b, m = mass_height_terms(q, dq, leg.p)
        assert m == pytest.approx(mass, rel=1e-15)
        assert mass_height(q, leg.p) == pytest.approx(mass * com[1], abs=TOL)
        assert np.allclose(grad, mass * Jc[1], atol=TOL)
        assert b == pytest.approx(mass * data.acom[0][1], abs=TOL)
