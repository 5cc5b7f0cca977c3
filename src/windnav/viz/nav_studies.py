"""Figures of single benchmark cases and of the benchmark's winds (thesis ch. 5).

:func:`plot_cases`: for each re-flown scenario of
:func:`windnav.experiments.nav_cases.fly_cases` (the best and worst case of
:func:`~windnav.experiments.nav_cases.best_worst`, say), its paths over the mean wind and its
airspeed, power and energy (:mod:`windnav.viz.nav_compare`). :func:`plot_wind_scenarios`: the
wind-scenario figure, a panel per inlet of :func:`~windnav.experiments.nav_cases.wind_scenarios`
with the mean wind speed, its streamlines, the buildings and the suite's start/goal pairs.
:func:`plot_reach`: the least times of :mod:`windnav.experiments.nav_feasibility` per inlet
speed and pair kind, and each variant's failures among the reachable scenarios.
:func:`plot_gust_routes`: one scenario's mean wind and gust map with the least-time routes
flown with and without the gust margin (:func:`windnav.experiments.nav_gusts.gust_routes`).
:func:`plot_inflight`: the onboard stack's wind in flight by inlet speed, the input errors of
``W_robot`` and the decoder's and the baselines' errors against the mean field
(:func:`windnav.experiments.nav_inflight.inflight_study`). :func:`plot_outcome_map`: each
variant's outcome at each scenario of one map (``benchmark-nav --table --figure``).
"""

from __future__ import annotations

import math
import re
from collections.abc import Mapping
from pathlib import Path

import matplotlib.patheffects as pe
import matplotlib.pyplot as plt
import numpy as np
from matplotlib.lines import Line2D

from windnav._console import closes_figures_on_error, save_and_close
from windnav.viz import check_result, figure_path
from windnav.viz.nav_compare import plot_energy, plot_paths, wind_background, wind_colorbar

__all__ = ["KIND_COLORS", "OUTCOME_COLORS", "plot_cases", "plot_gust_routes", "plot_inflight",
           "plot_inflight_tau", "plot_outcome_map", "plot_reach", "plot_wind_scenarios"]

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


@closes_figures_on_error
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


@closes_figures_on_error
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
    check_result(
        result, ("winds", "city"), "plot_wind_scenarios",
        "windnav.experiments.nav_cases.wind_scenarios")
    path = figure_path(path, "plot_wind_scenarios")
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
        wind_colorbar(fig, im, ax, "mean wind speed (m/s)", shrink=0.85)
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
    return _finish(fig, handles, title or f"{result['suite']} suite, map "
                   f"m{result['map_index']:02d}: mean wind of {n} inlet{'s' if n > 1 else ''}",
                   path, bottom=0.08 / nrows)  # (one row: the legend overlapped the x label)


OUTCOME_COLORS = {"success": "#34c759", "hover": "#ff9500", "timeout": "#ff3b30",
                  "left_map": "#af52de", "collision": "#000000", "error": "#8e8e93"}
"""Colours of a flight's outcome in :func:`plot_outcome_map`."""


@closes_figures_on_error
def plot_outcome_map(city, records, variants, path, *, title: str | None = None) -> Path:
    """Where each variant fails on one map: a panel per variant with the map's buildings and
    each of its scenarios as a line from the start (a small grey dot) to the goal (a circle),
    both in :data:`OUTCOME_COLORS` by the flight's outcome, failures drawn over successes.

    Parameters
    ----------
    city : windnav.city.City
        The map every record was flown on.
    records : sequence of dict
        Benchmark records (``variant``, ``outcome``, ``start``, ``goal``; the latest record of
        each scenario and variant, as the table takes them).
    variants : sequence of str
        The panels, in order; a variant without records is left out.
    path : str or Path
        The PNG to write.
    title : str, optional
        Default: the number of scenarios.

    Returns
    -------
    Path
    """
    by_variant = {v: [r for r in records if r["variant"] == v] for v in variants}
    by_variant = {v: rs for v, rs in by_variant.items() if rs}
    if not by_variant:
        raise ValueError("The 'records' parameter of plot_outcome_map must hold flights of "
                         f"the variants {list(variants)}. Got none of them instead.")
    path = figure_path(path, "plot_outcome_map")
    n = len(by_variant)
    ncols = min(n, 3)
    nrows = math.ceil(n / ncols)
    x0, x1, y0, y1 = city.bounds
    side = 4.6
    fig, axes = plt.subplots(nrows, ncols, figsize=(side * ncols, side * nrows * (y1 - y0)
                                                    / (x1 - x0) + 0.6 * nrows), squeeze=False)
    for ax in axes.flat[n:]:
        ax.set_visible(False)
    for ax, (variant, rs) in zip(axes.flat[:n], by_variant.items(), strict=True):
        for fx0, fx1, fy0, fy1 in city.footprints:
            ax.add_patch(plt.Rectangle((fx0, fy0), fx1 - fx0, fy1 - fy0, fc="0.55", ec="0.3",
                                       lw=0.4, zorder=1))
        for r in sorted(rs, key=lambda r: r["outcome"] != "success"):
            c = OUTCOME_COLORS.get(r["outcome"], OUTCOME_COLORS["error"])
            (sx, sy), (gx, gy) = r["start"], r["goal"]
            ax.plot([sx, gx], [sy, gy], "-", color=c, lw=0.8, alpha=0.8, zorder=2)
            ax.plot(sx, sy, "o", color="0.4", ms=2.5, zorder=3)
            ax.plot(gx, gy, "o", color=c, mec="k", mew=0.4, ms=5, zorder=4)
        failed = sum(r["outcome"] != "success" for r in rs)
        label = _wrap_label(str(variant), 40)
        ax.set_title(f"{label}: {100.0 * failed / len(rs):.1f} % failed ({failed} of "
                     f"{len(rs)})", fontsize=9)
        ax.set_xlim(x0, x1)
        ax.set_ylim(y0, y1)
        ax.set_aspect("equal")
        ax.tick_params(labelsize=7)
    present = {r["outcome"] for rs in by_variant.values() for r in rs}
    handles = [Line2D([], [], color=c, marker="o", mec="k", ms=6, label=k.replace("_", " "))
               for k, c in OUTCOME_COLORS.items() if k in present]
    handles.append(Line2D([], [], ls="none", marker="o", color="0.4", ms=3, label="start"))
    count = len({r["scenario_id"] for rs in by_variant.values() for r in rs})
    return _finish(fig, handles, title or f"outcomes of {count} scenarios (start to goal)",
                   path, bottom=0.05)


def _wrap_label(label: str, width: int) -> str:
    """A variant label broken into lines of at most about ``width`` characters before its
    ``@`` parameters."""
    head, *params = label.split("@")
    lines = [head]
    for p in params:
        if len(lines[-1]) + 1 + len(p) > width:
            lines.append(f"@{p}")
        else:
            lines[-1] += f"@{p}"
    return "\n".join(lines)


def _finish(fig, handles, title: str, path, *, bottom: float, ncol: int | None = None) -> Path:
    """The legend of ``handles`` in rows of ``ncol`` (default: one row) below the panels
    (``bottom`` of the figure), the title, and the figure written to ``path`` (PNG) and
    closed."""
    fig.legend(handles=handles, loc="lower center", ncol=ncol or len(handles), fontsize=9,
               frameon=False)
    fig.suptitle(title)
    fig.tight_layout(rect=(0, bottom, 1, 1))
    path = Path(path)
    save_and_close(fig, path, dpi=110)
    return path


@closes_figures_on_error
def plot_reach(reach, table: Mapping, path, *, title: str | None = None) -> Path:
    """The reachability figure: least time to the goal per scenario, and failures.

    Top: each scenario's least time in its recorded wind within the airspeed limit
    (:func:`~windnav.experiments.nav_feasibility.reach_table`'s ``airspeed``), grouped by inlet
    speed and pair kind (jittered points, in :data:`KIND_COLORS`); unreachable scenarios as
    crosses above the record's end; the dashed line is the last arrival that leaves the 5 s
    hold. Without variants in ``table`` (no benchmark store given), that panel alone. Bottom
    left: per variant of ``table`` flown on all its scenarios, the failure rate over
    all its flights and over the flights in reachable scenarios (one bar when every scenario is
    reachable). Bottom right: the same variants' failure rates (rows, in the bars' order) by the
    scenario's least time in the mean wind (columns, ``by_mean_time``, with the number of
    scenarios of each bin), as a table of colours with the rate written in each cell.

    Parameters
    ----------
    reach : iterable of dict
        Reach records (:func:`~windnav.experiments.nav_feasibility.reach_scenarios`).
    table : dict
        :func:`~windnav.experiments.nav_feasibility.reach_table` of those records.
    path : str or Path
        The PNG to write.
    title : str, optional

    Returns
    -------
    Path
    """
    check_result(
        table, ("airspeed", "groups", "variants"), "plot_reach",
        "windnav.experiments.nav_feasibility.reach_table", "table")
    path = figure_path(path, "plot_reach")
    import numpy as np

    key = f"{table['airspeed']:g}"
    reach = list(reach)
    groups = list(table["groups"])
    rng = np.random.default_rng(0)
    v = table["variants"]
    # the scatter across the top; the two failure panels below it, whose variant labels (long
    # label parameters of the sixth variant) need the width; without flights, the scatter alone
    # (its two panels were drawn empty)
    fig = plt.figure(figsize=(16, 10.5 if v else 5.5))
    grid = fig.add_gridspec(2 if v else 1, 2, width_ratios=[1, 1.15],
                            height_ratios=[1, 1.1] if v else [1])
    ax = fig.add_subplot(grid[0, :])
    record_s = max(r["record_s"] for r in reach)
    hold_s = max(r["hold_s"] for r in reach)
    for g, name in enumerate(groups):
        speed, kind = name.split("/")
        rows = [r for r in reach if f"{r['speed']:g}/{r['kind']}" == name]
        t = np.array([r["limits"][key]["recorded_time_s"]
                      if r["limits"][key]["reachable"] else np.nan for r in rows], float)
        jit = g + rng.uniform(-0.3, 0.3, t.size)
        c = KIND_COLORS.get(kind, "0.5")
        ax.plot(jit[np.isfinite(t)], t[np.isfinite(t)], "o", ms=3, color=c, alpha=0.7)
        bad = ~np.isfinite(t)
        ax.plot(jit[bad], np.full(bad.sum(), record_s + 4), "x", ms=5, color="k")
        info = table["groups"][name]
        ax.annotate(f"{info['reachable']}/{info['n']}", (g, record_s + 9), ha="center",
                    fontsize=8)
    ax.axhline(record_s - hold_s, ls="--", color="k", lw=1)
    ax.text(len(groups) - 0.5, record_s - hold_s - 1, "last arrival with the 5 s hold",
            ha="right", va="top", fontsize=8)
    ax.set_xticks(range(len(groups)))
    ax.set_xticklabels([n.replace("/", " m/s\n") for n in groups], fontsize=9)
    ax.set_xlim(-0.5, len(groups) - 0.5)  # (the hold line's label inside, at the right)
    ax.set_ylim(0, record_s + 13)
    ax.set_ylabel("least time to the goal, recorded wind (s)")
    ax.set_title(f"least time within {table['airspeed']:.2f} m/s of airspeed "
                 f"(x: not reachable; n reachable/n)", fontsize=10)
    if v:
        _reach_failures(fig, fig.add_subplot(grid[1, 0]), fig.add_subplot(grid[1, 1]), table)
    fig.suptitle(title or "Which scenarios can be flown within the airspeed envelope?")
    fig.tight_layout()
    # the top panel from the figure's left margin: laid out with the bars' long variant labels
    # below it, it began a third of the way in (figures audit, 2026-12-05)
    top = ax.get_position()
    x0 = min(top.x0, 0.06)
    ax.set_position([x0, top.y0, top.x1 - x0, top.height])
    path = Path(path)
    save_and_close(fig, path, dpi=110, bbox_inches="tight")
    return path


def _reach_failures(fig, bx, cx, table: Mapping) -> None:
    """:func:`plot_reach`'s two failure panels of the variants of ``table`` (at least one):
    the bars on ``bx``, the rates by least time in the mean wind on ``cx``."""
    import numpy as np

    v = table["variants"]
    # the variants flown on every scenario of the table (studies flown on a part of the suite
    # would compare failure rates over other scenario sets); all when none is
    names = [n for n in v if v[n]["flights"] + v[n].get("errors", 0) == table["n"]] or list(v)
    ys = np.arange(len(names))
    fail = np.array([100 * v[n]["failures"] / max(v[n]["flights"], 1) for n in names])
    fail_r = np.array([100 * v[n]["failures_reachable"] / v[n]["reachable"]
                       if v[n]["reachable"] else np.nan for n in names])  # 0/0 drew 0.0
    if table["reachable"] == table["n"]:  # the two rates are one: one bar each
        bx.barh(ys, fail_r, height=0.6, color="#007aff")
        bx.set_title(f"every scenario reachable ({table['n']}): failure over all flights",
                     fontsize=10)
    else:
        bx.barh(ys + 0.2, fail, height=0.4, color="0.6", label="all flights")
        bx.barh(ys - 0.2, fail_r, height=0.4, color="#007aff", label="reachable scenarios")
        bx.legend(fontsize=8, loc="lower right")
        bx.set_title(f"{table['reachable']} of {table['n']} scenarios reachable", fontsize=10)
    at = ys if table["reachable"] == table["n"] else ys - 0.2  # beside the blue bar
    for y, f in zip(at, fail_r, strict=True):
        bx.annotate(f"{f:.1f}" if np.isfinite(f) else "no reachable flight",
                    (f if np.isfinite(f) else 0.0, y), xytext=(3, 0), textcoords="offset points",
                    va="center", fontsize=7)
    bx.set_yticks(ys)
    bx.set_yticklabels(names, fontsize=8)
    bx.set_ylim(len(names) - 0.5, -0.5)  # the first variant on top, as in the table
    bx.set_xlim(0, min(100.0, 1.15 * max(fail.max(initial=0), fail_r.max(initial=0)) + 5))
    bx.set_xlabel("failure (%)")
    # failures by the least time in the mean wind: one row per variant (the bars' rows), one
    # column per bin with scenarios, the rate written in each cell
    bins = list(next(iter(v.values()))["by_mean_time"])
    counts = [v[names[0]]["by_mean_time"][b][0] for b in bins]
    shown = [i for i, c in enumerate(counts) if c > 0]
    rates = np.array([[100 * v[n]["by_mean_time"][bins[i]][1] / v[n]["by_mean_time"][bins[i]][0]
                       for i in shown] for n in names]).reshape(len(names), len(shown))
    im = cx.imshow(rates, cmap="Reds", vmin=0, vmax=100, aspect="auto",
                   extent=(-0.5, len(shown) - 0.5, len(names) - 0.5, -0.5))
    for (k, j), r in np.ndenumerate(rates):
        cx.annotate(f"{r:.0f}", (j, k), ha="center", va="center", fontsize=7,
                    color="white" if r > 60 else "black")
    cx.set_yticks(ys)
    cx.tick_params(labelleft=False)
    cx.set_ylim(len(names) - 0.5, -0.5)
    cx.set_xticks(range(len(shown)))
    cx.set_xticklabels([f"{bins[i]}\n(n={counts[i]})" for i in shown], fontsize=8)
    cx.set_xlabel("least time to the goal in the mean wind (s; scenarios per bin)")
    cx.set_title("failure (%) by the least time in the mean wind", fontsize=10)
    fig.colorbar(im, ax=cx, label="failure (%)", fraction=0.05, pad=0.02)


@closes_figures_on_error
def plot_gust_routes(result: Mapping, path, *, title: str | None = None) -> Path:
    """One scenario's mean wind (left) and gust map (right), with each flight's path.

    Both panels draw the buildings, the start (circle) and goal (star), and for each of the two
    flights of :func:`~windnav.experiments.nav_gusts.gust_routes` (without, then with the gust
    margin) its last least-time route (dashed) and its flown path (solid), labelled with its
    outcome. The right panel's colour is the standard deviation of the wind along the inlet's
    direction, m/s. Each colour scale ends at its field's 99th percentile; the colour bar's
    arrow marks the values beyond (:func:`~windnav.viz.nav_compare.wind_colorbar`).

    Parameters
    ----------
    result : dict
        :func:`~windnav.experiments.nav_gusts.gust_routes`'s result.
    path : str or Path
        The PNG to write.
    title : str, optional
        Default: the scenario, its inlet and the gust margin.

    Returns
    -------
    Path
    """
    check_result(
        result, ("scenario", "city", "flow", "sigma_along", "flights", "routes"),
        "plot_gust_routes", "windnav.experiments.nav_gusts.gust_routes")
    path = figure_path(path, "plot_gust_routes")
    sc, city, flow = result["scenario"], result["city"], result["flow"]
    colors = ("#34c759", "#5ac8fa")
    fig, axes = plt.subplots(1, 2, figsize=(12.4, 5.6))
    panels = ((None, "mean wind speed (m/s)", True),
              (result["sigma_along"], "std of the wind along the inlet (m/s)", False))
    handles = []
    for ax, (field, label, stream) in zip(axes, panels, strict=True):
        im = wind_background(ax, city, flow, field, streamlines=stream)
        wind_colorbar(fig, im, ax, label, shrink=0.85)
        for (v, res), c in zip(result["flights"].items(), colors, strict=True):
            route = result["routes"].get(v)
            if route is not None:
                q = route["samples"]
                ax.plot(q[:, 0], q[:, 1], "--", color=c, lw=1.4, zorder=7,
                        path_effects=[pe.withStroke(linewidth=2.6, foreground="w")])
            p = res.position
            ax.plot(p[:, 0], p[:, 1], "-", color=c, lw=1.6, zorder=6,
                    path_effects=[pe.withStroke(linewidth=2.8, foreground="k")])
            if ax is axes[0]:
                tag = "with the gust margin" if "@gust=" in v else "mean wind only"
                arrival = res.summary().get("arrival_time_s")
                when = (f", arrived at {arrival:.1f} s"
                        if arrival is not None and math.isfinite(arrival) else "")
                handles.append(Line2D([], [], color=c, lw=1.8,
                                      label=f"{tag}: {res.outcome}{when}"))
        (sx, sy), (gx, gy) = sc.start, sc.goal
        ax.plot(sx, sy, "o", color="w", mec="k", ms=9, zorder=7)
        ax.plot(gx, gy, "*", color="w", mec="k", ms=15, zorder=7)
    handles.append(Line2D([], [], ls="--", color="0.5", label="last least-time route flown"))
    return _finish(fig, handles, title or f"{sc.scenario_id} ({sc.kind}): {sc.speed:g} m/s "
                   f"toward {sc.direction_deg:g}°, gust margin K = {result['gust_k']:g}",
                   path, bottom=0.07)


_INFLIGHT_INPUTS = {"ukf_vs_mean": ("UKF vs mean (what the decoder gets)", "tab:red", "-"),
                    "inst_vs_mean": ("instantaneous vs mean (the flow's unsteadiness)",
                                     "tab:purple", "--"),
                    "ukf_vs_inst": ("UKF vs instantaneous (the UKF's own error)", "tab:gray", ":")}
_INFLIGHT_MODELS = {"decoder_ukf": ("decoder, W_robot from the UKF (flown)", "tab:blue", "-", "o"),
                    "decoder_mean": ("decoder, mean W_robot (as trained)", "tab:blue", "--", "s"),
                    "decoder_inst": ("decoder, true instantaneous W_robot", "tab:blue", ":", "^"),
                    "local_ukf": ("Local, UKF", "tab:orange", "-", "o"),
                    "local_mean": ("Local, mean", "tab:orange", "--", "s"),
                    "upstream": ("Upstream", "tab:green", "-", "D")}


@closes_figures_on_error
def plot_inflight(result: Mapping, path, *, title: str | None = None,
                  labels: Mapping[str, str] | None = None) -> Path:
    """The decoder in flight (:func:`~windnav.experiments.nav_inflight.inflight_study`): per
    inlet speed, the RMS input errors of ``W_robot`` (left), and the speed and direction errors
    against the mean field in the decoder's window of the decoder and the baselines given each
    ``W_robot`` (middle, right). Written to ``path`` (PNG).

    ``labels`` names the compared decoders (``result["compare"]``) in the legend, e.g.
    ``{"shipped": "2026-11-26 default"}``; a decoder it does not name is labelled with its
    name and, where ``result["models"]`` records it, the file it was loaded from without the
    ``decoder_`` prefix (``"flight (2026-11-29-flight)"``): which model a name such as
    ``shipped`` meant changes when another is shipped."""
    check_result(
        result, ("by_speed",), "plot_inflight", "windnav.experiments.nav_inflight.inflight_study")
    unknown = sorted(set(labels or {}) - set(result.get("compare") or []))
    if unknown:
        raise ValueError(f"The 'labels' parameter of plot_inflight must name decoders of the "
                         f"result's 'compare' ({result.get('compare') or []}). Got {unknown} "
                         "instead.")
    path = figure_path(path, "plot_inflight")
    rows = result["by_speed"]
    speeds = [float(s) for s in rows]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6 + 0.5 * bool(result.get("compare"))))
    for key, (label, color, ls) in _INFLIGHT_INPUTS.items():
        axes[0].plot(speeds, [r["inputs"][key] for r in rows.values()], color=color, ls=ls,
                     marker="o", label=label)
    axes[0].set_ylabel("RMS |difference| at the vehicle (m/s)")
    axes[0].legend(fontsize=8, loc="upper left")
    handles = []
    models = dict(_INFLIGHT_MODELS)
    for name, color in zip(result.get("compare") or [], ("tab:red", "tab:purple", "tab:brown",
                                                          "tab:pink", "tab:olive"), strict=False):
        label = _decoder_label(name, result.get("models") or {}, labels or {})
        models[f"{name}_ukf"] = (f"{label}, W_robot from the UKF", color, "-", "v")
        models[f"{name}_mean"] = (f"{label}, mean W_robot", color, "--", "s")
    for ax, metric, unit in ((axes[1], "speed_error", "speed error (m/s)"),
                             (axes[2], "direction_error_deg", "direction error (deg)")):
        for key, (label, color, ls, marker) in models.items():
            line, = ax.plot(speeds, [r["errors"][key][metric] for r in rows.values()],
                            color=color, ls=ls, marker=marker, label=label)
            if ax is axes[1]:
                handles.append(line)
        ax.set_ylabel(unit)
    for ax in axes:
        ax.set_xlabel("inlet speed (m/s)")
        ax.set_xticks(speeds)
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
    n = sum(r["flights"] for r in rows.values())
    ncol = _legend_columns(fig, handles, most=6)
    rows_of_legend = -(-len(handles) // ncol)
    return _finish(fig, handles, title or f"The onboard stack's wind in flight ({n} flights of "
                   f"{result['variant']}, a sample every {result['every_s']:g} s), against "
                   "the mean field in the decoder's window", path,
                   bottom=0.1 + 0.05 * (rows_of_legend - 1), ncol=ncol)


def _legend_columns(fig, handles, *, most: int, fontsize: float = 9) -> int:
    """The most columns, up to ``most``, in which :func:`_finish`'s legend of ``handles`` fits
    the width of ``fig`` (long decoder labels wrap into more rows instead of off the page)."""
    renderer = fig.canvas.get_renderer()
    width = fig.bbox.width
    for ncol in range(min(most, len(handles)), 1, -1):
        legend = fig.legend(handles=handles, loc="lower center", ncol=ncol, fontsize=fontsize,
                            frameon=False)
        wide = legend.get_window_extent(renderer).width
        legend.remove()
        if wide <= 0.98 * width:
            return ncol
    return 1


def _decoder_label(name: str, files: Mapping, labels: Mapping) -> str:
    """A compared decoder's legend name: ``labels``' if it has one, else ``name`` with the
    stem of its file in ``files`` (``decoder_`` dropped), else ``name``."""
    if name in labels:
        return str(labels[name])
    if name not in files:
        return name
    stem = Path(str(files[name])).stem
    return f"{name} ({stem.removeprefix('decoder_')})"


@closes_figures_on_error
def plot_inflight_tau(result: Mapping, path, *, title: str | None = None) -> Path:
    """The in-flight study's averaged ``W_robot`` (its ``taus``): against the averaging time
    constant (0: the UKF's estimate itself), one line per inlet speed, the RMS distance of the
    averaged estimate to the mean wind at the vehicle (left) and the decoder's speed and
    direction errors given it (middle, right); dotted, the decoder given the mean wind itself.
    Written to ``path`` (PNG)."""
    check_result(
        result, ("taus", "by_speed"), "plot_inflight_tau",
        "windnav.experiments.nav_inflight.inflight_study")
    from windnav.experiments.nav_inflight import smoothed_key

    taus = [float(t) for t in result["taus"]]
    if not taus:
        raise ValueError("The 'result' parameter of plot_inflight_tau must hold an in-flight "
                         "study run with taus. Got one without.")
    path = figure_path(path, "plot_inflight_tau")
    x = [0.0, *taus]
    keys = [smoothed_key(t) for t in taus]
    fig, axes = plt.subplots(1, 3, figsize=(15, 4.6))
    rows = {**{f"{float(s):g} m/s": r for s, r in result["by_speed"].items()},
            **({"all": result["all"]} if result.get("all") else {})}
    colors = plt.cm.viridis(np.linspace(0.0, 0.85, max(len(rows) - 1, 1)))
    handles = []
    for (label, r), color in zip(rows.items(), [*colors, "black"], strict=False):
        lw = 2.5 if label == "all" else 1.5
        inp = [r["inputs"]["ukf_vs_mean"], *(r["inputs"][f"{k}_vs_mean"] for k in keys)]
        line, = axes[0].plot(x, inp, color=color, marker="o", lw=lw, label=label)
        handles.append(line)
        for ax, metric in ((axes[1], "speed_error"), (axes[2], "direction_error_deg")):
            err = [r["errors"]["decoder_ukf"][metric],
                   *(r["errors"][f"decoder_{k}"][metric] for k in keys)]
            ax.plot(x, err, color=color, marker="o", lw=lw)
            ax.axhline(r["errors"]["decoder_mean"][metric], color=color, ls=":", lw=1)
    axes[0].set_ylabel("RMS |averaged UKF estimate - mean wind| (m/s)")
    axes[1].set_ylabel("decoder speed error (m/s)")
    axes[2].set_ylabel("decoder direction error (deg)")
    for ax in axes:
        ax.set_xlabel("averaging time constant tau (s; 0: the estimate itself)")
        ax.set_ylim(bottom=0)
        ax.grid(alpha=0.3)
    n = sum(r["flights"] for r in result["by_speed"].values())
    return _finish(fig, handles, title or f"W_robot averaged over time in flight ({n} flights "
                   f"of {result['variant']}); dotted: the decoder given the mean wind", path,
                   bottom=0.1)
