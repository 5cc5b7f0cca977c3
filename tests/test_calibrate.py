"""Drag calibration: least squares on the force model, recovery from simulated steady flights."""

import json
import math
import warnings
from types import SimpleNamespace

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

import windnav as wn
from windnav.cli import main
from windnav.estimate.calibrate import DragFit, fit_drag
from windnav.experiments.calibration import calibrate, calibration_flights, calibration_notes

P_HB = wn.vehicle.params("hummingbird")
SHORT = {"x": (-4.0, -2.0, 2.0, 4.0), "y": (-4.0, 2.0, 4.0), "z": (-1.5, -0.5, 1.0, 2.0)}


def synthetic_log(p, rng, K=200, B=12):
    """A log whose accelerometer obeys the force model exactly (no noise)."""
    t = np.arange(K) * 0.01
    eta = p.hover_rotor_speed * rng.uniform(0.8, 1.2, (K, B, p.n_rotors))
    v_world = rng.normal(0.0, 3.0, (K, B, 3))
    q = Rotation.from_euler("ZYX", rng.uniform([-3, -0.5, -0.5], [3, 0.5, 0.5],
                                               (K * B, 3))).as_quat()
    R = Rotation.from_quat(q).as_matrix()
    # eta(t_k) is measured by the command at t_{k-1}: the force at t_k uses eta[k - 1]
    eta_used = np.concatenate([eta[:1], eta[:-1]]).reshape(-1, p.n_rotors)
    va = np.einsum("bji,bj->bi", R, v_world.reshape(-1, 3))
    s, s2 = eta_used.sum(1), (eta_used**2).sum(1)
    sp = np.linalg.norm(va, axis=1)
    f = np.empty_like(va)
    f[:, 0] = -p.k_d * s * va[:, 0] - p.c_dx * sp * va[:, 0]
    f[:, 1] = -p.k_d * s * va[:, 1] - p.c_dy * sp * va[:, 1]
    f[:, 2] = (p.k_eta * s2 + p.n_rotors * p.k_h * (va[:, 0] ** 2 + va[:, 1] ** 2)
               - p.k_z * s * va[:, 2] - p.c_dz * sp * va[:, 2])
    f /= p.mass
    sensors = {"imu": {"t": t, "accel": f.reshape(K, B, 3)},
               "odometry": {"t": t, "velocity": v_world, "attitude": q.reshape(K, B, 4)},
               "rotor_speeds": {"t": t, "cmd": eta}}
    return SimpleNamespace(t=t, sensors=sensors, wind=np.zeros((K, B, 3)),
                           saturated=np.zeros((K, B, p.n_rotors), bool))


def test_least_squares_is_exact_on_noise_free_model_data():
    p = P_HB.replace(k_d=4e-4, k_z=9e-4, c_dx=6e-4, c_dy=2e-4, c_dz=1.2e-2)
    fit = fit_drag(synthetic_log(p, np.random.default_rng(0)), p, settle_s=0.0)
    for k, v in fit.coefficients.items():
        assert v == pytest.approx(getattr(p, k), rel=1e-8), k
    assert max(fit.residual_rms) < 1e-9
    assert fit.r2[0] == pytest.approx(1.0) and fit.r2[1] == pytest.approx(1.0)


def test_linear_fit_matches_the_thesis_regression_without_parasitic_drag():
    """c_d = 0: a_x = -(k_d / m) sum(eta) v_x alone recovers k_d and k_z exactly."""
    p = P_HB.replace(c_dx=0.0, c_dy=0.0, c_dz=0.0)
    fit = fit_drag(synthetic_log(p, np.random.default_rng(1)), p, settle_s=0.0, parasitic=False)
    assert fit.k_d == pytest.approx(p.k_d, rel=1e-8)
    assert fit.k_z == pytest.approx(p.k_z, rel=1e-8)
    assert (fit.c_dx, fit.c_dy, fit.c_dz) == (0.0, 0.0, 0.0)


@pytest.fixture(scope="module")
def hummingbird_fit():
    return calibrate(P_HB, speeds=SHORT, duration=5.0, rng=0)


def test_calibration_recovers_the_hummingbird_drag(hummingbird_fit):
    fit, believed = hummingbird_fit
    assert fit.rows_dropped == 0
    assert fit.k_d == pytest.approx(P_HB.k_d, rel=0.01)
    assert fit.k_z == pytest.approx(P_HB.k_z, rel=0.01)
    for k in ("c_dx", "c_dy", "c_dz"):
        assert getattr(fit, k) == pytest.approx(getattr(P_HB, k), rel=0.05), k
    # residual at the level of the IMU's white noise (0.028 m/s^2 at 100 Hz)
    assert max(fit.residual_rms) < 0.06
    assert believed.k_d == fit.k_d and believed.mass == P_HB.mass
    # standard errors are honest: the fit lies within a few of them of the truth
    assert abs(fit.k_d - P_HB.k_d) < 5 * fit.stderr["k_d"] + 1e-3 * P_HB.k_d
    # flights along every axis determine every coefficient: nothing to say
    assert fit.undetermined == {} and fit.notes == ()
    assert all(math.isfinite(v) for v in fit.stderr.values())


def test_ignoring_parasitic_drag_inflates_the_rotor_drag():
    """The linear (thesis) model absorbs -|v| c v into k_d: the fit overestimates it."""
    log = calibration_flights(P_HB, SHORT, duration=5.0, rng=1)
    lin = fit_drag(log, P_HB, parasitic=False)
    full = fit_drag(log, P_HB, parasitic=True)
    assert lin.k_d > 1.03 * P_HB.k_d
    assert abs(full.k_d - P_HB.k_d) < abs(lin.k_d - P_HB.k_d)
    assert lin.residual_rms[0] > full.residual_rms[0]


def test_calibration_of_a_heavy_high_drag_vehicle():
    p = P_HB.replace(mass=0.84, k_d=9.0e-4, k_z=1.25e-3, c_dx=4e-4, c_dy=5e-4, c_dz=5.5e-4)
    with warnings.catch_warnings(record=True) as got:
        warnings.simplefilter("always")
        fit, _ = calibrate(p, speeds=SHORT, duration=5.0, rng=2)
    assert fit.k_d == pytest.approx(p.k_d, rel=0.02)
    assert fit.k_z == pytest.approx(p.k_z, rel=0.02)
    assert all(getattr(fit, k) >= 0 for k in ("c_dx", "c_dy", "c_dz"))
    # a small frame drag NNLS pins at 0 (c_dy, c_dz here) is said, without a standard error
    pinned = {k for k, v in fit.coefficients.items() if v == 0.0}
    assert set(fit.undetermined) == pinned
    assert all(math.isnan(fit.stderr[k]) for k in pinned)
    assert all("lie" in str(w.message) and "at 0, the bound" in str(w.message) for w in got)
    assert len(got) == (1 if pinned else 0)


def test_bad_input_is_named():
    log = calibration_flights(P_HB, {"x": (2.0,)}, duration=1.0)
    with pytest.raises(ValueError, match="settle_s"):
        fit_drag(log, P_HB, settle_s=5.0)
    with pytest.raises(ValueError, match="params"):
        fit_drag(log, "hummingbird")
    with pytest.raises(ValueError, match="speeds"):
        calibration_flights(P_HB, {"w": (1.0,)})
    no_rotor = SimpleNamespace(**{**vars(log), "sensors": {k: v for k, v in log.sensors.items()
                                                          if k != "rotor_speeds"}})
    with pytest.raises(ValueError, match="rotor_speeds"):
        fit_drag(no_rotor, P_HB, settle_s=0.5)


def test_fit_round_trips_to_json():
    fit = DragFit(k_d=1e-4, k_z=2e-4, stderr={"k_d": 1e-7})
    back = json.loads(fit.to_json())
    assert back["k_d"] == 1e-4 and back["stderr"]["k_d"] == 1e-7


def test_calibrate_command_writes_the_fit(tmp_path, capsys):
    assert main(["calibrate", "--vehicle", "hummingbird", "--out", str(tmp_path),
                 "--duration", "4", "--settle", "2"]) == 0
    rec = json.loads((tmp_path / "calibration.json").read_text())
    assert rec["fit"]["k_d"] == pytest.approx(P_HB.k_d, rel=0.01)
    assert abs(rec["relative_error"]["k_z"]) < 0.01
    assert (tmp_path / "calibration_log.npz").exists()
    assert "k_d" in capsys.readouterr().out


def test_calibrate_command_gives_no_relative_error_where_the_truth_is_zero(tmp_path, capsys):
    # CLI audit C: the Crazyflie's c_dx (true 0) printed "rel. error +0.00%", its absolute
    # error (2.7e-6) shown as a percent
    truth = wn.vehicle.params("crazyflie_brushless")
    assert main(["calibrate", "--vehicle", "crazyflie_brushless", "--out", str(tmp_path)]) == 0
    rec = json.loads((tmp_path / "calibration.json").read_text())
    zero = [k for k in rec["true"] if rec["true"][k] == 0]
    assert zero == ["c_dx", "c_dy", "c_dz"]
    assert set(rec["absolute_error"]) == set(zero)
    lines = {line.split()[0]: line for line in capsys.readouterr().out.splitlines() if line}
    for k in zero:
        assert rec["relative_error"][k] is None
        assert rec["absolute_error"][k] == rec["fit"][k] > 0
        assert "%" not in lines[k] and f"n/a (abs {rec['fit'][k]:+.1e})" in lines[k]
    for k in ("k_d", "k_z"):  # nonzero truth: the relative error as before
        assert rec["relative_error"][k] == pytest.approx(
            (rec["fit"][k] - getattr(truth, k)) / getattr(truth, k), rel=1e-12)
        assert lines[k].endswith(f"{rec['relative_error'][k]:>+12.2%}")


def test_calibrate_command_names_settle_when_it_leaves_no_sample(tmp_path, capsys):
    # "The 'settle_s' parameter of fit_drag must leave samples" named no option of the command
    assert main(["calibrate", "--out", str(tmp_path / "c"), "--duration", "1",
                 "--settle", "0.999"]) == 2
    err = capsys.readouterr().err
    assert ("error: The '--settle' parameter of windnav calibrate must leave samples in the "
            "log" in err)
    assert "settle_s" not in err and "fit_drag" not in err
    assert not (tmp_path / "c").exists()


def test_calibrate_command_names_duration_when_the_log_would_not_fit(tmp_path, capsys):
    # the memory check advised "a shorter flight, log less often (log_every)", which no flag
    # of the command sets (CLI audit, 2026-12-07)
    assert main(["calibrate", "--out", str(tmp_path / "c"), "--duration", "1e6"]) == 2
    err = capsys.readouterr().err
    assert "error: the log and the sensors' states of 29 vehicle(s) for 1e+06 s" in err
    assert "Give a shorter --duration, or raise WINDNAV_MEMORY_LIMIT." in err
    assert "log_every" not in err and "fly:" not in err
    assert not (tmp_path / "c").exists()


def test_estimate_imports_neither_the_simulator_nor_the_experiments():
    """The fitting math is pure: no module of windnav.estimate imports windnav.sim or
    windnav.experiments at import time."""
    import ast
    from pathlib import Path

    import windnav.estimate

    for path in Path(windnav.estimate.__file__).parent.glob("*.py"):
        for node in ast.parse(path.read_text()).body:  # module level only
            names = ([a.name for a in node.names] if isinstance(node, ast.Import)
                     else [node.module or ""] if isinstance(node, ast.ImportFrom) else [])
            for name in names:
                assert not name.startswith(("windnav.sim", "windnav.experiments")), (path, name)


def test_a_linear_fit_that_leaves_out_frame_drag_is_noted(tmp_path, capsys):
    """--linear on the Hummingbird (c_d 0.005/0.005/0.01 N/(m/s)^2): k_d +9.0 % and k_z +6.2 %,
    hundreds of standard errors from the truth, with no note (misspecification audit)."""
    assert main(["calibrate", "--vehicle", "hummingbird", "--linear", "--out",
                 str(tmp_path / "lin")]) == 0
    rec = json.loads((tmp_path / "lin" / "calibration.json").read_text())
    assert rec["relative_error"]["k_d"] == pytest.approx(0.090, abs=0.005)  # the fit unchanged
    assert rec["relative_error"]["k_z"] == pytest.approx(0.062, abs=0.005)
    assert len(rec["notes"]) == 1
    note = rec["notes"][0]
    assert "leaves out hummingbird's frame drag" in note and "k_d +9.0 %" in note
    assert "k_z +6.2 %" in note and "Wind UKF built on them is biased" in note
    assert f"note: {note}" in capsys.readouterr().err
    # with the frame drag in the model, or for a vehicle without it: nothing to say
    fit = DragFit(k_d=1.19e-4, k_z=2.32e-4, c_dx=5e-3, c_dy=5e-3, c_dz=1e-2, parasitic=True)
    assert calibration_notes(fit, P_HB) == []
    cf = wn.vehicle.params("crazyflie_brushless")
    assert calibration_notes(DragFit(k_d=cf.k_d, k_z=cf.k_z, parasitic=False), cf) == []


def test_the_linear_drag_matches_the_true_one_where_the_note_says():
    """k_d' S V = k_d S V + c_d V^2 at V* = (k_d' - k_d) S / c_d: the note's crossing speed."""
    fit = DragFit(k_d=1.1 * P_HB.k_d, k_z=P_HB.k_z, stderr={"k_d": 1e-7}, parasitic=False)
    s = P_HB.n_rotors * P_HB.hover_rotor_speed
    v_eq = 0.1 * P_HB.k_d * s / P_HB.c_dx
    assert fit.k_d * s * v_eq == pytest.approx(P_HB.k_d * s * v_eq + P_HB.c_dx * v_eq**2)
    (note,) = calibration_notes(fit, P_HB)
    assert f"in-plane near {v_eq:.2g} m/s" in note and "k_d +10.0 % (119 standard errors)" in note


def test_flights_along_x_alone_say_what_they_do_not_determine():
    """Calibration audit: flights along x only gave c_dy = 0 (standard error 0.011), c_dz 3.9 x
    and k_z -19 % from the truth, with ordinary standard errors, from no y or z airflow, and
    apply() handed them to the Wind UKF without a word."""
    with pytest.warns(RuntimeWarning, match=r"do not determine c_dy, k_z and c_dz") as got:
        fit, believed = calibrate(P_HB, speeds={"x": (1.0, 2.0, 3.0)}, duration=4.0,
                                  settle_s=2.0, rng=0)
    assert "tilt of the horizontal flights" in str(got[0].message)
    assert set(fit.undetermined) == {"c_dy", "k_z", "c_dz"}
    assert "no airflow along y" in fit.undetermined["c_dy"]
    assert "no airflow along z" in fit.undetermined["k_z"]
    assert all(math.isnan(fit.stderr[k]) for k in fit.undetermined)
    # what the flights do determine keeps its standard error, and is right
    assert math.isfinite(fit.stderr["k_d"]) and math.isfinite(fit.stderr["c_dx"])
    assert fit.k_d == pytest.approx(P_HB.k_d, rel=0.01)
    assert any("no calibration row flew along y or z" in n for n in fit.notes)
    # the values are the fit's, and so are the filter's, said when handed on
    assert fit.c_dz > 2 * P_HB.c_dz and believed.c_dz == fit.c_dz
    with pytest.warns(RuntimeWarning, match=r"DragFit.apply: .*c_dz = .*no airflow along z"):
        applied = fit.apply(P_HB)
    assert all(getattr(applied, k) == getattr(believed, k) == v
               for k, v in fit.coefficients.items())
    assert json.loads(fit.to_json())["stderr"]["c_dz"] is None  # valid JSON, not NaN


def test_hover_alone_determines_nothing():
    """Hover only: k_d = k_z = 0 and c_dx 237 x the truth, R^2 0.003 and -0.010, silently."""
    with pytest.warns(RuntimeWarning) as got:
        fit, _ = calibrate(P_HB, speeds={"x": (), "y": (), "z": ()}, duration=4.0,
                           settle_s=2.0, rng=0)
    text = " | ".join(str(w.message) for w in got)
    assert "no calibration row flew along x, y or z" in text
    assert "explains little of the specific force" in text and "below 0.1" in text
    assert list(fit.undetermined) == ["k_d", "k_z", "c_dx", "c_dy", "c_dz"]
    assert all(math.isnan(v) for v in fit.stderr.values())
    assert max(fit.r2) < 0.1 and len(fit.notes) == 2


def test_one_airspeed_does_not_separate_rotor_from_frame_drag():
    """A single airspeed along x: k_d S V and c_dx V^2 are one column twice (k_d -36 %,
    c_dx 9 x the truth)."""
    with pytest.warns(RuntimeWarning) as got:
        fit, _ = calibrate(P_HB, speeds={"x": (2.0,)}, duration=3.0, settle_s=1.5, rng=0)
    assert any("do not separate k_d and c_dx" in str(w.message) for w in got)
    assert "not separated from c_dx" in fit.undetermined["k_d"]
    assert math.isnan(fit.stderr["k_d"]) and math.isnan(fit.stderr["c_dx"])


def test_a_coefficient_at_the_bound_has_no_standard_error():
    """Data that would put c_dx below 0: NNLS pins it at 0, its standard error NaN (as the
    sys-id fits at a bound), the others' kept."""
    p = P_HB.replace(k_d=4e-4, k_z=9e-4, c_dx=6e-4, c_dy=2e-4, c_dz=1.2e-2)
    below = SimpleNamespace(**{k: getattr(p, k) for k in (
        "mass", "k_eta", "k_h", "k_d", "k_z", "c_dy", "c_dz", "n_rotors", "hover_rotor_speed")},
        c_dx=-6e-4)
    with pytest.warns(RuntimeWarning, match=r"c_dx lies at 0, the bound"):
        fit = fit_drag(synthetic_log(below, np.random.default_rng(0)), p, settle_s=0.0)
    assert fit.c_dx == 0.0 and fit.undetermined == {"c_dx": "on the bound 0"}
    assert math.isnan(fit.stderr["c_dx"])
    assert all(math.isfinite(fit.stderr[k]) for k in ("k_d", "k_z", "c_dy", "c_dz"))


def test_a_fit_by_hand_applies_without_a_word_unless_undetermined():
    fit = DragFit(k_d=1e-4, k_z=2e-4)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert fit.apply(P_HB).k_d == 1e-4
    odd = DragFit(k_d=1e-4, k_z=0.0, stderr={"k_z": math.nan}, undetermined={"k_z": "x"})
    with pytest.warns(RuntimeWarning, match=r"do not determine k_z = 0 \(x\)"):
        assert odd.apply(P_HB).k_z == 0.0
