"""``boundary="blend"`` as the default of load_decoder and of the decoder commands (2026-12-06),
and the lines of the results made before it (``windnav.provenance.VALUES_BEFORE``).

The blend itself (continuity, the documented mix, the symmetries) is tested in
``test_decoder_blend.py``; here: which rule each entry point takes, that training and the
scaling study keep the one pass they validate with, and that a committed result's rebuilt line
still names the rule it was made with.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import windnav.cli as cli
from windnav.predict import load_decoder
from windnav.predict.decoder import BLEND_WIDTH_DEG, BOUNDARIES, Decoder
from windnav.provenance import VALUES_BEFORE, command_arguments

DOCS = Path(__file__).resolve().parents[1] / "docs" / "data"


def _scenes(directions_deg, seed=0):
    rng = np.random.default_rng(seed)
    b = len(directions_deg)
    a = np.radians(np.asarray(directions_deg, dtype=np.float64))
    w_up = 6.0 * np.column_stack([np.cos(a), np.sin(a)])
    return rng.uniform(0.5, 100.0, (b, 360)), w_up, 0.8 * w_up


def test_load_decoder_blends_by_default_and_a_bare_decoder_takes_one_pass():
    dec = load_decoder()
    assert dec.boundary == "blend"
    one = load_decoder(boundary="average")
    raw = Decoder(one.weights, one.metadata)
    assert raw.boundary == "average"
    # near a boundary the default differs from the one pass; far from every one it is it
    near, far = [44.0, 3.0, 91.0], [22.5, 67.0, 200.0]
    x = _scenes(near)
    assert np.abs(dec.predict(*x) - one.predict(*x)).max() > 1e-3
    y = _scenes(far, seed=1)
    assert min(abs(((d + 22.5) % 45.0) - 22.5) for d in far) > BLEND_WIDTH_DEG
    np.testing.assert_array_equal(dec.predict(*y), one.predict(*y))
    np.testing.assert_array_equal(raw.predict(*x), one.predict(*x))


def _parser_default(command, dest):
    parser = cli.build_parser()
    sub = parser.commands[command]
    return next(a for a in sub._actions if a.dest == dest)


@pytest.mark.parametrize("command", ["predict", "evaluate-decoder", "decoder-study"])
def test_the_commands_default_to_the_blend(command):
    action = _parser_default(command, "boundary")
    assert action.default == "blend"
    assert set(action.choices) == set(BOUNDARIES)


def test_evaluate_decoder_compares_under_its_rule_unless_told(tmp_path):
    from windnav.commands._common import compare_boundary

    parser = cli.build_parser()
    base = ["evaluate-decoder", "--out", str(tmp_path)]
    assert compare_boundary(parser.parse_args(base)) == "blend"
    assert compare_boundary(parser.parse_args(base + ["--boundary", "average"])) == "average"
    assert compare_boundary(parser.parse_args(
        base + ["--boundary", "blend", "--compare-boundary", "average"])) == "average"
    with pytest.raises(SystemExit):
        parser.parse_args(base + ["--compare-boundary", "round"])


def test_the_compared_files_load_with_the_rule_given():
    from windnav.experiments.decoder_eval import _compared
    from windnav.predict.decoder import DEFAULT_MODEL

    dec = load_decoder()
    for rule in (None, "average", "floor"):
        models, paths = _compared({"other": DEFAULT_MODEL}, dec, "test", rule)
        assert models["other"].boundary == (rule or "blend")
        assert paths["other"] == str(DEFAULT_MODEL)


def test_decoder_study_loads_its_models_with_the_rule(tmp_path, monkeypatch):
    """The studies that score a model load it (and noise's compared models) with --boundary."""
    import windnav.predict as wp

    seen = []
    real = wp.load_decoder

    def spy(path=None, **kw):
        seen.append(kw.get("boundary"))
        return real(path, **kw)

    monkeypatch.setattr(wp, "load_decoder", spy)
    code = cli.main(["decoder-study", "gradients", "--quick", "--out", str(tmp_path / "a"),
                     "--boundary", "average", "--no-progress", "--json",
                     str(tmp_path / "a.json")])
    assert code == 0 and seen == ["average"]
    doc = json.loads((tmp_path / "a.json").read_text())
    assert doc["arguments"]["boundary"] == "average" and doc["model"]["boundary"] == "average"


def _doc(command, arguments, argv=None):
    d = {"command": f"windnav {command}", "arguments": arguments}
    if argv is not None:
        d["argv"] = argv
    return d


def _parsed(words):
    return vars(cli.build_parser().parse_args(words[1:]))


def test_a_result_made_with_one_pass_rebuilds_with_its_rule():
    typed = ["evaluate-decoder", "--maps", "0", "--out", "runs/x"]
    # recorded with the then default: named after the typed words
    words = command_arguments(_doc("evaluate-decoder", {"boundary": "average", "maps": 0,
                                                        "out": "runs/x"}, typed))
    assert words[:len(typed) + 1] == ["windnav", *typed]
    p = _parsed(words)
    assert (p["boundary"], p["compare_boundary"]) == ("average", "average")
    # made before the option: the value before (VALUES_BEFORE), typed or rebuilt
    for argv in (typed, None):
        p = _parsed(command_arguments(_doc("evaluate-decoder", {"maps": 0, "out": "runs/x"},
                                           argv)))
        assert p["boundary"] == VALUES_BEFORE["evaluate-decoder"]["boundary"] == "average"
    # made with the new default: the line as typed, nothing added
    blend = ["evaluate-decoder", "--out", "runs/y"]
    assert command_arguments(_doc("evaluate-decoder", {"boundary": "blend",
                                                       "compare_boundary": None,
                                                       "out": "runs/y"}, blend)) == \
        ["windnav", *blend]
    # a study, and a command with no such option: untouched
    study = ["decoder-study", "mosaic", "--out", "runs/s"]
    assert _parsed(command_arguments(_doc("decoder-study", {"study": "mosaic"}, study)))[
        "boundary"] == "average"
    fly = ["fly", "--duration", "1", "--out", "runs/f"]
    assert command_arguments(_doc("fly", {"duration": 1.0}, fly)) == ["windnav", *fly]


def test_the_committed_one_pass_evaluation_names_its_rule():
    words = command_arguments(json.loads((DOCS / "decoder_eval_windinet.json").read_text()))
    p = _parsed(words)
    assert (p["boundary"], p["compare_boundary"]) == ("average", "average")
    words = command_arguments(json.loads((DOCS / "decoder_eval_windinet_blend.json")
                                         .read_text()))
    p = _parsed(words)
    assert (p["boundary"], p["compare_boundary"]) == ("blend", "average")
