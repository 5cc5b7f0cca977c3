"""Shared pieces of windnav's Zarr v3 files (private): format names, units, codecs, readers.

Used by :mod:`windnav.flow.solution_io` (one flow solution) and :mod:`windnav.flow.sweep_store`
(a sweep of many). Every chunk is compressed with a checksummed Zstandard frame, so a damaged
chunk is a read error rather than silently wrong numbers; readers turn any failure into a
``ValueError`` naming the store and the array.
"""

from __future__ import annotations

import json
import math
import os

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


def open_group(path, fmt: str, where: str):
    """Open an existing windnav Zarr group read-only; any failure is a ValueError naming path."""
    path = os.fspath(path)
    try:
        group = zarr.open_group(path, mode="r")
        found = group.attrs.get("windnav_format")
    except Exception as exc:
        raise ValueError(f"{where}: cannot open the Zarr store {path!r}: {exc}") from exc
    if found != fmt:
        raise ValueError(
            f"{where}: the Zarr store {path!r} is not a {fmt} (windnav_format={found!r})."
        )
    return group


def read(group, name: str, path: str, where: str, index=Ellipsis) -> np.ndarray:
    """Array ``name`` of ``group`` (or its ``index``); a ValueError naming path and array."""
    try:
        return np.asarray(group[name][index])
    except Exception as exc:
        raise ValueError(
            f"{where}: the Zarr store {path!r} has a missing or corrupt array {name!r}: {exc}"
        ) from exc
