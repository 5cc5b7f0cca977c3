"""Energy-aware MPPI: a batched sampling planner for a point mass in wind (Folk 2026, ch. 5).

Model. A point mass in the plane; state ``p~`` (position relative to the start of the planning
period, m) and ground velocity ``v`` (m/s); control ``u = a`` (m/s^2) clipped per axis to
``[a_min, a_max]``; drag ``d = -C |v_a| v_a`` with ``v_a = v - w(p~)``; forward Euler with step
``dt`` over ``N_k`` steps (:func:`rollout`). The wind is known inside ``L_t`` only
(:class:`~windnav.plan.local_wind.LocalWind`), and is zero for the variants without wind.
Euler's position trails the exact point-mass path by ``a dt^2 / 2`` per step (0.31 m at the
tilt cap and ``dt = 0.25`` s): against an RK4 solution of the same model (200 smoothed random
controls, 187 steps) it is off by a median 0.42 m after 1 s, 1.7 m at the end of the horizon
(up to 5 m; 28 m in a wind that varies along the path), with ``J_E`` 0.8 % high; the samples'
ranking holds (Spearman 0.998, the same best sample), and only the first 0.1 s of a plan is
flown before the next update (convergence audit, 2026-12-05). The benchmark's records depend on
this arithmetic, so it stays.

Cost, non-dimensionalised by the LiDAR range ``D_max`` and the hover power ``P_hover``::

    J_prog = sum_k |p~_k / D_max - g / D_max|^2     (goal g capped at radius D_max)
    J_obs  = max_k max_o D_max^2 / |p~_k - o|^2      (LiDAR points o; obstacles.py)
    J_E    = sum_k P(|v_k - w_k|) / P_hover dt        (steady-flight power curve, config.py)
    J      = J_prog + Q_O J_obs + Q_E J_E

``PlannerConfig.energy_mode = "mission"`` (ours) makes ``J_E`` the energy of the mission the
rollout starts: the sum stops once the rollout is within ``goal_radius`` of the uncapped goal,
and a rollout that does not get there adds the least energy to fly the rest of the way in the
wind at the vehicle, ``e_R (|p~_K - g| - goal_radius)`` (:meth:`PlannerConfig.energy_per_metre`).

Update (one call of :meth:`MPPIPlanner.update`, :func:`mppi_step`):

1. sample ``N_tau`` sequences: ``"gaussian"`` perturbs the previous optimal sequence with
   ``N(0, sigma_u^2)``, clips to the bounds, and smooths each sequence along time with a
   Gaussian kernel of ``sigma_gf`` steps (rows renormalised at the ends); ``"uniform"`` draws
   every control uniformly in ``[a_min, a_max]`` (thesis hardware);
2. roll out and cost every sequence in one fused Numba pass (``_kernels.rollout_cost``);
3. weight by the softmin ``w_i ∝ exp(-(J_i - min J) / lambda)`` and average the sequences;
4. apply its first control; keep the sequence, shifted by ``1 / f_plan``, as the next warm
   start.

A non-finite state returns zero acceleration (hover) and non-finite scan or wind data return
a braking command; both are counted in :attr:`MPPIPlanner.stats` and never raise.

Speed. The update runs in single-threaded Numba kernels (``cache=True``): ziggurat normals
(``_random``), perturb-clip-smooth into float32 samples laid out time-major as structure of
arrays (K, 2, S), the rollout and costs advancing all samples one step at a time (so the
dynamics vectorise), and the obstacle distance field (:mod:`windnav.plan.obstacles`).
``benchmarks/bench_mppi.py`` times it against pytorch_mppi on the same problem.
"""

from __future__ import annotations

import functools
import time
import warnings
from collections import deque
from collections.abc import Callable
from dataclasses import dataclass, field
from functools import lru_cache
from typing import NamedTuple

import numpy as np

from windnav._validate import _fail, batch_array, generator, positive_float, positive_int
from windnav.plan import _kernels as K
from windnav.plan.config import MAX_STEPS, PlannerConfig
from windnav.plan.local_wind import NO_WIND, LocalWind
from windnav.plan.obstacles import ObstacleField, obstacle_field, returns, scan_points

__all__ = [
    "MPPIPlanner",
    "PlanResult",
    "PlannerStats",
    "Problem",
    "NO_MISSION",
    "fused_rollout_cost",
    "mission_terms",
    "mppi_step",
    "rollout",
    "sample_controls",
    "shift_controls",
    "smoothing_matrix",
    "softmin_weights",
]


NO_MISSION = np.zeros(5)
NO_MISSION.setflags(write=False)
"""``Problem.mission`` of the thesis's horizon energy."""


class Problem(NamedTuple):
    """What one update plans against (all relative to the vehicle's current position).

    Attributes
    ----------
    velocity : ndarray of shape (2,)
        Ground velocity, m/s.
    goal : ndarray of shape (2,)
        Goal, m, capped at ``D_max``.
    field : ObstacleField
        Obstacle points of the scan.
    wind : tuple
        Packed wind ``(mode, grid, meta)`` (see ``_kernels``).
    mission : ndarray of shape (5,)
        ``[on, g_x, g_y, goal_radius, e_R]`` for ``energy_mode="mission"``: the uncapped goal,
        m, and the energy per metre to go, s/m (:data:`NO_MISSION`: the thesis's ``J_E``).
    """

    velocity: np.ndarray
    goal: np.ndarray
    field: ObstacleField
    wind: tuple
    mission: np.ndarray = NO_MISSION


RolloutCost = Callable[[PlannerConfig, np.ndarray, Problem], tuple[np.ndarray, np.ndarray]]
"""``(config, controls (K, 2, S), problem) -> (costs (S,), parts (S, 4))``."""


def smoothing_matrix(n_steps: int, sigma: float) -> np.ndarray:
    """Gaussian smoothing along time as a matrix ``G`` (K, K): ``U_smooth = G @ U``.

    Taps ``exp(-(i - j)^2 / (2 sigma^2))`` truncated at ``4 sigma`` and each row normalised to
    sum 1, so a constant sequence is unchanged and smoothed controls stay inside the bounds.
    ``sigma = 0`` gives the identity.

    Raises
    ------
    ValueError
        On ``n_steps`` that is not an integer in 1 .. :data:`~windnav.plan.config.MAX_STEPS`
        (the dense matrix is ``n_steps^2`` floats), or ``sigma`` below 0 or not finite.
    """
    n_steps = positive_int(n_steps, "n_steps", "smoothing_matrix")
    if n_steps > MAX_STEPS:  # 10**6 steps asked for 7.3 TiB (closure-module audit)
        raise _fail("n_steps", "smoothing_matrix", f"at most {MAX_STEPS} (the matrix is "
                    "n_steps^2 floats, PlannerConfig's longest horizon)", n_steps)
    sigma = positive_float(sigma, "sigma", "smoothing_matrix", allow_zero=True)  # NaN: NaN G
    k = np.arange(n_steps)
    if sigma == 0:
        return np.eye(n_steps)
    d = k[:, None] - k[None, :]
    g = np.exp(-0.5 * (d / sigma) ** 2) * (np.abs(d) <= 4.0 * sigma + 1e-9)
    return g / g.sum(axis=1, keepdims=True)


@lru_cache(maxsize=16)
def _smoothing_bands(n_steps: int, sigma: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(taps, lo, hi)`` of the banded :func:`smoothing_matrix` for the kernel."""
    g = smoothing_matrix(n_steps, sigma)
    nz = g != 0
    lo = nz.argmax(axis=1)
    hi = g.shape[1] - nz[:, ::-1].argmax(axis=1)
    taps = np.zeros((g.shape[0], int((hi - lo).max())), np.float32)
    for k in range(g.shape[0]):
        taps[k, :hi[k] - lo[k]] = g[k, lo[k]:hi[k]]
    return taps, lo.astype(np.int64), hi.astype(np.int64)


def shift_controls(controls, steps: float) -> np.ndarray:
    """The sequence advanced by ``steps`` (fractional) model steps, the last control held.

    ``out[k] = controls(k + steps)`` by linear interpolation in time; ``controls`` is a finite
    (K, 2) sequence, K >= 1, m/s^2, and ``steps >= 0``.

    Raises
    ------
    ValueError
        On ``controls`` of another shape or with NaN or inf, or a negative or NaN ``steps``.
    """
    where = "shift_controls"
    try:
        u = np.asarray(controls, dtype=np.float64)
    except (TypeError, ValueError):
        u = None
    if u is None or u.ndim != 2 or u.shape[0] < 1 or u.shape[1] != 2:
        raise ValueError(f"The 'controls' parameter of {where} must be an array of shape (K, 2) "
                         f"with K >= 1, m/s^2. Got shape {np.shape(controls)} instead.")
    if not np.isfinite(u).all():  # NaN or inf came back as a NaN warm start
        raise ValueError(f"The 'controls' parameter of {where} must be finite. Got non-finite "
                         "entries instead.")
    return _shift(u, positive_float(steps, "steps", where, allow_zero=True))


def _shift(controls: np.ndarray, steps: float) -> np.ndarray:
    """:func:`shift_controls` without the checks, for the planner's own (K, 2) finite plan
    (once per update: the checks would cost more than the shift of a short horizon)."""
    i, j, a = _shift_weights(controls.shape[0], float(steps))
    return (1.0 - a) * controls[i] + a * controls[j]


@lru_cache(maxsize=16)
def _shift_weights(n: int, steps: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    # checked here, once per cached value: a negative shift rotated the sequence (negative
    # indices wrap), NaN was an IndexError of index -9.2e18
    positive_float(steps, "steps", "shift_controls", allow_zero=True)
    t = np.minimum(np.arange(n) + steps, n - 1)
    i = np.minimum(np.floor(t).astype(int), max(n - 2, 0))
    j = np.minimum(i + 1, n - 1)
    a = (t - i)[:, None] if n > 1 else np.zeros((n, 1))
    for arr in (i, j, a):
        arr.setflags(write=False)   # cached: shared by every call
    return i, j, a


def _chunks(n_samples: int, threads: int) -> np.ndarray:
    """The bounds of ``threads`` near-equal chunks of the samples, int64 (threads + 1,)."""
    return np.array([n_samples * c // threads for c in range(threads + 1)], dtype=np.int64)


def _threads(threads, config: PlannerConfig, where: str) -> int:
    """``threads`` checked: a positive int, at most the config's ``n_samples``."""
    threads = positive_int(threads, "threads", where)
    if threads > config.n_samples:
        raise ValueError(f"The 'threads' parameter of {where} must be at most n_samples "
                         f"({config.n_samples}). Got {threads} instead.")
    return threads


def sample_controls(config: PlannerConfig, mean: np.ndarray, *, rng: np.random.Generator,
                    out: np.ndarray | None = None, work: np.ndarray | None = None,
                    threads: int = 1) -> np.ndarray:
    """Draw ``N_tau`` control sequences, (K, 2, S) float32 (time-major, structure of arrays
    for the kernels), m/s^2.

    ``"gaussian"``: ``G @ clip(mean + sigma_u eps)`` with ``G`` the :func:`smoothing_matrix`
    of ``sigma_gf`` and ``eps`` standard normals (a ziggurat seeded by one draw of ``rng``,
    ``windnav.plan._random``); ``"uniform"``: ``U[a_min, a_max]`` per axis and step. The
    samples are float32 (planning tensors may be, DESIGN.md); the kernels clip them to the
    float64 bounds again. ``out`` and ``work`` (float32 buffers of that shape) are reused when
    given. ``threads`` > 1 draws ``"gaussian"`` samples in that many chunks on Numba's
    threads, chunk ``c`` from its own stream (``threads`` draws of ``rng``): as random, but
    not the numbers of ``threads = 1``, whose stream the benchmark's records were flown with.

    Raises
    ------
    ValueError
        On a ``mean`` that is not (K, 2), or buffers of another shape or type (the kernel
        would read or write past their ends).
    """
    shape = (config.n_steps, 2, config.n_samples)
    if np.shape(mean) != shape[:2]:
        raise ValueError(f"The 'mean' parameter of sample_controls must have shape "
                         f"(n_steps, 2) = {shape[:2]}. Got {np.shape(mean)} instead.")
    for name, buf in (("out", out), ("work", work)):
        if buf is not None and (buf.shape != shape or buf.dtype != np.float32):
            raise ValueError(f"The {name!r} parameter of sample_controls must be a float32 "
                             f"array of shape {shape}. Got {buf.dtype} {buf.shape} instead.")
    threads = _threads(threads, config, "sample_controls")
    out = np.empty(shape, np.float32) if out is None else out
    if config.sampling == "uniform":
        rng.random(dtype=np.float32, out=out)
        out *= np.float32(config.a_max - config.a_min)
        out += np.float32(config.a_min)
        return out
    clipped = work if work is not None else np.empty(shape, np.float32)
    taps, lo, hi = _smoothing_bands(config.n_steps, config.sigma_gf)
    mean = np.ascontiguousarray(mean, dtype=np.float64)
    if threads == 1:
        K.perturb_clip_smooth(rng.integers(0, 2**64, dtype=np.uint64), clipped, mean,
                              config.sigma_u, config.a_min, config.a_max, taps, lo, hi, out)
    else:
        K.perturb_clip_smooth_chunks(rng.integers(0, 2**64, size=threads, dtype=np.uint64),
                                     clipped, mean, config.sigma_u, config.a_min, config.a_max,
                                     taps, lo, hi, out, _chunks(config.n_samples, threads))
    return out


def softmin_weights(costs: np.ndarray, temperature: float) -> np.ndarray:
    """``w_i = exp(-(J_i - min J) / lambda) / sum`` of the costs (S,); non-finite costs get
    weight 0.

    Returns all zeros when no cost is finite. Float costs keep their precision; integer ones
    are weighted in float64.

    Raises
    ------
    ValueError
        On costs that are not a 1-D array of numbers, or a temperature that is not > 0.
    """
    temperature = positive_float(temperature, "temperature", "softmin_weights")  # 0: NaN
    costs = np.asarray(costs)
    if costs.ndim != 1 or costs.dtype.kind not in "biuf":  # (S, 2) was weighted as 2 S samples
        raise ValueError("The 'costs' parameter of softmin_weights must be a 1-D array of "
                         f"numbers (S,). Got shape {costs.shape} of {costs.dtype} instead.")
    if costs.dtype.kind != "f":  # integer costs got integer weights: all 0
        costs = costs.astype(np.float64)
    ok = np.isfinite(costs)
    w = np.zeros_like(costs)
    if not ok.any():
        return w
    c = costs[ok]
    e = np.exp(-(c - c.min()) / temperature)
    w[ok] = e / e.sum()
    return w


def _check_config(config, where: str) -> None:
    if not isinstance(config, PlannerConfig):
        raise ValueError(f"The 'config' parameter of {where} must be a PlannerConfig. Got "
                         f"{type(config).__name__} instead.")


def _misshapen(problem: Problem) -> bool:
    """Whether ``problem``'s arrays are not the shapes the rollout kernel reads by index."""
    return (len(problem.wind) != 3 or np.shape(problem.wind[2]) != (7,)
            or np.shape(problem.velocity) != (2,) or np.shape(problem.goal) != (2,)
            or np.shape(problem.mission) != (5,))


def fused_rollout_cost(config: PlannerConfig, controls: np.ndarray, problem: Problem,
                       threads: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """Costs (S,) and their parts (S, 4) ``[J_prog, J_obs, J_E, d_min (m)]`` of the
    sequences ``controls`` (K, 2, S): the fused Numba rollout and cost (``threads`` > 1: in
    that many chunks of the samples on Numba's threads, the same numbers to the bit).

    Raises
    ------
    ValueError
        On ``controls`` that are not an array of shape (K, 2, S), or a ``problem`` whose
        arrays have other shapes than :class:`Problem`'s (the kernel reads them by index).
    """
    where = "fused_rollout_cost"
    _check_config(config, where)
    if not isinstance(controls, np.ndarray) or controls.ndim != 3 or controls.shape[1] != 2:
        # (K, 3, S) and (K, 1, S) gave plausible costs of other controls (closure-module audit)
        raise ValueError(f"The 'controls' parameter of {where} must be a NumPy array of shape "
                         f"(K, 2, S), m/s^2. Got {type(controls).__name__} of shape "
                         f"{np.shape(controls)} instead.")
    if not isinstance(problem, Problem):
        raise ValueError(f"The 'problem' parameter of {where} must be a Problem. Got "
                         f"{type(problem).__name__} instead.")
    if _misshapen(problem) or not isinstance(problem.field, ObstacleField):  # a velocity (1,)
        # was read past
        raise ValueError(f"The 'problem' parameter of {where} must hold velocity (2,), goal "
                         "(2,), an ObstacleField, wind (mode, grid, meta (7,)) as LocalWind.pack "
                         f"gives and mission (5,). Got velocity {np.shape(problem.velocity)}, "
                         f"goal {np.shape(problem.goal)}, {type(problem.field).__name__}, wind "
                         f"of {len(problem.wind)} and mission {np.shape(problem.mission)} "
                         "instead.")
    return _fused_rollout_cost(config, controls, problem, threads)


def _fused_rollout_cost(config: PlannerConfig, controls: np.ndarray, problem: Problem,
                        threads: int = 1) -> tuple[np.ndarray, np.ndarray]:
    """:func:`fused_rollout_cost` without the checks of its arguments: the planner's default
    ``rollout_cost``, whose arguments :func:`mppi_step` has checked (nothing added to the
    update's path)."""
    s = controls.shape[2]
    costs = np.empty(s)
    parts = np.empty((s, 4))
    mode, grid, meta = problem.wind
    f = problem.field
    args = (controls, problem.velocity, problem.goal, config.dt, config.drag,
            1.0 / config.lidar_range, config.a_min, config.a_max, config.obstacle_weight,
            config.energy_weight, config.power_table(), problem.mission,
            mode, grid, meta, not f.empty, *f.kernel_args(), costs, parts)
    threads = positive_int(threads, "threads", "fused_rollout_cost")
    if threads == 1 or s == 0:  # no samples: nothing to chunk
        K.rollout_cost(*args)
    else:  # (more threads than samples: one sample each)
        K.rollout_cost_chunks(*args, _chunks(s, min(threads, s)))
    return costs, parts


def rollout(config: PlannerConfig, controls, velocity, wind: LocalWind | None = None
            ) -> tuple[np.ndarray, np.ndarray]:
    """States of the point-mass model under control sequences.

    Parameters
    ----------
    config : PlannerConfig
        Model constants (``dt``, ``drag``, bounds, ``horizon``; the wind is used only when
        ``config.use_wind``).
    controls : array_like of shape (S, K, 2) or (K, 2)
        Accelerations, m/s^2 (clipped to the bounds).
    velocity : array_like of shape (2,)
        Initial ground velocity, m/s.
    wind : LocalWind, optional

    Returns
    -------
    positions, velocities : ndarray of shape (S, K + 1, 2)
        Relative to the start (``positions[:, 0] = 0``), m and m/s.

    Raises
    ------
    ValueError
        On a ``config`` that is not a PlannerConfig, ``controls`` of another shape, a
        ``velocity`` that is not 2 finite numbers, or a ``wind`` that is not a LocalWind.
    """
    where = "rollout"
    _check_config(config, where)  # None was an AttributeError on config.use_wind
    try:
        u = np.asarray(controls, dtype=np.float64)
    except (TypeError, ValueError):
        u = None
    if u is None or u.ndim not in (2, 3) or u.shape[-1] != 2:  # a last axis of 1 or 3 was
        # read as 2 columns, past the array's end or dropping the third (closure-module audit)
        raise ValueError(f"The 'controls' parameter of {where} must be an array of shape "
                         f"(S, K, 2) or (K, 2), m/s^2. Got shape {np.shape(controls)} instead.")
    if u.ndim == 2:
        u = u[None]
    u = np.ascontiguousarray(u.transpose(1, 2, 0))
    v0 = batch_array(velocity, "velocity", "rollout", (2,), batch=1)[0]
    mode, grid, meta = _pack_wind(config, wind)
    s, k = u.shape[2], u.shape[0]
    pos = np.empty((s, k + 1, 2))
    vel = np.empty((s, k + 1, 2))
    K.rollout_states(u, v0, config.dt, config.drag, config.a_min, config.a_max, mode, grid,
                     meta, pos, vel)
    return pos, vel


def mission_terms(config: PlannerConfig, goal: np.ndarray, packed_wind: tuple) -> np.ndarray:
    """``Problem.mission`` for ``energy_mode="mission"``: ``[1, g_x, g_y, goal_radius, e_R]``
    with ``goal`` (2,) the uncapped goal relative to the vehicle, m, and ``e_R`` the least
    energy per metre towards it in the packed wind at the vehicle (``(0, 0)`` is the vehicle),
    s/m (:meth:`PlannerConfig.energy_per_metre`)."""
    w0 = K.wind_at(0.0, 0.0, *packed_wind)
    e_r = config.energy_per_metre(goal, w0) if np.any(goal) else 0.0
    return np.array([1.0, goal[0], goal[1], config.goal_radius, e_r])


def _pack_wind(config: PlannerConfig, wind: LocalWind | None) -> tuple:
    if wind is not None and not isinstance(wind, LocalWind):  # an AttributeError on pack
        raise ValueError("The 'wind' parameter of rollout must be a LocalWind or None. Got "
                         f"{type(wind).__name__} instead.")
    if not config.use_wind or wind is None:
        return NO_WIND
    return wind.pack(config.horizon)


def mppi_step(config: PlannerConfig, mean: np.ndarray, problem: Problem, *,
              rng: np.random.Generator, rollout_cost: RolloutCost = fused_rollout_cost,
              workspace: tuple | None = None, profile: dict | None = None,
              threads: int = 1) -> dict:
    """One MPPI update (pure apart from ``rng`` and ``workspace``): sample, roll out and cost,
    reweight.

    Parameters
    ----------
    config : PlannerConfig
    mean : ndarray of shape (K, 2)
        Warm start (the previous optimal sequence, already shifted), m/s^2.
    problem : Problem
    rng : numpy.random.Generator, keyword-only (required)
    rollout_cost : callable, optional
        ``(config, controls (K, 2, S), problem) -> (costs (S,), parts (S, 4))``.
    workspace : tuple of ndarray, optional
        Float32 buffers ``(samples, clipped)``, each (K, 2, S), reused across updates.
    profile : dict, optional
        Filled with the milliseconds of ``sampling``, ``rollout_cost`` and ``update``.
    threads : int
        Chunks of the samples drawn on Numba's threads (:func:`sample_controls`); the
        rollout's threads are ``rollout_cost``'s (:class:`MPPIPlanner` gives both).

    Returns
    -------
    dict
        ``controls`` (K, 2) the weighted mean, ``costs`` (S,), ``parts`` (S, 4), ``weights``
        (S,), ``samples`` (K, 2, S) (the workspace's buffer when one is given) and ``ok``
        (False when no sample had a finite cost).
    """
    t0 = time.perf_counter()
    if _misshapen(problem):  # the kernel reads them by index
        raise ValueError("The 'problem' parameter of mppi_step must hold velocity (2,), goal "
                         "(2,), mission (5,) and wind (mode, grid, meta (7,)) as LocalWind.pack "
                         f"gives. Got {problem!r} instead.")
    u = sample_controls(config, mean, rng=rng, out=None if workspace is None else workspace[0],
                        work=None if workspace is None else workspace[1], threads=threads)
    t1 = time.perf_counter()
    costs, parts = rollout_cost(config, u, problem)
    t2 = time.perf_counter()
    w = np.empty(costs.size)
    new = mean.copy()
    ok = bool(K.softmin_mean(costs, config.temperature, u, w, new))
    t3 = time.perf_counter()
    if profile is not None:
        profile.update(sampling=1e3 * (t1 - t0), rollout_cost=1e3 * (t2 - t1),
                       update=1e3 * (t3 - t2))
    return {"controls": new, "costs": costs, "parts": parts, "weights": w, "samples": u,
            "ok": ok}


class PlanResult(NamedTuple):
    """The plan of the last update, in the world frame.

    Attributes
    ----------
    controls : ndarray of shape (K, 2)
        Optimal accelerations, m/s^2.
    positions, velocities : ndarray of shape (K + 1, 2)
        Its rollout from the vehicle's state, m and m/s (world).
    cost_parts : ndarray of shape (4,)
        ``[J_prog, J_obs, J_E, d_min]`` of the lowest-cost sample.
    """

    controls: np.ndarray
    positions: np.ndarray
    velocities: np.ndarray
    cost_parts: np.ndarray


TIMES_KEPT = 100_000
"""Update times a :class:`PlannerStats` keeps: 2.8 h at 10 Hz, more than any flight the
package simulates (a benchmark flight makes at most 2,500 updates)."""


@dataclass
class PlannerStats:
    """Counters and timings of a planner.

    Attributes
    ----------
    updates : int
        Calls of ``update``.
    fallbacks : int
        Updates that returned hover or braking instead of a plan.
    reasons : dict of str to int
        Fallbacks by cause: ``"state"``, ``"scan"``, ``"contact"`` (a scan of zeros),
        ``"wind"``, ``"costs"``.
    profile_ms : dict of str to float
        The last planned update's ``obstacles`` (scan to distance field), ``sampling``,
        ``rollout_cost`` (the fused rollout and cost), ``update`` (weights, mean, warm start)
        and ``total``, ms.
    profile_sum_ms : dict of str to float
        The same, summed over all planned updates (see :meth:`mean_profile_ms`).
    total_ms : collections.deque of float
        Duration of each of the last :data:`TIMES_KEPT` updates, ms (fallbacks included): a
        planner that runs for hours keeps a bounded record (a list grew by 1.2 MB an hour at
        10 Hz, long-run audit).
    """

    updates: int = 0
    fallbacks: int = 0
    reasons: dict = field(default_factory=dict)
    profile_ms: dict = field(default_factory=dict)
    profile_sum_ms: dict = field(default_factory=dict)
    total_ms: deque = field(default_factory=lambda: deque(maxlen=TIMES_KEPT))

    def median_ms(self) -> float:
        """Median update time over :attr:`total_ms`, ms (nan before the first update)."""
        return float(np.median(self.total_ms)) if self.total_ms else float("nan")

    def mean_profile_ms(self) -> dict:
        """Mean of each part of :attr:`profile_ms` over the planned updates, ms."""
        n = self.updates - self.fallbacks
        return {k: v / n for k, v in self.profile_sum_ms.items()} if n else {}


class MPPIPlanner:
    """MPPI planner: a thin shell holding the warm start, the goal, the RNG and statistics.

    Parameters
    ----------
    config : PlannerConfig
        From :func:`windnav.plan.planner_config`.
    goal_xy : array_like of shape (2,), optional
        Goal in the world frame, m (or :meth:`set_goal` later).
    rng : numpy.random.Generator or int or None, keyword-only
        Sampling noise (None: fresh entropy).
    rollout_cost : callable, optional
        Injected ``(config, controls (K, 2, S), problem) -> (costs, parts)``; default the fused
        Numba kernel.
    threads : int
        Chunks of the samples drawn, and rolled out by the default ``rollout_cost``, on
        Numba's threads (default 1, the benchmark's). The rollout gives the same costs at any
        count; the samples of 2 or more come from other streams than those of 1 (as random),
        so a flight is reproducible at its own thread count. On the 2-core AMD EPYC, 2 threads
        took a 1000 x 25 update from 0.54-0.58 to 0.49-0.52 ms, and to 0.39 ms with
        ``OMP_WAIT_POLICY=ACTIVE`` (``benchmarks/bench_mppi.py``, ``docs/benchmarks.md``); at the
        default 100 x 187 they are slower than one (0.41 against 0.31 ms, an audit on a loaded
        machine), and more threads than cores gain nothing. Fixed at construction (read-only).
        Numba's threads come from its threading layer: under GNU OpenMP (the layer picked
        where ``libgomp`` is installed) a process that has used them cannot ``fork`` (a forked
        worker that plans with them is killed: use a ``spawn`` pool, as windnav's executors
        do), and under the ``workqueue`` fallback two Python threads running such planners at
        once abort the process (thread audit, 2026-12-05).

    Examples
    --------
    >>> planner = MPPIPlanner(planner_config(params, "ea-mppi"), goal_xy=(500, 300), rng=0)
    >>> accel = planner.update([x, y, vx, vy], city.lidar([x, y])[0])   # every 0.1 s
    """

    @property
    def threads(self) -> int:
        """The thread count, fixed at construction: the default rollout was built with it, so
        changing it afterwards would leave sampling and rollout on different counts."""
        return self._threads

    def __init__(self, config: PlannerConfig, goal_xy=None, *,
                 rng: np.random.Generator | int | None = None,
                 rollout_cost: RolloutCost | None = None, threads: int = 1):
        if not isinstance(config, PlannerConfig):
            raise ValueError("The 'config' parameter of MPPIPlanner must be a PlannerConfig. "
                             f"Got {type(config).__name__} instead.")
        if config.planner != "mppi":
            raise ValueError("The 'config' parameter of MPPIPlanner must have an MPPI variant. "
                             f"Got variant {config.variant!r} instead.")
        self.config = config
        self.rng = generator(rng, "rng", "MPPIPlanner")
        self._threads = _threads(threads, config, "MPPIPlanner")
        if rollout_cost is None:
            rollout_cost = (_fused_rollout_cost if self._threads == 1 else
                            functools.partial(_fused_rollout_cost, threads=self._threads))
        elif not callable(rollout_cost):  # a TypeError at the first update
            raise ValueError("The 'rollout_cost' parameter of MPPIPlanner must be callable "
                             "(config, controls, problem) -> (costs, parts) or None. Got "
                             f"{type(rollout_cost).__name__} instead.")
        self.rollout_cost = rollout_cost
        self.goal = None if goal_xy is None else self._goal(goal_xy)
        shape = (config.n_steps, 2, config.n_samples)
        self._work = (np.empty(shape, np.float32), np.empty(shape, np.float32))
        self.stats = PlannerStats()
        self._warned_no_wind = False
        self.reset()

    @staticmethod
    def _goal(goal_xy) -> np.ndarray:
        return batch_array(goal_xy, "goal_xy", "MPPIPlanner", (2,), batch=1)[0].copy()

    def set_goal(self, goal_xy) -> None:
        """Set the goal, world frame, m."""
        self.goal = self._goal(goal_xy)

    def reset(self) -> None:
        """Forget the warm start (zeros) and the last plan; keep the goal and the stats."""
        self.mean = np.zeros((self.config.n_steps, 2))
        self._last = None

    # ------------------------------------------------------------------------------------
    def update(self, state, scan=None, wind: LocalWind | None = None) -> np.ndarray:
        """Plan from ``state`` and return the acceleration command, m/s^2, world (2,).

        Parameters
        ----------
        state : array_like of shape (4,) or VehicleState-like
            ``[x, y, v_x, v_y]`` (m, m/s, world), or an object with ``position`` and
            ``velocity`` arrays (the first row's x and y are used).
        scan : array_like, optional
            LiDAR: ranges (n_rays,) of one scan (ray k at ``2 pi k / n_rays``; readings at or
            beyond ``lidar_range`` are no return; ``City.lidar``'s (1, n_rays) too), or points
            (P, 2) relative to the vehicle, m. None: no obstacles.
        wind : LocalWind, optional
            The local wind estimate (used only by the variants with wind; such a variant given
            None plans in still air, with a RuntimeWarning the first time).

        Returns
        -------
        ndarray of shape (2,)
            Acceleration, m/s^2, inside ``[a_min, a_max]``. Zero (hover) when the state is not
            finite; braking ``clip(-v / dt)`` when the scan, the wind or every sampled cost is
            not finite, and when the scan reads 0 on every ray (``City.lidar``'s reading on or
            inside a building: no direction to plan in; every sample paid the same obstacle
            cost and the plan ignored the wall).

        Raises
        ------
        ValueError
            With no goal set; on a state of another shape or of more than one vehicle; on a
            scan of another shape or with a range below 0.
        """
        if self.goal is None:
            raise ValueError("The 'goal_xy' of MPPIPlanner must be set (constructor or "
                             "set_goal) before update. Got None instead.")
        t0 = time.perf_counter()
        cfg = self.config
        self.stats.updates += 1
        pos, vel = _state_xy(state)
        if not (np.all(np.isfinite(pos)) and np.all(np.isfinite(vel))):
            return self._fallback("state", np.zeros(2), t0)
        points = _scan_to_points(scan, cfg.lidar_range)
        if points is None:
            return self._fallback("scan", self._brake(vel), t0)
        if points is _CONTACT:
            return self._fallback("contact", self._brake(vel), t0)
        if cfg.use_wind and wind is not None and not (isinstance(wind, LocalWind)
                                                      and wind.finite):
            if not isinstance(wind, LocalWind):
                raise ValueError("The 'wind' parameter of MPPIPlanner.update must be a "
                                 f"LocalWind or None. Got {type(wind).__name__} instead.")
            return self._fallback("wind", self._brake(vel), t0)
        if cfg.use_wind and wind is None and not self._warned_no_wind:
            # a wind-aware variant given no wind plans in still air: say so once (API audit,
            # 2026-12-05: EA-MPPI+W's first command was [5.76, -0.31] without the wind given,
            # [1.11, 1.09] with it, and nothing told them apart)
            self._warned_no_wind = True
            warnings.warn("MPPIPlanner.update: the planner's config uses the wind (use_wind) "
                          "but no 'wind' was given, so it plans in still air; pass a LocalWind "
                          "(e.g. windnav.plan.LocalWind.grid or navigate's local_wind), or use "
                          "a variant without wind. (Said once per planner.)", RuntimeWarning,
                          stacklevel=2)
        goal = self.goal - pos
        dist = float(np.hypot(*goal))
        packed = _pack_wind(cfg, wind)
        mission = (mission_terms(cfg, goal, packed) if cfg.energy_mode == "mission"
                   else NO_MISSION)
        if dist > cfg.lidar_range:
            goal *= cfg.lidar_range / dist
        field_ = obstacle_field(points, resolution=cfg.obstacle_resolution)
        t1 = time.perf_counter()
        problem = Problem(vel, goal, field_, packed, mission)
        prof: dict = {}
        out = mppi_step(cfg, self.mean, problem, rng=self.rng, rollout_cost=self.rollout_cost,
                        threads=self.threads,
                        workspace=self._work, profile=prof)
        if not out["ok"]:
            return self._fallback("costs", self._brake(vel), t0)
        controls = out["controls"]
        self._last = (controls.copy(), pos.copy(), vel.copy(), problem.wind,
                      out["parts"][int(np.argmin(out["costs"]))].copy())
        self.mean = _shift(controls, 1.0 / (cfg.rate_hz * cfg.dt))
        total = 1e3 * (time.perf_counter() - t0)
        self.stats.profile_ms = {"obstacles": 1e3 * (t1 - t0), **prof, "total": total}
        for key, value in self.stats.profile_ms.items():
            self.stats.profile_sum_ms[key] = self.stats.profile_sum_ms.get(key, 0.0) + value
        self.stats.total_ms.append(total)
        return controls[0].copy()

    def plan(self) -> PlanResult | None:
        """The last update's plan in the world frame (None before the first good update)."""
        if self._last is None:
            return None
        controls, pos, vel, wind, parts = self._last
        u = np.ascontiguousarray(controls[:, :, None])
        k = controls.shape[0]
        p = np.empty((1, k + 1, 2))
        v = np.empty((1, k + 1, 2))
        mode, grid, meta = wind
        K.rollout_states(u, vel, self.config.dt, self.config.drag, self.config.a_min,
                         self.config.a_max, mode, grid, meta, p, v)
        # copies: a caller writing the result must not change the next plan()
        return PlanResult(controls.copy(), p[0] + pos, v[0], parts.copy())

    # ------------------------------------------------------------------------------------
    def _brake(self, vel: np.ndarray) -> np.ndarray:
        if not np.all(np.isfinite(vel)):
            return np.zeros(2)
        return np.clip(-vel / self.config.dt, self.config.a_min, self.config.a_max)

    def _fallback(self, reason: str, accel: np.ndarray, t0: float) -> np.ndarray:
        self.stats.fallbacks += 1
        self.stats.reasons[reason] = self.stats.reasons.get(reason, 0) + 1
        self.stats.total_ms.append(1e3 * (time.perf_counter() - t0))
        return accel


def _state_xy(state) -> tuple[np.ndarray, np.ndarray]:
    if hasattr(state, "position") and hasattr(state, "velocity"):
        p = np.asarray(state.position, dtype=np.float64).reshape(-1, np.shape(state.position)[-1])
        v = np.asarray(state.velocity, dtype=np.float64).reshape(-1, np.shape(state.velocity)[-1])
        if len(p) != 1 or len(v) != 1 or p.shape[1] < 2 or v.shape[1] < 2:
            raise ValueError("The 'state' parameter of MPPIPlanner.update must be one vehicle's "
                             f"state. Got position {p.shape} and velocity {v.shape} instead.")
        return p[0, :2].copy(), v[0, :2].copy()
    s = np.asarray(state, dtype=np.float64)
    if s.shape not in ((4,), (1, 4)):
        raise ValueError("The 'state' parameter of MPPIPlanner.update must be [x, y, vx, vy] or "
                         f"have position and velocity. Got shape {np.shape(state)} instead.")
    s = s.reshape(4)
    return s[:2].copy(), s[2:].copy()


_CONTACT = np.zeros((0, 2))
"""What :func:`_scan_to_points` returns for ranges that are all zero (the vehicle in contact)."""


def _scan_to_points(scan, lidar_range: float) -> np.ndarray | None:
    """Points (P, 2) relative to the vehicle, None when the scan holds non-finite values, or
    :data:`_CONTACT` for ranges that are all zero."""
    if scan is None:
        return np.zeros((0, 2))
    a = np.asarray(scan, dtype=np.float64)
    if not np.all(np.isfinite(a)):
        return None
    if a.ndim == 2 and a.shape[0] == 1 and a.shape[1] != 2:
        a = a[0]  # City.lidar's batch of one scan, (1, n_rays), taken as written (API audit)
    if a.ndim == 1:
        if (a < 0).any():
            raise ValueError("The 'scan' parameter of MPPIPlanner.update must hold ranges >= 0, "
                             f"m. Got {a.min()!r} instead.")
        if a.size == 0:  # scan_points names an empty scan
            return scan_points(a, max_range=lidar_range)
        if a[0] == 0.0 and not a.any():  # the first ray first: one read in a normal scan
            return _CONTACT
        return returns(a, lidar_range)  # checked here: scan_points would check the signs again
    if a.ndim == 2 and a.shape[1] == 2:
        return a
    raise ValueError("The 'scan' parameter of MPPIPlanner.update must be ranges (n_rays,) or "
                     f"points (P, 2). Got shape {a.shape} instead.")
