"""The package layout of docs/architecture.md, enforced: each subpackage imports only from
the subpackages to its left in the data flow (DESIGN.md), nothing imports the harness or
interface layers, and each subpackage's public API is what its ``__init__`` exports."""

from __future__ import annotations

import ast
import importlib
from pathlib import Path

import pytest

SRC = Path(__file__).resolve().parents[1] / "src" / "windnav"

# the data flow, left to right; a package may import any package to its left
LAYERS = ["_source", "_jit", "_validate", "_extras", "_console", "city", "flow", "wind",
          "vehicle", "control", "sensors", "sim", "estimate", "predict", "plan", "sysid",
          "experiments", "viz", "commands", "cli", "provenance"]

# deliberate exceptions, each with its reason
ALLOWED = {
    # FlowSolution.wind_field() (DESIGN's public contract) wraps the mean field in a
    # GriddedWind; the import is inside the method, so flow does not need wind to load
    ("flow/solver.py", "wind"),
}


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text())
    out = set()
    for node in ast.walk(tree):
        names = []
        if isinstance(node, ast.Import):
            names = [a.name for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names = [node.module]
        out |= {n.split(".")[1] for n in names if n.startswith("windnav.") and "." in n}
    return out


def _modules():
    for path in sorted(SRC.rglob("*.py")):
        rel = path.relative_to(SRC)
        pkg = rel.parts[0] if len(rel.parts) > 1 else rel.stem
        if pkg in LAYERS:
            yield rel, pkg, path


@pytest.mark.parametrize(("rel", "pkg", "path"), list(_modules()), ids=lambda v: str(v))
def test_imports_follow_the_data_flow(rel, pkg, path):
    rank = LAYERS.index(pkg)
    bad = sorted(t for t in _imports(path) - {pkg}
                 if t in LAYERS and LAYERS.index(t) > rank and (str(rel), t) not in ALLOWED)
    assert not bad, f"{rel} ({pkg}) imports {bad}, which lie to its right in {LAYERS}"


def test_every_package_is_placed():
    packages = {p.name for p in SRC.iterdir() if p.is_dir() and (p / "__init__.py").exists()}
    assert packages <= set(LAYERS), f"unplaced packages: {packages - set(LAYERS)}"


@pytest.mark.parametrize("pkg", ["city", "flow", "wind", "vehicle", "control", "sensors",
                                 "sim", "estimate", "plan"])
def test_public_api_has_no_kernels(pkg):
    """Each ``__init__`` exports its public API only: no Numba dispatchers."""
    module = importlib.import_module(f"windnav.{pkg}")
    names = getattr(module, "__all__", [n for n in vars(module) if not n.startswith("_")])
    kernels = [n for n in names
               if type(getattr(module, n, None)).__name__ in ("CPUDispatcher", "Dispatcher")]
    assert not kernels, f"windnav.{pkg} exports Numba kernels {kernels}"


def test_no_module_switches_the_matplotlib_backend():
    """Eleven plotting modules called matplotlib.use("Agg") at import, so a notebook that
    imported one lost its inline backend (packaging audit); the command line sets Agg itself."""
    import subprocess
    import sys

    calls = [str(p.relative_to(SRC)) for p in SRC.rglob("*.py")
             if "matplotlib.use(" in p.read_text() or "mpl.use(" in p.read_text()]
    assert calls == []
    viz = sorted(p.stem for p in (SRC / "viz").glob("*.py") if p.stem != "__init__")
    code = ("import matplotlib; matplotlib.use('svg'); import importlib; "
            + "; ".join(f"importlib.import_module('windnav.viz.{m}')" for m in viz)
            + "; print(matplotlib.get_backend())")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "svg"
