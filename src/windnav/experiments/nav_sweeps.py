"""The thesis's Q_E and H sweeps: EA-MPPI+W's energy reduction against MPPI as its energy weight
``Q_E`` or its wind window ``H`` changes (thesis ch. 5: optimum ``Q_E`` 3-4; ``H`` from 0 to
infinity, flat beyond about 60 m).

Each value is a variant label of the benchmark (:func:`~windnav.experiments.nav_benchmark.
parse_variant`, e.g. ``"ea-mppi-w@qe=2"``), flown by :func:`~windnav.experiments.nav_benchmark.
run_benchmark` into an ordinary benchmark store beside MPPI, so a sweep shares its winds (one per
map and inlet) with every other variant flown in the same run, resumes after a kill, and its
flights replay by id. Values that are a thesis variant are flown under that variant's name and
shared with the ablation table: ``Q_E = 0`` with wind is MPPI+W, ``Q_E = 5`` and ``H = inf`` are
EA-MPPI+W itself.

The result (:func:`sweep_table`) is, per value, the paired energy reduction against MPPI (mean
over the scenarios where neither failed of ``1 - E/E_MPPI``, airspeed-model energy, with its
95 % t interval), the same per inlet speed, the table ratio and the failure rate: the numbers
behind :func:`windnav.viz.nav_sweeps.plot_sweep`.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Mapping, Sequence

__all__ = ["SWEEPS", "sweep_labels", "sweep_table"]

SWEEPS = {
    "qe": {"name": "Q_E", "unit": "", "values": (0.0, 0.5, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0)},
    "h": {"name": "H", "unit": "m", "values": (0.0, 25.0, 50.0, 100.0, 200.0, math.inf)},
}
"""The two sweeps of EA-MPPI+W (``Q_E = 5``, ``H = inf``), and their default values (the thesis
sweeps ``Q_E`` over 0-6; ``H = 0`` is no wind, ``inf`` the whole map)."""

BASE = "ea-mppi-w"
REFERENCE = "mppi"


def sweep_labels(kind: str, values: Sequence[float] | None = None) -> dict[float, str]:
    """The variant label flown for each value of a sweep.

    Parameters
    ----------
    kind : {"qe", "h"}
        The parameter swept (:data:`SWEEPS`).
    values : sequence of float, optional
        Its values (default the sweep's own); ``Q_E`` >= 0 finite, ``H`` >= 0 or ``inf``.

    Returns
    -------
    dict of float to str
        ``value -> label``: ``"ea-mppi-w@qe=2"``, or the thesis variant that is that value
        (``Q_E = 0``: ``"mppi-w"``; ``Q_E = 5``, ``H = inf``: ``"ea-mppi-w"``).
    """
    from windnav.experiments.nav_benchmark import number_label
    from windnav.plan import VARIANTS

    where = "sweep_labels"
    if kind not in SWEEPS:
        raise ValueError(f"The 'kind' parameter of {where} must be one of {list(SWEEPS)}. Got "
                         f"{kind!r} instead.")
    if values is None:
        values = SWEEPS[kind]["values"]
    try:
        values = [float(v) for v in values]
    except (TypeError, ValueError):
        raise ValueError(f"The 'values' parameter of {where} must be numbers. Got {values!r} "
                         "instead.") from None
    bad = [v for v in values if not v >= 0.0 or (kind == "qe" and not math.isfinite(v))]
    if bad or not values or len(set(values)) != len(values):
        # ("(H finite, H may be inf)" for the H sweep before: CLI audit)
        finite = "finite" if kind == "qe" else "finite or inf"
        raise ValueError(f"The 'values' parameter of {where} must be distinct numbers >= 0, at "
                         f"least one ({SWEEPS[kind]['name']}: {finite}). Got {values!r} "
                         "instead.")
    base = VARIANTS[BASE]
    out = {}
    for v in sorted(values):
        if (kind == "qe" and v == base.energy_weight) or (kind == "h" and v == math.inf):
            label = BASE
        elif kind == "qe" and v == 0.0:
            label = "mppi-w"
        else:
            label = f"{BASE}@{kind}={number_label(v)}"
        out[v] = label
    return out


def sweep_table(records: Iterable[Mapping], labels: Mapping[float, str], *,
                reference: str = REFERENCE) -> dict:
    """Per value of a sweep: the energy reduction against the reference and the failure rate.

    Parameters
    ----------
    records : iterable of dict
        Benchmark records (the store's), with the reference's and the sweep's labels.
    labels : dict of float to str
        :func:`sweep_labels`.
    reference : str
        The variant the energy is compared with (MPPI).

    Returns
    -------
    dict
        ``reference``, ``values`` (sorted), ``speeds`` (the inlet speeds, m/s, as strings), and
        ``rows``: per value its ``label``, ``flights``, ``failure_pct``, ``paired_reduction``
        (``mean``, ``ci95``, ``n``, fractions), ``by_speed`` {speed: ``mean``, ``std``, ``n``}
        and ``table_ratio`` (``value``, ``ci95``), airspeed-model energy.

    Raises
    ------
    ValueError
        Records without the reference's flights, or ``labels`` empty or naming no variant
        the records hold (a value whose label is not flown is left out of the rows).
    """
    from windnav.experiments.nav_records import benchmark_table

    where = "sweep_table"
    records = list(records)
    present = {r["variant"] for r in records}
    if reference not in present:
        raise ValueError(f"The 'records' parameter of {where} must hold flights of the "
                         f"reference {reference!r}. Got variants {sorted(present)} instead.")
    # (an empty sweep, or one the records hold none of, gave a table without rows; Python API
    # audit, fifty-eighth session)
    if not isinstance(labels, Mapping) or not labels:
        raise ValueError(f"The 'labels' parameter of {where} must be a non-empty dict of value "
                         f"to variant label (sweep_labels). Got {labels!r} instead.")
    if not any(lb in present and lb != reference for lb in labels.values()):
        raise ValueError(f"The 'labels' parameter of {where} must name at least one variant "
                         f"of the records other than the reference, among {sorted(present)}. "
                         f"Got {sorted(map(str, set(labels.values())))} instead.")
    flown = [lb for lb in dict.fromkeys(labels.values()) if lb in present and lb != reference]
    table = benchmark_table(records, variants=[reference, *flown], reference=reference,
                            n_boot=500)
    rows, speeds = {}, set()
    for value, label in sorted(labels.items()):
        if label not in flown:
            continue
        row = table["rows"][label]
        vs = row["vs_reference"]["energy_J"]
        pr = vs["paired_reduction"]
        speeds |= set(pr["by_speed"])
        rows[value] = {"label": label, "flights": row["flights"],
                       "failure_pct": row["failure_pct"]["value"],
                       "paired_reduction": {k: pr[k] for k in ("mean", "ci95", "n", "ci95_note")
                                            if k in pr},
                       "by_speed": pr["by_speed"],
                       "table_ratio": {k: vs["table_ratio"][k] for k in ("value", "ci95",
                                                                         "ci95_note")
                                       if k in vs["table_ratio"]}}
    ref_row = table["rows"][reference]
    return {"reference": reference, "reference_failure_pct": ref_row["failure_pct"]["value"],
            "reference_flights": ref_row["flights"], "values": sorted(rows),
            "speeds": sorted(speeds, key=float), "rows": rows}
