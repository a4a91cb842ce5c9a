"""How transparent the device can be, and how transparent it is (``exoleg validate
--transparency``).

**The budget**: what the device alone (its links at the child's telescope settings and
its motors' rotors, :func:`~exoleg.child.interaction.device_leg`, and its friction) takes
to move along the child's gait, ``M_d(q) ddq + C_d(q, dq) dq + G_d(q) + f(dq)`` on the
normative gait (Schwartz 2008) at the stride time, against the torque its drives
deliver (the gear's working limit). Whatever is beyond the drives the child moves: no
controller takes it away, so its RMS is the floor of the transparent mode's residual.

**The walk**: a typically developing child (the 50th percentile 10-year-old girl of
the WHO / CDC charts, :func:`~exoleg.sizing.child.population_child`) walking in the
device in the transparent mode. Each part of the transparent law is logged
(:attr:`~exoleg.sim.walk.WalkResult.transparent_parts`), so the one run shows what the
child would feel on this motion without each: the cuffs' torque plus the parts left out,
added in the law's order (none, gravity, + inertia, + friction, + the cuffs' torque
feedback) -- each part as commanded, the drive's lag and saturation aside.

References: Lerner et al. 2018 (zero-torque residual of a CP ankle exoskeleton, 0.015-
0.036 N m/kg RMS: the goal is its upper end), Chen et al. 2021 (P.REX, a pediatric
knee exoskeleton: under 1.8 N m in its zero mode), ``shared/design/child-references.md``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from exoleg.control.gears import law_bounds, law_on_gears
from exoleg.device.drive import current_loop, drive_limit
from exoleg.dynamics.kernels import mass_height_terms
from exoleg.errors import ParameterError
from exoleg.params.records import JOINTS

F64 = NDArray[np.float64]

#: the transparent mode's goal, N m/kg RMS per joint (Lerner et al. 2018, Table II's upper end)
GOAL_NM_PER_KG = 0.036
#: P.REX's residual in its zero mode, N m (Chen et al. 2021)
PREX_NM = 1.8
#: strides left out of the figures at the walk's start (the child settles into it)
SETTLE_STRIDES = 2


def budget(leg: Any, config: Any, body_mass: float, stride_time: float = 1.1,
           speed: str = "Free", samples: int = 1101) -> list[dict[str, Any]]:
    """Per joint: what the device alone at ``leg``'s telescope settings takes along the
    normative gait of ``stride_time`` s (N m: RMS, peak, and its inertial part's RMS),
    the drive's limit (N m), the share of the cycle beyond it and the RMS beyond it per
    kg of ``body_mass`` (the residual's floor); the rotor's reflected inertia today and
    the largest with which the need stays within the drive's limit (kg m^2; the gear
    ratio scales it by its square)."""
    from exoleg.child.interaction import device_leg
    from exoleg.device.actuator import params_array
    from exoleg.device.drive import friction
    from exoleg.reference.gait import SchwartzGait2008

    dev = device_leg(leg, config.actuators)
    A = params_array(config.actuators)
    t = np.linspace(0.0, stride_time, samples)
    q, dq, ddq = SchwartzGait2008(stride_time=stride_time, speed=speed, upright=True).sample(t)
    fr = np.array([[friction(A[j:j + 1], w) for j, w in enumerate(row)] for row in dq])
    # the rotors are the device alone's armature: their J ddq is added to the rest
    rotors = dev.armature
    links = dev.with_armature(np.zeros(3)).inverse_dynamics(q, dq, ddq) + fr
    need = links + rotors * ddq
    inertial = np.einsum("kij,kj->ki", dev.M(q), ddq)
    rows = []
    for j, joint in enumerate(JOINTS):
        act = config.actuators[j]
        lim = act.torque_limit
        over = np.maximum(np.abs(need[:, j]) - lim, 0.0)
        # the need is the links' and friction's plus the rotor's J ddq: the largest J
        # that keeps |links + J ddq| within the limit at every sample of the cycle
        a, b = ddq[:, j], links[:, j]
        moving = a != 0.0
        fits = (0.0 if np.any(np.abs(b) > lim) else
                max(0.0, float(np.min((lim - b[moving] * np.sign(a[moving]))
                                      / np.abs(a[moving])))))
        rows.append({"joint": joint, "need_rms_Nm": _rms(need[:, j]),
                     "need_peak_Nm": float(np.abs(need[:, j]).max()),
                     "inertial_rms_Nm": _rms(inertial[:, j]), "limit_Nm": float(lim),
                     "beyond_share": float(np.mean(over > 0.0)),
                     "floor_Nm_per_kg": _rms(over) / body_mass,
                     "rotor_inertia_kgm2": float(rotors[j]), "fits_kgm2": fits,
                     **limit_floors(act, need[:, j], dq[:, j], body_mass)})
    return rows


#: the physical limits a drive's torque meets, by name (:func:`limit_floors`)
LIMITS = ("gear's repeated peak", "drive's current limit", "bus voltage (back-EMF)",
          "rotor's permissible speed")


def limit_floors(act: Any, need: F64, w: F64, body_mass: float) -> dict[str, Any]:
    """What each of the actuator ``act``'s physical limits alone leaves the child of the
    device's ``need`` (N m per sample of the cycle) at joint speeds ``w`` (rad/s): per
    :data:`LIMITS`, the RMS of the need beyond the torque that limit allows, per kg
    (``floors_Nm_per_kg``), and all together (``floor_all_Nm_per_kg``: the drive's
    envelope, :func:`~exoleg.device.drive.drive_limit`); the gear's first mode with
    the rotor and the gear's input on its stiffness (``gear_mode_hz``: sqrt(k / N^2 J)
    / 2 pi), which bounds any torque loop's bandwidth (a loop on a joint torque sensor
    included).

    The torque each allows: the gear, its repeated peak; the drive, N eta k_t I_max;
    the voltage, N eta k_t (V - N k_t abs(w)) / R while the motor drives the motion (the
    need along the speed; braking, the back-EMF helps: no limit); the rotor's speed, none
    beyond N times its permissible speed while driving."""
    from exoleg.device.drive import drive_limit

    a = np.abs(need)
    driving = need * w > 0.0
    volt = np.where(driving, act.joint_torque_constant * np.maximum(
        0.0, (act.bus_voltage - act.torque_constant * act.ratio * np.abs(w))
        / act.terminal_resistance), np.inf)
    speed = np.where(driving & (np.abs(w) > act.permissible_speed), 0.0, np.inf)
    allowed = {LIMITS[0]: np.full_like(a, act.repeated_peak_torque),
               LIMITS[1]: np.full_like(a, act.current_limited_torque),
               LIMITS[2]: volt, LIMITS[3]: speed}
    A = act.record()
    envelope = np.array([drive_limit(A, wk, uk) for wk, uk in zip(w, need, strict=True)])
    return {"floors_Nm_per_kg": {k: _rms(np.maximum(a - v, 0.0)) / body_mass
                                 for k, v in allowed.items()},
            "floor_all_Nm_per_kg": _rms(np.maximum(a - envelope, 0.0)) / body_mass,
            "gear_mode_hz": float(np.sqrt(act.gear_stiffness / act.reflected_inertia)
                                  / (2 * np.pi))}


def contributions(r: Any, after: float | None = None, walks: Sequence[Any] | None = None,
                  acting: Sequence[str] | None = None, need: F64 | None = None
                  ) -> list[dict[str, Any]]:
    """The cuffs' torque a walk in the transparent mode leaves (``r``: a
    :class:`~exoleg.sim.walk.WalkResult`), and what it would be on the same motion
    without the law's parts, left out from the last: rows (``parts``, RMS N m and N m/kg
    per joint) over the walk from ``after`` s (default: :data:`SETTLE_STRIDES` strides
    after its start), a row per part ``acting`` in the walk (default: all of
    :data:`~exoleg.control.transparency.PARTS`). The same motion is a what-if: the
    child walks otherwise when a part is left out (the cuffs' feedback above all, which
    reacts to the walk it is in). With ``walks`` -- the same walk with only each row's
    parts acting, one walk per row but the last (whose walk is ``r``) -- each row also
    says what its walk left (``walked_Nm_per_kg``, per joint) and whether the safety
    layer stopped it (``stopped``).

    The same motion's rows but the last (the law's own walk) are the cuffs' torque plus the
    parts left out, as commanded -- or, given the device's ``need`` along the walk's
    settled samples (:func:`walk_need`, N m), that need less the parts kept, as commanded:
    the two agree where the drives deliver what they are asked, and the need's rows keep
    what they did not (a torque loop's lag behind a spring, a drive at its limit). With
    ``need`` the last row also says what the law's whole command leaves on its motion
    (``commanded_Nm_per_kg``): beside its walked figure, what the drives' delivery adds."""
    from exoleg.control.transparency import PARTS

    def settled(w: Any) -> Any:
        return w.t >= (w.walk_start + SETTLE_STRIDES * w.stride_time if after is None
                       else after)

    acting = list(PARTS if acting is None else acting)
    sel = settled(r)
    it = r.interaction[sel]
    parts = r.transparent_parts[sel]
    if walks is not None and len(walks) != len(acting):
        raise ParameterError("contributions", "walks", f"{len(walks)} walks: one per row "
                             f"but the last, {len(acting)}")
    every = [] if walks is None else [*walks, r]
    rows = []
    last = len(acting)
    for n in range(last + 1):
        kept = parts[:, [PARTS.index(p) for p in acting[:n]]].sum(axis=1)
        left_out = parts[:, [PARTS.index(p) for p in acting[n:]]].sum(axis=1)
        what_if = it + left_out if need is None or n == last else need - kept
        rms = np.sqrt(np.mean(what_if ** 2, axis=0))
        row: dict[str, Any] = {"parts": " + ".join(acting[:n]) or "none",
                               "rms_Nm": dict(zip(JOINTS, rms.tolist(), strict=True)),
                               "rms_Nm_per_kg": dict(zip(JOINTS, (rms / r.body_mass).tolist(),
                                                         strict=True))}
        if need is not None and n == last:
            row["commanded_Nm_per_kg"] = dict(zip(JOINTS, (np.sqrt(np.mean(
                (need - kept) ** 2, axis=0)) / r.body_mass).tolist(), strict=True))
        if every:
            w = every[n]
            walked = np.sqrt(np.mean(w.interaction[settled(w)] ** 2, axis=0)) / w.body_mass
            row["walked_Nm_per_kg"] = dict(zip(JOINTS, walked.tolist(), strict=True))
            row["stopped"] = bool(np.any(w.fault))
        rows.append(row)
    return rows


@dataclass(frozen=True)
class Transparency:
    """``exoleg validate --transparency``'s figures: the child, the budget rows, the
    contribution rows, each joint's share of the walk at the drive's limit, whether the
    safety layer stopped the walk, the run, per joint the physical floor along the
    walk's own motion (:func:`walk_floors`), the heel strikes' loading
    (:func:`heel_strike_loading`), the law's least-damped mode on each gear's stiffness
    (:func:`law_on_gears`) and the bounds the console allows the law's share and estimate
    within for this child (:func:`~exoleg.control.gears.law_bounds`)."""

    child: str
    body_mass: float
    budget: list[dict[str, Any]]
    rows: list[dict[str, Any]]
    saturated: dict[str, float]
    fault: bool
    run: Any
    floors: list[dict[str, Any]]
    loading: dict[str, Any]
    gears: list[dict[str, Any]]
    console: dict[str, list[list[float]]]
    landing: str = "drop"
    #: the child's leg, the device's configuration and :func:`walk_need` of the run (for
    #: :func:`unit_bound`'s of other units along the same motion)
    leg: Any = None
    config: Any = None
    need: dict[str, Any] | None = None

    @property
    def met(self) -> bool:
        """Every joint's residual within :data:`GOAL_NM_PER_KG`, no fault."""
        last = self.rows[-1]["rms_Nm_per_kg"]
        return not self.fault and all(v <= GOAL_NM_PER_KG for v in last.values())


def evaluate(strides: int = 10, stride_time: float = 1.1, seed: int = 0,
             device: str | Path | None = None, landing: str | None = None) -> Transparency:
    """The typically developing 10-year-old girl walking ``strides`` strides of
    ``stride_time`` s in the transparent mode (the sensors at their datasheet noise), on
    the device of the folder ``device`` (None: the shipped one), the other leg letting
    her down onto it as ``landing`` (:data:`~exoleg.device.ground.LANDINGS`; None: as the
    folder's ``walking.toml`` says)."""
    import dataclasses

    from exoleg.child.model import ChildModel
    from exoleg.control.safety import Limited
    from exoleg.control.transparency import PARTS, SupportMode
    from exoleg.device.ground import Ground
    from exoleg.sim.walk import simulate_walk
    from exoleg.sizing import personalized_leg
    from exoleg.sizing.child import population_child
    from exoleg.system.config import DeviceConfig

    if not (isinstance(strides, int) and SETTLE_STRIDES < strides <= 1000):
        raise ParameterError("validate.transparency", "strides",
                             f"{strides!r}: the first {SETTLE_STRIDES} are left out (the "
                             f"child settles into the walk); allowed {SETTLE_STRIDES + 1}-1000")
    c, _ = population_child(None, "female", 10.0, 50.0)
    child = ChildModel.of(c)
    leg = personalized_leg(c)
    config = DeviceConfig.load(device)
    ground = Ground.default(device)
    if landing is not None:
        ground = dataclasses.replace(ground, landing=landing)  # checked there
    r = simulate_walk(leg, c.mass, strides=strides, stride_time=stride_time, child=child,
                      seed=seed, support_mode=SupportMode.TRANSPARENT, device=device,
                      ground=ground)
    # the same walk with only the parts up to each row's acting (those the file has on)
    on = [p for p, is_on in zip(PARTS, config.transparency.parts, strict=True) if is_on]
    walks = [simulate_walk(leg, c.mass, strides=strides, stride_time=stride_time,
                           child=child, seed=seed, support_mode=SupportMode.TRANSPARENT,
                           device=device, ground=ground,
                           transparency=config.transparency.with_parts(*on[:n]))
             for n in range(len(on))]
    sel = r.t >= r.walk_start + SETTLE_STRIDES * stride_time
    lim = np.array([a.torque_limit for a in config.actuators])
    at = np.abs(r.tau[sel]) >= 0.99 * lim
    h = float(r.t[1] - r.t[0])
    need = walk_need(r, leg, config)
    return Transparency(child=c.name or "child", body_mass=c.mass,
                        budget=budget(leg, config, c.mass, stride_time),
                        rows=contributions(r, walks=walks, acting=on, need=need["need"]),
                        fault=bool(np.any(r.safety_status & Limited.FAULT)),
                        saturated=dict(zip(JOINTS, at.mean(axis=0).tolist(), strict=True)),
                        run=r, floors=walk_floors(r, leg, config, known=need),
                        loading=heel_strike_loading(r, g=leg.g),
                        gears=law_on_gears(leg, config.actuators, config.transparency, h),
                        console=law_bounds(leg, config.actuators, config.transparency, h),
                        landing=ground.landing, leg=leg, config=config, need=need)


#: the landing's window after each initial contact, s (the knee's deceleration and the
#: cuffs' peaks of the simulated heel strike lie within it)
LANDING_S = 0.045


def _contacts(load: F64, dt: float) -> NDArray[np.intp]:
    """The samples at which the sole's vertical ``load`` (sampled every ``dt`` s) becomes
    non-zero for a stance (:func:`~exoleg.sim.events.loads`: not a touch in swing); a
    load already on at the record's first sample is no contact."""
    from exoleg.sim.events import loads

    on = loads(load > 0.0, dt)[0]
    return on[on > 0]


def _landing(load: F64, dt: float) -> NDArray[np.bool_]:
    """The samples of the sole's ``load`` (sampled every ``dt`` s) in the
    :data:`LANDING_S` after each contact."""
    landing = np.zeros(len(load), dtype=bool)
    for k in _contacts(load, dt):
        landing[k:k + int(round(LANDING_S / dt))] = True
    return landing


def heel_strike_loading(r: Any, after: float | None = None, g: float = 9.81
                        ) -> dict[str, Any]:
    """How hard the walk ``r`` lands, beside Schwartz et al. 2008's children (free speed):
    at each initial contact of the device's foot from ``after`` s (default: as
    :func:`walk_floors`), the sole's vertical load 2 % of the stride after it
    (``at_2pct_bw``, in the child's body weight; theirs ``source_2pct_bw`` +- ``_sd``),
    the time within which it reaches one body weight (``to_1bw_ms``; theirs, at the first
    %-step their mean reaches 1 BW: ``source_to_1bw_ms``); medians over the contacts
    (the body weight at gravity ``g``, m/s^2).
    The device's own weight is in the load: the source's children carried none. And the
    landing's part of the cuffs' torque: the share of the walk in the :data:`LANDING_S`
    after each contact (``landing_share``), per joint the share of the cuffs' torque
    (squared) there (``cuffs_at_landing``) and its RMS per kg outside
    (``cuffs_outside_Nm_per_kg``). Contacts are the stances'
    (:func:`~exoleg.sim.events.loads`); the loads too short for one, the foot touching
    the belt in swing, are counted apart (``swing_touches``)."""
    from exoleg.reference.gait import schwartz2008
    from exoleg.sim.events import touches

    t0 = r.walk_start + SETTLE_STRIDES * r.stride_time if after is None else after
    load = r.contact_force.sum(axis=1) / (r.body_mass * g)
    dt = float(r.t[1] - r.t[0])
    onsets = _contacts(load, dt)
    onsets = onsets[(r.t[onsets] >= t0) & (onsets + int(0.2 * r.stride_time / dt) < len(load))]
    at2 = [load[k + int(round(0.02 * r.stride_time / dt))] for k in onsets]
    to1 = [dt * (int(np.argmax(load[k:] >= 1.0)) + 1) * 1e3 for k in onsets
           if np.any(load[k:k + int(0.5 * r.stride_time / dt)] >= 1.0)]
    pct, mean, sd = schwartz2008("grf_vertical")
    first = int(np.argmax(mean >= 1.0))
    sel = r.t >= t0  # the cuffs' torque in the LANDING_S after each contact, and outside
    landing = _landing(load[sel], dt)
    sq = np.square(r.interaction[sel])
    share = sq[landing].sum(axis=0) / np.maximum(sq.sum(axis=0), 1e-300)
    outside = np.sqrt(sq[~landing].mean(axis=0)) / r.body_mass
    return {"landing_share": float(landing.mean()),
            "swing_touches": float(len(touches(r.contact_force, r.t, t0))),
            "cuffs_at_landing": dict(zip(JOINTS, share.tolist(), strict=True)),
            "cuffs_outside_Nm_per_kg": dict(zip(JOINTS, outside.tolist(), strict=True)),
            "contacts": float(len(onsets)), "at_2pct_bw": float(np.median(at2)) if at2
            else float("nan"), "to_1bw_ms": float(np.median(to1)) if to1 else float("nan"),
            "source_2pct_bw": float(np.interp(2.0, pct, mean)),
            "source_2pct_sd": float(np.interp(2.0, pct, sd)),
            "source_to_1bw_ms": float(pct[first] / 100.0 * r.stride_time * 1e3)}


def loop_floor(act: Any, need: F64, w: F64, h: float, body_mass: float) -> float:
    """What a law that knows the device alone's ``need`` (N m per tick of ``h`` s: each
    tick's mean) exactly leaves the child, RMS per kg of ``body_mass``, through the loop
    that delivers it: at each tick it has the need of the ticks before (the sensors are
    read at the tick's start; what the tick will ask depends on its own accelerations)
    and extrapolates it along their last difference, commands that within the drive's
    envelope at the last speed ``w`` (rad/s), and the drive's torque loop -- the current
    loop, or behind a spring the torque loop -- delivers it as a first order of its
    bandwidth (:func:`~exoleg.device.drive.current_loop`, the tick's mean). Beside
    :func:`limit_floors` it adds the control rate and the torque loop's lag: an impact
    that stops the rotors within a tick is felt whatever the law. A ramp of slope ``a``
    N m/s within the limits leaves ``a / (2 pi f_c)`` (the first order's lag)."""
    return _rms(loop_left(act, need, w, h)[2:]) / body_mass


def loop_left(act: Any, need: F64, w: F64, h: float) -> F64:
    """:func:`loop_floor`'s ticks: what is left of ``need`` at each, N m (the first two,
    which have no need before them to extrapolate, left out of its RMS)."""
    import dataclasses

    if act.compliant:  # the torque loop on the spring stands where the current loop is
        act = dataclasses.replace(act, current_loop_bandwidth=act.torque_loop_bandwidth)
    left = np.zeros(len(need))
    _loop_left(act.record(), need, w, h, left)
    return left


@njit(cache=True)
def _loop_left(A, need, w, h, left):  # type: ignore[no-untyped-def]
    """:func:`loop_floor`'s ticks: what is left of ``need`` at each into ``left``."""
    tau = 0.0
    for k in range(2, len(need)):
        p = 2.0 * need[k - 1] - need[k - 2]
        lim = drive_limit(A, w[k - 1], p)
        tau, mean = current_loop(A, tau, min(max(p, -lim), lim), h)
        left[k] = need[k] - mean


#: :func:`rotor_floor`'s iterations at most (ADMM).
ADMM_ITERATIONS = 20000


def rotor_floor(act: Any, need: F64, q: F64, h: float, body_mass: float,
                tol: float = 1e-4, rho: float = 1.0) -> float:
    """What any law leaves the child through a compliant unit ``act`` -- even one that
    knew the whole walk ahead -- RMS per kg of ``body_mass``: the spring passes
    ``K (r - q) + c (dr/dt - dq/dt)`` (its rotor's angle ``r`` at the joint's side, the
    link's ``q`` per tick of ``h`` s), and the rotor moves only as its motor's torque,
    bounded by the drive's current limit, drives it: ``B d2r/dt2 + spring = tau_m``,
    ``abs(tau_m) <= N eta k_t I_max``. The least RMS of ``spring - need`` over every rotor
    path, a convex quadratic programme over the walk (ADMM on the torques scaled by the
    limit, its penalty starting at ``rho`` and balanced to the residuals, its sparse
    system factored at each change; to ``tol`` of its residuals within
    :data:`ADMM_ITERATIONS`, else a RuntimeError: an unconverged iterate is no bound).
    A relaxation of the device -- no tick's delay, no current loop, no voltage or speed
    limit, no friction -- so a bound below any law's residual: where the link's heel
    strikes ask the rotor to follow faster than its motor can turn it, the spring passes
    the difference."""
    from scipy import sparse
    from scipy.sparse.linalg import splu

    if not act.compliant:
        raise ValueError("rotor_floor: the unit is rigid (its rotor is its link)")
    n = len(need)
    K, c, B = act.series_stiffness, act.series_damping, act.reflected_inertia
    lim = act.current_limited_torque
    # the spring's torque S (r - q), the damper's rate a backward difference
    S = sparse.diags([np.full(n, K + c / h), np.full(n - 1, -c / h)], [0, -1], format="csc")
    S[0, 0] = K
    Sq = S @ q
    target = need + Sq
    # the motor's torque D r - S's offset on the inner ticks: B (r+ - 2 r + r-) / h^2 + spring
    a = B / (h * h)
    D = (sparse.diags([np.full(n - 2, a), np.full(n - 2, -2 * a), np.full(n - 2, a)],
                      [0, 1, 2], shape=(n - 2, n)) + S[1:-1]).tocsc() / lim
    off = Sq[1:-1] / lim
    StS, DtD = S.T @ S, D.T @ D
    lu = splu((StS + rho * DtD).tocsc())
    z = np.zeros(n - 2)
    y = np.zeros(n - 2)
    Stb = S.T @ target
    scale = max(float(np.linalg.norm(Stb)), 1.0)
    for k in range(ADMM_ITERATIONS):
        r = lu.solve(Stb + rho * (D.T @ (z - y + off)))
        Dr = D @ r - off
        z_old = z
        z = np.clip(Dr + y, -1.0, 1.0)
        y += Dr - z
        primal = float(np.linalg.norm(Dr - z)) / (tol * max(float(np.linalg.norm(Dr)), 1.0))
        dual = rho * float(np.linalg.norm(D.T @ (z - z_old))) / (tol * scale)
        if primal <= 1.0 and dual <= 1.0:
            return _rms(S @ r - target) / body_mass
        # the penalty balanced to the residuals (Boyd et al. 2011, section 3.4.1), each
        # against its own criterion: a fixed one converged slowly or not at all on a
        # stiff unit (a torque sensor on a gear's 16,000 N m/rad)
        if k % 20 == 19 and max(primal, dual) > 10.0 * min(primal, dual):
            f = 2.0 if primal > dual else 0.5
            rho *= f
            y /= f  # the scaled dual variable is the multiplier over the penalty
            lu = splu((StS + rho * DtD).tocsc())
    raise RuntimeError(f"rotor_floor: the quadratic programme did not converge to {tol:g} "
                       f"in {ADMM_ITERATIONS} iterations (residuals {primal:.3g} / "
                       f"{dual:.3g} of their criteria)")


@njit(cache=True)
def _pelvis_terms(q, dq, p, ddy, out):  # type: ignore[no-untyped-def]
    """What the pelvis's vertical acceleration ``ddy`` asks of the links ``p`` at each
    sample (:func:`~exoleg.dynamics.kernels.mass_height_terms`' gradient) into ``out``."""
    for k in range(len(ddy)):
        y0, y1, y2, _, _ = mass_height_terms(q[k], dq[k], p)
        out[k, 0] = y0 * ddy[k]
        out[k, 1] = y1 * ddy[k]
        out[k, 2] = y2 * ddy[k]


def walk_need(r: Any, leg: Any, config: Any, after: float | None = None) -> dict[str, Any]:
    """What the device alone needs along a walk's own motion (``r``: a
    :class:`~exoleg.sim.walk.WalkResult`) from ``after`` s (default: :data:`SETTLE_STRIDES`
    strides after its start): its angles and rates, their acceleration and the pelvis's
    vertical one by central differences (``q``, ``dq``, ``ddq``, ``ddy``), the need
    (``need``, N m: the device alone's inverse dynamics, its rotors as the links feel them,
    the pelvis's part -- the device's links carry the pelvis's bounce too, as
    :func:`~exoleg.child.interaction.interaction_torque` counts it -- and the actuators'
    friction), that pelvis's part alone (``pelvis``), the samples (``sel``) and the step
    (``dt``, s)."""
    from exoleg.child.interaction import device_leg
    from exoleg.device.actuator import params_array
    from exoleg.device.drive import friction

    t0 = r.walk_start + SETTLE_STRIDES * r.stride_time if after is None else after
    sel = r.t >= t0
    dt = float(r.t[1] - r.t[0])
    q, dq = r.q[sel], r.dq[sel]
    ddq = np.gradient(r.dq, dt, axis=0)[sel]
    ddy = np.gradient(np.gradient(r.pelvis, dt), dt)[sel]
    dev = device_leg(leg, config.actuators)
    A = params_array(config.actuators)
    pelvis = np.zeros_like(q)
    _pelvis_terms(q, dq, dev.p, ddy, pelvis)
    need = dev.inverse_dynamics(q, dq, ddq) + pelvis + np.array(
        [[friction(A[j:j + 1], w) for j, w in enumerate(row)] for row in dq])
    return {"sel": sel, "dt": dt, "q": q, "dq": dq, "ddq": ddq, "ddy": ddy, "need": need,
            "pelvis": pelvis}


def walk_floors(r: Any, leg: Any, config: Any, after: float | None = None,
                known: dict[str, Any] | None = None) -> list[dict[str, Any]]:
    """Per joint, :func:`limit_floors` and :func:`loop_floor` of the device alone's need
    along a walk's own motion (:func:`walk_need` of ``r``, a
    :class:`~exoleg.sim.walk.WalkResult`, from ``after`` s; or ``known``, its result
    already at hand): the floor the transparent law's residual on that walk is to be
    judged against (``floor_loop_Nm_per_kg``: every limit and the loop's lag together);
    ``floor_rotor_Nm_per_kg``, a compliant unit's :func:`rotor_floor` on its links' need
    (NaN for a rigid unit); ``pelvis_Nm_per_kg``, the RMS of the need's part from the
    pelvis's vertical acceleration;
    ``floor_unread_pelvis_Nm_per_kg``, the loop's floor of a law that knows all of the
    need but that part, which none of the device's sensors reads (the encoders, the foot's
    IMU): that part left to the child whole;
    ``gear_floor_at_landing``, the share of the gear's floor (its square) in the
    :data:`LANDING_S` after each initial contact; ``floor_loop_outside_Nm_per_kg``, the
    loop's floor outside those (beside :func:`heel_strike_loading`'s law outside them)."""
    w = walk_need(r, leg, config, after) if known is None else known
    sel, dt, q, dq = w["sel"], w["dt"], w["q"], w["dq"]
    need, pelvis = w["need"], w["pelvis"]
    # a compliant unit's links alone: its rotor is rotor_floor's
    links = links_need(leg, w) if any(a.compliant for a in config.actuators) else None
    landing = _landing(r.contact_force[sel].sum(axis=1), dt)

    def at_landing(j: int, act: Any) -> float:
        beyond = np.maximum(np.abs(need[:, j]) - act.repeated_peak_torque, 0.0) ** 2
        return float(beyond[landing].sum() / beyond.sum()) if beyond.sum() > 0 else 0.0

    outside = ~landing
    outside[:2] = False  # (loop_floor's first two ticks)
    lefts = [loop_left(act, need[:, j], dq[:, j], dt) for j, act in enumerate(config.actuators)]
    unread = [loop_left(act, need[:, j] - pelvis[:, j], dq[:, j], dt) + pelvis[:, j]
              for j, act in enumerate(config.actuators)]
    return [{"joint": joint, **limit_floors(act, need[:, j], dq[:, j], r.body_mass),
             "gear_floor_at_landing": at_landing(j, act),
             "floor_loop_Nm_per_kg": _rms(lefts[j][2:]) / r.body_mass,
             "floor_unread_pelvis_Nm_per_kg": _rms(unread[j][2:]) / r.body_mass,
             "floor_loop_outside_Nm_per_kg": _rms(lefts[j][outside]) / r.body_mass,
             "floor_rotor_Nm_per_kg": (rotor_floor(act, links[:, j], q[:, j], dt, r.body_mass)
                                       if act.compliant and links is not None else np.nan),
             "pelvis_Nm_per_kg": _rms(pelvis[:, j]) / r.body_mass}
            for j, (joint, act) in enumerate(zip(JOINTS, config.actuators, strict=True))]


def links_need(leg: Any, w: dict[str, Any]) -> F64:
    """What the device's links alone ask of each joint along a walk's motion (``w``:
    :func:`walk_need`'s), N m: their inverse dynamics, the pelvis's bounce included, no
    rotor -- not even a rigid unit's, which its link carries -- and no friction: what a
    series element passes to them."""
    from exoleg.child.interaction import device_links

    q, dq = w["q"], w["dq"]
    dl = device_links(leg)
    links = np.zeros_like(q)
    _pelvis_terms(q, dq, dl.p, w["ddy"], links)
    return links + dl.inverse_dynamics(q, dq, w["ddq"])


def unit_bound(act: Any, j: int, w: dict[str, Any], links: F64, body_mass: float) -> float:
    """What no law goes below with the unit ``act`` at joint ``j`` along a walk's motion
    (``w``: :func:`walk_need`'s; ``links``: :func:`links_need`'s), RMS per kg of
    ``body_mass``, the walk known ahead: behind a series element, its rotor following the
    links within its motor's current limit (:func:`rotor_floor`); rigid, the links' need
    with this unit's own rotor (N^2 J q'') and friction beyond its drive's envelope
    (:func:`limit_floors`' all together). Either is a relaxation of the device -- a unit
    whose bound is above the goal cannot meet it on this walk, whatever its law."""
    from exoleg.device.drive import friction

    q, dq, dt = w["q"][:, j], w["dq"][:, j], w["dt"]
    if act.compliant:
        return rotor_floor(act, links[:, j], q, dt, body_mass)
    A = act.record()
    need = links[:, j] + act.reflected_inertia * w["ddq"][:, j] + np.array(
        [friction(A, x) for x in dq])
    return float(limit_floors(act, need, dq, body_mass)["floor_all_Nm_per_kg"])


def _rms(x: F64) -> float:
    return float(np.sqrt(np.mean(np.square(x))))
