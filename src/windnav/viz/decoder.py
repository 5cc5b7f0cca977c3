"""Figures of the wind flow decoder's evaluation and of one prediction.

- :func:`plot_evaluation`: the pooled errors of the decoder and both baselines (bars, per map
  group), and each (map, inlet) slot's decoder error against the Local baseline's (scatter).
- :func:`plot_prediction`: truth, prediction, speed error and direction error on the decoder's
  ``H x H`` grid around one robot (speed colour, quiver, buildings masked).
- The studies of :mod:`windnav.experiments.decoder_studies`: :func:`plot_eigenflows`,
  :func:`plot_gradients`, :func:`plot_mosaic`, :func:`plot_winds_ablation`,
  :func:`plot_size_study`.
"""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.colors import ListedColormap

from windnav._console import closes_figures_on_error, save_and_close
from windnav.predict.metrics import direction_error_cells
from windnav.viz import check_result, figure_path
from windnav.viz.nav_compare import colour_extend

__all__ = ["plot_averaging", "plot_eigenflows", "plot_evaluation", "plot_gradients", "plot_mosaic",
           "plot_prediction", "plot_size_study", "plot_start", "plot_winds_ablation"]

PALETTE_FORMATS = ("png",)
"""What the 128-colour plotters (eigenflows, gradients, mosaic) write: PNG bytes, whatever the
suffix."""

_MODELS = ("decoder", "local", "upstream")
_COLOURS = {"decoder": "C0", "local": "C1", "upstream": "C2"}
_METRICS = (("speed_error", "speed error (m/s)"),
            ("direction_error_deg", "direction error (deg)"),
            ("direction_error_masked_deg", "direction error, |u| >= 0.1 U (deg)"),
            ("vector_error", "vector error (m/s)"))


@closes_figures_on_error
def plot_evaluation(result: dict, path) -> Path:
    """Bars of the pooled errors per model and map group; scatter of the per-slot errors.

    Parameters
    ----------
    result : dict
        :func:`windnav.experiments.decoder_eval.evaluate_decoder`'s result.
    path : str or path-like
        The PNG to write.
    """
    check_result(
        result, ("pooled", "records", "decoder"), "plot_evaluation",
        "windnav.experiments.decoder_eval.evaluate_decoder")
    path = figure_path(path, "plot_evaluation")
    groups = [g for g in ("dense", "windinet", "file") if g in result["pooled"]]
    models = tuple(result.get("models", _MODELS))
    compared = [m for m in models if m not in _MODELS]
    colours = {**_COLOURS, **{m: f"C{3 + k}" for k, m in enumerate(compared)}}
    fig, axes = plt.subplots(2, 4, figsize=(15, 7.5))
    width = 0.8 / len(models)
    for ax, (metric, label) in zip(axes[0], _METRICS, strict=True):
        for k, model in enumerate(models):
            values = [result["pooled"][g][model][metric] for g in groups]
            ax.bar(np.arange(len(groups)) + (k - (len(models) - 1) / 2) * width, values, width,
                   color=colours[model], label=model)
        ax.set_xticks(np.arange(len(groups)),
                      [f"{g}\n({result['pooled'][g]['n_slots']} inlets)" for g in groups])
        ax.set_title(label, fontsize=10)
    axes[0, 0].legend(fontsize=8)
    for ax, (metric, label) in zip(axes[1], _METRICS, strict=True):
        for group, marker in (("dense", "o"), ("windinet", "s"), ("file", "D")):
            recs = [r for r in result["records"] if r["group"] == group]
            if not recs:
                continue
            local = [r["local"][metric] for r in recs]
            dec = [r["decoder"][metric] for r in recs]
            sc = ax.scatter(local, dec, c=[r["speed"] for r in recs], cmap="viridis",
                            vmin=2, vmax=10, marker=marker, edgecolors="k", linewidths=0.4,
                            label=group)
            for model in compared:
                ax.scatter(local, [r[model][metric] for r in recs], marker=marker,
                           facecolors="none", edgecolors=colours[model], linewidths=0.8,
                           label=f"{model}, {group}")
        lim = ax.get_xlim()[1] if result["records"] else 1.0
        lim = max(lim, ax.get_ylim()[1])
        ax.plot([0, lim], [0, lim], "k:", lw=0.8)
        ax.set_xlim(0, lim)
        ax.set_ylim(0, lim)
        ax.set_xlabel(f"Local: {label}", fontsize=9)
        ax.set_ylabel(f"decoder{' (filled)' if compared else ''}: {label}", fontsize=9)
    if result["records"]:
        fig.colorbar(sc, ax=axes[1, -1], label="inlet speed (m/s)")
        axes[1, 0].legend(fontsize=8)
    d = result["decoder"]
    fig.suptitle(f"Wind flow decoder ({d['architecture']}, H = {d['size']}) vs baselines: "
                 f"top, pooled over samples; bottom, one point per (map, inlet)")
    return _save(fig, path)


def _panel(ax, offsets, centre, field, free, colour, cmap, label, vmin, vmax, arrows=None,
           arrow_speed=None):
    """One panel; ``arrow_speed`` (m/s) is drawn one cell long, the same in every panel that
    passes it (each panel's own maximum made truth and prediction arrows incomparable)."""
    x = centre[0] + offsets
    y = centre[1] + offsets
    data = np.where(free, colour, np.nan)
    im = ax.pcolormesh(x, y, data, shading="nearest", cmap=cmap, vmin=vmin, vmax=vmax)
    plt.colorbar(im, ax=ax, label=label, fraction=0.046, pad=0.04)
    if arrows is not None:
        u = np.where(free, arrows[0], np.nan)
        v = np.where(free, arrows[1], np.nan)
        speed = arrow_speed if arrow_speed is not None else np.nanmax(np.hypot(u, v))
        ax.quiver(x, y, u, v, color="w", scale_units="xy", angles="xy",
                  scale=max(speed, 1e-6) / (offsets[1] - offsets[0])
                  if offsets.size > 1 else None, width=0.004)
    ax.pcolormesh(x, y, np.where(free, np.nan, 1.0), shading="nearest",
                  cmap=ListedColormap(["0.3"]))  # buildings (and cells off the solver grid)
    ax.plot(*centre, "r+", ms=12, mew=2)
    ax.set_aspect("equal")
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")


@closes_figures_on_error
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
    check_result(
        pred, ("offsets", "position", "free", "truth", "prediction", "metrics", "w_up", "w_robot"),
        "plot_prediction", "windnav.experiments.decoder_eval.predict_at", "pred")
    path = figure_path(path, "plot_prediction")
    o, c, free = pred["offsets"], pred["position"], pred["free"]
    truth, guess = np.asarray(pred["truth"], float), np.asarray(pred["prediction"], float)
    st, sp = np.hypot(*truth), np.hypot(*guess)
    vmax = max(np.nanmax(np.where(free, st, np.nan)) if free.any() else 1.0,
               np.nanmax(np.where(free, sp, np.nan)) if free.any() else 1.0)
    angle = direction_error_cells(guess, truth)  # NaN (blank) where the metric counts none
    fig, axes = plt.subplots(2, 2, figsize=(11, 10))
    _panel(axes[0, 0], o, c, truth, free, st, "viridis", "speed (m/s)", 0, vmax, truth,
           arrow_speed=vmax)
    axes[0, 0].set_title(f"truth (mean solver field); an arrow one cell long: {vmax:.2f} m/s")
    _panel(axes[0, 1], o, c, guess, free, sp, "viridis", "speed (m/s)", 0, vmax, guess,
           arrow_speed=vmax)
    axes[0, 1].set_title("decoder prediction (arrows on the truth's scale)")
    err = np.abs(sp - st)
    _panel(axes[1, 0], o, c, None, free, err, "magma", "| |û| - |u| | (m/s)", 0,
           max(float(np.nanmax(np.where(free, err, np.nan))) if free.any() else 1.0, 1e-6))
    axes[1, 0].set_title("speed error")
    # the colour scale up to the largest error (at least 10 deg), not always 180: errors of
    # 20 deg drew the whole panel black (figures audit, 2026-12-05)
    counted = np.where(free, angle, np.nan)
    worst = float(np.nanmax(counted)) if np.isfinite(counted).any() else 180.0
    _panel(axes[1, 1], o, c, None, free, angle, "magma", "direction error (deg)", 0,
           min(max(worst, 10.0), 180.0))
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


def _save(fig, path, dpi: int = 110, palette: bool = False) -> Path:
    path = Path(path)
    fig.tight_layout()
    if palette:
        # 128 colours (PIL's median cut): the whole-map fields stay a few hundred kB
        import io

        from PIL import Image

        buf = io.BytesIO()
        save_and_close(fig, buf, dpi=dpi, format="png")
        buf.seek(0)
        Image.open(buf).convert("RGB").quantize(128).save(path, format="PNG", optimize=True)
        return path
    save_and_close(fig, path, dpi=dpi)
    return path


# ------------------------------------------------------------------------------- studies


@closes_figures_on_error
def plot_eigenflows(result: dict, path, *, n_show: int = 8) -> Path:
    """Cumulative explained variance of the eigenflows (both frames) and the first modes.

    Parameters
    ----------
    result : dict
        :func:`windnav.experiments.decoder_studies.eigenflow_study`'s result.
    path : str or path-like
        The PNG to write.
    n_show : int
        Modes drawn (speed of the mode as colour, its vectors as arrows).

    Notes
    -----
    The number of modes that explain 98 % of the variance is marked on each frame's curve and
    given in the legend.
    """
    check_result(
        result, ("world", "canonical", "size", "spacing", "n_fields"), "plot_eigenflows",
        "windnav.experiments.decoder_studies.eigenflow_study")
    path = figure_path(path, "plot_eigenflows", PALETTE_FORMATS)
    world, canon = result["world"], result["canonical"]
    n_show = min(n_show, world["modes"].shape[0])
    cols = max(4, (n_show + 1) // 2 + 1)
    fig = plt.figure(figsize=(3.0 * cols + 0.6, 7.0))
    grid = fig.add_gridspec(2, cols + 1, width_ratios=[1.0] * cols + [0.06])  # + colour bar
    ax = fig.add_subplot(grid[:, 0])
    for res, label, colour in ((world, "world frame", "C0"), (canon, "canonical D4 frame", "C1")):
        cum = np.asarray(res["cumulative"])
        k = np.arange(1, cum.size + 1)
        n98 = res["n_modes"]["0.98"]
        # the count in the legend, not as text by the marker: both curves pass there
        ax.plot(k, 100 * cum, color=colour, label=f"{label} (98 %: {n98} modes)")
        ax.plot(n98, 100 * cum[n98 - 1], "o", color=colour)
    ax.axhline(98, color="k", ls=":", lw=0.8)
    ax.axvline(16, color="0.5", ls="--", lw=0.8, label="16 modes (thesis: >= 98 %)")
    ax.set_xscale("log")
    ax.set_ylim(max(0.0, 100 * min(world["cumulative"][0], canon["cumulative"][0]) - 5), 100.5)
    ax.set_xlabel("number of eigenflows")
    ax.set_ylabel("cumulative explained variance (%)")
    # below the panel: inside it, a legend this wide would cover the curves' start
    ax.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.09), frameon=False)
    h = result["size"]
    o = (np.arange(h) - (h - 1) / 2) * result["spacing"]
    ratio = world["explained_variance_ratio"]
    # one colour scale for every mode, with its bar: the modes are unit-norm, so their cell
    # magnitudes compare (a scale per panel, without a bar, said nothing; figures audit)
    top = float(max(np.hypot(*world["modes"][m]).max() for m in range(n_show)))
    mode_axes = []
    for m in range(n_show):
        a = fig.add_subplot(grid[m // (cols - 1), 1 + m % (cols - 1)])
        mode_axes.append(a)
        mode = world["modes"][m]
        sp = np.hypot(mode[0], mode[1])
        mesh = a.pcolormesh(o, o, sp, shading="nearest", cmap="viridis", vmin=0.0, vmax=top)
        step = max(1, h // 9)
        a.quiver(o[::step], o[::step], mode[0][::step, ::step], mode[1][::step, ::step],
                 color="w", width=0.006)
        a.set_title(f"mode {m + 1}: {100 * ratio[m]:.1f} %", fontsize=9)
        a.set_aspect("equal")
        a.set_xticks([])
        a.set_yticks([])
    if mode_axes:
        fig.colorbar(mesh, cax=fig.add_subplot(grid[:, -1]),
                     label="|mode| per cell (unit-norm modes)")
    fig.suptitle(f"Eigenflows of {result['n_fields']} local label fields (H = {h}, divided by "
                 f"the inlet speed); modes in the world frame", fontsize=11)
    return _save(fig, path, dpi=80, palette=True)


@closes_figures_on_error
def plot_gradients(result: dict, path) -> Path:
    """Predicted against true wind gradients at the robot, one panel per component.

    Parameters
    ----------
    result : dict
        :func:`windnav.experiments.decoder_studies.gradient_study`'s result.
    path : str or path-like
        The PNG to write.
    """
    check_result(
        result, ("decoder", "decoder_per_U"), "plot_gradients",
        "windnav.experiments.decoder_studies.gradient_study")
    path = figure_path(path, "plot_gradients", PALETTE_FORMATS)
    names = ("du/dx", "du/dy", "dv/dx", "dv/dy")
    res = result["decoder"]
    fig, axes = plt.subplots(1, 4, figsize=(16, 4.4))
    for k, (ax, name) in enumerate(zip(axes, names, strict=True)):
        t, p = res["true"][:, k], res["pred"][:, k]
        lim = float(np.quantile(np.abs(np.concatenate([t, p])), 0.995)) if t.size else 1.0
        ax.hexbin(t, p, gridsize=60, extent=(-lim, lim, -lim, lim), bins="log", cmap="viridis",
                  mincnt=1)
        ax.plot([-lim, lim], [-lim, lim], "r:", lw=1)
        ax.set_xlim(-lim, lim)
        ax.set_ylim(-lim, lim)
        ax.set_aspect("equal")
        ax.set_xlabel(f"true {name} (1/s)")
        ax.set_ylabel(f"predicted {name} (1/s)")
        ax.set_title(f"{name}: R² {res['r2'][name]:.2f}, r {res['pearson_r'][name]:.2f} "
                     f"(per U: R² {result['decoder_per_U']['r2'][name]:.2f})", fontsize=9)
    fig.suptitle(f"Wind gradients at the robot by central differences: decoder vs mean field "
                 f"({res['n_samples']} samples with the 5 centre cells free)", fontsize=11)
    return _save(fig, path, palette=True)


def _bin_labels(edges, unit: str) -> list[str]:
    return [f"{a:g}-{b:g}{unit}" if np.isfinite(b) else f">= {a:g}{unit}"
            for a, b in zip(edges[:-1], edges[1:], strict=True)]


@closes_figures_on_error
def plot_direction(result: dict, path) -> Path:
    """Mean direction error per bin of the true speed over the inlet's and of the distance
    from the robot, for the decoder and both baselines, with each bin's share of the cells
    and its contribution to the decoder's mean.

    Parameters
    ----------
    result : dict
        :func:`windnav.experiments.decoder_studies.direction_study`'s result.
    path : str or path-like
        The PNG to write.
    """
    check_result(
        result, ("models", "n_samples_drawn"), "plot_direction",
        "windnav.experiments.decoder_studies.direction_study")
    path = figure_path(path, "plot_direction")
    models = result["models"]
    dec = models["decoder"]
    colours = {"decoder": "C0", "local": "C1", "upstream": "C2"}
    fig, axes = plt.subplots(1, 2, figsize=(13, 4.6))
    for ax, (axis, edges, unit, xlabel) in zip(axes, (
            ("by_speed", dec["speed_edges"], " U", "true speed |u| / inlet speed U"),
            ("by_radius", dec["radius_edges"], " m", "distance of the cell from the robot")),
            strict=True):
        labels = _bin_labels(np.asarray(edges, dtype=float), unit)
        x = np.arange(len(labels))
        w = 0.8 / len(models)
        for k, (m, res) in enumerate(models.items()):
            ax.bar(x + (k - (len(models) - 1) / 2) * w, res[axis]["mean_deg"], w,
                   color=colours.get(m, f"C{k + 3}"),
                   label=f"{m}: mean {res['direction_error_deg']:.1f} deg")
        for xi, share, contrib in zip(x, dec[axis]["share"], dec[axis]["contribution_deg"],
                                      strict=True):
            ax.annotate(f"{100 * share:.0f} % of cells\n+{contrib:.1f} deg", (xi, 0),
                        xytext=(0, -30), textcoords="offset points", ha="center", fontsize=7)
        ax.set_xticks(x, labels, fontsize=8)
        ax.set_xlabel(xlabel, labelpad=28)
        ax.set_ylabel("mean direction error in the bin (deg)")
        ax.set_ylim(bottom=0)
    axes[0].legend(fontsize=8)
    fig.suptitle("Where the direction error lies (annotations: the bin's share of the cells and "
                 f"what it adds to the decoder's mean); {result['n_samples_drawn']:,} samples",
                 fontsize=10)
    return _save(fig, path)


@closes_figures_on_error
def plot_basis(result: dict, path, *, n_show: int = 24) -> Path:
    """The basis oracle beside the decoder and the baselines (speed and direction errors),
    and the decoder's ``R^2`` on each of the labels' eigenflows within its modes' span.

    Parameters
    ----------
    result : dict
        :func:`windnav.experiments.decoder_studies.basis_study`'s result.
    path : str or path-like
        The PNG to write.
    n_show : int
        Eigenflows shown, largest first.
    """
    check_result(
        result, ("errors", "modes", "n_modes", "n_samples", "r2_total"), "plot_basis",
        "windnav.experiments.decoder_studies.basis_study")
    path = figure_path(path, "plot_basis")
    from windnav.experiments.decoder_eval import ACCEPTANCE

    errors, modes = result["errors"], result["modes"]
    names = ["upstream", "local", "decoder", "basis_oracle"]
    colours = ["C2", "C1", "C0", "C3"]
    eig = result.get("eigenflow_fields")
    rows = 1 if eig is None else 2
    fig = plt.figure(figsize=(19, 4.6 * rows))
    grid = fig.add_gridspec(rows, 4, width_ratios=[1, 1, 2, 1.4])
    axes = [fig.add_subplot(grid[0, i]) for i in range(4)]
    for ax, metric, label in ((axes[0], "speed_error", "speed error (m/s)"),
                              (axes[1], "direction_error_deg", "direction error (deg)")):
        values = [errors[n][metric] for n in names]
        ax.bar(names, values, color=colours)
        for i, v in enumerate(values):
            ax.annotate(f"{v:.2f}", (i, v), xytext=(0, 2), textcoords="offset points",
                        ha="center", fontsize=8)
        ax.axhline(ACCEPTANCE[metric], color="k", ls="--", lw=1,
                   label=f"issue 9's target {ACCEPTANCE[metric]:g}")
        ax.legend(fontsize=8)
        ax.set_ylabel(label)
        ax.tick_params(axis="x", labelsize=8, rotation=20)
    k = min(n_show, len(modes["r2"]))
    x = np.arange(1, k + 1)
    ax = axes[2]
    ax.bar(x - 0.2, 100 * np.asarray(modes["variance_share"][:k]), 0.4, color="C7",
           label="share of the labels' variance")
    ax.bar(x + 0.2, 100 * np.asarray(modes["error_share"][:k]), 0.4, color="C0",
           label="share of the decoder's squared error")
    ax.set_xlabel("eigenflow of the labels within the decoder's modes (largest first)")
    ax.set_ylabel("%")
    right = ax.twinx()
    right.plot(x, modes["r2"][:k], "k.-", label="decoder R^2 on it")
    right.set_ylim(-0.5, 1.0)
    right.axhline(0.0, color="k", lw=0.5)
    right.set_ylabel("R^2")
    handles = ax.get_legend_handles_labels()
    extra = right.get_legend_handles_labels()
    # above the panel, off the data: no corner inside it is free of both axes' bars and line
    ax.legend(handles[0] + extra[0], handles[1] + extra[1], fontsize=8, loc="lower center",
              bbox_to_anchor=(0.5, 1.01), ncol=2, frameon=False)
    # the decoder with its first k eigenflows right: 0 is the decoder, all of them the oracle
    fixed = {int(n): e for n, e in result.get("fixed_modes", {}).items()}
    ks = [0, *sorted(fixed), result["n_modes"]]
    series = [errors["decoder"], *(fixed[n] for n in sorted(fixed)), errors["basis_oracle"]]
    ax = axes[3]
    ax.plot(ks, [e["speed_error"] for e in series], "o-", color="C0",
            label="speed error (m/s)")
    ax.axhline(ACCEPTANCE["speed_error"], color="C0", ls="--", lw=1)
    ax.set_xscale("symlog", linthresh=1)
    ax.set_xlabel("leading eigenflows given the oracle's coefficients")
    ax.set_ylabel("speed error (m/s)", color="C0")
    right = ax.twinx()
    right.plot(ks, [e["direction_error_deg"] for e in series], "s-", color="C3",
               label="direction error (deg)")
    right.axhline(ACCEPTANCE["direction_error_deg"], color="C3", ls="--", lw=1)
    right.set_ylabel("direction error (deg)", color="C3")
    ax.set_ylim(bottom=0)
    right.set_ylim(bottom=0)
    ax.set_title("the decoder with its largest eigenflows right\n(dashed: issue 9's targets)",
                 fontsize=9)
    if eig is not None:
        eig = np.asarray(eig, dtype=float)
        c = np.asarray(result["offsets"], dtype=float)
        half = (c[1] - c[0]) / 2 if c.size > 1 else 0.5
        ext = (c[0] - half, c[-1] + half, c[0] - half, c[-1] + half)
        sub = grid[1, :].subgridspec(1, eig.shape[0] + 1,
                                     width_ratios=[1.0] * eig.shape[0] + [0.04])
        step = max(1, c.size // 8)
        top = float(max(np.hypot(*f).max() for f in eig))  # one scale, with its bar
        for i, f in enumerate(eig):
            ax = fig.add_subplot(sub[0, i])
            image = ax.imshow(np.hypot(*f), origin="lower", extent=ext, cmap="viridis",
                              vmin=0.0, vmax=top)
            ax.quiver(c[::step], c[::step], f[0][::step, ::step], f[1][::step, ::step])
            ax.plot(0, 0, "r+")
            ax.set_title(f"eigenflow {i + 1}: {100 * modes['variance_share'][i]:.0f} % of the "
                         f"variance, decoder R^2 {modes['r2'][i]:.2f}", fontsize=9)
            ax.set_xlabel("m from the robot (canonical frame: the inlet toward +x to 45 deg)",
                          fontsize=8)
        fig.colorbar(image, cax=fig.add_subplot(sub[0, -1]),
                     label="|eigenflow| per cell (unit norm)")
    fig.suptitle(f"The decoder's {result['n_modes']} output modes: the best fit of each label "
                 f"(basis oracle) against the prediction; R^2 over all {result['n_modes']}: "
                 f"{result['r2_total']:.2f}; {result['n_samples']:,} samples", fontsize=10)
    return _save(fig, path)


@closes_figures_on_error
def plot_mosaic(result: dict, path) -> Path:
    """Truth, mosaic prediction, speed error and direction error over a whole map.

    Parameters
    ----------
    result : dict
        :func:`windnav.experiments.decoder_studies.mosaic`'s result.
    path : str or path-like
        The PNG to write.
    """
    check_result(
        result, ("x", "y", "truth", "prediction", "free", "covered", "n_robots", "size", "robots",
        "metrics", "w_up", "name", "coverage"), "plot_mosaic",
        "windnav.experiments.decoder_studies.mosaic")
    path = figure_path(path, "plot_mosaic", PALETTE_FORMATS)
    x, y = result["x"], result["y"]
    truth = np.asarray(result["truth"], float)
    pred = np.asarray(result["prediction"], float)
    ok = result["free"] & result["covered"]
    st, sp = np.hypot(*truth), np.hypot(*pred)
    vmax = float(np.quantile(st[result["free"]], 0.995)) if result["free"].any() else 1.0
    angle = direction_error_cells(pred, truth)  # NaN (blank) where the metric counts none
    err = np.abs(sp - st)
    fig, axes = plt.subplots(2, 2, figsize=(13, 12))
    panels = (
        (axes[0, 0], np.where(result["free"], st, np.nan), "viridis", 0, vmax, "speed (m/s)",
         "truth (mean solver field)"),
        (axes[0, 1], np.where(ok, sp, np.nan), "viridis", 0, vmax, "speed (m/s)",
         f"decoder mosaic ({result['n_robots']} robots, H = {result['size']}; white: free "
         "cells no robot reaches)"),
        (axes[1, 0], np.where(ok, err, np.nan), "magma", 0,
         float(np.quantile(err[ok], 0.99)) if ok.any() else 1.0, "| |û| - |u| | (m/s)",
         "speed error"),
        (axes[1, 1], np.where(ok, angle, np.nan), "magma", 0, 90, "direction error (deg)",
         "direction error"))
    for ax, data, cmap, lo, hi, label, title in panels:
        im = ax.imshow(data, origin="lower", extent=(x[0], x[-1], y[0], y[-1]), cmap=cmap,
                       vmin=lo, vmax=hi, interpolation="nearest")
        ax.imshow(np.where(result["free"], np.nan, 1.0), origin="lower",
                  extent=(x[0], x[-1], y[0], y[-1]), cmap=ListedColormap(["0.3"]),
                  interpolation="nearest")
        # the speed and speed-error scales stop at a quantile: an arrow says the data pass it
        plt.colorbar(im, ax=ax, label=label, fraction=0.046, pad=0.04, extend=colour_extend(im))
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("x east (m)")
        ax.set_ylabel("y north (m)")
    r = result["robots"]
    axes[0, 1].plot(r[:, 0], r[:, 1], "r.", ms=1.0)
    m = result["metrics"]
    d, lo, up = m["decoder"], m["local"], m["upstream"]
    w = result["w_up"]
    fig.suptitle(
        f"{result['name']}: W_up ({w[0]:.2f}, {w[1]:.2f}) m/s; map-wide over "
        f"{100 * result['coverage']:.1f} % of the free cells: decoder speed "
        f"{d['speed_error']:.2f} m/s, direction {d['direction_error_deg']:.1f} deg; Local "
        f"{lo['speed_error']:.2f} m/s, {lo['direction_error_deg']:.1f} deg; Upstream "
        f"{up['speed_error']:.2f} m/s, {up['direction_error_deg']:.1f} deg", fontsize=10)
    return _save(fig, path, dpi=72, palette=True)


def _variant_bars(ax, names, result, metric, label):
    model = [result["variants"][n]["errors"]["model"][metric] for n in names]
    ax.bar(np.arange(len(names)), model, color="C0", label="model")
    for base, colour in (("local", "C1"), ("upstream", "C2")):
        ax.axhline(result["variants"][names[0]]["errors"][base][metric], color=colour, ls="--",
                   label=f"{base} baseline")
    ax.set_xticks(np.arange(len(names)), names)
    ax.set_ylabel(label)


@closes_figures_on_error
def plot_winds_ablation(result: dict, path) -> Path:
    """Test errors of the models given no wind, W_up, W_robot or both, with the baselines.

    Parameters
    ----------
    result : dict
        :func:`windnav.experiments.decoder_studies.winds_ablation`'s result.
    path : str or path-like
        The PNG to write.
    """
    check_result(
        result, ("variants", "schedule"), "plot_winds_ablation",
        "windnav.experiments.decoder_studies.winds_ablation")
    path = figure_path(path, "plot_winds_ablation")
    names = list(result["variants"])
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2))
    for ax, (metric, label) in zip(axes, (_METRICS[0], _METRICS[1], _METRICS[3]), strict=True):
        _variant_bars(ax, names, result, metric, label)
        ax.set_xlabel("winds given to the model")
    axes[0].legend(fontsize=8)
    s = result["schedule"]
    fig.suptitle(f"Winds ablation: {s['architecture']} ({_settings(s['hyperparameters'])}), "
                 f"{s['epochs']} epochs x {result['variants'][names[0]]['n_train_samples']} "
                 "samples; test samples of a held-out map", fontsize=10)
    return _save(fig, path)


def _settings(values) -> str:
    """A mapping of settings as title text, ``"width 256, depth 3"`` (not its Python repr);
    nested mappings in parentheses, anything else as ``str``."""
    if not isinstance(values, dict):
        return str(values)
    return ", ".join(f"{k} ({_settings(v)})" if isinstance(v, dict) else f"{k} {v}"
                     for k, v in values.items())


@closes_figures_on_error
def plot_size_study(result: dict, path) -> Path:
    """Test errors of the models trained at each H against ``A_pred / A_total``.

    Parameters
    ----------
    result : dict
        :func:`windnav.experiments.decoder_studies.size_study`'s result.
    path : str or path-like
        The PNG to write.
    """
    check_result(
        result, ("variants", "schedule"), "plot_size_study",
        "windnav.experiments.decoder_studies.size_study")
    path = figure_path(path, "plot_size_study")
    names = list(result["variants"])
    frac = [100 * result["variants"][n]["area_fraction"] for n in names]
    fig, axes = plt.subplots(1, 3, figsize=(14, 4.2))
    for ax, (metric, label) in zip(axes, (_METRICS[0], _METRICS[1], _METRICS[3]), strict=True):
        for who, colour, marker in (("model", "C0", "o"), ("local", "C1", "s"),
                                    ("upstream", "C2", "^")):
            ax.plot(frac, [result["variants"][n]["errors"][who][metric] for n in names],
                    marker=marker, color=colour,
                    label="d4-film" if who == "model" else f"{who} baseline")
        for f, n in zip(frac, names, strict=True):
            ax.annotate(n.replace("H", "H="), (f, result["variants"][n]["errors"]["model"][
                metric]), textcoords="offset points", xytext=(3, 5), fontsize=7)
        ax.set_xscale("log")
        ax.set_xlabel("A_pred / A_total = (1/π)(H / D_max)² (%)")
        ax.set_ylabel(label)
    axes[0].legend(fontsize=8)
    s = result["schedule"]
    fig.suptitle(f"Size study: d4-film, {s['epochs']} epochs; test samples of a held-out map",
                 fontsize=10)
    return _save(fig, path)


@closes_figures_on_error
def plot_noise(result: dict, path) -> Path:
    """Each model's errors against the noise on ``W_robot`` (fraction of the inlet speed).

    Top: the errors themselves, the baselines included (down to 0). Bottom, on an axis of its
    own: each decoder's error minus the first decoder's at the lowest level (the exact
    ``W_robot`` at level 0), the cost of the noise and the gaps between the decoders, which
    the top row's range hides.

    Parameters
    ----------
    result : dict
        :func:`windnav.experiments.decoder_studies.noise_study`'s result.
    path : str or path-like
        The PNG to write.
    """
    check_result(
        result, ("levels", "errors", "n_samples"), "plot_noise",
        "windnav.experiments.decoder_studies.noise_study")
    path = figure_path(path, "plot_noise")
    levels = result["levels"]
    fig, axes = plt.subplots(2, 2, figsize=(11, 7.6), sharex=True)
    others = [m for m in result["errors"] if m not in ("local", "upstream")]
    styles = {m: (f"C{[0, 3, 4, 5, 6][k % 5]}", "o") for k, m in enumerate(others)}
    styles.update(local=("C1", "s"), upstream=("C2", "^"))
    parts = {"speed_error": ("speed error", "m/s"),
             "direction_error_deg": ("direction error", "deg")}
    least = int(np.argmin(levels))  # the reference: the first decoder at the lowest noise
    given = "exact W_robot" if levels[least] == 0 else f"W_robot noise {levels[least]:g} U"
    for col, (metric, label) in enumerate(_METRICS[:2]):
        ax, diff = axes[0, col], axes[1, col]
        for m, errs in result["errors"].items():
            colour, marker = styles[m]
            ax.plot(levels, [e[metric] for e in errs], marker=marker, color=colour,
                    label=m if m in others else f"{m} baseline")
        ax.set_ylabel(label)
        ax.set_ylim(bottom=0)
        if others:
            ref = others[0]
            base = result["errors"][ref][least][metric]
            for m in others:
                colour, marker = styles[m]
                diff.plot(levels, [e[metric] - base for e in result["errors"][m]],
                          marker=marker, color=colour, label=m)
            diff.axhline(0.0, color="k", lw=0.6)
            name, unit = parts[metric]
            diff.set_ylabel(f"{name} - {ref}'s\nwith {given} ({unit})")
            diff.grid(alpha=0.3)
        diff.set_xlabel("noise on W_robot per component (fraction of the inlet speed)")
    axes[0, 0].legend(fontsize=8)
    fig.suptitle(f"W_robot noise study: {result['n_samples']:,} samples, the same noise draw "
                 f"for every model; bottom: the decoders' errors relative to the first's "
                 f"with {given}", fontsize=10)
    return _save(fig, path)


@closes_figures_on_error
def plot_scaling(result: dict, path) -> Path:
    """Test and training errors of the models trained on fractions of the sweep's maps (and of
    the wider model), against the number of training maps; and each model's validation speed
    error per epoch.

    Parameters
    ----------
    result : dict
        :func:`windnav.experiments.decoder_studies.scaling_study`'s result.
    path : str or path-like
        The PNG to write.
    """
    check_result(
        result, ("variants", "schedule"), "plot_scaling",
        "windnav.experiments.decoder_studies.scaling_study")
    path = figure_path(path, "plot_scaling")
    v = result["variants"]
    arms = [n for n in v if n != "wide"]
    maps = [v[n]["n_train_maps"] for n in arms]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.4))
    for ax, (metric, label) in zip(axes[:2], _METRICS[:2], strict=True):
        ax.plot(maps, [v[n]["errors"]["model"][metric] for n in arms], "o-", color="C0",
                label="d4-film, test (held-out map)")
        ax.plot(maps, [v[n]["train_errors"]["decoder"][metric] for n in arms], "o--",
                color="C0", alpha=0.5, label="d4-film, training maps")
        if "wide" in v:
            ax.plot([v["wide"]["n_train_maps"]], [v["wide"]["errors"]["model"][metric]], "D",
                    color="C3", label=f"wide d4-film ({v['wide']['n_parameters']:,} par.), test")
            ax.plot([v["wide"]["n_train_maps"]], [v["wide"]["train_errors"]["decoder"][metric]],
                    "D", color="C3", alpha=0.4, label="wide, training maps")
        ax.axhline(v[arms[-1]]["errors"]["local"][metric], color="C1", lw=1,
                   label="Local baseline, test")
        ax.set_xscale("log", base=2)
        ax.set_xticks(maps, [str(m) for m in maps])
        ax.set_xlabel(f"training maps (x {v[arms[-1]]['n_train_fields'] // maps[-1]} inlets)")
        ax.set_ylabel(label)
        ax.set_ylim(bottom=0)
    axes[0].legend(fontsize=7)
    for k, n in enumerate(v):
        curve = [e["speed_error"] for e in v[n]["val_curve"]]
        axes[2].plot(np.arange(1, len(curve) + 1), curve, color="C3" if n == "wide" else
                     f"C{[0, 4, 5, 6, 7][k % 5]}", label=n)
    axes[2].set_xlabel("epoch")
    axes[2].set_ylabel("validation speed error (m/s)")
    axes[2].legend(fontsize=7)
    s = result["schedule"]
    fig.suptitle(f"Scaling study: d4-film, {s['epochs']} epochs, as many samples per epoch "
                 "for every fraction of the maps", fontsize=10)
    return _save(fig, path)


def _label_study_figure(groups, image, *, vmax: float, colorbar_label: str, title: str):
    """The figure of the label studies (:func:`plot_averaging`, :func:`plot_start`): for the
    speed and the direction error, one bar per model and per group ``(label, errors)``
    (``errors[model][metric]``); then ``image`` (a map over U, NaN in buildings) with its colour
    bar. Returns ``(fig, axes)``; the caller adds its legend and title."""
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6))
    width = 0.8 / len(groups)
    for ax, (metric, name) in zip(axes[:2], _METRICS[:2], strict=True):
        for k, (label, errors) in enumerate(groups):
            ax.bar(np.arange(len(_MODELS)) + (k - (len(groups) - 1) / 2) * width,
                   [errors[m][metric] for m in _MODELS], width, label=label)
        ax.set_xticks(np.arange(len(_MODELS)), _MODELS)
        ax.set_ylabel(name)
    im = axes[2].imshow(image, origin="lower", cmap="magma", vmin=0.0, vmax=vmax)
    fig.colorbar(im, ax=axes[2], label=colorbar_label, extend=colour_extend(im))
    axes[2].set_title(title, fontsize=9)
    axes[2].set_xticks([])
    axes[2].set_yticks([])
    return fig, axes


@closes_figures_on_error
def plot_averaging(result: dict, path) -> Path:
    """The decoder and its baselines scored against a short and a long average, and the map of
    the difference between the two means.

    Parameters
    ----------
    result : dict
        :func:`windnav.experiments.decoder_studies.averaging_study`'s result.
    path : str or path-like
        The PNG to write.
    """
    check_result(
        result, ("protocols", "label_noise", "difference", "map", "speed", "direction_deg",
        "samples"), "plot_averaging", "windnav.experiments.decoder_studies.averaging_study")
    path = figure_path(path, "plot_averaging")
    groups = [(f"{label}: {p['spinup_steps']} + {p['steps']} steps "
               f"({p['diagnostics']['flow_throughs_average']:.2f} flow-throughs, "
               f"halves differ {p['diagnostics']['half_window_difference']:.2f} U)", p["errors"])
              for label, p in result["protocols"].items()]
    noise = result["label_noise"]
    fig, axes = _label_study_figure(
        groups, result["difference"], vmax=1.0, colorbar_label="|mean(short) - mean(long)| / U",
        title=f"label noise: RMS {noise['rms_mps']:.2f} m/s ({noise['rms_over_U']:.2f} U)")
    for ax in axes[:2]:  # headroom above the bars, where the legend goes (it covered the
        ax.set_ylim(0.0, 1.5 * ax.get_ylim()[1])  # Upstream bars; figures audit, 2026-12-05)
    axes[0].legend(fontsize=7, loc="upper left")
    fig.suptitle(f"{result['map']}: inlet {result['speed']:g} m/s toward "
                 f"{result['direction_deg']:g} deg, {result['samples']} robots at the same "
                 "positions for both means", fontsize=10)
    return _save(fig, path)


@closes_figures_on_error
def plot_start(result: dict, path) -> Path:
    """The decoder and its baselines against labels that differ only by the solver's start, the
    floor that spread sets (half the largest pairwise disagreement), and the map of the spread.

    Parameters
    ----------
    result : dict
        :func:`windnav.experiments.decoder_studies.start_study`'s result.
    path : str or path-like
        The PNG to write.
    """
    check_result(
        result, ("kicks", "spread", "spread_rms_mps", "floor", "map", "speed", "direction_deg",
        "spinup_steps", "steps", "samples"), "plot_start",
        "windnav.experiments.decoder_studies.start_study")
    path = figure_path(path, "plot_start")
    groups = [(f"labels started with kick {r['kick']:+g} U", r["errors"])
              for r in result["kicks"]]
    spread = result["spread"]
    fig, axes = _label_study_figure(
        groups, spread, vmax=max(0.05, float(np.nanpercentile(spread, 99))),
        colorbar_label="largest |mean(kick a) - mean(kick b)| / U",
        title=f"label spread over the kicks: RMS {result['spread_rms_mps']:.3f} m/s")
    for ax, (metric, _) in zip(axes[:2], _METRICS[:2], strict=True):
        ax.axhline(result["floor"][metric], color="k", ls="--", lw=1,
                   label=f"floor (half the largest label disagreement): "
                         f"{result['floor'][metric]:.3g}")
    axes[0].legend(fontsize=7)
    fig.suptitle(f"{result['map']}: inlet {result['speed']:g} m/s toward "
                 f"{result['direction_deg']:g} deg, {result['spinup_steps']} + "
                 f"{result['steps']} steps, {result['samples']} robots at the same positions "
                 "for every start", fontsize=10)
    return _save(fig, path)
