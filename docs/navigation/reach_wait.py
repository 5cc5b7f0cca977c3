"""How much the feasibility study's least times change when the vehicle may also hover before a
move it could fly (``least_time(..., wait="best")``) instead of only before one it cannot
(``"blocked"``, the committed study's rule). navigation.md, "Which scenarios can be flown at
all?". Writes the JSON named on the command line.

    .venv/bin/python docs/navigation/reach_wait.py docs/navigation/reach_wait.json

The thesis suite (seed 0), map 0, its 16 winds, the four pairs of each, in the recorded wind,
at airspeed limits of 10 and 13.45 m/s, each goal reached within the 5 m success radius, as the
study searches them; about 5 minutes on one core (the winds are simulated again).
"""

import json
import sys
import time

import numpy as np

from windnav.experiments.nav_benchmark import group_wind
from windnav.experiments.nav_suite import get_suite, parse_scenario_id
from windnav.experiments.navigate import GOAL_RADIUS
from windnav.plan.reach import least_time, reach_lattice


def main(path):
    t0 = time.perf_counter()
    spec = get_suite("thesis", seed=0)
    rows = []
    for w in range(16):
        city, flow, _ = group_wind(spec, 0, w)
        lat = reach_lattice(city, flow.solution.wind_field(unsteady=True), dx=2.0,
                            clearance=1.0)
        for p in spec.pairs:
            sc = parse_scenario_id(spec, f"{spec.name}/m00/w{w:02d}/p{p}")
            for a in (10.0, 13.45):
                times = {mode: least_time(lat, sc.start, sc.goal, airspeed_max=a,
                                          t_end=float(spec.record_s), goal_radius=GOAL_RADIUS,
                                          wait=mode).time_s for mode in ("blocked", "best")}
                rows.append({"scenario_id": sc.scenario_id, "speed": sc.speed, "kind": sc.kind,
                             "airspeed_max": a,
                             **{f"{m}_s": (t if np.isfinite(t) else None)
                                for m, t in times.items()}})
        print(f"wind {w}: {time.perf_counter() - t0:.0f} s", flush=True)
    summary = {}
    for a in (10.0, 13.45):
        sel = [r for r in rows if r["airspeed_max"] == a]
        both = [r for r in sel if r["blocked_s"] is not None and r["best_s"] is not None]
        gain = np.array([r["blocked_s"] - r["best_s"] for r in both])
        summary[f"{a:g}"] = {
            "scenarios": len(sel),
            "reached_blocked": sum(r["blocked_s"] is not None for r in sel),
            "reached_best": sum(r["best_s"] is not None for r in sel),
            "earlier_with_best": int((gain > 1e-9).sum()),
            "gain_s_max": float(gain.max()) if gain.size else None,
            "gain_s_mean": float(gain.mean()) if gain.size else None,
            "gain_relative_max": float(max((g / r["blocked_s"] for g, r in zip(gain, both,
                                                                               strict=True)),
                                           default=0.0))}
    out = {"command": "python docs/navigation/reach_wait.py " + path, "summary": summary,
           "rows": rows, "elapsed_s": round(time.perf_counter() - t0, 1)}
    with open(path, "w") as f:
        json.dump(out, f, indent=1)
    print(json.dumps(summary, indent=1))


if __name__ == "__main__":
    main(sys.argv[1])
