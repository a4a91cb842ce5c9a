"""The child as an actor: passive moments against Riener & Edrich's printed formula and the
predictcpgait child's curves, the height^5 law, the child file, the intended crouch gait,
standing on the unpowered device, and the cuffs' torque against the device's statics."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import exoleg
from conftest import REALTIME
from exoleg.child.curves import SIGNATURES, curve_signatures, falisse_curves, signatures
from exoleg.child.interaction import device_leg
from exoleg.child.model import ChildModel, Spasticity, crouch_offset, intended_gait
from exoleg.child.passive import Contracture, passive_moments, passive_record
from exoleg.errors import ParameterError, SimulationError


def riener_printed(pa: float, pk: float, ph: float) -> tuple[float, float, float]:
    """Riener & Edrich 1999, eqs (1)-(3), typed from the paper (child-references.md)."""
    mh = (math.exp(1.4655 - 0.0034 * pk - 0.0750 * ph)
          - math.exp(1.3403 - 0.0226 * pk + 0.0305 * ph) + 8.072)
    mk = (math.exp(1.800 - 0.0460 * pa - 0.0352 * pk + 0.0217 * ph)
          - math.exp(-3.971 - 0.0004 * pa + 0.0495 * pk - 0.0128 * ph) - 4.820
          + math.exp(2.220 - 0.150 * pk))
    ma = (math.exp(2.1016 - 0.0843 * pa - 0.0176 * pk)
          - math.exp(-7.9763 + 0.1949 * pa + 0.0008 * pk) - 1.792)
    return mh, mk, ma


def test_the_adults_moments_are_riener_and_edrichs_formula_made_conservative() -> None:
    # reference: the printed equations on a 9 x 11 x 12 grid of their checked range; at
    # the reference height (1.75 m) the scale is 1, and exoleg's signs are Riener's
    # converted (hip as is, knee and ankle negated). The shipped terms are the printed
    # ones refitted as a conservative field (tools/fit_passive_potential.py); bounds: the
    # fit's residuals as measured (data/child/passive.toml), rounded up
    A, K, H = np.linspace(-30, 30, 9), np.linspace(0, 100, 11), np.linspace(-20, 90, 12)
    ph = np.stack(np.meshgrid(A, K, H, indexing="ij"), -1).reshape(-1, 3)
    want = np.array([riener_printed(*p) for p in ph]) * [1, -1, -1]
    got = passive_moments(passive_record(1.75), np.radians(ph[:, ::-1] * [1, -1, -1]))
    e = got - want
    walking = (np.abs(ph[:, 0]) <= 20) & (ph[:, 1] <= 70) & (ph[:, 2] <= 50)
    rms = np.sqrt(np.mean(e[walking] ** 2, axis=0))
    assert np.all(rms <= [0.5, 0.9, 1.4]), rms
    assert np.all(np.abs(e[walking]).max(axis=0) <= [2.8, 3.8, 8.5])
    assert np.all(np.sqrt(np.mean(e ** 2, axis=0)) <= [1.4, 4.6, 3.1])


@pytest.mark.parametrize("preset,level", [("none", 0.0), ("predictcpgait", 0.5),
                                          ("predictcpgait", 1.0), ("predictcpgait", 1.5)])
def test_the_passive_field_is_conservative(preset: str, level: float) -> None:
    # Issue 41: the printed field's cross stiffnesses differed (dtau_hip/dq_knee -6.4
    # against dtau_knee/dq_hip -2.8 N m/rad; -114 against -35 with the contracture): the
    # moments added or took energy around a loop. Reference: a gradient field's
    # stiffness matrix is symmetric (central differences at 100 random postures, in and
    # beyond the checked range), and the work around a closed loop of postures is zero.
    P = passive_record(1.375, Contracture.preset(preset, level) if level else None)
    rng = np.random.default_rng(41)
    worst = 0.0
    for _ in range(100):
        q = np.radians([rng.uniform(-30, 100), -rng.uniform(-5, 110), rng.uniform(-40, 40)])
        k = np.empty((3, 3))
        for c in range(3):
            dq = np.zeros(3)
            dq[c] = 1e-6
            k[:, c] = (passive_moments(P, q + dq) - passive_moments(P, q - dq)) / 2e-6
        worst = max(worst, float(np.abs(k - k.T).max() / np.abs(k).max()))
    assert worst < 1e-6  # the issue's bound: 5 %
    # the work of the passive moments around a loop through hip, knee and ankle
    s = np.linspace(0.0, 2 * np.pi, 20001)
    loop = np.radians(np.stack([30 + 40 * np.cos(s), -50 + 40 * np.sin(s),
                                10 * np.sin(2 * s)], axis=1))
    tau = passive_moments(P, loop)
    work = np.sum(0.5 * (tau[1:] + tau[:-1]) * np.diff(loop, axis=0))
    assert abs(work) < 1e-6 * np.sum(np.abs(tau[1:] * np.diff(loop, axis=0)))


@given(st.floats(1.0, 1.6), st.floats(1.0, 1.6))
@settings(max_examples=50, deadline=None)
def test_passive_stiffness_scales_with_height5_so_the_natural_frequency_does_not(
        h1: float, h2: float) -> None:
    # Lebiedowska & Fisk 1999: stiffness and inertia both ~ height^5, the natural
    # frequency independent of height. A geometrically similar leg (mass ~ h^3, lengths
    # ~ h) has inertia ~ h^5; the passive knee stiffness must scale the same way.
    q = np.radians([0.0, -40.0, 0.0])
    dq = np.radians([0.0, -1e-3, 0.0])

    def stiffness(h: float) -> float:
        P = passive_record(h)
        return float((passive_moments(P, q + dq)[1] - passive_moments(P, q - dq)[1])
                     / (2 * dq[1]))

    k1, k2 = stiffness(h1), stiffness(h2)
    assert k1 / k2 == pytest.approx((h1 / h2) ** 5, rel=1e-9)
    inertia1, inertia2 = h1 ** 3 * h1 ** 2, h2 ** 3 * h2 ** 2
    assert math.sqrt(abs(k1) / inertia1) == pytest.approx(math.sqrt(abs(k2) / inertia2),
                                                          rel=1e-9)


def test_the_predictcpgait_childs_contracture_signatures() -> None:
    # reference: the shipped curves of Falisse et al. 2020's child (read off the CSV);
    # tolerance: the issue's +-3 deg / +-15 % (measured: worst 13.4 % on the
    # plantarflexors' moment at 0 deg, knee 0: 8.8 against 10.2 N m; the knee's moment
    # at hip 90, knee 0: 98.4 against 88.1 N m, 11.7 %)
    want = curve_signatures("personalized")
    got = signatures(passive_record(1.375, Contracture.preset("predictcpgait")))
    for name, w, g in zip(SIGNATURES, want, got, strict=True):
        if "deg" in name.split(",")[-1] or name.endswith("(deg)"):
            assert abs(g - w) <= 3.0, (name, g, w)
        else:
            assert abs(g - w) <= 0.15 * abs(w), (name, g, w)


def test_the_contracture_holds_off_its_fitted_curves() -> None:
    # Issue 41: the preset met its curves (the hip swept with the knee straight) with
    # constants of 79 / -17 / -62 N m that gave the hip, with the knee flexed 40-90 deg,
    # a 16-29 N m flexing moment over all of -20..90 deg and no resting point. Reference:
    # a relaxed limb has a passive resting posture (Riener & Edrich's adults: the hip's
    # moment crosses zero with the knee flexed 40-90 deg, as the scaled model here does),
    # and the moment restores towards it (falls through zero as the hip flexes)
    hips = np.radians(np.arange(-20.0, 90.5, 0.5))
    for P in (passive_record(1.375), passive_record(1.375, Contracture.preset("predictcpgait"))):
        for knee in (40.0, 60.0, 90.0):
            q = np.stack([hips, np.full_like(hips, -np.radians(knee)), np.zeros_like(hips)], 1)
            m = passive_moments(P, q)[:, 0]
            cross = np.nonzero(np.diff(np.sign(m)))[0]
            assert len(cross) == 1, (knee, cross)
            assert m[cross[0]] > 0 > m[cross[0] + 1]  # restoring
    # the preset's contracture constants within 2.5x Riener & Edrich's largest (8.07 N m)
    assert np.all(np.abs(Contracture.preset("predictcpgait").constant) <= 20.0)


def test_contracture_shortens_muscles_not_the_joint_limit() -> None:
    none = passive_record(1.375)
    cp = passive_record(1.375, Contracture.preset("predictcpgait"))
    limit = 4  # the knee's extension-limit term of data/child/passive.toml
    assert np.array_equal(none["coef"][0, limit], cp["coef"][0, limit])
    # and the curves it was fitted to are met on the whole (RMS measured 3.1 N m)
    c = falisse_curves()
    c = c[c.params == "personalized"]
    m = passive_moments(cp, c.q)[np.arange(len(c.moment)), c.joint]
    assert float(np.sqrt(np.mean((m - c.moment) ** 2))) < 3.5


def test_crouch_intention_meets_the_clusters_within_one_sd() -> None:
    # reference: Rozumalski & Schwartz 2009, knee flexion at initial contact (mean, SD)
    ic = [(28.9, 7.0), (30.6, 7.8), (31.8, 8.2), (41.7, 10.7), (47.3, 11.9)]
    mins = [5.1, 18.7, 17.4, 24.5, 43.2]
    for cluster in range(1, 6):
        ch = ChildModel.typical("c", 10, 1.4, 32).with_(crouch=cluster)
        q, _, _ = intended_gait(ch, 1.1)
        knee = -np.degrees(q[:, 1])
        assert abs(knee[0] - ic[cluster - 1][0]) <= ic[cluster - 1][1]
        assert abs(knee[:55].min() - mins[cluster - 1]) <= ic[cluster - 1][1]
    # no crouch at the swing's peak (72 %): the clusters' peak swing is near normal
    assert all(abs(crouch_offset(c, np.array([0.72]))[0]) < 3.0 for c in range(1, 6))


def test_child_file_round_trip_and_bad_files(tmp_path) -> None:  # type: ignore[no-untyped-def]
    ch = ChildModel("a", 9.5, 1.32, 27.0, 2, Contracture.preset("predictcpgait", 0.5),
                    Spasticity.preset("moderate"), True, 3, "male", 0.8)
    ch.save(tmp_path / "child.toml")
    back = ChildModel.load(tmp_path / "child.toml")
    assert back == ch
    bad = {"gmfcs = 2": "gmfcs = 7", 'level = "moderate"': 'level = "extreme"',
           "crouch = 3": "crouch = 9", "height_m = 1.32": "height_m = 13.2",
           "strength = 0.8": "strength = 3",
           # a blank or numeric name was taken as the child's (the fit refuses it blank)
           'name = "a"': 'name = " "'}
    for old, new in bad.items():
        (tmp_path / "bad.toml").write_text((tmp_path / "child.toml").read_text()
                                           .replace(old, new))
        with pytest.raises(ParameterError) as e:
            ChildModel.load(tmp_path / "bad.toml")
        assert "bad.toml" in str(e.value)
    (tmp_path / "bad.toml").write_text((tmp_path / "child.toml").read_text()
                                       .replace('name = "a"', "name = 7"))
    with pytest.raises(ParameterError, match="bad.toml: name: 7: the child's name as text"):
        ChildModel.load(tmp_path / "bad.toml")
    # a contracture's level is checked with no contracture too (it was ignored: -1 or
    # nan read as a child without one)
    ChildModel("b", 9.5, 1.32, 27.0, 2).save(tmp_path / "none.toml")
    # ... and a level that is not a number named as the file's field ("x" said only
    # "(value): could not convert string to float"; true read as 1)
    for level, match in (("-1", "level: -1 is outside 0-1.5"), ("nan", "level: must be"),
                         ('"x"', "contracture_level: expected a number, got 'x'"),
                         ("true", "contracture_level: expected a number, got True")):
        (tmp_path / "bad.toml").write_text((tmp_path / "none.toml").read_text().replace(
            "contracture_level = 0 ", f"contracture_level = {level} "))
        with pytest.raises(ParameterError, match=f"bad.toml.*{match}"):
            ChildModel.load(tmp_path / "bad.toml")
    (tmp_path / "bin.toml").write_bytes(b"\x00\x01\xff")
    with pytest.raises(ParameterError):
        ChildModel.load(tmp_path / "bin.toml")


@pytest.fixture(scope="module")
def fitted_leg() -> exoleg.LegModel:
    from exoleg.sizing import Child
    from exoleg.sizing.personal import personalized_leg

    return personalized_leg(Child(age=10, sex="male", height=1.40, mass=32.0))


@pytest.mark.parametrize("gmfcs,level", [(0, "none"), (2, "mild")])
def test_a_child_stands_on_the_unpowered_device_for_a_minute(fitted_leg, gmfcs, level
                                                              ) -> None:  # type: ignore[no-untyped-def]
    from exoleg.sim.walk import simulate_walk

    ch = ChildModel("c", 10, 1.40, 32.0, gmfcs, spasticity=Spasticity.preset(level))
    n = 60_000
    r = simulate_walk(fitted_leg, 32.0, strides=1, standing=60.0 - 1.1, child=ch,
                      commands=np.zeros(n + 1, dtype=np.int64))
    assert r.fault.max() == 0
    # the knee stays within 3 deg of the standing posture (measured: 0.1-0.3 deg)
    assert abs(np.degrees(r.q[-1, 1] - r.q[0, 1])) < 3.0
    # the pelvis settles (measured 1.7-1.8 cm) onto the other leg's support, not further
    assert r.pelvis[-1] > r.pelvis[1000] - 0.03


def test_without_the_child_the_unpowered_leg_folds(fitted_leg) -> None:  # type: ignore[no-untyped-def]
    # the same minute with a passive rigid leg: the knee folds (measured -28.8 deg)
    from exoleg.sim.walk import simulate_walk

    n = 60_000
    r = simulate_walk(fitted_leg, 32.0, strides=1, standing=60.0 - 1.1,
                      commands=np.zeros(n + 1, dtype=np.int64))
    assert abs(np.degrees(r.q[-1, 1] - r.q[0, 1])) > 10.0


def test_the_cuffs_carry_the_device_at_rest(fitted_leg) -> None:  # type: ignore[no-untyped-def]
    # reference: statics. Unpowered and near still, the cuffs hold the device's own
    # links: tau_int = -G_device(q) - friction(dq) (the device alone's gravity through
    # LegModel's general path; the drives' friction at the residual creep)
    from exoleg.device.actuator import paper_actuators, params_array
    from exoleg.device.drive import friction
    from exoleg.sim.walk import simulate_walk

    ch = ChildModel("c", 10, 1.40, 32.0)
    n = 3000
    r = simulate_walk(fitted_leg, 32.0, strides=1, standing=3.0 - 1.1, child=ch,
                      commands=np.zeros(n + 1, dtype=np.int64))
    dev = device_leg(fitted_leg, paper_actuators())
    k = -10
    A = params_array(paper_actuators())
    want = -np.asarray(dev.G(r.q[k])) - [friction(A[i:i + 1], r.dq[k, i]) for i in range(3)]
    # tolerance: the tick's mean accelerations and midpoint posture (measured 1.5e-3 N m)
    assert r.interaction[k] == pytest.approx(want, abs=0.02)
    assert np.abs(want).max() > 1.0


def test_the_pendulum_test_meets_white_2007_for_a_typical_and_a_spastic_child() -> None:
    # reference: White et al. 2007 (10 TD, 10 CP, mean 13 y): peak knee velocity 293 vs
    # 202 deg/s, time to peak 0.34 vs 0.22 s; the issue's +-15 %. Measured on a 13 y,
    # 1.56 m, 45 kg child: TD 306 deg/s at 0.290 s; moderate spasticity 182 at 0.210 s
    import warnings

    from exoleg.child.assess import pendulum, stretch

    td = ChildModel.typical("td", 13, 1.56, 45.0, "male")
    moderate = td.with_(gmfcs=2, spasticity=Spasticity.preset("moderate"))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        typical = pendulum(td)
        spastic = pendulum(moderate)
    for p, (v, t) in ((typical, (293, 0.34)), (spastic, (202, 0.22))):
        assert abs(p.peak_velocity - v) <= 0.15 * v
        assert abs(p.time_to_peak - t) <= 0.15 * t
    # Bajd & Vodovnik's relaxation index: >= 1.6 typical, below spastic
    assert typical.relaxation_index >= 1.6 > spastic.relaxation_index
    assert spastic.first_swing < typical.first_swing
    # spasticity, not hypertonia: the knee flexors resist a fast stretch more than a
    # slow one (issue 41: 20.7 against 20.3 N m before the velocity reflex; its bound
    # 1.5x; measured 1.66x), the typical child's by their tissue's damping alone
    # (measured 1.08x)
    fast = stretch(moderate, speeds=(5.0, 180.0)).peak_resistance
    assert fast[1] >= 1.5 * fast[0]
    calm = stretch(td, speeds=(5.0, 180.0)).peak_resistance
    assert calm[1] <= 1.1 * calm[0]
    # a knee whose range ends before the stretch starts has nothing to stretch: said,
    # not a peak of one sample
    tight = td.with_(contracture=Contracture("tight hamstrings", {
        "knee_flexors": (5.0, 1.0, 1.0), "hip_extensors": (5.0, 1.0, 1.0)}))
    with pytest.raises(SimulationError, match="resist .* N m at 90 deg flexion already"):
        stretch(tight)


def test_assess_writes_the_summary_the_issue_names(tmp_path) -> None:  # type: ignore[no-untyped-def]
    import json

    from exoleg.cli import main

    ch = ChildModel("a", 10, 1.40, 32.0, 2, spasticity=Spasticity.preset("moderate"),
                    sex="male")
    ch.save(tmp_path / "child.toml")
    assert main(["assess", "--child", str(tmp_path / "child.toml"), "--test", "pendulum",
                 "--out", str(tmp_path / "p")]) == 0
    s = json.loads((tmp_path / "p" / "summary.json").read_text())
    for k in ("peak_knee_velocity_deg_s", "time_to_peak_s", "first_swing_deg",
              "relaxation_index"):
        assert math.isfinite(s[k])
    assert (tmp_path / "p" / "pendulum.png").stat().st_size > 10_000
    assert main(["assess", "--child", str(tmp_path / "child.toml"), "--test", "stretch",
                 "--out", str(tmp_path / "s")]) == 0
    s = json.loads((tmp_path / "s" / "summary.json").read_text())
    assert len(s["peak_resistance_Nm"]) == len(s["speeds_deg_s"]) == 6
    assert "catch_angle_deg" in s


def test_the_child_leaves_the_device_the_body_weight_it_holds(fitted_leg) -> None:  # type: ignore[no-untyped-def]
    # Slacking (Emken et al. 2007): with the device holding the body at the centre of
    # pressure (stance support 1, the shipped gains) the child's stance feedforward is
    # none of the normative moments; with support 0 the child's own ankle carries the
    # body (Schwartz 2008's stance ankle moment, about 1 N m/kg at push-off). Measured,
    # the child's mean ankle torque over stance, walks 3-6: support 1: -3.8 N m, support
    # 0: -11.8 N m (plantarflexing); both walks go on without a fault.
    import dataclasses

    from exoleg.control.hierarchy import WalkGains
    from exoleg.sim.walk import simulate_walk

    ch = ChildModel.typical("c", 10, 1.4, 32.0, "male")
    mean = {}
    for support in (1.0, 0.0):
        gains = dataclasses.replace(WalkGains.default(), support=support)
        r = simulate_walk(fitted_leg, 32.0, strides=6, child=ch, gains=gains)
        assert not np.any(r.fault >= 1)
        stance = (r.contact_force.sum(axis=1) > 20.0) & (r.t > r.walk_start + 2 * 1.1)
        mean[support] = float(r.child_torque[stance, 2].mean())
    assert mean[0.0] < -8.0 and mean[1.0] > -6.0, mean


def test_with_the_child_every_walk_goes_on_and_foot_flat_and_heel_off_are_seen() -> None:
    # the children of `exoleg validate --gait-phase` (design range, TD), each an actor,
    # 20 strides at sensor noise x0, x1, x3. Before the child model the detector saw foot
    # flat and heel off in 1 and 2 of 5 strides and 6 of the 9 walks were stopped by the
    # safety layer; the issue asks >= 95 % of strides. Measured on the rolling sole and
    # the upright gait: 100 % and 100 %, no fault; initial contact and toe off none
    # missed, none false (on four hard points 98.7 % and 96.9 %, initial contact missed
    # 1.2 % and false 2.4 %: toes scuffing the belt in swing, which the drive, braking,
    # now stops)
    from exoleg.validate.gait_phase import evaluate

    v = evaluate(strides=20)
    rows, runs, faults = v.rows, v.runs, v.faults
    assert not any(r.fault for r in runs)
    # the replay (exoleg detect's detector over the walks' own readings, a fresh state)
    # gives the closed loop's events exactly
    from exoleg.validate.gait_phase import CHILDREN, FAULTS, NOISE, SOURCES

    assert faults[next(iter(FAULTS))] == rows
    by = {r["event"]: r for r in rows}
    for event in ("foot flat", "heel off"):
        assert by[event]["in_strides"] >= 0.95, by[event]
    for event in ("initial contact", "toe off"):
        assert by[event]["missed_rate"] <= 0.03 and by[event]["false_rate"] <= 0.03
    # issue 24's goal for the FSRs and the foot's IMU together: initial contact and toe off
    # median |error| <= 20 ms, p95 <= 40 ms, missed + extra <= 1 % of the true events --
    # on these walks, with each single-sensor fault the FSRs can lose and the IMU cover
    # (drift, a preloaded, failed hallux or failed heel sensor) replayed over the walks and
    # injected into them (the controller walking on the faulted readings), at 2 and 4 s
    # strides and for the harder walkers (crouch, contracture, weak, a controlled stop,
    # walking again).
    # Measured: initial contact 8 / 8 ms (the heel's sensor failed: 0 / 1, the strike);
    # toe off at most 14 / 21 ms; none missed, none extra. The IMU alone in the loop (the
    # FSRs failed or reading zeros): 0 / 1 and 3 / 6 ms -- 32 / 41 ms before its stance
    # model ended as the push-off's turn passes unload_turn. Not met, and so not asserted
    # for the toe off: the single sources replayed over walks the other source led (docs:
    # the FSRs cannot see the toes' tips). The IMU alone at slow strides is asserted below
    # against the published foot-off bound.
    sensor = ("none", "every", "first", "hallux", "heel")
    tables = [faults[c] for c in FAULTS if c.startswith(sensor)]
    tables += [v.closed[c] for c in v.closed if c.startswith((*sensor, "FSRs"))]
    tables += [t[SOURCES[0]] for t in (*v.slow_sources.values(), *v.worst.values())]
    assert not any(v.closed_stopped.values()), v.closed_stopped
    # each source alone: the initial contact (the IMU's at the strike: 0-1 ms; before it
    # took the strike, the IMU alone's contact in the closed loop was 105 ms off, 31 toe
    # offs of 60 missed)
    contact = [faults[c] for c in SOURCES[1:]] + [v.closed[c] for c in SOURCES[1:]]
    contact += [t[c] for t in v.worst.values() for c in SOURCES[1:]]
    # a sensor preloaded while the gyroscope has failed: every contact is found, and the
    # first swing, before the sensor's offset is known, is not seen -- one toe off a walk
    # missed, none extra. Before the held sensor's landing rule the stance latched: all
    # missed replayed, 3 contacts in 20 strides in the loop; before a load beside the held
    # sensor had to last the debounce to end its swing, noise on an unloaded sensor at 3x
    # the datasheet's restarted its wait, and a walk's first landing went unseen in 4 of 18
    # walks at 3x (seeds 10-15, the walks starting at rest: reference.gait.START_RAMP)
    held = "preloaded metatarsal, gyroscope failed"
    contact += [faults[held], v.closed[held]]
    for table, walks in ((faults[held], len(CHILDREN) * len(NOISE)),
                         (v.closed[held], len(CHILDREN))):
        by_event = {r["event"]: r for r in table}
        to, ic = by_event["toe off"], by_event["initial contact"]
        assert to["missed"] <= walks and to["false"] == 0, to
        assert ic["missed"] == 0 and ic["false"] == 0, ic
    checked = [(r, ("initial contact", "toe off")) for table in tables for r in table]
    checked += [(r, ("initial contact",)) for table in contact for r in table]
    for r, events in checked:
        if r["event"] in events:
            assert r["median_abs_error_ms"] <= 20.0 and r["p95_abs_error_ms"] <= 40.0, r
            assert r["missed"] + r["false"] <= 0.01 * r["true"], r
    # the IMU alone at slow strides (the FSRs failed): its toe off within Catalfamo et al.
    # 2010's foot-off bound (< 75 ms), none missed. Measured: 11 / 14 ms (median / p95)
    # at 2 s, 47 / 59 ms at 4 s -- it said toe off at the heel's rise, 81 / 89 and 180 /
    # 197 ms early, 3 of 63 missed at 4 s, before the slow strides' rule
    # (gait_phase.toml imu_toe_eased)
    for stride, by_source in v.slow_sources.items():
        to = next(r for r in by_source[SOURCES[2]] if r["event"] == "toe off")
        assert to["p95_abs_error_ms"] < 75.0 and to["missed"] + to["false"] == 0, (stride, to)


def test_a_child_whose_foot_lands_behind_the_hip_walks_on() -> None:
    # A foot that lands behind the hip is no strike (it may be a toe scuffing the belt);
    # a child whose cycle ran out with the foot down that way waited for a strike that
    # could not come: the GMFCS III girl below, under a transparent law that does her
    # badly, stood still on the moving belt from her sixth stride to the walk's end -- her
    # knee within 0.1 deg over each of the last five strides, the mode still WALKING, and
    # the walk's residual counting those strides as transparent ones (0.002-0.015 N m/kg
    # a stride). A child takes a foot that is down when their swing has ended as their
    # stance: every stride she walks on (measured: the knee's range 50-60 deg each
    # stride; before, 0.0-0.1 from the sixth), as every walk the suite's children walk
    # already did (their own strikes; unchanged)
    import dataclasses

    from exoleg.child.model import ChildModel
    from exoleg.control.transparency import SupportMode, TransparencySettings
    from exoleg.sim.walk import simulate_walk
    from exoleg.sizing import personalized_leg
    from exoleg.sizing.child import population_child
    from exoleg.tick import Mode

    c, _ = population_child(3, "female", 10.0, 50.0)
    law = dataclasses.replace(TransparencySettings.default(),
                              inertia_share=np.array([0.5, 0.9, 0.15]),
                              kp=np.array([3.0, 3.0, 1.0]), accel_filter_hz=np.full(3, 250.0))
    r = simulate_walk(personalized_leg(c), c.mass, strides=10,
                      child=ChildModel.of(c, spasticity="moderate"), seed=0,
                      support_mode=SupportMode.TRANSPARENT, transparency=law)
    assert np.all(r.mode[r.t >= r.walk_start] == Mode.WALKING)
    n = int(round(r.stride_time / 1e-3))
    k0 = int(np.argmax(r.t >= r.walk_start))
    knee = [np.degrees(np.ptp(r.q[k0 + s * n:k0 + (s + 1) * n, 1])) for s in range(10)]
    assert min(knee) > 40.0, np.round(knee, 1)


def test_with_both_feets_fsrs_no_contact_or_toe_off_is_missed_or_added() -> None:
    # issue 41's goal: with the unassisted foot's insole fitted, missed + extra initial
    # contacts and toe offs <= 1 % of the true ones on every walk and fault case of
    # `exoleg validate --gait-phase --other-foot` (reference: the walks' true contacts).
    # Measured: none, in every table -- the walks, each fault replayed and injected, the
    # single sources at 2 and 4 s strides and for the harder walkers. Before the IMU
    # alone's slow strides' rule (gait_phase.toml imu_toe_eased) the IMU alone at 4 s
    # strides missed 3 + 3 of 63 (each walk's first toe off, 270-330 ms before the toes
    # leave: the heel rise's toe-down turn); before the hand-over between the detector's
    # paths and the other foot's bounds (stop 57): the board frozen 11 + 2, a preloaded
    # sensor with the gyroscope failed 9 + 0, the FSRs failed 2 + 2 (replayed; in the loop
    # 3 and 3 missed), the IMU alone at 4 s strides 43 + 43
    from exoleg.validate.gait_phase import evaluate

    v = evaluate(strides=20, other_foot=True)
    tables = [v.rows, *v.faults.values(), *v.closed.values(), *v.slow.values(),
              *(t for by in (*v.slow_sources.values(), *v.worst.values())
                for t in by.values())]
    for table in tables:
        for r in table:
            if r["event"] in ("initial contact", "toe off"):
                assert r["missed"] + r["false"] <= 0.01 * r["true"], r
    # and on the walks themselves every event, foot flat and heel off too (a sensor
    # failed or the IMU alone cannot see those), but for one read off by more than the
    # matching window (a miss and a false one): before the heel's own unloading
    # threshold (gait_phase.toml heel_off) 5 + 5 of 180 heel offs, read off over 200 ms
    # early while the heel still bore 25-45 N after its landing. Measured 1 + 1 heel off
    # of 180: the TD girl of 9 at 3x the datasheet's noise, one stride whose heel
    # unloaded at 10 % of the cycle against her 17 % (Schwartz's children: 30-40 %); 0
    # before the child's feedforward stopped counting the passive moments twice, when her
    # heel unloaded at 9 % in every stride
    for table in (v.rows, *v.slow.values()):
        for r in table:
            assert r["missed"] + r["false"] <= max(0.01 * r["true"], 2), r
    assert not any(v.closed_stopped.values()), v.closed_stopped


@pytest.mark.skipif(not __import__("exoleg.validate.opensim_child", fromlist=["x"]).available(),
                    reason="OpenSim not installed (pip install exoleg[opensim])")
def test_opensim_integrates_the_same_pendulum() -> None:
    # reference: OpenSim 4.6 (an independent multibody engine and integrator) with the
    # same body, the passive moments as its own expression and the reflex torques as
    # exoleg produced them. Measured over 5 s: 2.2e-4 deg (typical), 6.9e-5 deg
    # (moderate spasticity); the peak velocities to 1e-4 deg/s
    import warnings

    from exoleg.validate.opensim_child import compare_pendulum

    td = ChildModel.typical("td", 13, 1.56, 45.0, "male")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        for c in (td, td.with_(spasticity=Spasticity.preset("moderate"))):
            r = compare_pendulum(c)
            assert r.max_difference < 1e-3
            assert r.peak_velocity[0] == pytest.approx(r.peak_velocity[1], abs=1e-2)


def test_a_session_with_the_child_logs_and_sums_up_the_cuffs_torque(tmp_path) -> None:  # type: ignore[no-untyped-def]
    # exoleg run --child on the simulated device: the child stands disarmed (the knee
    # holds), the log has the cuffs' torque and the child's, and the summary sums it up
    from exoleg.runtime.session import run, summarize
    from exoleg.session_log import read_log

    ch = ChildModel("c", 10, 1.40, 32.0, 2, spasticity=Spasticity.preset("mild"), sex="male")
    _, path = run("sim", 2.0, tmp_path / "s", realtime=REALTIME, child=ch, body_mass=32.0)
    header, cols, _ = read_log(path)
    assert header["child"] == "c"
    assert abs(np.degrees(cols["q_knee"][-1] - cols["q_knee"][0])) < 3.0
    s = summarize(path)
    assert set(s["interaction_rms_Nm"]) == {"hip", "knee", "ankle"}
    assert all(math.isfinite(v) and v > 0 for v in s["interaction_rms_Nm_per_kg"].values())
    # a log without the device's own cuff readings (the buses' drives): nothing claimed
    from exoleg.runtime.session import _interaction_figures

    assert _interaction_figures({"t": cols["t"]}, 32.0)["interaction_rms_Nm"] is None
