/* Seeded noise of N elements (twmr.blocks.Noise): sample k of element i is Philox-4x32-10 of the
 * counter (k, i) under the key SEED (philox.h), made uniform (DIST_UNIFORM) or Gaussian by Box-Muller, held
 * over each sample period; the same integer operations as twmr.blocks.signal_kernels. */
#include <math.h>
#include <stdint.h>
#include "kernel.h"
#include "philox.h"

enum { T0 = 0 };  /* work value: the time of sample 0 */

static double sample(const double *v, int64_t k, uint32_t i) {
    double r[2];
    philox_draw((uint64_t)SEED, k, i, r);
#if DIST == DIST_UNIFORM
    return v[V_mean] + v[V_stddev] * 1.7320508075688772 * (2.0 * r[0] - 1.0);
#else
    return v[V_mean] + v[V_stddev] * box_muller(r[0], r[1]);
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
