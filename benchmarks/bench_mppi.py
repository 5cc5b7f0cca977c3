"""Benchmark: one MPPI update (windnav, Numba) against pytorch_mppi on the same problem.

The problem, in both planners: the planner's point mass (4 states, 2 controls, quadratic drag
in a uniform wind known inside a 60 m window), progress + obstacle + energy cost with the
Hummingbird's constants (``planner_config(params, "ea-mppi-w")``), a LiDAR scan of a planning
map (obstacle cost by brute force over the points in torch, by the distance field in windnav)
and a goal 100 m away. Shapes: 1000 samples x 25 steps and 100 x 187 (the thesis's). windnav's
update includes building the obstacle field from the scan; pytorch_mppi's ``command`` samples,
rolls out, weights and updates. Before timing, the two costs of the same control samples are
compared (they must agree). Timings are medians over interleaved repeats; windnav runs at each
of ``--windnav-threads`` (``MPPIPlanner(threads=N)``, default 1 and all cores; 1 is the
benchmark suite's planner) and torch in ``--torch-dtype`` (default float32, its faster) at each
of ``--torch-threads`` (default 1 and all cores: on a loaded machine its threads stall each
other); each planner's fastest count is its figure, and the ratio of the two at one thread
each (one core each) is reported beside it. Each figure is the smallest of
``--repeats`` interleaved rounds' medians (load from other processes only adds time); every
round is written to the JSON.

Also: GS+W (energy_route) on a 600 m planning map, ``planning_map(rng=0)``, in a non-uniform
wind, corner to corner.

    .venv/bin/python benchmarks/bench_mppi.py [--json FILE] [--no-record] [--repeats 4]
"""

from __future__ import annotations

import os

# before numba is imported: as many threads as windnav is timed on (1 runs no parallel region)
os.environ["NUMBA_NUM_THREADS"] = str(os.cpu_count() or 1)
for _var in ("OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ.setdefault(_var, "1")
# torch's OpenMP threads sleep when idle instead of spinning (GOMP's default): a spinning
# thread holds the second core through the next timed update of either planner. On an Intel
# Xeon (2026-12-03) it made pytorch_mppi faster (23-29 ms against 37-44 at 1000 x 25 on 2
# threads) and windnav's rounds steadier; the reference is timed at its best.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import json  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402

import windnav as wn  # noqa: E402
from windnav.plan import (  # noqa: E402
    LocalWind,
    MPPIPlanner,
    Problem,
    energy_route,
    free_space,
    fused_rollout_cost,
    obstacle_field,
    planner_config,
    sample_controls,
    scan_points,
)

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _record import append_record, machine  # noqa: E402

SHAPES = ((1000, 25), (100, 187))
WIND = (4.0, -1.5)
WINDOW = 60.0


def scene(seed: int = 0):
    """A planning map, a free origin with a busy scan, and the scan."""
    city = wn.city.planning_map(rng=seed)
    rng = np.random.default_rng(seed)
    best = None
    for _ in range(200):
        o = rng.uniform(60, 540, 2)
        if city.contains(o[None])[0]:
            continue
        r = city.lidar(o)[0]
        n = int(np.sum(r < 100.0))
        if best is None or n > best[0]:
            best = (n, o, r)
    return city, best[1], best[2]


class TorchProblem:
    """The same point mass and cost in torch, for pytorch_mppi."""

    def __init__(self, torch, cfg, goal, points, dtype):
        t = torch
        self.t = t
        self.cfg = cfg
        self.dtype = dtype
        self.goal = t.tensor(goal, dtype=dtype)
        self.points = t.tensor(points, dtype=dtype)
        self.wind = t.tensor(WIND, dtype=dtype)
        self.tab = t.tensor(cfg.power_table(), dtype=dtype)
        self.half = WINDOW / 2
        self._power = None

    def power_bar(self, s):
        tab = self.tab
        r = self.t.zeros_like(s)
        for c in tab[4:].flip(0):                  # Horner, c_n .. c_0
            r = r * s + c
        e = s - tab[0]
        return self.t.where(s <= tab[0], r, tab[1] + e * (tab[2] + e * tab[3]))

    def dynamics(self, state, u):
        t, cfg = self.t, self.cfg
        p, v = state[:, :2], state[:, 2:]
        inside = (p.abs() <= self.half).all(dim=1, keepdim=True)
        w = t.where(inside, self.wind, t.zeros_like(self.wind))
        va = v - w
        s = va.norm(dim=1, keepdim=True)
        self._power = self.power_bar(s[:, 0])      # P(|v_k - w_k|), read by the running cost
        u = u.clamp(cfg.a_min, cfg.a_max)
        return t.cat([p + cfg.dt * v, v + cfg.dt * (u - cfg.drag * s * va)], dim=1)

    def running_cost(self, state, u):
        cfg = self.cfg
        e = (state[:, :2] - self.goal) / cfg.lidar_range
        return (e * e).sum(dim=1) + cfg.energy_weight * cfg.dt * self._power

    def terminal_cost(self, states, actions):
        cfg = self.cfg
        pos = states[0, :, :, :2]
        k, n = pos.shape[:2]
        # exact distances (the default matrix-product shortcut loses the small ones in float32)
        d = self.t.cdist(pos.reshape(-1, 2), self.points,
                         compute_mode="donot_use_mm_for_euclid_dist").min(dim=1).values
        d = d.reshape(k, n)
        d2 = (d.min(dim=1).values ** 2).clamp(min=1e-6)
        return (cfg.obstacle_weight * cfg.lidar_range**2 / d2)[None]


def numba_layer() -> str:
    import numba

    try:
        return numba.threading_layer()
    except ValueError:  # no parallel region ran (one thread only)
        return "unused"


def median_ms(fn, n: int) -> float:
    out = np.empty(n)
    for i in range(n):
        t0 = time.perf_counter()
        fn()
        out[i] = time.perf_counter() - t0
    return float(np.median(out) * 1e3)


def bench_shape(torch, pytorch_mppi, base, S, Kk, origin, scan, args):
    cfg = dataclasses.replace(base, n_samples=S, n_steps=Kk, horizon=WINDOW)
    goal_rel = np.array([80.0, 60.0])
    goal = origin + goal_rel
    state = np.r_[origin, 3.0, 1.0]
    wind = LocalWind.uniform(WIND)
    planner = MPPIPlanner(cfg, goal_xy=goal, rng=args.seed)
    pts = scan_points(scan, max_range=cfg.lidar_range)
    planners = {n: MPPIPlanner(cfg, goal_xy=goal, rng=args.seed, threads=n)
                for n in args.windnav_threads}

    dtype = torch.float32 if args.torch_dtype == "float32" else torch.float64
    tp = TorchProblem(torch, cfg, goal_rel, pts, dtype)
    torch.manual_seed(args.seed)
    ref = pytorch_mppi.MPPI(tp.dynamics, tp.running_cost, 4,
                            noise_sigma=torch.eye(2, dtype=dtype) * cfg.sigma_u**2,
                            num_samples=S, horizon=Kk, lambda_=cfg.temperature,
                            u_min=torch.full((2,), cfg.a_min, dtype=dtype),
                            u_max=torch.full((2,), cfg.a_max, dtype=dtype),
                            terminal_state_cost=tp.terminal_cost)
    x0 = torch.tensor([0.0, 0.0, 3.0, 1.0], dtype=dtype)

    # same problem: both cost the same control samples alike
    rng = np.random.default_rng(args.seed)
    u = rng.normal(0, 8.0, (S, Kk, 2))
    problem = Problem(state[2:], goal_rel, obstacle_field(pts), wind.pack(cfg.horizon))
    ours_cost, _ = fused_rollout_cost(cfg, np.ascontiguousarray(u.transpose(1, 2, 0)), problem)
    ref.state = x0
    ref_cost, _, _ = ref._compute_rollout_costs(torch.tensor(u, dtype=dtype))
    agree = float(np.max(np.abs(ref_cost.double().numpy() / ours_cost - 1)))

    for _ in range(20):                                  # compile, warm caches
        planner.update(state, scan, wind)
        for other in planners.values():
            other.update(state, scan, wind)
    for _ in range(3):
        ref.command(x0)
    # the fused kernel split: dynamics + progress + energy alone, and with the obstacle cost
    u32 = sample_controls(cfg, planner.mean, rng=np.random.default_rng(args.seed))
    bare = Problem(state[2:], goal_rel, obstacle_field(np.zeros((0, 2))), problem.wind)
    split = {"rollout_progress_energy": median_ms(lambda: fused_rollout_cost(cfg, u32, bare),
                                                 args.updates),
             "with_obstacle_cost": median_ms(lambda: fused_rollout_cost(cfg, u32, problem),
                                             args.updates)}
    # fresh planners for the timing (the warm-up's advanced their random streams)
    planners = {n: MPPIPlanner(cfg, goal_xy=goal, rng=args.seed, threads=n)
                for n in args.windnav_threads}
    for p in planners.values():
        p.update(state, scan, wind)
    t_ours = {n: [] for n in args.windnav_threads}
    t_ref = {n: [] for n in args.torch_threads}
    for _ in range(args.repeats):
        for n, p in planners.items():
            t_ours[n].append(median_ms(lambda p=p: p.update(state, scan, wind), args.updates))
        for n in args.torch_threads:
            torch.set_num_threads(n)
            t_ref[n].append(median_ms(lambda: ref.command(x0), args.ref_updates))
    # other processes only ever add time: the best round's median is each planner's own cost;
    # each planner's figure is its fastest thread count in this run
    by_threads = {n: min(v) for n, v in t_ref.items()}
    ours = {n: min(v) for n, v in t_ours.items()}
    first = min(args.windnav_threads)
    return {"windnav_ms": min(ours.values()), "windnav_ms_by_threads": ours,
            "pytorch_mppi_ms": min(by_threads.values()),
            "pytorch_mppi_ms_by_threads": by_threads,
            "rounds_ms": {**{f"windnav_{n}_threads": v for n, v in t_ours.items()},
                          **{f"pytorch_mppi_{n}_threads": v for n, v in t_ref.items()}},
            "cost_agreement": agree, "profile_ms": planners[first].stats.mean_profile_ms(),
            "kernel_split_ms": split, "n_points": int(len(pts))}


class SwirlWind:
    """A smooth non-uniform wind over the 600 m map (for GS+W timing), m/s."""

    def velocity(self, t, xyz):
        x, y = xyz[:, 0] / 600.0, xyz[:, 1] / 600.0
        w = np.zeros((len(xyz), 3))
        w[:, 0] = 5.0 + 3.0 * np.sin(2 * np.pi * y)
        w[:, 1] = 2.0 * np.cos(2 * np.pi * x)
        return w


def bench_gs(base) -> dict:
    city = wn.city.planning_map(rng=0)
    cfg = dataclasses.replace(base, variant="gs-w", energy_weight=None, use_wind=None)
    _, _, free = free_space(city, 2.0, 6.0)
    x, y = city.grid(2.0)
    cells = np.argwhere(free)
    a = cells[np.argmin(cells.sum(1))]
    b = cells[np.argmax(cells.sum(1))]
    start, goal = (x[a[1]], y[a[0]]), (x[b[1]], y[b[0]])
    energy_route(wn.city.City((0, 100, 0, 100), np.zeros((0, 4)), np.zeros(0)), (9, 9), (91, 91),
                 cfg)                                    # compile outside the timing
    t0 = time.perf_counter()
    r = energy_route(city, start, goal, cfg, wind=SwirlWind())
    s = time.perf_counter() - t0
    return {"gs_w_s_600m": s, "start": list(map(float, start)), "goal": list(map(float, goal)),
            "length_m": r.length, "energy_J": r.energy, "waypoints": int(len(r.waypoints))}


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", type=Path, help="write the figures to this JSON file")
    ap.add_argument("--no-record", action="store_true", help="do not append docs/benchmarks.md")
    ap.add_argument("--repeats", type=int, default=4, help="interleaved timing rounds")
    ap.add_argument("--updates", type=int, default=200, help="windnav updates per round")
    ap.add_argument("--ref-updates", type=int, default=10, help="pytorch_mppi updates per round")
    ap.add_argument("--torch-threads", type=int, nargs="+",
                    default=sorted({1, os.cpu_count() or 1}),
                    help="torch thread counts to try; the fastest is the reference")
    ap.add_argument("--windnav-threads", type=int, nargs="+",
                    default=sorted({1, os.cpu_count() or 1}),
                    help="windnav thread counts (MPPIPlanner(threads=N)); the fastest is its "
                         "figure")
    ap.add_argument("--torch-dtype", choices=("float32", "float64"), default="float32")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--skip-gs", action="store_true")
    args = ap.parse_args(argv)

    import pytorch_mppi
    import torch

    base = planner_config(wn.vehicle.params("hummingbird"), "ea-mppi-w")
    _, origin, scan = scene(args.seed)
    out = {"machine": machine(), "torch": torch.__version__,
           "torch_threads_tried": args.torch_threads, "torch_dtype": args.torch_dtype,
           "numba_threads": int(os.environ["NUMBA_NUM_THREADS"]),
           "windnav_threads_tried": args.windnav_threads}
    rows = ["| shape (samples x steps) | windnav ms (fastest thread count) | pytorch_mppi ms "
            "(fastest thread count) | speed-up | speed-up, one core each | windnav ms per "
            "thread count | pytorch_mppi ms per thread count | windnav mean profile ms, "
            f"{min(args.windnav_threads)} thread{'s' if min(args.windnav_threads) > 1 else ''} "
            "(obstacles / sampling / rollout+cost / update) "
            "| fused kernel ms (no obstacles / all costs) |",
            "|---|---|---|---|---|---|---|---|---|"]
    for S, Kk in SHAPES:
        r = bench_shape(torch, pytorch_mppi, base, S, Kk, origin, scan, args)
        tag = f"{S}x{Kk}"
        out[f"windnav_ms_{tag}"] = r["windnav_ms"]
        out[f"pytorch_mppi_ms_{tag}"] = r["pytorch_mppi_ms"]
        out[f"speedup_{tag}"] = r["pytorch_mppi_ms"] / r["windnav_ms"]
        # like for like: both on one thread
        one = r["pytorch_mppi_ms_by_threads"].get(1)
        ours_one = r["windnav_ms_by_threads"].get(1)
        out[f"speedup_one_core_{tag}"] = (None if one is None or ours_one is None
                                          else one / ours_one)
        out[f"windnav_ms_by_threads_{tag}"] = r["windnav_ms_by_threads"]
        out[f"pytorch_mppi_ms_by_threads_{tag}"] = r["pytorch_mppi_ms_by_threads"]
        out[f"rounds_ms_{tag}"] = r["rounds_ms"]
        out[f"profile_ms_{tag}"] = r["profile_ms"]
        out[f"kernel_split_ms_{tag}"] = r["kernel_split_ms"]
        out[f"cost_agreement_{tag}"] = r["cost_agreement"]
        out["scan_points"] = r["n_points"]
        p, k = r["profile_ms"], r["kernel_split_ms"]
        threads = ", ".join(f"{n}: {v:.1f}" for n, v in r["pytorch_mppi_ms_by_threads"].items())
        mine = ", ".join(f"{n}: {v:.2f}" for n, v in r["windnav_ms_by_threads"].items())
        ratio = out[f"speedup_one_core_{tag}"]
        one_core = "-" if ratio is None else f"{ratio:.0f}x"
        rows.append(f"| {tag} | {r['windnav_ms']:.2f} | {r['pytorch_mppi_ms']:.1f} | "
                    f"**{out[f'speedup_{tag}']:.0f}x** | {one_core} | {mine} | {threads} | "
                    f"{p['obstacles']:.2f} / "
                    f"{p['sampling']:.2f} / {p['rollout_cost']:.2f} / {p['update']:.2f} | "
                    f"{k['rollout_progress_energy']:.2f} / {k['with_obstacle_cost']:.2f} |")
    agree = ", ".join(f"{out[f'cost_agreement_{S}x{K}']:.1e}" for S, K in SHAPES)
    rows += ["", f"- scan: {out['scan_points']} LiDAR returns; torch {out['torch']}, "
             f"{args.torch_dtype}; windnav on Numba's threads (the threading layer "
             f"{numba_layer()}), float64 state, float32 samples",
             f"- same problem: the two planners' costs of the same control samples agree to "
             f"{agree} (relative)"]
    if not args.skip_gs:
        gs = bench_gs(base)
        out.update(gs)
        rows.append(f"- GS+W on the 600 m map (planning_map(rng=0), dx 2 m, 16 moves, 79 speed "
                    f"levels), corner to corner ({gs['length_m']:.0f} m): **{gs['gs_w_s_600m']:.2f}"
                    " s**")
    print("\n".join(rows))
    if args.json:
        args.json.write_text(json.dumps(out, indent=2))
    if not args.no_record:
        append_record("MPPI update vs pytorch_mppi (benchmarks/bench_mppi.py)", rows,
                      command="python benchmarks/bench_mppi.py " + " ".join(argv or sys.argv[1:]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
