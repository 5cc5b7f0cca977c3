"""``windnav ukf-montecarlo`` says the workers its trials ran on (leftovers, 2026-12-05).

It printed ``--workers`` (by default the CPU count) whatever ran: "on 16 workers" for two
trials on a 16-core machine, where :func:`windnav.experiments.run_tasks` starts two.
"""

from __future__ import annotations

import json
import os
import sys
from types import SimpleNamespace

import windnav.experiments.ukf_montecarlo as mc
from windnav.cli import main
from windnav.commands.ukf_montecarlo import workers_used

SHORT = dict(duration=(3.0, 4.0))


def test_the_command_prints_and_records_the_workers_it_ran_on(tmp_path, monkeypatch, capsys):
    orig, real_run = mc.MonteCarloConfig, mc.run_montecarlo
    monkeypatch.setattr(mc, "MonteCarloConfig", lambda **kw: orig(**{**SHORT, **kw}))
    asked = []

    def in_this_process(config, *, backend, workers, **kw):  # the trials, without a pool
        asked.append((backend, workers))
        return real_run(config, backend="serial", workers=None, **kw)

    monkeypatch.setattr(mc, "run_montecarlo", in_this_process)
    monkeypatch.setattr(os, "cpu_count", lambda: 16)
    js = tmp_path / "out.json"
    assert main(["ukf-montecarlo", "--trials", "2", "--workers", "4", "--json", str(js),
                 "--no-progress"]) == 0
    assert "s on 2 workers (4 asked for; one per trial left to run)\n" in capsys.readouterr().out
    doc = json.loads(js.read_text())
    assert doc["workers"] == 2 and doc["arguments"]["workers"] == 4  # used; asked for
    # by default the CPU count, one per trial at most
    assert main(["ukf-montecarlo", "--trials", "1", "--no-progress"]) == 0
    assert "s on 1 worker\n" in capsys.readouterr().out
    assert asked == [("process", 4), ("process", None)]


def test_workers_used_follows_run_tasks(monkeypatch):
    monkeypatch.setattr(os, "cpu_count", lambda: 16)
    assert workers_used("process", None, 50) == 16
    assert workers_used("process", None, 3) == 3
    assert workers_used("process", 32, 50) == 32  # more than the CPUs: started all the same
    assert workers_used("process", 4, 0) == 0     # every trial resumed: no pool
    assert workers_used("serial", 4, 7) == 1
    ray = SimpleNamespace(is_initialized=lambda: True, cluster_resources=lambda: {"CPU": 6.0})
    monkeypatch.setitem(sys.modules, "ray", ray)
    assert workers_used("ray", None, 50) == 6 and workers_used("ray", 8, 4) == 4
