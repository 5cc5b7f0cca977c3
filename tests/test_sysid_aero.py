"""Tunnel hover: the simulated campaign through the command line, back to k_eta, k_d, k_z,
k_h and the accelerometer bias; the same fit from a CSV and from ROS 1 and ROS 2 bags."""

from __future__ import annotations

import argparse
import json

import numpy as np
import pytest

import windnav.commands.sysid
from windnav.commands.sysid import AVERAGE_NOTE
from windnav.experiments.sysid import vehicle_params
from windnav.sysid import AeroData, PWMMotorModel, aero_columns, fit_aero, read_table, write_csv
from windnav.vehicle.thesis_presets import THESIS_CRAZYFLIE, crazyflie_thesis

TRUE = {"k_eta": 4.052e-8, "k_d": 5.09e-6, "k_z": 1.19e-5, "k_h": 1.11e-3}
MASS = 0.044


def _cli(*argv):
    parser = argparse.ArgumentParser()
    sub = parser.add_subparsers(dest="command")
    windnav.commands.sysid.register(sub)
    args = parser.parse_args([str(a) for a in argv])
    return args.func(args)


def _model_samples(n=400, bias=(0.05, -0.04), seed=0):
    """Specific force from the force model of windnav.vehicle.dynamics (closed form)."""
    rng = np.random.default_rng(seed)
    va = rng.uniform(-6, 6, (n, 3)) * [1, 1, 0.5]
    eta = rng.uniform(1200, 2200, (n, 4))
    s1, s2 = eta.sum(1), (eta**2).sum(1)
    f = np.empty((n, 3))
    f[:, 0] = -TRUE["k_d"] * va[:, 0] * s1 / MASS + bias[0]
    f[:, 1] = -TRUE["k_d"] * va[:, 1] * s1 / MASS + bias[1]
    f[:, 2] = (TRUE["k_eta"] * s2 - TRUE["k_z"] * va[:, 2] * s1
               + 4 * TRUE["k_h"] * (va[:, 0] ** 2 + va[:, 1] ** 2)) / MASS
    return AeroData(np.arange(n) * 0.01, va, f, eta, "model")


def test_exact_data_give_the_exact_coefficients():
    fit = fit_aero(_model_samples(), MASS)
    for k, v in TRUE.items():
        assert getattr(fit, k).value == pytest.approx(v, rel=1e-9)
    assert fit.accel_bias[0].value == pytest.approx(0.05, abs=1e-9)
    assert fit.accel_bias[1].value == pytest.approx(-0.04, abs=1e-9)
    assert fit.lateral.r2 == pytest.approx(1.0) and fit.vertical.r2 == pytest.approx(1.0)


@pytest.fixture(scope="module")
def tunnel(tmp_path_factory):
    root = tmp_path_factory.mktemp("tunnel")
    _cli("sysid", "simulate-tunnel", "--out", root / "sim", "--seed", 7)
    _cli("sysid", "aero", "--log", root / "sim" / "tunnel_log.npz", "--json",
         root / "log.json", "--out", root / "log")
    _cli("sysid", "aero", "--csv", root / "sim" / "tunnel.csv", "--vehicle",
         "crazyflie_thesis", "--json", root / "csv.json", "--out", root / "csv")
    return root


@pytest.mark.parametrize("source", ["log", "csv"])
def test_round_trip_recovers_the_thesis_coefficients(tunnel, source):
    doc = json.loads((tunnel / f"{source}.json").read_text())
    truth = json.loads((tunnel / "sim" / "truth.json").read_text())
    assert truth["true"] == {**TRUE, "c_Dx": 0.0, "c_Dy": 0.0, "c_Dz": 0.0,
                             "accel_bias": [0.05, -0.04, 0.03]}
    for key, tol in (("k_eta", 0.02), ("k_d", 0.02), ("k_z", 0.02), ("k_h", 0.10)):
        assert doc[key]["value"] == pytest.approx(TRUE[key], rel=tol), key
        assert doc[key]["ci95"][0] < doc[key]["value"] < doc[key]["ci95"][1]
    assert doc["accel_bias"]["x"]["value"] == pytest.approx(0.05, abs=0.01)
    assert doc["accel_bias"]["y"]["value"] == pytest.approx(-0.04, abs=0.01)
    assert doc["mass_kg"] == MASS and doc["n_rotors"] == 4
    assert (tunnel / source / "aero.png").stat().st_size > 10_000


def test_simulated_tunnel_csv_has_the_documented_header(tunnel):
    tab = read_table(tunnel / "sim" / "tunnel.csv")
    assert tab.names == list(aero_columns(4))
    # 13 airspeeds (0 ... 6 m/s by 0.5) on 5 axes, 2.5 ... 4.0 s at 200 Hz (both ends)
    speed = np.linalg.norm(np.column_stack([tab.columns[f"airspeed_{a}"] for a in "xyz"]),
                           axis=1)
    assert speed.max() == pytest.approx(6.0, abs=0.2)
    assert len(tab) == 65 * 301


def test_csv_without_rotor_speeds_names_file_and_columns(tmp_path):
    cols = {k: v for k, v in _model_samples(10).to_columns().items()
            if not k.startswith("rotor")}
    path = write_csv(tmp_path / "tun.csv", cols)
    with pytest.raises(ValueError, match=r"tun\.csv.*'rotor_speed_1' \.\.\. 'rotor_speed_N'"):
        _cli("sysid", "aero", "--csv", path, "--mass", MASS, "--out", tmp_path / "o")
    full = write_csv(tmp_path / "full.csv", _model_samples(10).to_columns())
    with pytest.raises(ValueError, match="'--mass' parameter"):
        _cli("sysid", "aero", "--csv", full, "--out", tmp_path / "o")
    # both: --mass won silently, the coefficients scaled by it (CLI audit, 2026-12-05)
    with pytest.raises(ValueError, match="'--mass' parameter of .* must not be given with "
                                         "--vehicle"):
        _cli("sysid", "aero", "--csv", full, "--mass", MASS, "--vehicle", "crazyflie_thesis",
             "--out", tmp_path / "o")


def _write_bag(path, data: AeroData, ros1: bool):
    from rosbags.rosbag1 import Writer as Writer1
    from rosbags.rosbag2 import Writer as Writer2
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    T = ts.types
    imu_t, v3s_t = "sensor_msgs/msg/Imu", "geometry_msgs/msg/Vector3Stamped"
    arr_t = "std_msgs/msg/Float64MultiArray"

    def header(t):
        sec = int(np.floor(t))
        return T["std_msgs/msg/Header"](stamp=T["builtin_interfaces/msg/Time"](
            sec=sec, nanosec=int(round((t - sec) * 1e9))), frame_id="base_link")

    def vec(v):
        return T["geometry_msgs/msg/Vector3"](x=float(v[0]), y=float(v[1]), z=float(v[2]))

    ser = ts.serialize_ros1 if ros1 else ts.serialize_cdr
    writer = Writer1(path) if ros1 else Writer2(path, version=9)
    with writer as w:
        c_imu = w.add_connection("/imu", imu_t, typestore=ts)
        c_air = w.add_connection("/tunnel/airspeed", v3s_t, typestore=ts)
        c_mot = w.add_connection("/motors", arr_t, typestore=ts)
        for k in range(data.t.size):
            t = 1000.0 + data.t[k]
            ns = int(round(t * 1e9)) + 1000  # receive time a little after the stamp
            imu = T[imu_t](header=header(t), orientation=T["geometry_msgs/msg/Quaternion"](
                x=0.0, y=0.0, z=0.0, w=1.0), orientation_covariance=np.zeros(9),
                angular_velocity=vec((0, 0, 0)), angular_velocity_covariance=np.zeros(9),
                linear_acceleration=vec(data.specific_force_body[k]),
                linear_acceleration_covariance=np.zeros(9))
            w.write(c_imu, ns, ser(imu, imu_t))
            w.write(c_air, ns, ser(T[v3s_t](header=header(t), vector=vec(
                data.airspeed_body[k])), v3s_t))
            w.write(c_mot, ns, ser(T[arr_t](layout=T["std_msgs/msg/MultiArrayLayout"](
                dim=[], data_offset=0), data=data.rotor_speeds[k].copy()), arr_t))


@pytest.mark.parametrize("ros1", [False, True], ids=["ros2", "ros1"])
def test_bag_round_trip(tmp_path, ros1):
    import importlib.util

    if importlib.util.find_spec("rosbags") is None:  # a test dependency: fail, do not skip
        pytest.fail("The ROS bag reader needs the 'rosbags' package (pip install rosbags, in "
                    "the 'test' extra).")
    data = _model_samples(120, seed=3)
    bag = tmp_path / ("tunnel.bag" if ros1 else "tunnel_ros2")
    _write_bag(bag, data, ros1)
    _cli("sysid", "aero", "--bag", bag, "--topic", "specific_force=/imu:linear_acceleration",
         "--topic", "airspeed=/tunnel/airspeed:vector", "--topic", "rotor_speed=/motors:data",
         "--mass", MASS, "--json", tmp_path / "bag.json", "--out", tmp_path / "o")
    doc = json.loads((tmp_path / "bag.json").read_text())
    # the motors' array has no header: its receive times, 1 us after the stamps, bound the
    # common span, which leaves out the first IMU sample
    assert doc["n_points"] == 119
    for k, v in TRUE.items():
        assert doc[k]["value"] == pytest.approx(v, rel=1e-4)  # motors interpolated by 1 us
    with pytest.raises(ValueError, match=r"has no topic '/nope'.*'/imu'"):
        _cli("sysid", "aero", "--bag", bag, "--topic", "specific_force=/nope:x", "--mass",
             MASS, "--out", tmp_path / "o2")


def test_thesis_preset_carries_the_identified_values():
    p = crazyflie_thesis()
    base = vehicle_params("crazyflie_brushless")
    assert p.name == "crazyflie_thesis"
    for k in ("k_eta", "k_d", "k_z", "k_h"):
        assert getattr(p, k) == THESIS_CRAZYFLIE[k]
    assert p.mass == base.mass and np.array_equal(p.inertia, base.inertia)
    motor = PWMMotorModel.from_params(p)
    assert (motor.Kv, motor.V0, motor.DZ) == (0.3637, 0.5535, 4673.0)
    # the model's inverse: the PWM that gives hover at 3.7 V lies inside the ramp
    pwm = motor.pwm(p.hover_rotor_speed, 3.7)
    assert 10_000 < pwm < 50_000
    assert motor.rotor_speed(pwm, 3.7) == pytest.approx(p.hover_rotor_speed)
    np.testing.assert_allclose(p.extra["power_curve"], [10.56, 0.15160, -0.14970, 0.021114],
                               rtol=2e-4)
    assert crazyflie_thesis(mass=0.05).mass == 0.05
    with pytest.raises(ValueError, match="pwm_motor"):
        PWMMotorModel.from_params(base)


def test_arguments_of_the_wrong_type_are_named():
    # AttributeErrors before the 2026-12-05 audit
    from windnav.sysid import fit_thrust_stand
    from windnav.vehicle.power import max_endurance_speed, max_range_speed

    with pytest.raises(ValueError, match="'data' parameter of fit_aero must be an AeroData"):
        fit_aero("x", MASS)
    with pytest.raises(ValueError, match="'tables' parameter of fit_thrust_stand must hold "
                                         "tables"):
        fit_thrust_stand(["a"], 4)
    with pytest.raises(ValueError, match="'curve' parameter of max_range_speed"):
        max_range_speed("cf", 0.0)
    with pytest.raises(ValueError, match="'curve' parameter of max_endurance_speed"):
        max_endurance_speed(None)


def test_aero_data_refuses_arrays_that_do_not_line_up():
    # built by hand, mismatched arrays reached fit_aero as a LinAlgError, an IndexError or a
    # misleading "linearly dependent" message; NaN samples the same (audit of the helpers)
    d = _model_samples(n=20)
    t, va, f, eta = d.t, d.airspeed_body, d.specific_force_body, d.rotor_speeds
    for args, name in [
        ((t[:, None], va, f, eta), "t"),
        ((np.r_[t[:-1], np.nan], va, f, eta), "t"),
        ((t, va[:, :2], f, eta), "airspeed_body"),
        ((t, va[:-1], f, eta), "airspeed_body"),
        ((t, va, f[:-1], eta), "specific_force_body"),
        ((t, va, np.full_like(f, np.nan), eta), "specific_force_body"),
        ((t, va, f, eta[:, 0]), "rotor_speeds"),
        ((t, va, f, eta[:, :0]), "rotor_speeds"),
        ((t, va, f, np.where(eta > 2000, np.inf, eta)), "rotor_speeds"),
        ((None, va, f, eta), "t"),
    ]:
        with pytest.raises(ValueError, match=f"'{name}' parameter of AeroData must be"):
            AeroData(*args)
    listed = AeroData(t.tolist(), va.tolist(), f.tolist(), eta.tolist())
    assert listed.n_rotors == 4 and listed.t.dtype == np.float64
    assert AeroData(t[:0], va[:0], f[:0], eta[:0]).t.size == 0  # an empty file: fit_aero names it


def test_a_mass_that_disagrees_with_the_log_is_noted(tunnel, tmp_path, capsys):
    # --mass 27 (grams typed as kg) gave k_d 600 x too large with nothing said (audit)
    capsys.readouterr()
    _cli("sysid", "aero", "--log", tunnel / "sim" / "tunnel_log.npz", "--mass", 27,
         "--out", tmp_path / "o")
    err = capsys.readouterr().err
    assert f"--mass 27 kg differs from the {MASS:g} kg the logs record" in err
    _cli("sysid", "aero", "--log", tunnel / "sim" / "tunnel_log.npz", "--mass", MASS,
         "--out", tmp_path / "p")
    assert "differs" not in capsys.readouterr().err


def test_a_settle_time_past_the_log_is_named(tunnel, tmp_path):
    # "hold 0 usable points" without naming --settle-s before (audit)
    with pytest.raises(ValueError, match=r"'--settle-s' parameter of windnav sysid aero must "
                                         r"leave samples in the log .*tunnel_log.npz.*ends "
                                         r".* Got 1000\.0"):
        _cli("sysid", "aero", "--log", tunnel / "sim" / "tunnel_log.npz", "--settle-s", 1000,
             "--out", tmp_path / "o")
    assert not (tmp_path / "o").exists()


def test_horizontal_flows_alone_note_that_k_z_and_k_h_are_not_separated(tunnel, tmp_path,
                                                                         capsys):
    # --axes x y xy gave k_z -25 % and k_h -40 % with intervals that excluded the truth and
    # no word: their regressors correlate at -0.997 (audit)
    _cli("sysid", "simulate-tunnel", "--axes", "x", "y", "xy", "--seed", 3, "--out",
         tmp_path / "sim")
    capsys.readouterr()
    _cli("sysid", "aero", "--csv", tmp_path / "sim" / "tunnel.csv", "--vehicle",
         "crazyflie_thesis", "--json", tmp_path / "h.json", "--out", tmp_path / "h")
    err = capsys.readouterr().err
    doc = json.loads((tmp_path / "h.json").read_text())
    assert doc["kz_kh_regressor_correlation"] < -0.99
    assert doc["vertical_condition_number"] > 20
    assert len(doc["notes"]) == 2 and "k_z and k_h are not separable without vertical flows" \
        in doc["notes"][0] and "ignore regressor noise" in doc["notes"][0]
    assert doc["notes"][1] == AVERAGE_NOTE  # the CSV's 100 Hz samples, not averaged
    assert err.count("note: k_z and k_h are not separable") == 1
    # the default campaign, with vertical flows, separates them
    for source in ("log", "csv"):
        default = json.loads((tunnel / f"{source}.json").read_text())
        assert abs(default["kz_kh_regressor_correlation"]) < 0.5
        assert default["vertical_condition_number"] < 5
        assert default["notes"] == ([AVERAGE_NOTE] if source == "csv" else [])
    exact = fit_aero(_model_samples(), MASS)
    assert abs(exact.kz_kh_correlation) < 0.2 and exact.notes == []


def test_tunnel_vehicles_that_did_not_fly_ok_are_counted(tunnel, tmp_path, capsys):
    # --max-speed 12 on the Crazyflie (trusted to 7 m/s): 30 of 65 conditions outside the
    # envelope, said only in truth.json, and sysid aero --log fitted them unflagged (audit)
    capsys.readouterr()
    _cli("sysid", "simulate-tunnel", "--axes", "x", "z", "--max-speed", 12, "--speed-step", 2,
         "--out", tmp_path / "sim")
    err = capsys.readouterr().err
    truth = json.loads((tmp_path / "sim" / "truth.json").read_text())
    bad = [s for s in truth["status"] if s != "OK"]
    assert 0 < len(bad) < len(truth["status"]) == 14
    assert f"note: {len(bad)} of the 14 tunnel conditions did not fly OK" in err
    assert truth["notes"] and "trusted airspeed limit is 6.97 m/s" in truth["notes"][0]
    _cli("sysid", "aero", "--log", tmp_path / "sim" / "tunnel_log.npz", "--json",
         tmp_path / "a.json", "--out", tmp_path / "a")
    err = capsys.readouterr().err
    doc = json.loads((tmp_path / "a.json").read_text())
    status = doc["log_status"]
    assert status["vehicles_not_ok"] == len(bad) and status["not_ok_kept"] is True
    assert sum(status["samples"].values()) == doc["n_points"]  # they are kept
    assert 0 < status["samples_not_ok"] < doc["n_points"]
    text = (f"{status['samples_not_ok']} of the {doc['n_points']} log samples come from "
            f"{len(bad)} of 14 vehicles whose status is not OK")
    assert any(text in n and "kept in the fit" in n for n in doc["notes"])
    assert f"note: {text}" in err
    # the default campaign flies OK throughout: counted, no note
    default = json.loads((tunnel / "log.json").read_text())
    assert default["log_status"]["samples_not_ok"] == 0
    assert default["log_status"]["samples"] == {"OK": default["n_points"]}
    assert "log_status" not in json.loads((tunnel / "csv.json").read_text())


def test_frame_drag_is_fitted_with_parasitic_and_noted_without(tmp_path, capsys):
    """The thesis's model has no frame drag: on the simulated Hummingbird (c_D 0.005-0.01
    N/(m/s)^2) it gave k_d +10.7 %, k_z +10.9 %, k_h -8.1 %, each 95 % interval excluding the
    truth, and said nothing (API audit, 2026-12-05). Without --parasitic a note says so; with
    it every coefficient, the drag included, comes back."""
    p = vehicle_params("hummingbird")
    sim = tmp_path / "sim"
    _cli("sysid", "simulate-tunnel", "--vehicle", "hummingbird", "--out", sim, "--seed", 0)
    truth = json.loads((sim / "truth.json").read_text())["true"]
    assert (truth["c_Dx"], truth["c_Dy"], truth["c_Dz"]) == (p.c_dx, p.c_dy, p.c_dz)
    log = sim / "tunnel_log.npz"
    _cli("sysid", "aero", "--log", log, "--json", tmp_path / "plain.json", "--out",
         tmp_path / "plain")
    plain = json.loads((tmp_path / "plain.json").read_text())
    assert plain["k_d"]["ci95"][0] > 1.05 * p.k_d  # biased, the interval excluding the truth
    assert plain["frame_drag"] is None and plain["frame_drag_check"]["significant"]
    note = [n for n in plain["notes"] if "frame (parasitic) drag" in n]
    assert len(note) == 1 and "sysid aero --parasitic" in note[0]
    assert "frame (parasitic) drag" in capsys.readouterr().err
    _cli("sysid", "aero", "--log", log, "--parasitic", "--json", tmp_path / "drag.json",
         "--out", tmp_path / "drag")
    drag = json.loads((tmp_path / "drag.json").read_text())
    for key, tol in (("k_eta", 0.01), ("k_d", 0.01), ("k_z", 0.01), ("k_h", 0.02)):
        assert drag[key]["value"] == pytest.approx(getattr(p, key), rel=tol), key
        assert drag[key]["ci95"][0] < getattr(p, key) * (1 + tol)
    for key, true in zip(("c_Dx", "c_Dy", "c_Dz"), (p.c_dx, p.c_dy, p.c_dz), strict=True):
        assert drag["frame_drag"][key]["value"] == pytest.approx(true, rel=0.03), key
    assert drag["frame_drag_check"] is None
    assert not any("frame (parasitic) drag" in n for n in drag["notes"])
    assert (tmp_path / "drag" / "aero.png").stat().st_size > 10_000


def test_no_frame_drag_note_for_a_vehicle_without_it(tunnel):
    """The thesis's Crazyflie has no frame drag: no note, and the drag fitted with
    parasitic=True is zero within its intervals."""
    doc = json.loads((tunnel / "log.json").read_text())
    assert not doc["frame_drag_check"]["significant"]
    assert not any("frame (parasitic) drag" in n for n in doc["notes"])
    from windnav.sim import FlightLog
    from windnav.sysid.aero import aero_from_flight_log

    data = aero_from_flight_log(FlightLog.load(tunnel / "sim" / "tunnel_log.npz"))
    fit = fit_aero(data, MASS, parasitic=True)
    for e in fit.frame_drag:
        assert e.ci95[0] < 0.0 < e.ci95[1]
    assert fit.k_d.value == pytest.approx(TRUE["k_d"], rel=0.01)
    with pytest.raises(ValueError, match="'parasitic' parameter of fit_aero"):
        fit_aero(data, MASS, parasitic="yes")


def test_the_vertical_fit_states_that_a_z_bias_goes_into_k_eta(tunnel, capsys):
    """The vertical equation has no intercept: the simulated accelerometer's z bias (0.03
    m/s^2) moves k_eta, k_z and k_h by about 0.03 / 9.81 = +0.31 %, outside their intervals,
    and the samples cannot show it. An assumption, said always (once), not a data note."""
    doc = json.loads((tunnel / "log.json").read_text())
    assert len(doc["assumptions"]) == 1 and "no intercept" in doc["assumptions"][0]
    assert "b_z / 9.81" in doc["assumptions"][0]
    assert not any("intercept" in n for n in doc["notes"])
    # the physics it states: k_eta off by b_z / g, outside its interval
    assert doc["k_eta"]["value"] / TRUE["k_eta"] - 1 == pytest.approx(0.03 / 9.81, abs=5e-4)
    assert not doc["k_eta"]["ci95"][0] < TRUE["k_eta"] < doc["k_eta"]["ci95"][1]
    capsys.readouterr()
    _cli("sysid", "aero", "--csv", tunnel / "sim" / "tunnel.csv", "--vehicle",
         "crazyflie_thesis", "--out", tunnel / "csv_again")
    err = capsys.readouterr().err
    assert err.count("assumption: the vertical fit has no intercept") == 1


def test_fast_measured_samples_fitted_unaveraged_are_noted(tunnel, tmp_path):
    """The CSV's sensor noise sits in the regressors: unaveraged, k_d's, k_z's and k_eta's
    intervals covered the truth 51, 57 and 75 % of the time; 0.1 s blocks brought them to
    91-97 % (coverage audit). A flight log (true regressors) gets no such note."""
    _cli("sysid", "aero", "--csv", tunnel / "sim" / "tunnel.csv", "--vehicle",
         "crazyflie_thesis", "--average-s", 0.1, "--json", tmp_path / "a.json", "--out",
         tmp_path / "a")
    assert AVERAGE_NOTE not in json.loads((tmp_path / "a.json").read_text())["notes"]
    assert AVERAGE_NOTE in json.loads((tunnel / "csv.json").read_text())["notes"]
    assert AVERAGE_NOTE not in json.loads((tunnel / "log.json").read_text())["notes"]


def test_rows_with_a_non_finite_value_are_counted(tunnel, tmp_path):
    """NaN on every other row of the CSV halved the samples fitted, silently (files audit)."""
    tab = read_table(tunnel / "sim" / "tunnel.csv")
    cols = {k: v.copy() for k, v in tab.columns.items()}
    cols["airspeed_x"][::2] = np.nan
    write_csv(tmp_path / "holes.csv", cols)
    _cli("sysid", "aero", "--csv", tmp_path / "holes.csv", "--vehicle", "crazyflie_thesis",
         "--average-s", 0.1, "--json", tmp_path / "h.json", "--out", tmp_path / "h")
    doc = json.loads((tmp_path / "h.json").read_text())
    n = int(np.ceil(tab.columns["airspeed_x"].size / 2))
    assert doc["n_dropped"] == n and f"{n} sample(s) with a non-finite value" in doc["notes"][-1]
    assert json.loads((tunnel / "csv.json").read_text())["n_dropped"] == 0


def test_a_sparse_log_gives_the_airspeed_of_a_full_one():
    """The body airspeed at the IMU's times took the next logged attitude: with ``log_every
    = 4`` in this circle it was off by up to 0.16 m/s (0.59 m/s in the metamorphic audit's
    manoeuvres, 2026-12-05); the attitude is now slerped between logged samples, as velocity
    and wind are interpolated."""
    import windnav as wn
    from windnav.sysid.aero import aero_from_flight_log

    p = wn.vehicle.params("hummingbird")
    wind = wn.wind.ConstantWind((3.0, -1.0, 0.0))
    traj = wn.sim.make_trajectory("circle", size=4.0, speed=6.0)
    full, sparse = (aero_from_flight_log(wn.sim.fly(p, traj, wind, 4.0, rng=0, log_every=k),
                                         settle_s=1.0) for k in (1, 4))
    np.testing.assert_array_equal(sparse.t, full.t)
    err = np.abs(sparse.airspeed_body - full.airspeed_body).max()
    assert err < 0.05, err


@pytest.mark.parametrize("convention", ["frd", "air_velocity", "dead_z"])
def test_samples_in_another_convention_are_refused_not_fitted(convention):
    """An audit (thirty-eighth session) fitted k_eta = -4.06e-8 with a tight interval from
    z-down (FRD) samples, k_d = -5.08e-6 from the air's velocity given for the airspeed, and
    k_eta = 0 [0, 0] from a dead accelerometer z, each with status 0 and no note."""
    d = _model_samples()
    va, f = d.airspeed_body.copy(), d.specific_force_body.copy()
    if convention == "frd":
        va[:, 1:] *= -1
        f[:, 1:] *= -1
    elif convention == "air_velocity":
        va *= -1
    else:
        f[:, 2] = 0.0
    with pytest.raises(ValueError, match="where the physics makes it positive"):
        fit_aero(AeroData(d.t, va, f, d.rotor_speeds, "model"), MASS)


def test_coefficients_the_samples_do_not_determine_are_noted():
    """Samples in still air only (|v_a| < 0.3 m/s): k_d came out 23 x low with an interval
    over 0 and no note (audit). The fit is kept, with a note naming each such coefficient."""
    d = _model_samples(n=600)
    rng = np.random.default_rng(1)
    va = d.airspeed_body * 0.03  # |v_a| < 0.3 m/s
    eta = d.rotor_speeds
    s1, s2 = eta.sum(1), (eta**2).sum(1)
    f = np.column_stack([-TRUE["k_d"] * va[:, 0] * s1 / MASS,
                         -TRUE["k_d"] * va[:, 1] * s1 / MASS,
                         (TRUE["k_eta"] * s2 - TRUE["k_z"] * va[:, 2] * s1
                          + 4 * TRUE["k_h"] * (va[:, 0] ** 2 + va[:, 1] ** 2)) / MASS])
    f += rng.normal(0.0, 0.3, f.shape)
    fit = fit_aero(AeroData(d.t, va, f, eta, "model"), MASS)
    note = [n for n in fit.notes if n.startswith("the samples do not determine")]
    assert len(note) == 1 and "k_h [" in note[0] and "k_eta" not in note[0]
    assert fit.to_dict()["notes"] == fit.notes
    assert not [n for n in fit_aero(_model_samples(), MASS).notes
                if n.startswith("the samples do not determine")]


@pytest.mark.parametrize("kwargs, match", [
    ({"axes": ["x", "x"]}, r"'axes' parameter of simulate_tunnel must name some of .* each "
                           r"once\. Got \['x', 'x'\]"),
    ({"speeds": [0.0, 0.0]}, r"'speeds' parameter of simulate_tunnel must be distinct finite "
                             r"airspeeds >= 0 m/s, one of them > 0\. Got \[0\.0, 0\.0\]"),
    ({"speeds": [0.0]}, "one of them > 0"),
    ({"speeds": [1.0, float("nan")]}, "'speeds' parameter"),
    ({"speeds": []}, "'speeds' parameter"),
])
def test_the_tunnel_refuses_repeated_axes_and_airflow_free_speeds(kwargs, match):
    """The command refuses these (CLI audit, 2026-12-07); the library ran them: every
    condition twice, or no airflow to fit k_d from."""
    from windnav.experiments.sysid import simulate_tunnel

    with pytest.raises(ValueError, match=match):
        simulate_tunnel(vehicle_params("hummingbird"), **kwargs)
