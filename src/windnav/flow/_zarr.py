"""Shared pieces of windnav's Zarr v3 files (private): format names, units, codecs, readers.

Used by :mod:`windnav.flow.solution_io` (one flow solution) and :mod:`windnav.flow.sweep_store`
(a sweep of many). Every chunk is compressed with a checksummed Zstandard frame, so a damaged
chunk is a read error rather than silently wrong numbers. A *deleted* chunk is no read error:
Zarr returns the array's fill value in its place. So every array is also recorded with a
SHA-256 digest of its decoded contents (:func:`digest`) when it is written, and compared when
it is read back. Readers turn any failure into a :class:`CorruptStoreError` naming the store
and the array.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Iterable

import numpy as np
import zarr
from zarr.codecs import ZstdCodec

FLOW_FORMAT = "windnav.flow-solution"
SWEEP_FORMAT = "windnav.wind-sweep"
FORMAT_VERSION = 1
FRAME = "world: x east, y north, z up; wind (u, v) blows toward (+x, +y)"
UNITS = {
    "x": "m",
    "y": "m",
    "mean_u": "m/s",
    "mean_v": "m/s",
    "frames_u": "m/s",
    "frames_v": "m/s",
    "t": "s",
    "wind": "m/s",
    "frames": "m/s",
    "speed": "m/s",
    "direction_deg": "deg",
    "seconds": "s",
}


class CorruptStoreError(ValueError):
    """A windnav Zarr store is damaged or incomplete: an attribute, an array or a chunk is
    missing or unreadable, or an array no longer matches the digest recorded when it was
    written. The message names the store and what is wrong."""


def compressor() -> ZstdCodec:
    # The checksum turns a damaged chunk into a read error instead of silently wrong numbers.
    return ZstdCodec(level=3, checksum=True)


def jsonable(config, name: str, where: str) -> dict:
    """``config`` as a dict of plain JSON values; a ValueError naming ``name`` otherwise."""
    try:
        return json.loads(json.dumps(dict(config or {}), allow_nan=False))
    except (TypeError, ValueError):
        raise ValueError(
            f"The {name!r} parameter of {where} must be a dict of JSON values (numbers, "
            f"strings, lists). Got {config!r} instead."
        ) from None


def grid_attrs(x: np.ndarray, y: np.ndarray) -> dict:
    """Shape, spacing (m) and origin (m) attributes of the cell-centred grid ``x``, ``y``."""
    dx = float(x[1] - x[0]) if x.size > 1 else math.nan
    dy = float(y[1] - y[0]) if y.size > 1 else math.nan
    return {
        "shape": [int(y.size), int(x.size)],
        "spacing": [dx, dy],
        "origin": [float(x[0]), float(y[0])],
        "origin_is": "centre of cell [0, 0] (row y[0], column x[0])",
    }


def write_array(group, name, data, chunks=None, fill_value=None):
    """Write ``data`` as array ``name`` of ``group`` (replacing it), with its units attribute."""
    data = np.asarray(data)
    arr = group.create_array(
        name,
        shape=data.shape,
        chunks=chunks or data.shape or (1,),
        dtype=data.dtype,
        compressors=compressor(),
        fill_value=fill_value,
        overwrite=True,
    )
    if name in UNITS:
        arr.attrs["units"] = UNITS[name]
    arr[...] = data
    return arr


def open_group(path, fmt: str, where: str, mode: str = "r"):
    """Open an existing windnav Zarr group (read-only by default).

    A ValueError naming ``path`` when nothing is there or it is another kind of store; a
    :class:`CorruptStoreError` when its metadata cannot be read.
    """
    path = os.fspath(path)
    if not os.path.exists(path):
        raise ValueError(f"{where}: there is no Zarr store at {path!r}.")
    try:
        group = zarr.open_group(path, mode=mode)
        found = group.attrs.get("windnav_format")
    except Exception as exc:
        raise CorruptStoreError(f"{where}: cannot open the Zarr store {path!r}: {exc}") from exc
    if found != fmt:
        raise ValueError(
            f"{where}: the Zarr store {path!r} is not a {fmt} (windnav_format={found!r})."
        )
    return group


def require_attr(group, name: str, path: str, where: str):
    """Attribute ``name`` of ``group``; a CorruptStoreError naming it and ``path`` if missing."""
    try:
        return group.attrs[name]
    except KeyError:
        raise CorruptStoreError(
            f"{where}: the Zarr store {path!r} is incomplete: its {group.path or 'root'!r} "
            f"group has no {name!r} attribute."
        ) from None


def read(group, name: str, path: str, where: str, index=Ellipsis) -> np.ndarray:
    """Array ``name`` of ``group`` (or its ``index``); a CorruptStoreError naming path and
    array when it cannot be read."""
    try:
        return np.asarray(group[name][index])
    except Exception as exc:
        raise CorruptStoreError(
            f"{where}: the Zarr store {path!r} has a missing or corrupt array {name!r}: {exc}"
        ) from exc


def digest(data: np.ndarray | None = None, *, shape=None, dtype=None,
           parts: Iterable[np.ndarray] = ()) -> str:
    """SHA-256 (hex) of an array's shape, dtype and little-endian C-order bytes.

    Give the array as ``data``, or its ``shape`` and ``dtype`` and its contents as ``parts``
    (consecutive slabs along the first axis, e.g. one frame at a time, so a large array need
    not be held in memory): both give the same digest.
    """
    if data is not None:
        data = np.asarray(data)
        shape, dtype, parts = data.shape, data.dtype, (data,)
    little = np.dtype(dtype).newbyteorder("<")  # unchanged for single-byte types
    h = hashlib.sha256(f"{little.str}|{tuple(int(s) for s in shape)}|".encode())
    for part in parts:
        h.update(np.ascontiguousarray(part, dtype=little).data)
    return h.hexdigest()


def digest_word(hexdigest: str) -> int:
    """The first 8 bytes of a :func:`digest` as an integer in [1, 2**63): what a sweep store
    keeps per case (0 is the fill value, "no digest recorded")."""
    return int(hexdigest[:16], 16) % (2**63 - 1) + 1
