"""Case studies against the global graph search: MPPI, EA-MPPI+W, GS and GS+W on three maps.

The thesis (ch. 5) compares the MPPI variants with the energy-optimal global graph search
(GS, GS+W: :func:`windnav.plan.energy_route`, flown by a route follower) on an intersection, a
single building and one evaluation map, and draws them without giving coordinates. The
geometry below is ours. Coordinates are ``(x, y)`` in m, world frame (x east, y north);
footprints are ``[x_min, x_max, y_min, y_max]``; ``direction_deg`` is the direction the wind
blows toward, counter-clockwise from +x (DESIGN.md).

``"intersection"``
    Map ``(0, 300, 0, 300)``. Four blocks 95 m (east-west) x 60 m (north-south), 40 m high:
    ``[40, 135, 75, 135]``, ``[165, 260, 75, 135]``, ``[40, 135, 165, 225]``,
    ``[165, 260, 165, 225]``. Between them two perpendicular 30 m streets cross at
    ``(150, 150)``: an east-west street ``y`` in ``[135, 165]`` (walls from ``x = 40`` to 260)
    and a north-south street ``x`` in ``[135, 165]`` (walls from ``y = 75`` to 225); open
    ground surrounds the blocks. Start ``(60, 150)`` on the axis of the east-west street's
    west arm, 20 m inside it; goal ``(150, 210)`` on the axis of the north-south street's north
    arm, 15 m from its end; each 15 m from the nearest wall, so the route turns the corner.
    Wind 5 m/s toward 0 deg, along the east-west street, which channels it to a mean of 9.3 m/s
    between the walls (15.7 m/s at most) while the north arm stays sheltered (1.6 m/s). At
    7 m/s the street's jet reaches 16-18 m/s, beyond the 13 m/s airspeed of the Hummingbird's
    power curve, and every variant is blown out of the map. The blocks are longer along the
    wind than across it so that they block 40 % of the inlet (the side boundaries hold the
    inlet velocity, so blockage speeds up the flow between the blocks).
``"single-building"``
    Map ``(0, 300, 0, 300)``. One 50 m x 50 m building, 40 m high, ``[125, 175, 125, 175]``,
    on the straight line from start ``(50, 150)`` to goal ``(250, 150)`` (each 75 m from it).
    Wind 5 m/s toward 90 deg: across the line, so going round the building upwind (south)
    and downwind (north, through its wake) differ.
``"evaluation-map"``
    The thesis suite's scenario ``thesis/m00/w06/p0`` (:data:`EVALUATION_SCENARIO`): map 0 of
    the suite (600 m x 600 m, :func:`~windnav.experiments.nav_suite.suite_map`), wind ``w06``
    (5 m/s toward 30 deg), tailwind pair 0 (282 m), its start and goal as
    :func:`~windnav.experiments.nav_suite.parse_scenario_id` draws them: map
    ``(0, 600, 0, 600)`` with 20 footprints, start ``(44.30, 137.37)``, goal
    ``(246.06, 334.39)`` (to 0.01 m).

Every case is flown in the thesis wind (:func:`~windnav.experiments.navigate.simulate_flow`:
25 s of spin-up, then 100 s recorded, ``dx = 1`` m, ``dt = 0.25`` s; simulated once per case)
by each of :data:`VARIANTS`, with the same seed: MPPI; EA-MPPI+W with ``Q_E = 3`` and the wind
known inside a window of side ``H = 90`` m; GS (route planned in still air) and GS+W (in the
mean wind). :func:`run_case` flies one case, :func:`case_summary` gives its JSON-ready numbers,
and :func:`windnav.viz.gs_cases.plot_gs_case` draws it. The benchmark flew the evaluation
scenario with the scenario's own seed (``Scenario.seed``, 504508306); :func:`run_case`'s
``seed=`` replays that flight when given it.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Mapping

import numpy as np

from windnav._validate import generator
from windnav.experiments.results import say

__all__ = [
    "CASES",
    "EVALUATION_SCENARIO",
    "INTERSECTION_STREETS",
    "THESIS_FLOW",
    "VARIANTS",
    "case_summary",
    "evaluation_map",
    "intersection",
    "run_case",
    "single_building",
]

THESIS_FLOW = {"spinup_s": 25.0, "record_s": 100.0, "dx": 1.0, "dt": 0.25}
"""Keyword arguments of :func:`~windnav.experiments.navigate.simulate_flow`: the thesis wind
(spin-up and record, s; grid spacing, m; time step, s)."""

VARIANTS = {
    "MPPI": ("mppi", {}),
    "EA-MPPI+W": ("ea-mppi-w", {"planner_overrides": {"energy_weight": 3.0}, "horizon": 90.0}),
    "GS": ("gs", {}),
    "GS+W": ("gs-w", {}),
}
"""Display name -> (variant of :data:`windnav.plan.VARIANTS`, extra keyword arguments of
:func:`~windnav.experiments.navigate.navigate`), flown in this order."""

EVALUATION_SCENARIO = "thesis/m00/w06/p0"
"""The scenario of the thesis suite flown as the ``"evaluation-map"`` case."""

_MAP = (0.0, 300.0, 0.0, 300.0)
_HEIGHT = 40.0  # m, above the 10 m flight altitude; the 2D flow ignores it

INTERSECTION_STREETS = {"east-west": (135.0, 165.0), "north-south": (135.0, 165.0)}
"""The intersection's streets: ``"east-west"`` spans this ``y`` range and ``"north-south"``
this ``x`` range, m (each 30 m wide, between the blocks)."""


def intersection():
    """The ``"intersection"`` case (module docstring): ``(city, start_xy, goal_xy, speed,
    direction_deg)``, m, m, m/s, deg."""
    from windnav.city import City

    xs, ys = ((40.0, 135.0), (165.0, 260.0)), ((75.0, 135.0), (165.0, 225.0))
    blocks = np.array([[*x, *y] for y in ys for x in xs])
    city = City(_MAP, blocks, np.full(len(blocks), _HEIGHT))
    return city, (60.0, 150.0), (150.0, 210.0), 5.0, 0.0


def single_building():
    """The ``"single-building"`` case (module docstring): ``(city, start_xy, goal_xy, speed,
    direction_deg)``, m, m, m/s, deg."""
    from windnav.city import City

    city = City(_MAP, np.array([[125.0, 175.0, 125.0, 175.0]]), np.array([_HEIGHT]))
    return city, (50.0, 150.0), (250.0, 150.0), 5.0, 90.0


def evaluation_map():
    """The ``"evaluation-map"`` case: scenario :data:`EVALUATION_SCENARIO` of the thesis suite,
    ``(city, start_xy, goal_xy, speed, direction_deg)``, m, m, m/s, deg."""
    from windnav.experiments.nav_suite import get_suite, parse_scenario_id, suite_map

    spec = get_suite("thesis")
    sc = parse_scenario_id(spec, EVALUATION_SCENARIO)
    return suite_map(spec, sc.map_index), sc.start, sc.goal, sc.speed, sc.direction_deg


CASES: dict[str, Callable] = {
    "intersection": intersection,
    "single-building": single_building,
    "evaluation-map": evaluation_map,
}
"""Case name -> a function returning ``(City, start_xy, goal_xy, speed m/s, direction_deg)``."""


def _check_flow_settings(flow_settings, where: str) -> dict:
    if flow_settings is None:
        return dict(THESIS_FLOW)
    if not isinstance(flow_settings, Mapping) or not set(flow_settings) <= set(THESIS_FLOW):
        raise ValueError(f"The 'flow_settings' parameter of {where} must be a dict with keys "
                         f"among {list(THESIS_FLOW)}. Got {flow_settings!r} instead.")
    return {**THESIS_FLOW, **flow_settings}


def run_case(name: str, *, seed: int = 0, progress: bool = False,
             flow_settings: Mapping | None = None, keep_frames: bool = False) -> dict:
    """Simulate one case's wind once and fly every variant of :data:`VARIANTS` through it.

    Parameters
    ----------
    name : str
        A key of :data:`CASES`.
    seed : int, keyword-only
        The flights' seed (planner sampling, LiDAR noise), the same for every variant.
    progress : bool
        A line for the wind and one per flight on stderr.
    flow_settings : dict, optional
        Overrides of :data:`THESIS_FLOW` (``spinup_s``, ``record_s``, ``dx``, ``dt``), e.g. a
        short record for tests; the longest flight is ``record_s``.
    keep_frames : bool
        Keep the wind's recorded frames in ``"flow"`` (about 0.7 GB for the 300 m maps, 2.3 GB
        for the 600 m one); default only its mean field, what the figures draw.

    Returns
    -------
    dict
        ``name``; ``city``; ``flow`` (:class:`~windnav.flow.FlowSolution`, mean field only
        unless ``keep_frames``); ``start``, ``goal`` (ndarray of shape (2,), m); ``speed``
        (m/s); ``direction_deg``; ``seed``; ``flow_settings``; ``flow_s`` (wall time of the
        wind, s); ``results``: ``{label: NavigationResult}`` in the order of :data:`VARIANTS`;
        ``summary``: ``{label: dict}``, the JSON-ready numbers of :func:`case_summary`.

    Raises
    ------
    ValueError
        An unknown case, a bad ``seed`` or bad ``flow_settings`` (before the wind); whatever
        the wind or a flight raises.
    """
    from windnav.experiments.nav_benchmark import SharedFlow
    from windnav.experiments.nav_cases import mean_flow
    from windnav.experiments.navigate import navigate, simulate_flow

    where = "run_case"
    if name not in CASES:
        raise ValueError(f"The 'name' parameter of {where} must be one of {list(CASES)}. Got "
                         f"{name!r} instead.")
    settings = _check_flow_settings(flow_settings, where)
    # navigate's check named its 'rng', after the wind had been simulated (Python API audit,
    # fifty-eighth session); the seed itself goes on to every flight as before
    generator(seed, "seed", where)
    city, start, goal, speed, direction = CASES[name]()
    say(progress, f"gs_cases: wind of {name} ({speed:g} m/s toward {direction:g} deg)")
    t0 = time.perf_counter()
    flow = SharedFlow(simulate_flow(city, speed, direction, **settings))  # one field, 4 flights
    flow_s = time.perf_counter() - t0
    results = {}
    for label, (variant, options) in VARIANTS.items():
        results[label] = navigate(city, start, goal, speed=speed, direction_deg=direction,
                                  variant=variant, rng=seed, flow=flow, **options)
        r = results[label]
        say(progress, f"gs_cases: {name} {label}: {r.outcome}, {r.energy_J / 1e3:.2f} kJ, "
                       f"{r.time_s:.1f} s")
    flow = flow.solution if keep_frames else mean_flow(flow)
    return {"name": name, "city": city, "flow": flow,
            "start": np.asarray(start, dtype=np.float64),
            "goal": np.asarray(goal, dtype=np.float64), "speed": float(speed),
            "direction_deg": float(direction), "seed": seed, "flow_settings": settings,
            "flow_s": flow_s, "results": results,
            "summary": {label: _flight_numbers(r) for label, r in results.items()}}


def _number(value) -> float | None:
    """A float, or None where it is not finite (strict JSON has no NaN)."""
    v = float(value)
    return v if math.isfinite(v) else None


def _flight_numbers(result) -> dict:
    out = {"variant": result.variant, "outcome": result.outcome,
           "energy_J": _number(result.energy_J),
           "rotor_energy_J": _number(result.rotor_energy_J),
           "time_s": _number(result.time_s), "distance_m": _number(result.distance_m),
           "final_distance_to_goal_m": _number(np.hypot(*(result.position[-1, :2]
                                                          - result.goal)))}
    for key in ("route_energy_J", "route_time_s", "route_length_m"):
        if key in result.settings:  # GS and GS+W: the route as planned
            out[key] = _number(result.settings[key])
    return out


def case_summary(case: Mapping) -> dict:
    """The JSON-ready numbers of a :func:`run_case` result.

    Returns
    -------
    dict
        ``name``, ``seed``, ``speed`` (m/s), ``direction_deg``, ``start``, ``goal`` (m),
        ``bounds`` and ``footprints`` (m, ``[x_min, x_max, y_min, y_max]``), ``flow_settings``,
        and ``variants``: per display name, ``variant``, ``outcome``, ``energy_J`` (airspeed
        power curve), ``rotor_energy_J``, ``time_s``, ``distance_m``,
        ``final_distance_to_goal_m`` and, for GS and GS+W, the planned route's
        ``route_energy_J``, ``route_time_s`` and ``route_length_m`` (non-finite numbers as
        None).

    Raises
    ------
    ValueError
        A ``case`` that is not a :func:`run_case` result (``{}`` raised a bare KeyError;
        Python API audit, fifty-eighth session).
    """
    keys = ("name", "speed", "direction_deg", "start", "goal", "city", "results")
    if not isinstance(case, Mapping) or not all(k in case for k in keys):
        got = (f"one with the keys {sorted(map(str, case))}" if isinstance(case, Mapping)
               else f"a {type(case).__name__}")
        raise ValueError(f"The 'case' parameter of case_summary must be run_case's result, with "
                         f"the keys {list(keys)}. Got {got} instead.")
    city = case["city"]
    return {"name": case["name"], "seed": case.get("seed"), "speed": float(case["speed"]),
            "direction_deg": float(case["direction_deg"]),
            "start": [float(v) for v in case["start"]], "goal": [float(v) for v in case["goal"]],
            "bounds": [float(v) for v in city.bounds],
            "footprints": np.asarray(city.footprints, dtype=np.float64).tolist(),
            "flow_settings": dict(case.get("flow_settings", {})),
            "variants": {label: _flight_numbers(r) for label, r in case["results"].items()}}
