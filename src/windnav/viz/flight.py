"""Plots of a ``FlightLog``: 3D path, tracking error, wind, power and energy."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np

from windnav._console import closes_figures_on_error, save_and_close


@closes_figures_on_error
def plot_flight(log, out_dir, *, vehicle: int = 0, prefix: str = "flight") -> list[Path]:
    """Write PNG figures of one vehicle of ``log`` into ``out_dir``; returns their paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    paths = []
    t = log.t
    pos = log.position[:, vehicle]

    fig = plt.figure(figsize=(6, 5))
    ax = fig.add_subplot(projection="3d")
    ax.plot(*log.target_position.T, "k--", lw=1, label="reference")
    ax.plot(*pos.T, lw=1.5, label="flown")
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    ax.set_zlabel("z up (m)")
    # one scale on the three axes: each scaled to its own range, a 5 cm altitude wobble
    # looked as large as a 6 m circle (figures audit, 2026-12-05)
    both = np.concatenate([log.target_position, pos])
    both = both[np.all(np.isfinite(both), axis=1)]
    if both.size:
        centre = 0.5 * (both.min(axis=0) + both.max(axis=0))
        half = max(0.5 * float(np.ptp(both, axis=0).max()), 0.5)
        ax.set_xlim(centre[0] - half, centre[0] + half)
        ax.set_ylim(centre[1] - half, centre[1] + half)
        ax.set_zlim(centre[2] - half, centre[2] + half)
        ax.set_box_aspect((1.0, 1.0, 1.0))
    ax.legend()
    ax.set_title("3D path (equal scales)")
    paths.append(_save(fig, out / f"{prefix}_path.png"))

    fig, axes = plt.subplots(4, 1, figsize=(8, 9), sharex=True)
    axes[0].plot(t, log.tracking_error[:, vehicle])
    axes[0].set_ylabel("tracking error (m)")
    for j, lab in enumerate("xyz"):
        axes[1].plot(t, log.wind[:, vehicle, j], label=f"wind {lab}")
    axes[1].set_ylabel("wind (m/s)")
    axes[1].legend(ncol=3, fontsize=8)
    axes[2].plot(t, log.power[:, vehicle])
    axes[2].set_ylabel("rotor power (W)")
    axes[3].plot(t, log.energy[:, vehicle] / 1000.0)
    axes[3].set_ylabel("energy (kJ)")
    axes[3].set_xlabel("time (s)")
    sat = np.any(log.saturated[:, vehicle], axis=-1)
    if sat.any():
        axes[2].fill_between(t, 0, 1, where=sat, transform=axes[2].get_xaxis_transform(),
                             color="red", alpha=0.15, label="rotor saturated")
        axes[2].legend(fontsize=8)
    fig.suptitle(f"{', '.join(log.meta.get('vehicles', []))} in {log.meta.get('wind', '')}")
    paths.append(_save(fig, out / f"{prefix}_timeseries.png"))
    return paths


def _save(fig, path: Path) -> Path:
    fig.tight_layout()
    save_and_close(fig, path, dpi=110)
    return path
