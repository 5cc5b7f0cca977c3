"""The navigation benchmark's winds simulated three at a time against one at a time, A/B.

Run: ``.venv/bin/python benchmarks/bench_wind_batch.py`` (about 4 minutes on one core; peak
memory about 7.5 GB: three winds' frames).

Every task of ``windnav benchmark-nav --suite thesis`` starts by simulating its winds (600 m,
25 s + 100 s at dt 0.25 s, dx 1 m; 2.3 GB of frames each). Since 2026-11-27 a task simulates
up to three winds of one map whose inlets are the same sides together
(``nav_benchmark.wind_batches``, ``windnav.flow.simulate_batch``): one pressure solve with a
column per wind at each step instead of one solve per wind. This measures, on one suite map:

* the red-black Schur complement's CHOLMOD solve with 1, 2, 3 and 4 right-hand sides: time per
  solve and per column, and whether every column equals the one-column solve to the bit (the
  reason batches stop at three, ``windnav.flow.solver.BITWISE_BATCH``);
* three winds of one incidence family (default: 2 m/s at 15, 30 and 45 deg), simulated one at
  a time and together, alternating, each way with a worker's reused memory and factorisation
  (``nav_benchmark.WorkerReuse``, warmed first, as in a benchmark worker after its first
  task): the time per wind, and a hash of each wind's frames and mean, which must agree.

It prints both tables and appends them to docs/benchmarks.md.
"""

from __future__ import annotations

import os

for _var in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import gc  # noqa: E402
import hashlib  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _record import append_record  # noqa: E402

from windnav.experiments.nav_benchmark import WorkerReuse, suite_flows  # noqa: E402
from windnav.experiments.nav_suite import get_suite, suite_map  # noqa: E402
from windnav.flow.pressure import factorize  # noqa: E402
from windnav.flow.solver import city_domain  # noqa: E402


def _digest(flow) -> str:
    h = hashlib.blake2b(digest_size=16)
    for name in ("frames_u", "frames_v", "mean_u", "mean_v"):
        h.update(np.ascontiguousarray(getattr(flow, name)).tobytes())
    return h.hexdigest()


def solve_table(city, speed: float, direction: float, repeats: int) -> list[str]:
    """CHOLMOD's Schur-complement solve with 1-4 columns on the map's pressure matrix."""
    factor, _, _ = factorize(city_domain(city, speed, direction, 1.0))
    schur = factor._schur_solve
    m = factor.shape[0] - factor._nr
    rng = np.random.default_rng(0)
    rows = [f"| columns | solve (Schur complement, {m:,} unknowns) | per column | every column "
            "the one-column solve to the bit |", "|---|---|---|---|"]
    for k in (1, 2, 3, 4):
        b = rng.standard_normal((m, k))
        x = schur(b)
        same = all(np.array_equal(schur(np.ascontiguousarray(b[:, c])), x[:, c])
                   for c in range(k))
        arg = np.ascontiguousarray(b[:, 0]) if k == 1 else b
        schur(arg)
        t0 = time.perf_counter()
        for _ in range(repeats):
            schur(arg)
        ms = 1e3 * (time.perf_counter() - t0) / repeats
        rows.append(f"| {k} | {ms:.1f} ms | {ms / k:.1f} ms | {'yes' if same else 'no'} |")
        print(rows[-1], flush=True)
    return rows


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--map", type=int, default=4, help="suite map index (default 4)")
    ap.add_argument("--winds", default="1,2,3",
                    help="three comma-separated wind indices of that map with the same inlet "
                         "sides (default 1,2,3: 2 m/s at 15, 30 and 45 deg)")
    ap.add_argument("--repeats", type=int, default=2, help="A/B rounds (default 2)")
    ap.add_argument("--no-record", action="store_true", help="do not append to docs/benchmarks.md")
    args = ap.parse_args(argv)
    spec = get_suite("thesis")
    city = suite_map(spec, args.map)
    winds = [spec.wind(int(w)) for w in args.winds.split(",")]
    solve_rows = solve_table(city, *winds[0], repeats=30)
    reuse = WorkerReuse()
    suite_flows(spec, city, winds, reuse=reuse)  # warm: frame memory and factorisation
    gc.collect()
    times = {"one at a time": [], "three together": []}
    digests = {}
    for _ in range(args.repeats):
        for mode in times:
            gc.collect()
            got = []
            t0 = time.perf_counter()
            if mode == "one at a time":
                for wind in winds:
                    (flow,) = suite_flows(spec, city, [wind], reuse=reuse)
                    times[mode].append(time.perf_counter() - t0)
                    got.append(_digest(flow))
                    del flow
                    gc.collect()
                    t0 = time.perf_counter()
            else:
                flows = suite_flows(spec, city, winds, reuse=reuse)
                times[mode] += [(time.perf_counter() - t0) / len(winds)] * len(winds)
                got = [_digest(f) for f in flows]
                del flows
            digests.setdefault(mode, got)
            if got != digests[mode]:
                print(f"{mode}: a repeat gave other winds", file=sys.stderr)
                return 1
            print(f"{mode}: {statistics.mean(times[mode][-len(winds):]):.1f} s per wind",
                  flush=True)
    same = digests["one at a time"] == digests["three together"]
    print(f"every wind the same to the bit both ways: {same}")
    if not same:
        print("the batched winds differ from the winds simulated alone", file=sys.stderr)
        return 1
    alone, together = (statistics.median(times[m]) for m in times)
    n_winds = spec.n_scenarios // 4
    rows = [
        f"- map {args.map}, winds {args.winds} (the same inlet sides; 600 m, 25 s + 100 s at "
        "dt 0.25 s, dx 1 m), one process, a worker's memory and factorisation reused both "
        f"ways, {args.repeats} rounds alternating; every wind's frames and mean the same to "
        "the bit both ways",
        "",
        *solve_rows,
        "",
        "| per wind (median) | one at a time | three together | ratio |",
        "|---|---|---|---|",
        f"| simulation | {alone:.1f} s | {together:.1f} s | {alone / together:.2f}x |",
        "",
        f"- the thesis suite's {n_winds} winds per variant on 2 workers: "
        f"{n_winds * alone / 2 / 60:.1f} min one at a time, "
        f"{n_winds * together / 2 / 60:.1f} min three together (one process's times)",
    ]
    print("\n".join(rows))
    if not args.no_record:
        append_record("Navigation benchmark wind: three winds per pressure solve "
                      "(bench_wind_batch.py)", rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
