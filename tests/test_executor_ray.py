"""The executor's ``ray`` backend on a real local Ray instance: same records as ``serial`` and
``process``, per-task failures, reuse of the caller's Ray, and a real wind sweep written through
Ray that is bit-identical to the same sweep written by worker processes.

Ray is a test dependency (``windnav[test]``): it is imported at module level, so a missing Ray
fails this file instead of skipping it.
"""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import ray
import zarr

from windnav.city import City
from windnav.experiments.executor import run_tasks
from windnav.experiments.wind_sweep import sweep

HERE = Path(__file__).resolve().parent


@pytest.fixture(scope="module")
def local_ray():
    """One local Ray instance, started by the test (2 CPUs), shut down after the module.

    Ray workers import the task functions by module name, so this folder goes on their path
    (the ``process`` backend's spawned workers inherit ``sys.path`` instead).
    """
    import shutil
    import tempfile

    assert not ray.is_initialized(), "another test left Ray running"
    path = os.pathsep.join(p for p in (str(HERE), os.environ.get("PYTHONPATH")) if p)
    # Ray's session files (about 220 kB a start) in a folder removed afterwards: by default
    # they stayed in /tmp/ray for good (isolation audit, thirty-seventh session); a short path,
    # as Ray's socket names must fit 107 characters
    temp = tempfile.mkdtemp(prefix="wn-ray-", dir="/tmp" if os.path.isdir("/tmp") else None)
    ray.init(num_cpus=2, include_dashboard=False, _temp_dir=temp,
             runtime_env={"env_vars": {"PYTHONPATH": path}})
    try:
        yield ray
    finally:
        ray.shutdown()
        shutil.rmtree(temp, ignore_errors=True)


def _seeded_mean(task):
    """A deterministic stochastic task: the mean of n normal draws under a given seed."""
    seed, n = task
    if n < 0:
        raise ValueError(f"negative sample count {n}")
    return float(np.random.default_rng(seed).normal(size=n).mean())


def _where(_task):
    return os.getpid(), ray.is_initialized() and ray.get_runtime_context().get_worker_id()


TASKS = [(s, 1000) for s in range(6)] + [(99, -1)] + [(s, 10) for s in range(6, 9)]


def _by_index(results):
    return sorted(results, key=lambda r: r.index)


def test_ray_gives_the_same_records_as_serial_and_process(local_ray):
    runs = {
        backend: _by_index(run_tasks(_seeded_mean, TASKS, backend=backend, workers=2,
                                     progress=False))
        for backend in ("serial", "process", "ray")
    }
    for backend, results in runs.items():
        assert [r.index for r in results] == list(range(len(TASKS))), backend
        assert [r.task for r in results] == TASKS, backend
    for a, b, c in zip(runs["serial"], runs["process"], runs["ray"], strict=True):
        assert a.ok == b.ok == c.ok
        assert a.value == b.value == c.value  # bit-identical: same task code on every backend
    assert runs["ray"][0].value == _seeded_mean(TASKS[0])


def test_one_failing_task_under_ray_is_reported_and_does_not_abort_the_others(local_ray):
    results = list(run_tasks(_seeded_mean, TASKS, backend="ray", progress=False))
    assert len(results) == len(TASKS)
    failed = [r for r in results if not r.ok]
    assert [r.index for r in failed] == [6]
    assert failed[0].value is None
    assert failed[0].error.startswith("ValueError: negative sample count -1")
    assert "Traceback" in failed[0].error  # the worker's traceback comes back with the record
    assert all(r.ok and r.error is None and r.seconds >= 0 for r in results if r.index != 6)


def _dies_on_two(task):
    if task == 2:
        os._exit(3)  # the worker process itself dies (as if killed, or out of memory)
    return 2 * task


def test_a_worker_dying_under_ray_fails_only_its_own_task(local_ray):
    # Ray retries a task whose worker died (3 times by default), then reports it lost.
    results = _by_index(run_tasks(_dies_on_two, range(5), backend="ray", progress=False))
    assert [r.ok for r in results] == [True, True, False, True, True]
    assert [r.value for r in results] == [0, 2, None, 6, 8]
    assert results[2].error.startswith("WorkerCrashedError")


def test_ray_backend_reuses_the_running_instance_and_runs_in_ray_workers(local_ray):
    job = ray.get_runtime_context().get_job_id()
    # workers=1 would start a 1-CPU Ray if the backend initialised its own
    results = list(run_tasks(_where, range(4), backend="ray", workers=1, progress=False))
    assert all(r.ok for r in results)
    assert ray.is_initialized() and ray.get_runtime_context().get_job_id() == job
    assert ray.cluster_resources()["CPU"] == 2
    pids = {r.value[0] for r in results}
    assert os.getpid() not in pids
    assert all(isinstance(r.value[1], str) and r.value[1] for r in results)  # a Ray worker


def _tiny_city():
    return City((0.0, 40.0, 0.0, 40.0), [[15.0, 22.0, 14.0, 26.0]], [10.0])


SWEEP = dict(speeds=[2.0, 5.0], directions_deg=[0.0, 90.0], progress=False, seed=7,
             settings={"dx": 2.0, "dt": 0.2, "spinup_steps": 10, "steps": 10,
                       "record_every": 5})


def _arrays(path):
    """Every stored array of map 0 but the solve times."""
    g = zarr.open_group(str(path), mode="r")["maps/0"]
    return {name: g[name][...] for name in ("x", "y", "wind", "solid", "frames", "seed", "done")}


def test_real_wind_sweep_through_ray_is_bit_identical_to_process_and_serial(local_ray, tmp_path):
    maps = [("tiny", "test", _tiny_city())]
    stores = {}
    for backend in ("ray", "process", "serial"):
        store, results = sweep(maps, tmp_path / f"{backend}.zarr", backend=backend, workers=2,
                               **SWEEP)
        # one task per direction, its two speeds stepped together
        assert len(results) == 2 and all(r.ok for r in results), [r.error for r in results]
        assert sorted(c for r in results for c in r.task.case_indices) == [0, 1, 2, 3]
        assert store.pending() == []
        stores[backend] = _arrays(store.path)
    ray_arrays = stores["ray"]
    # the flow itself: finite everywhere, still air inside the building, the inlet's speed
    wind, solid = ray_arrays["wind"], ray_arrays["solid"]
    assert wind.shape == (4, 2, 20, 20) and ray_arrays["frames"].shape == (4, 2, 2, 20, 20)
    assert np.isfinite(wind).all() and solid.any()
    assert np.all(wind[:, 0][solid] == 0) and np.all(wind[:, 1][solid] == 0)
    speed = np.hypot(wind[:, 0], wind[:, 1])
    for c, inlet in enumerate([2.0, 2.0, 5.0, 5.0]):
        assert 0.5 * inlet < np.median(speed[c][~solid[c]]) < 1.5 * inlet
    for backend in ("process", "serial"):
        for name, value in ray_arrays.items():
            other = stores[backend][name]
            assert value.dtype == other.dtype and value.shape == other.shape, (backend, name)
            assert value.tobytes() == other.tobytes(), (backend, name)  # bit for bit
