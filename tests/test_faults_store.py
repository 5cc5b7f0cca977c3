"""Damaged stores are found, named and repaired: no silent wrong results, no lost data.

Each kind of damage a disk, a person or a crash can do to a finished store -- a deleted chunk
(Zarr reads it back as the fill value: NaN wind, zeros, "no building"), flipped bytes in a
chunk, a deleted array, lost attributes -- is made on a tiny sweep. ``SweepStore.verify`` must
find exactly the damaged cases, ``sweep(verify=True)`` must recompute exactly those, and the
store must then equal an undamaged run. Single flow files must refuse to load, naming the array.
"""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import numpy as np
import pytest
import zarr
from test_wind_dataset import MAPS, SETTINGS, FakeSolver, fake_solution, tiny_city

from windnav.experiments.wind_sweep import sweep
from windnav.flow import load_flow, save_flow
from windnav.flow.sweep_store import CorruptStoreError, SweepStore

FRAMES = {**SETTINGS, "steps": 4, "record_every": 2}  # two frames per case
KW = dict(speeds=[2.0, 6.0], directions_deg=[0.0, 90.0], settings=FRAMES, backend="serial",
          progress=False)


def solver(tmp_path, name):
    log = tmp_path / name
    log.mkdir()
    return FakeSolver(str(log))


def called(fake):
    """The (speed, direction) of every simulation ``fake`` ran."""
    return sorted(tuple(float(p) for p in f.split("_")[:2]) for f in os.listdir(fake.log_dir))


def flip_byte(path: Path) -> None:
    raw = bytearray(path.read_bytes())
    raw[len(raw) // 2] ^= 0xFF  # one flipped byte in the middle of the compressed frame
    path.write_bytes(bytes(raw))


def chunk(out, k, name, *index) -> Path:
    return Path(out, "maps", str(k), name, "c", *(str(i) for i in index))


def assert_same_data(a: SweepStore, b: SweepStore) -> None:
    """Every array of every case equal (``seconds`` and its digest are wall-clock times)."""
    for k in range(a.n_maps):
        assert a.done(k).all() and b.done(k).all()
        for name in ("x", "y", "seed", "wind", "solid", "frames", "diagnostics"):
            np.testing.assert_array_equal(a.group[f"maps/{k}/{name}"][...],
                                          b.group[f"maps/{k}/{name}"][...], err_msg=name)


@pytest.fixture
def finished(tmp_path):
    """A finished sweep (2 maps x 4 cases, frames recorded) and an untouched copy of it."""
    out = tmp_path / "s.zarr"
    sweep(MAPS, out, simulate=solver(tmp_path, "log0"), **KW)
    shutil.copytree(out, tmp_path / "reference.zarr")
    return out, SweepStore(tmp_path / "reference.zarr")


def test_every_kind_of_damage_is_found_and_exactly_those_cases_are_recomputed(
        tmp_path, finished):
    out, reference = finished
    assert SweepStore(out).verify().ok
    chunk(out, 0, "wind", 3, 0, 0, 0).unlink()  # deleted: would read back as NaN
    flip_byte(chunk(out, 0, "solid", 2, 0, 0))  # corrupt bytes in the building mask
    flip_byte(chunk(out, 1, "frames", 1, 1, 0, 0, 0))  # a corrupt frame
    chunk(out, 1, "frames", 2, 0, 0, 0, 0).unlink()  # a deleted frame
    chunk(out, 1, "checksums", 0, 0).unlink()  # the digests of a case themselves
    report = SweepStore(out).verify()
    assert report.cases == [(0, 2), (0, 3), (1, 0), (1, 1), (1, 2)]
    assert report.n_checked == 8 and report.store == () and not report.ok
    assert report.damaged[(0, 3)] == ("wind: does not match its checksum (a chunk is missing "
                                      "or damaged)",)
    assert report.damaged[(0, 2)][0].startswith("solid: unreadable")
    assert report.damaged[(1, 1)][0].startswith("frames: unreadable")
    assert report.damaged[(1, 2)][0].startswith("frames: does not match")
    assert report.damaged[(1, 0)] == ("checksums: not recorded (a chunk is missing)",)
    # readers do not get the damaged data silently either
    with pytest.raises(CorruptStoreError, match=r"read_case\(0, 3\).*s\.zarr.*wind"):
        SweepStore(out).read_case(0, 3)
    with pytest.raises(CorruptStoreError, match="frames"):
        SweepStore(out).read_case(1, 2)
    assert SweepStore(out).read_case(0, 0)["done"]  # the others read as before
    # a plain resume trusts the done markers; verify recomputes exactly the damaged cases
    fake = solver(tmp_path, "log1")
    _, results = sweep(MAPS, out, simulate=fake, **KW)
    assert results == [] and called(fake) == []
    store, results = sweep(MAPS, out, simulate=fake, verify=True, **KW)
    assert store.last_verify.cases == report.cases
    assert sorted((r.task.map_index, r.task.case_index) for r in results) == report.cases
    # cases are (speed, direction) with speeds outermost: c = 0 (2, 0), 1 (2, 90), 2 (6, 0) ...
    assert called(fake) == [(2.0, 0.0), (2.0, 90.0), (6.0, 0.0), (6.0, 0.0), (6.0, 90.0)]
    assert_same_data(SweepStore(out), reference)
    assert SweepStore(out).verify().ok


def test_damaged_case_is_marked_not_done_so_an_interrupted_repair_resumes(tmp_path, finished):
    out, reference = finished
    chunk(out, 0, "wind", 1, 0, 0, 0).unlink()
    store = SweepStore(out, mode="r+")
    store.invalidate(store.verify().damaged)
    assert SweepStore(out).pending() == [(0, 1)]  # found once, not forgotten
    fake = solver(tmp_path, "log1")
    sweep(MAPS, out, simulate=fake, **KW)  # no verify needed any more
    assert called(fake) == [(2.0, 90.0)]
    assert_same_data(SweepStore(out), reference)


def test_damage_to_the_shared_arrays_is_repaired_on_resume(tmp_path, finished):
    out, reference = finished
    chunk(out, 1, "seed", 3).unlink()  # would read back as seed 0
    flip_byte(chunk(out, 0, "x", 0))
    Path(out, "cases", "speed", "c", "0").unlink()  # would read back as speeds 0
    with pytest.raises(CorruptStoreError, match=r"'cases/speed'.*s\.zarr"):
        SweepStore(out)
    fake = solver(tmp_path, "log1")
    store, results = sweep(MAPS, out, simulate=fake, verify=True, **KW)
    assert sorted(store.repaired) == ["cases/speed", "maps/0/x", "maps/1/seed"]
    assert results == [] and called(fake) == []  # the cases themselves were intact
    assert_same_data(SweepStore(out), reference)
    np.testing.assert_array_equal(SweepStore(out).speeds, reference.speeds)


def test_a_lost_array_is_recreated_and_its_cases_recomputed(tmp_path, finished):
    out, reference = finished
    shutil.rmtree(Path(out, "maps", "1", "solid"))
    report = SweepStore(out).verify()
    assert report.cases == [(1, c) for c in range(4)]
    fake = solver(tmp_path, "log1")
    store, _ = sweep(MAPS, out, simulate=fake, verify=True, **KW)
    assert store.repaired == ["maps/1/solid"] and len(called(fake)) == 4
    assert_same_data(SweepStore(out), reference)


def test_the_real_solver_sweep_recomputes_damaged_cases_to_the_same_numbers(tmp_path):
    """The issue's reproduction, on the real solver: deleted wind, corrupt solid and frames."""
    settings = {"dx": 2.0, "dt": 0.2, "spinup_steps": 2, "steps": 4, "record_every": 2}
    kw = dict(speeds=[2.0, 4.0], directions_deg=[0.0, 90.0, 180.0, 270.0], settings=settings,
              backend="serial", progress=False)
    out = tmp_path / "s.zarr"
    sweep(MAPS, out, **kw)
    shutil.copytree(out, tmp_path / "reference.zarr")
    chunk(out, 0, "wind", 5, 0, 0, 0).unlink()
    flip_byte(chunk(out, 0, "solid", 2, 0, 0))
    flip_byte(chunk(out, 1, "frames", 6, 0, 0, 0, 0))
    chunk(out, 1, "diagnostics", 7, 0).unlink()
    store, results = sweep(MAPS, out, verify=True, **kw)
    assert store.last_verify.cases == [(0, 2), (0, 5), (1, 6), (1, 7)]
    assert sorted(c for r in results for c in r.task.case_indices) == [2, 5, 6, 7]
    a, b = SweepStore(out), SweepStore(tmp_path / "reference.zarr")
    for k in range(2):
        assert a.done(k).all()
        for c in range(8):
            got, want = a.read_case(k, c), b.read_case(k, c)
            np.testing.assert_array_equal(got["solid"], want["solid"])
            # a recomputed case ran alone, not with the other speed of its direction: the
            # same arithmetic up to the summation order of the multi-right-hand-side solve
            for name in ("mean_u", "mean_v", "frames_u", "frames_v"):
                np.testing.assert_allclose(got[name], want[name], rtol=0, atol=1e-12)
                assert np.isfinite(got[name]).all()
            assert got["diagnostics"] == pytest.approx(want["diagnostics"], rel=1e-9)
    assert a.verify().ok


def _strip_digests(out):
    """Turn a store into one written before digests existed."""
    root = zarr.open_group(str(out), mode="r+")
    attrs = dict(root.attrs)
    attrs.pop("checksums")
    root.attrs.clear()
    root.attrs.update(attrs)
    for k in range(root.attrs["n_maps"]):
        g = root[f"maps/{k}"]
        attrs = dict(g.attrs)
        attrs.pop("checksums")
        g.attrs.clear()
        g.attrs.update(attrs)
        shutil.rmtree(Path(out, "maps", str(k), "checksums"))


def test_a_store_without_digests_is_reported_unverified_and_obvious_damage_still_found(
        tmp_path, finished):
    out, reference = finished
    _strip_digests(out)
    chunk(out, 0, "wind", 1, 0, 0, 0).unlink()  # NaN wind: no finished case has that
    flip_byte(chunk(out, 1, "solid", 3, 0, 0))  # unreadable
    report = SweepStore(out).verify()
    assert report.cases == [(0, 1), (1, 3)]
    assert report.damaged[(0, 1)] == ("wind: not finite (a chunk is missing)",)
    assert sorted(report.unverified) == [(0, 0), (0, 2), (0, 3), (1, 0), (1, 1), (1, 2)]
    fake = solver(tmp_path, "log1")
    store, results = sweep(MAPS, out, simulate=fake, verify=True, **KW)
    assert len(called(fake)) == 2 and store.last_verify.unverified == report.unverified
    assert_same_data(SweepStore(out), reference)


@pytest.mark.parametrize("missing", ["n_maps", "config", "identity"])
def test_a_store_without_its_attributes_is_a_named_error(tmp_path, finished, missing):
    out, _ = finished
    meta = Path(out, "zarr.json")
    doc = json.loads(meta.read_text())
    del doc["attributes"][missing]
    meta.write_text(json.dumps(doc))
    with pytest.raises(CorruptStoreError, match=rf"s\.zarr.*'{missing}' attribute") as err:
        if missing == "identity":
            sweep(MAPS, out, simulate=solver(tmp_path, "log1"), **KW)
        else:
            SweepStore(out)
    assert isinstance(err.value, ValueError) and "--" not in str(err.value)


def test_a_store_with_unreadable_metadata_is_a_named_error(tmp_path, finished):
    out, _ = finished
    Path(out, "zarr.json").write_text("{not json")
    with pytest.raises(CorruptStoreError, match=r"s\.zarr"):
        SweepStore(out)
    with pytest.raises(ValueError, match="no Zarr store") as err:
        SweepStore(tmp_path / "nothing.zarr")
    assert not isinstance(err.value, CorruptStoreError)


# ----------------------------------------------------------------- one flow solution


@pytest.fixture
def flow_file(tmp_path):
    sol = fake_solution(tiny_city(), 5.0, 30.0, 2.0, dt=0.25, steps=6, record_every=2)
    path = tmp_path / "f.zarr"
    save_flow(sol, path)
    return path, sol


@pytest.mark.parametrize(
    "name, damage",
    [("mean_u", "delete"), ("mean_v", "flip"), ("solid", "delete"), ("frames_u", "delete"),
     ("frames_v", "flip"), ("x", "delete")],
)
def test_load_flow_names_the_damaged_array(flow_file, name, damage):
    path, _ = flow_file
    files = sorted(p for p in Path(path, name, "c").rglob("*") if p.is_file())
    target = files[len(files) // 2]
    target.unlink() if damage == "delete" else flip_byte(target)
    with pytest.raises(CorruptStoreError, match=rf"{name}.*f\.zarr|f\.zarr.*{name}") as err:
        load_flow(path)
    assert isinstance(err.value, ValueError) and "--" not in str(err.value)


def test_load_flow_refuses_a_store_that_lost_a_whole_array(flow_file):
    path, _ = flow_file
    shutil.rmtree(Path(path, "frames_v"))  # would otherwise load as "no frames recorded"
    with pytest.raises(CorruptStoreError, match="frames_v"):
        load_flow(path)


def test_load_flow_of_a_file_without_digests_warns_and_loads(flow_file):
    path, sol = flow_file
    meta = Path(path, "zarr.json")
    doc = json.loads(meta.read_text())
    del doc["attributes"]["checksums"]
    meta.write_text(json.dumps(doc))
    with pytest.warns(UserWarning, match=r"f\.zarr.*without checksums"):
        back = load_flow(path)
    np.testing.assert_array_equal(back.mean_u, sol.mean_u)
    np.testing.assert_array_equal(back.frames_v, sol.frames_v)


def test_save_flow_replaces_a_flow_but_never_empties_a_folder_of_other_files(flow_file,
                                                                              tmp_path):
    path, sol = flow_file
    save_flow(sol, path)  # a flow solution is replaced, as documented
    assert load_flow(path).mean_u.shape == sol.mean_u.shape
    mine = tmp_path / "results"
    mine.mkdir()
    (mine / "important.csv").write_text("x\n1\n")
    # zarr's mode "w" deleted important.csv before (audit, 2026-12-05)
    with pytest.raises(ValueError, match="'path' parameter of save_flow must be a new or empty "
                                         "folder, or a flow solution"):
        save_flow(sol, mine)
    assert (mine / "important.csv").read_text() == "x\n1\n"
    (tmp_path / "a_file").write_text("x")
    with pytest.raises(ValueError, match="'path' parameter of save_flow"):
        save_flow(sol, tmp_path / "a_file")
    (tmp_path / "empty").mkdir()
    save_flow(sol, tmp_path / "empty")
    assert load_flow(tmp_path / "empty").mean_u.shape == sol.mean_u.shape


def test_a_foreign_checksums_attribute_and_an_unknown_mode_are_named(flow_file, tmp_path):
    import zarr

    path, _ = flow_file
    group = zarr.open_group(str(path), mode="r+")
    group.attrs["checksums"] = ["not", "a", "table"]  # an AttributeError before
    with pytest.raises(CorruptStoreError, match="corrupt 'checksums' attribute"):
        load_flow(path)
    with pytest.raises(ValueError, match="'mode' parameter of SweepStore must be 'r' or 'r\\+'"):
        SweepStore(tmp_path, mode="zz")  # a CorruptStoreError with an empty message before


def test_save_flow_refuses_a_solution_that_would_load_and_fail_later(flow_file, tmp_path):
    import dataclasses

    _, sol = flow_file
    for change, match in (({"t": sol.t[:-1]}, "one time per frame"),
                          ({"x": sol.x[::-1].copy()}, "x of at least two finite, increasing"),
                          ({"frames_v": None}, "both frames_u and frames_v, or neither")):
        with pytest.raises(ValueError, match=match):
            save_flow(dataclasses.replace(sol, **change), tmp_path / "bad.zarr")
        assert not (tmp_path / "bad.zarr").exists()


def test_save_flow_names_a_solution_that_is_not_one(tmp_path):
    with pytest.raises(ValueError, match="'solution' parameter of save_flow must be a "
                                         "FlowSolution"):
        save_flow("x", tmp_path / "f.zarr")  # an AttributeError before


def test_an_unverified_store_whose_arrays_do_not_fit_the_grid_is_refused(flow_file):
    """Without checksums (an older windnav's store, or the attribute deleted) a (ny - 1, nx)
    mean on the (ny, nx) grid loaded, with only the unverified warning (files audit)."""
    import zarr

    path, sol = flow_file
    group = zarr.open_group(str(path), mode="r+")
    del group["mean_u"]
    group.create_array("mean_u", data=sol.mean_u[:-1])  # save_flow would refuse it
    meta = Path(path, "zarr.json")
    doc = json.loads(meta.read_text())
    del doc["attributes"]["checksums"]
    meta.write_text(json.dumps(doc))
    with pytest.warns(UserWarning, match="without checksums"), pytest.raises(
            CorruptStoreError, match=r"'mean_u' of the Zarr store .* has shape \(\d+, \d+\) "
                                     r"where the grid .* needs"):
        load_flow(path)


def test_a_second_sweep_into_a_store_another_run_is_computing_waits_for_it(tmp_path,
                                                                           held_elsewhere):
    """Two wind-sweep runs on one store both computed every pending case (the store stayed
    right, the time was spent twice; concurrency audit). A run holds an flock on the store
    folder itself; a second one says so, waits for it to end, and then computes only what it
    left (nothing here): both finish, as before, and the work is done once."""
    import time

    out = tmp_path / "s.zarr"
    sweep(MAPS[:1], out, simulate=solver(tmp_path, "log0"), **{**KW, "speeds": [2.0]})
    with held_elsewhere("exclusive_folder", out, seconds=2.0):
        second = solver(tmp_path, "log1")
        t0 = time.perf_counter()
        with pytest.warns(UserWarning, match=r"another run is writing the sweep store "
                                             r".*s\.zarr': waiting for it to end"):
            store, results = sweep(MAPS[:1], out, simulate=second, **{**KW, "speeds": [2.0]})
        assert time.perf_counter() - t0 > 1.0   # it waited for the holder
        assert results == [] and called(second) == [] and store.done(0).all()
    assert sorted(p.name for p in out.iterdir() if p.name.startswith(".")) == []  # no lock file
