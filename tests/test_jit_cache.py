"""Numba's on-disk cache follows the source a kernel depends on (``windnav._jit``).

Numba stamps a cached kernel with its own file only: a kernel calling a jitted function of
another module kept running the old machine code after that module changed (cache audit,
2026-12-06). ``windnav._jit.njit`` keys the cache folder by the whole import closure.
"""

from __future__ import annotations

import os
import shutil
import subprocess
import sys
import time
from pathlib import Path

import pytest

from windnav import _jit, _source

SRC = Path(_jit.__file__).resolve().parent


def _package(tmp_path: Path) -> Path:
    root = tmp_path / "windnav"
    (root / "sub").mkdir(parents=True)
    (root / "__init__.py").write_text("")
    (root / "sub" / "__init__.py").write_text("")
    (root / "sub" / "consts.py").write_text("SCALE = 2.0\n")
    (root / "sub" / "helper.py").write_text("from .consts import SCALE\n")
    (root / "unrelated.py").write_text("X = 1\n")
    (root / "kernel.py").write_text(
        "import numpy as np\n"
        "from windnav.sub import (\n    helper,\n)\n"
        "from windnav import unrelated as _u  # noqa\n"
        "import windnav.sub.consts\n"
    )
    return root


def test_the_closure_follows_absolute_relative_parenthesised_and_submodule_imports(tmp_path):
    root = _package(tmp_path)
    got = {p.relative_to(root).as_posix() for p in _source.source_closure(root / "kernel.py", root)}
    assert got == {"kernel.py", "sub/__init__.py", "sub/helper.py", "sub/consts.py",
                   "unrelated.py", "__init__.py"}


def test_the_key_changes_with_a_dependency_and_not_with_a_file_outside_the_closure(tmp_path):
    root = _package(tmp_path)
    (root / "other.py").write_text("Y = 1\n")
    key = _source.source_key(root / "kernel.py", root)
    (root / "other.py").write_text("Y = 2\n")
    assert _source.source_key(root / "kernel.py", root) == key
    (root / "sub" / "consts.py").write_text("SCALE = 3.0\n")
    assert _source.source_key(root / "kernel.py", root) != key


def test_the_real_kernels_closures_hold_their_jitted_dependencies():
    closure = {p.relative_to(SRC).as_posix()
               for p in _source.source_closure(SRC / "plan" / "_kernels.py")}
    assert {"plan/_kernels.py", "plan/_random.py", "_jit.py"} <= closure
    closure = {p.relative_to(SRC).as_posix()
               for p in _source.source_closure(SRC / "vehicle" / "dynamics.py")}
    assert {"vehicle/layout.py", "vehicle/rotation.py", "vehicle/params.py"} <= closure


_PROBE = """
from windnav._probe_a import calls
value = calls()
print(value, sum(calls.stats.cache_hits.values()), calls.stats.cache_path)
"""


def _run(src: Path, env: dict) -> tuple[float, int, str]:
    out = subprocess.run([sys.executable, "-c", _PROBE], cwd=src.parent, env=env,
                         capture_output=True, text=True, check=True)
    value, hits, path = out.stdout.split()
    return float(value), int(hits), path


@pytest.mark.parametrize("user_dir", [False, True], ids=["beside-the-package", "NUMBA_CACHE_DIR"])
def test_editing_a_jitted_dependency_in_another_file_recompiles_its_caller(tmp_path, user_dir):
    src = tmp_path / "src"
    shutil.copytree(SRC, src / "windnav", ignore=shutil.ignore_patterns("__pycache__"))
    pkg = src / "windnav"
    (pkg / "_probe_b.py").write_text(
        "from windnav._jit import njit\n\n\n@njit(cache=True)\ndef value():\n    return 1.0\n")
    (pkg / "_probe_a.py").write_text(
        "from windnav._jit import njit\nfrom windnav._probe_b import value\n\n\n"
        "@njit(cache=True)\ndef calls():\n    return value() + 0.5\n")
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["PYTHONPATH"] = str(src)
    env["XDG_CACHE_HOME"] = str(tmp_path / "xdg")
    if user_dir:
        env["NUMBA_CACHE_DIR"] = str(tmp_path / "numba-cache")
    first = _run(src, env)
    again = _run(src, env)
    assert first[:2] == (1.5, 0)
    assert again[:2] == (1.5, 1), "the second run must load the cached kernel"
    base = Path(env["NUMBA_CACHE_DIR"]) if user_dir else pkg / "__pycache__" / "numba"
    assert Path(again[2]).is_relative_to(base)
    (pkg / "_probe_b.py").write_text(
        "from windnav._jit import njit\n\n\n@njit(cache=True)\ndef value():\n    return 2.0\n")
    edited = _run(src, env)
    assert edited[:2] == (2.5, 0), "the caller ran the old callee's cached code"
    old = Path(again[2]).parent                    # the older code's folder: a process still
    assert old.is_dir()                            # running it may write there, so it stays
    day_ago = time.time() - 2 * 86400.0            # until untouched for a day
    for dirpath, _, files in os.walk(old):
        for f in [*files, "."]:
            os.utime(os.path.join(dirpath, f), (day_ago, day_ago))
    assert _run(src, env)[:2] == (2.5, 1)
    assert not old.exists(), "the stale folder is removed"


def test_every_cached_kernel_goes_through_windnav_jit():
    direct = [str(p.relative_to(SRC)) for p in SRC.rglob("*.py")
              if p.name != "_jit.py"
              and any(s in p.read_text()
                      for s in ("numba.njit(", "numba.jit(", "from numba import"))]
    assert direct == []


def _probe_package(tmp_path: Path) -> tuple[Path, dict]:
    src = tmp_path / "src"
    shutil.copytree(SRC, src / "windnav", ignore=shutil.ignore_patterns("__pycache__"))
    (src / "windnav" / "_probe_b.py").write_text(
        "from windnav._jit import njit\n\n\n@njit(cache=True)\ndef value():\n    return 1.0\n")
    (src / "windnav" / "_probe_a.py").write_text(
        "from windnav._jit import njit\nfrom windnav._probe_b import value\n\n\n"
        "@njit(cache=True)\ndef calls():\n    return value() + 0.5\n")
    env = {k: v for k, v in os.environ.items() if k != "NUMBA_CACHE_DIR"}
    env["PYTHONPATH"] = str(src)
    env["XDG_CACHE_HOME"] = str(tmp_path / "xdg")
    return src, env


def test_a_dependency_edited_after_windnav_was_imported_compiles_without_the_cache(tmp_path):
    """The hash reads the files when a kernel is decorated, which can be after Python loaded
    a dependency: an edit in between was cached under the new hash with the old code (jit
    audit: 1.5 for 2.5 in every later run). Such a kernel now compiles without the cache."""
    src, env = _probe_package(tmp_path)
    code = ("import pathlib, windnav\n"
            "b = pathlib.Path(windnav.__file__).with_name('_probe_b.py')\n"
            "import windnav._probe_b\n"                          # loaded: value() is 1.0
            "b.write_text(b.read_text().replace('1.0', '2.0'))\n"  # edited afterwards
            "from windnav._probe_a import calls\n"
            "print(calls(), calls.stats.cache_path)\n")
    out = subprocess.run([sys.executable, "-c", code], cwd=src.parent, env=env,
                         capture_output=True, text=True, check=True).stdout.split()
    assert out == ["1.5", "None"]                                # its own code, not cached
    assert _run(src, env)[:2] == (2.5, 0)                         # the next process: edited


def test_an_unwritable_numba_cache_dir_falls_back_to_the_users_keyed_cache(tmp_path):
    """NUMBA_CACHE_DIR that cannot be written left the choice to numba, whose cache is not
    keyed by the closure (jit audit); the user's cache folder is tried before that."""
    src, env = _probe_package(tmp_path)
    (tmp_path / "a_file").write_text("")
    env["NUMBA_CACHE_DIR"] = str(tmp_path / "a_file" / "cache")  # no folder can be made there
    first = _run(src, env)
    assert first[:2] == (1.5, 0)
    assert Path(first[2]).is_relative_to(tmp_path / "xdg" / "windnav")
    assert _run(src, env)[:2] == (1.5, 1)


def test_a_function_outside_the_package_is_cached_as_numba_does(tmp_path):
    from windnav._jit import njit

    script = tmp_path / "user.py"
    script.write_text("def f(x):\n    return x + 1\n")
    namespace = {}
    exec(compile(script.read_text(), str(script), "exec"), namespace)
    assert njit(cache=False)(namespace["f"])(1) == 2
    assert njit(cache=True)(namespace["f"])(2) == 3              # no ValueError on its path


def test_no_kernel_module_imports_by_name_at_run_time():
    """The closure is read from import statements: a kernel module that imported a windnav
    module with importlib or __import__ would hide that dependency from it (importing a third
    party, as pressure.py does cholespy, is no dependency of the hash)."""
    import re

    by_name = re.compile(r"(?:import_module|__import__)\(\s*f?[\"']windnav|"
                         r"(?:import_module|__import__)\(\s*[A-Za-z_]")
    kernels = [p for p in SRC.rglob("*.py") if "@njit(" in p.read_text()]
    assert kernels
    found = {str(p.relative_to(SRC)): by_name.findall(p.read_text()) for p in kernels}
    # pressure.py's one call takes a name given by its caller: the third-party cholespy
    assert {k: set(v) for k, v in found.items() if v} == {"flow/pressure.py": {"import_module(n"}}


def test_the_closure_scan_reads_continued_commented_and_one_line_statements(tmp_path):
    root = _package(tmp_path)
    (root / "sub" / "extra.py").write_text("Z = 1\n")
    (root / "sub" / "more.py").write_text("W = 1\n")
    (root / "k2.py").write_text(
        "from windnav.sub import \\\n    extra\n"
        "from windnav.sub import (  # a comment with ) in it\n    more,\n)\n"
        "try: from windnav import unrelated\nexcept ImportError: pass\n")
    got = {p.relative_to(root).as_posix() for p in _source.source_closure(root / "k2.py", root)}
    assert {"sub/extra.py", "sub/more.py", "unrelated.py"} <= got
    (root / "k3.py").write_text("import windnav as wn\n\n\ndef f():\n    return wn.sub.extra.Z\n")
    got = {p.relative_to(root).as_posix() for p in _source.source_closure(root / "k3.py", root)}
    assert "sub/extra.py" in got                              # an alias's attribute chain


def test_a_file_changed_after_windnav_was_imported_is_said(tmp_path, monkeypatch):
    """The hash describes the files on disk; once one changed after windnav was imported,
    the code running may be the older one: module_key then says "-modified" (review)."""
    import windnav

    root = _package(tmp_path)
    old = windnav.IMPORTED_NS / 1e9 - 60.0                 # before this process imported it
    for f in root.rglob("*.py"):
        os.utime(f, (old, old))
    assert not _source.changed_since_import(root / "kernel.py", root)
    (root / "sub" / "consts.py").write_text("SCALE = 4.0\n")        # now, after the import
    assert _source.changed_since_import(root / "kernel.py", root)
    key = _source._cached_key(str(SRC / "flow" / "solver.py"))
    monkeypatch.setattr(_source, "changed_since_import", lambda path, root=None: False)
    assert _source.module_key("windnav.flow.solver") == key
    monkeypatch.setattr(_source, "changed_since_import", lambda path, root=None: True)
    assert _source.module_key("windnav.flow.solver") == key + "-modified"


def test_numbas_own_cache_files_of_the_old_layout_are_removed(tmp_path, monkeypatch):
    """The in-tree files numba wrote before the cache was keyed (about 12 MB in a developer's
    checkout) were never read again nor removed (review): a module's go when its keyed folder
    is made beside it; one that cannot be removed is left (a read-only install)."""
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    root = _package(tmp_path)
    cache = root / "__pycache__"
    cache.mkdir()
    old = [cache / "kernel.f-3.py311.nbi", cache / "kernel.f-3.py311.1.nbc"]
    other = cache / "unrelated.g-1.py311.nbi"
    for f in (*old, other):
        f.write_bytes(b"x")
    folder = _jit.cache_folder(root / "kernel.py", root)
    assert folder is not None and folder.is_relative_to(cache / "numba")
    assert not any(f.exists() for f in old) and other.exists()
    kept = cache / "unrelated.g-1.py311.1.nbc"
    kept.write_bytes(b"x")

    def refuse(self, missing_ok=False):
        raise PermissionError(f"read-only: {self}")

    monkeypatch.setattr(Path, "unlink", refuse)
    _jit._remove_old_layout(root / "unrelated.py")             # no error: the files stay
    assert kept.exists()
