"""The closed loop of navigation: a planner flies the 6-DoF Hummingbird through urban wind.

This is the experimental setup of the thesis (Folk 2026, ch. 5) as one function,
:func:`navigate`, and the comparison of variants over scenarios, :func:`compare_variants`.

The loop
--------
* **Wind.** The 2D urban flow (:func:`windnav.flow.simulate`) of the map at the inlet ``speed``
  and ``direction_deg``: 25 s of spin-up, then 100 s of frames recorded every ``dt = 0.25`` s at
  ``dx = 1`` m (:func:`simulate_flow`), interpolated bilinearly in space and linearly in time
  (:meth:`FlowSolution.wind_field` with ``unsteady=True``; ``w = 0``). Flight time ``t`` is the
  time of the record (its first frame is held before ``t = 0.25`` s).
* **Vehicle.** :class:`windnav.vehicle.Multirotor` with aerodynamics, stepped over
  ``1 / control_rate_hz`` (RK4 sub-steps of at most 5 ms) with the wind at the centre of mass.
* **Control, 100 Hz.** :meth:`windnav.control.SE3Controller.accelerate` on the command
  ``[a_x, a_y, a_z]``: the horizontal part from the planner (held between its updates), the
  vertical part from an altitude hold ``a_z = k_p (z_ref - z) - k_d v_z`` with the SE(3)
  controller's own z gains (15 s^-2, 9 s^-1), clipped to ``+-0.5 g``; yaw is held at 0.
* **Tilt cap.** The horizontal command is clipped to the disk ``|a_xy| <= g tan(tilt_max)``,
  ``tilt_max = 55 deg`` by default (thrust ``1.74 mg`` at the cap). 55 deg leaves margin above
  the 43.9 deg of steady flight at 13 m/s, the last airspeed at which the power curve is valid
  (46.0 deg at 13.5 m/s, just past it), so
  the vehicle can hold every airspeed of the model and still manoeuvre. So that planner and
  flight agree, the MPPI planner's per-axis bound is the box inscribed in that disk,
  ``a_max = g tan(tilt_max) / sqrt(2)`` (9.9 m/s^2; :func:`planner_config` would otherwise
  allow the 70 m/s^2 of full thrust); the clip then never acts on its commands.
* **Planner, 10 Hz.** MPPI variants get the true ``[x, y, v_x, v_y]``, a LiDAR scan (360 rays,
  ``D_max = 100`` m, noise 0.14 m; :meth:`City.lidar`) and, in the ``-w`` variants, the
  ground-truth wind averaged over the 100 s record, noise-free, on the solver's 1 m grid inside
  the window ``L_t`` of side ``H = horizon`` (``inf``: the whole map).
* **EA-MPPI+Ŵ** (``ea-mppi-w-hat``, our addition, issue 11). EA-MPPI+W's planner whose wind
  inside ``L_t`` comes from the onboard stack of :mod:`windnav.experiments.onboard` instead of
  the truth: the Wind UKF on simulated sensors at thesis-level noise every control step
  (100 Hz), the wind flow decoder on a fresh LiDAR scan, the inlet wind and the UKF's estimate
  at 50 Hz; ``L_t`` is the decoder's grid (``H = 25`` m), and the result carries the UKF's error
  and the per-stage timings (:class:`~windnav.experiments.onboard.OnboardReport`). The stack
  draws from its own streams, so the other variants' flights are unchanged.
* **EA-MPPI+W+esc** (``ea-mppi-w-esc``, our addition, issue 11). EA-MPPI+W plus a progress
  monitor (:mod:`windnav.plan.escape`): the GS+W route (below) is computed once before take-off;
  when the distance to the goal has not shrunk by 2 m in 3 s, the route follower (below) flies
  the next 60 m of the route from the vehicle's projection onto it, then MPPI takes over again
  (its warm start reset). The other variants never build the route or the monitor. With
  ``EscapeConfig.airspeed_mps`` set (label ``@escair=A``) the first stall instead hands the
  vehicle, for the rest of the flight, to the least-time route from where it stalled to the goal
  in the mean wind with the airspeed at most ``A`` (:func:`windnav.plan.reach.fastest_route`, on
  the GS lattice with the GS clearance), flown by the same follower at the route's ground
  speeds. More triggers of that route (``EscapeConfig.edge_m``, ``pace_margin_s``,
  ``launch_s``: near the map's edge, a pace too slow, a least time too long at take-off) and
  the release of the goal hold (``regain_m``) are described in :mod:`windnav.plan.escape`.
* **GS / GS+W.** :func:`windnav.plan.energy_route` is computed once before take-off, with full
  knowledge of the buildings and (GS+W) the mean wind, and flown by a path follower in the same
  acceleration mode: a reference point moves along the route's samples at the route's planned
  ground speed (ramped up from 0.5 m/s and down to 0 at the goal at 2 m/s^2, and held back while
  the vehicle is more than 4 m behind it), and ``a = K_p (p_ref - p) + K_d (v_ref - v)`` with the
  SE(3) controller's horizontal gains (6.5 s^-2, 4 s^-1), then the tilt cap.

Goal capture (ours)
-------------------
Once the vehicle is within ``capture_radius`` (10 m, twice the success radius) of the goal, the
loop stops updating the planner and holds the goal with the same PD law and gains as the route
follower, ``a = K_p (g - p) - K_d v`` (then the tilt cap), for the rest of the flight, as a
mission executive would; the success condition below is unchanged. The thesis does not say how
its vehicle settles in the goal region for the 5 s its success criterion needs, and its costs do
not let MPPI settle there:

* the rest point of the cost is pulled away from buildings: with the progress cost summed over
  ``N_k`` steps and the obstacle cost ``Q_O (D_max / d)^2`` of the nearest building at ``d``,
  their gradients balance ``delta ~ Q_O D_max^4 / (N_k d^3)`` from the goal (10 m at
  ``d = 40`` m, 25 m at 30 m with the simulation settings), outside the 5 m success radius;
* near the goal the progress cost varies across samples by less than the temperature
  ``lambda``, so the softmin weights are nearly uniform, the warm start random-walks, and the
  gusts of the urban wake push the vehicle about.

The capture is the same for every variant, its energy (including the 5 s hold) is counted, and
``capture_radius=0`` flies the planner to the end.
The one exception is ours and optional: the sixth variant with ``EscapeConfig.regain_m`` leaves
the hold when blown farther than that from the goal and flies a new least-time route back
(:class:`windnav.plan.FastestEscape`).

Termination (checked every control step)
----------------------------------------
``success``: within 5 m of the goal with ``|v| <= 2`` m/s for 5 s; ``hover``: ``|v| <= 1`` m/s
for 5 s anywhere else (the thesis's hover failure); ``collision``: the vehicle's position inside a
building footprint; and, our additions, ``left_map``: outside the map's bounds, ``timeout``: the
end of the recorded wind. ``time_s`` is the time the flight ended (for success, the end of the
5 s hold).

Energy is reported twice: ``energy_J`` integrates the planner's steady-flight power curve at the
true horizontal airspeed, ``P(|v_xy - w_xy|)`` (as the thesis does), and ``rotor_energy_J``
the 6-DoF simulator's rotor power ``sum_i k_m eta_i^3 / efficiency``, both by the trapezoid rule
over the control steps. ``power_shape="crazyflie"`` is a counterfactual for studies: the
planner's curve, and with it ``energy_J``, take the shape of the thesis's Crazyflie cubic
(:meth:`windnav.vehicle.PowerCurve.crazyflie`) scaled to this vehicle's hover power, while the
6-DoF dynamics, and ``rotor_energy_J``, stay the vehicle's.

A planner update that returns a non-finite acceleration is replaced by hover (zero horizontal
acceleration) and counted in ``fallbacks`` (reason ``"nan"``), next to the planner's own
fallbacks (:attr:`windnav.plan.MPPIPlanner.stats`).
"""

from __future__ import annotations

import bisect
import dataclasses
import math
import time
import warnings
from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from windnav._validate import batch_array, finite_float, generator, positive_float
from windnav.city.core import check_city

__all__ = [
    "OUTCOMES",
    "NavigationResult",
    "check_point",
    "compare_variants",
    "free_point",
    "local_wind",
    "mean_wind_at",
    "navigate",
    "simulate_flow",
    "simulate_flows",
    "tilt_accel_cap",
    "with_power_shape",
]

OUTCOMES = ("success", "hover", "collision", "left_map", "timeout")

MAX_CONTROL_STEPS = 10**8
"""The most control steps :func:`navigate` flies (about 10 GB of recorded series)."""
"""How a flight ends (see the module docstring)."""

GOAL_RADIUS = 5.0
"""Success radius around the goal, m."""
CAPTURE_RADIUS = 10.0
"""Default distance from the goal at which the loop stops planning and holds it, m."""
TILT_MAX_DEG = 55.0
"""Default tilt cap of the closed loop, degrees (see the module docstring)."""

ROUTE_DX = 2.0
"""Lattice spacing of the GS routes (``gs``, ``gs-w``, the escapes), m."""

ROUTE_CLEARANCE = 6.0
"""Least distance of a GS route from any building, m: a start or goal closer has no route."""

HOLD_SETTLE_S = 2.0
"""Seconds after entering the goal's capture circle that the hold's own braking may spend at
the tilt cap (its gains command 65 m/s^2 at 10 m): time at the cap after them is the wind's
(:meth:`NavigationResult.envelope`)."""
TILT_LIMIT_DEG = 80.0
"""A tilt cap must lie in (0, TILT_LIMIT_DEG) degrees."""
GOAL_SPEED = 2.0
"""Largest speed that counts as stopped at the goal, m/s."""
HOVER_SPEED = 1.0
"""Largest speed that counts as hovering (failure when away from the goal), m/s."""
HOLD_S = 5.0
"""How long either condition must hold, s."""

LIDAR_RAYS = 360
LIDAR_RANGE = 100.0
LIDAR_NOISE = 0.14

_WHERE = "navigate"

POWER_SHAPES = ("crazyflie",)
"""Counterfactual power-curve shapes of :func:`navigate` (``power_shape``): ``"crazyflie"``, the
thesis's Crazyflie cubic times ``P_hover / 10.56 W`` of the flown vehicle (its bucket at
4.15 m/s, 0.96 ``P_hover``; 2.6 ``P_hover`` at 12 m/s)."""


@dataclass(frozen=True, eq=False)
class NavigationResult:
    """One closed-loop flight.

    Attributes
    ----------
    outcome : str
        One of :data:`OUTCOMES`.
    variant : str
        The planner variant flown.
    energy_J : float
        Energy from the airspeed power curve ``P(|v - w|)``, J.
    rotor_energy_J : float
        Rotor energy of the 6-DoF simulator, J.
    time_s : float
        Flight time until termination, s.
    distance_m : float
        Horizontal distance flown, m.
    mean_cmd_accel : float
        Mean norm of the horizontal acceleration command after the tilt cap, m/s^2, over
        ``accel_cmd`` (whose last entry is the command before the cap, below).
    planner_ms_median : float
        Median planner update time, ms (GS: the one route computation).
    fallbacks : int
        Planner updates replaced by hover or braking (the planner's and the loop's own).
    fallback_reasons : dict of str to int
        Fallbacks by cause (``"state"``, ``"scan"``, ``"wind"``, ``"costs"``, ``"nan"``).
    planner_updates : int
        Planner updates (GS: 1).
    start, goal : ndarray of shape (2,)
        m, world.
    t : ndarray of shape (T,)
        Times of the control steps, s.
    position, velocity : ndarray of shape (T, 3)
        m and m/s, world.
    wind : ndarray of shape (T, 2)
        True wind at the vehicle, m/s, world.
    airspeed : ndarray of shape (T,)
        Horizontal airspeed ``|v_xy - w_xy|``, m/s.
    accel_cmd : ndarray of shape (T, 2)
        Horizontal acceleration command after the tilt cap, m/s^2, world; the last entry (the
        step that ends the flight, which sends none) is the command before the cap. Recorded
        flights keep it so that they replay. MPPI's bounds lie within the cap, so only the
        goal hold and the route followers can leave it above; in 10 benchmark flights
        replayed (five variants, 2026-12-05) it was within the cap every time.
    power, rotor_power : ndarray of shape (T,)
        Airspeed-model and rotor power, W.
    energy, rotor_energy : ndarray of shape (T,)
        Their running integrals, J.
    route : ndarray of shape (M, 2) or None
        The GS route's samples, m (GS, GS+W, and the GS+W route of the escape variants; None
        for the other MPPI variants).
    wall_s : float
        Wall time of the closed loop (flow simulation and route search excluded), s.
    settings : dict
        The flight's settings (inlet, altitude, window, rates, ...).
    wind_estimate : ndarray of shape (T, 3) or None
        The onboard Wind UKF's world-frame wind at each control step, m/s (``ea-mppi-w-hat``;
        None for the other variants); NaN at the last step, where the flight ended before the
        stack ran.
    onboard : OnboardReport or None
        The onboard stack's errors and stage timings (``ea-mppi-w-hat``; see
        :mod:`windnav.experiments.onboard`), else None.
    diverged_s : float or None
        When the vehicle's state stopped being finite (the simulation left its model), s: the
        flight ends there, its outcome classified by where it was (``collision`` or
        ``left_map``); None for a flight simulated to its end.
    """

    outcome: str
    variant: str
    energy_J: float
    rotor_energy_J: float
    time_s: float
    distance_m: float
    mean_cmd_accel: float
    planner_ms_median: float
    fallbacks: int
    fallback_reasons: dict
    planner_updates: int
    start: np.ndarray
    goal: np.ndarray
    t: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    wind: np.ndarray
    airspeed: np.ndarray
    accel_cmd: np.ndarray
    power: np.ndarray
    rotor_power: np.ndarray
    energy: np.ndarray
    rotor_energy: np.ndarray
    route: np.ndarray | None = None
    wall_s: float = float("nan")
    settings: dict = field(default_factory=dict)
    wind_estimate: np.ndarray | None = None
    onboard: object = None
    diverged_s: float | None = None

    def envelope(self) -> dict:
        """Where the flight left the envelope of its models: ``airspeed_max_mps`` (the largest
        horizontal airspeed, m/s), ``outside_envelope_s`` (time above the vehicle's
        ``airspeed_limit``, where its aerodynamic model is not trusted, s) and
        ``power_extrapolated_s`` (time above the power curve's last valid airspeed, where
        ``energy_J`` uses the curve's continuation, s). The limits are in ``settings``.

        And where it reached the limit of its authority at the goal: ``goal_hold_at_cap_s``,
        the time within ``capture_radius`` of the goal (where the loop holds it) with the
        command at the tilt cap, s. It includes the capture itself: the hold's gains command
        65 m/s^2 at the 10 m radius, so a vehicle that enters the circle at speed is braked at
        the cap for up to about a second, whatever the wind (0.3-1.1 s in every success of an
        audit in still air, 2026-12-05). ``goal_hold_at_cap_settled_s`` leaves out the first
        :data:`HOLD_SETTLE_S` after each entry into the circle: time there means the wind at
        the goal was, for that long, more than the vehicle can hold against at its tilt cap
        (at 55 deg the Hummingbird's steady limit lies near its 13.45 m/s trusted
        airspeed)."""
        dt = float(self.t[1] - self.t[0]) if self.t.size > 1 else 0.0
        air = self.airspeed
        limit = self.settings.get("airspeed_limit", float("inf"))
        p_max = self.settings.get("power_speed_max", float("inf"))
        capture = self.settings.get("capture_radius", 0.0)
        tilt = self.settings.get("tilt_max_deg")
        at_cap_s = settled_s = 0.0
        if capture > 0 and tilt is not None and self.accel_cmd.size:
            near = np.hypot(*(self.position[:, :2] - self.goal).T) <= capture
            capped = np.hypot(*self.accel_cmd.T) >= tilt_accel_cap(tilt) * (1.0 - 1e-9)
            at_cap_s = dt * int(np.count_nonzero(near & capped))
            entry = near & ~np.r_[False, near[:-1]]  # the samples that enter the circle
            last = np.maximum.accumulate(np.where(entry, np.arange(near.size), 0))
            settled = near & capped & (self.t - self.t[last] >= HOLD_SETTLE_S)
            settled_s = dt * int(np.count_nonzero(settled))
        return {"airspeed_max_mps": float(air.max()) if air.size else 0.0,
                "outside_envelope_s": dt * int(np.count_nonzero(air > limit)),
                "power_extrapolated_s": dt * int(np.count_nonzero(air > p_max)),
                "goal_hold_at_cap_s": at_cap_s, "goal_hold_at_cap_settled_s": settled_s}

    def arrival(self) -> dict:
        """``arrival_time_s`` and ``arrival_energy_J``, ``arrival_rotor_energy_J``: when the
        vehicle first came within :data:`GOAL_RADIUS` of the goal and the energies used until
        then (NaN if it never did)."""
        d = np.hypot(*(self.position[:, :2] - self.goal).T)
        hit = np.flatnonzero(d <= GOAL_RADIUS)
        if hit.size == 0:
            nan = float("nan")
            return {"arrival_time_s": nan, "arrival_energy_J": nan,
                    "arrival_rotor_energy_J": nan}
        k = int(hit[0])
        return {"arrival_time_s": float(self.t[k]), "arrival_energy_J": float(self.energy[k]),
                "arrival_rotor_energy_J": float(self.rotor_energy[k])}

    def summary(self) -> dict:
        """The scalars, JSON-ready (what ``windnav navigate --json`` writes); with the onboard
        stack also ``stage_ms_median``, ``stage_ms_mean``, ``stage_updates``,
        ``stage_rate_hz``, ``real_time_fraction``, ``ukf_wind_rms_mps``,
        ``ukf_wind_rms_xy_mps`` and ``onboard`` (:meth:`OnboardReport.summary`)."""
        extra = {} if self.onboard is None else self.onboard.summary()
        return {
            "outcome": self.outcome, "variant": self.variant,
            "energy_J": self.energy_J, "rotor_energy_J": self.rotor_energy_J,
            "time_s": self.time_s, "distance_m": self.distance_m,
            "mean_cmd_accel": self.mean_cmd_accel,
            "planner_ms_median": self.planner_ms_median,
            "fallbacks": self.fallbacks, "fallback_reasons": dict(self.fallback_reasons),
            "planner_updates": self.planner_updates,
            "start": self.start.tolist(), "goal": self.goal.tolist(),
            "final_position": self.position[-1].tolist(),
            "final_distance_to_goal_m": float(np.hypot(*(self.position[-1, :2] - self.goal))),
            **self.arrival(), **self.envelope(),
            "diverged_s": self.diverged_s,
            "wall_s": self.wall_s, "settings": dict(self.settings), **extra,
        }


# ------------------------------------------------------------------------------------ wind


def simulate_flow(city, speed: float, direction_deg: float, *, spinup_s: float = 25.0,
                  record_s: float = 100.0, dx: float = 1.0, dt: float = 0.25,
                  progress: bool = False, factor_cache=None, frame_buffers=None):
    """The unsteady wind of the thesis setup: ``spinup_s`` of spin-up, then ``record_s`` of
    frames every ``dt`` (defaults: 25 s, 100 s, 0.25 s, on a 1 m grid). ``factor_cache`` and
    ``frame_buffers``: a caller's reusable factorisations and frame memory
    (:func:`windnav.flow.simulate`).

    Returns
    -------
    windnav.flow.FlowSolution
        With ``frames_u, frames_v`` (T, ny, nx) and the mean over the record.
    """
    return simulate_flows(city, [(speed, direction_deg)], spinup_s=spinup_s,
                          record_s=record_s, dx=dx, dt=dt, progress=progress,
                          factor_cache=factor_cache, frame_buffers=frame_buffers,
                          _where="simulate_flow")[0]


def simulate_flows(city, winds, *, spinup_s: float = 25.0, record_s: float = 100.0,
                   dx: float = 1.0, dt: float = 0.25, progress: bool = False,
                   factor_cache=None, frame_buffers=None, _where: str = "simulate_flows"):
    """:func:`simulate_flow` for several ``(speed, direction_deg)`` winds (m/s, degrees) whose
    inlets are the same sides, stepped together (:func:`windnav.flow.simulate_batch`: each
    equal to its own :func:`simulate_flow` to the bit for up to
    :data:`windnav.flow.solver.BITWISE_BATCH` winds). Returns a list of
    :class:`windnav.flow.FlowSolution` in the order of ``winds``."""
    from windnav.flow import simulate_batch

    where = _where
    dt = positive_float(dt, "dt", where)
    spin = int(round(positive_float(spinup_s, "spinup_s", where, allow_zero=True) / dt))
    steps = max(2, int(round(positive_float(record_s, "record_s", where) / dt)))
    winds = [tuple(w) for w in winds]
    if not winds or any(len(w) != 2 for w in winds):
        raise ValueError(f"The 'winds' parameter of {where} must be a non-empty sequence of "
                         f"(speed, direction_deg) pairs. Got {winds!r} instead.")
    return simulate_batch(city, [w[0] for w in winds], [w[1] for w in winds], dx=dx, dt=dt,
                          spinup_steps=spin, steps=steps, record_every=1, progress=progress,
                          factor_cache=factor_cache, frame_buffers=frame_buffers,
                          _where="simulate" if where == "simulate_flow" else "simulate_batch")


def local_wind(flow, position_xy, horizon: float, *, uv=None, known_finite: bool = False,
               outside: str = "zero"):
    """The mean wind the ``-w`` planners know: ``flow``'s time average inside ``L_t``.

    Parameters
    ----------
    flow : FlowSolution
    position_xy : array_like of shape (2,)
        The vehicle's position at the start of the planning period, m.
    horizon : float
        ``H``, side of the window, m (``inf``: the whole map).
    uv : ndarray of shape (2, ny, nx), optional
        ``[flow.mean_u, flow.mean_v]``, stacked once by a caller that queries many times. It
        is not copied (a window that covers the whole grid is ``uv`` itself): do not write it
        while a wind built from it is in use.
    known_finite : bool
        The caller checked ``uv`` finite once (:attr:`windnav.plan.LocalWind.known_finite`).
    outside : {"zero", "truth"}
        The planner's wind outside the window: zero (the thesis's planner), or the mean wind at
        ``position_xy`` (:func:`mean_wind_at`; ours: the ideal of the onboard stack's
        ``outside="robot"``, a perfect ``W_robot``). Ignored when ``horizon`` is infinite.

    Returns
    -------
    windnav.plan.LocalWind
        On the solver's cell centres, offsets relative to ``position_xy``, with
        :attr:`~windnav.plan.LocalWind.fill` per ``outside``.
    """
    from windnav.plan import LocalWind

    if uv is None:
        uv = np.stack([flow.mean_u, flow.mean_v])
    x, y = flow.x, flow.y
    px, py = float(position_xy[0]), float(position_xy[1])
    if math.isfinite(horizon):
        half = 0.5 * horizon + 2.0 * flow.dx
        i0, i1 = np.searchsorted(x, [px - half, px + half])
        j0, j1 = np.searchsorted(y, [py - half, py + half])
        i0, j0 = min(i0, x.size - 2), min(j0, y.size - 2)
        i1, j1 = max(i1, i0 + 2), max(j1, j0 + 2)
        fill = ((0.0, 0.0) if outside == "zero"
                else tuple(mean_wind_at(uv[:, j0:j1, i0:i1], x[i0:i1], y[j0:j1], px, py)))
        uv, x, y = uv[:, j0:j1, i0:i1], x[i0:i1], y[j0:j1]
        return LocalWind.grid(uv, x - px, y - py, known_finite=known_finite, fill=fill,
                              copy=False)  # ``uv`` adopted, as documented
    return LocalWind.grid(uv, x - px, y - py, known_finite=known_finite, copy=False)


def mean_wind_at(uv, x, y, px: float, py: float) -> np.ndarray:
    """The field ``uv`` at the point ``(px, py)``, bilinear between cell centres.

    Parameters
    ----------
    uv : ndarray of shape (2, ny, nx)
        Wind components on the cell centres, m/s (0 in solid cells).
    x : ndarray of shape (nx,)
    y : ndarray of shape (ny,)
        Cell-centre coordinates, m, increasing, at least 2 each.
    px, py : float
        The point, m; clamped to the grid's extent.

    Returns
    -------
    ndarray of shape (2,)
        ``(u, v)``, m/s.
    """
    i = int(np.clip(np.searchsorted(x, px) - 1, 0, x.size - 2))
    j = int(np.clip(np.searchsorted(y, py) - 1, 0, y.size - 2))
    tx = min(max((px - x[i]) / (x[i + 1] - x[i]), 0.0), 1.0)
    ty = min(max((py - y[j]) / (y[j + 1] - y[j]), 0.0), 1.0)
    c = uv[:, j:j + 2, i:i + 2]
    return ((1 - ty) * ((1 - tx) * c[:, 0, 0] + tx * c[:, 0, 1])
            + ty * ((1 - tx) * c[:, 1, 0] + tx * c[:, 1, 1]))


# ------------------------------------------------------------------------------- checks


def check_point(city, value, name: str, where: str = _WHERE) -> np.ndarray:
    """``value`` as a (2,) point, checked to lie inside the map and outside every building.

    Raises
    ------
    ValueError
        Naming ``name`` (``"start_xy"``, ``"--goal"``) and ``where``.
    """
    p = batch_array(value, name, where, (2,), batch=1)[0].astype(np.float64)
    x0, x1, y0, y1 = city.bounds
    if not (x0 < p[0] < x1 and y0 < p[1] < y1):
        raise ValueError(f"The {name!r} parameter of {where} must lie inside the map "
                         f"{tuple(float(b) for b in city.bounds)}. Got {p.tolist()} instead.")
    if bool(city.contains(p[None])[0]):
        raise ValueError(f"The {name!r} parameter of {where} must not lie inside a building. "
                         f"Got {p.tolist()} instead, which is inside one.")
    return p


def _check_flow_kind(flow):
    if not all(hasattr(flow, a) for a in ("frames_u", "t", "speed", "direction_deg", "x", "y",
                                          "dx", "wind_field")):
        raise ValueError(f"The 'flow' parameter of {_WHERE} must be a FlowSolution (e.g. "
                         f"simulate_flow(city, speed, direction_deg)). Got "
                         f"{type(flow).__name__} instead.")


def _check_flow(flow, speed: float, direction_deg: float, city):
    _check_flow_kind(flow)
    if flow.frames_u is None or flow.t is None or flow.t.size < 2:
        raise ValueError(f"The 'flow' parameter of {_WHERE} must hold recorded frames "
                         "(simulate with record_every > 0, e.g. simulate_flow). Got a mean "
                         "field only instead.")
    turn = (float(flow.direction_deg) - float(direction_deg) + 180.0) % 360.0 - 180.0
    if not (math.isclose(flow.speed, speed, rel_tol=1e-9)
            and math.isclose(turn, 0.0, abs_tol=1e-9)):  # 315 deg is -45 deg (API audit)
        raise ValueError(f"The 'flow' parameter of {_WHERE} must be simulated at speed={speed} "
                         f"and direction_deg={direction_deg}. Got speed={flow.speed} and "
                         f"direction_deg={flow.direction_deg} instead.")
    x0, x1, y0, y1 = city.bounds
    if not (flow.x[0] - flow.dx <= x0 and flow.x[-1] + flow.dx >= x1
            and flow.y[0] - flow.dx <= y0 and flow.y[-1] + flow.dx >= y1):
        raise ValueError(f"The 'flow' parameter of {_WHERE} must cover the map "
                         f"{tuple(float(b) for b in city.bounds)}. Got a grid over "
                         f"x {flow.x[0]:g}..{flow.x[-1]:g}, y {flow.y[0]:g}..{flow.y[-1]:g} "
                         "instead.")


# ------------------------------------------------------------------------------ the loop


class _RouteFollower:
    """Acceleration commands that fly an :class:`EnergyRoute` (see the module docstring)."""

    RAMP = 2.0        # m/s^2, speed ramp at take-off and before the goal
    V_START = 0.5     # m/s, reference speed at the start of the ramp
    LAG = 4.0         # m, distance behind the reference beyond which it waits

    def __init__(self, route, kp: float, kd: float):
        self.samples = np.asarray(route.samples, dtype=np.float64)
        pieces = np.diff(self.samples, axis=0)
        lengths = np.hypot(pieces[:, 0], pieces[:, 1])
        self.s_knots = np.concatenate([[0.0], np.cumsum(lengths)])
        self.length = float(self.s_knots[-1])
        self.tangent = pieces / np.maximum(lengths, 1e-12)[:, None]
        self.speeds = np.asarray(route.speeds, dtype=np.float64)
        self.kp, self.kd = kp, kd
        self.s = 0.0

    def _piece(self, s: float) -> int:
        return int(np.clip(np.searchsorted(self.s_knots, s, side="right") - 1, 0,
                           self.speeds.size - 1))

    def speed(self, s: float) -> float:
        if self.speeds.size == 0:
            return 0.0
        v = self.speeds[self._piece(s)]
        v = min(v, math.sqrt(self.V_START**2 + 2.0 * self.RAMP * s))
        return min(v, math.sqrt(2.0 * self.RAMP * max(self.length - s, 0.0)))

    def command(self, pos: np.ndarray, vel: np.ndarray, dt: float) -> np.ndarray:
        if self.speeds.size == 0:
            return self.kp * (self.samples[-1] - pos) - self.kd * vel
        k = self._piece(self.s)
        ref = self.samples[k] + (self.s - self.s_knots[k]) * self.tangent[k]
        v_ref = self.speed(self.s) * self.tangent[k]
        behind = float(np.hypot(*(ref - pos)))
        a = self.kp * (ref - pos) + self.kd * (v_ref - vel)
        if behind < self.LAG:
            self.s = min(self.length, self.s + self.speed(self.s) * dt)
        return a


class _EscapeFollower(_RouteFollower):
    """The route follower of an escape (``ea-mppi-w-esc``): its reference starts at, and never
    falls behind, the vehicle's projection onto the route, so a vehicle that joins the route
    ahead of the reference is not held back by it (the plain follower waits for a vehicle more
    than ``LAG`` behind, which deadlocks when the vehicle is ahead)."""

    def __init__(self, route, kp: float, kd: float, s_from: float):
        super().__init__(route, kp, kd)
        self.s = s_from

    def command(self, pos: np.ndarray, vel: np.ndarray, dt: float) -> np.ndarray:
        from windnav.plan import route_projection

        self.s = max(self.s, route_projection(self.samples, pos)[0])
        return super().command(pos, vel, dt)


class _FastestRouteFn:
    """``route_fn`` of :class:`~windnav.plan.FastestEscape`: the least-time route from a
    position to ``goal`` in the mean wind of ``flow`` on the GS lattice (spacing ``dx``,
    ``clearance`` from buildings), airspeed at most ``airspeed``, the search weighing
    ``gust_k`` deviations of the recorded wind (:func:`windnav.plan.reach.wind_covariance`)
    when > 0; the lattice is built here, once, and ``ms`` lists the build's and each search's
    wall time, ms."""

    speed_max = 20.0  # m/s, the GS routes' largest ground speed

    def __init__(self, city, flow, goal, airspeed: float, dx: float, clearance: float,
                 edge_m: float = 0.0, gust_k: float = 0.0):
        from windnav.plan.reach import reach_lattice, wind_covariance

        t0 = time.perf_counter()
        gust = wind_covariance(flow) if gust_k > 0 else None
        lattice = reach_lattice(city, flow.wind_field(), dx=dx, clearance=clearance, gust=gust)
        x0, x1, y0, y1 = city.bounds
        # the edge guard's band is no place for the route either, but on a side with the goal
        # inside it (a suite whose rule keeps goals nearer the edge than the guard, as a small
        # city's may) the band narrows to leave the goal a cell clear of it: the goal was
        # refused as "within 6 m of a building", and the flight ended in a harness error
        if edge_m > 0:
            w, e, s, n = (min(edge_m, d - lattice.dx) for d in
                          (goal[0] - x0, x1 - goal[0], goal[1] - y0, y1 - goal[1]))
            inside_x = (lattice.x >= x0 + w) & (lattice.x <= x1 - e)
            inside_y = (lattice.y >= y0 + s) & (lattice.y <= y1 - n)
            lattice = dataclasses.replace(
                lattice, free=lattice.free & inside_y[:, None] & inside_x[None, :])
        self.lattice = lattice
        self.goal, self.airspeed, self.gust_k = goal, airspeed, gust_k
        self.ms = [1e3 * (time.perf_counter() - t0)]

    def __call__(self, position_xy):
        from windnav.plan.reach import fastest_route

        t0 = time.perf_counter()
        route = fastest_route(self.lattice, position_xy, self.goal,
                              airspeed_max=self.airspeed, speed_max=self.speed_max,
                              gust_k=self.gust_k)
        self.ms.append(1e3 * (time.perf_counter() - t0))
        return route


class _FastWind:
    """``GriddedWind.velocity`` for one position per call without its per-call checks (the
    loop's positions are finite (1, 3) float64 arrays): the frame bracket by bisection, then
    the same compiled interpolation. ~25x faster per query than the checked method."""

    def __init__(self, field):
        from windnav.wind.gridded import _interpolate

        self.field = field
        self._interpolate = _interpolate
        self._t = [float(v) for v in field.t]
        self._out = np.empty((1, 3))

    def __call__(self, t: float, xyz: np.ndarray) -> np.ndarray:
        ts = self._t
        if t <= ts[0]:
            k, c = 0, 0.0
        elif t >= ts[-1]:
            k, c = len(ts) - 2, 1.0
        else:
            k = bisect.bisect_right(ts, t) - 1
            c = (t - ts[k]) / (ts[k + 1] - ts[k])
        f = self.field
        self._interpolate(f.x, f.y, f._frames, k, k + 1, c, xyz, self._out)
        return self._out


def with_power_shape(config, shape: str):
    """``config`` with the power curve of :data:`POWER_SHAPES` ``shape``, scaled to its hover
    power (so ``P_hover``, and the non-dimensional costs' scale, stay the vehicle's)."""
    from dataclasses import replace

    from windnav.vehicle.power import PowerCurve

    curve = {"crazyflie": PowerCurve.crazyflie}[shape]()
    c = np.asarray(curve.coefficients, dtype=np.float64)
    scaled = c * (config.hover_power / c[0])
    return replace(config, power_coefficients=tuple(float(x) for x in scaled),
                   power_speed_max=float(curve.speed_max))


def _default_params():
    from windnav.vehicle import params

    return params("hummingbird")


def tilt_accel_cap(tilt_deg: float) -> float:
    """The horizontal acceleration at the tilt cap ``tilt_deg`` (degrees) while holding altitude,
    m/s^2: ``g tan(tilt)``. The closed loop clips commands to this disk; the MPPI planner's
    per-axis bound is the box inside it, ``tilt_accel_cap(tilt) / sqrt 2``."""
    from windnav.vehicle.params import GRAVITY

    return GRAVITY * math.tan(math.radians(tilt_deg))


def navigate(
    city,
    start_xy,
    goal_xy,
    *,
    speed: float | None = None,
    direction_deg: float | None = None,
    variant: str,
    rng: np.random.Generator | int | None = None,
    flow=None,
    altitude: float = 10.0,
    horizon: float = math.inf,
    vehicle=None,
    config=None,
    planner=None,
    tilt_max_deg: float = TILT_MAX_DEG,
    control_rate_hz: float = 100.0,
    plan_rate_hz: float = 10.0,
    duration: float | None = None,
    route_dx: float = ROUTE_DX,
    route_clearance: float = ROUTE_CLEARANCE,
    planner_overrides: dict | None = None,
    capture_radius: float = CAPTURE_RADIUS,
    decoder=None,
    onboard=None,
    escape=None,
    power_shape: str | None = None,
    outside: str = "zero",
) -> NavigationResult:
    """Fly from ``start_xy`` to ``goal_xy`` through ``city`` in its urban wind (closed loop).

    Parameters
    ----------
    city : windnav.city.City
    start_xy, goal_xy : array_like of shape (2,)
        m, world; inside the map and outside every building.
    speed : float, optional
        Inlet wind speed, m/s. Required without ``flow``; with it, default ``flow.speed``.
    direction_deg : float, optional
        Direction the wind blows toward, degrees counter-clockwise from +x. Required without
        ``flow``; with it, default ``flow.direction_deg``.
    variant : str
        A key of :data:`windnav.plan.VARIANTS`.
    rng : numpy.random.Generator or int or None, keyword-only
        Seeds the planner's sampling and the LiDAR noise. Same seed, same flight (None:
        fresh entropy, a flight that does not repeat).
    flow : FlowSolution, optional
        The wind, precomputed (reuse it across variants); default :func:`simulate_flow` at
        ``speed`` and ``direction_deg``, run here without a progress bar (most of a call's
        time: about 15 s on a 400 m map against under 1 s of flight; ``simulate_flow(...,
        progress=True)`` shows it). It must have recorded frames, and match ``speed`` and
        ``direction_deg`` (modulo 360 deg) where they are given.
    altitude : float
        Flight altitude held by the controller, m.
    horizon : float
        ``H``, side of the window inside which the ``-w`` MPPI variants know the wind, m. For
        ``ea-mppi-w-hat`` the window is the decoder's grid (``H Delta = 25`` m); a smaller
        finite ``horizon`` shrinks it.
    vehicle : MultirotorParams, optional
        Default: the Hummingbird.
    config : PlannerConfig, optional
        The planner's configuration; default ``planner_config(vehicle, variant,
        horizon=horizon, a_max=g tan(tilt_max) / sqrt(2), **planner_overrides)``.
    planner : object, optional
        Replaces the MPPI planner: anything with ``update(state, scan, wind) -> (2,)`` (a
        ``stats`` attribute is read when present). For tests and ablations.
    tilt_max_deg : float
        Tilt cap: horizontal commands are clipped to ``g tan(tilt_max)``, degrees (0-80). A
        vehicle whose full thrust cannot hold its altitude at that tilt gets the tilt it can
        (:func:`windnav.plan.config.acceleration_limit`), with a warning: the Hummingbird
        and the Crazyflie can tilt to 84 and 74 deg, so only a heavier or weaker vehicle does.
    control_rate_hz, plan_rate_hz : float
        Controller and planner rates, Hz; the planner's a whole number of control steps.
    duration : float, optional
        Longest flight, s; default (and at most) the end of the recorded wind.
    route_dx, route_clearance : float
        Lattice spacing and building clearance of the GS route, m.
    planner_overrides : dict, optional
        Extra :class:`~windnav.plan.PlannerConfig` fields for the default configuration.
    capture_radius : float
        Hand over to a position hold at the goal once within this distance of it, m (see the
        module docstring; our addition, the same for every variant). 0 keeps the planner
        flying until the flight ends.
    decoder : object, optional
        ``ea-mppi-w-hat`` only: the wind flow decoder (``offsets``, ``predict``); default the
        shipped one (:func:`windnav.experiments.onboard.default_decoder`).
    onboard : OnboardOptions or dict, optional
        ``ea-mppi-w-hat`` only: settings of the onboard stack (UKF conditions, default
        ``"thesis"``; decoder rate, default 50 Hz; ...), see
        :class:`windnav.experiments.onboard.OnboardOptions`.
    escape : EscapeConfig, optional
        Variants with a route escape (``ea-mppi-w-esc``) only: the progress monitor's window and
        threshold and the escape's length (:class:`windnav.plan.EscapeConfig`; default its
        defaults). The result's ``settings["escapes"]`` lists every escape as
        ``(t_s, s_from_m, s_to_m)``.
    power_shape : str, optional
        A counterfactual power curve (:data:`POWER_SHAPES`) for the planner's ``J_E`` and for
        ``energy_J``, scaled to the vehicle's hover power; the vehicle flies as before and
        ``rotor_energy_J`` is its own. Default None: the vehicle's steady-flight sweep.
    outside : {"zero", "truth"}
        The ``-w`` MPPI variants with a finite ``horizon`` only: the planner's wind outside
        ``L_t``, zero (the thesis's) or the true mean wind at the vehicle at each planning step
        (ours, :func:`local_wind`: the onboard stack's ``outside="robot"`` with a perfect
        estimate, which separates the fill's effect from the estimate's).

    Returns
    -------
    NavigationResult

    Raises
    ------
    ValueError
        On a start or goal outside the map or inside a building, an unknown variant, no
        ``speed`` or ``direction_deg`` without a ``flow``, a flow that does not match them,
        invalid rates, or (``ea-mppi-w-hat``) a ``config`` whose window is wider than the
        decoder's grid.
    """
    from windnav.control import SE3Controller
    from windnav.plan import (
        VARIANTS,
        EscapeConfig,
        FastestEscape,
        MPPIPlanner,
        RouteEscape,
        energy_route,
        planner_config,
    )
    from windnav.plan.config import acceleration_limit
    from windnav.plan.reach import FastestRoute
    from windnav.vehicle import Multirotor
    from windnav.vehicle.params import GRAVITY

    if variant not in VARIANTS:
        raise ValueError(f"The 'variant' parameter of {_WHERE} must be one of "
                         f"{list(VARIANTS)}. Got {variant!r} instead.")
    check_city(city, _WHERE)
    start = check_point(city, start_xy, "start_xy")
    goal = check_point(city, goal_xy, "goal_xy")
    if flow is not None:  # a flow carries its inlet: speed and direction_deg may be left out
        _check_flow_kind(flow)
        speed = flow.speed if speed is None else speed
        direction_deg = flow.direction_deg if direction_deg is None else direction_deg
    for name, value in (("speed", speed), ("direction_deg", direction_deg)):
        if value is None:
            raise ValueError(f"The {name!r} parameter of {_WHERE} must be given when 'flow' is "
                             "not (the wind to simulate). Got None instead.")
    speed = positive_float(speed, "speed", _WHERE)
    direction_deg = finite_float(direction_deg, "direction_deg", _WHERE)
    altitude = positive_float(altitude, "altitude", _WHERE)
    capture = positive_float(capture_radius, "capture_radius", _WHERE, allow_zero=True)
    tilt = finite_float(tilt_max_deg, "tilt_max_deg", _WHERE)
    if not 0.0 < tilt < TILT_LIMIT_DEG:
        raise ValueError(f"The 'tilt_max_deg' parameter of {_WHERE} must be in "
                         f"(0, {TILT_LIMIT_DEG:g}). Got {tilt_max_deg!r} instead.")
    control_dt = 1.0 / positive_float(control_rate_hz, "control_rate_hz", _WHERE)
    ratio = control_rate_hz / positive_float(plan_rate_hz, "plan_rate_hz", _WHERE)
    plan_every = int(round(ratio))
    if plan_every < 1 or abs(ratio - plan_every) > 1e-9 * ratio:
        raise ValueError(f"The 'plan_rate_hz' parameter of {_WHERE} must divide "
                         f"control_rate_hz={control_rate_hz:g}. Got {plan_rate_hz!r} instead.")
    gen = generator(rng, "rng", _WHERE)
    planner_rng, lidar_rng = gen.spawn(2)

    if flow is None:
        flow = simulate_flow(city, speed, direction_deg)
    _check_flow(flow, speed, direction_deg, city)
    end = float(flow.t[-1])
    if duration is not None:
        asked = positive_float(duration, "duration", _WHERE)
        if asked > end + 1e-9:  # it was cut to the wind's end silently
            warnings.warn(f"{_WHERE}: the flow's frames end at {end:g} s, so the flight ends "
                          f"there, not at the {asked:g} s asked for (simulate the flow longer)",
                          stacklevel=2)
        end = min(end, asked)
    wind_at = _FastWind(flow.wind_field(unsteady=True))

    params = _default_params() if vehicle is None else vehicle
    a_vehicle = acceleration_limit(params)  # at full thrust, holding altitude
    tilt_vehicle = math.degrees(math.atan2(a_vehicle, GRAVITY))
    if tilt_vehicle < tilt:  # the planner and the hold asked for what the rotors cannot give
        warnings.warn(f"{_WHERE}: at full thrust the vehicle holds its altitude up to "
                      f"{a_vehicle:.3g} m/s^2 of horizontal acceleration ({tilt_vehicle:.1f} deg "
                      f"of tilt), less than the {tilt:g} deg tilt cap's "
                      f"{tilt_accel_cap(tilt):.3g}: the cap is lowered to {tilt_vehicle:.1f} deg "
                      "(settings' tilt_max_deg)", stacklevel=2)
        tilt = tilt_vehicle
    a_cap = tilt_accel_cap(tilt)
    model = Multirotor(params)
    controller = SE3Controller(params)
    n_max = int(math.floor(end / control_dt + 1e-9)) + 1
    if n_max > MAX_CONTROL_STEPS:  # 1e12 Hz tried to allocate 6.55 TiB of series
        raise ValueError(f"The 'control_rate_hz' parameter of {_WHERE} must give at most "
                         f"{MAX_CONTROL_STEPS:.0e} control steps over the {end:g} s flown. Got "
                         f"{control_rate_hz!r} instead ({n_max:.3g} steps).")
    if n_max < 2:  # a flight of no step, reported as a timeout with no energy
        raise ValueError(f"The 'control_rate_hz' parameter of {_WHERE} must give at least one "
                         f"control step in the {end:g} s flown. Got {control_rate_hz!r} "
                         "instead.")
    onboard_stack = None
    if VARIANTS[variant].wind_source == "onboard":
        from windnav.experiments.onboard import OnboardOptions, OnboardStack

        onboard_stack = OnboardStack(
            city, model, params, speed=speed, direction_deg=direction_deg,
            control_rate_hz=1.0 / control_dt, plan_rate_hz=plan_rate_hz, n_max=n_max, rng=gen,
            decoder=decoder, options=OnboardOptions.coerce(onboard, _WHERE))
        window = onboard_stack.window
        if config is not None and not config.horizon <= window + 1e-9:
            raise ValueError(f"The 'config' parameter of {_WHERE} must have a horizon of at "
                             f"most the decoder's window {window:g} m for {variant!r}. Got "
                             f"{config.horizon!r} instead.")
        if isinstance(horizon, (int, float)) and math.isfinite(horizon) and \
                horizon > window + 1e-9:  # was cut to the window silently (CLI audit)
            raise ValueError(f"The 'horizon' parameter of {_WHERE} must be at most the "
                             f"decoder's window {window:g} m for {variant!r} (or inf: the "
                             f"window). Got {horizon!r} instead.")
        if isinstance(horizon, (int, float)) and horizon > 0:  # else planner_config names it
            horizon = min(horizon, window)
    if outside not in ("zero", "truth") or (outside == "truth" and not (
            VARIANTS[variant].use_wind and VARIANTS[variant].wind_source == "truth"
            and VARIANTS[variant].planner != "gs" and 0 < horizon < math.inf)):
        raise ValueError(f"The 'outside' parameter of {_WHERE} must be 'zero', or 'truth' for "
                         f"an MPPI variant with the true wind and a finite horizon > 0. Got "
                         f"{outside!r} for {variant!r} with horizon {horizon!r} instead.")
    if power_shape is not None and power_shape not in POWER_SHAPES:
        raise ValueError(f"The 'power_shape' parameter of {_WHERE} must be None or one of "
                         f"{list(POWER_SHAPES)}. Got {power_shape!r} instead.")
    if config is None:
        overrides = {"a_max": a_cap / math.sqrt(2.0), "rate_hz": float(plan_rate_hz),
                     **(planner_overrides or {})}
        config = planner_config(params, variant, horizon=horizon, **overrides)
    planned_rate = getattr(config if planner is None else getattr(planner, "config", None),
                           "rate_hz", None)  # a planner without a config: nothing to check
    if (planned_rate is not None and VARIANTS[variant].planner != "gs"
            and not math.isclose(planned_rate, plan_rate_hz, rel_tol=1e-9)):
        # the planner shifts its warm start by 1 / rate_hz at each update: at another rate its
        # plan would be shifted by the wrong time (a 5 or 20 Hz loop shifted it 0.1 s; audit)
        raise ValueError(f"The 'plan_rate_hz' parameter of {_WHERE} must equal the planner "
                         f"configuration's rate_hz, {planned_rate:g} Hz (its warm start is "
                         f"shifted by 1 / rate_hz at each update). Got {plan_rate_hz!r} "
                         "instead.")
    if power_shape is not None:
        config = with_power_shape(config, power_shape)
    kp_xy, kd_xy = controller.gains.kp_pos[0], controller.gains.kd_pos[0]
    kp_z, kd_z = controller.gains.kp_pos[2], controller.gains.kd_pos[2]
    az_cap = 0.5 * GRAVITY

    # the planner, or the GS route and its follower
    follower, route, plan_ms, route_hold_J = None, None, [], None
    use_wind = bool(VARIANTS[variant].use_wind)
    mean_uv = (np.ascontiguousarray(np.stack([flow.mean_u, flow.mean_v]))
               if use_wind and onboard_stack is None else None)
    # checked once here, not at each update (every window of a finite field is finite)
    mean_finite = mean_uv is not None and bool(np.all(np.isfinite(mean_uv)))
    if planner is None and VARIANTS[variant].planner == "gs":
        gs_config = config if config.planner == "gs" else planner_config(params, variant)
        t0 = time.perf_counter()
        mean_wind = flow.wind_field()
        # GS plans in still air: the wind goes only to a config that uses it
        route = energy_route(city, start, goal, gs_config,
                             wind=mean_wind if gs_config.use_wind else None,
                             dx=route_dx, clearance=route_clearance, altitude=altitude)
        plan_ms.append(1e3 * (time.perf_counter() - t0))
        follower = _RouteFollower(route, kp_xy, kd_xy)
        # the goal hold the route leaves out: HOLD_S at rest in the wind it was planned in
        w_goal = (np.asarray(mean_wind.velocity(0.0, np.array([[*goal, altitude]])))[0, :2]
                  if gs_config.use_wind else np.zeros(2))
        route_hold_J = float(gs_config.power(math.hypot(*w_goal))) * HOLD_S
    elif planner is None:
        planner = MPPIPlanner(config, goal, rng=planner_rng)
    escape_guide = escape_follower = None
    if escape is not None and not isinstance(escape, EscapeConfig):
        raise ValueError(f"The 'escape' parameter of {_WHERE} must be an EscapeConfig or None. "
                         f"Got {type(escape).__name__} instead.")
    if VARIANTS[variant].escape and follower is None:
        t0 = time.perf_counter()
        if escape is not None and escape.airspeed_mps is not None:
            escape_guide = FastestEscape(
                _FastestRouteFn(city, flow, goal, escape.airspeed_mps, route_dx,
                                  route_clearance, escape.edge_m, escape.gust_k), goal, escape,
                bounds=city.bounds, deadline_s=end - HOLD_S)
        else:
            route = energy_route(city, start, goal, planner_config(params, "gs-w"),
                                 wind=flow.wind_field(), dx=route_dx, clearance=route_clearance,
                                 altitude=altitude)
            escape_guide = RouteEscape(route.samples, goal, escape)
        escape_ms = 1e3 * (time.perf_counter() - t0)
    regain = 0.0  # the hold is released beyond this distance from the goal (0: never), m
    if isinstance(escape_guide, FastestEscape) and escape.regain_m > 0:
        if escape.regain_inside(capture):
            raise ValueError(f"The 'escape' parameter of {_WHERE} must have regain_m larger "
                             f"than capture_radius={capture:g} m (the hold begins within it). "
                             f"Got regain_m={escape.regain_m:g} instead.")
        regain = escape.regain_m
    regain_after = -math.inf  # no new route searched before this time after a failed one, s

    # the loop -------------------------------------------------------------------------------
    x = model.hover_state(np.array([start[0], start[1], altitude])).to_array()
    out = np.empty_like(x)
    N = model.n_rotors
    lo = model.packed.rotor_speed_min[:, None]
    hi = model.packed.rotor_speed_max[:, None]
    yaw, yaw_rate = np.zeros(1), np.zeros(1)
    x0b, x1b, y0b, y1b = city.bounds
    T_pos = np.empty((n_max, 3))
    T_vel = np.empty((n_max, 3))
    T_wind = np.empty((n_max, 2))
    T_acc = np.empty((n_max, 2))
    T_eta = np.empty((n_max, N))
    a_cmd = np.zeros((1, 3))
    a_xy = np.zeros(2)
    com = np.zeros((1, 3))
    # every hub sees the centre-of-mass wind: a (1, N, 3) view of ``com`` (stride 0 over hubs)
    hub = np.ndarray((1, N, 3), np.float64, com, 0, (com.strides[0], 0, com.strides[1]))
    xyz = np.zeros((1, 3))
    fx0, fx1, fy0, fy1 = (np.ascontiguousarray(c) for c in city.footprints.T)
    loop_fallbacks = 0
    goal_since = hover_since = holding = None
    cmd = None
    outcome = "timeout"
    diverged_s = None
    n = n_max
    wall0 = time.perf_counter()
    for k in range(n_max):
        t = k * control_dt
        pos = x[0, 0:3]
        vel = x[0, 3:6]
        xyz[0] = pos
        w = wind_at(t, xyz)
        T_pos[k] = pos
        T_vel[k] = vel
        T_wind[k] = w[0, :2]
        T_eta[k] = x[0, 13:13 + N]
        # termination ---------------------------------------------------------------------
        px, py = pos[0], pos[1]
        if not (x0b <= px <= x1b and y0b <= py <= y1b):
            outcome = "left_map"
        elif ((fx0 <= px) & (px <= fx1) & (fy0 <= py) & (py <= fy1)).any():  # City.contains
            outcome = "collision"
        else:
            v_norm = math.sqrt(vel[0] ** 2 + vel[1] ** 2 + vel[2] ** 2)
            d_goal = math.hypot(px - goal[0], py - goal[1])
            at_goal = d_goal <= GOAL_RADIUS
            if holding is None and d_goal <= capture:
                holding = t
            elif (regain > 0 and holding is not None and d_goal > regain and t >= regain_after
                  and k % plan_every == 0):  # blown off the goal: a new least-time route
                if escape_guide.restart(t, pos[:2]) is None:
                    regain_after = t + escape.window_s
                else:
                    holding, escape_follower = None, None
            if at_goal and v_norm <= GOAL_SPEED:
                goal_since = t if goal_since is None else goal_since
            else:
                goal_since = None
            if not at_goal and v_norm <= HOVER_SPEED:
                hover_since = t if hover_since is None else hover_since
            else:
                hover_since = None
            if goal_since is not None and t - goal_since >= HOLD_S - 1e-9:
                outcome = "success"
            elif hover_since is not None and t - hover_since >= HOLD_S - 1e-9:
                outcome = "hover"
        if outcome != "timeout" or k == n_max - 1:
            n = k + 1
            T_acc[k] = a_xy
            break
        # onboard wind stack (ea-mppi-w-hat): sensors and UKF at 100 Hz, decoder at 50 Hz ----
        if onboard_stack is not None:
            onboard_stack.step(k, x, w[0], cmd)
        # planning, 10 Hz -----------------------------------------------------------------
        if holding is not None:
            a_xy = kp_xy * (goal - pos[:2]) - kd_xy * vel[:2]
        elif follower is not None:
            a_xy = follower.command(pos[:2], vel[:2], control_dt)
        elif escape_follower is not None or (escape_guide is not None and k % plan_every == 0
                                             and escape_guide.update(t, pos[:2]) is not None):
            if escape_follower is None:  # an escape begins: fly the route from the projection
                if isinstance(escape_guide, FastestEscape):
                    route = escape_guide.route
                escape_follower = _EscapeFollower(route, kp_xy, kd_xy, escape_guide.active[0])
            a_xy = escape_follower.command(pos[:2], vel[:2], control_dt)
            if k % plan_every == plan_every - 1 and escape_guide.update(t, pos[:2]) is None:
                escape_follower = None  # the escape ended: MPPI from a fresh warm start
                if hasattr(planner, "reset"):
                    planner.reset()
        elif k % plan_every == 0:
            scan = city.lidar(pos[None, :2], n_rays=LIDAR_RAYS, max_range=LIDAR_RANGE,
                              noise_std=LIDAR_NOISE, rng=lidar_rng)[0]
            if onboard_stack is not None:
                known = onboard_stack.local_wind(pos[:2])
            else:
                known = (local_wind(flow, pos[:2], config.horizon, uv=mean_uv,
                                    known_finite=mean_finite, outside=outside)
                         if use_wind else None)
            a_new = np.asarray(planner.update(np.array([px, py, vel[0], vel[1]]), scan, known),
                               dtype=np.float64).reshape(-1)
            if a_new.shape != (2,) or not np.all(np.isfinite(a_new)):
                loop_fallbacks += 1
                a_new = np.zeros(2)
            a_xy = a_new
        # control, 100 Hz -----------------------------------------------------------------
        norm = math.hypot(a_xy[0], a_xy[1])
        scale = a_cap / norm if norm > a_cap else 1.0
        a_cmd[0, 0] = a_xy[0] * scale
        a_cmd[0, 1] = a_xy[1] * scale
        a_cmd[0, 2] = min(max(kp_z * (altitude - pos[2]) - kd_z * vel[2], -az_cap), az_cap)
        T_acc[k] = a_cmd[0, :2]
        if onboard_stack is not None:
            t_ctl = time.perf_counter()
        cmd, _ = controller.accelerate(x, a_cmd, yaw, yaw_rate)
        np.minimum(cmd, hi, out=cmd)
        np.maximum(cmd, lo, out=cmd)
        if onboard_stack is not None:
            onboard_stack.add_time("control", 1e3 * (time.perf_counter() - t_ctl))
        com[0] = w[0]
        model.step_packed(x, cmd, com, hub, control_dt, out)
        x, out = out, x
        if not np.all(np.isfinite(x)):  # the vehicle left the model: stop, keep what was flown
            n = k + 1
            outcome = "collision" if city.contains(T_pos[k:k + 1, :2])[0] else "left_map"
            diverged_s = (k + 1) * control_dt
            # said, not only classified: a state that stopped being finite is the simulation
            # failing, which the outcome alone would pass off as the flight's (audit)
            warnings.warn(f"{_WHERE}: the vehicle's state became non-finite at "
                          f"{diverged_s:.2f} s (the simulation left its model); the flight "
                          f"ends there, recorded as {outcome!r}", RuntimeWarning, stacklevel=2)
            break
    wall = time.perf_counter() - wall0

    # results --------------------------------------------------------------------------------
    from windnav.vehicle.power import energy as cumulative_energy

    t = np.arange(n) * control_dt
    vel_xy = T_vel[:n, :2]
    air = np.hypot(*(vel_xy - T_wind[:n]).T)
    power = config.power(air)
    eff = getattr(params, "motor_efficiency", 1.0)
    rotor_power = float(model.packed.k_m[0]) * np.sum(np.abs(T_eta[:n]) ** 3, axis=1) / eff
    e = cumulative_energy(t, power)
    e_rot = cumulative_energy(t, rotor_power)
    steps = np.diff(T_pos[:n, :2], axis=0)
    stats = getattr(planner, "stats", None)
    reasons = dict(getattr(stats, "reasons", {}) or {})
    if loop_fallbacks:
        reasons["nan"] = reasons.get("nan", 0) + loop_fallbacks
    if stats is not None and getattr(stats, "total_ms", None):
        plan_ms = list(stats.total_ms)
    updates = (int(getattr(stats, "updates", 0)) if stats is not None
               else (1 if follower is not None else (n - 1 + plan_every - 1) // plan_every))
    settings = {"speed": speed, "direction_deg": direction_deg, "altitude": altitude,
                "horizon": config.horizon, "tilt_max_deg": tilt, "a_max": config.a_max,
                "control_rate_hz": 1.0 / control_dt, "plan_rate_hz": plan_rate_hz,
                "duration_max_s": end, "vehicle": getattr(params, "name", ""),
                "capture_radius": capture, "hold_started_s": holding,
                "airspeed_limit": float(getattr(params, "airspeed_limit", math.inf)),
                "power_speed_max": float(config.power_speed_max)}
    if isinstance(route, FastestRoute):
        settings.update(route_time_s=route.time_s, route_length_m=route.length_m)
    elif route is not None:
        air_max = float(np.max(route.airspeeds)) if np.size(route.airspeeds) else 0.0
        settings.update(route_energy_J=route.energy, route_time_s=route.time,
                        route_length_m=route.length, route_airspeed_max_mps=air_max)
    if route_hold_J is not None:
        settings.update(route_hold_energy_J=route_hold_J)
    if isinstance(escape_guide, FastestEscape):
        escape_ms += sum(escape_guide.route_fn.ms)
    if escape_guide is not None:
        settings.update(escapes=[list(e) for e in escape_guide.escapes],
                        route_ms=escape_ms)
    report = None if onboard_stack is None else onboard_stack.report(n, plan_ms, air)
    return NavigationResult(
        outcome=outcome, variant=variant,
        energy_J=float(e[-1]), rotor_energy_J=float(e_rot[-1]), time_s=float(t[-1]),
        distance_m=float(np.sum(np.hypot(steps[:, 0], steps[:, 1]))),
        mean_cmd_accel=float(np.mean(np.hypot(*T_acc[:n].T))),
        planner_ms_median=float(np.median(plan_ms)) if plan_ms else float("nan"),
        fallbacks=int(sum(reasons.values())), fallback_reasons=reasons,
        planner_updates=updates, start=start, goal=goal, t=t,
        position=T_pos[:n].copy(), velocity=T_vel[:n].copy(), wind=T_wind[:n].copy(),
        airspeed=air, accel_cmd=T_acc[:n].copy(), power=power, rotor_power=rotor_power,
        energy=e, rotor_energy=e_rot,
        route=None if route is None else np.asarray(route.samples).copy(),
        wall_s=wall, settings=settings,
        wind_estimate=None if report is None else report.wind_estimate, onboard=report,
        diverged_s=diverged_s,
    )


# ------------------------------------------------------------------------- comparisons


def free_point(city, xy, *, clearance: float = 10.0, edge: float = 10.0,
               step: float = 2.0) -> np.ndarray:
    """The point nearest ``xy`` (m) at least ``clearance`` m from every building and ``edge`` m
    from the map's edge, searched on rings of spacing ``step``; raises ValueError when there
    is none."""
    xy = np.asarray(xy, dtype=np.float64)
    x0, x1, y0, y1 = city.bounds
    fp = city.footprints
    for r in np.arange(0.0, max(x1 - x0, y1 - y0), step):
        n = max(1, int(2 * math.pi * r / step))
        ang = np.arange(n) * 2 * math.pi / n
        cand = xy + r * np.stack([np.cos(ang), np.sin(ang)], axis=1)
        ok = ((cand[:, 0] >= x0 + edge) & (cand[:, 0] <= x1 - edge)
              & (cand[:, 1] >= y0 + edge) & (cand[:, 1] <= y1 - edge))
        dx = np.maximum(np.maximum(fp[None, :, 0] - cand[:, None, 0],
                                   cand[:, None, 0] - fp[None, :, 1]), 0.0)
        dy = np.maximum(np.maximum(fp[None, :, 2] - cand[:, None, 1],
                                   cand[:, None, 1] - fp[None, :, 3]), 0.0)
        ok &= np.all(np.hypot(dx, dy) >= clearance, axis=1)
        if ok.any():
            return cand[int(np.argmax(ok))]
    raise ValueError(f"The 'xy' parameter of free_point has no point {clearance} m clear of the "
                     f"buildings in the map. Got {xy.tolist()} instead.")


DEFAULT_SCENARIOS = (
    {"map_seed": 0, "speed": 5.0, "direction_deg": 0.0},
    {"map_seed": 1, "speed": 10.0, "direction_deg": 0.0},
    {"map_seed": 2, "speed": 5.0, "direction_deg": 180.0},
    {"map_seed": 3, "speed": 10.0, "direction_deg": 180.0},
)
"""The acceptance scenarios: 600 m planning maps, upwind/downwind flights across them."""


def compare_variants(
    scenarios: Sequence[dict] = DEFAULT_SCENARIOS,
    variants: Sequence[str] = ("mppi", "ea-mppi-w"),
    *,
    rng: int = 0,
    map_size: float = 600.0,
    start_xy=(80.0, 300.0),
    goal_xy=(520.0, 300.0),
    clearance: float = 40.0,
    edge: float = 50.0,
    progress: bool = False,
    **navigate_kwargs,
) -> dict:
    """Fly every variant on every scenario (one flow simulation per scenario).

    Each scenario is a dict with ``map_seed`` (:func:`windnav.city.planning_map`), ``speed``,
    ``direction_deg`` and optionally ``start_xy``, ``goal_xy`` (m; moved to the nearest point
    ``clearance`` m clear of the buildings and ``edge`` m from the map's edge,
    :func:`free_point`: MPPI's obstacle cost pushes its rest point away from buildings near the
    goal, see the module docstring's goal capture).

    Returns
    -------
    dict
        ``records``: one per (scenario, variant), the :meth:`NavigationResult.summary` plus the
        scenario; ``both_succeeded``: per scenario, whether ``variants[-1]`` used less
        ``energy_J`` than ``variants[0]`` where both succeeded (None otherwise); ``pairs``: how
        many scenarios both succeeded in, the evidence ``holds`` rests on (one, on the four
        default scenarios: ``docs/planner.md``); and ``holds``: True when that is so in every
        such scenario (False when there is none).
    """
    from windnav.city import planning_map

    records, verdicts = [], []
    for i, sc in enumerate(scenarios):
        city = planning_map(rng=int(sc["map_seed"]), size=map_size)
        start = free_point(city, sc.get("start_xy", start_xy), clearance=clearance, edge=edge)
        goal = free_point(city, sc.get("goal_xy", goal_xy), clearance=clearance, edge=edge)
        t0 = time.perf_counter()
        flow = simulate_flow(city, sc["speed"], sc["direction_deg"])
        flow_s = time.perf_counter() - t0
        runs = {}
        for v in variants:
            res = navigate(city, start, goal, speed=sc["speed"],
                           direction_deg=sc["direction_deg"], variant=v, rng=rng + i,
                           flow=flow, **navigate_kwargs)
            runs[v] = res
            rec = {"scenario": i, **sc, "flow_s": flow_s, **res.summary(),
                   "min_goal_distance_m": float(np.min(np.hypot(*(res.position[:, :2]
                                                                  - goal).T)))}
            records.append(rec)
            if progress:
                print(f"scenario {i} {v:10s} {res.outcome:9s} E={res.energy_J:8.0f} J "
                      f"E_rot={res.rotor_energy_J:8.0f} J t={res.time_s:6.1f} s "
                      f"wall={res.wall_s:5.2f} s", flush=True)
        a, b = runs[variants[0]], runs[variants[-1]]
        if a.outcome == b.outcome == "success":
            verdicts.append(bool(b.energy_J < a.energy_J))
        else:
            verdicts.append(None)
    decided = [v for v in verdicts if v is not None]
    return {"records": records, "both_succeeded": verdicts, "pairs": len(decided),
            "holds": bool(decided) and all(decided)}

