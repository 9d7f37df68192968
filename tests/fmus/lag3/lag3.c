/* The lag2 model as an FMI 3.0 co-simulation FMU (the functions fmpy calls for co-simulation).
 * Its state can be saved, restored and serialised (the instance's values and time, as bytes).
 * Written for twmr-cosim's tests; built at test time against the FMI 3.0 headers fmpy ships. */
#include <math.h>
#include <stdlib.h>
#include <string.h>
#include "fmi3Functions.h"

#define NV 6
typedef struct { double v[NV]; double time; } Inst;

const char *fmi3GetVersion(void) { return fmi3Version; }
fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean on, size_t n, const fmi3String cat[]) { return fmi3OK; }

fmi3Instance fmi3InstantiateCoSimulation(fmi3String name, fmi3String token, fmi3String res,
    fmi3Boolean visible, fmi3Boolean log, fmi3Boolean eventMode, fmi3Boolean earlyReturn,
    const fmi3ValueReference req[], size_t nreq, fmi3InstanceEnvironment env,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback update) {
    Inst *c = (Inst *)calloc(1, sizeof(Inst));
    if (c) { c->v[0] = 2.0; c->v[1] = 0.5; }
    return c;
}
void fmi3FreeInstance(fmi3Instance c) { free(c); }
fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean tolDef, fmi3Float64 tol,
    fmi3Float64 start, fmi3Boolean stopDef, fmi3Float64 stop) { ((Inst *)c)->time = start; return fmi3OK; }
fmi3Status fmi3ExitInitializationMode(fmi3Instance c) { return fmi3OK; }
fmi3Status fmi3Terminate(fmi3Instance c) { return fmi3OK; }
fmi3Status fmi3Reset(fmi3Instance c) { return fmi3OK; }

fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Float64 v[], size_t nv) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] == 99) { v[j] = i->time; continue; }
        if (vr[j] >= NV) return fmi3Error;
        v[j] = i->v[vr[j]];
    }
    return fmi3OK;
}
fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Float64 v[], size_t nv) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] >= NV) return fmi3Error;
        if (vr[j] == 1 && !(v[j] > 0)) return fmi3Error;
        i->v[vr[j]] = v[j];
    }
    return fmi3OK;
}
fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 t, fmi3Float64 h, fmi3Boolean noSetPrior,
    fmi3Boolean *eventNeeded, fmi3Boolean *terminate, fmi3Boolean *early, fmi3Float64 *last) {
    Inst *i = (Inst *)c;
    double a = 1.0 - exp(-h / i->v[1]);
    for (int j = 0; j < 2; j++) i->v[4 + j] += (i->v[0] * i->v[2 + j] - i->v[4 + j]) * a;
    i->time = t + h;
    *eventNeeded = fmi3False; *terminate = fmi3False; *early = fmi3False; *last = t + h;
    return fmi3OK;
}

fmi3Status fmi3GetFMUState(fmi3Instance c, fmi3FMUState *s) {
    Inst *st = (Inst *)(*s ? *s : malloc(sizeof(Inst))); /* a state given back is reused */
    if (!st) return fmi3Error;
    memcpy(st, c, sizeof(Inst)); *s = st; return fmi3OK;
}
fmi3Status fmi3SetFMUState(fmi3Instance c, fmi3FMUState s) {
    if (!s) return fmi3Error;
    memcpy(c, s, sizeof(Inst)); return fmi3OK;
}
fmi3Status fmi3FreeFMUState(fmi3Instance c, fmi3FMUState *s) { free(*s); *s = NULL; return fmi3OK; }
fmi3Status fmi3SerializedFMUStateSize(fmi3Instance c, fmi3FMUState s, size_t *n) { *n = sizeof(Inst); return fmi3OK; }
fmi3Status fmi3SerializeFMUState(fmi3Instance c, fmi3FMUState s, fmi3Byte b[], size_t n) {
    if (!s || n != sizeof(Inst)) return fmi3Error;
    memcpy(b, s, sizeof(Inst)); return fmi3OK;
}
fmi3Status fmi3DeserializeFMUState(fmi3Instance c, const fmi3Byte b[], size_t n, fmi3FMUState *s) {
    if (n != sizeof(Inst)) return fmi3Error;
    Inst *st = (Inst *)(*s ? *s : malloc(sizeof(Inst)));
    if (!st) return fmi3Error;
    memcpy(st, b, sizeof(Inst)); *s = st; return fmi3OK;
}
