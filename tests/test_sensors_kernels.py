"""The compiled one-sample sensor arithmetic equals the batched NumPy models to the bit."""

import numpy as np
import pytest

from windnav.sensors import IMU, Odometry, RotorSpeedSensor, SensorSuite
from windnav.sensors._kernels import N_NORMALS, NormalStream, imu_odometry_sample


def _models(imu, odo, sf, rates, vel, att, rng):
    accel, gyro, _ = imu.measure(sf[None, None], rates[None, None], rng, bias0=np.zeros((1, 6)))
    _, v, q = odo.measure(np.zeros((1, 1, 3)), vel[None, None], att[None, None], rng)
    return accel[0, 0], gyro[0, 0], v[0, 0], q[0, 0]


@pytest.mark.parametrize("attitude_std", [0.0035, 1e-9, 0.3])
def test_imu_odometry_sample_equals_the_models_bitwise(attitude_std):
    imu = IMU(rate_hz=100.0, accel_noise_density=0.1021, gyro_noise_density=7.07e-5,
              accel_bias_walk=0.0, gyro_bias_walk=0.0)
    odo = Odometry(rate_hz=100.0, velocity_std=0.0354, attitude_std=attitude_std)
    scales = np.array([imu.accel_std, imu.gyro_std, odo.velocity_std, odo.attitude_std])
    gen = np.random.default_rng(7)
    ref_rng, stream = np.random.default_rng(11), NormalStream(np.random.default_rng(11), 50)
    out = [np.empty(3), np.empty(3), np.empty(3), np.empty(4)]
    for _ in range(3000):
        sf, rates, vel = gen.normal(scale=[5.0, 1.0, 3.0], size=(3, 3))
        att = gen.normal(size=4)
        att /= np.linalg.norm(att)
        want = _models(imu, odo, sf, rates, vel, att, ref_rng)
        imu_odometry_sample(sf, rates, vel, att, stream.take(N_NORMALS), scales, *out)
        for a, b in zip(out, want, strict=True):
            assert np.array_equal(a, b)


def test_normal_stream_hands_out_the_generators_sequence():
    stream = NormalStream(np.random.default_rng(3), block=7)
    got = np.concatenate([stream.take(n).copy() for n in (3, 5, 1, 9, 4, 20)])
    assert np.array_equal(got, np.random.default_rng(3).standard_normal(got.size))


@pytest.mark.parametrize("make, name", [
    (lambda: IMU(accel_noise_density=np.nan), "accel_noise_density"),  # logged NaN before
    (lambda: IMU(accel_bias_walk=np.inf), "accel_bias_walk"),
    (lambda: IMU(gyro_noise_density=-1.0), "gyro_noise_density"),  # "scale < 0" at fly time
    (lambda: Odometry(position_std=np.nan), "position_std"),
    (lambda: RotorSpeedSensor(noise_std=np.nan), "noise_std"),
    (lambda: SensorSuite(imu=Odometry()), "imu"),  # blamed 'extra' before
    (lambda: SensorSuite(imu="abc"), "imu"),
])
def test_bad_sensor_noise_and_kinds_are_named_at_construction(make, name):
    with pytest.raises(ValueError, match=f"'{name}' parameter of"):
        make()


def test_imu_bias_random_walk_variance_grows_as_walk_squared_times_elapsed_time():
    """``b_k`` is a sum of ``k`` steps of std ``sigma_bw sqrt(1 / rate_hz)`` (it starts at 0 at
    the first sample), so ``Var b_k = sigma_bw^2 k / rate_hz``, independently per axis. Pooled
    over 30,000 samples (3 axes) per step the variance is within 4 % (about 5 sigma); the
    mutation ``h = 1 / rate_hz`` would divide it by 50."""
    rate, walk_a, walk_g, K, B = 50.0, 0.4, 0.03, 9, 10_000
    imu = IMU(rate_hz=rate, accel_noise_density=0.0, gyro_noise_density=0.0,
              accel_bias_walk=walk_a, gyro_bias_walk=walk_g)
    zeros = np.zeros((K, B, 3))
    _, _, bias = imu.measure(zeros, zeros, np.random.default_rng(5))
    assert bias.shape == (K, B, 6)
    np.testing.assert_array_equal(bias[0], 0.0)
    k = np.arange(1, K)[:, None]
    want = np.array([walk_a**2, walk_g**2]) * k / rate
    # zero-mean walk: the second moment is the variance; pooled over vehicles and axes
    var = (bias[1:] ** 2).reshape(K - 1, B, 2, 3).mean(axis=(1, 3))
    np.testing.assert_allclose(var, want, rtol=0.04)
    # independent increments: the variance of each step is sigma_bw^2 / rate_hz
    step = np.diff(bias, axis=0).reshape(-1, 2, 3)
    np.testing.assert_allclose((step**2).mean(axis=(0, 2)), [walk_a**2 / rate, walk_g**2 / rate],
                               rtol=0.02)
