"""Aerodynamic coefficients from hover in a wind tunnel: rotor drag, inflow and lift.

With the body airspeed ``v_a = R^T (v - w)`` (the same at every hub in steady hover), rotor
speeds ``eta_i`` (``S = sum_i eta_i``, ``S2 = sum_i eta_i^2``) and the accelerometer's specific
force ``f`` in body axes (x forward, y left, z up), the force model of
:mod:`windnav.vehicle.dynamics` gives (thesis ch. 6)::

    lateral    m f_x = -k_d v_a,x S + m b_x,     m f_y = -k_d v_a,y S + m b_y
    vertical   m f_z = k_eta S2 - k_z v_a,z S + N k_h (v_a,x^2 + v_a,y^2)

The lateral equations share the slope ``k_d``; their intercepts are the accelerometer biases
``b_x``, ``b_y``. ``k_eta``, ``k_z`` and ``k_h`` come jointly from the vertical one, by least
squares (``windnav.sysid._fit``). Thesis values (Crazyflie 2.1 Brushless): k_eta 4.26e-8,
k_d 5.09e-6, k_z 1.19e-5, k_h 1.11e-3.

Parasitic frame drag (``D = -|v_a| diag(c_Dx, c_Dy, c_Dz) v_a``, the simulator's) is not in
the thesis's model. ``fit_aero(..., parasitic=True)`` (``windnav sysid aero --parasitic``) adds
it: ``- c_Dx |v_a| v_a,x`` and ``- c_Dy |v_a| v_a,y`` to the lateral equations and ``- c_Dz
|v_a| v_a,z`` to the vertical one, fitted with the rest. Without it, the fit still fits the
lateral equations with frame drag too (:attr:`AeroFit.frame_drag_check`) and notes when the
drag is there and moves ``k_d`` by more than ``k_d``'s own 95 % interval: on the simulated
Hummingbird (``c_D`` 0.005-0.01 N/(m/s)^2) the thesis's model gave k_d +10.7 %, k_z +10.9 %,
k_h -8.1 %, each interval excluding the truth, and said nothing.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from windnav._validate import ReadOnlyOnCopy, nonnegative_int, positive_float, positive_int
from windnav.sysid._fit import Estimate, LeastSquares, linear_fit
from windnav.sysid.io import Table

__all__ = ["AERO_COLUMNS", "AeroData", "AeroFit", "COLLINEAR_KZ_KH", "FRAME_DRAG_NAMES",
           "aero_and_status_from_flight_log", "aero_columns", "aero_from_flight_log",
           "block_average", "fit_aero"]

AERO_COLUMNS = ("time_s", "airspeed_x", "airspeed_y", "airspeed_z", "specific_force_x",
                "specific_force_y", "specific_force_z")
"""The first columns of an aero CSV: time (s), body airspeed (m/s), body specific force
(m/s^2), body axes x forward, y left, z up; then ``rotor_speed_1`` ... ``rotor_speed_N``
(rad/s)."""

_ROTOR = re.compile(r"^rotor_speed_(\d+)$")

COLLINEAR_KZ_KH = 0.95
"""Above this ``|r|`` between the regressors of ``k_z`` (``-v_a,z sum(eta)``) and ``k_h``
(``N v_h^2``), the fit notes that the two are not separated. Horizontal flows alone give
``r`` about -0.997 (the inflow ``v_a,z`` comes only from the tilt, which grows like ``V``),
and sensor noise then biased k_z by -25 % and k_h by -40 % with 95 % intervals that excluded
the truth (audit, 2027); the default campaign with vertical flows gives about -0.2."""


FRAME_DRAG_NAMES = ("c_Dx", "c_Dy", "c_Dz")
"""The parasitic (frame) drag coefficients ``fit_aero(..., parasitic=True)`` fits, N/(m/s)^2
(the fields ``c_dx``, ``c_dy``, ``c_dz`` of :class:`windnav.vehicle.MultirotorParams`)."""


def _float_array(value, name: str) -> np.ndarray:
    try:  # a copy: AeroData is checked finite at construction, and keeps what it checked
        return np.array(value, dtype=np.float64)
    except (TypeError, ValueError):
        raise ValueError(f"The {name!r} parameter of AeroData must be an array of numbers. Got "
                         f"{type(value).__name__} instead.") from None


def aero_columns(n_rotors: int) -> tuple[str, ...]:
    """The full header of an aero CSV for ``n_rotors`` rotors (an integer >= 1)."""
    # 0 or -2 gave a header without a rotor column (Python API audit, fifty-eighth session)
    n_rotors = positive_int(n_rotors, "n_rotors", "aero_columns")
    return AERO_COLUMNS + tuple(f"rotor_speed_{i + 1}" for i in range(n_rotors))


@dataclass(frozen=True, eq=False)
class AeroData(ReadOnlyOnCopy):
    """Samples of a hovering vehicle in a known airflow.

    Attributes
    ----------
    t : ndarray of shape (K,)
        Times, s.
    airspeed_body : ndarray of shape (K, 3)
        ``R^T (v - w)``, body axes, m/s.
    specific_force_body : ndarray of shape (K, 3)
        Accelerometer reading, body axes, m/s^2 (about +9.81 on z in hover).
    rotor_speeds : ndarray of shape (K, N)
        rad/s.
    source : str
        Where the samples came from, for messages.
    dropped : int
        Rows of the source left out for a non-finite value (:meth:`from_table`, the flight
        log reader); ``sysid aero`` says how many.

    Every array is checked at construction: finite, with one row per time (K may be 0) and
    at least one rotor.
    """

    t: np.ndarray
    airspeed_body: np.ndarray
    specific_force_body: np.ndarray
    rotor_speeds: np.ndarray
    source: str = "aero data"
    dropped: int = 0

    def __post_init__(self):
        # built by hand, arrays that did not line up reached fit_aero as a LinAlgError, an
        # IndexError or a "linearly dependent" message, and NaN samples as the latter
        names = ("t", "airspeed_body", "specific_force_body", "rotor_speeds")
        arrays = {n: _float_array(getattr(self, n), n) for n in names}
        t, eta = arrays["t"], arrays["rotor_speeds"]
        k = t.shape[0] if t.ndim == 1 else None
        wanted = {"t": ((k,), "(K,)"), "airspeed_body": ((k, 3), "(K, 3)"),
                  "specific_force_body": ((k, 3), "(K, 3)"),
                  "rotor_speeds": ((k, max(eta.shape[-1], 1) if eta.ndim == 2 else -1),
                                   "(K, N) with N >= 1")}
        for name, a in arrays.items():
            shape, text = wanted[name]
            if a.shape != shape:
                raise ValueError(f"The {name!r} parameter of AeroData must be an array of shape "
                                 f"{text}, K = len(t). Got shape {a.shape} with t "
                                 f"{t.shape} instead.")
            if not np.all(np.isfinite(a)):
                raise ValueError(f"The {name!r} parameter of AeroData must be finite (drop the "
                                 "rows with NaN first). Got non-finite entries instead.")
            a.setflags(write=False)  # a caller refilling its buffer got NaN past the check
            object.__setattr__(self, name, a)
        # -3 passed, and was reported as dropped rows (Python API audit, fifty-eighth session)
        object.__setattr__(self, "dropped", nonnegative_int(self.dropped, "dropped", "AeroData"))

    @property
    def n_rotors(self) -> int:
        return int(self.rotor_speeds.shape[1])

    @classmethod
    def from_table(cls, table: Table, where: str = "AeroData.from_table") -> AeroData:
        """From a table with the columns :func:`aero_columns` (rows with NaN are dropped)."""
        table.require(AERO_COLUMNS, where)
        idx = sorted(int(m.group(1)) for n in table.names if (m := _ROTOR.match(n)))
        if not idx or idx != list(range(1, len(idx) + 1)):
            raise ValueError(f"The file {table.source!r} given to {where} must have the "
                             "columns 'rotor_speed_1' ... 'rotor_speed_N' (rad/s). Got "
                             f"{[n for n in table.names if n.startswith('rotor_speed')]} "
                             "instead.")
        c = table.columns
        va = np.column_stack([c[f"airspeed_{a}"] for a in "xyz"])
        f = np.column_stack([c[f"specific_force_{a}"] for a in "xyz"])
        eta = np.column_stack([c[f"rotor_speed_{i}"] for i in idx])
        t = c["time_s"]
        ok = np.isfinite(t) & np.all(np.isfinite(va), 1) & np.all(np.isfinite(f), 1) & np.all(
            np.isfinite(eta), 1)
        return cls(t[ok], va[ok], f[ok], eta[ok], table.source, int(ok.size - ok.sum()))

    def to_columns(self) -> dict:
        """``{column: (K,)}`` in the aero CSV layout (read-only views of the samples)."""
        cols = {"time_s": self.t}
        for j, a in enumerate("xyz"):
            cols[f"airspeed_{a}"] = self.airspeed_body[:, j]
        for j, a in enumerate("xyz"):
            cols[f"specific_force_{a}"] = self.specific_force_body[:, j]
        for i in range(self.n_rotors):
            cols[f"rotor_speed_{i + 1}"] = self.rotor_speeds[:, i]
        return cols

    @staticmethod
    def concatenate(parts: Sequence[AeroData]) -> AeroData:
        """All samples of ``parts`` (same rotor count) as one."""
        n = {p.n_rotors for p in parts}
        if len(n) != 1:
            raise ValueError("The aero data to pool must have the same number of rotors. Got "
                             f"{sorted(n)} from {[p.source for p in parts]}.")
        return AeroData(np.concatenate([p.t for p in parts]),
                        np.concatenate([p.airspeed_body for p in parts]),
                        np.concatenate([p.specific_force_body for p in parts]),
                        np.concatenate([p.rotor_speeds for p in parts]),
                        ", ".join(repr(p.source) for p in parts),
                        sum(p.dropped for p in parts))


def aero_from_flight_log(log, *, settle_s: float | None = None,
                         source: str = "FlightLog") -> AeroData:
    """Aero samples of a :class:`~windnav.sim.FlightLog` at its IMU sample times.

    Specific force: the logged IMU accelerometer (with its noise and bias). Airspeed
    ``R^T (v - w)`` and rotor speeds: the logged state and wind at the same times (the log
    is interpolated linearly; the attitude is taken at the nearest logged instant). Every
    vehicle of the batch contributes, except those flagged non-finite: ``SATURATED`` and
    ``OUTSIDE_ENVELOPE`` ones are kept (:func:`aero_and_status_from_flight_log` counts them).

    Parameters
    ----------
    log : FlightLog
        With the ``imu`` sensor.
    settle_s : float, optional
        Samples before this time are dropped (the transient after the flow starts). Default
        ``log.meta["sysid"]["settle_s"]`` when present, else 0.
    source : str
        For messages.
    """
    _check_log(log, "aero_from_flight_log")
    return aero_and_status_from_flight_log(log, settle_s=settle_s, source=source)[0]


def _check_log(log, where: str) -> None:
    """Refuse a ``log`` that is not a FlightLog, by name (an AttributeError before; Python API
    audit, fifty-eighth session)."""
    from windnav.sim.log import FlightLog

    if not isinstance(log, FlightLog):
        raise ValueError(f"The 'log' parameter of {where} must be a FlightLog. Got "
                         f"{type(log).__name__} instead.")


def aero_and_status_from_flight_log(log, *, settle_s: float | None = None,
                                    source: str = "FlightLog") -> tuple[AeroData, dict]:
    """:func:`aero_from_flight_log`, with how many of its samples come from each
    :class:`~windnav.sim.log.FlightStatus` of the flying vehicle (one pass over the log).

    The status is the vehicle's over its whole flight (the settling transient included):
    ``SATURATED`` or ``OUTSIDE_ENVELOPE`` vehicles are *kept* (only non-finite ones are
    dropped), and their samples may lie where the force model does not hold.

    Returns
    -------
    (AeroData, dict)
        The samples, and ``{"samples": {status name: count}, "vehicles": {status name:
        count}}`` (``"OK"`` for the vehicles without a flag).
    """
    from windnav.sim.log import FlightStatus

    _check_log(log, "aero_and_status_from_flight_log")
    parts = _vehicle_parts(log, settle_s, source)
    if not parts:
        raise ValueError(f"The flight log {source!r} has no vehicle that flew with finite "
                         "values.")
    status = np.asarray(log.status, dtype=np.int64)
    samples: dict[str, int] = {}
    vehicles: dict[str, int] = {}
    for b, part in parts:
        code = int(status[b])
        name = str(FlightStatus(code).name) if code else "OK"
        samples[name] = samples.get(name, 0) + int(part.t.size)
        vehicles[name] = vehicles.get(name, 0) + 1
    data = AeroData.concatenate([d for _, d in parts])
    return (AeroData(data.t, data.airspeed_body, data.specific_force_body, data.rotor_speeds,
                     source, data.dropped), {"samples": samples, "vehicles": vehicles})


def _vehicle_parts(log, settle_s: float | None, source: str) -> list:
    """``[(batch index, AeroData)]`` of the vehicles that flew with finite values."""
    from scipy.spatial.transform import Rotation

    if "imu" not in log.sensors:
        raise ValueError(f"The flight log {source!r} must carry the 'imu' sensor for an aero "
                         f"fit (logged: {sorted(log.sensors)}).")
    if settle_s is None:
        settle_s = float(log.meta.get("sysid", {}).get("settle_s", 0.0))
    settle_s = positive_float(settle_s, "settle_s", "aero_from_flight_log", allow_zero=True)
    imu = log.sensors["imu"]
    t_imu = np.asarray(imu["t"], dtype=np.float64)
    keep = t_imu >= log.t[0] + settle_s
    if not keep.any():  # "0 usable points" before, without the cause
        end = float(t_imu[-1] - log.t[0]) if t_imu.size else 0.0
        raise ValueError(f"The 'settle_s' parameter of aero_from_flight_log must leave samples "
                         f"in the log {source!r} (its IMU ends {end:.4g} s after its start). "
                         f"Got {settle_s!r} instead.")
    t = t_imu[keep]
    # the attitude at the IMU's times: the logged one where the log holds the time, else
    # slerped between its neighbours, as velocity and wind are interpolated; the next logged
    # attitude was taken, which with log_every = 4 put 0.59 m/s of error into the airspeed in
    # manoeuvres (metamorphic audit, 2026-12-05)
    at_log = np.clip(np.searchsorted(log.t, t - 1e-9), 0, log.t.size - 1)
    exact = np.abs(log.t[at_log] - t) <= 1e-9
    t_slerp = np.clip(t, log.t[0], log.t[-1])
    B = log.position.shape[1]
    finite = np.asarray(log.finite, dtype=bool)
    parts = []
    for b in range(B):
        if not finite[b]:
            continue

        def at(arr, b=b):
            return np.column_stack([np.interp(t, log.t, arr[:, b, j])
                                    for j in range(arr.shape[2])])

        rel = at(log.velocity) - at(log.wind)
        quat = np.array(log.attitude[at_log, b], dtype=np.float64)
        if not exact.all() and log.t.size > 1:
            from scipy.spatial.transform import Slerp

            quat[~exact] = Slerp(log.t, Rotation.from_quat(log.attitude[:, b]))(
                t_slerp[~exact]).as_quat()
        R = Rotation.from_quat(quat)
        va = R.inv().apply(rel)
        f = np.asarray(imu["accel"])[keep, b]
        eta = at(log.rotor_speeds)
        ok = (np.all(np.isfinite(f), 1) & np.all(np.isfinite(va), 1)  # AeroData holds
              & np.all(np.isfinite(eta), 1))                            # finite samples only
        parts.append((b, AeroData(t[ok], va[ok], f[ok], eta[ok], source,
                                  int(ok.size - ok.sum()))))
    return parts


MAX_BLOCK_KEY = 2.0**52
"""The most blocks (times segments) :func:`block_average` splits samples into: its integer
keys stay exact in float64 and far from int64's overflow."""


def block_average(data: AeroData, window_s: float) -> AeroData:
    """Means over consecutive blocks of ``window_s`` seconds (a time gap or a step back in
    time starts a new block).

    Averaging the samples before forming the regressors keeps sensor noise on the rotor
    speeds and airspeed (errors in the regressors, which bias least squares toward zero) from
    biasing the coefficients; in steady hover it changes nothing else.
    """
    where = "block_average"
    if not isinstance(data, AeroData):  # an AttributeError before (Python API audit)
        raise ValueError(f"The 'data' parameter of {where} must be an AeroData. Got "
                         f"{type(data).__name__} instead.")
    w = positive_float(window_s, "window_s", where)
    t = data.t
    if t.size == 0:
        return data
    dt = np.diff(t)
    step = float(np.median(dt[dt > 0])) if np.any(dt > 0) else w
    new_seg = np.r_[True, (dt <= 0) | (dt > 5 * step)]
    seg = np.cumsum(new_seg) - 1
    start = t[np.flatnonzero(new_seg)][seg]
    blocks = (t - start) / w + 1e-9
    # the block keys are int64: a window of 1e-300 s overflowed them and averaged 2 blocks
    # where each sample was its own (Python API audit, fifty-eighth session)
    if float(blocks.max()) * (int(seg[-1]) + 1) >= MAX_BLOCK_KEY:
        raise ValueError(f"The 'window_s' parameter of {where} is too small for the samples' "
                         f"{float((t - start).max()):.4g} s: it must split them into fewer than "
                         f"{MAX_BLOCK_KEY:.2g} blocks. Got {window_s!r} instead.")
    block = np.floor(blocks).astype(np.int64)
    key = seg * (int(block.max()) + 1) + block
    _, inverse, counts = np.unique(key, return_inverse=True, return_counts=True)

    def mean(a):
        a2 = a.reshape(a.shape[0], -1)
        out = np.stack([np.bincount(inverse, a2[:, j]) for j in range(a2.shape[1])], 1)
        return (out / counts[:, None]).reshape((-1,) + a.shape[1:])

    return AeroData(mean(t), mean(data.airspeed_body), mean(data.specific_force_body),
                    mean(data.rotor_speeds), data.source, data.dropped)


@dataclass(frozen=True, eq=False)
class AeroFit:
    """Rotor aerodynamic coefficients from hover in a known airflow.

    Attributes
    ----------
    k_eta : Estimate
        Thrust coefficient, N/(rad/s)^2.
    k_d : Estimate
        In-plane rotor drag, kg/rad.
    k_z : Estimate
        Axial (inflow) rotor drag, kg/rad.
    k_h : Estimate
        Translational lift, kg/m.
    accel_bias : tuple of Estimate
        Accelerometer biases ``(b_x, b_y)``, m/s^2.
    lateral, vertical : LeastSquares
        The two regressions (``lateral`` stacks the x then the y equations).
    mass : float
        Mass used, kg.
    data : AeroData
        The samples.
    frame_drag : tuple of Estimate or None
        ``(c_Dx, c_Dy, c_Dz)``, N/(m/s)^2, when fitted (``parasitic=True``); else None.
    frame_drag_check : dict or None
        Without ``parasitic``: the lateral equations fitted again with frame drag
        (``c_Dx``, ``c_Dy`` and that fit's ``k_d``, each ``{"value", "std_error", "ci95"}``),
        and ``significant``: whether the drag is there (both intervals above 0) and moves
        ``k_d`` past its own 95 % interval, when the thesis's model is biased (a note says
        so). None with ``parasitic`` (the drag is in the model) or where the samples cannot
        separate it.
    """

    k_eta: Estimate
    k_d: Estimate
    k_z: Estimate
    k_h: Estimate
    accel_bias: tuple
    lateral: LeastSquares
    vertical: LeastSquares
    mass: float
    data: AeroData
    frame_drag: tuple | None = None
    frame_drag_check: dict | None = None

    @property
    def kz_kh_correlation(self) -> float | None:
        """Pearson correlation of the regressors of ``k_z`` (``-v_a,z sum(eta)``) and ``k_h``
        (``v_h^2``) over the samples; None where one of them does not vary. Near +-1 the two
        are not separated (horizontal flows only), see :data:`COLLINEAR_KZ_KH`."""
        X = _vertical_regressors(self.data, self.mass)
        a, b = X[:, 1], X[:, 2]
        if a.size < 2 or np.ptp(a) == 0 or np.ptp(b) == 0:
            return None
        return float(np.corrcoef(a, b)[0, 1])

    @property
    def vertical_condition_number(self) -> float:
        """Condition number of the vertical regressors scaled to unit norm (the matrix the
        fit solves): about 3 with vertical flows, about 50 with horizontal flows only."""
        X = _vertical_regressors(self.data, self.mass)
        norm = np.linalg.norm(X, axis=0)
        return float(np.linalg.cond(X / np.where(norm > 0, norm, 1.0)))

    @property
    def notes(self) -> list[str]:
        """Caveats of the fit, one sentence each (empty when none)."""
        notes = []
        loose = [f"{n} [{e.ci95[0]:.3g}, {e.ci95[1]:.3g}]" for n in POSITIVE
                 for e in (getattr(self, n),) if e.ci95[0] <= 0.0 <= e.ci95[1]]
        if loose:  # hover-only samples: k_d 23 x low, its interval over 0, no note (audit)
            notes.append(
                f"the samples do not determine {', '.join(loose)}: each 95 % interval "
                "includes 0, so the value is noise; fly airflows that excite it (several "
                "lateral airspeeds for k_d and k_h, vertical ones for k_z)")
        r = self.kz_kh_correlation
        if r is not None and abs(r) > COLLINEAR_KZ_KH:
            notes.append(
                f"k_z and k_h are not separable without vertical flows: their regressors "
                f"v_z sum(eta) and v_h^2 correlate at r = {r:.3f} (|r| > {COLLINEAR_KZ_KH:g}; "
                f"condition number {self.vertical_condition_number:.3g}), so noise on the "
                "rotor speeds and airspeed biases both, and their 95 % intervals, which "
                "ignore regressor noise, may exclude the truth; fly vertical flows "
                "(simulate-tunnel --axes ... z neg_z) or use --average-s")
        check = self.frame_drag_check
        if check is not None and check["significant"]:
            kd, kd2 = self.k_d.value, check["k_d"]["value"]
            notes.append(
                f"the lateral samples carry frame (parasitic) drag, which the thesis's model "
                f"leaves out: with it, c_Dx = {check['c_Dx']['value']:.3g} and c_Dy = "
                f"{check['c_Dy']['value']:.3g} N/(m/s)^2 and k_d = {kd2:.4g} "
                f"({100 * (kd2 / kd - 1):+.1f} % from this fit's, outside its 95 % interval), "
                "so this k_d, and k_z and k_h with it, are biased; fit with the drag "
                "(fit_aero(..., parasitic=True), sysid aero --parasitic)")
        return notes

    def to_dict(self) -> dict:
        """The JSON payload: each coefficient with ``value``, ``std_error``, ``ci95``."""
        return {
            "k_eta": self.k_eta.to_dict(), "k_d": self.k_d.to_dict(),
            "k_z": self.k_z.to_dict(), "k_h": self.k_h.to_dict(),
            "accel_bias": {"x": self.accel_bias[0].to_dict(), "y": self.accel_bias[1].to_dict()},
            "r2_lateral": self.lateral.r2, "r2_vertical": self.vertical.r2,
            "rmse_lateral_m_s2": self.lateral.rmse, "rmse_vertical_m_s2": self.vertical.rmse,
            "mass_kg": self.mass, "n_points": int(self.data.t.size),
            "n_rotors": self.data.n_rotors,
            "kz_kh_regressor_correlation": self.kz_kh_correlation,
            "vertical_condition_number": self.vertical_condition_number,
            "units": {"k_eta": "N/(rad/s)^2", "k_d": "kg/rad", "k_z": "kg/rad", "k_h": "kg/m",
                      "accel_bias": "m/s^2", "frame_drag": "N/(m/s)^2"},
            "frame_drag": (None if self.frame_drag is None else
                           {n: e.to_dict() for n, e in zip(FRAME_DRAG_NAMES, self.frame_drag,
                                                          strict=True)}),
            "frame_drag_check": self.frame_drag_check,
            "notes": self.notes,
        }

    def frame_drag_accel(self) -> np.ndarray:
        """The fitted frame drag's specific force at the samples, ``(K, 3)`` m/s^2 (zeros
        without ``parasitic``)."""
        if self.frame_drag is None:
            return np.zeros_like(self.data.airspeed_body)
        c = np.array([e.value for e in self.frame_drag])
        return _frame_drag_regressors(self.data, self.mass) * c


def _vertical_regressors(d: AeroData, m: float) -> np.ndarray:
    """The columns of the vertical fit, ``(K, 3)``: those of ``k_eta``, ``k_z``, ``k_h``."""
    va, eta = d.airspeed_body, d.rotor_speeds
    s1 = eta.sum(axis=1)
    s2 = (eta**2).sum(axis=1)
    return np.column_stack([s2 / m, -va[:, 2] * s1 / m,
                            d.n_rotors * (va[:, 0] ** 2 + va[:, 1] ** 2) / m])


def _frame_drag_regressors(d: AeroData, m: float) -> np.ndarray:
    """``-|v_a| v_a / m`` per axis, ``(K, 3)``: frame drag's specific force per unit of
    ``c_D`` (N/(m/s)^2)."""
    va = d.airspeed_body
    return -np.linalg.norm(va, axis=1)[:, None] * va / m


def _lateral_system(d: AeroData, m: float, parasitic: bool):
    """The lateral regression: x rows then y rows; columns ``k_d``, ``b_x``, ``b_y`` (and
    ``c_Dx``, ``c_Dy`` with ``parasitic``)."""
    va, f = d.airspeed_body, d.specific_force_body
    K = va.shape[0]
    s1 = d.rotor_speeds.sum(axis=1)
    zero, one = np.zeros(K), np.ones(K)
    cols_x = [-va[:, 0] * s1 / m, one, zero]
    cols_y = [-va[:, 1] * s1 / m, zero, one]
    names = ["k_d", "b_x", "b_y"]
    if parasitic:
        drag = _frame_drag_regressors(d, m)
        cols_x += [drag[:, 0], zero]
        cols_y += [zero, drag[:, 1]]
        names += ["c_Dx", "c_Dy"]
    X = np.vstack([np.column_stack(cols_x), np.column_stack(cols_y)])
    return X, np.concatenate([f[:, 0], f[:, 1]]), names


def fit_aero(data: AeroData | Sequence[AeroData], mass: float, *, parasitic: bool = False,
             where: str = "fit_aero") -> AeroFit:
    """Fit ``k_d`` (with the accelerometer biases) and ``k_eta, k_z, k_h`` (jointly).

    Parameters
    ----------
    data : AeroData or sequence of AeroData
        Hover samples in several airflows (pooled).
    mass : float
        Vehicle mass, kg.
    parasitic : bool, default False
        Fit the frame drag ``c_Dx``, ``c_Dy`` (lateral) and ``c_Dz`` (vertical) with the rest
        (:data:`FRAME_DRAG_NAMES`). Without it, the thesis's model, and a check that notes when
        the samples carry frame drag that biases it (:attr:`AeroFit.frame_drag_check`).
    where : str
        The caller, for messages.

    Returns
    -------
    AeroFit

    Raises
    ------
    ValueError
        Naming the source: too few samples, or airflows that do not separate the
        coefficients (e.g. no lateral airspeed, or only one airspeed).
    """
    m = positive_float(mass, "mass", where)
    if not isinstance(data, AeroData) and not (
            isinstance(data, (list, tuple)) and data
            and all(isinstance(x, AeroData) for x in data)):  # an AttributeError before
        raise ValueError(f"The 'data' parameter of {where} must be an AeroData or a non-empty "
                         f"list of them. Got {type(data).__name__} instead.")
    if not isinstance(parasitic, bool | np.bool_):
        raise ValueError(f"The 'parasitic' parameter of {where} must be True or False. Got "
                         f"{parasitic!r} instead.")
    d = data if isinstance(data, AeroData) else AeroData.concatenate(list(data))
    f = d.specific_force_body
    lat_source = (f"{d.source} (columns 'specific_force_x', 'specific_force_y', 'airspeed_x', "
                  "'airspeed_y', 'rotor_speed_*')")
    X_lat, y_lat, names = _lateral_system(d, m, parasitic)
    lat = linear_fit(X_lat, y_lat, names, source=lat_source)
    X_ver, names_ver = _vertical_regressors(d, m), ["k_eta", "k_z", "k_h"]
    if parasitic:
        X_ver = np.column_stack([X_ver, _frame_drag_regressors(d, m)[:, 2]])
        names_ver.append("c_Dz")
    ver = linear_fit(X_ver, f[:, 2], names_ver,
                     source=f"{d.source} (columns 'specific_force_z', 'airspeed_*', "
                            "'rotor_speed_*')")
    _check_signs(lat, ver, d.source)
    frame = check = None
    if parasitic:
        frame = (lat.estimate("c_Dx"), lat.estimate("c_Dy"), ver.estimate("c_Dz"))
    else:
        check = _frame_drag_check(d, m, lat.estimate("k_d"), lat_source)
    return AeroFit(ver.estimate("k_eta"), lat.estimate("k_d"), ver.estimate("k_z"),
                   ver.estimate("k_h"), (lat.estimate("b_x"), lat.estimate("b_y")), lat, ver,
                   m, d, frame, check)


POSITIVE = ("k_eta", "k_d", "k_z", "k_h")
"""The coefficients the physics makes positive (thrust, rotor drag, induced inflow, lift)."""


def _check_signs(lat, ver, source: str) -> None:
    """Refuse a fit whose ``k_eta`` is not positive, or whose ``k_d``, ``k_z`` or ``k_h`` is
    negative beyond its 95 % interval: the samples' sign conventions, not the vehicle (an
    audit's z-down samples fitted k_eta = -4.06e-8 with a tight interval, status 0; the air's
    velocity given for the airspeed fitted k_d = -5.08e-6; a dead accelerometer z, k_eta = 0)."""
    for name in POSITIVE:
        e = (lat if name == "k_d" else ver).estimate(name)
        if (name == "k_eta" and not e.value > 0) or e.ci95[1] < 0:
            raise ValueError(
                f"The samples of {source} fit {name} = {e.value:.4g} (95 % interval "
                f"[{e.ci95[0]:.4g}, {e.ci95[1]:.4g}]), where the physics makes it positive: "
                "check their conventions (body frame x forward, y left, z up, as FLU: a "
                "z-down (FRD) frame must be converted; 'airspeed_*' is the vehicle's velocity "
                "relative to the air, the opposite of the wind's; 'specific_force_*' is the "
                "accelerometer's reading, about +9.81 m/s^2 along z in hover) and that the "
                "columns carry a signal.")


def _frame_drag_check(d: AeroData, m: float, k_d: Estimate, source: str) -> dict | None:
    """The lateral equations fitted with frame drag, beside the thesis model's ``k_d``
    (:attr:`AeroFit.frame_drag_check`); None where the samples cannot separate the drag."""
    X, y, names = _lateral_system(d, m, True)
    try:
        fit = linear_fit(X, y, names, source=source)
    except ValueError:  # too few samples, or airflows that do not separate it
        return None
    c = [fit.estimate(n) for n in ("c_Dx", "c_Dy")]
    k_d2 = fit.estimate("k_d")
    there = all(e.ci95[0] > 0 for e in c)
    moved = not (k_d.ci95[0] <= k_d2.value <= k_d.ci95[1])
    return {"c_Dx": c[0].to_dict(), "c_Dy": c[1].to_dict(), "k_d": k_d2.to_dict(),
            "significant": bool(there and moved)}
