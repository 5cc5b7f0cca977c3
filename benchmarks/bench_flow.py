"""Flow-solver step time: windnav (MacCormack + exact projection) vs PhiFlow, one core.

Run: ``.venv/bin/python benchmarks/bench_flow.py`` (pins numba/BLAS to one thread itself).
Measures the median time of one incompressible step (advection + exact pressure projection)
on 1200^2 (first, so the process's peak memory is its own) and 500^2 cells with ~10
buildings, the projection alone under the red-black Schur ordering with CHOLMOD (default),
with SuperLU (the previous default) and under the whole-matrix nested-dissection
ordering, the thesis-style Jacobi-300 step and its residual
divergence, and PhiFlow 3.4's ``fluid.make_incompressible`` step
(numpy backend, staggered grid, obstacles) on the same grid and mask (200^2 as well, since
PhiFlow reportedly overflows above ~215^2, PhiML issue #15). Appends to docs/benchmarks.md.
"""

from __future__ import annotations

import os

for _var in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import resource  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _record import append_record  # noqa: E402

from windnav.flow import (  # noqa: E402
    BoundaryConditions,
    MACGrid,
    divergence,
    make_domain,
    make_exact_projection,
    make_flow_step,
)
from windnav.flow.solver import FILTER_PER_BUILDING, SMAGORINSKY  # noqa: E402


def building_rects(n: int, seed: int = 0) -> list[tuple[int, int, int, int]]:
    """About 10 rectangular buildings ``(i0, i1, j0, j1)`` (cells) on an n x n grid."""
    rng = np.random.default_rng(seed)
    rects = []
    for _ in range(10):
        w, h = rng.integers(n // 25, n // 10, 2)
        i, j = rng.integers(n // 8, n - n // 8 - max(w, h), 2)
        rects.append((int(i), int(i + w), int(j), int(j + h)))
    return rects


def buildings(n: int, seed: int = 0) -> np.ndarray:
    """The mask (n, n) of :func:`building_rects`."""
    solid = np.zeros((n, n), dtype=bool)
    for i0, i1, j0, j1 in building_rects(n, seed):
        solid[j0:j1, i0:i1] = True
    return solid


def median_time(fn, repeats: int) -> float:
    fn()
    ts = []
    for _ in range(repeats):
        t = time.perf_counter()
        fn()
        ts.append(time.perf_counter() - t)
    return float(np.median(ts))


def default_filter_width(n: int, dx: float = 1.0) -> float:
    """The filter width simulate() would use on the :func:`buildings` map, m."""
    sides = [min(i1 - i0, j1 - j0) * dx for i0, i1, j0, j1 in building_rects(n)]
    return max(dx, float(np.median(sides)) / FILTER_PER_BUILDING)


def ours(n: int, repeats: int, pressure: str = "exact", ordering: str = "red_black",
         closure: bool = False, warmup: int = 3, backend: str = "cholmod"):
    """Median step of windnav; ``closure``: simulate()'s default Smagorinsky eddy viscosity
    (its cost grows with the strain, so use ``warmup`` steps to develop the wakes)."""
    speed, dx = 5.0, 1.0
    dt = 0.5 * dx / speed
    domain = make_domain(MACGrid((n, n), dx), buildings(n), BoundaryConditions.for_wind(speed, 0))
    t0 = time.perf_counter()
    project = (make_exact_projection(domain, ordering, backend=backend) if pressure == "exact"
               else pressure)
    kw = dict(smagorinsky=SMAGORINSKY, filter_width=default_filter_width(n, dx)) if closure \
        else {}
    step = make_flow_step(domain, dt, "maccormack", project, **kw)
    build = time.perf_counter() - t0
    u, v = step.project(*domain.initial_velocity(0.05 * speed))
    un, vn = np.empty_like(u), np.empty_like(v)
    for _ in range(warmup):  # leave the initial state
        step.advance(u, v, un, vn)
        u, v, un, vn = un, vn, u, v
    t_step = median_time(lambda: step.advance(u, v, un, vn), repeats)
    t_adv = median_time(lambda: step.advect.into(u, v, un, vn), repeats)
    pu, pv = np.empty_like(u), np.empty_like(v)
    t_proj = median_time(lambda: step.project.into(un, vn, pu, pv), repeats)
    step.advance(u, v, un, vn)
    div = float(np.abs(divergence(domain, un, vn)).max() * dx / speed)
    out = {"build": build, "step": t_step, "advect": t_adv, "project": t_proj, "div": div}
    if closure:
        adv = step.advect
        out["nu_max"] = float(adv._nu_c.max())
        out["substeps"] = int(np.ceil(out["nu_max"] * dt / dx**2 / 0.2))
        out["filter_width"] = adv.filter_width
    return out


def phiflow_step(n: int, repeats: int, tolerance: float):
    from phi import flow as pf  # benchmark-only reference

    speed = 5.0
    dt = 0.5 / speed
    boxes = [pf.Box(x=(i0, i1), y=(j0, j1)) for i0, i1, j0, j1 in building_rects(n)]
    obstacle = pf.Obstacle(pf.union(*boxes))
    bounds = pf.Box(x=n, y=n)
    bc = {"x-": pf.vec(x=speed, y=0), "x+": pf.ZERO_GRADIENT, "y": 0}
    velocity = pf.StaggeredGrid(pf.vec(x=speed, y=0), bc, x=n, y=n, bounds=bounds)
    solve = pf.Solve("CG", abs_tol=tolerance, rel_tol=0, x0=None, max_iterations=100000)

    def step():
        v = pf.advect.semi_lagrangian(velocity, velocity, dt)
        v, _ = pf.fluid.make_incompressible(v, obstacle, solve)
        return v

    return median_time(step, repeats)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=11)
    parser.add_argument("--no-phiflow", action="store_true")
    parser.add_argument("--no-record", action="store_true")
    args = parser.parse_args(argv)

    rows = ["| case | cells | median step (s) | notes |", "|---|---|---|---|"]
    r1200 = ours(1200, max(3, args.repeats // 2))
    peak_mib = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    rows.append(
        f"| windnav MacCormack + exact (red-black Schur, CHOLMOD) | 1200^2 | {r1200['step']:.4f} | "
        f"advection {r1200['advect']:.4f} s, projection {r1200['project']:.4f} s, "
        f"factorisation {r1200['build']:.2f} s once, peak RSS of the process {peak_mib:.0f} MiB, "
        f"max|div| dx/U = {r1200['div']:.1e} |"
    )
    print(rows[-1], flush=True)
    r500 = ours(500, args.repeats)
    rows.append(
        f"| windnav MacCormack + exact (red-black Schur, CHOLMOD) | 500^2 | {r500['step']:.4f} | "
        f"advection {r500['advect']:.4f} s, projection {r500['project']:.4f} s, "
        f"factorisation {r500['build']:.2f} s once, max|div| dx/U = {r500['div']:.1e} |"
    )
    print(rows[-1], flush=True)
    c500 = ours(500, args.repeats, closure=True, warmup=300)
    rows.append(
        f"| windnav default closure (Smagorinsky C_s = {SMAGORINSKY}, filter "
        f"{c500['filter_width']:.2f} m) | 500^2 | {c500['step']:.4f} | advection + eddy "
        f"viscosity + {c500['substeps']} diffusion substep(s) {c500['advect']:.4f} s after 300 "
        f"steps (max nu_t {c500['nu_max']:.2f} m^2/s); {c500['step'] / r500['step']:.2f}x the "
        f"inviscid step above |"
    )
    print(rows[-1], flush=True)
    slu500 = ours(500, args.repeats, backend="superlu")
    rows.append(
        f"| windnav MacCormack + exact (red-black Schur by SuperLU, previous default) | 500^2 | "
        f"{slu500['step']:.4f} | projection {slu500['project']:.4f} s (CHOLMOD: "
        f"{slu500['project'] / r500['project']:.2f}x faster), factorisation "
        f"{slu500['build']:.2f} s |"
    )
    print(rows[-1], flush=True)
    nd500 = ours(500, args.repeats, ordering="nested_dissection")
    rows.append(
        f"| windnav MacCormack + exact (whole-matrix ND + MMD by SuperLU) | 500^2 | "
        f"{nd500['step']:.4f} | projection {nd500['project']:.4f} s "
        f"(red-black + CHOLMOD: {nd500['project'] / r500['project']:.2f}x faster), factorisation "
        f"{nd500['build']:.2f} s |"
    )
    print(rows[-1], flush=True)
    j500 = ours(500, max(3, args.repeats // 3), "jacobi")
    rows.append(
        f"| windnav MacCormack + Jacobi-300 | 500^2 | {j500['step']:.4f} | residual "
        f"max|div| dx/U = {j500['div']:.1e} |"
    )
    print(rows[-1], flush=True)
    if not args.no_phiflow:
        for n in (200, 500):
            try:
                r_ours = r500["step"] if n == 500 else ours(n, args.repeats)["step"]
                t_phi = phiflow_step(n, max(3, args.repeats // 3), tolerance=1e-5)
                rows.append(
                    f"| PhiFlow 3.4 make_incompressible (numpy, CG abs_tol 1e-5) | {n}^2 | "
                    f"{t_phi:.4f} | windnav {r_ours:.4f} s: ratio {t_phi / r_ours:.0f}x |"
                )
            except Exception as exc:  # report the reference's failure, keep our figures
                rows.append(f"| PhiFlow 3.4 | {n}^2 | failed | {type(exc).__name__}: {exc} |")
            print(rows[-1], flush=True)
    if not args.no_record:
        append_record("Flow solver step (one core)", rows,
                      command="python benchmarks/bench_flow.py")
    return 0


if __name__ == "__main__":
    sys.exit(main())
