"""Closed-loop flight: SE(3) control, multi-rate sensors, FlightLog."""

import numpy as np
import pytest

import windnav as wn
from windnav.control import SE3Controller
from windnav.sensors import IMU, Odometry, RotorSpeedSensor, SensorSuite
from windnav.sim import FlightLog, fly, make_trajectory
from windnav.vehicle import GRAVITY, Multirotor
from windnav.wind import ConstantWind

NO_SENSORS = SensorSuite(None, None, None)


class ShearWind:
    """w_x = shear * y: a spatially varying test field."""

    def __init__(self, shear):
        self.shear = shear

    def velocity(self, t, xyz):
        xyz = np.asarray(xyz, float)
        return np.stack([self.shear * xyz[:, 1], 0 * xyz[:, 0], 0 * xyz[:, 0]], axis=1)


class NaNWind:
    def velocity(self, t, xyz):
        out = np.zeros((len(xyz), 3))
        if t > 0.5:
            out[:] = np.nan
        return out


@pytest.mark.parametrize("vehicle", wn.vehicle.VEHICLES)
def test_hover_holds_position(vehicle):
    p = wn.vehicle.params(vehicle)
    log = fly(p, make_trajectory("hover", start=(1.0, -2.0, 3.0)), ConstantWind((0, 0, 0)), 5.0,
              sensors=NO_SENSORS)
    assert np.max(log.tracking_error) < 1e-9


@pytest.mark.parametrize("vehicle", wn.vehicle.VEHICLES)
def test_circle_tracking_in_still_air_and_wind(vehicle):
    p = wn.vehicle.params(vehicle)
    traj = make_trajectory("circle", start=(0, 0, 2), size=2.0, speed=1.5)
    calm = fly(p, traj, ConstantWind((0, 0, 0)), 12.0, sensors=NO_SENSORS)
    windy = fly(p, traj, ConstantWind((3.0, 1.0, 0)), 12.0, sensors=NO_SENSORS)
    rms = lambda log: np.sqrt(np.mean(log.tracking_error[log.t > 4] ** 2))  # noqa: E731
    assert rms(calm) < 0.2
    assert calm.saturation_fraction == 0.0
    # the SE(3) law has no integral action: wind leaves a bounded offset, larger than in calm
    assert rms(calm) < rms(windy) < 1.0


def test_acceleration_command_mode_tracks_commanded_acceleration():
    p = wn.vehicle.params("hummingbird")
    model = Multirotor(p, aero=False)
    ctrl = SE3Controller(p)
    s = model.hover_state([0.0, 0.0, 0.0])
    x = s.to_array()
    out = np.empty_like(x)
    a_cmd = np.array([[1.0, -0.5, 0.2]])
    dt = 0.005
    zero = np.zeros((1, 3))
    for _ in range(int(3.0 / dt)):
        cmd, _ = ctrl.accelerate(x, a_cmd, np.zeros(1))
        model.step_packed(x, np.clip(cmd, 0, p.rotor_speed_max), zero,
                          np.zeros((1, 4, 3)), dt, out)
        x, out = out, x
    # after the attitude transient (~0.2 s) the velocity grows at the commanded rate
    np.testing.assert_allclose(x[0, 3:6], a_cmd[0] * 3.0, rtol=0.06, atol=0.03)


def test_imu_statistics_at_hover():
    p = wn.vehicle.params("hummingbird")
    imu = IMU(rate_hz=200.0, accel_bias_walk=0.0, gyro_bias_walk=0.0)
    log = fly(p, make_trajectory("hover"), ConstantWind((0, 0, 0)), 20.0,
              sensors=SensorSuite(imu, Odometry(rate_hz=100.0), RotorSpeedSensor(rate_hz=50.0)),
              seed=1)
    accel = log.sensors["imu"]["accel"][:, 0]
    gyro = log.sensors["imu"]["gyro"][:, 0]
    np.testing.assert_allclose(accel.mean(axis=0), [0, 0, GRAVITY], atol=4 * imu.accel_std / 63)
    np.testing.assert_allclose(accel.std(axis=0), imu.accel_std, rtol=0.05)
    np.testing.assert_allclose(gyro.std(axis=0), imu.gyro_std, rtol=0.05)
    # each sensor at its own rate
    assert len(log.sensors["imu"]["t"]) == 4001
    assert len(log.sensors["odometry"]["t"]) == 2001
    assert len(log.sensors["rotor_speeds"]["t"]) == 1001
    np.testing.assert_allclose(np.diff(log.sensors["odometry"]["t"]), 0.01)


def test_accelerometer_reads_specific_force_in_manoeuvre():
    p = wn.vehicle.params("hummingbird")
    imu = IMU(rate_hz=200.0, accel_noise_density=0.0, gyro_noise_density=0.0,
              accel_bias_walk=0.0, gyro_bias_walk=0.0)
    log = fly(p, make_trajectory("circle", size=2.0, speed=2.0), ConstantWind((2, 0, 0)), 6.0,
              sensors=SensorSuite(imu, None, None))
    # specific force = R^T (a + g e3): compare with finite-differenced velocity
    from scipy.spatial.transform import Rotation

    t = log.t
    acc_world = np.gradient(log.velocity[:, 0], t, axis=0)
    f_world = acc_world + [0, 0, GRAVITY]
    f_body = Rotation.from_quat(log.attitude[:, 0]).inv().apply(f_world)
    meas = log.sensors["imu"]["accel"][:, 0]
    np.testing.assert_allclose(meas[50:-50], f_body[50:-50], atol=0.02)


def test_clipping_is_recorded():
    p = wn.vehicle.params("crazyflie_brushless")
    aggressive = wn.sim.Line((0, 0, 0), (15, 0, 0), duration=1.5)
    log = fly(p, aggressive, ConstantWind((0, 0, 0)), 2.0, sensors=NO_SENSORS)
    assert log.saturation_fraction > 0.01
    assert np.all(log.rotor_speeds <= p.rotor_speed_max + 1e-9)
    assert log.meta["saturated_fraction"] == pytest.approx(log.saturation_fraction)
    gentle = fly(p, make_trajectory("hover"), ConstantWind((0, 0, 0)), 1.0, sensors=NO_SENSORS)
    assert gentle.saturation_fraction == 0.0


def test_log_round_trip_and_corrupt_file(tmp_path):
    p = wn.vehicle.params("hummingbird")
    log = fly(p, make_trajectory("waypoints", size=2.0), ConstantWind((1, 0, 0)), 2.0, seed=3)
    path = log.save(tmp_path / "flight.npz")
    back = FlightLog.load(path)
    for name in FlightLog._ARRAYS:
        np.testing.assert_array_equal(getattr(back, name), getattr(log, name))
    np.testing.assert_array_equal(back.sensors["imu"]["accel"], log.sensors["imu"]["accel"])
    assert back.meta == log.meta
    bad = tmp_path / "bad.npz"
    bad.write_bytes(b"not a zip file")
    with pytest.raises(ValueError, match="'path'"):
        FlightLog.load(bad)


def test_energy_is_integral_of_power():
    p = wn.vehicle.params("hummingbird")
    log = fly(p, make_trajectory("hover"), ConstantWind((0, 0, 0)), 2.0, sensors=NO_SENSORS)
    hover_power = p.n_rotors * p.k_m * p.hover_rotor_speed**3
    np.testing.assert_allclose(log.power[:, 0], hover_power, rtol=1e-9)
    np.testing.assert_allclose(log.energy[-1, 0], 2.0 * hover_power, rtol=1e-9)


def test_same_seed_same_numbers_and_batch_rows_match():
    p = wn.vehicle.params("hummingbird")
    traj = make_trajectory("circle", size=2.0)
    a = fly(p, traj, ConstantWind((1, 1, 0)), 1.0, seed=7)
    b = fly(p, traj, ConstantWind((1, 1, 0)), 1.0, seed=7)
    np.testing.assert_array_equal(a.sensors["imu"]["accel"], b.sensors["imu"]["accel"])
    batch = fly(p, traj, ConstantWind((1, 1, 0)), 1.0, batch=3, sensors=NO_SENSORS)
    for i in range(3):
        np.testing.assert_array_equal(batch.position[:, i], a.position[:, 0])


def test_hub_wind_sees_shear():
    p = wn.vehicle.params("hummingbird")
    traj = make_trajectory("hover", start=(0, 0, 1))
    uniform = ConstantWind((2.0, 0.0, 0.0))
    a = fly(p, traj, uniform, 1.0, sensors=NO_SENSORS)
    b = fly(p, traj, uniform, 1.0, sensors=NO_SENSORS, hub_wind=True)
    np.testing.assert_allclose(a.position, b.position, atol=1e-12)
    shear = ShearWind(3.0)
    c = fly(p, traj, shear, 1.0, sensors=NO_SENSORS)
    d = fly(p, traj, shear, 1.0, sensors=NO_SENSORS, hub_wind=True)
    # at the start the CoM sits at y = 0 (no wind), but the hubs at y = +-0.12 m feel +-0.36 m/s
    assert np.max(np.abs(c.body_rates[:20])) < 1e-12
    assert np.max(np.abs(d.body_rates[:20])) > 1e-6


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(duration=0.0), "duration"),
        (dict(dt=-1.0), "dt"),
        (dict(control_rate_hz=300.0), "rate_hz"),
        (dict(sensors=SensorSuite(IMU(rate_hz=333.0), None, None)), "rate_hz"),
        (dict(wind=NaNWind()), "wind"),
        (dict(wind=object()), "wind"),
    ],
)
def test_bad_input(kwargs, name):
    p = wn.vehicle.params("hummingbird")
    args = dict(trajectory=make_trajectory("hover"), wind=ConstantWind((0, 0, 0)), duration=1.0)
    args.update(kwargs)
    with pytest.raises(ValueError, match=name):
        fly(p, **args)
