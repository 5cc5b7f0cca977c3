"""``windnav power-curve``: steady-flight power versus airspeed, swept in the simulator."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np


def register(sub) -> None:
    from windnav.vehicle.params import VEHICLES

    p = sub.add_parser("power-curve", help="sweep steady-flight power versus airspeed",
                       description="Sweep steady level flights (hover in a uniform wind) in the "
                                   "simulator, fit P(airspeed), and report the best speeds.")
    p.add_argument("--vehicle", default="hummingbird", choices=VEHICLES)
    p.add_argument("--max-speed", type=float, default=12.0, help="largest airspeed, m/s")
    p.add_argument("--points", type=int, default=21, help="airspeeds in the sweep")
    p.add_argument("--degree", type=int, default=4, help="degree of the fitted polynomial")
    p.add_argument("--out", type=Path, default=Path("out/power_curve"))
    p.set_defaults(func=run)


def run(args) -> int:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    import windnav as wn
    from windnav.sim.sweeps import simulated_power_curve
    from windnav.vehicle.power import PowerCurve, max_endurance_speed, max_range_speed

    params = wn.vehicle.params(args.vehicle)
    curve, sweep = simulated_power_curve(params, args.max_speed, args.points, args.degree)
    thesis = PowerCurve.crazyflie()
    winds = (-3.0, 0.0, 3.0)
    result = {
        "vehicle": args.vehicle,
        "speeds_m_s": sweep["speeds"].tolist(),
        "power_W": sweep["power"].tolist(),
        "tilt_deg": sweep["pitch_deg"].tolist(),
        "saturated_fraction": sweep["saturated"].tolist(),
        "fit_coefficients": curve.coefficients.tolist(),
        "max_endurance_speed_m_s": max_endurance_speed(curve),
        "max_range": {f"{w:+.0f} m/s along track": max_range_speed(curve, w)._asdict()
                      for w in winds},
        "thesis_crazyflie": {
            "coefficients": thesis.coefficients.tolist(),
            "max_endurance_speed_m_s": max_endurance_speed(thesis),
            "max_range_speed_m_s": max_range_speed(thesis, 0.0).ground_speed,
        },
    }
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "power_curve.json").write_text(json.dumps(result, indent=2) + "\n")

    fig, axes = plt.subplots(1, 2, figsize=(11, 4.2))
    v = np.linspace(0, args.max_speed, 200)
    axes[0].plot(sweep["speeds"], sweep["power"], "o", label="simulated steady flight")
    axes[0].plot(v, curve(v), "-", label=f"degree-{args.degree} fit")
    axes[0].set_title(f"{args.vehicle}: rotor power vs airspeed")
    vt = np.linspace(0, 10, 200)
    axes[1].plot(vt, thesis(vt), "-", color="tab:green", label="thesis Crazyflie curve")
    vr = max_range_speed(thesis, 0.0)
    axes[1].plot([0, vr.ground_speed], [0, vr.power], "k--", lw=0.8,
                 label=f"max range {vr.ground_speed:.2f} m/s")
    axes[1].set_ylim(0, thesis(vt).max() * 1.1)
    axes[1].set_title("thesis Crazyflie curve")
    for ax in axes:
        ax.set_xlabel("airspeed (m/s)")
        ax.set_ylabel("power (W)")
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.out / "power_curve.png", dpi=110)
    plt.close(fig)
    print(json.dumps({k: result[k] for k in ("vehicle", "max_endurance_speed_m_s", "max_range")},
                     indent=2))
    print(f"wrote {args.out / 'power_curve.json'}\nwrote {args.out / 'power_curve.png'}")
    return 0
