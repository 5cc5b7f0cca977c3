"""Grid refinement of the time-averaged flow (the product), not of St (flow_validation.md).

One 16 m block (``single``: s / 8 = 2 m, the coarsest resolution the validation accepts) and
two side by side with an 8 m street between them (``pair``), on a 160 x 80 m map at 5 m/s
toward +x, solved at dx = 2, 1 and 0.5 m, (a) with dt = dx / 8 (a fixed CFL number of 0.625)
and (b) at the protocol's fixed dt = 0.25 s, both over 50 s of spin-up and 250 s of averaging.
The fields are compared on the common 2 m grid (block means; every edge lies on a 2 m line):
the RMS and 95th percentile over the free cells of |difference| / U against the 0.5 m field,
and the mean speed over the free cells.

    python docs/data/flow_grid_mean.py docs/data/flow_grid_mean.json    # about 1 minute
"""

from __future__ import annotations

import json
import sys
import warnings

import numpy as np

import windnav as wn

U = 5.0
CITIES = {
    "single": wn.city.City(bounds=(0, 160, 0, 80), footprints=[[40, 56, 32, 48]],
                           heights=[20]),
    "pair": wn.city.City(bounds=(0, 160, 0, 80),
                         footprints=[[40, 56, 20, 36], [40, 56, 44, 60]], heights=[20, 20]),
}
PROTOCOLS = {"cfl_0.625": lambda dx: 0.125 * dx, "dt_0.25": lambda dx: 0.25}


def coarse(sol, c=2.0):
    """The mean wind and the solid mask on the 2 m grid (block means)."""
    k = int(round(c / sol.dx))
    ny, nx = sol.mean_u.shape

    def red(a):
        return a.reshape(ny // k, k, nx // k, k).mean(axis=(1, 3))

    solid = red(sol.solid.astype(float)) > 0
    return (red(np.where(sol.solid, 0, sol.mean_u)), red(np.where(sol.solid, 0, sol.mean_v)),
            ~solid)


def solve(city, dx, dt):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the young-mean and jet notes: recorded below
        sol = wn.flow.simulate(city, speed=U, direction_deg=0.0, dx=dx, dt=dt,
                               spinup_steps=int(round(50.0 / dt)),
                               steps=int(round(250.0 / dt)))
    return sol, coarse(sol)


def main(path) -> None:
    out = {}
    for geom, city in CITIES.items():
        for name, rule in PROTOCOLS.items():
            runs = [(dx, *solve(city, dx, rule(dx))) for dx in (2.0, 1.0, 0.5)]
            _, _, (uf, vf, ff) = runs[-1]
            rows = []
            for dx, sol, (u, v, f) in runs:
                both = f & ff
                d = np.hypot(u - uf, v - vf)[both] / U
                rows.append({"dx": dx, "dt": rule(dx), "cfl": U * rule(dx) / dx,
                             "mean_speed_free": float(np.hypot(u, v)[f].mean()),
                             "rms_vs_finest": float(np.sqrt(np.mean(d ** 2))),
                             "p95_vs_finest": float(np.percentile(d, 95)),
                             "half_window_difference": float(sol.half_window_difference),
                             "verdict": wn.flow.averaging_verdict(sol)["level"]})
                print(geom, name, {k: (round(x, 4) if isinstance(x, float) else x)
                                   for k, x in rows[-1].items()}, flush=True)
            out[f"{geom}/{name}"] = rows
    with open(path, "w") as fh:
        json.dump(out, fh, indent=1)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else "flow_grid_mean.json")
