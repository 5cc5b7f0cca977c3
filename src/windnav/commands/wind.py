"""``windnav wind``: one urban flow simulation, saved as Zarr and drawn as a PNG.

::

    windnav wind --map city.json --speed 5 --direction-deg 30 --out runs/wind
    # -> runs/wind/flow.zarr (see windnav.flow.solution_io) and runs/wind/mean_speed.png

The flow is solved by :func:`windnav.flow.simulate`; the picture shows the time-averaged wind
speed ``|(mean_u, mean_v)|`` with streamlines of the mean wind over the building footprints.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from windnav._validate import finite_float, positive_float, positive_int
from windnav.experiments.wind_sweep import (  # noqa: F401  (re-exported for callers)
    AUTO_CFL,
    DEFAULT_SETTINGS,
    auto_dt,
    simulate_case,
)


def add_solver_arguments(parser) -> None:
    """Add ``--dx --dt --spinup-steps --steps --record-every --seed`` to ``parser``."""
    d = DEFAULT_SETTINGS
    parser.add_argument("--dx", type=float, default=d["dx"], help="cell size, m (%(default)s)")
    parser.add_argument("--dt", type=float, default=None,
                        help=f"time step, s (default: {d['dt']}, or less to keep the CFL "
                             f"number speed*dt/dx <= {AUTO_CFL:g} at the fastest inlet)")
    parser.add_argument("--spinup-steps", type=int, default=d["spinup_steps"],
                        help="steps run before averaging starts (%(default)s)")
    parser.add_argument("--steps", type=int, default=d["steps"],
                        help="steps averaged into the mean wind (%(default)s)")
    parser.add_argument("--record-every", type=int, default=d["record_every"],
                        help="store a frame every this many averaged steps; 0: none "
                             "(%(default)s)")
    parser.add_argument("--seed", type=int, default=0, help="random seed (%(default)s)")


def _count(value, name: str, where: str) -> int:
    if isinstance(value, bool) or int(value) != value or int(value) < 0:
        raise ValueError(
            f"The {name!r} parameter of {where} must be an integer >= 0. Got {value!r} instead."
        )
    return int(value)


def solver_settings(args, max_speed: float) -> dict:
    """Validated solver settings from parsed arguments, as a dict of JSON values.

    ``max_speed`` (m/s), the fastest inlet, sets the default time step (:func:`auto_dt`).
    """
    where = f"windnav {args.command}"
    dx = positive_float(args.dx, "--dx", where)
    return {
        "dx": dx,
        "dt": auto_dt(dx, max_speed) if args.dt is None else positive_float(args.dt, "--dt", where),
        "spinup_steps": _count(args.spinup_steps, "--spinup-steps", where),
        "steps": positive_int(args.steps, "--steps", where),
        "record_every": _count(args.record_every, "--record-every", where),
    }


def load_city(path, name: str = "--map", where: str = "windnav wind"):
    """Read a RotorPy world JSON map; a missing file is a ValueError naming the argument."""
    from windnav.city import City

    if not os.path.isfile(path):
        raise ValueError(f"The {name!r} parameter of {where} must be an existing RotorPy world "
                         f"JSON file. Got {str(path)!r} instead.")
    return City.from_rotorpy_json(path)


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


def register(subparsers) -> None:
    """Add the ``wind`` subcommand."""
    p = subparsers.add_parser(
        "wind",
        help="simulate the wind over one map and save it (Zarr + PNG)",
        description="Simulate the 2D urban wind over one map for one inlet; write "
                    "OUT/flow.zarr and OUT/mean_speed.png.",
    )
    p.add_argument("--map", required=True, help="RotorPy world JSON file")
    p.add_argument("--speed", type=float, required=True, help="inlet speed, m/s")
    p.add_argument("--direction-deg", type=float, default=0.0,
                   help="inlet direction the wind blows toward, deg CCW from +x (%(default)s)")
    p.add_argument("--out", required=True, help="output directory")
    add_solver_arguments(p)
    p.set_defaults(func=run)


def run(args, simulate=None) -> int:
    """Run ``windnav wind``; returns the exit code."""
    from windnav.flow.solution_io import save_flow

    where = "windnav wind"
    speed = positive_float(args.speed, "--speed", where)
    direction_deg = finite_float(args.direction_deg, "--direction-deg", where)
    settings = solver_settings(args, speed)
    city = load_city(args.map)
    out = Path(args.out)
    solution, seconds = simulate_case(city, speed, direction_deg, settings, args.seed, simulate)
    config = {
        "speed": speed,
        "direction_deg": direction_deg,
        **settings,
        "seed": int(args.seed),
        "map_source": os.path.abspath(args.map),
        "solve_seconds": seconds,
    }
    out.mkdir(parents=True, exist_ok=True)
    save_flow(solution, out / "flow.zarr", config=config)
    png = plot_mean_speed(
        solution, city, out / "mean_speed.png",
        title=f"{Path(args.map).name}: inlet {speed:g} m/s toward {direction_deg:g} deg",
    )
    print(f"solved in {seconds:.1f} s; wrote {out / 'flow.zarr'} and {png}")
    print(averaging_report(solution))
    return 0


def averaging_report(solution) -> str:
    """One paragraph on how well the mean wind is converged (printed by ``windnav wind``)."""
    d = getattr(solution, "diagnostics", {})
    if not d:
        return "averaging: no diagnostics (solver override)"
    text = (
        f"averaging: spin-up {d['flow_throughs_spinup']:.2f} and window "
        f"{d['flow_throughs_average']:.2f} flow-throughs of the domain; mean differs between "
        f"the window's halves by {d['half_window_difference']:.3f} of the inlet speed (RMS); "
        f"closure: Smagorinsky C_s = {d['smagorinsky']:g}, filter {d['filter_width']:.2f} m"
    )
    if d["flow_throughs_spinup"] < 1.0 or d["half_window_difference"] > 0.05:
        text += ("\nwarning: the mean is not converged (spin-up under one flow-through or "
                 "halves differing by more than 5 %); raise --spinup-steps / --steps")
    return text
