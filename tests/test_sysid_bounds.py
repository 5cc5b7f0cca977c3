"""Coefficients fitted on a bound: no interval, a flag, a warning and a note (audit: "a DZ
fitted on its bound gets a meaningless interval, unflagged")."""

from __future__ import annotations

import argparse
import dataclasses
import json
import warnings

import numpy as np
import pytest
import scipy.stats

import windnav.commands.sysid
from windnav.sysid import PWMMotorModel, fit_thrust_stand, write_csv
from windnav.sysid._fit import Estimate, nonlinear_fit
from windnav.sysid.io import Table
from windnav.sysid.thrust_stand import RPM_TO_RAD_S, _apart


def _exponential(bounds):
    x = np.linspace(0.0, 1.0, 60)
    y = 2.0 * np.exp(3.0 * x) + 0.05 * np.random.default_rng(0).standard_normal(x.size)

    def model(b):
        return b[0] * np.exp(b[1] * x)

    def jac(b):
        return np.column_stack([np.exp(b[1] * x), b[0] * x * np.exp(b[1] * x)])

    return nonlinear_fit(model, jac, [1.0, 1.0], y, ("a", "k"), source="the samples",
                         bounds=bounds)


def test_a_coefficient_on_its_bound_has_no_interval_and_is_named():
    with pytest.warns(RuntimeWarning, match=r"k = 2 in the fit to the samples lies on its "
                                            r"bound 2 .* no standard error or interval"):
        fit = _exponential(([0.0, 0.0], [np.inf, 2.0]))  # the data want k = 3
    assert fit.at_bound == {"k": 2.0}
    k = fit.estimate("k")
    assert k.value == pytest.approx(2.0, abs=1e-9)
    assert np.isnan(k.std_error) and np.all(np.isnan(k.ci95))
    # the free coefficient keeps the covariance's interval, as before
    a = fit.estimate("a")
    half = scipy.stats.t.ppf(0.975, fit.dof) * np.sqrt(fit.cov[0, 0])
    assert a.ci95 == pytest.approx((a.value - half, a.value + half), rel=1e-12)


def test_a_fit_away_from_its_bounds_is_unchanged_and_silent():
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        fit = _exponential(([0.0, 0.0], [np.inf, 10.0]))
    assert fit.at_bound == {}
    for i, name in enumerate(fit.names):
        e = fit.estimate(name)
        se = np.sqrt(fit.cov[i, i])
        half = scipy.stats.t.ppf(0.975, fit.dof) * se
        assert e.std_error == se and e.ci95 == (e.value - half, e.value + half)


# --- the thrust stand's DZ ------------------------------------------------------------------
def _dead_zone_ramp(floor: float) -> list[Table]:
    """The thesis's motor on a ramp whose first step (PWM 3000) lies inside its dead zone (4673):
    the stopped rotor's tachometer reads ``floor`` rad/s, which ``min_speed=0`` keeps as steady.
    The fit pushes DZ up against its bound, the lowest steady PWM."""
    rng = np.random.default_rng(0)
    motor = PWMMotorModel.thesis()
    tabs = []
    for volt in (2.7, 3.4, 4.1):
        pwm = np.repeat(np.r_[3000.0, np.arange(10_000.0, 50_001.0, 10_000.0)], 100)
        w = np.maximum(motor.rotor_speed(pwm, volt), floor) * (
            1 + 0.005 * rng.standard_normal(pwm.size))
        tabs.append(Table(f"{volt} V", {"timestamp": 0.01 * np.arange(1, pwm.size + 1),
                                        "pwm": pwm, "thrust_N": 4 * 4.052e-8 * w**2,
                                        "rpm": w / RPM_TO_RAD_S,
                                        "voltage_V": np.full(pwm.size, volt)}))
    return tabs


@pytest.mark.parametrize("floor", [0.01, 2.0])
def test_a_dead_zone_fitted_on_its_bound_has_no_interval_and_a_note(floor):
    """floor 0.01 rad/s: DZ = 3000 - 1e-6 exactly, the bound, where the covariance gave
    [2999.9996, 3000.0004] (half-width 4e-4 counts, reaching past the bound); floor 2 rad/s:
    DZ 0.09 counts below the bound with an interval [2998.6, 3001.2] past it."""
    with pytest.warns(RuntimeWarning, match=r"DZ = .* lies on its bound 2999.999999"):
        fit = fit_thrust_stand(_dead_zone_ramp(floor), 4, min_speed=0.0)
    bound = 3000.0 - 1e-6
    assert fit.at_bound == {"DZ": pytest.approx(bound, abs=1e-9)}
    assert fit.DZ.value == pytest.approx(bound, abs=0.1)
    assert np.isnan(fit.DZ.std_error) and np.all(np.isnan(fit.DZ.ci95))
    # what was reported before: the covariance's interval, reaching past the bound
    linearised = dataclasses.replace(fit.speed, at_bound={}).estimate("DZ")
    assert linearised.ci95[0] < bound < linearised.ci95[1]
    note = [n for n in fit.notes if n.startswith("DZ (")]
    assert len(note) == 1 and "sits on its bound" in note[0] and "(3000, less 1e-6" in note[0]
    doc = fit.to_dict()
    assert doc["at_bound"] == fit.at_bound
    # Kv and V0 keep their intervals, and the settling check is not fooled by a missing one
    assert np.all(np.isfinite(fit.Kv.ci95)) and np.all(np.isfinite(fit.V0.ci95))
    assert fit.settling_check is None or not fit.settling_check["significant"]


def test_the_command_line_carries_the_flag_and_a_null_interval(tmp_path, capsys):
    paths = [write_csv(tmp_path / f"stand_{t.source.split()[0]}V.csv", t.columns)
             for t in _dead_zone_ramp(0.01)]
    parser = argparse.ArgumentParser()
    windnav.commands.sysid.register(parser.add_subparsers(dest="command"))
    args = parser.parse_args(["sysid", "thrust-stand", "--csv", *map(str, paths),
                              "--min-speed", "0", "--json", str(tmp_path / "fit.json"),
                              "--out", str(tmp_path / "out")])
    with pytest.warns(RuntimeWarning, match="DZ = "):
        assert args.func(args) == 0
    doc = json.loads((tmp_path / "fit.json").read_text())
    assert list(doc["at_bound"]) == ["DZ"]
    assert doc["DZ"]["std_error"] is None and doc["DZ"]["ci95"] == [None, None]
    assert doc["Kv"]["ci95"][0] is not None
    assert "note: DZ (" in capsys.readouterr().err


def test_estimates_without_an_interval_are_judged_by_the_other_s():
    nan = float("nan")
    free = Estimate(10.0, 1.0, (8.0, 12.0))
    assert not _apart(free, Estimate(11.0, nan, (nan, nan)))  # inside the free interval
    assert _apart(free, Estimate(20.0, nan, (nan, nan)))
    assert not _apart(Estimate(1.0, nan, (nan, nan)), Estimate(9.0, nan, (nan, nan)))
    assert _apart(free, Estimate(20.0, 1.0, (18.0, 22.0)))
    assert not _apart(free, Estimate(13.0, 2.0, (9.0, 17.0)))
