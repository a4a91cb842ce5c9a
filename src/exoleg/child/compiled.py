"""The child as the compiled actor the simulated device carries, one tick at a time: the
child model (:class:`~exoleg.child.model.ChildModel`) as the records the compiled tick
reads (:func:`child_records`) and the tick itself (:func:`child_tick`): tone,
short-range stiffness, the delayed stretch reflex, the effort tracking the intended gait.
The equations, numbers and sources are in ``docs/child.md``."""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from exoleg.child.model import (
    GAIT_SAMPLES,
    HISTORY,
    PASSIVE_DAMPING,
    SPASTIC_GROUPS,
    ChildModel,
    intended_gait,
)
from exoleg.child.passive import (
    PASSIVE,
    RienerModel,
    child_data,
    height_scale,
    passive_moments,
    passive_record,
    riener_phi,
    term_value,
)
from exoleg.errors import ParameterError
from exoleg.layout import F8, I8, new
from exoleg.reference.gait import start_blend

F64 = NDArray[np.float64]


#: The child as the compiled tick reads it: the spastic groups' passive term (index into
#: :data:`PASSIVE`'s terms), tone (N m, scaled), reflex gains (force, force rate, and
#: stretch velocity beyond its threshold: N m per deg/s, scaled), short-range stiffness
#: (per degree of tone), its range (deg) and fade (s), the reflex delay (ticks), the
#: tonically active muscles' force-velocity (the eccentric gain, its speed deg/s); the
#: effort (1 on), its stiffness (N m/rad) and damping (N m s/rad) with the foot loaded
#: (row 0) and in swing (row 1), strength (N m), delay
#: (ticks), the standing posture (rad), the intended gait (q, dq rad, rad/s; the active
#: moments along it: the net internal moments less a typically developing body's passive
#: ones, N m) over the cycle, the share of those moments the child drives with the foot
#: loaded (row 0: what the device's stance support leaves them) and in swing (row 1), and
#: the stride time (s) the cycle takes.
CHILD = np.dtype([("term", I8, 4), ("tone", F8, 4), ("g_f", F8, 4), ("g_df", F8, 4),
                  ("g_v", F8, 4), ("v_threshold", F8),
                  ("srs", F8), ("srs_range", F8), ("srs_decay", F8), ("reflex_delay", I8),
                  ("eccentric", F8), ("fv_speed", F8),
                  ("effort", F8), ("kp", F8, (2, 3)), ("kd", F8, (2, 3)), ("strength", F8, 3),
                  ("effort_delay", I8), ("stand", F8, 3),
                  ("gait_q", F8, (GAIT_SAMPLES, 3)), ("gait_dq", F8, (GAIT_SAMPLES, 3)),
                  ("gait_tau", F8, (GAIT_SAMPLES, 3)), ("share", F8, 2), ("stride", F8),
                  ("intrinsic", F8), ("learn_f", F8), ("learn_g", F8)])

#: The child's memory (:func:`child_tick`): ticks so far, each group's force, its rate
#: and its stretch velocity (deg/s), the joint angles and rates the child felt (rings
#: of :data:`HISTORY` ticks), the
#: short-range stiffness's anchor (deg), its torque (N m) and whether it yielded; the
#: tick's torques (N m, exoleg's signs): the reflexes' (tone, short range, stretch
#: reflex) and the effort's.
CHILD_STATE = np.dtype([("k", I8), ("force", F8, (HISTORY, 4)), ("rate", F8, (HISTORY, 4)),
                        ("stretch", F8, (HISTORY, 4)),
                        ("q", F8, (HISTORY, 3)), ("dq", F8, (HISTORY, 3)),
                        ("anchor", F8, 4), ("srs", F8, 4), ("yielded", F8, 4),
                        ("reflex", F8, 3), ("effort", F8, 3), ("share0", F8), ("e_sq", F8),
                        ("e_n", I8), ("x_last", F8), ("strides", I8)])


def child_records(child: ChildModel | None, h: float, stride_time: float = 1.1,
                  speed: str = "Free", standing: Any = (0.0, 0.0, 0.0),
                  leg_length: float | None = None, inertia: Any = (0.5, 0.2, 0.05),
                  device_support: float = 0.0
                  ) -> tuple[NDArray[np.void], NDArray[np.void], NDArray[np.void]]:
    """(:data:`PASSIVE`, :data:`CHILD`, :data:`CHILD_STATE`) for ``child`` at a tick of
    ``h`` s; for None a leg without a child actor (all off). ``standing``: the posture
    the child holds when not walking (rad); ``leg_length`` (m) scales the stance
    stiffness (default 0.53 of the height: Drillis & Contini's hip height); ``inertia``
    (kg m^2 per joint: the swinging leg's, device included) sets the swing's;
    ``device_support`` (0-1): the share of the body weight the device carries in stance
    (:class:`~exoleg.control.hierarchy.WalkGains` ``support``), which the child leaves to
    it -- their stance feedforward is the rest (the slacking of people walking in a
    device that helps: Emken et al. 2007)."""
    C = new(CHILD)
    S = new(CHILD_STATE)
    if child is None:
        return new(PASSIVE), C, S
    s = height_scale(child.height)
    damping = tuple(d * s for d in PASSIVE_DAMPING)
    P = passive_record(child.height, child.contracture, damping)  # type: ignore[arg-type]
    sp = child.spasticity
    groups = [t.group for t in RienerModel.shipped().terms]
    r = C[0]
    r["term"] = [groups.index(g) for g in SPASTIC_GROUPS]
    r["tone"] = np.array(sp.tone) * s
    r["g_f"], r["g_df"] = sp.g_f, sp.g_df
    r["g_v"], r["v_threshold"] = np.array(sp.g_v) * s, sp.v_threshold
    r["srs"], r["srs_range"], r["srs_decay"] = sp.srs_per_deg, sp.srs_range, sp.srs_decay
    r["eccentric"], r["fv_speed"] = sp.eccentric, sp.fv_speed
    for name, delay in (("reflex_delay", sp.delay),
                        ("effort_delay", float(child_data("effort.toml")["delay_s"]))):
        n = int(round(delay / h))
        if n >= HISTORY:
            raise ParameterError("child", name, f"{delay:g} s is {n} ticks of {h:g} s; the "
                                 f"child's memory holds {HISTORY - 1}")
        r[name] = n
    e = child_data("effort.toml")
    L = 0.53 * child.height if leg_length is None else leg_length
    # the stance loop's stiffness is the antigravity muscles' response, which scales
    # with the force they can give (effort.toml's stiffness, a typically developing
    # child's, times the child's strength fraction); the swing loop's (below) moves
    # the leg's own inertia, far within any child's strength
    kp = np.array(e["stiffness"]) * child.mass * 9.81 * L * child.strength_fraction
    r["effort"] = 1.0 if child.effort else 0.0
    r["kp"][0], r["kd"][0] = kp, kp * np.array(e["damping_s"])
    wn = 2 * math.pi * float(e["swing_bandwidth_hz"])
    inert = np.asarray(inertia, dtype=float)
    r["kp"][1] = wn * wn * inert
    r["kd"][1] = 2 * float(e["swing_damping_ratio"]) * wn * inert
    r["strength"] = child.strength()
    r["stand"] = standing
    q_g, dq_g, tau_g = intended_gait(child, stride_time, speed)
    # the gait's moments are net ones (inverse dynamics: the muscles' and the passive
    # tissues' together) and the plant adds the child's passive moments itself, so the
    # muscles drive the net less a typically developing body's passive moments along the
    # gait: the active moment. The device's stance support relieves the muscles of their
    # share of it, not the tissues (a child it carries relaxes; their tissues still
    # act). The child's own contracture stays theirs, beyond what they mean
    td = passive_record(child.height, None, damping)  # type: ignore[arg-type]
    r["gait_q"], r["gait_dq"] = q_g, dq_g
    r["gait_tau"] = tau_g - passive_moments(td, q_g, dq_g)
    r["share"] = float(e["share"]) * (1.0 - device_support), float(e["share"])
    r["stride"] = stride_time
    r["intrinsic"] = float(e["intrinsic"])
    r["learn_f"], r["learn_g"] = child.learning, float(e["learning_gain_per_rad"])
    S[0]["share0"] = r["share"][0]
    return P, C, S


@njit(cache=True)
def _delayed(ring, k, n, j):  # type: ignore[no-untyped-def]
    """Column j of the ring's entry n ticks before tick k (its oldest while younger)."""
    i = k - n if k >= n else 0
    return ring[i % ring.shape[0], j]


@njit(cache=True)
def _cycle(table, x, j):  # type: ignore[no-untyped-def]
    """Column j of a table over one cycle (rows at 0 .. 1) at the fraction x, linear."""
    nx = table.shape[0] - 1
    f = x * nx
    i0 = min(int(f), nx - 1)
    a = f - i0
    return (1 - a) * table[i0, j] + a * table[i0 + 1, j]


@njit(cache=True)
def _learn(c, s, xc, q, loaded):  # type: ignore[no-untyped-def]
    """The learning child (Emken et al. 2007's human model): their stance share of the
    normative moments, x <- f x + g e at each new stride (e: the stride's stance RMS of
    the gait they mean against the one they walk, over the joints), within 0 and their
    full share."""
    if xc < s.x_last - 0.5 and s.e_n > 0:  # the cycle wrapped: a new stride
        e = math.sqrt(s.e_sq / s.e_n)
        s.share0 = min(max(c.learn_f * s.share0 + c.learn_g * e, 0.0), c.share[1])
        s.e_sq = 0.0
        s.e_n = 0
        s.strides += 1
    s.x_last = xc
    if loaded:
        for j in range(3):
            d = _cycle(c.gait_q, xc, j) - q[j]
            s.e_sq += d * d / 3.0
        s.e_n += 1


@njit(cache=True)
def child_tick(child, q, dq, h, walking, gait, loaded, out):  # type: ignore[no-untyped-def]
    """The child's muscles over one tick, their passive moments aside (the plant adds
    those in every stage): tone, short-range stiffness and stretch reflex of each spastic
    group, and the effort tracking the intended gait while ``walking`` (else holding the
    standing posture) from what the child felt a delay ago, within their strength,
    stiffer while their foot is ``loaded``. ``gait``: the child's gait fraction, its pace
    (0-1) and the pace's rate (1/s): at a walk's start the child moves from standing
    into the gait as the pace rises (:func:`~exoleg.reference.gait.start_blend`). ``child``:
    (:data:`PASSIVE`, :data:`CHILD`, :data:`CHILD_STATE`), as :func:`child_records` makes
    them. Torques (N m, exoleg's signs) into ``out`` (3,)."""
    P, C, CS = child
    xc, pace, rate = gait
    R = P[0]
    c = C[0]
    s = CS[0]
    k = s.k
    L = s.force.shape[0]
    i = k % L
    for j in range(3):
        out[j] = 0.0
        s.q[i, j] = q[j]
        s.dq[i, j] = dq[j]
        s.reflex[j] = 0.0
        s.effort[j] = 0.0
    if R.on != 0.0:
        phi = np.empty(3)
        riener_phi(q, phi)
        dphi = np.empty(3)
        riener_phi(dq, dphi)
        for g in range(4):
            t = c.term[g]
            jr = int(R.joint[t])
            # the group's stretch along its own joint, degrees (phi increases with the
            # term's exponent when its own coefficient is positive)
            own = 2 - jr  # phi index of joint jr: hip 2, knee 1, ankle 0
            b = R.coef[t, 1 + own]
            x = phi[own] * (1.0 if b > 0.0 else -1.0)
            if c.tone[g] > 0.0:
                # short-range stiffness: elastic over the first degrees of a stretch,
                # fading once it yields or the muscle shortens
                if x < s.anchor[g]:
                    s.anchor[g] = x
                    s.yielded[g] = 0.0
                dx = x - s.anchor[g]
                if s.yielded[g] == 0.0 and dx <= c.srs_range:
                    s.srs[g] = c.srs * c.tone[g] * dx
                else:
                    s.yielded[g] = 1.0
                    s.srs[g] *= math.exp(-h / c.srs_decay)
                    if dx < 0.5 * c.srs_range:
                        s.anchor[g] = x
                        s.yielded[g] = 0.0
            # the tonically active muscle's force-velocity (Hill): more force
            # lengthening, less shortening
            v = dphi[own] * (1.0 if b > 0.0 else -1.0)
            fv = (1.0 + c.eccentric * math.tanh(v / c.fv_speed) if v >= 0.0
                  else 1.0 + math.tanh(v / c.fv_speed))
            tone = c.tone[g] * fv
            force = tone + s.srs[g] + term_value(R, t, phi)
            prev = s.force[(i - 1) % L, g] if k > 0 else force
            s.force[i, g] = force
            s.rate[i, g] = (force - prev) / h
            s.stretch[i, g] = v
            n = c.reflex_delay
            # the stretch reflex: the muscle's force and its rate (De Groote 2018) and
            # the spindles' velocity response beyond its threshold (Lance 1980's
            # velocity-dependent resistance)
            reflex = max(0.0, c.g_f[g] * _delayed(s.force, k, n, g)
                         + c.g_df[g] * _delayed(s.rate, k, n, g)
                         + c.g_v[g] * max(0.0, _delayed(s.stretch, k, n, g)
                                          - c.v_threshold))
            active = 0.0
            if c.tone[g] > 0.0 or reflex > 0.0:
                active = R.sign[t] * (tone + s.srs[g] + reflex)
            # Riener's moments flex hip and knee and plantarflex the ankle
            s.reflex[jr] += active if jr == 0 else -active
    if c.effort != 0.0:
        n = c.effort_delay
        row = 0 if loaded else 1
        if c.learn_f != 0.0 and walking:
            _learn(c, s, xc, q, loaded)
        # the error the child feels is the delayed one: what they felt a delay ago
        # against what they meant then (their intention at that fraction of the cycle);
        # the feedforward is the moment meant for now
        xd = xc - n * h / c.stride
        xd -= math.floor(xd)
        r = c.intrinsic
        for j in range(3):
            if walking:
                x = min(max(xc, 0.0), 1.0)
                qi, dqi = _cycle(c.gait_q, xd, j), _cycle(c.gait_dq, xd, j)
                qn, dqn = _cycle(c.gait_q, x, j), _cycle(c.gait_dq, x, j)
                if pace < 1.0:  # a walk's start: from standing into the gait
                    qi, dqi, _ = start_blend(c.stand[j], qi, dqi, 0.0, (pace, rate, 0.0))
                    qn, dqn, _ = start_blend(c.stand[j], qn, dqn, 0.0, (pace, rate, 0.0))
                ff = (s.share0 if row == 0 else c.share[1]) * _cycle(c.gait_tau, x, j)
            else:
                qi, dqi, ff = c.stand[j], 0.0, 0.0
                qn, dqn = qi, dqi
            # the loop's share the muscles' own visco-elasticity gives at once, about the
            # posture meant now; the rest through the delayed loop
            u = (ff + r * (c.kp[row, j] * (qn - q[j]) + c.kd[row, j] * (dqn - dq[j]))
                 + (1.0 - r) * (c.kp[row, j] * (qi - _delayed(s.q, k, n, j))
                                + c.kd[row, j] * (dqi - _delayed(s.dq, k, n, j))))
            s.effort[j] = min(max(u, -c.strength[j]), c.strength[j])
    for j in range(3):
        out[j] = s.reflex[j] + s.effort[j]
    s.k = k + 1


__all__ = ["CHILD", "CHILD_STATE", "child_records", "child_tick"]
