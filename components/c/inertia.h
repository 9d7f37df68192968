/* The inertia of eq. (8) as components/_model.inertia computes it (same order of operations),
 * shared by the C twins of the plant and of the controllers. */
#ifndef TWMR_INERTIA_H
#define TWMR_INERTIA_H

/* (m11, m12, q1, q2) of eq. (8), exactly as printed (m11 with 2 m_W r^2): out[0..3]. */
static void inertia(double a, double I_G, double I_D, double I_W, double r, double b,
                    double m_W, double m_G, double *out) {
    double k = r * r / (4.0 * b * b);
    out[0] = m_G * (r * r / 4.0 + a * a * r * r / (4.0 * b * b)) + k * (I_G + 2.0 * I_D)
             + 2.0 * m_W * r * r + I_W;
    out[1] = m_G * (r * r / 4.0 - a * a * r * r / (4.0 * b * b)) - k * (I_G + 2.0 * I_D);
    out[2] = m_G * r / 4.0 * (1.0 + a * a / (b * b)) + r / (4.0 * b) * (I_G + 2.0 * I_D);
    out[3] = m_G * r / 4.0 * (1.0 - a * a / (b * b)) - r / (4.0 * b) * (I_G + 2.0 * I_D);
}

#endif
