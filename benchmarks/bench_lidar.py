"""2D LiDAR throughput on a dense 1.2 km map: numba kernel vs brute-force numpy reference.

Ours: ``City.lidar`` (numba, one core, broad-phase cull + slab method). Reference: every ray
against every edge of every building in float64 numpy, one origin at a time (vectorised over
rays x edges). Both scan the same street origins of ``dense_map(rng=seed)`` (>= 200 buildings) with
360 rays and a 100 m range; the figures are medians over repeats. Also times rasterising the
map on a 1 m grid (1200 x 1200) against full-grid comparisons per building.

Run: ``.venv/bin/python benchmarks/bench_lidar.py [--origins 10000] [--repeats 7]``
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from windnav.city import dense_map

try:
    from _record import append_record
except ImportError:  # run from the repository root as a module
    from benchmarks._record import append_record


def brute_force_scan(footprints, origins, n_rays, max_range):
    """Nearest ray/edge intersection for every ray and every building edge (float64)."""
    a = 2.0 * np.pi * np.arange(n_rays) / n_rays
    c, s = np.cos(a)[:, None], np.sin(a)[:, None]
    c[np.abs(c) < 1e-12] = 0.0
    s[np.abs(s) < 1e-12] = 0.0
    x0, x1, y0, y1 = footprints.T
    out = np.empty((len(origins), n_rays))
    with np.errstate(divide="ignore", invalid="ignore"):
        for b, (ox, oy) in enumerate(origins):
            tv = (np.concatenate([x0, x1])[None, :] - ox) / c
            yv = oy + tv * s
            okv = (tv >= 0) & (yv >= np.tile(y0, 2)) & (yv <= np.tile(y1, 2))
            th = (np.concatenate([y0, y1])[None, :] - oy) / s
            xh = ox + th * c
            okh = (th >= 0) & (xh >= np.tile(x0, 2)) & (xh <= np.tile(x1, 2))
            t = np.minimum(np.where(okv, tv, np.inf).min(1), np.where(okh, th, np.inf).min(1))
            out[b] = np.minimum(t, max_range)
    return out


def raster_reference(footprints, x, y):
    mask = np.zeros((y.size, x.size), dtype=bool)
    for x0, x1, y0, y1 in footprints:
        mask |= ((y >= y0) & (y <= y1))[:, None] & ((x >= x0) & (x <= x1))[None, :]
    return mask


def median_time(fn, repeats):
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        fn()
        times.append(time.perf_counter() - t0)
    return float(np.median(times))


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--origins", type=int, default=10_000, help="scans per timed batch")
    ap.add_argument("--ref-origins", type=int, default=200, help="scans for the reference")
    ap.add_argument("--repeats", type=int, default=7)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--no-record", action="store_true", help="do not append to docs/")
    args = ap.parse_args(argv)

    city = dense_map(rng=args.seed)
    rng = np.random.default_rng(args.seed)
    pts = rng.uniform(0.0, 1200.0, size=(3 * args.origins, 2))
    origins = pts[~city.contains(pts)][: args.origins]
    n_rays, max_range = 360, 100.0

    city.lidar(origins[:10], n_rays=n_rays, max_range=max_range)  # compile / load cache
    t_ours = median_time(lambda: city.lidar(origins, n_rays=n_rays, max_range=max_range),
                         args.repeats)
    noise_rng = np.random.default_rng(1)
    t_noisy = median_time(lambda: city.lidar(origins, n_rays=n_rays, max_range=max_range,
                                             noise_std=0.35, rng=noise_rng), args.repeats)
    sub = origins[: args.ref_origins]
    t_ref = median_time(lambda: brute_force_scan(city.footprints, sub, n_rays, max_range),
                        max(3, args.repeats // 2))
    err = np.abs(city.lidar(sub, n_rays=n_rays, max_range=max_range)
                 - brute_force_scan(city.footprints, sub, n_rays, max_range)).max()

    ours = len(origins) / t_ours
    noisy = len(origins) / t_noisy
    ref = len(sub) / t_ref

    x, y = city.grid(1.0)
    t_r = median_time(lambda: city.rasterize(x, y), args.repeats)
    t_rr = median_time(lambda: raster_reference(city.footprints, x, y), max(3, args.repeats // 2))
    same = bool(np.array_equal(city.rasterize(x, y), raster_reference(city.footprints, x, y)))

    rows = [
        f"dense_map(rng={args.seed}): 1200 x 1200 m, {city.n_buildings} buildings; "
        f"{n_rays} rays, max_range {max_range} m, street origins; medians of "
        f"{args.repeats} repeats; one core.",
        "",
        "| what | ours | reference | ratio |",
        "|---|---|---|---|",
        f"| LiDAR scans/s (no noise) | {ours:,.0f} (numba, batch {len(origins)}) "
        f"| {ref:,.0f} (numpy brute force, {len(sub)} scans) | {ours / ref:,.0f}x |",
        f"| LiDAR scans/s (noise 0.35 m) | {noisy:,.0f} | - | {noisy / ref:,.0f}x |",
        f"| rasterise 1 m grid 1200 x 1200, ms | {1e3 * t_r:.2f} (index ranges) "
        f"| {1e3 * t_rr:.1f} (full-grid comparisons) | {t_rr / t_r:,.0f}x |",
        "",
        f"Max |ours - reference| over {len(sub)} scans: {err:.2e} m; "
        f"rasters identical: {same}.",
    ]
    print("\n".join(rows))
    if not args.no_record:
        append_record("2D LiDAR and rasterisation (windnav.city)", rows,
                      command="python benchmarks/bench_lidar.py " + " ".join(argv or []))
    return 0


if __name__ == "__main__":
    import sys

    raise SystemExit(main(sys.argv[1:]))
