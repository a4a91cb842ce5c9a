"""Exports a robotics user can open: limits, efforts, masses and geometry read back by
Pinocchio, MuJoCo and ROS's urdf_parser_py; the z-up frame against exoleg's G.

References: the paper's range of motion (section 2.1) and Table 2 as shipped
(``exoleg.params.paper``); the leg's own masses; exoleg's G (itself checked against
Appendix B and Pinocchio in test_model_validation).
"""

import math

import numpy as np
import pytest

import exoleg
from exoleg.export import writers
from exoleg.params import paper

LEG = exoleg.paper_leg("detailed")
ROM = paper.range_of_motion()
ACTS = paper.actuators()
EFFORT = [a.max_torque for a in ACTS]
VELOCITY = [a.max_velocity for a in ACTS]


def test_urdf_read_by_ros_urdf_parser():
    urdf = pytest.importorskip("urdf_parser_py.urdf", reason="urdf-parser-py (exoleg[dev])")
    for mode in ("lumped", "welded"):
        robot = urdf.URDF.from_xml_string(writers.to_urdf(LEG, mode, frame="z-up"))
        joints = {j.name: j for j in robot.joints}
        for i, name in enumerate(("hip", "knee", "ankle")):
            lim = joints[name].limit
            assert (lim.lower, lim.upper) == (ROM.lower[i], ROM.upper[i])
            assert (lim.effort, lim.velocity) == (EFFORT[i], VELOCITY[i])
        mass = sum(lk.inertial.mass for lk in robot.links if lk.inertial is not None)
        assert mass == pytest.approx(sum(lk.mass for lk in LEG.links), rel=1e-15)
        shapes = [lk.visual.geometry for lk in robot.links if lk.visual is not None]
        assert len(shapes) == 3 and type(shapes[2]).__name__ == "Box"
        assert shapes[2].size[0] == LEG.links[2].length  # footplate, Table 1: 23.5 cm


def test_urdf_read_by_pinocchio():
    pin = pytest.importorskip("pinocchio", reason="Pinocchio (exoleg[validate])")
    model = pin.buildModelFromXML(writers.to_urdf(LEG))
    assert np.array_equal(model.lowerPositionLimit, ROM.lower)
    assert np.array_equal(model.upperPositionLimit, ROM.upper)
    assert np.array_equal(model.effortLimit, EFFORT)
    assert np.array_equal(model.velocityLimit, VELOCITY)
    assert sum(model.inertias[i].mass for i in range(1, 4)) == pytest.approx(
        sum(lk.mass for lk in LEG.links), rel=1e-14)


def test_z_up_urdf_gives_exoleg_gravity_with_pinocchio_default_gravity():
    # REP 103: z up. Loaded with Pinocchio's default gravity (0, 0, -9.81) and nothing
    # else set, the z-up export must give exoleg's G (g = 9.81, the paper's).
    pin = pytest.importorskip("pinocchio", reason="Pinocchio (exoleg[validate])")
    model = pin.buildModelFromXML(writers.to_urdf(LEG, frame="z-up"))
    data = model.createData()
    assert np.array_equal(model.gravity.linear, [0.0, 0.0, -9.81])
    for q in np.random.default_rng(3).uniform(ROM.lower, ROM.upper, (20, 3)):
        got = pin.computeGeneralizedGravity(model, data, q)
        assert np.allclose(got, LEG.G(q), rtol=1e-12, atol=1e-12)
    # and the y-up export gives zero G with that default: the frame matters
    y_up = pin.buildModelFromXML(writers.to_urdf(LEG))
    assert np.allclose(pin.computeGeneralizedGravity(y_up, y_up.createData(), np.ones(3)), 0)


def test_mjcf_read_by_mujoco():
    mujoco = pytest.importorskip("mujoco", reason="MuJoCo (exoleg[validate])")
    arm = [1e-3, 2e-3, 3e-3]
    for frame in ("y-up", "z-up"):
        m = mujoco.MjModel.from_xml_string(writers.to_mjcf(LEG, "welded", frame=frame,
                                                           armature=arm))
        assert np.array_equal(m.jnt_range, np.stack([ROM.lower, ROM.upper], axis=1))
        assert np.array_equal(m.jnt_limited, [1, 1, 1])
        assert np.array_equal(m.jnt_actfrcrange[:, 1], EFFORT)
        assert np.array_equal(m.actuator_ctrlrange[:, 1], EFFORT)
        assert np.array_equal(m.dof_armature, arm)
        assert m.nu == 3 and m.ngeom == 3
        assert m.body_mass.sum() == pytest.approx(sum(lk.mass for lk in LEG.links), rel=1e-14)
        # gravity torques at rest equal exoleg's G in either frame
        d = mujoco.MjData(m)
        q = np.array([0.4, -0.7, 0.2])
        d.qpos[:] = q
        mujoco.mj_forward(m, d)
        assert np.allclose(d.qfrc_bias, LEG.G(q), rtol=1e-12, atol=1e-12)


def test_mjcf_motor_ctrl_is_joint_torque():
    # A motor actuator with gear 1 applies ctrl as the joint torque: at rest with ctrl = G,
    # the leg does not accelerate (reference: exoleg's G).
    mujoco = pytest.importorskip("mujoco", reason="MuJoCo (exoleg[validate])")
    m = mujoco.MjModel.from_xml_string(writers.to_mjcf(LEG))
    d = mujoco.MjData(m)
    q = np.array([0.3, -0.5, 0.1])
    d.qpos[:] = q
    d.ctrl[:] = LEG.G(q)
    mujoco.mj_forward(m, d)
    assert np.allclose(d.qacc, 0.0, atol=1e-10)


def test_bad_export_arguments_are_named():
    with pytest.raises(exoleg.ParameterError, match="frame"):
        writers.to_urdf(LEG, frame="x-up")  # type: ignore[arg-type]
    with pytest.raises(exoleg.ParameterError, match="armature"):
        writers.to_mjcf(LEG, armature=[0.0, -1.0, 0.0])
    with pytest.raises(exoleg.ParameterError, match="armature"):
        writers.to_mjcf(LEG, armature=[0.0, math.nan, 0.0])


def test_names_with_quotes_are_escaped():
    leg = exoleg.LegModel(LEG.lumped().links, name='leg "A" & <b>')
    pin = pytest.importorskip("pinocchio", reason="Pinocchio (exoleg[validate])")
    mujoco = pytest.importorskip("mujoco", reason="MuJoCo (exoleg[validate])")
    assert pin.buildModelFromXML(writers.to_urdf(leg)).name == 'leg_"A"_&_<b>'
    assert mujoco.MjModel.from_xml_string(writers.to_mjcf(leg)).nbody == 4
