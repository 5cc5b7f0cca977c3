"""Load a script of the repository that is not part of the package (``benchmarks/``,
``docs/data/``) as a module, for the tests of its functions."""

from __future__ import annotations

import importlib.util
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def load_script(relative_path: str):
    """The module of the file at ``relative_path`` from the repository root, executed afresh
    under its file name's stem."""
    path = ROOT / relative_path
    spec = importlib.util.spec_from_file_location(path.stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module
