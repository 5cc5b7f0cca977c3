"""The plan of a city map (``windnav city``): its blocks by height and, when asked, the
start/goal pairs a navigation suite's rule draws on it."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.cm import ScalarMappable
from matplotlib.colors import Normalize
from matplotlib.lines import Line2D
from matplotlib.patches import Rectangle

from windnav._console import closes_figures_on_error, save_and_close
from windnav.experiments.nav_suite import rule_words
from windnav.viz import check_result, figure_path
from windnav.viz.nav_studies import KIND_COLORS

__all__ = ["plot_city"]


@closes_figures_on_error
def plot_city(city, summary: dict, path) -> Path:
    """The plan of ``city``: each block filled by its height (taller blocks drawn last), the
    map's edge, and, where ``summary`` has a ``suite`` entry that holds
    (:func:`windnav.commands.city.suite_pairs`), its start/goal pairs as lines from the start
    (a dot) to the goal (a star) in :data:`~windnav.viz.nav_studies.KIND_COLORS`, with the
    rule's edge as a dashed frame; a suite that does not hold is named in the title.

    Parameters
    ----------
    city : windnav.city.City
    summary : dict
        :func:`windnav.commands.city.summarize_city`'s fields (``buildings``, ``blocks``,
        ``built_fraction``) and optionally ``name`` (the title's start) and ``suite``.
    path : str or Path
        The PNG to write.

    Returns
    -------
    Path
    """
    check_result(  # (name: the command's, optional here; summarize_city gives none)
        summary, ("buildings", "blocks", "built_fraction"), "plot_city",
        "windnav.commands.city.summarize_city", "summary")
    path = figure_path(path, "plot_city")
    x0, x1, y0, y1 = city.bounds
    side = 6.0  # the plan's width, in; the colour bar and the legend around it
    fig, ax = plt.subplots(figsize=(side + 1.4, side * (y1 - y0) / (x1 - x0) + 1.5))
    heights = np.asarray(city.heights, dtype=float)
    norm = Normalize(vmin=0.0, vmax=float(heights.max()) if heights.size else 1.0)
    cmap = plt.get_cmap("YlOrBr")
    for k in np.argsort(heights, kind="stable"):
        fx0, fx1, fy0, fy1 = city.footprints[k]
        ax.add_patch(Rectangle((fx0, fy0), fx1 - fx0, fy1 - fy0, fc=cmap(norm(heights[k])),
                               ec="0.25", lw=0.5, zorder=2))
    if heights.size:
        fig.colorbar(ScalarMappable(norm=norm, cmap=cmap), ax=ax, label="block height (m)",
                     shrink=0.6, fraction=0.04, pad=0.03)
    suite = summary.get("suite")
    handles = []
    if suite is not None and suite["holds"]:
        edge = suite["rule"]["edge"]
        ax.add_patch(Rectangle((x0 + edge, y0 + edge), x1 - x0 - 2 * edge, y1 - y0 - 2 * edge,
                               fill=False, ls="--", ec="0.4", lw=0.8, zorder=1))
        for pair in suite["pairs"]:
            c = KIND_COLORS.get(pair["kind"], "0.3")
            (sx, sy), (gx, gy) = pair["start"], pair["goal"]
            ax.plot([sx, gx], [sy, gy], "-", color=c, lw=0.7, alpha=0.7, zorder=3)
            ax.plot(sx, sy, "o", color=c, mec="k", mew=0.4, ms=3.5, zorder=4)
            ax.plot(gx, gy, "*", color=c, mec="k", mew=0.4, ms=7, zorder=4)
        handles = [Line2D([], [], color=c, marker="o", ms=4, label=f"{kind} pair")
                   for kind, c in KIND_COLORS.items()]
        handles += [Line2D([], [], ls="none", marker="*", color="0.7", mec="k", ms=8,
                           label="goal"),
                    Line2D([], [], ls="--", color="0.4", label=f"{edge:g} m inside the edge")]
        fig.legend(handles=handles, fontsize=7, loc="lower center", ncol=4, frameon=False)
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    def count(n: int, word: str) -> str:
        return f"{n} {word}{'' if n == 1 else 's'}"

    title = (f"{summary['name'] + ': ' if summary.get('name') else ''}"
             f"{x1 - x0:g} x {y1 - y0:g} m, "
             f"{count(summary['buildings'], 'building')} ("
             f"{count(summary['blocks'], 'block')}), {100 * summary['built_fraction']:.1f} % "
             "built")
    if suite is not None:
        what = (count(len(suite["pairs"]), "start/goal pair") if suite["holds"]
                else "cannot hold the start/goal pairs")
        title += f"\n{suite['suite']} suite's rule ({rule_words(**suite['rule'])}): {what}"
    ax.set_title(title, fontsize=9)
    fig.tight_layout(rect=(0, 0.05 if handles else 0, 1, 1))
    path = Path(path)
    save_and_close(fig, path, dpi=110)
    return path
