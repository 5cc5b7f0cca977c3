"""The onboard wind stack's step (sensors, Wind UKF, decoder): compiled sampling, A/B.

Run: ``.venv/bin/python benchmarks/bench_onboard.py`` (about 1.5 minutes on one core).

EA-MPPI+Ŵ runs :class:`~windnav.experiments.onboard.OnboardStack` at every control step
(100 Hz): the simulated sensors, the Wind UKF, and every second step the decoder. This flies
one suite flight (``thesis/m04/w08/p1``: 37 s, the suite's wind simulated once, 22-28 s),
records the true state, wind and command the stack met at each step, then replays those
inputs into two stacks, alternating:

* reference: the sensors sampled by the batched models (``IMU.measure``,
  ``Odometry.measure``, ``Rotation.from_quat(...).as_euler``, ``RotorSpeedSensor.measure``
  and ``np.clip``, each drawing from the generator) and the decoder's features made in two
  steps (``centred_min_pool`` then the ring permutation, the inlet wind's features at every
  call): what the stack did before 2026-11-27;
* compiled: what it does now (``sensors._kernels.imu_odometry_sample`` on a block-drawn
  normal stream, SciPy's compiled Euler conversion, one gather for the sectors, the inlet
  wind's features kept through the flight).

It checks both give the same UKF estimate and decoder field at every step, to the bit, prints
the time per control step of each (median of the repetitions) and appends them to
docs/benchmarks.md. The flight is flown under the arithmetic its committed record was flown
under (a new process, when this machine's differs and can run it), and compared with that
record.
"""

from __future__ import annotations

import os

for _var in ("NUMBA_NUM_THREADS", "OMP_NUM_THREADS", "OPENBLAS_NUM_THREADS", "MKL_NUM_THREADS"):
    os.environ[_var] = "1"

import argparse  # noqa: E402
import dataclasses  # noqa: E402
import pickle  # noqa: E402
import statistics  # noqa: E402
import sys  # noqa: E402
import time  # noqa: E402
from pathlib import Path  # noqa: E402

import numpy as np  # noqa: E402
from scipy.spatial.transform import Rotation  # noqa: E402

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _record import append_record, matches_record, under_record_arithmetic  # noqa: E402

from windnav.experiments import nav_benchmark, onboard  # noqa: E402
from windnav.experiments.nav_suite import get_suite, parse_scenario_id  # noqa: E402
from windnav.predict import decoder as dec_mod  # noqa: E402
from windnav.vehicle import layout  # noqa: E402


class ReferenceStack(onboard.OnboardStack):
    """The stack sampling its sensors with the batched models, one call each, from the
    generator itself (the code of the stack before the compiled sampling)."""

    def _measure(self, x, wind_com, cmd_prev):
        self._com[0] = wind_com
        sf = self.model.derivatives_packed(x, self._com, self._hub)["specific_force_body"]
        s, rng = self.sensors, self.sensor_rng
        accel, gyro, _ = s.imu.measure(sf[None], x[None, :, layout.BODY_RATES], rng,
                                       bias0=np.zeros((1, 6)))
        _, vel, att = s.odometry.measure(x[None, :, layout.POSITION],
                                         x[None, :, layout.VELOCITY],
                                         x[None, :, layout.ATTITUDE], rng)
        euler = Rotation.from_quat(att[0, 0]).as_euler("ZYX")
        meas = {"accel": accel[0, 0], "gyro": gyro[0, 0], "odom": np.r_[vel[0, 0], euler]}
        if cmd_prev is not None and self._rotor_measured:
            eta = s.rotor_speeds.measure(np.asarray(cmd_prev)[:1], rng)[0]
            meas["rotor_speeds"] = np.clip(eta, self._rotor_lo, self._rotor_hi)
        return meas, euler


def reference_features(arch, scans, w_up, w_robot) -> dict:
    """d4-film's features the two-step way, everything recomputed at each call."""
    hp = arch.hp
    g = dec_mod.canonical_elements(w_up)
    pooled = dec_mod.centred_min_pool(scans, hp["pool"])
    pooled = np.take_along_axis(pooled, arch._bins[g], axis=1)
    mats = dec_mod._D4[g]
    w_up_c = np.einsum("bij,bj->bi", mats, w_up)
    w_robot_c = np.einsum("bij,bj->bi", mats, w_robot).astype(np.float32)
    winds, scale = dec_mod.wind_features(w_up_c, w_robot_c, hp["speed_floor"])
    return {"g": g, "channels": dec_mod.range_channels(pooled, hp["range_scale"],
                                                       hp["range_min"]),
            "winds": winds, "scale": scale, "w_robot": w_robot_c,
            "w_robot_world": np.asarray(w_robot, dtype=np.float32)}


def capture(scenario_id: str):
    """Fly the scenario with EA-MPPI+Ŵ and return the stack's constructor arguments and the
    inputs of each of its steps, and the flight's record."""
    spec = get_suite("thesis")
    sc = parse_scenario_id(spec, scenario_id)
    city, flow, flow_s = nav_benchmark.group_wind(spec, sc.map_index, sc.wind_index)
    print(f"{scenario_id}: wind simulated in {flow_s:.1f} s", flush=True)
    seen = []
    base = onboard.OnboardStack

    class Recording(base):
        def __init__(self, city, model, params, **kw):
            # the generator as it is before the stack spawns its streams from it
            seen.append({"args": (city, model, params), "kw": dict(kw),
                         "rng": pickle.dumps(kw["rng"]), "steps": []})
            super().__init__(city, model, params, **kw)

        def step(self, k, x, wind_com, cmd_prev):
            seen[-1]["steps"].append((k, x.copy(), np.array(wind_com),
                                      None if cmd_prev is None else np.array(cmd_prev)))
            super().step(k, x, wind_com, cmd_prev)

    onboard.OnboardStack = Recording
    try:
        rec = nav_benchmark.fly_scenario(spec, sc, "ea-mppi-w-hat", city=city, flow=flow)
    finally:
        onboard.OnboardStack = base
    if rec["error"]:
        raise RuntimeError(rec["error"])
    print(f"flown: {rec['outcome']}, {rec['time_s']:.1f} s, {len(seen[0]['steps'])} steps",
          flush=True)
    return seen[0], rec


def replay(cap, cls, decoder):
    """Run a fresh stack of class ``cls`` through the captured steps: (seconds, estimates,
    fields at every decoder step)."""
    kw = dict(cap["kw"])
    kw["rng"], kw["decoder"] = pickle.loads(cap["rng"]), decoder
    # every decode computed at its time, as the hardware would (and as this benchmark measured
    # before the stack skipped the decodes no planner update reads: bench_onboard_decodes.py)
    kw["options"] = dataclasses.replace(kw.get("options") or onboard.OnboardOptions(),
                                        decode_all=True)
    stack = cls(*cap["args"], **kw)
    fields = []
    t0 = time.perf_counter()
    for k, x, w, cmd in cap["steps"]:
        stack.step(k, x, w, cmd)
        if k % stack.decode_every == 0:
            fields.append(stack.field)
    seconds = time.perf_counter() - t0
    return seconds, stack.wind_est[:len(cap["steps"])], np.array(fields)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--scenario", default="thesis/m04/w08/p1",
                    help="the suite flight to capture (default thesis/m04/w08/p1)")
    ap.add_argument("--repeats", type=int, default=5, help="replays of each stack (5)")
    ap.add_argument("--no-record", action="store_true", help="do not append to docs/benchmarks.md")
    args = ap.parse_args(argv)
    committed = under_record_arithmetic(args.scenario, "ea-mppi-w-hat")
    cap, flown = capture(args.scenario)
    matched = matches_record(flown, committed)
    print(matched, flush=True)
    decoder = nav_benchmark.benchmark_decoder()
    arch = decoder.arch
    compiled_features = arch.features
    times = {"reference": [], "compiled": []}
    out = {}
    for _ in range(args.repeats):
        for mode in ("reference", "compiled"):
            arch.features = (compiled_features if mode == "compiled" else
                             (lambda s, u, r: reference_features(arch, s, u, r)))
            arch._upstream_memo = None
            cls = onboard.OnboardStack if mode == "compiled" else ReferenceStack
            seconds, est, fields = replay(cap, cls, decoder)
            times[mode].append(seconds)
            out[mode] = (est, fields)
    del arch.features
    n = len(cap["steps"])
    same_est = np.array_equal(out["reference"][0], out["compiled"][0], equal_nan=True)
    same_fields = np.array_equal(out["reference"][1], out["compiled"][1], equal_nan=True)
    print(f"UKF estimates equal to the bit: {same_est}; decoder fields: {same_fields}")
    if not (same_est and same_fields):
        print("the compiled stack differs from the reference", file=sys.stderr)
        return 1
    ref, new = (1e6 * statistics.median(times[m]) / n for m in ("reference", "compiled"))
    rows = [
        f"- `{args.scenario}` flown with EA-MPPI+Ŵ, its {n} control steps replayed into the "
        f"stack {args.repeats} times each way, alternating; UKF estimate and decoder field "
        "equal to the bit at every step",
        f"- {matched}",
        "",
        "| per control step (UKF 100 Hz, decoder 50 Hz) | reference (batched models, "
        "two-step features) | compiled | ratio |",
        "|---|---|---|---|",
        f"| median of the replays | {ref:.0f} us | {new:.0f} us | {ref / new:.2f}x |",
        "",
        f"- per 100 s of flight: {ref * 1e4 / 1e6:.1f} s against {new * 1e4 / 1e6:.1f} s of one "
        "core",
    ]
    print("\n".join(rows))
    if not args.no_record:
        append_record("Onboard wind stack step: compiled sensor sampling and decoder features "
                      "(bench_onboard.py)", rows)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
