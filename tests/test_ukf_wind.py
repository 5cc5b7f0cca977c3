"""The Wind UKF model and shell: physics of the model, FilterPy agreement, convergence."""

import numpy as np
import pytest
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter
from scipy import stats
from scipy.spatial.transform import Rotation

import windnav as wn
from windnav.estimate import DEFAULT_R, WindUKF, sensor_range, wind_world
from windnav.estimate import wind_model as wm

P_HB = wn.vehicle.params("hummingbird")
DT = 0.01


def random_states(rng, n, params=P_HB):
    X = np.zeros((n, 12 + params.n_rotors))
    X[:, 0:3] = rng.uniform([-np.pi, -0.5, -0.5], [np.pi, 0.5, 0.5], (n, 3))
    X[:, 3:6] = rng.normal(0, 1.0, (n, 3))
    X[:, 6:12] = rng.normal(0, 3.0, (n, 6))
    X[:, 12:] = params.hover_rotor_speed * rng.uniform(0.7, 1.3, (n, params.n_rotors))
    return X


def synthetic_flight(seconds, wind_world_true, wind_frame, rng, params=P_HB, noise=None):
    """Truth from the filter's own process model; body rates prescribed, wind fixed in the
    chosen frame. Returns states (K, n), commands (K, N), noisy measurements (list of dict)."""
    prm = wm.model_constants(params, wind_frame=wind_frame)
    noise = noise or {"accel": 0.3, "gyro": 0.07, "vel": 0.035, "euler": 0.005}
    n_rot = params.n_rotors
    x = np.zeros(12 + n_rot)
    x[12:] = params.hover_rotor_speed
    x[9:12] = wind_world_true                          # level, yaw 0: body = world
    xs, us, zs = [], [], []
    for k in range(int(round(seconds / DT))):
        t = k * DT
        x[3:6] = [0.6 * np.sin(2 * np.pi * 0.5 * t), 0.6 * np.cos(2 * np.pi * 0.4 * t),
                  0.2 * np.sin(2 * np.pi * 0.2 * t)]
        u = params.hover_rotor_speed * (1 + 0.05 * np.sin(2 * np.pi * 0.7 * t)) * np.ones(n_rot)
        x = wm.process(x[None], DT, u, prm)[0]
        X = x[None]
        zs.append({
            "accel": wm.specific_force(X, prm)[0] + rng.normal(0, noise["accel"], 3),
            "gyro": x[3:6] + rng.normal(0, noise["gyro"], 3),
            "odom": wm.odometry(X)[0] + np.r_[rng.normal(0, noise["vel"], 3),
                                              rng.normal(0, noise["euler"], 3)],
        })
        xs.append(x.copy())
        us.append(u)
    return np.array(xs), np.array(us), zs


def test_hover_is_an_equilibrium():
    x = np.zeros(16)
    x[12:] = P_HB.hover_rotor_speed
    prm = wm.model_constants(P_HB)
    np.testing.assert_allclose(wm.state_derivative(x, x[12:], prm), 0.0, atol=1e-12)
    np.testing.assert_allclose(wm.specific_force(x[None], prm)[0], [0, 0, 9.81], atol=1e-12)
    np.testing.assert_allclose(wm.process(x[None], DT, x[12:], prm)[0], x, atol=1e-12)


def test_accelerometer_is_the_non_gravitational_part_of_the_velocity_dynamics():
    rng = np.random.default_rng(0)
    X = random_states(rng, 50)
    prm = wm.model_constants(P_HB)
    dx = wm.state_derivative(X, np.full(4, 500.0), prm)
    R = wm.euler_to_matrix(X[:, :3])
    g_body = np.einsum("bji,j->bi", R, [0.0, 0.0, 9.81])
    a = dx[:, 6:9] + np.cross(X[:, 3:6], X[:, 6:9]) + g_body
    np.testing.assert_allclose(wm.specific_force(X, prm), a, atol=1e-12)


def test_force_law_is_the_thesis_model_in_closed_form():
    """Against the thesis's force law written out here (body axes, ``v_a = v_b - w_b``):
    ``m f = k_eta sum eta^2 e3 - sum eta diag(k_d, k_d, k_z) v_a + N k_h (v_ax^2 + v_ay^2) e3
    - |v_a| diag(c_dx, c_dy, c_dz) v_a``, and ``v_b' = f - R^T g e3 - Omega x v_b`` with SciPy's
    ZYX rotation; at these airspeeds the k_h lift is about 5 % of the force along e3 (median)."""
    p = P_HB
    X = random_states(np.random.default_rng(11), 40)
    eta, va = X[:, 12:], X[:, 6:9] - X[:, 9:12]
    s1, s2 = eta.sum(axis=1), (eta**2).sum(axis=1)
    speed = np.linalg.norm(va, axis=1)
    thrust = p.k_eta * s2 + p.n_rotors * p.k_h * (va[:, 0] ** 2 + va[:, 1] ** 2)
    force = np.column_stack([
        -s1 * p.k_d * va[:, 0] - speed * p.c_dx * va[:, 0],
        -s1 * p.k_d * va[:, 1] - speed * p.c_dy * va[:, 1],
        thrust - s1 * p.k_z * va[:, 2] - speed * p.c_dz * va[:, 2]])
    f = force / p.mass
    lift = p.n_rotors * p.k_h * (va[:, 0] ** 2 + va[:, 1] ** 2) / p.mass
    assert np.median(lift / f[:, 2]) > 0.03   # the k_h term matters at these states
    for frame in ("world", "body"):
        prm = wm.model_constants(p, wind_frame=frame)
        np.testing.assert_allclose(wm.specific_force(X, prm), f, rtol=1e-12, atol=1e-12)
        R = Rotation.from_euler("ZYX", X[:, :3]).as_matrix()
        g_body = np.einsum("bji,j->bi", R, [0.0, 0.0, wn.vehicle.GRAVITY])
        dv = f - g_body - np.cross(X[:, 3:6], X[:, 6:9])
        got = wm.state_derivative(X, np.full(p.n_rotors, 500.0), prm)[:, 6:9]
        np.testing.assert_allclose(got, dv, rtol=1e-10, atol=1e-10)


def test_linear_drag_limit_matches_the_appendix_model():
    """Without lift and parasitic drag, a_x = -(k_d sum(eta) / m) (v_x - w_x)."""
    p = P_HB.replace(k_h=0.0, c_dx=0.0, c_dy=0.0, c_dz=0.0)
    X = random_states(np.random.default_rng(1), 20, p)
    a = wm.specific_force(X, wm.model_constants(p))
    gain = p.k_d * X[:, 12:].sum(1) / p.mass
    np.testing.assert_allclose(a[:, 0], -gain * (X[:, 6] - X[:, 9]), rtol=1e-12)
    np.testing.assert_allclose(a[:, 1], -gain * (X[:, 7] - X[:, 10]), rtol=1e-12)


def test_euler_matrix_and_odometry_agree_with_scipy():
    X = random_states(np.random.default_rng(2), 30)
    R_ref = Rotation.from_euler("ZYX", X[:, :3]).as_matrix()
    np.testing.assert_allclose(wm.euler_to_matrix(X[:, :3]), R_ref, atol=1e-12)
    odom = wm.odometry(X)
    np.testing.assert_allclose(odom[:, :3], np.einsum("bij,bj->bi", R_ref, X[:, 6:9]), atol=1e-12)
    np.testing.assert_array_equal(odom[:, 3:], X[:, :3])


def test_process_is_rk4_accurate_and_motors_exact():
    X = random_states(np.random.default_rng(3), 5)
    prm = wm.model_constants(P_HB, wind_frame="body")
    u = np.array([400.0, 450.0, 500.0, 550.0])
    dt = 0.05
    ref = wm.process(X, dt, u, prm, n_substeps=256)
    errs = [np.abs(wm.process(X, dt, u, prm, n_substeps=k)[:, :12] - ref[:, :12]).max()
            for k in (4, 8)]
    assert errs[0] / errs[1] > 12.0   # fourth order: halving the step divides the error by 16
    eta = u + (X[:, 12:] - u) * np.exp(-dt / P_HB.tau_m)
    np.testing.assert_allclose(wm.process(X, dt, u, prm)[:, 12:], eta, rtol=1e-12)


def test_world_frame_wind_option_keeps_world_wind_constant():
    prm = wm.model_constants(P_HB, wind_frame="world")
    x = random_states(np.random.default_rng(4), 1)
    w0 = np.einsum("bij,bj->bi", wm.euler_to_matrix(x[:, :3]), x[:, 9:12])
    for _ in range(50):
        x = wm.process(x, DT, x[0, 12:], prm, n_substeps=4)
    w1 = np.einsum("bij,bj->bi", wm.euler_to_matrix(x[:, :3]), x[:, 9:12])
    np.testing.assert_allclose(w1, w0, atol=1e-6)


@pytest.mark.parametrize("wind_frame", ["body", "world"])
def test_wind_ukf_matches_filterpy_over_200_steps(wind_frame):
    rng = np.random.default_rng(5)
    xs, us, zs = synthetic_flight(2.0, np.array([2.0, -1.0, 0.3]), wind_frame, rng)
    ours = WindUKF(P_HB, DT, wind_frame=wind_frame, alpha=0.8, beta=2.0, kappa=0.0)
    prm = wm.model_constants(P_HB, wind_frame=wind_frame)
    R = np.zeros((12, 12))
    R[:3, :3] = ours.R["accel"]
    R[3:6, 3:6] = ours.R["gyro"]
    R[6:, 6:] = ours.R["odom"]

    def hx(x):
        X = x[None]
        return np.concatenate([wm.specific_force(X, prm)[0], x[3:6], wm.odometry(X)[0]])

    ref = UnscentedKalmanFilter(16, 12, DT, hx=hx, fx=lambda x, dt, u: wm.process(
        x[None], dt, u, prm)[0], points=MerweScaledSigmaPoints(16, 0.8, 2.0, 0.0))
    ref.x, ref.P, ref.Q, ref.R = ours.x.copy(), ours.P.copy(), ours.Q, R
    for u, z in zip(us, zs, strict=True):
        ours.step(u, z)
        ref.predict(u=u)
        ref.update(np.concatenate([z["accel"], z["gyro"], z["odom"]]))
    np.testing.assert_allclose(ours.x, ref.x, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(ours.P, ref.P, rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("wind_frame", ["body", "world"])
def test_wind_estimate_converges_on_synthetic_flight(wind_frame):
    rng = np.random.default_rng(6)
    w_true = np.array([3.0, -2.0, 0.5])
    xs, us, zs = synthetic_flight(5.0, w_true, wind_frame, rng)
    f = WindUKF(P_HB, DT, wind_frame=wind_frame)
    est, cov = [], []
    for u, z in zip(us, zs, strict=True):
        e = f.step(u, z)
        est.append(e.wind_world)
        cov.append(e.wind_world_cov)
    truth = np.einsum("bij,bj->bi", wm.euler_to_matrix(xs[:, :3]), xs[:, 9:12])
    err = (np.array(est) - truth)[200:]
    rmse = np.sqrt(np.mean(np.sum(err**2, axis=1)))
    assert rmse < 0.3
    # Not overconfident. A consistent filter's NEES e^T C^-1 e is chi2(3) per sample; the 300
    # samples are correlated over ~14 steps (integrated autocorrelation of the whitened error),
    # so count one independent sample per 30 steps, K = 10: the mean NEES is then
    # chi2(3K) / K, and exceeds chi2.ppf(0.999, 30) / 10 = 5.97 with probability 0.001. Only
    # the upper tail is tested: the truth here has a constant wind and prescribed rates while
    # the filter assumes random walks, so its covariance over-bounds the error (mean NEES
    # ~1.4); both tails are tested below, where the truth follows the filter's model.
    nees = np.mean([e @ np.linalg.solve(c, e) for e, c in zip(err, np.array(cov)[200:],
                                                               strict=True)])
    K = err.shape[0] // 30
    assert nees < stats.chi2.ppf(0.999, 3 * K) / K
    assert f.repairs == 0


@pytest.mark.parametrize("wind_frame", ["world", "body"])
def test_nees_is_chi_square_when_the_truth_follows_the_filter_model(wind_frame):
    """Consistency (Bar-Shalom's NEES test). M = 40 independent runs whose truth is the filter's
    own model: initial state drawn from (x0, P0), process noise from Q, measurement noise from
    R. After 1.5 s, each run's world-wind NEES is chi2(3) and its full-state NEES chi2(16) for a
    consistent filter (up to the unscented approximation); the runs are independent, so the
    averages are chi2(3M) / M and chi2(16M) / M. Bounds: their 0.001 and 0.999 quantiles."""
    q = {"euler": 0.01, "rates": 0.3, "velocity": 0.1, "wind": 0.3, "rotor_speeds": 5.0}
    P0 = np.diag(np.r_[[0.05**2] * 3, [0.1**2] * 3, [0.2**2] * 3, [1.0] * 3, [10.0**2] * 4])
    prm = wm.model_constants(P_HB, wind_frame=wind_frame)
    M, steps = 40, 150
    nees_wind, nees_state = [], []
    for run in range(M):
        rng = np.random.default_rng([run, 13])
        f = WindUKF(P_HB, DT, q=q, P0=P0, wind_frame=wind_frame)
        sq = np.sqrt(np.diag(f.Q))
        LR = {k: np.linalg.cholesky(v) for k, v in f.R.items()}
        x = f.x + np.linalg.cholesky(P0) @ rng.normal(size=16)
        for k in range(steps):
            u = P_HB.hover_rotor_speed * (1 + 0.05 * np.sin(4.4 * k * DT + run)) * np.ones(4)
            x = wm.process(x[None], DT, u, prm)[0] + sq * rng.normal(size=16)
            X = x[None]
            e = f.step(u, {"accel": wm.specific_force(X, prm)[0] + LR["accel"] @ rng.normal(size=3),
                           "gyro": x[3:6] + LR["gyro"] @ rng.normal(size=3),
                           "odom": wm.odometry(X)[0] + LR["odom"] @ rng.normal(size=6)})
        err = e.wind_world - wm.euler_to_matrix(x[:3])[0] @ x[9:12]
        nees_wind.append(err @ np.linalg.solve(e.wind_world_cov, err))
        dx = f.x - x
        nees_state.append(dx @ np.linalg.solve(f.P, dx))
    for values, dof in ((nees_wind, 3), (nees_state, 16)):
        lo, hi = stats.chi2.ppf([0.001, 0.999], dof * M) / M
        assert lo < np.mean(values) < hi, (dof, np.mean(values), lo, hi)


def test_accel_from_differenced_odometry_converges():
    rng = np.random.default_rng(7)
    w_true = np.array([2.0, 1.0, 0.0])
    xs, us, zs = synthetic_flight(5.0, w_true, "world", rng)
    f = WindUKF(P_HB, DT, wind_frame="world", accel_from_odometry=True)
    est = np.array([f.step(u, {**z, "accel": np.full(3, np.nan)}).wind_world
                    for u, z in zip(us, zs, strict=True)])
    truth = np.einsum("bij,bj->bi", wm.euler_to_matrix(xs[:, :3]), xs[:, 9:12])
    rmse = np.sqrt(np.mean(np.sum((est - truth)[200:] ** 2, axis=1)))
    assert rmse < 0.6
    assert f.rejected["accel"] == 0   # the IMU entry is ignored, not fused


def test_wind_world_covariance_matches_monte_carlo():
    rng = np.random.default_rng(8)
    x = np.zeros(16)
    x[:3] = [0.7, 0.1, -0.2]
    x[9:12] = [4.0, -1.0, 0.5]
    A = rng.normal(size=(16, 16)) * 0.01       # attitude std ~0.05 rad, wind std ~0.3 m/s
    P = A @ A.T + np.diag(np.r_[[0.03**2] * 3, [0.1] * 9, [1.0] * 4])
    mean, cov = wind_world(x, P)
    S = rng.multivariate_normal(x, P, size=200_000)
    W = np.einsum("bij,bj->bi", wm.euler_to_matrix(S[:, :3]), S[:, 9:12])
    np.testing.assert_allclose(mean, W.mean(0), atol=0.02)
    np.testing.assert_allclose(cov, np.cov(W.T), rtol=0.05, atol=0.005)
    # no attitude uncertainty at zero attitude: the body covariance itself
    P0 = np.diag(np.r_[[0.0] * 3, [0.1] * 13])
    P0[:3, :3] = np.eye(3) * 1e-30
    m0, c0 = wind_world(np.r_[np.zeros(9), [1.0, 2.0, 3.0], np.zeros(4)], P0)
    np.testing.assert_allclose(m0, [1.0, 2.0, 3.0], atol=1e-12)
    np.testing.assert_allclose(c0, 0.1 * np.eye(3), atol=1e-12)


def test_shell_validates_and_rejects():
    f = WindUKF(P_HB)
    with pytest.raises(ValueError, match="'u_cmd'"):
        f.step(np.zeros(3), {})
    # a batch of commands is not one (the second row used to be dropped), None is not a
    # mapping, and neither leaves the filter predicted (audit, 2026-12-05)
    x_before = f.x.copy()
    with pytest.raises(ValueError, match="'u_cmd' parameter of WindUKF.step must be a batch "
                                         "of 1"):
        f.step(np.zeros((2, 4)), {})
    with pytest.raises(ValueError, match="'measurements' parameter of WindUKF.step"):
        f.step(np.full(4, P_HB.hover_rotor_speed), None)
    np.testing.assert_array_equal(f.x, x_before)
    with pytest.raises(ValueError, match="'accel_from_odometry' parameter of WindUKF"):
        WindUKF(P_HB, accel_from_odometry="yes")
    with pytest.raises(ValueError, match="'x' and 'P' parameters of wind_world"):
        wind_world(np.zeros(5), np.eye(5))  # an IndexError inside the kernel before
    with pytest.raises(ValueError, match="'x' and 'P' parameters of wind_world"):
        wind_world(np.zeros(16), np.eye(15))
    with pytest.raises(ValueError, match="'r'"):
        WindUKF(P_HB, r={"gps": 1.0})
    with pytest.raises(ValueError, match="'q'"):
        WindUKF(P_HB, q={"attitude": 1.0})
    with pytest.raises(ValueError, match=r"r\['accel'\]"):
        WindUKF(P_HB, r={"accel": -1.0})
    with pytest.raises(ValueError, match="'wind_frame'"):
        WindUKF(P_HB, wind_frame="earth")
    e = f.step(np.full(4, P_HB.hover_rotor_speed), {"gyro": [np.nan, 0, 0], "odom": None})
    assert f.rejected["gyro"] == 1
    assert np.all(np.isfinite(e.wind_world))
    custom = WindUKF(P_HB, r={"accel": [0.1, 0.1, 0.2], "odom": np.eye(6) * 1e-4})
    np.testing.assert_allclose(np.diag(custom.R["accel"]), [0.01, 0.01, 0.04])
    np.testing.assert_allclose(custom.R["odom"], np.eye(6) * 1e-4)


@pytest.mark.parametrize("block, value", [("accel", [1e6, 0.0, 9.81]), ("gyro", [1e3, 0, 0]),
                                          ("odom", [1e4, 0, 0, 0, 0, 0]),
                                          ("rotor_speeds", [1e7, 0, 0, 0])])
def test_one_absurd_sample_is_rejected_and_the_filter_goes_on(block, value):
    # before the sensor ranges (2026-12-05) an accelerometer sample of 1e6 m/s^2 threw the
    # state so far that this and every later step raised FloatingPointError
    hover = np.full(4, P_HB.hover_rotor_speed)
    good = {"accel": [0.0, 0.0, 9.81], "gyro": np.zeros(3), "odom": np.zeros(6),
            "rotor_speeds": hover}
    f, ref = WindUKF(P_HB), WindUKF(P_HB)
    f.step(hover, {**good, block: np.asarray(value, dtype=float) + good[block]})
    ref.step(hover, {k: v for k, v in good.items() if k != block})
    assert f.rejected[block] == 1
    np.testing.assert_array_equal(f.x, ref.x)  # as if the block had not been sampled
    for _ in range(50):
        e = f.step(hover, good)
    assert np.all(np.isfinite(e.wind_world)) and np.abs(e.wind_world).max() < 1.0
    limit = sensor_range(P_HB)[block]
    assert limit.shape == (len(value),) and (np.abs(value) >= limit).any()


def test_measurements_of_real_flights_are_inside_the_sensor_ranges():
    # the ranges reject no sample of a simulated flight with a gusty wind
    rng = np.random.default_rng(4)
    xs, us, zs = synthetic_flight(3.0, np.array([6.0, -4.0, 0.0]), "world", rng)
    f = WindUKF(P_HB, DT)
    for u, z in zip(us, zs, strict=True):
        f.step(u, z)
    assert sum(f.rejected.values()) == 0


def test_multirate_odometry_and_rotor_speed_block():
    rng = np.random.default_rng(9)
    w_true = np.array([-2.0, 2.5, 0.0])
    xs, us, zs = synthetic_flight(5.0, w_true, "world", rng)
    x0 = np.zeros(16)
    x0[12:] = P_HB.hover_rotor_speed + 80.0          # rotor speeds start badly off
    f = WindUKF(P_HB, DT, wind_frame="world", x0=x0)
    est = []
    for k, (u, z) in enumerate(zip(us, zs, strict=True)):
        meas = {"accel": z["accel"], "gyro": z["gyro"],
                "odom": z["odom"] if k % 4 == 0 else None,              # 25 Hz odometry
                "rotor_speeds": xs[k, 12:] + rng.normal(0, 10.0, 4)}
        est.append(f.step(u, meas).wind_world)
    truth = np.einsum("bij,bj->bi", wm.euler_to_matrix(xs[:, :3]), xs[:, 9:12])
    rmse = np.sqrt(np.mean(np.sum((np.array(est) - truth)[200:] ** 2, axis=1)))
    assert rmse < 0.3
    assert np.abs(f.x[12:] - xs[-1, 12:]).max() < 15.0


def test_accel_from_odometry_equals_fusing_the_differenced_velocity_explicitly():
    """With odometry every step, differencing inside the filter is the same as fusing
    a_b = R^T ((v_k - v_(k-1)) / dt + g e3) as an accelerometer of std sqrt(2) sigma_v / dt;
    the noise is built per step, the filter's registered blocks stay as configured."""
    rng = np.random.default_rng(10)
    xs, us, zs = synthetic_flight(1.0, np.array([2.0, 1.0, 0.0]), "world", rng)
    inside = WindUKF(P_HB, DT, accel_from_odometry=True)
    sigma_v = DEFAULT_R["odom_velocity"]
    explicit = WindUKF(P_HB, DT, r={"accel": np.sqrt(2.0) * sigma_v / DT})
    blocks_before = {k: b.R.copy() for k, b in inside.ukf.blocks.items()}
    prev = None
    for u, z in zip(us, zs, strict=True):
        inside.step(u, {**z, "accel": None})
        accel = None
        if prev is not None:
            a_world = (z["odom"][:3] - prev[:3]) / DT + np.array([0.0, 0.0, wn.vehicle.GRAVITY])
            accel = wm.euler_to_matrix(z["odom"][3:])[0].T @ a_world
        prev = z["odom"]
        explicit.step(u, {**z, "accel": accel})
    np.testing.assert_allclose(inside.x, explicit.x, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(inside.P, explicit.P, rtol=1e-10, atol=1e-16)
    for k, R in blocks_before.items():
        np.testing.assert_array_equal(inside.ukf.blocks[k].R, R)


def test_an_imu_presets_accelerometer_noise_does_not_replace_the_differenced_odometrys():
    """``conditions='windnav'`` with ``accel_from_odometry=True``: the differenced velocity is
    fused with its own noise, sqrt(2) sigma_v / dt, as without the preset (whose other setting,
    q wind 1.0, is given alike); the preset's 0.1 m/s^2 is an IMU's. It used to be taken for the
    differenced velocity's: 2.9 m/s of wind error and a NEES of 574 (audit, 2026-12-05). An
    explicit ``r['accel']`` still sets it."""
    rng = np.random.default_rng(10)
    xs, us, zs = synthetic_flight(1.0, np.array([2.0, 1.0, 0.0]), "world", rng)
    preset = WindUKF(P_HB, DT, conditions="windnav", accel_from_odometry=True,
                     wind_frame="world")
    plain = WindUKF(P_HB, DT, q={"wind": 1.0}, accel_from_odometry=True, wind_frame="world")
    given = WindUKF(P_HB, DT, conditions="windnav", accel_from_odometry=True,
                    wind_frame="world", r={"accel": 0.1})
    for u, z in zip(us, zs, strict=True):
        for f in (preset, plain, given):
            f.step(u, {**z, "accel": None})
    np.testing.assert_array_equal(preset.x, plain.x)
    np.testing.assert_array_equal(preset.P, plain.P)
    assert not np.allclose(given.P, plain.P)


def test_accel_from_25_hz_odometry_differences_over_the_four_steps_between_samples():
    """Odometry every 4th step of a 100 Hz filter: the filter fuses
    a_b = R^T ((v_k - v_(k-4)) / (4 dt) + g e3) with std sqrt(2) sigma_v / (4 dt), the same as
    fusing that accelerometer explicitly at the odometry steps."""
    rng = np.random.default_rng(12)
    xs, us, zs = synthetic_flight(1.0, np.array([2.0, 1.0, 0.0]), "world", rng)
    every = 4
    interval = every * DT
    inside = WindUKF(P_HB, DT, accel_from_odometry=True)
    sigma_v = DEFAULT_R["odom_velocity"]
    explicit = WindUKF(P_HB, DT, r={"accel": np.sqrt(2.0) * sigma_v / interval})
    prev = None
    for k, (u, z) in enumerate(zip(us, zs, strict=True)):
        odom = z["odom"] if k % every == 0 else None
        inside.step(u, {"gyro": z["gyro"], "odom": odom})
        accel = None
        if odom is not None:
            if prev is not None:
                a_world = (odom[:3] - prev[:3]) / interval + np.array([0.0, 0.0,
                                                                       wn.vehicle.GRAVITY])
                accel = wm.euler_to_matrix(odom[3:])[0].T @ a_world
            prev = odom
        explicit.step(u, {"gyro": z["gyro"], "odom": odom, "accel": accel})
    np.testing.assert_allclose(inside.x, explicit.x, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(inside.P, explicit.P, rtol=1e-8, atol=1e-14)


def test_wind_frame_default_is_the_same_everywhere():
    import inspect

    from windnav.estimate import run_wind_ukf

    defaults = {f.__name__: inspect.signature(f).parameters["wind_frame"].default
                for f in (WindUKF, run_wind_ukf, wm.model_constants)}
    # None in the filter's entry points means "the conditions' frame, else the default";
    # run_wind_ukf passes it on to WindUKF, which resolves it to the one default
    assert defaults["model_constants"] == "world"
    assert defaults["WindUKF"] is None and defaults["run_wind_ukf"] is None, defaults
    assert WindUKF(P_HB).wind_frame == "world"
    assert WindUKF(P_HB)._prm[wm.PRM_WORLD_WIND] == 1.0


def test_the_model_functions_name_commands_of_the_wrong_shape():
    """A scalar command (one speed for every rotor) was a Numba TypingError deep inside the
    kernel (mutation audit, 2026-12-05): named, for the derivative and the propagation."""
    prm = wm.model_constants(P_HB)
    x = np.zeros(16)
    for call in (lambda u: wm.state_derivative(x[None], u, prm),
                 lambda u: wm.process(x[None], 0.01, u, prm)):
        with pytest.raises(ValueError, match=r"'u' parameter of (state_derivative|process) "
                                             r"must be an array of the 4 commanded"):
            call(500.0)
        with pytest.raises(ValueError, match=r"Got shape \(3,\) instead"):
            call(np.full(3, 500.0))
        assert call(np.full(4, 500.0)).shape == (1, 16)


def test_a_tracks_mean_error_and_rmse_are_over_the_same_settled_samples():
    """``mean_error_after`` (the bias fly and the demo report) and ``rmse_after`` keep the
    samples at ``t - t_0 >= settle_s``, leave NaN out of the mean, and refuse a settle time
    past the track."""
    from windnav.estimate.flight import WindTrack

    t = 5.0 + 0.5 * np.arange(8)
    est = np.zeros((8, 3))
    est[:, 0] = np.arange(8.0)
    est[6, 1] = np.nan
    track = WindTrack(t=t, wind_est=est, wind_cov=np.tile(np.eye(3), (8, 1, 1)),
                      wind_true=np.zeros((8, 3)), x=np.zeros((8, 16)), repairs=0)
    np.testing.assert_allclose(track.mean_error_after(1.0), [4.5, 0.0, 0.0])  # samples 2-7
    assert track.rmse_after(1.0, axis=0) == pytest.approx(np.sqrt(np.mean(np.arange(2, 8) ** 2)))
    with pytest.raises(ValueError, match="'settle_s' parameter of WindTrack.mean_error_after"):
        track.mean_error_after(10.0)
