/* An FMI 3.0 co-simulation FMU that declares a clock: the input clock `tick`
 * (intervalVariability="triggered") and the Int32 output `ticks`, clocked by tick.
 * Written for twmr-cosim's tests of clocks in co-simulation;
 * built at test time against the FMI 3.0 headers fmpy ships (tests/fmu_build.py adds stubs returning
 * fmi3Error for the FMI 3.0 functions not defined here).
 * Minimal behaviour: an importer using event mode (eventModeUsed = true; initialization then ends in
 * event mode) may activate tick with fmi3SetClock in event mode, which counts it in ticks (one per
 * activation, until the next fmi3UpdateDiscreteStates). doStep only advances the time. */
#include <stdio.h>
#include <stdlib.h>
#include "fmi3Functions.h"

enum { VR_TIME = 0, VR_TICK = 1, VR_TICKS = 2 };

typedef enum { M_INSTANTIATED, M_INIT, M_EVENT, M_STEP, M_TERMINATED } Mode;

typedef struct {
    double time;
    int ticks, active, event_mode_used;
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
static void defaults(Inst *c) { c->time = 0; c->ticks = 0; c->active = 0; c->mode = M_INSTANTIATED; }

const char *fmi3GetVersion(void) { return fmi3Version; }
fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean on, size_t n, const fmi3String cat[]) { return fmi3OK; }

fmi3Instance fmi3InstantiateCoSimulation(fmi3String name, fmi3String token, fmi3String res,
    fmi3Boolean visible, fmi3Boolean log, fmi3Boolean eventModeUsed, fmi3Boolean earlyReturn,
    const fmi3ValueReference req[], size_t nreq, fmi3InstanceEnvironment env,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback update) {
    Inst *c = (Inst *)calloc(1, sizeof(Inst));
    if (!c) return NULL;
    c->env = env; c->log = logMessage; c->event_mode_used = eventModeUsed;
    defaults(c);
    return c;
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
    i->mode = i->event_mode_used ? M_EVENT : M_STEP; /* with event mode used, initialization ends in event mode */
    return fmi3OK;
}
fmi3Status fmi3EnterEventMode(fmi3Instance c) { ((Inst *)c)->mode = M_EVENT; return fmi3OK; }
fmi3Status fmi3EnterStepMode(fmi3Instance c) { ((Inst *)c)->mode = M_STEP; return fmi3OK; }
fmi3Status fmi3Terminate(fmi3Instance c) { ((Inst *)c)->mode = M_TERMINATED; return fmi3OK; }
fmi3Status fmi3Reset(fmi3Instance c) { defaults((Inst *)c); return fmi3OK; }

fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Float64 v[], size_t nv) {
    Inst *i = (Inst *)c;
    if (nv != n) return fail(i, "fmi3GetFloat64: nValues must equal nValueReferences (no arrays)");
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_TIME) return bad_vr(i, "fmi3GetFloat64", vr[j]);
        v[j] = i->time;
    }
    return fmi3OK;
}
fmi3Status fmi3GetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Int32 v[], size_t nv) {
    Inst *i = (Inst *)c;
    if (nv != n) return fail(i, "fmi3GetInt32: nValues must equal nValueReferences (no arrays)");
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_TICKS) return bad_vr(i, "fmi3GetInt32", vr[j]);
        v[j] = i->ticks;
    }
    return fmi3OK;
}
fmi3Status fmi3SetClock(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Clock v[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_TICK) return bad_vr(i, "fmi3SetClock", vr[j]);
        if (i->mode != M_EVENT) return fail(i, "fmi3SetClock: clocks can only be set in event mode");
    }
    for (size_t j = 0; j < n; j++) if (v[j] && !i->active) { i->active = 1; i->ticks++; }
    return fmi3OK;
}
fmi3Status fmi3GetClock(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Clock v[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_TICK) return bad_vr(i, "fmi3GetClock", vr[j]);
        v[j] = i->active ? fmi3ClockActive : fmi3ClockInactive;
    }
    return fmi3OK;
}
fmi3Status fmi3UpdateDiscreteStates(fmi3Instance c, fmi3Boolean *needUpdate, fmi3Boolean *terminate,
    fmi3Boolean *nominalsChanged, fmi3Boolean *valuesChanged, fmi3Boolean *nextDefined, fmi3Float64 *next) {
    Inst *i = (Inst *)c;
    if (i->mode != M_EVENT) return fail(i, "fmi3UpdateDiscreteStates called outside event mode");
    i->active = 0;
    *needUpdate = fmi3False; *terminate = fmi3False; *nominalsChanged = fmi3False;
    *valuesChanged = fmi3False; *nextDefined = fmi3False; *next = 0;
    return fmi3OK;
}
fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 t, fmi3Float64 h, fmi3Boolean noSetPrior,
    fmi3Boolean *eventNeeded, fmi3Boolean *terminate, fmi3Boolean *early, fmi3Float64 *last) {
    Inst *i = (Inst *)c;
    if (i->mode != M_STEP) return fail(i, "fmi3DoStep called outside step mode");
    i->time = t + h;
    *eventNeeded = fmi3False; *terminate = fmi3False; *early = fmi3False; *last = t + h;
    return fmi3OK;
}
