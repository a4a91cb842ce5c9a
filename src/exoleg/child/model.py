"""The child as data (``child.toml``) and as the compiled actor the simulated device
carries: passive moments (:mod:`exoleg.child.passive`), spasticity and the child's own
effort, one tick at a time (:func:`child_tick`). The equations, numbers and sources are
in ``docs/child.md``."""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numba import njit
from numpy.typing import NDArray

from exoleg import checks as _check
from exoleg.child.passive import (
    GROUPS,
    PASSIVE,
    Contracture,
    RienerModel,
    child_data,
    height_scale,
    passive_record,
    riener_phi,
    term_value,
)
from exoleg.errors import ParameterError
from exoleg.layout import F8, I8, new

F64 = NDArray[np.float64]

LEVELS = ("none", "mild", "moderate", "severe")
#: Strength as a multiple of the GMFCS level's typical, the range a child model takes.
STRENGTH_SCALE = (0.1, 1.5)
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

    def __post_init__(self) -> None:
        w = "spasticity"
        for name, lo, hi in (("tone", 0.0, 50.0), ("g_f", 0.0, 1.0), ("g_df", 0.0, 0.5)):
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
                   float(d["force_velocity_speed_deg_s"]))


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
        _check.keys(f"{where} [effort]", e, [], ["on", "crouch", "strength", "learning"])
        try:
            con = Contracture.preset(str(p.get("contracture", "none")),
                                     float(p.get("contracture_level", 1.0)))
            return cls(name=str(c.get("name", "child")), age=c["age_years"],
                       height=c["height_m"], mass=c["mass_kg"],
                       gmfcs=_int(where, "gmfcs", c.get("gmfcs", 0)), contracture=con,
                       spasticity=Spasticity.preset(str(s.get("level", "none"))),
                       effort=_bool(where, "effort.on", e.get("on", True)),
                       crouch=_int(where, "crouch", e.get("crouch", 0)), sex=str(c["sex"]),
                       strength_scale=e.get("strength", 1.0), learning=e.get("learning", 0.0))
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
    Schwartz 2008's N m/kg x the child's mass)."""
    from exoleg.reference.gait import SchwartzGait2008, schwartz2008

    x = np.linspace(0.0, 1.0, GAIT_SAMPLES)
    gait = SchwartzGait2008(stride_time=stride_time, speed=speed, upright=True)
    q, dq, _ = gait.sample(x * stride_time)
    if child.crouch:
        off = np.radians(crouch_offset(child.crouch, x))
        dx = 1e-3
        doff = np.radians(crouch_offset(child.crouch, x + dx)
                          - crouch_offset(child.crouch, x - dx)) / (2 * dx * stride_time)
        q[:, 1] -= off  # knee flexion is -q2
        dq[:, 1] -= doff
    tau = np.empty_like(q)
    for j, (var, sign) in enumerate((("hip_moment_sagittal", -1.0),
                                     ("knee_moment_sagittal", 1.0),
                                     ("ankle_moment_sagittal", -1.0))):
        pct, mean, _ = schwartz2008(var, speed)
        tau[:, j] = sign * np.interp(x * 100.0, pct, mean) * child.mass
    return q, dq, tau


#: The child as the compiled tick reads it: the spastic groups' passive term (index into
#: :data:`PASSIVE`'s terms), tone (N m, scaled), reflex gains, short-range stiffness
#: (per degree of tone), its range (deg) and fade (s), the reflex delay (ticks), the
#: tonically active muscles' force-velocity (the eccentric gain, its speed deg/s); the
#: effort (1 on), its stiffness (N m/rad) and damping (N m s/rad) with the foot loaded
#: (row 0) and in swing (row 1), strength (N m), delay
#: (ticks), the standing posture (rad), the intended gait (q, dq rad, rad/s; internal
#: moments N m) over the cycle, the share of those moments the child drives with the foot
#: loaded (row 0: what the device's stance support leaves them) and in swing (row 1), and the
#: stride time (s) the cycle takes.
CHILD = np.dtype([("term", I8, 4), ("tone", F8, 4), ("g_f", F8, 4), ("g_df", F8, 4),
                  ("srs", F8), ("srs_range", F8), ("srs_decay", F8), ("reflex_delay", I8),
                  ("eccentric", F8), ("fv_speed", F8),
                  ("effort", F8), ("kp", F8, (2, 3)), ("kd", F8, (2, 3)), ("strength", F8, 3),
                  ("effort_delay", I8), ("stand", F8, 3),
                  ("gait_q", F8, (GAIT_SAMPLES, 3)), ("gait_dq", F8, (GAIT_SAMPLES, 3)),
                  ("gait_tau", F8, (GAIT_SAMPLES, 3)), ("share", F8, 2), ("stride", F8),
                  ("intrinsic", F8), ("learn_f", F8), ("learn_g", F8)])

#: The child's memory (:func:`child_tick`): ticks so far, each group's force and its
#: rate, the joint angles and rates the child felt (rings of :data:`HISTORY` ticks), the
#: short-range stiffness's anchor (deg), its torque (N m) and whether it yielded; the
#: tick's torques (N m, exoleg's signs): the reflexes' (tone, short range, stretch
#: reflex) and the effort's.
CHILD_STATE = np.dtype([("k", I8), ("force", F8, (HISTORY, 4)), ("rate", F8, (HISTORY, 4)),
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
    P = passive_record(child.height, child.contracture,
                       tuple(d * s for d in PASSIVE_DAMPING))  # type: ignore[arg-type]
    sp = child.spasticity
    groups = [t.group for t in RienerModel.shipped().terms]
    r = C[0]
    r["term"] = [groups.index(g) for g in SPASTIC_GROUPS]
    r["tone"] = np.array(sp.tone) * s
    r["g_f"], r["g_df"] = sp.g_f, sp.g_df
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
    kp = np.array(e["stiffness"]) * child.mass * 9.81 * L
    r["effort"] = 1.0 if child.effort else 0.0
    r["kp"][0], r["kd"][0] = kp, kp * np.array(e["damping_s"])
    wn = 2 * math.pi * float(e["swing_bandwidth_hz"])
    inert = np.asarray(inertia, dtype=float)
    r["kp"][1] = wn * wn * inert
    r["kd"][1] = 2 * float(e["swing_damping_ratio"]) * wn * inert
    r["strength"] = child.strength()
    r["stand"] = standing
    r["gait_q"], r["gait_dq"], r["gait_tau"] = intended_gait(child, stride_time, speed)
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
def child_tick(P, C, CS, q, dq, h, walking, xc, loaded, out):  # type: ignore[no-untyped-def]
    """The child's muscles over one tick, their passive moments aside (the plant adds
    those in every stage): tone, short-range stiffness and stretch reflex of each spastic
    group, and the effort tracking the intended gait at the child's gait fraction ``xc``
    while ``walking`` (else holding the standing posture) from what the child felt a
    delay ago, within their strength, stiffer while their foot is ``loaded``. Torques
    (N m, exoleg's signs) into ``out`` (3,)."""
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
            n = c.reflex_delay
            reflex = max(0.0, c.g_f[g] * _delayed(s.force, k, n, g)
                         + c.g_df[g] * _delayed(s.rate, k, n, g))
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


__all__ = ["CHILD", "CHILD_STATE", "GROUPS", "LEVELS", "ChildModel", "Spasticity",
           "child_records", "child_tick", "intended_gait"]
