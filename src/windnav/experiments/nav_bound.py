"""How much energy could any planner save against MPPI? The energy-optimal route as a bound.

A GS+W flight of the benchmark records the route it planned before take-off
(:data:`~windnav.experiments.nav_benchmark.ROUTE_FIELDS`): the energy-optimal route through the
whole known map in the mean wind, each piece flown at its best ground speed (the maximum-range
speed ``V_R(W)``), plus the 5 s goal hold at rest in the mean wind at the goal. Its energy ::

    E*(scenario) = route_energy_J + route_hold_energy_J        (J, airspeed power curve)

is what the vehicle would use on the cheapest route it can find, in steady flight, with no
acceleration, no gusts and no time limit. It is not a proven lower bound (the lattice's optimum
is a discretisation's, and a flight in the unsteady wind could in principle draw on its gusts)
but :func:`bound_study` measures how often a flown flight used less (``below_bound``) and
by how much at most (``shortfall``), and draws the bound again with every ``E*`` lowered by
that much (``slack``): a target beyond even that curve is out of reach on the evidence of
every flight flown.

What it bounds:

- **the paired reduction** against MPPI: over MPPI's successes, no planner can save more than
  ``1 - E* / E_MPPI`` on a scenario (``ideal_paired``);
- **the table ratio** ``1 - mean(E) / mean(E_MPPI)`` at a failure rate ``f``: a variant that
  fails at most ``f`` of the ``N`` scenarios succeeds on at least ``N - floor(f N)`` of them,
  and its mean energy over them is at least the mean of the cheapest that many ``E*``
  (:func:`ideal_table_ratio`). A scenario without a route counts with ``E* = 0``, so the bound
  stays an upper bound on the ratio.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence

import numpy as np

from windnav.experiments.nav_records import (
    _both_succeeded,
    _describe,
    _energies,
    records_by_variant,
)
from windnav.experiments.thesis_nav import TARGETS

__all__ = ["TARGETS", "bound_study", "ideal_energy", "ideal_table_ratio"]


def _check_confidence(confidence, where: str) -> None:
    """A ValueError naming ``confidence`` of ``where`` unless it is a number in (0, 1) (2, 0
    and NaN gave intervals of no level; Python API audit, fifty-eighth session)."""
    try:
        ok = not isinstance(confidence, (bool, str)) and 0.0 < float(confidence) < 1.0
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise ValueError(f"The 'confidence' parameter of {where} must be in (0, 1). Got "
                         f"{confidence!r} instead.")


def ideal_energy(route_records: Mapping[str, Mapping]) -> dict[str, float]:
    """``E*`` per scenario id (J) from GS+W records (scenario id -> record): the planned route's
    energy plus its goal hold; NaN where the record has no route (a harness error)."""
    # (a list of records raised an AttributeError; Python API audit, fifty-eighth session)
    if not isinstance(route_records, Mapping):
        raise ValueError("The 'route_records' parameter of ideal_energy must be a dict of "
                         f"scenario id to record. Got a {type(route_records).__name__} instead.")
    bad = [sid for sid, r in route_records.items() if not isinstance(r, Mapping)]
    if bad:
        raise ValueError("The 'route_records' parameter of ideal_energy must be a dict of "
                         f"scenario id to record (a dict). Got other values for {bad[:3]} "
                         "instead.")
    out = {}
    for sid, r in route_records.items():
        e, hold = r.get("route_energy_J"), r.get("route_hold_energy_J")
        out[sid] = (float(e) + float(hold)) if e is not None and hold is not None else math.nan
    return out


def ideal_table_ratio(ideal: Sequence[float], reference_mean_J: float,
                      failure_pct) -> np.ndarray:
    """The largest table ratio a variant failing at most ``failure_pct`` (%, scalar or array) of
    the scenarios could reach: ``1 - mean(cheapest N - floor(f N) of ideal) / reference_mean_J``.
    ``ideal``: ``E*`` of every scenario (J, finite and >= 0; NaN, no route, counts as 0);
    ``reference_mean_J`` finite and > 0; ``failure_pct`` in [0, 100]. (An infinite energy or
    reference, a NaN rate or one beyond 0-100 gave numbers, or an IndexError; Python API audit,
    fifty-eighth session.)"""
    where = "ideal_table_ratio"
    raw = np.asarray(ideal, dtype=np.float64)
    e = np.sort(np.nan_to_num(raw, nan=0.0))
    n = e.size
    if n == 0 or not reference_mean_J > 0:
        raise ValueError("The 'ideal' parameter of ideal_table_ratio must hold at least one "
                         "energy, and 'reference_mean_J' must be > 0. Got "
                         f"{n} energies and {reference_mean_J!r} instead.")
    if not math.isfinite(reference_mean_J):
        raise ValueError(f"The 'reference_mean_J' parameter of {where} must be a finite number "
                         f"> 0, J. Got {reference_mean_J!r} instead.")
    if np.isinf(raw).any() or (raw < 0).any():
        raise ValueError(f"The 'ideal' parameter of {where} must hold finite energies >= 0, J "
                         f"(NaN: no route). Got {raw.tolist()!r} instead."
                         if n <= 8 else
                         f"The 'ideal' parameter of {where} must hold finite energies >= 0, J "
                         f"(NaN: no route). Got {int(np.isinf(raw).sum())} infinite and "
                         f"{int((raw < 0).sum())} negative of {n} instead.")
    f = np.asarray(failure_pct, dtype=np.float64)
    if not np.all((f >= 0.0) & (f <= 100.0)):
        raise ValueError(f"The 'failure_pct' parameter of {where} must be in [0, 100], %. Got "
                         f"{failure_pct!r} instead.")
    keep = np.maximum(n - np.floor(f / 100.0 * n + 1e-9).astype(np.int64), 1)
    prefix = np.concatenate([[0.0], np.cumsum(e)])
    return 1.0 - prefix[keep] / keep / reference_mean_J


def bound_study(records: Iterable[Mapping], *, route_variant: str = "gs-w",
                reference: str = "mppi", variants: Sequence[str] | None = None,
                confidence: float = 0.95) -> dict:
    """The GS+W bound against the measured variants of a benchmark store.

    Parameters
    ----------
    records : iterable of dict
        The store's records; they must hold ``route_variant``'s flights (with
        :data:`~windnav.experiments.nav_benchmark.ROUTE_FIELDS`) and ``reference``'s.
    route_variant, reference : str
        Variant labels.
    variants : sequence of str, optional
        The variants set against the bound (default: every variant flown on all of the route
        variant's scenarios, but the ``@power=`` counterfactuals, whose energies use another
        power curve).
    confidence : float
        Level of the paired intervals (``ideal_paired``, ``by_speed`` and each variant's
        ``paired``; default 0.95).

    Returns
    -------
    dict
        ``n`` (scenarios with a ``route_variant`` flight), ``no_route``, ``ideal_mean_J``,
        ``reference_mean_J`` (over the reference's successes), ``curve`` (``failure_pct`` 0-100
        and the ideal ``table_ratio`` at each, and ``table_ratio_with_slack``: the same with
        every ``E*`` times ``shortfall["slack"]``), ``shortfall`` (over the successes of
        ``variants``, the flown energy over ``E*``: ``n``, ``below`` (how many under 1),
        ``min_ratio``, ``p01_ratio``, ``median_ratio``, and ``slack = min(1, min_ratio)``),
        ``targets`` (:data:`TARGETS` with the ideal ratio at each failure rate, with and
        without the slack, and whether each reaches the target), ``ideal_paired``
        (``1 - E*/E_ref`` over the reference's successes: mean, std, n, interval;
        ``by_speed``), and per variant in
        ``variants`` (the route variant and the reference included): its ``failure_pct``,
        ``table_ratio``, ``paired`` reduction against the reference and ``below_bound`` (its
        successes with ``energy_J < E*``) of ``successes``.

    Raises
    ------
    ValueError
        When the records lack the route variant's planned routes or the reference's flights,
        ``variants`` names a variant they lack, or ``confidence`` is not in (0, 1).
    """
    where = "bound_study"
    _check_confidence(confidence, where)
    by_variant = records_by_variant(records)
    if variants is not None:
        # (a variant not in the records was left out of the result silently; Python API audit,
        # fifty-eighth session)
        if isinstance(variants, str):
            raise ValueError(f"The 'variants' parameter of {where} must be a sequence of "
                             f"variant labels. Got the string {variants!r} instead.")
        absent = [v for v in variants if v not in by_variant]
        if absent:
            raise ValueError(f"The 'variants' parameter of {where} must name variants of the "
                             f"records, among {sorted(by_variant)}. Got {absent} instead.")
    routes = by_variant.get(route_variant, {})
    if not any(r.get("route_energy_J") is not None for r in routes.values()):
        raise ValueError(f"The 'records' parameter of {where} must hold {route_variant!r} "
                         f"flights with planned routes (route_energy_J). Got variants "
                         f"{sorted(by_variant)} instead.")
    if reference not in by_variant:
        raise ValueError(f"The 'records' parameter of {where} must hold {reference!r} "
                         f"flights. Got variants {sorted(by_variant)} instead.")
    ideal = ideal_energy(routes)
    ref = {sid: r for sid, r in by_variant[reference].items() if sid in ideal}
    ref_e = _energies(ref.values(), "energy_J")
    ref_mean = float(np.mean(ref_e))
    e_star = list(ideal.values())
    grid = np.arange(0.0, 100.0 + 1e-9, 0.5)
    curve = ideal_table_ratio(e_star, ref_mean, grid)
    paired, speeds = [], []
    for sid, q in ref.items():
        if q["outcome"] == "success" and math.isfinite(ideal[sid]):
            paired.append(1.0 - ideal[sid] / float(q["energy_J"]))
            speeds.append(float(q["speed"]))
    ideal_paired = _describe(paired, confidence)
    ideal_paired["by_speed"] = {
        f"{s:g}": _describe([p for p, sp in zip(paired, speeds, strict=True) if sp == s],
                            confidence) for s in sorted(set(speeds))}
    if variants is None:
        variants = [v for v, recs in by_variant.items()
                    if "@power=" not in v and set(ideal) <= set(recs)]
    rows, all_ratios = {}, []
    for v in variants:
        # harness errors are no flights: left out of the rate, as the benchmark's table does
        # (they counted as failures here; audit, 2026-12-05)
        recs = {sid: r for sid, r in by_variant.get(v, {}).items()
                if sid in ideal and r["outcome"] != "error"}
        if not recs:
            continue
        ok = [r for r in recs.values() if r["outcome"] == "success"]
        e = _energies(ok, "energy_J")
        pairs = [1.0 - float(r["energy_J"]) / float(q["energy_J"])
                 for r, q in _both_succeeded(recs, ref)]
        # each success's energy over its scenario's E*: how far below the bound it flew
        ratios = [float(r["energy_J"]) / ideal[r["scenario_id"]] for r in ok
                  if math.isfinite(ideal[r["scenario_id"]]) and ideal[r["scenario_id"]] > 0]
        all_ratios += ratios
        rows[v] = {
            "flights": len(recs), "successes": len(ok),
            "failure_pct": 100.0 * (1.0 - len(ok) / len(recs)),
            "table_ratio": float(1.0 - np.mean(e) / ref_mean) if e else None,
            "paired": _describe(pairs, confidence),
            "below_bound": sum(x < 1.0 for x in ratios),
        }
    # the bound again with E* times the least ratio flown
    ratios = np.array(all_ratios)
    slack = float(min(1.0, ratios.min())) if ratios.size else 1.0
    shortfall = {"n": int(ratios.size), "below": int(np.sum(ratios < 1.0)),
                 "min_ratio": float(ratios.min()) if ratios.size else None,
                 "p01_ratio": float(np.quantile(ratios, 0.01)) if ratios.size else None,
                 "median_ratio": float(np.median(ratios)) if ratios.size else None,
                 "slack": slack}
    scaled = [x * slack for x in e_star]
    targets = []
    for who, f, t in TARGETS:
        best = float(ideal_table_ratio(e_star, ref_mean, f))
        wide = float(ideal_table_ratio(scaled, ref_mean, f))
        targets.append({"whose": who, "failure_pct": f, "table_ratio": t,
                        "ideal_table_ratio": best, "ideal_table_ratio_with_slack": wide,
                        "reachable": bool(best >= t), "reachable_with_slack": bool(wide >= t)})
    return {
        "route_variant": route_variant, "reference": reference, "n": len(ideal),
        "no_route": sum(not math.isfinite(x) for x in e_star),
        "ideal_mean_J": float(np.nanmean(e_star)), "reference_mean_J": ref_mean,
        "reference_successes": len(ref_e),
        "curve": {"failure_pct": grid.tolist(), "table_ratio": curve.tolist(),
                  "table_ratio_with_slack": ideal_table_ratio(scaled, ref_mean, grid).tolist()},
        "shortfall": shortfall,
        "targets": targets, "ideal_paired": ideal_paired, "variants": rows,
    }
