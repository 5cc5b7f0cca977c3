"""Figures of the end-to-end demo: map with mean wind and path; estimated vs true wind."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.patches import Rectangle

from windnav._console import closes_figures_on_error, save_and_close
from windnav.viz import check_result, figure_path


@closes_figures_on_error
def plot_map(result: dict, path) -> Path:
    """Mean wind speed with streamlines, buildings, planned route and flown path."""
    check_result(
        result, ("solution", "city", "log", "route", "metrics"), "plot_map",
        "windnav.experiments.demo.run_demo")
    path = figure_path(path, "plot_map")
    sol, city, log, route = result["solution"], result["city"], result["log"], result["route"]
    speed = np.hypot(sol.mean_u, sol.mean_v)
    speed = np.where(sol.solid, np.nan, speed)
    fig, ax = plt.subplots(figsize=(7.5, 6.5))
    im = ax.pcolormesh(sol.x, sol.y, speed, shading="auto", cmap="viridis")
    fig.colorbar(im, ax=ax, label="mean wind speed (m/s)")
    ax.streamplot(sol.x, sol.y, np.where(sol.solid, 0, sol.mean_u),
                  np.where(sol.solid, 0, sol.mean_v), color="white", density=1.2, linewidth=0.6,
                  arrowsize=0.7)
    for x0, x1, y0, y1 in city.footprints:
        ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, color="0.35", zorder=3))
    wp = route["waypoints"]
    ax.plot(wp[:, 0], wp[:, 1], "w--", lw=1.2, zorder=4, label="planned route")
    pos = log.position[:, 0]
    ax.plot(pos[:, 0], pos[:, 1], color="tab:red", lw=2, zorder=5, label="flown path")
    ax.plot(*wp[0], "o", color="white", zorder=6)
    ax.plot(*wp[-1], "*", color="white", ms=12, zorder=6)
    b = city.bounds
    ax.set_xlim(b[0], b[1])
    ax.set_ylim(b[2], b[3])
    ax.set_aspect("equal")
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    m = result["metrics"]
    ax.set_title(f"seed {m['seed']}: inlet {m['inlet_speed_m_s']:.1f} m/s toward "
                 f"{m['wind_direction_deg']:.0f} deg")
    ax.legend(loc="lower right", fontsize=8)
    return _save(fig, path)


@closes_figures_on_error
def plot_wind_estimate(result: dict, path) -> Path:
    """Estimated (with 2-sigma band) and true wind per world axis over time."""
    check_result(
        result, ("track", "metrics", "config"), "plot_wind_estimate",
        "windnav.experiments.demo.run_demo")
    path = figure_path(path, "plot_wind_estimate")
    track = result["track"]
    t = track.t - track.t[0]
    fig, axes = plt.subplots(4, 1, figsize=(9, 9), sharex=True)
    for k, lab in enumerate(("x (east)", "y (north)", "z (up)")):
        sd = np.sqrt(np.maximum(track.wind_cov[:, k, k], 0))
        axes[k].plot(t, track.wind_true[:, k], "k", lw=1, label="true")
        axes[k].plot(t, track.wind_est[:, k], color="tab:blue", lw=1.2, label="Wind UKF")
        axes[k].fill_between(t, track.wind_est[:, k] - 2 * sd, track.wind_est[:, k] + 2 * sd,
                             color="tab:blue", alpha=0.2, label="2 sigma")
        axes[k].set_ylabel(f"wind {lab}\n(m/s)")
    axes[0].legend(ncol=3, fontsize=8)
    err = np.linalg.norm(track.error, axis=1)
    axes[3].plot(t, err, color="tab:red")
    axes[3].set_ylabel("|error| (m/s)")
    axes[3].set_xlabel("time (s)")
    m = result["metrics"]
    fig.suptitle(f"Wind UKF in urban wind: RMSE {m['wind_rmse_m_s']:.2f} m/s after "
                 f"{result['config'].settle_s:.0f} s")
    return _save(fig, path)


def _save(fig, path) -> Path:
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    save_and_close(fig, path, dpi=110)
    return path
