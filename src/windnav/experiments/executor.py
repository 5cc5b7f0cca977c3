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
    by ``RAY_ADDRESS``). Without Ray, :class:`BackendUnavailableError` says how to install it.

Interruptions and orphans
-------------------------
Results stream back as they finish (and to ``on_result``), so a caller that writes each record
as it arrives loses nothing finished when the sweep is interrupted. Process workers ignore
SIGINT: on Ctrl-C (which a terminal sends to the whole process group) only the parent reacts.
When the stream stops early -- ``KeyboardInterrupt``, an exception, or a caller that stops
iterating -- queued tasks are cancelled and the workers are terminated at once, with no
traceback from the workers; the ``KeyboardInterrupt`` then reaches the caller. A worker also
dies with its parent if the parent is killed outright (SIGKILL, the out-of-memory killer): on
Linux through ``prctl(PR_SET_PDEATHSIG, SIGKILL)``, elsewhere through a thread that watches the
parent's pid. The multiprocessing resource tracker exits once the workers are gone. A worker
that dies on its own (the out-of-memory killer, a crash in compiled code) breaks its whole
pool; the unfinished tasks then run again in a fresh pool, at most :data:`POOL_RESTARTS` times,
after which they are reported lost. (Linux
sends that signal when the *thread* that started a worker exits; workers are started by the
thread that iterates the stream, so iterate one stream from one thread.)

The code of a task is the same in all three: every backend calls the same wrapper around ``fn``,
which turns an exception into a failed status record instead of aborting the other tasks
(principle 8 of STYLE.md: no exceptions escape a batch). ``BaseException`` such as
``KeyboardInterrupt`` is not caught, so an interrupted serial sweep stops at once.
"""

from __future__ import annotations

import ctypes
import multiprocessing
import os
import signal
import sys
import threading
import time
import traceback
import warnings
from collections.abc import Callable, Iterable, Iterator
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from concurrent.futures.process import BrokenProcessPool
from dataclasses import dataclass
from typing import Any

from windnav._console import one_line_warning, progress_bar
from windnav._extras import install_hint
from windnav._validate import positive_int

BACKENDS = ("serial", "process", "ray")
PARENT_POLL_S = 0.5
"""How often a worker without ``PR_SET_PDEATHSIG`` checks that its parent is alive, s."""
POOL_RESTARTS = 2
"""How many times the ``process`` backend starts a fresh pool for the unfinished tasks after a
worker died (the out-of-memory killer, a crash in compiled code): a dead worker breaks the whole
pool, and without a restart every task still queued in it would be lost with the one that
died. After that many restarts the unfinished tasks are reported lost."""
_PR_SET_PDEATHSIG = 1  # from <linux/prctl.h>


class BackendUnavailableError(ImportError, ValueError):
    """The chosen backend needs an optional dependency that is not installed.

    A ``ValueError`` (a bad ``backend`` argument for this installation) and an
    ``ImportError``; the message says what to install.
    """


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
    hint = (f" (its pool broke {POOL_RESTARTS + 1} times: a worker process died; out of "
            "memory? fewer workers need less)" if isinstance(exc, BrokenProcessPool) else "")
    return TaskResult(index, task, False, None, f"{type(exc).__name__}: {exc}{hint}", 0.0)


def _serial(fn, tasks, workers) -> Iterator[TaskResult]:
    for i, task in enumerate(tasks):
        yield _call(fn, i, task)


def die_with_parent(parent_pid: int, poll_s: float = PARENT_POLL_S) -> str:
    """Make this process exit when the process ``parent_pid`` (its parent) dies.

    On Linux the kernel sends SIGKILL on the parent's death (``prctl(PR_SET_PDEATHSIG)``);
    elsewhere, or if that fails, a daemon thread polls ``os.getppid()`` every ``poll_s``
    seconds and exits the process when the parent has changed. If the parent is already gone,
    the process exits at once.

    Returns
    -------
    str
        ``"pdeathsig"`` or ``"watcher"``: the mechanism armed.
    """
    how = "watcher"
    if sys.platform.startswith("linux"):
        try:
            libc = ctypes.CDLL(None, use_errno=True)
            if libc.prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0:
                how = "pdeathsig"
        except (OSError, AttributeError):
            pass
    # The parent may have died before the signal was armed: then we are already an orphan.
    if os.getppid() != parent_pid:
        os._exit(1)
    if how == "watcher":

        def watch():
            while os.getppid() == parent_pid:
                time.sleep(poll_s)
            os._exit(1)

        threading.Thread(target=watch, name="windnav-parent-watch", daemon=True).start()
    return how


def _worker_init(parent_pid: int, warning_where: str | None = None) -> None:
    """Initializer of every process worker: leave Ctrl-C to the parent, die with it, and print
    warnings as the parent does when it prints them as one line
    (:func:`windnav._console.one_line_warning`: the command line's)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    die_with_parent(parent_pid)
    if warning_where is not None:
        warnings.showwarning = one_line_warning(warning_where)


def _stop_pool(pool: ProcessPoolExecutor, pending) -> None:
    """Cancel queued tasks and terminate the workers now (the stream was abandoned)."""
    for fut in pending:
        fut.cancel()
    if hasattr(pool, "terminate_workers"):  # Python >= 3.14
        pool.terminate_workers()
        return
    procs = list((getattr(pool, "_processes", None) or {}).values())
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in procs:
        if proc.is_alive():
            proc.terminate()
    for proc in procs:
        proc.join(timeout=5.0)
        if proc.is_alive():
            proc.kill()
            proc.join(timeout=5.0)


def _process(fn, tasks, workers) -> Iterator[TaskResult]:
    todo = list(enumerate(tasks))
    for restart in range(POOL_RESTARTS + 1):
        broken = []
        yield from _process_pool(fn, todo, workers, broken, last=restart == POOL_RESTARTS)
        if not broken:
            return
        todo = sorted(broken, key=lambda it: it[0])
        print(f"run_tasks: a worker process died (BrokenProcessPool: killed, perhaps by the "
              f"out-of-memory killer, or crashed); starting a fresh pool for the "
              f"{len(todo)} unfinished tasks (restart {restart + 1} of {POOL_RESTARTS}).",
              file=sys.stderr, flush=True)


def _process_pool(fn, todo, workers, broken: list, last: bool) -> Iterator[TaskResult]:
    """One pool over the ``(index, task)`` pairs of ``todo``; the pairs lost to a broken pool
    are appended to ``broken`` (reported lost instead when ``last``)."""
    ctx = multiprocessing.get_context("spawn")
    pool = ProcessPoolExecutor(max_workers=min(workers, len(todo)), mp_context=ctx,
                               initializer=_worker_init,
                               initargs=(os.getpid(), getattr(warnings.showwarning, "where",
                                                              None)))
    pending: dict = {}
    finished = False
    try:
        pending = {pool.submit(_call, fn, i, t): (i, t) for i, t in todo}
        while pending:
            done, _ = wait(pending, return_when=FIRST_COMPLETED)
            for fut in done:
                i, t = pending.pop(fut)
                try:
                    result = fut.result()
                except BrokenProcessPool as exc:
                    if not last:
                        broken.append((i, t))
                        continue
                    result = _lost(i, t, exc)
                except Exception as exc:  # pickling errors
                    result = _lost(i, t, exc)
                yield result
        finished = True
    finally:
        if finished:
            pool.shutdown(wait=True)
        else:
            # Ctrl-C, an error, or a caller that stopped iterating: nothing more is wanted,
            # and waiting for running tasks (minutes of flow solving) would hang the exit.
            _stop_pool(pool, pending)


def check_backend(backend: str) -> None:
    """Raise the errors :func:`run_tasks` would for ``backend``: a ValueError for an unknown
    one, :class:`BackendUnavailableError` for ``"ray"`` without Ray (call it before creating
    what the tasks will fill)."""
    if backend not in _RUNNERS:
        raise ValueError(
            f"The 'backend' parameter of run_tasks must be one of {BACKENDS}. "
            f"Got {backend!r} instead."
        )
    if backend == "ray":
        _import_ray()


def _import_ray():
    try:
        import ray
    except ImportError as exc:
        raise BackendUnavailableError(
            f"The 'ray' backend of run_tasks needs the optional dependency Ray; "
            f"{install_hint('ray')}, or choose backend='process'."
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


def task_workers(backend: str, workers: int | None, n_tasks: int) -> int | None:
    """The worker count :func:`run_tasks` starts for ``n_tasks`` tasks: ``workers`` (checked;
    for ``process`` by default the CPU count) at most one per task and at least one; None where
    none is given and the backend picks (``ray``: its instance's CPUs; ``serial``)."""
    if workers is not None:
        workers = positive_int(workers, "workers", "run_tasks")
    elif backend == "process":
        workers = os.cpu_count() or 1
    return None if workers is None else max(1, min(workers, n_tasks))


def run_tasks(
    fn: Callable[[Any], Any],
    tasks: Iterable,
    backend: str = "process",
    workers: int | None = None,
    progress: bool = True,
    desc: str | None = None,
    on_result: Callable[[TaskResult], Any] | None = None,
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
    on_result : callable, optional
        Called with each :class:`TaskResult` as it finishes, before it is yielded: the place
        to persist records one by one, so an interruption loses no finished task even when
        the stream is collected with ``list()`` or ``sorted()``. An exception it raises stops
        the run (the workers are stopped) and reaches the caller.

    Yields
    ------
    TaskResult
        In completion order; ``result.index`` gives the task's position. Exactly one per task,
        whether it succeeded or failed.

    Raises
    ------
    ValueError
        On an unknown ``backend`` or a ``workers`` that is not an integer >= 1.
    BackendUnavailableError
        (a ValueError and an ImportError) When ``backend="ray"`` and Ray is not installed;
        the message gives the install command.
    KeyboardInterrupt
        From the iteration, on Ctrl-C, after queued tasks are cancelled and the workers
        stopped (see the module docstring).

    Notes
    -----
    Arguments are checked at the call; the tasks run only while the returned iterator is
    consumed. Collect everything with
    ``sorted(run_tasks(...), key=lambda r: r.index)``.
    """
    check_backend(backend)  # ray's now, with the install hint, rather than on first iteration
    tasks = list(tasks)
    workers = task_workers(backend, workers, len(tasks))
    if on_result is not None and not callable(on_result):
        raise ValueError(
            f"The 'on_result' parameter of run_tasks must be callable or None. "
            f"Got {on_result!r} instead."
        )
    return _stream(_RUNNERS[backend], fn, tasks, workers, progress, desc, on_result)


def _stream(runner, fn, tasks, workers, progress, desc, on_result) -> Iterator[TaskResult]:
    if not tasks:
        return
    n_failed = 0
    with progress_bar(total=len(tasks), auto=False, desc=desc, disable=not progress,
                      unit="task") as bar:
        results = runner(fn, tasks, workers)
        try:
            for result in results:
                n_failed += not result.ok
                if n_failed:
                    bar.set_postfix(failed=n_failed, refresh=False)
                bar.update(1)
                if on_result is not None:
                    on_result(result)
                yield result
        finally:
            results.close()  # stops the backend's workers now, not when garbage collected
