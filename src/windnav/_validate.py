"""Input validation shared by every public entry point.

Messages follow one form: ``"The 'name' parameter of where must be <rule>. Got <value> instead."``
so a user always learns which argument was wrong, the rule, and what was received.
"""

from __future__ import annotations

import contextlib
import math
import warnings
from collections.abc import Sequence

import numpy as np


class _Said(str):
    """A description of what was received ("shape (3, 1)"), shown as written, not quoted as
    a value would be."""

    def __repr__(self) -> str:
        return str(self)


def _fail(name: str, where: str, rule: str, got) -> ValueError:
    return ValueError(f"The {name!r} parameter of {where} must be {rule}. Got {got!r} instead.")


def positive_float(value, name: str, where: str, *, allow_zero: bool = False) -> float:
    """Return ``value`` as a finite float > 0 (or >= 0), else raise a named ValueError."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise _fail(name, where, "a number", value) from None
    if not math.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        raise _fail(name, where, "a finite number " + (">= 0" if allow_zero else "> 0"), value)
    return v


def finite_float(value, name: str, where: str) -> float:
    """Return ``value`` as a finite float, else raise a named ValueError."""
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise _fail(name, where, "a number", value) from None
    if not math.isfinite(v):
        raise _fail(name, where, "finite", value)
    return v


def generator(rng, name: str, where: str) -> np.random.Generator:
    """``rng`` itself when it is a ``numpy.random.Generator``, else ``default_rng(rng)`` (an
    integer seed >= 0, a SeedSequence, a sequence of seeds, or None for fresh entropy); a
    ValueError naming the argument for anything ``default_rng`` refuses."""
    if isinstance(rng, np.random.Generator):
        return rng
    if isinstance(rng, (bool, str, bytes)):
        raise _fail(name, where, "a numpy.random.Generator, an integer seed >= 0 or None", rng)
    try:
        return np.random.default_rng(rng)
    except (TypeError, ValueError):
        raise _fail(name, where, "a numpy.random.Generator, an integer seed >= 0 or None",
                    rng) from None


def nonnegative_int(value, name: str, where: str) -> int:
    """Return ``value`` as an int >= 0 (a seed, a count that may be none), else raise a named
    ValueError (NaN, inf, None, strings and bools included)."""
    try:
        ok = (not isinstance(value, (bool, str, bytes)) and int(value) == value
              and int(value) >= 0)
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok:
        raise _fail(name, where, "an integer >= 0", value)
    return int(value)


def speed_range(value, name: str, where: str) -> tuple[float, float]:
    """``(low, high)`` from two numbers with ``0 < low < high`` finite (a range of speeds, m/s),
    else a named ValueError."""
    try:
        lo, hi = (float(x) for x in value)
    except (TypeError, ValueError):
        raise _fail(name, where, "two numbers, m/s", value) from None
    if not 0 < lo < hi < math.inf:
        raise _fail(name, where, "0 < low < high, m/s", value)
    return lo, hi


def positive_int(value, name: str, where: str) -> int:
    """Return ``value`` as an int >= 1, else raise a named ValueError (NaN, inf, None and
    strings included)."""
    try:
        ok = (not isinstance(value, (bool, np.bool_, str, bytes)) and int(value) == value
              and value >= 1)
    except (TypeError, ValueError, OverflowError):
        ok = False
    if not ok:
        raise _fail(name, where, "an integer >= 1", value)
    return int(value)


def batch_array(
    value,
    name: str,
    where: str,
    trailing: Sequence[int],
    *,
    batch: int | None = None,
    finite: bool = True,
) -> np.ndarray:
    """Coerce to float64 of shape ``(B, *trailing)``; a single item gains a batch of one.

    Raises a ValueError naming ``name`` on a wrong shape, a batch size different from
    ``batch`` (when given), or NaN/inf entries (when ``finite``).
    """
    arr = np.asarray(value, dtype=np.float64)
    trailing = tuple(trailing)
    if arr.shape == trailing:
        arr = arr[None]
    if arr.ndim != len(trailing) + 1 or arr.shape[1:] != trailing:
        want = "(B, " + ", ".join(str(t) for t in trailing) + ")"
        raise _fail(name, where, f"an array of shape {want} or {trailing}",
                    _Said(f"shape {arr.shape}"))
    if batch is not None and arr.shape[0] != batch:
        raise _fail(name, where, f"a batch of {batch}",
                    _Said(f"a batch of {arr.shape[0]}"))
    if finite and not np.isfinite(arr).all():
        raise _fail(name, where, "finite (no NaN or inf)",
                    _Said("non-finite entries"))
    return arr


@contextlib.contextmanager
def options_named(names: dict[str, str]):
    """Re-raise a library's ValueError with its parameter names replaced by those the caller's
    user typed (``{"'max_speed' parameter of simulated_power_curve": "'--max-speed' parameter
    of windnav power-curve"}``; a library function naming its own parameters for a helper's
    alike); other errors pass unchanged."""
    try:
        yield
    except ValueError as exc:
        text = str(exc)
        for library, option in names.items():
            text = text.replace(library, option)
        if text == str(exc):
            raise
        raise ValueError(text) from None


def keyword_only(args: tuple, given: dict, where: str) -> dict:
    """The keyword-only parameters ``given`` (name -> keyword value, None when not given), with
    any passed positionally (``args``, in ``given``'s order) filled in and a DeprecationWarning:
    DESIGN's convention is a keyword-only ``rng``, and a public name changes only with a
    deprecation. A name given both ways, or too many positional values, is a TypeError, as
    Python's own."""
    if not args:
        return given
    names = list(given)
    if len(args) > len(names):
        raise TypeError(f"{where}() takes at most {len(names)} more positional argument(s) "
                        f"({', '.join(names)}, deprecated); got {len(args)}")
    out = dict(given)
    for name, value in zip(names, args, strict=False):
        if given[name] is not None:
            raise TypeError(f"{where}() got multiple values for argument {name!r}")
        out[name] = value
    used = names[:len(args)]
    warnings.warn(f"{where}: pass {', '.join(f'{n}=' for n in used)} by keyword; positional "
                  "use is deprecated", DeprecationWarning, stacklevel=3)
    return out


class ReadOnlyOnCopy:
    """Mixin: a pickled or deep-copied object's arrays are read-only where the original's were.

    NumPy restores every array writable, so a copy (a spawned worker's, ``copy.deepcopy``'s)
    lost the protection its class gives at construction: a copied ``FlowSolution`` took NaN
    frames past the finite check it had passed, and a copied ``Decoder``'s edited weights
    changed its fingerprint but not its predictions (pickling audit, thirty-seventh session).
    Covers array attributes and the arrays of dict attributes.
    """

    def __getstate__(self):
        state = dict(self.__dict__)
        frozen = []
        for name, value in state.items():
            if isinstance(value, np.ndarray) and not value.flags.writeable:
                frozen.append((name, None))
            elif isinstance(value, dict):
                frozen += [(name, key) for key, item in value.items()
                           if isinstance(item, np.ndarray) and not item.flags.writeable]
        state["_read_only_arrays"] = frozen
        return state

    def __setstate__(self, state):
        state = dict(state)
        frozen = state.pop("_read_only_arrays", ())
        self.__dict__.update(state)
        for name, key in frozen:
            value = self.__dict__[name]
            (value if key is None else value[key]).setflags(write=False)
