/* Units: an FMI 2.0 co-simulation FMU (no model exchange interface) whose variables carry units
 * with offsets, scale factors and no base unit at all (see modelDescription.xml).
 * Written for twmr-cosim's tests; built at test time against the FMI headers fmpy ships.
 * temp_out = temp_in [degF], len_out = len_in [myLen], w = 1 [widget], plain = 5 (no unit); all
 * outputs are direct feedthrough / constant, doStep only advances the time. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "fmi2Functions.h"

enum { VR_TEMP_IN = 0, VR_TEMP_OUT = 1, VR_LEN_IN = 2, VR_LEN_OUT = 3, VR_W = 4, VR_PLAIN = 5 };

typedef enum { M_INSTANTIATED, M_INIT, M_STEP, M_TERMINATED } Mode;

typedef struct {
    double temp, len, time;
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
static void defaults(Inst *c) { c->temp = 212.0; c->len = 1.0; c->time = 0; c->mode = M_INSTANTIATED; }

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }
fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[]) { return fmi2OK; }

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String loc,
                              const fmi2CallbackFunctions *cb, fmi2Boolean visible, fmi2Boolean log) {
    Inst *c = (Inst *)calloc(1, sizeof(Inst));
    if (!c) return NULL;
    if (cb) c->cb = *cb;
    snprintf(c->name, sizeof c->name, "%s", name ? name : "units2");
    if (type != fmi2CoSimulation) {
        fail(c, "units2 supports co-simulation only");
        free(c);
        return NULL;
    }
    defaults(c);
    return c;
}
void fmi2FreeInstance(fmi2Component c) { free(c); }
fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolDef, fmi2Real tol, fmi2Real start,
                               fmi2Boolean stopDef, fmi2Real stop) { ((Inst *)c)->time = start; return fmi2OK; }
fmi2Status fmi2EnterInitializationMode(fmi2Component c) { ((Inst *)c)->mode = M_INIT; return fmi2OK; }
fmi2Status fmi2ExitInitializationMode(fmi2Component c) { ((Inst *)c)->mode = M_STEP; return fmi2OK; }
fmi2Status fmi2Terminate(fmi2Component c) { ((Inst *)c)->mode = M_TERMINATED; return fmi2OK; }
fmi2Status fmi2Reset(fmi2Component c) { defaults((Inst *)c); return fmi2OK; }

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        switch (vr[j]) {
        case VR_TEMP_IN: case VR_TEMP_OUT: value[j] = i->temp; break;
        case VR_LEN_IN: case VR_LEN_OUT: value[j] = i->len; break;
        case VR_W: value[j] = 1.0; break;
        case VR_PLAIN: value[j] = 5.0; break;
        default: return bad_vr(i, "fmi2GetReal", vr[j]);
        }
    }
    return fmi2OK;
}
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real value[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++)
        if (vr[j] != VR_TEMP_IN && vr[j] != VR_LEN_IN) return bad_vr(i, "fmi2SetReal", vr[j]);
    for (size_t j = 0; j < n; j++) {
        if (vr[j] == VR_TEMP_IN) i->temp = value[j]; else i->len = value[j];
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

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
    const fmi2Integer order[], const fmi2Real value[]) { return fail((Inst *)c, "input derivatives not supported"); }
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
    const fmi2Integer order[], fmi2Real value[]) { return fail((Inst *)c, "output derivatives not supported"); }
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior) {
    Inst *i = (Inst *)c;
    if (i->mode != M_STEP) return fail(i, "fmi2DoStep called outside step mode");
    if (!(h >= 0)) return fail(i, "fmi2DoStep: negative step size");
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
