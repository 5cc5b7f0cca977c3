"""Evaluation of the wind flow decoder against its baselines (issue 9, items 6 and 7).

:func:`evaluate_decoder` simulates the mean flow of evaluation maps at random inlets and
scores the decoder, the Local baseline (uniform ``W_robot``) and the Upstream baseline (uniform
``W_up``) on samples drawn from each field, with the metrics of :mod:`windnav.predict.metrics`
(defined once there). :func:`predict_at` is one prediction at one point of a map, with its
truth, for ``windnav predict``.

The protocol (the thesis's evaluation, ch. 4, on our maps):

- **Maps.** ``dense-i``: :func:`windnav.city.dense_map` (1.2 km, >= 200 buildings) drawn from
  child ``i`` of ``numpy.random.SeedSequence(EVAL_MAP_SEED)`` (:func:`generated_maps`); the
  default recipe trains on seeds 1001-1005, so these maps are never trained on. ``windinet``:
  the third-party 1.1 km layout ``windinet/example_layout.json`` of the project's shared data
  folder (Weihao-Li-2001/windinet, Apache-2.0; :func:`windinet_layout` says where it is
  looked for). ``files`` (group ``file``, since the fiftieth session): maps of your own,
  RotorPy world JSON files (``windnav evaluate-decoder --map FILE``), after the others, so the
  slots of the dense maps and windinet are the same with them or without.
- **Inlets.** Speed ``U[2, 10]`` m/s and direction ``U[0, 360)`` deg, drawn from ``seed`` for
  every (map, inlet) slot before anything runs (:func:`inlet_slots`), and the samples of each
  slot from its own stream (:func:`slot_rng`), so a slot does not depend on the budget.
- **Flow.** :func:`windnav.flow.simulate` with the thesis protocol (100 spin-up steps, mean over
  200) at ``dx`` (1 m: the decoder's training resolution) and the training sweep's time step
  (:func:`windnav.experiments.wind_sweep.auto_dt`: 0.25 s, shortened to ``U dt / dx <= 1``).
- **Samples.** :func:`windnav.predict.draw_samples`: scan noise 0.35 m, no ``W_robot`` noise,
  robots >= 1 m from walls and within 40 m of a building, on the decoder's grid.
- **Budget.** Slots run inlet by inlet, each inlet over every map in turn (so the maps share the
  time); before a slot starts, its cost is estimated from the slots done (seconds per grid cell
  times its cells) and the run stops when it would end past ``budget_s``. The first slot always
  runs. A slot whose flow comes from the cache (``flow_cache``) is charged as if it had been
  solved: what it took plus the simulation's seconds recorded in the cache entry
  (``config["compute_s"]``, :func:`slot_flow`), both in the time spent and in the cost per cell;
  so the budget is deterministic given the cache's recorded times, and a run resumed from the
  cache runs the same slots as the run it resumes (up to the wall-clock noise of the rest of the
  work: sampling, scoring, the flows solved now). An entry that recorded no time (written by an
  older windnav) is charged the current estimate (its own time when there is none yet) and does
  not change the estimate.

Pooled errors weigh cells equally (:func:`windnav.predict.pooled_errors`); improvements are
``1 - model / baseline`` (:func:`windnav.predict.improvement`), in percent; those of the speed
and direction errors with a paired bootstrap interval over the slots
(:func:`improvement_interval`: none below 6 slots, called approximate below 64).
"""

from __future__ import annotations

import hashlib
import math
import sys
import time
import warnings
from collections.abc import Mapping
from pathlib import Path

import numpy as np

from windnav._source import SOLVER_MODULE, module_key
from windnav._validate import nonnegative_int, positive_float, positive_int

__all__ = ["ACCEPTANCE", "EVAL_MAP_SEED", "MODELS", "WINDINET_LAYOUT", "evaluate_decoder",
           "check_point", "flow_cache_name", "improvement_interval", "inlet_slots", "map_sha256",
           "predict_at",
           "slot_flow", "slot_rng", "windinet_layout"]

EVAL_MAP_SEED = 2000
"""Seed of the dense evaluation maps (the default recipe's training maps use 1001-1005)."""
WINDINET_FILE = Path("windinet") / "example_layout.json"
"""The third-party 1.1 km urban layout (Weihao-Li-2001/windinet @ 2de913ee, Apache-2.0), in the
project's shared data folder."""
WINDINET_SHA256 = "f9aea3e8d53e0037241b6fc208d18b64f74c7b20cef4910f6a163a7807f23c16"
"""The SHA-256 of that file: the layout every windinet figure of ``docs/decoder.md`` is of."""


def _windinet_candidates() -> list[Path]:
    """Where the layout is looked for, in order: ``$WINDNAV_SHARED_DATA``, the shared data
    folder beside this checkout (``../shared/data``), the checkout's test copy
    (``tests/data``), ``/work/shared/data``."""
    import os

    up = Path(__file__).resolve().parents  # .../<checkout>/src/windnav/experiments/this file
    checkout = up[min(3, len(up) - 1)]
    out = [Path(r) / WINDINET_FILE for r in (os.environ.get("WINDNAV_SHARED_DATA"),) if r]
    out += [checkout.parent / "shared" / "data" / WINDINET_FILE,
            checkout / "tests" / "data" / WINDINET_FILE.name,
            Path("/work/shared/data") / WINDINET_FILE]
    return list(dict.fromkeys(out))


def _found_windinet() -> Path | None:
    """The first of :func:`_windinet_candidates` that is a file, else None."""
    return next((c for c in _windinet_candidates() if c.is_file()), None)


WINDINET_LAYOUT = _found_windinet() or _windinet_candidates()[0]
"""The windinet layout's path on this machine (the first of :func:`_windinet_candidates` that
exists, else the first); read it with :func:`windinet_layout`."""


def windinet_layout() -> Path:
    """The third-party windinet layout's file (:data:`WINDINET_FILE`), checked.

    Raises
    ------
    FileNotFoundError
        When it is on none of the paths looked for (``$WINDNAV_SHARED_DATA``, ``../shared/data``
        beside this checkout, the checkout's ``tests/data``, ``/work/shared/data``): an
        installed package carries no copy.
    ValueError
        When the file found is not that layout (its SHA-256 differs): the windinet figures
        would be another layout's under its name.
    """
    path = _found_windinet()
    if path is None:
        looked = ", ".join(str(c) for c in _windinet_candidates())
        raise FileNotFoundError(
            f"The third-party windinet layout ({WINDINET_FILE}) is not on this machine (looked "
            f"in {looked}): it is example_layout.json of github.com/Weihao-Li-2001/windinet "
            f"@ 2de913ee (Apache-2.0); set WINDNAV_SHARED_DATA to the folder holding "
            f"{WINDINET_FILE}, or leave the layout out (--no-windinet).")
    digest = hashlib.sha256(path.read_bytes()).hexdigest()
    if digest != WINDINET_SHA256:
        raise ValueError(f"The windinet layout at {str(path)!r} must be Weihao-Li-2001/windinet "
                         f"@ 2de913ee's example_layout.json (SHA-256 {WINDINET_SHA256[:16]}...). "
                         f"Got a file with SHA-256 {digest[:16]}... instead.")
    return path
MODELS = ("decoder", "local", "upstream")
"""The predictors always scored, in report order (the compared models, when any, come after
the decoder)."""
BASELINES = ("local", "upstream")
GROUPS = ("dense", "windinet", "file")
"""The map groups, in report order: the dense evaluation maps, the windinet layout, the maps of
``files`` (each pooled apart, then all together)."""
SPEED_RANGE = (2.0, 10.0)
"""Inlet speeds, m/s (uniform)."""
PROTOCOL = {"spinup_steps": 100, "steps": 200}
"""The thesis's averaging protocol (steps)."""
ACCEPTANCE = {"speed_error": 0.6, "direction_error_deg": 12.0, "vs_local": 35.0,
              "vs_upstream": 75.0}
"""Issue 9's accuracy targets at H = 25: errors (m/s, deg) and improvements (%)."""
ACCEPTANCE_SAMPLES = 2048
"""Samples per (map, inlet) slot the acceptance verdict needs: the thesis's protocol. A run
with fewer (``--samples 1``) is a quick look, and its verdict was printed as one
(statistics audit)."""
ACCEPTANCE_SLOTS = 2
"""Slots the acceptance verdict needs: one inlet says nothing about a distribution of
inlets."""
_IMPROVED = ("speed_error", "direction_error_deg", "direction_error_masked_deg", "vector_error")


def _improvement_pct(model: float, baseline: float) -> float:
    from windnav.predict import improvement

    if not (np.isfinite(model) and np.isfinite(baseline) and baseline > 0 and model >= 0):
        return float("nan")
    return 100.0 * improvement(model, baseline)


def _improvements(errors: dict, model: str) -> dict:
    return {base: {k: _improvement_pct(errors[model][k], errors[base][k]) for k in _IMPROVED}
            for base in BASELINES}


IMPROVEMENT_BOOTSTRAP = 2000
"""Resamples of the slots behind each improvement's interval (:func:`improvement_interval`)."""
MAX_IMPROVEMENT_BOOTSTRAP = 1_000_000
"""The most resamples :func:`improvement_interval` draws (one row of 8-byte counts per
resample and slot: 256 MB for 32 slots)."""


def improvement_interval(records, model: str = "decoder", baseline: str = "local",
                         metric: str = "speed_error", *, group: str = "all",
                         n_boot: int = IMPROVEMENT_BOOTSTRAP, confidence: float = 0.95,
                         seed: int = 0) -> dict:
    """A model's pooled improvement over a baseline (%) with a paired bootstrap interval
    over the evaluation's slots (:func:`windnav.experiments.intervals.pooled_ratio_interval`).

    Each (map, inlet) slot's samples share one flow, so the slots are resampled, the model's
    and the baseline's cells of a drawn slot together; a resample's improvement is ``1 -
    pooled(model) / pooled(baseline)`` over its slots, cells weighing equally, as the pooled
    figures do.

    Parameters
    ----------
    records : sequence of dict
        :func:`evaluate_decoder`'s ``records`` (or those of its JSON): per slot ``group`` and,
        per model, the metrics and their cell counts.
    model, baseline : str
        Names in the records (``"decoder"``, a compared model; ``"local"``, ``"upstream"``).
    metric : str
        One of :data:`windnav.predict.METRICS`.
    group : str
        ``"dense"``, ``"windinet"``, ``"file"`` or ``"all"``: the slots taken.
    n_boot, confidence, seed
        Resamples, level and seed (the stream is the seed, the three names and the slots
        taken, so an interval does not depend on which others are asked for, nor on the
        group's name when two groups hold the same slots).

    Returns
    -------
    dict
        ``value`` (%, the pooled improvement), ``ci95`` ([low, high] % or None), ``slots``
        and, where the interval is missing or approximate, ``ci95_note`` (fewer than
        :data:`~windnav.experiments.intervals.MIN_BOOTSTRAP_CLUSTERS` slots: none; fewer than
        :data:`~windnav.experiments.intervals.COVERED_BOOTSTRAP_CLUSTERS`: approximate).
    """
    import zlib

    from windnav.experiments.intervals import (
        COVERED_BOOTSTRAP_CLUSTERS,
        MIN_BOOTSTRAP_CLUSTERS,
        pooled_ratio,
        pooled_ratio_interval,
    )
    from windnav.predict.metrics import _COUNTS

    where = "improvement_interval"
    if metric not in _COUNTS:
        raise ValueError(f"The 'metric' parameter of {where} must be one of {sorted(_COUNTS)}. "
                         f"Got {metric!r} instead.")
    # Python API audit, fifty-eighth session: group 'foo' gave {'value': None, 'slots': 0};
    # confidence 0 a zero-width interval, 1.5 or NaN NumPy's quantile error; n_boot -5
    # "negative dimensions", 10**9 a 44.7 GiB MemoryError; seed -1 NumPy's message; the whole
    # JSON instead of its records an AttributeError
    if group not in (*GROUPS, "all"):
        raise ValueError(f"The 'group' parameter of {where} must be one of "
                         f"{[*GROUPS, 'all']}. Got {group!r} instead.")
    try:
        level = float(confidence)
    except (TypeError, ValueError):
        level = math.nan
    if isinstance(confidence, bool) or not 0 < level < 1:
        raise ValueError(f"The 'confidence' parameter of {where} must be a level in (0, 1). "
                         f"Got {confidence!r} instead.")
    n_boot = positive_int(n_boot, "n_boot", where)
    if n_boot > MAX_IMPROVEMENT_BOOTSTRAP:
        raise ValueError(f"The 'n_boot' parameter of {where} must be at most "
                         f"{MAX_IMPROVEMENT_BOOTSTRAP} resamples. Got {n_boot!r} instead.")
    seed = nonnegative_int(seed, "seed", where)
    if isinstance(records, Mapping) or isinstance(records, str | bytes):
        raise ValueError(f"The 'records' parameter of {where} must be a sequence of slot "
                         "records (evaluate_decoder's 'records', or its JSON's). Got "
                         + (f"a dict with keys {list(records)[:8]}" if isinstance(
                             records, Mapping) else repr(records))
                         + " instead" + ("; pass its 'records'" if isinstance(
                             records, Mapping) and "records" in records else "") + ".")
    try:
        records = list(records)
    except TypeError:
        raise ValueError(f"The 'records' parameter of {where} must be a sequence of slot "
                         f"records. Got {records!r} instead.") from None
    bad = [r for r in records if not isinstance(r, Mapping)]
    if bad:
        raise ValueError(f"The 'records' parameter of {where} must hold one dict per slot. "
                         f"Got {bad[0]!r} among them instead.")
    count = _COUNTS[metric]
    chosen = [r for r in records if group == "all" or r.get("group") == group]
    sums = []
    for r in chosen:
        row = []
        for name in (model, baseline):
            if name not in r:
                raise ValueError(f"The 'records' parameter of {where} must hold {name!r} in "
                                 f"every slot. Got a slot of {r.get('map')!r} without it.")
            n = float(r[name][count])
            row += [float(r[name][metric]) * n if n > 0 else 0.0, n]
        sums.append(row)
    s = np.asarray(sums, dtype=np.float64).reshape(-1, 4)
    out = {"value": None, "ci95": None, "slots": len(chosen)}
    if not (s[:, 1].sum() > 0 and s[:, 3].sum() > 0 and s[:, 2].sum() > 0):
        return out
    out["value"] = 100.0 * pooled_ratio(s)
    if len(chosen) < MIN_BOOTSTRAP_CLUSTERS:
        out["ci95_note"] = (f"no interval: {len(chosen)} slot{'s' if len(chosen) != 1 else ''}, "
                            f"and a bootstrap over the slots needs at least "
                            f"{MIN_BOOTSTRAP_CLUSTERS}")
        return out
    if len(chosen) < COVERED_BOOTSTRAP_CLUSTERS:
        out["ci95_note"] = (f"approximate: from {len(chosen)} slots; on the navigation "
                            "table's winds a bootstrap over so few clusters covered the truth "
                            f"less often than it says (until {COVERED_BOOTSTRAP_CLUSTERS})")
    # the stream: the seed, the names and the slots taken (not the group's name, so that a
    # windinet-only run's "windinet" and "all" give one interval; review)
    slots = sorted(f"{r.get('map')}/{r.get('inlet')}" for r in chosen)
    label = zlib.crc32("|".join([model, baseline, metric, *slots]).encode())
    rng = np.random.default_rng([int(seed), label])
    ci = pooled_ratio_interval(s, n_boot=n_boot, rng=rng, confidence=confidence)
    out["ci95"] = None if ci is None else [100.0 * ci[0], 100.0 * ci[1]]
    return out


def _intervals(records, models, group: str) -> dict:
    """:func:`improvement_interval` of every scored model over each baseline, for the speed
    and direction errors (the acceptance's two)."""
    return {m: {base: {k: improvement_interval(records, m, base, k, group=group)
                       for k in ("speed_error", "direction_error_deg")}
                for base in BASELINES}
            for m in models if m not in BASELINES}


def _summary(errors: dict) -> dict:
    """Per-model errors plus the decoder's improvement (%) over each baseline
    (``improvement_pct``), and each compared model's (``compared_improvement_pct``). The
    improvements are keyed by the metric improved: ``improvement_pct.local.direction_error_deg``
    is a percentage (of the direction error, which is in degrees), not an angle."""
    out = dict(errors)
    out["improvement_pct"] = _improvements(errors, "decoder")
    compared = [m for m in errors if m not in MODELS]
    if compared:
        out["compared_improvement_pct"] = {m: _improvements(errors, m) for m in compared}
    return out


def _acceptance(summary: dict, samples_per_slot: int) -> dict:
    """Issue 9's checks on a pooled summary; each None (not judged), with ``note``, below
    :data:`ACCEPTANCE_SAMPLES` samples per slot or :data:`ACCEPTANCE_SLOTS` slots."""
    if samples_per_slot < ACCEPTANCE_SAMPLES or summary["n_slots"] < ACCEPTANCE_SLOTS:
        return {**{k: None for k in ("speed_error", "direction_error_deg", "vs_local",
                                     "vs_upstream", "all")},
                "note": f"not judged: {summary['n_slots']} slot"
                        f"{'' if summary['n_slots'] == 1 else 's'} of {samples_per_slot} "
                        f"samples, where the verdict needs at least {ACCEPTANCE_SLOTS} slots "
                        f"of the protocol's {ACCEPTANCE_SAMPLES}"}
    d, imp = summary["decoder"], summary["improvement_pct"]
    checks = {
        "speed_error": d["speed_error"] <= ACCEPTANCE["speed_error"],
        "direction_error_deg": d["direction_error_deg"] <= ACCEPTANCE["direction_error_deg"],
        "vs_local": all(imp["local"][k] >= ACCEPTANCE["vs_local"]
                        for k in ("speed_error", "direction_error_deg")),
        "vs_upstream": all(imp["upstream"][k] >= ACCEPTANCE["vs_upstream"]
                           for k in ("speed_error", "direction_error_deg")),
    }
    return {**{k: bool(v) for k, v in checks.items()}, "all": bool(all(checks.values()))}


def inlet_slots(n_maps: int, n_inlets: int, seed: int) -> np.ndarray:
    """The inlets of every (map, inlet) slot: ``(n_maps, n_inlets, 2)`` of (speed m/s,
    direction deg), drawn from ``seed``, one stream per map.

    Slot (i, j) does not depend on ``n_maps``, but it does on ``n_inlets``: a map's stream
    draws all its speeds, then all its directions, so ``--inlets 2`` gives inlet 0 another
    direction than ``--inlets 1`` (216.5 against 144.9 deg for map 0 at seed 0; pipeline audit,
    2026-12-05; until then this docstring said no slot depended on how many run). Compare runs
    with the same ``--inlets``; every committed evaluation depends on this draw, so it stays.
    """
    # -1 met "negative dimensions", 2.5 a TypeError, seed -1 NumPy's message (Python API
    # audit, fifty-eighth session)
    where = "inlet_slots"
    n_maps = nonnegative_int(n_maps, "n_maps", where)
    n_inlets = positive_int(n_inlets, "n_inlets", where)
    seed = nonnegative_int(seed, "seed", where)
    out = np.empty((n_maps, n_inlets, 2))
    for i in range(n_maps):
        child = np.random.default_rng(np.random.SeedSequence([seed, 2, i]))
        out[i, :, 0] = child.uniform(*SPEED_RANGE, size=n_inlets)
        out[i, :, 1] = child.uniform(0.0, 360.0, size=n_inlets)
    return out


def slot_rng(seed: int, map_index: int, inlet_index: int) -> np.random.Generator:
    """The random source of the samples of slot (``map_index``, ``inlet_index``)."""
    where = "slot_rng"  # a seed of -1 met NumPy's message (Python API audit)
    seed = nonnegative_int(seed, "seed", where)
    map_index = nonnegative_int(map_index, "map_index", where)
    inlet_index = nonnegative_int(inlet_index, "inlet_index", where)
    return np.random.default_rng(np.random.SeedSequence([int(seed), 3, map_index, inlet_index]))


def flow_cache_name(name: str, city, speed: float, direction: float, dx: float,
                    settings: dict, dt: float) -> str:
    """The folder name of one slot's cached solution: the map's name, then a hash of its
    bounds and buildings, the inlet (``speed`` m/s, ``direction`` deg, the way the inlet wind
    blows, counter-clockwise from +x), ``dx`` (the solver's cell, m), ``dt`` (its time step,
    s) and the protocol's steps (``settings``: ``spinup_steps``, ``steps``).
    (The bounds since 2026-12-06: a map of the same buildings on a larger domain read the
    smaller one's flow, silently; cache audit. Entries cached before are solved again.)"""
    key = hashlib.sha256(np.asarray(city.bounds[:4], dtype=np.float64).tobytes()
                         + np.ascontiguousarray(city.footprints).tobytes()
                         + repr((speed, direction, dx, dt, sorted(settings.items()))).encode())
    safe = "".join(ch if ch.isalnum() or ch in "-_" else "_" for ch in name)
    return f"{safe}-{key.hexdigest()[:16]}.zarr"


def slot_flow(city, name: str, inlet: int, speed: float, direction: float, *, dx: float,
              dt: float, steps: dict, cache_dir=None, simulate=None) -> tuple:
    """The thesis-protocol solution of one (map, inlet) slot, and whether it came from the cache.

    The inlet is ``speed`` (m/s) toward ``direction`` (deg, counter-clockwise from +x); the
    solver's cell is ``dx`` (m) and its time step ``dt`` (s); ``inlet`` is the slot's index,
    recorded with a cached entry.

    With ``cache_dir`` the solution is read from there when the same map, inlet, ``dx``, ``dt``
    and ``steps`` (``spinup_steps``, ``steps``) were solved before
    (:func:`windnav.flow.load_flow`), and kept there otherwise (:func:`windnav.flow.save_flow`):
    the evaluation and the studies share their flows. ``simulate`` replaces
    :func:`windnav.flow.simulate` (tests). A diverged flow raises
    :class:`windnav.flow.solver.FlowDivergedError` and is not cached.

    An entry is written to a temporary sibling and renamed into place once complete
    (:func:`windnav.experiments.results.atomic_path`), so an interrupted write (Ctrl-C) leaves
    no entry; its config records the map, the inlet, ``compute_s``, the seconds the
    simulation took (what :func:`evaluate_decoder`'s budget charges a cached slot), and
    ``solver_code``, the hash of the solver's source (:data:`SOLVER_MODULE` and the windnav
    modules it imports; :func:`windnav._source.module_key`). An entry solved by other solver
    code, or one from before 2026-12-06 that records none, is solved again and replaced, with a
    warning: a cache kept across a change of the solver served the old flows. Where a file of
    the solver's code changed after windnav was imported (``module_key`` ends ``-modified``)
    the cache is neither read nor written, with a warning. An entry
    that cannot be read (damaged, or left incomplete by a process killed while writing it with
    an older windnav) is a cache miss: a warning names it, and the flow is solved again and
    replaces it. The temporary copy a killed process left of the entry is removed when the
    entry is written (:func:`windnav.experiments.results._remove_dead_leftovers`: only that of a
    dead process of this host).
    """
    sol, cached, _ = _slot_flow(city, name, inlet, speed, direction, dx=dx, dt=dt, steps=steps,
                                cache_dir=cache_dir, simulate=simulate)
    return sol, cached


def _recorded_seconds(attrs: dict) -> float | None:
    """The simulation seconds a cache entry recorded (``config["compute_s"]``), or None."""
    value = (attrs.get("config") or {}).get("compute_s")
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    return float(value) if math.isfinite(value) and value >= 0 else None


def _slot_flow(city, name: str, inlet: int, speed: float, direction: float, *, dx: float,
               dt: float, steps: dict, cache_dir=None, simulate=None) -> tuple:
    """:func:`slot_flow`, with the simulation's seconds third: measured when solved now, the
    entry's recorded ``compute_s`` when read from the cache (None when it recorded none)."""
    import glob

    from windnav.experiments.results import _remove_dead_leftovers, atomic_path
    from windnav.flow import flow_attrs, load_flow, save_flow
    from windnav.flow import simulate as flow_simulate

    path = Path(cache_dir) / flow_cache_name(name, city, speed, direction, dx, steps, dt) \
        if cache_dir is not None else None
    code = module_key(SOLVER_MODULE)
    if path is not None and code.endswith("-modified"):  # the running solver is not the files'
        warnings.warn(f"slot_flow: a file of {SOLVER_MODULE}'s code changed after windnav was "
                      "imported, so the solver running may not be the one on disk: the flow "
                      "cache is not read nor written in this process.", stacklevel=3)
        path = None  # (an entry marked so would match no later run: review)
    if path is not None and path.is_dir():
        try:  # CorruptStoreError (a ValueError), or a folder that is no flow solution (yet)
            sol = load_flow(path)
            attrs = flow_attrs(path)
        except ValueError as exc:
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            warnings.warn(f"slot_flow: the flow cache entry {str(path)!r} cannot be read (an "
                          f"interrupted write, or damaged); solving it again to replace it. "
                          f"({reason})", stacklevel=3)
        else:
            recorded = (attrs.get("config") or {}).get("solver_code")
            if recorded == code:
                return sol, True, _recorded_seconds(attrs)
            warnings.warn(f"slot_flow: the flow cache entry {str(path)!r} was solved by "
                          + (f"other solver code (source hash {recorded})" if recorded else
                             "a windnav that did not record its solver code")
                          + f"; this solver's is {code} ({SOLVER_MODULE} and the modules it "
                          "imports). Solving it again to replace it.", stacklevel=3)
    t0 = time.perf_counter()
    sol = (simulate or flow_simulate)(city, speed=speed, direction_deg=direction, dx=dx, dt=dt,
                                      **steps)
    compute_s = time.perf_counter() - t0
    if path is not None:
        path.parent.mkdir(parents=True, exist_ok=True)
        # a process killed while writing this entry left its temporary copy (tens of MB)
        _remove_dead_leftovers(path.parent, [glob.escape(path.name)])
        with atomic_path(path) as tmp:  # replaces an unreadable entry whole
            save_flow(sol, tmp, config={"map": name, "inlet": inlet, "compute_s": compute_s,
                                        "solver_code": code})
    return sol, False, compute_s


def _evaluation_maps(maps, windinet, where):
    """``[(name, group, City)]``: the dense maps, then the windinet layout."""
    from windnav.city import City, read_rotorpy_json

    out = []
    if isinstance(maps, int | np.integer) and not isinstance(maps, bool):
        if maps > 0:
            from windnav.experiments.maps import generated_maps

            out += [(name, "dense", c) for name, _, c in
                    generated_maps(int(maps), "dense", seed=EVAL_MAP_SEED)]
        elif maps < 0:
            raise ValueError(f"The 'maps' parameter of {where} must be an integer >= 0 or a "
                             f"list of (name, City). Got {maps!r} instead.")
    else:
        for item in maps:
            name, c = item
            if not isinstance(c, City):
                raise ValueError(f"The 'maps' parameter of {where} must be an integer >= 0 or "
                                 f"a list of (name, City). Got {type(c).__name__} instead.")
            out.append((str(name), "dense", c))
    if windinet:
        path = windinet_layout() if windinet is True else Path(windinet)
        out.append(("windinet", "windinet", read_rotorpy_json(path)))
    if not out:
        raise ValueError(f"The 'maps' parameter of {where} must give at least one map (or "
                         "windinet=True). Got no map instead.")
    return out


def _with_files(cities, files, where) -> tuple[list, list]:
    """``cities`` (:func:`_evaluation_maps`), then the maps of ``files`` (``(name, path)`` of
    RotorPy world JSON files, group ``file``), every name once; and each file's record
    ``{"map", "path", "sha256"}``, hashed as it is read (not when the result is written, after
    the flows)."""
    from windnav.city import read_rotorpy_json

    out, records = list(cities), []
    for item in files:
        if not (isinstance(item, list | tuple) and len(item) == 2):
            raise ValueError(f"The 'files' parameter of {where} must be (name, path) pairs. "
                             f"Got {item!r} instead.")
        name, path = item
        if not Path(path).is_file():
            raise ValueError(f"The 'files' parameter of {where} must name RotorPy world JSON "
                             f"files. Got {str(path)!r} instead, which is not a file.")
        records.append({"map": str(name), "path": str(path), "sha256": map_sha256(path)})
        out.append((str(name), "file", read_rotorpy_json(path)))
    names = [n for n, _, _ in out]
    twice = sorted({n for n in names if names.count(n) > 1})
    if twice:  # a slot is named by its map (its records, its bootstrap stream, its cache entry)
        raise ValueError(f"The 'files' parameter of {where} must name each map once, apart "
                         f"from the others ({names}). Got {twice} more than once instead "
                         "(give each its own name; on the command line --map NAME=FILE).")
    return out, records


def _compared_rule(compare_boundary, dec):
    """The rule compared files load with: ``compare_boundary``, else the decoder's own (a
    like-for-like comparison), else :func:`~windnav.predict.load_decoder`'s default (None)."""
    return compare_boundary if compare_boundary is not None else getattr(dec, "boundary", None)


def _compared(compare, dec, where, boundary=None) -> tuple[dict, dict]:
    """``{name: Decoder}`` and ``{name: file or None}`` from ``compare`` (a mapping of names
    to decoder files or objects, or a sequence of them, then named by their architecture);
    each must predict on ``dec``'s grid. Files load with the ``boundary`` rule (default
    :func:`~windnav.predict.load_decoder`'s)."""
    from windnav.predict import load_decoder

    if compare is None:
        return {}, {}
    items = compare.items() if isinstance(compare, dict) else [(None, c) for c in compare]
    rule = {} if boundary is None else {"boundary": boundary}
    out, paths = {}, {}
    for name, item in items:
        model = item if hasattr(item, "predict") else load_decoder(item, **rule)
        name = model.architecture if name is None else str(name)
        if name in MODELS or name in out:
            raise ValueError(f"The 'compare' parameter of {where} must name each model once, "
                             f"and none {MODELS}. Got {name!r} twice or reserved instead "
                             "(give it a name: NAME=FILE).")
        if (model.size, model.spacing) != (dec.size, dec.spacing):
            raise ValueError(f"The 'compare' parameter of {where} must hold models on the "
                             f"decoder's grid ({dec.size} cells of {dec.spacing} m). Got "
                             f"{name!r} with {model.size} cells of {model.spacing} m instead.")
        out[name] = model
        paths[name] = None if hasattr(item, "predict") else str(item)
    return out, paths


def _score(decoder, batch, size, spacing, compared=None) -> tuple[dict, dict]:
    """Errors (pooled, and per sample) of the decoder, the compared models and both baselines
    on one batch."""
    from windnav.predict import field_errors
    from windnav.predict.baselines import with_baselines

    predictors = with_baselines({"decoder": decoder, **(compared or {})}, size, spacing)
    errors, per_sample = {}, {}
    for name, model in predictors.items():
        pred = model.predict(batch.scans, batch.w_up, batch.w_robot)
        e = field_errors(pred, batch.labels, batch.free, batch.inlet_speed, per_sample=True)
        per_sample[name] = e.pop("per_sample")
        errors[name] = e
    return errors, per_sample


def _pool(per_sample_list: list[dict]) -> dict:
    from windnav.predict import pooled_errors

    joined = {k: np.concatenate([p[k] for p in per_sample_list]) for k in per_sample_list[0]}
    return pooled_errors(joined)


def evaluate_decoder(model_path=None, *, maps=3, windinet=True, files=(), n_inlets: int = 8,
                     samples_per_inlet: int = 2048, seed: int = 0, budget_s: float = 1200.0,
                     dx: float = 1.0, flow_settings: dict | None = None, decoder=None,
                     compare=None, compare_boundary: str | None = None,
                     progress: bool = False, simulate=None, flow_cache=None) -> dict:
    """Score the decoder and its baselines on simulated evaluation fields (module doc).

    Parameters
    ----------
    model_path : str or path-like, optional
        A decoder file; default the shipped model (``windnav.predict.load_decoder``).
    maps : int or list of (str, City)
        The number of dense evaluation maps (``dense-i``, see the module doc), or the maps.
    windinet : bool or path
        Also evaluate the third-party windinet layout (or the RotorPy JSON at this path).
    files : sequence of (str, path)
        Maps of your own, each a name and a RotorPy world JSON file, evaluated after the others
        (group ``"file"``); the names must differ from each other and from ``dense-i`` and
        ``windinet``.
    n_inlets : int
        Random inlets per map, >= 1 (at most; the budget may stop earlier).
    samples_per_inlet : int
        Samples drawn per (map, inlet), >= 1.
    seed : int
        Seed of the inlets and the samples.
    budget_s : float
        Wall-clock budget, s (> 0); no slot starts that would end past it.
    dx : float
        Solver cell size, m (the decoder was trained at 1 m).
    flow_settings : dict, optional
        Override ``spinup_steps``, ``steps`` and ``dt`` (s) of the thesis protocol (tests).
    decoder : Decoder, optional
        Use this decoder instead of loading ``model_path``.
    compare : dict or sequence, optional
        Other models scored on the same fields and samples, reported beside the decoder (e.g.
        the thesis MLP trained on the same data): ``{name: file or Decoder}``, or files or
        Decoders named by their architecture. Each must predict on the decoder's grid.
    compare_boundary : {"blend", "average", "floor"}, optional
        The rule the compared files load with (default: the decoder's own rule).
    progress : bool
        Print one line per slot.
    simulate : callable, optional
        Replaces :func:`windnav.flow.simulate` (same signature; tests).
    flow_cache : str or path-like, optional
        Keep each slot's solution in this folder and reuse it when the same map, inlet and
        protocol come again (:func:`slot_flow`; shared with ``windnav decoder-study
        --flow-cache``). The budget charges a cached slot the simulation time recorded in its
        entry on top of its own (module doc), so the slots run do not depend on which flows
        were cached.

    Returns
    -------
    dict
        ``config`` (the protocol), ``decoder`` (its file and architecture), ``records`` (one
        per (map, inlet) slot run: map, group, speed, direction_deg, seconds, flow_cached,
        flow_diagnostics (the truth flow's averaging diagnostics, solved or read from the
        cache), errors of each model, improvement_pct), ``failed`` (slots whose flow
        failed, with the error),
        ``pooled`` (``{"dense": ..., "windinet": ..., "file": ..., "all": ...}``: errors per
        model,
        improvement_pct, ``improvement_ci95`` (per model other than the baselines, per
        baseline, for the speed and direction errors: :func:`improvement_interval`'s value,
        interval over the slots and note) and ``acceptance``: issue 9's checks, None with a
        ``note`` below
        :data:`ACCEPTANCE_SLOTS` slots of :data:`ACCEPTANCE_SAMPLES` samples),
        ``n_slots_run``, ``n_slots_planned``, ``stopped_by_budget``, ``elapsed_s``;
        ``models`` (the names scored, in order) and ``compared`` (each compared model's file
        and architecture). A compared model's errors sit beside the decoder's, its
        improvements under ``compared_improvement_pct``.
    """
    from windnav.experiments.wind_sweep import auto_dt
    from windnav.flow.solver import FlowDivergedError
    from windnav.predict import draw_samples, field_from_solution, load_decoder

    where = "evaluate_decoder"
    t_start = time.perf_counter()
    n_inlets = positive_int(n_inlets, "n_inlets", where)
    samples = positive_int(samples_per_inlet, "samples_per_inlet", where)
    budget_s = positive_float(budget_s, "budget_s", where)
    dx = positive_float(dx, "dx", where)
    nonnegative_int(seed, "seed", where)
    settings = {**PROTOCOL, **(flow_settings or {})}
    unknown = sorted(set(settings) - {"spinup_steps", "steps", "dt"})
    if unknown:
        raise ValueError(f"The 'flow_settings' parameter of {where} must only set "
                         f"spinup_steps, steps, dt. Got {unknown} instead.")
    dec = decoder if decoder is not None else load_decoder(model_path)
    compared, compared_paths = _compared(compare, dec, where,
                                         _compared_rule(compare_boundary, dec))
    models = ("decoder", *compared, *BASELINES)
    if windinet is True:
        windinet = windinet_layout()  # found and checked once (its SHA-256 reads the file)
    files = list(files or ())
    no_other = not windinet and (isinstance(maps, list | tuple) and not maps or (
        isinstance(maps, int | np.integer) and not isinstance(maps, bool) and maps == 0))
    cities, file_records = _with_files(
        [] if no_other and files else _evaluation_maps(maps, windinet, where), files, where)
    inlets = inlet_slots(len(cities), n_inlets, int(seed))
    slots = [(i, j) for j in range(n_inlets) for i in range(len(cities))]

    records, failed, per_sample = [], [], []
    seconds_per_cell = None  # the cost of the slots done, s per grid cell
    spent_s, spent_cells = 0.0, 0
    credit_s = 0.0  # charged to cached slots beyond their own time (module doc: Budget)
    stopped = False
    for i, j in slots:
        name, group, city = cities[i]
        speed, direction = inlets[i, j]
        cells = np.prod([len(a) for a in city.grid(dx)])
        elapsed = time.perf_counter() - t_start + credit_s
        if seconds_per_cell is not None and elapsed + seconds_per_cell * cells > budget_s:
            stopped = True
            break
        t0 = time.perf_counter()
        dt = settings.get("dt") or auto_dt(dx, speed)
        try:
            sol, cached, compute_s = _slot_flow(city, name, j, float(speed), float(direction),
                                                dx=dx, dt=float(dt),
                                                steps={k: settings[k] for k in
                                                       ("spinup_steps", "steps")},
                                                cache_dir=flow_cache, simulate=simulate)
        except FlowDivergedError as exc:
            failed.append({"map": name, "group": group, "inlet": j, "speed": speed,
                           "direction_deg": direction, "error": str(exc)})
            continue
        t_flow = time.perf_counter() - t0
        field = field_from_solution(city, sol, name=f"{name}/{j}")
        batch = draw_samples(field, samples, rng=slot_rng(seed, i, j), size=dec.size,
                             spacing=dec.spacing, scan_noise=0.35, w_robot_noise=0.0)
        errors, ps = _score(dec, batch, dec.size, dec.spacing, compared)
        seconds = time.perf_counter() - t0
        charged = seconds  # a solved slot: what it took
        if cached and compute_s is not None:  # as if solved: plus its recorded simulation
            charged = seconds + compute_s
        elif cached and seconds_per_cell is not None:  # no time recorded: the estimate
            charged = max(seconds, seconds_per_cell * cells)
        credit_s += charged - seconds
        if not cached or compute_s is not None:
            spent_s, spent_cells = spent_s + charged, spent_cells + int(cells)
            seconds_per_cell = spent_s / spent_cells
        rec = {"map": name, "group": group, "inlet": j, "speed": float(speed),
               "direction_deg": float(direction), "dt": float(dt), "cells": int(cells),
               "n_samples": int(batch.scans.shape[0]), "flow_seconds": t_flow,
               "flow_cached": cached,
               "flow_diagnostics": dict(getattr(sol, "diagnostics", None) or {}),
               "seconds": seconds, **_summary(errors)}
        records.append(rec)
        per_sample.append((group, ps))
        if progress:
            d, lo = errors["decoder"], errors["local"]
            others = "".join(f"; {m} {errors[m]['speed_error']:.3f}, "
                             f"{errors[m]['direction_error_deg']:.1f}" for m in compared)
            print(f"{name} inlet {j}: {speed:.2f} m/s {direction:.0f} deg; decoder speed "
                  f"{d['speed_error']:.3f} m/s dir {d['direction_error_deg']:.1f} deg (Local "
                  f"{lo['speed_error']:.3f}, {lo['direction_error_deg']:.1f}{others}); flow "
                  f"{t_flow:.0f} s, total {seconds:.0f} s", file=sys.stderr, flush=True)

    pooled = {}
    for group in (*GROUPS, "all"):
        chosen = [ps for g, ps in per_sample if group in ("all", g)]
        if not chosen:
            continue
        summary = _summary({m: _pool([ps[m] for ps in chosen]) for m in models})
        summary["n_slots"] = len(chosen)
        summary["improvement_ci95"] = _intervals(records, models, group)
        summary["acceptance"] = _acceptance(summary, samples)
        pooled[group] = summary
    return {
        "config": {"maps": [n for n, _, _ in cities], "map_seed": EVAL_MAP_SEED,
                   "windinet_layout": str(windinet) if windinet else None,
                   "files": file_records,
                   "n_inlets": n_inlets, "samples_per_inlet": samples, "seed": int(seed),
                   "budget_s": budget_s, "dx": dx, **settings,
                   "dt_rule": "0.25 s, shortened to U dt / dx <= 1" if "dt" not in
                   (flow_settings or {}) else "given",
                   "speed_range": SPEED_RANGE, "direction_range_deg": (0.0, 360.0),
                   "scan_noise": 0.35, "w_robot_noise": 0.0, "acceptance": ACCEPTANCE},
        "decoder": _describe(dec, model_path if model_path is not None else "default"),
        "models": list(models),
        "compared": {m: _describe(c, compared_paths[m]) for m, c in compared.items()},
        "records": records, "failed": failed, "pooled": pooled,
        "n_slots_run": len(records) + len(failed), "n_slots_planned": len(slots),
        "stopped_by_budget": stopped, "elapsed_s": time.perf_counter() - t_start,
    }


def map_sha256(path) -> str:
    """The SHA-256 (64 hex digits) of the map file ``path`` (one of ``files``, as a result
    records it; ``windnav decoder-study --map`` too)."""
    with open(path, "rb") as f:
        return hashlib.file_digest(f, "sha256").hexdigest()


def _describe(model, path) -> dict:
    return {"path": str(path) if path is not None else None,
            "architecture": model.architecture, "size": model.size, "spacing": model.spacing,
            "n_parameters": model.n_parameters, "boundary": getattr(model, "boundary", None),
            "rotations_deg": getattr(model, "rotations_deg", None)}


def check_point(city, at, flag: str = "at", where: str = "predict_at") -> np.ndarray:
    """``at`` as an (2,) array inside the map and outside every building, else ValueError."""
    from windnav.city import City

    # None met AttributeError 'bounds', and 'ab' NumPy's bare "could not convert string to
    # float" (Python API audit, fifty-eighth session)
    if not isinstance(city, City):
        raise ValueError(f"The 'city' parameter of {where} must be a City (windnav.city). Got "
                         f"{city!r} instead.")
    try:
        p = np.asarray(at, dtype=np.float64)
    except (TypeError, ValueError):
        p = np.full(1, np.nan)
    if p.shape != (2,) or not np.all(np.isfinite(p)):
        raise ValueError(f"The {flag!r} parameter of {where} must be two finite numbers X Y, "
                         f"m. Got {at!r} instead.")
    x0, x1, y0, y1 = city.bounds
    if not (x0 < p[0] < x1 and y0 < p[1] < y1):
        # (written as a closed interval before, which the refused edge contradicted: audit)
        edge = x0 <= p[0] <= x1 and y0 <= p[1] <= y1
        raise ValueError(f"The {flag!r} parameter of {where} must be a point inside the map, "
                         f"its edges excluded: ({x0:g}, {x1:g}) x ({y0:g}, {y1:g}) m. Got "
                         f"({p[0]:g}, {p[1]:g}) instead, which is "
                         f"{'on its edge' if edge else 'outside the map'}.")
    if bool(city.contains(p[None])[0]):
        raise ValueError(f"The {flag!r} parameter of {where} must be a point outside every "
                         f"building. Got ({p[0]:g}, {p[1]:g}) instead, which is inside a "
                         "building.")
    return p


def predict_at(decoder, field, at, *, scan_noise: float = 0.0, rng=None) -> dict:
    """One prediction at one point of a mean field, with its truth and the baselines' errors.

    Parameters
    ----------
    decoder : Decoder
    field : MeanField
        The map's mean flow (:func:`windnav.predict.field_from_solution`).
    at : array_like of shape (2,)
        The robot's position, m, world frame (inside the map, outside every building).
    scan_noise : float
        Standard deviation of the LiDAR range noise, m (0: noise-free).
    rng : numpy.random.Generator, int or None
        Source of the scan noise; required when ``scan_noise > 0``.

    Returns
    -------
    dict
        ``position``, ``w_up``, ``w_robot`` (m/s), ``offsets`` (H,), ``scan`` (360,),
        ``truth``, ``prediction`` (2, H, H), ``free`` (H, H), and ``metrics``: the errors of
        the decoder and both baselines with the improvement (%).
    """
    from windnav.predict import SCAN_MAX, SCAN_MIN, MeanField, SampleBatch

    if not isinstance(field, MeanField):  # a FlowSolution met AttributeError 'city' (audit)
        raise ValueError("The 'field' parameter of predict_at must be a MeanField "
                         "(windnav.predict.field_from_solution makes one of a FlowSolution). "
                         f"Got a {type(field).__name__} instead.")
    p = check_point(field.city, at)
    noise = positive_float(scan_noise, "scan_noise", "predict_at", allow_zero=True)
    scan = field.city.lidar(p[None], n_rays=decoder.n_rays, max_range=SCAN_MAX,
                            noise_std=noise, rng=rng)
    scan = np.clip(scan, SCAN_MIN, SCAN_MAX)
    w_robot = field.interpolate(p)
    w_up = np.asarray(field.w_up, dtype=np.float64)[None]
    truth, free = field.grid_values(p, decoder.offsets, dtype=np.float32)

    batch = SampleBatch(scan, w_up, w_robot, truth, free, p[None],
                        np.array([field.inlet_speed]))
    errors, _ = _score(decoder, batch, decoder.size, decoder.spacing)
    prediction = decoder.predict(scan, w_up, w_robot)
    return {"position": p, "w_up": w_up[0], "w_robot": w_robot[0], "offsets": decoder.offsets,
            "scan": scan[0], "truth": truth[0], "prediction": prediction[0], "free": free[0],
            "metrics": _summary(errors)}
