"""The walking plant (exoleg.world.plant): contacts and the pelvis on the leg's model.

References: MuJoCo stepping the same leg on a vertical slider (its own equations, its
RK4) under the same contact forces applied at the same points through its own Jacobian
(mj_applyFT); statics (standing still, the belt carries the supported weight); the
work-energy theorem.
"""

from __future__ import annotations

import numpy as np
import pytest

import exoleg
from exoleg.child.passive import PASSIVE
from exoleg.device import with_actuators
from exoleg.device.actuator import ACTUATOR
from exoleg.layout import new
from exoleg.world.plant import (
    STEP,
    WalkingPlant,
    contact_buffers,
    step_contacts,
    walking_energy,
    walking_step,
)

LEG = with_actuators(exoleg.paper_leg())
NO_FRICTION = np.zeros(0, ACTUATOR)
NO_CHILD = new(PASSIVE)  # no child actor: no passive moments
H = 2.5e-4


def _run(plant: WalkingPlant, x0: np.ndarray, q_hold: np.ndarray, n: int,
         kp: float = 400.0, kd: float = 40.0, h: float = H) -> dict[str, np.ndarray]:
    """n plant steps with a joint PD + gravity compensation held over each step."""
    p, w = plant.leg.p, plant.record()
    x = x0.copy()
    pts, F, gen = contact_buffers()
    work = new(STEP)[0]  # the step's work, kept as the simulated device keeps it
    X, FN, GEN, TAU, PTS, FF = [x.copy()], [], [], [], [], []
    for _ in range(n):
        step_contacts(p, w, x, pts, F, gen, (h, work))
        tau = kp * (q_hold - x[1:4]) - kd * x[5:8] + plant.leg.G(x[1:4])
        walking_step(p, w, NO_FRICTION, NO_CHILD, x, tau, gen, (h, work))
        X.append(x.copy())
        FN.append(F[:, 1].sum())
        GEN.append(gen.copy())
        TAU.append(tau)
        PTS.append(pts.copy())
        FF.append(F.copy())
    return {"x": np.array(X), "fn": np.array(FN), "gen": np.array(GEN), "tau": np.array(TAU),
            "pts": np.array(PTS), "F": np.array(FF)}


def test_standing_still_the_belt_carries_the_supported_weight() -> None:
    plant = WalkingPlant.of(LEG, body_mass=20.0, belt_speed=0.0)
    x0 = np.zeros(8)
    x0[0] = plant.standing_height - 0.001
    # a step of 0.125 ms: without joint friction (NO_FRICTION) the contacts' smoothed
    # Coulomb friction on the knee's 0.22 kg m^2 (the datasheets' rotor, issue 21) rings
    # at 2 kHz -- RK4's edge -- at 0.25 ms; the device's own joint friction damps it
    r = _run(plant, x0, np.zeros(3), int(3.0 / (H / 2)), h=H / 2)
    weight = (plant.body_mass + plant.leg_mass) * LEG.g
    # statics: sum of normal forces = (pelvis + leg) g; measured 1.6e-7 relative (creep)
    assert abs(r["fn"][-1] - weight) / weight < 1e-6
    assert r["gen"][-1][0] == pytest.approx(r["fn"][-1])    # the other leg does not help


def test_contacts_agree_with_mujoco_under_the_same_forces() -> None:
    mujoco = pytest.importorskip("mujoco", reason="MuJoCo (exoleg[validate])")
    from exoleg.export.writers import to_mjcf

    plant = WalkingPlant.of(LEG, body_mass=20.0, belt_speed=1.0)
    x0 = np.zeros(8)
    x0[0] = plant.standing_height + 0.01       # drops onto the moving belt
    x0[1:4] = [0.2, -0.3, 0.1]
    n = int(0.6 / H)
    r = _run(plant, x0, np.array([0.1, -0.2, 0.05]), n)
    assert r["fn"].max() > 100.0                # it did land
    m = mujoco.MjModel.from_xml_string(to_mjcf(LEG, timestep=H, pelvis_mass=plant.body_mass))
    m.opt.disableflags |= mujoco.mjtDisableBit.mjDSBL_LIMIT
    d = mujoco.MjData(m)
    d.qpos[:] = x0[:4]
    d.qvel[:] = x0[4:]
    foot = m.body("foot").id
    q = [d.qpos.copy()]
    for k in range(n):
        mujoco.mj_forward(m, d)
        qfrc = np.zeros(m.nv)
        for i in range(plant.record()["n"][0]):
            point = np.array([r["pts"][k][i, 0], r["pts"][k][i, 1], 0.0])
            force = np.array([r["F"][k][i, 0], r["F"][k][i, 1], 0.0])
            mujoco.mj_applyFT(m, d, force, np.zeros(3), point, foot, qfrc)
        support = r["gen"][k][0] - r["F"][k][:, 1].sum()
        qfrc[0] += support
        d.qfrc_applied[:] = qfrc
        d.qfrc_applied[1:] += r["tau"][k]
        mujoco.mj_step(m, d)
        q.append(d.qpos.copy())
    diff = np.abs(np.array(q) - r["x"][:, :4]).max()
    assert diff < 1e-9  # issue 11: <= 1e-9 rad; measured 2.4e-15


def test_energy_balance_with_contacts() -> None:
    # Forces held over each step do work gen . dx exactly; the rest is RK4's error.
    plant = WalkingPlant.of(LEG, body_mass=20.0, belt_speed=1.0)
    x0 = np.zeros(8)
    x0[0] = plant.standing_height + 0.01
    x0[1:4] = [0.2, -0.3, 0.1]
    r = _run(plant, x0, np.array([0.1, -0.2, 0.05]), int(0.6 / H))
    p, w = plant.leg.p, plant.record()
    E = np.array([walking_energy(p, w, x[0], x[4], x[1:4], x[5:8]) for x in r["x"]])
    dx = np.diff(r["x"][:, :4], axis=0)
    work = np.sum(r["gen"] * dx) + np.sum(r["tau"] * dx[:, 1:])
    scale = np.sum(np.abs(r["gen"] * dx)) + np.sum(np.abs(r["tau"] * dx[:, 1:]))
    assert abs((E[-1] - E[0]) - work) < 1e-10 * scale  # measured 3.3e-13
