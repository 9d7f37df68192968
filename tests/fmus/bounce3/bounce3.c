/* The bounce2 bouncing ball as an FMI 3.0 FMU for model exchange and co-simulation.
 * Written for twmr-cosim's tests; built at test time against the FMI 3.0 headers fmpy ships
 * (tests/fmu_build.py adds stubs returning fmi3Error for the FMI 3.0 functions not defined here).
 *
 * States h [m] and v [m/s]: der(h) = v, der(v) = -g. One event indicator z = h (variable "z").
 * At an event with h <= 0 and v <= 0: h := 0, v := -e v, bounces += 1; a rebound speed below
 * V_REST (1e-3 m/s) puts the ball at rest (h = v = 0, derivatives 0, z held at 1: no chattering).
 * Co-simulation: RK4 substeps of at most H_INT, exact here; a ground crossing inside a substep is
 * the root of the same quadratic and gets the same bounce rule.
 * The FMU state (both interfaces) is the model's part of the instance, up to `cs`, as bytes. */
#include <math.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "fmi3Functions.h"

enum { VR_TIME = 0, VR_H = 1, VR_DER_H = 2, VR_V = 3, VR_DER_V = 4, VR_G = 5, VR_E = 6,
       VR_BOUNCES = 7, VR_Z = 8 };
#define V_REST 1e-3
#define H_INT 1e-3

typedef enum { M_INSTANTIATED, M_INIT, M_EVENT, M_CONT, M_STEP, M_TERMINATED } Mode;

typedef struct {
    double h, v, g, e, time;
    int bounces, rest;
    Mode mode;
    int cs; /* from here on the instance's own, not part of a saved state */
    fmi3InstanceEnvironment env;
    fmi3LogMessageCallback log;
} Inst;

static fmi3Status fail(Inst *c, const char *msg) {
    if (c->log) c->log(c->env, fmi3Error, "logStatusError", msg);
    return fmi3Error;
}
static fmi3Status bad_vr(Inst *c, const char *fn, fmi3ValueReference vr) {
    char msg[160];
    snprintf(msg, sizeof msg, "%s: invalid value reference %u", fn, (unsigned)vr);
    return fail(c, msg);
}
static void defaults(Inst *c) {
    c->h = 1.0; c->v = 0.0; c->g = 9.81; c->e = 0.7; c->time = 0.0; c->bounces = 0; c->rest = 0;
    c->mode = M_INSTANTIATED;
}
static double der_h(const Inst *c) { return c->rest ? 0.0 : c->v; }
static double der_v(const Inst *c) { return c->rest ? 0.0 : -c->g; }
static double indicator(const Inst *c) { return c->rest ? 1.0 : c->h; }

static int bounce(Inst *c) {
    if (c->rest || c->h > 0 || c->v > 0) return 0;
    if (c->v < 0) c->bounces++;
    c->h = 0.0;
    c->v = -c->e * c->v;
    if (c->v < V_REST) { c->v = 0.0; c->rest = 1; }
    return 1;
}

static void advance(Inst *c, double dt) {
    double left = dt;
    while (left > 0 && !c->rest) {
        double s = left < H_INT ? left : H_INT;
        double k1h = c->v, k1v = -c->g;
        double k2h = c->v + 0.5 * s * k1v, k2v = -c->g;
        double k3h = c->v + 0.5 * s * k2v, k3v = -c->g;
        double k4h = c->v + s * k3v, k4v = -c->g;
        double h1 = c->h + s / 6.0 * (k1h + 2 * k2h + 2 * k3h + k4h);
        double v1 = c->v + s / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v);
        if (h1 > 0 || v1 > 0) { c->h = h1; c->v = v1; left -= s; continue; }
        double h0 = c->h > 0 ? c->h : 0, root = sqrt(c->v * c->v + 2 * c->g * h0);
        double t = c->v < 0 ? 2 * h0 / (root - c->v) : (c->v + root) / c->g; /* no cancellation */
        if (!(t >= 0)) t = 0;
        if (t > s) t = s;
        c->v -= c->g * t;
        c->h = 0.0;
        left -= t;
        bounce(c);
    }
    c->time += dt;
}

static Inst *create(fmi3InstanceEnvironment env, fmi3LogMessageCallback log, int cs) {
    Inst *c = (Inst *)calloc(1, sizeof(Inst));
    if (!c) return NULL;
    c->env = env; c->log = log; c->cs = cs;
    defaults(c);
    return c;
}

const char *fmi3GetVersion(void) { return fmi3Version; }
fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean on, size_t n, const fmi3String cat[]) { return fmi3OK; }

fmi3Instance fmi3InstantiateModelExchange(fmi3String name, fmi3String token, fmi3String res,
    fmi3Boolean visible, fmi3Boolean log, fmi3InstanceEnvironment env, fmi3LogMessageCallback logMessage) {
    return create(env, logMessage, 0);
}
fmi3Instance fmi3InstantiateCoSimulation(fmi3String name, fmi3String token, fmi3String res,
    fmi3Boolean visible, fmi3Boolean log, fmi3Boolean eventModeUsed, fmi3Boolean earlyReturn,
    const fmi3ValueReference req[], size_t nreq, fmi3InstanceEnvironment env,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback update) {
    return create(env, logMessage, 1);
}
void fmi3FreeInstance(fmi3Instance c) { free(c); }

fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean tolDef, fmi3Float64 tol,
    fmi3Float64 start, fmi3Boolean stopDef, fmi3Float64 stop) {
    Inst *i = (Inst *)c;
    i->time = start; i->mode = M_INIT;
    return fmi3OK;
}
fmi3Status fmi3ExitInitializationMode(fmi3Instance c) {
    Inst *i = (Inst *)c;
    if (i->cs) { bounce(i); i->mode = M_STEP; } else i->mode = M_EVENT;
    return fmi3OK;
}
fmi3Status fmi3EnterEventMode(fmi3Instance c) { ((Inst *)c)->mode = M_EVENT; return fmi3OK; }
fmi3Status fmi3Terminate(fmi3Instance c) { ((Inst *)c)->mode = M_TERMINATED; return fmi3OK; }
fmi3Status fmi3Reset(fmi3Instance c) { defaults((Inst *)c); return fmi3OK; }

fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Float64 v[], size_t nv) {
    Inst *i = (Inst *)c;
    if (nv != n) return fail(i, "fmi3GetFloat64: nValues must equal nValueReferences (no arrays)");
    for (size_t j = 0; j < n; j++) {
        switch (vr[j]) {
        case VR_TIME: v[j] = i->time; break;
        case VR_H: v[j] = i->h; break;
        case VR_DER_H: v[j] = der_h(i); break;
        case VR_V: v[j] = i->v; break;
        case VR_DER_V: v[j] = der_v(i); break;
        case VR_G: v[j] = i->g; break;
        case VR_E: v[j] = i->e; break;
        case VR_Z: v[j] = indicator(i); break;
        default: return bad_vr(i, "fmi3GetFloat64", vr[j]);
        }
    }
    return fmi3OK;
}
fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Float64 v[], size_t nv) {
    Inst *i = (Inst *)c;
    if (nv != n) return fail(i, "fmi3SetFloat64: nValues must equal nValueReferences (no arrays)");
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_H && vr[j] != VR_V && vr[j] != VR_G && vr[j] != VR_E) return bad_vr(i, "fmi3SetFloat64", vr[j]);
        if (i->mode != M_INSTANTIATED && i->mode != M_INIT)
            return fail(i, "fmi3SetFloat64: h, v, g and e can only be set before initialization is done");
        if (vr[j] == VR_G && !(v[j] > 0)) return fail(i, "fmi3SetFloat64: g must be positive");
        if (vr[j] == VR_E && !(v[j] >= 0 && v[j] <= 1)) return fail(i, "fmi3SetFloat64: e must be in [0, 1]");
    }
    for (size_t j = 0; j < n; j++) {
        switch (vr[j]) {
        case VR_H: i->h = v[j]; break;
        case VR_V: i->v = v[j]; break;
        case VR_G: i->g = v[j]; break;
        default: i->e = v[j]; break;
        }
    }
    return fmi3OK;
}
fmi3Status fmi3GetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Int32 v[], size_t nv) {
    Inst *i = (Inst *)c;
    if (nv != n) return fail(i, "fmi3GetInt32: nValues must equal nValueReferences (no arrays)");
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_BOUNCES) return bad_vr(i, "fmi3GetInt32", vr[j]);
        v[j] = i->bounces;
    }
    return fmi3OK;
}

/* model exchange */
fmi3Status fmi3UpdateDiscreteStates(fmi3Instance c, fmi3Boolean *needUpdate, fmi3Boolean *terminate,
    fmi3Boolean *nominalsChanged, fmi3Boolean *valuesChanged, fmi3Boolean *nextDefined, fmi3Float64 *next) {
    Inst *i = (Inst *)c;
    if (i->mode != M_EVENT) return fail(i, "fmi3UpdateDiscreteStates called outside event mode");
    int changed = bounce(i);
    *needUpdate = fmi3False; *terminate = fmi3False; *nominalsChanged = fmi3False;
    *valuesChanged = changed ? fmi3True : fmi3False;
    *nextDefined = fmi3False; *next = 0;
    return fmi3OK;
}
fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance c) { ((Inst *)c)->mode = M_CONT; return fmi3OK; }
fmi3Status fmi3CompletedIntegratorStep(fmi3Instance c, fmi3Boolean noSet, fmi3Boolean *enter, fmi3Boolean *term) {
    *enter = fmi3False; *term = fmi3False; return fmi3OK;
}
fmi3Status fmi3SetTime(fmi3Instance c, fmi3Float64 t) { ((Inst *)c)->time = t; return fmi3OK; }
fmi3Status fmi3SetContinuousStates(fmi3Instance c, const fmi3Float64 x[], size_t n) {
    Inst *i = (Inst *)c;
    if (n != 2) return fail(i, "fmi3SetContinuousStates: expected 2 states");
    i->h = x[0]; i->v = x[1];
    return fmi3OK;
}
fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance c, fmi3Float64 dx[], size_t n) {
    Inst *i = (Inst *)c;
    if (n != 2) return fail(i, "fmi3GetContinuousStateDerivatives: expected 2 states");
    dx[0] = der_h(i); dx[1] = der_v(i);
    return fmi3OK;
}
fmi3Status fmi3GetEventIndicators(fmi3Instance c, fmi3Float64 z[], size_t n) {
    Inst *i = (Inst *)c;
    if (n != 1) return fail(i, "fmi3GetEventIndicators: expected 1 event indicator");
    z[0] = indicator(i);
    return fmi3OK;
}
fmi3Status fmi3GetContinuousStates(fmi3Instance c, fmi3Float64 x[], size_t n) {
    Inst *i = (Inst *)c;
    if (n != 2) return fail(i, "fmi3GetContinuousStates: expected 2 states");
    x[0] = i->h; x[1] = i->v;
    return fmi3OK;
}
fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance c, fmi3Float64 x[], size_t n) {
    for (size_t j = 0; j < n; j++) x[j] = 1.0;
    return fmi3OK;
}
fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance c, size_t *n) { *n = 1; return fmi3OK; }
fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance c, size_t *n) { *n = 2; return fmi3OK; }

/* co-simulation */
fmi3Status fmi3EnterStepMode(fmi3Instance c) { ((Inst *)c)->mode = M_STEP; return fmi3OK; }
fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 t, fmi3Float64 h, fmi3Boolean noSetPrior,
    fmi3Boolean *eventNeeded, fmi3Boolean *terminate, fmi3Boolean *early, fmi3Float64 *last) {
    Inst *i = (Inst *)c;
    if (i->mode != M_STEP) return fail(i, "fmi3DoStep called outside step mode");
    if (!(h >= 0)) return fail(i, "fmi3DoStep: negative step size");
    i->time = t;
    advance(i, h);
    *eventNeeded = fmi3False; *terminate = fmi3False; *early = fmi3False; *last = t + h;
    return fmi3OK;
}

/* FMU state: the model's values up to `cs` (not the instance's interface or callbacks) */
#define STATE_SIZE offsetof(Inst, cs)
fmi3Status fmi3GetFMUState(fmi3Instance c, fmi3FMUState *s) {
    void *st = *s ? *s : malloc(STATE_SIZE); /* a state given back is reused */
    if (!st) return fail((Inst *)c, "fmi3GetFMUState: out of memory");
    memcpy(st, c, STATE_SIZE); *s = st; return fmi3OK;
}
fmi3Status fmi3SetFMUState(fmi3Instance c, fmi3FMUState s) {
    if (!s) return fail((Inst *)c, "fmi3SetFMUState: no state");
    memcpy(c, s, STATE_SIZE); return fmi3OK;
}
fmi3Status fmi3FreeFMUState(fmi3Instance c, fmi3FMUState *s) { free(*s); *s = NULL; return fmi3OK; }
fmi3Status fmi3SerializedFMUStateSize(fmi3Instance c, fmi3FMUState s, size_t *n) { *n = STATE_SIZE; return fmi3OK; }
fmi3Status fmi3SerializeFMUState(fmi3Instance c, fmi3FMUState s, fmi3Byte b[], size_t n) {
    if (!s || n != STATE_SIZE) return fail((Inst *)c, "fmi3SerializeFMUState: wrong size");
    memcpy(b, s, STATE_SIZE); return fmi3OK;
}
fmi3Status fmi3DeserializeFMUState(fmi3Instance c, const fmi3Byte b[], size_t n, fmi3FMUState *s) {
    if (n != STATE_SIZE) return fail((Inst *)c, "fmi3DeserializeFMUState: wrong size");
    void *st = *s ? *s : malloc(STATE_SIZE);
    if (!st) return fail((Inst *)c, "fmi3DeserializeFMUState: out of memory");
    memcpy(st, b, STATE_SIZE); *s = st; return fmi3OK;
}
