"""Bad inputs to the Dryden and constant winds, the flight harness and the two demos: each is
refused up front by a ValueError naming the argument (Python API audit, fifty-eighth session)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import windnav.wind.dryden as D
from windnav.wind.constant import ConstantWind

# Dryden ------------------------------------------------------------------------------------


@pytest.mark.parametrize("call, name", [
    (lambda: D.DrydenWind().velocity(1e9, [[0, 0, 0]]), "t"),
    (lambda: D.DrydenWind().velocity(1e300, [[0, 0, 0]]), "t"),
    (lambda: D.DrydenWind().sample([0.5, 1e9]), "times"),
    (lambda: D.DrydenWind(time_step=1e-12).velocity(1.0, [[0, 0, 0]]), "t"),
    (lambda: D.DrydenWind(batch_size=100).velocity(1e6, np.zeros((100, 3))), "t"),
])
def test_a_query_beyond_the_generation_cap_is_refused(call, name):
    # Python API audit, fifty-eighth session: these spun for ever (the lattice is generated in
    # order from t0: t = 1e5 s took 9.7 s, t = 1e9 s about a day)
    with pytest.raises(ValueError, match=f"'{name}' parameter of DrydenWind.*at most"):
        call()


def test_the_cap_is_a_pure_function_of_t_and_the_same_for_a_batch(monkeypatch):
    # the cap (2^25 steps, about 3 s of work per realisation) lowered to 4 blocks to reach its
    # edge quickly; a batch reaches as far as one realisation (a first form of the cap divided
    # it by the realisations and refused 256 vehicles flying 300 s, part-way; review)
    monkeypatch.setattr(D, "_MAX_STEPS", 4 * 2048)
    reach = 4 * 2048 * 0.05
    for batch in (None, 3):
        field = D.DrydenWind(rng=3, time_step=0.05, batch_size=batch)
        want = D.DrydenWind(rng=3, time_step=0.05, batch_size=batch).sample([reach])[0]
        xyz = np.zeros((1 if batch is None else batch, 3))
        np.testing.assert_array_equal(field.velocity(reach, xyz), np.reshape(want, xyz.shape))
        with pytest.raises(ValueError, match="'t' parameter of DrydenWind.velocity must be at "
                                             "most 409.6 s"):
            field.velocity(reach + 0.05, xyz)
        with pytest.raises(ValueError, match="'times' parameter of DrydenWind.sample must be "
                                             "at most 409.6 s"):
            field.sample([reach + 0.05])


@pytest.mark.parametrize("kwargs", [{"time_step": 1e6}, {"time_step": 1.5},
                                    {"length_scales": (5, 5, 2), "time_step": 0.3}])
def test_a_time_step_longer_than_the_gusts_time_scale_is_refused(kwargs):
    # Python API audit, fifty-eighth session: time_step=1e6 s was accepted (the docstring says
    # keep it well below L_w / V = 1 s), every query a straight line between two points
    with pytest.raises(ValueError, match="'time_step' parameter of DrydenWind"):
        D.DrydenWind(**kwargs)


def test_a_time_step_is_bounded_only_by_the_axes_with_gusts():
    # w has no gust: its 1 s time scale does not bound the step, u's 6.7 s does
    assert D.DrydenWind(sigma=(1, 1, 0), time_step=2.0).time_step == 2.0
    assert D.DrydenWind(sigma=(0, 0, 0), time_step=1e6).sample([3e6])[0].tolist() == [3, 0, 0]


@pytest.mark.parametrize("dt", [1e40, 1e100, 1e300])
def test_a_step_far_beyond_every_time_constant_decays_to_zero_not_nan(dt):
    # Python API audit, fifty-eighth session: transition(1e300) and lag_correlation(1e300)
    # gave NaN (SciPy's expm overflows in its scaling)
    field = D.DrydenWind()
    phi, q = field.transition(dt)
    assert np.all(phi == 0) and np.array_equal(q, field.stationary_covariance)
    assert field.lag_correlation(dt).tolist() == [0.0, 0.0, 0.0]


def test_van_loan_refuses_a_negative_or_unrepresentable_step():
    # Python API audit, fifty-eighth session: van_loan(-I, I, -1) gave a negative Q
    with pytest.raises(ValueError, match="'dt' parameter of van_loan"):
        D.van_loan(-np.eye(2), np.eye(2), -1.0)
    with pytest.raises(ValueError, match="'dt' parameter of van_loan"):
        D.van_loan(-np.eye(2), np.eye(2), 1e300)
    phi, q = D.van_loan(-np.eye(2), np.eye(2), 1.0)
    np.testing.assert_allclose(np.diag(q), (1 - np.exp(-2.0)) / 2)


@pytest.mark.parametrize("a", [np.eye(2), np.zeros((2, 2)), [[0.0, 1.0], [-1.0, 0.0]]])
def test_stationary_covariance_refuses_an_unstable_a(a):
    # Python API audit, fifty-eighth session: A = I gave a negative-definite P
    with pytest.raises(ValueError, match="'a' parameter of stationary_covariance must be "
                                         "stable"):
        D.stationary_covariance(np.asarray(a), np.eye(2))


@pytest.mark.parametrize("a, b, match", [
    ([[np.nan, 0.0], [0.0, -1.0]], np.eye(2), "'a' parameter of stationary_covariance must be "
                                              "finite"),
    (-np.eye(2), np.eye(3), "'b' parameter of stationary_covariance must be a matrix of 2 rows"),
    (-np.eye(2), [[np.inf, 0.0], [0.0, 1.0]], "'b' parameter of stationary_covariance must be "
                                              "finite"),
    (np.ones(3), np.eye(3), "'a' parameter of stationary_covariance must be a square matrix")])
def test_stationary_covariance_names_what_is_wrong(a, b, match):
    # review of the audit's mends: a NaN in A was "must be a finite square matrix. Got shape
    # (2, 2)", and a B of the wrong shape SciPy's "Matrix a and q should have the same shape"
    with pytest.raises(ValueError, match=match):
        D.stationary_covariance(np.asarray(a), np.asarray(b))


@pytest.mark.parametrize("kwargs, name", [({"mean": "abc"}, "mean"), ({"sigma": "abc"}, "sigma"),
                                          ({"length_scales": ["a", 1, 1]}, "length_scales")])
def test_dryden_text_for_numbers_is_named(kwargs, name):
    # before: "could not convert string to float: 'abc'", naming nothing
    with pytest.raises(ValueError, match=f"'{name}' parameter of DrydenWind"):
        D.DrydenWind(**kwargs)


@pytest.mark.parametrize("velocity", ["abc", ["a", 0, 0], {"x": 1}])
def test_constant_wind_text_for_numbers_is_named(velocity):
    # Python API audit, fifty-eighth session: "could not convert string to float: 'abc'"
    with pytest.raises(ValueError, match="'velocity' parameter of ConstantWind"):
        ConstantWind(velocity)


# The flight harness ------------------------------------------------------------------------

import windnav.experiments.flight as FL  # noqa: E402


@pytest.fixture(scope="module")
def short_flight():
    return FL.run_flight("hummingbird", "hover", FL.make_wind("none"), size=1.0, speed=1.0,
                         duration=0.5, dt=0.01)


@pytest.mark.parametrize("kwargs, name", [({"duration": 0.0}, "duration"),
                                          ({"duration": math.nan}, "duration"),
                                          ({"dt": -0.01}, "dt"), ({"dt": "fast"}, "dt"),
                                          ({"control_rate_hz": 0.0}, "control_rate_hz")])
def test_run_flight_names_a_bad_duration_or_step(kwargs, name):
    # Python API audit, fifty-eighth session: checked only inside the simulator, under its names
    args = {"size": 1.0, "speed": 1.0, "duration": 1.0, "dt": 0.01, **kwargs}
    with pytest.raises(ValueError, match=f"'{name}' parameter of run_flight"):
        FL.run_flight("hummingbird", "hover", FL.make_wind("none"), **args)


def test_run_flight_warns_of_a_controller_too_slow_for_its_rate_loop():
    # Python API audit, fifty-eighth session: at dt = 0.5 s the controller ran at 2 Hz and the
    # circle fell 0.6 m in 1 s with status OK, silently
    with pytest.warns(RuntimeWarning, match="controller updates every 0.5 s"):
        FL.run_flight("hummingbird", "hover", FL.make_wind("none"), size=1, speed=1,
                      duration=1, dt=0.5)


def test_run_flight_at_a_validated_step_does_not_warn():
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        FL.run_flight("hummingbird", "hover", FL.make_wind("none"), size=1.0, speed=1.0,
                      duration=0.1, dt=0.02)
    assert not [w for w in caught if "controller updates" in str(w.message)]


@pytest.mark.parametrize("fn", [FL.tracking_rms, FL.settled])
@pytest.mark.parametrize("duration", [math.nan, -1.0, 0.0, 1e6, "long"])
def test_a_duration_that_is_not_the_flights_is_named(short_flight, fn, duration):
    # Python API audit, fifty-eighth session: tracking_rms(log, nan) and (log, 1e6) gave nan
    # with NumPy's warnings; settled(log, nan) kept no instant
    log, _ = short_flight
    with pytest.raises(ValueError, match=f"'duration' parameter of {fn.__name__}"):
        fn(log, duration)


def test_the_duration_checks_keep_the_flights_own_numbers(short_flight):
    log, summary = short_flight
    assert FL.tracking_rms(log, 0.5) == summary["rms_tracking_error_m"]
    assert FL.settled(log, 0.5).sum() == np.sum(np.asarray(log.t) >= 0.25)


def test_wind_estimate_names_a_negative_duration(short_flight):
    # Python API audit, fifty-eighth session: duration=-1 was accepted (scored from t = -0.5 s)
    import windnav as wn

    log, _ = short_flight
    with pytest.raises(ValueError, match="'duration' parameter of wind_estimate"):
        FL.wind_estimate(log, wn.vehicle.params("hummingbird"), "windnav", -1)


@pytest.mark.parametrize("args, kwargs, name", [
    ((100, "windnav"), {"dt": 0.0}, "dt"), ((None, "windnav"), {"dt": math.nan}, "dt"),
    ((0,), {}, "rate_hz"), ((-5.0, "windnav"), {}, "rate_hz"), (("x",), {}, "rate_hz")])
def test_sensors_at_names_its_arguments(args, kwargs, name):
    # Python API audit, fifty-eighth session: dt=0 was accepted with a rate; rate 0 was
    # refused under IMU's 'rate_hz'
    with pytest.raises(ValueError, match=f"'{name}' parameter of sensors_at"):
        FL.sensors_at(*args, **kwargs)


@pytest.mark.parametrize("dt, rates, name", [
    (0, {"imu": 100}, "dt"), (-0.01, {"imu": 100}, "dt"), (0.01, {"imu": math.nan}, "rates"),
    (0.01, {"imu": 0.0}, "rates"), (0.01, {"imu": "x"}, "rates"), (0.01, [100.0], "rates")])
def test_misfit_rates_names_its_arguments(dt, rates, name):
    # Python API audit, fifty-eighth session: dt=0 raised ZeroDivisionError, a NaN rate
    # "cannot convert float NaN to integer"
    with pytest.raises(ValueError, match=f"'{name}' parameter of misfit_rates"):
        FL.misfit_rates(dt, rates)


def test_misfit_rates_still_finds_the_misfits():
    assert FL.misfit_rates(0.01, {"imu": 100.0, "odometry": 30.0}) == {"odometry": 30.0}


# The two demos -----------------------------------------------------------------------------

import windnav.experiments.demo as DM  # noqa: E402
import windnav.experiments.nav_demo as ND  # noqa: E402


@pytest.mark.parametrize("kwargs, name", [({"vehicle": "foo"}, "vehicle"),
                                          ({"vehicle": 3}, "vehicle"),
                                          ({"seed": -1}, "seed"), ({"seed": 1.5}, "seed"),
                                          ({"seed": "0"}, "seed")])
def test_demo_config_names_a_bad_vehicle_or_seed(kwargs, name):
    # Python API audit, fifty-eighth session: accepted, to fail inside run_demo (NavDemoConfig
    # refused seed=-1)
    with pytest.raises(ValueError, match=f"'{name}' parameter of DemoConfig"):
        DM.DemoConfig(**kwargs)


def test_demo_config_keeps_its_vehicles():
    assert DM.DemoConfig(vehicle="crazyflie_thesis", seed=3).vehicle == "crazyflie_thesis"


@pytest.mark.parametrize("args, name", [((-5,), "wind_speed"), ((0.0,), "wind_speed"),
                                        ((math.nan,), "wind_speed"), ((5.0, 0.0), "dx")])
def test_auto_flow_dt_names_a_bad_speed_or_cell(args, name):
    # Python API audit, fifty-eighth session: auto_flow_dt(-5) gave a flow step of -0.4 s
    with pytest.raises(ValueError, match=f"'{name}' parameter of auto_flow_dt"):
        DM.auto_flow_dt(*args)


def test_auto_flow_dt_keeps_its_values():
    assert DM.auto_flow_dt(5.0) == 0.2 and DM.auto_flow_dt(20.0) == 0.1


def test_run_demo_names_a_config_of_another_type():
    # Python API audit, fifty-eighth session: a dict raised AttributeError
    with pytest.raises(ValueError, match="'cfg' parameter of run_demo must be a DemoConfig"):
        DM.run_demo({"seed": 0})


_REC = {"outcome": "success", "energy_J": 4000.0, "rotor_energy_J": 4100.0, "time_s": 50.0,
        "distance_m": 300.0}


@pytest.mark.parametrize("summaries", [
    {"a": {**_REC, "energy_J": -100.0}, "b": {**_REC, "energy_J": 50.0}},
    {"a": _REC, "b": {**_REC, "energy_J": math.nan}},
    {"a": {**_REC, "energy_J": 0.0}, "b": _REC},
    {"a": _REC, "b": {**_REC, "energy_J": None}},
    {"a": _REC, "b": {"energy_J": 3.0}},
    {}, [("a", _REC)], None])
def test_compare_energies_names_records_it_cannot_compare(summaries):
    # Python API audit, fifty-eighth session: a negative reference read as a +150 % saving,
    # NaN as nan, 0 raised ZeroDivisionError, {} "not enough values to unpack"
    with pytest.raises(ValueError, match="'summaries' parameter of compare_energies"):
        ND.compare_energies(summaries)


def test_compare_energies_leaves_failed_flights_alone_and_names_bad_shapes():
    failed = {"outcome": "collision", "energy_J": math.nan}
    got = ND.compare_energies({"a": _REC, "b": failed, "c": {**_REC, "energy_J": 3000.0}})
    assert got["energy_vs_reference_percent"] == {"b": None, "c": 25.0}
    with pytest.raises(ValueError, match="'power_shapes' parameter of compare_energies"):
        ND.compare_energies({"a": _REC}, ["flat"])


@pytest.mark.parametrize("flights", [
    [{"variant": "mppi"}], [{"label": "x", "base": "nope", "kwargs": {}}],
    [{"label": 5, "base": "mppi", "kwargs": {}}], ["mppi"], 7,
    [{"label": "x", "base": "mppi", "kwargs": {"horizn": 50.0}}],
    [{"label": "x", "base": "mppi", "kwargs": {"rng": 1}}],
    [{"label": "x", "base": "mppi", "kwargs": [("horizon", 50.0)]}]])
def test_run_nav_demo_names_bad_flights_before_the_wind(flights, monkeypatch):
    # Python API audit, fifty-eighth session: [{'variant': 'mppi'}] raised KeyError 'label'; a
    # bad base or keyword failed only after the flow was simulated
    import windnav.experiments.navigate as NV

    monkeypatch.setattr(NV, "simulate_flow", lambda *a, **k: pytest.fail("simulated the flow"))
    with pytest.raises(ValueError, match="'flights' parameter of run_nav_demo"):
        ND.run_nav_demo(flights=flights)


def test_run_nav_demo_names_a_config_of_another_type():
    # Python API audit, fifty-eighth session: a dict raised AttributeError
    with pytest.raises(ValueError, match="'cfg' parameter of run_nav_demo must be a "
                                         "NavDemoConfig"):
        ND.run_nav_demo({"seed": 0})


@pytest.mark.parametrize("summary", [{}, {"variants": [1]}, {"variants": {"mppi": {}}}, None])
def test_describe_names_a_summary_it_cannot_read(summary):
    # Python API audit, fifty-eighth session: describe({}) raised KeyError 'variants'
    with pytest.raises(ValueError, match="'summary' parameter of describe"):
        ND.describe(summary)


@pytest.mark.parametrize("args, name", [((5,), "label"), ((None,), "label"),
                                        (("mppi", 0), "width"), (("mppi", math.nan), "width"),
                                        (("mppi", "wide"), "width")])
def test_legend_name_names_its_arguments(args, name):
    # Python API audit, fifty-eighth session: legend_name(5) raised AttributeError
    with pytest.raises(ValueError, match=f"'{name}' parameter of legend_name"):
        ND.legend_name(*args)


def test_legend_name_keeps_its_lines():
    assert ND.legend_name("ea-mppi-w@power=crazyflie", math.inf) == "EA-MPPI+W@power=crazyflie"
    assert ND.legend_name("ea-mppi-w@power=crazyflie", 10) == "EA-MPPI+W\n@power=crazyflie"


@pytest.mark.parametrize("kind, kwargs, name", [
    ("none", {"mean": (5.0, 0.0, 0.0)}, "mean"), ("none", {"sigma": (1.0, 1.0, 1.0)}, "sigma"),
    ("constant", {"mean": (1.0, 0.0, 0.0), "sigma": (2.0, 2.0, 2.0)}, "sigma")])
def test_make_wind_refuses_what_its_kind_ignores(kind, kwargs, name):
    # Python API audit, fifty-eighth session: make_wind("none", (5, 0, 0)) flew in still air and
    # a constant wind's sigma was dropped, unsaid
    with pytest.raises(ValueError, match=f"'{name}' parameter of make_wind applies only"):
        FL.make_wind(kind, **kwargs)
    FL.make_wind(kind, **{k: (0.0, 0.0, 0.0) for k in kwargs})   # zeros are the defaults


def test_fly_notes_a_fitted_controller_rate_once_and_passes_the_warning_of_a_chosen_one(
        tmp_path, capsys):
    from windnav import cli

    args = ["fly", "--duration", "0.2", "--no-progress", "--no-plots", "--trajectory", "hover"]
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert cli.main([*args, "--dt", "0.05", "--out", str(tmp_path / "a")]) == 0
    assert "controller ran at 20 Hz" in capsys.readouterr().err
    assert not [w for w in caught if "controller updates" in str(w.message)]
    with pytest.warns(RuntimeWarning, match="controller updates every 0.1 s"):  # (pytest
        # records it; the command line prints it as "windnav fly: warning: ...")
        assert cli.main([*args, "--dt", "0.01", "--control-rate-hz", "10",
                         "--out", str(tmp_path / "b")]) == 0


def test_make_wind_takes_none_as_not_given_and_any_mapping_of_rates():
    # review of the audit's mends: sigma=None was refused as non-zero, a MappingProxyType of
    # rates as "not a dict"
    import types

    assert FL.make_wind("constant", (1.0, 0.0, 0.0), None).velocity(0.0, [[0, 0, 0]])[0, 0] == 1
    assert FL.misfit_rates(0.01, types.MappingProxyType({"imu": 100.0})) == {}
