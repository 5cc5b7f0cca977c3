"""The scenarios of the navigation benchmark (thesis ch. 5): maps x winds x start/goal pairs.

A :class:`SuiteSpec` is a frozen value that fixes everything a flight depends on: the maps
(:func:`windnav.city.planning_map`), the winds (inlet speeds x incidences), the start/goal
pairs, the wind simulation (spin-up, record, ``dx``, ``dt``) and the options of the closed loop
(:func:`windnav.experiments.navigate.navigate`). :func:`make_suite` expands it into
:class:`Scenario` values, deterministically from the suite's one ``seed``.

The ``thesis`` suite (:data:`SUITES`)
-------------------------------------
* 16 planning maps of 600 m x 600 m (9-16 stacked buildings of 10-50 m, alleys >= 15 m);
* 16 winds per map: inlet speeds {2, 5, 7, 10} m/s x incidences {0, 15, 30, 45} deg (the
  direction the wind blows toward, counter-clockwise from +x); wind ``w`` is speed
  ``w // 4`` and incidence ``w % 4`` (``w04`` is 5 m/s toward 0 deg);
* 25 s of spin-up, then 100 s of recorded frames, ``dt = 0.25`` s, ``dx = 1`` m;
* 4 start/goal pairs per wind, 282 m apart: pairs 0 and 1 are *tailwind* (the start-to-goal
  vector within 45 deg of the wind direction), pairs 2 and 3 *headwind* (within 45 deg of its
  opposite). The thesis gives no rule; ours: the angle is uniform in the 90 deg cone, the start
  uniform in the map, both points at least ``clearance = 15`` m from every building and
  ``edge = 25`` m inside the map (rejection sampling);
* 16 x 16 x 4 = 1,024 scenarios per variant.

The ``quick`` suite is a subset of the ``thesis`` suite: maps 0 and 1, winds ``w04`` (5 m/s,
0 deg) and ``w10`` (7 m/s, 30 deg), pairs 0 (tailwind) and 2 (headwind): 8 scenarios.

Identity and seeds
------------------
Scenario ``m``, ``w``, ``p`` of suite ``name`` has the id ``"{name}/m{m:02d}/w{w:02d}/p{p}"``.
Its seeds come from the suite seed and the suite-independent key ``"m03/w07/p2"`` by SHA-256
(:func:`derive_seed`): the map from ``"map/m03"``, the pairs of a wind from ``"m03/w07/pairs"``
(all pairs of a wind are drawn in order, so a subset draws the same points), the flight (the
planner's sampling and the LiDAR noise; the same for every variant, so variants are paired)
from ``"m03/w07/p2"``. A ``quick`` scenario is therefore the ``thesis`` scenario of the same
key, flown in the same wind with the same seed.
"""

from __future__ import annotations

import copy
import hashlib
import json
import math
import re
from dataclasses import asdict, dataclass, field, replace

import numpy as np

from windnav._validate import nonnegative_int, positive_float

__all__ = [
    "KINDS",
    "SUITES",
    "Scenario",
    "SuiteSpec",
    "derive_seed",
    "get_suite",
    "make_suite",
    "parse_scenario_id",
    "rule_words",
    "suite_map",
    "suite_name_ok",
    "wind_of",
]

KINDS = ("tailwind", "headwind")
"""Pair kinds: the start-to-goal vector along the wind, or against it."""

# ASCII digits, the whole string: "\d" took Arabic-Indic digits and "$" a trailing newline
_ID = re.compile(r"(?P<name>[^/\s]+)/m(?P<m>[0-9]+)/w(?P<w>[0-9]+)/p(?P<p>[0-9]+)")
_NAME = re.compile(r"[^/\s]+")


def suite_name_ok(name) -> bool:
    """Whether ``name`` can name a suite: a non-empty string without ``/`` or white space (the
    first part of every scenario id, :data:`_ID`)."""
    return isinstance(name, str) and _NAME.fullmatch(name) is not None


def _settings_value(obj) -> str:
    """How :meth:`SuiteSpec.settings` writes a value JSON has no form for: an object with a
    ``fingerprint()`` as its type and fingerprint, anything else as its ``str``."""
    fingerprint = getattr(obj, "fingerprint", None)
    if callable(fingerprint):
        return f"{type(obj).__name__} sha256:{fingerprint()}"
    return str(obj)


def rule_words(pair_distance: float, clearance: float, edge: float) -> str:
    """A suite's start/goal rule in words (m): ``"282 m apart, 15 m from the buildings, 25 m
    inside its edge"``."""
    return (f"{pair_distance:g} m apart, {clearance:g} m from the buildings, {edge:g} m inside "
            "its edge")


def derive_seed(seed: int, key: str) -> int:
    """A 32-bit seed from the suite ``seed`` and a string ``key``: SHA-256, first 4 bytes.

    Independent of the order in which scenarios are generated or flown, and of the platform.
    """
    digest = hashlib.sha256(f"{int(seed)}/{key}".encode()).digest()
    return int.from_bytes(digest[:4], "little")


MAP_SIZE_DEFAULT = 600.0
""":class:`SuiteSpec`'s ``map_size`` by default: the thesis's planning maps, m."""


@dataclass(frozen=True)
class SuiteSpec:
    """Everything a benchmark suite's flights depend on (a frozen value).

    Attributes
    ----------
    name : str
        Suite name, the first part of every scenario id (no ``/``).
    seed : int
        The one seed every map, pair and flight seed derives from (>= 0).
    maps : tuple of int
        Map indices flown.
    winds : tuple of int
        Wind indices flown: wind ``w`` is ``speeds[w // len(incidences_deg)]`` toward
        ``incidences_deg[w % len(incidences_deg)]``.
    pairs : tuple of int
        Pair indices flown: ``p < n_tailwind`` are tailwind pairs, the next ``n_headwind``
        headwind pairs.
    speeds : tuple of float
        Inlet speeds of the wind grid, m/s.
    incidences_deg : tuple of float
        Inlet directions of the wind grid (toward, counter-clockwise from +x), deg.
    n_tailwind, n_headwind : int
        Pairs drawn per wind of each kind.
    pair_distance : float
        Distance from start to goal, m.
    cone_deg : float
        Largest angle between the start-to-goal vector and the wind direction (tailwind) or its
        opposite (headwind), deg.
    clearance : float
        Smallest distance from a start or goal to any building, m.
    edge : float
        Smallest distance from a start or goal to the map's edge, m.
    map_size : float
        Side of the square planning maps, m.
    map_options : dict
        Further keyword arguments of :func:`windnav.city.planning_map` (small test suites).
    spinup_s, record_s : float
        Wind spin-up and recorded duration (the longest flight), s.
    dx, dt : float
        Flow grid spacing (m) and time step (s); frames are recorded every step.
    navigate_options : dict
        Further keyword arguments of :func:`windnav.experiments.navigate.navigate`
        (``capture_radius``, ``tilt_max_deg``, ``horizon``, ...); default: its defaults.
    city : City, optional
        A map of one's own (:class:`~windnav.city.City`, e.g. read from a RotorPy world JSON),
        flown as the suite's one map, ``m00``, instead of a :func:`~windnav.city.planning_map`:
        ``maps`` must then be ``(0,)`` and ``map_options`` empty, and the pairs are drawn
        inside the city's own bounds (``map_size`` draws nothing: it is set to the city's
        larger side, which the settings record; another value than that and the default is
        refused). In the settings by its
        :meth:`~windnav.city.City.fingerprint`; absent from them when None, so the suites
        without one keep their settings hash.
    """

    name: str
    seed: int = 0
    maps: tuple = tuple(range(16))
    winds: tuple = tuple(range(16))
    pairs: tuple = (0, 1, 2, 3)
    speeds: tuple = (2.0, 5.0, 7.0, 10.0)
    incidences_deg: tuple = (0.0, 15.0, 30.0, 45.0)
    n_tailwind: int = 2
    n_headwind: int = 2
    pair_distance: float = 282.0
    cone_deg: float = 45.0
    clearance: float = 15.0
    edge: float = 25.0
    map_size: float = 600.0  # MAP_SIZE_DEFAULT
    map_options: dict = field(default_factory=dict)
    spinup_s: float = 25.0
    record_s: float = 100.0
    dx: float = 1.0
    dt: float = 0.25
    navigate_options: dict = field(default_factory=dict)
    city: object = None

    def __post_init__(self):
        where = "SuiteSpec"
        if not suite_name_ok(self.name):
            raise ValueError(f"The 'name' parameter of {where} must be a non-empty string "
                             f"without '/' or white space (the first part of every scenario "
                             f"id). Got {self.name!r} instead.")
        object.__setattr__(self, "seed", nonnegative_int(self.seed, "seed", where))
        for name in ("speeds", "incidences_deg"):
            vals = tuple(float(v) for v in getattr(self, name))
            if not vals or not all(math.isfinite(v) for v in vals):
                raise ValueError(f"The {name!r} parameter of {where} must be a non-empty "
                                 f"sequence of finite numbers. Got {getattr(self, name)!r} "
                                 "instead.")
            object.__setattr__(self, name, vals)
        for v in self.speeds:
            positive_float(v, "speeds", where)
        for name in ("n_tailwind", "n_headwind"):
            nonnegative_int(getattr(self, name), name, where)
        n_winds = len(self.speeds) * len(self.incidences_deg)
        for name, count in (("maps", None), ("winds", n_winds),
                            ("pairs", self.n_tailwind + self.n_headwind)):
            vals = getattr(self, name)
            ok = (len(vals) > 0 and len(set(vals)) == len(vals)
                  and all(not isinstance(v, bool) and int(v) == v and 0 <= v for v in vals)
                  and (count is None or all(v < count for v in vals)))
            if not ok:
                rule = "distinct integers >= 0" + ("" if count is None else f" and < {count}")
                raise ValueError(f"The {name!r} parameter of {where} must be a non-empty "
                                 f"sequence of {rule}. Got {vals!r} instead.")
            object.__setattr__(self, name, tuple(int(v) for v in vals))
        # as floats: an int (pair_distance=180) wrote 180 into the settings, and its store
        # hashed apart from the same suite's with 180.0 (review, fifty-second session)
        for name in ("pair_distance", "map_size", "record_s", "dx", "dt"):
            object.__setattr__(self, name, positive_float(getattr(self, name), name, where))
        for name in ("clearance", "edge", "spinup_s"):
            object.__setattr__(self, name, positive_float(getattr(self, name), name, where,
                                                          allow_zero=True))
        if not 0.0 < float(self.cone_deg) <= 90.0:
            raise ValueError(f"The 'cone_deg' parameter of {where} must be in (0, 90]. "
                             f"Got {self.cone_deg!r} instead.")
        object.__setattr__(self, "cone_deg", float(self.cone_deg))
        if self.city is not None:
            self._check_city(where)
            # the city's larger side, as benchmark-nav --map records it: a suite built by hand
            # kept the preset's 600 m, and hashed apart from the command's for the same city
            side = float(max(self.city.size))
            if self.map_size not in (side, MAP_SIZE_DEFAULT):  # it was replaced, unsaid
                raise ValueError(f"The 'map_size' parameter of {where} draws nothing with a "
                                 f"city: it is the city's larger side, {side:g} m. Got "
                                 f"{self.map_size!r} instead; leave it out.")
            object.__setattr__(self, "map_size", side)
            x0, x1, y0, y1 = self.city.bounds
            width, depth = x1 - x0 - 2.0 * self.edge, y1 - y0 - 2.0 * self.edge
        else:
            width = depth = self.map_size - 2.0 * self.edge
        if min(width, depth) <= 0.0 or self.pair_distance >= math.hypot(width, depth):
            raise ValueError(f"The 'pair_distance' parameter of {where} must be shorter than "
                             f"the diagonal of the map inside its edge "
                             f"({math.hypot(max(width, 0.0), max(depth, 0.0)):g} m). Got "
                             f"{self.pair_distance!r} instead.")

    def _check_city(self, where: str) -> None:
        from windnav.city import City

        if not isinstance(self.city, City):
            raise ValueError(f"The 'city' parameter of {where} must be a City or None. Got "
                             f"{type(self.city).__name__} instead.")
        if self.maps != (0,) or self.map_options:
            raise ValueError(f"The 'maps' parameter of {where} must be (0,), without "
                             "map_options, when a city is given: the city is the suite's one "
                             f"map. Got maps {self.maps!r} and map_options "
                             f"{self.map_options!r} instead.")

    # -------------------------------------------------------------------------- identity

    def settings(self) -> dict:
        """Everything but the name and seed, JSON-ready (what the settings hash covers). An
        object among ``navigate_options`` with a ``fingerprint()`` (a decoder) is written as
        its fingerprint: its ``str`` is the same for every decoder of one architecture, so one
        store took the flights of two decoders as one suite's (audit, 2026-12-05)."""
        bare = self
        if self.city is not None:  # (a copy without it: asdict would take the City apart)
            bare = copy.copy(self)
            object.__setattr__(bare, "city", None)
        d = asdict(bare)
        d.pop("name")
        d.pop("seed")
        d.pop("city")
        if self.city is not None:
            d["city"] = _settings_value(self.city)
        return json.loads(json.dumps(d, sort_keys=True, default=_settings_value))

    def settings_hash(self) -> str:
        """SHA-256 (hex, 16 characters) of :meth:`settings` as canonical JSON."""
        text = json.dumps(self.settings(), sort_keys=True, separators=(",", ":"))
        return hashlib.sha256(text.encode()).hexdigest()[:16]

    def wind(self, w: int) -> tuple[float, float]:
        """``(speed m/s, direction_deg)`` of wind ``w``."""
        k = len(self.incidences_deg)
        return self.speeds[w // k], self.incidences_deg[w % k]

    def kind(self, p: int) -> str:
        """``"tailwind"`` or ``"headwind"``: the kind of pair ``p``."""
        return KINDS[0] if p < self.n_tailwind else KINDS[1]

    @property
    def n_scenarios(self) -> int:
        """Scenarios per variant."""
        return len(self.maps) * len(self.winds) * len(self.pairs)

    def flies(self, scenario_id: str) -> bool:
        """Whether ``scenario_id`` names one of this suite's scenarios (its name, and a map,
        wind and pair it flies); :func:`parse_scenario_id` says which part does not."""
        match = _ID.fullmatch(str(scenario_id))
        return (match is not None and match["name"] == self.name and int(match["m"]) in self.maps
                and int(match["w"]) in self.winds and int(match["p"]) in self.pairs)


SUITES = {
    "thesis": SuiteSpec("thesis"),
    "quick": SuiteSpec("quick", maps=(0, 1), winds=(4, 10), pairs=(0, 2)),
}
"""The named suites (seed 0); :func:`get_suite` gives them with another seed."""


def get_suite(name: str, seed: int = 0) -> SuiteSpec:
    """The named suite (a key of :data:`SUITES`) with the suite seed ``seed``."""
    if not isinstance(name, str) or name not in SUITES:  # a list was "unhashable"
        raise ValueError(f"The 'suite' parameter of get_suite must be one of {list(SUITES)}. "
                         f"Got {name!r} instead.")
    return replace(SUITES[name], seed=seed)


@dataclass(frozen=True)
class Scenario:
    """One flight of the suite, for every variant.

    Attributes
    ----------
    scenario_id : str
        ``"{suite}/m{map:02d}/w{wind:02d}/p{pair}"``.
    map_index, wind_index, pair_index : int
    kind : str
        ``"tailwind"`` or ``"headwind"``.
    speed : float
        Inlet wind speed, m/s.
    direction_deg : float
        Direction the wind blows toward, deg counter-clockwise from +x.
    start, goal : tuple of float
        ``(x, y)``, m, world.
    seed : int
        Seed of the flight (planner sampling and LiDAR noise), the same for every variant.
    """

    scenario_id: str
    map_index: int
    wind_index: int
    pair_index: int
    kind: str
    speed: float
    direction_deg: float
    start: tuple
    goal: tuple
    seed: int

    @property
    def group(self) -> tuple[int, int]:
        """``(map_index, wind_index)``: the scenarios that share one wind simulation."""
        return self.map_index, self.wind_index


def _key(m: int, w: int) -> str:
    return f"m{m:02d}/w{w:02d}"


def suite_map(spec: SuiteSpec, m: int):
    """Map ``m`` of the suite: :func:`windnav.city.planning_map` from its derived seed, or the
    suite's own ``city`` (its one map, ``m = 0``)."""
    from windnav.city import planning_map

    if spec.city is not None:
        if m != 0:
            raise ValueError(f"The 'm' parameter of suite_map must be 0 for the suite "
                             f"{spec.name!r}, whose one map is its city. Got {m!r} instead.")
        return spec.city
    return planning_map(rng=derive_seed(spec.seed, f"map/m{m:02d}"), size=spec.map_size,
                        **spec.map_options)


def clearance_to_buildings(city, points_xy) -> np.ndarray:
    """Distance from each point (B, 2) m to the nearest building footprint, (B,) m
    (0 inside one; inf in a map without buildings)."""
    p = np.asarray(points_xy, dtype=np.float64).reshape(-1, 2)
    fp = np.asarray(city.footprints, dtype=np.float64).reshape(-1, 4)
    if fp.shape[0] == 0:
        return np.full(p.shape[0], np.inf)
    dx = np.maximum(np.maximum(fp[None, :, 0] - p[:, None, 0], p[:, None, 0] - fp[None, :, 1]),
                    0.0)
    dy = np.maximum(np.maximum(fp[None, :, 2] - p[:, None, 1], p[:, None, 1] - fp[None, :, 3]),
                    0.0)
    return np.hypot(dx, dy).min(axis=1)


_BATCH = 512
_MAX_DRAWS = 200


def draw_pairs(spec: SuiteSpec, city, m: int, w: int) -> list[tuple[np.ndarray, np.ndarray]]:
    """All ``n_tailwind + n_headwind`` start/goal pairs of map ``m`` and wind ``w``, in order.

    Each pair: the angle of the start-to-goal vector uniform within ``cone_deg`` of the wind
    direction (tailwind) or its opposite (headwind), the start uniform in the map; candidates
    are drawn in batches of 512 from the pairs' derived generator and the first one with both
    points ``edge`` m inside the map and ``clearance`` m from every building is kept.

    Raises
    ------
    ValueError
        When 100,000 candidates hold no valid pair (a map too crowded for the rule).
    """
    rng = np.random.default_rng(derive_seed(spec.seed, f"{_key(m, w)}/pairs"))
    _, direction = spec.wind(w)
    x0, x1, y0, y1 = (float(b) for b in city.bounds)
    lo = np.array([x0 + spec.edge, y0 + spec.edge])
    hi = np.array([x1 - spec.edge, y1 - spec.edge])
    pairs = []
    for p in range(spec.n_tailwind + spec.n_headwind):
        base = direction + (0.0 if spec.kind(p) == "tailwind" else 180.0)
        for _ in range(_MAX_DRAWS):
            ang = np.radians(base + rng.uniform(-spec.cone_deg, spec.cone_deg, _BATCH))
            start = lo + (hi - lo) * rng.random((_BATCH, 2))
            goal = start + spec.pair_distance * np.stack([np.cos(ang), np.sin(ang)], axis=1)
            ok = np.all((goal >= lo) & (goal <= hi), axis=1)
            idx = np.flatnonzero(ok)
            if idx.size:
                clear = ((clearance_to_buildings(city, start[idx]) >= spec.clearance)
                         & (clearance_to_buildings(city, goal[idx]) >= spec.clearance))
                if clear.any():
                    k = int(idx[np.argmax(clear)])
                    pairs.append((start[k], goal[k]))
                    break
        else:
            raise ValueError(
                f"The 'spec' parameter of draw_pairs must allow a {spec.kind(p)} pair "
                f"{spec.pair_distance:g} m long, {spec.clearance:g} m clear of the buildings, on "
                f"map {m} with wind {w}. Got none in {_MAX_DRAWS * _BATCH} draws instead.")
    return pairs


def make_suite(spec: SuiteSpec, *, maps=None) -> list[Scenario]:
    """The suite's scenarios, ordered by map, wind, pair.

    Parameters
    ----------
    spec : SuiteSpec
    maps : dict of int to City, optional
        Maps already built (:func:`suite_map`), to skip rebuilding them.

    Returns
    -------
    list of Scenario
        ``spec.n_scenarios`` of them; the same for the same ``spec``.
    """
    spec = check_suite_spec(spec, "make_suite")  # a name is looked up (AttributeError before)
    out = []
    for m in spec.maps:
        city = (maps or {}).get(m) or suite_map(spec, m)
        for w in spec.winds:
            speed, direction = spec.wind(w)
            drawn = draw_pairs(spec, city, m, w)
            for p in spec.pairs:
                start, goal = drawn[p]
                key = f"{_key(m, w)}/p{p}"
                out.append(Scenario(
                    scenario_id=f"{spec.name}/{key}", map_index=m, wind_index=w, pair_index=p,
                    kind=spec.kind(p), speed=speed, direction_deg=direction,
                    start=(float(start[0]), float(start[1])),
                    goal=(float(goal[0]), float(goal[1])),
                    seed=derive_seed(spec.seed, key)))
    return out


def wind_of(scenario_id: str) -> str:
    """The (map, wind) that ``scenario_id`` belongs to, ``"thesis/m03/w07"`` for
    ``"thesis/m03/w07/p2"``: the four start and goal pairs of one wind share its field, so
    their flights are not independent. An id of another form is its own group."""
    match = _ID.fullmatch(str(scenario_id))
    return str(scenario_id) if match is None else \
        f"{match['name']}/m{match['m']}/w{match['w']}"


def parse_scenario_id(spec: SuiteSpec, scenario_id: str) -> Scenario:
    """The scenario of ``scenario_id`` (``"thesis/m03/w07/p2"``), checked against ``spec``.

    Raises
    ------
    ValueError
        On a malformed id, another suite's id, or indices the suite does not fly.
    """
    where = "parse_scenario_id"
    spec = check_suite_spec(spec, where)
    match = _ID.fullmatch(str(scenario_id))
    if match is None:
        raise ValueError(f"The 'scenario_id' parameter of {where} must look like "
                         f"'{spec.name}/m03/w07/p2'. Got {scenario_id!r} instead.")
    if match["name"] != spec.name:
        raise ValueError(f"The 'scenario_id' parameter of {where} must be a scenario of the "
                         f"suite {spec.name!r}. Got {scenario_id!r} instead.")
    m, w, p = int(match["m"]), int(match["w"]), int(match["p"])
    if not spec.flies(scenario_id):
        raise ValueError(f"The 'scenario_id' parameter of {where} must name a map in "
                         f"{list(spec.maps)}, a wind in {list(spec.winds)} and a pair in "
                         f"{list(spec.pairs)} of the suite {spec.name!r}. Got {scenario_id!r} "
                         "instead.")
    one = replace(spec, maps=(m,), winds=(w,), pairs=(p,))
    return make_suite(one)[0]


def check_suite_spec(spec, where: str) -> SuiteSpec:
    """``spec`` as a :class:`SuiteSpec` (a name of :data:`SUITES` is looked up)."""
    if isinstance(spec, str):
        return get_suite(spec)
    if not isinstance(spec, SuiteSpec):
        raise ValueError(f"The 'spec' parameter of {where} must be a SuiteSpec or one of "
                         f"{list(SUITES)}. Got {spec!r} instead.")
    return spec
