"""The one counter-based random generator of the blocks and sensors: Philox-4x32-10 (Salmon et
al., SC'11) in integer operations that give the same bits in plain Python, compiled by numba
(int64, products wrapping and masked to 32 bits) and in C (c/philox.h, uint32_t / uint64_t).
Draw (k, i) of a seed depends on nothing else, so a sequence does not depend on the step.
"""
from __future__ import annotations

import math

from twmr.core.kernel import kernel_function

M32 = 0xFFFFFFFF
#: Philox-4x32 multipliers and Weyl key increments
PHILOX_M0, PHILOX_M1 = 0xD2511F53, 0xCD9E8D57
PHILOX_W0, PHILOX_W1 = 0x9E3779B9, 0xBB67AE85


@kernel_function
def philox(c0: int, c1: int, c2: int, c3: int, k0: int, k1: int) -> tuple[int, int, int, int]:
    """Philox-4x32-10 of the counter (c0, c1, c2, c3) under the key (k0, k1), 32-bit words."""
    for _ in range(10):
        p0 = PHILOX_M0 * c0
        p1 = PHILOX_M1 * c2
        c0, c1, c2, c3 = (((p1 >> 32) & M32) ^ c1 ^ k0, p1 & M32,
                          ((p0 >> 32) & M32) ^ c3 ^ k1, p0 & M32)
        k0 = (k0 + PHILOX_W0) & M32
        k1 = (k1 + PHILOX_W1) & M32
    return c0, c1, c2, c3


@kernel_function
def unit53(a: int, b: int) -> float:
    """A double in [0, 1) from two 32-bit words: 53 random bits times 2^-53 (exact)."""
    return float((a >> 5) * 67108864 + (b >> 6)) * (1.0 / 9007199254740992.0)


@kernel_function
def draw(seed: int, k: int, i: int) -> tuple[float, float]:
    """Two uniform doubles in [0, 1) of draw k of stream i: Philox of the counter (k, i) under
    the key `seed` (a whole number in [0, 2^63))."""
    w0, w1, w2, w3 = philox(k & M32, (k >> 32) & M32, i, 0, seed & M32, (seed >> 32) & M32)
    return unit53(w0, w1), unit53(w2, w3)


@kernel_function
def box_muller(r1: float, r2: float) -> float:
    """A standard normal sample from two uniforms in [0, 1): sqrt(-2 ln(1 - r1)) cos(2 pi r2)."""
    return math.sqrt(-2.0 * math.log(1.0 - r1)) * math.cos(2.0 * math.pi * r2)


@kernel_function
def standard_normal(seed: int, k: int, i: int) -> float:
    """Sample k of the standard normal sequence i of `seed`."""
    r1, r2 = draw(seed, k, i)
    return box_muller(r1, r2)
