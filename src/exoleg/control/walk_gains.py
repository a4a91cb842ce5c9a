"""The walking controller's settings (:class:`WalkGains`, from ``walking_control.toml``:
impedance per phase, the standing posture, the stance support, the stand's blend) and
the parameters record its compiled tick reads (:data:`PARAMS`), with what an operator
may change between ticks (:data:`TUNABLE`)."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike, NDArray

from exoleg import checks as _check
from exoleg.control.gears import LAW_TUNABLE
from exoleg.errors import ParameterError
from exoleg.layout import F8, new
from exoleg.reference.gait import MID_STANCE
from exoleg.sizing.anthropometry import body_mass_of

F64 = NDArray[np.float64]


@dataclass(frozen=True)
class WalkGains:
    """Impedance per phase (N m/rad, N m s/rad; hip, knee, ankle), the standing posture
    (rad), the stance support level (0: none -- transparency -- to 1: the body weight
    carried through the leg's joints) and how long a stand from walking takes to bring
    the reference to the standing posture (s)."""

    kp_stance: F64
    kd_stance: F64
    kp_swing: F64
    kd_swing: F64
    standing: F64
    support: float
    stand_blend: float

    def __post_init__(self) -> None:
        w = "WalkGains"
        for name in ("kp_stance", "kd_stance", "kp_swing", "kd_swing"):
            v = _check.vector(w, name, list(getattr(self, name)), 3)
            if np.any(v < 0) or np.any(v > 1e4):
                raise ParameterError(w, name, f"gains are 0-1e4 per joint, got {v.tolist()}")
            object.__setattr__(self, name, v)
        object.__setattr__(self, "standing", _check.vector(w, "standing", list(self.standing), 3))
        object.__setattr__(self, "support", _check.within(w, "support", self.support, 0.0, 1.0))
        object.__setattr__(self, "stand_blend", _check.within(
            w, "stand_blend", self.stand_blend, *STAND_BLEND_S, unit="s"))

    @classmethod
    def default(cls, folder: str | Path | None = None) -> WalkGains:
        """From ``walking_control.toml`` (a device folder's, :mod:`exoleg.device.files`,
        or the package's)."""
        from exoleg.device.files import load

        where, d = load("walking_control.toml", folder)
        names = ("kp_stance", "kd_stance", "kp_swing", "kd_swing", "standing_deg")
        _check.keys(where, d, [*names, "support", "stand_blend_s"], ["source"])
        vec = {n: _check.vector(where, n, d[n], 3) for n in names}
        try:
            return cls(kp_stance=vec["kp_stance"], kd_stance=vec["kd_stance"],
                       kp_swing=vec["kp_swing"], kd_swing=vec["kd_swing"],
                       standing=np.radians(vec["standing_deg"]),
                       support=_check.finite(where, "support", d["support"]),
                       stand_blend=_check.finite(where, "stand_blend_s", d["stand_blend_s"]))
        except ParameterError as e:  # a range checked by the record: name the file
            raise ParameterError(where, e.field, e.problem) from None

    #: The gains an operator may change between ticks (:meth:`WalkController.set_gains`).
    TUNABLE = ("kp_stance", "kd_stance", "kp_swing", "kd_swing", "support")

    def record(self, body_mass: float, g: float, fsr_x: ArrayLike, sole: float
               ) -> NDArray[np.void]:
        """The controller's parameters as the compiled tick reads them (:data:`PARAMS`)."""
        r = new(PARAMS)
        for name in (*self.TUNABLE, "standing", "stand_blend"):
            r[name] = getattr(self, name)
        r["body_mass"], r["start_fraction"], r["g"] = body_mass, START_FRACTION, g
        r["child_mass"] = body_mass_of(body_mass)
        r["fsr_x"], r["sole"] = fsr_x, sole
        return r


#: Walking starts at this fraction of the cycle (mid-stance: the gait nearest to standing).
START_FRACTION = MID_STANCE
#: The range a stand's blend may take, s: long enough for the knee to follow without
#: overshoot, short enough to be a stop (a few strides at most).
STAND_BLEND_S = (0.2, 3.0)
#: The walking controller's parameters (:meth:`WalkGains.record`): impedance per phase
#: (N m/rad, N m s/rad), the standing posture (rad), the stance support (0-1), the
#: body mass the pelvis carries (kg), where walking starts in the cycle, g (m/s^2), the
#: FSRs' x on the foot (m) and their y in the foot frame (m, negative: below the ankle),
#: the stand's blend (s), the operator's bounds on assist-as-needed's support per joint
#: (0-1, :data:`BOUNDS`), the child's whole mass (kg: what the cuffs' limit per kg is of),
#: the gait's foot off (a fraction of the cycle: where its swing starts).
PARAMS = np.dtype([("kp_stance", F8, 3), ("kd_stance", F8, 3), ("kp_swing", F8, 3),
                   ("kd_swing", F8, 3), ("standing", F8, 3), ("support", F8),
                   ("body_mass", F8), ("start_fraction", F8), ("g", F8), ("fsr_x", F8, 4),
                   ("sole", F8), ("stand_blend", F8),
                   ("support_min", F8, 3), ("support_max", F8, 3), ("child_mass", F8),
                   ("foot_off", F8)])
#: The operator's bounds on assist-as-needed's support, tunable with the gains
#: (:meth:`WalkController.set_gains`; their values at the start: ``assist.toml``).
BOUNDS = ("support_min", "support_max")
#: What the operator may change while the walking controller runs, in this order: the
#: gains, the support, assist-as-needed's bounds, and the transparent law's inertia share
#: and acceleration estimate (:data:`~exoleg.control.transparency.TRANSPARENCY`'s fields;
#: their bounds :func:`~exoleg.control.gears.law_bounds`).
TUNABLE = (*WalkGains.TUNABLE, *BOUNDS, *LAW_TUNABLE)
