"""Independent engines loaded from exoleg's exported models: Pinocchio (URDF) and MuJoCo (MJCF).

Both are optional extras (``pip install exoleg[validate]``); constructing an
engine without its package raises :class:`ImportError` with the install hint.
Each engine offers the same calls as :class:`~exoleg.LegModel`, one state at a
time: ``M(q)``, ``Cdq(q, dq)``, ``G(q)``, ``forward_dynamics(q, dq, tau)``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from exoleg.dynamics.model import LegModel
from exoleg.export.writers import Mode, to_mjcf, to_urdf

if TYPE_CHECKING:
    from exoleg.sim.scenario import ScenarioReport

F64 = NDArray[np.float64]


def _require(module: str, extra: str = "validate") -> Any:
    try:
        return __import__(module)
    except ImportError as e:
        raise ImportError(f"{module} is needed for this; install it with "
                          f"'pip install exoleg[{extra}]'") from e


def have(module: str) -> bool:
    """Whether an optional engine's package is importable."""
    try:
        __import__(module)
    except ImportError:
        return False
    return True


class PinocchioLeg:
    """The leg in Pinocchio, loaded from :func:`exoleg.export.to_urdf` (gravity set to -y g)."""

    name = "Pinocchio"

    def __init__(self, leg: LegModel, mode: Mode = "lumped") -> None:
        pin = _require("pinocchio")
        self._pin = pin
        self.model = pin.buildModelFromXML(to_urdf(leg, mode))
        self.model.gravity.linear = np.array([0.0, -leg.g, 0.0])
        self.model.armature = np.asarray(leg.armature, dtype=float)  # URDF has no armature
        self.data = self.model.createData()

    def M(self, q: F64) -> F64:
        M = np.array(self._pin.crba(self.model, self.data, np.asarray(q, float)))
        return np.triu(M) + np.triu(M, 1).T  # crba fills the upper triangle

    def G(self, q: F64) -> F64:
        return np.array(self._pin.computeGeneralizedGravity(self.model, self.data,
                                                            np.asarray(q, float)))

    def Cdq(self, q: F64, dq: F64) -> F64:
        nle = self._pin.nonLinearEffects(self.model, self.data, np.asarray(q, float),
                                         np.asarray(dq, float))
        return np.array(nle) - self.G(q)

    def forward_dynamics(self, q: F64, dq: F64, tau: F64) -> F64:
        return np.array(self._pin.aba(self.model, self.data, np.asarray(q, float),
                                      np.asarray(dq, float), np.asarray(tau, float)))


class MujocoLeg:
    """The leg in MuJoCo, loaded from :func:`exoleg.export.to_mjcf`."""

    name = "MuJoCo"

    def __init__(self, leg: LegModel, mode: Mode = "lumped", timestep: float = 1e-3) -> None:
        mj = _require("mujoco")
        self._mj = mj
        self.model = mj.MjModel.from_xml_string(to_mjcf(leg, mode, timestep=timestep))
        # the model's dynamics over every state: the exported joint ranges must not act
        self.model.opt.disableflags |= mj.mjtDisableBit.mjDSBL_LIMIT
        self.data = mj.MjData(self.model)

    def _set(self, q: F64, dq: F64 | None = None, tau: F64 | None = None) -> None:
        self.data.qpos[:] = q
        self.data.qvel[:] = 0.0 if dq is None else dq
        self.data.qfrc_applied[:] = 0.0 if tau is None else tau
        self._mj.mj_forward(self.model, self.data)

    def M(self, q: F64) -> F64:
        self._set(q)
        out = np.zeros((self.model.nv, self.model.nv))
        self._mj.mj_fullM(self.model, self.data, out)
        return out

    def G(self, q: F64) -> F64:
        self._set(q)
        return self.data.qfrc_bias.copy()

    def Cdq(self, q: F64, dq: F64) -> F64:
        self._set(q, dq)
        bias = self.data.qfrc_bias.copy()
        return bias - self.G(q)

    def forward_dynamics(self, q: F64, dq: F64, tau: F64) -> F64:
        self._set(q, dq, tau)
        return self.data.qacc.copy()

    def closed_loop(self, controller: Any, q_ref: F64, dq_ref: F64, ddq_ref: F64, hold: int,
                    q0: F64, dq0: F64) -> F64:
        """MuJoCo's own stepping (its integrator, its timestep) under ``controller``,
        sampled every ``hold`` steps and held (zero-order hold), as exoleg's simulator does.
        Returns q (N, 3) at every step, N = len(q_ref)."""
        from exoleg.control.laws import control_law

        mj, m, d = self._mj, self.model, self.data
        mj.mj_resetData(m, d)
        d.qpos[:], d.qvel[:] = q0, dq0
        out = np.empty((len(q_ref), 3))
        out[0] = d.qpos
        args = controller.call_args()
        u = np.zeros(3)
        qpos, qvel = d.qpos, d.qvel  # views into MuJoCo's state
        for k in range(len(q_ref) - 1):
            if k % hold == 0:
                control_law(args, qpos, qvel, (q_ref[k], dq_ref[k], ddq_ref[k]), u)
                d.qfrc_applied[:] = u
            mj.mj_step(m, d)
            out[k + 1] = qpos
        return out


def scenario_engine(leg: LegModel, dt: float) -> tuple[MujocoLeg | None, str | None]:
    """MuJoCo for the scenario's engine comparison (Fig. 13E) at the simulator's step
    ``dt``, or None and why not (MuJoCo not installed)."""
    if not have("mujoco"):
        return None, ("MuJoCo not installed: engine comparison skipped "
                      "(pip install exoleg[validate])")
    return MujocoLeg(leg, timestep=dt), None


def paper_scenario(engine: str | None = "mujoco", dt: float = 1e-3,
                   progress: Callable[[str, float], None] | None = None) -> ScenarioReport:
    """The paper's section 6 scenario on Table 5's simplified leg, the detailed (welded)
    leg driven with doubled torques, and (``engine="mujoco"``) MuJoCo."""
    from exoleg import paper_leg
    from exoleg.control.controllers import PDGravity
    from exoleg.reference.paper import SEGMENT, paper_reference
    from exoleg.sim.scenario import run_scenario

    leg = paper_leg("simplified")
    eng, note = scenario_engine(leg, dt) if engine == "mujoco" else (None, None)
    report = run_scenario(leg, PDGravity(leg), paper_reference(), duration=4 * SEGMENT,
                          dt=dt, q0=np.zeros(3), detailed=paper_leg("detailed"),
                          engine=eng, progress=progress)
    if note:
        report.notes.append(note)
    return report
