"""Calls that leave the caller's process as they found it (side-effects audit, thirty-seventh
session)."""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

import windnav as wn
from windnav import cli
from windnav.sim import fly, make_trajectory
from windnav.viz.flight import plot_flight
from windnav.wind import ConstantWind


def test_progress_bars_start_no_monitor_thread(monkeypatch, capsys):
    """tqdm starts a monitor thread with its first bar, even a disabled one, and keeps it: a
    program calling ``fly`` (``progress=False``) became multi-threaded, which a later fork can
    deadlock on. windnav's bars start none, shown or not."""
    import tqdm.std

    started = []
    monkeypatch.setattr(tqdm.std, "TMonitor", lambda *a: started.append(a))
    monkeypatch.setattr(tqdm.std.tqdm, "monitor", None)
    p = wn.vehicle.params("hummingbird")
    for progress in (False, True):
        fly(p, make_trajectory("hover"), ConstantWind((1.0, 0.0, 0.0)), 0.05, progress=progress)
    wn.experiments.run_tasks(abs, [-1, 2], workers=1, progress=True)
    capsys.readouterr()
    assert started == []
    tqdm.std.tqdm(disable=True).close()  # the check itself sees tqdm's own bar start one
    assert len(started) == 1


def test_a_figure_that_cannot_be_saved_is_closed(tmp_path):
    """A figure whose file could not be written stayed open (``plt.get_fignums()``), one per
    failed call, for the life of the process."""
    import matplotlib.pyplot as plt

    p = wn.vehicle.params("hummingbird")
    log = fly(p, make_trajectory("hover"), ConstantWind((1.0, 0.0, 0.0)), 0.2)
    open_before = set(plt.get_fignums())
    with pytest.raises(OSError):
        plot_flight(log, tmp_path, prefix="missing/folder/x")
    assert set(plt.get_fignums()) == open_before
    assert np.isfinite(log.position).all()


def test_json_to_a_symbolic_link_replaces_its_target_and_keeps_the_link(tmp_path, capsys):
    """``--json LINK --overwrite`` replaced the link by a plain file (``os.replace`` onto the
    link); a link to a device or pipe (``/dev/stdout``) would have been replaced too, and
    ``--json -`` wrote a file named ``-``."""
    import json

    from windnav.cli import main

    target = tmp_path / "results" / "power.json"
    target.parent.mkdir()
    target.write_text("{}")
    link = tmp_path / "latest.json"
    link.symlink_to(target)
    base = ["similitude", "--full-scale-speed", "10", "--json"]
    assert main(base + [str(link), "--overwrite"]) == 0
    assert link.is_symlink()
    assert json.loads(target.read_text())["full_scale_diameter_m"] == 1.8
    printed = capsys.readouterr()
    json.loads(printed.out)  # standard output: the summary alone ("wrote" goes to stderr)
    assert f"wrote {target}" in printed.err

    fifo = tmp_path / "pipe"
    os.mkfifo(fifo)
    device = tmp_path / "stdout"
    device.symlink_to(fifo)
    for path in (fifo, device, "-", "/dev/stdout", "/dev/null"):
        assert main(base + [str(path), "--overwrite"]) == 2
        err = capsys.readouterr().err
        assert "'--json'" in err and ("regular file" in err or "standard output" in err), err
    assert fifo.exists() and not fifo.is_file() and device.is_symlink()
    assert not (tmp_path / "-").exists()
    if os.access("/dev/shm", os.W_OK):  # regular files under /dev are files
        import tempfile

        shm = tempfile.mkdtemp(dir="/dev/shm")
        try:
            assert main(base + [f"{shm}/s.json"]) == 0
        finally:
            import shutil

            shutil.rmtree(shm)


def test_fly_and_demo_can_hide_their_progress_bars(tmp_path, capsys):
    """``fly`` and ``demo`` always drew their bars; in a log file an error then shared a line
    with a bar's carriage returns."""
    from windnav.cli import main

    assert main(["fly", "--duration", "0.2", "--no-plots", "--no-progress",
                 "--out", str(tmp_path / "fly")]) == 0
    assert "%|" not in capsys.readouterr().err
    with pytest.raises(SystemExit) as info:
        main(["demo", "--help"])
    assert info.value.code == 0 and "--no-progress" in capsys.readouterr().out


@pytest.mark.parametrize("buffered", [True, False])
def test_a_closed_pipe_on_standard_output_stops_nothing(tmp_path, buffered):
    """``windnav ... | head -1`` printed ``error: [Errno 32] Broken pipe``; with Python's usual
    buffered output the break came at the flush on exit (status 120 and a traceback), and a
    command that printed before writing could stop before its files. The command now finishes
    its work, writes its files and says so on standard error."""
    import subprocess
    import sys

    env = {k: v for k, v in os.environ.items() if k != "PYTHONUNBUFFERED"}
    if not buffered:
        env["PYTHONUNBUFFERED"] = "1"
    read, write = os.pipe()
    os.close(read)  # the reader is gone before the command prints
    try:
        proc = subprocess.run([sys.executable, "-m", "windnav", "similitude",
                               "--full-scale-speed", "10", "--json", str(tmp_path / "s.json")],
                              stdout=write, stderr=subprocess.PIPE, text=True, timeout=120,
                              env=env)
    finally:
        os.close(write)
    assert proc.returncode == 0, proc.stderr
    assert f"wrote {tmp_path / 's.json'}" in proc.stderr
    for bad in ("error", "Traceback", "Exception ignored"):
        assert bad not in proc.stderr, proc.stderr
    assert (tmp_path / "s.json").is_file()


@pytest.mark.parametrize("argv, command", [
    (["power-curve", "--speeds", "0", "1"], "power-curve"),
    (["sysid", "similitude", "--full-scale-speed", "10", "--speeds", "0"], "sysid similitude"),
])
def test_an_unknown_option_shows_its_commands_usage(argv, command, capsys):
    """``windnav power-curve --speeds 0 1`` printed windnav's own usage line and
    ``windnav: error``, not the command's (nor a subcommand's)."""
    from windnav.cli import main

    with pytest.raises(SystemExit) as info:
        main(argv)
    err = capsys.readouterr().err
    assert info.value.code == 2
    assert f"usage: windnav {command}" in err
    assert f"windnav {command}: error: unrecognized arguments: --speeds" in err


@pytest.mark.parametrize("argv", [
    ["fly", "--duration", "0.2", "--no-plots", "--no-progress", "--out", "{tmp}/fly"],
    ["similitude", "--full-scale-speed", "10", "--json", "{tmp}/s.json"],
    ["power-curve", "--points", "5", "--degree", "2", "--out", "{tmp}/pc"],
])
def test_a_json_summary_is_alone_on_standard_output(argv, tmp_path, capsys):
    """The summary was followed by "wrote PATH" lines on standard output, so that ``windnav
    similitude ... | python -c 'json.load(sys.stdin)'`` failed."""
    import json

    from windnav.cli import main

    assert main([a.replace("{tmp}", str(tmp_path)) for a in argv]) == 0
    printed = capsys.readouterr()
    assert isinstance(json.loads(printed.out), dict)
    assert "wrote " in printed.err


def test_a_plot_that_fails_midway_closes_its_figure():
    """A plotting function that raised after opening its figure (``plot_wind_track``'s default
    settling time on a 1 s flight) left the figure open: about 1 MB a failed call."""
    import matplotlib.pyplot as plt

    from windnav.estimate import run_wind_ukf
    from windnav.viz.ukf import plot_wind_track

    p = wn.vehicle.params("hummingbird")
    log = fly(p, make_trajectory("circle", size=2.0), ConstantWind((2.0, 0.0, 0.0)), 1.0, rng=0)
    track = run_wind_ukf(log, p, conditions="windnav")
    open_before = set(plt.get_fignums())
    for _ in range(3):
        with pytest.raises(ValueError):
            plot_wind_track(track, "never-written.png")
    assert set(plt.get_fignums()) == open_before


def test_the_planners_sweep_cache_is_bounded(monkeypatch):
    """``steady_flight`` kept every vehicle's sweep: a sweep over a vehicle's mass in one process
    grew it by 3.5 kB a vehicle without end. It keeps the latest, and a sweep computed again
    equals the one it replaces."""
    import dataclasses

    from windnav.plan import config

    monkeypatch.setattr(config, "_SWEEPS", {})
    monkeypatch.setattr(config, "_SWEEPS_KEPT", 2)
    p = wn.vehicle.params("hummingbird")
    vehicles = [dataclasses.replace(p, mass=p.mass * (1.0 + 0.01 * i)) for i in range(3)]
    first = config.steady_flight(vehicles[0])
    for v in vehicles[1:]:
        config.steady_flight(v)
    assert len(config._SWEEPS) == 2
    again = config.steady_flight(vehicles[0])  # dropped, computed again
    for key in ("speeds", "power", "drag_accel"):
        np.testing.assert_array_equal(again[key], first[key])


@pytest.mark.parametrize("argv", [
    ["fly", "--duration", "1e308", "--no-plots", "--out", "{tmp}/f"],
    ["calibrate", "--duration", "1e308", "--out", "{tmp}/c"],
    ["sysid", "simulate-stand", "--step-s", "1e308", "--out", "{tmp}/s"],
])
def test_a_value_too_large_to_compute_with_is_a_named_error(argv, tmp_path, capsys):
    """``--duration 1e308`` and its kind ended in an OverflowError's traceback (CLI audit,
    thirty-seventh session): now one line and status 2."""
    from windnav.cli import main

    assert main([a.replace("{tmp}", str(tmp_path)) for a in argv]) == 2
    err = capsys.readouterr().err
    assert "too large" in err and "Traceback" not in err
    assert len([line for line in err.splitlines() if "error" in line]) == 1


@pytest.mark.parametrize("before", [None, "module://my_backend"])
def test_the_command_line_restores_the_callers_matplotlib_backend(before, monkeypatch, capsys):
    """``main()`` sets ``MPLBACKEND=Agg`` for its own figures and workers; a program that
    calls it keeps its own setting afterwards (it was left at Agg: audit, 2026-12-05)."""
    if before is None:
        monkeypatch.delenv("MPLBACKEND", raising=False)
    else:
        monkeypatch.setenv("MPLBACKEND", before)
    monkeypatch.setattr(sys, "argv", ["windnav", "fly", "--duration", "-1"])
    assert cli.main() == 2
    assert os.environ.get("MPLBACKEND") == before
