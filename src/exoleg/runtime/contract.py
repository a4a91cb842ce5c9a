"""The device contract as a suite: what a backend of :class:`~exoleg.runtime.loop.Device`
must do for the loop to drive it, checked on a device through its whole lifecycle --
configure, warm up, ticks of read -> record -> write with the drives disabled, the quick
stop, release. The shipped backends pass it (``tests/test_device_contract.py``: the
simulated device, the CANopen master on the virtual bus, the EtherCAT master on simulated
slaves); a new backend runs it first (``docs/extending/device.md``), then a session.

Nothing here moves a joint: every write has the drives disabled and zero torque.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np

from exoleg.runtime.loop import LOG_HEAD, LOG_TAIL

#: a reading's fields: (shape, whether NaN -- not measured -- is allowed)
READINGS = {"q": ((3,), False), "dq": ((3,), False), "fsr": ((4,), False),
            "gyro": ((), True), "accel": ((2,), True), "interaction": ((3,), True),
            "fsr_other": ((4,), True)}
#: the fields a device must give every tick (the others it may leave out)
REQUIRED = ("q", "dq", "fsr")


def _reading(name: str, value: Any) -> str:
    """What is wrong with one field of a reading ('' when nothing)."""
    shape, nan_ok = READINGS[name]
    try:
        x = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        return f"{name}: not numbers ({type(value).__name__})"
    if x.shape != shape:
        return f"{name}: shape {x.shape}, expected {shape}"
    bad = ~np.isfinite(x) & ~(np.isnan(x) if nan_ok else False)
    if np.any(bad):
        return f"{name}: {x.tolist()} is not finite" + ("" if nan_ok else
                                                         " (NaN only where not measured)")
    return ""


def check_device(device: Any, limits: Any, ticks: int = 50, period: float = 1e-3) -> list[str]:
    """Run ``device`` through the :class:`~exoleg.runtime.loop.Device` lifecycle against
    the safety ``limits`` (:class:`~exoleg.control.safety.SafetyLimits`) and return what
    it does against the contract, one line each (empty: it passes).

    Parameters
    ----------
    device
        The backend, not yet configured (it is configured, driven ``ticks`` ticks with
        its drives disabled, stopped and released here).
    limits
        The safety layer's limits, as the loop gives them to :meth:`Device.configure`.
    ticks
        How many read -> record -> write ticks to run.
    period
        The tick, s (the time given to ``read``).

    Returns
    -------
    list of str
        Each departure from the contract, naming the method and what it gave.
    """
    problems: list[str] = []
    cols = getattr(device, "columns", None)
    if not isinstance(cols, list) or not all(isinstance(c, str) for c in cols):
        return [f"columns: expected a list of names, got {type(cols).__name__}"]
    if len(set(cols)) != len(cols):
        problems.append("columns: names repeat")
    if clash := set(cols) & set(LOG_HEAD + LOG_TAIL):
        problems.append(f"columns: {sorted(clash)} are the loop's own log columns")
    said = device.configure(limits)
    if not isinstance(said, list) or not all(isinstance(s, str) for s in said):
        problems.append(f"configure: expected a list of what it checked (str), got {said!r}")
    try:
        device.warm_up()
        for k in range(ticks):
            r = device.read(k * period)
            if not isinstance(r, Mapping):
                problems.append(f"read: expected a mapping, got {type(r).__name__}")
                break
            if r.get("fault"):
                problems.append(f"read: the device reports a fault at tick {k}: {r['fault']}")
                break
            missing = [n for n in REQUIRED if n not in r]
            wrong = [w for n in READINGS if n in r and (w := _reading(n, r[n]))]
            if missing or wrong:
                problems.append(f"read at tick {k}: " + "; ".join(
                    [f"{', '.join(missing)} missing"] * bool(missing) + wrong))
                break
            rec = np.asarray(device.record())
            if rec.shape != (len(cols),) or rec.dtype.kind != "f":
                problems.append(f"record: expected {len(cols)} floats (one per column), "
                                f"got shape {rec.shape} of {rec.dtype}")
                break
            device.write(np.zeros(3), False)
        device.safe()
        device.safe()  # the quick stop may come twice (a fault, then the session's end)
    finally:
        device.deactivate()
    return problems
