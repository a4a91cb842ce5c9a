"""URDF and MJCF writers for the leg: limits, actuators and geometry a robotics user can load.

The exported chain is the paper's D-H chain (Table 3): a fixed ``pelvis`` at the
origin; revolute joints ``hip``, ``knee``, ``ankle`` about z; each link's frame
turned by its D-H offset so that x runs along the link, exactly as in
:mod:`exoleg.kinematics`; a massless ``toe`` frame at (a3, 0) on the foot.

Frames (``frame=``):

* ``"y-up"`` (default): exoleg's own frame (``docs/conventions.md``): sagittal plane
  x-y, y up, gravity -y. URDF has no gravity field: set it on the loaded model
  (Pinocchio: ``model.gravity.linear = (0, -g, 0)``); the MJCF sets ``<option gravity>``.
* ``"z-up"``: for ROS tools (REP 103: x forward, y left, z up): a fixed ``base_link``
  turned +90 deg about x carries the pelvis, so the sagittal plane is x-z, z up, and
  every tool's default gravity (0, 0, -9.81) gives exoleg's G. The joint axes point
  along -y in the world; joint angles keep exoleg's signs.

What is written (and from where):

* joint limits: the device's range of motion (paper section 2.1, ``range_of_motion.toml``);
* effort and velocity limits: Table 2's maximum torque and velocity per joint
  (URDF ``<limit>``; MJCF ``actuatorfrcrange`` and a ``motor`` actuator per joint with
  ``ctrlrange`` +- that torque, gear 1, so ``ctrl`` is the joint torque in N m);
* armature: rotor inertia reflected through the gear (kg m^2): the leg's own
  (:attr:`~exoleg.LegModel.armature`) unless given (MJCF ``armature``; URDF has no
  such field, so a URDF user sets it on the loaded model, e.g. Pinocchio's
  ``model.armature``);
* geometry (visual and collision): a capsule along each of thigh and shank and a box
  for the footplate (Table 1: 23.5 cm long; section 2.3: 23 mm thick). Radii are
  drawing sizes, not measured. MuJoCo's contacts are off (``<flag contact="disable"/>``).

``mode="lumped"`` writes one body per link (the paper's simplified model);
``mode="welded"`` writes each link's parts as separate bodies joined by fixed
joints (the detailed model: human and SLE apart), which needs every link to
carry its parts.

Only ``izz`` enters the planar dynamics; the out-of-plane moments ``ixx``,
``iyy`` are set equal to ``izz``, which satisfies the triangle inequalities
that make an inertia physical.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from pathlib import Path
from typing import Literal
from xml.sax.saxutils import quoteattr

from exoleg.dynamics.model import LegModel
from exoleg.errors import ParameterError
from exoleg.inertia import RigidBody
from exoleg.params import paper
from exoleg.params.records import JOINTS

Mode = Literal["lumped", "welded"]
Frame = Literal["y-up", "z-up"]

#: Drawing sizes of the geometry, m: capsule radius of thigh and shank; footplate
#: width (the paper prints length and thickness only).
LINK_RADIUS = (0.035, 0.028)
FOOTPLATE_WIDTH = 0.08


def _bodies(leg: LegModel, mode: Mode) -> list[list[RigidBody]]:
    if mode == "lumped":
        return [[lk.body] for lk in leg.links]
    if mode == "welded":
        missing = [lk.name for lk in leg.links if not lk.parts]
        if missing:
            raise ParameterError(f"export {leg.name!r}", "mode",
                                 f"'welded' needs the parts of every link; {', '.join(missing)} "
                                 "has none (use mode='lumped')")
        return [list(lk.parts) for lk in leg.links]
    raise ParameterError(f"export {leg.name!r}", "mode",
                         f"unknown {mode!r} (allowed: 'lumped', 'welded')")


def _frame(leg: LegModel, frame: str) -> str:
    if frame not in ("y-up", "z-up"):
        raise ParameterError(f"export {leg.name!r}", "frame",
                             f"unknown {frame!r} (allowed: 'y-up', 'z-up')")
    return frame


def _armature(leg: LegModel, armature: Sequence[float] | None) -> list[float]:
    if armature is None:
        return [float(a) for a in leg.armature]
    a = [float(x) for x in armature]
    if len(a) != 3 or not all(math.isfinite(x) and x >= 0 for x in a):
        raise ParameterError(f"export {leg.name!r}", "armature",
                             f"expected 3 reflected inertias >= 0 kg m^2, got {armature!r}")
    return a


def _limits() -> tuple[list[float], list[float], list[float], list[float]]:
    """(lower, upper) rad from the range of motion; (effort N m, velocity rad/s) Table 2."""
    rom = paper.range_of_motion()
    acts = paper.actuators()
    return ([float(x) for x in rom.lower], [float(x) for x in rom.upper],
            [a.max_torque for a in acts], [a.max_velocity for a in acts])


def _f(x: float) -> str:
    return repr(float(x))


def _name(s: str) -> str:
    return s.replace(" ", "_")


def _geometry(leg: LegModel, i: int) -> tuple[str, tuple[float, float, float], float]:
    """Link i's shape in its frame: (kind, size, x of its centre): a capsule of the link's
    length (thigh, shank) or the footplate box."""
    a = leg.links[i].length
    if i < 2:
        return "capsule", (LINK_RADIUS[i], a, 0.0), a / 2
    return "box", (a, paper_footplate_height(), FOOTPLATE_WIDTH), a / 2


def paper_footplate_height() -> float:
    """Footplate thickness, m (paper section 2.3: 23 mm; ``device.toml``)."""
    return float(paper.device()["footplate_height_m"])


def to_urdf(leg: LegModel, mode: Mode = "lumped", frame: Frame = "y-up",
            armature: Sequence[float] | None = None) -> str:
    """URDF text of ``leg`` (see the module docstring for frames, limits and geometry).

    Parameters
    ----------
    leg : LegModel
        The leg.
    mode : {"lumped", "welded"}, default "lumped"
        One body per link, or each link's welded parts (human, SLE) as bodies.
    frame : {"y-up", "z-up"}, default "y-up"
        The exported frame (exoleg's, or z up for ROS tools).
    armature : sequence of float, optional
        Per joint rotor inertia reflected through the gear, kg m^2.

    Returns
    -------
    str
        The URDF document.
    """
    bodies = _bodies(leg, mode)
    _frame(leg, frame)
    _armature(leg, armature)  # URDF has no armature; checked for a consistent API
    lo, hi, eff, vel = _limits()
    out = [f"<robot name={quoteattr(_name(leg.name))}>"]
    if frame == "z-up":
        out += ['  <link name="base_link"/>',
                '  <joint name="base_to_pelvis" type="fixed">',
                '    <parent link="base_link"/><child link="pelvis"/>',
                f'    <origin xyz="0 0 0" rpy="{_f(math.pi / 2)} 0 0"/>', "  </joint>"]
    out.append('  <link name="pelvis"/>')
    parent, origin = "pelvis", 0.0
    for i, (lk, parts) in enumerate(zip(leg.links, bodies, strict=True)):
        out += [
            f'  <joint name="{JOINTS[i]}" type="revolute">',
            f'    <parent link="{parent}"/><child link={quoteattr(lk.name)}/>',
            f'    <origin xyz="{_f(origin)} 0 0" rpy="0 0 {_f(leg.offsets[i])}"/>',
            '    <axis xyz="0 0 1"/>',
            f'    <limit lower="{_f(lo[i])}" upper="{_f(hi[i])}" effort="{_f(eff[i])}" '
            f'velocity="{_f(vel[i])}"/>',
            "  </joint>",
        ]
        kind, size, cx = _geometry(leg, i)
        if kind == "capsule":  # URDF has no capsule: a cylinder along the link's x axis
            shape = (f'<origin xyz="{_f(cx)} 0 0" rpy="0 {_f(math.pi / 2)} 0"/>'
                     f'<geometry><cylinder radius="{_f(size[0])}" length="{_f(size[1])}"/>'
                     "</geometry>")
        else:
            shape = (f'<origin xyz="{_f(cx)} 0 0" rpy="0 0 0"/><geometry><box size="'
                     f'{_f(size[0])} {_f(size[1])} {_f(size[2])}"/></geometry>')
        for j, b in enumerate(parts):
            name = lk.name if j == 0 else f"{lk.name}__{b.name}"
            if j > 0:
                out += [f"  <joint name={quoteattr(name + '_weld')} type=\"fixed\">",
                        f'    <parent link={quoteattr(lk.name)}/><child link={quoteattr(name)}/>',
                        '    <origin xyz="0 0 0" rpy="0 0 0"/>', "  </joint>"]
            out += [
                f"  <link name={quoteattr(name)}>", "    <inertial>",
                f'      <origin xyz="{_f(b.com[0])} {_f(b.com[1])} 0" rpy="0 0 0"/>',
                f'      <mass value="{_f(b.mass)}"/>',
                f'      <inertia ixx="{_f(b.izz)}" ixy="0" ixz="0" iyy="{_f(b.izz)}" iyz="0" '
                f'izz="{_f(b.izz)}"/>',
                "    </inertial>",
            ]
            if j == 0:
                out += [f"    <visual>{shape}</visual>", f"    <collision>{shape}</collision>"]
            out.append("  </link>")
        parent, origin = lk.name, lk.length
    out += ['  <joint name="toe_fixed" type="fixed">',
            f"    <parent link={quoteattr(parent)}/><child link=\"toe\"/>",
            f'    <origin xyz="{_f(origin)} 0 0" rpy="0 0 0"/>', "  </joint>",
            '  <link name="toe"/>', "</robot>", ""]
    return "\n".join(out)


def to_mjcf(leg: LegModel, mode: Mode = "lumped", timestep: float = 1e-3,
            integrator: str = "RK4", frame: Frame = "y-up",
            armature: Sequence[float] | None = None, pelvis_mass: float | None = None) -> str:
    """MJCF text of ``leg``: joint ranges, torque ranges and motor actuators, armature,
    geometry; contacts off (see the module docstring).

    Parameters
    ----------
    leg : LegModel
        The leg.
    mode : {"lumped", "welded"}, default "lumped"
        One body per link, or each link's welded parts (human, SLE) as bodies.
    timestep : float, default 0.001
        MuJoCo's step, s.
    integrator : str, default "RK4"
        MuJoCo's integrator.
    frame : {"y-up", "z-up"}, default "y-up"
        The exported frame (exoleg's, or z up for ROS tools).
    armature : sequence of float, optional
        Per joint rotor inertia reflected through the gear, kg m^2.
    pelvis_mass : float, optional
        The walking plant's pelvis: a body at the hip carrying that mass (kg) on a
        vertical slide joint ``pelvis_y`` (:mod:`exoleg.world.plant`).

    Returns
    -------
    str
        The MJCF document.
    """
    bodies = _bodies(leg, mode)
    _frame(leg, frame)
    arm = _armature(leg, armature)
    lo, hi, eff, _ = _limits()
    grav = f"0 {_f(-leg.g)} 0" if frame == "y-up" else f"0 0 {_f(-leg.g)}"
    out = [
        f"<mujoco model={quoteattr(_name(leg.name))}>",
        '  <compiler angle="radian" autolimits="true"/>',
        f'  <option timestep="{_f(timestep)}" integrator="{integrator}" gravity="{grav}">',
        '    <flag contact="disable"/>',
        "  </option>",
        "  <worldbody>",
    ]
    indent = "    "
    if frame == "z-up":
        out.append(f'{indent}<body name="pelvis" axisangle="1 0 0 {_f(math.pi / 2)}">')
        indent += "  "
    if pelvis_mass is not None:
        if not (math.isfinite(pelvis_mass) and pelvis_mass > 0):
            raise ParameterError(f"export {leg.name!r}", "pelvis_mass",
                                 f"expected a mass > 0 kg, got {pelvis_mass!r}")
        out += [f'{indent}<body name="hip_slider">',
                f'{indent}  <joint name="pelvis_y" type="slide" axis="0 1 0" limited="false"/>',
                f'{indent}  <inertial pos="0 0 0" mass="{_f(pelvis_mass)}" '
                'diaginertia="1e-6 1e-6 1e-6"/>']
        indent += "  "
    origin = 0.0
    for i, (lk, parts) in enumerate(zip(leg.links, bodies, strict=True)):
        out += [
            f"{indent}<body name={quoteattr(lk.name)} pos=\"{_f(origin)} 0 0\" "
            f'axisangle="0 0 1 {_f(leg.offsets[i])}">',
            f'{indent}  <joint name="{JOINTS[i]}" type="hinge" axis="0 0 1" pos="0 0 0" '
            f'range="{_f(lo[i])} {_f(hi[i])}" actuatorfrcrange="{_f(-eff[i])} {_f(eff[i])}" '
            f'armature="{_f(arm[i])}"/>',
        ]
        kind, size, cx = _geometry(leg, i)
        if kind == "capsule":
            out.append(f'{indent}  <geom name="{lk.name}_geom" type="capsule" size="{_f(size[0])}" '
                       f'fromto="0 0 0 {_f(size[1])} 0 0" mass="0"/>')
        else:
            out.append(f'{indent}  <geom name="footplate" type="box" pos="{_f(cx)} 0 0" '
                       f'size="{_f(size[0] / 2)} {_f(size[1] / 2)} {_f(size[2] / 2)}" mass="0"/>')
        for j, b in enumerate(parts):
            inertial = (f'<inertial pos="{_f(b.com[0])} {_f(b.com[1])} 0" mass="{_f(b.mass)}" '
                        f'diaginertia="{_f(b.izz)} {_f(b.izz)} {_f(b.izz)}"/>')
            if j == 0:
                out.append(f"{indent}  {inertial}")
            else:
                out.append(f"{indent}  <body name={quoteattr(lk.name + '__' + b.name)}>"
                           f"{inertial}</body>")
        indent += "  "
        origin = lk.length
    out.append(f'{indent}<site name="toe" pos="{_f(origin)} 0 0"/>')
    for _ in range(len(leg.links) + (frame == "z-up") + (pelvis_mass is not None)):
        indent = indent[:-2]
        out.append(f"{indent}</body>")
    out += ["  </worldbody>", "  <actuator>"]
    out += [f'    <motor name="{j}_motor" joint="{j}" gear="1" '
            f'ctrlrange="{_f(-eff[i])} {_f(eff[i])}"/>' for i, j in enumerate(JOINTS)]
    out += ["  </actuator>", "</mujoco>", ""]
    return "\n".join(out)


def _write(text: str, path: str | Path) -> Path:
    from exoleg.io import atomic_path

    with atomic_path(path) as tmp:
        tmp.write_text(text, encoding="utf-8")
    return Path(path)


def write_urdf(leg: LegModel, path: str | Path, mode: Mode = "lumped", frame: Frame = "y-up",
               armature: Sequence[float] | None = None) -> Path:
    """Write :func:`to_urdf` to ``path`` (whole or not at all).

    Parameters
    ----------
    leg : LegModel
        The leg.
    mode : {"lumped", "welded"}, default "lumped"
        One body per link, or each link's welded parts (human, SLE) as bodies.
    path : str or Path
        The file to write.
    frame : {"y-up", "z-up"}, default "y-up"
        The exported frame (exoleg's, or z up for ROS tools).
    armature : sequence of float, optional
        Per joint rotor inertia reflected through the gear, kg m^2.

    Returns
    -------
    Path
        The file written.
    """
    return _write(to_urdf(leg, mode, frame, armature), path)


def write_mjcf(leg: LegModel, path: str | Path, mode: Mode = "lumped", frame: Frame = "y-up",
               armature: Sequence[float] | None = None) -> Path:
    """Write :func:`to_mjcf` to ``path`` (whole or not at all).

    Parameters
    ----------
    leg : LegModel
        The leg.
    mode : {"lumped", "welded"}, default "lumped"
        One body per link, or each link's welded parts (human, SLE) as bodies.
    path : str or Path
        The file to write.
    frame : {"y-up", "z-up"}, default "y-up"
        The exported frame (exoleg's, or z up for ROS tools).
    armature : sequence of float, optional
        Per joint rotor inertia reflected through the gear, kg m^2.

    Returns
    -------
    Path
        The file written.
    """
    return _write(to_mjcf(leg, mode, frame=frame, armature=armature), path)
