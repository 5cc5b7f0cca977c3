"""The mean wind within the success radius of each goal of a list of scenarios (analysis).

Usage::

    .venv/bin/python docs/navigation/goal_wind.py SEED IDS_FILE OUT.jsonl

``SEED`` the ``thesis`` suite's seed, ``IDS_FILE`` one scenario id per line. Each scenario's
wind is simulated again as the benchmark does (``group_wind``, about 45 s per wind on one
core); per scenario one JSON line is appended to ``OUT.jsonl``, over the 100 s record:
``goal_mean`` (m/s, the mean wind speed at the free 1 m cell nearest the goal),
``goal_frac_le_13.45`` (the share of the record whose wind there is at most 13.45 m/s, the
envelope), and for the free cells within ``r`` = 3.5 and 5 m of the goal: the least and
largest mean speed (``min_mean_r{r}``, ``max_mean_r{r}``), the share under 13.45 m/s at the
cell of least mean (``best_frac_le_13.45_r{r}``) and the share of frames in which some cell
is under it (``any_frac_le_13.45_r{r}``). Run on 2026-11-29 for the 38 captured failures of
the sixth variant on seed 1 (``heldout_captured_ids.txt``): ``heldout_goal_wind.jsonl``,
summarised in docs/navigation.md.
"""

import json
import sys
import time

import numpy as np

from windnav.experiments.nav_benchmark import group_wind
from windnav.experiments.nav_suite import get_suite, parse_scenario_id

ENVELOPE_MPS = 13.45


def main(seed: int, ids_path: str, out_path: str) -> None:
    ids = [line.strip() for line in open(ids_path) if line.strip()]
    spec = get_suite("thesis", seed)
    by_group: dict = {}
    for sid in ids:
        sc = parse_scenario_id(spec, sid)
        by_group.setdefault(sc.group, []).append(sc)
    with open(out_path, "a") as out:
        for (m, w), scenarios in sorted(by_group.items()):
            t0 = time.time()
            _, flow, _ = group_wind(spec, m, w)
            sol = flow.solution
            X, Y = np.meshgrid(sol.x, sol.y)
            mean_speed = np.hypot(sol.mean_u, sol.mean_v)
            frames = np.hypot(sol.frames_u, sol.frames_v)  # (T, ny, nx)
            for sc in scenarios:
                d = np.hypot(X - sc.goal[0], Y - sc.goal[1])
                ig = np.unravel_index(np.argmin(np.where(sol.solid, np.inf, d)), d.shape)
                rec = {"id": sc.scenario_id, "speed": sc.speed, "kind": sc.kind,
                       "goal_mean": float(mean_speed[ig]),
                       "goal_frac_le_13.45": float((frames[:, ig[0], ig[1]]
                                                    <= ENVELOPE_MPS).mean())}
                for r in (3.5, 5.0):
                    mask = (d <= r) & ~sol.solid
                    ib = np.unravel_index(np.argmin(np.where(mask, mean_speed, np.inf)),
                                          d.shape)
                    rec[f"min_mean_r{r}"] = float(mean_speed[ib])
                    rec[f"max_mean_r{r}"] = float(mean_speed[mask].max())
                    rec[f"best_frac_le_13.45_r{r}"] = float(
                        (frames[:, ib[0], ib[1]] <= ENVELOPE_MPS).mean())
                    rec[f"any_frac_le_13.45_r{r}"] = float(
                        (frames[:, mask].min(axis=1) <= ENVELOPE_MPS).mean())
                out.write(json.dumps(rec) + "\n")
                out.flush()
            print(f"m{m:02d} w{w:02d}: {len(scenarios)} goals, {time.time() - t0:.1f} s",
                  flush=True)


if __name__ == "__main__":
    main(int(sys.argv[1]), sys.argv[2], sys.argv[3])
