"""``WindTrack``'s metrics leave out the samples where the filter did not run (leftovers,
2026-12-05).

``mean_error_after`` left non-finite estimates out, ``rmse_after`` and ``nees`` returned NaN for
the same track; now all three leave them out, and say so when none is left.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest

from windnav.estimate.flight import WindTrack


def track(est, cov=None):
    n = len(est)
    rng = np.random.default_rng(0)
    true = rng.normal(size=(n, 3))
    cov = np.tile(np.diag([0.5, 1.0, 2.0]), (n, 1, 1)) if cov is None else cov
    return WindTrack(t=0.5 * np.arange(n), wind_est=np.asarray(est, float), wind_cov=cov,
                     wind_true=true, x=np.zeros((n, 16)), repairs=0)


def test_the_three_metrics_leave_out_where_the_filter_did_not_run():
    est = np.random.default_rng(1).normal(size=(10, 3))
    full = track(est)
    holes = est.copy()
    holes[[4, 7]] = np.nan                  # the filter did not run there
    cov = full.wind_cov.copy()
    cov[[4, 7]] = np.nan
    gappy = track(holes, cov)
    ran = [i for i in range(10) if i not in (4, 7)]
    kept = WindTrack(t=full.t[ran], wind_est=est[ran], wind_cov=full.wind_cov[ran],
                     wind_true=full.wind_true[ran], x=np.zeros((8, 16)))
    with warnings.catch_warnings():
        warnings.simplefilter("error")      # no warning: samples are left
        for settle in (0.0, 1.0):           # samples 0-9 and 2-9
            assert gappy.rmse_after(settle) == pytest.approx(kept.rmse_after(settle), rel=1e-12)
            for k in range(3):
                assert gappy.rmse_after(settle, axis=k) == pytest.approx(
                    kept.rmse_after(settle, axis=k), rel=1e-12)
            assert gappy.nees(settle) == pytest.approx(kept.nees(settle), rel=1e-12)
            np.testing.assert_allclose(gappy.mean_error_after(settle),
                                       kept.mean_error_after(settle), rtol=1e-12)
    assert np.isfinite(gappy.rmse_after(1.0)) and np.isfinite(gappy.nees(1.0))
    # a track where the filter ran throughout: the numbers as before, to the bit
    e = full.error[full.t - full.t[0] >= 1.0]
    assert full.rmse_after(1.0) == float(np.sqrt(np.mean(np.sum(e**2, axis=1))))
    assert full.rmse_after(1.0, axis=2) == float(np.sqrt(np.mean(e[:, 2] ** 2)))
    sol = np.linalg.solve(full.wind_cov[2:], e[..., None])[..., 0]
    assert full.nees(1.0) == float(np.mean(np.sum(e * sol, axis=1)))
    assert np.array_equal(full.mean_error_after(1.0), np.nanmean(e, axis=0))


def test_no_sample_left_is_nan_with_a_warning_naming_the_metric():
    est = np.random.default_rng(2).normal(size=(6, 3))
    est[2:] = np.nan                        # the filter stopped after 1 s
    cov = np.tile(np.eye(3), (6, 1, 1))
    cov[2:] = np.nan
    stopped = track(est, cov)
    for method in ("rmse_after", "nees", "mean_error_after"):
        with pytest.warns(RuntimeWarning, match=rf"WindTrack.{method}: no estimate \(the filter "
                                                r"did not run\) or no logged truth at any of "
                                                r"the 4 samples after settle_s = 1 s"):
            value = getattr(stopped, method)(1.0)
        assert np.all(np.isnan(value))
    # nees checks its settling time as the other two do (it took the mean of no sample)
    with pytest.raises(ValueError, match="'settle_s' parameter of WindTrack.nees must be below"):
        stopped.nees(10.0)


def test_a_sparse_log_gives_the_same_estimate_and_scores_only_its_own_samples():
    """With ``log_every`` > 2 the filter's inputs took the log's commands, up to
    ``log_every - 1`` physics steps stale, and scored against the log's last true wind: the
    estimate moved with ``log_every`` (0.49 m/s at 100; metamorphic audit, 2026-12-05). The
    rotor-speed sensor's commands are as fresh as the controller's, so the estimate is the same
    whatever the logging, and the error is taken where the log holds the truth."""
    import windnav as wn

    p = wn.vehicle.params("hummingbird")
    gusts = wn.wind.DrydenWind(mean=(3, 0, 0), sigma=(1.5, 1.5, 0.7), rng=0)
    traj = wn.sim.make_trajectory("circle", size=3.0)
    tracks = {k: wn.estimate.run_wind_ukf(
        wn.sim.fly(p, traj, gusts, duration=6.0, rng=0, log_every=k), p, conditions="windnav")
        for k in (1, 2, 5)}
    for k in (2, 5):
        np.testing.assert_array_equal(tracks[k].wind_est, tracks[1].wind_est)
        scored = np.isfinite(tracks[k].wind_true[:, 0])
        np.testing.assert_array_equal(tracks[k].wind_true[scored], tracks[1].wind_true[scored])
        assert scored.sum() == pytest.approx(scored.size / k, abs=1)  # the log's own samples
        assert abs(tracks[k].rmse_after(2.0) / tracks[1].rmse_after(2.0) - 1) < 0.1


def test_a_noisy_rotor_sensor_is_not_taken_for_the_commands():
    """Under the thesis's conditions the rotor-speed sensor reads the commands with 10 rad/s of
    noise: its readings are measurements, and taken as the inputs they counted the noise twice
    (up to 0.39 m/s with log_every = 3; pipeline audit, 2026-12-05). Such a log's stale
    commands are warned instead; log_every = 2 keeps every control step and is exact."""
    import warnings

    import windnav as wn
    from windnav.experiments.ukf_conditions import ukf_conditions

    p = wn.vehicle.params("hummingbird")
    sensors = ukf_conditions("thesis").sensor_suite(100.0)
    wind = wn.wind.ConstantWind((3.0, 0.0, 0.0))
    traj = wn.sim.make_trajectory("circle", size=3.0)

    def track(k):
        log = wn.sim.fly(p, traj, wind, duration=4.0, rng=0, log_every=k, sensors=sensors)
        return wn.estimate.run_wind_ukf(log, p, conditions="thesis")

    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        full, two = track(1), track(2)
    np.testing.assert_array_equal(two.wind_est, full.wind_est)
    with pytest.warns(RuntimeWarning, match="coarser than the controller's 0.01 s"):
        track(3)
