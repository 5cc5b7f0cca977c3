"""The flow validation studies report what they say: exact closed forms and brute force."""

import numpy as np
import pytest

from windnav.experiments import flow_validation as fv


def test_taylor_green_fit_recovers_the_viscosity_of_an_exact_navier_stokes_decay(monkeypatch):
    """u = sin x cos y, v = -cos x sin y is an eigenmode of the Laplacian with |k|^2 = 1 + 1,
    so Navier-Stokes decays the velocity as exp(-2 nu t) and the energy as exp(-4 nu t).
    A step that applies exactly that decay must be reported with viscosity nu."""
    nu = 0.037

    class ExactDecay:
        def __init__(self, domain, dt, *args, **kwargs):
            self.f = np.exp(-2.0 * nu * dt)  # velocity factor per step, |k|^2 = 2

        def project(self, u, v):
            return u.copy(), v.copy()

        def __call__(self, u, v):
            return u * self.f, v * self.f

    monkeypatch.setattr(fv, "make_flow_step", ExactDecay)
    monkeypatch.setattr(fv, "make_advection", lambda *a, **k: None)
    res = fv.taylor_green_study(n=16, periods=1.0)
    for scheme in ("semi_lagrangian", "maccormack"):
        assert res[scheme]["nu"] == pytest.approx(nu, rel=1e-9)


def test_projection_study_reports_the_largest_divergence_not_a_typical_one():
    """The last reported max |div| dx / U equals the maximum, over fluid cells, of the MAC
    face differences of the returned field, recomputed here by hand (dx = 1, U = 5)."""
    res = fv.projection_study(rng=0, steps=3)
    u, v, solid = res["u"], res["v"], res["solid"]
    dx, speed = 1.0, 5.0
    d = (u[:, 1:] - u[:, :-1] + v[1:, :] - v[:-1, :]) / dx
    d[solid] = 0.0
    expected = np.abs(d).max() * dx / speed
    assert np.abs(d).mean() < 0.5 * np.abs(d).max()  # max and mean are told apart
    assert res["max_div_dx_over_U"][-1] == pytest.approx(expected, rel=1e-6, abs=0.0)


def test_uniform_study_reports_the_worst_cell_deviation(monkeypatch):
    """A solution exactly uniform (4 m/s along the inlet direction) except for one cell whose
    v is off by 0.7 m/s is reported with error 0.7 m/s, the largest deviation."""

    class Sol:
        pass

    def fake_simulate(city, speed, direction_deg, **kwargs):
        th = np.deg2rad(direction_deg)
        s = Sol()
        s.mean_u = np.full((40, 60), speed * np.cos(th))
        s.mean_v = np.full((40, 60), speed * np.sin(th))
        s.mean_v[17, 23] += 0.7
        return s

    monkeypatch.setattr(fv, "simulate", fake_simulate)
    out = fv.uniform_study(directions=(0.0, 135.0))
    assert out["0"] == pytest.approx(0.7, rel=1e-9)
    assert out["135"] == pytest.approx(0.7, rel=1e-9)
