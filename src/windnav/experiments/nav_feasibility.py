"""Which benchmark scenarios can be flown at all within the vehicle's airspeed envelope?

For every scenario of a suite, :func:`reach_scenarios` bounds from below the time any planner
needs to reach the goal (:func:`windnav.plan.reach.least_time`): the vehicle turns and
accelerates instantly and flies every move at the largest ground speed its airspeed limit
allows in the wind, on the 2 m lattice of the GS baseline with 1 m of clearance. It does so in
the scenario's recorded (unsteady) wind, where it may also wait for a lull, and in the mean
wind the ``+W`` planners know.

A scenario is **reachable** when the goal is reached in the recorded wind by
``record_s - hold_s`` (100 - 5 s: success needs 5 s of hold at the goal before the record ends)
and the wind at the goal then allows the hold: some ``hold_s`` window after arrival in which
the wind at some free lattice cell within the success radius of the goal (5 m; the goal's own
cell alone until 2026-12-05) never exceeds the airspeed limit plus the 2 m/s of drift the
success criterion allows. A scenario that is not reachable cannot be a success of any planner whose
vehicle stays inside the envelope; a reachable one may still be out of reach of a real vehicle.

Each (map, wind) is one task: its wind is simulated once (as the benchmark does, with the same
worker reuse, so it is the benchmark's wind to the bit) and its pairs are searched at each
airspeed limit. Results are appended to ``reach.jsonl`` in the output folder as tasks finish
(flushed and synced); a rerun computes only what is missing. A kill loses at most the lines
being written: a last line without its newline is torn, ignored on reading and cut off before
the next append, as in the benchmark store (:class:`~windnav.experiments.nav_records.NavStore`);
any other line that is not a reach record is an error naming the file and the line. ``fly``
(variant labels) and ``store`` (a benchmark store) also fly those variants' pending flights in
the same winds, as :func:`~windnav.experiments.nav_benchmark.run_benchmark` would, so that one
pass over the suite's winds serves both.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np

__all__ = ["MEAN_TIME_BINS", "ReachTask", "cache_identity", "check_cache", "reach_scenarios",
           "reach_table", "reach_task"]


RECORDS = "reach.jsonl"
MANIFEST = "reach_manifest.json"
"""The cache folder's identity: the suite's name, seed and ``settings_hash`` and the search's
settings. Records were keyed by scenario id alone, which names a scenario only within one seed
and one suite's settings: ``nav-study feasibility --store runs/heldout`` (seed 1) read the
seed-0 records of the shared default cache and printed their tables as its own (cache audit,
thirty-ninth session)."""


@dataclass(frozen=True)
class ReachTask:
    """One (map, wind) of a suite, searched at each airspeed limit. Picklable."""

    spec: object
    map_index: int
    wind_index: int
    airspeeds: tuple
    dx: float = 2.0
    clearance: float = 1.0
    store: str | None = None
    flights: tuple = ()


def _hold_ok(goal_wind_speed: np.ndarray, t: np.ndarray, arrival: float, t_end: float,
             hold_s: float, limit: float) -> bool:
    """Whether some ``hold_s`` window in ``[arrival, t_end]`` keeps the wind at the goal
    (``goal_wind_speed`` at the frame times ``t``) within ``limit``."""
    calm = goal_wind_speed <= limit
    start = None
    for k in range(t.size):
        if t[k] < arrival - 1e-9 or not calm[k]:
            start = None
            continue
        if start is None:
            start = max(t[k], arrival)
        if min(t[k], t_end) - start >= hold_s - 1e-9:
            return True
    return False


def goal_disc_wind(lattice, goal_xy, radius: float) -> np.ndarray:
    """The wind speed (m/s) at every frame ``(T, n)`` at the ``n`` free lattice cells whose
    centres lie within ``radius`` (m) of ``goal_xy``: where a success may hold. (The hold was
    checked at the goal's own cell alone, which marked goals unreachable whose disc has a
    calmer cell: ``thesis/m10/w13/p3`` at 13.45 m/s, 7 of its 19 free cells; audit,
    2026-12-05.)"""
    gx, gy = (float(v) for v in goal_xy)
    near = np.hypot(*np.meshgrid(lattice.x - gx, lattice.y - gy)) <= radius
    js, is_ = np.nonzero(lattice.free & near)
    f = lattice.frames[:, js, is_]
    return np.hypot(f[..., 0], f[..., 1])


def reach_task(task: ReachTask) -> list[dict]:
    """The reach records of one (map, wind): one per pair, with the least times (s; None: not
    reached by the end of the record) in the recorded and the mean wind at each airspeed.
    Then the task's ``flights`` are flown in the same wind into ``store``."""
    from windnav.experiments.nav_benchmark import fly_group, group_wind
    from windnav.experiments.nav_suite import parse_scenario_id
    from windnav.experiments.navigate import GOAL_RADIUS, GOAL_SPEED, HOLD_S
    from windnav.plan.reach import least_time, reach_lattice

    spec = task.spec
    city, flow, flow_s = group_wind(spec, task.map_index, task.wind_index)
    sol = flow.solution
    t_end = float(spec.record_s)
    hold_s = HOLD_S
    lattices = {"recorded": reach_lattice(city, sol.wind_field(unsteady=True), dx=task.dx,
                                          clearance=task.clearance),
                "mean": reach_lattice(city, sol.wind_field(), dx=task.dx,
                                      clearance=task.clearance)}
    lat = lattices["recorded"]
    t_frames = lat.t0 + lat.dt_frames * np.arange(lat.frames.shape[0])
    out = []
    for p in spec.pairs:
        sc = parse_scenario_id(spec, f"{spec.name}/m{task.map_index:02d}/"
                                     f"w{task.wind_index:02d}/p{p}")
        gi = int(np.clip(np.round((sc.goal[0] - lat.x[0]) / lat.dx), 0, lat.x.size - 1))
        gj = int(np.clip(np.round((sc.goal[1] - lat.y[0]) / lat.dx), 0, lat.y.size - 1))
        goal_wind = np.hypot(*lat.frames[:, gj, gi].T)
        disc_wind = goal_disc_wind(lat, sc.goal, GOAL_RADIUS)
        if disc_wind.shape[1] == 0:
            disc_wind = goal_wind[:, None]
        rec = {"scenario_id": sc.scenario_id, "map_index": sc.map_index,
               "wind_index": sc.wind_index, "pair_index": sc.pair_index, "kind": sc.kind,
               "speed": sc.speed, "direction_deg": sc.direction_deg,
               "straight_m": float(math.dist(sc.start, sc.goal)),
               "goal_wind_mean_mps": float(goal_wind.mean()),
               "goal_wind_max_mps": float(goal_wind.max()),
               "record_s": t_end, "hold_s": hold_s, "dx": task.dx,
               "clearance": task.clearance, "flow_s": flow_s, "limits": {}}
        for a in task.airspeeds:
            row = {}
            for name, lattice in lattices.items():
                r = least_time(lattice, sc.start, sc.goal, airspeed_max=a, t_end=t_end,
                               goal_radius=GOAL_RADIUS)
                row[f"{name}_time_s"] = r.time_s if r.reached else None
                row[f"{name}_length_m"] = r.length_m if r.reached else None
            arrival = row["recorded_time_s"]
            row["hold_ok"] = bool(arrival is not None and any(
                _hold_ok(disc_wind[:, c], t_frames, arrival, t_end, hold_s, a + GOAL_SPEED)
                for c in range(disc_wind.shape[1])))
            row["reachable"] = bool(row["hold_ok"] and arrival + hold_s <= t_end)
            rec["limits"][f"{a:g}"] = row
        out.append(rec)
    if task.flights:
        fly_group(spec, task.store, task.flights, city=city, flow=flow, flow_s=flow_s)
    return out


def _done(path: Path) -> list[dict]:
    """The reach records in ``path``, in order ([] when there is none).

    A last line without its newline was torn by a kill mid-write: it is ignored (and cut off
    before the next append, :func:`_append`).

    Raises
    ------
    ValueError
        Naming the file and the (1-based) line of the first other line that is not a reach
        record.
    """
    from windnav.experiments.nav_records import json_lines

    if not path.is_file():
        return []
    out = []
    for i, raw, rec in json_lines(path):
        if not (isinstance(rec, dict) and isinstance(rec.get("scenario_id"), str)
                and isinstance(rec.get("limits"), dict)):
            text = raw[:80].decode("utf-8", "replace")
            raise ValueError(
                f"The reach record file {str(path)!r} has a corrupt record at line {i}: "
                f"{text!r}. Delete or repair that line (its scenarios are then computed "
                "again); the other lines keep their finished scenarios.")
        out.append(rec)
    return out


def _append(path: Path, records: Sequence[Mapping]) -> None:
    """Append ``records`` to ``path``, one JSON line each, durably; a torn last line left by
    an earlier kill is cut off first."""
    from windnav.experiments.nav_records import _cut_torn_tail
    from windnav.experiments.results import json_ready

    if not records:
        return
    data = "".join(json.dumps(json_ready(rec)) + "\n" for rec in records).encode()
    with path.open("a+b") as fh:
        _cut_torn_tail(fh)
        fh.seek(0, os.SEEK_END)
        fh.write(data)
        fh.flush()
        os.fsync(fh.fileno())


def cache_identity(spec) -> dict:
    """What a reach record depends on besides its scenario id: the suite (name, seed, settings)
    and the search's settings (lattice, clearance, the hold rule's constants)."""
    from windnav.experiments.navigate import GOAL_RADIUS, GOAL_SPEED, HOLD_S

    task = ReachTask(spec, 0, 0, ())
    return {"suite": spec.name, "seed": int(spec.seed), "settings_hash": spec.settings_hash(),
            "dx": task.dx, "clearance": task.clearance, "hold_s": HOLD_S,
            "goal_radius": GOAL_RADIUS, "goal_speed": GOAL_SPEED}


def check_cache(spec, out: Path, where: str = "reach_scenarios", option: str = "out") -> None:
    """Refuse a cache folder that holds another suite's reach records; name a new one.

    A folder without :data:`MANIFEST` gets one. If it already holds records (a cache from
    before 2026-12-06, such as the committed ``thesis_reach.jsonl.gz`` restored), they are
    taken for the preset suite's seed 0, the only one they were computed for, when their suite
    name, ``record_s`` and search (``dx``, ``clearance``, ``hold_s``) match and the suite's
    settings are the preset's; otherwise the folder is refused."""
    out = Path(out)
    want = cache_identity(spec)
    man = out / MANIFEST
    if man.is_file():
        try:
            got = json.loads(man.read_text())
            if not isinstance(got, dict):
                raise ValueError(f"a JSON {type(got).__name__}, not an object")
        except (OSError, ValueError) as exc:
            raise ValueError(f"The '{option}' parameter of {where} names a reach cache whose "
                             f"{MANIFEST} cannot be read ({exc}). Got {str(out)!r}.") from None
        if got != want:
            diff = ", ".join(f"{k} {got.get(k)!r} there, {want.get(k)!r} here"
                             for k in sorted(set(got) | set(want)) if got.get(k) != want.get(k))
            raise ValueError(
                f"The '{option}' parameter of {where} names a reach cache of another suite or "
                f"search ({diff}): give another folder. Got {str(out)!r} instead.")
        return
    old = _done(out / RECORDS) if (out / RECORDS).is_file() else []
    if old:
        from windnav.experiments.nav_suite import SUITES

        names = {r["scenario_id"].split("/")[0] for r in old}
        record_s = {r.get("record_s") for r in old}
        preset = SUITES.get(spec.name)  # such caches were computed for the presets, seed 0
        search = {(r.get("dx"), r.get("clearance"), r.get("hold_s")) for r in old}
        if (names != {spec.name} or record_s != {spec.record_s} or spec.seed != 0
                or preset is None or spec.settings_hash() != preset.settings_hash()
                or search != {(want["dx"], want["clearance"], want["hold_s"])}):
            raise ValueError(
                f"The '{option}' parameter of {where} names a reach cache without {MANIFEST} "
                f"whose records (suite {sorted(names)}, record_s "
                f"{sorted(map(str, record_s))}, taken for seed 0) are not this suite's "
                f"({spec.name!r}, record_s {spec.record_s:g}, seed {spec.seed}): give another "
                f"folder. Got {str(out)!r} instead.")
    from windnav.experiments.results import write_json

    write_json(want, man)


def reach_scenarios(spec, out: Path, *, maps: Sequence[int] | None = None,
                    airspeeds: Sequence[float], executor: str = "process",
                    workers: int | None = None, progress: bool = True,
                    fly: Sequence[str] = (), store=None) -> list[dict]:
    """Reach records of the suite's scenarios on ``maps`` (default all), computed where
    ``out/reach.jsonl`` lacks them (appended as each wind finishes) and returned with the ones
    it had. Records computed with other ``airspeeds`` are recomputed.

    ``fly``: variant labels whose flights not yet in the benchmark store ``store`` (created
    if need be) are flown in the same winds (a wind with pending flights is simulated even
    when its reach records exist).

    Returns
    -------
    list of dict
        One per scenario (:func:`reach_task`), ordered by scenario id.
    """
    from windnav.experiments.executor import run_tasks
    from windnav.experiments.nav_benchmark import NavStore, check_variants
    from windnav.experiments.nav_suite import make_suite

    where = "reach_scenarios"
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    path = out / RECORDS
    check_cache(spec, out, where)
    maps = tuple(spec.maps if maps is None else maps)
    keys = {f"{a:g}" for a in airspeeds}
    have = {r["scenario_id"]: r for r in _done(path) if set(r["limits"]) == keys}
    pending: dict[tuple[int, int], list] = {}
    if fly:
        if store is None:
            raise ValueError(f"The 'store' parameter of {where} must name a benchmark store "
                             f"when 'fly' names variants. Got None instead.")
        variants = check_variants(fly, where)
        nav_store = NavStore(store, spec)
        done = nav_store.latest()
        for sc in make_suite(dataclasses.replace(spec, maps=maps)):
            for v in variants:
                if (sc.scenario_id, v) not in done:
                    pending.setdefault((sc.map_index, sc.wind_index), []).append((sc, v))
        store = str(nav_store.path)
    tasks = [ReachTask(spec, m, w, tuple(float(a) for a in airspeeds), store=store,
                       flights=tuple(pending.get((m, w), ())))
             for m in maps for w in spec.winds
             if (m, w) in pending or any(f"{spec.name}/m{m:02d}/w{w:02d}/p{p}" not in have
                                         for p in spec.pairs)]

    def on_result(res):
        if res.ok:
            _append(path, [rec for rec in res.value if rec["scenario_id"] not in have])

    failed = []
    for res in run_tasks(reach_task, tasks, executor, workers=workers, progress=progress,
                         desc="winds", on_result=on_result):
        if res.ok:
            have.update({r["scenario_id"]: r for r in res.value})
        else:
            failed.append(res.error)
    if failed:
        raise RuntimeError(f"{len(failed)} of {len(tasks)} winds failed; the first:\n"
                           f"{failed[0]}")
    wanted = {f"{spec.name}/m{m:02d}/w{w:02d}/p{p}" for m in maps for w in spec.winds
              for p in spec.pairs}
    return [have[k] for k in sorted(wanted)]


MEAN_TIME_BINS = (30.0, 40.0, 50.0, 60.0, 95.0)
"""Upper edges of the bins of least time in the mean wind, s, by which :func:`reach_table`
splits each variant's failures (then one bin for no route by 95 s)."""


def _bin_labels() -> list[str]:
    edges = (0.0, *MEAN_TIME_BINS)
    return [f"{a:g}-{b:g}" for a, b in zip(edges, edges[1:], strict=False)] + ["none"]


def _mean_time_bin(t) -> str:
    labels = _bin_labels()
    if t is None or not np.isfinite(t) or t > MEAN_TIME_BINS[-1]:
        return labels[-1]
    return labels[int(np.searchsorted(MEAN_TIME_BINS, t))]


def reach_table(reach: Iterable[Mapping], records: Iterable[Mapping] = (), *,
                airspeed: float) -> dict:
    """Reachability by inlet speed and pair kind at one airspeed limit, and, for each
    variant of ``records`` (benchmark flights, the latest of each), its failures among the
    reachable scenarios and its successes among the unreachable ones.

    Returns
    -------
    dict
        ``airspeed``, ``n``, ``reachable`` (count), ``groups``: per ``"<speed>/<kind>"`` the
        count, the reachable count and the median least time (recorded wind) of the reachable
        ones, s; ``variants``: per variant, ``flights``, ``failures``, ``failures_reachable``
        (failures in reachable scenarios), ``reachable`` (its flights in reachable scenarios),
        ``success_unreachable``, ``errors`` (flights whose harness failed, outcome
        ``"error"``: counted apart and in no other count, as in the benchmark's table) and
        ``by_mean_time``: per bin of the least time in the *mean* wind
        (:data:`MEAN_TIME_BINS`, s; the wind the ``+W`` planners know), ``[flights,
        failures]``.

    Raises
    ------
    ValueError
        ``airspeed`` not a limit every reach record was searched at.
    """
    from windnav._validate import positive_float

    where = "reach_table"
    key = f"{positive_float(airspeed, 'airspeed', where):g}"
    reach = {r["scenario_id"]: r for r in reach}
    # (a limit the records were not searched at raised a bare KeyError; Python API audit,
    # fifty-eighth session)
    missing = [sid for sid, r in reach.items() if key not in r["limits"]]
    if missing:
        limits = sorted(set.intersection(*(set(r["limits"]) for r in reach.values())),
                        key=float)
        raise ValueError(f"The 'airspeed' parameter of {where} must be an airspeed limit the "
                         f"reach records were searched at, m/s ({limits} in all of them; "
                         f"{len(missing)} of {len(reach)} lack {key}). Got {airspeed!r} "
                         "instead.")
    rows = {sid: r["limits"][key] for sid, r in reach.items()}
    groups = {}
    for sid, r in reach.items():
        g = groups.setdefault(f"{r['speed']:g}/{r['kind']}", {"n": 0, "reachable": 0,
                                                              "times": []})
        g["n"] += 1
        if rows[sid]["reachable"]:
            g["reachable"] += 1
            g["times"].append(rows[sid]["recorded_time_s"])
    for g in groups.values():
        times = g.pop("times")
        g["median_time_s"] = float(np.median(times)) if times else None
    from windnav.experiments.nav_records import ERROR, latest_records

    variants = {}
    for rec in latest_records(records).values():  # a re-flown flight counts once, as the table
        row = rows.get(rec["scenario_id"])
        if row is None:
            continue
        v = variants.setdefault(rec["variant"], {
            "flights": 0, "failures": 0, "reachable": 0, "failures_reachable": 0,
            "success_unreachable": 0, "errors": 0,
            "by_mean_time": {b: [0, 0] for b in _bin_labels()}})
        if rec["outcome"] == ERROR:  # the harness failed: no flight, in no rate (as the table)
            v["errors"] += 1
            continue
        ok = rec["outcome"] == "success"
        v["flights"] += 1
        v["failures"] += not ok
        cell = v["by_mean_time"][_mean_time_bin(row.get("mean_time_s"))]
        cell[0] += 1
        cell[1] += not ok
        if row["reachable"]:
            v["reachable"] += 1
            v["failures_reachable"] += not ok
        else:
            v["success_unreachable"] += ok
    return {"airspeed": airspeed, "n": len(rows),
            "reachable": sum(r["reachable"] for r in rows.values()),
            "groups": dict(sorted(groups.items(), key=lambda kv: (float(kv[0].split("/")[0]),
                                                                   kv[0]))),
            "variants": variants}
