"""``Multirotor``: a thin stateful-free shell over the batched dynamics kernels."""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np

from windnav._validate import batch_array, positive_float, positive_int
from windnav.vehicle.dynamics import derivative_kernel, pack_params, step_kernel
from windnav.vehicle.layout import ATTITUDE, BODY_RATES, N_RIGID, VELOCITY
from windnav.vehicle.params import MultirotorParams
from windnav.vehicle.state import VehicleState, _pack

MAX_SUBSTEP_S = 0.005
"""Default upper bound on the RK4 sub-step of the rigid body, s."""


class Multirotor:
    """Batched multirotor dynamics: ``step(state, rotor_speed_cmd, wind_world, dt) -> state``.

    Parameters
    ----------
    params : MultirotorParams or sequence of MultirotorParams
        One vehicle shared by the whole batch, or one per batch row (same rotor count).
    aero : bool
        Include rotor drag, translational lift, flapping and parasitic drag.
    gravity : bool
        Include gravity (switch off for free-rigid-body checks).
    substeps : int, optional
        RK4 sub-steps per call of :meth:`step`. Default: the fewest that keep each sub-step
        at or below 5 ms.
    """

    def __init__(
        self,
        params: MultirotorParams | Sequence[MultirotorParams],
        *,
        aero: bool = True,
        gravity: bool = True,
        substeps: int | None = None,
    ):
        self.params = params
        self.packed = pack_params(params, aero=aero, gravity=gravity)
        self.aero = aero
        self.gravity = gravity
        self.substeps = None if substeps is None else positive_int(substeps, "substeps",
                                                                   "Multirotor")
        first = params if isinstance(params, MultirotorParams) else params[0]
        self.n_rotors = first.n_rotors

    # ------------------------------------------------------------------------------------
    def _substeps(self, dt: float) -> int:
        if self.substeps is not None:
            return self.substeps
        return max(1, math.ceil(dt / MAX_SUBSTEP_S - 1e-9))

    def _check_batch(self, batch: int) -> None:
        if self.packed.size not in (1, batch):
            raise ValueError(
                f"The 'state' parameter of Multirotor has a batch of {batch} but the model holds "
                f"{self.packed.size} vehicles' parameters."
            )

    def hover_state(self, position) -> VehicleState:
        """Level, motionless state at ``position`` (3,) or (B, 3) with rotors at hover speed."""
        pos = batch_array(position, "position", "Multirotor.hover_state", (3,))
        B = pos.shape[0]
        hover = self.packed.hover_rotor_speed
        self._check_batch(B)
        hover = np.broadcast_to(hover[:, None], (B, self.n_rotors))
        att = np.zeros((B, 4))
        att[:, 3] = 1.0
        return VehicleState(pos.copy(), np.zeros((B, 3)), att, np.zeros((B, 3)),
                            np.array(hover, dtype=np.float64))

    def _winds(self, wind_world, B: int, where: str) -> tuple[np.ndarray, np.ndarray]:
        """``(wind_com (B, 3), wind_hub (B, N, 3))`` from one wind per vehicle or per hub."""
        w = np.asarray(wind_world, dtype=np.float64)
        N = self.n_rotors
        per_hub = w.ndim == 3
        trailing = (N, 3) if per_hub else (3,)
        arr = batch_array(w, "wind_world", where, trailing)
        if arr.shape[0] not in (1, B):
            raise ValueError(f"The 'wind_world' parameter of {where} must have a batch of {B}. "
                             f"Got {arr.shape[0]} instead.")
        arr = np.broadcast_to(arr, (B, *trailing))
        if per_hub:
            return np.ascontiguousarray(arr.mean(axis=1)), np.ascontiguousarray(arr)
        com = np.ascontiguousarray(arr)
        return com, np.ascontiguousarray(np.broadcast_to(com[:, None, :], (B, N, 3)))

    def _packed_state(self, state: VehicleState, where: str) -> np.ndarray:
        if not isinstance(state, VehicleState):
            raise ValueError(f"The 'state' parameter of {where} must be a VehicleState. "
                             f"Got {type(state).__name__} instead.")
        widths = {"position": 3, "velocity": 3, "attitude": 4, "body_rates": 3,
                  "rotor_speeds": self.n_rotors}
        batch = np.shape(state.position)[0] if np.ndim(state.position) else None
        for field, width in widths.items():
            shape = np.shape(getattr(state, field))
            if shape != (batch, width):
                raise ValueError(f"The 'state' parameter of {where} must have {field} of shape "
                                 f"(B, {width}) with the batch of position. Got {field} of "
                                 f"shape {shape} instead.")
        x = _pack(state)  # shapes checked above
        if not np.all(np.isfinite(x)):
            raise ValueError(f"The 'state' parameter of {where} must be finite. Got NaN/inf.")
        q_norm = np.sqrt(np.sum(x[:, ATTITUDE] ** 2, axis=1))
        if (q_norm < 1e-6).any():  # the rotation divides by it
            raise ValueError(f"The 'state' parameter of {where} must have a non-zero attitude "
                             f"quaternion. Got a norm of {float(q_norm.min())!r} instead.")
        self._check_batch(x.shape[0])
        return x

    # ------------------------------------------------------------------------------------
    def step(self, state: VehicleState, rotor_speed_cmd, wind_world, dt: float) -> VehicleState:
        """Advance ``state`` by ``dt`` seconds with constant commands and wind (pure).

        Parameters
        ----------
        state : VehicleState
            Batch of B states.
        rotor_speed_cmd : ndarray of shape (B, N) or (N,)
            Commanded rotor speeds, rad/s; clipped to ``[rotor_speed_min, rotor_speed_max]``.
        wind_world : ndarray of shape (B, 3), (3,) or (B, N, 3)
            Wind velocity in the world frame, m/s: one per vehicle (at the centre of mass) or one
            per rotor hub.
        dt : float
            Time step, s (> 0).

        Returns
        -------
        VehicleState
            The new state (inputs are not modified).
        """
        where = "Multirotor.step"
        dt = positive_float(dt, "dt", where)
        x = self._packed_state(state, where)
        B = x.shape[0]
        cmd = batch_array(rotor_speed_cmd, "rotor_speed_cmd", where, (self.n_rotors,))
        if cmd.shape[0] == 1 and B > 1:
            cmd = np.broadcast_to(cmd, (B, self.n_rotors))
        if cmd.shape[0] != B:
            raise ValueError(f"The 'rotor_speed_cmd' parameter of {where} must have a batch of "
                             f"{B}. Got {cmd.shape[0]} instead.")
        com, hub = self._winds(wind_world, B, where)
        out = np.empty_like(x)
        if B:  # the kernel's chunks fail on an empty batch ("range() arg 3 must not be zero")
            self.step_packed(x, np.ascontiguousarray(cmd), com, hub, dt, out)
        return VehicleState.from_array(out)

    def step_packed(self, x, cmd, wind_com, wind_hub, dt, out) -> None:
        """Unchecked fast path of :meth:`step` on packed ``(B, 13 + N)`` arrays (writes ``out``)."""
        p = self.packed
        step_kernel(p.scalars, p.inertia, p.inertia_inv, p.rotor_positions, p.rotor_directions,
                    x, cmd, wind_com, wind_hub, float(dt), self._substeps(dt), out)

    def derivatives(self, state: VehicleState, wind_world) -> dict:
        """Instantaneous accelerations and body wrench at ``state`` (rotor speeds as in state).

        Returns
        -------
        dict with
            ``acceleration_world`` (B, 3) m/s^2, ``angular_acceleration`` (B, 3) rad/s^2,
            ``force_body`` (B, 3) N (aerodynamic + rotor forces, no gravity),
            ``moment_body`` (B, 3) N m, ``specific_force_body`` (B, 3) m/s^2 (what an ideal
            accelerometer at the centre of mass reads: force_body / mass).
        """
        where = "Multirotor.derivatives"
        x = self._packed_state(state, where)
        B = x.shape[0]
        com, hub = self._winds(wind_world, B, where)
        return self.derivatives_packed(x, com, hub)

    def derivatives_packed(self, x, wind_com, wind_hub) -> dict:
        """Unchecked fast path of :meth:`derivatives` on packed states and winds."""
        com, hub = wind_com, wind_hub
        B = x.shape[0]
        dy = np.empty((B, N_RIGID))
        force = np.empty((B, 3))
        moment = np.empty((B, 3))
        p = self.packed
        if B:  # an empty batch: empty results (the kernel's chunks fail on it)
            derivative_kernel(p.scalars, p.inertia, p.inertia_inv, p.rotor_positions,
                              p.rotor_directions, x, com, hub, dy, force, moment)
        mass = p.mass[:, None]
        return {
            "acceleration_world": dy[:, VELOCITY],
            "angular_acceleration": dy[:, BODY_RATES],
            "force_body": force,
            "moment_body": moment,
            "specific_force_body": force / mass,
        }

    def clip_rotor_speeds(self, rotor_speed_cmd) -> tuple[np.ndarray, np.ndarray]:
        """Clip commands to the rotor limits; return ``(clipped, saturated_mask)``.

        ``rotor_speed_cmd`` is (..., B, N) or (N,), rad/s, B the model's vehicles when it holds
        more than one.

        Raises
        ------
        ValueError
            Naming ``rotor_speed_cmd`` when it has another shape (3 commands for 4 rotors were
            clipped as if there were 3 rotors).
        """
        lo = self.packed.rotor_speed_min[:, None]
        hi = self.packed.rotor_speed_max[:, None]
        cmd = np.asarray(rotor_speed_cmd, dtype=np.float64)
        shape, P = cmd.shape, lo.shape[0]
        if not (shape and shape[-1] == self.n_rotors
                and (len(shape) == 1 or P == 1 or shape[-2] == P)):
            want = f"(..., {self.n_rotors})" if P == 1 else (
                f"(..., {P}, {self.n_rotors}) or ({self.n_rotors},)")
            raise ValueError(f"The 'rotor_speed_cmd' parameter of Multirotor.clip_rotor_speeds "
                             f"must have shape {want}. Got shape {shape} instead.")
        clipped = np.clip(cmd, lo, hi)
        return clipped, clipped != cmd
