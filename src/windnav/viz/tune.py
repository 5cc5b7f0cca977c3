"""The figure of the MPPI tuning study (:func:`windnav.experiments.tune_mppi.tune`): the cost of
every trial with the running best, and the thesis defaults (trial 0) marked."""

from __future__ import annotations

from pathlib import Path

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.ticker import MaxNLocator

from windnav._console import closes_figures_on_error, save_and_close
from windnav.viz import check_result, figure_path

__all__ = ["plot_tuning"]


@closes_figures_on_error
def plot_tuning(result: dict, path) -> Path:
    """Cost per trial (s), the running best, and the thesis defaults' cost.

    Trials whose flights all succeeded are filled, those with a failure hollow.

    Parameters
    ----------
    result : dict
        :func:`windnav.experiments.tune_mppi.tune`'s result.
    path : str or path-like
        The PNG to write.
    """
    check_result(
        result, ("trials", "best_cost", "best_trial", "defaults_cost", "seed", "seeds"),
        "plot_tuning", "windnav.experiments.tune_mppi.tune")
    path = figure_path(path, "plot_tuning")
    trials = result["trials"]
    number = np.array([t["number"] for t in trials])
    cost = np.array([t["cost"] for t in trials])
    clean = np.array([all(f["outcome"] == "success" for f in t["flights"]) for t in trials])
    fig, ax = plt.subplots(figsize=(7.0, 4.0), constrained_layout=True)
    ax.scatter(number[clean], cost[clean], s=22, color="C0", label="trial, all flights succeeded")
    ax.scatter(number[~clean], cost[~clean], s=22, facecolors="none", edgecolors="C0",
               label="trial with a failed flight")
    ax.step(number, np.minimum.accumulate(cost), where="post", color="C1", label="running best")
    ax.axhline(result["defaults_cost"], color="C3", ls="--", lw=1.0)
    ax.scatter([number[0]], [cost[0]], marker="*", s=160, color="C3", zorder=3,
               label=f"thesis defaults ({result['defaults_cost']:.1f} s)")
    best = result["best_trial"]
    ax.annotate(f"best: trial {best}, {result['best_cost']:.1f} s", (best, result["best_cost"]),
                xytext=(6, -12), textcoords="offset points", fontsize=8)
    ax.xaxis.set_major_locator(MaxNLocator(integer=True))
    ax.set_xlabel("trial")
    ax.set_ylabel("cost (mean over flights), s")
    ax.set_title(f"MPPI base hyperparameters, intersection without wind "
                 f"(TPE seed {result['seed']}, flight seeds {result['seeds']})", fontsize=9)
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    path = Path(path)
    save_and_close(fig, path, dpi=120)
    return path
