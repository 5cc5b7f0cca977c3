"""Bad inputs to the Dryden and constant winds, the flight harness and the two demos: each is
refused up front by a ValueError naming the argument (Python API audit, fifty-eighth session)."""

from __future__ import annotations

import time

import numpy as np
import pytest

import windnav.wind.dryden as D
from windnav.wind.constant import ConstantWind

# Dryden ------------------------------------------------------------------------------------


@pytest.mark.parametrize("call, name", [
    (lambda: D.DrydenWind().velocity(1e9, [[0, 0, 0]]), "t"),
    (lambda: D.DrydenWind().velocity(1e300, [[0, 0, 0]]), "t"),
    (lambda: D.DrydenWind().sample([0.5, 1e9]), "times"),
    (lambda: D.DrydenWind(time_step=1e-12).velocity(1.0, [[0, 0, 0]]), "t"),
    (lambda: D.DrydenWind(batch_size=100).velocity(1e3, np.zeros((100, 3))), "t"),
])
def test_a_query_beyond_the_generation_cap_is_refused_at_once(call, name):
    # Python API audit, fifty-eighth session: these spun for ever (the lattice is generated in
    # order from t0: t = 1e5 s took 9.7 s, t = 1e9 s about a day)
    start = time.perf_counter()
    with pytest.raises(ValueError, match=f"'{name}' parameter of DrydenWind.*at most"):
        call()
    assert time.perf_counter() - start < 1.0


def test_the_cap_is_a_pure_function_of_t_and_the_realisations(monkeypatch):
    # the cap (2^25 steps, about 3 s of work) lowered to 4 blocks to reach its edge quickly
    monkeypatch.setattr(D, "_MAX_WORK", 4 * 2048)
    reach = 4 * 2048 * 0.05
    field = D.DrydenWind(rng=3, time_step=0.05)
    want = D.DrydenWind(rng=3, time_step=0.05).sample([reach])
    np.testing.assert_array_equal(field.velocity(reach, [[0, 0, 0]]), want)
    with pytest.raises(ValueError, match="'t' parameter of DrydenWind.velocity must be at most "
                                         "409.6 s"):
        field.velocity(reach + 0.05, [[0, 0, 0]])
    pair = D.DrydenWind(rng=3, time_step=0.05, batch_size=2)
    assert pair.velocity(reach / 2, np.zeros((2, 3))).shape == (2, 3)
    with pytest.raises(ValueError, match="at most 204.8 s"):
        pair.sample([reach / 2 + 0.05])


def test_the_cap_leaves_hours_of_gusts_at_the_default_step():
    assert D._MAX_WORK * D.DrydenWind().time_step > 9 * 3600


@pytest.mark.parametrize("kwargs", [{"time_step": 1e6}, {"time_step": 1.5},
                                    {"length_scales": (5, 5, 2), "time_step": 0.3}])
def test_a_time_step_longer_than_the_gusts_time_scale_is_refused(kwargs):
    # Python API audit, fifty-eighth session: time_step=1e6 s was accepted (the docstring says
    # keep it well below L_w / V = 1 s), every query a straight line between two points
    with pytest.raises(ValueError, match="'time_step' parameter of DrydenWind"):
        D.DrydenWind(**kwargs)


def test_a_time_step_is_bounded_only_by_the_axes_with_gusts():
    # w has no gust: its 1 s time scale does not bound the step, u's 6.7 s does
    assert D.DrydenWind(sigma=(1, 1, 0), time_step=2.0).time_step == 2.0
    assert D.DrydenWind(sigma=(0, 0, 0), time_step=1e6).sample([3e6])[0].tolist() == [3, 0, 0]


@pytest.mark.parametrize("dt", [1e40, 1e100, 1e300])
def test_a_step_far_beyond_every_time_constant_decays_to_zero_not_nan(dt):
    # Python API audit, fifty-eighth session: transition(1e300) and lag_correlation(1e300)
    # gave NaN (SciPy's expm overflows in its scaling)
    field = D.DrydenWind()
    phi, q = field.transition(dt)
    assert np.all(phi == 0) and np.array_equal(q, field.stationary_covariance)
    assert field.lag_correlation(dt).tolist() == [0.0, 0.0, 0.0]


def test_van_loan_refuses_a_negative_or_unrepresentable_step():
    # Python API audit, fifty-eighth session: van_loan(-I, I, -1) gave a negative Q
    with pytest.raises(ValueError, match="'dt' parameter of van_loan"):
        D.van_loan(-np.eye(2), np.eye(2), -1.0)
    with pytest.raises(ValueError, match="'dt' parameter of van_loan"):
        D.van_loan(-np.eye(2), np.eye(2), 1e300)
    phi, q = D.van_loan(-np.eye(2), np.eye(2), 1.0)
    np.testing.assert_allclose(np.diag(q), (1 - np.exp(-2.0)) / 2)


@pytest.mark.parametrize("a", [np.eye(2), np.zeros((2, 2)), [[0.0, 1.0], [-1.0, 0.0]]])
def test_stationary_covariance_refuses_an_unstable_a(a):
    # Python API audit, fifty-eighth session: A = I gave a negative-definite P
    with pytest.raises(ValueError, match="'a' parameter of stationary_covariance must be "
                                         "stable"):
        D.stationary_covariance(np.asarray(a), np.eye(2))


@pytest.mark.parametrize("kwargs, name", [({"mean": "abc"}, "mean"), ({"sigma": "abc"}, "sigma"),
                                          ({"length_scales": ["a", 1, 1]}, "length_scales")])
def test_dryden_text_for_numbers_is_named(kwargs, name):
    # before: "could not convert string to float: 'abc'", naming nothing
    with pytest.raises(ValueError, match=f"'{name}' parameter of DrydenWind"):
        D.DrydenWind(**kwargs)


@pytest.mark.parametrize("velocity", ["abc", ["a", 0, 0], {"x": 1}])
def test_constant_wind_text_for_numbers_is_named(velocity):
    # Python API audit, fifty-eighth session: "could not convert string to float: 'abc'"
    with pytest.raises(ValueError, match="'velocity' parameter of ConstantWind"):
        ConstantWind(velocity)
