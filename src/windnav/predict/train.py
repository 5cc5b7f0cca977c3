"""Training of the wind flow decoder from a sweep store of mean fields (torch; resumable).

A *recipe* (TOML, :func:`load_recipe`) says everything: the sweep that makes the data (maps,
inlets, solver settings: run by ``windnav train-decoder``, which calls
:func:`windnav.experiments.wind_sweep.sweep` with :func:`recipe_maps`), how samples are drawn
from it (:class:`windnav.predict.dataset.DecoderDataset`), the architecture and the training
schedule. :func:`train_decoder` then

- splits the store's fields into training and validation by map (``data.validation_maps``:
  whole maps held out; ``data.exclude_maps`` leaves further maps out of training, for learning
  curves on a subset of a sweep);
- draws the training samples (kept in memory with ``train.cache``), new ones every
  ``train.resample_every`` epochs (fresh robot positions and noise), and the validation
  samples once; optionally turns each training scene about its robot by a random whole
  number of degrees up to ``data.turn_deg`` (:func:`windnav.predict.dataset.draw_samples`;
  the directions between the sweep's), and each training sample by a random D4 element
  (``train.augment_d4``) and rescales it to a random inlet speed (``train.augment_speed``),
  both exact symmetries of the solver, which the ``thesis-mlp`` must learn and the
  ``d4-film`` has built in;
- initialises the model (``train.seed``); a ``d4-film`` basis from the principal components of
  the training residuals (:func:`windnav.predict.torch_models.init_basis_pca`);
- minimises the mean over free cells of ``w (pred - label)^2 / U^2``, ``w = (U / 10 m/s)^p``
  (``train.loss_speed_power`` p: 0 weighs every inlet speed alike, 2 is the plain MSE in units
  of 10 m/s, the thesis's), plus ``train.direction_loss_weight`` times the mean of
  ``1 - cos(pred, label)`` (the direction error weighs slow cells as much as fast ones, the
  MSE does not; faded out in cells slower than ``train.direction_fade`` U, 0.1 by default),
  with Adam or AdamW, weight decay (the thesis's
  ``lambda / 2 |theta|^2``, lambda = 0.002, is Adam with ``weight_decay = 0.002``), a linear
  warm-up and a cosine decay per step;
- after every epoch evaluates the NumPy decoder (the shipped inference path, not the torch
  module) on the validation samples with :func:`windnav.predict.metrics.field_errors`, keeps
  the best (lowest mean of the speed and direction errors relative to the Local baseline's) as
  ``model.npz``, writes ``checkpoint.pt`` (model, optimizer, schedule, history, best) and
  ``history.json``, and logs to TensorBoard when the ``tensorboard`` package is installed;
- with ``train.teacher`` (a decoder file) and ``train.teacher_weight`` w > 0, minimises
  ``(1 - w)`` times that loss plus ``w`` times the same loss against the teacher's field on
  the same samples (distillation: an ensemble's field, smoother than one label, as a second
  target for a single model that costs one model's inference);
- with ``train.ema_decay`` d > 0, keeps an exponential moving average of the weights, updated
  after every optimizer step with the decay ``min(d, (1 + t) / (10 + t))`` at step ``t``
  (:func:`ema_decay_at`), and validates, keeps and ships the average instead of the raw
  weights (the raw weights' validation is recorded as ``val_raw``);
- with ``train.members`` M > 1 (``d4-film`` only), does all of the above M times, for seeds
  ``train.seed + i`` (:func:`member_recipe`; the same samples in the same order, which
  ``data.seed`` sets, another initialisation and, with augmentation on, other augmentation
  draws), each in ``<out>/member<i>``, then writes their ensemble (the mean of their fields,
  :func:`windnav.predict.decoder.ensemble_decoder`) as ``<out>/model.npz``, scored on the same
  validation and training samples, and an ``history.json`` with each member's summary.

Re-running with the same recipe and out folder continues after the last finished epoch and
ends with the same model as an uninterrupted run: the sample order of epoch ``e`` and any
augmentation are functions of (seed, e), the samples are functions of the seed, and the torch
state is restored from the checkpoint (bit for bit on one CPU thread count: a resume on
another ``train.threads`` than the run began on is allowed, with a warning).
"""

from __future__ import annotations

import contextlib
import copy
import functools
import hashlib
import json
import math
import os
import time
import warnings
from pathlib import Path

import numpy as np

from windnav._source import module_key
from windnav._validate import finite_float, positive_int
from windnav.predict._loss import DIRECTION_FADE, SPEED_REF, fused_loss
from windnav.predict.baselines import LocalBaseline, UpstreamBaseline
from windnav.predict.dataset import TURN_LIMIT_DEG, DecoderDataset, fields_from_store
from windnav.predict.decoder import (
    ARCHITECTURES,
    Decoder,
    canonicalize_field,
    d4_grid_permutation,
    d4_matrices,
    d4_ring_indices,
    load_decoder,
    make_architecture,
    permute_cells,
    save_decoder,
)
from windnav.predict.metrics import field_errors

__all__ = ["DEFAULTS", "flush_denormals", "load_recipe", "member_recipe", "recipe_maps",
           "recipe_path", "recipe_toml", "resolve_paths", "shipped_recipes", "train_decoder"]

RECIPES = Path(__file__).resolve().parent / "recipes"
"""Folder of the recipes shipped with windnav (``default.toml``, ``tiny.toml``, ...)."""

DEFAULTS = {
    "name": "decoder",
    "sweep": {
        "store": "sweep.zarr",  # relative to the out folder
        "speeds": [6.0],
        "directions_deg": [3.75, 56.25, 101.25, 198.75, 228.75, 296.25],
        "settings": {},
        "seed": 0,
        "backend": "process",
        "workers": None,
        "maps": [],
    },
    "data": {
        "size": 25,
        "spacing": 1.0,
        "samples_per_field": 512,
        "validation_maps": [],
        "exclude_maps": [],
        "map_weights": {},
        "validation_samples_per_field": 256,
        "scan_noise": 0.35,
        "w_robot_noise": 0.0,
        "wall_clearance": 1.0,
        "building_reach": 40.0,
        "turn_deg": 0,
        "seed": 0,
    },
    "model": {"architecture": "d4-film", "hyperparameters": {}},
    "train": {
        "epochs": 10,
        "batch_size": 256,
        "optimizer": "adamw",
        "learning_rate": 2e-3,
        "weight_decay": 1e-4,
        "warmup_fraction": 0.03,
        "final_lr_fraction": 0.02,
        "loss_speed_power": 1.0,
        "vector_loss": "squared",
        "speed_loss_weight": 0.0,
        "direction_loss_weight": 0.0,
        "direction_loss": "cosine",
        "direction_fade": DIRECTION_FADE,
        "augment_d4": False,
        "augment_speed": [],
        "pca_samples": 8192,
        "cache": True,
        "resample_every": 0,
        "threads": 2,
        "flush_denormal": False,
        "device": "auto",
        "seed": 0,
        "eval_batch_size": 4096,
        "train_eval_samples": 4096,
        "tensorboard": True,
        "members": 1,
        "teacher": "",
        "teacher_weight": 0.0,
        "ema_decay": 0.0,
        "keep": "best",
    },
}
"""Every recipe key and its default (see ``recipes/default.toml`` for their meaning)."""

MAP_KINDS = ("training", "dense", "planning", "file")

MAX_SIZE = 401
"""The largest ``data.size`` (cells per side of a decoder's window): a 401 x 401 window is a
``thesis-mlp`` output layer of 660 M weights at its width of 2048 (2.6 GB in float32)."""

RECIPE_SECTIONS = tuple(k for k, v in DEFAULTS.items() if isinstance(v, dict))
"""The tables of a recipe (``sweep``, ``data``, ``model``, ``train``); a recipe file that
sets none of one's keys is warned about."""


# ---------------------------------------------------------------------------- recipes


def _read_toml(path: Path) -> dict:
    import tomllib

    raw = path.read_bytes()
    return tomllib.loads(raw.decode("utf-8-sig"))  # a byte-order mark, as editors write


_WHOLE_TABLES = ("hyperparameters", "settings", "map_weights")
"""Tables of a recipe that are values, replaced whole (not merged key by key)."""


def _merge(defaults: dict, given: dict, where: str, prefix: str = "") -> dict:
    out = copy.deepcopy(defaults)
    for key, value in given.items():
        if key not in defaults:
            raise ValueError(f"The 'config' parameter of {where} must hold only known keys. "
                             f"Got unknown key {prefix + key!r} instead (known: "
                             f"{sorted(defaults)}).")
        if isinstance(defaults[key], dict) and key not in _WHOLE_TABLES:
            if not isinstance(value, dict):
                raise ValueError(f"The 'config' parameter of {where} must hold a table at "
                                 f"{prefix + key!r}. Got {value!r} instead.")
            out[key] = _merge(defaults[key], value, where, prefix + key + ".")
        else:
            out[key] = copy.deepcopy(value)
    return out


def _overlay(base: dict, given: dict) -> dict:
    """``given`` over ``base``: tables merged key by key, anything else (lists included,
    such as ``sweep.maps``, and the tables of :data:`_WHOLE_TABLES`) replaced."""
    out = copy.deepcopy(base)
    for key, value in given.items():
        if (isinstance(value, dict) and isinstance(out.get(key), dict)
                and key not in _WHOLE_TABLES):
            out[key] = _overlay(out[key], value)
        else:
            out[key] = copy.deepcopy(value)
    return out


def _read_recipe(source: Path, where: str, chain: tuple = ()) -> dict:
    """The TOML recipe ``source`` with its ``base`` recipes (relative to its folder) under it."""
    if source.resolve() in {p.resolve() for p in chain}:
        raise ValueError(f"The 'config' parameter of {where} names recipes whose 'base' keys "
                         f"form a cycle: {' -> '.join(str(p) for p in (*chain, source))}.")
    if not source.is_file():
        kind = "a folder" if source.is_dir() else "which does not exist"
        raise ValueError(f"The 'config' parameter of {where} must name a TOML recipe file"
                         + (f" (the base of {str(chain[-1])!r})" if chain else
                            f" or a shipped recipe ({', '.join(shipped_recipes())})")
                         + f". Got {str(source)!r} instead, {kind}.")
    try:
        config = _read_toml(source)
    except Exception as exc:  # tomllib.TOMLDecodeError, UnicodeDecodeError, OSError
        raise ValueError(f"The 'config' parameter of {where} names {str(source)!r}, which "
                         f"is not valid TOML: {exc}") from exc
    base = config.pop("base", None)
    if base is None:
        return config
    if not isinstance(base, str) or not base:
        raise ValueError(f"The 'config' parameter of {where} must have base, in "
                         f"{str(source)!r}, a recipe file name. Got {base!r} instead.")
    under = _read_recipe(source.parent / base, where, (*chain, source))
    return _overlay(under, config)


def recipe_toml(recipe: dict) -> str:
    """A recipe as one TOML document that :func:`load_recipe` reads back to the same recipe.

    A recipe file may start from a ``base`` named relative to its own folder, so a plain copy
    of it elsewhere did not load (four of the six shipped recipes), and an edit of its base
    changed what the copy meant. This writes every resolved key instead: keys that are
    ``None`` are left out (they take their default, which is ``None``), as is ``"source"``.

    Parameters
    ----------
    recipe : dict
        From :func:`load_recipe`.

    Returns
    -------
    str
        The TOML text (top-level keys, then ``[sweep]``, ``[[sweep.maps]]``, ``[data]``,
        ``[model]``, ``[train]``).
    """
    if not isinstance(recipe, dict):  # [1] met AttributeError 'items' (Python API audit)
        raise ValueError(f"The 'recipe' parameter of recipe_toml must be a recipe (a dict, "
                         f"from load_recipe). Got {recipe!r} instead.")

    def key(k) -> str:
        k = str(k)
        return k if k and all(c.isascii() and (c.isalnum() or c in "_-") for c in k) \
            else value(k)

    def value(v) -> str:
        if isinstance(v, (bool, np.bool_)):
            return "true" if v else "false"
        if isinstance(v, (int, np.integer)):
            return str(int(v))
        if isinstance(v, (float, np.floating)):
            v = float(v)
            if math.isinf(v):  # TOML's spellings; repr gives "nan" already
                return "inf" if v > 0 else "-inf"
            return repr(v)
        if isinstance(v, str):  # JSON's escapes are TOML's, but for DEL
            return json.dumps(v).replace("\x7f", "\\u007f")
        if isinstance(v, (list, tuple)):
            return "[" + ", ".join(value(x) for x in v if x is not None) + "]"
        if isinstance(v, dict):
            return "{" + ", ".join(f"{key(k)} = {value(x)}" for k, x in v.items()
                                   if x is not None) + "}"
        raise TypeError(f"recipe_toml: a recipe value of type {type(v).__name__} ({v!r}) has "
                        "no TOML form.")

    def is_tables(v) -> bool:
        return isinstance(v, list) and bool(v) and all(isinstance(x, dict) for x in v)

    lines = [f"{key(k)} = {value(v)}" for k, v in recipe.items()
             if k != "source" and v is not None and not isinstance(v, dict)]
    for section, table in recipe.items():
        if not isinstance(table, dict):
            continue
        lines += ["", f"[{key(section)}]"]
        lines += [f"{key(k)} = {value(v)}" for k, v in table.items()
                  if v is not None and not is_tables(v)]
        for k, v in table.items():
            if is_tables(v):
                for item in v:
                    lines += ["", f"[[{key(section)}.{key(k)}]]"]
                    lines += [f"{key(ik)} = {value(iv)}" for ik, iv in item.items()
                              if iv is not None]
    return "\n".join(lines) + "\n"


def recipe_path(config) -> Path:
    """The recipe file ``config`` names: a path, or, when no file is there, the name of a
    recipe shipped in :data:`RECIPES` (``"default"`` or ``"default.toml"``), so that an
    installed windnav, without the source tree, trains with ``--config default``."""
    path = Path(config)
    if path.exists() or path.name != str(config) or not path.name:  # a path, or a folder's
        return path
    shipped = RECIPES / (path.name if path.suffix == ".toml" else f"{path.name}.toml")
    return shipped if shipped.is_file() else path


def shipped_recipes() -> list[str]:
    """Names of the recipes shipped with windnav (:data:`RECIPES`)."""
    return sorted(p.stem for p in RECIPES.glob("*.toml"))


def load_recipe(config) -> dict:
    """A complete, checked recipe from a dict or a TOML file.

    Parameters
    ----------
    config : dict, str or path-like
        The recipe, or the path of its TOML file, or the name of a shipped one (``"default"``,
        :func:`recipe_path`); missing keys take :data:`DEFAULTS`. A file
        may start from another with ``base = "default.toml"`` (a path relative to its own
        folder): its tables are merged over the base's key by key, and anything else it sets
        (a list such as ``sweep.maps`` included) replaces the base's, as do the tables
        ``model.hyperparameters``, ``sweep.settings`` and ``data.map_weights``
        (:data:`_WHOLE_TABLES`).

    Returns
    -------
    dict
        With the sections ``sweep``, ``data``, ``model``, ``train`` complete; the source file
        (if any) under ``"source"``.

    Raises
    ------
    ValueError
        Naming 'config', for a missing or unreadable file, an unknown key or a bad value.
    """
    where = "load_recipe"
    source = None
    # None and 5 met pathlib's "expected str, bytes or os.PathLike object" (Python API audit,
    # fifty-eighth session)
    if not isinstance(config, dict | str | os.PathLike):
        raise ValueError(f"The 'config' parameter of {where} must be a recipe (a dict), the "
                         "path of a TOML recipe file or the name of a shipped recipe "
                         f"({', '.join(shipped_recipes())}). Got {config!r} instead.")
    if not isinstance(config, dict):
        source = recipe_path(config)
        config = _read_recipe(source, where)
        unset = [s for s in RECIPE_SECTIONS if s not in config]
        if unset:  # a file cut short, or a section forgotten: built-in values, silently
            warnings.warn(
                f"the recipe {str(source)!r} (with its base) sets nothing in "
                f"{', '.join(f'[{s}]' for s in unset)}: the built-in defaults of "
                "windnav.predict.train.DEFAULTS are used there, which are not the shipped "
                "default recipe's (start the file with base = \"default.toml\" to build on "
                "that one)", stacklevel=2)
    config = {k: v for k, v in config.items() if k != "source"}
    recipe = _merge(DEFAULTS, config, where)
    _check_recipe(recipe, where)
    recipe["source"] = str(source) if source is not None else None
    return recipe


def _check_recipe(r: dict, where: str) -> None:
    def fail(key, rule, got):
        raise ValueError(f"The 'config' parameter of {where} must have {key} {rule}. Got "
                         f"{got!r} instead.")

    t, d = r["train"], r["data"]
    # the run's folder under runs/ (resolve_paths) and its members' names: "../../x" wrote
    # outside runs/, and 5 was accepted (CLI audit)
    v = r["name"]
    if not isinstance(v, str) or not v or v in (".", "..") or set(v) & {"/", "\\", "\0"}:
        fail("name", "a non-empty name without path separators, not '.' or '..' (the run's "
             "folder is runs/<name>)", v)
    # as every --direction-deg of the commands (commands._common.inlet_direction refuses
    # |deg| > 360): 720 was accepted here (CLI audit)
    v = r["sweep"]["directions_deg"]
    if not isinstance(v, list) or not v or not all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and abs(x) <= 360.0
            for x in v):
        fail("sweep.directions_deg", "a non-empty list of directions within one turn, from "
             "-360 to 360 deg", v)
    # as every inlet --speed (commands._common.inlet_speed): a -3 was refused by the sweep,
    # naming its own 'speeds', after the run's folder was made (CLI audit)
    from windnav.flow.solver import MAX_SPEED

    v = r["sweep"]["speeds"]
    if not isinstance(v, list) or not v or not all(
            isinstance(x, (int, float)) and not isinstance(x, bool) and 0 < x <= MAX_SPEED
            for x in v):
        fail("sweep.speeds", f"a non-empty list of inlet speeds > 0 and <= {MAX_SPEED:g} m/s", v)
    for key in ("epochs", "batch_size", "threads", "eval_batch_size", "train_eval_samples",
                "pca_samples", "members"):
        v = t[key]
        if isinstance(v, bool) or not isinstance(v, int) or v < 1:
            fail(f"train.{key}", "an integer >= 1", v)
    v = t["resample_every"]
    if isinstance(v, bool) or not isinstance(v, int) or v < 0:
        fail("train.resample_every", "an integer >= 0 (0: the same samples every epoch)", v)
    for key in ("size", "samples_per_field", "validation_samples_per_field"):
        v = d[key]
        if isinstance(v, bool) or not isinstance(v, int) or v < 1:
            fail(f"data.{key}", "an integer >= 1", v)
    v = d["size"]  # an even window has no cell centred on the robot (decoder-study --sizes)
    if v % 2 == 0 or v < 3:
        fail("data.size", "an odd integer >= 3 (cells per side of the window centred on the "
             "robot)", v)
    if v > MAX_SIZE:  # 100001 was 640 GB of a D4 permutation (Python API audit)
        fail("data.size", f"at most {MAX_SIZE} (cells per side of the window)", v)
    _check_sampling(r, fail)
    for key in ("learning_rate",):
        if not isinstance(t[key], (int, float)) or not 0 < t[key] < math.inf:
            fail(f"train.{key}", "a positive number", t[key])
    for key in ("weight_decay", "warmup_fraction", "final_lr_fraction",
                "direction_loss_weight", "speed_loss_weight", "direction_fade",
                "loss_speed_power"):
        top = 1 if key in ("warmup_fraction", "final_lr_fraction") else math.inf
        if not isinstance(t[key], (int, float)) or not 0 <= t[key] <= top:
            fail(f"train.{key}", "a number >= 0 (a fraction <= 1)", t[key])
    if t["direction_loss"] not in ("cosine", "angle"):
        fail("train.direction_loss", "'cosine' (1 - cos) or 'angle' (the angle, rad)",
             t["direction_loss"])
    if t["vector_loss"] not in ("squared", "norm"):
        fail("train.vector_loss", "'squared' (|pred - label|^2 / U^2) or 'norm' "
             "(|pred - label| / U)", t["vector_loss"])
    if t["optimizer"] not in ("adam", "adamw"):
        fail("train.optimizer", "'adam' or 'adamw'", t["optimizer"])
    if t["keep"] not in ("best", "last"):
        fail("train.keep", "'best' (the epoch with the best validation score) or 'last' (the "
             "last epoch's weights)", t["keep"])
    sp = t["augment_speed"]
    if not isinstance(sp, list) or (sp and (len(sp) != 2 or not all(
            isinstance(v, (int, float)) and v > 0 for v in sp) or sp[0] > sp[1])):
        fail("train.augment_speed", "[] or [lo, hi] with 0 < lo <= hi, m/s", sp)
    if t["device"] not in ("auto", "cpu", "cuda"):
        fail("train.device", "'auto', 'cpu' or 'cuda'", t["device"])
    # true or false, not a string: "false" is truthy, so augment_d4 = "false" augmented
    # (audit, 2026-12-05)
    for key in ("flush_denormal", "augment_d4", "cache", "tensorboard"):
        if not isinstance(t[key], bool):
            fail(f"train.{key}", "true or false", t[key])
    if not isinstance(d["validation_maps"], list) or not d["validation_maps"]:
        fail("data.validation_maps", "a non-empty list of store map names (held out)",
             d["validation_maps"])
    v = d["turn_deg"]
    if isinstance(v, bool) or not isinstance(v, int) or not 0 <= v <= TURN_LIMIT_DEG:
        fail("data.turn_deg", f"a whole number of degrees in [0, {TURN_LIMIT_DEG}] (each "
             "training scene turned by up to that much; 0: as simulated)", v)
    ex = d["exclude_maps"]
    if not isinstance(ex, list) or not all(isinstance(m, str) for m in ex) or set(ex) & set(
            d["validation_maps"]):
        fail("data.exclude_maps", "a list of store map names left out of training (not "
             "validation maps)", ex)
    # 5 met "'int' object is not iterable" (Python API audit, fifty-eighth session)
    if not isinstance(r["sweep"]["maps"], list):
        fail("sweep.maps", "a list of map groups (tables with a name and a kind; [] for the "
             "maps of a given store)", r["sweep"]["maps"])
    groups = [g.get("name") for g in r["sweep"]["maps"] if isinstance(g, dict)]
    mw = d["map_weights"]
    if isinstance(mw, dict) and mw and not groups:  # it said only that the weights were wrong
        fail("data.map_weights", "{} when sweep.maps is empty (the weights name sweep.maps "
             "groups, and this recipe has none)", mw)
    if not isinstance(mw, dict) or not all(
            k in groups and isinstance(v, int) and not isinstance(v, bool) and v >= 1
            for k, v in mw.items()):
        fail("data.map_weights", "a table of sweep.maps group names to integers >= 1 (each "
             "training field of the group is drawn that many times over)", mw)
    # the architecture and its hyperparameters ('foo' was refused as make_architecture's
    # 'name', a table of 5 as "argument after ** must be a mapping"; Python API audit,
    # fifty-eighth session)
    if r["model"]["architecture"] not in ARCHITECTURES:
        fail("model.architecture", f"one of {sorted(ARCHITECTURES)} (passed on as the 'name' "
             "parameter of make_architecture)", r["model"]["architecture"])
    if not isinstance(r["model"]["hyperparameters"], dict):
        fail("model.hyperparameters", "a table of the architecture's hyperparameters",
             r["model"]["hyperparameters"])
    arch = make_architecture(r["model"]["architecture"], d["size"],
                             **r["model"]["hyperparameters"])
    if arch.hp.get("members", 1) != 1:
        fail("model.hyperparameters.members", "1 (a trained ensemble's members come from "
             "train.members)", arch.hp["members"])
    if not isinstance(t["teacher_weight"], (int, float)) or isinstance(
            t["teacher_weight"], bool) or not 0 <= t["teacher_weight"] <= 1:
        fail("train.teacher_weight", "a number in [0, 1] (the teacher's share of the loss)",
             t["teacher_weight"])
    if not isinstance(t["teacher"], str) or bool(t["teacher"]) != (t["teacher_weight"] > 0):
        fail("train.teacher", "a decoder file (.npz) when train.teacher_weight > 0, and \"\" "
             "when it is 0", t["teacher"])
    e = t["ema_decay"]
    if not isinstance(e, (int, float)) or isinstance(e, bool) or not 0 <= e < 1:
        fail("train.ema_decay", "a number in [0, 1) (0: no moving average of the weights)", e)
    if t["pca_samples"] < 2 and r["model"]["architecture"] == "d4-film":
        # one sample has no principal components (init_basis_pca refuses it: Python API
        # audit, fifty-eighth session), and it was met only after the sweep
        fail("train.pca_samples", "an integer >= 2 for a d4-film (the samples of the PCA that "
             "initialises its basis)", t["pca_samples"])
    if t["members"] > 1 and r["model"]["architecture"] != "d4-film":
        fail("train.members", "1 for the thesis-mlp (only d4-film decoders are ensembled)",
             t["members"])
    for i, group in enumerate(r["sweep"]["maps"]):
        if not isinstance(group, dict) or group.get("kind") not in MAP_KINDS:
            fail(f"sweep.maps[{i}].kind", f"one of {MAP_KINDS}", group)
        if "name" not in group:
            fail(f"sweep.maps[{i}].name", "a name (the map names are '<name>-<i>')", group)
        if group["kind"] == "file" and (
                not isinstance(group.get("path"), str) or not group["path"]
                or set(group) - {"name", "kind", "path"}):
            fail(f"sweep.maps[{i}]", "for kind \"file\", a name and the path of one RotorPy "
                 "world JSON file (no count, seed or generator arguments)", group)
        count = group.get("count", 1)
        if isinstance(count, bool) or not isinstance(count, int) or count < 1:
            fail(f"sweep.maps[{i}].count", "an integer >= 1", count)
    # the map names are known before the sweep: a wrong name failed only after it (an hour)
    names = [f"{g['name']}-{k}" for g in r["sweep"]["maps"]
             for k in range(1 if g["kind"] == "file" else g.get("count", 1))]
    for key in ("validation_maps", "exclude_maps") if names else ():  # none: a store's maps
        missing = [m for m in d[key] if m not in names]
        if missing:
            shown = ", ".join(names[:6]) + (", ..." if len(names) > 6 else "")
            fail(f"data.{key}", f"names of the sweep's maps ('<name>-<i>': {shown})", missing)


def _is_number(v) -> bool:
    return isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v)


def _check_sampling(r: dict, fail) -> None:
    """The recipe keys the sweep and the samples read, checked with the recipe: a negative
    scan noise, a spacing of 0, a train.seed of -1, speeds [5, 5] or solver settings
    {dx = -1} or {foo = 1} were accepted, and refused (or simulated twice) only after the
    sweep, by the dataset, NumPy or the solver, naming their own parameters (Python API
    audit, fifty-eighth session). The rules are those of
    :class:`windnav.predict.dataset.DecoderDataset` and of the sweep's solver
    (:func:`windnav.flow.simulate_batch`); the settings' names, and ``record_every`` against
    the default ``steps``, are checked by the sweep itself before it makes its store
    (:func:`windnav.experiments.wind_sweep.sweep`: ``predict`` does not import
    ``experiments``)."""
    d, sw = r["data"], r["sweep"]
    v = d["spacing"]
    if not _is_number(v) or v <= 0:
        fail("data.spacing", "a finite number > 0 (m between the window's cells)", v)
    for key, unit in (("scan_noise", "m"), ("w_robot_noise", "m/s"),
                      ("wall_clearance", "m")):
        if not _is_number(d[key]) or d[key] < 0:
            fail(f"data.{key}", f"a finite number >= 0, {unit}", d[key])
    v = d["building_reach"]
    if not _is_number(v) or v <= d["wall_clearance"]:
        fail("data.building_reach", "a finite number greater than data.wall_clearance "
             f"({d['wall_clearance']!r}), m (the robots stand between the two from the "
             "buildings)", v)
    for key, seed in (("sweep.seed", sw["seed"]), ("data.seed", d["seed"]),
                      ("train.seed", r["train"]["seed"])):
        if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
            fail(key, "an integer >= 0", seed)
    if len(set(sw["speeds"])) != len(sw["speeds"]):
        fail("sweep.speeds", "distinct inlet speeds (each is simulated once per map and "
             "direction)", sw["speeds"])
    v = sw["settings"]
    if not isinstance(v, dict):
        fail("sweep.settings", "a table of solver settings (dx, dt, spinup_steps, steps, "
             "record_every, ...)", v)
    for key in ("dx", "dt"):
        if key in v and not (key == "dt" and v[key] is None) and (
                not _is_number(v[key]) or v[key] <= 0):
            fail(f"sweep.settings.{key}", "a finite number > 0, " + (
                "m (the solver's cell size)" if key == "dx" else "s (the solver's time step)"),
                v[key])
    for key, least in (("spinup_steps", 0), ("steps", 1), ("record_every", 0)):
        if key in v and (isinstance(v[key], bool) or not isinstance(v[key], int)
                         or v[key] < least):
            fail(f"sweep.settings.{key}", f"an integer >= {least}", v[key])
    steps = v.get("steps")
    if steps is not None and v.get("record_every", 0) > steps:
        fail("sweep.settings.record_every", f"at most steps ({steps}) to record a frame, or 0 "
             "for none", v["record_every"])


def recipe_maps(recipe: dict) -> list[tuple]:
    """The sweep's maps of a recipe, drawn reproducibly: ``[(name, source, City)]``.

    Each ``[[sweep.maps]]`` group has ``name``, ``kind`` (a :mod:`windnav.city` generator:
    ``training``, ``dense``, ``planning``), ``count``, ``seed`` and keyword arguments of the
    generator (``size``, ``lots_per_side``, ...). Map ``i`` of a group is named
    ``"<name>-<i>"`` and drawn from child ``i`` of ``SeedSequence(seed).spawn(count)``.
    A group of kind ``file`` has ``name`` and ``path``: one map, ``"<name>-0"``, read from that
    RotorPy world JSON file (:func:`windnav.city.read_rotorpy_json`; a relative path from the
    working folder), e.g. your own city's layout.
    """
    import windnav.city as city_pkg

    recipe = load_recipe(recipe)
    out = []
    for group in recipe["sweep"]["maps"]:
        if group["kind"] == "file":
            path = group["path"]
            out.append((f"{group['name']}-0", f"windnav.city.read_rotorpy_json({path!r})",
                        city_pkg.read_rotorpy_json(path)))
            continue
        kw = {k: v for k, v in group.items() if k not in ("name", "kind", "count", "seed")}
        count, seed = int(group.get("count", 1)), int(group.get("seed", 0))
        make = getattr(city_pkg, f"{group['kind']}_map")
        for i, child in enumerate(np.random.SeedSequence(seed).spawn(count)):
            source = (f"windnav.city.{group['kind']}_map(SeedSequence({seed}).spawn({count})"
                      f"[{i}], **{kw!r})")
            out.append((f"{group['name']}-{i}", source,
                        make(rng=np.random.default_rng(child), **kw)))
    return out


def resolve_paths(recipe: dict, out_dir=None) -> tuple[Path, Path]:
    """The out folder (default ``runs/<name>``) and the sweep store (relative to it)."""
    if not isinstance(recipe, dict) or not isinstance(recipe.get("name"), str) \
            or not isinstance(recipe.get("sweep"), dict) or "store" not in recipe["sweep"]:
        # {} met KeyError 'name' (Python API audit, fifty-eighth session)
        raise ValueError(f"The 'recipe' parameter of resolve_paths must be a recipe (a dict, "
                         f"from load_recipe). Got {recipe!r} instead.")
    if out_dir is not None and str(out_dir) == "":  # Path("") is "." (the current folder)
        raise ValueError("The 'out_dir' parameter of resolve_paths must be a path (or None: "
                         f"runs/{recipe['name']}). Got '' instead.")
    out = Path(out_dir) if out_dir is not None else Path("runs") / recipe["name"]
    store = Path(recipe["sweep"]["store"])
    return out, store if store.is_absolute() else out / store


def _fingerprint(recipe: dict) -> str:
    """What must not change between a run and its resumption (not paths or workers)."""
    sweep = {k: v for k, v in recipe["sweep"].items() if k not in ("store", "backend", "workers")}
    # an empty exclude_maps or map_weights, or no turn (added later), leaves the fingerprints
    # of earlier runs as they were
    data = {k: v for k, v in recipe["data"].items()
            if k not in ("exclude_maps", "map_weights", "turn_deg") or v}
    # the loss keys added on 2026-11-30 likewise, at their defaults
    added = {k: DEFAULTS["train"][k] for k in ("vector_loss", "speed_loss_weight",
                                              "direction_loss", "members", "teacher",
                                              "teacher_weight", "ema_decay", "keep",
                                              "direction_fade")}
    train = {k: v for k, v in recipe["train"].items()
             if k not in ("threads", "flush_denormal", "device", "tensorboard",
                          "eval_batch_size") and not (k in added and v == added[k])}
    if train.get("teacher"):  # the teacher's weights, not where its file lies
        train["teacher"] = hashlib.sha256(Path(train["teacher"]).read_bytes()).hexdigest() \
            if Path(train["teacher"]).is_file() else train["teacher"]
    keep = {"sweep": sweep, "data": data, "model": recipe["model"], "train": train}
    return hashlib.sha256(json.dumps(keep, sort_keys=True).encode()).hexdigest()[:16]


# ------------------------------------------------------------------------------- data


def _split_fields(store_path, validation_maps, where, exclude_maps=(), map_weights=None):
    """The store's fields split by map: validation maps, and training maps (all the others
    but ``exclude_maps``, which learning-curve studies leave out).

    ``map_weights`` maps a sweep group's name to an integer ``w``: each training field of its
    maps (named ``<group>-<i>``) is listed ``w`` times, so that it gets ``w`` times the samples
    (each repeat draws its own robot positions and noise)."""
    from windnav.flow.sweep_store import SweepStore

    store = SweepStore(store_path)
    names = [str(store.map_attrs(k).get("name", k)) for k in range(store.n_maps)]
    for what, listed in (("validation", validation_maps), ("excluded", exclude_maps)):
        missing = [m for m in listed if m not in names]
        if missing:
            raise ValueError(f"The 'config' parameter of {where} must name {what} maps of the "
                             f"store {str(store_path)!r}. Got {missing} instead (the store "
                             f"holds {names}).")
    val = [k for k, n in enumerate(names) if n in validation_maps]
    train = [k for k, n in enumerate(names) if k not in val and n not in exclude_maps]
    if not train:
        raise ValueError(f"The 'config' parameter of {where} holds out every map of the store "
                         f"{str(store_path)!r}; keep at least one for training.")
    weights = map_weights or {}
    fields_train = [f for k in train for f in fields_from_store(store, maps=[k])
                    * weights.get(names[k].rsplit("-", 1)[0], 1)]
    fields_val = fields_from_store(store, maps=val)
    if not fields_train or not fields_val:
        raise ValueError(f"{where}: the store {str(store_path)!r} has no finished simulation "
                         f"for {'training' if not fields_train else 'validation'}; run (or "
                         "resume) its sweep first (`windnav train-decoder` does).")
    return fields_train, fields_val, len(train), len(val)


def _dataset(fields, per_field, data: dict, seed_offset: int, threads: int = 1,
             turn_deg: int = 0) -> DecoderDataset:
    return DecoderDataset(fields, per_field, seed=int(data["seed"]) + seed_offset,
                          size=data["size"], spacing=data["spacing"],
                          scan_noise=data["scan_noise"], w_robot_noise=data["w_robot_noise"],
                          wall_clearance=data["wall_clearance"],
                          building_reach=data["building_reach"], threads=threads,
                          turn_deg=turn_deg)


def _train_block(fields, data: dict, block: int, threads: int = 1) -> DecoderDataset:
    """The training samples of block ``block`` (seed ``data.seed + 1000 * block``), derived on
    ``threads`` threads (the same samples for any count), each scene turned by up to
    ``data.turn_deg`` (the validation samples never are: scored as simulated)."""
    return _dataset(fields, data["samples_per_field"], data, 1000 * block, threads,
                    data["turn_deg"])


def _augment(batch, rng: np.random.Generator):
    """One random D4 element per sample applied to a world-frame batch (exact): the sample
    of the same map turned by that element (ray ``j`` sees what ray ``A_g^-1(j)`` saw; the
    field at ``p`` is ``A_g u(A_g^-1 p)``)."""
    scans, w_up, w_robot, labels, free, speed = batch
    b, h = labels.shape[0], labels.shape[-1]
    g = rng.integers(0, 8, size=b)
    mats = d4_matrices()[g]
    scans = permute_cells(scans, d4_ring_indices(scans.shape[1]), g)
    labels = canonicalize_field(labels.reshape(b, 2, -1), g).reshape(b, 2, h, h)
    inverse = np.argsort(d4_grid_permutation(h), axis=1)
    free = permute_cells(free.reshape(b, -1), inverse, g).reshape(b, h, h)
    return (scans, np.einsum("bij,bj->bi", mats, w_up), np.einsum("bij,bj->bi", mats, w_robot),
            labels, free, speed)


def _rescale(batch, rng: np.random.Generator, lo: float, hi: float):
    """Each sample rescaled to an inlet speed uniform in [lo, hi] m/s: winds and labels times
    ``speed' / speed`` (exact: the solver has no velocity scale, see
    :mod:`windnav.predict.decoder`)."""
    scans, w_up, w_robot, labels, free, speed = batch
    target = rng.uniform(lo, hi, size=labels.shape[0]).astype(np.float32)
    k = target / np.maximum(np.asarray(speed, np.float32), np.float32(1e-6))
    return (scans, w_up * k[:, None], w_robot * k[:, None], labels * k[:, None, None, None],
            free, target)


class _Batches:
    """Training batches, world frame. The samples of epoch ``e`` are those of the dataset of
    block ``e // resample_every`` (seed ``data.seed + 1000 * block``; one block when
    ``resample_every`` is 0): fresh robot positions and noise every few epochs, each a
    function of the seed and the epoch. A block's samples are materialized once (``cache``)
    or regenerated batch by batch.

    With ``model_frame`` (an architecture) and ``cache``, the cached labels and free masks are
    turned into that architecture's frame once per block, in their own memory
    (:func:`_model_frame_in_place`): batches then carry labels ``(B, 2, H^2)`` and free
    ``(B, H^2)`` already in the model frame (``in_model_frame``), the same numbers that
    ``arch.model_labels`` gave each batch before (its gathers were 5.3 ms of a 256-sample step
    on an Intel Xeon, 2026-12-03, paid every epoch rather than once a block)."""

    def __init__(self, make_dataset, cache: bool, batch_size: int, resample_every: int,
                 model_frame=None):
        self.make, self.cache, self.batch_size = make_dataset, cache, batch_size
        self.every = resample_every
        self.arch = model_frame if cache else None
        self.block, self.dataset, self.arrays, self.features = None, None, None, None
        self._use(0)

    @property
    def in_model_frame(self) -> bool:
        """Whether the batches' labels and free masks are already in the model frame."""
        return self.arch is not None

    def _use(self, block: int) -> None:
        if block == self.block:
            return
        self.arrays = self.features = None  # free the previous block first
        self.dataset, self.block = self.make(block), block
        if self.cache:
            s = self.dataset.materialize()
            labels, free = s.labels, s.free
            if self.arch is not None:
                from windnav.predict.torch_models import INPUTS

                labels, free, self.features = _model_frame_in_place(
                    self.arch, s.scans, s.w_up, s.w_robot, labels, free,
                    keep=(*INPUTS[self.arch.name], "g"))
            self.arrays = (s.scans, s.w_up, s.w_robot, labels, free, s.inlet_speed)

    def __len__(self) -> int:
        return -(-len(self.dataset) // self.batch_size)

    def spread(self, n: int):
        """``n`` samples of block 0 spread evenly over the set (every field contributes)."""
        self._use(0)
        rows = np.unique(np.linspace(0, len(self.dataset) - 1, min(n, len(self.dataset)))
                         .astype(np.int64))
        if self.arrays is not None:
            return tuple(a[rows] for a in self.arrays)
        s = self.dataset.samples(rows)
        return s.scans, s.w_up, s.w_robot, s.labels, s.free, s.inlet_speed

    def epoch(self, e: int):
        """``(batch, features)`` pairs of epoch ``e``: the features (the network's inputs and
        ``g``, cached with the model-frame labels) of the batch's samples, or None when
        nothing is cached."""
        self._use(e // self.every if self.every else 0)
        if self.arrays is None:
            for s in self.dataset.epoch(e, self.batch_size):
                yield (s.scans, s.w_up, s.w_robot, s.labels, s.free, s.inlet_speed), None
            return
        order = self.dataset.indices(e)
        for i in range(0, order.size, self.batch_size):
            rows = np.sort(order[i:i + self.batch_size])
            features = None if self.features is None else \
                {k: a[rows] for k, a in self.features.items()}
            yield tuple(a[rows] for a in self.arrays), features


def _model_frame_in_place(arch, scans, w_up, w_robot, labels, free, chunk: int = 4096,
                          keep=()):
    """World-frame ``labels (N, 2, H, H)`` and ``free (N, H, H)`` turned into ``arch``'s
    frame in their own buffers, ``chunk`` samples at a time (no second copy of the block);
    returns them as ``(N, 2, H^2)`` and ``(N, H^2)`` views, and a dict of the features named
    in ``keep`` for all N samples (float32; ``g`` as computed). Sample by sample the numbers
    are those of ``arch.model_labels`` and ``arch.features`` on any batch holding the sample:
    a gather and a product by an integer D4 matrix, per sample."""
    n = labels.shape[0]
    lab, fr = labels.reshape(n, 2, -1), free.reshape(n, -1)
    kept = {}
    for i in range(0, n, chunk):
        sl = slice(i, min(i + chunk, n))
        f = arch.features(np.asarray(scans[sl], np.float32), np.asarray(w_up[sl], np.float32),
                          np.asarray(w_robot[sl], np.float32))
        lab[sl], fr[sl] = arch.model_labels(lab[sl], fr[sl], f)
        for k in keep:
            if k not in f:  # the thesis MLP has no frame "g" (a KeyError at setup; audit)
                continue
            a = f[k] if k == "g" else np.asarray(f[k], np.float32)
            if k not in kept:
                kept[k] = np.empty((n, *a.shape[1:]), a.dtype)
            kept[k][sl] = a
    return lab, fr, kept


def _labels_in_model_frame(arch, labels, free, f: dict, already: bool):
    """A batch's labels ``(B, 2, H^2)`` and free mask ``(B, H^2)`` in ``arch``'s frame
    (``f``: its features); ``already``: they are (:class:`_Batches` with ``model_frame``)."""
    if already:
        return labels, free
    b = labels.shape[0]
    return arch.model_labels(labels.reshape(b, 2, -1), free.reshape(b, -1), f)


# ---------------------------------------------------------------------------- training


def _device(name: str):
    import torch

    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    if name == "cuda" and not torch.cuda.is_available():
        raise ValueError("The 'train.device' setting of train_decoder is 'cuda', but torch "
                         "sees no CUDA device. Use 'auto' or 'cpu'.")
    return torch.device(name)


def _tensor_batch(arch, batch, device, teacher=None, in_model_frame: bool = False,
                  features: dict | None = None):
    """Network inputs, model-frame labels, free mask and inlet speeds as tensors; with a
    ``teacher`` (a :class:`Decoder`), also its fields on the batch in the model frame.
    ``in_model_frame``: the batch's labels and free mask are already in the model frame
    (:class:`_Batches` with ``model_frame``); ``features``: the batch's features cached with
    them (:meth:`_Batches.epoch`), else computed here."""
    import torch

    from windnav.predict.torch_models import to_tensors

    scans, w_up, w_robot, labels, free, speed = batch
    f = features if features is not None else arch.features(
        np.asarray(scans, np.float32), np.asarray(w_up, np.float32),
        np.asarray(w_robot, np.float32))
    b = labels.shape[0]
    lab, fr = _labels_in_model_frame(arch, labels, free, f, in_model_frame)
    def to(a):
        return torch.from_numpy(np.ascontiguousarray(a)).to(device, torch.float32)

    out = (to_tensors(f, arch.name, device), to(lab), to(fr), to(np.asarray(speed, np.float32)))
    if teacher is None:
        return out
    taught = teacher.predict(scans, w_up, w_robot).reshape(b, 2, -1)
    return (*out, to(arch.model_labels(taught, free.reshape(b, -1), f)[0]))


def _loss(pred, labels, free, speed, power: float, direction_weight: float,
          vector: str = "squared", speed_weight: float = 0.0, direction: str = "cosine",
          fade: float = DIRECTION_FADE, fused: bool = True):
    """The training loss, a mean over free cells of three terms:

    - the vector term, ``vector = "squared"``: ``(U / 10)^p |pred - label|^2 / U^2`` (the MSE);
      ``"norm"``: ``(U / 10)^p |pred - label| / U``, the vector-error metric's own form, whose
      minimiser is a median, not a mean (the squared error pulls a prediction towards the
      average of the fields a scan leaves possible, which is slower than each of them);
    - ``speed_weight * (U / 10)^p ||pred| - |label|| / U``, the speed-error metric's own form;
    - ``direction_weight * c (1 - cos(pred, label))`` (``direction = "cosine"``), or ``c``
      times the angle between them in radians (``"angle"``, the direction error's own form,
      ``atan2(|pred x label|, pred . label)``: its gradient does not vanish for small angles
      as that of ``1 - cos ~ angle^2 / 2`` does). Both are scale-invariant (their gradients
      never pull on the predicted speed); the cosine is softened only by ``1e-6 U^2`` against
      0 / 0, the cross product by ``1e-3 U^2``; ``c = min(1, |label| / (fade U))`` fades out
      cells whose true direction is barely defined (``fade`` = ``train.direction_fade``,
      0.1 by default; 0: ``c = 1`` wherever the label is not 0, every free cell counted as
      the direction-error metric counts it).

    The norms are softened by ``1e-3 U`` so that their gradients stay finite at 0.

    With ``fused`` (the default), ``direction = "cosine"`` and CPU tensors, the loss and its
    gradient come out of one compiled pass (:mod:`windnav.predict._loss`; the same values to
    float32 rounding, about a third of a training step's time less on 2 cores); otherwise
    (and as its reference) the torch formula below.
    """
    import torch

    if fused and direction == "cosine" and pred.device.type == "cpu":
        return fused_loss(pred, labels, free, speed, power, direction_weight, vector,
                          speed_weight, fade)
    u = torch.clamp(speed, min=0.1)
    n_free = torch.clamp(free.sum(), min=1.0)
    by_speed = (u / SPEED_REF) ** power
    soft = (1e-3 * u[:, None]) ** 2  # the norms' softening, (1e-3 U)^2
    sq = ((pred - labels) ** 2).sum(dim=1)  # (B, H^2)
    if vector == "squared":
        err, w = sq, by_speed / (u * u)
    else:
        err, w = torch.sqrt(sq + soft), by_speed / u
    loss = (err * free * w[:, None]).sum() / n_free
    if speed_weight > 0:
        speed_err = (torch.sqrt((pred ** 2).sum(dim=1) + soft)
                     - torch.sqrt((labels ** 2).sum(dim=1) + soft)).abs()
        loss = loss + speed_weight * (speed_err * free * (by_speed / u)[:, None]).sum() / n_free
    if direction_weight > 0:
        norm_l = torch.sqrt((labels ** 2).sum(dim=1))
        c = torch.clamp(norm_l / (fade * u[:, None]), max=1.0) if fade > 0 \
            else (norm_l > 0).to(norm_l.dtype)
        if direction == "cosine":
            norm_p = torch.sqrt((pred ** 2).sum(dim=1))
            cos = (pred * labels).sum(dim=1) / (norm_p * norm_l + 1e-6 * (u * u)[:, None])
            miss = 1.0 - cos
        else:
            cross = pred[:, 0] * labels[:, 1] - pred[:, 1] * labels[:, 0]
            dot = (pred * labels).sum(dim=1)
            miss = torch.atan2(torch.sqrt(cross ** 2 + (1e-3 * (u * u)[:, None]) ** 2), dot)
        loss = loss + direction_weight * (miss * c * free).sum() / n_free
    return loss


def ema_decay_at(decay: float, step: int) -> float:
    """The decay of the weights' moving average at optimizer step ``step`` (1, 2, ...):
    ``min(decay, (1 + step) / (10 + step))``, so that the initial weights fade within the first
    steps instead of over ``1 / (1 - decay)`` of them.

    Parameters
    ----------
    decay : float
        ``train.ema_decay``, in [0, 1) (a fraction per step, no unit; 0: no averaging).
    step : int
        The optimizer steps taken so far, >= 1 (the schedule's count after the step).

    Returns
    -------
    float
        The decay at that step, in [0, decay].
    """
    # 1.5, -1 and NaN were returned as decays, and step -10 divided by zero (Python API audit,
    # fifty-eighth session)
    where = "ema_decay_at"
    d = finite_float(decay, "decay", where)
    if isinstance(decay, bool) or not isinstance(decay, int | float | np.number) \
            or not 0 <= d < 1:
        raise ValueError(f"The 'decay' parameter of {where} must be a number in [0, 1). Got "
                         f"{decay!r} instead.")
    return _decay_at(decay, positive_int(step, "step", where))


def _decay_at(decay: float, step: int) -> float:
    return min(decay, (1.0 + step) / (10.0 + step))


def _ema_update(averages, params, decay: float, step: int) -> None:
    """``a <- a + (1 - d) (p - a)`` for each average ``a`` and parameter ``p`` (torch's
    ``lerp_``), ``d = ema_decay_at(decay, step)``."""
    import torch

    w = 1.0 - _decay_at(decay, step)  # checked with the recipe (train.ema_decay)
    with torch.no_grad():
        for a, p in zip(averages, params, strict=True):
            a.lerp_(p.detach(), w)


def _schedule(total_steps: int, warmup: float, final: float):
    warm = max(1, int(round(warmup * total_steps)))

    def factor(step: int) -> float:
        if step < warm:
            return (step + 1) / warm
        p = min(1.0, (step - warm) / max(1, total_steps - warm))
        return final + (1.0 - final) * 0.5 * (1.0 + math.cos(math.pi * p))

    return factor


def _evaluate(decoder: Decoder, samples, batch_size: int) -> dict:
    # the one pass (boundary="average"), whatever the decoder's rule: the validation that
    # picks the kept epoch, and the metrics recorded, are of the network as trained
    if decoder.boundary != "average":
        decoder = Decoder(decoder.weights, decoder.metadata, boundary="average")
    # on one BLAS thread: a batch's float32 products otherwise change in their last bits with
    # the BLAS thread count (6e-6 m/s under OpenBLAS's Haswell kernel), and so could the
    # validation errors that pick the shipped epoch (thread audit, 2026-12-05)
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        pred = np.concatenate([decoder.predict(samples.scans[i:i + batch_size],
                                               samples.w_up[i:i + batch_size],
                                               samples.w_robot[i:i + batch_size])
                               for i in range(0, samples.scans.shape[0], batch_size)])
    return _errors(pred, samples)


def _errors(pred, samples) -> dict:
    out = field_errors(pred, samples.labels, samples.free, samples.inlet_speed)
    return {k: float(v) for k, v in out.items() if k in (
        "speed_error", "direction_error_deg", "direction_error_masked_deg", "vector_error")}


def _baselines(samples, size: int, spacing: float) -> dict:
    return {name: _errors(cls(size=size, spacing=spacing).predict(
        samples.scans, samples.w_up, samples.w_robot), samples)
        for name, cls in (("local", LocalBaseline), ("upstream", UpstreamBaseline))}


def _score(metrics: dict, local: dict) -> float:
    """Mean of the speed and direction errors relative to the Local baseline's (lower is
    better): the model selection criterion."""
    return 0.5 * (metrics["speed_error"] / max(local["speed_error"], 1e-12)
                  + metrics["direction_error_deg"] / max(local["direction_error_deg"], 1e-12))


def _summary_writer(enabled: bool, log_dir: Path):
    if not enabled:
        return None
    try:
        from torch.utils.tensorboard import SummaryWriter
    except ImportError:
        warnings.warn("train_decoder: the 'tensorboard' package is not installed, so no "
                      "TensorBoard log is written (install windnav[train]); the JSON history "
                      "is written as usual.", stacklevel=3)
        return None
    return SummaryWriter(log_dir=str(log_dir))


def _atomic_json(obj, path: Path) -> None:
    tmp = path.with_name(path.name + ".tmp")
    tmp.write_text(json.dumps(obj, indent=2, sort_keys=False) + "\n")
    os.replace(tmp, path)


def train_decoder(config, *, store=None, out_dir=None, progress: bool = True, log=print,
                  callback=None) -> dict:
    """Train (or resume training) a wind flow decoder.

    Parameters
    ----------
    config : dict, str or path-like
        The recipe (:func:`load_recipe`).
    store : str or path-like, optional
        The sweep store with the mean fields (default: the recipe's ``sweep.store`` in
        ``out_dir``). Its maps named in ``data.validation_maps`` are held out.
    out_dir : str or path-like, optional
        Where ``checkpoint.pt``, ``history.json``, ``model.npz`` (the best decoder) and
        ``tensorboard/`` go (default ``runs/<name>``). A checkpoint of the same recipe there is
        resumed; one of another recipe is refused.
    progress : bool
        Show a tqdm bar per epoch.
    log : callable
        Receives one line per epoch (``print`` by default; None: silent).
    callback : callable, optional
        ``callback(epoch, record)`` after each epoch's checkpoint (tests stop a run with it).

    Returns
    -------
    dict
        The history, as in ``history.json``: ``epochs`` (one record per epoch: ``train_loss``,
        ``val`` metrics, ``score``, ``lr``, ``seconds``), ``baselines`` (the validation metrics
        of the Local and Upstream baselines), ``best_epoch``, ``best_val``, ``train_metrics``
        (the kept model, best or last per ``train.keep``, on training samples, with the
        baselines'), ``model`` (path),
        ``n_parameters`` and the ``recipe``.

    Raises
    ------
    ValueError
        Naming 'config' for a bad recipe or a checkpoint of another recipe in ``out_dir``; for
        a store without the validation maps or without finished simulations.
    """
    where = "train_decoder"
    recipe = load_recipe(config)
    out, default_store = resolve_paths(recipe, out_dir)
    given_store = store is not None
    store = Path(store) if store is not None else default_store
    if not store.exists() and not (out / "checkpoint.pt").is_file() \
            and not (out / "history.json").is_file():
        # "SweepStore: there is no Zarr store ...", after the out folder was made (Python API
        # audit, fifty-eighth session); a finished run needs no store, so only a new one
        raise _missing_store(store, given_store, where)
    import torch

    out.mkdir(parents=True, exist_ok=True)
    if recipe["train"]["members"] > 1:
        return _train_members(recipe, out, store, progress, log, callback, where)
    run = _Run(recipe, out, store)
    ckpt = run.load_checkpoint(where)
    if ckpt is not None and "train_metrics" in ckpt["history"]:
        return ckpt["history"]  # finished

    tr = recipe["train"]
    flushed = flush_denormals() if tr["flush_denormal"] else None
    if flushed is False and log:
        log(f"{where}: train.flush_denormal could not be set on every thread (torch's worker "
            "threads had started, or the CPU lacks FTZ/DAZ): subnormal numbers may slow the "
            "training; run it in a fresh process")
    torch.set_num_threads(tr["threads"])
    run.setup(where)
    if ckpt is not None:
        run.restore(ckpt)
        if log and run.start < tr["epochs"]:
            log(f"{where}: resuming {str(out)!r} after epoch {run.start}")
        began = run.history.get("threads")
        if began is not None and began != tr["threads"] and run.start < tr["epochs"]:
            warnings.warn(
                f"{where}: resuming on {tr['threads']} torch thread(s) a run begun on {began}: "
                "its model will not be the one an uninterrupted run makes (torch's sums "
                f"depend on the thread count); set train.threads = {began} to match it",
                stacklevel=2)
    run.history["flush_denormal"] = flushed
    writer = _summary_writer(tr["tensorboard"], out / "tensorboard") \
        if run.start < tr["epochs"] else None
    try:
        for e in range(run.start, tr["epochs"]):
            record = run.epoch(e, progress)
            run.save_checkpoint()
            if writer is not None:
                _log_scalars(writer, record)
            if log:
                local = run.history["baselines"]["local"]
                log(f"epoch {e + 1}/{tr['epochs']}: loss {record['train_loss']:.4g}, val speed "
                    f"{record['val']['speed_error']:.3f} m/s, direction "
                    f"{record['val']['direction_error_deg']:.2f} deg (Local "
                    f"{local['speed_error']:.3f} m/s, {local['direction_error_deg']:.2f} deg), "
                    f"{record['seconds']:.0f} s")
            if callback is not None:
                callback(e + 1, record)
    finally:
        if writer is not None:
            writer.close()
    run.finish()
    return run.history


def _missing_store(store: Path, given: bool, where: str) -> ValueError:
    if given:
        return ValueError(f"The 'store' parameter of {where} must be a sweep store (the Zarr "
                          "folder windnav wind-sweep, or windnav train-decoder's sweep, writes). "
                          f"Got {str(store)!r} instead, which does not exist.")
    return ValueError(f"{where}: there is no sweep store at {str(store)!r} (the recipe's "
                      "sweep.store, relative to the out folder); pass 'store', or run the "
                      "recipe's sweep first (`windnav train-decoder` does).")


def member_recipe(recipe: dict, i: int) -> dict:
    """Member ``i`` of a recipe with ``train.members`` > 1: the same recipe with one member,
    ``train.seed`` + ``i`` (another initialisation; the same samples in the same order, which
    ``data.seed`` sets) and the name ``<name>-member<i>``. Member 0 is the recipe's own single
    model, bit for bit."""
    # -1 and 99 of 3 members were accepted, {} met KeyError 'train' and '1' a TypeError
    # (Python API audit, fifty-eighth session)
    where = "member_recipe"
    if not isinstance(recipe, dict) or not isinstance(recipe.get("train"), dict) \
            or "name" not in recipe:
        raise ValueError(f"The 'recipe' parameter of {where} must be a recipe (a dict, from "
                         f"load_recipe). Got {recipe!r} instead.")
    members = recipe["train"].get("members", 1)
    if isinstance(i, bool) or not isinstance(i, int | np.integer) or not 0 <= i < members:
        raise ValueError(f"The 'i' parameter of {where} must be a member of the recipe: an "
                         f"integer in [0, {members}) (train.members). Got {i!r} instead.")
    r = copy.deepcopy({k: v for k, v in recipe.items() if k != "source"})
    r["train"].update(members=1, seed=int(recipe["train"]["seed"]) + i)
    r["name"] = f"{recipe['name']}-member{i}"
    return r


def _train_members(recipe: dict, out: Path, store: Path, progress: bool, log, callback,
                   where: str) -> dict:
    """``train.members`` > 1: train each member in ``out/member<i>`` (each resumable as a
    run of its own), then write their ensemble (:func:`windnav.predict.decoder.ensemble_decoder`,
    the mean of their fields) to ``out/model.npz``, scored like a single run's best model."""
    from windnav.predict.decoder import ensemble_decoder

    m = recipe["train"]["members"]
    fingerprint = _fingerprint(recipe)
    hist_path, model_path = out / "history.json", out / "model.npz"
    if (out / "checkpoint.pt").exists():
        raise ValueError(f"The 'config' parameter of {where} differs from the recipe of the "
                         f"checkpoint in {str(out)!r} (a single model's; this recipe trains "
                         f"{m} members); use another out folder, or delete it (`windnav "
                         "train-decoder --overwrite`) to start over.")
    if hist_path.is_file():
        done = json.loads(hist_path.read_text())
        if done.get("fingerprint") != fingerprint:
            raise ValueError(f"The 'config' parameter of {where} differs from the recipe of "
                             f"the ensemble in {str(out)!r}; use another out folder, or delete "
                             "it (`windnav train-decoder --overwrite`) to start over.")
        if "train_metrics" in done:
            return done
    histories = []
    for i in range(m):
        sub = member_recipe(recipe, i)
        if log:
            log(f"{where}: member {i + 1}/{m} (train.seed {sub['train']['seed']}) in "
                f"{str(out / f'member{i}')!r}")
        histories.append(train_decoder(sub, store=store, out_dir=out / f"member{i}",
                                       progress=progress, log=log, callback=callback))
    members = [load_decoder(h["model"]) for h in histories]
    run = _Run(recipe, out, store)
    run.load_data(where)
    data, tr = run.data, run.tr
    baselines = _baselines(run.val, data["size"], data["spacing"])
    meta = {"spacing": float(data["spacing"]),
            "recipe": {k: v for k, v in recipe.items() if k != "source"}}
    dec = ensemble_decoder(members, {**members[0].metadata, **meta})
    val = _evaluate(dec, run.val, tr["eval_batch_size"])
    subset = run.train_subset()
    train_metrics = {"decoder": _evaluate(dec, subset, tr["eval_batch_size"]),
                     **_baselines(subset, data["size"], data["spacing"])}
    seconds = sum(r["seconds"] for h in histories for r in h["epochs"])
    save_decoder(dec.weights, {**dec.metadata, "metrics": {
        "validation": val, "validation_baselines": baselines,
        "training_subset": train_metrics,
        "members_validation": [h["best_val"] for h in histories]},
        "training": {"epochs": tr["epochs"], "members": m,
                     "best_epochs": [h["best_epoch"] for h in histories],
                     "seconds": seconds, "device": histories[0]["device"],
                     "threads": tr["threads"],
                     "flush_denormal": histories[0].get("flush_denormal"),
                     "n_train_samples": histories[0]["n_train_samples"],
                     "n_train_fields": histories[0]["n_train_fields"]}}, model_path)
    history = {
        "recipe": meta["recipe"], "fingerprint": fingerprint, "store": str(store),
        "members": [{"out": str(out / f"member{i}"), "seed": recipe["train"]["seed"] + i,
                     "best_epoch": h["best_epoch"], "best_val": h["best_val"],
                     "seconds": sum(r["seconds"] for r in h["epochs"])}
                    for i, h in enumerate(histories)],
        "baselines": baselines, "best_val": val, "best_score": _score(val, baselines["local"]),
        "train_metrics": train_metrics, "n_parameters": dec.n_parameters,
        "n_train_samples": histories[0]["n_train_samples"],
        "n_val_samples": int(run.val.scans.shape[0]), "device": histories[0]["device"],
        "threads": tr["threads"], "model": str(model_path)}
    _atomic_json(history, hist_path)
    if log:
        log(f"{where}: ensemble of {m} members, val speed {val['speed_error']:.3f} m/s, "
            f"direction {val['direction_error_deg']:.2f} deg (members: " + ", ".join(
                f"{h['best_val']['speed_error']:.3f} m/s / "
                f"{h['best_val']['direction_error_deg']:.2f} deg" for h in histories) + ")")
    return history


def flush_denormals() -> bool:
    """Flush subnormal floats to zero (FTZ/DAZ) in torch's CPU arithmetic, on every thread.

    Why: with an L2 penalty (the thesis MLP's lambda = 0.002) weights, Adam moments and
    activations drift into the subnormal range (below 1.2e-38 in float32), where some CPUs
    take a slow path for each operation: the thesis MLP's epochs slowed 4-10 x from the 4th
    (docs/decoder.md). The flag is a per-thread CPU register; torch's OpenMP and MKL worker
    threads copy it from the thread that starts them, when the process first computes in
    parallel. So it must be set before that: set afterwards it reaches the calling thread only
    (measured: half of a 2-thread product stayed subnormal).

    Returns
    -------
    bool
        Whether a probe computed on every intra-op thread came out flushed: False when the
        CPU has no FTZ/DAZ, or when the worker threads had already started.
    """
    import torch

    if not torch.set_flush_denormal(True):
        return False
    # an elementwise product is split among the threads in chunks of 32,768 elements
    n = 65536 * max(2, torch.get_num_threads())
    probe = torch.full((n,), 1e-20) * torch.full((n,), 1e-20)  # 1e-40: subnormal unless flushed
    return bool((probe == 0).all())


def _log_scalars(writer, record: dict) -> None:
    step = record["epoch"]
    writer.add_scalar("loss/train", record["train_loss"], step)
    for k, v in record["val"].items():
        writer.add_scalar(f"val/{k}", v, step)
    writer.add_scalar("val/score", record["score"], step)
    writer.add_scalar("lr", record["lr"], step)
    writer.flush()


TRAINING_MODULE = "windnav.predict.train"
"""The module whose source (with the windnav modules it imports) a checkpoint records
(``code``); a resume under other code is warned."""


class _Run:
    """The state of one training run: data, model, optimizer, history, and its files."""

    def __init__(self, recipe: dict, out: Path, store: Path):
        self.recipe, self.out, self.store = recipe, out, store
        self.data, self.tr, self.mdl = recipe["data"], recipe["train"], recipe["model"]
        self.fingerprint = _fingerprint(recipe)
        self.code = module_key(TRAINING_MODULE)
        self.ckpt_path = out / "checkpoint.pt"
        self.hist_path = out / "history.json"
        self.model_path = out / "model.npz"
        self.start = 0

    def load_checkpoint(self, where: str):
        import torch

        if not self.ckpt_path.is_file():
            return None
        ckpt = torch.load(self.ckpt_path, map_location="cpu", weights_only=True)
        if ckpt.get("fingerprint") != self.fingerprint:
            raise ValueError(f"The 'config' parameter of {where} differs from the recipe of the "
                             f"checkpoint in {str(self.out)!r}; use another out folder, or delete "
                             "it (`windnav train-decoder --overwrite`) to start over.")
        return ckpt

    def load_data(self, where: str) -> tuple:
        """``fields_train`` and the validation samples ``val`` from the store; returns the
        validation fields and the training and validation map counts."""
        data = self.data
        self.fields_train, fields_val, n_train_maps, n_val_maps = _split_fields(
            self.store, data["validation_maps"], where, data["exclude_maps"],
            data["map_weights"])
        self.val = _dataset(fields_val, data["validation_samples_per_field"], data, 1,
                            self.tr["threads"]).materialize()
        return fields_val, n_train_maps, n_val_maps

    def train_subset(self):
        """The training samples the finished model is scored on (of block 0, evenly spaced)."""
        block0 = self.train_set(0)
        return block0.samples(np.unique(np.linspace(
            0, len(block0) - 1, min(self.tr["train_eval_samples"], len(block0))).astype(
                np.int64)))

    def train_set(self, block: int) -> DecoderDataset:
        return _train_block(self.fields_train, self.data, block, self.tr["threads"])

    def setup(self, where: str) -> None:
        import torch

        from windnav.predict.torch_models import build_model

        data, tr, mdl = self.data, self.tr, self.mdl
        self.device = _device(tr["device"])
        fields_val, n_train_maps, n_val_maps = self.load_data(where)
        self.arch = make_architecture(mdl["architecture"], data["size"],
                                      **mdl["hyperparameters"])
        # not the bound train_set: the batches would then hold this run, a cycle that keeps
        # its samples (GBs) alive after the run until the cycle collector comes (2026-12-02:
        # 13.8 GB peak for two ensemble members trained in turn, 6.3 GB for one)
        # labels turned into the model frame once a block, unless an augmentation must turn
        # the world-frame batches first
        augmented = tr["augment_d4"] or bool(tr["augment_speed"])
        self.batches = _Batches(functools.partial(_train_block, self.fields_train, data,
                                                  threads=tr["threads"]),
                                tr["cache"], tr["batch_size"], tr["resample_every"],
                                model_frame=None if augmented else self.arch)
        torch.manual_seed(tr["seed"])
        self.model = build_model(mdl["architecture"], data["size"],
                                 **mdl["hyperparameters"]).to(self.device)
        self.teacher = None
        if tr["teacher_weight"] > 0:
            self.teacher = load_decoder(tr["teacher"], boundary="average")  # as trained
            if self.teacher.size != data["size"] or self.teacher.spacing != data["spacing"]:
                raise ValueError(
                    f"The 'config' parameter of {where} must have train.teacher predict on the "
                    f"recipe's grid ({data['size']} cells of {data['spacing']} m). Got "
                    f"{self.teacher!r} instead.")
        self.meta = {"spacing": float(data["spacing"]),
                     "recipe": {k: v for k, v in self.recipe.items() if k != "source"}}
        if mdl["architecture"] == "d4-film":
            self.meta["pca_explained_variance"] = self._init_basis()
        # the weights' exponential moving average (train.ema_decay > 0), from the initial ones
        self.ema = [q.detach().clone() for q in self.model.parameters()] \
            if tr["ema_decay"] > 0 else None
        opt_cls = torch.optim.AdamW if tr["optimizer"] == "adamw" else torch.optim.Adam
        # the fused update (one kernel over all parameters, not a loop of small ops per
        # tensor): 0.8 ms per step against 2.4 on an Intel Xeon (2026-12-03)
        self.opt = opt_cls(self.model.parameters(), lr=tr["learning_rate"],
                           weight_decay=tr["weight_decay"],
                           fused=self.device.type in ("cpu", "cuda"))
        self.sched = torch.optim.lr_scheduler.LambdaLR(self.opt, _schedule(
            tr["epochs"] * len(self.batches), tr["warmup_fraction"], tr["final_lr_fraction"]))
        baselines = _baselines(self.val, data["size"], data["spacing"])
        self.history = {
            "recipe": self.meta["recipe"], "fingerprint": self.fingerprint,
            "code": self.code, "store": str(self.store),
            "n_train_fields": len(self.fields_train),
            "n_val_fields": len(fields_val), "n_train_maps": n_train_maps,
            "n_val_maps": n_val_maps, "n_train_samples": len(self.batches.dataset),
            "n_val_samples": int(self.val.scans.shape[0]),
            "n_parameters": int(sum(p.numel() for p in self.model.parameters())),
            "device": str(self.device), "threads": tr["threads"], "baselines": baselines,
            "epochs": [], "best_epoch": None, "best_val": None, "best_score": None,
            "model": str(self.model_path)}

    def _init_basis(self) -> list:
        """PCA of the canonical residuals ``(label - W_robot) / U`` of training samples."""
        from windnav.predict.torch_models import init_basis_pca

        first = self.batches.spread(self.tr["pca_samples"])
        f = self.arch.features(*first[:3])
        b = first[3].shape[0]
        lab, fr = _labels_in_model_frame(self.arch, first[3], first[4], f,
                                         self.batches.in_model_frame)
        resid = (lab - f["w_robot"][:, :, None]) / f["scale"][:, None, None] * fr[:, None, :]
        explained = init_basis_pca(self.model, resid.reshape(b, -1))
        return [round(float(x), 6) for x in explained]

    def restore(self, ckpt: dict) -> None:
        import torch

        self.model.load_state_dict(ckpt["model"])
        self.opt.load_state_dict(ckpt["optimizer"])
        self.sched.load_state_dict(ckpt["scheduler"])
        torch.set_rng_state(ckpt["torch_rng"])
        if self.ema is not None:
            for a, saved in zip(self.ema, ckpt["ema"], strict=True):
                a.copy_(saved)
        self.history = ckpt["history"]
        self.start = len(self.history["epochs"])
        code = ckpt.get("code")  # the code that trained last, not the first (review)
        if code is not None and code != self.code:  # the epochs before and after differ
            warnings.warn(
                f"train_decoder: the checkpoint in {str(self.out)!r} was trained by other "
                f"training code (source hash {code}; this one's is {self.code}: "
                f"{TRAINING_MODULE} and the modules it imports); resuming mixes the two in one "
                "model. Delete the folder (`windnav train-decoder --overwrite`) to train it "
                "with this code alone.", stacklevel=3)
            self.history.setdefault("resumed_by_code", []).append(
                {"code": self.code, "from_epoch": self.start})

    def epoch(self, e: int, progress: bool) -> dict:
        """Train epoch ``e``, validate, keep the best model; returns the epoch's record."""
        from threadpoolctl import threadpool_limits

        from windnav._console import progress_bar
        from windnav.predict.torch_models import export_weights

        tr, model = self.tr, self.model
        t0 = time.perf_counter()
        model.train()
        rng = np.random.default_rng([int(tr["seed"]), 2, e])
        total, count = 0.0, 0
        bar = progress_bar(self.batches.epoch(e), total=len(self.batches), disable=not progress,
                           desc=f"epoch {e + 1}/{tr['epochs']}", leave=False)
        # the teacher's NumPy products on one BLAS thread: beside torch's threads, two BLAS
        # threads spin against them (2026-12-02: 26 ms per batch of 256 for the 3-model
        # teacher instead of 6.7)
        limit = threadpool_limits(limits=1, user_api="blas") if self.teacher is not None \
            else contextlib.nullcontext()
        terms = (tr["loss_speed_power"], tr["direction_loss_weight"], tr["vector_loss"],
                 tr["speed_loss_weight"], tr["direction_loss"], tr["direction_fade"])
        with limit:
            for batch, features in bar:
                if tr["augment_speed"]:
                    batch = _rescale(batch, rng, *tr["augment_speed"])
                if tr["augment_d4"]:
                    batch = _augment(batch, rng)
                inputs, labels, free, speed, *taught = _tensor_batch(
                    self.arch, batch, self.device, self.teacher, self.batches.in_model_frame,
                    features)
                pred = model(inputs)
                loss = _loss(pred, labels, free, speed, *terms)
                if taught:  # distillation: the teacher's field as a second target
                    w = tr["teacher_weight"]
                    loss = (1.0 - w) * loss + w * _loss(pred, taught[0], free, speed, *terms)
                self.opt.zero_grad(set_to_none=True)
                loss.backward()
                self.opt.step()
                self.sched.step()
                if self.ema is not None:  # the schedule counts the optimizer's steps
                    _ema_update(self.ema, model.parameters(), tr["ema_decay"],
                                self.sched.last_epoch)
                value = float(loss.detach())
                if not math.isfinite(value):  # was "'weights' of Decoder must be finite"
                    raise ValueError(
                        f"The 'train.learning_rate' parameter of the recipe made the training "
                        f"diverge: the loss became {value} in epoch {e + 1} (at "
                        f"{tr['learning_rate']!r}, now {self.opt.param_groups[0]['lr']:.3g} in "
                        "its schedule); lower it, or check the sweep's fields and the "
                        "recipe's other train settings.")
                total += value * labels.shape[0]
                count += labels.shape[0]
                bar.set_postfix(loss=f"{total / count:.4g}", refresh=False)
        model.eval()
        decoder = Decoder(export_weights(model), {**self.meta, "architecture": self.arch.name,
                                                  "hyperparameters": self.arch.hp},
                          boundary="average")
        metrics = _evaluate(decoder, self.val, tr["eval_batch_size"])
        raw_metrics = None
        if self.ema is not None:  # the average is the model kept; the raw one is recorded
            raw_metrics = metrics
            decoder = Decoder(self._ema_weights(decoder.weights), decoder.metadata,
                              boundary="average")
            metrics = _evaluate(decoder, self.val, tr["eval_batch_size"])
        h = self.history
        score = _score(metrics, h["baselines"]["local"])
        record = {"epoch": e + 1, "train_loss": total / max(count, 1), "val": metrics,
                  "score": score, "lr": float(self.opt.param_groups[0]["lr"]),
                  "seconds": time.perf_counter() - t0}
        if raw_metrics is not None:
            record["val_raw"] = raw_metrics
        h["epochs"].append(record)
        best = h["best_score"] is None or score < h["best_score"]
        if best:
            h.update(best_epoch=e + 1, best_val=metrics, best_score=score)
        if best or tr["keep"] == "last":
            save_decoder(decoder.weights, {**decoder.metadata, "metrics": {
                "validation": metrics, "validation_baselines": h["baselines"],
                "epoch": e + 1}}, self.model_path)
        return record

    def _ema_weights(self, weights: dict) -> dict:
        """``weights`` (the model's, as :func:`export_weights` gives them) with the moving
        average in place of every parameter."""
        import torch

        return {**weights, **{n: a.detach().to("cpu", torch.float32).numpy().copy()
                              for (n, _), a in zip(self.model.named_parameters(), self.ema,
                                                   strict=True)}}

    def save_checkpoint(self) -> None:
        import torch

        state = {"fingerprint": self.fingerprint, "code": self.code,
                 "model": self.model.state_dict(),
                 "optimizer": self.opt.state_dict(), "scheduler": self.sched.state_dict(),
                 "torch_rng": torch.get_rng_state(), "history": self.history}
        if self.ema is not None:
            state["ema"] = self.ema
        tmp = self.ckpt_path.with_name(self.ckpt_path.name + ".tmp")
        torch.save(state, tmp)
        os.replace(tmp, self.ckpt_path)
        _atomic_json(self.history, self.hist_path)

    def finish(self) -> None:
        """The kept model (``train.keep``) on training samples (with the baselines), into its
        file, the history and the checkpoint (which then marks the run finished)."""
        h, tr = self.history, self.tr
        best = load_decoder(self.model_path, boundary="average")  # as validated
        subset = self.train_subset()
        h["train_metrics"] = {"decoder": _evaluate(best, subset, tr["eval_batch_size"]),
                              **_baselines(subset, self.data["size"], self.data["spacing"])}
        save_decoder(best.weights, {**best.metadata, "metrics": {
            **best.metadata["metrics"], "training_subset": h["train_metrics"]},
            "training": {"epochs": tr["epochs"], "best_epoch": h["best_epoch"],
                         "kept": tr["keep"],
                         "seconds": sum(r["seconds"] for r in h["epochs"]),
                         "device": h["device"], "threads": tr["threads"],
                         "flush_denormal": h.get("flush_denormal"),
                         "n_train_samples": h["n_train_samples"],
                         "n_train_fields": h["n_train_fields"]}}, self.model_path)
        self.save_checkpoint()
