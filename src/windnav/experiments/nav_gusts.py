"""The gust map of one benchmark scenario, and the least-time routes with and without it.

The sixth variant's least-time routes are planned in the mean wind (``@escair``); with
``@gust=K`` each move's ground speed is lowered by ``K`` standard deviations of the recorded
wind along it (:func:`windnav.plan.reach.least_time`). :func:`gust_routes` re-flies one
scenario of the suite with both (the benchmark's flights, exactly) and returns what the figure
(:func:`windnav.viz.nav_studies.plot_gust_routes`) draws: the mean wind, the standard
deviation of the wind along the inlet's direction (the gust a headwind or tailwind route
meets), the least-time route each flight flew, and the flown paths.

``windnav nav-study gusts --out docs/img/navigation`` (scenario ``thesis/m12/w14/p2``).
"""

from __future__ import annotations

import math

import numpy as np

from windnav._validate import options_named
from windnav.experiments.nav_benchmark import check_scenario_ids, number_label, parse_variant
from windnav.experiments.nav_cases import fly_cases, mean_flow
from windnav.experiments.nav_suite import check_suite_spec

__all__ = ["DEFAULT_BASE", "DEFAULT_SCENARIO", "gust_routes"]

DEFAULT_BASE = "ea-mppi-w-esc@escair=13.45@edge=15@pace=20@regain=20@launch=40"
"""The sixth variant's setting the gust margin is added to."""

DEFAULT_SCENARIO = "thesis/m12/w14/p2"
"""A 10 m/s headwind the gust margin turned from a timeout into a success (the figure of
docs/navigation.md)."""


def gust_routes(spec="thesis", scenario_id: str = DEFAULT_SCENARIO, *,
                base: str = DEFAULT_BASE, gust_k: float = 0.5, progress: bool = False) -> dict:
    """Fly one scenario with ``base`` and ``base@gust=gust_k``; the routes and the gust map.

    Parameters
    ----------
    spec : SuiteSpec or str
        The suite (a name: its seed 0).
    scenario_id : str
        A scenario of the suite.
    base : str
        A label of the sixth variant with least-time escapes (``ea-mppi-w-esc@escair=A...``)
        and no ``@gust``.
    gust_k : float
        The gust margin, standard deviations (> 0).
    progress : bool
        A line per wind and flight on stderr.

    Returns
    -------
    dict
        ``scenario``, ``city``, ``flow`` (the mean field only), ``sigma_along`` (ny, nx: the
        standard deviation of the wind along the inlet's direction, m/s, on the flow's grid),
        ``gust_k``, ``variants`` (the two labels), ``flights`` (``{label: NavigationResult}``)
        and ``routes`` (``{label: {"samples": (M, 2) m, "begun_s": s, "time_s": s}}``: the last
        least-time route each flight flew, when it was begun and its time in the mean wind;
        None for a flight that flew none).

    Raises
    ------
    ValueError
        A ``base`` without least-time escapes or with a gust margin, ``gust_k <= 0``, or a
        ``scenario_id`` not of the suite (each checked before any flight).
    """
    from windnav.plan.reach import wind_covariance

    where = "gust_routes"
    # the names the caller gave (parse_variant's and fly_cases' named 'variants' and
    # 'scenario_ids', the latter after the wind had been simulated; Python API audit,
    # fifty-eighth session)
    with options_named({"'suite' parameter of get_suite": f"'spec' parameter of {where}"}):
        spec = check_suite_spec(spec, where)
    if not isinstance(scenario_id, str):
        raise ValueError(f"The 'scenario_id' parameter of {where} must be a scenario id of the "
                         f"suite {spec.name!r}. Got {scenario_id!r} instead.")
    with options_named({f"'scenario_ids' parameter of {where}":
                        f"'scenario_id' parameter of {where}"}):
        check_scenario_ids(spec, [scenario_id], where)
    with options_named({f"'variants' parameter of {where}": f"'base' parameter of {where}"}):
        _, options = parse_variant(base, where)
    escape = options.get("escape")
    if escape is None or escape.airspeed_mps is None or escape.gust_k > 0:
        raise ValueError(f"The 'base' parameter of {where} must be a label of the sixth variant "
                         "with least-time escapes ('ea-mppi-w-esc@escair=A...') and no '@gust'. "
                         f"Got {base!r} instead.")
    k = float(gust_k)
    if not (0.0 < k < math.inf):
        raise ValueError(f"The 'gust_k' parameter of {where} must be a finite number > 0. Got "
                         f"{gust_k!r} instead.")
    variants = [base, f"{base}@gust={number_label(k)}"]
    case = fly_cases(spec, [scenario_id], variants, progress=progress,
                     keep_frames=True)[scenario_id]
    scenario, city, flow = case["scenario"], case["city"], case["flow"]
    cov = wind_covariance(flow)
    d = math.radians(scenario.direction_deg)
    ex, ey = math.cos(d), math.sin(d)
    sigma = np.sqrt(np.maximum(ex * ex * cov[..., 0] + 2 * ex * ey * cov[..., 1]
                               + ey * ey * cov[..., 2], 0.0))
    routes = {}
    for label, res in case["results"].items():
        samples = getattr(res, "route", None)
        escapes = [e for e in res.settings.get("escapes") or [] if math.isfinite(e[2])]
        routes[label] = None if samples is None or not escapes else {
            "samples": np.asarray(samples, dtype=np.float64), "begun_s": float(escapes[-1][0]),
            "time_s": res.settings.get("route_time_s")}
    return {"scenario": scenario, "city": city, "flow": mean_flow(flow), "sigma_along": sigma,
            "gust_k": k, "routes": routes, "variants": variants, "flights": case["results"]}
