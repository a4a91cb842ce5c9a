"""The cuffs' torque as a safety quantity (issue 38): read as a cuff passes it (a
low-pass on the rigid model's estimate), a limit per joint per kg of the child, and the
safety layer's response -- the support falls, then a controlled stop, then torque off --
each logged with its value.

References: the limits are Schwartz et al. 2008's very fast group's sagittal joint
moments (mean + 2 SD peak, the package's gait data); the sensor's response is the exact
discrete step response of two first-order stages, 1 - k^n (1 + n (1 - k)) with
k = exp(-2 pi f h); the ladder's levels are safety.toml's.
"""

from __future__ import annotations

import math
from importlib import resources
from pathlib import Path

import numpy as np
import pytest

from exoleg.child.model import ChildModel
from exoleg.control.safety import Fault, Limited, SafetyLimits, fault_detail
from exoleg.reference.gait import schwartz2008
from exoleg.sim.walk import simulate_walk
from exoleg.sizing import personalized_leg
from exoleg.sizing.child import population_child
from exoleg.tick import Mode


def test_the_limits_are_what_walking_asks_of_a_child_s_joints() -> None:
    # Schwartz 2008, very fast: the largest sagittal moment (mean + 2 SD), N m/kg
    peak = [float(np.max(np.abs(m) + 2 * sd)) for m, sd in
            (schwartz2008(f"{j}_moment_sagittal", "VeryFast")[1:]
             for j in ("hip", "knee", "ankle"))]
    limits = SafetyLimits.paper().cuff_limit
    assert np.allclose(limits, peak, atol=0.05), (limits, peak)  # rounded to 0.1 in the file


def test_the_reading_is_a_critically_damped_second_order_low_pass() -> None:
    from exoleg.control.safety import arm, cuff_check, new_state

    limits = SafetyLimits.paper()
    f, h = limits.cuff_bandwidth, limits.dt
    assert f == 20.0  # safety.toml [cuffs]
    lim, state = limits.record(), new_state()
    arm(state)
    cuff_check(lim, state, np.zeros(3), 30.0, True)  # the first reading: no transient
    assert np.array_equal(state[0]["cuff_read"][1], np.zeros(3))
    k = math.exp(-2 * math.pi * f * h)
    for n in range(1, 60):
        stage = cuff_check(lim, state, np.array([1.0, -2.0, np.nan]), 30.0, True)
        read = state[0]["cuff_read"][1]
        step = 1.0 - k**n * (1.0 + n * (1.0 - k))
        assert read[0] == pytest.approx(step, rel=1e-12, abs=1e-15)
        assert read[1] == pytest.approx(-2.0 * step, rel=1e-12, abs=1e-15)
        assert math.isnan(read[2]) and stage == 0  # no sensor: not watched
    # the continuous filter's step response at 59 ms, 1 - (1 + w t) e^-wt: measured
    # 2.7e-4 apart (the stages exact for a held input, the second's input is not held)
    t, w = 59 * h, 2 * math.pi * f
    assert read[0] == pytest.approx(1.0 - (1.0 + w * t) * math.exp(-w * t), rel=5e-4)


@pytest.fixture(scope="module")
def pusher() -> tuple[object, object]:
    # a GMFCS III girl of 10 (50th percentile) with severe spasticity, the predictcpgait
    # contracture and the deepest crouch she intends (cluster 5): walked in the impedance
    # mode, she pushes against the normative gait the device drives
    c, _ = population_child(3, "female", 10.0, 50.0)
    child = ChildModel.of(c, contracture="predictcpgait", spasticity="severe", crouch=5)
    return c, child


def _folder(tmp: Path, limits: str) -> Path:  # a device folder with other cuff limits
    shipped = (resources.files("exoleg") / "data" / "device" / "safety.toml").read_text()
    assert "limit_Nm_per_kg = [2.5, 1.3, 1.9]" in shipped
    (tmp / "safety.toml").write_text(shipped.replace("limit_Nm_per_kg = [2.5, 1.3, 1.9]",
                                                     f"limit_Nm_per_kg = {limits}"))
    return tmp


def test_beyond_the_shipped_limit_the_support_falls_every_tick_it_is(pusher) -> None:  # type: ignore[no-untyped-def]
    # Measured: her cuffs read up to 3.3 / 1.7 / 2.6 N m/kg (hip / knee / ankle) against
    # 2.5 / 1.3 / 1.9; the status says so in every such tick, and the support falls
    c, child = pusher
    r = simulate_walk(personalized_leg(c), c.mass, strides=6, child=child)
    limit = SafetyLimits.paper().cuff_limit * c.mass
    beyond = np.any(np.abs(r.cuff) > limit, axis=1)  # the reading each tick checks
    armed = np.isin(r.mode, (Mode.STANDING, Mode.WALKING, Mode.STOPPING))
    flagged = (r.safety_status & Limited.CUFF) > 0
    assert beyond[armed].sum() > 50  # she does push beyond it
    assert np.array_equal(flagged[armed], beyond[armed])
    assert (r.support_level[beyond & armed] < 1.0).any()
    # the rigid model's raw estimate peaks far higher at the heel strikes
    assert np.nanmax(np.abs(r.interaction[:, 0])) > 1.5 * np.nanmax(np.abs(r.cuff[:, 0]))
    assert not np.any(r.fault)  # never three times the limit


def test_the_ladder_support_then_a_controlled_stop_then_torque_off() -> None:
    # Fault injection into the walking controller (the same compiled tick the simulator,
    # the runtime and the buses run): a 20 kg child walking, the hip's cuff reading
    # 1.2 x its limit (2.5 N m/kg x 20 kg = 50 N m) from t = 0.4 s: the support falls
    # from the tick its low-passed reading crosses the limit (its ramp: 0.5 s), the walk
    # stops after 0.5 s beyond (a controlled stop, STOPPING), and a reading of 3.2 x the
    # limit takes the torque off the tick it crosses 3 x, latched, naming the reading and
    # the level it crossed
    import exoleg
    from exoleg.control.hierarchy import WalkController
    from exoleg.device import with_actuators
    from exoleg.tick import Command

    ctl = WalkController(with_actuators(exoleg.paper_leg()), 20.0)
    q = ctl.gains.standing.copy()
    limit = 2.5 * 20.0

    def tick(k: int, cuff: float, command: int = Command.NONE) -> dict:
        return ctl.update({"q": q, "dq": np.zeros(3), "fsr": np.array([1500.0, 800, 600, 300]),
                           "interaction": np.array([cuff, 0.0, 0.0])}, command, k * 1e-3)

    k = math.exp(-2 * math.pi * 20.0 * 1e-3)  # the cuffs' low-pass, safety.toml

    def crossing(start: float, end: float, level: float) -> int:
        """The tick after a step start -> end at which the reading (the exact discrete
        step response) first goes beyond level."""
        return next(n for n in range(1, 1000)
                    if start + (end - start) * (1 - k**n * (1 + n * (1 - k))) > level)

    tick(0, 0.0, Command.ARM)
    out = tick(1, 0.0, Command.WALK)
    n = 2
    while out["mode"] != Mode.WALKING:  # the walk waits for the foot's contact (8 ms)
        out = tick(n, 0.0)
        n += 1
    assert n < 20
    for m in range(n, 400):
        out = tick(m, 0.99 * limit)  # within: nothing
        assert not out["safety_status"] & (Limited.CUFF | Limited.CUFF_STOP)
    first = 400 - 1 + crossing(0.99 * limit, 1.2 * limit, limit)
    levels = []
    for n in range(400, first + 499):
        out = tick(n, 1.2 * limit)
        assert bool(out["safety_status"] & Limited.CUFF) == (n >= first), n
        assert out["mode"] == Mode.WALKING, n
        if n >= first:
            levels.append(out["support_level"][0])
    assert np.all(np.diff(levels) < 0) and levels[-1] == pytest.approx(0.002, abs=1e-9)
    n = first + 499  # its 500th tick beyond: 0.5 s -- a controlled stop
    out = tick(n, 1.2 * limit)
    assert out["safety_status"] & Limited.CUFF_STOP and out["mode"] == Mode.STOPPING
    assert out["support_level"][0] == 0.0 and out["fault"] == Fault.NONE
    off = n + crossing(1.2 * limit, 3.2 * limit, 3.0 * limit)
    for m in range(n + 1, off + 1):
        out = tick(m, 3.2 * limit)
        assert (out["fault"] == Fault.CUFF_TORQUE) == (m == off), m
    assert out["mode"] == Mode.FAULT and np.array_equal(out["tau"], np.zeros(3))
    assert out["fault_joint"] == 0 and out["fault_limit"] == 3.0 * limit
    assert 3.0 * limit < out["fault_value"] == out["cuff"][0] < 3.2 * limit
    assert fault_detail(out["fault"], 0, 151.2, 150.0).startswith(
        "CUFF_TORQUE at the hip: the cuffs' torque at 151 N m beyond its torque-off level "
        "of 150 N m")
    # a device without a cuff sensor reads NaN: not watched, never a fault
    ctl2 = WalkController(with_actuators(exoleg.paper_leg()), 20.0)
    ctl = ctl2
    tick(0, np.nan, Command.ARM)
    for k in range(1, 800):
        out = tick(k, np.nan, Command.WALK if k == 20 else Command.NONE)
    assert not out["safety_status"] & Limited.CUFF and out["mode"] == Mode.WALKING


def test_bad_cuff_settings_are_named(tmp_path: Path) -> None:
    from exoleg.errors import ParameterError

    with pytest.raises(ParameterError, match=r"limit_Nm_per_kg.*0-20 N m/kg"):
        SafetyLimits.paper(folder=_folder(tmp_path, "[2.5, -1.0, 1.9]"))
    shipped = (resources.files("exoleg") / "data" / "device" / "safety.toml").read_text()
    (tmp_path / "safety.toml").write_text(shipped.replace("off_at = 3.0", "off_at = 0.5"))
    with pytest.raises(ParameterError, match=r"off_at: 0.5 is outside 1-10"):
        SafetyLimits.paper(folder=tmp_path)
    (tmp_path / "safety.toml").write_text(shipped.replace("[cuffs]", "[cuffz]"))
    with pytest.raises(ParameterError, match="cuffs"):
        SafetyLimits.paper(folder=tmp_path)
