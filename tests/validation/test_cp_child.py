"""A real child with CP in the package (issue 41): predictcpgait subject 1 (Falisse et al.
2020, MIT licence), shipped with its trials' spread, moments and ground reaction force;
exoleg's dynamics on their gait, the gait as a simulated child's intent, and their
sagittal pattern. References: the shipped inverse-dynamics moments (OpenSim's, from the
authors' repository) and the shipped samples themselves."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from exoleg.child.model import ChildModel, real_gait
from exoleg.errors import ParameterError
from exoleg.validate.cp_child import MASS_KG, cp_child_gait, inverse_dynamics


def test_exolegs_dynamics_on_the_real_childs_gait_give_their_moments() -> None:
    # exoleg's planar leg for a child of their size, moved through their sagittal
    # kinematics and loaded by their ground reaction force, against the authors' inverse
    # dynamics. Measured: hip 17 %, knee 22 % RMS of the moments' own RMS (16.1, 17.0 N m);
    # with the subject's own segments, planar, 29 / 17 %; in 3D on their model, 6.5 / 5.1 %
    # (the next test): the rest is the child's hip out of the plane. Bounds: as measured
    r = inverse_dynamics()
    assert np.all(r["relative"][:2] <= [0.18, 0.23]), r["relative"]
    assert np.allclose(r["tau"][:, 2], r["shipped"][:, 2], atol=1e-9)  # by construction
    # the pelvis's tilt turns the thigh as the hip's flexion does: added the other way
    # the hip's moment is off by more than its own size
    assert inverse_dynamics(tilt_sign=-1.0)["relative"][0] > 1.0
    # the ground reaction force is in % body weight (the source's unit): in N it would
    # be 1 / 3.2 of the moments' loads, the stance knee off by most of its moment
    g = cp_child_gait()
    import exoleg.validate.cp_child as cc

    try:
        cc.cp_child_gait = lambda: dataclasses.replace(g, grf=g.grf / (MASS_KG * 9.81 / 100))
        assert cc.inverse_dynamics()["relative"][1] > 0.5
    finally:
        cc.cp_child_gait = cp_child_gait


def test_their_own_model_in_3d_gives_their_moments() -> None:
    # issue 41's goal: inverse dynamics on the shipped kinematics within 10 % RMS of the
    # shipped moments at hip and knee. On the subject's own OpenSim model (its right leg,
    # shipped), in 3D, loaded by the shipped ground reaction force at the centre of
    # pressure the shipped ankle and subtalar moments place: measured hip flexion 6.5 %,
    # adduction 4.1 %, knee 5.1 % (the planar leg's 17 / 22 % above are the child's hip
    # out of the sagittal plane); hip rotation 40 % (the free moment, not shipped, is
    # left out: it is the rotation's load). Reference: the authors' OpenSim inverse
    # dynamics (the shipped moments), with the model this reads
    from exoleg.validate.cp_child import inverse_dynamics_3d

    r = inverse_dynamics_3d()
    rel = dict(zip(r["coordinates"], r["relative"], strict=True))
    assert rel["hip_flex_r"] <= 0.10 and rel["knee_flex_r"] <= 0.10, rel
    assert rel["hip_add_r"] <= 0.10, rel
    # the ankle's and subtalar's are given (they place the centre of pressure: exact in
    # stance, the samples under 1 N of load the rest; measured 0.02 and 0.1 %); that
    # centre moves forward along the stance, under the foot
    assert rel["ankle_flex_r"] < 2e-3 and rel["subt_angle_r"] < 2e-3
    x = r["cop"][:, 0]
    stance = np.isfinite(x)
    assert 0.10 <= np.ptp(x[stance]) <= 0.20  # a 10-year-old's foot, 18-22 cm
    # the model read otherwise: the knee's frame not turned in the tibia (its
    # orientation) the knee and hip are off by more
    import exoleg.reference.cp_child as ref
    import exoleg.validate.cp_child as cc

    model = ref.cp_child_model()
    tibia = {**model["body"]["tibia_r"], "orientation": [0.0, 0.0, 0.0]}
    plain = cc.SubjectLeg({**model, "body": {**model["body"], "tibia_r": tibia}})
    try:
        cc.SubjectLeg = lambda: plain  # type: ignore[assignment,misc]
        worse = dict(zip(r["coordinates"], inverse_dynamics_3d()["relative"], strict=True))
    finally:
        cc.SubjectLeg = type(plain)  # type: ignore[misc]
    assert worse["knee_flex_r"] > rel["knee_flex_r"], (worse, rel)


@pytest.mark.skipif(not __import__("exoleg.validate.opensim_child", fromlist=["x"]).available(),
                    reason="OpenSim not installed (pip install exoleg[opensim])")
def test_their_leg_moves_as_opensim_moves_it(tmp_path: Path) -> None:
    # reference: OpenSim 4.6 itself, with the subject's leg rebuilt from the shipped model
    # file (bodies, the same joints' transform functions, the patella's couplers) as a
    # fresh OpenSim model: every body's place and orientation at the shipped motion's
    # samples. Measured: 7e-10 m and 1e-9 (rotation entries); 1.3e-7 m and 5e-8 against
    # the authors' own model file (its muscles and all, OpenSim 3's format)
    import opensim as osim

    from exoleg.reference.cp_child import cp_child_motion
    from exoleg.validate.cp_child import SubjectLeg

    path = _opensim_leg(tmp_path)
    model = osim.Model(str(path))
    state = model.initSystem()
    coords = model.getCoordinateSet()
    leg = SubjectLeg()
    m = cp_child_motion()
    worst = [0.0, 0.0]
    for k in range(0, 100, 9):
        q = {c: float(v[k]) for c, v in m.q.items()}
        for c, v in q.items():
            coords.get(c).setValue(state, v, False)
        model.assemble(state)
        model.realizePosition(state)
        mine = leg.poses(q)
        for name in leg.bodies:
            b = model.getBodySet().get(name)
            p, rot = b.getPositionInGround(state), b.getTransformInGround(state).R()
            worst[0] = max(worst[0], max(abs(p.get(i) - mine[name][1][i]) for i in range(3)))
            worst[1] = max(worst[1], max(abs(rot.get(i, j) - mine[name][0][i, j])
                                         for i in range(3) for j in range(3)))
    assert worst[0] < 1e-6 and worst[1] < 1e-6, worst


def _opensim_leg(tmp_path: Path) -> Path:
    """The shipped model file's right leg as an OpenSim 4 model file: a pelvis on six
    coordinates (x, y, z rotations body-fixed, then translations), each body on a
    CustomJoint with the file's transform axes and functions, the patella's couplers."""
    from exoleg.reference.cp_child import cp_child_model

    m = cp_child_model()

    def fn(f: dict) -> str:  # type: ignore[type-arg]
        kind = f["kind"]
        if kind == "linear":
            body = (f"<LinearFunction><coefficients>{f['slope']} {f['offset']}"
                    "</coefficients></LinearFunction>")
        elif kind == "constant":
            body = f"<Constant><value>{f['value']}</value></Constant>"
        else:
            tag = "SimmSpline" if kind == "spline" else "PiecewiseLinearFunction"
            body = (f"<{tag}><x>{' '.join(map(str, f['x']))}</x>"
                    f"<y>{' '.join(map(str, f['y']))}</y></{tag}>")
        if "scale" in f:
            body = (f"<MultiplierFunction><function>{body}</function>"
                    f"<scale>{f['scale']}</scale></MultiplierFunction>")
        return body

    def v3(x: list[float]) -> str:
        return " ".join(map(str, x))

    def joint(name: str, parent: str, child: str, loc: list[float], ori: list[float],
              axes: list[dict]) -> str:  # type: ignore[type-arg]
        coords = sorted({a["coordinate"] for a in axes if a["coordinate"]})
        moves = {c: "translational" if c[-2:] in ("TX", "TY", "TZ") or "_t" in c[-4:]
                 else "rotational" for c in coords}
        cs = "".join(f'<Coordinate name="{c}"><motion_type>{moves[c]}</motion_type>'
                     '<range>-100 100</range></Coordinate>' for c in coords)
        ta = "".join(
            f'<TransformAxis name="{a["name"]}">'
            + (f'<coordinates>{a["coordinate"]}</coordinates>' if a["coordinate"] else "")
            + f'<axis>{v3(a["axis"])}</axis>{fn(a["function"]) if "function" in a else ""}'
            '</TransformAxis>' for a in axes)
        return (f'<CustomJoint name="{name}"><socket_parent_frame>{parent}_offset'
                f'</socket_parent_frame><socket_child_frame>{child}_offset</socket_child_frame>'
                f'<coordinates>{cs}</coordinates><frames>'
                f'<PhysicalOffsetFrame name="{parent}_offset"><socket_parent>'
                f'{"/ground" if parent == "ground" else "/bodyset/" + parent}</socket_parent>'
                f'<translation>{v3(loc)}</translation><orientation>0 0 0</orientation>'
                f'</PhysicalOffsetFrame><PhysicalOffsetFrame name="{child}_offset">'
                f'<socket_parent>/bodyset/{child}</socket_parent><translation>0 0 0'
                f'</translation><orientation>{v3(ori)}</orientation></PhysicalOffsetFrame>'
                f'</frames><SpatialTransform>{ta}</SpatialTransform></CustomJoint>')

    lin = {"kind": "linear", "slope": 1.0, "offset": 0.0}
    zero = {"kind": "constant", "value": 0.0}
    pelvis_axes = [{"name": f"rotation{i + 1}", "coordinate": f"lower_torso_R{a}",
                    "axis": ax, "function": lin}
                   for i, (a, ax) in enumerate(zip("XYZ", ([1, 0, 0], [0, 1, 0], [0, 0, 1]),
                                                   strict=True))]
    pelvis_axes += [{"name": f"translation{i + 1}", "coordinate": f"lower_torso_T{a}",
                     "axis": ax, "function": lin}
                    for i, (a, ax) in enumerate(zip("XYZ", ([1, 0, 0], [0, 1, 0], [0, 0, 1]),
                                                    strict=True))]
    bodies = ['<Body name="pelvis"><mass>1</mass><mass_center>0 0 0</mass_center>'
              '<inertia>1 1 1 0 0 0</inertia></Body>']
    joints = [joint("gnd_pelvis", "ground", "pelvis", [0, 0, 0], [0, 0, 0], pelvis_axes)]
    for name, b in m["body"].items():
        bodies.append(f'<Body name="{name}"><mass>{b["mass"]}</mass><mass_center>'
                      f'{v3(b["com"])}</mass_center><inertia>{v3(b["inertia"])}</inertia></Body>')
        axes = [{**a, "function": a["function"] if a["coordinate"] else zero}
                for a in b["axes"]]
        joints.append(joint(name + "_joint", b["parent"], name, b["location_in_parent"],
                            b["orientation"], axes))
    couplers = "".join(
        f'<CoordinateCouplerConstraint name="{dep}_con"><coupled_coordinates_function>'
        f'{fn(c["function"])}</coupled_coordinates_function><independent_coordinate_names>'
        f'{c["coordinate"]}</independent_coordinate_names><dependent_coordinate_name>{dep}'
        f'</dependent_coordinate_name><scale_factor>{c["scale"]}</scale_factor>'
        '</CoordinateCouplerConstraint>' for dep, c in m.get("coupler", {}).items())
    xml = ('<?xml version="1.0" encoding="UTF-8" ?><OpenSimDocument Version="40000">'
           '<Model name="subject1_right_leg"><gravity>0 -9.80665 0</gravity>'
           f'<BodySet><objects>{"".join(bodies)}</objects></BodySet>'
           f'<JointSet><objects>{"".join(joints)}</objects></JointSet>'
           f'<ConstraintSet><objects>{couplers}</objects></ConstraintSet>'
           '</Model></OpenSimDocument>')
    path = tmp_path / "subject1_right_leg.osim"
    path.write_text(xml)
    return path


def test_the_real_childs_gait_as_a_childs_intent() -> None:
    g = cp_child_gait()
    x = np.linspace(0.0, 1.0, len(g.t))
    q, dq, tau = real_gait(x, float(g.t[-1]), 2 * MASS_KG)
    want = g.q.copy()
    want[:, 0] += g.tilt  # the hip from the vertical, as exoleg's upright hip
    assert np.degrees(np.abs(q - want)).max() < 0.7  # 12 harmonics: measured 0.64 deg
    # scaled by the mass (the last sample is the next cycle's first: x = 1 is x = 0)
    assert tau[:-1] == pytest.approx(2 * g.tau[:-1], rel=1e-12)
    # the rate is the angle's derivative over the stride time (central differences)
    h = 1e-5
    qa, _, _ = real_gait(x + h, float(g.t[-1]), MASS_KG)
    qb, _, _ = real_gait(x - h, float(g.t[-1]), MASS_KG)
    assert dq == pytest.approx((qa - qb) / (2 * h) / float(g.t[-1]), abs=1e-6)
    child = ChildModel("cp", 10, 1.375, 33.1, gmfcs=2, gait="predictcpgait")
    assert ChildModel.from_dict({"child": {"age_years": 10, "height_m": 1.375,
                                           "mass_kg": 33.1, "sex": "female", "gmfcs": 2},
                                 "effort": {"gait": "predictcpgait"}}).gait == child.gait
    with pytest.raises(ParameterError, match="crouch: 3: a crouch cluster bends"):
        child.with_(crouch=3)
    with pytest.raises(ParameterError, match="gait: 'toe': allowed normative, predictcpgait"):
        child.with_(gait="toe")


def test_the_simulated_child_walks_the_real_childs_pattern() -> None:
    # the simulated child of their size (GMFCS II, mild spasticity, the predictcpgait
    # contracture) intending their gait, transparent mode, on a treadmill matched to that
    # gait (the belt's speed and the other leg's support from its stance and swing): the
    # same sagittal pattern as the real child (Sangeux 2015: apparent equinus), forefoot
    # contacts, no fault. Against the real child's mean +- 1 SD (measured over 12
    # strides, exoleg validate --cp-child: 62 / 75 / 59 % of the cycle at hip / knee /
    # ankle, RMS 2.3 / 3.3 / 4.4 deg -- 63 / 70 / 54 %, 2.6 / 3.5 / 4.4 deg with the
    # passive moments counted twice in the child's feedforward; 68 / 77 / 60 %, 2.4 / 3.0
    # / 4.5 deg before the child's stance loop was scaled with their strength, issue 38;
    # on the normative
    # gait's treadmill 50 / 31 / 44 %, 5.1 / 7.3 / 5.7 deg): the 90 % is not
    # reached -- nor by any of the real child's own trials (49-100 / 10-97 / 30-98 %,
    # the last test); bounds as measured here
    from exoleg.validate.cp_child import walk_match

    w = walk_match(strides=12)
    assert w.strides >= 8 and not w.fault
    assert w.pattern == w.real_pattern == "apparent equinus"
    assert w.forefoot_first >= 0.9
    assert np.all(w.rms_deg <= [2.8, 3.8, 4.7]), w.rms_deg
    assert np.all(w.within >= [0.6, 0.65, 0.5]), w.within


def test_the_detector_finds_a_forefoot_first_childs_contacts() -> None:
    # issue 41: the gait-phase detector had never seen a forefoot-first contact. The
    # simulated child walking the real CP child's gait lands forefoot first every stride
    # (above); noise-free, in the loop, the detector's initial contacts and toe offs
    # against the true ones (exoleg.sim.events: the contact forces): none missed, none
    # false, within the 20 ms (measured: median 11 / 13 ms, p95 11 / 13 ms)
    from exoleg.child.model import Spasticity
    from exoleg.child.passive import Contracture
    from exoleg.control.transparency import SupportMode
    from exoleg.reference.cp_child import HEIGHT_M
    from exoleg.sim.metrics import detection_table
    from exoleg.sim.walk import simulate_walk
    from exoleg.sizing import Child, personalized_leg

    c = Child(age=10, sex="male", height=HEIGHT_M, mass=MASS_KG, gmfcs=2, name="cp")
    child = ChildModel("cp", 10, HEIGHT_M, MASS_KG, gmfcs=2, sex="male",
                       contracture=Contracture.preset("predictcpgait"),
                       spasticity=Spasticity.preset("mild"), gait="predictcpgait")
    r = simulate_walk(personalized_leg(c), MASS_KG, strides=12, stride_time=1.025,
                      child=child, support_mode=SupportMode.TRANSPARENT, noise_scale=0.0)
    rows = {row["event"]: row for row in detection_table([r])}
    for event in ("initial contact", "toe off"):
        row = rows[event]
        assert row["true"] >= 10 and row["missed_rate"] == 0 and row["false_rate"] == 0
        assert row["median_abs_error_ms"] <= 20 and row["p95_abs_error_ms"] <= 20, row


def test_the_real_childs_own_trials_spread_about_their_band() -> None:
    # the shipped trials are the ones the shipped mean and SD were taken over (the
    # source's .mat: Qs.mean and Qs.std, the SD with n - 1; rounded to 6 significant
    # digits), and the band the simulated child is judged against (mean +- 1 SD) holds
    # the child's own trials at 49-100 % of the cycle at the hip (from the vertical,
    # each trial's own tilt), 10-97 % at the knee, 30-98 % at the ankle: none of the
    # four meets the 90 % at every joint (measured from the source's .mat with
    # scipy, the same figures)
    from exoleg.validate.cp_child import within_band

    g = cp_child_gait()
    assert g.q_trials.shape == (4, 100, 3) and g.tilt_trials.shape == (4, 100)
    tol = 1e-6 * np.radians(180.0)
    np.testing.assert_allclose(g.q_trials.mean(axis=0), g.q, atol=tol)
    np.testing.assert_allclose(g.q_trials.std(axis=0, ddof=1), g.q_sd, atol=tol)
    np.testing.assert_allclose(g.tilt_trials.mean(axis=0), g.tilt, atol=tol)
    own = within_band(g.q_trials_vertical)
    np.testing.assert_allclose(100 * own, [[77, 97, 98], [100, 10, 30], [80, 69, 66],
                                           [49, 80, 52]])
    assert not np.any(np.all(own >= 0.9, axis=1))
