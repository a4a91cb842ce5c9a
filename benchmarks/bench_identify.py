"""Benchmark: identification (issue 25) -- the regressor over a plan's samples against
Pinocchio's on the same job, the estimate, and the plan's design.

Run: ``python benchmarks/bench_identify.py``. Figures (issue 25 states no speed target;
a clinic identifies once per fitting): what a 2-minute plan costs to identify once
recorded, and the regressor against Pinocchio's.

* the regressor Y(q, dq, ddq) at a 2-minute plan's 12,000 samples (every 10 ms):
  exoleg's generated kernel over the batch (:meth:`exoleg.LegModel.regressor`) against
  Pinocchio's ``computeJointTorqueRegressor`` called per state on the exported URDF;
* the estimate (:func:`exoleg.identify.estimate.identify_leg`) on those samples;
* the design of a plan (:func:`exoleg.identify.plan.design_plan`, 20 candidates).
Best of 5 after a warm-up.
"""

from __future__ import annotations

import time

from exoleg.control.safety import SafetyLimits
from exoleg.device import with_actuators
from exoleg.device.actuator import paper_actuators
from exoleg.identify.base import actuator_friction, friction_columns
from exoleg.identify.estimate import identify_leg
from exoleg.identify.plan import design_plan, plan_limits
from exoleg.sizing import Child, personalized_leg


def best(f, n: int = 5) -> float:  # type: ignore[no-untyped-def]
    f()
    times = []
    for _ in range(n):
        t0 = time.perf_counter()
        f()
        times.append(time.perf_counter() - t0)
    return min(times)


def main() -> None:
    acts = paper_actuators()
    leg = with_actuators(personalized_leg(Child(age=10, sex="male", height=1.40, mass=32.0)))
    lim = plan_limits(SafetyLimits.paper(), acts)
    t_design = best(lambda: design_plan(leg, acts, lim, candidates=20), n=1)
    plan = design_plan(leg, acts, lim, candidates=20)
    _, q, dq, ddq = plan.sample(0.01)
    theta, smooth = actuator_friction(acts)
    tau = leg.inverse_dynamics(q, dq, ddq) + friction_columns(dq, smooth) @ theta
    n = len(q)
    t_ours = best(lambda: leg.regressor(q, dq, ddq))
    rows = [("regressor, exoleg (batch)", t_ours, "")]
    try:
        import pinocchio as pin

        from exoleg.validate.engines import PinocchioLeg

        model = PinocchioLeg(leg).model
        data = model.createData()

        def pinocchio() -> None:
            for k in range(n):
                pin.computeJointTorqueRegressor(model, data, q[k], dq[k], ddq[k])

        t_pin = best(pinocchio)
        rows.append(("regressor, Pinocchio (per state)", t_pin,
                     f"exoleg {t_pin / t_ours:.1f}x faster"))
    except ImportError:
        rows.append(("regressor, Pinocchio", float("nan"), "not installed (exoleg[validate])"))
    t_est = best(lambda: identify_leg(leg, q, dq, ddq, tau, smooth))
    rows.append(("identify_leg (estimate)", t_est, ""))
    rows.append(("design_plan (20 candidates)", t_design, ""))
    print(f"identification of a {plan.duration:g} s plan, {n} samples every 10 ms")
    for name, t, note in rows:
        print(f"  {name:36s} {t * 1e3:10.2f} ms  {t / n * 1e6:8.3f} us/sample  {note}")


if __name__ == "__main__":
    main()
