"""The Strouhal estimator against synthetic signals of known frequency (mutation audit,
2026-12-05: dropping the crossings' linear interpolation survived the tests, whose long
records average the error of up to one sample out)."""

from __future__ import annotations

import numpy as np
import pytest

from windnav.flow.strouhal import strouhal_number


@pytest.mark.parametrize("f, dt, cycles", [(0.137, 0.9, 4.0), (1.7, 0.05, 3.3), (0.5, 0.31, 5.2)])
def test_crossings_give_f_d_over_u_of_a_sine_exactly(f, dt, cycles):
    """A pure sine sampled coarsely, its frequency not a whole number of samples: the upward
    crossings, linearly interpolated, give ``St = f D / U`` to the interpolation's error (a
    few 1e-3 here), where crossings rounded down to a sample are off by up to dt / period."""
    t = np.arange(0.0, cycles / f, dt)
    s = np.sin(2.0 * np.pi * f * t + 0.3)
    D, U = 2.0, 3.5
    got = strouhal_number(s, dt, D, U, "crossings")
    assert got == pytest.approx(f * D / U, rel=5e-3)


def test_spectrum_and_crossings_scale_with_length_over_speed():
    f, dt = 0.8, 0.02
    t = np.arange(0.0, 40.0, dt)
    s = np.sin(2.0 * np.pi * f * t)
    for method in ("crossings", "spectrum"):
        base = strouhal_number(s, dt, 1.0, 1.0, method)
        assert base == pytest.approx(f, rel=2e-3)
        assert strouhal_number(s, dt, 2.0, 5.0, method) == pytest.approx(base * 2.0 / 5.0,
                                                                          rel=1e-12)
