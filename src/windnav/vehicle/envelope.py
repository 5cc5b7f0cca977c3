"""Where the aerodynamic model is used outside its envelope.

RotorPy's translational lift ``L_i = k_h (v_a,i,x^2 + v_a,i,y^2)`` is a small-advance-ratio
correction fitted near hover. Used far outside that range it dominates the physics: it does not
depend on the rotor speed, so a Crazyflie whose rotors have stopped still climbs in a 30 m/s
wind, and the Hummingbird gets 0.8 times its weight of free lift at 17 m/s. A state is flagged
when, for any rotor ``i``,

    L_i > lift_fraction * k_eta eta_i^2        (lift no longer a correction of the thrust)

or when the airspeed at the centre of mass exceeds the vehicle's limit,

    |v - w| > max_airspeed                     (MultirotorParams.airspeed_limit by default).

``L_i`` is the lift of the vehicle's own model (``translational_lift``), at the hub airspeed
``R^T (v - w_i) + Omega x r_i`` the dynamics use (the same kernel code). The simulation runner
reports the fraction of flagged samples of every flight.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from windnav._validate import positive_float
from windnav.vehicle.dynamics import rotor_loads_kernel
from windnav.vehicle.layout import ATTITUDE, N_RIGID, VELOCITY
from windnav.vehicle.multirotor import Multirotor
from windnav.vehicle.params import LIFT_ENVELOPE_FRACTION, MultirotorParams
from windnav.vehicle.state import VehicleState

__all__ = ["outside_envelope"]


def _speed_limit(value, where: str) -> float:
    """A positive airspeed, m/s; ``inf`` (no limit) is allowed."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        v = float("nan")
    if not v > 0.0:
        raise ValueError(f"The 'max_airspeed' parameter of {where} must be a number > 0 (inf "
                         f"for no limit). Got {value!r} instead.")
    return v


def outside_envelope(
    params: MultirotorParams | Sequence[MultirotorParams],
    state: VehicleState | np.ndarray,
    wind_world,
    *,
    lift_fraction: float = LIFT_ENVELOPE_FRACTION,
    max_airspeed: float | None = None,
) -> np.ndarray:
    """Flag the states at which the aerodynamic model is used outside its envelope.

    Parameters
    ----------
    params : MultirotorParams or sequence of MultirotorParams
        One vehicle for the whole batch, or one per batch row (as for :class:`Multirotor`).
    state : VehicleState or ndarray of shape (B, 13 + N)
        States (a packed array as :meth:`VehicleState.to_array` writes it is accepted).
    wind_world : ndarray of shape (B, 3), (3,) or (B, N, 3)
        Wind velocity in the world frame, m/s: one per vehicle or one per rotor hub (then the
        airspeed criterion uses the hub average), as for :meth:`Multirotor.step`.
    lift_fraction : float
        Largest translational lift of a rotor, as a fraction of its thrust ``k_eta eta_i^2``,
        inside the envelope (> 0).
    max_airspeed : float, optional
        Largest airspeed inside the envelope, m/s (``inf``: no limit); default each vehicle's
        :attr:`MultirotorParams.airspeed_limit`.

    Returns
    -------
    ndarray of shape (B,) of bool
        True where some rotor's lift exceeds ``lift_fraction`` of its thrust, the airspeed
        exceeds the limit, or the state is not finite.
    """
    where = "outside_envelope"
    plist = [params] if isinstance(params, MultirotorParams) else list(params)
    if not plist or not all(isinstance(p, MultirotorParams) for p in plist):
        raise ValueError(f"The 'params' parameter of {where} must be a MultirotorParams or a "
                         f"sequence of them. Got {type(params).__name__} instead.")
    lift_fraction = positive_float(lift_fraction, "lift_fraction", where)
    if max_airspeed is None:
        limit = np.array([p.airspeed_limit for p in plist])
    else:
        limit = np.array([_speed_limit(max_airspeed, where)])
    model = Multirotor(plist[0] if len(plist) == 1 else plist)
    x = state.to_array() if isinstance(state, VehicleState) else np.asarray(state, np.float64)
    if x.ndim != 2 or x.shape[1] != N_RIGID + model.n_rotors:
        raise ValueError(f"The 'state' parameter of {where} must be a VehicleState or a packed "
                         f"array of shape (B, {N_RIGID + model.n_rotors}). Got shape {x.shape} "
                         "instead.")
    x = np.ascontiguousarray(x)
    B = x.shape[0]
    if B == 0:  # "range() arg 3 must not be zero" inside the kernel before
        return np.zeros(0, dtype=bool)
    model._check_batch(B)
    q_norm = np.sqrt(np.sum(x[:, ATTITUDE] ** 2, axis=1))
    no_attitude = ~(q_norm >= 1e-6)  # a zero quaternion: a ZeroDivisionError in the kernel
    if no_attitude.any():  # such a row is outside any envelope, like a non-finite one
        x = x.copy()
        x[no_attitude, ATTITUDE] = (0.0, 0.0, 0.0, 1.0)
    com, hub = model._winds(wind_world, B, where)
    thrust = np.empty((B, model.n_rotors))
    lift = np.empty((B, model.n_rotors))
    p = model.packed
    rotor_loads_kernel(p.scalars, p.inertia, p.inertia_inv, p.rotor_positions,
                       p.rotor_directions, x, com, hub, thrust, lift)
    with np.errstate(over="ignore", invalid="ignore"):  # a diverging row's 1e200 m/s: inf,
        airspeed = np.linalg.norm(x[:, VELOCITY] - com, axis=1)  # outside, as it should be
    # a diverged (non-finite) state is outside any envelope; no exception for one bad row
    return (np.any(lift > lift_fraction * thrust, axis=1) | (airspeed > limit)
            | ~np.all(np.isfinite(x), axis=1) | no_attitude)
