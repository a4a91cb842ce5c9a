"""The fixed-step closed-loop simulator: RK4 plant, sampled controller with zero-order hold."""

from __future__ import annotations

import logging
import os
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import cached_property
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from exoleg.control.controllers import Controller
from exoleg.control.laws import Law, law
from exoleg.dynamics.kernels import coefficients, diagnostics, forward_dynamics_sc, mass_matrix
from exoleg.dynamics.model import LegModel
from exoleg.errors import ParameterError, SimulationError
from exoleg.params.records import JOINTS, RangeOfMotion
from exoleg.reference.steps import Reference
from exoleg.sim.integrators import RESYNC, next_sincos, rk4_sc, sincos3
from exoleg.sim.series import TimeSeries

F64 = NDArray[np.float64]
log = logging.getLogger(__name__)


@njit(cache=True)
def _diagnose(p, g, kp_eff, Q, DQ, Qr, E):  # type: ignore[no-untyped-def]
    """E[k, 0..4] = kinetic, potential, Lyapunov V (eq 26), dq^T (Mdot - 2C) dq and
    dq^T Mdot dq (the size of the terms that cancel in the former) at every state k."""
    for k in range(Q.shape[0]):
        kin, pot, ver, mdq = diagnostics(Q[k], DQ[k], p, g)
        vq = 0.0
        for i in range(3):
            e = Qr[k, i] - Q[k, i]
            vq += 0.5 * kp_eff[i] * e * e
        E[k, 0], E[k, 1], E[k, 2], E[k, 3], E[k, 4] = kin, pot, kin + vq, ver, mdq


def warm_up() -> None:
    """Compile, or load from numba's cache, the kernels a scenario needs besides the
    stepper :func:`_run`: the per-state diagnostics and the control law an engine
    comparison calls from Python. The command line does this in its second process
    while the first compiles the stepper (numba compiles on one core; cold, the two
    together take several seconds)."""
    from exoleg import paper_leg
    from exoleg.control import PDGravity
    from exoleg.control.laws import control_law

    leg = paper_leg()
    ctrl = PDGravity(leg)
    states = np.zeros((2, 3))  # the argument types simulate() and the engines pass
    _diagnose(leg.p, leg.g, (1.0, 1.0, 1.0), states, states, states, np.empty((2, 5)))
    z = np.zeros(3)
    control_law((ctrl.kind, *ctrl.law_args()), z, z, (z, z, z), np.zeros(3))


@njit(cache=True, error_model="numpy")
def _run(p, g, c, ref, span, series, carry):  # type: ignore[no-untyped-def]
    """Integrate steps k0 .. k1-1 from the state in Q[k0], DQ[k0]: the leg ``p`` under
    gravity ``g``, the law ``c`` (kind, Kp, Kd, model coefficients, scale, saturation:
    :func:`~exoleg.control.laws.law`'s; tuples, passed by value), the reference ``ref``
    (Qr, DQr, DDQr), ``span`` (dt, the steps a control sample is held, k0, k1), the
    ``series`` written (Q, DQ, DDQ, U, SAT). ``carry`` (u (3,), mask (1,)) holds the
    torque and saturation flags between calls (so a run can be done in chunks). Returns
    the index of the first non-finite state, or -1.
    """
    kind, kp, kd, kc, scale, limit = c
    Qr, DQr, DDQr = ref
    dt, hold, k0, k1 = span
    Q, DQ, DDQ, U, SAT = series
    u, mask = carry
    coef = coefficients(p, g)
    q0, q1, q2 = Q[k0, 0], Q[k0, 1], Q[k0, 2]
    v0, v1, v2 = DQ[k0, 0], DQ[k0, 1], DQ[k0, 2]
    s0, c0, s1, c1, s2, c2 = sincos3(q0, q1, q2)
    held = k0 % hold  # steps since the controller last sampled
    for k in range(k0, k1):
        if held == hold:
            held = 0
        held += 1
        if held == 1:
            u[0], u[1], u[2], mask[0] = law(
                (kind, kp, kd, kc, scale, limit), (s0, c0, s1, c1, s2, c2), (q0, q1, q2),
                (v0, v1, v2), (Qr[k, 0], Qr[k, 1], Qr[k, 2]),
                (DQr[k, 0], DQr[k, 1], DQr[k, 2]), (DDQr[k, 0], DDQr[k, 1], DDQr[k, 2]))
        U[k, 0], U[k, 1], U[k, 2] = u[0], u[1], u[2]
        SAT[k] = mask[0]
        qn, vn, a = rk4_sc((s0, c0, s1, c1, s2, c2), (q0, q1, q2), (v0, v1, v2),
                           (u[0], u[1], u[2]), coef, dt)
        s0, c0, s1, c1, s2, c2 = next_sincos((s0, c0, s1, c1, s2, c2), (q0, q1, q2), qn, k + 1)
        q0, q1, q2 = qn
        v0, v1, v2 = vn
        Q[k + 1, 0], Q[k + 1, 1], Q[k + 1, 2] = qn
        DQ[k + 1, 0], DQ[k + 1, 1], DQ[k + 1, 2] = vn
        DDQ[k, 0], DDQ[k, 1], DDQ[k, 2] = a
        if not (np.isfinite(q0) and np.isfinite(q1) and np.isfinite(q2) and np.isfinite(v0)
                and np.isfinite(v1) and np.isfinite(v2)):
            return k + 1
    n = Q.shape[0] - 1
    if k1 == n:
        U[n, 0], U[n, 1], U[n, 2] = u[0], u[1], u[2]  # (not U[n] = u: its shape check
        SAT[n] = mask[0]                                # compiles numba's string formatting)
        DDQ[n, 0], DDQ[n, 1], DDQ[n, 2] = forward_dynamics_sc(
            (s0, c0, s1, c1, s2, c2), (v0, v1, v2), (u[0], u[1], u[2]), coef)
    return -1


@njit(inline="always")
def _inv3(M):  # type: ignore[no-untyped-def]
    """Inverse of a 3 x 3 matrix by its adjugate."""
    a, b, c = M[0, 0], M[0, 1], M[0, 2]
    d, e, f = M[1, 0], M[1, 1], M[1, 2]
    g, h, i = M[2, 0], M[2, 1], M[2, 2]
    A, B, C = e * i - f * h, f * g - d * i, d * h - e * g
    det = a * A + b * B + c * C
    out = np.empty((3, 3))
    out[0, 0], out[1, 0], out[2, 0] = A / det, B / det, C / det
    out[0, 1], out[1, 1] = (c * h - b * i) / det, (a * i - c * g) / det
    out[2, 1] = (b * g - a * h) / det
    out[0, 2], out[1, 2] = (b * f - c * e) / det, (c * d - a * f) / det
    out[2, 2] = (a * e - b * d) / det
    return out


@njit(inline="always")
def _largest_real_eigenvalue(A):  # type: ignore[no-untyped-def]
    """Largest real part of the eigenvalues of a 3 x 3 matrix: the roots of its
    characteristic polynomial l^3 - tr l^2 + c2 l - det, by Cardano in complex numbers."""
    tr = A[0, 0] + A[1, 1] + A[2, 2]
    c2 = (A[0, 0] * A[1, 1] - A[0, 1] * A[1, 0] + A[0, 0] * A[2, 2] - A[0, 2] * A[2, 0]
          + A[1, 1] * A[2, 2] - A[1, 2] * A[2, 1])
    det = (A[0, 0] * (A[1, 1] * A[2, 2] - A[1, 2] * A[2, 1])
           - A[0, 1] * (A[1, 0] * A[2, 2] - A[1, 2] * A[2, 0])
           + A[0, 2] * (A[1, 0] * A[2, 1] - A[1, 1] * A[2, 0]))
    # depressed cubic in x = l - tr/3:  x^3 + P x + Q = 0
    P = c2 - tr * tr / 3.0
    Q = -2.0 * tr ** 3 / 27.0 + tr * c2 / 3.0 - det
    disc = complex(Q * Q / 4.0 + P ** 3 / 27.0) ** 0.5
    u = (-Q / 2.0 + disc) ** (1.0 / 3.0)
    if abs(u) < 1e-300:
        u = (-Q / 2.0 - disc) ** (1.0 / 3.0)
    best = -np.inf
    w = complex(-0.5, 0.8660254037844386)  # a cube root of unity
    for k in range(3):
        uk = u * w ** k
        x = uk - P / (3.0 * uk) if abs(uk) > 1e-300 else 0.0j
        best = max(best, (x + tr / 3.0).real)
    return best


@njit(cache=True)
def _margin(p, p_model, kind, kd, scale, h, postures):  # type: ignore[no-untyped-def]
    """Largest h * Re lambda(A) over the postures (N, 3), A the gain of the held velocity
    feedback on the plant: A = scale M_plant^-1 Kd for PD and PD + gravity compensation
    (Kd in N m s/rad), A = scale M_plant^-1 M_model Kd for computed torque (Kd in 1/s)."""
    Mp = np.empty((3, 3))
    Mm = np.empty((3, 3))
    B = np.empty((3, 3))
    best = 0.0
    for k in range(postures.shape[0]):
        mass_matrix(postures[k], p, Mp)
        Minv = _inv3(Mp)
        if kind == Law.COMPUTED_TORQUE:
            mass_matrix(postures[k], p_model, Mm)
        else:
            Mm[:] = np.eye(3)
        for i in range(3):  # B = M_plant^-1 M_model Kd scale (no BLAS in numba without scipy)
            for j in range(3):
                B[i, j] = scale * kd[j] * (Minv[i, 0] * Mm[0, j] + Minv[i, 1] * Mm[1, j]
                                           + Minv[i, 2] * Mm[2, j])
        best = max(best, h * _largest_real_eigenvalue(B))
    return best


def sampled_stability(leg: LegModel, controller: Controller, h: float,
                      postures: ArrayLike) -> float:
    """Largest h * lambda_max of the velocity-feedback gain over the postures (N, 3): a held
    velocity feedback is stable only while this is < 2 (``docs/conventions.md``, "Sampled
    control at 1 kHz"). The gain is M^-1 Kd for PD and PD + gravity compensation (Kd in
    N m s/rad) and M^-1 M_model Kd, i.e. Kd (1/s) when the model is exact, for computed
    torque; both times the controller's torque scale."""
    P = np.ascontiguousarray(np.atleast_2d(np.asarray(postures, dtype=float)))
    model = controller.model if controller.model is not None else leg
    return float(_margin(leg.p, model.p, controller.kind,
                         np.ascontiguousarray(controller.Kd, dtype=float), controller.scale, h, P))


#: Memory a run keeps per step, bytes: t; q, dq, ddq, u, the three references, error and
#: saturation (3 each); five diagnostics; float64 throughout.
BYTES_PER_STEP = 8 * (1 + 3 * 9 + 5)


def available_memory() -> int | None:
    """Bytes of memory available now (Linux: MemAvailable; else physical memory), or None."""
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except OSError:
        pass
    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return None


@dataclass(frozen=True)
class SimResult(TimeSeries):
    """Named time series of a run; arrays (N,) or (N, 3), joints ordered (hip, knee, ankle).

    Computed on first access (one compiled pass over the run, then kept): error =
    q_ref - q; kinetic, potential J; lyapunov V of eq 26 (J); verification
    dq^T (Mdot - 2C) dq (W) and verification_scale abs(dq^T Mdot dq) (W), the size of
    what cancels in it.

    Parameters
    ----------
    t : ndarray
        s.
    q, dq, ddq : ndarray
        rad, rad/s, rad/s^2.
    u : ndarray
        The held torque, N m.
    q_ref : ndarray
        rad.
    saturated : ndarray of bool
        (N, 3): where the torque was saturated.
    stability_margin : float
        The largest h * lambda of the velocity feedback checked before the run (< 2
        stable, see :func:`sampled_stability`).
    notes : tuple of str
        What the caller should know (e.g. a run outside the device's range of motion, on
        request).
    leg : LegModel, optional
        The leg simulated (for the diagnostics).
    kp_effective : ndarray, optional
        The stiffness the V of eq 26 is built with.
    """

    t: F64
    q: F64
    dq: F64
    ddq: F64
    u: F64
    q_ref: F64
    saturated: NDArray[np.bool_]
    stability_margin: float = float("nan")
    notes: tuple[str, ...] = ()
    leg: LegModel | None = field(default=None, repr=False)
    kp_effective: F64 | None = field(default=None, repr=False)

    @cached_property
    def error(self) -> F64:
        return self.q_ref - self.q

    @cached_property
    def _diagnostics(self) -> F64:
        if self.leg is None or self.kp_effective is None:
            raise ParameterError("SimResult", "leg",
                                 "the diagnostics need the run's leg and gains (kp_effective)")
        E = np.empty((len(self.q), 5))
        _diagnose(self.leg.p, self.leg.g, tuple(map(float, self.kp_effective)), self.q,
                  self.dq, self.q_ref, E)
        return E

    @property
    def kinetic(self) -> F64:
        return self._diagnostics[:, 0]

    @property
    def potential(self) -> F64:
        return self._diagnostics[:, 1]

    @property
    def lyapunov(self) -> F64:
        return self._diagnostics[:, 2]

    @property
    def verification(self) -> F64:
        return self._diagnostics[:, 3]

    @property
    def verification_scale(self) -> F64:
        return np.abs(self._diagnostics[:, 4])

    def columns(self) -> dict[str, F64]:
        """Every series as named 1-D columns (``q_hip``, ``u_ankle``, ...).

        Returns
        -------
        dict of str to ndarray
            SI units, rad.
        """
        cols: dict[str, F64] = {"t": self.t}
        for name in ("q", "dq", "ddq", "u", "q_ref", "error", "saturated"):
            arr = getattr(self, name)
            for i, j in enumerate(JOINTS):
                cols[f"{name}_{j}"] = arr[:, i].astype(float)
        for name in ("kinetic", "potential", "lyapunov", "verification", "verification_scale"):
            cols[name] = getattr(self, name)
        return cols



def _rom(range_of_motion: RangeOfMotion | None) -> RangeOfMotion:
    from exoleg.params.paper import range_of_motion as device_rom

    return device_rom() if range_of_motion is None else range_of_motion


def check_inputs(where: str, leg: Any, controller: Any = None, reference: Any = None
                 ) -> None:
    """The run's model, controller and reference are what they must be (ParameterError
    naming the one that is not and what it must be): a :class:`LegModel`, a controller
    record (:func:`exoleg.control.PDGravity`, ``PD``, ``ComputedTorque``), a reference
    with ``sample(t)`` (``Steps``, ``MinJerk``, ``SchwartzGait2008``)."""
    if not isinstance(leg, LegModel):
        raise ParameterError(where, "leg", f"expected a LegModel (exoleg.paper_leg(), "
                             f"exoleg.load_leg(...)), got {type(leg).__name__}")
    if controller is not None and not isinstance(controller, Controller):
        raise ParameterError(where, "controller", "expected a controller record "
                             "(exoleg.control.PDGravity, PD or ComputedTorque), got "
                             f"{type(controller).__name__}")
    if reference is not None and not callable(getattr(reference, "sample", None)):
        raise ParameterError(where, "reference", "expected a reference with sample(t) "
                             "(exoleg.reference.Steps, MinJerk, SchwartzGait2008), got "
                             f"{type(reference).__name__}")


def check_run(reference: Reference, duration: float, dt: float, q0: ArrayLike | None,
              dq0: ArrayLike | None, bytes_per_step: int = BYTES_PER_STEP,
              range_of_motion: RangeOfMotion | None = None,
              beyond_range_of_motion: bool = False
              ) -> tuple[F64, F64, F64, F64, F64, F64, list[str]]:
    """What every fixed-step run checks before it starts, and the arrays it starts from:
    (t, q_ref, dq_ref, ddq_ref, q0, dq0, notes). Refuses (ParameterError naming the input
    and what is allowed) fewer than one step, more steps than half the memory available
    holds at ``bytes_per_step``, a reference that is not finite or not (N, 3), a start
    or reference outside the range of motion unless ``beyond_range_of_motion`` (then
    ``notes`` say so)."""
    for nm, v in (("duration", duration), ("dt", dt)):
        if not (isinstance(v, (int, float, np.floating)) and np.isfinite(v) and v > 0):
            raise ParameterError("simulate", nm, f"must be a finite time > 0 s, got {v!r}")
    steps = duration / dt
    if steps < 0.5:
        raise ParameterError("simulate", "duration",
                             f"{duration!r} s is less than one step of dt = {dt!r} s; allowed: "
                             f"duration >= dt")
    avail = available_memory()
    need = (steps + 1) * bytes_per_step
    if avail is not None and need > 0.5 * avail:
        raise ParameterError("simulate", "duration",
                             f"{duration:g} s at dt = {dt:g} s is {steps:.3g} steps and needs "
                             f"{need / 2**30:.3g} GiB; {avail / 2**30:.3g} GiB is available "
                             f"(allowed: at most {0.5 * avail / bytes_per_step * dt:.4g} s at "
                             "this dt, half the memory available)")
    n = int(round(steps))
    t: F64 = (np.arange(n + 1) * dt).astype(np.float64)
    Qr, DQr, DDQr = (np.ascontiguousarray(a, dtype=np.float64) for a in reference.sample(t))
    for name, arr in (("q_ref", Qr), ("dq_ref", DQr), ("ddq_ref", DDQr)):
        if arr.shape != (n + 1, 3):
            raise ParameterError("simulate", "reference",
                                 f"sample(t) returned {name} of shape {arr.shape}, expected "
                                 f"({n + 1}, 3)")
        nonfinite = np.argwhere(~np.isfinite(arr))
        if len(nonfinite):
            ks, js = int(nonfinite[0][0]), int(nonfinite[0][1])
            raise ParameterError("simulate", "reference",
                                 f"{name} is not finite at t = {t[ks]:.6g} s ({JOINTS[js]}): "
                                 f"{arr[ks, js]}; references must be finite numbers")
    q_init = Qr[0].copy() if q0 is None else np.asarray(q0, dtype=float)
    dq_init = np.zeros(3) if dq0 is None else np.asarray(dq0, dtype=float)
    for name, vec in (("q0", q_init), ("dq0", dq_init)):
        if vec.shape != (3,) or not np.all(np.isfinite(vec)):
            raise ParameterError("simulate", name, f"expected 3 finite values, got {vec!r}")
    rom = _rom(range_of_motion)
    notes: list[str] = []
    for name, arr in (("reference", Qr), ("q0", q_init[None])):
        out = outside_range(arr, rom)
        if out:
            if not beyond_range_of_motion:
                raise ParameterError("simulate", name, out + " (allowed: the device's range of "
                                     "motion; beyond_range_of_motion=True to simulate anyway)")
            notes.append(f"{name} outside the device's range of motion, simulated on request: "
                         + out)
    return t, Qr, DQr, DDQr, q_init, dq_init, notes


def simulate(leg: LegModel, controller: Controller, reference: Reference, duration: float,
             dt: float = 1e-3, q0: ArrayLike | None = None, dq0: ArrayLike | None = None,
             control_dt: float | None = None,
             progress: Callable[[float], None] | None = None,
             range_of_motion: RangeOfMotion | None = None,
             beyond_range_of_motion: bool = False) -> SimResult:
    """Simulate the closed loop for ``duration`` s with RK4 steps of ``dt`` s.

    Refused before the run (:class:`~exoleg.errors.ParameterError`, naming the input and
    what is allowed): fewer than one step; more steps than the memory available holds;
    gains the sampled loop cannot keep stable (:func:`sampled_stability` >= 2); a start
    posture or reference outside ``range_of_motion`` unless ``beyond_range_of_motion``.
    Raises :class:`~exoleg.errors.SimulationError` naming the time and joint if the state
    stops being finite.

    Parameters
    ----------
    leg : LegModel
        The plant.
    controller : exoleg.control.controllers.Controller
        The law (:func:`~exoleg.control.PDGravity`, ...).
    reference : Reference
        What it follows (:mod:`exoleg.reference`).
    duration : float
        s.
    dt : float, default 0.001
        The RK4 step, s.
    q0, dq0 : array_like, optional
        The start; default the reference's first posture at rest.
    control_dt : float, optional
        The controller's period, a whole multiple of ``dt`` (its torque held in between);
        default ``dt``.
    progress : callable, optional
        Called with the fraction done (the run is then done in about 100 chunks; the
        result is the same bit for bit).
    range_of_motion : RangeOfMotion, optional
        Default the device's (paper section 2.1).
    beyond_range_of_motion : bool, default False
        Run outside it all the same; the result's ``notes`` say so.

    Returns
    -------
    SimResult
        Diagnostics (energies, V, verification signal) are computed when first read.
    """
    check_inputs("simulate", leg, controller, reference)
    t, Qr, DQr, DDQr, q_init, dq_init, notes = check_run(
        reference, duration, dt, q0, dq0, range_of_motion=range_of_motion,
        beyond_range_of_motion=beyond_range_of_motion)
    cdt = dt if control_dt is None else control_dt
    if not (isinstance(cdt, (int, float, np.floating)) and np.isfinite(cdt) and cdt > 0):
        raise ParameterError("simulate", "control_dt", f"must be a finite time > 0 s, got {cdt!r}")
    hold = int(round(cdt / dt))
    if hold < 1 or abs(hold * dt - cdt) > 1e-9 * cdt:
        raise ParameterError("simulate", "control_dt",
                             f"must be a whole multiple of dt = {dt} s, got {cdt!r}")
    n = len(t) - 1
    rom = _rom(range_of_motion)
    # the stability margin depends on the posture: the start and ~500 reference samples
    postures = np.vstack([q_init, Qr[:: max(1, len(Qr) // 500)]])
    margin = sampled_stability(leg, controller, hold * dt, postures)
    if margin >= 2.0:
        raise ParameterError("simulate", "Kd/control_dt",
                             f"h * lambda = {margin:.3f} >= 2 ({_GAIN_NAME[controller.kind]}): the "
                             f"sampled loop is unstable; largest stable control step "
                             f"{2 * hold * dt / margin:.2e} s or Kd scaled by < {2 / margin:.3g}")
    if margin > 1.8:
        log.warning("sampled loop near its stability edge: h * lambda = %.3f (limit 2)", margin)
    Q, DQ, DDQ, U = (np.empty((n + 1, 3)) for _ in range(4))
    SAT = np.zeros(n + 1, dtype=np.int64)
    Q[0], DQ[0] = q_init, dq_init
    u, mask = np.zeros(3), np.zeros(1, dtype=np.int64)
    # chunks start where the stepper re-anchors its carried sin/cos anyway, so a run with
    # progress reports is bit for bit the run without
    chunk = n if progress is None else RESYNC * max(1, n // (100 * RESYNC))
    bad = -1
    for k0 in range(0, n, chunk):
        k1 = min(n, k0 + chunk)
        bad = _run(leg.p, leg.g, (controller.kind, *controller.law_args()), (Qr, DQr, DDQr),
                   (dt, hold, k0, k1), (Q, DQ, DDQ, U, SAT), (u, mask))
        if progress is not None:
            progress(k1 / n)
        if bad >= 0:
            break
    if bad >= 0:
        j = [JOINTS[i] for i in range(3)
             if not (np.isfinite(Q[bad, i]) and np.isfinite(DQ[bad, i]))]
        raise SimulationError(f"state became non-finite at t = {t[bad]:.6g} s ({', '.join(j)})")
    left = outside_range(Q, rom)
    if left:
        notes.append("the leg left the device's range of motion during the run: " + left)
    sat = ((SAT[:, None] >> np.arange(3)) & 1).astype(bool)
    return SimResult(t=t, q=Q, dq=DQ, ddq=DDQ, u=U, q_ref=Qr, saturated=sat,
                     stability_margin=margin, notes=tuple(notes), leg=leg,
                     kp_effective=controller.scale * controller.Kp)


_GAIN_NAME = {Law.PD: "lambda of M^-1 Kd", Law.PD_GRAVITY: "lambda of M^-1 Kd",
              Law.COMPUTED_TORQUE: "lambda of M^-1 M_model Kd, Kd in 1/s"}


def outside_range(Q: F64, rom: RangeOfMotion, tol: float = 1e-9) -> str:
    """'' when every posture of Q (N, 3) lies within ``rom``; else where the first one
    leaves it, in degrees (joint, value, allowed range)."""
    below = Q < rom.lower - tol
    above = Q > rom.upper + tol
    bad = np.argwhere(below | above)
    if not len(bad):
        return ""
    k, j = int(bad[0][0]), int(bad[0][1])
    worst = float(np.max(np.where(below[:, j], rom.lower[j] - Q[:, j],
                                  np.where(above[:, j], Q[:, j] - rom.upper[j], 0.0))))
    return (f"{JOINTS[j]} at {np.degrees(Q[k, j]):.4g} deg (sample {k}; up to "
            f"{np.degrees(worst):.3g} deg beyond), allowed {np.degrees(rom.lower[j]):g} to "
            f"{np.degrees(rom.upper[j]):g} deg")
