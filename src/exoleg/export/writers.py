"""URDF and MJCF writers for the leg.

The exported chain is the paper's D-H chain (Table 3): a fixed ``pelvis`` at the
origin; revolute joints ``hip``, ``knee``, ``ankle`` about z; each link's frame
turned by its D-H offset so that x runs along the link, exactly as in
:mod:`exoleg.kinematics`; a massless ``toe`` frame at (a3, 0) on the foot.
Gravity is -y (set it on the loaded model: URDF has no gravity field; the
MJCF sets ``<option gravity>``).

``mode="lumped"`` writes one body per link (the paper's simplified model);
``mode="welded"`` writes each link's parts as separate bodies joined by fixed
joints (the detailed model: human and SLE apart), which needs every link to
carry its parts.

Only ``izz`` enters the planar dynamics; the out-of-plane moments ``ixx``,
``iyy`` are set equal to ``izz``, which satisfies the triangle inequalities
that make an inertia physical.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

from exoleg.dynamics.model import LegModel
from exoleg.errors import ParameterError
from exoleg.inertia import RigidBody
from exoleg.params.records import JOINTS

Mode = Literal["lumped", "welded"]


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


def _f(x: float) -> str:
    return repr(float(x))


def to_urdf(leg: LegModel, mode: Mode = "lumped", limits: tuple[list[float], list[float]] | None = None,
            effort: list[float] | None = None, velocity: list[float] | None = None) -> str:
    """URDF text of ``leg``. ``limits`` (lower, upper) rad; default +-pi (dynamics ignore them)."""
    bodies = _bodies(leg, mode)
    lo, hi = limits if limits is not None else ([-3.141592653589793] * 3, [3.141592653589793] * 3)
    eff = effort if effort is not None else [1000.0] * 3
    vel = velocity if velocity is not None else [100.0] * 3
    out = [f'<robot name="{leg.name.replace(" ", "_")}">', '  <link name="pelvis"/>']
    parent, origin = "pelvis", 0.0
    for i, (lk, parts) in enumerate(zip(leg.links, bodies, strict=True)):
        out += [
            f'  <joint name="{JOINTS[i]}" type="revolute">',
            f'    <parent link="{parent}"/><child link="{lk.name}"/>',
            f'    <origin xyz="{_f(origin)} 0 0" rpy="0 0 {_f(leg.offsets[i])}"/>',
            '    <axis xyz="0 0 1"/>',
            f'    <limit lower="{_f(lo[i])}" upper="{_f(hi[i])}" effort="{_f(eff[i])}" '
            f'velocity="{_f(vel[i])}"/>',
            "  </joint>",
        ]
        for j, b in enumerate(parts):
            name = lk.name if j == 0 else f"{lk.name}__{b.name}"
            if j > 0:
                out += [f'  <joint name="{name}_weld" type="fixed">',
                        f'    <parent link="{lk.name}"/><child link="{name}"/>',
                        '    <origin xyz="0 0 0" rpy="0 0 0"/>', "  </joint>"]
            out += [
                f'  <link name="{name}">', "    <inertial>",
                f'      <origin xyz="{_f(b.com[0])} {_f(b.com[1])} 0" rpy="0 0 0"/>',
                f'      <mass value="{_f(b.mass)}"/>',
                f'      <inertia ixx="{_f(b.izz)}" ixy="0" ixz="0" iyy="{_f(b.izz)}" iyz="0" '
                f'izz="{_f(b.izz)}"/>',
                "    </inertial>", "  </link>",
            ]
        parent, origin = lk.name, lk.length
    out += ['  <joint name="toe_fixed" type="fixed">',
            f'    <parent link="{parent}"/><child link="toe"/>',
            f'    <origin xyz="{_f(origin)} 0 0" rpy="0 0 0"/>', "  </joint>",
            '  <link name="toe"/>', "</robot>", ""]
    return "\n".join(out)


def to_mjcf(leg: LegModel, mode: Mode = "lumped", timestep: float = 1e-3,
            integrator: str = "RK4") -> str:
    """MJCF text of ``leg``: no contacts, no joint limits, damping or armature."""
    bodies = _bodies(leg, mode)
    out = [
        f'<mujoco model="{leg.name.replace(" ", "_")}">',
        '  <compiler angle="radian" autolimits="true"/>',
        f'  <option timestep="{_f(timestep)}" integrator="{integrator}" '
        f'gravity="0 {_f(-leg.g)} 0">',
        '    <flag contact="disable"/>',
        "  </option>",
        "  <worldbody>",
    ]
    indent, origin = "    ", 0.0
    for i, (lk, parts) in enumerate(zip(leg.links, bodies, strict=True)):
        out += [
            f'{indent}<body name="{lk.name}" pos="{_f(origin)} 0 0" '
            f'axisangle="0 0 1 {_f(leg.offsets[i])}">',
            f'{indent}  <joint name="{JOINTS[i]}" type="hinge" axis="0 0 1" pos="0 0 0" '
            'limited="false"/>',
        ]
        for j, b in enumerate(parts):
            inertial = (f'<inertial pos="{_f(b.com[0])} {_f(b.com[1])} 0" mass="{_f(b.mass)}" '
                        f'diaginertia="{_f(b.izz)} {_f(b.izz)} {_f(b.izz)}"/>')
            if j == 0:
                out.append(f"{indent}  {inertial}")
            else:
                out.append(f'{indent}  <body name="{lk.name}__{b.name}">{inertial}</body>')
        indent += "  "
        origin = lk.length
    out.append(f'{indent}<site name="toe" pos="{_f(origin)} 0 0"/>')
    for _ in leg.links:
        indent = indent[:-2]
        out.append(f"{indent}</body>")
    out += ["  </worldbody>", "</mujoco>", ""]
    return "\n".join(out)


def write_urdf(leg: LegModel, path: str | Path, mode: Mode = "lumped") -> Path:
    """Write :func:`to_urdf` to ``path``."""
    p = Path(path)
    p.write_text(to_urdf(leg, mode))
    return p


def write_mjcf(leg: LegModel, path: str | Path, mode: Mode = "lumped") -> Path:
    """Write :func:`to_mjcf` to ``path``."""
    p = Path(path)
    p.write_text(to_mjcf(leg, mode))
    return p
