"""``windnav flow-validate``: the flow solver's validation study (plots + JSON).

Checks, each against a reference that does not come from this code: the discrete
divergence after every projection (0), the normal velocity on building faces (0), uniform
flow without buildings (stays uniform), the Taylor-Green vortex in a free-slip box (an exact
steady Euler solution: its decay is the scheme's numerical viscosity), and the Strouhal
number of a square building (0.13, Okajima 1982; Lyn et al. 1995; ~0.145 at Re = 100,
Sohankar et al. 1998) with dx, dt halvings.
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
                   help="also run the MacCormack Strouhal halving studies (inviscid, and Re = 100 "
                        "at D = 8, 16, 32 cells: about 10-15 minutes)")
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


STROUHAL_REYNOLDS = 100.0

# (label, scheme, Reynolds number or None for inviscid, resolutions D/dx): consecutive
# resolutions halve dx and dt together (CFL fixed)
STROUHAL_SERIES_FAST = (("semi_lagrangian", "semi_lagrangian", None, (8, 16)),)
STROUHAL_SERIES_FULL = STROUHAL_SERIES_FAST + (
    ("maccormack", "maccormack", None, (8, 16)),
    (f"maccormack_re{STROUHAL_REYNOLDS:g}", "maccormack", STROUHAL_REYNOLDS, (8, 16, 32)),
)


def strouhal_study(full: bool):
    """St of the square building per scheme and resolution, and the change per halving.

    The inviscid runs have no resolution-independent answer with a low-dissipation scheme
    (the effective Reynolds number grows as dx shrinks); the viscous MacCormack series at
    Re = 100 (Okajima 1982; Sohankar et al. 1998: St ~ 0.14-0.15) is the converging study.
    """
    res = {}
    for label, scheme, reynolds, resolutions in (
        STROUHAL_SERIES_FULL if full else STROUHAL_SERIES_FAST
    ):
        for n in resolutions:
            case = SquareCylinderCase(cells_per_side=n, advection=scheme, reynolds=reynolds)
            r = square_cylinder_strouhal(case, progress=True)
            res[f"{label}/{n}"] = {
                "strouhal": r["strouhal"], "strouhal_spectrum": r["strouhal_spectrum"],
                "dx": r["dx"], "dt": r["dt"], "shape": list(r["shape"]), "steps": r["steps"],
                "reynolds": reynolds, "t": r["t"].tolist(), "probe_v": r["probe_v"].tolist(),
            }
        for a, b in zip(resolutions[:-1], resolutions[1:], strict=True):
            sa, sb = (res[f"{label}/{n}"]["strouhal"] for n in (a, b))
            res[f"{label}/halving_change_{a}_to_{b}"] = float(abs(sb - sa) / sa)
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

    fig, (ax0, ax1) = plt.subplots(1, 2, figsize=(10, 3.6), width_ratios=(1, 2))
    series = sorted({k.split("/")[0] for k in st})
    for label in series:
        keys = [k for k, r in st.items() if k.startswith(label + "/") and isinstance(r, dict)]
        n = [int(k.split("/")[1]) for k in keys]
        ax0.plot(n, [st[k]["strouhal"] for k in keys], "o-", label=label)
        k = keys[-1]
        r = st[k]
        t, p = np.array(r["t"]), np.array(r["probe_v"])
        last = t >= t[-1] - 25.0
        ax1.plot(t[last], p[last], lw=0.8, label=f"{k} cells/D: St = {r['strouhal']:.3f}")
    ax0.axhspan(0.12, 0.16, color="0.9", label="accepted 0.12-0.16")
    ax0.set_xscale("log", base=2)
    ax0.set_xlabel("D / dx (dt halved with dx)")
    ax0.set_ylabel("St")
    ax0.legend(fontsize=7)
    ax1.set_xlabel("t (D/U)")
    ax1.set_ylabel("v at wake probe (U)")
    ax1.set_title("wake probe 2D behind the rear face, finest run of each series", fontsize=9)
    ax1.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(out / "flow_strouhal.png", dpi=110)
    plt.close(fig)


def strouhal_acceptance(st) -> dict:
    """Per series: all St within [0.12, 0.16] and every halving change below 5 %."""
    out = {}
    for label in sorted({k.split("/")[0] for k in st}):
        vals = [r["strouhal"] for k, r in st.items()
                if k.startswith(label + "/") and isinstance(r, dict)]
        changes = [c for k, c in st.items() if k.startswith(label + "/halving")]
        out[label] = bool(all(0.12 <= v <= 0.16 for v in vals) and changes
                          and all(c < 0.05 for c in changes))
    return out


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
        "strouhal_passes": strouhal_acceptance(st),
    }
    (out / "flow_validation.json").write_text(json.dumps(summary, indent=2))
    print(json.dumps(summary, indent=2))
    return 0
