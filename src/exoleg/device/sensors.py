"""The foot board's sensors as the board would send them (paper section 2.3).

* **FSRs** (four FlexiForce A201 at :data:`exoleg.device.walking.SENSOR_POINTS`): the
  normal force at each point -> the amplifier's voltage, linear in force (the sensor's
  conductance is) with the datasheet's linearity error as a bow of at most
  ``linearity`` of full scale -> noise -> saturation at the ADC's reference -> 12-bit
  counts.
* **IMU** (MPU9250 on the footplate): the gyroscope's sagittal rate (the foot's angular
  velocity) and the accelerometer's specific force in the foot frame, each with a bias
  drawn once per run, white noise of the datasheet's density over the sensor's
  bandwidth, and saturation at the full-scale range.
* Encoders: :func:`exoleg.device.actuator.encode`.

Noise is drawn before a run from a seeded generator (:func:`draw_noise`), so runs are
deterministic. Figures and their sources: ``data/device/sensors.toml``.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numba import njit
from numpy.typing import NDArray

from exoleg.errors import ParameterError
from exoleg.layout import F8, new
from exoleg.params import _check

F64 = NDArray[np.float64]

#: The four FlexiForce A201 points under the footplate, as fractions of the foot link's
#: length (the footplate's, Table 1: 23.5 cm) from the ankle: the heel behind it, the
#: first and fifth metatarsal heads, the hallux -- the usual insole positions on a foot
#: whose ankle sits a quarter of the way from the heel (paper section 2.3 names four
#: sensors, not where). Sagittal plane: the two metatarsal heads differ only in x.
#: (The names: :data:`exoleg.control.contract.SENSOR_POINTS`.)
SENSOR_X = (-0.18, 0.45, 0.38, 0.62)


@dataclass(frozen=True)
class FootSensors:
    """FSR and IMU figures (SI: N, V, rad/s, m/s^2; see ``sensors.toml``)."""

    fsr_full_scale: float
    fsr_linearity: float
    fsr_noise: float
    adc_bits: int
    adc_reference: float
    fsr_full_scale_voltage: float
    gyro_noise: float        # rad/s, one sample's standard deviation
    gyro_bias: float         # rad/s, standard deviation of the per-run bias
    gyro_range: float        # rad/s
    accel_noise: float       # m/s^2, one sample
    accel_bias: float        # m/s^2, standard deviation of the per-run bias
    accel_range: float       # m/s^2
    imu_position: float      # fraction of the foot from the ankle

    @classmethod
    def default(cls, noise_scale: float = 1.0, folder: str | Path | None = None) -> FootSensors:
        """From ``sensors.toml`` (a device folder's, :mod:`exoleg.device.files`, or the
        package's); ``noise_scale`` multiplies every noise and bias (0: ideal sensors, 2:
        twice the datasheets' noise)."""
        from exoleg.device.files import load

        where, d = load("sensors.toml", folder)
        _check.keys(where, d, ["fsr", "imu"], ["source"])
        f = _check.ranged(f"{where} [fsr]", d["fsr"], {
            "full_scale_N": (1.0, 1e4, "N"), "linearity": (0.0, 0.2, ""),
            "noise": (0.0, 0.5, ""), "adc_bits": (8.0, 24.0, "bit"),
            "adc_reference_V": (0.5, 10.0, "V"), "full_scale_V": (0.1, 10.0, "V")})
        if f["adc_bits"] != int(f["adc_bits"]) or f["full_scale_V"] > f["adc_reference_V"]:
            raise ParameterError(f"{where} [fsr]", "adc_bits/full_scale_V",
                                 "adc_bits a whole number; full_scale_V <= adc_reference_V")
        i = _check.ranged(f"{where} [imu]", d["imu"], {
            "gyro_noise_dps_rthz": (0.0, 10.0, "deg/s/sqrt(Hz)"),
            "gyro_bias_dps": (0.0, 100.0, "deg/s"), "gyro_range_dps": (10.0, 1e4, "deg/s"),
            "accel_noise_ug_rthz": (0.0, 1e5, "ug/sqrt(Hz)"),
            "accel_bias_mg": (0.0, 1e3, "mg"), "accel_range_g": (1.0, 100.0, "g"),
            "bandwidth_hz": (1.0, 1e4, "Hz"), "position": (-0.5, 1.0, "")})
        k = _check.finite("FootSensors", "noise_scale", noise_scale)
        if not 0.0 <= k <= 100.0:
            raise ParameterError("FootSensors", "noise_scale", f"{k:g} is outside 0-100")
        g = 9.81
        rt = math.sqrt(i["bandwidth_hz"])
        return cls(fsr_full_scale=f["full_scale_N"], fsr_linearity=f["linearity"],
                   fsr_noise=k * f["noise"], adc_bits=int(f["adc_bits"]),
                   adc_reference=f["adc_reference_V"], fsr_full_scale_voltage=f["full_scale_V"],
                   gyro_noise=k * math.radians(i["gyro_noise_dps_rthz"]) * rt,
                   gyro_bias=k * math.radians(i["gyro_bias_dps"]),
                   gyro_range=math.radians(i["gyro_range_dps"]),
                   accel_noise=k * i["accel_noise_ug_rthz"] * 1e-6 * g * rt,
                   accel_bias=k * i["accel_bias_mg"] * 1e-3 * g,
                   accel_range=i["accel_range_g"] * g, imu_position=i["position"])

    def record(self) -> NDArray[np.void]:
        """What the compiled functions take (:data:`BOARD`)."""
        r = new(BOARD)
        r[0] = (self.fsr_full_scale, self.fsr_linearity, self.fsr_noise,
                float(2**self.adc_bits - 1), self.adc_reference, self.fsr_full_scale_voltage,
                self.gyro_range, self.accel_range)
        return r


#: The foot board as the compiled functions read it (:meth:`FootSensors.record`): the
#: FSR's full scale (N), linearity error and noise (fractions of full scale), the ADC's
#: top count and reference (V), the FSR's full-scale voltage (V), the IMU's ranges
#: (rad/s, m/s^2).
BOARD = np.dtype([("full_scale", F8), ("linearity", F8), ("noise", F8), ("counts", F8),
                  ("reference", F8), ("full_scale_v", F8), ("gyro_range", F8),
                  ("accel_range", F8)])


@njit(cache=True)
def fsr_counts(s, force, noise):  # type: ignore[no-untyped-def]
    """ADC counts of one FSR under ``force`` N, with the unit normal draw ``noise``."""
    b = s[0]
    f = max(force, 0.0) / b.full_scale
    v = b.full_scale_v * (f + 4.0 * b.linearity * f * (1.0 - f) if f < 1.0 else f)
    v += b.noise * b.full_scale_v * noise
    v = min(max(v, 0.0), b.reference)
    return math.floor(v / b.reference * b.counts + 0.5)


@njit(cache=True)
def imu(s, foot_rate, acc_x, acc_y, phi, g, bias_g, bias_ax, bias_ay, n_g, n_ax, n_ay):  # type: ignore[no-untyped-def]
    """(gyro rad/s, accelerometer x, y m/s^2 in the foot frame): the true foot rate and
    the specific force (acceleration less gravity, rotated into the foot frame) plus
    bias and noise (already scaled), saturated at the ranges."""
    c, sn = math.cos(phi), math.sin(phi)
    fx, fy = acc_x, acc_y + g  # specific force in the world frame (gravity along -y)
    ax = c * fx + sn * fy + bias_ax + n_ax
    ay = -sn * fx + c * fy + bias_ay + n_ay
    gr = foot_rate + bias_g + n_g
    rg, ra = s[0].gyro_range, s[0].accel_range
    return min(max(gr, -rg), rg), min(max(ax, -ra), ra), min(max(ay, -ra), ra)


def draw_noise(sensors: FootSensors, n: int, seed: int) -> tuple[F64, F64, F64]:
    """Seeded draws for a run of n ticks: FSR unit normals (n, 4); IMU noise (n, 3)
    already scaled (gyro, accel x, y); the per-run biases (3,)."""
    rng = np.random.default_rng(seed)
    fsr = rng.standard_normal((n, 4))
    imu_noise = rng.standard_normal((n, 3)) * np.array(
        [sensors.gyro_noise, sensors.accel_noise, sensors.accel_noise])
    bias = rng.standard_normal(3) * np.array(
        [sensors.gyro_bias, sensors.accel_bias, sensors.accel_bias])
    return fsr, imu_noise, bias
