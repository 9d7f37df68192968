/* A co-simulation FMU (FMI 2.0) that misbehaves on demand, for testing how importers survive a bad FMU.
 * Written for twmr-cosim's tests; built at test time against the FMI headers fmpy ships.
 * y counts the completed doStep calls, y2 = 2 u. Once the count reaches fail_after, doStep does what
 * mode says: 0 nothing, 1 segfault, 2 exit(0), 3 hang forever, 4 return fmi2Error, 5 set y to NaN,
 * 6 end the simulation, 7 fork a child that sleeps for ever (the step then completes), 8 write a
 * 4-byte length header to every socket it holds, then hang.
 * Its state can be saved, restored and serialised; a saved state carries STATE_BALLAST bytes beside
 * the model's values, as a real model's solver data would, so a leak of states shows in memory. */
#define _POSIX_C_SOURCE 200809L
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#ifdef _WIN32
#include <windows.h>
#else
#include <sys/socket.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>
#endif
#include "fmi2Functions.h"

#define NR 3 /* Real: y, y2, u */
#define NI 2 /* Integer: fail_after, mode */
typedef struct { double r[NR]; int i[NI]; long count; double time; fmi2CallbackFunctions cb; fmi2String name; int terminated; } Inst;
#define STATE_BALLAST 16384
typedef struct { double r[NR]; int i[NI]; long count; double time; int terminated; char ballast[STATE_BALLAST]; } State;

static void log_msg(Inst *c, fmi2Status s, const char *cat, const char *msg) {
    if (c->cb.logger) c->cb.logger(c->cb.componentEnvironment, c->name, s, cat, msg);
}
static fmi2Status bad_vr(Inst *c) { log_msg(c, fmi2Error, "error", "invalid value reference"); return fmi2Error; }
static void defaults(Inst *c) {
    memset(c->r, 0, sizeof(c->r)); c->i[0] = 1000000; c->i[1] = 0; c->count = 0; c->time = 0; c->terminated = 0;
}
static void sleep_10ms(void) {
#ifdef _WIN32
    Sleep(10);
#else
    struct timespec ts = {0, 10000000L};
    nanosleep(&ts, NULL);
#endif
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }
fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n, const fmi2String cat[]) { return fmi2OK; }

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid, fmi2String loc,
                              const fmi2CallbackFunctions *cb, fmi2Boolean visible, fmi2Boolean log) {
    if (type != fmi2CoSimulation) return NULL;
    Inst *c = (Inst *)calloc(1, sizeof(Inst));
    if (!c) return NULL;
    defaults(c);
    if (cb) c->cb = *cb;
    c->name = name;
    if (strcmp(name, "refuse") == 0) { /* an instance named 'refuse' fails to instantiate */
        log_msg(c, fmi2Error, "logStatusError", "faulty: instantiation refused on purpose");
        free(c);
        return NULL;
    }
    log_msg(c, fmi2OK, "logAll", "faulty: instantiated");
    return c;
}
void fmi2FreeInstance(fmi2Component c) { free(c); }
fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolDef, fmi2Real tol, fmi2Real start,
                               fmi2Boolean stopDef, fmi2Real stop) { ((Inst *)c)->time = start; return fmi2OK; }
fmi2Status fmi2EnterInitializationMode(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2ExitInitializationMode(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2Terminate(fmi2Component c) { return fmi2OK; }
fmi2Status fmi2Reset(fmi2Component c) { defaults((Inst *)c); return fmi2OK; }

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Real value[]) {
    Inst *i = (Inst *)c;
    i->r[1] = 2.0 * i->r[2]; /* y2 = 2 u: direct feedthrough */
    for (size_t j = 0; j < n; j++) { if (vr[j] >= NR) return bad_vr(i); value[j] = i->r[vr[j]]; }
    return fmi2OK;
}
fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Real value[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] >= NR || vr[j] == 1) return bad_vr(i); /* y2 is calculated; y: initial="exact" */
        i->r[vr[j]] = value[j];
    }
    return fmi2OK;
}
fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Integer v[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) { if (vr[j] >= NI) return bad_vr(i); v[j] = i->i[vr[j]]; }
    return fmi2OK;
}
fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Integer v[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) { if (vr[j] >= NI) return bad_vr(i); i->i[vr[j]] = v[j]; }
    return fmi2OK;
}
fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2Boolean v[]) { return n ? fmi2Error : fmi2OK; }
fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2Boolean v[]) { return n ? fmi2Error : fmi2OK; }
fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, fmi2String v[]) { return n ? fmi2Error : fmi2OK; }
fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n, const fmi2String v[]) { return n ? fmi2Error : fmi2OK; }

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s) {
    Inst *i = (Inst *)c;
    State *st = (State *)(*s ? *s : calloc(1, sizeof(State))); /* a state given back is reused */
    if (!st) return fmi2Error;
    memcpy(st->r, i->r, sizeof(i->r)); memcpy(st->i, i->i, sizeof(i->i));
    st->count = i->count; st->time = i->time; st->terminated = i->terminated;
    memset(st->ballast, (int)(i->count & 0x7f), sizeof(st->ballast)); /* touched: resident */
    *s = st;
    return fmi2OK;
}
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) {
    Inst *i = (Inst *)c; State *st = (State *)s;
    if (!st) return fmi2Error;
    memcpy(i->r, st->r, sizeof(i->r)); memcpy(i->i, st->i, sizeof(i->i));
    i->count = st->count; i->time = st->time; i->terminated = st->terminated;
    return fmi2OK;
}
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s) { free(*s); *s = NULL; return fmi2OK; }
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *n) { *n = sizeof(State); return fmi2OK; }
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n) {
    if (!s || n != sizeof(State)) return fmi2Error;
    memcpy(b, s, sizeof(State));
    return fmi2OK;
}
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s) {
    if (n != sizeof(State)) return fmi2Error;
    State *st = (State *)(*s ? *s : malloc(sizeof(State)));
    if (!st) return fmi2Error;
    memcpy(st, b, sizeof(State));
    *s = st;
    return fmi2OK;
}
fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference a[], size_t na,
    const fmi2ValueReference b[], size_t nb, const fmi2Real dv[], fmi2Real df[]) { return fmi2Error; }

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
    const fmi2Integer order[], const fmi2Real value[]) { return fmi2Error; }
fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t n,
    const fmi2Integer order[], fmi2Real value[]) { return fmi2Error; }
fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean noSetPrior) {
    Inst *i = (Inst *)c;
    if (h < 0) return fmi2Error;
    i->count++;
    i->r[0] = (double)i->count;
    i->time = t + h;
    if (i->count >= i->i[0]) {
        switch (i->i[1]) {
        case 1: { volatile int *volatile p = NULL; *p = 1; break; } /* segmentation fault */
        case 2: exit(0);
        case 3: /* hang forever */
            log_msg(i, fmi2OK, "logAll", "faulty: hanging in doStep");
            for (;;) sleep_10ms();
        case 4: {
            char msg[128];
            snprintf(msg, sizeof(msg), "faulty: doStep failed on purpose at step %ld", i->count);
            log_msg(i, fmi2Error, "logStatusError", msg);
            return fmi2Error;
        }
        case 5: i->r[0] = NAN; break;
        case 6: i->terminated = 1; return fmi2Discard; /* the model ends the simulation */
#ifndef _WIN32
        case 7: /* once: a child that outlives the step */
            if (i->count == i->i[0] && fork() == 0) for (;;) sleep_10ms();
            break;
        case 8: { /* a length header on every socket, never followed by its message */
            const unsigned char header[4] = {0, 0, 0, 16};
            for (int fd = 3; fd < 256; fd++) {
                struct stat sb;
                if (fstat(fd, &sb) == 0 && S_ISSOCK(sb.st_mode)) (void)!write(fd, header, 4);
            }
            for (;;) sleep_10ms();
        }
#endif
        default: break;
        }
    }
    return fmi2OK;
}
fmi2Status fmi2CancelStep(fmi2Component c) { return fmi2Error; }
fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *v) { return fmi2Error; }
fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *v) { *v = ((Inst *)c)->time; return fmi2OK; }
fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *v) { return fmi2Error; }
fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *v) {
    if (s != fmi2Terminated) return fmi2Error;
    *v = ((Inst *)c)->terminated ? fmi2True : fmi2False;
    return fmi2OK;
}
fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *v) { return fmi2Error; }
