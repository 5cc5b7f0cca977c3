"""What a decoder was trained on, read from its file's metadata (the recipe).

:func:`training_envelope` gathers the conditions of a decoder's training data: the LiDAR scan
noise, where the robots stood (``wall_clearance`` to ``building_reach`` from the buildings),
the label spacing, and the flow protocol of its sweep (cell size, time step, steps, inlet
speeds and so how far the inlet's air travelled during spin-up and averaging). ``windnav
predict`` and ``windnav evaluate-decoder`` compare their inputs and truth flows with it and
say when they lie outside. Nothing here changes a prediction.
"""

from __future__ import annotations

import copy

__all__ = ["training_envelope"]


def training_envelope(decoder_or_metadata) -> dict:
    """The training conditions of a decoder, from ``metadata["recipe"]``.

    A recipe key the file lacks takes the value ``windnav train-decoder`` gives it
    (:data:`windnav.predict.train.DEFAULTS`); a file without a recipe gets all of them
    (``source`` says which). The solver settings are the recipe's as written: a missing one is
    the sweep's default (``windnav wind-sweep``'s, the time step set by the fastest speed),
    which the caller fills in.

    Parameters
    ----------
    decoder_or_metadata : Decoder or dict
        A loaded decoder, or its ``metadata``.

    Returns
    -------
    dict
        ``source`` (``"recipe"`` or ``"defaults"``), ``scan_noise`` m, ``w_robot_noise``
        m/s, ``wall_clearance`` m, ``building_reach`` m, ``label_spacing`` m, ``speeds``
        (the sweep's inlet speeds, m/s) and ``settings`` (the sweep's solver settings as given:
        ``dx`` m, ``dt`` s, ``spinup_steps``, ``steps``, each when set).
    """
    from windnav.predict.train import DEFAULTS

    where = "training_envelope"
    meta = getattr(decoder_or_metadata, "metadata", decoder_or_metadata) or {}
    if not isinstance(meta, dict):
        # a file name met AttributeError 'get' (Python API audit, fifty-eighth session): the
        # caller holds the decoder it predicts with, so a path is not read here
        raise ValueError(f"The 'decoder_or_metadata' parameter of {where} must be a Decoder "
                         "or its metadata (a dict); load a decoder file with "
                         f"windnav.predict.load_decoder. Got {decoder_or_metadata!r} instead.")
    recipe = meta.get("recipe")
    source = "recipe" if isinstance(recipe, dict) and recipe else "defaults"
    recipe = recipe if source == "recipe" else {}
    for key in ("data", "sweep"):  # [1, 2] met a TypeError from dict()
        if not isinstance(recipe.get(key) or {}, dict):
            raise ValueError(f"The 'decoder_or_metadata' parameter of {where} must hold a "
                             f"recipe whose {key!r} is a table. Got {recipe[key]!r} instead.")
    data = {**copy.deepcopy(DEFAULTS["data"]), **dict(recipe.get("data") or {})}
    sweep = {**copy.deepcopy(DEFAULTS["sweep"]), **dict(recipe.get("sweep") or {})}
    return {
        "source": source,
        "scan_noise": float(data["scan_noise"]),
        "w_robot_noise": float(data["w_robot_noise"]),
        "wall_clearance": float(data["wall_clearance"]),
        "building_reach": float(data["building_reach"]),
        "label_spacing": float(data.get("spacing", meta.get("spacing", 1.0))),
        "speeds": [float(v) for v in (sweep.get("speeds") or DEFAULTS["sweep"]["speeds"])],
        "settings": dict(sweep.get("settings") or {}),
    }
