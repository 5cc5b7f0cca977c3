"""The closed loop of a flight: setup once, then a pure step ``LoopState -> LoopState``.

One physics step from ``t = k dt`` (:func:`closed_loop_step`) is :func:`observe` -- the wind at
the vehicles and, on a control tick, the trajectory's target and a new rotor-speed command,
clipped to the rotor limits -- then :func:`advance`, the dynamics over ``dt`` with the held
command. Nothing is mutated: each returns a new state.

No exception is raised inside the loop for one vehicle (STYLE principle 8): a vehicle whose
wind, command or next state is not finite is frozen at its last finite state and its step kept
in ``LoopState.failed_step``; the kernels run row by row, so the rest of the batch flies on
exactly as it would without it. Configuration errors (rates, a wind of the wrong shape) raise
a ValueError naming the parameter.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from windnav._jit import njit
from windnav._validate import positive_float, positive_int
from windnav.control.se3 import SE3Controller
from windnav.vehicle import layout
from windnav.vehicle.multirotor import Multirotor
from windnav.vehicle.params import MultirotorParams
from windnav.vehicle.rotation import quat_to_matrix

DEFAULT_CONTROL_RATE_HZ = 100.0
"""Controller rate when ``fly`` is given none, Hz (lowered to divide a slower physics rate)."""

_WHERE = "fly"


def steps_per_sample(rate_hz: float, dt: float, what: str) -> int:
    """Physics steps per sample of a component running at ``rate_hz``; ``what`` names it in
    the ValueError raised when the rate is not a whole number of steps."""
    ratio = 1.0 / (rate_hz * dt)
    k = round(ratio)
    if k < 1 or abs(ratio - k) > 1e-6 * ratio:
        raise ValueError(f"The {what} of {_WHERE} must divide the physics rate 1/dt = "
                         f"{1 / dt:g} Hz (a whole number of physics steps per sample). "
                         f"Got {rate_hz:g} Hz instead.")
    return k


def fitted_rate(rate_hz: float, dt: float) -> float:
    """The highest rate at or below ``rate_hz`` (Hz) that is a whole number of ``dt`` steps."""
    return 1.0 / (dt * max(1, math.ceil(1.0 / (rate_hz * dt) - 1e-9)))


@dataclass(frozen=True, eq=False)
class ClosedLoop:
    """Everything a closed-loop step needs, resolved once (see :func:`make_closed_loop`).

    Attributes
    ----------
    model : Multirotor
    controller : object
        ``track(x, pos, vel, acc, yaw, yaw_rate) -> (rotor_speed_cmd (B, N), wrench (B, 4))``.
    trajectory : callable
        ``trajectory(t) -> FlatOutput``.
    wind : WindField
    dt : float
        Physics step, s.
    control_every : int
        Physics steps per controller update.
    hub_wind : bool
        Wind sampled at every rotor hub rather than at the centre of mass.
    batch : int
        Number of vehicles B.
    """

    model: Multirotor
    controller: object
    trajectory: object
    wind: object
    dt: float
    control_every: int
    hub_wind: bool
    batch: int
    # resolved from the fields above once, for the step (not arguments)
    n_rotors: int = field(init=False, repr=False)
    rotor_speed_limits: tuple = field(init=False, repr=False)
    """``(min, max)`` rotor speeds, each (P, 1), rad/s (read-only)."""

    def __post_init__(self):
        packed = self.model.packed
        limits = tuple(np.ascontiguousarray(col[:, None], dtype=np.float64)
                       for col in (packed.rotor_speed_min, packed.rotor_speed_max))
        for a in limits:
            a.setflags(write=False)
        object.__setattr__(self, "n_rotors", self.model.n_rotors)
        object.__setattr__(self, "rotor_speed_limits", limits)


class LoopState(NamedTuple):
    """What the loop carries from one physics step to the next (arrays are never mutated).

    ``x`` (B, 13 + N) packed state; ``cmd`` (B, N) the controller's command and ``cmd_clipped``
    the one applied, rad/s; ``saturated`` (B, N) where it was clipped (or at the lower limit);
    ``reference`` the last target; ``failed_step`` (B,) the step from which a vehicle is
    frozen, -1 while it flies; ``n_failed`` how many are frozen.
    """

    x: np.ndarray
    cmd: np.ndarray
    cmd_clipped: np.ndarray
    saturated: np.ndarray
    reference: object
    failed_step: np.ndarray
    n_failed: int = 0


class Instant(NamedTuple):
    """What the loop saw at ``t = step * dt`` before stepping: the raw wind at the centre of mass
    (B, 3; with ``hub_wind``, the mean over the hubs, which equals it only in a uniform or
    linear field) and, with ``hub_wind``, at every hub (B, N, 3) (else None)."""

    step: int
    t: float
    wind_com: np.ndarray
    wind_hub: np.ndarray | None


def make_closed_loop(params, trajectory, wind, *, dt, control_rate_hz=None, gains=None,
                     batch=None, hub_wind=False, substeps=None, controller=None) -> ClosedLoop:
    """Validate the parts of a flight once and build its :class:`ClosedLoop`.

    Parameters
    ----------
    params : MultirotorParams or sequence of them
        Vehicle(s); a sequence flies one vehicle per batch row.
    trajectory : callable
        ``trajectory(t) -> FlatOutput``.
    wind : WindField
        ``wind.velocity(t, xyz (B, 3)) -> (B, 3)`` m/s, world frame.
    dt : float
        Physics step, s.
    control_rate_hz : float, optional
        Controller rate, Hz, a whole number of physics steps per update; default
        :data:`DEFAULT_CONTROL_RATE_HZ`, lowered to :func:`fitted_rate` when it does not fit.
    gains, batch, hub_wind, substeps, controller
        As for :func:`windnav.sim.fly`.

    Returns
    -------
    ClosedLoop

    Raises
    ------
    ValueError
        Naming ``dt``, ``wind``, ``trajectory``, ``batch`` or ``control_rate_hz``.
    """
    dt = positive_float(dt, "dt", _WHERE)
    if not hasattr(wind, "velocity"):
        raise ValueError(f"The 'wind' parameter of {_WHERE} must be a WindField with a "
                         f"velocity(t, xyz) method. Got {type(wind).__name__} instead.")
    if not callable(trajectory):
        raise ValueError(f"The 'trajectory' parameter of {_WHERE} must be callable as "
                         f"trajectory(t). Got {type(trajectory).__name__} instead.")
    plist = [params] if isinstance(params, MultirotorParams) else list(params)
    if len(plist) > 1 and batch is not None and batch != len(plist):
        # it was ignored: a list of 2 with batch=3 flew 2 (API audit, thirty-ninth session)
        raise ValueError(f"The 'batch' parameter of {_WHERE} must be {len(plist)}, the number "
                         f"of vehicles in 'params', or not given. Got {batch!r} instead.")
    B = len(plist) if len(plist) > 1 else positive_int(1 if batch is None else batch, "batch",
                                                       _WHERE)
    per_row = getattr(wind, "batch_size", None)  # a wind with one realisation per vehicle
    if isinstance(per_row, int) and not isinstance(per_row, bool):
        if per_row != B:  # named the library's 'xyz' at the first step
            raise ValueError(f"The 'wind' parameter of {_WHERE} has batch_size {per_row}, one "
                             f"realisation per vehicle, for {B} vehicle(s): give batch="
                             f"{per_row} or a wind of batch_size {B}.")
        if hub_wind:
            raise ValueError(f"The 'hub_wind' parameter of {_WHERE} must be False with a wind "
                             f"of one realisation per vehicle (batch_size {per_row}): it takes "
                             "one point per vehicle, and such a wind (Dryden's gusts) is the "
                             "same at every point of a vehicle, so the hubs would add nothing.")
    vehicles = plist if len(plist) > 1 else plist[0]
    if control_rate_hz is None:
        control_rate_hz = fitted_rate(DEFAULT_CONTROL_RATE_HZ, dt)
    rate = positive_float(control_rate_hz, "control_rate_hz", _WHERE)
    return ClosedLoop(
        model=Multirotor(vehicles, substeps=substeps),
        controller=controller or SE3Controller(vehicles, gains),
        trajectory=trajectory, wind=wind, dt=dt,
        control_every=steps_per_sample(rate, dt, "'control_rate_hz' parameter"),
        hub_wind=bool(hub_wind), batch=B)


def initial_loop_state(loop: ClosedLoop, x0: np.ndarray) -> LoopState:
    """The loop state before the first step, from packed states ``x0`` (B, 13 + N)."""
    B, N = loop.batch, loop.n_rotors
    return LoopState(x=np.ascontiguousarray(x0, dtype=np.float64), cmd=np.zeros((B, N)),
                     cmd_clipped=np.zeros((B, N)), saturated=np.zeros((B, N), bool),
                     reference=loop.trajectory(0.0), failed_step=np.full(B, -1, np.int64))


# The closed-loop step ----------------------------------------------------------------------
# It runs once per physics step, so the path on which every vehicle stays finite is lean: one
# compiled finiteness test per input, the clip and the saturation flags in one compiled pass, no
# NamedTuple._replace. Only when something is not finite does the step look for the vehicles.
_EXPONENT = np.uint64(0x7FF0000000000000)  # all ones in exactly the NaN and inf float64s


@njit(cache=True)
def _all_finite(a):  # pragma: no cover - compiled
    """True when every entry of float64 ``a`` (any shape) is finite (a bit test that
    vectorises: no early exit to wait for)."""
    bits = np.ascontiguousarray(a).ravel().view(np.uint64)
    bad = False
    for k in range(bits.size):
        bad |= (bits[k] & _EXPONENT) == _EXPONENT
    return not bad


@njit(cache=True)
def _command_kernel(cmd, lo, hi, wind, clipped, sat):  # pragma: no cover - compiled
    """``clipped = np.clip(cmd, lo, hi)``, ``sat`` where it was clipped or sits at the lower
    limit (the values NumPy gives; a command equal to a limit is kept, so a zero keeps its sign,
    which NumPy's vectorised clip does not always do); lo, hi (P, 1) with P 1 or B. Returns
    whether ``cmd`` and ``wind`` (any shape) are finite."""
    B, N = cmd.shape
    P = lo.shape[0]
    finite = True
    for b in range(B):
        p = b if P > 1 else 0
        low = lo[p, 0]
        high = hi[p, 0]
        for i in range(N):
            c = cmd[b, i]
            v = low if c < low else c
            v = high if v > high else v
            clipped[b, i] = v
            sat[b, i] = v != c or v <= low
            finite = finite and math.isfinite(c)
    for w in wind.flat:
        finite = finite and math.isfinite(w)
    return finite


def _command(loop: ClosedLoop, cmd, wind: np.ndarray) -> tuple[np.ndarray, np.ndarray, bool]:
    """The applied command, where it saturated, and whether ``cmd`` and ``wind`` are finite."""
    lo, hi = loop.rotor_speed_limits
    if (type(cmd) is np.ndarray and cmd.dtype == np.float64 and cmd.ndim == 2
            and lo.shape[0] in (1, cmd.shape[0])):
        clipped = np.empty(cmd.shape)
        sat = np.empty(cmd.shape, np.bool_)
        return clipped, sat, _command_kernel(cmd, lo, hi, wind, clipped, sat)
    clipped = np.clip(cmd, lo, hi)  # any other command: the same rule through NumPy
    # a command at the lower limit is saturated too: the SE(3) allocation already clips
    # a negative thrust demand to 0 rad/s before the limits are applied
    sat = (clipped != cmd) | (clipped <= lo)
    return clipped, sat, bool(np.isfinite(cmd).all()) and _all_finite(wind)


def _hub_positions(model: Multirotor, x: np.ndarray) -> np.ndarray:
    """World positions of every rotor hub, (B * N, 3)."""
    R = quat_to_matrix(x[:, layout.ATTITUDE])  # (B, 3, 3)
    r = model.packed.rotor_positions  # (P, N, 3)
    hubs = x[:, None, layout.POSITION] + np.einsum(
        "bij,bnj->bni", R, np.broadcast_to(r, (x.shape[0],) + r.shape[1:]))
    return hubs.reshape(-1, 3)


def _hub_wind(loop: ClosedLoop, t: float, x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Raw wind at every hub (B, N, 3) and its mean over the hubs, the centre-of-mass wind."""
    B, N = loop.batch, loop.n_rotors
    hub = np.asarray(loop.wind.velocity(t, _hub_positions(loop.model, x)), dtype=np.float64)
    if hub.shape != (B * N, 3):
        raise ValueError(f"The 'wind' parameter of {_WHERE} returned shape {hub.shape} for "
                         f"{B * N} hub positions at t = {t:.3f} s; expected ({B * N}, 3).")
    hub = hub.reshape(B, N, 3)
    return hub.mean(axis=1), hub


def _rows(value, B: int) -> np.ndarray:
    """``value`` (3,) repeated on B rows, (B, 3) (anything else broadcast the same way)."""
    v = np.asarray(value, dtype=np.float64)
    if v.shape == (3,):
        return v[None].repeat(B, axis=0)  # a row copy: quicker than broadcasting for large B
    out = np.empty((B, 3))
    out[:] = v
    return out


def _targets(ref, B: int) -> tuple[np.ndarray, ...]:
    """The target's position, velocity, acceleration (each (B, 3)), yaw and yaw rate (B,),
    repeated on every row."""
    yaw = np.empty((2, B))
    yaw[0] = float(ref.yaw)
    yaw[1] = float(ref.yaw_rate)
    if B > 1:
        return (_rows(ref.position, B), _rows(ref.velocity, B), _rows(ref.acceleration, B),
                yaw[0], yaw[1])
    rows = np.empty((3, 1, 3))  # one vehicle: a single allocation
    rows[0] = ref.position
    rows[1] = ref.velocity
    rows[2] = ref.acceleration
    return rows[0], rows[1], rows[2], yaw[0], yaw[1]


def observe(loop: ClosedLoop, state: LoopState, step: int) -> tuple[LoopState, Instant]:
    """Wind at ``t = step * dt`` and, on a control tick, a new command.

    Vehicles meeting a non-finite wind or command get ``failed_step = step``.
    """
    t = step * loop.dt
    x = state.x
    if loop.hub_wind:
        com, hub = _hub_wind(loop, t, x)
        wind = hub
    else:
        com = wind = np.asarray(loop.wind.velocity(t, x[:, layout.POSITION]), dtype=np.float64)
        hub = None
        if com.shape != (loop.batch, 3):
            raise ValueError(f"The 'wind' parameter of {_WHERE} returned shape {com.shape} for "
                             f"{loop.batch} positions at t = {t:.3f} s; expected "
                             f"({loop.batch}, 3).")
    if step % loop.control_every:
        finite = _all_finite(wind)
        suspects = (wind,)
    else:
        ref = loop.trajectory(t)
        cmd, _ = loop.controller.track(x, *_targets(ref, loop.batch))
        clipped, sat, finite = _command(loop, cmd, wind)
        state = LoopState(x, cmd, clipped, sat, ref, state.failed_step, state.n_failed)
        suspects = (wind, cmd)
    if not finite:  # rare: find the vehicles
        found = np.logical_and.reduce([np.isfinite(a.reshape(loop.batch, -1)).all(axis=1)
                                       for a in suspects])
        state = _fail(state, ~found, step)
    if state.n_failed:
        state = state._replace(saturated=state.saturated & (state.failed_step < 0)[:, None])
    return state, Instant(step, t, com, hub)


def _fail(state: LoopState, bad: np.ndarray, step: int) -> LoopState:
    """Freeze the vehicles ``bad`` (B,) not frozen yet at ``step``."""
    failed = np.where(bad & (state.failed_step < 0), step, state.failed_step)
    return state._replace(failed_step=failed, n_failed=int(np.count_nonzero(failed >= 0)))


def _each_hub(com: np.ndarray, n_rotors: int) -> np.ndarray:
    """``com`` (B, 3) C-contiguous float64 seen at every hub: a (B, N, 3) view (stride 0 over
    the hubs) for the dynamics kernel to read; nothing is copied."""
    return np.ndarray((com.shape[0], n_rotors, 3), np.float64, com, 0, (com.strides[0], 0,
                                                                         com.strides[1]))


def advance(loop: ClosedLoop, state: LoopState, seen: Instant) -> LoopState:
    """Dynamics from ``seen.t`` to ``seen.t + dt`` with the held command (pure).

    Frozen vehicles keep their state; a vehicle whose next state is not finite is frozen at
    this one.
    """
    x, com, hub, cmd = state.x, seen.wind_com, seen.wind_hub, state.cmd_clipped
    if state.n_failed:  # keep NaN out of the kernels; the rows are discarded below
        dead = state.failed_step >= 0
        com = np.where(dead[:, None], 0.0, com)
        hub = None if hub is None else np.where(dead[:, None, None], 0.0, hub)
        cmd = np.where(dead[:, None], 0.0, cmd)
    com = np.ascontiguousarray(com, dtype=np.float64)
    if hub is None:  # one wind per vehicle: every hub sees the centre-of-mass wind, a view
        hub = _each_hub(com, loop.n_rotors)
    else:
        hub = np.ascontiguousarray(hub)
    out = np.empty_like(x)
    loop.model.step_packed(x, np.ascontiguousarray(cmd), com, hub, loop.dt, out)
    if state.n_failed or not _all_finite(out):
        blown = ~np.isfinite(out).all(axis=1)
        frozen = (state.failed_step >= 0) | blown
        out[frozen] = x[frozen]
        state = _fail(state, blown, seen.step)
    return LoopState(out, state.cmd, state.cmd_clipped, state.saturated, state.reference,
                     state.failed_step, state.n_failed)


def closed_loop_step(loop: ClosedLoop, state: LoopState, step: int) -> tuple[LoopState, Instant]:
    """One physics step from ``t = step * dt``: returns the next state and what was seen."""
    state, seen = observe(loop, state, step)
    return advance(loop, state, seen), seen


__all__ = ["DEFAULT_CONTROL_RATE_HZ", "ClosedLoop", "Instant", "LoopState", "advance",
           "closed_loop_step", "fitted_rate", "initial_loop_state", "make_closed_loop",
           "observe", "steps_per_sample"]
