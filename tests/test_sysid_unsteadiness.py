"""Unsteadiness maps: binned mean wind, force-command spread and body rates."""

from __future__ import annotations

import argparse
import json

import numpy as np
import pytest

import windnav as wn
import windnav.commands.sysid
from windnav.sysid import (
    UNSTEADINESS_COLUMNS,
    FlightSamples,
    bin_xy,
    lateral_force_command,
    unsteadiness_maps,
    write_csv,
)


def _cli(*argv):
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers(dest="command")
    windnav.commands.sysid.register(sub)
    args = parser.parse_args([str(a) for a in argv])
    return args.func(args)


# --- unsteadiness-----------------------------------------------------------------------
def test_bin_xy_matches_loops():
    rng = np.random.default_rng(0)
    xy = rng.uniform(-2, 3, (500, 2))
    vals = rng.normal(size=(500, 2))
    xe, ye = np.arange(-2, 3.5, 1.0), np.arange(-2, 3.5, 0.5)
    count, mean, var = bin_xy(xy, vals, xe, ye)
    for j in range(len(ye) - 1):
        for i in range(len(xe) - 1):
            sel = ((xy[:, 0] >= xe[i]) & (xy[:, 0] < xe[i + 1]) & (xy[:, 1] >= ye[j])
                   & (xy[:, 1] < ye[j + 1]))
            assert count[j, i] == sel.sum()
            if sel.any():
                np.testing.assert_allclose(mean[j, i], vals[sel].mean(0), atol=1e-12)
                np.testing.assert_allclose(var[j, i], vals[sel].var(0), atol=1e-12)


def test_lateral_force_command_of_a_tilted_thrust():
    eta = np.full((2, 4), 1000.0)
    theta = 0.3
    att = np.array([[0, 0, 0, 1.0], [0, np.sin(theta / 2), 0, np.cos(theta / 2)]])
    f = lateral_force_command(att, eta, 4e-8)
    thrust = 4 * 4e-8 * 1000.0**2
    np.testing.assert_allclose(f[0], [0, 0], atol=1e-15)
    np.testing.assert_allclose(f[1], [thrust * np.sin(theta), 0], rtol=1e-12)


def test_unsteadiness_maps_of_known_samples(tmp_path):
    # two bins: calm (constant force) and gusty (force alternating +/- 0.1 N on x)
    n = 40
    xy = np.r_[np.full((n, 2), 0.5), np.full((n, 2), [1.5, 0.5])]
    fx = np.r_[np.full(n, 0.2), 0.2 + 0.1 * (-1.0) ** np.arange(n)]
    cols = {"x": xy[:, 0], "y": xy[:, 1], "wind_x": np.r_[np.full(n, 1.0), np.full(n, 3.0)],
            "wind_y": np.zeros(2 * n), "force_cmd_x": fx, "force_cmd_y": np.zeros(2 * n),
            "body_rate_x": np.r_[np.zeros(n), np.full(n, 0.3)], "body_rate_y": np.zeros(2 * n),
            "body_rate_z": np.r_[np.zeros(n), np.full(n, 0.4)]}
    maps = unsteadiness_maps(FlightSamples(xy, np.column_stack([cols["wind_x"], cols["wind_y"]]),
                                           np.column_stack([fx, np.zeros(2 * n)]),
                                           np.zeros((2 * n, 3))), cell=1.0)
    np.testing.assert_allclose(maps.wind_mean[0, :, 0], [1.0, 3.0])
    with pytest.raises(ValueError, match="'cell' parameter of unsteadiness_maps must give at "
                                         "most"):  # a 7.5 TiB MemoryError on a log before
        unsteadiness_maps(FlightSamples(xy * 100, np.zeros((2 * n, 2)), np.zeros((2 * n, 2)),
                                        np.zeros((2 * n, 3))), cell=1e-6)
    bad = xy.copy()
    bad[3] = np.nan  # "arange: cannot compute length" before
    with pytest.raises(ValueError, match="'samples' parameter of unsteadiness_maps must have "
                                         "finite positions"):
        unsteadiness_maps(FlightSamples(bad, np.zeros((2 * n, 2)), np.zeros((2 * n, 2)),
                                        np.zeros((2 * n, 3))))
    np.testing.assert_allclose(maps.force_cmd_std[0], [0.0, 0.1], atol=1e-12)
    path = write_csv(tmp_path / "u.csv", cols)
    _cli("sysid", "unsteadiness", "--csv", path, "--cell", 1.0, "--min-count", 1,
         "--json", tmp_path / "u.json", "--out", tmp_path / "o")
    doc = json.loads((tmp_path / "u.json").read_text())
    np.testing.assert_allclose(doc["body_rate_mean_rad_s"][0], [0.0, 0.5], atol=1e-12)
    np.testing.assert_allclose(doc["force_cmd_std_N"][0], [0.0, 0.1], atol=1e-12)
    assert (tmp_path / "o" / "unsteadiness.png").is_file()
    # the command names its option, not the library's parameter (docs audit)
    with pytest.raises(ValueError, match="'--cell' parameter of windnav sysid unsteadiness "
                                         "must give at most"):
        _cli("sysid", "unsteadiness", "--csv", path, "--cell", 1e-9, "--out", tmp_path / "p")


def test_csv_files_without_a_finite_row_are_named_with_the_option(tmp_path, capsys):
    # "The 'samples' parameter of unsteadiness_maps holds no finite sample." named neither
    # --csv nor the file (CLI audit)
    from windnav import cli

    header = ",".join(UNSTEADINESS_COLUMNS)
    (tmp_path / "header.csv").write_text(header + "\n")
    (tmp_path / "nan.csv").write_text(header + "\nnan" + ",0" * 8 + "\n")
    status = cli.main(["sysid", "unsteadiness", "--csv", str(tmp_path / "header.csv"),
                       str(tmp_path / "nan.csv"), "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err.strip()
    assert status == 2 and len(err.splitlines()) == 1, err
    assert "header.csv'" in err and "nan.csv' given to windnav sysid unsteadiness (--csv) " \
        "hold no sample to bin: no row with finite x/y/wind_x/" in err
    assert "unsteadiness_maps" not in err
    assert not (tmp_path / "o").exists()


def test_a_csv_file_without_a_finite_row_beside_others_is_noted(tmp_path, capsys):
    # two files, one of them a header alone: the other was binned and the empty one passed
    # unsaid (CLI audit, fifty-seventh session)
    from windnav import cli

    header = ",".join(UNSTEADINESS_COLUMNS)
    (tmp_path / "header.csv").write_text(header + "\n")
    (tmp_path / "one.csv").write_text(header + "\n" + ",".join(["1"] * 9) + "\n")
    status = cli.main(["sysid", "unsteadiness", "--csv", str(tmp_path / "one.csv"),
                       str(tmp_path / "header.csv"), "--min-count", "1",
                       "--out", str(tmp_path / "o")])
    err = capsys.readouterr().err
    assert status == 0
    assert "header.csv' (--csv) has no row with finite x/y/wind_x/" in err
    assert "one.csv" not in err


@pytest.mark.parametrize("cell", [0.2, 0.1, 0.3, 0.7, 1.1, 0.05])
def test_samples_on_multiples_of_a_cell_not_exact_in_binary_are_all_binned(cell):
    """A hover logged at a waypoint on a multiple of the cell (55.2 m, cell 0.2): the grid
    ended on or before it and the sample fell out of every half-open bin (reference audit,
    2026-12-05: 256 of 4,000 fuzzed triples lost one)."""
    rng = np.random.default_rng(int(cell * 100))
    for _ in range(200):
        xy = rng.integers(-400, 400, size=(3, 2)) * cell
        xy += rng.choice([0.0, 1e-15, -1e-15], size=xy.shape)
        samples = FlightSamples(xy, np.zeros((3, 2)), np.zeros((3, 2)), np.zeros((3, 3)))
        maps = unsteadiness_maps(samples, cell=cell, min_count=1)
        assert maps.count.sum() == 3
        np.testing.assert_allclose(np.diff(maps.x_edges), cell, rtol=1e-9)


def test_unsteadiness_of_a_flight_log_with_ukf_wind(tmp_path):
    p = wn.vehicle.params("crazyflie_brushless")
    log = wn.sim.fly(p, wn.sim.Line((0, 0, 1), (4, 0, 1), 6.0),
                     wn.wind.ConstantWind((2.0, 1.0, 0.0)), 6.0, rng=0, log_every=4)
    log.save(tmp_path / "line.npz")
    for source in ("truth", "ukf"):
        _cli("sysid", "unsteadiness", "--log", tmp_path / "line.npz", "--wind", source,
             "--cell", 1.0, "--min-count", 10, "--json", tmp_path / f"{source}.json",
             "--out", tmp_path / source)
        doc = json.loads((tmp_path / f"{source}.json").read_text())
        assert doc["wind_source"] == source
        wx = np.array(doc["wind_mean_x_m_s"], dtype=float)
        wy = np.array(doc["wind_mean_y_m_s"], dtype=float)
        xc = 0.5 * (np.array(doc["x_edges_m"][1:]) + np.array(doc["x_edges_m"][:-1]))
        later = np.isfinite(wx) & (xc[None, :] > 1.0)  # after the filter has converged
        assert later.sum() >= 2
        np.testing.assert_allclose(wx[later], 2.0, atol=0.05)
        np.testing.assert_allclose(wy[later], 1.0, atol=0.05)


def test_a_vehicle_other_than_the_logs_is_noted(tmp_path, capsys):
    # a hummingbird log read as crazyflie_thesis gave a force spread 135 x too small, unflagged
    p = wn.vehicle.params("crazyflie_brushless")
    log = wn.sim.fly(p, wn.sim.Line((0, 0, 1), (4, 0, 1), 2.0),
                     wn.wind.ConstantWind((2.0, 1.0, 0.0)), 2.0, rng=0, log_every=4)
    log.save(tmp_path / "line.npz")
    _cli("sysid", "unsteadiness", "--log", tmp_path / "line.npz", "--vehicle",
         "crazyflie_thesis", "--cell", 1.0, "--min-count", 1, "--out", tmp_path / "o")
    assert "flew 'crazyflie_brushless', not --vehicle 'crazyflie_thesis'" in \
        capsys.readouterr().err


def test_bins_of_one_sample_have_no_spread_and_blanked_bins_are_not_occupied():
    """A failure audit (thirty-eighth session): 44 of 47 bins of one sample each showed a
    force-command spread of 0.0 N (perfectly steady, where the spread is undefined); with
    every bin under min_count the maps were NaN, 'occupied_bins' 47, and status 0."""
    from windnav.sysid.unsteadiness import FlightSamples, unsteadiness_maps

    rng = np.random.default_rng(0)
    n = 50
    samples = FlightSamples(rng.uniform(0, 20, (n, 2)), rng.normal(0, 1, (n, 2)),
                            rng.normal(0, 0.1, (n, 2)), rng.normal(0, 0.5, (n, 3)))
    maps = unsteadiness_maps(samples, cell=1.0, min_count=1)
    ones = maps.count == 1
    assert ones.any() and np.isnan(maps.force_cmd_std[ones]).all()
    assert np.isfinite(maps.force_cmd_std[maps.count >= 2]).all()
    assert maps.to_dict()["occupied_bins"] == int((maps.count >= 1).sum())
    two = unsteadiness_maps(samples, cell=5.0, min_count=2)
    assert two.to_dict()["occupied_bins"] == int((two.count >= 2).sum()) < (two.count > 0).sum()
    with pytest.raises(ValueError, match="'min_count' parameter of unsteadiness_maps must be "
                                         "met by at least one bin"):
        unsteadiness_maps(samples, cell=1.0, min_count=5)
