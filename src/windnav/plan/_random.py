"""Fast standard normals for the MPPI sampler (private Numba kernels).

NumPy's normals cost ~10 ns each on the project's CPU, a third of a 1000 x 25 planner update.
Here: the ziggurat method of Marsaglia & Tsang (2000, J. Stat. Softw. 5(8)), 128 layers, on the
SplitMix64 generator (Steele, Lea & Flood 2014; passes BigCrush). Unlike the paper's RNOR, the
layer index (low 7 bits) and the signed 32-bit value (high 32 bits) come from disjoint bits of
one 64-bit draw, which removes the correlation Doornik (2005) found in the original. The stream
is seeded from the caller's ``numpy.random.Generator`` once per call, so results are a pure
function of that generator's state. tests/test_mppi.py checks the distribution (moments, tail
mass beyond the ziggurat's base, Kolmogorov-Smirnov).
"""

from __future__ import annotations

import math

import numpy as np

from windnav._jit import njit

_R = 3.442619855899          # start of the tail
_V = 9.91256303526217e-3     # area of each layer
_M1 = 2147483648.0           # 2^31


def _tables() -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``kn`` (acceptance thresholds), ``wn`` (scales), ``fn`` (densities) of the 128 layers."""
    kn, wn, fn = np.zeros(128), np.zeros(128), np.zeros(128)
    dn = tn = _R
    q = _V / math.exp(-0.5 * dn * dn)
    kn[0] = (dn / q) * _M1
    wn[0] = q / _M1
    wn[127] = dn / _M1
    fn[0] = 1.0
    fn[127] = math.exp(-0.5 * dn * dn)
    for i in range(126, 0, -1):
        dn = math.sqrt(-2.0 * math.log(_V / dn + math.exp(-0.5 * dn * dn)))
        kn[i + 1] = (dn / tn) * _M1
        tn = dn
        fn[i] = math.exp(-0.5 * dn * dn)
        wn[i] = dn / _M1
    return kn, wn, fn


KN, WN, FN = _tables()

_GOLDEN = np.uint64(0x9E3779B97F4A7C15)
_MIX1 = np.uint64(0xBF58476D1CE4E5B9)
_MIX2 = np.uint64(0x94D049BB133111EB)
_S11, _S27, _S30, _S31, _S32 = (np.uint64(k) for k in (11, 27, 30, 31, 32))
_LOW7 = np.uint64(127)
_TWO_M53 = 2.0 ** -53


@njit(cache=True, inline="always")
def splitmix64(state):  # pragma: no cover - numba
    """Advance the state; return ``(state, 64 random bits)``."""
    state = state + _GOLDEN
    z = state
    z = (z ^ (z >> _S30)) * _MIX1
    z = (z ^ (z >> _S27)) * _MIX2
    return state, z ^ (z >> _S31)


@njit(cache=True, inline="always")
def uniform(state):  # pragma: no cover - numba
    """``(state, u)`` with ``u`` uniform in (0, 1) (53 bits, never 0 or 1)."""
    state, z = splitmix64(state)
    return state, (float(z >> _S11) + 0.5) * _TWO_M53


@njit(cache=True)
def _normal_slow(state, hz, iz, kn, wn, fn):  # pragma: no cover - numba
    """The ziggurat's rare path (about 1.2% of draws): the wedges and the tail."""
    while True:
        x = hz * wn[iz]
        if abs(hz) < kn[iz]:
            return state, x
        if iz == 0:  # the tail beyond R (Marsaglia 1964)
            while True:
                state, u1 = uniform(state)
                state, u2 = uniform(state)
                xt = -math.log(u1) / _R
                if -2.0 * math.log(u2) >= xt * xt:
                    break
            return state, (_R + xt) if hz > 0 else -(_R + xt)
        state, u = uniform(state)
        if fn[iz] + u * (fn[iz - 1] - fn[iz]) < math.exp(-0.5 * x * x):
            return state, x
        state, z = splitmix64(state)
        iz = np.int64(z & _LOW7)
        hz = np.int64(z >> _S32) - 2147483648


@njit(cache=True)
def fill_normal(seed, out, mean, sigma, lo, hi, kn, wn, fn):  # pragma: no cover - numba
    """``out[k, c, s] = clip(mean[k, c] + sigma z, lo, hi)`` with ``z`` standard normals
    (ziggurat) from the stream of ``seed`` (uint64), drawn in (k, c, s) order.

    ``out`` (K, C, S) may be float32. The fast path (97% of draws, one 64-bit draw each) is
    written out here: routed through an inlined helper with two exits, Numba's code was five
    times slower.
    """
    state = seed
    for k in range(out.shape[0]):
        for c in range(out.shape[1]):
            m = mean[k, c]
            row = out[k, c]
            for i in range(row.size):
                state, z = splitmix64(state)
                iz = np.int64(z & _LOW7)
                hz = np.int64(z >> _S32) - 2147483648
                if abs(hz) < kn[iz]:
                    x = hz * wn[iz]
                else:
                    state, x = _normal_slow(state, hz, iz, kn, wn, fn)
                row[i] = min(max(m + sigma * x, lo), hi)


def standard_normal(rng: np.random.Generator, n: int) -> np.ndarray:
    """``n`` standard normals from this module's stream, seeded by ``rng``."""
    out = np.empty((1, 1, n))
    fill_normal(rng.integers(0, 2**64, dtype=np.uint64), out, np.zeros((1, 1)), 1.0, -np.inf,
                np.inf, KN, WN, FN)
    return out.reshape(n)
