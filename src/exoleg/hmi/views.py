"""What the operator interface's pages are given to show, apart from serving them: the
names of the compiled tick's enumerations, the device the Live page draws, and how a
session ended (the banner every page keeps until acknowledged)."""

from __future__ import annotations

import time
from typing import Any

import numpy as np

from exoleg.control.contract import vocabulary
from exoleg.runtime.link import LoopLink

#: the names and texts of the modes, phases, events, faults and safety bits, from the
#: enumerations the compiled tick uses (the page keeps no table of its own)
VOCABULARY = vocabulary()


def device_info(leg: Any, folder: str | None = None) -> dict[str, Any]:
    """What the live page draws with: link lengths and D-H offsets (the same kinematics
    as :func:`exoleg.kinematics.forward_kinematics`), the range of motion, the FSR
    positions, each actuator's torque limits and torque-speed envelope (SI units) -- of
    the device folder ``folder``'s actuators (None: the shipped ones)."""
    from exoleg.control.safety import SafetyLimits
    from exoleg.device.actuator import paper_actuators
    from exoleg.device.drive import envelope
    from exoleg.device.sensors import SENSOR_X, FootSensors
    from exoleg.dynamics._generated import OFFSETS
    from exoleg.params import paper
    from exoleg.tick import SENSOR_POINTS

    acts = paper_actuators(folder)
    rom = paper.range_of_motion()
    # the cuffs' limit the safety layer enforces (the device's safety.toml [cuffs]), N m
    # per kg of the child; None where a joint is not watched
    safety = SafetyLimits.paper(folder=folder, actuators=tuple(acts))
    # the foot board's counts as newtons (its response inverted: FootSensors.newtons),
    # every 16 counts, for the Live page's foot load in % body weight
    board = FootSensors.default(noise_scale=0.0, folder=folder)
    top = 2**board.adc_bits - 1
    grid = [min(c, top) for c in range(0, top + 16, 16)]
    cuff_limit = [float(x) if np.isfinite(x) else None for x in safety.cuff_limit]
    out: dict[str, Any] = {
        "leg": leg.name, "lengths": [float(x) for x in leg.lengths], "offsets": list(OFFSETS),
        "rom_lower": rom.lower.tolist(), "rom_upper": rom.upper.tolist(),
        "sensors": list(SENSOR_POINTS),
        "sensor_x": [float(x) * float(leg.lengths[2]) for x in SENSOR_X], "actuators": [],
        "cuff_limit_Nm_per_kg": cuff_limit, "cuff_off_at": float(safety.cuff_off),
        "cuff_stop_after_s": float(safety.cuff_stop),
        "fsr_counts": grid, "fsr_newtons": [board.newtons(c) for c in grid],
        "device_folder": folder}
    for a in acts:
        # the envelope's own Python source on a record view: 60 points need none of
        # numba's machinery, whose first load was 0.7 s of the console's 1.1 s start
        # (the same operations on doubles: the compiled function's values to the bit)
        par = a.record().view(np.recarray)
        w = np.linspace(0.0, 1.05 * a.max_velocity, 60)
        out["actuators"].append({
            "joint": a.joint, "torque_limit": a.torque_limit,
            "continuous_torque": a.continuous_torque, "max_velocity": a.max_velocity,
            "envelope_speed": w.tolist(),
            "envelope_torque": [float(envelope.py_func(par, x)) for x in w]})
    return out


def ended_record(name: str, stopped_by: str, link: LoopLink) -> dict[str, Any]:
    """How session ``name`` ended, as every page shows it until its operator acknowledges
    it: ``stopped_by`` (the session's own words), when, the last mode and the fault
    latched (named, with its value against its limit) from the loop's last publication."""
    from exoleg.control.safety import fault_detail
    from exoleg.tick import Mode

    last = LoopLink.snapshot(link.web_copy())
    return {"session": name, "stopped_by": stopped_by, "time": time.time(),
            "t": last["t"], "mode": Mode(last["mode"]).name,
            "fault_text": fault_detail(last["fault"], last["fault_joint"],
                                       last["fault_value"], last["fault_limit"])
            if last["fault"] else ""}


