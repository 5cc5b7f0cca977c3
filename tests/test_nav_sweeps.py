"""The Q_E and H sweeps of the navigation benchmark: labels, the table, the command.

Flights and winds are stand-ins (``tests/test_nav_benchmark.py``'s ``Fake`` and tiny suite), so
that the tests check the bookkeeping in milliseconds; the flights themselves are the benchmark's.
"""

from __future__ import annotations

import functools
import json
import math

import numpy as np
import pytest
from test_nav_benchmark import TINY, Fake, fake_flows

import windnav.experiments.nav_benchmark as nb
from windnav import cli
from windnav.experiments.nav_records import NavStore
from windnav.experiments.nav_suite import SUITES
from windnav.experiments.nav_sweeps import sweep_labels, sweep_table

REAL_FLY = nb.fly_scenario


def test_labels_name_the_thesis_variants_they_are():
    qe = sweep_labels("qe")
    assert qe[0.0] == "mppi-w" and qe[5.0] == "ea-mppi-w" and qe[2.0] == "ea-mppi-w@qe=2"
    assert list(qe) == sorted(qe) and len(qe) == 8
    h = sweep_labels("h", [math.inf, 0, 50])
    assert h == {0.0: "ea-mppi-w@h=0", 50.0: "ea-mppi-w@h=50", math.inf: "ea-mppi-w"}
    for bad in ([-1.0], [1.0, 1.0], [], ["x"]):
        with pytest.raises(ValueError, match="'values' parameter of sweep_labels"):
            sweep_labels("qe", bad)
    with pytest.raises(ValueError, match="'kind' parameter of sweep_labels"):
        sweep_labels("lambda")
    # each sweep's own rule ("(H finite, H may be inf)" for H before: CLI audit)
    with pytest.raises(ValueError, match=r"at least one \(H: finite or inf\)\. Got \[-5\.0\]"):
        sweep_labels("h", [-5])
    with pytest.raises(ValueError, match=r"at least one \(Q_E: finite\)\. Got \[inf\]"):
        sweep_labels("qe", [math.inf])


def rec(sid, variant, outcome, energy, speed):
    return {"scenario_id": sid, "variant": variant, "outcome": outcome, "energy_J": energy,
            "rotor_energy_J": energy, "time_s": 10.0, "distance_m": 100.0,
            "mean_cmd_accel": 1.0, "speed": speed}


def test_table_is_the_paired_reduction_per_value_and_per_speed():
    labels = {1.0: "ea-mppi-w@qe=1", 5.0: "ea-mppi-w", 6.0: "ea-mppi-w@qe=6"}
    recs = [rec("a", "mppi", "success", 100.0, 2.0), rec("b", "mppi", "success", 200.0, 5.0),
            rec("c", "mppi", "hover", 50.0, 5.0),
            rec("a", "ea-mppi-w@qe=1", "success", 90.0, 2.0),
            rec("b", "ea-mppi-w@qe=1", "success", 220.0, 5.0),
            rec("c", "ea-mppi-w@qe=1", "success", 10.0, 5.0),  # MPPI failed: not paired
            rec("a", "ea-mppi-w", "collision", 10.0, 2.0),
            rec("b", "ea-mppi-w", "success", 100.0, 5.0)]
    t = sweep_table(recs, labels)
    assert t["values"] == [1.0, 5.0]  # qe=6 was not flown
    r1 = t["rows"][1.0]
    assert r1["paired_reduction"]["n"] == 2
    assert r1["paired_reduction"]["mean"] == pytest.approx(np.mean([0.1, -0.1]))
    assert r1["by_speed"]["2"]["mean"] == pytest.approx(0.1)
    assert r1["by_speed"]["5"]["mean"] == pytest.approx(-0.1)
    assert r1["failure_pct"] == 0.0
    r5 = t["rows"][5.0]
    assert r5["paired_reduction"]["mean"] == pytest.approx(0.5) and r5["failure_pct"] == 50.0
    assert t["reference_failure_pct"] == pytest.approx(100 / 3) and t["speeds"] == ["2", "5"]
    with pytest.raises(ValueError, match="reference 'mppi'"):
        sweep_table(recs[3:], labels)


@pytest.fixture
def quick_is_tiny(monkeypatch):
    monkeypatch.setitem(SUITES, "quick", TINY.__class__(**{**TINY.__dict__, "name": "quick"}))
    monkeypatch.setattr(nb, "suite_flows", fake_flows)
    monkeypatch.setattr(nb, "fly_scenario", lambda spec, sc, v, **kw: REAL_FLY(
        spec, sc, v, city=kw.get("city"), flow=kw.get("flow"), navigate_fn=Fake()))


def study(tmp_path, kind, values, *extra):
    return ["nav-study", kind, "--suite", "quick", "--store", str(tmp_path / "store"),
            "--values", *values, "--executor", "serial", "--out", str(tmp_path / kind),
            "--no-progress", *extra]


def test_command_flies_the_sweep_into_the_store_and_plots_it(tmp_path, quick_is_tiny, capsys):
    assert cli.main(study(tmp_path, "qe", ["0", "2", "5"])) == 0
    doc = json.loads((tmp_path / "qe" / "nav_sweep_qe.json").read_text())
    assert doc["values"] == [0.0, 2.0, 5.0] and doc["flights_now"] == 16  # 4 scenarios x 4
    assert [doc["rows"][k]["label"] for k in ("0.0", "2.0", "5.0")] == [
        "mppi-w", "ea-mppi-w@qe=2", "ea-mppi-w"]
    assert (tmp_path / "qe" / "nav_sweep_qe.png").stat().st_size > 10_000
    store = NavStore(tmp_path / "store", SUITES["quick"], create=False)
    assert {r["variant"] for r in store.load()} == {"mppi", "mppi-w", "ea-mppi-w@qe=2",
                                                    "ea-mppi-w"}
    capsys.readouterr()
    # an H sweep reuses EA-MPPI+W's flights (H = inf) and MPPI's
    assert cli.main(study(tmp_path, "h", ["0", "inf"])) == 0
    assert '"flights_now": 4' in capsys.readouterr().out  # only ea-mppi-w@h=0 is new
    assert (tmp_path / "h" / "nav_sweep_h.png").stat().st_size > 10_000
    assert cli.main(study(tmp_path, "qe", ["0", "2", "5"])) == 2  # outputs exist
    capsys.readouterr()
    assert cli.main(study(tmp_path, "qe", ["0", "2", "5"], "--overwrite")) == 0
    assert '"flights_now": 0' in capsys.readouterr().out  # a rerun flies nothing
    assert cli.main(study(tmp_path, "qe", ["0"], "--maps", "7", "--overwrite")) == 2
    assert cli.main(study(tmp_path, "qe", ["-1"], "--overwrite")) == 2


@functools.lru_cache(maxsize=1)
def small_map():
    """The small map of ``tests/test_escape_variant.py`` (one building) and a 2 m/s wind."""
    from windnav.city import City
    from windnav.experiments.navigate import simulate_flow

    city = City((0.0, 140.0, 0.0, 120.0), np.array([(35.0, 45.0, 45.0, 75.0)]),
                np.array([20.0]))
    return city, simulate_flow(city, 2.0, 0.0, spinup_s=5.0, record_s=20.0)


def fly_small_map(label: str):
    """A real 15 s flight of a benchmark variant label across :func:`small_map`."""
    from windnav.experiments.navigate import navigate

    city, flow = small_map()
    base, options = nb.parse_variant(label)
    return navigate(city, (10.0, 60.0), (110.0, 60.0), speed=2.0, direction_deg=0.0,
                    variant=base, flow=flow, rng=3, duration=15.0, **options)


def test_qe_zero_with_wind_is_mppi_w_and_qe_five_is_ea_mppi_w():
    """The labels that name a thesis variant fly that variant's flight (real flights)."""

    def fly(label):
        return fly_small_map(label).summary()

    for label, same in (("ea-mppi-w@qe=0", "mppi-w"), ("ea-mppi-w@h=inf", "ea-mppi-w")):
        a, b = fly(label), fly(same)
        assert (a["energy_J"], a["distance_m"]) == (b["energy_J"], b["distance_m"])
    with pytest.raises(ValueError, match="own value"):  # one flight, one label
        fly("ea-mppi-w@qe=5")
    assert fly("ea-mppi-w@qe=1")["energy_J"] != fly("ea-mppi-w")["energy_J"]


@pytest.fixture
def quick_is_tiny_real(monkeypatch):
    monkeypatch.setitem(SUITES, "quick", TINY.__class__(**{**TINY.__dict__, "name": "quick"}))


def test_command_cases_reflies_the_best_and_worst_and_winds_draws_a_map(tmp_path,
                                                                         quick_is_tiny_real,
                                                                         capsys):
    spec = SUITES["quick"]
    store = NavStore(tmp_path / "store", spec)
    energies = {"quick/m00/w00/p0": (1000.0, 700.0), "quick/m00/w01/p1": (1000.0, 1300.0),
                "quick/m00/w01/p0": (1000.0, 900.0)}
    for sid, (e_ref, e) in energies.items():
        for v, energy in (("mppi", e_ref), ("ea-mppi-w", e)):
            store.append({**rec(sid, v, "success", energy, 3.0), "seed": 0})
    out = tmp_path / "cases"
    assert cli.main(["nav-study", "cases", "--suite", "quick", "--store", str(store.path),
                     "--out", str(out), "--no-progress"]) == 0
    doc = json.loads((out / "nav_cases.json").read_text())
    assert doc["n"] == 3
    assert doc["best"]["scenario_id"] == "quick/m00/w00/p0"
    assert doc["best"]["reduction"] == pytest.approx(0.3)
    assert doc["worst"]["scenario_id"] == "quick/m00/w01/p1"
    assert set(doc["reflown_energy_J"]["best"]) == {"mppi", "ea-mppi-w"}
    # the records are made up here, so every re-flown flight differs from its record, and the
    # command says so (it drew them as the cases, silently: failure audit, 2026-12-06)
    err = capsys.readouterr().err
    assert err.count("re-flew as") == 4 and "not its record's success with 700.0 J" in err
    assert err.count("fields up to ") == 4  # every replayed field compared, as --check does
    for t in ("best", "worst"):
        for k in ("paths", "energy"):
            assert (out / f"{t}_{k}.png").stat().st_size > 10_000
    assert cli.main(["nav-study", "winds", "--suite", "quick", "--out", str(tmp_path / "w"),
                     "--no-progress"]) == 0
    doc = json.loads((tmp_path / "w" / "nav_winds.json").read_text())
    assert [w["wind_index"] for w in doc["winds"]] == [1]
    assert len(doc["winds"][0]["pairs"]) == 2
    assert (tmp_path / "w" / "nav_winds.png").stat().st_size > 10_000
    capsys.readouterr()
    assert cli.main(["nav-study", "winds", "--suite", "quick", "--map", "3", "--out",
                     str(tmp_path / "x")]) == 2
    assert "'--map' parameter" in capsys.readouterr().err
    assert cli.main(["nav-study", "cases", "--suite", "quick", "--out", str(tmp_path / "y")]) == 2


def test_one_flight_has_one_label():
    """A label is the key of its flight's records, so each flight is written one way: numbers in
    their shortest form (``qe=2``, not ``qe=2.0``), and one list may not name the same
    parameters twice in another order. The sweeps wrote values with ``:g`` (six digits), which
    gave two values one label that flew neither."""
    from windnav.experiments.nav_benchmark import check_variants, number_label, parse_variant
    from windnav.experiments.nav_tilt import tilt_label

    assert [number_label(v) for v in (2.0, 0.5, 13.45, 1000.0, 0.1 + 0.2, math.inf)] == [
        "2", "0.5", "13.45", "1000", "0.30000000000000004", "inf"]
    labels = sweep_labels("qe", [0.1234567, 0.1234568, 2.0])
    assert len(set(labels.values())) == 3
    for value, label in labels.items():
        assert parse_variant(label)[1]["planner_overrides"]["energy_weight"] == value
    assert parse_variant(tilt_label("mppi", 70.25))[1]["tilt_max_deg"] == 70.25
    for bad, want in (("ea-mppi-w@qe=2.0", "qe=2 for qe=2.0"), ("ea-mppi-w@h=050", "h=50"),
                      ("mppi@tilt=7e1", "tilt=70"), ("ea-mppi-w@h=-0", "h=0 for h=-0"),
                      ("ea-mppi-w@h=Infinity", "h=inf for h=Infinity"),
                      ("ea-mppi-w@qe=5", "qe=5 is 'ea-mppi-w'"), ("mppi@tilt=55", "own value"),
                      ("ea-mppi-w@qe=-2.0", "qe must be >= 0")):
        with pytest.raises(ValueError, match=want):
            parse_variant(bad)
    assert parse_variant("ea-mppi-w@h=inf")[1] == {"horizon": math.inf}
    with pytest.raises(ValueError, match="names one flight twice"):
        check_variants(["mppi", "ea-mppi-w@qe=2@h=50", "ea-mppi-w@h=50@qe=2"], "test")
    assert check_variants("ea-mppi-w@qe=2@h=50,ea-mppi-w@qe=3@h=50", "test")


def test_command_cases_restarts_under_the_records_arithmetic(tmp_path, quick_is_tiny_real,
                                                             monkeypatch, capsys):
    """``nav-study cases`` re-flies its cases under the records' arithmetic, as ``benchmark-nav
    --replay`` does: a new process when it differs from this machine's and the CPU can run
    it, not with ``--native-arithmetic`` (the option and this test: leftovers of the
    thirty-eighth session, whose restart was checked only by hand)."""
    import windnav.commands.benchmark_nav as bench_cmd
    import windnav.experiments.arithmetic as ar
    import windnav.experiments.nav_cases as nav_cases

    store = NavStore(tmp_path / "store", SUITES["quick"])
    for sid, e in (("quick/m00/w00/p0", 700.0), ("quick/m00/w01/p1", 1300.0)):
        for v, energy in (("mppi", 1000.0), ("ea-mppi-w", e)):
            store.append({**rec(sid, v, "success", energy, 3.0), "seed": 0,
                          "blas_kernel": "OpenBLAS Older"})
    restarts = []
    monkeypatch.setattr(bench_cmd, "_restart",
                        lambda args, env, why: restarts.append((args.argv, env, why)) or 7)
    monkeypatch.setattr(ar, "pinned_environment",
                        lambda rec, nearest: ({"OPENBLAS_CORETYPE": "Older"}, "blas_kernel "
                                              "'OpenBLAS Older'"))

    class Flown(Exception):
        pass

    def fly_cases(*args, **kwargs):
        raise Flown

    monkeypatch.setattr(nav_cases, "fly_cases", fly_cases)
    argv = ["nav-study", "cases", "--store", str(store.path), "--out", str(tmp_path / "c"),
            "--no-progress"]
    assert cli.main(argv) == 7  # the new process's status; nothing flown here
    assert restarts == [(argv, {"OPENBLAS_CORETYPE": "Older"},
                         "re-flying the cases under their records' arithmetic (blas_kernel "
                         "'OpenBLAS Older')")]
    with pytest.raises(Flown):  # flown here, under this machine's arithmetic
        cli.main(argv + ["--native-arithmetic"])
    assert len(restarts) == 1
    assert cli.main(["nav-study", "pace", "--store", str(store.path), "--out",
                     str(tmp_path / "p"), "--native-arithmetic"]) == 2
    assert "'--native-arithmetic' parameter of windnav nav-study is for the cases study" in (
        capsys.readouterr().err)
