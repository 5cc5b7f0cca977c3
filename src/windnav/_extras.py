"""Optional dependencies: which ``windnav[extra]`` installs each, and one check before the work.

A command that needs an optional package says so before it starts (``train-decoder`` ran its
whole flow sweep, 414 simulations with the default recipe, before it failed on a missing torch),
with the extra that installs it.
"""

from __future__ import annotations

import importlib.util

EXTRAS = {"torch": "train", "tensorboard": "train", "optuna": "tune", "ray": "ray",
          "rosbags": "rosbag", "rotorpy": "rotorpy", "filterpy": "test", "pytest": "test",
          "pytorch_mppi": "bench"}
"""The extra of pyproject.toml that installs each optional top-level module."""

TORCH_CPU = ("pip install torch==2.13.0 --index-url https://download.pytorch.org/whl/cpu")
"""PyTorch's CPU build (PyPI's Linux wheel is the CUDA build, several GB)."""


def install_hint(module: str) -> str:
    """How to install the optional ``module`` (a dotted name: its top-level package counts)."""
    top = (module or "").split(".")[0]
    extra = EXTRAS.get(top)
    if extra is None:
        return f"install it with pip (pip install {top})"
    hint = f"install it with pip install 'windnav[{extra}]'"
    if top == "torch" or extra in ("train", "rotorpy", "test", "bench"):
        hint += f" (first the CPU build of torch, unless you want CUDA: {TORCH_CPU})"
    return hint


def installed(module: str) -> bool:
    """Whether the top-level ``module`` can be imported (found without importing it)."""
    return importlib.util.find_spec(module) is not None


def require(module: str, what: str) -> None:
    """Raise ModuleNotFoundError naming ``module``, its extra and ``what`` needs it, unless it
    is :func:`installed`."""
    if not installed(module):
        raise ModuleNotFoundError(
            f"{what} needs the optional dependency {module!r}: {install_hint(module)}",
            name=module)
