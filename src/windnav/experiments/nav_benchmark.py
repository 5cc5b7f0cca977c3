"""The navigation benchmark of the thesis (ch. 5): every variant flies every scenario of a suite.

The scenarios are those of :mod:`windnav.experiments.nav_suite` (the ``thesis`` suite: 16 maps
x 16 winds x 4 start/goal pairs = 1,024 per variant); the flight is the closed loop of
:func:`windnav.experiments.navigate.navigate`; the records and the table are
:mod:`windnav.experiments.nav_records`.

How a run is organised
----------------------
* **A few winds per task.** The flights of a suite are grouped by (map, wind), and the winds
  of a map whose inlets are the same sides (the 0 deg winds; the 15, 30 and 45 deg winds) in
  batches of up to ``wind_batch`` (:func:`wind_batches`). One task of
  :func:`windnav.experiments.executor.run_tasks` (``serial``, ``process`` or ``ray``)
  simulates its winds once, together (:func:`windnav.experiments.navigate.simulate_flows`:
  ``spinup_s`` of spin-up, then ``record_s`` of frames every ``dt`` on a ``dx`` grid; one
  pressure solve with a column per wind at each step, each wind to the bit as if simulated
  alone: :data:`windnav.flow.solver.BITWISE_BATCH`), then flies every pending (pair, variant)
  of each wind in it. The gridded wind field (frames ``(T, ny, nx, 2)``, the layout the
  solver records them in, so the field adopts them without a copy) is built once per wind
  and shared by its flights (:class:`SharedFlow`): a task holds one copy of the frames of
  each of its winds (2.3 GB for 600 m x 600 m x 400 frames in float64; with 3 winds a worker
  peaks at 7.8 GB, against 3.2 GB with one: the whole-suite runs of EA-MPPI+Ŵ).
* **Flows are recomputed, not stored.** A 600 m wind of 125 s at ``dx = 1`` m is 2.3 GB of
  float64 frames (1.2 GB in float32): the thesis suite's 256 winds would need ~300 GB, so a
  task recomputes its wind (deterministic: same map, inlet and settings, same frames) and the
  store keeps only the records. A replay recomputes it the same way.
* **Resumable.** Each flight's record is appended to the store by the worker that flew it as
  soon as it lands (see :class:`~windnav.experiments.nav_records.NavStore`); a rerun skips every
  (scenario_id, variant) already recorded (with ``retry_errors``, also re-flies those whose
  harness failed). A killed run loses only the flights in the air and the winds being solved.
* **Failures are data.** A flight that raises is recorded with ``outcome = "error"`` and its
  traceback in ``error``; a task whose wind cannot be simulated (or whose worker dies) records
  that error for each of its pending flights. Neither stops the run.

The flight's seed (:attr:`Scenario.seed`) seeds the planner's sampling and the LiDAR noise and
is the same for every variant, so that variants fly paired scenarios. Same suite, same seed,
same records (up to the wall times): :func:`replay` re-flies one record. The onboard-stack
variant (``ea-mppi-w-hat``) flies a pinned decoder, :data:`BENCHMARK_DECODER` of
:data:`DECODERS` (files checked by hash), not whatever model windnav ships as its default, so
that its records replay after the default changes; ``ea-mppi-w-hat@decoder=DATE`` flies another.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import numbers
import os
import time
import traceback
from collections.abc import Callable, Sequence
from dataclasses import dataclass

from windnav._source import module_key
from windnav._validate import options_named
from windnav.experiments.arithmetic import FIELDS, arithmetic, blas_kernel
from windnav.experiments.nav_records import (
    ERROR,
    CorruptRecordError,
    NavStore,
    StoreBusyError,
    SuiteMismatchError,
    benchmark_table,
    render_table,
)
from windnav.experiments.nav_suite import (
    SUITES,
    Scenario,
    SuiteSpec,
    check_suite_spec,
    clearance_to_buildings,
    get_suite,
    make_suite,
    parse_scenario_id,
    suite_map,
)

__all__ = [
    "BENCHMARK_DECODER",
    "DECODERS",
    "CODE_FIELDS",
    "CODE_MODULE",
    "ENVELOPE_FIELDS",
    "KERNEL_FIELDS",
    "KERNEL_SENSITIVE_NOTE",
    "ONBOARD_FIELDS",
    "PARAMETERS",
    "RECORD_FIELDS",
    "ROUTE_FIELDS",
    "SUITES",
    "CorruptRecordError",
    "GroupTask",
    "NavStore",
    "StoreBusyError",
    "Scenario",
    "SharedFlow",
    "SuiteMismatchError",
    "SuiteSpec",
    "benchmark_decoder",
    "flight_decoder",
    "blas_kernel",
    "benchmark_table",
    "check_against_suite",
    "check_records",
    "checked_flight",
    "check_scenario_ids",
    "check_variants",
    "compare_records",
    "error_record",
    "fly",
    "fly_group",
    "fly_scenario",
    "get_suite",
    "group_wind",
    "group_winds",
    "make_suite",
    "parse_variant",
    "render_table",
    "replay",
    "run_benchmark",
    "run_group",
    "suite_flow",
    "suite_flows",
    "wind_batches",
    "with_goal_clearance",
]

WIND_BATCH = 3
"""Default most winds a benchmark task simulates together: ``windnav.flow.solver.BITWISE_BATCH``
(not imported here, to keep the solver out of this module's import; a test checks they agree)."""

RECORD_FIELDS = (
    "scenario_id", "variant", "seed", "outcome", "energy_J", "rotor_energy_J", "time_s",
    "distance_m", "mean_cmd_accel", "planner_ms_median", "kind", "speed", "direction_deg",
    "map_index", "wind_index", "pair_index", "start", "goal", "fallbacks", "planner_updates",
    "final_distance_to_goal_m", "arrival_time_s", "wall_s", "loop_wall_s", "flow_s", "error",
)
"""The fields of a flight record, in order (metrics in SI units: J, s, m, m/s^2, ms)."""

ENVELOPE_FIELDS = ("airspeed_max_mps", "outside_envelope_s", "power_extrapolated_s",
                   "goal_hold_at_cap_s")
"""Fields after :data:`RECORD_FIELDS` in every record flown since 2026-11-26 (the records before
lack them): the largest airspeed (m/s), the time above the vehicle's trusted airspeed and the
time above the power curve's valid range (s); since 2026-11-29 also the time spent holding the
goal with the command at the tilt cap (s)
(:meth:`~windnav.experiments.navigate.NavigationResult.envelope`)."""

KERNEL_FIELDS = FIELDS
"""Fields after :data:`ENVELOPE_FIELDS`: the arithmetic of the process that flew the record
(:func:`windnav.experiments.arithmetic.arithmetic`): NumPy's BLAS kernel and its SIMD dispatch
targets, in every record flown since 2026-12-02 (the records before lack them; the first of
that day only name the kernel). A flight replays to 1e-6 only under the same arithmetic
(:data:`KERNEL_SENSITIVE_NOTE`); ``windnav benchmark-nav --replay`` pins the record's when this
CPU can run it."""

CODE_FIELDS = ("code",)
"""The field after :data:`KERNEL_FIELDS` in every record flown since 2026-12-06 (the records
before lack it): the hash of the code that flew it, this module and every windnav module it
imports (:func:`windnav._source.module_key` of :data:`CODE_MODULE`; 90 files). A store resumed
across a change of the code holds records of both; the table counts them (``codes``) and says
so, and ``windnav benchmark-nav --check`` replays a sample of them under the code at hand."""

CODE_MODULE = "windnav.experiments.nav_benchmark"
"""The module whose import closure :data:`CODE_FIELDS`' hash covers."""

ONBOARD_FIELDS = ("stage_ms_median", "real_time_fraction", "ukf_wind_rms_mps",
                  "ukf_wind_rms_xy_mps")
"""Fields appended to the record of a flight with the onboard wind stack (``ea-mppi-w-hat``,
:mod:`windnav.experiments.onboard`): per-stage median times (ms), the real-time load (s/s) and
the Wind UKF's RMS errors (m/s). Other variants' records have exactly :data:`RECORD_FIELDS`,
:data:`ENVELOPE_FIELDS`, :data:`KERNEL_FIELDS` and :data:`CODE_FIELDS`."""

KERNEL_SENSITIVE_NOTE = (
    "a closed-loop flight can amplify the last-bit differences between BLAS kernels and between "
    "NumPy's SIMD loops (both picked by CPU) into another flight: a record replays to 1e-6 "
    "only under the arithmetic that flew it (docs/navigation.md, 'Replays across CPUs')")
"""What ``windnav benchmark-nav --replay`` says when a flight does not replay."""


ROUTE_FIELDS = ("route_energy_J", "route_hold_energy_J", "route_time_s", "route_length_m")
"""Fields appended to the record of a GS or GS+W flight (after :data:`CODE_FIELDS`): the
planned route's energy in the wind it was planned in (the mean wind for GS+W; steady flight at
each piece's optimal speed, no acceleration, no gusts; airspeed power curve, J), the goal hold
it leaves out (``HOLD_S`` at rest in that wind at the goal, J), its time (s) and its length
(m): what the energy-optimal route promises before it is flown
(:func:`windnav.plan.energy_route`)."""

_METRICS = ("energy_J", "rotor_energy_J", "time_s", "distance_m", "mean_cmd_accel",
            "planner_ms_median", "fallbacks", "planner_updates", "final_distance_to_goal_m",
            "arrival_time_s")
REPLAY_FIELDS = ("outcome", "energy_J", "rotor_energy_J", "time_s", "distance_m",
                 "mean_cmd_accel")
"""Fields a replay must reproduce (the wall times and planner timings are not reproducible)."""


# ------------------------------------------------------------------------------- the wind


class SharedFlow:
    """A :class:`~windnav.flow.FlowSolution` whose unsteady wind field is built once.

    :func:`~windnav.experiments.navigate.navigate` asks its ``flow`` for
    ``wind_field(unsteady=True)`` on every flight; this wrapper builds that field once (it adopts
    the solver's ``(T, ny, nx, 2)`` frames, 2.3 GB for a 600 m map, and copies only frames laid
    out otherwise), keeps the solution's ``frames_u`` and ``frames_v`` as views into it and
    answers every other attribute from the solution. The field's values are the solution's, so
    a flight on it is the flight on the solution itself.
    """

    def __init__(self, flow):
        self._field = flow.wind_field(unsteady=True)
        self._flow = dataclasses.replace(flow, frames_u=self._field.u, frames_v=self._field.v)

    @property
    def solution(self):
        """The :class:`~windnav.flow.FlowSolution` (its frames views into the shared field)."""
        return self._flow

    def wind_field(self, unsteady: bool = False):
        """The shared unsteady field, or the steady mean field (as ``FlowSolution``)."""
        return self._field if unsteady else self._flow.wind_field()

    def __getattr__(self, name):
        return getattr(self._flow, name)


def suite_flow(spec: SuiteSpec, city, speed: float, direction_deg: float, *,
               reuse: WorkerReuse | None = None) -> SharedFlow:
    """The suite's wind for one inlet: :func:`~windnav.experiments.navigate.simulate_flow`
    with the suite's spin-up, record, ``dx`` and ``dt``, wrapped in :class:`SharedFlow`.
    ``reuse``: a worker's factorisations and frame memory, kept from its earlier winds (the
    same wind to the bit, faster)."""
    return suite_flows(spec, city, [(speed, direction_deg)], reuse=reuse)[0]


def suite_flows(spec: SuiteSpec, city, winds, *, reuse: WorkerReuse | None = None
                ) -> list[SharedFlow]:
    """:func:`suite_flow` for several ``(speed, direction_deg)`` winds of one map whose inlets
    are the same sides, simulated together
    (:func:`~windnav.experiments.navigate.simulate_flows`); each equals its
    :func:`suite_flow` to the bit for up to :data:`~windnav.flow.solver.BITWISE_BATCH` winds."""
    from windnav.experiments.navigate import simulate_flows

    kw = {} if reuse is None else {"factor_cache": reuse.factors,
                                   "frame_buffers": reuse.frames}
    flows = simulate_flows(city, winds, spinup_s=spec.spinup_s, record_s=spec.record_s,
                           dx=spec.dx, dt=spec.dt, **kw)
    return [SharedFlow(f) for f in flows]


def wind_batches(spec: SuiteSpec, groups, size: int) -> list[tuple[int, tuple[int, ...]]]:
    """The ``(map_index, wind_indices)`` batches of the ``(map_index, wind_index)`` pairs in
    ``groups``: the winds of one map whose inlets are the same sides
    (:meth:`~windnav.flow.BoundaryConditions.for_wind`), in wind order, split into
    ``ceil(n / size)`` batches of as even sizes as possible (the thesis suite with ``size`` 3:
    per map, the 0 deg winds in two pairs and the 15, 30 and 45 deg winds of each speed in a
    triple). Sorted by map and first wind."""
    from windnav.flow import BoundaryConditions

    families: dict[tuple, list[int]] = {}
    for m, w in sorted(groups):
        sides = BoundaryConditions.for_wind(*spec.wind(w)).sides
        families.setdefault((m, sides), []).append(w)
    batches = []
    for (m, _), ws in families.items():
        n = math.ceil(len(ws) / size)
        cuts = [round(k * len(ws) / n) for k in range(n + 1)]
        batches += [(m, tuple(ws[a:b])) for a, b in zip(cuts[:-1], cuts[1:], strict=True)]
    return sorted(batches)


def wind_memory(spec: SuiteSpec, batch: int = 1) -> int:
    """Bytes that simulating ``batch`` winds of one of the suite's maps together takes, by
    :func:`~windnav.flow.memory.estimate_flow_memory`: the suite's grid (its planning maps'
    square, or its city's bounds) and recorded frames, the map counted open (the conservative
    case: buildings take cells out of the pressure solve)."""
    from windnav.city import grid_shape
    from windnav.flow.memory import estimate_flow_memory

    bounds = (0.0, spec.map_size, 0.0, spec.map_size) if spec.city is None else spec.city.bounds
    frames = max(2, int(round(spec.record_s / spec.dt)))
    return estimate_flow_memory(grid_shape(bounds, spec.dx), batch, frames)


def fit_wind_batch(spec: SuiteSpec, wind_batch: int, processes: int) -> int:
    """The largest batch of at most ``wind_batch`` winds whose simulation in ``processes``
    workers at once fits the memory limit (:func:`windnav.flow.memory.default_memory_limit`)
    by :func:`wind_memory`; 1 when none does (the solver's own check then decides). A smaller
    batch changes no value, only the time."""
    from windnav.flow.memory import default_memory_limit

    limit = default_memory_limit()
    if limit is None:
        return wind_batch
    for batch in range(wind_batch, 1, -1):
        if processes * wind_memory(spec, batch) <= limit:
            return batch
    return 1


class WorkerReuse:
    """What a benchmark worker keeps from one wind to the next: the pressure factorisations
    (keyed by map and inlet sides: the 15, 30 and 45 deg winds of a map share one, and every
    speed of an incidence) and the memory of the recorded frames (2.3 GB per 600 m wind, whose
    first write would otherwise page-fault: :class:`~windnav.flow.FrameBuffers`). Neither
    changes a value: a flight in a reused wind is bitwise the flight in a fresh one."""

    def __init__(self, max_factors: int = 2):
        from windnav.flow import FactorCache, FrameBuffers

        self.factors = FactorCache(maxsize=max_factors)
        self.frames = FrameBuffers()


@functools.cache
def worker_reuse() -> WorkerReuse:
    """This process's :class:`WorkerReuse`, made on first use (each worker process has its
    own, so nothing is shared between processes)."""
    return WorkerReuse()


def with_goal_clearance(spec: SuiteSpec, records: Sequence[dict]) -> list[dict]:
    """``records`` with ``goal_clearance_m``: the distance, m, from each flight's goal to the
    nearest building of its map (the suite's :func:`suite_map`), derived for the table's
    failure bands (records that have no ``goal`` or ``map_index`` are returned unchanged)."""
    by_map: dict[int, list[int]] = {}
    out = [dict(r) for r in records]
    for k, r in enumerate(out):
        if r.get("goal") is not None and r.get("map_index") is not None:
            by_map.setdefault(int(r["map_index"]), []).append(k)
    for m, ks in by_map.items():
        goals = [out[k]["goal"] for k in ks]
        for k, d in zip(ks, clearance_to_buildings(suite_map(spec, m), goals), strict=True):
            out[k]["goal_clearance_m"] = float(d)
    return out


# ------------------------------------------------------------------------------- one flight


DECODERS = {
    "2026-11-23": ("decoder_2026-11-23.npz",
                   "75ea65022f6507f4acba63f9380724804d0c2f1c5cc3ca4ef92dec884a8a02e3"),
    "2026-11-26": ("decoder_2026-11-26.npz",
                   "5dd14faf5598ee6d56593089d1157f0a017bd94184330c1914b7a34423d427e5"),
    "2026-11-29": ("decoder_2026-11-29.npz",
                   "5e3220601fab717a55bb88e0a9f12c54a14dd13a268f286d2582d2c434d61874"),
    "2026-11-29-area": ("decoder_2026-11-29-area.npz",
                        "6ef284457b032a2787e63b68888abee5576e8bb57480d914e42b4b8385ad21cd"),
    "2026-11-30": ("decoder_2026-11-30.npz",
                   "eef872ceeeb23f606912ff4a4b51c3cda69bce4a48545cb30c6f7c5c023c891d"),
    "2026-11-30-clusters": ("decoder_2026-11-30-clusters.npz",
                            "db58e11bab470127aa5c748254ba27813ba32438910c5609cdaf52ca51c25b3f"),
    "2026-12-01": ("decoder_2026-12-01.npz",
                   "e02053ddc7e3f8b7a7d3a4351fc5644c189772a849bc52d60bc456d030786a43"),
    "2026-12-06": ("decoder_2026-12-06.npz",
                   "7551605058863134abac688d638cd3e1c29a5e85727b371c578679a1348eb0b3"),
    "2026-12-06-maps": ("decoder_default.npz",
                        "6af94e9470f4f9e7bc39964088878813ecc2f7de4df5d4dccbb63a7890a0b1d3"),
    "2026-11-29-flight": ("decoder_2026-11-29-flight.npz",
                          "5c1fcadb03ad19b08326fcc1238a4851b725d35548b6340e72782a9461cda14e"),
}
"""The decoders the onboard stack can fly in the benchmark, by the date they were trained: the
file in ``windnav/predict/data`` and its SHA-256. A model keeps its date when the shipped
default is retrained (its file is then copied under its date), so a label names the same
weights for good; a file whose bytes differ is refused. ``2026-11-29-area``, the default from
the evening of 2026-11-29, is the second model trained that day: samples drawn in proportion
to the area around buildings and six 1.1 km clusters (``docs/decoder.md``). ``2026-11-30``,
the first default of that day, is the same data and model trained with the
metrics' own forms as the loss; ``2026-11-30-clusters``, the second default of that day, is
that recipe with the six 1.1 km clusters drawn twice as often (``map_weights`` 8 instead of 4);
``2026-12-01``, the default until 2026-12-06, has eight clusters (two more of 52 single
blocks), each drawn 6 times over, for the same number of samples; ``2026-12-06``, the default
from the forty-fifth session of 2026-12-06 to the forty-sixth, is that recipe with every
training scene turned about its robot by up to 4 deg (``data.turn_deg``); ``2026-12-06-maps``,
the default since, is that recipe with twice the 300 m maps, each group keeping its share of
the samples.
``2026-11-29-flight`` is not a default: the recipe ``wrobot_flight.toml`` (the default's with
0.45 U of noise on ``W_robot``, the in-flight error of the onboard estimate against the mean
wind)."""

BENCHMARK_DECODER = "2026-11-23"
"""The decoder (a key of :data:`DECODERS`) that the benchmark's onboard stack
(``ea-mppi-w-hat``) flies: the model its committed flights (``docs/navigation/``) were flown
with. The shipped default (:func:`windnav.predict.load_decoder`) was retrained on 2026-11-26,
twice on 2026-11-29, twice on 2026-11-30, on 2026-12-01 and twice on 2026-12-06
(``ea-mppi-w-hat@decoder=2026-11-26``, ``@decoder=2026-11-29``, ``@decoder=2026-11-29-area``,
``@decoder=2026-11-30``, ``@decoder=2026-11-30-clusters``, ``@decoder=2026-12-01``,
``@decoder=2026-12-06`` and ``@decoder=2026-12-06-maps`` fly them);
pinning the benchmark's model keeps every recorded flight replayable to the bit."""


def benchmark_decoder(name: str = BENCHMARK_DECODER, views_deg: float = 0.0):
    """The decoder :data:`DECODERS` ``[name]``, its file's hash checked, loaded once per process,
    with the sector boundaries its recorded flights met (``boundary="floor"``,
    :data:`windnav.predict.decoder.BOUNDARIES`); with ``views_deg`` > 0 (whole degrees under
    :data:`VIEWS_LIMIT_DEG`), its turned views ``rotations_deg=(0, -views_deg, views_deg)``
    (the label's ``@views=``; ``docs/decoder.md``, "Turned views").

    Raises
    ------
    ValueError
        An unknown name, a file whose SHA-256 is not the recorded one, or ``views_deg`` not a
        whole number of degrees in [0, 45) (a number, not a string or a boolean).
    """
    views = views_deg
    if (isinstance(views, bool) or not isinstance(views, numbers.Real)
            or not (0.0 <= float(views) < VIEWS_LIMIT_DEG and float(views) == round(views))):
        raise ValueError(f"The 'views_deg' parameter of benchmark_decoder must be a whole number "
                         f"of degrees in [0, {VIEWS_LIMIT_DEG:g}). Got {views_deg!r} instead.")
    return _dated_decoder(str(name), float(views) + 0.0)


VIEWS_LIMIT_DEG = 45.0
"""The label's ``@views=A`` takes whole degrees ``0 < A <`` this: for the d4-film, whose answer
is the same under quarter turns, the views at -45 and +45 deg are one view (1.2e-6 m/s apart),
which would weigh twice in the mean."""


def flight_decoder(options: dict):
    """The decoder :func:`fly` gives the onboard stack of a label's ``options``
    (:func:`parse_variant`): its ``decoder`` (default :data:`BENCHMARK_DECODER`) with its
    ``decoder_views`` (default none)."""
    return benchmark_decoder(options.get("decoder", BENCHMARK_DECODER),
                             options.get("decoder_views", 0.0))


@functools.lru_cache(maxsize=None)
def _dated_decoder(name: str, views_deg: float = 0.0):
    from windnav.predict import load_decoder
    from windnav.predict.decoder import DEFAULT_MODEL, model_sha256

    if name not in DECODERS:
        raise ValueError(f"The 'decoder' parameter of benchmark_decoder must be one of "
                         f"{list(DECODERS)}. Got {name!r} instead.")
    file, sha = DECODERS[name]
    path = DEFAULT_MODEL.parent / file
    if not path.is_file() or model_sha256(path) != sha:
        raise ValueError(f"The 'decoder' parameter of benchmark_decoder names {name!r}, whose "
                         f"file {str(path)!r} is missing or not the model of that date "
                         f"(SHA-256 {sha[:12]}...): its flights would not replay.")
    # the sector boundaries as the recorded flights met them (the suite's 0 and 45 deg
    # incidences): windnav.predict.decoder.BOUNDARIES
    views = None if views_deg == 0.0 else (0.0, -views_deg, views_deg)
    return load_decoder(path, boundary="floor", rotations_deg=views)


PARAMETERS = {"qe": "energy_weight", "h": "horizon", "power": "power_shape",
              "decoder": "decoder", "esc": "escape", "escair": "escape_airspeed",
              "edge": "escape_edge", "pace": "escape_pace", "regain": "escape_regain",
              "launch": "escape_launch", "gust": "escape_gust", "tilt": "tilt_max_deg",
              "outside": "outside", "energy": "energy_mode", "tau": "wrobot_tau_s",
              "views": "decoder_views"}
"""Study parameters a variant label may set after ``@`` (:func:`parse_variant`): ``qe`` the
energy weight ``Q_E``, ``h`` the side ``H`` of the wind window ``L_t``, m (``inf``: the whole
map; ``0``: no wind), ``power`` the shape of the power curve that the planner and ``energy_J``
use (a name of :data:`windnav.experiments.navigate.POWER_SHAPES`; a counterfactual), ``tilt``
the closed loop's tilt cap, degrees (in (0, 80); ``navigate``'s ``tilt_max_deg``, default 55: the
planner's ``a_max = g tan(tilt) / sqrt 2`` with it; a counterfactual of the vehicle's
authority), ``energy=mission`` (``J_E`` is the energy of the mission instead of the horizon's,
:attr:`windnav.plan.PlannerConfig.energy_mode`, ours; also for ``ea-mppi-w-hat``); for
``ea-mppi-w-hat`` only, ``decoder`` the onboard decoder (a key of :data:`DECODERS`) and
``outside=robot`` (the planner's wind outside the decoder's window is the uniform ``W_robot``
the decoder was given instead of zero: :attr:`windnav.experiments.onboard.OnboardOptions.outside`,
ours, not the thesis's) and ``tau`` (s, finite, > 0: ``W_robot`` is the UKF's estimate averaged
with that time constant, :attr:`~windnav.experiments.onboard.OnboardOptions.wrobot_tau_s`,
ours) and ``views`` (whole degrees in (0, 45): the decoder predicts the mean over the
scene as given and turned by -``views`` and +``views`` degrees, its opt-in turned views,
``docs/decoder.md``; three passes per decode); for ``mppi-w`` and ``ea-mppi-w`` with a finite
``h``, ``outside=truth``
(outside ``L_t`` the planner gets the true mean wind at the vehicle instead of zero:
:func:`windnav.experiments.navigate.local_wind`, ours: the onboard option with a perfect
estimate); and for
``ea-mppi-w-esc`` only, ``esc`` the length of route an escape flies, m (finite, > 0;
:class:`windnav.plan.EscapeConfig` ``length_m``, default 60 m: longer than any route means that
the first stall hands the flight to the route for good) and ``escair`` the airspeed of a
least-time escape, m/s (finite, > 0; ``EscapeConfig.airspeed_mps``: the first stall hands the
flight to the least-time route to the goal in the mean wind, see
:class:`windnav.plan.FastestEscape`), with ``edge`` (m: the escape also begins that near the
map's edge, ``EscapeConfig.edge_m``) and ``pace`` (s: the escape also begins when the closing
speed of the last 10 s would arrive later than that before the deadline,
``EscapeConfig.pace_margin_s``), ``regain`` (m: a vehicle blown that far off the goal it holds
flies a new least-time route back, ``EscapeConfig.regain_m``) and ``launch`` (s: the escape
begins at take-off when the least time to the goal in the mean wind is longer than that,
``EscapeConfig.launch_s``) and ``gust`` (standard deviations: the least-time routes are
searched with each move's ground speed lowered by that many deviations of the recorded wind
along it, and flown at the mean wind's speeds, ``EscapeConfig.gust_k``)."""

_PARAMETRIC = ("mppi", "mppi-w", "ea-mppi", "ea-mppi-w", "ea-mppi-w-esc")
_TRUTH_FILL = ("mppi-w", "ea-mppi-w")
"""The variants that take ``outside=truth`` (with a finite ``h``)."""
_ESCAPE_KEYS = ("esc", "escair", "edge", "pace", "regain", "launch", "gust")
"""The label parameters of the escape variants (:class:`windnav.plan.EscapeConfig`)."""
_NEEDS_ESCAIR = ("edge", "pace", "regain", "launch", "gust")
"""Those that act only on a least-time escape (``escair``)."""


def parse_variant(label: str, where: str = "parse_variant") -> tuple[str, dict]:
    """A variant label: a key of :data:`windnav.plan.VARIANTS`, or one of the MPPI variants with
    study parameters, ``"ea-mppi-w@qe=2"``, ``"ea-mppi-w@h=50"``, ``"ea-mppi-w@qe=3@h=90"``
    (:data:`PARAMETERS`; the Q_E and H sweeps of the thesis), ``"mppi@power=crazyflie"`` (the
    power-curve counterfactual), ``"ea-mppi-w@tilt=70"`` (the tilt-cap counterfactual),
    ``"ea-mppi-w-hat@decoder=2026-11-26"`` (another decoder), ``"ea-mppi-w-hat@outside=robot"``
    (the onboard stack's ``W_robot`` outside the decoder's window),
    ``"ea-mppi-w-hat@outside=robot@tau=5"`` (and its ``W_robot`` averaged over 5 s),
    ``"ea-mppi-w-hat@views=3"`` (the decoder's turned views by 0 and +-3 deg),
    ``"ea-mppi-w@h=25@outside=truth"`` (the true mean wind at the vehicle outside the window),
    ``"ea-mppi-w@energy=mission"`` (the mission's energy as ``J_E``).

    Returns
    -------
    base : str
        The variant of :data:`windnav.plan.VARIANTS`.
    options : dict
        Extra keyword arguments of :func:`~windnav.experiments.navigate.navigate`:
        ``planner_overrides`` (``energy_weight``; ``use_wind=False`` for ``h=0``),
        ``horizon``, ``power_shape``, ``tilt_max_deg``, ``decoder`` (a key of
        :data:`DECODERS`) and ``decoder_views`` (deg), which :func:`fly` loads
        (:func:`flight_decoder`), ``onboard`` (fields of
        :class:`~windnav.experiments.onboard.OnboardOptions`: ``outside``, ``wrobot_tau_s``),
        ``outside`` (``"truth"``) and ``escape`` (an :class:`~windnav.plan.EscapeConfig`).

    Raises
    ------
    ValueError
        An unknown base variant or parameter, a parameter given twice, or a value that is not a
        number >= 0 (``h`` may be ``inf``), or a number not in its shortest form (``qe=2.0``
        for ``qe=2``, ``-0`` for ``0``, ``Infinity`` for ``inf``: the label is the key of the
        flight's records, so one flight has one), or ``qe`` or ``tilt`` at the variant's own
        value (``ea-mppi-w@qe=5``, ``mppi@tilt=55``: the bare label's flight).
    """
    from windnav.experiments.navigate import POWER_SHAPES, TILT_LIMIT_DEG, TILT_MAX_DEG
    from windnav.plan import VARIANTS

    label = str(label)
    base, *params = label.split("@")

    def fail(why):
        return ValueError(f"The 'variants' parameter of {where} must be distinct names among "
                          f"{list(VARIANTS)}, or one of {list(_PARAMETRIC)} with parameters "
                          f"'@qe=Q_E', '@h=H' (m, inf, or 0 for no wind) and/or "
                          f"'@power=SHAPE' (one of {list(POWER_SHAPES)}) and/or "
                          f"'@tilt=DEG' (in (0, {TILT_LIMIT_DEG:g})) and/or "
                          f"'@energy=mission', "
                          f"'ea-mppi-w-hat@decoder=DATE' (one of {list(DECODERS)}) and/or "
                          f"'@outside=robot' and/or '@tau=S' (s, finite, > 0) and/or "
                          f"'@views=DEG' (whole degrees in (0, 45)), "
                          f"'mppi-w' or 'ea-mppi-w' with '@h=H' and '@outside=truth', or "
                          f"'ea-mppi-w-esc@esc=LENGTH' (m, finite, > 0) and/or "
                          f"'@escair=AIRSPEED' (m/s, finite, > 0), with '@edge=M' (m, > 0) and/or "
                          f"'@pace=S' (s, > 0) and/or '@regain=D' (m, > 10) and/or "
                          f"'@launch=T' (s, > 0) and/or '@gust=K' (deviations, > 0): "
                          f"{why}. Got {label!r} instead.")

    if base not in VARIANTS:
        raise fail(f"unknown variant {base!r}")
    if not params:
        return base, {}
    onboard = VARIANTS[base].wind_source == "onboard"
    if base not in _PARAMETRIC and not onboard:
        raise fail(f"{base!r} takes no parameters")
    options, overrides, escape, seen = {}, {}, {}, set()
    for item in params:
        key, sep, text = item.partition("=")
        if (not sep or key not in PARAMETERS or key in seen
                or PARAMETERS[key] in {**options, **overrides, **escape}):
            raise fail(f"bad or repeated parameter {item!r}")
        seen.add(key)
        if ((key != "energy"
             and (key in ("decoder", "tau", "views")
                  or (key == "outside" and base not in _TRUTH_FILL))
             != onboard)
                or (key in _ESCAPE_KEYS and not VARIANTS[base].escape)):
            raise fail(f"{base!r} takes no parameter {key!r}")
        if key == "outside":
            want = "robot" if onboard else "truth"
            if text != want:  # zero is the variant without the parameter: one label each
                raise fail(f"outside must be {want!r} for {base!r} (zero is the default), "
                           f"not {text!r}")
            if onboard:
                options.setdefault("onboard", {})["outside"] = "robot"
            else:
                options["outside"] = "truth"
            continue
        if key == "energy":
            if text != "mission":  # the horizon's energy is the default: one label each
                raise fail(f"energy must be 'mission' (the horizon's is the default), "
                           f"not {text!r}")
            overrides["energy_mode"] = "mission"
            continue
        if key == "decoder":
            if text not in DECODERS:
                raise fail(f"unknown decoder {text!r}")
            options["decoder"] = text
            continue
        if key == "power":
            if text not in POWER_SHAPES:
                raise fail(f"unknown power shape {text!r}")
            options["power_shape"] = text
            continue
        try:
            value = float(text)
        except ValueError:
            raise fail(f"{text!r} is not a number") from None
        if not value >= 0.0 or (key == "qe" and not math.isfinite(value)):
            raise fail(f"{key} must be >= 0")
        if text != number_label(value):
            # '@qe=2.0' and '@qe=2' fly one flight: the label is the records' key, so one form
            raise fail(f"write {key}={number_label(value)} for {key}={text} (numbers in their "
                       f"shortest form: the label is the key of the flight's records)")
        if (key, value) in (("qe", VARIANTS[base].energy_weight), ("tilt", TILT_MAX_DEG)):
            raise fail(f"{key}={text} is {base!r}'s own value: leave it out (the label without "
                       "it flies the same flight)")
        if key == "tilt":
            if not 0.0 < value < TILT_LIMIT_DEG:
                raise fail(f"tilt must be in (0, {TILT_LIMIT_DEG:g}) degrees")
            options["tilt_max_deg"] = value
        elif key == "views":
            if not (0.0 < value < VIEWS_LIMIT_DEG and value == round(value)):
                raise fail(f"views must be a whole number of degrees in "
                           f"(0, {VIEWS_LIMIT_DEG:g})")
            options["decoder_views"] = value
        elif key in _ESCAPE_KEYS or key == "tau":
            if not (0.0 < value < math.inf):
                raise fail(f"{key} must be finite and > 0")
            if key == "tau":
                options.setdefault("onboard", {})["wrobot_tau_s"] = value
            else:
                escape[PARAMETERS[key]] = value
        elif key == "qe":
            overrides["energy_weight"] = value
        elif value == 0.0:
            overrides["use_wind"] = False
        else:
            options["horizon"] = value
    if options.get("outside") == "truth" and not (0 < options.get("horizon", math.inf) < math.inf):
        raise fail("outside=truth needs a finite h > 0 (the wind window it fills around)")
    if overrides:
        options["planner_overrides"] = overrides
    if escape:
        from windnav.plan import EscapeConfig

        for name in _NEEDS_ESCAIR:
            if PARAMETERS[name] in escape and "escape_airspeed" not in escape:
                raise fail(f"{name} needs escair")
        options["escape"] = EscapeConfig(length_m=escape.get("escape", 60.0),
                                         airspeed_mps=escape.get("escape_airspeed"),
                                         edge_m=escape.get("escape_edge", 0.0),
                                         pace_margin_s=escape.get("escape_pace", 0.0),
                                         regain_m=escape.get("escape_regain", 0.0),
                                         launch_s=escape.get("escape_launch", 0.0),
                                         gust_k=escape.get("escape_gust", 0.0))
    return base, options


def number_label(value: float) -> str:
    """A variant label parameter's number in its one written form (what :func:`parse_variant`
    accepts, and what the sweeps write): the shortest that reads back as
    ``value`` (``repr``), without a trailing ``.0`` (``2``, ``0.5``, ``13.45``, ``1000``)."""
    value = float(value)
    if value == 0.0:  # -0.0 too
        return "0"
    text = repr(value)  # 'inf' for infinity, the one spelling accepted
    return text[:-2] if text.endswith(".0") else text


def check_variants(variants, where: str) -> tuple[str, ...]:
    """``variants`` (a sequence, or one comma-separated string) checked: each a key of
    :data:`windnav.plan.VARIANTS` or a label with study parameters (:func:`parse_variant`),
    distinct, at least one."""
    from windnav.plan import VARIANTS

    if isinstance(variants, str):
        variants = [v.strip() for v in variants.split(",") if v.strip()]
    variants = tuple(variants)
    if not variants or len(set(variants)) != len(variants):
        raise ValueError(f"The 'variants' parameter of {where} must be distinct names among "
                         f"{list(VARIANTS)}. Got {list(variants)!r} instead.")
    seen = {}
    for v in variants:
        parse_variant(v, where)
        base, *params = v.split("@")
        same = seen.setdefault((base, frozenset(params)), v)
        if same != v:  # the same parameters in another order: one flight, two keys
            raise ValueError(f"The 'variants' parameter of {where} names one flight twice: "
                             f"{same!r} and {v!r} set the same parameters in another order.")
    return variants


def check_maps(spec: SuiteSpec, maps, where: str) -> tuple[int, ...]:
    """``maps`` (map indices of the suite, ``spec.maps``; None: all) checked: distinct, of the
    suite, at least one; returned sorted."""
    if maps is None:
        return tuple(spec.maps)
    try:
        got = [int(m) for m in maps]
        ok = all(int(m) == m for m in maps)
    except (TypeError, ValueError):
        ok = False
    if not ok or not got or len(set(got)) != len(got) or not set(got) <= set(spec.maps):
        raise ValueError(f"The 'maps' parameter of {where} must be distinct map indices of the "
                         f"{spec.name} suite, among {list(spec.maps)}. Got {maps!r} instead.")
    return tuple(sorted(got))


def check_scenario_ids(spec: SuiteSpec, scenario_ids, where: str) -> frozenset | None:
    """``scenario_ids`` (a sequence of ids of ``spec``, at least one) as a set of their
    canonical forms (``thesis/m3/w7/p2`` is ``thesis/m03/w07/p2``), each checked with
    :func:`~windnav.experiments.nav_suite.parse_scenario_id`; None stays None (every
    scenario). (The ids were kept as given: an unpadded one passed the check and then matched
    no scenario, and the run flew nothing with exit status 0; audit, 2026-12-05.)"""
    if scenario_ids is None:
        return None
    ids = [scenario_ids] if isinstance(scenario_ids, str) else list(scenario_ids)
    if not ids:
        raise ValueError(f"The 'scenario_ids' parameter of {where} must name at least one "
                         "scenario. Got none instead.")
    with options_named({"'scenario_id' parameter of parse_scenario_id":
                        f"'scenario_ids' parameter of {where}"}):
        return frozenset(parse_scenario_id(spec, sid).scenario_id for sid in ids)


def check_wind_batch(wind_batch, where: str) -> int:
    """``wind_batch`` as an int in 1 .. :data:`~windnav.flow.solver.BITWISE_BATCH` (a larger
    batch would change the winds at round-off, and so every flight, against a replay)."""
    from windnav.flow.solver import BITWISE_BATCH

    if (isinstance(wind_batch, bool) or not isinstance(wind_batch, numbers.Integral)
            or not 1 <= wind_batch <= BITWISE_BATCH):
        raise ValueError(
            f"The 'wind_batch' parameter of {where} must be an integer from 1 to "
            f"{BITWISE_BATCH} (larger batches change the winds at round-off). "
            f"Got {wind_batch!r} instead.")
    return int(wind_batch)


def check_against_suite(spec: SuiteSpec, variants, where: str) -> None:
    """Raise before any flight for label parameters the suite's settings make invalid: a
    ``@regain`` no larger than the suite's capture radius (each flight would fail)."""
    from windnav.experiments.navigate import CAPTURE_RADIUS

    capture = float(spec.navigate_options.get("capture_radius", CAPTURE_RADIUS))
    for label in variants:
        escape = parse_variant(label, where)[1].get("escape")
        if escape is not None and escape.regain_inside(capture):
            raise ValueError(f"The 'variants' parameter of {where} must give regain larger "
                             f"than the suite's capture radius, {capture:g} m (the hold "
                             f"begins within it). Got {label!r} instead.")


def fly(spec: SuiteSpec, scenario: Scenario, variant: str, *, city, flow,
        navigate_fn: Callable | None = None):
    """The flight of one scenario with one variant, as the benchmark flies it: ``navigate``
    from the scenario's start to its goal with its seed, in ``flow``, with the suite's
    ``navigate_options`` and the variant label's study parameters (:func:`parse_variant`;
    ``planner_overrides`` of both are merged, the label's win). The onboard-stack variant flies
    :func:`benchmark_decoder` (:data:`BENCHMARK_DECODER`, or the label's ``@decoder=``) unless
    the suite names a ``decoder`` object.

    Returns
    -------
    NavigationResult
        (or whatever ``navigate_fn`` returns). Raises whatever the flight raises.
    """
    if navigate_fn is None:
        from windnav.experiments.navigate import navigate as navigate_fn
    from windnav.plan import VARIANTS

    base, options = parse_variant(variant, "fly")
    kwargs = {**spec.navigate_options, **options}
    kwargs.pop("decoder_views", None)
    if ("decoder_views" in options and "decoder" not in options
            and "decoder" in spec.navigate_options):
        raise ValueError(f"The 'variant' parameter of fly gives {variant!r}, the turned views of "
                         "a dated decoder, but the suite names its own decoder object, which "
                         "the label would replace: give that decoder its views "
                         "(load_decoder(rotations_deg=...)) in the suite, or name a dated "
                         "decoder with '@decoder='.")
    if VARIANTS[base].wind_source == "onboard":
        if "decoder" in options or "decoder_views" in options:
            kwargs["decoder"] = flight_decoder(options)
        elif "decoder" not in kwargs:
            kwargs["decoder"] = benchmark_decoder()
    if "onboard" in options and isinstance(spec.navigate_options.get("onboard"), dict):
        kwargs["onboard"] = {**spec.navigate_options["onboard"], **options["onboard"]}
    if "planner_overrides" in options and spec.navigate_options.get("planner_overrides"):
        kwargs["planner_overrides"] = {**spec.navigate_options["planner_overrides"],
                                       **options["planner_overrides"]}
    return navigate_fn(city, scenario.start, scenario.goal, speed=scenario.speed,
                       direction_deg=scenario.direction_deg, variant=base, rng=scenario.seed,
                       flow=flow, **kwargs)


def fly_scenario(spec: SuiteSpec, scenario: Scenario, variant: str, *, city=None, flow=None,
                 navigate_fn: Callable | None = None) -> dict:
    """Fly one scenario with one variant and return its record (never raises an Exception).

    Parameters
    ----------
    spec : SuiteSpec
    scenario : Scenario
    variant : str
        A key of :data:`windnav.plan.VARIANTS`, or a label with study parameters
        (:func:`parse_variant`, e.g. ``"ea-mppi-w@qe=2"``).
    city, flow : optional
        The scenario's map (:func:`suite_map`) and wind (:func:`suite_flow`), when already
        built; otherwise built here.
    navigate_fn : callable, optional
        Replaces :func:`~windnav.experiments.navigate.navigate` (same signature; its result
        needs a ``summary()``): a hook for tests and ablations.

    Returns
    -------
    dict
        :data:`RECORD_FIELDS`, :data:`ENVELOPE_FIELDS`, :data:`KERNEL_FIELDS` and
        :data:`CODE_FIELDS` (then :data:`ONBOARD_FIELDS` for
        the onboard stack, :data:`ROUTE_FIELDS` for GS and GS+W). When
        anything raised, ``outcome`` is ``"error"``, the metrics
        are None and ``error`` holds ``"Type: message"`` and the traceback.
    """
    t0 = time.perf_counter()
    rec = error_record(scenario, variant, None)
    try:
        if city is None:
            city = suite_map(spec, scenario.map_index)
        if flow is None:
            t_flow = time.perf_counter()
            flow = suite_flow(spec, city, scenario.speed, scenario.direction_deg)
            rec["flow_s"] = time.perf_counter() - t_flow
        result = fly(spec, scenario, variant, city=city, flow=flow, navigate_fn=navigate_fn)
        summary = result.summary()
        rec["outcome"] = summary["outcome"]
        rec.update({k: summary.get(k) for k in _METRICS})
        rec["loop_wall_s"] = summary.get("wall_s")
        rec.update({k: summary.get(k) for k in ENVELOPE_FIELDS})
        rec.update({k: summary[k] for k in ONBOARD_FIELDS if k in summary})
        if summary.get("diverged_s") is not None:  # the simulation's failure, not the flight's
            rec["diverged_s"] = summary["diverged_s"]  # (its warning stays in the worker)
        settings = summary.get("settings") or {}
        if "route_hold_energy_J" in settings:  # GS and GS+W
            rec.update({k: settings[k] for k in ROUTE_FIELDS})
    except Exception as exc:  # one failing flight must not stop the suite
        rec["error"] = f"{type(exc).__name__}: {exc}\n{traceback.format_exc()}"
    rec["wall_s"] = time.perf_counter() - t0
    return rec


# ------------------------------------------------------------------------------- tasks


@dataclass(frozen=True)
class GroupTask:
    """The pending flights of a few winds of one map (:func:`wind_batches`): one task, one
    simulation of its winds together. Picklable.

    Attributes
    ----------
    spec : SuiteSpec
    store : str
        Path of the store the worker appends its records to.
    map_index : int
    wind_indices : tuple of int
        The winds, whose inlets are the same sides.
    flights : tuple of (Scenario, str)
        The scenarios (of this map and these winds) and variants to fly, in order.
    navigate_fn : callable or None
        See :func:`fly_scenario` (module-level, to pickle).
    """

    spec: SuiteSpec
    store: str
    map_index: int
    wind_indices: tuple
    flights: tuple
    navigate_fn: Callable | None = None


def run_group(task: GroupTask) -> dict:
    """Simulate the task's winds once, fly each wind's flights in it, append each record to
    the store.

    Returns
    -------
    dict
        ``map_index``, ``wind_indices``, ``flights`` (flown), ``errors`` (flights whose harness
        failed), ``flow_s`` (each wind's share of the simulation's wall time, s).

    Raises
    ------
    Exception
        Whatever the map or the wind simulation raised (the caller records it for every
        flight of the task).
    """
    spec = task.spec
    city, flows, flow_s = group_winds(spec, task.map_index, task.wind_indices)
    errors = 0
    for w in task.wind_indices:
        flow = flows.pop(0)  # dropped after its flights: its frames go back to the pool
        flights = tuple(f for f in task.flights if f[0].wind_index == w)
        errors += fly_group(spec, task.store, flights, city=city, flow=flow, flow_s=flow_s,
                            navigate_fn=task.navigate_fn)
        del flow
    return {"map_index": task.map_index, "wind_indices": list(task.wind_indices),
            "flights": len(task.flights), "errors": errors, "flow_s": flow_s}


def group_wind(spec: SuiteSpec, map_index: int, wind_index: int):
    """The map and the wind of one (map, wind) of the suite, simulated in this worker with its
    :func:`worker_reuse`: ``(city, flow, flow_s)``, ``flow_s`` the simulation's wall time, s."""
    city, flows, flow_s = group_winds(spec, map_index, (wind_index,))
    return city, flows[0], flow_s


def group_winds(spec: SuiteSpec, map_index: int, wind_indices: Sequence[int]):
    """:func:`group_wind` for a batch of winds of one map whose inlets are the same sides
    (:func:`wind_batches`), simulated together: ``(city, flows, flow_s)``, ``flows`` a list
    in the order of ``wind_indices``, ``flow_s`` each wind's share of the wall time, s."""
    city = suite_map(spec, map_index)
    winds = [spec.wind(w) for w in wind_indices]
    t0 = time.perf_counter()
    flows = suite_flows(spec, city, winds, reuse=worker_reuse())
    return city, flows, (time.perf_counter() - t0) / len(winds)


def fly_group(spec: SuiteSpec, store, flights, *, city, flow, flow_s: float | None = None,
              navigate_fn: Callable | None = None) -> int:
    """Fly ``flights`` (``(Scenario, variant)`` pairs of one map and wind) in the wind
    ``flow`` already simulated, appending each record to the store at ``store`` as it lands
    (with ``flow_s``, the wind's simulation time, s). Returns the number of harness errors."""
    nav_store = NavStore(store, spec, create=False)
    errors = 0
    for scenario, variant in flights:
        rec = fly_scenario(spec, scenario, variant, city=city, flow=flow,
                           navigate_fn=navigate_fn)
        rec["flow_s"] = flow_s
        nav_store.append(rec)
        errors += rec["error"] is not None
    return errors


def error_record(scenario: Scenario, variant: str, error: str | None) -> dict:
    """The record of a flight that did not fly: ``outcome = "error"``, no metrics, ``error``
    (the traceback). Also the skeleton every record starts from (:data:`RECORD_FIELDS`)."""
    rec = dict.fromkeys(RECORD_FIELDS + ENVELOPE_FIELDS + KERNEL_FIELDS + CODE_FIELDS)
    rec.update(scenario_id=scenario.scenario_id, variant=variant, seed=scenario.seed,
               outcome=ERROR, kind=scenario.kind, speed=scenario.speed,
               direction_deg=scenario.direction_deg, map_index=scenario.map_index,
               wind_index=scenario.wind_index, pair_index=scenario.pair_index,
               start=list(scenario.start), goal=list(scenario.goal), error=error,
               code=module_key(CODE_MODULE), **arithmetic())
    return rec


def run_benchmark(
    spec,
    variants: Sequence[str] | str,
    store,
    *,
    executor: str = "process",
    workers: int | None = None,
    progress: bool = True,
    retry_errors: bool = False,
    navigate_fn: Callable | None = None,
    maps: Sequence[int] | None = None,
    scenario_ids: Sequence[str] | None = None,
    wind_batch: int = WIND_BATCH,
) -> dict:
    """Fly (or resume) every pending (scenario, variant) of the suite into ``store``.

    Parameters
    ----------
    spec : SuiteSpec or str
        The suite (a name of :data:`SUITES`: its seed 0).
    variants : sequence of str, or a comma-separated str
        Keys of :data:`windnav.plan.VARIANTS`.
    store : str or path-like
        The store folder (created with its manifest; resumed when it holds this suite).
    executor : {"serial", "process", "ray"}
        Backend of :func:`~windnav.experiments.executor.run_tasks` (one task per batch of
        winds of a map, :func:`wind_batches`; the workers append to the store, so it must be on
        a filesystem they share).
    workers : int, optional
        Worker processes (default: every core, at most one per task). Each holds the winds of
        its task (about 2.3 GB each for a 600 m map; EA-MPPI+Ŵ's workers peaked at 3.2 GB
        with one wind, 7.8 GB with three).
    progress : bool
        A progress bar over the tasks, on stderr.
    retry_errors : bool
        Also re-fly the flights whose recorded harness failed (``outcome == "error"``).
    navigate_fn : callable, optional
        See :func:`fly_scenario`.
    maps : sequence of int, optional
        Fly only the scenarios of these maps (map indices of ``spec.maps``; default all): a part
        of the suite, run now and completed later into the same store.
    scenario_ids : sequence of str, optional
        Fly only these scenarios (ids of the suite, e.g. ``"thesis/m03/w07/p2"``; with
        ``maps``, those of them on these maps): a pilot on a chosen subset, whose records are
        the suite's own (the same ids, seeds and winds).
    wind_batch : int
        Most winds a task simulates together, 1 to :data:`~windnav.flow.solver.BITWISE_BATCH`
        (default 3): one multi-column pressure solve per step instead of one per wind, 2.2 x
        less solve time per wind at 3 on the thesis maps (1.34 x less wind time), and every
        wind, so every record, the same to the bit as with 1 (which needs less memory: 3.2
        against 7.8 GB per worker). Lowered to what the memory limit allows the workers at
        once (:func:`fit_wind_batch`; not with ``ray``).

    Returns
    -------
    dict
        ``suite``, ``seed``, ``store``, ``variants``, ``maps`` (the indices flown),
        ``scenarios`` (per variant, of those maps), ``total``
        (flights of the run's variants), ``already`` (recorded before), ``now`` (recorded by
        this run), ``errors_now`` (of those, harness failures), ``pending`` (left: 0 unless
        a task was lost), ``failed_tasks`` (``map_index``, ``wind_indices``, first line of
        the error), ``wind_batch`` (the batch used: ``wind_batch`` or less, as the memory
        limit allows the workers, :func:`fit_wind_batch`) and ``wall_s``.

    Raises
    ------
    ValueError
        An unknown variant or executor; :class:`SuiteMismatchError` for a store of another
        suite; :class:`CorruptRecordError` for a corrupt record line.
    StoreBusyError
        When another run is flying any of the same variants on any of the same maps into
        ``store`` (:meth:`NavStore.claim`): the second run used to fly them all again.
    KeyboardInterrupt
        On Ctrl-C, after the workers are stopped; every finished flight is in the store.
    """
    from windnav.experiments.executor import BACKENDS

    where = "run_benchmark"
    spec = check_suite_spec(spec, where)
    variants = check_variants(variants, where)
    if executor not in BACKENDS:
        raise ValueError(f"The 'executor' parameter of {where} must be one of {BACKENDS}. "
                         f"Got {executor!r} instead.")
    maps = check_maps(spec, maps, where)
    chosen = check_scenario_ids(spec, scenario_ids, where)
    wind_batch = check_wind_batch(wind_batch, where)
    check_against_suite(spec, variants, where)
    t0 = time.perf_counter()
    nav_store = NavStore(store, spec)
    scenarios = make_suite(dataclasses.replace(spec, maps=maps))  # the same ids and seeds
    if chosen is not None:
        scenarios = [sc for sc in scenarios if sc.scenario_id in chosen]
    # claimed before the records are read: a run that ends meanwhile has recorded everything
    with nav_store.claim((v, sc.group[0]) for sc in scenarios for v in variants):
        return _run_claimed(spec, variants, nav_store, scenarios, maps, t0, executor=executor,
                            workers=workers, progress=progress, retry_errors=retry_errors,
                            navigate_fn=navigate_fn, wind_batch=wind_batch)


def _run_claimed(spec, variants, nav_store, scenarios, maps, t0, *, executor, workers,
                 progress, retry_errors, navigate_fn, wind_batch) -> dict:
    """:func:`run_benchmark` once its (variant, map) pairs are claimed."""
    from windnav.experiments.executor import run_tasks

    done = nav_store.latest()

    def finished(key) -> bool:
        rec = done.get(key)
        return rec is not None and not (retry_errors and rec["outcome"] == ERROR)

    groups: dict[tuple[int, int], list] = {}
    for sc in scenarios:
        for v in variants:
            if not finished((sc.scenario_id, v)):
                groups.setdefault(sc.group, []).append((sc, v))
    already = len(scenarios) * len(variants) - sum(len(f) for f in groups.values())
    if executor != "ray":  # ray's workers may be other machines
        batches = wind_batches(spec, groups, wind_batch)
        processes = 1 if executor == "serial" else min(workers or os.cpu_count() or 1,
                                                       max(len(batches), 1))
        wind_batch = fit_wind_batch(spec, wind_batch, processes)
    tasks = [GroupTask(spec, str(nav_store.path), m, ws,
                       tuple(f for w in ws for f in groups[(m, w)]), navigate_fn)
             for m, ws in wind_batches(spec, groups, wind_batch)]
    failed_tasks = []

    def on_result(result) -> None:
        if result.ok:
            return
        task = result.task
        recorded = nav_store.latest()
        for sc, v in task.flights:  # those its worker did not record before it failed
            key = (sc.scenario_id, v)
            if recorded.get(key) is None or recorded[key] == done.get(key):
                nav_store.append(error_record(sc, v, result.error or "task lost"))
        failed_tasks.append({"map_index": task.map_index,
                             "wind_indices": list(task.wind_indices),
                             "error": (result.error or "").splitlines()[0] if result.error
                             else "task lost"})

    for _ in run_tasks(run_group, tasks, backend=executor, workers=workers, progress=progress,
                       desc=f"benchmark-nav {spec.name}", on_result=on_result):
        pass
    pending_keys = [(sc.scenario_id, v) for f in groups.values() for sc, v in f]
    final = nav_store.latest()
    now = [final[k] for k in pending_keys if k in final and final[k] != done.get(k)]
    return {"suite": spec.name, "seed": spec.seed, "store": str(nav_store.path),
            "variants": list(variants), "maps": list(maps), "scenarios": len(scenarios),
            "total": len(scenarios) * len(variants), "already": already, "now": len(now),
            "errors_now": sum(r["outcome"] == ERROR for r in now),
            "pending": len(pending_keys) - len(now), "failed_tasks": failed_tasks,
            "wind_batch": wind_batch, "wall_s": time.perf_counter() - t0}


# ------------------------------------------------------------------------------- replay


def replay(spec, scenario_id: str, variant: str, *, navigate_fn: Callable | None = None) -> dict:
    """Re-fly one scenario from its id (its map, wind, pair and seed) and return its record.

    The wind is simulated again (35-45 s for a 600 m map on one core) exactly as a run does,
    so the record equals the recorded one in :data:`REPLAY_FIELDS` (see :func:`compare_records`).

    Raises
    ------
    ValueError
        An id that is not a scenario of ``spec`` or an unknown variant.
    """
    where = "replay"
    spec = check_suite_spec(spec, where)
    (variant,) = check_variants([variant], where)
    scenario = parse_scenario_id(spec, scenario_id)
    return fly_scenario(spec, scenario, variant, navigate_fn=navigate_fn)


def check_records(spec, recorded: Sequence[dict], *, executor: str = "process",
                  workers: int | None = None, progress: bool = True,
                  wind_batch: int = WIND_BATCH, navigate_fn: Callable | None = None) -> list:
    """Fly the ``recorded`` flights again, as a run does, and compare each with its record.

    The scenarios of the records are flown with every variant among them (one wind simulation
    per wind, as :func:`run_benchmark`) into a temporary store that is removed afterwards; a
    (scenario, variant) flown but not among ``recorded`` is not compared.

    Returns
    -------
    list of dict
        One per record, in its order (:func:`checked_flight`; ``replayed`` None when the
        flight was not flown, e.g. a lost task).
    """
    import tempfile

    spec = check_suite_spec(spec, "check_records")
    if not recorded:
        return []
    variants = list(dict.fromkeys(r["variant"] for r in recorded))
    ids = sorted({r["scenario_id"] for r in recorded})
    with tempfile.TemporaryDirectory(prefix="windnav-check-") as tmp:
        run_benchmark(spec, variants, tmp, executor=executor, workers=workers,
                      progress=progress, navigate_fn=navigate_fn, scenario_ids=ids,
                      wind_batch=wind_batch)
        flown = NavStore(tmp, spec, create=False).latest()
    return [checked_flight(rec, flown.get((rec["scenario_id"], rec["variant"])))
            for rec in recorded]


def checked_flight(recorded: dict, replayed: dict | None) -> dict:
    """One flight compared with its record: ``scenario_id``, ``variant``, the
    :data:`REPLAY_FIELDS` of ``recorded`` and ``replayed`` (None when it was not flown) and
    ``check`` (:func:`compare_records`; None then)."""
    return {"scenario_id": recorded["scenario_id"], "variant": recorded["variant"],
            "recorded": {k: recorded.get(k) for k in REPLAY_FIELDS},
            "replayed": None if replayed is None else {k: replayed.get(k) for k in REPLAY_FIELDS},
            "check": None if replayed is None else compare_records(replayed, recorded)}


def compare_records(replayed: dict, recorded: dict) -> dict:
    """How a replayed record differs from the recorded one.

    Returns
    -------
    dict
        ``same_outcome`` (bool), ``relative_difference`` {field: |a - b| / max(|b|, 1e-12)} for
        the numeric :data:`REPLAY_FIELDS`, and ``max_relative_difference``.
    """
    rel = {}
    for k in REPLAY_FIELDS[1:]:
        a, b = replayed.get(k), recorded.get(k)
        if a is None or b is None:
            rel[k] = 0.0 if a is None and b is None else math.inf
        else:
            rel[k] = abs(float(a) - float(b)) / max(abs(float(b)), 1e-12)
    return {"same_outcome": replayed.get("outcome") == recorded.get("outcome"),
            "relative_difference": rel, "max_relative_difference": max(rel.values())}

