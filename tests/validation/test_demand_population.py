"""Actuator demand and population coverage (issue 4)."""

import numpy as np
import pytest

from exoleg.control import PDGravity
from exoleg.design.demand import actuator_demand, gait_reference
from exoleg.design.population import coverage
from exoleg.reference import SchwartzGait2008
from exoleg.sim.batch import batch_gait_peaks
from exoleg.sim.closed_loop import simulate
from exoleg.sizing import Child, personalized_leg

CHILD = Child(age=9.5, sex="female", height=1.25, mass=24.0, gmfcs=3)
LEG = personalized_leg(CHILD)


def test_paper_per_kg_demand():
    # Paper section 2.2: 30 kg child -> 21 N m / 24 W (hip), 15 / 21 (knee), 36 / 90 (ankle).
    c = Child(age=12, sex="male", height=1.50, mass=30.0)
    d = actuator_demand(c, personalized_leg(c), simulate=False)
    assert np.allclose(d.rows["paper per-kg"][0], [21, 15, 36])
    assert np.allclose(d.rows["paper per-kg"][2], [24, 21, 90])


def test_batch_peaks_equal_the_single_simulator():
    # Reference: exoleg.simulate on the same leg, controller and reference.
    q, dq = gait_reference("Free", 0.0, 1.1)
    peaks = batch_gait_peaks(np.stack([LEG.p, LEG.p]), LEG.g, [80, 80, 50], [12, 12, 2], q, dq,
                             1e-3)
    ref = SchwartzGait2008(stride_time=1.1)
    res = simulate(LEG, PDGravity(LEG), ref, duration=2.2, q0=q[0], dq0=dq[0])
    assert np.allclose(peaks[0, 0], np.abs(res.u[:-1]).max(axis=0), rtol=1e-9)
    assert np.allclose(peaks[0, 1], np.abs(res.dq[:-1]).max(axis=0), rtol=1e-9)
    assert np.array_equal(peaks[0], peaks[1])


def test_margins_are_limit_over_demand():
    d = actuator_demand(CHILD, LEG)
    m = d.margins()["simulated gait"]
    assert np.allclose(m * d.rows["simulated gait"], d.limits)
    margin, src, qty, joint = d.smallest_margin()
    assert margin == pytest.approx(min(np.nanmin(v) for v in d.margins().values()))


def test_coverage_confirms_or_corrects_the_papers_claim():
    rows = coverage(ages=(8.0, 12.0), percentiles=(50.0,), groups=(1, 4), simulate=False)
    by = {(r.group, r.sex, r.age): r for r in rows}
    girl = by[("GMFCS IV", "female", 8.0)]
    boy = by[("GMFCS I", "male", 12.0)]
    # The paper's rule says both fit; at joint-centre level the girl's knee-to-sole
    # length ((0.246 + 0.039) x 109.8 cm = 31.3 cm) is below the 33 cm telescope minimum.
    assert girl.paper_rule_fits and not girl.fits and girl.binding.startswith("lower")
    assert boy.fits


def test_device_limits_are_the_actuators_envelope():
    # Reference: the motor's equations on the sheets' figures (device-datasheets.md): the
    # working torque min(repeated peak, N eta k_t I_lim), the no-load joint speed
    # V / (k_t N), and the envelope's largest power found analytically: along the
    # voltage line tau(w) = N eta k_t (V - k_t N w) / R the power peaks at w = V / (2 k_t N);
    # where the torque cap binds there, at the cap's corner instead.
    import math

    from exoleg.design.demand import device_limits
    from exoleg.device.actuator import paper_actuators

    lim = device_limits()
    for j, a in enumerate(paper_actuators()):
        kt, ke = a.joint_torque_constant, a.torque_constant * a.ratio
        cap = min(a.repeated_peak_torque, kt * a.peak_current)
        w_peak = a.bus_voltage / (2 * ke)
        tau_peak = kt * (a.bus_voltage - ke * w_peak) / a.terminal_resistance
        if tau_peak <= cap:
            power = tau_peak * w_peak
        else:  # the corner: the cap meets the voltage line
            power = cap * (a.bus_voltage - cap / kt * a.terminal_resistance) / ke
        assert lim[0, j] == pytest.approx(cap, rel=1e-12)
        assert lim[1, j] == pytest.approx(a.bus_voltage / ke, rel=1e-12)
        assert lim[2, j] == pytest.approx(power, rel=1e-3)  # 2001 speeds: measured 4e-4
    assert np.allclose(np.degrees(lim[1]), [193, 524, 218], atol=1)  # device-datasheets D
    assert np.allclose(lim[0], [54.0, 30.45, 54.0])
    assert not math.isclose(lim[2, 0], 220.0)  # not Table 2's rated power


def test_the_simulated_gait_demand_is_the_device_s():
    # Reference: exoleg.simulate (the single-leg closed loop, another code path than the
    # batch) on the leg with the actuators' reflected inertia.
    from exoleg.device.actuator import with_actuators

    d = actuator_demand(CHILD, LEG)
    dev = with_actuators(LEG)
    q, dq = gait_reference("Free", 0.0, 1.1)
    res = simulate(dev, PDGravity(dev), SchwartzGait2008(stride_time=1.1), duration=2.2,
                   q0=q[0], dq0=dq[0])
    second = res.t[:-1] >= 1.1 - 1e-12
    assert np.allclose(d.rows["simulated gait"][0], np.abs(res.u[:-1][second]).max(axis=0),
                       rtol=1e-9)


def test_gait_percentiles_rise_with_the_percentile_not_with_the_childs_size():
    """Issue 41: the growth charts' percentile was the gait's too, and a curve of mean +
    z SD at every phase has peaks that fall and rise across z (ankle speed 378 / 320 /
    289 deg/s and hip moment 1.04 / 0.73 / 1.39 N m/kg at P3 / P50 / P97). Reference:
    Schwartz 2008's printed mean and SD (the shipped table), read here by hand."""
    from statistics import NormalDist

    from exoleg.design.demand import schwartz_demand
    from exoleg.reference.gait import schwartz2008
    from exoleg.sizing.child import population_child

    pcts = (3.0, 10.0, 25.0, 50.0, 75.0, 90.0, 97.0)
    zs = [NormalDist().inv_cdf(p / 100) for p in pcts]
    rows = np.array([schwartz_demand(1.0, "Free", z, 1.1) for z in zs])  # per kg
    assert np.all(np.diff(rows, axis=0) > 0)  # every quantity at every joint
    # by hand from the table: the median is the mean curve's peak; P97 the largest of
    # abs(mean) + z SD over the phases
    _, m, sd = schwartz2008("hip_moment_sagittal", "Free")
    assert rows[3, 0, 0] == pytest.approx(np.abs(m).max(), rel=1e-12)
    assert rows[6, 0, 0] == pytest.approx(np.max(np.abs(m) + zs[6] * sd), rel=1e-12)
    # the ankle's speed at P97: the median's, times 1 + z x the excursion's spread (the
    # SDs at the mean's highest and lowest phases, independent)
    _, a, asd = schwartz2008("ankle_dorsiflexion", "Free")
    hi, lo = np.argmax(a), np.argmin(a)
    spread = np.hypot(asd[hi], asd[lo]) / (a[hi] - a[lo])
    assert rows[6, 1, 2] == pytest.approx(rows[3, 1, 2] * (1 + zs[6] * spread), rel=1e-12)
    # the population: a small and a tall 10-year-old girl walk the same gait per kg at
    # the same gait percentile; their simulated gait's ankle speed rises with it
    margins = []
    for gait in (10.0, 50.0, 90.0):
        rows_ = coverage(ages=(10.0,), sexes=("female",), groups=(None,),
                         percentiles=(3.0, 97.0), gait_percentile=gait)
        assert [r.gait_percentile for r in rows_] == [gait, gait]
        margins.append([r.margin for r in rows_])
    assert np.all(np.diff(margins, axis=0) < 0)  # a harder gait leaves less margin
    girl, _ = population_child(None, "female", 10.0, 50.0)
    leg = personalized_leg(girl)
    speeds = [actuator_demand(girl, leg, percentile=p).rows["simulated gait"][1, 2]
              for p in (10.0, 50.0, 90.0)]
    assert speeds[0] < speeds[1] < speeds[2]
    per_kg = [actuator_demand(c, personalized_leg(c), percentile=50.0, simulate=False)
              .rows["Schwartz 2008 Free P50"][0] / c.mass
              for c in (population_child(None, "female", 10.0, p)[0] for p in (3.0, 97.0))]
    assert per_kg[0] == pytest.approx(per_kg[1], rel=1e-12)
