"""``windnav flow-validate``: the flow solver's validation study (plots + JSON).

Checks, each against a reference that does not come from this code: the discrete
divergence after every projection (0), the normal velocity on building faces (0), uniform
flow without buildings (stays uniform), the Taylor-Green vortex in a free-slip box (an exact
steady Euler solution: its decay is the scheme's numerical viscosity). ``--studies`` adds the
Strouhal studies of the thesis's validation figure (St against incidence for 1:1, 2:1 and 3:1
rectangles, St against the depth ratio B/H; about 15-20 minutes on 2 cores), ``--full`` also the
resolution series (a square at 0 and 90 deg, 8/16/32 cells per height), the closure comparison
and the label-noise table of the thesis's averaging protocol (about 30-40 minutes).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from windnav.city import City
from windnav.experiments import flow_validation as fv
from windnav.flow import (
    BoundaryConditions,
    MACGrid,
    divergence,
    fixed_face_violation,
    make_advection,
    make_domain,
    make_flow_step,
    simulate,
)


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "flow-validate",
        help="validate the 2D flow solver (divergence, walls, vortex decay, Strouhal)",
        description=__doc__.splitlines()[0],
    )
    p.add_argument("--out", type=Path, required=True, help="output folder (plots, JSON)")
    p.add_argument("--studies", action="store_true",
                   help="also run the Strouhal studies against incidence and aspect ratio "
                        "(about 15-20 minutes on 2 cores)")
    p.add_argument("--full", action="store_true",
                   help="the studies, plus the resolution series (8/16/32 cells per height), "
                        "the closure comparison and the label-noise table (30-40 minutes)")
    p.add_argument("--workers", type=int, default=None,
                   help="worker processes for the Strouhal runs (default: all cores)")
    p.add_argument("--seed", type=int, default=0, help="seed of the random city layout")
    p.set_defaults(func=run)


def _random_city(rng: np.random.Generator) -> City:
    fp = []
    for _ in range(8):
        x0, y0 = rng.uniform(15.0, 105.0), rng.uniform(8.0, 62.0)
        w, h = rng.uniform(4.0, 12.0, 2)
        fp.append([x0, x0 + w, y0, y0 + h])
    return City((0.0, 140.0, 0.0, 80.0), fp, np.full(len(fp), 20.0))


def projection_study(rng, steps=300):
    city = _random_city(rng)
    speed, dx, dt = 5.0, 1.0, 0.1
    grid = MACGrid((80, 140), dx)
    domain = make_domain(grid, city.rasterize(grid.x, grid.y),
                         BoundaryConditions.for_wind(speed, 15.0))
    step = make_flow_step(domain, dt)
    u, v = step.project(*domain.initial_velocity(0.05 * speed))
    div, wall = [], []
    for _ in range(steps):
        u, v = step(u, v)
        div.append(float(np.abs(divergence(domain, u, v)).max() * dx / speed))
        wall.append(fixed_face_violation(domain, u, v))
    return {"max_div_dx_over_U": div, "max_fixed_face_error": wall,
            "solid": domain.solid, "u": u, "v": v, "grid": grid}


def uniform_study():
    city = City((0.0, 60.0, 0.0, 40.0), np.zeros((0, 4)), np.zeros(0))
    out = {}
    for direction in (0.0, 30.0, 90.0, 135.0, 200.0, 290.0):
        sol = simulate(city, speed=4.0, direction_deg=direction, dx=1.0, dt=0.2,
                       spinup_steps=50, steps=50)
        th = np.deg2rad(direction)
        err = max(np.abs(sol.mean_u - 4.0 * np.cos(th)).max(),
                  np.abs(sol.mean_v - 4.0 * np.sin(th)).max())
        out[f"{direction:g}"] = float(err)
    return out


def taylor_green_study(n=64, periods=4.0):
    dx = np.pi / n
    grid = MACGrid((n, n), dx)
    box = make_domain(grid, np.zeros((n, n), bool), BoundaryConditions(("wall",) * 4))
    res = {}
    for scheme in ("semi_lagrangian", "maccormack"):
        u = np.sin(grid.x_faces)[None, :] * np.cos(grid.y)[:, None]
        v = -np.cos(grid.x)[None, :] * np.sin(grid.y_faces)[:, None]
        u[:, [0, -1]] = 0.0
        v[[0, -1], :] = 0.0
        dt = 0.5 * dx
        step = make_flow_step(box, dt, make_advection(box, dt, scheme))
        u, v = step.project(u, v)
        steps = int(periods * np.pi / dt)
        e = []
        for _ in range(steps):
            e.append(0.5 * (np.sum(u**2) + np.sum(v**2)) * dx**2)
            u, v = step(u, v)
        t = dt * np.arange(steps)
        nu = -np.polyfit(t, np.log(e), 1)[0] / 4.0
        res[scheme] = {"nu": float(nu), "t": t.tolist(), "energy": e, "dx": dx, "dt": dt}
    return res


def _plots(out: Path, proj, tg):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(6, 3.5))
    ax.semilogy(np.maximum(proj["max_div_dx_over_U"], 1e-18), label="max |div u| dx / U")
    ax.semilogy(np.maximum(proj["max_fixed_face_error"], 1e-18), label="max |u_n| on solid faces")
    ax.axhline(1e-8, color="k", ls="--", lw=0.8, label="acceptance 1e-8")
    ax.set_xlabel("step")
    ax.legend(fontsize=8)
    ax.set_title("after every exact projection (0 shown as 1e-18)")
    fig.tight_layout()
    fig.savefig(out / "flow_divergence.png", dpi=110)
    plt.close(fig)

    g = proj["grid"]
    speed = np.hypot(0.5 * (proj["u"][:, :-1] + proj["u"][:, 1:]),
                     0.5 * (proj["v"][:-1, :] + proj["v"][1:, :]))
    speed[proj["solid"]] = np.nan
    fig, ax = plt.subplots(figsize=(7, 4))
    im = ax.imshow(speed, origin="lower", extent=(0, g.nx * g.dx, 0, g.ny * g.dx))
    fig.colorbar(im, ax=ax, label="|u| (m/s)")
    ax.set_title("instantaneous speed, random city, 5 m/s at 15 deg")
    fig.tight_layout()
    fig.savefig(out / "flow_city_speed.png", dpi=110)
    plt.close(fig)

    fig, ax = plt.subplots(figsize=(6, 3.5))
    for scheme, r in tg.items():
        ax.semilogy(r["t"], np.array(r["energy"]) / r["energy"][0],
                    label=f"{scheme}: nu_num = {r['nu']:.2e} m^2/s")
    ax.set_xlabel("t (s)")
    ax.set_ylabel("E / E0")
    ax.set_title("Taylor-Green vortex, free-slip box [0, pi]^2, 64^2")
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(out / "flow_taylor_green.png", dpi=110)
    plt.close(fig)



def _strouhal_plots(out: Path, res) -> list[str]:
    """The Strouhal figures of whichever studies ran; returns the file names."""
    import matplotlib

    matplotlib.use("Agg")
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
        ax.set_xscale("log", base=2)
        ax.set_xlabel("cells per body height H / dx (dt halved with dx)")
        ax.set_ylabel("St = f H / U")
        ax.set_title("square cylinder: St under grid refinement", fontsize=10)
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(out / "flow_strouhal_resolution.png", dpi=110)
        plt.close(fig)
        names.append("flow_strouhal_resolution.png")
    if "incidence" in res:
        inc = res["incidence"]
        fig, ax = plt.subplots(figsize=(6.5, 3.8))
        for shape, vals in inc["strouhal"].items():
            ax.plot(inc["angles"], vals, "o-", ms=3, label=f"computed {shape}:1")
        pts = [p for p in refs if p["study"] == "incidence"]
        if pts:
            ax.plot([p["angle_deg"] for p in pts], [p["strouhal"] for p in pts], "k*", ms=9,
                    label="experiments (reference CSV)")
        ax.set_xlabel("incidence (inlet direction, deg)")
        ax.set_ylabel("St = f H / U")
        ax.set_title(f"St against incidence, {fv.STUDY_CELLS} cells per height H, default "
                     "closure", fontsize=10)
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig(out / "flow_strouhal_incidence.png", dpi=110)
        plt.close(fig)
        names.append("flow_strouhal_incidence.png")
    if "aspect_ratio" in res:
        ar = res["aspect_ratio"]
        fig, ax = plt.subplots(figsize=(6.5, 3.8))
        ax.plot(ar["ratios"], ar["strouhal"], "o-", label="computed, 0 deg")
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
        fig.savefig(out / "flow_strouhal_aspect.png", dpi=110)
        plt.close(fig)
        names.append("flow_strouhal_aspect.png")
    return names


def strouhal_studies(full: bool, studies: bool, workers: int | None) -> dict:
    """Run the requested Strouhal studies (see the module docstring)."""
    res = {}
    if full:
        res["resolution"] = fv.resolution_study(workers=workers)
        res["closures"] = fv.closure_study(workers=workers)
        res["label_noise"] = fv.label_noise_study()
    if full or studies:
        res["incidence"] = fv.incidence_study(workers=workers)
        res["aspect_ratio"] = fv.aspect_ratio_study(workers=workers)
        res["references"] = fv.compare_references(fv.load_references(), res["incidence"],
                                                   res["aspect_ratio"])
    return res


def _brief(res: dict) -> dict:
    """The studies without the per-run force histories (for the printed summary)."""
    out = {}
    for name, study in res.items():
        if isinstance(study, dict):
            out[name] = {k: v for k, v in study.items() if k not in ("runs", "points")}
            if name == "references":
                out[name]["points"] = [
                    {k: p[k] for k in ("study", "aspect_ratio", "angle_deg", "strouhal",
                                       "computed", "deviation", "source")}
                    for p in study["points"]
                ]
    return out


def run(args) -> int:
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(args.seed)
    proj = projection_study(rng)
    uni = uniform_study()
    tg = taylor_green_study()
    _plots(out, proj, tg)
    st = strouhal_studies(args.full, args.studies, args.workers)
    figures = _strouhal_plots(out, st)
    summary = {
        "max_div_dx_over_U": max(proj["max_div_dx_over_U"]),
        "max_fixed_face_error": max(proj["max_fixed_face_error"]),
        "uniform_flow_max_error": uni,
        "taylor_green_nu": {k: r["nu"] for k, r in tg.items()},
        **_brief(st),
        "figures": figures,
    }
    (out / "flow_validation.json").write_text(json.dumps(summary, indent=2))
    runs = {name: study["runs"] for name, study in st.items() if "runs" in study}
    if runs:
        (out / "strouhal_runs.json").write_text(json.dumps(runs))
    print(json.dumps(summary, indent=2))
    return 0
