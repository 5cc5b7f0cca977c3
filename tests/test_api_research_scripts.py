"""What a researcher's own scripts met (an API audit of the thirty-ninth session): inputs the
library accepted and ignored or refused by the wrong name, each now checked by name or
accepted as written."""

from __future__ import annotations

import numpy as np
import pytest

import windnav as wn

HB = wn.vehicle.params("hummingbird")


def _fly(params, wind, **kw):
    return wn.sim.fly(params, wn.sim.make_trajectory("hover"), wind, duration=0.05, **kw)


def test_fly_refuses_a_batch_that_is_not_its_list_of_vehicles():
    """``batch=3`` with two vehicles flew two, silently."""
    still = wn.wind.ConstantWind((0.0, 0.0, 0.0))
    with pytest.raises(ValueError, match="'batch' parameter of fly must be 2, the number of "
                                         "vehicles in 'params', or not given. Got 3"):
        _fly([HB, HB], still, batch=3)
    assert _fly([HB, HB], still, batch=2).position.shape[1] == 2
    assert _fly([HB, HB], still).position.shape[1] == 2
    assert _fly(HB, still).position.shape[1] == 1 and _fly(HB, still, batch=3).position.shape[
        1] == 3


def test_a_wind_of_one_realisation_per_vehicle_is_checked_against_the_flight():
    """``DrydenWind(batch_size=2)`` with ``hub_wind=True``, or flown by 3 vehicles, failed at
    the first step naming DrydenWind.velocity's 'xyz' (a batch of 8 hub points, of 3)."""
    gusts = wn.wind.DrydenWind(rng=0, batch_size=2)
    assert gusts.batch_size == 2 and wn.wind.DrydenWind(rng=0).batch_size is None
    with pytest.raises(ValueError, match="'hub_wind' parameter of fly must be False"):
        _fly(HB, gusts, batch=2, hub_wind=True)
    with pytest.raises(ValueError, match="'wind' parameter of fly has batch_size 2, one "
                                         "realisation per vehicle, for 3 vehicle"):
        _fly(HB, gusts, batch=3)
    log = _fly(HB, gusts, batch=2)
    assert log.position.shape[1] == 2


def test_the_planner_takes_city_lidar_scans_as_they_come():
    """``City.lidar`` returns (1, n_rays) for one point; ``MPPIPlanner.update`` refused it, so
    every script added ``[0]``. It is the same scan: the same plan."""
    city = wn.city.City((0.0, 100.0, 0.0, 100.0), [[40.0, 60.0, 40.0, 60.0]], [10.0])
    scan = city.lidar([10.0, 10.0], noise_std=0.0, rng=0)
    assert scan.shape == (1, 360)
    cfg = wn.plan.planner_config(HB, "mppi")
    a = wn.plan.MPPIPlanner(cfg, (90.0, 90.0), rng=0).update([10.0, 10.0, 0.0, 0.0], scan)
    b = wn.plan.MPPIPlanner(cfg, (90.0, 90.0), rng=0).update([10.0, 10.0, 0.0, 0.0], scan[0])
    np.testing.assert_array_equal(a, b)


def test_a_max_range_speed_on_the_curves_top_speed_is_flagged():
    """A curve valid to 6 m/s whose energy per metre still falls there gave
    ``ground_speed=6.0``, exactly ``speed_max``, as the optimum, unflagged (``sysid.fit_power``
    and ``power-curve`` flag it)."""
    from windnav.vehicle import PowerCurve, max_range_speed

    thesis = PowerCurve.crazyflie()  # max range at 7.73 m/s in still air
    short = PowerCurve(thesis.coefficients, speed_max=6.0)
    edge = max_range_speed(short)
    assert edge.ground_speed == pytest.approx(6.0) and edge.at_speed_limit is True
    inside = max_range_speed(thesis)
    assert inside.ground_speed == pytest.approx(7.73, abs=0.01)
    assert inside.at_speed_limit is False


def test_the_onboard_calibration_is_cached_by_what_it_depends_on(monkeypatch):
    """The onboard stack cached its drag calibration by the conditions' name: a custom
    ``UKFConditions`` named "windnav" with the thesis's sensors and no parasitic drag got the
    preset's calibration (c_dx 0.005 where its own is 0; cache audit)."""
    import dataclasses

    import windnav.experiments.calibration as calibration
    import windnav.experiments.onboard as onboard
    from windnav.estimate.conditions import CONDITIONS

    calls = []
    monkeypatch.setattr(calibration, "calibrate", lambda params, rng, sensors, parasitic: (
        calls.append(parasitic) or (None, ("believed", len(calls)))))
    monkeypatch.setattr(onboard, "_BELIEVED", {})
    preset = CONDITIONS["windnav"]
    custom = dataclasses.replace(preset, sensors="thesis", parasitic_drag=False)
    assert custom.name == preset.name
    a = onboard._calibrated(HB, preset)
    b = onboard._calibrated(HB, custom)
    assert a != b and len(calls) == 2
    assert onboard._calibrated(HB, preset) == a and len(calls) == 2  # cached


def test_what_a_cache_was_built_from_cannot_be_changed_under_it():
    """``DrydenWind.airspeed = 20`` changed ``time_scales`` and the repr but not the gusts,
    generated at construction; an in-place edit of a UKF block's ``R`` went unseen by the
    stacked model cached from it (cache audit). Both are read-only now."""
    from windnav.estimate.ukf import UKF

    gusts = wn.wind.DrydenWind(rng=0, airspeed=5.0)
    with pytest.raises(AttributeError):
        gusts.airspeed = 20.0
    with pytest.raises(AttributeError):
        gusts.altitude = 50.0
    assert gusts.airspeed == 5.0 and gusts.altitude == 10.0
    ukf = UKF(lambda x, dt, u: x, np.zeros(2), np.eye(2), 0.01 * np.eye(2), dt=0.1)
    ukf.add_block("z", lambda x: x[:1], [[1.0]])
    with pytest.raises(ValueError, match="read-only"):
        ukf.blocks["z"].R[0, 0] = 1e6
    wrap = np.array([0], dtype=np.intp)  # the caller's array stays the caller's (review)
    ukf.add_block("yaw", lambda x: x[:1], [[1.0]], wrap=wrap)
    wrap[0] = 5
    assert ukf.blocks["yaw"].wrap.tolist() == [0] and wrap.flags.writeable


def test_the_cached_symbolic_model_cannot_be_edited_by_one_caller():
    """``symbolic_model`` is cached and its result shared: after ``f0[6] = 0`` every later call
    returned the edit, and the observability Jacobians were built from it (cache audit)."""
    from windnav.estimate.observability import symbolic_model

    x, prm, f0, gs, h = symbolic_model(4)
    with pytest.raises(TypeError):
        f0[6] = 0
    with pytest.raises(TypeError):
        h[0] = 0
    assert isinstance(x, tuple) and isinstance(gs, tuple) and symbolic_model(4)[2][6] != 0


def test_fly_says_when_the_control_rate_was_lowered_to_fit_the_step(tmp_path, capsys):
    """``fly --dt 0.02`` flies its controller at 50 Hz, the models' validation is at 100 Hz;
    it was said only when the flight also saturated (discretisation audit)."""
    from windnav import cli

    argv = ["fly", "--duration", "1", "--no-plots", "--no-progress", "--out"]
    assert cli.main([*argv, str(tmp_path / "a"), "--dt", "0.02"]) == 0
    assert "note: the controller ran at 50 Hz" in capsys.readouterr().err
    assert cli.main([*argv, str(tmp_path / "b")]) == 0
    assert "controller ran at" not in capsys.readouterr().err
    assert cli.main([*argv, str(tmp_path / "c"), "--dt", "0.02", "--control-rate-hz", "50"]) == 0
    assert "controller ran at" not in capsys.readouterr().err  # asked for: not a surprise
