/* The slip profile of a descriptor as components/_model.slip_at evaluates it (same order of
 * operations), shared by the C twins of the plant and of the slip block; config.h #defines the
 * codes SLIP_* from _model's constants. */
#ifndef TWMR_SLIP_PROFILE_H
#define TWMR_SLIP_PROFILE_H

#include <math.h>

/* the slip profile descriptor (_model.DESCRIPTOR): the index of each of its fields */
enum { D_CODE, D_GAIN, D_DGAIN, D_SLIP, D_DIST = D_SLIP + 3, D_STEP_TIME = D_DIST + 2,
       D_MUD_CENTER, D_MUD_RADIUS = D_MUD_CENTER + 2, D_PHASE };

/* Slip rates [m/s], slip accelerations [m/s2] and disturbance [N.m] (u[0..7]) of descriptor p
 * at time t [s] with M at (x, y) [m] (Sec. IV-A for the paper profile). The codes are compared
 * as doubles, as in Python (a code that is none of them gives no slip). */
static void slip_at(const double *p, double t, double x, double y, double *u) {
    double code = p[D_CODE], g = p[D_GAIN], gd = p[D_DGAIN];
    int on, i;
    if (code == SLIP_PAPER) {
        double tp = t + p[D_PHASE], c = cos(tp), s = sin(tp);
        double v[8] = {g * (1.0 + c), g * (1.0 + s), g * c, -g * s, g * c, -g * s,
                       gd * 2.0 * sin(3.0 * tp), gd * 2.0 * cos(3.0 * tp)};
        for (i = 0; i < 8; i++) u[i] = v[i];
        return;
    }
    on = code == SLIP_CONSTANT || (code == SLIP_STEP && t >= p[D_STEP_TIME]) ||
         (code == SLIP_MUD && hypot(x - p[D_MUD_CENTER], y - p[D_MUD_CENTER + 1])
                              <= p[D_MUD_RADIUS]);
    for (i = 0; i < 8; i++) u[i] = 0.0;
    if (on) {
        for (i = 0; i < 3; i++) u[i] = g * p[D_SLIP + i];
        u[6] = gd * p[D_DIST];
        u[7] = gd * p[D_DIST + 1];
    }
}

#endif
