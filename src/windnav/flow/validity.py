"""Whether a flow solution lies inside the envelope the solver was checked in (flags only).

Nothing here changes a field, a time step or a step count: these functions read a solution's
averaging diagnostics (:attr:`windnav.flow.FlowSolution.diagnostics`) or a map and a cell size,
and say in words when the result should not be trusted as it is.

**Averaging** (:func:`averaging_verdict`). The mean wind of a run is *converged* when

* the spin-up lasted at least :data:`SPINUP_FLOW_THROUGHS` (1) flow-through of the domain
  (``U t / L``, ``L`` the domain's extent along the wind): the start-up has left the domain;
* the averaging window lasted at least :data:`WINDOW_FLOOR` (0.5) flow-through: a shorter
  window makes the half-window test blind, since its two halves are then a few nearly
  identical snapshots (2 steps of 0.25 s at 5 m/s on a 200 m map: halves 0.000 U apart, but
  0.266 U RMS from the mean of 1600 steps; measured on that map, the halves' difference
  matches the error against the long mean from about 0.25 flow-through on);
* the means of the window's two halves differ by at most :data:`HALVES_LIMIT` (5 %) of the
  inlet speed (RMS over the fluid).

A run that fails only because its spin-up lies between :data:`SPINUP_FLOOR` (0.25) and one
flow-through is a *young* mean (level ``"note"``): the thesis's protocol is of this kind (dx
= 1 m, dt = 0.25 s, 100 spin-up + 200 averaged steps at 10 m/s over 600 m maps: spin-up 0.42
and window 0.83 flow-throughs along an axis, 0.29 and 0.59 along a diagonal). Anything else
that fails is *not converged* (level ``"warning"``).

**Resolution** (:func:`resolution_check`). The closure's filter is tied to the buildings,
``max(dx, s / 8)`` with ``s`` the median building's smaller side, and the grid independence
was shown for ``dx <= s / 8`` only (docs/flow_validation.md): a coarser cell is accepted, with
the note that the results are grid-dependent.

**Blockage** (:func:`blockage`, since the fifty-second session). The map is the whole 2D
domain: the wind cannot pass over the buildings or around the map. For a wind along a map axis
the two sides parallel to it carry no flux, so every cross-section carries the inlet's, and
one that the buildings close by a share ``b`` has a mean wind ``1 / (1 - b)`` times the
inlet's through the rest (measured on ``planning_map(rng=3, size=200.0, n_buildings=6)`` at
5 m/s toward 0 deg: its most blocked column, 36 % closed, carries 7.8125 m/s, and every
column's flux is the inlet's to 1e-14 relative). For an oblique wind the sides exchange flux
and the share is geometry only: it does not give the mean (on the 300 m city of
docs/navigation.md at 5 m/s, 25 s of spin-up and 50 s averaged: toward 0 deg its section 33.0 %
closed carries 1.4925 x the inlet's along the wind, as 1 / 0.67 says; toward 30 deg the section
36.6 % closed carries 1.32 x, not 1.58 x; the second review of the fifty-second session).
Closed along an axis: the thesis suite's 16 planning maps 8-19 % (median 13 %), the windinet
layout 16-18 %, the decoder's dense evaluation maps 49-61 % (a mean 2.2-2.6 x the inlet's
through a section): a confinement an open city does not have.
"""

from __future__ import annotations

import math

__all__ = ["HALVES_LIMIT", "SPINUP_FLOOR", "SPINUP_FLOW_THROUGHS", "WINDOW_FLOOR",
           "averaging_message", "averaging_verdict", "blockage", "resolution_check",
           "validated_dx"]

SPINUP_FLOW_THROUGHS = 1.0
"""Spin-up, in flow-throughs, from which the start-up is taken to have left the domain."""
SPINUP_FLOOR = 0.25
"""Spin-up, in flow-throughs, below which the mean is not converged (between it and one
flow-through the mean is young: a note)."""
WINDOW_FLOOR = 0.5
"""Averaging window, in flow-throughs, below which the half-window test cannot see the error
of the mean (each half under a quarter of a flow-through)."""
HALVES_LIMIT = 0.05
"""Largest RMS difference between the means of the window's halves, over the inlet speed."""

_KEYS = ("flow_throughs_spinup", "flow_throughs_average", "half_window_difference")


def averaging_verdict(diagnostics) -> dict:
    """How well a run's mean wind is converged, from its averaging diagnostics.

    Parameters
    ----------
    diagnostics : dict or FlowSolution
        ``flow_throughs_spinup``, ``flow_throughs_average`` and ``half_window_difference``
        (a :class:`~windnav.flow.FlowSolution`, its ``diagnostics`` dict, or a sweep case's).

    Returns
    -------
    dict
        ``converged`` (bool; None without diagnostics), ``level`` (``"ok"``, ``"note"``: a
        young mean, ``"warning"``: not converged, or ``"unknown"``) and ``reason`` (words).
    """
    d = getattr(diagnostics, "diagnostics", diagnostics)
    d = dict(d or {})
    try:
        spin, window, halves = (float(d[k]) for k in _KEYS)
    except (KeyError, TypeError, ValueError):
        return {"converged": None, "level": "unknown",
                "reason": "no averaging diagnostics (solver override)"}
    if not (math.isfinite(spin) and math.isfinite(window)):
        return {"converged": None, "level": "unknown", "reason": "no averaging diagnostics"}
    warn, note = [], []
    if window < WINDOW_FLOOR:
        warn.append(f"window {window:.2g} flow-throughs, under {WINDOW_FLOOR:g}: too short for "
                    "the half-window test, whose halves are then nearly the same snapshots")
    if not math.isfinite(halves):
        warn.append("halves not compared (fewer than 2 averaged steps)")
    elif halves > HALVES_LIMIT:
        warn.append(f"halves differ by {halves:.3f} of the inlet speed, over "
                    f"{HALVES_LIMIT:.0%}")
    if spin < SPINUP_FLOOR:
        warn.append(f"spin-up {spin:.2g} flow-throughs, under {SPINUP_FLOOR:g}: the start-up "
                    "still fills most of the domain")
    elif spin < SPINUP_FLOW_THROUGHS:
        note.append(f"spin-up {spin:.2g} flow-throughs, under one, so the start-up may linger "
                    "downstream (the thesis's protocol gives 0.29-0.42 at 10 m/s)")
    if warn or note:
        return {"converged": False, "level": "warning" if warn else "note",
                "reason": "; ".join(warn + note)}
    return {"converged": True, "level": "ok",
            "reason": f"spin-up {spin:.2f} and window {window:.2f} flow-throughs, halves "
                      f"{halves:.3f} of the inlet speed apart"}


def averaging_message(verdict: dict) -> str | None:
    """The ``warning: ...`` or ``note: ...`` line for a verdict of :func:`averaging_verdict`
    (None when converged or unknown)."""
    if verdict.get("level") == "warning":
        return (f"warning: the mean is not converged: {verdict['reason']}. Raise "
                "--spinup-steps / --steps")
    if verdict.get("level") == "note":
        return (f"note: the mean is young: {verdict['reason']}. Raise --spinup-steps for a "
                "converged one")
    return None


def validated_dx(city) -> float:
    """The coarsest cell size of the grid-independence validation, m: ``s / 8`` with ``s`` the
    median over the buildings of their smaller side (inf for a map without buildings)."""
    from windnav.flow.solver import FILTER_PER_BUILDING

    side = city.median_building_side
    return math.inf if side is None else side / FILTER_PER_BUILDING


def blockage(city, direction_deg, dx: float = 1.0):
    """The largest share of a cross-section across the wind that ``city``'s buildings block.

    The map is rasterised at ``dx`` (m; :meth:`windnav.city.City.rasterize`, cell centres),
    its cells binned into slabs ``dx`` thick along the wind blowing toward ``direction_deg``
    (counter-clockwise from +x); the result is the largest solid share of a slab, over the
    slabs holding at least half as many cells as the longest (an oblique wind's corner slabs,
    a few cells long, would read a corner block as a wall, and a wall across the map may read
    less than 1 at such an angle). For a wind along a map axis the mean wind through that
    section is ``1 / (1 - b)`` times the inlet's, by continuity; for an oblique wind the share
    is geometry only (the module docstring).

    Parameters
    ----------
    city : windnav.city.City
    direction_deg : float or sequence of float
        The wind's direction, toward, deg (several: the map rasterised once).
    dx : float
        Raster cell and slab thickness, m (> 0).

    Returns
    -------
    float, or ndarray of the directions' shape
        In [0, 1].
    """
    import numpy as np

    from windnav._validate import finite_float, positive_float

    dx = positive_float(dx, "dx", "blockage")
    try:
        angles = np.asarray(direction_deg, dtype=float)
    except (TypeError, ValueError):
        raise ValueError("The 'direction_deg' parameter of blockage must be a number or a "
                         f"sequence of numbers, deg. Got {direction_deg!r} instead.") from None
    for a in angles.ravel():
        finite_float(a, "direction_deg", "blockage")
    x, y = city.grid(dx)
    solid = np.asarray(city.rasterize(x, y), dtype=float).ravel()
    out = np.empty(angles.size)
    for i, th in enumerate(np.radians(angles.ravel())):
        along = x[None, :] * math.cos(th) + y[:, None] * math.sin(th)
        slab = np.floor((along - along.min()) / dx + 1e-9).astype(np.int64).ravel()
        cells = np.bincount(slab)
        blocked = np.bincount(slab, weights=solid)
        long = cells >= 0.5 * cells.max()
        out[i] = (blocked[long] / cells[long]).max()
    return float(out[0]) if angles.ndim == 0 else out.reshape(angles.shape)


def resolution_check(city, dx: float) -> dict:
    """Whether cell size ``dx`` (m) is within the validated resolution of ``city``.

    Returns
    -------
    dict
        ``dx`` m, ``validated_dx`` m (:func:`validated_dx`; None for an empty map),
        ``grid_dependent`` (bool: ``dx`` above it) and ``note`` (the words, or None).

    Raises
    ------
    ValueError
        On a ``city`` that is not a City, or a ``dx`` that is not a finite number > 0 (NaN
        was reported as "dx = nan m").
    """
    from windnav._validate import positive_float
    from windnav.city.core import check_city

    check_city(city, "resolution_check")
    dx = positive_float(dx, "dx", "resolution_check")
    limit = validated_dx(city)
    note = city.resolution_note(dx)
    return {"dx": dx, "validated_dx": limit if math.isfinite(limit) else None,
            "grid_dependent": note is not None, "note": note}
