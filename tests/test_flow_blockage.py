"""The blockage of a cross-section across the wind (``windnav.flow.validity.blockage``): the
closed form for a block in a rectangle, and continuity through the solver's most blocked
column, where the mean wind is the inlet's over the open share."""

from __future__ import annotations

import numpy as np
import pytest

from windnav.city import City
from windnav.experiments.navigate import simulate_flow
from windnav.flow.validity import blockage

# 100 m x 60 m; one block 10 m along x, 30 m across, against the south side
CITY = City((0.0, 100.0, 0.0, 60.0), np.array([[40.0, 50.0, 0.0, 30.0]]), np.array([20.0]))


def test_a_block_closes_its_share_of_each_cross_section():
    assert blockage(CITY, 0.0) == pytest.approx(30.0 / 60.0)    # a column: 30 of 60 m
    assert blockage(CITY, 90.0) == pytest.approx(10.0 / 100.0)  # a row: 10 of 100 m
    assert blockage(CITY, 180.0) == blockage(CITY, 0.0)         # a wind and its opposite
    both = blockage(CITY, [0.0, 90.0, 45.0])
    assert both.shape == (3,) and both[:2] == pytest.approx([0.5, 0.1])
    assert 0.1 < both[2] < 0.5                                  # across the diagonal
    empty = City((0.0, 50.0, 0.0, 50.0), np.zeros((0, 4)), np.zeros(0))
    assert blockage(empty, 30.0) == 0.0
    wall = City((0.0, 100.0, 0.0, 60.0), np.array([[40.0, 50.0, 0.0, 60.0]]), np.array([9.0]))
    assert blockage(wall, 0.0) == 1.0 and blockage(wall, 90.0) == pytest.approx(0.1)
    assert blockage(wall, np.float64(0.0)) == 1.0 and blockage(wall, [[0.0]]).shape == (1, 1)
    for bad, name in (({"direction_deg": np.nan}, "direction_deg"), ({"dx": 0.0}, "dx"),
                      ({"direction_deg": "north"}, "direction_deg")):
        with pytest.raises(ValueError, match=f"'{name}' parameter of blockage"):
            blockage(CITY, **{"direction_deg": 0.0, **bad})


def test_the_solver_carries_the_inlet_flux_through_the_most_blocked_column():
    """Continuity, the reference no one here wrote: along an axis the map's sides carry no
    flux, so every column carries the inlet's, and the mean wind over the open cells of the
    most blocked one is ``U / (1 - b)``."""
    speed = 3.0
    flow = simulate_flow(CITY, speed, 0.0, spinup_s=5.0, record_s=5.0)
    u = np.where(flow.solid, 0.0, flow.mean_u)
    flux = u.sum(axis=0) * flow.dx
    np.testing.assert_allclose(flux, speed * 60.0, rtol=1e-9)
    open_cells = (~flow.solid).sum(axis=0)
    k = int(np.argmin(open_cells))
    b = blockage(CITY, 0.0)
    assert 1.0 - open_cells[k] / flow.solid.shape[0] == pytest.approx(b)
    assert u[:, k].sum() / open_cells[k] == pytest.approx(speed / (1.0 - b), rel=1e-9)
    assert u[:, k].sum() / open_cells[k] > 1.9 * speed      # not the inlet's: twice it
