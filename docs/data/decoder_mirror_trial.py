"""Trial (2026-12-06, not an option of the package): the decoder averaged with its answer for
the scene mirrored across the wind's axis, on the held-out district.

Mirroring a scene across the line through the robot along the inlet wind is a symmetry of
the flow (the solver's start kick aside: docs/reliability.md): the mirrored city under the
same inlet has the mirrored mean field. The d4-film sees the mirrored scene at the same
folded inlet angle, through other weights than the scene itself, so its two answers differ
(exactly on a sector boundary, under the "floor" rule, this mirror is the other fold: the fold
trial found them 2.0-2.7 m/s apart at 6 m/s; within 0.25 deg of one the rounded axis is a
mirror of the square, which the d4-film answers exactly, so under the default rule the view is
the one pass there). This trial predicts the mean of the two, as the turned views average
turns:

- the axis: the inlet direction rounded to the nearest half degree ``phi``, so that the
  1-degree scan mirrors exactly: ray ``k`` of the mirrored scan is ray ``2 phi - k``;
- both winds reflected across the axis (``M w``);
- the mirrored scene's field ``u_m`` brought back by ``u(p) = M u_m(M p)``, bilinear on the
  grid, the nearest edge value beyond it (as the turned views turn back).

Scored beside the one pass and the turned views (0, +-3 deg) on the fold trial's 16 inlets of
the held-out district (holdout-0), never on the evaluation maps.

    .venv/bin/python docs/data/decoder_mirror_trial.py --out runs/mirror --flow-cache runs/flows

Writes ``decoder_mirror_trial.json`` into ``--out``.
"""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from pathlib import Path

import numpy as np

import windnav.predict.decoder as D
from windnav.predict.baselines import check_inputs

METRICS = ("speed_error", "direction_error_deg")


class MirrorView(D.Decoder):
    """The decoder's mean with its mirrored scene's answer brought back."""

    def predict(self, scans, w_up, w_robot):
        scans, w_up, w_robot = check_inputs(scans, w_up, w_robot, "MirrorView.predict")
        own = super().predict(scans, w_up, w_robot)
        phi = np.round(2.0 * np.degrees(np.arctan2(w_up[:, 1], w_up[:, 0]))) / 2.0
        out = np.empty_like(own)
        h = self.size
        for value in np.unique(phi):
            rows = np.flatnonzero(phi == value)
            n = int(round(2 * value))
            c, s = math.cos(math.radians(2 * value)), math.sin(math.radians(2 * value))
            m = np.array([[c, s], [s, -c]])
            rays = (n - np.arange(scans.shape[1])) % scans.shape[1]
            mirrored = super().predict(scans[rows][:, rays], w_up[rows] @ m.T,
                                       w_robot[rows] @ m.T)
            p = D.linear_resampler(self.offsets, m)  # f(M p)
            b = rows.size
            at = (p @ mirrored.reshape(b * 2, h * h).T.astype(np.float64)).T.reshape(b, 2, h, h)
            back = np.einsum("ij,bjyx->biyx", m, at)
            out[rows] = 0.5 * (own[rows] + back)
        return out


TRIAL_MODEL = (Path(__file__).resolve().parents[2] / "src" / "windnav" / "predict" / "data"
               / "decoder_2026-12-01.npz")
"""The model the trial ran on."""


def main(argv=None) -> int:
    sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "benchmarks"))
    import decoder_holdout as dh

    from windnav.experiments.decoder_eval import improvement_interval
    from windnav.predict import load_decoder

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--out", type=Path, required=True)
    p.add_argument("--flow-cache", type=Path, default=None)
    args = p.parse_args(argv)
    t0 = time.perf_counter()
    # the one pass of the model the trial ran on (the default file from 2026-12-01 to
    # 2026-12-06; the shipped file since is another model)
    plain = load_decoder(TRIAL_MODEL, boundary="average")
    compare = {"mirror": MirrorView(plain.weights, plain.metadata),
               "views3": D.Decoder(plain.weights, plain.metadata, rotations_deg=(0, -3, 3))}
    records, _, _ = dh.holdout_records(plain, compare, flow_cache=args.flow_cache)
    names = ["decoder", *compare, "local"]
    pooled = {n: {m: dh.pooled_error(records, n, m) for m in METRICS} for n in names}
    versus = {n: {m: improvement_interval(records, n, "decoder", m) for m in METRICS}
              for n in compare}
    result = {"map": dh.views.VALIDATION_MAP, "inlets": len(records), "pooled": pooled,
              "versus_one_pass": versus,
              "per_inlet": [{"direction_deg": r["direction_deg"], "speed": r["speed"],
                             **{n: {m: r[n][m] for m in METRICS} for n in names}}
                            for r in records],
              "elapsed_s": time.perf_counter() - t0}
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "decoder_mirror_trial.json").write_text(json.dumps(result, indent=1) + "\n")
    for n in names:
        extra = "" if n not in versus else "  ".join(
            f"{m}: {versus[n][m]['value']:+.2f} % {versus[n][m]['ci95']}" for m in METRICS)
        print(f"{n:>8}: {pooled[n]['speed_error']:.4f} m/s  "
              f"{pooled[n]['direction_error_deg']:.3f} deg  {extra}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
