"""One shape for every command's outputs: --json, --overwrite, --seed, atomic and resumable.

The helpers of :mod:`windnav.experiments.results` are tested directly; the commands are run
in-process (``windnav.cli.main``) on tiny inputs.
"""

import argparse
import json
import math

import numpy as np
import pytest

import windnav.experiments.ukf_montecarlo as mc
from windnav.cli import COMMAND_MODULES, build_parser, main
from windnav.experiments import results as res

SEEDED = {"fly", "wind", "wind-sweep", "flow-validate", "ukf-montecarlo", "calibrate", "demo",
          "navigate", "benchmark-nav", "evaluate-decoder", "predict"}
"""Commands that draw random numbers; ``power-curve`` draws none (no sensors, steady wind)."""


def leaves(choices, prefix=()):
    """(command words, parser) of every runnable command, nested subcommands included."""
    for name, sub in choices.items():
        nested = [a for a in sub._actions if isinstance(a, argparse._SubParsersAction)]
        if nested:
            yield from leaves(nested[0].choices, prefix + (name,))
        else:
            yield prefix + (name,), sub


def options(sub):
    return {s for a in sub._actions for s in a.option_strings}


def test_every_listed_command_is_registered_with_json_overwrite_and_seed():
    parser = build_parser()
    action = next(a for a in parser._actions if a.dest == "command")
    assert set(action.choices) == {m.replace("_", "-") for m in COMMAND_MODULES}
    for words, sub in leaves(action.choices):
        opts = options(sub)
        assert {"--json", "--overwrite"} <= opts, words
        if words[0] in SEEDED or words == ("power-curve",):
            assert ("--seed" in opts) == (words[0] in SEEDED), words


def _help_of(sub, action) -> str:
    """The help of one option as ``--help`` prints it (``%(default)s`` expanded), one line."""
    return " ".join(sub._get_formatter()._expand_help(action).split()) if action.help else ""


def _default_text(value) -> str:
    if isinstance(value, (list, tuple)):
        return " ".join(_default_text(v) for v in value)
    return f"{value:g}" if isinstance(value, float) else str(value)


def test_every_option_with_a_default_says_it_in_its_help():
    # many --help entries gave neither the default nor, for a physical quantity, the unit
    # (CLI audit, 2026-12-05); the flags, required options and options off by default aside
    parser = build_parser()
    action = next(a for a in parser._actions if a.dest == "command")
    flags = (argparse._HelpAction, argparse._StoreTrueAction, argparse._StoreFalseAction,
             argparse.BooleanOptionalAction)
    missing = []
    for words, sub in leaves(action.choices):
        for a in sub._actions:
            if (not a.option_strings or a.required or isinstance(a, flags)
                    or a.default is None or a.default == []):
                continue
            text = _help_of(sub, a)
            if not ("default" in text or str(a.default) in text
                    or _default_text(a.default) in text):
                missing.append(f"{' '.join(words)} {a.option_strings[0]}: {text!r}")
    assert not missing, "\n".join(missing)


@pytest.mark.parametrize("words, option, needles", [
    (("sysid", "simulate-stand"), "--kv", ["rad/s/V/count^(2/3)", "default: the vehicle's"]),
    (("sysid", "simulate-tunnel"), "--max-speed", ["airspeed, m/s (6.0)"]),
    (("sysid", "simulate-tunnel"), "--record-s", ["s (1.5)"]),
    (("sysid", "power"), "--time-col", ["s:", "default: none, every sample is used"]),
    (("sysid", "aero"), "--average-s", ["seconds", "default: none, no averaging"]),
    (("similitude",), "--full-scale-mass", ["kg (default: none"]),
    (("similitude",), "--kinematic-viscosity", ["kinematic viscosity of the air, m^2/s"]),
    (("calibrate",), "--settle", ["s (default 3.0"]),
    (("nav-study",), "--values", ["the window side H, m", "the tilt cap, deg"]),
    (("decoder-study",), "--sizes", ["cells per side"]),
    (("wind-sweep",), "--maps", ["default: none"]),
])
def test_help_gives_units_and_what_an_unset_option_means(words, option, needles):
    parser = build_parser()
    subs = next(a for a in parser._actions if a.dest == "command").choices
    sub = dict(leaves(subs))[words]
    text = _help_of(sub, next(a for a in sub._actions if option in a.option_strings))
    for needle in needles:
        assert needle in text, text


def test_a_command_module_that_fails_to_import_is_not_dropped(monkeypatch):
    import windnav.cli as cli

    monkeypatch.setattr(cli, "COMMAND_MODULES", cli.COMMAND_MODULES + ("not_written_yet",))
    with pytest.raises(ModuleNotFoundError, match="not_written_yet"):
        cli.build_parser()


# ------------------------------------------------------------------ helpers of results.py


def test_json_ready_writes_non_finite_numbers_as_null():
    doc = res.json_ready({"a": np.float64("nan"), "b": (1, np.int64(2)), 3: np.array([1.5, np.inf]),
                          "ok": np.bool_(True)})
    assert doc == {"a": None, "b": [1, 2], "3": [1.5, None], "ok": True}
    json.dumps(doc, allow_nan=False)
    kept = res.json_ready({"x": float("inf")}, keep_nonfinite=True)
    assert kept["x"] == math.inf


def test_atomic_path_keeps_the_old_file_on_failure_and_leaves_nothing_behind(tmp_path):
    target = tmp_path / "r.json"
    target.write_text("old")
    with pytest.raises(RuntimeError), res.atomic_path(target) as tmp:
        tmp.write_text("half")
        raise RuntimeError("disk on fire")
    assert target.read_text() == "old" and sorted(tmp_path.iterdir()) == [target]
    with res.atomic_path(target) as tmp:
        assert tmp.suffix == ".json"  # writers that pick the format from the suffix still work
        tmp.write_text("new")
    assert target.read_text() == "new" and sorted(tmp_path.iterdir()) == [target]


def test_atomic_path_replaces_a_folder_whole(tmp_path):
    store = tmp_path / "flow.zarr"
    (store / "old").mkdir(parents=True)
    with res.atomic_path(store) as tmp:
        (tmp / "new").mkdir(parents=True)
    assert [p.name for p in store.iterdir()] == ["new"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["flow.zarr"]


def test_outputs_refuse_an_earlier_run_and_replace_it_whole_with_overwrite(tmp_path):
    out = tmp_path / "run"
    products = ("summary.json", "fig_*.png")
    first = res.Outputs("windnav x", out=("--out", out, products))
    with first.writing() as stage:
        for name in ("summary.json", "fig_a.png", "fig_b.png"):
            (stage.dir / name).write_text("run 1")
    assert sorted(p.name for p in first.written) == ["fig_a.png", "fig_b.png", "summary.json"]
    (out / "notes.txt").write_text("mine")  # not a product: never touched
    with pytest.raises(res.OutputExistsError, match="--overwrite") as refused:
        res.Outputs("windnav x", out=("--out", out, products))
    assert "'--out'" in str(refused.value) and "summary.json" in str(refused.value)
    again = res.Outputs("windnav x", out=("--out", out, products), overwrite=True)
    with again.writing() as stage:
        for name in ("summary.json", "fig_a.png"):
            (stage.dir / name).write_text("run 2")
    assert sorted(p.name for p in out.iterdir()) == ["fig_a.png", "notes.txt", "summary.json"]
    assert (out / "fig_a.png").read_text() == "run 2"
    assert [p.name for p in again.removed] == ["fig_b.png"]  # stale figure of run 1


def test_outputs_of_a_run_that_ended_meanwhile_are_not_replaced(tmp_path):
    """Two runs started on the same paths both passed the check at their start; the one that
    ends second used to replace the first's results without --overwrite. Now its own are
    kept beside them under new names, and it says where."""
    out = tmp_path / "run"
    json_path = tmp_path / "summary.json"
    products = ("a.txt",)
    first = res.Outputs("windnav x", out=("--out", out, products), files={"--json": json_path})
    second = res.Outputs("windnav x", out=("--out", out, products), files={"--json": json_path})
    with first.writing() as stage:
        (stage.dir / "a.txt").write_text("run 1")
        stage.file("--json").write_text("{1}")
    with pytest.raises(res.OutputExistsError, match="another run wrote") as clash, \
            second.writing() as stage:
        (stage.dir / "a.txt").write_text("run 2")
        stage.file("--json").write_text("{2}")
    assert (out / "a.txt").read_text() == "run 1" and json_path.read_text() == "{1}"
    kept = sorted(p for p in out.iterdir() if p.name.startswith("results-pid"))
    assert len(kept) == 1 and (kept[0] / "a.txt").read_text() == "run 2"
    other = [p for p in tmp_path.glob("summary.pid*.json")]
    assert len(other) == 1 and other[0].read_text() == "{2}"
    assert str(kept[0]) in str(clash.value) and str(other[0]) in str(clash.value)
    assert not [p for p in tmp_path.rglob("*windnav-tmp*")]
    # with --overwrite the second run replaces the first's, as asked
    third = res.Outputs("windnav x", out=("--out", out, products), files={"--json": json_path},
                        overwrite=True)
    with third.writing() as stage:
        (stage.dir / "a.txt").write_text("run 3")
        stage.file("--json").write_text("{3}")
    assert (out / "a.txt").read_text() == "run 3" and json_path.read_text() == "{3}"


def test_two_runs_that_finish_together_do_not_both_move_their_results(tmp_path, monkeypatch):
    """The check for another run's results and the moves into place were not one step: two
    runs finishing together both passed the check and both moved, or --out came from one run
    and --json from the other (concurrency audit, forced in a harness). The moves now happen
    under an flock of the output folders: the second waits, sees the first's results and
    keeps its own beside them."""
    import threading
    import time

    out, json_path, products = tmp_path / "run", tmp_path / "summary.json", ("a.txt",)
    real_replace = res._replace
    first_move = threading.Event()

    def slow_replace(src, dst):  # the first run to move pauses inside its commit
        if not first_move.is_set():
            first_move.set()
            time.sleep(0.5)
        real_replace(src, dst)

    monkeypatch.setattr(res, "_replace", slow_replace)
    runs = [res.Outputs("windnav x", out=("--out", out, products), files={"--json": json_path})
            for _ in range(2)]
    errors = []

    def run(k):
        try:
            with runs[k].writing() as stage:
                (stage.dir / "a.txt").write_text(f"run {k}")
                stage.file("--json").write_text(f"{{{k}}}")
                if k == 1:
                    first_move.wait(5.0)   # finish while run 0 is moving its results
        except res.OutputExistsError as exc:
            errors.append((k, exc))

    threads = [threading.Thread(target=run, args=(k,)) for k in range(2)]
    for t in threads:
        t.start()
    for t in threads:
        t.join(10.0)
    assert [k for k, _ in errors] == [1], errors   # the second to commit keeps its own apart
    assert (out / "a.txt").read_text() == "run 0" and json_path.read_text() == "{0}"
    kept = [p for p in out.iterdir() if p.name.startswith("results-pid")]
    assert len(kept) == 1 and (kept[0] / "a.txt").read_text() == "run 1"
    assert not [p for p in tmp_path.rglob("*.lock")]   # no lock file left behind


def test_outputs_write_nothing_when_the_run_fails(tmp_path):
    out = tmp_path / "run"
    o = res.Outputs("windnav x", out=("--out", out, ("a.txt",)), files={"--json": tmp_path / "j"})
    with pytest.raises(KeyboardInterrupt), o.writing() as stage:
        (stage.dir / "a.txt").write_text("half")
        stage.file("--json").write_text("{}")
        raise KeyboardInterrupt
    assert list(out.iterdir()) == [] and sorted(p.name for p in tmp_path.iterdir()) == ["run"]


def test_what_a_killed_run_left_is_removed_by_the_next_run_and_nothing_else(tmp_path):
    """A SIGKILL while writing leaves a staging folder in --out and a temporary file beside
    --json; the next run that stages its outputs removes those of processes that are gone,
    and keeps those of live processes, of other hosts, of other files and of older names."""
    import os
    import subprocess
    import sys

    gone = subprocess.Popen([sys.executable, "-c", "pass"])
    gone.wait()  # a process id that no longer names a process
    dead, live, host = gone.pid, os.getpid(), res._host_tag()
    other_host = f"{(int(host, 16) + 1) % 2**32:08x}"
    out, json_path = tmp_path / "run", tmp_path / "summary.json"
    out.mkdir()
    removed = [out / f".windnav-staging-{dead}-{host}-0badc0de",
               out / f".a.{dead}-{host}-0badc0de.windnav-tmp.txt",  # a product's, in --out
               tmp_path / f".summary.{dead}-{host}-0badc0de.windnav-tmp.json"]
    kept = [out / f".windnav-staging-{live}-{host}-0badc0de",  # a live run's
            out / f".windnav-staging-{dead}-{other_host}-0badc0de",  # a shared folder's
            out / ".windnav-staging-0badc0de",  # an older windnav's name: no process id
            out / f".notes.{dead}-{host}-0badc0de.windnav-tmp.txt",  # not a product
            tmp_path / f".summary.{live}-{host}-0badc0de.windnav-tmp.json",
            tmp_path / f".other.{dead}-{host}-0badc0de.windnav-tmp.json"]  # not --json's
    for path in removed + kept:
        if "staging" in path.name:
            path.mkdir()
            (path / "a.txt").write_text("half")
        else:
            path.write_text("half")
    # the names this windnav writes are the names it cleans up
    assert res._STAGING.fullmatch(f"{res._STAGING_PREFIX}{res._owner()}")
    m = res._TEMPORARY_NAME.fullmatch(res._temporary_name(json_path).name)
    assert (m["stem"] + m["suffix"], int(m["pid"]), m["host"]) == ("summary.json", live, host)
    o = res.Outputs("windnav x", out=("--out", out, ("a.txt",)), files={"--json": json_path})
    with o.writing() as stage:
        staged = stage.dir.name
        assert staged.startswith(f".windnav-staging-{live}-{host}-")
        assert stage.file("--json").name.startswith(f".summary.{live}-{host}-")
        (stage.dir / "a.txt").write_text("run")
        stage.file("--json").write_text("{}")
    assert sorted(o.cleaned) == sorted(removed)
    assert not any(p.exists() for p in removed) and all(p.exists() for p in kept)
    assert (out / "a.txt").read_text() == "run" and json_path.read_text() == "{}"
    assert not (out / staged).exists()


def test_outputs_refuse_two_flags_naming_one_file(tmp_path):
    with pytest.raises(res.OutputPathError, match="--plot"):
        res.Outputs("windnav x", files={"--json": tmp_path / "a", "--plot": tmp_path / "a"})
    with pytest.raises(res.OutputPathError, match="--json"):
        res.Outputs("windnav x", out=("--out", tmp_path, ("summary.json",)),
                    files={"--json": tmp_path / "summary.json"})


def test_record_log_refuses_another_study_and_skips_a_torn_line(tmp_path):
    log = res.RecordLog(tmp_path / "r.jsonl", {"seed": 1})
    log.append({"index": 0, "rmse": float("nan")})
    with open(log.path, "a") as f:
        f.write('{"index": 1, "rm')  # killed mid-write
    log.append({"index": 2, "rmse": 0.25})
    got = log.load()
    assert [r["index"] for r in got] == [0, 2] and math.isnan(got[0]["rmse"])
    with pytest.raises(res.RecordMismatchError, match="another study"):
        res.RecordLog(tmp_path / "r.jsonl", {"seed": 2}).load()
    # a NaN in the header is the same study on resume (NaN != NaN refused it as another's;
    # audit, 2026-12-05), another value still another study
    nan = res.RecordLog(tmp_path / "n.jsonl", {"tau": float("nan"), "seed": 1})
    nan.append({"index": 0})
    assert res.RecordLog(tmp_path / "n.jsonl", {"seed": 1, "tau": float("nan")}).load() == \
        [{"index": 0}]
    with pytest.raises(res.RecordMismatchError, match="another study"):
        res.RecordLog(tmp_path / "n.jsonl", {"seed": 1, "tau": 2.0}).load()


def test_record_log_takes_an_empty_or_torn_header_file_for_no_records(tmp_path):
    """A kill between creating the file and writing its header left a file the next run
    called another study's; lines that are JSON but no object crashed the callers, and bytes
    that are not UTF-8 failed the whole load (files audit)."""
    for torn in (b"", b'{"hea', b'{"header": {"seed": 1'):
        path = tmp_path / f"r{len(torn)}.jsonl"
        path.write_bytes(torn)
        log = res.RecordLog(path, {"seed": 1})
        assert log.load() == []
        log.append({"index": 0})
        assert log.load() == [{"index": 0}]
    with open(path, "ab") as f:
        f.write(b'[1, 2]\n7\n{"index": \xff\xfe}\n{"index": 1}\n')
    assert log.load() == [{"index": 0}, {"index": 1}]
    other = tmp_path / "other.jsonl"
    other.write_bytes(b"not a record log")
    with pytest.raises(res.RecordMismatchError, match="another study"):
        res.RecordLog(other, {"seed": 1}).load()


def test_ukf_montecarlo_resumes_only_the_records_of_its_own_trials(tmp_path, monkeypatch):
    """A record of another study's trial 1 (another seed) in this study's log was taken for
    trial 1 and moved the median, silently; a record without its rmse failed the summary
    after every other trial had run (files audit)."""
    cfg = mc.MonteCarloConfig(n_trials=3, seed=5, duration=(3.0, 3.0))
    specs = mc.draw_trials(cfg)
    log = res.RecordLog(tmp_path / "mc.partial.jsonl", mc.records_header(cfg))
    good = {"rmse": 0.3, "rmse_axes": [0.1, 0.2, 0.1], "saturated_fraction": 0.0,
            "outside_envelope_fraction": 0.0}
    log.append({"index": 0, "seed": specs[0].seed, **good})
    log.append({"index": 1, "seed": specs[1].seed + 1, **good, "rmse": 9.0})  # another study
    log.append({"index": 2, "seed": specs[2].seed, "rmse_axes": [0.1, 0.2, 0.1]})  # no rmse
    ran = []
    monkeypatch.setattr(mc, "run_trial", lambda spec: ran.append(spec.index) or {
        "index": spec.index, "seed": spec.seed, **good, "rmse": 0.2})
    out = mc.run_montecarlo(cfg, backend="serial", progress=False, records=log.path)
    assert ran == [1, 2] and out["resumed"] == 1
    assert [t["rmse"] for t in out["trials"]] == [0.3, 0.2, 0.2]


# ------------------------------------------------------------------ --json of each command


def write_tiny_map(path):
    doc = {"bounds": {"extents": [0, 20, 0, 16, 0, 20]},
           "blocks": [{"extents": [8, 12, 6, 10, 0, 10], "color": [0, 1, 0]}]}
    path.write_text(json.dumps(doc))
    return path


def read_doc(path, command):
    doc = json.loads(path.read_text())
    assert doc["command"] == f"windnav {command}" and doc["windnav_version"]
    assert doc["arguments"]["json"] == str(path)
    # the machine it ran on: timings and last-bit results depend on it
    assert doc["machine"]["cores"] >= 1 and doc["machine"]["cpu"] and doc["machine"]["python"]
    return doc


def test_fly_json_equals_its_summary_and_names_its_arguments(tmp_path):
    js = tmp_path / "fly.json"
    argv = ["fly", "--duration", "0.2", "--wind", "constant", "--no-plots", "--seed", "3",
            "--out", str(tmp_path / "run"), "--json", str(js)]
    assert main(argv) == 0
    doc = read_doc(js, "fly")
    assert doc == json.loads((tmp_path / "run" / "summary.json").read_text())
    assert doc["seed"] == 3 and doc["arguments"]["duration"] == 0.2
    assert doc["mean_wind_speed_m_s"] == pytest.approx(np.hypot(3.0, 1.0))


def test_power_curve_and_calibrate_json(tmp_path):
    js = tmp_path / "p.json"
    assert main(["power-curve", "--points", "4", "--degree", "2", "--max-speed", "4",
                 "--out", str(tmp_path / "p"), "--json", str(js)]) == 0
    doc = read_doc(js, "power-curve")
    assert len(doc["power_W"]) == 4 and all(p > 0 for p in doc["power_W"])
    # degree + 1 points: an exact interpolation, whose endurance check could never fire, and
    # read "endurance_within_fit_noise: false" as checked (statistics audit)
    assert main(["power-curve", "--points", "3", "--degree", "2", "--max-speed", "4",
                 "--out", str(tmp_path / "p3")]) == 2
    js = tmp_path / "c.json"
    assert main(["calibrate", "--duration", "2", "--settle", "1", "--out", str(tmp_path / "c"),
                 "--json", str(js)]) == 0
    doc = read_doc(js, "calibrate")
    assert doc == json.loads((tmp_path / "c" / "calibration.json").read_text())
    assert abs(doc["relative_error"]["k_d"]) < 0.05


@pytest.mark.parametrize("argv, match", [
    # 10^9 hung with no output; 1e-6 swept speeds 2e-7 m/s apart (CLI audit)
    (["--points", "1000000000"], "'--points' parameter of windnav power-curve must be at most "
                                 "1001"),
    (["--max-speed", "1e-6", "--points", "6", "--degree", "1"],
     "'--max-speed' parameter of windnav power-curve must be at least 1 m/s"),
    # the envelope's limit, not the first swept speed beyond it ("it leaves it at 15.0 m/s")
    (["--max-speed", "100"], "leaves 3 of the 21 points below the airspeed limit of "
                             "hummingbird's envelope, 13.45 m/s, too few for a degree-4 fit"),
    (["--vehicle", "crazyflie_brushless", "--max-speed", "40", "--points", "9"],
     "airspeed limit of crazyflie_brushless's envelope, 6.97 m/s"),
])
def test_power_curve_refuses_sweeps_it_cannot_fit_before_flying(argv, match, tmp_path, capsys,
                                                                monkeypatch):
    def no_sweep(*args, **kwargs):
        raise AssertionError("the sweep ran")

    monkeypatch.setattr("windnav.experiments.power_curve.power_curve_study", no_sweep)
    assert main(["power-curve", *argv, "--out", str(tmp_path / "p")]) == 2
    err = capsys.readouterr().err
    assert match in err and "15.0" not in err
    assert not (tmp_path / "p").exists()


@pytest.mark.parametrize("argv", [
    ["fly", "--duration", "0.1", "--no-plots"],
    ["power-curve"],
    ["evaluate-decoder", "--maps", "0"],
    ["decoder-study", "gradients", "--quick"],
    ["train-decoder", "--config", "tiny"],
    # every other command whose --out is a folder (they wrote into the current one too)
    ["calibrate", "--duration", "5"],
    ["demo", "--map-size", "300"],
    ["flow-validate"],
    ["nav-study", "gs"],
    ["sysid", "simulate-stand"],
    ["sysid", "simulate-tunnel"],
    ["benchmark-nav", "--suite", "quick"],
    ["benchmark-nav", "--replay", "quick/m00/w00/p0", "--variant", "mppi"],
])
def test_an_empty_out_is_refused_not_read_as_the_current_folder(argv, tmp_path, monkeypatch,
                                                                 capsys):
    """``fly --out ""`` wrote its log and summary into the current folder: argparse's Path("")
    is "." (CLI audit). Kept as typed, it is refused as every empty output path is."""
    monkeypatch.chdir(tmp_path)
    assert main([*argv, "--out", ""]) == 2
    command = " ".join(argv[:2]) if argv[0] == "sysid" else argv[0]
    assert (f"The '--out' parameter of windnav {command} must be a path. Got '' instead."
            in capsys.readouterr().err)
    assert list(tmp_path.iterdir()) == []


def test_wind_and_wind_sweep_json(tmp_path):
    tiny = write_tiny_map(tmp_path / "tiny.json")
    js = tmp_path / "w.json"
    assert main(["wind", "--map", str(tiny), "--speed", "3", "--dx", "2", "--steps", "3",
                 "--spinup-steps", "2", "--out", str(tmp_path / "w"), "--json", str(js)]) == 0
    doc = read_doc(js, "wind")
    assert doc["config"]["speed"] == 3.0 and doc["config"]["steps"] == 3
    assert "half_window_difference" in doc["diagnostics"]
    js = tmp_path / "s.json"
    assert main(["wind-sweep", "--maps", str(tiny), "--out", str(tmp_path / "s.zarr"),
                 "--speeds", "2", "--directions", "2", "--backend", "serial", "--dx", "2",
                 "--steps", "2", "--spinup-steps", "0", "--no-progress", "--json", str(js)]) == 0
    doc = read_doc(js, "wind-sweep")
    assert doc["summary"]["simulations"] == 2 and doc["summary"]["done"] == 2
    assert [r["ok"] for r in doc["records"]] == [True, True]
    assert sorted(d for r in doc["records"] for d in r["directions_deg"]) == [0.0, 180.0]


def test_wind_refuses_a_json_that_is_its_map_or_inside_its_store(tmp_path, capsys):
    """``wind --json M.json --overwrite`` replaced the input map with the summary, and ``--json
    OUT/flow.zarr/zarr.json`` wrote inside the store the run replaces (CLI audit): refused
    before the solve, as ``fly`` refuses a --json that names one of --out's files."""
    tiny = write_tiny_map(tmp_path / "tiny.json")
    before = tiny.read_bytes()
    run = ["wind", "--map", str(tiny), "--speed", "3", "--dx", "2", "--steps", "2",
           "--spinup-steps", "2", "--out", str(tmp_path / "w")]
    for js, match in ((str(tiny), "'--json' parameter of windnav wind must not name --map's "
                                  "file, an input of the run"),
                      # the same file by another path
                      (str(tmp_path / "w" / ".." / "tiny.json"), "--map's file"),
                      (str(tmp_path / "w" / "flow.zarr" / "zarr.json"),
                       "'--json' parameter of windnav wind must not name a file inside "
                       "'flow.zarr', which --out writes")):
        assert main([*run, "--json", js, "--overwrite"]) == 2
        assert match in capsys.readouterr().err
        assert tiny.read_bytes() == before and not (tmp_path / "w").exists()
    # a store there already: the same
    assert main(run) == 0
    assert main([*run, "--json", str(tmp_path / "w" / "flow.zarr" / "zarr.json"),
                 "--overwrite"]) == 2
    assert "inside 'flow.zarr'" in capsys.readouterr().err
    # a --json beside the products in --out is fine, as before
    assert main([*run, "--json", str(tmp_path / "w" / "summary.json"), "--overwrite"]) == 0


def test_evaluate_decoder_refuses_a_json_that_is_one_of_its_maps(tmp_path, capsys):
    """Each repeated ``--map`` is an input: ``--json`` naming the second one (by another path)
    was written over it with --overwrite (CLI audit), refused before any flow."""
    first = write_tiny_map(tmp_path / "a.json")
    second = write_tiny_map(tmp_path / "b.json")
    before = second.read_bytes()
    assert main(["evaluate-decoder", "--map", str(first), "--map", f"mine={second}", "--json",
                 str(tmp_path / "o" / ".." / "b.json"), "--overwrite", "--no-progress",
                 "--out", str(tmp_path / "o")]) == 2
    err = capsys.readouterr().err
    assert ("'--json' parameter of windnav evaluate-decoder must not name --map's file, an "
            "input of the run" in err), err
    assert second.read_bytes() == before and not (tmp_path / "o").exists()


def test_flow_validate_json_and_figures(tmp_path, monkeypatch):
    import windnav.experiments.flow_validation as fv

    real = (fv.projection_study, fv.uniform_study, fv.taylor_green_study)
    monkeypatch.setattr(fv, "projection_study", lambda *, rng: real[0](rng=rng, steps=3))
    monkeypatch.setattr(fv, "uniform_study", lambda: real[1](directions=(30.0,)))
    monkeypatch.setattr(fv, "taylor_green_study", lambda: real[2](n=8, periods=0.5))
    js = tmp_path / "v.json"
    assert main(["flow-validate", "--out", str(tmp_path / "v"), "--json", str(js)]) == 0
    doc = read_doc(js, "flow-validate")
    assert doc["max_div_dx_over_U"] < 1e-8 and doc["max_fixed_face_error"] < 1e-8
    assert set(doc["taylor_green_nu"]) == {"semi_lagrangian", "maccormack"}
    assert sorted(p.name for p in (tmp_path / "v").iterdir()) == sorted(
        doc["figures"] + ["flow_validation.json"])


# ------------------------------------------------------------------ ukf-montecarlo: resume


UKF = ["ukf-montecarlo", "--trials", "3", "--duration", "3", "3", "--backend", "serial",
       "--no-progress"]


def test_ukf_montecarlo_interrupted_keeps_finished_trials_and_resumes(tmp_path, monkeypatch,
                                                                      capsys):
    js = tmp_path / "mc.json"
    argv = UKF + ["--json", str(js)]
    real = mc.run_trial
    calls = []

    def interrupted_after_one(spec):
        if calls:
            raise KeyboardInterrupt
        calls.append(spec.index)
        return real(spec)

    monkeypatch.setattr(mc, "run_trial", interrupted_after_one)
    assert main(argv) == 130
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "1/3 trials done" in err[0] and "rerun" in err[0]
    partial = tmp_path / "mc.partial.jsonl"
    assert not js.exists() and len(partial.read_text().splitlines()) == 2  # header + 1 trial

    calls.clear()

    def counted(spec):
        calls.append(spec.index)
        return real(spec)

    monkeypatch.setattr(mc, "run_trial", counted)
    assert main(argv) == 0
    assert calls == [1, 2]  # trial 0 was not run again
    assert "resuming: 1/3" in capsys.readouterr().err
    doc = read_doc(js, "ukf-montecarlo")
    assert doc["resumed"] == 1 and [t["index"] for t in doc["trials"]] == [0, 1, 2]
    assert not partial.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["mc.json"]
    # a resumed study gives the numbers of an uninterrupted one
    whole = mc.run_montecarlo(mc.MonteCarloConfig(n_trials=3, duration=(3.0, 3.0)),
                              backend="serial", progress=False)
    assert [t["rmse"] for t in doc["trials"]] == pytest.approx([t["rmse"] for t in whole["trials"]])
    assert doc["summary"]["median"] == pytest.approx(whole["summary"]["median"])


def test_ukf_montecarlo_partial_records_of_another_study_are_not_mixed_in(tmp_path, monkeypatch,
                                                                          capsys):
    js = tmp_path / "mc.json"
    cfg = mc.MonteCarloConfig(n_trials=3, seed=5, duration=(3.0, 3.0))
    log = res.RecordLog(tmp_path / "mc.partial.jsonl", mc.records_header(cfg))
    log.append({"index": 0, "rmse": 0.1})
    ran = []
    monkeypatch.setattr(mc, "run_trial", lambda spec: ran.append(spec) or {})
    assert main(UKF + ["--json", str(js)]) == 2  # seed 0 is another study
    err = capsys.readouterr().err
    assert "'--json'" in err and "another study" in err and "--overwrite" in err
    assert ran == [] and log.path.exists()
    monkeypatch.setattr(mc, "run_trial", lambda spec: {"index": spec.index, "rmse": 0.2,
                                                       "rmse_axes": [0.1, 0.1, 0.1]})
    assert main(UKF + ["--json", str(js), "--overwrite"]) == 0
    assert [t["rmse"] for t in json.loads(js.read_text())["trials"]] == [0.2, 0.2, 0.2]
    assert not log.path.exists()


def test_version(capsys):
    import windnav
    from windnav.cli import main

    with pytest.raises(SystemExit) as info:
        main(["--version"])
    assert info.value.code == 0 and capsys.readouterr().out == f"windnav {windnav.__version__}\n"


def test_the_command_line_sets_the_agg_backend_itself(tmp_path, monkeypatch):
    """The plotting modules leave the backend alone (a notebook's import of one switched it
    to Agg); the command line itself, and only it (not main(argv) called from Python), sets
    Agg for its figures and its workers, while the command runs (and restores the caller's
    setting after it: tests/test_side_effects.py)."""
    import os
    import sys

    from windnav import cli

    seen = []
    run = cli._run
    monkeypatch.setattr(cli, "_run", lambda args, where: (
        seen.append(os.environ.get("MPLBACKEND")), run(args, where))[1])
    monkeypatch.delenv("MPLBACKEND", raising=False)
    assert cli.main(["power-curve", "--out", str(tmp_path / "a")]) == 0
    monkeypatch.setattr(sys, "argv", ["windnav", "power-curve", "--out", str(tmp_path / "b")])
    assert cli.main() == 0
    assert seen == [None, "Agg"]
