"""Local observability of the Wind UKF model by Lie derivatives (Hermann & Krener 1977).

The model of :mod:`windnav.estimate.wind_model` is control-affine in the commanded rotor speeds
through the motor equation ``eta_i' = (u_i - eta_i) / tau_m``::

    x' = f0(x) + sum_i g_i u_i,     f0 = model with u = 0,     g_i = e_(12+i) / tau_m

with outputs ``h(x)`` = accelerometer specific force (3), gyro (3), odometry world velocity
``R v_b`` (3) and Euler angles (3). The observability codistribution up to order ``k`` is
spanned by the gradients of ``h`` and of its repeated Lie derivatives ``L_v h = (dh/dx) v``
along ``v in {f0, g_1..g_N}``; the system is locally weakly observable at ``x`` when

    O(x) = d/dx [h; L_v h; L_v L_w h; ...]    has rank 12 + N.

The symbolic build (sympy) is cached per (number of rotors, order); vehicle parameters are
lambdify arguments, so ``rank_at`` works for any parameter values, including zeroed ones.

The model is the filter's: its wind is a random walk in the world frame by default
(``w_b' = -Omega x w_b``), or in the body frame with ``wind_frame="body"`` (``w_b' = 0``, the
thesis model), as in :func:`windnav.estimate.wind_model.model_constants`. Until 2026-12-05 it
was always the body frame's, whatever the filter's; of the findings below only the one where
no equation sees the horizontal wind differs.

Findings (hummingbird, order 1, either frame unless said; checked in
``tests/test_observability.py``):

- random states: rank 16 = full. Order 1 is the lowest that achieves it: order 0 gives 12
  (the accelerometer alone cannot separate the wind from the rotor speeds).
- ``k_d = 0`` and ``c_dx = c_dy = 0``: horizontal wind enters only through translational lift
  ``k_h (v_a,x^2 + v_a,y^2)`` and ``|v_a|`` in the vertical parasitic drag: rank 15. With
  ``k_h = 0`` and ``c_dz = 0`` as well, horizontal wind enters no equation: rank 14 in the
  body frame; 15 in the world frame, where the turning body carries the world-fixed wind into
  its vertical axis and the rotors' vertical drag ``k_z`` sees one more direction.
- steady level hover in still air (zero airspeed, zero acceleration) with ``k_d = 0``: the
  quadratic parasitic drag and lift have zero gradient there, so horizontal wind is
  unobservable (rank 14) although it is observable in motion; likewise ``k_z = 0`` leaves the
  vertical wind unobservable at hover (rank 15). Rotor drag (linear in airspeed) is what makes
  the wind observable at hover.

These are order-1 ranks. An independent check (2026-12-05: Lie derivatives by nested
automatic differentiation of the filter's own functions, 25 cases, every rank equal; and the
Jacobian of outputs stacked over a few RK4 steps, which counts every order) found the drops
above, but for the body frame's 14 without any horizontal drag, recovered at higher orders or
once the inputs move the vehicle off hover: they mark directions the wind reaches the outputs
through slowly, not directions it never reaches. The world frame's 15 without horizontal drag
rests on a singular value 13-26 x ``rtol`` (at ``rtol = 1e-8`` it reads 14).

Measurement sets (``measurements=``, :data:`MEASUREMENT_SETS`): ``"imu"`` (default) is the four
outputs above. ``"hardware"`` is the author's hardware filter (:mod:`windnav.estimate.hardware`):
no accelerometer, so ``h`` = gyro, world velocity and Euler angles. Its differenced-velocity
acceleration adds no direction of its own: ``d/dt (R v_b) = L_f0 (R v_b) = R F / m - g e3`` is
already a first-order Lie derivative of the velocity output, so the hardware set needs one
order more than the IMU set for the same rank. Findings (hummingbird; tested): order 1 gives
rank 12 at random states, order 2 gives full rank 16 (also at hover with rotor drag).
"""

from __future__ import annotations

import functools

import numpy as np

from windnav.estimate.layout import IDX_ROTORS, IDX_VELOCITY, IDX_WIND, N_BASE, ROTORS
from windnav.estimate.wind_model import WIND_FRAMES
from windnav.vehicle.params import GRAVITY, MultirotorParams

__all__ = ["MEASUREMENT_SETS", "observability_matrix", "rank_at", "symbolic_model"]

_OUTPUT_ROWS = {"accel": (0, 3), "gyro": (3, 6), "velocity": (6, 9), "euler": (9, 12)}

MEASUREMENT_SETS = {
    "imu": ("accel", "gyro", "velocity", "euler"),
    "hardware": ("gyro", "velocity", "euler"),
}
"""Outputs of each measurement set, as blocks of :func:`symbolic_model`'s ``h``: ``accel``
(specific force), ``gyro``, ``velocity`` (world), ``euler``."""


def _measurement_set(measurements, where: str) -> tuple[str, ...]:
    found = MEASUREMENT_SETS.get(measurements) if isinstance(measurements, str) else None
    if found is None:
        raise ValueError(f"The 'measurements' parameter of {where} must be one of "
                         f"{sorted(MEASUREMENT_SETS)}. Got {measurements!r} instead.")
    return found

_PARAM_NAMES = ("m", "k_eta", "k_d", "k_z", "k_h", "c_dx", "c_dy", "c_dz", "tau_m", "g", "eps")


@functools.lru_cache(maxsize=8)
def symbolic_model(n_rotors: int, wind_frame: str = "world"):
    """Symbolic Wind UKF model.

    Parameters
    ----------
    n_rotors : int
    wind_frame : {"world", "body"}
        The wind's random-walk frame, as in :func:`windnav.estimate.wind_model.model_constants`:
        "world" (default, the filter's), ``w_b' = -Omega x w_b``; "body", ``w_b' = 0`` (the
        thesis model).

    Returns
    -------
    x : tuple of sympy.Symbol, length 12 + n_rotors
        State symbols, ordered as in :mod:`windnav.estimate.wind_model`.
    prm : tuple of sympy.Symbol
        ``m, k_eta, k_d, k_z, k_h, c_dx, c_dy, c_dz, tau_m, g, eps`` (``eps`` smooths
        ``|v_a| = sqrt(v_a . v_a + eps^2)``; 0 reproduces the model exactly).
    f0 : sympy.ImmutableMatrix of shape (12 + n_rotors, 1)
        Drift (``u = 0``).
    g : tuple of sympy.ImmutableMatrix
        Input vector fields ``e_(12+i) / tau_m``.
    h : sympy.ImmutableMatrix of shape (12, 1)
        Outputs: specific force (3), body rates (3), world velocity (3), Euler angles (3).
    """
    import sympy as sp

    if wind_frame not in WIND_FRAMES:
        raise ValueError(f"The 'wind_frame' parameter of symbolic_model must be one of "
                         f"{list(WIND_FRAMES)}. Got {wind_frame!r} instead.")
    ps, th, ph, p, q, r, vx, vy, vz, wx, wy, wz = sp.symbols(
        "psi theta phi p q r vx vy vz wx wy wz", real=True)
    eta = list(sp.symbols(f"eta0:{n_rotors}", real=True))
    x = [ps, th, ph, p, q, r, vx, vy, vz, wx, wy, wz, *eta]
    prm = list(sp.symbols(" ".join(_PARAM_NAMES), real=True))
    m, k_eta, k_d, k_z, k_h, c_dx, c_dy, c_dz, tau, g, eps = prm
    va = sp.Matrix([vx - wx, vy - wy, vz - wz])
    speed = sp.sqrt(va.dot(va) + eps**2)
    s_eta = sum(eta)
    F = sp.Matrix([
        -s_eta * k_d * va[0] - speed * c_dx * va[0],
        -s_eta * k_d * va[1] - speed * c_dy * va[1],
        k_eta * sum(e**2 for e in eta) + n_rotors * k_h * (va[0] ** 2 + va[1] ** 2)
        - s_eta * k_z * va[2] - speed * c_dz * va[2],
    ]) / m
    Rz = sp.Matrix([[sp.cos(ps), -sp.sin(ps), 0], [sp.sin(ps), sp.cos(ps), 0], [0, 0, 1]])
    Ry = sp.Matrix([[sp.cos(th), 0, sp.sin(th)], [0, 1, 0], [-sp.sin(th), 0, sp.cos(th)]])
    Rx = sp.Matrix([[1, 0, 0], [0, sp.cos(ph), -sp.sin(ph)], [0, sp.sin(ph), sp.cos(ph)]])
    R = Rz * Ry * Rx
    v = sp.Matrix([vx, vy, vz])
    omega = sp.Matrix([p, q, r])
    a = q * sp.sin(ph) + r * sp.cos(ph)
    dv = F - R.T * sp.Matrix([0, 0, g]) - omega.cross(v)
    dw = -omega.cross(sp.Matrix([wx, wy, wz])) if wind_frame == "world" else sp.zeros(3, 1)
    f0 = sp.Matrix([a / sp.cos(th), q * sp.cos(ph) - r * sp.sin(ph),
                    p + a * sp.tan(th), 0, 0, 0, *dv, *dw, *[-e / tau for e in eta]])
    gs = []
    for i in range(n_rotors):
        gi = sp.zeros(N_BASE + n_rotors, 1)
        gi[ROTORS + i] = 1 / tau
        gs.append(gi)
    h = sp.Matrix([*F, p, q, r, *(R * v), ps, th, ph])
    # immutable: the result is cached and shared by every caller, and an edit of one (f0[6] = 0)
    # reached every later call and the lambdified Jacobians built from it (cache audit)
    return (tuple(x), tuple(prm), sp.ImmutableMatrix(f0),
            tuple(sp.ImmutableMatrix(gi) for gi in gs), sp.ImmutableMatrix(h))


@functools.lru_cache(maxsize=8)
def _lambdified(n_rotors: int, order: int, outputs: tuple[str, ...], wind_frame: str):
    import sympy as sp

    x, prm, f0, gs, h_all = symbolic_model(n_rotors, wind_frame)
    h = sp.Matrix.vstack(*(h_all[slice(*_OUTPUT_ROWS[o]), :] for o in outputs))
    X = sp.Matrix(x)
    level = [h]
    funcs = [h]
    for _ in range(order):
        nxt = []
        for phi in level:
            J = phi.jacobian(X)
            for vf in (f0, *gs):
                L = J * vf
                if any(e != 0 for e in L):
                    nxt.append(L)
        funcs.extend(nxt)
        level = nxt
    Phi = sp.Matrix.vstack(*funcs)
    O = Phi.jacobian(X)
    return sp.lambdify([x, prm], O, modules="numpy", cse=True)


def _prm_values(params: MultirotorParams, eps: float) -> list[float]:
    return [params.mass, params.k_eta, params.k_d, params.k_z, params.k_h, params.c_dx,
            params.c_dy, params.c_dz, params.tau_m, GRAVITY, eps]


def observability_matrix(params: MultirotorParams, state, order: int = 1,
                         measurements: str = "imu", wind_frame: str = "world") -> np.ndarray:
    """Numerical observability matrix at one state.

    Parameters
    ----------
    params : MultirotorParams
    state : array_like of shape (12 + N,)
        Wind UKF state (angles rad, rates rad/s, velocities m/s, rotor speeds rad/s).
    order : int
        Highest Lie-derivative order (0, 1 or 2; 2 builds in seconds, once per process).
    measurements : {"imu", "hardware"}
        Output set (:data:`MEASUREMENT_SETS`).
    wind_frame : {"world", "body"}
        The model's wind frame (:func:`symbolic_model`); default the filter's, "world".

    Returns
    -------
    ndarray of shape (rows, 12 + N)
        Gradients of the outputs and their Lie derivatives, stacked.
    """
    if not isinstance(params, MultirotorParams):
        raise ValueError("The 'params' parameter of observability_matrix must be a "
                         f"MultirotorParams. Got {type(params).__name__} instead.")
    if isinstance(order, bool) or order not in (0, 1, 2):
        raise ValueError(f"The 'order' parameter of observability_matrix must be 0, 1 or 2. "
                         f"Got {order!r} instead.")
    n = N_BASE + params.n_rotors
    x = np.asarray(state, dtype=np.float64)
    if x.shape != (n,) or not np.all(np.isfinite(x)):
        raise ValueError(f"The 'state' parameter of observability_matrix must be a finite ({n},)"
                         f" array. Got shape {x.shape} instead.")
    airspeed = float(np.linalg.norm(x[IDX_VELOCITY] - x[IDX_WIND]))
    # |v_a| v_a has a zero gradient at v_a = 0 that the symbolic form writes as 0/0; a tiny
    # smoothing gives the limit without adding a spurious (eps-sized) gradient
    eps = 1e-12 if airspeed == 0.0 else 0.0
    outputs = _measurement_set(measurements, "observability_matrix")
    if wind_frame not in WIND_FRAMES:
        raise ValueError(f"The 'wind_frame' parameter of observability_matrix must be one of "
                         f"{list(WIND_FRAMES)}. Got {wind_frame!r} instead.")
    fn = _lambdified(params.n_rotors, int(order), outputs, wind_frame)
    O = np.array(fn(list(x), _prm_values(params, eps)), dtype=np.float64)
    return O.reshape(-1, n)  # the caller's (a broadcast view was read-only)


def rank_at(params: MultirotorParams, state, order: int = 1, rtol: float = 1e-9,
            measurements: str = "imu", wind_frame: str = "world") -> int:
    """Numerical rank of the observability matrix (full rank = 12 + N: locally observable).

    Columns are scaled by the state's typical magnitudes (rotor speeds by the hover speed)
    before an SVD; singular values below ``rtol`` times the largest count as zero. Rows are not
    normalised, so that negligible (round-off sized) rows cannot be inflated into information.

    Parameters
    ----------
    params : MultirotorParams
    state : array_like of shape (12 + N,)
    order : int
        Lie-derivative order (1 suffices for full rank with rotor drag).
    rtol : float
        Relative singular-value threshold.
    measurements : {"imu", "hardware"}
        Output set (:data:`MEASUREMENT_SETS`); "hardware" needs ``order=2`` for full rank.
    wind_frame : {"world", "body"}
        The model's wind frame (:func:`symbolic_model`); default the filter's, "world".

    Returns
    -------
    int
    """
    O = observability_matrix(params, state, order, measurements, wind_frame)
    scale = np.ones(O.shape[1])
    scale[IDX_ROTORS] = params.hover_rotor_speed
    sv = np.linalg.svd(O * scale, compute_uv=False)
    return int(np.sum(sv > rtol * sv[0]))
