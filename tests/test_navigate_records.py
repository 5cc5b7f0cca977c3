"""What a navigation result records, against closed forms computed from its own series.

A small map (140 m x 120 m, one building) and a short weak wind, as in test_navigate.py; stub
planners keep every flight to a few seconds.
"""

import dataclasses

import numpy as np
import pytest

from windnav.city import City
from windnav.experiments.navigate import navigate, simulate_flow
from windnav.vehicle import params
from windnav.vehicle.params import GRAVITY

START = (10.0, 60.0)
GOAL = (110.0, 60.0)
BUILDING = (35.0, 45.0, 45.0, 75.0)
SPEED = 2.0


@pytest.fixture(scope="module")
def city():
    return City((0.0, 140.0, 0.0, 120.0), np.array([BUILDING]), np.array([20.0]))


@pytest.fixture(scope="module")
def flow(city):
    return simulate_flow(city, SPEED, 0.0, spinup_s=10.0, record_s=40.0)


@pytest.fixture(scope="module")
def still(flow):
    return dataclasses.replace(flow, **{k: np.zeros_like(getattr(flow, k)) for k in
                                        ("mean_u", "mean_v", "frames_u", "frames_v")})


def fly(city, flow, **kw):
    kw.setdefault("rng", 0)
    return navigate(city, kw.pop("start", START), kw.pop("goal", GOAL), speed=SPEED,
                    direction_deg=0.0, variant="mppi", flow=flow, **kw)


class Brake:
    """``a = -4 v``: the vehicle stays where it is, hovering."""

    def update(self, state, scan=None, wind=None):
        return -4.0 * np.asarray(state[2:4], dtype=float)


class Ramp:
    """A command that grows with each update: 0.2 m/s^2 more each time, along +y."""

    def __init__(self):
        self.calls = 0

    def update(self, state, scan=None, wind=None):
        self.calls += 1
        return np.array([0.0, 0.2 * self.calls])


def test_rotor_power_in_hover_is_n_k_m_eta_cubed_over_the_motor_efficiency(city, still):
    """Still air, braking from rest: the rotors hold the hover speed eta_h = sqrt(m g / (N k_eta))
    and draw N k_m eta_h^3 / efficiency (a motor of efficiency 0.6 draws more, not less)."""
    eff = 0.6
    vehicle = params("hummingbird", motor_efficiency=eff)
    res = fly(city, still, planner=Brake(), vehicle=vehicle, duration=2.0)
    n_rot = len(vehicle.rotor_directions)
    eta_h = np.sqrt(vehicle.mass * GRAVITY / (n_rot * vehicle.k_eta))
    p_hover = n_rot * vehicle.k_m * eta_h**3 / eff
    np.testing.assert_allclose(res.rotor_power, p_hover, rtol=2e-3)
    # the rotor energy is the time integral of the rotor power (trapezoid rule)
    assert res.rotor_energy[0] == 0.0
    np.testing.assert_allclose(
        res.rotor_energy[1:], np.cumsum(0.5 * (res.rotor_power[1:] + res.rotor_power[:-1])
                                        * np.diff(res.t)), rtol=1e-12)
    assert res.rotor_energy_J == pytest.approx(p_hover * res.time_s, rel=2e-3)


def test_mean_cmd_accel_is_the_mean_of_the_commanded_acceleration_magnitudes(city, flow):
    res = fly(city, flow, planner=Ramp(), duration=2.0)
    mag = np.hypot(res.accel_cmd[:, 0], res.accel_cmd[:, 1])
    assert mag.max() > 1.5 * mag.mean()  # the commands vary: mean and max differ
    assert res.mean_cmd_accel == pytest.approx(float(np.mean(mag)), rel=1e-12)


def test_a_vehicle_that_leaves_the_model_ends_as_left_map_not_collision(city, flow, monkeypatch):
    """The simulator's state turning non-finite (here forced at the 50th step) stops the flight
    where it was last finite: in the map and in no building, so the outcome is ``left_map``."""
    from windnav.vehicle.multirotor import Multirotor

    step, calls = Multirotor.step_packed, [0]

    class Armed(Brake):  # counts the flight's steps only (planner_config also steps the model)
        armed = False

        def update(self, state, scan=None, wind=None):
            Armed.armed = True
            return super().update(state, scan, wind)

    def blow_up(self, x, cmd, wind_com, wind_hub, dt, out):
        step(self, x, cmd, wind_com, wind_hub, dt, out)
        calls[0] += Armed.armed
        if calls[0] == 50:
            out[...] = np.nan

    monkeypatch.setattr(Multirotor, "step_packed", blow_up)
    res = fly(city, flow, planner=Armed(), duration=2.0)
    assert len(res.t) == 50 and np.all(np.isfinite(res.position))
    last = res.position[-1:, :2]
    assert not city.contains(last)[0]
    assert res.outcome == "left_map"
