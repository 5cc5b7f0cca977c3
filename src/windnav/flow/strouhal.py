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

from windnav.flow.grid import BoundaryConditions, MACGrid, make_domain
from windnav.flow.solver import BLOWUP_FACTOR, check_finite, make_flow_step


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
        Hann-windowed periodogram zero-padded to 16x the length.

    Returns
    -------
    float
        NaN if fewer than 3 upward crossings (no oscillation).
    """
    s = np.asarray(signal, dtype=np.float64)
    s = s - s.mean()
    if method == "spectrum":
        n = 16 * s.size
        spec = np.abs(np.fft.rfft(s * np.hanning(s.size), n))
        freq = np.fft.rfftfreq(n, dt)
        return float(freq[1:][np.argmax(spec[1:])] * length / speed)
    if method != "crossings":
        raise ValueError(
            f"The 'method' parameter of strouhal_number must be 'crossings' or 'spectrum'. "
            f"Got {method!r} instead."
        )
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
    limit = BLOWUP_FACTOR * case.speed
    iterator = range(n_spin + n_rec)
    if progress:
        from tqdm import tqdm

        iterator = tqdm(iterator, desc=f"St D/dx={n}", unit="step")
    u_next, v_next = np.empty_like(u), np.empty_like(v)
    for k in iterator:
        step.advance(u, v, u_next, v_next)
        u, v, u_next, v_next = u_next, v_next, u, v
        check_finite(u, v, limit, k + 1)
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
