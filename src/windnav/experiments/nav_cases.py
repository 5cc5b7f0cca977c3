"""Single cases of the navigation benchmark: the best and worst scenario, re-flown; the winds.

The benchmark's store (:class:`~windnav.experiments.nav_records.NavStore`) keeps one record per
flight, not the flights. This module picks scenarios from the records and flies them again to
show them (thesis ch. 5, the example flights and the wind-scenario figure):

* :func:`best_worst` ranks the scenarios where both a variant and the reference succeeded by
  the paired energy reduction ``r = 1 - E_variant / E_reference`` (``energy_J``, the airspeed
  power curve), the per-scenario quantity whose mean is the table's *paired reduction*
  (:func:`~windnav.experiments.nav_records.benchmark_table`);
* :func:`fly_cases` re-flies scenarios by id with several variants, exactly as the benchmark
  does (:func:`~windnav.experiments.nav_benchmark.fly_scenario`: the suite's map, the suite's
  wind from :func:`~windnav.experiments.nav_benchmark.suite_flow`, the scenario's seed and the
  suite's ``navigate_options``), and keeps the time series (:class:`NavigationResult`);
* :func:`wind_scenarios` simulates a few winds of one map and draws the suite's start/goal
  pairs of each: the data of the wind-scenario figure.

The figures are in :mod:`windnav.viz.nav_studies` (``plot_cases``, ``plot_wind_scenarios``):
``viz`` lies to the right of ``experiments`` in the data flow, so this module draws nothing.

Memory: a 600 m wind of the thesis suite holds 2.3 GB of frames. The cases and the wind
scenarios keep only each wind's mean field (a :class:`~windnav.flow.FlowSolution` whose
``frames_u``, ``frames_v`` are None), what the figures draw, unless ``keep_frames``.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable, Iterable, Mapping, Sequence

from windnav.experiments.nav_records import latest_records
from windnav.experiments.nav_suite import (
    Scenario,
    SuiteSpec,
    check_suite_spec,
    make_suite,
    parse_scenario_id,
    suite_map,
)
from windnav.experiments.results import say

__all__ = ["SUCCESS", "best_worst", "check_pair", "default_winds", "fly_cases", "mean_flow",
           "wind_scenarios"]

SUCCESS = "success"
"""The outcome of a flight that reached and held its goal."""


# ------------------------------------------------------------------------------- ranking


def _energy(rec: Mapping) -> float | None:
    """The record's ``energy_J`` as a finite float, or None."""
    try:
        e = float(rec.get("energy_J"))
    except (TypeError, ValueError):
        return None
    return e if math.isfinite(e) else None


def check_pair(variant, reference, where: str) -> None:
    """A ValueError naming ``variant`` or ``reference`` of ``where`` unless both are variant
    labels (non-empty strings) and differ: a variant against itself compares nothing."""
    for name, value in (("variant", variant), ("reference", reference)):
        if not isinstance(value, str) or not value:
            raise ValueError(f"The {name!r} parameter of {where} must be a variant label. Got "
                             f"{value!r} instead.")
    if variant == reference:
        raise ValueError(f"The 'variant' parameter of {where} must differ from the reference "
                         f"{reference!r}. Got {variant!r} instead.")


def best_worst(records: Iterable[Mapping], *, variant: str = "ea-mppi-w",
               reference: str = "mppi") -> dict:
    """The scenarios with the largest and smallest paired energy reduction of ``variant``.

    For each scenario where both ``variant`` and ``reference`` succeeded (``outcome ==
    "success"``, with a finite ``energy_J``, the reference's > 0), the reduction is
    ``r = 1 - E_variant / E_reference`` (``energy_J``, J; r > 0: the variant used less energy).
    When a ``(scenario_id, variant)`` was recorded twice (a ``--retry-errors`` run), its last
    record counts, as in :meth:`NavStore.latest`.

    Parameters
    ----------
    records : iterable of dict
        Flight records (:meth:`NavStore.load`): ``scenario_id``, ``variant``, ``outcome``,
        ``energy_J``; any order, other variants ignored.
    variant, reference : str
        The variant compared and the reference it is compared with.

    Returns
    -------
    dict
        ``variant``, ``reference``; ``n`` (scenarios compared); ``best`` and ``worst``, each
        ``{"scenario_id", "reduction", "energy_J": {variant: J, reference: J}}``; ``ranked``,
        every ``(scenario_id, reduction)`` from the largest reduction to the smallest (ties in
        the order of the ids).

    Raises
    ------
    ValueError
        ``variant`` equal to ``reference`` or not a string; no scenario where both succeeded.
    """
    where = "best_worst"
    check_pair(variant, reference, where)
    latest = latest_records(records)
    energies: dict[str, dict[str, float]] = {}
    for (sid, v), rec in latest.items():
        e = _energy(rec)
        if v in (variant, reference) and rec.get("outcome") == SUCCESS and e is not None:
            energies.setdefault(sid, {})[v] = e
    paired = {sid: e for sid, e in energies.items()
              if variant in e and reference in e and e[reference] > 0.0}
    if not paired:
        ok = {v: sum(1 for (_, w), r in latest.items() if w == v and r.get("outcome") == SUCCESS)
              for v in (variant, reference)}
        raise ValueError(f"The 'records' parameter of {where} must hold at least one scenario "
                         f"where both {variant!r} and {reference!r} succeeded. Got "
                         f"{len(latest)} flights ({ok[variant]} successes of {variant!r}, "
                         f"{ok[reference]} of {reference!r}, none in the same scenario) "
                         "instead.")
    reduction = {sid: 1.0 - e[variant] / e[reference] for sid, e in paired.items()}
    ranked = sorted(reduction.items(), key=lambda item: (-item[1], item[0]))

    def case(sid: str) -> dict:
        return {"scenario_id": sid, "reduction": reduction[sid],
                "energy_J": {variant: paired[sid][variant],
                             reference: paired[sid][reference]}}

    return {"variant": variant, "reference": reference, "n": len(ranked),
            "best": case(ranked[0][0]), "worst": case(ranked[-1][0]), "ranked": ranked}


# ------------------------------------------------------------------------------- flights


def mean_flow(flow):
    """``flow`` without its frames: the :class:`~windnav.flow.FlowSolution` of its mean field.

    Accepts a ``FlowSolution`` or the benchmark's
    :class:`~windnav.experiments.nav_benchmark.SharedFlow` (whose solution is unwrapped, so the
    2.3 GB of a 600 m wind's frames can be freed). Anything else is returned as it is.
    """
    from windnav.experiments.nav_benchmark import SharedFlow

    base = flow.solution if isinstance(flow, SharedFlow) else flow
    if dataclasses.is_dataclass(base) and hasattr(base, "frames_u"):
        return dataclasses.replace(base, frames_u=None, frames_v=None)
    return base


def _check_ids(spec: SuiteSpec, scenario_ids, where: str) -> list[Scenario]:
    if isinstance(scenario_ids, str):
        scenario_ids = [scenario_ids]
    ids = list(scenario_ids)
    if not ids or len(set(ids)) != len(ids):
        raise ValueError(f"The 'scenario_ids' parameter of {where} must be distinct scenario "
                         f"ids, at least one. Got {scenario_ids!r} instead.")
    out = []
    for sid in ids:
        try:
            out.append(parse_scenario_id(spec, sid))
        except ValueError as exc:
            raise ValueError(f"The 'scenario_ids' parameter of {where} must hold scenarios of "
                             f"the suite {spec.name!r}. Got {sid!r} instead: {exc}") from exc
    return out


def fly_cases(spec, scenario_ids: Sequence[str] | str, variants: Sequence[str] | str, *,
              progress: bool = False, keep_frames: bool = False,
              navigate_fn: Callable | None = None) -> dict:
    """Re-fly scenarios of the suite with several variants, exactly as the benchmark does.

    Each scenario's map (:func:`suite_map`) and wind
    (:func:`~windnav.experiments.nav_benchmark.suite_flow`: ``spinup_s`` of spin-up, then
    ``record_s`` of frames) are built once, shared by scenarios of the same map and wind, and
    every variant flies it with :func:`~windnav.experiments.nav_benchmark.fly` (the call of
    :func:`~windnav.experiments.nav_benchmark.fly_scenario`), so the flights are the recorded
    ones (a 600 m wind takes 25-40 s of one core to simulate).

    Parameters
    ----------
    spec : SuiteSpec or str
        The suite (a name of :data:`~windnav.experiments.nav_suite.SUITES`: its seed 0).
    scenario_ids : sequence of str, or one str
        Distinct ids of the suite's scenarios (``"thesis/m03/w07/p2"``).
    variants : sequence of str, or a comma-separated str
        Keys of :data:`windnav.plan.VARIANTS` or labels with study parameters
        (:func:`~windnav.experiments.nav_benchmark.parse_variant`), flown in this order.
    progress : bool
        A line per wind and per flight on stderr.
    keep_frames : bool
        Keep each wind's recorded frames (:class:`SharedFlow`, 2.3 GB for a 600 m wind);
        default only its mean field (:func:`mean_flow`), what the figures draw.
    navigate_fn : callable, optional
        Replaces :func:`~windnav.experiments.navigate.navigate` (same signature): a hook for
        tests and ablations.

    Returns
    -------
    dict
        ``{scenario_id: {"scenario": Scenario, "city": City, "flow": FlowSolution,
        "results": {variant: NavigationResult}}}`` in the order of ``scenario_ids``.

    Raises
    ------
    ValueError
        An id that is not a scenario of the suite, an unknown variant; whatever the wind
        simulation or a flight raised is not caught (a case is wanted whole).
    """
    from windnav.experiments import nav_benchmark

    where = "fly_cases"
    spec = check_suite_spec(spec, where)
    variants = nav_benchmark.check_variants(variants, where)
    scenarios = _check_ids(spec, scenario_ids, where)
    cities: dict[int, object] = {}
    cases: dict[str, dict] = {}
    groups: dict[tuple[int, int], list[Scenario]] = {}
    for sc in scenarios:
        groups.setdefault(sc.group, []).append(sc)
    for (m, _), members in groups.items():
        city = cities.get(m)
        if city is None:
            city = cities[m] = suite_map(spec, m)
        first = members[0]
        say(progress, f"fly_cases: wind of {first.scenario_id} ({first.speed:g} m/s toward "
                       f"{first.direction_deg:g} deg)")
        flow = nav_benchmark.suite_flow(spec, city, first.speed, first.direction_deg)
        for sc in members:
            results = {}
            for v in variants:
                results[v] = nav_benchmark.fly(spec, sc, v, city=city, flow=flow,
                                               navigate_fn=navigate_fn)
                say(progress, f"fly_cases: {sc.scenario_id} {v}: {results[v].outcome}, "
                               f"{results[v].energy_J / 1e3:.2f} kJ")
            cases[sc.scenario_id] = {"scenario": sc, "city": city, "results": results,
                                     "flow": flow if keep_frames else None}
        if not keep_frames:
            mean = mean_flow(flow)
            del flow  # the frames go with the last reference
            for sc in members:
                cases[sc.scenario_id]["flow"] = mean
    return {sc.scenario_id: cases[sc.scenario_id] for sc in scenarios}


# ------------------------------------------------------------------------------- winds


def default_winds(spec: SuiteSpec) -> tuple[int, ...]:
    """The winds of the wind-scenario figure: one per inlet speed, each at another incidence.

    Speed ``i`` (of ``len(spec.speeds)``) is paired with incidence ``(i + 1) % k`` (of
    ``k = len(spec.incidences_deg)``), wind ``w = i k + (i + 1) % k``, keeping the first four
    that the suite flies. For the thesis suite: ``w01`` (2 m/s toward 15 deg), ``w06`` (5 m/s,
    30 deg), ``w11`` (7 m/s, 45 deg) and ``w12`` (10 m/s, 0 deg): every inlet speed and every
    incidence appears once (a diagonal of the 4 x 4 wind grid), so the four panels span both the
    Reynolds-number range and the angles at which the wind meets the street grid. A suite that
    flies none of the diagonal's winds gets its own first four: the ``quick`` suite's ``w04``
    and ``w10`` were an empty choice that ``nav-study winds --suite quick`` refused
    (fifty-second session).
    """
    k = len(spec.incidences_deg)
    diagonal = [i * k + (i + 1) % k for i in range(len(spec.speeds))]
    return tuple(w for w in diagonal if w in spec.winds)[:4] or tuple(spec.winds[:4])


def wind_scenarios(spec, map_index: int, winds: Sequence[int] | None = None, *,
                   pairs: bool = True, progress: bool = False) -> dict:
    """The mean wind of a few inlets on one map of the suite, with the suite's pairs of each.

    The data of the wind-scenario figure (:func:`windnav.viz.nav_studies.plot_wind_scenarios`).
    Each wind is simulated as the benchmark does
    (:func:`~windnav.experiments.nav_benchmark.suite_flow`), one at a time, and only its mean
    field is kept (:func:`mean_flow`; a 600 m wind takes 25-40 s of one core and 4.6 GB while
    it is built).

    Parameters
    ----------
    spec : SuiteSpec or str
        The suite (a name of :data:`~windnav.experiments.nav_suite.SUITES`: its seed 0).
    map_index : int
        A map of the suite (``spec.maps``).
    winds : sequence of int, optional
        Distinct wind indices of the suite (``spec.winds``), one panel each; default
        :func:`default_winds` (``w01, w06, w11, w12`` for the thesis suite).
    pairs : bool
        Also draw the suite's start/goal pairs (``spec.pairs``) of each wind.
    progress : bool
        A line per wind on stderr.

    Returns
    -------
    dict
        ``suite`` (name), ``map_index``, ``city``, and ``winds``: one dict per wind, in order,
        with ``wind_index``, ``speed`` (m/s), ``direction_deg`` (toward, counter-clockwise from
        +x), ``flow`` (mean field only: ``x``, ``y``, ``solid``, ``mean_u``, ``mean_v``, m/s)
        and ``scenarios`` (the :class:`Scenario` of each pair, with ``kind`` ``"tailwind"`` or
        ``"headwind"`` and ``start``, ``goal`` in m; empty without ``pairs``).

    Raises
    ------
    ValueError
        A map or a wind the suite does not fly, repeated winds, no wind.
    """
    from windnav.experiments import nav_benchmark

    where = "wind_scenarios"
    spec = check_suite_spec(spec, where)
    try:
        ok = not isinstance(map_index, bool) and int(map_index) == map_index
    except (TypeError, ValueError):
        ok = False
    if not ok or int(map_index) not in spec.maps:
        raise ValueError(f"The 'map_index' parameter of {where} must be a map of the "
                         f"{spec.name} suite, among {list(spec.maps)}. Got {map_index!r} "
                         "instead.")
    m = int(map_index)
    chosen = default_winds(spec) if winds is None else winds
    try:
        ws = [int(w) for w in chosen]
        ok = all(not isinstance(w, bool) and int(w) == w for w in chosen)
    except (TypeError, ValueError):
        ok = False
    if not ok or not ws or len(set(ws)) != len(ws) or not set(ws) <= set(spec.winds):
        raise ValueError(f"The 'winds' parameter of {where} must be distinct wind indices of "
                         f"the {spec.name} suite, among {list(spec.winds)}, at least one. Got "
                         f"{chosen!r} instead.")
    city = suite_map(spec, m)
    out = []
    for w in ws:
        speed, direction = spec.wind(w)
        say(progress, f"wind_scenarios: m{m:02d}/w{w:02d} ({speed:g} m/s toward "
                       f"{direction:g} deg)")
        flow = mean_flow(nav_benchmark.suite_flow(spec, city, speed, direction))
        scenarios = (make_suite(dataclasses.replace(spec, maps=(m,), winds=(w,)),
                                maps={m: city}) if pairs else [])
        out.append({"wind_index": w, "speed": speed, "direction_deg": direction,
                    "flow": flow, "scenarios": scenarios})
    return {"suite": spec.name, "map_index": m, "city": city, "winds": out}
