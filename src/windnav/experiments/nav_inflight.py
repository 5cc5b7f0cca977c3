"""The decoder in flight: what the onboard stack's wind is worth where the vehicle flies.

The decoder is trained with ``W_robot`` = the *mean* wind at the robot (its labels are mean
fields), and its offline studies perturb that mean with noise
(:func:`windnav.experiments.decoder_studies.noise_study`). In flight the onboard stack gives it
the Wind UKF's estimate, which tracks the *instantaneous* wind at the vehicle; in the urban
winds of the navigation benchmark the instantaneous wind can be far from the mean. This study
re-flies benchmark scenarios with the onboard-stack variant and, every ``every_s`` seconds of
each flight, scores against the flow's mean field in the decoder's window (the wind the
``-w`` planners are given, and the decoder's label):

- the decoder given the UKF's ``W_robot`` (what the planner got in flight), the mean wind at
  the vehicle (what it was trained with), and the true instantaneous wind (a perfect UKF);
- the Local baseline with each of those, and the Upstream baseline;

and reports the input errors, RMS over the samples: ``|w_ukf - w_mean|``, ``|w - w_mean|``
(the flow's unsteadiness at the vehicle) and ``|w_ukf - w|`` (the UKF's own error). With
``taus``, also the UKF's estimate averaged over time
(:func:`windnav.experiments.onboard.smooth_wind` with each time constant, the onboard stack's
``wrobot_tau_s``): its distance to the mean, and the decoder's and Local's errors given it.
Everything is grouped by inlet speed. The scans are drawn afresh at the sampled positions with
the decoder's training noise (the flight's own scans are not kept; their noise is independent
draws of the same law).

With ``records`` (a :class:`~windnav.experiments.results.RecordLog`, JSON lines), each wind's
flights and samples are appended as the wind finishes (the arrays exactly, as compressed
bytes), so an interrupted study resumes with the winds not yet done, and its result is the
uninterrupted study's.
"""

from __future__ import annotations

import base64
import zlib
from collections.abc import Mapping, Sequence

import numpy as np

from windnav._validate import generator, options_named, positive_float

__all__ = ["INFLIGHT_VARIANT", "MODELS", "RECORDS", "inflight_errors", "inflight_samples",
           "inflight_study", "records_header", "smoothed_key", "summarize_inflight"]

INFLIGHT_VARIANT = "ea-mppi-w-hat@outside=robot"
"""The variant re-flown: the onboard stack with ``W_robot`` outside the decoder's window."""

MODELS = ("decoder_ukf", "decoder_mean", "decoder_inst", "local_ukf", "local_mean",
          "local_inst", "upstream")
"""The predictions scored: model and the ``W_robot`` it is given (``ukf``: the onboard UKF's
horizontal estimate, ``mean``: the mean wind at the vehicle, ``inst``: the true instantaneous
wind at the vehicle)."""

INPUTS = {"ukf_vs_mean": ("ukf", "mean"), "inst_vs_mean": ("inst", "mean"),
          "ukf_vs_inst": ("ukf", "inst")}
"""The input errors reported, as pairs of winds at the vehicle."""


_SMOOTHED = "ukf_tau"

RECORDS = "nav_inflight.partial.jsonl"
"""The record log ``windnav nav-study inflight`` keeps in its output folder while it runs."""


def smoothed_key(tau_s: float) -> str:
    """The samples' key of the UKF's estimate averaged with time constant ``tau_s`` (s, finite,
    > 0, as :func:`inflight_samples` takes its ``taus``; -1 gave ``"ukf_tau-1"``: Python API
    audit, fifty-eighth session)."""
    return f"{_SMOOTHED}{positive_float(tau_s, 'tau_s', 'smoothed_key'):g}"


def inflight_samples(result, city, flow, offsets, *, every_s: float = 0.5,
                     settle_s: float = 2.0, rng=None, taus: Sequence[float] = ()) -> dict:
    """Decoder inputs and labels along one flown path.

    Parameters
    ----------
    result : NavigationResult
        A flight of an onboard-stack variant (its ``wind_estimate`` is used).
    city : City
        The map flown.
    flow : FlowSolution
        The wind flown in (its mean field gives the labels).
    offsets : array_like of shape (H,)
        The decoder's cell-centre offsets, m.
    every_s : float
        Time between samples, s (> 0).
    settle_s : float
        Samples begin this long after take-off (the UKF's start), s (>= 0).
    rng : numpy.random.Generator, int or None
        The scans' noise (None: fresh entropy).
    taus : sequence of float
        Time constants (s, > 0) of averages of the UKF's estimate to sample as well.

    Returns
    -------
    dict
        ``t`` (N,) s, ``position`` (N, 2) m, ``scans`` (N, 360) m, ``w_up`` (N, 2),
        ``ukf``, ``inst``, ``mean`` (N, 2) m/s (the winds at the vehicle), ``labels``
        (N, 2, H, H) m/s and ``free`` (N, H, H) of the mean field, ``speed`` (N,) inlet speed;
        for each of ``taus``, :func:`smoothed_key` (N, 2) m/s: the estimate averaged over the
        flight at every control step (:func:`windnav.experiments.onboard.smooth_wind`), sampled.
        Samples where the UKF's estimate is not finite are left out.
    """
    from windnav.experiments.onboard import smooth_wind
    from windnav.predict.dataset import N_RAYS, SCAN_MAX, SCAN_MIN, SCAN_NOISE, field_from_solution

    where = "inflight_samples"
    every = positive_float(every_s, "every_s", where)
    settle = positive_float(settle_s, "settle_s", where, allow_zero=True)
    if result.wind_estimate is None:
        raise ValueError(f"The 'result' parameter of {where} must be a flight of an onboard-"
                         f"stack variant (with a wind_estimate). Got one of "
                         f"{result.variant!r} instead.")
    t = np.asarray(result.t, dtype=np.float64)
    dt = float(t[1] - t[0]) if t.size > 1 else 1.0
    step = max(1, int(round(every / dt)))
    taus = [positive_float(tau, "taus", where) for tau in taus]
    k = np.arange(0, t.size, step)
    k = k[t[k] >= settle - 1e-9]
    estimate = np.asarray(result.wind_estimate, dtype=np.float64)[:, :2]
    ukf = estimate[k]
    k, ukf = k[np.isfinite(ukf).all(axis=1)], ukf[np.isfinite(ukf).all(axis=1)]
    smoothed = {smoothed_key(tau): smooth_wind(estimate, dt, tau)[k] for tau in taus}
    solution = getattr(flow, "solution", flow)
    field = field_from_solution(city, solution)
    pos = np.asarray(result.position, dtype=np.float64)[k, :2]
    gen = generator(rng, "rng", "inflight_samples")
    scans = city.lidar(pos, n_rays=N_RAYS, max_range=SCAN_MAX, noise_std=SCAN_NOISE, rng=gen)
    np.clip(scans, SCAN_MIN, SCAN_MAX, out=scans)
    labels, free = field.grid_values(pos, offsets)
    n = k.size
    return {"t": t[k], "position": pos, "scans": scans,
            "w_up": np.broadcast_to(field.w_up, (n, 2)).copy(), "ukf": ukf,
            "inst": np.asarray(result.wind, dtype=np.float64)[k, :2],
            "mean": field.interpolate(pos), "labels": labels, "free": free,
            "speed": np.full(n, field.inlet_speed), **smoothed}


def _concat(groups: Sequence[Mapping]) -> dict:
    return {key: np.concatenate([g[key] for g in groups]) for key in groups[0]}


def inflight_errors(samples: Mapping, decoder, compare: Mapping | None = None) -> dict:
    """The decoder's and the baselines' errors on in-flight samples, and the input errors.

    Parameters
    ----------
    samples : mapping
        :func:`inflight_samples`'s arrays (several flights concatenated), at least one sample.
    decoder : Decoder
        With ``offsets`` matching the labels and ``predict(scans, w_up, w_robot)``.
    compare : mapping of str to Decoder, optional
        Other decoders scored on the same samples (same ``offsets``), each given the three
        ``W_robot``: models ``NAME_ukf``, ``NAME_mean`` and ``NAME_inst``.

    Returns
    -------
    dict
        ``errors[model]``: :func:`windnav.predict.field_errors` for each of :data:`MODELS`
        (then the compared decoders', then ``decoder_KEY`` and ``local_KEY`` for each averaged
        estimate ``KEY`` of the samples, :func:`smoothed_key`); ``inputs[name]``: RMS of the
        horizontal difference, m/s, for each of :data:`INPUTS` (then ``KEY_vs_mean``);
        ``n_samples``.
    """
    from windnav.predict import LocalBaseline, UpstreamBaseline, field_errors

    where = "inflight_errors"
    n = int(np.asarray(samples["scans"]).shape[0])
    if n < 1:
        raise ValueError(f"The 'samples' parameter of {where} must hold at least one sample. "
                         "Got none.")
    offsets = np.asarray(decoder.offsets, dtype=np.float64)
    compare = _check_compare(compare, offsets, where)
    size = offsets.size
    spacing = float(offsets[1] - offsets[0]) if size > 1 else 1.0
    local = LocalBaseline(size, spacing)
    args = (samples["labels"], samples["free"], samples["speed"])
    errors = {}
    for name, model in {"decoder": decoder, "local": local, **compare}.items():
        for wind in ("ukf", "mean", "inst"):
            errors[f"{name}_{wind}"] = field_errors(
                model.predict(samples["scans"], samples["w_up"], samples[wind]), *args)
    errors["upstream"] = field_errors(
        UpstreamBaseline(size, spacing).predict(samples["scans"], samples["w_up"],
                                                samples["mean"]), *args)
    smoothed = sorted((key for key in samples if key.startswith(_SMOOTHED)),
                      key=lambda key: float(key[len(_SMOOTHED):]))
    for key in smoothed:
        for name, model in (("decoder", decoder), ("local", local)):
            errors[f"{name}_{key}"] = field_errors(
                model.predict(samples["scans"], samples["w_up"], samples[key]), *args)
    pairs = {**INPUTS, **{f"{key}_vs_mean": (key, "mean") for key in smoothed}}
    inputs = {name: float(np.sqrt(np.mean(np.sum((samples[a] - samples[b]) ** 2, axis=1))))
              for name, (a, b) in pairs.items()}
    order = [*MODELS, *(f"{name}_{wind}" for name in compare for wind in ("ukf", "mean", "inst")),
             *(f"{name}_{key}" for key in smoothed for name in ("decoder", "local"))]
    return {"errors": {m: errors[m] for m in order}, "inputs": inputs, "n_samples": n}


def _check_compare(compare, offsets, where: str) -> dict:
    """``compare`` as a dict, its names free of the built-in models' and its decoders' cells
    the same as ``offsets``."""
    compare = dict(compare or {})
    taken = {m.rsplit("_", 1)[0] for m in MODELS}
    for name, other in compare.items():
        if not isinstance(name, str) or not name.isidentifier() or name in taken:
            raise ValueError(f"The 'compare' parameter of {where} must name each decoder with "
                             f"an identifier other than {sorted(taken)}. Got {name!r} instead.")
        cells = np.asarray(getattr(other, "offsets", ()), dtype=np.float64)
        if cells.shape != offsets.shape or not np.allclose(cells, offsets):
            raise ValueError(f"The 'compare' parameter of {where} must hold decoders with the "
                             f"same cells as the flown one ({offsets.size} offsets from "
                             f"{offsets[0]:g} m). Got {name!r} with other cells.")
    return compare


def _decoder_name(variant: str) -> str:
    """The name (a key of :data:`~windnav.experiments.nav_benchmark.DECODERS`) of the decoder
    ``fly`` gives the onboard stack of ``variant``: the label's ``@decoder=``, or the benchmark's
    pinned :data:`~windnav.experiments.nav_benchmark.BENCHMARK_DECODER`."""
    from windnav.experiments import nav_benchmark

    name = nav_benchmark.parse_variant(variant)[1].get("decoder")
    return nav_benchmark.BENCHMARK_DECODER if name is None else str(name)


def _spec_decoder(spec, variant: str):
    """The suite's own decoder object (``spec.navigate_options["decoder"]``, e.g. ``windnav
    nav-study inflight --decoder FILE``'s) when ``fly`` gives it to the onboard stack of
    ``variant`` (a label without ``@decoder=`` or ``@views=``); else None."""
    from windnav.experiments import nav_benchmark

    options = nav_benchmark.parse_variant(variant)[1]
    own = (getattr(spec, "navigate_options", None) or {}).get("decoder")
    if own is None or "decoder" in options or "decoder_views" in options:
        return None
    return own


def _decoder(variant: str, spec=None):
    """The decoder ``fly`` gives the onboard stack of ``variant`` in the suite ``spec``: the
    suite's own decoder object (:func:`_spec_decoder`), else :func:`_decoder_name`'s, with the
    label's ``@views=``."""
    from windnav.experiments import nav_benchmark

    own = None if spec is None else _spec_decoder(spec, variant)
    if own is not None:
        return own
    return nav_benchmark.flight_decoder(nav_benchmark.parse_variant(variant)[1])


def _decoder_identity(variant: str, spec=None) -> dict:
    """The flown decoder's identity: its name, file and the first 16 hex digits of the file's
    SHA-256 (the one :func:`~windnav.experiments.nav_benchmark.benchmark_decoder` checks the
    file against before it loads it), and its turned views (``rotations_deg``, deg) when the
    label gives ``@views=``; the suite's own decoder object (:func:`_spec_decoder`) by its
    fingerprint (``{"name": "suite", "fingerprint": ...}``)."""
    from windnav.experiments.nav_benchmark import DECODERS

    own = None if spec is None else _spec_decoder(spec, variant)
    if own is not None:
        return {"name": "suite", "fingerprint": own.fingerprint()}
    name = _decoder_name(variant)
    decoder = _decoder(variant)  # an unknown name or a file not of its date: its error
    file, sha = DECODERS[name]
    views = getattr(decoder, "rotations_deg", None)
    return {"name": name, "file": file, "sha256": sha[:16],
            **({} if views is None else {"rotations_deg": list(views)})}


def _fly_wind(task):
    """Worker: one wind of the suite, each of its scenarios flown with the onboard stack and
    sampled (:func:`inflight_samples`)."""
    spec, scenario_ids, variant, every_s, taus = task
    from windnav.experiments.nav_benchmark import fly, suite_flow
    from windnav.experiments.nav_suite import parse_scenario_id, suite_map

    scenarios = [parse_scenario_id(spec, sid) for sid in scenario_ids]
    first = scenarios[0]
    city = suite_map(spec, first.map_index)
    flow = suite_flow(spec, city, first.speed, first.direction_deg)
    offsets = _decoder(variant, spec).offsets
    out = []
    for sc in scenarios:
        res = fly(spec, sc, variant, city=city, flow=flow)
        samples = inflight_samples(res, city, flow, offsets, every_s=every_s,
                                   rng=np.random.default_rng([sc.seed, 7]), taus=taus)
        samples = {k: (v.astype(np.float32) if k in ("scans", "labels") else v)
                   for k, v in samples.items()}
        out.append({"scenario_id": sc.scenario_id, "speed": sc.speed, "outcome": res.outcome,
                    "time_s": res.time_s, "samples": samples})
    return out


def _suite(spec, where: str):
    """``spec`` as a :class:`~windnav.experiments.nav_suite.SuiteSpec` (a name of
    :data:`~windnav.experiments.nav_suite.SUITES` looked up), or a ValueError naming ``spec``
    of ``where``."""
    from windnav.experiments.nav_suite import check_suite_spec

    with options_named({"'suite' parameter of get_suite": f"'spec' parameter of {where}"}):
        return check_suite_spec(spec, where)


def records_header(spec, variant: str, every_s: float, taus: Sequence[float]) -> dict:
    """The header of a study's record log: what its flights and samples depend on (the suite,
    the variant flown and the decoder its onboard stack flies, the sampling; not the scenarios,
    each wind's recorded with its flights, nor the compared decoders, which only score the
    samples). The decoder is named by file and SHA-256 (:func:`_decoder_identity`), so a log
    flown before the benchmark's pinned decoder changed is another study's. ``spec``: a
    :class:`~windnav.experiments.nav_suite.SuiteSpec` or a name of
    :data:`~windnav.experiments.nav_suite.SUITES`, as :func:`inflight_study` takes it (a name
    raised an AttributeError; Python API audit, fifty-eighth session)."""
    spec = _suite(spec, "records_header")
    return {"study": "windnav.experiments.nav_inflight", "suite": spec.name, "seed": spec.seed,
            "settings_hash": spec.settings_hash(), "variant": variant,
            "decoder": _decoder_identity(variant, spec), "every_s": every_s,
            "taus": list(taus)}


def _packed(a: np.ndarray) -> dict:
    """An array as JSON: dtype, shape and its bytes (zlib, base64), to read back exactly."""
    a = np.ascontiguousarray(a)
    return {"dtype": a.dtype.str, "shape": list(a.shape),
            "data": base64.b64encode(zlib.compress(a.tobytes())).decode("ascii")}


def _unpacked(d: Mapping) -> np.ndarray:
    raw = zlib.decompress(base64.b64decode(d["data"], validate=True))
    return np.frombuffer(raw, dtype=np.dtype(d["dtype"])).reshape(d["shape"]).copy()


def _flight_record(flight: Mapping) -> dict:
    return {**{k: flight[k] for k in ("scenario_id", "speed", "outcome", "time_s")},
            "samples": {k: _packed(v) for k, v in flight["samples"].items()}}


def _recorded_winds(log, groups: Sequence[Sequence[str]]) -> dict:
    """The flights of each of ``groups`` (one wind's scenario ids) that the record log ``log``
    holds for exactly that group (the last record of it), by the group as a tuple."""
    wanted = {tuple(g) for g in groups}
    found = {}
    for rec in log.load():
        ids = tuple(rec.get("scenario_ids") or ()) if isinstance(rec, dict) else ()
        if ids in wanted:
            found[ids] = rec["flights"]
    try:
        return {ids: [{**{k: f[k] for k in ("scenario_id", "speed", "outcome", "time_s")},
                       "samples": {k: _unpacked(v) for k, v in f["samples"].items()}}
                      for f in flights]
                for ids, flights in found.items()}
    except (KeyError, TypeError, ValueError, zlib.error) as exc:
        raise ValueError(f"The record log {str(log.path)!r} holds a wind that cannot be read "
                         f"({type(exc).__name__}: {exc}); move it away, or start over.") from None


def inflight_study(spec, scenario_ids: Sequence[str], *, variant: str = INFLIGHT_VARIANT,
                   every_s: float = 0.5, compare: Mapping | None = None,
                   taus: Sequence[float] = (), executor: str = "process",
                   workers: int | None = None, progress: bool = True,
                   records=None) -> dict:
    """Re-fly ``scenario_ids`` with the onboard stack and score its wind along the paths.

    Parameters
    ----------
    spec : SuiteSpec
        The suite (a :data:`~windnav.experiments.nav_suite.SUITES` name and seed); a
        ``decoder`` among its ``navigate_options`` is the one flown and scored for a label
        without ``@decoder=`` (``windnav nav-study inflight --decoder FILE``).
    scenario_ids : sequence of str
        Scenarios of ``spec``, at least one.
    variant : str
        An onboard-stack label (``ea-mppi-w-hat`` with its parameters).
    every_s : float
        Time between samples along each flight, s.
    compare : mapping of str to Decoder, optional
        Other decoders scored on the same samples (:func:`inflight_errors`); they do not fly.
    taus : sequence of float
        Time constants, s (> 0): the decoder and Local are also scored given the UKF's
        estimate averaged with each (:func:`inflight_samples`); nothing flies differently.
    executor, workers, progress
        :func:`windnav.experiments.executor.run_tasks`.
    records : str or path-like, optional
        A record log (:class:`windnav.experiments.results.RecordLog`, header
        :func:`records_header`): each wind's flights, with their samples, are appended as soon
        as the wind finishes, so an interrupted study loses only the winds in flight. A wind
        recorded there (the same scenarios) is not flown again (a failed wind is); the result
        is the uninterrupted study's.

    Returns
    -------
    dict
        ``by_speed[speed]``: :func:`inflight_errors` of that inlet speed's samples, with
        ``flights`` and ``failed`` (non-success outcomes); ``all``: the same over every
        sample; ``flights``: per scenario its outcome, time and sample count; ``variant``,
        ``every_s``, ``taus``, ``compare`` (the compared decoders' names), ``errors`` (harness
        errors, scenario id to message; a wind that fails fails all its scenarios).

    Raises
    ------
    RecordMismatchError
        When ``records`` holds the records of another study (checked before any flight).
    ValueError
        Naming the argument: a variant that is not an onboard-stack variant, a bad
        ``every_s``, ``taus`` or ``compare``.
    """
    from windnav.experiments.executor import run_tasks
    from windnav.experiments.nav_benchmark import check_scenario_ids, parse_variant
    from windnav.experiments.nav_suite import parse_scenario_id
    from windnav.experiments.results import RecordLog, say
    from windnav.plan import VARIANTS

    where = "inflight_study"
    spec = _suite(spec, where)
    # (parse_variant's message named 'variants'; Python API audit, fifty-eighth session)
    with options_named({f"'variants' parameter of {where}": f"'variant' parameter of {where}"}):
        base, options = parse_variant(variant, where)
    if VARIANTS[base].wind_source != "onboard":
        raise ValueError(f"The 'variant' parameter of {where} must be an onboard-stack variant "
                         f"(ea-mppi-w-hat, with parameters). Got {variant!r} instead.")
    ids = list(scenario_ids)
    check_scenario_ids(spec, ids, where)
    every = positive_float(every_s, "every_s", where)
    taus = tuple(sorted({positive_float(tau, "taus", where) for tau in taus}))
    decoder = _decoder(variant, spec)
    compare = _check_compare(compare, np.asarray(decoder.offsets, dtype=np.float64), where)
    winds = {}
    for sid in ids:
        sc = parse_scenario_id(spec, sid)
        winds.setdefault((sc.map_index, sc.wind_index), []).append(sid)
    log = None if records is None else RecordLog(records, records_header(spec, variant, every,
                                                                          taus))
    done = {} if log is None else _recorded_winds(log, list(winds.values()))
    flown = [f for group in winds.values() for f in done.get(tuple(group), ())]
    tasks = [(spec, group, variant, every, taus) for group in winds.values()
             if tuple(group) not in done]
    if len(tasks) < len(winds):
        say(progress, f"resuming: {len(winds) - len(tasks)}/{len(winds)} winds already flown, "
                      f"in {log.path}")
    errors = {}
    for res in run_tasks(_fly_wind, tasks, executor, workers=workers, progress=progress,
                         desc="in-flight decoder (winds)"):
        if res.error is not None:
            errors.update({sid: str(res.error) for sid in res.task[1]})
        else:
            if log is not None:
                log.append({"scenario_ids": list(res.task[1]),
                            "flights": [_flight_record(f) for f in res.value]})
            flown.extend(res.value)
    flown.sort(key=lambda f: ids.index(f["scenario_id"]))
    by_speed = {}
    for speed in sorted({f["speed"] for f in flown}):
        group = [f for f in flown if f["speed"] == speed and f["samples"]["t"].size]
        if not group:
            continue
        by_speed[speed] = {**inflight_errors(_concat([f["samples"] for f in group]), decoder,
                                             compare),
                           "flights": len(group),
                           "failed": sum(f["outcome"] != "success" for f in group)}
    usable = [f["samples"] for f in flown if f["samples"]["t"].size]
    return {"variant": variant, "every_s": every, "taus": list(taus),
            "by_speed": by_speed,
            "all": inflight_errors(_concat(usable), decoder, compare) if usable else None,
            "compare": sorted(compare),
            "flights": {f["scenario_id"]: {"speed": f["speed"], "outcome": f["outcome"],
                                           "time_s": f["time_s"],
                                           "samples": int(f["samples"]["t"].size)}
                        for f in flown},
            "errors": errors}


def summarize_inflight(result: Mapping) -> list[str]:
    """Markdown table lines of :func:`inflight_study`'s result: per inlet speed the input
    errors and the speed / direction errors of each model."""
    lines = ["| inlet (m/s) | flights (failed) | samples | |w_ukf - w_mean| | |w - w_mean| "
             "| |w_ukf - w| | decoder, UKF | decoder, mean | decoder, inst. | Local, UKF "
             "| Local, mean | Upstream |",
             "|---" * 12 + "|"]
    rows = [(f"{s:g}", r) for s, r in result["by_speed"].items()]
    if result.get("all"):
        rows.append(("all", {**result["all"],
                             "flights": sum(r["flights"] for r in result["by_speed"].values()),
                             "failed": sum(r["failed"] for r in result["by_speed"].values())}))
    for label, r in rows:
        e, i = r["errors"], r["inputs"]
        cells = " | ".join(_cell(e[m]) for m in ("decoder_ukf", "decoder_mean", "decoder_inst",
                                                  "local_ukf", "local_mean", "upstream"))
        lines.append(f"| {label} | {r['flights']} ({r['failed']}) | {r['n_samples']} | "
                     f"{i['ukf_vs_mean']:.2f} | {i['inst_vs_mean']:.2f} | "
                     f"{i['ukf_vs_inst']:.2f} | {cells} |")
    taus = result.get("taus") or []
    if taus:
        keys = [smoothed_key(tau) for tau in taus]
        lines += ["", "| inlet (m/s) | " + " | ".join(
            f"tau = {tau:g} s: |w_avg - w_mean|, decoder, Local" for tau in [0.0, *taus])
            + " |", "|---" * (2 + len(taus)) + "|"]
        for label, r in rows:
            e, i = r["errors"], r["inputs"]
            lines.append(f"| {label} | " + " | ".join(
                f"{i[f'{k}_vs_mean']:.2f}, {_cell(e[f'decoder_{k}'])}, {_cell(e[f'local_{k}'])}"
                for k in ["ukf", *keys]) + " |")
    names = result.get("compare") or []
    if names:
        lines += ["", "| inlet (m/s) | " + " | ".join(
            f"{n}, {w}" for n in ["decoder", *names] for w in ("UKF", "mean", "inst."))
            + " |", "|---" * (1 + 3 * (1 + len(names))) + "|"]
        for label, r in rows:
            e = r["errors"]
            lines.append(f"| {label} | " + " | ".join(
                _cell(e[f"{n}_{w}"]) for n in ["decoder", *names] for w in ("ukf", "mean", "inst"))
                + " |")
    return lines


def _cell(errors: Mapping) -> str:
    """``speed / direction`` error of one model, as the tables print it (m/s / deg)."""
    return f"{errors['speed_error']:.2f} / {errors['direction_error_deg']:.1f}"
