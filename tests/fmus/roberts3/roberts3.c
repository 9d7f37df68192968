/* Robertson's stiff chemical kinetics as an FMI 3.0 model-exchange FMU, written for twmr-cosim's
 * tests (an FMU with a Boolean structural parameter, as the Modelica Association's Roberts has).
 * Built at test time against the FMI 3.0 headers fmpy ships (tests/fmu_build.py adds stubs
 * returning fmi3Error for the FMI 3.0 functions not defined here).
 *
 * States y1, y2: der(y1) = -k1 y1 + k3 y2 y3, der(y2) = k1 y1 - k3 y2 y3 - k2 y2^2, with
 * y3 = 1 - y1 - y2 (k1 = 0.04, k2 = 3e7, k3 = 1e4). The structural parameter `dae` (Boolean, set
 * in configuration mode) asks for the semi-explicit DAE form, which this FMU does not provide:
 * with dae true, fmi3EnterInitializationMode logs why and returns fmi3Error. */
#include <stdio.h>
#include <stdlib.h>
#include "fmi3Functions.h"

enum { VR_TIME = 0, VR_DAE = 1, VR_Y1 = 2, VR_DER_Y1 = 3, VR_Y2 = 4, VR_DER_Y2 = 5, VR_Y3 = 6,
       VR_K1 = 7, VR_K2 = 8, VR_K3 = 9 };

typedef enum { M_INSTANTIATED, M_CONFIG, M_INIT, M_EVENT, M_CONT, M_TERMINATED } Mode;

typedef struct {
    double y1, y2, k1, k2, k3, time;
    int dae;
    Mode mode;
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
static double y3(const Inst *c) { return 1.0 - c->y1 - c->y2; }
static double der_y1(const Inst *c) { return -c->k1 * c->y1 + c->k3 * c->y2 * y3(c); }
static double der_y2(const Inst *c) {
    return c->k1 * c->y1 - c->k3 * c->y2 * y3(c) - c->k2 * c->y2 * c->y2;
}

const char *fmi3GetVersion(void) { return fmi3Version; }
fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean on, size_t n, const fmi3String cat[]) { return fmi3OK; }

fmi3Instance fmi3InstantiateModelExchange(fmi3String name, fmi3String token, fmi3String res,
    fmi3Boolean visible, fmi3Boolean log, fmi3InstanceEnvironment env, fmi3LogMessageCallback logMessage) {
    Inst *c = (Inst *)calloc(1, sizeof(Inst));
    if (!c) return NULL;
    c->env = env; c->log = logMessage;
    c->y1 = 1.0; c->y2 = 0.0; c->k1 = 0.04; c->k2 = 3e7; c->k3 = 1e4;
    c->mode = M_INSTANTIATED;
    return c;
}
void fmi3FreeInstance(fmi3Instance c) { free(c); }

fmi3Status fmi3EnterConfigurationMode(fmi3Instance c) {
    Inst *i = (Inst *)c;
    if (i->mode != M_INSTANTIATED) return fail(i, "fmi3EnterConfigurationMode: not in the instantiated state");
    i->mode = M_CONFIG;
    return fmi3OK;
}
fmi3Status fmi3ExitConfigurationMode(fmi3Instance c) {
    Inst *i = (Inst *)c;
    if (i->mode != M_CONFIG) return fail(i, "fmi3ExitConfigurationMode: not in configuration mode");
    i->mode = M_INSTANTIATED;
    return fmi3OK;
}
fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean tolDef, fmi3Float64 tol,
    fmi3Float64 start, fmi3Boolean stopDef, fmi3Float64 stop) {
    Inst *i = (Inst *)c;
    if (i->dae) return fail(i, "roberts3: dae = true (the semi-explicit DAE form) is not provided by this FMU");
    i->time = start; i->mode = M_INIT;
    return fmi3OK;
}
fmi3Status fmi3ExitInitializationMode(fmi3Instance c) { ((Inst *)c)->mode = M_EVENT; return fmi3OK; }
fmi3Status fmi3EnterEventMode(fmi3Instance c) { ((Inst *)c)->mode = M_EVENT; return fmi3OK; }
fmi3Status fmi3Terminate(fmi3Instance c) { ((Inst *)c)->mode = M_TERMINATED; return fmi3OK; }
fmi3Status fmi3Reset(fmi3Instance c) { return fail((Inst *)c, "fmi3Reset: not supported"); }

fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Float64 v[], size_t nv) {
    Inst *i = (Inst *)c;
    if (nv != n) return fail(i, "fmi3GetFloat64: nValues must equal nValueReferences (no arrays)");
    for (size_t j = 0; j < n; j++) {
        switch (vr[j]) {
        case VR_TIME: v[j] = i->time; break;
        case VR_Y1: v[j] = i->y1; break;
        case VR_DER_Y1: v[j] = der_y1(i); break;
        case VR_Y2: v[j] = i->y2; break;
        case VR_DER_Y2: v[j] = der_y2(i); break;
        case VR_Y3: v[j] = y3(i); break;
        case VR_K1: v[j] = i->k1; break;
        case VR_K2: v[j] = i->k2; break;
        case VR_K3: v[j] = i->k3; break;
        default: return bad_vr(i, "fmi3GetFloat64", vr[j]);
        }
    }
    return fmi3OK;
}
fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Float64 v[], size_t nv) {
    Inst *i = (Inst *)c;
    if (nv != n) return fail(i, "fmi3SetFloat64: nValues must equal nValueReferences (no arrays)");
    if (i->mode != M_INSTANTIATED && i->mode != M_INIT)
        return fail(i, "fmi3SetFloat64: y1, y2, k1, k2 and k3 can only be set before initialization is done");
    for (size_t j = 0; j < n; j++) {
        switch (vr[j]) {
        case VR_Y1: i->y1 = v[j]; break;
        case VR_Y2: i->y2 = v[j]; break;
        case VR_K1: i->k1 = v[j]; break;
        case VR_K2: i->k2 = v[j]; break;
        case VR_K3: i->k3 = v[j]; break;
        default: return bad_vr(i, "fmi3SetFloat64", vr[j]);
        }
    }
    return fmi3OK;
}
fmi3Status fmi3GetBoolean(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Boolean v[], size_t nv) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_DAE) return bad_vr(i, "fmi3GetBoolean", vr[j]);
        v[j] = i->dae ? fmi3True : fmi3False;
    }
    return fmi3OK;
}
fmi3Status fmi3SetBoolean(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Boolean v[], size_t nv) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_DAE) return bad_vr(i, "fmi3SetBoolean", vr[j]);
        if (i->mode != M_CONFIG) return fail(i, "fmi3SetBoolean: dae is set only in configuration mode");
        i->dae = v[j] ? 1 : 0;
    }
    return fmi3OK;
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance c, fmi3Boolean *needUpdate, fmi3Boolean *terminate,
    fmi3Boolean *nominalsChanged, fmi3Boolean *valuesChanged, fmi3Boolean *nextDefined, fmi3Float64 *next) {
    Inst *i = (Inst *)c;
    if (i->mode != M_EVENT) return fail(i, "fmi3UpdateDiscreteStates called outside event mode");
    *needUpdate = fmi3False; *terminate = fmi3False; *nominalsChanged = fmi3False;
    *valuesChanged = fmi3False; *nextDefined = fmi3False; *next = 0;
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
    i->y1 = x[0]; i->y2 = x[1];
    return fmi3OK;
}
fmi3Status fmi3GetContinuousStates(fmi3Instance c, fmi3Float64 x[], size_t n) {
    Inst *i = (Inst *)c;
    if (n != 2) return fail(i, "fmi3GetContinuousStates: expected 2 states");
    x[0] = i->y1; x[1] = i->y2;
    return fmi3OK;
}
fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance c, fmi3Float64 dx[], size_t n) {
    Inst *i = (Inst *)c;
    if (n != 2) return fail(i, "fmi3GetContinuousStateDerivatives: expected 2 states");
    dx[0] = der_y1(i); dx[1] = der_y2(i);
    return fmi3OK;
}
fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance c, fmi3Float64 x[], size_t n) {
    Inst *i = (Inst *)c;
    if (n != 2) return fail(i, "fmi3GetNominalsOfContinuousStates: expected 2 states");
    x[0] = 1.0; x[1] = 1e-5;
    return fmi3OK;
}
fmi3Status fmi3GetEventIndicators(fmi3Instance c, fmi3Float64 z[], size_t n) {
    return n == 0 ? fmi3OK : fail((Inst *)c, "fmi3GetEventIndicators: there are none");
}
fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance c, size_t *n) { *n = 0; return fmi3OK; }
fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance c, size_t *n) { *n = 2; return fmi3OK; }
