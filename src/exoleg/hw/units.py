"""Joint SI units <-> a CiA 402 drive's units, written once for every transport.

* position: the absolute joint encoder's counts (2^bits per turn) with the joint's
  zero offset (counts at q = 0) and direction (+1 or -1: the drive's positive against
  exoleg's sign convention, ``docs/conventions.md``);
* torque: the drive's target and actual torque (0x6071, 0x6077) are per mille of the
  motor's rated torque (0x6076); the joint torque is N eta times the motor's. The rated
  torque is taken as k_t times the drive's continuous current (the actuator file's).
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
    rated_motor_torque: float  # N m

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
                   rated_motor_torque=actuator.torque_constant * actuator.continuous_current)

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
        ``tau`` (N m), saturated to the int16 range."""
        pm = self.direction * tau / (self.ratio * self.efficiency) / self.rated_motor_torque
        return max(-32768, min(32767, round(1000.0 * pm)))

    def to_nm(self, per_mille: int) -> float:
        """Joint torque (N m) of a drive's per-mille torque."""
        return (self.direction * per_mille / 1000.0 * self.rated_motor_torque * self.ratio
                * self.efficiency)


def rated_torque_mnm(scaling: JointScaling) -> int:
    """Object 0x6076 (motor rated torque, mN m) as the device file gives it."""
    return int(round(1000.0 * scaling.rated_motor_torque))
