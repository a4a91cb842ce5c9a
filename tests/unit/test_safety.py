"""The safety layer, by fault injection: each behaviour forced and its reaction asserted,
and a property test: for any sensor values and commands the torque is finite and within
the limits.

References: the paper's range of motion (section 2.1) and Table 2 as shipped; the
torque rate and margins of ``data/device/safety.toml``.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exoleg.control.safety import Fault, Limited, SafetyLayer, SafetyLimits
from exoleg.errors import ParameterError
from exoleg.params import paper

LIM = SafetyLimits.paper()
ROM = paper.range_of_motion()
# Table 2's torques (150, 70, 168 N m) within the actuation units' working limits: the
# gears' repeated peak (54 N m, CSF-17-100; device-datasheets.md S10) and the knee's
# current limit (50 x 0.8 x 0.0525 N m/A x 14.5 A = 30.45 N m)
TMAX = np.minimum(np.array([a.max_torque for a in paper.actuators()]),
                  [54.0, 50.0 * 0.8 * 0.0525 * 14.5, 54.0])
Q = np.array([0.3, -0.6, 0.1])  # inside the range of motion
Z = np.zeros(3)


def armed() -> SafetyLayer:
    s = SafetyLayer(LIM)
    s.arm()
    return s


def ramp_to(s: SafetyLayer, u: np.ndarray, q: np.ndarray = Q, ticks: int = 200) -> np.ndarray:
    out = Z
    for _ in range(ticks):
        out, _ = s.step(q, Z, u)
    return out


def test_defaults_are_the_paper_s() -> None:
    assert np.array_equal(LIM.lower, ROM.lower) and np.array_equal(LIM.upper, ROM.upper)
    assert np.array_equal(LIM.max_torque, TMAX)
    assert np.allclose(LIM.max_speed, 1.2 * np.radians([300, 720, 300]))


def test_no_motion_without_arming() -> None:
    s = SafetyLayer(LIM)
    u, status = s.step(Q, Z, [10.0, 10.0, 10.0])
    assert np.array_equal(u, Z) and status & Limited.DISARMED


def test_torque_passes_when_armed_and_within_limits() -> None:
    s = armed()
    u = ramp_to(s, np.array([10.0, -5.0, 2.0]))
    assert np.array_equal(u, [10.0, -5.0, 2.0])


def test_torque_rate_makes_a_step_a_ramp() -> None:
    s = armed()
    u, status = s.step(Q, Z, [100.0, 0.0, 0.0])
    assert u[0] == pytest.approx(3000.0 * 1e-3) and status & Limited.RATE  # 3 N m per tick


def test_torque_clipped_to_the_working_limit() -> None:
    s = armed()
    u = ramp_to(s, np.array([1e6, -1e6, 1e6]))
    assert np.array_equal(u, [TMAX[0], -TMAX[1], TMAX[2]])


def test_estop_torque_off_same_tick_latched_rearm_only_explicit() -> None:
    s = armed()
    ramp_to(s, np.array([20.0, 20.0, 20.0]))
    u, status = s.step(Q, Z, [20.0, 20.0, 20.0], estop=True)
    assert np.array_equal(u, Z) and status & Limited.FAULT and s.fault == Fault.ESTOP
    u, _ = s.step(Q, Z, [20.0, 20.0, 20.0], estop=False)  # released: still latched
    assert np.array_equal(u, Z)
    with pytest.raises(ParameterError, match="ESTOP is latched"):
        s.arm()
    with pytest.raises(ParameterError, match="still pressed"):
        s.reset(Q, Z, estop_input=True)
    s.reset(Q, Z)
    assert not s.armed  # reset does not arm
    u, _ = s.step(Q, Z, [20.0, 20.0, 20.0])
    assert np.array_equal(u, Z)
    s.arm()
    u, _ = s.step(Q, Z, [20.0, 20.0, 20.0])
    assert u[0] == pytest.approx(3.0)  # ramps up again from zero


def test_estop_command_latches() -> None:
    s = armed()
    s.estop()
    assert np.array_equal(s.step(Q, Z, [5.0, 5.0, 5.0])[0], Z) and s.fault == Fault.ESTOP


@pytest.mark.parametrize("where", ["q", "dq", "u"])
@pytest.mark.parametrize("bad", [math.nan, math.inf, -math.inf])
def test_non_finite_anything_is_torque_off(where: str, bad: float) -> None:
    s = armed()
    ramp_to(s, np.array([5.0, 5.0, 5.0]))
    q, dq, u = Q.copy(), Z.copy(), np.array([5.0, 5.0, 5.0])
    {"q": q, "dq": dq, "u": u}[where][1] = bad
    out, status = s.step(q, dq, u)
    assert np.array_equal(out, Z) and s.fault == Fault.NONFINITE and s.fault_joint == "knee"


def test_overspeed_is_torque_off() -> None:
    s = armed()
    dq = np.array([0.0, 0.0, 1.21 * math.radians(300)])  # ankle: Table 2 300 deg/s x 1.2
    out, _ = s.step(Q, dq, [1.0, 1.0, 1.0])
    assert np.array_equal(out, Z) and s.fault == Fault.OVERSPEED and s.fault_joint == "ankle"
    s2 = armed()
    out, _ = s2.step(Q, 0.99 * dq, [1.0, 1.0, 1.0])
    assert s2.fault == Fault.NONE and out[2] == 1.0


def test_soft_limit_removes_only_outward_torque() -> None:
    s = armed()
    q = Q.copy()
    q[1] = ROM.upper[1] + math.radians(2)  # knee 2 deg hyperextended: within the hard margin
    out = ramp_to(s, np.array([5.0, 5.0, 5.0]), q)  # + at the knee pushes further out
    assert out[1] == 0.0 and out[0] == 5.0 and s.fault == Fault.NONE
    out = ramp_to(s, np.array([5.0, -5.0, 5.0]), q)  # - pulls it back in: allowed
    assert out[1] == -5.0
    _, status = s.step(q, Z, [5.0, 5.0, 5.0])
    assert status & Limited.SOFT_LIMIT


def test_beyond_the_hard_margin_is_torque_off() -> None:
    s = armed()
    q = Q.copy()
    q[0] = ROM.lower[0] - math.radians(5.5)  # hip extended 5.5 deg past 30 deg
    out, _ = s.step(q, Z, [-1.0, 0.0, 0.0])
    assert np.array_equal(out, Z) and s.fault == Fault.HARD_LIMIT and s.fault_joint == "hip"
    with pytest.raises(ParameterError, match="HARD_LIMIT still holds"):
        s.reset(q, Z)
    s.reset(Q, Z)
    assert s.fault == Fault.NONE


def test_disarm_stops_at_once() -> None:
    s = armed()
    ramp_to(s, np.array([50.0, 50.0, 50.0]))
    s.disarm()
    out, status = s.step(Q, Z, [50.0, 50.0, 50.0])
    assert np.array_equal(out, Z) and status & Limited.DISARMED


def test_bad_limits_are_named() -> None:
    with pytest.raises(ParameterError, match="max_torque"):
        SafetyLimits(ROM.lower, ROM.upper, 0.1, [1.0, -1.0, 1.0], [1.0] * 3, [1.0] * 3)
    with pytest.raises(ParameterError, match="lower/upper"):
        SafetyLimits(ROM.upper, ROM.lower, 0.1, [1.0] * 3, [1.0] * 3, [1.0] * 3)
    with pytest.raises(ParameterError, match="hard_margin"):
        SafetyLimits(ROM.lower, ROM.upper, math.nan, [1.0] * 3, [1.0] * 3, [1.0] * 3)


_any = st.floats(allow_nan=True, allow_infinity=True, width=64)


@settings(max_examples=400, deadline=None)
@given(ticks=st.lists(st.tuples(st.lists(_any, min_size=3, max_size=3),
                                st.lists(_any, min_size=3, max_size=3),
                                st.lists(_any, min_size=3, max_size=3), st.booleans()),
                      min_size=1, max_size=12), arm=st.booleans())
def test_property_commands_finite_and_within_limits(ticks: list, arm: bool) -> None:
    """For any sequence of sensor values, commands and E-stop inputs: every torque is
    finite, within Table 2, changes by at most the torque rate per tick, and is zero
    when disarmed or after a fault."""
    s = SafetyLayer(LIM)
    if arm:
        s.arm()
    prev = Z
    for q, dq, u_cmd, estop in ticks:
        out, status = s.step(q, dq, u_cmd, estop)
        assert np.all(np.isfinite(out))
        assert np.all(np.abs(out) <= LIM.max_torque)
        faulted = status & (Limited.FAULT | Limited.DISARMED)
        if faulted:
            assert np.array_equal(out, Z)
        else:
            assert np.all(np.abs(out - prev) <= LIM.max_torque_rate * LIM.dt * (1 + 1e-12))
        prev = out
    if not arm:
        assert np.array_equal(prev, Z)


def test_the_pages_table_of_commands_is_the_supervisors() -> None:
    # The pages enable their buttons by supervisor.APPLIES; the reference is the compiled
    # supervisor itself: every command in every mode, applied or refused.
    from exoleg.control.contract import Command, Mode
    from exoleg.control.safety import Fault, new_state
    from exoleg.control.supervisor import APPLIES, SUPERVISOR, supervise
    from exoleg.layout import new

    lim = LIM.record()
    q, dq = np.zeros(3), np.zeros(3)  # a sane state: a reset may clear the fault
    for mode in Mode:
        for cmd in Command:
            if cmd == Command.NONE:
                continue
            sup, sst = new(SUPERVISOR), new_state()
            sup[0]["mode"] = mode
            sst[0]["armed"] = mode in (Mode.STANDING, Mode.WALKING, Mode.STOPPING)
            if mode == Mode.FAULT:
                sst[0]["fault"] = Fault.OVERSPEED
            refused = supervise(sup, lim, sst, int(cmd), q, dq)
            assert (refused == Command.NONE) == (cmd in APPLIES[mode]), (mode, cmd)


def test_a_fault_names_its_value_against_its_limit() -> None:
    # Reference: the limits the layer was given (Table 2 x overspeed factor; the range of
    # motion + hard margin); the value is the one the tick saw.
    from exoleg.control.safety import Fault, fault_detail

    layer = SafetyLayer(LIM)
    layer.arm()
    lim = LIM
    dq = np.array([0.0, 1.2 * lim.max_speed[1], 0.0])
    layer.step(np.zeros(3), dq, np.zeros(3))
    s = layer.state[0]
    assert layer.fault == Fault.OVERSPEED and int(s["fault_joint"]) == 1
    assert s["fault_value"] == dq[1] and s["fault_limit"] == lim.max_speed[1]
    text = fault_detail(s["fault"], s["fault_joint"], s["fault_value"], s["fault_limit"])
    assert text.startswith(f"OVERSPEED at the knee: {dq[1]:.2f} rad/s") and \
        f"its limit of {lim.max_speed[1]:.2f} rad/s" in text and "Reset" in text
    below = SafetyLayer(lim)
    below.arm()
    q = np.array([0.0, 0.0, lim.lower[2] - 2 * lim.hard_margin])
    below.step(q, np.zeros(3), np.zeros(3))
    s = below.state[0]
    assert below.fault == Fault.HARD_LIMIT and s["fault_limit"] == \
        lim.lower[2] - lim.hard_margin
    layer.reset(np.zeros(3), np.zeros(3))  # cleared with the fault
    assert layer.state[0]["fault_value"] == 0.0 and layer.state[0]["fault_limit"] == 0.0
