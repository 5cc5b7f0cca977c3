"""EA-MPPI+W+esc: the progress monitor and GS+W route escape (issue 11, "Beyond the thesis").

The unit tests feed the monitor and the escape hand-made positions; the closed-loop tests use
the small map and weak wind of ``tests/test_navigate.py`` (140 m x 120 m, one building, 2 m/s,
10 s spin-up, 40 s recorded).
"""

import math

import numpy as np
import pytest

from windnav.experiments.nav_demo import LABELS
from windnav.experiments.navigate import navigate
from windnav.plan import (
    VARIANTS,
    EscapeConfig,
    FastestEscape,
    ProgressMonitor,
    RouteEscape,
    energy_route,
    planner_config,
    route_projection,
)
from windnav.vehicle import params

START = (10.0, 60.0)
GOAL = (110.0, 60.0)
BUILDING = (35.0, 45.0, 45.0, 75.0)
SPEED = 2.0
VARIANT = "ea-mppi-w-esc"


@pytest.fixture(scope="module")
def route(city, flow):
    return energy_route(city, START, GOAL, planner_config(params("hummingbird"), "gs-w"),
                        wind=flow.wind_field())


def fly(city, flow, variant=VARIANT, **kw):
    kw.setdefault("rng", 0)
    return navigate(city, START, GOAL, speed=SPEED, direction_deg=0.0, variant=variant,
                    flow=flow, **kw)


class Brake:
    """A planner that brakes, ``a = -4 v``: the vehicle stops wherever it is (a stall)."""

    def __init__(self):
        self.resets = 0

    def update(self, state, scan=None, wind=None):
        return -4.0 * np.asarray(state[2:4], dtype=float)

    def reset(self):
        self.resets += 1


# ------------------------------------------------------------------------------- the monitor


def test_monitor_fires_after_the_window_without_progress_and_not_before():
    mon = ProgressMonitor(GOAL, EscapeConfig(window_s=3.0, min_progress_m=2.0))
    # 1.9 m closer over 3 s is not progress: fires at 3 s, not at 2.9 s
    times = np.arange(0.0, 3.05, 0.1)
    fired = [mon.update(t, (10.0 + 1.9 * t / 3.0, 60.0)) for t in times]
    assert not any(fired[:-1]) and fired[-1]
    assert times[-1] == pytest.approx(3.0)


def test_monitor_window_restarts_on_progress():
    mon = ProgressMonitor(GOAL, EscapeConfig(window_s=3.0, min_progress_m=2.0))
    # 1 m/s toward the goal: every 2 m of progress restarts the window, so it never fires
    assert not any(mon.update(t, (10.0 + t, 60.0)) for t in np.arange(0.0, 20.0, 0.1))
    # then it stops: fires 3 s after the last restart (at most 2 s before the stop), not before
    stop = 20.0
    t_fire = next(t for t in np.arange(stop, stop + 10.0, 0.1) if mon.update(t, (30.0, 60.0)))
    assert stop + 1.0 - 1e-6 <= t_fire <= stop + 3.0 + 1e-6
    # moving away from the goal is no progress either
    mon.reset()
    fired = [mon.update(t, (30.0 - t, 60.0)) for t in np.arange(0.0, 3.5, 0.1)]
    assert fired.index(True) == 30


def test_escape_config_and_inputs_are_validated():
    for name, bad in (("window_s", 0.0), ("min_progress_m", -1.0), ("length_m", math.nan)):
        with pytest.raises(ValueError, match=name):
            EscapeConfig(**{name: bad})
    with pytest.raises(ValueError, match="position_xy"):
        ProgressMonitor(GOAL).update(0.0, (math.nan, 1.0))
    with pytest.raises(ValueError, match="goal_xy"):
        ProgressMonitor((1.0, 2.0, 3.0))
    with pytest.raises(ValueError, match="samples"):
        RouteEscape(np.zeros((3, 3)), GOAL)


# ---------------------------------------------------------------------------- the escape


def test_route_projection_on_a_polyline():
    poly = np.array([[0.0, 0.0], [10.0, 0.0], [10.0, 10.0]])
    s, p = route_projection(poly, (4.0, -3.0))
    assert s == pytest.approx(4.0) and p == pytest.approx([4.0, 0.0])
    s, p = route_projection(poly, (13.0, 6.0))
    assert s == pytest.approx(16.0) and p == pytest.approx([10.0, 6.0])
    s, _ = route_projection(poly, (-5.0, -5.0))
    assert s == 0.0


def test_escape_starts_on_the_route_ahead_and_releases_past_its_end(city, route):
    cfg = EscapeConfig(window_s=3.0, min_progress_m=2.0, length_m=30.0)
    esc = RouteEscape(route.samples, GOAL, cfg)
    here = np.array([30.0, 55.0])  # stalled just before the building
    assert all(esc.update(t, here) is None for t in np.arange(0.0, 2.95, 0.1))
    s_from, s_to = esc.update(3.0, here)
    assert s_from == pytest.approx(route_projection(route.samples, here)[0])
    assert s_to == pytest.approx(s_from + 30.0)
    # the stretch to fly lies on the route, ahead of the vehicle, outside (and clear of) the
    # building
    knots = np.concatenate([[0.0], np.cumsum(np.hypot(*np.diff(route.samples, axis=0).T))])
    stretch = route.samples[(knots >= s_from) & (knots <= s_to)]
    assert stretch.shape[0] > 5
    assert not city.contains(stretch).any()
    ahead = np.hypot(*(stretch - GOAL).T)
    assert ahead[-1] < np.hypot(*(here - GOAL)) - 5.0  # around the building: 30 m for 7 m
    # still active until the vehicle's projection passes s_to, then released
    mid = route.samples[np.searchsorted(knots, 0.5 * (s_from + s_to))]
    assert esc.update(4.0, mid) == (s_from, s_to)
    end = route.samples[np.searchsorted(knots, s_to + 1.0)]
    assert esc.update(5.0, end) is None and esc.active is None
    # the monitor restarted at release: no new escape for the next 3 s at the same place
    assert all(esc.update(t, end) is None for t in np.arange(5.1, 7.95, 0.1))
    assert esc.update(8.0, end) is not None
    assert len(esc.escapes) == 2


# --------------------------------------------------------------------------- closed loop


def test_variant_is_registered():
    assert VARIANTS[VARIANT] == VARIANTS["ea-mppi-w"]._replace(escape=True)
    assert LABELS[VARIANT] == "EA-MPPI+W+esc"


def test_escape_turns_a_stall_into_a_success(city, flow):
    # the same stalling planner: without the mechanism a hover failure, with it the vehicle is
    # carried along the GS+W route, one 60 m escape at a time, into the goal capture
    base = fly(city, flow, "ea-mppi-w", planner=Brake(), duration=40.0)
    assert base.outcome == "hover"
    brake = Brake()
    res = fly(city, flow, planner=brake, duration=40.0)
    assert res.outcome == "success", res.summary()
    escapes = res.settings["escapes"]
    assert len(escapes) >= 2 and brake.resets >= 1
    # each escape began after 3 s without progress, and the first at the start
    assert escapes[0][0] == pytest.approx(3.0, abs=0.11)
    assert all(b[0] - a[0] >= 3.0 - 1e-9 for a, b in zip(escapes, escapes[1:], strict=False))
    # it went around the building along the route and never hit it
    assert not city.contains(res.position[:, :2]).any()
    abreast = (res.position[:, 0] > BUILDING[0]) & (res.position[:, 0] < BUILDING[1])
    y = res.position[abreast, 1]
    assert y.size and np.all((y < BUILDING[2]) | (y > BUILDING[3]))


def test_same_seed_same_flight_and_the_monitor_is_the_only_difference(city, flow):
    a = fly(city, flow, rng=3, duration=15.0)
    b = fly(city, flow, rng=3, duration=15.0)
    assert a.energy_J == b.energy_J and np.array_equal(a.position, b.position)
    assert a.settings["escapes"] == b.settings["escapes"]
    # with a monitor that never fires the variant flies exactly as EA-MPPI+W
    never = fly(city, flow, rng=3, duration=15.0, escape=EscapeConfig(window_s=1e6))
    base = fly(city, flow, "ea-mppi-w", rng=3, duration=15.0)
    assert never.settings["escapes"] == []
    assert never.energy_J == base.energy_J and np.array_equal(never.position, base.position)


def test_existing_variants_ignore_the_mechanism(city, flow):
    for v in ("mppi", "ea-mppi-w"):
        a = fly(city, flow, v, rng=1, duration=10.0)
        b = fly(city, flow, v, rng=1, duration=10.0,
                escape=EscapeConfig(window_s=0.1, min_progress_m=50.0))
        assert a.energy_J == b.energy_J and np.array_equal(a.position, b.position)
        assert "escapes" not in a.settings and a.route is None
    with pytest.raises(ValueError, match="'escape'"):
        fly(city, flow, rng=1, duration=1.0, escape={"window_s": 3.0})


# ------------------------------------------------------------------- the least-time escape


class Straight:
    """A route_fn: the straight line from the position to GOAL at 5 m/s (None when asked to
    fail), counting its calls."""

    def __init__(self, fail=False):
        self.calls, self.fail = [], fail

    def __call__(self, p):
        self.calls.append(tuple(p))
        if self.fail:
            return None
        d = math.hypot(GOAL[0] - p[0], GOAL[1] - p[1])
        return type("R", (), {"samples": np.array([p, GOAL]), "speeds": np.array([5.0]),
                              "time_s": d / 5.0})()


def test_fastest_escape_begins_at_the_first_stall_and_lasts_to_the_goal():
    fn = Straight()
    esc = FastestEscape(fn, GOAL, EscapeConfig(airspeed_mps=10.0))
    assert esc.update(0.0, (10, 60)) is None and esc.update(2.9, (11, 60)) is None
    active = esc.update(3.0, (11, 60))
    assert active == (0.0, pytest.approx(99.0)) and fn.calls == [(11.0, 60.0)]
    assert esc.route.samples[0].tolist() == [11.0, 60.0]
    # it never ends, wherever the vehicle goes, and the route is asked for once
    assert esc.update(50.0, (0, 0)) == active and len(fn.calls) == 1
    assert esc.escapes == [(3.0, 0.0, pytest.approx(99.0))]


def test_fastest_escape_without_a_route_lets_mppi_go_on():
    fn = Straight(fail=True)
    esc = FastestEscape(fn, GOAL, EscapeConfig(airspeed_mps=10.0))
    esc.update(0.0, (10, 60))
    assert esc.update(3.0, (10, 60)) is None and esc.route is None
    # the window restarts at the next update
    assert esc.update(3.1, (10, 60)) is None and esc.update(6.0, (10, 60)) is None
    assert len(fn.calls) == 1
    assert esc.update(6.1, (10, 60)) is None and len(fn.calls) == 2
    assert [e[0] for e in esc.escapes] == [3.0, 6.1] and math.isnan(esc.escapes[0][2])
    with pytest.raises(ValueError, match="'route_fn'"):
        FastestEscape(None, GOAL, EscapeConfig())
    with pytest.raises(ValueError, match="'airspeed_mps'"):
        EscapeConfig(airspeed_mps=0.0)


def test_least_time_escape_turns_a_stall_into_a_success(city, flow):
    brake = Brake()
    res = fly(city, flow, planner=brake, duration=40.0, escape=EscapeConfig(airspeed_mps=8.0))
    assert res.outcome == "success", res.summary()
    (escape,) = res.settings["escapes"]  # one escape, at the first stall, into the goal
    assert escape[0] == pytest.approx(3.0, abs=0.11)
    assert escape[2] == pytest.approx(res.settings["route_length_m"])
    assert np.array_equal(res.route[0], res.position[int(round(escape[0] / 0.01)), :2])
    assert not city.contains(res.position[:, :2]).any()
    abreast = (res.position[:, 0] > BUILDING[0]) & (res.position[:, 0] < BUILDING[1])
    y = res.position[abreast, 1]
    assert y.size and np.all((y < BUILDING[2]) | (y > BUILDING[3]))
    # the route was flown near its planned ground speeds (2 m/s of wind, 8 m/s of airspeed)
    assert res.settings["route_time_s"] == pytest.approx(res.settings["route_length_m"] / 8.0,
                                                         rel=0.35)
    assert res.settings["route_ms"] > 0


def test_fastest_escape_edge_guard_begins_the_escape_near_the_map_edge():
    fn = Straight()
    config = EscapeConfig(airspeed_mps=10.0, edge_m=15.0)
    esc = FastestEscape(fn, GOAL, config, bounds=(0.0, 140.0, 0.0, 120.0))
    # moving fast (no stall), 15 m or more from every edge: MPPI flies
    assert esc.update(0.0, (20, 60)) is None and esc.update(0.1, (15, 60)) is None
    # within 15 m of the left edge: the escape begins at once
    assert esc.update(0.2, (14.9, 60)) is not None and fn.calls == [(14.9, 60.0)]
    assert FastestEscape(Straight(), GOAL, EscapeConfig(airspeed_mps=10.0)).update(
        0.0, (1, 1)) is None  # no guard by default
    with pytest.raises(ValueError, match="'bounds'"):
        FastestEscape(fn, GOAL, config)
    with pytest.raises(ValueError, match="'edge_m'"):
        EscapeConfig(edge_m=10.0)
    with pytest.raises(ValueError, match="'edge_m'"):
        EscapeConfig(airspeed_mps=10.0, edge_m=-1.0)


def test_fastest_escape_pace_trigger_begins_the_escape_when_time_would_run_out():
    config = EscapeConfig(airspeed_mps=10.0, pace_margin_s=10.0)  # 10 s pace window
    # 100 m from the goal closing at 1 m/s (above the stall monitor's 0.67 m/s): at that pace
    # it arrives 100 s after each moment, later than deadline 95 s - 10 s whenever t > -15 s
    fn = Straight()
    esc = FastestEscape(fn, GOAL, config, deadline_s=95.0)
    x = GOAL[0] - 100.0
    fired = None
    for k in range(200):
        t = 0.1 * k
        if esc.update(t, (x + 0.1 * k, GOAL[1])) is not None:
            fired = t
            break
    assert fired == pytest.approx(10.0)  # the first moment a whole window has passed
    assert fn.calls == [(pytest.approx(x + 10.0), GOAL[1])]
    # the same approach at 5 m/s from 300 m: arrival 60 s + t, never later than 85 s before
    # t = 25 s; at t = 30 s the closing speed drops to 1 m/s, and the 10 s window sees it as
    # soon as the projected arrival passes 85 s
    fn = Straight()
    esc = FastestEscape(fn, GOAL, config, deadline_s=95.0)
    d, fired = 300.0, None
    for k in range(600):
        t = 0.1 * k
        if esc.update(t, (GOAL[0] - d, GOAL[1])) is not None:
            fired = t
            break
        d -= 0.1 * (5.0 if t < 30.0 else 1.0)
    # for 30 < t < 40 s: d = 180 - t, the window's closing speed (170 - 4 t) / 10, and the
    # projected arrival t + d / closing passes 85 s at the root of t^2 - 125 t + 3162.5,
    # t = 35.23 s: the next 0.1 s tick
    assert fired == pytest.approx(35.3, abs=0.01)
    with pytest.raises(ValueError, match="'deadline_s'"):
        FastestEscape(Straight(), GOAL, config)
    with pytest.raises(ValueError, match="'pace_margin_s'"):
        EscapeConfig(pace_margin_s=10.0)
    with pytest.raises(ValueError, match="'pace_window_s'"):
        EscapeConfig(airspeed_mps=10.0, pace_margin_s=10.0, pace_window_s=0.0)


class Drift:
    """A planner that flies at (6, 6) m/s: over the building and off the map's top edge
    (y = 120 m) at x = 70 m."""

    def update(self, state, scan=None, wind=None):
        return 2.0 * (np.array([6.0, 6.0]) - np.asarray(state[2:4], dtype=float))

    def reset(self):
        pass


def test_edge_guard_turns_a_drift_off_the_map_into_a_success(city, flow):
    # the stall monitor switched off (a 1e6 s window): only the guard can begin an escape
    base = fly(city, flow, planner=Drift(), duration=40.0,
               escape=EscapeConfig(airspeed_mps=8.0, window_s=1e6))
    assert base.outcome == "left_map" and base.settings["escapes"] == []
    res = fly(city, flow, planner=Drift(), duration=40.0,
              escape=EscapeConfig(airspeed_mps=8.0, window_s=1e6, edge_m=8.0))
    assert res.outcome == "success", res.summary()
    (escape,) = res.settings["escapes"]
    k = int(round(escape[0] / 0.01))
    assert 112.0 <= res.position[k, 1] < 112.0 + 2.0  # began on crossing y = 120 - 8
    # the route runs outside the 8 m band, after the way out of it
    assert np.all(res.route[1:, 1] <= 112.0) and np.all(res.route[1:, 0] >= 8.0)


class Crawl:
    """A planner that flies toward the goal at 1.5 m/s, flying north around the building:
    faster than the stall monitor's 0.67 m/s and the hover rule's 1 m/s, too slow to arrive."""

    def update(self, state, scan=None, wind=None):
        p, v = np.asarray(state[:2], dtype=float), np.asarray(state[2:4], dtype=float)
        aim = np.array([40.0, 85.0]) if p[0] < 40.0 and p[1] < 80.0 else np.asarray(GOAL)
        e = (aim - p) / max(np.hypot(*(aim - p)), 1e-9)
        return 2.0 * (1.5 * e - v)

    def reset(self):
        pass


def test_pace_trigger_turns_a_crawl_that_runs_out_of_time_into_a_success(city, flow):
    # 40 s of flight: the goal hold must begin by 35 s; at 1.5 m/s the crawl cannot make it
    base = fly(city, flow, planner=Crawl(), duration=40.0, escape=EscapeConfig(airspeed_mps=8.0))
    assert base.outcome == "timeout" and base.settings["escapes"] == []
    res = fly(city, flow, planner=Crawl(), duration=40.0,
              escape=EscapeConfig(airspeed_mps=8.0, pace_margin_s=5.0))
    assert res.outcome == "success", res.summary()
    (escape,) = res.settings["escapes"]
    # one pace window (10 s) must pass before the trigger may judge the pace, which by then
    # projects an arrival long after 40 - 5 - 5 s
    assert escape[0] == pytest.approx(10.0, abs=0.11)


def test_fastest_escape_launch_begins_at_take_off_only_when_the_least_time_is_long():
    # from (10, 60): 100 m at 5 m/s, 20 s in the mean wind
    fn = Straight()
    esc = FastestEscape(fn, GOAL, EscapeConfig(airspeed_mps=10.0, launch_s=15.0))
    assert esc.update(0.0, (10, 60)) == (0.0, pytest.approx(100.0))
    assert esc.escapes == [(0.0, 0.0, pytest.approx(100.0))] and len(fn.calls) == 1
    # 20 s is not longer than 25 s: asked once at take-off, then the monitor as usual
    fn = Straight()
    esc = FastestEscape(fn, GOAL, EscapeConfig(airspeed_mps=10.0, launch_s=25.0))
    assert esc.update(0.0, (10, 60)) is None and esc.update(2.9, (10, 60)) is None
    assert len(fn.calls) == 1 and esc.escapes == []
    assert esc.update(3.0, (10, 60)) is not None and len(fn.calls) == 2
    assert esc.escapes == [(3.0, 0.0, pytest.approx(100.0))]
    # no route at take-off: MPPI flies, nothing is listed
    fn = Straight(fail=True)
    esc = FastestEscape(fn, GOAL, EscapeConfig(airspeed_mps=10.0, launch_s=1.0))
    assert esc.update(0.0, (10, 60)) is None and esc.escapes == [] and len(fn.calls) == 1
    with pytest.raises(ValueError, match="'launch_s'"):
        EscapeConfig(launch_s=30.0)
    with pytest.raises(ValueError, match="'launch_s'"):
        EscapeConfig(airspeed_mps=10.0, launch_s=-1.0)


def test_launch_flies_the_least_time_route_from_the_start(city, flow):
    base = fly(city, flow, planner=Crawl(), duration=40.0, escape=EscapeConfig(airspeed_mps=8.0))
    # a least time longer than the threshold: never launched, the same flight to the bit
    late = fly(city, flow, planner=Crawl(), duration=40.0,
               escape=EscapeConfig(airspeed_mps=8.0, launch_s=1000.0))
    assert late.settings["escapes"] == [] and np.array_equal(late.position, base.position)
    res = fly(city, flow, planner=Crawl(), duration=40.0,
              escape=EscapeConfig(airspeed_mps=8.0, launch_s=5.0))
    assert base.outcome == "timeout" and res.outcome == "success", res.summary()
    (escape,) = res.settings["escapes"]
    assert escape[0] == 0.0 and np.array_equal(res.route[0], np.asarray(START))
    # about 100 m at 8 m/s of airspeed in 2 m/s of wind: longer than 5 s, so it launched
    assert res.settings["route_time_s"] > 5.0
    # with a gust margin the route may go around the wake's gusts: no faster in the mean wind
    gusty = fly(city, flow, planner=Crawl(), duration=40.0,
                escape=EscapeConfig(airspeed_mps=8.0, launch_s=5.0, gust_k=1.0))
    assert gusty.settings["escapes"][0][0] == 0.0
    assert gusty.settings["route_time_s"] >= res.settings["route_time_s"] - 1e-9


def test_fastest_escape_restart_replaces_the_route_from_where_the_vehicle_is():
    fn = Straight()
    esc = FastestEscape(fn, GOAL, EscapeConfig(airspeed_mps=10.0, regain_m=20.0))
    esc.update(0.0, (10, 60))
    first = esc.update(3.0, (10, 60))
    assert first == (0.0, pytest.approx(100.0))
    # blown off the goal it held, to 30 m below it: a new route from there
    assert esc.restart(40.0, (110, 30)) == (0.0, pytest.approx(30.0))
    assert esc.route.samples[0].tolist() == [110.0, 30.0] and len(fn.calls) == 2
    assert esc.update(41.0, (110, 31)) == (0.0, pytest.approx(30.0))
    assert [e[0] for e in esc.escapes] == [3.0, 40.0]
    # no route: the escape in hand stays, the call is listed
    fn.fail = True
    assert esc.restart(45.0, (110, 20)) is None and esc.active == (0.0, pytest.approx(30.0))
    assert math.isnan(esc.escapes[-1][2])
    with pytest.raises(ValueError, match="'regain_m'"):
        EscapeConfig(regain_m=20.0)
    with pytest.raises(ValueError, match="'regain_m'"):
        EscapeConfig(airspeed_mps=10.0, regain_m=-1.0)


def gust_at_goal(flow, t0, t1, v_mps):
    """``flow`` with a uniform wind of ``v_mps`` toward -y added within 40 m of GOAL for frame
    times in [t0, t1) (the mean field unchanged: the planners do not know of the gust)."""
    import dataclasses

    near = (np.abs(flow.x[None, :] - GOAL[0]) <= 40.0) & (np.abs(flow.y[:, None] - GOAL[1]) <= 40.0)
    when = (flow.t >= t0) & (flow.t < t1)
    frames_v = flow.frames_v.copy()
    frames_v[when] -= v_mps * (near & ~flow.solid)
    return dataclasses.replace(flow, frames_v=frames_v)


def test_regain_flies_back_to_the_goal_from_where_a_gust_left_the_vehicle(city, flow):
    # the least-time escape takes the vehicle to the goal; a 3 s gust of 25 m/s then blows it
    # off the goal it holds, south; the hold alone brings it back here (no jet, no buildings
    # in the way), so this checks the mechanism, not that it is needed
    config = EscapeConfig(airspeed_mps=8.0)
    base = fly(city, flow, planner=Brake(), duration=40.0, escape=config)
    hold = base.settings["hold_started_s"]
    assert base.outcome == "success" and hold < 30.0
    gusty = gust_at_goal(flow, hold + 1.0, hold + 4.0, 25.0)
    blown = fly(city, gusty, planner=Brake(), duration=40.0, escape=config)
    d = np.hypot(*(blown.position[:, :2] - np.asarray(GOAL)).T)
    k = int(round((hold + 1.0) / 0.01))
    assert d[k:].max() > 20.0 and len(blown.settings["escapes"]) == 1
    assert blown.settings["hold_started_s"] == hold  # the hold was never released
    res = fly(city, gusty, planner=Brake(), duration=40.0,
              escape=EscapeConfig(airspeed_mps=8.0, regain_m=20.0))
    first, second = res.settings["escapes"]
    assert first == blown.settings["escapes"][0]  # the same flight up to the gust
    j = int(round(second[0] / 0.01))
    # the check runs with the planner, every 0.1 s: the vehicle crossed 20 m within the last
    assert d[j - 10] <= 20.0 < d[j] and np.array_equal(res.position[j], blown.position[j])
    assert np.array_equal(res.route[0], res.position[j, :2])  # the new route starts there
    assert res.outcome == "success" and res.settings["hold_started_s"] > second[0]
    with pytest.raises(ValueError, match="regain_m"):
        fly(city, flow, planner=Brake(), duration=40.0,
            escape=EscapeConfig(airspeed_mps=8.0, regain_m=10.0))


def test_the_edge_band_leaves_a_goal_inside_it_reachable(city, flow):
    """A goal nearer the map's edge than the edge guard (a small city's rule may keep goals
    10 m in while the sixth variant guards 15 m): the route's lattice narrows its band to
    leave the goal a cell clear of it. The goal's cell was taken out, and the first escape's
    search raised "the 'goal_xy' parameter of least_time lies inside a building or within
    6.0 m of one", ending the flight in a harness error."""
    from windnav.experiments.navigate import _FastestRouteFn

    goal = np.array([130.0, 60.0])  # 10 m from the east edge
    guarded = _FastestRouteFn(city, flow, goal, 8.0, dx=2.0, clearance=6.0, edge_m=15.0)
    route = guarded(np.array([60.0, 20.0]))
    assert np.allclose(route.samples[-1], goal) and route.time_s > 0
    assert route.samples[:, 0].max() <= 130.0 + 1e-9
    lat = guarded.lattice  # only the goal's side narrows: the other three keep 15 m
    assert not lat.free[:, lat.x < 15.0].any() and not lat.free[lat.y < 15.0].any()
    assert not lat.free[lat.y > 120.0 - 15.0].any()
    assert not lat.free[:, lat.x > 140.0 - 8.0].any() and lat.free[:, lat.x > 125.0].any()
    # a goal clear of the band: the band as before (no cell within 15 m of the edge)
    far = _FastestRouteFn(city, flow, np.asarray(GOAL), 8.0, dx=2.0, clearance=6.0,
                          edge_m=15.0)
    lat = far.lattice
    assert not lat.free[:, lat.x > 140.0 - 15.0].any() and not lat.free[lat.y < 15.0].any()
    assert guarded.lattice.free[:, lat.x > 140.0 - 15.0].any()
