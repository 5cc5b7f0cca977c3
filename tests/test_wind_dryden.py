"""Dryden gusts: exact scaling at any step, the MIL-F-8785C spectra, colour, determinism.

Statistical tolerances are derived from the integral time scales of the process (not tuned):
for a record of duration D of a stationary process with autocorrelation rho(tau),

    Var(sample mean)     ~ sigma^2 / D * int_{-inf}^{inf} rho      = 2 sigma^2 T_int / D
    Var(sample variance) ~ 2 sigma^4 / D * int_{-inf}^{inf} rho^2

with, for T = L/V, rho_u = exp(-tau/T) (int_0^inf rho = T, int_0^inf rho^2 = T/2) and
rho_v = rho_w = (1 - tau/(2T)) exp(-tau/T) (int_0^inf rho = T/2, int_0^inf rho^2 = 5T/16).
The lag-one sample autocorrelation's spread follows Bartlett's formula. Every check uses 4
standard deviations; the runs are long enough that 4 sd of the sample std is below 5 %.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg

from windnav.wind import DrydenWind, dryden_length_scales, dryden_state_space, van_loan
from windnav.wind.dryden import FOOT

MEAN = np.array([3.0, -1.0, 0.5])
SIGMA = np.array([1.5, 1.2, 0.7])
ALTITUDE = 10 * FOOT  # the model's lowest altitude: short scales, so the runs stay short
DURATION = 8000.0  # s, > 3000 T_u
K_SD = 4.0


def _rho(kind: str, tau: np.ndarray, time_scale: float) -> np.ndarray:
    x = np.abs(tau) / time_scale
    return np.exp(-x) if kind == "u" else (1 - x / 2) * np.exp(-x)


def _bartlett_lag1_sd(kind: str, dt: float, time_scale: float, n: int) -> float:
    """Bartlett's large-sample sd of the lag-one sample autocorrelation."""
    k = np.arange(-int(40 * time_scale / dt) - 2, int(40 * time_scale / dt) + 3)
    r = lambda j: _rho(kind, j * dt, time_scale)  # noqa: E731
    r1 = r(1)
    terms = r(k + 1) ** 2 + r(k - 1) * r(k + 1) + 2 * r1**2 * r(k) ** 2 - 4 * r1 * r(k) * r(k + 1)
    return math.sqrt(terms.sum() / n)


@pytest.fixture(scope="module", params=[0.001, 0.01, 0.05], ids=lambda dt: f"dt={dt}")
def record(request):
    dt = request.param
    field = DrydenWind(mean=MEAN, sigma=SIGMA, seed=2024, altitude=ALTITUDE)
    n = int(round(DURATION / dt))
    return dt, field, field.sample(dt * np.arange(1, n + 1))


def test_length_scales_follow_mil_f_8785c():
    # 1000 ft: L_u = L_v = 1000/(0.177 + 0.823)^1.2 = 1000 ft = L_w
    np.testing.assert_allclose(dryden_length_scales(1000 * FOOT), [304.8] * 3, rtol=1e-12)
    h = 100.0  # ft
    l_uv = h / (0.177 + 0.000823 * h) ** 1.2
    np.testing.assert_allclose(dryden_length_scales(h * FOOT), np.array([l_uv, l_uv, h]) * FOOT)
    # clamped to the model's range [10, 1000] ft
    np.testing.assert_array_equal(dryden_length_scales(1.0), dryden_length_scales(10 * FOOT))
    np.testing.assert_array_equal(dryden_length_scales(1e4), dryden_length_scales(1000 * FOOT))


def test_realisation_reproduces_the_dryden_transfer_functions():
    scales, v_ref = np.array([40.0, 25.0, 6.0]), 8.0
    a, b, c = dryden_state_space(SIGMA, scales, v_ref)
    lu, lv, lw = scales
    for omega in (0.01, 0.3, 1.0, 7.0, 50.0):
        s = 1j * omega
        h = c @ np.linalg.solve(s * np.eye(5) - a, b)
        h_u = SIGMA[0] * np.sqrt(2 * lu / (np.pi * v_ref)) / (1 + lu / v_ref * s)
        h_v, h_w = (
            sig * np.sqrt(ell / (np.pi * v_ref)) * (1 + np.sqrt(3) * ell / v_ref * s)
            / (1 + ell / v_ref * s) ** 2
            for sig, ell in ((SIGMA[1], lv), (SIGMA[2], lw))
        )
        # a standard Wiener process has one-sided spectral density 1/pi: gain sqrt(pi) H
        np.testing.assert_allclose(h, np.sqrt(np.pi) * np.diag([h_u, h_v, h_w]), atol=1e-12)


@pytest.mark.parametrize("dt", [1e-5, 1e-3, 0.01, 0.05, 0.3, 2.0, 50.0, 1e4])
def test_discrete_step_preserves_sigma_exactly(dt):
    field = DrydenWind(sigma=SIGMA, seed=0)
    _, _, c = field.state_space
    p = field.stationary_covariance
    phi, q = field.transition(dt)
    np.testing.assert_allclose(np.diag(c @ p @ c.T), SIGMA**2, rtol=1e-12)
    np.testing.assert_allclose(np.diag(c @ (phi @ p @ phi.T + q) @ c.T), SIGMA**2, rtol=1e-10)
    assert np.all(np.linalg.eigvalsh(q) > -1e-12 * np.abs(q).max())


@pytest.mark.parametrize("dt", [1e-3, 0.05, 0.37, 1.5])
def test_van_loan_matches_the_stationary_identity(dt):
    # for a stationary start, Q = P - Phi P Phi^T exactly: an independent route to Q
    a, b, _ = dryden_state_space(SIGMA, [20.0, 10.0, 4.0], 10.0)
    p = scipy.linalg.solve_continuous_lyapunov(a, -b @ b.T)
    phi, q = van_loan(a, b, dt)
    np.testing.assert_allclose(phi, scipy.linalg.expm(a * dt), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(q, p - phi @ p @ phi.T, rtol=1e-9, atol=1e-12 * np.abs(p).max())


def test_sample_std_within_5_percent_and_mean_within_tolerance(record):
    dt, field, w = record
    t_scales = field.time_scales
    # int_{-inf}^{inf} rho and rho^2 for u, v, w
    int_rho = np.array([2.0, 1.0, 1.0]) * t_scales
    int_rho2 = np.array([1.0, 5.0 / 8.0, 5.0 / 8.0]) * t_scales
    sd_rel_std = 0.5 * np.sqrt(2 * int_rho2 / DURATION)
    sd_mean = SIGMA * np.sqrt(int_rho / DURATION)
    assert np.all(K_SD * sd_rel_std < 0.05), "run too short for a 5 % check"
    rel = w.std(axis=0) / SIGMA - 1
    assert np.all(np.abs(rel) < 0.05), rel
    assert np.all(np.abs(rel) < K_SD * sd_rel_std), (rel, sd_rel_std)
    assert np.all(np.abs(w.mean(axis=0) - MEAN) < K_SD * sd_mean), (w.mean(0), sd_mean)


def _lag1(x: np.ndarray) -> float:
    x = x - x.mean()
    return float(np.dot(x[:-1], x[1:]) / np.dot(x, x))


def test_gusts_are_coloured_with_dryden_correlation(record):
    dt, field, w = record
    n = w.shape[0]
    t_u, t_v, t_w = field.time_scales
    for axis, kind, tau in ((0, "u", t_u), (1, "v", t_v), (2, "w", t_w)):
        rho_hat = _lag1(w[:, axis])
        expected = float(_rho(kind, np.array(dt), tau))
        white_sd = 1 / math.sqrt(n)
        assert rho_hat > 0.5 and rho_hat > 100 * white_sd  # far from white noise (~0)
        tol = K_SD * _bartlett_lag1_sd(kind, dt, tau, n)
        assert abs(rho_hat - expected) < tol, (kind, rho_hat, expected, tol)
        # the model's own autocorrelation agrees with the closed form
        assert field.lag_correlation(dt)[axis] == pytest.approx(expected, rel=1e-10)
    # u: exactly exp(-dt V / L_u)
    assert float(_rho("u", np.array(dt), t_u)) == pytest.approx(
        math.exp(-dt * field.airspeed / field.length_scales[0])
    )


def test_sample_equals_repeated_velocity_queries():
    times = np.concatenate([0.002 * np.arange(1, 301), 0.6 + 0.05 * np.arange(1, 21),
                            [1.7, 1.7, 4.0]])
    a = DrydenWind(mean=MEAN, sigma=SIGMA, seed=11)
    b = DrydenWind(mean=MEAN, sigma=SIGMA, seed=11)
    bulk = a.sample(times)
    loop = np.array([b.velocity(t, np.zeros((1, 3)))[0] for t in times])
    np.testing.assert_allclose(bulk, loop, rtol=0, atol=1e-12)
    assert a.time == b.time == 4.0
    np.testing.assert_allclose(a.velocity(5.0, np.zeros(3)), b.velocity(5.0, np.zeros(3)),
                               atol=1e-12)


def test_same_time_same_value_earlier_time_raises_and_reset_replays():
    field = DrydenWind(seed=5)
    first = field.velocity(0.5, np.zeros((2, 3)))
    np.testing.assert_array_equal(field.velocity(0.5, np.ones((4, 3))), np.tile(first[0], (4, 1)))
    with pytest.raises(ValueError, match="'t'"):
        field.velocity(0.4, np.zeros((1, 3)))
    with pytest.raises(ValueError, match="'times'"):
        field.sample([0.3])
    field.reset()
    np.testing.assert_array_equal(field.velocity(0.5, np.zeros((2, 3))), first)


def test_different_seeds_differ_and_sigma_zero_gives_mean():
    w0 = DrydenWind(seed=0).velocity(1.0, np.zeros((1, 3)))
    w1 = DrydenWind(seed=1).velocity(1.0, np.zeros((1, 3)))
    assert not np.allclose(w0, w1)
    calm = DrydenWind(mean=(1.0, 2.0, 3.0), sigma=(0.0, 0.0, 0.0), seed=0)
    np.testing.assert_array_equal(calm.sample([0.1, 1.0, 9.0]), np.tile([1.0, 2.0, 3.0], (3, 1)))


def test_independent_realisations_per_row():
    r = 64
    field = DrydenWind(mean=MEAN, sigma=SIGMA, seed=9, batch_size=r, length_scales=(5, 5, 2))
    w = field.sample(0.05 * np.arange(1, 4001))  # (K, R, 3), 200 s = 100 T_u
    assert w.shape == (4000, r, 3)
    # rows are independent: cross-correlation between realisations ~ 0
    corr = np.corrcoef(w[:, :, 0].T)
    off = corr[~np.eye(r, dtype=bool)]
    assert np.abs(off).max() < 0.5 and abs(off.mean()) < 0.02
    # and together they have the right spread
    np.testing.assert_allclose(w.reshape(-1, 3).std(axis=0), SIGMA, rtol=0.05)
    with pytest.raises(ValueError, match="'xyz'"):
        field.velocity(300.0, np.zeros((r - 1, 3)))
    assert field.velocity(300.0, np.zeros((r, 3))).shape == (r, 3)


@pytest.mark.parametrize(
    "kwargs, name",
    [({"sigma": (1, -1, 1)}, "sigma"), ({"airspeed": 0.0}, "airspeed"),
     ({"altitude": -2.0}, "altitude"), ({"length_scales": (1, 0, 1)}, "length_scales"),
     ({"mean": (1, np.nan, 0)}, "mean"), ({"seed": -1}, "seed"), ({"seed": 1.5}, "seed"),
     ({"batch_size": 0}, "batch_size")],
)
def test_bad_parameters_raise_naming_them(kwargs, name):
    with pytest.raises(ValueError, match=f"'{name}'"):
        DrydenWind(**kwargs)
