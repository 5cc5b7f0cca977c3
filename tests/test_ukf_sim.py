"""The Wind UKF on simulated flights: accuracy in Dryden wind, alignment, purity, consistency."""

import numpy as np
import pytest
from scipy import stats
from scipy.spatial.transform import Rotation

import windnav as wn
from windnav.estimate.flight import filter_inputs, run_wind_ukf
from windnav.experiments.ukf_montecarlo import (
    FILTER_Q,
    FILTER_R,
    MIL_VERTICAL_SIGMA_RATIO,
    TUNING,
    sensor_suite,
)
from windnav.sensors.models import IMU, Odometry, RotorSpeedSensor, SensorSuite

P_HB = wn.vehicle.params("hummingbird")


def circle_flight(seed, duration=30.0, sigma=(1.0, 1.0, 1.0), sensors=None, params=P_HB):
    wind = wn.wind.DrydenWind(mean=(2.0, 1.0, 0.0), sigma=sigma, seed=seed)
    traj = wn.sim.make_trajectory("circle", start=(0.0, 0.0, 10.0), size=3.0, speed=2.0)
    return wn.sim.fly(params, traj, wind, duration, dt=0.005,
                      sensors=sensors or sensor_suite(100.0), rng=seed)


@pytest.fixture(scope="module")
def logs():
    return [circle_flight(seed) for seed in range(3)]


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_hummingbird_in_moderate_dryden_wind_rmse_below_0_3(logs, seed):
    """Default Hummingbird, 30 s circle, mean wind (2, 1, 0) m/s, gusts of 1 m/s on every
    axis, 100 Hz sensors: 3D RMSE after 2 s <= 0.3 m/s."""
    track = run_wind_ukf(logs[seed], P_HB, q=FILTER_Q, r=FILTER_R)
    assert track.rmse_after(2.0) <= 0.3
    assert track.repairs == 0
    # the wind is estimated, not just its mean: error well below the gusts' own spread
    assert track.rmse_after(2.0) < 0.5 * np.sqrt(np.mean(np.sum(
        (track.wind_true - track.wind_true.mean(0)) ** 2, axis=1)))


def test_reported_covariance_is_not_overconfident(logs):
    """Normalised estimation error squared against its chi-square distribution.

    A consistent filter's NEES is chi2(3) per sample. The three flights give 3 x 2801 samples
    after 2 s, correlated over a few steps (integrated autocorrelation of the whitened error
    ~4 steps at 100 Hz); counting one independent sample per 0.5 s, K = 3 x 56 = 168, the mean
    NEES is chi2(3K) / K and exceeds chi2.ppf(0.999, 504) / 168 = 3.62 with probability
    0.001: above it the filter claims accuracy it does not have. The lower tail is not a
    chi-square bound here: the tuning inflates R and Q to cover the force model's errors
    (FILTER_R: 0.1 m/s^2 against the IMU's 0.028), so the covariance over-bounds the error
    (mean NEES ~1.3); the test only bounds that inflation to a covariance at most 3 times the
    error's (NEES > 1). ``test_ukf_wind`` tests both tails where the truth follows the model.
    """
    nees = np.mean([run_wind_ukf(log, P_HB, q=FILTER_Q, r=FILTER_R).nees(2.0) for log in logs])
    K = 3 * 56
    assert 1.0 < nees < stats.chi2.ppf(0.999, 3 * K) / K


def test_noisy_rotorpy_sensors_stay_near_the_thesis_level():
    """RotorPy's default sensors (accelerometer ~10x noisier), MIL-F-8785C vertical gusts."""
    sig = (1.0, 1.0, MIL_VERTICAL_SIGMA_RATIO)
    q, r = TUNING["rotorpy"]
    rmse = [run_wind_ukf(circle_flight(s, 20.0, sig, sensor_suite(100.0, "rotorpy")), P_HB,
                         q=q, r=r).rmse_after(2.0) for s in (0, 1)]
    assert max(rmse) < 0.4


def test_wrong_drag_coefficients_bias_the_estimate(logs):
    """Calibration matters: a filter believing half the rotor drag estimates worse."""
    good = run_wind_ukf(logs[0], P_HB, q=FILTER_Q, r=FILTER_R).rmse_after(2.0)
    bad = run_wind_ukf(logs[0], P_HB.replace(k_d=0.5 * P_HB.k_d), q=FILTER_Q,
                       r=FILTER_R).rmse_after(2.0)
    assert bad > 2.0 * good


def test_still_air_hover_estimates_zero_wind():
    log = wn.sim.fly(P_HB, wn.sim.Hover((0.0, 0.0, 5.0)), wn.wind.ConstantWind((0, 0, 0)), 8.0,
                     sensors=sensor_suite(100.0), rng=3)
    track = run_wind_ukf(log, P_HB, q=FILTER_Q, r=FILTER_R)
    assert np.all(track.wind_true == 0.0)
    assert track.rmse_after(2.0) < 0.1


def test_a_diverging_filter_says_when_and_names_the_flights_status():
    # `windnav fly --dt 0.2 --conditions windnav`: the controller at 5 Hz saturates the rotors,
    # the measurements leave the filter's model, and it diverged with a bare FloatingPointError
    from windnav.estimate import FilterDivergedError
    from windnav.experiments.flight import wind_estimate

    log = wn.sim.fly(P_HB, wn.sim.Hover((0.0, 0.0, 5.0)), wn.wind.ConstantWind((2, 0, 0)), 5.0,
                     dt=0.2, rng=3)
    assert "SATURATED" in str(log.meta["status"])
    with pytest.raises(FilterDivergedError, match=r"diverged at t = [0-9.]+ s of the log "
                                                   r"\(vehicle 0\), whose flight status is"):
        run_wind_ukf(log, P_HB, conditions="windnav")
    summary = wind_estimate(log, P_HB, "windnav", 5.0)  # fly keeps the flight and says why
    assert summary["wind_rmse_m_s"] is None
    assert "diverged" in summary["wind_estimate_error"]
    assert issubclass(FilterDivergedError, FloatingPointError)


def test_inputs_are_aligned_with_the_command_held_over_each_step(logs):
    log = logs[0]
    inp = filter_inputs(log, P_HB)
    assert inp["dt"] == pytest.approx(0.01)
    k = 137
    tk = inp["t"][k]
    i_prev = np.flatnonzero(np.isclose(log.t, tk - 0.01))[0]
    np.testing.assert_array_equal(inp["u"][k], np.clip(log.rotor_speed_cmd[i_prev, 0], 0, 1500))
    j = np.flatnonzero(np.isclose(log.sensors["rotor_speeds"]["t"], tk))[0]
    rs = log.sensors["rotor_speeds"]["cmd"]
    np.testing.assert_array_equal(inp["rotor_speeds"][k], rs[j - 1, 0])
    R_meas = Rotation.from_euler("ZYX", inp["odom"][k, 3:]).as_matrix()
    R_ref = Rotation.from_quat(log.sensors["odometry"]["attitude"][j, 0]).as_matrix()
    np.testing.assert_allclose(R_meas, R_ref, atol=1e-12)
    np.testing.assert_array_equal(inp["accel"][k], log.sensors["imu"]["accel"][j, 0])
    np.testing.assert_array_equal(inp["wind_true"][k], log.wind[np.isclose(log.t, tk), 0][0])


def test_run_is_a_pure_function_of_the_log(logs):
    log = logs[1]
    before = log.sensors["imu"]["accel"].copy()
    a = run_wind_ukf(log, P_HB, q=FILTER_Q, r=FILTER_R)
    b = run_wind_ukf(log, P_HB, q=FILTER_Q, r=FILTER_R)
    np.testing.assert_array_equal(a.wind_est, b.wind_est)
    np.testing.assert_array_equal(a["wind_cov"], b.wind_cov)
    np.testing.assert_array_equal(log.sensors["imu"]["accel"], before)


def test_multi_rate_sensors_step_on_the_fastest_grid():
    """IMU at 200 Hz, odometry and rotor speeds at 100 Hz: the filter runs at 200 Hz."""
    sensors = SensorSuite(IMU(rate_hz=200), Odometry(rate_hz=100), RotorSpeedSensor(rate_hz=100))
    log = circle_flight(4, duration=12.0, sensors=sensors)
    track = run_wind_ukf(log, P_HB, q=FILTER_Q, r=FILTER_R)
    assert np.diff(track.t) == pytest.approx(0.005)
    assert track.rmse_after(2.0) < 0.3


def test_bad_input_is_named(logs):
    log = logs[0]
    with pytest.raises(ValueError, match="params_filter"):
        run_wind_ukf(log, "hummingbird")
    with pytest.raises(ValueError, match="vehicle"):
        run_wind_ukf(log, P_HB, vehicle=3)
    for v in (0.7, np.nan):  # 0.7 was read as 0
        with pytest.raises(ValueError, match="'vehicle' parameter of filter_inputs must be an "
                                             "integer"):
            run_wind_ukf(log, P_HB, vehicle=v)
    with pytest.raises(ValueError, match="settle_s"):
        run_wind_ukf(log, P_HB).rmse_after(100.0)
    with pytest.raises(ValueError, match="imu"):
        run_wind_ukf(log, P_HB, sensors=("odometry",))
    # no finite odometry sample: an IndexError before (API audit, 2026-12-05)
    import copy

    blind = copy.deepcopy(log)
    blind.sensors["odometry"]["velocity"][:] = np.nan
    with pytest.raises(ValueError, match="'log' parameter of run_wind_ukf must hold at least "
                                         "one finite odometry sample"):
        run_wind_ukf(blind, P_HB)


def test_fly_exits_1_when_the_wind_estimate_it_was_asked_for_diverged(tmp_path, capsys):
    """``fly --conditions`` on a finite flight whose filter diverged printed a note, a null
    RMSE and exited 0: the product asked for was missing and a script saw success (leftover
    of 2026-12-06). Now an ``error:`` line and exit status 1, the files still written."""
    import json

    from windnav import cli

    out = tmp_path / "fly"
    assert cli.main(["fly", "--trajectory", "hover", "--wind", "constant", "--wind-mean", "2",
                     "0", "0", "--duration", "5", "--dt", "0.2", "--conditions", "windnav",
                     "--seed", "3", "--no-plots", "--no-progress", "--out", str(out)]) == 1
    assert "error: no wind estimate: The process model" in capsys.readouterr().err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["non_finite_from_s"] is None and summary["wind_rmse_m_s"] is None
    assert summary["energy_J"] > 0
    assert summary["rotor_energy_J"] == summary["energy_J"]   # navigate's name for it
