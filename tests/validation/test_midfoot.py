"""The load sliding between the foot board's point sensors (issue 41): on real foot-force
walks through four point sensors, the load crossing the forefoot between them in
push-off reads, to the FSRs, as the foot lifting and landing again. Constructed here on
a simulated walk: in each push-off (its true heel off to toe off) 30 % of it, in the
middle, the four sensors read what they read in swing (unloaded, their noise), the foot
still on the ground. Reference: the walk's true events (exoleg.sim.events, from the
contact forces)."""

from __future__ import annotations

import numpy as np


def test_the_load_between_the_sensors_is_not_a_lift_with_the_foots_imu() -> None:
    from exoleg.child.model import ChildModel
    from exoleg.control import gait_phase as gp
    from exoleg.control.replay import detect_all, event_rows
    from exoleg.sim.walk import simulate_walk
    from exoleg.sizing import personalized_leg
    from exoleg.sizing.child import population_child
    from exoleg.system.config import DeviceConfig

    c, _ = population_child(None, "female", 10.0, 50.0)
    r = simulate_walk(personalized_leg(c), c.mass, strides=20, child=ChildModel.of(c))
    true = r.true_events()
    ho, to = np.nonzero(true & gp.Event.HO)[0], np.nonzero(true & gp.Event.TO)[0]
    counts = r.fsr.copy()
    gaps = 0
    for a in ho:
        after = to[to > a]
        if len(after) < 2:
            continue
        b = int(after[0])
        half = int(0.15 * (b - a))
        swing = int(b + 0.2 * (after[1] - b))  # mid-swing after it (swing: ~40 %)
        counts[(a + b) // 2 - half:(a + b) // 2 + half] = r.fsr[swing:swing + 2 * half]
        gaps += 1
    assert gaps >= 15
    cfg = DeviceConfig.load()
    d = cfg.detector.record(cfg.fsr_floor_counts, 1.1, cfg.sensors.gyro_range,
                            cfg.sensors.accel_range)
    walking = r.t >= r.walk_start

    def rows(gyro: np.ndarray) -> dict[str, dict[str, float]]:
        bits = detect_all(d, gp.new_state(d), counts, np.ascontiguousarray(gyro),
                          r.accel, r.t)
        return {x["event"]: x for x in event_rows([(r.t[walking], bits[walking],
                                                    true[walking])])}

    # the device's detector (the FSRs and the foot's IMU): no event added, none missed
    fused = rows(r.gyro)
    for event in ("initial contact", "toe off"):
        assert fused[event]["false_rate"] == 0 and fused[event]["missed_rate"] == 0
    # the FSRs alone (the gyroscope failed) read each gap as a lift and a landing: the
    # construction reproduces what real walks showed (measured: about one extra toe off
    # and initial contact a stride) -- left to the IMU
    alone = rows(np.full_like(r.gyro, np.nan))
    assert alone["initial contact"]["false_rate"] > 0.3
