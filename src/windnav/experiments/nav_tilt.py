"""The tilt-cap study: the thesis's four variants flown with more authority.

The closed loop clips the planner's horizontal command to ``g tan(tilt_max)`` (55 deg by
default, :func:`~windnav.experiments.navigate.navigate`), and the planner's per-axis bound is
the box inside that disk, ``a_max = g tan(tilt_max) / sqrt 2``: 9.9 m/s^2 at 55 deg, 19.1 at
70, 32.6 at 78. The Hummingbird's rotors would allow far more (70 m/s^2 at full thrust); 55 deg
is this project's choice, to keep the vehicle inside the airspeeds its power curve covers. The
thesis gives no bound, but its table's mean commanded accelerations (14-21 m/s^2) are 3-5 x
ours, so its vehicle was allowed much more.

This study sets the four thesis variants (MPPI, MPPI+W, EA-MPPI, EA-MPPI+W; their costs and
hyperparameters unchanged) flown at each tilt cap (the benchmark's ``@tilt=`` labels,
:func:`~windnav.experiments.nav_benchmark.parse_variant`) against one another on the same
scenarios: per cap, each variant's failure rate and its kinds, mean commanded acceleration and
time to goal, the flights that left the airspeed envelope, and the energy of each variant
against MPPI *at the same cap* (paired reduction, table ratio, and the pace split into time and
mean power). A counterfactual of the vehicle, not a change of the thesis's variants: the
ablation table keeps 55 deg.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence

from windnav.experiments.nav_records import FAILURES, benchmark_table
from windnav.experiments.navigate import TILT_LIMIT_DEG, TILT_MAX_DEG, tilt_accel_cap
from windnav.experiments.thesis_nav import ABLATION

__all__ = ["THESIS_ROWS", "TILTS", "check_tilts", "tilt_label", "tilt_study"]

TILTS = (55.0, 70.0, 78.0)
"""The caps of the study, degrees."""

VARIANTS = ("mppi", "mppi-w", "ea-mppi", "ea-mppi-w")
"""The thesis's four variants."""

THESIS_ROWS = {v: {k: ABLATION[v][k] for k in ("failure_pct", "cmd_accel", "time_s",
                                                 "energy_kJ")} for v in VARIANTS}
"""The thesis's ablation table, the columns the study draws (:data:`~windnav.experiments.
thesis_nav.ABLATION`; its vehicle: energies in kJ, not comparable with ours)."""


def tilt_label(variant: str, tilt: float) -> str:
    """The benchmark label of ``variant`` flown with the tilt cap ``tilt`` (degrees): the variant
    itself at ``navigate``'s default cap (the ablation table's, 55 deg), else
    ``"variant@tilt=70"``. ``tilt`` must be in (0, ``TILT_LIMIT_DEG``) (NaN gave
    ``"variant@tilt=nan"``; Python API audit, fifty-eighth session)."""
    from windnav.experiments.nav_benchmark import number_label

    try:
        ok = not isinstance(tilt, (bool, str)) and 0.0 < float(tilt) < TILT_LIMIT_DEG
    except (TypeError, ValueError):
        ok = False
    if not ok:
        raise ValueError(f"The 'tilt' parameter of tilt_label must be a tilt cap in "
                         f"(0, {TILT_LIMIT_DEG:g}) degrees. Got {tilt!r} instead.")
    return variant if float(tilt) == TILT_MAX_DEG else f"{variant}@tilt={number_label(tilt)}"


def check_tilts(tilts: Sequence[float], param: str = "tilts",
                where: str = "check_tilts") -> list[float]:
    """The caps ``tilts`` (degrees), sorted; a ValueError naming ``param`` of ``where`` unless
    they are distinct, at least one, each in (0, ``TILT_LIMIT_DEG``) (80)."""
    tilts = sorted(float(t) for t in tilts)
    if (not tilts or any(not 0.0 < t < TILT_LIMIT_DEG for t in tilts)
            or len(set(tilts)) != len(tilts)):
        raise ValueError(f"The '{param}' parameter of {where} must be distinct tilt caps in "
                         f"(0, {TILT_LIMIT_DEG:g}) degrees. Got {tilts!r} instead.")
    return tilts


def tilt_study(records: Iterable[Mapping], tilts: Sequence[float] | None = None, *,
               variants: Sequence[str] = VARIANTS) -> dict:
    """The four thesis variants at each tilt cap, each cap's energies against its own MPPI.

    Parameters
    ----------
    records : iterable of dict
        Benchmark records holding, for every cap, the flights of every variant
        (:func:`tilt_label`).
    tilts : sequence of float, optional
        The caps, degrees (default :data:`TILTS`).
    variants : sequence of str
        The variants compared; the first is the reference (MPPI).

    Returns
    -------
    dict
        ``tilts`` (sorted), ``variants``, ``scenarios`` (the ids flown by every label; only
        they count), ``a_max`` {tilt: per-axis bound, m/s^2}, ``thesis`` (:data:`THESIS_ROWS`)
        and ``rows`` {tilt: {variant: ``label``, ``flights``, ``failure_pct`` {``value``,
        ``ci95``}, ``failures`` {outcome: %}, ``cmd_accel``, ``time_s``, ``energy_kJ`` (means
        over successes), ``outside_envelope`` (flights above the trusted airspeed, or None for
        records without the field), and for all but the reference ``paired`` {``mean``,
        ``ci95``, ``n``, ``less``}, ``table_ratio``, ``time_ratio``, ``power_ratio``}}
        (reductions and ratios as fractions).

    Raises
    ------
    ValueError
        No scenario flown by every label, a cap outside (0, 80), or no ``variants``.
    """
    tilts = check_tilts(TILTS if tilts is None else tilts, "tilts", "tilt_study")
    # ([] raised "set.intersection() needs an argument"; Python API audit, fifty-eighth session)
    if (isinstance(variants, str) or not variants
            or not all(isinstance(v, str) and v for v in variants)
            or len(set(variants)) != len(variants)):
        raise ValueError(f"The 'variants' parameter of tilt_study must be distinct variant "
                         f"labels, at least one (the first the reference). Got {variants!r} "
                         "instead.")
    labels = {t: {v: tilt_label(v, t) for v in variants} for t in tilts}
    wanted = {lb for row in labels.values() for lb in row.values()}
    records = [r for r in records if r["variant"] in wanted]
    flown = {}
    for r in records:
        flown.setdefault(r["variant"], set()).add(r["scenario_id"])
    missing = sorted(wanted - set(flown))
    if missing:
        raise ValueError(f"The 'records' parameter of tilt_study must hold flights of every "
                         f"label. Missing: {missing}.")
    common = set.intersection(*flown.values())
    if not common:
        raise ValueError("The 'records' parameter of tilt_study must hold scenarios flown by "
                         "every label. Got none in common.")
    records = [r for r in records if r["scenario_id"] in common]
    rows = {}
    for t in tilts:
        ref = labels[t][variants[0]]
        table = benchmark_table(records, variants=list(labels[t].values()), reference=ref,
                                n_boot=500)
        rows[t] = {}
        for v, lb in labels[t].items():
            row = table["rows"][lb]
            m = row["metrics"]
            env = row.get("envelope") or None
            out = {"label": lb, "flights": row["flights"], "failure_pct": row["failure_pct"],
                   "failures": {k: row["failures"][k]["pct"] for k in FAILURES},
                   "cmd_accel": m["mean_cmd_accel"]["mean"], "time_s": m["time_s"]["mean"],
                   "energy_kJ": m["energy_kJ"]["mean"],
                   "outside_envelope": None if env is None else env["outside"]}
            if lb != ref:
                vs = row["vs_reference"]["energy_J"]
                pr = vs["paired_reduction"]
                out.update(paired={"mean": pr["mean"], "ci95": pr["ci95"], "n": pr["n"],
                                   "less": pr["less"],
                                   **({"ci95_note": pr["ci95_note"]} if "ci95_note" in pr
                                      else {})},
                           table_ratio=vs["table_ratio"]["value"],
                           time_ratio=row["vs_reference"]["pace"]["time_ratio"]["mean"],
                           power_ratio=row["vs_reference"]["pace"]["power_ratio"]["mean"])
            rows[t][v] = out
    return {"tilts": tilts, "variants": list(variants), "scenarios": len(common),
            "a_max": {t: tilt_accel_cap(t) / math.sqrt(2.0) for t in tilts},
            "thesis": THESIS_ROWS, "rows": rows}
