"""windnav: real-time local wind inference and wind-aware navigation for small multirotors.

Subpackages follow the data flow of ``DESIGN.md``::

    city -> flow -> wind -> vehicle -> control -> sensors -> sim -> estimate -> predict -> plan

beside them ``sysid`` (system identification: data files to vehicle coefficients, on
``vehicle`` and ``sim``), and the harnesses ``experiments`` and ``viz`` on top. They are
imported lazily (``import windnav as wn; wn.vehicle.params(...)``) so that ``import windnav``
stays cheap. None of them loads torch: only training the decoder
(:mod:`windnav.predict.train`, the ``train`` extra) does.
"""

from __future__ import annotations

import importlib
import time

IMPORTED_NS = time.time_ns()
"""When windnav was first imported in this process (ns since the epoch): every windnav module
it runs was read from disk after this (``windnav._jit`` compares source files' times with it)."""

__version__ = "0.1.0"

_SUBPACKAGES = (
    "city",
    "flow",
    "wind",
    "vehicle",
    "control",
    "sensors",
    "sim",
    "estimate",
    "predict",
    "plan",
    "sysid",
    "experiments",
    "viz",
)

__all__ = list(_SUBPACKAGES) + ["__version__"]


def __getattr__(name: str):
    if name in _SUBPACKAGES:
        module = importlib.import_module(f"{__name__}.{name}")
        globals()[name] = module
        return module
    raise AttributeError(f"module 'windnav' has no attribute {name!r}")


def __dir__():
    return sorted(__all__)
