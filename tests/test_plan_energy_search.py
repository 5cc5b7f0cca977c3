"""GS / GS+W: energy-optimal routes on the (position, ground speed) lattice."""

import numpy as np
import pytest

import windnav as wn
from windnav.city import City
from windnav.plan import MOVES, energy_route, planner_config, with_variant


@pytest.fixture(scope="module")
def gs_w():
    return planner_config(wn.vehicle.params("hummingbird"), "gs-w")


def _v_r(cfg, direction, wind):
    """Brute-force argmin_V P(|V e - w|) / V over [0.5, 20] m/s, and the minimum (J/m)."""
    v = np.linspace(0.5, 20.0, 400001)
    f = cfg.power(np.hypot(*(v[:, None] * direction - np.asarray(wind, float)).T)) / v
    return v[np.argmin(f)], f.min()


@pytest.mark.parametrize("wind", [(0.0, 0.0), (4.0, 2.0), (-4.0, -2.0), (-2.0, 4.0)])
def test_empty_map_uniform_wind_gives_the_straight_line_at_v_r(gs_w, wind):
    city = City((0, 200, 0, 200), np.zeros((0, 4)), np.zeros(0))
    start, goal = np.array([10.0, 30.0]), np.array([190.0, 120.0])
    r = energy_route(city, start, goal, gs_w, wind=wind)
    np.testing.assert_allclose(r.waypoints, [start, goal])
    e = (goal - start) / np.linalg.norm(goal - start)
    v_r, e_min = _v_r(gs_w, e, wind)
    np.testing.assert_allclose(r.speeds, v_r, atol=1e-3)
    length = np.linalg.norm(goal - start)
    assert r.length == pytest.approx(length)
    assert r.energy == pytest.approx(length * e_min, rel=1e-6)
    assert r.time == pytest.approx(length / v_r, rel=1e-3)
    np.testing.assert_allclose(r.airspeeds, np.linalg.norm(v_r * e - np.array(wind)), atol=1e-3)
    # the lattice path (16 directions) costs at most a few per cent more than the line
    assert r.energy <= r.lattice_energy <= 1.03 * r.energy


def test_gs_plans_in_still_air_whatever_the_wind(gs_w):
    city = City((0, 200, 0, 200), np.zeros((0, 4)), np.zeros(0))
    gs = with_variant(gs_w, "gs")
    with pytest.warns(UserWarning, match="'wind' parameter of energy_route is ignored"):
        r = energy_route(city, (10, 100), (190, 100), gs, wind=(-5.0, 0.0))
    np.testing.assert_allclose(r.speeds, gs.max_range_speed(0.0), atol=1e-3)
    assert r.variant == "gs"


def test_gs_w_takes_the_sheltered_corridor(gs_w):
    """Two corridors around a central block; a strong headwind blows in the southern one, which
    is the shorter. GS (still air) takes the shorter; GS+W the sheltered one, and uses less
    energy in the real wind."""
    city = City((0, 300, 0, 160), [[60, 240, 50, 110], [60, 240, 0, 10]], [30, 30])

    class CorridorWind:
        def velocity(self, t, xyz):
            w = np.zeros((len(xyz), 3))
            w[:, 0] = np.where(xyz[:, 1] < 50, -9.0, 0.0)
            return w

    start, goal = (20.0, 40.0), (280.0, 40.0)
    with_wind = energy_route(city, start, goal, gs_w, wind=CorridorWind())
    still = energy_route(city, start, goal, with_variant(gs_w, "gs"))
    assert np.all(still.samples[:, 1] < 50.0)            # the short, windy corridor
    assert np.max(with_wind.samples[:, 1]) > 110.0        # around the block, out of the wind
    # flown in the real wind, GS's route costs more than GS+W's (the planner sees the wind on
    # its lattice, bilinear between cell centres: 1% of the step at the corridor's edge)
    assert _route_energy_in_wind(gs_w, with_wind, CorridorWind()) == pytest.approx(
        with_wind.energy, rel=0.01)
    in_wind = _route_energy_in_wind(gs_w, still, CorridorWind())
    assert in_wind > 1.1 * with_wind.energy


def _route_energy_in_wind(cfg, route, wind):
    """Energy of ``route`` flown at its own speeds through ``wind``, J."""
    seg = np.diff(route.samples, axis=0)
    length = np.linalg.norm(seg, axis=1)
    mid = 0.5 * (route.samples[1:] + route.samples[:-1])
    w = wind.velocity(0.0, np.c_[mid, np.zeros(len(mid))])[:, :2]
    air = np.linalg.norm(route.speeds[:, None] * seg / length[:, None] - w, axis=1)
    return float(np.sum(cfg.power(air) * length / route.speeds))


@pytest.mark.parametrize("seed", range(2))
def test_routes_keep_clearance_on_planning_maps(gs_w, seed):
    city = wn.city.planning_map(rng=seed, size=300.0)
    rng = np.random.default_rng(seed)
    from windnav.plan import free_space
    x, y, free = free_space(city, 2.0, 6.0)
    cells = np.argwhere(free)
    a, b = cells[rng.choice(len(cells), 2, replace=False)]
    start, goal = np.array([x[a[1]], y[a[0]]]), np.array([x[b[1]], y[b[0]]])
    r = energy_route(city, start, goal, gs_w, wind=(3.0, -2.0))
    pts = r.samples
    for x0, x1, y0, y1 in city.footprints:
        gx = np.maximum.reduce([x0 - pts[:, 0], np.zeros(len(pts)), pts[:, 0] - x1])
        gy = np.maximum.reduce([y0 - pts[:, 1], np.zeros(len(pts)), pts[:, 1] - y1])
        assert np.min(np.hypot(gx, gy)) > 6.0 - 2.0   # within one cell of the clearance
    assert r.energy <= r.lattice_energy * (1 + 1e-9)
    assert np.all((r.speeds >= 0.5) & (r.speeds <= 20.0))


def test_moves_and_bad_input(gs_w):
    assert len({tuple(m) for m in MOVES}) == 16
    city = City((0, 100, 0, 100), [[40, 60, 40, 60]], [20])
    with pytest.raises(ValueError, match="'goal_xy' parameter of energy_route"):
        energy_route(city, (5, 5), (50, 50), gs_w)
    walled = City((0, 100, 0, 100), [[45, 55, 0, 100]], [20])
    with pytest.raises(ValueError, match="cannot be reached"):
        energy_route(walled, (5, 50), (95, 50), gs_w)
    with pytest.raises(ValueError, match="'speed_range' parameter of energy_route"):
        energy_route(city, (5, 5), (95, 95), gs_w, speed_range=(5.0, 1.0))
    with pytest.raises(ValueError, match="'wind' parameter of energy_route"):
        energy_route(city, (5, 5), (95, 95), gs_w, wind=(1.0, np.nan))
    with pytest.raises(ValueError, match="'speed_step' parameter of energy_route must give at "
                                         "most"):
        energy_route(city, (5, 5), (95, 95), gs_w, speed_step=1e-9)  # 145 GiB before


@pytest.mark.parametrize("start, goal, name", [((-20, 20), (55, 20), "start_xy"),
                                               ((-500, 20), (55, 20), "start_xy"),
                                               ((5, 20), (55, 300), "goal_xy")])
def test_an_end_point_off_the_map_is_rejected(gs_w, start, goal, name):
    # a start off the map used to be snapped to the edge cell while the route began at the
    # real start: the first leg overran the kernel's buffer and the process later died with a
    # segmentation fault (found by a bad-input audit, 2026-12-05)
    city = City((0, 60, 0, 40), [[25, 35, 15, 25]], [10])
    with pytest.raises(ValueError, match=f"'{name}' parameter of energy_route must lie "
                                         "inside the map"):
        energy_route(city, start, goal, gs_w, wind=(3.0, 0.0))


def test_a_map_without_buildings_is_free_everywhere(gs_w):
    # the distance transform of an image with no background measures from a phantom corner;
    # free_space must not inherit that (a start 3 m from the edge of an empty map is free)
    from windnav.plan import free_space
    city = City((0, 20, 0, 20), np.zeros((0, 4)), np.zeros(0))
    _, _, free = free_space(city, 2.0, 6.0)
    assert free.all()
    r = energy_route(city, (3, 3), (17, 17), gs_w)
    assert r.length == pytest.approx(np.hypot(14, 14))


def test_edge_weight_uses_the_mean_wind_of_its_two_cells(gs_w):
    """Two free cells, winds (4, 0) and (-4, 3) m/s: both edges (+x and -x) weigh
    L min_v P(|v e - w|) / (P_hover v) over the speed levels, w = (0, 1.5) the cells' mean,
    against a brute-force minimum over the levels with the power curve."""
    from windnav.plan import _search_kernels as SK
    from windnav.plan.energy_search import _guards

    dx = 2.0
    free = np.ones((1, 2), bool)
    wind = np.array([[[4.0, 0.0], [-4.0, 3.0]]])
    speeds = np.arange(0.5, 20.0 + 1e-9, 0.25)
    n_cap = free.size * len(MOVES)
    rows, cols = np.empty(n_cap, np.int64), np.empty(n_cap, np.int64)
    weights, levels = np.empty(n_cap), np.empty(n_cap, np.int64)
    n = SK.edge_weights(free, wind, MOVES, _guards(MOVES), dx, speeds, gs_w.power_table(),
                        rows, cols, weights, levels)
    assert n == 2 and sorted(zip(rows[:n], cols[:n], strict=True)) == [(0, 1), (1, 0)]
    w_mean = wind[0].mean(axis=0)
    for k in range(n):
        e = np.array([1.0, 0.0]) if cols[k] == 1 else np.array([-1.0, 0.0])
        per_metre = gs_w.power(np.hypot(*(speeds[:, None] * e - w_mean).T)) / speeds
        expected = dx * per_metre.min() / gs_w.hover_power
        assert weights[k] == pytest.approx(expected, rel=1e-12), \
            f"edge {rows[k]}->{cols[k]} must use the mean wind {w_mean} of its two cells"
        assert speeds[levels[k]] == speeds[np.argmin(per_metre)]


def _cells_met(di, dj):
    """Brute force: cells (i, j) (unit squares centred on integers) whose closed square the
    segment (0, 0) -> (di, dj) meets, by exact slab clipping in rationals."""
    from fractions import Fraction as F

    met = set()
    for i in range(min(0, di) - 1, max(0, di) + 2):
        for j in range(min(0, dj) - 1, max(0, dj) + 2):
            lo, hi = F(0), F(1)
            for c, d in ((i, di), (j, dj)):  # c - 1/2 <= t d <= c + 1/2
                a, b = F(2 * c - 1, 2), F(2 * c + 1, 2)
                if d == 0:
                    lo, hi = (lo, hi) if a <= 0 <= b else (F(1), F(0))
                else:
                    t1, t2 = sorted((a / d, b / d))
                    lo, hi = max(lo, t1), min(hi, t2)
            if lo <= hi:
                met.add((i, j))
    return met


def test_a_move_is_refused_exactly_when_it_meets_a_blocked_cell():
    """Every one of the 16 moves from the centre of a free 5 x 5 grid, with one other cell
    blocked at a time: refused exactly when the straight move meets that cell's closed square
    (brute force), e.g. the knight move (2, 1) from (0, 0) crosses (1, 0) and (1, 1)."""
    from windnav.plan import _search_kernels as SK
    from windnav.plan.energy_search import _guards

    guards = _guards(MOVES)
    assert _cells_met(2, 1) == {(0, 0), (1, 0), (1, 1), (2, 1)}
    knight = int(np.flatnonzero((MOVES == (2, 1)).all(axis=1))[0])
    free = np.ones((3, 3), bool)
    free[1, 1] = False  # [j, i]: the cell (1, 1) the knight move (2, 1) from (0, 0) crosses
    assert not SK.move_ok(free, 0, 0, knight, MOVES, guards), "(2, 1) cuts the blocked (1, 1)"
    for m, (di, dj) in enumerate(MOVES):
        met = _cells_met(int(di), int(dj))
        for bj in range(-2, 3):
            for bi in range(-2, 3):
                if (bi, bj) == (0, 0):
                    continue
                free = np.ones((5, 5), bool)
                free[2 + bj, 2 + bi] = False
                ok = SK.move_ok(free, 2, 2, m, MOVES, guards)
                assert ok == ((bi, bj) not in met), \
                    f"move {(int(di), int(dj))} with cell {(bi, bj)} blocked: move_ok={ok}"
