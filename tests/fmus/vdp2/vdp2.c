/* A Van der Pol oscillator as an FMI 2.0 FMU for model exchange and co-simulation.
 * Written for twmr-cosim's tests; built at test time against the FMI headers fmpy ships.
 *
 * States x0 and x1: der(x0) = x1, der(x1) = mu (1 - x0^2) x1 - x0 (mu = 1, x0 = 2, x1 = 0 by
 * default, as in the Modelica Association's VanDerPol). No event indicators.
 * Co-simulation: every doStep is one classic RK4 step of the communication step size, so the
 * result's accuracy is the importer's choice of step (local error of order h^5).
 * The FMU state (both interfaces: get, set, serialise) is the model's part of the instance. */
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "fmi2Functions.h"

enum { VR_X0 = 0, VR_DER_X0 = 1, VR_X1 = 2, VR_DER_X1 = 3, VR_MU = 4 };

typedef enum { M_INSTANTIATED, M_INIT, M_EVENT, M_CONT, M_STEP, M_TERMINATED } Mode;

typedef struct {
    double x0, x1, mu, time;
    Mode mode;
    fmi2Type type; /* from here on the instance's own, not part of a saved state */
    fmi2CallbackFunctions cb;
    char name[128];
} Inst;

#define SAVED offsetof(Inst, type)

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
    c->x0 = 2.0; c->x1 = 0.0; c->mu = 1.0; c->time = 0.0; c->mode = M_INSTANTIATED;
}
static void rhs(double mu, double x0, double x1, double *d0, double *d1) {
    *d0 = x1;
    *d1 = mu * (1.0 - x0 * x0) * x1 - x0;
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }
fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[]) { return fmi2OK; }

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String loc,
                              const fmi2CallbackFunctions *cb, fmi2Boolean visible, fmi2Boolean log) {
    Inst *c = (Inst *)calloc(1, sizeof(Inst));
    if (!c) return NULL;
    if (cb) c->cb = *cb;
    snprintf(c->name, sizeof c->name, "%s", name ? name : "vdp2");
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
    i->mode = i->type == fmi2CoSimulation ? M_STEP : M_EVENT;
    return fmi2OK;
}
fmi2Status fmi2Terminate(fmi2Component c) { ((Inst *)c)->mode = M_TERMINATED; return fmi2OK; }
fmi2Status fmi2Reset(fmi2Component c) { defaults((Inst *)c); return fmi2OK; }

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[]) {
    Inst *i = (Inst *)c;
    double d0, d1;
    rhs(i->mu, i->x0, i->x1, &d0, &d1);
    for (size_t j = 0; j < n; j++) {
        switch (vr[j]) {
        case VR_X0: value[j] = i->x0; break;
        case VR_DER_X0: value[j] = d0; break;
        case VR_X1: value[j] = i->x1; break;
        case VR_DER_X1: value[j] = d1; break;
        case VR_MU: value[j] = i->mu; break;
        default: return bad_vr(i, "fmi2GetReal", vr[j]);
        }
    }
    return fmi2OK;
}
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real value[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_X0 && vr[j] != VR_X1 && vr[j] != VR_MU) return bad_vr(i, "fmi2SetReal", vr[j]);
        if (i->mode != M_INSTANTIATED && i->mode != M_INIT)
            return fail(i, "fmi2SetReal: x0, x1 and mu can only be set before initialization is done");
    }
    for (size_t j = 0; j < n; j++) {
        switch (vr[j]) {
        case VR_X0: i->x0 = value[j]; break;
        case VR_X1: i->x1 = value[j]; break;
        default: i->mu = value[j]; break;
        }
    }
    return fmi2OK;
}
fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]) {
    return n ? bad_vr((Inst *)c, "fmi2GetInteger", vr[0]) : fmi2OK;
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

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s) {
    if (*s == NULL) *s = malloc(SAVED);
    if (*s == NULL) return fail((Inst *)c, "fmi2GetFMUstate: out of memory");
    memcpy(*s, c, SAVED);
    return fmi2OK;
}
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) {
    if (s == NULL) return fail((Inst *)c, "fmi2SetFMUstate: no state");
    memcpy(c, s, SAVED);
    return fmi2OK;
}
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s) { free(*s); *s = NULL; return fmi2OK; }
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *n) { *n = SAVED; return fmi2OK; }
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n) {
    if (n != SAVED) return fail((Inst *)c, "fmi2SerializeFMUstate: wrong buffer size");
    memcpy(b, s, SAVED);
    return fmi2OK;
}
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s) {
    if (n != SAVED) return fail((Inst *)c, "fmi2DeSerializeFMUstate: wrong size (not a vdp2 state)");
    *s = malloc(SAVED);
    if (*s == NULL) return fail((Inst *)c, "fmi2DeSerializeFMUstate: out of memory");
    memcpy(*s, b, SAVED);
    return fmi2OK;
}
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference a[], size_t na,
    const fmi2ValueReference b[], size_t nb, const fmi2Real dv[], fmi2Real df[]) {
    return fail((Inst *)c, "directional derivatives not supported");
}

/* co-simulation: one RK4 step of h */
fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
    const fmi2Integer order[], const fmi2Real value[]) { return fail((Inst *)c, "no inputs"); }
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
    const fmi2Integer order[], fmi2Real value[]) { return fail((Inst *)c, "output derivatives not supported"); }
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior) {
    Inst *i = (Inst *)c;
    if (i->mode != M_STEP) return fail(i, "fmi2DoStep called outside step mode");
    if (!(h >= 0)) return fail(i, "fmi2DoStep: negative step size");
    double mu = i->mu, a0 = i->x0, a1 = i->x1, k1a, k1b, k2a, k2b, k3a, k3b, k4a, k4b;
    rhs(mu, a0, a1, &k1a, &k1b);
    rhs(mu, a0 + 0.5 * h * k1a, a1 + 0.5 * h * k1b, &k2a, &k2b);
    rhs(mu, a0 + 0.5 * h * k2a, a1 + 0.5 * h * k2b, &k3a, &k3b);
    rhs(mu, a0 + h * k3a, a1 + h * k3b, &k4a, &k4b);
    i->x0 = a0 + h / 6.0 * (k1a + 2 * k2a + 2 * k3a + k4a);
    i->x1 = a1 + h / 6.0 * (k1b + 2 * k2b + 2 * k3b + k4b);
    i->time = t + h;
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

/* model exchange: states (x0, x1), no event indicators */
fmi2Status fmi2EnterEventMode(fmi2Component c) { ((Inst *)c)->mode = M_EVENT; return fmi2OK; }
fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *e) {
    Inst *i = (Inst *)c;
    if (i->mode != M_EVENT) return fail(i, "fmi2NewDiscreteStates called outside event mode");
    e->newDiscreteStatesNeeded = fmi2False; e->terminateSimulation = fmi2False;
    e->nominalsOfContinuousStatesChanged = fmi2False; e->valuesOfContinuousStatesChanged = fmi2False;
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
    i->x0 = x[0]; i->x1 = x[1];
    return fmi2OK;
}
fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real dx[], size_t n) {
    Inst *i = (Inst *)c;
    if (n != 2) return fail(i, "fmi2GetDerivatives: expected 2 states");
    rhs(i->mu, i->x0, i->x1, &dx[0], &dx[1]);
    return fmi2OK;
}
fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real z[], size_t n) {
    return n ? fail((Inst *)c, "fmi2GetEventIndicators: no event indicators") : fmi2OK;
}
fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t n) {
    Inst *i = (Inst *)c;
    if (n != 2) return fail(i, "fmi2GetContinuousStates: expected 2 states");
    x[0] = i->x0; x[1] = i->x1;
    return fmi2OK;
}
fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x[], size_t n) {
    for (size_t j = 0; j < n; j++) x[j] = 1.0;
    return fmi2OK;
}
