"""Figures of the case studies against the global graph search (thesis ch. 5).

:func:`plot_gs_case`: a case of :func:`windnav.experiments.gs_cases.run_case` in one PNG, the
four flown paths (and the GS routes as planned, dashed) over the mean wind, beside bars of each
variant's energy (kJ) and flight time (s) labelled with its outcome.
:func:`plot_gs_case_energy`: its airspeed, power and energy against time
(:func:`windnav.viz.nav_compare.plot_energy`).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from windnav._console import closes_figures_on_error, save_and_close
from windnav.viz import check_result, figure_path
from windnav.viz.nav_compare import COLORS_ON_WHITE, draw_paths, plot_energy

__all__ = ["plot_gs_case", "plot_gs_case_energy"]


def _title(case: Mapping) -> str:
    return (f"{case['name']}: inlet {case['speed']:g} m/s toward {case['direction_deg']:g}°, "
            f"seed {case.get('seed', '?')}")


@closes_figures_on_error
def plot_gs_case(case: Mapping, path, *, title: str | None = None) -> Path:
    """One case in one PNG: paths over the mean wind, and energy and time per variant.

    The left panel draws the mean wind speed, its streamlines and the buildings
    (:func:`~windnav.viz.nav_compare.draw_paths`), each flown path in the colours of
    :data:`~windnav.viz.nav_compare.COLORS` (in the order of ``case["results"]``), the route
    GS and GS+W planned before take-off (thin, dashed), the start (circle) and goal (star).
    The right panels are bars of ``energy_J`` (airspeed power curve, kJ; the rotor energy of
    the 6-DoF simulator as a black tick) and ``time_s`` (s), each labelled with its outcome.

    Parameters
    ----------
    case : dict
        :func:`windnav.experiments.gs_cases.run_case`'s result (``city``, ``flow``,
        ``results``; ``name``, ``speed``, ``direction_deg`` for the title).
    path : str or Path
        The PNG to write (about 0.3-0.6 MB).
    title : str, optional
        Default: the case, its inlet and seed.

    Returns
    -------
    Path
    """
    check_result(
        case, ("city", "flow", "results"), "plot_gs_case", "windnav.experiments.gs_cases.run_case",
        "case")
    path = figure_path(path, "plot_gs_case")
    results = case["results"]
    labels = list(results)
    fig = plt.figure(figsize=(12.5, 6.2))
    grid = fig.add_gridspec(2, 2, width_ratios=(1.9, 1.0))
    ax = fig.add_subplot(grid[:, 0])
    draw_paths(fig, ax, results, case["city"], case["flow"], detail=False, routes=True)

    energy = [results[k].energy_J / 1e3 for k in labels]
    rotor = [results[k].rotor_energy_J / 1e3 for k in labels]
    times = [results[k].time_s for k in labels]
    outcomes = [results[k].outcome for k in labels]
    colors = [COLORS_ON_WHITE[i % len(COLORS_ON_WHITE)] for i in range(len(labels))]
    pos = np.arange(len(labels))
    ax_e = fig.add_subplot(grid[0, 1])
    ax_t = fig.add_subplot(grid[1, 1], sharex=ax_e)
    ax_e.bar(pos, energy, color=colors)
    ax_e.plot(pos, rotor, "_", color="k", ms=22, mew=2, label="rotor energy")
    ax_t.bar(pos, times, color=colors)
    tops = (np.maximum(energy, rotor), times)  # labels above the bar and the rotor tick
    for axis, values, top, fmt in ((ax_e, energy, tops[0], "{:.2f} kJ"),
                                   (ax_t, times, tops[1], "{:.0f} s")):
        for p, v, y, o in zip(pos, values, top, outcomes, strict=True):
            axis.annotate(f"{fmt.format(v)}\n{o}", (p, y), xytext=(0, 4),
                          textcoords="offset points", ha="center", va="bottom", fontsize=7.5)
        axis.set_ylim(0.0, 1.35 * max(max(top), 1e-9))
        axis.grid(axis="y", alpha=0.3)
    ax_e.set_ylabel("energy P(|v - w|) (kJ)")
    ax_e.legend(fontsize=7.5, loc="upper right")
    ax_t.set_ylabel("flight time (s)")
    ax_t.set_xticks(pos, labels, fontsize=8.5)
    plt.setp(ax_e.get_xticklabels(), visible=False)
    fig.suptitle(title or _title(case))
    fig.tight_layout()
    path = Path(path)
    save_and_close(fig, path, dpi=100)
    return path


@closes_figures_on_error
def plot_gs_case_energy(case: Mapping, path, *, title: str | None = None) -> Path:
    """Airspeed, power and cumulative energy against time of every flight of ``case``
    (:func:`~windnav.viz.nav_compare.plot_energy`); returns the PNG's path."""
    check_result(
        case, ("results",), "plot_gs_case_energy", "windnav.experiments.gs_cases.run_case", "case")
    path = figure_path(path, "plot_gs_case_energy")
    return plot_energy(dict(case["results"]), path, title=title or _title(case))
