/* The one counter-based generator (twmr.blocks.philox): Philox-4x32-10 of the counter (k, i)
 * under the key `seed`, two uniform doubles in [0, 1) from it, and a standard normal by
 * Box-Muller; the same integer operations as the Python kernel functions. */
#ifndef TWMR_PHILOX_H
#define TWMR_PHILOX_H
#include <math.h>
#include <stdint.h>

static void philox(uint32_t c[4], uint32_t k0, uint32_t k1) {
    int r;
    for (r = 0; r < 10; r++) {
        uint64_t p0 = (uint64_t)0xD2511F53u * c[0], p1 = (uint64_t)0xCD9E8D57u * c[2];
        uint32_t n0 = (uint32_t)(p1 >> 32) ^ c[1] ^ k0, n2 = (uint32_t)(p0 >> 32) ^ c[3] ^ k1;
        c[0] = n0;
        c[1] = (uint32_t)p1;
        c[2] = n2;
        c[3] = (uint32_t)p0;
        k0 += 0x9E3779B9u;
        k1 += 0xBB67AE85u;
    }
}

static double unit53(uint32_t a, uint32_t b) {
    return (double)((uint64_t)(a >> 5) * 67108864u + (b >> 6)) * (1.0 / 9007199254740992.0);
}

/* r[0], r[1]: the two uniforms of draw k of stream i */
static void philox_draw(uint64_t seed, int64_t k, uint32_t i, double r[2]) {
    uint32_t c[4];
    c[0] = (uint32_t)((uint64_t)k & 0xFFFFFFFFu);
    c[1] = (uint32_t)((uint64_t)k >> 32);
    c[2] = i;
    c[3] = 0;
    philox(c, (uint32_t)(seed & 0xFFFFFFFFu), (uint32_t)(seed >> 32));
    r[0] = unit53(c[0], c[1]);
    r[1] = unit53(c[2], c[3]);
}

static double box_muller(double r1, double r2) {
    return sqrt(-2.0 * log(1.0 - r1)) * cos(2.0 * 3.141592653589793 * r2);
}

static double standard_normal(uint64_t seed, int64_t k, uint32_t i) {
    double r[2];
    philox_draw(seed, k, i, r);
    return box_muller(r[0], r[1]);
}
#endif
