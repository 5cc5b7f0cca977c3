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


def test_the_python_api_compares_files_under_the_decoders_own_rule():
    from windnav.experiments.decoder_eval import _compared_rule

    one = load_decoder(boundary="average")
    assert _compared_rule(None, one) == "average"
    assert _compared_rule(None, load_decoder()) == "blend"
    assert _compared_rule("floor", one) == "floor"


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


def _compared_rule(parsed):
    """The compared models' rule: --compare-boundary, else --boundary's."""
    return parsed["compare_boundary"] or parsed["boundary"]


def _parsed(words):
    return vars(cli.build_parser().parse_args(words[1:]))


def test_a_result_made_with_one_pass_rebuilds_with_its_rule():
    typed = ["evaluate-decoder", "--maps", "0", "--out", "runs/x"]
    # recorded with the then default: named after the command's name; no compared models,
    # so no --compare-boundary
    words = command_arguments(_doc("evaluate-decoder", {"boundary": "average", "maps": 0,
                                                        "out": "runs/x"}, typed))
    # (and --windinet: its default became None, resolved by --map, in the fiftieth session)
    assert words == ["windnav", "evaluate-decoder", "--boundary", "average", "--windinet",
                     *typed[1:]]
    # with compared models, made before --compare-boundary: theirs named too
    cmp = [*typed, "--compare", "a=m.npz"]
    p = _parsed(command_arguments(_doc("evaluate-decoder", {"boundary": "average",
                                                            "compare": ["a=m.npz"]}, cmp)))
    assert (p["boundary"], _compared_rule(p)) == ("average", "average")
    blend_then = [*cmp, "--boundary", "blend"]   # the blend trial: compared one pass
    words = command_arguments(_doc("evaluate-decoder", {"boundary": "blend",
                                                        "compare": ["a=m.npz"]}, blend_then))
    assert words[2:4] == ["--compare-boundary", "average"]
    # made before the option: the value before (VALUES_BEFORE), typed or rebuilt
    for argv in (typed, None):
        p = _parsed(command_arguments(_doc("evaluate-decoder", {"maps": 0, "out": "runs/x"},
                                           argv)))
        assert p["boundary"] == VALUES_BEFORE["evaluate-decoder"]["boundary"] == "average"
    # made with the new default, compared models following it: the line as typed
    blend = ["evaluate-decoder", "--out", "runs/y", "--compare", "a=m.npz"]
    assert command_arguments(_doc("evaluate-decoder", {"boundary": "blend",
                                                       "compare_boundary": None,
                                                       "compare": ["a=m.npz"], "maps": None,
                                                       "windinet": None,
                                                       "out": "runs/y"}, blend)) == \
        ["windnav", *blend]
    # a study, and a command with no such option: untouched
    study = ["decoder-study", "mosaic", "--out", "runs/s"]
    assert _parsed(command_arguments(_doc("decoder-study", {"study": "mosaic"}, study)))[
        "boundary"] == "average"
    fly = ["fly", "--duration", "1", "--out", "runs/f"]
    assert command_arguments(_doc("fly", {"duration": 1.0}, fly)) == ["windnav", *fly]


def test_the_added_words_survive_a_list_option_and_a_line_that_no_longer_parses_is_named():
    typed = ["evaluate-decoder", "--out", "x", "--rotations-deg", "0", "-3", "3"]
    words = command_arguments(_doc("evaluate-decoder", {"boundary": "average"}, typed))
    p = _parsed(words)
    assert p["rotations_deg"] == [0.0, -3.0, 3.0] and p["boundary"] == "average"
    with pytest.raises(ValueError, match="no longer parses"):
        command_arguments(_doc("evaluate-decoder", {"boundary": "average"},
                               ["evaluate-decoder", "--out", "x", "--frobnicate"]))


def test_the_committed_one_pass_evaluation_names_its_rule():
    words = command_arguments(json.loads((DOCS / "decoder_eval_windinet_2026-12-06.json")
                                         .read_text()))
    p = _parsed(words)
    assert (p["boundary"], _compared_rule(p)) == ("average", "average")
    words = command_arguments(json.loads((DOCS / "decoder_eval_windinet_blend.json")
                                         .read_text()))
    p = _parsed(words)
    assert (p["boundary"], _compared_rule(p)) == ("blend", "average")


def _card_commands(text):
    """The model card's decoder commands (line number, words): fenced lines (joined over
    backslash continuations) and inline code spans of three words or more."""
    import re

    pat = re.compile(r"windnav (evaluate-decoder|predict|decoder-study (gradients|mosaic|"
                     r"direction|averaging|start|noise|basis))\b")
    fences = [m.start() for m in re.finditer(r"^```", text, flags=re.M)]
    assert len(fences) % 2 == 0
    ranges = list(zip(fences[::2], fences[1::2], strict=True))
    out = []
    for a, b in ranges:
        lines = text[a:b].split("\n")
        i = 0
        while i < len(lines):
            j = i
            while lines[j].rstrip().endswith("\\") and j + 1 < len(lines):
                j += 1
            line = " ".join(lines[i:j + 1]).split("  #")[0]
            if pat.search(line):
                out.append((text[:a].count("\n") + i + 1, line.split()))
            i = j + 1
    for m in re.finditer(r"`([^`]*)`", text):
        if any(a <= m.start() < b for a, b in ranges) or not pat.search(m.group(1)):
            continue
        words = m.group(1).split()
        if len(words) >= 3 and words[-1] != "--seed" and words[-2:] != ["--seed", "0"]:
            out.append((text[:m.start()].count("\n") + 1, words))
    return out


def test_every_decoder_command_of_the_model_card_names_its_rule():
    """Since blend became the default, a command in docs/decoder.md that made a one-pass
    figure must say --boundary average, or rerunning it gives the blend's figures; the new
    ones say --boundary blend. Compared models under another rule say --compare-boundary."""
    text = (DOCS.parent / "decoder.md").read_text()
    found = _card_commands(text)
    assert len(found) >= 40
    unnamed = [(line, " ".join(w)[:80]) for line, w in found if "--boundary" not in w]
    assert unnamed == []
    for line, words in found:
        rule = words[words.index("--boundary") + 1]
        if rule == "blend" and any(w.startswith("one-pass=") for w in words):
            assert "--compare-boundary" in words, line
