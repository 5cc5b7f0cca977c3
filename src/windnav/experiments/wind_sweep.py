"""Wind-sweep harness: many maps x inlet speeds x directions into one resumable Zarr store.

Default inlet grid (the thesis's training data): speeds 0.1, 2.575, 5.05, 7.525, 10.0 m/s x
8 directions 0, 45, ..., 315 deg. The simulations of one map and direction form one task of
:func:`windnav.experiments.executor.run_tasks` (their speeds are stepped together and share
the factorisation); so do those of several directions whose inlets are the same sides (3.75
and 56.25 deg: west and south) while the task's runs are at most
:data:`windnav.flow.solver.BITWISE_BATCH`, the most that equal separate runs to the bit. The
largest tasks are dispatched first. A task writes its own chunks of the store (layout,
completion markers and resumption: :mod:`windnav.flow.sweep_store`). Rerunning the same
sweep after an interruption computes only the simulations not marked done; with ``verify``
it first reads back every finished simulation and recomputes exactly those found damaged.

Before anything is created or dispatched, each map's task is checked against the memory limit
(:mod:`windnav.flow.memory`): a map that cannot fit is refused with
:class:`~windnav.flow.memory.MemoryEstimateError`, and the process backend runs no more
workers at once than the limit holds.
"""

from __future__ import annotations

import inspect
import os
import time
import warnings
from collections.abc import Mapping
from dataclasses import dataclass

import numpy as np

from windnav._validate import (
    finite_float,
    nonnegative_int,
    options_named,
    positive_float,
    positive_int,
)

THESIS_SPEEDS = (0.1, 2.575, 5.05, 7.525, 10.0)
THESIS_DIRECTIONS = 8

# Solver settings shared with ``windnav wind-sweep`` (the example of the public contract).
DEFAULT_SETTINGS = {"dx": 1.0, "dt": 0.25, "spinup_steps": 100, "steps": 200, "record_every": 0}
# When --dt is not given: DEFAULT_SETTINGS["dt"], shortened to keep speed*dt/dx <= AUTO_CFL for
# the fastest inlet (the solver refuses CFL numbers above 2).
AUTO_CFL = 1.0
# The solver's own options a sweep's ``settings`` may also set (passed on to
# :func:`windnav.flow.simulate_batch` as they are).
SOLVER_OPTIONS = ("advection", "pressure", "symmetry_break", "smagorinsky", "filter_width",
                  "viscosity")
MAX_DIRECTIONS = 360
"""The most directions :func:`directions_from` spaces evenly: 1 deg apart (as ``windnav
wind-sweep --directions N``; a count of 10**9 was a raw MemoryError)."""


def _number(value, name: str, where: str, *, allow_zero: bool = False) -> float:
    """:func:`~windnav._validate.positive_float`, and no str either (it takes ``'4'``, which the
    arithmetic after it did not); the caller keeps its own value, so results stay the same."""
    if isinstance(value, (str, bytes)):
        raise ValueError(f"The {name!r} parameter of {where} must be a number. Got {value!r} "
                         "instead.")
    return positive_float(value, name, where, allow_zero=allow_zero)


def auto_dt(dx: float, max_speed: float) -> float:
    """Default time step, s: 0.25 s, or less so that ``max_speed * dt / dx <= AUTO_CFL``."""
    # Python API audit, fifty-eighth session: a dx of 0 gave dt 0.0, a negative speed a negative
    # dt, a NaN speed 0.25 s and a speed of 0 a ZeroDivisionError
    _number(dx, "dx", "auto_dt")
    _number(max_speed, "max_speed", "auto_dt")
    return min(DEFAULT_SETTINGS["dt"], AUTO_CFL * dx / max_speed)


@dataclass(frozen=True)
class SweepTask:
    """Simulations of one sweep map and inlet sides: everything a worker needs, picklable.

    The built-in solver steps the runs of a task together (:func:`windnav.flow.simulate_batch`:
    one factorisation, one multi-right-hand-side pressure solve per step): the speeds of one
    direction, or of several directions with the same inlet sides (:func:`direction_batches`);
    a solver override (tests) gets one task per simulation.

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
    directions_deg : tuple of float
        Inlet direction of each case, deg.
    settings : dict
        Solver settings (dx m, dt s, spinup_steps, steps, record_every).
    seeds : tuple of int
        Seed of each case.
    simulate : callable or None
        Solver override (tests); None means :func:`windnav.flow.simulate_batch`.
    memory_limit : float or None
        Passed to :func:`windnav.flow.simulate_batch` (bytes; None: its default).
    """

    store: str
    map_index: int
    case_indices: tuple
    city: object
    speeds: tuple
    directions_deg: tuple
    settings: dict
    seeds: tuple
    simulate: object = None
    memory_limit: float | None = None

    def describe(self) -> str:
        """``map K cases [...] (speeds ... m/s, directions ... deg)``, for messages."""
        return (f"map {self.map_index} cases {list(self.case_indices)} (speeds "
                f"{', '.join(f'{s:g}' for s in self.speeds)} m/s, directions "
                f"{', '.join(f'{d:g}' for d in self.directions_deg)} deg)")

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

    if task.simulate is None:
        sols, seconds = simulate_speeds(task.city, task.speeds, task.directions_deg,
                                        task.settings, memory_limit=task.memory_limit)
        seconds = [seconds / len(sols)] * len(sols)
    else:
        pairs = [simulate_case(task.city, sp, dd, task.settings, seed, task.simulate)
                 for sp, dd, seed in zip(task.speeds, task.directions_deg, task.seeds,
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


def simulate_speeds(city, speeds, direction_deg, settings: dict,
                    memory_limit: float | None = None):
    """Run the flow for several inlet speeds of one direction together.

    ``direction_deg`` is one direction (deg) for every speed, or one per speed whose inlets
    are the same sides; ``memory_limit`` (bytes) is passed to
    :func:`windnav.flow.simulate_batch`.

    Returns
    -------
    solutions : list of FlowSolution
    seconds : float
        Wall-clock time of the whole batch, s.
    """
    from windnav.flow import simulate_batch

    t0 = time.perf_counter()
    directions = float(direction_deg) if np.ndim(direction_deg) == 0 else \
        [float(d) for d in direction_deg]
    sols = simulate_batch(city, [float(s) for s in speeds], directions, **settings,
                          memory_limit=memory_limit)
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
    if not isinstance(settings, Mapping):  # dict()'s "dictionary update sequence" error before
        raise ValueError("The 'settings' parameter of simulate_case must be a dict of solver "
                         "settings (dx, dt, spinup_steps, steps, record_every). Got "
                         f"{settings!r} instead.")
    if simulate is None:
        from windnav.flow import simulate
    kwargs = dict(settings)
    if "seed" in inspect.signature(simulate).parameters:
        kwargs["seed"] = int(seed)
    t0 = time.perf_counter()
    solution = simulate(city, speed=float(speed), direction_deg=float(direction_deg), **kwargs)
    return solution, time.perf_counter() - t0


def directions_from(count: int | None = None, degrees=None) -> np.ndarray:
    """Inlet directions, deg: ``count`` evenly spaced from 0 (at most :data:`MAX_DIRECTIONS`),
    or the ``degrees`` given (one or more, none repeated modulo 360 deg); not both."""
    where = "directions_from"
    if degrees is not None:
        if count is not None:  # the count was ignored
            raise ValueError("The 'count' parameter of directions_from cannot be given with "
                             f"'degrees': give one of them. Got count={count!r} and degrees="
                             f"{degrees!r} instead.")
        return _inlet_directions(degrees, "degrees", where)
    n = positive_int(THESIS_DIRECTIONS if count is None else count, "count", where)
    if n > MAX_DIRECTIONS:
        raise ValueError(f"The 'count' parameter of directions_from must be at most "
                         f"{MAX_DIRECTIONS} (directions 1 deg apart). Got {count!r} instead.")
    return 360.0 * np.arange(n) / n


def _values(values, name: str, where: str, what: str) -> list:
    """``values`` as a non-empty list, else a ValueError naming the argument."""
    if isinstance(values, (str, bytes)):  # "90" was the directions 9 and 0
        raise ValueError(f"The {name!r} parameter of {where} must be a sequence of {what}. Got "
                         f"{values!r} instead.")
    try:
        items = list(values)
    except TypeError:
        raise ValueError(f"The {name!r} parameter of {where} must be a sequence of {what}. Got "
                         f"{values!r} instead.") from None
    if not items:
        raise ValueError(f"The {name!r} parameter of {where} must hold at least one of the "
                         f"{what}. Got {values!r} instead.")
    return items


def _no_repeat(values, same, name: str, where: str, what: str) -> None:
    if len(set(same)) < len(same):  # the same inlet twice was simulated twice into the store
        raise ValueError(f"The {name!r} parameter of {where} must not repeat a value ({what}): "
                         f"each would be simulated again. Got "
                         f"{' '.join(f'{v:g}' for v in values)} instead.")


def _inlet_directions(values, name: str, where: str) -> np.ndarray:
    """Directions, deg: finite, at least one, none repeated modulo 360 deg."""
    degrees = np.array([finite_float(d, name, where)
                        for d in _values(values, name, where, "directions, deg")])
    _no_repeat(degrees, [d % 360.0 for d in degrees.tolist()], name, where,
               "a direction modulo 360 deg")
    return degrees


def _inlet_speeds(values, where: str) -> list[float]:
    """Speeds, m/s: finite, above 0, at most the solver's ``MAX_SPEED``, at least one, none
    repeated."""
    from windnav.flow.solver import MAX_SPEED

    speeds = [_number(s, "speeds", where) for s in _values(values, "speeds", where,
                                                             "inlet speeds, m/s")]
    if max(speeds) > MAX_SPEED:  # every task failed in the solver before
        raise ValueError(f"The 'speeds' parameter of {where} must be at most {MAX_SPEED:g} m/s "
                         f"(the solver is incompressible). Got {max(speeds)!r} instead.")
    _no_repeat(speeds, speeds, "speeds", where, "a speed")
    return speeds


def _checked_settings(settings, speeds: list[float], where: str) -> dict:
    """:data:`DEFAULT_SETTINGS` updated with ``settings`` (its values as given, ``dt`` from
    :func:`auto_dt` when missing or None), each checked; a ValueError naming the key."""
    from windnav.flow.advection import SCHEMES
    from windnav.flow.solver import MAX_CFL, PRESSURE_SOLVERS

    if settings is not None and not isinstance(settings, Mapping):
        raise ValueError(f"The 'settings' parameter of {where} must be a dict of solver "
                         f"settings ({', '.join(DEFAULT_SETTINGS)}). Got {settings!r} instead.")
    given = dict(settings or {})
    unknown = [k for k in given if k not in DEFAULT_SETTINGS and k not in SOLVER_OPTIONS]
    if unknown:  # passed on to the solver, whose TypeError each task reported
        raise ValueError(f"The 'settings' parameter of {where} must only set "
                         f"{', '.join(DEFAULT_SETTINGS)} (or the solver's "
                         f"{', '.join(SOLVER_OPTIONS)}). Got {unknown} instead.")
    out = {**DEFAULT_SETTINGS, **given}

    def key(k: str) -> str:
        return f"settings[{k!r}]"

    dx = _number(out["dx"], key("dx"), where)
    if given.get("dt") is None:
        out["dt"] = auto_dt(out["dx"], max(speeds))
    dt = _number(out["dt"], key("dt"), where)
    if max(speeds) * dt / dx > MAX_CFL:
        raise ValueError(f"The {key('dt')!r} parameter of {where} must keep the CFL number "
                         f"speed*dt/dx at or below {MAX_CFL:g} at the fastest inlet "
                         f"{max(speeds):g} m/s; use dt <= {MAX_CFL * dx / max(speeds):.4g} s "
                         f"(or leave it out). Got {out['dt']!r} instead.")
    nonnegative_int(out["spinup_steps"], key("spinup_steps"), where)
    steps = positive_int(out["steps"], key("steps"), where)
    if nonnegative_int(out["record_every"], key("record_every"), where) > steps:
        raise ValueError(f"The {key('record_every')!r} parameter of {where} must be at most "
                         f"steps ({steps}) to record a frame, or 0 for none. Got "
                         f"{out['record_every']!r} instead.")
    for k, choices in (("advection", SCHEMES), ("pressure", PRESSURE_SOLVERS)):
        if k in given and given[k] not in choices:
            raise ValueError(f"The {key(k)!r} parameter of {where} must be one of {choices}. "
                             f"Got {given[k]!r} instead.")
    if "symmetry_break" in given:
        finite_float(given["symmetry_break"], key("symmetry_break"), where)
    for k in ("smagorinsky", "viscosity"):
        if k in given:
            _number(given[k], key(k), where, allow_zero=True)
    if given.get("filter_width") is not None:
        _number(given["filter_width"], key("filter_width"), where)
    return out


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
    memory_limit: float | None = None,
    group_sides: bool = True,
):
    """Run (or resume) a sweep of flow simulations into one Zarr store.

    Parameters
    ----------
    maps : sequence of (name, source, City)
        The maps, in order.
    out : str or path-like
        The sweep store (created, or resumed when it holds the same sweep).
    speeds : sequence of float
        Inlet speeds, m/s, one or more, none repeated. Default: the thesis's 0.1 ... 10 m/s in
        5 steps.
    directions_deg : sequence of float, optional
        Inlet directions, deg, one or more, none repeated modulo 360 deg. Default: 0, 45, ...,
        315.
    settings : dict, optional
        Solver settings ``dx`` m, ``dt`` s, ``spinup_steps``, ``steps``, ``record_every``
        (or the solver's :data:`SOLVER_OPTIONS`), checked before anything is created;
        missing keys take :data:`DEFAULT_SETTINGS`, a missing ``dt`` :func:`auto_dt` of the
        fastest speed.
    backend, workers, progress
        Passed to :func:`windnav.experiments.executor.run_tasks`.
    seed : int
        Root seed; each simulation's seed is stored with it.
    verify : bool
        First read back every array of every finished simulation and compare it with its
        digest (:meth:`SweepStore.verify`); the damaged ones are marked not done and
        recomputed with the pending ones. The report is ``store.last_verify``.
    simulate : callable, optional
        Solver override, picklable for the ``process`` backend (tests).
    memory_limit : float, optional
        Memory the sweep may use on this machine, bytes (default:
        :func:`windnav.flow.memory.default_memory_limit`). A map whose task's estimate is
        above it is refused before anything is written; the process backend runs at most as
        many workers at once as the limit holds (with a warning when that is fewer than
        asked for); each task's solver gets the same limit.
    group_sides : bool, default True
        Step directions whose inlets are the same sides together (:func:`direction_batches`:
        one factorisation and one pressure solve per step for the pair, the same fields to
        the bit). False: one task per direction, as before 2026-12-03 (less memory a task).

    Returns
    -------
    store : SweepStore
        ``store.repaired`` lists creation-time arrays that were damaged and rewritten;
        ``store.last_verify`` is the :class:`~windnav.flow.sweep_store.VerifyReport` when
        ``verify``, else None.
    results : list of TaskResult
        One per task run now (finished simulations skipped), in completion order; a task
        holds the pending cases of one map and one direction, or of several whose inlets are
        the same sides (:func:`direction_batches`): ``task.case_indices``, ``task.speeds``,
        ``task.directions_deg``. A task that failed holds its error (``.error``); when every
        task run now failed, a warning says so.

    Raises
    ------
    ValueError
        Naming the argument: no maps, or invalid speeds, directions or settings.
    MemoryEstimateError
        (a ValueError) When one map's task needs more memory than the limit.
    SweepMismatchError
        (a ValueError) When ``out`` holds a different sweep.
    CorruptStoreError
        (a ValueError) When ``out`` is a sweep store whose identity attributes are lost.
    KeyboardInterrupt
        On Ctrl-C, after the workers are stopped; finished simulations stay in the store.
    """
    from windnav.city import City
    from windnav.experiments.executor import check_backend, run_tasks
    from windnav.experiments.results import exclusive_folder
    from windnav.flow.sweep_store import SweepMap, SweepStore, note_solver_code

    where = "sweep"
    # Python API audit, fifty-eighth session: settings the solver refuses (steps 0, dt -1, an
    # unknown key), a repeated or empty inlet list and a seed < 0 all passed here; the store
    # was created and every task failed, its error kept only in results[i].error
    speeds = _inlet_speeds(speeds, where)
    settings = _checked_settings(settings, speeds, where)
    directions_deg = _inlet_directions(directions_deg, "directions_deg", where) \
        if directions_deg is not None else directions_from()
    nonnegative_int(seed, "seed", where)
    if not maps:
        raise ValueError(f"The 'maps' parameter of {where} must name at least one map.")
    sweep_maps = []
    for k, entry in enumerate(maps):
        try:
            name, source, city = entry
        except (TypeError, ValueError):  # "cannot unpack non-iterable City object" before
            raise ValueError(f"The 'maps' parameter of {where} must be a sequence of (name, "
                             "source, City) triples (windnav.experiments.maps.generated_maps "
                             f"makes them). Got a {type(entry).__name__}"
                             f"{f' of {len(entry)}' if isinstance(entry, tuple | list) else ''} "
                             f"as map {k} instead.") from None
        if not isinstance(city, City):
            raise ValueError(f"The 'maps' parameter of {where} must be a sequence of (name, "
                             "source, City) triples. Got a "
                             f"{type(city).__name__} as the City of map {k} instead.")
        x, y = _solver_grid(city, settings["dx"], f"\"settings['dx']\" parameter of {where}")
        sweep_maps.append(SweepMap(name=name, source=source, city=city, x=x, y=y))
    n_frames = _n_frames(settings)
    batch_of = direction_batches(directions_deg, len(speeds), group_sides) \
        if simulate is None else None
    runs = len(speeds) * max(np.bincount(list(batch_of.values()))) if batch_of else 1
    workers = _fit_workers(sweep_maps, settings["dx"], runs, n_frames, backend, workers,
                           memory_limit, len(directions_deg) * len(sweep_maps))
    check_backend(backend)  # before the store: ray's was created, then its import failed
    store = SweepStore.create(out, sweep_maps, speeds, directions_deg, config=settings,
                              n_frames=n_frames, seed=seed)
    # one run computes a store at a time: a second one computed every pending case again
    # (concurrency audit); it now waits for the first, then computes what is left (nothing,
    # when the first finished)
    with exclusive_folder(store.path, f"the sweep store {str(store.path)!r}",
                          on_wait=lambda message: warnings.warn(f"{where}: {message}",
                                                                stacklevel=3)):
        # read again under the lock: a run that held it may have changed the attributes
        # this handle read when it opened the store (a solver hash lost; review)
        repaired = store.repaired
        store = SweepStore(store.path, mode="r+")
        store.repaired = repaired
        if verify:
            store.invalidate(store.verify(progress=progress).damaged)
        note_solver_code(store, where)  # the cases left are now known: say a mix of solvers
        groups: dict = {}
        for k, c in store.pending():
            key = (k, batch_of[float(store.directions_deg[c])]) if batch_of else (k, c)
            groups.setdefault(key, []).append(c)
        tasks = [
            SweepTask(store.path, k, tuple(cases), sweep_maps[k].city,
                      tuple(float(store.speeds[c]) for c in cases),
                      tuple(float(store.directions_deg[c]) for c in cases),
                      settings, tuple(store.case_seed(k, c) for c in cases), simulate,
                      memory_limit)
            for (k, _), cases in groups.items()
        ]
        # the largest first, so that no long task is left alone at the end (a stable sort: maps
        # of one size keep their order)
        tasks.sort(key=lambda t: -sweep_maps[t.map_index].x.size * sweep_maps[t.map_index].y.size
                   * len(t.case_indices))
        results = list(run_tasks(run_sweep_task, tasks, backend=backend, workers=workers,
                                 progress=progress, desc="wind-sweep"))
    failed = [r for r in results if not r.ok]
    if results and len(failed) == len(results):  # said only in results[i].error before
        first = min(failed, key=lambda r: r.index)
        warnings.warn(f"{where}: all {len(results)} task(s) run now failed; first "
                      f"({first.task.describe()}): "
                      f"{(first.error or 'no error').splitlines()[0]}. Each task's error is "
                      "in its result's .error; a rerun retries the cases not done.",
                      stacklevel=2)
    return store, results


def direction_batches(directions_deg, n_speeds: int, group_sides: bool = True) -> dict:
    """Which inlet directions a sweep simulates together, as ``{direction_deg: batch}``.

    Directions whose inlets are the same sides (:meth:`windnav.flow.BoundaryConditions.for_wind`:
    3.75 and 56.25 deg both enter on the west and south sides) share the pressure
    factorisation, so they are stepped together, in their given order, as many as keep a
    batch's runs (``n_speeds`` each) within :data:`windnav.flow.solver.BITWISE_BATCH`: the
    most that equal their separate runs to the bit. When two directions' runs would be more
    (two speeds or more), every direction is a batch of its own, as with
    ``group_sides=False``. Batches are numbered from 0 in order of first direction.
    """
    from windnav.flow.grid import BoundaryConditions
    from windnav.flow.solver import BITWISE_BATCH

    per_batch = max(1, BITWISE_BATCH // max(int(n_speeds), 1)) if group_sides else 1
    batch_of: dict = {}
    open_batch: dict = {}  # sides -> (batch, directions in it)
    n = 0
    # a NaN was named "'inflow_velocity' parameter of BoundaryConditions" (Python API audit,
    # fifty-eighth session)
    for d in (finite_float(d, "directions_deg", "direction_batches") for d in directions_deg):
        if d in batch_of:
            continue
        sides = BoundaryConditions.for_wind(1.0, d).sides
        b, size = open_batch.get(sides, (None, per_batch))
        if size >= per_batch:
            b, size, n = n, 0, n + 1
        batch_of[d] = b
        open_batch[sides] = (b, size + 1)
    return batch_of


def averaging_summary(store) -> dict:
    """The averaging verdict (:func:`windnav.flow.validity.averaging_verdict`) of every finished
    case of a sweep store, from the diagnostics stored with it.

    Returns
    -------
    dict
        ``checked`` (finished cases with diagnostics), ``unknown`` (finished cases without:
        a solver override, or an unreadable diagnostics chunk), ``not_converged`` and
        ``young`` (one dict per such case: ``map``, ``map_index``, ``case``, ``speed`` m/s,
        ``direction_deg``, ``flow_throughs_spinup``, ``flow_throughs_average``,
        ``half_window_difference``, ``reason``).
    """
    from windnav.flow.sweep_store import SweepStore
    from windnav.flow.validity import averaging_verdict

    # a path was an AttributeError (Python API audit, fifty-eighth session)
    if isinstance(store, (str, os.PathLike)):
        store = SweepStore(store)
    elif not isinstance(store, SweepStore):
        raise ValueError("The 'store' parameter of averaging_summary must be a SweepStore or "
                         f"the path of one. Got {type(store).__name__} instead.")
    out = {"checked": 0, "unknown": 0, "not_converged": [], "young": []}
    for k in range(store.n_maps):
        done = np.flatnonzero(store.done(k))
        try:
            name = str(store.map_attrs(k).get("name", k))
            diagnostics = store.case_diagnostics(k)
        except ValueError:  # a damaged group or chunk: verify / resume reports it
            out["unknown"] += int(done.size)
            continue
        for c in done:
            case = {key: float(v[c]) for key, v in diagnostics.items()}
            verdict = averaging_verdict(case)
            if verdict["converged"] is None:
                out["unknown"] += 1
                continue
            out["checked"] += 1
            if verdict["converged"]:
                continue
            entry = {"map": name, "map_index": int(k), "case": int(c),
                     "speed": float(store.speeds[c]),
                     "direction_deg": float(store.directions_deg[c]),
                     **{key: case.get(key) for key in ("flow_throughs_spinup",
                                                       "flow_throughs_average",
                                                       "half_window_difference")},
                     "reason": verdict["reason"]}
            out["not_converged" if verdict["level"] == "warning" else "young"].append(entry)
    return out


def solver_grid(city, dx: float) -> tuple[np.ndarray, np.ndarray]:
    """Cell centres ``x`` (nx,), ``y`` (ny,) in m of the grid :func:`windnav.flow.simulate`
    solves ``city`` on at spacing ``dx`` (:func:`windnav.flow.grid.grid_for`)."""
    from windnav.city import check_city

    check_city(city, "solver_grid")
    return _solver_grid(city, dx, "'dx' parameter of solver_grid")


def _solver_grid(city, dx: float, named: str) -> tuple[np.ndarray, np.ndarray]:
    """:func:`solver_grid`, its errors naming ``named`` (the caller's argument: they named
    grid_shape's 'dx' before)."""
    from windnav.flow.grid import grid_for

    with options_named({"'dx' parameter of grid_shape": named}):
        grid = grid_for(city.bounds, dx)
    return grid.x, grid.y


def _fit_workers(sweep_maps, dx: float, n_runs: int, n_frames: int, backend: str, workers,
                 memory_limit, n_tasks: int):
    """Refuse a map whose task cannot fit in the memory limit; for the process backend, cap
    the workers so that the largest tasks running at once fit too. Returns the workers."""
    import os

    from windnav.city import grid_shape
    from windnav.flow.memory import (
        BYTES_PER_FRAME_CELL,
        PROCESS_BASELINE_BYTES,
        check_flow_memory,
        default_memory_limit,
        fluid_fraction,
        format_bytes,
    )

    biggest = 0
    for k, m in enumerate(sweep_maps):
        shape = grid_shape(m.city.bounds, dx)
        what = (f"map {k} ({m.name!r}, {shape[0]} x {shape[1]} cells), {n_runs} run(s) "
                f"at once, {n_frames} frame(s) each")
        need = check_flow_memory(shape, n_runs, n_frames, fluid_fraction=fluid_fraction(m.city),
                                 memory_limit=memory_limit, where="sweep", what=what)
        # writing a case stacks its frames once more
        biggest = max(biggest, need + BYTES_PER_FRAME_CELL * n_frames * shape[0] * shape[1])
    limit = memory_limit if memory_limit is not None else default_memory_limit()
    if backend != "process" or limit is None or not np.isfinite(limit):
        return workers
    asked = min(workers or os.cpu_count() or 1, max(n_tasks, 1))
    fit = max(1, int(limit // (biggest + PROCESS_BASELINE_BYTES)))
    if fit < asked:
        warnings.warn(
            f"sweep: running {fit} worker(s) at once instead of {asked}: each task may need "
            f"{format_bytes(biggest + PROCESS_BASELINE_BYTES)} (with the worker process) and the "
            f"memory limit is {format_bytes(limit)}.",
            stacklevel=3,
        )
        return fit
    return workers


def _n_frames(settings: dict) -> int:
    every = int(settings.get("record_every", 0))
    return int(settings["steps"]) // every if every > 0 else 0


