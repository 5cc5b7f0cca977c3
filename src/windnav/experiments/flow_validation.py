"""Validation of the flow solver: exact checks, and Strouhal studies against experiments.

The checks (:func:`projection_study`, :func:`uniform_study`, :func:`taylor_green_study`), each
against a reference that does not come from this code: the discrete divergence after every
projection (0), the normal velocity on building faces (0), uniform flow without buildings
(stays uniform), the Taylor-Green vortex in a free-slip box (an exact steady Euler solution:
its energy decay is the scheme's numerical viscosity).

Each study is a list of :class:`windnav.flow.BluffBodyCase` runs (solver defaults unless
stated), run through :func:`windnav.experiments.executor.run_tasks`:

* resolution: a square at 0 and 90 deg, H = 8, 16, 32 cells, dt halved with dx: St must stay
  in [0.12, 0.16] and change by at most 5 % per halving, and 0 and 90 deg must agree;
* incidence: St against the inlet angle 0-90 deg for 1:1, 2:1 and 3:1 rectangles (the thesis's
  validation figure; experiments: Norberg 1993);
* aspect ratio: St against the depth ratio B/H at 0 deg (Nakaguchi et al. 1968; Okajima 1982).

Reference values come from ``windnav/flow/data/strouhal_reference.csv`` (one row per point,
with its source, and whether it is stated in the text or read from a figure).

With ``records`` (a :class:`~windnav.experiments.results.RecordLog`, JSON lines, header
:func:`records_header`), every finished run of a study -- each Strouhal case, and the
label-noise table -- is appended as it finishes, with its study and its case, so an
interrupted validation resumes with the runs not yet done. A run's record is its result as
:func:`run_case` returns it (floats written with ``repr``, which reads back to the bit; the
lift history is float32 values), so the resumed validation's result is the uninterrupted one's.
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import asdict, replace
from importlib import resources

import numpy as np

from windnav._validate import (
    finite_float,
    nonnegative_int,
    options_named,
    positive_float,
    positive_int,
)
from windnav.city import City
from windnav.experiments.results import RecordLog, json_ready
from windnav.flow import (
    BoundaryConditions,
    MACGrid,
    divergence,
    fixed_face_violation,
    make_advection,
    make_domain,
    make_flow_step,
    simulate,
)
from windnav.flow.strouhal import BluffBodyCase, bluff_body_strouhal

RESOLUTIONS = (8, 16, 32)
INCIDENCE_ANGLES = tuple(float(a) for a in range(0, 91, 5))
INCIDENCE_SHAPES = (1.0, 2.0, 3.0)
ASPECT_RATIOS = (0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0, 5.0, 6.0)
STUDY_CELLS = 8
ST_RANGE = (0.12, 0.16)
MAX_HALVING_CHANGE = 0.05
# a shorter domain and record for the resolution series: its finest grid is 512^2 cells
RESOLUTION_CASE = BluffBodyCase(upstream=5.0, downstream=10.0, spinup_time=40.0,
                                record_time=80.0)
# 120 H/U of spin-up and 160 recorded: after 40, the square at 20-35 deg and B/H = 1.5 were
# still changing their shedding (St 0.132 at 30 deg in the first 80 H/U, 0.140-0.145 in the
# next three; audit, 2026-12-05); the record's halves tell a run that has not settled, and
# such a run's record is doubled up to 1,280 H/U: the square at 35 and 55 deg and B/H = 1.5
# switch between two shedding states, whose mix a long record averages (thirty-fifth session)
STUDY_CASE = BluffBodyCase(cells_per_height=STUDY_CELLS, upstream=6.0, downstream=12.0,
                           spinup_time=120.0, record_time=160.0, max_record_time=1280.0)
MAX_TAYLOR_GREEN_N = 1024
"""The finest Taylor-Green grid :func:`taylor_green_study` runs (n x n cells, 2 * n * periods
steps; n = 10**6 was a 931 GiB MemoryError)."""
REFERENCE_COLUMNS = ("study", "aspect_ratio", "angle_deg", "strouhal", "source")
"""The columns of a reference CSV (:func:`load_references`) the comparison reads."""

RECORDS = "flow_validation.partial.jsonl"
"""The record log ``windnav flow-validate`` keeps in its output folder while its studies run."""


class StudyFailedError(RuntimeError):
    """A Strouhal study some of whose runs failed (the message gives the first error)."""


def run_case(case: BluffBodyCase) -> dict:
    """One Strouhal run, reduced to JSON-ready scalars and the lift history (a sweep task)."""
    r = bluff_body_strouhal(case)
    keep = ("strouhal", "strouhal_crossings", "cd_mean", "cl_rms", "dx", "dt", "steps",
            "cells_per_height", "aspect_ratio", "angle_deg", "filter_width", "settled",
            "record_time_used")
    out = {k: (float(r[k]) if isinstance(r[k], float | np.floating) else r[k]) for k in keep}
    out["strouhal_halves"] = [float(x) for x in r["strouhal_halves"]]
    out["shape"] = list(r["shape"])
    out["cl"] = np.asarray(r["cl"], dtype=np.float32).tolist()
    return out


def records_header(*, seed: int, studies: bool, full: bool) -> dict:
    """The header of a validation's record log: what its runs depend on (which studies run,
    and the seed of the label-noise map; not the workers)."""
    return {"study": "windnav.experiments.flow_validation",
            "studies": "full" if full else "studies" if studies else "checks", "seed": int(seed)}


def _case_key(case: dict) -> str:
    """A run's case (a dataclass's fields, or JSON read back) as a string to look it up by."""
    return json.dumps(json_ready(case, keep_nonfinite=True), sort_keys=True)


def _recorded(records: RecordLog | None, study: str) -> dict:
    """The results ``records`` holds for ``study``, by :func:`_case_key` (the last of each)."""
    if records is None:
        return {}
    return {_case_key(rec["case"]): rec["run"] for rec in records.load()
            if isinstance(rec, dict) and rec.get("study") == study
            and isinstance(rec.get("case"), dict) and "run" in rec}


def _record(records: RecordLog | None, study: str, case: dict, run) -> None:
    if records is not None:
        records.append({"study": study, "case": case, "run": run})


def _run(cases, study: str, backend: str, workers: int | None, progress: bool,
         records: RecordLog | None = None) -> list[dict]:
    """:func:`run_case` of each of ``cases`` (in their order), those recorded for ``study`` in
    ``records`` taken from it, the others run and appended to it as each finishes."""
    from windnav.experiments.executor import run_tasks

    desc = f"St {study.replace('_', ' ')}"
    done = _recorded(records, study)
    keys = [_case_key(asdict(c)) for c in cases]
    todo = [i for i, key in enumerate(keys) if key not in done]

    def keep(r):
        if r.ok:
            _record(records, study, asdict(cases[todo[r.index]]), r.value)

    results = list(run_tasks(run_case, [cases[i] for i in todo], backend=backend,
                             workers=workers, progress=progress, desc=desc, on_result=keep))
    failed = sorted((r for r in results if not r.ok), key=lambda r: r.index)
    if failed:
        kept = "" if records is None else (f"; the finished runs are kept in "
                                           f"{str(records.path)!r}, a rerun runs the others")
        raise StudyFailedError(f"{len(failed)} of {len(cases)} Strouhal runs ({desc}) "
                               f"failed; first: {failed[0].error}{kept}")
    ran = {todo[r.index]: r.value for r in results}
    return [ran[i] if i in ran else done[key] for i, key in enumerate(keys)]


def _study_values(values, name: str, where: str, rule: str = "finite") -> list:
    """``values`` checked up front, before any run: one or more numbers, finite (``rule``
    "finite") or finite and above 0 ("positive"); a ValueError naming the argument."""
    from windnav.experiments.wind_sweep import _values

    items = _values(values, name, where, "numbers")
    for v in items:
        if isinstance(v, (str, bytes)):
            raise ValueError(f"The {name!r} parameter of {where} must hold numbers. Got "
                             f"{v!r} instead.")
        if rule == "positive":
            positive_float(v, name, where)
        else:
            finite_float(v, name, where)
    return items


def resolution_study(resolutions=RESOLUTIONS, angles=(0.0, 90.0), backend="process",
                     workers=None, progress=True, base: BluffBodyCase = RESOLUTION_CASE,
                     records: RecordLog | None = None) -> dict:
    """St of a square at each angle and resolution (default closure), with the verdict.

    ``records``: a record log (see the module docstring); runs recorded there are not run
    again, and each other run is appended as it finishes (as for every study here).

    Returns
    -------
    dict
        ``runs`` (list of run dicts), ``strouhal`` {angle: [St per resolution]},
        ``halving_change`` {angle: [relative change per halving]}, ``angle_difference``
        (max over resolutions of |St(first) - St(second angle)| / St(first)), ``passes``.
    """
    # one resolution measured no halving and one angle no difference, and the verdict passed
    # over what it had not measured (all([]) is True; statistics audit)
    for key, values in (("resolutions", resolutions), ("angles", angles)):
        if len(set(values)) < 2:
            raise ValueError(f"The '{key}' parameter of resolution_study must hold at least two "
                             f"different values (the verdict compares them). Got {values!r} "
                             "instead.")
    cases = [replace(base, cells_per_height=int(n), angle_deg=float(a))
             for a in angles for n in resolutions]
    runs = _run(cases, "resolution", backend, workers, progress, records)
    st = {f"{a:g}": [r["strouhal"] for r in runs if r["angle_deg"] == a] for a in angles}
    change = {k: [abs(b - a) / a for a, b in zip(v[:-1], v[1:], strict=True)]
              for k, v in st.items()}
    first, *rest = st.values()
    diff = max((abs(a - b) / a for other in rest for a, b in zip(first, other, strict=True)),
               default=0.0)
    lo, hi = ST_RANGE
    passes = bool(all(lo <= s <= hi for v in st.values() for s in v)
                  and all(c <= MAX_HALVING_CHANGE for v in change.values() for c in v)
                  and diff <= 0.02)
    return {"runs": runs, "resolutions": list(resolutions), "strouhal": st,
            "halving_change": change, "angle_difference": float(diff), "passes": passes}


def incidence_study(shapes=INCIDENCE_SHAPES, angles=INCIDENCE_ANGLES, backend="process",
                    workers=None, progress=True, base: BluffBodyCase = STUDY_CASE,
                    records: RecordLog | None = None) -> dict:
    """St against the inlet angle for each aspect ratio, and the square's checks.

    Returns
    -------
    dict
        ``runs``, ``strouhal`` {aspect ratio: [St per angle]}, ``angles``, ``unsettled``
        ([aspect ratio, angle] of the runs whose record's halves disagree on St by more than
        :data:`windnav.flow.strouhal.SETTLED_TOLERANCE` at the longest record the base case
        allows, ``max_record_time``), ``extended`` ([aspect ratio, angle, H / U recorded] of
        the runs whose record was doubled), and for the square:
        ``symmetry`` (max |St(a) - St(90 - a)| / St(a)), ``symmetry_settled`` (the same over
        the pairs of settled runs), ``peak_angle`` and ``peak_strouhal``
        (the largest St in 5-25 deg), ``strouhal_0``, ``checks`` (each acceptance point).
    """
    # Python API audit, fifty-eighth session: an aspect ratio of -1 ran for seconds and
    # reported St 0.191; shapes and angles are checked before any run
    _study_values(shapes, "shapes", "incidence_study", "positive")
    _study_values(angles, "angles", "incidence_study")
    cases = [replace(base, aspect_ratio=float(s), angle_deg=float(a))
             for s in shapes for a in angles]
    runs = _run(cases, "incidence", backend, workers, progress, records)
    st = {f"{s:g}": [r["strouhal"] for r in runs if r["aspect_ratio"] == s] for s in shapes}
    unsettled = [[r["aspect_ratio"], r["angle_deg"]] for r in runs
                 if not r.get("settled", True)]
    out = {"runs": runs, "angles": list(angles), "strouhal": st, "unsettled": unsettled,
           "extended": _extended(runs, base)}
    if 1.0 in shapes:
        sq = dict(zip(angles, st["1"], strict=True))
        pairs = [(a, 90.0 - a) for a in angles if a < 45.0 and (90.0 - a) in sq]
        # a NaN St (no resolved shedding peak) makes each check it enters NaN and False:
        # Python's max skips a NaN unless it comes first, so a pair without shedding could
        # pass the mirror check (the thirty-eighth session's leftover)
        sym = _max_or_nan([abs(sq[a] - sq[b]) / sq[a] for a, b in pairs])
        # a run whose record's halves disagree switches between shedding states: its St is a
        # window's, so the mirror check is also given over the settled pairs alone
        odd = {a for b, a in unsettled if b == 1.0}
        sym_settled = _max_or_nan([abs(sq[a] - sq[b]) / sq[a] for a, b in pairs
                                   if a not in odd and b not in odd])
        band = [a for a in angles if 5.0 <= a <= 25.0]
        if any(math.isnan(sq[a]) for a in band):
            band = []  # no peak among runs of which one did not shed
        peak = max(band, key=lambda a: sq[a]) if band else float("nan")
        s0 = sq.get(0.0, float("nan"))
        lo, hi = ST_RANGE
        out.update({
            "symmetry": float(sym),
            "symmetry_settled": float(sym_settled),
            "peak_angle": float(peak),
            "peak_strouhal": float(sq[peak]) if band else float("nan"),
            "strouhal_0": float(s0),
            "checks": {
                "symmetric_within_3pct": bool(sym <= 0.03),
                "peak_5_25_above_0": bool(band and sq[peak] > s0 and sq[peak] >= _max_or_nan(
                    [v for a, v in sq.items() if a <= 45.0])),
                "st0_in_range": bool(lo <= s0 <= hi),
            },
        })
    return out


def _max_or_nan(values) -> float:
    """The largest of ``values``; NaN when there are none or any is NaN."""
    values = [float(v) for v in values]
    if not values or any(math.isnan(v) for v in values):
        return float("nan")
    return max(values)


def aspect_ratio_study(ratios=ASPECT_RATIOS, backend="process", workers=None, progress=True,
                       base: BluffBodyCase = STUDY_CASE,
                       records: RecordLog | None = None) -> dict:
    """St against the depth ratio B/H at 0 deg. Returns ``runs``, ``ratios``, ``strouhal``,
    ``unsettled`` (the ratios whose record's halves disagree, as in :func:`incidence_study`),
    ``extended`` (as there)."""
    # an aspect ratio of 0 ran for seconds and reported St 0.191 (Python API audit,
    # fifty-eighth session)
    _study_values(ratios, "ratios", "aspect_ratio_study", "positive")
    cases = [replace(base, aspect_ratio=float(b), angle_deg=0.0) for b in ratios]
    runs = _run(cases, "aspect_ratio", backend, workers, progress, records)
    return {"runs": runs, "ratios": list(ratios), "strouhal": [r["strouhal"] for r in runs],
            "unsettled": [r["aspect_ratio"] for r in runs if not r.get("settled", True)],
            "extended": _extended(runs, base)}


def _extended(runs, base: BluffBodyCase) -> list:
    """[aspect ratio, angle, H / U recorded] of the runs recorded longer than
    ``base.record_time`` (an unsettled run's doubled record)."""
    return [[r["aspect_ratio"], r["angle_deg"], r["record_time_used"]] for r in runs
            if r.get("record_time_used", base.record_time) > base.record_time * (1 + 1e-9)]


def load_references(path=None) -> list[dict]:
    """The experimental reference points: a list of rows of the reference CSV.

    Columns: ``study`` (incidence | aspect_ratio), ``aspect_ratio`` (B/H), ``angle_deg``,
    ``strouhal``, ``reynolds``, ``kind`` (stated | figure), ``source``, ``note``.
    """
    if path is None:
        text = resources.files("windnav.flow").joinpath("data/strouhal_reference.csv").read_text()
    else:
        with open(path, encoding="utf-8") as f:
            text = f.read()
    reader = csv.DictReader(line for line in text.splitlines() if not line.startswith("#"))
    rows = list(reader)
    missing = [c for c in REFERENCE_COLUMNS if c not in (reader.fieldnames or ())]
    if missing:  # rows of NaN before (Python API audit, fifty-eighth session)
        raise ValueError(f"The 'path' parameter of load_references must name a CSV with the "
                         f"columns {', '.join(REFERENCE_COLUMNS)}. Got {str(path)!r} instead, "
                         f"without {', '.join(missing)}.")
    for r in rows:
        for k in ("aspect_ratio", "angle_deg", "strouhal", "reynolds"):
            r[k] = float(r[k]) if r.get(k) not in (None, "") else float("nan")
    return rows


def compare_references(refs, incidence: dict | None, aspect: dict | None) -> dict:
    """Deviation computed - experiment at every reference point the studies cover.

    The computed value at a reference's (aspect ratio, angle) is linearly interpolated in
    angle (incidence study) or in B/H (aspect-ratio study); points outside a study's range are
    listed as not covered. Returns ``points`` (each with ``computed`` and ``deviation``),
    ``rms`` over the covered points and ``n``.
    """
    points = []
    for r in refs:
        computed = float("nan")
        if r["study"] == "incidence" and incidence is not None:
            key = f"{r['aspect_ratio']:g}"
            if key in incidence["strouhal"]:
                a = np.asarray(incidence["angles"], dtype=float)
                if a.min() <= r["angle_deg"] <= a.max():
                    computed = float(np.interp(r["angle_deg"], a, incidence["strouhal"][key]))
        elif r["study"] == "aspect_ratio" and aspect is not None:
            b = np.asarray(aspect["ratios"], dtype=float)
            if b.min() <= r["aspect_ratio"] <= b.max():
                computed = float(np.interp(r["aspect_ratio"], b, aspect["strouhal"]))
        points.append({**r, "computed": computed, "deviation": computed - r["strouhal"]})
    dev = np.array([p["deviation"] for p in points if np.isfinite(p["deviation"])])
    rms = float(np.sqrt(np.mean(dev**2))) if dev.size else float("nan")
    return {"points": points, "rms": rms, "n": int(dev.size)}


def label_noise_study(speeds=(2.0, 5.0, 10.0), direction_deg: float = 0.0, seed: int = 0,
                      size: float = 500.0, spinup_steps: int = 100, steps: int = 200,
                      dx: float = 1.0, dt: float = 0.25) -> dict:
    """The thesis's averaging protocol on a training map: how converged are its mean fields?

    One ``training_map(rng=seed, size=size)``; for each inlet speed, the flow-throughs of
    the spin-up and of the window and the half-window difference of the mean (relative to the
    inlet speed), which is the noise of the labels a decoder learns from.

    Returns
    -------
    dict
        ``rows`` (one per speed: speed, flow_throughs_spinup, flow_throughs_average,
        half_window_difference, filter_width, seconds), ``map`` (number of buildings, size).
    """
    import time

    from windnav.city import training_map
    from windnav.flow import simulate_batch

    where = "label_noise_study"
    # a size of 0 was named "'size' parameter of training_map" and a seed < 0 NumPy's
    # "expected non-negative integer" (Python API audit, fifty-eighth session)
    nonnegative_int(seed, "seed", where)
    with options_named({"'size' parameter of training_map": f"'size' parameter of {where}"}):
        city = training_map(rng=np.random.default_rng(seed), size=size)
    t0 = time.perf_counter()
    sols = simulate_batch(city, list(speeds), direction_deg, dx, dt, spinup_steps, steps)
    seconds = time.perf_counter() - t0
    rows = [{"speed": s.speed, **s.diagnostics, "seconds_batch": seconds} for s in sols]
    return {"rows": rows, "map": {"buildings": int(city.n_buildings), "size": size,
                                  "seed": seed}, "protocol": {"spinup_steps": spinup_steps,
                                                              "steps": steps, "dx": dx,
                                                              "dt": dt,
                                                              "direction_deg": direction_deg}}


CLOSURES = ("inviscid", "smagorinsky_grid_filter", "default")


def closure_study(resolutions=(8, 16), backend="process", workers=None, progress=True,
                  base: BluffBodyCase = RESOLUTION_CASE,
                  records: RecordLog | None = None) -> dict:
    """St of the square at 0 deg per closure and resolution: why the default is what it is.

    ``inviscid``: no closure (the scheme's numerical diffusion); ``smagorinsky_grid_filter``:
    Smagorinsky with the usual filter width ``dx``; ``default``: the building-scaled filter.
    Returns ``runs`` and ``strouhal`` {closure: [St per resolution]}.
    """
    cases, labels = [], []
    for name in CLOSURES:
        for n in resolutions:
            case = replace(base, cells_per_height=int(n), angle_deg=0.0)
            if name == "inviscid":
                case = replace(case, smagorinsky=0.0)
            elif name == "smagorinsky_grid_filter":
                case = replace(case, filter_width=1.0 / n)
            cases.append(case)
            labels.append(name)
    runs = _run(cases, "closures", backend, workers, progress, records)
    for r, name in zip(runs, labels, strict=True):
        r["closure"] = name
    st = {name: [r["strouhal"] for r in runs if r["closure"] == name] for name in CLOSURES}
    return {"runs": runs, "resolutions": list(resolutions), "strouhal": st}


# ------------------------------------------------------------------------------ exact checks


def random_city(*, rng) -> City:
    """Eight random 4-12 m buildings in a 140 x 80 m map (the projection study's map)."""
    rng = np.random.default_rng(rng)
    fp = []
    for _ in range(8):
        x0, y0 = rng.uniform(15.0, 105.0), rng.uniform(8.0, 62.0)
        w, h = rng.uniform(4.0, 12.0, 2)
        fp.append([x0, x0 + w, y0, y0 + h])
    return City((0.0, 140.0, 0.0, 80.0), fp, np.full(len(fp), 20.0))


def projection_study(*, rng, steps: int = 300) -> dict:
    """Step the flow through a random city (:func:`random_city`), 5 m/s at 15 deg.

    Returns ``max_div_dx_over_U`` and ``max_fixed_face_error`` per step (both 0 for an exact
    projection), and the last ``u``, ``v``, the ``solid`` mask and the ``grid``.
    """
    # a steps of 0 or -3 returned empty lists (Python API audit, fifty-eighth session)
    steps = positive_int(steps, "steps", "projection_study")
    city = random_city(rng=rng)
    speed, dx, dt = 5.0, 1.0, 0.1
    grid = MACGrid((80, 140), dx)
    domain = make_domain(grid, city.rasterize(grid.x, grid.y),
                         BoundaryConditions.for_wind(speed, 15.0))
    step = make_flow_step(domain, dt)
    u, v = step.project(*domain.initial_velocity(0.05 * speed))
    div, wall = [], []
    for _ in range(steps):
        u, v = step(u, v)
        div.append(float(np.abs(divergence(domain, u, v)).max() * dx / speed))
        wall.append(fixed_face_violation(domain, u, v))
    return {"max_div_dx_over_U": div, "max_fixed_face_error": wall,
            "solid": domain.solid, "u": u, "v": v, "grid": grid}


def uniform_study(directions=(0.0, 30.0, 90.0, 135.0, 200.0, 290.0)) -> dict:
    """Largest deviation (m/s) of the mean wind from a 4 m/s uniform inlet without buildings,
    per direction (deg)."""
    # no direction returned {} (Python API audit, fifty-eighth session)
    _study_values(directions, "directions", "uniform_study")
    city = City((0.0, 60.0, 0.0, 40.0), np.zeros((0, 4)), np.zeros(0))
    out = {}
    for direction in directions:
        sol = simulate(city, speed=4.0, direction_deg=direction, dx=1.0, dt=0.2,
                       spinup_steps=50, steps=50)
        th = np.deg2rad(direction)
        err = max(np.abs(sol.mean_u - 4.0 * np.cos(th)).max(),
                  np.abs(sol.mean_v - 4.0 * np.sin(th)).max())
        out[f"{direction:g}"] = float(err)
    return out


def taylor_green_field(grid: MACGrid) -> tuple[np.ndarray, np.ndarray]:
    """The Taylor-Green vortex ``u = sin x cos y``, ``v = -cos x sin y`` (peak 1 m/s) on the
    faces of ``grid``, a free-slip box [0, pi]^2 (the wall faces 0): an exact steady solution
    of the Euler equations whose energy decays as ``exp(-4 nu t)`` with a viscosity ``nu``."""
    u = np.sin(grid.x_faces)[None, :] * np.cos(grid.y)[:, None]
    v = -np.cos(grid.x)[None, :] * np.sin(grid.y_faces)[:, None]
    u[:, [0, -1]] = 0.0
    v[[0, -1], :] = 0.0
    return u, v


def taylor_green_study(n: int = 64, periods: float = 4.0) -> dict:
    """Numerical viscosity ``nu`` (m^2/s) of each advection scheme from the energy decay
    ``E(t) ~ exp(-4 nu t)`` of the Taylor-Green vortex in a free-slip box [0, pi]^2.

    ``n`` (2 to :data:`MAX_TAYLOR_GREEN_N`) cells a side; ``periods`` long enough for two
    steps at least (``periods * n >= 1``)."""
    # Python API audit, fifty-eighth session: n = 0 was a ZeroDivisionError, n = 10**6 a
    # 931 GiB MemoryError, periods = -1 a TypeError in numpy.polyfit (no step)
    where = "taylor_green_study"
    try:
        cells = positive_int(n, "n", where)
    except ValueError:
        cells = 0
    if not 2 <= cells <= MAX_TAYLOR_GREEN_N:
        raise ValueError(f"The 'n' parameter of {where} must be an integer from 2 to "
                         f"{MAX_TAYLOR_GREEN_N}. Got {n!r} instead.")
    n = cells
    if isinstance(periods, (str, bytes)):
        raise ValueError(f"The 'periods' parameter of {where} must be a number. Got "
                         f"{periods!r} instead.")
    positive_float(periods, "periods", where)
    dx = np.pi / n
    if int(periods * np.pi / (0.5 * dx)) < 2:  # the steps below
        raise ValueError(f"The 'periods' parameter of {where} must give at least two steps "
                         f"(periods * n >= 1). Got {periods!r} instead (n = {n}).")
    grid = MACGrid((n, n), dx)
    box = make_domain(grid, np.zeros((n, n), bool), BoundaryConditions(("wall",) * 4))
    res = {}
    for scheme in ("semi_lagrangian", "maccormack"):
        u, v = taylor_green_field(grid)
        dt = 0.5 * dx
        step = make_flow_step(box, dt, make_advection(box, dt, scheme))
        u, v = step.project(u, v)
        steps = int(periods * np.pi / dt)
        e = []
        for _ in range(steps):
            e.append(0.5 * (np.sum(u**2) + np.sum(v**2)) * dx**2)
            u, v = step(u, v)
        t = dt * np.arange(steps)
        nu = -np.polyfit(t, np.log(e), 1)[0] / 4.0
        res[scheme] = {"nu": float(nu), "t": t.tolist(), "energy": e, "dx": dx, "dt": dt}
    return res


# ------------------------------------------------------------------------------ the report


def open_records(records, *, seed: int, studies: bool, full: bool) -> RecordLog | None:
    """The record log at ``records`` (None: none) for this validation, checked: its records
    are loaded once, so one of another validation is refused before anything runs.

    Raises
    ------
    RecordMismatchError
        When ``records`` holds the records of another validation (:func:`records_header`).
    """
    if records is None:
        return None
    log = RecordLog(records, records_header(seed=seed, studies=studies, full=full))
    log.load()
    return log


def _label_noise(seed: int, records: RecordLog | None) -> dict:
    """:func:`label_noise_study` of ``seed``, from ``records`` when recorded there (else
    appended to it), as JSON reads it back either way."""
    case = {"seed": int(seed)}
    done = _recorded(records, "label_noise").get(_case_key(case))
    if done is not None:
        return done
    res = json_ready(label_noise_study(seed=seed), keep_nonfinite=True)
    _record(records, "label_noise", case, res)
    return res


def strouhal_studies(full: bool, studies: bool, workers: int | None = None,
                     progress: bool = True, seed: int = 0, *, backend: str = "process",
                     records=None) -> dict:
    """The requested Strouhal studies: ``studies`` the incidence and aspect-ratio studies
    (with the reference comparison), ``full`` also the resolution series, the closure
    comparison and the label-noise table (on the training map of ``seed``).

    ``records`` (str or path-like, optional): a record log (header :func:`records_header`) that
    every finished run is appended to as it finishes; runs recorded there are not run again,
    and the result is the uninterrupted validation's. Raises ``RecordMismatchError`` (before
    any run) when it holds the records of another validation.
    """
    log = open_records(records, seed=seed, studies=studies, full=full)
    kw = {"backend": backend, "workers": workers, "progress": progress, "records": log}
    res = {}
    if full:
        res["resolution"] = resolution_study(**kw)
        res["closures"] = closure_study(**kw)
        res["label_noise"] = _label_noise(seed, log)
    if full or studies:
        res["incidence"] = incidence_study(**kw)
        res["aspect_ratio"] = aspect_ratio_study(**kw)
        res["references"] = compare_references(load_references(), res["incidence"],
                                               res["aspect_ratio"])
    return res


def brief(res: dict) -> dict:
    """The studies without the per-run force histories (for the printed summary)."""
    out = {}
    for name, study in res.items():
        if isinstance(study, dict):
            out[name] = {k: v for k, v in study.items() if k not in ("runs", "points")}
            if name == "references":
                out[name]["points"] = [
                    {k: p[k] for k in ("study", "aspect_ratio", "angle_deg", "strouhal",
                                       "computed", "deviation", "source")}
                    for p in study["points"]
                ]
    return out


def run_validation(*, seed: int = 0, studies: bool = False, full: bool = False,
                   workers: int | None = None, progress: bool = True, backend: str = "process",
                   records=None) -> dict:
    """Every check, and the requested Strouhal studies.

    ``backend`` and ``workers`` run the Strouhal runs (:func:`windnav.experiments.run_tasks`);
    ``records`` is :func:`strouhal_studies`'s record log, checked before the checks run (the
    checks take seconds and are not recorded).

    Returns
    -------
    dict
        ``summary`` (JSON-ready: the checks' maxima, per-direction uniform-flow errors, the
        Taylor-Green viscosities and the studies without their histories), ``runs`` (the
        studies' per-run records), and ``projection``, ``taylor_green``, ``strouhal`` (the
        raw results, for the figures of :mod:`windnav.experiments.flow_figures`).
    """
    from windnav.experiments.executor import BACKENDS, check_backend

    # a bad backend ran the checks, and was never used without studies (Python API audit,
    # fifty-eighth session); one not installed is refused before the checks when it will run
    if backend not in BACKENDS:
        raise ValueError(f"The 'backend' parameter of run_validation must be one of "
                         f"{BACKENDS}. Got {backend!r} instead.")
    if studies or full:
        check_backend(backend)
    open_records(records, seed=seed, studies=studies, full=full)
    proj = projection_study(rng=np.random.default_rng(seed))
    uni = uniform_study()
    tg = taylor_green_study()
    st = strouhal_studies(full, studies, workers, progress, seed, backend=backend,
                          records=records)
    summary = {
        "seed": seed,
        "max_div_dx_over_U": max(proj["max_div_dx_over_U"]),
        "max_fixed_face_error": max(proj["max_fixed_face_error"]),
        "uniform_flow_max_error": uni,
        "taylor_green_nu": {k: r["nu"] for k, r in tg.items()},
        **brief(st),
    }
    runs = {name: study["runs"] for name, study in st.items() if "runs" in study}
    return {"summary": summary, "runs": runs, "projection": proj, "taylor_green": tg,
            "strouhal": st}
