"""EA-MPPI+Ŵ's closed-loop flight with and without the decodes no planner update reads, A/B.

Run: ``.venv/bin/python benchmarks/bench_onboard_decodes.py`` (about 2 minutes on one core).

The onboard stack's decoder is due at 50 Hz and the planner reads its field at 10 Hz, so 4 of
every 5 decodes are never read. Since 2026-12-04 the stack computes a decode only when a
planner update reads it, drawing each due decode's scan noise at its own time so that the
stream, and so every flight, stays the same (:class:`~windnav.experiments.onboard.
OnboardOptions`, ``decode_all``). This flies the four start-goal pairs of one suite wind
(default ``thesis/m04/w08``, simulated once) with EA-MPPI+Ŵ both ways, alternating:

* every decode: ``decode_all=True``, the stack as it ran before (the reference);
* read decodes: the default.

It checks that each pair's two records are equal on every field but the timings, and compares
them with the committed store's (flown under that record's arithmetic, restarting in a new
process when this machine's differs and can run it), prints the wall time of each flight
(median of the repetitions) and the decodes computed, and appends them to docs/benchmarks.md.
"""

from __future__ import annotations

import os

for _var in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _record import append_record, matches_record, under_record_arithmetic  # noqa: E402

from windnav.experiments import nav_benchmark  # noqa: E402
from windnav.experiments.nav_suite import get_suite, parse_scenario_id  # noqa: E402
from windnav.experiments.navigate import navigate  # noqa: E402
from windnav.experiments.onboard import OnboardOptions  # noqa: E402

TIMINGS = {"wall_s", "loop_wall_s", "flow_s", "planner_ms_median", "stage_ms_median",
           "real_time_fraction"}
"""Record fields that are wall times, not flight results."""


def same_value(a, b) -> bool:
    """Equal, counting NaN equal to NaN (a flight that never arrived has no arrival time)."""
    return a == b or (isinstance(a, float) and isinstance(b, float) and a != a and b != b)


def keeping(fn, results: list):
    """``fn`` (a ``navigate``) that also appends each flight's result to ``results`` (the
    record leaves out the stack's decode counts)."""
    def navigate_fn(*args, **kwargs):
        results.append(fn(*args, **kwargs))
        return results[-1]
    return navigate_fn


def navigate_every_decode(*args, **kwargs):
    """:func:`~windnav.experiments.navigate.navigate` with every due decode computed."""
    options = OnboardOptions.coerce(kwargs.pop("onboard", None), "bench_onboard_decodes")
    return navigate(*args, onboard=dataclasses.replace(options, decode_all=True), **kwargs)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--wind", default="thesis/m04/w08",
                    help="the suite wind whose four pairs are flown (default thesis/m04/w08)")
    ap.add_argument("--repeats", type=int, default=3, help="flights of each pair each way (3)")
    ap.add_argument("--no-record", action="store_true", help="do not append to docs/benchmarks.md")
    args = ap.parse_args(argv)
    spec = get_suite("thesis")
    scenarios = [parse_scenario_id(spec, f"{args.wind}/p{p}") for p in range(4)]
    sc0 = scenarios[0]
    committed = {sc.scenario_id: under_record_arithmetic(sc.scenario_id, "ea-mppi-w-hat")
                 for sc in scenarios}  # one store, one arithmetic: restarts at most once
    city, flow, flow_s = nav_benchmark.group_wind(spec, sc0.map_index, sc0.wind_index)
    print(f"{args.wind}: wind simulated in {flow_s:.1f} s", flush=True)
    results = []
    modes = {"every": keeping(navigate_every_decode, results), "read": keeping(navigate, results)}
    times = {(sc.scenario_id, m): [] for sc in scenarios for m in modes}
    records = {}
    decodes = {}
    for rep in range(args.repeats + 1):  # the first round compiles and warms: not timed
        for sc in scenarios:
            for mode, fn in modes.items():
                t0 = time.perf_counter()
                rec = nav_benchmark.fly_scenario(spec, sc, "ea-mppi-w-hat", city=city,
                                                 flow=flow, navigate_fn=fn)
                seconds = time.perf_counter() - t0
                if rec["error"]:
                    raise RuntimeError(rec["error"])
                if rep:
                    times[(sc.scenario_id, mode)].append(seconds)
                records[(sc.scenario_id, mode)] = rec
                decodes[(sc.scenario_id, mode)] = results[-1].onboard.settings["decoder_computed"]
    same = True
    rows = [f"- the four pairs of `{args.wind}` flown with EA-MPPI+Ŵ, {args.repeats} times each "
            "way, alternating, after one untimed round; wind simulated once "
            f"({flow_s:.1f} s)", "",
            "| flight | outcome, simulated time | every decode: wall | read decodes: wall | "
            "ratio | decodes computed (every / read) | records equal but the timings | "
            "as committed |",
            "|---|---|---|---|---|---|---|---|"]
    tot = {m: 0.0 for m in modes}
    for sc in scenarios:
        a, b = records[(sc.scenario_id, "every")], records[(sc.scenario_id, "read")]
        differ = sorted(k for k in a if k not in TIMINGS and not same_value(a[k], b[k]))
        if differ:
            print(f"{sc.scenario_id}: differ in {differ}: {[(a[k], b[k]) for k in differ]}")
        equal = not differ
        matched = matches_record(b, committed[sc.scenario_id])
        print(f"{sc.scenario_id}: {matched}")
        same &= equal and set(a) == set(b)
        med = {m: statistics.median(times[(sc.scenario_id, m)]) for m in modes}
        for m in modes:
            tot[m] += med[m]
        rows.append(f"| `{sc.scenario_id}` | {a['outcome']}, {a['time_s']:.1f} s | "
                    f"{med['every']:.3f} s | {med['read']:.3f} s | "
                    f"{med['every'] / med['read']:.2f}x | "
                    f"{decodes[(sc.scenario_id, 'every')]} / "
                    f"{decodes[(sc.scenario_id, 'read')]} | {'yes' if equal else 'NO'} | "
                    f"{'yes' if matched.startswith('the flight matches') else 'no'} |")
    rows.append(f"| all four | | {tot['every']:.3f} s | {tot['read']:.3f} s | "
                f"{tot['every'] / tot['read']:.2f}x | | {'yes' if same else 'NO'} | |")
    print("\n".join(rows))
    if not same:
        print("the flights differ between the two ways", file=sys.stderr)
        return 1
    if not args.no_record:
        append_record("EA-MPPI+Ŵ flights: the decodes no planner update reads skipped "
                      "(bench_onboard_decodes.py)", rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
