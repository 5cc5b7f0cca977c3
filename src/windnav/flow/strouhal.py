"""Vortex-shedding frequency and the square-cylinder Strouhal benchmark.

The Strouhal number ``St = f D / U`` (shedding frequency ``f``, body width ``D``, free-stream
speed ``U``) of a square cylinder at 0 deg incidence is 0.13 at Re ~ 10^3 - 10^5 (Okajima
1982, J. Fluid Mech. 123; Lyn, Einav, Rodi & Park 1995, J. Fluid Mech. 304). It is measured
here from the cross-stream velocity at a probe on the wake centreline, where ``v`` oscillates
at the shedding frequency, by counting upward zero crossings of the de-meaned signal (or
from the peak of a zero-padded Hann periodogram).

A resolution study needs a Reynolds number that does not move with the grid: without
viscosity the scheme's numerical diffusion sets it, and with the low-dissipation MacCormack
scheme it roughly doubles per halving of dx until the wake turns irregular (St 0.140 at
D/dx = 8, 0.17-0.19 at 16-32). ``SquareCylinderCase(reynolds=100.0)`` adds nu = U D / Re;
St at Re = 100 is ~0.14-0.15 (Okajima 1982; Sohankar, Norberg & Davidson 1998).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from windnav._validate import positive_float
from windnav.flow.grid import BoundaryConditions, MACGrid, make_domain
from windnav.flow.solver import (
    FILTER_PER_BUILDING,
    SMAGORINSKY,
    blowup_limit,
    check_finite,
    make_flow_step,
)

SETTLED_TOLERANCE = 0.03
"""Largest relative difference between the St of a record's two halves for the shedding to
count as settled."""

SETTLED_AMPLITUDE_RATIO = 2.0
"""Largest ratio between the lift RMS of a record's two halves for the shedding to count as
settled: an oscillation dying out (a wake that does not shed, whose start transient decays) or
growing has not settled, even where both halves peak at one frequency. Measured (audit,
2026-12-06): at most 1.18 over every record of the flow-validate studies and the tests (every
record length, settled or not); 6 to 2e9 for squares at Re = 10-30, whose wakes do not shed (the
Re = 20 square at 45 deg, 8 cells per side, rings at St 0.094 in both halves, its lift RMS
falling 260x)."""


PEAK_TO_FLOOR = 100.0
"""Smallest ratio of a periodogram's peak power to the median power of the frequencies searched
for the peak to count as an oscillation (:func:`spectral_peak`): 20 dB. Measured (audit,
2026-12-06): white noise peaks at 3-23 times its median (the largest of 880 records of 64 to
65,536 samples), while every lift record of the flow-validate studies and the tests (halves and
wholes, every record length the studies ran) peaks at 5e6 or more, and a sine half as large as
the noise's standard deviation, over 2,560 samples, at 107 or more (50 draws). The floor tells an
oscillation from noise, not from a smooth transient: the decaying lift of a wake that does
not shed (squares at Re = 10-30) has its power at low frequencies and peaks at 5e2 to 1e13
times the median; an edge peak, and in :func:`bluff_body_strouhal` the record's halves, tell
those."""


def spectral_peak(signal: np.ndarray, dt: float) -> dict:
    """The dominant frequency of ``signal`` from its periodogram, and whether it is resolved.

    The periodogram is that of the de-meaned signal, Hann-windowed and zero-padded to 16x its
    length; the peak is searched among frequencies of at least two cycles per record (slower
    drifts are not shedding) up to the Nyquist frequency.

    Parameters
    ----------
    signal : ndarray of shape (T,)
        Uniformly sampled signal (any unit).
    dt : float
        Sampling interval, s.

    Returns
    -------
    dict
        ``frequency`` (Hz; NaN when no frequency is resolved), ``peak_to_floor`` (the peak's
        power over the median power of the frequencies searched; NaN when there is no
        spectrum to search) and ``reason`` (None, or why ``frequency`` is NaN:
        ``"not finite"``, a NaN or infinite sample; ``"no variance"``, a constant signal
        (or none); ``"too short"``, fewer than 5 samples, too few for a frequency between two
        cycles per record and the Nyquist frequency; ``"edge of band"``, the largest power at
        the lowest or highest frequency searched, i.e. a spectrum that falls or rises across
        the band, as a drift gives, and no peak within it; ``"below floor"``, a peak
        less than :data:`PEAK_TO_FLOOR` times the median power).
    """
    dt = positive_float(dt, "dt", "spectral_peak")
    s = np.asarray(signal, dtype=np.float64)
    if s.ndim != 1:
        raise ValueError(f"The 'signal' parameter of spectral_peak must be 1-D (T,). Got an "
                         f"array of shape {s.shape} instead.")
    nan = float("nan")
    if not np.all(np.isfinite(s)):
        return {"frequency": nan, "peak_to_floor": nan, "reason": "not finite"}
    s = s - s.mean() if s.size else s
    if not np.any(s != s[:1]):
        return {"frequency": nan, "peak_to_floor": nan, "reason": "no variance"}
    n = 16 * s.size
    power = np.abs(np.fft.rfft(s * np.hanning(s.size), n)) ** 2
    freq = np.fft.rfftfreq(n, dt)
    ok = freq >= 2.0 / (dt * s.size)  # a peak needs two cycles in the record
    band, f_band = power[ok], freq[ok]
    if band.size < 3:  # no frequency between the band's edges
        return {"frequency": nan, "peak_to_floor": nan, "reason": "too short"}
    i = int(np.argmax(band))
    floor = float(np.median(band))
    ratio = float(band[i] / floor) if floor > 0.0 else float("inf")
    reason = None
    if i == 0 or i == band.size - 1:
        reason = "edge of band"
    elif not ratio >= PEAK_TO_FLOOR:
        reason = "below floor"
    return {"frequency": float(f_band[i]) if reason is None else nan, "peak_to_floor": ratio,
            "reason": reason}


def strouhal_number(
    signal: np.ndarray, dt: float, length: float, speed: float, method: str = "crossings"
) -> float:
    """Strouhal number ``f * length / speed`` of the dominant oscillation of ``signal``.

    Parameters
    ----------
    signal : ndarray of shape (T,)
        Uniformly sampled probe signal (e.g. cross-stream velocity, m/s).
    dt : float
        Sampling interval, s.
    length : float
        Body width D, m.
    speed : float
        Free-stream speed U, m/s.
    method : {"crossings", "spectrum"}
        Mean period between upward zero crossings (linearly interpolated), or the peak of a
        Hann-windowed periodogram zero-padded to 16x the length, among frequencies of at least
        two cycles per record (slow drifts are not shedding): :func:`spectral_peak`.

    Returns
    -------
    float
        NaN where the signal gives no frequency: a non-finite sample (both methods); with
        "crossings", fewer than 3 upward crossings (no oscillation); with "spectrum", a
        constant signal, a peak at the lowest or highest frequency searched (a drift, noise:
        no resolved frequency) or one less than :data:`PEAK_TO_FLOOR` times the spectrum's
        median (no clear oscillation; :func:`spectral_peak` says which).
    """
    dt = positive_float(dt, "dt", "strouhal_number")
    length = positive_float(length, "length", "strouhal_number")
    speed = positive_float(speed, "speed", "strouhal_number")
    s = np.asarray(signal, dtype=np.float64)
    if s.ndim != 1:
        raise ValueError(f"The 'signal' parameter of strouhal_number must be 1-D (T,). Got an "
                         f"array of shape {s.shape} instead.")
    if method == "spectrum":
        return float(spectral_peak(s, dt)["frequency"] * length / speed)
    if method != "crossings":
        raise ValueError(
            f"The 'method' parameter of strouhal_number must be 'crossings' or 'spectrum'. "
            f"Got {method!r} instead."
        )
    if s.size < 2 or not np.all(np.isfinite(s)):
        return float("nan")
    s = s - s.mean()
    k = np.flatnonzero((s[:-1] < 0.0) & (s[1:] >= 0.0))
    if k.size < 3:
        return float("nan")
    t_cross = (k + s[k] / (s[k] - s[k + 1])) * dt
    period = (t_cross[-1] - t_cross[0]) / (k.size - 1)
    return float(length / (period * speed))


@dataclass(frozen=True)
class SquareCylinderCase:
    """A square building of width D = 1 m in a uniform 0 deg wind (the Strouhal benchmark).

    Attributes
    ----------
    cells_per_side : int
        Resolution: D / dx.
    cfl : float
        ``U dt / dx``.
    speed : float
        Inlet speed U, m/s.
    upstream, downstream, width : float
        Inlet-to-front-face distance, rear-face-to-outlet distance and domain width, in D.
        The side boundaries are far-field inlets (zero normal velocity), so ``1 / width`` is
        the blockage ratio.
    probe_distance : float
        Probe on the wake centreline, this many D behind the rear face.
    spinup_time, record_time : float
        Convective times (in D / U) run before and during the measurement.
    advection : str
        Advection scheme.
    reynolds : float or None
        Reynolds number ``U D / nu`` of an explicit viscosity; None: inviscid (the scheme's
        numerical diffusion sets an effective Reynolds number that grows as dx shrinks).
    """

    cells_per_side: int = 8
    cfl: float = 0.5
    speed: float = 1.0
    upstream: float = 5.0
    downstream: float = 14.0
    width: float = 12.0
    probe_distance: float = 2.0
    spinup_time: float = 60.0
    record_time: float = 100.0
    advection: str = "maccormack"
    reynolds: float | None = None

    def refined(self) -> SquareCylinderCase:
        """The same case with dx and dt both halved."""
        from dataclasses import replace

        return replace(self, cells_per_side=2 * self.cells_per_side)


def square_cylinder_strouhal(case: SquareCylinderCase = SquareCylinderCase(), progress=False):
    """Run the square-cylinder case and measure St at the wake probe.

    Returns
    -------
    dict
        ``strouhal`` (zero crossings), ``strouhal_spectrum``, ``t`` (T,) s and ``probe_v``
        (T,) m/s, ``dx`` m, ``dt`` s, ``shape`` (ny, nx), ``steps``.
    """
    D = 1.0
    n = int(case.cells_per_side)
    dx = D / n
    dt = case.cfl * dx / case.speed
    nx = int(round((case.upstream + 1.0 + case.downstream) * n))
    ny = int(round(case.width * n))
    ny += (ny - n) % 2  # centre the building on whole cells
    grid = MACGrid((ny, nx), dx, (0.0, 0.0))
    solid = np.zeros((ny, nx), dtype=bool)
    i0 = int(round(case.upstream * n))
    j0 = (ny - n) // 2
    solid[j0 : j0 + n, i0 : i0 + n] = True
    domain = make_domain(grid, solid, BoundaryConditions.for_wind(case.speed, 0.0))
    nu = 0.0 if case.reynolds is None else case.speed * D / float(case.reynolds)
    step = make_flow_step(domain, dt, case.advection, "exact", viscosity=nu)
    u, v = step.project(*domain.initial_velocity(0.05 * case.speed))
    # probe: the y-face on the centreline (between the two middle rows), probe_distance behind
    ip = i0 + n + int(round(case.probe_distance * n))
    jp = ny // 2
    n_spin = int(round(case.spinup_time * D / case.speed / dt))
    n_rec = int(round(case.record_time * D / case.speed / dt))
    probe = np.empty(n_rec)
    limit, basis = blowup_limit(case.speed, u, v)
    iterator = range(n_spin + n_rec)
    if progress:
        from windnav._console import progress_bar

        iterator = progress_bar(iterator, auto=False, desc=f"St D/dx={n}", unit="step")
    u_next, v_next = np.empty_like(u), np.empty_like(v)
    for k in iterator:
        step.advance(u, v, u_next, v_next)
        u, v, u_next, v_next = u_next, v_next, u, v
        check_finite(u, v, limit, k + 1, basis)
        if k >= n_spin:
            probe[k - n_spin] = 0.5 * (v[jp, ip - 1] + v[jp, ip])
    return {
        "strouhal": strouhal_number(probe, dt, D, case.speed),
        "strouhal_spectrum": strouhal_number(probe, dt, D, case.speed, "spectrum"),
        "t": dt * np.arange(1, n_rec + 1),
        "probe_v": probe,
        "dx": dx,
        "dt": dt,
        "shape": (ny, nx),
        "steps": n_spin + n_rec,
    }


@dataclass(frozen=True)
class BluffBodyCase:
    """An isolated rectangular building in a uniform wind at an incidence angle.

    The body is axis-aligned, with cross-stream height ``H = 1`` m (along y) and streamwise
    depth ``B = aspect_ratio * H`` (along x) at 0 deg; the incidence is set by turning the
    inlet wind, ``angle_deg`` counter-clockwise from +x (0: wind along the depth, 90: along the
    height). City maps are axis-aligned blocks that the wind meets from any direction, so this
    is the configuration the solver runs in every sweep, with no staircase on the body. The
    defaults are those of :func:`windnav.flow.simulate` (MacCormack, Smagorinsky closure,
    symmetry kick in the near wake).

    Attributes
    ----------
    cells_per_height : int
        Resolution: ``H / dx``.
    aspect_ratio : float
        ``B / H`` (streamwise depth over cross-stream height at 0 deg).
    angle_deg : float
        Incidence, degrees (the inlet direction).
    cfl : float
        ``U dt / dx``.
    speed : float
        Inlet speed U, m/s.
    upstream, downstream : float
        Distance from the inlet sides to the body, and from the body to the outflow sides,
        in H. The domain is square.
    spinup_time, record_time : float
        Convective times (H / U) run before and during the force record.
    max_record_time : float or None
        None (the default): the record is ``record_time`` long. A number: while the run has
        not settled (its record's two halves disagree on St by more than
        :data:`SETTLED_TOLERANCE`, a flow switching between shedding states, or give no St, or
        the record gives none; see :func:`bluff_body_strouhal`), the record is doubled, up to
        this many H / U, and St is taken from the whole record. A run still unsettled at the
        cap is flagged as such.
    smagorinsky, filter_width, viscosity : float
        Closure, as in :func:`windnav.flow.simulate` (``filter_width`` None:
        ``max(dx, min(H, B) / 8)``, the default rule for a map of this one building).
    advection : str
        Advection scheme.
    """

    cells_per_height: int = 16
    aspect_ratio: float = 1.0
    angle_deg: float = 0.0
    cfl: float = 0.5
    speed: float = 1.0
    upstream: float = 7.0
    downstream: float = 16.0
    spinup_time: float = 50.0
    record_time: float = 100.0
    max_record_time: float | None = None
    smagorinsky: float = SMAGORINSKY
    filter_width: float | None = None
    viscosity: float = 0.0
    advection: str = "maccormack"

    def __post_init__(self):
        if not (self.record_time > 0):
            raise ValueError(f"The 'record_time' parameter of BluffBodyCase must be > 0 H/U. "
                             f"Got {self.record_time!r} instead.")
        if self.max_record_time is not None and not (self.max_record_time >= self.record_time):
            raise ValueError(f"The 'max_record_time' parameter of BluffBodyCase must be None or "
                             f">= record_time ({self.record_time!r} H/U). Got "
                             f"{self.max_record_time!r} instead.")


def _body_faces(solid):
    """Fluid cells next to a building, per side: (E, W, N, S) flat index arrays."""
    fluid = ~solid
    e = np.zeros_like(solid)
    w = np.zeros_like(solid)
    n = np.zeros_like(solid)
    s = np.zeros_like(solid)
    e[:, 1:] = solid[:, :-1] & fluid[:, 1:]  # fluid east of a solid cell
    w[:, :-1] = solid[:, 1:] & fluid[:, :-1]
    n[1:, :] = solid[:-1, :] & fluid[1:, :]
    s[:-1, :] = solid[1:, :] & fluid[:-1, :]
    return tuple(np.flatnonzero(m) for m in (e, w, n, s))


def body_force(q_cells, faces, dx: float, dt: float) -> tuple[float, float]:
    """Pressure force on the buildings per unit span and density, ``(F_x, F_y)`` in m^3/s^2.

    ``q_cells`` is the projection potential (:meth:`FlowStep.advance`), ``p / rho = q dx / dt``;
    each building face of length ``dx`` is pushed along its inward normal by the pressure of
    the fluid cell beside it.
    """
    e, w, n, s = faces
    q = q_cells.ravel()
    scale = dx * dx / dt
    fx = (q[w].sum() - q[e].sum()) * scale
    fy = (q[s].sum() - q[n].sum()) * scale
    return float(fx), float(fy)


def bluff_body_strouhal(case: BluffBodyCase = BluffBodyCase(), progress: bool = False) -> dict:
    """Run :class:`BluffBodyCase` and measure St from the cross-stream force history.

    St is the peak of the Hann-windowed, 16x zero-padded periodogram of the lift (the force
    component across the wind), with ``H`` and ``U`` (:func:`strouhal_number`, "spectrum": NaN
    where the lift has no resolved peak). The viscous stress on the faces is left out: on
    sharp-edged bodies it is a small part of the force and does not set its frequency.

    Returns
    -------
    dict
        ``strouhal``, ``strouhal_crossings`` (mean period between upward zero crossings of the
        lift), ``strouhal_halves`` (St of the record's first and second halves) and ``settled``
        (whether they agree within :data:`SETTLED_TOLERANCE`: a flow still changing its
        shedding gives a St of its transient, not of the flow; audit, 2026-12-05; and whether
        the record and both halves give a St, not NaN, and the halves' lift RMS agree within
        :data:`SETTLED_AMPLITUDE_RATIO`: a wake that does not shed, its start transient dying
        out, has not settled into shedding; audit, 2026-12-06),
        ``record_time_used`` (H / U: ``record_time``, or more where ``max_record_time``
        doubled the record of an unsettled run),
        ``cd_mean`` and ``cl_rms`` (force coefficients on ``0.5 U^2 H``), ``t`` (T,) s,
        ``cl`` (T,), ``dx`` m, ``dt`` s, ``shape`` (ny, nx), ``steps``,
        ``cells_per_height``, ``aspect_ratio``, ``angle_deg``.
    """
    from windnav.flow.solver import initial_velocity

    H = 1.0
    n = int(case.cells_per_height)
    nb = max(int(round(case.aspect_ratio * n)), 1)
    dx = H / n
    dt = case.cfl * dx / case.speed
    up = int(round(case.upstream * n))
    size = up + max(nb, n) + int(round(case.downstream * n))
    grid = MACGrid((size, size), dx, (0.0, 0.0))
    solid = np.zeros((size, size), dtype=bool)
    solid[up : up + n, up : up + nb] = True
    domain = make_domain(grid, solid, BoundaryConditions.for_wind(case.speed, case.angle_deg))
    fw = case.filter_width
    if fw is None:
        fw = max(dx, min(H, nb * dx) / FILTER_PER_BUILDING)
    step = make_flow_step(
        domain, dt, case.advection, "exact", viscosity=case.viscosity,
        smagorinsky=case.smagorinsky, filter_width=fw,
    )
    u, v = step.project(*initial_velocity(domain, 0.05 * case.speed))
    faces = _body_faces(domain.solid)
    n_spin = int(round(case.spinup_time * H / case.speed / dt))
    n_rec = int(round(case.record_time * H / case.speed / dt))
    n_max = n_rec if case.max_record_time is None else max(
        n_rec, int(round(case.max_record_time * H / case.speed / dt)))
    q_cells = np.zeros(grid.shape)
    limit, basis = blowup_limit(case.speed, u, v)
    u_next, v_next = np.empty_like(u), np.empty_like(v)
    th = np.deg2rad(case.angle_deg)
    norm = 0.5 * case.speed**2 * H
    k = 0  # steps run

    def run_to(n_end: int) -> np.ndarray:
        """Advance to step ``n_end``; the forces of the recorded steps on the way (n, 2)."""
        nonlocal u, v, u_next, v_next, k
        first = max(k, n_spin)
        rec = np.empty((max(n_end - first, 0), 2))
        iterator = range(k, n_end)
        if progress:
            from windnav._console import progress_bar

            iterator = progress_bar(iterator, auto=False, desc=f"St a={case.angle_deg:g}",
                                    unit="step", leave=False)
        for i in iterator:
            step.advance(u, v, u_next, v_next, q_cells if i >= n_spin else None)
            u, v, u_next, v_next = u_next, v_next, u, v
            check_finite(u, v, limit, i + 1, basis)
            if i >= n_spin:
                rec[i - first] = body_force(q_cells, faces, dx, dt)
        k = n_end
        return rec

    def measure(force):
        cl = (-force[:, 0] * np.sin(th) + force[:, 1] * np.cos(th)) / norm
        half = cl.size // 2
        parts = (cl[:half], cl[half:])
        halves = [strouhal_number(c, dt, H, case.speed, "spectrum") for c in parts]
        st = strouhal_number(cl, dt, H, case.speed, "spectrum")
        rms = sorted(float(c.std()) for c in parts)
        settled = bool(np.isfinite(st) and np.all(np.isfinite(halves))
                       and abs(halves[0] - halves[1]) <= SETTLED_TOLERANCE * np.mean(halves)
                       and rms[1] <= SETTLED_AMPLITUDE_RATIO * rms[0])
        return cl, halves, st, settled

    force = run_to(n_spin + n_rec)
    cl, halves, st, settled = measure(force)
    while not settled and force.shape[0] < n_max:
        # double the record: its new second half is as long as everything recorded so far
        force = np.concatenate([force, run_to(k + min(force.shape[0], n_max - force.shape[0]))])
        cl, halves, st, settled = measure(force)
    drag = force[:, 0] * np.cos(th) + force[:, 1] * np.sin(th)
    return {
        "strouhal": st,
        "strouhal_halves": halves,
        "settled": settled,
        "record_time_used": float(force.shape[0] * dt * case.speed / H),
        "strouhal_crossings": strouhal_number(cl, dt, H, case.speed),
        "cd_mean": float(drag.mean() / norm),
        "cl_rms": float(cl.std()),
        "t": dt * np.arange(1, cl.size + 1),
        "cl": cl,
        "dx": dx,
        "dt": dt,
        "shape": grid.shape,
        "steps": k,
        "cells_per_height": n,
        "filter_width": fw,
        "aspect_ratio": float(case.aspect_ratio),
        "angle_deg": float(case.angle_deg),
    }
