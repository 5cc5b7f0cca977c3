"""No orphaned workers, no lost results: the process backend under SIGKILL and Ctrl-C.

Each test runs a real parent process (``python -c``) that drives :func:`run_tasks` on the
``process`` backend, with tasks that announce their pid in a file and then sleep for a minute,
and kills or interrupts that parent the way a user or the system would. Every descendant of
the parent (workers and the multiprocessing resource tracker) must be gone a few seconds later.
Descendants are found through ``/proc`` (Linux).
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import pytest

HERE = Path(__file__).resolve().parent

pytestmark = pytest.mark.skipif(not Path("/proc/self/stat").exists(),
                                reason="finds child processes through Linux's /proc")


def announce_and_sleep(task):
    """A task: write ``<dir>/pid-<pid>-<index>``, then sleep ``seconds``."""
    folder, index, seconds = task
    Path(folder, f"pid-{os.getpid()}-{index}").touch()
    time.sleep(seconds)
    return index


def _stat(pid: int):
    try:
        text = Path(f"/proc/{pid}/stat").read_text()
    except OSError:
        return None
    fields = text[text.rindex(")") + 2:].split()  # after "pid (comm) "
    return fields[0], int(fields[1])  # state, ppid


def alive(pid: int) -> bool:
    st = _stat(pid)
    return st is not None and st[0] not in ("Z", "X")  # a zombie has exited


def descendants(pid: int) -> set[int]:
    """Every process below ``pid`` now."""
    children: dict[int, list[int]] = {}
    for entry in os.listdir("/proc"):
        if entry.isdigit() and (st := _stat(int(entry))) is not None:
            children.setdefault(st[1], []).append(int(entry))
    found, todo = set(), [pid]
    while todo:
        for child in children.get(todo.pop(), []):
            if child not in found:
                found.add(child)
                todo.append(child)
    return found


def wait_for(predicate, timeout: float) -> bool:
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        if predicate():
            return True
        time.sleep(0.1)
    return predicate()


PARENT = textwrap.dedent("""
    import sys
    from pathlib import Path
    sys.path.insert(0, {here!r})
    from test_faults_workers import announce_and_sleep
    from windnav.experiments.executor import run_tasks

    if __name__ == "__main__":
        folder = {folder!r}
        tasks = [(folder, 0, 0.1)] + [(folder, i, 60.0) for i in range(1, 6)]
        finished = []
        try:
            for r in run_tasks(announce_and_sleep, tasks, backend="process", workers=2,
                               progress=False,
                               on_result=lambda r: Path(folder, f"done-{{r.index}}").touch()):
                finished.append(r.value)
        except KeyboardInterrupt:
            print("interrupted after", finished, flush=True)
            sys.exit(130)
""")


def start_parent(tmp_path):
    folder = tmp_path / "pids"
    folder.mkdir()
    script = PARENT.format(here=str(HERE), folder=str(folder))
    # a test runner started in the background (``cmd &``) ignores SIGINT, and its children
    # would inherit that: give the parent the default disposition, as a terminal would
    proc = subprocess.Popen([sys.executable, "-c", script], start_new_session=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL))
    # the first task finished and both workers are busy with a long one
    started = wait_for(lambda: (folder / "done-0").exists()
                       and len({p.name.split("-")[1] for p in folder.glob("pid-*")}) == 2
                       and len(list(folder.glob("pid-*"))) >= 3, timeout=60)
    return proc, folder, started


def cleanup(pids) -> None:
    for pid in pids:
        if alive(pid):
            os.kill(pid, signal.SIGKILL)


def test_workers_and_resource_tracker_exit_when_the_parent_is_killed(tmp_path):
    proc, folder, started = start_parent(tmp_path)
    kids = descendants(proc.pid)
    try:
        assert started, proc.stderr.read() if proc.poll() is not None else "workers not started"
        workers = {int(p.name.split("-")[1]) for p in folder.glob("pid-*")}
        assert workers <= kids and len(kids) >= 3  # two workers and the resource tracker
        os.kill(proc.pid, signal.SIGKILL)  # the parent only, as the OOM killer would
        proc.wait(timeout=10)
        assert wait_for(lambda: not any(alive(p) for p in kids), timeout=10), \
            [p for p in kids if alive(p)]
    finally:
        cleanup(kids)
        proc.stdout.close()
        proc.stderr.close()


@pytest.mark.parametrize("to_group", [True, False], ids=["terminal", "parent-only"])
def test_ctrl_c_stops_the_workers_keeps_finished_results_and_prints_no_traceback(
        tmp_path, to_group):
    proc, folder, started = start_parent(tmp_path)
    kids = descendants(proc.pid)
    try:
        assert started, "workers not started"
        # A terminal's Ctrl-C reaches the whole process group; `kill -INT` only the parent.
        if to_group:
            os.killpg(proc.pid, signal.SIGINT)
        else:
            os.kill(proc.pid, signal.SIGINT)
        out, err = proc.communicate(timeout=30)
        assert proc.returncode == 130, err
        assert out.strip() == "interrupted after [0]"  # the finished task reached the caller
        assert "Traceback" not in err and "KeyboardInterrupt" not in err, err
        assert wait_for(lambda: not any(alive(p) for p in kids), timeout=10), \
            [p for p in kids if alive(p)]
        assert sorted(p.name for p in folder.glob("done-*")) == ["done-0"]
    finally:
        cleanup(kids)


WATCHED = textwrap.dedent("""
    import subprocess, sys
    child = subprocess.Popen([sys.executable, "-c", {child!r}])
    print(child.pid, flush=True)
    child.wait()
""")

CHILD = textwrap.dedent("""
    import os, sys, time
    parent = os.getppid()  # before the imports: the parent may die meanwhile
    sys.platform = "other"  # no PR_SET_PDEATHSIG: the portable watcher must do the job
    from windnav.experiments.executor import die_with_parent
    assert die_with_parent(parent, poll_s=0.1) == "watcher"
    print("armed", flush=True)
    time.sleep(60)
""")


def test_without_pdeathsig_a_watcher_thread_ends_the_orphan():
    script = WATCHED.format(child=CHILD)
    parent = subprocess.Popen([sys.executable, "-c", script], stdout=subprocess.PIPE,
                              text=True, start_new_session=True)
    child = int(parent.stdout.readline())
    try:
        assert parent.stdout.readline().strip() == "armed"
        assert alive(child)
        os.kill(parent.pid, signal.SIGKILL)
        parent.wait(timeout=10)
        assert wait_for(lambda: not alive(child), timeout=10)
    finally:
        cleanup([child])
        parent.stdout.close()


def test_die_with_parent_arms_pdeathsig_on_linux():
    if not sys.platform.startswith("linux"):
        pytest.skip("PR_SET_PDEATHSIG is Linux's")
    code = ("import os; from windnav.experiments.executor import die_with_parent; "
            "print(die_with_parent(os.getppid()))")
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=60)
    assert done.stdout.strip() == "pdeathsig", done.stderr
