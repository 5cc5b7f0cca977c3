"""Which floating-point arithmetic a process computes with, and how to pin another one.

A closed-loop flight is bit-reproducible on one machine, but two libraries pick their code by
CPU at load time and round float results differently in the last bits, which a flight can
amplify into another flight (``docs/navigation.md``, "Replays across CPUs"):

* **NumPy's BLAS** (OpenBLAS in the wheels): its kernels, e.g. ``Haswell`` on a CPU with AVX2,
  ``SkylakeX`` on one with AVX-512 (:func:`blas_kernel`). ``OPENBLAS_CORETYPE`` picks another
  one, if the CPU can run it.
* **NumPy's SIMD loops** (e.g. ``exp`` on float64 has AVX2 and AVX-512 versions): the dispatch
  targets in use (:func:`numpy_simd`, e.g. ``"X86_V3"``). ``NPY_DISABLE_CPU_FEATURES`` turns the
  higher ones off.

Both set when a process starts, so pinning them means a new process:
:func:`pinned_environment` gives the environment under which a process computes as a record's
did (checked by starting one), :func:`portable_environment` the one every x86-64 CPU with AVX2
can run (``windnav benchmark-nav --portable``). Numba's kernels are compiled for the host CPU
without reassociation; they are not pinned here.
"""

from __future__ import annotations

import contextlib
import functools
import os
import subprocess
import sys

__all__ = [
    "FIELDS",
    "PIN_VARIABLE",
    "PORTABLE",
    "arithmetic",
    "blas_kernel",
    "numpy_simd",
    "pinned_environment",
    "portable_environment",
    "process_environment",
]

FIELDS = ("blas_kernel", "numpy_simd")
"""The fields that name an arithmetic, in a flight record and in :func:`arithmetic`."""

PIN_VARIABLE = "WINDNAV_ARITHMETIC_PINNED"
"""Set (to ``"1"``) in a process started under a pinned arithmetic, so that it does not start
another."""

PORTABLE = {"blas_kernel": "OpenBLAS Haswell", "numpy_simd": "X86_V3"}
"""The arithmetic every x86-64 CPU with AVX2 and FMA can run (Intel since 2013, every AMD Zen):
OpenBLAS's ``Haswell`` kernels and NumPy's ``X86_V3`` loops."""


@functools.cache
def blas_kernel() -> str | None:
    """The kernel NumPy's BLAS runs on this machine, e.g. ``"OpenBLAS Haswell"``
    (:func:`threadpoolctl.threadpool_info`); None when no BLAS is found.

    OpenBLAS picks its kernels by CPU at load time (``OPENBLAS_CORETYPE`` overrides): an Intel
    Xeon with AVX-512 and an AMD EPYC with AVX2 round float products differently in the last
    bits. Read once per process.
    """
    import numpy as np
    from threadpoolctl import threadpool_info

    libs = os.path.join(os.path.dirname(os.path.dirname(np.__file__)), "numpy.libs")
    blas = [lib for lib in threadpool_info() if lib["user_api"] == "blas"]
    # NumPy's own BLAS (its wheel's), before SciPy's (they may differ), else the first found
    if not blas:
        return None
    lib = min(blas, key=lambda lib: not lib["filepath"].startswith(libs))
    name = {"openblas": "OpenBLAS", "mkl": "MKL", "blis": "BLIS"}.get(lib["internal_api"],
                                                                    lib["internal_api"])
    return f"{name} {lib.get('architecture') or 'unknown'}"


def _dispatch() -> tuple[tuple[str, ...], dict]:
    """NumPy's SIMD dispatch targets (lowest first) and its CPU features (True when usable:
    on this CPU and not disabled by ``NPY_DISABLE_CPU_FEATURES``)."""
    from numpy._core._multiarray_umath import __cpu_dispatch__, __cpu_features__

    return tuple(__cpu_dispatch__), dict(__cpu_features__)


@functools.cache
def numpy_simd() -> str | None:
    """NumPy's SIMD dispatch targets in use in this process, space-separated, e.g. ``"X86_V3"``
    on a CPU with AVX2, ``"X86_V3 X86_V4 AVX512_ICL"`` on an Ice Lake; ``"baseline"`` when none
    is; None when this NumPy does not say. Read once per process."""
    try:
        targets, features = _dispatch()
    except ImportError:  # a NumPy without the introspection
        return None
    return " ".join(t for t in targets if features.get(t)) or "baseline"


def arithmetic() -> dict:
    """This process's arithmetic as a flight record stores it: ``blas_kernel`` and
    ``numpy_simd``."""
    return dict(zip(FIELDS, (blas_kernel(), numpy_simd()), strict=True))


def _targets(simd: str | None) -> set:
    return set() if simd in (None, "baseline") else set(simd.split())


def _environment(want: dict) -> tuple[dict, str]:
    """The variables that turn this process's arithmetic into ``want``'s (empty when it is
    already), or ``({}, why not)``, before any check."""
    env, now = {}, arithmetic()
    kernel = want.get("blas_kernel")
    if kernel is not None and kernel != now["blas_kernel"]:
        if not kernel.startswith("OpenBLAS ") or not (now["blas_kernel"] or "").startswith(
                "OpenBLAS "):
            return {}, f"only OpenBLAS kernels can be pinned (the record's: {kernel})"
        env["OPENBLAS_CORETYPE"] = kernel.split(" ", 1)[1]
    simd = want.get("numpy_simd")
    if simd is not None and now["numpy_simd"] is not None and simd != now["numpy_simd"]:
        targets, features = _dispatch()
        if _targets(simd) - _targets(now["numpy_simd"]):
            return {}, (f"this CPU cannot run NumPy's SIMD targets {simd!r} (it has "
                        f"{now['numpy_simd']!r})")
        higher = [t for t in targets if features.get(t) and t not in _targets(simd)]
        old = os.environ.get("NPY_DISABLE_CPU_FEATURES", "").replace(",", " ").split()
        env["NPY_DISABLE_CPU_FEATURES"] = " ".join(dict.fromkeys(old + higher))
    return env, ""


def _probe(env: dict) -> dict | None:
    """The arithmetic a new Python process reports under ``env`` (None when it fails, e.g.
    with an illegal instruction: OpenBLAS told to use kernels the CPU lacks)."""
    code = ("import json; from windnav.experiments.arithmetic import arithmetic; "
            "import numpy as np; a = np.ones((64, 64)); a @ a; print(json.dumps(arithmetic()))")
    try:
        out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                             env={**os.environ, **env}, timeout=120)
    except (OSError, subprocess.SubprocessError):
        return None
    if out.returncode != 0:
        return None
    import json

    try:
        return json.loads(out.stdout.strip().splitlines()[-1])
    except (ValueError, IndexError):
        return None


def _lacking(simd: str | None) -> list[str]:
    """The NumPy SIMD targets of ``simd`` this process cannot use (its CPU lacks them, or
    ``NPY_DISABLE_CPU_FEATURES`` turned them off), in ``simd``'s order."""
    now = numpy_simd()
    if simd in (None, "baseline") or now is None:
        return []
    return [t for t in simd.split() if t not in _targets(now)]


def pinned_environment(recorded: dict, *, nearest: bool = False) -> tuple[dict | None, str]:
    """The environment under which a new process computes as the flight ``recorded`` did.

    Parameters
    ----------
    recorded : dict
        A flight record, or any mapping with the :data:`FIELDS` it knows.
    nearest : bool, default False
        When the record names NumPy SIMD targets this machine cannot run (an Intel Xeon's
        ``AVX512_SPR`` on an AMD EPYC with AVX-512), pin the rest of its arithmetic (the BLAS
        kernel and the targets it can run) instead of none of it, and say so in the line.
        Whether those targets took part in the flight shows only when it is flown again: a
        replay or a check compares. (NumPy builds its ``AVX512_SPR`` code for 16-bit types,
        its ``float16`` sort among them, and the onboard stack's records of 2026-12-05 flown on
        such a Xeon replayed to the bit without it, ``docs/navigation.md``.)

    Returns
    -------
    env : dict or None
        The variables to add to ``os.environ`` (``{}`` when this process already computes so),
        or None when it cannot be pinned on this machine.
    line : str
        Which arithmetic, or why not.

    A record without the fields (flown before 2026-12-02, or flown before ``numpy_simd`` was
    recorded) pins only what it names. The pin is checked by starting a process under it (a
    second or so).
    """
    want = {k: recorded.get(k) for k in FIELDS}
    named = ", ".join(f"{k} {v!r}" for k, v in want.items() if v is not None)
    lacking = _lacking(want["numpy_simd"]) if nearest else []
    if lacking:
        kept = [t for t in want["numpy_simd"].split() if t not in lacking]
        want["numpy_simd"] = " ".join(kept) or "baseline"
        named += (f", without NumPy's {' '.join(lacking)} loops, which this machine cannot run "
                  "(the nearest arithmetic it can)")
    env, why = _environment(want)
    if why:
        return None, why
    if not env:
        return {}, named
    got = _probe(env)
    if got is None or any(v is not None and got[k] != v for k, v in want.items()):
        return None, (f"this CPU cannot run the record's arithmetic ({named}): a process "
                      f"under {env} " + ("failed" if got is None else f"reports {got}"))
    return env, named


@contextlib.contextmanager
def process_environment(env: dict):
    """``os.environ`` with ``env`` added inside the block and restored after it.

    The processes started in the block (a process pool's workers) compute under the arithmetic
    that ``env`` pins (:func:`pinned_environment`); this process keeps its own, read when its
    libraries loaded.
    """
    saved = {k: os.environ.get(k) for k in env}
    os.environ.update({k: str(v) for k, v in env.items()})
    try:
        yield
    finally:
        for k, v in saved.items():
            if v is None:
                os.environ.pop(k, None)
            else:
                os.environ[k] = v


def portable_environment() -> tuple[dict | None, str]:
    """The environment of :data:`PORTABLE` on this machine (``{}`` when it computes so
    already), or ``(None, why not)``; as :func:`pinned_environment`."""
    env, line = pinned_environment(PORTABLE)
    if env is None:
        return None, f"this machine cannot run the portable arithmetic: {line}"
    return env, line
