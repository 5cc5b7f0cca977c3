"""Adapters between windnav wind fields and other simulators.

RotorPy (``rotorpy/simulate.py``) asks its wind profile ``wind_profile.update(t, position)`` once
per step, with ``position`` of shape (3,) (or (B, 3) in its batched simulator) in the world frame,
and expects the wind there, m/s, of the same shape. :class:`RotorPyWind` answers that from any
:class:`~windnav.wind.WindField` (to RotorPy).

:class:`FromRotorPy` goes the other way: any RotorPy wind profile as a windnav
:class:`~windnav.wind.WindField`. RotorPy's Dryden gusts (``rotorpy.wind.dryden_winds.
DrydenGust``) are stateful filters stepped once per ``update`` call with RotorPy's *global*
NumPy random state, whatever ``t`` and ``position``; with ``dt=`` the adapter steps such a profile
on its own grid ``t_k = k dt`` (as RotorPy's simulator does, one call per step) and holds each
sample over ``[t_k, t_{k+1})``, drawing from its own ``numpy.random.RandomState(seed)`` (swapped
in around each call, the caller's global state restored). The samples are generated in order
and kept, so the wind is a function of ``(t, seed)`` whatever the order of queries.
"""

from __future__ import annotations

import math

import numpy as np

from windnav._validate import positive_float
from windnav.wind.base import WindField, check_query


class RotorPyWind:
    """Wrap a windnav :class:`~windnav.wind.WindField` as a RotorPy wind profile.

    Parameters
    ----------
    field : WindField
        Any object with ``velocity(t, xyz) -> (B, 3)``.

    Examples
    --------
    >>> from windnav.wind import ConstantWind
    >>> RotorPyWind(ConstantWind((1.0, 0.0, 0.0))).update(0.0, np.zeros(3))
    array([1., 0., 0.])
    """

    def __init__(self, field: WindField):
        if not isinstance(field, WindField):
            raise ValueError(
                "The 'field' parameter of RotorPyWind must have a velocity(t, xyz) method. "
                f"Got {type(field).__name__} instead."
            )
        self.field = field

    def update(self, t: float, position) -> np.ndarray:
        """Wind at time ``t`` (s) and ``position`` (3,) or (B, 3) m, world; same shape, m/s."""
        if type(position).__module__.startswith("torch"):  # RotorPy's batched simulator
            import torch

            wind = self.field.velocity(float(t), position.detach().cpu().numpy())
            return torch.as_tensor(wind, dtype=position.dtype, device=position.device)
        pos = np.asarray(position, dtype=np.float64)
        wind = self.field.velocity(float(t), pos.reshape(-1, 3))
        return wind[0] if pos.ndim == 1 else wind

    def __repr__(self) -> str:
        return f"RotorPyWind({self.field!r})"


def to_rotorpy(field: WindField) -> RotorPyWind:
    """Return ``RotorPyWind(field)``: ``field`` as a RotorPy wind profile (``update(t, x)``)."""
    return RotorPyWind(field)


class FromRotorPy:
    """A RotorPy wind profile (``update(t, position) -> (3,)``) as a windnav WindField.

    Parameters
    ----------
    profile : object
        A RotorPy wind profile. The adapter owns it from now on (stepping it changes it).
    dt : float, optional
        For a stateful profile that ignores ``t`` and ``position`` (RotorPy's ``DrydenGust``):
        the step of its grid, s, which should be the ``dt`` the profile was built with (RotorPy's
        simulator steps it at its own rate, 100 Hz by default). Without ``dt`` the profile is
        called for every queried position at the queried time (RotorPy's deterministic winds).
    seed : int, optional
        Seed of the random state the stateful profile draws from (only with ``dt``).
    chunk : int
        Samples generated at a time when a query passes the end of the grid.

    Examples
    --------
    >>> from rotorpy.wind.dryden_winds import DrydenGust
    >>> gust = DrydenGust(dt=0.01, avg_wind=np.array([2.0, 0, 0]), sig_wind=np.full(3, 30.0))
    >>> w = FromRotorPy(gust, dt=0.01, seed=3)
    >>> w.velocity(1.234, np.zeros((2, 3))).shape
    (2, 3)
    """

    def __init__(self, profile, *, dt: float | None = None, seed: int | None = None,
                 chunk: int = 1000):
        where = "FromRotorPy"
        if not callable(getattr(profile, "update", None)):
            raise ValueError(f"The 'profile' parameter of {where} must have an update(t, "
                             f"position) method. Got {type(profile).__name__} instead.")
        self.profile = profile
        self.dt = None if dt is None else positive_float(dt, "dt", where)
        if self.dt is None and seed is not None:
            raise ValueError(f"The 'seed' parameter of {where} needs 'dt' (a stateful profile); "
                             f"a profile called at the queried times draws nothing. Got seed="
                             f"{seed!r} without dt.")
        if isinstance(seed, bool) or (seed is not None and (int(seed) != seed or seed < 0)):
            raise ValueError(f"The 'seed' parameter of {where} must be a non-negative int or "
                             f"None. Got {seed!r} instead.")
        self.seed = None if seed is None else int(seed)
        self.chunk = int(chunk)
        self._state = np.random.RandomState(self.seed).get_state()
        self._samples = np.empty((0, 3))

    def _extend(self, k_max: int) -> None:
        """Step the profile until sample ``k_max`` exists."""
        n = self._samples.shape[0]
        if k_max < n:
            return
        count = max(k_max + 1 - n, self.chunk)
        new = np.empty((count, 3))
        # RotorPy's gusts draw from the global state: lend it ours, then give it back
        saved = np.random.get_state()  # noqa: NPY002
        try:
            np.random.set_state(self._state)  # noqa: NPY002
            origin = np.zeros(3)
            for i in range(count):
                new[i] = np.asarray(self.profile.update((n + i) * self.dt, origin),
                                    dtype=np.float64).reshape(3)
            self._state = np.random.get_state()  # noqa: NPY002
        finally:
            np.random.set_state(saved)  # noqa: NPY002
        self._samples = np.concatenate([self._samples, new])

    def velocity(self, t: float, xyz: np.ndarray) -> np.ndarray:
        """Wind at time ``t`` (s) and positions ``xyz`` (B, 3) m: (B, 3) m/s, world frame."""
        t, xyz = check_query(t, xyz, "FromRotorPy.velocity")
        if self.dt is None:
            return np.array([np.asarray(self.profile.update(t, p), dtype=np.float64).reshape(3)
                             for p in xyz]).reshape(-1, 3)
        if t < 0:
            raise ValueError(f"The 't' parameter of FromRotorPy.velocity must be >= 0 with a "
                             f"stepped profile. Got {t!r} instead.")
        k = int(math.floor(t / self.dt + 1e-9))
        self._extend(k)
        return np.tile(self._samples[k], (xyz.shape[0], 1))

    def __repr__(self) -> str:
        return (f"FromRotorPy({type(self.profile).__name__}, dt={self.dt!r}, "
                f"seed={self.seed!r})")


def from_rotorpy(profile, *, dt: float | None = None, seed: int | None = None) -> FromRotorPy:
    """Return ``FromRotorPy(profile, dt=dt, seed=seed)``: a RotorPy wind profile as a windnav
    :class:`~windnav.wind.WindField`."""
    return FromRotorPy(profile, dt=dt, seed=seed)
