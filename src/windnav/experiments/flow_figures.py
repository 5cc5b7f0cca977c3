"""Figures of the flow solver: a mean wind field over its map, and the validation studies.

``plot_mean_speed`` is the picture of ``windnav wind``; ``plot_checks`` and ``plot_strouhal``
are the figures of ``windnav flow-validate`` (:mod:`windnav.experiments.flow_validation`).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from windnav._console import closes_figures_on_error, save_and_close
from windnav.experiments import flow_validation as fv

__all__ = ["CHECK_FIGURES", "STROUHAL_FIGURES", "plot_checks", "plot_mean_speed",
           "plot_strouhal"]

CHECK_FIGURES = ("flow_divergence.png", "flow_city_speed.png", "flow_taylor_green.png")
"""Files written by :func:`plot_checks`."""
STROUHAL_FIGURES = ("flow_strouhal_resolution.png", "flow_strouhal_incidence.png",
                    "flow_strouhal_aspect.png")
"""Files :func:`plot_strouhal` may write (those of the studies that ran)."""


@closes_figures_on_error
def plot_mean_speed(solution, city, path, title: str = "") -> Path:
    """Save a PNG of the mean wind speed with streamlines over the buildings.

    Parameters
    ----------
    solution : FlowSolution
        ``x`` (nx,), ``y`` (ny,) m; ``solid`` (ny, nx); ``mean_u``, ``mean_v`` (ny, nx) m/s.
    city : City
        Its footprints are drawn as grey rectangles.
    path : str or path-like
        The PNG to write.
    title : str, optional
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure
    from matplotlib.patches import Rectangle

    x, y = np.asarray(solution.x), np.asarray(solution.y)
    solid = np.asarray(solution.solid, dtype=bool)
    u = np.ma.masked_array(solution.mean_u, mask=solid)
    v = np.ma.masked_array(solution.mean_v, mask=solid)
    speed = np.ma.sqrt(u * u + v * v)
    aspect = (np.ptp(y) + 1.0) / (np.ptp(x) + 1.0)
    fig = Figure(figsize=(7.0, float(np.clip(6.0 * aspect, 2.5, 12.0)) + 0.8))
    FigureCanvasAgg(fig)
    ax = fig.add_subplot()
    mesh = ax.pcolormesh(x, y, speed, shading="nearest", cmap="viridis")
    fig.colorbar(mesh, ax=ax, label="mean wind speed (m/s)")
    if x.size > 1 and y.size > 1:
        ax.streamplot(x, y, u.filled(np.nan), v.filled(np.nan), color="w", linewidth=0.6,
                      density=1.2, arrowsize=0.7)
    for x0, x1, y0, y1 in city.footprints:
        ax.add_patch(Rectangle((x0, y0), x1 - x0, y1 - y0, facecolor="0.45", edgecolor="k",
                               linewidth=0.4, zorder=3))
    hx = 0.5 * (x[1] - x[0]) if x.size > 1 else 0.5
    hy = 0.5 * (y[1] - y[0]) if y.size > 1 else 0.5
    ax.set_xlim(x[0] - hx, x[-1] + hx)
    ax.set_ylim(y[0] - hy, y[-1] + hy)
    ax.set_aspect("equal")
    ax.set_xlabel("x east (m)")
    ax.set_ylabel("y north (m)")
    if title:
        ax.set_title(title)
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=150, bbox_inches="tight")
    return path


@closes_figures_on_error
def plot_checks(out, proj: dict, tg: dict) -> list[str]:
    """The figures of the solver checks (divergence and wall error per step, the random
    city's speed, Taylor-Green energy decay) into the folder ``out``; returns the file names."""
    out = Path(out)
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.semilogy(np.maximum(proj["max_div_dx_over_U"], 1e-18), label="max |div u| dx / U")
    ax.semilogy(np.maximum(proj["max_fixed_face_error"], 1e-18), label="max |u_n| on solid faces")
    ax.axhline(1e-8, color="k", ls="--", lw=0.8, label="acceptance 1e-8")
    ax.set_xlabel("step")
    ax.set_ylabel("error (|div u| dx / U; |u_n| in m/s)")
    ax.legend(fontsize=8)
    ax.set_title("after every exact projection (0 shown as 1e-18)")
    fig.tight_layout()
    save_and_close(fig, out / "flow_divergence.png", dpi=110)

    g = proj["grid"]
    speed = np.hypot(0.5 * (proj["u"][:, :-1] + proj["u"][:, 1:]),
                     0.5 * (proj["v"][:-1, :] + proj["v"][1:, :]))
    speed[proj["solid"]] = np.nan
    fig, ax = plt.subplots(figsize=(7, 4))
    im = ax.imshow(speed, origin="lower", extent=(0, g.nx * g.dx, 0, g.ny * g.dx))
    fig.colorbar(im, ax=ax, label="|u| (m/s)")
    ax.set(xlabel="x (m)", ylabel="y (m)")
    ax.set_title("instantaneous speed, random city, 5 m/s at 15 deg")
    fig.tight_layout()
    save_and_close(fig, out / "flow_city_speed.png", dpi=110)

    fig, ax = plt.subplots(figsize=(6, 3.5))
    for scheme, r in tg.items():
        ax.semilogy(r["t"], np.array(r["energy"]) / r["energy"][0],
                    label=f"{scheme}: nu_num = {r['nu']:.2e} m^2/s")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("E / E0")
    ax.set_title("Taylor-Green vortex, free-slip box [0, pi]^2, 64^2")
    ax.legend(fontsize=8)
    fig.tight_layout()
    save_and_close(fig, out / "flow_taylor_green.png", dpi=110)
    return ["flow_divergence.png", "flow_city_speed.png", "flow_taylor_green.png"]



@closes_figures_on_error
def plot_strouhal(out, res: dict) -> list[str]:
    """The Strouhal figures of whichever studies ran into the folder ``out``; returns the file
    names."""
    out = Path(out)
    import matplotlib.pyplot as plt

    names = []
    refs = res.get("references", {}).get("points", [])
    lo, hi = fv.ST_RANGE
    if "resolution" in res or "closures" in res:
        fig, ax = plt.subplots(figsize=(6, 3.8))
        if "closures" in res:
            c = res["closures"]
            for name, vals in c["strouhal"].items():
                if name != "default":
                    ax.plot(c["resolutions"], vals, "s--", alpha=0.7, label=f"0 deg, {name}")
        if "resolution" in res:
            r = res["resolution"]
            for angle, vals in r["strouhal"].items():
                ax.plot(r["resolutions"], vals, "o-", label=f"{angle} deg, default closure")
        ax.axhspan(lo, hi, color="0.92", label=f"accepted {lo}-{hi}")
        ax.axhline(0.132, color="k", lw=0.8, ls=":", label="Lyn et al. 1995 (Re 21,400)")
        studies = [res[k] for k in ("closures", "resolution") if k in res]
        if not np.any(np.isfinite(np.asarray(
                [v for r in studies for vals in r["strouhal"].values() for v in vals],
                dtype=float))):
            # no run gave a St (NaN: no resolved shedding), so no point set the x range
            tried = [n for r in studies for n in r["resolutions"]]
            ax.set_xlim(min(tried) / 1.5, max(tried) * 1.5)
        ax.set_xscale("log", base=2)
        ax.set_xlabel("cells per body height H / dx (dt halved with dx)")
        ax.set_ylabel("St = f H / U")
        ax.set_title("square cylinder: St under grid refinement", fontsize=10)
        ax.legend(fontsize=7)
        fig.tight_layout()
        save_and_close(fig, out / "flow_strouhal_resolution.png", dpi=110)
        names.append("flow_strouhal_resolution.png")
    if "incidence" in res:
        inc = res["incidence"]
        fig, ax = plt.subplots(figsize=(6.5, 4.4))
        unsettled = {(float(b), float(a)) for b, a in inc.get("unsettled", [])}
        extended = {(float(b), float(a)) for b, a, _ in inc.get("extended", [])}
        for shape, vals in inc["strouhal"].items():
            line, = ax.plot(inc["angles"], vals, "o-", ms=3, label=f"computed {shape}:1")
            longer = [(a, v) for a, v in zip(inc["angles"], vals, strict=True)
                      if (float(shape), float(a)) in extended - unsettled]
            if longer:  # settled only over a doubled record: a diamond
                ax.plot(*zip(*longer, strict=True), "D", ms=4, color=line.get_color(),
                        zorder=3)
            odd = [(a, v) for a, v in zip(inc["angles"], vals, strict=True)
                   if (float(shape), float(a)) in unsettled]
            if odd:  # runs that switch shedding states within their record: hollow
                ax.plot(*zip(*odd, strict=True), "o", ms=6, mfc="w", mec=line.get_color(),
                        zorder=3)
        if extended - unsettled:
            ax.plot([], [], "D", ms=4, color="0.3",
                    label="settled over a longer record (doubled, up to 1,280 H/U)")
        if unsettled:
            ax.plot([], [], "o", ms=6, mfc="w", mec="0.3",
                    label="unsettled (its longest record's halves differ > 3 %)")
        pts = [p for p in refs if p["study"] == "incidence"]
        if pts:
            ax.plot([p["angle_deg"] for p in pts], [p["strouhal"] for p in pts], "k*", ms=9,
                    label="experiments (reference CSV)")
        ax.set_xlabel("incidence (inlet direction, deg)")
        ax.set_ylabel("St = f H / U")
        ax.set_title(f"St against incidence, {fv.STUDY_CELLS} cells per height H, default "
                     "closure", fontsize=10)
        ax.legend(fontsize=7, loc="upper center", bbox_to_anchor=(0.5, -0.17), ncol=2)
        fig.tight_layout()
        save_and_close(fig, out / "flow_strouhal_incidence.png", dpi=110)
        names.append("flow_strouhal_incidence.png")
    if "aspect_ratio" in res:
        ar = res["aspect_ratio"]
        fig, ax = plt.subplots(figsize=(6.5, 3.8))
        ax.plot(ar["ratios"], ar["strouhal"], "o-", label="computed, 0 deg")
        longer = [(r, v) for r, v in zip(ar["ratios"], ar["strouhal"], strict=True)
                  if r in {b for b, _, _ in ar.get("extended", [])}
                  and r not in set(ar.get("unsettled", []))]
        if longer:
            ax.plot(*zip(*longer, strict=True), "D", ms=8, color="C0", mec="k", zorder=3,
                    label="settled over a longer record (doubled, up to 1,280 H/U)")
        odd = [(r, v) for r, v in zip(ar["ratios"], ar["strouhal"], strict=True)
               if r in set(ar.get("unsettled", []))]
        if odd:
            ax.plot(*zip(*odd, strict=True), "o", ms=7, mfc="w", mec="C0", zorder=3,
                    label="unsettled (its longest record's halves differ > 3 %)")
        pts = [p for p in refs if p["study"] == "aspect_ratio"]
        if pts:
            ax.plot([p["aspect_ratio"] for p in pts], [p["strouhal"] for p in pts], "k*", ms=9,
                    label="experiments (reference CSV)")
        ax.axvline(2.8, color="0.5", ls="--", lw=0.8,
                   label="reattachment jump, B/H ~ 2.8 (Nakaguchi et al. 1968)")
        ax.set_xlabel("depth ratio B / H")
        ax.set_ylabel("St = f H / U")
        ax.set_title(f"St against aspect ratio, {fv.STUDY_CELLS} cells per height H",
                     fontsize=10)
        ax.legend(fontsize=7)
        fig.tight_layout()
        save_and_close(fig, out / "flow_strouhal_aspect.png", dpi=110)
        names.append("flow_strouhal_aspect.png")
    return names
