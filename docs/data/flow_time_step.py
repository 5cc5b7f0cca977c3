"""How much the mean flow depends on the time step at a fixed physical time (flow_validation.md,
"The time step"). Writes the JSON named on the command line; under a minute on one core.

    .venv/bin/python docs/data/flow_time_step.py docs/data/flow_time_step.json

Two protocols on one 200 m training map (seed 3, inlet toward +x, 1 m cells, default closure):
- 5 m/s, 100 s of spin-up and 200 s of averaging, at dt = 0.25, 0.125 and 0.0625 s, and at
  dt = 0.25 s with another start kick (``symmetry_break`` 0.06 instead of 0.05): how far the
  start moves the mean, for scale;
- 6 m/s, the decoder recipe's protocol (100 + 200 steps at dt = 1/6 s: 16.7 s + 33.3 s) against
  the same physical times at dt = 0.25 s (the navigation benchmark's step) and 1/12 s.
- the numerical viscosity of the MacCormack scheme against the CFL number: the energy decay
  exp(-4 nu t) of the Taylor-Green vortex in a free-slip box [0, pi]^2 of 64 cells over 2 s,
  inviscid, at CFL 0.25 and 2.5 (as ``flow-validate``'s check at CFL 0.5);
- 5 and 10 m/s at dt = 0.25 s, 25 + 100 s: the closure's eddy viscosity diffused as now (at
  most 3 substeps, the corner faces beyond that updated point-implicitly, which applies
  nu / (1 + s) there) against as many explicit substeps as the corners need.
Differences are over the free cells, in units of the inlet speed U: the mean and RMS of the
vector difference of the two means, and its 95th percentile; and the mean angle between the two
means where the reference is faster than U / 2.
"""

import json
import sys
import time

import numpy as np

import windnav as wn
from windnav.experiments.flow_validation import taylor_green_field
from windnav.flow import advection


def _mean_flow(city, speed, dt, spinup_s, average_s, symmetry_break=0.05):
    return wn.flow.simulate(city, speed=speed, direction_deg=0.0, dx=1.0, dt=dt,
                            spinup_steps=int(round(spinup_s / dt)),
                            steps=int(round(average_s / dt)), symmetry_break=symmetry_break,
                            progress=False)


def _taylor_green_nu(cfl, n=64, duration=2.0):
    """The MacCormack scheme's numerical viscosity, m^2/s, at ``cfl`` (the vortex's peak
    speed is 1 m/s)."""
    dx = np.pi / n
    grid = wn.flow.MACGrid((n, n), dx)
    box = wn.flow.make_domain(grid, np.zeros((n, n), bool),
                              wn.flow.BoundaryConditions(("wall",) * 4))
    steps = int(round(duration / (cfl * dx)))
    dt = duration / steps
    step = wn.flow.make_flow_step(box, dt, wn.flow.make_advection(box, dt, "maccormack"))
    u, v = step.project(*taylor_green_field(grid))
    energy = []
    for _ in range(steps + 1):
        energy.append(np.sum(u**2) + np.sum(v**2))
        u, v = step(u, v)
    return float(-np.polyfit(dt * np.arange(steps + 1), np.log(energy), 1)[0] / 4.0)


def _without_limiter(city, speed):
    """The same run with up to 64 explicit diffusion substeps (``Advection.max_substeps`` set
    before the first step), so that no corner face is updated point-implicitly."""
    init = advection.Advection.__init__

    def uncapped(self, *args, **kwargs):
        init(self, *args, **kwargs)
        self.max_substeps = 64

    advection.Advection.__init__ = uncapped
    try:
        return _mean_flow(city, speed, 0.25, 25.0, 100.0)
    finally:
        advection.Advection.__init__ = init


def _difference(a, b, speed):
    free = ~a.solid
    d = np.hypot(a.mean_u - b.mean_u, a.mean_v - b.mean_v)[free] / speed
    fast = free & (np.hypot(b.mean_u, b.mean_v) > 0.5 * speed)
    turn = np.angle(np.exp(1j * (np.arctan2(a.mean_v, a.mean_u) - np.arctan2(b.mean_v, b.mean_u))))
    return {"mean_over_U": float(d.mean()), "rms_over_U": float(np.sqrt((d**2).mean())),
            "p95_over_U": float(np.percentile(d, 95)),
            "mean_angle_deg_where_faster_than_half_U": float(np.degrees(np.abs(turn[fast])).mean())}


def main(path):
    t0 = time.perf_counter()
    city = wn.city.training_map(rng=3, size=200.0)
    out = {"command": "python docs/data/flow_time_step.py " + path, "map": "training_map(rng=3, "
           "size=200)", "dx_m": 1.0}
    runs = {dt: _mean_flow(city, 5.0, dt, 100.0, 200.0) for dt in (0.25, 0.125, 0.0625)}
    kicked = _mean_flow(city, 5.0, 0.25, 100.0, 200.0, symmetry_break=0.06)
    out["5_m_s"] = {
        "dt_0.125_vs_0.25": _difference(runs[0.125], runs[0.25], 5.0),
        "dt_0.0625_vs_0.125": _difference(runs[0.0625], runs[0.125], 5.0),
        "start_kick_0.06_vs_0.05_at_dt_0.25": _difference(kicked, runs[0.25], 5.0),
        "half_window_difference": {str(dt): float(s.half_window_difference)
                                   for dt, s in runs.items()},
    }
    recipe = {dt: _mean_flow(city, 6.0, dt, 100.0 / 6.0, 200.0 / 6.0)
              for dt in (1.0 / 6.0, 0.25, 1.0 / 12.0)}
    out["6_m_s_decoder_protocol"] = {
        "dt_0.25_vs_1/6": _difference(recipe[0.25], recipe[1.0 / 6.0], 6.0),
        "dt_1/12_vs_1/6": _difference(recipe[1.0 / 12.0], recipe[1.0 / 6.0], 6.0),
    }
    out["maccormack_numerical_viscosity_m2_s"] = {f"cfl_{cfl:g}": _taylor_green_nu(cfl)
                                                  for cfl in (0.25, 2.5)}
    out["corner_limiter"] = {
        f"{speed:g}_m_s": _difference(_without_limiter(city, speed),
                                      _mean_flow(city, speed, 0.25, 25.0, 100.0), speed)
        for speed in (5.0, 10.0)}
    out["elapsed_s"] = round(time.perf_counter() - t0, 1)
    with open(path, "w") as f:
        json.dump(out, f, indent=1)
    print(json.dumps(out, indent=1))


if __name__ == "__main__":
    main(sys.argv[1])
