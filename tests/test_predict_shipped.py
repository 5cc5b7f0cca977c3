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


def test_a_scan_from_inside_a_building_is_warned():
    """``City.lidar`` reads 0 m on every ray on or inside a building; the decoder returned a
    field for it (1.2 m/s of mean speed in the API audit) without a word."""
    import warnings

    dec = wn.predict.load_decoder()
    scans = np.full((3, 360), 30.0)
    scans[1] = 0.0
    with pytest.warns(RuntimeWarning, match=r"1 of 3 scans read 0 m on every ray \(first: row 1\)"):
        dec.predict(scans, [4.0, 1.0], [3.0, 0.5])
    scans[1, 7] = 0.3  # one return: a robot beside a wall, not in it
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        dec.predict(scans, [4.0, 1.0], [3.0, 0.5])
