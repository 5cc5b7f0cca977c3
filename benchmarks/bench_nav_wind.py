"""The navigation benchmark's wind time: a worker reusing its memory and factorisations, A/B.

Run: ``.venv/bin/python benchmarks/bench_nav_wind.py`` (about 4-5 minutes on one core).

Every (map, wind) group of ``windnav benchmark-nav --suite thesis`` starts by simulating a
600 m wind (25 s + 100 s at dt 0.25 s, dx 1 m; 2.3 GB of frames). This times the winds of one
suite map the way a worker meets them, in one process, two ways, alternating:

* fresh (the reference, and the behaviour before): new memory for the frames and a new
  pressure factorisation for every wind;
* reused (what a benchmark worker now does, ``nav_benchmark.WorkerReuse``): the frames written
  into the memory of the previous wind, and the factorisation kept for winds with the same
  inflow sides (the 15, 30 and 45 deg winds of a map, and every speed of an incidence).

It checks that both give the same wind to the bit (every frame and the mean), prints the mean
time per wind of each, their ratio, and the suite's wind time per variant on 2 workers
(256 winds / 2 x the reused time per wind), and appends them to docs/benchmarks.md.

It also times, on each reused wind, the wind field of its frames built the two ways
:class:`~windnav.wind.gridded.GriddedWind` can: trusted (``known_finite=True``, what a
simulated wind's ``wind_field`` now does: the solver checked every step) and scanned (every
value checked finite, what it did before), and checks both fields equal to the bit.
"""

from __future__ import annotations

import os

for _var in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import gc  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _record import append_record  # noqa: E402

from windnav.experiments.nav_benchmark import WorkerReuse, suite_flow  # noqa: E402
from windnav.experiments.nav_suite import get_suite, suite_map  # noqa: E402
from windnav.wind.gridded import GriddedWind  # noqa: E402


def _bitwise(a, b) -> bool:
    return a.shape == b.shape and a.tobytes() == b.tobytes()


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--map", type=int, default=4, help="suite map index (default 4)")
    ap.add_argument("--winds", default="1,2,3,5",
                    help="comma-separated wind indices of that map, flown in this order "
                         "(default 1,2,3,5: 2 m/s at 15, 30, 45 deg and 5 m/s at 15 deg)")
    ap.add_argument("--no-record", action="store_true", help="do not append to docs/benchmarks.md")
    args = ap.parse_args(argv)
    spec = get_suite("thesis")
    city = suite_map(spec, args.map)
    winds = [int(w) for w in args.winds.split(",")]
    # compile the kernels outside the timings: the suite's wind with a 2-step record
    suite_flow(dataclasses.replace(spec, spinup_s=0.25, record_s=0.5), city, 5.0, 0.0)
    reuse = WorkerReuse()
    times = {"fresh": [], "reused": []}
    field_s = {"trusted": [], "scanned": []}
    for w in winds:
        speed, direction = spec.wind(w)
        flows = {}
        for mode in ("fresh", "reused"):
            gc.collect()
            t0 = time.perf_counter()
            flows[mode] = suite_flow(spec, city, speed, direction,
                                     reuse=reuse if mode == "reused" else None)
            times[mode].append(time.perf_counter() - t0)
        a, b = flows["fresh"], flows["reused"]
        same = all(_bitwise(getattr(a, n), getattr(b, n))
                   for n in ("frames_u", "frames_v", "mean_u", "mean_v"))
        print(f"w{w:02d} {speed:g} m/s {direction:g} deg: fresh {times['fresh'][-1]:.1f} s, "
              f"reused {times['reused'][-1]:.1f} s, bitwise same: {same}", flush=True)
        if not same:
            print("the reused wind differs from the fresh one", file=sys.stderr)
            return 1
        sol = b.solution
        fields = {}
        for mode in ("trusted", "scanned"):
            t0 = time.perf_counter()
            fields[mode] = GriddedWind(sol.x, sol.y, sol.frames_u, sol.frames_v, t=sol.t,
                                       solid=sol.solid, known_finite=mode == "trusted")
            field_s[mode].append(time.perf_counter() - t0)
        if not (_bitwise(fields["trusted"].u, fields["scanned"].u)
                and _bitwise(fields["trusted"].v, fields["scanned"].v)):
            print("the trusted wind field differs from the scanned one", file=sys.stderr)
            return 1
        print(f"    wind field of the frames: trusted {field_s['trusted'][-1]:.3f} s, "
              f"scanned {field_s['scanned'][-1]:.3f} s", flush=True)
        del fields, sol
        del a, b, flows
    fresh, reused = statistics.mean(times["fresh"]), statistics.mean(times["reused"])
    # the first reused wind pays for new memory and a factorisation like a fresh one; a worker
    # meets it once per worker (memory) and per map and inflow sides (factorisation)
    steady = statistics.mean(times["reused"][1:]) if len(winds) > 1 else reused
    n_winds = spec.n_scenarios // 4
    trusted, scanned = (statistics.mean(field_s[m]) for m in ("trusted", "scanned"))
    rows = [
        f"- map {args.map}, winds {args.winds} (a 600 m map, 25 s + 100 s at dt 0.25 s, "
        "dx 1 m), one process, fresh and reused alternating; every reused wind equals the "
        "fresh one to the bit (frames and mean)",
        "",
        "| per wind | fresh (new memory, new factorisation) | reused (worker memory and "
        "factorisations) | ratio |",
        "|---|---|---|---|",
        f"| mean of all | {fresh:.1f} s | {reused:.1f} s | {fresh / reused:.2f}x |",
        f"| after the first | {statistics.mean(times['fresh'][1:]):.1f} s | {steady:.1f} s | "
        f"{statistics.mean(times['fresh'][1:]) / steady:.2f}x |",
        "",
        f"- the thesis suite's {n_winds} winds per variant on 2 workers: "
        f"{n_winds * fresh / 2 / 60:.1f} min fresh, {n_winds * steady / 2 / 60:.1f} min reused "
        "(one process's times; two workers share the memory bus)",
        f"- the wind field of a wind's frames (bitwise the same both ways): {trusted:.3f} s "
        f"trusted, {scanned:.3f} s scanned (every value checked finite): "
        f"{scanned - trusted:.2f} s saved per wind, "
        f"{n_winds * (scanned - trusted) / 2 / 60:.1f} min per variant on 2 workers",
    ]
    print("\n".join(rows))
    if not args.no_record:
        append_record("Navigation benchmark wind: worker reuse of frame memory and "
                      "factorisations (bench_nav_wind.py)", rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
