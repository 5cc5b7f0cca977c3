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


# ------------------------------------------------------------------- the one-building yard
# The small map of the navigation tests (navigate, its variants, the escape variant, the
# onboard stack, in-flight decoding), shared by their modules and built once per worker: the
# flow took 5-30 s in each module's setup. A module may define its own ``flow``; one that
# defines its own ``city`` defines its own ``flow`` too (this one is built from the yard).


@pytest.fixture(scope="session")
def city():
    """The yard: 140 m x 120 m, one building 20 m tall over x 35-45 m, y 45-75 m, between the
    start (10, 60) and the goal (110, 60) that the modules name START and GOAL."""
    import numpy as np

    from windnav.city import City

    return City((0.0, 140.0, 0.0, 120.0), np.array([(35.0, 45.0, 45.0, 75.0)]),
                np.array([20.0]))


@pytest.fixture(scope="session")
def flow(city):
    """The yard's wind: 2 m/s toward +x, 10 s of spin-up, then 40 s recorded. Shared: a test
    changes a copy (``dataclasses.replace``), never its arrays."""
    from windnav.experiments.navigate import simulate_flow

    return simulate_flow(city, 2.0, 0.0, spinup_s=10.0, record_s=40.0)
