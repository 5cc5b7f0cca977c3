"""Deprecated package attributes: names that moved to a private module keep working, warning."""

from __future__ import annotations

import importlib
import warnings


def moved_attributes(package: str, moved: dict[str, str]):
    """A module ``__getattr__`` serving ``moved`` (name -> module now holding it) with a
    DeprecationWarning; other unknown names raise AttributeError as usual."""

    def __getattr__(name: str):
        if name not in moved:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        warnings.warn(f"{package}.{name} is deprecated; import it from {moved[name]}.",
                      DeprecationWarning, stacklevel=2)
        return getattr(importlib.import_module(moved[name]), name)

    return __getattr__
