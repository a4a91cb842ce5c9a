"""Benchmark: the child as an actor (issue 22) -- walking with the full device and the
child, the child's tick, and the pendulum test against OpenSim integrating the same.

Run: ``python benchmarks/bench_child.py``. Targets (issue 22, raised by issue 37):
walking with the full device and the child >= 150x real time on one core; the OpenSim
comparison's figures.

* walking: :func:`exoleg.sim.walk.simulate_walk`, 60 s of treadmill walking with the
  whole device (contacts, sensors, detection, hierarchy, safety layer, drives) on a
  fitted 10-year-old, without a child actor and with one (passive moments in every RK4
  stage, spasticity and effort each tick), end to end after a warm-up run;
* the child's tick (:func:`exoleg.child.compiled.child_tick`, moderate spasticity, effort
  on) and the passive moments (:func:`exoleg.child.passive.passive_torque`), compiled
  loops of 1,000,000 calls, per call;
* the pendulum test, 5 s: exoleg (RK4, 1 kHz, Python loop over compiled torques)
  against OpenSim 4.6 (its error-controlled integrator at accuracy 1e-10, a state at
  least every 1 ms) on the same body and torques (:mod:`exoleg.validate.opensim_child`),
  with the largest difference of their knee angles.
"""

from __future__ import annotations

import time
import warnings

import numpy as np
from numba import njit

from exoleg.child.compiled import child_records, child_tick
from exoleg.child.model import ChildModel, Spasticity
from exoleg.child.passive import passive_torque
from exoleg.sim.walk import simulate_walk
from exoleg.sizing import Child, personalized_leg

DURATION = 60.0
CALLS = 1_000_000


@njit  # not cached: numba would keep stale code when only exoleg's kernels change
def _child_loop(P, C, S, n, out):  # type: ignore[no-untyped-def]
    q = np.array([0.1, -0.3, 0.05])
    dq = np.array([0.5, -1.0, 0.2])
    acc = 0.0
    for k in range(n):
        q[1] = -0.3 + 0.2 * np.sin(k * 1e-3)
        child_tick((P, C, S), q, dq, 1e-3, True, (k % 1100) / 1100.0, k % 1100 < 660, out)
        acc += out[1]
    return acc


@njit  # not cached, as above
def _passive_loop(P, n, out):  # type: ignore[no-untyped-def]
    q = np.array([0.1, -0.3, 0.05])
    dq = np.zeros(3)
    acc = 0.0
    for k in range(n):
        q[1] = -0.3 + 0.2 * np.sin(k * 1e-3)
        passive_torque(P, q, dq, out)
        acc += out[1]
    return acc


def main() -> None:
    warnings.simplefilter("ignore")
    c = Child(age=10, sex="male", height=1.40, mass=32.0)
    leg = personalized_leg(c)
    child = ChildModel("bench", 10, 1.40, 32.0, 2, spasticity=Spasticity.preset("moderate"),
                       sex="male")
    strides = int(round((DURATION - 1.0) / 1.1))
    rows = []
    for name, ch in (("walking, no child actor", None), ("walking, with the child", child)):
        simulate_walk(leg, 32.0, strides=1, child=ch)  # compile / load the cache
        t0 = time.perf_counter()
        r = simulate_walk(leg, 32.0, strides=strides, child=ch)
        sec = time.perf_counter() - t0
        rows.append((f"{name}, {r.t[-1]:.0f} s", sec, r.t[-1] / sec))
    P, C, S = child_records(child, 1e-3)
    out = np.zeros(3)
    _child_loop(P, C, S, 10, out)
    t0 = time.perf_counter()
    _child_loop(P, C, S, CALLS, out)
    per_tick = (time.perf_counter() - t0) / CALLS
    _passive_loop(P, 10, out)
    t0 = time.perf_counter()
    _passive_loop(P, CALLS, out)
    per_passive = (time.perf_counter() - t0) / CALLS
    print(f"{'':<52} {'wall':>12} {'x real time':>12}")
    for name, sec, rt in rows:
        print(f"{name:<52} {sec:>10.3f} s {rt:>12,.0f}")
    print(f"{'the child tick (moderate spasticity, effort)':<52} {per_tick * 1e9:>9.0f} ns")
    print(f"{'passive moments, one call':<52} {per_passive * 1e9:>9.0f} ns")
    print(f"walking with the child costs {rows[1][1] / rows[0][1]:.2f}x walking without")
    print(f"target: walking with the child >= 150x real time: {rows[1][2]:,.0f}x "
          f"({'meets' if rows[1][2] >= 150 else 'MISSES'})")
    from exoleg.validate.opensim_child import available, compare_pendulum

    if not available():
        print("OpenSim not installed (pip install exoleg[opensim]): its comparison skipped")
        return
    td = ChildModel.typical("td", 13, 1.56, 45.0, "male")
    compare_pendulum(td, duration=0.1)  # load OpenSim, compile exoleg's side
    print(f"\n{'pendulum test, 5 s':<28} {'exoleg s':>10} {'OpenSim s':>10} {'ratio':>8} "
          f"{'max |diff| deg':>15} {'peak deg/s (exoleg, OpenSim)':>30}")
    for name, ch in (("typical", td),
                     ("moderate spasticity", td.with_(spasticity=Spasticity.preset("moderate")))):
        cmp = compare_pendulum(ch)
        ex, os_ = cmp.wall_time
        print(f"{name:<28} {ex:>10.3f} {os_:>10.3f} {os_ / ex:>7.1f}x {cmp.max_difference:>15.2e} "
              f"{cmp.peak_velocity[0]:>14.3f} {cmp.peak_velocity[1]:>14.3f}")


if __name__ == "__main__":
    main()
