"""What every transport's master keeps, written once: the joints' scaling, the staged
torques and the arming, each drive's CiA 402 state and the controlword walking it, the
measured velocity (the drives' filter of :func:`exoleg.device.drive.filter_gain`, as
in simulation), the foot board's last data, and the log's columns. The canopen and
ethercat backends add only their bus exchange (``read``), start-up, ``safe`` and
``close``."""

from __future__ import annotations

import time
from typing import Any

import numpy as np
from numpy.typing import NDArray

from exoleg.device.drive import filter_gain
from exoleg.errors import ParameterError
from exoleg.hw import cia402
from exoleg.hw.rig import JOINT_ORDER
from exoleg.hw.units import JointScaling, MotorData

F64 = NDArray[np.float64]

#: Process-data loss (a drive's answer missing at a cycle; on EtherCAT a working counter
#: short of the segment's): the cycle goes on with that drive's last answer held, and is
#: counted. :data:`LOSS_RUN` cycles in a row from one drive (3 ms at 1 kHz: a position
#: held three ticks, the velocity filter's rate frozen), or more than :data:`LOSS_MAX` of
#: the last :data:`LOSS_WINDOW` cycles (1 %), are a device fault: the torque goes off.
LOSS_RUN = 3
LOSS_WINDOW = 1000
LOSS_MAX = 10


class DriveMaster:
    """The master's side of three CiA 402 drives and the foot board, whatever the bus."""

    columns = ([f"q_meas_{j}" for j in JOINT_ORDER] + [f"dq_meas_{j}" for j in JOINT_ORDER]
               + ["fsr_heel", "fsr_met1", "fsr_met5", "fsr_hallux", "gyro", "acc_x", "acc_y"]
               + [f"state_{j}" for j in JOINT_ORDER] + ["bus_us"]
               + [f"tau_meas_{j}" for j in JOINT_ORDER])

    def __init__(self, actuators: tuple[Any, ...], period: float, timeout: float,
                 offsets: dict[str, int] | None) -> None:
        self.period = period
        self.timeout = timeout
        self.scaling = {j: JointScaling.of(actuators[i], (offsets or {}).get(j, 0))
                        for i, j in enumerate(JOINT_ORDER)}
        # what each drive must hold, configured for the device file's motor
        self.motor = {j: MotorData.of(actuators[i]) for i, j in enumerate(JOINT_ORDER)}
        self.b = np.array([filter_gain(a.record(), period) for a in actuators])
        self.emcy: list[tuple[str, Any]] = []
        self.enabled = False
        self.tau = np.zeros(3)
        self.q_prev = np.zeros(3)
        self.vm = np.zeros(3)
        self.fsr = np.zeros(4)
        self.gyro = 0.0
        self.accel = np.full(2, np.nan)  # the foot's accelerometer, m/s^2 (none yet)
        self.tau_meas = np.zeros(3)  # each drive's torque actual value (0x6077), N m
        self.states = [cia402.State.SWITCH_ON_DISABLED] * 3
        self.first = True
        self.bus_us = 0.0
        self.cycles = 0  # cycles exchanged, and each drive's answers missing
        self.lost = dict.fromkeys(JOINT_ORDER, 0)
        self._in_a_row = dict.fromkeys(JOINT_ORDER, 0)
        self._recent = np.zeros(LOSS_WINDOW, dtype=bool)

    def check_drives(self, order: tuple[str, ...], where: dict[str, str], configure: Any,
                     lower: F64, upper: F64, margin: float) -> list[str]:
        """The start-up check of every drive, in ``order`` (the bus's): ``configure(j)``
        sets drive ``j`` to cyclic synchronous torque and its targets to torque 0 and the
        position it reads, and returns what the bus reads of it
        (:class:`~exoleg.hw.cia402.DriveObjects`); :func:`cia402.check_drive` judges them.
        The positions read become the velocity filter's start. Raises ParameterError
        naming the drive (``where[j]``); returns what it checked."""
        done = []
        for j in order:
            try:
                read = configure(j)
            except ParameterError:
                raise
            except Exception as e:  # SDO abort or timeout
                raise ParameterError(where[j], "(start-up)", f"does not answer: {e}") from None
            i = JOINT_ORDER.index(j)
            q = self.scaling[j].to_rad(read.counts)
            done.append(cia402.check_drive(where[j], read, self.motor[j], q, lower[i],
                                           upper[i], margin, self.period))
            self.q_prev[i] = q
        return done

    def pdo_loss(self, missing: tuple[str, ...], what: dict[str, str]) -> str:
        """Count this cycle's answers missing (the drives in ``missing``); the fault once
        a drive has missed :data:`LOSS_RUN` in a row or the segment more than
        :data:`LOSS_MAX` of the last :data:`LOSS_WINDOW` cycles ('' while within them);
        ``what[j]``: how the bus says drive ``j``'s answer was missing."""
        self._recent[self.cycles % LOSS_WINDOW] = bool(missing)
        self.cycles += 1
        fault = ""
        for j in JOINT_ORDER:
            if j in missing:
                self.lost[j] += 1
                self._in_a_row[j] += 1
                if self._in_a_row[j] >= LOSS_RUN and not fault:
                    fault = (f"{what[j]}, {self._in_a_row[j]} cycles in a row (at most "
                             f"{LOSS_RUN - 1} held)")
            else:
                self._in_a_row[j] = 0
        n = int(self._recent.sum())
        if not fault and n > LOSS_MAX:
            seen = min(self.cycles, LOSS_WINDOW)
            fault = (f"process data lost in {n} of the last {seen} cycles (at most "
                     f"{LOSS_MAX} of {LOSS_WINDOW}): the bus is failing")
        return fault

    def pdo_counts(self) -> dict[str, Any]:
        """The session's process data: cycles sent, and per drive the answers received
        and missing (for the session's summary)."""
        return {"cycles": self.cycles,
                "received": {j: self.cycles - n for j, n in self.lost.items()},
                "missing": dict(self.lost)}

    def on_emcy(self, joint: str) -> Any:
        """A callback keeping the EMCY messages of ``joint``'s drive (read in ``read``)."""
        def on(msg: Any) -> None:
            self.emcy.append((joint, msg))
        return on

    def configure(self, limits: Any) -> list[str]:
        """Bring the bus up and check every drive against the safety limits' range of
        motion (:meth:`start_up`)."""
        return self.start_up(limits.lower, limits.upper, limits.hard_margin)

    def start_up(self, lower: F64, upper: F64, margin: float) -> list[str]:
        raise NotImplementedError  # each bus's own

    def write(self, tau: F64, enable: bool) -> None:
        """Stage the torques (N m) and the CiA 402 walk towards Operation Enabled
        (``enable``) or away from it, sent at the next bus cycle."""
        self.tau[:] = tau
        self.enabled = bool(enable)

    def warm_up(self) -> None:
        """Nothing to compile: the master's tick is Python and the bus's."""

    def deactivate(self) -> None:
        """Release the bus (:meth:`close`)."""
        self.close()

    def close(self) -> None:
        raise NotImplementedError  # each bus's own

    def command(self, i: int) -> tuple[int, int]:
        """Drive ``i``'s controlword (one CiA 402 transition towards the arming) and
        target torque (per mille) for this tick."""
        j = JOINT_ORDER[i]
        return (cia402.controlword_towards(self.states[i], self.enabled),
                self.scaling[j].to_per_mille(float(self.tau[i])))

    def sensed(self, q: F64, fault: str, t0: float) -> dict[str, Any]:
        """This tick's sensors from the joint angles read (``q``, rad), with the velocity
        filtered, the bus time since ``t0`` (``time.perf_counter``) and any ``fault``."""
        if not self.first:
            self.vm += self.b * ((q - self.q_prev) / self.period - self.vm)
        self.first = False
        self.q_prev = q
        self.bus_us = (time.perf_counter() - t0) * 1e6
        out: dict[str, Any] = {"q": q, "dq": self.vm.copy(), "fsr": self.fsr.copy(),
                               "gyro": self.gyro, "accel": self.accel.copy()}
        if fault:
            out["fault"] = fault
        return out

    def record(self) -> F64:
        return np.concatenate([self.q_prev, self.vm, self.fsr, [self.gyro], self.accel,
                               [s.value[1] for s in self.states], [self.bus_us],
                               self.tau_meas])
