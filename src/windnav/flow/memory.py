"""How much memory a flow run needs, estimated before anything is allocated.

A map too large for the machine (20 km at ``dx = 1`` m is 4e8 cells) must be refused with a
clear error at the call, not after minutes of allocation with a ``MemoryError`` (or the kernel's
out-of-memory killer). :func:`check_flow_memory` compares :func:`estimate_flow_memory` with a
limit and raises :class:`MemoryEstimateError` naming both.

The model (bytes; ``N`` cells, ``N_f`` fluid cells, ``B`` inlet speeds stepped together, ``T``
recorded frames per speed)::

    peak = BYTES_PER_FACTOR_NNZ * nnz(N_f)          the pressure factorisation (exact solver)
         + B * N * (BYTES_PER_RUN_CELL + 16 T)      fields, scratch and frames of each speed
    nnz(N_f) = N_f * max(4, 6.2 log2(N_f) - 46)     fill of the red-black Schur factor

Calibration (this machine, Linux, peak resident set measured in a fresh process by resetting
``VmHWM`` through ``/proc/self/clear_refs`` before :func:`~windnav.flow.simulate_batch` and
reading it after; maps of 200^2 to 1200^2 cells, 58 % to 99 % fluid, 1 to 3 speeds, 0 or 20
frames; the JIT warmed first):

- ``nnz``: the factor's nonzeros per fluid cell on an open domain (the worst case: buildings
  cut the fill) were 22.5, 37.9, 54.8, 66.0, 74.6, 80.4 at 2.5e3, 2.2e4, 8.9e4, 2.5e5, 9.9e5,
  1.9e6 fluid cells; the line above gives them to within -5 % / +15 %. MMD fill grows slightly
  faster than ``N log N``, so extrapolating far beyond 2e6 cells is an estimate, not a bound.
- ``BYTES_PER_FACTOR_NNZ``: the factor kept (values, indices, supernode structure) plus the
  matrices it is built from and SuperLU's transient workspace came to 15 to 22 B per nonzero.
  That was SuperLU's LU. CHOLMOD's Cholesky (the default since) keeps only ``L``: recalibrated
  on 2026-11-23 at 200^2, 300^2, 500^2 and 800^2 (one speed) the factor part came to 8 to 11 B
  per estimated nonzero, so the constant is now 12 (the estimate is 1.05 to 1.39 times the
  measured peak over those maps and the 250^2, 2-speed, 10-frame case of the tests).
- ``BYTES_PER_RUN_CELL``: each additional speed added 222 to 225 B per cell (velocity faces and
  their copies, advection and diffusion scratch, eddy viscosity, diffusion weights, the
  half-window means, the solution's arrays).
- 500 x 500 cells, one speed, with CHOLMOD: measured 189 MB, estimated 240 MB (SuperLU's LU:
  279.5 MB measured). The estimate errs on the side of refusing.

The default limit is :data:`DEFAULT_FRACTION` of the machine's memory (the smaller of the
physical memory and a cgroup limit), or the ``WINDNAV_MEMORY_LIMIT`` environment variable
(bytes, or with a suffix: ``"8G"``, ``"512MB"``, ``"1.5TiB"``); a ``memory_limit`` argument
overrides both. The limit applies to one run: the sweep divides it among its workers.
"""

from __future__ import annotations

import math
import os
import re

import numpy as np

__all__ = [
    "BYTES_PER_FACTOR_NNZ",
    "BYTES_PER_RUN_CELL",
    "DEFAULT_FRACTION",
    "ENV_VAR",
    "PROCESS_BASELINE_BYTES",
    "MemoryEstimateError",
    "check_city_memory",
    "check_flow_memory",
    "default_memory_limit",
    "estimate_flow_memory",
    "factor_nnz",
    "fluid_fraction",
    "format_bytes",
    "parse_bytes",
    "refuse_above_limit",
]

BYTES_PER_FACTOR_NNZ = 12
"""Bytes per estimated nonzero of the pressure factor (see the module docstring)."""
BYTES_PER_RUN_CELL = 250
"""Bytes per cell of each inlet speed's fields and scratch (see the module docstring)."""
BYTES_PER_JACOBI_CELL = 48
"""Bytes per cell of the Jacobi projection's iterates and weights (no factorisation)."""
BYTES_PER_FRAME_CELL = 16
"""Bytes per cell of one recorded frame: ``u`` and ``v`` in float64."""
PROCESS_BASELINE_BYTES = 200_000_000
"""Resident memory of a worker process once the solver is imported (measured 180 MB), bytes."""
DEFAULT_FRACTION = 0.75
"""Share of the machine's memory one run may use by default."""
ENV_VAR = "WINDNAV_MEMORY_LIMIT"
"""Environment variable that sets the default limit (bytes, or e.g. ``"8G"``)."""

_UNITS = {"": 1, "K": 1e3, "M": 1e6, "G": 1e9, "T": 1e12,
          "KI": 2**10, "MI": 2**20, "GI": 2**30, "TI": 2**40}


class MemoryEstimateError(ValueError):
    """A flow run would need more memory than the limit allows (refused before allocating)."""


def factor_nnz(n_fluid: int) -> float:
    """Estimated nonzeros of the pressure factor of a map with ``n_fluid`` fluid cells."""
    n = max(float(n_fluid), 2.0)
    return n * max(4.0, 6.2 * math.log2(n) - 46.0)


def estimate_flow_memory(
    shape,
    n_speeds: int = 1,
    n_frames: int = 0,
    *,
    fluid_fraction: float = 1.0,
    pressure: str = "exact",
) -> int:
    """Peak memory, bytes, that one :func:`~windnav.flow.simulate_batch` call allocates.

    Parameters
    ----------
    shape : tuple of int
        ``(ny, nx)`` cells of the solver grid (:func:`windnav.city.grid_shape`).
    n_speeds : int, default 1
        Inlet speeds stepped together (one per :func:`~windnav.flow.simulate`).
    n_frames : int, default 0
        Frames recorded per speed (``steps // record_every``).
    fluid_fraction : float, default 1.0
        Share of the cells outside buildings, in (0, 1] (1: the conservative open domain).
    pressure : {"exact", "jacobi"}
        The projection: ``exact`` factorises (the dominant term on large maps).

    Returns
    -------
    int
        Estimated bytes above what the process held before the call (see the module
        docstring for the model and its calibration).
    """
    ny, nx = (int(s) for s in shape)
    cells = float(ny) * float(nx)
    frac = min(max(float(fluid_fraction), 0.0), 1.0)
    if pressure == "exact":
        solve = BYTES_PER_FACTOR_NNZ * factor_nnz(frac * cells)
    else:
        solve = BYTES_PER_JACOBI_CELL * cells
    per_run = cells * (BYTES_PER_RUN_CELL + BYTES_PER_FRAME_CELL * int(n_frames))
    return int(math.ceil(solve + int(n_speeds) * per_run))


def fluid_fraction(city, samples: int = 256) -> float:
    """Share of ``city``'s area outside buildings, from a raster of at most ``samples`` cells
    a side (cheap on any map size; the solver's own mask may differ by a cell per edge)."""
    x0, x1, y0, y1 = (float(b) for b in city.bounds)
    xs = x0 + (np.arange(samples) + 0.5) * (x1 - x0) / samples
    ys = y0 + (np.arange(samples) + 0.5) * (y1 - y0) / samples
    solid = np.asarray(city.rasterize(xs, ys), dtype=bool)
    return float(max(1.0 - solid.mean(), 1.0 / solid.size))


def parse_bytes(text, name: str = ENV_VAR, where: str = "the environment") -> int:
    """``"8G"``, ``"512MB"``, ``"1.5TiB"`` or ``"8e9"`` as bytes (> 0); a named ValueError else."""
    m = re.fullmatch(r"\s*([0-9.]+(?:[eE][+-]?[0-9]+)?)\s*([kKmMgGtT]?[iI]?)[bB]?\s*", str(text))
    value = float(m.group(1)) * _UNITS[m.group(2).upper()] if m else math.nan
    if not (math.isfinite(value) and value > 0):
        raise ValueError(
            f"The {name!r} setting of {where} must be a number of bytes > 0, optionally with a "
            f"unit (e.g. 8000000000, 8G, 512MB, 1.5TiB). Got {text!r} instead."
        )
    return int(value)


def _machine_memory() -> int | None:
    """The smaller of the physical memory and this process's cgroup limit, bytes."""
    found = []
    try:
        found.append(os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (AttributeError, ValueError, OSError):
        pass
    for path in ("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory/memory.limit_in_bytes"):
        try:
            with open(path) as f:
                text = f.read().strip()
        except OSError:
            continue
        if text.isdigit() and 0 < int(text) < 2**60:  # "max" or a huge number: no limit
            found.append(int(text))
    return min(found) if found else None


def default_memory_limit() -> int | None:
    """The limit a run gets when none is given, bytes (None when it cannot be found).

    ``WINDNAV_MEMORY_LIMIT`` when set; otherwise :data:`DEFAULT_FRACTION` of the machine's
    memory (physical, or the cgroup limit when lower).
    """
    text = os.environ.get(ENV_VAR, "").strip()
    if text:
        return parse_bytes(text)
    total = _machine_memory()
    return int(DEFAULT_FRACTION * total) if total else None


def format_bytes(n: float) -> str:
    """``n`` bytes in decimal units, e.g. ``"4.9 GB"``."""
    for unit, scale in (("TB", 1e12), ("GB", 1e9), ("MB", 1e6), ("kB", 1e3)):
        if abs(n) >= scale:
            return f"{n / scale:.3g} {unit}"
    return f"{int(n)} B"


def _limit_from(memory_limit, where: str) -> tuple[int | None, str]:
    if memory_limit is None:
        limit = default_memory_limit()
        if os.environ.get(ENV_VAR, "").strip():
            return limit, f"set by {ENV_VAR}"
        return limit, f"{DEFAULT_FRACTION:.0%} of this machine's memory"
    try:
        limit = float(memory_limit)
    except (TypeError, ValueError):
        limit = math.nan
    if isinstance(memory_limit, bool) or not (limit > 0):  # also refuses NaN
        raise ValueError(
            f"The 'memory_limit' parameter of {where} must be a number of bytes > 0 (or None "
            f"for the default). Got {memory_limit!r} instead."
        )
    return (None if math.isinf(limit) else int(limit)), "given as memory_limit"


def check_flow_memory(
    shape,
    n_speeds: int = 1,
    n_frames: int = 0,
    *,
    fluid_fraction: float = 1.0,
    pressure: str = "exact",
    memory_limit: float | None = None,
    where: str = "check_flow_memory",
    what: str | None = None,
) -> int:
    """Refuse a run whose :func:`estimate_flow_memory` exceeds the memory limit.

    Parameters
    ----------
    shape, n_speeds, n_frames, fluid_fraction, pressure
        As in :func:`estimate_flow_memory`.
    memory_limit : float, optional
        The limit, bytes (``math.inf``: no limit). Default: :func:`default_memory_limit`.
    where : str
        The public function on whose behalf the check runs (named in the message).
    what : str, optional
        What is being run, for the message (default: the grid, speeds and frames).

    Returns
    -------
    int
        The estimate, bytes.

    Raises
    ------
    MemoryEstimateError
        When the estimate is above the limit; the message gives both and how to raise the limit.
    ValueError
        On a ``memory_limit`` that is not a positive number.
    """
    limit, source = _limit_from(memory_limit, where)
    need = estimate_flow_memory(shape, n_speeds, n_frames, fluid_fraction=fluid_fraction,
                                pressure=pressure)
    if limit is not None and need > limit:
        ny, nx = (int(s) for s in shape)
        what = what or (f"a grid of {ny} x {nx} cells, {int(n_speeds)} speed(s), "
                        f"{int(n_frames)} frame(s) each")
        raise MemoryEstimateError(
            f"{where}: {what} needs an estimated {format_bytes(need)} of memory, above the limit "
            f"of {format_bytes(limit)} ({source}). Use a larger dx, a smaller map, fewer speeds "
            f"or frames at once, or raise the limit with the 'memory_limit' parameter (bytes) "
            f"or the {ENV_VAR} environment variable."
        )
    return need


def refuse_above_limit(need: float, where: str, what: str, advice: str) -> None:
    """Raise :class:`MemoryEstimateError` when ``need`` (bytes, an estimate) exceeds the default
    limit (:func:`default_memory_limit`): "``where``: ``what`` needs ... ``advice``, or raise
    the limit" (for estimates other than the flow's: ``fly``'s records, a route's graph)."""
    limit, source = _limit_from(None, where)
    if limit is not None and need > limit:
        raise MemoryEstimateError(
            f"{where}: {what} needs an estimated {format_bytes(need)} of memory, above the "
            f"limit of {format_bytes(limit)} ({source}). {advice}, or raise {ENV_VAR}.")


def check_city_memory(
    city,
    dx: float,
    n_speeds: int = 1,
    n_frames: int = 0,
    *,
    pressure: str = "exact",
    memory_limit: float | None = None,
    where: str = "simulate_batch",
) -> int:
    """:func:`check_flow_memory` for the solver grid of ``city`` at spacing ``dx`` (m).

    Cheap on any map size: the grid shape is arithmetic and the fluid fraction a coarse raster.
    """
    from windnav.city import grid_shape

    return check_flow_memory(grid_shape(city.bounds, dx), n_speeds, n_frames,
                             fluid_fraction=fluid_fraction(city), pressure=pressure,
                             memory_limit=memory_limit, where=where)
