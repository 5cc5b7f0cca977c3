"""``benchmarks/decoder_divergence.py``: the block divergence, checked on fields whose
divergence is known in closed form, and the smoothing towards divergence-free fields."""

from __future__ import annotations

import numpy as np
import pytest
from _scripts import load_script


@pytest.fixture(scope="module")
def mod():
    return load_script("benchmarks/decoder_divergence.py")


def linear_field(size, spacing, a, b, c, d):
    """u = a x + b y, v = c x + d y at the cell centres, ``(1, 2, size, size)``: divergence
    a + d everywhere, exactly, for any centred difference."""
    y, x = np.meshgrid(np.arange(size) * spacing, np.arange(size) * spacing, indexing="ij")
    return np.stack([a * x + b * y, c * x + d * y])[None]


@pytest.mark.parametrize("spacing", [1.0, 0.5])
def test_block_divergence_of_linear_fields(mod, spacing):
    size = 7
    div = mod.block_divergence(size, spacing)
    assert div.shape == ((size - 1) ** 2, 2 * size * size)
    for a, b, c, d in [(1.0, 0.0, 0.0, 1.0), (0.3, -2.0, 1.5, 0.7), (1.0, 2.0, -3.0, -1.0)]:
        f = linear_field(size, spacing, a, b, c, d).reshape(1, -1)
        np.testing.assert_allclose(div @ f[0], a + d, atol=1e-12)


def test_block_divergence_against_numpy_gradient(mod):
    """A smooth field: the block values are the cell-centre divergence (np.gradient's central
    differences) averaged over the block's four cells, to second order in the spacing."""
    size, h = 25, 0.05
    y, x = np.meshgrid(np.arange(size) * h, np.arange(size) * h, indexing="ij")
    u, v = np.sin(x) * np.cos(2 * y), np.exp(0.5 * x) * y ** 2
    exact = np.cos(x) * np.cos(2 * y) + 2 * np.exp(0.5 * x) * y
    block = (mod.block_divergence(size, h) @ np.concatenate([u.ravel(), v.ravel()]))
    centre = 0.25 * (exact[:-1, :-1] + exact[1:, :-1] + exact[:-1, 1:] + exact[1:, 1:])
    np.testing.assert_allclose(block.reshape(size - 1, size - 1), centre, atol=5 * h ** 2)


def test_free_blocks(mod):
    free = np.ones((1, 4, 4), dtype=bool)
    free[0, 1, 2] = False  # one wall cell: the four blocks that hold it are not counted
    blocks = mod.free_blocks(free).reshape(3, 3)
    expected = np.ones((3, 3), dtype=bool)
    expected[0:2, 1:3] = False
    np.testing.assert_array_equal(blocks, expected)


def test_smoothing_keeps_divergence_free_fields_and_removes_divergence(mod):
    size = 9
    div = mod.block_divergence(size)
    free = np.ones((2, size, size), dtype=bool)
    free[1, 3:5, 3:6] = False
    blocks = mod.free_blocks(free)
    solenoidal = np.concatenate([linear_field(size, 1.0, 0.4, 1.0, -2.0, -0.4)] * 2)
    for mu in (1.0, 100.0):
        f = mod.global_filter(div, mu)
        out = solenoidal.reshape(2, -1) @ f.T
        np.testing.assert_allclose(out, solenoidal.reshape(2, -1), atol=1e-9)
        np.testing.assert_allclose(mod.masked_projection(solenoidal, blocks, div, mu),
                                   solenoidal, atol=1e-5)
    rng = np.random.default_rng(0)
    noisy = rng.normal(size=(2, 2, size, size)).astype(np.float32)
    speed = np.ones(2)
    before = mod.divergence_rms(noisy, blocks, speed, div, 1.0)
    after = mod.divergence_rms(mod.masked_projection(noisy, blocks, div, 1e4), blocks, speed,
                               div, 1.0)
    assert after < 1e-3 * before
    # the divergence is counted on the free blocks only: a field diverging only inside the
    # building of sample 1 has none there
    inside = np.zeros((1, 2, size, size))
    inside[0, 0, 4, 4] = 1.0
    assert mod.divergence_rms(inside, blocks[1:], speed[:1], div, 1.0) == 0.0
    assert mod.divergence_rms(inside, blocks[:1], speed[:1], div, 1.0) > 0.0
