"""The default solver: Smagorinsky closure, unbiased start, honest averages, batching, grids."""

import math

import numpy as np
import pytest

from windnav.city import City
from windnav.experiments.flow_validation import RESOLUTION_CASE
from windnav.flow import (
    BoundaryConditions,
    MACGrid,
    bluff_body_strouhal,
    make_domain,
    simulate,
    simulate_batch,
)
from windnav.flow.advection import _eddy_viscosity, make_advection
from windnav.flow.grid import grid_for
from windnav.flow.solver import (
    BITWISE_BATCH,
    FILTER_PER_BUILDING,
    SMAGORINSKY,
    city_domain,
    default_filter_width,
    initial_velocity,
    wake_seed,
)


def empty_city(lx=200.0, ly=120.0):
    return City((0.0, lx, 0.0, ly), np.zeros((0, 4)), np.zeros(0))


def city_of(footprints, lx=140.0, ly=80.0):
    return City((0.0, lx, 0.0, ly), footprints, np.full(len(footprints), 20.0))


EIGHT = [[20, 28, 10, 20], [24, 34, 45, 55], [45, 52, 25, 36], [60, 70, 52, 60],
         [75, 82, 12, 22], [88, 96, 35, 47], [105, 112, 58, 66], [110, 118, 15, 24]]


# ------------------------------------------------------------------ Strouhal, default settings


@pytest.mark.slow
def test_default_closure_square_strouhal_in_range_and_same_at_0_and_90_deg():
    """H = 8 cells (the coarse end of the 8/16/32 series of flow-validate --full): St of a
    square building from its lift history is in the experiments' range and does not depend on
    which grid axis the wind blows along."""
    from dataclasses import replace

    st = {}
    for angle in (0.0, 90.0):
        r = bluff_body_strouhal(replace(RESOLUTION_CASE, cells_per_height=8, angle_deg=angle))
        st[angle] = r["strouhal"]
        assert 0.12 <= r["strouhal"] <= 0.16, r["strouhal"]
        assert abs(r["strouhal"] - r["strouhal_crossings"]) < 0.005  # one clean frequency
        assert 1.5 < r["cd_mean"] < 2.6  # square-cylinder drag, experiments ~2.1
    assert abs(st[0.0] - st[90.0]) / st[0.0] <= 0.02


# ------------------------------------------------------------------ uniform flow, no bias


@pytest.mark.parametrize("direction", [0.0, 30.0, 135.0, 250.0])
@pytest.mark.parametrize("spinup", [0, 7])
def test_empty_map_gives_the_inlet_flow_exactly_with_default_settings(direction, spinup):
    sol = simulate(empty_city(), speed=4.0, direction_deg=direction, spinup_steps=spinup,
                   steps=6)
    speed = np.hypot(sol.mean_u, sol.mean_v)
    angle = np.rad2deg(np.arctan2(sol.mean_v, sol.mean_u))
    assert np.max(np.abs(speed - 4.0)) / 4.0 <= 1e-9
    dev = (angle - direction + 180.0) % 360.0 - 180.0
    assert np.max(np.abs(dev)) <= 1e-9 * 360.0
    assert sol.half_window_difference <= 1e-12


def test_start_kick_stays_in_the_near_wake_of_each_building():
    city = city_of([[40.0, 50.0, 30.0, 40.0]])
    domain = city_domain(city, 5.0, 0.0, 1.0)
    seed = wake_seed(domain)
    ii = np.nonzero(seed)[1]
    assert seed.sum() == 3 * 10 and ii.min() == 50 and ii.max() == 52  # 3 cells behind it
    assert not (seed & domain.solid).any()
    u0, v0 = domain.initial_velocity(0.0)
    u, v = initial_velocity(domain, 0.25)
    changed_u, changed_v = u != u0, v != v0
    assert not changed_u.any() and changed_v.sum() > 0  # 0 deg wind: the kick is across it
    rows, cols = np.nonzero(changed_v)
    assert cols.min() >= 50 and cols.max() <= 52
    assert not wake_seed(city_domain(empty_city(), 5.0, 30.0, 1.0)).any()


def test_mean_near_buildings_is_unbiased_within_its_own_half_window_difference():
    """With 8 buildings, the mean over 50 steps and over 400 steps (same start) differ by
    less than the 50-step mean's own reported half-window difference, and the longer window
    reports a smaller one. (The start's own bias is tested exactly on the empty map above: a
    domain-wide transverse start left 0.156 m/s there.)"""
    city = city_of(EIGHT)
    kw = dict(speed=5.0, direction_deg=15.0, dx=1.0, dt=0.25, spinup_steps=60)
    short = simulate(city, steps=50, **kw)
    long = simulate(city, steps=400, **kw)
    fluid = ~short.solid
    diff = np.sqrt(((short.mean_u - long.mean_u) ** 2 + (short.mean_v - long.mean_v) ** 2)
                   [fluid].mean()) / 5.0
    assert 0.0 < diff < short.half_window_difference
    assert long.half_window_difference < short.half_window_difference


def test_half_window_difference_is_the_rms_over_fluid_cells_of_the_frames_halves():
    """Its definition rebuilt from every step's frame (record_every=1, 12 steps): the means of
    frames 1-6 and 7-12, the RMS over fluid cells (buildings excluded, 11 % of this map) of
    their difference's magnitude, divided by the speed."""
    city = city_of([[15, 25, 12, 28], [35, 45, 5, 15]], 60.0, 40.0)
    sol = simulate(city, speed=5.0, direction_deg=10.0, dx=1.0, dt=0.25, spinup_steps=10,
                   steps=12, record_every=1)
    fluid = ~sol.solid
    assert sol.frames_u.shape[0] == 12 and 0.05 < sol.solid.mean() < 0.5
    du = sol.frames_u[:6].mean(axis=0) - sol.frames_u[6:].mean(axis=0)
    dv = sol.frames_v[:6].mean(axis=0) - sol.frames_v[6:].mean(axis=0)
    expected = math.sqrt(np.mean((du**2 + dv**2)[fluid])) / 5.0
    assert expected > 0.01
    assert sol.half_window_difference == pytest.approx(expected, rel=1e-9), \
        "half_window_difference must be the RMS over fluid cells only"


def test_diagnostics_count_flow_throughs_along_the_wind():
    sol = simulate(empty_city(200.0, 100.0), speed=4.0, direction_deg=0.0, dt=0.25,
                   spinup_steps=20, steps=40)
    assert sol.flow_throughs_spinup == pytest.approx(4.0 * 20 * 0.25 / 200.0)
    assert sol.flow_throughs_average == pytest.approx(4.0 * 40 * 0.25 / 200.0)
    diag = simulate(empty_city(200.0, 100.0), 4.0, 90.0, steps=4).diagnostics
    assert diag["flow_throughs_average"] == pytest.approx(4.0 * 4 * 0.25 / 100.0)
    assert diag["smagorinsky"] == SMAGORINSKY and diag["filter_width"] == 1.0
    assert np.isnan(simulate(empty_city(), 4.0, steps=1).half_window_difference)  # no halves


# ------------------------------------------------------------------ closure


def test_filter_width_is_the_median_building_side_over_8_or_dx():
    city = city_of([[10, 26, 10, 50], [40, 80, 10, 18], [90, 130, 20, 60]], 140.0, 80.0)
    # smaller sides 16, 8, 40 -> median 16 -> 2 m
    assert default_filter_width(city, 1.0) == pytest.approx(16.0 / FILTER_PER_BUILDING)
    assert default_filter_width(city, 4.0) == 4.0
    assert default_filter_width(empty_city(), 0.5) == 0.5
    sol = simulate(city, 5.0, steps=2, spinup_steps=0)
    assert sol.filter_width == pytest.approx(2.0)


def test_eddy_viscosity_is_zero_in_uniform_flow_and_closed_form_in_simple_shear():
    n, dx, gamma, cs_delta = 12, 0.5, 0.3, 0.2
    grid = MACGrid((n, n), dx)
    solid = np.zeros((n, n), bool)
    out, corner = np.zeros((n, n)), np.zeros((n + 1, n + 1))
    u = np.full((n, n + 1), 3.0)
    v = np.zeros((n + 1, n))
    assert _eddy_viscosity(u, v, solid, 0.0, cs_delta**2, 1 / dx, corner, out) == 0.0
    u = gamma * grid.y[:, None] + np.zeros((1, n + 1))  # u = gamma y: |S| = gamma
    top = _eddy_viscosity(u, v, solid, 0.01, cs_delta**2, 1 / dx, corner, out)
    np.testing.assert_allclose(out[1:-1, :], 0.01 + cs_delta**2 * gamma, rtol=1e-12)
    assert top == pytest.approx(0.01 + cs_delta**2 * gamma)


def test_eddy_viscosity_is_closed_form_in_pure_strain():
    """Pure strain u = gamma x, v = -gamma y (no shear): |S| = sqrt(2 (u_x^2 + v_y^2) +
    (u_y + v_x)^2) = sqrt(2 (gamma^2 + gamma^2)) = 2 gamma, so nu = nu0 + (C_s Delta)^2 2 gamma
    in every cell (the face differences of a linear field are exact, the edges included)."""
    ny, nx, dx, gamma, cs_delta, nu0 = 10, 14, 0.5, 0.3, 0.2, 0.01
    grid = MACGrid((ny, nx), dx)
    solid = np.zeros((ny, nx), bool)
    out, corner = np.zeros((ny, nx)), np.zeros((ny + 1, nx + 1))
    u = gamma * grid.x_faces[None, :] + np.zeros((ny, 1))
    v = -gamma * grid.y_faces[:, None] + np.zeros((1, nx))
    top = _eddy_viscosity(u, v, solid, nu0, cs_delta**2, 1 / dx, corner, out)
    expected = nu0 + cs_delta**2 * 2.0 * gamma
    np.testing.assert_allclose(out, expected, rtol=1e-12,
                               err_msg="nu_t of pure strain must be (C_s Delta)^2 * 2 gamma")
    assert top == pytest.approx(expected)


def test_eddy_diffusion_stays_bounded_for_any_viscosity():
    """A huge eddy viscosity (r = nu dt / dx^2 in the hundreds) is damped, never amplified:
    every update is a convex combination of the face, its neighbours and the walls (0)."""
    n = 24
    solid = np.zeros((n, n), bool)
    solid[9:14, 9:14] = True
    domain = make_domain(MACGrid((n, n), 1.0), solid, BoundaryConditions.for_wind(2.0, 0.0))
    rng = np.random.default_rng(0)
    adv = make_advection(domain, 1.0, "semi_lagrangian", viscosity=300.0, smagorinsky=5.0)
    u0, v0 = domain.initial_velocity(0.0)
    u = np.where(domain.u_code == 0, u0, rng.uniform(-3, 3, u0.shape))
    v = np.where(domain.v_code == 0, v0, rng.uniform(-3, 3, v0.shape))
    for _ in range(20):
        u, v = adv(u, v)
        assert np.all(np.isfinite(u)) and np.max(np.abs(u)) <= 3.0 + 1e-12
        assert np.max(np.abs(v)) <= 3.0 + 1e-12


# ------------------------------------------------------------------ batching and grids


def test_simulate_batch_equals_simulate_per_speed():
    city = city_of(EIGHT[:4], 90.0, 70.0)
    kw = dict(direction_deg=30.0, dx=1.0, dt=0.25, spinup_steps=15, steps=20)
    batch = simulate_batch(city, [2.0, 7.0], **kw)
    for sol in batch:
        one = simulate(city, speed=sol.speed, **kw)
        np.testing.assert_array_equal(sol.mean_u, one.mean_u)
        np.testing.assert_array_equal(sol.mean_v, one.mean_v)
        assert sol.diagnostics == one.diagnostics
    with pytest.raises(ValueError, match="'speeds'"):
        simulate_batch(city, [2.0, -1.0], **kw)
    with pytest.raises(ValueError, match="CFL"):
        simulate_batch(city, [2.0, 20.0], **kw)


def test_a_batch_of_up_to_three_winds_is_each_wind_to_the_bit():
    """Speeds and directions that share their inlet sides (15, 30 and 45 deg: west and
    south), stepped together with one three-column pressure solve per step, give each run's
    mean, frames and diagnostics exactly as a run of its own (BITWISE_BATCH); a four-run
    batch does not (CHOLMOD's four-column kernel sums in another order), which is why the
    benchmark batches at most three."""
    city = city_of(EIGHT[:5], 100.0, 80.0)
    kw = dict(dx=1.0, dt=0.25, spinup_steps=10, steps=12, record_every=3)
    winds = [(2.0, 15.0), (7.0, 30.0), (10.0, 45.0)]
    assert BITWISE_BATCH == len(winds)
    batch = simulate_batch(city, [s for s, _ in winds], [d for _, d in winds], **kw)
    ones = [simulate(city, s, d, **kw) for s, d in winds]
    for sol, one, (s, d) in zip(batch, ones, winds, strict=True):
        assert (sol.speed, sol.direction_deg) == (s, d)
        for name in ("mean_u", "mean_v", "frames_u", "frames_v"):
            np.testing.assert_array_equal(getattr(sol, name), getattr(one, name), err_msg=name)
        assert sol.diagnostics == one.diagnostics
    four = simulate_batch(city, [s for s, _ in winds] + [5.0],
                          [d for _, d in winds] + [15.0], **kw)
    pairs = zip(four[:3], ones, strict=True)
    assert not all(np.array_equal(a.frames_u, b.frames_u) for a, b in pairs)
    np.testing.assert_allclose(four[0].frames_u, ones[0].frames_u, rtol=0, atol=1e-9)


def test_a_batch_refuses_winds_whose_inlets_differ():
    city = city_of(EIGHT[:4], 90.0, 70.0)
    kw = dict(dx=1.0, dt=0.25, spinup_steps=2, steps=2)
    with pytest.raises(ValueError, match="same boundary kinds"):
        simulate_batch(city, [2.0, 5.0], [0.0, 30.0], **kw)
    with pytest.raises(ValueError, match="one per speed"):
        simulate_batch(city, [2.0, 5.0], [15.0, 30.0, 45.0], **kw)
    with pytest.raises(ValueError, match="'direction_deg'"):
        simulate_batch(city, [2.0, 5.0], [15.0, float("nan")], **kw)


@pytest.mark.parametrize("extent,dx", [(100.4, 1.0), (100.6, 1.0), (37.0, 2.5), (41.25, 0.75)])
def test_one_grid_rule_for_solver_and_sweep_store(extent, dx):
    from windnav.experiments.wind_sweep import solver_grid

    city = City((0.0, extent, 0.0, extent / 2), [[10.0, 14.0, 5.0, 9.0]], [10.0])
    grid = grid_for(city.bounds, dx)
    sol = simulate(city, 2.0, dx=dx, dt=0.1 * dx, spinup_steps=0, steps=1)
    x, y = solver_grid(city, dx)
    np.testing.assert_array_equal(sol.x, grid.x)
    np.testing.assert_array_equal(sol.y, grid.y)
    np.testing.assert_array_equal(x, grid.x)
    np.testing.assert_array_equal(y, grid.y)
    # the one rule (windnav.city.grid_shape): the grid covers the map
    assert grid.nx == math.ceil(extent / dx - 1e-9)
    assert (grid.ny, grid.nx) == City.grid(city, dx)[1].shape + City.grid(city, dx)[0].shape


def test_recorded_frames_are_adopted_by_the_wind_field_without_a_copy():
    from windnav.wind import GriddedWind

    city = City((0.0, 60.0, 0.0, 40.0), np.array([(20.0, 28.0, 16.0, 24.0)]), np.array([10.0]))
    sol = simulate(city, 3.0, 20.0, dx=2.0, dt=0.25, spinup_steps=2, steps=6, record_every=2)
    assert sol.frames_u.shape == (3, *sol.solid.shape)
    field = sol.wind_field(unsteady=True)
    assert np.shares_memory(field.u, sol.frames_u) and np.shares_memory(field.v, sol.frames_v)
    # the same field as from separate copies of the frames
    copied = GriddedWind(sol.x, sol.y, sol.frames_u.copy(), sol.frames_v.copy(), t=sol.t,
                         solid=sol.solid)
    assert not np.shares_memory(copied.u, sol.frames_u)
    np.testing.assert_array_equal(copied.u, field.u)
    np.testing.assert_array_equal(copied.v, field.v)
    xyz = np.array([[5.0, 7.0, 10.0], [41.3, 30.2, 10.0]])
    np.testing.assert_array_equal(copied.velocity(0.9, xyz), field.velocity(0.9, xyz))
    # u and v swapped, or frames of another array, are copied
    swapped = GriddedWind(sol.x, sol.y, sol.frames_v, sol.frames_u, t=sol.t)
    assert not np.shares_memory(swapped.u, sol.frames_v)
    np.testing.assert_array_equal(swapped.u, sol.frames_v)
