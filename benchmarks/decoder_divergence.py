"""Is the decoder's error a divergence it could be projected out of? (windinet, 2D continuity)

The labels are means of a 2D incompressible flow, so they satisfy continuity, du/dx + dv/dy =
0, wherever the air is free. The decoder's fields need not. This benchmark measures both
fields' divergence on the label grid and scores the decoder with its field smoothed towards
divergence-free fields, against the decoder itself on the same samples (the reference):

- ``global mu``: the field ``x`` replaced by ``argmin |y - x|^2 + mu |D y|^2``, a fixed linear
  filter on the whole window (buildings not known to it), so it could be folded into the
  decoder's output basis at no inference cost;
- ``masked mu``: the same with ``D`` kept to the blocks of four free cells of each sample's
  true building mask (an oracle of the geometry, per-sample sparse solves).

``D`` is the divergence at the centre of each 2 x 2 block of cells (the mean of the two
differences across it). The divergence is reported as the RMS over the blocks of four free
cells, in units of the inlet speed per cell (``U / spacing``).

    .venv/bin/python benchmarks/decoder_divergence.py --out runs/divergence \
        [--model FILE] [--inlets 8] [--samples 2048] [--flow-cache runs/flows] [--record]

The flows and samples are ``windnav evaluate-decoder``'s windinet slots (seed 0, ``--inlets``
as there), so the reference row equals that command's windinet row for the same ``--inlets``
and samples. Writes ``decoder_divergence.json`` into ``--out``; ``--record`` appends the
table to docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np

GLOBAL_MU = (1.0, 10.0, 100.0)
MASKED_MU = (10.0, 1000.0)
METRICS = ("speed_error", "direction_error_deg", "vector_error")


def block_divergence(size: int, spacing: float = 1.0):
    """The divergence at each 2 x 2 block's centre of a field ``[u cells, v cells]`` (cells
    ``[iy, ix]``, ``size`` per side): a sparse ``((size - 1)^2, 2 size^2)`` matrix, 1/m."""
    import scipy.sparse as sp

    iy, ix = np.meshgrid(np.arange(size - 1), np.arange(size - 1), indexing="ij")
    row = (iy * (size - 1) + ix).ravel()

    def cell(c, y, x):  # the flat index of component c at cells (y, x)
        return (c * size * size + y * size + x).ravel()

    h = 0.5 / spacing
    terms = [(cell(0, iy, ix + 1), h), (cell(0, iy + 1, ix + 1), h), (cell(0, iy, ix), -h),
             (cell(0, iy + 1, ix), -h), (cell(1, iy + 1, ix), h), (cell(1, iy + 1, ix + 1), h),
             (cell(1, iy, ix), -h), (cell(1, iy, ix + 1), -h)]
    rows = np.concatenate([row] * len(terms))
    cols = np.concatenate([c for c, _ in terms])
    vals = np.concatenate([np.full(row.size, v) for _, v in terms])
    return sp.csr_matrix((vals, (rows, cols)), shape=((size - 1) ** 2, 2 * size * size))


def free_blocks(free: np.ndarray) -> np.ndarray:
    """``(B, (H - 1)^2)`` bool: the 2 x 2 blocks whose four cells are free."""
    return (free[:, :-1, :-1] & free[:, 1:, :-1] & free[:, :-1, 1:]
            & free[:, 1:, 1:]).reshape(free.shape[0], -1)


def divergence_rms(fields: np.ndarray, blocks: np.ndarray, inlet_speed: np.ndarray, div,
                   spacing: float) -> float:
    """RMS of the divergence over the counted blocks, in units of ``U / spacing``."""
    d = np.asarray(div @ fields.reshape(fields.shape[0], -1).astype(np.float64).T).T
    d *= spacing / inlet_speed[:, None]
    return float(np.sqrt(np.mean(d[blocks] ** 2)))


def global_filter(div, mu: float) -> np.ndarray:
    """The dense matrix ``(I + mu D^T D)^-1``, applied to a flattened field."""
    dd = div.toarray()
    return np.linalg.inv(np.eye(dd.shape[1]) + mu * dd.T @ dd)


def masked_projection(fields: np.ndarray, blocks: np.ndarray, div, mu: float) -> np.ndarray:
    """Each field smoothed with ``D`` kept to its own free blocks (one sparse solve each)."""
    import scipy.sparse as sp
    import scipy.sparse.linalg as spla

    flat = fields.reshape(fields.shape[0], -1).astype(np.float64)
    eye = sp.identity(flat.shape[1], format="csc")
    out = np.empty_like(flat)
    for s in range(flat.shape[0]):
        d = div[blocks[s]]
        out[s] = spla.spsolve((eye + mu * (d.T @ d)).tocsc(), flat[s])
    return out.reshape(fields.shape).astype(np.float32)


def run(model=None, *, n_inlets: int = 8, samples: int = 2048, flow_cache=None,
        progress: bool = True) -> dict:
    """Score the decoder and its divergence-smoothed fields on windinet's evaluation slots."""
    from windnav.city import read_rotorpy_json
    from windnav.experiments.decoder_eval import slot_rng, windinet_layout
    from windnav.experiments.decoder_studies import evaluation_fields
    from windnav.predict import draw_samples, field_errors, load_decoder, pooled_errors

    t0 = time.perf_counter()
    dec = load_decoder(model)
    # the flows of evaluate-decoder's windinet slots (its cache entries), as the studies get them
    flows = evaluation_fields([("windinet", read_rotorpy_json(windinet_layout()))], n_inlets,
                              seed=0, cache_dir=flow_cache, progress=progress)
    div = block_divergence(dec.size, dec.spacing)
    filters = {f"global mu={mu:g}": global_filter(div, mu) for mu in GLOBAL_MU}
    per_sample, sq, n_blocks = {}, {}, 0  # sq: each arm's sum of squared divergences
    for field, slot in zip(flows["fields"], flows["slots"], strict=True):
        # evaluate-decoder's samples of the slot, so the decoder's row is its windinet row
        b = draw_samples(field, samples, rng=slot_rng(0, 0, slot["inlet"]), size=dec.size,
                         spacing=dec.spacing, scan_noise=0.35, w_robot_noise=0.0)
        pred = dec.predict(b.scans, b.w_up, b.w_robot)
        blocks = free_blocks(b.free)
        n_blocks += int(blocks.sum())
        arms = {"truth": b.labels, "decoder": pred}
        flat = pred.reshape(pred.shape[0], -1).astype(np.float64)
        for arm, f in filters.items():
            arms[arm] = (flat @ f.T).reshape(pred.shape).astype(np.float32)
        for mu in MASKED_MU:
            arms[f"masked mu={mu:g}"] = masked_projection(pred, blocks, div, mu)
        for arm, fields in arms.items():
            rms = divergence_rms(fields, blocks, b.inlet_speed, div, dec.spacing)
            sq[arm] = sq.get(arm, 0.0) + rms ** 2 * int(blocks.sum())
            if arm == "truth":
                continue
            e = field_errors(fields, b.labels, b.free, b.inlet_speed, per_sample=True)
            per_sample.setdefault(arm, []).append(e["per_sample"])
        if progress:
            print(f"windinet inlet {slot['inlet']}: {slot['speed']:.2f} m/s "
                  f"{slot['direction_deg']:.0f} deg scored ({time.perf_counter() - t0:.0f} s)",
                  file=sys.stderr, flush=True)
    rows = {}
    for arm, parts in per_sample.items():
        joined = {k: np.concatenate([p[k] for p in parts]) for k in parts[0]}
        e = pooled_errors(joined)
        rows[arm] = {**{m: float(e[m]) for m in METRICS},
                     "divergence_rms": float(np.sqrt(sq[arm] / n_blocks))}
    ref = rows["decoder"]
    for r in rows.values():
        r["change_pct"] = {m: 100.0 * (r[m] / ref[m] - 1.0) for m in METRICS}
    return {"model": str(model) if model is not None else "default", "boundary": dec.boundary,
            "map": "windinet", "inlets": [{k: slot[k] for k in ("speed", "direction_deg")}
                                          for slot in flows["slots"]],
            "failed": flows["failed"], "samples": samples * len(flows["fields"]),
            "truth_divergence_rms": float(np.sqrt(sq["truth"] / n_blocks)),
            "arms": rows, "elapsed_s": time.perf_counter() - t0}


def table(res: dict) -> list[str]:
    """The Markdown table of a :func:`run` result."""
    lines = [f"Windinet layout, {len(res['inlets'])} evaluation inlets (seed 0), "
             f"{res['samples']:,} samples; model {res['model']} ({res['boundary']} rule). "
             "Divergence: RMS over the blocks of four free cells, in U per cell; the "
             f"truth's is {res['truth_divergence_rms']:.2e}.", "",
             "| field | divergence (U / cell) | speed error (m/s) | direction error (deg) "
             "| vector error (m/s) | change against the decoder (speed / direction) |",
             "|---|---|---|---|---|---|"]
    for arm, r in res["arms"].items():
        c = r["change_pct"]
        lines.append(f"| {arm} | {r['divergence_rms']:.2e} | {r['speed_error']:.4f} | "
                     f"{r['direction_error_deg']:.3f} | {r['vector_error']:.4f} | "
                     f"{c['speed_error']:+.2f} % / {c['direction_error_deg']:+.2f} % |")
    return lines


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--out", type=Path, required=True, metavar="DIR", help="output folder")
    ap.add_argument("--model", type=Path, default=None, help="decoder file (default: shipped)")
    ap.add_argument("--inlets", type=int, default=8, help="windinet inlets (default 8)")
    ap.add_argument("--samples", type=int, default=2048, help="samples per inlet (default 2048)")
    ap.add_argument("--flow-cache", type=Path, default=None, metavar="DIR",
                    help="keep and reuse the flows here (shared with evaluate-decoder)")
    ap.add_argument("--no-progress", action="store_true", help="hide the per-inlet lines")
    ap.add_argument("--record", action="store_true", help="append to docs/benchmarks.md")
    args = ap.parse_args(argv)
    if args.inlets < 1 or args.samples < 1:
        ap.error("--inlets and --samples must be >= 1")
    res = run(args.model, n_inlets=args.inlets, samples=args.samples,
              flow_cache=args.flow_cache, progress=not args.no_progress)
    lines = table(res)
    print("\n".join(lines))
    res["command"] = "python benchmarks/decoder_divergence.py " + " ".join(
        sys.argv[1:] if argv is None else argv)
    args.out.mkdir(parents=True, exist_ok=True)
    (args.out / "decoder_divergence.json").write_text(json.dumps(res, indent=1) + "\n")
    print(f"wrote {args.out / 'decoder_divergence.json'}", file=sys.stderr)
    if args.record:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from _record import append_record

        append_record("Decoder: divergence-free smoothing of its field (windinet)", lines,
                      command=res["command"])
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
