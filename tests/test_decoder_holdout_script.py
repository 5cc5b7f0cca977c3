"""``benchmarks/decoder_holdout.py``: decoders compared on the held-out district at random
inlets. The evaluation itself is ``evaluate_decoder`` (tested elsewhere), stood in for here by
records whose errors are known, so the pooling, the paired comparison and the command line
are checked."""

from __future__ import annotations

import hashlib
import json
import sys
from pathlib import Path

import numpy as np
import pytest

import windnav.experiments.decoder_eval as de

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _scripts import load_script  # noqa: E402
from test_decoder_rotations import tiny  # noqa: E402


def _module():
    return load_script("benchmarks/decoder_holdout.py")


def _slot(speed_err: dict, dir_err: dict, direction_deg: float, cells: int) -> dict:
    rec = {"map": "holdout-0", "group": "dense", "speed": 5.0, "direction_deg": direction_deg,
           "n_samples": 16}
    for name in speed_err:
        rec[name] = {"speed_error": speed_err[name], "direction_error_deg": dir_err[name],
                     "n_free": cells, "n_direction": cells}
    return rec


@pytest.fixture()
def stubbed(tmp_path, monkeypatch):
    """Two decoder files, and evaluate_decoder answering one slot per inlet: the candidate
    10 % better on speed at every inlet, on direction better at the first and worse after;
    inlet i has 1000 (i + 1) cells, and seed 2's run has one failed inlet."""
    paths = {}
    for name, seed in (("ref", 0), ("cand", 1)):
        paths[name] = tiny("d4-film", seed=seed).save(tmp_path / f"{name}.npz")
    calls = []

    def evaluate(model_path, *, decoder, maps, windinet, n_inlets, seed, budget_s, compare,
                 flow_cache, progress):
        calls.append({"model": model_path, "seed": seed, "n": n_inlets,
                      "compare": sorted(compare), "map": maps[0][0], "boundary":
                      (decoder.boundary, *(d.boundary for d in compare.values())),
                      "views": (decoder.rotations_deg,
                                *(d.rotations_deg for d in compare.values()))})
        recs = []
        for i in range(n_inlets):
            base = 2.0 + seed + i
            recs.append(_slot({"decoder": base, "cand": 0.9 * base, "local": 2 * base},
                              {"decoder": 20.0, "cand": 19.0 if i == 0 else 21.0,
                               "local": 30.0}, 10.0 * i, 1000 * (i + 1)))
        failed = [{"map": "holdout-0", "inlet": n_inlets, "error": "diverged"}] * (seed == 2)
        return {"records": recs, "failed": failed, "stopped_by_budget": False}

    monkeypatch.setattr(de, "evaluate_decoder", evaluate)
    return paths, calls


def test_the_candidate_is_compared_on_the_held_out_district_inlet_by_inlet(stubbed):
    paths, calls = stubbed
    mod = _module()
    res = mod.run(paths["ref"], [("cand", paths["cand"])], boundary="blend",
                  runs=[(2, 1), (3, 2)], progress=False)
    assert [(c["n"], c["seed"], c["map"]) for c in calls] == [(2, 1, "holdout-0"),
                                                              (3, 2, "holdout-0")]
    assert all(c["compare"] == ["cand"] and c["boundary"] == ("blend", "blend")
               and c["views"] == (None, None) for c in calls)
    assert res["inlets"] == 5 and res["samples"] == 80
    assert [r["seed"] for r in res["per_inlet"]] == [1, 1, 2, 2, 2]
    speeds, cells = np.array([3.0, 4.0, 4.0, 5.0, 6.0]), np.array([1, 2, 1, 2, 3])
    pooled = (speeds * cells).sum() / cells.sum()  # each cell weighing equally
    assert res["pooled"]["decoder"]["speed_error"] == pytest.approx(pooled)
    assert res["pooled"]["cand"]["speed_error"] == pytest.approx(0.9 * pooled)
    cand_dir = (np.array([19.0, 21.0, 19.0, 21.0, 21.0]) * cells).sum() / cells.sum()
    assert res["pooled"]["cand"]["direction_error_deg"] == pytest.approx(cand_dir)
    v = res["versus_reference"]["cand"]
    assert v["speed_error"]["value"] == pytest.approx(10.0)
    assert v["speed_error"]["better_inlets"] == 5
    assert v["direction_error_deg"]["better_inlets"] == 2  # the first inlet of each run
    assert v["direction_error_deg"]["value"] == pytest.approx(100 * (1 - cand_dir / 20.0))
    assert res["failed"] == [{"map": "holdout-0", "inlet": 3, "error": "diverged",
                              "run_seed": 2}]
    lines = mod.table(res)
    assert any(line.startswith("| cand (") and "+10.00 %" in line and "better at 5 of 5" in line
               for line in lines)
    assert "Not scored: 1 inlets failed." in lines


def test_the_command_writes_its_json_and_refuses_what_it_cannot_run(stubbed, tmp_path,
                                                                    capsys):
    paths, _ = stubbed
    mod = _module()
    out = tmp_path / "out"
    assert mod.main(["--out", str(out), "--model", str(paths["ref"]), "--compare",
                     f"cand={paths['cand']}", "--runs", "2:1", "--no-progress"]) == 0
    res = json.loads((out / "decoder_holdout.json").read_text())
    assert res["boundary"] == "average" and res["runs"] == [[2, 1]]
    assert res["sha256"] == {n: hashlib.sha256(paths[f].read_bytes()).hexdigest()
                             for n, f in (("decoder", "ref"), ("cand", "cand"))}
    assert res["rotations_deg"] is None
    assert mod.main(["--out", str(out), "--compare", f"cand={paths['cand']}", "--runs", "1:1",
                     "--rotations-deg", "0", "-3", "3", "--no-progress"]) == 0
    res = json.loads((out / "decoder_holdout.json").read_text())
    assert res["rotations_deg"] == [0.0, -3.0, 3.0]
    assert stubbed[1][-1]["views"] == ((0.0, -3.0, 3.0),) * 2
    assert "turned by 0, -3, 3 deg" in capsys.readouterr().out
    assert res["command"].startswith("python benchmarks/decoder_holdout.py --out")
    for argv in (["--out", str(out)],  # nothing to compare
                 ["--out", str(out), "--compare", "x=a.npz", "--compare", "x=b.npz"],
                 ["--out", str(out), "--compare", "decoder=a.npz"],
                 ["--out", str(out), "--compare", "x=a.npz", "--runs", "0:1"],
                 ["--out", str(out), "--compare", "x=a.npz", "--runs", "4"]):
        with pytest.raises(SystemExit) as exc:
            mod.main(argv)
        assert exc.value.code == 2
    assert "--compare" in capsys.readouterr().err
