"""One flow solution on disk, in Zarr v3 (:func:`save_flow` / :func:`load_flow`).

The group is self-describing through its attributes (units, frame, spacing, origin and the
generating config: speed, direction_deg, dx, dt, steps, seed, map source)::

    x (nx,) m, y (ny,) m          cell-centre coordinates, world frame
    solid (ny, nx) bool           building cells
    mean_u, mean_v (ny, nx) m/s   time-averaged wind, world frame
    frames_u, frames_v (T, ny, nx) m/s, one chunk per frame   (only when recorded)
    t (T,) s, frame times from the start of averaging        (only when recorded)
    attrs["solution"]: speed m/s, direction_deg, dx m, dt s, and the averaging and closure
        diagnostics (flow_throughs_spinup, flow_throughs_average, half_window_difference,
        smagorinsky, filter_width m, viscosity m^2/s)          (the FlowSolution's scalars)

    attrs["checksums"]: {array name: SHA-256 of its shape, dtype and bytes}, for every array

Chunks are compressed with a checksummed Zstandard frame (a damaged chunk is a read error), and
every array's digest is recorded when it is written and compared when it is loaded (a deleted
chunk, which Zarr would read back as its fill value, and a deleted array are caught too). So a
damaged file is a :class:`~windnav.flow._zarr.CorruptStoreError` (a ``ValueError``) naming the
store and the array, never silently wrong numbers. Files written before the digests were
recorded load with a warning that they cannot be verified. Many simulations in one store:
:mod:`windnav.flow.sweep_store`.
"""

from __future__ import annotations

import os
import warnings
from pathlib import Path

import numpy as np
import zarr

from windnav.flow._zarr import (
    FLOW_FORMAT,
    FORMAT_VERSION,
    FRAME,
    UNITS,
    CorruptStoreError,
    digest,
    grid_attrs,
    jsonable,
    open_group,
    read,
    write_array,
)
from windnav.flow.solver import DIAGNOSTICS

__all__ = ["CorruptStoreError", "flow_attrs", "load_flow", "save_flow"]


def save_flow(solution, path, config: dict | None = None) -> None:
    """Write a flow solution to a Zarr v3 group at ``path`` (replacing a flow solution there).

    Parameters
    ----------
    solution : FlowSolution
        ``x`` (nx,), ``y`` (ny,) in m; ``solid`` (ny, nx) bool; ``mean_u``, ``mean_v``
        (ny, nx) in m/s; ``frames_u``, ``frames_v`` (T, ny, nx) in m/s and ``t`` (T,) in s,
        or None when no frames were recorded; ``speed`` m/s, ``direction_deg``, ``dx`` m and
        ``dt`` s.
    path : str or os.PathLike
        Directory of the store (conventionally ending in ``.zarr``).
    config : dict, optional
        The generating config, stored as the ``config`` attribute: e.g. speed (m/s),
        direction_deg, dx (m), dt (s), spinup_steps, steps, record_every, seed, map_source.
        JSON values only.

    Raises
    ------
    ValueError
        On a solution of inconsistent shapes, or a ``path`` that is a file or a folder holding
        anything but a flow solution (it would be emptied: refused, as
        :meth:`~windnav.flow.sweep_store.SweepStore.create` refuses).
    """
    config = jsonable(config, "config", "save_flow")
    missing = [a for a in ("x", "y", "solid", "mean_u", "mean_v") if not hasattr(solution, a)]
    if missing:  # an AttributeError before
        raise ValueError(f"The 'solution' parameter of save_flow must be a FlowSolution. Got "
                         f"{type(solution).__name__} (without {missing}) instead.")
    target = Path(path)
    if target.exists() and (not target.is_dir() or any(target.iterdir())):
        try:
            open_group(target, FLOW_FORMAT, "save_flow")
        except ValueError:  # zarr's mode "w" deleted a folder's files, whatever they were
            raise ValueError(f"The 'path' parameter of save_flow must be a new or empty folder, "
                             f"or a flow solution to replace. Got {str(target)!r} instead, "
                             "which holds something else.") from None
    x = np.asarray(solution.x, dtype=np.float64)
    y = np.asarray(solution.y, dtype=np.float64)
    shape = (y.size, x.size)
    fields = {
        "solid": np.asarray(solution.solid, dtype=bool),
        "mean_u": np.asarray(solution.mean_u, dtype=np.float64),
        "mean_v": np.asarray(solution.mean_v, dtype=np.float64),
    }
    for name, value in fields.items():
        if value.shape != shape:
            raise ValueError(
                f"The 'solution' parameter of save_flow must have {name} of shape {shape} "
                f"(ny, nx). Got shape {value.shape} instead."
            )
    for name, c in (("x", x), ("y", y)):  # a store that loaded and failed later before
        if c.ndim != 1 or c.size < 2 or not np.all(np.isfinite(c)) or not np.all(np.diff(c) > 0):
            raise ValueError(f"The 'solution' parameter of save_flow must have {name} of at "
                             "least two finite, increasing cell centres, m. Got "
                             f"{np.array2string(c.ravel()[:6], precision=3)} "
                             f"(shape {c.shape}) instead.")
    arrays = {"x": x, "y": y, **fields}
    frames_u = getattr(solution, "frames_u", None)
    frames_v = getattr(solution, "frames_v", None)
    if (frames_u is None) != (frames_v is None):  # one was silently dropped
        raise ValueError("The 'solution' parameter of save_flow must have both frames_u and "
                         "frames_v, or neither. Got one of them instead.")
    if frames_u is not None and frames_v is not None:
        fu = np.asarray(frames_u, dtype=np.float64)
        fv = np.asarray(frames_v, dtype=np.float64)
        if fu.ndim != 3 or fu.shape[1:] != shape or fv.shape != fu.shape:
            raise ValueError(
                f"The 'solution' parameter of save_flow must have frames_u and frames_v of shape "
                f"(T, {shape[0]}, {shape[1]}). Got {fu.shape} and {fv.shape} instead."
            )
        arrays.update(frames_u=fu, frames_v=fv)
        times = getattr(solution, "t", None)
        if times is None:  # load_flow needs a time per frame: saved, the file did not load
            raise ValueError(f"The 'solution' parameter of save_flow must have the times 't' of "
                             f"its {fu.shape[0]} frames. Got t = None instead.")
        arrays["t"] = np.asarray(times, dtype=np.float64)
        if arrays["t"].shape != (fu.shape[0],):
            raise ValueError(f"The 'solution' parameter of save_flow must have one time per "
                             f"frame ({fu.shape[0]}). Got t of shape {arrays['t'].shape} "
                             "instead.")
    group = zarr.open_group(os.fspath(path), mode="w")
    group.attrs.update(
        {
            "windnav_format": FLOW_FORMAT,
            "format_version": FORMAT_VERSION,
            "frame": FRAME,
            "units": {k: UNITS[k] for k in ("x", "y", "mean_u", "mean_v")},
            **grid_attrs(x, y),
            "solution": {
                k: float(getattr(solution, k))
                for k in ("speed", "direction_deg", "dx", "dt", *DIAGNOSTICS)
                if hasattr(solution, k)
            },
            "config": config,
            "checksums": {name: digest(value) for name, value in arrays.items()},
            "checksum": "SHA-256 of the array's dtype, shape and little-endian C-order bytes",
        }
    )
    for name, value in arrays.items():
        chunks = (1, *shape) if name in ("frames_u", "frames_v") else None  # one per frame
        write_array(group, name, value, chunks=chunks)


def flow_attrs(path) -> dict:
    """Attributes of a stored flow solution: units, frame, spacing, origin, shape and config."""
    return dict(open_group(path, FLOW_FORMAT, "flow_attrs").attrs)


def load_flow(path):
    """Read a flow solution written by :func:`save_flow`.

    Parameters
    ----------
    path : str or os.PathLike
        The store directory.

    Returns
    -------
    FlowSolution
        With the same arrays as were saved (``frames_u``/``frames_v`` None when none were).
        The generating config is in :func:`flow_attrs`.

    Raises
    ------
    CorruptStoreError
        (a ValueError) Naming ``path`` and the array when an array is missing, unreadable or
        differs from the digest recorded when it was saved (a deleted or damaged chunk).
    ValueError
        Naming ``path`` when there is no store, or it is not a flow solution.

    Warns
    -----
    UserWarning
        When the file was written before digests were recorded: it loads, unverified.
    """
    path = os.fspath(path)
    where = "load_flow"
    group = open_group(path, FLOW_FORMAT, where)
    from windnav.flow.solver import FlowSolution

    sums = group.attrs.get("checksums")
    if sums is not None and not isinstance(sums, dict):  # an AttributeError below before
        raise CorruptStoreError(f"{where}: the Zarr store {path!r} has a corrupt 'checksums' "
                                f"attribute (a {type(sums).__name__}, not a table).")
    if sums is None:
        warnings.warn(
            f"load_flow: the Zarr store {path!r} was written without checksums (by an older "
            "windnav); its arrays cannot be verified. Save it again to record them.",
            stacklevel=2,
        )
        present = set(group.array_keys())
    else:
        present = set(sums)  # every array saved must be there
    data = {n: read(group, n, path, where) for n in ("x", "y", "solid", "mean_u", "mean_v")}
    for n in ("frames_u", "frames_v", "t"):  # absent when no frames were recorded
        data[n] = read(group, n, path, where) if n in present else None
    for name, value in data.items():
        if sums is not None and value is not None and digest(value) != sums.get(name):
            raise CorruptStoreError(
                f"{where}: the array {name!r} of the Zarr store {path!r} does not match the "
                "checksum recorded when it was saved (a chunk is missing or damaged)."
            )
    grid = (np.shape(data["y"])[0], np.shape(data["x"])[0]) if np.ndim(data["x"]) == 1 \
        and np.ndim(data["y"]) == 1 else None
    frames = data["frames_u"]
    want = {"solid": grid, "mean_u": grid, "mean_v": grid}
    if frames is not None and grid is not None:
        want |= {"frames_u": (np.shape(frames)[0], *grid), "frames_v": (np.shape(frames)[0], *grid),
                 "t": (np.shape(frames)[0],)}
    for name, shape in want.items():  # unverified stores (no checksums) loaded a (29, 30)
        if shape is None or np.shape(data[name]) != shape:  # mean on a (30, 30) grid
            raise CorruptStoreError(
                f"{where}: the array {name!r} of the Zarr store {path!r} has shape "
                f"{np.shape(data[name])} where the grid (y {np.shape(data['y'])}, x "
                f"{np.shape(data['x'])}) needs {shape}.")
    try:
        scalars = {k: float(v) for k, v in group.attrs["solution"].items()}
        return FlowSolution(**data, **scalars)
    except Exception as exc:
        raise CorruptStoreError(f"{where}: the Zarr store {path!r} is incomplete: {exc}") from exc
