"""Random maps, winds and options fed to the commands' library entry points.

Each call either returns a finite, physically bounded result or raises a named ValueError:
never a raw exception (ZeroDivisionError, IndexError, a numpy error, a silent NaN). Sizes are
tiny so every example runs in well under a second.
"""

import json
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, event, given, settings
from hypothesis import strategies as st

import windnav as wn
from windnav.city import City, training_map
from windnav.cli import main
from windnav.flow import FlowDivergedError
from windnav.sim.sweeps import power_sweep
from windnav.wind import ConstantWind, DrydenWind

FAST = settings(max_examples=25, deadline=None,
                suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much])
GRAVITY = 9.81

BAD_NUMBERS = [0.0, -1.0, np.nan, np.inf]
"""The worst values a user can type for a positive number."""


def or_bad(valid, one_in: int = 7):
    """``valid`` values, and about one time in ``one_in`` a bad number instead (the selector is
    a middle value: hypothesis draws the ends of a range more often)."""
    return st.integers(0, one_in - 1).flatmap(
        lambda k: st.sampled_from(BAD_NUMBERS) if k == one_in // 2 else valid)


@st.composite
def tiny_maps(draw):
    """A map of 8-24 m with 0-3 buildings; about one map in six has an invalid block."""
    lx, ly = draw(st.floats(8.0, 24.0)), draw(st.floats(8.0, 24.0))
    blocks = []
    for _ in range(draw(st.integers(0, 3))):
        x0, y0 = draw(st.floats(0.0, lx - 1.0)), draw(st.floats(0.0, ly - 1.0))
        w = draw(st.floats(0.5, lx - x0))
        h = draw(st.floats(0.5, ly - y0))
        blocks.append([x0, x0 + w, y0, y0 + h])
    if blocks and draw(st.integers(0, 6)) == 3:
        blocks[0] = draw(st.sampled_from([[2.0, 2.0, 1.0, 3.0], [-5.0, 3.0, 1.0, 3.0],
                                          [1.0, np.nan, 1.0, 3.0]]))
    return (0.0, lx, 0.0, ly), blocks


@FAST
@given(tiny_maps(), or_bad(st.floats(0.1, 12.0)), st.floats(-720.0, 720.0),
       st.sampled_from([0.7, 1.0, 2.0]), or_bad(st.floats(0.01, 0.6)), st.integers(0, 3),
       st.integers(1, 4), st.integers(0, 2))
def test_flow_on_random_maps_is_finite_and_bounded_or_a_named_error(
        city_map, speed, direction, dx, dt, spinup, steps, record_every):
    bounds, blocks = city_map
    try:
        city = City(bounds, np.array(blocks).reshape(-1, 4), np.full(len(blocks), 10.0))
        sol = wn.flow.simulate(city, speed=speed, direction_deg=direction, dx=dx, dt=dt,
                               spinup_steps=spinup, steps=steps, record_every=record_every)
    except (ValueError, FlowDivergedError) as exc:
        # a named error says what was wrong (a diverged flow is named too: a wall across the
        # whole domain, or a thin block at a coarse step, blows up instead of being refused)
        assert str(exc)
        event(type(exc).__name__ + ": " + str(exc)[:60])
        return
    event("solved")
    ny, nx = sol.y.size, sol.x.size
    assert ny > 0 and nx > 0
    assert sol.mean_u.shape == sol.mean_v.shape == sol.solid.shape == (ny, nx)
    assert np.all(np.isfinite(sol.mean_u)) and np.all(np.isfinite(sol.mean_v))
    # no wind inside buildings; nowhere faster than the solver's own divergence bound: 10 x the
    # inlet, or 1.25 x the jets of the projected start where a narrow gap makes them faster
    assert np.all(sol.mean_u[sol.solid] == 0) and np.all(sol.mean_v[sol.solid] == 0)
    assert 10.0 * speed <= sol.blowup_limit < np.inf
    assert np.hypot(sol.mean_u, sol.mean_v).max() <= sol.blowup_limit
    if record_every and steps // record_every:
        assert sol.frames_u.shape == (steps // record_every, ny, nx)
        assert np.all(np.isfinite(sol.frames_u)) and np.all(np.isfinite(sol.frames_v))


winds = st.one_of(
    st.tuples(st.floats(-25.0, 25.0), st.floats(-25.0, 25.0), st.floats(-10.0, 10.0))
    .map(ConstantWind),
    st.builds(lambda m, s, seed: DrydenWind(mean=(m, 0.0, 0.0), sigma=(s, s, s / 2), seed=seed),
              st.floats(-10.0, 10.0), st.floats(0.0, 3.0), st.integers(0, 2**31 - 1)),
)


@FAST
@given(st.sampled_from(["hummingbird", "crazyflie_brushless"]),
       st.sampled_from(["hover", "line", "circle", "waypoints"]), winds,
       or_bad(st.floats(0.02, 0.6)), st.sampled_from([0.0025, 0.005, 0.01, 0.005, 0.003]),
       or_bad(st.floats(0.2, 4.0)), or_bad(st.floats(0.5, 5.0)),
       st.integers(0, 2**32 - 1))
def test_flights_in_random_winds_are_bounded_or_a_named_error(vehicle, kind, wind, duration, dt,
                                                             speed, size, seed):
    p = wn.vehicle.params(vehicle)
    try:
        traj = wn.sim.make_trajectory(kind, start=(0.0, 0.0, 2.0), size=size, speed=speed)
        log = wn.sim.fly(p, traj, wind, duration, dt=dt, rng=seed)
    except ValueError as exc:
        assert str(exc)
        event(str(exc)[:60])
        return
    event("returned")
    ok = (np.asarray(log.status) & wn.sim.log.FlightStatus.NON_FINITE) == 0  # flagged, not raised
    if not ok.any():
        return
    pos, vel = log.position[:, ok], log.velocity[:, ok]
    assert np.all(np.isfinite(pos)) and np.all(np.isfinite(vel))
    assert np.allclose(np.linalg.norm(log.attitude[:, ok], axis=-1), 1.0, atol=1e-9)
    w = log.rotor_speeds[:, ok]
    assert np.all(w >= p.rotor_speed_min - 1e-9) and np.all(w <= p.rotor_speed_max + 1e-9)
    assert np.all(log.power[:, ok] >= 0) and np.all(np.diff(log.energy[:, ok], axis=0) >= -1e-9)
    # drag pulls the velocity toward the wind; thrust and gravity change it at a bounded rate
    a_max = p.n_rotors * p.k_eta * p.rotor_speed_max ** 2 / p.mass + GRAVITY
    w_max = np.linalg.norm(log.wind[:, ok], axis=-1).max()
    bound = 2.0 * w_max + a_max * log.t[:, None] + 1e-6
    assert np.all(np.linalg.norm(vel, axis=-1) <= bound)


@st.composite
def sweep_options(draw):
    """Airspeeds, a flight time and a settling time (usually, not always, below it)."""
    speeds = draw(st.lists(or_bad(st.floats(0.0, 15.0), one_in=11), min_size=1, max_size=3))
    duration = draw(or_bad(st.floats(0.05, 0.6)))
    fraction = draw(st.integers(0, 6).flatmap(
        lambda k: st.sampled_from([-0.5, 1.0, 2.0]) if k == 3 else st.floats(0.0, 0.9)))
    settle = fraction * duration if np.isfinite(duration) else 0.1
    return speeds, duration, settle


@FAST
@given(sweep_options(), st.sampled_from(["hummingbird", "crazyflie_brushless"]))
def test_power_sweeps_are_positive_and_finite_or_a_named_error(options, vehicle):
    speeds, duration, settle = options
    p = wn.vehicle.params(vehicle)
    try:
        out = power_sweep(p, speeds, duration=duration, settle_s=settle)
    except ValueError as exc:
        assert str(exc)
        event(str(exc)[:60])
        return
    event("returned")
    power = out["power"]
    assert power.shape == (len(speeds),)
    # a point the vehicle cannot trim inside the model's envelope is NaN and flagged, not raised
    valid = out.get("valid", np.ones(len(speeds), bool))
    assert np.all(np.isfinite(power[valid])) and np.all(power[valid] > 0)
    assert np.all(np.isnan(power[~valid]))
    assert np.all((out["saturated"] >= 0) & (out["saturated"] <= 1))
    assert np.all((out["pitch_deg"] >= 0) & (out["pitch_deg"] <= 180))


@FAST
@given(st.integers(0, 2**32 - 1), or_bad(st.floats(40.0, 400.0)),
       st.one_of(st.none(), st.integers(0, 6), st.sampled_from([-1, 40])), st.floats(1.0, 150.0),
       st.integers(1, 64))
def test_random_training_maps_and_their_scans_or_a_named_error(seed, size, n, max_range, rays):
    try:
        city = training_map(rng=seed, size=size, n_buildings=n)
    except ValueError as exc:
        assert str(exc)
        event(str(exc)[:60])
        return
    event("returned")
    x0, x1, y0, y1 = city.bounds
    assert x1 - x0 == pytest.approx(size) and y1 - y0 == pytest.approx(size)
    fp = city.footprints
    assert np.all(fp[:, 0] >= x0) and np.all(fp[:, 1] <= x1) and np.all(fp[:, 0] < fp[:, 1])
    origins = np.random.default_rng(seed).uniform((x0, y0), (x1, y1), (3, 2))
    scan = city.lidar(origins, n_rays=rays, max_range=max_range)
    assert scan.shape == (3, rays) and np.all(np.isfinite(scan))
    assert np.all((scan >= 0) & (scan <= max_range))


FLY_OPTIONS = {  # option -> (valid values, bad values)
    "--speed": (["0.5", "3"], ["0", "-1", "nan", "inf"]),
    "--dt": (["0.005", "0.01", "0.0031"], ["0", "-0.005", "nan"]),
    "--duration": (["0.05", "0.2"], ["0", "-1", "nan"]),
    "--sensor-rate-hz": (["50", "20"], ["0", "-5", "inf", "1000"]),
}


@st.composite
def fly_options(draw):
    """Valid options, with (most of the time) one of them replaced by a bad value."""
    bad = draw(st.sampled_from([None, *FLY_OPTIONS]))
    argv = ["--trajectory", draw(st.sampled_from(["hover", "line", "circle", "waypoints"]))]
    for option, (good, worse) in FLY_OPTIONS.items():
        argv += [option, draw(st.sampled_from(worse if option == bad else good))]
    return argv


@settings(max_examples=15, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(fly_options())
def test_fly_command_with_random_options_succeeds_or_says_why_in_one_line(options):
    with tempfile.TemporaryDirectory() as d, _capture() as err:
        rc = main(["fly", *options, "--wind", "constant", "--no-plots",
                   "--out", str(Path(d) / "run")])
        event(f"exit {rc}")
        if rc == 0:
            summary = json.loads((Path(d) / "run" / "summary.json").read_text())
            assert np.isfinite(summary["energy_J"]) and summary["energy_J"] > 0
        else:
            assert rc == 2 and len(err.getvalue().strip().splitlines()) == 1
            assert "'--" in err.getvalue()  # names the option


class _capture:
    """Collect stderr (capsys cannot be shared across hypothesis examples)."""

    def __enter__(self):
        import contextlib
        import io

        self.buffer = io.StringIO()
        self._redirect = contextlib.redirect_stderr(self.buffer)
        self._redirect.__enter__()
        self._out = contextlib.redirect_stdout(io.StringIO())
        self._out.__enter__()
        return self.buffer

    def __exit__(self, *exc):
        self._out.__exit__(*exc)
        return self._redirect.__exit__(*exc)
