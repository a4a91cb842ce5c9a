"""The foot board's sensor faults (:mod:`exoleg.device.faults`): what each kind does to a
reading (reference: the readings built by hand and the module's definitions), faults
refused by name, and a fault injected into a closed-loop walk reaches the controller's
readings and nothing else."""

from __future__ import annotations

import math

import numpy as np
import pytest

import exoleg
from exoleg.device.faults import SensorFault, faulted
from exoleg.device.sensors import FootSensors
from exoleg.errors import ParameterError
from exoleg.sim.walk import simulate_walk

BOARD = FootSensors.default()
TOP = float(2**BOARD.adc_bits - 1)


def _readings() -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    t = np.arange(5.0)
    counts = np.tile([100.0, 200.0, 300.0, 400.0], (5, 1)) + t[:, None]
    return counts, 0.1 * t, np.column_stack([t, 9.8 + t]), t


def test_each_kind_of_fault_as_defined() -> None:
    counts, gyro, acc, t = _readings()
    c, g, a, _ = faulted([SensorFault("heel", "dead", 1.0),
                       SensorFault("gyro", "frozen", 2.0),
                       SensorFault("met1", "offset", 3.0, 0.25),
                       SensorFault("hallux", "drift", 1.0, 0.5, end=4.0),
                          SensorFault("accel", "missing", 4.0)], counts, gyro, acc, t,
                         BOARD)
    assert c[:, 0].tolist() == [100.0, 0.0, 0.0, 0.0, 0.0]
    assert g.tolist() == pytest.approx([0.0, 0.1, 0.2, 0.2, 0.2])
    assert c[:, 1].tolist() == [200.0, 201.0, 202.0, 203.0 + 0.25 * TOP, 204.0 + 0.25 * TOP]
    # 1 + 0.5 (t - 1) from 1 s, until 4 s
    assert c[:, 3].tolist() == [400.0, 401.0, 402.0 * 1.5, 403.0 * 2.0, 404.0]
    assert c[:, 2].tolist() == counts[:, 2].tolist()  # untouched
    assert np.all(np.isnan(a[4])) and a[:4].tolist() == acc[:4].tolist()
    # the inputs are not changed
    assert counts[1, 0] == 101.0 and gyro[3] == pytest.approx(0.3)


def test_a_fault_stays_within_the_sensor_range() -> None:
    # the ADC saturates at its top count and at 0; the gyroscope at its range
    counts, gyro, acc, t = _readings()
    c, g, _, _ = faulted([SensorFault("fsrs", "offset", 0.0, 1.0),
                          SensorFault("gyro", "dead", 0.0, 1e3)], counts, gyro, acc, t,
                         BOARD)
    assert np.all(c == TOP) and np.all(g == BOARD.gyro_range)
    c, _, _, o = faulted([SensorFault("board", "offset", 0.0, -1.0)], counts, gyro, acc, t,
                         BOARD, counts + 1000.0)
    assert np.all(c == 0.0) and np.all(o == 0.0)


def test_the_insole_is_a_channel_of_the_board() -> None:
    # the unassisted foot's insole is read on the foot board's spare ADC channels
    # (sensors.toml [other_foot]): the whole board's fault covers it, the "insole"
    # channel is it alone, and no fault of the device's foot touches it
    counts, gyro, acc, t = _readings()
    other = counts[:, ::-1] + 50.0
    c, g, a, o = faulted([SensorFault("insole", "dead", 2.0)], counts, gyro, acc, t, BOARD,
                         other)
    assert o[:2].tolist() == other[:2].tolist() and np.all(o[2:] == 0.0)
    assert c.tolist() == counts.tolist() and g.tolist() == gyro.tolist()
    _, _, _, o = faulted([SensorFault("board", "frozen", 1.0)], counts, gyro, acc, t, BOARD,
                         other)
    assert o.tolist() == [other[0].tolist()] + [other[1].tolist()] * 4
    _, _, _, o = faulted([SensorFault("fsrs", "dead"), SensorFault("heel", "offset", 0.0, 0.5)],
                         counts, gyro, acc, t, BOARD, other)
    assert o.tolist() == other.tolist()
    _, _, _, o = faulted([], counts, gyro, acc, t, BOARD)  # none fitted: no reading
    assert np.all(np.isnan(o))
    assert SensorFault.parse("insole:dead@2") == SensorFault("insole", "dead", 2.0)


@pytest.mark.parametrize(("args", "field"), [
    (("toe", "dead"), "channel"), (("heel", "broken"), "kind"),
    (("heel", "dead", -1.0), "start/end"), (("heel", "dead", 2.0, 0.0, 1.0), "start/end"),
    (("heel", "offset", 0.0, 2.0), "value"), (("gyro", "drift", 0.0, 5.0), "value"),
    (("gyro", "dead", math.nan), "start"), (("gyro", "dead", 0.0, math.inf), "value"),
])
def test_a_bad_fault_is_refused_by_name(args: tuple, field: str) -> None:
    with pytest.raises(ParameterError) as e:
        SensorFault(*args)
    assert e.value.field == field


def test_too_many_faults_are_refused() -> None:
    counts, gyro, acc, t = _readings()
    with pytest.raises(ParameterError, match="at most 16"):
        faulted([SensorFault("heel", "dead")] * 17, counts, gyro, acc, t, BOARD)


def test_a_fault_in_a_walk_reaches_the_readings_not_the_foot() -> None:
    # the heel's sensor dead from 2 s: the controller reads 0 from then (and the loaded
    # heel before), while the heel still bears on the ground (the true contact force)
    leg = exoleg.paper_leg()
    r = simulate_walk(leg, 30.0, strides=2, seed=1,
                      faults=(SensorFault("heel", "dead", 2.0),))
    after = r.t >= 2.0
    assert np.all(r.fsr[after, 0] == 0.0) and r.fsr[~after, 0].max() > 100.0
    assert r.contact_force[after, 0].max() > 50.0
    clean = simulate_walk(leg, 30.0, strides=2, seed=1)
    assert np.array_equal(r.fsr[~after], clean.fsr[~after])


def test_a_fault_as_typed() -> None:
    # --sensor-fault's SPEC: CHANNEL:KIND[@START[..END]][=VALUE]
    assert SensorFault.parse("gyro:frozen@2.5..5") == SensorFault("gyro", "frozen", 2.5,
                                                                  end=5.0)
    assert SensorFault.parse("met1:offset=0.25") == SensorFault("met1", "offset", value=0.25)
    assert SensorFault.parse("accel:drift@1=-0.1") == SensorFault("accel", "drift", 1.0, -0.1)
    for text, problem in (("heel", "no ':'"), ("heel:dead@2-5", "not a number"),
                          ("heel:dead@-1", "0 <= start < end"), ("fsrs:gone", "kind")):
        with pytest.raises(ParameterError, match=problem):
            SensorFault.parse(text)
