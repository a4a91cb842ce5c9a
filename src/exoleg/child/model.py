"""The child as data (``child.toml``) and as the compiled actor the simulated device
carries: passive moments (:mod:`exoleg.child.passive`), spasticity and the child's own
effort, one tick at a time (:func:`exoleg.child.compiled.child_tick`). The equations,
numbers and sources are in ``docs/child.md``."""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from exoleg import checks as _check
from exoleg.child.passive import (
    Contracture,
    child_data,
)
from exoleg.errors import ParameterError

F64 = NDArray[np.float64]

LEVELS = ("none", "mild", "moderate", "severe")
#: Strength as a multiple of the GMFCS level's typical, the range a child model takes.
STRENGTH_SCALE = (0.1, 1.5)
#: The gaits a child may intend: the normative (Schwartz 2008, with a crouch cluster) or
#: the shipped real child with CP's (predictcpgait subject 1, Falisse et al. 2020).
GAITS = ("normative", "predictcpgait")
#: Rozumalski & Schwartz 2009's crouch clusters (0: the normative gait).
CROUCH_CLUSTERS = (0, 1, 2, 3, 4, 5)
SPASTIC_GROUPS = ("plantarflexors", "knee_flexors", "knee_extensors", "hip_flexors")
#: ticks of history the child's delays may reach back
HISTORY = 256
#: samples of the intended gait over one cycle
GAIT_SAMPLES = 101
#: the passive moments' damping, N m s/rad at the reference height (scaled by height^5
#: with the moments; Lebiedowska & Fisk 1999: damping ~ height^5). A choice, set so that
#: a typically developing 13-year-old's simulated pendulum test meets White 2007's
PASSIVE_DAMPING = (1.0, 0.5, 0.5)


@dataclass(frozen=True)
class Spasticity:
    """A child's reflexes, per spastic muscle group (:data:`SPASTIC_GROUPS`).

    Parameters
    ----------
    level : str
        The preset it came from (none, mild, moderate, severe).
    tone : tuple of float
        Per group, the tone, N m at the reference height.
    g_f, g_df : tuple of float
        Per group, the force and force-rate reflex gains (-, s).
    delay : float
        The reflex delay, s.
    srs_per_deg : float
        Short-range stiffness, a fraction of tone per degree.
    srs_range : float
        Degrees over which the short-range stiffness acts.
    srs_decay : float
        s over which it fades.
    eccentric : float, default 0.8
        The tonically active muscles' eccentric gain: their force times 1 +
        eccentric tanh(v / fv_speed) while lengthening at v deg/s.
    fv_speed : float, default 30.0
        That force-velocity relation's speed, deg/s.
    g_v : tuple of float, default (0, 0, 0, 0)
        Per group, the stretch reflex's velocity gain, N m per deg/s of stretch beyond
        ``v_threshold`` at the reference height.
    v_threshold : float, default 0.0
        The stretch velocity the velocity reflex starts from, deg/s.
    """

    level: str
    tone: tuple[float, ...]
    g_f: tuple[float, ...]
    g_df: tuple[float, ...]
    delay: float
    srs_per_deg: float
    srs_range: float
    srs_decay: float
    eccentric: float = 0.8
    fv_speed: float = 30.0
    g_v: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0)
    v_threshold: float = 0.0

    def __post_init__(self) -> None:
        w = "spasticity"
        if not (math.isfinite(self.v_threshold) and 0.0 <= self.v_threshold <= 500.0):
            raise ParameterError(w, "velocity_threshold_deg_s", f"{self.v_threshold!r} is "
                                 "outside 0-500 deg/s")
        for name, lo, hi in (("tone", 0.0, 50.0), ("g_f", 0.0, 1.0), ("g_df", 0.0, 0.5),
                             ("g_v", 0.0, 2.0)):
            v = getattr(self, name)
            if len(v) != 4 or not all(math.isfinite(x) and lo <= x <= hi for x in v):
                raise ParameterError(w, name, f"{v!r}: expected 4 values in {lo:g}-{hi:g} "
                                     f"({', '.join(SPASTIC_GROUPS)})")
        if not (math.isfinite(self.delay) and 0.0 <= self.delay <= 0.2):
            raise ParameterError(w, "delay_s", f"{self.delay!r} is outside 0-0.2 s")

    @classmethod
    def preset(cls, level: str) -> Spasticity:
        """A shipped preset (``data/child/spasticity.toml``).

        Parameters
        ----------
        level : str
            none, mild, moderate or severe.

        Returns
        -------
        Spasticity
        """
        d = child_data("spasticity.toml")
        if level not in d["levels"]:
            raise ParameterError("spasticity", "level", f"unknown {level!r} (allowed: "
                                 + ", ".join(LEVELS) + ")")
        lv = d["levels"][level]
        return cls(level, tuple(lv["tone"]), tuple(lv["g_f"]), tuple(lv["g_df"]),
                   float(d["delay_s"]), float(d["srs_per_deg"]), float(d["srs_range_deg"]),
                   float(d["srs_decay_s"]), float(d["eccentric_gain"]),
                   float(d["force_velocity_speed_deg_s"]), tuple(lv["g_v"]),
                   float(d["velocity_threshold_deg_s"]))


@dataclass(frozen=True)
class ChildModel:
    """A child as the simulated device carries them: who they are, their passive joints,
    their reflexes, their own effort and the gait they intend.

    Parameters
    ----------
    name : str
        A label (a pseudonym in a clinic's records).
    age : float
        Years.
    height : float
        m.
    mass : float
        Body mass, kg.
    gmfcs : int, default 0
        GMFCS level 1-4; 0 for a typically developing child.
    contracture : Contracture
        Their passive joints (shortened muscles); default none.
    spasticity : Spasticity
        Their reflexes; default none.
    effort : bool, default True
        Whether they walk with their own muscles (with their GMFCS level's strength).
    crouch : int, default 0
        The gait they intend: 0 the normative gait, 1-5 Rozumalski & Schwartz's crouch
        cluster.
    sex : str, default "female"
        The growth charts' and segment tables' group ("female" or "male").
    strength_scale : float, default 1.0
        Multiplies their GMFCS level's typical strength (a child measured weaker or
        stronger than their level's).
    learning : float, default 0.0
        How they adapt their stance effort to the device stride by stride (Emken et
        al. 2007's human model, x <- f x + g e: this is their f, 0.5-0.999); 0: they do
        not adapt, their stance effort fixed by the support the device starts with.
    gait : str, default "normative"
        The gait they intend (:data:`GAITS`): the normative gait (with ``crouch``'s
        cluster) or a real child's (``predictcpgait``: the shipped child with CP's, its
        moments scaled to this child's mass).
    """

    name: str
    age: float
    height: float
    mass: float
    gmfcs: int = 0
    contracture: Contracture = field(default_factory=Contracture.none)
    spasticity: Spasticity = field(default_factory=lambda: Spasticity.preset("none"))
    effort: bool = True
    crouch: int = 0
    sex: str = "female"
    strength_scale: float = 1.0
    learning: float = 0.0
    gait: str = "normative"

    def __post_init__(self) -> None:
        w = "child"
        if self.sex not in ("female", "male"):
            raise ParameterError(w, "sex", f"{self.sex!r}: allowed female, male")
        for name, lo, hi, unit in (("age", 2.0, 20.0, "years"), ("height", 0.7, 2.0, "m"),
                                   ("mass", 8.0, 150.0, "kg")):
            v = _check.finite(w, name, getattr(self, name))
            if not lo <= v <= hi:
                raise ParameterError(w, name, f"{v:g} {unit} is outside {lo:g}-{hi:g} {unit}")
        from exoleg.sizing.growth import check_bmi

        check_bmi(w, self.sex, self.age, self.height, self.mass)
        _check.name(w, "name", self.name)  # (save writes it: its load reads it back)
        if self.gmfcs not in (0, 1, 2, 3, 4):
            raise ParameterError(w, "gmfcs", f"{self.gmfcs!r}: allowed 0 (typically "
                                 "developing), 1-4 (the device's users)")
        sc = _check.finite(w, "strength", self.strength_scale)
        if not STRENGTH_SCALE[0] <= sc <= STRENGTH_SCALE[1]:
            raise ParameterError(w, "strength", f"{sc:g} is outside "
                                 f"{STRENGTH_SCALE[0]:g}-{STRENGTH_SCALE[1]:g} (x the GMFCS "
                                 "level's typical strength)")
        lf = _check.finite(w, "learning", self.learning)
        if lf != 0.0 and not 0.5 <= lf <= 0.999:
            raise ParameterError(w, "learning", f"{lf:g}: 0 (the child does not adapt) or "
                                 "0.5-0.999 (their effort's forgetting per stride)")
        if self.crouch not in CROUCH_CLUSTERS:
            raise ParameterError(w, "crouch", f"{self.crouch!r}: allowed 0 (none), 1-5 "
                                 "(Rozumalski & Schwartz 2009's clusters)")
        if self.gait not in GAITS:
            raise ParameterError(w, "gait", f"{self.gait!r}: allowed {', '.join(GAITS)}")
        if self.gait != "normative" and self.crouch:
            raise ParameterError(w, "crouch", f"{self.crouch}: a crouch cluster bends the "
                                 f"normative gait; the {self.gait} gait is a real child's "
                                 "as measured (crouch 0)")

    @classmethod
    def typical(cls, name: str, age: float, height: float, mass: float,
                sex: str = "female") -> ChildModel:
        """A typically developing child: no contracture, no spasticity, full strength.

        Parameters
        ----------
        name : str
            A label.
        age : float
            Years.
        height : float
            m.
        mass : float
            kg.
        sex : str, default "female"
            "female" or "male".

        Returns
        -------
        ChildModel
        """
        return cls(name, age, height, mass, sex=sex)

    @classmethod
    def of(cls, child: Any, contracture: str = "none", spasticity: str = "none",
           crouch: int = 0, strength: float = 1.0) -> ChildModel:
        """A fitted child as an actor, with these presets (their effort on).

        Parameters
        ----------
        child : exoleg.sizing.Child
            Who they are (age, sex, height, mass, GMFCS level).
        contracture : str, default "none"
            A shipped contracture preset (:meth:`Contracture.preset`).
        spasticity : str, default "none"
            A spasticity preset: none, mild, moderate or severe.
        crouch : int, default 0
            0 the normative gait, 1-5 a crouch cluster.
        strength : float, default 1.0
            Their strength against their GMFCS level's typical.

        Returns
        -------
        ChildModel
        """
        return cls(child.name, child.age, child.height, child.mass, child.gmfcs or 0,
                   Contracture.preset(contracture), Spasticity.preset(spasticity), True,
                   crouch, child.sex, strength)

    def sizing_child(self) -> Any:
        """This child for :mod:`exoleg.sizing` (dimensions estimated from age, sex and
        height).

        Returns
        -------
        exoleg.sizing.Child
        """
        from exoleg.sizing import Child

        return Child(age=self.age, sex=self.sex, height=self.height, mass=self.mass,  # type: ignore[arg-type]
                     gmfcs=self.gmfcs or None, name=self.name, accept_unusual=True)

    @property
    def strength_fraction(self) -> float:
        """Strength as a fraction of a typically developing child's: the GMFCS level's
        (``data/child/effort.toml``) times :attr:`strength_scale`."""
        typical = child_data("effort.toml")["strength_by_gmfcs"][self.gmfcs]
        return float(typical) * self.strength_scale

    def strength(self) -> F64:
        """The largest torque the child's muscles give at each joint.

        Returns
        -------
        ndarray
            Shape ``(3,)``, N m (hip, knee, ankle).
        """
        d = child_data("effort.toml")
        return np.array(d["strength_Nm_per_kg"]) * self.mass * self.strength_fraction

    # ---------------------------------------------------------------- child.toml
    def to_toml(self) -> str:
        """This child as a child file's text.

        Returns
        -------
        str
            TOML that :meth:`load` reads back to this child.
        """
        from exoleg.io import toml_string

        sp = self.spasticity
        lines = [
            "# A child as exoleg's simulated device carries them (docs/child.md).",
            "# Edit by hand: every key is checked when the file is read.",
            "[child]",
            f"name = {toml_string(self.name)}",
            f"age_years = {self.age:g}",
            f"height_m = {self.height:g}",
            f"mass_kg = {self.mass:g}",
            f'sex = "{self.sex}"',
            f"gmfcs = {self.gmfcs}            # 0 typically developing, 1-4",
            "",
            "[passive]   # Riener & Edrich 1999 scaled by height^5 (Lebiedowska & Fisk 1999)",
            f'contracture = "{self.contracture.name}"   # none | predictcpgait (Falisse 2020)',
            f"contracture_level = {self.contracture.level:g}   # 0 none - 1 as measured (- 1.5)",
            "",
            "[spasticity]   # De Groote 2018 reflex; levels are presets",
            f'level = "{sp.level}"   # none | mild | moderate | severe',
            "",
            "[effort]",
            f"on = {'true' if self.effort else 'false'}",
            f'gait = "{self.gait}"   # normative | predictcpgait (a real CP child, Falisse 2020)',
            f"crouch = {self.crouch}   # 0 normative gait, 1-5 Rozumalski & Schwartz 2009 cluster",
            f"strength = {self.strength_scale:g}   # x the GMFCS level's strength (0.1-1.5)",
            f"learning = {self.learning:g}   # 0 fixed; 0.5-0.999 adapts, per stride",
        ]
        return "\n".join(lines) + "\n"

    def save(self, path: str | Path) -> None:
        """Write this child as a child file (whole or not at all).

        Parameters
        ----------
        path : str or Path
            The TOML file to write.
        """
        from exoleg.io import atomic_path

        with atomic_path(path) as tmp:
            Path(tmp).write_text(self.to_toml())

    @classmethod
    def load(cls, path: str | Path) -> ChildModel:
        """Read a child file (``exoleg fit`` writes one; ``--child`` of every command).

        Parameters
        ----------
        path : str or Path
            The TOML file.

        Returns
        -------
        ChildModel
        """
        from exoleg.io import read_text

        where = str(path)
        text = read_text(path, what="child file")
        try:
            d = tomllib.loads(text)
        except tomllib.TOMLDecodeError as e:
            raise ParameterError(where, "(toml)", f"is not valid TOML: {e}") from None
        return cls.from_dict(d, where)

    @classmethod
    def from_dict(cls, d: dict[str, Any], where: str = "child.toml") -> ChildModel:
        """A child from the tables of a child file (as :meth:`to_toml` writes them).

        Parameters
        ----------
        d : dict
            The file's tables.
        where : str, default "child.toml"
            The file's name, for the errors (a ParameterError naming the key).

        Returns
        -------
        ChildModel
        """
        _check.keys(where, d, ["child"], ["passive", "spasticity", "effort"])
        c = d["child"]
        _check.keys(f"{where} [child]", c, ["age_years", "height_m", "mass_kg", "sex"],
                    ["name", "gmfcs"])
        p = d.get("passive", {})
        _check.keys(f"{where} [passive]", p, [], ["contracture", "contracture_level"])
        s = d.get("spasticity", {})
        _check.keys(f"{where} [spasticity]", s, [], ["level"])
        e = d.get("effort", {})
        _check.keys(f"{where} [effort]", e, [], ["on", "crouch", "strength", "learning",
                                                  "gait"])
        try:
            con = Contracture.preset(str(p.get("contracture", "none")),
                                     _check.finite(where, "contracture_level",
                                                   p.get("contracture_level", 1.0)))
            return cls(name=c.get("name", "child"), age=c["age_years"],
                       height=c["height_m"], mass=c["mass_kg"],
                       gmfcs=_int(where, "gmfcs", c.get("gmfcs", 0)), contracture=con,
                       spasticity=Spasticity.preset(str(s.get("level", "none"))),
                       effort=_bool(where, "effort.on", e.get("on", True)),
                       crouch=_int(where, "crouch", e.get("crouch", 0)), sex=str(c["sex"]),
                       strength_scale=e.get("strength", 1.0), learning=e.get("learning", 0.0),
                       gait=str(e.get("gait", "normative")))
        except ParameterError as err:
            raise ParameterError(where, err.field, err.problem) from None
        except (TypeError, ValueError) as err:
            raise ParameterError(where, "(value)", str(err)) from None

    def with_(self, **changes: Any) -> ChildModel:
        """A copy with some fields changed (their values checked as when made).

        Parameters
        ----------
        **changes
            Field names and their new values.

        Returns
        -------
        ChildModel
        """
        return replace(self, **changes)


def _int(where: str, name: str, v: Any) -> int:
    if isinstance(v, bool) or not isinstance(v, int):
        raise ParameterError(where, name, f"{v!r} is not a whole number")
    return v


def _bool(where: str, name: str, v: Any) -> bool:
    if not isinstance(v, bool):
        raise ParameterError(where, name, f"{v!r}: expected true or false")
    return v


# ------------------------------------------------------------------ the intended gait
def crouch_offset(cluster: int, x: F64) -> F64:
    """Extra knee flexion (degrees) over the gait cycle ``x`` (fractions) for a crouch
    cluster (1-5): at initial contact the cluster's mean less the normative, through
    mid-stance its minimum less the normative, fading to none at the swing's peak
    (72 %) and back by the next contact (smooth, periodic)."""
    d = child_data("effort.toml")["crouch"]
    ic = d["initial_contact_deg"][cluster - 1] - d["normative"][0]
    ms = d["min_stance_deg"][cluster - 1] - d["normative"][1]
    pts_x = np.array([0.0, 0.12, 0.45, 0.60, 0.72, 0.86, 1.0])
    pts_y = np.array([ic, ms, ms, 0.5 * ms, 0.0, 0.5 * ic, ic])
    # straight lines between the points, over three cycles (periodic), their corners
    # rounded by a moving average of 15 of 401 samples (a 3.5 % window)
    xs = np.concatenate([pts_x[:-1] - 1.0, pts_x, pts_x[1:] + 1.0])
    ys = np.concatenate([pts_y[:-1], pts_y, pts_y[1:]])
    k = 7
    grid = np.linspace(0, 1, 401)
    g = np.interp(grid, xs, ys)
    g = np.convolve(np.concatenate([g[-k:], g, g[:k]]), np.ones(2 * k + 1) / (2 * k + 1),
                    "same")[k:-k]
    return np.interp(np.mod(x, 1.0), grid, g)


def intended_gait(child: ChildModel, stride_time: float, speed: str = "Free"
                  ) -> tuple[F64, F64, F64]:
    """The child's intended gait over one cycle (:data:`GAIT_SAMPLES`): q (rad), dq
    (rad/s) and the internal joint moments of the normative gait (N m, exoleg's signs;
    Schwartz 2008's N m/kg x the child's mass), or of the real child's their ``gait``
    names (:func:`real_gait`)."""
    from exoleg.reference.gait import SchwartzGait2008, gait_moments

    x = np.linspace(0.0, 1.0, GAIT_SAMPLES)
    if child.gait == "predictcpgait":
        return real_gait(x, stride_time, child.mass)
    gait = SchwartzGait2008(stride_time=stride_time, speed=speed, upright=True)
    q, dq, _ = gait.sample(x * stride_time)
    if child.crouch:
        off = np.radians(crouch_offset(child.crouch, x))
        dx = 1e-3
        doff = np.radians(crouch_offset(child.crouch, x + dx)
                          - crouch_offset(child.crouch, x - dx)) / (2 * dx * stride_time)
        q[:, 1] -= off  # knee flexion is -q2
        dq[:, 1] -= doff
    return q, dq, gait_moments(x, speed) * child.mass


def real_gait(x: F64, stride_time: float, mass: float, harmonics: int = 12
              ) -> tuple[F64, F64, F64]:
    """The shipped real child with CP's gait (:func:`exoleg.validate.cp_child.cp_child_gait`)
    at cycle fractions ``x``, played over ``stride_time`` s: q (rad; the hip's angle from
    the vertical, the pelvis's tilt added, as exoleg's upright hip is), dq (rad/s) through
    its first ``harmonics`` Fourier harmonics (its 99 samples of a cycle), and its
    inverse-dynamics moments (N m, exoleg's signs) scaled by ``mass`` / the child's."""
    from exoleg.reference.cp_child import MASS_KG, cp_child_gait

    g = cp_child_gait()
    n = len(g.t) - 1  # the last sample closes the cycle onto the first
    q = g.q_vertical[:n]
    c = np.fft.rfft(q, axis=0) / n
    k = np.arange(harmonics + 1)
    phase = np.exp(2j * np.pi * np.outer(np.mod(x, 1.0), k))
    w = np.where(k == 0, 1.0, 2.0)[None, :]
    qx = np.real((phase * w) @ c[:harmonics + 1])
    dqx = np.real((phase * w * (2j * np.pi * k / stride_time)[None, :]) @ c[:harmonics + 1])
    xs = np.linspace(0.0, 1.0, n + 1)
    tau = np.stack([np.interp(np.mod(x, 1.0), xs, g.tau[:, j]) for j in range(3)], axis=1)
    return qx, dqx, tau * (mass / MASS_KG)


def real_gait_toe_off(gait: str) -> float:
    """The fraction of the cycle at which the real child whose gait is named ``gait``
    (:data:`GAITS` but the normative) leaves the ground."""
    from exoleg.reference.cp_child import toe_off_fraction

    if gait != "predictcpgait":
        raise ParameterError("child", "gait", f"{gait!r} is not a real child's gait")
    return toe_off_fraction()


__all__ = ["GAITS", "LEVELS", "ChildModel", "Spasticity", "intended_gait", "real_gait",
           "real_gait_toe_off"]
