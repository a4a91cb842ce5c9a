"""Assist-as-needed (Emken et al. 2007's law per gait-phase bin): the decay inside the
deadband as f^k, the growth with the error beyond it, the operator's bounds, the ramp
of a stride's new values, the interpolation along the cycle, the settings file."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from exoleg.control.assist import (
    BINS,
    AssistSettings,
    assist_level,
    assist_stride,
    assist_track,
)
from exoleg.errors import ParameterError


def _stride(ap: Any, as_: Any, err: Any, t: float, ticks: int = 1000) -> None:
    """One stride of ``ticks`` ticks over the cycle with the tracking error ``err`` (3,)
    rad at every tick, ended by an initial contact at ``t``."""
    for k in range(ticks):
        assist_track(as_, k / ticks, np.asarray(err, float))
    assist_stride(ap, as_, t)


@given(st.integers(1, 40), st.floats(0.0, 1.0))
@settings(max_examples=40, deadline=None)
def test_inside_the_deadband_the_support_decays_as_f_to_the_k(k: int, frac: float) -> None:
    # reference: Emken et al. 2007, s_k = f^k s_0 when w(e) = 0 (the error within the
    # deadband); the ramp over, every bin and joint
    s = AssistSettings.default()
    ap, as_ = s.record(), s.state()
    err = frac * s.deadband
    for i in range(k):
        _stride(ap, as_, err, float(i + 1))
    out = np.empty(3)
    assist_level(ap, as_, 0.37, k + 10.0, out)
    assert out == pytest.approx(s.forgetting ** k * s.start, rel=1e-12)
    assert as_[0]["strides"] == k


@given(st.floats(0.0, 0.5))
@settings(max_examples=40, deadline=None)
def test_beyond_the_deadband_the_support_grows_with_the_error(e: float) -> None:
    # reference: s_1 = clip(f s_0 + g max(0, e - deadband), min, max), e the bin's RMS
    s = AssistSettings.default()
    ap, as_ = s.record(), s.state()
    as_[0]["support"] = as_[0]["before"] = 0.2
    _stride(ap, as_, [e, e, e], 1.0)
    want = np.clip(s.forgetting * 0.2 + s.gain * np.maximum(0.0, e - s.deadband),
                   s.support_min, s.support_max)
    out = np.empty(3)
    assist_level(ap, as_, 0.5, 5.0, out)
    assert out == pytest.approx(want, rel=1e-12)


def test_the_bins_adapt_to_their_own_errors_and_the_cycle_interpolates() -> None:
    s = AssistSettings.default()
    ap, as_ = s.record(), s.state()
    # an error in the first half of the cycle only: those bins keep support, the
    # others forget
    ticks = 1000
    for k in range(ticks):
        x = k / ticks
        assist_track(as_, x, np.full(3, 0.3 if x < 0.5 else 0.0))
    assist_stride(ap, as_, 1.0)
    sup = as_[0]["support"]
    assert np.all(sup[: BINS // 2] == 1.0) and np.all(sup[BINS // 2:] == s.forgetting)
    # at a bin's centre its value; between two centres the line between them; across
    # the cycle's end the first and the last bins
    out = np.empty(3)
    assist_level(ap, as_, 0.5 / BINS, 9.0, out)
    assert out == pytest.approx(sup[0])
    assist_level(ap, as_, 0.5, 9.0, out)  # between the last high and the first low bin
    assert out == pytest.approx(0.5 * (sup[BINS // 2 - 1] + sup[BINS // 2]))
    assist_level(ap, as_, 0.999, 9.0, out)
    assert out[0] == pytest.approx(sup[-1, 0] + (0.999 * BINS - 0.5 - (BINS - 1))
                                   * (sup[0, 0] - sup[-1, 0]))


def test_a_strides_new_support_is_ramped_in_and_the_bounds_hold() -> None:
    s = AssistSettings.default()
    ap, as_ = s.record(), s.state()
    _stride(ap, as_, [0.0, 0.0, 0.0], 2.0)  # 1 -> f at t = 2 s over the ramp
    out = np.empty(3)
    for frac in (0.0, 0.25, 0.5, 1.0, 2.0):
        assist_level(ap, as_, 0.3, 2.0 + frac * s.ramp, out)
        assert out == pytest.approx(1.0 + min(frac, 1.0) * (s.forgetting - 1.0))
    # a stride ending mid-ramp starts from where the ramp had got to
    _stride(ap, as_, [0.0, 0.0, 0.0], 3.0)
    _stride(ap, as_, [0.0, 0.0, 0.0], 3.0 + 0.5 * s.ramp)
    half = s.forgetting + 0.5 * (s.forgetting ** 2 - s.forgetting)
    assist_level(ap, as_, 0.3, 10.0, out)
    assert out == pytest.approx(s.forgetting * half)
    # the operator's bounds: never below the floor, never above the ceiling
    as_[0]["lo"], as_[0]["hi"] = 0.4, 0.6
    for i in range(30):
        _stride(ap, as_, [0.0, 1.0, 0.0], 20.0 + i)
    assist_level(ap, as_, 0.3, 60.0, out)
    assert out[0] == pytest.approx(0.4) and out[1] == pytest.approx(0.6)


def test_a_bad_assist_file_is_refused_naming_the_field(tmp_path: Any) -> None:
    from importlib import resources

    from exoleg.device.config import DeviceConfig

    text = resources.files("exoleg").joinpath("data", "device", "assist.toml").read_text()
    for old, new, match in (("forgetting = 0.9", "forgetting = 1.0",
                             r"assist.toml.*forgetting.*must forget"),
                            ("support_min = [0.0, 0.0, 0.0]", "support_min = [0.0, 0.8, 0.0]",
                             r"assist.toml.*support_min.*above support_max"),
                            ("deadband_deg = [3.0, 3.0, 3.0]", "deadband_deg = [3.0, 3.0]",
                             r"assist.toml.*deadband_deg.*3 numbers")):
        bad = text.replace(old, new).replace("support_max = [1.0, 1.0, 1.0]",
                                             "support_max = [1.0, 0.5, 1.0]")
        (tmp_path / "assist.toml").write_text(bad)
        with pytest.raises(ParameterError, match=match):
            DeviceConfig.load(tmp_path)


def _walk(group: int | None, child_options: dict[str, Any], device: Any = None,
          learning: float = 0.0, strides: int = 40) -> Any:
    from exoleg.child.model import ChildModel
    from exoleg.control.transparency import SupportMode
    from exoleg.sim.walk import simulate_walk
    from exoleg.sizing import personalized_leg
    from exoleg.sizing.population import population_child

    c, _ = population_child(group, "female", 10.0, 50.0)
    child = ChildModel.of(c, **child_options).with_(learning=learning)
    return simulate_walk(personalized_leg(c), c.mass, strides=strides, child=child,
                         support_mode=SupportMode.AAN, device=device)


def _support(r: Any) -> list[float]:
    from exoleg.sim.metrics import support_by_stride

    return support_by_stride(r.t, r.support_level, r.strikes())


def test_the_support_falls_for_a_child_who_tracks_well_and_not_for_a_spastic_crouch() -> None:
    # The goal over 40 strides: the support falls by 30 % or more for a typically
    # developing child (the 50th-percentile girl of 10, learning: f 0.97) -- measured
    # 0.96 -> 0.22 -- and stays higher for a GMFCS III girl with moderate spasticity,
    # contracture and crouch (cluster 3) -- measured 0.52. Never outside the bounds, no
    # fault, the range of motion never left; the safety layer's torque clip and rate limit
    # do act (the gears' 54 N m, reached in every mode: impedance 20338 ticks, this
    # 13815 of 44000)
    from exoleg.sim.metrics import safety_events

    td = _walk(None, {}, learning=0.97)
    s = _support(td)
    assert len(s) >= 38 and s[-1] <= 0.7 * s[0], s
    crouch = _walk(3, {"contracture": "predictcpgait", "spasticity": "moderate",
                       "crouch": 3})
    c = _support(crouch)
    assert c[-1] >= s[-1] + 0.2, (c[-1], s[-1])
    for r in (td, crouch):
        assert not np.any(r.fault)
        assert np.all((r.support_level >= 0.0) & (r.support_level <= 1.0))
        fired = {e["event"] for e in safety_events(r.t, r.safety_status, r.walk_start)}
        assert fired <= {"torque", "rate"}, fired


def test_the_device_hands_over_only_when_it_relaxes_faster_than_the_child_slacks(
        tmp_path: Any) -> None:
    # Emken et al. 2007's condition, with a learning child (their stance share x <- f x
    # + g e): the device forgetting faster (0.9) than the child (0.97) hands the stance
    # over -- the support falls to 0.22, the child drives their whole share (1.0); the
    # device forgetting slower (0.99) than the child (0.9) keeps it -- 0.76, the child
    # slacks at 0.38 (measured)
    from importlib import resources

    text = resources.files("exoleg").joinpath("data", "device", "assist.toml").read_text()
    (tmp_path / "assist.toml").write_text(text.replace("forgetting = 0.9",
                                                       "forgetting = 0.99"))
    fast = _walk(None, {}, learning=0.97)
    slow = _walk(None, {}, device=tmp_path, learning=0.9)
    assert _support(fast)[-1] < 0.5 < _support(slow)[-1]
    assert fast.child_share[-1] > 0.9 and slow.child_share[-1] < 0.5


def test_a_learning_child_is_checked_and_kept_in_their_file(tmp_path: Any) -> None:
    from exoleg.child.model import ChildModel

    with pytest.raises(ParameterError, match=r"learning.*0\.3.*0\.5-0\.999"):
        ChildModel("c", 10.0, 1.4, 32.0, learning=0.3)
    c = ChildModel("c", 10.0, 1.4, 32.0, learning=0.97)
    c.save(tmp_path / "child.toml")
    assert ChildModel.load(tmp_path / "child.toml") == c
