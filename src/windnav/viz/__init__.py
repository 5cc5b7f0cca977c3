"""Plots and figures (matplotlib, Agg backend).

Every ``plot_*(..., path)`` of this package checks its arguments before it draws anything:
:func:`check_result` that the result it draws holds what the function reads (naming the
function whose result it should be) and :func:`figure_path` that ``path`` can be written, the
file it names being the one returned.
"""

from __future__ import annotations

import os
from collections.abc import Iterable, Mapping
from pathlib import Path

__all__ = ["check_result", "figure_path"]


def figure_path(path, where: str, formats=None) -> Path:
    """The file ``matplotlib``'s ``savefig`` writes for ``path``, its folder made if need be.

    As ``savefig`` does, a ``path`` without a suffix (``"fig"``, ``"fig."``, an existing
    folder ``"out"``) gains ``rcParams["savefig.format"]``'s (``"fig.png"``, ``"out.png"``);
    a path with one is kept as it is. (The plotters returned ``path`` as given, a file that was
    not written, and a missing folder or a suffix no backend writes failed only after the whole
    figure was drawn; Python API audit, fifty-eighth session.)

    Raises
    ------
    ValueError
        Naming ``path`` of ``where``: not a path, a suffix matplotlib cannot write (its
        ``FigureCanvasBase.get_supported_filetypes``), a file that is an existing folder, or a
        folder that cannot be made. ``formats`` (e.g. ``("png",)``): the suffixes a plotter
        that writes its own bytes (a 128-colour PNG) takes, instead of matplotlib's.
    """
    import matplotlib
    from matplotlib.backend_bases import FigureCanvasBase

    try:
        name = os.fspath(path)
    except TypeError:
        name = None
    if not isinstance(name, str) or not name:
        raise ValueError(f"The 'path' parameter of {where} must be a file path (str or "
                         f"path-like). Got {path!r} instead.")
    fmt = os.path.splitext(name)[1][1:]
    if not fmt:  # savefig's own rule (FigureCanvasBase.print_figure)
        fmt = matplotlib.rcParams["savefig.format"]
        name = name.rstrip(".") + "." + fmt
    own = formats is not None  # (a .svg of PNG bytes passed before; review)
    formats = tuple(formats) if own else FigureCanvasBase.get_supported_filetypes()
    if fmt.lower() not in formats:
        raise ValueError(f"The 'path' parameter of {where} must end in a suffix "
                         f"{where if own else 'matplotlib'} writes, one of {sorted(formats)} "
                         "(none: "
                         f"'.{matplotlib.rcParams['savefig.format']}'). Got {path!r} instead.")
    out = Path(name)
    if out.is_dir():
        raise ValueError(f"The 'path' parameter of {where} must name a file, not an existing "
                         f"folder. Got {path!r} instead.")
    try:
        out.parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        why = f"{exc.strerror}: {exc.filename!r}" if exc.strerror else str(exc)
        raise ValueError(f"The 'path' parameter of {where} must be in a folder that exists or "
                         f"can be made ({why}). Got {path!r} instead.") from None
    return out


def check_result(result, keys: Iterable[str], where: str, producer: str,
                 name: str = "result") -> None:
    """A ValueError naming ``name`` of ``where`` unless ``result`` is a mapping holding every
    one of ``keys``: what ``where`` reads of a result of ``producer`` (a dotted function name).
    (A plotter given another result, or ``{}``, raised a bare KeyError after opening its figure;
    Python API audit, fifty-eighth session.)"""
    if not isinstance(result, Mapping):
        raise ValueError(f"The {name!r} parameter of {where} must be {producer}'s result (a "
                         f"dict). Got a {type(result).__name__} instead.")
    missing = [k for k in keys if k not in result]
    if missing:
        raise ValueError(f"The {name!r} parameter of {where} must be {producer}'s result, "
                         f"with the keys {missing}. Got one with the keys "
                         f"{sorted(map(str, result))} instead.")
