"""``windnav flow-validate``: the flow solver's validation study (plots + JSON).

Checks, each against a reference that does not come from this code: the discrete
divergence after every projection (0), the normal velocity on building faces (0), uniform
flow without buildings (stays uniform), the Taylor-Green vortex in a free-slip box (an exact
steady Euler solution: its decay is the scheme's numerical viscosity), and the Strouhal
number of a square building (0.13, Okajima 1982; Lyn et al. 1995) with a dx, dt halving.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from windnav.city import City
from windnav.flow import (
    BoundaryConditions,
    MACGrid,
    SquareCylinderCase,
    divergence,
    fixed_face_violation,
    make_advection,
    make_domain,
    make_flow_step,
    simulate,
    square_cylinder_strouhal,
)


def register(subparsers) -> None:
    p = subparsers.add_parser(
        "flow-validate",
        help="validate the 2D flow solver (divergence, walls, vortex decay, Strouhal)",
        description=__doc__.splitlines()[0],
    )
    p.add_argument("--out", type=Path, required=True, help="output folder (plots, JSON)")
    p.add_argument("--full", action="store_true",
                   help="also run the MacCormack Strouhal halving study (several minutes)")
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
                       spinup_steps=50, steps=50, symmetry_break=0.0)
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


def strouhal_study(full: bool):
    schemes = ("semi_lagrangian", "maccormack") if full else ("semi_lagrangian",)
    res = {}
    for scheme in schemes:
        base = SquareCylinderCase(cells_per_side=8, advection=scheme)
        for case in (base, base.refined()):
            r = square_cylinder_strouhal(case, progress=True)
            res[f"{scheme}/{case.cells_per_side}"] = {
                "strouhal": r["strouhal"], "strouhal_spectrum": r["strouhal_spectrum"],
                "dx": r["dx"], "dt": r["dt"], "shape": list(r["shape"]), "steps": r["steps"],
                "t": r["t"].tolist(), "probe_v": r["probe_v"].tolist(),
            }
        a, b = (res[f"{scheme}/{n}"]["strouhal"] for n in (8, 16))
        res[f"{scheme}/halving_change"] = float(abs(b - a) / a)
    return res


def _plots(out: Path, proj, tg, st):
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

    fig, ax = plt.subplots(figsize=(7, 3.5))
    for key, r in st.items():
        if isinstance(r, dict):
            ax.plot(r["t"], r["probe_v"], lw=0.8, label=f"{key} cells/D: St = {r['strouhal']:.3f}")
    ax.set_xlabel("t (D/U)")
    ax.set_ylabel("v at wake probe (U)")
    ax.set_title("square building at 0 deg: wake probe 2D behind the rear face")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "flow_strouhal.png", dpi=110)
    plt.close(fig)


def run(args) -> int:
    out = Path(args.out)
    out.mkdir(parents=True, exist_ok=True)
    rng = np.random.default_rng(args.seed)
    proj = projection_study(rng)
    uni = uniform_study()
    tg = taylor_green_study()
    st = strouhal_study(args.full)
    _plots(out, proj, tg, st)
    summary = {
        "max_div_dx_over_U": max(proj["max_div_dx_over_U"]),
        "max_fixed_face_error": max(proj["max_fixed_face_error"]),
        "uniform_flow_max_error": uni,
        "taylor_green_nu": {k: r["nu"] for k, r in tg.items()},
        "strouhal": {k: (r["strouhal"] if isinstance(r, dict) else r) for k, r in st.items()},
        "strouhal_spectrum": {k: r["strouhal_spectrum"] for k, r in st.items()
                              if isinstance(r, dict)},
    }
    (out / "flow_validation.json").write_text(json.dumps(summary, indent=2))
    print(json.dumps(summary, indent=2))
    return 0
