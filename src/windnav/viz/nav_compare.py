"""Figures that compare several navigation flights (``NavigationResult``) in one city's wind.

:func:`plot_paths`: every flown path over the mean wind speed, its streamlines and the
buildings; :func:`plot_energy`: airspeed, power and cumulative energy against time, one colour
per flight. The animated version of the first is :func:`windnav.viz.animate.animate_flights`.
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import matplotlib.patheffects as pe
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.lines import Line2D
from matplotlib.patches import Rectangle

from windnav._console import closes_figures_on_error, save_and_close
from windnav._validate import nonnegative_int, positive_float
from windnav.viz import figure_path

__all__ = ["COLORS", "COLORS_ON_WHITE", "colour_extend", "draw_paths", "path_widths",
           "plot_energy", "plot_paths", "wind_background", "wind_colorbar"]

COLORS = ("#ff2d55", "#ffffff", "#ff9500", "#5ac8fa")
"""Line colours of the flights, in order (drawn with a black outline over the wind)."""

COLORS_ON_WHITE = ("tab:red", "tab:gray", "tab:orange", "tab:blue")
"""The same flights' colours on a white background (curves, bars): white's is grey. One
flight keeps one colour across a command's figures (the energy curves took blue for the
second flight, which the paths draw white and the bars grey; figures audit, 2026-12-05)."""

OUTLINE = [pe.Stroke(linewidth=3.2, foreground="k"), pe.Normal()]


def wind_background(ax, city, flow, speed=None, *, vmax: float | None = None,
                    streamlines: bool = True):
    """Draw a wind speed field (default: the mean), buildings and the map's frame on ``ax``.

    Parameters
    ----------
    ax : matplotlib.axes.Axes
    city : windnav.city.City
    flow : windnav.flow.FlowSolution
    speed : ndarray of shape (ny, nx), optional
        Wind speed on ``flow``'s cell centres, m/s; default the mean ``|(u, v)|``.
    vmax : float, optional
        Top of the colour scale, m/s; default the field's 99th percentile over fluid cells.
    streamlines : bool
        Draw the mean flow's streamlines.

    Returns
    -------
    matplotlib.image.AxesImage
        The speed image (``set_data`` it to animate).
    """
    if speed is None:
        speed = np.hypot(flow.mean_u, flow.mean_v)
    fluid = ~flow.solid
    if vmax is None:
        vmax = float(np.percentile(speed[fluid], 99)) if fluid.any() else 1.0
    h = 0.5 * flow.dx
    extent = (flow.x[0] - h, flow.x[-1] + h, flow.y[0] - h, flow.y[-1] + h)
    im = ax.imshow(np.ma.masked_array(speed, flow.solid), origin="lower", extent=extent,
                   cmap="viridis", vmin=0.0, vmax=vmax, interpolation="bilinear")
    if streamlines:
        ax.streamplot(flow.x, flow.y, np.where(flow.solid, 0.0, flow.mean_u),
                      np.where(flow.solid, 0.0, flow.mean_v), color=(1, 1, 1, 0.45),
                      linewidth=0.5, density=1.0, arrowsize=0.6)
    for x0, x1, y0, y1 in city.footprints:
        ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, fc="0.35", ec="0.15", lw=0.5,
                               zorder=3))
    x0, x1, y0, y1 = city.bounds
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    return im


def wind_colorbar(fig, im, ax, label: str, **kwargs):
    """``im``'s colour bar on ``ax``, with an arrow at each end the data pass.

    :func:`wind_background` clips its colours at the 99th percentile by default: the bar's
    arrow (``extend`` "max", "min" or "both") says that the field goes beyond the scale.

    Parameters
    ----------
    fig : matplotlib.figure.Figure
    im : matplotlib.image.AxesImage
        The image (its array, masked where there is no data, and its norm's limits).
    ax : matplotlib.axes.Axes
        The axes the bar takes its room from.
    label : str
    **kwargs
        Passed to ``fig.colorbar`` (``shrink``, say).

    Returns
    -------
    matplotlib.colorbar.Colorbar
    """
    return fig.colorbar(im, ax=ax, label=label, extend=colour_extend(im), **kwargs)


def colour_extend(im) -> str:
    """``"neither"``, ``"max"``, ``"min"`` or ``"both"``: the ends of ``im``'s colour scale
    that its (unmasked, finite) data pass."""
    data = np.ma.masked_invalid(np.ma.asarray(im.get_array(), dtype=float)).compressed()
    vmin, vmax = im.norm.vmin, im.norm.vmax
    above = data.size > 0 and vmax is not None and bool(data.max() > vmax)
    below = data.size > 0 and vmin is not None and bool(data.min() < vmin)
    return {(False, False): "neither", (True, False): "max", (False, True): "min",
            (True, True): "both"}[(above, below)]


def path_widths(n: int, *, thinnest: float = 2.0, step: float = 1.2) -> list[float]:
    """Line widths (points) of ``n`` paths drawn in order, each one ``step`` thinner than the
    one before: a later path over an earlier one leaves the earlier's colour on both sides.

    ``n``: an integer >= 0; ``thinnest`` (points) finite and > 0; ``step`` (points) finite and
    >= 0 (a negative step drew the first paths with negative widths; Python API audit,
    fifty-eighth session)."""
    where = "path_widths"
    n = nonnegative_int(n, "n", where)
    positive_float(thinnest, "thinnest", where)
    positive_float(step, "step", where, allow_zero=True)
    return [thinnest + step * (n - 1 - i) for i in range(n)]


def _check_results(results, where: str) -> None:
    """A ValueError naming ``results`` of ``where`` unless it is a non-empty mapping (of legend
    name to flight). (``{}`` wrote a blank figure, or failed after opening one; Python API
    audit, fifty-eighth session.)"""
    if not isinstance(results, Mapping) or not results:
        got = f"a {type(results).__name__}" if not isinstance(results, Mapping) else "none"
        raise ValueError(f"The 'results' parameter of {where} must be a non-empty dict of "
                         f"legend name to NavigationResult. Got {got} instead.")


def _endpoints(ax, result) -> None:
    ax.plot(*result.start, "o", color="w", mec="k", ms=8, zorder=6, label="start")
    ax.plot(*result.goal, "*", color="w", mec="k", ms=14, zorder=6, label="goal")


@closes_figures_on_error
def plot_paths(results: dict, city, flow, path, *, title: str | None = None) -> Path:
    """Every flight's path over the mean wind speed, its streamlines and the buildings.

    Parameters
    ----------
    results : dict of str to NavigationResult
        The flights (same start and goal) by their legend name (``"EA-MPPI+W"``), drawn in
        the order given.
    city : windnav.city.City
    flow : windnav.flow.FlowSolution
    path : str or Path
        The PNG to write.
    title : str, optional

    Returns
    -------
    Path
    """
    _check_results(results, "plot_paths")
    path = figure_path(path, "plot_paths")
    fig, ax = plt.subplots(figsize=(7.2, 6.2))
    draw_paths(fig, ax, results, city, flow)
    ax.set_title(title or "Flown paths over the mean wind")
    return _save(fig, path)


def draw_paths(fig, ax, results: dict, city, flow, *, detail: bool = True,
               routes: bool = False) -> None:
    """The panel of :func:`plot_paths` on ``ax``: the mean wind with its colour bar
    (:func:`wind_colorbar`), every flight's path in :data:`COLORS` with a dot where it ended,
    the start and goal of the first, a legend. Each path is drawn over the ones before it and
    thinner (:func:`path_widths`), so that paths flown along the same line stay visible.
    ``detail``: each legend entry adds the outcome, energy and time; ``routes``: the routes
    planned before take-off (``NavigationResult.route``, GS and GS+W) as thin dashed lines."""
    im = wind_background(ax, city, flow)
    wind_colorbar(fig, im, ax, "mean wind speed (m/s)", shrink=0.85)
    widths = path_widths(len(results))
    handles = []
    for i, (name, r) in enumerate(results.items()):
        c = COLORS[i % len(COLORS)]
        if routes and r.route is not None:
            ax.plot(*np.asarray(r.route).T, "--", color=c, lw=0.9, zorder=4)
        label = (f"{name}: {r.outcome}, {r.energy_J / 1e3:.2f} kJ, {r.time_s:.0f} s" if detail
                 else name)
        xy = r.position[:, :2].T
        # the black outlines under every path, each path over the ones before it and thinner:
        # where paths coincide, they show as nested bands instead of the last one alone
        ax.plot(*xy, color="k", lw=widths[i] + 1.2, zorder=5, solid_capstyle="round")
        ax.plot(*xy, color=c, lw=widths[i], zorder=5.1 + 0.01 * i, solid_capstyle="round")
        ax.plot(*r.position[-1, :2], "o", color=c, mec="k", ms=5, zorder=5.5)
        handles.append(Line2D([], [], color=c, lw=widths[i],
                              path_effects=[pe.Stroke(linewidth=widths[i] + 1.2,
                                                      foreground="k"), pe.Normal()],
                              label=label))
    _endpoints(ax, next(iter(results.values())))
    ax.legend(handles=handles + ax.get_legend_handles_labels()[0], loc="upper left",
              fontsize=8, framealpha=0.75)


@closes_figures_on_error
def plot_energy(results: dict, path, *, title: str | None = None) -> Path:
    """Airspeed, power (airspeed power curve) and cumulative energy against time.

    The energy panel draws the airspeed-model energy (solid) and the rotor energy of the 6-DoF
    simulator (dotted).

    Parameters
    ----------
    results : dict of str to NavigationResult
        The flights by their legend name.
    path : str or Path
        The PNG to write.
    title : str, optional

    Returns
    -------
    Path
    """
    _check_results(results, "plot_energy")
    path = figure_path(path, "plot_energy")
    fig, axes = plt.subplots(3, 1, figsize=(8, 7.5), sharex=True)
    for i, (name, r) in enumerate(results.items()):
        c = COLORS_ON_WHITE[i % len(COLORS_ON_WHITE)]
        axes[0].plot(r.t, r.airspeed, color=c, lw=1.2, label=name)
        axes[1].plot(r.t, r.power, color=c, lw=1.2, label=name)
        axes[2].plot(r.t, r.energy / 1e3, color=c, lw=1.6,
                     label=f"{name}: {r.energy_J / 1e3:.2f} kJ ({r.outcome})")
        axes[2].plot(r.t, r.rotor_energy / 1e3, color=c, lw=1.0, ls=":",
                     label=f"{name}, rotor: {r.rotor_energy_J / 1e3:.2f} kJ")
        axes[2].plot(r.t[-1], r.energy[-1] / 1e3, "o", color=c, ms=4)
    axes[0].set_ylabel("airspeed (m/s)")
    axes[1].set_ylabel("power P(|v - w|) (W)")
    axes[2].set_ylabel("energy (kJ)")
    axes[2].set_xlabel("time (s)")
    for ax in axes:
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    axes[2].legend(fontsize=8, loc="upper left")
    axes[0].set_title(title or "Airspeed, power and energy")
    return _save(fig, path)


def _save(fig, path) -> Path:
    path = Path(path)
    fig.tight_layout()
    save_and_close(fig, path, dpi=110)
    return path
