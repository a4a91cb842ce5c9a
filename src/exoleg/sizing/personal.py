"""A personalized leg model: this child's segments and the device at this child's settings.

Human segments (thigh, shank, foot):

* mass: body mass x Jensen's children's mass fraction, interpolated linearly in age
  between Jensen 1989 (6 y), Jensen 1986 (12 y, 15 y) and Jensen 1989 (18 y), held
  constant outside 6-18 y (``data/segments``);
* COM and radius of gyration: Dempster's adult fractions as tabulated by Winter
  (``BMC_BSP_DempsterWinter.txt``) -- thigh and leg: COM 0.433 of the segment from its
  proximal joint, radius of gyration 0.323 and 0.302; foot: 0.5 and 0.475 of the
  ankle-to-second-metatarsal-head length. No children's values exist in these sources.
  The foot segment (ankle to MT2 head) is taken as half the foot length (the ankle sits
  about a quarter of the foot behind, the MT2 head a quarter of the foot before, the
  toe tip), its COM 0.5 of that ahead of the ankle and half the ankle height below it.

Device links: ``data/paper/device.toml`` (the paper's SLE bodies, scaled with the
telescope setting); at the paper's setting they give back Table 4's SLE masses and
lengths. Each link of the model is the SMS composition of the human and the SLE body.
"""

from __future__ import annotations

import csv
from functools import cache
from importlib import resources

import numpy as np

from exoleg.dynamics.model import LegModel
from exoleg.inertia import RigidBody
from exoleg.params import paper
from exoleg.params.records import LINKS, Link
from exoleg.sizing.anthropometry import Dimensions
from exoleg.sizing.child import Child
from exoleg.sizing.fit import DeviceFit, device, fit_device

_JENSEN = (("wspr_jensen1989-6yr.csv", 6.0), ("wspr_jensen1986-12yr.csv", 12.0),
           ("wspr_jensen1986-15yr.csv", 15.0), ("wspr_jensen1989-18yr.csv", 18.0))
_SEGMENT = {"thigh": "thigh", "shank": "leg", "foot": "foot"}


def _segments_text(name: str) -> str:
    return resources.files("exoleg").joinpath("data", "segments", name).read_text()


@cache
def _jensen() -> tuple[np.ndarray, dict[str, np.ndarray]]:
    ages: list[float] = []
    fr: dict[str, list[float]] = {k: [] for k in _SEGMENT}
    for name, age in _JENSEN:
        rows = {r[0]: r for r in csv.reader(_segments_text(name).splitlines())}
        ages.append(age)
        for k, seg in _SEGMENT.items():
            fr[k].append(float(rows[seg][2]) / 100.0)  # rescaled mass percentage
    return np.array(ages), {k: np.array(v) for k, v in fr.items()}


def jensen_mass_fractions(age: float) -> dict[str, float]:
    """Thigh, shank and foot mass as fractions of body mass at ``age`` years (Jensen)."""
    ages, fr = _jensen()
    return {k: float(np.interp(age, ages, v)) for k, v in fr.items()}


@cache
def dempster_winter() -> dict[str, tuple[float, float]]:
    """Segment -> (COM from proximal / length, radius of gyration about COM / length)."""
    out = {}
    for line in _segments_text("BMC_BSP_DempsterWinter.txt").splitlines()[1:]:
        f = line.split("\t")
        out[f[0]] = (float(f[3]), float(f[5]))
    return {"thigh": out["Thigh"], "shank": out["Leg"], "foot": out["Foot"]}


def human_bodies(child: Child, d: Dimensions) -> list[RigidBody]:
    """The child's thigh, shank and foot as bodies in the link frames (from the proximal joint)."""
    frac = jensen_mass_fractions(child.age)
    dw = dempster_winter()
    bodies = []
    for name, length in (("thigh", d.thigh), ("shank", d.shank)):
        c, k = dw[name]
        bodies.append(RigidBody.from_radius_of_gyration(
            child.mass * frac[name], (c * length, 0.0), k * length, name=f"{name}_child"))
    seg = 0.5 * d.foot_length
    c, k = dw["foot"]
    bodies.append(RigidBody.from_radius_of_gyration(
        child.mass * frac["foot"], (c * seg, -0.5 * d.ankle_height), k * seg, name="foot_child"))
    return bodies


def device_bodies(upper: float, lower: float) -> list[RigidBody]:
    """The SLE's thigh, shank and foot bodies at these telescope settings (m)."""
    lam = float(device()["tube_linear_density"])
    out = []
    for i, (lk, setting) in enumerate(zip(paper.detailed_links(), (upper, lower, None),
                                          strict=True)):
        sle = lk.parts[1]
        if setting is None:  # the footplate does not telescope
            out.append(RigidBody(sle.mass, sle.com, sle.izz, name=f"{LINKS[i]}_sle"))
            continue
        r = setting / lk.length
        mass = sle.mass + lam * (setting - lk.length)
        k = np.sqrt(sle.izz / sle.mass) * r
        out.append(RigidBody.from_radius_of_gyration(mass, (sle.com[0] * r, sle.com[1]), k,
                                                     name=f"{LINKS[i]}_sle"))
    return out


def personalized_leg(child: Child, fit: DeviceFit | None = None, g: float | None = None
                     ) -> LegModel:
    """A :class:`~exoleg.LegModel` of ``child`` wearing the device at its telescope settings.

    Link lengths are the fit's joint-to-joint lengths (hip-knee, knee-ankle) and the
    footplate length; each link carries its two parts (child, SLE), composed by the SMS
    method.

    Parameters
    ----------
    child : Child
        The child (measured values used as given).
    fit : DeviceFit, optional
        The fit; default :func:`fit_device` of the child.
    g : float, optional
        m/s^2; default the paper's.

    Returns
    -------
    LegModel
    """
    f = fit if fit is not None else fit_device(child)
    human = human_bodies(child, f.dimensions)
    lengths = f.link_lengths
    sle = device_bodies(lengths[0], lengths[1])
    links = [Link.from_parts(lengths[i], (human[i], sle[i]), name=LINKS[i]) for i in range(3)]
    return LegModel(links, g=paper.gravity() if g is None else g, name=child.name)
