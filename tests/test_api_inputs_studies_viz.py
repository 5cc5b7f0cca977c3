"""Bad inputs to the navigation studies, the tuning and Monte Carlo studies and the figures:
each refused up front with a ValueError naming the argument (Python API audit, fifty-eighth
session). Each test says what happened before."""

from __future__ import annotations

import gzip
import json
import math
from pathlib import Path
from types import SimpleNamespace

import matplotlib.pyplot as plt
import numpy as np
import pytest

import windnav.experiments.gs_cases as GC
import windnav.experiments.nav_bound as NB
import windnav.experiments.nav_feasibility as NF
import windnav.experiments.nav_gusts as NG
import windnav.experiments.nav_inflight as NI
import windnav.experiments.nav_pace as NP
import windnav.experiments.nav_sweeps as NS
import windnav.experiments.nav_tilt as NT
import windnav.experiments.thesis_nav as TN
import windnav.experiments.tune_mppi as TU
import windnav.experiments.ukf_montecarlo as MC
import windnav.viz.animate as VA
import windnav.viz.city as VCITY
import windnav.viz.decoder as VD
import windnav.viz.demo as VDEMO
import windnav.viz.gs_cases as VGS
import windnav.viz.nav_compare as VNC
import windnav.viz.nav_studies as VN
import windnav.viz.nav_sweeps as VS
import windnav.viz.tune as VT
import windnav.viz.ukf as VU

ROOT = Path(__file__).resolve().parents[1]
DOCS = ROOT / "docs"


@pytest.fixture(scope="module")
def recs():
    """The thesis store's records of a few variants (the studies' own input)."""
    keep = {"mppi", "ea-mppi-w", "gs-w", "mppi-w", "ea-mppi"}
    with gzip.open(DOCS / "navigation" / "thesis_records.jsonl.gz", "rt") as fh:
        return [r for r in map(json.loads, fh) if r["variant"] in keep]


def _doc(name: str) -> dict:
    return json.loads((DOCS / name).read_text())


# ----------------------------------------------------------------------------- nav_bound


@pytest.mark.parametrize("kwargs, match", [
    # before: the unknown variant was left out of the result silently
    ({"variants": ["foo"]}, "'variants' parameter of bound_study"),
    # before: intervals at "confidence" 2 or 0 were computed
    ({"confidence": 2}, "'confidence' parameter of bound_study"),
    ({"confidence": 0}, "'confidence' parameter of bound_study"),
    ({"confidence": math.nan}, "'confidence' parameter of bound_study"),
])
def test_bound_study_refuses_unknown_variants_and_confidence_outside_0_1(recs, kwargs, match):
    # Python API audit, fifty-eighth session
    with pytest.raises(ValueError, match=match):
        NB.bound_study(recs, **kwargs)


@pytest.mark.parametrize("args, match", [
    (([1.0, 2.0, 3.0], 5.0, math.nan), "'failure_pct'"),    # before: 0.8 with overflow warnings
    (([math.inf, 2.0, 3.0], 5.0, 0.0), "'ideal'"),          # before: -1.2e307
    (([1.0, -2.0, 3.0], 5.0, 0.0), "'ideal'"),              # before: a number
    (([1.0, 2.0, 3.0], math.inf, 0.0), "'reference_mean_J'"),  # before: 1.0
    (([1.0, 2.0, 3.0], 5.0, 150.0), "'failure_pct'"),       # before: accepted
    (([1.0, 2.0, 3.0], 5.0, -10.0), "'failure_pct'"),       # before: IndexError
    (([1.0, 2.0, 3.0], 5.0, [0.0, 101.0]), "'failure_pct'"),
])
def test_ideal_table_ratio_refuses_non_finite_energies_and_rates_outside_0_100(args, match):
    # Python API audit, fifty-eighth session
    with pytest.raises(ValueError, match=match + " parameter of ideal_table_ratio"):
        NB.ideal_table_ratio(*args)


def test_ideal_table_ratio_of_valid_inputs_is_unchanged():
    got = NB.ideal_table_ratio([4.0, 1.0, 3.0, 2.0], 10.0, [0.0, 25.0, 49.0, 50.0, 100.0])
    np.testing.assert_allclose(got, [0.75, 0.8, 0.8, 0.85, 0.9])
    np.testing.assert_allclose(NB.ideal_table_ratio([4.0, math.nan], 10.0, 0.0), 0.8)


@pytest.mark.parametrize("bad", [[{}], None, {"a": 3}])
def test_ideal_energy_refuses_what_is_not_a_dict_of_records(bad):
    # Python API audit, fifty-eighth session: before, AttributeError (a list) or TypeError
    with pytest.raises(ValueError, match="'route_records' parameter of ideal_energy"):
        NB.ideal_energy(bad)


# ------------------------------------------------------------------------------ nav_pace


@pytest.mark.parametrize("args, kwargs, match", [
    ((), {"confidence": math.nan}, "'confidence'"),   # before: accepted
    ((), {"confidence": 1}, "'confidence'"),           # before: accepted
    (("mppi", "mppi"), {}, "'variant'"),               # before: the reference against itself
    ((None,), {}, "'variant'"),
])
def test_pace_study_refuses_bad_confidence_and_the_reference_against_itself(recs, args,
                                                                            kwargs, match):
    # Python API audit, fifty-eighth session
    with pytest.raises(ValueError, match=match + " parameter of pace_study"):
        NP.pace_study(recs, *args, **kwargs)


# ---------------------------------------------------------------------------- nav_sweeps


@pytest.mark.parametrize("labels", [{}, {1.0: "nonexistent"}, {0.0: "mppi"}, None])
def test_sweep_table_refuses_empty_labels_or_labels_none_of_which_was_flown(recs, labels):
    # Python API audit, fifty-eighth session: before, a table without rows. (A value not yet
    # flown beside others that were is left out, as tests/test_nav_sweeps.py has it.)
    with pytest.raises(ValueError, match="'labels' parameter of sweep_table"):
        NS.sweep_table(recs, labels)


# ------------------------------------------------------------------------------ nav_tilt


@pytest.mark.parametrize("variants", [[], "mppi", ["mppi", "mppi"], [None]])
def test_tilt_study_refuses_no_variants(recs, variants):
    # Python API audit, fifty-eighth session: before, "set.intersection() needs an argument"
    with pytest.raises(ValueError, match="'variants' parameter of tilt_study"):
        NT.tilt_study(recs, variants=variants)


@pytest.mark.parametrize("tilt", [math.nan, 0.0, 80.0, -5.0, "70", None])
def test_tilt_label_refuses_a_cap_outside_0_80(tilt):
    # Python API audit, fifty-eighth session: before, NaN gave "mppi@tilt=nan"
    with pytest.raises(ValueError, match="'tilt' parameter of tilt_label"):
        NT.tilt_label("mppi", tilt)


def test_tilt_label_of_valid_caps_is_unchanged():
    assert NT.tilt_label("mppi", 55.0) == "mppi"
    assert NT.tilt_label("ea-mppi-w", 70) == "ea-mppi-w@tilt=70"


# ---------------------------------------------------- nav_feasibility, thesis_nav


def test_reach_table_refuses_an_airspeed_the_records_were_not_searched_at():
    # Python API audit, fifty-eighth session: before, KeyError '7.77'
    reach = [{"scenario_id": "s", "speed": 2.0, "kind": "t", "limits": {"10": {}}}]
    with pytest.raises(ValueError, match=r"'airspeed' parameter of reach_table.*\['10'\]"):
        NF.reach_table(reach, airspeed=7.77)


@pytest.mark.parametrize("args", [("foo",), ("ea-mppi-w", "bar"), (["mppi"],)])
def test_thesis_table_ratio_refuses_a_variant_not_in_the_ablation_table(args):
    # Python API audit, fifty-eighth session: before, KeyError
    with pytest.raises(ValueError, match="parameter of table_ratio must be one of"):
        TN.table_ratio(*args)
    assert TN.table_ratio() == pytest.approx(1.0 - 10.81 / 13.61)


# ---------------------------------------------------------------------------- nav_inflight


@pytest.mark.parametrize("tau", [-1, 0, math.nan, math.inf, "x"])
def test_smoothed_key_refuses_a_time_constant_that_is_not_positive(tau):
    # Python API audit, fifty-eighth session: before, "ukf_tau-1"
    with pytest.raises(ValueError, match="'tau_s' parameter of smoothed_key"):
        NI.smoothed_key(tau)


def test_records_header_takes_a_suite_name_as_inflight_study_does():
    # Python API audit, fifty-eighth session: before, AttributeError ('str' has no 'name')
    head = NI.records_header("thesis", NI.INFLIGHT_VARIANT, 0.5, [])
    assert head["suite"] == "thesis" and head["seed"] == 0
    with pytest.raises(ValueError, match="'spec' parameter of records_header"):
        NI.records_header("nope", NI.INFLIGHT_VARIANT, 0.5, [])


def test_inflight_study_names_its_variant_parameter():
    # Python API audit, fifty-eighth session: before, the message named 'variants'
    with pytest.raises(ValueError, match="The 'variant' parameter of inflight_study"):
        NI.inflight_study("thesis", ["thesis/m00/w00/p0"], variant="foo")


# ----------------------------------------------------------------------------- nav_gusts


@pytest.mark.parametrize("kwargs, name", [
    ({"base": "foo"}, "base"),                 # before: "The 'variants' parameter of ..."
    ({"scenario_id": "nope"}, "scenario_id"),  # before: "'scenario_ids' parameter of fly_cases"
    ({"scenario_id": 3}, "scenario_id"),
    ({"spec": "nope"}, "spec"),
])
def test_gust_routes_names_its_own_parameters_before_any_flight(monkeypatch, kwargs, name):
    # Python API audit, fifty-eighth session
    monkeypatch.setattr(NG, "fly_cases", lambda *a, **k: pytest.fail("flew"))
    with pytest.raises(ValueError, match=f"The '{name}' parameter of gust_routes"):
        NG.gust_routes(**kwargs)


# ------------------------------------------------------------------------- ukf_montecarlo


@pytest.mark.parametrize("kwargs, name", [
    ({"q": {"foo": 1.0}}, "q"),               # before: accepted, every trial failed
    ({"q": {"wind": -1.0}}, "q"),             # before: accepted
    ({"q": ["wind"]}, "q"),
    ({"r": {"bar": 0.1}}, "r"),
    ({"r": {"accel": 0.0}}, "r"),
    ({"wind_frame": "foo"}, "wind_frame"),    # before: accepted
    ({"mass": (0.1, 0.2, 0.3)}, "mass"),      # before: "too many values to unpack"
    ({"radius": 3.0}, "radius"),              # before: "cannot unpack non-iterable float"
])
def test_montecarlo_config_checks_its_filter_tuning_and_ranges(kwargs, name):
    # Python API audit, fifty-eighth session
    with pytest.raises(ValueError, match=f"The '{name}' parameter of MonteCarloConfig"):
        MC.MonteCarloConfig(**kwargs)


def test_montecarlo_config_keeps_valid_tuning():
    cfg = MC.MonteCarloConfig(q={"wind": 0.7}, r={"accel": 0.2}, wind_frame="body")
    assert cfg.q["wind"] == 0.7 and cfg.r["accel"] == 0.2 and cfg.wind_frame == "body"
    assert MC.MonteCarloConfig().q["wind"] == MC.FILTER_Q["wind"]


@pytest.mark.parametrize("call, match", [
    (lambda: MC.summarize([{"a": 1}]), "'records' parameter of summarize"),  # before: KeyError
    (lambda: MC.mass_to_drag(None), "'p' parameter of mass_to_drag"),  # before: AttributeError
    (lambda: MC.draw_trials(None), "'config' parameter of draw_trials"),  # before: same
])
def test_montecarlo_functions_name_a_wrong_argument(call, match):
    # Python API audit, fifty-eighth session
    with pytest.raises(ValueError, match=match):
        call()


# ------------------------------------------------------------------------------ tune_mppi


@pytest.mark.parametrize("summary", [{}, {"outcome": "timeout"}, {"outcome": "success"}, None])
def test_flight_cost_refuses_a_summary_without_its_keys(summary):
    # Python API audit, fifty-eighth session: before, KeyError 'outcome' (or the others)
    with pytest.raises(ValueError, match="'summary' parameter of flight_cost"):
        TU.flight_cost(summary, 45.0)
    assert TU.flight_cost({"outcome": "success", "time_s": 20.0}, 45) == 20.0


@pytest.mark.parametrize("function", [TU.objective, TU.evaluate])
@pytest.mark.parametrize("params", [{"horizon": 30.0}, {"variant": "gs"}, {"foo": 1.0}, [1]])
def test_the_tuning_objective_names_its_params(function, params):
    # Python API audit, fifty-eighth session: before, "planner_config() got multiple values for
    # keyword argument 'horizon'", or planner_config's 'overrides' named
    with pytest.raises(ValueError, match=f"'params' parameter of {function.__name__}"):
        function(params, seeds=(0,), duration=1.0)


# ------------------------------------------------------------------------------- gs_cases


@pytest.mark.parametrize("seed", [-1, "0", 1.5])
def test_run_case_checks_its_seed_before_the_wind(monkeypatch, seed):
    # Python API audit, fifty-eighth session: before, 6 s of flow, then "'rng' parameter of
    # navigate"
    import windnav.experiments.navigate as nav

    monkeypatch.setattr(nav, "simulate_flow", lambda *a, **k: pytest.fail("simulated"))
    with pytest.raises(ValueError, match="'seed' parameter of run_case"):
        GC.run_case("intersection", seed=seed)


@pytest.mark.parametrize("case", [{}, {"name": "x"}, None])
def test_case_summary_refuses_what_is_not_a_run_case_result(case):
    # Python API audit, fifty-eighth session: before, a bare KeyError
    with pytest.raises(ValueError, match="'case' parameter of case_summary"):
        GC.case_summary(case)


# ----------------------------------------------------------------------------------- viz


@pytest.fixture(scope="module")
def pace():
    return _doc("img/navigation/nav_pace.json")


def test_figure_path_follows_savefig(tmp_path):
    from windnav.viz import figure_path

    (tmp_path / "folder").mkdir()
    assert figure_path(tmp_path / "a.png", "f") == tmp_path / "a.png"
    assert figure_path(str(tmp_path / "a.PDF"), "f") == tmp_path / "a.PDF"
    assert figure_path(tmp_path / "noext", "f") == tmp_path / "noext.png"
    assert figure_path(str(tmp_path / "dot."), "f") == tmp_path / "dot.png"
    assert figure_path(tmp_path / "folder", "f") == tmp_path / "folder.png"
    assert figure_path(tmp_path / "new" / "sub" / "a.svg", "f").parent.is_dir()


def test_plot_evaluation_returns_the_file_it_wrote(tmp_path):
    # Python API audit, fifty-eighth session: before, PosixPath('.../noext'), which did not
    # exist (savefig wrote noext.png)
    ev = _doc("data/decoder_eval.json")
    out = VD.plot_evaluation(ev, tmp_path / "noext")
    assert out == tmp_path / "noext.png" and out.is_file()
    assert not (tmp_path / "noext").exists()


@pytest.mark.parametrize("name, written", [("noext", "noext.png"), ("folder", "folder.png"),
                                           ("missing/sub/p.png", "missing/sub/p.png"),
                                           ("p.png", "p.png")])
def test_a_plotter_returns_the_path_it_wrote(tmp_path, pace, name, written):
    # Python API audit, fifty-eighth session: before, the path as given (the folder, or a file
    # savefig never wrote), or a FileNotFoundError after drawing for a missing folder
    (tmp_path / "folder").mkdir()
    out = VS.plot_pace(pace, tmp_path / name)
    assert out == tmp_path / written and out.is_file()


@pytest.mark.parametrize("name", ["p.xyz", "isdir.png", "afile/p.png"])
def test_a_plotter_refuses_an_unwritable_path_before_drawing(tmp_path, monkeypatch, pace,
                                                             name):
    # Python API audit, fifty-eighth session: before, matplotlib's format error (or PIL's
    # IsADirectoryError) after the whole figure was drawn
    (tmp_path / "isdir.png").mkdir()
    (tmp_path / "afile").write_text("")
    monkeypatch.setattr(VS.plt, "subplots", lambda *a, **k: pytest.fail("drew"))
    with pytest.raises(ValueError, match="'path' parameter of plot_pace"):
        VS.plot_pace(pace, tmp_path / name)


_RESULT_PLOTTERS = [
    (VD.plot_evaluation, "evaluate_decoder"), (VD.plot_prediction, "predict_at"),
    (VD.plot_eigenflows, "eigenflow_study"), (VD.plot_gradients, "gradient_study"),
    (VD.plot_direction, "direction_study"), (VD.plot_basis, "basis_study"),
    (VD.plot_mosaic, "mosaic"), (VD.plot_winds_ablation, "winds_ablation"),
    (VD.plot_size_study, "size_study"), (VD.plot_noise, "noise_study"),
    (VD.plot_scaling, "scaling_study"), (VD.plot_averaging, "averaging_study"),
    (VD.plot_start, "start_study"), (VDEMO.plot_map, "run_demo"),
    (VDEMO.plot_wind_estimate, "run_demo"), (VGS.plot_gs_case, "run_case"),
    (VGS.plot_gs_case_energy, "run_case"), (VN.plot_wind_scenarios, "wind_scenarios"),
    (VN.plot_gust_routes, "gust_routes"), (VN.plot_inflight, "inflight_study"),
    (VN.plot_inflight_tau, "inflight_study"), (VS.plot_sweep, "sweep_table"),
    (VS.plot_pace, "pace_study"), (VS.plot_bound, "bound_study"),
    (VS.plot_tilt, "tilt_study"), (VT.plot_tuning, "tune"),
    (VU.plot_montecarlo, "run_montecarlo"),
]


@pytest.mark.parametrize("plot, producer", _RESULT_PLOTTERS,
                         ids=[p[0].__name__ for p in _RESULT_PLOTTERS])
def test_a_result_plotter_given_another_result_names_its_producer(tmp_path, plot, producer):
    # Python API audit, fifty-eighth session: before, KeyError 'pooled', 'offsets', 'curve'...
    # after opening the figure
    figures = set(plt.get_fignums())
    with pytest.raises(ValueError, match=rf"parameter of {plot.__name__} must be .*{producer}"):
        plot({}, tmp_path / "x.png")
    assert set(plt.get_fignums()) == figures
    assert not list(tmp_path.iterdir())


@pytest.mark.parametrize("call, match", [
    (lambda p: VCITY.plot_city(None, {}, p), "'summary' parameter of plot_city"),
    (lambda p: VN.plot_reach([], {}, p), "'table' parameter of plot_reach"),
    (lambda p: VNC.plot_energy({}, p), "'results' parameter of plot_energy"),  # before: blank
    (lambda p: VNC.plot_paths({}, None, None, p), "'results' parameter of plot_paths"),
])
def test_the_other_plotters_refuse_an_empty_input(tmp_path, call, match):
    # Python API audit, fifty-eighth session
    with pytest.raises(ValueError, match=match):
        call(tmp_path / "x.png")
    assert not (tmp_path / "x.png").exists()


@pytest.mark.parametrize("results, n_frames, match", [
    ({}, 10, "'results'"),                                   # before: max() of an empty sequence
    ({"a": SimpleNamespace(t=np.array([0.0, 2.0]))}, 1, "'n_frames'"),  # before: two frames
    ({"a": SimpleNamespace(t=np.array([0.0, 2.0]))}, math.nan, "'n_frames'"),
])
def test_frame_times_refuses_no_flights_or_fewer_than_two_frames(results, n_frames, match):
    # Python API audit, fifty-eighth session
    with pytest.raises(ValueError, match=match + " parameter of frame_times"):
        VA.frame_times(results, n_frames)
    flight = {"a": SimpleNamespace(t=np.array([0.0, 2.0]))}
    np.testing.assert_allclose(VA.frame_times(flight, 3), [0.0, 1.0, 2.0])


@pytest.mark.parametrize("kwargs, name", [({"step": -1.0}, "step"), ({"thinnest": 0.0},
                                                                    "thinnest"),
                                          ({"thinnest": math.nan}, "thinnest")])
def test_path_widths_refuses_widths_that_are_not_positive(kwargs, name):
    # Python API audit, fifty-eighth session: before, negative widths
    with pytest.raises(ValueError, match=f"'{name}' parameter of path_widths"):
        VNC.path_widths(5, **kwargs)
    with pytest.raises(ValueError, match="'n' parameter of path_widths"):
        VNC.path_widths(-1)
    assert VNC.path_widths(3) == [2.0 + 2 * 1.2, 2.0 + 1.2, 2.0]


@pytest.mark.parametrize("fn, keys", [
    ("plot_gradients", ("decoder", "decoder_per_U")),
    ("plot_eigenflows", ("world", "canonical", "size", "spacing", "n_fields")),
    ("plot_mosaic", ("x", "y", "truth", "prediction", "free", "covered", "n_robots", "size",
                     "robots", "metrics", "w_up", "name", "coverage"))])
def test_the_palette_plotters_take_png_alone(fn, keys, tmp_path):
    # review of the audit's mends: these write 128-colour PNG bytes whatever the suffix, and
    # figure_path approved a '.svg' (a file of PNG bytes named .svg)
    import windnav.viz.decoder as VD

    with pytest.raises(ValueError, match=f"'path' parameter of {fn} must end in a suffix {fn} "
                                         r"writes, one of \['png'\]"):
        getattr(VD, fn)(dict.fromkeys(keys), tmp_path / "f.svg")
    assert not (tmp_path / "f.svg").exists()


def test_nav_study_pace_names_its_variant_flag_when_it_is_the_reference(tmp_path, capsys):
    # review of the audit's mends: pace_study's new refusal reached the command line as "The
    # 'variant' parameter of pace_study"
    import gzip
    import shutil
    from pathlib import Path

    from windnav import cli

    docs = Path(__file__).parents[1] / "docs" / "navigation"
    store = tmp_path / "store"
    store.mkdir()
    shutil.copy(docs / "thesis_manifest.json", store / "manifest.json")
    (store / "records.jsonl").write_bytes(gzip.decompress(
        (docs / "thesis_records.jsonl.gz").read_bytes()))
    assert cli.main(["nav-study", "pace", "--store", str(store), "--variant", "mppi",
                     "--out", str(tmp_path / "p")]) == 2
    err = capsys.readouterr().err
    assert "'--variant' parameter of windnav nav-study" in err and "pace_study" not in err


def test_plot_city_takes_summarize_city_s_own_result(tmp_path):
    # review of the audit's mends: the key check asked for 'name', which the command adds and
    # summarize_city does not give
    import windnav as wn
    from windnav.commands.city import summarize_city
    from windnav.viz.city import plot_city

    city = wn.city.planning_map(rng=0, size=400.0)
    assert plot_city(city, summarize_city(city), tmp_path / "c").name == "c.png"
