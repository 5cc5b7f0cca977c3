"""A dataset of many flow simulations, ``maps x cases``, in one Zarr v3 store (:class:`SweepStore`).

The store is self-describing through its attributes (units, frame, spacing, origin and the
generating config: solver settings, seed, map sources). One group per map::

    cases/speed (C,) m/s, cases/direction_deg (C,) deg      the inlet grid shared by every map
    maps/<k>/x (nx,), y (ny,), seed (C,) int                written once, at creation
    maps/<k>/wind (C, 2, ny, nx) m/s, chunks (1, 2, ny, nx)  [u, v] mean wind of case c
    maps/<k>/solid (C, ny, nx) bool, chunks (1, ny, nx)      the solver's solid cells of case c
    maps/<k>/frames (C, T, 2, ny, nx) m/s, chunks (1, 1, 2, ny, nx)   (when recorded)
    maps/<k>/diagnostics (C, D), chunks (1, D)   flow-throughs of spin-up and window, the
        mean's half-window difference / U, Smagorinsky constant, filter width m, viscosity
        (columns named in its attributes; see windnav.flow.FlowSolution)
    maps/<k>/seconds (C,) s, done (C,) bool, chunks (1,)
    maps/<k>/checksums (C, A) int64, chunks (1, A)   digest of each case's wind, solid, frames,
        diagnostics and seconds (columns named in its attributes)

Maps of different sizes are kept in separate groups rather than padded to a common grid: a padded
grid would waste memory on the largest map's size, need a validity mask besides the solid mask and
break the meaning of ``x``/``y``; a reader iterating ``(map, case)`` pairs loses nothing.

The solid mask is stored per case because the solver's mask can differ from the footprints
(pockets no outflow can reach are filled, and which sides are outflows depends on the inlet).

Completion and integrity
------------------------
Every simulation owns its own chunks, so parallel workers write without locks. A worker writes
its wind, solid mask, frames, diagnostics and ``seconds``, then their digests (the first 8
bytes of a SHA-256 of each case's decoded slice, :func:`windnav.flow._zarr.digest`), and only
then ``done[c] = True`` (the completion marker). Zarr's local store writes each chunk to a
temporary file and renames it, so a crash leaves a case either finished and marked done, or not
marked and recomputed (and overwritten) on the next run. The arrays written once at creation
(``cases/*``, ``x``, ``y``, ``seed``) have their digests in the attributes (``checksums``).

Damage after the fact is found by :meth:`SweepStore.verify`: it reads back every array of every
finished case and compares it with its digest. Chunks are compressed with a checksummed
Zstandard frame, so flipped bytes are a read error; a *deleted* chunk reads back as the array's
fill value (NaN wind, no buildings, zeros) and is caught by its digest. Damaged cases are marked
not done (:meth:`SweepStore.invalidate`) and recomputed by the next run; damaged creation-time
arrays are rewritten when the sweep is resumed (:meth:`SweepStore.create`). Stores written
before the digests existed can only be checked for unreadable chunks and non-finite wind; their
other finished cases are reported as unverified.

Reopening a store with :meth:`SweepStore.create` and the same config resumes it; a different
config is refused. The store records the hash of the solver's source of every run that wrote it
(``solver_code``, :func:`note_solver_code`); resuming with other solver code, when cases are
done and others left, warns that the sweep mixes two solvers. One simulation on its own:
:mod:`windnav.flow.solution_io`.
"""

from __future__ import annotations

import contextlib
import fcntl
import hashlib
import json
import math
import os
import warnings
from collections.abc import Iterable, Sequence
from dataclasses import dataclass, field

import numpy as np
import zarr

from windnav._source import SOLVER_MODULE, module_key
from windnav.city import City
from windnav.flow._zarr import (
    FORMAT_VERSION,
    FRAME,
    SWEEP_FORMAT,
    UNITS,
    CorruptStoreError,
    compressor,
    digest,
    digest_word,
    grid_attrs,
    jsonable,
    open_group,
    read,
    require_attr,
    write_array,
)
from windnav.flow.solver import DIAGNOSTICS

__all__ = [
    "CorruptStoreError",
    "SweepMap",
    "SweepMismatchError",
    "SweepStore",
    "VerifyReport",
    "map_fingerprint",
    "note_solver_code",
]

CASE_ARRAYS = ("wind", "solid", "frames", "diagnostics", "seconds")
"""The per-case arrays a worker writes (``frames`` only when recorded), in checksum order."""
DIGEST_NOTE = ("first 8 bytes of SHA-256 of the case's slice (dtype, shape, little-endian "
               "C-order bytes) as an integer in [1, 2**63); 0: not recorded")


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


@dataclass(frozen=True)
class VerifyReport:
    """What :meth:`SweepStore.verify` found.

    Attributes
    ----------
    damaged : dict
        ``(map, case) -> tuple of str``: finished cases with an array that is unreadable or
        differs from its digest, and what is wrong (e.g. ``"wind: does not match its
        checksum ..."``). These are the cases to recompute.
    unverified : tuple of (int, int)
        Finished cases that read back but have no digests to compare with (a store written
        before digests were recorded).
    store : tuple of str
        Damaged arrays shared by all cases (``cases/speed``, ``maps/<k>/x``, ...). Resuming
        the sweep (:meth:`SweepStore.create` with the same maps) rewrites them.
    n_checked : int
        Finished cases read back.
    """

    damaged: dict = field(default_factory=dict)
    unverified: tuple = ()
    store: tuple = ()
    n_checked: int = 0

    @property
    def ok(self) -> bool:
        """True when nothing is damaged (unverified cases do not count as damage)."""
        return not self.damaged and not self.store

    @property
    def cases(self) -> list[tuple[int, int]]:
        """The damaged ``(map, case)`` pairs, sorted."""
        return sorted(self.damaged)



@contextlib.contextmanager
def _creation_lock(path: str):
    """Hold an exclusive ``flock`` on the folder that holds ``path`` while a store is created
    or reopened there: a second process waits, then finds the finished store and resumes it
    (two ``wind-sweep`` runs started together each wiped the store the other was building,
    and could leave one that no rerun repaired)."""
    parent = os.path.dirname(os.path.abspath(path))
    os.makedirs(parent, exist_ok=True)
    fd = os.open(parent, os.O_RDONLY)
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX)
        except OSError:  # a file system without locks: create as before, unguarded
            pass
        yield
    finally:
        os.close(fd)  # releases the lock

def note_solver_code(store: SweepStore, where: str) -> None:
    """Record this solver's source hash in a store with cases left to solve, and warn when
    cases already done were solved by other code (or by a windnav that recorded none): the
    sweep then mixes two solvers, which nothing else would show. A finished store is left as it
    is. :func:`windnav.experiments.wind_sweep.sweep` calls it once it knows which cases are
    left (after ``verify`` has marked damaged ones), before solving them."""
    code = module_key(SOLVER_MODULE)
    before = store.solver_code
    if code.endswith("-modified"):  # which code solves the cases left is not known
        warnings.warn(f"{where}: a file of {SOLVER_MODULE}'s code changed after windnav was "
                      f"imported, so the cases this run solves in {store.path!r} are of code "
                      "this store cannot name; rerun the sweep in a new process to record "
                      "it.", stacklevel=4)
        return
    if code in before:
        return
    n_done = sum(int(np.count_nonzero(store.done(k))) for k in range(store.n_maps))
    if n_done == store.n_maps * store.n_cases:
        return  # nothing left to solve: no case of this code, no mix (review)
    if n_done:
        by = (f"other solver code (source hash {', '.join(before)})" if before else
              "a windnav that did not record its solver code")
        warnings.warn(
            f"{where}: {store.path!r} holds {n_done} finished case(s) solved by {by}; this "
            f"solver's is {code} ({SOLVER_MODULE} and the modules it imports). The cases left "
            "are solved with this one, so the sweep mixes two solvers; delete the store to "
            "solve every case with this one.", stacklevel=4)
    store.group.attrs["solver_code"] = [*before, code]


class SweepStore:
    """A dataset of flow simulations, ``maps x cases``, in one Zarr v3 store (see module doc).

    Open an existing store with ``SweepStore(path)`` (read-only unless ``mode="r+"``); make or
    resume one with :meth:`create`.

    Attributes
    ----------
    path : str
    config : dict
        The solver settings of the sweep.
    n_maps, n_cases : int
    speeds, directions_deg : ndarray of shape (n_cases,)
        Inlet of each case, m/s and deg.
    repaired : list of str
        Creation-time arrays that :meth:`create` found damaged and rewrote (empty otherwise).
    last_verify : VerifyReport or None
        The report of the latest :meth:`verify` on this object.

    Raises
    ------
    CorruptStoreError
        (a ValueError) Naming the path and what is missing when the store's metadata, a
        required attribute (``config``, ``n_maps``) or the case list is damaged.
    ValueError
        When there is no store at ``path``, or it is another kind of store.
    """

    def __init__(self, path, mode: str = "r"):
        self.path = os.fspath(path)
        where = "SweepStore"
        if mode not in ("r", "r+"):  # "zz" was a CorruptStoreError with an empty message
            raise ValueError(f"The 'mode' parameter of {where} must be 'r' or 'r+'. Got {mode!r} "
                             "instead.")
        self.group = open_group(self.path, SWEEP_FORMAT, where, mode=mode)
        config = require_attr(self.group, "config", self.path, where)
        n_maps = require_attr(self.group, "n_maps", self.path, where)
        if not isinstance(config, dict) or isinstance(n_maps, bool) or not isinstance(n_maps, int):
            raise CorruptStoreError(
                f"{where}: the Zarr store {self.path!r} has a malformed 'config' or 'n_maps' "
                f"attribute (config={config!r}, n_maps={n_maps!r})."
            )
        self.config = dict(config)
        self.n_maps = int(n_maps)
        sums = self.group.attrs.get("checksums", {})
        self.speeds = _read_checked(self.group, "cases/speed", sums, self.path, where)
        self.directions_deg = _read_checked(self.group, "cases/direction_deg", sums,
                                            self.path, where)
        self.n_cases = int(self.speeds.size)
        self.repaired: list[str] = []
        self.last_verify: VerifyReport | None = None

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

        Resuming rewrites creation-time arrays that are damaged (listed in the returned
        store's ``repaired``) and recreates per-case arrays whose metadata is lost (their
        cases are then marked not done).

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
        CorruptStoreError
            When ``path`` holds a sweep store whose identity attributes are lost.
        ValueError
            When ``path`` holds a store of another kind (or something that is not a store).
        """
        where = "SweepStore.create"
        speeds = np.asarray(speeds, dtype=np.float64).reshape(-1)
        directions_deg = np.asarray(directions_deg, dtype=np.float64).reshape(-1)
        case_speed = np.repeat(speeds, directions_deg.size)
        case_dir = np.tile(directions_deg, speeds.size)
        config = jsonable(config, "config", where)
        ident = {
            "config": config,
            "seed": int(seed),
            "n_frames": int(n_frames),
            "maps": [map_fingerprint(m.city) for m in maps],
            "speeds": speeds.tolist(),
            "directions_deg": directions_deg.tolist(),
        }
        path = os.fspath(path)
        static = _static_arrays(maps, case_speed, case_dir, int(seed))
        with _creation_lock(path):  # two processes creating one store wiped each other's
            return cls._create_locked(path, maps, static, ident, config, case_speed,
                                      int(n_frames), int(seed), where)

    @classmethod
    def _create_locked(cls, path, maps, static, ident, config, case_speed, n_frames: int,
                       seed: int, where: str) -> SweepStore:
        """:meth:`create` once it holds the creation lock."""
        if _is_unfinished_sweep(path):
            pass  # creation itself was interrupted: nothing computed yet, start over
        elif os.path.exists(path) and (not os.path.isdir(path) or os.listdir(path)):
            group = open_group(path, SWEEP_FORMAT, where, mode="r+")
            if require_attr(group, "identity", path, where) != json.loads(json.dumps(ident)):
                raise SweepMismatchError(
                    f"{where}: {path!r} already holds a different sweep (maps, speeds, "
                    "directions, solver config or seed differ); write the sweep to another "
                    "path, or delete the store to start over."
                )
            repaired = _repair(group, maps, static, case_speed.size, n_frames)
            store = cls(path, mode="r+")
            store.repaired = repaired
            return store
        group = zarr.open_group(path, mode="w")
        group.attrs["windnav_format"] = SWEEP_FORMAT + ".unfinished"
        cases = group.create_group("cases")
        for name in ("speed", "direction_deg"):
            write_array(cases, name, static[f"cases/{name}"])
        n_cases = case_speed.size
        for k, m in enumerate(maps):
            _create_map_group(group, k, m, static, n_cases, n_frames)
        # Written last: a store without these attributes is not a sweep store and is refused.
        group.attrs.update(
            {
                "frame": FRAME,
                "units": {k: UNITS[k] for k in ("x", "y", "wind", "speed", "direction_deg")},
                "layout": "maps/<k>/wind[c] = [u, v] of map k, case c; "
                "see windnav.flow.sweep_store",
                "config": config,
                "seed": seed,
                "n_maps": len(maps),
                "n_frames": n_frames,
                "identity": ident,
                "checksums": {p: digest(a) for p, a in static.items() if p.startswith("cases/")},
                "format_version": FORMAT_VERSION,
                "windnav_format": SWEEP_FORMAT,
            }
        )
        return cls(path, mode="r+")

    @property
    def solver_code(self) -> list[str]:
        """The hashes of the solver's source (:func:`windnav._source.module_key` of
        :data:`SOLVER_MODULE`) of every run that wrote this store, oldest first (recorded by
        :func:`note_solver_code`, which a sweep runs before it solves); empty for a store from
        before 2026-12-06."""
        codes = self.group.attrs.get("solver_code")
        return [str(c) for c in codes] if isinstance(codes, list) else []

    def _map(self, k: int):
        try:
            return self.group[f"maps/{int(k)}"]
        except Exception as exc:
            raise CorruptStoreError(
                f"SweepStore: the Zarr store {self.path!r} has a missing or corrupt group "
                f"'maps/{int(k)}' (delete the store to start over): {exc}"
            ) from exc

    def done(self, k: int) -> np.ndarray:
        """Completion markers of map ``k``: bool array of shape (n_cases,).

        An unreadable marker chunk (or a lost ``done`` array) counts as not done.
        """
        out = np.zeros(self.n_cases, dtype=bool)
        try:
            arr = self._map(k)["done"]
        except Exception:
            return out
        try:
            return np.asarray(arr[:], dtype=bool)
        except Exception:
            for c in range(self.n_cases):
                try:
                    out[c] = bool(arr[c])
                except Exception:
                    out[c] = False
            return out

    def pending(self, verify: bool = False) -> list[tuple[int, int]]:
        """``(map, case)`` pairs still to compute, sorted.

        With ``verify``, finished cases that :meth:`verify` finds damaged are pending too
        (reading back every array of every finished case).
        """
        todo = [(k, c) for k in range(self.n_maps) for c in np.flatnonzero(~self.done(k))]
        todo = [(int(k), int(c)) for k, c in todo]
        if verify:
            todo = sorted(set(todo) | set(self.verify().damaged))
        return todo

    def verify(self, maps: Iterable[int] | None = None, progress: bool = False) -> VerifyReport:
        """Read back every array of every finished case and compare it with its digest.

        Parameters
        ----------
        maps : iterable of int, optional
            The maps to check (default: all).
        progress : bool, default False
            Show a tqdm progress bar over the finished cases.

        Returns
        -------
        VerifyReport
            Damaged cases (unreadable, missing or changed data) with what is wrong, finished
            cases that could not be verified (no digests recorded), and damaged
            creation-time arrays. Also kept as ``last_verify``. Nothing is changed: mark the
            damaged cases for recomputation with :meth:`invalidate`.
        """
        from windnav._console import progress_bar

        keys = range(self.n_maps) if maps is None else [int(k) for k in maps]
        todo = [(k, int(c)) for k in keys for c in np.flatnonzero(self.done(k))]
        damaged, unverified, store = {}, [], list(self._verify_static(keys))
        groups = {}
        for k, c in progress_bar(todo, auto=False, desc="verify", unit="case",
                                 disable=not progress):
            if k not in groups:
                groups[k] = self._case_checker(k)
            problems, checked = groups[k](c)
            if problems:
                damaged[(k, c)] = tuple(problems)
            elif not checked:
                unverified.append((k, c))
        self.last_verify = VerifyReport(damaged, tuple(unverified), tuple(store), len(todo))
        return self.last_verify

    def invalidate(self, cases: Iterable[tuple[int, int]]) -> None:
        """Mark ``(map, case)`` pairs not done, so the next run of the sweep recomputes them."""
        for k, c in cases:
            g = self._map(k)
            if "done" in g:
                g["done"][int(c)] = False

    def _verify_static(self, keys) -> Iterable[str]:
        root_sums = self.group.attrs.get("checksums")
        if root_sums is not None:
            for name in ("cases/speed", "cases/direction_deg"):
                problem = _static_problem(self.group, name, root_sums)
                if problem:
                    yield problem
        for k in keys:
            g = self._map(k)
            sums = g.attrs.get("checksums")
            if sums is None:
                continue
            for name in sums:
                problem = _static_problem(g, name, sums)
                if problem:
                    yield f"maps/{k}/{problem}"

    def _case_checker(self, k: int):
        """A function ``c -> (problems, verified)`` checking case ``c`` of map ``k``."""
        g = self._map(k)
        digests_written = "checksums" in g.attrs  # a store written with digests
        try:
            sums_arr = g["checksums"]
            columns = list(sums_arr.attrs["columns"])
        except Exception:
            sums_arr, columns = None, None
        names = columns or [n for n in CASE_ARRAYS if n in g]

        def check(c: int):
            problems = []
            recorded = None
            if digests_written and sums_arr is None:
                problems.append("checksums: the array is lost (resuming the sweep recreates it)")
            elif sums_arr is not None:
                try:
                    recorded = np.asarray(sums_arr[c], dtype=np.int64)
                except Exception as exc:
                    problems.append(f"checksums: unreadable ({type(exc).__name__}: {exc})")
                else:
                    if not recorded.any():
                        problems.append("checksums: not recorded (a chunk is missing)")
                        recorded = None
            for j, name in enumerate(names):
                try:
                    word, finite = _case_digest(g, name, c)
                except Exception as exc:
                    problems.append(f"{name}: unreadable ({type(exc).__name__}: {exc})")
                    continue
                if recorded is not None and word != int(recorded[j]):
                    problems.append(f"{name}: does not match its checksum (a chunk is missing "
                                    "or damaged)")
                elif recorded is None and not finite and name in ("wind", "frames"):
                    problems.append(f"{name}: not finite (a chunk is missing)")
            return problems, digests_written or sums_arr is not None

        return check

    def case_seed(self, k: int, c: int) -> int:
        """Seed of simulation (map ``k``, case ``c``)."""
        return int(read(self._map(k), "seed", self.path, "SweepStore.case_seed", int(c)))

    def write_case(self, k: int, c: int, solution, seconds: float = math.nan) -> None:
        """Write simulation (map ``k``, case ``c``), its digests, and then mark it done.

        Raises
        ------
        ValueError
            When the solution's grid differs from the map's stored one (to 1e-9 of a cell), or
            its inlet speed or direction from case ``c``'s (a solution of another case was
            written under this one's name; audit, 2026-12-05).
        """
        g = self._map(k)
        x, y = g["x"][:], g["y"][:]
        cell = float(np.min(np.diff(x))) if x.size > 1 else 1.0
        if not (
            np.shape(solution.x) == x.shape
            and np.shape(solution.y) == y.shape
            and np.allclose(solution.x, x, rtol=0.0, atol=1e-9 * cell)
            and np.allclose(solution.y, y, rtol=0.0, atol=1e-9 * cell)
        ):
            raise ValueError(
                f"SweepStore.write_case: the solution's grid ({np.size(solution.y)} x "
                f"{np.size(solution.x)}) does not match map {k}'s grid ({y.size} x {x.size}) "
                f"in {self.path!r}."
            )
        speed, direction = float(self.speeds[c]), float(self.directions_deg[c])
        got = (float(getattr(solution, "speed", speed)),
               float(getattr(solution, "direction_deg", direction)))
        if not (np.isclose(got[0], speed, rtol=1e-12, atol=0.0)
                and np.isclose((got[1] - direction + 180.0) % 360.0 - 180.0, 0.0, atol=1e-9)):
            raise ValueError(
                f"SweepStore.write_case: the solution's inlet ({got[0]:g} m/s toward "
                f"{got[1]:g} deg) is not case {c}'s ({speed:g} m/s toward {direction:g} deg) "
                f"in {self.path!r}.")
        data = {
            "wind": np.stack([solution.mean_u, solution.mean_v]).astype(np.float64, copy=False),
            "solid": np.asarray(solution.solid, dtype=bool),
        }
        if "frames" in g:
            frames = np.stack([solution.frames_u, solution.frames_v], axis=1)
            if frames.shape != g["frames"].shape[1:]:
                raise ValueError(
                    f"SweepStore.write_case: the solution has frames of shape {frames.shape}; "
                    f"map {k} of {self.path!r} expects {g['frames'].shape[1:]}."
                )
            data["frames"] = frames.astype(np.float64, copy=False)
        if "diagnostics" in g:
            columns = g["diagnostics"].attrs.get("columns", list(DIAGNOSTICS))
            data["diagnostics"] = np.array(
                [float(getattr(solution, name, np.nan)) for name in columns], dtype=np.float64)
        data["seconds"] = np.asarray(float(seconds), dtype=np.float64)
        for name, value in data.items():
            g[name][c] = value
        if "checksums" in g:
            columns = list(g["checksums"].attrs["columns"])
            g["checksums"][c] = [digest_word(digest(data[name])) for name in columns]
        g["done"][c] = True  # last: the completion marker

    def read_case(self, k: int, c: int, verify: bool = True) -> dict:
        """Arrays of simulation (map ``k``, case ``c``).

        Parameters
        ----------
        k, c : int
            Map and case.
        verify : bool, default True
            Compare a finished case's arrays with their digests (when the store has them).

        Returns
        -------
        dict
            ``x`` (nx,), ``y`` (ny,) m; ``solid`` (ny, nx); ``mean_u``, ``mean_v`` (ny, nx)
            m/s; ``frames_u``, ``frames_v`` (T, ny, nx) m/s when recorded; ``diagnostics``
            (a dict); ``speed`` m/s, ``direction_deg``, ``seed``, ``done``. A case not done
            reads as the fill values (NaN wind).

        Raises
        ------
        CorruptStoreError
            (a ValueError) Naming the path, the case and the array when an array is
            unreadable or (with ``verify``) differs from its digest.
        """
        g = self._map(k)
        where = f"SweepStore.read_case({k}, {c})"
        done = bool(self.done(k)[c])
        if verify and done:
            problems, _ = self._case_checker(k)(int(c))
            if problems:
                raise CorruptStoreError(
                    f"{where}: the Zarr store {self.path!r} is damaged: " + "; ".join(problems)
                )
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
            "done": done,
        }
        if "frames" in g:
            frames = read(g, "frames", self.path, where, int(c))
            out["frames_u"], out["frames_v"] = frames[:, 0], frames[:, 1]
        if "diagnostics" in g:
            columns = g["diagnostics"].attrs.get("columns", list(DIAGNOSTICS))
            values = read(g, "diagnostics", self.path, where, int(c)).tolist()
            out["diagnostics"] = dict(zip(columns, values, strict=True))
        return out

    def case_diagnostics(self, k: int) -> dict:
        """The averaging and closure diagnostics of every case of map ``k``, read as stored:
        ``{column: ndarray of shape (n_cases,)}`` (NaN for a case not done, or a store or
        solver without them: then empty)."""
        g = self._map(k)
        if "diagnostics" not in g:
            return {}
        columns = g["diagnostics"].attrs.get("columns", list(DIAGNOSTICS))
        values = np.asarray(read(g, "diagnostics", self.path,
                                 f"SweepStore.case_diagnostics({k})"), dtype=np.float64)
        return {name: values[:, i] for i, name in enumerate(columns)}

    def map_attrs(self, k: int) -> dict:
        """Attributes of map ``k``: name, source, bounds, fingerprint, spacing, origin."""
        return dict(self._map(k).attrs)


def _read_checked(group, name: str, sums: dict, path: str, where: str) -> np.ndarray:
    value = read(group, name, path, where)
    if name in sums and digest(value) != sums[name]:
        raise CorruptStoreError(
            f"{where}: the array {name!r} of the Zarr store {path!r} does not match the "
            "checksum recorded when it was written (a chunk is missing or damaged); resuming "
            "the sweep with the same maps and settings rewrites it."
        )
    return value


def _static_problem(group, name: str, sums: dict) -> str | None:
    """What is wrong with creation-time array ``name`` of ``group``, or None."""
    try:
        value = np.asarray(group[name][...])
    except Exception as exc:
        return f"{name}: unreadable ({type(exc).__name__}: {exc})"
    if digest(value) != sums.get(name):
        return f"{name}: does not match its checksum (a chunk is missing or damaged)"
    return None


def _case_digest(g, name: str, c: int) -> tuple[int, bool]:
    """Digest word of case ``c``'s slice of array ``name``, and whether it is all finite.

    Frames are read one chunk at a time, so a long recording need not fit in memory."""
    arr = g[name]
    if name == "frames":
        finite = [True]

        def parts():
            for t in range(arr.shape[1]):
                part = np.asarray(arr[c, t])
                finite[0] = finite[0] and bool(np.isfinite(part).all())
                yield part

        word = digest_word(digest(shape=arr.shape[1:], dtype=arr.dtype, parts=parts()))
        return word, finite[0]
    value = np.asarray(arr[c])
    finite = bool(np.isfinite(value).all()) if value.dtype.kind == "f" else True
    return digest_word(digest(value)), finite


def _is_unfinished_sweep(path: str) -> bool:
    try:
        fmt = zarr.open_group(path, mode="r").attrs.get("windnav_format")
    except Exception:
        return False
    return fmt == SWEEP_FORMAT + ".unfinished"


def _static_arrays(maps, case_speed, case_dir, seed: int) -> dict:
    """The arrays written once at creation, by path: ``cases/*`` and each map's x, y, seed."""
    out = {"cases/speed": np.asarray(case_speed, dtype=np.float64),
           "cases/direction_deg": np.asarray(case_dir, dtype=np.float64)}
    n_cases = int(np.size(case_speed))
    for k, m in enumerate(maps):
        out[f"maps/{k}/x"] = np.asarray(m.x, dtype=np.float64)
        out[f"maps/{k}/y"] = np.asarray(m.y, dtype=np.float64)
        out[f"maps/{k}/seed"] = np.asarray(
            [int(np.random.SeedSequence([seed, k, c]).generate_state(1, np.uint32)[0])
             for c in range(n_cases)], dtype=np.int64)
    return out


def _case_array_specs(n_cases: int, ny: int, nx: int, n_frames: int) -> dict:
    """name -> (shape, chunks, dtype, fill value, attributes) of the per-case arrays."""
    specs = {
        "wind": ((n_cases, 2, ny, nx), (1, 2, ny, nx), np.float64, np.nan,
                 {"units": "m/s", "axis1": ["u", "v"]}),
        "solid": ((n_cases, ny, nx), (1, ny, nx), bool, False, {}),
    }
    if n_frames > 0:
        specs["frames"] = ((n_cases, n_frames, 2, ny, nx), (1, 1, 2, ny, nx), np.float64,
                           np.nan, {"units": "m/s", "axis2": ["u", "v"]})
    nd = len(DIAGNOSTICS)
    specs["diagnostics"] = ((n_cases, nd), (1, nd), np.float64, np.nan,
                            {"columns": list(DIAGNOSTICS)})
    specs["seconds"] = ((n_cases,), (1,), np.float64, np.nan, {"units": UNITS["seconds"]})
    columns = [n for n in CASE_ARRAYS if n in specs]
    specs["checksums"] = ((n_cases, len(columns)), (1, len(columns)), np.int64, 0,
                          {"columns": columns, "digest": DIGEST_NOTE})
    specs["done"] = ((n_cases,), (1,), bool, False, {})
    return specs


def _create_case_array(g, name: str, spec) -> None:
    shape, chunks, dtype, fill, attrs = spec
    arr = g.create_array(name, shape=shape, chunks=chunks, dtype=dtype, fill_value=fill,
                         compressors=compressor(), overwrite=True)
    if attrs:
        arr.attrs.update(attrs)


def _write_static(g, name: str, value: np.ndarray) -> None:
    write_array(g, name, value, chunks=(1,) if name == "seed" else None)


def _create_map_group(root, k: int, m: SweepMap, static: dict, n_cases: int, n_frames: int):
    y, x = static[f"maps/{k}/y"], static[f"maps/{k}/x"]
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
            "checksums": {n: digest(static[f"maps/{k}/{n}"]) for n in ("x", "y", "seed")},
        }
    )
    for name in ("x", "y", "seed"):
        _write_static(g, name, static[f"maps/{k}/{name}"])
    for name, spec in _case_array_specs(n_cases, y.size, x.size, n_frames).items():
        _create_case_array(g, name, spec)


def _repair(root, maps, static: dict, n_cases: int, n_frames: int) -> list[str]:
    """Rewrite damaged creation-time arrays and recreate lost per-case arrays of a resumed
    store (in the parent, before any worker starts). Returns what was repaired."""
    repaired = []
    root_sums = root.attrs.get("checksums")
    if root_sums is not None:
        for name in ("cases/speed", "cases/direction_deg"):
            if _static_problem(root, name, root_sums):
                write_array(root.require_group("cases"), name.split("/")[1], static[name])
                repaired.append(name)
    for k in range(len(maps)):
        try:
            g = root[f"maps/{k}"]
            sums = g.attrs.get("checksums")
        except Exception:
            continue  # a lost map group: SweepStore reports it by name
        if sums is None:
            continue  # written before digests: nothing to compare with
        for name in ("x", "y", "seed"):
            if _static_problem(g, name, sums):
                _write_static(g, name, static[f"maps/{k}/{name}"])
                repaired.append(f"maps/{k}/{name}")
        y, x = static[f"maps/{k}/y"], static[f"maps/{k}/x"]
        specs = _case_array_specs(n_cases, y.size, x.size, n_frames)
        lost = []
        for name, spec in specs.items():
            try:
                g[name]
            except Exception:
                _create_case_array(g, name, spec)
                lost.append(name)
        if lost:
            g["done"][...] = False  # their cases' data is gone: recompute every case
            repaired += [f"maps/{k}/{name}" for name in lost]
    return repaired
