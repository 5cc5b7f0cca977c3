"""Sensor models: IMU, odometry / motion capture, rotor-speed pseudo-measurements.

Each sensor is a frozen parameter dataclass with its own ``rate_hz``, a pure, batched
``measure`` function taking an explicit ``numpy.random.Generator``, and the common
:class:`~windnav.sensors.base.Sensor` interface the runner calls: a ``name`` and
``sample(truth, rng)``.

IMU (continuous-time noise densities, as in Kalibr / Furgale et al.)::

    accel = R^T (a_world + g e3) + b_a + n_a,   n_a ~ N(0, sigma_a^2 * rate_hz)
    gyro  = Omega + b_g + n_g,                  n_g ~ N(0, sigma_g^2 * rate_hz)
    b_{k+1} = b_k + sigma_bw * sqrt(1 / rate_hz) * N(0, 1)     (bias random walk)

where sigma_a (m/s^2/sqrt(Hz)) and sigma_g (rad/s/sqrt(Hz)) are noise densities, so the
white-noise standard deviation grows with the square root of the sample rate.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import ClassVar

import numpy as np

from windnav._validate import positive_float
from windnav.sensors.base import Sensor, SensorTruth
from windnav.vehicle.rotation import quat_from_rotvec, quat_multiply


def _check_noise(sensor, names, where: str) -> None:
    """Each noise parameter finite and >= 0 (NaN logged NaN measurements; a negative one failed
    at the first sample with NumPy's "scale < 0")."""
    for name in names:
        positive_float(getattr(sensor, name), name, where, allow_zero=True)


def _check_rate(rate_hz, where):
    return positive_float(rate_hz, "rate_hz", where)


def _numbers(a, name: str, where: str) -> np.ndarray:
    """``a`` as an array of numbers (the same object for an ndarray), else a named ValueError."""
    try:
        arr = np.asarray(a)
    except ValueError:  # ragged
        arr = None
    if arr is None or arr.dtype.kind not in "biuf":
        raise ValueError(f"The {name!r} parameter of {where} must be an array of numbers. Got "
                         f"{type(a).__name__} instead.")
    return arr


def _shaped(a, name: str, where: str, shape: tuple, want: str) -> np.ndarray:
    """``a`` as an array of numbers of ``shape``, else a ValueError naming it and ``want``."""
    arr = _numbers(a, name, where)
    if arr.shape != shape:
        raise ValueError(f"The {name!r} parameter of {where} must have shape {want}. Got shape "
                         f"{arr.shape} instead.")
    return arr


@dataclass(frozen=True)
class IMU:
    """Accelerometer + gyroscope at the centre of mass.

    Attributes
    ----------
    rate_hz : float
        Sample rate, Hz.
    accel_noise_density : float
        White-noise density of the accelerometer, m/s^2/sqrt(Hz).
    gyro_noise_density : float
        White-noise density of the gyroscope, rad/s/sqrt(Hz).
    accel_bias_walk : float
        Accelerometer bias random walk, m/s^3/sqrt(Hz).
    gyro_bias_walk : float
        Gyroscope bias random walk, rad/s^2/sqrt(Hz).
    """

    name: ClassVar[str] = "imu"
    rate_hz: float = 200.0
    accel_noise_density: float = 0.0028
    gyro_noise_density: float = 0.00017
    accel_bias_walk: float = 1e-4
    gyro_bias_walk: float = 2e-5

    def __post_init__(self):
        _check_rate(self.rate_hz, "IMU")
        _check_noise(self, ("accel_noise_density", "gyro_noise_density", "accel_bias_walk",
                            "gyro_bias_walk"), "IMU")

    @property
    def accel_std(self) -> float:
        """White-noise standard deviation per sample, m/s^2."""
        return self.accel_noise_density * np.sqrt(self.rate_hz)

    @property
    def gyro_std(self) -> float:
        """White-noise standard deviation per sample, rad/s."""
        return self.gyro_noise_density * np.sqrt(self.rate_hz)

    def measure(self, specific_force_body, body_rates, rng, bias0=None):
        """Samples over a sequence; returns ``(accel, gyro, bias)``.

        Parameters
        ----------
        specific_force_body : ndarray of shape (K, B, 3)
            True non-gravitational acceleration in body axes at K consecutive samples, m/s^2.
        body_rates : ndarray of shape (K, B, 3)
            True body rates, rad/s.
        rng : numpy.random.Generator
        bias0 : ndarray of shape (B, 6), optional
            Biases (accelerometer then gyroscope) at the first sample; zero by default.

        Returns
        -------
        accel (K, B, 3) m/s^2, gyro (K, B, 3) rad/s, bias (K, B, 6) in force at each sample.

        Raises
        ------
        ValueError
            Naming ``specific_force_body`` (not (K, B, 3)), ``body_rates`` (not its shape) or
            ``bias0`` (not (B, 6) or another shape that broadcasts to (K, B, 6)).
        """
        where = "IMU.measure"
        specific_force_body = _numbers(specific_force_body, "specific_force_body", where)
        shape = specific_force_body.shape
        if len(shape) != 3 or shape[2] != 3:
            raise ValueError(f"The 'specific_force_body' parameter of {where} must have shape "
                             f"(K, B, 3). Got shape {shape} instead.")
        body_rates = _shaped(body_rates, "body_rates", where, shape, f"{shape} (K, B, 3) as "
                             "specific_force_body's")
        if bias0 is not None:
            bias0 = _numbers(bias0, "bias0", where)
            try:
                fits = np.broadcast_shapes(bias0.shape, (*shape[:2], 6)) == (*shape[:2], 6)
            except ValueError:
                fits = False
            if not fits:
                raise ValueError(f"The 'bias0' parameter of {where} must have shape "
                                 f"({shape[1]}, 6). Got shape {bias0.shape} instead.")
        K, B = specific_force_body.shape[:2]
        h = np.sqrt(1.0 / self.rate_hz)
        walk = np.concatenate([
            rng.normal(scale=self.accel_bias_walk * h, size=(K, B, 3)),
            rng.normal(scale=self.gyro_bias_walk * h, size=(K, B, 3)),
        ], axis=-1)
        bias = np.cumsum(walk, axis=0) - walk  # the walk starts after the first sample
        if bias0 is not None:
            bias = bias + bias0
        accel = specific_force_body + bias[..., :3] + rng.normal(scale=self.accel_std,
                                                                 size=(K, B, 3))
        gyro = body_rates + bias[..., 3:] + rng.normal(scale=self.gyro_std, size=(K, B, 3))
        return accel, gyro, bias

    def sample(self, truth: SensorTruth, rng) -> dict:
        """``accel`` (K, B, 3) m/s^2, ``gyro`` (K, B, 3) rad/s, ``bias`` (K, B, 6) of ``truth``."""
        accel, gyro, bias = self.measure(truth.specific_force_body, truth.body_rates, rng)
        return {"accel": accel, "gyro": gyro, "bias": bias}


@dataclass(frozen=True)
class Odometry:
    """Motion-capture / odometry: position, world velocity and attitude with white noise.

    Attributes
    ----------
    rate_hz : float
        Sample rate, Hz.
    position_std : float
        m.
    velocity_std : float
        m/s.
    attitude_std : float
        Standard deviation of a small random rotation applied to the attitude, rad.
    """

    name: ClassVar[str] = "odometry"
    rate_hz: float = 100.0
    position_std: float = 0.005
    velocity_std: float = 0.02
    attitude_std: float = 0.005

    def __post_init__(self):
        _check_rate(self.rate_hz, "Odometry")
        _check_noise(self, ("position_std", "velocity_std", "attitude_std"), "Odometry")

    def measure(self, position, velocity, attitude, rng):
        """Samples of arrays with any leading shape ``(..., 3)`` / ``(..., 4)``.

        Returns ``(position, velocity, attitude xyzw)`` with white noise; the attitude is
        perturbed by a random rotation vector of standard deviation ``attitude_std`` per axis,
        applied in the body frame.

        Raises
        ------
        ValueError
            Naming ``position`` (not (..., 3)), ``velocity`` (not its shape) or ``attitude``
            (not (..., 4) with its leading axes).
        """
        where = "Odometry.measure"
        position = _numbers(position, "position", where)
        shape = position.shape
        if not shape or shape[-1] != 3:
            raise ValueError(f"The 'position' parameter of {where} must have shape (..., 3). "
                             f"Got shape {shape} instead.")
        velocity = _shaped(velocity, "velocity", where, shape, f"{shape} as position's")
        attitude = _shaped(attitude, "attitude", where, (*shape[:-1], 4),
                           f"{(*shape[:-1], 4)} (position's leading axes, xyzw)")
        pos = position + rng.normal(scale=self.position_std, size=position.shape)
        vel = velocity + rng.normal(scale=self.velocity_std, size=velocity.shape)
        dtheta = rng.normal(scale=self.attitude_std, size=position.shape)
        att = quat_multiply(attitude, quat_from_rotvec(dtheta))
        return pos, vel, att

    def sample(self, truth: SensorTruth, rng) -> dict:
        """``position`` (K, B, 3) m, ``velocity`` (K, B, 3) m/s, ``attitude`` (K, B, 4) xyzw."""
        p, v, q = self.measure(truth.position, truth.velocity, truth.attitude, rng)
        return {"position": p, "velocity": v, "attitude": q}


@dataclass(frozen=True)
class RotorSpeedSensor:
    """Commanded rotor speeds used as pseudo-measurements of the rotor speeds.

    Attributes
    ----------
    rate_hz : float
        Sample rate, Hz.
    noise_std : float
        rad/s (0: the exact commands).
    """

    name: ClassVar[str] = "rotor_speeds"
    rate_hz: float = 100.0
    noise_std: float = 0.0

    def __post_init__(self):
        _check_rate(self.rate_hz, "RotorSpeedSensor")
        _check_noise(self, ("noise_std",), "RotorSpeedSensor")

    def measure(self, rotor_speed_cmd, rng):
        """Samples of the commanded speeds (any shape), rad/s.

        Raises
        ------
        ValueError
            Naming ``rotor_speed_cmd`` when it is not an array of numbers.
        """
        rotor_speed_cmd = _numbers(rotor_speed_cmd, "rotor_speed_cmd", "RotorSpeedSensor.measure")
        if self.noise_std == 0.0:
            return np.array(rotor_speed_cmd, dtype=np.float64)
        return rotor_speed_cmd + rng.normal(scale=self.noise_std, size=rotor_speed_cmd.shape)

    def sample(self, truth: SensorTruth, rng) -> dict:
        """``cmd`` (K, B, N): the clipped rotor-speed commands, rad/s."""
        return {"cmd": self.measure(truth.rotor_speed_cmd, rng)}


@dataclass(frozen=True)
class SensorSuite:
    """The sensors carried by a vehicle; ``None`` disables one.

    Attributes
    ----------
    imu, odometry, rotor_speeds : IMU, Odometry, RotorSpeedSensor or None
        The standard sensors.
    extra : tuple of Sensor
        Further sensors (anything with ``name``, ``rate_hz`` and ``sample(truth, rng)``),
        sampled after the standard ones; names must be unique.
    """

    imu: IMU | None = IMU()
    odometry: Odometry | None = Odometry()
    rotor_speeds: RotorSpeedSensor | None = RotorSpeedSensor()
    extra: tuple = ()

    def __post_init__(self):
        for name, kind in (("imu", IMU), ("odometry", Odometry),
                           ("rotor_speeds", RotorSpeedSensor)):
            value = getattr(self, name)
            if value is not None and not isinstance(value, kind):  # blamed 'extra' before
                raise ValueError(f"The {name!r} parameter of SensorSuite must be a "
                                 f"{kind.__name__} or None. Got {type(value).__name__} instead.")
        extra = tuple(self.extra)
        for s in extra:
            if not isinstance(s, Sensor):
                raise ValueError("The 'extra' parameter of SensorSuite must hold sensors with "
                                 "name, rate_hz and sample(truth, rng). "
                                 f"Got {type(s).__name__} instead.")
        object.__setattr__(self, "extra", extra)
        names = [name for name, _ in self.items()]
        if len(set(names)) != len(names):
            raise ValueError("The 'extra' parameter of SensorSuite must not repeat a sensor "
                             f"name. Got names {names} instead.")

    def sensors(self) -> list:
        """The enabled sensors, in sampling order."""
        return [s for s in (self.imu, self.odometry, self.rotor_speeds, *self.extra)
                if s is not None]

    def items(self):
        """``[(name, sensor), ...]`` of the enabled sensors, in sampling order."""
        return [(s.name, s) for s in self.sensors()]
