"""The sensors' noise generator: SplitMix64 (Steele, Lea & Flood 2014; Vigna's reference code),
counter-based, and a standard normal by Box-Muller. Its C twin is c/splitmix.h; the two give the
same bits. Compiled by numba in Python runs too (64-bit wrap-around arithmetic).

Draw i of seed s (i = 1, 2, ...) is the i-th output of a SplitMix64 generator seeded with s:
    z = s + i * 0x9E3779B97F4A7C15 (mod 2^64)
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9;  z = (z ^ (z >> 27)) * 0x94D049BB133111EB
    draw = z ^ (z >> 31)
Sample k (k = 0, 1, ...) of the normal sequence uses draws 2k + 1 and 2k + 2:
    u1 = ((a >> 11) + 1) 2^-53 in (0, 1],  u2 = (b >> 11) 2^-53 in [0, 1)
    n_k = sqrt(-2 ln u1) cos(2 pi u2)
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

GAMMA = np.uint64(0x9E3779B97F4A7C15)
MIX1 = np.uint64(0xBF58476D1CE4E5B9)
MIX2 = np.uint64(0x94D049BB133111EB)
_S30, _S27, _S31, _S11 = np.uint64(30), np.uint64(27), np.uint64(31), np.uint64(11)
_ONE = np.uint64(1)
ULP53 = 2.0 ** -53


@njit(cache=True)
def splitmix64(seed: float, i: float) -> np.uint64:
    """Draw i (a whole number >= 1) of the SplitMix64 generator seeded with `seed` (a whole
    number in [0, 2^53))."""
    z = np.uint64(seed) + np.uint64(i) * GAMMA
    z = (z ^ (z >> _S30)) * MIX1
    z = (z ^ (z >> _S27)) * MIX2
    return z ^ (z >> _S31)


@njit(cache=True)
def splitmix_normal(seed: float, k: float) -> float:
    """Sample k (a whole number >= 0) of the standard normal sequence of `seed` (Box-Muller)."""
    a = splitmix64(seed, 2.0 * k + 1.0)
    b = splitmix64(seed, 2.0 * k + 2.0)
    u1 = (float(a >> _S11) + 1.0) * ULP53
    u2 = float(b >> _S11) * ULP53
    return math.sqrt(-2.0 * math.log(u1)) * math.cos(2.0 * math.pi * u2)
