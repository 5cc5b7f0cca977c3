"""The decoder's error metrics, defined once (thesis ch. 4) and used by every study.

On the free cells of the label grids (outside buildings, inside the solver grid), with the
prediction ``û`` and the truth ``u`` (2-vectors, m/s):

- speed error ``| |û| - |u| |``, m/s;
- direction error ``arccos(clip(û . u / (|û| |u|), -1, 1))``, deg (the thesis's definition).
  Undefined where either vector is zero: such cells (``|û|`` or ``|u|`` below
  :data:`ZERO_SPEED`) are left out of the direction means. The masked variant keeps only cells
  with ``|u| >= min_speed_fraction * inlet speed``, where the direction is well defined;
- vector error ``|û - u|``, m/s.

Each is the mean over all the counted cells of all samples (cells weigh equally, samples with
more free cells weigh more). Per-sample means and cell counts (``per_sample=True``) let callers
pool any subset (a map, an inlet) the same way, with :func:`pooled_errors`.
"""

from __future__ import annotations

import numpy as np

from windnav._validate import _fail as _named_fail
from windnav._validate import _Said, positive_float

ZERO_SPEED = 1e-9
"""Speeds below this (m/s) count as zero vectors, which have no direction."""

METRICS = ("speed_error", "direction_error_deg", "direction_error_masked_deg", "vector_error")
"""The metric names, in report order."""
_COUNTS = {"speed_error": "n_free", "vector_error": "n_free",
           "direction_error_deg": "n_direction",
           "direction_error_masked_deg": "n_direction_masked"}
_CHUNK = 4096  # samples per pass (float64 temporaries of a few hundred MB at most)


def _fail(name: str, where: str, rule: str, got: str) -> ValueError:
    """The package's message (:func:`windnav._validate._fail`) with ``got`` a description."""
    return _named_fail(name, where, rule, _Said(got))


def _fields(pred, true, free, inlet_speed, where):
    pred = np.asarray(pred)
    true = np.asarray(true)
    if true.ndim != 4 or true.shape[1] != 2 or true.shape[2] != true.shape[3]:
        raise _fail("true", where, "an array of shape (B, 2, H, H)", f"shape {true.shape}")
    if pred.shape != true.shape:
        raise _fail("pred", where, f"an array of the shape of 'true' {true.shape}",
                    f"shape {pred.shape}")
    b, _, h, _ = true.shape
    free = np.asarray(free)
    if free.shape != (b, h, h) or free.dtype != bool:
        raise _fail("free", where, f"a boolean array of shape {(b, h, h)}",
                    f"{free.dtype} of shape {free.shape}")
    speed = np.asarray(inlet_speed, dtype=np.float64)
    if speed.ndim == 0:  # one inlet for every sample, as Decoder.predict takes a (2,) w_up
        speed = np.full(b, float(speed))
    if speed.shape != (b,) or not np.all(np.isfinite(speed)) or np.any(speed < 0):
        raise _fail("inlet_speed", where, f"finite speeds >= 0 of shape ({b},), m/s",
                    f"shape {speed.shape}" if speed.shape != (b,) else "a negative or NaN speed")
    for name, arr in (("pred", pred), ("true", true)):
        if not np.all(np.isfinite(arr)):
            raise _fail(name, where, "finite (no NaN or inf)", "non-finite entries")
    return pred, true, free, speed


def _angles(pu, pv, tu, tv):
    """Predicted and true speeds and the angle between the vectors (deg), per cell."""
    sp, st = np.hypot(pu, pv), np.hypot(tu, tv)
    cos = (pu * tu + pv * tv) / np.maximum(sp * st, ZERO_SPEED**2)
    return sp, st, np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def _cell_angles(p, t, f):
    """Per cell: predicted and true speeds, the angle between them (deg), and where the angle
    counts (free, both speeds >= :data:`ZERO_SPEED`); ``p``, ``t`` float64 (B, 2, H, H)."""
    sp, st, angle = _angles(p[:, 0], p[:, 1], t[:, 0], t[:, 1])
    return sp, st, angle, f & (sp >= ZERO_SPEED) & (st >= ZERO_SPEED)


def direction_error_cells(pred, true, *, axis: int = 0) -> np.ndarray:
    """The direction error of each cell (deg), as :func:`field_errors` counts it: NaN where
    either vector is shorter than :data:`ZERO_SPEED` (no direction; left out of its means).

    ``pred`` and ``true`` are ``[u, v]`` fields of one shape, the components along ``axis``
    (m/s); the result has that shape without ``axis``. The figures draw this, so a cell of
    calm air no longer shows as a 90-deg error the metric does not count.
    """
    p = np.moveaxis(np.asarray(pred, dtype=np.float64), axis, 0)
    t = np.moveaxis(np.asarray(true, dtype=np.float64), axis, 0)
    if p.shape != t.shape or p.shape[:1] != (2,):
        raise _fail("pred", "direction_error_cells",
                    f"an array of the shape of 'true' with 2 components along axis {axis}",
                    f"shapes {np.shape(pred)} and {np.shape(true)}")
    sp, st, angle = _angles(p[0], p[1], t[0], t[1])
    return np.where((sp >= ZERO_SPEED) & (st >= ZERO_SPEED), angle, np.nan)


def field_errors(pred, true, free, inlet_speed, *, min_speed_fraction: float = 0.1,
                 per_sample: bool = False) -> dict:
    """Speed, direction and vector errors of predicted local wind fields (see the module doc).

    Parameters
    ----------
    pred, true : array_like of shape (B, 2, H, H)
        Predicted and true ``[u, v]``, m/s, indexed ``[b, :, iy, ix]``.
    free : ndarray of bool, shape (B, H, H)
        Cells that count (outside buildings, inside the solver grid).
    inlet_speed : float or array_like of shape (B,)
        Inlet speed of each sample (a float: the same for every sample), m/s, >= 0 (for the
        masked direction error).
    min_speed_fraction : float
        The masked direction error keeps cells with ``|u| >= min_speed_fraction *
        inlet_speed``, >= 0.
    per_sample : bool
        Also return ``"per_sample"``: each metric's mean per sample, shape (B,) (NaN where a
        sample has no counted cell), and the counts ``"n_free"``, ``"n_direction"``,
        ``"n_direction_masked"`` (B,).

    Returns
    -------
    dict
        ``speed_error`` m/s, ``direction_error_deg`` deg, ``direction_error_masked_deg`` deg,
        ``vector_error`` m/s (floats, NaN when no cell counts), the cell counts ``n_free``,
        ``n_direction``, ``n_direction_masked`` (ints), and ``per_sample`` when asked.

    Raises
    ------
    ValueError
        Naming the argument: mismatched shapes, a non-boolean mask, NaN values or speeds.
    """
    where = "field_errors"
    pred, true, free, speed = _fields(pred, true, free, inlet_speed, where)
    frac = positive_float(min_speed_fraction, "min_speed_fraction", where, allow_zero=True)
    b = true.shape[0]
    sums = {name: np.zeros(b) for name in METRICS}
    counts = {name: np.zeros(b, dtype=np.int64) for name in set(_COUNTS.values())}
    for s in range(0, b, _CHUNK):
        p = pred[s:s + _CHUNK].astype(np.float64)
        t = true[s:s + _CHUNK].astype(np.float64)
        f = free[s:s + _CHUNK]
        sp, st, angle, has_dir = _cell_angles(p, t, f)
        masked = has_dir & (st >= frac * speed[s:s + _CHUNK, None, None])
        axes = (1, 2)
        sums["speed_error"][s:s + _CHUNK] = np.where(f, np.abs(sp - st), 0.0).sum(axes)
        sums["vector_error"][s:s + _CHUNK] = np.where(
            f, np.hypot(p[:, 0] - t[:, 0], p[:, 1] - t[:, 1]), 0.0).sum(axes)
        sums["direction_error_deg"][s:s + _CHUNK] = np.where(has_dir, angle, 0.0).sum(axes)
        sums["direction_error_masked_deg"][s:s + _CHUNK] = np.where(masked, angle, 0.0).sum(axes)
        counts["n_free"][s:s + _CHUNK] = f.sum(axes)
        counts["n_direction"][s:s + _CHUNK] = has_dir.sum(axes)
        counts["n_direction_masked"][s:s + _CHUNK] = masked.sum(axes)
    out = {}
    for name in METRICS:
        n = int(counts[_COUNTS[name]].sum())
        out[name] = float(sums[name].sum() / n) if n else float("nan")
    out.update({name: int(c.sum()) for name, c in counts.items()})
    if per_sample:
        ps = {}
        with np.errstate(invalid="ignore", divide="ignore"):
            for name in METRICS:
                n = counts[_COUNTS[name]]
                ps[name] = np.where(n > 0, sums[name] / np.maximum(n, 1), np.nan)
        ps.update(counts)
        out["per_sample"] = ps
    return out


DIRECTION_SPEED_EDGES = (0.0, 0.1, 0.3, 0.6, 1.0, 1.5, np.inf)
"""Default bins of the true speed over the inlet speed, ``|u| / U``, for
:func:`direction_error_breakdown`."""
DIRECTION_RADIUS_EDGES = (0.0, 3.0, 6.0, 9.0, 12.0, np.inf)
"""Default bins of a cell's distance from the robot (the grid centre), m."""


def _edges(edges, name: str, where: str) -> np.ndarray:
    e = np.asarray(edges, dtype=np.float64)
    if e.ndim != 1 or e.size < 2 or np.isnan(e).any() or e[0] != 0 or np.any(np.diff(e) <= 0):
        raise _fail(name, where, "increasing bin edges starting at 0 (at least two)",
                    repr(edges))
    return e


def direction_error_breakdown(pred, true, free, inlet_speed, offsets, *,
                              speed_edges=DIRECTION_SPEED_EDGES,
                              radius_edges=DIRECTION_RADIUS_EDGES) -> dict:
    """Where the direction error lies: its per-cell angles binned by the true speed relative to
    the inlet, ``|u| / U``, and by the cell's distance from the robot.

    The cells and angles are exactly those of :func:`field_errors`'s ``direction_error_deg``
    (free, both speeds at least :data:`ZERO_SPEED`); with edges that end at ``inf`` (the
    defaults) every such cell is in one bin of each axis, so the counts sum to its
    ``n_direction`` and the contributions to its value.

    Parameters
    ----------
    pred, true : array_like of shape (B, 2, H, H)
        Predicted and true ``[u, v]``, m/s, indexed ``[b, :, iy, ix]``.
    free : ndarray of bool, shape (B, H, H)
        Cells that count.
    inlet_speed : array_like of shape (B,)
        Inlet speed ``U`` of each sample, m/s, > 0.
    offsets : array_like of shape (H,)
        Cell-centre offsets from the robot, m (``Decoder.offsets``), the same for x and y.
    speed_edges, radius_edges : sequence of float
        Increasing bin edges from 0 (the last may be ``inf``); a cell beyond the last edge is
        counted in no bin of that axis but still in the totals.

    Returns
    -------
    dict
        ``speed_edges``, ``radius_edges``; ``sum_deg`` and ``n`` (S, R) arrays over the speed
        and radius bins (cells beyond the last edges in neither); ``direction_error_deg`` (the
        mean over all counted cells) and ``n_direction``; ``by_speed`` and ``by_radius``:
        per bin ``share`` (of the counted cells), ``mean_deg`` (NaN for an empty bin) and
        ``contribution_deg`` (``share * mean_deg``: what the bin adds to the mean).
    """
    where = "direction_error_breakdown"
    pred, true, free, speed = _fields(pred, true, free, inlet_speed, where)
    if np.any(speed <= 0):
        raise _fail("inlet_speed", where, "speeds > 0, m/s", "a zero speed")
    h = true.shape[-1]
    off = np.asarray(offsets, dtype=np.float64)
    if off.shape != (h,) or not np.all(np.isfinite(off)):
        raise _fail("offsets", where, f"finite offsets of shape ({h},), m", f"shape {off.shape}")
    se = _edges(speed_edges, "speed_edges", where)
    re = _edges(radius_edges, "radius_edges", where)
    radius_bin = np.digitize(np.hypot(off[None, :], off[:, None]), re) - 1  # [iy, ix]
    n_s, n_r = se.size - 1, re.size - 1
    sums, counts = np.zeros((n_s, n_r)), np.zeros((n_s, n_r), dtype=np.int64)
    total, n_total = 0.0, 0
    for s in range(0, true.shape[0], _CHUNK):
        t = true[s:s + _CHUNK].astype(np.float64)
        _, st, angle, has_dir = _cell_angles(pred[s:s + _CHUNK].astype(np.float64), t,
                                             free[s:s + _CHUNK])
        total += float(angle[has_dir].sum())
        n_total += int(has_dir.sum())
        speed_bin = np.digitize(st / speed[s:s + _CHUNK, None, None], se) - 1
        rb = np.broadcast_to(radius_bin, speed_bin.shape)
        keep = has_dir & (speed_bin < n_s) & (rb < n_r)
        np.add.at(sums, (speed_bin[keep], rb[keep]), angle[keep])
        np.add.at(counts, (speed_bin[keep], rb[keep]), 1)

    def marginal(s_, n_):
        with np.errstate(invalid="ignore", divide="ignore"):
            mean = np.where(n_ > 0, s_ / np.maximum(n_, 1), np.nan)
        share = n_ / n_total if n_total else np.full(n_.shape, np.nan)
        return {"share": share, "mean_deg": mean,
                "contribution_deg": s_ / n_total if n_total else np.full(n_.shape, np.nan)}

    return {"speed_edges": se, "radius_edges": re, "sum_deg": sums, "n": counts,
            "direction_error_deg": total / n_total if n_total else float("nan"),
            "n_direction": n_total,
            "by_speed": marginal(sums.sum(1), counts.sum(1)),
            "by_radius": marginal(sums.sum(0), counts.sum(0))}


def pooled_errors(per_sample: dict, select=None) -> dict:
    """Pool per-sample errors (``field_errors(..., per_sample=True)["per_sample"]``) over a
    subset of samples exactly as :func:`field_errors` pools all of them.

    Parameters
    ----------
    per_sample : dict
        Per-sample means and counts.
    select : array_like of bool or int, optional
        The samples to pool (a mask or indices); default all.

    Returns
    -------
    dict
        The four metrics (NaN when no cell counts) and the three counts.
    """
    out = {}
    for name in METRICS:
        n = np.asarray(per_sample[_COUNTS[name]])
        mean = np.asarray(per_sample[name], dtype=np.float64)
        if select is not None:
            n, mean = n[select], mean[select]
        total = int(n.sum())
        out[name] = float(np.sum(np.where(n > 0, mean, 0.0) * n) / total) if total else np.nan
    for name in set(_COUNTS.values()):
        n = np.asarray(per_sample[name])
        out[name] = int((n if select is None else n[select]).sum())
    return out


def improvement(model_err, baseline_err):
    """Relative improvement of a model over a baseline: ``1 - model_err / baseline_err``.

    Parameters
    ----------
    model_err : float or array_like
        The model's error, >= 0.
    baseline_err : float or array_like
        The baseline's error, > 0 (same unit).

    Returns
    -------
    float or ndarray
        0.35 means 35 % less error than the baseline; negative when worse.
    """
    where = "improvement"
    m = np.asarray(model_err, dtype=np.float64)
    base = np.asarray(baseline_err, dtype=np.float64)
    if not np.all(np.isfinite(m)) or np.any(m < 0):
        raise _fail("model_err", where, "finite and >= 0", repr(model_err))
    if not np.all(np.isfinite(base)) or np.any(base <= 0):
        raise _fail("baseline_err", where, "finite and > 0", repr(baseline_err))
    out = 1.0 - m / base
    return float(out) if out.ndim == 0 else out


def central_gradients(uv, spacing: float) -> np.ndarray:
    """Wind gradients at the centre cell (the robot) by central differences.

    Parameters
    ----------
    uv : array_like of shape (B, 2, H, H)
        ``[u, v]`` on the label grid, m/s, indexed ``[b, :, iy, ix]``; ``H`` odd, >= 3.
    spacing : float
        Grid spacing, m, > 0.

    Returns
    -------
    ndarray of shape (B, 4)
        ``du/dx, du/dy, dv/dx, dv/dy``, 1/s: e.g. ``du/dx = (u[c, c+1] - u[c, c-1]) /
        (2 spacing)`` with ``c = (H - 1) / 2``. Exact for a field linear in x and y.
    """
    where = "central_gradients"
    uv = np.asarray(uv, dtype=np.float64)
    if uv.ndim != 4 or uv.shape[1] != 2 or uv.shape[2] != uv.shape[3] or uv.shape[2] < 3 \
            or uv.shape[2] % 2 == 0:
        raise _fail("uv", where, "an array of shape (B, 2, H, H) with H odd and >= 3",
                    f"shape {uv.shape}")
    h = positive_float(spacing, "spacing", where)
    c = (uv.shape[2] - 1) // 2
    ddx = (uv[:, :, c, c + 1] - uv[:, :, c, c - 1]) / (2.0 * h)
    ddy = (uv[:, :, c + 1, c] - uv[:, :, c - 1, c]) / (2.0 * h)
    return np.stack([ddx[:, 0], ddy[:, 0], ddx[:, 1], ddy[:, 1]], axis=1)
