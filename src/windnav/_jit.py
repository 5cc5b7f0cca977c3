"""Numba's ``njit`` with an on-disk cache keyed by the source the kernel depends on.

Numba stamps a cached kernel with its own file only. A kernel that calls a jitted function,
or reads a constant, from another windnav module keeps running the cached machine code after
that module changes, until its own file changes too: a silently wrong result for whoever
edits the code (a fresh clone has no cache). :func:`njit` is ``numba.njit`` whose cache
lives in a folder named by a hash of the kernel's module and every windnav module it
imports, directly or through others, so that any such edit compiles afresh.

The folder is ``<module's folder>/__pycache__/numba/<module>-<hash>``. Where
``NUMBA_CACHE_DIR`` is set, it is ``$NUMBA_CACHE_DIR/windnav/<checkout>/<module>-<hash>``
(``<checkout>``: a hash of the package's path); where the package's folder is not writable (an
installed, read-only package), the same under the user's cache folder (``$XDG_CACHE_HOME`` or
``~/.cache``); the user's cache folder also where ``NUMBA_CACHE_DIR`` is not writable. A
module's folders with another hash are removed once untouched for a day (:data:`STALE_S`).
"""

from __future__ import annotations

import functools
import glob
import hashlib
import os
import shutil
import tempfile
import threading
import time
from pathlib import Path

import numba
from numba.core import config as _numba_config

from windnav._source import PACKAGE, ROOT, changed_since_import, dotted_name, source_key

STALE_S = 86400.0
"""A module's cache folder of another hash is removed once nothing in it has changed for this
long (s): a process still running the older code may be writing it (removing it at once made
such a process fail with ``FileNotFoundError``: jit audit)."""

_LOCK = threading.Lock()  # CACHE_DIR is numba's global: one decoration at a time sets it


def _writable(folder: Path) -> bool:
    try:
        folder.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
    except OSError:
        return False
    return True


def _newest_mtime(folder: Path) -> float:
    times = [folder.stat().st_mtime]
    for dirpath, _, files in os.walk(folder):
        times += [os.stat(os.path.join(dirpath, f)).st_mtime for f in files]
    return max(times)


def _prune(base: Path, name: str, keep: Path) -> None:
    """Remove ``name``'s folders under ``base`` other than ``keep`` that have not changed for
    :data:`STALE_S`."""
    now = time.time()
    for old in base.glob(f"{glob.escape(name)}-*"):
        if old == keep or not old.is_dir() or len(old.name) != len(keep.name):
            continue
        try:
            if now - _newest_mtime(old) > STALE_S:
                shutil.rmtree(old, ignore_errors=True)
        except OSError:
            continue  # removed meanwhile by another process


def _remove_old_layout(path: Path) -> None:
    """Numba's own in-tree files of the module at ``path``, from before this layout (unused)."""
    for old in (path.parent / "__pycache__").glob(f"{glob.escape(path.stem)}.*.nb[ic]"):
        try:
            old.unlink(missing_ok=True)
        except OSError:  # a folder this process may read but not change (review)
            return


def cache_folder(path: str | os.PathLike, root: str | os.PathLike = ROOT) -> Path | None:
    """The folder the kernels of the module at ``path`` are cached in (made; folders of other
    hashes untouched for :data:`STALE_S` removed), or None where no folder is writable."""
    path = Path(path).resolve()
    root = Path(root).resolve()
    name = dotted_name(path, root)
    leaf = f"{name}-{source_key(path, root)}"
    user = os.environ.get("NUMBA_CACHE_DIR")
    xdg = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    checkout = hashlib.sha1(str(root).encode()).hexdigest()[:12]
    bases = [Path(user) / PACKAGE / checkout] if user else [path.parent / "__pycache__" / "numba"]
    bases.append(Path(xdg) / PACKAGE / checkout)  # also where NUMBA_CACHE_DIR is not writable
    for base in bases:
        folder = base / leaf
        fresh = not folder.exists()
        if _writable(folder):
            _prune(base, name, folder)
            if fresh and base == path.parent / "__pycache__" / "numba":
                _remove_old_layout(path)
            return folder
    return None


@functools.lru_cache(maxsize=None)
def _cache_folder_for(path: str) -> str:
    folder = cache_folder(path)
    return "" if folder is None else str(folder)


def njit(**options):
    """``numba.njit(**options)``; with ``cache=True`` the cache is :func:`cache_folder`'s.

    The kernel is compiled without an on-disk cache where no folder is writable, or where a
    file it depends on changed after windnav was imported (this process may run other code
    than the files hold); a function outside the package is cached as numba does.
    """
    if not options.get("cache"):
        return numba.njit(**options)

    def decorate(func):
        path = Path(func.__code__.co_filename).resolve()
        if not path.is_relative_to(ROOT):
            with _LOCK:  # not while another decoration has CACHE_DIR set (review)
                return numba.njit(**options)(func)
        folder = "" if changed_since_import(path) else _cache_folder_for(str(path))
        if not folder:
            return numba.njit(**{**options, "cache": False})(func)
        with _LOCK:
            saved = _numba_config.CACHE_DIR
            try:
                _numba_config.CACHE_DIR = folder
                return numba.njit(**options)(func)
            finally:
                _numba_config.CACHE_DIR = saved

    return decorate
