"""Flow solutions and sweep datasets in Zarr: round trips, attributes, resumption, the CLI.

The sweep's bookkeeping is tested with a stand-in solver whose answer is known in closed form
(``FakeSolver``: a uniform inlet wind, zero in buildings), so every stored chunk can be checked
exactly and every call counted, also across worker processes (one marker file per call).
"""

from __future__ import annotations

import dataclasses
import json
import os
import signal
import subprocess
import sys
import textwrap
import time
import uuid
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
import zarr

from windnav.city import City
from windnav.experiments.wind_sweep import THESIS_SPEEDS, solver_grid, sweep
from windnav.flow import FlowSolution, SweepStore, flow_attrs, load_flow, save_flow

HERE = Path(__file__).resolve().parent


def expected_wind(city, speed, direction_deg, dx):
    """The stand-in's exact answer: the inlet wind everywhere but in buildings."""
    x, y = solver_grid(city, dx)
    solid = city.rasterize(x, y)
    a = np.deg2rad(direction_deg)
    u = np.where(solid, 0.0, speed * np.cos(a) * (1.0 + 0.01 * x[None, :]))
    v = np.where(solid, 0.0, speed * np.sin(a) * (1.0 + 0.01 * y[:, None]))
    return x, y, solid, u, v


@dataclass(frozen=True)
class FakeSolver:
    """Picklable stand-in for windnav.flow.simulate that logs each call as a file."""

    log_dir: str
    interrupt_after: int | None = None  # raise KeyboardInterrupt on this call number
    fail_speed: float | None = None  # raise RuntimeError for this inlet speed
    sleep: float = 0.0

    def calls(self) -> int:
        return len(os.listdir(self.log_dir))

    def __call__(self, city, speed, direction_deg, dx, dt, spinup_steps, steps, record_every):
        n = self.calls()
        if self.interrupt_after is not None and n >= self.interrupt_after:
            raise KeyboardInterrupt
        Path(self.log_dir, f"{speed}_{direction_deg}_{uuid.uuid4().hex}").touch()
        if speed == self.fail_speed:
            raise RuntimeError(f"solver diverged at {speed} m/s")
        time.sleep(self.sleep)
        return fake_solution(city, speed, direction_deg, dx, dt, steps, record_every)


def fake_solution(city, speed, direction_deg, dx, dt=0.1, steps=4, record_every=0):
    """The stand-in's FlowSolution: ``expected_wind``, and frames that drift linearly."""
    x, y, solid, u, v = expected_wind(city, speed, direction_deg, dx)
    frames_u = frames_v = t = None
    if record_every:
        k = np.arange(steps // record_every, dtype=float)[:, None, None]
        frames_u, frames_v = u[None] * (1 + 0.1 * k), v[None] * (1 - 0.1 * k)
        t = dt * record_every * (k[:, 0, 0] + 1)
    return FlowSolution(x, y, solid, u, v, frames_u, frames_v, t, speed, direction_deg, dx, dt)


def tiny_city(shift=0.0, size=40.0):
    return City((0.0, size, 0.0, size), [[15.0 + shift, 22.0 + shift, 12.0, 25.0]], [10.0])


SETTINGS = {"dx": 2.0, "dt": 0.1, "spinup_steps": 1, "steps": 4, "record_every": 0}
MAPS = [("a", "a.json", tiny_city()), ("b", "b.json", tiny_city(5.0, size=30.0))]


def check_store_matches(store, maps=MAPS, dx=SETTINGS["dx"]):
    for k, (_, _, city) in enumerate(maps):
        assert store.done(k).all()
        for c in range(store.n_cases):
            case = store.read_case(k, c)
            x, y, solid, u, v = expected_wind(city, case["speed"], case["direction_deg"], dx)
            np.testing.assert_array_equal(case["x"], x)
            np.testing.assert_array_equal(case["solid"], solid)
            np.testing.assert_array_equal(case["mean_u"], u)
            np.testing.assert_array_equal(case["mean_v"], v)


# ----------------------------------------------------------------- one solution


def test_flow_round_trip_gives_back_the_same_arrays_and_attributes(tmp_path):
    sol = fake_solution(tiny_city(), 5.0, 30.0, 1.0, dt=0.25, steps=6, record_every=2)
    config = {"speed": 5.0, "direction_deg": 30.0, "dx": 1.0, "dt": 0.25, "steps": 200,
              "seed": 7, "map_source": "tiny.json"}
    save_flow(sol, tmp_path / "f.zarr", config=config)
    back = load_flow(tmp_path / "f.zarr")
    assert isinstance(back, FlowSolution)
    for name in ("x", "y", "solid", "mean_u", "mean_v", "frames_u", "frames_v", "t"):
        got, want = np.asarray(getattr(back, name)), np.asarray(getattr(sol, name))
        assert got.dtype == want.dtype and got.shape == want.shape, name
        np.testing.assert_array_equal(got, want)
    assert (back.speed, back.direction_deg, back.dx, back.dt) == (5.0, 30.0, 1.0, 0.25)
    attrs = flow_attrs(tmp_path / "f.zarr")
    assert attrs["config"] == config
    assert attrs["spacing"] == [1.0, 1.0] and attrs["origin"] == [0.5, 0.5]
    assert attrs["shape"] == [40, 40]
    assert attrs["units"]["mean_u"] == "m/s" and attrs["units"]["x"] == "m"
    assert "x east" in attrs["frame"]
    # one chunk per frame, so a reader can stream frames
    assert zarr.open_group(str(tmp_path / "f.zarr"), mode="r")["frames_u"].chunks == (1, 40, 40)


def test_flow_without_frames_loads_with_none(tmp_path):
    sol = fake_solution(tiny_city(), 2.0, 0.0, 2.0)
    save_flow(sol, tmp_path / "f.zarr")
    back = load_flow(tmp_path / "f.zarr")
    assert back.frames_u is None and back.frames_v is None and back.t is None
    np.testing.assert_array_equal(back.mean_u, sol.mean_u)


def test_missing_or_corrupt_flow_store_is_a_value_error_naming_the_path(tmp_path):
    missing = tmp_path / "nothing.zarr"
    with pytest.raises(ValueError, match="nothing.zarr"):
        load_flow(missing)
    store = tmp_path / "bad.zarr"
    save_flow(fake_solution(tiny_city(), 2.0, 0.0, 2.0), store)
    chunk = store / "mean_u" / "c" / "0" / "0"
    raw = bytearray(chunk.read_bytes())
    raw[len(raw) // 2] ^= 0xFF  # one flipped byte: caught by the chunk checksum
    chunk.write_bytes(bytes(raw))
    with pytest.raises(ValueError, match=r"bad\.zarr.*mean_u"):
        load_flow(store)
    (store / "zarr.json").write_text("{not json")
    with pytest.raises(ValueError, match="bad.zarr"):
        load_flow(store)


def test_save_flow_rejects_mismatched_shapes(tmp_path):
    sol = fake_solution(tiny_city(), 2.0, 0.0, 2.0)
    bad = dataclasses.replace(sol, mean_v=sol.mean_v[:-1])
    with pytest.raises(ValueError, match="mean_v"):
        save_flow(bad, tmp_path / "f.zarr")


def test_save_flow_refuses_frames_without_their_times(tmp_path):
    """load_flow needs a time per frame; save_flow wrote frames without ``t`` and the file did
    not load back (audit, 2026-12-05)."""
    sol = fake_solution(tiny_city(), 2.0, 0.0, 2.0, record_every=2)
    with pytest.raises(ValueError, match="times 't' of its 2 frames"):
        save_flow(dataclasses.replace(sol, t=None), tmp_path / "f.zarr")
    assert not (tmp_path / "f.zarr").exists()


def test_a_sweep_store_refuses_a_solution_of_another_case(tmp_path):
    """write_case checks the solution's inlet against the case it is written as (a 9 m/s
    solution toward 45 deg was written as case 0, 2 m/s toward 0; audit, 2026-12-05)."""
    solver = FakeSolver(str(tmp_path / "log"))
    os.mkdir(solver.log_dir)
    store, _ = sweep(MAPS[:1], tmp_path / "s.zarr", speeds=[2.0], directions_deg=[0.0, 90.0],
                     settings=SETTINGS, backend="serial", progress=False, seed=3,
                     simulate=solver)
    city = tiny_city()
    with pytest.raises(ValueError, match=r"inlet \(2 m/s toward 90 deg\) is not case 0's"):
        store.write_case(0, 0, fake_solution(city, 2.0, 90.0, SETTINGS["dx"]))
    with pytest.raises(ValueError, match=r"inlet \(9 m/s toward 0 deg\) is not case 0's"):
        store.write_case(0, 0, fake_solution(city, 9.0, 0.0, SETTINGS["dx"]))
    store.write_case(0, 1, fake_solution(city, 2.0, 450.0, SETTINGS["dx"]))  # 450 = 90 deg


# ----------------------------------------------------------------- sweeps


def test_sweep_store_layout_one_chunk_per_simulation_and_attributes(tmp_path):
    solver = FakeSolver(str(tmp_path / "log"))
    os.mkdir(solver.log_dir)
    store, results = sweep(MAPS, tmp_path / "s.zarr", speeds=[2.0, 6.0],
                           directions_deg=[0.0, 90.0, 225.0], settings=SETTINGS,
                           backend="serial", progress=False, seed=3, simulate=solver)
    assert all(r.ok for r in results) and len(results) == 2 * 6 == solver.calls()
    check_store_matches(store)
    root = zarr.open_group(store.path, mode="r")
    assert root.attrs["config"]["dx"] == 2.0 and root.attrs["seed"] == 3
    assert root.attrs["units"]["wind"] == "m/s"
    np.testing.assert_array_equal(root["cases/speed"][:], [2, 2, 2, 6, 6, 6])
    np.testing.assert_array_equal(root["cases/direction_deg"][:], [0, 90, 225] * 2)
    # maps of different sizes live in their own groups, each one chunk per simulation
    wind_a, wind_b = root["maps/0/wind"], root["maps/1/wind"]
    assert wind_a.shape == (6, 2, 20, 20) and wind_a.chunks == (1, 2, 20, 20)
    assert wind_b.shape == (6, 2, 15, 15) and wind_b.chunks == (1, 2, 15, 15)
    assert root["maps/0/done"].chunks == (1,)
    assert root.attrs["n_maps"] == 2
    a = store.map_attrs(1)
    assert a["spacing"] == [2.0, 2.0] and a["origin"] == [1.0, 1.0] and a["source"] == "b.json"
    assert np.all(np.isfinite(root["maps/0/seconds"][:]))
    seeds = np.concatenate([root["maps/0/seed"][:], root["maps/1/seed"][:]])
    assert len(set(seeds.tolist())) == seeds.size  # every simulation has its own seed


def test_sweep_records_frames_when_asked(tmp_path):
    solver = FakeSolver(str(tmp_path / "log"))
    os.mkdir(solver.log_dir)
    settings = {**SETTINGS, "steps": 6, "record_every": 2}
    store, _ = sweep(MAPS[:1], tmp_path / "s.zarr", speeds=[3.0], directions_deg=[45.0],
                     settings=settings, backend="serial", progress=False, simulate=solver)
    case = store.read_case(0, 0)
    _, _, _, u, v = expected_wind(MAPS[0][2], 3.0, 45.0, 2.0)
    assert case["frames_u"].shape == (3, 20, 20)
    np.testing.assert_array_equal(case["frames_v"][2], v * 0.8)


def test_interrupted_sweep_resumes_without_recomputing_and_without_corrupt_chunks(tmp_path):
    out = tmp_path / "s.zarr"
    kw = dict(speeds=[2.0, 6.0], directions_deg=[0.0, 90.0, 180.0], settings=SETTINGS,
              backend="serial", progress=False)
    os.mkdir(tmp_path / "log1")
    crashing = FakeSolver(str(tmp_path / "log1"), interrupt_after=4)
    with pytest.raises(KeyboardInterrupt):  # Ctrl-C during the 5th simulation
        sweep(MAPS, out, simulate=crashing, **kw)
    store = SweepStore(out)
    assert store.done(0).sum() == 4 and store.done(1).sum() == 0
    # A worker killed mid-write leaves a torn chunk that is not marked done:
    torn = Path(out, "maps", "0", "wind", "c", "5", "0", "0", "0")
    torn.parent.mkdir(parents=True, exist_ok=True)
    torn.write_bytes(b"\x28\xb5\x2f\xfd torn")
    with pytest.raises(ValueError, match="corrupt"):
        store.read_case(0, 5)

    os.mkdir(tmp_path / "log2")
    solver = FakeSolver(str(tmp_path / "log2"))
    store, results = sweep(MAPS, out, simulate=solver, **kw)
    assert solver.calls() == 12 - 4 == len(results)  # finished chunks were not recomputed
    assert {(r.task.map_index, r.task.case_index) for r in results}.isdisjoint(
        {(0, c) for c in range(4)})
    check_store_matches(store)  # the torn chunk was recomputed and overwritten
    os.mkdir(tmp_path / "log3")
    again = FakeSolver(str(tmp_path / "log3"))
    _, results = sweep(MAPS, out, simulate=again, **kw)
    assert again.calls() == 0 and results == []
    # damage to a finished chunk after the fact is found by verify and recomputed
    chunk = Path(out, "maps", "1", "wind", "c", "2", "0", "0", "0")
    raw = bytearray(chunk.read_bytes())
    raw[len(raw) // 2] ^= 0xFF
    chunk.write_bytes(bytes(raw))
    assert SweepStore(out).pending() == [] and SweepStore(out).pending(verify=True) == [(1, 2)]
    _, results = sweep(MAPS, out, simulate=again, verify=True, **kw)
    assert again.calls() == 1 and [(r.task.map_index, r.task.case_index) for r in results] == [
        (1, 2)]
    check_store_matches(SweepStore(out))


def test_failed_simulations_are_reported_and_retried_on_rerun(tmp_path):
    out = tmp_path / "s.zarr"
    kw = dict(speeds=[2.0, 6.0], directions_deg=[0.0, 90.0], settings=SETTINGS,
              progress=False)
    os.mkdir(tmp_path / "log1")
    flaky = FakeSolver(str(tmp_path / "log1"), fail_speed=6.0)
    store, results = sweep(MAPS, out, simulate=flaky, backend="process", workers=2, **kw)
    failed = [r for r in results if not r.ok]
    assert len(results) == 8 and len(failed) == 4
    assert all("solver diverged at 6.0 m/s" in r.error for r in failed)
    assert store.pending() == [(0, 2), (0, 3), (1, 2), (1, 3)]
    os.mkdir(tmp_path / "log2")
    fixed = FakeSolver(str(tmp_path / "log2"))
    store, results = sweep(MAPS, out, simulate=fixed, backend="serial", **kw)
    assert fixed.calls() == 4 and all(r.ok for r in results)
    check_store_matches(store)


def test_sweep_killed_with_sigkill_resumes(tmp_path):
    """A real kill of the whole process group (parent and workers) mid-sweep."""
    out, log1 = tmp_path / "s.zarr", tmp_path / "log1"
    log1.mkdir()
    script = textwrap.dedent(f"""
        import sys
        sys.path.insert(0, {str(HERE)!r})
        from test_wind_dataset import FakeSolver, MAPS, SETTINGS
        from windnav.experiments.wind_sweep import sweep
        sweep(MAPS, {str(out)!r}, speeds=[2.0, 6.0], directions_deg=[0.0, 90.0, 180.0],
              settings=SETTINGS, backend="process", workers=2, progress=False,
              simulate=FakeSolver({str(log1)!r}, sleep=1.0))
    """)
    proc = subprocess.Popen([sys.executable, "-c", script], start_new_session=True)
    try:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline and proc.poll() is None:
            time.sleep(0.1)
            try:
                if SweepStore(out).done(0).sum() >= 2:
                    break
            except ValueError:
                pass  # store not created yet
    finally:
        os.killpg(proc.pid, signal.SIGKILL)
        proc.wait()
    store = SweepStore(out)
    n_done = int(store.done(0).sum() + store.done(1).sum())
    assert 2 <= n_done < 12
    log2 = tmp_path / "log2"
    log2.mkdir()
    solver = FakeSolver(str(log2))
    store, results = sweep(MAPS, out, speeds=[2.0, 6.0], directions_deg=[0.0, 90.0, 180.0],
                           settings=SETTINGS, backend="serial", progress=False, simulate=solver)
    assert solver.calls() == 12 - n_done
    check_store_matches(store)


def test_resuming_with_a_different_sweep_is_refused(tmp_path):
    os.mkdir(tmp_path / "log")
    solver = FakeSolver(str(tmp_path / "log"))
    kw = dict(directions_deg=[0.0], backend="serial", progress=False, simulate=solver)
    sweep(MAPS[:1], tmp_path / "s.zarr", speeds=[2.0], settings=SETTINGS, **kw)
    with pytest.raises(ValueError, match="different sweep") as refused:
        sweep(MAPS[:1], tmp_path / "s.zarr", speeds=[2.0], settings={**SETTINGS, "dx": 1.0},
              **kw)
    assert "s.zarr" in str(refused.value) and "--" not in str(refused.value)  # no CLI flags
    with pytest.raises(ValueError, match="different sweep"):
        sweep(MAPS[1:], tmp_path / "s.zarr", speeds=[2.0], settings=SETTINGS, **kw)


def test_thesis_grid_is_the_default():
    from windnav.experiments.wind_sweep import auto_dt, directions_from

    np.testing.assert_allclose(THESIS_SPEEDS, np.linspace(0.1, 10.0, 5))
    np.testing.assert_array_equal(directions_from(), np.arange(0, 360, 45))
    # without --dt the step keeps the CFL number <= 1 at the fastest inlet (solver allows 2.5)
    assert auto_dt(1.0, 10.0) == pytest.approx(0.1) and auto_dt(1.0, 2.0) == 0.25


def test_directions_with_the_same_inlet_sides_are_batched_within_the_bitwise_limit():
    from windnav.experiments.wind_sweep import direction_batches

    recipe = [3.75, 56.25, 101.25, 198.75, 228.75, 296.25]  # the decoder recipe's six
    # west+south: 3.75, 56.25; east+south: 101.25; east+north: 198.75, 228.75; west+north
    assert direction_batches(recipe, 1) == {3.75: 0, 56.25: 0, 101.25: 1, 198.75: 2,
                                            228.75: 2, 296.25: 3}
    # two speeds a direction: two directions would be 4 runs, past the bitwise limit of 3
    assert direction_batches(recipe, 2) == {d: i for i, d in enumerate(recipe)}
    # the thesis's 8 directions have 8 different inlet sides
    assert sorted(direction_batches(np.arange(0, 360, 45), 1).values()) == list(range(8))
    # four with the same sides and one speed: a batch of 3, then one
    assert direction_batches([15.0, 30.0, 45.0, 60.0], 1) == {15.0: 0, 30.0: 0, 45.0: 0,
                                                              60.0: 1}
    assert direction_batches(recipe, 1, group_sides=False) == {d: i for i, d in enumerate(recipe)}


def test_sweep_steps_directions_of_the_same_sides_together_bit_for_bit(tmp_path):
    """10 and 40 deg enter on the west and south sides: one task, one factorisation, each
    field the same to the bit as its own simulation; 190 deg is a task of its own."""
    from windnav.flow import simulate

    city = City.from_rotorpy_json(write_tiny_map(tmp_path / "tiny.json"))
    settings = {"dx": 2.0, "dt": 0.2, "spinup_steps": 6, "steps": 6}
    store, results = sweep([("tiny", "tiny.json", city)], tmp_path / "s.zarr", speeds=[4.0],
                           directions_deg=[10.0, 190.0, 40.0], settings=settings,
                           backend="serial", progress=False)
    tasks = sorted(r.task.directions_deg for r in results)
    assert tasks == [(10.0, 40.0), (190.0,)]
    assert all(r.ok for r in results)
    for c in range(3):
        case = store.read_case(0, c)
        direct = simulate(city, speed=4.0, direction_deg=case["direction_deg"], **settings)
        np.testing.assert_array_equal(case["mean_u"], direct.mean_u)
        np.testing.assert_array_equal(case["mean_v"], direct.mean_v)


# ----------------------------------------------------------------- the CLI


def write_tiny_map(path):
    doc = {"bounds": {"extents": [0, 40, 0, 40, 0, 20]},
           "blocks": [{"extents": [15, 22, 14, 26, 0, 10], "color": [0, 1, 0]}]}
    path.write_text(json.dumps(doc))
    return path


def inlet_direction_deg(u, v, solid, x, y, direction_deg):
    """Direction of the mean wind averaged over the fluid cells in the upstream quarter."""
    a = np.deg2rad(direction_deg)
    X, Y = np.meshgrid(x - x.mean(), y - y.mean())
    along = X * np.cos(a) + Y * np.sin(a)
    sel = ~solid & (along < np.quantile(along, 0.25))
    return np.rad2deg(np.arctan2(v[sel].mean(), u[sel].mean())) % 360.0


def test_cli_wind_end_to_end(tmp_path, capsys):
    from matplotlib.image import imread

    from windnav.cli import main

    tiny = write_tiny_map(tmp_path / "tiny.json")
    rc = main(["wind", "--map", str(tiny), "--speed", "4", "--direction-deg", "30",
               "--out", str(tmp_path / "run"), "--dx", "1", "--dt", "0.1",
               "--spinup-steps", "30", "--steps", "20", "--record-every", "1", "--seed", "1"])
    assert rc == 0
    sol = load_flow(tmp_path / "run" / "flow.zarr")
    assert sol.mean_u.shape == (40, 40) and sol.frames_u.shape == (20, 40, 40)
    # physics: no wind inside buildings, and upstream the mean wind blows the inlet's way
    assert np.all(sol.mean_u[sol.solid] == 0) and np.all(sol.mean_v[sol.solid] == 0)
    got = inlet_direction_deg(sol.mean_u, sol.mean_v, sol.solid, sol.x, sol.y, 30.0)
    assert abs(got - 30.0) < 5.0
    # every step recorded: the stored frames average exactly to the stored mean
    np.testing.assert_allclose(sol.frames_u.mean(axis=0), sol.mean_u, rtol=0, atol=1e-12)
    np.testing.assert_allclose(sol.frames_v.mean(axis=0), sol.mean_v, rtol=0, atol=1e-12)
    np.testing.assert_allclose(sol.t, 0.1 * np.arange(1, 21))
    cfg = flow_attrs(tmp_path / "run" / "flow.zarr")["config"]
    assert cfg["speed"] == 4.0 and cfg["direction_deg"] == 30.0 and cfg["steps"] == 20
    assert cfg["seed"] == 1 and cfg["map_source"] == str(tiny)
    png = imread(tmp_path / "run" / "mean_speed.png")
    assert png.ndim == 3 and min(png.shape[:2]) > 200 and png.std() > 0.05  # a real picture
    captured = capsys.readouterr()
    printed, printed_err = captured.out, captured.err
    assert "flow.zarr" in printed_err  # "wrote" lines: standard error
    # the averaging diagnostics: printed, stored in the attributes and loaded back
    length = 40.0 * (np.cos(np.deg2rad(30)) + np.sin(np.deg2rad(30)))  # domain along the wind
    assert sol.flow_throughs_spinup == pytest.approx(4.0 * 30 * 0.1 / length)
    assert sol.flow_throughs_average == pytest.approx(4.0 * 20 * 0.1 / length)
    assert 0.0 < sol.half_window_difference < 1.0 and sol.smagorinsky == 0.17
    stored = flow_attrs(tmp_path / "run" / "flow.zarr")["solution"]
    assert stored["half_window_difference"] == sol.half_window_difference
    assert f"{sol.flow_throughs_spinup:.2f} and window" in printed
    assert "not converged" in printed  # 0.7 flow-throughs of spin-up


def test_cli_wind_sweep_end_to_end_matches_direct_simulation_and_resumes(tmp_path, capsys):
    from windnav.cli import main
    from windnav.flow import simulate

    tiny = write_tiny_map(tmp_path / "tiny.json")
    argv = ["wind-sweep", "--maps", str(tiny), "--out", str(tmp_path / "s.zarr"),
            "--speeds", "2", "5", "--directions", "2", "--backend", "serial",
            "--dx", "2", "--dt", "0.2", "--spinup-steps", "10", "--steps", "10",
            "--no-progress"]
    assert main(argv) == 0
    assert "4/4 simulations done (4 now" in capsys.readouterr().out
    store = SweepStore(tmp_path / "s.zarr")
    city = City.from_rotorpy_json(tiny)
    for c in range(4):
        case = store.read_case(0, c)
        direct = simulate(city, speed=case["speed"], direction_deg=case["direction_deg"],
                          dx=2.0, dt=0.2, spinup_steps=10, steps=10)
        # the sweep steps both speeds together (one multi-right-hand-side pressure solve):
        # the same arithmetic up to the summation order of the solve
        np.testing.assert_allclose(case["mean_u"], direct.mean_u, rtol=0, atol=1e-12)
        np.testing.assert_allclose(case["mean_v"], direct.mean_v, rtol=0, atol=1e-12)
        np.testing.assert_array_equal(case["solid"], direct.solid)
        for key, value in direct.diagnostics.items():  # stored per case
            assert case["diagnostics"][key] == pytest.approx(value, rel=1e-6), key
        got = inlet_direction_deg(case["mean_u"], case["mean_v"], case["solid"], case["x"],
                                  case["y"], case["direction_deg"])
        assert min(abs(got - case["direction_deg"]), 360 - abs(got - case["direction_deg"])) < 5
    assert main(argv) == 0
    assert "4/4 simulations done (0 now, 4 already" in capsys.readouterr().out


def test_cli_wind_flags_a_short_window_and_a_cell_above_the_validated_resolution(tmp_path,
                                                                                  capsys):
    """Audit: a 2-step window passed the half-window test (two near-identical snapshots), and
    a dx above s/8 (s the median building's smaller side: 7 m here, s/8 = 0.875 m) was
    accepted with only its filter width printed. Both are now said, in the output, the JSON and
    the Zarr attributes (the fields themselves are unchanged)."""
    from windnav.cli import main

    tiny = write_tiny_map(tmp_path / "tiny.json")
    js = tmp_path / "w.json"
    assert main(["wind", "--map", str(tiny), "--speed", "4", "--dx", "2", "--dt", "0.1",
                 "--spinup-steps", "60", "--steps", "2", "--out", str(tmp_path / "w"),
                 "--json", str(js)]) == 0
    captured = capsys.readouterr()
    assert "warning: the mean is not converged: window 0.02 flow-throughs, under 0.5" in \
        captured.out
    note = ("windnav wind: note: cell size above the validated resolution (s/8 = 0.875 m, s "
            "the median building's smaller side; dx = 2 m): results grid-dependent")
    assert note in captured.err
    assert captured.err.count("validated resolution") == 1  # not again as the solver's warning
    doc = json.loads(js.read_text())
    assert doc["averaging"]["converged"] is False and doc["averaging"]["level"] == "warning"
    assert "window 0.02" in doc["averaging"]["reason"]
    assert doc["resolution"]["grid_dependent"] is True
    assert doc["diagnostics"]["validated_dx"] == 0.875
    attrs = flow_attrs(tmp_path / "w" / "flow.zarr")
    assert attrs["averaging"] == doc["averaging"] and attrs["resolution"] == doc["resolution"]
    assert load_flow(tmp_path / "w" / "flow.zarr").flow_throughs_average == pytest.approx(0.02)


def test_cli_wind_sweep_names_the_cases_whose_mean_is_not_converged(tmp_path, capsys):
    """Audit: one time step for the sweep (set by the fastest inlet) and fixed steps gave the
    0.1 m/s case 0.005 flow-throughs of spin-up, and the output said only "2/2 simulations
    done". The cases failing the averaging rule are now named once, and counted in --json."""
    from windnav.cli import main

    tiny = write_tiny_map(tmp_path / "tiny.json")
    js = tmp_path / "s.json"
    argv = ["wind-sweep", "--maps", str(tiny), "--out", str(tmp_path / "s.zarr"),
            "--speeds", "0.1", "10", "--directions-deg", "0", "--backend", "serial",
            "--dx", "1", "--spinup-steps", "40", "--steps", "80", "--no-progress",
            "--json", str(js)]
    assert main(argv) == 0
    captured = capsys.readouterr()
    assert "2/2 simulations done" in captured.out
    warning = [line for line in captured.err.splitlines() if "not converged" in line]
    assert len(warning) == 1 and "windnav wind-sweep: warning:" in warning[0]
    assert "map tiny 0.1 m/s toward 0 deg (spin-up 0.01, window 0.02 flow-throughs" in \
        warning[0]
    assert "set by the fastest inlet, 10 m/s" in warning[0]
    doc = json.loads(js.read_text())
    bad = doc["averaging"]["not_converged"]
    assert doc["summary"]["not_converged"] == len(bad) >= 1
    assert doc["summary"]["averaging_checked"] == 2
    assert bad[0]["speed"] == 0.1 and bad[0]["map"] == "tiny"
    assert bad[0]["flow_throughs_spinup"] == pytest.approx(0.1 * 40 * 0.1 / 40)
    assert doc["resolution"][0]["map"] == "tiny" and doc["resolution"][0]["grid_dependent"]


def test_cli_errors_name_the_argument(tmp_path, capsys):
    from windnav.cli import main

    rc = main(["wind", "--map", str(tmp_path / "missing.json"), "--speed", "3",
               "--out", str(tmp_path / "o")])
    assert rc == 2 and "'--map'" in capsys.readouterr().err
    tiny = write_tiny_map(tmp_path / "tiny.json")
    rc = main(["wind", "--map", str(tiny), "--speed", "3", "--dx", "-1",
               "--out", str(tmp_path / "o")])
    assert rc == 2 and "'--dx'" in capsys.readouterr().err
    rc = main(["wind", "--map", str(tiny), "--speed", "3", "--steps", "2", "--record-every",
               "5", "--out", str(tmp_path / "o")])  # exit 0 with no frame recorded before
    assert rc == 2 and "'--record-every'" in capsys.readouterr().err
    rc = main(["wind-sweep", "--maps", str(tiny), "--out", str(tmp_path / "s.zarr"),
               "--directions", "2.5"])
    assert rc == 2 and "'--directions'" in capsys.readouterr().err
    rc = main(["wind-sweep", "--maps", str(tiny), "--out", str(tmp_path / "s90.zarr"),
               "--directions", "90", "--workers", "0"])  # refused after the note below
    err = capsys.readouterr().err
    assert rc == 2 and "--directions 90 is a count: 90 directions, 4 deg apart" in err
    for extra in (["--directions", "nan"],  # "cannot convert float NaN to integer" before
                  ["--directions", "1", "--directions-deg", "90"]):  # one silently ignored
        rc = main(["wind-sweep", "--maps", str(tiny), "--out", str(tmp_path / "s.zarr"), *extra])
        assert rc == 2 and "'--directions'" in capsys.readouterr().err


def test_cli_wind_sweep_refuses_a_direction_count_that_is_no_count(tmp_path, capsys):
    # `--directions 400` (an angle) ran 400 simulations 0.9 deg apart, and a NaN in a list
    # was "'directions' parameter of directions_from"; --workers 0 stops a run that got past
    from windnav.cli import build_parser, main

    tiny = write_tiny_map(tmp_path / "tiny.json")
    base = ["wind-sweep", "--maps", str(tiny), "--out", str(tmp_path / "s.zarr"),
            "--workers", "0"]
    for count in ("400", "361", "0", "-8"):
        assert main(base + ["--directions", count]) == 2
        err = capsys.readouterr().err
        assert ("'--directions' parameter of windnav wind-sweep must be, as one value, a count "
                "of directions from 1 to 360" in err), err
        # (400 and 361 deg were suggested, which --directions-deg refuses: CLI audit)
        assert (f"for a single direction of {count} deg, give --directions-deg {count}." in err
                ) == (abs(int(count)) <= 360), err
        assert "is a count" not in err  # refused, not noted
    for extra, flag in ((["--directions", "0", "nan"], "--directions"),
                        (["--directions-deg", "inf"], "--directions-deg")):
        assert main(base + extra) == 2
        err = capsys.readouterr().err
        assert f"'{flag}' parameter of windnav wind-sweep must be finite" in err, err
    sweep_parser = build_parser()._subparsers._group_actions[0].choices["wind-sweep"]
    text = " ".join(sweep_parser.format_help().split())
    assert "a COUNT N of directions (an integer, 1 to 360)" in text
    assert "never an angle" in text and "two or more values: the directions themselves" in text
    assert not (tmp_path / "s.zarr").exists()


def test_cli_wind_sweep_into_a_folder_of_other_files_names_out(tmp_path, capsys):
    # "SweepStore.create: cannot open the Zarr store ...: No group found in store" before
    from windnav.cli import main

    tiny = write_tiny_map(tmp_path / "tiny.json")
    junk = tmp_path / "junk"
    junk.mkdir()
    (junk / "a.txt").write_text("mine")
    assert main(["wind-sweep", "--maps", str(tiny), "--out", str(junk), "--speeds", "3",
                 "--directions-deg", "0", "--backend", "serial", "--no-progress"]) == 2
    err = capsys.readouterr().err
    assert (f"'--out' parameter of windnav wind-sweep must be a new or empty folder, or the "
            f"store of a sweep to resume. Got {str(junk)!r} instead, a folder of other files "
            "(no zarr.json)." in err), err
    assert sorted(p.name for p in junk.iterdir()) == ["a.txt"]


def test_cli_wind_sweep_into_a_store_of_another_sweep_names_out(tmp_path, capsys):
    from windnav.cli import build_parser, main
    from windnav.commands import wind_sweep

    tiny = write_tiny_map(tmp_path / "tiny.json")
    argv = ["wind-sweep", "--maps", str(tiny), "--out", str(tmp_path / "s.zarr"),
            "--speeds", "2", "--directions", "2", "--backend", "serial", "--dx", "2",
            "--steps", "2", "--no-progress"]
    os.mkdir(tmp_path / "log")
    solver = FakeSolver(str(tmp_path / "log"))
    assert wind_sweep.run(build_parser().parse_args(argv), simulate=solver) == 0
    argv[argv.index("--speeds") + 1] = "3"  # another sweep, refused before anything is solved
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert "'--out'" in err and "different sweep" in err and "s.zarr" in err
    assert solver.calls() == 2 and SweepStore(tmp_path / "s.zarr").speeds.tolist() == [2.0, 2.0]


def test_cli_wind_sweep_ctrl_c_exits_130_and_says_how_to_resume(tmp_path, capsys):
    from windnav.cli import build_parser
    from windnav.commands import wind_sweep

    tiny = write_tiny_map(tmp_path / "tiny.json")
    argv = ["wind-sweep", "--maps", str(tiny), "--out", str(tmp_path / "s.zarr"),
            "--speeds", "2", "--directions", "4", "--backend", "serial", "--dx", "2",
            "--steps", "2", "--no-progress"]
    os.mkdir(tmp_path / "log")
    crashing = FakeSolver(str(tmp_path / "log"), interrupt_after=3)
    assert wind_sweep.run(build_parser().parse_args(argv), simulate=crashing) == 130
    assert "3/4 simulations done" in capsys.readouterr().err
    os.mkdir(tmp_path / "log2")
    solver = FakeSolver(str(tmp_path / "log2"))
    assert wind_sweep.run(build_parser().parse_args(argv), simulate=solver) == 0
    assert solver.calls() == 1


def test_cli_wind_sweep_reports_failed_simulations_and_counts(tmp_path, capsys):
    from windnav.cli import build_parser
    from windnav.commands import wind_sweep

    tiny = write_tiny_map(tmp_path / "tiny.json")
    argv = ["wind-sweep", "--maps", str(tiny), "--out", str(tmp_path / "s.zarr"),
            "--speeds", "2", "6", "--directions", "2", "--backend", "serial", "--dx", "2",
            "--steps", "2", "--no-progress"]
    os.mkdir(tmp_path / "log")
    solver = FakeSolver(str(tmp_path / "log"), fail_speed=6.0)
    assert wind_sweep.run(build_parser().parse_args(argv), simulate=solver) == 1
    out = capsys.readouterr().out
    assert out.count("failed: map 0 cases") == 2 and "solver diverged at 6.0 m/s" in out
    assert "2/4 simulations done (2 now, 0 already, 2 failed)" in out


def test_two_processes_creating_one_store_at_once_both_finish_it(tmp_path):
    # each used to wipe the store the other was building: 2 of 4 tries failed, one leaving a
    # store no rerun could repair (store audit, 2026-12-05); now the second waits on the
    # creation lock, then resumes the finished store
    script = textwrap.dedent("""
        import sys
        from windnav.city import City
        from windnav.experiments.wind_sweep import sweep
        maps = [("a", "a.json", City((0, 40, 0, 40), [[15, 22, 12, 25]], [10.0])),
                ("b", "b.json", City((0, 30, 0, 30), [[20, 27, 12, 25]], [10.0]))]
        sweep(maps, sys.argv[1], speeds=[2.0, 3.0], directions_deg=[0.0],
              settings={"dx": 2.0, "dt": 0.1, "spinup_steps": 1, "steps": 4,
                        "record_every": 0}, backend="serial", progress=False, seed=1)
    """)
    for attempt in range(3):
        path = tmp_path / f"s{attempt}.zarr"
        procs = [subprocess.Popen([sys.executable, "-c", script, str(path)],
                                  stderr=subprocess.PIPE, text=True) for _ in range(2)]
        errors = [p.communicate(timeout=120)[1] for p in procs]
        assert [p.returncode for p in procs] == [0, 0], errors
        store = SweepStore(path)
        assert store.n_maps == 2 and all(store.done(k).all() for k in range(2))


def test_resuming_a_sweep_with_other_solver_code_is_said_and_recorded(tmp_path, monkeypatch):
    """A sweep resumed after a change of the solver's code mixed cases of both solvers, and
    nothing in the store or the output said so (cache audit). The store now records the
    solver's source hash of every run that solves cases; resuming with another one, when cases
    are done and others left, warns. A finished store is not a mix (review)."""
    import warnings

    import windnav.flow.sweep_store as ss

    kw = dict(directions_deg=[0.0, 90.0, 180.0], backend="serial", progress=False,
              speeds=[2.0], settings=SETTINGS)
    out = tmp_path / "s.zarr"
    for k in range(4):
        os.mkdir(tmp_path / f"log{k}")
    with pytest.raises(KeyboardInterrupt):                    # 1 of 3 cases solved
        sweep(MAPS[:1], out, simulate=FakeSolver(str(tmp_path / "log0"), interrupt_after=1),
              **kw)
    first = ss.module_key(ss.SOLVER_MODULE)
    assert SweepStore(out).solver_code == [first]
    monkeypatch.setattr(ss, "module_key", lambda name: "0123456789abcdef")
    with pytest.raises(KeyboardInterrupt), pytest.warns(
            UserWarning, match=r"1 finished case\(s\) solved by other solver code"):
        sweep(MAPS[:1], out, simulate=FakeSolver(str(tmp_path / "log1"), interrupt_after=1),
              **kw)
    assert SweepStore(out).solver_code == [first, "0123456789abcdef"]
    del zarr.open_group(str(out), mode="r+").attrs["solver_code"]   # a store from before
    monkeypatch.setattr(ss, "module_key", lambda name: "fedcba9876543210")
    with pytest.warns(UserWarning, match=r"2 finished case\(s\) solved by a windnav that did "
                                         "not record its solver code"):
        store, _ = sweep(MAPS[:1], out, simulate=FakeSolver(str(tmp_path / "log2")), **kw)
    assert store.solver_code == ["fedcba9876543210"]
    monkeypatch.setattr(ss, "module_key", lambda name: "1111111111111111")
    with warnings.catch_warnings():
        warnings.simplefilter("error")                        # finished: nothing is mixed
        store, _ = sweep(MAPS[:1], out, simulate=FakeSolver(str(tmp_path / "log3")), **kw)
    assert store.solver_code == ["fedcba9876543210"]


def test_a_case_found_damaged_in_a_finished_store_is_solved_under_a_recorded_hash(
        tmp_path, monkeypatch):
    """A finished store resumed under other solver code is no mix, but a case its verify then
    finds damaged is solved by the new code: the hash is recorded then (review's leftover)."""
    import windnav.flow.sweep_store as ss

    os.mkdir(tmp_path / "log")
    kw = dict(directions_deg=[0.0, 90.0], backend="serial", progress=False, speeds=[2.0],
              settings=SETTINGS, simulate=FakeSolver(str(tmp_path / "log")))
    out = tmp_path / "s.zarr"
    sweep(MAPS[:1], out, **kw)
    first = ss.module_key(ss.SOLVER_MODULE)
    chunk = Path(out, "maps", "0", "wind", "c", "1", "0", "0", "0")
    raw = bytearray(chunk.read_bytes())
    raw[len(raw) // 2] ^= 0xFF
    chunk.write_bytes(bytes(raw))
    monkeypatch.setattr(ss, "module_key", lambda name: "0123456789abcdef")
    with pytest.warns(UserWarning, match=r"1 finished case\(s\) solved by other solver code"):
        store, results = sweep(MAPS[:1], out, verify=True, **kw)
    assert len(results) == 1 and store.solver_code == [first, "0123456789abcdef"]


def test_a_solver_changed_during_the_run_is_not_recorded_as_a_hash(tmp_path, monkeypatch):
    """A "-modified" hash names no code a later run could match; the store records none and
    says why (review)."""
    import windnav.flow.sweep_store as ss

    kw = dict(directions_deg=[0.0, 90.0], backend="serial", progress=False, speeds=[2.0],
              settings=SETTINGS)
    out = tmp_path / "s.zarr"
    os.mkdir(tmp_path / "log0")
    os.mkdir(tmp_path / "log1")
    with pytest.raises(KeyboardInterrupt):
        sweep(MAPS[:1], out, simulate=FakeSolver(str(tmp_path / "log0"), interrupt_after=1),
              **kw)
    first = SweepStore(out).solver_code
    monkeypatch.setattr(ss, "module_key", lambda name: "0123456789abcdef-modified")
    with pytest.warns(UserWarning, match="cannot name"):
        store, _ = sweep(MAPS[:1], out, simulate=FakeSolver(str(tmp_path / "log1")), **kw)
    assert store.solver_code == first
