"""Trial (2026-12-06, not an option of the package): how far the d4-film's two folds disagree
across a sector boundary, and what blending them near it gains, on the held-out district.

The d4-film folds the inlet direction into [0, 45] deg by one of the square's eight symmetries;
on either side of a multiple of 45 deg a different symmetry folds it (docs/decoder.md,
"Limits"). This script

1. measures the jump: the mean over cells and samples of |field(b + e) - field(b - e)| for
   inlets at b = 0, 45, 90 deg turned by e either way, 6 m/s, W_robot = 0.8 W_up, at 1,000
   robots of the dense 1.2 km map of seed 0 (noisy 100 m scans, robots more than 1 m from a
   wall);
2. scores, on the default recipe's held-out district (holdout-0; the 16 inlets of
   benchmarks/decoder_views.py's two runs, seeds 1 and 2), a blend of the two folds within
   ``d`` deg of a boundary: at signed distance ``s`` from it, ``(1 - w) own + w other`` with
   ``w = (1 - |s| / d) / 2`` (continuous across the boundary; the "other" fold is the network
   evaluated through the symmetry of the boundary's other side, which puts the canonical inlet
   up to ``d`` deg outside [0, 45]), beside the one pass and the turned views (0, +-3 deg).

The other fold is reached by replacing ``windnav.predict.decoder.canonical_elements`` for the
call: a trial, not an API.

    .venv/bin/python docs/data/decoder_fold_blend.py --out runs/fold_blend --flow-cache runs/flows
        [--model FILE]

``--model``: the decoder (default ``decoder_2026-12-01.npz``, the model the trial ran on and
the committed JSON is of: the shipped file since 2026-12-06 is another model). Writes
``decoder_fold_blend.json`` into ``--out``.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

import windnav.predict.decoder as D
from windnav.predict.baselines import check_inputs

DELTAS_DEG = (1, 2, 3, 5, 8, 12, 22.5)
TRIAL_MODEL = Path(D.__file__).resolve().parent / "data" / "decoder_2026-12-01.npz"
"""The model the trial ran on (the default file from 2026-12-01 to 2026-12-06)."""
METRICS = ("speed_error", "direction_error_deg")


class FoldBlend(D.Decoder):
    """The decoder with its two folds blended within ``delta`` deg of a sector boundary."""

    delta = 5.0

    def predict(self, scans, w_up, w_robot):
        scans, w_up, w_robot = check_inputs(scans, w_up, w_robot, "FoldBlend.predict")
        own = super().predict(scans, w_up, w_robot)
        alpha = np.degrees(np.arctan2(w_up[:, 1], w_up[:, 0]))
        base = 45.0 * np.round(alpha / 45.0)
        s = alpha - base
        near = np.flatnonzero((np.abs(s) < self.delta) & (np.abs(s) >= D.BOUNDARY_TOLERANCE_DEG)
                              & (np.hypot(w_up[:, 0], w_up[:, 1]) > 0))
        if near.size == 0:
            return own
        mirrored = np.radians(base[near] - s[near])
        g_other = D.canonical_elements(np.column_stack([np.cos(mirrored), np.sin(mirrored)]))
        real = D.canonical_elements
        try:
            D.canonical_elements = lambda w: g_other.copy()
            self.arch._upstream_memo = None
            other = self.arch.predict(self.prepared, scans[near].astype(np.float32),
                                      w_up[near], w_robot[near])
        finally:
            D.canonical_elements = real
            self.arch._upstream_memo = None
        other = other.reshape(own[near].shape)
        w = (0.5 * (1.0 - np.abs(s[near]) / self.delta)).astype(np.float32)[:, None, None, None]
        out = own.copy()
        out[near] = (1.0 - w) * own[near] + w * other
        return out


def jump(plain, n: int = 1000, speed: float = 6.0) -> dict:
    """Mean |field(b + e) - field(b - e)| (m/s) per boundary b and half-step e."""
    from windnav.city.generate import dense_map

    city = dense_map(rng=0)
    rng = np.random.default_rng(1)
    x0, x1, y0, y1 = city.bounds
    pts = np.column_stack([rng.uniform(x0 + 50, x1 - 50, 4 * n),
                           rng.uniform(y0 + 50, y1 - 50, 4 * n)])
    scans = city.lidar(pts, noise_std=0.35, rng=rng)
    scans = scans[scans.min(axis=1) > 1.0][:n]
    b = len(scans)
    out = {"samples": b, "speed": speed, "by_boundary": {}}
    for base in (0.0, 45.0, 90.0):
        row = {}
        for e in (0.01, 0.5, 1.0, 2.0):
            fields = []
            for d in (base - e, base + e):
                a = np.radians(d)
                w = speed * np.array([np.cos(a), np.sin(a)])
                fields.append(plain.predict(scans, np.tile(w, (b, 1)), np.tile(0.8 * w, (b, 1))))
            diff = fields[1] - fields[0]
            row[f"{e:g}"] = float(np.hypot(diff[:, 0], diff[:, 1]).mean())
        out["by_boundary"][f"{base:g}"] = row
    return out


def main(argv=None) -> int:
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    import decoder_holdout as dh

    from windnav.predict import load_decoder

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--flow-cache", type=Path, default=None)
    p.add_argument("--model", type=Path, default=TRIAL_MODEL,
                   help="decoder file (default: the model of 2026-12-01, the trial's)")
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    plain = load_decoder(args.model, boundary="average")  # the one pass the trial compares with
    compare = {}
    for d in DELTAS_DEG:
        compare[f"blend{d:g}"] = FoldBlend(plain.weights, plain.metadata)
        compare[f"blend{d:g}"].delta = float(d)
    compare["views3"] = D.Decoder(plain.weights, plain.metadata, rotations_deg=(0, -3, 3))
    records, _, _ = dh.holdout_records(plain, compare, runs=((4, 1), (12, 2)),
                                       flow_cache=args.flow_cache)
    names = ["decoder", *compare]
    per_inlet = [{"direction_deg": r["direction_deg"], "speed": r["speed"],
                  "boundary_distance_deg": float(D.sector_boundary_distance_deg(
                      r["direction_deg"])),
                  **{n: {m: r[n][m] for m in METRICS} for n in names}} for r in records]
    pooled = {n: {m: float(np.mean([r[n][m] for r in records])) for m in METRICS}
              for n in names}
    result = {"model": str(args.model), "jump": jump(plain), "map": dh.views.VALIDATION_MAP,
              "inlets": len(records),
              "per_inlet": per_inlet, "pooled_mean_over_inlets": pooled,
              "elapsed_s": time.perf_counter() - t0}
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "decoder_fold_blend.json").write_text(json.dumps(result, indent=1) + "\n")
    for n in names:
        print(f"{n:>10}: {pooled[n]['speed_error']:.4f} m/s  "
              f"{pooled[n]['direction_error_deg']:.3f} deg")
    print("jump (m/s):", json.dumps(result["jump"]["by_boundary"]))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
