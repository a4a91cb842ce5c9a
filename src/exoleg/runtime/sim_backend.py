"""The ``sim`` backend: the simulated walking device (:mod:`exoleg.world.device`) stepped in
real time in this process -- the same plant, drives and sensors ``exoleg simulate
--walk`` runs, one tick at a time, so ``exoleg run`` works on any machine."""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray

from exoleg.dynamics.model import LegModel
from exoleg.layout import F8, column_names, new
from exoleg.system.build import build
from exoleg.system.config import DeviceConfig
from exoleg.tick import LABELS, SENSORS
from exoleg.world.device import SimulatedDevice, device_actuate, device_sense

F64 = NDArray[np.float64]
_CHUNK = 4096  # ticks of noise drawn at once

#: What the log keeps of the simulated device each tick besides the tick's own records:
#: its readings (the encoders' angles and rates, rad, rad/s; the FSRs, counts; the foot's
#: gyro, rad/s, and accelerations, m/s^2), the plant's true joint angles (rad) and pelvis
#: height (m), the torque the drives delivered, the cuffs' torque and the child's
#: muscles' torque (N m), and the unassisted foot's insole (counts; NaN where none is
#: fitted). Its flat columns are :attr:`SimBackend.columns`.
RECORD = np.dtype([("q_meas", F8, 3), ("dq_meas", F8, 3), ("fsr", F8, 4), ("gyro", F8),
                   ("acc", F8, 2), ("q", F8, 3), ("pelvis", F8), ("tau", F8, 3),
                   ("interaction", F8, 3), ("child", F8, 3), ("fsr_other", F8, 4)])


class SimBackend:
    """The simulated device (:class:`~exoleg.runtime.loop.Device`): ``read(t)`` its
    sensors, ``write(tau, enable)`` its drives' command, which acts over the next tick:
    the plant steps under it when the device is read again (as a bus's drives act at
    the next cycle); ``record()`` what the log keeps of the device per tick. ``walking``
    is the scenery's: while the child walks the treadmill runs and the other leg steps
    (the session sets it from the supervisor's mode) -- unless the child stands on a step
    (``step`` of :meth:`~exoleg.world.device.SimulatedDevice.of`), the leg hanging."""

    columns = column_names(RECORD, {**LABELS, 2: ("x", "y")})

    def __init__(self, device: SimulatedDevice, period: float = 1e-3, substeps: int = 2,
                 seed: int = 0, controller: Any = None) -> None:
        """The simulated ``device`` (:class:`~exoleg.world.device.SimulatedDevice`, as
        :func:`~exoleg.system.build.build` makes it) at a tick of ``period`` s;
        ``controller``: the one built with it, kept for the caller (:attr:`controller`)."""
        from exoleg.sim.walk import check_step

        self.dev = device
        self.controller = controller
        substeps = device.substeps_for(period, substeps)
        check_step(self.dev.plant, period / substeps, self.dev.folder)
        self.period = period
        self.substeps = substeps
        self.S = self.dev.state()
        self.K = self.dev.child_records(period)
        self.w = self.dev.plant.record()
        self.p = self.dev.plant.leg.p
        self.sens = self.dev.sensors.record()
        self.rng = np.random.default_rng(seed)
        from exoleg.device.sensors import draw_noise

        self._draw = lambda: draw_noise(self.dev.sensors, _CHUNK, int(self.rng.integers(2**31)))
        self.fsr_noise, self.imu_noise, self.bias = self._draw()
        self.k = 0
        self.reading = new(SENSORS)
        self.fn = np.zeros(4)
        self.u, self.env, self.tau = np.zeros(3), np.zeros(3), np.zeros(3)
        self.walking = False
        self._written = False
        self._record = np.zeros(1, RECORD)

    @classmethod
    def built(cls, leg: LegModel, body_mass: float, period: float = 1e-3,
              substeps: int = 2, seed: int = 0, *, config: DeviceConfig | None = None,
              noise_scale: float = 1.0, controller: str = "impedance",
              **scene: Any) -> SimBackend:
        """The device :func:`~exoleg.system.build.build` makes for ``leg`` and a child of
        ``body_mass`` kg with ``controller`` (kept as :attr:`controller`) from ``config``
        (default the shipped files' at this tick, the foot board's noise times
        ``noise_scale``); ``scene``: build's other options (``child``, ``step``...)."""
        cfg = DeviceConfig.load(control_dt=period, noise_scale=noise_scale) \
            if config is None else config
        system = build(cfg, leg, body_mass, controller, **scene)
        assert system.device is not None  # simulated
        return cls(system.device, period, substeps, seed, system.controller)

    def configure(self, limits: Any = None) -> list[str]:
        """Nothing to bring up: the simulated drives are the plant's."""
        return ["simulated device: the walking plant, its drives and foot board"]

    def deactivate(self) -> None:
        """Nothing to release."""

    def warm_up(self) -> None:
        """Compile (or load from numba's cache) the tick's functions on copies of the state,
        so that the first real tick is not late by the compile time."""
        S, w, f = self.S.copy(), self.w.copy(), np.zeros(4)
        device_sense((self.p, w, self.dev.A), (self.sens, self.dev.imu_x, -self.dev.depth),
                     S, self.period, True, (self.fsr_noise[0], self.imu_noise[0], self.bias),
                     new(SENSORS), f)
        # the child's memory copied, the rest as the ticks pass it: a copy of the device
        # alone's parameters (read-only in its model) is another type to numba, and the
        # first real tick compiled it again -- a second late (a loop overrun on a fresh
        # install, whose compile cache is empty)
        P, C, CS, pd = self.K
        device_actuate((self.p, w, self.dev.A), (P, C, CS.copy(), pd), S,
                       (self.period, self.substeps), np.zeros(3), f,
                       (False, 0.0, self.dev.stride_time, self.dev.support,
                        self.dev.plant.support_height), (np.zeros(3), np.zeros(3)))

    def read(self, t: float) -> dict[str, Any]:
        if self._written:  # the drives' last command acts over the tick that ended
            self._step()
        i = self.k % _CHUNK
        if i == 0 and self.k:
            self.fsr_noise, self.imu_noise, _ = self._draw()
        device_sense((self.p, self.w, self.dev.A), (self.sens, self.dev.imu_x,
                                                     -self.dev.depth),
                     self.S, self.period, self.k == 0,
                     (self.fsr_noise[i], self.imu_noise[i], self.bias), self.reading, self.fn)
        r = self.reading[0]
        return {"q": r["q"], "dq": r["dq"], "fsr": r["fsr"], "gyro": float(r["gyro"]),
                "accel": r["accel"], "interaction": r["interaction"],
                "fsr_other": r["fsr_other"]}

    def write(self, tau: F64, enable: bool) -> None:
        """The drives' torque command (N m), zero unless ``enable``."""
        self.u[:] = tau if enable else 0.0
        self._written = True

    def safe(self) -> None:
        """Torque off (the simulated drives' quick stop)."""
        self.u[:] = 0.0

    def _step(self) -> None:
        t = self.k * self.period
        walking = self.walking and not self.dev.step
        device_actuate((self.p, self.w, self.dev.A), self.K, self.S,
                       (self.period, self.substeps), self.u, self.fn,
                       (walking, t, self.dev.stride_time, self.dev.support,
                        self.dev.plant.support_height), (self.env, self.tau))
        self.k += 1
        self._written = False

    def record(self) -> F64:
        """What the log keeps of the device this tick (:data:`RECORD`, flat)."""
        r, x, o = self.reading[0], self.S[0]["x"], self._record[0]
        o["q_meas"], o["dq_meas"], o["fsr"] = r["q"], r["dq"], r["fsr"]
        o["gyro"], o["acc"] = r["gyro"], r["accel"]
        o["q"], o["pelvis"] = x[1:4], x[0]
        o["tau"], o["interaction"], o["child"] = self.tau, r["interaction"], self.S[0]["child"]
        o["fsr_other"] = r["fsr_other"]
        return self._record.view(np.float64).copy()
