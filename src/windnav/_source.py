"""The windnav source files a module depends on, and a hash of them.

A result computed by windnav code (a compiled kernel, a cached flow, a stored simulation)
stays valid while that code is unchanged. :func:`source_closure` finds a module's code: its
file and every windnav module it imports, directly or through others, read from the import
statements' text (lazy imports inside functions included; a superset where a statement is
never run). :func:`source_key` hashes their contents, :func:`module_key` by module name.
"""

from __future__ import annotations

import functools
import hashlib
import os
import re
from pathlib import Path

PACKAGE = "windnav"
ROOT = Path(__file__).resolve().parent

SOLVER_MODULE = "windnav.flow.solver"
"""The module whose closure names the flow solver's code: the ``solver_code`` of a cached flow
(:mod:`windnav.experiments.decoder_eval`) and of a sweep store (:mod:`windnav.flow.sweep_store`)."""

# a statement starts a line, or follows ";" or ":" ("try: from ...", "x = 1; import ...")
_FROM = re.compile(
    r"(?:^|[;:])[ \t]*from[ \t]+(\.+[\w.]*|windnav(?:\.[\w.]+)?)[ \t]+import[ \t]+"
    r"(\([^)]*\)|[^\n;]+)",
    re.MULTILINE,
)
_IMPORT = re.compile(r"(?:^|[;:])[ \t]*import[ \t]+([^\n;]+)", re.MULTILINE)
_PLAIN = re.compile(r"(?:^|[;:])[ \t]*import[ \t]+windnav\b", re.MULTILINE)
_CHAIN = re.compile(r"\bwindnav(?:\.[A-Za-z_]\w*)+")
_ALIAS = re.compile(r"(?:^|[;:])[ \t]*import[ \t]+windnav[ \t]+as[ \t]+([A-Za-z_]\w*)",
                    re.MULTILINE)
_COMMENT = re.compile(r"#[^\n]*")


def _statements(text: str) -> str:
    """``text`` with comments removed and backslash continuations joined (a comment's ``)``
    ended a parenthesised import early; a continued line was missed: jit audit)."""
    return _COMMENT.sub("", text).replace("\\\n", " ")


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


def dotted_name(path: Path, root: Path) -> str:
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
    text = _statements(path.read_text(encoding="utf-8"))
    own = dotted_name(path, root)
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
            words = item.split()
            dotted = words[0] if words else ""
            if dotted.startswith(PACKAGE + ".") or dotted == PACKAGE:
                target = _module_file(dotted, root)
                if target is not None:
                    found.add(target)
    chains = set(_CHAIN.findall(text)) if _PLAIN.search(text) else set()
    for alias in set(_ALIAS.findall(text)):  # `import windnav as wn`, then wn.sim.fly
        chains |= {PACKAGE + c[len(alias):] for c in
                   re.findall(rf"\b{alias}(?:\.[A-Za-z_]\w*)+", text)}
    if chains:  # `import windnav(.x)` or an alias, then windnav.a.b.X: each chain named
        for chain in chains:
            parts = chain.split(".")
            while len(parts) > 1:
                target = _module_file(".".join(parts), root)
                if target is not None:
                    found.add(target)
                    break
                parts.pop()
    found.discard(path)
    return frozenset(found)


def source_closure(path: str | os.PathLike, root: str | os.PathLike = ROOT) -> list[Path]:
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


def source_key(path: str | os.PathLike, root: str | os.PathLike = ROOT) -> str:
    """A hash of the contents of :func:`source_closure` ``(path, root)``: 16 hex digits."""
    root = Path(root).resolve()
    digest = hashlib.sha256()
    for file in source_closure(path, root):
        digest.update(str(file.relative_to(root)).encode())
        digest.update(b"\0")
        digest.update(file.read_bytes())
        digest.update(b"\0")
    return digest.hexdigest()[:16]


def module_key(dotted: str) -> str:
    """:func:`source_key` of the windnav module ``dotted`` (e.g. ``"windnav.flow.solver"``),
    with ``"-modified"`` after it where a file of the closure changed after windnav was
    imported: the code this process runs may then not be the code the files hold (review)."""
    path = _module_file(dotted, ROOT)
    if path is None:
        raise ValueError(f"module_key: no windnav module {dotted!r}")
    key = _cached_key(str(path))
    return key + "-modified" if changed_since_import(path) else key


def changed_since_import(path: str | os.PathLike, root: str | os.PathLike = ROOT) -> bool:
    """Whether a file of ``path``'s closure was modified after windnav was imported in this
    process (or cannot be read): every module it runs was read before that time."""
    from windnav import IMPORTED_NS

    try:
        return any(f.stat().st_mtime_ns >= IMPORTED_NS for f in source_closure(path, root))
    except OSError:
        return True


@functools.lru_cache(maxsize=None)
def _cached_key(path: str) -> str:
    return source_key(path)
