"""Where an energy-aware variant's energy goes against MPPI: time and mean power, per pair.

The energy of a flight is its mean power times its time, so over the benchmark's scenarios
where neither variant failed the energy ratio of a variant to MPPI splits exactly into a time
ratio and a mean-power ratio (:func:`~windnav.experiments.nav_records.paired_pace`). A
variant that saves energy by flying slower must cut its mean power by more than it stretches
its time. How far it can cut is bounded: no flight draws less than the least power of the
curve, ``P_min``, so the power ratio of a pair is at least ``P_min / P_MPPI`` (MPPI's mean
power on that pair).

:func:`pace_study` gathers both ratios from a benchmark store for a variant and MPPI, with the
vehicle's own power curve and, where the store has them, the ``@power=crazyflie``
counterfactual (the thesis's Crazyflie curve shape scaled to the vehicle's hover power,
:data:`windnav.experiments.navigate.POWER_SHAPES`), and the thesis's own means from its
ablation table (:data:`THESIS`).
"""

from __future__ import annotations

from collections.abc import Iterable, Mapping

import numpy as np

from windnav.experiments.nav_records import _describe, paired_pace, records_by_variant
from windnav.experiments.thesis_nav import ABLATION

__all__ = ["THESIS", "pace_study"]

THESIS = {
    "time_ratio": ABLATION["ea-mppi-w"]["time_s"] / ABLATION["mppi"]["time_s"],
    "power_ratio": (ABLATION["ea-mppi-w"]["energy_kJ"] / ABLATION["ea-mppi-w"]["time_s"])
    / (ABLATION["mppi"]["energy_kJ"] / ABLATION["mppi"]["time_s"]),
}
"""EA-MPPI+W against MPPI in the thesis's ablation table, from its means (time to goal 37.94 s
against 28.29 s, energy 10.81 kJ against 13.61 kJ): 1.34 times the time at 0.59 times the mean
power (285 W against 481 W), a 20.6 % saving."""

CURVES = {"vehicle": ("", "", "vehicle"),
          "crazyflie": ("@power=crazyflie", "@power=crazyflie", "crazyflie"),
          "mission": ("@energy=mission", "", "vehicle")}
"""The comparisons: per name, the label suffixes of the variant and of the reference
(:func:`~windnav.experiments.nav_benchmark.parse_variant`) and the power curve both fly on:
the vehicle's curve, the Crazyflie shape (both variants on it), and the variant with the
mission's energy as ``J_E`` (:attr:`windnav.plan.PlannerConfig.energy_mode`) against the
reference as it is."""


def _min_power(shape: str, reference: str) -> float:
    """The least power (W) of the benchmark vehicle's curve (the Hummingbird's, or its
    counterfactual shape) over 0-20 m/s of airspeed."""
    from windnav.experiments.navigate import with_power_shape
    from windnav.plan import planner_config
    from windnav.vehicle import params

    config = planner_config(params("hummingbird"), reference.split("@")[0])
    if shape != "vehicle":
        config = with_power_shape(config, shape)
    return float(np.min(config.power(np.linspace(0.0, 20.0, 2001))))


def pace_study(records: Iterable[Mapping], variant: str = "ea-mppi-w",
               reference: str = "mppi", *, confidence: float = 0.95) -> dict:
    """Time and mean-power ratios of ``variant`` against ``reference`` per pair, for each
    comparison of :data:`CURVES` (power curve, energy cost) whose two variants the ``records``
    hold.

    Returns
    -------
    dict
        ``variant``, ``reference``, ``thesis`` (:data:`THESIS`) and ``curves``: per curve
        name, the two labels, ``pairs`` (:func:`~windnav.experiments.nav_records.paired_pace`),
        ``time_ratio``, ``power_ratio`` and ``energy_ratio`` (mean, std, n, t interval),
        ``shape`` (the power curve both fly on), ``min_power_W`` (the curve's least power)
        and ``power_floor``: ``min_power_W`` over the
        reference's mean power, averaged over the pairs (no pair's power ratio can be lower
        than its own floor).

    Raises
    ------
    ValueError
        When no curve has records of both variants, ``variant`` is ``reference`` (or either is
        not a label), or ``confidence`` is not in (0, 1).
    """
    from windnav.experiments.nav_bound import _check_confidence
    from windnav.experiments.nav_cases import check_pair

    where = "pace_study"
    # (the reference against itself, and confidence 1 or NaN, were accepted: ratios of 1 and
    # intervals of no level; Python API audit, fifty-eighth session)
    check_pair(variant, reference, where)
    _check_confidence(confidence, where)
    by_variant = records_by_variant(records)
    curves = {}
    for name, (suffix, ref_suffix, shape) in CURVES.items():
        mine, ref = variant + suffix, reference + ref_suffix
        if mine not in by_variant or ref not in by_variant:
            continue
        pairs = paired_pace(by_variant[mine], by_variant[ref])
        t, p = np.asarray(pairs["time_ratio"]), np.asarray(pairs["power_ratio"])
        p_min = _min_power(shape, reference)
        floors = p_min / np.asarray(pairs["reference_power_W"])
        curves[name] = {
            "variant": mine, "reference": ref, "shape": shape, "pairs": pairs,
            "time_ratio": _describe(t.tolist(), confidence),
            "power_ratio": _describe(p.tolist(), confidence),
            "energy_ratio": _describe((t * p).tolist(), confidence),
            "min_power_W": p_min,
            "power_floor": float(floors.mean()) if floors.size else None,
        }
    if not curves:
        labels = sorted({variant + c[0] for c in CURVES.values()}
                        | {reference + c[1] for c in CURVES.values()})
        raise ValueError(f"The 'records' parameter of pace_study must hold flights of "
                         f"{variant!r} and {reference!r} (or of their @power=crazyflie "
                         f"counterfactuals, {labels}). Got variants "
                         f"{sorted(by_variant)} instead.")
    return {"variant": variant, "reference": reference, "thesis": dict(THESIS),
            "curves": curves}
