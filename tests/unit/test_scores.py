"""The Gait Profile Score (exoleg.reference.scores) against its definition (Baker et al.
2009: a variable's score is the RMS difference from the normative mean over the cycle
every 2 %; the GPS the RMS of the scores), computed here by hand from the shipped data
files read with the csv module -- not through exoleg's readers."""

from __future__ import annotations

import csv
import math
from importlib.resources import files

import numpy as np
import pytest

from exoleg.errors import ParameterError
from exoleg.reference import scores

VARS = ("hip_flexion", "knee_flexion", "ankle_dorsiflexion")


def _normative_by_hand() -> dict[str, list[float]]:
    text = (files("exoleg") / "data" / "gait" / "schwartz2008_sagittal_mean_sd.csv").read_text()
    out: dict[str, list[float]] = {v: [0.0] * 51 for v in VARS}
    for row in csv.DictReader(text.splitlines()):
        if row["speed_group"] == "Free" and row["variable"] in VARS:
            out[row["variable"]][int(float(row["pct_gait_cycle"])) // 2] = float(row["mean"])
    return out


def test_the_normative_gait_scores_zero() -> None:
    mean, sd = scores.normative_cycle("Free")
    gvs, gps = scores.gait_scores(mean)
    assert gps == 0.0 and np.all(gvs == 0.0)
    assert np.all(sd > 0)


def test_the_cp_childs_gps_is_its_definition() -> None:
    """The shipped child with CP (predictcpgait subject 1) against Schwartz 2008 Free."""
    norm = _normative_by_hand()
    text = (files("exoleg") / "data" / "child" / "predictcpgait_subject1_r.csv").read_text()
    rows = list(csv.DictReader(ln for ln in text.splitlines() if not ln.startswith("#")))
    assert len(rows) == 100  # sample k at k/99 of the cycle, onto the 2 % grid linearly
    pct = [100.0 * k / 99 for k in range(100)]
    gvs_hand = []
    for v, col in zip(VARS, ("hip", "knee", "ankle"), strict=True):
        on_grid = np.interp(scores.PERCENT, pct, [float(r[col]) for r in rows])
        sq = [(on_grid[i] - norm[v][i]) ** 2 for i in range(len(on_grid))]
        gvs_hand.append(math.sqrt(sum(sq) / len(sq)))
    gps_hand = math.sqrt(sum(g * g for g in gvs_hand) / 3)
    gvs, gps = scores.gait_scores(scores.cp_child_cycle())
    assert gps == pytest.approx(gps_hand, rel=1e-12)
    assert gvs == pytest.approx(gvs_hand, rel=1e-12)
    # what a clinician sees in it: a crouched knee (38.6 deg at initial contact,
    # predictcpgait's README) dominates; far beyond the 1.6 deg MCID of any change
    assert gvs[1] == max(gvs) and gps > 10 * scores.GPS_MCID_DEG


def test_a_known_offset_scores_its_size() -> None:
    mean, _ = scores.normative_cycle()
    gvs, gps = scores.gait_scores(mean + np.array([0.0, 5.0, 0.0]))
    assert gvs == pytest.approx([0.0, 5.0, 0.0], abs=1e-12)
    assert gps == pytest.approx(5.0 / math.sqrt(3), rel=1e-12)


def test_a_walks_cycle_is_its_strides_mean() -> None:
    """Strides of 1.1 s and 1.0 s of the normative curve, sampled at 1 kHz: the mean
    cycle is the curve (linear interpolation between the samples: within 0.01 deg)."""
    mean, _ = scores.normative_cycle()
    ic = np.array([0.3, 1.4, 2.4, 3.5])
    t = np.arange(0.0, 4.0, 1e-3)
    frac = np.interp(t, ic, np.arange(len(ic)), left=np.nan, right=np.nan) % 1.0
    q = np.stack([np.interp(100 * frac, scores.PERCENT, mean[:, j]) for j in range(3)], 1)
    inside = (t >= ic[0]) & (t <= ic[-1])
    cycle = scores.cycle_of(t[inside], q[inside], ic)
    # (the printed 100 % sample does not close onto the 0 % one; a walk's does: its
    # next initial contact)
    assert np.max(np.abs(cycle[:-1] - mean[:-1])) < 0.01
    assert np.max(np.abs(cycle[-1] - mean[0])) < 0.01
    with pytest.raises(ParameterError, match="a cycle needs two"):
        scores.cycle_of(t, q, [1.0])
    with pytest.raises(ParameterError, match="expected 51 finite samples"):
        scores.gait_scores(mean[:50])


def test_exolegs_angles_in_clinical_degrees() -> None:
    # docs/conventions.md: hip flexion +, knee flexion -, ankle dorsiflexion + (rad)
    assert scores.clinical_degrees([0.1, -0.5, 0.2]) == pytest.approx(
        np.degrees([0.1, 0.5, 0.2]))


def test_sagittal_patterns_follow_sangeux_2015() -> None:
    # Sangeux, Rodda & Graham 2015 (Gait Posture 41:586): mean z-scores of the ankle and
    # the knee over 20-45 % of the cycle against the normative gait, thresholds +-1.
    # Cycles built from the normative mean shifted by whole SDs have scores of exactly
    # those shifts (the definition), and fall in the classes the paper's figure draws
    from exoleg.reference.scores import normative_cycle, sagittal_pattern

    mean, sd = normative_cycle()
    for ankle, knee, want in ((0, 0, "within normal limits"), (-2, 0, "true equinus"),
                              (-2, -2, "true equinus"), (-2, 2, "jump"),
                              (0, 2, "apparent equinus"), (2, 2, "crouch"),
                              (0, -2, "knee recurvatum"), (2, 0, "undetermined")):
        c = mean + sd * np.array([0.0, knee, ankle])
        got, za, zk = sagittal_pattern(c)
        assert got == want and za == pytest.approx(ankle) and zk == pytest.approx(knee)
    # the shipped child with CP (knee 42-49 deg in mid-stance, the ankle within its
    # band): apparent equinus, their scores computed here by hand over 20-44 %
    cyc = scores.cp_child_cycle()
    mid = slice(10, 23)
    pattern, za, zk = sagittal_pattern(cyc)
    assert pattern == "apparent equinus"
    assert zk == pytest.approx(np.mean((cyc[mid, 1] - mean[mid, 1]) / sd[mid, 1]), rel=1e-12)
    assert za == pytest.approx(np.mean((cyc[mid, 2] - mean[mid, 2]) / sd[mid, 2]), rel=1e-12)
