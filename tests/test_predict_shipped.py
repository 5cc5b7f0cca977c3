"""The shipped default decoder: it loads without torch and keeps the public contract."""

import subprocess
import sys

import numpy as np
import pytest

import windnav as wn
from windnav.city import training_map


def test_shipped_decoder_loads_without_torch():
    code = ("import sys, windnav as wn; d = wn.predict.load_decoder(); "
            "assert 'torch' not in sys.modules; print(d.size)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "25"


def test_shipped_decoder_contract_and_scaling():
    dec = wn.predict.load_decoder()
    assert dec.offsets.shape == (25,)
    np.testing.assert_allclose(dec.offsets, np.arange(-12.0, 13.0))
    city = training_map(rng=3, size=300.0)
    scans = city.lidar(np.array([[40.0, 40.0], [150.0, 20.0], [260.0, 280.0]]),
                       min_range=0.25)
    w_up = np.array([[5.0, 1.0], [-3.0, 2.0], [0.0, -7.0]])
    w_robot = np.array([[4.0, 0.5], [-2.0, 2.5], [1.0, -6.0]])
    uv = dec.predict(scans, w_up, w_robot)
    assert uv.shape == (3, 2, 25, 25) and np.all(np.isfinite(uv))
    # the residual on Local is scaled by |W_up|: doubling both winds doubles the field
    np.testing.assert_allclose(dec.predict(scans, 2 * w_up, 2 * w_robot), 2 * uv, rtol=1e-4,
                               atol=1e-4)
    with pytest.raises(ValueError, match="scans"):
        dec.predict(scans[:, :359], w_up, w_robot)


def test_a_scan_of_a_shorter_range_lidar_is_warned():
    """A LiDAR whose misses read its own maximum range (30 m) gave a field without a word; the
    decoder, trained on misses at 100 m, reads those rays as walls at 30 m. Its scans tie at
    their largest range; City.lidar's 100 m scans, with or without noise, and scans beyond 100 m
    do not warn."""
    import warnings

    from windnav.city import City

    city = City((0.0, 200.0, 0.0, 200.0), np.array([[60.0, 80.0, 90.0, 120.0],
                                                     [120.0, 140.0, 40.0, 70.0]]),
                np.array([20.0, 20.0]))
    at = np.array([[100.0, 100.0], [40.0, 150.0]])
    dec = wn.predict.load_decoder()
    w_up, w_rob = [4.0, 1.0], [3.0, 0.5]
    rng = np.random.default_rng(0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        for noise in (0.0, 0.35):
            dec.predict(city.lidar(at, max_range=100.0, noise_std=noise, rng=rng), w_up, w_rob)
        dec.predict(city.lidar(at, max_range=150.0), w_up, w_rob)  # clipped to 100 m inside
        dec.predict(rng.uniform(1.0, 99.0, (2, 360)), w_up, w_rob)  # no miss, no ties
    for noise in (0.0, 0.35):
        short = city.lidar(at, max_range=30.0, noise_std=noise, rng=rng)
        with pytest.warns(RuntimeWarning, match=r"2 of 2 scans have 3 or more rays at exactly "
                                                r"their largest range, under the decoder's 100 m "
                                                r"\(first: row 0, \d+ rays at 30 m\)"):
            dec.predict(short, w_up, w_rob)
    # a scan inside a building is warned once, as such, not as a short range: 0 m on every
    # ray, or the 0.25 m least range where the scan is clipped (the onboard stack's)
    inside = city.lidar([[70.0, 100.0]], min_range=0.25, noise_std=0.35, rng=rng)
    for scan in (np.zeros((1, 360)), inside):
        with pytest.warns(RuntimeWarning) as caught:
            dec.predict(scan, w_up, w_rob)
        assert len(caught) == 1 and "0.25 m least range" in str(caught[0].message)
    # the threshold (3 rays), the first flagged row of a mixed batch and its own numbers
    open_square = np.full((1, 360), 100.0)
    mixed = np.vstack([open_square, rng.uniform(1.0, 25.0, (2, 360))])
    mixed[1, :2] = mixed[2, :3] = 30.0
    with pytest.warns(RuntimeWarning, match=r"Decoder.predict: 1 of 3 scans .* \(first: row 2, "
                                            r"3 rays at 30 m\)") as caught:
        dec.predict(mixed, w_up, w_rob)
    assert len(caught) == 1 and caught[0].filename == __file__  # the caller's line
    # the turned views read the same scans: warned too, once
    views = wn.predict.load_decoder(rotations_deg=(0, -3, 3))
    with pytest.warns(RuntimeWarning, match="first: row 2, 3 rays at 30 m") as caught:
        views.predict(mixed, w_up, w_rob)
    assert len(caught) == 1 and caught[0].filename == __file__


def test_a_scan_from_inside_a_building_is_warned():
    """``City.lidar`` reads 0 m on every ray on or inside a building; the decoder returned a
    field for it (1.2 m/s of mean speed in the API audit) without a word."""
    import warnings

    dec = wn.predict.load_decoder()
    scans = np.full((3, 360), 100.0)  # an open square: every ray a miss at the 100 m range
    scans[1] = 0.0
    with pytest.warns(RuntimeWarning, match=r"1 of 3 scans read 0 m on every ray, or no more "
                                            r"than the 0.25 m least range \(first: row 1\)"):
        dec.predict(scans, [4.0, 1.0], [3.0, 0.5])
    scans[1, 7] = 0.3  # one return: a robot beside a wall, not in it
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        dec.predict(scans, [4.0, 1.0], [3.0, 0.5])
