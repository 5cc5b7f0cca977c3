"""Progress monitor and route escape: the mechanism of the ``ea-mppi-w-esc`` variant (ours).

EA-MPPI+W fails mostly by stalling: in a local minimum of its cost (a building pocket, or the
rest point that the obstacle cost ``Q_O (D_max / d)^2`` pushes away from a goal near buildings)
or into a headwind its point-mass model underestimates. The mechanism watches the distance to
the goal and, when it has not shrunk for a while, hands the vehicle to the energy-optimal GS+W
route (:func:`windnav.plan.energy_route`, computed once before take-off with the map and the mean
wind, as the ``gs-w`` variant does) for a stretch of that route, then gives it back to MPPI.

The monitor (:class:`ProgressMonitor`), checked at every planner tick ``t``::

    stalled  <=>  t - t_ref >= window_s  and  d(t_ref) - d(t) < min_progress_m

where ``d`` is the horizontal distance to the goal and ``t_ref`` the start of the current window:
the window restarts (``t_ref = t``) whenever the vehicle got ``min_progress_m`` closer than at
``t_ref``. So it fires ``window_s`` after the last ``min_progress_m`` of progress (the mean
closing speed over the window fell below ``min_progress_m / window_s``), never before.

The escape (:class:`RouteEscape`): the arc length ``s`` of the vehicle's projection onto the
route, then an escape ``[s, min(s + length_m, L)]`` along it (``L`` the route's length; the loop
flies it with its route follower). It ends when the vehicle's projection passes its end; the
monitor then restarts, so a vehicle that stalls again escapes again. An escape that reaches the
route's end (the goal) does not end: the loop's goal capture takes over from it. (MPPI's own
rest point near a goal close to buildings lies 10-30 m from it, where the goal itself is the
route's nearest point.)

The least-time escape (:class:`FastestEscape`, ``EscapeConfig.airspeed_mps = A``): the same
monitor; at the first stall the route is planned from the vehicle's position (so never behind
it, as a projection onto a route planned at take-off can be) to the goal, as the least-time
route in the mean wind with the airspeed at most ``A`` (:func:`windnav.plan.reach.fastest_route`),
and flown to the goal at its ground speeds. In the 10 m/s headwinds of the benchmark the
energy-optimal GS+W route is too slow: its least time is what runs out.

Two more triggers begin the least-time escape: the edge guard (``edge_m``: within that distance
of the map's edge, which MPPI's cost does not see) and the pace trigger (``pace_margin_s``: the
closing speed over the last ``pace_window_s``, ``(d(t - W) - d(t)) / W``, would bring the
vehicle to the goal after ``deadline_s - pace_margin_s``, where ``deadline_s`` is the latest
arrival that still leaves the goal hold inside the flight). The pace trigger catches the slow
approaches into a headwind that keep just above the monitor's closing speed until time or the
hover rule runs out.

A take-off trigger (``launch_s``) begins it before MPPI flies at all, when the least time to the
goal in the mean wind is longer than ``launch_s``: the flights whose budget is tight. The
energy-aware planner approaches more slowly than the least time (that is what it trades for
energy), and in a flight whose least time is 60 of its 95 s the seconds MPPI spends before the
pace trigger can judge it may be the ones that run out. (Measured at ``launch_s = 40`` s on the
benchmark's 1,024 scenarios: no measurable change, 8 flights gained and 7 lost; see
``docs/navigation.md``.)

A further option acts after the goal capture: with ``regain_m``, a vehicle that the wind blows
farther than that from the goal it holds (the street jets of the strongest winds do) leaves the
hold and flies a new least-time route back (:meth:`FastestEscape.restart`), instead of the
hold's straight pull against the jet.

Defaults: ``window_s = 3`` s, ``min_progress_m = 2`` m (a mean closing speed below 0.67 m/s, and
it fires before the 5 s of ``|v| <= 1`` m/s that the loop counts as a hover failure),
``length_m = 60`` m (more than the sides of the 600 m maps' building blocks and gaps, so an
escape leaves a pocket or a goal-side rest point behind it).
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass

import numpy as np

from windnav._validate import batch_array, finite_float, positive_float

__all__ = [
    "EscapeConfig",
    "FastestEscape",
    "ProgressMonitor",
    "RouteEscape",
    "route_projection",
]


@dataclass(frozen=True)
class EscapeConfig:
    """Settings of the progress monitor and the route escape.

    Attributes
    ----------
    window_s : float
        How long the distance to the goal may fail to shrink by ``min_progress_m`` before the
        monitor fires, s (> 0).
    min_progress_m : float
        Progress toward the goal that restarts the window, m (> 0).
    length_m : float
        Arc length of the GS+W route flown per escape, from the vehicle's projection, m (> 0).
    airspeed_mps : float or None
        None: escapes fly the GS+W route (:class:`RouteEscape`). A number: the first stall
        hands the vehicle to the least-time route from where it stalled to the goal, in the
        mean wind with the airspeed at most this (m/s, > 0), for the rest of the flight
        (:class:`FastestEscape`; ``length_m`` is then unused).
    edge_m : float
        With ``airspeed_mps`` set: the escape also begins when the vehicle comes within this
        distance of the map's edge (m, >= 0; 0: never), where the wind would carry it off
        the map before any stall; and the route keeps out of that band (narrowed on the
        goal's side to leave a goal inside it a lattice cell clear, since the fifty-second
        session: a small city's suite may keep its goals nearer the edge; a start or goal
        inside the band then begins the escape as soon as the vehicle is there).
    pace_margin_s : float
        With ``airspeed_mps`` set: the escape also begins when, at its closing speed over the
        last ``pace_window_s``, the vehicle would reach the goal later than ``pace_margin_s``
        before the flight's deadline (s, >= 0; 0: never). Catches the slow approaches that
        keep just above the monitor's ``min_progress_m / window_s`` until time runs out.
    pace_window_s : float
        The window of that closing speed, s (> 0); the pace is not judged before one window
        has passed.
    launch_s : float
        With ``airspeed_mps`` set: at take-off, the least-time route from the start is planned,
        and flown from the first tick when its time in the mean wind is longer than this (s,
        >= 0; 0: never). Otherwise MPPI flies and the other triggers apply.
    regain_m : float
        With ``airspeed_mps`` set: once the closed loop holds the goal, a vehicle blown
        farther than this from it (m, >= 0; 0: never; more than the loop's capture radius)
        leaves the hold and flies a new least-time route from where it is back to the goal
        (:meth:`FastestEscape.restart`), until the next capture.
    gust_k : float
        With ``airspeed_mps`` set: the least-time routes are searched with each move's ground
        speed lowered by ``gust_k`` standard deviations of the recorded wind along it
        (:func:`windnav.plan.reach.least_time`; >= 0; 0: the mean wind alone), so that they
        keep out of the streets whose gusts stop the vehicle; they are flown, and their time
        judged by ``launch_s``, at the mean wind's speeds.
    """

    window_s: float = 3.0
    min_progress_m: float = 2.0
    length_m: float = 60.0
    airspeed_mps: float | None = None
    edge_m: float = 0.0
    pace_margin_s: float = 0.0
    pace_window_s: float = 10.0
    regain_m: float = 0.0
    launch_s: float = 0.0
    gust_k: float = 0.0

    def __post_init__(self):
        for name in ("window_s", "min_progress_m", "length_m", "pace_window_s"):
            object.__setattr__(self, name, positive_float(getattr(self, name), name,
                                                          "EscapeConfig"))
        if self.airspeed_mps is not None:
            object.__setattr__(self, "airspeed_mps", positive_float(
                self.airspeed_mps, "airspeed_mps", "EscapeConfig"))
        for name in ("edge_m", "pace_margin_s", "regain_m", "launch_s", "gust_k"):
            object.__setattr__(self, name, positive_float(getattr(self, name), name,
                                                          "EscapeConfig", allow_zero=True))
            if getattr(self, name) > 0 and self.airspeed_mps is None:
                raise ValueError(f"The '{name}' parameter of EscapeConfig needs airspeed_mps "
                                 f"(it begins the least-time escape). Got {name}="
                                 f"{getattr(self, name)} with airspeed_mps=None instead.")

    def regain_inside(self, capture_radius_m: float) -> bool:
        """True when ``regain_m`` is set but no larger than the closed loop's capture radius,
        m: the hold begins within that radius, so such a regain would be meaningless (the
        closed loop and the benchmark both refuse it)."""
        return 0.0 < self.regain_m <= capture_radius_m


class ProgressMonitor:
    """Fires when the distance to ``goal_xy`` has not shrunk by ``min_progress_m`` in
    ``window_s`` (see the module docstring).

    Parameters
    ----------
    goal_xy : array_like of shape (2,)
        Goal, m, world.
    config : EscapeConfig, optional
    """

    def __init__(self, goal_xy, config: EscapeConfig | None = None):
        self.goal = batch_array(goal_xy, "goal_xy", "ProgressMonitor", (2,), batch=1)[0].copy()
        self.config = EscapeConfig() if config is None else config
        self.reset()

    def reset(self) -> None:
        """Forget the window: the next :meth:`update` starts a new one."""
        self._t_ref = None
        self._d_ref = math.inf

    def update(self, t: float, position_xy) -> bool:
        """Feed the vehicle's position at time ``t`` (s, non-decreasing); True when stalled.

        Parameters
        ----------
        t : float
            Time, s.
        position_xy : array_like of shape (2,)
            Position, m, world.
        """
        t = finite_float(t, "t", "ProgressMonitor.update")
        p = np.asarray(position_xy, dtype=np.float64).reshape(-1)
        if p.shape != (2,) or not np.all(np.isfinite(p)):
            raise ValueError("The 'position_xy' parameter of ProgressMonitor.update must be 2 "
                             f"finite numbers. Got {position_xy!r} instead.")
        d = math.hypot(p[0] - self.goal[0], p[1] - self.goal[1])
        if self._t_ref is None or self._d_ref - d >= self.config.min_progress_m:
            self._t_ref, self._d_ref = t, d
            return False
        return t - self._t_ref >= self.config.window_s - 1e-9


def route_projection(samples, position_xy) -> tuple[float, np.ndarray]:
    """Arc length and point of the polyline ``samples`` nearest ``position_xy``.

    Parameters
    ----------
    samples : ndarray of shape (M, 2)
        The route's points, m (M >= 1).
    position_xy : array_like of shape (2,)
        m.

    Returns
    -------
    s : float
        Arc length from ``samples[0]`` to the nearest point, m.
    point : ndarray of shape (2,)
        The nearest point, m.
    """
    q = np.asarray(samples, dtype=np.float64)
    p = np.asarray(position_xy, dtype=np.float64).reshape(2)
    if q.shape[0] == 1:
        return 0.0, q[0].copy()
    a, seg = q[:-1], np.diff(q, axis=0)
    length2 = np.einsum("ij,ij->i", seg, seg)
    c = np.clip(np.einsum("ij,ij->i", p - a, seg) / np.maximum(length2, 1e-300), 0.0, 1.0)
    near = a + c[:, None] * seg
    k = int(np.argmin(np.einsum("ij,ij->i", near - p, near - p)))
    knots = np.concatenate([[0.0], np.cumsum(np.sqrt(length2))])
    return float(knots[k] + c[k] * math.sqrt(length2[k])), near[k]


class RouteEscape:
    """The progress monitor and the escape along a route: which stretch of the route, if any,
    the vehicle should fly now.

    Parameters
    ----------
    samples : ndarray of shape (M, 2)
        The route (e.g. :attr:`EnergyRoute.samples`), from the start to ``goal_xy``, m.
    goal_xy : array_like of shape (2,)
        m.
    config : EscapeConfig, optional

    Attributes
    ----------
    escapes : list of (float, float, float)
        ``(t, s_from, s_to)`` of every escape begun: time, s; route arc lengths, m.
    active : tuple of (float, float) or None
        ``(s_from, s_to)`` of the escape in progress.
    """

    def __init__(self, samples, goal_xy, config: EscapeConfig | None = None):
        q = np.array(samples, dtype=np.float64)  # its own: the length is computed once
        if q.ndim != 2 or q.shape[1] != 2 or q.shape[0] < 1 or not np.all(np.isfinite(q)):
            raise ValueError("The 'samples' parameter of RouteEscape must be an (M, 2) array of "
                             f"finite points, M >= 1. Got shape {q.shape} instead.")
        self.samples = q
        self.length = float(np.sum(np.hypot(*np.diff(q, axis=0).T))) if q.shape[0] > 1 else 0.0
        self.config = EscapeConfig() if config is None else config
        self.monitor = ProgressMonitor(goal_xy, self.config)
        self.escapes: list = []
        self.active = None

    def update(self, t: float, position_xy) -> tuple | None:
        """Advance the monitor and the escape to time ``t`` (s) at ``position_xy`` (m).

        Returns
        -------
        tuple of (float, float) or None
            ``(s_from, s_to)`` while an escape is in progress (a new one starts at the vehicle's
            projection onto the route), None while MPPI flies.
        """
        if self.active is not None:
            if self.active[1] >= self.length - 1e-9:  # an escape into the goal does not end
                return self.active
            s, _ = route_projection(self.samples, position_xy)
            if s < self.active[1] - 1e-9:
                return self.active
            self.active = None
            self.monitor.reset()
        if self.monitor.update(t, position_xy):
            s, _ = route_projection(self.samples, position_xy)
            self.active = (s, min(s + self.config.length_m, self.length))
            self.escapes.append((float(t), *self.active))
            self.monitor.reset()
        return self.active


class FastestEscape:
    """The progress monitor and, at the first stall, the least-time route to the goal
    (``EscapeConfig.airspeed_mps`` set): the shell of ``ea-mppi-w-esc@escair=A``.

    Parameters
    ----------
    route_fn : callable
        ``route_fn(position_xy)``: a route from ``position_xy`` to the goal with ``samples``
        (M, 2), ``speeds`` (M - 1,) and ``time_s`` (its time in the mean wind, s), or None
        when there is none (then MPPI goes on and the monitor restarts). E.g.
        :func:`windnav.plan.reach.fastest_route` on the map's lattice in the mean wind.
    goal_xy : array_like of shape (2,)
        m.
    config : EscapeConfig
    bounds : tuple of 4 floats, optional
        The map's ``(x0, x1, y0, y1)``, m: with ``config.edge_m > 0`` the escape also begins
        within ``edge_m`` of them.
    deadline_s : float, optional
        The latest arrival at the goal that can still succeed, s (the record's end less the
        goal hold): with ``config.pace_margin_s > 0`` the escape also begins when the pace
        of the last ``pace_window_s`` would arrive after ``deadline_s - pace_margin_s``.

    Attributes
    ----------
    route : object or None
        The route being flown (None before the first escape).
    escapes : list of (float, float, float)
        ``(t, 0, L)`` of the escape begun (``L`` its route's length, m), and ``(t, 0, nan)``
        for every stall with no route.
    active : tuple of (float, float) or None
        ``(0, L)`` once the escape has begun.
    """

    def __init__(self, route_fn, goal_xy, config: EscapeConfig, bounds=None,
                 deadline_s: float | None = None):
        if not callable(route_fn):
            raise ValueError("The 'route_fn' parameter of FastestEscape must be callable. Got "
                             f"{type(route_fn).__name__} instead.")
        if config.edge_m > 0 and bounds is None:
            raise ValueError("The 'bounds' parameter of FastestEscape must be the map's "
                             "(x0, x1, y0, y1) when config.edge_m > 0. Got None instead.")
        if config.pace_margin_s > 0 and deadline_s is None:
            raise ValueError("The 'deadline_s' parameter of FastestEscape must be the latest "
                             "useful arrival, s, when config.pace_margin_s > 0. Got None "
                             "instead.")
        self.bounds = None if bounds is None else tuple(float(b) for b in bounds)
        self.deadline_s = None if deadline_s is None else finite_float(
            deadline_s, "deadline_s", "FastestEscape")
        self._pace = deque()  # (t, distance to the goal) over the last pace window
        self.goal = np.array(goal_xy, dtype=np.float64).reshape(2)  # its own, as the monitor's
        self.route_fn = route_fn
        self.config = config
        self.monitor = ProgressMonitor(goal_xy, config)
        self.route = None
        self.escapes: list = []
        self.active = None
        self._launch_checked = config.launch_s <= 0

    def update(self, t: float, position_xy) -> tuple | None:
        """Advance the monitor to time ``t`` (s) at ``position_xy`` (m); ``(0, L)`` once the
        escape has begun (it lasts to the goal), None while MPPI flies."""
        if self.active is not None:
            return self.active
        if not self._launch_checked:  # the first call: the take-off trigger
            self._launch_checked = True
            route = self.route_fn(np.asarray(position_xy, dtype=np.float64).reshape(2))
            if route is not None and route.time_s > self.config.launch_s:
                return self._begin(t, route)
        stalled = self.monitor.update(t, position_xy)
        if stalled or self._near_edge(position_xy) or self._late(t, position_xy):
            self.monitor.reset()
            self._pace.clear()
            self.restart(t, position_xy)
        return self.active

    def restart(self, t: float, position_xy) -> tuple | None:
        """Plan the least-time route from ``position_xy`` (m) to the goal at time ``t`` (s) and
        make it the escape being flown: ``(0, L)``, or None (and nothing changes) when there is
        no route. The closed loop calls it once the vehicle has been blown off a goal it held
        (``config.regain_m``); every call is listed in :attr:`escapes`."""
        route = self.route_fn(np.asarray(position_xy, dtype=np.float64).reshape(2))
        if route is None:
            self.escapes.append((float(t), 0.0, math.nan))
            return None
        return self._begin(t, route)

    def _begin(self, t: float, route) -> tuple:
        """Make ``route`` the escape being flown from time ``t`` (s): ``(0, L)``."""
        q = np.asarray(route.samples, dtype=np.float64)
        length = float(np.sum(np.hypot(*np.diff(q, axis=0).T))) if len(q) > 1 else 0.0
        self.route, self.active = route, (0.0, length)
        self.escapes.append((float(t), 0.0, length))
        return self.active

    def _late(self, t: float, position_xy) -> bool:
        """True when the closing speed over the last pace window would reach the goal after
        ``deadline_s - pace_margin_s`` (never before one window of samples)."""
        if self.config.pace_margin_s <= 0:
            return False
        d = math.hypot(float(position_xy[0]) - self.goal[0], float(position_xy[1]) - self.goal[1])
        pace = self._pace
        pace.append((float(t), d))
        window = self.config.pace_window_s
        while len(pace) > 1 and t - pace[1][0] >= window - 1e-9:
            pace.popleft()
        t0, d0 = pace[0]
        if t - t0 < window - 1e-9:
            return False
        closing = (d0 - d) / (t - t0)
        arrival = t + d / closing if closing > 0 else math.inf
        return arrival > self.deadline_s - self.config.pace_margin_s

    def _near_edge(self, position_xy) -> bool:
        if self.config.edge_m <= 0:
            return False
        x0, x1, y0, y1 = self.bounds
        x, y = float(position_xy[0]), float(position_xy[1])
        return min(x - x0, x1 - x, y - y0, y1 - y) < self.config.edge_m
