"""The decoder in flight (windnav.experiments.nav_inflight): samples along a flown path, scored
against the flow's mean field, and the input errors of the onboard W_robot."""

import re

import numpy as np
import pytest
from scipy.interpolate import RegularGridInterpolator

from windnav.experiments import nav_inflight as ni
from windnav.experiments.nav_suite import SuiteSpec, make_suite
from windnav.experiments.navigate import navigate
from windnav.experiments.onboard import smooth_wind
from windnav.predict import LocalBaseline, field_errors
from windnav.predict.dataset import field_from_solution

START, GOAL = (10.0, 60.0), (110.0, 60.0)
TINY = SuiteSpec(
    "tiny", maps=(0,), winds=(0, 1), pairs=(0, 1), speeds=(3.0,), incidences_deg=(0.0, 90.0),
    n_tailwind=1, n_headwind=1, pair_distance=100.0, clearance=25.0, edge=15.0, map_size=200.0,
    map_options={"n_buildings": 2, "side_range": (10.0, 20.0)}, spinup_s=5.0, record_s=30.0)


@pytest.fixture(scope="module")
def flight(city, flow):
    return navigate(city, START, GOAL, speed=2.0, direction_deg=0.0, variant="ea-mppi-w-hat",
                    flow=flow, rng=0, duration=12.0)


class Oracle:
    """A 'decoder' that returns the labels it is keyed to (exact), on the default grid."""

    def __init__(self, samples):
        self.offsets = np.arange(-12.0, 13.0)
        self.samples = samples

    def predict(self, scans, w_up, w_robot):
        return self.samples["labels"].copy()


def test_samples_follow_the_flight_and_the_mean_field(city, flow, flight):
    offsets = np.arange(-12.0, 13.0)
    s = ni.inflight_samples(flight, city, flow, offsets, every_s=0.5, settle_s=2.0, rng=0)
    n = s["t"].size
    assert n == 20  # 2.0, 2.5, ..., 11.5 s: at 12.0 s (the last step) the UKF had not run
    np.testing.assert_allclose(s["t"], 2.0 + 0.5 * np.arange(n), atol=1e-9)
    k = np.rint(s["t"] / (flight.t[1] - flight.t[0])).astype(int)
    np.testing.assert_array_equal(s["position"], flight.position[k, :2])
    np.testing.assert_array_equal(s["inst"], flight.wind[k, :2])
    np.testing.assert_array_equal(s["ukf"], flight.wind_estimate[k, :2])
    # the mean wind at the vehicle, against SciPy's bilinear interpolation of the mean field
    for comp, f in enumerate((flow.mean_u, flow.mean_v)):
        want = RegularGridInterpolator((flow.y, flow.x), f)(s["position"][:, ::-1])
        np.testing.assert_allclose(s["mean"][:, comp], want, rtol=0, atol=1e-12)
    labels, free = field_from_solution(city, flow).grid_values(s["position"], offsets)
    np.testing.assert_array_equal(s["labels"], labels)
    np.testing.assert_array_equal(s["free"], free)
    assert s["scans"].shape == (n, 360) and np.all(s["scans"] >= 0.25)
    np.testing.assert_array_equal(s["w_up"], np.tile([2.0, 0.0], (n, 1)))
    # the same seed, the same scans
    again = ni.inflight_samples(flight, city, flow, offsets, every_s=0.5, settle_s=2.0, rng=0)
    np.testing.assert_array_equal(again["scans"], s["scans"])
    assert not any(key.startswith("ukf_tau") for key in s)
    # averaged estimates: the whole flight's estimate smoothed, then sampled at the same steps
    avg = ni.inflight_samples(flight, city, flow, offsets, every_s=0.5, settle_s=2.0, rng=0,
                              taus=(1.0, 4.0))
    for tau in (1.0, 4.0):
        want = smooth_wind(flight.wind_estimate[:, :2], flight.t[1] - flight.t[0], tau)[k]
        np.testing.assert_array_equal(avg[ni.smoothed_key(tau)], want)
    assert ni.smoothed_key(4.0) == "ukf_tau4" and ni.smoothed_key(0.5) == "ukf_tau0.5"
    assert np.abs(avg["ukf_tau4"] - s["ukf"]).max() > 0.0
    with pytest.raises(ValueError, match="'taus'"):
        ni.inflight_samples(flight, city, flow, offsets, taus=(0.0,))


def test_errors_against_independent_arithmetic(city, flow, flight):
    s = ni.inflight_samples(flight, city, flow, np.arange(-12.0, 13.0), rng=1)
    s["ukf"] = s["mean"] + np.array([3.0, 4.0])  # 5 m/s off the mean, everywhere
    out = ni.inflight_errors(s, Oracle(s))
    assert out["n_samples"] == s["t"].size
    assert out["inputs"]["ukf_vs_mean"] == pytest.approx(5.0, abs=1e-12)
    d = s["inst"] - s["mean"]
    assert out["inputs"]["inst_vs_mean"] == pytest.approx(
        np.sqrt(np.mean(d[:, 0] ** 2 + d[:, 1] ** 2)), rel=1e-12)
    for wind in ("ukf", "mean", "inst"):
        assert out["errors"][f"decoder_{wind}"]["speed_error"] == 0.0
    # Local with the mean wind: a uniform field, scored by hand
    uniform = np.broadcast_to(s["mean"][:, :, None, None], s["labels"].shape)
    free = s["free"]
    speed_true = np.hypot(s["labels"][:, 0], s["labels"][:, 1])
    speed_pred = np.hypot(uniform[:, 0], uniform[:, 1])
    want = np.abs(speed_pred - speed_true)[free].mean()
    assert out["errors"]["local_mean"]["speed_error"] == pytest.approx(want, rel=1e-6)
    ref = field_errors(LocalBaseline().predict(s["scans"], s["w_up"], s["ukf"]), s["labels"],
                       free, s["speed"])
    assert out["errors"]["local_ukf"] == ref
    assert set(out["errors"]) == set(ni.MODELS)
    # a compared decoder that predicts calm air: its speed error is the mean label speed
    calm = Oracle(s)
    calm.predict = lambda scans, w_up, w_robot: np.zeros_like(s["labels"])
    more = ni.inflight_errors(s, Oracle(s), compare={"calm": calm})
    assert list(more["errors"]) == [*ni.MODELS, "calm_ukf", "calm_mean", "calm_inst"]
    for wind in ("ukf", "mean", "inst"):
        assert more["errors"][f"calm_{wind}"]["speed_error"] == pytest.approx(
            speed_true[free].mean(), rel=1e-6)
    assert {m: more["errors"][m] for m in ni.MODELS} == out["errors"]
    # an averaged estimate: its input error, and the decoder and Local given it
    s["ukf_tau2"] = s["mean"] + np.array([0.0, 2.0])
    avg = ni.inflight_errors(s, Oracle(s))
    assert list(avg["errors"]) == [*ni.MODELS, "decoder_ukf_tau2", "local_ukf_tau2"]
    assert avg["inputs"]["ukf_tau2_vs_mean"] == pytest.approx(2.0, abs=1e-12)
    assert avg["errors"]["local_ukf_tau2"] == field_errors(
        LocalBaseline().predict(s["scans"], s["w_up"], s["ukf_tau2"]), s["labels"], free,
        s["speed"])
    del s["ukf_tau2"]
    with pytest.raises(ValueError, match="'compare'.*identifier"):
        ni.inflight_errors(s, Oracle(s), compare={"local": calm})
    coarse = Oracle(s)
    coarse.offsets = np.arange(-12.0, 13.0, 2.0)
    with pytest.raises(ValueError, match="'compare'.*same cells"):
        ni.inflight_errors(s, Oracle(s), compare={"coarse": coarse})


def test_bad_input_is_refused(city, flow, flight):
    other = navigate(city, START, GOAL, speed=2.0, direction_deg=0.0, variant="ea-mppi-w",
                     flow=flow, rng=0, duration=2.0)
    with pytest.raises(ValueError, match="'result'.*onboard"):
        ni.inflight_samples(other, city, flow, np.arange(-12.0, 13.0))
    with pytest.raises(ValueError, match="'every_s'"):
        ni.inflight_samples(flight, city, flow, np.arange(-12.0, 13.0), every_s=0.0)
    with pytest.raises(ValueError, match="'variant'.*onboard"):
        ni.inflight_study(TINY, ["tiny/m00/w00/p0"], variant="ea-mppi-w")
    with pytest.raises(ValueError, match="scenario"):
        ni.inflight_study(TINY, ["tiny/m07/w00/p0"])


def test_the_study_flies_and_groups_by_speed():
    ids = [sc.scenario_id for sc in make_suite(TINY)][:2]  # the two pairs of one wind
    assert ids == ["tiny/m00/w00/p0", "tiny/m00/w00/p1"]
    res = ni.inflight_study(TINY, ids, every_s=1.0, executor="serial", progress=False,
                            taus=(3.0, 1.0))
    assert res["errors"] == {} and list(res["flights"]) == ids
    assert list(res["by_speed"]) == [3.0] and res["by_speed"][3.0]["flights"] == 2
    n = sum(f["samples"] for f in res["flights"].values())
    assert res["by_speed"][3.0]["n_samples"] == res["all"]["n_samples"] == n > 0
    assert res["taus"] == [1.0, 3.0]
    assert {"ukf_tau1_vs_mean", "ukf_tau3_vs_mean"} <= set(res["all"]["inputs"])
    lines = ni.summarize_inflight(res)
    assert len(lines) == 9 and lines[2].startswith("| 3 | 2 (")
    assert lines[5].startswith("| inlet (m/s) | tau = 0 s:") and "tau = 3 s" in lines[5]


def test_the_command_writes_the_table_json_and_figure(tmp_path, monkeypatch, capsys):
    import json

    from windnav import cli

    real, asked = ni.inflight_study, {}

    def on_tiny(spec, ids, **kw):  # the command's plumbing, on the tiny suite's flights
        asked.update(spec=spec.name, ids=list(ids), **kw)
        return real(TINY, ["tiny/m00/w00/p0", "tiny/m00/w01/p0"], **{**kw, "executor": "serial"})

    monkeypatch.setattr(ni, "inflight_study", on_tiny)
    out = tmp_path / "inflight"
    assert cli.main(["nav-study", "inflight", "--suite", "quick", "--maps", "0", "--pairs", "0",
                     "--every", "1", "--out", str(out), "--no-progress"]) == 0
    assert asked["spec"] == "quick" and asked["every_s"] == 1.0
    assert asked["variant"] == ni.INFLIGHT_VARIANT
    assert asked["ids"] and all(i.startswith("quick/m00/") and i.endswith("/p0")
                                for i in asked["ids"])
    doc = json.loads((out / "nav_inflight.json").read_text())
    assert doc["study"] == "inflight" and doc["pairs"] == [0] and doc["maps"] == [0]
    assert doc["by_speed"]["3.0"]["flights"] == 2
    assert (out / "nav_inflight.png").stat().st_size > 10_000
    assert "| 3 | 2 (" in capsys.readouterr().out
    # another decoder scored on the same samples: the shipped default, beside the pinned one
    from windnav.predict.decoder import DEFAULT_MODEL

    out2 = tmp_path / "inflight2"
    assert cli.main(["nav-study", "inflight", "--suite", "quick", "--maps", "0", "--pairs", "0",
                     "--every", "1", "--out", str(out2), "--no-progress",
                     "--compare", f"shipped={DEFAULT_MODEL}", "--tau", "2"]) == 0
    doc2 = json.loads((out2 / "nav_inflight.json").read_text())
    assert doc2["taus"] == [2.0] and "decoder_ukf_tau2" in doc2["all"]["errors"]
    assert (out2 / "nav_inflight_tau.png").stat().st_size > 10_000
    assert not (out / "nav_inflight_tau.png").exists()
    assert doc2["compare"] == ["shipped"] and doc2["models"] == {"shipped": str(DEFAULT_MODEL)}
    # the compared file by hash, so that its line names the dated file once it is replaced
    from windnav.predict.decoder import model_sha256

    assert doc2["model_files"] == {"compare": {f"shipped={DEFAULT_MODEL}": {
        "path": str(DEFAULT_MODEL), "sha256": model_sha256(DEFAULT_MODEL)}}}
    assert "model_files" not in doc
    assert "shipped_ukf" in doc2["all"]["errors"]
    assert "| inlet (m/s) | decoder, UKF |" in capsys.readouterr().out
    for bad, why in ((["--pairs", "7"], "'--pairs' parameter"),
                     (["--variant", "ea-mppi-w"], "'--variant' parameter"),
                     (["--every", "0"], "'--every' parameter"),
                     (["--tau", "0"], "'--tau' parameter"),
                     (["--compare", str(tmp_path / "none.npz")], "'--compare' parameter"),
                     # read before the study, naming the option, not load_decoder's 'path'
                     (["--compare", f"x={tmp_path / 'x.npz'}"], "'--compare' parameter of "
                      "windnav nav-study must name a windnav decoder file")):
        np.savez(tmp_path / "x.npz", a=np.zeros(3))
        monkeypatch.setattr(ni, "inflight_study", real)
        assert cli.main(["nav-study", "inflight", "--suite", "quick", "--maps", "0",
                         "--out", str(tmp_path / "bad"), *bad]) == 2
        assert why in capsys.readouterr().err
    assert cli.main(["nav-study", "bound", "--out", str(tmp_path / "b"), "--store",
                     str(tmp_path / "s"), "--compare", "x=y.npz"]) == 2
    assert "'--compare' parameter" in capsys.readouterr().err
    # every option a study does not read is refused (they were ignored, the JSON's arguments
    # alone differing; CLI audit, 2026-12-05)
    for study, bad, why in (("bound", ["--variant", "mppi"], "'--variant' parameter .* is for "
                                                              "the cases, pace, inflight"),
                            ("bound", ["--values", "3"], "'--values' parameter"),
                            ("bound", ["--seed", "7"], "'--seed' parameter .* gs study"),
                            ("winds", ["--maps", "0"], "'--maps' parameter"),
                            ("gs", ["--map", "0"], "'--map' parameter .* is for the qe, h, cases, "
                                                  "winds"),
                            ("gusts", ["--every", "1"], "'--every' parameter")):
        assert cli.main(["nav-study", study, "--out", str(tmp_path / "o"), "--store",
                         str(tmp_path / "s"), *bad] if study == "bound" else
                        ["nav-study", study, "--out", str(tmp_path / "o"), *bad]) == 2
        err = capsys.readouterr().err
        assert re.search(why, err), err


def test_the_command_resumes_an_interrupted_study_with_the_same_result(tmp_path, monkeypatch,
                                                                       capsys):
    """Ctrl-C after the first wind keeps it in the output folder's record log; the rerun flies
    only the other wind and writes what an uninterrupted run writes (but the timings)."""
    import json

    from windnav import cli

    real_study, real_fly = ni.inflight_study, ni._fly_wind
    ids = ["tiny/m00/w00/p0", "tiny/m00/w01/p0"]  # two winds
    monkeypatch.setattr(ni, "inflight_study", lambda spec, _ids, **kw: real_study(
        TINY, ids, **{**kw, "executor": "serial"}))
    flown = []

    def fly(task, stop_at=None):
        if len(flown) == stop_at:
            raise KeyboardInterrupt
        flown.append(task[1])
        return real_fly(task)

    def command(out, *more):
        return cli.main(["nav-study", "inflight", "--suite", "quick", "--maps", "0", "--pairs",
                         "0", "--every", "1", "--tau", "2", "--out", str(out), "--no-progress",
                         *more])

    def untimed(doc):
        return {**{k: v for k, v in doc.items() if k not in ("elapsed_s", "arguments", "argv")},
                "arguments": {k: v for k, v in doc["arguments"].items() if k != "out"}}

    monkeypatch.setattr(ni, "_fly_wind", fly)
    assert command(tmp_path / "whole") == 0 and len(flown) == 2
    whole = json.loads((tmp_path / "whole" / "nav_inflight.json").read_text())
    assert sorted(p.name for p in (tmp_path / "whole").iterdir()) == [
        "nav_inflight.json", "nav_inflight.png", "nav_inflight_tau.png"]  # no record log left

    out, log = tmp_path / "cut", tmp_path / "cut" / ni.RECORDS
    flown.clear()
    monkeypatch.setattr(ni, "_fly_wind", lambda task: fly(task, stop_at=1))
    capsys.readouterr()
    assert command(out) == 130
    assert f"the finished winds are kept in {log}" in capsys.readouterr().err
    assert sorted(p.name for p in out.iterdir()) == [ni.RECORDS]  # no result written
    assert len(log.read_text().splitlines()) == 2  # the header and the first wind
    flown.clear()
    monkeypatch.setattr(ni, "_fly_wind", fly)
    assert command(out) == 0
    assert flown == [["tiny/m00/w01/p0"]]  # the first wind was not flown again
    doc = json.loads((out / "nav_inflight.json").read_text())
    assert untimed(doc) == untimed(whole)
    assert not log.exists()
    assert (out / "nav_inflight.png").read_bytes() == (
        tmp_path / "whole" / "nav_inflight.png").read_bytes()

    # a record log of another study (here: another --every) is refused, never mixed in
    other = tmp_path / "other"
    other.mkdir()
    stale = ni.records_header(TINY, ni.INFLIGHT_VARIANT, 2.0, (2.0,))
    (other / ni.RECORDS).write_text(json.dumps({"header": stale}) + "\n")
    flown.clear()
    assert command(other) == 2 and flown == []
    err = capsys.readouterr().err
    assert "'--out' parameter" in err and "another inflight study" in err
    assert "--overwrite" in err and (other / ni.RECORDS).exists()


def test_the_suites_own_decoder_is_flown_scored_and_named_in_the_header(monkeypatch):
    """``nav-study inflight --decoder FILE`` puts the file's decoder among the suite's
    ``navigate_options``: the onboard stack flies it (``fly``), the study scores that decoder
    (it scored the benchmark's pinned one), and the record log's header names it by its
    fingerprint, so a log of another decoder is another study's. A label's ``@decoder=`` still
    flies its dated file."""
    from dataclasses import replace

    import windnav.experiments.navigate as navigate_module
    from windnav.experiments import nav_benchmark as nb
    from windnav.predict import load_decoder
    from windnav.predict.decoder import DEFAULT_MODEL

    mine = load_decoder(DEFAULT_MODEL.with_name("decoder_2026-12-01.npz"), boundary="blend")
    spec = replace(TINY, navigate_options={"decoder": mine})
    assert ni._decoder(ni.INFLIGHT_VARIANT, spec) is mine
    assert ni._decoder(f"{ni.INFLIGHT_VARIANT}@decoder=2026-11-26", spec) is \
        nb.benchmark_decoder("2026-11-26")
    header = ni.records_header(spec, ni.INFLIGHT_VARIANT, 1.0, ())
    assert header["decoder"] == {"name": "suite", "fingerprint": mine.fingerprint()}
    assert header["settings_hash"] != ni.records_header(TINY, ni.INFLIGHT_VARIANT, 1.0,
                                                        ())["settings_hash"]
    flown, scored = [], []
    real_navigate, real_errors = navigate_module.navigate, ni.inflight_errors

    def spy_navigate(*a, **kw):
        flown.append(kw.get("decoder"))
        return real_navigate(*a, **kw)

    def spy_errors(samples, decoder, compare=None):
        scored.append(decoder)
        return real_errors(samples, decoder, compare)

    monkeypatch.setattr(navigate_module, "navigate", spy_navigate)
    monkeypatch.setattr(ni, "inflight_errors", spy_errors)
    res = ni.inflight_study(spec, ["tiny/m00/w00/p0"], every_s=1.0, executor="serial",
                            progress=False)
    assert res["errors"] == {} and flown == [mine] and scored and all(d is mine for d in scored)


def test_the_command_flies_and_scores_the_decoder_file_given(tmp_path, monkeypatch, capsys):
    """``nav-study inflight --decoder FILE``: the study gets the suite with that decoder, and
    the JSON records the file; the pinned decoder's views with it are refused."""
    import json
    from dataclasses import replace

    from windnav import cli
    from windnav.predict.decoder import DEFAULT_MODEL, model_sha256

    file = DEFAULT_MODEL.with_name("decoder_2026-12-01.npz")
    real, asked = ni.inflight_study, {}

    def on_tiny(spec, ids, **kw):  # the command's suite, decoder included, on a tiny flight
        asked["decoder"] = spec.navigate_options.get("decoder")
        return real(replace(TINY, navigate_options=spec.navigate_options), ["tiny/m00/w00/p0"],
                    **{**kw, "executor": "serial"})

    monkeypatch.setattr(ni, "inflight_study", on_tiny)
    out = tmp_path / "mine"
    assert cli.main(["nav-study", "inflight", "--suite", "quick", "--maps", "0", "--pairs", "0",
                     "--every", "1", "--decoder", str(file), "--out", str(out),
                     "--no-progress"]) == 0
    from windnav.predict import load_decoder

    assert asked["decoder"].fingerprint() == load_decoder(file).fingerprint()
    doc = json.loads((out / "nav_inflight.json").read_text())
    assert doc["decoder_file"] == {"path": str(file), "sha256": model_sha256(file)}
    capsys.readouterr()
    assert cli.main(["nav-study", "inflight", "--suite", "quick", "--maps", "0", "--variant",
                     f"{ni.INFLIGHT_VARIANT}@views=3", "--decoder", str(file), "--out",
                     str(tmp_path / "x")]) == 2
    assert re.search(r"'--variant' parameter .* \('@views=' without", capsys.readouterr().err)
    assert not (tmp_path / "x").exists()


def test_a_record_log_flown_with_another_decoder_is_refused(tmp_path, monkeypatch):
    """Audit: the record log's header named the variant but not the decoder it flew, so a log
    flown with the benchmark's earlier pinned decoder was resumed after a re-pin and its winds
    mixed into a study of another decoder. The header now holds the decoder's file and SHA-256,
    and such a log is refused (before any flight) like another configuration's."""
    import json

    from windnav.experiments import nav_benchmark as nb
    from windnav.experiments.results import RecordMismatchError

    header = ni.records_header(TINY, ni.INFLIGHT_VARIANT, 1.0, ())
    file, sha = nb.DECODERS[nb.BENCHMARK_DECODER]
    assert header["decoder"] == {"name": nb.BENCHMARK_DECODER, "file": file,
                                 "sha256": sha[:16]}
    assert ni.records_header(TINY, f"{ni.INFLIGHT_VARIANT}@decoder=2026-11-26", 1.0,
                             ())["decoder"]["file"] == "decoder_2026-11-26.npz"
    # the turned views (@views=) are part of the decoder flown, so of the header
    viewed = ni.records_header(TINY, f"{ni.INFLIGHT_VARIANT}@views=3", 1.0, ())["decoder"]
    assert viewed == {**header["decoder"], "rotations_deg": [0.0, -3.0, 3.0]}
    # and the decoder the study scores is the one flown: with the views
    assert ni._decoder(f"{ni.INFLIGHT_VARIANT}@views=3").rotations_deg == (0.0, -3.0, 3.0)
    assert ni._decoder(ni.INFLIGHT_VARIANT) is nb.benchmark_decoder()
    log = tmp_path / ni.RECORDS
    log.write_text(json.dumps({"header": header}) + "\n")
    flown = []
    monkeypatch.setattr(ni, "_fly_wind", lambda task: flown.append(task) or [])
    monkeypatch.setattr(nb, "BENCHMARK_DECODER", "2026-11-26")  # the benchmark re-pinned
    with pytest.raises(RecordMismatchError, match="another study"):
        ni.inflight_study(TINY, ["tiny/m00/w00/p0"], every_s=1.0, executor="serial",
                          progress=False, records=log)
    assert flown == [] and log.read_text() == json.dumps({"header": header}) + "\n"
