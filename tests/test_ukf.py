"""Generic UKF: agreement with FilterPy, unscented-transform exactness, robustness."""

import warnings

import numpy as np
import pytest
from filterpy.kalman import MerweScaledSigmaPoints, UnscentedKalmanFilter
from hypothesis import given, settings
from hypothesis import strategies as st

from windnav.estimate import (
    UKF,
    merwe_weights,
    robust_cholesky,
    sigma_points,
    ukf_update,
    unscented_transform,
)


def pendulum_fx(X, dt, u):
    th, om = X[:, 0], X[:, 1]
    h = dt / 5
    for _ in range(5):
        om = om + h * (-9.81 * np.sin(th) - 0.1 * om + (0.0 if u is None else u))
        th = th + h * om
    return np.stack([th, om], axis=1)


def pendulum_hx(X):
    return np.stack([np.sin(X[:, 0]), X[:, 0] * X[:, 1]], axis=1)


def ct_fx(X, dt, u):
    """Coordinated turn: x, y, speed, heading, turn rate."""
    x, y, v, h, w = X.T
    w_safe = np.where(np.abs(w) < 1e-9, 1e-9, w)
    xn = x + v / w_safe * (np.sin(h + w * dt) - np.sin(h))
    yn = y + v / w_safe * (np.cos(h) - np.cos(h + w * dt))
    return np.stack([xn, yn, v, h + w * dt, w], axis=1)


def ct_hx(X):
    return np.stack([np.hypot(X[:, 0], X[:, 1]), np.arctan2(X[:, 1], X[:, 0])], axis=1)


def run_both(fx, hx, x0, P0, Q, R, truth, dt, n_steps, alpha, beta, kappa, seed, u=None):
    rng = np.random.default_rng(seed)
    n, m = x0.size, R.shape[0]
    ours = UKF(fx, x0, P0, Q, dt=dt, blocks={"z": (hx, R)}, alpha=alpha, beta=beta, kappa=kappa)
    pts = MerweScaledSigmaPoints(n, alpha=alpha, beta=beta, kappa=kappa)
    ref = UnscentedKalmanFilter(n, m, dt, hx=lambda x: hx(x[None])[0],
                                fx=lambda x, dt: fx(x[None], dt, u)[0], points=pts)
    ref.x, ref.P, ref.Q, ref.R = x0.copy(), P0.copy(), Q, R
    xt = truth.copy()
    for _ in range(n_steps):
        xt = fx(xt[None], dt, u)[0]
        z = hx(xt[None])[0] + rng.normal(0, np.sqrt(np.diag(R)))
        ours.predict(u=u)
        ours.update({"z": z})
        ref.predict()
        ref.update(z)
    return ours, ref, xt


def test_matches_filterpy_pendulum():
    ours, ref, xt = run_both(pendulum_fx, pendulum_hx, np.array([0.3, 0.0]), np.diag([0.5, 0.5]),
                             np.diag([1e-5, 1e-3]), np.diag([0.01, 0.05]), np.array([1.0, 0.0]),
                             0.02, 200, alpha=0.3, beta=2.0, kappa=1.0, seed=0)
    np.testing.assert_allclose(ours.x, ref.x, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(ours.P, ref.P, rtol=1e-9, atol=1e-9)
    assert abs(ours.x[0] - xt[0]) < 0.1  # and the filter tracks the pendulum


def test_matches_filterpy_coordinated_turn():
    x0 = np.array([50.0, 10.0, 8.0, 0.5, 0.05])
    ours, ref, xt = run_both(ct_fx, ct_hx, x0 + [2, -2, 1, 0.1, 0.02],
                             np.diag([10.0, 10.0, 2.0, 0.1, 0.01]),
                             np.diag([0.01, 0.01, 0.01, 1e-4, 1e-5]), np.diag([1.0, 1e-4]), x0,
                             0.1, 200, alpha=0.5, beta=2.0, kappa=0.0, seed=1)
    np.testing.assert_allclose(ours.x, ref.x, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(ours.P, ref.P, rtol=1e-9, atol=1e-9)
    assert np.hypot(*(ours.x[:2] - xt[:2])) < 3.0


def test_weights_and_sigma_points_match_filterpy():
    rng = np.random.default_rng(2)
    A = rng.normal(size=(4, 4))
    P = A @ A.T + np.eye(4)
    x = rng.normal(size=4)
    w = merwe_weights(4, 0.4, 2.0, 1.0)
    ref = MerweScaledSigmaPoints(4, 0.4, 2.0, 1.0)
    np.testing.assert_allclose(w.wm, ref.Wm, rtol=1e-14)
    np.testing.assert_allclose(w.wc, ref.Wc, rtol=1e-14)
    L, _, repaired = robust_cholesky(P)
    assert not repaired
    np.testing.assert_allclose(sigma_points(x, L, w), ref.sigma_points(x, P), atol=1e-12)


@settings(max_examples=30, deadline=None)
@given(n=st.integers(1, 6), m=st.integers(1, 4), alpha=st.floats(0.2, 1.5),
       kappa=st.floats(0.0, 3.0), seed=st.integers(0, 10_000))
def test_unscented_transform_is_exact_for_linear_maps(n, m, alpha, kappa, seed):
    rng = np.random.default_rng(seed)
    A = rng.normal(size=(m, n))
    b = rng.normal(size=m)
    B = rng.normal(size=(n, n))
    P = B @ B.T + 0.1 * np.eye(n)
    x = rng.normal(size=n)
    w = merwe_weights(n, alpha, 2.0, kappa)
    L, _, _ = robust_cholesky(P)
    mean, cov = unscented_transform(sigma_points(x, L, w) @ A.T + b, w)
    np.testing.assert_allclose(mean, A @ x + b, atol=1e-9)
    np.testing.assert_allclose(cov, A @ P @ A.T, atol=1e-9 * (1 + np.abs(A @ P @ A.T).max()))


def _two_block_filter():
    R1, R2 = np.diag([0.01]), np.diag([0.05])
    blocks = {"sin": (lambda X: np.sin(X[:, :1]), R1), "prod": (lambda X: X[:, :1] * X[:, 1:2], R2)}
    return UKF(pendulum_fx, [0.3, 0.1], np.diag([0.5, 0.5]), np.diag([1e-5, 1e-3]), dt=0.02,
               blocks=blocks)


def test_multiblock_update_equals_stacked_block():
    a = _two_block_filter()
    b = UKF(pendulum_fx, [0.3, 0.1], np.diag([0.5, 0.5]), np.diag([1e-5, 1e-3]), dt=0.02,
            blocks={"z": (pendulum_hx, np.diag([0.01, 0.05]))})
    for z in ([0.2, 0.05], [0.25, 0.1], [0.3, 0.2]):
        a.predict()
        b.predict()
        a.update({"sin": z[0], "prod": z[1]})
        b.update({"z": z})
    np.testing.assert_allclose(a.x, b.x, rtol=1e-12)
    np.testing.assert_allclose(a.P, b.P, rtol=1e-12, atol=1e-15)


def test_missing_and_nonfinite_blocks_are_skipped():
    a, b = _two_block_filter(), _two_block_filter()
    a.predict()
    b.predict()
    a.update({"sin": 0.2, "prod": None})
    b.update({"sin": 0.2, "prod": np.nan})
    np.testing.assert_array_equal(a.x, b.x)
    assert b.rejected == {"sin": 0, "prod": 1}
    x_before = b.x.copy()
    assert b.update({"sin": np.inf, "prod": None}) is None   # nothing fused: state unchanged
    np.testing.assert_array_equal(b.x, x_before)
    assert b.rejected["sin"] == 1
    # a bad first block, a good second one: the second alone is fused, to the bit
    c, d = _two_block_filter(), _two_block_filter()
    c.update({"sin": np.nan, "prod": 0.3})
    d.update({"prod": 0.3})
    np.testing.assert_array_equal(c.x, d.x)
    np.testing.assert_array_equal(c.P, d.P)
    assert c.rejected == {"sin": 1, "prod": 0}
    assert c.update({"sin": np.nan, "prod": [np.inf]}) is None
    assert c.rejected == {"sin": 2, "prod": 1}


def test_a_sample_beyond_the_blocks_range_is_rejected_like_a_non_finite_one():
    a, b = _two_block_filter(), _two_block_filter()
    b.add_block("prod", lambda X: X[:, :1] * X[:, 1:2], np.diag([0.05]), limit=10.0)
    b.update({"sin": 0.2, "prod": 1e6})  # beyond the range: "sin" alone is fused
    a.update({"sin": 0.2})
    np.testing.assert_array_equal(a.x, b.x)
    assert b.rejected == {"sin": 0, "prod": 1}
    b.update({"prod": 9.0})  # inside it: fused
    assert b.rejected["prod"] == 1 and not np.array_equal(a.x, b.x)
    # the default is no range: the same sample is fused, as before the limits existed
    c = _two_block_filter()
    c.update({"sin": 0.2, "prod": 1e6})
    assert c.rejected == {"sin": 0, "prod": 0}
    for bad in (0.0, -1.0, np.nan, [1.0, 2.0]):
        with pytest.raises(ValueError, match="'limit' parameter of UKF.add_block"):
            c.add_block("prod", lambda X: X[:, :1], np.diag([0.05]), limit=bad)


def test_bad_input_raises_named_errors():
    f = _two_block_filter()
    with pytest.raises(ValueError, match=r"measurements\['sin'\]"):
        f.update({"sin": [0.1, 0.2]})
    with pytest.raises(ValueError, match="unknown block 'gps'"):
        f.update({"gps": [0.1]})
    with pytest.raises(ValueError, match="'P0'"):
        UKF(pendulum_fx, [0.0, 0.0], np.eye(3), np.eye(2), dt=0.1)
    # not a covariance: only repaired, with a warning, at the first step before (2026-12-05)
    for bad in (-np.eye(2), np.array([[1.0, 0.5], [0.0, 1.0]]), np.array([[1.0, 2.0],
                                                                          [2.0, 1.0]])):
        with pytest.raises(ValueError, match="'P0' parameter of UKF must be a symmetric "
                                             "positive semi-definite covariance"):
            UKF(pendulum_fx, [0.0, 0.0], bad, np.eye(2), dt=0.1)
        with pytest.raises(ValueError, match="'Q' parameter of UKF must be a symmetric"):
            UKF(pendulum_fx, [0.0, 0.0], np.eye(2), bad, dt=0.1)
    assert UKF(pendulum_fx, [0.0, 0.0], np.zeros((2, 2)), np.zeros((2, 2)), dt=0.1).n == 2
    with pytest.raises(ValueError, match="'dt'"):
        UKF(pendulum_fx, [0.0, 0.0], np.eye(2), np.eye(2), dt=0.0)
    with pytest.raises(ValueError, match="positive definite"):
        f.add_block("bad", pendulum_hx, np.diag([1.0, -1.0]))
    g = UKF(lambda X, dt, u: X[:, :1], [0.0, 0.0], np.eye(2), np.eye(2), dt=0.1)
    with pytest.raises(ValueError, match="'fx'"):
        g.predict()


def test_lost_positive_definiteness_is_repaired_and_reported():
    f = _two_block_filter()
    f.P = np.array([[1.0, 2.0], [2.0, 1.0]])   # indefinite (eigenvalues 3, -1)
    with pytest.warns(RuntimeWarning, match="repaired"):
        f.predict()
    assert f.repairs == 1
    assert np.all(np.linalg.eigvalsh(f.P) > 0)
    f.P = np.array([[1.0, 2.0], [2.0, 1.0]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")   # warned once only
        f.update({"sin": 0.1})
    assert f.repairs == 2
    assert np.all(np.isfinite(f.x))


def test_robust_cholesky_clips_negative_eigenvalues():
    P = np.diag([4.0, 1.0, -1e-3])
    L, Pr, repaired = robust_cholesky(P)
    assert repaired
    np.testing.assert_allclose(L @ L.T, Pr, atol=1e-12)
    w = np.linalg.eigvalsh(Pr)
    assert w.min() > 0 and w.min() < 1e-9
    np.testing.assert_allclose(np.sort(w)[1:], [1.0, 4.0], atol=1e-12)


def test_functional_update_leaves_inputs_untouched():
    x, P = np.array([0.3, 0.1]), np.diag([0.5, 0.5])
    x0, P0 = x.copy(), P.copy()
    res = ukf_update(x, P, np.array([0.2, 0.05]), pendulum_hx, np.diag([0.01, 0.05]),
                     merwe_weights(2))
    np.testing.assert_array_equal(x, x0)
    np.testing.assert_array_equal(P, P0)
    assert np.all(np.diag(res.P) < np.diag(P))   # information reduces the variance


def test_per_update_noise_equals_a_block_with_that_noise_and_changes_no_block():
    a = _two_block_filter()
    b = UKF(pendulum_fx, [0.3, 0.1], np.diag([0.5, 0.5]), np.diag([1e-5, 1e-3]), dt=0.02,
            blocks={"sin": (lambda X: np.sin(X[:, :1]), np.diag([0.04])),
                    "prod": (lambda X: X[:, :1] * X[:, 1:2], np.diag([0.05]))})
    for z in ([0.2, 0.05], [0.25, 0.1], [0.3, 0.2]):
        a.predict()
        b.predict()
        a.update({"sin": z[0], "prod": z[1]}, noise={"sin": np.diag([0.04])})
        b.update({"sin": z[0], "prod": z[1]})
    np.testing.assert_array_equal(a.x, b.x)
    np.testing.assert_array_equal(a.P, b.P)
    np.testing.assert_array_equal(a.blocks["sin"].R, np.diag([0.01]))   # configuration kept
    with pytest.raises(ValueError, match="'noise'"):
        a.update({"sin": 0.1}, noise={"gps": np.eye(1)})
    with pytest.raises(ValueError, match=r"noise\['sin'\]"):
        a.update({"sin": 0.1}, noise={"sin": np.eye(2)})
