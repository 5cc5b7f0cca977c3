"""A dataset of many flow simulations, ``maps x cases``, in one Zarr v3 store (:class:`SweepStore`).

The store is self-describing through its attributes (units, frame, spacing, origin and the
generating config: solver settings, seed, map sources). One group per map::

    cases/speed (C,) m/s, cases/direction_deg (C,) deg      the inlet grid shared by every map
    maps/<k>/x (nx,), y (ny,)                               written once, at creation
    maps/<k>/wind (C, 2, ny, nx) m/s, chunks (1, 2, ny, nx)  [u, v] mean wind of case c
    maps/<k>/solid (C, ny, nx) bool, chunks (1, ny, nx)      the solver's solid cells of case c
    maps/<k>/frames (C, T, 2, ny, nx) m/s, chunks (1, 1, 2, ny, nx)   (when recorded)
    maps/<k>/seed (C,) int, seconds (C,) s, done (C,) bool, chunks (1,)
    maps/<k>/diagnostics (C, 5), chunks (1, 5)   flow-throughs of spin-up and window, the
        mean's half-window difference / U, Smagorinsky constant, filter width m (columns
        named in its attributes; see windnav.flow.FlowSolution)

Maps of different sizes are kept in separate groups rather than padded to a common grid: a padded
grid would waste memory on the largest map's size, need a validity mask besides the solid mask and
break the meaning of ``x``/``y``; a reader iterating ``(map, case)`` pairs loses nothing.

The solid mask is stored per case because the solver's mask can differ from the footprints
(pockets no outflow can reach are filled, and which sides are outflows depends on the inlet).
Every simulation owns its own chunks, so parallel workers write without locks. A worker writes
its wind, solid mask (and frames), then ``seconds``, and only then ``done[c] = True`` (the
completion marker). Zarr's local store writes each chunk to a temporary file and renames it, and
chunks are compressed with a checksummed Zstandard frame, so a crash leaves a case either
finished and marked done, or not marked and recomputed (and overwritten) on the next run.
Reopening a store with :meth:`SweepStore.create` and the same config resumes it; a different
config is refused.

One simulation on its own: :mod:`windnav.flow.solution_io`.
"""

from __future__ import annotations

import hashlib
import json
import math
import os
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import zarr

from windnav.city import City
from windnav.flow._zarr import (
    FORMAT_VERSION,
    FRAME,
    SWEEP_FORMAT,
    UNITS,
    compressor,
    grid_attrs,
    jsonable,
    open_group,
    read,
    write_array,
)
from windnav.flow.solver import DIAGNOSTICS

__all__ = ["SweepMap", "SweepMismatchError", "SweepStore", "map_fingerprint"]


class SweepMismatchError(ValueError):
    """A sweep store already holds a different sweep (maps, cases, solver config or seed)."""


def map_fingerprint(city: City) -> str:
    """SHA-256 of a map's bounds and footprints: the identity checked when a sweep resumes."""
    h = hashlib.sha256()
    h.update(np.asarray(city.bounds, dtype=np.float64).tobytes())
    h.update(np.ascontiguousarray(city.footprints, dtype=np.float64).tobytes())
    return h.hexdigest()


@dataclass(frozen=True, eq=False)
class SweepMap:
    """One map of a sweep and the grid its simulations are written on.

    Attributes
    ----------
    name : str
        Label, e.g. the file stem or ``"training-3"``.
    source : str
        Where the map came from (a path, or the generator and its seed).
    city : City
        The map.
    x : ndarray of shape (nx,)
        Cell-centre x coordinates of the solver grid, m.
    y : ndarray of shape (ny,)
        Cell-centre y coordinates of the solver grid, m.
    """

    name: str
    source: str
    city: City
    x: np.ndarray
    y: np.ndarray


class SweepStore:
    """A dataset of flow simulations, ``maps x cases``, in one Zarr v3 store (see module doc).

    Open an existing store with ``SweepStore(path)`` (read-only unless ``mode="r+"``); make or
    resume one with :meth:`create`.
    """

    def __init__(self, path, mode: str = "r"):
        self.path = os.fspath(path)
        group = open_group(self.path, SWEEP_FORMAT, "SweepStore")
        self.group = group if mode == "r" else zarr.open_group(self.path, mode=mode)
        attrs = self.group.attrs
        self.config = dict(attrs["config"])
        self.n_maps = int(attrs["n_maps"])
        self.speeds = read(self.group, "cases/speed", self.path, "SweepStore")
        self.directions_deg = read(self.group, "cases/direction_deg", self.path, "SweepStore")
        self.n_cases = int(self.speeds.size)

    @classmethod
    def create(
        cls,
        path,
        maps: Sequence[SweepMap],
        speeds,
        directions_deg,
        config: dict,
        n_frames: int = 0,
        seed: int = 0,
    ) -> SweepStore:
        """Make a sweep store, or reopen it for resuming when it holds the same sweep.

        Parameters
        ----------
        path : str or os.PathLike
            Store directory.
        maps : sequence of SweepMap
            The maps, in order; map ``k`` becomes group ``maps/k``.
        speeds : sequence of float
            Inlet speeds, m/s.
        directions_deg : sequence of float
            Inlet directions (blowing toward, counter-clockwise from +x), deg.
        config : dict
            Solver settings (dx, dt, spinup_steps, steps, record_every, ...), JSON values.
        n_frames : int, default 0
            Frames recorded per simulation (0: mean wind only).
        seed : int, default 0
            Root seed; simulation ``(k, c)`` gets ``SeedSequence([seed, k, c])``'s first word.

        Returns
        -------
        SweepStore
            Opened read-write. Cases are ``(speed, direction)`` pairs, speeds outermost.

        Raises
        ------
        SweepMismatchError
            When ``path`` holds another sweep (different maps, cases, config or seed).
        ValueError
            When ``path`` holds a store of another kind (or something that is not a store).
        """
        speeds = np.asarray(speeds, dtype=np.float64).reshape(-1)
        directions_deg = np.asarray(directions_deg, dtype=np.float64).reshape(-1)
        case_speed = np.repeat(speeds, directions_deg.size)
        case_dir = np.tile(directions_deg, speeds.size)
        config = jsonable(config, "config", "SweepStore.create")
        ident = {
            "config": config,
            "seed": int(seed),
            "n_frames": int(n_frames),
            "maps": [map_fingerprint(m.city) for m in maps],
            "speeds": speeds.tolist(),
            "directions_deg": directions_deg.tolist(),
        }
        path = os.fspath(path)
        if _is_unfinished_sweep(path):
            pass  # creation itself was interrupted: nothing computed yet, start over
        elif os.path.exists(path) and (not os.path.isdir(path) or os.listdir(path)):
            store = cls(path, mode="r+")
            if store.group.attrs.get("identity") != json.loads(json.dumps(ident)):
                raise SweepMismatchError(
                    f"SweepStore.create: {path!r} already holds a different sweep (maps, "
                    "speeds, directions, solver config or seed differ); write the sweep to "
                    "another path, or delete the store to start over."
                )
            return store
        group = zarr.open_group(path, mode="w")
        group.attrs["windnav_format"] = SWEEP_FORMAT + ".unfinished"
        cases = group.create_group("cases")
        write_array(cases, "speed", case_speed)
        write_array(cases, "direction_deg", case_dir)
        n_cases = case_speed.size
        for k, m in enumerate(maps):
            _create_map_group(group, k, m, n_cases, int(n_frames), int(seed))
        # Written last: a store without these attributes is not a sweep store and is refused.
        group.attrs.update(
            {
                "frame": FRAME,
                "units": {k: UNITS[k] for k in ("x", "y", "wind", "speed", "direction_deg")},
                "layout": "maps/<k>/wind[c] = [u, v] of map k, case c; "
                "see windnav.flow.sweep_store",
                "config": config,
                "seed": int(seed),
                "n_maps": len(maps),
                "n_frames": int(n_frames),
                "identity": ident,
                "format_version": FORMAT_VERSION,
                "windnav_format": SWEEP_FORMAT,
            }
        )
        return cls(path, mode="r+")

    def _map(self, k: int):
        return self.group[f"maps/{int(k)}"]

    def done(self, k: int) -> np.ndarray:
        """Completion markers of map ``k``: bool array of shape (n_cases,).

        An unreadable marker chunk counts as not done.
        """
        arr = self._map(k)["done"]
        try:
            return np.asarray(arr[:], dtype=bool)
        except Exception:
            out = np.zeros(self.n_cases, dtype=bool)
            for c in range(self.n_cases):
                try:
                    out[c] = bool(arr[c])
                except Exception:
                    out[c] = False
            return out

    def pending(self, verify: bool = False) -> list[tuple[int, int]]:
        """``(map, case)`` pairs still to compute.

        With ``verify``, finished cases whose wind cannot be read back (damaged after the
        fact) are pending too.
        """
        todo = []
        for k in range(self.n_maps):
            done = self.done(k)
            for c in range(self.n_cases):
                if done[c] and verify:
                    try:
                        self._map(k)["wind"][c]
                    except Exception:
                        done[c] = False
                if not done[c]:
                    todo.append((k, c))
        return todo

    def case_seed(self, k: int, c: int) -> int:
        """Seed of simulation (map ``k``, case ``c``)."""
        return int(self._map(k)["seed"][int(c)])

    def write_case(self, k: int, c: int, solution, seconds: float = math.nan) -> None:
        """Write simulation (map ``k``, case ``c``) and then mark it done.

        Raises
        ------
        ValueError
            When the solution's grid or solid mask differ from the map's stored ones.
        """
        g = self._map(k)
        x, y = g["x"][:], g["y"][:]
        if not (
            np.shape(solution.x) == x.shape
            and np.shape(solution.y) == y.shape
            and np.allclose(solution.x, x)
            and np.allclose(solution.y, y)
        ):
            raise ValueError(
                f"SweepStore.write_case: the solution's grid ({np.size(solution.y)} x "
                f"{np.size(solution.x)}) does not match map {k}'s grid ({y.size} x {x.size}) "
                f"in {self.path!r}."
            )
        g["wind"][c] = np.stack([solution.mean_u, solution.mean_v]).astype(np.float64)
        g["solid"][c] = np.asarray(solution.solid, dtype=bool)
        if "frames" in g:
            frames = np.stack([solution.frames_u, solution.frames_v], axis=1)
            if frames.shape != g["frames"].shape[1:]:
                raise ValueError(
                    f"SweepStore.write_case: the solution has frames of shape {frames.shape}; "
                    f"map {k} of {self.path!r} expects {g['frames'].shape[1:]}."
                )
            g["frames"][c] = frames.astype(np.float64)
        if "diagnostics" in g:
            g["diagnostics"][c] = [float(getattr(solution, k, np.nan)) for k in DIAGNOSTICS]
        g["seconds"][c] = float(seconds)
        g["done"][c] = True  # last: the completion marker

    def read_case(self, k: int, c: int) -> dict:
        """Arrays of simulation (map ``k``, case ``c``).

        Returns
        -------
        dict
            ``x`` (nx,), ``y`` (ny,) m; ``solid`` (ny, nx); ``mean_u``, ``mean_v`` (ny, nx)
            m/s; ``frames_u``, ``frames_v`` (T, ny, nx) m/s when recorded; ``speed`` m/s,
            ``direction_deg``, ``seed``, ``done``.
        """
        g = self._map(k)
        where = f"SweepStore.read_case({k}, {c})"
        wind = read(g, "wind", self.path, where, int(c))
        out = {
            "x": read(g, "x", self.path, where),
            "y": read(g, "y", self.path, where),
            "solid": read(g, "solid", self.path, where, int(c)),
            "mean_u": wind[0],
            "mean_v": wind[1],
            "speed": float(self.speeds[c]),
            "direction_deg": float(self.directions_deg[c]),
            "seed": self.case_seed(k, c),
            "done": bool(self.done(k)[c]),
        }
        if "frames" in g:
            frames = read(g, "frames", self.path, where, int(c))
            out["frames_u"], out["frames_v"] = frames[:, 0], frames[:, 1]
        if "diagnostics" in g:
            out["diagnostics"] = dict(zip(DIAGNOSTICS, g["diagnostics"][c].tolist(),
                                          strict=True))
        return out

    def map_attrs(self, k: int) -> dict:
        """Attributes of map ``k``: name, source, bounds, fingerprint, spacing, origin."""
        return dict(self._map(k).attrs)


def _is_unfinished_sweep(path: str) -> bool:
    try:
        fmt = zarr.open_group(path, mode="r").attrs.get("windnav_format")
    except Exception:
        return False
    return fmt == SWEEP_FORMAT + ".unfinished"


def _create_map_group(root, k: int, m: SweepMap, n_cases: int, n_frames: int, seed: int):
    x = np.asarray(m.x, dtype=np.float64)
    y = np.asarray(m.y, dtype=np.float64)
    ny, nx = y.size, x.size
    g = root.create_group(f"maps/{k}")
    g.attrs.update(
        {
            "name": m.name,
            "source": m.source,
            "bounds": list(m.city.bounds),
            "footprints": m.city.footprints.tolist(),
            "heights": m.city.heights.tolist(),
            "fingerprint": map_fingerprint(m.city),
            **grid_attrs(x, y),
        }
    )
    write_array(g, "x", x)
    write_array(g, "y", y)
    seeds = [
        int(np.random.SeedSequence([seed, k, c]).generate_state(1, np.uint32)[0])
        for c in range(n_cases)
    ]
    write_array(g, "seed", np.asarray(seeds, dtype=np.int64), chunks=(1,))
    wind = g.create_array(
        "wind",
        shape=(n_cases, 2, ny, nx),
        chunks=(1, 2, ny, nx),
        dtype=np.float64,
        fill_value=np.nan,
        compressors=compressor(),
    )
    wind.attrs.update({"units": "m/s", "axis1": ["u", "v"]})
    if n_frames > 0:
        frames = g.create_array(
            "frames",
            shape=(n_cases, n_frames, 2, ny, nx),
            chunks=(1, 1, 2, ny, nx),
            dtype=np.float64,
            fill_value=np.nan,
            compressors=compressor(),
        )
        frames.attrs.update({"units": "m/s", "axis2": ["u", "v"]})
    g.create_array(
        "solid",
        shape=(n_cases, ny, nx),
        chunks=(1, ny, nx),
        dtype=bool,
        fill_value=False,
        compressors=compressor(),
    )
    diag = g.create_array(
        "diagnostics",
        shape=(n_cases, len(DIAGNOSTICS)),
        chunks=(1, len(DIAGNOSTICS)),
        dtype=np.float64,
        fill_value=np.nan,
        compressors=compressor(),
    )
    diag.attrs["columns"] = list(DIAGNOSTICS)
    for name, dtype, fill in (("seconds", np.float64, np.nan), ("done", bool, False)):
        arr = g.create_array(
            name,
            shape=(n_cases,),
            chunks=(1,),
            dtype=dtype,
            fill_value=fill,
            compressors=compressor(),
        )
        if name in UNITS:
            arr.attrs["units"] = UNITS[name]
