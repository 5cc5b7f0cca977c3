"""Reuse across wind runs: caller-owned frame memory and factorisations change no value."""

from __future__ import annotations

import gc

import numpy as np

from windnav.city import City
from windnav.flow import FactorCache, FrameBuffers, simulate
from windnav.flow.solver import _centres_into, _to_centres, _to_centres_recording


def _city():
    fp = [[10.0, 16.0, 8.0, 14.0], [24.0, 30.0, 0.0, 6.0], [30.0, 36.0, 16.0, 22.0]]
    return City((0.0, 48.0, 0.0, 30.0), fp, np.full(len(fp), 10.0))


def _run(city, speed, direction, **kw):
    return simulate(city, speed, direction, dx=1.0, dt=0.25, spinup_steps=4, steps=12,
                    record_every=1, **kw)


def _same(a, b):
    """Bitwise: equal values and equal signs of zero."""
    return np.array_equal(a, b) and np.array_equal(np.signbit(a), np.signbit(b))


def test_frames_written_whole_equal_the_accumulated_frames_bitwise_signed_zeros_included():
    rng = np.random.default_rng(0)
    ny, nx = 7, 9
    u, v = rng.standard_normal((ny, nx + 1)), rng.standard_normal((ny + 1, nx))
    u[2, 3] = u[2, 4] = -0.0  # a -0.0 sum: the accumulation into zeros gives +0.0
    solid = rng.random((ny, nx)) < 0.3
    ref_u, ref_v = np.zeros((ny, nx)), np.zeros((ny, nx))
    _to_centres(u, v, solid, ref_u, ref_v, 1.0)
    out_u, out_v = np.full((ny, nx), np.nan), np.full((ny, nx), np.nan)  # stale contents
    _centres_into(u, v, solid, out_u, out_v)
    assert _same(out_u, ref_u) and _same(out_v, ref_v)
    assert not np.signbit(out_u[2, 3])


def test_the_one_pass_accumulate_and_record_is_the_two_kernels_bitwise():
    rng = np.random.default_rng(1)
    ny, nx = 8, 11
    u, v = rng.standard_normal((ny, nx + 1)), rng.standard_normal((ny + 1, nx))
    u[2, 3] = u[2, 4] = -0.0
    solid = rng.random((ny, nx)) < 0.3
    mean_u, mean_v = rng.standard_normal((2, ny, nx))
    ref_mu, ref_mv = mean_u.copy(), mean_v.copy()
    _to_centres(u, v, solid, ref_mu, ref_mv, 1.0 / 3.0)
    ref_fu, ref_fv = np.empty((ny, nx)), np.empty((ny, nx))
    _centres_into(u, v, solid, ref_fu, ref_fv)
    fu, fv = np.full((ny, nx), np.nan), np.full((ny, nx), np.nan)
    _to_centres_recording(u, v, solid, mean_u, mean_v, 1.0 / 3.0, fu, fv)
    for got, ref in ((mean_u, ref_mu), (mean_v, ref_mv), (fu, ref_fu), (fv, ref_fv)):
        assert _same(got, ref)


def test_a_block_is_handed_out_again_only_once_nothing_refers_to_it():
    pool = FrameBuffers()
    a = pool.take((3, 4, 5, 2))
    view = a[..., 0]
    del a
    b = pool.take((3, 4, 5, 2))  # a view of the first block lives on: a new block
    assert len(pool) == 2 and not np.shares_memory(b, view)
    address = view.__array_interface__["data"][0]
    del view
    c = pool.take((3, 4, 5, 2))  # the first block is free again
    assert c.__array_interface__["data"][0] == address and not np.shares_memory(b, c)
    del b, c
    d = pool.take((2, 4, 5, 2))  # another size: the free blocks of the old one are dropped
    assert len(pool) == 1 and d.shape == (2, 4, 5, 2)


def test_a_block_held_only_by_a_reference_cycle_is_reused_after_collection():
    pool = FrameBuffers()

    class Holder:
        pass

    h = Holder()
    h.me, h.frames = h, pool.take((2, 3, 3, 2))
    address = h.frames.__array_interface__["data"][0]
    del h
    gc.disable()
    try:
        again = pool.take((2, 3, 3, 2))
    finally:
        gc.enable()
    assert again.__array_interface__["data"][0] == address and len(pool) == 1


def test_reused_frames_and_factors_give_the_fresh_runs_bitwise():
    """Three winds in a row through one pool and one cache (the second and third share inlet
    sides, so one factorisation) equal three fresh runs, frame by frame and in the mean."""
    city = _city()
    factors, frames = FactorCache(maxsize=2), FrameBuffers()
    address = None
    for speed, direction in [(5.0, 0.0), (2.0, 30.0), (7.0, 45.0)]:
        fresh = _run(city, speed, direction)
        reused = _run(city, speed, direction, factor_cache=factors, frame_buffers=frames)
        for name in ("frames_u", "frames_v", "mean_u", "mean_v"):
            assert _same(getattr(reused, name), getattr(fresh, name)), (speed, direction, name)
        field = reused.wind_field(unsteady=True)  # adopts the pool's block, no copy
        assert np.shares_memory(field.u, reused.frames_u)
        del field
        here = reused.frames_u.__array_interface__["data"][0]
        if address is not None:
            assert here == address  # the previous wind's memory, not new memory
        address = here
        del fresh, reused
    assert len(factors) == 2 and len(frames) == 1  # 0 deg; 30 and 45 deg share their sides


def test_a_live_solution_keeps_its_frames():
    city = _city()
    frames = FrameBuffers()
    first = _run(city, 5.0, 0.0, frame_buffers=frames)
    kept = first.frames_u.copy()
    second = _run(city, 7.0, 30.0, frame_buffers=frames)
    assert not np.shares_memory(first.frames_u, second.frames_u)
    assert np.array_equal(first.frames_u, kept)
