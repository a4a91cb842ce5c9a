"""A real child with CP as the check of exoleg's child (issue 41): predictcpgait's subject 1
(Falisse et al. 2020, Front Hum Neurosci 14:40; MIT licence), a child with spastic
diplegic CP, shipped as ``data/child/predictcpgait_subject1_r.csv`` (their right leg's
angles over a gait cycle with the SD over 4 trials, rates and accelerations, the pelvis's
motion, the inverse-dynamics moments and the foot's ground reaction force).

Two checks, printed by ``exoleg validate --cp-child``:

* **Inverse dynamics** (:func:`inverse_dynamics`): exoleg's leg for a child of the
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


@dataclass(frozen=True)
class WalkMatch:
    """The simulated child intending the real child's gait, walked in the device:
    ``cycle`` (100, 3) their mean cycle (rad, exoleg's angles, the hip from the
    vertical), ``within`` per joint the share of its samples within the real child's
    mean +- 1 SD, ``rms_deg`` per joint, ``strides`` counted, ``pattern`` and
    ``real_pattern`` (Sangeux 2015's class of each), ``fault`` whether the safety layer
    stopped the walk, ``forefoot_first`` the share of contacts made with the forefoot,
    ``detection`` the gait-phase detector's rows for initial contact and toe off
    (:func:`exoleg.sim.metrics.detection_table`)."""

    cycle: F64
    within: F64
    rms_deg: F64
    strides: int
    pattern: str
    real_pattern: str
    fault: bool
    forefoot_first: float
    detection: list[dict[str, Any]]


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
    want = g.q.copy()
    want[:, 0] += g.tilt
    cycle = np.mean(cycles, axis=0) if cycles else np.full_like(want, np.nan)
    on_grid = [np.stack([np.interp(PERCENT / 100, x, v[:, j]) for j in range(3)], axis=1)
               for v in (cycle, g.q)]
    fore = r.contact_force[np.array(keep, dtype=int)]
    return WalkMatch(
        cycle=cycle, within=np.mean(np.abs(cycle - want) <= g.q_sd, axis=0),
        rms_deg=np.degrees(np.sqrt(np.mean((cycle - want) ** 2, axis=0))),
        strides=max(0, len(keep) - 1),
        pattern=sagittal_pattern(clinical_degrees(on_grid[0]))[0] if cycles else "-",
        real_pattern=sagittal_pattern(clinical_degrees(on_grid[1]))[0],
        fault=bool(np.any(r.safety_status & Limited.FAULT)),
        forefoot_first=float(np.mean((fore[:, 1:].max(axis=1) > 5.0) & (fore[:, 0] <= 5.0)))
        if len(keep) else math.nan,
        detection=[row for row in detection_table([r])
                   if row["event"] in ("initial contact", "toe off")])
