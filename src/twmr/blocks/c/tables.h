/* Breakpoint tables (twmr.blocks.tables): the interval search and the linear interpolation of
 * table, lookup_1d and lookup_2d. EXTRAP_HOLD, EXTRAP_LINEAR, EXTRAP_ERROR come from config.h. */
#ifndef TWMR_TABLES_H
#define TWMR_TABLES_H

#include <math.h>

/* the largest i in [0, n - 2] with bp[i] <= u (0 below bp[0]), by bisection */
static int interval(const double *bp, int n, double u) {
    int lo = 0, hi = n - 1;
    while (hi - lo > 1) {
        int mid = (lo + hi) / 2;
        if (bp[mid] <= u) lo = mid;
        else hi = mid;
    }
    return lo;
}

/* the segment i of u and its fraction *s, u held, the ends extended or *s = NaN outside */
static int segment(const double *bp, int n, double u, int extrapolation, double *s) {
    double first = bp[0], last = bp[n - 1];
    int i;
    if (extrapolation == EXTRAP_HOLD) {
        u = u < first ? first : (u > last ? last : u);
    } else if (extrapolation == EXTRAP_ERROR && (u < first || u > last)) {
        *s = NAN;
        return 0;
    }
    i = interval(bp, n, u);
    *s = (u - bp[i]) / (bp[i + 1] - bp[i]);
    return i;
}

static double interp1(const double *bp, const double *values, int n, double u,
                      int extrapolation) {
    double s;
    int i = segment(bp, n, u, extrapolation, &s);
    return values[i] + (values[i + 1] - values[i]) * s;
}

/* bilinear in values[i * m + j] at (bx[i], by[j]): along y in rows i and i + 1, then along x */
static double interp2(const double *bx, int nx, const double *by, int m, const double *values,
                      double u1, double u2, int extrapolation) {
    double sx, sy, a, b;
    int i = segment(bx, nx, u1, extrapolation, &sx);
    int j = segment(by, m, u2, extrapolation, &sy);
    a = values[i * m + j] + (values[i * m + j + 1] - values[i * m + j]) * sy;
    b = values[(i + 1) * m + j] + (values[(i + 1) * m + j + 1] - values[(i + 1) * m + j]) * sy;
    return a + (b - a) * sx;
}

#endif
