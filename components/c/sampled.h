/* When a sampled sensor's sample is due, as components/_sampled.py defines it. */
#ifndef TWMR_SAMPLED_H
#define TWMR_SAMPLED_H

/* a time has passed since the last sample at t_last [s] (NAN: none yet), and at least period */
static int sample_due(double t, double t_last, double period) {
    double dt = t - t_last;
    return dt > 0.0 && dt >= period * (1.0 - 1e-9);
}

#endif
