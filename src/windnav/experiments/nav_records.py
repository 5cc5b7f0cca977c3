"""The navigation benchmark's store of flight records, and its ablation table.

The store (:class:`NavStore`) is a folder:

* ``manifest.json``: the suite (``suite``, ``seed``, ``settings_hash`` and the full
  ``settings`` of :class:`~windnav.experiments.nav_suite.SuiteSpec`). A store answers only to the
  suite that created it: any other gives :class:`SuiteMismatchError`. It may also declare the
  arithmetic of the records that name none (:data:`UNNAMED_ARITHMETIC`,
  :func:`record_arithmetic`).
* ``records.jsonl``: one JSON object per finished flight, appended as each flight ends (by the
  worker that flew it, under an exclusive ``flock`` so that parallel workers never interleave),
  flushed and synced. A kill loses at most the line being written: a last line without its
  newline is *torn*, ignored on reading and cut off before the next append. Any other line
  that is not a record is corrupt and gives :class:`CorruptRecordError` naming the file and the
  line. When a flight was recorded twice (``--retry-errors``), its last record counts.

The table (:func:`benchmark_table`, :func:`render_table`) follows the thesis's ablation table:
per variant, the mean +- standard deviation over *successful* flights of the energy from the
airspeed power curve, the rotor energy, the mean commanded acceleration, the time to goal and
the distance flown, with 95 % confidence intervals of the means (Student t); the failure rate
with its breakdown (collision, hover, left_map, timeout) and a Wilson 95 % interval. Against the
reference (MPPI), for both energies:

* the *table ratio* ``1 - mean(E_variant) / mean(E_ref)``, each mean over that variant's
  successful flights (95 % percentile bootstrap interval, resampling the suite's winds with
  both variants' flights of each: both flew the same scenarios, and a wind's four pairs share
  its field; ``docs/navigation.md``, "How far to trust the intervals");
* the *paired reduction*: the mean over scenarios where neither failed of
  ``1 - E_variant / E_ref`` (Student t interval), also per inlet speed.

Flights whose harness failed (``outcome == "error"``, a traceback in ``error``) are counted
apart and left out of every rate.
"""

from __future__ import annotations

import contextlib
import json
import math
import os
import zlib
from collections import Counter
from collections.abc import Iterable, Iterator, Mapping, Sequence
from pathlib import Path

import numpy as np

from windnav.experiments.arithmetic import FIELDS
from windnav.experiments.intervals import (
    COVERAGE_NOTE,
    COVERED_BOOTSTRAP_CLUSTERS,
    MIN_BOOTSTRAP_CLUSTERS,
    pooled_ratio,
    pooled_ratio_interval,
)

__all__ = [
    "FAILURES",
    "UNNAMED_ARITHMETIC",
    "CorruptRecordError",
    "NavStore",
    "StoreBusyError",
    "SuiteMismatchError",
    "benchmark_table",
    "latest_records",
    "paired_pace",
    "record_arithmetic",
    "records_by_variant",
    "render_table",
]

FAILURES = ("collision", "hover", "left_map", "timeout")
"""Flight outcomes that count as failures (``navigate``'s outcomes other than success)."""

ERROR = "error"
"""Outcome of a flight whose harness raised (its traceback is in the record's ``error``)."""

METRICS = (
    ("energy_kJ", "energy_J", 1e-3),
    ("rotor_energy_kJ", "rotor_energy_J", 1e-3),
    ("mean_cmd_accel", "mean_cmd_accel", 1.0),
    ("time_s", "time_s", 1.0),
    ("distance_m", "distance_m", 1.0),
)
"""Table metrics: (name in the table, record field, scale)."""

ENERGIES = ("energy_J", "rotor_energy_J")

MIN_BOOTSTRAP_WINDS = MIN_BOOTSTRAP_CLUSTERS
"""Fewest winds the table ratio's bootstrap interval is given for. Every resample lies between
the ratios of the winds taken alone (where the two variants' successes per wind are alike),
so the interval is at most their range, and the range of
``G`` winds covers the middle of their distribution with probability ``1 - 2 ** (1 - G)``:
under 95 % below 6 winds (50 % for 2, 75 % for 3). With 2 winds the "95 %" interval covered
the truth in 26 % of simulated suites, with 3 in 46 % (audit); ``ci95`` is None below it, with
``ci95_note`` saying why. Six winds are needed, not enough: see :data:`COVERED_BOOTSTRAP_WINDS`."""

COVERED_BOOTSTRAP_WINDS = COVERED_BOOTSTRAP_CLUSTERS
"""Fewest winds at which the table ratio's interval covered the truth about as often as it says:
90-94.5 % of simulated suites with 64 winds (coverage audit, ``docs/navigation.md``), but 71 %
with 6 and 82 % with 16 (statistics audit, thirty-ninth session). Below it the interval is
given with a ``ci95_note`` calling it approximate (the thesis suite has 256 winds; maps 0-3 of
it, 64)."""

MANIFEST = "manifest.json"
RECORDS = "records.jsonl"
CLAIMS = ".claims"

UNRECORDED_CODE = "unrecorded"
"""The table's name (``codes``) for the code of records that name none (``code``: flown before
2026-12-06, :data:`windnav.experiments.nav_benchmark.CODE_FIELDS`)."""

UNNAMED_ARITHMETIC = "unnamed_records_arithmetic"
"""Manifest key: the arithmetic (``blas_kernel``, ``numpy_simd``, as
:func:`windnav.experiments.arithmetic.arithmetic` names them, and an optional ``found``: how it
was found) of the store's records that name none, i.e. that were flown before records named
their arithmetic (2026-12-02). Not known when they were flown: found afterwards by auditing
the store (``windnav benchmark-nav --check`` under a candidate arithmetic), and declared so
that replays and checks restart under it (``docs/navigation.md``)."""


def record_arithmetic(record: Mapping, manifest: Mapping | None = None) -> dict:
    """The arithmetic ``record`` was flown under, as far as is known.

    Parameters
    ----------
    record : mapping
        A flight record.
    manifest : mapping, optional
        Its store's manifest.

    Returns
    -------
    dict
        The record's own ``blas_kernel`` and ``numpy_simd`` when it names them (either one);
        for a record that names neither, the manifest's :data:`UNNAMED_ARITHMETIC` with
        ``declared`` True; else ``{}`` (not known).

    Raises
    ------
    SuiteMismatchError
        When the manifest's declaration is not a table of the two fields as strings.
    """
    own = {k: record[k] for k in FIELDS if k in record}
    declared = (manifest or {}).get(UNNAMED_ARITHMETIC)
    if own or declared is None:
        return own
    if not (isinstance(declared, Mapping)
            and all(isinstance(declared.get(k), str) and declared[k] for k in FIELDS)):
        raise SuiteMismatchError(
            f"The store manifest's {UNNAMED_ARITHMETIC!r} must be a table with "
            f"{' and '.join(FIELDS)} as strings, e.g. {{'blas_kernel': 'OpenBLAS Haswell', "
            f"'numpy_simd': 'X86_V3'}}. Got {declared!r} instead.")
    return {**{k: declared[k] for k in FIELDS}, "declared": True}


class SuiteMismatchError(ValueError):
    """A store that holds another suite (name, seed or settings), or is not a store."""


class CorruptRecordError(ValueError):
    """A line of the record file that is not a flight record (and is not a torn last line)."""


class StoreBusyError(RuntimeError):
    """Another run is flying some of the same (variant, map) pairs into the store."""


# ------------------------------------------------------------------------------- the store


def json_lines(path: Path) -> Iterator[tuple[int, bytes, object]]:
    """``(line number, raw line, parsed JSON or None)`` of each complete, non-blank line of an
    append-only record file (1-based; None where the line is not JSON). The last item after the
    last newline is skipped: empty, or a line torn by a kill mid-write (cut off before the next
    append, :func:`_cut_torn_tail`)."""
    for i, raw in enumerate(path.read_bytes().split(b"\n")[:-1], start=1):
        if not raw.strip():
            continue
        try:
            rec = json.loads(raw)
        except (json.JSONDecodeError, UnicodeDecodeError):
            rec = None
        yield i, raw, rec


class NavStore:
    """The folder of one suite's flight records (see the module docstring).

    Parameters
    ----------
    path : str or path-like
        The store folder.
    spec : SuiteSpec
        The suite it holds.
    create : bool
        Create the folder and its manifest when missing; otherwise a missing store is an error.

    Raises
    ------
    SuiteMismatchError
        When the folder's manifest names another suite, seed or settings, or the folder holds a
        record file without a manifest.
    """

    def __init__(self, path, spec, *, create: bool = True):
        self.path = Path(path)
        self.spec = spec
        self.records_path = self.path / RECORDS
        self.manifest = {"suite": spec.name, "seed": spec.seed,
                         "settings_hash": spec.settings_hash(), "settings": spec.settings()}
        man = self.path / MANIFEST
        if man.exists():
            self._check(man)
        elif self.records_path.exists():
            raise SuiteMismatchError(
                f"The store {str(self.path)!r} holds {RECORDS} but no {MANIFEST}, so its suite "
                "is unknown; choose another folder, or restore the manifest.")
        elif not create:
            raise SuiteMismatchError(
                f"The store {str(self.path)!r} holds no benchmark records ({MANIFEST} is "
                "missing); run the suite into it first.")
        else:
            from windnav import __version__
            from windnav.experiments.results import write_json

            self.path.mkdir(parents=True, exist_ok=True)
            tmp = man.with_name(f".{MANIFEST}.{os.getpid()}.tmp")
            write_json({**self.manifest, "windnav_version": __version__}, tmp)
            try:  # created only if absent: of two runs creating one store at once (the
                os.link(tmp, man)  # second's seed won, silently; concurrency audit), the
            except FileExistsError:  # other reads the winner's manifest, and is refused
                self._check(man)  # when its suite differs
            except OSError:  # a file system without hard links: as before, last one wins
                os.replace(tmp, man)
            finally:
                tmp.unlink(missing_ok=True)

    def _check(self, man: Path) -> None:
        try:
            found = json.loads(man.read_text())
            got = {k: found[k] for k in ("suite", "seed", "settings_hash")}
        except (json.JSONDecodeError, KeyError, TypeError, OSError):
            raise SuiteMismatchError(
                f"The store {str(self.path)!r} has a {MANIFEST} that is not a benchmark "
                "manifest; choose another folder.") from None
        want = {k: self.manifest[k] for k in ("suite", "seed", "settings_hash")}
        if got != want:
            diff = ", ".join(f"{k} {got[k]!r} (asked: {want[k]!r})" for k in want
                             if got[k] != want[k])
            raise SuiteMismatchError(
                f"The store {str(self.path)!r} holds another suite: {diff}. Use another "
                "folder for this suite, or run the store's own suite and seed.")

    # ----------------------------------------------------------------------------- reading

    def load(self) -> list[dict]:
        """Every record in the file, in order ([] when there is none).

        Raises
        ------
        CorruptRecordError
            Naming the file and the (1-based) line of the first line that is not a record, or
            not one of the suite's flights (a scenario it does not fly, an unknown outcome, a
            success without a finite energy); a torn last line (no newline) is ignored.
        SuiteMismatchError
            When a record is of another suite (its scenario id names another).
        """
        if not self.records_path.exists():
            return []
        out = []
        prefix = f"{self.spec.name}/"
        for i, raw, rec in json_lines(self.records_path):
            ok = (isinstance(rec, dict) and isinstance(rec.get("scenario_id"), str)
                  and isinstance(rec.get("variant"), str) and "outcome" in rec)
            if not ok:
                text = raw[:80].decode("utf-8", "replace")
                raise CorruptRecordError(
                    f"The record file {str(self.records_path)!r} has a corrupt record at line "
                    f"{i}: {text!r}. Delete or repair that line; the other lines keep their "
                    "finished flights.")
            if not rec["scenario_id"].startswith(prefix):
                raise SuiteMismatchError(
                    f"The record file {str(self.records_path)!r} has at line {i} a record of "
                    f"another suite ({rec['scenario_id']!r}, expected {prefix}...).")
            problem = self._record_problem(rec)
            if problem:  # a map the suite does not fly counted as a fifth flight of a table
                raise CorruptRecordError(  # of four, "banana" as a failure (files audit)
                    f"The record file {str(self.records_path)!r} has at line {i} a record "
                    f"that is not one of this suite's flights: {problem}. Delete or repair "
                    "that line; the other lines keep their finished flights.")
            out.append(rec)
        return out

    def _record_problem(self, rec: Mapping) -> str | None:
        """What makes ``rec`` no flight of this store's suite (None when nothing does): an id
        the suite does not fly, an unknown outcome, a success without a finite energy."""
        spec = self.spec
        if not spec.flies(rec["scenario_id"]):
            return (f"the scenario {rec['scenario_id']!r} is not in the suite (maps "
                    f"{list(spec.maps)}, winds {list(spec.winds)}, pairs {list(spec.pairs)})")
        outcome = rec["outcome"]
        if outcome not in ("success", *FAILURES, ERROR):
            return f"the outcome {outcome!r} is none of {['success', *FAILURES, ERROR]}"
        energy = rec.get("energy_J")
        if outcome == "success" and (isinstance(energy, bool) or not isinstance(
                energy, (int, float)) or not math.isfinite(energy)):
            return f"a success whose energy_J is {energy!r}, not a finite number"
        return None

    def latest(self) -> dict[tuple[str, str], dict]:
        """The last record of each ``(scenario_id, variant)``."""
        return latest_records(self.load())

    # ----------------------------------------------------------------------------- writing

    @contextlib.contextmanager
    def claim(self, pairs: Iterable[tuple[str, int]]):
        """Hold an exclusive claim on each ``(variant, map_index)`` of ``pairs`` until the block
        ends, so that two runs never fly the same flights into this store.

        Each pair is an ``flock`` on a file of ``.claims/`` in the store, which the kernel
        releases when the process ends, however it ends (no stale claim after a kill). The file
        names the holder (process id, host, start time, command line).

        Raises
        ------
        StoreBusyError
            When another process holds any of the pairs; none is then held by this one.
        """
        import hashlib

        from windnav.experiments.results import try_lock

        held = []
        try:
            for variant, m in sorted(set(pairs)):
                tag = hashlib.sha1(variant.encode()).hexdigest()[:12]  # any variant key
                f, holder = try_lock(self.path / CLAIMS / f"m{int(m):03d}-{tag}.lock")
                if f is None:
                    raise StoreBusyError(
                        f"Another run is flying variant {variant!r} on map {m} into the store "
                        f"{str(self.path)!r} ({holder}). Wait for it to end and run this "
                        "command again (every recorded flight is kept and skipped), or fly "
                        "other variants or maps.")
                held.append(f)
            yield
        finally:
            for f in held:
                f.close()  # releases its flock

    @contextlib.contextmanager
    def _locked(self):
        import fcntl  # POSIX; the store is written by processes of one machine

        self.path.mkdir(parents=True, exist_ok=True)
        with open(self.records_path, "a+b") as f:
            fcntl.flock(f.fileno(), fcntl.LOCK_EX)
            try:
                yield f
            finally:
                fcntl.flock(f.fileno(), fcntl.LOCK_UN)

    def append(self, record: Mapping) -> None:
        """Append one record (made JSON-ready: non-finite numbers become null), durably.

        A torn last line left by an earlier kill is cut off first.
        """
        from windnav.experiments.results import json_ready

        line = (json.dumps(json_ready(record), allow_nan=False) + "\n").encode()
        with self._locked() as f:
            _cut_torn_tail(f)
            f.seek(0, os.SEEK_END)
            f.write(line)
            f.flush()
            os.fsync(f.fileno())


def _cut_torn_tail(f) -> None:
    """Truncate an open (binary, read/write) file after its last newline."""
    size = f.seek(0, os.SEEK_END)
    if size == 0:
        return
    f.seek(size - 1)
    if f.read(1) == b"\n":
        return
    pos, block = size, 4096
    while pos > 0:
        start = max(0, pos - block)
        f.seek(start)
        chunk = f.read(pos - start)
        k = chunk.rfind(b"\n")
        if k >= 0:
            f.truncate(start + k + 1)
            return
        pos = start
    f.truncate(0)


# ------------------------------------------------------------------------------- statistics


def _num(value) -> float:
    return float("nan") if value is None else float(value)


def _t_quantile(confidence: float, dof: int) -> float:
    from scipy.stats import t

    return float(t.ppf(0.5 + 0.5 * confidence, dof))


def _describe(values, confidence: float) -> dict:
    """mean, std (ddof 1), n, and the Student-t interval of the mean; no interval (None, and
    ``ci95_note``) when every value is the same: a t interval of width 0 there read as
    certainty (two identical flights gave "0.0 % [0.0, 0.0] %"; statistics audit)."""
    v = np.asarray([x for x in values if math.isfinite(x)], dtype=np.float64)
    n = int(v.size)
    if n == 0:
        return {"mean": None, "std": None, "n": 0, "ci95": None}  # std: None below 2
    mean = float(v.mean())
    std = float(v.std(ddof=1)) if n > 1 else None
    ci = None
    if n > 1 and np.all(v == v[0]):
        return {"mean": mean, "std": std, "n": n, "ci95": None,
                "ci95_note": f"all {n} values are equal: no spread to give an interval from"}
    if n > 1:
        half = _t_quantile(confidence, n - 1) * std / math.sqrt(n)
        ci = [mean - half, mean + half]
    return {"mean": mean, "std": std, "n": n, "ci95": ci}


def _wilson(k: int, n: int, confidence: float) -> list[float] | None:
    """Wilson score interval (no continuity correction) of a proportion ``k / n``, in percent
    (SciPy's ``binomtest(...).proportion_ci(method="wilson")``)."""
    if n == 0:
        return None
    from scipy.stats import binomtest

    ci = binomtest(int(k), int(n)).proportion_ci(confidence_level=confidence, method="wilson")
    return [100.0 * float(ci.low), 100.0 * float(ci.high)]


def _table_ratio(mine: Mapping, ref: Mapping, field: str, confidence, n_boot, rng) -> dict:
    """``1 - mean(E) / mean(E_ref)`` over each variant's successful flights, with a percentile
    bootstrap that resamples the suite's winds (:func:`wind_of`: the four pairs of a map and
    wind) and takes both variants' flights of each drawn wind. Both variants flew the same
    scenarios, and the pairs of a wind share its field; resampling each variant's flights on
    their own (until 2026-12-05) ignored both and gave intervals 2.7-7.9 x too wide, covering
    the truth 100 % of the time (coverage audit)."""
    from windnav.experiments.nav_suite import wind_of

    # the winds in sorted order and each wind's flights by scenario id: the resamples and the
    # sums are a function of the records, not of the order a store's workers appended them
    # in (the intervals moved with it, e.g. 0.0158 / 0.0132 / 0.0145 for one lower bound;
    # metamorphic audit, 2026-12-05)
    groups = {w: g for g, w in enumerate(sorted({wind_of(sid) for recs in (mine, ref)
                                                 for sid in recs}))}
    sums = [[0.0, 0, 0.0, 0] for _ in groups]  # per wind: [energy sum, successes] of the
    for k, recs in enumerate((mine, ref)):     # variant, then of the reference
        for sid in sorted(recs):
            r = recs[sid]
            g = groups[wind_of(sid)]
            e = _num(r.get(field))
            if r["outcome"] == "success" and math.isfinite(e):
                sums[g][2 * k] += e
                sums[g][2 * k + 1] += 1
    s = np.array(sums, dtype=np.float64).reshape(-1, 4)
    nv, nr = int(s[:, 1].sum()), int(s[:, 3].sum())
    # the winds both flew in: a variant flown on a subset against the whole reference has no
    # more support than its own winds (a sweep's 32 of the suite's 256 were judged as 256;
    # review of the thirty-ninth session)
    both = len({wind_of(sid) for sid in mine} & {wind_of(sid) for sid in ref})
    out = {"value": None, "ci95": None, "n_variant": nv, "n_reference": nr,
           "winds": len(groups), "winds_both": both}
    if nv == 0 or nr == 0 or not s[:, 2].sum() > 0:
        return out
    out["value"] = pooled_ratio(s)
    if nv > 1 and nr > 1 and n_boot > 0 and both < MIN_BOOTSTRAP_WINDS:
        out["ci95_note"] = (f"no interval: the two variants flew in {both} common wind"
                            f"{'s' if both != 1 else ''}, and a bootstrap over the "
                            f"winds needs at least {MIN_BOOTSTRAP_WINDS} (below, its interval "
                            "is about the range of the winds' own ratios and covers the truth "
                            "far less than 95 % of the time)")
    elif nv > 1 and nr > 1 and n_boot > 0:
        if both < COVERED_BOOTSTRAP_WINDS:
            out["ci95_note"] = f"approximate: from {both} common winds, where {COVERAGE_NOTE}"
        out["ci95"] = pooled_ratio_interval(s, n_boot=n_boot, rng=rng, confidence=confidence)
    return out


def _energies(recs, field):
    return [_num(r.get(field)) for r in recs if r["outcome"] == "success"
            and math.isfinite(_num(r.get(field)))]


def latest_records(records: Iterable[Mapping]) -> dict[tuple[str, str], Mapping]:
    """The last of the ``records`` of each ``(scenario_id, variant)`` (a flight recorded again,
    e.g. by ``--retry-errors``, counts once, as its latest record)."""
    return {(r["scenario_id"], r["variant"]): r for r in records}


def records_by_variant(records: Iterable[Mapping]) -> dict[str, dict[str, Mapping]]:
    """``variant -> {scenario_id -> record}`` of the latest records (:func:`latest_records`)."""
    out: dict[str, dict[str, Mapping]] = {}
    for (sid, v), r in latest_records(records).items():
        out.setdefault(v, {})[sid] = r
    return out


def _both_succeeded(mine: Mapping, ref: Mapping):
    """``(record, reference record)`` of every scenario where neither failed (``mine`` and
    ``ref``: scenario id -> record), in ``mine``'s order."""
    for sid, r in mine.items():
        q = ref.get(sid)
        if q is not None and r["outcome"] == "success" and q["outcome"] == "success":
            yield r, q


def benchmark_table(
    records: Iterable[Mapping],
    *,
    variants: Sequence[str] | None = None,
    reference: str = "mppi",
    confidence: float = 0.95,
    n_boot: int = 2000,
    rng: int = 0,
) -> dict:
    """The ablation table as data.

    Parameters
    ----------
    records : iterable of dict
        Flight records (``scenario_id``, ``variant``, ``outcome``, the metrics, ``speed``); when
        a ``(scenario_id, variant)`` appears twice the last one counts.
    variants : sequence of str, optional
        Rows, in order; default every variant in ``records`` (sorted, reference first).
    reference : str
        The variant the energies are compared with (MPPI).
    confidence : float
        Level of every interval (0.95).
    n_boot : int
        Bootstrap resamples of the table ratio's interval (0: none).
    rng : int
        Seed of the bootstrap; each row draws from its own stream (the seed and its label), so
        its interval is the same whichever other rows are asked for.

    Returns
    -------
    dict
        ``reference``, ``confidence``, ``variants`` (the rows, in order) and ``rows``: per
        variant ``scenarios`` (flights recorded), ``errors`` (harness failures, left out),
        ``flights`` (the rest), ``success``, ``failure_pct`` {``value``, ``ci95``},
        ``failures`` {outcome: {``count``, ``pct``}} for :data:`FAILURES`, ``metrics``
        {name: {``mean``, ``std``, ``n``, ``ci95``}} over successful flights (energies in kJ),
        and, for variants other than the reference when it has records, ``vs_reference``
        {``energy_J`` and ``rotor_energy_J``: {``table_ratio`` {``value``, ``ci95``,
        ``n_variant``, ``n_reference``}, ``paired_reduction`` {``mean``, ``std``, ``n``,
        ``ci95``, ``by_speed`` {speed: {``mean``, ``std``, ``n``}}, ``less`` (pairs where
        the variant used less energy)}} and ``pace`` {``time_ratio``, ``power_ratio``: {``mean``,
        ``std``, ``n``, ``ci95``}} over the same pairs} (fractions, not %); ``failure_by``
        {``speed``, ``kind`` and ``goal_clearance_m`` (bands of :data:`GOAL_CLEARANCE_BANDS`,
        for records that have the field): {group: {``pct``, ``n``}}}; ``codes`` {the hash
        of the code that flew the records (:data:`UNRECORDED_CODE` for those that name none):
        how many}; for the onboard stack's
        records ``onboard``
        {``stage_ms`` {stage: {``median``, ``min``, ``max``, ``n``}}, ``real_time_fraction``,
        ``ukf_wind_rms_xy_mps``} over its flights; for variants whose records report the
        envelope (flown since 2026-11-26) ``envelope`` (:func:`_envelope`); for variants with
        flights whose simulation diverged ``diverged`` (:func:`_diverged`).
    """
    if not 0.0 < confidence < 1.0:
        raise ValueError(f"The 'confidence' parameter of benchmark_table must be in (0, 1). "
                         f"Got {confidence!r} instead.")
    by_variant = records_by_variant(records)
    if variants is None:
        variants = sorted(by_variant, key=lambda v: (v != reference, v))
    ref = by_variant.get(reference, {})
    rows = {}
    for v in variants:
        recs = list(by_variant.get(v, {}).values())
        valid = [r for r in recs if r["outcome"] != ERROR]
        n = len(valid)
        succ = [r for r in valid if r["outcome"] == "success"]
        n_fail = n - len(succ)
        row = {
            "scenarios": len(recs),
            "errors": len(recs) - n,
            "flights": n,
            "success": len(succ),
            "failure_pct": {"value": 100.0 * n_fail / n if n else None,
                            "ci95": _wilson(n_fail, n, confidence)},
            "failures": {o: {"count": sum(r["outcome"] == o for r in valid),
                             "pct": (100.0 * sum(r["outcome"] == o for r in valid) / n
                                     if n else None)} for o in FAILURES},
            "metrics": {name: _describe([scale * _num(r.get(key)) for r in succ], confidence)
                        for name, key, scale in METRICS},
        }
        row["failure_by"] = _failure_by(valid)
        onboard = _onboard(valid)
        if onboard:
            row["onboard"] = onboard
        envelope = _envelope(valid)
        if envelope:
            row["envelope"] = envelope
        diverged = _diverged(valid)
        if diverged:
            row["diverged"] = diverged
        row["codes"] = dict(sorted(Counter(r.get("code") or UNRECORDED_CODE
                                           for r in recs).items()))
        if v != reference and ref:
            # One stream per row, keyed by its label: a row's intervals do not depend on
            # which other rows the table shows.
            gen = np.random.default_rng([rng, zlib.crc32(v.encode())])
            row["vs_reference"] = {
                e: _versus(by_variant.get(v, {}), ref, e, confidence, n_boot, gen)
                for e in ENERGIES}
            row["vs_reference"]["pace"] = _pace(by_variant.get(v, {}), ref, confidence)
        rows[v] = row
    return {"reference": reference, "confidence": confidence, "variants": list(variants),
            "rows": rows}


GOAL_CLEARANCE_BANDS = (25.0, 40.0, 60.0)
"""Edges (m) of the bands of ``goal_clearance_m`` (the goal's distance to the nearest building)
by which the failure % is grouped: the thesis's progress and obstacle costs balance
``Q_O D_max^4 / (N_k d^3)`` from a goal ``d`` from a building (``docs/planner.md``)."""


def _clearance_band(value) -> str:
    d = _num(value)
    edges = GOAL_CLEARANCE_BANDS
    k = sum(d >= e for e in edges)
    if k == 0:
        return f"<{edges[0]:g}"
    return f">={edges[-1]:g}" if k == len(edges) else f"{edges[k - 1]:g}-{edges[k]:g}"


def _band_order(label: str) -> float:
    return -1.0 if label.startswith("<") else float(label.lstrip(">=").split("-")[0])


_FAILURE_GROUPS = {
    "speed": (lambda x: f"{_num(x):g}", float, "{} m/s"),
    "kind": (str, str, "{}"),
    "goal_clearance_m": (_clearance_band, _band_order, "goal {} m"),
}
"""Record fields the failure % is grouped by: (group label of a value, sort key of a label,
column head of a label). ``goal_clearance_m`` is derived, not recorded
(:func:`~windnav.experiments.nav_benchmark.with_goal_clearance`)."""


def _failure_by(valid: Sequence[Mapping]) -> dict:
    """Failure % of the flights ``valid`` grouped by inlet speed, by pair kind and (records
    that have it) by the goal's clearance band."""
    out = {}
    for key, (label, order, _) in _FAILURE_GROUPS.items():
        groups: dict[str, list[bool]] = {}
        for r in valid:
            if r.get(key) is not None:
                groups.setdefault(label(r[key]), []).append(r["outcome"] != "success")
        out[key] = {g: {"pct": 100.0 * sum(groups[g]) / len(groups[g]), "n": len(groups[g])}
                    for g in sorted(groups, key=order)}
    return out


def _envelope(valid: Sequence[Mapping]) -> dict:
    """How many of the flights ``valid`` left the models' envelope (records with
    ``outside_envelope_s``): ``n`` (such records), ``outside`` (flights with any time above
    the trusted airspeed), ``successes`` and ``successes_outside``, and the mean time above it
    and above the power curve's valid range over all of them, s."""
    rec = [r for r in valid if r.get("outside_envelope_s") is not None]
    if not rec:
        return {}
    out = [_num(r["outside_envelope_s"]) for r in rec]
    succ = [r for r in rec if r["outcome"] == "success"]
    return {"n": len(rec), "outside": sum(t > 0 for t in out), "successes": len(succ),
            "successes_outside": sum(_num(r["outside_envelope_s"]) > 0 for r in succ),
            "mean_outside_s": float(np.mean(out)),
            "mean_power_extrapolated_s": float(np.mean(
                [_num(r.get("power_extrapolated_s")) for r in rec]))}


def _diverged(valid: Sequence[Mapping]) -> dict:
    """The flights of ``valid`` whose simulated state stopped being finite (records with
    ``diverged_s``, 2026-12-06): ``n`` and the count per recorded outcome. Such a flight is
    classified by where it was (``left_map`` or ``collision``), so the failure columns alone
    would pass the simulation's failure off as the planner's."""
    rec = [r for r in valid if r.get("diverged_s") is not None]
    if not rec:
        return {}
    return {"n": len(rec), "by_outcome": dict(sorted(Counter(r["outcome"] for r in rec).items()))}


def _onboard(valid: Sequence[Mapping]) -> dict:
    """The onboard stack's per-flight timings and UKF errors (records of ``ea-mppi-w-hat``):
    median, min and max over the flights of each flight's median time per update (ms), of the
    compute per second of flight (s/s) and of the UKF's horizontal wind RMS error (m/s)."""
    stages: dict[str, list[float]] = {}
    series: dict[str, list[float]] = {"real_time_fraction": [], "ukf_wind_rms_xy_mps": []}
    for r in valid:
        for stage, ms in (r.get("stage_ms_median") or {}).items():
            if ms is not None and math.isfinite(_num(ms)):
                stages.setdefault(stage, []).append(_num(ms))
        for name, values in series.items():
            if r.get(name) is not None and math.isfinite(_num(r[name])):
                values.append(_num(r[name]))
    if not stages:
        return {}

    def summary(values):
        return {"median": float(np.median(values)), "min": float(np.min(values)),
                "max": float(np.max(values)), "n": len(values)}

    return {"stage_ms": {k: summary(v) for k, v in stages.items()},
            **{k: summary(v) for k, v in series.items() if v}}


def _versus(mine: Mapping, ref: Mapping, field: str, confidence, n_boot, gen) -> dict:
    ratio = _table_ratio(mine, ref, field, confidence, n_boot, gen)
    paired, speeds = [], []
    for r, q in _both_succeeded(mine, ref):
        e, e_ref = _num(r.get(field)), _num(q.get(field))
        if math.isfinite(e) and math.isfinite(e_ref) and e_ref > 0:
            paired.append(1.0 - e / e_ref)
            speeds.append(_num(r.get("speed")))
    red = _describe(paired, confidence)
    by_speed = {}
    for s in sorted({s for s in speeds if math.isfinite(s)}):
        d = _describe([p for p, sp in zip(paired, speeds, strict=True) if sp == s], confidence)
        by_speed[f"{s:g}"] = {k: d[k] for k in ("mean", "std", "n")}
    red["by_speed"] = by_speed
    red["less"] = sum(p > 0.0 for p in paired)  # pairs where the variant used less energy
    return {"table_ratio": ratio, "paired_reduction": red}


def paired_pace(mine: Mapping, ref: Mapping) -> dict:
    """Per scenario where neither failed (``mine`` and ``ref``: scenario id -> record): the
    time ratio ``T / T_ref`` and the mean-power ratio ``(E / T) / (E_ref / T_ref)``
    (airspeed-model energy ``energy_J``, ``time_s``), whose product is ``E / E_ref``: whether a
    variant saves energy by drawing less power or by arriving sooner.

    Returns
    -------
    dict
        ``scenario_id``, ``speed`` (inlet, m/s), ``time_ratio``, ``power_ratio`` and
        ``reference_power_W`` (``E_ref / T_ref``): lists, one entry per pair.
    """
    out = {k: [] for k in ("scenario_id", "speed", "time_ratio", "power_ratio",
                           "reference_power_W")}
    for r, q in _both_succeeded(mine, ref):
        t, t_ref = _num(r.get("time_s")), _num(q.get("time_s"))
        e, e_ref = _num(r.get("energy_J")), _num(q.get("energy_J"))
        if all(math.isfinite(x) and x > 0 for x in (t, t_ref, e, e_ref)):
            out["scenario_id"].append(r["scenario_id"])
            out["speed"].append(_num(r.get("speed")))
            out["time_ratio"].append(t / t_ref)
            out["power_ratio"].append((e / t) / (e_ref / t_ref))
            out["reference_power_W"].append(e_ref / t_ref)
    return out


def _pace(mine: Mapping, ref: Mapping, confidence) -> dict:
    """:func:`paired_pace`'s two ratios summarised (mean, std, n, t interval)."""
    pairs = paired_pace(mine, ref)
    return {"time_ratio": _describe(pairs["time_ratio"], confidence),
            "power_ratio": _describe(pairs["power_ratio"], confidence)}


# ------------------------------------------------------------------------------- Markdown


def _pm(d: Mapping, digits: int) -> str:
    if not d or d.get("mean") is None:
        return "-"
    if d.get("std") is None:
        return f"{d['mean']:.{digits}f} (n = 1)"
    return f"{d['mean']:.{digits}f} ± {d['std']:.{digits}f}"


def _ci(interval, digits: int, scale: float = 1.0, unit: str = "") -> str:
    if not interval:
        return "-"
    return f"[{scale * interval[0]:.{digits}f}, {scale * interval[1]:.{digits}f}]{unit}"


def _pct(value, digits: int = 1) -> str:
    return "-" if value is None else f"{100.0 * value:.{digits}f}%"


_COLUMNS = (("energy_kJ", "energy (kJ)", 2), ("rotor_energy_kJ", "rotor energy (kJ)", 2),
            ("mean_cmd_accel", "cmd. acc. (m/s²)", 2), ("time_s", "time to goal (s)", 2),
            ("distance_m", "distance (m)", 1))


def render_table(table: Mapping) -> str:
    """The table of :func:`benchmark_table` as Markdown: the ablation table (mean ± std over
    successful flights, failure % with its breakdown), the 95 % intervals of its entries, and
    both energy measures against the reference."""
    rows, variants = table["rows"], table["variants"]
    pct_conf = f"{100 * table['confidence']:g}%"
    head = ("| variant | flights | " + " | ".join(c[1] for c in _COLUMNS)
            + " | failure % (collision, hover, left map, timeout) |")
    out = [head, "|" + "---|" * (len(_COLUMNS) + 3)]
    for v in variants:
        r = rows[v]
        f = r["failures"]
        fail = r["failure_pct"]["value"]
        parts = ", ".join("-" if f[o]["pct"] is None else f"{f[o]['pct']:.1f}" for o in FAILURES)
        fail_s = "-" if fail is None else f"{fail:.1f} ({parts})"
        n = f"{r['flights']}" + (f" (+{r['errors']} errors)" if r["errors"] else "")
        out.append(f"| {v} | {n} | " + " | ".join(_pm(r["metrics"][c], d) for c, _, d in _COLUMNS)
                   + f" | {fail_s} |")
    out += ["", "Time to goal is the flight's end (`time_s`): for a success it includes the "
            "goal's capture and its 5 s hold (`arrival_time_s` is the arrival).",
            "", f"{pct_conf} confidence intervals (means: Student t over successful flights; "
            "failure %: Wilson):", "",
            "| variant | " + " | ".join(c[1] for c in _COLUMNS) + " | failure % |",
            "|" + "---|" * (len(_COLUMNS) + 2)]
    for v in variants:
        r = rows[v]
        out.append(f"| {v} | " + " | ".join(_ci(r["metrics"][c]["ci95"], d) for c, _, d in
                                              _COLUMNS)
                   + f" | {_ci(r['failure_pct']['ci95'], 1)} |")
    ref = table["reference"]
    others = [v for v in variants if "vs_reference" in rows[v]]
    if others:
        out += ["", f"Energy against {ref} (table ratio: 1 - mean(E)/mean(E_{ref}) over each "
                "variant's successful flights, bootstrap interval over the winds; paired "
                f"reduction: mean of 1 - E/E_{ref} over the scenarios where neither failed, t "
                "interval):", "",
                "| variant | energy | table ratio | paired reduction | n (variant, ref; "
                f"pairs) | pairs where it used less than {ref} |", "|---|---|---|---|---|---|"]
        for v in others:
            for e, label in (("energy_J", "airspeed model"), ("rotor_energy_J", "rotor")):
                d = rows[v]["vs_reference"][e]
                tr, pr = d["table_ratio"], d["paired_reduction"]
                tr_s = (f"{_pct(tr['value'])} {_ci(tr['ci95'], 1, 100.0, '%')}"
                        if tr["value"] is not None else "-")
                pr_s = (f"{_pct(pr['mean'])} {_ci(pr['ci95'], 1, 100.0, '%')}"
                        if pr["mean"] is not None else "-")
                out.append(f"| {v} | {label} | {tr_s} | {pr_s} | {tr['n_variant']}, "
                           f"{tr['n_reference']}; {pr['n']} | {pr['less']} of {pr['n']} |")
        ratios = [rows[v]["vs_reference"][e]["table_ratio"] for v in others for e in ENERGIES]
        few = sorted({r["winds_both"] for r in ratios
                      if r.get("ci95_note") and r["ci95"] is None})
        if few:
            out += ["", f"No table-ratio interval: the variants flew in "
                    f"{' or '.join(str(g) for g in few)} common wind(s), fewer than the "
                    f"{MIN_BOOTSTRAP_WINDS} a bootstrap over the winds needs."]
        rough = sorted({r["winds_both"] for r in ratios if r.get("ci95_note") and r["ci95"]})
        if rough:
            out += ["", f"The table-ratio intervals over {' or '.join(map(str, rough))} winds "
                    f"are approximate: {COVERAGE_NOTE}."]
        out += ["", f"Time and mean power against {ref} over the same pairs (time ratio "
                f"T/T_{ref}; mean-power ratio (E/T)/(E_{ref}/T_{ref}), airspeed model; their "
                "product is the energy ratio; t intervals):", "",
                "| variant | time ratio | mean-power ratio | pairs |", "|---|---|---|---|"]
        for v in others:
            pace = rows[v]["vs_reference"]["pace"]
            tr, pw = pace["time_ratio"], pace["power_ratio"]
            cells = [("-" if d["mean"] is None else f"{d['mean']:.3f} {_ci(d['ci95'], 3)}")
                     for d in (tr, pw)]
            out.append(f"| {v} | {cells[0]} | {cells[1]} | {tr['n']} |")
    described = [d for v in variants for d in rows[v]["metrics"].values()]
    described += [d for v in others for d in (
        *(rows[v]["vs_reference"][e]["paired_reduction"] for e in ENERGIES),
        *rows[v]["vs_reference"]["pace"].values())]
    if any(d.get("ci95_note") for d in described):  # "1.000 -" was left unexplained (review)
        out += ["", "A t interval shown as \"-\" beside a value: one value, or every value it "
                "would be drawn from the same, so there is no spread to give one from."]
    out += _render_failure_by(rows, variants)
    out += _render_envelope(rows, variants)
    out += _render_diverged(rows, variants)
    out += _render_onboard(rows, variants)
    out += _render_codes(rows, variants)
    return "\n".join(out) + "\n"


def _render_codes(rows: Mapping, variants: Sequence[str]) -> list[str]:
    """The code versions behind the rows, said when there is more than one or one unknown."""
    codes = {c for v in variants for c in rows[v].get("codes", {})}
    if (len(codes) <= 1 and UNRECORDED_CODE not in codes
            and not any(c.endswith("-modified") for c in codes)):
        return []
    check = ("`windnav benchmark-nav --check N` replays a sample of them under the code at "
             "hand")
    if codes == {UNRECORDED_CODE}:  # unknown is not mixed (review)
        head = ("The records name no code (flown before records named it): which version of "
                f"the code flew them is not known; {check}:")
    else:
        head = (f"Records by the code that flew them (the hash of its source; "
                f"\"{UNRECORDED_CODE}\": flown before records named it; \"-modified\": its "
                "files changed during the run, so the code is not known exactly). The table "
                f"mixes code versions or holds records of unknown code; {check}:")
    out = ["", head, "", "| variant | records by code (harness errors included) |", "|---|---|"]
    for v in variants:
        parts = ", ".join(f"{c} {n}" for c, n in rows[v].get("codes", {}).items())
        out.append(f"| {v} | {parts or '-'} |")
    return out


def _render_failure_by(rows: Mapping, variants: Sequence[str]) -> list[str]:
    groups = {key: sorted({g for v in variants for g in rows[v]["failure_by"].get(key, {})},
                          key=order)
              for key, (_, order, _) in _FAILURE_GROUPS.items()}
    if not any(groups.values()):
        return []
    heads = [head.format(g) for key, (_, _, head) in _FAILURE_GROUPS.items()
             for g in groups[key]]
    out = ["", "Failure % by inlet speed, by pair kind and by the goal's distance to the nearest "
           "building (flights in each group in parentheses):", "",
           "| variant | " + " | ".join(heads) + " |",
           "|" + "---|" * (len(heads) + 1)]
    for v in variants:
        by = rows[v]["failure_by"]
        cells = [(f"{by[key][g]['pct']:.1f} ({by[key][g]['n']})" if g in by.get(key, {})
                  else "-") for key in _FAILURE_GROUPS for g in groups[key]]
        out.append(f"| {v} | " + " | ".join(cells) + " |")
    return out


def _render_section(rows: Mapping, variants: Sequence[str], key: str, head: list[str],
                    line) -> list[str]:
    """A section under the table for the variants whose rows have ``key``: ``head`` (its
    introduction and table head), then ``line(variant, row[key])`` per variant; [] when none
    has it."""
    mine = [v for v in variants if rows[v].get(key)]
    return ["", *head, *(line(v, rows[v][key]) for v in mine)] if mine else []


def _render_envelope(rows: Mapping, variants: Sequence[str]) -> list[str]:
    head = ["Outside the envelope (records flown since 2026-11-26): flights with any time "
            "above the vehicle's trusted airspeed (13.45 m/s for the Hummingbird), and the mean "
            "time above it and above the power curve's valid range (13 m/s), where energy_J "
            "extrapolates:", "",
            "| variant | flights outside | successes outside | mean s above the airspeed limit "
            "| mean s above the power curve |", "|---|---|---|---|---|"]
    return _render_section(rows, variants, "envelope", head, lambda v, e: (
        f"| {v} | {e['outside']} of {e['n']} | {e['successes_outside']} of "
        f"{e['successes']} | {e['mean_outside_s']:.2f} | {e['mean_power_extrapolated_s']:.2f} |"))


def _render_diverged(rows: Mapping, variants: Sequence[str]) -> list[str]:
    head = ["Flights whose simulation diverged (the vehicle's state stopped being finite; "
            "each is counted above under the outcome where it stopped, `diverged_s` in its "
            "record):", "", "| variant | diverged | recorded as |", "|---|---|---|"]
    return _render_section(rows, variants, "diverged", head, lambda v, d: (
        f"| {v} | {d['n']} of {rows[v]['flights']} | "
        + ", ".join(f"{o} {k}" for o, k in d["by_outcome"].items()) + " |"))


def _render_onboard(rows: Mapping, variants: Sequence[str]) -> list[str]:
    out = []
    for v in variants:
        ob = rows[v].get("onboard")
        if not ob:
            continue
        out += ["", f"Onboard stack of {v}, over its flights (median [min, max] of each "
                "flight's median time per update; compute per second of flight; the Wind "
                "UKF's horizontal wind RMS error):", "",
                "| quantity | median | min | max |", "|---|---|---|---|"]
        for stage, d in ob["stage_ms"].items():
            out.append(f"| {stage} (ms per update) | {d['median']:.3f} | {d['min']:.3f} | "
                       f"{d['max']:.3f} |")
        if "real_time_fraction" in ob:
            d = ob["real_time_fraction"]
            out.append(f"| compute per second of flight (% of one core) | "
                       f"{100 * d['median']:.1f} | {100 * d['min']:.1f} | {100 * d['max']:.1f} |")
        if "ukf_wind_rms_xy_mps" in ob:
            d = ob["ukf_wind_rms_xy_mps"]
            out.append(f"| UKF horizontal wind RMS error (m/s) | {d['median']:.2f} | "
                       f"{d['min']:.2f} | {d['max']:.2f} |")
    return out
