"""Figures drawn by the tests go to files: the non-interactive backend, whatever the display
(the plotting modules leave the backend to their user)."""

import os

os.environ.setdefault("MPLBACKEND", "Agg")


import contextlib  # noqa: E402
import subprocess  # noqa: E402
import sys  # noqa: E402

import pytest  # noqa: E402


@pytest.fixture
def held_elsewhere():
    """``held_elsewhere(lock, path, seconds=60)``: a context manager in which another process
    holds ``windnav.experiments.results.<lock>(path, 'x')`` (``exclusive`` or
    ``exclusive_folder``) for up to ``seconds``; it yields that process (the concurrency tests'
    other run)."""
    @contextlib.contextmanager
    def hold(lock: str, path, seconds: float = 60.0):
        holder = subprocess.Popen([sys.executable, "-c", (
            "import time\n"
            f"from windnav.experiments.results import {lock}\n"
            f"with {lock}({str(path)!r}, 'x'):\n"
            "    print('held', flush=True)\n"
            f"    time.sleep({float(seconds)!r})\n")], stdout=subprocess.PIPE, text=True)
        try:
            assert holder.stdout.readline().strip() == "held"
            yield holder
        finally:
            holder.kill()
            holder.wait()
            holder.stdout.close()

    return hold
