"""OpenSim as an independent engine for the child: the pendulum test rebuilt in OpenSim
(PyPI ``opensim``, the ``opensim`` extra) and integrated with the same passive and
reflex torques, against exoleg's run (:func:`exoleg.child.assess.pendulum`).

The OpenSim model: the child's shank and foot (ankle held where the pendulum holds it)
as one body on a ``PinJoint`` at the knee, the thigh (ground) horizontal, gravity -y;
its mass, centre of mass and inertia taken from exoleg's leg (the mass matrix's knee
entry and the gravity torque at two angles -- the same rigid body, exactly); the
passive moments as an ``ExpressionBasedCoordinateForce`` whose expression is the
passive terms as the child's record holds them (scaled, contracted, each acting at the
knee through its moment arm there and continued on its tangent beyond the checked
range, as exoleg's compiled model does), written out by
:func:`passive_expression`; the reflexes' torque as exoleg's run produced it, held over
each tick (a ``CoordinateActuator`` driven by a ``PrescribedController``). OpenSim
integrates with its own error-controlled integrator; exoleg with RK4 at 1 kHz.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]


def available() -> bool:
    try:
        import opensim  # noqa: F401
    except ImportError:
        return False
    return True


def passive_expression(P: NDArray[np.void], hip: float, ankle: float) -> str:
    """The knee's passive torque (exoleg's sign, N m) as a Lepton expression in the
    coordinate ``q`` (rad) and ``qdot``: every term's force acting at the knee (through
    its moment arm there) with hip and ankle held, its stretch clamped to its range over
    the checked box and continued on its tangent."""
    R = P[0]
    d = 180.0 / math.pi
    parts = []
    for k in range(len(R["joint"])):
        arm = float(R["arm"][k][1])
        if arm == 0.0:
            continue
        c = [float(x) for x in R["coef"][k]]
        lo, hi = (float(x) for x in R["span"][k])
        x0 = c[1] * (-ankle * d) + c[3] * (hip * d)  # phi_A, phi_H held
        x = f"({x0!r}+{c[2]!r}*(-q*{d!r}))"
        clamped = f"min(max({x},{lo!r}),{hi!r})"
        parts.append(f"{arm!r}*exp({c[0]!r}+{clamped})*max(0,1+{x}-{clamped})")
    mk = "+".join(parts) + f"+{float(R['constant'][1])!r}"
    return f"-({mk})-{float(R['damping'][1])!r}*qdot"


@dataclass(frozen=True)
class Comparison:
    """exoleg's knee against OpenSim's over the test: time (s), both knee flexions (deg),
    the largest difference (deg) and the peak knee velocity each gives (deg/s)."""

    t: F64
    exoleg: F64
    opensim: F64
    max_difference: float
    peak_velocity: tuple[float, float]
    wall_time: tuple[float, float]


def compare_pendulum(child: Any, duration: float = 5.0, accuracy: float = 1e-10
                     ) -> Comparison:
    """exoleg's pendulum test of ``child`` against OpenSim's (see the module)."""
    import time

    import opensim as osim

    from exoleg.child.assess import child_leg, pendulum
    from exoleg.child.compiled import child_records

    t0 = time.perf_counter()
    ex = pendulum(child, duration=duration)
    t_ex = time.perf_counter() - t0
    leg = child_leg(child)
    h = float(ex.t[1] - ex.t[0])
    P, _, _ = child_records(child.with_(effort=False), h)
    g = float(leg.g)
    geo = np.array([math.pi / 2, 0.0, ex.ankle])
    inertia_knee = float(leg.M(geo)[1, 1])
    m = float(leg.links[1].mass + leg.links[2].mass)
    # G_2(theta) = m g (cx cos theta - cy sin theta), theta the shank's angle
    cx = float(leg.G(geo)[1]) / (m * g)
    geo[1] = math.pi / 2
    cy = -float(leg.G(geo)[1]) / (m * g)
    izz = inertia_knee - m * (cx * cx + cy * cy)

    osim.Logger.setLevelString("Warn")  # not a line per integration on the terminal
    osim.Logger.removeFileSink()  # nor an opensim.log in whatever folder this runs in
    t1 = time.perf_counter()
    model = osim.Model()
    model.setGravity(osim.Vec3(0, -g, 0))
    body = osim.Body("shank_foot", m, osim.Vec3(cx, cy, 0),
                     osim.Inertia(izz, izz, izz))  # about the COM; only zz acts here
    model.addBody(body)
    joint = osim.PinJoint("knee", model.getGround(), osim.Vec3(0), osim.Vec3(0), body,
                          osim.Vec3(0), osim.Vec3(0))
    joint.upd_coordinates(0).setName("q")
    model.addJoint(joint)
    force = osim.ExpressionBasedCoordinateForce("q", passive_expression(P, ex.hip, ex.ankle))
    force.setName("passive")
    model.addForce(force)
    act = osim.CoordinateActuator("q")
    act.setName("reflex")
    act.setOptimalForce(1.0)
    act.setMinControl(-1e6)
    act.setMaxControl(1e6)
    model.addForce(act)
    ctrl = osim.PrescribedController()
    ctrl.addActuator(act)
    fn = osim.PiecewiseConstantFunction()
    for tk, v in zip(ex.t[:-1], ex.reflex[:-1], strict=True):
        fn.addPoint(float(tk), float(v))
    fn.addPoint(float(ex.t[-1]), float(ex.reflex[-2]))
    ctrl.prescribeControlForActuator("reflex", fn)
    model.addController(ctrl)
    state = model.initSystem()
    model.getCoordinateSet().get("q").setValue(state, 0.0)
    manager = osim.Manager(model)
    manager.setIntegratorAccuracy(accuracy)
    manager.setIntegratorMaximumStepSize(h)  # a state at least every tick to compare
    state.setTime(0.0)
    manager.initialize(state)
    manager.integrate(duration)
    table = manager.getStatesTable()
    times = np.array(table.getIndependentColumn())
    col = table.getDependentColumn("/jointset/knee/q/value")
    q = np.array([col[i] for i in range(col.size())])
    speed = table.getDependentColumn("/jointset/knee/q/speed")
    v = np.array([speed[i] for i in range(speed.size())])
    t_os = time.perf_counter() - t1
    os_knee = np.interp(ex.t, times, -np.degrees(q))
    diff = float(np.max(np.abs(os_knee - ex.knee)))
    return Comparison(ex.t, ex.knee, os_knee, diff,
                      (ex.peak_velocity, float(np.max(-np.degrees(v)))), (t_ex, t_os))
