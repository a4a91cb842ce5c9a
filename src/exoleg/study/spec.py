"""A study (a sweep) as data: its axes, how they are sampled, and how its runs are grouped.

A study file is TOML (``examples/sweep-small.toml``)::

    [study]
    name = "small"
    sampling = "grid"        # grid | random | lhs | list
    strides = 4              # walking strides per run, after 1 s of standing
    runs_per_task = 8        # runs a task computes in one go
    partition_by = "hip_motor"

    [axes]
    age = [8, 10, 12]        # a list: these values; {min, max}: a range (random, lhs;
    group = ["TD", "GMFCS II"]   # grid: with steps = n)
    hip_motor = ["ec90flat-90w", "ec90flat-160w"]

Every axis (:data:`AXES`) has a kind, a range and a default; an axis not given takes its
default. Children are either the growth charts' (``age``, ``sex``, ``group``,
``percentile``: height and mass at the same percentile of the group's chart), or
``[[profiles]]`` of measured children (``age``, ``sex``, ``height`` m, ``mass`` kg,
optional ``gmfcs``, ``name``), an axis of its own. ``sampling = "list"`` takes
``[[runs]]``, each a table of axis values. Random and Latin-hypercube samples draw
``samples`` runs from ``seed``. A run is a dict of every axis's value; its id is its
place in the expanded study, the same on every machine.
"""

from __future__ import annotations

import dataclasses
import math
import os
import shutil
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from exoleg.checks import repeated
from exoleg.child.model import CROUCH_CLUSTERS, LEVELS, STRENGTH_SCALE
from exoleg.entry import ASSIST_LAWS, HIP_VARIANTS, SUPPORT_MODES
from exoleg.errors import ParameterError
from exoleg.io import read_text

#: Schwartz 2008's speed groups (the normative gait the walking controller follows).
SPEEDS = ("VerySlow", "Slow", "Free", "Fast", "VeryFast")
#: The children's groups: typically developing (WHO 2007 charts) and GMFCS I-IV (Brooks
#: 2011 charts).
GROUPS = ("TD", "GMFCS I", "GMFCS II", "GMFCS III", "GMFCS IV")
#: The strain-wave gear ratios whose ratings exoleg carries (size 17: CSF-17-50 and
#: CSF-17-100, device-datasheets.md S10; 120: the shipped ankle's, the 100's ratings).
RATIOS = (50.0, 100.0, 120.0)


@dataclass(frozen=True)
class Axis:
    """One axis: its kind ("number", "whole" or "choice"), the range (numbers) or the
    allowed values (choices), its default, and what it means."""

    kind: str
    lower: float = -math.inf
    upper: float = math.inf
    choices: tuple[Any, ...] = ()
    default: Any = None
    meaning: str = ""


#: Every axis a study may sweep (the child model and the controllers of the issues to
#: come add theirs here).
AXES: dict[str, Axis] = {
    # the child: the growth charts' (or [[profiles]])
    "age": Axis("number", 2.0, 20.0, default=10.0, meaning="years"),
    "sex": Axis("choice", choices=("female", "male"), default="female"),
    "group": Axis("choice", choices=GROUPS, default="TD",
                  meaning="TD (WHO 2007) or GMFCS I-IV (Brooks 2011)"),
    "percentile": Axis("number", 1.0, 99.0, default=50.0,
                       meaning="height and mass percentile of the group's chart"),
    # the child as an actor (exoleg.child; "passive": the leg as a rigid body, as the
    # paper's; the impairments below act on an actor only)
    "child": Axis("choice", choices=("passive", "actor"), default="passive",
                  meaning="passive leg, or the child as an actor (docs/child.md)"),
    "spasticity": Axis("choice", choices=LEVELS,
                       default="none", meaning="data/child/spasticity.toml preset"),
    "crouch": Axis("whole", min(CROUCH_CLUSTERS), max(CROUCH_CLUSTERS), default=0,
                   meaning="intended gait: 0 normative, 1-5 Rozumalski & Schwartz cluster"),
    "contracture": Axis("choice", choices=("none", "predictcpgait"), default="none",
                        meaning="data/child/contracture.toml preset"),
    "strength": Axis("number", *STRENGTH_SCALE, default=1.0,
                     meaning="x the GMFCS level's typical strength"),
    # the device
    "hip_motor": Axis("choice", choices=HIP_VARIANTS, default="ec90flat-160w",
                      meaning="data/device/hip-variants"),
    "bus_voltage": Axis("number", 10.0, 50.0, default=24.0,
                        meaning="V (the EPOS4 50/15: 10-50 V)"),
    "hip_ratio": Axis("choice", choices=RATIOS, default=100.0),
    "knee_ratio": Axis("choice", choices=RATIOS, default=50.0),
    "ankle_ratio": Axis("choice", choices=RATIOS, default=120.0),
    # the controller (the walking hierarchy, data/device/walking_control.toml)
    "controller": Axis("choice", choices=SUPPORT_MODES, default="impedance",
                       meaning="support mode: the paper's impedance, transparent (an actor "
                       "only) or assist-as-needed (docs/device.md)"),
    "assist_law": Axis("choice", choices=ASSIST_LAWS, default="error",
                       meaning="assist-as-needed's law: Emken's error-based per gait-phase "
                       "bin, or OpenExo's proportional joint moment (assist.toml)"),
    "support": Axis("number", 0.0, 1.0, default=1.0,
                    meaning="stance support level (0 none, 1 the body weight)"),
    "kp_scale": Axis("number", 0.25, 2.0, default=1.0, meaning="x the stiffness gains"),
    "kd_scale": Axis("number", 0.25, 2.0, default=1.0, meaning="x the damping gains"),
    # the walk
    "speed": Axis("choice", choices=SPEEDS, default="Free",
                  meaning="Schwartz 2008 speed group"),
    "stride_time": Axis("number", 0.7, 2.5, default=1.1, meaning="s"),
    "noise": Axis("number", 0.0, 10.0, default=1.0, meaning="x the sensors' datasheet noise"),
    "seed": Axis("whole", 0, 2**31 - 1, default=0, meaning="sensor noise seed"),
}
#: The axes that name the device's actuation (:func:`exoleg.study.runs.device_variant`).
DEVICE_AXES = ("hip_motor", "bus_voltage", "hip_ratio", "knee_ratio", "ankle_ratio")
#: The axes that act on the child as an actor only (the ``child`` axis's "actor").
IMPAIRMENTS = ("spasticity", "crouch", "contracture", "strength")
#: The axes that describe a chart's child (replaced by ``profile`` when profiles are given).
CHART_CHILD = ("age", "sex", "group", "percentile")
SAMPLINGS = ("grid", "random", "lhs", "list")
#: The most runs a study may hold: its specs (about 1 kB each) and its rows must fit in
#: this machine's memory and disk many times over.
MAX_RUNS = 2_000_000
#: A run's row on disk, bytes (Parquet, about 60 columns; measured 0.25-0.6 kB).
ROW_BYTES = 1000
_STUDY_KEYS = {"name": str, "sampling": str, "samples": int, "seed": int, "strides": int,
               "runs_per_task": int, "partition_by": str, "description": str}
_KIND_NAMES = {str: "text", int: "a whole number"}


@dataclass(frozen=True)
class Study:
    """A parsed study (:func:`parse_study`, :func:`load_study`).

    Parameters
    ----------
    name : str
        Its name.
    sampling : str
        grid, random, lhs or list.
    axes : dict
        The axes given: name -> list of values, or a (min, max) range.
    profiles : tuple of dict
        Children measured (``[[profiles]]``), or empty.
    listed : tuple of dict
        A list's runs.
    samples : int
        Runs drawn (random, lhs).
    seed : int
        The sampling's seed.
    strides : int
        Strides walked per run.
    runs_per_task : int
        Runs per Dask task.
    partition_by : str
        The axis the dataset is partitioned by.
    description : str
        Free text.
    text : str
        The file as written (kept with the results).
    device : str
        The device folder whose files replace the shipped ones in every run.
    """

    name: str
    sampling: str
    axes: dict[str, Any]
    profiles: tuple[dict[str, Any], ...] = ()
    listed: tuple[dict[str, Any], ...] = ()
    samples: int = 0
    seed: int = 0
    strides: int = 4
    runs_per_task: int = 8
    partition_by: str = ""
    description: str = ""
    text: str = field(default="", compare=False)
    device: str = ""  # a device folder every run uses (exoleg sweep --device; "": shipped)

    def runs(self) -> list[dict[str, Any]]:
        """Every run's axis values, in the study's order (a run's id is its index).

        Returns
        -------
        list of dict
        """
        return expand(self)

    def on_device(self, folder: str) -> Study:
        """This study on a device folder.

        Parameters
        ----------
        folder : str
            The device folder: its runs walk the folder's own actuation units, gains,
            sensors, limits and ground.

        Returns
        -------
        Study
            The same study with ``device`` set; a ParameterError when it names a device
            axis (:data:`DEVICE_AXES`), which the folder fixes.
        """
        named = [a for a in DEVICE_AXES
                 if a in self.axes or any(a in r for r in self.listed)]
        if named:
            raise ParameterError(self.name, named[0], "a device folder fixes the actuation: "
                                 f"leave {', '.join(DEVICE_AXES)} out of a study run with "
                                 "--device, or sweep them on the shipped device")
        return dataclasses.replace(self, device=folder)

    @property
    def swept(self) -> list[str]:
        """The axes that vary, in the file's order (``profile`` for profiles)."""
        names = [k for k, v in self.axes.items() if not (isinstance(v, list) and len(v) == 1)]
        return (["profile"] if len(self.profiles) > 1 else []) + names


def _values_named(spec: Any) -> list[Any]:
    """The values an axis's entry lists (a list, or a single value); [] for a range."""
    return spec if isinstance(spec, list) else [] if isinstance(spec, dict) else [spec]


def _where(path: str | Path | None) -> str:
    return str(path) if path is not None else "study"


def load_study(path: str | Path) -> Study:
    """Read a study file (one line naming the key for anything wrong).

    Parameters
    ----------
    path : str or Path
        The TOML file.

    Returns
    -------
    Study
    """
    text = read_text(path, "study file (TOML)")
    return parse_study(text, str(path))


def parse_study(text: str, where: str = "study") -> Study:
    """A study from its TOML text.

    Parameters
    ----------
    text : str
        The study as TOML.
    where : str, default "study"
        Its name in errors.

    Returns
    -------
    Study
    """
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as e:
        raise ParameterError(where, "(syntax)", f"not valid TOML: {e}") from None
    unknown = sorted(set(data) - {"study", "axes", "profiles", "runs"})
    if unknown:
        raise ParameterError(where, unknown[0], "unknown table (allowed: study, axes, "
                             "profiles, runs)")
    head = data.get("study", {})
    if not isinstance(head, dict):
        raise ParameterError(where, "study", "must be a table")
    for k, v in head.items():
        if k not in _STUDY_KEYS:
            raise ParameterError(where, f"study.{k}", "unknown key (allowed: "
                                 + ", ".join(_STUDY_KEYS) + ")")
        kind = _STUDY_KEYS[k]
        if not isinstance(v, kind) or isinstance(v, bool):
            raise ParameterError(where, f"study.{k}", f"expected {_KIND_NAMES[kind]}, got "
                                 f"{v!r}")
    if "name" in head and not head["name"].strip():
        raise ParameterError(where, "study.name", "blank: a name to tell the study by (or "
                             "leave it out: the file's name)")
    sampling = head.get("sampling", "grid")
    if sampling not in SAMPLINGS:
        raise ParameterError(where, "study.sampling", f"{sampling!r}: allowed "
                             + ", ".join(SAMPLINGS))
    strides = head.get("strides", 4)
    if not 1 <= strides <= 1000:
        raise ParameterError(where, "study.strides", f"{strides} is outside 1-1000")
    per_task = head.get("runs_per_task", 8)
    if not 1 <= per_task <= 10000:
        raise ParameterError(where, "study.runs_per_task", f"{per_task} is outside 1-10000")
    axes_in = data.get("axes", {})
    if not isinstance(axes_in, dict):
        raise ParameterError(where, "axes", "must be a table of axis = values")
    axes = {name: _axis_values(where, name, v, sampling) for name, v in axes_in.items()}
    profiles = tuple(_profile(where, i, p) for i, p in enumerate(_tables(where, data,
                                                                         "profiles")))
    if profiles and (clash := [k for k in CHART_CHILD if k in axes]):
        raise ParameterError(where, f"axes.{clash[0]}", "a chart's child and [[profiles]] "
                             "exclude each other: give one")
    impaired = [k for k in IMPAIRMENTS if k in axes]
    if impaired and "actor" not in _values_named(axes.get("child", {})):
        raise ParameterError(where, f"axes.{impaired[0]}", "acts on the child as an actor "
                             "only: add child = [\"actor\"] (the default is a passive leg)")
    if ("transparent" in _values_named(axes.get("controller", {}))
            and _values_named(axes.get("child", {})) != ["actor"]):
        raise ParameterError(where, "axes.controller", "transparent leaves the leg to the "
                             "child: it needs child = [\"actor\"] alone (a passive leg in a "
                             "transparent device falls)")
    listed = tuple(_listed(where, i, r) for i, r in enumerate(_tables(where, data, "runs")))
    if sampling == "list" and axes:
        raise ParameterError(where, "axes", "sampling = \"list\" takes [[runs]], not [axes]")
    if sampling == "list" and not listed:
        raise ParameterError(where, "runs", "sampling = \"list\" needs [[runs]] tables")
    if sampling != "list" and listed:
        raise ParameterError(where, "runs", f"[[runs]] go with sampling = \"list\", not "
                             f"{sampling!r}")
    samples = head.get("samples", 0)
    if sampling in ("random", "lhs"):
        if not 1 <= samples <= MAX_RUNS:
            raise ParameterError(where, "study.samples", f"{samples}: {sampling} sampling "
                                 f"needs 1-{MAX_RUNS} samples")
    elif "samples" in head:
        raise ParameterError(where, "study.samples", f"goes with random or lhs sampling, "
                             f"not {sampling!r}")
    study = Study(name=head.get("name", Path(where).stem), sampling=sampling, axes=axes,
                  profiles=profiles, listed=listed, samples=samples,
                  seed=head.get("seed", 0), strides=strides, runs_per_task=per_task,
                  partition_by=head.get("partition_by", ""),
                  description=head.get("description", ""), text=text)
    n = count_runs(study)
    if n == 0:
        raise ParameterError(where, "axes", "the study has no run (an axis with no value)")
    if n > MAX_RUNS:
        raise ParameterError(where, "axes", f"{n:,} runs is more than {MAX_RUNS:,}: split "
                             "the study (its specs and rows would not fit this machine)")
    part = study.partition_by
    if part and part not in (*AXES, "profile"):
        raise ParameterError(where, "study.partition_by", f"unknown axis {part!r}")
    return study


def check_room(study: Study, out: str | Path) -> None:
    """Refuses a study whose rows would not fit on ``out``'s disk (naming the key)."""
    n = count_runs(study)
    need = n * ROW_BYTES
    parent = Path(out).resolve()
    while not parent.exists():
        parent = parent.parent
    free = shutil.disk_usage(parent).free
    if need > free // 2:
        raise ParameterError("study", "axes", f"{n:,} runs need about {need / 1e9:.2f} GB "
                             f"of results; {parent} has {free / 1e9:.2f} GB free (at most "
                             "half of it is used)")
    try:
        memory = os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES")
    except (ValueError, OSError, AttributeError):  # pragma: no cover - not Linux
        return
    if n * 2000 > memory // 4:
        raise ParameterError("study", "axes", f"{n:,} runs would not fit in memory "
                             f"({memory / 1e9:.0f} GB): split the study")


def _tables(where: str, data: Mapping[str, Any], key: str) -> list[dict[str, Any]]:
    v = data.get(key, [])
    if not isinstance(v, list) or not all(isinstance(x, dict) for x in v):
        raise ParameterError(where, key, f"expected [[{key}]] tables")
    return v


def _value(where: str, key: str, name: str, v: Any) -> Any:
    """One value of axis ``name``, checked."""
    if name not in AXES:
        raise ParameterError(where, key, "unknown axis (allowed: " + ", ".join(AXES) + ")")
    ax = AXES[name]
    if ax.kind == "choice":
        ok = [c for c in ax.choices if c == v and type(v) is not bool]
        if not ok:
            raise ParameterError(where, key, f"{v!r} is not one of "
                                 + ", ".join(map(str, ax.choices)))
        return ok[0]
    if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
        raise ParameterError(where, key, f"expected a number, got {v!r}")
    if not ax.lower <= v <= ax.upper:
        raise ParameterError(where, key, f"{v:g} is outside {ax.lower:g}-{ax.upper:g}"
                             + (f" ({ax.meaning})" if ax.meaning else ""))
    if ax.kind == "whole":
        if v != int(v):
            raise ParameterError(where, key, f"expected a whole number, got {v!r}")
        return int(v)
    return float(v)


def _once(where: str, key: str, values: list[Any], sampling: str) -> list[Any]:
    """A grid axis's values, each once: a value twice walks the same runs twice (a whole
    axis's range with more steps than whole numbers in it, too)."""
    if sampling == "grid":
        twice = repeated(values)
        if twice is not None:
            raise ParameterError(where, key, f"lists {twice!r} twice: the grid would walk "
                                 "the same runs twice" + ("" if key == "axes.seed" else
                                                          " (repeats: the seed axis)"))
    return values


def _axis_values(where: str, name: str, v: Any, sampling: str) -> Any:
    key = f"axes.{name}"
    if name not in AXES:
        raise ParameterError(where, key, "unknown axis (allowed: " + ", ".join(AXES) + ")")
    if isinstance(v, list):
        if not v:
            raise ParameterError(where, key, "empty: give at least one value")
        return _once(where, key, [_value(where, key, name, x) for x in v], sampling)
    if isinstance(v, dict):
        if AXES[name].kind == "choice":
            raise ParameterError(where, key, "a choice takes a list of values, not a range")
        extra = set(v) - {"min", "max", "steps"}
        if extra or not {"min", "max"} <= set(v):
            raise ParameterError(where, key, "a range is {min = a, max = b} (grid: steps = n)")
        lo, hi = _value(where, key, name, v["min"]), _value(where, key, name, v["max"])
        if not lo < hi:
            raise ParameterError(where, key, f"min {lo:g} must be below max {hi:g}")
        if sampling == "grid":
            steps = v.get("steps")
            if not isinstance(steps, int) or isinstance(steps, bool) or not 2 <= steps <= 10000:
                raise ParameterError(where, f"{key}.steps", "a grid's range needs steps = "
                                     "2-10000")
            vals = np.linspace(lo, hi, steps)
            return _once(where, key, [_value(where, key, name, round(float(x), 12)
                                             if AXES[name].kind == "number" else
                                             int(round(x))) for x in vals], sampling)
        if "steps" in v:
            raise ParameterError(where, f"{key}.steps", f"goes with grid sampling, not "
                                 f"{sampling!r}")
        return (lo, hi)
    return [_value(where, key, name, v)]


def _profile(where: str, i: int, p: dict[str, Any]) -> dict[str, Any]:
    key = f"profiles[{i}]"
    allowed = {"name", "age", "sex", "height", "mass", "gmfcs"}
    extra = sorted(set(p) - allowed)
    if extra:
        raise ParameterError(where, f"{key}.{extra[0]}", "unknown key (allowed: "
                             + ", ".join(sorted(allowed)) + ")")
    missing = [k for k in ("age", "sex", "height", "mass") if k not in p]
    if missing:
        raise ParameterError(where, f"{key}.{missing[0]}", "missing")
    from exoleg.sizing import Child

    try:  # the child's own checks: ranges, growth charts
        import warnings

        from exoleg.sizing.child import DesignRangeWarning

        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DesignRangeWarning)
            c = Child(age=float(p["age"]), sex=p["sex"], height=float(p["height"]),
                      mass=float(p["mass"]), gmfcs=p.get("gmfcs"),
                      name=str(p.get("name", f"profile {i}")))
    except (ParameterError, TypeError, ValueError) as e:
        field_ = getattr(e, "field", "")
        raise ParameterError(where, f"{key}.{field_}" if field_ else key,
                             getattr(e, "problem", str(e))) from None
    return {"name": c.name, "age": c.age, "sex": c.sex, "height": c.height, "mass": c.mass,
            "gmfcs": c.gmfcs}


def _listed(where: str, i: int, r: dict[str, Any]) -> dict[str, Any]:
    return {k: _value(where, f"runs[{i}].{k}", k, v) for k, v in r.items()}


def count_runs(study: Study) -> int:
    """How many runs the study holds (without expanding it)."""
    if study.sampling == "list":
        return len(study.listed) * max(1, len(study.profiles))
    if study.sampling in ("random", "lhs"):
        return study.samples
    n = max(1, len(study.profiles))
    for v in study.axes.values():
        n *= len(v)
    return n


def _defaults(study: Study) -> dict[str, Any]:
    out = {k: a.default for k, a in AXES.items()}
    if study.profiles:
        for k in CHART_CHILD:
            out.pop(k)
    return out


class Runs(Sequence[dict[str, Any]]):
    """A study's runs by index, each built when asked (its id is the index): the
    defaults, then the study's axes -- a grid in the file's order, the last axis fastest
    (decoded from the index: a study of millions of runs holds none of them); a list; or
    the sample drawn from the study's seed -- for each profile in turn."""

    def __init__(self, study: Study) -> None:
        self.study = study
        self.base = _defaults(study)
        self.profiles: Sequence[dict[str, Any] | None] = study.profiles or (None,)
        self.names = list(study.axes)
        self.combos: list[dict[str, Any]] | None = None
        if study.sampling == "list":
            self.combos = [dict(r) for r in study.listed]
        elif study.sampling != "grid":
            self.combos = _sample(study)
        self.n = len(self.combos) if self.combos is not None else int(np.prod(
            [len(study.axes[k]) for k in self.names], dtype=np.int64))

    def __len__(self) -> int:
        return len(self.profiles) * self.n

    def _grid(self, c: int) -> dict[str, Any]:
        picked: dict[str, Any] = {}
        for name in reversed(self.names):
            c, r = divmod(c, len(self.study.axes[name]))
            picked[name] = self.study.axes[name][r]
        return {k: picked[k] for k in self.names}

    def __getitem__(self, i: int) -> dict[str, Any]:  # type: ignore[override]
        if not 0 <= i < len(self):
            raise IndexError(i)
        p, c = divmod(i, self.n)
        combo = self.combos[c] if self.combos is not None else self._grid(c)
        run = {**self.base, **combo}
        if self.profiles[p] is not None:
            run["profile"] = self.profiles[p]
        return run


def expand(study: Study) -> list[dict[str, Any]]:
    """Every run's values, in the study's order (:class:`Runs`, all of them)."""
    return list(Runs(study))


def _sample(study: Study) -> list[dict[str, Any]]:
    """``samples`` draws over the axes: each uniformly (a range) or among its values (a
    list); Latin hypercube: each axis's draws stratified into ``samples`` equal bins,
    the bins' order shuffled per axis."""
    rng = np.random.default_rng(study.seed)
    n = study.samples
    cols: dict[str, list[Any]] = {}
    for name, v in study.axes.items():
        if study.sampling == "lhs":
            u = (rng.permutation(n) + rng.random(n)) / n
        else:
            u = rng.random(n)
        if isinstance(v, tuple):
            lo, hi = v
            x = lo + u * (hi - lo)
            cols[name] = [int(round(a)) if AXES[name].kind == "whole" else float(a) for a in x]
        else:
            idx = np.minimum((u * len(v)).astype(int), len(v) - 1)
            cols[name] = [v[i] for i in idx]
    return [{k: cols[k][i] for k in cols} for i in range(n)]
