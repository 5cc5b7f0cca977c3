"""The figure of the Q_E and H sweeps (:mod:`windnav.experiments.nav_sweeps`): EA-MPPI+W's
paired energy reduction against MPPI for each value, overall (with its 95 % interval) and per
inlet speed, and the failure rate beside MPPI's; and the figure of the pace study
(:mod:`windnav.experiments.nav_pace`): time and mean-power ratios per pair; and the figure of
the energy bound (:mod:`windnav.experiments.nav_bound`); and of the tilt-cap study
(:mod:`windnav.experiments.nav_tilt`)."""

from __future__ import annotations

import math
from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.collections import PathCollection

from windnav._console import closes_figures_on_error
from windnav.experiments.thesis_nav import PAIRED_SAVING
from windnav.viz import check_result, figure_path
from windnav.viz.navigate import _save

__all__ = ["plot_bound", "plot_pace", "plot_sweep", "plot_tilt"]


def _positions(values):
    """x positions: the values themselves, ``inf`` one step past the largest finite value."""
    finite = [v for v in values if math.isfinite(v)]
    top = max(finite) if finite else 0.0
    step = (top - min(finite)) / max(len(finite) - 1, 1) if len(finite) > 1 else 1.0
    return np.array([v if math.isfinite(v) else top + 1.5 * step for v in values])


@closes_figures_on_error
def plot_sweep(result: dict, path, *, name: str = "Q_E", unit: str = "") -> Path:
    """Paired energy reduction (%) and failure rate (%) against the swept value.

    Parameters
    ----------
    result : dict
        :func:`windnav.experiments.nav_sweeps.sweep_table`'s result.
    path : str or path-like
        The PNG to write.
    name, unit : str
        The swept parameter's name and unit, for the axis.
    """
    check_result(
        result, ("values", "rows", "speeds", "reference", "reference_flights"), "plot_sweep",
        "windnav.experiments.nav_sweeps.sweep_table")
    path = figure_path(path, "plot_sweep")
    values = result["values"]
    x = _positions(values)
    rows = [result["rows"][v] for v in values]
    fig, (ax, bx) = plt.subplots(1, 2, figsize=(12, 4.4))
    cmap = plt.get_cmap("viridis")
    speeds = result["speeds"]
    for k, s in enumerate(speeds):
        y = [100 * r["by_speed"][s]["mean"] if s in r["by_speed"]
             and r["by_speed"][s]["mean"] is not None else np.nan for r in rows]
        ax.plot(x, y, "o-", color=cmap(0.85 * k / max(len(speeds) - 1, 1)), lw=1.2, ms=4,
                label=f"{s} m/s")  # viridis short of its pale yellow
    mean = np.array([100 * r["paired_reduction"]["mean"] if r["paired_reduction"]["mean"]
                     is not None else np.nan for r in rows])
    lo = np.array([100 * r["paired_reduction"]["ci95"][0] if r["paired_reduction"]["ci95"]
                   else np.nan for r in rows])
    hi = np.array([100 * r["paired_reduction"]["ci95"][1] if r["paired_reduction"]["ci95"]
                   else np.nan for r in rows])
    ax.fill_between(x, lo, hi, color="k", alpha=0.12, lw=0)
    ax.plot(x, mean, "ks-", lw=2, ms=5, label="all (95 % CI)")
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.set_ylabel(f"paired energy reduction vs {result['reference']} (%)")
    ax.legend(fontsize=8, title="inlet", title_fontsize=8, loc="center left",
              bbox_to_anchor=(1.01, 0.5))  # beside the curves, not over them
    bx.plot(x, [r["failure_pct"] for r in rows], "o-", color="#c0392b", label="EA-MPPI+W")
    if result.get("reference_failure_pct") is not None:
        bx.axhline(result["reference_failure_pct"], color="0.3", ls="--",
                   label=result["reference"])
    bx.set_ylabel("failure (%)")
    bx.set_ylim(0, 100)
    bx.legend(fontsize=8)
    labels = ["∞" if not math.isfinite(v) else f"{v:g}" for v in values]
    for a in (ax, bx):
        a.set_xticks(x, labels)
        a.set_xlabel(f"{name} ({unit})" if unit else name)
        a.grid(alpha=0.3)
    n = [r["paired_reduction"]["n"] for r in rows]
    fig.suptitle(f"EA-MPPI+W against {result['reference']}, sweeping {name}: "
                 f"{result['reference_flights']} scenarios, {min(n)}-{max(n)} pairs where "
                 "neither failed", fontsize=10)
    return _save(fig, path)


_PACE_COLORS = {"vehicle": "#1f77b4", "crazyflie": "#d62728", "mission": "#2ca02c"}
_PACE_NAMES = {"vehicle": "the Hummingbird's curve", "crazyflie": "the thesis's Crazyflie shape",
               "mission": "the mission's energy as J_E"}


@closes_figures_on_error
def plot_pace(result: dict, path) -> Path:
    """Per pair, the mean-power ratio against the time ratio of a variant to MPPI
    (:func:`windnav.experiments.nav_pace.pace_study`), each curve's means and power floor, the
    thesis's means, and the lines of equal energy and of the thesis's 14.1 % paired saving
    (``power ratio = energy ratio / time ratio``)."""
    check_result(
        result, ("thesis", "curves"), "plot_pace", "windnav.experiments.nav_pace.pace_study")
    path = figure_path(path, "plot_pace")
    fig, ax = plt.subplots(figsize=(7.5, 5.6))
    t_all = [result["thesis"]["time_ratio"]]
    p_all = [result["thesis"]["power_ratio"], 1.3]
    floors = set()
    for name, c in result["curves"].items():
        t, p = np.asarray(c["pairs"]["time_ratio"]), np.asarray(c["pairs"]["power_ratio"])
        t_all += list(t)
        p_all += list(p)
        color = _PACE_COLORS.get(name, "0.4")
        e = c["energy_ratio"]["mean"]  # (None without a pair: no scenario where neither failed)
        ax.scatter(t, p, s=10, alpha=0.45, color=color, lw=0,
                   label=f"{_PACE_NAMES.get(name, name)}: {c['variant']} / {c['reference']}, "
                         f"{len(t)} pairs" + ("" if e is None else f" (energy x{e:.2f})"))
        if c["time_ratio"]["mean"] is not None:
            ax.plot(c["time_ratio"]["mean"], c["power_ratio"]["mean"], "o", ms=11, mfc=color,
                    mec="k", mew=1.2, zorder=5)
        # one floor line per power curve (the mission's energy flies on the vehicle's)
        if c["power_floor"] is not None and c["shape"] not in floors:
            floors.add(c["shape"])
            ax.axhline(c["power_floor"], color=color, ls=":", lw=1.2)
            ax.text(0.99, c["power_floor"], f"least power / MPPI's ({name})", color=color,
                    fontsize=7, ha="right", va="bottom", transform=ax.get_yaxis_transform())
    th = result["thesis"]
    ax.plot(th["time_ratio"], th["power_ratio"], "*", ms=16, mfc="gold", mec="k", zorder=6,
            label=f"the thesis's means (energy x{th['time_ratio'] * th['power_ratio']:.2f})")
    lo, hi = 0.8 * min(t_all), 1.1 * max(t_all)
    tt = np.linspace(max(lo, 0.05), hi, 200)
    ax.plot(tt, 1.0 / tt, "k--", lw=1, label="the same energy as MPPI")
    ax.plot(tt, (1.0 - PAIRED_SAVING) / tt, "k:", lw=1,
            label=f"{100 * PAIRED_SAVING:.1f} % less (the thesis's paired saving)")
    ax.set_xlim(lo, hi)
    ax.set_ylim(0.0, 1.05 * max(p_all))
    ax.set_xlabel("time ratio  T / T_MPPI")
    ax.set_ylabel("mean-power ratio  (E/T) / (E_MPPI/T_MPPI)")
    ax.plot([], [], "o", ms=11, mfc="0.8", mec="k", mew=1.2, ls="",
            label="large markers: each curve's means")
    ax.grid(alpha=0.3)
    # the scatter's keys enlarged alone: a markerscale for all made the star's key cover the
    # key of the row above it (figures audit, 2026-12-05)
    legend = ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.14))
    for handle in legend.legend_handles:
        if isinstance(handle, PathCollection):
            handle.set_sizes([25.0])
            handle.set_alpha(0.8)
    ax.set_title("Energy = mean power x time: scenarios where neither failed", fontsize=10)
    return _save(fig, path)


@closes_figures_on_error
def plot_bound(result: dict, path) -> Path:
    """The largest table ratio any planner could reach at each failure rate, from the GS+W
    bound (:func:`windnav.experiments.nav_bound.bound_study`), with the issue's targets and
    each variant's measured failure rate and table ratio."""
    check_result(
        result, ("curve", "n", "targets", "variants", "reference"), "plot_bound",
        "windnav.experiments.nav_bound.bound_study")
    path = figure_path(path, "plot_bound")
    fig, ax = plt.subplots(figsize=(7.5, 5.4))
    c = result["curve"]
    f, r = np.asarray(c["failure_pct"]), 100.0 * np.asarray(c["table_ratio"])
    ax.plot(f, r, "k-", lw=1.6, label=f"bound: the cheapest GS+W routes ({result['n']} "
                                       "scenarios)")
    slack = result.get("shortfall", {}).get("slack", 1.0)
    if slack < 1.0:
        ax.plot(f, 100.0 * np.asarray(c["table_ratio_with_slack"]), "k--", lw=1.0,
                label=f"the same, every route {100.0 * (1.0 - slack):.1f} % cheaper (the "
                      "largest shortfall flown)")
        r = 100.0 * np.asarray(c["table_ratio_with_slack"])
    ax.fill_between(f, r, 100.0, color="0.85", label="out of reach of any planner")
    for k, t in enumerate(result["targets"]):
        ax.plot(t["failure_pct"], 100.0 * t["table_ratio"], "*", ms=15, mfc="gold", mec="k",
                zorder=6)
        ax.annotate(f"target, {t['whose']}\n(bound {100.0 * t['ideal_table_ratio']:.1f} %, "
                    f"{100.0 * t['ideal_table_ratio_with_slack']:.1f} % with the shortfall)",
                    (t["failure_pct"], 100.0 * t["table_ratio"]), fontsize=7,
                    xytext=(10, -24 if k % 2 == 0 else 10), textcoords="offset points")
    settings = False
    shown = 0
    for v, row in result["variants"].items():
        if row["table_ratio"] is None:
            continue
        y = 100.0 * row["table_ratio"]
        if v.startswith("ea-mppi-w-esc@"):  # the sixth variant's settings: one legend entry
            ax.plot(row["failure_pct"], y, "o", ms=4, color="C2",
                    label=None if settings else "ea-mppi-w-esc@... (the sixth variant's settings)")
            settings = True
            continue
        ax.plot(row["failure_pct"], y, "o", ms=5, color="C0" if v != result["route_variant"]
                else "C3")
        ax.annotate(v, (row["failure_pct"], y), fontsize=6,  # staggered: neighbours overlapped
                    xytext=(4, (-8, 3, -17)[shown % 3]), textcoords="offset points")
        shown += 1
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.set_xlim(0.0, 100.0)
    lows = [100.0 * row["table_ratio"] for row in result["variants"].values()
            if row["table_ratio"] is not None]
    ax.set_ylim(min([*lows, float(r.min())]) - 5.0, max(60.0, float(r.max()) + 5.0))
    ax.set_xlabel("failure rate, % of the scenarios")
    ax.set_ylabel(f"table ratio against {result['reference']}, %  (1 - mean E / mean E_ref)")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, loc="upper left")
    ax.set_title("The table ratio any planner could reach, and the measured variants",
                 fontsize=10)
    return _save(fig, path)


_TILT_STYLE = {"mppi": ("#7f7f7f", "o"), "mppi-w": ("#1f77b4", "s"),
               "ea-mppi": ("#ff7f0e", "^"), "ea-mppi-w": ("#d62728", "D")}


@closes_figures_on_error
def plot_tilt(result: dict, path) -> Path:
    """The thesis's four variants against the tilt cap
    (:func:`windnav.experiments.nav_tilt.tilt_study`): failure rate, paired energy reduction
    against MPPI at the same cap (95 % interval) and mean commanded acceleration, each with the
    thesis's value beside it, and the share of flights that went above the vehicle's trusted
    airspeed (where the drag and power models extrapolate)."""
    check_result(
        result, ("tilts", "thesis", "variants", "rows", "a_max", "scenarios"), "plot_tilt",
        "windnav.experiments.nav_tilt.tilt_study")
    path = figure_path(path, "plot_tilt")
    tilts = result["tilts"]
    fig, axes = plt.subplots(1, 4, figsize=(17.5, 4.4))
    x = np.asarray(tilts)
    x_thesis = x[-1] + 0.35 * (x[-1] - x[0] if len(x) > 1 else 10.0)
    thesis = result["thesis"]
    ref = result["variants"][0]
    for v in result["variants"]:
        color, marker = _TILT_STYLE.get(v, ("0.3", "o"))
        rows = [result["rows"][t][v] for t in tilts]
        th = thesis.get(v, {})
        axes[0].plot(x, [r["failure_pct"]["value"] for r in rows], marker=marker, color=color,
                     label=v)
        axes[2].plot(x, [r["cmd_accel"] for r in rows], marker=marker, color=color, label=v)
        if all(r["outside_envelope"] is not None for r in rows):
            axes[3].plot(x, [100.0 * r["outside_envelope"] / r["flights"] for r in rows],
                         marker=marker, color=color, label=v)
        for ax, key in ((axes[0], "failure_pct"), (axes[2], "cmd_accel")):
            if key in th:
                ax.plot(x_thesis, th[key], marker=marker, mfc="none", mec=color, ms=9, ls="")
        if v == ref:
            continue
        mean = np.array([np.nan if r["paired"]["mean"] is None else 100.0 * r["paired"]["mean"]
                         for r in rows])  # no pair at a cap: no point (a TypeError before)
        # no interval (one pair, or every pair the same): a point without a bar
        lo, hi = np.array([[100.0 * c for c in r["paired"]["ci95"]] if r["paired"]["ci95"]
                           else [m, m] for r, m in zip(rows, mean, strict=True)]).T
        axes[1].errorbar(x, mean, yerr=[mean - lo, hi - mean], marker=marker, color=color,
                         capsize=3, label=f"{v} (pairs {min(r['paired']['n'] for r in rows)}-"
                                          f"{max(r['paired']['n'] for r in rows)})")
    axes[1].plot(x_thesis, 100.0 * PAIRED_SAVING, marker="D", mfc="none",
                 mec=_TILT_STYLE["ea-mppi-w"][0], ms=9)
    axes[1].axhline(0.0, color="k", lw=0.8)
    axes[2].plot(x, [result["a_max"][t] * math.sqrt(2.0) for t in tilts], "k:", lw=1,
                 label="the cap g tan(tilt)")
    titles = ("failure %", f"paired energy reduction against {ref} at the same cap, %",
              "mean commanded acceleration, m/s²",
              "flights above the trusted airspeed, %")
    for i, (ax, title) in enumerate(zip(axes, titles, strict=True)):
        ticks = [*x, x_thesis] if i < 3 else list(x)
        ax.set_xticks(ticks, [f"{t:g}°" for t in tilts] + (["thesis"] if i < 3 else []))
        ax.set_xlabel("tilt cap (planner a_max = g tan(tilt) / √2)")
        ax.set_title(title, fontsize=10)
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8, loc="lower left")
    axes[1].legend(fontsize=7)
    axes[2].legend(fontsize=8)
    axes[3].set_ylim(bottom=0.0)
    fig.suptitle(f"The thesis's variants with more authority: {result['scenarios']} scenarios, "
                 "each flown by every variant at every cap (open markers: the thesis's table)",
                 fontsize=10)
    return _save(fig, path)
