"""Reference trajectories: flat outputs (position, velocity, acceleration, yaw) versus time.

Each trajectory is a frozen dataclass callable as ``traj(t) -> FlatOutput`` with world-frame
arrays of shape (3,) and is shared by every vehicle of a batch.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np

from windnav._validate import batch_array, finite_float, positive_float


@dataclass(frozen=True)
class FlatOutput:
    """Target position (m), velocity (m/s), acceleration (m/s^2), yaw (rad) and yaw rate (rad/s)."""

    position: np.ndarray
    velocity: np.ndarray
    acceleration: np.ndarray
    yaw: float = 0.0
    yaw_rate: float = 0.0


def _point(value, name: str, where: str) -> None:
    """Refuse anything but 3 finite numbers by name (NaN flew the vehicle to rotor commands of
    0; a (1, 3) point was broadcast over the batch)."""
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError):
        arr = None
    if arr is None or arr.shape != (3,) or not np.isfinite(arr).all():
        raise ValueError(f"The {name!r} parameter of {where} must be 3 finite numbers "
                         f"(x, y, z), m, of shape (3,). Got {value!r} instead.")


def _min_jerk(s: float) -> tuple[float, float, float]:
    """Minimum-jerk blend 10s^3 - 15s^4 + 6s^5 and its first two derivatives in s."""
    s = min(max(s, 0.0), 1.0)
    return (10 * s**3 - 15 * s**4 + 6 * s**5, 30 * s**2 - 60 * s**3 + 30 * s**4,
            60 * s - 180 * s**2 + 120 * s**3)


@dataclass(frozen=True)
class Hover:
    """Hold ``position`` (m) with heading ``yaw`` (rad)."""

    position: tuple = (0.0, 0.0, 0.0)
    yaw: float = 0.0

    def __post_init__(self):
        _point(self.position, "position", "Hover")
        finite_float(self.yaw, "yaw", "Hover")

    def __call__(self, t: float) -> FlatOutput:
        return FlatOutput(np.asarray(self.position, float), np.zeros(3), np.zeros(3), self.yaw)


@dataclass(frozen=True)
class Line:
    """Straight segment from ``start`` to ``end`` (m) in ``duration`` s with a min-jerk profile."""

    start: tuple = (0.0, 0.0, 0.0)
    end: tuple = (10.0, 0.0, 0.0)
    duration: float = 10.0

    def __post_init__(self):
        _point(self.start, "start", "Line")
        _point(self.end, "end", "Line")
        positive_float(self.duration, "duration", "Line")

    def __call__(self, t: float) -> FlatOutput:
        a = np.asarray(self.start, float)
        d = np.asarray(self.end, float) - a
        s, ds, dds = _min_jerk(t / self.duration)
        T = self.duration
        return FlatOutput(a + s * d, ds / T * d, dds / T**2 * d)


@dataclass(frozen=True)
class Circle:
    """Horizontal circle of ``radius`` m around ``center`` at ``speed`` m/s (counter-clockwise).

    Starts at ``center + [radius, 0, 0]``; the angular rate ramps up smoothly over
    ``ramp_s`` seconds so the vehicle can start from hover there.
    """

    center: tuple = (0.0, 0.0, 0.0)
    radius: float = 2.0
    speed: float = 2.0
    ramp_s: float = 2.0

    def __post_init__(self):
        _point(self.center, "center", "Circle")
        positive_float(self.radius, "radius", "Circle")
        positive_float(self.speed, "speed", "Circle", allow_zero=True)
        positive_float(self.ramp_s, "ramp_s", "Circle", allow_zero=True)

    def _phase(self, t: float) -> tuple[float, float, float]:
        w = self.speed / self.radius
        T = self.ramp_s
        if T <= 0 or t >= T:
            # phase accumulated during the ramp is w*T/2 (the min-jerk rate averages 1/2)
            return w * (t - T) + w * T / 2, w, 0.0
        s, ds, dds = _min_jerk(t / T)
        # rate = w * s(t/T): integrate the quintic analytically
        u = t / T
        integral = T * (2.5 * u**4 - 3 * u**5 + u**6)
        return w * integral, w * s, w * ds / T

    def __call__(self, t: float) -> FlatOutput:
        th, om, al = self._phase(t)
        r = self.radius
        c = np.asarray(self.center, float)
        ct, st = np.cos(th), np.sin(th)
        pos = c + np.array([r * ct, r * st, 0.0])
        vel = np.array([-r * st * om, r * ct * om, 0.0])
        acc = np.array([-r * ct * om**2 - r * st * al, -r * st * om**2 + r * ct * al, 0.0])
        return FlatOutput(pos, vel, acc)


@dataclass(frozen=True)
class Waypoints:
    """Rest-to-rest min-jerk legs through ``points`` (K, 3) at an average ``speed`` m/s."""

    points: tuple
    speed: float = 2.0

    def __post_init__(self):
        pts = batch_array(self.points, "points", "Waypoints", (3,))
        if pts.shape[0] < 2:
            raise ValueError("The 'points' parameter of Waypoints must hold at least 2 points.")
        positive_float(self.speed, "speed", "Waypoints")
        object.__setattr__(self, "points", pts)
        lengths = np.linalg.norm(np.diff(pts, axis=0), axis=1)
        durations = np.maximum(lengths / self.speed, 1e-3)
        object.__setattr__(self, "_t", np.concatenate([[0.0], np.cumsum(durations)]))

    @property
    def duration(self) -> float:
        return float(self._t[-1])

    def __call__(self, t: float) -> FlatOutput:
        k = int(np.clip(np.searchsorted(self._t, t, side="right") - 1, 0, len(self._t) - 2))
        a, b = self.points[k], self.points[k + 1]
        T = self._t[k + 1] - self._t[k]
        s, ds, dds = _min_jerk((t - self._t[k]) / T)
        return FlatOutput(a + s * (b - a), ds / T * (b - a), dds / T**2 * (b - a))


TRAJECTORIES = ("hover", "line", "circle", "waypoints")


def make_trajectory(kind: str, *, start=(0.0, 0.0, 0.0), size: float = 5.0,
                    speed: float = 2.0, duration: float | None = None):
    """Build a named trajectory starting at ``start`` (m).

    ``size`` is the circle radius (its centre ``size`` m along -x from ``start``), the line
    length along +x, or the waypoint square's side (m); ``speed`` the reference speed (m/s; > 0
    for a line or waypoints, which must get somewhere): a circle's constant speed, a line's
    peak speed (its minimum-jerk leg takes ``max(1.875 size / speed, 1)`` s), the waypoints'
    average speed per leg. How long the flight lasts is ``fly``'s ``duration``: this
    ``duration`` was accepted and ignored until 2026-12-05 (API audit); it is deprecated and
    warns when given.

    Raises
    ------
    ValueError
        Naming ``trajectory``, ``start``, ``size`` or ``speed`` when it is out of range.
    """
    where = "make_trajectory"
    if duration is not None:
        warnings.warn(f"{where}: 'duration' is deprecated and was never used (a trajectory's "
                      "length follows from size and speed); give the flight's duration to "
                      "fly(..., duration=).", DeprecationWarning, stacklevel=2)
    s = batch_array(start, "start", where, (3,), batch=1)[0]
    if kind in ("line", "waypoints"):
        size = positive_float(size, "size", where, allow_zero=kind == "line")
        speed = positive_float(speed, "speed", where)
    elif kind == "circle":
        size = positive_float(size, "size", where)
        speed = positive_float(speed, "speed", where, allow_zero=True)
    if kind == "hover":
        return Hover(tuple(s))
    if kind == "line":
        return Line(tuple(s), tuple(s + [size, 0.0, 0.0]), duration=max(size / speed * 1.875, 1.0))
    if kind == "circle":
        return Circle(center=tuple(s - [size, 0.0, 0.0]), radius=size, speed=speed)
    if kind == "waypoints":
        sq = s + size * np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0.2], [0, 1, 0.2], [0, 0, 0.0]])
        return Waypoints(tuple(map(tuple, sq)), speed=speed)
    raise ValueError(f"The 'trajectory' parameter must be one of {list(TRAJECTORIES)}. "
                     f"Got {kind!r} instead.")
