"""The decoder's baselines (thesis ch. 4) and the input validation every predictor shares.

Every predictor, learned or not, answers ``predict(scans, w_up, w_robot) -> (B, 2, H, H)`` on
the grid ``offsets`` (:func:`windnav.predict.dataset.grid_offsets`):

- :class:`UpstreamBaseline`: the inlet wind ``W_up`` everywhere;
- :class:`LocalBaseline`: the wind measured at the robot ``W_robot`` everywhere;
- :func:`with_baselines`: named models followed by both baselines on their grid, the set every
  comparison scores.

:func:`check_inputs` is the one validation of the inputs, so the learned decoder and the
baselines refuse the same bad input with the same messages.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from windnav._validate import batch_array, positive_float, positive_int
from windnav.predict.dataset import N_RAYS, grid_offsets


def _array(value, name: str, where: str) -> np.ndarray:
    try:
        a = np.asarray(value)
        if a.dtype.kind == "c":  # the cast to float64 would drop the imaginary part
            raise TypeError
        return a.astype(np.float64, copy=False)
    except (TypeError, ValueError):
        raise ValueError(f"The {name!r} parameter of {where} must be an array of real "
                         f"numbers. Got {type(value).__name__} instead.") from None


_FLOAT32_MAX = float(np.finfo(np.float32).max)


def _wind(value, name: str, where: str, batch: int) -> np.ndarray:
    w = _array(value, name, where)
    if w.shape == (2,):  # one wind for every scan: a copy per row, (B, 2) like any batch
        w = np.repeat(w[None], batch, axis=0)
    elif w.shape != (batch, 2):
        raise ValueError(f"The {name!r} parameter of {where} must be an array of shape "
                         f"({batch}, 2), a row per scan, or (2,), the same for every scan. "
                         f"Got shape {w.shape} instead.")
    w = batch_array(w, name, where, (2,), batch=batch)
    if w.size and np.abs(w).max() > _FLOAT32_MAX:  # the models compute in float32
        raise ValueError(f"The {name!r} parameter of {where} must be within float32's range "
                         f"(|w| <= {_FLOAT32_MAX:.3g} m/s). Got {np.abs(w).max()!r} instead.")
    return w


def check_inputs(scans, w_up, w_robot, where: str):
    """Validate and batch a predictor's inputs.

    Parameters
    ----------
    scans : array_like of shape (B, 360) or (360,)
        LiDAR ranges, m, ray k at k degrees counter-clockwise from +x (world frame); finite
        and >= 0.
    w_up : array_like of shape (B, 2) or (2,)
        Inlet wind, m/s, world frame, finite. A single ``(2,)`` wind is used for every scan.
    w_robot : array_like of shape (B, 2) or (2,)
        Wind at the robot, m/s, world frame, finite. A single ``(2,)`` wind is used for every
        scan.
    where : str
        The caller, named in the messages (e.g. ``"LocalBaseline.predict"``).

    Returns
    -------
    scans : ndarray of float64, shape (B, 360)
    w_up, w_robot : ndarray of float64, shape (B, 2)
        A single sample (``(360,)``, ``(2,)``, ``(2,)``) becomes a batch of one; a ``(2,)``
        wind with a batch of scans is repeated over the batch.

    Raises
    ------
    ValueError
        Naming the argument: a scan of the wrong length or shape, NaN, inf or negative ranges,
        NaN or inf wind or wind beyond float32's range, a wind of a shape other than
        ``(B, 2)`` or ``(2,)`` (a batch size different from the scans' included, with both
        shapes in the message), or complex numbers.
    """
    scans = _array(scans, "scans", where)
    if scans.shape != (N_RAYS,) and (scans.ndim != 2 or scans.shape[1] != N_RAYS):
        raise ValueError(f"The 'scans' parameter of {where} must be an array of shape "
                         f"(B, {N_RAYS}), a scan per row, or ({N_RAYS},), one scan. Got shape "
                         f"{scans.shape} instead.")
    scans = batch_array(scans, "scans", where, (N_RAYS,))
    if (scans < 0).any():
        bad = int(np.flatnonzero((scans < 0).any(axis=1))[0])
        raise ValueError(f"The 'scans' parameter of {where} must hold ranges >= 0, m. "
                         f"Got a negative range in scan {bad} instead.")
    b = scans.shape[0]
    w_up = _wind(w_up, "w_up", where, b)
    w_robot = _wind(w_robot, "w_robot", where, b)
    return scans, w_up, w_robot


@dataclass(frozen=True)
class _UniformBaseline:
    """A uniform field on an ``H x H`` grid of spacing ``spacing`` (m) centred on the robot."""

    size: int = 25
    spacing: float = 1.0

    def __post_init__(self):
        where = type(self).__name__
        object.__setattr__(self, "size", positive_int(self.size, "size", where))
        object.__setattr__(self, "spacing", positive_float(self.spacing, "spacing", where))

    @property
    def offsets(self) -> np.ndarray:
        """Cell-centre offsets ``(H,)``, m, the same along x and y."""
        return grid_offsets(self.size, self.spacing)

    _wind = 1  # which of check_inputs' (scans, w_up, w_robot) fills every cell

    def predict(self, scans, w_up, w_robot) -> np.ndarray:
        """Predict the local mean wind.

        Parameters
        ----------
        scans : array_like of shape (B, 360) or (360,)
            LiDAR ranges, m (checked, otherwise unused).
        w_up, w_robot : array_like of shape (B, 2) or (2,)
            Inlet wind and wind at the robot, m/s, world frame; a ``(2,)`` wind is used for
            every scan.

        Returns
        -------
        ndarray of float32, shape (B, 2, H, H)
            ``[u, v]`` = the baseline's wind in every cell, m/s, indexed ``[b, :, iy, ix]``.
        """
        wind = check_inputs(scans, w_up, w_robot, f"{type(self).__name__}.predict")[self._wind]
        h = self.size
        return np.broadcast_to(wind.astype(np.float32)[:, :, None, None],
                               (wind.shape[0], 2, h, h)).copy()


@dataclass(frozen=True)
class UpstreamBaseline(_UniformBaseline):
    """The Upstream baseline: the inlet wind ``W_up`` in every cell.

    Parameters
    ----------
    size : int
        Cells per side ``H``, >= 1.
    spacing : float
        Cell size, m, > 0.
    """

    _wind = 1


@dataclass(frozen=True)
class LocalBaseline(_UniformBaseline):
    """The Local baseline: the wind at the robot ``W_robot`` in every cell.

    Parameters
    ----------
    size : int
        Cells per side ``H``, >= 1.
    spacing : float
        Cell size, m, > 0.
    """

    _wind = 2


def with_baselines(models: dict, size: int, spacing: float) -> dict:
    """``models`` followed by both baselines on their grid: the set every comparison scores.

    Parameters
    ----------
    models : dict
        Name -> predictor (anything with ``offsets`` and ``predict(scans, w_up, w_robot)``).
    size : int
        Cells per side ``H`` of the baselines' grid (the models', e.g. ``decoder.size``).
    spacing : float
        Cell size of that grid, m (e.g. ``decoder.spacing``).

    Returns
    -------
    dict
        ``models``, then ``"local"`` (:class:`LocalBaseline`) and ``"upstream"``
        (:class:`UpstreamBaseline`), in that order.
    """
    return {**models, "local": LocalBaseline(size=size, spacing=spacing),
            "upstream": UpstreamBaseline(size=size, spacing=spacing)}
