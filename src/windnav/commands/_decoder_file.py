"""``--decoder FILE`` of the commands on the navigation benchmark's stores (``benchmark-nav``
since 2026-12-07, ``nav-study`` since the fiftieth session): the onboard stack
(``ea-mppi-w-hat`` without ``@decoder=``) flies that decoder file instead of the benchmark's
pinned one (:data:`windnav.experiments.nav_benchmark.BENCHMARK_DECODER`).

The decoder is part of the suite's settings (by its fingerprint: weights, architecture, rule),
so its flights go into a store of their own, and every command on that store needs the same
file again (:func:`with_decoder`). A result's JSON records the file's path and SHA-256, taken
when it was loaded (:func:`decoder_file`).
"""

from __future__ import annotations

from windnav.commands._common import options_named

DECODER_RULE = "blend"
"""The rule at the sector boundaries ``--decoder``'s file is flown with (``load_decoder``'s
default since 2026-12-06), pinned: it is part of the decoder's fingerprint in the store's
settings, which a change of the default would otherwise change under the same file."""

_LOADED: dict = {}
"""``--decoder``'s path -> ``{"path", "sha256"}`` of the file as it was last loaded in this
process (hashed then, not when a JSON is written hours of flights later)."""


def load(args, name: str):
    """``--decoder``'s file loaded under :data:`DECODER_RULE` and hashed, its errors naming the
    option."""
    from windnav.predict import load_decoder
    from windnav.predict.decoder import model_sha256

    with options_named({"'path' parameter of load_decoder": f"'--decoder' parameter of {name}"}):
        decoder = load_decoder(args.decoder, boundary=DECODER_RULE)
    _LOADED[str(args.decoder)] = {"path": str(args.decoder), "sha256": model_sha256(args.decoder)}
    return decoder


def load_files(files, flag: str, name: str, **kwargs):
    """The decoder ``files`` (a mapping of names to files, or a sequence of files; None: the
    shipped decoder) loaded now with ``kwargs`` (:func:`windnav.predict.load_decoder`'s), so
    that a file that is no decoder is refused before any work, naming ``flag`` (a text file
    given to ``decoder-study gradients --model`` was read only after minutes of flows, and
    named load_decoder's 'path': CLI audit). The same mapping or list, of Decoders."""
    from windnav.predict import load_decoder

    with options_named({"'path' parameter of load_decoder": f"'{flag}' parameter of {name}"}):
        if isinstance(files, dict):
            return {key: load_decoder(file, **kwargs) for key, file in files.items()}
        return [load_decoder(file, **kwargs) for file in files]


def decoder_file(args) -> dict:
    """``{"decoder_file": {"path", "sha256"}}`` of ``--decoder`` as :func:`load` read it (to
    merge into a result's JSON), or ``{}`` when the option is not given."""
    if getattr(args, "decoder", None) is None:
        return {}
    return {"decoder_file": _LOADED[str(args.decoder)]}


def store_decoder(man: dict, spec) -> tuple[bool, str | None]:
    """Of a store's manifest ``man`` (of the suite ``spec``; another suite's, or a malformed
    one, reads as none): whether it records ``navigate_options`` at all, and the decoder among
    them (``"Decoder sha256:<fingerprint>"``), None where the store flew the pinned one."""
    settings = man.get("settings") if man.get("suite") == spec.name else None
    options = settings.get("navigate_options") if isinstance(settings, dict) else None
    if not isinstance(options, dict):
        return False, None
    return True, options.get("decoder")


def with_decoder(args, name: str, spec, man: dict):
    """``spec`` whose onboard stack flies ``--decoder`` (a ``decoder`` among its
    ``navigate_options``, in its settings by fingerprint); a ValueError naming the option where
    the store ``man`` describes (its manifest, of this suite) was flown with another decoder
    object, or without one."""
    import dataclasses

    known, recorded = store_decoder(man, spec)
    if args.decoder is None:
        if recorded is not None:
            raise ValueError(f"The '--decoder' parameter of {name} must name the decoder file "
                             f"that the store {str(args_store(args))!r} was flown with "
                             f"({recorded}). Got None instead.")
        return spec
    flown = dataclasses.replace(spec, navigate_options={**spec.navigate_options,
                                                        "decoder": load(args, name)})
    mine = flown.settings()["navigate_options"]["decoder"]  # "Decoder sha256:<fingerprint>"
    if known and recorded != mine:  # (a malformed one: NavStore says so)
        theirs = ("the benchmark's pinned decoder" if recorded is None
                  else f"another decoder ({recorded})")
        raise ValueError(f"The '--decoder' parameter of {name} must name the decoder the store "
                         f"{str(args_store(args))!r} was flown with: {theirs}. Got "
                         f"{str(args.decoder)!r} instead ({mine}); a decoder's flights need a "
                         "store of their own.")
    return flown


def args_store(args):
    """The store folder of the command line: ``benchmark-nav``'s ``--out``, ``nav-study``'s
    ``--store``."""
    store = getattr(args, "store", None)
    return store if store is not None else getattr(args, "out", None)


def decoder_labels(labels, name: str) -> tuple[list[str], bool]:
    """Of the variant ``labels``: those that ask the turned views of the benchmark's pinned
    decoder (``@views=`` without ``@decoder=``), whose flights with ``--decoder`` would not fly
    its file (each recorded as an error by :func:`windnav.experiments.nav_benchmark.fly`), and
    whether any flies the suite's own decoder object (the onboard stack without
    ``@decoder=``)."""
    from windnav.experiments.nav_benchmark import parse_variant
    from windnav.plan import VARIANTS

    views, flies = [], False
    for label in labels:
        base, options = parse_variant(label, name)
        if "decoder" in options:
            continue
        views += [label] if "decoder_views" in options else []
        flies = flies or VARIANTS[base].wind_source == "onboard"
    return views, flies


def refuse_other_views(args, name: str, labels, flag: str) -> None:
    """With ``--decoder``, a ValueError naming ``flag`` for labels asking the turned views of
    the benchmark's pinned decoder (:func:`decoder_labels`)."""
    if args.decoder is None:
        return
    with options_named({f"'variants' parameter of {name}": f"'{flag}' parameter of {name}"}):
        views, _ = decoder_labels(labels, name)
    if views:
        raise ValueError(f"The '{flag}' parameter of {name} must not ask, with --decoder, the "
                         "turned views of the benchmark's pinned decoder ('@views=' without "
                         "'@decoder='): the flight would not fly --decoder's file. Got "
                         f"{', '.join(views)} instead.")
