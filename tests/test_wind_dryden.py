"""Dryden gusts: exact scaling at any step, the MIL-F-8785C spectra, colour, determinism.

Statistical tolerances are derived from the integral time scales of the process (not tuned):
for a record of duration D of a stationary process with autocorrelation rho(tau),

    Var(sample mean)     ~ sigma^2 / D * int_{-inf}^{inf} rho      = 2 sigma^2 T_int / D
    Var(sample variance) ~ 2 sigma^4 / D * int_{-inf}^{inf} rho^2

with, for T = L/V, rho_u = exp(-tau/T) (int_0^inf rho = T, int_0^inf rho^2 = T/2) and
rho_v = rho_w = (1 - tau/(2T)) exp(-tau/T) (int_0^inf rho = T/2, int_0^inf rho^2 = 5T/16).
The lag-one sample autocorrelation's spread follows Bartlett's formula. Every check uses 4
standard deviations; the runs are long enough that 4 sd of the sample std is below 5 %.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
import scipy.linalg

from windnav.wind import DrydenWind, dryden_length_scales
from windnav.wind.dryden import FOOT, dryden_state_space, van_loan

MEAN = np.array([3.0, -1.0, 0.5])
SIGMA = np.array([1.5, 1.2, 0.7])
ALTITUDE = 10 * FOOT  # the model's lowest altitude: short scales, so the runs stay short
DURATION = 8000.0  # s, > 3000 T_u
K_SD = 4.0


def _rho(kind: str, tau: np.ndarray, time_scale: float) -> np.ndarray:
    x = np.abs(tau) / time_scale
    return np.exp(-x) if kind == "u" else (1 - x / 2) * np.exp(-x)


def _bartlett_lag1_sd(kind: str, dt: float, time_scale: float, n: int) -> float:
    """Bartlett's large-sample sd of the lag-one sample autocorrelation."""
    k = np.arange(-int(40 * time_scale / dt) - 2, int(40 * time_scale / dt) + 3)
    r = lambda j: _rho(kind, j * dt, time_scale)  # noqa: E731
    r1 = r(1)
    terms = r(k + 1) ** 2 + r(k - 1) * r(k + 1) + 2 * r1**2 * r(k) ** 2 - 4 * r1 * r(k) * r(k + 1)
    return math.sqrt(terms.sum() / n)


@pytest.fixture(scope="module", params=[0.001, 0.01, 0.05], ids=lambda dt: f"dt={dt}")
def record(request):
    dt = request.param
    field = DrydenWind(mean=MEAN, sigma=SIGMA, seed=2024, altitude=ALTITUDE)
    n = int(round(DURATION / dt))
    return dt, field, field.sample(dt * np.arange(1, n + 1))


def test_length_scales_follow_mil_f_8785c():
    # 1000 ft: L_u = L_v = 1000/(0.177 + 0.823)^1.2 = 1000 ft = L_w
    np.testing.assert_allclose(dryden_length_scales(1000 * FOOT), [304.8] * 3, rtol=1e-12)
    h = 100.0  # ft
    l_uv = h / (0.177 + 0.000823 * h) ** 1.2
    np.testing.assert_allclose(dryden_length_scales(h * FOOT), np.array([l_uv, l_uv, h]) * FOOT)
    # clamped to the model's range [10, 1000] ft
    np.testing.assert_array_equal(dryden_length_scales(1.0), dryden_length_scales(10 * FOOT))
    np.testing.assert_array_equal(dryden_length_scales(1e4), dryden_length_scales(1000 * FOOT))


def test_realisation_reproduces_the_dryden_transfer_functions():
    scales, v_ref = np.array([40.0, 25.0, 6.0]), 8.0
    a, b, c = dryden_state_space(SIGMA, scales, v_ref)
    lu, lv, lw = scales
    for omega in (0.01, 0.3, 1.0, 7.0, 50.0):
        s = 1j * omega
        h = c @ np.linalg.solve(s * np.eye(5) - a, b)
        h_u = SIGMA[0] * np.sqrt(2 * lu / (np.pi * v_ref)) / (1 + lu / v_ref * s)
        h_v, h_w = (
            sig * np.sqrt(ell / (np.pi * v_ref)) * (1 + np.sqrt(3) * ell / v_ref * s)
            / (1 + ell / v_ref * s) ** 2
            for sig, ell in ((SIGMA[1], lv), (SIGMA[2], lw))
        )
        # a standard Wiener process has one-sided spectral density 1/pi: gain sqrt(pi) H
        np.testing.assert_allclose(h, np.sqrt(np.pi) * np.diag([h_u, h_v, h_w]), atol=1e-12)


@pytest.mark.parametrize("dt", [1e-5, 1e-3, 0.01, 0.05, 0.3, 2.0, 50.0, 1e4])
def test_discrete_step_preserves_sigma_exactly(dt):
    field = DrydenWind(sigma=SIGMA, seed=0)
    _, _, c = field.state_space
    p = field.stationary_covariance
    phi, q = field.transition(dt)
    np.testing.assert_allclose(np.diag(c @ p @ c.T), SIGMA**2, rtol=1e-12)
    np.testing.assert_allclose(np.diag(c @ (phi @ p @ phi.T + q) @ c.T), SIGMA**2, rtol=1e-10)
    assert np.all(np.linalg.eigvalsh(q) > -1e-12 * np.abs(q).max())


@pytest.mark.parametrize("dt", [1e-3, 0.05, 0.37, 1.5])
def test_van_loan_matches_the_stationary_identity(dt):
    # for a stationary start, Q = P - Phi P Phi^T exactly: an independent route to Q
    a, b, _ = dryden_state_space(SIGMA, [20.0, 10.0, 4.0], 10.0)
    p = scipy.linalg.solve_continuous_lyapunov(a, -b @ b.T)
    phi, q = van_loan(a, b, dt)
    np.testing.assert_allclose(phi, scipy.linalg.expm(a * dt), rtol=1e-12, atol=1e-14)
    np.testing.assert_allclose(q, p - phi @ p @ phi.T, rtol=1e-9, atol=1e-12 * np.abs(p).max())


def test_sample_std_within_5_percent_and_mean_within_tolerance(record):
    dt, field, w = record
    t_scales = field.time_scales
    # int_{-inf}^{inf} rho and rho^2 for u, v, w
    int_rho = np.array([2.0, 1.0, 1.0]) * t_scales
    int_rho2 = np.array([1.0, 5.0 / 8.0, 5.0 / 8.0]) * t_scales
    sd_rel_std = 0.5 * np.sqrt(2 * int_rho2 / DURATION)
    sd_mean = SIGMA * np.sqrt(int_rho / DURATION)
    assert np.all(K_SD * sd_rel_std < 0.05), "run too short for a 5 % check"
    rel = w.std(axis=0) / SIGMA - 1
    assert np.all(np.abs(rel) < 0.05), rel
    assert np.all(np.abs(rel) < K_SD * sd_rel_std), (rel, sd_rel_std)
    assert np.all(np.abs(w.mean(axis=0) - MEAN) < K_SD * sd_mean), (w.mean(0), sd_mean)


def _lag1(x: np.ndarray) -> float:
    x = x - x.mean()
    return float(np.dot(x[:-1], x[1:]) / np.dot(x, x))


def test_gusts_are_coloured_with_dryden_correlation(record):
    dt, field, w = record
    n = w.shape[0]
    t_u, t_v, t_w = field.time_scales
    for axis, kind, tau in ((0, "u", t_u), (1, "v", t_v), (2, "w", t_w)):
        rho_hat = _lag1(w[:, axis])
        expected = float(_rho(kind, np.array(dt), tau))
        white_sd = 1 / math.sqrt(n)
        assert rho_hat > 0.5 and rho_hat > 100 * white_sd  # far from white noise (~0)
        tol = K_SD * _bartlett_lag1_sd(kind, dt, tau, n)
        assert abs(rho_hat - expected) < tol, (kind, rho_hat, expected, tol)
        # the model's own autocorrelation agrees with the closed form
        assert field.lag_correlation(dt)[axis] == pytest.approx(expected, rel=1e-10)
    # u: exactly exp(-dt V / L_u)
    assert float(_rho("u", np.array(dt), t_u)) == pytest.approx(
        math.exp(-dt * field.airspeed / field.length_scales[0])
    )


def test_sample_equals_repeated_velocity_queries():
    times = np.concatenate([0.002 * np.arange(1, 301), 0.6 + 0.05 * np.arange(1, 21),
                            [1.7, 1.7, 4.0, 0.30017, 5.5e-4]])
    a = DrydenWind(mean=MEAN, sigma=SIGMA, seed=11)
    b = DrydenWind(mean=MEAN, sigma=SIGMA, seed=11)
    bulk = a.sample(times)
    loop = np.array([b.velocity(t, np.zeros((1, 3)))[0] for t in times])
    np.testing.assert_array_equal(bulk, loop)


def test_same_time_same_gust_whatever_the_order_of_queries():
    # the gust is a function of (t, seed): forward, backward, shuffled and repeated queries,
    # fresh or reused objects, all give the same bits
    rng = np.random.default_rng(0)
    times = np.concatenate([rng.uniform(0.0, 30.0, 400), 0.005 * np.arange(200),
                            [0.0, 7.3, 7.3, 29.999]])
    forward = DrydenWind(mean=MEAN, sigma=SIGMA, seed=5)
    ref = np.array([forward.velocity(t, np.zeros((1, 3)))[0] for t in np.sort(times)])
    ref = ref[np.argsort(np.argsort(times, kind="stable"), kind="stable")]
    backward = DrydenWind(mean=MEAN, sigma=SIGMA, rng=5)
    desc = np.argsort(-times, kind="stable")
    back = np.empty_like(ref)
    back[desc] = [backward.velocity(t, np.zeros((1, 3)))[0] for t in times[desc]]
    np.testing.assert_array_equal(back, ref)
    np.testing.assert_array_equal(backward.sample(times), ref)  # reused, queried again
    shuffled = DrydenWind(mean=MEAN, sigma=SIGMA, rng=5)
    np.testing.assert_array_equal(shuffled.sample(times), ref)
    # evicting the cache regenerates the same values
    backward.reset()
    np.testing.assert_array_equal(backward.sample(times[::-1])[::-1], ref)
    # positions only set the batch size
    np.testing.assert_array_equal(forward.velocity(7.3, np.ones((4, 3))),
                                  np.tile(ref[times == 7.3][0], (4, 1)))


def test_earlier_than_t0_raises_and_later_blocks_are_reachable_directly():
    field = DrydenWind(seed=5, t0=2.0)
    with pytest.raises(ValueError, match="'t'"):
        field.velocity(1.9, np.zeros((1, 3)))
    with pytest.raises(ValueError, match="'times'"):
        field.sample([3.0, 1.0])
    far = field.velocity(60.0, np.zeros((1, 3)))  # many blocks ahead, generated in order
    np.testing.assert_array_equal(DrydenWind(seed=5, t0=2.0).sample([2.0, 60.0])[1], far[0])


def test_a_query_far_ahead_keeps_only_its_own_block():
    """One query 2e4 s ahead kept every block it generated on the way (499 MB, past the
    64 MB cap; long-run audit): the blocks passed over give their start states only."""
    field = DrydenWind(seed=5)
    far = field.velocity(500.0, np.zeros((1, 3)))
    assert len(field._values) == 1
    near = field.velocity(100.0, np.zeros((1, 3)))  # a block passed over: regenerated alike
    fresh = DrydenWind(seed=5).sample(np.arange(0.0, 500.001, 0.5))
    np.testing.assert_array_equal(far[0], fresh[-1])
    np.testing.assert_array_equal(near[0], fresh[200])


def test_between_lattice_points_the_gust_is_linear():
    field = DrydenWind(sigma=SIGMA, seed=2, time_step=0.01)
    g0, g1, gm = field.sample([1.0, 1.01, 1.0025])
    np.testing.assert_allclose(gm, 0.75 * g0 + 0.25 * g1, rtol=0, atol=1e-12)


def test_rng_generator_int_and_seed_alias():
    a = DrydenWind(rng=7).sample([0.5, 1.5])
    np.testing.assert_array_equal(DrydenWind(seed=7).sample([0.5, 1.5]), a)
    np.testing.assert_array_equal(DrydenWind((3, 0, 0), (1.5, 1.5, 0.7), 7).sample([0.5, 1.5]), a)
    g1 = DrydenWind(rng=np.random.default_rng(3))
    g2 = DrydenWind(rng=np.random.default_rng(3))
    assert g1.seed == g2.seed
    np.testing.assert_array_equal(g1.sample([0.5, 1.5]), g2.sample([0.5, 1.5]))
    with pytest.raises(ValueError, match="'seed'"):
        DrydenWind(seed=1, rng=1)
    with pytest.raises(ValueError, match="'rng'"):
        DrydenWind(rng="zero")


def test_pickled_copy_gives_the_same_gusts():
    import pickle

    field = DrydenWind(mean=MEAN, sigma=SIGMA, seed=4)
    first = field.sample([0.3, 12.0])
    copy = pickle.loads(pickle.dumps(field))
    np.testing.assert_array_equal(copy.sample([12.0, 0.3]), first[::-1])


def test_different_seeds_differ_and_sigma_zero_gives_mean():
    w0 = DrydenWind(seed=0).velocity(1.0, np.zeros((1, 3)))
    w1 = DrydenWind(seed=1).velocity(1.0, np.zeros((1, 3)))
    assert not np.allclose(w0, w1)
    calm = DrydenWind(mean=(1.0, 2.0, 3.0), sigma=(0.0, 0.0, 0.0), seed=0)
    np.testing.assert_array_equal(calm.sample([0.1, 1.0, 9.0]), np.tile([1.0, 2.0, 3.0], (3, 1)))


def test_independent_realisations_per_row():
    r = 64
    field = DrydenWind(mean=MEAN, sigma=SIGMA, seed=9, batch_size=r, length_scales=(5, 5, 2),
                       time_step=0.01)
    w = field.sample(0.05 * np.arange(1, 4001))  # (K, R, 3), 200 s = 100 T_u
    assert w.shape == (4000, r, 3)
    # rows are independent: cross-correlation between realisations ~ 0
    corr = np.corrcoef(w[:, :, 0].T)
    off = corr[~np.eye(r, dtype=bool)]
    assert np.abs(off).max() < 0.5 and abs(off.mean()) < 0.02
    # and together they have the right spread
    np.testing.assert_allclose(w.reshape(-1, 3).std(axis=0), SIGMA, rtol=0.05)
    with pytest.raises(ValueError, match="'xyz'"):
        field.velocity(300.0, np.zeros((r - 1, 3)))
    assert field.velocity(300.0, np.zeros((r, 3))).shape == (r, 3)


@pytest.mark.parametrize(
    "kwargs, name",
    [({"sigma": (1, -1, 1)}, "sigma"), ({"airspeed": 0.0}, "airspeed"),
     ({"altitude": -2.0}, "altitude"), ({"length_scales": (1, 0, 1)}, "length_scales"),
     ({"mean": (1, np.nan, 0)}, "mean"), ({"seed": -1}, "seed"), ({"seed": 1.5}, "seed"),
     ({"batch_size": 0}, "batch_size"), ({"rng": -3}, "rng"), ({"time_step": 0.0}, "time_step"),
     # a microsecond time constant: the gusts were hundreds of times sigma (audit, 2026-12-05)
     ({"length_scales": (1e-6,) * 3}, "length_scales")],
)
def test_bad_parameters_raise_naming_them(kwargs, name):
    with pytest.raises(ValueError, match=f"'{name}' parameter of DrydenWind"):
        DrydenWind(**kwargs)


def test_one_object_serves_two_flights_like_two_fresh_ones():
    # issue 8: a reused DrydenWind gives the same gusts to two flights; the second flight
    # queries times earlier than the first one's last
    import windnav as wn

    p = wn.vehicle.params("hummingbird")
    quiet = wn.sensors.SensorSuite(None, None, None)
    circle = wn.sim.make_trajectory("circle", start=(0, 0, 2), size=2.0, speed=1.5)
    hover = wn.sim.make_trajectory("hover", start=(1, 1, 3))

    def gusts():
        return DrydenWind(mean=MEAN, sigma=SIGMA, rng=21)

    shared = gusts()
    first = wn.sim.fly(p, circle, shared, 3.0, sensors=quiet)
    second = wn.sim.fly(p, hover, shared, 1.5, sensors=quiet, dt=0.002)
    again = wn.sim.fly(p, circle, shared, 3.0, sensors=quiet)
    fresh_first = wn.sim.fly(p, circle, gusts(), 3.0, sensors=quiet)
    fresh_second = wn.sim.fly(p, hover, gusts(), 1.5, sensors=quiet, dt=0.002)
    for name in ("position", "velocity", "attitude", "rotor_speeds", "wind", "energy"):
        np.testing.assert_array_equal(getattr(first, name), getattr(fresh_first, name))
        np.testing.assert_array_equal(getattr(again, name), getattr(fresh_first, name))
        np.testing.assert_array_equal(getattr(second, name), getattr(fresh_second, name))
    # the two flights saw the same gust at the same times
    common = np.isin(np.round(second.t, 9), np.round(first.t, 9))
    np.testing.assert_array_equal(second.wind[common, 0],
                                  first.wind[np.isin(np.round(first.t, 9),
                                                     np.round(second.t, 9)), 0])
    assert np.ptp(first.wind[:, 0, 0]) > 0.1  # they are gusts, not a constant


def test_concurrent_queries_from_threads_see_the_same_gusts():
    from concurrent.futures import ThreadPoolExecutor

    times = np.random.default_rng(1).uniform(0.0, 40.0, (4, 300))
    ref = DrydenWind(mean=MEAN, sigma=SIGMA, rng=8).sample(times.ravel()).reshape(4, 300, 3)
    shared = DrydenWind(mean=MEAN, sigma=SIGMA, rng=8)

    def query(row):
        return np.array([shared.velocity(t, np.zeros((1, 3)))[0] for t in times[row]])

    with ThreadPoolExecutor(4) as pool:
        got = list(pool.map(query, range(4)))
    np.testing.assert_array_equal(np.stack(got), ref)


def test_block_start_states_are_kept_sparsely_and_regenerated_bit_for_bit():
    """Every block's start state was kept: one per 2.048 s, about 100 MB at t = 1e6 s
    (long-run audit). Every 64th and the furthest are kept; a block between is run forward
    from the kept one before it, to the same bits."""
    from windnav.wind.dryden import _BLOCK, _START_STRIDE

    field = DrydenWind(mean=MEAN, sigma=SIGMA, seed=5, batch_size=3)
    far = 1.0 + 150 * _BLOCK * field.time_step   # 150 blocks ahead
    field.velocity(far, np.zeros((3, 3)))
    assert field._frontier == 151 and set(field._starts) == {0, 64, 128, 151}
    assert _START_STRIDE == 64
    past = np.array([3.7, 77.0 * _BLOCK * field.time_step + 0.31, far - 0.5])
    got = np.array([field.velocity(t, np.zeros((3, 3))) for t in past])
    fresh = DrydenWind(mean=MEAN, sigma=SIGMA, seed=5, batch_size=3)
    want = np.array([fresh.velocity(t, np.zeros((3, 3))) for t in past])  # in order
    np.testing.assert_array_equal(got, want)
    field.reset()
    assert set(field._starts) == {0} and field._frontier == 0
    np.testing.assert_array_equal(field.velocity(past[1], np.zeros((3, 3))), want[1])
