"""One executor for every sweep: run a function over many tasks, stream per-task status records.

A sweep (maps x inlets of the flow solver, Monte Carlo flights) is a list of independent tasks and
one function ``fn(task) -> value``. :func:`run_tasks` runs them on one of three backends and yields
a :class:`TaskResult` for each task *as it finishes* (completion order, not submission order), so
callers can drive a progress bar, write results incrementally and resume after an interruption.

Backends
--------
``"serial"``
    In this process, one task after another. For debugging and tiny sweeps.
``"process"`` (default)
    :class:`concurrent.futures.ProcessPoolExecutor` on this machine. Workers are started with the
    ``spawn`` method: forking a process that already runs threads (the zarr event loop, numba,
    tqdm's monitor) can deadlock the child. ``fn`` and the tasks must therefore be picklable
    (a module-level function and plain data), and a script that uses this backend needs the
    usual ``if __name__ == "__main__":`` guard (each worker imports the main module).
``"ray"``
    A Ray cluster (optional extra ``windnav[ray]``); ``ray`` is imported only when asked for. If
    Ray is not yet initialised, ``ray.init()`` starts a local instance (or joins the cluster named
    by ``RAY_ADDRESS``).

The code of a task is the same in all three: every backend calls the same wrapper around ``fn``,
which turns an exception into a failed status record instead of aborting the other tasks
(principle 8 of STYLE.md: no exceptions escape a batch). ``BaseException`` such as
``KeyboardInterrupt`` is not caught, so an interrupted serial sweep stops at once.
"""

from __future__ import annotations

import multiprocessing
import os
import time
import traceback
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import dataclass
from typing import Any

from tqdm import tqdm

from windnav._validate import positive_int

BACKENDS = ("serial", "process", "ray")


@dataclass(frozen=True)
class TaskResult:
    """Status record of one task.

    Attributes
    ----------
    index : int
        Position of the task in the list given to :func:`run_tasks`.
    task : object
        The task itself, as given.
    ok : bool
        True when ``fn(task)`` returned; False when it raised.
    value : object
        What ``fn(task)`` returned; None when it failed.
    error : str or None
        ``"ExceptionType: message"`` followed by the traceback when it failed; None otherwise.
    seconds : float
        Wall-clock time spent in ``fn(task)``, s (0.0 when the worker itself died).
    """

    index: int
    task: Any
    ok: bool
    value: Any = None
    error: str | None = None
    seconds: float = 0.0


def _call(fn: Callable, index: int, task) -> TaskResult:
    """Run one task and return its status record; the body every backend executes."""
    t0 = time.perf_counter()
    try:
        value = fn(task)
    except Exception as exc:  # one failing task must not abort the sweep
        err = f"{type(exc).__name__}: {exc}\n{traceback.format_exc()}"
        return TaskResult(index, task, False, None, err, time.perf_counter() - t0)
    return TaskResult(index, task, True, value, None, time.perf_counter() - t0)


def _lost(index: int, task, exc: BaseException) -> TaskResult:
    """Status record for a task whose worker died (killed, out of memory, unpicklable value)."""
    return TaskResult(index, task, False, None, f"{type(exc).__name__}: {exc}", 0.0)


def _serial(fn, tasks, workers) -> Iterator[TaskResult]:
    for i, task in enumerate(tasks):
        yield _call(fn, i, task)


def _process(fn, tasks, workers) -> Iterator[TaskResult]:
    ctx = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
        pending = {pool.submit(_call, fn, i, t): (i, t) for i, t in enumerate(tasks)}
        try:
            while pending:
                done, _ = wait(pending, return_when=FIRST_COMPLETED)
                for fut in done:
                    i, t = pending.pop(fut)
                    try:
                        yield fut.result()
                    except Exception as exc:  # BrokenProcessPool, pickling errors
                        yield _lost(i, t, exc)
        finally:
            # An abandoned generator (caller broke out, Ctrl-C) must not leave work queued.
            for fut in pending:
                fut.cancel()


def _import_ray():
    try:
        import ray
    except ImportError as exc:
        raise ImportError(
            "The 'ray' backend of run_tasks needs the optional dependency Ray; install it with "
            "`pip install 'windnav[ray]'` or choose backend='process'."
        ) from exc
    return ray


def _ray(fn, tasks, workers) -> Iterator[TaskResult]:
    ray = _import_ray()
    if not ray.is_initialized():
        ray.init(**({"num_cpus": workers} if workers is not None else {}))
    remote_call = ray.remote(_call)
    fn_ref = ray.put(fn)
    refs = {remote_call.remote(fn_ref, i, t): (i, t) for i, t in enumerate(tasks)}
    try:
        while refs:
            ready, _ = ray.wait(list(refs), num_returns=1)
            for ref in ready:
                i, t = refs.pop(ref)
                try:
                    yield ray.get(ref)
                except Exception as exc:  # worker died (RayTaskError / WorkerCrashedError)
                    yield _lost(i, t, exc)
    finally:
        for ref in refs:
            ray.cancel(ref)


_RUNNERS = {"serial": _serial, "process": _process, "ray": _ray}


def run_tasks(
    fn: Callable[[Any], Any],
    tasks: Iterable,
    backend: str = "process",
    workers: int | None = None,
    progress: bool = True,
    desc: str | None = None,
) -> Iterator[TaskResult]:
    """Run ``fn`` over ``tasks`` and yield one :class:`TaskResult` per task as each finishes.

    Parameters
    ----------
    fn : callable
        ``fn(task) -> value``. For the ``process`` and ``ray`` backends it must be picklable
        (a module-level function, or a ``functools.partial`` of one).
    tasks : iterable
        The tasks; consumed into a list at once.
    backend : {"serial", "process", "ray"}, default "process"
        Where the tasks run (see the module docstring).
    workers : int, optional
        Number of worker processes (``process``) or CPUs to start a local Ray with (``ray``).
        Default: ``os.cpu_count()`` capped at the number of tasks. Ignored by ``serial``.
    progress : bool, default True
        Show a tqdm progress bar (with a count of failures) on stderr.
    desc : str, optional
        Label of the progress bar.

    Yields
    ------
    TaskResult
        In completion order; ``result.index`` gives the task's position. Exactly one per task,
        whether it succeeded or failed.

    Raises
    ------
    ValueError
        On an unknown ``backend`` or a ``workers`` that is not an integer >= 1.
    ImportError
        When ``backend="ray"`` and Ray is not installed.

    Notes
    -----
    Arguments are checked at the call; the tasks run only while the returned iterator is
    consumed. Collect everything with
    ``sorted(run_tasks(...), key=lambda r: r.index)``.
    """
    if backend not in _RUNNERS:
        raise ValueError(
            f"The 'backend' parameter of run_tasks must be one of {BACKENDS}. "
            f"Got {backend!r} instead."
        )
    tasks = list(tasks)
    if workers is not None:
        workers = positive_int(workers, "workers", "run_tasks")
    elif backend == "process":
        workers = os.cpu_count() or 1
    if workers is not None:
        workers = max(1, min(workers, len(tasks)))
    if backend == "ray":
        _import_ray()  # fail now, with the install hint, rather than on first iteration
    return _stream(_RUNNERS[backend], fn, tasks, workers, progress, desc)


def _stream(runner, fn, tasks, workers, progress, desc) -> Iterator[TaskResult]:
    if not tasks:
        return
    n_failed = 0
    with tqdm(total=len(tasks), desc=desc, disable=not progress, unit="task") as bar:
        for result in runner(fn, tasks, workers):
            n_failed += not result.ok
            if n_failed:
                bar.set_postfix(failed=n_failed, refresh=False)
            bar.update(1)
            yield result
