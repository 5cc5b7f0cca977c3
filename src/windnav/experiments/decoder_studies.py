"""Studies of the wind flow decoder (issue 9, "Studies, each one command, each writing a figure").

Each study is a function returning a results dict; ``windnav decoder-study`` runs one and draws
its figure (:mod:`windnav.viz.decoder`). The metrics are :mod:`windnav.predict.metrics`'s and
the samples :func:`windnav.predict.draw_samples`'s, never re-implemented here.

Studies of the shipped model on simulated evaluation fields (:func:`evaluation_fields`: the
dense 1.2 km maps of :mod:`windnav.experiments.decoder_eval`, its random inlets and its
thesis flow protocol):

- :func:`eigenflows` (e): principal components ("eigenflows") of local label fields
  ``X (N, 2 H^2)``, centred: ``X - mean = U S V^T``; mode ``k`` explains
  ``S_k^2 / sum S^2`` of the variance (the thesis: 16 modes explain >= 98 %).
- :func:`gradient_r2` (c): the gradients at the robot by central differences
  (:func:`windnav.predict.central_gradients`), predicted against true, with
  ``R^2 = 1 - sum (g_pred - g_true)^2 / sum (g_true - mean g_true)^2`` per component.
- :func:`direction_study`: where the direction error lies, binned by the true speed over the
  inlet's and by the distance from the robot (:func:`windnav.predict.direction_error_breakdown`).
- :func:`basis_study`: the best fields the d4-film's output modes can express (per-sample
  least squares on the label, the "basis oracle") beside the decoder's, and the decoder's
  ``R^2`` on each of the labels' eigenflows within the modes' span.
- :func:`mosaic` (d): one map tiled with predictions at robot positions on a grid of spacing
  ``H Delta`` (``W_robot`` the true mean wind there, ``W_up`` the inlet, the scan from the map).

A study of the labels themselves:

- :func:`averaging_study`: is the decoder's error the noise of the thesis's short average? The
  same map and inlet averaged with the thesis protocol (100 + 200 steps, a fraction of a
  flow-through) and with a long one (spin-up of about one flow-through, mean over several), the
  decoder and its baselines scored at the same robot positions against each mean, and the
  difference of the two means (the label noise of the short protocol).
- :func:`start_study`: is the thesis-protocol label a function of the map and the inlet? The
  same flow started with different symmetry-breaking kicks (an arbitrary choice of the solver's
  start, :func:`windnav.flow.simulate`'s ``symmetry_break``), each averaged with the thesis
  protocol; how far apart the labels are bounds from below what any model can reach against
  them (half the largest pairwise disagreement, by the triangle inequality of each metric).

Studies that train models (:func:`train_variants` over a reduced copy of the default recipe,
:func:`study_recipe`, sharing one sweep store):

- :func:`winds_ablation` (a): the thesis MLP given no wind, ``W_up`` only, ``W_robot`` only or
  both (hyperparameter ``winds`` of ``thesis-mlp``).
- :func:`size_study` (b): the d4-film at ``H`` in {5, 15, 25, 35, 45}, against the fraction of
  the LiDAR disc it predicts, ``A_pred / A_total = (H Delta)^2 / (pi D_max^2)``, D_max = 100 m.
"""

from __future__ import annotations

import copy
import time
import warnings
from pathlib import Path

import numpy as np

from windnav._validate import options_named, positive_float, positive_int

__all__ = ["AVERAGING_PROTOCOLS", "GRADIENT_COMPONENTS", "SIZES", "THRESHOLDS", "WIND_VARIANTS",
           "START_KICKS", "area_fraction", "averaging_study", "basis_study", "direction_study",
           "start_study", "eigenflow_study", "eigenflows", "evaluation_fields", "gradient_r2",
           "gradient_study", "masked_least_squares", "mosaic", "scaling_recipe", "size_study",
           "study_recipe", "train_variants", "winds_ablation"]

THRESHOLDS = (0.90, 0.95, 0.98, 0.99)
"""Explained-variance levels reported by :func:`eigenflows`."""
GRADIENT_COMPONENTS = ("du/dx", "du/dy", "dv/dx", "dv/dy")
"""The columns of :func:`windnav.predict.central_gradients`."""
WIND_VARIANTS = ("none", "up", "robot", "both")
"""The winds ablation's configurations (``thesis-mlp`` hyperparameter ``winds``)."""
SIZES = (5, 15, 25, 35, 45)
"""The size study's grids H (cells per side)."""
D_MAX = 100.0
"""LiDAR range, m (``windnav.predict.SCAN_MAX``): the radius of the sensed disc."""
AVERAGING_PROTOCOLS = {"thesis": (100, 200), "long": (600, 3000)}
"""The two averaging protocols of :func:`averaging_study`, (spin-up steps, averaged steps):
the thesis's, and one with about one flow-through of spin-up and five of averaging on the
600 m held-out district at 6 m/s (dt = 1/6 s)."""
START_KICKS = (0.05, -0.05, 0.02, 0.10)
"""The symmetry-breaking kicks of :func:`start_study`, as fractions of the inlet speed: the
solver's default (0.05) first, then the other side of each wake, a weaker and a stronger
one."""
FLOOR_METRICS = ("speed_error", "direction_error_deg", "vector_error")
"""The metrics whose per-cell distance obeys the triangle inequality (``| |a| - |b| |``, the
angle between two vectors, ``|a - b|``): :func:`start_study` bounds them."""


def _seed(seed, where: str) -> int:
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ValueError(f"The 'seed' parameter of {where} must be an integer >= 0. "
                         f"Got {seed!r} instead.")
    return int(seed)


# --------------------------------------------------------------------------- the fields


def evaluation_fields(maps=1, n_inlets: int = 2, *, seed: int = 0, dx: float = 1.0,
                      flow_settings: dict | None = None, cache_dir=None, simulate=None,
                      max_fields: int | None = None, progress: bool = False) -> dict:
    """Mean fields of evaluation maps at random inlets (the protocol of
    :mod:`windnav.experiments.decoder_eval`).

    Parameters
    ----------
    maps : int or list of (str, City)
        The number of dense 1.2 km evaluation maps (``dense-i``, never trained on), or maps.
    n_inlets : int
        Inlets per map, >= 1: speed U[2, 10] m/s, direction U[0, 360) deg, drawn from ``seed``
        (:func:`windnav.experiments.decoder_eval.inlet_slots`).
    seed : int
        Seed of the inlets.
    dx : float
        Solver cell size, m (the decoder was trained at 1 m).
    flow_settings : dict, optional
        Override ``spinup_steps``, ``steps`` (the thesis: 100 and 200) and ``dt`` (s; default
        0.25 s shortened to ``U dt / dx <= 1``).
    cache_dir : str or path-like, optional
        Keep each solution there (:func:`windnav.flow.save_flow`) and reuse it when the same
        map, inlet and settings come again (the studies share their flows).
    simulate : callable, optional
        Replaces :func:`windnav.flow.simulate` (tests).
    max_fields : int, optional
        Stop after this many fields (the mosaic needs one); the inlets stay those of
        ``n_inlets`` (:func:`inlet_slots` draws them together).
    progress : bool
        Show a tqdm bar.

    Returns
    -------
    dict
        ``fields`` (list of MeanField), ``slots`` (map, inlet, speed m/s, direction_deg, dt s,
        seconds, cached, averaging: the flow's
        :func:`~windnav.flow.validity.averaging_verdict`), ``failed`` (slots whose flow
        diverged, with the error) and ``config``.
    """
    from windnav._console import progress_bar
    from windnav.experiments.decoder_eval import (
        PROTOCOL,
        _evaluation_maps,
        inlet_slots,
        slot_flow,
    )
    from windnav.experiments.wind_sweep import auto_dt
    from windnav.flow.solver import FlowDivergedError
    from windnav.flow.validity import averaging_verdict
    from windnav.predict import field_from_solution

    where = "evaluation_fields"
    n_inlets = positive_int(n_inlets, "n_inlets", where)
    seed = _seed(seed, where)
    dx = positive_float(dx, "dx", where)
    settings = {**PROTOCOL, **(flow_settings or {})}
    unknown = sorted(set(settings) - {"spinup_steps", "steps", "dt"})
    if unknown:
        raise ValueError(f"The 'flow_settings' parameter of {where} must only set "
                         f"spinup_steps, steps, dt. Got {unknown} instead.")
    cities = _evaluation_maps(maps, False, where)
    inlets = inlet_slots(len(cities), n_inlets, seed)
    cache = Path(cache_dir) if cache_dir is not None else None
    if cache is not None:
        cache.mkdir(parents=True, exist_ok=True)
    fields, slots, failed = [], [], []
    todo = [(i, j) for i in range(len(cities)) for j in range(n_inlets)]
    if max_fields is not None:
        todo = todo[:positive_int(max_fields, "max_fields", where)]
    for i, j in progress_bar(todo, desc="flows", disable=not progress, unit="flow"):
        name, _, city = cities[i]
        speed, direction = (float(v) for v in inlets[i, j])
        dt = float(settings.get("dt") or auto_dt(dx, speed))
        steps = {k: settings[k] for k in ("spinup_steps", "steps")}
        t0 = time.perf_counter()
        try:
            sol, cached = slot_flow(city, name, j, speed, direction, dx=dx, dt=dt, steps=steps,
                                    cache_dir=cache, simulate=simulate)
        except FlowDivergedError as exc:
            failed.append({"map": name, "inlet": j, "speed": speed,
                           "direction_deg": direction, "error": str(exc)})
            continue
        fields.append(field_from_solution(city, sol, name=f"{name}/{j}"))
        slots.append({"map": name, "inlet": j, "speed": speed, "direction_deg": direction,
                      "dt": dt, "seconds": time.perf_counter() - t0, "cached": cached,
                      "averaging": averaging_verdict(sol)})
    if not fields:
        raise ValueError(f"{where}: every flow failed ({failed[0]['error'] if failed else ''}).")
    return {"fields": fields, "slots": slots, "failed": failed,
            "config": {"maps": [n for n, _, _ in cities], "n_inlets": n_inlets, "seed": seed,
                       "dx": dx, **settings,
                       "dt_rule": "given" if "dt" in (flow_settings or {}) else
                       "0.25 s, shortened to U dt / dx <= 1"}}


def _draw(fields, samples_per_field: int, seed: int, size: int, spacing: float, where: str):
    """Samples of every field (field ``k`` from ``default_rng([seed, 4, k])``), joined."""
    from windnav.predict import SampleBatch, draw_samples

    n = positive_int(samples_per_field, "samples_per_field", where)
    parts = [draw_samples(f, n, rng=np.random.default_rng([seed, 4, k]), size=size,
                          spacing=spacing) for k, f in enumerate(fields)]
    return SampleBatch(*(np.concatenate(a) for a in zip(*parts, strict=True)))


# ------------------------------------------------------------------------- (e) eigenflows


def eigenflows(fields, *, thresholds=THRESHOLDS, n_keep: int = 16) -> dict:
    """Principal components of local wind fields and the variance each explains.

    Parameters
    ----------
    fields : array_like of shape (N, 2, H, H)
        ``[u, v]`` on the label grid (any unit, e.g. m/s or divided by the inlet speed),
        N >= 2, finite, not all equal.
    thresholds : sequence of float
        Explained-variance levels in (0, 1] for which to report the number of modes needed.
    n_keep : int
        Modes returned (the leading ones), >= 1.

    Returns
    -------
    dict
        ``explained_variance_ratio`` (K,) non-increasing, summing to 1; ``cumulative`` (K,);
        ``n_modes`` ``{level: smallest k with cumulative[k - 1] >= level}``; ``modes``
        (n_keep, 2, H, H) unit-norm components; ``mean`` (2, H, H); ``n_fields``.
    """
    where = "eigenflows"
    x = np.asarray(fields, dtype=np.float64)
    if x.ndim != 4 or x.shape[1] != 2 or x.shape[2] != x.shape[3] or x.shape[0] < 2:
        raise ValueError(f"The 'fields' parameter of {where} must be an array of shape "
                         f"(N, 2, H, H) with N >= 2. Got shape {x.shape} instead.")
    if not np.all(np.isfinite(x)):
        raise ValueError(f"The 'fields' parameter of {where} must be finite. Got non-finite "
                         "values instead.")
    levels = [float(t) for t in thresholds]
    if not levels or any(not 0 < t <= 1 for t in levels):
        raise ValueError(f"The 'thresholds' parameter of {where} must be levels in (0, 1]. "
                         f"Got {thresholds!r} instead.")
    n_keep = positive_int(n_keep, "n_keep", where)
    n, _, h, _ = x.shape
    flat = x.reshape(n, -1)
    mean = flat.mean(axis=0)
    _, s, vt = np.linalg.svd(flat - mean, full_matrices=False)
    var = s**2
    if var.sum() <= 0:
        raise ValueError(f"The 'fields' parameter of {where} must vary. Got {n} equal fields "
                         "instead.")
    ratio = var / var.sum()
    cumulative = np.cumsum(ratio)
    # a level counts as reached within rounding (an exact k-mode set gives 1 - 1e-16)
    n_modes = {f"{t:g}": int(np.searchsorted(cumulative, t - 1e-12) + 1) for t in levels}
    if max(n_modes.values()) >= n - 1:  # 16 fields "explained" by 16 modes (failure audit)
        warnings.warn(f"{where}: {n} fields span at most {n - 1} modes, and a level needs "
                      f"{max(n_modes.values())} of them: the mode counts are the sample's "
                      "rank, not the flow's; draw more fields", RuntimeWarning, stacklevel=2)
    k = min(n_keep, vt.shape[0])
    return {"explained_variance_ratio": ratio, "cumulative": cumulative, "n_modes": n_modes,
            "modes": vt[:k].reshape(k, 2, h, h), "mean": mean.reshape(2, h, h),
            "n_fields": int(n)}


def eigenflow_study(fields, samples_per_field: int = 2048, *, seed: int = 0, size: int = 25,
                    spacing: float = 1.0, n_keep: int = 16) -> dict:
    """Eigenflows of the label fields drawn from mean fields, in two frames.

    The labels (0 in buildings) are divided by the inlet speed (the solver's mean field scales
    with it) and decomposed as they are (``world``: the thesis's set-up) and turned into the
    canonical D4 frame of the inlet direction (``canonical``: the frame of the d4-film's
    basis, :func:`windnav.predict.decoder.canonicalize_field`).

    Parameters
    ----------
    fields : sequence of MeanField
    samples_per_field : int
        Label fields drawn per mean field (:func:`windnav.predict.draw_samples`).
    seed : int
        Seed of the samples.
    size, spacing
        The label grid: H cells per side of ``spacing`` m.
    n_keep : int
        Modes kept per frame.

    Returns
    -------
    dict
        ``world`` and ``canonical``: :func:`eigenflows` results; ``n_fields``, ``size``,
        ``spacing``.
    """
    from windnav.predict.decoder import canonical_elements, canonicalize_field

    where = "eigenflow_study"
    # Python API audit, fifty-eighth session: no fields met a TypeError from SampleBatch, an
    # even size was accepted (the recipe refuses it: no cell centred on the robot) and a
    # spacing of 0 was named as grid_offsets'
    given = fields
    try:
        fields = None if isinstance(fields, str | bytes) else list(fields)
    except TypeError:
        fields = None
    if not fields:
        raise ValueError(f"The 'fields' parameter of {where} must be a sequence of at least one "
                         f"MeanField. Got {given!r} instead.")
    h = positive_int(size, "size", where)
    if h % 2 == 0 or h < 3:
        raise ValueError(f"The 'size' parameter of {where} must be an odd integer >= 3 (cells "
                         f"per side of the window centred on the robot). Got {size!r} instead.")
    positive_float(spacing, "spacing", where)
    batch = _draw(fields, samples_per_field, _seed(seed, where), size, spacing, where)
    labels = batch.labels.astype(np.float64) / batch.inlet_speed[:, None, None, None]
    b, h = labels.shape[0], labels.shape[-1]
    canon = canonicalize_field(labels.reshape(b, 2, -1),
                               canonical_elements(batch.w_up)).reshape(b, 2, h, h)
    return {"world": eigenflows(labels, n_keep=n_keep),
            "canonical": eigenflows(canon, n_keep=n_keep), "n_fields": int(b),
            "size": int(h), "spacing": float(spacing)}


# -------------------------------------------------------------------------- (c) gradients


MIN_GRADIENT_SAMPLES = 3
"""Fewest counted samples :func:`gradient_r2` scores (NaN below): two points fit any line, so
their correlation is +-1 whatever the decoder predicts (statistics audit: ``pearson_r`` -1.0
from 2 samples)."""


def gradient_r2(pred, true, free, spacing: float) -> dict:
    """R^2 of the predicted wind gradients at the robot (the centre cell) against the true ones.

    Parameters
    ----------
    pred, true : array_like of shape (B, 2, H, H)
        Predicted and true ``[u, v]``, m/s, indexed ``[b, :, iy, ix]``; ``H`` odd >= 3.
    free : array_like of bool, shape (B, H, H)
        Free cells; a sample counts only when the centre and its four neighbours are free (a
        difference across a wall is no gradient).
    spacing : float
        Grid spacing, m.

    Returns
    -------
    dict
        ``r2`` and ``pearson_r`` ``{component: float}`` over the samples that count (NaN when
        the true component does not vary, or fewer than :data:`MIN_GRADIENT_SAMPLES` count,
        with ``note`` saying so), ``n_samples``, ``n_excluded``, and ``pred``,
        ``true`` (n, 4): the gradients in 1/s (columns :data:`GRADIENT_COMPONENTS`).
    """
    from windnav.predict import central_gradients

    where = "gradient_r2"
    true = np.asarray(true, dtype=np.float64)
    pred = np.asarray(pred, dtype=np.float64)
    if pred.shape != true.shape:
        raise ValueError(f"The 'pred' parameter of {where} must have the shape of 'true' "
                         f"{true.shape}. Got shape {pred.shape} instead.")
    # a NaN prediction gave NaN R^2, and an even H or a spacing of 0 were named as
    # central_gradients' (Python API audit, fifty-eighth session)
    for name, a in (("pred", pred), ("true", true)):
        if not np.isfinite(a).all():
            raise ValueError(f"The {name!r} parameter of {where} must be finite (no NaN or "
                             "inf). Got non-finite entries instead.")
    with options_named({"'uv' parameter of central_gradients": f"'true' parameter of {where}",
                        "'spacing' parameter of central_gradients":
                            f"'spacing' parameter of {where}"}):
        gt = central_gradients(true, spacing)
    gp = central_gradients(pred, spacing)
    b, h = true.shape[0], true.shape[-1]
    free = np.asarray(free)
    if free.shape != (b, h, h) or free.dtype != bool:
        raise ValueError(f"The 'free' parameter of {where} must be a boolean array of shape "
                         f"{(b, h, h)}. Got {free.dtype} of shape {free.shape} instead.")
    c = (h - 1) // 2
    ok = (free[:, c, c] & free[:, c, c - 1] & free[:, c, c + 1] & free[:, c - 1, c]
          & free[:, c + 1, c])
    gt, gp = gt[ok], gp[ok]
    if gt.shape[0] < MIN_GRADIENT_SAMPLES:
        nan = {name: float("nan") for name in GRADIENT_COMPONENTS}
        return {"r2": nan, "pearson_r": dict(nan), "n_samples": int(ok.sum()),
                "n_excluded": int(b - ok.sum()), "pred": gp, "true": gt,
                "note": f"{int(ok.sum())} samples count (a free centre and four free "
                        f"neighbours), fewer than the {MIN_GRADIENT_SAMPLES} a correlation "
                        "needs: no R^2"}
    r2, r = {}, {}
    for k, name in enumerate(GRADIENT_COMPONENTS):
        ss_tot = float(np.sum((gt[:, k] - gt[:, k].mean()) ** 2)) if gt.shape[0] else 0.0
        ss_res = float(np.sum((gp[:, k] - gt[:, k]) ** 2))
        r2[name] = 1.0 - ss_res / ss_tot if ss_tot > 0 else float("nan")
        sp = float(np.std(gp[:, k])) if gt.shape[0] else 0.0
        r[name] = float(np.corrcoef(gp[:, k], gt[:, k])[0, 1]) if ss_tot > 0 and sp > 0 \
            else float("nan")
    return {"r2": r2, "pearson_r": r, "n_samples": int(ok.sum()),
            "n_excluded": int(b - ok.sum()), "pred": gp, "true": gt}


def gradient_study(decoder, fields, samples_per_field: int = 2048, *, seed: int = 0) -> dict:
    """Gradients at the robot: the decoder (and the Local baseline, whose are 0) against the
    mean field, on samples drawn from ``fields``.

    Returns
    -------
    dict
        ``decoder``: :func:`gradient_r2` on the gradients in 1/s; ``decoder_per_U``: the same
        with every field divided by its inlet speed (1/m: the pooled inlet speeds do not inflate
        the R^2); ``local``: the Local baseline's R^2 (uniform field: zero gradients);
        ``n_samples_drawn``.
    """
    from windnav.predict import LocalBaseline

    where = "gradient_study"
    batch = _draw(fields, samples_per_field, _seed(seed, where), decoder.size,
                  decoder.spacing, where)
    pred = decoder.predict(batch.scans, batch.w_up, batch.w_robot)
    local = LocalBaseline(size=decoder.size, spacing=decoder.spacing).predict(
        batch.scans, batch.w_up, batch.w_robot)
    u = batch.inlet_speed.astype(np.float64)[:, None, None, None]
    return {"decoder": gradient_r2(pred, batch.labels, batch.free, decoder.spacing),
            "decoder_per_U": gradient_r2(pred / u, batch.labels / u, batch.free,
                                         decoder.spacing),
            "local": {k: v for k, v in gradient_r2(local, batch.labels, batch.free,
                                                   decoder.spacing).items()
                      if k in ("r2", "n_samples")},
            "n_samples_drawn": int(batch.scans.shape[0])}


def direction_study(decoder, fields, samples_per_field: int = 2048, *, seed: int = 0) -> dict:
    """Where the direction error lies: the decoder's and both baselines' per-cell angles binned
    by the true speed over the inlet's and by the distance from the robot
    (:func:`windnav.predict.direction_error_breakdown`), on samples drawn from ``fields``.

    Returns
    -------
    dict
        ``models``: ``{"decoder", "local", "upstream"}`` -> the breakdown; ``n_samples_drawn``.
    """
    from windnav.predict import direction_error_breakdown
    from windnav.predict.baselines import with_baselines

    where = "direction_study"
    batch = _draw(fields, samples_per_field, _seed(seed, where), decoder.size,
                  decoder.spacing, where)
    models = with_baselines({"decoder": decoder}, decoder.size, decoder.spacing)
    return {"models": {m: direction_error_breakdown(
                model.predict(batch.scans, batch.w_up, batch.w_robot), batch.labels,
                batch.free, batch.inlet_speed, decoder.offsets) for m, model in models.items()},
            "n_samples_drawn": int(batch.scans.shape[0])}


# ------------------------------------------------------------------ the output basis


FIXED_MODES = (1, 2, 5, 10, 16)
"""The numbers of leading eigenflows :func:`basis_study` fixes to the oracle's coefficients."""
N_EIGENFLOW_FIELDS = 4
"""The leading eigenflows :func:`basis_study` returns as fields (for its figure)."""


def masked_least_squares(basis: np.ndarray, target: np.ndarray, mask: np.ndarray, *,
                         chunk: int = 256) -> np.ndarray:
    """Per sample, the coefficients ``c`` that minimise ``sum_n m_n (basis c - t)_n^2``.

    Parameters
    ----------
    basis : ndarray of shape (N, K)
        Columns of full rank.
    target : ndarray of shape (B, N)
    mask : ndarray of shape (B, N)
        Weights (1 on the cells that count, 0 elsewhere); every sample must leave the masked
        columns of ``basis`` of full rank.
    chunk : int
        Samples per batched solve.

    Returns
    -------
    ndarray of shape (B, K), float64
        The normal equations ``(A^T M A) c = A^T M t``, solved in batches.
    """
    # Python API audit, fifty-eighth session: a NaN target passed through, a shape mismatch
    # met an einsum error, chunk 0 a range() error and an all-zero mask a LinAlgError
    where = "masked_least_squares"
    basis = np.asarray(basis, dtype=np.float64)
    target = np.asarray(target, dtype=np.float64)
    mask = np.asarray(mask, dtype=np.float64)
    chunk = positive_int(chunk, "chunk", where)
    if basis.ndim != 2 or not 1 <= basis.shape[1] <= basis.shape[0]:
        raise ValueError(f"The 'basis' parameter of {where} must be an array of shape (N, K) "
                         f"with 1 <= K <= N. Got shape {basis.shape} instead.")
    if target.ndim != 2 or target.shape[1] != basis.shape[0]:
        raise ValueError(f"The 'target' parameter of {where} must be an array of shape (B, "
                         f"{basis.shape[0]}) (N, the basis's rows). Got shape {target.shape} "
                         "instead.")
    if mask.shape != target.shape:
        raise ValueError(f"The 'mask' parameter of {where} must have the shape of 'target' "
                         f"{target.shape}. Got shape {mask.shape} instead.")
    for name, a in (("basis", basis), ("target", target), ("mask", mask)):
        if not np.isfinite(a).all():
            raise ValueError(f"The {name!r} parameter of {where} must be finite (no NaN or "
                             "inf). Got non-finite entries instead.")
    out = np.empty((target.shape[0], basis.shape[1]))
    for i in range(0, target.shape[0], chunk):
        m = mask[i:i + chunk]
        weighted = m[:, :, None] * basis[None]                      # (b, N, K)
        gram = np.swapaxes(weighted, 1, 2) @ basis                  # (b, K, K)
        rhs = np.einsum("bnk,bn->bk", weighted, target[i:i + chunk])
        try:
            out[i:i + chunk] = np.linalg.solve(gram, rhs[:, :, None])[:, :, 0]
        except np.linalg.LinAlgError:
            raise ValueError(f"The 'mask' parameter of {where} must leave, in every sample, "
                             "the masked columns of 'basis' of full rank (enough cells that "
                             f"count). Got a sample among rows {i} to "
                             f"{min(i + chunk, len(mask)) - 1} where they are not instead."
                             ) from None
    return out


def basis_study(decoder, fields, samples_per_field: int = 2048, *, seed: int = 0,
                fixed_modes=FIXED_MODES) -> dict:
    """Is the decoder's output basis what limits it? The best fields its modes can express,
    against the fields it predicts, and which modes it misses.

    The d4-film predicts ``W_robot + U (basis a + bias)`` in the canonical frame
    (:class:`windnav.predict.decoder.D4FilmArchitecture`). For every sample the **basis
    oracle** takes the coefficients that fit the label best (least squares over the free cells,
    :func:`masked_least_squares`, both components, in units of ``U``) and is scored with the
    project's metrics beside the decoder and both baselines. Then, in an orthonormal basis of
    the modes' span ordered by the oracle coefficients' variance (the labels' eigenflows within
    the span), each direction's share of that variance, its share of the decoder's squared
    coefficient error, and the decoder's ``R^2 = 1 - error / variance`` on it. Last, the
    decoder is scored with its coefficients on the first ``k`` of those directions replaced by
    the oracle's: what predicting the largest eigenflows right would be worth.

    Parameters
    ----------
    decoder : Decoder
        A single-model ``d4-film``.
    fields : sequence of MeanField
    samples_per_field : int
    seed : int
    fixed_modes : sequence of int
        The ``k`` (>= 1) of the last part.

    Returns
    -------
    dict
        ``errors``: ``{"decoder", "basis_oracle", "local", "upstream"}`` ->
        :func:`windnav.predict.field_errors` plus ``squared_error`` (the mean of ``|u_hat -
        u|^2`` over free cells, m^2/s^2: what the oracle minimises); ``modes``:
        ``variance_share``, ``error_share``, ``r2`` (one per direction, largest variance first);
        ``r2_total``; ``fixed_modes``: ``{k: errors}`` of the decoder with its first ``k``
        directions fixed; ``eigenflow_fields`` ``(4, 2, H, H)``: the first four directions as
        unit fields in the canonical frame (the inlet wind toward [0, 45] deg), indexed
        ``[.., iy, ix]`` at ``offsets`` (m, the decoder's); ``n_modes``; ``n_samples``.
    """
    from windnav.predict import field_errors
    from windnav.predict.baselines import with_baselines

    where = "basis_study"
    fixed_modes = [positive_int(k, "fixed_modes", where) for k in fixed_modes]
    if decoder.architecture != "d4-film" or decoder.hyperparameters.get("members", 1) != 1:
        raise ValueError(f"The 'decoder' parameter of {where} must be a single-model d4-film "
                         f"(it has an output basis). Got {decoder.architecture!r} with "
                         f"{decoder.hyperparameters.get('members', 1)} member(s) instead.")
    n_basis = decoder.weights["basis.weight"].shape[1]
    batch = _draw(fields, samples_per_field, _seed(seed, where), decoder.size,
                  decoder.spacing, where)
    if batch.scans.shape[0] <= n_basis:  # R^2 of 2e15 and -inf, shares of NaN (failure audit)
        raise ValueError(f"The 'samples_per_field' parameter of {where} must give more samples "
                         f"than the decoder's {n_basis} modes, for the variance along each to "
                         f"be estimated. Got {samples_per_field!r} per field instead "
                         f"({batch.scans.shape[0]} samples).")
    arch, w = decoder.arch, decoder.weights
    b = batch.scans.shape[0]
    f = arch.features(*(np.asarray(a, dtype=np.float32)
                        for a in (batch.scans, batch.w_up, batch.w_robot)))
    labels_c, free_c = arch.model_labels(batch.labels.reshape(b, 2, -1),
                                         batch.free.reshape(b, -1), f)
    scale = f["scale"].astype(np.float64)
    bias = w["basis.bias"].astype(np.float64)
    target = ((labels_c - f["w_robot"][:, :, None]) / scale[:, None, None]).reshape(b, -1) - bias
    q, r = np.linalg.qr(w["basis.weight"].astype(np.float64))      # basis = q r
    mask = np.concatenate([free_c, free_c], axis=1)
    c_oracle = masked_least_squares(q, target, mask)
    c_decoder = arch.coefficients(decoder.prepared, f).astype(np.float64) @ r.T

    def world(c):  # coefficients (in q's coordinates) -> world-frame fields (B, 2, H, H)
        field_c = ((c @ q.T + bias).reshape(b, 2, -1) * scale[:, None, None]
                   + f["w_robot"][:, :, None])
        return arch.world_frame(field_c.astype(np.float32), f)

    free = batch.free.astype(bool)

    def scored(p):
        return {**field_errors(p, batch.labels, batch.free, batch.inlet_speed),
                "squared_error": float(np.sum((p.astype(np.float64) - batch.labels) ** 2,
                                              axis=1)[free].mean())}

    preds = {"decoder": decoder.predict(batch.scans, batch.w_up, batch.w_robot),
             "basis_oracle": world(c_oracle)}
    for name, model in with_baselines({}, decoder.size, decoder.spacing).items():
        preds[name] = model.predict(batch.scans, batch.w_up, batch.w_robot)
    errors = {name: scored(p) for name, p in preds.items()}
    centred = c_oracle - c_oracle.mean(axis=0)
    variance, axes = np.linalg.eigh(centred.T @ centred / b)
    order = np.argsort(variance)[::-1]
    variance, axes = variance[order], axes[:, order]
    error = np.mean(((c_decoder - c_oracle) @ axes) ** 2, axis=0)
    # the decoder with its first k eigenflows' coefficients replaced by the oracle's
    fixed = {}
    for k in sorted({min(k, q.shape[1]) for k in fixed_modes}):
        a = axes[:, :k]
        fixed[k] = scored(world(c_decoder + (c_oracle - c_decoder) @ a @ a.T))
    return {"errors": errors,
            "modes": {"variance_share": variance / variance.sum(),
                      "error_share": error / error.sum(),
                      "r2": 1.0 - error / variance},
            "r2_total": float(1.0 - error.sum() / variance.sum()),
            "fixed_modes": fixed,
            "eigenflow_fields": (q @ axes[:, :N_EIGENFLOW_FIELDS]).T.reshape(
                -1, 2, decoder.size, decoder.size),
            "offsets": decoder.offsets,
            "n_modes": int(q.shape[1]), "n_samples": int(b)}


# ------------------------------------------------------------------ noise on W_robot


NOISE_LEVELS = (0.0, 0.05, 0.1, 0.15, 0.2)
"""The noise study's standard deviations of ``W_robot``'s error per component, as fractions of
the inlet speed (0.14 per component is an RMS vector error of 0.2 U, about the Wind UKF's in
the navigation benchmark's flights)."""


def noise_study(decoders: dict, fields, samples_per_field: int = 2048, *,
                levels=NOISE_LEVELS, seed: int = 0) -> dict:
    """The decoders and the baselines given a noisy ``W_robot``, as the onboard stack gives it.

    The samples are drawn once without noise; at each level ``s`` every model gets
    ``W_robot + s U z`` with the same standard normal ``z`` (per sample and component, one draw
    for all levels and models), and is scored against the same labels.

    Parameters
    ----------
    decoders : dict of str to Decoder
        The models to compare (same grid size and spacing).
    fields : sequence of MeanField
    samples_per_field : int
    levels : sequence of float
        Noise standard deviations per component, fractions of the inlet speed, >= 0.
    seed : int

    Returns
    -------
    dict
        ``levels``; ``errors[model][k]``: :func:`windnav.predict.field_errors` at ``levels[k]``,
        models the decoders' names and ``local``, ``upstream``; ``w_robot_error_mps[k]``: the
        mean ``|error|`` given at each level; ``n_samples``.
    """
    from windnav.predict import field_errors
    from windnav.predict.baselines import with_baselines

    where = "noise_study"
    if not decoders:
        raise ValueError(f"The 'decoders' parameter of {where} must name at least one decoder. "
                         "Got none.")
    first = next(iter(decoders.values()))
    if any((d.size, d.spacing) != (first.size, first.spacing) for d in decoders.values()):
        got = [(n, d.size, d.spacing) for n, d in decoders.items()]
        raise ValueError(f"The 'decoders' parameter of {where} must hold decoders of one grid "
                         f"size and spacing. Got {got} instead.")
    levels = [positive_float(v, "levels", where, allow_zero=True) for v in levels]
    if not levels:
        raise ValueError(f"The 'levels' parameter of {where} must list at least one level. Got "
                         "none.")
    seed = _seed(seed, where)
    batch = _draw(fields, samples_per_field, seed, first.size, first.spacing, where)
    z = np.random.default_rng([seed, 5]).standard_normal(batch.w_robot.shape)
    u = batch.inlet_speed.astype(np.float64)[:, None]
    models = with_baselines(decoders, first.size, first.spacing)
    errors = {name: [] for name in models}
    given = []
    for level in levels:
        w_robot = (batch.w_robot + level * u * z).astype(batch.w_robot.dtype)
        given.append(float(np.mean(np.linalg.norm(w_robot - batch.w_robot, axis=1))))
        for name, model in models.items():
            pred = model.predict(batch.scans, batch.w_up, w_robot)
            errors[name].append(field_errors(pred, batch.labels, batch.free,
                                             batch.inlet_speed))
    return {"levels": levels, "errors": errors, "w_robot_error_mps": given,
            "n_samples": int(batch.scans.shape[0])}


# ----------------------------------------------------------------------------- (d) mosaic


def _tiles_to_map(tiles: np.ndarray, nty: int, ntx: int) -> np.ndarray:
    """``(nty ntx, ..., H, H)`` tiles, row-major over (ty, tx), as one ``(..., nty H, ntx H)``."""
    h = tiles.shape[-1]
    lead = tiles.shape[1:-2]
    t = tiles.reshape(nty, ntx, *lead, h, h)
    t = np.moveaxis(t, (0, 1), (-4, -2))  # (..., nty, H, ntx, H)
    return t.reshape(*lead, nty * h, ntx * h)


def mosaic(decoder, field, *, scan_noise: float = 0.35, rng=None, batch_size: int = 1024,
           progress: bool = False) -> dict:
    """Reconstruct a whole map's mean wind from decoder predictions on a grid of robots.

    The map's cells (``decoder.spacing`` m) are cut into ``H x H`` tiles; each tile is
    predicted by one robot at its centre cell (``W_robot`` = the mean wind there, ``W_up`` =
    the inlet, the scan from the map with ``scan_noise``). When the centre cell or one of its 8
    neighbours is not free (a building, the solver's pockets), the robot moves to the tile's
    nearest cell whose 3 x 3 block is free, and its prediction, shifted by whole cells, covers
    the tile less the strip it no longer reaches; a tile with no such cell is not predicted.
    The truth is :meth:`MeanField.grid_values` on the same cells, and the metrics are
    :func:`windnav.predict.field_errors` over the free, covered cells of every tile.

    Parameters
    ----------
    decoder : Decoder
        With odd H.
    field : MeanField
    scan_noise : float
        LiDAR range noise, m (returns only, clipped to [0.25, 100] m as in training).
    rng : numpy.random.Generator, int or None
        Source of the scan noise (None: fresh entropy).
    batch_size : int
        Robots per decoder call.
    progress : bool
        Show a tqdm bar.

    Returns
    -------
    dict
        ``x`` (nx,), ``y`` (ny,) cell centres, m; ``truth``, ``prediction``, ``local``
        (2, ny, nx) m/s (``local``: the Local baseline's uniform tiles); ``free``,
        ``covered`` (ny, nx) bool; ``robots`` (n, 2) m; ``n_tiles``, ``n_robots``,
        ``n_moved``; ``coverage`` (covered free cells / free cells); ``metrics``: errors of
        ``decoder``, ``local``, ``upstream`` and ``improvement_pct`` over each baseline.
    """
    from windnav._console import progress_bar
    from windnav.experiments.decoder_eval import _summary
    from windnav.predict import (
        SCAN_MAX,
        SCAN_MIN,
        LocalBaseline,
        MeanField,
        UpstreamBaseline,
        field_errors,
    )

    where = "mosaic"
    if not isinstance(field, MeanField):
        raise ValueError(f"The 'field' parameter of {where} must be a MeanField. Got "
                         f"{type(field).__name__} instead.")
    h, dx = int(decoder.size), float(decoder.spacing)
    if h % 2 == 0 or h < 3:
        raise ValueError(f"The 'decoder' parameter of {where} must predict an odd grid H >= 3. "
                         f"Got H = {h} instead.")
    noise = positive_float(scan_noise, "scan_noise", where, allow_zero=True)
    batch_size = positive_int(batch_size, "batch_size", where)
    rng = np.random.default_rng(rng)
    x0, x1, y0, y1 = field.city.bounds
    nx, ny = int(round((x1 - x0) / dx)), int(round((y1 - y0) / dx))
    ntx, nty = -(-nx // h), -(-ny // h)
    c = (h - 1) // 2
    # tile centres, row-major over (ty, tx)
    cx = x0 + (np.arange(ntx) * h + c + 0.5) * dx
    cy = y0 + (np.arange(nty) * h + c + 0.5) * dx
    centres = np.stack(np.meshgrid(cx, cy), axis=-1).reshape(-1, 2)
    truth, free = field.grid_values(centres, decoder.offsets, dtype=np.float32)
    # a robot cell needs its 3 x 3 block free: >= about one cell from any wall
    pad = np.pad(free, ((0, 0), (1, 1), (1, 1)))
    block = np.ones_like(free)
    for dy in range(3):
        for dxx in range(3):
            block &= pad[:, dy:dy + h, dxx:dxx + h]
    k = np.arange(h) - c
    dist = k[None, :] ** 2 + k[:, None] ** 2  # [iy, ix]
    cost = np.where(block, dist[None], np.iinfo(np.int64).max)
    has = block.any(axis=(1, 2))
    best = cost.reshape(cost.shape[0], -1).argmin(axis=1)
    shift = np.stack([best % h - c, best // h - c], axis=1)  # (sx, sy) cells
    tiles = np.flatnonzero(has)
    robots = centres[tiles] + shift[tiles] * dx
    s = shift[tiles]

    w_up = np.broadcast_to(field.w_up, (tiles.size, 2)).astype(np.float64)
    w_robot = field.interpolate(robots) if tiles.size else np.zeros((0, 2))
    pred = np.zeros((tiles.size, 2, h, h), dtype=np.float32)
    for a in progress_bar(range(0, tiles.size, batch_size), desc="mosaic", disable=not progress,
                          unit="batch"):
        sl = slice(a, a + batch_size)
        scan = field.city.lidar(robots[sl], n_rays=decoder.n_rays, max_range=SCAN_MAX,
                                noise_std=noise, rng=rng)
        pred[sl] = decoder.predict(np.clip(scan, SCAN_MIN, SCAN_MAX), w_up[sl], w_robot[sl])
    # tile cell (iy, ix) is cell (iy - sy, ix - sx) of the moved robot's grid
    iy = np.arange(h)[None, :] - s[:, 1:2]
    ix = np.arange(h)[None, :] - s[:, 0:1]
    reach = ((iy >= 0) & (iy < h))[:, :, None] & ((ix >= 0) & (ix < h))[:, None, :]
    b = np.arange(tiles.size)[:, None, None, None]
    comp = np.arange(2)[None, :, None, None]
    shifted = pred[b, comp, np.clip(iy, 0, h - 1)[:, None, :, None],
                   np.clip(ix, 0, h - 1)[:, None, None, :]]
    covered_t = np.zeros_like(free)
    covered_t[tiles] = reach
    pred_t = np.zeros_like(truth)
    pred_t[tiles] = np.where(reach[:, None], shifted, 0.0)

    speed = np.full(tiles.size, field.inlet_speed)
    mask = free[tiles] & reach
    errors = {}
    base = {"decoder": pred_t[tiles],
            "local": LocalBaseline(size=h, spacing=dx).predict(
                np.zeros((tiles.size, decoder.n_rays)), w_up, w_robot),
            "upstream": UpstreamBaseline(size=h, spacing=dx).predict(
                np.zeros((tiles.size, decoder.n_rays)), w_up, w_robot)}
    for name, p in base.items():
        e = field_errors(p, truth[tiles], mask, speed)
        errors[name] = e
    local_t = np.zeros_like(truth)
    local_t[tiles] = base["local"]
    n_free = int(free.sum())

    def crop(a):
        return _tiles_to_map(a, nty, ntx)[..., :ny, :nx]

    return {"x": x0 + (np.arange(nx) + 0.5) * dx, "y": y0 + (np.arange(ny) + 0.5) * dx,
            "truth": crop(truth), "prediction": crop(pred_t), "local": crop(local_t),
            "free": crop(free), "covered": crop(covered_t), "robots": robots,
            "n_tiles": int(centres.shape[0]), "n_robots": int(tiles.size),
            "n_moved": int(np.any(s != 0, axis=1).sum()),
            "coverage": float(mask.sum() / n_free) if n_free else float("nan"),
            "metrics": _summary(errors), "w_up": np.asarray(field.w_up, float),
            "name": field.name, "size": h, "spacing": dx}


# ---------------------------------------------------------------- (a), (b) trained models


def area_fraction(size, spacing: float = 1.0, d_max: float = D_MAX):
    """The fraction of the LiDAR disc a grid covers: ``(H spacing)^2 / (pi d_max^2)``
    (the thesis's ``A_pred / A_total = (1 / pi) (H / D_max)^2`` at 1 m cells).

    ``size`` is H, cells per side (a number or an array of them, > 0), ``spacing`` the cell,
    m, and ``d_max`` the LiDAR's range, m (:data:`D_MAX`); a fraction of the same shape as
    ``size`` (above 1 where the grid is wider than the disc)."""
    # -5 gave a fraction > 0 and d_max 0 inf (Python API audit, fifty-eighth session)
    where = "area_fraction"
    try:
        h = np.asarray(size, dtype=np.float64)
    except (TypeError, ValueError):
        h = np.full(1, np.nan)
    if h.size == 0 or not (np.isfinite(h) & (h > 0)).all():
        raise ValueError(f"The 'size' parameter of {where} must be cells per side: finite and "
                         f"> 0. Got {size!r} instead.")
    positive_float(spacing, "spacing", where)
    positive_float(d_max, "d_max", where)
    return (h * spacing) ** 2 / (np.pi * d_max**2)


STUDY_SCHEDULE = {"winds": {"epochs": 20, "samples_per_field": 384, "learning_rate": 3e-4},
                  "size": {"epochs": 12, "samples_per_field": 384}}
"""The studies' reduced training schedules (the default recipe: 40 epochs of about 553k
samples). The thesis MLP's learning rate is 3e-4, not the thesis's 1e-3: at 1e-3
the models given no ``W_robot`` stopped learning in the first epoch (every ReLU unit dead: a
constant output), at 3e-4 they learn."""


def study_recipe(study: str, *, quick: bool = False, epochs: int | None = None,
                 samples_per_field: int | None = None) -> dict:
    """The reduced recipe a training study starts from (its variants change the model).

    Both studies share one sweep (so one store): the default recipe's six inlet directions at
    6 m/s on the thesis protocol, but over 11 maps of 300 m instead of 45 (8 dense, 2 of the
    thesis's sparse maps, and 1 dense map held out for the test samples); one model thread.
    ``winds``: the thesis MLP at width 256 (depth 3), trained as the thesis (Adam,
    lambda = 0.002, MSE; but a learning rate of 3e-4, see :data:`STUDY_SCHEDULE`) with D4 and
    speed (2-10 m/s) augmentation, so that speed is not known without a wind. ``size``: the
    default d4-film. ``quick``: the tiny recipe's sweep and models (tests).

    Parameters
    ----------
    study : {"winds", "size"}
    quick : bool
    epochs, samples_per_field : int, optional
        Override :data:`STUDY_SCHEDULE` (quick: 2 epochs, the tiny recipe's samples).
    """
    from windnav.predict.train import RECIPES, load_recipe

    where = "study_recipe"
    if study not in ("winds", "size"):
        raise ValueError(f"The 'study' parameter of {where} must be 'winds' or 'size'. Got "
                         f"{study!r} instead.")
    if quick:
        r = load_recipe(RECIPES / "tiny.toml")
        r["train"]["epochs"] = 2
    else:
        # the default recipe as the studies' figures were measured with (its maps are replaced)
        r = load_recipe(RECIPES / "default_2026-12-06.toml")
        r["name"] = "decoder-studies"
        r["sweep"]["backend"] = "serial"
        r["sweep"]["workers"] = 1
        r["sweep"]["maps"] = [
            {"name": "dense", "kind": "dense", "count": 8, "seed": 1001, "size": 300.0,
             "lots_per_side": 4},
            {"name": "sparse", "kind": "training", "count": 2, "seed": 1003, "size": 300.0},
            {"name": "holdout", "kind": "dense", "count": 1, "seed": 1005, "size": 300.0,
             "lots_per_side": 4}]
        r["data"]["validation_maps"] = ["holdout-0"]
        # the default recipe's weights and exclusions name its own groups, not these (every
        # full `winds` and `size` study stopped on them since the weights came, 2026-11-30)
        r["data"]["map_weights"] = {}
        r["data"]["exclude_maps"] = []
        r["data"]["validation_samples_per_field"] = 512
        # the scenes untouched, as when the studies' figures were measured (the default recipe
        # turns its training scenes since 2026-12-06; a study compares winds and sizes, not that)
        r["data"]["turn_deg"] = 0
        r["train"].update(epochs=STUDY_SCHEDULE[study]["epochs"], resample_every=0, threads=1,
                          members=1)
        r["data"]["samples_per_field"] = STUDY_SCHEDULE[study]["samples_per_field"]
    if epochs is not None:
        r["train"]["epochs"] = positive_int(epochs, "epochs", where)
    if samples_per_field is not None:
        r["data"]["samples_per_field"] = positive_int(samples_per_field, "samples_per_field",
                                                      where)
    r["train"]["tensorboard"] = False
    if study == "winds":
        width = 32 if quick else 256
        r["model"] = {"architecture": "thesis-mlp",
                      "hyperparameters": {"width": width, "depth": 1 if quick else 3}}
        r["train"].update(optimizer="adam", weight_decay=0.002,
                          learning_rate=1e-3 if quick else STUDY_SCHEDULE[study]["learning_rate"],
                          loss_speed_power=2.0, direction_loss_weight=0.0, augment_d4=True,
                          augment_speed=[2.0, 10.0])
    return load_recipe({k: v for k, v in r.items() if k != "source"})


def _sweep(recipe: dict, store: Path, progress: bool) -> dict:
    from windnav.experiments.wind_sweep import sweep
    from windnav.predict.train import recipe_maps

    sw = recipe["sweep"]
    t0 = time.perf_counter()
    st, results = sweep(recipe_maps(recipe), store, speeds=sw["speeds"],
                        directions_deg=sw["directions_deg"], settings=sw["settings"],
                        backend=sw["backend"], workers=sw["workers"], seed=sw["seed"],
                        progress=progress)
    failed = [{"map": r.task.map_index, "directions_deg": list(r.task.directions_deg),
               "error": (r.error or "").splitlines()[0]} for r in results if not r.ok]
    return {"store": str(store), "n_simulations": st.n_maps * st.n_cases,
            "seconds": time.perf_counter() - t0, "failed": failed}


def train_variants(recipe: dict, variants: dict, runs_dir, *, progress: bool = False,
                   test_seed: int = 0) -> dict:
    """Run the recipe's sweep (resumable) into ``runs_dir/sweep.zarr``, train one model per
    variant (resumable) and score each on fresh test samples of the held-out maps.

    Parameters
    ----------
    recipe : dict
        A complete recipe (:func:`study_recipe`).
    variants : dict of str to dict
        ``name -> {dotted key: value}``, e.g. ``{"data.size": 15}``: set in a copy of the
        recipe.
    runs_dir : str or path-like
        The store and one folder per variant (named with the schedule, so another schedule
        trains anew instead of refusing the checkpoint).
    progress : bool
        Progress bars (sweep, epochs).
    test_seed : int
        The test samples are ``DecoderDataset(held-out fields, validation_samples_per_field,
        seed = data.seed + 101 + test_seed)``: other robot positions and noise than the
        validation samples that chose each model's best epoch.

    Returns
    -------
    dict
        ``sweep`` (store, seconds, failed), ``schedule`` (epochs, samples per field, training
        samples), and ``variants``: per name, ``errors`` of the model and of the Local and
        Upstream baselines on the test samples, ``train_seconds``, ``best_epoch``,
        ``n_parameters``, ``n_test_samples``, ``model`` (path).
    """
    from windnav.predict import field_errors, load_decoder
    from windnav.predict.baselines import with_baselines
    from windnav.predict.train import _dataset, _split_fields, train_decoder

    runs = Path(runs_dir)
    runs.mkdir(parents=True, exist_ok=True)
    store = runs / "sweep.zarr"
    sweep_info = _sweep(recipe, store, progress)
    out = {"sweep": sweep_info, "variants": {}}
    tr, data = recipe["train"], recipe["data"]
    for name, changes in variants.items():
        r = copy.deepcopy(recipe)
        for key, value in changes.items():
            *parents, last = key.split(".")
            table = r
            for part in parents:
                table = table[part]
            table[last] = value
        tag = f"{name}-e{r['train']['epochs']}-n{r['data']['samples_per_field']}"
        t0 = time.perf_counter()
        hist = train_decoder(r, store=store, out_dir=runs / tag, progress=progress, log=None)
        seconds = time.perf_counter() - t0
        dec = load_decoder(runs / tag / "model.npz", boundary="average")  # as validated
        _, fields_val, _, _ = _split_fields(store, r["data"]["validation_maps"],
                                            "train_variants")
        test = _dataset(fields_val, r["data"]["validation_samples_per_field"], r["data"],
                        101 + int(test_seed)).materialize()
        errors = {}
        for model_name, model in with_baselines({"model": dec}, dec.size,
                                                dec.spacing).items():
            p = model.predict(test.scans, test.w_up, test.w_robot)
            errors[model_name] = field_errors(p, test.labels, test.free, test.inlet_speed)
        out["variants"][name] = {
            "errors": errors, "size": dec.size, "train_seconds": seconds,
            "trained_seconds": sum(e["seconds"] for e in hist["epochs"]),
            "best_epoch": hist["best_epoch"], "n_parameters": dec.n_parameters,
            "n_train_samples": hist["n_train_samples"], "n_test_samples":
            int(test.scans.shape[0]), "model": str(runs / tag / "model.npz"),
            "hyperparameters": r["model"]["hyperparameters"],
            "n_train_maps": hist["n_train_maps"], "n_train_fields": hist["n_train_fields"],
            "train_errors": hist.get("train_metrics"),
            "val_curve": [{k: e["val"][k] for k in FLOOR_METRICS} for e in hist["epochs"]]}
    out["schedule"] = {"epochs": tr["epochs"], "samples_per_field": data["samples_per_field"],
                       "resample_every": tr["resample_every"], "threads": tr["threads"],
                       "architecture": recipe["model"]["architecture"],
                       "hyperparameters": recipe["model"]["hyperparameters"],
                       "sweep_maps": [m["name"] + f" x{m.get('count', 1)}"
                                      for m in recipe["sweep"]["maps"]],
                       "directions_deg": recipe["sweep"]["directions_deg"],
                       "speeds": recipe["sweep"]["speeds"],
                       "solver": recipe["sweep"]["settings"]}
    return out


def winds_ablation(runs_dir, *, quick: bool = False, epochs: int | None = None,
                   samples_per_field: int | None = None, variants=WIND_VARIANTS,
                   progress: bool = False, seed: int = 0) -> dict:
    """(a) The thesis MLP trained with no wind, ``W_up`` only, ``W_robot`` only and both.

    Returns
    -------
    dict
        :func:`train_variants`'s result, each variant named by the winds given; ``ratio_to_both``
        ``{variant: {speed_error, direction_error_deg}}``: its error over the model given both.
    """
    where = "winds_ablation"
    bad = [v for v in variants if v not in WIND_VARIANTS]
    if bad or not variants:
        raise ValueError(f"The 'variants' parameter of {where} must be among {WIND_VARIANTS}. "
                         f"Got {list(variants)!r} instead.")
    recipe = study_recipe("winds", quick=quick, epochs=epochs,
                          samples_per_field=samples_per_field)
    res = train_variants(recipe, {v: {"model.hyperparameters.winds": v} for v in variants},
                         runs_dir, progress=progress, test_seed=_seed(seed, where))
    if "both" in res["variants"]:
        ref = res["variants"]["both"]["errors"]["model"]
        res["ratio_to_both"] = {v: {k: r["errors"]["model"][k] / ref[k]
                                    for k in ("speed_error", "direction_error_deg")}
                                for v, r in res["variants"].items()}
    return res


def size_study(runs_dir, *, sizes=SIZES, quick: bool = False, epochs: int | None = None,
               samples_per_field: int | None = None, progress: bool = False,
               seed: int = 0) -> dict:
    """(b) The d4-film trained at each grid size H, against ``A_pred / A_total``.

    Returns
    -------
    dict
        :func:`train_variants`'s result, variants named ``"H<size>"``, each with
        ``area_fraction``; ``sizes``.
    """
    where = "size_study"
    sizes = [positive_int(h, "sizes", where) for h in sizes]
    if not sizes or any(h % 2 == 0 or h < 3 for h in sizes):
        raise ValueError(f"The 'sizes' parameter of {where} must be odd integers >= 3. Got "
                         f"{sizes!r} instead.")
    recipe = study_recipe("size", quick=quick, epochs=epochs,
                          samples_per_field=samples_per_field)
    res = train_variants(recipe, {f"H{h}": {"data.size": h} for h in sizes}, runs_dir,
                         progress=progress, test_seed=_seed(seed, where))
    for h in sizes:
        res["variants"][f"H{h}"]["area_fraction"] = float(
            area_fraction(h, recipe["data"]["spacing"]))
    res["sizes"] = sizes
    return res


SCALING_FRACTIONS = (0.25, 0.5, 1.0)
"""The scaling study's fractions of the default recipe's training maps."""
WIDE = {"pool": 3, "conv_channels": 16, "embed": 256, "width": 256, "depth": 3, "modes": 64}
"""The scaling study's wider d4-film (the default recipe's other hyperparameters): about 4 x
the parameters of the shipped model."""


def _training_draws(recipe: dict, excluded=()) -> int:
    """The recipe's training maps but ``excluded``, each counted as often as its group's
    ``data.map_weights`` draws its fields (so that samples per field scaled by the ratio of
    two counts give as many training samples per epoch)."""
    weights = recipe["data"]["map_weights"]
    left_out = set(recipe["data"]["validation_maps"]) | set(excluded)
    return sum(weights.get(g["name"], 1) for g in recipe["sweep"]["maps"]
               for i in range(int(g.get("count", 1))) if f"{g['name']}-{i}" not in left_out)


def map_subset(recipe: dict, fraction: float) -> list[str]:
    """The training maps a fraction of a recipe's sweep leaves out (``data.exclude_maps``).

    Each ``[[sweep.maps]]`` group keeps its first ``max(1, round(fraction x count))`` maps, so
    every kind of map stays in the mix in its proportion; validation maps are never left out.

    Parameters
    ----------
    recipe : dict
        A complete recipe.
    fraction : float
        In (0, 1].

    Returns
    -------
    list of str
        The names of the maps left out, ``"<group>-<i>"``.
    """
    where = "map_subset"
    if not isinstance(fraction, (int, float)) or not 0 < fraction <= 1:
        raise ValueError(f"The 'fraction' parameter of {where} must be in (0, 1]. Got "
                         f"{fraction!r} instead.")
    held = set(recipe["data"]["validation_maps"])
    out = []
    for group in recipe["sweep"]["maps"]:
        names = [f"{group['name']}-{i}" for i in range(int(group.get("count", 1)))]
        names = [n for n in names if n not in held]
        if names:
            out += names[max(1, round(fraction * len(names))):]
    return out


def scaling_recipe(*, quick: bool = False) -> tuple[dict, dict]:
    """The scaling study's recipe and its wide model's hyperparameters (:func:`scaling_study`):
    the default recipe as it was until 2026-12-06 (69 maps, ``default_2026-12-06.toml``, without
    its turned training scenes: the study's figures were measured so; it compares maps and model
    sizes), single models; ``quick``: the tiny recipe for 2 epochs, the wide model at twice its
    widths."""
    from windnav.predict.train import RECIPES, load_recipe

    if quick:
        r = load_recipe(RECIPES / "tiny.toml")
        r["train"]["epochs"] = 2
        hp = r["model"]["hyperparameters"]
        wide_hp = {**hp, **{k: 2 * hp[k] for k in ("embed", "width")}}
    else:
        r = load_recipe(RECIPES / "default_2026-12-06.toml")
        r["train"]["members"] = 1   # the study compares single models
        r["data"]["turn_deg"] = 0
        wide_hp = {**r["model"]["hyperparameters"], **WIDE}
    r["train"]["tensorboard"] = False
    return r, wide_hp


def scaling_study(runs_dir, *, fractions=SCALING_FRACTIONS, wide: bool = True,
                  quick: bool = False, progress: bool = False, seed: int = 0) -> dict:
    """What limits the decoder: the number of training maps, or the model's size?

    The default recipe of 2026-12-06 (sweep, samples, 40-epoch schedule) trained on a fraction
    of its 68 training maps (:func:`map_subset`), each fraction with its samples per field
    scaled up so that every model sees as many training samples per epoch, and the same number
    of steps; and
    at the full sweep a wider d4-film (:data:`WIDE`). The full-sweep arm is the default recipe
    as it was until 2026-12-06, without turned training scenes (so a ``maps-1`` folder linked to
    a finished ``windnav train-decoder`` run of that recipe is reused; :func:`scaling_recipe`).
    Scored on fresh test samples of the held-out map, with the training-set errors (the gap
    between the two is what more maps can close; the training error, what a bigger model can).

    Parameters
    ----------
    runs_dir : str or path-like
        The store (``sweep.zarr``) and one folder per model, resumable.
    fractions : sequence of float
        Fractions of the training maps, in (0, 1].
    wide : bool
        Also train :data:`WIDE` on the full sweep.
    quick : bool
        The tiny recipe (2 training maps), 2 epochs, a wide model of 2 x its widths (tests).
        A fraction that keeps the same maps as a smaller one is dropped.
    progress : bool
    seed : int
        The test samples' seed offset.

    Returns
    -------
    dict
        :func:`train_variants`'s result, variants ``"maps-<fraction>"`` (and ``"wide"``) each
        with ``fraction``; ``fractions``; ``per_doubling``: for each pair of successive
        fractions, the ratio of the test errors per doubling of the maps,
        ``(e2 / e1) ** (1 / log2(n2 / n1))``.
    """
    where = "scaling_study"
    fractions = sorted({float(f) for f in fractions})
    if not fractions:
        raise ValueError(f"The 'fractions' parameter of {where} must list at least one "
                         "fraction. Got none.")
    r, wide_hp = scaling_recipe(quick=quick)
    base = r["data"]["samples_per_field"]
    n_all = _training_draws(r)
    variants, kept = {}, {}
    for f in list(fractions):
        excluded = map_subset(r, f)
        draws = _training_draws(r, excluded)
        if draws in kept.values():  # the same maps as a smaller fraction
            fractions.remove(f)
            continue
        kept[f] = draws
        variants[f"maps-{f:g}"] = {"data.exclude_maps": excluded,
                                   "data.samples_per_field": round(base * n_all / kept[f])}
    if wide:
        variants["wide"] = {"model.hyperparameters": wide_hp}
    res = train_variants(r, variants, runs_dir, progress=progress,
                         test_seed=_seed(seed, where))
    for f in fractions:
        res["variants"][f"maps-{f:g}"]["fraction"] = f
    if wide:
        res["variants"]["wide"]["fraction"] = 1.0
    res["fractions"] = fractions
    res["per_doubling"] = []
    for f1, f2 in zip(fractions[:-1], fractions[1:], strict=True):
        e1 = res["variants"][f"maps-{f1:g}"]["errors"]["model"]
        e2 = res["variants"][f"maps-{f2:g}"]["errors"]["model"]
        doublings = np.log2(kept[f2] / kept[f1])
        res["per_doubling"].append({"from": f1, "to": f2, "maps": [kept[f1], kept[f2]], **{
            k: float((e2[k] / e1[k]) ** (1.0 / doublings)) for k in FLOOR_METRICS}})
    return res


# ----------------------------------------------------------------- averaging (label noise)


def averaging_study(decoder, city, *, speed: float = 6.0, direction_deg: float = 3.75,
                    dx: float = 1.0, dt: float | None = None, protocols=None,
                    samples: int = 4096, seed: int = 0, simulate=None,
                    name: str = "map") -> dict:
    """Score the decoder and its baselines against the mean of a short and of a long average.

    Parameters
    ----------
    decoder : Decoder
    city : windnav.city.City
    speed : float
        Inlet speed, m/s.
    direction_deg : float
        Inlet direction, deg (where the wind blows toward).
    dx : float
        Cell size, m.
    dt : float, optional
        Time step, s (default :func:`windnav.experiments.wind_sweep.auto_dt`, as the sweeps).
    protocols : dict, optional
        ``{label: (spinup_steps, steps)}``, default :data:`AVERAGING_PROTOCOLS`.
    samples : int
        Robot samples, the same positions for every protocol.
    seed : int
        Seed of the samples (positions and scan noise).
    simulate : callable, optional
        Replaces :func:`windnav.flow.simulate` (tests).
    name : str
        The map's label in the result (``"map"``) and in its fields' names (default "map").

    Returns
    -------
    dict
        ``protocols``: per label its steps, ``diagnostics`` (flow-throughs, half-window
        difference), ``errors`` (per model, :func:`windnav.predict.metrics` fields) and
        ``seconds``; ``label_noise``: the RMS and mean over the fluid cells of
        ``|mean_a - mean_b|`` between the first two protocols (m/s, and over ``speed``), and
        ``mean_speed`` (m/s) of the last protocol's mean over the fluid; ``difference``
        (ny, nx) ``|mean_a - mean_b| / speed`` for the figure; the inlet and the map.
    """
    where = "averaging_study"
    speed, dx, dt, samples, seed = _flow_arguments(speed, dx, dt, samples, seed, where)
    protocols = dict(AVERAGING_PROTOCOLS if protocols is None else protocols)
    if len(protocols) < 2:
        raise ValueError(f"The 'protocols' parameter of {where} must name at least two "
                         f"protocols. Got {protocols!r} instead.")
    out, means = {}, []
    for label, (spinup, steps) in protocols.items():
        entry, _, sol = _simulate_and_score(
            decoder, city, simulate, speed=speed, direction_deg=direction_deg, dx=dx, dt=dt,
            spinup_steps=int(spinup), steps=int(steps), samples=samples, seed=seed,
            name=f"{name}/{label}")
        out[label] = {"spinup_steps": int(spinup), "steps": int(steps), **entry}
        means.append((sol.mean_u, sol.mean_v, ~np.asarray(sol.solid, dtype=bool)))
    (ua, va, fluid), (ub, vb, _) = means[0], means[1]
    diff = np.hypot(ua - ub, va - vb)
    d = diff[fluid]
    noise = {"rms_mps": float(np.sqrt(np.mean(d ** 2))), "mean_mps": float(np.mean(d)),
             "rms_over_U": float(np.sqrt(np.mean(d ** 2)) / speed)}
    ul, vl, _ = means[-1]
    return {"map": name, "speed": speed, "direction_deg": float(direction_deg), "dx": dx,
            "dt": dt, "samples": samples, "seed": seed, "protocols": out,
            "label_noise": noise,
            "mean_speed": float(np.hypot(ul, vl)[fluid].mean()),
            "difference": np.where(fluid, diff / speed, np.nan)}


def _flow_arguments(speed, dx, dt, samples, seed, where: str) -> tuple:
    """The label studies' common arguments checked: ``(speed, dx, dt, samples, seed)``, ``dt``
    by default :func:`windnav.experiments.wind_sweep.auto_dt` (as the sweeps)."""
    from windnav.experiments.wind_sweep import auto_dt

    speed = positive_float(speed, "speed", where)
    dx = positive_float(dx, "dx", where)
    dt = auto_dt(dx, speed) if dt is None else positive_float(dt, "dt", where)
    return speed, dx, dt, positive_int(samples, "samples", where), _seed(seed, where)


def _simulate_and_score(decoder, city, simulate, *, speed, direction_deg, dx, dt, spinup_steps,
                        steps, samples, seed, name, **solver):
    """One flow of ``city`` with the given protocol, its mean as a field, ``samples`` robot
    samples at positions fixed by ``seed`` alone (the same for every flow of the same map),
    and the decoder and its baselines scored on them.

    Returns ``({"diagnostics", "errors", "seconds"}, SampleBatch, FlowSolution)``.
    """
    from windnav.experiments.decoder_eval import _score
    from windnav.flow import simulate as flow_simulate
    from windnav.predict import draw_samples, field_from_solution

    t0 = time.perf_counter()
    sol = (simulate or flow_simulate)(city, speed=speed, direction_deg=float(direction_deg),
                                      dx=dx, dt=dt, spinup_steps=spinup_steps, steps=steps,
                                      **solver)
    field = field_from_solution(city, sol, name=name)
    batch = draw_samples(field, samples, rng=np.random.default_rng([seed, 7]), size=decoder.size,
                         spacing=decoder.spacing, scan_noise=0.35, w_robot_noise=0.0)
    errors, _ = _score(decoder, batch, decoder.size, decoder.spacing)
    return ({"diagnostics": sol.diagnostics, "errors": errors,
             "seconds": time.perf_counter() - t0}, batch, sol)


# ------------------------------------------------------------ start (label determinism)

def start_study(decoder, city, *, speed: float = 6.0, direction_deg: float = 3.75,
                dx: float = 1.0, dt: float | None = None, kicks=START_KICKS,
                spinup_steps: int = 100, steps: int = 200, samples: int = 4096, seed: int = 0,
                simulate=None, name: str = "map") -> dict:
    """How much of the thesis-protocol label is fixed by the map and the inlet?

    The flow is started with each symmetry-breaking kick in ``kicks`` (the cross-wind velocity
    the solver gives the near wakes at the start, a fraction of ``speed``: an arbitrary choice
    that a model cannot know) and averaged with the same protocol. At the same robot positions
    and scans, each kick's labels are scored against every other's with the decoder's metrics.
    For any prediction ``p`` and two labels ``a``, ``b`` of the same inputs,
    ``err(p, a) + err(p, b) >= err(a, b)`` for each metric of :data:`FLOOR_METRICS` (a mean of
    per-cell distances), so no model can be closer than ``err(a, b) / 2`` to both: half the
    largest pairwise disagreement is a floor on the error any model can guarantee against these
    labels. (``W_robot``, the label at the robot, differs between kicks as well; its mean
    difference is reported, ``w_robot_difference_mps``.)

    Parameters
    ----------
    decoder : Decoder
    city : windnav.city.City
    speed, direction_deg : float
        Inlet, m/s and deg (where the wind blows toward).
    dx, dt : float
        Cell size, m, and time step, s (default :func:`windnav.experiments.wind_sweep.auto_dt`).
    kicks : sequence of float
        At least two distinct symmetry-breaking kicks, fractions of ``speed``.
    spinup_steps, steps : int
        The averaging protocol (default the thesis's, 100 + 200).
    samples, seed : int
        Robot samples (positions and scan noise from ``seed``, the same for every kick).
    simulate : callable, optional
        Replaces :func:`windnav.flow.simulate` (tests).
    name : str
        The map's label in the result (``"map"``) and in its fields' names (default "map").

    Returns
    -------
    dict
        ``kicks``: per kick ``kick``, ``errors`` (decoder, local, upstream), ``diagnostics``,
        ``seconds``; ``pairs``: per pair of kicks ``a``, ``b``, the metrics of ``b``'s labels
        against ``a``'s and ``w_robot_difference_mps``; ``floor``: half the largest pairwise
        value of each of :data:`FLOOR_METRICS`; ``spread`` (ny, nx): the largest
        ``|mean_a - mean_b|`` over the pairs, over ``speed`` (NaN in buildings), for the
        figure; ``spread_rms_mps`` over the fluid; the inlet, the protocol and the map.
    """
    from windnav.predict.metrics import field_errors

    where = "start_study"
    speed, dx, dt, samples, seed = _flow_arguments(speed, dx, dt, samples, seed, where)
    steps = positive_int(steps, "steps", where)  # spinup_steps: checked by the solver
    kicks = [float(k) for k in kicks]
    if len(set(kicks)) < 2 or len(set(kicks)) != len(kicks) or not np.all(np.isfinite(kicks)):
        raise ValueError(f"The 'kicks' parameter of {where} must hold at least two distinct "
                         f"finite kicks. Got {kicks!r} instead.")
    runs, batches, means = [], [], []
    for kick in kicks:
        entry, batch, sol = _simulate_and_score(
            decoder, city, simulate, speed=speed, direction_deg=direction_deg, dx=dx, dt=dt,
            spinup_steps=spinup_steps, steps=steps, samples=samples, seed=seed,
            name=f"{name}/kick={kick:g}", symmetry_break=kick)
        runs.append({"kick": kick, **entry})
        batches.append(batch)
        means.append((sol.mean_u, sol.mean_v))
    fluid = ~np.asarray(sol.solid, dtype=bool)
    pairs, spread = [], np.zeros(fluid.shape)
    for i in range(len(kicks)):
        for j in range(i + 1, len(kicks)):
            a, b = batches[i], batches[j]
            errors = field_errors(b.labels, a.labels, a.free, a.inlet_speed)
            dw = np.hypot(*(a.w_robot.astype(np.float64) - b.w_robot).T)
            pairs.append({"a": kicks[i], "b": kicks[j],
                          **{m: errors[m] for m in (*FLOOR_METRICS,
                                                    "direction_error_masked_deg")},
                          "w_robot_difference_mps": float(dw.mean())})
            spread = np.maximum(spread, np.hypot(means[i][0] - means[j][0],
                                                 means[i][1] - means[j][1]))
    return {"map": name, "speed": speed, "direction_deg": float(direction_deg), "dx": dx,
            "dt": dt, "spinup_steps": spinup_steps, "steps": steps, "samples": samples,
            "seed": seed, "kicks": runs, "pairs": pairs,
            "floor": {m: 0.5 * max(p[m] for p in pairs) for m in FLOOR_METRICS},
            "spread_rms_mps": float(np.sqrt(np.mean(spread[fluid] ** 2))),
            "spread": np.where(fluid, spread / speed, np.nan)}
