"""The navigation demo: a city, its wind, MPPI and EA-MPPI+W flying the same start and goal.

1. A planning city from the seed (:func:`windnav.city.planning_map`, 400 m square, 9-16
   buildings of 10-50 m stacked from blocks: the thesis's planning maps are 600 m with as many
   buildings, so this is a denser district).
2. Its unsteady 2D wind (:func:`windnav.experiments.navigate.simulate_flow`: 25 s of spin-up,
   then 100 s of frames every 0.25 s), inlet ``wind_speed`` toward ``direction_deg``.
3. A start on the west side and a goal on the east side of the map, each moved to the nearest
   point ``clearance`` m (40) from every building and ``map_size / 12`` from the edges
   (:func:`~windnav.experiments.navigate.free_point`), so the goal can be reached and held.
4. MPPI and EA-MPPI+W fly from the start to the goal in the same wind with the same seed
   (:func:`~windnav.experiments.navigate.navigate`: 6-DoF Hummingbird, 10 Hz planner, 100 Hz
   SE(3) control); the energy of each (airspeed power curve and rotor energy) and the saving of
   EA-MPPI+W over MPPI, ``100 (E_mppi - E_ea) / E_mppi`` %, when both succeeded. Other
   flights (``flights``, ``windnav demo --variant``: any of ``benchmark-nav``'s labels, up to
   four) fly instead, the first the reference of the comparison.

Why this size and grid
----------------------
The demo is the README's first command, so it must run in about a minute on 2 cores. The flow
costs in proportion to its cells: the thesis's 600 m map on its 1 m grid (360,000 cells) takes
about a minute by itself. A 400 m map on a 2 m grid has 40,000 cells, 9x fewer, and simulates
in 5-12 s. The 2 m grid resolves the same flow as the 1 m grid: the closure's filter width is
``max(dx, median building side / 8)``, about 3.7 m for these buildings, so halving ``dx`` below
it changes the solution by 2-3 % (docs/flow_validation.md, the resolution study at 8 cells per
building side). The start and goal are aimed 290 m apart (then moved to clear points), long
enough for the planners' 100 m horizon to matter, short enough for both flights to end well
within the 100 s of wind.

The default case
----------------
``--seed 0`` draws the city; the inlet, 5 m/s toward -45 deg (from the north-west), was chosen
among 13 inlets (5 m/s toward eight directions, 8 and 10 m/s toward a few) for that city, on
2026-11-23 with the planner of that date, as an illustrative case: the one in which both
variants reach the goal. Nothing else is chosen, and no result is written down here: the
numbers are whatever the flights give. With the planner of that date EA-MPPI+W uses *more*
energy than MPPI in this case (it flies slower and overshoots the goal before settling), as in
every case tried where both succeeded, and the summary says so rather than hiding it.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass

import numpy as np

from windnav._validate import finite_float, nonnegative_int, positive_float
from windnav.experiments.results import say

__all__ = ["LABELS", "RECORD_KEYS", "VARIANTS", "NavDemoConfig", "compare_energies",
           "default_flights", "describe", "describe_comparison", "legend_name", "run_nav_demo"]

VARIANTS = ("mppi", "ea-mppi-w")
"""The baseline and the energy-aware, wind-aware planner the demo compares by default."""

LABELS = {"mppi": "MPPI", "mppi-w": "MPPI+W", "ea-mppi": "EA-MPPI", "ea-mppi-w": "EA-MPPI+W",
          "gs": "GS", "gs-w": "GS+W", "ea-mppi-w-hat": "EA-MPPI+Ŵ",
          "ea-mppi-w-esc": "EA-MPPI+W+esc"}
"""Display names of the variants."""

RECORD_KEYS = ("outcome", "energy_J", "rotor_energy_J", "time_s", "distance_m",
               "mean_cmd_accel", "planner_ms_median")
"""The keys of each variant's record in the summary that ``windnav navigate --json`` writes
too (each record also has the rest of :meth:`NavigationResult.summary`)."""


@dataclass(frozen=True)
class NavDemoConfig:
    """Settings of :func:`run_nav_demo` (SI units).

    Attributes
    ----------
    seed : int
        Seeds the city, the planners' sampling and the LiDAR noise.
    map_size : float
        Side of the square planning map, m.
    wind_speed : float
        Inlet wind speed, m/s.
    direction_deg : float
        Direction the inlet wind blows toward, degrees counter-clockwise from +x (east).
    dx : float
        Flow grid spacing, m.
    flow_dt : float
        Flow time step and frame interval, s; ``wind_speed * flow_dt / dx`` <= 2.5 (CFL).
    spinup_s : float
        Flow spin-up before the record, s.
    record_s : float
        Recorded wind, s: the longest flight.
    clearance : float
        Smallest distance from the start and goal to a building, m.
    altitude : float
        Flight altitude, m.
    """

    seed: int = 0
    map_size: float = 400.0
    wind_speed: float = 5.0
    direction_deg: float = -45.0
    dx: float = 2.0
    flow_dt: float = 0.25
    spinup_s: float = 25.0
    record_s: float = 100.0
    clearance: float = 40.0
    altitude: float = 10.0

    def __post_init__(self):
        from windnav.flow.solver import MAX_CFL

        where = "NavDemoConfig"
        nonnegative_int(self.seed, "seed", where)
        finite_float(self.direction_deg, "direction_deg", where)
        for name in ("map_size", "wind_speed", "dx", "flow_dt", "record_s", "altitude"):
            positive_float(getattr(self, name), name, where)
        for name in ("spinup_s", "clearance"):
            positive_float(getattr(self, name), name, where, allow_zero=True)
        cfl = self.wind_speed * self.flow_dt / self.dx
        if cfl > MAX_CFL:
            raise ValueError(
                f"The 'flow_dt' parameter of {where} gives a CFL number wind_speed*flow_dt/dx "
                f"= {cfl:.3g} above {MAX_CFL:g}; use flow_dt <= "
                f"{MAX_CFL * self.dx / self.wind_speed:.4g} s. Got {self.flow_dt!r} instead.")
        if self.dx > self.map_size / 20:
            raise ValueError(f"The 'dx' parameter of {where} must be at most map_size / 20 = "
                             f"{self.map_size / 20:g} m. Got {self.dx!r} instead.")


def _city(cfg: NavDemoConfig):
    """The seed's planning map, with a message naming the config when it cannot be drawn."""
    from windnav.city import planning_map

    try:
        return planning_map(rng=cfg.seed, size=cfg.map_size)
    except ValueError as exc:
        raise ValueError(f"The 'map_size' parameter of run_nav_demo must leave room for the "
                         f"city of seed {cfg.seed} ({exc}). Got {cfg.map_size!r} instead; use a "
                         "larger map (the default is 400 m).") from exc


def _endpoints(city, cfg: NavDemoConfig) -> tuple[np.ndarray, np.ndarray]:
    """Start (west) and goal (east) at mid-height, moved clear of buildings and edges."""
    from windnav.experiments.navigate import free_point

    s = cfg.map_size
    edge = s / 12.0
    points = []
    for side, x in (("west", s * 2 / 15), ("east", s * 13 / 15)):
        try:
            points.append(free_point(city, (x, s / 2), clearance=cfg.clearance, edge=edge))
        except ValueError as exc:
            raise ValueError(
                f"The 'map_size' parameter of run_nav_demo must leave the city of seed "
                f"{cfg.seed} a point {cfg.clearance:g} m clear of every building on its {side} "
                f"side. Got {cfg.map_size!r} instead, which has none; use a larger map, "
                "another seed or a smaller clearance.") from exc
    return points[0], points[1]


def _saving(records: dict, key: str, shapes: dict) -> tuple[float | None, str]:
    """``100 (E_base - E_new) / E_base`` of ``key`` for the two flights of ``records`` (the
    first is the base) when both succeeded on the same power curve (``shapes``: label -> its
    ``@power=`` shape or None), and why not."""
    labels = list(records)
    names = [legend_name(v, math.inf) for v in labels]
    failed = [f"{n} ended in {records[v]['outcome']}" for v, n in zip(labels, names, strict=True)
              if records[v]["outcome"] != "success"]
    if failed:
        return None, "not compared: " + " and ".join(failed) + " (energies compare only when " \
                     "both reach the goal)"
    if shapes.get(labels[0]) != shapes.get(labels[1]):
        return None, (f"not compared: {names[1]}'s energy_J is on another power curve than "
                      f"{names[0]}'s (@power=)")
    base, new = (records[v] for v in labels)
    pct = 100.0 * (base[key] - new[key]) / base[key]
    verb = "less" if pct >= 0 else "more"
    return pct, f"{names[1]} used {abs(pct):.1f} % {verb} energy than {names[0]}"


def _checked_flights(flights, navigate) -> list[dict]:
    """``flights`` as a list, each a dict of a ``label`` (str, distinct), a ``base`` (a key of
    :data:`windnav.plan.VARIANTS`) and ``kwargs`` (a dict of ``navigate``'s keyword arguments
    that :func:`run_nav_demo` does not set itself), else a ValueError naming ``flights``
    before the wind is simulated (``[{'variant': 'mppi'}]`` raised KeyError 'label', and a
    bad base or keyword failed only after the flow; API audit)."""
    import inspect

    from windnav.plan import VARIANTS as PLAN_VARIANTS

    where = "run_nav_demo"
    try:
        flights = list(flights)
    except TypeError:
        raise ValueError(f"The 'flights' parameter of {where} must be a list of dicts. Got "
                         f"{flights!r} instead.") from None
    own = {"speed", "direction_deg", "variant", "rng", "flow", "altitude"}
    takes = {name for name, par in inspect.signature(navigate).parameters.items()
             if par.kind is inspect.Parameter.KEYWORD_ONLY} - own
    for flight in flights:
        if not isinstance(flight, dict) or not {"label", "base", "kwargs"} <= set(flight):
            raise ValueError(f"The 'flights' parameter of {where} must give each flight a "
                             f"dict with 'label', 'base' and 'kwargs'. Got {flight!r} instead.")
        if not isinstance(flight["label"], str):
            raise ValueError(f"The 'flights' parameter of {where} must give each flight a "
                             f"label that is a str. Got {flight['label']!r} instead.")
        if flight["base"] not in PLAN_VARIANTS:
            raise ValueError(f"The 'flights' parameter of {where} must give each flight a base "
                             f"among {sorted(PLAN_VARIANTS)}. Got {flight['base']!r} for "
                             f"{flight['label']!r} instead.")
        kwargs = flight["kwargs"]
        if not isinstance(kwargs, dict) or not set(kwargs) <= takes:
            wrong = kwargs if not isinstance(kwargs, dict) else sorted(set(kwargs) - takes)
            raise ValueError(f"The 'flights' parameter of {where} must give each flight kwargs "
                             f"among navigate's {sorted(takes)}. Got {wrong!r} for "
                             f"{flight['label']!r} instead.")
    return flights


def default_flights() -> list[dict]:
    """The demo's two flights: :data:`VARIANTS` with navigate's defaults."""
    return [{"label": v, "base": v, "kwargs": {}} for v in VARIANTS]


def run_nav_demo(cfg: NavDemoConfig | None = None, *, flights: list[dict] | None = None,
                 progress: bool = False) -> dict:
    """Simulate the city's wind and fly MPPI and EA-MPPI+W (or ``flights``) through it.

    Parameters
    ----------
    cfg : NavDemoConfig, optional
        Default ``NavDemoConfig()`` (built at the call: a default built at import imported
        the flow solver with the module).
    flights : list of dict, optional
        The flights, in order, each ``label`` (distinct), ``base`` (a key of
        :data:`windnav.plan.VARIANTS`) and ``kwargs`` (navigate's keyword arguments beyond the
        scenario; a label's ``power_shape`` among them), as
        :func:`windnav.commands.navigate.flights` gives them for ``--variant``. Default
        :func:`default_flights`, MPPI then EA-MPPI+W.
    progress : bool
        Report each stage (and the flow's progress bar) on stderr.

    Returns
    -------
    dict
        ``config``; ``city``; ``flow`` (the :class:`~windnav.flow.FlowSolution`); ``start``,
        ``goal`` (ndarray of shape (2,), m); ``results``: label -> ``NavigationResult``;
        ``summary``: the JSON-ready scalars (see :func:`describe`), with ``timings_s``. Its
        ``variants`` holds each flight's record by label (with ``label`` where it has
        parameters). Two flights compare the second with the first:
        ``energy_saving_percent``, ``rotor_energy_saving_percent`` and ``energy_saving_note``
        (the rotor energy, the simulator's, compares across ``@power=`` curves too); three or
        more compare each with the first: :func:`compare_energies`'s ``reference``,
        ``energy_vs_reference_percent`` and ``energy_not_compared``; one flight compares
        nothing.
    """
    from windnav.experiments.navigate import navigate, simulate_flow

    cfg = NavDemoConfig() if cfg is None else cfg
    if not isinstance(cfg, NavDemoConfig):  # a dict raised AttributeError (API audit)
        raise ValueError(f"The 'cfg' parameter of run_nav_demo must be a NavDemoConfig or "
                         f"None. Got {cfg!r} instead.")
    flights = default_flights() if flights is None else _checked_flights(flights, navigate)
    labels = [f["label"] for f in flights]
    if not flights or len(set(labels)) != len(labels):
        raise ValueError(f"The 'flights' parameter of run_nav_demo must name one flight or "
                         f"more, each label once. Got {labels!r} instead.")
    timings = {}
    t0 = time.perf_counter()
    city = _city(cfg)
    start, goal = _endpoints(city, cfg)
    timings["city"] = time.perf_counter() - t0

    say(progress, f"simulating the wind of a {cfg.map_size:g} m city "
                   f"({np.unique(city.building_labels()).size} buildings): "
                   f"{cfg.wind_speed:g} m/s toward {cfg.direction_deg:g} deg, "
                   f"{cfg.spinup_s:g} s spin-up + {cfg.record_s:g} s recorded on {cfg.dx:g} m "
                   "cells")
    t0 = time.perf_counter()
    flow = simulate_flow(city, cfg.wind_speed, cfg.direction_deg, spinup_s=cfg.spinup_s,
                         record_s=cfg.record_s, dx=cfg.dx, dt=cfg.flow_dt, progress=progress)
    timings["flow"] = time.perf_counter() - t0

    results, records = {}, {}
    for flight in flights:
        label = flight["label"]
        say(progress, f"flying {legend_name(label, math.inf)} from "
                       f"{np.round(start).tolist()} to {np.round(goal).tolist()} m")
        t0 = time.perf_counter()
        res = navigate(city, start, goal, speed=cfg.wind_speed, direction_deg=cfg.direction_deg,
                       variant=flight["base"], rng=cfg.seed, flow=flow, altitude=cfg.altitude,
                       **flight["kwargs"])
        timings[label] = time.perf_counter() - t0
        results[label] = res
        records[label] = res.summary()
        if label != flight["base"]:
            records[label]["label"] = label

    shapes = {f["label"]: f["kwargs"].get("power_shape") for f in flights}
    if len(flights) == 2:
        saving, note = _saving(records, "energy_J", shapes)
        rotor_saving, _ = _saving(records, "rotor_energy_J", {})  # the vehicle's, always
        comparison = {"energy_saving_percent": saving,
                      "rotor_energy_saving_percent": rotor_saving, "energy_saving_note": note}
    else:
        comparison = compare_energies(records, shapes) if len(flights) > 2 else {}
    summary = {
        "seed": cfg.seed,
        "map_size_m": cfg.map_size,
        "n_buildings": int(np.unique(city.building_labels()).size),
        "n_blocks": int(city.n_buildings),
        "wind_speed_m_s": cfg.wind_speed,
        "direction_deg": cfg.direction_deg,
        "start": start.tolist(),
        "goal": goal.tolist(),
        "straight_line_m": float(math.hypot(*(goal - start))),
        "variants": records,
        **comparison,
        "flow": {"flow_throughs_spinup": flow.flow_throughs_spinup,
                 "flow_throughs_average": flow.flow_throughs_average,
                 "filter_width_m": flow.filter_width},
        "timings_s": timings,
    }
    return {"config": cfg, "city": city, "flow": flow, "start": start, "goal": goal,
            "results": results, "summary": summary}


ONE_FLIGHT = "one flight, not a rate: the benchmark's 1,024 scenarios are the measure"
"""What :func:`describe` says of its energy comparison, either way."""


def describe(summary: dict) -> str:
    """The human summary of a run: one line per variant, then the energy comparison.

    ``MPPI: success, 3.47 kJ in 54.0 s (rotor 3.60 kJ, 290 m flown)``, one such line per
    variant, then, for two flights, ``EA-MPPI+W saves 12.3 % of MPPI's energy in this flight
    (rotor energy: 11.8 %; ...)``, or says that it used more, or why the two were not compared;
    either way that it is one flight (the single-flight figure was printed as a saving without
    that; statistics audit). For three or more, each one's energy against the first's
    (:func:`describe_comparison`'s lines); for one, its line alone. Flights are named as the
    figures name them (:func:`legend_name` on one line).
    """
    where = "describe"
    if not isinstance(summary, dict) or not isinstance(summary.get("variants"), dict):
        raise ValueError(f"The 'summary' parameter of {where} must be run_nav_demo's summary, "
                         f"a dict with 'variants'. Got {summary!r} instead.")  # ({}: KeyError)
    need = ("outcome", "energy_J", "time_s", "rotor_energy_J", "distance_m")
    for v, r in summary["variants"].items():
        if not isinstance(r, dict) or not set(need) <= set(r):
            raise ValueError(f"The 'summary' parameter of {where} must give each variant a "
                             f"record with {list(need)}. Got {v!r}: {r!r} instead.")
    lines = []
    for v, r in summary["variants"].items():
        lines.append(f"{legend_name(v, math.inf)}: {r['outcome']}, {r['energy_J'] / 1e3:.2f} kJ "
                     f"in {r['time_s']:.1f} s (rotor {r['rotor_energy_J'] / 1e3:.2f} kJ, "
                     f"{r['distance_m']:.0f} m flown)")
    if "reference" in summary:
        return "\n".join(lines + _comparison_lines(summary, lambda v: legend_name(v, math.inf)))
    if "energy_saving_percent" not in summary:  # one flight
        return "\n".join(lines)
    pct = summary["energy_saving_percent"]
    if pct is None:
        lines.append(summary["energy_saving_note"])
        return "\n".join(lines)
    rotor = summary["rotor_energy_saving_percent"]
    base, new = (legend_name(v, math.inf) for v in summary["variants"])
    if pct >= 0:
        lines.append(f"{new} saves {pct:.1f} % of {base}'s energy in this flight (rotor "
                     f"energy: {rotor:+.1f} %; {ONE_FLIGHT})")
    else:
        lines.append(f"{new} used {-pct:.1f} % more energy than {base} (rotor energy: "
                     f"{-rotor:+.1f} %): no saving in this flight ({ONE_FLIGHT})")
    return "\n".join(lines)


def legend_name(label: str, width: float = 36) -> str:
    """A label as the figures' legends show it: the variant's display name
    (:data:`LABELS`), then its parameters, broken before an ``@``
    into lines of about ``width`` characters (a label of six parameters ran off the figure;
    ``math.inf``: one line, the GIF's title)."""
    if not isinstance(label, str):  # 5 raised AttributeError (API audit)
        raise ValueError(f"The 'label' parameter of legend_name must be a str. Got {label!r} "
                         "instead.")
    try:
        ok = float(width) > 0
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise ValueError(f"The 'width' parameter of legend_name must be a number > 0 "
                         f"(math.inf: one line). Got {width!r} instead.")
    base, *params = label.split("@")
    lines = [LABELS.get(base, base)]
    for param in params:
        if len(lines[-1]) + 1 + len(param) > width:
            lines.append("")
        lines[-1] += "@" + param
    return "\n".join(lines)


def compare_energies(summaries: dict, power_shapes: dict | None = None) -> dict:
    """The comparison of several flights with the first (the reference): ``reference`` (its
    label), ``energy_vs_reference_percent``: for each other label, ``100 (E_ref - E) / E_ref``
    (positive: less energy than the reference), or None where either flight failed (energies
    compare only when both reach the goal: one flight each, not a rate) or where the two
    flights' ``energy_J`` come from different power curves (``power_shapes``, label -> a
    label's ``@power=`` shape or None); and ``energy_not_compared``: label -> why, for each
    None.

    Raises
    ------
    ValueError
        Naming ``summaries`` when it holds no flight, a record without ``outcome``, or a
        compared flight whose ``energy_J`` is not a finite number > 0 (a negative reference
        read as a +150 % saving, NaN as nan, 0 raised ZeroDivisionError; API audit); naming
        ``power_shapes`` when it is not a dict.
    """
    where = "compare_energies"
    if not isinstance(summaries, dict) or not summaries:
        raise ValueError(f"The 'summaries' parameter of {where} must be a dict of one flight "
                         f"record or more, label -> record. Got {summaries!r} instead.")
    for label, record in summaries.items():
        if not isinstance(record, dict) or "outcome" not in record:
            raise ValueError(f"The 'summaries' parameter of {where} must give each flight a "
                             f"record with 'outcome'. Got {label!r}: {record!r} instead.")
    if power_shapes is not None and not isinstance(power_shapes, dict):
        raise ValueError(f"The 'power_shapes' parameter of {where} must be None or a dict "
                         f"label -> shape. Got {power_shapes!r} instead.")
    shapes = power_shapes or {}
    ref, *others = summaries
    base = summaries[ref]
    pct, why = {}, {}
    for label in others:
        s = summaries[label]
        failed = [v for v, r in ((ref, base), (label, s)) if r["outcome"] != "success"]
        pct[label] = None
        if failed:
            why[label] = f"{' and '.join(failed)} did not reach the goal"
        elif shapes.get(label) != shapes.get(ref):
            why[label] = (f"energy_J on another power curve ({shapes.get(label) or 'the vehicle'}"
                          f"'s against {shapes.get(ref) or 'the vehicle'}'s, @power=)")
        else:
            for v, r in ((ref, base), (label, s)):
                energy = r.get("energy_J")
                try:
                    ok = (not isinstance(energy, (bool, str, bytes))
                          and math.isfinite(float(energy)) and float(energy) > 0)
                except (TypeError, ValueError):
                    ok = False
                if not ok:
                    raise ValueError(f"The 'summaries' parameter of {where} must give each "
                                     "flight that reached the goal an energy_J that is a "
                                     f"finite number > 0. Got {v!r}: {energy!r} instead.")
            pct[label] = 100.0 * (base["energy_J"] - s["energy_J"]) / base["energy_J"]
    return {"reference": ref, "energy_vs_reference_percent": pct, "energy_not_compared": why}


def describe_comparison(summary: dict) -> str:
    """One line per flight, then each one's energy against the reference's, or why not."""
    lines = []
    for label, s in summary["variants"].items():
        lines.append(f"{label}: {s['outcome']}, {s['energy_J'] / 1e3:.2f} kJ in "
                     f"{s['time_s']:.1f} s ({s['distance_m']:.0f} m flown)")
    return "\n".join(lines + _comparison_lines(summary))


def _comparison_lines(summary: dict, name=str) -> list[str]:
    """Each flight's energy against the reference's (:func:`compare_energies`), or why not;
    ``name(label)`` names a flight in them."""
    lines = []
    ref = name(summary["reference"])
    for label, pct in summary["energy_vs_reference_percent"].items():
        if pct is None:
            lines.append(f"{name(label)} against {ref}: not compared "
                         f"({summary['energy_not_compared'][label]})")
        else:
            lines.append(f"{name(label)} used {abs(pct):.1f} % "
                         f"{'less' if pct >= 0 else 'more'} energy than {ref} (one flight "
                         "each, not a rate)")
    return lines
