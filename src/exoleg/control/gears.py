"""The transparent law on the gears' stiffness: a linear model of each rigid unit's
rotor on its gear, the links beyond, under the law's inertia and friction compensation
(:func:`gear_mode`), and from it the bounds an operator may move the law's inertia
share and acceleration estimate within (:func:`law_bounds`).

The law reads the joint's encoder on the link's side of the gear (the paper's AksIM-2,
section 2.3); through the rotor's inertia on the gear's stiffness, a share of the
device's inertia compensated from that reading is feedback of the gear's mode. For the
hip and the knee it damps the mode; the ankle's foot mode, on a light footplate behind a
heavy rotor, grows with any share (``exoleg validate --transparency``, "the law on the
gears"). The operator's bounds keep every mode as damped as the device folder's own
setting leaves it, or damped.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from exoleg.params.records import JOINTS

F64 = NDArray[np.float64]

#: the ticks a command may come late: as the simulated loop applies it, and a bus's cycle
#: later (EtherCAT's outputs a cycle behind its inputs)
DELAYS = (0, 1)


def gear_plant(act: Any, link: float, h: float) -> tuple[F64, F64]:
    """The rotor (its inertia reflected at the joint, ``act.reflected_inertia``, with the
    unit's viscous friction) on the gear's stiffness (``act.gear_stiffness``) to the
    link's ``link`` kg m^2, the drive's current loop a first order of its bandwidth,
    stepped exactly over a tick of ``h`` s (the matrix exponential, the command held):
    (A, B) of the state (the rotor's angle at the joint and rate, the link's, the torque
    delivered)."""
    from scipy.linalg import expm

    jm, k, c = act.reflected_inertia, act.gear_stiffness, act.viscous_friction
    wc = 2.0 * np.pi * act.current_loop_bandwidth
    a = np.array([[0.0, 1.0, 0.0, 0.0, 0.0], [-k / jm, -c / jm, k / jm, 0.0, 1.0 / jm],
                  [0.0, 0.0, 0.0, 1.0, 0.0], [k / link, 0.0, -k / link, 0.0, 0.0],
                  [0.0, 0.0, 0.0, 0.0, -wc]])
    e = expm(np.block([[a, np.eye(5, 1, -4) * wc], [np.zeros((1, 6))]]) * h)
    return e[:5, :5], e[:5, 5]


def plant_mode(plant: tuple[F64, F64], act: Any, share: float, accel_filter_hz: float,
               lead: float, inertia: float, h: float, delay: int = 0) -> tuple[float, float]:
    """:func:`gear_mode` on a plant :func:`gear_plant` stepped already."""
    ad, bd = plant
    c = act.viscous_friction
    bv = 1.0 - np.exp(-2.0 * np.pi * act.velocity_filter_hz * h)
    ba = 1.0 - np.exp(-2.0 * np.pi * accel_filter_hz * h)
    # the loop's state z: x, then the last angle read, rate and acceleration estimates,
    # then the commands still on their way (delay)
    n = 8 + delay
    z = np.zeros((n, n))
    read = np.eye(1, n, 2)[0]                        # the link's angle
    rate = bv / h * (read - np.eye(1, n, 5)[0]) + (1.0 - bv) * np.eye(1, n, 6)[0]
    acc = ba / h * (rate - np.eye(1, n, 6)[0]) + (1.0 - ba) * np.eye(1, n, 7)[0]
    command = share * inertia * acc + c * (rate + lead * acc)
    applied = command if delay == 0 else np.eye(1, n, n - 1)[0]
    z[:5, :5] = ad
    z[:5] += np.outer(bd, applied)
    z[5], z[6], z[7] = read, rate, acc
    if delay:
        z[8] = command
        for i in range(9, n):
            z[i, i - 1] = 1.0
    ev = np.linalg.eigvals(z)
    ev = ev[(np.abs(ev - 1.0) > 1e-6) & (np.abs(ev) > 1e-12)]  # (0: a state read, not kept)
    s = np.log(ev.astype(complex)) / h
    zeta = -s.real / np.abs(s)
    i = int(np.argmin(zeta))
    return float(abs(s[i].imag) / (2.0 * np.pi)), float(zeta[i])


def gear_mode(act: Any, share: float, accel_filter_hz: float, lead: float, inertia: float,
              link: float, h: float, delay: int = 0) -> tuple[float, float]:
    """The least-damped mode of a rigid unit's joint -- its rotor on the gear's
    stiffness, the link beyond -- under the transparent law's inertia and viscous friction
    compensation: (its frequency, Hz; its damping ratio, negative when it grows).

    The linear model, per joint, about a posture and a speed away from zero (the Coulomb
    friction's slope there none; gravity and the Coriolis terms compensated, not in the
    loop): :func:`gear_plant` to the link's ``link`` kg m^2 about the joint (the
    device's links beyond it, with or without the child's segments strapped to them); at
    each tick of ``h`` s the joint encoder read (on the link's side of the gear), its
    rate the difference per tick through the drive's velocity low-pass, the acceleration
    the rates' difference through ``accel_filter_hz``'s
    (:func:`~exoleg.control.transparency.track_rates`), the command ``share`` x
    ``inertia`` (the law's device inertia at the joint) x that acceleration plus the
    viscous friction at the rate taken ``lead`` s ahead, held over the tick, ``delay``
    ticks late (0: as the simulated loop; 1: a bus's cycle more). The rigid body's two
    modes (the angle, and the speed the friction's compensation leaves undamped) are left
    out."""
    return plant_mode(gear_plant(act, link, h), act, share, accel_filter_hz, lead, inertia,
                      h, delay)


def gear_links(leg: Any, actuators: Sequence[Any]) -> list[dict[str, float]]:
    """Per joint of ``leg`` (standing straight) with ``actuators``: the device's inertia
    about the joint as the law takes it (``device``: its links and the rotor's reflected
    inertia), beyond the gear with the cuffs open (``alone``: the device's links) and
    with the child's segments strapped rigidly to them (``worn``), kg m^2."""
    from exoleg.child.interaction import device_leg

    q = np.zeros(3)
    whole = leg.M(q)
    dev = device_leg(leg, tuple(actuators)).M(q)
    return [{"device": float(dev[j, j]), "alone": float(dev[j, j]) - act.reflected_inertia,
             "worn": float(whole[j, j])} for j, act in enumerate(actuators)]


def worst_mode(plants: Sequence[tuple[F64, F64]], act: Any, share: float,
               accel_filter_hz: float, lead: float, inertia: float, h: float
               ) -> tuple[float, float]:
    """The least damped of :func:`plant_mode` over ``plants`` and :data:`DELAYS`."""
    return min((plant_mode(p, act, share, accel_filter_hz, lead, inertia, h, d)
                for p in plants for d in DELAYS), key=lambda m: m[1])


def law_on_gears(leg: Any, actuators: Sequence[Any], settings: Any, h: float
                 ) -> list[dict[str, Any]]:
    """Per joint of ``actuators`` on ``leg``, :func:`gear_mode` of the transparent law's
    ``settings`` (:class:`~exoleg.control.transparency.TransparencySettings`) at a tick of
    ``h`` s, the worse of :data:`DELAYS`: ``alone`` and ``worn`` (:func:`gear_links`) --
    each (Hz, damping ratio). A negative ratio is a mode the law makes grow, unless the
    gear's own (structural) damping, which no datasheet held gives, is at least as large;
    a compliant unit (a series spring) is None: its torque loop is
    :mod:`exoleg.device.drive`'s, checked against its two-mass model in the tests."""
    rows: list[dict[str, Any]] = []
    for j, (joint, act, links) in enumerate(zip(JOINTS, actuators, gear_links(leg, actuators),
                                                strict=True)):
        if act.compliant:
            rows.append({"joint": joint, "alone": None, "worn": None})
            continue
        law = (float(settings.inertia_share[j]), float(settings.accel_filter_hz[j]),
               settings.lead, links["device"], h)
        rows.append({"joint": joint, **{
            case: worst_mode([gear_plant(act, links[case], h)], act, *law)
            for case in ("alone", "worn")}})
    return rows


#: The operator's bounds on the law's settings (:func:`law_bounds`): the inertia's share
#: at most 0.9 (at 1 the device alone diverges on its gears: ``exoleg validate
#: --transparency`` over 0.3-1), on a grid of 0.05; the acceleration estimate's low-pass
#: among these, Hz (30 the device's own, 250 the fastest walked over 40 children:
#: docs/device.md), and the device folder's own values always among them.
SHARE_MAX, SHARE_STEP = 0.9, 0.05
FILTERS_HZ = (30.0, 60.0, 100.0, 250.0)
#: the tunable settings of the law :func:`law_bounds` bounds, in this order
LAW_TUNABLE = ("inertia_share", "accel_filter_hz")


def law_bounds(leg: Any, actuators: Sequence[Any], settings: Any, h: float
               ) -> dict[str, list[list[float]]]:
    """The bounds (per joint, [lower, upper]) an operator may move the transparent law's
    ``inertia_share`` and ``accel_filter_hz`` within, for ``actuators`` on ``leg`` at a
    tick of ``h`` s: a box on the grid of :data:`SHARE_STEP` shares up to
    :data:`SHARE_MAX` and the :data:`FILTERS_HZ`, grown from the device's own
    ``settings`` one step at a time (a share more, a faster estimate, a share less, a
    slower one, in turn) while every point of the grid in it leaves each gear's mode,
    alone and worn, a command on time and a bus's cycle late (:func:`worst_mode`), at
    least as damped as the device's own setting does, or damped. A compliant unit's
    share may only fall and its estimate stays (its torque loop's margin is not this
    model's)."""
    out: dict[str, list[list[float]]] = {n: [] for n in LAW_TUNABLE}
    for j, (act, links) in enumerate(zip(actuators, gear_links(leg, actuators), strict=True)):
        own_s, own_f = float(settings.inertia_share[j]), float(settings.accel_filter_hz[j])
        if act.compliant:
            share, hz = [0.0, own_s], [own_f, own_f]
        else:
            share, hz = _box(act, links, own_s, own_f, settings.lead, h)
        out["inertia_share"].append(share)
        out["accel_filter_hz"].append(hz)
    return out


def _box(act: Any, links: dict[str, float], own_s: float, own_f: float, lead: float,
         h: float) -> tuple[list[float], list[float]]:
    """:func:`law_bounds`' box for one rigid unit: ([share lo, hi], [Hz lo, hi])."""
    plants = [gear_plant(act, links[c], h) for c in ("alone", "worn")]
    seen: dict[tuple[float, float], float] = {}

    def zeta(s: float, f: float) -> float:
        if (s, f) not in seen:
            seen[s, f] = worst_mode(plants, act, s, f, lead, links["device"], h)[1]
        return seen[s, f]

    floor = min(0.0, zeta(own_s, own_f)) - 1e-9
    shares = sorted({*np.round(np.arange(0.0, SHARE_MAX + 1e-9, SHARE_STEP), 10).tolist(),
                     own_s})
    filters = sorted({*FILTERS_HZ, own_f})
    box = [shares.index(own_s)] * 2 + [filters.index(own_f)] * 2  # share lo, hi; Hz lo, hi
    grown = True
    while grown:
        grown = False
        for side, step in ((1, 1), (3, 1), (0, -1), (2, -1)):
            trial = list(box)
            trial[side] += step
            if not 0 <= trial[side] < (len(shares) if side < 2 else len(filters)):
                continue
            if all(zeta(s, f) >= floor for s in shares[trial[0]:trial[1] + 1]
                   for f in filters[trial[2]:trial[3] + 1]):
                box, grown = trial, True
    return [shares[box[0]], shares[box[1]]], [filters[box[2]], filters[box[3]]]
