/* Mixed-type direct feedthrough: an FMI 2.0 co-simulation FMU (no model exchange interface).
 * Written for twmr-cosim's tests; built at test time against the FMI headers fmpy ships.
 *
 * Inputs r1 [N.m], r2 [rad/s] (Real), i1, i2 (Integer), b1 (Boolean), s1 (String).
 * Outputs, computed from the current inputs whenever they are read (direct feedthrough):
 * r1o = 2 r1, r2o = r2 + 1, i1o = i1 + 1, i2o = 3 i2, b1o = !b1, s1o = s1 (a copy of the string).
 * acc [N.m.s] integrates r1 over doStep (acc += r1 h for the input held over the step): it depends
 * on r1 only through the state, i.e. it is not direct feedthrough. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "fmi2Functions.h"

enum { VR_R1 = 0, VR_R2 = 1, VR_I1 = 2, VR_I2 = 3, VR_B1 = 4, VR_S1 = 5,
       VR_R1O = 6, VR_R2O = 7, VR_I1O = 8, VR_I2O = 9, VR_B1O = 10, VR_S1O = 11, VR_ACC = 12 };

typedef enum { M_INSTANTIATED, M_INIT, M_STEP, M_TERMINATED } Mode;

typedef struct {
    double r1, r2, acc, time;
    int i1, i2, b1;
    char *s1;
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
static char *copy_string(const char *s) {
    size_t n = strlen(s) + 1;
    char *p = (char *)malloc(n);
    if (p) memcpy(p, s, n);
    return p;
}
static int defaults(Inst *c) {
    c->r1 = 1.5; c->r2 = 0.5; c->acc = 0; c->time = 0; c->i1 = 3; c->i2 = -4; c->b1 = 0;
    free(c->s1);
    c->s1 = copy_string("hello");
    c->mode = M_INSTANTIATED;
    return c->s1 != NULL;
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }
fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[]) { return fmi2OK; }

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String loc,
                              const fmi2CallbackFunctions *cb, fmi2Boolean visible, fmi2Boolean log) {
    Inst *c = (Inst *)calloc(1, sizeof(Inst));
    if (!c) return NULL;
    if (cb) c->cb = *cb;
    snprintf(c->name, sizeof c->name, "%s", name ? name : "mixed2");
    if (type != fmi2CoSimulation) {
        fail(c, "mixed2 supports co-simulation only");
        free(c);
        return NULL;
    }
    if (!defaults(c)) { free(c); return NULL; }
    return c;
}
void fmi2FreeInstance(fmi2Component c) {
    if (!c) return;
    free(((Inst *)c)->s1);
    free(c);
}
fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolDef, fmi2Real tol, fmi2Real start,
                               fmi2Boolean stopDef, fmi2Real stop) { ((Inst *)c)->time = start; return fmi2OK; }
fmi2Status fmi2EnterInitializationMode(fmi2Component c) { ((Inst *)c)->mode = M_INIT; return fmi2OK; }
fmi2Status fmi2ExitInitializationMode(fmi2Component c) { ((Inst *)c)->mode = M_STEP; return fmi2OK; }
fmi2Status fmi2Terminate(fmi2Component c) { ((Inst *)c)->mode = M_TERMINATED; return fmi2OK; }
fmi2Status fmi2Reset(fmi2Component c) {
    Inst *i = (Inst *)c;
    return defaults(i) ? fmi2OK : fail(i, "out of memory");
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        switch (vr[j]) {
        case VR_R1: value[j] = i->r1; break;
        case VR_R2: value[j] = i->r2; break;
        case VR_R1O: value[j] = 2 * i->r1; break;
        case VR_R2O: value[j] = i->r2 + 1; break;
        case VR_ACC: value[j] = i->acc; break;
        default: return bad_vr(i, "fmi2GetReal", vr[j]);
        }
    }
    return fmi2OK;
}
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real value[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] == VR_ACC) {
            if (i->mode != M_INSTANTIATED && i->mode != M_INIT)
                return fail(i, "fmi2SetReal: acc can only be set before initialization is done");
        } else if (vr[j] != VR_R1 && vr[j] != VR_R2) return bad_vr(i, "fmi2SetReal", vr[j]);
    }
    for (size_t j = 0; j < n; j++) {
        if (vr[j] == VR_R1) i->r1 = value[j];
        else if (vr[j] == VR_R2) i->r2 = value[j];
        else i->acc = value[j];
    }
    return fmi2OK;
}
fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        switch (vr[j]) {
        case VR_I1: v[j] = i->i1; break;
        case VR_I2: v[j] = i->i2; break;
        case VR_I1O: v[j] = i->i1 + 1; break;
        case VR_I2O: v[j] = 3 * i->i2; break;
        default: return bad_vr(i, "fmi2GetInteger", vr[j]);
        }
    }
    return fmi2OK;
}
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++)
        if (vr[j] != VR_I1 && vr[j] != VR_I2) return bad_vr(i, "fmi2SetInteger", vr[j]);
    for (size_t j = 0; j < n; j++) {
        if (vr[j] == VR_I1) i->i1 = v[j]; else i->i2 = v[j];
    }
    return fmi2OK;
}
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] == VR_B1) v[j] = i->b1 ? fmi2True : fmi2False;
        else if (vr[j] == VR_B1O) v[j] = i->b1 ? fmi2False : fmi2True;
        else return bad_vr(i, "fmi2GetBoolean", vr[j]);
    }
    return fmi2OK;
}
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++)
        if (vr[j] != VR_B1) return bad_vr(i, "fmi2SetBoolean", vr[j]);
    for (size_t j = 0; j < n; j++) i->b1 = v[j] != fmi2False;
    return fmi2OK;
}
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_S1 && vr[j] != VR_S1O) return bad_vr(i, "fmi2GetString", vr[j]);
        v[j] = i->s1; /* valid until s1 is set again */
    }
    return fmi2OK;
}
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_S1) return bad_vr(i, "fmi2SetString", vr[j]);
        if (!v[j]) return fail(i, "fmi2SetString: NULL string");
    }
    for (size_t j = 0; j < n; j++) {
        char *s = copy_string(v[j]);
        if (!s) return fail(i, "out of memory");
        free(i->s1);
        i->s1 = s;
    }
    return fmi2OK;
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
    i->acc += i->r1 * h;
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
