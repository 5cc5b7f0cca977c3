"""A result file names the command that reproduces it: ``windnav.provenance.command_line``.

The provenance audit (2026-12-06) found committed results whose documented commands were
fragments (``evaluate-decoder ... --compare NAME=...``, three without ``--out`` that did not
parse) although each JSON records its command and arguments. The line is now rebuilt from the
file, and every committed JSON that records its arguments rebuilds to a line the current
interface parses to the same arguments: a renamed or removed option fails here first.
"""

from __future__ import annotations

import gzip
import json
from pathlib import Path

import pytest

import windnav.cli as cli
from windnav.experiments.results import NOT_ARGUMENTS
from windnav.predict.decoder import DEFAULT_MODEL, model_sha256, shipped_model_file
from windnav.provenance import command_arguments, command_line

DOCS = Path(__file__).resolve().parents[1] / "docs"


def _documents():
    for path in sorted([*DOCS.rglob("*.json"), *DOCS.rglob("*.json.gz")]):
        opener = gzip.open if path.suffix == ".gz" else open
        with opener(path, "rt") as f:
            doc = json.load(f)
        if (isinstance(doc, dict) and isinstance(doc.get("arguments"), dict)
                and str(doc.get("command", "")).startswith("windnav ")):
            yield path, doc


COMMITTED = list(_documents())


def _parsed(words):
    ns = vars(cli.build_parser().parse_args(words[1:]))
    return json.loads(json.dumps(ns, default=str))


def test_there_are_committed_results_to_rebuild():
    assert len(COMMITTED) >= 90


@pytest.mark.parametrize("path, doc", COMMITTED, ids=[str(p.relative_to(DOCS)) for p, _ in
                                                        COMMITTED])
def test_every_committed_result_rebuilds_to_its_own_arguments(path, doc):
    words = command_arguments(doc)
    assert words[:2] == doc["command"].split()[:2]
    parsed = _parsed(words)
    recorded = {k: v for k, v in doc["arguments"].items() if k not in NOT_ARGUMENTS}
    files = doc.get("model_files") or {}
    made = files.get("model") or {}
    if made.get("sha256") and recorded.get("model") is None:  # the default of its day
        # by its hash: the current default, or the dated file the line names
        assert model_sha256(parsed["model"]) == made["sha256"]
        parsed["model"] = None
    for i, (text, rec) in enumerate((files.get("compare") or {}).items()):
        if parsed["compare"][i] != text:  # the shipped file by path, since replaced
            assert text.endswith(DEFAULT_MODEL.name) and rec["sha256"]
            assert model_sha256(parsed["compare"][i].split("=", 1)[-1]) == rec["sha256"]
            parsed["compare"][i] = text
    assert {k: parsed.get(k) for k in recorded} == recorded


def _rerun(words, tmp_path, name):
    words = list(words)
    words[words.index("--out") + 1] = str(tmp_path / name)
    words[words.index("--json") + 1] = str(tmp_path / f"{name}.json")
    assert cli.main(words[1:]) == 0
    return json.loads((tmp_path / f"{name}.json").read_text())


def test_the_line_of_a_result_runs_and_reproduces_it(tmp_path):
    typed = ["fly", "--trajectory", "hover", "--wind", "dryden", "--duration", "1",
             "--no-plots", "--no-progress", "--out", str(tmp_path / "a"), "--json",
             str(tmp_path / "a.json")]
    assert cli.main(typed) == 0
    first = json.loads((tmp_path / "a.json").read_text())
    assert first["argv"] == typed                           # the words as typed
    assert command_arguments(first) == ["windnav", *typed]
    again = _rerun(command_arguments(first), tmp_path, "b")
    old = {k: v for k, v in first.items() if k != "argv"}  # a result from before argv
    line = command_line(old)
    assert line.startswith("windnav fly ") and "--duration 1.0" in line
    assert "--wind " not in line and "--dt" not in line     # the defaults': left out
    rebuilt = _rerun(command_arguments(old), tmp_path, "c")
    numbers = ("energy_J", "rms_tracking_error_m", "max_airspeed_m_s", "mean_power_W")
    for other in (again, rebuilt):
        assert [other[k] for k in numbers] == [first[k] for k in numbers]
        assert {**other["arguments"], "out": None, "json": None} == {
            **first["arguments"], "out": None, "json": None}


def test_a_result_the_interface_can_no_longer_rebuild_is_an_error_naming_why():
    doc = {"command": "windnav fly", "arguments": {"duration": 1.0, "old_option": 3}}
    with pytest.raises(ValueError, match="no longer has: old_option"):
        command_line(doc)
    with pytest.raises(ValueError, match="'command'"):
        command_line({"arguments": {}})
    with pytest.raises(ValueError, match="'arguments'"):
        command_line({"command": "windnav fly"})
    with pytest.raises(ValueError, match="no longer a windnav command"):
        command_line({"command": "windnav teleport", "arguments": {}})


def _predict_result(model_files: dict, model=None) -> dict:
    """A result of ``windnav predict`` as it records its arguments and model files."""
    typed = ["predict", "--map", "m.json", "--at", "10", "20", "--speed", "5",
             "--direction-deg", "30", "--out", "runs/p"]
    return _result(typed + (["--model", model] if model is not None else []), model_files)


def _result(typed: list[str], model_files, **recorded) -> dict:
    """A result of the command ``typed[0]`` with its arguments (``recorded`` over the parsed
    ones: values of options added since) and model files."""
    args = {k: v for k, v in _parsed(["windnav", *typed]).items() if k not in NOT_ARGUMENTS}
    return {"command": f"windnav {typed[0]}", "argv": typed, "model_files": model_files,
            "arguments": {**args, **recorded}}


def _replaced_model() -> Path:
    """The newest dated file kept of a model the shipped one replaced."""
    dated = sorted(set(DEFAULT_MODEL.parent.glob("decoder_*.npz")) - {DEFAULT_MODEL})
    assert dated, "the dated files of replaced models are installed"
    return dated[-1]


def _shown(path: Path) -> str:
    return str(path.relative_to(Path.cwd())) if path.is_relative_to(Path.cwd()) else str(path)


def test_a_result_of_a_replaced_default_model_names_its_dated_file():
    # Results made with the default decoder named no model, so once a new model was shipped
    # their line ran the new one. Since the forty-seventh session they record its hash.
    old = _replaced_model()
    assert shipped_model_file(model_sha256(old)) == old
    assert shipped_model_file(model_sha256()) == DEFAULT_MODEL
    assert shipped_model_file("0" * 64) is None

    then = _predict_result({"model": {"path": "default", "sha256": model_sha256(old)}})
    words = command_arguments(then)
    assert words[:4] == ["windnav", "predict", "--model", _shown(old)]
    assert model_sha256(_parsed(words)["model"]) == model_sha256(old)
    assert words[4:] == then["argv"][1:]                    # the rest as typed

    now = _predict_result({"model": {"path": "default", "sha256": model_sha256()}})
    assert command_arguments(now) == ["windnav", *now["argv"]]   # still the default
    given = _predict_result({"model": {"path": "x.npz", "sha256": "0" * 64}}, model="x.npz")
    assert command_arguments(given) == ["windnav", *given["argv"]]   # named: as typed
    before = _predict_result({})                            # no hash recorded: as typed
    assert command_arguments(before) == ["windnav", *before["argv"]]

    gone = _predict_result({"model": {"path": "default", "sha256": "0" * 64}})
    with pytest.raises(ValueError, match=r"default decoder of its day \(SHA-256 0{64}\), "
                                         "which this windnav no longer installs"):
        command_line(gone)


@pytest.mark.parametrize("typed", [
    ["evaluate-decoder", "--maps", "0", "--inlets", "2", "--out", "runs/e"],
    ["decoder-study", "eigenflows", "--out", "runs/s", "--quick"],
], ids=["evaluate-decoder", "decoder-study"])
@pytest.mark.parametrize("typed_argv", [True, False], ids=["argv", "arguments"])
def test_every_model_command_names_the_dated_file_of_its_replaced_default(typed, typed_argv):
    old = _replaced_model()
    doc = _result(typed, {"model": {"path": "default", "sha256": model_sha256(old)},
                          "compare": {}}, boundary="average")
    if not typed_argv:                                      # a result from before argv
        del doc["argv"]
    words = command_arguments(doc)
    parsed = _parsed(words)
    assert words[2:4] == ["--model", _shown(old)]           # before the study's name
    assert model_sha256(parsed["model"]) == model_sha256(old)
    assert parsed["boundary"] == "average"                  # the changed default, too
    assert parsed.get("study", typed[1]) == typed[1]
    assert {k: parsed[k] for k in doc["arguments"] if k not in ("model", "out")} == {
        k: v for k, v in doc["arguments"].items() if k not in ("model", "out")}


def test_the_shipped_file_named_by_path_is_redirected_to_its_dated_file():
    # A compare item (or --model) naming decoder_default.npz by path read the model of its
    # day; once replaced, the line would compare against the new one.
    old = _replaced_model()
    shipped = "src/windnav/predict/data/decoder_default.npz"
    then = {"path": "default", "sha256": model_sha256(old)}
    typed = ["evaluate-decoder", "--maps", "0", "--out", "runs/e", "--compare",
             f"one-pass={shipped}", f"--compare=x={shipped}", "--compare", "runs/m.npz"]
    doc = _result(typed, {"model": then, "compare": {
        f"one-pass={shipped}": then, f"x={shipped}": then,
        "runs/m.npz": {"path": "runs/m.npz", "sha256": "1" * 64}}})
    words = command_arguments(doc)
    assert words[2:4] == ["--model", _shown(old)]
    assert _parsed(words)["compare"] == [f"one-pass={_shown(old)}", f"x={_shown(old)}",
                                         "runs/m.npz"]        # another file: as typed
    now = {"path": "default", "sha256": model_sha256()}
    same = _result(typed, {"model": now, "compare": {f"one-pass={shipped}": now,
                                                     f"x={shipped}": now}})
    assert command_arguments(same) == ["windnav", *typed]   # still the shipped model
    named = _result(["predict", "--map", "m.json", "--at", "1", "2", "--speed", "5",
                     "--direction-deg", "0", "--out", "runs/p", f"--model=./{shipped}"],
                    {"model": {"path": shipped, "sha256": model_sha256(old)}})
    assert command_arguments(named)[-1] == f"--model={_shown(old)}"
    gone = _result(typed, {"model": now, "compare": {
        f"one-pass={shipped}": {"path": shipped, "sha256": "0" * 64}}})
    with pytest.raises(ValueError, match=r"SHA-256 0{64}\), which this windnav no longer"):
        command_line(gone)


@pytest.mark.parametrize("files", [["not", "a", "mapping"], "x", {"model": 3},
                                   {"model": {"path": "default"}}, {"compare": [1]}])
def test_a_malformed_model_record_leaves_the_typed_line(files):
    doc = _predict_result(files)
    assert command_arguments(doc) == ["windnav", *doc["argv"]]


def test_only_the_shipped_file_is_redirected():
    old = _replaced_model()
    then = {"path": "default", "sha256": model_sha256()}
    elsewhere = "/elsewhere/src/windnav/predict/data/decoder_default.npz"   # another checkout
    windows = r"src\windnav\predict\data\decoder_default.npz"
    lookalike = "runs/xwindnav/predict/data/decoder_default.npz"
    items = [f"a={elsewhere}", f"b={windows}", lookalike]
    typed = ["evaluate-decoder", "--maps", "0", "--out", "runs/e"]
    for item in items:
        typed += ["--compare", item]
    doc = _result(typed, {"model": then, "compare": {
        items[0]: {"path": elsewhere, "sha256": "0" * 64},       # its own model: no error
        items[1]: {"path": windows, "sha256": model_sha256(old)},
        items[2]: {"path": lookalike, "sha256": model_sha256(old)}}})
    assert _parsed(command_arguments(doc))["compare"] == [
        items[0], f"b={_shown(old)}", lookalike]


def test_an_abbreviated_model_option_is_redirected_as_the_full_one():
    # argparse reads a unique prefix (--mod, --compa) as the option; the redirect found only
    # the full name, so such a line named the new shipped model (left alone 2026-12-06).
    old = _replaced_model()
    shipped = "src/windnav/predict/data/decoder_default.npz"
    then = {"path": shipped, "sha256": model_sha256(old)}
    typed = ["evaluate-decoder", "--maps", "0", "--out", "runs/e", "--mod", shipped,
             f"--compare=x={shipped}"]
    doc = _result(typed, {"model": then, "compare": {f"x={shipped}": then}})
    parsed = _parsed(command_arguments(doc))
    assert str(parsed["model"]) == _shown(old)
    assert parsed["compare"] == [f"x={_shown(old)}"]
    # a prefix of two options is no abbreviation (argparse refuses it): left as typed
    from windnav.provenance import _unabbreviated

    sub = cli.build_parser().commands["evaluate-decoder"]
    assert _unabbreviated(["windnav", "evaluate-decoder", "--comp", "x", "--mo=y"], sub,
                          ("--model", "--compare")) == [
        "windnav", "evaluate-decoder", "--comp", "x", "--model=y"]


@pytest.mark.parametrize("typed", [
    ["nav-study", "inflight", "--maps", "0", "--out", "runs/i"],
    ["nav-study", "pace", "--store", "runs/b", "--out", "runs/p"],
    ["benchmark-nav", "--suite", "quick", "--variants", "ea-mppi-w-hat", "--out", "runs/b"],
], ids=["inflight", "pace", "benchmark-nav"])
def test_a_decoder_flown_or_compared_from_the_shipped_file_names_its_dated_file(typed):
    # nav-study and benchmark-nav record --decoder's hash (decoder_file) and nav-study
    # inflight --compare's (model_files, since the fifty-second session); a line naming
    # decoder_default.npz by path flew, or compared, the model of its day (the committed
    # in-flight study of the shipped model did), and was not redirected once it was replaced.
    old = _replaced_model()
    shipped = "src/windnav/predict/data/decoder_default.npz"
    then = {"path": shipped, "sha256": model_sha256(old)}
    compare = typed[1] == "inflight"
    words = [*typed, "--dec", f"./{shipped}"] + (["--compare", f"s={shipped}"] if compare else [])
    doc = _result(words, {"compare": {f"s={shipped}": then}} if compare else None)
    doc["decoder_file"] = then
    parsed = _parsed(command_arguments(doc))
    assert str(parsed["decoder"]) == _shown(old)
    assert not compare or parsed["compare"] == [f"s={_shown(old)}"]
    assert parsed["study" if typed[0] == "nav-study" else "suite"] == typed[1 + (
        typed[0] == "benchmark-nav")]
    now = dict(doc, decoder_file={"path": shipped, "sha256": model_sha256()},
               model_files={"compare": {f"s={shipped}": {"path": shipped,
                                                         "sha256": model_sha256()}}})
    assert _parsed(command_arguments(now)) == _parsed(["windnav", *words])   # still shipped
    mine = dict(doc, decoder_file={"path": "runs/m.npz", "sha256": "1" * 64},
                argv=[*typed, "--decoder", "runs/m.npz"], model_files=None)
    assert command_arguments(mine) == ["windnav", *mine["argv"]]   # its own file: as typed
    gone = dict(now, decoder_file={"path": shipped, "sha256": "0" * 64})
    with pytest.raises(ValueError, match=r"SHA-256 0{64}\), which this windnav no longer"):
        command_line(gone)


@pytest.mark.parametrize("typed", [
    ["navigate", "--map", "m.json", "--start", "10", "20", "--goal", "90", "20", "--speed", "5",
     "--variant", "ea-mppi-w-hat", "--out", "runs/n"],
    ["demo", "--variant", "mppi,ea-mppi-w-hat", "--out", "runs/d"],
], ids=["navigate", "demo"])
def test_an_onboard_flight_names_the_dated_file_of_its_replaced_default(typed):
    # windnav navigate records the decoder it flew (ea-mppi-w-hat) since 2026-12-07, and
    # windnav demo's --variant since the fifty-fourth session
    old = _replaced_model()
    doc = _result(typed, {"model": {"path": "default", "sha256": model_sha256(old)},
                          "compare": {}})
    words = command_arguments(doc)
    assert words[2:4] == ["--model", _shown(old)]
    assert words[4:] == typed[1:]
    now = _result(typed, {"model": {"path": "default", "sha256": model_sha256()},
                          "compare": {}})
    assert command_arguments(now) == ["windnav", *typed]
