"""windnav.flow: projection invariants, boundary conditions, numerical viscosity, Strouhal."""

from __future__ import annotations

import importlib.util
from collections import OrderedDict

import numpy as np
import pytest

import windnav as wn
from windnav.city import City
from windnav.flow import (
    BoundaryConditions,
    FactorCache,
    FlowDivergedError,
    MACGrid,
    SquareCylinderCase,
    divergence,
    fixed_face_violation,
    make_advection,
    make_domain,
    make_exact_projection,
    make_flow_step,
    make_jacobi_projection,
    square_cylinder_strouhal,
    strouhal_number,
)
from windnav.flow.solver import _max_abs, check_finite


def _city():
    # two buildings, one touching the lower boundary, plus an enclosed courtyard (a ring)
    fp = [
        [10.0, 16.0, 8.0, 14.0],
        [24.0, 28.0, 0.0, 6.0],
        [30.0, 38.0, 14.0, 15.0],
        [30.0, 38.0, 21.0, 22.0],
        [30.0, 31.0, 14.0, 22.0],
        [37.0, 38.0, 14.0, 22.0],
    ]
    return City((0.0, 48.0, 0.0, 30.0), fp, np.full(len(fp), 10.0))


def _domain(direction_deg, speed=2.0, dx=1.0):
    city = _city()
    x0, x1, y0, y1 = city.bounds
    grid = MACGrid((int((y1 - y0) / dx), int((x1 - x0) / dx)), dx, (x0, y0))
    solid = city.rasterize(grid.x, grid.y)
    return make_domain(grid, solid, BoundaryConditions.for_wind(speed, direction_deg))


@pytest.mark.parametrize("direction_deg", [0.0, 37.0, 90.0, 180.0, 225.0, 301.0])
def test_exact_projection_is_divergence_free_after_every_step(direction_deg):
    speed, dx, dt = 2.0, 1.0, 0.4
    domain = _domain(direction_deg, speed, dx)
    step = make_flow_step(domain, dt)
    rng = np.random.default_rng(1)
    u, v = domain.initial_velocity(0.1 * speed)
    u = np.where(domain.u_code > 0, u + 0.3 * speed * rng.standard_normal(u.shape), u)
    v = np.where(domain.v_code > 0, v + 0.3 * speed * rng.standard_normal(v.shape), v)
    assert np.abs(divergence(domain, u, v)).max() > 0.1
    tol = 1e-8 * speed / dx
    u, v = step.project(u, v)
    assert np.abs(divergence(domain, u, v)).max() <= tol
    for _ in range(30):
        u, v = step(u, v)
        assert np.abs(divergence(domain, u, v)).max() <= tol
        assert fixed_face_violation(domain, u, v) == 0.0


def test_enclosed_courtyard_is_filled_and_pure_neumann_box_is_pinned():
    domain = _domain(0.0)
    # the ring's inside (31..37 x 15..21) cannot reach the outflow: filled, so A is SPD
    assert domain.filled[17, 33] and domain.filled.sum() == 6 * 6
    # a closed box (all walls) has a singular Poisson problem: pinned, still exact
    grid = MACGrid((16, 20), 0.5)
    box = make_domain(grid, np.zeros((16, 20), bool), BoundaryConditions(("wall",) * 4))
    rng = np.random.default_rng(0)
    u = np.where(box.u_code > 0, rng.standard_normal(box.u_code.shape), 0.0)
    v = np.where(box.v_code > 0, rng.standard_normal(box.v_code.shape), 0.0)
    u, v = make_exact_projection(box)(u, v)
    assert np.abs(divergence(box, u, v)).max() <= 1e-10


def test_orderings_give_the_same_projection():
    domain = _domain(37.0)
    rng = np.random.default_rng(2)
    u = np.where(domain.u_code > 0, rng.standard_normal(domain.u_code.shape), domain.u_fixed)
    v = np.where(domain.v_code > 0, rng.standard_normal(domain.v_code.shape), domain.v_fixed)
    ref = make_exact_projection(domain, "COLAMD")(u, v)
    for ordering in ("red_black", "nested_dissection", "MMD_AT_PLUS_A"):
        got = make_exact_projection(domain, ordering)(u, v)
        np.testing.assert_allclose(got[0], ref[0], atol=1e-11)
        np.testing.assert_allclose(got[1], ref[1], atol=1e-11)


def test_cholmod_and_superlu_backends_agree_for_one_and_many_fields():
    """The default CHOLMOD factor and SuperLU's give the same projection, for one field and
    for several fields projected together (one multi-right-hand-side solve)."""
    domain = _domain(37.0)
    rng = np.random.default_rng(3)
    fields = []
    for _ in range(3):
        u = np.where(domain.u_code > 0, rng.standard_normal(domain.u_code.shape), domain.u_fixed)
        v = np.where(domain.v_code > 0, rng.standard_normal(domain.v_code.shape), domain.v_fixed)
        fields.append((u, v))
    chol = make_exact_projection(domain)
    slu = make_exact_projection(domain, backend="superlu")
    outs = [(np.empty_like(u), np.empty_like(v)) for u, v in fields]
    chol.into_many(*zip(*fields, strict=True), *zip(*outs, strict=True))
    for (u, v), (ou, ov) in zip(fields, outs, strict=True):
        ref = slu(u, v)
        np.testing.assert_allclose(chol(u, v)[0], ref[0], atol=1e-11)
        np.testing.assert_allclose(ou, ref[0], atol=1e-11)
        np.testing.assert_allclose(ov, ref[1], atol=1e-11)
        assert np.abs(divergence(domain, ou, ov)).max() <= 1e-10
    with pytest.raises(ValueError, match="'backend'"):
        make_exact_projection(domain, backend="umfpack")


def test_factor_cache_is_explicit_and_shared():
    """No module-level cache: a caller-owned FactorCache shares one factorisation between
    projections of the same face classification, and projecting is pure (no captured
    buffer: two calls on different inputs leave the first result untouched)."""
    from windnav.flow import pressure

    assert not any(isinstance(v, OrderedDict) for v in vars(pressure).values())
    domain = _domain(37.0)
    cache = FactorCache(maxsize=2)
    first = pressure.factorize(domain, cache=cache)
    assert pressure.factorize(domain, cache=cache) is first
    assert pressure.factorize(domain) is not first  # no cache given: factorised afresh
    assert len(cache) == 1
    project = make_exact_projection(domain, cache=cache)
    assert len(cache) == 1
    rng = np.random.default_rng(4)
    u = np.where(domain.u_code > 0, rng.standard_normal(domain.u_code.shape), domain.u_fixed)
    v = np.where(domain.v_code > 0, rng.standard_normal(domain.v_code.shape), domain.v_fixed)
    a = project(u, v)
    kept = (a[0].copy(), a[1].copy())
    project(2.0 * u, 2.0 * v)
    np.testing.assert_array_equal(a[0], kept[0])
    np.testing.assert_array_equal(a[1], kept[1])
    assert np.abs(divergence(domain, *a)).max() <= 1e-10
    with pytest.raises(ValueError, match="maxsize"):
        FactorCache(0)


def test_jacobi_reduces_but_does_not_remove_divergence():
    domain = _domain(0.0)
    rng = np.random.default_rng(3)
    u = np.where(domain.u_code > 0, rng.standard_normal(domain.u_code.shape), domain.u_fixed)
    v = np.where(domain.v_code > 0, rng.standard_normal(domain.v_code.shape), domain.v_fixed)
    before = np.abs(divergence(domain, u, v)).max()
    uj, vj = make_jacobi_projection(domain, 300)(u, v)
    after = np.abs(divergence(domain, uj, vj)).max()
    assert after < 0.1 * before
    assert after > 1e-8
    assert fixed_face_violation(domain, uj, vj) == 0.0


def test_buildings_have_zero_velocity_and_solid_normal_faces_stay_zero():
    city = _city()
    sol = wn.flow.simulate(city, speed=3.0, direction_deg=20.0, dx=1.0, dt=0.3,
                           spinup_steps=20, steps=30, record_every=10)
    assert sol.frames_u.shape == (3, 30, 48) and sol.t.tolist() == pytest.approx([3, 6, 9])
    for field in (sol.mean_u, sol.mean_v, sol.frames_u, sol.frames_v):
        assert np.all(field[..., sol.solid] == 0.0)
    assert np.abs(sol.mean_u[~sol.solid]).max() > 1.0  # the fluid does move


@pytest.mark.parametrize("direction_deg", [0.0, 30.0, 90.0, 200.0])
def test_uniform_flow_without_buildings_stays_uniform(direction_deg):
    city = City((0.0, 40.0, 0.0, 25.0), np.zeros((0, 4)), np.zeros(0))
    speed = 4.0
    want = speed * np.array([np.cos(np.deg2rad(direction_deg)), np.sin(np.deg2rad(direction_deg))])
    sol = wn.flow.simulate(city, speed=speed, direction_deg=direction_deg, dx=1.0, dt=0.2,
                           spinup_steps=10, steps=20, symmetry_break=0.0)
    np.testing.assert_allclose(sol.mean_u, want[0], atol=1e-10)
    np.testing.assert_allclose(sol.mean_v, want[1], atol=1e-10)
    # with the default symmetry break the transient is flushed within a few transit times
    sol = wn.flow.simulate(city, speed=speed, direction_deg=direction_deg, dx=1.0, dt=0.2,
                           spinup_steps=300, steps=20)
    np.testing.assert_allclose(sol.mean_u, want[0], atol=1e-3 * speed)
    np.testing.assert_allclose(sol.mean_v, want[1], atol=1e-3 * speed)


def test_rotating_the_map_rotates_the_wind():
    # a 90 deg rotation maps the MAC grid onto itself: same solver, rotated answer
    fp = np.array([[8.0, 13.0, 10.0, 14.0], [20.0, 22.0, 4.0, 12.0]])
    L = 32.0
    city = City((0.0, L, 0.0, L), fp, np.ones(2))
    # rotate (x, y) -> (L - y, x): footprints [x0,x1,y0,y1] -> [L-y1, L-y0, x0, x1]
    rot = np.column_stack([L - fp[:, 3], L - fp[:, 2], fp[:, 0], fp[:, 1]])
    city_r = City((0.0, L, 0.0, L), rot, np.ones(2))
    kw = dict(speed=2.0, dx=1.0, dt=0.3, spinup_steps=10, steps=10)
    a = wn.flow.simulate(city, direction_deg=0.0, **kw)
    b = wn.flow.simulate(city_r, direction_deg=90.0, **kw)
    # b(x', y') at (L - y, x) equals R a(x, y): u' = -v, v' = u
    np.testing.assert_allclose(np.rot90(a.mean_u, -1), b.mean_v, atol=1e-8)
    np.testing.assert_allclose(-np.rot90(a.mean_v, -1), b.mean_u, atol=1e-8)


def _taylor_green_viscosity(scheme, n=32, steps=60, viscosity=0.0):
    # u = sin x cos y, v = -cos x sin y in a free-slip box [0, pi]^2: steady for the Euler
    # equations; any decay is numerical. Energy ~ exp(-4 nu t) gives nu.
    dx = np.pi / n
    grid = MACGrid((n, n), dx)
    box = make_domain(grid, np.zeros((n, n), bool), BoundaryConditions(("wall",) * 4))
    xf, yc = grid.x_faces, grid.y
    xc, yf = grid.x, grid.y_faces
    u = np.sin(xf)[None, :] * np.cos(yc)[:, None]
    v = -np.cos(xc)[None, :] * np.sin(yf)[:, None]
    u[:, [0, -1]] = 0.0
    v[[0, -1], :] = 0.0
    dt = 0.5 * dx
    step = make_flow_step(box, dt, make_advection(box, dt, scheme, viscosity), "exact")
    u, v = step.project(u, v)
    energy = []
    for _ in range(steps):
        energy.append(0.5 * (np.sum(u**2) + np.sum(v**2)) * dx**2)
        u, v = step(u, v)
    energy = np.array(energy)
    t = dt * np.arange(steps)
    slope = np.polyfit(t, np.log(energy), 1)[0]
    return -slope / 4.0, energy


def test_taylor_green_numerical_viscosity_ordering():
    nu_sl, e_sl = _taylor_green_viscosity("semi_lagrangian")
    nu_mc, e_mc = _taylor_green_viscosity("maccormack")
    # inviscid flow: energy can only be lost (numerically), never gained
    assert np.all(np.diff(e_sl) < 0) and np.all(np.diff(e_mc) <= 1e-12 * e_mc[0])
    assert 0.0 < nu_mc < 0.5 * nu_sl
    # semi-Lagrangian bilinear diffusion is O(dx^2 / dt) ~ a few 1e-2 here
    assert 1e-3 < nu_sl < 0.2


@pytest.mark.parametrize("scheme", ["semi_lagrangian", "maccormack"])
def test_explicit_viscosity_adds_nu_to_the_taylor_green_decay(scheme):
    # Taylor-Green in a free-slip box is an exact Navier-Stokes solution decaying as
    # exp(-4 nu t) in energy: the explicit term must add nu (less the 5-point stencil's
    # O(k^2 dx^2) deficit, ~0.2 % here) to the scheme's own numerical viscosity.
    nu = 0.05
    nu_num, _ = _taylor_green_viscosity(scheme)
    nu_total, _ = _taylor_green_viscosity(scheme, viscosity=nu)
    assert nu_total - nu_num == pytest.approx(nu, rel=0.05)


def test_strouhal_number_of_a_square_building():
    case = SquareCylinderCase(cells_per_side=8, advection="semi_lagrangian")
    res = square_cylinder_strouhal(case)
    assert 0.12 <= res["strouhal"] <= 0.16
    # the spectral estimate agrees with the zero-crossing count
    assert abs(res["strouhal_spectrum"] - res["strouhal"]) < 0.01


def test_strouhal_number_of_a_square_building_maccormack_at_re_100():
    # the default scheme with a physical viscosity: St ~ 0.14-0.15 at Re = 100 (Okajima 1982;
    # Sohankar et al. 1998); the D = 8 -> 16 -> 32 halving study is in flow-validate --full
    case = SquareCylinderCase(cells_per_side=8, advection="maccormack", reynolds=100.0)
    res = square_cylinder_strouhal(case)
    assert 0.13 <= res["strouhal"] <= 0.16
    assert abs(res["strouhal_spectrum"] - res["strouhal"]) < 0.01


def test_strouhal_number_of_a_pure_tone():
    t = np.arange(0.0, 200.0, 0.05)
    sig = np.sin(2 * np.pi * 0.13 * t + 0.3) + 0.1 * np.sin(2 * np.pi * 0.41 * t)
    assert strouhal_number(sig, 0.05, 2.0, 2.0) == pytest.approx(0.13, rel=2e-3)
    assert strouhal_number(sig, 0.05, 2.0, 2.0, "spectrum") == pytest.approx(0.13, rel=2e-3)
    assert np.isnan(strouhal_number(np.ones(50), 0.1, 1.0, 1.0))


@pytest.mark.parametrize(
    "kwargs, name",
    [
        (dict(speed=float("nan")), "speed"),
        (dict(speed=-1.0), "speed"),
        (dict(direction_deg=float("nan")), "direction_deg"),
        (dict(dx=0.0), "dx"),
        (dict(dx=-1.0), "dx"),
        (dict(dt=5.0), "dt"),
        (dict(steps=0), "steps"),
        (dict(record_every=-1), "record_every"),
        (dict(record_every=100), "record_every"),  # more than steps: no frame, silently
        (dict(viscosity=-1e-3), "viscosity"),
        (dict(viscosity=float("inf")), "viscosity"),
    ],
)
def test_bad_input_names_the_argument(kwargs, name):
    with pytest.raises(ValueError, match=f"'{name}'"):
        wn.flow.simulate(_city(), **{"speed": 2.0, "dt": 0.2, "steps": 2, **kwargs})


@pytest.mark.parametrize("city", [None, "map.json"])
def test_a_city_of_another_type_is_named(city):
    with pytest.raises(ValueError, match="'city' parameter of simulate must be a "
                                         "windnav.city.City .*Got (NoneType|str) instead"):
        wn.flow.simulate(city, speed=2.0, dt=0.2, steps=2)


def test_an_inlet_past_the_incompressible_model_is_refused():
    """1e300 m/s overflowed in the diffusion (an OverflowError from `windnav predict`); any
    inlet past Mach 0.3 is outside the incompressible model, so it is refused, named."""
    with pytest.raises(ValueError, match=r"'speed' parameter of simulate must be <= 100 m/s: "
                                         r"the solver is incompressible.*Got 1e\+300"):
        wn.flow.simulate(_city(), speed=1e300, dt=1e-300, steps=2)
    with pytest.raises(ValueError, match=r"'speeds' parameter of simulate_batch .* Got 101\.0"):
        wn.flow.simulate_batch(_city(), [2.0, 101.0], 0.0, 1.0, 0.01, 1, 2)


def test_cfl_error_reports_the_cfl_number():
    with pytest.raises(ValueError, match=r"'dt'.*CFL number speed\*dt/dx = 5"):
        wn.flow.simulate(_city(), speed=5.0, dx=1.0, dt=1.0)


def test_blocked_inlet_is_rejected():
    wall = City((0.0, 30.0, 0.0, 20.0), [[0.0, 2.0, 0.0, 20.0]], [5.0])
    with pytest.raises(ValueError, match="'city'.*inlet"):
        wn.flow.simulate(wall, speed=2.0, dt=0.2, steps=2)
    # ... and blocking the only outlet leaves no through-flow either
    with pytest.raises(ValueError, match="'city'.*inlet"):
        wn.flow.simulate(wall, speed=2.0, direction_deg=180.0, dt=0.2, steps=2)
    # the same wall is harmless when the wind runs along it
    sol = wn.flow.simulate(wall, speed=2.0, direction_deg=90.0, dt=0.2, spinup_steps=0, steps=2)
    assert np.isfinite(sol.mean_v).all() and sol.mean_v[~sol.solid].min() > 1.0


def test_blowup_is_reported_with_the_step_number():
    u = np.zeros((4, 5))
    v = np.zeros((5, 4))
    check_finite(u, v, 10.0, 3)
    v[2, 1] = np.nan
    with pytest.raises(FlowDivergedError, match="step 7.*non-finite"):
        check_finite(u, v, 10.0, 7)
    v[2, 1] = 11.0
    with pytest.raises(FlowDivergedError, match="step 8"):
        check_finite(u, v, 10.0, 8)


def _gap(speed: float = 2.0):
    # a wall across a 40 m wide stream, with a 3 m gap: the start's jet is 20 x the inlet
    return City((0.0, 60.0, 0.0, 40.0), [[28.0, 32.0, 0.0, 18.5], [28.0, 32.0, 21.5, 40.0]],
                [5.0, 5.0])


def test_a_narrow_gap_is_no_blowup_but_growth_past_its_start_jet_is(monkeypatch):
    import windnav.flow.solver as solver

    # the jet through the gap is the flow's own, from the first projection: the run goes on
    # (with the limit at 10 x the inlet alone, it stopped at step 1)
    sol = wn.flow.simulate(_gap(), speed=2.0, dt=0.2, dx=1.0, spinup_steps=5, steps=20)
    assert np.isfinite(sol.mean_u).all() and np.nanmax(np.abs(sol.mean_u)) > 10 * 2.0
    # the same map whose advection gains 20 % a step blows up past 1.25 x that jet
    make = solver.make_flow_step

    def gaining(*args, **kwargs):
        step = make(*args, **kwargs)
        advect = step.advect

        class Gain:
            def into(self, u, v, out_u, out_v):
                advect.into(u, v, out_u, out_v)
                out_u *= 1.2
                out_v *= 1.2

        step.advect = Gain()
        return step

    monkeypatch.setattr(solver, "make_flow_step", gaining)
    with pytest.raises(FlowDivergedError, match=r"step [2-9].*1.25 x the start's fastest jet, "
                                                r"2\d.* x the inlet speed"):
        wn.flow.simulate(_gap(), speed=2.0, dt=0.2, dx=1.0, spinup_steps=5, steps=20)


def test_blowup_limit_is_ten_times_the_inlet_unless_the_start_jets_faster():
    from windnav.flow.solver import START_JET_MARGIN, blowup_limit

    u, v = np.full((4, 5), 3.0), np.zeros((5, 4))
    assert blowup_limit(2.0, u, v) == (20.0, "10 x the inlet speed")
    u[1, 2] = -30.0
    limit, basis = blowup_limit(2.0, u, v)
    assert limit == START_JET_MARGIN * 30.0 and basis.startswith("1.25 x the start's")
    u[1, 2] = np.nan  # a start that is not finite sets no limit of its own
    assert blowup_limit(2.0, u, v)[0] == 20.0


def test_the_blowup_check_finds_the_exact_largest_magnitude_or_inf():
    rng = np.random.default_rng(5)
    a = rng.standard_normal((40, 41)) * 10.0 ** rng.integers(-300, 300, (40, 41))
    a[3, 4] = 5e-324  # subnormal
    a[7, 8] = -0.0
    for x in (a, a[:, ::3], -a.T, np.zeros((3, 3)), np.full((2, 2), -0.0)):
        assert _max_abs(x) == np.max(np.abs(x))  # the value itself, not an approximation
    for bad in (np.nan, np.inf, -np.inf):
        for where in ((0, 0), (20, 17), (39, 40)):
            b = a.copy()
            b[where] = bad
            assert _max_abs(b) == np.inf


def test_mac_grid_is_a_checked_value():
    g = MACGrid((3, 4), 0.5, (1.0, 2.0))
    assert g == MACGrid((3, 4), 0.5, (1.0, 2.0))
    np.testing.assert_allclose(g.x, [1.25, 1.75, 2.25, 2.75])
    np.testing.assert_allclose(g.y_faces, [2.0, 2.5, 3.0, 3.5])
    with pytest.raises(ValueError, match="'u' field"):
        g.check_u(np.zeros((3, 4)))
    with pytest.raises(ValueError, match="'dx'"):
        MACGrid((3, 4), 0.0)


@pytest.mark.skipif(importlib.util.find_spec("windnav.wind.gridded") is None,
                    reason="windnav.wind.gridded not written yet")
def test_wind_field_matches_the_solution_at_cell_centres():
    sol = wn.flow.simulate(_city(), speed=2.0, direction_deg=10.0, dt=0.3, spinup_steps=5,
                           steps=6, record_every=2)
    xx, yy = np.meshgrid(sol.x[3:9], sol.y[4:8])
    xyz = np.column_stack([xx.ravel(), yy.ravel(), np.full(xx.size, 5.0)])
    steady = sol.wind_field().velocity(0.0, xyz)
    np.testing.assert_allclose(steady[:, 0], sol.mean_u[4:8, 3:9].ravel(), atol=1e-12)
    np.testing.assert_allclose(steady[:, 1], sol.mean_v[4:8, 3:9].ravel(), atol=1e-12)
    unsteady = sol.wind_field(unsteady=True).velocity(sol.t[1], xyz)
    np.testing.assert_allclose(unsteady[:, 0], sol.frames_u[1, 4:8, 3:9].ravel(), atol=1e-12)


def test_the_solvers_frames_skip_the_finite_scan_and_any_other_frames_do_not(monkeypatch):
    import dataclasses

    import windnav.wind.gridded as gridded

    sol = wn.flow.simulate(_city(), speed=2.0, direction_deg=10.0, dt=0.3, spinup_steps=5,
                           steps=6, record_every=2)
    scans = []
    real = gridded._all_finite
    monkeypatch.setattr(gridded, "_all_finite", lambda a: scans.append(a.shape) or real(a))
    with pytest.raises(ValueError, match="read-only"):  # and they stay so: no writes
        sol.frames_u[0, 0, 0] = np.nan
    field = sol.wind_field(unsteady=True)
    assert scans == []                                   # finite by construction: no scan
    checked = gridded.GriddedWind(sol.x, sol.y, sol.frames_u, sol.frames_v, t=sol.t)
    assert len(scans) == 2                               # the same frames, scanned
    np.testing.assert_array_equal(field.u, checked.u)    # and the same field
    np.testing.assert_array_equal(field.v, checked.v)
    # a solution made from it (other frames) is scanned again, and NaN is caught
    bad = np.array(sol.frames_u)
    bad[1, 2, 3] = np.nan
    other = dataclasses.replace(sol, frames_u=bad)
    with pytest.raises(ValueError, match="'u'.*must be finite"):
        other.wind_field(unsteady=True)
    # the steady mean is scanned as before
    scans.clear()
    sol.wind_field()
    assert len(scans) == 2


# ----------------------------------------------------------------- validity flags (notes only)


def _diag(spinup, window, halves):
    return {"flow_throughs_spinup": spinup, "flow_throughs_average": window,
            "half_window_difference": halves}


def test_a_window_much_shorter_than_a_flow_through_is_not_converged_though_its_halves_agree():
    """Audit: 400 + 2 steps at 5 m/s on a 200 m map (spin-up 2, window 0.01 flow-throughs)
    had halves 0.031 apart and no warning, but was 0.265 U RMS from the mean of 1600 steps:
    two snapshots a step apart always agree."""
    from windnav.commands.wind import averaging_report
    from windnav.flow.validity import averaging_verdict

    verdict = averaging_verdict(_diag(2.0, 0.01, 0.031))
    assert verdict["converged"] is False and verdict["level"] == "warning"
    assert "window 0.01 flow-throughs, under 0.5" in verdict["reason"]

    class Short:
        diagnostics = {**_diag(2.0, 0.01, 0.031), "smagorinsky": 0.17, "filter_width": 2.5}

    assert "warning: the mean is not converged: window 0.01" in averaging_report(Short())
    # long enough, spun up, halves agreeing: converged, and no line added to the report
    ok = averaging_verdict(_diag(1.2, 0.6, 0.04))
    assert ok["converged"] is True and ok["level"] == "ok"
    Short.diagnostics.update(_diag(1.2, 0.6, 0.04))
    assert "\n" not in averaging_report(Short())
    # fewer than 2 averaged steps: the halves are not compared (NaN), not "converged"
    assert averaging_verdict(_diag(2.0, 0.6, float("nan")))["converged"] is False
    assert averaging_verdict({})["converged"] is None


@pytest.mark.parametrize("direction_deg", [0.0, 45.0])
def test_the_thesis_protocol_is_a_young_mean_a_note_not_a_warning(direction_deg):
    """dx 1 m, dt 0.25 s, 100 + 200 steps at 10 m/s over a 600 m map: spin-up 0.42 and window
    0.83 flow-throughs along x (0.29 and 0.59 along the diagonal). With halves that agree the
    verdict is a young mean, worded as a note."""
    from windnav.flow.validity import averaging_message, averaging_verdict

    a = np.deg2rad(direction_deg)
    length = 600.0 * (abs(np.cos(a)) + abs(np.sin(a)))
    spin, window = 10.0 * 0.25 * 100 / length, 10.0 * 0.25 * 200 / length
    assert spin == pytest.approx(0.4167 if direction_deg == 0 else 0.2946, abs=1e-4)
    verdict = averaging_verdict(_diag(spin, window, 0.03))
    assert verdict["converged"] is False and verdict["level"] == "note"
    assert averaging_message(verdict).startswith("note: the mean is young: spin-up 0.")
    # a spin-up under a quarter of a flow-through (the slow inlets of one-dt sweeps) is not
    assert averaging_verdict(_diag(0.1, window, 0.03))["level"] == "warning"


def test_a_cell_above_a_eighth_of_the_median_building_is_accepted_with_a_note():
    """docs/flow_validation.md validates grid independence for dx <= s/8 only (s the median
    building's smaller side: 20 m here, s/8 = 2.5 m); dx 4 is run, but said to be
    grid-dependent (check_resolution's warning, which simulate gives)."""
    from windnav.flow.validity import resolution_check

    city = City((0.0, 200.0, 0.0, 200.0),
                [[60.0, 80.0, 60.0, 90.0], [100.0, 125.0, 50.0, 70.0],
                 [140.0, 160.0, 80.0, 130.0]], [20.0, 20.0, 20.0])
    check = resolution_check(city, 4.0)
    assert check["grid_dependent"] and check["validated_dx"] == 2.5
    assert "cell size above the validated resolution (s/8 = 2.5 m" in check["note"]
    assert "results grid-dependent" in check["note"]
    assert resolution_check(city, 2.5)["note"] is None
    with pytest.warns(UserWarning, match="simulate: cell size above the validated resolution"):
        city.check_resolution(4.0, "simulate")
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        city.check_resolution(2.0, "simulate")  # validated: no warning


def test_jets_past_mach_0_3_or_too_long_a_trace_are_warned():
    """A 1 m street through a 40 m barrier at a 5 m/s inlet made a 205 m/s mean jet (41 x the
    inlet), reported as an ordinary flow: the inlet alone was checked (failure audit,
    2026-12-06). A wide street at the same inlet is not warned."""
    import warnings

    barrier = City((0.0, 60.0, 0.0, 41.0), np.array([[10, 50, 0, 20], [10, 50, 21, 41]], float),
                   np.array([10.0, 10.0]))
    kw = dict(speed=5.0, direction_deg=0.0, dx=1.0, dt=0.2, spinup_steps=20, steps=20)
    with pytest.warns(RuntimeWarning, match=r"mean flow reaches 20\d m/s .* past Mach 0\.3 .* "
                                            r"4\d\.?\d* cells a step, past 20"):
        wn.flow.simulate(barrier, **kw)
    wide = City((0.0, 60.0, 0.0, 41.0), np.array([[10, 50, 0, 12], [10, 50, 29, 41]], float),
                np.array([10.0, 10.0]))
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        wn.flow.simulate(wide, **kw)


def test_a_sealed_courtyard_filled_as_solid_is_warned():
    """The solver fills air the outflow cannot reach (a courtyard walled in on every side) as
    solid; ``predict`` inside one read 0 m/s, and nothing said the pocket was filled (failure
    audit, 2026-12-06)."""
    walls = np.array([[20, 40, 10, 12], [20, 40, 28, 30], [20, 22, 10, 30], [38, 40, 10, 30]],
                     float)
    city = City((0.0, 60.0, 0.0, 40.0), walls, np.full(4, 10.0))
    with pytest.warns(RuntimeWarning, match=r"256 cells \(256 m\^2\) enclosed by buildings"):
        wn.flow.simulate(city, speed=3.0, direction_deg=0.0, dx=1.0, dt=0.25, spinup_steps=2,
                         steps=2)
