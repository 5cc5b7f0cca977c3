"""The Strouhal estimator against synthetic signals of known frequency (mutation audit,
2026-12-05: dropping the crossings' linear interpolation survived the tests, whose long
records average the error of up to one sample out)."""

from __future__ import annotations

import numpy as np
import pytest

from windnav.flow import strouhal as estimator
from windnav.flow.strouhal import BluffBodyCase, bluff_body_strouhal, strouhal_number


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


# ------------------------------------------------ no oscillation, no Strouhal number (audit,
# 2026-12-06: the spectrum method gave the lowest admitted frequency, St 0.2 here, for a
# constant, zero, ramp or NaN signal, and a Re = 10 wake that does not shed came out settled)

DT, SECONDS = 0.05, 100.0  # two cycles per record: f >= 0.02 Hz


def _t():
    return np.arange(0.0, SECONDS, DT)


SIGNALS = {
    "constant": lambda t: np.full(t.size, 3.0),
    "zero": lambda t: np.zeros(t.size),
    "ramp": lambda t: 0.7 * t,
    "nan": lambda t: np.where(t == t[17], np.nan, np.sin(2.0 * np.pi * 0.13 * t)),
    "inf": lambda t: np.where(t == t[17], np.inf, np.sin(2.0 * np.pi * 0.13 * t)),
}


@pytest.mark.parametrize("name", SIGNALS)
def test_a_signal_that_does_not_oscillate_has_no_strouhal_number(name):
    """Both methods give NaN; the spectrum method gave 0.02 * D / U, its lowest admitted
    frequency, for every one of them (the drift test's 0.2 with these D / U)."""
    s = SIGNALS[name](_t())
    for method in ("spectrum", "crossings"):
        assert np.isnan(strouhal_number(s, DT, 1.0, 0.1, method)), method


def test_the_spectral_peak_says_why_there_is_no_frequency():
    want = {"constant": "no variance", "zero": "no variance", "ramp": "edge of band",
            "nan": "not finite", "inf": "not finite"}
    for name, signal in SIGNALS.items():
        p = estimator.spectral_peak(signal(_t()), DT)
        assert np.isnan(p["frequency"]) and p["reason"] == want[name], name
    assert estimator.spectral_peak(np.arange(4.0), DT)["reason"] == "too short"
    with pytest.raises(ValueError, match="'dt' parameter of spectral_peak"):
        estimator.spectral_peak(np.arange(40.0), -1.0)


def test_noise_alone_has_no_strouhal_number_but_a_sine_in_noise_has_its_own():
    """White noise peaks at 5-23 times the median of its periodogram, below the 100 of
    :data:`PEAK_TO_FLOOR` (10-16 here); a sine as large as the noise's standard deviation peaks
    at 430-530 times it and gives its frequency (between bins: not a multiple of 1 / record)."""
    rng = np.random.default_rng(3)
    t = _t()
    for _ in range(5):
        noise = rng.standard_normal(t.size)
        assert np.isnan(strouhal_number(noise, DT, 1.0, 1.0, "spectrum"))
        s = np.sin(2.0 * np.pi * 0.3713 * t + rng.uniform(0.0, 6.0)) + noise
        assert strouhal_number(s, DT, 2.0, 4.0, "spectrum") == pytest.approx(0.3713 / 2.0,
                                                                             rel=2e-3)
        p = estimator.spectral_peak(noise, DT)
        assert p["reason"] == "below floor"
        assert p["peak_to_floor"] < estimator.PEAK_TO_FLOOR / 3
        p = estimator.spectral_peak(s, DT)
        assert p["reason"] is None and p["peak_to_floor"] > 2 * estimator.PEAK_TO_FLOOR


@pytest.mark.parametrize("cycles", [0.6, 1.5, 1.9])
def test_a_peak_at_the_low_edge_of_the_band_is_no_frequency(cycles):
    """A sine of fewer than two cycles per record: its lobe lies below the band searched,
    whose largest power is then its lowest frequency (it gave 2 cycles per record)."""
    t = _t()
    s = np.sin(2.0 * np.pi * cycles / SECONDS * t + 0.4)
    assert np.isnan(strouhal_number(s, DT, 1.0, 1.0, "spectrum"))


def test_a_peak_at_the_nyquist_frequency_is_no_frequency():
    """Samples alternating in sign (plus a slower sine): the largest power at the highest
    frequency searched, 1 / (2 dt), is not a resolved peak; the slower sine alone is."""
    t = _t()
    slow = 0.1 * np.sin(2.0 * np.pi * 3.1 * t)
    s = np.where(np.arange(t.size) % 2 == 0, 1.0, -1.0) + slow
    assert np.isnan(strouhal_number(s, DT, 1.0, 1.0, "spectrum"))
    assert strouhal_number(slow, DT, 1.0, 1.0, "spectrum") == pytest.approx(3.1, rel=2e-3)


@pytest.mark.parametrize("kwargs, name", [
    (dict(dt=0.0), "dt"), (dict(dt=float("nan")), "dt"), (dict(length=-1.0), "length"),
    (dict(speed=float("inf")), "speed"), (dict(signal=np.ones((4, 5))), "signal"),
])
def test_strouhal_number_names_a_bad_argument(kwargs, name):
    args = {"signal": np.sin(np.arange(100.0)), "dt": 0.1, "length": 1.0, "speed": 1.0, **kwargs}
    for method in ("spectrum", "crossings"):
        with pytest.raises(ValueError, match=f"'{name}' parameter of strouhal_number"):
            strouhal_number(args["signal"], args["dt"], args["length"], args["speed"], method)


RE_10 = BluffBodyCase(cells_per_height=4, viscosity=0.1, smagorinsky=0.0, spinup_time=20.0,
                      record_time=40.0, upstream=4.0, downstream=8.0)


def test_a_wake_that_does_not_shed_has_not_settled():
    """A square at Re = 10 (4 cells per side): the start's kick dies out (lift RMS 3e-5), the
    record's halves peak at the edge of their band (they gave St 0.1 and 0.1, and ``settled``),
    so the halves have no St and the run has not settled; recorded on, it stays so."""
    from dataclasses import replace

    r = bluff_body_strouhal(RE_10)
    assert r["cl_rms"] < 1e-4 and np.isnan(r["strouhal_crossings"])
    assert not r["settled"]
    assert np.all(np.isnan(r["strouhal_halves"]))
    longer = bluff_body_strouhal(replace(RE_10, max_record_time=160.0))
    assert longer["record_time_used"] == pytest.approx(160.0) and not longer["settled"]


def test_a_wake_ringing_down_at_one_frequency_has_not_settled():
    """At Re = 20 and 45 deg the decaying wake rings at one frequency (both halves 0.1016, and
    ``settled``), but its lift RMS falls 29x from the first half to the second."""
    from dataclasses import replace

    ringing = bluff_body_strouhal(replace(RE_10, viscosity=0.05, angle_deg=45.0,
                                          record_time=80.0))
    a, b = ringing["strouhal_halves"]
    assert np.isfinite(ringing["strouhal"]) and a == pytest.approx(b, rel=1e-12)
    assert not ringing["settled"]
    half = ringing["cl"].size // 2
    first, second = ringing["cl"][:half].std(), ringing["cl"][half:].std()
    assert first > 10 * estimator.SETTLED_AMPLITUDE_RATIO * second
