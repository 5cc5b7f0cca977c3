"""GriddedWind: bilinear in space on cell centres, linear in time, clamped, checked against
closed forms (bilinear functions are reproduced exactly) and SciPy's RegularGridInterpolator."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import RegularGridInterpolator

from windnav.wind import GriddedWind

X = np.linspace(0.5, 19.5, 20)  # cell centres of a 1 m grid
Y = np.linspace(0.5, 11.5, 12)
XX, YY = np.meshgrid(X, Y)  # (ny, nx)


def _bilinear(x, y, c):
    return c[0] + c[1] * x + c[2] * y + c[3] * x * y


def _points(n, lo=(0.5, 0.5), hi=(19.5, 11.5), seed=0):
    rng = np.random.default_rng(seed)
    xy = rng.uniform(lo, hi, (n, 2))
    return np.column_stack([xy, rng.uniform(0, 30, n)])


def test_bilinear_functions_are_reproduced_exactly():
    cu, cv = (1.0, 0.3, -0.2, 0.05), (-2.0, 0.1, 0.4, -0.03)
    field = GriddedWind(X, Y, _bilinear(XX, YY, cu), _bilinear(XX, YY, cv))
    p = _points(1000)
    w = field.velocity(3.0, p)
    np.testing.assert_allclose(w[:, 0], _bilinear(p[:, 0], p[:, 1], cu), atol=1e-12)
    np.testing.assert_allclose(w[:, 1], _bilinear(p[:, 0], p[:, 1], cv), atol=1e-12)
    np.testing.assert_array_equal(w[:, 2], 0.0)


def test_nonuniform_grid_reproduces_bilinear_functions():
    x = np.cumsum(np.random.default_rng(1).uniform(0.2, 2.0, 15))
    y = np.cumsum(np.random.default_rng(2).uniform(0.2, 2.0, 9))
    gx, gy = np.meshgrid(x, y)
    c = (0.5, -0.2, 0.7, 0.1)
    field = GriddedWind(x, y, _bilinear(gx, gy, c), np.zeros_like(gx))
    p = _points(500, lo=(x[0], y[0]), hi=(x[-1], y[-1]), seed=3)
    np.testing.assert_allclose(field.velocity(0.0, p)[:, 0], _bilinear(p[:, 0], p[:, 1], c),
                               atol=1e-11)


def test_agrees_with_scipy_regular_grid_interpolator():
    rng = np.random.default_rng(4)
    u, v = rng.normal(size=(2, Y.size, X.size))
    field = GriddedWind(X, Y, u, v)
    p = _points(1000, seed=5)
    for comp, arr in ((0, u), (1, v)):
        ref = RegularGridInterpolator((Y, X), arr, method="linear")(p[:, [1, 0]])
        np.testing.assert_allclose(field.velocity(0.0, p)[:, comp], ref, atol=1e-12)


def test_values_at_cell_centres_and_clamping_at_edges():
    rng = np.random.default_rng(6)
    u, v = rng.normal(size=(2, Y.size, X.size))
    field = GriddedWind(X, Y, u, v)
    centres = np.column_stack([XX.ravel(), YY.ravel(), np.ones(XX.size)])
    w = field.velocity(0.0, centres)
    np.testing.assert_allclose(w[:, 0], u.ravel(), atol=1e-14)
    np.testing.assert_allclose(w[:, 1], v.ravel(), atol=1e-14)
    outside = np.array([[-100.0, 5.0, 0.0], [1e3, -1e3, 0.0], [7.3, 50.0, 0.0]])
    clamped = np.array([[X[0], 5.0, 0.0], [X[-1], Y[0], 0.0], [7.3, Y[-1], 0.0]])
    np.testing.assert_allclose(field.velocity(0.0, outside), field.velocity(0.0, clamped))


def test_linear_in_time_and_clamped_outside_frames():
    t = np.array([1.0, 2.0, 4.0])
    base = _bilinear(XX, YY, (1.0, 0.2, 0.1, 0.0))
    u = np.stack([base * (1 + tk) for tk in t])  # linear in t
    v = np.stack([np.full_like(base, tk) for tk in t])
    field = GriddedWind(X, Y, u, v, t=t)
    p = _points(50, seed=7)
    b = _bilinear(p[:, 0], p[:, 1], (1.0, 0.2, 0.1, 0.0))
    for tq in (1.0, 1.3, 2.0, 3.1, 4.0):
        w = field.velocity(tq, p)
        np.testing.assert_allclose(w[:, 0], b * (1 + tq), atol=1e-12)
        np.testing.assert_allclose(w[:, 1], tq, atol=1e-12)
    np.testing.assert_array_equal(field.velocity(-5.0, p), field.velocity(1.0, p))
    np.testing.assert_array_equal(field.velocity(99.0, p), field.velocity(4.0, p))
    # time order does not matter for a stored field
    np.testing.assert_array_equal(field.velocity(3.1, p), field.velocity(3.1, p))


def test_is_solid_uses_nearest_cell():
    solid = np.zeros(XX.shape, dtype=bool)
    solid[3:5, 6:9] = True  # x in [6, 9), y in [3, 5)
    field = GriddedWind(X, Y, np.zeros(XX.shape), np.zeros(XX.shape), solid=solid)
    q = np.array([[7.0, 4.0, 0.0], [6.01, 3.01, 0.0], [5.99, 4.0, 0.0], [7.0, 5.01, 0.0],
                  [-3.0, 4.0, 0.0]])
    np.testing.assert_array_equal(field.is_solid(q), [True, True, False, False, False])
    assert not GriddedWind(X, Y, np.zeros(XX.shape), np.zeros(XX.shape)).is_solid(q).any()


@pytest.mark.parametrize(
    "kwargs, name",
    [
        ({"x": X[::-1]}, "x"),
        ({"x": X[:1]}, "x"),
        ({"y": np.full(Y.size, 1.0)}, "y"),
        ({"u": np.zeros((3, 3))}, "u"),
        ({"v": np.zeros((Y.size, X.size + 1))}, "v"),
        ({"u": np.full(XX.shape, np.nan)}, "u"),
        ({"v": np.where(XX > 0.5, np.inf, 0.0)}, "v"),
        ({"u": np.stack([np.zeros(XX.shape), np.where(XX > 0.5, -np.inf, 0.0)]),
          "v": np.zeros((2, *XX.shape)), "t": [0.0, 1.0]}, "u"),
        ({"t": [0.0]}, "t"),
        ({"u": np.zeros((2, *XX.shape)), "v": np.zeros((2, *XX.shape))}, "t"),
        ({"u": np.zeros((2, *XX.shape)), "v": np.zeros((2, *XX.shape)), "t": [1.0, 1.0]}, "t"),
        ({"u": np.zeros((2, *XX.shape)), "v": np.zeros((2, *XX.shape)), "t": [0.0]}, "t"),
        ({"solid": np.zeros((2, 2), dtype=bool)}, "solid"),
    ],
)
def test_bad_inputs_raise_naming_them(kwargs, name):
    args = {"x": X, "y": Y, "u": np.zeros(XX.shape), "v": np.zeros(XX.shape)} | kwargs
    with pytest.raises(ValueError, match=f"'{name}'"):
        GriddedWind(**args)
