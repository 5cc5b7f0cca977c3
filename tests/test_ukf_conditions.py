"""Wind UKF conditions: RotorPy's sensor arithmetic, the presets, the hardware's acceleration
chain and PWM rotor speeds, RotorPy's gusts through the adapter, and small studies under each."""

# RotorPy, the reference here, draws from NumPy's global random state: the tests seed it
# ruff: noqa: NPY002

import json
import math
import pickle

import numpy as np
import pytest

import windnav as wn
import windnav.experiments.ukf_montecarlo as mc
from windnav.cli import main
from windnav.estimate import CONDITIONS, OdometryAccel, UKFConditions, WindUKF, ukf_conditions
from windnav.estimate.hardware import odometry_specific_force
from windnav.experiments.ukf_conditions import (
    believed_params,
    pwm_rotor_speed_map,
    rotorpy_dryden,
)
from windnav.sensors import presets
from windnav.sysid import PWMMotorModel
from windnav.vehicle.params import GRAVITY
from windnav.vehicle.rotation import euler_zyx_to_matrix
from windnav.wind import FromRotorPy

P_HB = wn.vehicle.params("hummingbird")


def _rotorpy_imu_noise(accel_density, gyro_density, rate_hz, n, seed):
    """Noise of RotorPy's own ``Imu`` at rest, level: (n, 3) accel and gyro minus the truth."""
    from rotorpy.sensors.imu import Imu

    imu = Imu(accelerometer_params={"initial_bias": np.zeros(3),
                                    "noise_density": accel_density * np.ones(3),
                                    "random_walk": np.zeros(3)},
              gyroscope_params={"initial_bias": np.zeros(3),
                                "noise_density": gyro_density * np.ones(3),
                                "random_walk": np.zeros(3)},
              sampling_rate=rate_hz)
    state = {"x": np.zeros(3), "v": np.zeros(3), "q": np.array([0.0, 0.0, 0.0, 1.0]),
             "w": np.zeros(3)}
    acc = {"vdot": np.zeros(3), "wdot": np.zeros(3)}
    saved = np.random.get_state()
    np.random.seed(seed)
    try:
        out = [imu.measurement(state, acc, with_noise=True) for _ in range(n)]
    finally:
        np.random.set_state(saved)
    accel = np.array([o["accel"] for o in out]) - [0.0, 0.0, 9.81]
    gyro = np.array([o["gyro"] for o in out])
    return accel, gyro


@pytest.mark.parametrize("density", [presets.ROTORPY_ACCEL_DENSITY,
                                     presets.ROTORPY_ACCEL_DENSITY_NUMPY],
                         ids=["0.38^2", "0.038^2"])
@pytest.mark.parametrize("rate_hz", [100.0, 200.0])
def test_rotorpy_imu_noise_matches_rotorpys_imu(density, rate_hz):
    n = 6000
    ref_a, ref_g = _rotorpy_imu_noise(density, presets.ROTORPY_GYRO_DENSITY, rate_hz, n, 4)
    imu = presets.rotorpy_imu(rate_hz, accel_noise_density=density)
    zeros = np.zeros((n, 1, 3))
    ours_a, ours_g, bias = imu.measure(zeros, zeros, np.random.default_rng(5))
    assert np.all(bias == 0.0)  # no bias walk, as RotorPy's defaults
    for ours, ref in ((ours_a[:, 0], ref_a), (ours_g[:, 0], ref_g)):
        assert np.abs(ref.mean(0)).max() < 4 * ref.std() / math.sqrt(n)  # zero-mean noise
        np.testing.assert_allclose(ours.std(0), ref.std(0), rtol=0.05)
    # and the closed form: sqrt(rate / 2) times the (already squared) density
    assert imu.accel_std == pytest.approx(math.sqrt(rate_hz / 2) * density, rel=1e-12)
    if rate_hz == 100.0:
        expected = 1.021 if density > 0.1 else 0.01021
        assert imu.accel_std == pytest.approx(expected, rel=1e-3)


def test_rotorpy_mocap_noise_matches_rotorpys_motion_capture():
    from rotorpy.sensors.external_mocap import MotionCapture

    n, rate = 4000, 100.0
    ref = MotionCapture(sampling_rate=rate)
    state = {"x": np.zeros(3), "v": np.zeros(3), "q": np.array([0.0, 0.0, 0.0, 1.0]),
             "w": np.zeros(3)}
    saved = np.random.get_state()
    np.random.seed(6)
    try:
        meas = [ref.measurement(state, with_noise=True) for _ in range(n)]
    finally:
        np.random.set_state(saved)
    od = presets.rotorpy_mocap(rate)
    p, v, _ = od.measure(np.zeros((n, 3)), np.zeros((n, 3)),
                         np.tile([0.0, 0.0, 0.0, 1.0], (n, 1)), np.random.default_rng(7))
    np.testing.assert_allclose(p.std(0), np.std([m["x"] for m in meas], axis=0), rtol=0.05)
    np.testing.assert_allclose(v.std(0), np.std([m["v"] for m in meas], axis=0), rtol=0.05)


def test_presets_table_and_what_each_changes():
    assert {"windnav", "thesis", "thesis-0.038", "hardware"} <= set(CONDITIONS)
    suites = {name: c.sensor_suite(100.0) for name, c in CONDITIONS.items()}
    assert suites["windnav"].imu.accel_std == pytest.approx(0.028)
    assert suites["thesis"].imu.accel_std == pytest.approx(math.sqrt(50) * 0.38**2)
    assert suites["thesis-0.038"].imu.accel_std == pytest.approx(math.sqrt(50) * 0.038**2)
    assert suites["thesis"].rotor_speeds.noise_std > 0 == suites["windnav"].rotor_speeds.noise_std
    thesis, hw = CONDITIONS["thesis"], CONDITIONS["hardware"]
    assert (thesis.alpha, thesis.beta, thesis.kappa) == (0.001, 2.0, -1.0)
    assert not thesis.parasitic_drag and CONDITIONS["windnav"].parasitic_drag
    # the filter's R follows the sensors: the noisier accelerometer is trusted less
    assert thesis.r["accel"] > 1.0 > CONDITIONS["thesis-0.038"].r["accel"]
    assert isinstance(hw.accel, OdometryAccel) and hw.r["accel"] == pytest.approx(1.9)
    assert hw.filter_sensors == ("imu", "odometry") and hw.rotor_speeds == "pwm"
    assert ukf_conditions(None) is CONDITIONS["windnav"] and ukf_conditions(hw) is hw
    assert pickle.loads(pickle.dumps(hw)) == hw and hash(pickle.loads(pickle.dumps(hw))) == hash(hw)
    json.dumps(hw.to_dict())
    with pytest.raises(ValueError, match="'conditions'"):
        ukf_conditions("perfect")
    with pytest.raises(ValueError, match="'kv_error'"):
        UKFConditions("x", kv_error=1.5)
    with pytest.raises(ValueError, match="'sensors'"):
        UKFConditions("x", sensors="nope")


def test_windukf_takes_the_preset_and_explicit_arguments_win():
    u = WindUKF(P_HB, conditions="thesis")
    assert u.ukf.weights.alpha == 0.001 and u.ukf.weights.kappa == -1.0
    assert u.wind_frame == "body" and not u.accel_from_odometry
    assert np.sqrt(u.R["accel"][0, 0]) == pytest.approx(CONDITIONS["thesis"].r["accel"])
    v = WindUKF(P_HB, conditions="thesis", alpha=1.0, wind_frame="world", r={"accel": 0.5})
    assert v.ukf.weights.alpha == 1.0 and v.wind_frame == "world"
    assert np.sqrt(v.R["accel"][0, 0]) == pytest.approx(0.5)
    assert np.sqrt(v.R["rotor_speeds"][0, 0]) == pytest.approx(10.0)  # the preset's, kept
    w = WindUKF(P_HB)  # no preset: the filter's own defaults, unchanged
    assert w.ukf.weights.alpha == 1.0 and w.wind_frame == "world" and w.odometry_accel is None
    assert WindUKF(P_HB, conditions="hardware").odometry_accel == OdometryAccel()


def test_odometry_accel_settles_on_the_specific_force_and_low_passes_a_step():
    chain = OdometryAccel()
    dt, T = 0.01, 400
    t = np.arange(T) * dt
    a_world = np.array([1.0, -0.5, 0.3])
    euler = np.tile([0.3, 0.1, -0.2], (T, 1))
    v = t[:, None] * a_world
    out = odometry_specific_force(t, v, euler, chain)
    R = euler_zyx_to_matrix(euler[:1])[0]
    np.testing.assert_allclose(out[0], R.T @ [0.0, 0.0, GRAVITY], atol=1e-12)  # hover start
    target = R.T @ (a_world + [0.0, 0.0, GRAVITY])
    np.testing.assert_allclose(out[-1], target, atol=1e-5)
    # first-order response: after tau the step has covered 1 - (tau / (tau + dt))^(tau / dt)
    k = int(round(chain.tau_s / dt))
    frac = (out[k] - out[0]) / (target - out[0])
    np.testing.assert_allclose(frac, 1 - (chain.tau_s / (chain.tau_s + dt)) ** k, rtol=1e-9)
    # the clamp: a 100 m/s^2 jump enters as 15 m/s^2 (level, along x)
    jump = odometry_specific_force([0.0, dt], [[0, 0, 0], [1.0, 0, 0]], np.zeros((2, 3)),
                                   OdometryAccel(tau_s=0.0))
    assert jump[1, 0] == pytest.approx(15.0)


def test_windukf_runs_the_same_chain_online():
    """WindUKF's hardware mode fuses exactly what odometry_specific_force computes."""
    rng = np.random.default_rng(0)
    T, dt = 30, 0.01
    v = np.cumsum(rng.normal(0, 0.05, (T, 3)), axis=0)
    euler = 0.05 * rng.normal(size=(T, 3))
    expected = odometry_specific_force(np.arange(T) * dt, v, euler)
    ukf = WindUKF(P_HB, dt, accel_from_odometry=OdometryAccel(), r={"accel": 1.9})
    seen = []
    real = ukf.ukf.update

    def spy(meas, noise=None):
        seen.append(meas.get("accel"))
        return real(meas, noise)

    ukf.ukf.update = spy
    for k in range(T):
        ukf.step(np.full(4, P_HB.hover_rotor_speed), {"odom": np.r_[v[k], euler[k]]})
    assert seen[0] is None
    np.testing.assert_allclose(np.array(seen[1:]), expected[1:], atol=1e-12)


def test_pwm_chain_reads_back_the_command_scaled_by_the_kv_error():
    cmd = np.linspace(300.0, 900.0, 40).reshape(10, 4)
    exact = pwm_rotor_speed_map(0.0)(np.arange(10), cmd)
    # whole PWM counts: about 0.07 rad/s per count at these speeds
    np.testing.assert_allclose(exact, cmd, atol=0.2)
    off = pwm_rotor_speed_map(0.05)(np.arange(10), cmd)
    np.testing.assert_allclose(off / exact, 1.05, rtol=1e-12)
    motor = PWMMotorModel.thesis()
    assert np.all(np.round(motor.pwm(cmd, 3.9)) > motor.DZ)


def test_believed_params_follow_the_conditions():
    p, err = believed_params(P_HB, "windnav")
    assert p is P_HB and err == {}
    p, err = believed_params(P_HB, "thesis")
    assert (p.c_dx, p.c_dy, p.c_dz, p.k_d) == (0.0, 0.0, 0.0, P_HB.k_d) and err == {}
    a, err_a = believed_params(P_HB, "hardware", rng=3)
    b, err_b = believed_params(P_HB, "hardware", rng=3)
    assert err_a == err_b and set(err_a) == {"mass", "k_eta", "k_d", "k_z", "k_h", "tau_m"}
    for k, e in err_a.items():
        assert abs(e) <= 0.05 and getattr(a, k) == pytest.approx(getattr(P_HB, k) * (1 + e))


def test_rotorpy_gusts_through_the_adapter_are_rotorpys_and_reproducible():
    from rotorpy.wind.dryden_winds import DrydenGust

    mean, sigma = np.array([2.0, -1.0, 0.0]), np.array([30.0, 45.0, 60.0])
    w = rotorpy_dryden(mean, sigma, seed=11)
    before = np.random.get_state()[1].copy()
    late = w.velocity(3.004, np.zeros((2, 3)))  # queried out of order first
    assert np.array_equal(np.random.get_state()[1], before)  # the caller's global state kept
    series = np.array([w.velocity(k * 0.01, np.zeros(3))[0] for k in range(500)])
    np.testing.assert_array_equal(late, np.tile(series[300], (2, 1)))
    # the same numbers as RotorPy's own DrydenGust stepped from RandomState(11)
    ref = DrydenGust(dt=0.01, avg_wind=mean, sig_wind=sigma, altitude=2.0)
    saved = np.random.get_state()
    np.random.set_state(np.random.RandomState(11).get_state())
    try:
        direct = np.array([ref.update(0.0, np.zeros(3)) for _ in range(500)])
    finally:
        np.random.set_state(saved)
    np.testing.assert_allclose(series, direct, rtol=0, atol=1e-12)
    # held over each 10 ms step, and a function of the seed
    np.testing.assert_array_equal(w.velocity(1.005, np.zeros(3)), w.velocity(1.0, np.zeros(3)))
    other = rotorpy_dryden(mean, sigma, seed=12).velocity(3.0, np.zeros(3))
    assert not np.allclose(other, series[300])
    with pytest.raises(ValueError, match="'profile'"):
        FromRotorPy(object())


SHORT = dict(n_trials=2, seed=3, duration=(6.0, 6.0))


@pytest.fixture(scope="module")
def small_studies():
    return {c: mc.run_montecarlo(mc.MonteCarloConfig(conditions=c, **SHORT), backend="serial",
                                 progress=False)
            for c in ("thesis", "thesis-0.038", "hardware")}


def test_small_studies_under_each_preset(small_studies):
    for name, out in small_studies.items():
        assert out["failed"] == 0 and out["config"]["conditions"] == name
        assert all(t["conditions"] == name for t in out["trials"])
        for t in out["trials"]:
            assert t["rmse"] == pytest.approx(np.sqrt(np.sum(np.square(t["rmse_axes"]))))
            # the filter follows the gusts: error well below the wind's own spread
            assert 0 < t["rmse"] < 1.5
        json.dumps(out)
    thesis, low, hw = (small_studies[k] for k in ("thesis", "thesis-0.038", "hardware"))
    # same vehicles and gusts, 100x less accelerometer noise: a clearly smaller error
    for a, b in zip(low["trials"], thesis["trials"], strict=True):
        assert a["sigma"] == b["sigma"] and a["rmse"] < 0.5 * b["rmse"]
    cfg = thesis["config"]
    assert cfg["wind_model"] == "rotorpy" and cfg["vertical_sigma_ratio"] == 1.0
    assert all(30.0 <= t["sigma"][0] <= 60.0 for t in thesis["trials"])
    for t in thesis["trials"]:
        assert t["fitted"]["c_dx"] == 0.0 and t["kv_error"] is None  # linear drag fit only
    for t in hw["trials"]:
        assert t["fitted"] is None and abs(t["kv_error"]) <= 0.05
        assert max(abs(e) for e in t["parameter_errors"].values()) <= 0.05


def test_config_resolves_the_preset_and_refuses_mixtures():
    cfg = mc.MonteCarloConfig(conditions="thesis")
    assert cfg.sensor_noise == "thesis" and cfg.wind_frame == "body"
    assert cfg.gust_sigma == (30.0, 60.0) and cfg.r["rotor_speeds"] == 10.0
    legacy = mc.MonteCarloConfig(sensor_noise="rotorpy")
    assert legacy.q == {"wind": 0.7} and legacy.r == {"accel": 0.3}  # the earlier study
    assert mc.MonteCarloConfig().gust_sigma == (1.0, 2.0)
    with pytest.raises(ValueError, match="sensor_noise"):
        mc.MonteCarloConfig(conditions="thesis", sensor_noise="rotorpy")
    with pytest.raises(ValueError, match="'conditions'"):
        mc.MonteCarloConfig(conditions="kind")


def test_command_takes_the_conditions(tmp_path, monkeypatch, capsys):
    orig = mc.MonteCarloConfig

    def short_config(**kw):
        return orig(**{**kw, "duration": (4.0, 4.0)})

    monkeypatch.setattr(mc, "MonteCarloConfig", short_config)
    js = tmp_path / "hw.json"
    assert main(["ukf-montecarlo", "--conditions", "hardware", "--trials", "1", "--json",
                 str(js), "--backend", "serial", "--no-progress"]) == 0
    rec = json.loads(js.read_text())
    assert rec["config"]["conditions"] == "hardware" and rec["summary"]["n"] == 1
    assert "hardware conditions" in capsys.readouterr().out
    assert main(["ukf-montecarlo", "--conditions", "thesis", "--sensor-noise", "rotorpy",
                 "--trials", "1", "--backend", "serial"]) == 2
    assert "--sensor-noise" in capsys.readouterr().err


def test_fly_runs_the_filter_under_a_preset(tmp_path):
    rmse = {}
    for name in ("windnav", "thesis-0.038"):
        js = tmp_path / f"{name}.json"
        assert main(["fly", "--duration", "4", "--wind", "constant", "--conditions", name,
                     "--no-plots", "--out", str(tmp_path / name), "--json", str(js)]) == 0
        doc = json.loads(js.read_text())
        assert doc["conditions"] == name and len(doc["wind_rmse_axes_m_s"]) == 3
        rmse[name] = doc["wind_rmse_m_s"]
    # a constant 3.2 m/s wind: windnav's filter (parasitic drag calibrated in) finds it to a few
    # cm/s; the thesis's filter leaves out the Hummingbird's parasitic drag (c_dx = 5e-3, about
    # a tenth of its drag at 5 m/s airspeed) and errs by about that tenth of the airspeed
    assert 0 < rmse["windnav"] < 0.15 < rmse["thesis-0.038"] < 1.0


def test_fly_under_a_preset_draws_the_estimate_against_the_truth(tmp_path):
    """`fly --conditions` ran the filter but drew no figure of it: only the summary's RMSE
    (figures audit, 2026-12-05)."""
    assert main(["fly", "--duration", "3", "--wind", "dryden", "--conditions", "windnav",
                 "--out", str(tmp_path / "a")]) == 0
    assert (tmp_path / "a" / "flight_wind_estimate.png").is_file()
    assert main(["fly", "--duration", "3", "--out", str(tmp_path / "b")]) == 0
    assert not (tmp_path / "b" / "flight_wind_estimate.png").exists()  # no filter, no figure


@pytest.mark.parametrize("preset", ["thesis", "thesis-0.038"])
def test_the_rotorpy_presets_noise_follows_the_sensor_rate(preset):
    """The thesis presets' sensors draw a per-sample noise growing as sqrt(rate) (RotorPy's
    arithmetic), but the filter kept the 100 Hz R at every rate: at 200 Hz it believed 1.03
    m/s^2 where the accelerometer drew 1.44 (conventions audit, 2026-12-05). R is now the
    sensors' at the filter's rate, and at 100 Hz exactly the preset's."""
    cond = CONDITIONS[preset]
    at100 = WindUKF(P_HB, dt=0.01, conditions=preset)
    assert np.sqrt(at100.R["accel"][0, 0]) == cond.r["accel"]
    assert cond.filter_options(100.0)["r"] == dict(cond.r)
    assert cond.filter_options(1 / 0.009999999999999787)["r"] == dict(cond.r)  # grid rounding
    for rate in (50.0, 200.0):
        imu = cond.sensor_suite(rate).imu
        drawn = imu.accel_noise_density * math.sqrt(rate)  # per-sample std, m/s^2
        ukf = WindUKF(P_HB, dt=1.0 / rate, conditions=preset)
        assert np.sqrt(ukf.R["accel"][0, 0]) == pytest.approx(math.hypot(drawn, 0.1), rel=1e-12)
        odom = cond.sensor_suite(rate).odometry
        r = cond.filter_options(rate)["r"]
        assert r["odom_velocity"] / at100_std(cond, "odom_velocity") == pytest.approx(
            odom.velocity_std / cond.sensor_suite(100.0).odometry.velocity_std, rel=1e-12)
    # an accelerometer R the user set is theirs at any rate; other presets keep theirs
    mine = UKFConditions("mine", sensors=preset, r={"accel": 2.0})
    assert mine.filter_options(200.0)["r"]["accel"] == 2.0
    assert CONDITIONS["windnav"].filter_options(200.0)["r"] == dict(CONDITIONS["windnav"].r)


def at100_std(cond, key):
    from windnav.estimate import DEFAULT_R

    return cond.r.get(key, DEFAULT_R[key])
