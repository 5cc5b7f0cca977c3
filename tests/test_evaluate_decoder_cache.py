"""``windnav evaluate-decoder`` keeps its solved flows by default, so a rerun after an interrupt
resumes (interrupt audit, 2026-12-05: without ``--flow-cache DIR`` a Ctrl-C or a kill lost
every flow of a 5-7 minute run).

One tiny map (120 m, 4 buildings), tiny flows (2 m cells, 10 + 10 steps) and a tiny d4-film with
random weights, as in test_decoder_eval.py; the solver is counted to tell a solved flow from
one read back.
"""

from __future__ import annotations

import json

import pytest
from test_decoder_eval import TINY_FLOW, tiny_decoder, tiny_maps

import windnav.cli as cli
import windnav.commands.evaluate_decoder as cmd


@pytest.fixture
def tiny_run(tmp_path, monkeypatch):
    """``(folder, counted solves, argv of a 2-inlet run)``: the command on one tiny map whose
    solver counts its calls and, while ``interrupt_at`` is set, raises KeyboardInterrupt (a
    Ctrl-C) on that call instead of solving."""
    from windnav.flow import simulate

    city = tiny_maps(1)[0][1]
    tiny_decoder().save(tmp_path / "model.npz")
    monkeypatch.setattr("windnav.experiments.decoder_eval._evaluation_maps",
                        lambda maps, windinet, where: [("tiny-0", "dense", city)])
    solves = {"n": 0, "interrupt_at": None}

    def counted(*args, **kwargs):
        solves["n"] += 1
        if solves["n"] == solves["interrupt_at"]:
            raise KeyboardInterrupt
        return simulate(*args, **kwargs)

    run = cmd.run
    monkeypatch.setattr(cmd, "run",
                        lambda args: run(args, simulate=counted, flow_settings=TINY_FLOW))
    argv = ["evaluate-decoder", "--model", str(tmp_path / "model.npz"), "--maps", "1",
            "--inlets", "2", "--samples", "16", "--dx", "2", "--seed", "4", "--no-progress"]
    return tmp_path, solves, argv


def entries(folder) -> list[str]:
    """The flow cache entries in ``folder`` (none when it does not exist)."""
    return sorted(p.name for p in folder.glob("*.zarr")) if folder.is_dir() else []


def test_an_interrupted_run_resumes_from_out_without_a_flow_cache_option(tiny_run, capsys):
    d, solves, argv = tiny_run
    out = d / "eval"
    solves["interrupt_at"] = 2  # Ctrl-C while the second inlet's flow is solved
    assert cli.main([*argv, "--out", str(out)]) == 130
    err = capsys.readouterr().err
    assert f"the flows solved so far are kept in {str(out / 'flows')!r}" in err
    assert "rerun the same command" in err
    assert len(entries(out / "flows")) == 1  # the first inlet's flow, kept
    assert not (out / "decoder_eval.json").exists()

    # the same command again: no --overwrite needed (the cache is no result), one flow solved
    solves.update(n=0, interrupt_at=None)
    assert cli.main([*argv, "--out", str(out)]) == 0
    assert solves["n"] == 1
    resumed = json.loads((out / "decoder_eval.json").read_text())
    assert [r["flow_cached"] for r in resumed["records"]] == [True, False]
    assert resumed["flow_cache"] == str(out / "flows")
    assert len(entries(out / "flows")) == 2
    size = sum(f.stat().st_size for f in (out / "flows").rglob("*") if f.is_file())
    assert f"flow cache: {str(out / 'flows')!r}, {size / 1e6:.1f} MB" in capsys.readouterr().err

    # --overwrite replaces the results and keeps the cache: nothing solved again
    solves["n"] = 0
    assert cli.main([*argv, "--out", str(out), "--overwrite"]) == 0
    assert solves["n"] == 0 and len(entries(out / "flows")) == 2

    # the uninterrupted run, keeping nothing: the same scores as the resumed one
    fresh = d / "fresh"
    solves["n"] = 0
    assert cli.main([*argv, "--out", str(fresh), "--no-flow-cache"]) == 0
    assert solves["n"] == 2
    assert sorted(p.name for p in fresh.iterdir()) == ["decoder_eval.json", "decoder_eval.png"]
    doc = json.loads((fresh / "decoder_eval.json").read_text())
    assert doc["flow_cache"] is None
    assert [r["flow_cached"] for r in doc["records"]] == [False, False]
    for a, b in zip(doc["records"], resumed["records"], strict=True):
        assert a["decoder"] == b["decoder"] and a["local"] == b["local"]
    assert doc["pooled"] == resumed["pooled"]


def test_a_flow_cache_named_elsewhere_keeps_nothing_in_out(tiny_run):
    d, solves, argv = tiny_run
    assert cli.main([*argv, "--out", str(d / "eval"), "--flow-cache", str(d / "shared")]) == 0
    assert len(entries(d / "shared")) == 2 and not (d / "eval" / "flows").exists()
    doc = json.loads((d / "eval" / "decoder_eval.json").read_text())
    assert doc["flow_cache"] == str(d / "shared")


def test_no_flow_cache_says_what_an_interrupt_loses(tiny_run, capsys):
    d, solves, argv = tiny_run
    solves["interrupt_at"] = 2
    assert cli.main([*argv, "--out", str(d / "eval"), "--no-flow-cache"]) == 130
    assert "interrupted; nothing is kept with --no-flow-cache" in capsys.readouterr().err
    assert not (d / "eval" / "flows").exists()


@pytest.mark.parametrize("extra, needles", [
    (["--no-flow-cache", "--flow-cache", "{d}/fc"], ["'--no-flow-cache' parameter",
                                                     "'--flow-cache'", "Got both"]),
    ([], ["'--out' parameter", "(the default flow cache)", "is a file",
          "--flow-cache DIR or --no-flow-cache"]),
])
def test_contradictory_or_unusable_cache_options_are_refused_before_any_work(tiny_run, capsys,
                                                                             extra, needles):
    d, solves, argv = tiny_run
    out = d / "eval"
    out.mkdir()
    (out / "flows").write_text("not a folder")  # where the default cache would go
    rc = cli.main([*argv, "--out", str(out), *[x.format(d=d) for x in extra]])
    assert rc == 2
    err = capsys.readouterr().err
    assert all(n in err for n in needles), err
    assert solves["n"] == 0 and sorted(p.name for p in out.iterdir()) == ["flows"]
    assert not (d / "fc").exists()
