"""The interaction torque between child and device: what the device's cuffs transmit.

At each joint, the torque that reaches the device's link (a rigid unit's delivered torque
less its friction; a compliant unit's spring torque) less what the device's own links and
the rotors they carry (the reflected inertia of a rigid unit) take:

    tau_int = tau_link - [M_d(q) ddq + C_d(q, dq) dq + G_d(q) + p_d(q) ddy]

with M_d, C_d, G_d the device alone (its links with the rotors as armature) and
p_d ddy what the pelvis's vertical acceleration asks of them (the walking plant's
coupling, :mod:`exoleg.world.plant`). The ground's reaction passes through the
footplate to the child's foot, so it is the child's, not the cuffs'. Positive moves the
child's joint towards positive q (hip flexion, knee extension, dorsiflexion).
"""

from __future__ import annotations

from numba import njit

from exoleg.device.actuator import ActuatorModel, with_actuators
from exoleg.dynamics.kernels import (
    coriolis_dq_trig,
    gravity_trig,
    joint_trig,
    mass_height_terms_trig,
    mass_matrix_trig,
)
from exoleg.dynamics.model import LegModel
from exoleg.params.records import LINKS, Link


def device_leg(leg: LegModel, actuators: tuple[ActuatorModel, ...],
               link: bool = False) -> LegModel:
    """The device alone at ``leg``'s lengths (:func:`device_links`), its rotors as
    armature (as the links feel them, or, ``link``, as they carry them:
    :func:`~exoleg.device.actuator.with_actuators`)."""
    return with_actuators(device_links(leg), actuators, link)


def device_links(leg: LegModel) -> LegModel:
    """The device's links alone at ``leg``'s lengths, no rotor: the links' parts after the
    first (the child's) when the leg was composed from parts (a fitted child, the paper's
    detailed leg), else the paper's SLE bodies at these telescope settings
    (``data/paper/device.toml``)."""
    if all(len(lk.parts) >= 2 for lk in leg.links):
        links = [Link.from_parts(lk.length, lk.parts[1:], name=LINKS[i])
                 for i, lk in enumerate(leg.links)]
    else:
        from exoleg.sizing.personal import device_bodies

        bodies = device_bodies(float(leg.lengths[0]), float(leg.lengths[1]))
        links = [Link.from_parts(float(leg.lengths[i]), (bodies[i],), name=LINKS[i])
                 for i in range(3)]
    return LegModel(links, g=leg.g, name="device alone")


@njit(cache=True)
def interaction_torque(pd, g, motion, ddy, link, out, work):  # type: ignore[no-untyped-def]
    """The cuffs' torque (N m) into out (3,) from the torque that reaches the device's
    links ``link`` (a rigid unit's delivered torque less its friction; a compliant
    unit's spring torque, its friction being its rotor's) and the motion (``motion``:
    rows q, dq, ddq; the pelvis's ddy), the device alone's parameters ``pd`` (its links
    with the armature they carry themselves: ``device_leg(..., link=True)``); ``work``:
    (3, 3) arrays to work in, the device alone's mass matrix and its Coriolis and
    gravity torques by row."""
    q, dq, ddq = motion[0], motion[1], motion[2]
    M, rows = work
    sc = joint_trig(q)  # once for the four kernels
    mass_matrix_trig(sc, pd, M)
    Cq, G = rows[0], rows[1]
    coriolis_dq_trig(sc, dq, pd, Cq)
    gravity_trig(sc, pd, g, G)
    y0, y1, y2, _, _ = mass_height_terms_trig(sc, dq, pd)
    pv = (y0, y1, y2)
    for j in range(3):
        need = Cq[j] + G[j] + pv[j] * ddy
        for k in range(3):
            need += M[j, k] * ddq[k]
        out[j] = link[j] - need
