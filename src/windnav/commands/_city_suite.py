"""A navigation suite on a city of one's own: the pieces ``benchmark-nav --map``, ``nav-study
--map`` and ``windnav city --suite`` share.

``--map [NAME=]FILE`` makes the file's city the suite's one map, ``m00``, named NAME
(:func:`city_suite`); ``--pair-distance``, ``--edge`` and ``--clearance`` (:data:`CITY_RULE`,
since the fifty-second session) change the preset's start/goal rule for a city too small for
its 282 m pairs (:func:`city_rule`). A store records both in its suite's settings: the city by
:meth:`windnav.city.City.fingerprint`, the rule by value; on a store, a rule value given must be
the one it records (:func:`check_store_rule`).
"""

from __future__ import annotations

from windnav._validate import positive_float
from windnav.commands._common import map_argument, where

CITY_RULE = {"pair_distance": "--pair-distance", "edge": "--edge", "clearance": "--clearance"}
"""The start/goal rule options of a suite on a city of one's own (:class:`SuiteSpec` field:
option)."""


def suite_rule(spec) -> dict:
    """The start/goal rule of the suite ``spec`` (:data:`CITY_RULE` field: value, m), in that
    order: what ``--pair-distance``, ``--edge`` and ``--clearance`` set."""
    return {k: getattr(spec, k) for k in CITY_RULE}


def add_city_rule_arguments(parser) -> None:
    """``--pair-distance``, ``--edge``, ``--clearance``: the start/goal rule on ``--map``'s
    city (default: the suite's, 282 m, 25 m and 15 m for both presets)."""
    parser.add_argument("--pair-distance", type=float, default=None, metavar="M",
                        help="with --map: the distance from start to goal, m (default: the "
                             "suite's, 282; a new store only: a store keeps its own)")
    parser.add_argument("--edge", type=float, default=None, metavar="M",
                        help="with --map: the least distance from a start or goal to the "
                             "map's edge, m (default: the suite's, 25)")
    parser.add_argument("--clearance", type=float, default=None, metavar="M",
                        help="with --map: the least distance from a start or goal to a "
                             "building, m (default: the suite's, 15)")


def city_rule(args, name: str | None = None, *, city: bool | None = None) -> dict:
    """The rule options given (:data:`CITY_RULE` field: value as a float, m), checked: each a
    finite number, the distance > 0 and the others >= 0, and only with a city of one's own (a
    preset's planning maps keep the preset's rule: its stores and scenario ids are the
    preset's). ``name``: the command's, default ``where(args)`` (read only when an option is
    given); ``city``: whether the command has a city of one's own (default: ``--map`` is a
    file; nav-study's ``--map N``, an int, is a map index)."""
    rule = {}
    if city is None:
        city = isinstance(getattr(args, "map", None), str)
    for key, flag in CITY_RULE.items():
        value = getattr(args, key, None)
        if value is None:
            continue
        name = name or where(args)
        if not city:
            given = getattr(args, "map", None)
            had = (f"with --map {given}, a map index of the winds study" if given is not None
                   and "map" not in getattr(args, "filled_defaults", ()) else "without it")
            raise ValueError(f"The '{flag}' parameter of {name} sets the start/goal rule on a "
                             "city of your own, with --map [NAME=]FILE: a preset suite's "
                             f"planning maps keep its rule. Got {flag} {value!r} {had} "
                             "instead.")
        rule[key] = positive_float(value, flag, name, allow_zero=key != "pair_distance")
    return rule


def city_label(label: str, flag: str, name: str) -> str:
    """``label``, the suite name of a city (``NAME`` of ``NAME=FILE``, or the file's name):
    refused naming ``flag`` when it is a preset's or not a suite name (no ``/`` or white
    space: the first part of every scenario id)."""
    from windnav.experiments.nav_suite import SUITES, suite_name_ok

    if label in SUITES or not suite_name_ok(label):
        raise ValueError(f"The {flag!r} parameter of {name} must name its suite apart from "
                         f"{list(SUITES)}, without '/' or white space (the first part of every "
                         f"scenario id; NAME=FILE names it). Got the name {label!r} instead.")
    return label


def store_city(man: dict) -> str | None:
    """The city a store's manifest ``man`` records among its settings (``"City sha256:..."``,
    a store of ``--map``), None for a store of planning maps (or a malformed manifest)."""
    settings = man.get("settings")
    city = settings.get("city") if isinstance(settings, dict) else None
    return city if isinstance(city, str) else None


def city_suite(text: str, name: str, man: dict, *, suite: str | None,
               seed_value: int | None, store, rule: dict | None = None):
    """The suite of ``--map [NAME=]FILE`` (``text``): without ``suite``, the suite the
    manifest ``man`` of the store ``store`` records under NAME (``--suite`` not needed),
    whose city must be the file's (by :meth:`~windnav.city.City.fingerprint`); with it (a key
    of :data:`~windnav.experiments.nav_suite.SUITES`, for a new store), that suite's winds,
    start/goal rule and flight options on the file's city, its one map (``m00``), named NAME.
    The seed: ``seed_value``, else the store's, else 0. ``rule`` (:func:`city_rule`'s) sets
    the start/goal rule of a new store; on a store, each value must be the one it records."""
    from windnav.experiments.nav_suite import SUITES, SuiteSpec, get_suite

    label, path, city = map_argument(text, "--map", name)
    city_label(label, "--map", name)
    own = man.get("suite") == label
    if man.get("suite") is not None and not own:  # another suite's store: refused by name
        theirs = store_city(man)
        what = (f"the name of the suite it was flown as, {man.get('suite')!r}=FILE"
                if theirs is not None else "no --map: its suite flew planning maps")
        raise ValueError(f"The '--map' parameter of {name} must match the store "
                         f"{str(store)!r}: {what}. Got the name {label!r} instead.")
    value = seed_value if seed_value is not None else (man.get("seed", 0) if own else 0)
    settings = man.get("settings") if own else None
    mine = f"City sha256:{city.fingerprint()}"
    if isinstance(settings, dict) and settings.get("city") != mine:  # (with --suite too)
        raise ValueError(f"The '--map' parameter of {name} must name the map the store "
                         f"{str(store)!r} was flown on ({settings.get('city')}). Got "
                         f"{str(path)!r} instead ({mine}); another map needs a store of its "
                         "own.")
    if isinstance(settings, dict):
        check_store_rule(settings, rule or {}, suite, name, store)
    if suite is not None or not isinstance(settings, dict):
        if suite is None:
            raise ValueError(f"The '--suite' parameter of {name} must be given with --map "
                             f"without a store of that map: the suite whose winds and "
                             f"start/goal rule fly on it (one of {list(SUITES)}). Got None "
                             "instead.")
        return new_city_suite(get_suite(suite, seed=value), label, city, path, name, rule)
    options = {k: v for k, v in settings.items() if k != "city"}
    options["navigate_options"] = dict(options.get("navigate_options") or {})
    try:  # (its recorded decoder, a fingerprint, stays: with_decoder asks for the file)
        return SuiteSpec(name=label, seed=value, city=city, **options)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"The store {str(store)!r} of {name} must have a manifest this "
                         f"version reads: {exc}") from None


def check_store_rule(settings: dict, rule: dict, suite: str | None, name: str,
                     store) -> None:
    """Each rule value given (``rule``, :func:`city_rule`'s), and with ``--suite`` its preset's
    value of an option not given, must be the one the store's ``settings`` record: a store's
    rule is its own (another needs a store of its own). Every value that differs is named in
    one error, with the options that reproduce the store's rule, rather than the store being
    refused as another suite's."""
    from windnav.experiments.nav_suite import get_suite

    preset = get_suite(suite) if suite is not None else None
    wrong, flags, store_rule = [], [], []
    for key, flag in CITY_RULE.items():
        recorded = settings.get(key)
        store_rule.append(f"{flag} {recorded:g}" if isinstance(recorded, (int, float))
                          else f"{flag} {recorded!r}")
        if key in rule and rule[key] != recorded:
            wrong.append(f"{flag} {rule[key]:g} given")
        elif key not in rule and preset is not None and getattr(preset, key) != recorded:
            wrong.append(f"{flag} not given, so --suite {suite}'s {getattr(preset, key):g}")
        else:
            continue
        flags.append(flag)
    if wrong:
        raise ValueError(f"The '{flags[0]}' parameter of {name} must give the start/goal rule the "
                         f"store {str(store)!r} records, {', '.join(store_rule)} (read from its "
                         "manifest when --suite and the rule options are left out). Got "
                         f"{'; '.join(wrong)} instead; another rule needs a store of its own.")


def new_city_suite(base, label: str, city, path, name: str, rule: dict | None = None, *,
                   flag: str = "--map"):
    """``base``'s rule, with ``rule``'s values, on ``city``, named ``label``, its pairs drawn now
    (a map too small or too crowded for them is refused naming ``flag``, the map's option, and
    the rule options, before a store is made)."""
    import dataclasses

    from windnav.experiments.nav_suite import make_suite, rule_words

    rule = {k: float(v) for k, v in (rule or {}).items()}  # (an int would hash apart)
    want = {**suite_rule(base), **rule}
    try:
        spec = dataclasses.replace(base, name=label, maps=(0,), map_options={},
                                   map_size=float(max(city.size)), city=city, **rule)
        make_suite(spec)
    except ValueError as exc:
        given = " with " * bool(rule) + ", ".join(f"{CITY_RULE[k]} {v:g}" for k, v in rule.items())
        raise ValueError(f"The '{flag}' parameter of {name} must be a map that holds the "
                         f"start/goal pairs of the {base.name} suite{given} "
                         f"({rule_words(**want)}; {', '.join(CITY_RULE.values())} change "
                         f"them). Got {str(path)!r} instead: {exc}") from None
    return spec
