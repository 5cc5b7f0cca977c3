"""``windnav flow-validate --studies`` / ``--full`` resume after an interrupt.

Every finished run of the Strouhal studies (and the label-noise table) is kept in ``--out``'s
record log; a rerun of the same command runs only the others and writes what an uninterrupted
run writes. The studies are made quick: the checks shrunk, each Strouhal case run on a tiny
domain for a few convective times (its own angle, shape and closure kept, so the runs differ),
the label-noise map small, everything serial.
"""

import json
from dataclasses import replace

import pytest

import windnav.experiments.flow_validation as fv
from windnav.cli import main
from windnav.experiments.results import RecordMismatchError


@pytest.fixture
def ran(monkeypatch):
    """The cases run (and ``"label_noise"`` for each label-noise table), in order; set
    ``ran.stop_after = k`` to raise KeyboardInterrupt from the run after the k-th."""
    real = (fv.projection_study, fv.uniform_study, fv.taylor_green_study, fv.run_case,
            fv.label_noise_study, fv.run_validation)
    monkeypatch.setattr(fv, "projection_study", lambda *, rng: real[0](rng=rng, steps=3))
    monkeypatch.setattr(fv, "uniform_study", lambda: real[1](directions=(30.0,)))
    monkeypatch.setattr(fv, "taylor_green_study", lambda: real[2](n=8, periods=0.5))
    monkeypatch.setattr(fv, "run_validation", lambda **kw: real[5](**{**kw, "backend": "serial"}))

    class Ran(list):
        stop_after = None

        def unit(self, what):
            if len(self) == self.stop_after:
                raise KeyboardInterrupt
            self.append(what)

    done = Ran()

    def run_case(case):
        done.unit(case)
        # 4 H/U shed no resolved St, so a study case's run is unsettled and recorded on: two
        # doublings, not the studies' eight to 1,280 H/U (5 min for this file)
        cap = None if case.max_record_time is None else 16.0
        return real[3](replace(case, cells_per_height=4, upstream=1.0, downstream=2.0,
                               spinup_time=1.0, record_time=4.0, max_record_time=cap))

    def label_noise_study(*, seed):
        done.unit("label_noise")
        return real[4](seed=seed, size=200.0, spinup_steps=2, steps=2)

    monkeypatch.setattr(fv, "run_case", run_case)
    monkeypatch.setattr(fv, "label_noise_study", label_noise_study)
    return done


def command(out, *more):
    return main(["flow-validate", "--out", str(out), "--no-progress", *more])


def untimed(folder):
    """The run's JSON document, without its output folder and the label-noise timings."""
    doc = json.loads((folder / "flow_validation.json").read_text())
    doc["arguments"].pop("out")
    doc.pop("argv")                       # the words typed, --out's folder among them
    for row in doc.get("label_noise", {}).get("rows", []):
        row.pop("seconds_batch")
    return doc


def assert_same_outputs(folder, whole):
    assert untimed(folder) == untimed(whole)
    names = sorted(p.name for p in whole.iterdir())
    assert sorted(p.name for p in folder.iterdir()) == names  # the record log removed
    for name in names:
        if name != "flow_validation.json":  # the runs, to the bit, and the figures
            assert (folder / name).read_bytes() == (whole / name).read_bytes(), name


@pytest.mark.parametrize("mode, stop_after", [("--studies", 5), ("--full", 14)])
def test_an_interrupted_validation_resumes_to_the_uninterrupted_result(tmp_path, ran, capsys,
                                                                     mode, stop_after):
    """Ctrl-C after k runs keeps them; the rerun runs only the others. Under --full, the first
    14 runs are the resolution series (6), the closures (6), the label-noise table and one
    incidence case: the table is not made again either."""
    whole = tmp_path / "whole"
    assert command(whole, mode) == 0
    every = list(ran)
    assert len(every) == (68 if mode == "--studies" else 81)
    assert (mode == "--full") == ("label_noise" in every)

    out, log = tmp_path / "cut", tmp_path / "cut" / fv.RECORDS
    ran.clear()
    ran.stop_after = stop_after
    capsys.readouterr()
    assert command(out, mode) == 130
    err = capsys.readouterr().err.strip().splitlines()
    assert err == [f"windnav flow-validate: interrupted: {stop_after} finished runs kept in "
                   f"{log}; rerun the same command to resume"]
    assert sorted(p.name for p in out.iterdir()) == [fv.RECORDS]  # no result written
    assert len(log.read_text().splitlines()) == 1 + stop_after  # the header and the runs

    ran.clear()
    ran.stop_after = None
    assert command(out, mode) == 0
    assert ran == every[stop_after:]  # the finished runs were not run again
    assert f"resuming: {stop_after} finished runs already in {log}" in capsys.readouterr().err
    assert_same_outputs(out, whole)


def test_a_torn_last_record_is_run_again(tmp_path, ran):
    """A kill while a run's record was written leaves half a line: it is ignored, that run is
    run again, and the result is the uninterrupted one's."""
    whole = tmp_path / "whole"
    assert command(whole, "--studies") == 0
    every = list(ran)
    out, log = tmp_path / "cut", tmp_path / "cut" / fv.RECORDS
    ran.clear()
    ran.stop_after = 5
    assert command(out, "--studies") == 130
    text = log.read_bytes()
    last = text.rstrip(b"\n").rfind(b"\n") + 1
    log.write_bytes(text[:last + (len(text) - last) // 2])  # the fifth record, torn
    ran.clear()
    ran.stop_after = None
    assert command(out, "--studies") == 0
    assert ran == every[4:]
    assert_same_outputs(out, whole)


def test_a_damaged_record_log_is_said_to_be_no_record_log(tmp_path, ran, capsys):
    """A log whose first line is no header was "the runs of another validation" (CLI audit)."""
    out, log = tmp_path / "v", tmp_path / "v" / fv.RECORDS
    out.mkdir()
    log.write_text("garbage\n{}\n")
    assert command(out, "--studies") == 2 and ran == []
    err = capsys.readouterr().err
    assert (f"whose record log {str(log)!r} is not a record log (its first line is no JSON "
            "header: damaged, or another file); pass --overwrite to discard it, or choose "
            "another --out." in err), err
    assert log.read_text() == "garbage\n{}\n"


def test_the_record_log_of_another_validation_is_refused_or_discarded(tmp_path, ran, capsys):
    """Runs kept by --full --seed 1 are not mixed into --studies or --full --seed 0: refused
    before anything runs, and with --overwrite discarded."""
    out, log = tmp_path / "v", tmp_path / "v" / fv.RECORDS
    ran.stop_after = 2
    assert command(out, "--full", "--seed", "1") == 130
    kept = log.read_bytes()
    ran.clear()
    ran.stop_after = None
    for other in (["--studies"], ["--full"]):
        capsys.readouterr()
        assert command(out, *other) == 2 and ran == []
        err = capsys.readouterr().err
        assert "'--out' parameter" in err and "another validation" in err
        assert "--overwrite" in err and log.read_bytes() == kept
    with pytest.raises(RecordMismatchError):
        fv.strouhal_studies(False, True, backend="serial", progress=False, records=log)
    assert ran == []
    assert command(out, "--studies", "--overwrite") == 0
    assert len(ran) == 68 and not log.exists()
