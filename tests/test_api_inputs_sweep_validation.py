"""Bad inputs to the wind-sweep harness, the flow-validation studies and the sweep maps.

Python API audit, fifty-eighth session: each test names what happened before. Every check is
proved to fire before any simulation: the simulation (or the store, or the study's runs) is
replaced by a function that fails the test if it is reached.
"""

from __future__ import annotations

import json
import math
import re
import warnings

import numpy as np
import pytest

import windnav.experiments.flow_validation as FV
import windnav.experiments.maps as MP
import windnav.experiments.wind_sweep as WS
from windnav.city import City

CITY = City((0.0, 40.0, 0.0, 40.0), [[15.0, 22.0, 14.0, 26.0]], [10.0])
MAPS = [("m", "gen", CITY)]
QUICK = {"dx": 2.0, "dt": 0.1, "spinup_steps": 1, "steps": 2, "record_every": 0}


def _reached(*args, **kwargs):
    raise AssertionError("reached the simulation: the check did not come first")


@pytest.fixture
def no_simulation(monkeypatch):
    """Any store creation, task run or flow simulation fails the test."""
    import windnav.experiments.executor as executor
    import windnav.flow as flow
    import windnav.flow.sweep_store as sweep_store

    monkeypatch.setattr(executor, "run_tasks", _reached)
    monkeypatch.setattr(sweep_store.SweepStore, "create", _reached)
    monkeypatch.setattr(flow, "simulate_batch", _reached)
    monkeypatch.setattr(flow, "simulate", _reached)


def _sweep(tmp_path, **kw):
    args = {"speeds": [5.0], "directions_deg": [0.0], "settings": QUICK, "backend": "serial",
            "progress": False, **kw}
    return WS.sweep(args.pop("maps", MAPS), tmp_path / "s.zarr", **args)


# Python API audit, fifty-eighth session: each of these settings created the store and
# returned normally, every task's error kept only in results[i].error
@pytest.mark.parametrize(("settings", "named"), [
    ({"dx": 4, "steps": 0, "spinup_steps": 2}, "\"settings['steps']\""),
    ({"foo": 1}, "'settings'"),
    ({"dt": -1}, "\"settings['dt']\""),
    ({"dx": -1}, "\"settings['dx']\""),  # named grid_shape's 'dx' before
    ({"dx": 1e-6}, "\"settings['dx']\""),  # named grid_shape's 'dx' before
    ({"dx": "4"}, "\"settings['dx']\""),
    ({"spinup_steps": -1}, "\"settings['spinup_steps']\""),
    ({"steps": 2, "record_every": 5}, "\"settings['record_every']\""),
    ({"dt": 10.0}, "\"settings['dt']\""),  # CFL 25 at 5 m/s
    ({"advection": "upwind"}, "\"settings['advection']\""),
    ({"smagorinsky": -0.1}, "\"settings['smagorinsky']\""),
    ([("dx", 1.0)], "'settings'"),
])
def test_sweep_refuses_bad_settings_before_the_store(tmp_path, no_simulation, settings, named):
    with pytest.raises(ValueError, match=re.escape(f"{named} parameter of sweep")):
        _sweep(tmp_path, settings=settings)
    assert not (tmp_path / "s.zarr").exists()


# Python API audit, fifty-eighth session: [5, 5] swept 2 cases of one inlet, [0, 0, 360] 3
# cases of one, [] directions an empty store, [] speeds "max() arg is an empty sequence",
# a seed of -1 NumPy's "expected non-negative integer"
@pytest.mark.parametrize(("kw", "named"), [
    ({"speeds": [5.0, 5.0]}, "'speeds'"),
    ({"speeds": []}, "'speeds'"),
    ({"speeds": 5.0}, "'speeds'"),
    ({"speeds": [500.0]}, "'speeds'"),
    ({"directions_deg": [0.0, 0.0, 360.0]}, "'directions_deg'"),
    ({"directions_deg": [90.0, -270.0]}, "'directions_deg'"),
    ({"directions_deg": []}, "'directions_deg'"),
    ({"directions_deg": "90"}, "'directions_deg'"),
    ({"directions_deg": [math.nan]}, "'directions_deg'"),
    ({"seed": -1}, "'seed'"),
    ({"maps": [CITY]}, "'maps'"),  # "cannot unpack non-iterable City object" before
    ({"maps": [("m", "gen")]}, "'maps'"),
    ({"maps": [("m", "gen", None)]}, "'maps'"),
])
def test_sweep_refuses_bad_inlets_seed_and_maps_before_the_store(tmp_path, no_simulation, kw,
                                                                  named):
    with pytest.raises(ValueError, match=re.escape(f"{named} parameter of sweep")):
        _sweep(tmp_path, **kw)
    assert not (tmp_path / "s.zarr").exists()


def _always_fails(city, speed, direction_deg, dx, dt, spinup_steps, steps, record_every):
    raise RuntimeError(f"solver diverged at {speed} m/s")


def test_sweep_warns_when_every_task_fails(tmp_path):
    # Python API audit, fifty-eighth session: a sweep all of whose tasks failed returned
    # normally and silently; the errors stay in the results, and a warning now says so
    with pytest.warns(UserWarning, match=r"sweep: all 2 task\(s\) run now failed.*"
                                         r"RuntimeError: solver diverged at 5.0 m/s"):
        store, results = _sweep(tmp_path, directions_deg=[0.0, 90.0], simulate=_always_fails)
    assert len(results) == 2 and not any(r.ok for r in results)
    assert len(store.pending()) == 2


def test_wind_sweep_command_still_reports_failures_and_exits_1(tmp_path, capsys):
    # the command keeps its report (a "failed:" line per task, the counts, exit status 1);
    # the warning of an all-failed sweep comes with it
    from windnav.cli import build_parser
    from windnav.commands import wind_sweep

    path = tmp_path / "tiny.json"
    path.write_text(json.dumps({"bounds": {"extents": [0, 40, 0, 40, 0, 20]},
                                "blocks": [{"extents": [15, 22, 14, 26, 0, 10]}]}))
    argv = ["wind-sweep", "--maps", str(path), "--out", str(tmp_path / "s.zarr"),
            "--speeds", "2", "--directions-deg", "0", "--backend", "serial", "--dx", "2",
            "--steps", "2", "--no-progress"]
    with pytest.warns(UserWarning, match="all 1 task"):
        assert wind_sweep.run(build_parser().parse_args(argv), simulate=_always_fails) == 1
    out = capsys.readouterr().out
    assert "failed: map 0 cases [0]" in out and "0/1 simulations done" in out


def test_sweep_valid_settings_are_stored_as_given(tmp_path):
    # the checks change no valid sweep: the store records the settings as given (an int dx
    # stays an int), and a missing dt is auto_dt's
    def solver(city, speed, direction_deg, dx, dt, spinup_steps, steps, record_every):
        raise RuntimeError("not run")

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        store, _ = _sweep(tmp_path, settings={"dx": 2, "steps": 2, "spinup_steps": 0},
                          simulate=solver)
    assert store.config == {"dx": 2, "dt": 0.25, "spinup_steps": 0, "steps": 2,
                            "record_every": 0}


@pytest.mark.parametrize(("call", "match"), [
    # a count with degrees ignored the count; 10**9 was a raw MemoryError; [] an empty array
    (lambda: WS.directions_from(4, [0, 90]), "'count' parameter of directions_from"),
    (lambda: WS.directions_from(10**9), "'count' parameter of directions_from must be at most"),
    (lambda: WS.directions_from(degrees=[]), "'degrees' parameter of directions_from"),
    (lambda: WS.directions_from(degrees=[10, 370]), "'degrees' parameter of directions_from"),
    # auto_dt(0, 5) was 0.0, (1, -5) -0.2, (1, nan) 0.25, (1, 0) a ZeroDivisionError
    (lambda: WS.auto_dt(0, 5), "'dx' parameter of auto_dt"),
    (lambda: WS.auto_dt(1, -5), "'max_speed' parameter of auto_dt"),
    (lambda: WS.auto_dt(1, math.nan), "'max_speed' parameter of auto_dt"),
    (lambda: WS.auto_dt(1, 0), "'max_speed' parameter of auto_dt"),
    (lambda: WS.auto_dt("1", 5), "'dx' parameter of auto_dt"),
    # an AttributeError before
    (lambda: WS.averaging_summary(3), "'store' parameter of averaging_summary"),
    # "dictionary update sequence element #0 ..." before
    (lambda: WS.simulate_case(CITY, 5, 0, "abc", 0), "'settings' parameter of simulate_case"),
    # named "'inflow_velocity' parameter of BoundaryConditions" before
    (lambda: WS.direction_batches([math.nan], 2), "'directions_deg' parameter of "
                                                   "direction_batches"),
    # named grid_shape's 'dx' before; None was an AttributeError
    (lambda: WS.solver_grid(CITY, 1e-6), "'dx' parameter of solver_grid"),
    (lambda: WS.solver_grid(None, 1.0), "'city' parameter of solver_grid"),
    # NumPy's "expected non-negative integer" before
    (lambda: MP.generated_maps(1, seed=-1), "'seed' parameter of generated_maps"),
])
def test_helpers_name_their_arguments(no_simulation, call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_helpers_still_give_their_values():
    np.testing.assert_array_equal(WS.directions_from(), np.arange(0, 360, 45))
    assert WS.directions_from(360).size == 360
    np.testing.assert_array_equal(WS.directions_from(degrees=[3.75, 56.25]), [3.75, 56.25])
    assert WS.auto_dt(1.0, 10.0) == pytest.approx(0.1) and WS.auto_dt(1, 2) == 0.25
    assert WS.direction_batches([0.0, 90.0], 2) == {0.0: 0, 90.0: 1}
    names = [m[0] for m in MP.generated_maps(2, seed=0)]
    assert names == ["training-0", "training-1"]


def test_averaging_summary_takes_a_path(tmp_path):
    # a path was an AttributeError (Python API audit, fifty-eighth session)
    with pytest.warns(UserWarning):
        store, _ = _sweep(tmp_path, simulate=_always_fails)
    assert WS.averaging_summary(store.path) == WS.averaging_summary(store)
    assert WS.averaging_summary(str(store.path))["checked"] == 0


# ---------------------------------------------------------------------- flow validation


@pytest.fixture
def no_study_run(monkeypatch):
    """The Strouhal runs, the flow steps and the simulations fail the test if reached."""
    for name in ("_run", "make_flow_step", "make_domain", "simulate", "MACGrid"):
        monkeypatch.setattr(FV, name, _reached)


@pytest.mark.parametrize(("call", "match"), [
    # about 7 s each, then St 0.191 reported for aspect ratio 0 and -1
    (lambda: FV.aspect_ratio_study(ratios=(0,), backend="serial", progress=False),
     "'ratios' parameter of aspect_ratio_study"),
    (lambda: FV.aspect_ratio_study(ratios=(), backend="serial", progress=False),
     "'ratios' parameter of aspect_ratio_study"),
    (lambda: FV.incidence_study(shapes=(-1,), angles=(0,), backend="serial", progress=False),
     "'shapes' parameter of incidence_study"),
    (lambda: FV.incidence_study(shapes=(math.inf,), angles=(0,), backend="serial",
                                progress=False), "'shapes' parameter of incidence_study"),
    (lambda: FV.incidence_study(shapes=(1,), angles=(math.nan,), backend="serial",
                                progress=False), "'angles' parameter of incidence_study"),
    # empty lists before
    (lambda: FV.projection_study(rng=0, steps=0), "'steps' parameter of projection_study"),
    (lambda: FV.projection_study(rng=0, steps=-3), "'steps' parameter of projection_study"),
    # {} before
    (lambda: FV.uniform_study(directions=()), "'directions' parameter of uniform_study"),
    # ran the checks with the bad backend (ignored without studies)
    (lambda: FV.run_validation(backend="foo", progress=False),
     "'backend' parameter of run_validation"),
    # n = 0 a ZeroDivisionError, periods = -1 a TypeError in polyfit, n = 10**6 a 931 GiB
    # MemoryError
    (lambda: FV.taylor_green_study(n=0), "'n' parameter of taylor_green_study"),
    (lambda: FV.taylor_green_study(n=1), "'n' parameter of taylor_green_study"),
    (lambda: FV.taylor_green_study(n=10**6), "'n' parameter of taylor_green_study"),
    (lambda: FV.taylor_green_study(periods=-1), "'periods' parameter of taylor_green_study"),
    (lambda: FV.taylor_green_study(n=4, periods=0.1), "'periods' parameter of "
                                                      "taylor_green_study"),
])
def test_validation_studies_check_their_arguments_before_any_run(no_study_run, call, match):
    with pytest.raises(ValueError, match=match):
        call()


def test_label_noise_study_names_its_own_arguments(monkeypatch):
    # size 0 was named "'size' parameter of training_map"; seed -1 NumPy's error
    import windnav.flow as flow

    monkeypatch.setattr(flow, "simulate_batch", _reached)
    with pytest.raises(ValueError, match="'size' parameter of label_noise_study"):
        FV.label_noise_study(size=0)
    with pytest.raises(ValueError, match="'seed' parameter of label_noise_study"):
        FV.label_noise_study(seed=-1)


def test_load_references_requires_its_columns(tmp_path):
    # a CSV of other columns gave rows of NaN (Python API audit, fifty-eighth session)
    path = tmp_path / "x.csv"
    path.write_text("a,b\n1,2\n")
    with pytest.raises(ValueError, match="'path' parameter of load_references.*without study"):
        FV.load_references(path)
    shipped = FV.load_references()
    assert shipped and all(set(FV.REFERENCE_COLUMNS) <= set(r) for r in shipped)


def test_taylor_green_study_still_runs_small_grids():
    res = FV.taylor_green_study(n=4, periods=0.25)  # two steps: the least it accepts
    assert set(res) == {"semi_lagrangian", "maccormack"}
    assert all(len(r["energy"]) == 2 for r in res.values())
