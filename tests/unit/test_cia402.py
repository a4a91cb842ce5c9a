"""The CiA 402 state machine and the unit conversions (reference: CiA 402 part 2's
statusword table and transitions 2-16; the definitions of counts and per-mille torque)."""

from __future__ import annotations

import math
import re

import pytest
from hypothesis import given
from hypothesis import strategies as st

from exoleg.device.actuator import paper_actuators
from exoleg.errors import ParameterError
from exoleg.hw import cia402 as c
from exoleg.hw.units import JointScaling


@pytest.mark.parametrize("word,state", [
    (0x0000, c.State.NOT_READY_TO_SWITCH_ON), (0x0040, c.State.SWITCH_ON_DISABLED),
    (0x0021, c.State.READY_TO_SWITCH_ON), (0x0023, c.State.SWITCHED_ON),
    (0x0027, c.State.OPERATION_ENABLED), (0x0007, c.State.QUICK_STOP_ACTIVE),
    (0x000F, c.State.FAULT_REACTION_ACTIVE), (0x0008, c.State.FAULT),
    (0x0637, c.State.OPERATION_ENABLED),  # remote, target reached, voltage: ignored bits
])
def test_decode_statusword(word: int, state: c.State) -> None:
    assert c.decode(word) is state
    assert c.decode(c.STATUSWORD[state]) is state


def test_arming_walks_transitions_2_3_4() -> None:
    d = c.Drive()
    seen = []
    while not d.torque_allowed:
        d.controlword(c.controlword_towards(c.decode(d.statusword), True))
        seen.append(d.state)
    assert seen == [c.State.READY_TO_SWITCH_ON, c.State.SWITCHED_ON,
                    c.State.OPERATION_ENABLED]


def test_quick_stop_then_disable() -> None:
    d = c.Drive()
    for cw in (c.SHUTDOWN, c.SWITCH_ON_CMD, c.ENABLE_OPERATION_CMD):
        d.controlword(cw)
    assert d.controlword(c.QUICK_STOP_CMD) is c.State.QUICK_STOP_ACTIVE       # 11
    assert not d.torque_allowed
    assert d.controlword(c.DISABLE_VOLTAGE) is c.State.SWITCH_ON_DISABLED    # 12
    # disarming from Operation Enabled goes through quick stop
    assert c.controlword_towards(c.State.OPERATION_ENABLED, False) == c.QUICK_STOP_CMD


def test_fault_and_reset_on_the_rising_edge_only() -> None:
    d = c.Drive()
    for cw in (c.SHUTDOWN, c.SWITCH_ON_CMD, c.ENABLE_OPERATION_CMD):
        d.controlword(cw)
    d.fault()
    assert d.state is c.State.FAULT and not d.torque_allowed
    assert d.controlword(c.ENABLE_OPERATION_CMD) is c.State.FAULT  # no way out but reset
    assert d.controlword(c.FAULT_RESET_CMD) is c.State.SWITCH_ON_DISABLED  # 15
    d.fault()
    assert d.controlword(c.FAULT_RESET_CMD) is c.State.FAULT  # bit 7 held: no new edge
    d.controlword(0)
    assert d.controlword(c.FAULT_RESET_CMD) is c.State.SWITCH_ON_DISABLED


def test_unknown_statusword() -> None:
    with pytest.raises(ValueError, match="matches no CiA 402 state"):
        c.decode(0x0001)  # "ready" without its quick-stop bit: no state


@given(st.lists(st.integers(0, 0xFFFF), max_size=30))
def test_property_torque_only_by_the_enable_path(words: list[int]) -> None:
    """Whatever controlwords arrive, Operation Enabled is entered only from Switched On
    (transition 4) or Quick Stop Active (16), by an enable-operation command."""
    d = c.Drive()
    for w in words:
        before = d.state
        after = d.controlword(w)
        if after is c.State.OPERATION_ENABLED and before is not c.State.OPERATION_ENABLED:
            assert before in (c.State.SWITCHED_ON, c.State.QUICK_STOP_ACTIVE)
            assert w & 0x8F == c.ENABLE_OPERATION_CMD


SC = JointScaling.of(paper_actuators()[2], offset_counts=123456, direction=-1)


@given(st.floats(-3.0, 3.0))  # every joint range of motion lies within it
def test_counts_round_trip_within_half_a_count(q: float) -> None:
    assert abs(SC.to_rad(SC.to_counts(q)) - q) <= math.pi / 2**20 * (1 + 1e-9)


def test_counts_offset_direction_and_wrap() -> None:
    assert SC.to_counts(0.0) == 123456 and SC.to_rad(123456) == 0.0
    assert SC.to_rad(123456 - 2**18) == pytest.approx(math.pi / 2)  # direction -1
    assert SC.to_rad((123456 + 2**20 - 5) % 2**20) == pytest.approx(5 * 2 * math.pi / 2**20)


@given(st.floats(-70.0, 70.0))  # within the ankle's 2 x rated (73 N m at the joint)
def test_torque_round_trip_within_half_a_per_mille(tau: float) -> None:
    step = SC.rated_motor_torque * SC.ratio * SC.efficiency / 1000
    assert abs(SC.to_nm(SC.to_per_mille(tau)) - tau) <= step / 2 * (1 + 1e-9)


def test_torque_scale_and_saturation() -> None:
    a = paper_actuators()[2]
    rated = a.torque_constant * a.nominal_current  # 0.0525 x 7.25 = 0.381 N m (0x6076)
    assert SC.to_per_mille(-(a.ratio * a.efficiency * rated)) == 1000  # direction -1
    # the drive accepts +-(limit / nominal) x 1000 = +-2000 per mille (S3)
    assert SC.to_per_mille(1e9) == -2000 and SC.to_per_mille(-1e9) == 2000


def test_bad_scaling() -> None:
    with pytest.raises(ParameterError, match="direction"):
        JointScaling(20, 0, 2, 100.0, 0.8, 0.5)
    with pytest.raises(ParameterError, match="offset_counts"):
        JointScaling(20, 2**20, 1, 100.0, 0.8, 0.5)


def test_a_drive_configured_as_maxon_configures_it_is_accepted() -> None:
    # Reference: maxon's own configuration file for an EPOS4 50/15 with an EC 90 flat
    # (device-datasheets.md, S3): 0x6076 = 512 871 uN m = 4.760 A x 107.746 mN m/A;
    # 0x3001 sub 1 = 4760 mA, sub 2 = 9520 mA (2 x I_N); product code 0x65520000.
    import dataclasses

    from exoleg.device.actuator import paper_actuators
    from exoleg.errors import ParameterError
    from exoleg.hw.cia402 import DriveObjects, check_drive
    from exoleg.hw.units import MotorData

    hip = dataclasses.replace(paper_actuators()[0], torque_constant=0.107746,
                              nominal_current=4.76, peak_current=9.52)
    want = MotorData.of(hip)
    assert (want.rated_unm, want.nominal_current_ma, want.current_limit_ma) == (
        512871, 4760, 9520)
    # sub 3-5 as the device file's motor has them (the EC 90 flat 160 W's 11 pole pairs,
    # S2 line 29; its winding's 69.8 s; the torque constant above)
    dcf = DriveObjects(device_type=0x00020192, product_code=0x65520000, rated_unm=512871,
                       nominal_ma=4760, limit_ma=9520, pole_pairs=11, winding_ds=698,
                       kt_unm_a=107746, mode=10, counts=0, inputs=0)
    assert "rated torque 512871 uN m" in check_drive("hip drive", dcf, want, 0.0, -1.0,
                                                     1.0, 0.1)
    # a drive commissioned with the 90 W frame's 12 pole pairs (S1) would commutate the
    # 160 W's 11 wrongly; a torque constant off by the 24 V and 36 V windings' (70.5
    # against 107.7 mN m/A, S1) would turn every torque into the wrong current: refused
    for field, value, text in (
            ("pole_pairs", 12, "0x3001 sub 3 (pole pairs): 12; the device file says 11"),
            ("kt_unm_a", 70500, "0x3001 sub 5 (torque constant): 70500 uN m/A; the device "
                                "file says 107746 uN m/A"),
            ("winding_ds", 460, "0x3001 sub 4 (winding's thermal time constant): 460 x 0.1 "
                                "s; the device file says 698 x 0.1 s")):
        with pytest.raises(ParameterError, match=re.escape(text)):
            check_drive("hip drive", dataclasses.replace(dcf, **{field: value}), want, 0.0,
                        -1.0, 1.0, 0.1)
    # the units exoleg held before (mN m of k_t x the drive's 15 A): refused, named
    old = dataclasses.replace(dcf, rated_unm=round(0.107746 * 15 * 1000))
    with pytest.raises(ParameterError, match=r"0x6076: motor rated torque 1616 uN m; the "
                                             r"device file's motor gives 512871 uN m"):
        check_drive("hip drive", old, want, 0.0, -1.0, 1.0, 0.1)


def test_target_torque_stays_within_what_the_drive_accepts() -> None:
    # 0x6071 is limited to +-(output current limit / nominal current) x 1000 per mille
    # (S3: +-2000 for a limit of 2 x I_N); the scaling saturates there
    from exoleg.device.actuator import paper_actuators
    from exoleg.hw.units import JointScaling

    for a in paper_actuators():
        s = JointScaling.of(a)
        assert s.per_mille_limit == 2000
        assert s.to_per_mille(1e4) == 2000 and s.to_per_mille(-1e4) == -2000
        # 1000 per mille is the motor's rated torque k_t I_N, through the gear
        assert s.to_nm(1000) == pytest.approx(a.ratio * a.efficiency * a.torque_constant
                                              * a.nominal_current, rel=1e-12)
