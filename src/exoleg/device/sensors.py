"""The foot board's sensors as the board would send them (paper section 2.3).

* **FSRs** (four FlexiForce A201 at :data:`exoleg.world.plant.SENSOR_POINTS`): the
  normal force at each point -> the sheet's **hysteresis** (:func:`fsr_response`: the
  unloading curve above the loading one by up to ``hysteresis`` of full scale, at half
  scale, meeting it at no load and at full scale) and **drift** (creep: under a
  constant load the reading rises by ``drift`` per decade of time, three first-order
  states of 1, 10 and 100 s) -> the amplifier's voltage, linear in force (the sensor's
  conductance is) with the datasheet's linearity error as a bow of at most
  ``linearity`` of full scale -> noise -> saturation at the ADC's reference -> 12-bit
  counts.
* **IMU** (MPU9250 on the footplate): the gyroscope's sagittal rate (the foot's angular
  velocity) and the accelerometer's specific force in the foot frame, each with a bias
  drawn once per run, white noise of the datasheet's density over the sensor's
  bandwidth, and saturation at the full-scale range.
* Encoders: :func:`exoleg.device.drive.encode`.

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

from exoleg import checks as _check
from exoleg.errors import ParameterError
from exoleg.layout import F8, new

F64 = NDArray[np.float64]

#: The FSR load the detector's calibration floor starts from, N (each sensor's running
#: maximum starts at its reading of this load: an unloaded start divides by nothing).
FSR_FLOOR_N = 20.0


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
    fsr_hysteresis: float    # fraction of full scale (largest loading/unloading gap)
    fsr_drift: float         # fraction of the reading per decade of time under load
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
    #: the unassisted foot's insole (``[other_foot]``): fitted or not, and where along its
    #: stance (0 its strike, 1 its toe off) the load leaves the heel and reaches the hallux
    other_foot: bool = False
    other_heel_until: float = 0.6
    other_hallux_from: float = 0.5

    @classmethod
    def default(cls, noise_scale: float = 1.0, folder: str | Path | None = None) -> FootSensors:
        """From ``sensors.toml`` (a device folder's, :mod:`exoleg.device.files`, or the
        package's); ``noise_scale`` multiplies every noise and bias (0: ideal sensors, 2:
        twice the datasheets' noise)."""
        from exoleg.device.files import load

        where, d = load("sensors.toml", folder)
        _check.keys(where, d, ["fsr", "imu"], ["source", "other_foot"])
        f = _check.ranged(f"{where} [fsr]", d["fsr"], {
            "full_scale_N": (1.0, 1e4, "N"), "linearity": (0.0, 0.2, ""),
            "hysteresis": (0.0, 0.2, ""), "drift": (0.0, 0.2, ""),
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
        o = d.get("other_foot", {"fitted": False})
        if not isinstance(o, dict):
            raise ParameterError(where, "other_foot", "expected a table (fitted, "
                                 "heel_until, hallux_from)")
        _check.keys(f"{where} [other_foot]", o, ["fitted"], ["heel_until", "hallux_from"])
        if not isinstance(o["fitted"], bool):
            raise ParameterError(f"{where} [other_foot]", "fitted",
                                 f"expected true or false, got {o['fitted']!r}")
        shares = _check.ranged(f"{where} [other_foot]", {  # (absent: the fields' defaults)
            "heel_until": o.get("heel_until", cls.other_heel_until),
            "hallux_from": o.get("hallux_from", cls.other_hallux_from)},
            {"heel_until": (0.1, 1.0, ""), "hallux_from": (0.0, 0.9, "")})
        k = _check.finite("FootSensors", "noise_scale", noise_scale)
        if not 0.0 <= k <= 100.0:
            raise ParameterError("FootSensors", "noise_scale", f"{k:g} is outside 0-100")
        g = 9.81
        rt = math.sqrt(i["bandwidth_hz"])
        return cls(fsr_full_scale=f["full_scale_N"], fsr_linearity=f["linearity"],
                   fsr_noise=k * f["noise"], fsr_hysteresis=f["hysteresis"],
                   fsr_drift=f["drift"], adc_bits=int(f["adc_bits"]),
                   adc_reference=f["adc_reference_V"], fsr_full_scale_voltage=f["full_scale_V"],
                   gyro_noise=k * math.radians(i["gyro_noise_dps_rthz"]) * rt,
                   gyro_bias=k * math.radians(i["gyro_bias_dps"]),
                   gyro_range=math.radians(i["gyro_range_dps"]),
                   accel_noise=k * i["accel_noise_ug_rthz"] * 1e-6 * g * rt,
                   accel_bias=k * i["accel_bias_mg"] * 1e-3 * g,
                   accel_range=i["accel_range_g"] * g, imu_position=i["position"],
                   other_foot=o["fitted"], other_heel_until=shares["heel_until"],
                   other_hallux_from=shares["hallux_from"])

    def counts(self, force: float) -> float:
        """The board's noise-free reading of ``force`` N on an FSR, ADC counts."""
        return float(fsr_counts(self.record(), force, 0.0))

    def newtons(self, counts: float) -> float:
        """The force, N, that the board's noise-free reading ``counts`` stands for: the
        inverse of :func:`fsr_counts`' response (its linearity's quadratic solved; to
        within one count's quantization), beyond full scale linear."""
        y = float(counts) / float(2**self.adc_bits - 1) * self.adc_reference \
            / self.fsr_full_scale_voltage
        lin = self.fsr_linearity
        if y >= 1.0 or lin <= 0.0:
            return max(y, 0.0) * self.fsr_full_scale
        b = 1.0 + 4.0 * lin
        f = (b - math.sqrt(max(b * b - 16.0 * lin * y, 0.0))) / (8.0 * lin)
        return max(f, 0.0) * self.fsr_full_scale

    def record(self) -> NDArray[np.void]:
        """What the compiled functions take (:data:`BOARD`)."""
        r = new(BOARD)
        r[0] = (self.fsr_full_scale, self.fsr_linearity, self.fsr_noise,
                float(2**self.adc_bits - 1), self.adc_reference, self.fsr_full_scale_voltage,
                self.gyro_range, self.accel_range, self.fsr_hysteresis, self.fsr_drift,
                1.0 if self.other_foot else 0.0, self.other_heel_until,
                self.other_hallux_from)
        return r


#: The foot board is frozen when its readings (four FSRs and the gyro, noisy in every
#: real sample) repeat bit for bit this long, s: the runtime's watch
#: (:class:`~exoleg.runtime.watch.SensorWatch`) and the simulated walk's take the torque
#: off.
FROZEN_S = 0.25

#: The foot board as the compiled functions read it (:meth:`FootSensors.record`): the
#: FSR's full scale (N), linearity error and noise (fractions of full scale), the ADC's
#: top count and reference (V), the FSR's full-scale voltage (V), the IMU's ranges
#: (rad/s, m/s^2), the FSRs' hysteresis and drift, whether the unassisted foot's insole
#: is fitted (1/0) and its load's progression (:func:`other_loads`).
BOARD = np.dtype([("full_scale", F8), ("linearity", F8), ("noise", F8), ("counts", F8),
                  ("reference", F8), ("full_scale_v", F8), ("gyro_range", F8),
                  ("accel_range", F8), ("hysteresis", F8), ("drift", F8), ("other", F8),
                  ("heel_until", F8), ("hallux_from", F8)])
#: the creep states' time constants, s: three decades, so that a constant load's
#: reading rises by about ``drift`` per decade of time between 1 and 100 s
CREEP_TAU = (1.0, 10.0, 100.0)


@njit(cache=True)
def fsr_response(s, last, memory, creep, i, force, h):  # type: ignore[no-untyped-def]
    """FSR ``i``'s normalised reading (fraction of full scale) under ``force`` N, after
    its hysteresis and drift, ``h`` s after the last call; updates its memory: per sensor
    the last normalised force ``last`` (4,), the hysteresis's direction memory ``memory``
    (4,: -1 loading .. +1 unloading) and the creep states ``creep`` (4, 3) (a device's
    :data:`~exoleg.world.device.DEVICE` holds them). Hysteresis: reading =
    f + 2 H f (1 - f) m, the direction memory m moving towards -1 while loading and +1
    while unloading, all the way over a change of H in f -- so the two curves are
    2 x H/2 = H apart at half scale (the sheet's figure) and meet at no load and full
    scale. Drift: creep states c_k relaxing to drift x the reading with time constants
    :data:`CREEP_TAU`; reading x (1 + sum c_k)."""
    b = s[0]
    f = min(max(force, 0.0) / b.full_scale, 1.0)
    H = b.hysteresis
    if H > 0.0:
        memory[i] = min(max(memory[i] - (f - last[i]) / H, -1.0), 1.0)
    last[i] = f
    y = f + 2.0 * H * f * (1.0 - f) * memory[i]
    c = 0.0
    target = b.drift if f > 0.0 else 0.0
    for k in range(3):
        creep[i, k] += (target - creep[i, k]) * (1.0 - math.exp(-h / CREEP_TAU[k]))
        c += creep[i, k]
    return y * (1.0 + c)


@njit(cache=True)
def other_loads(s, force, progress, out):  # type: ignore[no-untyped-def]
    """The unassisted foot's ``force`` (N, its whole load) over its insole's four sensors
    (:data:`~exoleg.tick.SENSOR_POINTS`' order) into ``out`` (4,), at ``progress`` along
    its stance (0 its strike, 1 its toe off): the heel's share falls from all to none by
    ``heel_until``, the rest on the forefoot, of which the hallux takes up to half from
    ``hallux_from`` on, the metatarsal heads the rest (first 55 %, fifth 45 %). The
    common heel-to-toe pattern of children's plantar loading; the figures are choices
    (``sensors.toml [other_foot]``)."""
    b = s[0]
    p = min(max(progress, 0.0), 1.0)
    heel = min(max(1.0 - p / b.heel_until, 0.0), 1.0)
    fore = 1.0 - heel
    hallux = 0.5 * fore * min(max((p - b.hallux_from) / (1.0 - b.hallux_from), 0.0), 1.0)
    f = max(force, 0.0)
    out[0] = f * heel
    out[1] = 0.55 * f * (fore - hallux)
    out[2] = 0.45 * f * (fore - hallux)
    out[3] = f * hallux


@njit(cache=True)
def fsr_counts(s, force, noise):  # type: ignore[no-untyped-def]
    """ADC counts of one FSR under ``force`` N (as the sensor reads it: after
    :func:`fsr_response`), with the unit normal draw ``noise``."""
    b = s[0]
    f = max(force, 0.0) / b.full_scale
    v = b.full_scale_v * (f + 4.0 * b.linearity * f * (1.0 - f) if f < 1.0 else f)
    v += b.noise * b.full_scale_v * noise
    v = min(max(v, 0.0), b.reference)
    return math.floor(v / b.reference * b.counts + 0.5)


@njit(cache=True)
def imu(s, foot_rate, acc_x, acc_y, phi, g, bias, noise):  # type: ignore[no-untyped-def]
    """(gyro rad/s, accelerometer x, y m/s^2 in the foot frame): the true foot rate and
    the specific force (acceleration less gravity, rotated into the foot frame) plus
    ``bias`` and ``noise`` (3,: gyro, accelerometer x, y; the noise already scaled),
    saturated at the ranges."""
    c, sn = math.cos(phi), math.sin(phi)
    fx, fy = acc_x, acc_y + g  # specific force in the world frame (gravity along -y)
    ax = c * fx + sn * fy + bias[1] + noise[1]
    ay = -sn * fx + c * fy + bias[2] + noise[2]
    gr = foot_rate + bias[0] + noise[0]
    rg, ra = s[0].gyro_range, s[0].accel_range
    return min(max(gr, -rg), rg), min(max(ax, -ra), ra), min(max(ay, -ra), ra)


def draw_noise(sensors: FootSensors, n: int, seed: int) -> tuple[F64, F64, F64]:
    """Seeded draws for a run of n ticks: FSR unit normals (n, 8: the foot's four, then
    the unassisted foot's insole's, drawn after the rest -- zeros when it is not fitted,
    so that a run without it draws what it always drew); IMU noise (n, 3) already
    scaled (gyro, accel x, y); the per-run biases (3,)."""
    rng = np.random.default_rng(seed)
    fsr = np.zeros((n, 8))
    fsr[:, :4] = rng.standard_normal((n, 4))
    imu_noise = rng.standard_normal((n, 3)) * np.array(
        [sensors.gyro_noise, sensors.accel_noise, sensors.accel_noise])
    bias = rng.standard_normal(3) * np.array(
        [sensors.gyro_bias, sensors.accel_bias, sensors.accel_bias])
    if sensors.other_foot:
        fsr[:, 4:] = rng.standard_normal((n, 4))
    return fsr, imu_noise, bias
