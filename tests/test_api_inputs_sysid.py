"""Bad inputs to the sysid library functions and their experiments are refused by name, up
front (Python API audit, fifty-eighth session). Each case says what happened before."""

from __future__ import annotations

import numpy as np
import pytest

import windnav.experiments.power_curve as PC
import windnav.experiments.sysid as SY
import windnav.sysid.aero as A
import windnav.sysid.power as P
import windnav.sysid.unsteadiness as U
from windnav.sysid.similitude import Similitude

NAN = np.nan


# ------------------------------------------------------------------------------ similitude


def test_similitude_keeps_the_validated_diameters():
    # Python API audit, fifty-eighth session: Similitude('1.8', 0.055) passed its check and
    # failed in the arithmetic with a TypeError (str / float)
    s = Similitude("1.8", 0.055)
    assert s.full_scale_diameter == 1.8 and s.length_scale == pytest.approx(1.8 / 0.055)
    with pytest.raises(ValueError, match="'model_diameter' parameter of Similitude must be a "
                                         "number"):
        Similitude(1.8, True)


@pytest.mark.parametrize("call, name", [
    (lambda s: s.model_mass(-3), "'full_scale_mass' parameter of Similitude.model_mass"),
    (lambda s: s.model_speed(NAN), "'full_scale_speed' parameter of Similitude.model_speed"),
    (lambda s: s.reynolds_model_speed(-5),
     "'full_scale_speed' parameter of Similitude.reynolds_model_speed"),
    (lambda s: s.full_scale_speed(-1), "'model_speed' parameter of Similitude.full_scale_speed"),
    (lambda s: s.model_frequency(NAN),
     "'full_scale_frequency' parameter of Similitude.model_frequency"),
    (lambda s: s.full_scale_frequency(-2),
     "'model_frequency' parameter of Similitude.full_scale_frequency"),
])
def test_similitude_scalings_refuse_negative_and_nan(call, name):
    # Python API audit, fifty-eighth session: a mass of -3 kg gave -9.2e-5 kg, a NaN speed NaN,
    # a speed of -5 m/s a Reynolds-matched -160 m/s
    with pytest.raises(ValueError, match=name):
        call(Similitude.thesis())


# ------------------------------------------------------------------------------ power


T = np.arange(100) * 0.1
V = np.full(100, 5.0)


@pytest.mark.parametrize("kwargs, match", [
    ({"altitude": T}, "'min_altitude' parameter of steady_level_mask must be given with "
                      "altitude"),
    ({"min_altitude": 5}, "'altitude' parameter of steady_level_mask must be given with "
                          "min_altitude"),
    ({"vertical_speed": np.zeros(3)}, r"'vertical_speed' parameter of steady_level_mask must "
                                      r"be an array of shape \(100,\)"),
])
def test_steady_level_mask_refuses_an_argument_it_would_ignore_or_misfit(kwargs, match):
    # Python API audit, fifty-eighth session: altitude without min_altitude (or the other way)
    # was ignored silently; a short vertical_speed was NumPy's broadcast error
    with pytest.raises(ValueError, match=match):
        P.steady_level_mask(T, V, **kwargs)


@pytest.mark.parametrize("t, v, match", [
    (T, V[:-3], r"'speed' parameter of steady_level_mask must be an array of shape \(100,\)"),
    ("abc", V, "'t' parameter of steady_level_mask must be an array of numbers"),
])
def test_steady_level_mask_names_bad_arrays(t, v, match):
    # Python API audit, fifty-eighth session: a broadcast error; "could not convert string"
    with pytest.raises(ValueError, match=match):
        P.steady_level_mask(t, v)


def test_steady_level_mask_with_altitude_still_selects():
    alt = np.linspace(0.0, 10.0, 100)
    keep = P.steady_level_mask(T, V, altitude=alt, min_altitude=5.0, min_segment_s=0.0)
    np.testing.assert_array_equal(keep, alt > 5.0)


SPEEDS = np.repeat(np.linspace(0.0, 5.0, 11), 3)


@pytest.mark.parametrize("residuals, n_params, match", [
    (np.full(SPEEDS.size, NAN), 2, "'residuals' parameter of lack_of_fit_test must be finite"),
    (np.zeros(SPEEDS.size), -3, "'n_params' parameter of lack_of_fit_test must be an integer "
                                ">= 1"),
    (np.zeros(5), 4, r"'residuals' parameter of lack_of_fit_test must be an array of shape "
                     r"\(33,\), one per speed"),
])
def test_lack_of_fit_test_refuses_bad_residuals_and_parameter_counts(residuals, n_params, match):
    # Python API audit, fifty-eighth session: NaN residuals gave F NaN, "not rejected";
    # n_params = -3 was tested; 5 residuals for 33 speeds was "The weights and list don't
    # have the same length"
    with pytest.raises(ValueError, match=match):
        P.lack_of_fit_test(SPEEDS, residuals, n_params)


def test_fit_power_and_hover_check_name_bad_arguments():
    # Python API audit, fifty-eighth session: winds=3.0 was "'float' object is not iterable"
    # after the fit, a str speed NumPy's conversion error, hover_check({}) an AttributeError
    power = 10.0 + SPEEDS**2
    with pytest.raises(ValueError, match="'winds' parameter of fit_power must be a sequence"):
        P.fit_power(SPEEDS, power, winds=3.0)
    with pytest.raises(ValueError, match="'speed' parameter of fit_power must be an array of "
                                         "numbers"):
        P.fit_power("abc", power)
    with pytest.raises(ValueError, match="'fit' parameter of hover_check must be a PowerFit"):
        P.hover_check({})
    fit = P.fit_power(SPEEDS, power, winds=iter([-1.0, 1.0]))  # any iterable, as before
    assert [r["wind_m_s"] for r in fit.in_wind] == [-1.0, 1.0]


# ------------------------------------------------------------------------------ unsteadiness


Q = np.tile([0.0, 0.0, 0.0, 1.0], (3, 1))


@pytest.mark.parametrize("attitude, eta, match", [
    ([0.0, 0.0, 0.0, 1.0], np.full((1, 4), 500.0),
     r"'attitude' parameter of lateral_force_command must be an array of shape \(K, 4\)"),
    (Q, np.full((2, 4), 500.0), "'rotor_speed_cmd' parameter of lateral_force_command must be "
                                "an array of shape"),
    (Q, np.full(3, 500.0), "'rotor_speed_cmd' parameter of lateral_force_command must be an "
                           "array of shape"),
    (np.where(np.arange(4) == 0, NAN, Q), np.full((3, 4), 500.0),
     "'attitude' parameter of lateral_force_command must be finite"),
    (np.zeros((3, 4)), np.full((3, 4), 500.0),
     "'attitude' parameter of lateral_force_command must hold unit quaternions"),
])
def test_lateral_force_command_checks_shapes_and_values(attitude, eta, match):
    # Python API audit, fifty-eighth session: an IndexError, a broadcast error, an AxisError,
    # SciPy's "Found zero norm quaternions"
    with pytest.raises(ValueError, match=match):
        U.lateral_force_command(attitude, eta, 1e-5)


XY = np.zeros((4, 2))
RATES = np.zeros((4, 3))


@pytest.mark.parametrize("arrays, match", [
    ((XY, np.full((4, 2), NAN), XY, RATES), "'wind_xy' parameter of FlightSamples must be "
                                            "finite"),
    ((np.zeros((4, 3)), XY, XY, RATES), r"'xy' parameter of FlightSamples must be an array of "
                                        r"shape \(K, 2\)"),
    ((XY, XY, XY, np.zeros((4, 2))), r"'body_rates' parameter of FlightSamples must be an "
                                     r"array of shape \(K, 3\) with K = 4"),
    ((XY, XY[:3], XY, RATES), "'wind_xy' parameter of FlightSamples must be an array of shape"),
    ((np.zeros(4), XY, XY, RATES), "'xy' parameter of FlightSamples must be an array of shape"),
    (("abc", XY, XY, RATES), "'xy' parameter of FlightSamples must be an array of numbers"),
])
def test_flight_samples_check_their_arrays(arrays, match):
    # Python API audit, fifty-eighth session: NaN winds mapped NaN bins counted occupied, (K, 3)
    # positions and (K, 2) rates were accepted, others failed in NumPy
    with pytest.raises(ValueError, match=match):
        U.FlightSamples(*arrays)


@pytest.mark.parametrize("values, x_edges, match", [
    (np.ones((4, 1)), [3, 2, 1, 0], "'x_edges' parameter of bin_xy must increase strictly"),
    (np.ones(4), [0, 1, 2, 3], r"'values' parameter of bin_xy must be an array of shape "
                               r"\(K, C\)"),
    (np.ones((4, 1)), [], "'x_edges' parameter of bin_xy must be an array of shape"),
])
def test_bin_xy_checks_its_arguments(values, x_edges, match):
    # Python API audit, fifty-eighth session: decreasing edges gave all-zero counts, 1-D values
    # an IndexError, empty edges "minlength must not be negative"
    with pytest.raises(ValueError, match=match):
        U.bin_xy(np.ones((4, 2)), values, x_edges, [0, 1, 2, 3])


def test_flight_samples_from_log_names_a_log_that_is_not_one():
    # Python API audit, fifty-eighth session: an AttributeError
    with pytest.raises(ValueError, match="'log' parameter of flight_samples_from_log must be a "
                                         "FlightLog"):
        U.flight_samples_from_log(None, 1e-5)


# ------------------------------------------------------------------------------ aero


def _aero(n=50, step=0.02):
    return A.AeroData(np.arange(n) * step, np.zeros((n, 3)), np.zeros((n, 3)), np.ones((n, 4)))


def test_block_average_refuses_a_window_that_overflows_its_blocks():
    # Python API audit, fifty-eighth session: 1e-300 s overflowed the int64 block keys and
    # averaged the 50 samples into 2 blocks
    with pytest.raises(ValueError, match="'window_s' parameter of block_average is too small"):
        A.block_average(_aero(), 1e-300)
    assert A.block_average(_aero(), 1e-12).t.size == 50  # one sample a block, as it should


@pytest.mark.parametrize("call, match", [
    (lambda: A.block_average({}, 1.0), "'data' parameter of block_average must be an AeroData"),
    (lambda: A.aero_from_flight_log(None), "'log' parameter of aero_from_flight_log must be a "
                                           "FlightLog"),
    (lambda: A.aero_and_status_from_flight_log(None),
     "'log' parameter of aero_and_status_from_flight_log must be a FlightLog"),
    (lambda: A.aero_columns(0), "'n_rotors' parameter of aero_columns must be an integer >= 1"),
    (lambda: A.aero_columns(-2), "'n_rotors' parameter of aero_columns must be an integer >= 1"),
    (lambda: A.AeroData(np.arange(3.0), np.zeros((3, 3)), np.zeros((3, 3)), np.ones((3, 4)),
                        dropped=-3), "'dropped' parameter of AeroData must be an integer >= 0"),
])
def test_aero_functions_name_bad_arguments(call, match):
    # Python API audit, fifty-eighth session: AttributeErrors; a header without rotor columns;
    # -3 dropped rows accepted
    with pytest.raises(ValueError, match=match):
        call()


# ------------------------------------------------------------------------------ experiments


@pytest.fixture(scope="module")
def thesis():
    return SY.vehicle_params(SY.THESIS_VEHICLE)


@pytest.mark.parametrize("kwargs, match", [
    ({"voltages": [0]}, "'voltages' parameter of simulate_stand must hold distinct numbers > 0"),
    ({"voltages": [-3.7]}, "'voltages' parameter of simulate_stand must hold distinct numbers"),
    ({"voltages": []}, "'voltages' parameter of simulate_stand must be a non-empty sequence"),
    ({"voltages": [3.7, 3.7]}, "'voltages' parameter of simulate_stand must hold distinct"),
    ({"pwm_steps": [-1000]}, "'pwm_steps' parameter of simulate_stand must hold PWM commands "
                             ">= 0"),
    ({"pwm_steps": [NAN]}, "'pwm_steps' parameter of simulate_stand must be a non-empty "
                           "sequence of finite"),
    ({"step_s": 0}, "'step_s' parameter of simulate_stand must be a finite number > 0"),
    ({"step_s": 1e7}, "'rate_hz' parameter of simulate_stand must give 1 to 1,000,000 samples"),
    ({"step_s": 1e300, "rate_hz": 1e300}, "'rate_hz' parameter of simulate_stand must give 1"),
    ({"rate_hz": 0}, "'rate_hz' parameter of simulate_stand must be a finite number > 0"),
    ({"rate_hz": -100}, "'rate_hz' parameter of simulate_stand must be a finite number > 0"),
    ({"rate_hz": NAN}, "'rate_hz' parameter of simulate_stand must be a finite number > 0"),
    ({"rng": -1}, "'rng' parameter of simulate_stand must be a numpy.random.Generator"),
    ({"noise": {}}, "'noise' parameter of simulate_stand must be a StandNoise"),
])
def test_simulate_stand_checks_its_arguments_up_front(thesis, kwargs, match):
    # Python API audit, fifty-eighth session: 0 V drew rpm with a divide-by-zero, -3.7 V ran,
    # [] gave no ramp, 3.7 twice two ramps, PWM -1000 or NaN ran, a 0 s step empty columns,
    # 1e7 s a 67 GiB MemoryError, 0/-100/NaN Hz NumPy's errors, seed -1 NumPy's message
    with pytest.raises(ValueError, match=match):
        SY.simulate_stand(thesis, **kwargs)


def test_simulate_stand_still_runs(thesis):
    runs = SY.simulate_stand(thesis, voltages=[3.0, 4], pwm_steps=[20_000, 30_000], step_s=0.1,
                             rate_hz=50)
    assert [r["voltage"] for r in runs] == [3.0, 4.0]
    assert runs[0]["columns"]["pwm"].size == 10


@pytest.mark.parametrize("call, match", [
    (lambda: SY.StandNoise(thrust_N=-1), "'thrust_N' parameter of StandNoise must be a finite "
                                         "number >= 0"),
    (lambda: SY.StandNoise(thrust_N=NAN), "'thrust_N' parameter of StandNoise"),
    (lambda: SY.TunnelNoise(accel_bias=(1, 2)), "'accel_bias' parameter of TunnelNoise must be "
                                                "3 finite numbers"),
    (lambda: SY.TunnelNoise(accel_bias=(0, NAN, 0)), "'accel_bias' parameter of TunnelNoise"),
    (lambda: SY.TunnelNoise(airspeed_m_s=-0.1), "'airspeed_m_s' parameter of TunnelNoise"),
    (lambda: SY.stand_csv_name(NAN), "'voltage' parameter of stand_csv_name must be a finite "
                                     "number > 0"),
    (lambda: SY.stand_csv_name("3.7"), "'voltage' parameter of stand_csv_name must be a "
                                       "number"),
])
def test_noise_and_file_names_are_checked(call, match):
    # Python API audit, fifty-eighth session: negative or NaN noise and a 2-component bias were
    # accepted; NaN V was named 'stand_nanV.csv', '3.7' Python's format error
    with pytest.raises(ValueError, match=match):
        call()


def test_noise_and_file_names_keep_valid_values():
    assert SY.TunnelNoise(accel_bias=(0, 0, 0)).accel_bias == (0, 0, 0)  # truth.json lists it
    assert SY.StandNoise(thrust_N=0).thrust_N == 0.0
    assert SY.stand_csv_name(3.7) == "stand_3.70V.csv"


@pytest.mark.parametrize("kwargs, match", [
    ({"dt": 1.0}, "'dt' parameter of simulate_tunnel must divide the IMU's sample period"),
    ({"dt": 0}, "'dt' parameter of simulate_tunnel must be a finite number > 0"),
    ({"settle_s": -1}, "'settle_s' parameter of simulate_tunnel must be a finite number >= 0"),
    ({"record_s": "1"}, "'record_s' parameter of simulate_tunnel must be a number"),
    ({"noise": None}, "'noise' parameter of simulate_tunnel must be a TunnelNoise"),
])
def test_simulate_tunnel_checks_before_flying(thesis, kwargs, match):
    # Python API audit, fifty-eighth session: dt = 1 s was named "The 'sensors' parameter's imu
    # rate_hz of fly", dt = 0 fly's, settle_s = -1 aero_from_flight_log's after the flights
    with pytest.raises(ValueError, match=match):
        SY.simulate_tunnel(thesis, **kwargs)


@pytest.mark.parametrize("points, degree", [(1, 4), (4, 5), (21, 30)])
def test_power_curve_study_names_points_and_degree_before_the_sweep(points, degree):
    # Python API audit, fifty-eighth session: simulated_power_curve's 'max_speed' was blamed,
    # "it leaves it at None m/s ... sweep more points below None m/s"
    with pytest.raises(ValueError, match="'points' parameter of power_curve_study must be at "
                                         f"least degree \\+ 1 = {degree + 1}") as err:
        PC.power_curve_study("hummingbird", points=points, degree=degree)
    assert "None" not in str(err.value)


def test_power_curve_study_refuses_a_bad_degree():
    with pytest.raises(ValueError, match="'degree' parameter of power_curve_study must be an "
                                         "integer >= 1"):
        PC.power_curve_study("hummingbird", degree=0)


def test_endurance_check_names_its_arguments():
    # Python API audit, fifty-eighth session: endurance_check(None, ...) was a raw TypeError
    from windnav.vehicle.power import PowerCurve

    with pytest.raises(ValueError, match="'curve' parameter of endurance_check must be a "
                                         "PowerCurve"):
        PC.endurance_check(None, [0.0, 1.0, 2.0], [1.0, 2.0, 3.0])
    with pytest.raises(ValueError, match="'powers' parameter of endurance_check must be a "
                                         "sequence of 3 numbers"):
        PC.endurance_check(PowerCurve.crazyflie(), [0.0, 1.0, 2.0], [1.0, 2.0])


def test_power_study_keeps_the_altitude_rule_of_sysid_power():
    # Python API audit, fifty-eighth session: steady_level_mask now refuses altitude without
    # min_altitude; power_study refuses either one without the other (each was ignored)
    from windnav.sysid.io import Table

    t = np.arange(600) * 0.1
    speed = np.repeat(np.linspace(0.0, 5.0, 6), 100)
    alt = np.where(speed > 4.5, 1.0, 3.0)        # the fastest 100 rows below 2 m
    table = Table("t.csv", {"t": t, "v": speed, "p": 10.0 + speed**2 + 0.01 * np.sin(t),
                            "alt": alt})
    fit, doc = SY.power_study(table, "v", "p", time_col="t", altitude_col="alt",
                              min_altitude=2.0, degree=2)
    plain, plain_doc = SY.power_study(table, "v", "p", time_col="t", degree=2)
    assert doc["selection"]["steady_level"] < plain_doc["selection"]["steady_level"]
    assert not np.array_equal(fit.fit.coef, plain.fit.coef)
    for kwargs in ({"altitude_col": "alt", "min_altitude": 2.0}, {"vertical_speed_col": "v"}):
        with pytest.raises(ValueError, match="'time_col' parameter of power_study must be "
                                             "given with"):
            SY.power_study(table, "v", "p", degree=2, **kwargs)
    with pytest.raises(ValueError, match="'altitude_col' parameter of power_study must be given "
                                         "with min_altitude"):
        SY.power_study(table, "v", "p", time_col="t", min_altitude=2.0, degree=2)
    with pytest.raises(ValueError, match="'min_altitude' parameter of power_study must be given "
                                         "with altitude_col"):
        SY.power_study(table, "v", "p", time_col="t", altitude_col="alt", degree=2)


def test_the_froude_scalings_take_arrays_of_amounts():
    # review of the audit's mends: an array of speeds scaled element by element before the
    # checks, and was refused by them ("must be a number")
    from windnav.sysid.similitude import Similitude

    sim = Similitude.thesis()
    speeds = np.array([0.0, 2.0, 8.0])
    np.testing.assert_array_equal(sim.model_speed(speeds), [sim.model_speed(v) for v in speeds])
    np.testing.assert_array_equal(sim.model_mass([1.0, 2.0]),
                                  [sim.model_mass(1.0), sim.model_mass(2.0)])
    for bad in ([1.0, -2.0], [1.0, np.nan], ["a", "b"]):
        with pytest.raises(ValueError, match="'full_scale_speed' parameter of "
                                             "Similitude.model_speed must hold finite numbers"):
            sim.model_speed(bad)
    with pytest.raises(ValueError, match="must hold finite numbers > 0"):
        sim.model_mass([1.0, 0.0])
