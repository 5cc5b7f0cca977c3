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
``~/.cache``). A module's folders with another hash are removed when a new one is made.
"""

from __future__ import annotations

import functools
import hashlib
import os
import shutil
import tempfile
from pathlib import Path

import numba
from numba.core import config as _numba_config

from windnav._source import PACKAGE, ROOT, dotted_name, source_key


def _writable(folder: Path) -> bool:
    try:
        folder.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
    except OSError:
        return False
    return True


def cache_folder(path: str | os.PathLike, root: str | os.PathLike = ROOT) -> Path | None:
    """The folder the kernels of the module at ``path`` are cached in (made, older ones
    removed), or None where no folder is writable (numba then finds its own)."""
    path = Path(path).resolve()
    root = Path(root).resolve()
    name = dotted_name(path, root)
    leaf = f"{name}-{source_key(path, root)}"
    user = os.environ.get("NUMBA_CACHE_DIR")
    xdg = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    checkout = hashlib.sha1(str(root).encode()).hexdigest()[:12]
    bases = [] if user else [path.parent / "__pycache__" / "numba"]
    bases.append(Path(user or xdg) / PACKAGE / checkout)
    for base in bases:
        folder = base / leaf
        if _writable(folder):
            for old in base.glob(f"{name}-*"):
                if old != folder and old.is_dir() and len(old.name) == len(leaf):
                    shutil.rmtree(old, ignore_errors=True)
            return folder
    return None


@functools.lru_cache(maxsize=None)
def _cache_folder_for(path: str) -> str:
    folder = cache_folder(path)
    return "" if folder is None else str(folder)


def njit(**options):
    """``numba.njit(**options)``; with ``cache=True`` the cache is :func:`cache_folder`'s."""
    if not options.get("cache"):
        return numba.njit(**options)

    def decorate(func):
        folder = _cache_folder_for(func.__code__.co_filename)
        saved = _numba_config.CACHE_DIR
        try:
            if folder:
                _numba_config.CACHE_DIR = folder
            return numba.njit(**options)(func)
        finally:
            _numba_config.CACHE_DIR = saved

    return decorate
