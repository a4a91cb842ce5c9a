"""The shipped real child with CP (issue 41): predictcpgait's subject 1 (Falisse et al.
2020, Front Hum Neurosci 14:40; repository antoinefalisse/predictcpgait, MIT licence), a
child with spastic diplegic CP -- their right leg over one gait cycle
(``data/child/predictcpgait_subject1_r.csv``) in exoleg's angles and signs. Checked by
:mod:`exoleg.validate.cp_child`; walked as a simulated child's intent by
:func:`exoleg.child.model.real_gait`."""

from __future__ import annotations

import csv
import math
from dataclasses import dataclass
from functools import cache
from importlib import resources
from typing import Any

import numpy as np
from numpy.typing import NDArray

from exoleg.params.records import JOINTS

F64 = NDArray[np.float64]

#: the subject's mass (the repository's OpenSim model, the sum of its bodies), kg
MASS_KG = 33.1
#: the height taken for them, m (child-references: a 33 kg child's generic hamstring
#: moment is 0.30x Riener's adults, (1.35-1.40 / 1.75)^5)
HEIGHT_M = 1.375
G = 9.81


@dataclass(frozen=True)
class CPChildGait:
    """The shipped gait in exoleg's angles and signs (q = hip flexion, -knee flexion,
    ankle dorsiflexion; a torque + moves q +): time (s), q, its SD, dq, ddq (rad, rad/s,
    rad/s^2; hip from the pelvis), the joint moments and their SD (N m), the pelvis's
    tilt (rad, + anticlockwise seen from the right) with its rates, its origin's
    acceleration (m/s^2, x forward, y up), and the ground reaction force (N); each
    trial's angles (trials, samples, joint; rad, as ``q``) and pelvis tilt (trials,
    samples; rad): the spread of the child's own walks about the mean."""

    t: F64
    q: F64
    q_sd: F64
    dq: F64
    ddq: F64
    tau: F64
    tau_sd: F64
    tilt: F64
    tilt_rate: F64
    tilt_acc: F64
    pelvis_acc: F64
    grf: F64
    q_trials: F64
    tilt_trials: F64

    @property
    def q_vertical(self) -> F64:
        """``q`` with the hip from the vertical (the pelvis's tilt added): as exoleg's
        upright hip reads it, and as a walk is judged against this gait."""
        return _hip_from_vertical(self.q, self.tilt)

    @property
    def q_trials_vertical(self) -> F64:
        """``q_trials`` with each trial's hip from the vertical (its own tilt added)."""
        return _hip_from_vertical(self.q_trials, self.tilt_trials)


def _hip_from_vertical(q: F64, tilt: F64) -> F64:
    """Angles (..., samples, joint) with the hip's (joint 0) the pelvis's ``tilt``
    (..., samples) added."""
    out = q.copy()
    out[..., 0] += tilt
    return out


@cache
def cp_child_gait() -> CPChildGait:
    """The shipped real CP child's gait (``data/child/predictcpgait_subject1_r.csv``).

    Returns
    -------
    CPChildGait
        100 samples over one cycle from the right initial contact.
    """
    c = _rows()
    sign = np.array([1.0, -1.0, 1.0])  # knee flexion is -q2

    def joints(suffix: str) -> F64:
        return np.stack([c[f"{j}{suffix}"] for j in JOINTS], axis=1) * sign

    rad = math.pi / 180.0
    n = sum(1 for k in c if k.startswith("hip_trial"))
    trials = np.stack([np.stack([c[f"{j}_trial{k}"] for j in JOINTS], axis=1) * sign
                       for k in range(1, n + 1)]) * rad
    return CPChildGait(
        t=c["time_s"], q=joints("") * rad, q_sd=np.abs(joints("_sd")) * rad,
        dq=joints("_rate") * rad, ddq=joints("_acc") * rad, tau=joints("_moment"),
        tau_sd=np.abs(joints("_moment_sd")), tilt=c["pelvis_tilt"] * rad,
        tilt_rate=c["pelvis_tilt_rate"] * rad, tilt_acc=c["pelvis_tilt_acc"] * rad,
        pelvis_acc=np.stack([c["pelvis_x_acc"], c["pelvis_y_acc"]], axis=1),
        grf=np.stack([c["grf_fore_aft_pct_bw"], c["grf_vertical_pct_bw"]], axis=1)
        / 100.0 * MASS_KG * G,
        q_trials=trials,
        tilt_trials=np.stack([c[f"pelvis_tilt_trial{k}"] for k in range(1, n + 1)]) * rad)


#: The shipped columns of the 3D check and the subject's model's coordinates they hold
#: (OpenSim's: degrees and metres as the source has them).
COORDINATES = {"pelvis_list": "lower_torso_RX", "pelvis_rotation": "lower_torso_RY",
               "pelvis_tilt": "lower_torso_RZ", "pelvis_x": "lower_torso_TX",
               "pelvis_y": "lower_torso_TY", "pelvis_z": "lower_torso_TZ",
               "hip": "hip_flex_r", "hip_adduction": "hip_add_r",
               "hip_rotation": "hip_rot_r", "knee": "knee_flex_r", "ankle": "ankle_flex_r",
               "subtalar": "subt_angle_r"}


@dataclass(frozen=True)
class CPChildMotion:
    """The shipped gait as the subject's OpenSim model moves (its 3D check): per model
    coordinate (:data:`COORDINATES`' values) its value, rate and acceleration over the
    cycle (rad or m, and per s, s^2: OpenSim's signs), the inverse-dynamics moments of
    the leg's six (N m, + in the coordinate's + direction), and the right foot's ground
    reaction force (100, 3) N in the lab's x forward, y up, z to the right."""

    q: dict[str, F64]
    dq: dict[str, F64]
    ddq: dict[str, F64]
    moment: dict[str, F64]
    grf: F64


def _rows() -> dict[str, F64]:
    text = resources.files("exoleg").joinpath(
        "data", "child", "predictcpgait_subject1_r.csv").read_text()
    rows = list(csv.DictReader(ln for ln in text.splitlines() if not ln.startswith("#")))
    return {k: np.array([float(r[k]) for r in rows]) for k in rows[0]}


@cache
def cp_child_motion() -> CPChildMotion:
    """The shipped gait's every model coordinate (``predictcpgait_subject1_r.csv``)."""
    c = _rows()
    q, dq, ddq, moment = {}, {}, {}, {}
    for col, name in COORDINATES.items():
        unit = 1.0 if name[-2:] in ("TX", "TY", "TZ") else math.pi / 180.0
        q[name], dq[name] = c[col] * unit, c[f"{col}_rate"] * unit
        ddq[name] = c[f"{col}_acc"] * unit
        if f"{col}_moment" in c:
            moment[name] = c[f"{col}_moment"]
    grf = np.stack([c["grf_fore_aft_pct_bw"], c["grf_vertical_pct_bw"],
                    c["grf_lateral_pct_bw"]], axis=1) / 100.0 * MASS_KG * G
    return CPChildMotion(q, dq, ddq, moment, grf)


@cache
def cp_child_model() -> dict[str, Any]:
    """The subject's right leg as their OpenSim model holds it
    (``data/child/predictcpgait_subject1_model.toml``: bodies, joints, the patella's
    couplers; OpenSim's units and frames, the file's header)."""
    import tomllib

    text = resources.files("exoleg").joinpath(
        "data", "child", "predictcpgait_subject1_model.toml").read_text()
    return tomllib.loads(text)


def toe_off_fraction() -> float:
    """The fraction of the cycle at which the shipped child's foot leaves the ground:
    the first sample after their stance whose vertical ground reaction force is below
    1 % of their body weight."""
    g = cp_child_gait()
    off = np.nonzero(g.grf[:, 1] < 0.01 * MASS_KG * G)[0]
    return float(off[0] / (len(g.t) - 1))


__all__ = ["COORDINATES", "CPChildGait", "CPChildMotion", "HEIGHT_M", "MASS_KG", "cp_child_gait",
           "cp_child_model", "cp_child_motion", "toe_off_fraction"]
