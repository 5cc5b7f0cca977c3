"""Wind-sweep harness: many maps x inlet speeds x directions into one resumable Zarr store.

Default inlet grid (the thesis's training data): speeds 0.1, 2.575, 5.05, 7.525, 10.0 m/s x
8 directions 0, 45, ..., 315 deg. The simulations of one map and direction form one task of
:func:`windnav.experiments.executor.run_tasks` (their speeds are stepped together and share
the factorisation); the task writes its own chunks of the store (layout, completion markers
and resumption: :mod:`windnav.flow.sweep_store`). Rerunning the same sweep after an
interruption computes only the simulations not marked done.
"""

from __future__ import annotations

import inspect
import time
from dataclasses import dataclass

import numpy as np

from windnav._validate import finite_float, positive_float, positive_int

THESIS_SPEEDS = (0.1, 2.575, 5.05, 7.525, 10.0)
THESIS_DIRECTIONS = 8

# Solver settings shared with ``windnav wind-sweep`` (the example of the public contract).
DEFAULT_SETTINGS = {"dx": 1.0, "dt": 0.25, "spinup_steps": 100, "steps": 200, "record_every": 0}
# When --dt is not given: DEFAULT_SETTINGS["dt"], shortened to keep speed*dt/dx <= AUTO_CFL for
# the fastest inlet (the solver refuses CFL numbers above 2).
AUTO_CFL = 1.0


def auto_dt(dx: float, max_speed: float) -> float:
    """Default time step, s: 0.25 s, or less so that ``max_speed * dt / dx <= AUTO_CFL``."""
    return min(DEFAULT_SETTINGS["dt"], AUTO_CFL * dx / max_speed)


@dataclass(frozen=True)
class SweepTask:
    """Simulations of one sweep map and inlet direction: everything a worker needs, picklable.

    The built-in solver steps the speeds of a task together (:func:`windnav.flow.simulate_batch`:
    one factorisation, one multi-right-hand-side pressure solve per step); a solver override
    (tests) gets one task per simulation.

    Attributes
    ----------
    store : str
        Path of the sweep store.
    map_index : int
        The map (``maps/<map_index>/...``).
    case_indices : tuple of int
        The cases (``...[case_index]``), all of the same direction.
    city : City
    speeds : tuple of float
        Inlet speed of each case, m/s.
    direction_deg : float
        Inlet direction, deg.
    settings : dict
        Solver settings (dx m, dt s, spinup_steps, steps, record_every).
    seeds : tuple of int
        Seed of each case.
    simulate : callable or None
        Solver override (tests); None means :func:`windnav.flow.simulate_batch`.
    """

    store: str
    map_index: int
    case_indices: tuple
    city: object
    speeds: tuple
    direction_deg: float
    settings: dict
    seeds: tuple
    simulate: object = None

    @property
    def case_index(self) -> int:
        """The case of a one-simulation task."""
        if len(self.case_indices) != 1:
            raise AttributeError("SweepTask.case_index: this task holds several cases; use "
                                 "case_indices.")
        return self.case_indices[0]


def run_sweep_task(task: SweepTask) -> dict:
    """Solve the task's simulations and write each (then its completion marker) into the store.

    Returns
    -------
    dict
        ``map_index``, ``cases`` (one dict per case: ``case_index``, ``seconds`` (its share of
        the solve time, s), ``max_speed`` (m/s)).
    """
    from windnav.flow.sweep_store import SweepStore

    if task.simulate is None and len(task.case_indices) > 1:
        sols, seconds = simulate_speeds(task.city, task.speeds, task.direction_deg, task.settings)
        seconds = [seconds / len(sols)] * len(sols)
    else:
        pairs = [simulate_case(task.city, sp, task.direction_deg, task.settings, seed,
                               task.simulate) for sp, seed in zip(task.speeds, task.seeds,
                                                                  strict=True)]
        sols, seconds = [p[0] for p in pairs], [p[1] for p in pairs]
    store = SweepStore(task.store, mode="r+")
    cases = []
    for c, sol, sec in zip(task.case_indices, sols, seconds, strict=True):
        store.write_case(task.map_index, c, sol, sec)
        fluid = ~np.asarray(sol.solid, dtype=bool)
        top = float(np.hypot(sol.mean_u, sol.mean_v)[fluid].max()) if fluid.any() else 0.0
        cases.append({"case_index": int(c), "seconds": float(sec), "max_speed": top})
    return {"map_index": task.map_index, "cases": cases}


def simulate_speeds(city, speeds, direction_deg: float, settings: dict):
    """Run the flow for several inlet speeds of one direction together.

    Returns
    -------
    solutions : list of FlowSolution
    seconds : float
        Wall-clock time of the whole batch, s.
    """
    from windnav.flow import simulate_batch

    t0 = time.perf_counter()
    sols = simulate_batch(city, [float(s) for s in speeds], float(direction_deg), **settings)
    return sols, time.perf_counter() - t0


def simulate_case(city, speed: float, direction_deg: float, settings: dict, seed: int,
                  simulate=None):
    """Run one flow simulation; the body shared by ``wind`` and every ``wind-sweep`` task.

    Parameters
    ----------
    city : City
    speed : float
        Inlet speed, m/s.
    direction_deg : float
        Inlet direction (blowing toward, counter-clockwise from +x), deg.
    settings : dict
        ``dx`` m, ``dt`` s, ``spinup_steps``, ``steps``, ``record_every``.
    seed : int
        Passed on when the solver takes a ``seed``.
    simulate : callable, optional
        The solver, default :func:`windnav.flow.simulate` (injectable for tests).

    Returns
    -------
    solution : FlowSolution
    seconds : float
        Wall-clock time of the solve, s.
    """
    if simulate is None:
        from windnav.flow import simulate
    kwargs = dict(settings)
    if "seed" in inspect.signature(simulate).parameters:
        kwargs["seed"] = int(seed)
    t0 = time.perf_counter()
    solution = simulate(city, speed=float(speed), direction_deg=float(direction_deg), **kwargs)
    return solution, time.perf_counter() - t0


def directions_from(count: int | None = None, degrees=None) -> np.ndarray:
    """Inlet directions, deg: ``count`` evenly spaced from 0, or the ``degrees`` given."""
    where = "directions_from"
    if degrees is not None:
        return np.array([finite_float(d, "directions", where) for d in degrees])
    n = positive_int(THESIS_DIRECTIONS if count is None else count, "directions", where)
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
        One per task run now (finished simulations skipped), in completion order; a task
        holds the pending speeds of one map and direction (``task.case_indices``).
    """
    from windnav.experiments.executor import run_tasks
    from windnav.flow.sweep_store import SweepMap, SweepStore

    where = "sweep"
    speeds = [positive_float(s, "speeds", where) for s in speeds]
    given = dict(settings or {})
    settings = {**DEFAULT_SETTINGS, **given}
    if given.get("dt") is None:
        settings["dt"] = auto_dt(settings["dx"], max(speeds))
    directions_deg = directions_from(degrees=directions_deg) if directions_deg is not None \
        else directions_from()
    if not maps:
        raise ValueError(f"The 'maps' parameter of {where} must name at least one map.")
    sweep_maps = []
    for name, source, city in maps:
        x, y = solver_grid(city, settings["dx"])
        sweep_maps.append(SweepMap(name=name, source=source, city=city, x=x, y=y))
    n_frames = _n_frames(settings)
    store = SweepStore.create(out, sweep_maps, speeds, directions_deg, config=settings,
                              n_frames=n_frames, seed=seed)
    groups: dict = {}
    for k, c in store.pending(verify=verify):
        key = (k, float(store.directions_deg[c])) if simulate is None else (k, c)
        groups.setdefault(key, []).append(c)
    tasks = [
        SweepTask(store.path, k, tuple(cases), sweep_maps[k].city,
                  tuple(float(store.speeds[c]) for c in cases),
                  float(store.directions_deg[cases[0]]),
                  settings, tuple(store.case_seed(k, c) for c in cases), simulate)
        for (k, _), cases in groups.items()
    ]
    results = list(run_tasks(run_sweep_task, tasks, backend=backend, workers=workers,
                             progress=progress, desc="wind-sweep"))
    return store, results


def solver_grid(city, dx: float) -> tuple[np.ndarray, np.ndarray]:
    """Cell centres ``x`` (nx,), ``y`` (ny,) in m of the grid :func:`windnav.flow.simulate`
    solves ``city`` on at spacing ``dx`` (:func:`windnav.flow.grid.grid_for`)."""
    from windnav.flow.grid import grid_for

    grid = grid_for(city.bounds, dx)
    return grid.x, grid.y


def _n_frames(settings: dict) -> int:
    every = int(settings.get("record_every", 0))
    return int(settings["steps"]) // every if every > 0 else 0


