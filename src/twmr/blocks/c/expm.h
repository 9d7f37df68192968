/* exp(M) of an EXPM_N square matrix (row-major) by scaling and squaring of a Taylor series, to
 * double precision for the matrices the linear blocks hold; #define EXPM_N before including. */
#include <math.h>
#include <string.h>

static void matmul(const double *a, const double *b, double *out) {
    double r[EXPM_N * EXPM_N];
    int i, j, k;
    for (i = 0; i < EXPM_N; i++)
        for (j = 0; j < EXPM_N; j++) {
            double s = 0.0;
            for (k = 0; k < EXPM_N; k++) s += a[i * EXPM_N + k] * b[k * EXPM_N + j];
            r[i * EXPM_N + j] = s;
        }
    memcpy(out, r, sizeof r);
}

static void expm(const double *M, double *E) {
    double S[EXPM_N * EXPM_N], T[EXPM_N * EXPM_N], norm = 0.0;
    int i, j, q, squarings = 0;
    for (i = 0; i < EXPM_N; i++) {  /* infinity norm */
        double row = 0.0;
        for (j = 0; j < EXPM_N; j++) row += fabs(M[i * EXPM_N + j]);
        norm = fmax(norm, row);
    }
    while (norm > 0.125) {
        norm /= 2.0;
        squarings++;
    }
    for (i = 0; i < EXPM_N * EXPM_N; i++) S[i] = ldexp(M[i], -squarings);
    memset(E, 0, sizeof S);
    memset(T, 0, sizeof T);
    for (i = 0; i < EXPM_N; i++) E[i * EXPM_N + i] = T[i * EXPM_N + i] = 1.0;
    for (q = 1; q <= 18; q++) {  /* ||S|| <= 1/8: the term 18 is below 1e-35 */
        matmul(T, S, T);
        for (i = 0; i < EXPM_N * EXPM_N; i++) {
            T[i] /= q;
            E[i] += T[i];
        }
    }
    for (i = 0; i < squarings; i++) matmul(E, E, E);
}
