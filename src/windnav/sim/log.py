"""``FlightLog``: time series of a closed-loop flight, saved as a single ``.npz`` file.

Every log carries a per-vehicle :class:`FlightStatus` (bit flags): a vehicle whose wind, command
or state went non-finite is frozen at its last finite state and flagged, instead of aborting the
batch; saturation and flight outside the model's envelope are flagged too.
"""

from __future__ import annotations

import enum
import json
import zipfile
import zlib
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np


class FlightStatus(enum.IntFlag):
    """How one vehicle's flight went; flags combine (``SATURATED | OUTSIDE_ENVELOPE``).

    ``OK`` (0): finite throughout, never clipped, inside the envelope. ``SATURATED``: some
    rotor command was clipped to a rotor limit (the lower one included). ``OUTSIDE_ENVELOPE``:
    some logged instant left the model's envelope (lift above the stated fraction of rotor
    thrust, or airspeed above the vehicle's limit). ``NON_FINITE``: the wind, the command or the
    state went NaN/inf; the vehicle is frozen at its last finite state from then on.
    """

    OK = 0
    SATURATED = 1
    OUTSIDE_ENVELOPE = 2
    NON_FINITE = 4


@dataclass
class FlightLog:
    """Everything recorded along a (batched) flight; arrays have time first, then batch.

    Attributes
    ----------
    t : ndarray of shape (T,)
        Log times, s: every ``log_every``-th physics step, and the last step when the duration
        is not a whole number of log intervals.
    position, velocity : ndarray of shape (T, B, 3)
        World frame, m and m/s.
    attitude : ndarray of shape (T, B, 4)
        Quaternion xyzw, body to world.
    body_rates : ndarray of shape (T, B, 3)
        rad/s.
    rotor_speeds : ndarray of shape (T, B, N)
        Actual rotor speeds, rad/s.
    rotor_speed_cmd : ndarray of shape (T, B, N)
        Rotor speeds asked for by the controller before clipping, rad/s.
    saturated : ndarray of bool, shape (T, B, N)
        True where the command was clipped to the rotor limits.
    target_position, target_velocity : ndarray of shape (T, 3)
        Reference trajectory, m and m/s.
    wind : ndarray of shape (T, B, 3)
        True wind at the centre of mass, world frame, m/s (with ``hub_wind``, the mean of the
        wind at the rotor hubs, which equals it only in a uniform or linear field).
    power : ndarray of shape (T, B)
        Rotor mechanical power over motor efficiency, W; NaN from the step a vehicle's state
        stopped being finite (``FlightStatus.NON_FINITE``).
    energy : ndarray of shape (T, B)
        Cumulative energy, J (the trapezoid rule over ``t``; held from that step on).
    outside_envelope : ndarray of bool, shape (T, B)
        True where the logged instant is outside the model's envelope (see
        :func:`windnav.vehicle.envelope.outside_envelope`); all False when not given (logs
        written before it existed).
    status : ndarray of uint8, shape (B,)
        :class:`FlightStatus` flags of each vehicle. Derived from ``saturated`` and the
        finiteness of ``position`` when not given (logs written before it existed).
    sensors : dict
        ``{sensor: {"t": (K,), field: (K, B, ...)}}`` at each sensor's own rate; NaN for a
        vehicle from the instant it went non-finite.
    meta : dict
        JSON-serialisable description (vehicle, wind, trajectory, rates, seed, fractions of
        time saturated and outside the envelope, ``non_finite_at_s`` per vehicle).

    Raises
    ------
    ValueError
        If the arrays do not share one time axis T, batch B and rotor count N.
    """

    t: np.ndarray
    position: np.ndarray
    velocity: np.ndarray
    attitude: np.ndarray
    body_rates: np.ndarray
    rotor_speeds: np.ndarray
    rotor_speed_cmd: np.ndarray
    saturated: np.ndarray
    target_position: np.ndarray
    target_velocity: np.ndarray
    wind: np.ndarray
    power: np.ndarray
    energy: np.ndarray
    outside_envelope: np.ndarray | None = None
    status: np.ndarray | None = None
    sensors: dict = field(default_factory=dict)
    meta: dict = field(default_factory=dict)

    _ARRAYS = ("t", "position", "velocity", "attitude", "body_rates", "rotor_speeds",
               "rotor_speed_cmd", "saturated", "target_position", "target_velocity", "wind",
               "power", "energy", "outside_envelope", "status")
    _OPTIONAL = ("outside_envelope", "status")

    def __post_init__(self):
        if self.outside_envelope is None:
            self.outside_envelope = np.zeros(np.shape(self.power), bool)
        if self.status is None:
            self.check(status=False)
            sat = np.any(self.saturated, axis=(0, 2))
            bad = ~np.all(np.isfinite(self.position), axis=(0, 2))
            self.status = (sat * FlightStatus.SATURATED | bad * FlightStatus.NON_FINITE).astype(
                np.uint8)
        self.check()

    def check(self, *, status: bool = True) -> None:
        """Raise a ValueError naming the first array whose shape breaks the common (T, B, N)."""
        def fail(name, want, arr):
            raise ValueError(f"The {name!r} array of FlightLog must have shape {want}. "
                             f"Got {np.shape(arr)} instead.")

        t = np.asarray(self.t)
        if t.ndim != 1:
            fail("t", "(T,)", t)
        _check_times(t, "t")
        pos = np.asarray(self.position)
        if pos.ndim != 3 or pos.shape[0] != t.size:
            fail("position", f"({t.size}, B, 3)", pos)
        T, B = pos.shape[:2]
        rot = np.asarray(self.rotor_speeds)
        N = rot.shape[-1] if rot.ndim == 3 else -1
        want = {"position": (T, B, 3), "velocity": (T, B, 3), "attitude": (T, B, 4),
                "body_rates": (T, B, 3), "rotor_speeds": (T, B, N), "rotor_speed_cmd": (T, B, N),
                "saturated": (T, B, N), "target_position": (T, 3), "target_velocity": (T, 3),
                "wind": (T, B, 3), "power": (T, B), "energy": (T, B),
                "outside_envelope": (T, B)}
        if status:
            want["status"] = (B,)
        for name, shape in want.items():
            arr = getattr(self, name)
            if np.shape(arr) != shape or N < 1:
                fail(name, shape, arr)
        for name in ("saturated", "outside_envelope"):
            if np.asarray(getattr(self, name)).dtype != bool:
                raise ValueError(f"The {name!r} array of FlightLog must be boolean. "
                                 f"Got {np.asarray(getattr(self, name)).dtype} instead.")
        for sensor, values in self.sensors.items():
            ts = np.asarray(values.get("t", ()))
            if ts.ndim == 1:
                _check_times(ts, f"sensors/{sensor}/t")
            for key, arr in values.items():
                shape = np.shape(arr)
                ok = shape == ts.shape if key == "t" else (len(shape) >= 2 and shape[:2] == (
                    ts.size, B))
                if ts.ndim != 1 or not ok:
                    raise ValueError(f"The 'sensors/{sensor}/{key}' array of FlightLog must have "
                                     f"shape ({ts.size}, {B}, ...) after its (K,) times. "
                                     f"Got {shape} instead.")

    @property
    def envelope_fraction(self) -> float:
        """Fraction of logged vehicle-instants outside the model's envelope."""
        return float(np.mean(self.outside_envelope)) if self.outside_envelope.size else 0.0

    @property
    def flags(self) -> list[FlightStatus]:
        """:class:`FlightStatus` of each vehicle, (B,) list."""
        return [FlightStatus(int(s)) for s in self.status]

    @property
    def finite(self) -> np.ndarray:
        """(B,) bool: True for the vehicles that flew the whole log with finite values."""
        return (self.status & FlightStatus.NON_FINITE) == 0

    @property
    def tracking_error(self) -> np.ndarray:
        """Position error norm (T, B), m."""
        return np.linalg.norm(self.position - self.target_position[:, None, :], axis=-1)

    @property
    def saturation_fraction(self) -> float:
        """Fraction of logged rotor commands that were clipped."""
        return float(np.mean(self.saturated)) if self.saturated.size else 0.0

    def save(self, path) -> Path:
        """Write the log to ``path`` (``.npz``, written atomically); returns the path."""
        self.check()
        path = Path(path)
        if path.suffix != ".npz":
            path = path.with_suffix(".npz")
        path.parent.mkdir(parents=True, exist_ok=True)
        arrays = {name: getattr(self, name) for name in self._ARRAYS}
        for sensor, values in self.sensors.items():
            for key, arr in values.items():
                arrays[f"sensors/{sensor}/{key}"] = arr
        arrays["meta"] = np.array(json.dumps(self.meta))
        tmp = path.with_name(path.name + ".tmp.npz")
        np.savez_compressed(tmp, **arrays)
        tmp.replace(path)
        return path

    @classmethod
    def load(cls, path) -> FlightLog:
        """Read a log written by :meth:`save`.

        Raises
        ------
        ValueError
            Naming the path, if the file is missing, not a FlightLog, truncated or otherwise
            corrupt (a bad CRC, undecodable data), or holds arrays of inconsistent shapes.
        """
        path = Path(path)

        def bad(why) -> ValueError:
            return ValueError(f"The 'path' parameter of FlightLog.load must name a readable "
                              f"FlightLog .npz file. Got {str(path)!r} ({why}).")

        if path.is_file() and not zipfile.is_zipfile(path):  # NumPy would read it as a pickle
            raise bad("not an .npz file, which is a zip archive")  # and suggest allow_pickle
        try:
            with np.load(path, allow_pickle=False) as data:
                content = {k: data[k] for k in data.files}
            meta = json.loads(str(content["meta"])) if "meta" in content else None
        except (OSError, ValueError, EOFError, KeyError, zipfile.BadZipFile, zlib.error) as exc:
            raise bad(f"{type(exc).__name__}: {exc}") from None
        missing = [k for k in cls._ARRAYS if k not in content and k not in cls._OPTIONAL]
        if missing or not isinstance(meta, dict):
            raise ValueError(f"The 'path' parameter of FlightLog.load names a file that is not a "
                             f"FlightLog: {str(path)!r} lacks {missing or ['meta']}.")
        sensors: dict = {}
        for key, arr in content.items():
            if key.startswith("sensors/"):
                parts = key.split("/", 2)
                if len(parts) != 3:
                    raise bad(f"unexpected array {key!r}")
                sensors.setdefault(parts[1], {})[parts[2]] = arr
        kwargs = {f.name: content[f.name] for f in fields(cls)
                  if f.name in cls._ARRAYS and f.name in content}
        try:
            return cls(**kwargs, sensors=sensors, meta=meta)
        except ValueError as exc:
            raise bad(exc) from None


def _check_times(t: np.ndarray, name: str) -> None:
    """A log's times: numbers, finite and strictly increasing (a log whose IMU times ran
    backwards was fitted by ``sysid aero`` into k_d -7.5 % and k_h +10 %, silently; files
    audit)."""
    ok = t.dtype.kind in "iuf" and bool(np.all(np.isfinite(t)))
    if ok and t.size > 1:
        ok = bool(np.all(np.diff(t) > 0))
    if not ok:
        span = (f" from {float(t[0])!r} to {float(t[-1])!r}"
                if t.size and t.dtype.kind in "iuf" else "")
        raise ValueError(f"The {name!r} array of FlightLog must hold finite, strictly increasing "
                         f"times, s. Got {t.dtype} values{span} instead.")
