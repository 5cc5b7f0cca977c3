"""Figures of single benchmark cases and of the benchmark's winds (thesis ch. 5).

:func:`plot_cases`: for each re-flown scenario of
:func:`windnav.experiments.nav_cases.fly_cases` (the best and worst case of
:func:`~windnav.experiments.nav_cases.best_worst`, say), its paths over the mean wind and its
airspeed, power and energy (:mod:`windnav.viz.nav_compare`). :func:`plot_wind_scenarios`: the
wind-scenario figure, a panel per inlet of :func:`~windnav.experiments.nav_cases.wind_scenarios`
with the mean wind speed, its streamlines, the buildings and the suite's start/goal pairs.
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.patheffects as pe  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402
from matplotlib.lines import Line2D  # noqa: E402

from windnav.viz.nav_compare import plot_energy, plot_paths, wind_background  # noqa: E402

__all__ = ["KIND_COLORS", "plot_cases", "plot_wind_scenarios"]

KIND_COLORS = {"tailwind": "#ff9500", "headwind": "#ff2d55"}
"""Marker colours of the start/goal pairs, by kind (drawn with a black edge over the wind)."""

_TAG = re.compile(r"^[A-Za-z0-9_.-]+$")


def _labels(labels: Mapping | None) -> Mapping:
    if labels is not None:
        return labels
    from windnav.experiments.nav_demo import LABELS

    return LABELS


def _check_tags(cases: Mapping, tags: Mapping | None) -> dict:
    where = "plot_cases"
    if tags is None:
        return {sid.replace("/", "_"): sid for sid in cases}
    if not isinstance(tags, Mapping) or not tags:
        raise ValueError(f"The 'tags' parameter of {where} must be a non-empty mapping of tag "
                         f"to scenario id. Got {tags!r} instead.")
    for tag, sid in tags.items():
        if not isinstance(tag, str) or not _TAG.match(tag):
            raise ValueError(f"The 'tags' parameter of {where} must have file-name tags "
                             f"(letters, digits, '_', '.', '-'). Got {tag!r} instead.")
        if sid not in cases:
            raise ValueError(f"The 'tags' parameter of {where} must map each tag to a scenario "
                             f"of 'cases', among {list(cases)}. Got {tag!r}: {sid!r} instead.")
    return dict(tags)


def plot_cases(cases: Mapping, out_dir, *, tags: Mapping[str, str] | None = None,
               labels: Mapping[str, str] | None = None) -> list[Path]:
    """Write ``{tag}_paths.png`` and ``{tag}_energy.png`` for each case.

    Parameters
    ----------
    cases : dict
        :func:`~windnav.experiments.nav_cases.fly_cases`'s result: ``{scenario_id:
        {"scenario", "city", "flow", "results": {variant: NavigationResult}}}``.
    out_dir : str or Path
        Folder of the figures (created).
    tags : dict of str to str, optional
        Tag (the file-name prefix: letters, digits, ``_ . -``) to scenario id of ``cases``,
        e.g. ``{"best": "thesis/m03/w07/p2", "worst": ...}``; drawn in this order. Default
        every case, tagged by its id with ``/`` as ``_`` (``thesis_m03_w07_p2``).
    labels : dict of str to str, optional
        Legend name of each variant; default
        :data:`windnav.experiments.nav_demo.LABELS` (``"ea-mppi-w"``: ``"EA-MPPI+W"``).

    Returns
    -------
    list of Path
        The PNGs written: paths then energy, per tag.

    Raises
    ------
    ValueError
        A tag that is no file name or names no case.

    Notes
    -----
    Each title names the tag, the scenario id and its kind, the inlet (speed, m/s, and the
    direction it blows toward, deg) and each variant's energy (``energy_J``, kJ) and outcome.
    """
    tags = _check_tags(cases, tags)
    names = _labels(labels)
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    for tag, sid in tags.items():
        case = cases[sid]
        sc = case["scenario"]
        results = {names.get(v, v): r for v, r in case["results"].items()}
        energies = ", ".join(f"{name} {r.energy_J / 1e3:.2f} kJ ({r.outcome})"
                             for name, r in results.items())
        head = (f"{tag}: {sid} ({sc.kind}), inlet {sc.speed:g} m/s toward "
                f"{sc.direction_deg:g}°")
        title = f"{head}\n{energies}"
        written.append(plot_paths(results, case["city"], case["flow"],
                                  out / f"{tag}_paths.png", title=title))
        written.append(plot_energy(results, out / f"{tag}_energy.png", title=title))
    return written


def plot_wind_scenarios(result: Mapping, path, *, title: str | None = None) -> Path:
    """The wind-scenario figure: one panel per inlet on one map, with the suite's pairs.

    Each panel draws the mean wind speed (its own colour scale, m/s), the streamlines of the
    mean flow and the buildings (:func:`~windnav.viz.nav_compare.wind_background`), and each
    start/goal pair of that wind as a circle (start) and a star (goal) joined by a dashed line,
    in :data:`KIND_COLORS` by kind (tailwind, headwind) and numbered by pair index.

    Parameters
    ----------
    result : dict
        :func:`~windnav.experiments.nav_cases.wind_scenarios`'s result.
    path : str or Path
        The PNG to write.
    title : str, optional
        Default: the suite, the map and the number of inlets.

    Returns
    -------
    Path
    """
    winds = result["winds"]
    city = result["city"]
    n = len(winds)
    ncols = min(n, 2)
    nrows = math.ceil(n / ncols)
    fig, axes = plt.subplots(nrows, ncols, figsize=(5.6 * ncols, 5.0 * nrows), squeeze=False)
    for ax in axes.flat[n:]:
        ax.set_visible(False)
    for ax, wind in zip(axes.flat[:n], winds, strict=True):
        im = wind_background(ax, city, wind["flow"])
        fig.colorbar(im, ax=ax, label="mean wind speed (m/s)", shrink=0.85)
        for sc in wind["scenarios"]:
            c = KIND_COLORS.get(sc.kind, "w")
            (sx, sy), (gx, gy) = sc.start, sc.goal
            ax.plot([sx, gx], [sy, gy], "--", color=c, lw=1.0, zorder=5)
            ax.plot(sx, sy, "o", color=c, mec="k", ms=8, zorder=6)
            ax.plot(gx, gy, "*", color=c, mec="k", ms=14, zorder=6)
            ax.annotate(f"p{sc.pair_index}", (sx, sy), xytext=(5, 5),
                        textcoords="offset points", fontsize=7, color="w", zorder=7,
                        path_effects=[pe.withStroke(linewidth=2, foreground="k")])
        ax.set_title(f"w{wind['wind_index']:02d}: {wind['speed']:g} m/s toward "
                     f"{wind['direction_deg']:g}°", fontsize=10)
    handles = [Line2D([], [], ls="none", marker="o", color="0.8", mec="k", ms=8,
                      label="start"),
               Line2D([], [], ls="none", marker="*", color="0.8", mec="k", ms=12,
                      label="goal")]
    handles += [Line2D([], [], ls="--", color=c, label=f"{kind} pair")
                for kind, c in KIND_COLORS.items()]
    fig.legend(handles=handles, loc="lower center", ncol=len(handles), fontsize=9,
               frameon=False)
    fig.suptitle(title or f"{result['suite']} suite, map m{result['map_index']:02d}: mean wind "
                          f"of {n} inlet{'s' if n > 1 else ''}")
    fig.tight_layout(rect=(0, 0.04, 1, 1))
    path = Path(path)
    fig.savefig(path, dpi=110)
    plt.close(fig)
    return path
