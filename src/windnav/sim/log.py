"""``FlightLog``: time series of a closed-loop flight, saved as a single ``.npz`` file."""

from __future__ import annotations

import json
from dataclasses import dataclass, field, fields
from pathlib import Path

import numpy as np


@dataclass
class FlightLog:
    """Everything recorded along a (batched) flight; arrays have time first, then batch.

    Attributes
    ----------
    t : ndarray of shape (T,)
        Log times, s.
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
        True wind at the centre of mass, world frame, m/s.
    power : ndarray of shape (T, B)
        Rotor mechanical power over motor efficiency, W.
    energy : ndarray of shape (T, B)
        Cumulative energy, J.
    sensors : dict
        ``{sensor: {"t": (K,), field: (K, B, ...)}}`` at each sensor's own rate.
    meta : dict
        JSON-serialisable description (vehicle, wind, trajectory, rates, seed).
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
    sensors: dict = field(default_factory=dict)
    meta: dict = field(default_factory=dict)

    _ARRAYS = ("t", "position", "velocity", "attitude", "body_rates", "rotor_speeds",
               "rotor_speed_cmd", "saturated", "target_position", "target_velocity", "wind",
               "power", "energy")

    @property
    def tracking_error(self) -> np.ndarray:
        """Position error norm (T, B), m."""
        return np.linalg.norm(self.position - self.target_position[:, None, :], axis=-1)

    @property
    def saturation_fraction(self) -> float:
        """Fraction of logged rotor commands that were clipped."""
        return float(np.mean(self.saturated)) if self.saturated.size else 0.0

    def save(self, path) -> Path:
        """Write the log to ``path`` (``.npz``); returns the path."""
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
            If the file is missing, not a FlightLog, or corrupt.
        """
        path = Path(path)
        try:
            with np.load(path, allow_pickle=False) as data:
                content = {k: data[k] for k in data.files}
        except (OSError, ValueError, EOFError) as exc:
            raise ValueError(f"The 'path' parameter of FlightLog.load must name a readable "
                             f"FlightLog .npz file. Got {str(path)!r} ({exc}).") from None
        missing = [k for k in cls._ARRAYS if k not in content]
        if missing:
            raise ValueError(f"The 'path' parameter of FlightLog.load names a file that is not a "
                             f"FlightLog: {str(path)!r} lacks {missing}.")
        sensors: dict = {}
        for key, arr in content.items():
            if key.startswith("sensors/"):
                _, sensor, name = key.split("/", 2)
                sensors.setdefault(sensor, {})[name] = arr
        kwargs = {f.name: content[f.name] for f in fields(cls) if f.name in cls._ARRAYS}
        return cls(**kwargs, sensors=sensors, meta=json.loads(str(content["meta"])))
