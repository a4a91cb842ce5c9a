"""Joint SI units <-> a CiA 402 drive's units, written once for every transport.

* position: the absolute joint encoder's counts (2^bits per turn) with the joint's
  zero offset (counts at q = 0) and direction (+1 or -1: the drive's positive against
  exoleg's sign convention, ``docs/conventions.md``);
* torque: the drive's target and actual torque (0x6071, 0x6077) are per mille of the
  motor's rated torque (0x6076), which an EPOS4 holds in uN m as the motor's nominal
  current times its torque constant (maxon's configuration file, device-datasheets.md
  S3); the joint torque is N eta times the motor's. The target is limited to
  +-(output current limit / nominal current) x 1000 per mille, as the drive limits it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from exoleg.device.actuator import ActuatorModel
from exoleg.errors import ParameterError


@dataclass(frozen=True)
class JointScaling:
    """One joint's conversions (see the module docstring)."""

    bits: int
    offset_counts: int
    direction: int
    ratio: float
    efficiency: float
    rated_motor_torque: float  # N m: k_t I_N (0x6076)
    per_mille_limit: int = 32767  # |0x6071| the drive accepts: I_limit / I_N x 1000

    def __post_init__(self) -> None:
        if self.direction not in (1, -1):
            raise ParameterError("JointScaling", "direction", f"must be +1 or -1, got "
                                 f"{self.direction!r}")
        if not 8 <= self.bits <= 32:
            raise ParameterError("JointScaling", "bits", f"{self.bits} is outside 8-32")
        if not (0 <= self.offset_counts < 2**self.bits):
            raise ParameterError("JointScaling", "offset_counts",
                                 f"{self.offset_counts} is outside 0-{2**self.bits - 1}")
        for name in ("ratio", "efficiency", "rated_motor_torque"):
            v = getattr(self, name)
            if not (math.isfinite(v) and v > 0):
                raise ParameterError("JointScaling", name, f"must be > 0, got {v!r}")

    @classmethod
    def of(cls, actuator: ActuatorModel, offset_counts: int = 0,
           direction: int = 1) -> JointScaling:
        return cls(bits=actuator.encoder_bits, offset_counts=offset_counts,
                   direction=direction, ratio=actuator.ratio, efficiency=actuator.efficiency,
                   rated_motor_torque=actuator.rated_motor_torque,
                   per_mille_limit=min(32767, round(1000 * actuator.peak_current
                                                    / actuator.nominal_current)))

    @property
    def counts_per_turn(self) -> int:
        return 2**self.bits

    def to_rad(self, counts: int) -> float:
        """Joint angle (rad, in (-pi, pi]) of an absolute encoder reading."""
        n = self.counts_per_turn
        d = (int(counts) - self.offset_counts) % n
        if d > n // 2:
            d -= n
        return self.direction * d * 2.0 * math.pi / n

    def to_counts(self, q: float) -> int:
        """The encoder reading of joint angle ``q`` (rad), nearest count."""
        n = self.counts_per_turn
        return (self.offset_counts + round(self.direction * q * n / (2.0 * math.pi))) % n

    def to_per_mille(self, tau: float) -> int:
        """Target torque (0x6071, int16 per mille of rated motor torque) for joint torque
        ``tau`` (N m), within what the drive accepts (:attr:`per_mille_limit`)."""
        pm = self.direction * tau / (self.ratio * self.efficiency) / self.rated_motor_torque
        lim = self.per_mille_limit
        return max(-lim, min(lim, round(1000.0 * pm)))

    def to_nm(self, per_mille: int) -> float:
        """Joint torque (N m) of a drive's per-mille torque."""
        return (self.direction * per_mille / 1000.0 * self.rated_motor_torque * self.ratio
                * self.efficiency)


@dataclass(frozen=True)
class MotorData:
    """An EPOS4's motor data (0x3001) as configured for an actuator file's motor:
    nominal current and output current limit (mA), pole pairs, the winding's thermal
    time constant (0.1 s), the torque constant (uN m/A); its identity (0x1018) and its
    motor rated torque (0x6076, uN m: I_N x k_t)."""

    nominal_current_ma: int
    current_limit_ma: int
    pole_pairs: int
    winding_time_constant_ds: int
    torque_constant_unm_a: int
    product_code: int
    rated_unm: int

    @classmethod
    def of(cls, a: ActuatorModel) -> MotorData:
        return cls(round(1000 * a.nominal_current), round(1000 * a.peak_current),
                   a.pole_pairs, round(10 * a.thermal_time_constant_winding),
                   round(1e6 * a.torque_constant), a.product_code,
                   round(1e6 * a.rated_motor_torque))

    def subs(self) -> dict[int, int]:
        """0x3001's subindices 1-5."""
        return {1: self.nominal_current_ma, 2: self.current_limit_ma, 3: self.pole_pairs,
                4: self.winding_time_constant_ds, 5: self.torque_constant_unm_a}
