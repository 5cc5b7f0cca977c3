"""The sensor protocol: what the runner hands a sensor, and what a sensor gives back.

A sensor is any object with a ``name`` (its key in ``FlightLog.sensors``), a ``rate_hz`` and ::

    sample(truth: SensorTruth, rng: numpy.random.Generator) -> dict[str, ndarray (K, B, ...)]

``truth`` is the true flight at the sensor's own K sample instants (:class:`SensorTruth`); the
runner adds the sample times ``"t"`` (K,) to the returned dict. Sensors never feed back into the
controller, so the runner keeps the true states at sensor ticks while flying and calls every
sensor afterwards, vectorised over time, in a fixed order (the order of the random draws).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property
from typing import Protocol, runtime_checkable

import numpy as np

from windnav.vehicle import layout


@runtime_checkable
class Sensor(Protocol):
    """Anything the runner can sample: ``name``, ``rate_hz`` and ``sample(truth, rng)``."""

    name: str
    rate_hz: float

    def sample(self, truth: SensorTruth, rng: np.random.Generator) -> dict:
        """Measurements of ``truth`` (K samples of B vehicles): ``{field: (K, B, ...)}``."""
        ...


@dataclass(frozen=True, eq=False)
class SensorTruth:
    """The true flight at K sample instants of B vehicles.

    Attributes
    ----------
    t : ndarray of shape (K,)
        Sample times, s.
    state : ndarray of shape (K, B, 13 + N)
        Packed vehicle states (:mod:`windnav.vehicle.layout`).
    wind_com : ndarray of shape (K, B, 3)
        Wind at the centre of mass, world frame, m/s.
    wind_hub : ndarray of shape (K, B, N, 3) or None
        Wind at each rotor hub, world frame, m/s; None when every hub sees ``wind_com``.
    rotor_speed_cmd : ndarray of shape (K, B, N)
        Rotor-speed commands after clipping to the rotor limits, rad/s.
    model : Multirotor
        The dynamics that flew, for quantities derived from the forces (specific force).
    """

    t: np.ndarray
    state: np.ndarray
    wind_com: np.ndarray
    wind_hub: np.ndarray | None
    rotor_speed_cmd: np.ndarray
    model: object

    @property
    def position(self) -> np.ndarray:
        """(K, B, 3) m, world frame."""
        return self.state[..., layout.POSITION]

    @property
    def velocity(self) -> np.ndarray:
        """(K, B, 3) m/s, world frame."""
        return self.state[..., layout.VELOCITY]

    @property
    def attitude(self) -> np.ndarray:
        """(K, B, 4) quaternion xyzw, body to world."""
        return self.state[..., layout.ATTITUDE]

    @property
    def body_rates(self) -> np.ndarray:
        """(K, B, 3) rad/s, body frame."""
        return self.state[..., layout.BODY_RATES]

    @property
    def rotor_speeds(self) -> np.ndarray:
        """(K, B, N) rad/s."""
        return self.state[..., layout.ROTOR_SPEEDS]

    def at(self, index) -> SensorTruth:
        """The samples ``index`` (any index of the K axis)."""
        hub = None if self.wind_hub is None else self.wind_hub[index]
        return SensorTruth(self.t[index], self.state[index], self.wind_com[index], hub,
                           self.rotor_speed_cmd[index], self.model)

    @cached_property
    def specific_force_body(self) -> np.ndarray:
        """Non-gravitational acceleration at the centre of mass, body axes, (K, B, 3) m/s^2.

        What an ideal accelerometer reads: ``force_body / mass`` of the dynamics at each sample
        (evaluated on demand, once: arrays edited in place afterwards leave it as it was, so
        build a new ``SensorTruth`` for other states; cache audit, thirty-ninth session).
        """
        K, B, n_x = self.state.shape
        N = n_x - layout.N_RIGID
        com = self.wind_com.reshape(K * B, 3)
        if self.wind_hub is None:
            hub = np.ascontiguousarray(np.broadcast_to(com[:, None, :], (K * B, N, 3)))
        else:
            hub = np.ascontiguousarray(self.wind_hub.reshape(K * B, N, 3))
        flat = np.ascontiguousarray(self.state.reshape(K * B, n_x))
        com = np.ascontiguousarray(com)
        model = self.model
        if model.packed.size > 1:  # per-vehicle parameters: one sample (B rows) at a time
            rows = [slice(k * B, (k + 1) * B) for k in range(K)]
            f = np.concatenate([model.derivatives_packed(flat[r], com[r], hub[r])
                                ["specific_force_body"] for r in rows]) if K else np.empty((0, 3))
        else:
            f = model.derivatives_packed(flat, com, hub)["specific_force_body"]
        return f.reshape(K, B, 3)


__all__ = ["Sensor", "SensorTruth"]
