"""One conformance suite over every WindField (STYLE principle 9)."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from windnav.wind import ConstantWind, DrydenWind, FromRotorPy, GriddedWind, WindField


def _grid_fields(unsteady: bool):
    x = np.linspace(-5.0, 15.0, 21)
    y = np.linspace(-3.0, 9.0, 13)
    rng = np.random.default_rng(7)
    shape = (3, y.size, x.size) if unsteady else (y.size, x.size)
    u = rng.normal(3.0, 1.0, shape)
    v = rng.normal(0.0, 1.0, shape)
    return GriddedWind(x, y, u, v, t=np.array([0.0, 0.4, 1.0]) if unsteady else None)


def _rotorpy_gusts():
    from rotorpy.wind.dryden_winds import DrydenGust

    gust = DrydenGust(dt=0.01, avg_wind=np.array([2.0, 0.0, 0.0]), sig_wind=np.full(3, 40.0))
    return FromRotorPy(gust, dt=0.01, seed=5)


FACTORIES = {
    "constant": lambda: ConstantWind((2.0, 1.0, 0.0)),
    "dryden": lambda: DrydenWind(mean=(3, 0, 0), sigma=(1.5, 1.5, 0.7), seed=3),
    "dryden_short_scales": lambda: DrydenWind(seed=4, length_scales=(5.0, 3.0, 1.0)),
    "gridded_steady": lambda: _grid_fields(False),
    "gridded_unsteady": lambda: _grid_fields(True),
    "rotorpy_gusts": _rotorpy_gusts,
}
TIMES = (0.0, 0.013, 0.25, 0.7, 1.3)


@pytest.fixture(params=sorted(FACTORIES))
def factory(request):
    return FACTORIES[request.param]


def _positions(n: int, seed: int = 0) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return rng.uniform([-8.0, -6.0, 0.0], [18.0, 12.0, 20.0], (n, 3))


def test_is_a_wind_field(factory):
    assert isinstance(factory(), WindField)


@pytest.mark.parametrize("n", [1, 7, 1000])
def test_returns_finite_float64_batch(factory, n):
    field = factory()
    for t in TIMES:
        w = field.velocity(t, _positions(n))
        assert w.shape == (n, 3)
        assert w.dtype == np.float64
        assert np.all(np.isfinite(w))


def test_single_position_is_a_batch_of_one(factory):
    field = factory()
    p = _positions(1)
    np.testing.assert_array_equal(field.velocity(0.1, p[0]), field.velocity(0.1, p))


def test_batch_of_one_equals_row_of_batch(factory):
    field = factory()
    xyz = _positions(9, seed=1)
    for t in TIMES:
        batch = field.velocity(t, xyz)
        for k in range(xyz.shape[0]):
            np.testing.assert_array_equal(field.velocity(t, xyz[k : k + 1])[0], batch[k])


def test_deterministic_under_seed(factory):
    a, b = factory(), factory()
    for t in TIMES:
        xyz = _positions(5, seed=int(100 * t))
        np.testing.assert_array_equal(a.velocity(t, xyz), b.velocity(t, xyz))


def test_output_is_not_a_view_of_internal_state(factory):
    field = factory()
    xyz = _positions(3)
    first = field.velocity(0.2, xyz)
    expected = first.copy()
    first[:] = 1e9
    np.testing.assert_array_equal(field.velocity(0.2, xyz), expected)
    np.testing.assert_array_equal(xyz, _positions(3))  # input untouched


@pytest.mark.parametrize(
    "xyz",
    [np.zeros((4, 2)), np.zeros((2, 3, 1)), np.zeros(4), [[0.0, np.nan, 1.0]], [[np.inf, 0, 0]]],
    ids=["B-by-2", "3d", "len-4", "nan", "inf"],
)
def test_bad_positions_raise_naming_xyz(factory, xyz):
    with pytest.raises(ValueError, match="'xyz'"):
        factory().velocity(0.0, xyz)


@pytest.mark.parametrize("t", [np.nan, np.inf, "soon", None])
def test_bad_time_raises_naming_t(factory, t):
    with pytest.raises(ValueError, match="'t'"):
        factory().velocity(t, np.zeros((1, 3)))


_finite = st.floats(-50.0, 50.0, allow_nan=False, allow_infinity=False)


@settings(max_examples=60, deadline=None)
@given(rows=st.lists(st.tuples(_finite, _finite, _finite), min_size=1, max_size=20),
       t=st.floats(-2.0, 3.0, allow_nan=False))
def test_stateless_fields_batch_equals_one_by_one(rows, t):
    xyz = np.array(rows)
    for field in (FACTORIES["constant"](), GRIDDED_STEADY, GRIDDED_UNSTEADY):
        batch = field.velocity(t, xyz)
        single = np.vstack([field.velocity(t, row) for row in xyz])
        np.testing.assert_array_equal(batch, single)
        assert np.all(batch[:, 2] == 0) or isinstance(field, ConstantWind)


GRIDDED_STEADY = _grid_fields(False)
GRIDDED_UNSTEADY = _grid_fields(True)
