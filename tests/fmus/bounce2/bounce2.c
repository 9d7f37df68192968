/* A bouncing ball as an FMI 2.0 FMU for model exchange and co-simulation.
 * Written for twmr-cosim's tests; built at test time against the FMI headers fmpy ships.
 *
 * States h [m] and v [m/s]: der(h) = v, der(v) = -g. One event indicator z = h. At a state event with
 * h <= 0 and v <= 0 the ball bounces: h := 0, v := -e v, bounces += 1. If the rebound speed is below
 * V_REST (1e-3 m/s) the ball comes to rest: v := 0, h := 0 and both derivatives are 0 from then on;
 * at rest the event indicator is the constant 1, so no further crossing (no chattering) is reported.
 * Co-simulation: doStep integrates with RK4 substeps of at most H_INT (exact here, the motion being a
 * quadratic polynomial in time); a ground crossing inside a substep is located as the root of that
 * quadratic and handled with the same bounce rule as in model exchange. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "fmi2Functions.h"

enum { VR_H = 0, VR_DER_H = 1, VR_V = 2, VR_DER_V = 3, VR_G = 4, VR_E = 5, VR_BOUNCES = 6 };
#define V_REST 1e-3
#define H_INT 1e-3

typedef enum { M_INSTANTIATED, M_INIT, M_EVENT, M_CONT, M_STEP, M_TERMINATED } Mode;

typedef struct {
    double h, v, g, e, time;
    int bounces, rest;
    fmi2Type type;
    Mode mode;
    fmi2CallbackFunctions cb;
    char name[128];
} Inst;

static fmi2Status fail(Inst *c, const char *msg) {
    if (c->cb.logger) c->cb.logger(c->cb.componentEnvironment, c->name, fmi2Error, "logStatusError", msg);
    return fmi2Error;
}
static fmi2Status bad_vr(Inst *c, const char *fn, fmi2ValueReference vr) {
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

/* the discrete part of the model: returns 1 if the continuous states were changed */
static int bounce(Inst *c) {
    if (c->rest || c->h > 0 || c->v > 0) return 0;
    if (c->v < 0) c->bounces++;
    c->h = 0.0;
    c->v = -c->e * c->v;
    if (c->v < V_REST) { c->v = 0.0; c->rest = 1; }
    return 1;
}

/* co-simulation: advance the ball by dt with RK4 substeps and exact crossing location */
static void advance(Inst *c, double dt) {
    double left = dt;
    while (left > 0 && !c->rest) {
        double s = left < H_INT ? left : H_INT;
        /* RK4 for h' = v, v' = -g */
        double k1h = c->v, k1v = -c->g;
        double k2h = c->v + 0.5 * s * k1v, k2v = -c->g;
        double k3h = c->v + 0.5 * s * k2v, k3v = -c->g;
        double k4h = c->v + s * k3v, k4v = -c->g;
        double h1 = c->h + s / 6.0 * (k1h + 2 * k2h + 2 * k3h + k4h);
        double v1 = c->v + s / 6.0 * (k1v + 2 * k2v + 2 * k3v + k4v);
        if (h1 > 0 || v1 > 0) { c->h = h1; c->v = v1; left -= s; continue; }
        /* crossing: h + v t - g t^2 / 2 = 0 for t in (0, s] */
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

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }
fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[]) { return fmi2OK; }

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String loc,
                              const fmi2CallbackFunctions *cb, fmi2Boolean visible, fmi2Boolean log) {
    Inst *c = (Inst *)calloc(1, sizeof(Inst));
    if (!c) return NULL;
    if (cb) c->cb = *cb;
    snprintf(c->name, sizeof c->name, "%s", name ? name : "bounce2");
    c->type = type;
    defaults(c);
    return c;
}
void fmi2FreeInstance(fmi2Component c) { free(c); }
fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolDef, fmi2Real tol, fmi2Real start,
                               fmi2Boolean stopDef, fmi2Real stop) { ((Inst *)c)->time = start; return fmi2OK; }
fmi2Status fmi2EnterInitializationMode(fmi2Component c) { ((Inst *)c)->mode = M_INIT; return fmi2OK; }
fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Inst *i = (Inst *)c;
    if (i->type == fmi2CoSimulation) { bounce(i); i->mode = M_STEP; } /* ME: first event iteration follows */
    else i->mode = M_EVENT;
    return fmi2OK;
}
fmi2Status fmi2Terminate(fmi2Component c) { ((Inst *)c)->mode = M_TERMINATED; return fmi2OK; }
fmi2Status fmi2Reset(fmi2Component c) { defaults((Inst *)c); return fmi2OK; }

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        switch (vr[j]) {
        case VR_H: value[j] = i->h; break;
        case VR_DER_H: value[j] = der_h(i); break;
        case VR_V: value[j] = i->v; break;
        case VR_DER_V: value[j] = der_v(i); break;
        case VR_G: value[j] = i->g; break;
        case VR_E: value[j] = i->e; break;
        default: return bad_vr(i, "fmi2GetReal", vr[j]);
        }
    }
    return fmi2OK;
}
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real value[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_H && vr[j] != VR_V && vr[j] != VR_G && vr[j] != VR_E) return bad_vr(i, "fmi2SetReal", vr[j]);
        if (i->mode != M_INSTANTIATED && i->mode != M_INIT)
            return fail(i, "fmi2SetReal: h, v, g and e can only be set before initialization is done");
        if (vr[j] == VR_G && !(value[j] > 0)) return fail(i, "fmi2SetReal: g must be positive");
        if (vr[j] == VR_E && !(value[j] >= 0 && value[j] <= 1)) return fail(i, "fmi2SetReal: e must be in [0, 1]");
    }
    for (size_t j = 0; j < n; j++) {
        switch (vr[j]) {
        case VR_H: i->h = value[j]; break;
        case VR_V: i->v = value[j]; break;
        case VR_G: i->g = value[j]; break;
        default: i->e = value[j]; break;
        }
    }
    return fmi2OK;
}
fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_BOUNCES) return bad_vr(i, "fmi2GetInteger", vr[j]);
        v[j] = i->bounces;
    }
    return fmi2OK;
}
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]) {
    return n ? bad_vr((Inst *)c, "fmi2SetInteger", vr[0]) : fmi2OK;
}
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]) {
    return n ? bad_vr((Inst *)c, "fmi2GetBoolean", vr[0]) : fmi2OK;
}
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]) {
    return n ? bad_vr((Inst *)c, "fmi2SetBoolean", vr[0]) : fmi2OK;
}
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]) {
    return n ? bad_vr((Inst *)c, "fmi2GetString", vr[0]) : fmi2OK;
}
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]) {
    return n ? bad_vr((Inst *)c, "fmi2SetString", vr[0]) : fmi2OK;
}

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s) { return fail((Inst *)c, "FMU state not supported"); }
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) { return fail((Inst *)c, "FMU state not supported"); }
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s) { return fail((Inst *)c, "FMU state not supported"); }
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *n) { return fail((Inst *)c, "FMU state not supported"); }
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n) { return fail((Inst *)c, "FMU state not supported"); }
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s) { return fail((Inst *)c, "FMU state not supported"); }
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference a[], size_t na,
    const fmi2ValueReference b[], size_t nb, const fmi2Real dv[], fmi2Real df[]) {
    return fail((Inst *)c, "directional derivatives not supported");
}

/* co-simulation */
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
    const fmi2Integer order[], const fmi2Real value[]) { return fail((Inst *)c, "no inputs"); }
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
    const fmi2Integer order[], fmi2Real value[]) { return fail((Inst *)c, "output derivatives not supported"); }
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior) {
    Inst *i = (Inst *)c;
    if (i->mode != M_STEP) return fail(i, "fmi2DoStep called outside step mode");
    if (!(h >= 0)) return fail(i, "fmi2DoStep: negative step size");
    i->time = t;
    advance(i, h);
    return fmi2OK;
}
fmi2Status fmi2CancelStep(fmi2Component c) { return fail((Inst *)c, "fmi2CancelStep not supported"); }
fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *v) { return fail((Inst *)c, "fmi2GetStatus not supported"); }
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *v) {
    if (s != fmi2LastSuccessfulTime) return fail((Inst *)c, "fmi2GetRealStatus: unsupported status kind");
    *v = ((Inst *)c)->time;
    return fmi2OK;
}
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *v) { return fail((Inst *)c, "fmi2GetIntegerStatus not supported"); }
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *v) {
    if (s != fmi2Terminated) return fail((Inst *)c, "fmi2GetBooleanStatus: unsupported status kind");
    *v = fmi2False;
    return fmi2OK;
}
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *v) { return fail((Inst *)c, "fmi2GetStringStatus not supported"); }

/* model exchange: states (h, v), event indicator z = h */
fmi2Status fmi2EnterEventMode(fmi2Component c) { ((Inst *)c)->mode = M_EVENT; return fmi2OK; }
fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *e) {
    Inst *i = (Inst *)c;
    if (i->mode != M_EVENT) return fail(i, "fmi2NewDiscreteStates called outside event mode");
    int changed = bounce(i);
    e->newDiscreteStatesNeeded = fmi2False; e->terminateSimulation = fmi2False;
    e->nominalsOfContinuousStatesChanged = fmi2False;
    e->valuesOfContinuousStatesChanged = changed ? fmi2True : fmi2False;
    e->nextEventTimeDefined = fmi2False; e->nextEventTime = 0;
    return fmi2OK;
}
fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) { ((Inst *)c)->mode = M_CONT; return fmi2OK; }
fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSet, fmi2Boolean *enter, fmi2Boolean *term) {
    *enter = fmi2False; *term = fmi2False; return fmi2OK;
}
fmi2Status fmi2SetTime(fmi2Component c, fmi2Real t) { ((Inst *)c)->time = t; return fmi2OK; }
fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t n) {
    Inst *i = (Inst *)c;
    if (n != 2) return fail(i, "fmi2SetContinuousStates: expected 2 states");
    i->h = x[0]; i->v = x[1];
    return fmi2OK;
}
fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real dx[], size_t n) {
    Inst *i = (Inst *)c;
    if (n != 2) return fail(i, "fmi2GetDerivatives: expected 2 states");
    dx[0] = der_h(i); dx[1] = der_v(i);
    return fmi2OK;
}
fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real z[], size_t n) {
    Inst *i = (Inst *)c;
    if (n != 1) return fail(i, "fmi2GetEventIndicators: expected 1 event indicator");
    z[0] = indicator(i);
    return fmi2OK;
}
fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t n) {
    Inst *i = (Inst *)c;
    if (n != 2) return fail(i, "fmi2GetContinuousStates: expected 2 states");
    x[0] = i->h; x[1] = i->v;
    return fmi2OK;
}
fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x[], size_t n) {
    for (size_t j = 0; j < n; j++) x[j] = 1.0;
    return fmi2OK;
}
