"""``windnav wind-sweep``: a dataset of urban flows, maps x speeds x directions, in one Zarr store.

::

    windnav wind-sweep --maps maps/ --out sweep.zarr                 # the thesis grid
    windnav wind-sweep --maps a.json b.json --out s.zarr --speeds 5 10 --directions 4 \\
        --backend process --workers 8

Default inlet grid (the thesis's training data): speeds 0.1, 2.575, 5.05, 7.525, 10.0 m/s x
8 directions 0, 45, ..., 315 deg. Every simulation is one task of
:func:`windnav.experiments.executor.run_tasks`; the task solves the flow and writes its own chunks
of the store (layout, completion markers and resumption: :mod:`windnav.flow.sweep_store`).
Rerunning the same command after an interruption computes only the simulations not marked done.
"""

from __future__ import annotations

import os
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from windnav._validate import finite_float, positive_float, positive_int
from windnav.commands.wind import add_solver_arguments, load_city, simulate_case, solver_settings

THESIS_SPEEDS = (0.1, 2.575, 5.05, 7.525, 10.0)
THESIS_DIRECTIONS = 8


@dataclass(frozen=True)
class SweepTask:
    """One simulation of a sweep: everything a worker needs, picklable.

    Attributes
    ----------
    store : str
        Path of the sweep store.
    map_index, case_index : int
        Where the result goes (``maps/<map_index>/...[case_index]``).
    city : City
    speed : float
        Inlet speed, m/s.
    direction_deg : float
        Inlet direction, deg.
    settings : dict
        Solver settings (dx m, dt s, spinup_steps, steps, record_every).
    seed : int
    simulate : callable or None
        Solver override (tests); None means :func:`windnav.flow.simulate`.
    """

    store: str
    map_index: int
    case_index: int
    city: object
    speed: float
    direction_deg: float
    settings: dict
    seed: int
    simulate: object = None


def run_sweep_task(task: SweepTask) -> dict:
    """Solve one simulation and write it (then its completion marker) into the store.

    Returns
    -------
    dict
        ``map_index``, ``case_index``, ``seconds`` (solve time, s), ``max_speed`` (m/s).
    """
    from windnav.flow.sweep_store import SweepStore

    sol, seconds = simulate_case(task.city, task.speed, task.direction_deg, task.settings,
                                 task.seed, task.simulate)
    SweepStore(task.store, mode="r+").write_case(task.map_index, task.case_index, sol, seconds)
    fluid = ~np.asarray(sol.solid, dtype=bool)
    max_speed = float(np.hypot(sol.mean_u, sol.mean_v)[fluid].max()) if fluid.any() else 0.0
    return {"map_index": task.map_index, "case_index": task.case_index, "seconds": seconds,
            "max_speed": max_speed}


def directions_from(count: int | None = None, degrees=None) -> np.ndarray:
    """Inlet directions, deg: ``count`` evenly spaced from 0, or the ``degrees`` given."""
    where = "windnav wind-sweep"
    if degrees is not None:
        return np.array([finite_float(d, "--directions", where) for d in degrees])
    n = positive_int(THESIS_DIRECTIONS if count is None else count, "--directions", where)
    return 360.0 * np.arange(n) / n


def sweep(
    maps,
    out,
    speeds=THESIS_SPEEDS,
    directions_deg=None,
    settings: dict | None = None,
    backend: str = "process",
    workers: int | None = None,
    seed: int = 0,
    progress: bool = True,
    verify: bool = False,
    simulate=None,
):
    """Run (or resume) a sweep of flow simulations into one Zarr store.

    Parameters
    ----------
    maps : sequence of (name, source, City)
        The maps, in order.
    out : str or path-like
        The sweep store (created, or resumed when it holds the same sweep).
    speeds : sequence of float
        Inlet speeds, m/s. Default: the thesis's 0.1 ... 10 m/s in 5 steps.
    directions_deg : sequence of float, optional
        Inlet directions, deg. Default: 0, 45, ..., 315.
    settings : dict, optional
        Solver settings ``dx`` m, ``dt`` s, ``spinup_steps``, ``steps``, ``record_every``;
        missing keys take :data:`windnav.commands.wind.DEFAULT_SETTINGS`, a missing ``dt``
        :func:`windnav.commands.wind.auto_dt` of the fastest speed.
    backend, workers, progress
        Passed to :func:`windnav.experiments.executor.run_tasks`.
    seed : int
        Root seed; each simulation's seed is stored with it.
    verify : bool
        Also recompute finished simulations whose chunks no longer read back.
    simulate : callable, optional
        Solver override, picklable for the ``process`` backend (tests).

    Returns
    -------
    store : SweepStore
    results : list of TaskResult
        One per simulation run now (finished ones skipped), in completion order.
    """
    from windnav.commands.wind import DEFAULT_SETTINGS, auto_dt
    from windnav.experiments.executor import run_tasks
    from windnav.flow.sweep_store import SweepMap, SweepStore

    where = "windnav wind-sweep"
    speeds = [positive_float(s, "--speeds", where) for s in speeds]
    given = dict(settings or {})
    settings = {**DEFAULT_SETTINGS, **given}
    if given.get("dt") is None:
        settings["dt"] = auto_dt(settings["dx"], max(speeds))
    directions_deg = directions_from(degrees=directions_deg) if directions_deg is not None \
        else directions_from()
    if not maps:
        raise ValueError(f"The '--maps' parameter of {where} must name at least one map.")
    sweep_maps = []
    for name, source, city in maps:
        x, y = solver_grid(city, settings["dx"])
        sweep_maps.append(SweepMap(name=name, source=source, city=city, x=x, y=y))
    n_frames = _n_frames(settings)
    store = SweepStore.create(out, sweep_maps, speeds, directions_deg, config=settings,
                              n_frames=n_frames, seed=seed)
    tasks = [
        SweepTask(store.path, k, c, sweep_maps[k].city, float(store.speeds[c]),
                  float(store.directions_deg[c]), settings, store.case_seed(k, c), simulate)
        for k, c in store.pending(verify=verify)
    ]
    results = list(run_tasks(run_sweep_task, tasks, backend=backend, workers=workers,
                             progress=progress, desc="wind-sweep"))
    return store, results


def solver_grid(city, dx: float) -> tuple[np.ndarray, np.ndarray]:
    """Cell centres ``x`` (nx,), ``y`` (ny,) in m of the grid :func:`windnav.flow.simulate`
    solves ``city`` on at spacing ``dx``: ``n = max(round(extent / dx), 2)`` cells from the
    lower-left corner (as ``windnav.flow.solver.city_domain``). A drift between the two is
    caught when a result is written (``SweepStore.write_case`` checks the grid).
    """
    from windnav.flow import MACGrid

    x0, x1, y0, y1 = city.bounds
    nx = max(int(round((x1 - x0) / dx)), 2)
    ny = max(int(round((y1 - y0) / dx)), 2)
    grid = MACGrid((ny, nx), dx, (x0, y0))
    return grid.x, grid.y


def _n_frames(settings: dict) -> int:
    every = int(settings.get("record_every", 0))
    return int(settings["steps"]) // every if every > 0 else 0


def _map_files(items) -> list[Path]:
    files = []
    for item in items:
        p = Path(item)
        if p.is_dir():
            found = sorted(p.glob("*.json"))
            if not found:
                raise ValueError(f"The '--maps' parameter of windnav wind-sweep names the "
                                 f"folder {item!r}, which holds no .json map.")
            files += found
        else:
            files.append(p)
    return files


def _generated_maps(k: int, kind: str, seed: int):
    """``k`` procedural maps of ``windnav.city.<kind>_map``, map i drawn from spawn i of seed."""
    import windnav.city as city_pkg

    make = getattr(city_pkg, f"{kind}_map", None)
    if make is None:
        raise ValueError(
            f"The '--map-kind' parameter of windnav wind-sweep must name a generator of "
            f"windnav.city (training, planning, dense). Got {kind!r} instead."
        )
    children = np.random.SeedSequence(seed).spawn(k)
    return [(f"{kind}-{i}", f"windnav.city.{kind}_map(SeedSequence({seed}).spawn({k})[{i}])",
             make(np.random.default_rng(child))) for i, child in enumerate(children)]


def register(subparsers) -> None:
    """Add the ``wind-sweep`` subcommand."""
    p = subparsers.add_parser(
        "wind-sweep",
        help="simulate many maps x inlets into one resumable Zarr dataset",
        description="Run maps x speeds x directions flow simulations into one Zarr store "
                    "(one group per map, one chunk per simulation). Rerun the same command to "
                    "resume after an interruption.",
    )
    p.add_argument("--maps", nargs="+", default=[], metavar="FILE_OR_DIR",
                   help="RotorPy world JSON files, or folders of them")
    p.add_argument("--generate", type=int, default=0, metavar="K",
                   help="also make K procedural maps (with --map-kind)")
    p.add_argument("--map-kind", choices=("training", "planning", "dense"), default="training",
                   help="generator of the --generate maps (%(default)s)")
    p.add_argument("--out", required=True, help="the dataset store (a .zarr directory)")
    p.add_argument("--speeds", nargs="+", type=float, default=list(THESIS_SPEEDS),
                   help="inlet speeds, m/s (default: 0.1 2.575 5.05 7.525 10.0)")
    p.add_argument("--directions", nargs="+", type=float, default=None, metavar="N_OR_DEG",
                   help="one integer N: N directions evenly spaced from 0 deg; several "
                        "values: the directions in deg (default: 8)")
    p.add_argument("--directions-deg", nargs="+", type=float, default=None,
                   help="explicit directions in deg (use for a single direction)")
    p.add_argument("--backend", choices=("serial", "process", "ray"), default="process")
    p.add_argument("--workers", type=int, default=None, help="worker count (all cores)")
    p.add_argument("--verify", action="store_true",
                   help="also recompute finished simulations whose data no longer reads back")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    add_solver_arguments(p)
    p.set_defaults(func=run)


def _directions_arg(args):
    if args.directions_deg is not None:
        return list(args.directions_deg)
    if args.directions is None:
        return None
    if len(args.directions) == 1:
        n = args.directions[0]
        if n != int(n) or n < 1:
            raise ValueError(
                "The '--directions' parameter of windnav wind-sweep must be one integer count "
                f"or a list of degrees. Got {args.directions!r} instead; use --directions-deg "
                "for a single direction."
            )
        return directions_from(int(n)).tolist()
    return list(args.directions)


def run(args, simulate=None) -> int:
    """Run ``windnav wind-sweep``; returns 0 when every simulation is done, 1 otherwise."""
    from windnav.flow.sweep_store import SweepMismatchError, SweepStore

    where = "windnav wind-sweep"
    speeds = [positive_float(v, "--speeds", where) for v in args.speeds]
    settings = solver_settings(args, max(speeds))
    maps = [(f.stem, os.path.abspath(f), load_city(f, "--maps", where))
            for f in _map_files(args.maps)]
    if args.generate:
        k = positive_int(args.generate, "--generate", where)
        maps += _generated_maps(k, args.map_kind, args.seed)
    try:
        store, results = sweep(maps, args.out, speeds=speeds,
                               directions_deg=_directions_arg(args), settings=settings,
                               backend=args.backend, workers=args.workers, seed=args.seed,
                               progress=not args.no_progress, verify=args.verify,
                               simulate=simulate)
    except ImportError as exc:  # the ray backend without ray
        raise ValueError(str(exc)) from exc
    except SweepMismatchError as exc:  # the library's message names no flag; add it here
        raise ValueError(
            f"The '--out' parameter of {where} names {args.out!r}, which already holds a "
            "different sweep (maps, speeds, directions, solver config or seed differ); choose "
            "another --out, or delete it to start over."
        ) from exc
    except KeyboardInterrupt:
        store = SweepStore(args.out)
        total = store.n_maps * store.n_cases
        print(f"interrupted: {total - len(store.pending())}/{total} simulations done in "
              f"{store.path}; rerun the same command to resume.", file=sys.stderr)
        return 130
    failed = [r for r in results if not r.ok]
    total = store.n_maps * store.n_cases
    for r in failed:
        t = r.task
        first = (r.error or "").splitlines()[0]
        print(f"failed: map {t.map_index} case {t.case_index} (speed {t.speed:g} m/s, "
              f"direction {t.direction_deg:g} deg): {first}")
    print(f"{store.path}: {total - len(store.pending())}/{total} simulations done "
          f"({len(results) - len(failed)} now, {total - len(results)} already, "
          f"{len(failed)} failed)")
    return 1 if failed else 0
