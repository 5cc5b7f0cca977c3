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
