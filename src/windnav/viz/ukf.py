"""Plots of the Wind UKF: estimate against truth along a flight, Monte Carlo RMSE scatter."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import matplotlib.ticker as mticker
import numpy as np

from windnav._console import closes_figures_on_error, save_and_close
from windnav.viz import check_result, figure_path

__all__ = ["plot_montecarlo", "plot_wind_track"]


def _save(fig, path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.tight_layout()
    save_and_close(fig, path, dpi=120)
    return path


@closes_figures_on_error
def plot_wind_track(track, path, *, settle_s: float = 2.0) -> Path:
    """Estimated (with a 2-sigma band) and true wind per world axis against time.

    Parameters
    ----------
    track : WindTrack
        From :func:`windnav.estimate.flight.run_wind_ukf`.
    path : str or Path
        PNG file to write.
    settle_s : float
        Settling time excluded from the RMSE in the title, s.
    """
    path = figure_path(path, "plot_wind_track")
    fig, axes = plt.subplots(3, 1, figsize=(8, 7), sharex=True)
    t = track.t
    for j, (ax, lab) in enumerate(zip(axes, "xyz", strict=True)):
        sd = np.sqrt(track.wind_cov[:, j, j])
        ax.fill_between(t, track.wind_est[:, j] - 2 * sd, track.wind_est[:, j] + 2 * sd,
                        alpha=0.25, lw=0, label="estimate ± 2σ")
        ax.plot(t, track.wind_true[:, j], "k", lw=1, label="true")
        ax.plot(t, track.wind_est[:, j], lw=1, label="estimate")
        ax.set_ylabel(f"wind {lab} (m/s)")
        # the scale of the settled estimate: the start's wide prior squeezed the rest flat
        after = t >= settle_s
        seen = np.concatenate([track.wind_true[after, j],
                               track.wind_est[after, j] - 2 * sd[after],
                               track.wind_est[after, j] + 2 * sd[after]])
        seen = seen[np.isfinite(seen)]
        if seen.size and np.any(~after):
            pad = 0.1 * max(float(np.ptp(seen)), 0.2)
            ax.set_ylim(float(seen.min()) - pad, float(seen.max()) + pad)
            ax.axvspan(t[0], settle_s, color="0.85", lw=0, zorder=0,
                       label=f"settling (first {settle_s:g} s, off the scale)" if j == 0
                       else None)
    axes[0].legend(ncol=4, fontsize=8, loc="lower left", bbox_to_anchor=(0.0, 1.02),
                   frameon=False)  # above the data, wherever it lies
    axes[-1].set_xlabel("time (s)")
    fig.suptitle(f"Wind UKF: 3D RMSE after {settle_s:g} s = "
                 f"{track.rmse_after(settle_s):.3f} m/s")
    return _save(fig, Path(path))


@closes_figures_on_error
def plot_montecarlo(result: dict, path) -> Path:
    """RMSE of each trial against the mass-to-drag ratio ``tau_drag`` (log axis).

    Parameters
    ----------
    result : dict
        From :func:`windnav.experiments.ukf_montecarlo.run_montecarlo`.
    path : str or Path
        PNG file to write.
    """
    check_result(
        result, ("trials", "summary"), "plot_montecarlo",
        "windnav.experiments.ukf_montecarlo.run_montecarlo")
    path = figure_path(path, "plot_montecarlo")
    ok = [t for t in result["trials"] if "error" not in t and np.isfinite(t["rmse"])]
    tau = np.array([t["tau_drag"] for t in ok])
    rmse = np.array([t["rmse"] for t in ok])
    mass = np.array([t["params"]["mass"] for t in ok])
    fig, ax = plt.subplots(figsize=(7, 4.5))
    sc = ax.scatter(np.clip(tau, 1e-3, 1e4), rmse, c=mass, cmap="viridis", s=25)
    fig.colorbar(sc, ax=ax, label="mass (kg)")
    s = result["summary"]
    if s.get("n"):
        ax.axhline(s["median"], color="k", ls="--", lw=1, label=f"median {s['median']:.3f} m/s")
        ax.legend()
    ax.set_xscale("log")
    decades = np.ptp(np.log10(np.clip(tau, 1e-3, 1e4))) if tau.size else np.inf
    if decades < 2.0:
        # within a decade or two matplotlib labels minor ticks as 3x10^-1, 4x10^-1, ..., which
        # run into each other (figures audit, 2026-12-05): plain numbers, every minor tick
        # under a decade, only 2 and 5 of each decade above one
        plain = mticker.FuncFormatter(lambda x, _: f"{x:g}")
        ax.xaxis.set_major_formatter(plain)
        ax.xaxis.set_minor_formatter(plain if decades < 1.0 else mticker.FuncFormatter(
            lambda x, _: f"{x:g}" if round(x / 10 ** np.floor(np.log10(x))) in (2, 5) else ""))
        ax.tick_params(axis="x", which="minor", labelsize=8)
    ax.set_xlabel(r"mass-to-drag ratio $\tau_d = m / (k_d N \eta_{hover})$ (s)")
    ax.set_ylabel("3D wind RMSE (m/s)")
    ax.set_title(f"Wind UKF Monte Carlo: {len(ok)} trials, {result.get('failed', 0)} failed")
    return _save(fig, Path(path))
