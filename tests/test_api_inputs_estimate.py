"""Bad inputs to the unscented filter's functions, the hardware's differenced odometry and the
Wind UKF's noise settings: each is refused up front by a ValueError naming the argument
(closure-module audit, fifty-ninth session)."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import windnav.estimate.ukf as U
from windnav.estimate import WindUKF, merwe_weights
from windnav.estimate.hardware import odometry_specific_force
from windnav.experiments import ukf_montecarlo as MC
from windnav.vehicle.params import params

W3 = merwe_weights(3)
X3, I3 = np.zeros(3), np.eye(3)


def _fx(X, dt, u):
    return X


def _hx(X):
    return X[:, :2]


# ------------------------------------------------------------------------------- ukf.py


@pytest.mark.parametrize("call, name", [
    # before: P holding 1.5e-321, sigma points of heap memory, or a plausible wrong mean
    (lambda: U.ukf_predict(X3, I3, _fx, 0.1, np.eye(2), W3), "Q"),
    (lambda: U.ukf_predict(X3, np.eye(4), _fx, 0.1, I3, W3), "P"),
    (lambda: U.ukf_predict(X3, I3, _fx, 0.1, I3, merwe_weights(2)), "weights"),
    (lambda: U.ukf_predict(np.zeros((3, 1)), I3, _fx, 0.1, I3, W3), "x"),
    (lambda: U.sigma_points(X3, np.eye(2), W3), "L"),
    (lambda: U.sigma_points(X3, I3, merwe_weights(4)), "weights"),
    (lambda: U.unscented_transform(np.zeros((5, 2)), W3), "Y"),
    (lambda: U.unscented_transform(np.zeros(7), W3), "Y"),
    (lambda: U.unscented_transform(np.zeros((7, 2)), W3, np.eye(3)), "noise"),
    (lambda: U.ukf_update(X3, I3, np.zeros(2), _hx, np.eye(3), W3), "R"),
    (lambda: U.ukf_update(X3, np.eye(2), np.zeros(2), _hx, np.eye(2), W3), "P"),
    (lambda: U.ukf_update(X3, I3, np.zeros(2), _hx, np.eye(2), merwe_weights(5)), "weights"),
    (lambda: U.ukf_update(X3, I3, np.zeros((2, 1)), _hx, np.eye(2), W3), "z"),
    (lambda: U.ukf_update(X3, I3, np.zeros(2), _hx, np.eye(2), W3, wrap=[5]), "wrap"),
])
def test_the_ukf_functions_refuse_sizes_that_do_not_match_x(call, name):
    with pytest.raises(ValueError, match=f"The '{name}' parameter of "):
        call()


def test_the_ukf_shell_steps_past_the_checks_of_the_public_functions(monkeypatch):
    # its sizes are checked once, at construction: the per-step hot path stays as it was
    def checked(*args, **kwargs):
        raise AssertionError("the shell's step went through the checked public function")

    monkeypatch.setattr(U, "ukf_predict", checked)
    monkeypatch.setattr(U, "ukf_update", checked)
    H = np.eye(2, 3)
    k = U.UKF(_fx, X3, I3, 0.01 * I3, dt=0.1, blocks={"h": (lambda X: X @ H.T, 0.1 * np.eye(2))})
    k.predict()
    assert k.update({"h": np.ones(2)}) is not None


# -------------------------------------------------------------------------- hardware.py


@pytest.mark.parametrize("t", [[0.0, np.nan, 0.02], [np.inf, 0.01, 0.02]])
def test_odometry_specific_force_refuses_times_that_are_not_finite(t):
    v = np.array([[0.0, 0, 0], [0.1, 0, 0], [0.2, 0, 0]])
    with pytest.raises(ValueError, match=r"The 't' parameter of odometry_specific_force must "
                       r"hold finite times\. Got t\[\d\] = (nan|inf)"):
        odometry_specific_force(t, v, np.zeros((3, 3)))


@pytest.mark.parametrize("t", [
    [0.02, 0.01, 0.0],         # reversed or repeated stamps: the motion part 0, silently
    [0.0, 0.0, 0.0],
    [0.0, 10.0, 20.0],         # milliseconds read as seconds: every interval above max_dt
])
def test_odometry_specific_force_warns_when_every_interval_is_held(t):
    v = np.array([[0.0, 0, 0], [0.1, 0, 0], [0.2, 0, 0]])
    with pytest.warns(RuntimeWarning, match=r"no interval of 't' lies in \(min_dt, max_dt\)"):
        out = odometry_specific_force(t, v, np.zeros((3, 3)))
    np.testing.assert_array_equal(out, np.broadcast_to(out[0], out.shape))


def test_odometry_specific_force_holds_a_repeated_stamp_as_the_hardware_does():
    # one repeated motion-capture stamp among good ones is held (review: the node does the
    # same); no warning, and the output moves with the rest
    v = np.array([[0.0, 0, 0], [0.1, 0, 0], [0.1, 0, 0], [0.3, 0, 0]])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        out = odometry_specific_force([0.0, 0.01, 0.01, 0.02], v, np.zeros((4, 3)))
    np.testing.assert_array_equal(out[2], out[1])
    assert not np.array_equal(out[3], out[2])


def test_odometry_specific_force_names_t_of_another_shape():
    with pytest.raises(ValueError, match="The 't' parameter of odometry_specific_force"):
        odometry_specific_force([[0.0, 0.01]], np.zeros((2, 3)), np.zeros((2, 3)))


# ------------------------------------------------------------- wind_ukf.py noise settings


P_HB = params("hummingbird")


@pytest.mark.parametrize("kwargs, message", [
    ({"q": {"wind": -1.0}}, "The 'q' parameter of {} must give q['wind'] a finite density"),
    ({"r": {"accel": 0.0}}, "The 'r' parameter of {} must give r['accel'] a finite standard"),
    ({"r": {"accel": "x"}}, "The 'r' parameter of {} must give r['accel'] a finite standard"),
    ({"r": {"accel": np.eye(4)}}, "The 'r' parameter of {} must give r['accel'] a finite"),
    ({"r": {"odom": np.ones(5)}}, "The 'r' parameter of {} must give r['odom'] a finite"),
    ({"q": {"attitude": 1.0}}, "The 'q' parameter of {} has unknown keys ['attitude']"),
])
def test_the_wind_ukf_and_the_monte_carlo_study_check_noise_by_one_rule(kwargs, message):
    # the study restated the filter's rules without the sizes (a (4, 4) accelerometer noise
    # passed its check and failed every trial); both now call wind_ukf.check_noise
    from windnav.estimate.wind_ukf import check_noise

    for where, call in (("WindUKF", lambda: WindUKF(P_HB, **kwargs)),
                        ("MonteCarloConfig", lambda: MC.MonteCarloConfig(**kwargs)),
                        ("mine", lambda: check_noise(**kwargs, where="mine", n_rotors=4))):
        with pytest.raises(ValueError) as err:
            call()
        assert str(err.value).startswith(message.format(where)), str(err.value)


def test_check_noise_sizes_the_rotor_speeds_by_the_vehicle():
    from windnav.estimate.wind_ukf import check_noise

    check_noise(r={"rotor_speeds": np.ones(6)})  # no vehicle named: any rotor count
    with pytest.raises(ValueError, match=r"r\['rotor_speeds'\] .* \(4,\)"):
        WindUKF(P_HB, r={"rotor_speeds": np.ones(6)})
    # the study sizes it by its vehicle before any trial (it passed, and every trial failed;
    # review)
    with pytest.raises(ValueError, match=r"'r' parameter of MonteCarloConfig .*"
                       r"r\['rotor_speeds'\] .* \(4,\)"):
        MC.MonteCarloConfig(r={"rotor_speeds": np.ones(6)})
    MC.MonteCarloConfig(r={"rotor_speeds": np.ones(4)})
