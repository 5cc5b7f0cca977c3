"""A percentile bootstrap of a ratio of pooled means, resampling clusters: defined once.

Both the navigation table's energy ratio (clusters: the suite's winds) and the decoder's
improvement over a baseline (clusters: the evaluation's (map, inlet) slots) compare two pooled
means, ``1 - (a / b) / (c / d)``, where ``a / b`` is one method's sum over its counted items
(flights, cells) divided by their number and ``c / d`` the other's, both over the same
clusters. Items within a cluster share its flow, so the clusters, not the items, are resampled,
and both methods' items of a drawn cluster are taken together (paired).

Where the clusters' counts are alike between the two methods (the same flights, the same
cells), every resample's ratio lies between the clusters' own ratios, so with ``G`` clusters
the interval is at most their range, which covers the middle of their distribution with
probability ``1 - 2 ** (1 - G)``: none is given below :data:`MIN_BOOTSTRAP_CLUSTERS`. (With
counts far from proportional a resample can leave that range.) Above it
the interval still covers the truth less often than it says until about
:data:`COVERED_BOOTSTRAP_CLUSTERS` (measured on the navigation table's winds:
``docs/navigation.md``, "How far to trust the intervals").
"""

from __future__ import annotations

import numpy as np

__all__ = ["COVERAGE_NOTE", "COVERED_BOOTSTRAP_CLUSTERS", "MIN_BOOTSTRAP_CLUSTERS",
           "pooled_ratio", "pooled_ratio_interval"]

MIN_BOOTSTRAP_CLUSTERS = 6
"""Fewest clusters an interval is given for (the module doc). With 2 winds the navigation
table's "95 %" interval covered the truth in 26 % of simulated suites, with 3 in 46 %."""

COVERED_BOOTSTRAP_CLUSTERS = 64
"""Fewest clusters at which the navigation table's interval covered the truth about as often
as it says: 90-94.5 % of simulated suites with 64 winds, but 71 % with 6 and 82 % with 16
(statistics audit, thirty-ninth session). Below it an interval is called approximate."""

COVERAGE_NOTE = ("a bootstrap over the winds covered the truth in 71 % (6 winds) to 82 % (16) "
                 f"of simulated suites, 90-94.5 % only at {COVERED_BOOTSTRAP_CLUSTERS}")
"""The measured coverage below :data:`COVERED_BOOTSTRAP_CLUSTERS`, as the notes say it."""


def pooled_ratio(sums) -> float:
    """``1 - (a / b) / (c / d)`` over all clusters: the sums of the columns of ``sums``
    (G, 4), as :func:`pooled_ratio_interval` resamples it."""
    s = np.asarray(sums, dtype=np.float64).reshape(-1, 4)
    return float(1.0 - (s[:, 0].sum() / s[:, 1].sum()) / (s[:, 2].sum() / s[:, 3].sum()))


def pooled_ratio_interval(sums, *, n_boot: int, rng: np.random.Generator,
                          confidence: float = 0.95) -> list[float] | None:
    """The percentile interval of ``1 - (a / b) / (c / d)`` over ``n_boot`` resamples of the
    clusters (rows of ``sums``, drawn with replacement, each resample as many as there are).

    Parameters
    ----------
    sums : array_like of shape (G, 4)
        Per cluster ``[a, b, c, d]``: the first method's sum and count, the second's.
    n_boot : int
        Resamples (> 0).
    rng : numpy.random.Generator
        Their source (one ``multinomial`` draw of shape ``(n_boot, G)``).
    confidence : float
        The interval's level.

    Returns
    -------
    list of two floats, or None
        The bounds; None where no resample has a ratio (no count of either method).
    """
    s = np.asarray(sums, dtype=np.float64).reshape(-1, 4)
    g = s.shape[0]
    w = rng.multinomial(g, np.full(g, 1.0 / g), size=n_boot)
    t = w @ s  # (n_boot, 4): each resample's sums and counts
    with np.errstate(invalid="ignore", divide="ignore"):
        boot = 1.0 - (t[:, 0] / t[:, 1]) / (t[:, 2] / t[:, 3])
    boot = boot[np.isfinite(boot)]  # a resample without an item of either method: no ratio
    if boot.size == 0:
        return None
    a = 0.5 * (1.0 - confidence)
    return [float(np.quantile(boot, a)), float(np.quantile(boot, 1.0 - a))]
