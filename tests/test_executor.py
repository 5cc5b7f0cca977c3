"""The sweep executor: same results on every backend, per-task failures, streaming, validation."""

from __future__ import annotations

import functools
import os
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from windnav.experiments.executor import BackendUnavailableError, TaskResult, run_tasks


def _seeded_mean(task):
    """A deterministic stochastic task: the mean of n normal draws under a given seed."""
    seed, n = task
    if n < 0:
        raise ValueError(f"negative sample count {n}")
    return float(np.random.default_rng(seed).normal(size=n).mean())


def _scaled(task, factor):
    return task * factor


def _pid(_task):
    return os.getpid()


def _dies(task, folder, always):
    """Task ``(i, value)``: the worker process dies at task ``i == 2`` (the first time only,
    unless ``always``), as under the out-of-memory killer; else ``value`` squared."""
    i, value = task
    marker = Path(folder) / "died"
    if i == 2 and (always or not marker.exists()):
        marker.touch()
        os._exit(1)
    time.sleep(0.05)
    return value * value


TASKS = [(s, 1000) for s in range(6)] + [(99, -1)] + [(s, 10) for s in range(6, 9)]


def _by_index(results):
    return sorted(results, key=lambda r: r.index)


def test_serial_and_process_backends_give_identical_records():
    serial = _by_index(run_tasks(_seeded_mean, TASKS, backend="serial", progress=False))
    process = _by_index(
        run_tasks(_seeded_mean, TASKS, backend="process", workers=2, progress=False)
    )
    assert [r.index for r in serial] == list(range(len(TASKS)))
    assert [r.index for r in process] == list(range(len(TASKS)))
    for a, b in zip(serial, process, strict=True):
        assert a.task == b.task == TASKS[a.index]
        assert a.ok == b.ok
        assert a.value == b.value  # bit-identical: the task code is the same in every backend
    # the reference value is what calling the function directly gives
    assert serial[0].value == _seeded_mean(TASKS[0])


@pytest.mark.parametrize("backend", ["serial", "process"])
def test_one_failing_task_is_reported_and_does_not_abort_the_others(backend):
    results = list(run_tasks(_seeded_mean, TASKS, backend=backend, workers=2, progress=False))
    assert len(results) == len(TASKS)
    failed = [r for r in results if not r.ok]
    assert [r.index for r in failed] == [6]
    assert failed[0].value is None
    assert failed[0].error.startswith("ValueError: negative sample count -1")
    assert all(r.ok and r.error is None and r.seconds >= 0 for r in results if r.index != 6)


def test_results_stream_back_as_they_finish():
    # The consumer sees the first record before the later tasks are started (serial), so a
    # caller can write and checkpoint each result as it arrives.
    seen = []

    def record(task):
        seen.append(task)
        return task

    stream = run_tasks(record, range(5), backend="serial", progress=False)
    first = next(stream)
    assert isinstance(first, TaskResult) and first.value == 0
    assert seen == [0]
    assert [r.value for r in stream] == [1, 2, 3, 4]


def test_process_backend_runs_in_worker_processes_and_accepts_partials():
    pids = {r.value for r in run_tasks(_pid, range(4), workers=2, progress=False)}
    assert os.getpid() not in pids
    scaled = _by_index(run_tasks(functools.partial(_scaled, factor=3), [1, 2], workers=2,
                                 progress=False))
    assert [r.value for r in scaled] == [3, 6]


def test_empty_task_list_yields_nothing():
    assert list(run_tasks(_seeded_mean, [], backend="process", progress=False)) == []


def test_bad_arguments_are_named_at_the_call():
    with pytest.raises(ValueError, match="'backend' parameter of run_tasks"):
        run_tasks(_seeded_mean, TASKS, backend="threads")
    with pytest.raises(ValueError, match="'workers' parameter of run_tasks"):
        run_tasks(_seeded_mean, TASKS, workers=0)


def test_ray_backend_without_ray_says_how_to_install_it(monkeypatch):
    # Ray is a test dependency, so hide it: a None entry makes `import ray` raise ImportError.
    # (The ray backend itself is tested on a real local Ray in test_executor_ray.py.)
    monkeypatch.setitem(sys.modules, "ray", None)
    with pytest.raises(BackendUnavailableError, match=r"pip install 'windnav\[ray\]'") as err:
        run_tasks(_seeded_mean, TASKS, backend="ray")
    # a bad choice of argument for this installation: a ValueError (and an ImportError)
    assert isinstance(err.value, ValueError) and isinstance(err.value, ImportError)
    assert "backend='process'" in str(err.value)


def _record_pid(task):
    folder, index, seconds = task
    Path(folder, f"pid-{os.getpid()}-{index}").touch()
    time.sleep(seconds)
    Path(folder, f"end-{index}").touch()
    return index


def _worker_pids(folder):
    return {int(p.name.split("-")[1]) for p in Path(folder).glob("pid-*")}


def _gone(pids, timeout=10.0):
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if not [p for p in pids if Path(f"/proc/{p}").exists()
                and Path(f"/proc/{p}/stat").read_text().split(") ")[1][0] not in "ZX"]:
            return True
        time.sleep(0.1)
    return False


def test_on_result_sees_each_record_before_it_is_yielded():
    seen = []
    stream = run_tasks(_seeded_mean, TASKS, backend="serial", progress=False,
                       on_result=seen.append)
    first = next(stream)
    assert seen == [first]
    rest = list(stream)
    assert seen == [first, *rest] and len(seen) == len(TASKS)
    with pytest.raises(ValueError, match="'on_result' parameter of run_tasks"):
        run_tasks(_seeded_mean, TASKS, on_result="results.jsonl")


@pytest.mark.skipif(not Path("/proc").is_dir(), reason="checks processes through /proc")
def test_a_failing_on_result_or_an_abandoned_stream_stops_the_workers_at_once(tmp_path):
    tasks = [(str(tmp_path), 0, 0.0)] + [(str(tmp_path), i, 60.0) for i in range(1, 5)]

    def persist(result):
        raise OSError("disk full")

    with pytest.raises(OSError, match="disk full"):
        list(run_tasks(_record_pid, tasks, workers=2, progress=False, on_result=persist))
    pids = _worker_pids(tmp_path)
    assert pids and _gone(pids)
    # stopped, not waited for: no 60 s task ran to its end
    assert [p.name for p in tmp_path.glob("end-*")] == ["end-0"]
    for p in tmp_path.iterdir():
        p.unlink()
    stream = run_tasks(_record_pid, tasks, workers=2, progress=False)
    assert next(stream).index == 0
    stream.close()  # the caller stops iterating
    pids = _worker_pids(tmp_path)
    assert pids and _gone(pids)
    assert [p.name for p in tmp_path.glob("end-*")] == ["end-0"]


def test_a_dead_worker_costs_no_other_task(tmp_path, capsys):
    # a dead worker breaks its pool: the unfinished tasks run again in a fresh pool
    tasks = [(i, float(i)) for i in range(6)]
    fn = functools.partial(_dies, folder=str(tmp_path), always=False)
    results = _by_index(run_tasks(fn, tasks, backend="process", workers=2, progress=False))
    assert [r.index for r in results] == list(range(6))
    assert all(r.ok for r in results) and [r.value for r in results] == [i * i for i in range(6)]
    assert (tmp_path / "died").exists()
    assert "starting a fresh pool" in capsys.readouterr().err


def test_a_task_that_always_kills_its_worker_is_lost_after_the_restarts(tmp_path, monkeypatch):
    import windnav.experiments.executor as ex

    monkeypatch.setattr(ex, "POOL_RESTARTS", 1)
    tasks = [(i, float(i)) for i in range(4)]
    fn = functools.partial(_dies, folder=str(tmp_path), always=True)
    results = _by_index(run_tasks(fn, tasks, backend="process", workers=1, progress=False))
    assert [r.index for r in results] == list(range(4))
    assert results[0].ok and results[1].ok and not results[2].ok
    assert "BrokenProcessPool" in results[2].error and "pool broke 2 times" in results[2].error


def _warns(task):
    import warnings

    warnings.warn(f"task {task} is odd", UserWarning, stacklevel=1)
    return task


def test_process_workers_print_warnings_as_the_command_line_does(capfd, monkeypatch):
    """The command line prints a warning as one line; a process worker printed Python's form
    (file, line number, source line) instead (packaging audit)."""
    import warnings

    from windnav._console import one_line_warning

    monkeypatch.setattr(warnings, "showwarning", one_line_warning("windnav x"))
    values = [r.value for r in run_tasks(_warns, [7], backend="process", workers=1,
                                         progress=False)]
    assert values == [7]
    err = capfd.readouterr().err
    assert "windnav x: warning: task 7 is odd" in err and "UserWarning" not in err


def test_a_sweep_without_ray_creates_nothing(tmp_path, monkeypatch):
    """wind-sweep --backend ray without Ray created its store, then failed on the import."""
    from windnav.city import training_map
    from windnav.experiments.wind_sweep import sweep

    monkeypatch.setitem(sys.modules, "ray", None)  # `import ray` raises ImportError
    city = training_map(rng=1, size=120.0, n_buildings=3, side_range=(10.0, 30.0))
    with pytest.raises(BackendUnavailableError, match=r"windnav\[ray\]"):
        sweep([("m", "generated", city)], tmp_path / "s.zarr", speeds=[5.0],
              directions_deg=[0.0], settings={"dx": 4.0}, backend="ray", progress=False)
    assert not (tmp_path / "s.zarr").exists()
