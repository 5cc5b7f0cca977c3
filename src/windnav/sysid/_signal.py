"""Signal helpers shared by the fits: derivatives of noisy logs and runs of kept samples."""

from __future__ import annotations

import numpy as np

from windnav._jit import njit
from windnav._validate import positive_float

__all__ = ["local_slope", "min_run", "steepest_slope"]


def _segments(t: np.ndarray) -> list[np.ndarray]:
    """Index runs of ``t`` split at gaps longer than five median steps."""
    if t.size < 2:
        return [np.arange(t.size)]
    step = float(np.median(np.diff(t)))
    breaks = np.flatnonzero(np.diff(t) > 5 * step) + 1
    return np.split(np.arange(t.size), breaks)


@njit(cache=True)
def _segment_slopes(ts, ys, w, before, after, out):
    """:func:`_window_slope` over one segment, each window's sums taken about its own sample
    (``t - t_i``, ``y - y_i``), so that no precision is lost to the size of ``t`` or ``y``."""
    n = ts.size
    for i in range(n):
        if w[i] == 0.0:
            out[i] = np.nan
            continue
        k = st = sy = sty = stt = 0.0
        for j in range(max(i - before, 0), min(i + after + 1, n)):
            if w[j] == 0.0:
                continue
            d, e = ts[j] - ts[i], ys[j] - ys[i]
            k += 1.0
            st += d
            sy += e
            sty += d * e
            stt += d * d
        den = k * stt - st * st
        ok = k > 1.0 and den > 1e-12 * max(stt * k, 1e-300)
        out[i] = (k * sty - st * sy) / den if ok else 0.0


def _window_slope(t: np.ndarray, y: np.ndarray, before: int, after: int) -> np.ndarray:
    """Slope of the least-squares line over samples ``i - before ... i + after`` (clipped to
    each segment), for every sample ``i``; 0 where the window holds one sample. A non-finite
    ``y`` is left out of its neighbours' windows and gets NaN itself (the running sums carried
    one NaN into every later slope of its segment: a blanked speed dropped the real power log's
    fit from 1,045 to 556 points; audit, 2026-12-05). Each window's sums are taken about its own
    sample: the running sums over the whole segment this replaced lost the slope to
    cancellation on long logs (a 60-min 100 Hz log of a steady 1,500 rad/s: 1,410 rad/s^2
    where the slopes are about 49; reference audit, 2026-12-05)."""
    t = np.ascontiguousarray(t, dtype=np.float64)
    y = np.ascontiguousarray(y, dtype=np.float64)
    out = np.zeros_like(y)
    for seg in _segments(t):
        if seg.size < 2:
            continue
        ys = y[seg]
        w = np.isfinite(ys).astype(np.float64)
        res = np.empty(seg.size)
        _segment_slopes(t[seg], np.where(w > 0, ys, 0.0), w, int(before), int(after), res)
        out[seg] = res
    return out


def _half_width(t: np.ndarray, window_s: float) -> int:
    step = float(np.median(np.diff(t))) if t.size > 1 else 0.0
    return max(1, int(round(0.5 * window_s / step))) if step > 0 else 1


def local_slope(t, y, window_s: float) -> np.ndarray:
    """``dy/dt`` as the slope of a least-squares line over each sample's centred window.

    Parameters
    ----------
    t : ndarray of shape (n,)
        Increasing times, s.
    y : ndarray of shape (n,)
        The signal.
    window_s : float
        Window width, s (at least one sample each side).

    Returns
    -------
    ndarray of shape (n,)
        The slope, in units of ``y`` per second. A gap longer than five median steps starts a
        new segment (windows never span it); a segment of one sample gets 0.
    """
    t = np.asarray(t, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    if t.size < 2:
        return np.zeros_like(y)
    h = _half_width(t, window_s)
    return _window_slope(t, y, h, h)


def steepest_slope(t, y, window_s: float) -> np.ndarray:
    """``dy/dt`` as the steeper of the two one-sided slopes, over the half-windows that end
    and that start at each sample (``window_s / 2`` each, least-squares lines).

    A centred window averages a step with the flat samples before it, so the first samples
    after a step in the command pass for steady; the one-sided slope after them does not.
    Same arguments and segments as :func:`local_slope`.
    """
    t = np.asarray(t, dtype=np.float64)
    y = np.asarray(y, dtype=np.float64)
    if t.ndim != 1 or y.shape != t.shape:  # an IndexError or a broadcast error before
        raise ValueError(f"The times and values of steepest_slope must be 1-D arrays of one "
                         f"length. Got shapes {t.shape} and {y.shape} instead.")
    window_s = positive_float(window_s, "window_s", "steepest_slope")  # 0 and < 0 passed
    if t.size < 2:
        return np.zeros_like(y)
    h = _half_width(t, window_s)
    left, right = _window_slope(t, y, h, 0), _window_slope(t, y, 0, h)
    return np.where(np.abs(left) >= np.abs(right), left, right)


def min_run(t, mask, min_s: float) -> np.ndarray:
    """``mask`` with the runs of True shorter than ``min_s`` seconds removed (a gap in ``t``
    longer than five median steps ends a run)."""
    t = np.asarray(t, dtype=np.float64)
    mask = np.asarray(mask, dtype=bool).copy()
    for seg in _segments(t):
        m = mask[seg]
        edges = np.flatnonzero(np.diff(np.r_[0, m.astype(np.int8), 0]))
        for a, b in zip(edges[::2], edges[1::2], strict=True):
            if t[seg[b - 1]] - t[seg[a]] < min_s:
                mask[seg[a:b]] = False
    return mask
