"""The aerodynamic model's envelope: translational lift against rotor thrust, and airspeed."""

import math

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import windnav as wn
from windnav.vehicle import Multirotor, VehicleState, outside_envelope

CF = wn.vehicle.params("crazyflie_brushless")
HB = wn.vehicle.params("hummingbird")


def test_crazyflie_hovering_in_30_m_s_wind_is_flagged_calm_hover_is_not():
    s = Multirotor(CF).hover_state(np.zeros((2, 3)))
    wind = np.array([[30.0, 0.0, 0.0], [0.0, 0.0, 0.0]])
    np.testing.assert_array_equal(outside_envelope(CF, s, wind), [True, False])
    # the lift criterion alone flags it: k_h V^2 = 1.0 N per rotor against 0.108 N of thrust
    np.testing.assert_array_equal(outside_envelope(CF, s, wind, max_airspeed=math.inf),
                                  [True, False])


def test_lift_threshold_at_the_closed_form_airspeed():
    """Level hover (thrust T = m g / N per rotor), wind V along x: L / T = k_h V^2 / T."""
    T = HB.mass * wn.vehicle.GRAVITY / HB.n_rotors
    s = Multirotor(HB).hover_state(np.zeros((2, 3)))
    v40 = math.sqrt(0.4 * T / HB.k_h)  # lift = 40% of the thrust
    wind = np.array([[v40, 0.0, 0.0], [0.0, -v40, 0.0]])
    kw = {"max_airspeed": math.inf}
    assert not np.any(outside_envelope(HB, s, wind, lift_fraction=0.41, **kw))
    assert np.all(outside_envelope(HB, s, wind, lift_fraction=0.39, **kw))


def test_derived_airspeed_limit_is_where_hover_lift_reaches_half_the_thrust():
    for p in (HB, CF):
        T = p.mass * wn.vehicle.GRAVITY / p.n_rotors
        assert p.airspeed_limit == pytest.approx(math.sqrt(0.5 * T / p.k_h), rel=1e-14)
    assert HB.airspeed_limit == pytest.approx(13.45, abs=0.01)
    assert CF.airspeed_limit == pytest.approx(6.97, abs=0.01)
    assert HB.replace(k_h=0.0).airspeed_limit == math.inf


def test_airspeed_criterion_uses_the_relative_air_not_the_ground_speed():
    """Flying at 12 m/s into a 0 m/s wind or drifting with a 12 m/s wind: only the first
    moves through the air (level, rotors at 2x hover speed so the lift stays small)."""
    eta = 2.0 * HB.hover_rotor_speed
    s = VehicleState(np.zeros((2, 3)), np.array([[12.0, 0.0, 0.0], [12.0, 0.0, 0.0]]),
                     np.tile([0.0, 0.0, 0.0, 1.0], (2, 1)), np.zeros((2, 3)),
                     np.full((2, 4), eta))
    wind = np.array([[0.0, 0.0, 0.0], [12.0, 0.0, 0.0]])
    np.testing.assert_array_equal(outside_envelope(HB, s, wind), [False, False])
    np.testing.assert_array_equal(outside_envelope(HB, s, wind, max_airspeed=11.0),
                                  [True, False])
    limited = HB.replace(max_airspeed=11.0)
    np.testing.assert_array_equal(outside_envelope(limited, s, wind), [True, False])


def test_stopped_rotor_in_wind_is_outside_unless_the_lift_is_bounded():
    s = Multirotor(HB).hover_state(np.zeros(3))
    s = VehicleState(s.position, s.velocity, s.attitude, s.body_rates, np.zeros((1, 4)))
    wind = [[3.0, 0.0, 0.0]]
    assert outside_envelope(HB, s, wind)[0]  # RotorPy's lift on a stopped rotor
    assert not outside_envelope(HB.replace(translational_lift="bounded"), s, wind)[0]
    assert not outside_envelope(HB, s, [[0.0, 0.0, 0.0]])[0]  # no air, no lift


def test_packed_states_per_hub_winds_and_per_vehicle_params_agree_with_one_by_one():
    rng = np.random.default_rng(4)
    B = 6
    params = [HB, HB.replace(mass=0.8), CF.replace(rotor_positions=HB.rotor_positions)] * 2
    s = VehicleState(rng.normal(size=(B, 3)), rng.normal(scale=6.0, size=(B, 3)),
                     Rotation.random(B, random_state=5).as_quat(), rng.normal(size=(B, 3)),
                     rng.uniform(100.0, 900.0, size=(B, 4)))
    hub = rng.normal(scale=6.0, size=(B, 4, 3))
    batched = outside_envelope(params, s.to_array(), hub)
    single = [outside_envelope(params[b], s[b], hub[b:b + 1])[0] for b in range(B)]
    np.testing.assert_array_equal(batched, single)
    assert batched.dtype == bool and batched.shape == (B,)


def test_a_diverged_row_is_flagged_without_raising():
    x = Multirotor(HB).hover_state(np.zeros((2, 3))).to_array()
    x[1, 3] = np.nan
    np.testing.assert_array_equal(outside_envelope(HB, x, np.zeros(3)), [False, True])
    # a zero quaternion (a ZeroDivisionError in the kernel) and an empty batch (a
    # "range() arg 3" error) before the 2026-12-05 audit
    x = Multirotor(HB).hover_state(np.zeros((2, 3))).to_array()
    x[0, 6:10] = 0.0
    np.testing.assert_array_equal(outside_envelope(HB, x, np.zeros(3)), [True, False])
    assert outside_envelope(HB, x[:0], np.zeros((0, 3))).shape == (0,)


def test_bad_input_is_named():
    s = Multirotor(HB).hover_state(np.zeros(3))
    with pytest.raises(ValueError, match="'lift_fraction'"):
        outside_envelope(HB, s, np.zeros(3), lift_fraction=0.0)
    with pytest.raises(ValueError, match="'max_airspeed'"):
        outside_envelope(HB, s, np.zeros(3), max_airspeed=-3.0)
    with pytest.raises(ValueError, match="'state'"):
        outside_envelope(HB, np.zeros((1, 5)), np.zeros(3))
    with pytest.raises(ValueError, match="'params'"):
        outside_envelope("hummingbird", s, np.zeros(3))
    with pytest.raises(ValueError, match="'wind_world'"):
        outside_envelope(HB, s, np.zeros(2))


def test_a_diverged_flight_is_an_error_with_no_energy(tmp_path, monkeypatch, capsys):
    """``fly`` in gusts of 1e5 m/s (the library takes them; the command now refuses them)
    diverged at its first step, exited 0 and reported 0.42 J of energy, the log's energy held
    from the step it stopped: a small, plausible number. Now no energy, the time it stopped,
    an error line and exit status 1 (its files are still written, to look at)."""
    import json

    import windnav.experiments.flight as flight
    from windnav import cli

    make_wind = flight.make_wind
    monkeypatch.setattr(flight, "make_wind", lambda kind, mean, sigma, seed: make_wind(
        "dryden", (0.0, 0.0, 0.0), (1e5, 1e5, 1e5), seed=seed))
    out = tmp_path / "fly"
    assert cli.main(["fly", "--duration", "1", "--no-progress", "--no-plots",
                     "--out", str(out)]) == 1
    assert "error: the flight diverged" in capsys.readouterr().err
    summary = json.loads((out / "summary.json").read_text())
    assert summary["energy_J"] is None and summary["mean_power_W"] is None
    assert 0.0 < summary["non_finite_from_s"] < 1.0
    # with the Wind UKF run on it: SciPy's "zero norm quaternions", status 2 and no files, before
    # (the session's review)
    assert cli.main(["fly", "--duration", "1", "--no-progress", "--no-plots", "--conditions",
                     "windnav", "--out", str(tmp_path / "ukf")]) == 1
    assert capsys.readouterr().err.count("error:") == 1  # one failure, one line (review)
    summary = json.loads((tmp_path / "ukf" / "summary.json").read_text())
    assert summary["wind_estimate_error"].startswith("the flight diverged at")
