"""The paper's laws on the device: a reference followed by PD + gravity compensation (eq
23), plain PD or computed torque (:mod:`exoleg.control.controllers`), behind the shared
supervisor (:mod:`exoleg.control.supervisor`) and the safety layer -- the
:class:`~exoleg.control.contract.Controller` contract, so ``exoleg run --controller
pd-gravity`` drives the simulated device, the CANopen drives and the EtherCAT drives
with the law ``exoleg simulate`` checks against the paper.

The reference keeps its own clock, which runs only while WALKING: armed and standing,
the device holds the reference where its clock stands (at the start, its first
posture), at rest; WALK runs it on from there, STAND stops it where it is -- so neither
command makes the reference jump.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping
from typing import Any, Protocol

import numpy as np
from numba import njit
from numpy.typing import ArrayLike, NDArray

from exoleg import checks as _check
from exoleg.control import safety as sf
from exoleg.control.controllers import Controller as LawRecord
from exoleg.control.gait_phase import Phase, Source
from exoleg.control.laws import control_law
from exoleg.control.safety import SafetyLimits, safety_step
from exoleg.control.supervisor import SUPERVISOR, report, settle, supervise
from exoleg.errors import ParameterError
from exoleg.layout import new
from exoleg.reference.steps import Reference
from exoleg.tick import OUTPUT, SENSORS, Mode, TickRecords


@njit(cache=True)
def guard_step(lim, sst, sup, sens, refused, u, qr, out):  # type: ignore[no-untyped-def]
    """What every law's torque ``u`` (3,) N m goes through: the safety layer on the
    readings ``sens`` (:data:`~exoleg.tick.SENSORS`), the supervisor (already told this
    tick's command, ``refused`` what it refused) settling on a fault, its report, and the
    reference ``qr`` (3,) followed. Writes ``out`` (:data:`~exoleg.tick.OUTPUT`)."""
    s = sens[0]
    o = out[0]
    status = safety_step(lim, sst, s.q, s.dq, u, False, o.tau)
    settle(sup, sst)
    report(sup, sst, refused, status, out)
    o.phase = Phase.UNKNOWN
    o.gait_source = Source.NONE
    o.gait_fraction = 0.0
    o.events = 0
    for j in range(3):
        o.q_ref[j] = qr[j]
        o.support_level[j] = 1.0  # the law carries the leg along its reference


@njit(cache=True)
def track_step(params, guard, sens, refused, ref, out):  # type: ignore[no-untyped-def]
    """A compiled law (``params``: its record, :func:`~exoleg.control.laws.control_law`)
    at the reference ``ref`` (q, dq, ddq: (3,) each) on the readings ``sens``, then
    :func:`guard_step` (``guard``: the safety layer's limits and state and the
    supervisor's)."""
    s = sens[0]
    u = np.empty(3)
    control_law(params, s.q, s.dq, ref, u)
    lim, sst, sup = guard
    guard_step(lim, sst, sup, sens, refused, u, ref[0], out)


#: The ticks as Python calls them (numba's dispatcher has no signature for a type checker).
_supervise: Callable[..., int] = supervise
_track: Callable[..., None] = track_step
_guard: Callable[..., None] = guard_step


class CustomLaw(Protocol):
    """A control law of your own (``docs/extending/controller.md``): the torque (3,) N m
    for the joints' state and the reference, each (3,) -- angles rad, rates rad/s,
    accelerations rad/s^2, ordered hip, knee, ankle. It may also offer the
    ``gains_now`` and ``set_gains`` of :class:`~exoleg.tick.Controller`."""

    def torque(self, q: NDArray[np.float64], dq: NDArray[np.float64],
               q_ref: NDArray[np.float64], dq_ref: NDArray[np.float64],
               ddq_ref: NDArray[np.float64]) -> ArrayLike: ...


def law_factory(spec: str) -> Callable[[Any], CustomLaw]:
    """The factory named by ``spec``: ``FILE.py:NAME`` (a Python file, relative to the
    current folder or absolute) or ``MODULE:NAME`` (an importable module), whose NAME is
    called with the leg model the law may use (the child + device leg with the actuators'
    reflected inertia) and returns a :class:`CustomLaw`. A ParameterError names what
    was missing or wrong."""
    import importlib
    import importlib.util
    from pathlib import Path

    w, what = "controller", "--controller"
    where, _, name = str(spec).rpartition(":")
    if not where or not name.isidentifier():
        raise ParameterError(w, what, f"{spec!r}: expected FILE.py:NAME or MODULE:NAME "
                             "(a law of your own) or one of the controllers' names")
    if where.endswith(".py"):
        path = Path(where).expanduser().resolve()
        if not path.is_file():
            raise ParameterError(w, what, f"{spec!r}: no file {path}")
        mod_spec = importlib.util.spec_from_file_location(f"exoleg_law_{path.stem}", path)
        assert mod_spec is not None and mod_spec.loader is not None
        module = importlib.util.module_from_spec(mod_spec)
        try:
            mod_spec.loader.exec_module(module)
        except Exception as e:  # the user's file: say what failed in it, in one line
            raise ParameterError(w, what, f"{spec!r}: {path.name} failed to load: "
                                 f"{type(e).__name__}: {e}") from None
    else:
        try:
            module = importlib.import_module(where)
        except ImportError as e:
            raise ParameterError(w, what, f"{spec!r}: cannot import {where!r} ({e})") from None
    factory = getattr(module, name, None)
    if not callable(factory):
        raise ParameterError(w, what, f"{spec!r}: {where} has no callable {name!r}")
    return factory


class TrackingController:
    """``law`` following ``reference`` on the device, with the supervisor and the safety
    layer (``safety``, default :meth:`SafetyLimits.paper`): one of the paper's (a
    :class:`~exoleg.control.controllers.Controller` record: PDGravity, PD, ComputedTorque;
    compiled) or a :class:`CustomLaw` of your own (its ``torque`` called from Python each
    tick, then the same compiled supervisor and safety layer)."""

    def __init__(self, law: LawRecord | CustomLaw, reference: Reference,
                 safety: SafetyLimits | None = None) -> None:
        w = "TrackingController"
        if not isinstance(law, LawRecord) and not callable(getattr(law, "torque", None)):
            raise ParameterError(w, "law", "expected a controller record (PDGravity, PD, "
                                 "ComputedTorque) or a law with torque(q, dq, q_ref, dq_ref, "
                                 f"ddq_ref), got {type(law).__name__}")
        if not callable(getattr(reference, "sample", None)):
            raise ParameterError(w, "reference", "expected a reference with sample(t) "
                                 f"(Steps, MinJerk, SchwartzGait2008), got "
                                 f"{type(reference).__name__}")
        if safety is not None and not isinstance(safety, SafetyLimits):
            raise ParameterError(w, "safety", f"expected SafetyLimits, got "
                                 f"{type(safety).__name__}")
        self.law = law
        self.reference = reference
        self.safety = SafetyLimits.paper() if safety is None else safety
        self.lim, self.sst, self.sup = self.safety.record(), sf.new_state(), new(SUPERVISOR)
        self.io = TickRecords("TrackingController.update")
        self.clock = 0.0       # the reference's own time, s: runs only while walking
        self._since = 0.0      # the session time the reference's clock last started from
        self._held: tuple[float, Any, Any, Any] | None = None  # the reference at rest
        self._own = None if isinstance(law, LawRecord) else law
        if isinstance(law, LawRecord):
            self._args = law.call_args()  # arrays: typed in C at each call from Python

    def warm_up(self) -> None:
        """Compile (or load from numba's cache) on copies of the state."""
        sst, sup, z = self.sst.copy(), self.sup.copy(), np.zeros(3)
        refused = _supervise(sup, self.lim, sst, 0, z, z)
        if self._own is None:
            _track(self._args, (self.lim, sst, sup), new(SENSORS), refused, (z, z, z),
                   new(OUTPUT))
        else:  # a law of one's own fails here, before the clock starts, if it must
            _guard(self.lim, sst, sup, new(SENSORS), refused,
                   self._torque(z, z, z, z, z), z, new(OUTPUT))
        self.reference.sample(np.zeros(1))

    def _torque(self, *state: NDArray[np.float64]) -> NDArray[np.float64]:
        """A law of one's own's torque: 3 numbers (NaN or infinite ones the safety layer
        takes the torque off for), else a ParameterError (a controller error)."""
        assert self._own is not None
        u = np.asarray(self._own.torque(*(x.copy() for x in state)), dtype=float)
        if u.shape != (3,):
            raise ParameterError(type(self._own).__name__, "torque",
                                 f"expected 3 torques (hip, knee, ankle), got shape {u.shape}")
        return u

    def update(self, sensors: Mapping[str, Any], command: int, t: float) -> dict[str, Any]:
        """One tick (the :class:`~exoleg.control.contract.Controller` contract)."""
        self.io.read(sensors, command)
        r = self.io.sens[0]
        before = int(self.sup[0]["mode"])
        refused = _supervise(self.sup, self.lim, self.sst, int(r["command"]), r["q"], r["dq"])
        if int(self.sup[0]["mode"]) == Mode.STOPPING:  # no stride to finish: stop here
            self.sup[0]["mode"] = Mode.STANDING
        walking = int(self.sup[0]["mode"]) == Mode.WALKING
        if walking and before != Mode.WALKING:
            self._since = float(t) - self.clock
        if walking:
            self.clock = float(t) - self._since
        if walking or self._held is None or self._held[0] != self.clock:
            q, dq, ddq = (np.ascontiguousarray(x[0], dtype=float)
                          for x in self.reference.sample(np.array([self.clock])))
            if not walking:  # held where the reference's clock stands, at rest
                dq, ddq = np.zeros(3), np.zeros(3)
                self._held = (self.clock, q, dq, ddq)  # sampled once while it stands
        else:
            _, q, dq, ddq = self._held
        if self._own is None:
            _track(self._args, (self.lim, self.sst, self.sup), self.io.sens, refused,
                   (q, dq, ddq), self.io.out)
        else:
            _guard(self.lim, self.sst, self.sup, self.io.sens, refused,
                   self._torque(r["q"], r["dq"], q, dq, ddq), q, self.io.out)
        return self.io.result()

    def gains_now(self) -> dict[str, list[float]]:
        """Kp and Kd per joint (the law's units: N m/rad and N m s/rad; computed torque
        1/s^2 and 1/s); a law of one's own: its ``gains_now()``, if it has one."""
        if self._own is not None:
            own = getattr(self._own, "gains_now", None)
            return dict(own()) if callable(own) else {}
        return {"Kp": [float(x) for x in self._args[1]], "Kd": [float(x) for x in self._args[2]]}

    def set_gains(self, change: dict[str, list[float]]) -> None:
        """Change Kp and/or Kd between ticks: all of ``change`` or, if any value is unknown,
        not finite or outside 0-1e4, none (ParameterError)."""
        if self._own is not None:
            own = getattr(self._own, "set_gains", None)
            if not callable(own):
                raise ParameterError("TrackingController.set_gains", "law",
                                     f"{type(self._own).__name__} has no gains to change")
            own(change)
            return
        where = "TrackingController.set_gains"
        now = self.gains_now()
        new_ = dict(now)
        for k, v in change.items():
            if k not in now:
                raise ParameterError(where, k, f"unknown gain (allowed: {', '.join(now)})")
            x = _check.vector(where, k, v, 3)
            if np.any(x < 0) or np.any(x > 1e4):
                raise ParameterError(where, k, f"gains are 0-1e4 per joint, got {x.tolist()}")
            new_[k] = [float(a) for a in x]
        self._args[1][:] = new_["Kp"]
        self._args[2][:] = new_["Kd"]
