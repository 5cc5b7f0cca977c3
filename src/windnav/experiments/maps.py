"""Maps for flow sweeps: procedural maps drawn reproducibly from one seed.

Map ``i`` of ``k`` is drawn from child ``i`` of ``numpy.random.SeedSequence(seed).spawn(k)``,
so it does not depend on how many maps are drawn after it, and each map records where it came
from (its ``source``), as a sweep store keeps it.
"""

from __future__ import annotations

import numpy as np

from windnav._validate import nonnegative_int, positive_int

__all__ = ["MAP_KINDS", "generated_maps"]

MAP_KINDS = ("training", "planning", "dense")
"""Generators of :mod:`windnav.city` (``windnav.city.<kind>_map``)."""


def generated_maps(k: int, kind: str = "training", *, seed: int = 0) -> list[tuple]:
    """``k`` procedural maps of ``windnav.city.<kind>_map``.

    Returns
    -------
    list of (name, source, City)
        ``name`` is ``"<kind>-<i>"``; ``source`` says how to draw the map again.
    """
    import windnav.city as city_pkg

    k = positive_int(k, "k", "generated_maps")
    # NumPy's "expected non-negative integer" before (Python API audit, fifty-eighth session)
    nonnegative_int(seed, "seed", "generated_maps")
    if kind not in MAP_KINDS:
        raise ValueError(f"The 'kind' parameter of generated_maps must be one of {MAP_KINDS}. "
                         f"Got {kind!r} instead.")
    make = getattr(city_pkg, f"{kind}_map")
    children = np.random.SeedSequence(seed).spawn(k)
    return [(f"{kind}-{i}", f"windnav.city.{kind}_map(SeedSequence({seed}).spawn({k})[{i}])",
             make(rng=np.random.default_rng(child))) for i, child in enumerate(children)]
