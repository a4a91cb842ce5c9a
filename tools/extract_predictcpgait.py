"""Extract the sagittal gait of predictcpgait's subject 1 (a child with spastic diplegic
CP; Falisse et al. 2020, Front Hum Neurosci 14:40; repository
antoinefalisse/predictcpgait, commit 93588fe, MIT licence) from its experimental data
(``ExperimentalData_r.mat``: one gait cycle from the right initial contact, 100 samples,
4 trials) into ``src/exoleg/data/child/predictcpgait_subject1_r.csv``: the right hip,
knee and ankle's angles (mean and SD over the trials; each trial's, with its pelvis
tilt), rates and accelerations, inverse-dynamics moments (mean and SD), the pelvis's
tilt and translations with their rates and accelerations, and the right foot's ground
reaction force -- values as the source holds them, rounded to 6 significant digits; with
the subject's OpenSim model (``OpenSimModel/subject1/subject1_MRI.osim``, the model
their inverse dynamics used), also the pelvis's other coordinates, the hip's adduction
and rotation and the subtalar joint (with their moments) and the force's lateral part
into the same file, and the right leg's bodies and joints into
``predictcpgait_subject1_model.toml`` (exoleg's 3D check of their inverse dynamics,
:mod:`exoleg.validate.cp_child`). Needs scipy (a development tool).

    python tools/extract_predictcpgait.py PATH/TO/ExperimentalData_r.mat [PATH/TO/subject1_MRI.osim]
"""

from __future__ import annotations

import sys
import xml.etree.ElementTree as ET
from pathlib import Path

import numpy as np
import scipy.io as sio

OUT = Path(__file__).resolve().parents[1] / "src/exoleg/data/child/predictcpgait_subject1_r.csv"
JOINTS = {"hip": "hip_flex_r", "knee": "knee_flex_r", "ankle": "ankle_flex_r"}
PELVIS = {"pelvis_tilt": "lower_torso_RZ", "pelvis_x": "lower_torso_TX",
          "pelvis_y": "lower_torso_TY"}
# the 3D check's: the pelvis's other coordinates, the hip's other two, the subtalar joint
PELVIS_3D = {"pelvis_list": "lower_torso_RX", "pelvis_rotation": "lower_torso_RY",
             "pelvis_z": "lower_torso_TZ"}
JOINTS_3D = {"hip_adduction": "hip_add_r", "hip_rotation": "hip_rot_r",
             "subtalar": "subt_angle_r"}
MODEL_OUT = OUT.with_name("predictcpgait_subject1_model.toml")
LEG_BODIES = ("femur_r", "tibia_r", "patella_r", "talus_r", "foot_r", "toes_r")
STRIDE_S = 1.025  # KS_Gait_average_r.mot: 100 samples over 0-1.025 s

HEADER = """\
# predictcpgait subject 1's right leg walking: a child with spastic diplegic CP (Falisse et al. 2020,
# Front Hum Neurosci 14:40; repository antoinefalisse/predictcpgait, commit 93588fe, MIT licence:
# LICENSE-predictcpgait.txt), from its ExperimentalData_r.mat by tools/extract_predictcpgait.py.
# One gait cycle from the right initial contact, 100 samples over 0-1.025 s (sample k at k/99 of
# the cycle), mean and SD over 4 trials. OpenSim's coordinates: hip flexion +, knee flexion +,
# ankle dorsiflexion + (deg, deg/s, deg/s^2); pelvis tilt about the lab's z (deg, + anticlockwise
# seen from the right, walking towards +x), pelvis origin x forward and y up (m, m/s, m/s^2);
# inverse-dynamics joint moments (N m, + in the coordinate's + direction); the right foot's ground
# reaction force, fore-aft (+ forward) and vertical, in % body weight (the source's unit: the
# vertical peaks at 120; the model's mass is 33.1 kg). For the 3D check of the inverse
# dynamics (the right leg's model: predictcpgait_subject1_model.toml): the pelvis's list,
# rotation (OpenSim's body-fixed x-y-z sequence with the tilt: about x forward, then y up)
# and sideways place (z, to the right), the hip's adduction and rotation and the subtalar
# angle (deg, OpenSim's + directions) with their moments, and the lateral ground reaction
# force (+ to the right, % body weight). Each of the 4 trials' hip, knee and ankle angles and
# pelvis tilt (deg; hip_trial1 ... pelvis_tilt_trial4).
"""


def _function(el: ET.Element) -> str:
    """An OpenSim function as a TOML inline table."""
    if el.tag in ("function", "coupled_coordinates_function"):
        el = el[0]
    if el.tag == "MultiplierFunction":
        inner = _function(el.find("function"))  # type: ignore[arg-type]
        scale = float(el.findtext("scale", "1"))
        return inner[:-2] + f", scale = {scale!r} }}"
    if el.tag == "LinearFunction":
        a, b = (float(v) for v in el.findtext("coefficients", "").split())
        return f"{{ kind = \"linear\", slope = {a!r}, offset = {b!r} }}"
    if el.tag == "Constant":
        return f"{{ kind = \"constant\", value = {float(el.findtext('value', '')):g} }}"
    xs = ", ".join(repr(float(v)) for v in el.findtext("x", "").split())
    ys = ", ".join(repr(float(v)) for v in el.findtext("y", "").split())
    kind = {"SimmSpline": "spline", "PiecewiseLinearFunction": "linear_pieces"}[el.tag]
    return f"{{ kind = \"{kind}\", x = [{xs}], y = [{ys}] }}"


def _triple(el: ET.Element, tag: str) -> str:
    return "[" + ", ".join(repr(float(v)) for v in el.findtext(tag, "").split()) + "]"


def write_model(osim: str) -> None:
    """The right leg's bodies (mass, centre of mass, inertia) and joints (parent, place,
    the joint frame's orientation in the body, the six transform axes with their
    functions of the coordinates) and the patella's couplers, from the OpenSim model."""
    root = ET.parse(osim).getroot()
    lines = [
        "# predictcpgait subject 1's right leg: the OpenSim model their inverse dynamics used",
        "# (repository antoinefalisse/predictcpgait, commit 93588fe,",
        "# OpenSimModel/subject1/subject1_MRI.osim; MIT licence: LICENSE-predictcpgait.txt),",
        "# extracted unchanged by tools/extract_predictcpgait.py. OpenSim's conventions: metres,",
        "# kilograms, radians; a body's centre of mass and inertia (about it: xx yy zz xy xz yz)",
        "# in its own frame; a joint's place in its parent, its frame's orientation in the",
        "# child (x-y-z body-fixed angles), its transform axes (three rotations, body-fixed in",
        "# order, then three translations in the parent) and their functions of a coordinate.",
        "# The pelvis's frame moves on six coordinates about and along ground's x, y, z.",
        "",
    ]
    bodies = {b.get("name"): b for b in root.iter("Body")}
    for name in LEG_BODIES:
        b = bodies[name]
        j = b.find("Joint")[0]  # type: ignore[index]
        lines += [f"[body.{name}]", f"mass = {float(b.findtext('mass', ''))!r}",
                  f"com = {_triple(b, 'mass_center')}",
                  "inertia = [" + ", ".join(repr(float(b.findtext(f'inertia_{a}', '')))
                                            for a in ("xx", "yy", "zz", "xy", "xz", "yz")) + "]",
                  f"parent = \"{j.findtext('parent_body', '').strip()}\"",
                  f"location_in_parent = {_triple(j, 'location_in_parent')}",
                  f"orientation_in_parent = {_triple(j, 'orientation_in_parent')}",
                  f"location = {_triple(j, 'location')}",
                  f"orientation = {_triple(j, 'orientation')}",
                  "axes = ["]
        for ta in j.find("SpatialTransform"):  # type: ignore[union-attr]
            co = (ta.findtext("coordinates") or "").strip()
            lines.append(f"  {{ name = \"{ta.get('name')}\", coordinate = \"{co}\", axis = "
                         f"{_triple(ta, 'axis')}, function = {_function(ta.find('function'))} }},")  # type: ignore[arg-type]
        lines += ["]", ""]
    for c in root.iter("CoordinateCouplerConstraint"):
        dep = (c.findtext("dependent_coordinate_name") or "").strip()
        if not dep.endswith("_r") and "_r_" not in dep:
            continue
        lines += [f"[coupler.{dep}]",
                  f"coordinate = \"{(c.findtext('independent_coordinate_names') or '').strip()}\"",
                  f"scale = {float(c.findtext('scale_factor', '1'))!r}",
                  f"function = {_function(c.find('coupled_coordinates_function'))}", ""]  # type: ignore[arg-type]
    MODEL_OUT.write_text("\n".join(lines))
    print(f"wrote {MODEL_OUT}")


def main() -> None:
    d = sio.loadmat(sys.argv[1], squeeze_me=True, struct_as_record=False)["ExperimentalData"]
    three_d = len(sys.argv) > 2
    q = d.Q.subject1
    cols = list(q.Qs.colheaders)
    tau = d.Torques.subject1
    grf = d.GRFs.subject1
    gcols = list(grf.colheaders)
    out: dict[str, np.ndarray] = {"sample": np.arange(100.0),
                                  "time_s": np.linspace(0.0, STRIDE_S, 100)}
    joints = {**JOINTS, **JOINTS_3D} if three_d else JOINTS
    for name, c in {**JOINTS, **PELVIS, **(PELVIS_3D | JOINTS_3D if three_d else {})}.items():
        i = cols.index(c)
        out[f"{name}"] = q.Qs.mean[:, i]
        if name in joints:
            out[f"{name}_sd"] = q.Qs.std[:, i]
        out[f"{name}_rate"] = q.Qdots.mean[:, i]
        out[f"{name}_acc"] = q.Qdotdots.mean[:, i]
        if name in joints:
            out[f"{name}_moment"] = tau.mean[:, list(tau.colheaders).index(c)]
            out[f"{name}_moment_sd"] = tau.std[:, list(tau.colheaders).index(c)]
    # each trial's sagittal angles and pelvis tilt: the spread a mean +- SD band leaves
    # the child's own walks
    for name, c in {**JOINTS, "pelvis_tilt": PELVIS["pelvis_tilt"]}.items():
        for k in range(q.Qs.all.shape[2]):
            out[f"{name}_trial{k + 1}"] = q.Qs.all[:, cols.index(c), k]
    out["grf_fore_aft_pct_bw"] = grf.mean[:, gcols.index("Fore-aft-r")]
    out["grf_vertical_pct_bw"] = grf.mean[:, gcols.index("Vertical-r")]
    if three_d:
        out["grf_lateral_pct_bw"] = grf.mean[:, gcols.index("Lateral-r")]
        write_model(sys.argv[2])
    names = list(out)
    lines = [",".join(names)]
    for k in range(100):
        lines.append(",".join(f"{int(out[n][k])}" if n == "sample" else f"{out[n][k]:.6g}"
                              for n in names))
    OUT.write_text(HEADER + "\n".join(lines) + "\n")
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
