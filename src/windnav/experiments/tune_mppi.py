"""Tuning MPPI's base hyperparameters with Optuna on the intersection case without wind.

The thesis (Folk 2026, ch. 5) tuned the base hyperparameters of its MPPI planner -- the softmin
temperature ``lambda``, the control noise ``sigma_u``, the smoothing width ``sigma_gf`` and the
obstacle weight ``Q_O`` -- with Optuna on an intersection without wind, then fixed them for
every variant (they are :class:`windnav.plan.PlannerConfig`'s defaults: ``temperature=0.79``,
``sigma_u=5.15``, ``sigma_gf=5.97``, ``obstacle_weight=1.25``). This module repeats that study.

The case (ours: the thesis gives no coordinates)
------------------------------------------------
:func:`intersection_case`: a 200 m x 200 m map with four 80 m x 80 m blocks (20 m tall) in its
corners, which leave two perpendicular 40 m streets, ``80 <= x <= 120`` (north-south) and
``80 <= y <= 120`` (east-west), crossing at the centre. The start ``(100, 40)`` lies on the axis
of the south arm and the goal ``(160, 100)`` on the axis of the east arm, each 40 m from the
intersection's edge and 20 m from the walls beside it; the straight line between them crosses
the south-east block, so the vehicle must fly north and turn the corner (120 m along the
streets' axes).

The streets are 40 m wide, not 20 m: with 20 m streets the thesis defaults never turned the
corner (the flights of seeds 0-2 all flew south, out of the map), nor, but for one flight, did
the few one-parameter changes between x0.25 and x4 we tried, so such a study would rank
failures only. At 40 m the defaults succeed on most seeds (6 of seeds 0-7) and on the others
fly south the same way, which leaves the tuning something to find.

Without wind
------------
:func:`navigate` needs an inlet ``speed > 0`` and a recorded flow that matches it; it does not
accept ``speed=0`` and the flow solver has no still-air mode. The flights therefore get a
:class:`~windnav.flow.FlowSolution` whose frames are exactly zero everywhere (:func:`still_air`,
on the solver's 1 m grid over the map), labelled with the nominal inlet :data:`STILL_AIR_SPEED`
(1e-6 m/s) that the check requires. The label enters nothing but the flight's recorded
settings: the vehicle flies in still air, and the ``mppi`` variant's planner ignores the wind.

The objective
-------------
:func:`objective` flies MPPI (variant ``"mppi"``, ``planner_overrides=params``) once per seed
(the seed of :func:`navigate`: the planner's samples and the LiDAR noise) and averages the cost
of each flight (:func:`flight_cost`)::

    cost = time_s                                           (success; time_s <= duration)
    cost = duration + FAILURE_PENALTY_S + d_goal / V_REF    (any failure)

``time_s`` is the end of the 5 s hold inside the goal region (the success criterion of
:mod:`windnav.experiments.navigate`), ``d_goal`` the distance to the goal where the flight ended
(m) and ``V_REF = 1`` m/s. A success costs at most ``duration``, and a failure at least
``duration + FAILURE_PENALTY_S``, so any failure costs more than any success, and among failures
the one that ended nearer the goal costs less.

The search
----------
:func:`tune`: Optuna's TPE sampler seeded by ``seed`` (its first :data:`STARTUP_TRIALS` trials
random, the defaults among them), over each parameter of :data:`SEARCH_SPACE`, log-uniform from
a quarter to four times its thesis value. Trial 0 is the thesis defaults
(``study.enqueue_trial``), so the defaults' cost on the same seeds comes with every study. The
objective is deterministic (the flights are seeded), so the whole study is: same ``seed`` and
``seeds``, same trials.
"""

from __future__ import annotations

import math
import time
from collections.abc import Mapping, Sequence
from dataclasses import fields

import numpy as np

from windnav._extras import install_hint
from windnav._validate import nonnegative_int, positive_float, positive_int

__all__ = [
    "FAILURE_PENALTY_S",
    "SEARCH_SPACE",
    "STILL_AIR_SPEED",
    "THESIS_DEFAULTS",
    "evaluate",
    "flight_cost",
    "intersection_case",
    "objective",
    "require_optuna",
    "still_air",
    "thesis_defaults",
    "tune",
]

MAP_SIZE = 200.0
"""Side of the intersection map, m."""
STREET_WIDTH = 40.0
"""Width of both streets, m."""
BLOCK_HEIGHT = 20.0
"""Height of the four blocks, m."""
START_XY = (100.0, 40.0)
"""Start, m: on the axis of the south arm."""
GOAL_XY = (160.0, 100.0)
"""Goal, m: on the axis of the east arm."""

DURATION_S = 45.0
"""Longest flight, s (the defaults' successes end at 24-27 s)."""
FAILURE_PENALTY_S = 10.0
"""Cost added to ``duration`` for a failed flight, s."""
V_REF = 1.0
"""Speed that turns a failure's distance left to the goal into seconds, m/s."""
STILL_AIR_SPEED = 1e-6
"""Nominal inlet speed of the still-air flow, m/s: a label that :func:`navigate` requires
(``speed > 0``); the wind itself is zero."""
SEEDS = (0, 1, 2)
"""Flight seeds the objective averages over."""
STARTUP_TRIALS = 5
"""Random trials before TPE models the costs (the enqueued defaults count as one)."""

TUNED = ("temperature", "sigma_u", "sigma_gf", "obstacle_weight")
"""The base hyperparameters: :class:`~windnav.plan.PlannerConfig` fields ``lambda``,
``sigma_u``, ``sigma_gf`` and ``Q_O``."""


def _float_defaults() -> dict:
    """Every float field default of :class:`~windnav.plan.PlannerConfig` (the thesis values)."""
    from windnav.plan import PlannerConfig

    return {f.name: f.default for f in fields(PlannerConfig) if isinstance(f.default, float)}


def thesis_defaults() -> dict:
    """The thesis values of the base hyperparameters: :class:`~windnav.plan.PlannerConfig`'s
    field defaults for :data:`TUNED` (``temperature`` 0.79, ``sigma_u`` 5.15 m/s^2,
    ``sigma_gf`` 5.97 steps, ``obstacle_weight`` 1.25)."""
    defaults = _float_defaults()
    return {name: defaults[name] for name in TUNED}


THESIS_DEFAULTS = thesis_defaults()
""":func:`thesis_defaults`, evaluated once."""
SEARCH_SPACE = {name: (0.25 * v, 4.0 * v) for name, v in THESIS_DEFAULTS.items()}
"""Log-uniform range ``(low, high)`` of each tuned field: x0.25 to x4 its thesis value."""


# ------------------------------------------------------------------------------- the case


def intersection_case():
    """The intersection of the tuning study (see the module docstring).

    Returns
    -------
    city : windnav.city.City
        200 m x 200 m, four 80 m x 80 m blocks leaving two perpendicular 40 m streets.
    start_xy, goal_xy : ndarray of shape (2,)
        m, world: in the south arm and in the east arm.
    """
    from windnav.city import City

    lo = 0.5 * (MAP_SIZE - STREET_WIDTH)
    hi = 0.5 * (MAP_SIZE + STREET_WIDTH)
    footprints = np.array([[0.0, lo, 0.0, lo], [hi, MAP_SIZE, 0.0, lo],
                           [0.0, lo, hi, MAP_SIZE], [hi, MAP_SIZE, hi, MAP_SIZE]])
    city = City((0.0, MAP_SIZE, 0.0, MAP_SIZE), footprints, np.full(4, BLOCK_HEIGHT))
    return city, np.array(START_XY), np.array(GOAL_XY)


def still_air(city, duration: float, *, dx: float = 1.0):
    """A recorded flow of zero wind over ``city`` for flights of up to ``duration`` s.

    Parameters
    ----------
    city : windnav.city.City
    duration : float
        Time of the last frame, s (> 0): :func:`navigate` flies until the record ends.
    dx : float
        Grid spacing, m (the solver's 1 m by default; the field is zero whatever it is).

    Returns
    -------
    windnav.flow.FlowSolution
        Two frames (t = 0 and ``duration``) of exactly zero ``u, v`` on cell centres covering
        the map, with ``speed`` :data:`STILL_AIR_SPEED` and ``direction_deg`` 0.
    """
    from windnav.city import grid_shape
    from windnav.flow import FlowSolution

    where = "still_air"
    duration = positive_float(duration, "duration", where)
    dx = positive_float(dx, "dx", where)
    x0, _, y0, _ = city.bounds
    ny, nx = grid_shape(city.bounds, dx)
    x = x0 + dx * (np.arange(nx) + 0.5)
    y = y0 + dx * (np.arange(ny) + 0.5)
    zero = np.zeros((2, ny, nx))
    zero.setflags(write=False)
    return FlowSolution(x=x, y=y, solid=city.rasterize(x, y), mean_u=zero[0], mean_v=zero[0],
                        frames_u=zero, frames_v=zero, t=np.array([0.0, duration]),
                        speed=STILL_AIR_SPEED, direction_deg=0.0, dx=dx, dt=duration)


# --------------------------------------------------------------------------- the objective


def flight_cost(summary: Mapping, duration: float) -> float:
    """The cost of one flight (see the module docstring), s.

    Parameters
    ----------
    summary : mapping
        :meth:`NavigationResult.summary` (``outcome``, ``time_s``,
        ``final_distance_to_goal_m``).
    duration : float
        The flight's time limit, s (> 0).

    Raises
    ------
    ValueError
        A ``summary`` without the keys its outcome is costed by (``{}`` raised a bare
        KeyError; Python API audit, fifty-eighth session), or a bad ``duration``.
    """
    where = "flight_cost"
    if not isinstance(summary, Mapping) or "outcome" not in summary:
        raise ValueError(f"The 'summary' parameter of {where} must be a "
                         "NavigationResult.summary() (with 'outcome'). Got "
                         f"{summary!r} instead.")
    need = "time_s" if summary["outcome"] == "success" else "final_distance_to_goal_m"
    if need not in summary:
        raise ValueError(f"The 'summary' parameter of {where} must hold {need!r} for an "
                         f"outcome {summary['outcome']!r}. Got the keys {sorted(summary)} "
                         "instead.")
    positive_float(duration, "duration", where)
    if summary["outcome"] == "success":
        return float(summary["time_s"])
    return float(duration + FAILURE_PENALTY_S + summary["final_distance_to_goal_m"] / V_REF)


def _check_seeds(seeds, where: str) -> tuple:
    try:
        out = tuple(int(s) for s in seeds)
        ok = len(out) > 0 and all(s >= 0 and s == v and not isinstance(v, bool)
                                  for s, v in zip(out, seeds, strict=True))
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise ValueError(f"The 'seeds' parameter of {where} must be a non-empty sequence of "
                         f"integers >= 0. Got {seeds!r} instead.")
    return out


_NOT_TUNED = ("horizon", "variant")
"""PlannerConfig fields ``params`` may not set: the flights' own (``navigate``'s ``horizon``,
the wind window, which MPPI without wind has no use for; the variant, ``"mppi"``)."""


def _check_params(params, where: str) -> None:
    """A ValueError naming ``params`` of ``where`` unless it is None or a mapping of
    :class:`~windnav.plan.PlannerConfig` fields other than :data:`_NOT_TUNED`. (``horizon``
    raised "planner_config() got multiple values for keyword argument 'horizon'", and an
    unknown field named planner_config's 'overrides'; Python API audit, fifty-eighth
    session.)"""
    from windnav.plan import PlannerConfig

    if params is None:
        return
    names = sorted(f.name for f in fields(PlannerConfig) if f.name not in _NOT_TUNED)
    if not isinstance(params, Mapping):
        raise ValueError(f"The 'params' parameter of {where} must be a dict of PlannerConfig "
                         f"fields, among {names}. Got {params!r} instead.")
    bad = sorted(map(str, set(params) - set(names)))
    if bad:
        raise ValueError(f"The 'params' parameter of {where} must name PlannerConfig fields, "
                         f"among {names} (not {list(_NOT_TUNED)}: MPPI flies without wind, as "
                         f"'mppi'). Got {bad} instead.")


def evaluate(params: Mapping | None = None, *, seeds: Sequence[int] = SEEDS,
             duration: float = DURATION_S, case=None, flow=None) -> dict:
    """Fly MPPI without wind once per seed with ``params``; the cost and the flights.

    Parameters
    ----------
    params : mapping of str to float, optional
        :class:`~windnav.plan.PlannerConfig` fields passed as ``planner_overrides`` (default:
        none, the thesis values); not ``horizon`` or ``variant``, the flights' own.
    seeds : sequence of int
        Flight seeds (>= 0), one flight each.
    duration : float
        Longest flight, s.
    case : (City, start_xy, goal_xy), optional
        Default :func:`intersection_case`.
    flow : FlowSolution, optional
        Default :func:`still_air` over the case's map.

    Returns
    -------
    dict
        ``cost`` (the mean of the flights' :func:`flight_cost`, s) and ``flights``: per seed
        ``seed``, ``outcome``, ``time_s``, ``final_distance_to_goal_m``, ``energy_J``,
        ``cost``.
    """
    from windnav.experiments.navigate import navigate

    where = "evaluate"
    _check_params(params, where)
    seeds = _check_seeds(seeds, where)
    duration = positive_float(duration, "duration", where)
    city, start, goal = intersection_case() if case is None else case
    if flow is None:
        flow = still_air(city, duration)
    flights = []
    for s in seeds:
        res = navigate(city, start, goal, speed=flow.speed, direction_deg=flow.direction_deg,
                       variant="mppi", rng=s, flow=flow, duration=duration,
                       planner_overrides=dict(params or {}))
        summary = res.summary()
        flights.append({"seed": s, "outcome": summary["outcome"], "time_s": summary["time_s"],
                        "final_distance_to_goal_m": summary["final_distance_to_goal_m"],
                        "energy_J": summary["energy_J"],
                        "cost": flight_cost(summary, duration)})
    return {"cost": float(np.mean([f["cost"] for f in flights])), "flights": flights}


def objective(params: Mapping | None = None, *, seeds: Sequence[int] = SEEDS,
              duration: float = DURATION_S, case=None, flow=None) -> float:
    """The tuning objective: :func:`evaluate`'s mean flight cost, s (lower is better)."""
    _check_params(params, "objective")
    return evaluate(params, seeds=seeds, duration=duration, case=case, flow=flow)["cost"]


# ------------------------------------------------------------------------------ the search


def require_optuna():
    """The ``optuna`` module; a ModuleNotFoundError that says how to install it when it is
    missing (the ``tune`` extra)."""
    try:
        import optuna
    except ImportError as exc:
        raise ModuleNotFoundError(
            f"Tuning MPPI needs the optional dependency Optuna: {install_hint('optuna')}",
            name=exc.name) from exc
    return optuna


def _check_space(space, where: str) -> dict:
    names = _float_defaults()
    if not isinstance(space, Mapping) or not space:
        raise ValueError(f"The 'search_space' parameter of {where} must be a non-empty mapping "
                         f"of PlannerConfig fields to (low, high). Got {space!r} instead.")
    out = {}
    for name, bounds in space.items():
        default = names.get(name)
        if default is None:
            raise ValueError(f"The 'search_space' parameter of {where} must name float fields "
                             "of PlannerConfig with a default. Got "
                             f"{name!r} instead.")
        try:
            lo, hi = (float(b) for b in bounds)
        except (TypeError, ValueError):
            lo = hi = math.nan
        if not (0.0 < lo <= default <= hi < math.inf and lo < hi):
            raise ValueError(f"The 'search_space' parameter of {where} must give {name!r} a "
                             f"range 0 < low < high around its thesis value {default}. Got "
                             f"{bounds!r} instead.")
        out[name] = (lo, hi)
    return out


def tune(n_trials: int, *, seed: int = 0, seeds: Sequence[int] = SEEDS,
         search_space: Mapping | None = None, duration: float = DURATION_S,
         progress: bool = False) -> dict:
    """Tune the base hyperparameters with Optuna's TPE sampler (see the module docstring).

    Parameters
    ----------
    n_trials : int
        Trials (>= 2), the thesis defaults first: with one, the defaults were called "best"
        among themselves (statistics audit).
    seed : int
        Seed of the TPE sampler (>= 0). Same seed, same trials.
    seeds : sequence of int
        Flight seeds of every trial (:func:`objective`).
    search_space : mapping of str to (float, float), optional
        Log-uniform range of each tuned :class:`~windnav.plan.PlannerConfig` field, each range
        holding the field's thesis value; default :data:`SEARCH_SPACE`.
    duration : float
        Longest flight, s.
    progress : bool
        Print one line per trial.

    Returns
    -------
    dict
        ``best_params``, ``best_cost`` (s), ``best_trial``; ``defaults`` (the thesis values)
        and ``defaults_cost`` (trial 0); ``trials``: per trial ``number``, ``params``,
        ``cost`` and ``flights`` (:func:`evaluate`); and the settings (``seed``, ``seeds``,
        ``n_trials``, ``duration``, ``search_space``, ``case``, ``sampler``,
        ``optuna_version``, ``elapsed_s``).

    Raises
    ------
    ModuleNotFoundError
        When Optuna is not installed (the ``tune`` extra).
    ValueError
        On a bad ``n_trials``, ``seed``, ``seeds``, ``search_space`` or ``duration``.
    """
    where = "tune"
    optuna = require_optuna()
    n_trials = positive_int(n_trials, "n_trials", where)
    if n_trials < 2:
        raise ValueError(f"The 'n_trials' parameter of {where} must be at least 2 (the first "
                         f"trial flies the defaults, the others search). Got {n_trials} "
                         "instead.")
    nonnegative_int(seed, "seed", where)
    seeds = _check_seeds(seeds, where)
    space = _check_space(SEARCH_SPACE if search_space is None else search_space, where)
    duration = positive_float(duration, "duration", where)
    case = intersection_case()
    flow = still_air(case[0], duration)
    defaults = {name: _float_defaults()[name] for name in space}

    def trial_cost(trial) -> float:
        params = {name: trial.suggest_float(name, lo, hi, log=True)
                  for name, (lo, hi) in space.items()}
        res = evaluate(params, seeds=seeds, duration=duration, case=case, flow=flow)
        trial.set_user_attr("flights", res["flights"])
        return res["cost"]

    def report(study, trial) -> None:
        if progress:
            ok = sum(f["outcome"] == "success" for f in trial.user_attrs["flights"])
            text = " ".join(f"{k}={v:.3g}" for k, v in trial.params.items())
            print(f"trial {trial.number:3d}: cost {trial.value:7.2f} s ({ok}/{len(seeds)} "
                  f"succeeded)  {text}  best {study.best_value:.2f} s", flush=True)

    verbosity = optuna.logging.get_verbosity()
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    t0 = time.perf_counter()
    try:
        sampler = optuna.samplers.TPESampler(seed=int(seed),
                                             n_startup_trials=STARTUP_TRIALS)
        study = optuna.create_study(direction="minimize", sampler=sampler)
        study.enqueue_trial(defaults)
        study.optimize(trial_cost, n_trials=n_trials, callbacks=[report])
    finally:
        optuna.logging.set_verbosity(verbosity)
    trials = [{"number": t.number, "params": dict(t.params), "cost": float(t.value),
               "flights": t.user_attrs["flights"]} for t in study.trials]
    best = study.best_trial
    city, start, goal = case
    return {
        "best_params": dict(best.params), "best_cost": float(best.value),
        "best_trial": best.number,
        "defaults": defaults, "defaults_cost": trials[0]["cost"],
        "trials": trials,
        "seed": int(seed), "seeds": list(seeds), "n_trials": n_trials, "duration": duration,
        "search_space": {k: list(v) for k, v in space.items()},
        "case": {"bounds": list(city.bounds), "footprints": city.footprints.tolist(),
                 "start_xy": start.tolist(), "goal_xy": goal.tolist(), "variant": "mppi",
                 "wind": "none (still_air)"},
        "cost": {"success": "time_s", "failure": f"duration + {FAILURE_PENALTY_S:g} s + "
                 f"final distance to goal / {V_REF:g} m/s"},
        "sampler": f"TPESampler(seed={int(seed)}, n_startup_trials={STARTUP_TRIALS})",
        "optuna_version": optuna.__version__,
        "elapsed_s": time.perf_counter() - t0,
    }

