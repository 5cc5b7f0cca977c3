"""Figures of a closed-loop navigation flight (a ``NavigationResult``)."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Rectangle

from windnav._console import closes_figures_on_error, save_and_close
from windnav.viz import figure_path

__all__ = ["plot_navigation", "plot_path", "plot_time_series"]


@closes_figures_on_error
def plot_path(result, city, flow, path) -> Path:
    """The flown path (and the GS route) over the mean wind speed and its streamlines."""
    path = figure_path(path, "plot_path")
    fig, ax = plt.subplots(figsize=(7, 6))
    speed = np.hypot(flow.mean_u, flow.mean_v)
    speed = np.where(flow.solid, np.nan, speed)
    im = ax.pcolormesh(flow.x, flow.y, speed, shading="auto", cmap="viridis")
    fig.colorbar(im, ax=ax, label="mean wind speed (m/s)")
    ax.streamplot(flow.x, flow.y, np.where(flow.solid, 0.0, flow.mean_u),
                  np.where(flow.solid, 0.0, flow.mean_v), color="w", linewidth=0.5,
                  density=1.0, arrowsize=0.6)
    for x0, x1, y0, y1 in city.footprints:
        ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, fc="0.35", ec="k", lw=0.5))
    if result.route is not None:
        ax.plot(*result.route.T, "w--", lw=1.2, label="planned route")
    ax.plot(*result.position[:, :2].T, "r-", lw=1.6, label=f"flown ({result.variant})")
    ax.plot(*result.start, "wo", mec="k", label="start")
    ax.plot(*result.goal, "w*", mec="k", ms=12, label="goal")
    ax.add_patch(plt.Circle(tuple(result.goal), 5.0, fill=False, ec="w", ls=":"))
    x0, x1, y0, y1 = city.bounds
    ax.set_xlim(x0, x1)
    ax.set_ylim(y0, y1)
    ax.set_aspect("equal")
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    ax.set_title(f"{result.variant}: {result.outcome}, {result.time_s:.1f} s, "
                 f"{result.energy_J / 1e3:.2f} kJ")
    ax.legend(loc="upper left", fontsize=8, framealpha=0.6)
    return _save(fig, path)


@closes_figures_on_error
def plot_time_series(result, path) -> Path:
    """Airspeed (and ground speed, wind speed), power and energy against time."""
    path = figure_path(path, "plot_time_series")
    t = result.t
    fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    axes[0].plot(t, result.airspeed, label="airspeed")
    axes[0].plot(t, np.hypot(*result.velocity[:, :2].T), lw=1, label="ground speed")
    axes[0].plot(t, np.hypot(*result.wind.T), lw=1, label="wind speed")
    axes[0].set_ylabel("speed (m/s)")
    axes[0].legend(fontsize=8)
    axes[1].plot(t, result.power, label="airspeed power curve P(|v - w|)")
    axes[1].plot(t, result.rotor_power, lw=1, label="rotor power (6-DoF)")
    axes[1].set_ylabel("power (W)")
    axes[1].legend(fontsize=8)
    axes[2].plot(t, result.energy / 1e3, label="airspeed model")
    axes[2].plot(t, result.rotor_energy / 1e3, label="rotor")
    axes[2].set_ylabel("energy (kJ)")
    axes[2].set_xlabel("time (s)")
    axes[2].legend(fontsize=8)
    axes[0].set_title(f"{result.variant}: {result.outcome}")
    return _save(fig, path)


@closes_figures_on_error
def plot_navigation(result, city, flow, out_dir, *, prefix: str = "navigate") -> list[Path]:
    """Write ``{prefix}_path.png`` and ``{prefix}_series.png`` into ``out_dir``."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    return [plot_path(result, city, flow, out / f"{prefix}_path.png"),
            plot_time_series(result, out / f"{prefix}_series.png")]


def _save(fig, path) -> Path:
    path = Path(path)
    fig.tight_layout()
    save_and_close(fig, path, dpi=110)
    return path
