"""RotorPy world JSON in and out (the map format of RotorPy's ``World.from_file``).

Format::

    {"bounds": {"extents": [xmin, xmax, ymin, ymax, zmin, zmax]},
     "blocks": [{"extents": [xmin, xmax, ymin, ymax, zmin, zmax], "color": [r, g, b]}, ...]}

Each block becomes one footprint ``[xmin, xmax, ymin, ymax]`` with ``base_z = zmin`` and
``height = zmax - zmin``. Every other key (block ``"color"``, ``"trainable"``, extra top-level
sections) is kept on the :class:`~windnav.city.core.City` and written back, so reading and
writing a file is lossless: ``json.load`` of the output equals ``json.load`` of the input
(numbers are written as floats, which compare equal to the integers they came from), but
for one addition: a block without a ``"color"`` is written with :data:`DEFAULT_COLOR`, the
grey every block of a generated map gets.

This module is the document layer (JSON text and dictionaries, checked); it does not import
:class:`~windnav.city.core.City`, which builds itself from :func:`parse_rotorpy_doc`
(``City.from_rotorpy_json``, :func:`~windnav.city.core.read_rotorpy_json`). Writing takes any
object with a City's attributes.
"""

from __future__ import annotations

import copy
import json
import math
from pathlib import Path

import numpy as np

# Colour written for blocks that carry none (RotorPy accepts any matplotlib colour).
DEFAULT_COLOR = (0.5, 0.5, 0.5)


def load_rotorpy_doc(path) -> dict:
    """The JSON document of a RotorPy world file.

    Raises
    ------
    FileNotFoundError
        If the file does not exist (the message names it).
    ValueError
        If the path is a folder, or the file is not UTF-8 text or not valid JSON (the message
        names the file).
    """
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"RotorPy world file {str(path)!r} does not exist.")
    if path.is_dir():
        raise ValueError(f"RotorPy world file {str(path)!r} is a folder, not a JSON file.")
    try:
        text = path.read_text(encoding="utf-8-sig")  # a byte-order mark, as editors write
    except UnicodeDecodeError as exc:
        raise ValueError(f"RotorPy world file {str(path)!r} is not UTF-8 text: {exc}") from None
    try:
        return json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"RotorPy world file {str(path)!r} is not valid JSON: {exc}") from None


def write_rotorpy_json(city, path) -> Path:
    """Write ``city`` as RotorPy world JSON.

    Parameters
    ----------
    city : City
        (or any object with its attributes)
    path : str or path-like
        The file to (over)write; parent folders are created.

    Returns
    -------
    Path
        The file written.
    """
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(to_rotorpy_dict(city), indent=2) + "\n")
    return path


def to_rotorpy_dict(city) -> dict:
    """The RotorPy world dictionary of ``city`` (what :func:`write_rotorpy_json` writes)."""
    extras = copy.deepcopy(city.extras)
    bounds = {"extents": [*city.bounds, *city.z_bounds], **extras.pop("bounds", {})}
    attrs = city.block_attrs or ({},) * city.n_buildings
    blocks = []
    for fp, z0, h, a in zip(city.footprints, city.base_z, city.heights, attrs, strict=True):
        block = {"extents": [float(v) for v in fp] + [float(z0), float(z0 + h)]}
        block.update(copy.deepcopy(a))
        block.setdefault("color", list(DEFAULT_COLOR))
        blocks.append(block)
    return {"bounds": bounds, "blocks": blocks, **extras}


def parse_rotorpy_doc(doc) -> dict:
    """The :class:`~windnav.city.core.City` keyword arguments of a RotorPy world dictionary.

    Raises
    ------
    ValueError
        Naming what is missing or malformed (the City checks the blocks themselves).
    """
    if not isinstance(doc, dict):
        raise ValueError(f"the top level must be an object, got {type(doc).__name__}")
    bounds = doc.get("bounds")
    if not isinstance(bounds, dict) or "extents" not in bounds:
        raise ValueError("missing 'bounds': {'extents': [xmin, xmax, ymin, ymax, zmin, zmax]}")
    b = _extents(bounds["extents"], "'bounds.extents'")
    blocks = doc.get("blocks")
    if not isinstance(blocks, list):
        raise ValueError("missing 'blocks': a list of {'extents': [...], 'color': ...}")
    ext = np.empty((len(blocks), 6))
    attrs = []
    for i, block in enumerate(blocks):
        if not isinstance(block, dict) or "extents" not in block:
            raise ValueError(f"block {i} must be an object with 'extents', got {block!r}")
        ext[i] = _extents(block["extents"], f"block {i} 'extents'")
        attrs.append({k: v for k, v in block.items() if k != "extents"})
    extras = {k: copy.deepcopy(v) for k, v in doc.items() if k not in ("bounds", "blocks")}
    rest = {k: copy.deepcopy(v) for k, v in bounds.items() if k != "extents"}
    if rest:
        extras["bounds"] = rest
    return {
        "bounds": b[:4],
        "footprints": ext[:, :4],
        "heights": _exact_heights(ext[:, 4], ext[:, 5]),
        "base_z": ext[:, 4],
        "z_bounds": b[4:],
        "block_attrs": attrs,
        "extras": extras,
    }


def _extents(value, what: str) -> list[float]:
    ok = isinstance(value, list) and len(value) == 6
    ok = ok and all(isinstance(v, int | float) and not isinstance(v, bool) for v in value)
    if not ok or not all(math.isfinite(v) for v in value):
        raise ValueError(f"{what} must be 6 finite numbers [xmin, xmax, ymin, ymax, zmin, zmax], "
                         f"got {value!r}")
    if not (value[0] < value[1] and value[2] < value[3] and value[4] < value[5]):
        raise ValueError(f"{what} {value!r} must have min < max on every axis")
    return [float(v) for v in value]


def _exact_heights(z0: np.ndarray, z1: np.ndarray) -> np.ndarray:
    """Heights ``h`` with ``z0 + h == z1`` exactly in float64 (so the top survives a round trip).

    ``z1 - z0`` is rounded; the exact top is recovered by stepping ``h`` a few ulps.
    """
    h = z1 - z0
    for _ in range(8):
        top = z0 + h
        if np.array_equal(top, z1):
            break
        up, down = np.nextafter(h, np.inf), np.nextafter(h, -np.inf)
        h = np.where(top < z1, up, np.where(top > z1, down, h))
    return h
