"""Extract the sagittal gait of predictcpgait's subject 1 (a child with spastic diplegic
CP; Falisse et al. 2020, Front Hum Neurosci 14:40; repository antoinefalisse/predictcpgait,
commit 93588fe, MIT licence) from its experimental data (``ExperimentalData_r.mat``: one
gait cycle from the right initial contact, 100 samples, 4 trials) into
``src/exoleg/data/child/predictcpgait_subject1_r.csv``: the right hip, knee and ankle's
angles (mean and SD over the trials), rates and accelerations, inverse-dynamics moments
(mean and SD), the pelvis's tilt and translations with their rates and accelerations,
and the right foot's ground reaction force -- values as the source holds them, rounded to
6 significant digits. Needs scipy (a development tool).

    python tools/extract_predictcpgait.py PATH/TO/ExperimentalData_r.mat
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import scipy.io as sio

OUT = Path(__file__).resolve().parents[1] / "src/exoleg/data/child/predictcpgait_subject1_r.csv"
JOINTS = {"hip": "hip_flex_r", "knee": "knee_flex_r", "ankle": "ankle_flex_r"}
PELVIS = {"pelvis_tilt": "lower_torso_RZ", "pelvis_x": "lower_torso_TX",
          "pelvis_y": "lower_torso_TY"}
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
# vertical peaks at 120; the model's mass is 33.1 kg).
"""


def main() -> None:
    d = sio.loadmat(sys.argv[1], squeeze_me=True, struct_as_record=False)["ExperimentalData"]
    q = d.Q.subject1
    cols = list(q.Qs.colheaders)
    tau = d.Torques.subject1
    grf = d.GRFs.subject1
    gcols = list(grf.colheaders)
    out: dict[str, np.ndarray] = {"sample": np.arange(100.0),
                                  "time_s": np.linspace(0.0, STRIDE_S, 100)}
    for name, c in {**JOINTS, **PELVIS}.items():
        i = cols.index(c)
        out[f"{name}"] = q.Qs.mean[:, i]
        if name in JOINTS:
            out[f"{name}_sd"] = q.Qs.std[:, i]
        out[f"{name}_rate"] = q.Qdots.mean[:, i]
        out[f"{name}_acc"] = q.Qdotdots.mean[:, i]
        if name in JOINTS:
            out[f"{name}_moment"] = tau.mean[:, list(tau.colheaders).index(c)]
            out[f"{name}_moment_sd"] = tau.std[:, list(tau.colheaders).index(c)]
    out["grf_fore_aft_pct_bw"] = grf.mean[:, gcols.index("Fore-aft-r")]
    out["grf_vertical_pct_bw"] = grf.mean[:, gcols.index("Vertical-r")]
    names = list(out)
    lines = [",".join(names)]
    for k in range(100):
        lines.append(",".join(f"{int(out[n][k])}" if n == "sample" else f"{out[n][k]:.6g}"
                              for n in names))
    OUT.write_text(HEADER + "\n".join(lines) + "\n")
    print(f"wrote {OUT}")


if __name__ == "__main__":
    main()
