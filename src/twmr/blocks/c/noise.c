/* Seeded noise of N elements (twmr.blocks.Noise): sample k of element i is Philox-4x32-10 of the
 * counter (k, i) under the key SEED, made uniform (DIST_UNIFORM) or Gaussian by Box-Muller, held
 * over each sample period; the same integer operations as twmr.blocks.signal_kernels. */
#include <math.h>
#include <stdint.h>
#include "kernel.h"

enum { T0 = 0 };  /* work value: the time of sample 0 */

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

static double sample(const double *v, int64_t k, uint32_t i) {
    uint64_t seed = (uint64_t)SEED;
    uint32_t c[4];
    double r1;
    c[0] = (uint32_t)((uint64_t)k & 0xFFFFFFFFu);
    c[1] = (uint32_t)((uint64_t)k >> 32);
    c[2] = i;
    c[3] = 0;
    philox(c, (uint32_t)(seed & 0xFFFFFFFFu), (uint32_t)(seed >> 32));
    r1 = unit53(c[0], c[1]);
#if DIST == DIST_UNIFORM
    return v[V_mean] + v[V_stddev] * 1.7320508075688772 * (2.0 * r1 - 1.0);
#else
    return v[V_mean] + v[V_stddev] * (sqrt(-2.0 * log(1.0 - r1)) *
                                      cos(2.0 * 3.141592653589793 * unit53(c[2], c[3])));
#endif
}

static void fill(Model *m, int64_t k) {
    int i;
    for (i = 0; i < N; i++) m->v[V_y + i] = sample(m->v, k, (uint32_t)i);
}

void kernel_init(Model *m) {
    m->w[T0] = m->time;
    fill(m, 0);
}

void kernel_eval(Model *m) { (void)m; }

void kernel_step(Model *m, double t, double h) {
    double period = m->v[V_period] > 0.0 ? m->v[V_period] : h;
    /* SLACK = 1e-6 of signal_kernels: a time a rounding below k periods is sample k */
    fill(m, (int64_t)floor((t + h - m->w[T0]) / period + 1e-6));
}
