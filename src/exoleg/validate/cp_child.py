"""A real child with CP as the check of exoleg's child (issue 41): predictcpgait's subject 1
(Falisse et al. 2020, Front Hum Neurosci 14:40; MIT licence), a child with spastic
diplegic CP, shipped as ``data/child/predictcpgait_subject1_r.csv`` (their right leg's
angles over a gait cycle with the SD over 4 trials, rates and accelerations, the pelvis's
motion, the inverse-dynamics moments and the foot's ground reaction force).

The checks, printed by ``exoleg validate --cp-child``:

* **Inverse dynamics in 3D** (:func:`inverse_dynamics_3d`): the right leg of the subject's
  own OpenSim model (``data/child/predictcpgait_subject1_model.toml``, :class:`SubjectLeg`)
  through every shipped coordinate, loaded by the whole ground reaction force at the
  centre of pressure the ankle's and subtalar's shipped moments place: the hip's and
  knee's moments against the shipped ones.
* **Inverse dynamics on the planar leg** (:func:`inverse_dynamics`): exoleg's leg for a child of the
  subject's size (33.1 kg, the model's mass; 1.375 m, the height whose (H / 1.75)^5 makes
  the child's generic hamstring moment 0.30x Riener's adults, child-references) moved
  through the shipped kinematics, its hip carried by the pelvis's measured acceleration,
  loaded by the measured ground reaction force -- at the ankle, with the moment about it
  that the shipped ankle moment implies (the centre of pressure is not shipped) -- gives
  the hip and knee moments, against the shipped moments.
* **The simulated child walking it** (:func:`walk_match`): the child as an actor
  intending this gait, in the device in transparent mode, against the real child's mean
  +- 1 SD.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from exoleg.errors import ParameterError
from exoleg.reference.cp_child import HEIGHT_M, MASS_KG, cp_child_gait

F64 = NDArray[np.float64]

def cp_child_leg() -> Any:
    """exoleg's own leg (no device) for a child of the subject's size: a 10-year-old of
    :data:`HEIGHT_M` and :data:`MASS_KG` (their age and sex are not shipped: the
    segments' shares do not depend much on either, :mod:`exoleg.sizing.personal`)."""
    from exoleg.child.assess import child_leg
    from exoleg.child.model import ChildModel

    return child_leg(ChildModel.typical("predictcpgait subject 1", 10.0, HEIGHT_M,
                                        MASS_KG, "male"))


def inverse_dynamics(leg: Any = None, tilt_sign: float = 1.0) -> dict[str, Any]:
    """The hip and knee moments exoleg's leg needs to move through the shipped gait under
    the shipped ground reaction force (see the module), against the shipped moments.

    Parameters
    ----------
    leg : LegModel, optional
        Default :func:`cp_child_leg`.
    tilt_sign : float, default 1.0
        How the pelvis's tilt adds to the hip's angle to make the thigh's from the
        vertical (+1: the tilt is anticlockwise seen from the right, as the hip's
        flexion is).

    Returns
    -------
    dict
        ``tau`` (100, 3) N m exoleg's moments (the ankle's is the shipped one, by
        construction), ``shipped`` (100, 3), ``rms_error`` and ``rms_shipped`` per joint
        (N m) and ``relative`` (their ratio).
    """
    g = cp_child_gait()
    leg = cp_child_leg() if leg is None else leg
    # the thigh's angle from the vertical: the hip's flexion from the pelvis plus the
    # pelvis's tilt; the knee's and the ankle's are relative already
    q, dq, ddq = g.q.copy(), g.dq.copy(), g.ddq.copy()
    q[:, 0] += tilt_sign * g.tilt
    dq[:, 0] += tilt_sign * g.tilt_rate
    ddq[:, 0] += tilt_sign * g.tilt_acc
    free = np.array([leg.inverse_dynamics(q[k], dq[k], ddq[k]) for k in range(len(q))])
    # the hip carried by the pelvis: each link's centre of mass accelerates with it too
    jac = leg.jacobians(q)
    masses = [float(ln.mass) for ln in leg.links]
    for name, m in zip(("com_thigh", "com_shank", "com_foot"), masses, strict=True):
        free += m * np.einsum("kij,ki->kj", jac[name], g.pelvis_acc)
    # the ground's force at the ankle (its Jacobian's transpose) and its moment about the
    # ankle: a pure moment on the foot, the same at every joint, set so the ankle's
    # moment is the shipped one
    fk = leg.fk(q)
    lever_knee = fk["ankle"] - fk["knee"]
    lever_hip = fk["ankle"] - fk["hip"]
    cross_knee = lever_knee[:, 0] * g.grf[:, 1] - lever_knee[:, 1] * g.grf[:, 0]
    cross_hip = lever_hip[:, 0] * g.grf[:, 1] - lever_hip[:, 1] * g.grf[:, 0]
    mu = free[:, 2] - g.tau[:, 2]
    tau = np.stack([free[:, 0] - cross_hip - mu, free[:, 1] - cross_knee - mu,
                    free[:, 2] - mu], axis=1)
    err = np.sqrt(np.mean((tau - g.tau) ** 2, axis=0))
    size = np.sqrt(np.mean(g.tau ** 2, axis=0))
    return {"tau": tau, "shipped": g.tau, "rms_error": err, "rms_shipped": size,
            "relative": err / size}


def _spline(x: F64, y: F64) -> tuple[F64, F64, F64]:
    """The cubic spline OpenSim's SimmSpline is (Forsythe, Malcolm & Moler 1977: each end's
    third derivative that of the cubic through its four nearest points): the
    coefficients (b, c, d) of y_i + b_i dx + c_i dx^2 + d_i dx^3 on each interval."""
    n = len(x)
    h = np.diff(x)
    s = np.diff(y) / h
    # the tridiagonal system in the second-derivative terms, FMM's end rows
    a = np.zeros((n, n))
    r = np.zeros(n)
    a[0, :2] = -h[0], h[0]
    a[-1, -2:] = h[-1], -h[-1]
    r[0] = h[0] ** 2 * ((s[2] - s[1]) / (x[3] - x[1]) - (s[1] - s[0]) / (x[2] - x[0])) \
        / (x[3] - x[0])
    r[-1] = -h[-1] ** 2 * ((s[-1] - s[-2]) / (x[-1] - x[-3]) - (s[-2] - s[-3]) / (x[-2] - x[-4])) \
        / (x[-1] - x[-4])
    for i in range(1, n - 1):
        a[i, i - 1:i + 2] = h[i - 1], 2.0 * (h[i - 1] + h[i]), h[i]
        r[i] = s[i] - s[i - 1]
    sig = np.linalg.solve(a, r)
    b = s - h * (sig[1:] + 2.0 * sig[:-1])
    return b, np.asarray(3.0 * sig[:-1], dtype=float), np.asarray(np.diff(sig) / h, dtype=float)


def _function(spec: dict[str, Any]) -> Any:
    """An OpenSim function of one coordinate (the model file's inline tables)."""
    kind, scale = spec["kind"], float(spec.get("scale", 1.0))
    if kind == "linear":
        return lambda v: scale * (spec["slope"] * v + spec["offset"])
    if kind == "constant":
        return lambda v: scale * spec["value"]
    x, y = np.asarray(spec["x"], float), np.asarray(spec["y"], float)
    if kind == "linear_pieces":
        return lambda v: scale * float(np.interp(v, x, y))
    b, c, d = _spline(x, y)

    def spline(v: float) -> float:
        i = int(np.clip(np.searchsorted(x, v) - 1, 0, len(x) - 2))
        dx = v - x[i]
        return scale * float(y[i] + dx * (b[i] + dx * (c[i] + dx * d[i])))
    return spline


def _rotation(axis: Any, angle: float) -> F64:
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    k = np.array([[0.0, -a[2], a[1]], [a[2], 0.0, -a[0]], [-a[1], a[0], 0.0]])
    return np.eye(3) + math.sin(angle) * k + (1.0 - math.cos(angle)) * k @ k


def _vee(m: F64) -> F64:
    return 0.5 * np.array([m[2, 1] - m[1, 2], m[0, 2] - m[2, 0], m[1, 0] - m[0, 1]])


class SubjectLeg:
    """The subject's right leg as their OpenSim model moves it
    (:func:`~exoleg.reference.cp_child.cp_child_model`): the pelvis on its six
    coordinates, then each body on its joint's transform (rotations body-fixed in order,
    translations in the parent, the joint's frame oriented in the child), the patella on
    its couplers. Checked against OpenSim's own (``tests/validation/test_cp_child.py``)."""

    PELVIS = ("lower_torso_RX", "lower_torso_RY", "lower_torso_RZ", "lower_torso_TX",
              "lower_torso_TY", "lower_torso_TZ")
    #: the leg's coordinates whose moments the check computes
    LEG = ("hip_flex_r", "hip_add_r", "hip_rot_r", "knee_flex_r", "ankle_flex_r",
           "subt_angle_r")

    def __init__(self, model: dict[str, Any] | None = None) -> None:
        from exoleg.reference.cp_child import cp_child_model

        m = cp_child_model() if model is None else model
        self.bodies: dict[str, Any] = m["body"]
        self.axes = {name: [(a["name"].startswith("rotation"), a["coordinate"],
                             np.asarray(a["axis"], float), _function(a["function"]))
                            for a in b["axes"]] for name, b in self.bodies.items()}
        self.couplers = {dep: (c["coordinate"], _function(c["function"]), c["scale"])
                         for dep, c in m.get("coupler", {}).items()}
        self.inertia, self.frame = {}, {}  # each joint's frame turned in its body
        for name, b in self.bodies.items():
            if any(b["location"]) or any(b["orientation_in_parent"]):
                raise ParameterError("predictcpgait_subject1_model.toml", name,
                                     "a joint placed in its body or turned in its parent is "
                                     "not read (this model's are all zero)")
            xx, yy, zz, xy, xz, yz = b["inertia"]
            self.inertia[name] = np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])
            o = b["orientation"]
            self.frame[name] = _rotation([1, 0, 0], o[0]) @ _rotation([0, 1, 0], o[1]) \
                @ _rotation([0, 0, 1], o[2])

    def poses(self, q: dict[str, float]) -> dict[str, tuple[F64, F64]]:
        """Each body's (rotation to ground, origin in ground) at the coordinates ``q``
        (the pelvis's and the leg's; the patella's from its couplers)."""
        q = dict(q)
        for dep, (ind, f, scale) in self.couplers.items():
            q[dep] = scale * f(q[ind])
        r = np.eye(3)
        for ax, name in zip(((1, 0, 0), (0, 1, 0), (0, 0, 1)), self.PELVIS[:3], strict=True):
            r = r @ _rotation(ax, q[name])
        out = {"pelvis": (r, np.array([q[n] for n in self.PELVIS[3:]]))}
        for name, b in self.bodies.items():  # parents before children, as the file lists
            rp, pp = out[b["parent"]]
            rj, t = np.eye(3), np.zeros(3)
            for rotates, coord, axis, f in self.axes[name]:
                v = f(q.get(coord, 0.0) if coord else 0.0)
                if rotates:
                    rj = rj @ _rotation(axis, v)
                else:
                    t = t + v * axis
            out[name] = (rp @ rj @ self.frame[name].T,
                         pp + rp @ (np.asarray(b["location_in_parent"]) + t))
        return out

    def inverse_dynamics(self, q: dict[str, float], dq: dict[str, float],
                         ddq: dict[str, float], grf: F64,
                         known: dict[str, float]) -> tuple[dict[str, float], F64]:
        """The leg's generalized forces (N m, :data:`LEG`) at one instant, by virtual
        work: each body's inertial and gravity force and moment through its Jacobian
        (central differences: along the motion, h = 1 ms; in each coordinate, 1e-6), the
        ground's force ``grf`` (N) on the foot at a centre of pressure found so the
        ankle's and subtalar's moments are ``known``'s (none is shipped; no free moment).
        Returns the forces and the centre of pressure (NaN without load)."""
        h, e = 1e-3, 1e-6
        g = np.array([0.0, -9.80665, 0.0])
        ahead = self.poses({c: q[c] + dq[c] * h + 0.5 * ddq[c] * h * h for c in q})
        behind = self.poses({c: q[c] - dq[c] * h + 0.5 * ddq[c] * h * h for c in q})
        now = self.poses(q)
        moved = {c: (self.poses({**q, c: q[c] + e}), self.poses({**q, c: q[c] - e}))
                 for c in self.LEG}
        tau = dict.fromkeys(self.LEG, 0.0)

        def com(p: dict[str, tuple[F64, F64]], name: str) -> F64:
            return p[name][1] + p[name][0] @ np.asarray(self.bodies[name]["com"])

        for name, b in self.bodies.items():
            r = now[name][0]
            acc = (com(ahead, name) - 2.0 * com(now, name) + com(behind, name)) / h ** 2
            w = _vee((ahead[name][0] - behind[name][0]) / (2.0 * h) @ r.T)
            alpha = _vee((ahead[name][0] - 2.0 * r + behind[name][0]) / h ** 2 @ r.T)
            inertia = r @ self.inertia[name] @ r.T
            force = b["mass"] * (acc - g)
            moment = inertia @ alpha + np.cross(w, inertia @ w)
            for c, (up, down) in moved.items():
                tau[c] += force @ (com(up, name) - com(down, name)) / (2.0 * e) \
                    + moment @ _vee((up[name][0] - down[name][0]) / (2.0 * e) @ r.T)
        cop = np.full(3, np.nan)
        if grf[1] > 1.0:  # N: below it, its moments are under 0.3 N m at the leg's length
            rf, pf = now["foot_r"]

            def lever(c: str) -> tuple[F64, F64]:  # the foot's point's motion per unit q_c
                up, down = moved[c]
                return ((up["foot_r"][1] - down["foot_r"][1]) / (2.0 * e),
                        _vee((up["foot_r"][0] - down["foot_r"][0]) / (2.0 * e) @ rf.T))

            # tau_c = inertial - grf . (dp + w_c x (cop - pf)), linear in cop's x and z
            # on the floor (y = 0: any point of the force's line gives its moments)
            rows, rhs = [], []
            for c in ("ankle_flex_r", "subt_angle_r"):
                dp, wc = lever(c)
                v = np.cross(grf, wc)
                rows.append([v[0], v[2]])
                rhs.append(tau[c] - known[c] - grf @ dp + v @ pf)
            x, z = np.linalg.solve(np.array(rows), np.array(rhs))
            cop = np.array([x, 0.0, z])
            for c in self.LEG:
                dp, wc = lever(c)
                tau[c] -= float(grf @ (dp + np.cross(wc, cop - pf)))
        return tau, cop


def inverse_dynamics_3d() -> dict[str, Any]:
    """The leg's moments from the subject's own 3D model (:class:`SubjectLeg`) through
    the shipped motion and ground reaction force, the ankle's and subtalar's given (they
    place the centre of pressure), against the shipped moments: per coordinate of
    :data:`SubjectLeg.LEG`, ``tau`` (100, 6), ``shipped``, ``rms_error``, ``rms_shipped``,
    ``relative``; ``cop`` (100, 3) m."""
    from exoleg.reference.cp_child import cp_child_motion

    m = cp_child_motion()
    leg = SubjectLeg()
    taus, cops = [], []
    for k in range(len(m.grf)):
        at = {c: float(v[k]) for c, v in m.q.items()}
        tau, cop = leg.inverse_dynamics(at, {c: float(v[k]) for c, v in m.dq.items()},
                                        {c: float(v[k]) for c, v in m.ddq.items()},
                                        m.grf[k], {c: float(v[k]) for c, v in m.moment.items()})
        taus.append([tau[c] for c in leg.LEG])
        cops.append(cop)
    tau_ = np.array(taus)
    shipped = np.stack([m.moment[c] for c in leg.LEG], axis=1)
    err = np.sqrt(np.mean((tau_ - shipped) ** 2, axis=0))
    size = np.sqrt(np.mean(shipped ** 2, axis=0))
    return {"tau": tau_, "shipped": shipped, "rms_error": err, "rms_shipped": size,
            "relative": err / size, "cop": np.array(cops), "coordinates": leg.LEG}


@dataclass(frozen=True)
class WalkMatch:
    """The simulated child intending the real child's gait, walked in the device:
    ``cycle`` (100, 3) their mean cycle (rad, exoleg's angles, the hip from the
    vertical), ``within`` per joint the share of its samples within the real child's
    mean +- 1 SD, ``rms_deg`` per joint, ``strides`` counted, ``pattern`` and
    ``real_pattern`` (Sangeux 2015's class of each), ``fault`` whether the safety layer
    stopped the walk, ``forefoot_first`` the share of contacts made with the forefoot,
    ``detection`` the gait-phase detector's rows for initial contact and toe off
    (:func:`exoleg.sim.metrics.detection_table`); ``trials_within`` (trials, joint) the
    same share for each of the real child's own trials, judged the same way."""

    cycle: F64
    within: F64
    rms_deg: F64
    strides: int
    pattern: str
    real_pattern: str
    fault: bool
    forefoot_first: float
    detection: list[dict[str, Any]]
    trials_within: F64


def within_band(q: F64) -> F64:
    """The share of the samples of cycles ``q`` (..., samples, joint; rad, the hip from
    the vertical, on the shipped gait's samples) within the real child's mean +- 1 SD,
    per joint (and per cycle)."""
    g = cp_child_gait()
    return np.mean(np.abs(q - g.q_vertical) <= g.q_sd, axis=-2)


#: The fewest strides :func:`walk_match` judges a cycle from (two left out, then one
#: contact to the next; three strides' contacts leave none after the first two).
MIN_STRIDES = 4


def walk_match(strides: int = 12, spasticity: str = "mild",
               contracture: str = "predictcpgait") -> WalkMatch:
    """The simulated child of the subject's size, GMFCS II, with ``contracture`` and
    ``spasticity``, intending the shipped child's gait (:func:`exoleg.child.model.real_gait`)
    and walking it ``strides`` strides of its stride time in the device in transparent
    mode; their mean cycle (from their true initial contacts, the first two strides
    left out) against the real child's mean +- 1 SD."""
    from exoleg.child.model import ChildModel, Spasticity
    from exoleg.child.passive import Contracture
    from exoleg.control.safety import Limited
    from exoleg.control.transparency import SupportMode
    from exoleg.reference.scores import PERCENT, clinical_degrees, sagittal_pattern
    from exoleg.sim.events import true_events
    from exoleg.sim.metrics import detection_table
    from exoleg.sim.walk import simulate_walk
    from exoleg.sizing import Child, personalized_leg

    if not (isinstance(strides, int) and MIN_STRIDES <= strides <= 1000):
        raise ParameterError("validate.cp_child", "strides",
                             f"{strides!r}: the first 2 are left out and a cycle runs from "
                             f"one contact to the next; allowed {MIN_STRIDES}-1000")
    g = cp_child_gait()
    stride = float(g.t[-1])
    c = Child(age=10, sex="male", height=HEIGHT_M, mass=MASS_KG, gmfcs=2,
              name="predictcpgait subject 1")
    child = ChildModel(c.name or "", 10, HEIGHT_M, MASS_KG, gmfcs=2,
                       contracture=Contracture.preset(contracture),
                       spasticity=Spasticity.preset(spasticity), sex="male",
                       gait="predictcpgait")
    r = simulate_walk(personalized_leg(c), MASS_KG, strides=strides, stride_time=stride,
                      child=child, support_mode=SupportMode.TRANSPARENT)
    ev = true_events(r.contact_force)
    ic = np.nonzero(ev & 1)[0]
    ic = ic[r.t[ic] >= r.walk_start + 2 * stride]
    # a stride's contact: at least half a stride after the last (a toe tapping the belt
    # within a stride is not one)
    keep: list[int] = []
    for k in ic:
        if not keep or r.t[k] - r.t[keep[-1]] >= 0.5 * stride:
            keep.append(int(k))
    x = np.linspace(0.0, 1.0, len(g.t))
    cycles = []
    for a, b in zip(keep[:-1], keep[1:], strict=False):
        tt = (r.t[a:b] - r.t[a]) / (r.t[b] - r.t[a])
        cycles.append(np.stack([np.interp(x, tt, r.q[a:b, j]) for j in range(3)], axis=1))
    want = g.q_vertical
    cycle = np.mean(cycles, axis=0) if cycles else np.full_like(want, np.nan)
    on_grid = [np.stack([np.interp(PERCENT / 100, x, v[:, j]) for j in range(3)], axis=1)
               for v in (cycle, g.q)]
    fore = r.contact_force[np.array(keep, dtype=int)]
    return WalkMatch(
        cycle=cycle, within=within_band(cycle),
        rms_deg=np.degrees(np.sqrt(np.mean((cycle - want) ** 2, axis=0))),
        strides=max(0, len(keep) - 1),
        pattern=sagittal_pattern(clinical_degrees(on_grid[0]))[0] if cycles else "-",
        real_pattern=sagittal_pattern(clinical_degrees(on_grid[1]))[0],
        fault=bool(np.any(r.safety_status & Limited.FAULT)),
        forefoot_first=float(np.mean((fore[:, 1:].max(axis=1) > 5.0) & (fore[:, 0] <= 5.0)))
        if len(keep) else math.nan,
        detection=[row for row in detection_table([r])
                   if row["event"] in ("initial contact", "toe off")],
        trials_within=within_band(g.q_trials_vertical))
