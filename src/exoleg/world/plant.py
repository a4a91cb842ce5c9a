"""The walking plant: the leg on a treadmill, its foot meeting the belt through four
compliant contacts, the pelvis free to move up and down under the body-weight share.

Model (one set of equations; stance and swing differ only in which contacts act):

* the hip stays at x = 0 (the treadmill keeps the child in place) and slides vertically:
  generalized coordinates ``(y, q0, q1, q2)`` -- pelvis height (m, hip joint above the
  belt) and the leg's joint angles;
* the pelvis carries ``body_mass`` kg (the child's body-weight share above the hips,
  :func:`body_weight_share`) at the hip;
* the other leg is a one-sided support under the pelvis (it pushes, it does not pull):
  ``F_c = max(0, k_c (y_c - y) - c_c dy)``, holding the pelvis at ``y_c`` while this
  leg swings; ``y_c`` sits a little below this leg's stance height, so in stance this
  leg carries the body weight;
* the foot touches the belt through its **sole**: a row of compliant elements from the
  heel to the toes' tips (``walking.toml`` ``sole``, in the foot frame: along the foot
  as fractions of its length, each raised above the flat sole by the arch or the toes'
  spring), each with its share of the sole's stiffness and damping: normal force
  ``max(0, k_i d - c_i dy_p)`` for a penetration d > 0, and friction
  ``-mu F_n tanh((dx_p - v_belt) / v_s)`` against the belt's speed. A soft sole is what
  lets the foot *roll*: the load moves from the heel to the forefoot and the toes as the
  foot turns over stance, instead of jumping between four hard points. Each element
  belongs to a region of the foot (the four sensors' -- heel, first and fifth metatarsal
  heads, hallux -- or the midfoot); four of them carry the footplate's FSRs, which read
  their own element's load only
  (:func:`sole_loads`): load under the midfoot, between the sensors, is not sensed.

Equations of motion, from the leg's own M, C, G (the generated kernels, with the
armature) and the kinematics of its centre of mass (generated with them:
:func:`~exoleg.dynamics.kernels.mass_height_terms`): with Y(q) = sum m_i y_ci(q),
p = dY/dq and b = dq^T (d^2 Y / dq^2) dq,

    [ m_t  p^T ] [ddy]   [ F_c + sum F_n - m_t g - b              ]
    [ p    M   ] [ddq] = [ tau - C dq - G + sum J_i^T (F_t, F_n)   ]

(m_t = body mass + leg mass; the cross terms of d/dt dT/ddq and dT/dq cancel because
p is a gradient). Contact forces are evaluated at the start of each plant step and held
over it (so an engine given the same forces steps the same trajectory).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numba import njit
from numpy.typing import NDArray

from exoleg import checks as _check
from exoleg.child.passive import passive_torque
from exoleg.device.drive import friction, series_torque
from exoleg.device.ground import ANKLE_HEIGHT, REGIONS, SOLE_MAX, Ground
from exoleg.dynamics.kernels import (
    coriolis_dq_trig,
    foot_point_jacobian_trig,
    foot_point_trig,
    gravity_trig,
    joint_trig,
    mass_height,
    mass_height_terms,
    mass_height_terms_trig,
    mass_matrix,
    mass_matrix_trig,
)
from exoleg.dynamics.model import LegModel
from exoleg.errors import ParameterError
from exoleg.layout import F8, I8, new

F64 = NDArray[np.float64]


#: the largest abs(lambda) h the plant's RK4 step is let to meet (its stability region
#: reaches 2.78 on the real axis, 2.83 on the imaginary one)
STEP_LIMIT = 2.5
#: the largest h c / m a plant step of a device of compliant units is let to meet on the
#: sole's friction (c its slope at no slip under the whole stance load, m the foot's
#: effective mass along the belt standing straight). Held over a step explicitly, the
#: friction beyond 2 reversed the slip it acts on and the foot chattered at the step's
#: rate; it is now implicit (:func:`implicit_friction`) and cannot, but such a device's
#: light foot still rang at 500 Hz at 2 steps a tick (the device ``exoleg design``
#: chose: 30 N m RMS above 100 Hz in the hip's cuffs; not the friction, the torque
#: loop's gains or the contact's damping alone), so its steps are kept this many (9 a
#: tick there: its transparent walk's residual 0.245 / 0.121 / 0.079 N m/kg against
#: 0.247 / 0.123 / 0.078 at 48 -- 0.289 / 0.141 / 0.090 with the friction explicit;
#: measured). The shipped rigid device keeps 2 steps a tick: 0.587 / 0.257 / 0.495 at
#: 2 against 0.574 / 0.252 / 0.495 at 32 (explicit: 0.593 / 0.257 / 0.498 at 2).
FRICTION_LIMIT = 2.0


@dataclass(frozen=True)
class WalkingPlant:
    """The leg (with its armature), the pelvis mass, the ground and belt, and where the
    sole's elements sit on the foot (``points`` (n, 2), foot frame, m)."""

    leg: LegModel
    body_mass: float
    ground: Ground
    belt_speed: float        # m/s, the belt moves backwards (-x) at this speed
    points: F64
    support_height: float    # y_c, m

    def __post_init__(self) -> None:
        _check.positive("WalkingPlant", "body_mass", self.body_mass, "kg")
        v = _check.finite("WalkingPlant", "belt_speed", self.belt_speed)
        if not 0.0 <= v <= 3.0:
            raise ParameterError("WalkingPlant", "belt_speed", f"{v:g} m/s is outside 0-3 m/s")

    @classmethod
    def of(cls, leg: LegModel, body_mass: float, belt_speed: float,
           ground: Ground | None = None, ankle_height: float = ANKLE_HEIGHT,
           support_height: float | None = None) -> WalkingPlant:
        """The plant for ``leg`` carrying ``body_mass`` kg at the pelvis. The flat sole
        lies ``ankle_height`` + the footplate below the ankle joint (default
        :data:`ANKLE_HEIGHT`), its raised elements above it. ``support_height``: where the other
        leg holds the pelvis; default the standing height less the ground's drop."""
        gr = Ground.default() if ground is None else ground
        h = _check.finite("WalkingPlant", "ankle_height", ankle_height)
        if not 0.0 <= h <= 0.2:
            raise ParameterError("WalkingPlant", "ankle_height", f"{h:g} m is outside 0-0.2 m")
        a3 = float(leg.lengths[2])
        depth = h + gr.sole
        pts = sole_points(gr, a3, depth)
        standing = float(leg.lengths[0] + leg.lengths[1] + depth)  # hip above the sole
        return cls(leg=leg, body_mass=float(body_mass), ground=gr, belt_speed=float(belt_speed),
                   points=pts, support_height=(standing - gr.support_drop
                                               if support_height is None else support_height))

    def step_problem(self, h: float) -> str:
        """Why the plant's RK4 step of ``h`` s would diverge ('' when it would not): the
        stiffest mode it meets, the pelvis on the whole sole and the other leg's
        support (mass: the pelvis's share and the leg; stiffness and damping: the
        ground's), has eigenvalues lambda; RK4 is stable for abs(lambda) h below 2.78 on the
        real axis and 2.83 on the imaginary one (its stability region), taken as 2.5."""
        g = self.ground
        m = self.body_mass + float(sum(link.mass for link in self.leg.links))
        k = g.stiffness + g.support_stiffness
        c = g.damping + g.support_damping
        lam = float(np.max(np.abs(np.roots([m, c, k]))))
        if lam * h <= STEP_LIMIT:
            return ""
        return (f"the contact (stiffness {g.stiffness:g} N/m, damping {g.damping:g} N s/m "
                f"for the sole, on {m:.1f} kg) has a mode of {lam:.3g} /s: the plant's step of "
                f"{h * 1e3:g} ms diverges above {STEP_LIMIT / h:.3g} /s (RK4: |lambda| h "
                f"<= {STEP_LIMIT:g}); soften the contact or take more substeps")

    def friction_rate(self) -> float:
        """c / m, 1/s: the sole's friction slope at no slip under the whole stance load
        (mu (body mass + leg) g / slip speed) over the foot's effective mass along the
        belt at its lightest sole element, standing straight (1 / (J_x M^-1 J_x^T), M
        with the armature the links carry)."""
        from exoleg.dynamics.kernels import foot_point_jacobian

        g = self.ground
        q = np.zeros(3)
        Mi = np.linalg.inv(self.leg.M(q))
        J = np.empty((2, 3))
        m = math.inf
        for px, py in self.points:
            foot_point_jacobian(q, self.leg.p, float(px), float(py), J)
            m = min(m, 1.0 / float(J[0] @ Mi @ J[0]))
        c = g.friction * (self.body_mass + self.leg_mass) * self.leg.g / g.slip_speed
        return c / m

    def fewest_substeps(self, tick: float) -> int:
        """The fewest plant steps per control tick of ``tick`` s that keep the sole's
        friction within :data:`FRICTION_LIMIT` (:meth:`friction_rate`)."""
        return max(1, math.ceil(tick * self.friction_rate() / FRICTION_LIMIT - 1e-9))

    @property
    def depth(self) -> float:
        """The flat sole's depth below the ankle joint, m."""
        return float(-self.points[:, 1].min())

    @property
    def standing_height(self) -> float:
        """Hip height above the belt standing straight, foot flat, m."""
        return float(self.leg.lengths[0] + self.leg.lengths[1] + self.depth)

    @property
    def leg_mass(self) -> float:
        return float(sum(lk.mass for lk in self.leg.links))

    def record(self) -> NDArray[np.void]:
        """What the compiled plant takes (:data:`PLANT`)."""
        gr = self.ground
        r = new(PLANT)
        r["body_mass"], r["g"] = self.body_mass, self.leg.g
        r["friction"], r["slip_speed"] = gr.friction, gr.slip_speed
        r["support_stiffness"], r["support_damping"] = gr.support_stiffness, gr.support_damping
        r["support_height"], r["belt_speed"] = self.support_height, self.belt_speed
        n = len(gr.elements)
        r["n"] = n
        r["points"][0, :n] = self.points
        r["k"][0, :n] = [e.share * gr.stiffness for e in gr.elements]
        r["c"][0, :n] = [e.share * gr.damping for e in gr.elements]
        r["region"][0, :n] = [REGIONS.index(e.region) for e in gr.elements]
        r["sensed"][0, :n] = [int(e.sensor) for e in gr.elements]
        return r


def sole_points(ground: Ground, foot_length: float, depth: float) -> F64:
    """The sole's elements (n, 2) in the foot frame, m: ``x`` of ``foot_length`` forward
    of the ankle, ``depth`` below it less their lift."""
    return np.array([[e.x * foot_length, -depth + e.lift] for e in ground.elements])


#: The walking plant's parameters as its compiled functions read them
#: (:meth:`WalkingPlant.record`): the pelvis mass (kg), g, the sole's mu and slip speed
#: (m/s), the other leg's support k, c and height (m), the belt's speed (m/s; the
#: scenery changes it and the support height as it runs); the sole's ``n`` elements: where
#: they sit (x, y) in the foot frame (m), their k (N/m) and c (N s/m), their region (index
#: into :data:`REGIONS`) and whether its FSR sits on them (1) or not (0).
PLANT = np.dtype([("body_mass", F8), ("g", F8),
                  ("friction", F8), ("slip_speed", F8), ("support_stiffness", F8),
                  ("support_damping", F8), ("support_height", F8), ("belt_speed", F8),
                  ("n", I8), ("points", F8, (SOLE_MAX, 2)), ("k", F8, SOLE_MAX),
                  ("c", F8, SOLE_MAX), ("region", I8, SOLE_MAX),
                  ("sensed", I8, SOLE_MAX)])


@njit(cache=True, error_model="numpy", inline="always")
def contact_points(p, w, y, q, sc, dq, dy, out):  # type: ignore[no-untyped-def]
    """Positions and velocities of the sole's elements: out (:data:`SOLE_MAX`, 4) rows (x,
    y, dx, dy), world frame (hip at (0, y)), the first ``n`` filled; the leg's kinematics
    are the generated :func:`~exoleg.dynamics.kernels.foot_point` (``sc``: the joints' sin
    and cos, :func:`~exoleg.dynamics.kernels.joint_trig`)."""
    P = w[0].points
    for k in range(w[0].n):
        x, yy, vx, vy, _ = foot_point_trig(sc, q, dq, p, P[k, 0], P[k, 1])
        out[k, 0], out[k, 1], out[k, 2], out[k, 3] = x, y + yy, vx, dy + vy


@njit(cache=True, error_model="numpy", inline="always")
def contact_forces(w, pts, F):  # type: ignore[no-untyped-def]
    """Forces F (:data:`SOLE_MAX`, 2) (tangential x, normal y) of the belt on the sole's
    elements from their state ``pts`` (:func:`contact_points`): spring-damper normal
    force, never pulling; friction against the belt (none on the unused rows). Returns the
    total normal force."""
    W = w[0]
    total = 0.0
    for k in range(SOLE_MAX):
        d = -pts[k, 1] if k < W.n else 0.0  # the belt surface is y = 0
        if d > 0.0:
            fn = max(0.0, W.k[k] * d - W.c[k] * pts[k, 3])
            slip = pts[k, 2] + W.belt_speed  # the belt moves at -belt_speed
            F[k, 0] = -W.friction * fn * math.tanh(slip / W.slip_speed)
            F[k, 1] = fn
            total += fn
        else:
            F[k, 0] = 0.0
            F[k, 1] = 0.0
    return total


@njit(cache=True, error_model="numpy", inline="always")
def support_force(w, y, dy):  # type: ignore[no-untyped-def]
    """The other leg under the pelvis: one-sided spring-damper, N (>= 0)."""
    W = w[0]
    return max(0.0, W.support_stiffness * (W.support_height - y) - W.support_damping * dy)


@njit(cache=True, error_model="numpy", inline="always")
def _solve4(A, r):  # type: ignore[no-untyped-def]
    """Solve the 4 x 4 system A x = r in place (Gaussian elimination with partial
    pivoting): ``A`` is overwritten, ``r`` becomes x."""
    for c in range(4):
        piv = c
        for i in range(c + 1, 4):
            if abs(A[i, c]) > abs(A[piv, c]):
                piv = i
        if piv != c:
            for j in range(4):
                A[c, j], A[piv, j] = A[piv, j], A[c, j]
            r[c], r[piv] = r[piv], r[c]
        for i in range(c + 1, 4):
            f = A[i, c] / A[c, c]
            for j in range(c, 4):
                A[i, j] -= f * A[c, j]
            r[i] -= f * r[c]
    for i in range(3, -1, -1):
        t = r[i]
        for j in range(i + 1, 4):
            t -= A[i, j] * r[j]
        r[i] = t / A[i, i]


#: The work of a plant step (:func:`walking_step`, :func:`walking_step_series`,
#: :func:`step_contacts`), kept by its caller (the simulated device: its DEVICE record's
#: ``step``) so that no step allocates: RK4's slopes ``k`` (4, 14), the stage's state
#: ``s`` and the step's start ``z`` (14,: the plant's 8, then the rotors' 6), the leg's
#: mass matrix ``M``, its Coriolis, gravity and joint torques by row ``V`` (3, 3), the
#: 4 x 4 system ``A`` and its right-hand side ``r`` (which becomes (ddy, ddq)), the
#: rotors' accelerations ``dr`` (3,) and a sole point's Jacobian ``J`` (2, 3).
STEP = np.dtype([("k", F8, (4, 14)), ("s", F8, 14), ("z", F8, 14), ("M", F8, (3, 3)),
                 ("V", F8, (3, 3)), ("A", F8, (4, 4)), ("r", F8, 4), ("dr", F8, 3),
                 ("J", F8, (2, 3))])


@njit(cache=True, error_model="numpy", inline="always")
def generalized_contact(p, w, sc, F, out, J):  # type: ignore[no-untyped-def]
    """Generalized forces (4,) of the elements' forces F (:data:`SOLE_MAX`, 2): on y the
    sum of the normal forces, on the joints sum J_i^T F_i (the generated
    :func:`~exoleg.dynamics.kernels.foot_point_jacobian` at the joints' sin and cos
    ``sc``; ``J``: a (2, 3) to work in)."""
    P = w[0].points
    out[:] = 0.0
    for k in range(w[0].n):
        out[0] += F[k, 1]
        foot_point_jacobian_trig(sc, p, P[k, 0], P[k, 1], J)
        for j in range(3):
            out[1 + j] += J[0, j] * F[k, 0] + J[1, j] * F[k, 1]


@njit(cache=True, error_model="numpy", inline="always")
def walking_accel(p, w, x, tau, gen, W):  # type: ignore[no-untyped-def]
    """(ddy, ddq) at the state x (8,) under joint torques tau (3,) and the generalized
    external forces ``gen`` (4,) (contacts and support), gravity included, into
    ``W.r`` (``W``: the step's work, :data:`STEP`)."""
    M, V, A, r = W.M, W.V, W.A, W.r
    q, dq = x[1:4], x[5:8]
    sc = joint_trig(q)  # once for the four kernels
    mass_matrix_trig(sc, p, M)
    Cq, G = V[0], V[1]
    coriolis_dq_trig(sc, dq, p, Cq)
    gravity_trig(sc, p, w[0].g, G)
    y0, y1, y2, b, m_leg = mass_height_terms_trig(sc, dq, p)
    pv = (y0, y1, y2)
    mt = w[0].body_mass + m_leg
    A[0, 0] = mt
    for j in range(3):
        A[0, 1 + j] = pv[j]
        A[1 + j, 0] = pv[j]
        for k in range(3):
            A[1 + j, 1 + k] = M[j, k]
        r[1 + j] = tau[j] - Cq[j] - G[j] + gen[1 + j]
    r[0] = gen[0] - mt * w[0].g - b
    _solve4(A, r)


@njit(cache=True, error_model="numpy")
def walking_energy(p, w, y, dy, q, dq):  # type: ignore[no-untyped-def]
    """Kinetic + potential energy of leg and pelvis, J (potential zero at y = 0)."""
    M = np.empty((3, 3))
    mass_matrix(q, p, M)
    y0, y1, y2, _, m_leg = mass_height_terms(q, dq, p)
    pv = (y0, y1, y2)
    T = 0.5 * (w[0].body_mass + m_leg) * dy * dy
    for j in range(3):
        T += dy * pv[j] * dq[j]
        for k in range(3):
            T += 0.5 * dq[j] * M[j, k] * dq[k]
    # potential: Y(q) = sum m_i y_ci relative to the hip
    return T + w[0].g * ((w[0].body_mass + m_leg) * y + mass_height(q, p))


@njit(cache=True, error_model="numpy", inline="always")
def _deriv(p, w, A, P, x, tau, gen, W):  # type: ignore[no-untyped-def]
    """(ddy, ddq) at x into ``W.r`` (:data:`STEP`) with the actuators' friction (A: (3,) of
    :data:`~exoleg.device.actuator.ACTUATOR`, or an empty one for none) and the child's
    passive joint moments (P: :data:`~exoleg.child.passive.PASSIVE`, off for none)."""
    t = W.V[2]
    dq = x[5:8]
    passive_torque(P, x[1:4], dq, t)
    for i in range(3):
        t[i] += tau[i] - (friction(A[i:i + 1], dq[i]) if A.shape[0] == 3 else 0.0)
    walking_accel(p, w, x, t, gen, W)


@njit(cache=True, error_model="numpy")
def walking_step(p, w, A, P, x, tau, gen, step):  # type: ignore[no-untyped-def]
    """One RK4 step of the state x (8,) = (y, q0, q1, q2, dy, dq0, dq1, dq2), in place, with
    the joint torques ``tau`` and generalized external forces ``gen`` held (the contact
    forces of the step's start, :func:`step_contacts`); the child's passive moments
    (``P``) in every stage. ``step``: (h s, the step's work :data:`STEP`)."""
    h, W = step
    k, s, a = W.k, W.s[:8], W.r
    for i in range(8):
        s[i] = x[i]
    for stage in range(4):
        c = 0.0 if stage == 0 else (0.5 if stage < 3 else 1.0)
        if stage > 0:
            for i in range(8):
                s[i] = x[i] + c * h * k[stage - 1, i]
        _deriv(p, w, A, P, s, tau, gen, W)
        for i in range(4):
            k[stage, i] = s[4 + i]
            k[stage, 4 + i] = a[i]
    for i in range(8):
        x[i] += h / 6.0 * (k[0, i] + 2.0 * k[1, i] + 2.0 * k[2, i] + k[3, i])


@njit(cache=True, error_model="numpy", inline="always")
def _deriv_series(p, w, A, P, s, drive, gen, W):  # type: ignore[no-untyped-def]
    """:func:`_deriv` with compliant units: the state s (14,) is the plant's (8,), then
    the rotors' angles and speeds at the joint's side (3 + 3); ``drive``: rows the motors'
    torques and the child's (3,) each. A rigid joint takes its motor's torque less its
    friction as :func:`_deriv` does; a compliant one the spring's, its rotor (reflected
    inertia B) driven by the motor against the spring and its own friction. ``W``: the
    step's work (:data:`STEP`): (ddy, ddq) into ``W.r``, the rotors' accelerations into
    ``W.dr`` (0 at a rigid joint, whose rotor is the link)."""
    t, dr = W.V[2], W.dr
    q, dq = s[1:4], s[5:8]
    passive_torque(P, q, dq, t)
    for i in range(3):
        a = A[i]
        if a.stiffness > 0.0:
            ts = series_torque(A[i:i + 1], q[i], dq[i], s[8 + i], s[11 + i])
            t[i] += ts + drive[1, i]
            dr[i] = (drive[0, i] - ts - friction(A[i:i + 1], s[11 + i])) / a.inertia
        else:
            t[i] += drive[0, i] + drive[1, i] - friction(A[i:i + 1], dq[i])
            dr[i] = 0.0
    walking_accel(p, w, s, t, gen, W)


@njit(cache=True, error_model="numpy")
def walking_step_series(p, w, A, P, state, drive, gen, step):  # type: ignore[no-untyped-def]
    """:func:`walking_step` for a device with compliant units: ``state`` the plant's x
    (8,) and the rotors' r (6,: angles, then speeds, at the joint's side), stepped
    together by RK4, in place, the motors' and the child's torques (``drive``, rows (2, 3)) and the
    generalized external forces held. A rigid joint's rotor is its link: its entries of r
    follow the link's. ``step``: (h s, the step's work :data:`STEP`)."""
    x, r = state
    h, W = step
    k, s, z, a, dr = W.k, W.s, W.z, W.r, W.dr
    s[:8] = x
    s[8:] = r
    z[:] = s
    for stage in range(4):
        c = 0.0 if stage == 0 else (0.5 if stage < 3 else 1.0)
        if stage > 0:
            for i in range(14):
                s[i] = z[i] + c * h * k[stage - 1, i]
        _deriv_series(p, w, A, P, s, drive, gen, W)
        for i in range(4):
            k[stage, i] = s[4 + i]
            k[stage, 4 + i] = a[i]
        for i in range(3):
            k[stage, 8 + i] = s[11 + i]
            k[stage, 11 + i] = dr[i]
    for i in range(8):
        x[i] += h / 6.0 * (k[0, i] + 2.0 * k[1, i] + 2.0 * k[2, i] + k[3, i])
    for i in range(3):
        if A[i].stiffness > 0.0:
            for j in (i, 3 + i):
                r[j] += h / 6.0 * (k[0, 8 + j] + 2.0 * k[1, 8 + j] + 2.0 * k[2, 8 + j]
                                   + k[3, 8 + j])
        else:
            r[i], r[3 + i] = x[1 + i], x[5 + i]


@njit(cache=True, error_model="numpy", inline="always")
def implicit_friction(p, w, sc, pts, F, step):  # type: ignore[no-untyped-def]
    """The sole's friction F[:, 0] as a step of ``h`` s meets it, linearly implicit: each
    element's slope within the smooth Coulomb law's band (mu F_n sech^2(slip /
    slip_speed) / slip_speed) acts as a damper on its effective mass along the belt (1 /
    (J_x M^-1 J_x^T), M the leg's with the armature its links carry, at the step's
    start), so the friction is divided by 1 + h slope / m. Held over a step explicitly,
    a slope beyond 2 m / h reverses the slip it acts on and the foot chatters at the
    step's rate within the band (:data:`FRICTION_LIMIT`); so it cannot, at any step,
    while a sliding element (beyond the band: slope ~ 0) keeps mu F_n. ``sc``: the
    joints' sin and cos; ``step``: (h, the step's work :data:`STEP`, whose ``M``, ``V``
    and ``J`` it works in)."""
    W = w[0]
    h, S = step
    M, Mi, J = S.M, S.V, S.J
    det = 0.0  # the mass matrix's adjugate and determinant, at the first contact (none in swing)
    P = W.points
    for k in range(W.n):
        if F[k, 1] <= 0.0:
            continue
        if det == 0.0:
            mass_matrix_trig(sc, p, M)
            a, b, c = M[0, 0], M[0, 1], M[0, 2]
            d, e, f = M[1, 1], M[1, 2], M[2, 2]
            Mi[0, 0], Mi[0, 1], Mi[0, 2] = d * f - e * e, c * e - b * f, b * e - c * d
            Mi[1, 1], Mi[1, 2], Mi[2, 2] = a * f - c * c, b * c - a * e, a * d - b * b
            det = a * Mi[0, 0] + b * Mi[0, 1] + c * Mi[0, 2]
        foot_point_jacobian_trig(sc, p, P[k, 0], P[k, 1], J)
        x0, x1, x2 = J[0, 0], J[0, 1], J[0, 2]
        inv_m = (x0 * (Mi[0, 0] * x0 + 2.0 * (Mi[0, 1] * x1 + Mi[0, 2] * x2))
                 + x1 * (Mi[1, 1] * x1 + 2.0 * Mi[1, 2] * x2) + x2 * Mi[2, 2] * x2) / det
        ch = math.cosh((pts[k, 2] + W.belt_speed) / W.slip_speed)
        F[k, 0] /= 1.0 + h * W.friction * F[k, 1] / (W.slip_speed * ch * ch) * inv_m


@njit(cache=True, error_model="numpy")
def step_contacts(p, w, x, pts, F, gen, step):  # type: ignore[no-untyped-def]
    """The contact and support forces at state x over a step: the sole's points into
    pts (:data:`SOLE_MAX`, 4), their forces into F (:data:`SOLE_MAX`, 2) -- the friction
    as the step meets it, :func:`implicit_friction` --, the generalized forces (support
    included) into gen (4,) (``step``: (h s, the step's work :data:`STEP`)).
    Returns the support force."""
    sc = joint_trig(x[1:4])  # once for the points, the friction and the Jacobians
    contact_points(p, w, x[0], x[1:4], sc, x[5:8], x[4], pts)
    contact_forces(w, pts, F)
    implicit_friction(p, w, sc, pts, F, step)
    generalized_contact(p, w, sc, F, gen, step[1].J)
    fc = support_force(w, x[0], x[4])
    gen[0] += fc
    return fc


@njit(cache=True, error_model="numpy")
def sole_loads(w, F, region, sensor):  # type: ignore[no-untyped-def]
    """The sole's normal forces F (:data:`SOLE_MAX`, 2) per sensor region into ``region``
    (4,: the whole region's load, N; the midfoot's in none) and what each FSR carries into
    ``sensor`` (4,: its own element's load, N)."""
    W = w[0]
    for i in range(4):
        region[i] = 0.0
        sensor[i] = 0.0
    for k in range(W.n):
        r = W.region[k]
        if r < 4:
            region[r] += F[k, 1]
            if W.sensed[k] == 1:
                sensor[r] = F[k, 1]


def contact_buffers() -> tuple[F64, F64, F64]:
    """Work arrays for :func:`step_contacts`: points (:data:`SOLE_MAX`, 4), forces
    (:data:`SOLE_MAX`, 2), generalized forces (4,)."""
    return np.zeros((SOLE_MAX, 4)), np.zeros((SOLE_MAX, 2)), np.zeros(4)
