"""The ground and the foot's sole as the device files give them (``walking.toml``): the
belt's contact and the other leg's support under the pelvis, the footplate's height and the
sole's compliant elements from heel to toe, each sensor's on its own element. Read and
checked here (the parts floor); the walking plant that steps them is
:mod:`exoleg.world.plant`."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from exoleg import checks as _check
from exoleg.device.sensors import SENSOR_X
from exoleg.errors import ParameterError
from exoleg.tick import SENSOR_POINTS

#: How the other leg lets the pelvis down onto this leg (``walking.toml``'s ``[support]
#: landing``; :func:`exoleg.world.treadmill.other_leg_support` runs them): ``drop`` holds
#: it at the swing's highest need plus the clearance until 95 % of the cycle, then lets
#: it down faster than it falls (the heel strikes under the falling body); ``handover``
#: holds it only as high as the rest of the swing needs, the clearance tapered to none,
#: and hands the body over to this leg through the double support (Schwartz 2008's
#: opposite foot off), as a child's other leg does.
LANDINGS = ("drop", "handover")


def check_landing(where: str, landing: object) -> str:
    """``landing`` if it is one of :data:`LANDINGS`, else one error naming ``where``."""
    if landing not in LANDINGS:
        raise ParameterError(where, "landing", f"{landing!r} is not one of "
                             f"{', '.join(repr(v) for v in LANDINGS)}")
    return str(landing)


@dataclass(frozen=True)
class Ground:
    """Contact and support parameters, SI units (defaults: ``data/device/walking.toml``)."""

    stiffness: float          # N/m, the whole sole (its elements share it)
    damping: float            # N s/m, the whole sole
    friction: float           # Coulomb coefficient against the belt
    slip_speed: float         # m/s: friction is mu F_n tanh(v / this)
    support_stiffness: float  # N/m, the other leg under the pelvis
    support_damping: float    # N s/m
    support_drop: float       # m: the other leg holds the pelvis this far below this
                              # leg's standing height
    sole: float               # m: footplate height under the ankle's sole (paper: 23 mm)
    elements: tuple[SoleElement, ...]   # the sole, heel to toe (walking.toml)
    source: str = field(default="", compare=False)
    landing: str = "drop"     # how the other leg lets the pelvis down onto this leg
                              # (LANDINGS; exoleg.world.treadmill.other_leg_support)

    def __post_init__(self) -> None:
        for name, lo, hi in (("stiffness", 1e3, 1e8), ("damping", 0.0, 1e6),
                             ("friction", 0.0, 3.0), ("slip_speed", 1e-5, 1.0),
                             ("support_stiffness", 0.0, 1e8), ("support_damping", 0.0, 1e6),
                             ("support_drop", 0.0, 0.2), ("sole", 0.0, 0.1)):
            v = _check.finite("Ground", name, getattr(self, name))
            if not lo <= v <= hi:
                raise ParameterError("Ground", name, f"{v:g} is outside {lo:g}-{hi:g}")
            object.__setattr__(self, name, v)
        check_sole("Ground", self.elements)
        check_landing("Ground", self.landing)

    @classmethod
    def default(cls, folder: str | Path | None = None) -> Ground:
        """From ``walking.toml`` (a device folder's, :mod:`exoleg.device.files`, or the
        package's)."""
        from exoleg.device.files import load

        where, d = load("walking.toml", folder)
        _check.keys(where, d, ["contact", "support", "footplate_height_m", "sole"], ["source"])
        c = _check.ranged(f"{where} [contact]", d["contact"],
                          {"stiffness": (1e3, 1e8, "N/m"), "damping": (0.0, 1e6, "N s/m"),
                           "friction": (0.0, 3.0, ""), "slip_speed": (1e-5, 1.0, "m/s")})
        s = _check.ranged(f"{where} [support]", d["support"],
                          {"stiffness": (0.0, 1e8, "N/m"), "damping": (0.0, 1e6, "N s/m"),
                           "drop": (0.0, 0.2, "m")}, optional=("source", "landing"))
        sole = _check.ranged(where, {"footplate_height_m": d["footplate_height_m"]},
                             {"footplate_height_m": (0.0, 0.1, "m")})["footplate_height_m"]
        try:  # the sole as a whole is checked once, by Ground: name the file
            return cls(stiffness=c["stiffness"], damping=c["damping"],
                       friction=c["friction"], slip_speed=c["slip_speed"],
                       support_stiffness=s["stiffness"], support_damping=s["damping"],
                       support_drop=s["drop"], sole=sole, elements=read_sole(where, d["sole"]),
                       source=str(d.get("source", where)),
                       landing=d["support"].get("landing", "drop"))
        except ParameterError as e:
            if e.where != "Ground":  # read_sole's: it names the file and the element
                raise
            raise ParameterError(where, e.field, e.problem) from None


#: The regions of the foot a sole element belongs to: the four sensors'
#: (:data:`~exoleg.control.contract.SENSOR_POINTS`, in order) and the midfoot (no sensor).
REGIONS = SENSOR_POINTS + ("midfoot",)
#: The most elements a sole may have (the compiled plant's fixed size).
SOLE_MAX = 12


@dataclass(frozen=True)
class SoleElement:
    """One compliant element of the sole: its ``region`` (:data:`REGIONS`), where it sits
    along the foot (``x``: a fraction of the foot link's length forward of the ankle), how
    far it is raised above the flat sole (``lift``, m: the arch, the toes' spring), its
    ``share`` of the sole's stiffness and damping, and whether the region's FSR sits on it
    (``sensor``)."""

    region: str
    x: float
    lift: float
    share: float
    sensor: bool = False


def check_sole(where: str, elements: tuple[SoleElement, ...]) -> None:
    """The sole must have 2-:data:`SOLE_MAX` elements from heel to toe, shares summing to
    1, and exactly one sensor per sensor region, on its element at the sensor's place
    (:data:`~exoleg.device.sensors.SENSOR_X`)."""
    if not 2 <= len(elements) <= SOLE_MAX:
        raise ParameterError(where, "sole", f"{len(elements)} elements: expected 2-{SOLE_MAX}")
    xs = [e.x for e in elements]
    if any(b <= a for a, b in zip(xs, xs[1:], strict=False)):
        raise ParameterError(where, "sole", f"the elements' x {xs} must increase from heel "
                             "to toe")
    if abs(sum(e.share for e in elements) - 1.0) > 1e-6:
        raise ParameterError(where, "sole", f"the shares sum to "
                             f"{sum(e.share for e in elements):.6g}, not 1")
    for i, name in enumerate(SENSOR_POINTS):
        on = [e for e in elements if e.sensor and e.region == name]
        if len(on) != 1:
            raise ParameterError(where, "sole", f"the {name} sensor sits on {len(on)} "
                                 "elements: expected exactly one")
        if abs(on[0].x - SENSOR_X[i]) > 1e-9:
            raise ParameterError(where, "sole", f"the {name} sensor's element is at x = "
                                 f"{on[0].x:g}, the sensor at {SENSOR_X[i]:g} (SENSOR_X)")
    if any(e.sensor and e.region == "midfoot" for e in elements):
        raise ParameterError(where, "sole", "the midfoot carries no sensor")


def read_sole(where: str, rows: Any) -> tuple[SoleElement, ...]:
    """The ``sole`` array of ``walking.toml``: tables with ``region``, ``x``,
    ``lift_mm``, ``share`` and optionally ``sensor`` (true on the element an FSR sits on),
    each checked; the sole as a whole by :func:`check_sole` (when :class:`Ground` is made)."""
    if not isinstance(rows, list):
        raise ParameterError(where, "sole", "expected an array of tables (region, x, "
                             "lift_mm, share, sensor)")
    out = []
    for k, r in enumerate(rows):
        at = f"{where} sole[{k}]"
        if not isinstance(r, dict):
            raise ParameterError(at, "(table)", f"expected a table, got {r!r}")
        _check.keys(at, r, ["region", "x", "lift_mm", "share"], ["sensor"])
        if r["region"] not in REGIONS:
            raise ParameterError(at, "region", f"{r['region']!r}: expected one of "
                                 f"{', '.join(REGIONS)}")
        sensor = r.get("sensor", False)
        if not isinstance(sensor, bool):
            raise ParameterError(at, "sensor", f"{sensor!r}: expected true or false")
        v = _check.ranged(at, {k2: r[k2] for k2 in ("x", "lift_mm", "share")},
                          {"x": (-0.5, 1.0, "of the foot's length"),
                           "lift_mm": (0.0, 20.0, "mm"), "share": (1e-3, 1.0, "")})
        out.append(SoleElement(r["region"], v["x"], v["lift_mm"] * 1e-3, v["share"], sensor))
    return tuple(out)


#: The child's ankle height the plant assumes unless told, m: Drillis & Contini's 0.039
#: of a 1.3 m child's height.
ANKLE_HEIGHT = 0.05
