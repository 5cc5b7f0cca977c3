"""The UKF story of ``windnav demo --story ukf``: city -> urban wind -> route -> flight -> Wind UKF.

(The default story, MPPI against EA-MPPI+W, is :mod:`windnav.experiments.nav_demo`.)

1. A random training city (300 m, 5-10 buildings) from a seed.
2. Its 2D wind from the flow solver (unsteady frames, flown as a time-varying field).
3. A collision-free route across the map by graph search (the global baseline planner).
4. The Hummingbird flies the route with the SE(3) controller at 100 Hz, IMU / odometry /
   rotor-speed sensors at 100 Hz, sampling the wind at every rotor hub.
5. The Wind UKF estimates the wind from the logged sensors; its error is scored against the
   true wind at the centre of mass.

The metrics say where the flight left the vehicle model's envelope: ``status`` (``OK`` or the
:class:`~windnav.sim.log.FlightStatus` flags), ``outside_envelope_fraction`` (of the logged
samples: airspeed above the vehicle's trusted ``airspeed_limit_m_s``, or translational lift
above its stated fraction of a rotor's thrust) and ``airspeed_max_m_s`` (the largest airspeed
at the centre of mass).

``DemoConfig.conditions`` (a Wind UKF preset, :data:`windnav.estimate.CONDITIONS`; default
None: windnav's sensors and the filter's defaults) gives the vehicle that preset's sensors and
runs the filter under it (:func:`windnav.experiments.ukf_conditions.estimate_wind`, from the
true parameters: the demo flies no calibration).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from windnav._validate import nonnegative_int, positive_float
from windnav.city.generate import training_map
from windnav.estimate.conditions import ukf_conditions
from windnav.estimate.flight import run_wind_ukf
from windnav.experiments.flight import tracking_rms
from windnav.experiments.ukf_conditions import estimate_wind
from windnav.flow import simulate
from windnav.plan.graph_search import free_space, grid_route
from windnav.sensors.models import IMU, Odometry, RotorSpeedSensor, SensorSuite
from windnav.sim.runner import fly
from windnav.sim.trajectories import Waypoints
from windnav.vehicle.params import VEHICLES
from windnav.vehicle.params import params as vehicle_params
from windnav.wind.gridded import GriddedWind

DEFAULT_FLOW_DT = 0.2
"""Flow time step of the demo at moderate inlet speeds, s."""
AUTO_CFL = 1.0
"""CFL number ``speed * flow_dt / dx`` that :func:`auto_flow_dt` keeps to (the solver allows
2.5)."""


def auto_flow_dt(wind_speed: float, dx: float = 2.0) -> float:
    """The flow time step for an inlet of ``wind_speed`` m/s on cells of ``dx`` m: 0.2 s, or
    less to keep the CFL number at or below 1, s."""
    # wind_speed=-5 gave a flow step of -0.4 s (API audit)
    wind_speed = positive_float(wind_speed, "wind_speed", "auto_flow_dt")
    dx = positive_float(dx, "dx", "auto_flow_dt")
    return min(DEFAULT_FLOW_DT, AUTO_CFL * dx / wind_speed)


@dataclass(frozen=True)
class DemoConfig:
    """Settings of :func:`run_demo` (SI units).

    ``flow_dt`` must keep the flow solver's CFL number ``wind_speed * flow_dt / dx`` at or
    below 2.5 (:func:`auto_flow_dt` picks one that does).
    """

    seed: int = 0
    vehicle: str = "hummingbird"
    map_size: float = 300.0
    wind_speed: float = 5.0
    dx: float = 2.0
    flow_dt: float = 0.2
    spinup_s: float = 60.0
    cruise_speed: float = 3.0
    altitude: float = 10.0
    clearance: float = 8.0
    sim_dt: float = 0.01
    settle_s: float = 2.0
    conditions: str | None = None

    def __post_init__(self):
        from windnav.estimate.conditions import CONDITIONS
        from windnav.flow.solver import MAX_CFL

        where = "DemoConfig"
        # seed=-1 and vehicle="foo" were accepted, to fail inside run_demo (API audit)
        nonnegative_int(self.seed, "seed", where)
        if not isinstance(self.vehicle, str) or self.vehicle not in VEHICLES:
            raise ValueError(f"The 'vehicle' parameter of {where} must be one of "
                             f"{list(VEHICLES)}. Got {self.vehicle!r} instead.")
        if self.conditions is not None and self.conditions not in CONDITIONS:
            raise ValueError(f"The 'conditions' parameter of {where} must be None or one of "
                             f"{sorted(CONDITIONS)}. Got {self.conditions!r} instead.")
        for name in ("map_size", "wind_speed", "dx", "flow_dt", "cruise_speed", "altitude",
                     "sim_dt"):
            positive_float(getattr(self, name), name, where)
        for name in ("spinup_s", "clearance", "settle_s"):
            positive_float(getattr(self, name), name, where, allow_zero=True)
        cfl = self.wind_speed * self.flow_dt / self.dx
        if cfl > MAX_CFL:
            raise ValueError(
                f"The 'flow_dt' parameter of {where} gives a CFL number wind_speed*flow_dt/dx "
                f"= {cfl:.3g} above {MAX_CFL:g}; use flow_dt <= "
                f"{MAX_CFL * self.dx / self.wind_speed:.4g} s. Got {self.flow_dt!r} instead.")


def _free_point(city, rng, x: float, cfg: DemoConfig) -> np.ndarray:
    """A point at abscissa ``x`` (middle half of the map in y) clear of every building."""
    x_c, y_c, free = free_space(city, cfg.dx, cfg.clearance + cfg.dx)
    i = int(np.argmin(np.abs(x_c - x)))
    lo, hi = 0.25 * cfg.map_size, 0.75 * cfg.map_size
    rows = np.flatnonzero(free[:, i] & (y_c >= lo) & (y_c <= hi))
    if rows.size == 0:
        rows = np.flatnonzero(free[:, i])
    return np.array([x_c[i], y_c[rng.choice(rows)]])


def run_demo(cfg: DemoConfig = DemoConfig(), *, progress: bool = False) -> dict:
    """Run the pipeline; returns every intermediate product plus timings (s) and metrics."""
    if not isinstance(cfg, DemoConfig):  # a dict raised AttributeError (API audit)
        raise ValueError(f"The 'cfg' parameter of run_demo must be a DemoConfig. Got "
                         f"{cfg!r} instead.")
    rng = np.random.default_rng(cfg.seed)
    timings = {}
    t0 = time.perf_counter()
    city = training_map(rng=rng, size=cfg.map_size, n_buildings=int(rng.integers(5, 11)))
    # the wind blows roughly along the route, which crosses the map from west to east
    direction_deg = float(rng.uniform(-40.0, 40.0))
    start = _free_point(city, rng, 15.0, cfg)
    goal = _free_point(city, rng, cfg.map_size - 15.0, cfg)
    route = grid_route(city, start, goal, dx=cfg.dx, clearance=cfg.clearance)
    timings["route"] = time.perf_counter() - t0

    # long enough to cover the whole flight with recorded frames (2 s apart)
    flight_s = 1.2 * route["length"] / cfg.cruise_speed + 8.0
    steps = int(np.ceil(flight_s / cfg.flow_dt)) + 10
    t0 = time.perf_counter()
    sol = simulate(city, speed=cfg.wind_speed, direction_deg=direction_deg, dx=cfg.dx,
                   dt=cfg.flow_dt, spinup_steps=int(cfg.spinup_s / cfg.flow_dt), steps=steps,
                   record_every=max(1, int(round(2.0 / cfg.flow_dt))), progress=progress)
    timings["flow"] = time.perf_counter() - t0
    wind = GriddedWind(sol.x, sol.y, sol.frames_u, sol.frames_v, t=sol.t - sol.t[0],
                       solid=sol.solid)

    p = vehicle_params(cfg.vehicle)
    wp = np.column_stack([route["waypoints"], np.full(len(route["waypoints"]), cfg.altitude)])
    traj = Waypoints(tuple(map(tuple, wp)), speed=cfg.cruise_speed)
    duration = traj.duration + 5.0
    if cfg.conditions is None:
        sensors = SensorSuite(IMU(rate_hz=100.0), Odometry(rate_hz=100.0),
                              RotorSpeedSensor(rate_hz=100.0))
    else:
        sensors = ukf_conditions(cfg.conditions).sensor_suite(100.0)
    t0 = time.perf_counter()
    log = fly(p, traj, wind, duration, dt=cfg.sim_dt, sensors=sensors, hub_wind=True,
              rng=cfg.seed, progress=progress)
    timings["flight"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    if cfg.conditions is None:
        track = run_wind_ukf(log, p, progress=progress)
    else:
        track, _ = estimate_wind(log, p, cfg.conditions, rng=np.random.default_rng([cfg.seed, 2]),
                                 progress=progress)
    timings["ukf"] = time.perf_counter() - t0

    pos = log.position[:, 0, :2]
    airspeed = np.linalg.norm(log.velocity[:, 0] - log.wind[:, 0], axis=-1)
    solid_hit = wind.is_solid(np.column_stack([pos, np.zeros(len(pos))]))
    rotor_energy = float(log.energy[-1, 0]) if bool(log.finite[0]) else None
    metrics = {
        "seed": cfg.seed,
        "conditions": cfg.conditions,
        # buildings and blocks as the navigation story counts them (it stored the block count
        # as n_buildings, which a map of several-block buildings would overstate; output audit)
        "n_buildings": int(np.unique(city.building_labels()).size),
        "n_blocks": int(city.n_buildings),
        "wind_direction_deg": direction_deg,
        "inlet_speed_m_s": cfg.wind_speed,
        "route_length_m": route["length"],
        "flight_duration_s": duration,
        "mean_wind_speed_along_path_m_s": float(np.linalg.norm(log.wind[:, 0], axis=-1).mean()),
        "max_wind_speed_along_path_m_s": float(np.linalg.norm(log.wind[:, 0], axis=-1).max()),
        "wind_rmse_m_s": track.rmse_after(cfg.settle_s),
        "wind_rmse_axes_m_s": [track.rmse_after(cfg.settle_s, axis=k) for k in range(3)],
        "rms_tracking_error_m": tracking_rms(log, duration),   # after take-off, as fly's
        # none for a diverged flight: the log holds its energy from the step it stopped (as
        # fly); the rotors' energy, under the name navigate gives it, and under the older
        # energy_J, which in the navigation story is the airspeed power curve's (as fly's)
        "rotor_energy_J": rotor_energy,
        "energy_J": rotor_energy,
        "rotor_saturation_fraction": log.saturation_fraction,
        # where the flight left the model's envelope (CLI audit C: --seed 1 spent 24.9 % of
        # its samples above the Hummingbird's trusted 13.45 m/s and the summary said nothing)
        "status": log.meta["status"][0],
        "outside_envelope_fraction": log.envelope_fraction,
        "airspeed_max_m_s": float(airspeed.max()),
        "airspeed_limit_m_s": float(p.airspeed_limit),
        "samples_inside_buildings": int(np.sum(solid_hit)),
        "filter_covariance_repairs": int(track.repairs),
        "timings_s": timings,
    }
    if cfg.conditions is not None:  # what the preset's drag model leaves out, at this flight
        from windnav.experiments.flight import drag_model_note

        metrics["wind_mean_error_m_s"] = [float(e) for e in
                                          track.mean_error_after(cfg.settle_s)]
        metrics.update(drag_model_note(log, p, cfg.conditions, cfg.settle_s))
    return {"config": cfg, "city": city, "solution": sol, "route": route, "log": log,
            "track": track, "metrics": metrics}
