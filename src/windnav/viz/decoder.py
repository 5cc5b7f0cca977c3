"""Figures of the wind flow decoder's evaluation and of one prediction.

- :func:`plot_evaluation`: the pooled errors of the decoder and both baselines (bars, per map
  group), and each (map, inlet) slot's decoder error against the Local baseline's (scatter).
- :func:`plot_prediction`: truth, prediction, speed error and direction error on the decoder's
  ``H x H`` grid around one robot (speed colour, quiver, buildings masked).
"""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
from matplotlib.colors import ListedColormap  # noqa: E402

__all__ = ["plot_evaluation", "plot_prediction"]

_MODELS = ("decoder", "local", "upstream")
_COLOURS = {"decoder": "C0", "local": "C1", "upstream": "C2"}
_METRICS = (("speed_error", "speed error (m/s)"),
            ("direction_error_deg", "direction error (deg)"),
            ("direction_error_masked_deg", "direction error, |u| >= 0.1 U (deg)"),
            ("vector_error", "vector error (m/s)"))


def plot_evaluation(result: dict, path) -> Path:
    """Bars of the pooled errors per model and map group; scatter of the per-slot errors.

    Parameters
    ----------
    result : dict
        :func:`windnav.experiments.decoder_eval.evaluate_decoder`'s result.
    path : str or path-like
        The PNG to write.
    """
    groups = [g for g in ("dense", "windinet") if g in result["pooled"]]
    fig, axes = plt.subplots(2, 4, figsize=(15, 7.5))
    width = 0.8 / len(_MODELS)
    for ax, (metric, label) in zip(axes[0], _METRICS, strict=True):
        for k, model in enumerate(_MODELS):
            values = [result["pooled"][g][model][metric] for g in groups]
            ax.bar(np.arange(len(groups)) + (k - 1) * width, values, width,
                   color=_COLOURS[model], label=model)
        ax.set_xticks(np.arange(len(groups)),
                      [f"{g}\n({result['pooled'][g]['n_slots']} inlets)" for g in groups])
        ax.set_title(label, fontsize=10)
    axes[0, 0].legend(fontsize=8)
    for ax, (metric, label) in zip(axes[1], _METRICS, strict=True):
        for group, marker in (("dense", "o"), ("windinet", "s")):
            recs = [r for r in result["records"] if r["group"] == group]
            if not recs:
                continue
            local = [r["local"][metric] for r in recs]
            dec = [r["decoder"][metric] for r in recs]
            sc = ax.scatter(local, dec, c=[r["speed"] for r in recs], cmap="viridis",
                            vmin=2, vmax=10, marker=marker, edgecolors="k", linewidths=0.4,
                            label=group)
        lim = ax.get_xlim()[1] if result["records"] else 1.0
        lim = max(lim, ax.get_ylim()[1])
        ax.plot([0, lim], [0, lim], "k:", lw=0.8)
        ax.set_xlim(0, lim)
        ax.set_ylim(0, lim)
        ax.set_xlabel(f"Local: {label}", fontsize=9)
        ax.set_ylabel(f"decoder: {label}", fontsize=9)
    if result["records"]:
        fig.colorbar(sc, ax=axes[1, -1], label="inlet speed (m/s)")
        axes[1, 0].legend(fontsize=8)
    d = result["decoder"]
    fig.suptitle(f"Wind flow decoder ({d['architecture']}, H = {d['size']}) vs baselines: "
                 f"top, pooled over samples; bottom, one point per (map, inlet)")
    return _save(fig, path)


def _panel(ax, offsets, centre, field, free, colour, cmap, label, vmin, vmax, arrows=None):
    x = centre[0] + offsets
    y = centre[1] + offsets
    data = np.where(free, colour, np.nan)
    im = ax.pcolormesh(x, y, data, shading="nearest", cmap=cmap, vmin=vmin, vmax=vmax)
    plt.colorbar(im, ax=ax, label=label, fraction=0.046, pad=0.04)
    if arrows is not None:
        u = np.where(free, arrows[0], np.nan)
        v = np.where(free, arrows[1], np.nan)
        ax.quiver(x, y, u, v, color="w", scale_units="xy", angles="xy",
                  scale=max(np.nanmax(np.hypot(u, v)), 1e-6) / (offsets[1] - offsets[0])
                  if offsets.size > 1 else None, width=0.004)
    ax.pcolormesh(x, y, np.where(free, np.nan, 1.0), shading="nearest",
                  cmap=ListedColormap(["0.3"]))  # buildings (and cells off the solver grid)
    ax.plot(*centre, "r+", ms=12, mew=2)
    ax.set_aspect("equal")
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")


def plot_prediction(pred: dict, path, *, title: str = "") -> Path:
    """Truth, prediction, speed error and direction error around one robot (one figure).

    Parameters
    ----------
    pred : dict
        :func:`windnav.experiments.decoder_eval.predict_at`'s result.
    path : str or path-like
        The PNG to write.
    title : str
        Prefix of the figure title (the metrics follow).
    """
    o, c, free = pred["offsets"], pred["position"], pred["free"]
    truth, guess = np.asarray(pred["truth"], float), np.asarray(pred["prediction"], float)
    st, sp = np.hypot(*truth), np.hypot(*guess)
    vmax = max(np.nanmax(np.where(free, st, np.nan)) if free.any() else 1.0,
               np.nanmax(np.where(free, sp, np.nan)) if free.any() else 1.0)
    cos = (truth * guess).sum(0) / np.maximum(st * sp, 1e-18)
    angle = np.degrees(np.arccos(np.clip(cos, -1, 1)))
    fig, axes = plt.subplots(2, 2, figsize=(11, 10))
    _panel(axes[0, 0], o, c, truth, free, st, "viridis", "speed (m/s)", 0, vmax, truth)
    axes[0, 0].set_title("truth (mean solver field)")
    _panel(axes[0, 1], o, c, guess, free, sp, "viridis", "speed (m/s)", 0, vmax, guess)
    axes[0, 1].set_title("decoder prediction")
    err = np.abs(sp - st)
    _panel(axes[1, 0], o, c, None, free, err, "magma", "| |û| - |u| | (m/s)", 0,
           max(float(np.nanmax(np.where(free, err, np.nan))) if free.any() else 1.0, 1e-6))
    axes[1, 0].set_title("speed error")
    _panel(axes[1, 1], o, c, None, free, angle, "magma", "direction error (deg)", 0, 180)
    axes[1, 1].set_title("direction error")
    m = pred["metrics"]
    d, lo, up = m["decoder"], m["local"], m["upstream"]
    fig.suptitle(
        f"{title}decoder: speed {d['speed_error']:.2f} m/s, direction "
        f"{d['direction_error_deg']:.1f} deg, vector {d['vector_error']:.2f} m/s\n"
        f"Local: {lo['speed_error']:.2f} m/s, {lo['direction_error_deg']:.1f} deg; "
        f"Upstream: {up['speed_error']:.2f} m/s, {up['direction_error_deg']:.1f} deg; "
        f"W_up ({pred['w_up'][0]:.2f}, {pred['w_up'][1]:.2f}), W_robot "
        f"({pred['w_robot'][0]:.2f}, {pred['w_robot'][1]:.2f}) m/s", fontsize=10)
    return _save(fig, path)


def _save(fig, path) -> Path:
    path = Path(path)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
