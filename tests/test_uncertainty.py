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


def test_drag_model_bias_of_a_filter_without_frame_drag():
    """A filter without the Hummingbird's frame drag reads ``c_d V^2 / (k_d N eta_h)`` too
    strong an airflow (the closed form), and the measured bias of a steady hover agrees; a
    filter with the vehicle's own model, or a vehicle without frame drag, reads none."""
    from windnav.estimate import drag_model_bias

    p = wn.vehicle.params("hummingbird")
    no_frame = p.replace(c_dx=0.0, c_dy=0.0, c_dz=0.0)
    v = np.array([0.0, 4.0, 8.0])
    s = p.n_rotors * p.hover_rotor_speed
    closed = p.c_dx * v**2 / (p.k_d * s)
    np.testing.assert_allclose(drag_model_bias(p, no_frame, v), closed, rtol=1e-12, atol=1e-15)
    assert drag_model_bias(p, no_frame, 4.0) == pytest.approx(0.358, abs=0.001)
    np.testing.assert_allclose(drag_model_bias(p, p, v), 0.0, atol=1e-12)
    np.testing.assert_allclose(drag_model_bias(p, no_frame, v, axis="z"),
                               p.c_dz * v**2 / (p.k_z * s), rtol=1e-12, atol=1e-15)
    # a filter whose k_d absorbed the drag (a linear calibration) reads it right at one speed
    k = p.k_d + p.c_dx * 4.0 / s
    assert drag_model_bias(p, no_frame.replace(k_d=k), 4.0) == pytest.approx(0.0, abs=1e-12)
    assert drag_model_bias(p, no_frame.replace(k_d=k), 8.0) > 0.5
    cf = wn.vehicle.params("crazyflie_brushless")
    np.testing.assert_allclose(drag_model_bias(cf, cf.replace(c_dx=0.0), v), 0.0, atol=1e-12)
    with pytest.raises(ValueError, match="'airspeed' parameter of drag_model_bias"):
        drag_model_bias(p, no_frame, -1.0)
    with pytest.raises(ValueError, match="'axis' parameter of drag_model_bias"):
        drag_model_bias(p, no_frame, 1.0, axis="w")
    with pytest.raises(ValueError, match="'believed' parameter of drag_model_bias"):
        drag_model_bias(p, "hummingbird", 1.0)
