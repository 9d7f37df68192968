/* The part of the FMI wrappers that does not depend on the FMI version. */
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "instance.h"

#ifdef BUS_TERMINAL
#define EVALUATE_ON_GET 0  /* a bus node's outputs are those of the last period it sent */
#else
#define EVALUATE_ON_GET HAS_FEEDTHROUGH
#endif

void inst_reset(Instance *s) {
    memset(&s->c, 0, sizeof s->c);
    memcpy(s->c.m.v, START, sizeof START);
    s->c.phase = PH_INSTANTIATED;
    s->stop = INFINITY;
}

void inst_log(Instance *s, int status, const char *category, const char *fmt, ...) {
    char text[512];
    va_list args;
    if (!s->log || (!s->logging && status == ST_OK)) return;
    va_start(args, fmt);
    vsnprintf(text, sizeof text, fmt, args);
    va_end(args);
    s->log(s, status, category, text);
}

static void flush_warning(Instance *s) {
    if (s->c.m.warning[0]) {
        inst_log(s, ST_WARNING, "logStatusWarning", "%s", s->c.m.warning);
        s->c.m.warning[0] = '\0';
    }
}

/* Whether element i may be set now (FMI causality and variability rules). */
static int settable(const Instance *s, size_t i) {
    switch (KIND[i]) {
    case 'i': return s->c.phase != PH_TERMINATED;
    case 't': return s->c.phase != PH_TERMINATED;
    case 'f': case 's': return s->c.phase <= PH_INITIALIZATION;
    default: return 0;
    }
}

int inst_set(Instance *s, size_t index, size_t n, const double *values) {
    size_t j;
    if (index + n > NV) {
        inst_log(s, ST_ERROR, "logStatusError", "value reference %zu out of range", index + n - 1);
        return ST_ERROR;
    }
    for (j = 0; j < n; j++) {
        size_t i = index + j;
        if (!settable(s, i)) {
            inst_log(s, ST_ERROR, "logStatusError", "variable '%s' cannot be set now", NAME[i]);
            return ST_ERROR;
        }
        if (values[j] != values[j]) {
            inst_log(s, ST_ERROR, "logStatusError", "'%s' = NaN is refused: not a number",
                     NAME[i]);
            return ST_ERROR;
        }
        if ((KIND[i] == 'f' || KIND[i] == 't') && (values[j] < MIN[i] || values[j] > MAX[i])) {
            inst_log(s, ST_ERROR, "logStatusError", "'%s' = %g is outside [%g, %g]", NAME[i],
                     values[j], MIN[i], MAX[i]);
            return ST_ERROR;
        }
    }
    memcpy(s->c.m.v + index, values, n * sizeof *values);
    s->c.dirty = 1;
    return ST_OK;
}

int inst_get(Instance *s, size_t index, size_t n, double *values) {
    if (index + n > NV) {
        inst_log(s, ST_ERROR, "logStatusError", "value reference %zu out of range", index + n - 1);
        return ST_ERROR;
    }
    if (EVALUATE_ON_GET && s->c.dirty && s->c.phase == PH_STEP) {
        kernel_eval(&s->c.m);
        s->c.dirty = 0;
        flush_warning(s);
    }
    if (s->c.phase == PH_INITIALIZATION) {
        /* a calculated output in initialization mode: computed from the inputs and parameters
         * set so far, as exiting would compute it (on a copy: nothing is committed) */
        Model *probe = (Model *)malloc(sizeof *probe);
        if (!probe) {
            inst_log(s, ST_ERROR, "logStatusError", "out of memory");
            return ST_ERROR;
        }
        memcpy(probe, &s->c.m, sizeof *probe);
        kernel_init(probe);
        memcpy(values, probe->v + index, n * sizeof *values);
        free(probe);
        return ST_OK;
    }
    memcpy(values, s->c.m.v + index, n * sizeof *values);
    return ST_OK;
}

int inst_enter_init(Instance *s, double start) {
    if (s->c.phase != PH_INSTANTIATED) return ST_ERROR;
    s->c.start = start;
    s->c.m.time = start;
    s->c.phase = PH_INITIALIZATION;
    return ST_OK;
}

int inst_exit_init(Instance *s) {
    if (s->c.phase != PH_INITIALIZATION) return ST_ERROR;
    kernel_init(&s->c.m);
    s->c.dirty = 0;
    s->c.phase = PH_STEP;
    flush_warning(s);
    return ST_OK;
}

/* The step from t by h is refused: not in step mode, h not a positive finite number, t not
 * finite, t + h not after t (h below the resolution of t) or beyond the experiment's stop. */
static int bad_step(Instance *s, double t, double h) {
    const char *why = NULL;
    if (s->c.phase != PH_STEP) why = "not in step mode";
    else if (!(h > 0.0) || !isfinite(h)) why = "the step size must be a positive finite number";
    else if (!isfinite(t) || !(t + h > t)) why = "the time would not advance";
    else if (t + h > s->stop + 1e-9 * fmax(1.0, fabs(s->stop)))
        why = "it ends after the experiment's stop time";
    if (why) inst_log(s, ST_ERROR, "logStatusError", "doStep(t = %g, h = %g) refused: %s", t, h,
                      why);
    return why != NULL;
}

int inst_step(Instance *s, double t, double h) {
    Core *c = &s->c;
    if (bad_step(s, t, h)) return ST_ERROR;
    if (HAS_FEEDTHROUGH && c->dirty) {
        c->m.time = t;
        kernel_eval(&c->m);
    }
    kernel_step(&c->m, t, h);
    if (c->m.error[0]) {
        inst_log(s, ST_ERROR, "logStatusError", "doStep(t = %g, h = %g) refused: %s", t, h,
                 c->m.error);
        c->m.error[0] = '\0';
        return ST_ERROR;
    }
    if (h == c->h) {
        c->k += 1;
    } else {
        c->start = t;
        c->h = h;
        c->k = 1;
    }
    c->m.time = c->start + c->k * h;
    c->dirty = 1;
    flush_warning(s);
    return ST_OK;
}
