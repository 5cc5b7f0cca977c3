"""Similitude: Froude and Reynolds scaling between a full-scale aircraft and its model."""

from __future__ import annotations

import argparse
import json
import math

import pytest

import windnav.commands.similitude
import windnav.commands.sysid
from windnav.sysid import Similitude


def _cli(*argv):
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers(dest="command")
    windnav.commands.sysid.register(sub)
    windnav.commands.similitude.register(sub)
    args = parser.parse_args([str(a) for a in argv])
    return args.func(args)


# --- similitude-------------------------------------------------------------------------
def test_thesis_scaling_numbers():
    s = Similitude.thesis()
    assert s.exact_scale == pytest.approx(1.8 / 0.055) and round(s.exact_scale, 1) == 32.7
    assert s.length_scale == 32.0
    assert s.model_mass(2000.0) == pytest.approx(0.061, abs=5e-4)  # 61 g
    assert s.model_speed(10.0) == pytest.approx(10.0 / math.sqrt(32))
    assert s.reynolds_model_speed(10.0) == pytest.approx(320.0)
    # Froude numbers U^2 / (g L) agree; Reynolds numbers do not
    u_fs = 12.0
    assert (s.model_speed(u_fs) ** 2 / 0.055) == pytest.approx(u_fs**2 / (0.055 * 32))
    r = s.report(full_scale_speed=u_fs)
    assert r["speed"]["reynolds_model"] / r["speed"]["reynolds_full_scale"] == pytest.approx(
        32**-1.5 * (0.055 * 32 / 1.8))


def test_control_to_shedding_ratio_is_the_same_at_both_scales():
    r = Similitude.thesis().report(model_speed=2.0, control_rate_hz=500.0, obstacle_width=0.5,
                                   strouhal=0.2)
    sh = r["shedding"]
    assert sh["model_hz"] == pytest.approx(0.2 * 2.0 / 0.5)
    assert sh["control_to_shedding_model"] == pytest.approx(500.0 / 0.8)
    assert sh["control_to_shedding_full_scale"] == pytest.approx(sh["control_to_shedding_model"])
    assert r["control"]["full_scale_hz"] == pytest.approx(500.0 / math.sqrt(32))
    with pytest.raises(ValueError, match="'model_speed' parameter"):
        Similitude.thesis().report(model_speed=1.0, full_scale_speed=1.0)


@pytest.mark.parametrize("command", [["similitude"], ["sysid", "similitude"]])
def test_similitude_command(tmp_path, command):
    _cli(*command, "--scale", 32, "--full-scale-mass", 2000, "--full-scale-speed", 10,
         "--json", tmp_path / "s.json")
    doc = json.loads((tmp_path / "s.json").read_text())
    assert doc["command"] == "windnav " + " ".join(command)
    assert doc["mass"]["model_kg"] == pytest.approx(2000 / 32**3)
    assert doc["speed"]["model_reynolds_m_s"] == pytest.approx(320.0)
    assert doc["length_scale_exact"] == pytest.approx(32.727, abs=1e-3)


@pytest.mark.parametrize("kwargs, name", [({"scale": 1e-200}, "scale"), ({"scale": 1e308}, "scale"),
                                          ({"full_scale_diameter": 1e300}, "full_scale_diameter")])
def test_a_length_scale_whose_powers_overflow_is_named(kwargs, name):
    # similitude --scale 1e-200 was an OverflowError traceback at lambda**-3
    with pytest.raises(ValueError, match=f"'{name}' parameter of Similitude must give a length "
                                         "scale in"):
        Similitude(**{"full_scale_diameter": 1.8, "model_diameter": 0.055, **kwargs})


def test_reynolds_names_a_zero_viscosity_or_a_negative_speed():
    sim = Similitude.thesis()
    assert sim.reynolds(10.0, 1.8) == pytest.approx(10.0 * 1.8 / 1.5e-5)
    with pytest.raises(ValueError, match="'kinematic_viscosity' parameter of Similitude"):
        sim.reynolds(1.0, 1.0, 0.0)  # a ZeroDivisionError before
    with pytest.raises(ValueError, match="'speed' parameter of Similitude.reynolds"):
        sim.reynolds(-1.0, 1.0)


def test_the_report_notes_what_leaves_the_scaling_valid():
    # a Reynolds-matched model speed near Mach 1 and a model larger than the aircraft were
    # reported without a word (CLI audit, 2026-12-05)
    notes = Similitude.thesis().report(full_scale_speed=10.0)["notes"]
    assert len(notes) == 1 and "Reynolds-scaled model speed 320 m/s is above Mach 0.3" in notes[0]
    assert Similitude.thesis().report(full_scale_speed=1.0)["notes"] == []
    swapped = Similitude(0.055, 1.8).report()["notes"]
    assert len(swapped) == 1 and "the model is larger than the full-scale aircraft" in swapped[0]


@pytest.mark.parametrize("command", [["similitude"], ["sysid", "similitude"]])
@pytest.mark.parametrize("option, value", [("--strouhal", 0), ("--kinematic-viscosity", 0),
                                           ("--full-scale-mass", -1),
                                           ("--control-rate-hz", -1),
                                           ("--obstacle-width", -1), ("--scale", 1e-200)])
def test_similitude_command_names_the_option_typed(command, option, value):
    # "The 'strouhal' parameter of Similitude.report must be ..." named no option the user
    # could type
    base = ["--full-scale-speed", 10, "--control-rate-hz", 500, "--obstacle-width", 0.3]
    with pytest.raises(ValueError) as info:
        _cli(*command, *base, f"{option}={value}")
    text = str(info.value)
    assert text.startswith(f"The '{option}' parameter of windnav {' '.join(command)} must")
    assert "Similitude" not in text


def test_the_report_refuses_an_obstacle_it_cannot_use():
    """Similitude.report ignored obstacle_width without a control rate and a speed, as the
    command did (CLI audit, 2026-12-07); with both it reports the shedding."""
    sim = Similitude(1.8, 0.055, scale=32)
    for kwargs in ({}, {"full_scale_speed": 10.0}, {"control_rate_hz": 500.0}):
        with pytest.raises(ValueError, match="'obstacle_width' parameter of Similitude.report "
                                             "gives the shedding against the control rate"):
            sim.report(obstacle_width=0.5, **kwargs)
    out = sim.report(obstacle_width=0.5, full_scale_speed=10.0, control_rate_hz=500.0)
    assert out["shedding"]["model_obstacle_width_m"] == 0.5


def test_similitude_command_checks_a_strouhal_number_it_would_not_use():
    # without an obstacle the bad --strouhal was silently ignored
    with pytest.raises(ValueError, match="'--strouhal' parameter of windnav similitude"):
        _cli("similitude", "--strouhal", -1)


@pytest.mark.parametrize("command", [["similitude"], ["sysid", "similitude"]])
@pytest.mark.parametrize("argv, option, missing", [
    (["--obstacle-width", 1], "--obstacle-width", "without --control-rate-hz and a speed"),
    (["--model-speed", 1, "--obstacle-width", 1], "--obstacle-width",
     "without --control-rate-hz instead"),
    (["--control-rate-hz", 500, "--obstacle-width", 1], "--obstacle-width",
     "without a speed instead"),
    (["--model-speed", 1, "--control-rate-hz", 500, "--strouhal", 0.13], "--strouhal",
     "without --obstacle-width"),
    (["--control-rate-hz", 500, "--kinematic-viscosity", 1e-6], "--kinematic-viscosity",
     "without a speed"),
])
def test_similitude_command_refuses_options_the_report_would_not_use(command, argv, option,
                                                                     missing, capsys):
    # the shedding needs a width, a speed and a control rate: without them --obstacle-width
    # and --strouhal were accepted and ignored, the output silent (CLI audit)
    from windnav import cli

    assert cli.main([*command, *[str(a) for a in argv]]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1, err
    assert f"The '{option}' parameter of windnav {' '.join(command)} is for the" in err
    assert missing in err
    # given what it needs, the same option is used
    _cli(*command, "--model-speed", 1, "--control-rate-hz", 500, "--obstacle-width", 1,
         "--strouhal", 0.13, "--kinematic-viscosity", 1e-6)
    report = json.loads(capsys.readouterr().out)
    assert report["shedding"]["strouhal"] == 0.13
    assert report["shedding"]["kinematic_viscosity_m2_s"] == 1e-6


def test_the_shedding_notes_an_obstacle_reynolds_number_without_constant_strouhal(capsys):
    # a 5 mm obstacle at 0.1 m/s (Re 33: no shedding at all) got shedding.model_hz 4.0 with
    # notes [] (audit)
    sim = Similitude.thesis()
    r = sim.report(model_speed=0.1, control_rate_hz=100.0, obstacle_width=0.005)
    sh = r["shedding"]
    assert sh["model_hz"] == pytest.approx(4.0)  # unchanged
    assert sh["reynolds_model"] == pytest.approx(0.1 * 0.005 / 1.5e-5)
    assert sh["reynolds_full_scale"] == pytest.approx(
        0.1 * math.sqrt(32) * 0.005 * 32 / 1.5e-5)
    assert sh["kinematic_viscosity_m2_s"] == 1.5e-5
    assert len(r["notes"]) == 1 and "model obstacle's Reynolds number U W / nu is 33.3" in \
        r["notes"][0] and "no shedding" in r["notes"][0]
    # laminar shedding (Re 167): St is not 0.2 there
    notes = sim.report(model_speed=0.5, control_rate_hz=100.0, obstacle_width=0.005)["notes"]
    assert len(notes) == 1 and "is 167, below ~300" in notes[0] and "0.12" in notes[0]
    # both scales between 300 and 2e5: nothing to say
    ok = sim.report(model_speed=0.5, control_rate_hz=500.0, obstacle_width=0.02)
    assert 300 < ok["shedding"]["reynolds_model"] < ok["shedding"]["reynolds_full_scale"] < 2e5
    assert ok["notes"] == []
    # a building at full scale, far above a cylinder's drag crisis: sharp edges fix its
    # separation, so nothing is said
    big = sim.report(full_scale_speed=1.0, control_rate_hz=500.0, obstacle_width=0.5)
    assert big["shedding"]["reynolds_full_scale"] > 2e5 and big["notes"] == []
    # the command prints the note, with its own viscosity
    capsys.readouterr()
    _cli("similitude", "--model-speed", 0.1, "--obstacle-width", 0.005, "--control-rate-hz",
         100, "--kinematic-viscosity", 1.5e-6)
    out = capsys.readouterr()
    assert json.loads(out.out)["shedding"]["reynolds_model"] == pytest.approx(333.33, rel=1e-4)
    assert "no shedding" not in out.err
    _cli("similitude", "--model-speed", 0.1, "--obstacle-width", 0.005, "--control-rate-hz",
         100)
    assert "note: the model obstacle's Reynolds number U W / nu is 33.3" in \
        capsys.readouterr().err


@pytest.mark.parametrize("sim", [Similitude.thesis(), Similitude(1.8, 0.055),
                                 Similitude(10.0, 1.0, 4.0)])
def test_froude_ratios_follow_from_the_dimensions(sim):
    # model / full-scale ratios from first principles, with the model's length ratio L = 1 / lam:
    # equal Froude number U^2 / (g L) gives U ~ L^0.5; time = length / speed; frequency = 1 /
    # time; mass ~ L^3 (same density); acceleration = speed / time ~ 1 (same g); force = mass x
    # acceleration; power = force x speed; Reynolds = speed x length / nu (same air)
    length = 1.0 / sim.length_scale
    speed = math.sqrt(length)
    time = length / speed
    mass = length**3
    force = mass * (speed / time)
    want = {"speed": speed, "time": time, "frequency": 1.0 / time, "mass": mass,
            "force": force, "power": force * speed, "reynolds": speed * length}
    froude = sim.report()["froude"]
    assert set(froude) == set(want) | {"note"}
    for name, value in want.items():
        assert froude[name] == pytest.approx(value, rel=1e-12), name
    # power, checked once more against momentum theory: ideal hover power sqrt(T^3 / (2 rho A))
    # with the thrust T = m g of the scaled mass and the disc area A of the scaled diameter
    def hover_power(mass_kg, diameter_m, rho=1.2):
        return math.sqrt((mass_kg * 9.81) ** 3 / (2 * rho * math.pi * diameter_m**2 / 4))

    p_fs = hover_power(2000.0, 1.8)
    p_m = hover_power(sim.model_mass(2000.0), 1.8 * length)
    assert p_m / p_fs == pytest.approx(froude["power"], rel=1e-12)
    # Reynolds scaling: the speed it asks of the model gives it the full-scale Reynolds number
    u = 7.0
    assert sim.reynolds(sim.reynolds_model_speed(u), 1.8 * length) == pytest.approx(
        sim.reynolds(u, 1.8), rel=1e-12)
    assert sim.reynolds(sim.model_speed(u), 1.8 * length) / sim.reynolds(u, 1.8) == (
        pytest.approx(froude["reynolds"], rel=1e-12))


def test_a_rounded_length_scale_says_which_numbers_use_it():
    """With --scale 32 for rotors 32.7 apart, froude.reynolds (32^-1.5) and the speed block's
    Reynolds numbers (from the diameters) gave two ratios 2 % apart in one output, unsaid
    (output audit). The report now says which uses which."""
    r = Similitude.thesis().report(full_scale_speed=10.0)
    ratio = r["speed"]["reynolds_model"] / r["speed"]["reynolds_full_scale"]
    gap = 100.0 * abs(ratio / r["froude"]["reynolds"] - 1.0)
    assert f"by {gap:.1f} %" in r["scale_note"] and round(gap, 1) == 2.2
    assert "scale_note" not in Similitude(1.8, 0.055).report(full_scale_speed=10.0)
