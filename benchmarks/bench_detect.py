"""Benchmark: the gait-phase detector's tick (issue 24) and ``exoleg detect``'s replay.

Run: ``python benchmarks/bench_detect.py``. Target (issue 24): the detector's tick
stays compiled and <= 200 ns.

* the tick: :func:`exoleg.control.gait_phase.detect` over 60 s of a fitted child's
  simulated walk (their FSR counts, gyroscope and accelerometer at 1 kHz: the FSRs' path
  fused with the gyroscope and the IMU's own path beside it, every phase and event; and
  the IMU alone, the FSRs reading NaN), in the compiled loop
  :func:`exoleg.control.replay.detect_all` repeated to 600,000 ticks, per tick;
* the replay: :func:`exoleg.control.replay.detect_events` over the same walk held at
  1 kHz, per second of recording (what ``exoleg detect`` spends beyond reading the file).
There is no like job in Pinocchio or MuJoCo (neither detects gait events): the figure
is against the target and the 1 ms tick. Best of 5 after a warm-up.
"""

from __future__ import annotations

import time

import numpy as np

from exoleg.control import gait_phase as gp
from exoleg.control.replay import Recording, detect_all, detect_events
from exoleg.sim.walk import simulate_walk
from exoleg.sizing import Child, personalized_leg
from exoleg.system.config import DeviceConfig

TARGET_NS = 200.0


def main() -> None:
    child = Child(age=10, sex="male", height=1.40, mass=32.0)
    w = simulate_walk(personalized_leg(child), 32.0, strides=54)  # about 60 s
    counts = np.ascontiguousarray(np.tile(w.fsr, (10, 1)))
    gyro = np.ascontiguousarray(np.tile(w.gyro, 10))
    acc = np.ascontiguousarray(np.tile(w.accel, (10, 1)))
    t = np.arange(len(counts)) * 1e-3
    cfg = DeviceConfig.load()
    d = cfg.detector.record(cfg.fsr_floor_counts, 1.1, cfg.sensors.gyro_range,
                            cfg.sensors.accel_range)
    other = np.full_like(counts, np.nan)  # no insole under the other foot
    detect_all(d, gp.new_state(d), counts[:1000], gyro[:1000], acc[:1000], t[:1000],
               other[:1000])
    for label, c in (("FSRs and IMU", counts), ("the IMU alone", np.full_like(counts, np.nan))):
        ticks = []
        for _ in range(5):
            st = gp.new_state(d)
            t0 = time.perf_counter()
            bits = detect_all(d, st, c, gyro, acc, t, other)
            ticks.append((time.perf_counter() - t0) / len(t))
        tick = min(ticks) * 1e9
        events = int(np.count_nonzero(bits & gp.Event.IC))
        print(f"detector tick, {label}: {tick:.1f} ns over {len(t)} ticks ({events} "
              f"initial contacts) -- target <= {TARGET_NS:g} ns: "
              f"{'met' if tick <= TARGET_NS else 'NOT met'}; {1e6 / tick:.0f}x within a "
              "1 ms tick")
    rec = Recording(t=w.t, counts=np.ascontiguousarray(w.fsr), gyro=w.gyro, accel=w.accel,
                    reference=None, source="simulated walk", rate_hz=1000.0)
    detect_events(rec)
    replay = min(_timed(lambda: detect_events(rec)) for _ in range(5)) / w.t[-1]
    print(f"exoleg detect's replay: {replay * 1e3:.3f} ms per second of recording "
          f"({1.0 / replay:.0f}x real time)")


def _timed(f) -> float:  # type: ignore[no-untyped-def]
    t0 = time.perf_counter()
    f()
    return time.perf_counter() - t0


if __name__ == "__main__":
    main()
