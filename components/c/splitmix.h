/* The sensors' noise generator, as components/_splitmix.py defines it (same bits): SplitMix64,
 * counter-based, and a standard normal by Box-Muller. */
#ifndef TWMR_SPLITMIX_H
#define TWMR_SPLITMIX_H

#include <math.h>
#include <stdint.h>

/* draw i (>= 1) of the SplitMix64 generator seeded with seed (whole numbers below 2^53) */
static uint64_t splitmix64(double seed, double i) {
    uint64_t z = (uint64_t)seed + (uint64_t)i * 0x9E3779B97F4A7C15ULL;
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    return z ^ (z >> 31);
}

/* sample k (>= 0) of the standard normal sequence of seed: draws 2k + 1 and 2k + 2 */
static double splitmix_normal(double seed, double k) {
    uint64_t a = splitmix64(seed, 2.0 * k + 1.0), b = splitmix64(seed, 2.0 * k + 2.0);
    double u1 = ((double)(a >> 11) + 1.0) * 0x1p-53, u2 = (double)(b >> 11) * 0x1p-53;
    return sqrt(-2.0 * log(u1)) * cos(2.0 * 3.141592653589793 * u2);
}

#endif
