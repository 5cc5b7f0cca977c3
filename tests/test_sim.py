"""Closed-loop flight: SE(3) control, multi-rate sensors, FlightLog."""

import numpy as np
import pytest

import windnav as wn
from windnav.control import SE3Controller
from windnav.sensors import IMU, Odometry, RotorSpeedSensor, SensorSuite
from windnav.sim import FlightLog, FlightStatus, fly, make_trajectory
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


class PatchyWind:
    """(2, 1, 0) m/s, but NaN after ``t_bad`` s wherever y > ``y_bad`` m."""

    def __init__(self, t_bad=0.5, y_bad=50.0):
        self.t_bad, self.y_bad = t_bad, y_bad

    def velocity(self, t, xyz):
        out = np.tile([2.0, 1.0, 0.0], (len(xyz), 1))
        if t > self.t_bad:
            out[np.asarray(xyz)[:, 1] > self.y_bad] = np.nan
        return out


class WrongShapeWind:
    def velocity(self, t, xyz):
        return np.zeros((len(xyz) + 1, 3))


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
              rng=1)
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
    log = fly(p, make_trajectory("waypoints", size=2.0), ConstantWind((1, 0, 0)), 2.0, rng=3)
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
    a = fly(p, traj, ConstantWind((1, 1, 0)), 1.0, rng=7)
    b = fly(p, traj, ConstantWind((1, 1, 0)), 1.0, rng=7)
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
        (dict(duration=0.05, dt=1.0), "'duration' parameter of fly must be at least half"),
        (dict(dt=-1.0), "dt"),
        (dict(control_rate_hz=300.0), "rate_hz"),
        (dict(sensors=SensorSuite(IMU(rate_hz=333.0), None, None)), "rate_hz"),
        (dict(wind=WrongShapeWind()), "wind"),
        (dict(wind=object()), "wind"),
        (dict(dt=0.02, control_rate_hz=100.0), "control_rate_hz"),
        (dict(seed=1, rng=1), "seed"),
        (dict(rng="one"), "rng"),
        (dict(initial_state=wn.vehicle.VehicleState(
            np.array([[0.0, np.nan, 1.0]]), np.zeros((1, 3)), np.array([[0.0, 0, 0, 1]]),
            np.zeros((1, 3)), np.full((1, 4), 500.0))), "initial_state"),
    ],
)
def test_bad_input(kwargs, name):
    p = wn.vehicle.params("hummingbird")
    args = dict(trajectory=make_trajectory("hover"), wind=ConstantWind((0, 0, 0)), duration=1.0)
    args.update(kwargs)
    with pytest.raises(ValueError, match=name):
        fly(p, **args)


def _hover_starts(n):
    xy = np.column_stack([np.arange(n) * 3.0, np.zeros(n), np.full(n, 2.0)])
    return xy


def test_one_vehicle_in_nan_wind_is_frozen_and_flagged_the_others_fly_on():
    p = wn.vehicle.params("hummingbird")
    model = Multirotor(p)
    starts = _hover_starts(8)
    starts[3, 1] = 100.0  # only vehicle 3 meets the NaN patch
    traj = make_trajectory("circle", start=(0, 0, 2), size=2.0, speed=1.5)
    wind = PatchyWind(t_bad=0.5, y_bad=50.0)
    log = fly(p, traj, wind, 1.5, batch=8, initial_state=model.hover_state(starts), rng=4)
    keep = [b for b in range(8) if b != 3]
    ref = fly(p, traj, wind, 1.5, batch=7, initial_state=model.hover_state(starts[keep]),
              sensors=NO_SENSORS)
    for name in ("position", "velocity", "attitude", "body_rates", "rotor_speeds",
                 "rotor_speed_cmd", "saturated", "wind", "power", "energy"):
        np.testing.assert_array_equal(getattr(log, name)[:, keep], getattr(ref, name), name)
    assert log.flags[3] & FlightStatus.NON_FINITE
    assert list(log.finite) == [b != 3 for b in range(8)]
    assert all(not (f & FlightStatus.NON_FINITE) for b, f in enumerate(log.flags) if b != 3)
    # frozen at its last finite state from the step it met the NaN wind (t > 0.5 s)
    k = int(np.argmax(~np.isfinite(log.wind[:, 3, 0])))
    assert log.t[k] == pytest.approx(0.505)
    assert log.meta["non_finite_at_s"][3] == pytest.approx(0.505)
    assert [x is None for x in log.meta["non_finite_at_s"]] == [b != 3 for b in range(8)]
    assert np.all(np.isfinite(log.position))
    np.testing.assert_array_equal(log.position[k:, 3], np.broadcast_to(log.position[k, 3],
                                                                      log.position[k:, 3].shape))
    assert np.all(log.position[1:k, 3] != log.position[:k - 1, 3])  # it flew before
    # its sensor readings are NaN from then on, the others' finite
    imu = log.sensors["imu"]
    late = imu["t"] >= log.t[k] - 1e-12
    assert np.all(np.isnan(imu["accel"][late, 3])) and np.all(np.isfinite(imu["accel"][~late, 3]))
    assert np.all(np.isfinite(imu["accel"][:, keep]))


def test_a_frozen_vehicle_draws_no_more_energy():
    """From the step a vehicle's state stops being finite its power is NaN, as its sensors are,
    and its energy stays where it was; its frozen rotor speeds kept adding to it (audit,
    2026-12-05: 168.6 J at 3 s where the flight stopped at 56.2 J)."""
    p = wn.vehicle.params("hummingbird")
    starts = _hover_starts(2)
    starts[1, 1] = 100.0
    log = fly(p, make_trajectory("hover"), PatchyWind(t_bad=0.5, y_bad=50.0), 1.5, batch=2,
              initial_state=Multirotor(p).hover_state(starts), sensors=NO_SENSORS)
    k = int(np.argmax(~np.isfinite(log.wind[:, 1, 0])))
    assert np.all(np.isnan(log.power[k:, 1])) and np.all(np.isfinite(log.power[:k, 1]))
    assert np.all(log.energy[k:, 1] == log.energy[k, 1])
    assert log.t[k] == pytest.approx(0.505) and log.energy[k, 1] > 0.0
    assert np.all(np.isfinite(log.power[:, 0]))


@pytest.mark.parametrize("log_every", [1, 3, 7, 100])
def test_the_log_ends_at_the_flights_end_whatever_log_every(log_every):
    """10.3 s of hover at 200 Hz (2,060 steps): every log_every-th step and the last, so the
    log ends at 10.3 s and its energy is the hover power times 10.3 s (at log_every = 100 it
    ended at 10.0 s, 2.9 % short; audit, 2026-12-05)."""
    p = wn.vehicle.params("hummingbird")
    log = fly(p, make_trajectory("hover"), ConstantWind((0, 0, 0)), 10.3, sensors=NO_SENSORS,
              log_every=log_every)
    assert log.t[-1] == pytest.approx(10.3)
    assert np.all(np.diff(log.t) > 0) and np.diff(log.t)[:-1] == pytest.approx(log_every * 0.005)
    hover = p.n_rotors * p.k_m * p.hover_rotor_speed ** 3
    assert log.energy[-1, 0] == pytest.approx(hover * 10.3, rel=1e-3)


def test_all_vehicles_in_nan_wind_return_a_log_instead_of_raising():
    p = wn.vehicle.params("hummingbird")
    log = fly(p, make_trajectory("hover"), PatchyWind(t_bad=0.2, y_bad=-1e9), 0.5, batch=2,
              sensors=NO_SENSORS)
    assert not np.any(log.finite)
    assert log.meta["status"] == ["NON_FINITE", "NON_FINITE"]


def test_controller_and_default_sensor_rates_adapt_to_a_slow_physics_step():
    # dt = 0.02 s (50 Hz): the 100 Hz controller and 200/100 Hz default sensors cannot run
    # faster than the physics, so they run every step
    p = wn.vehicle.params("hummingbird")
    log = fly(p, make_trajectory("hover", start=(0, 0, 2)), ConstantWind((1, 0, 0)), 2.0,
              dt=0.02)
    assert log.meta["control_rate_hz"] == pytest.approx(50.0)
    assert log.meta["sensors"] == pytest.approx({"imu": 50.0, "odometry": 50.0,
                                                 "rotor_speeds": 50.0})
    np.testing.assert_allclose(np.diff(log.sensors["imu"]["t"]), 0.02)
    assert np.max(log.tracking_error[log.t > 1.5]) < 0.2
    # at dt = 0.003 s the default controller rate is the fastest below 100 Hz that fits
    log = fly(p, make_trajectory("hover"), ConstantWind((0, 0, 0)), 0.3, dt=0.003,
              sensors=NO_SENSORS)
    assert log.meta["control_rate_hz"] == pytest.approx(1 / 0.012)


def test_rng_and_deprecated_seed_give_the_same_noise():
    p = wn.vehicle.params("hummingbird")
    traj = make_trajectory("hover")
    a = fly(p, traj, ConstantWind((1, 0, 0)), 0.5, rng=5)
    with pytest.warns(DeprecationWarning, match="rng="):
        b = fly(p, traj, ConstantWind((1, 0, 0)), 0.5, seed=5)
    c = fly(p, traj, ConstantWind((1, 0, 0)), 0.5, rng=np.random.default_rng(5))
    np.testing.assert_array_equal(a.sensors["imu"]["accel"], b.sensors["imu"]["accel"])
    np.testing.assert_array_equal(a.sensors["imu"]["accel"], c.sensors["imu"]["accel"])
    assert a.meta["seed"] == 5 and c.meta["seed"] is None


def test_strong_wind_leaves_the_envelope_and_stopped_rotors_count_as_saturated():
    # issue 13: a Crazyflie hovering in 30 m/s of wind: translational lift exceeds the weight,
    # the controller commands 0 rad/s (its lower limit) and the vehicle still climbs
    p = wn.vehicle.params("crazyflie_brushless")
    log = fly(p, make_trajectory("hover", start=(0, 0, 2)), ConstantWind((30.0, 0, 0)), 1.0,
              sensors=NO_SENSORS)
    at_min = log.rotor_speed_cmd <= p.rotor_speed_min
    assert np.any(at_min)
    assert np.all(log.saturated[at_min])
    assert log.saturation_fraction > 0
    assert log.meta["envelope_fraction"] > 0
    assert log.meta["envelope_fraction_per_vehicle"][0] == log.meta["envelope_fraction"]
    assert log.flags[0] == FlightStatus.SATURATED | FlightStatus.OUTSIDE_ENVELOPE
    calm = fly(p, make_trajectory("hover", start=(0, 0, 2)), ConstantWind((1.0, 0, 0)), 1.0,
               sensors=NO_SENSORS)
    assert calm.meta["envelope_fraction"] == 0.0 and calm.flags == [FlightStatus.OK]


class CountingSensor:
    """A custom sensor: the true altitude, through the common protocol."""

    name = "altimeter"
    rate_hz = 50.0

    def sample(self, truth, rng):
        return {"altitude": truth.position[..., 2] + rng.normal(0.0, 0.0, truth.t.shape)[:, None]}


def test_custom_sensors_follow_the_protocol():
    p = wn.vehicle.params("hummingbird")
    suite = SensorSuite(None, Odometry(rate_hz=100.0), None, extra=(CountingSensor(),))
    log = fly(p, make_trajectory("hover", start=(0, 0, 3)), ConstantWind((0, 0, 0)), 1.0,
              sensors=suite)
    alt = log.sensors["altimeter"]
    np.testing.assert_allclose(np.diff(alt["t"]), 0.02)
    np.testing.assert_allclose(alt["altitude"], 3.0, atol=1e-9)
    same = fly(p, make_trajectory("hover", start=(0, 0, 3)), ConstantWind((0, 0, 0)), 1.0,
               sensors=[Odometry(rate_hz=100.0), CountingSensor()])
    np.testing.assert_array_equal(same.sensors["odometry"]["position"],
                                  log.sensors["odometry"]["position"])
    with pytest.raises(ValueError, match="extra"):
        SensorSuite(extra=(object(),))
    with pytest.raises(ValueError, match="extra"):
        SensorSuite(extra=(CountingSensor(), CountingSensor()))


def test_corrupt_logs_raise_value_error_naming_the_file(tmp_path):
    p = wn.vehicle.params("hummingbird")
    log = fly(p, make_trajectory("hover"), ConstantWind((1, 0, 0)), 0.5, rng=3)
    path = log.save(tmp_path / "flight.npz")
    raw = path.read_bytes()
    back = FlightLog.load(path)
    np.testing.assert_array_equal(back.status, log.status)
    # truncated
    cut = tmp_path / "truncated.npz"
    cut.write_bytes(raw[: len(raw) // 2])
    with pytest.raises(ValueError, match="truncated.npz"):
        FlightLog.load(cut)
    # bytes flipped in the middle (compressed data: a CRC or zlib error)
    flipped = bytearray(raw)
    mid = len(raw) // 2
    flipped[mid:mid + 16] = bytes(b ^ 0xFF for b in flipped[mid:mid + 16])
    (tmp_path / "flipped.npz").write_bytes(bytes(flipped))
    with pytest.raises(ValueError, match="flipped.npz"):
        FlightLog.load(tmp_path / "flipped.npz")
    # a text file: NumPy read it as a pickle and advised allow_pickle, for a corrupt file
    (tmp_path / "text.npz").write_text("garbage")
    with pytest.raises(ValueError, match="text.npz' \\(not an .npz file") as info:
        FlightLog.load(tmp_path / "text.npz")
    assert "pickle" not in str(info.value)
    # an array of the wrong shape
    arrays = dict(np.load(path))
    arrays["velocity"] = arrays["velocity"][:, :, :2]
    np.savez_compressed(tmp_path / "shape.npz", **arrays)
    with pytest.raises(ValueError, match="shape.npz.*'velocity'"):
        FlightLog.load(tmp_path / "shape.npz")
    arrays = dict(np.load(path))
    arrays["sensors/imu/accel"] = arrays["sensors/imu/accel"][:-1]
    np.savez_compressed(tmp_path / "sensor.npz", **arrays)
    with pytest.raises(ValueError, match="sensors/imu/accel"):
        FlightLog.load(tmp_path / "sensor.npz")
    # and an in-memory log with a wrong shape is not saved
    log.power = log.power[:-1]
    with pytest.raises(ValueError, match="'power'"):
        log.save(tmp_path / "never.npz")
    assert not (tmp_path / "never.npz").exists()


def test_logs_without_status_get_it_derived():
    p = wn.vehicle.params("crazyflie_brushless")
    log = fly(p, wn.sim.Line((0, 0, 0), (15, 0, 0), duration=1.5), ConstantWind((0, 0, 0)),
              2.0, sensors=NO_SENSORS)
    arrays = {k: getattr(log, k) for k in FlightLog._ARRAYS if k != "status"}
    old = FlightLog(**arrays)
    assert old.flags == [FlightStatus.SATURATED]


@pytest.mark.parametrize(
    "kind, kwargs, name",
    [("line", dict(speed=0.0), "speed"), ("waypoints", dict(speed=0.0), "speed"),
     ("line", dict(speed=-1.0), "speed"), ("circle", dict(size=0.0), "size"),
     ("line", dict(size=np.nan), "size"), ("hover", dict(start=(0, 0)), "start"),
     ("spiral", {}, "trajectory")],
)
def test_make_trajectory_rejects_bad_parameters_by_name(kind, kwargs, name):
    with pytest.raises(ValueError, match=f"'{name}'"):
        make_trajectory(kind, **kwargs)


def test_zero_speed_circle_is_a_hover():
    traj = make_trajectory("circle", start=(1.0, 2.0, 3.0), size=2.0, speed=0.0)
    for t in (0.0, 1.0, 5.0):
        np.testing.assert_array_equal(traj(t).position, [1.0, 2.0, 3.0])
        np.testing.assert_array_equal(traj(t).velocity, 0.0)


@pytest.mark.parametrize("yaw", [0.3, np.pi / 2, -2.5])
def test_the_default_start_holds_the_reference_heading(yaw):
    """The default start was level at yaw 0 whatever the reference's heading: a still-air
    hover at yaw 0.3 rad began with a yaw step (two rotors at 3 rad/s, two at 1,272) and was
    flagged SATURATED | OUTSIDE_ENVELOPE for 4 % of the flight, 27 % at pi/2 (fuzz audit)."""
    p = wn.vehicle.params("hummingbird")
    log = fly(p, wn.sim.Hover((0.0, 0.0, 1.0), yaw=yaw), ConstantWind((0.0, 0.0, 0.0)), 2.0,
              sensors=NO_SENSORS)
    q = log.attitude[0, 0]
    assert np.allclose(q, [0.0, 0.0, np.sin(yaw / 2), np.cos(yaw / 2)], atol=1e-12)
    assert log.flags == [FlightStatus.OK] and log.meta["envelope_fraction"] == 0.0
    assert np.abs(log.position[:, 0] - [0.0, 0.0, 1.0]).max() < 1e-6


def test_a_flight_past_an_unsteady_wind_s_frames_says_the_wind_is_held():
    """An unsteady urban wind is held at its last frame after it (documented); a 600 s flight
    in a 100 s flow flew its last 500 s in a steady wind and said nothing (long-run audit)."""
    import warnings

    from windnav.wind import GriddedWind

    x = y = np.linspace(-50.0, 50.0, 11)
    t = np.linspace(0.0, 2.0, 5)
    u = np.broadcast_to(t[:, None, None], (5, 11, 11))  # u grows from 0 to 2 m/s
    wind = GriddedWind(x, y, u, np.zeros_like(u), t)
    p = wn.vehicle.params("hummingbird")
    hover = make_trajectory("hover", start=(0, 0, 1))
    with pytest.warns(UserWarning, match=r"frames end at 2 s and the flight lasts 3 s: for its "
                                         r"last 1 s the wind is held at its last frame"):
        log = fly(p, hover, wind, 3.0, sensors=NO_SENSORS)
    assert log.meta["wind_held_after_s"] == 2.0
    np.testing.assert_array_equal(log.wind[log.t > 2.0, 0, 0], 2.0)  # held
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        inside = fly(p, hover, wind, 2.0, sensors=NO_SENSORS)
    assert inside.meta["wind_held_after_s"] is None


def test_a_log_whose_times_do_not_increase_is_refused(tmp_path):
    """sysid aero interpolates a log's sensors on their times: IMU times that ran backwards
    were fitted into k_d -7.5 % and k_h +10 %, silently (files audit)."""
    p = wn.vehicle.params("hummingbird")
    log = fly(p, make_trajectory("hover", start=(0, 0, 1)), ConstantWind((1.0, 0, 0)), 0.5)
    log.save(tmp_path / "a.npz")
    good = dict(np.load(tmp_path / "a.npz"))
    for key, bad, why in (
            ("sensors/imu/t", good["sensors/imu/t"][::-1].copy(), "from 0.5 to 0.0"),
            ("t", np.r_[good["t"][:-1], good["t"][-3]], "'t' array"),
            ("t", np.where(np.arange(good["t"].size) == 3, np.nan, good["t"]), "'t' array"),
            ("sensors/imu/t", good["sensors/imu/t"].astype(str), "<U")):
        np.savez(tmp_path / "b.npz", **{**good, key: bad})
        with pytest.raises(ValueError, match=rf"must hold finite, strictly increasing times.*{why}"
                           if why.startswith("from") else "must hold finite, strictly increasing"):
            FlightLog.load(tmp_path / "b.npz")
    assert FlightLog.load(tmp_path / "a.npz").t.size == good["t"].size


def test_a_vehicle_the_controller_cannot_steer_in_yaw_is_refused():
    """Fixed rotors whose allocation matrix has rank < 4 cannot set thrust, roll, pitch and yaw
    apart: the pseudo-inverse's split let a tricopter spin up to 6.5 rad/s in 10 s of hover,
    unflagged. A pentacopter (rank 4, unequal hover speeds) still holds its hover."""
    def ring(n, dirs):
        a = np.deg2rad(90.0 + 360.0 / n * np.arange(n))
        pos = 0.17 * np.stack([np.cos(a), np.sin(a), 0.0 * a], axis=1)
        return wn.vehicle.params("hummingbird", rotor_positions=pos,
                                 rotor_directions=np.asarray(dirs, float))

    still = ConstantWind(np.zeros(3))
    for bad, rank in ((ring(3, [1, -1, 1]), 3), (ring(4, [1, 1, 1, 1]), 3),
                      (wn.vehicle.params("hummingbird", k_m=0.0), 3)):
        with pytest.raises(ValueError, match=f"'params' parameter of SE3Controller.*rank {rank}"):
            fly(bad, make_trajectory("hover"), still, duration=1.0)
    with pytest.raises(ValueError, match="vehicle 1 of the batch"):
        SE3Controller([wn.vehicle.params("hummingbird"), ring(3, [1, -1, 1])])
    log = fly(ring(5, [1, -1, 1, -1, 1]), make_trajectory("hover"), still, duration=5.0)
    assert np.abs(log.position[-1, 0]).max() < 1e-6
    assert np.abs(log.body_rates[-1, 0]).max() < 1e-6 and log.status[0] == 0


def test_make_trajectory_s_unused_duration_is_deprecated():
    """``duration`` was accepted and ignored (API audit, 2026-12-05): it now warns."""
    with pytest.warns(DeprecationWarning, match="'duration' is deprecated"):
        line = make_trajectory("line", size=10.0, speed=2.0, duration=99.0)
    assert line.duration == pytest.approx(1.875 * 10.0 / 2.0)


def test_a_flight_too_large_for_memory_is_refused_before_it_starts(monkeypatch):
    """``fly`` kept every sensor tick's state and failed with a bare MemoryError after the
    whole flight, or was killed, when they did not fit (scale audit, 2026-12-05: 10,000
    vehicles for 2 s took 3.94 GB). Its estimate is checked against the memory limit first."""
    from windnav.flow import MemoryEstimateError
    from windnav.sim.runner import estimate_fly_memory

    monkeypatch.setenv("WINDNAV_MEMORY_LIMIT", "50MB")
    p = wn.vehicle.params("hummingbird")
    with pytest.raises(MemoryEstimateError, match=r"fly: the log .* of 2000 vehicle\(s\) for "
                                                  r"2 s .* WINDNAV_MEMORY_LIMIT"):
        fly(p, make_trajectory("hover"), ConstantWind((1.0, 0.0, 0.0)), 2.0, batch=2000)
    fly(p, make_trajectory("hover"), ConstantWind((1.0, 0.0, 0.0)), 0.2, batch=10)  # fits
    # the estimate grows with vehicles and steps and drops without sensors
    one = estimate_fly_memory(1, 4, 201, 201, 3)
    assert estimate_fly_memory(1000, 4, 201, 201, 3) == pytest.approx(1000 * one)
    assert estimate_fly_memory(1, 4, 201, 201, 0) < one / 2


def test_a_flight_of_too_many_steps_is_refused_before_its_log_is_allocated(monkeypatch):
    """The log's step indices and arrays were allocated before the memory check: ``fly --dt
    1e-9 --duration 1`` took 7.9 GB and then failed on a 127 GiB array (side-effects audit,
    thirty-seventh session). The check now comes first; here 1e8 steps, whose old allocation
    alone was 0.8 GB of step indices, are refused with no large allocation."""
    import tracemalloc

    from windnav.flow import MemoryEstimateError

    monkeypatch.setenv("WINDNAV_MEMORY_LIMIT", "50MB")
    p = wn.vehicle.params("hummingbird")
    tracemalloc.start()
    try:
        with pytest.raises(MemoryEstimateError, match=r"100000000 steps"):
            fly(p, make_trajectory("hover"), ConstantWind((1.0, 0.0, 0.0)), 1.0, dt=1e-8,
                sensors=())
        _, peak = tracemalloc.get_traced_memory()
    finally:
        tracemalloc.stop()
    assert peak < 50e6
