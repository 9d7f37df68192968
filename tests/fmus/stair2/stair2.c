/* A staircase: an FMI 2.0 FMU for model exchange and co-simulation without continuous states whose
 * Integer output `counter` (start 1) goes up by 1 at each time event t = 1, 2, 3, ...
 * Written for twmr-cosim's tests; built at test time against the FMI headers fmpy ships.
 * Model exchange: fmi2NewDiscreteStates reports the next event time (nextEventTimeDefined = true);
 * an event iteration at time t >= next (within 1e-9 relative) increments the counter once per
 * elapsed event time. Co-simulation: doStep(t, H) counts the event times in (t, t + H], so the
 * output at an event time already shows the value after the event. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "fmi2Functions.h"

enum { VR_COUNTER = 0 };

typedef enum { M_INSTANTIATED, M_INIT, M_EVENT, M_CONT, M_STEP, M_TERMINATED } Mode;

typedef struct {
    int counter;
    double time, next; /* next: the next event time */
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
static void defaults(Inst *c) { c->counter = 1; c->time = 0; c->next = 1; c->mode = M_INSTANTIATED; }
static int reached(double t, double next) { return t >= next - 1e-9 * (1.0 + fabs(next)); }
/* count the event times up to and including t */
static int tick(Inst *c, double t) {
    int n = 0;
    while (reached(t, c->next)) { c->counter++; c->next += 1.0; n++; }
    return n;
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }
fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[]) { return fmi2OK; }

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String loc,
                              const fmi2CallbackFunctions *cb, fmi2Boolean visible, fmi2Boolean log) {
    Inst *c = (Inst *)calloc(1, sizeof(Inst));
    if (!c) return NULL;
    if (cb) c->cb = *cb;
    snprintf(c->name, sizeof c->name, "%s", name ? name : "stair2");
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
    i->next = floor(i->time) + 1.0; /* the first event time after the start time */
    i->mode = i->type == fmi2CoSimulation ? M_STEP : M_EVENT;
    return fmi2OK;
}
fmi2Status fmi2Terminate(fmi2Component c) { ((Inst *)c)->mode = M_TERMINATED; return fmi2OK; }
fmi2Status fmi2Reset(fmi2Component c) { defaults((Inst *)c); return fmi2OK; }

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[]) {
    return n ? bad_vr((Inst *)c, "fmi2GetReal", vr[0]) : fmi2OK;
}
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real value[]) {
    return n ? bad_vr((Inst *)c, "fmi2SetReal", vr[0]) : fmi2OK;
}
fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_COUNTER) return bad_vr(i, "fmi2GetInteger", vr[j]);
        v[j] = i->counter;
    }
    return fmi2OK;
}
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_COUNTER) return bad_vr(i, "fmi2SetInteger", vr[j]);
        if (i->mode != M_INSTANTIATED && i->mode != M_INIT)
            return fail(i, "fmi2SetInteger: counter can only be set before initialization is done");
    }
    for (size_t j = 0; j < n; j++) i->counter = v[j];
    return fmi2OK;
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
    i->time = t + h;
    tick(i, i->time);
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

/* model exchange: no continuous states, no event indicators, time events only */
fmi2Status fmi2EnterEventMode(fmi2Component c) { ((Inst *)c)->mode = M_EVENT; return fmi2OK; }
fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *e) {
    Inst *i = (Inst *)c;
    if (i->mode != M_EVENT) return fail(i, "fmi2NewDiscreteStates called outside event mode");
    tick(i, i->time);
    e->newDiscreteStatesNeeded = fmi2False; e->terminateSimulation = fmi2False;
    e->nominalsOfContinuousStatesChanged = fmi2False; e->valuesOfContinuousStatesChanged = fmi2False;
    e->nextEventTimeDefined = fmi2True; e->nextEventTime = i->next;
    return fmi2OK;
}
fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) { ((Inst *)c)->mode = M_CONT; return fmi2OK; }
fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSet, fmi2Boolean *enter, fmi2Boolean *term) {
    *enter = fmi2False; *term = fmi2False; return fmi2OK;
}
fmi2Status fmi2SetTime(fmi2Component c, fmi2Real t) { ((Inst *)c)->time = t; return fmi2OK; }
fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t n) {
    return n ? fail((Inst *)c, "fmi2SetContinuousStates: the model has no continuous states") : fmi2OK;
}
fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real dx[], size_t n) {
    return n ? fail((Inst *)c, "fmi2GetDerivatives: the model has no continuous states") : fmi2OK;
}
fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real z[], size_t n) {
    return n ? fail((Inst *)c, "fmi2GetEventIndicators: the model has no event indicators") : fmi2OK;
}
fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t n) {
    return n ? fail((Inst *)c, "fmi2GetContinuousStates: the model has no continuous states") : fmi2OK;
}
fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x[], size_t n) {
    return n ? fail((Inst *)c, "fmi2GetNominalsOfContinuousStates: the model has no continuous states") : fmi2OK;
}
