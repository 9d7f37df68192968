/* Discrete inputs: an FMI 2.0 FMU for model exchange and co-simulation.
 * Written for twmr-cosim's tests; built at test time against the FMI headers fmpy ships.
 *
 * Inputs: k (Integer, discrete), on (Boolean, discrete), r_d (Real, discrete), u (Real, continuous).
 * One continuous state x: der(x) = (on ? k + r_d : 0) + u. Outputs x, xo = x and y = 2 k (Integer,
 * direct feedthrough of k).
 * The instance tracks its mode (instantiated, initialization, event, continuous time, step, terminated).
 * As FMI 2.0 requires, a discrete input may only be set in the instantiated, initialization and event
 * modes (and in co-simulation between steps): setting k, on or r_d in continuous-time mode logs
 * "discrete input set outside event mode" (category logStatusError) and returns fmi2Error; nothing is
 * changed then. Co-simulation: doStep takes explicit Euler substeps of at most 1 ms, which is exact
 * because der(x) is constant over a step for held inputs. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "fmi2Functions.h"

enum { VR_K = 0, VR_ON = 1, VR_RD = 2, VR_U = 3, VR_X = 4, VR_DER_X = 5, VR_Y = 6, VR_XO = 7 };
#define H_INT 1e-3

typedef enum { M_INSTANTIATED, M_INIT, M_EVENT, M_CONT, M_STEP, M_TERMINATED } Mode;
static const char *MODE_NAMES[] = {"instantiated", "initialization", "event", "continuousTime", "step", "terminated"};

typedef struct {
    int k, on;
    double r_d, u, x, time;
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
    c->k = 0; c->on = 0; c->r_d = 0; c->u = 0; c->x = 0; c->time = 0; c->mode = M_INSTANTIATED;
}
static double der_x(const Inst *c) { return (c->on ? c->k + c->r_d : 0.0) + c->u; }

/* may a discrete input be set now? logs and returns fmi2Error if not */
static fmi2Status check_discrete_input(Inst *c) {
    if (c->mode == M_INSTANTIATED || c->mode == M_INIT || c->mode == M_EVENT || c->mode == M_STEP) return fmi2OK;
    return fail(c, "discrete input set outside event mode");
}
static fmi2Status check_continuous_input(Inst *c) {
    if (c->mode != M_TERMINATED) return fmi2OK;
    return fail(c, "input set after fmi2Terminate");
}
static fmi2Status check_start_value(Inst *c, const char *var) {
    char msg[160];
    if (c->mode == M_INSTANTIATED || c->mode == M_INIT) return fmi2OK;
    snprintf(msg, sizeof msg, "%s can only be set before initialization is done (mode is %s)", var, MODE_NAMES[c->mode]);
    return fail(c, msg);
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }
fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[]) { return fmi2OK; }

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String loc,
                              const fmi2CallbackFunctions *cb, fmi2Boolean visible, fmi2Boolean log) {
    Inst *c = (Inst *)calloc(1, sizeof(Inst));
    if (!c) return NULL;
    if (cb) c->cb = *cb;
    snprintf(c->name, sizeof c->name, "%s", name ? name : "discin2");
    c->type = type;
    defaults(c);
    return c;
}
void fmi2FreeInstance(fmi2Component c) { free(c); }
fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolDef, fmi2Real tol, fmi2Real start,
                               fmi2Boolean stopDef, fmi2Real stop) {
    Inst *i = (Inst *)c;
    if (i->mode != M_INSTANTIATED) return fail(i, "fmi2SetupExperiment called after fmi2EnterInitializationMode");
    i->time = start;
    return fmi2OK;
}
fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    Inst *i = (Inst *)c;
    if (i->mode != M_INSTANTIATED) return fail(i, "fmi2EnterInitializationMode called twice");
    i->mode = M_INIT;
    return fmi2OK;
}
fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    Inst *i = (Inst *)c;
    if (i->mode != M_INIT) return fail(i, "fmi2ExitInitializationMode called outside initialization mode");
    i->mode = i->type == fmi2CoSimulation ? M_STEP : M_EVENT;
    return fmi2OK;
}
fmi2Status fmi2Terminate(fmi2Component c) { ((Inst *)c)->mode = M_TERMINATED; return fmi2OK; }
fmi2Status fmi2Reset(fmi2Component c) { defaults((Inst *)c); return fmi2OK; }

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        switch (vr[j]) {
        case VR_RD: value[j] = i->r_d; break;
        case VR_U: value[j] = i->u; break;
        case VR_X: case VR_XO: value[j] = i->x; break;
        case VR_DER_X: value[j] = der_x(i); break;
        default: return bad_vr(i, "fmi2GetReal", vr[j]);
        }
    }
    return fmi2OK;
}
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real value[]) {
    Inst *i = (Inst *)c;
    fmi2Status s;
    for (size_t j = 0; j < n; j++) { /* check everything first: a rejected call changes nothing */
        switch (vr[j]) {
        case VR_RD: s = check_discrete_input(i); break;
        case VR_U: s = check_continuous_input(i); break;
        case VR_X: s = check_start_value(i, "x"); break;
        default: return bad_vr(i, "fmi2SetReal", vr[j]);
        }
        if (s != fmi2OK) return s;
    }
    for (size_t j = 0; j < n; j++) {
        if (vr[j] == VR_RD) i->r_d = value[j];
        else if (vr[j] == VR_U) i->u = value[j];
        else i->x = value[j];
    }
    return fmi2OK;
}
fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] == VR_K) v[j] = i->k;
        else if (vr[j] == VR_Y) v[j] = 2 * i->k;
        else return bad_vr(i, "fmi2GetInteger", vr[j]);
    }
    return fmi2OK;
}
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_K) return bad_vr(i, "fmi2SetInteger", vr[j]);
        if (check_discrete_input(i) != fmi2OK) return fmi2Error;
    }
    for (size_t j = 0; j < n; j++) i->k = v[j];
    return fmi2OK;
}
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_ON) return bad_vr(i, "fmi2GetBoolean", vr[j]);
        v[j] = i->on ? fmi2True : fmi2False;
    }
    return fmi2OK;
}
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_ON) return bad_vr(i, "fmi2SetBoolean", vr[j]);
        if (check_discrete_input(i) != fmi2OK) return fmi2Error;
    }
    for (size_t j = 0; j < n; j++) i->on = v[j] != fmi2False;
    return fmi2OK;
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
    const fmi2Integer order[], const fmi2Real value[]) { return fail((Inst *)c, "input derivatives not supported"); }
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
    const fmi2Integer order[], fmi2Real value[]) { return fail((Inst *)c, "output derivatives not supported"); }
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior) {
    Inst *i = (Inst *)c;
    if (i->mode != M_STEP) return fail(i, "fmi2DoStep called outside step mode");
    if (!(h >= 0)) return fail(i, "fmi2DoStep: negative step size");
    for (double left = h; left > 0;) {
        double s = left < H_INT ? left : H_INT;
        i->x += s * der_x(i);
        left -= s;
    }
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

/* model exchange: one state x, no event indicators; events come from the discrete inputs only */
fmi2Status fmi2EnterEventMode(fmi2Component c) {
    Inst *i = (Inst *)c;
    if (i->mode != M_CONT && i->mode != M_EVENT) return fail(i, "fmi2EnterEventMode called outside continuous-time mode");
    i->mode = M_EVENT;
    return fmi2OK;
}
fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *e) {
    Inst *i = (Inst *)c;
    if (i->mode != M_EVENT) return fail(i, "fmi2NewDiscreteStates called outside event mode");
    e->newDiscreteStatesNeeded = fmi2False; e->terminateSimulation = fmi2False;
    e->nominalsOfContinuousStatesChanged = fmi2False; e->valuesOfContinuousStatesChanged = fmi2False;
    e->nextEventTimeDefined = fmi2False; e->nextEventTime = 0;
    return fmi2OK;
}
fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c) {
    Inst *i = (Inst *)c;
    if (i->mode != M_EVENT) return fail(i, "fmi2EnterContinuousTimeMode called outside event mode");
    i->mode = M_CONT;
    return fmi2OK;
}
fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSet, fmi2Boolean *enter, fmi2Boolean *term) {
    *enter = fmi2False; *term = fmi2False; return fmi2OK;
}
fmi2Status fmi2SetTime(fmi2Component c, fmi2Real t) { ((Inst *)c)->time = t; return fmi2OK; }
fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t n) {
    Inst *i = (Inst *)c;
    if (n != 1) return fail(i, "fmi2SetContinuousStates: expected 1 state");
    i->x = x[0];
    return fmi2OK;
}
fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real dx[], size_t n) {
    Inst *i = (Inst *)c;
    if (n != 1) return fail(i, "fmi2GetDerivatives: expected 1 state");
    dx[0] = der_x(i);
    return fmi2OK;
}
fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real z[], size_t n) {
    return n ? fail((Inst *)c, "fmi2GetEventIndicators: the model has no event indicators") : fmi2OK;
}
fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t n) {
    Inst *i = (Inst *)c;
    if (n != 1) return fail(i, "fmi2GetContinuousStates: expected 1 state");
    x[0] = i->x;
    return fmi2OK;
}
fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x[], size_t n) {
    for (size_t j = 0; j < n; j++) x[j] = 1.0;
    return fmi2OK;
}
