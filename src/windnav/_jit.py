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
import re
import shutil
import tempfile
from pathlib import Path

import numba
from numba.core import config as _numba_config

_PACKAGE = "windnav"
_ROOT = Path(__file__).resolve().parent

_FROM = re.compile(
    r"^[ \t]*from[ \t]+(\.+[\w.]*|windnav(?:\.[\w.]+)?)[ \t]+import[ \t]+(\([^)]*\)|[^\n#]+)",
    re.MULTILINE,
)
_IMPORT = re.compile(r"^[ \t]*import[ \t]+([^\n#]+)", re.MULTILINE)


def _module_file(dotted: str, root: Path) -> Path | None:
    """The source file of module ``dotted`` (``windnav.a.b``) under ``root``, or None."""
    parts = dotted.split(".")
    if not parts or parts[0] != root.name:
        return None
    base = root.parent.joinpath(*parts)
    for candidate in (base.with_suffix(".py"), base / "__init__.py"):
        if candidate.is_file():
            return candidate
    return None


def _dotted_name(path: Path, root: Path) -> str:
    rel = path.relative_to(root.parent).with_suffix("")
    parts = list(rel.parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


def _imports(path: Path, root: Path) -> frozenset[Path]:
    """The files under ``root`` that ``path`` imports (by its import statements' text)."""
    stat = path.stat()
    return _imports_of(path, root, stat.st_mtime_ns, stat.st_size)


@functools.lru_cache(maxsize=None)
def _imports_of(path: Path, root: Path, mtime_ns: int, size: int) -> frozenset[Path]:
    text = path.read_text(encoding="utf-8")
    own = _dotted_name(path, root)
    package = own if path.name == "__init__.py" else own.rpartition(".")[0]
    found: set[Path] = set()
    for source, names in _FROM.findall(text):
        if source.startswith("."):
            dots = len(source) - len(source.lstrip("."))
            base = package.split(".")
            base = base[: len(base) - (dots - 1)] if dots > 1 else base
            rest = source.lstrip(".")
            dotted = ".".join(base + ([rest] if rest else []))
        else:
            dotted = source
        target = _module_file(dotted, root)
        if target is not None:
            found.add(target)
        for name in re.split(r"[,\s()]+", names):
            name = name.strip()
            if name and name.isidentifier():
                sub = _module_file(f"{dotted}.{name}", root)
                if sub is not None:
                    found.add(sub)
    for line in _IMPORT.findall(text):
        for item in line.split(","):
            dotted = item.strip().split(" ")[0]
            if dotted.startswith(_PACKAGE + ".") or dotted == _PACKAGE:
                target = _module_file(dotted, root)
                if target is not None:
                    found.add(target)
    found.discard(path)
    return frozenset(found)


def source_closure(path: str | os.PathLike, root: str | os.PathLike = _ROOT) -> list[Path]:
    """``path`` and every file under the package ``root`` it imports, directly or not (sorted)."""
    root = Path(root).resolve()
    start = Path(path).resolve()
    seen = {start}
    todo = [start]
    while todo:
        for target in _imports(todo.pop(), root):
            if target not in seen:
                seen.add(target)
                todo.append(target)
    return sorted(seen)


def source_key(path: str | os.PathLike, root: str | os.PathLike = _ROOT) -> str:
    """A hash of the contents of :func:`source_closure` ``(path, root)``: 16 hex digits."""
    root = Path(root).resolve()
    digest = hashlib.sha256()
    for file in source_closure(path, root):
        digest.update(str(file.relative_to(root)).encode())
        digest.update(b"\0")
        digest.update(file.read_bytes())
        digest.update(b"\0")
    return digest.hexdigest()[:16]


def _writable(folder: Path) -> bool:
    try:
        folder.mkdir(parents=True, exist_ok=True)
        tempfile.TemporaryFile(dir=folder).close()
    except OSError:
        return False
    return True


def cache_folder(path: str | os.PathLike, root: str | os.PathLike = _ROOT) -> Path | None:
    """The folder the kernels of the module at ``path`` are cached in (made, older ones
    removed), or None where no folder is writable (numba then finds its own)."""
    path = Path(path).resolve()
    root = Path(root).resolve()
    name = _dotted_name(path, root)
    leaf = f"{name}-{source_key(path, root)}"
    user = os.environ.get("NUMBA_CACHE_DIR")
    xdg = os.environ.get("XDG_CACHE_HOME") or os.path.join(os.path.expanduser("~"), ".cache")
    checkout = hashlib.sha1(str(root).encode()).hexdigest()[:12]
    bases = [] if user else [path.parent / "__pycache__" / "numba"]
    bases.append(Path(user or xdg) / _PACKAGE / checkout)
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
