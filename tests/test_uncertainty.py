"""A-priori wind uncertainty (appendix A): closed form, Monte Carlo, per-axis, comparison."""

import numpy as np
import pytest

import windnav as wn
from windnav.estimate import compare_vehicles, wind_uncertainty, wind_uncertainty_axes


def test_closed_form():
    # D = m / (k sum eta) = 0.5 / (1e-4 * 2000) = 2.5 s
    s = wind_uncertainty(0.5, 1e-4, 2000.0, sigma_accel=0.1, sigma_velocity=0.05)
    assert s == pytest.approx(np.sqrt(0.05**2 + (2.5 * 0.1) ** 2), rel=1e-14)
    rss = wind_uncertainty(0.5, 1e-4, 2000.0, 0.1, 0.05, bias_accel=0.02, bias_velocity=0.01)
    assert rss == pytest.approx(np.sqrt(0.05**2 + 0.25**2 + 0.01**2 + 0.05**2), rel=1e-14)
    worst = wind_uncertainty(0.5, 1e-4, 2000.0, 0.1, 0.05, bias_accel=-0.02, bias_velocity=0.01,
                             combine="worst")
    assert worst == pytest.approx(np.sqrt(0.05**2 + 0.25**2) + 0.01 + 0.05, rel=1e-14)
    assert worst >= rss


def test_matches_monte_carlo_of_the_single_sample_estimator():
    rng = np.random.default_rng(0)
    m, k, s, w, v = 0.5, 1.19e-4, 1900.0, 3.0, 1.0
    a_true = -(k * s / m) * (v - w)
    n = 200_000
    a = a_true + rng.normal(0, 0.2, n)
    vm = v + rng.normal(0, 0.03, n)
    w_hat = vm + m * a / (k * s)
    assert np.mean(w_hat) == pytest.approx(w, abs=0.01)
    assert np.std(w_hat) == pytest.approx(wind_uncertainty(m, k, s, 0.2, 0.03), rel=0.01)


def test_broadcasts_and_grows_with_mass():
    masses = np.array([0.1, 0.5, 1.0, 2.0])
    s = wind_uncertainty(masses, 1e-4, 2000.0, 0.1, 0.0)
    np.testing.assert_allclose(s, masses / 0.2 * 0.1, rtol=1e-14)


def test_per_axis_uses_kd_for_xy_and_kz_for_z():
    p = wn.vehicle.params("hummingbird")
    sig = wind_uncertainty_axes(p, 0.3, 0.035)
    total = p.n_rotors * p.hover_rotor_speed
    assert sig[0] == sig[1] == pytest.approx(wind_uncertainty(p.mass, p.k_d, total, 0.3, 0.035))
    assert sig[2] == pytest.approx(wind_uncertainty(p.mass, p.k_z, total, 0.3, 0.035))
    assert sig[2] < sig[0]   # k_z > k_d: vertical wind is sensed better
    per_axis = wind_uncertainty_axes(p, [0.3, 0.6, 0.3], 0.035)
    assert per_axis[1] > per_axis[0]


def test_compare_vehicles():
    rows = compare_vehicles(["hummingbird", "crazyflie_brushless"], 0.3, 0.035)
    assert [r["name"] for r in rows] == ["hummingbird", "crazyflie_brushless"]
    for r in rows:
        p = wn.vehicle.params(r["name"])
        np.testing.assert_allclose(r["sigma_wind"], wind_uncertainty_axes(p, 0.3, 0.035))
        assert r["drag_to_mass_xy"] == pytest.approx(p.k_d * r["rotor_speed_sum"] / p.mass)
    # the sensing gain k_d sum(eta)/m sets the ordering of the accelerometer term
    a, b = rows
    assert (a["sigma_wind"][0] < b["sigma_wind"][0]) == (a["drag_to_mass_xy"] >
                                                         b["drag_to_mass_xy"])


def test_rejects_bad_input():
    with pytest.raises(ValueError, match="'drag_coeff'"):
        wind_uncertainty(0.5, -1.0, 2000.0, 0.1, 0.05)
    with pytest.raises(ValueError, match="> 0"):
        wind_uncertainty(0.5, 0.0, 2000.0, 0.1, 0.05)
    with pytest.raises(ValueError, match="'sigma_accel'"):
        wind_uncertainty(0.5, 1e-4, 2000.0, np.nan, 0.05)
    with pytest.raises(ValueError, match="'combine'"):
        wind_uncertainty(0.5, 1e-4, 2000.0, 0.1, 0.05, combine="max")
