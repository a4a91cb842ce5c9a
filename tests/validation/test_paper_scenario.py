"""The paper's section 6 scenario, reproduced figure by figure.

References: paper Figs 13D (detailed vs simplified, 1e-13 deg), 13E (analytic vs
multibody engine, 1e-11 deg), 13F (tracking error ~1e-6 after 3 s), 14
(verification ~1e-16), eq 30 (V non-increasing in continuous time), Table 2
(actuator limits). Tolerances are the measured figures (see the closing note of
issue 3) with the margin stated at each assertion.
"""

import numpy as np
import pytest

import exoleg
from exoleg.sim import scenario
from exoleg.validate.engines import paper_scenario

pytest.importorskip("mujoco", reason="mujoco not installed (pip install exoleg[validate])")


@pytest.fixture(scope="module")
def report():
    """The paper's scenario, run once by the worker that runs this file (at collection
    every worker ran it)."""
    return paper_scenario()


@pytest.fixture(scope="module")
def figs(report):
    return report.figures()


def test_fig13d_detailed_with_doubled_torque_tracks_simplified(figs):
    # Paper: within 1e-13 deg. Measured 1.08e-13 deg: the tables' own rounding (Table 5's
    # detailed Izz is 2x simplified + 1e-15) and the welded composition.
    assert figs["detailed_vs_simplified_max_deg"] < 2e-13


def test_fig13e_analytic_vs_mujoco(figs):
    # Paper: within 1e-11 deg. Measured 1.3e-14 deg.
    assert figs["exoleg_vs_MuJoCo_max_deg"] < 1e-12


def test_fig13f_tracking_error_at_segment_ends(figs):
    # Paper: about 1e-6 after 3 s. Measured <= 7.9e-8 deg at every segment end.
    assert max(figs["tracking_error_at_segment_ends_deg"]) < 1e-6


def test_fig14_verification_signal(figs):
    # Paper: ~1e-16. Measured max 4e-15 W with terms of ~10 W that cancel: relative 3.8e-16.
    assert figs["verification_relative"] < 4 * np.finfo(float).eps
    assert figs["verification_max_abs"] < 1e-13


def test_lyapunov_rise_is_integration_error_of_order_4(report):
    # Eq 30: V is non-increasing in continuous time. It rises only in the first RK4 step
    # after each reference jump, by an amount that shrinks as h^4 (measured 3.2e-4 J,
    # 2.0e-5 J, 1.2e-6 J at h = 1, 0.5, 0.25 ms with V ~ 32 J).
    rises = [paper_scenario(engine=None, dt=h).lyapunov_rise()
             for h in (1e-3, 5e-4)]
    assert rises[0] < 1e-5 * report.result.lyapunov.max()
    assert 3.5 < np.log2(rises[0] / rises[1]) < 4.5


def test_fig15_torques_are_gravity_at_rest(report):
    # Paper Fig. 15: non-zero at rest because of G(q).
    r = report.result
    k = int(np.searchsorted(r.t, 2.99))
    leg = exoleg.paper_leg()
    assert np.allclose(r.u[k], leg.G(r.q[k]), atol=1e-5)
    assert np.all(np.abs(r.u[k]) > 0.1)


def test_peaks_against_table2(figs):
    # Table 2 limits; the paper's postures sequence needs the ankle faster than 300 deg/s
    # (measured 401 deg/s) -- reported, not hidden.
    rows = {row["joint"]: row for row in figs["peaks"]}
    assert rows["hip"]["within_limits"] and rows["knee"]["within_limits"]
    assert rows["ankle"]["speed_deg_s"] > rows["ankle"]["speed_limit_deg_s"]
    assert figs["sampled_stability_h_lambda"] < 2.0


def test_paper_postures_are_normative_gait():
    # Schwartz 2008 free-speed mean at 30 % and 73 % of the cycle (mid-stance, mid-swing).
    stance, swing = scenario.paper_postures()
    assert np.degrees(swing[1]) < -50  # knee flexed in swing
    assert abs(np.degrees(stance[1])) < 20
