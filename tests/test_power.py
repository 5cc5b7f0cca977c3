"""Power models: rotor shaft power, energy integration, steady-flight curves and best speeds."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.integrate

from windnav.vehicle.params import params
from windnav.vehicle.power import (
    PowerCurve,
    energy,
    max_endurance_speed,
    max_range_speed,
    rotor_power,
)


def _sig3(x: float) -> str:
    return f"{x:.3g}"


# --- (a) rotor power and energy ------------------------------------------------------------
def test_rotor_power_is_sum_of_drag_torque_times_speed():
    rng = np.random.default_rng(0)
    eta = rng.uniform(500, 2500, (6, 4))
    k_m = 7.8e-10
    expected = np.array([sum(k_m * e**2 * e for e in row) for row in eta]) / 0.8
    np.testing.assert_allclose(rotor_power(eta, k_m, efficiency=0.8), expected, rtol=1e-14)
    # cube law, sign of spin irrelevant, one k_m per vehicle allowed
    np.testing.assert_allclose(rotor_power(2 * eta, k_m), 8 * rotor_power(eta, k_m))
    np.testing.assert_array_equal(rotor_power(-eta, k_m), rotor_power(eta, k_m))
    per_vehicle = rotor_power(eta, np.full(6, k_m) * np.arange(1, 7))
    np.testing.assert_allclose(per_vehicle, rotor_power(eta, k_m) * np.arange(1, 7))


def test_hover_power_of_a_builtin_vehicle():
    p = params("hummingbird")
    eta_h = p.hover_rotor_speed
    power = rotor_power(np.full((1, p.n_rotors), eta_h), p.k_m, p.motor_efficiency)
    # N rotors each carrying W/N: P = N k_m eta_h^3 / efficiency
    assert power[0] == pytest.approx(p.n_rotors * p.k_m * eta_h**3 / p.motor_efficiency)
    assert rotor_power(np.full(p.n_rotors, eta_h), p.k_m).shape == (1,)


def test_energy_is_cumulative_trapezoid():
    t = np.linspace(0.0, 10.0, 101)
    const = energy(t, np.full(t.size, 12.5))
    np.testing.assert_allclose(const, 12.5 * t, atol=1e-12)
    ramp = energy(t, np.column_stack([3.0 * t, 1.0 + t]))  # (T, 2): integrated per column
    np.testing.assert_allclose(ramp[:, 0], 1.5 * t**2, atol=1e-10)  # exact for linear P
    np.testing.assert_allclose(ramp[:, 1], t + 0.5 * t**2, atol=1e-10)
    rng = np.random.default_rng(1)
    tt = np.sort(rng.uniform(0, 5, 50))
    pp = rng.uniform(5, 15, (50, 3, 2))
    e = energy(tt, pp)
    assert e.shape == pp.shape and np.all(e[0] == 0) and np.all(np.diff(e, axis=0) >= 0)
    np.testing.assert_allclose(e[-1], scipy.integrate.trapezoid(pp, tt, axis=0))


@pytest.mark.parametrize(
    "call, name",
    [(lambda: rotor_power(np.zeros((2, 2, 2)), 1e-9), "rotor_speeds"),
     (lambda: rotor_power([[np.nan, 1.0]], 1e-9), "rotor_speeds"),
     (lambda: rotor_power(np.ones((2, 4)), -1.0), "k_m"),
     (lambda: rotor_power(np.ones((2, 4)), np.ones(3)), "k_m"),
     (lambda: rotor_power(np.ones((2, 4)), 1e-9, efficiency=1.2), "efficiency"),
     (lambda: rotor_power(np.ones((2, 4)), 1e-9, efficiency=0.0), "efficiency"),
     (lambda: energy([0.0, 2.0, 1.0], [1.0, 1.0, 1.0]), "t"),
     (lambda: energy([0.0, 1.0], [1.0, 1.0, 1.0]), "power")],
)
def test_bad_inputs_raise_naming_them(call, name):
    with pytest.raises(ValueError, match=f"'{name}'"):
        call()


# --- (b) the thesis's Crazyflie curve -------------------------------------------------------
def test_crazyflie_curve_reproduces_its_four_defining_numbers():
    curve = PowerCurve.crazyflie()
    v_e = max_endurance_speed(curve)
    best = max_range_speed(curve, 0.0)
    assert _sig3(float(curve(0.0))) == "10.6" and float(curve(0.0)) == pytest.approx(10.56)
    assert _sig3(float(curve(v_e))) == "10.1" and float(curve(v_e)) == pytest.approx(10.12)
    assert _sig3(v_e) == "4.15"
    assert _sig3(best.ground_speed) == "7.73" and best.airspeed == pytest.approx(7.73, abs=1e-6)
    # no-wind tangency from the origin: P'(V_R) V_R = P(V_R), e = P(V_R)/V_R = P'(V_R)
    assert curve.derivative(best.ground_speed) * best.ground_speed == pytest.approx(
        float(curve(best.ground_speed)), rel=1e-8)
    assert best.energy_per_metre == pytest.approx(float(curve.derivative(7.73)), rel=1e-6)
    np.testing.assert_allclose(curve.coefficients,
                               [10.56, 0.151596, -0.149702, 0.0211145], rtol=2e-5)


def test_crazyflie_curve_is_a_proper_bucket():
    curve = PowerCurve.crazyflie()
    v = np.linspace(0.0, curve.speed_max, 120_001)
    p = curve(v)
    assert v[np.argmin(p)] == pytest.approx(4.15, abs=1e-3)
    # exactly one local minimum on [0, speed_max]: P' changes sign from - to + once
    slope_sign = np.sign(curve.derivative(v[1:-1]))
    minima = np.flatnonzero((slope_sign[:-1] < 0) & (slope_sign[1:] > 0))
    assert minima.size == 1
    second = 2 * curve.coefficients[2] + 6 * curve.coefficients[3] * v
    assert np.all(second[(v > 2.5) & (v < 12.0)] > 0)  # convex around (and beyond) the bucket
    assert float(curve(12.0)) > float(curve(0.0)) > float(curve(4.15))


def test_headwind_raises_and_tailwind_lowers_the_best_airspeed():
    curve = PowerCurve.crazyflie()
    winds = np.linspace(-4.0, 4.0, 17)  # headwind (< 0) to tailwind (> 0)
    opt = [max_range_speed(curve, w) for w in winds]
    airspeeds = np.array([o.airspeed for o in opt])
    energies = np.array([o.energy_per_metre for o in opt])
    assert np.all(np.diff(airspeeds) < 0)
    assert np.all(np.diff(energies) < 0)  # a tailwind always saves energy per metre
    still = max_range_speed(curve, 0.0)
    assert max_range_speed(curve, -2.0).airspeed > still.airspeed > max_range_speed(
        curve, 2.0).airspeed
    for o, w in zip(opt, winds, strict=True):
        assert o.airspeed == pytest.approx(abs(o.ground_speed - w))
        assert o.power == pytest.approx(float(curve(o.airspeed)))


@pytest.mark.parametrize("wind", [-3.0, -1.0, 0.0, 1.5, 3.0])
def test_max_range_speed_closed_form(wind):
    # P = a + b V^2: d/dV [(a + b (V - W)^2) / V] = 0  =>  V_R = sqrt(a/b + W^2)
    a, b = 4.0, 0.25
    curve = PowerCurve((a, 0.0, b), speed_max=30.0)
    best = max_range_speed(curve, wind)
    v_r = np.sqrt(a / b + wind**2)
    assert best.ground_speed == pytest.approx(v_r, rel=1e-7)
    assert best.energy_per_metre == pytest.approx((a + b * (v_r - wind) ** 2) / v_r, rel=1e-12)


def test_max_endurance_speed_closed_form():
    curve = PowerCurve((10.0 + 0.3 * 5.5**2, -2 * 0.3 * 5.5, 0.3), speed_max=20.0)  # min at 5.5
    assert max_endurance_speed(curve) == pytest.approx(5.5, abs=1e-7)


def test_headwind_beyond_speed_max_is_rejected():
    with pytest.raises(ValueError, match="'wind_along'"):
        max_range_speed(PowerCurve.crazyflie(), -12.0)


def test_from_samples_recovers_a_known_polynomial():
    true = np.array([9.0, -0.8, 0.2, -0.01, 0.0007])
    speeds = np.linspace(0.0, 12.0, 25)
    powers = np.polynomial.polynomial.polyval(speeds, true)
    fit = PowerCurve.from_samples(speeds, powers)  # default degree 4
    np.testing.assert_allclose(fit.coefficients, true, rtol=1e-8, atol=1e-10)
    assert fit.speed_max == 12.0
    # noisy samples: the least-squares fit averages the noise away
    rng = np.random.default_rng(2)
    noisy = PowerCurve.from_samples(np.repeat(speeds, 20),
                                    np.repeat(powers, 20) + rng.normal(0, 0.05, 500))
    np.testing.assert_allclose(noisy(speeds), powers, atol=0.03)
    quad = PowerCurve.from_samples([0, 1, 2, 3], [1, 2, 5, 10], degree=2)
    np.testing.assert_allclose(quad.coefficients, [1.0, 0.0, 1.0], atol=1e-12)


@pytest.mark.parametrize(
    "call, name",
    [(lambda: PowerCurve.from_samples([0, 1, 2], [1, 2, 3], degree=4), "speeds"),
     (lambda: PowerCurve.from_samples([0, 1, 2], [1, 2], degree=1), "powers"),
     (lambda: PowerCurve.from_samples([0, 1, 2], [1, 2, 3], degree=0), "degree"),
     (lambda: PowerCurve((np.nan, 1.0)), "coefficients"),
     (lambda: PowerCurve((1.0, 1.0), speed_max=-1), "speed_max"),
     (lambda: PowerCurve((1.0,))(-1.0), "airspeed"),
     (lambda: PowerCurve.from_conditions(10, 9, 5, 4), "max_range_speed"),
     # audit 2026-12-05: a "minimum" above hover made a local maximum; extreme speeds gave a
     # LinAlgError or an OverflowError
     (lambda: PowerCurve.from_conditions(10, 20, 4, 7), "min_power"),
     (lambda: PowerCurve.from_conditions(10, 5, 1e-300, 7), "min_power_speed"),
     (lambda: PowerCurve.from_conditions(10, 5, 4, 1e300), "min_power_speed")],
)
def test_bad_curve_inputs_raise_naming_them(call, name):
    with pytest.raises(ValueError, match=f"'{name}'"):
        call()


def test_a_curve_with_power_at_or_below_zero_is_refused():
    # from_conditions(10, 1, 4, 7) gave a cubic down to -8.9 W at 12 m/s whose "max-range
    # speed" was 12 m/s at -0.74 J/m; hand-made curves below 0 W gave negative energies per
    # metre at the ends of the search (audit of the low-level helpers)
    with pytest.raises(ValueError, match="'min_power'.* parameters of PowerCurve.from_conditions "
                                         "must give a cubic above 0 W"):
        PowerCurve.from_conditions(10, 1, 4, 7)
    with pytest.raises(ValueError, match="'speed_max' parameter of PowerCurve.from_conditions"):
        PowerCurve.from_conditions(10.56, 10.12, 4.15, 7.73, speed_max=np.nan)
    for coefficients in ((10.0, 0.0, -1.0), (-1.0,), (0.0,), (10.0, -5.0, 0.5)):
        curve = PowerCurve(coefficients, speed_max=12.0)
        for wind in (0.0, 5.0, -3.0):
            with pytest.raises(ValueError, match="'curve' parameter of max_range_speed must have "
                                                 "a power above 0 W"):
                max_range_speed(curve, wind)
    assert max_range_speed(PowerCurve.from_conditions(10, 1, 4, 7, speed_max=8.0)).power > 0


@pytest.mark.parametrize("eff", [1.5, 0.0])
def test_a_vehicle_refuses_a_motor_efficiency_outside_0_to_1(eff):
    """``fly`` divides k_m by the vehicle's efficiency before ``rotor_power``, whose own check
    then never saw it: 1.5 logged less electrical power than the shaft's (audit, 2026-12-05)."""
    with pytest.raises(ValueError, match="'motor_efficiency' parameter of MultirotorParams"):
        params("hummingbird", motor_efficiency=eff)
