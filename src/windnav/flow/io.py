"""Compatibility alias: flow files moved to :mod:`windnav.flow.solution_io` (one solution:
:func:`save_flow`, :func:`load_flow`, :func:`flow_attrs`) and :mod:`windnav.flow.sweep_store`
(many: :class:`SweepStore`, :class:`SweepMap`, :func:`map_fingerprint`, :class:`VerifyReport`).
Both raise :class:`CorruptStoreError` (a ``ValueError``) for a damaged store.

New code imports from those modules, or from :mod:`windnav.flow`.
"""

from windnav.flow._zarr import FLOW_FORMAT, FORMAT_VERSION, FRAME, SWEEP_FORMAT, CorruptStoreError
from windnav.flow.solution_io import flow_attrs, load_flow, save_flow
from windnav.flow.sweep_store import (
    SweepMap,
    SweepMismatchError,
    SweepStore,
    VerifyReport,
    map_fingerprint,
)

__all__ = [
    "FLOW_FORMAT",
    "FORMAT_VERSION",
    "FRAME",
    "SWEEP_FORMAT",
    "CorruptStoreError",
    "SweepMap",
    "SweepMismatchError",
    "SweepStore",
    "VerifyReport",
    "flow_attrs",
    "load_flow",
    "map_fingerprint",
    "save_flow",
]
