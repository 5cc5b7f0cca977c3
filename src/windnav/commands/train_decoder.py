"""``windnav train-decoder``: run (or resume) a decoder recipe: its sweep, then the training.

::

    windnav train-decoder --config default --out runs/default   # a shipped recipe, by name
    windnav train-decoder --config src/windnav/predict/recipes/default.toml --out runs/default
    windnav train-decoder --config tiny.toml --out runs/tiny --overwrite   # train again

The recipe (TOML, :mod:`windnav.predict.train`) names the maps, inlets and solver settings of
the sweep, the samples, the architecture and the schedule. The command first runs or resumes
the sweep into ``<out>/<sweep.store>`` (:func:`windnav.experiments.wind_sweep.sweep`: finished
simulations are kept), then trains with :func:`windnav.predict.train.train_decoder`, which
resumes from ``<out>/checkpoint.pt`` after an interruption. Rerun the same command to continue
either step (Ctrl-C says which was interrupted and what is kept). ``--overwrite`` starts the
training over (the sweep store is kept and reused).
The seconds each invocation spent in the sweep and in the training are kept in
``<out>/times.json``, so the times reported (``sweep_seconds``, ``train_seconds``) are the
recipe's whole cost over the invocations that made the run, interrupted ones included; each
count starts again with its step (a sweep into a store not there yet, a training with
``--overwrite``).
A recipe with ``train.members`` M > 1 trains M models from seeds ``train.seed + i``, each in
``<out>/member<i>`` with the files above, and writes their ensemble (the mean of their fields)
to ``<out>/model.npz``.

Writes into ``--out``: ``model.npz`` (the best decoder on the held-out maps; load it with
``windnav.predict.load_decoder``), ``history.json``, ``checkpoint.pt``, ``recipe.toml`` (the
recipe a fresh run started with, every key resolved: its base recipes, the defaults and
``--seed`` written out, so that ``--config OUT/recipe.toml`` repeats the run wherever the file
lies), ``tensorboard/`` (when the ``tensorboard`` package is installed), ``times.json``
(:data:`TIMES`) and the sweep store.
"""

from __future__ import annotations

import contextlib
import json
import shutil
import sys
import time
from pathlib import Path

from windnav._extras import require
from windnav._validate import nonnegative_int, positive_int
from windnav.commands._common import (
    add_output_arguments,
    check_output_path,
    document,
    options_named,
    outputs,
    path_argument,
    print_written,
    where,
)

__all__ = ["TIMES", "TRAINING_PRODUCTS", "register", "run"]

TRAINING_PRODUCTS = ("checkpoint.pt", "history.json", "model.npz", "tensorboard",
                     "recipe.toml")
"""What the training writes into ``--out`` (removed by ``--overwrite``; the store is kept)."""

LOCK = ".train-decoder.lock"
"""The lock file in ``--out`` a run holds (its ``flock``, naming the run): two runs into one
folder resumed each other's live checkpoint, and one crashed on the other's temporary file."""

TIMES = "times.json"
"""The run's time ledger in ``--out``: ``invocations``, one record per invocation of the command
(``sweep_seconds``, ``train_seconds``, s of wall time; ``new_sweep``: the store was not there
yet; ``new_training``: ``--overwrite``; ``ended``), and their totals ``sweep_seconds`` and
``train_seconds``, each summed from the last invocation that started its step over. Kept by
``--overwrite`` (the sweep it times is kept too)."""


def register(subparsers) -> None:
    """Add the ``train-decoder`` subcommand."""
    p = subparsers.add_parser(
        "train-decoder",
        help="run a wind flow decoder recipe: its flow sweep, then the training (resumable)",
        description="Run (or resume) the sweep of a decoder recipe (TOML), then train (or "
                    "resume training) the decoder; the best model on the held-out maps is "
                    "written to OUT/model.npz.",
    )
    p.add_argument("--config", type=Path, required=True, metavar="FILE",
                   help="the recipe: a TOML file, or the name of one shipped with windnav "
                        "(default, ensemble, thesis_mlp, tiny, wrobot_flight, wrobot_noise)")
    p.add_argument("--out", type=path_argument, default=None, metavar="DIR",
                   help="output folder (default runs/<recipe name>)")
    p.add_argument("--backend", choices=("serial", "process", "ray"), default=None,
                   help="sweep executor (default: the recipe's)")
    p.add_argument("--workers", type=int, default=None,
                   help="sweep workers (default: the recipe's)")
    p.add_argument("--seed", type=int, default=None, metavar="N",
                   help="the training's seed, in place of the recipe's train.seed: the "
                        "weights' initialisation (and the augmentation's draws); the samples "
                        "and their order come from data.seed, and the sweep and the validation "
                        "samples stay the recipe's, so runs of several seeds share one sweep "
                        "(give each its own --out)")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bars")
    add_output_arguments(p)
    p.set_defaults(func=run)


def run(args, simulate=None) -> int:
    """Run ``windnav train-decoder``; returns 0 (failed simulations are left out, warned)."""
    from windnav.experiments.results import exclusive
    from windnav.predict.train import load_recipe, resolve_paths

    name = where(args)
    if args.workers is not None:  # "'workers' parameter of run_tasks" after the set-up before
        positive_int(args.workers, "--workers", name)
    with options_named({"'config' parameter of load_recipe": f"'--config' parameter of {name}"}):
        recipe = load_recipe(args.config)
    if args.seed is not None:
        recipe["train"]["seed"] = nonnegative_int(args.seed, "--seed", name)
    require("torch", f"windnav {name}")  # before the sweep: it ran whole (an hour) first
    # --out "" (kept as typed: path_argument) is refused here, not read as "." by Path
    if args.out is not None:
        check_output_path(args.out, "--out", name, kind="dir")
    out_dir, store = resolve_paths(recipe, args.out)
    if args.out is None:  # runs/<name>
        check_output_path(out_dir, "--out", name, kind="dir")
    out = outputs(args)
    lock = out_dir / LOCK
    with exclusive(lock, f"the decoder run {str(out_dir)!r}"):  # a second run refuses at once
        return _train(args, name, recipe, out_dir, store, out, simulate)


def _train(args, name, recipe, out_dir, store, out, simulate) -> int:
    """The run itself, under the lock of ``--out``."""
    from windnav import __version__
    from windnav.experiments.results import write_json
    from windnav.experiments.wind_sweep import sweep
    from windnav.flow.sweep_store import SweepMismatchError
    from windnav.predict.train import recipe_maps, recipe_toml, train_decoder

    if args.overwrite:
        members = sorted(p.name for p in out_dir.glob("member*") if p.is_dir())
        for product in (*TRAINING_PRODUCTS, *members):
            path = out_dir / product
            if not path.exists():
                continue
            if path.is_dir():
                shutil.rmtree(path)
            else:
                path.unlink()
            print(f"removed {path} (from an earlier run)", file=sys.stderr)
    out_dir.mkdir(parents=True, exist_ok=True)
    if not (out_dir / "checkpoint.pt").exists():  # a fresh run: the recipe it was made with
        (out_dir / "recipe.toml").write_text(
            f"# The recipe of `windnav {name}` (windnav {__version__}), from "
            f"{recipe['source']}\n# with its base recipes, the defaults and the command's "
            "options resolved: `--config` this file repeats the run.\n\n"
            + recipe_toml(recipe), encoding="utf-8")

    times = _Times(out_dir / TIMES, name, new_sweep=not store.exists(),
                   new_training=bool(args.overwrite))
    sw = recipe["sweep"]
    progress = not args.no_progress
    try:
        with times.step("sweep"):
            st, results = sweep(recipe_maps(recipe), store, speeds=sw["speeds"],
                                directions_deg=sw["directions_deg"], settings=sw["settings"],
                                backend=args.backend or sw["backend"],
                                workers=args.workers if args.workers is not None
                                else sw["workers"],
                                seed=sw["seed"], progress=progress, simulate=simulate)
    except SweepMismatchError as exc:
        raise ValueError(
            f"The '--out' parameter of {name} holds a sweep store {str(store)!r} of a "
            "different sweep (maps, inlets, solver settings or seed); use another --out, or "
            "delete the store to start over."
        ) from exc
    except KeyboardInterrupt:
        print(_interrupted_sweep(name, store), file=sys.stderr)
        return 130
    sweep_seconds = times.this["sweep_seconds"]
    failed = [r for r in results if not r.ok]
    for r in failed:  # (it named a task's direction_deg, which a task has not: a crash)
        print(f"failed: {r.task.describe()}: {(r.error or '').splitlines()[0]}",
              file=sys.stderr)
    total = st.n_maps * st.n_cases
    print(f"sweep {st.path}: {total - len(st.pending())}/{total} simulations done "
          f"({sum(len(r.task.case_indices) for r in results if r.ok)} now, "
          f"{sweep_seconds:.0f} s)")
    if failed:
        # a simulation that fails (e.g. FlowDivergedError on a map whose streets jet the flow
        # past 10x the inlet) fails the same way every time: train on the rest, and say so;
        # the next run of the command retries them first
        print(f"{name}: warning: {len(failed)} sweep task(s) failed and are left out of the "
              "training (listed above); rerunning the command retries them.", file=sys.stderr)

    try:
        with (options_named({"'config' parameter of train_decoder":
                             f"'--config' parameter of {name}"}), times.step("train")):
            history = train_decoder(recipe, store=store, out_dir=out_dir, progress=progress)
    except KeyboardInterrupt:
        print(_interrupted_training(name, out_dir, recipe["train"]["members"],
                                    args.overwrite), file=sys.stderr)
        return 130
    train_seconds = times.this["train_seconds"]
    spent = times.finish()
    best = history["best_val"]
    local = history["baselines"]["local"]
    if "members" in history:
        chosen = "members' best epochs " + ", ".join(
            f"{m['best_epoch']}/{recipe['train']['epochs']}" for m in history["members"])
    elif recipe["train"]["keep"] == "last":
        best = history["epochs"][-1]["val"]
        chosen = (f"last epoch {len(history['epochs'])} (train.keep), best validation epoch "
                  f"{history['best_epoch']}")
    else:
        chosen = f"best epoch {history['best_epoch']}/{len(history['epochs'])}"
    print(f"model: {out_dir / 'model.npz'} ({recipe['model']['architecture']}, "
          f"{history['n_parameters']} parameters, {chosen})")
    print(f"held-out maps: speed error {best['speed_error']:.3f} m/s (Local "
          f"{local['speed_error']:.3f}), direction error {best['direction_error_deg']:.2f} deg "
          f"(Local {local['direction_error_deg']:.2f}); training {train_seconds:.0f} s")
    if len(spent["invocations"]) > 1:
        print(f"run time with the earlier invocations ({times.path}): sweep "
              f"{spent['sweep_seconds']:.0f} s, training {spent['train_seconds']:.0f} s")
    if args.json is not None:
        payload = {"model": str(out_dir / "model.npz"), "store": str(store),
                   "sweep_seconds": spent["sweep_seconds"],
                   "train_seconds": spent["train_seconds"],
                   "sweep_seconds_this_run": sweep_seconds,
                   "train_seconds_this_run": train_seconds,
                   "invocations": spent["invocations"], "history": history}
        with out.writing() as stage:
            write_json(document("train-decoder", payload, args), stage.file("--json"))
        print_written(out)
    return 0


class _Times:
    """The run's time ledger (:data:`TIMES`): the invocations before this one, read from
    ``path``, and this one's record (``this``), written back after each step it times."""

    def __init__(self, path: Path, name: str, *, new_sweep: bool, new_training: bool):
        self.path = path
        self.invocations = self._read(path, name)
        self.this = {"sweep_seconds": 0.0, "train_seconds": 0.0, "new_sweep": new_sweep,
                     "new_training": new_training, "ended": "started"}
        self.invocations.append(self.this)

    @staticmethod
    def _read(path: Path, name: str) -> list:
        try:
            invocations = json.loads(path.read_text())["invocations"]
            if not all(isinstance(i, dict) and isinstance(i.get("sweep_seconds"), float | int)
                       and isinstance(i.get("train_seconds"), float | int)
                       for i in invocations):
                raise TypeError("not a list of invocation records")
        except FileNotFoundError:
            return []
        except (ValueError, KeyError, TypeError) as exc:
            print(f"{name}: warning: the time ledger {path} cannot be read ({exc}); it starts "
                  "over with this invocation, so the times reported leave out the earlier "
                  "ones.", file=sys.stderr)
            return []
        return invocations

    @contextlib.contextmanager
    def step(self, step: str):
        """Time the step ``step`` ("sweep" or "train"), recorded however it ends."""
        t0 = time.perf_counter()
        try:
            yield
        except BaseException as exc:
            what = "interrupted" if isinstance(exc, KeyboardInterrupt) else "failed"
            self.this["ended"] = f"{what} during the {'training' if step == 'train' else step}"
            raise
        finally:
            self.this[f"{step}_seconds"] += time.perf_counter() - t0
            self.save()

    def totals(self) -> dict:
        """``sweep_seconds`` and ``train_seconds``, each summed from the last invocation that
        started its step over, and ``invocations``."""
        total = {"sweep_seconds": 0.0, "train_seconds": 0.0}
        for inv in self.invocations:
            for step in ("sweep", "train"):
                if inv.get(f"new_{'training' if step == 'train' else step}"):
                    total[f"{step}_seconds"] = 0.0
                total[f"{step}_seconds"] += inv[f"{step}_seconds"]
        return {**total, "invocations": self.invocations}

    def save(self) -> None:
        from windnav.experiments.results import write_json

        write_json(self.totals(), self.path)

    def finish(self) -> dict:
        """Mark this invocation finished, write the ledger and return :meth:`totals`."""
        self.this["ended"] = "finished"
        self.save()
        return self.totals()


def _interrupted_sweep(name: str, store: Path) -> str:
    """The Ctrl-C line of the sweep step: how many simulations its store keeps."""
    from windnav.flow.sweep_store import SweepStore

    try:
        st = SweepStore(store)
        total = st.n_maps * st.n_cases
        done = f"{total - len(st.pending())}/{total} simulations done, kept in {store}"
    except (ValueError, OSError):  # interrupted before the store was created
        done = "no simulation stored yet"
    return (f"{name}: interrupted during the sweep ({done}); rerun the same command to "
            "continue it, then train.")


def _interrupted_training(name: str, out_dir: Path, members: int, overwrite: bool) -> str:
    """The Ctrl-C line of the training step: the checkpoint kept (written after each finished
    epoch, :func:`windnav.predict.train.train_decoder`) and how to resume from it."""
    ckpts = [out_dir / "checkpoint.pt"] if members <= 1 else \
        [out_dir / f"member{i}" / "checkpoint.pt" for i in range(members)]
    kept = [c for c in ckpts if c.is_file()]
    again = "rerun the same command" + (" without --overwrite (which starts over)"
                                        if overwrite else "")
    if not kept:
        return (f"{name}: interrupted during the training, before its first epoch finished "
                f"(no checkpoint yet; the sweep is kept); {again} to start the training.")
    where = str(kept[0]) if members <= 1 else ", ".join(str(c) for c in kept)
    return (f"{name}: interrupted during the training; the checkpoint after the last finished "
            f"epoch is kept in {where}; {again} to resume from it.")
