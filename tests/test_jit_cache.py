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
    assert not Path(again[2]).exists(), "the stale folder is removed"
    assert _run(src, env)[:2] == (2.5, 1)


def test_every_cached_kernel_goes_through_windnav_jit():
    direct = [str(p.relative_to(SRC)) for p in SRC.rglob("*.py")
              if p.name != "_jit.py"
              and any(s in p.read_text()
                      for s in ("numba.njit(", "numba.jit(", "from numba import"))]
    assert direct == []
