"""Least-squares arithmetic of windnav.sysid and the readers' errors on bad input."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.optimize
import scipy.stats

from windnav.sysid import read_table
from windnav.sysid._fit import linear_fit, nonlinear_fit
from windnav.sysid._signal import local_slope, min_run, steepest_slope
from windnav.sysid.io import parse_topic_map


def test_linear_fit_matches_the_normal_equations_and_textbook_interval():
    rng = np.random.default_rng(0)
    n = 40
    X = np.column_stack([np.ones(n), rng.uniform(0, 10, n), rng.uniform(-1, 1, n)])
    y = X @ np.array([1.5, -0.3, 2.0]) + rng.normal(0, 0.2, n)
    fit = linear_fit(X, y, ["a", "b", "c"], source="test")
    beta = np.linalg.solve(X.T @ X, X.T @ y)
    np.testing.assert_allclose(fit.coef, beta, rtol=1e-12)
    s2 = np.sum((y - X @ beta) ** 2) / (n - 3)
    cov = s2 * np.linalg.inv(X.T @ X)
    np.testing.assert_allclose(fit.cov, cov, rtol=1e-10)
    e = fit.estimate("b")
    half = scipy.stats.t.ppf(0.975, n - 3) * np.sqrt(cov[1, 1])
    np.testing.assert_allclose(e.ci95, (beta[1] - half, beta[1] + half), rtol=1e-10)
    r2 = 1 - np.sum((y - X @ beta) ** 2) / np.sum((y - y.mean()) ** 2)
    assert fit.r2 == pytest.approx(r2, rel=1e-12)


def test_intervals_cover_the_truth_about_95_percent_of_the_time():
    rng = np.random.default_rng(1)
    x = np.linspace(0, 1, 12)
    X = np.column_stack([x**2 * 1e-8, np.ones_like(x)])  # badly scaled on purpose
    hits = 0
    trials = 400
    for _ in range(trials):
        y = X @ np.array([3e8, 0.5]) + rng.normal(0, 0.1, x.size)
        lo, hi = linear_fit(X, y, ["k", "b"], source="test").estimate("k").ci95
        hits += lo <= 3e8 <= hi
    # binomial(400, 0.95): 2.5 standard deviations is +/- 0.027
    assert abs(hits / trials - 0.95) < 0.03


def test_nonlinear_fit_recovers_an_exponential_and_agrees_with_curve_fit():
    rng = np.random.default_rng(2)
    t = np.linspace(0, 4, 60)
    y = 2.0 * np.exp(-0.7 * t) + rng.normal(0, 0.01, t.size)

    def model(b):
        return b[0] * np.exp(-b[1] * t)

    def jac(b):
        e = np.exp(-b[1] * t)
        return np.column_stack([e, -b[0] * t * e])

    fit = nonlinear_fit(model, jac, [1.0, 1.0], y, ["A", "k"], source="test")
    popt, pcov = scipy.optimize.curve_fit(lambda tt, a, k: a * np.exp(-k * tt), t, y, p0=[1, 1])
    np.testing.assert_allclose(fit.coef, popt, rtol=1e-6)
    np.testing.assert_allclose(fit.cov, pcov, rtol=1e-4)


def test_fits_refuse_too_few_points_and_dependent_regressors():
    X = np.ones((2, 2))
    with pytest.raises(ValueError, match="'f.csv' .* 2 usable points, fewer than the 3"):
        linear_fit(X, [1.0, 2.0], ["a", "b"], source="'f.csv'")
    X = np.column_stack([np.arange(5.0), 2 * np.arange(5.0)])
    with pytest.raises(ValueError, match="linearly dependent"):
        linear_fit(X, np.arange(5.0), ["a", "b"], source="x")


# --- heteroscedasticity- and cluster-robust covariances (cov_type) ---------------------------
def _tiny():
    """Eight points, a line, three clusters of unequal size."""
    x = np.array([0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0])
    X = np.column_stack([np.ones_like(x), x])
    y = np.array([0.1, 1.3, 1.7, 3.4, 3.9, 5.6, 5.8, 7.5])
    return X, y, np.array([0, 0, 0, 1, 1, 2, 2, 2])


def test_hc3_and_cluster_covariances_are_the_sandwiches_by_hand():
    X, y, groups = _tiny()
    n, p = X.shape
    classical = linear_fit(X, y, ["a", "b"], source="t")
    hc3 = linear_fit(X, y, ["a", "b"], source="t", cov_type="hc3")
    cr1 = linear_fit(X, y, ["a", "b"], source="t", cov_type="cluster", clusters=groups)
    for fit in (hc3, cr1):  # the estimates, residuals and R^2 do not depend on the covariance
        np.testing.assert_array_equal(fit.coef, classical.coef)
        np.testing.assert_array_equal(fit.residuals, classical.residuals)
        assert fit.r2 == classical.r2 and fit.dof == n - p
    bread = np.linalg.inv(X.T @ X)
    e = y - X @ bread @ X.T @ y
    h = np.array([X[i] @ bread @ X[i] for i in range(n)])
    meat = sum(np.outer(X[i], X[i]) * e[i] ** 2 / (1 - h[i]) ** 2 for i in range(n))
    np.testing.assert_allclose(hc3.cov, bread @ meat @ bread, rtol=1e-10)
    assert hc3.cov_type == "hc3" and hc3.t_dof is None  # t on n - p
    half = scipy.stats.t.ppf(0.975, n - p) * np.sqrt(hc3.cov[1, 1])
    np.testing.assert_allclose(hc3.estimate("b").ci95, hc3.coef[1] + np.array([-half, half]))
    scores = [X[groups == g].T @ e[groups == g] for g in range(3)]
    meat = sum(np.outer(s, s) for s in scores)
    corr = 3 / 2 * (n - 1) / (n - p)
    np.testing.assert_allclose(cr1.cov, corr * bread @ meat @ bread, rtol=1e-10)
    assert cr1.cov_type == "cluster" and cr1.t_dof == 2  # t on G - 1
    half = scipy.stats.t.ppf(0.975, 2) * np.sqrt(cr1.cov[1, 1])
    np.testing.assert_allclose(cr1.estimate("b").ci95, cr1.coef[1] + np.array([-half, half]))
    assert cr1.estimate("b").std_error == pytest.approx(np.sqrt(cr1.cov[1, 1]))
    # cluster labels of any kind (strings), in any order
    relabel = linear_fit(X, y, ["a", "b"], source="t", cov_type="cluster",
                         clusters=np.array(["z", "z", "z", "a", "a", "m", "m", "m"]))
    np.testing.assert_allclose(relabel.cov, cr1.cov, rtol=1e-12)


def test_robust_covariances_reduce_to_the_classical_one_for_an_even_residual_pattern():
    """Residuals all of one size, equal leverages (a balanced design): HC3 is the classical
    covariance times n / (n - p), and the cluster one with one point per cluster equals it
    (CR1's n / (n - 1) (n - 1) / (n - p) times HC0's s^2 (n - p) / n)."""
    x = np.array([1.0, 1.0, -1.0, -1.0, 1.0, 1.0, -1.0, -1.0])
    X = np.column_stack([np.ones_like(x), x])
    r = np.array([1.0, -1.0, 1.0, -1.0, 1.0, -1.0, 1.0, -1.0])  # orthogonal to both columns
    y = X @ np.array([2.0, 0.5]) + 0.3 * r
    n, p = X.shape
    classical = linear_fit(X, y, ["a", "b"], source="t")
    np.testing.assert_allclose(classical.residuals, 0.3 * r, atol=1e-12)
    hc3 = linear_fit(X, y, ["a", "b"], source="t", cov_type="hc3")
    np.testing.assert_allclose(hc3.cov, n / (n - p) * classical.cov, rtol=1e-10, atol=1e-15)
    singles = linear_fit(X, y, ["a", "b"], source="t", cov_type="cluster", clusters=np.arange(n))
    np.testing.assert_allclose(singles.cov, classical.cov, rtol=1e-10, atol=1e-15)
    assert singles.t_dof == n - 1


def test_nonlinear_fit_sandwiches_use_the_jacobian_at_the_optimum():
    # a model linear in its parameters, written as a nonlinear one: the same covariances
    X, y, groups = _tiny()
    for cov_type in ("classical", "hc3", "cluster"):
        lin = linear_fit(X, y, ["a", "b"], source="t", cov_type=cov_type, clusters=groups)
        non = nonlinear_fit(lambda b: X @ b, lambda b: X, [0.0, 0.0], y, ["a", "b"],
                            source="t", cov_type=cov_type, clusters=groups)
        np.testing.assert_allclose(non.coef, lin.coef, rtol=1e-9)
        np.testing.assert_allclose(non.cov, lin.cov, rtol=1e-6)
        assert non.cov_type == cov_type and non.t_dof == lin.t_dof


def test_cov_type_and_clusters_are_checked():
    X, y, groups = _tiny()
    with pytest.raises(ValueError, match=r"'cov_type' parameter of linear_fit must be one of "
                                         r"\['classical', 'hc3', 'cluster'\]. Got 'HC3'"):
        linear_fit(X, y, ["a", "b"], source="t", cov_type="HC3")
    with pytest.raises(ValueError, match="'clusters' parameter of linear_fit must give each "
                                         "point's cluster"):
        linear_fit(X, y, ["a", "b"], source="t", cov_type="cluster")
    with pytest.raises(ValueError, match=r"'clusters' parameter of nonlinear_fit must hold one "
                                         r"label per point \(8\). Got shape \(7,\)"):
        nonlinear_fit(lambda b: X @ b, lambda b: X, [0.0, 0.0], y, ["a", "b"], source="t",
                      cov_type="cluster", clusters=groups[:7])
    # two clusters cannot give a covariance of two parameters: their scores sum to zero
    with pytest.raises(ValueError, match=r"'f.csv' fall into 2 clusters, too few .* \(at "
                                         r"least 3 needed"):
        linear_fit(X, y, ["a", "b"], source="'f.csv'", cov_type="cluster",
                   clusters=np.r_[np.zeros(4), np.ones(4)])
    with pytest.raises(ValueError, match="leverage 1"):  # a point alone determines c
        linear_fit(np.column_stack([X, np.eye(8)[0]]), y, ["a", "b", "c"], source="t",
                   cov_type="hc3")


def _coverage(fits, truth) -> dict:
    """Share of the fits (lists per covariance) whose 95 % intervals hold the truth."""
    return {c: np.mean([[lo <= t <= hi for (lo, hi), t in zip(ci, truth, strict=True)]
                        for ci in cis], axis=0) for c, cis in fits.items()}


def test_robust_intervals_cover_a_scatter_that_grows_where_the_classical_do_not():
    """k_eta's fit, thrust = k omega^2, with 1 % relative noise (the simulated stand's speed
    noise made the scatter grow with the speed; the classical interval of k_eta covered 72 %
    of 1,000 seeds): 64 steps of 5 points, 1,000 draws (fixed seed; over 20 x 200 draws
    classical 0.81, HC3 0.94, cluster 0.93: CR1 runs a little narrow where a few clusters
    carry most of the weight, here the fastest steps)."""
    rng = np.random.default_rng(7)
    w = np.repeat(np.linspace(300.0, 1500.0, 64), 5)
    steps = np.repeat(np.arange(64), 5)
    X = w[:, None] ** 2
    k = 5e-6
    fits = {"classical": [], "hc3": [], "cluster": []}
    for _ in range(1000):
        y = k * X[:, 0] * (1 + 0.01 * rng.standard_normal(w.size))
        for cov_type, cis in fits.items():
            fit = linear_fit(X, y, ["k"], source="t", cov_type=cov_type, clusters=steps)
            cis.append([fit.estimate("k").ci95])
    cover = _coverage(fits, [k])
    assert cover["classical"][0] < 0.88
    assert 0.90 <= cover["hc3"][0] <= 0.99 and 0.90 <= cover["cluster"][0] <= 0.99


def test_cluster_intervals_cover_an_error_shared_within_each_step():
    """The PWM motor model on 8 voltages x 8 PWM steps x 10 points, 0.5 % independent relative
    speed noise and 0.4 % shared by the points of a step: only the cluster-robust intervals
    cover (1,000 draws, fixed seed; over 3,000 draws classical 0.57-0.73, HC3 0.63, cluster
    0.92-0.94)."""
    volt = np.repeat(2.7 + 0.2 * np.arange(8), 80)
    pwm = np.tile(np.repeat(np.arange(15_000.0, 50_001.0, 5_000.0), 10), 8)
    steps = np.repeat(np.arange(64), 10)
    truth = np.array([0.24, 0.5535, 4673.0])

    def model(b):
        return b[0] * (volt + b[1]) * (pwm - b[2]) ** (2 / 3)

    def jac(b):
        d = pwm - b[2]
        return np.column_stack([(volt + b[1]) * d ** (2 / 3), b[0] * d ** (2 / 3),
                                -2 / 3 * b[0] * (volt + b[1]) * d ** (-1 / 3)])

    rng = np.random.default_rng(1)
    fits = {"classical": [], "hc3": [], "cluster": []}
    for _ in range(1000):
        shared = 0.004 * rng.standard_normal(64)[steps]
        w = model(truth) * (1 + 0.005 * rng.standard_normal(pwm.size) + shared)
        for cov_type, cis in fits.items():
            fit = nonlinear_fit(model, jac, truth * [1.02, 0.9, 0.98], w, ["Kv", "V0", "DZ"],
                                source="t", cov_type=cov_type, clusters=steps)
            cis.append([fit.estimate(n).ci95 for n in ("Kv", "V0", "DZ")])
    cover = _coverage(fits, truth)
    assert np.all(cover["classical"] < 0.85) and np.all(cover["hc3"] < 0.85)
    assert np.all((0.90 <= cover["cluster"]) & (cover["cluster"] <= 0.99)), cover


def test_slopes_of_a_line_and_of_a_step():
    t = np.arange(0, 2, 0.01)
    np.testing.assert_allclose(local_slope(t, 3 * t + 1, 0.1), 3.0, rtol=1e-9)
    np.testing.assert_allclose(steepest_slope(t, 3 * t + 1, 0.1), 3.0, rtol=1e-9)
    step = np.where(t >= 1.0, 100.0, 0.0)
    k = int(np.argmax(t >= 1.0))
    # near a step the centred window averages it with flat samples; the steeper one-sided
    # slope sees it on both sides
    assert abs(steepest_slope(t, step, 0.1)[k - 1]) > 1000
    assert abs(steepest_slope(t, step, 0.1)[k + 4]) > 1000
    assert abs(local_slope(t, step, 0.1)[k + 4]) < abs(steepest_slope(t, step, 0.1)[k + 4])
    assert abs(steepest_slope(t, step, 0.1)[k + 10]) < 1e-6
    # a time gap starts a new segment: no slope across it
    t2 = np.r_[t, t + 10]
    y2 = np.r_[np.zeros_like(t), np.full_like(t, 50.0)]
    assert np.all(np.abs(steepest_slope(t2, y2, 0.1)) < 1e-6)


def test_slopes_of_a_long_log_equal_each_windows_own_least_squares():
    """An hour at 100 Hz of a steady 1,500 rad/s with noise: every window's slope equals its
    least-squares line computed about the window (NumPy's polyfit). Running sums over the whole
    log lost it to cancellation: 1,410 rad/s^2 where the slopes are about 49, so a steady
    sample crossed a 1,000 rad/s^2 steadiness threshold (reference audit, 2026-12-05)."""
    rng = np.random.default_rng(5)
    t = np.arange(360_000) / 100.0
    y = 1500.0 + rng.normal(0.0, 2.0, t.size)
    h = 5
    picks = np.r_[np.arange(h, 200), np.arange(t.size - 5_000, t.size - h)]
    left, right = steepest_slope(t, y, 0.1), local_slope(t, y, 0.1)
    for i in picks[::7]:
        before = np.polyfit(t[i - h : i + 1] - t[i], y[i - h : i + 1], 1)[0]
        after = np.polyfit(t[i : i + h + 1] - t[i], y[i : i + h + 1], 1)[0]
        steepest = before if abs(before) >= abs(after) else after
        centred = np.polyfit(t[i - h : i + h + 1] - t[i], y[i - h : i + h + 1], 1)[0]
        assert left[i] == pytest.approx(steepest, rel=1e-9, abs=1e-9)
        assert right[i] == pytest.approx(centred, rel=1e-9, abs=1e-9)
    assert np.abs(left[h:-h]).max() < 1000.0


def test_min_run_drops_short_runs():
    t = np.arange(0, 10, 0.1)
    mask = (t > 1) & (t < 1.5) | (t > 3) & (t < 6)
    kept = min_run(t, mask, 1.0)
    assert not kept[(t > 1) & (t < 1.5)].any()
    assert kept[(t > 3) & (t < 6)].all()



def test_min_run_keeps_a_run_exactly_min_s_long_and_drops_a_shorter_one():
    """A run's length is the time from its first to its last sample; runs of at least
    ``min_s`` stay. Dyadic times make the lengths exact, so the boundary is sharp."""
    t = 0.25 * np.arange(60)
    mask = np.zeros(t.size, bool)
    mask[4:13] = True    # t 1.00 .. 3.00: 2.00 s, exactly min_s
    mask[20:28] = True   # t 5.00 .. 6.75: 1.75 s
    mask[32:45] = True   # t 8.00 .. 11.00: 3.00 s
    kept = min_run(t, mask, 2.0)
    # brute force: each maximal run of True, kept when last - first >= min_s
    want = mask.copy()
    i = 0
    while i < t.size:
        if mask[i]:
            j = i
            while j + 1 < t.size and mask[j + 1]:
                j += 1
            want[i:j + 1] = t[j] - t[i] >= 2.0
            i = j + 1
        else:
            i += 1
    np.testing.assert_array_equal(kept, want)
    assert kept[4:13].all() and not kept[20:28].any() and kept[32:45].all()

# --- readers -----------------------------------------------------------------------------
def test_read_table_names_the_file_line_and_column_of_a_bad_value(tmp_path):
    path = tmp_path / "stand.csv"
    path.write_text("timestamp,pwm,rpm\n0.0,10000,3000\n0.01,abc,3001\n")
    with pytest.raises(ValueError, match=r"stand\.csv.*'abc' in column 'pwm' at line 3"):
        read_table(path)
    path.write_text("timestamp,pwm,rpm\n0.0,10000\n")
    with pytest.raises(ValueError, match=r"stand\.csv.*2 fields at line 2"):
        read_table(path)
    with pytest.raises(ValueError, match="does not exist"):
        read_table(tmp_path / "missing.csv")
    path.write_text("timestamp,pwm,rpm\n0.0,,nan\n")
    tab = read_table(path)
    assert np.isnan(tab.columns["pwm"][0]) and np.isnan(tab.columns["rpm"][0])
    with pytest.raises(ValueError, match=r"stand\.csv.*lacks the column\(s\) \['thrust_N'\]"):
        tab.require(["pwm", "thrust_N"], "here")


def test_read_table_headerless_whitespace_with_and_without_layout(tmp_path):
    path = tmp_path / "log.txt"
    path.write_text("1 2.5 3\n4 5 6e1\n")
    tab = read_table(path)
    assert tab.names == ["0", "1", "2"]
    np.testing.assert_array_equal(tab.columns["2"], [3.0, 60.0])
    tab = read_table(path, layout=["a", "b", "c"])
    np.testing.assert_array_equal(tab.columns["b"], [2.5, 5.0])
    with pytest.raises(ValueError, match="has 3 columns but the layout names 39"):
        read_table(path, layout="optimal_energy_quad")


def test_topic_map_syntax():
    assert parse_topic_map(["f=/imu:linear_acceleration", "p=/power"], "w") == {
        "f": ("/imu", "linear_acceleration"), "p": ("/power", "")}
    with pytest.raises(ValueError, match="COLUMN=/topic"):
        parse_topic_map(["f:/imu"], "w")


def test_missing_rosbags_is_an_import_error_with_an_install_hint(tmp_path, monkeypatch):
    import sys

    monkeypatch.setitem(sys.modules, "rosbags.highlevel", None)  # as if not installed
    from windnav.sysid import read_bag

    with pytest.raises(ImportError, match="pip install rosbags"):
        read_bag(tmp_path / "run.bag", {"f": ("/imu", "linear_acceleration")})


def test_a_nonlinear_fit_that_does_not_converge_says_so(monkeypatch):
    """least_squares stops at its evaluation budget; the last iterate was reported as a fit with
    intervals, unsaid (audit, 2026-12-05). Here the budget is cut to 2 evaluations."""
    import warnings

    import scipy.optimize

    from windnav.sysid._fit import nonlinear_fit

    x = np.linspace(0.0, 1.0, 50)
    y = np.exp(3.0 * x) + 0.01 * np.sin(40 * x)

    def model(b):
        return b[0] * np.exp(b[1] * x)

    def jac(b):
        return np.column_stack([np.exp(b[1] * x), b[0] * x * np.exp(b[1] * x)])

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        nonlinear_fit(model, jac, [1.0, 1.0], y, ("a", "k"), source="the samples")
    solve = scipy.optimize.least_squares
    monkeypatch.setattr(scipy.optimize, "least_squares",
                        lambda *a, **kw: solve(*a, **{**kw, "max_nfev": 2}))
    with pytest.warns(RuntimeWarning, match="fit of a, k to the samples did not converge"):
        nonlinear_fit(model, jac, [1.0, 1.0], y, ("a", "k"), source="the samples")
