"""Walking with the full device (exoleg.sim.walk) and the controller's contract.

References: the normative gait the controller follows (Schwartz 2008, tracking error);
the simulator's true contact events (from the noise-free contact forces) for the
detector; the supervisor's and safety layer's rules for the transitions and stops.
"""

from __future__ import annotations

import re
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import exoleg
from exoleg.control.hierarchy import WalkController
from exoleg.device import with_actuators
from exoleg.sim.metrics import detection_table
from exoleg.sim.walk import simulate_walk
from exoleg.tick import Command, Mode

LEG = exoleg.paper_leg()


@pytest.fixture(scope="module")
def walk() -> exoleg.sim.walk.WalkResult:
    return simulate_walk(LEG, 30.0, strides=10, seed=1)


def test_walks_ten_strides_without_a_fault(walk) -> None:  # type: ignore[no-untyped-def]
    assert set(np.unique(walk.mode)) == {Mode.STANDING, Mode.WALKING}
    assert not np.any(walk.safety_status & 2)
    last = walk.t >= walk.t[-1] - 5 * walk.stride_time
    err = np.degrees(np.abs(walk.q - walk.q_ref)[last]).max(axis=0)
    # measured with the datasheets' device (issue 21) on the rolling sole and the upright
    # gait (issue 22): 6.0, 10.2, 16.8 deg (RMS 2.7, 4.0, 4.9), the largest at toe off with
    # the hip and the ankle at their gears' 54 N m (the knee turning at 270 deg/s); on
    # four hard points and the tilted pelvis's gait 6.1, 5.8, 8.7; Table 2's device gave
    # 1.5, 6.0, 10.2
    assert np.all(err < [8.0, 12.0, 20.0]), err
    # stance carries the body: the contact forces' mean over the walk is near the weight
    # share times the stance fraction (about 0.6; measured 0.55)
    weight = (walk.plant.body_mass + walk.plant.leg_mass) * LEG.g
    mean = walk.contact_force[walk.t > walk.walk_start].sum(axis=1).mean()
    assert 0.4 * weight < mean < 0.9 * weight
    # the foot lands once a stride: no touch of the belt in swing (a load shorter than a
    # stance, sim.events.loads; the designed compliant device's toe catches it 2-10
    # times a stride, docs/design.md)
    assert len(walk.swing_touches()) == 0


def test_detector_against_true_events(walk) -> None:  # type: ignore[no-untyped-def]
    # Catalfamo et al. 2010 (shank gyroscope): initial contact -25 ms, foot off < 75 ms,
    # > 98 % detected; FSRs see contact directly: here initial contact within the
    # debounce (8 ms) + 2 ms. Toe off: the FSRs alone called it 24 ms early on average
    # (worst 26: the toes' tips, beyond the hallux's sensor, leave the belt last on the
    # rolling sole); timed by the foot's gyroscope (its toe-down turn easing past its
    # steepest, or rolled 10 deg over the toes since the FSRs' lift) it is late on this
    # leg, which rolls 6 deg, and in the first stride the turn's easing: measured mean
    # +12.6 ms, worst +15 ms; bounded at 20 -- with the FSRs' hysteresis (4.5 % of full
    # scale) and drift (5 % a decade) of the sheet (S11) in the readings the detector
    # gets.
    rows = {r["event"]: r for r in detection_table([walk])}
    for name in ("initial contact", "toe off"):  # every stride has them
        row = rows[name]
        assert row["true"] >= 9, row
        assert row["missed_rate"] == 0 and row["false_rate"] == 0, row
        assert abs(row["worst_error_ms"]) <= (10.0 if name == "initial contact" else 20.0), row
    # the rolling sole (issue 22) loads heel and forefoot together through mid-stance:
    # foot flat and heel off in every stride (on four hard points: 1 and 2 of 9), none
    # false. Measured (seed 1): foot flat 9.9 ms late on average (worst 25); heel off
    # 125 ms early (87-200: the heel unloads gradually as the foot rolls, and the
    # detector's threshold -- 15 % of the sensor's running maximum, some 75 N here -- is
    # met while the heel still bears on the belt; timing that issue 24's adaptive
    # thresholds and the gyroscope are for); bounded at 15 and 160 ms. Heel off is
    # matched within 250 ms, beyond its earliest: at the table's 200 ms a heel off
    # called 200 ms early would count as one missed and one false (it was 198 with the
    # sole's friction explicit, 200 since it is implicit: exoleg.world.plant)
    rows.update({r["event"]: r for r in detection_table([walk], window=0.25)
                 if r["event"] == "heel off"})
    for name, bound in (("foot flat", 15.0), ("heel off", 160.0)):
        row = rows[name]
        assert row["true"] >= 9 and row["in_strides"] == 1.0, row
        assert row["false_rate"] == 0.0 and abs(row["mean_error_ms"]) <= bound, row


def test_a_toe_scuffing_the_belt_in_swing_is_not_a_stride() -> None:
    # The truth's definitions (exoleg.sim.metrics.true_events): a stride's contact lands
    # ahead of the hip; a forefoot touching the belt behind it in swing (a toe scuff, the
    # foot drop of a child with CP) is neither an initial contact nor, leaving, a toe off.
    from exoleg.sim.events import true_events

    n = 1000
    F = np.zeros((n, 4))
    F[0:300, :] = 100.0          # stance
    F[450:480, 3] = 50.0         # the hallux scuffs in swing (0.15 s after toe off)
    F[700:1000, :] = 100.0       # the next stance
    ahead = np.zeros(n, dtype=bool)
    ahead[:50] = True            # the first stance landed ahead of the hip
    ahead[650:] = True           # the foot swings ahead of the hip before it lands
    with_rule = true_events(F, ahead=ahead)
    assert list(np.flatnonzero(with_rule & 1)) == [0, 700]
    assert list(np.flatnonzero(with_rule & 8)) == [300]
    # without it the scuff is a stride, and the real landing, too soon after its "toe
    # off", comes 50 ms late
    without = true_events(F)
    assert list(np.flatnonzero(without & 1)) == [0, 450, 750]


def test_walks_again_after_a_controlled_stop() -> None:
    # walk at 1 s, stand at 4.3 s, walk again at 7.6 s: the leg strikes the belt again
    # about once a stride -- no gap of 1.5 strides, the detector's own rejection bound
    # being 1.75 (gait_phase.toml) -- (the other leg and the child restart their clock
    # with the walk; keeping the first start's, the leg never struck again), every contact
    # detected within issue 24's 20 ms
    from exoleg.control.gait_phase import Event

    strides = 9
    c = np.zeros(int(round((1.0 + strides * 1.1) / 1e-3)) + 1, dtype=np.int64)
    c[0], c[1000], c[4300], c[7600] = Command.ARM, Command.WALK, Command.STAND, Command.WALK
    r = simulate_walk(LEG, 30.0, strides=strides, seed=1, commands=c)
    assert not np.any(r.fault >= 1)
    assert [int(r.mode[k]) for k in (4000, 7000, 9000)] == [Mode.WALKING, Mode.STANDING,
                                                           Mode.WALKING]
    true = r.t[(r.true_events() & Event.IC) > 0]
    again = true[true > 7.6]
    assert len(again) >= 2 and np.all(np.diff(again) < 1.5 * 1.1), true
    detected = r.t[(r.events & Event.IC) > 0]
    assert all(np.min(np.abs(detected - x)) <= 0.02 for x in again), (again, detected)


def test_deterministic_per_seed() -> None:
    a = simulate_walk(LEG, 30.0, strides=2, seed=5)
    b = simulate_walk(LEG, 30.0, strides=2, seed=5)
    c = simulate_walk(LEG, 30.0, strides=2, seed=6)
    assert np.array_equal(a.q, b.q) and np.array_equal(a.fsr, b.fsr)
    assert not np.array_equal(a.fsr, c.fsr)


def _sensors(q: np.ndarray, command: int = Command.NONE) -> tuple[dict, int]:
    return {"q": q, "dq": np.zeros(3), "fsr": np.array([1500.0, 800, 600, 300])}, command


def test_controller_contract_and_supervisor() -> None:
    ctl = WalkController(with_actuators(LEG), 20.0)
    q = ctl.gains.standing.copy()
    out = ctl.update(*_sensors(q), 0.0)
    assert out["mode"] == Mode.DISARMED and np.array_equal(out["tau"], np.zeros(3))
    out = ctl.update(*_sensors(q, Command.WALK), 0.001)  # no walking before arming
    assert out["mode"] == Mode.DISARMED
    out = ctl.update(*_sensors(q, Command.ARM), 0.002)
    assert out["mode"] == Mode.STANDING
    for k in range(3, 60):
        out = ctl.update(*_sensors(q), k * 1e-3)
    assert np.any(out["tau"] != 0.0)  # holding the standing posture with gravity
    out = ctl.update(*_sensors(q, Command.WALK), 0.06)
    assert out["mode"] == Mode.WALKING
    out = ctl.update(*_sensors(q, Command.STAND), 0.061)
    assert out["mode"] == Mode.STOPPING  # a controlled stop: it walks on to stand
    k = 62
    while out["mode"] == Mode.STOPPING and k < 3000:
        out = ctl.update(*_sensors(q), k * 1e-3)
        k += 1
    assert out["mode"] == Mode.STANDING and k * 1e-3 - 0.061 <= 1.5 * 1.1 + 0.01


def test_estop_while_walking_is_torque_off_the_same_tick_and_latched() -> None:
    ctl = WalkController(with_actuators(LEG), 20.0)
    q = ctl.gains.standing.copy()
    ctl.update(*_sensors(q, Command.ARM), 0.0)
    for k in range(1, 100):
        ctl.update(*_sensors(q, Command.WALK if k == 50 else Command.NONE), k * 1e-3)
    out = ctl.update(*_sensors(q, Command.ESTOP), 0.1)
    assert out["mode"] == Mode.FAULT and np.array_equal(out["tau"], np.zeros(3))
    out = ctl.update(*_sensors(q, Command.ARM), 0.101)   # arming does not clear it
    assert out["mode"] == Mode.FAULT and np.array_equal(out["tau"], np.zeros(3))
    out = ctl.update(*_sensors(q, Command.RESET), 0.102)
    assert out["mode"] == Mode.DISARMED
    out = ctl.update(*_sensors(q, Command.ARM), 0.103)
    assert out["mode"] == Mode.STANDING


def test_a_reset_while_the_fault_holds_is_refused_and_names_it() -> None:
    # The supervisor calls the safety layer's reset, which checks the state as
    # SafetyLayer.reset does: overspeed still measured -> refused, FAULT kept.
    from exoleg.control.safety import Fault, still_holds

    ctl = WalkController(with_actuators(LEG), 20.0)
    q = ctl.gains.standing.copy()
    ctl.update(*_sensors(q, Command.ARM), 0.0)
    fast = {"q": q, "dq": np.array([0.0, 0.0, 50.0]), "fsr": np.full(4, 1000.0)}
    out = ctl.update(fast, Command.NONE, 0.001)
    assert out["mode"] == Mode.FAULT and out["fault"] == Fault.OVERSPEED
    out = ctl.update(fast, Command.RESET, 0.002)
    assert out["mode"] == Mode.FAULT and out["refused"] == Command.RESET
    assert still_holds(out["fault"], out["fault_joint"]) == "OVERSPEED still holds (ankle)"
    out = ctl.update(*_sensors(q, Command.RESET), 0.003)  # slow again: cleared
    assert out["mode"] == Mode.DISARMED and out["refused"] == Command.NONE
    assert out["fault"] == Fault.NONE


def test_a_command_that_does_not_apply_is_reported_refused() -> None:
    ctl = WalkController(with_actuators(LEG), 20.0)
    q = ctl.gains.standing.copy()
    for cmd in (Command.WALK, Command.STAND, Command.RESET):  # none applies disarmed
        out = ctl.update(*_sensors(q, cmd), 0.0)
        assert out["mode"] == Mode.DISARMED and out["refused"] == cmd
    out = ctl.update(*_sensors(q, Command.ARM), 0.001)
    assert out["refused"] == Command.NONE
    out = ctl.update(*_sensors(q, Command.WALK), 0.002)
    k = 3
    while out["mode"] != Mode.WALKING:  # the walk waits for the foot's contact (8 ms)
        out = ctl.update(*_sensors(q), k * 1e-3)
        k += 1
    out = ctl.update(*_sensors(q, Command.DISARM), k * 1e-3)  # no torque off mid-stride
    assert out["mode"] == Mode.WALKING and out["refused"] == Command.DISARM
    from exoleg.control.supervisor import refusal

    assert "stand first" in refusal(out["refused"], out["mode"])


@pytest.mark.parametrize(("field", "value", "says"), [
    ("q", [0.1, 0.2], "q: expected 3 numbers, got shape (2,)"),
    ("dq", "fast", "dq: expected 3 numbers"),
    ("fsr", [[1.0, 2.0], [3.0, 4.0]], "fsr: expected 4 numbers, got shape (2, 2)"),
    ("q", [True, False, True], "q: expected 3 numbers, got shape (3,) of bool"),
])
def test_readings_of_the_wrong_shape_or_kind_are_refused(field: str, value: object,
                                                          says: str) -> None:
    # Before, a 2-value q was read past its end by the compiled tick.
    from exoleg.errors import ParameterError

    ctl = WalkController(with_actuators(LEG), 20.0)
    sensors, _ = _sensors(ctl.gains.standing.copy())
    sensors[field] = value
    with pytest.raises(ParameterError, match=re.escape(says)):
        ctl.update(sensors, Command.NONE, 0.0)
    with pytest.raises(ParameterError, match="command: 42 is not a command"):
        ctl.update(_sensors(ctl.gains.standing.copy())[0], 42, 0.0)
    with pytest.raises(ParameterError, match=re.escape("command: [1] is not a command")):
        ctl.update(_sensors(ctl.gains.standing.copy())[0], [1], 0.0)  # was a TypeError


def test_non_finite_sensor_is_a_fault() -> None:
    ctl = WalkController(with_actuators(LEG), 20.0)
    q = ctl.gains.standing.copy()
    ctl.update(*_sensors(q, Command.ARM), 0.0)
    bad = q.copy()
    bad[1] = np.nan
    out = ctl.update(*_sensors(bad), 0.001)
    assert out["mode"] == Mode.FAULT and np.all(np.isfinite(out["tau"]))
    assert np.array_equal(out["tau"], np.zeros(3))


def _stand_from_walking(leg: exoleg.LegModel, body_mass: float, t_stand: float,
                        seed: int) -> tuple[str, float, float]:
    """Walk from 1 s, stand at ``t_stand`` s, go on 3 s: (final mode, the worst excess
    over the soft range of motion after the stand (rad; negative: inside), the time from
    the command to STANDING (s))."""
    from exoleg.control.safety import SafetyLimits
    from exoleg.runtime.sim_backend import SimBackend

    lim = SafetyLimits.paper()
    b = SimBackend.built(leg, body_mass, seed=seed)
    ctl = b.controller
    ks = int(round(t_stand / 1e-3))
    worst, stood = -np.inf, np.inf
    for k in range(ks + 3000):
        s = b.read(k * 1e-3)
        cmd = (Command.ARM if k == 0 else Command.WALK if k == 1000
               else Command.STAND if k == ks else Command.NONE)
        out = ctl.update(s, cmd, k * 1e-3)
        if k >= ks:
            worst = max(worst, float(np.max(np.maximum(s["q"] - lim.upper,
                                                       lim.lower - s["q"]))))
            if out["mode"] == Mode.STANDING:
                stood = min(stood, (k - ks) * 1e-3)
        if out["mode"] == Mode.FAULT:
            return f"FAULT {out['fault'].name}", worst, stood
        b.walking = out["mode"] in (Mode.WALKING, Mode.STOPPING)
        b.write(out["tau"], out["mode"] in (Mode.STANDING, Mode.WALKING, Mode.STOPPING))
    return out["mode"].name, worst, stood


def _children() -> list[tuple[exoleg.LegModel, float]]:
    from exoleg.sizing import Child, personalized_leg

    # the design range's small end (8 y) and the paper's leg: the children the
    # datasheets' device carries walking (issue 21; a 12 y, 50 kg child's walk itself
    # leaves the range of motion: test_the_datasheets_device_does_not_carry_a_heavy_child)
    out = [(exoleg.paper_leg(), 30.0)]
    for age, sex, height, mass in ((8, "female", 1.20, 21.0),):
        out.append((personalized_leg(Child(age=age, sex=sex, height=height, mass=mass)),
                    mass))
    return out


CHILDREN = _children()


@settings(max_examples=24, deadline=None)
@given(phase=st.floats(0.0, 0.999), child=st.integers(0, len(CHILDREN) - 1),
       seed=st.integers(0, 9))
def test_stand_from_any_phase_ends_standing_inside_the_range_of_motion(
        phase: float, child: int, seed: int) -> None:
    # Property (issue 20: a stand while walking used to jump the reference to the
    # standing pose; the knee overshot and the hard margin tripped in 8 of 13 phases
    # tried): the stop walks on to where the stance foot is under the hip, then moves
    # to the standing posture. Measured with the datasheets' device over phases 0, 0.5
    # x these 2 children: always STANDING, at least 2.3 deg inside the soft limits,
    # standing within 0.97 s.
    leg, mass = CHILDREN[child]
    mode, worst, stood = _stand_from_walking(leg, mass, 2.0 + phase * 1.1, seed)
    assert mode == "STANDING"
    assert worst < 0.0, f"{np.degrees(worst):.2f} deg beyond the soft range of motion"
    assert stood <= 1.5 * 1.1 + 0.05  # at most STOP_WAIT_STRIDES strides (1.1 s each)


def test_a_reference_waiting_for_a_late_contact_stands_still() -> None:
    # Fault injection by the child: a weak GMFCS III girl with contracture (half her
    # group's strength) in assist-as-needed, whose initial contact comes late. The
    # reference waits at the cycle's end for it; it used to keep the gait's end-of-swing
    # rate and acceleration in the impedance, which held her knee flexed at the drive's
    # limit (30.4 N m against a reference 70 deg more extended) with her foot in the air
    # for the walk's last 16 s, the mode WALKING (measured: the knee at its limit 16,265
    # ticks in a row, the foot off the belt 16,893, 25 s between two strikes). Waiting, the
    # reference now stands still: no swing longer than a stride (the normative swing is 40
    # % of it: 0.44 s; measured at most 0.46 s), no run at the knee's limit as long (0.35
    # s), and the walk goes on (her longest stride 3.3 s) -- to its end, or to the cuffs'
    # torque off: the child is at the edge of what the device may do to her leg. Since
    # her feedforward stopped counting the passive moments twice, the device pushing her
    # lagging leg turns its torque off (CUFF_TORQUE, latched and logged, after the
    # support's fall and the controlled stop: issue 38's chain) at 24.5 s of this walk,
    # after 19 strides (measured over seeds 0-3: off in 2, at 24.5 and 25.6 s; with the
    # double count in 1, at 44.8 s); before it, her longest stride 2.2 s
    from exoleg.child.model import ChildModel
    from exoleg.control.transparency import SupportMode
    from exoleg.sim.metrics import safety_events
    from exoleg.sizing import personalized_leg
    from exoleg.sizing.child import population_child
    from exoleg.tick import Fault

    c, _ = population_child(3, "female", 10.0, 50.0)
    r = simulate_walk(personalized_leg(c), c.mass, strides=40, seed=0,
                      child=ChildModel.of(c, contracture="predictcpgait", strength=0.5),
                      support_mode=SupportMode.AAN)

    def longest(run: Any) -> float:
        edges = np.flatnonzero(np.diff(np.r_[0, run.astype(int), 0]))
        return float(np.max(edges[1::2] - edges[::2], initial=0)) * 1e-3

    off = np.flatnonzero(r.fault)
    end = r.t[off[0]] if len(off) else r.t[-1]
    if len(off):
        assert set(r.fault[off]) == {Fault.CUFF_TORQUE}, set(r.fault[off])
        fired = {e["event"] for e in safety_events(r.t, r.safety_status, r.walk_start)}
        assert {"cuff", "cuff_stop", "fault"} <= fired, fired
    walking = (r.t >= r.walk_start) & (r.t < end)
    assert longest(walking & (r.contact_force.sum(axis=1) == 0)) < r.stride_time
    assert longest(walking & (np.abs(r.tau[:, 1]) >= r.envelope[:, 1] - 1e-6)) < r.stride_time
    strikes = r.strikes()
    strikes = np.r_[r.walk_start, strikes[strikes < end], end]
    assert len(strikes) > 15 and np.diff(strikes).max() < 5 * r.stride_time, strikes


def test_the_datasheets_device_does_not_carry_a_heavy_child() -> None:
    # What the device can do (issue 21), as a regression: at 24 V, its gears' repeated
    # peak torque and 2 x I_N, a heavy 12-year-old walking at the free speed is not
    # carried where Table 2's device carried him. On four hard points and the gait of a
    # tilted pelvis a 40 kg boy already faulted (the knee past its hard limit); on the
    # rolling sole and the upright gait (issue 22) 40 kg is carried at the edge (hip at
    # its envelope in 44 % of the ticks, knee within 14.5 deg, RMS 6.3) and 48 kg is not:
    # measured, the knee 22 deg off its reference (RMS 10.5), the hip at its envelope in
    # 4232 of 7601 ticks. (Before the walk started at rest, reference.gait.START_RAMP: 34
    # deg, RMS 14.6 and 3517 ticks; before that, 61 deg, RMS 37, and 4221 ticks while the
    # world's cycle waited for a strike the leg could not make -- the foot down behind the
    # hip; it now goes on from such a foot, as the other leg of a child would); a 21 kg
    # 8-year-old tracks within 4.8 / 10.9 / 15.0 deg (RMS 2.2 / 4.1 / 4.2).
    from exoleg.sizing import Child, personalized_leg

    heavy = personalized_leg(Child(age=12, sex="male", height=1.55, mass=48.0))
    r = simulate_walk(heavy, 48.0, strides=6)
    e = np.degrees(np.abs(r.q - r.q_ref)[r.t > 3.0])
    knee_rms = float(np.sqrt(np.mean(e[:, 1] ** 2)))
    assert np.any(r.mode == Mode.FAULT) or knee_rms > 9.0, knee_rms  # 40 kg: 6.3
    at_envelope = (np.abs(r.tau) >= r.envelope - 1e-6).sum(axis=0)
    assert at_envelope[0] > 0.4 * len(r.t), at_envelope
    light = personalized_leg(Child(age=8, sex="female", height=1.20, mass=21.0))
    r = simulate_walk(light, 21.0, strides=6)
    assert not np.any(r.mode == Mode.FAULT)
    err = np.degrees(np.abs(r.q - r.q_ref)[r.t > 3.0]).max(axis=0)
    assert np.all(err < [8.0, 15.0, 20.0]), err


@pytest.mark.parametrize("mode", ["impedance", "transparent"])
def test_a_walk_from_standing_starts_without_an_impact_at_the_cuffs(mode: str) -> None:
    # The walk's start (reference.gait.START_RAMP): the belt, the other leg's lift, the
    # child's gait and the reference come up to pace together from rest. Started at full
    # pace in a tick, the belt dragged the standing foot to its speed at once: the cuffs
    # read 176 / 77 / 52 N m (impedance) and 176 / 79 / 32 (transparent) in the walk's
    # first 0.5 s, the hip's 2.2 times its limit (safety.toml's 2.5 / 1.3 / 1.9 N m per kg:
    # Schwartz 2008's very fast moments, mean + 2 SD) -- an impact no child starting to
    # walk meets. Measured now 46 / 30 / 50 and 31 / 19 / 12 N m (the girl of 10, 32 kg);
    # standing, 19 / 12 / 14
    from exoleg.child.model import ChildModel
    from exoleg.control.transparency import SUPPORT_NAMES
    from exoleg.sizing import personalized_leg
    from exoleg.sizing.child import population_child

    c, _ = population_child(None, "female", 10.0, 50.0)
    r = simulate_walk(personalized_leg(c), c.mass, strides=2, child=ChildModel.of(c),
                      support_mode=SUPPORT_NAMES[mode])
    assert not np.any(r.mode == Mode.FAULT)
    start = (r.t >= r.walk_start) & (r.t < r.walk_start + 0.5)
    peak = np.abs(r.interaction[start]).max(axis=0)
    assert np.all(peak <= r.cuff_limit * c.mass), (peak, r.cuff_limit * c.mass)


def test_a_walks_first_swing_is_timed_from_its_toe_off(tmp_path: Path) -> None:
    # A child's first stance from standing runs slower than the gait: their leg comes up
    # to pace from rest. At its toe off the reference had run on past the foot (its
    # fraction 0.62-0.64 against the gait's foot off, 0.59 +- 0.02: Schwartz 2008's free
    # speed, schwartz2008_cycle_events.csv), and played on at the stride's rate it led
    # the swinging leg: the knee extended early and the toe caught the belt. The first
    # swing now plays the rest of the cycle over the swing the gait gives it, (1 - 0.59)
    # of the stride expected (hierarchy.first_swing); later swings at the stride's rate.
    from exoleg.child.model import ChildModel
    from exoleg.cli import main
    from exoleg.control.gait_phase import Event
    from exoleg.control.transparency import SupportMode
    from exoleg.reference.gait import cycle_event
    from exoleg.sizing import personalized_leg
    from exoleg.sizing.child import population_child

    foot_off = cycle_event("Ipsilateral Foot Off")[0]
    assert foot_off == 0.59
    c, _ = population_child(None, "female", 10.0, 50.0)
    r = simulate_walk(personalized_leg(c), c.mass, strides=3, child=ChildModel.of(c),
                      support_mode=SupportMode.AAN)
    ev = r.events.astype(int)
    walking = r.t >= r.walk_start
    to = np.flatnonzero(walking & ((ev & Event.TO) != 0))
    ic = np.flatnonzero(walking & ((ev & Event.IC) != 0))
    x = r.gait_fraction
    # the first swing: from its toe off to the first contact (measured at 0.63 here)
    k, end = to[0], ic[0]
    assert 0.6 < x[k] < 0.66, x[k]
    rate = (x[end - 1] - x[k]) / (r.t[end - 1] - r.t[k])
    assert rate == pytest.approx((1.0 - x[k]) / ((1.0 - foot_off) * r.stride_time), rel=1e-6)
    # the second at its stride's: the mean of the strides so far (gait_phase.toml) -- one,
    # from where the walk started in the cycle (mid-stance, its pace's ramp) to the first
    # contact: 1.128 s here
    from exoleg.control.walk_gains import START_FRACTION
    from exoleg.reference.gait import START_RAMP

    k2, end2 = to[1], ic[1]
    begun = r.walk_start - START_FRACTION * r.stride_time + 0.5 * START_RAMP
    stride = r.t[ic[0]] - begun
    assert (x[end2 - 1] - x[k2]) / (r.t[end2 - 1] - r.t[k2]) == pytest.approx(
        1.0 / stride, rel=1e-6)
    # slower than the gait data's speeds (2 s strides, beyond SLOWEST_GROUP_STRIDE's 1.3)
    # the stance is longer in every stride (her toe offs at 0.636, 0.636, 0.637, 0.638 of
    # the reference, measured), not behind: the first swing plays at the stride's rate
    r = simulate_walk(personalized_leg(c), c.mass, strides=2, child=ChildModel.of(c),
                      support_mode=SupportMode.AAN, stride_time=2.0)
    ev = r.events.astype(int)
    walking = r.t >= r.walk_start
    k = np.flatnonzero(walking & ((ev & Event.TO) != 0))[0]
    end = np.flatnonzero(walking & ((ev & Event.IC) != 0))[0]
    assert 0.62 < r.gait_fraction[k] < 0.66, r.gait_fraction[k]
    assert (r.gait_fraction[end - 1] - r.gait_fraction[k]) / (r.t[end - 1] - r.t[k]) == (
        pytest.approx(1.0 / 2.0, rel=1e-6))
    # what it was for, on the example design's device: children whose toe caught the belt
    # in their first swing (measured before, 8 assisted strides: 3, 4, 2 and 2 touches)
    # walk it clear
    example = Path(__file__).resolve().parents[2] / "examples" / "design-population.toml"
    assert main(["design", str(example), "--out", str(tmp_path), "--no-population"]) == 0
    for group, sex, age, pct in ((1, "female", 12.0, 10.0), (1, "male", 12.0, 10.0),
                                 (2, "female", 8.0, 90.0), (2, "male", 8.0, 90.0)):
        c, _ = population_child(group, sex, age, pct)
        r = simulate_walk(personalized_leg(c), c.mass, strides=2, child=ChildModel.of(c),
                          support_mode=SupportMode.AAN, device=tmp_path / "device")
        first = r.strikes()[0]
        assert not np.any(r.swing_touches() < first), (c.name, r.swing_touches())
    # and what is left of it: children whose first swing still catches the belt with the
    # planned 1.1 s expected, and not with their own stride (1.14 s: these children walk
    # 1.134-1.143 s strides here, measured) expected from the start -- a later session's,
    # the console giving it from their last (hmi.history.expected_stride)
    for group, sex, age, pct in ((None, "female", 12.0, 90.0), (3, "male", 10.0, 90.0)):
        c, _ = population_child(group, sex, age, pct)
        caught = []
        for expected in (None, 1.14):
            r = simulate_walk(personalized_leg(c), c.mass, strides=2, child=ChildModel.of(c),
                              support_mode=SupportMode.AAN, device=tmp_path / "device",
                              expected_stride=expected)
            caught.append(bool(np.any(r.swing_touches() < r.strikes()[0])))
        assert caught == [True, False], (c.name, caught)
