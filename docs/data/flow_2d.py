"""What a 2D city does to the wind (flow_validation.md, "What a 2D city leaves out"). Writes the
JSON named on the command line; about 2 minutes on one core.

    .venv/bin/python docs/data/flow_2d.py docs/data/flow_2d.json

Two sets of flows, each in units of its inlet speed U, over the open cells:
- the navigation benchmark's own winds: the thesis suite's (seed 0) map 0 and its four 10 m/s
  winds (inlets toward 0, 15, 30 and 45 deg), as the benchmark simulates them
  (``nav_benchmark.group_wind``: 1 m cells, dt = 0.25 s, 25 s of spin-up, 100 s of frames):
  how much of the map and of its worst cross-section is built, the distribution of the mean
  speed and of the instantaneous speed, the share of open cells whose mean is faster than
  1.3 U, and the fluctuation (both components' standard deviations over the frames, combined)
  at the median and 95th-percentile cell; each wind's figures and their range;
- a 200 m training map (``training_map(rng=3, size=200)``) at the decoder recipe's protocol
  (6 m/s, dt = 1/6 s, 100 + 200 steps): the same blockage and mean-speed figures.
In 2D all the air must pass between the buildings, so a cross-section blocked by a fraction b
speeds the flow up by about 1 / (1 - b) on average; in a 3D city much of it passes over the
roofs instead.
"""

import json
import sys
import time

import numpy as np

import windnav as wn


def _figures(sol, speed, frames=True):
    open_ = ~sol.solid
    mean = np.hypot(sol.mean_u, sol.mean_v)[open_] / speed
    blocked = max(float(sol.solid.mean(axis=0).max()), float(sol.solid.mean(axis=1).max()))
    out = {"built_fraction": float(sol.solid.mean()),
           "worst_cross_section_blocked": blocked,
           "continuity_speed_up_there": 1.0 / (1.0 - blocked),
           "mean_speed_over_U": {"p50": float(np.percentile(mean, 50)),
                                 "p95": float(np.percentile(mean, 95)),
                                 "p99": float(np.percentile(mean, 99)),
                                 "max": float(mean.max())},
           "open_share_mean_above_1.3_U": float((mean > 1.3).mean())}
    if frames:
        fu, fv = sol.frames_u[:, open_], sol.frames_v[:, open_]
        inst = np.hypot(fu, fv) / speed
        sd = np.hypot(fu.std(axis=0), fv.std(axis=0)) / speed
        out["instantaneous_speed_over_U"] = {"p99.9": float(np.percentile(inst, 99.9)),
                                             "max": float(inst.max())}
        out["fluctuation_rms_over_U"] = {"p50": float(np.percentile(sd, 50)),
                                         "p95": float(np.percentile(sd, 95))}
    return out


def main(path):
    from windnav.experiments.nav_benchmark import group_wind
    from windnav.experiments.nav_suite import get_suite

    t0 = time.perf_counter()
    spec = get_suite("thesis", seed=0)
    bench = {}
    for w in (12, 13, 14, 15):
        speed, direction = spec.wind(w)
        _, flow, _ = group_wind(spec, 0, w)
        bench[f"wind_{w}_toward_{direction:g}_deg"] = _figures(flow.solution, speed)
    recipe = wn.flow.simulate(wn.city.training_map(rng=3, size=200.0), speed=6.0,
                              direction_deg=0.0, dx=1.0, dt=1.0 / 6.0, spinup_steps=100,
                              steps=200)
    out = {"command": "python docs/data/flow_2d.py " + path,
           "benchmark_thesis_map_0_10_m_s": bench,
           "recipe_training_map_3_6_m_s": _figures(recipe, 6.0, frames=False),
           "elapsed_s": round(time.perf_counter() - t0, 1)}
    with open(path, "w") as f:
        json.dump(out, f, indent=1)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main(sys.argv[1])
