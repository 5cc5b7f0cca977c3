"""MPPI planner: model and cost against a plain NumPy reference, sampling, closed-loop physics,
and bad input."""

import dataclasses
import types

import numba
import numpy as np
import pytest

import windnav as wn
from windnav.city import City
from windnav.plan import (
    NO_MISSION,
    LocalWind,
    MPPIPlanner,
    Problem,
    _kernels,
    fused_rollout_cost,
    mission_terms,
    obstacle_cost,
    obstacle_field,
    planner_config,
    rollout,
    sample_controls,
    scan_points,
    shift_controls,
    smoothing_matrix,
    softmin_weights,
    with_variant,
)


@pytest.fixture(scope="module")
def base():
    return planner_config(wn.vehicle.params("hummingbird"), "ea-mppi-w")


# --- a plain NumPy reference of the model and the cost (one step at a time) -------------------
def _ref_wind(wind: LocalWind | None, horizon, p):
    """w(p) (S, 2): the fill (zero by default) outside |p|_inf <= H/2; uniform, or bilinear
    clamped at the edges."""
    if wind is None:
        return np.zeros_like(p)
    inside = np.all(np.abs(p) <= horizon / 2, axis=1)[:, None]
    fill = np.asarray(wind.fill)
    if wind.is_uniform:
        return np.where(inside, wind.uv[:, 0, 0], fill)
    from scipy.interpolate import RegularGridInterpolator
    q = np.stack([np.clip(p[:, 1], wind.y[0], wind.y[-1]),
                  np.clip(p[:, 0], wind.x[0], wind.x[-1])], 1)
    w = np.stack([RegularGridInterpolator((wind.y, wind.x), wind.uv[c])(q) for c in (0, 1)], 1)
    return np.where(inside, w, fill)


def _ref_costs(cfg, u, v0, goal, pts, wind):
    """(S,) costs, (S, 3) parts and positions (S, K, 2) of controls u (S, K, 2)."""
    s, k = u.shape[:2]
    p = np.zeros((s, 2))
    v = np.tile(v0, (s, 1))
    jp = np.zeros(s)
    je = np.zeros(s)
    pos = []
    for t in range(k):
        va = v - _ref_wind(wind if cfg.use_wind else None, cfg.horizon, p)
        speed = np.linalg.norm(va, axis=1)
        je += cfg.power(speed) / cfg.hover_power * cfg.dt
        a = np.clip(u[:, t], cfg.a_min, cfg.a_max)
        p = p + cfg.dt * v
        v = v + cfg.dt * (a - cfg.drag * speed[:, None] * va)
        jp += np.sum(((p - goal) / cfg.lidar_range) ** 2, axis=1)
        pos.append(p)
    pos = np.stack(pos, 1)
    jo = obstacle_cost(pos, pts, cfg.lidar_range)
    return jp + cfg.obstacle_weight * jo + cfg.energy_weight * je, np.stack([jp, jo, je], 1), pos


@pytest.mark.parametrize("kind", ["none", "uniform", "grid", "grid-fill"])
def test_fused_kernel_matches_the_numpy_reference(base, kind):
    rng = np.random.default_rng(3)
    cfg = dataclasses.replace(base, n_samples=64, n_steps=30, horizon=60.0)
    if kind == "none":
        cfg, wind = with_variant(cfg, "ea-mppi"), None
    elif kind == "uniform":
        wind = LocalWind.uniform([4.0, -2.0])
    else:
        off = np.arange(-20, 21) * 1.5
        X, Y = np.meshgrid(off, off)
        # grid-fill: the onboard stack's option, a uniform wind outside the window
        wind = LocalWind.grid(np.stack([3 + 0.1 * Y, -1 + 0.05 * X]), off,
                              fill=(2.5, 1.0) if kind == "grid-fill" else (0.0, 0.0))
    city = wn.city.planning_map(rng=1)
    origin = np.array([300.0, 300.0])
    while city.contains(origin[None])[0]:
        origin = rng.uniform(50, 550, 2)
    pts = scan_points(city.lidar(origin)[0], max_range=cfg.lidar_range)
    u = rng.normal(0, 20, (cfg.n_samples, cfg.n_steps, 2))   # some beyond the bounds
    v0, goal = np.array([2.0, -1.0]), np.array([80.0, 30.0])
    mode = wind.pack(cfg.horizon) if (wind is not None and cfg.use_wind) else None
    problem = Problem(v0, goal, obstacle_field(pts),
                      mode or (0, np.zeros((2, 1, 1)), np.array([0, 0, 1, 1, 0.0, 0.0, 0.0])))
    costs, parts = fused_rollout_cost(cfg, np.ascontiguousarray(u.transpose(1, 2, 0)), problem)
    ref, ref_parts, ref_pos = _ref_costs(cfg, u, v0, goal, pts, wind)
    np.testing.assert_allclose(parts[:, :3], ref_parts, rtol=1e-10)
    np.testing.assert_allclose(costs, ref, rtol=1e-10)
    pos, vel = rollout(cfg, u, v0, wind)
    np.testing.assert_allclose(pos[:, 1:], ref_pos, rtol=1e-10, atol=1e-10)
    np.testing.assert_allclose(parts[:, 3], np.sqrt(
        ((ref_pos[:, :, None] - pts[None, None]) ** 2).sum(-1)).min((1, 2)), rtol=1e-9)


@pytest.mark.parametrize("use_wind", [False, True])
def test_mission_energy_matches_the_numpy_reference(base, use_wind):
    # J_E = power summed until a rollout is first within goal_radius of the uncapped goal,
    # then e_R times the distance left (beyond the radius) for those that never get there
    rng = np.random.default_rng(5)
    cfg = dataclasses.replace(base, n_samples=64, n_steps=60, energy_mode="mission",
                              goal_radius=8.0, use_wind=use_wind, lidar_range=50.0)
    wind = LocalWind.uniform([3.0, -1.0]) if use_wind else None
    v0 = np.array([6.0, 0.5])
    goal_true = np.array([60.0, 4.0])                        # beyond D_max: capped for J_prog
    goal = goal_true * cfg.lidar_range / np.hypot(*goal_true)
    # accelerations around a cruise towards the goal, so that some rollouts get there
    u = rng.normal(0.0, 2.0, (cfg.n_samples, cfg.n_steps, 2)) + [2.5, 0.0]
    packed = wind.pack(cfg.horizon) if use_wind else wn.plan.local_wind.NO_WIND
    mission = mission_terms(cfg, goal_true, packed)
    problem = Problem(v0, goal, obstacle_field(np.zeros((0, 2))), packed, mission)
    costs, parts = fused_rollout_cost(cfg, np.ascontiguousarray(u.transpose(1, 2, 0)), problem)

    # e_R by brute force over ground speeds: energy per metre towards the goal, s/m
    d = goal_true / np.hypot(*goal_true)
    w0 = np.array([3.0, -1.0]) if use_wind else np.zeros(2)
    speeds = np.linspace(0.5, 25.0, 200001)
    e_r = np.min(cfg.power(np.hypot(*(speeds[None] * d[:, None] - w0[:, None])))
                 / cfg.hover_power / speeds)
    assert mission[4] == pytest.approx(e_r, rel=1e-4)
    if not use_wind:   # still air: the max-range speed's energy per metre
        v_r = cfg.max_range_speed()
        assert mission[4] == pytest.approx(cfg.power(v_r) / cfg.hover_power / v_r, rel=1e-4)

    _, ref_parts, pos = _ref_costs(cfg, u, v0, goal, np.zeros((0, 2)), wind)
    p = np.zeros((cfg.n_samples, 2))
    v = np.tile(v0, (cfg.n_samples, 1))
    je = np.zeros(cfg.n_samples)
    arrived = np.zeros(cfg.n_samples, bool)
    for t in range(cfg.n_steps):
        va = v - (w0 if use_wind else 0.0)
        speed = np.linalg.norm(va, axis=1)
        je += np.where(arrived, 0.0, cfg.power(speed) / cfg.hover_power * cfg.dt)
        p = p + cfg.dt * v
        v = v + cfg.dt * (np.clip(u[:, t], cfg.a_min, cfg.a_max) - cfg.drag * speed[:, None] * va)
        arrived |= np.linalg.norm(p - goal_true, axis=1) <= cfg.goal_radius
    left = np.maximum(np.linalg.norm(p - goal_true, axis=1) - cfg.goal_radius, 0.0)
    je += np.where(arrived, 0.0, mission[4] * left)
    assert 5 <= arrived.sum() <= cfg.n_samples - 5          # both kinds are exercised
    np.testing.assert_allclose(parts[:, 2], je, rtol=1e-10)
    np.testing.assert_allclose(parts[:, 0], ref_parts[:, 0], rtol=1e-10)   # J_prog unchanged
    np.testing.assert_allclose(costs, parts[:, 0] + cfg.energy_weight * je, rtol=1e-10)


def test_the_planner_gives_the_mission_energy_the_uncapped_goal(base):
    # J_prog sees the goal capped at D_max, the mission energy the real one (500 m away):
    # the problem the planner hands its rollout cost, recorded by an injected cost
    cfg = dataclasses.replace(base, n_samples=32, n_steps=20, energy_mode="mission")
    seen = []

    def recording_cost(config, controls, problem):
        seen.append(problem)
        return fused_rollout_cost(config, controls, problem)

    pos, goal_true = np.array([20.0, -10.0]), np.array([480.0, 140.0])
    planner = MPPIPlanner(cfg, goal_xy=pos + goal_true, rng=1, rollout_cost=recording_cost)
    wind = LocalWind.uniform([3.0, -1.0])
    planner.update([*pos, 1.0, 0.5], None, wind)
    (problem,) = seen
    dist = np.hypot(*goal_true)
    assert dist == pytest.approx(500.0) and cfg.lidar_range == 100.0
    np.testing.assert_allclose(problem.goal, goal_true * 100.0 / dist, rtol=1e-12)
    # e_R by brute force over ground speeds towards the goal in the wind, s/m
    d = goal_true / dist
    speeds = np.linspace(0.5, 25.0, 200001)
    e_r = np.min(cfg.power(np.hypot(speeds * d[0] - 3.0, speeds * d[1] + 1.0))
                 / cfg.hover_power / speeds)
    np.testing.assert_allclose(problem.mission[:4], [1.0, *goal_true, cfg.goal_radius],
                               rtol=1e-12)
    assert problem.mission[4] == pytest.approx(e_r, rel=1e-4)


def test_mission_energy_is_least_at_the_max_range_speed(base):
    # a straight flight at constant ground speed V towards a far goal for the whole horizon:
    # its mission energy T P(V) + e_R (D - V T) is least near V_R (P'(V_R) = P(V_R) / V_R),
    # where the thesis's horizon energy T P(V) is least at the least-power speed, far below it
    cfg = dataclasses.replace(base, n_steps=40, energy_mode="mission", use_wind=False,
                              energy_weight=1.0)
    speeds = np.linspace(1.0, 14.0, 131)
    goal_true = np.array([5000.0, 0.0])
    mission = mission_terms(cfg, goal_true, wn.plan.local_wind.NO_WIND)
    # hold the speed: the control cancels the drag, a = C V^2 along x
    u = np.zeros((cfg.n_steps, 2, speeds.size))
    u[:, 0, :] = cfg.drag * speeds ** 2
    problem = Problem(np.zeros(2), goal_true / 50.0, obstacle_field(np.zeros((0, 2))),
                      wn.plan.local_wind.NO_WIND, mission)
    thesis = dataclasses.replace(cfg, energy_mode="horizon")
    e_mission, e_horizon = [], []
    for s in range(speeds.size):
        prob = problem._replace(velocity=np.array([speeds[s], 0.0]))
        uu = np.ascontiguousarray(u[:, :, s:s + 1])
        e_mission.append(fused_rollout_cost(cfg, uu, prob)[1][0, 2])
        e_horizon.append(fused_rollout_cost(thesis, uu, prob._replace(mission=NO_MISSION))[1][0, 2])
    best = speeds[int(np.argmin(e_mission))]
    assert best == pytest.approx(cfg.max_range_speed(), abs=0.15)
    least_power = speeds[int(np.argmin(cfg.power(speeds)))]
    assert speeds[int(np.argmin(e_horizon))] == pytest.approx(least_power, abs=0.15)
    assert least_power < 0.5 * best


def test_energy_mode_is_checked(base):
    with pytest.raises(ValueError, match="'energy_mode'"):
        dataclasses.replace(base, energy_mode="trip")
    with pytest.raises(ValueError, match="'goal_radius'"):
        dataclasses.replace(base, energy_mode="mission", goal_radius=0.0)


# the lookups as the rollout kernel compiles them (inlined, with its fastmath flags)
@numba.njit(fastmath={"contract", "arcp"})
def _winds_one_at_a_time(px, py, wmode, wgrid, wmeta, wx, wy):
    for s in range(px.size):
        wx[s], wy[s] = _kernels.wind_at(px[s], py[s], wmode, wgrid, wmeta)


@numba.njit(fastmath={"contract", "arcp"})
def _winds_batched(px, py, wmode, wgrid, wmeta, wx, wy):
    _kernels._winds(px, py, wmode, wgrid, wmeta, wx, wy)


@pytest.mark.parametrize("fill", [(0.0, 0.0), (1.5, -0.7)])
@pytest.mark.parametrize("spacing, half", [(1.0, np.inf), (25 / 24, 12.5), (0.7, 14.0)])
def test_the_batched_wind_lookup_is_the_one_at_a_time_lookup_to_the_bit(spacing, half, fill):
    # the batch reads the window once; its divisions by the spacing must stay divisions (a
    # multiplication by the reciprocal differs in the last bit for spacings like 25/24)
    rng = np.random.default_rng(3)
    n = 30
    wgrid = rng.standard_normal((2, n, n))
    x0 = -0.5 * (n - 1) * spacing + 0.123
    wmeta = np.array([x0, x0 - 0.31, spacing, spacing, half, *fill])
    r = (half if np.isfinite(half) else 0.5 * n * spacing) + 3.0
    px, py = rng.uniform(-r, r, (2, 5000))
    for mode in (1, 2):
        got = np.empty((2, px.size))
        want = np.empty((2, px.size))
        _winds_batched(px, py, mode, wgrid, wmeta, got[0], got[1])
        _winds_one_at_a_time(px, py, mode, wgrid, wmeta, want[0], want[1])
        assert got.tobytes() == want.tobytes()
        outside = (np.abs(px) > half) | (np.abs(py) > half)
        assert outside.any() == np.isfinite(half)
        # outside the window: the fill (zero for the thesis's planner)
        assert np.all(got[0, outside] == fill[0]) and np.all(got[1, outside] == fill[1])


def test_rollout_reaches_the_terminal_speed_of_the_drag(base):
    # constant acceleration a along x in still air: v -> sqrt(a / C); without drag, Euler's
    # exact sums p_K = dt^2 a K (K - 1) / 2
    cfg = with_variant(dataclasses.replace(base, n_steps=400), "mppi")
    a = 20.0
    u = np.tile([a, 0.0], (cfg.n_steps, 1))
    _, vel = rollout(cfg, u, [0.0, 0.0])
    assert vel[0, -1, 0] == pytest.approx(np.sqrt(a / cfg.drag), rel=1e-6)
    free = dataclasses.replace(cfg, drag=0.0, n_steps=10)
    pos, _ = rollout(free, u[:10], [0.0, 0.0])
    assert pos[0, -1, 0] == pytest.approx(free.dt**2 * a * 10 * 9 / 2, rel=1e-12)


def test_sampling_bounds_smoothing_and_seed(base):
    cfg = dataclasses.replace(base, n_samples=4000, n_steps=25)
    g = smoothing_matrix(25, cfg.sigma_gf)
    np.testing.assert_allclose(g.sum(1), 1.0, rtol=1e-12)
    mean = np.tile([1.0, -2.0], (25, 1))
    u = sample_controls(cfg, mean, rng=np.random.default_rng(0))
    assert u.shape == (25, 2, 4000)   # time-major, structure of arrays
    tol = 1e-5 * cfg.a_max            # float32 samples
    assert u.min() >= cfg.a_min - tol and u.max() <= cfg.a_max + tol
    # smoothing by G turns N(mean, sigma^2) into N(mean, sigma^2 |G_k|^2) at each step
    std = u[:, 0].std(axis=1)
    np.testing.assert_allclose(std, cfg.sigma_u * np.linalg.norm(g, axis=1), rtol=0.08)
    np.testing.assert_allclose(u.mean(axis=2), mean, atol=0.2)
    again = sample_controls(cfg, mean, rng=np.random.default_rng(0))
    np.testing.assert_array_equal(u, again)
    uni = sample_controls(dataclasses.replace(cfg, sampling="uniform"), mean,
                          rng=np.random.default_rng(0))
    assert uni.min() >= cfg.a_min - tol and uni.max() <= cfg.a_max + tol
    assert np.std(uni) == pytest.approx((cfg.a_max - cfg.a_min) / np.sqrt(12), rel=0.02)


@pytest.mark.parametrize("sigma", [0.7, 2.0, 5.97])
def test_smoothing_taps_are_the_normalised_gaussian_of_std_sigma(base, sigma):
    """Row k of G is SciPy's normal density of std ``sigma`` at ``j - k``, cut beyond
    ``4 sigma`` and scaled to sum 1; away from the ends the taps' spread is ``sigma``."""
    from scipy import stats
    n = 60
    g = smoothing_matrix(n, sigma)
    d = np.arange(n)[None, :] - np.arange(n)[:, None]
    ref = stats.norm.pdf(d, scale=sigma) * (np.abs(d) <= 4.0 * sigma)
    np.testing.assert_allclose(g, ref / ref.sum(axis=1, keepdims=True), rtol=1e-12, atol=1e-300)
    if sigma >= 2.0:   # the discrete second moment is sigma^2 (the 4-sigma cut takes 0.1 %)
        mid = n // 2
        assert np.sum(d[mid] ** 2 * g[mid]) == pytest.approx(sigma**2, rel=5e-3)
    assert base.sigma_gf == 5.97   # the planners' width is among the cases


@pytest.mark.parametrize("shape", [(25, 1000), (187, 100), (9, 37), (3, 300)])
def test_the_smoothing_is_the_float32_sum_over_taps_in_order_to_the_bit(base, shape):
    """perturb_clip_smooth works in column blocks and four taps per pass; every element must
    still be the float32 sum ``0 + w_0 x_0 + w_1 x_1 + ...`` taken in order, as NumPy adds it
    (the committed flights depend on these bits)."""
    from windnav.plan import _random
    from windnav.plan.mppi import _smoothing_bands
    k, s = shape
    cfg = dataclasses.replace(base, n_samples=s, n_steps=k)
    mean = np.random.default_rng(1).normal(0, 3, (k, 2))
    taps, lo, hi = _smoothing_bands(k, cfg.sigma_gf)
    seed = np.uint64(987654321)
    out = np.empty((k, 2, s), np.float32)
    clipped = np.empty_like(out)
    _kernels.perturb_clip_smooth(seed, clipped, mean, cfg.sigma_u, cfg.a_min, cfg.a_max, taps,
                                 lo, hi, out)
    noise = np.empty_like(out)
    _random.fill_normal(seed, noise, mean, cfg.sigma_u, cfg.a_min, cfg.a_max, _random.KN,
                        _random.WN, _random.FN)
    np.testing.assert_array_equal(clipped, noise)
    flat = noise.reshape(k, 2 * s)
    for i in range(k):
        ref = np.zeros(2 * s, np.float32)
        for t in range(hi[i] - lo[i]):
            ref = ref + np.float32(taps[i, t]) * flat[lo[i] + t]
        np.testing.assert_array_equal(out[i].reshape(-1).view(np.int32), ref.view(np.int32))


def test_the_weighted_mean_sums_each_row_in_sample_order_to_the_bit():
    """Each row of softmin_mean's weighted mean is ``sum_s w_s u_s`` added from s = 0 up in
    float64 (the committed flights depend on these bits), for any count of rows."""
    rng = np.random.default_rng(3)
    for k in (1, 2, 3, 25):
        costs = rng.uniform(0, 5, 101)
        u = rng.normal(size=(k, 2, 101)).astype(np.float32)
        w = np.empty(101)
        out = np.empty((k, 2))
        assert _kernels.softmin_mean(costs, 0.79, u, w, out)
        for r in range(2 * k):
            acc = 0.0
            for j in range(101):
                acc += w[j] * float(u[r // 2, r % 2, j])
            assert out[r // 2, r % 2] == acc


def test_sampler_normals_are_standard_normal():
    """The planner's ziggurat (windnav.plan._random) against N(0, 1): moments, the mass of the
    tail beyond the ziggurat's base (a separate code path), Kolmogorov-Smirnov; seeded."""
    from scipy import stats

    from windnav.plan import _random
    x = _random.standard_normal(np.random.default_rng(0), 1_000_000)
    assert abs(x.mean()) < 5e-3 and abs(x.var() - 1) < 5e-3
    assert abs(stats.skew(x)) < 0.01 and abs(stats.kurtosis(x)) < 0.02
    tail = np.sum(np.abs(x) > _random._R)
    expect = 2 * stats.norm.sf(_random._R) * x.size
    assert abs(tail - expect) < 5 * np.sqrt(expect)
    assert stats.kstest(x, "norm").pvalue > 1e-3
    np.testing.assert_array_equal(x[:100], _random.standard_normal(np.random.default_rng(0), 100))


def test_softmin_mean_and_shift(base):
    rng = np.random.default_rng(2)
    costs = rng.uniform(0, 5, 300)
    costs[7] = np.inf
    u = rng.normal(size=(20, 2, 300))
    w = np.empty(300)
    out = np.empty((20, 2))
    assert _kernels.softmin_mean(costs, 0.79, u, w, out)
    ref = softmin_weights(costs, 0.79)
    np.testing.assert_allclose(w, ref, rtol=1e-12)
    assert ref[7] == 0 and ref.sum() == pytest.approx(1.0)
    np.testing.assert_allclose(out, np.einsum("s,kcs->kc", ref, u), rtol=1e-12)
    assert not _kernels.softmin_mean(np.full(3, np.nan), 0.79, u[:, :, :3], w[:3], out)
    seq = np.arange(10.0)[:, None] * [1.0, 2.0]
    np.testing.assert_allclose(shift_controls(seq, 1.0)[:-1], seq[1:])
    np.testing.assert_allclose(shift_controls(seq, 1.0)[-1], seq[-1])
    np.testing.assert_allclose(shift_controls(seq, 0.4)[:-1], seq[:-1] + 0.4 * (seq[1] - seq[0]))


def _fly(cfg, goal, seconds, *, city=None, seed=0):
    """Closed loop of the planner's own point mass (10 ms substeps), re-planning at f_plan."""
    planner = MPPIPlanner(cfg, goal_xy=goal, rng=seed)
    x = np.zeros(4) if city is None else np.array([50.0, 100.0, 0.0, 0.0])
    track = []
    period = 1.0 / cfg.rate_hz
    for _ in range(int(seconds * cfg.rate_hz)):
        scan = None if city is None else city.lidar(x[:2])[0]
        a = planner.update(x, scan)
        for _ in range(10):
            v = x[2:].copy()
            x[:2] += 0.1 * period * v
            x[2:] += 0.1 * period * (a - cfg.drag * np.linalg.norm(v) * v)
            track.append(x.copy())
        if city is not None and np.hypot(*(x[:2] - goal)) < 2.0:
            break
    return np.array(track), planner


def test_ea_mppi_cruises_near_the_max_range_speed_and_mppi_faster(base):
    """Open space, still air, a far goal: the energy cost pulls EA-MPPI to the speed of least
    energy per metre of its power curve (thesis: 'near V_R'); MPPI has only the progress cost."""
    v_r = base.max_range_speed()
    speeds = {}
    for variant in ("ea-mppi", "mppi"):
        track, planner = _fly(with_variant(base, variant), (3000.0, 1000.0), 30.0)
        speeds[variant] = np.linalg.norm(track[len(track) // 2:, 2:], axis=1).mean()
        assert planner.stats.fallbacks == 0
        heading = track[-1, :2] / np.linalg.norm(track[-1, :2])
        assert heading @ np.array([3.0, 1.0]) / np.sqrt(10) > 0.98
    assert abs(speeds["ea-mppi"] - v_r) < 0.15 * v_r
    assert speeds["mppi"] > 1.25 * speeds["ea-mppi"]


def _fly_to_goal(cfg, goal, seconds, seed=0):
    """Open space, still air, the planner's own point mass: (time to within 5 m of the goal, s,
    or None; energy from the power curve until then, J)."""
    planner = MPPIPlanner(cfg, goal_xy=goal, rng=seed)
    x = np.zeros(4)
    period = 1.0 / cfg.rate_hz
    energy = 0.0
    for i in range(int(seconds * cfg.rate_hz)):
        a = planner.update(x, None)
        for _ in range(10):
            v = x[2:].copy()
            x[:2] += 0.1 * period * v
            x[2:] += 0.1 * period * (a - cfg.drag * np.linalg.norm(v) * v)
            energy += float(cfg.power(np.linalg.norm(v))) * 0.1 * period
        if np.hypot(*(x[:2] - goal)) < 5.0:
            return (i + 1) * period, energy
    return None, energy


def test_the_mission_energy_reaches_the_goal_with_less_energy_than_mppi(base):
    """Still air, open space, a goal 260 m away. The thesis's horizon energy (Q_E = 5, as
    EA-MPPI+W) is least for the least power, so it slows down on this flat power curve and
    uses more energy than MPPI; the mission's energy is least at the max-range speed and uses
    less (measured 2026-11-29: 2,661 J in 42.1 s; 2,212 J in 30.6 s; MPPI 2,521 J in 26.0 s)."""
    goal = np.array([240.0, 100.0])
    ea = dataclasses.replace(with_variant(base, "ea-mppi"), energy_weight=5.0)
    t_h, e_h = _fly_to_goal(ea, goal, 80.0)
    t_m, e_m = _fly_to_goal(dataclasses.replace(ea, energy_mode="mission"), goal, 80.0)
    t_0, e_0 = _fly_to_goal(with_variant(base, "mppi"), goal, 80.0)
    assert None not in (t_h, t_m, t_0)
    assert e_m < 0.95 * e_0 < 0.95 * e_h
    assert t_0 < t_m < t_h


def test_uniform_sampling_also_makes_progress(base):
    """The thesis hardware's sampler (uniform in the bounds, no warm start noise or smoothing)
    is cruder but still drives the point mass toward the goal."""
    cfg = dataclasses.replace(with_variant(base, "ea-mppi"), sampling="uniform")
    goal = np.array([150.0, 50.0])
    track, planner = _fly(cfg, goal, 30.0)
    assert np.hypot(*(track[-1, :2] - goal)) < 0.3 * np.hypot(*goal)
    assert planner.stats.fallbacks == 0


def test_mppi_reaches_a_goal_behind_a_building():
    cfg = planner_config(wn.vehicle.params("hummingbird"), "mppi")
    box = np.array([120.0, 180.0, 60.0, 140.0])
    city = City((0, 300, 0, 200), [box], [30])
    goal = np.array([250.0, 100.0])
    track, planner = _fly(cfg, goal, 60.0, city=city)
    assert np.hypot(*(track[-1, :2] - goal)) < 2.0
    gap_x = np.maximum.reduce([box[0] - track[:, 0], np.zeros(len(track)), track[:, 0] - box[1]])
    gap_y = np.maximum.reduce([box[2] - track[:, 1], np.zeros(len(track)), track[:, 1] - box[3]])
    assert np.hypot(gap_x, gap_y).min() > 3.0
    assert planner.stats.fallbacks == 0
    assert set(planner.stats.profile_ms) == {"obstacles", "sampling", "rollout_cost", "update",
                                             "total"}


def test_variants_without_wind_ignore_it(base):
    cfg = with_variant(dataclasses.replace(base, n_samples=50, n_steps=20), "ea-mppi")
    a = MPPIPlanner(cfg, goal_xy=(100, 0), rng=5).update([0, 0, 1, 0])
    b = MPPIPlanner(cfg, goal_xy=(100, 0), rng=5).update([0, 0, 1, 0], None,
                                                          LocalWind.uniform([8.0, 0.0]))
    np.testing.assert_array_equal(a, b)
    w = with_variant(cfg, "ea-mppi-w")
    c = MPPIPlanner(w, goal_xy=(100, 0), rng=5).update([0, 0, 1, 0], None,
                                                       LocalWind.uniform([8.0, 0.0]))
    assert not np.allclose(a, c)


@pytest.mark.filterwarnings("ignore:MPPIPlanner.update:RuntimeWarning")  # (base: no wind)
def test_nan_input_falls_back_and_is_counted(base):
    cfg = dataclasses.replace(base, n_samples=50, n_steps=20)
    planner = MPPIPlanner(cfg, goal_xy=(100, 0), rng=0)
    planner.update([0, 0, 2.0, 1.0])
    warm = planner.mean.copy()
    np.testing.assert_array_equal(planner.update([np.nan, 0, 2.0, 1.0]), [0.0, 0.0])
    scan = np.full(360, 50.0)
    scan[10] = np.nan
    brake = planner.update([0, 0, 2.0, 1.0], scan)
    np.testing.assert_allclose(brake, np.clip(-np.array([2.0, 1.0]) / cfg.dt, cfg.a_min,
                                              cfg.a_max))
    bad_wind = LocalWind.grid(np.full((2, 3, 3), np.nan), [-1.0, 0.0, 1.0])
    np.testing.assert_allclose(planner.update([0, 0, 2.0, 1.0], None, bad_wind), brake)
    assert planner.stats.updates == 4
    assert planner.stats.fallbacks == 3
    assert planner.stats.reasons == {"state": 1, "scan": 1, "wind": 1}
    np.testing.assert_array_equal(planner.mean, warm)   # the warm start is untouched
    good = planner.update([0, 0, 2.0, 1.0])
    assert np.all(np.isfinite(good)) and planner.stats.fallbacks == 3


@pytest.mark.filterwarnings("ignore:MPPIPlanner.update:RuntimeWarning")  # (base: no wind)
def test_planner_stats_keep_a_bounded_record_of_update_times(base, monkeypatch):
    """``total_ms`` was a list that grew by every update, 1.2 MB an hour at 10 Hz, for as
    long as a planner lived (long-run audit); it keeps the last TIMES_KEPT."""
    import windnav.plan.mppi as mppi

    monkeypatch.setattr(mppi, "TIMES_KEPT", 3)
    cfg = dataclasses.replace(base, n_samples=50, n_steps=20)
    planner = MPPIPlanner(cfg, goal_xy=(100, 0), rng=0)
    for _ in range(4):
        planner.update([0, 0, 2.0, 1.0])
    planner.update([np.nan, 0, 2.0, 1.0])   # a fallback's time is kept too
    assert planner.stats.updates == 5 and len(planner.stats.total_ms) == 3
    assert planner.stats.median_ms() == float(np.median(list(planner.stats.total_ms)))
    assert len(mppi.PlannerStats().total_ms) == 0


def test_a_scan_of_zeros_brakes_as_contact(base):
    """City.lidar reads 0 on every ray on or inside a building; the planner took it for
    obstacle points at the vehicle, which every sample paid alike, and flew the obstacle-free
    plan into the wall, with no fallback counted (fuzz audit)."""
    cfg = dataclasses.replace(base, n_samples=50, n_steps=20)
    city = City(bounds=(0, 100, 0, 100), footprints=[[40, 60, 40, 60]], heights=[20])
    scan = city.lidar([40.0, 50.0], n_rays=360, max_range=100.0)[0]  # on the west wall
    assert not scan.any()
    planner = MPPIPlanner(cfg, goal_xy=(90, 50), rng=0)
    accel = planner.update([40.0, 50.0, 2.0, 1.0], scan)
    np.testing.assert_allclose(accel, np.clip(-np.array([2.0, 1.0]) / cfg.dt, cfg.a_min,
                                              cfg.a_max))
    assert planner.stats.reasons == {"contact": 1} and planner.plan() is None
    # one ray at zero among others is a return like any other: planned
    scan = np.full(360, 50.0)
    scan[0] = 0.0
    planner.update([30.0, 50.0, 0.0, 0.0], scan)
    assert planner.stats.fallbacks == 1 and planner.plan() is not None


def test_bad_planner_arguments_raise_named_errors(base):
    with pytest.raises(ValueError, match="'config' parameter of MPPIPlanner"):
        MPPIPlanner(with_variant(base, "gs"))
    with pytest.raises(ValueError, match="'goal_xy' parameter of MPPIPlanner"):
        MPPIPlanner(base, goal_xy=(np.nan, 0))
    for bad in (-1, "a", 1.5):
        with pytest.raises(ValueError, match="'rng' parameter of MPPIPlanner"):
            MPPIPlanner(base, rng=bad)
    planner = MPPIPlanner(dataclasses.replace(base, n_samples=10, n_steps=5), rng=0)
    with pytest.raises(ValueError, match="'goal_xy'"):
        planner.update([0, 0, 0, 0])
    planner.set_goal((10, 0))
    with pytest.raises(ValueError, match="'state' parameter of MPPIPlanner.update"):
        planner.update([0, 0, 0])
    # a (2, 2) array is not [x, y, vx, vy], and two vehicles are not one (audit, 2026-12-05)
    with pytest.raises(ValueError, match="'state' parameter of MPPIPlanner.update"):
        planner.update([[0, 0], [0, 0]])
    two = types.SimpleNamespace(position=np.zeros((2, 3)), velocity=np.zeros((2, 3)))
    with pytest.raises(ValueError, match="'state' parameter of MPPIPlanner.update"):
        planner.update(two)
    assert planner.update([[0, 0, 0, 0]]).shape == (2,)
    # a negative range used to become an obstacle on the opposite side
    with pytest.raises(ValueError, match="'scan' parameter of MPPIPlanner.update must hold "
                                         "ranges >= 0"):
        planner.update([0, 0, 0, 0], np.full(8, -5.0))
    for bad in ([0.0, 1.0, 3.0], [2.0, 1.0, 0.0], [0.0, 0.0, 0.0], [0.0, np.nan, 2.0],
                [0.0, 1.0, np.inf], [0.0, 1.0, 2.00001]):
        with pytest.raises(ValueError, match="'offsets' parameter of LocalWind"):
            LocalWind.grid(np.zeros((2, 3, 3)), bad)
    even = -12.0 + 25 / 24 * np.arange(25)  # steps equal to rounding
    assert LocalWind.grid(np.zeros((2, 25, 25)), even).x is not None
    with pytest.raises(ValueError, match="'fill' parameter of LocalWind.grid"):
        LocalWind.grid(np.zeros((2, 3, 3)), [-1.0, 0.0, 1.0], fill=(1.0, 2.0, 3.0))
    assert not LocalWind.grid(np.zeros((2, 3, 3)), [-1.0, 0.0, 1.0], fill=(np.nan, 0.0)).finite


def test_the_low_level_steps_refuse_arrays_their_kernels_would_read_past(base):
    # a mean shorter than n_steps was read past its end (heap values in the samples), and a
    # problem's wind meta likewise (API audit, 2026-12-05)
    from windnav.plan import mppi_step
    from windnav.plan.local_wind import NO_WIND

    cfg = dataclasses.replace(base, n_samples=4, n_steps=40)
    rng = np.random.default_rng(0)
    for mean in (np.zeros((1, 2)), np.zeros((3, 2)), np.zeros(80)):
        with pytest.raises(ValueError, match="'mean' parameter of sample_controls"):
            sample_controls(cfg, mean, rng=rng)
    with pytest.raises(ValueError, match="'out' parameter of sample_controls"):
        sample_controls(cfg, np.zeros((40, 2)), rng=rng, out=np.empty((40, 2, 3), np.float32))
    field = obstacle_field(np.zeros((0, 2)))
    good = Problem(np.zeros(2), np.array([10.0, 0.0]), field, NO_WIND)
    assert mppi_step(cfg, np.zeros((40, 2)), good, rng=rng)["controls"].shape == (40, 2)
    short = Problem(np.zeros(2), np.array([10.0, 0.0]), field, (1, NO_WIND[1], np.zeros(2)))
    with pytest.raises(ValueError, match="'problem' parameter of mppi_step"):
        mppi_step(cfg, np.zeros((40, 2)), short, rng=rng)


def test_the_planner_helpers_refuse_degenerate_arguments(base):
    # audit 2026-12-05: a negative shift rotated the sequence, NaN shifts raised IndexError,
    # a zero temperature gave NaN weights, a NaN smoothing width a NaN matrix, and n_steps of
    # 20,000 asked for a 3.2 GB smoothing matrix
    u = np.arange(10.0).reshape(5, 2)
    for steps in (-3, np.nan):
        with pytest.raises(ValueError, match="'steps' parameter of shift_controls"):
            shift_controls(u, steps)
    np.testing.assert_array_equal(shift_controls(u, 0), u)
    for t in (0.0, -1.0):
        with pytest.raises(ValueError, match="'temperature' parameter of softmin_weights"):
            softmin_weights(np.array([1.0, 2.0]), t)
    with pytest.raises(ValueError, match="'sigma' parameter of smoothing_matrix"):
        smoothing_matrix(5, np.nan)
    np.testing.assert_array_equal(smoothing_matrix(3, 0.0), np.eye(3))
    with pytest.raises(ValueError, match="'n_steps' parameter of PlannerConfig"):
        dataclasses.replace(base, n_steps=20_000)
    with pytest.raises(ValueError, match="'n_samples' parameter of PlannerConfig"):
        dataclasses.replace(base, n_steps=1000, n_samples=10**6)


def test_shift_controls_and_softmin_weights_refuse_arrays_of_another_shape():
    # a (K,) sequence came back (K, K), a (K, 3) one was shifted, NaN controls came back NaN,
    # a list or None raised an AttributeError; (3, 2) costs were weighted as six samples, a
    # list raised a TypeError and integer costs got weights of 0 (audit of the low-level helpers)
    for bad in (np.zeros(5), np.zeros((5, 3)), np.zeros((0, 2)), np.zeros((5, 2, 1)), 1.0, None,
                "ab", np.full((5, 2), np.nan), [[0.0, 1.0], [np.inf, 0.0]]):
        with pytest.raises(ValueError, match="'controls' parameter of shift_controls must be"):
            shift_controls(bad, 1.0)
    with pytest.raises(ValueError, match="'steps' parameter of shift_controls"):
        shift_controls(np.zeros((5, 2)), "a")
    np.testing.assert_array_equal(shift_controls([[0.0, 1.0], [2.0, 3.0]], 1.0),
                                  [[2.0, 3.0], [2.0, 3.0]])
    for bad in (np.zeros((3, 2)), np.float64(1.0), "ab", None, np.array([1j, 2j])):
        with pytest.raises(ValueError, match="'costs' parameter of softmin_weights must be"):
            softmin_weights(bad, 1.0)
    np.testing.assert_allclose(softmin_weights([1, 1], 1.0), [0.5, 0.5])
    c32 = np.array([1.0, 2.0, np.nan], np.float32)   # a float32 input keeps its arithmetic
    assert softmin_weights(c32, 0.79).dtype == np.float32


def test_local_wind_built_directly_refuses_what_it_cannot_pack():
    # the constructor checked nothing: a (2, 3) wind, a (2, 3, 3) one on 4 x 3 offsets, NaN,
    # decreasing or repeated offsets and one offset per axis were packed (a NaN or negative
    # cell size for the kernel) or raised an IndexError; a horizon of NaN gave a NaN window
    z = np.zeros(0)
    for uv, x, y, name in [
        (np.zeros((2, 3)), z, z, "uv"),
        (np.zeros((3, 1, 1)), z, z, "uv"),
        (np.zeros((2, 3, 3)), np.arange(4.0), np.arange(3.0), "uv"),
        (np.zeros((2, 1, 1)), np.arange(2.0), z, "y"),
        (np.zeros((2, 2, 2)), np.array([0.0, np.nan]), np.arange(2.0), "x"),
        (np.zeros((2, 2, 2)), np.array([1.0, 0.0]), np.arange(2.0), "x"),
        (np.zeros((2, 2, 2)), np.arange(2.0), np.array([1.0, 1.0]), "y"),
        (np.zeros((2, 1, 1)), np.zeros(1), np.zeros(1), "x"),
        (np.zeros((2, 2, 2)), np.zeros((1, 2)), np.arange(2.0), "x"),
    ]:
        with pytest.raises(ValueError, match=f"'{name}' parameter of LocalWind must"):
            LocalWind(uv, x, y)
    for fill in ((1.0, 2.0, 3.0), "ab", None):
        with pytest.raises(ValueError, match="'fill' parameter of LocalWind must"):
            LocalWind(np.zeros((2, 1, 1)), z, z, fill=fill)
    for horizon in (np.nan, 0.0, -5.0, "wide"):
        with pytest.raises(ValueError, match="'horizon' parameter of LocalWind.pack"):
            LocalWind.uniform([1.0, 0.0]).pack(horizon)
    assert LocalWind.uniform([1.0, 0.0]).pack(np.inf)[2][4] == np.inf
    # NaN winds stay constructible: the planner checks them at each update and brakes
    nan_grid = LocalWind(np.full((2, 2, 3), np.nan), np.arange(3.0), np.arange(2.0),
                         fill=(np.nan, 0.0))
    assert not nan_grid.finite
    mode, grid, meta = LocalWind([[[1.0]], [[2.0]]], [], []).pack(10.0)
    assert mode == 1 and grid.dtype == np.float64 and list(meta) == [0, 0, 1, 1, 5, 0, 0]


def test_rollout_names_a_wind_that_is_not_a_local_wind(base):
    cfg = dataclasses.replace(base, n_samples=3, n_steps=5)
    with pytest.raises(ValueError, match="'wind' parameter of rollout must be a LocalWind"):
        rollout(cfg, np.zeros((5, 2)), [0.0, 0.0], wind=(1.0, 0.0))  # AttributeError before


def test_a_wind_aware_planner_given_no_wind_says_it_plans_in_still_air():
    """EA-MPPI+W's update without a wind plans as in still air: a RuntimeWarning says so, once
    per planner; a variant without wind, or one given its wind, says nothing."""
    import warnings

    p = wn.vehicle.params("hummingbird")
    scan = np.full(360, 100.0)
    windy = MPPIPlanner(planner_config(p, "ea-mppi-w", horizon=25.0), (50.0, 0.0), rng=0)
    with pytest.warns(RuntimeWarning, match="plans in still air"):
        windy.update([0.0, 0.0, 0.0, 0.0], scan)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        windy.update([0.0, 0.0, 0.0, 0.0], scan)  # once per planner
        calm = MPPIPlanner(planner_config(p, "mppi"), (50.0, 0.0), rng=0)
        calm.update([0.0, 0.0, 0.0, 0.0], scan)
        offsets = np.arange(-12.0, 13.0)
        uv = np.zeros((2, 25, 25))
        uv[0] = 3.0
        given = MPPIPlanner(planner_config(p, "ea-mppi-w", horizon=25.0), (50.0, 0.0), rng=0)
        given.update([0.0, 0.0, 0.0, 0.0], scan, LocalWind.grid(uv, offsets, offsets))


@pytest.mark.parametrize("threads", [2, 3])
def test_threads_roll_out_the_same_costs_and_draw_reproducible_samples(base, threads):
    """``threads`` > 1 splits the samples into chunks on Numba's threads: the rollout's costs
    and parts are the serial kernel's to the bit, each chunk's smoothing is the serial sum of
    its clipped samples, and the samples are a function of ``rng`` and the thread count."""
    rng = np.random.default_rng(4)
    cfg = dataclasses.replace(base, n_samples=301, n_steps=30)
    city = wn.city.planning_map(rng=1)
    pts = scan_points(city.lidar(np.array([[300.0, 300.0]]))[0], max_range=cfg.lidar_range)
    off = np.arange(-20, 21) * 1.5
    X, Y = np.meshgrid(off, off)
    wind = LocalWind.grid(np.stack([3 + 0.1 * Y, -1 + 0.05 * X]), off)
    problem = Problem(np.array([2.0, -1.0]), np.array([80.0, 30.0]), obstacle_field(pts),
                      wind.pack(cfg.horizon))
    u = rng.normal(0, 20, (cfg.n_steps, 2, cfg.n_samples)).astype(np.float32)
    one = fused_rollout_cost(cfg, u, problem)
    many = fused_rollout_cost(cfg, u, problem, threads=threads)
    np.testing.assert_array_equal(many[0], one[0])
    np.testing.assert_array_equal(many[1], one[1])
    mean = rng.normal(size=(cfg.n_steps, 2))
    work = np.empty((cfg.n_steps, 2, cfg.n_samples), np.float32)
    a = sample_controls(cfg, mean, rng=np.random.default_rng(7), threads=threads, work=work)
    b = sample_controls(cfg, mean, rng=np.random.default_rng(7), threads=threads)
    np.testing.assert_array_equal(a, b)
    assert not np.array_equal(a, sample_controls(cfg, mean, rng=np.random.default_rng(7)))
    G = smoothing_matrix(cfg.n_steps, cfg.sigma_gf).astype(np.float32)
    ref = np.zeros_like(a)
    for k in range(cfg.n_steps):  # the serial kernel's order: taps from the band's first up
        cols = np.flatnonzero(G[k])
        for t in cols:
            ref[k] = ref[k] + G[k, t] * work[t]
    np.testing.assert_array_equal(a, ref)
    assert abs(float(a.mean() - mean.mean())) < 0.2 and work.min() >= cfg.a_min
    planner = MPPIPlanner(cfg, (60.0, 0.0), rng=0, threads=threads)
    again = MPPIPlanner(cfg, (60.0, 0.0), rng=0, threads=threads)
    scan = np.full(360, 100.0)
    for _ in range(3):
        np.testing.assert_array_equal(planner.update([0, 0, 1.0, 0], scan, wind),
                                      again.update([0, 0, 1.0, 0], scan, wind))
    with pytest.raises(ValueError, match="'threads' parameter of MPPIPlanner"):
        MPPIPlanner(cfg, (60.0, 0.0), threads=cfg.n_samples + 1)
    with pytest.raises(ValueError, match="'threads' parameter of sample_controls"):
        sample_controls(cfg, mean, rng=rng, threads=0)


def test_threads_edges_zero_samples_numpy_bools_and_a_fixed_count(base):
    """Edges found by the thread audit (2026-12-05): no samples on 2 threads divided by zero;
    ``np.True_`` was taken for 1 thread where ``True`` is refused; and setting a planner's
    ``threads`` after construction left its rollout on the old count."""
    cfg = dataclasses.replace(base, n_samples=8, n_steps=5)
    problem = Problem(np.zeros(2), np.array([80.0, 0.0]), obstacle_field(np.zeros((0, 2))),
                      LocalWind.uniform([0.0, 0.0]).pack(cfg.horizon))
    none = np.zeros((cfg.n_steps, 2, 0), np.float32)
    for threads in (1, 2):
        costs, parts = fused_rollout_cost(cfg, none, problem, threads=threads)
        assert costs.shape == (0,) and parts.shape == (0, 4)
    for flag in (True, np.True_):
        with pytest.raises(ValueError, match="'threads' parameter of MPPIPlanner"):
            MPPIPlanner(cfg, (60.0, 0.0), threads=flag)
    planner = MPPIPlanner(cfg, (60.0, 0.0), rng=0, threads=2)
    with pytest.raises(AttributeError):
        planner.threads = 1
    assert planner.threads == 2
