/* The slip profile of a descriptor as components/_model.slip_at evaluates it (same order of
 * operations), shared by the C twins of the plant and of the slip block; config.h #defines the
 * codes SLIP_* from _model's constants and the index D_<FIELD> of each field of the descriptor
 * from _model.SlipProfile (components/ctwins.py). */
#ifndef TWMR_SLIP_PROFILE_H
#define TWMR_SLIP_PROFILE_H

#include <math.h>

/* Slip rates [m/s], slip accelerations [m/s2] and disturbance [N.m] (u[0..7]) of descriptor p
 * at time t [s] with M at (x, y) [m] (Sec. IV-A for the paper profile). The codes are compared
 * as doubles, as in Python (a code that is none of them gives no slip). */
static void slip_at(const double *p, double t, double x, double y, double *u) {
    double code = p[D_CODE], g = p[D_SLIP_GAIN], gd = p[D_DISTURBANCE_GAIN];
    int on, i;
    if (code == SLIP_PAPER) {
        double tp = t + p[D_PHASE], c = cos(tp), s = sin(tp);
        double v[8] = {g * (1.0 + c), g * (1.0 + s), g * c, -g * s, g * c, -g * s,
                       gd * 2.0 * sin(3.0 * tp), gd * 2.0 * cos(3.0 * tp)};
        for (i = 0; i < 8; i++) u[i] = v[i];
        return;
    }
    on = code == SLIP_CONSTANT || (code == SLIP_STEP && t >= p[D_STEP_TIME]) ||
         (code == SLIP_MUD && hypot(x - p[D_MUD_X], y - p[D_MUD_Y])
                              <= p[D_MUD_RADIUS]);
    for (i = 0; i < 8; i++) u[i] = 0.0;
    if (on) {
        u[0] = g * p[D_SLIP_R];
        u[1] = g * p[D_SLIP_L];
        u[2] = g * p[D_SLIP_DELTA];
        u[6] = gd * p[D_DISTURBANCE_R];
        u[7] = gd * p[D_DISTURBANCE_L];
    }
}

#endif
