/* FMI 2.0 co-simulation interface of a twmr-cosim block kernel (every Real is one element). */
#include <stdlib.h>
#include <string.h>
#include "fmi2Functions.h"
#include "instance.h"

#define INST ((Instance *)c)

static void log_fmi2(Instance *s, int status, const char *category, const char *message) {
    const fmi2CallbackFunctions *f = s->callbacks;
    if (f->logger) f->logger(f->componentEnvironment, s->name, (fmi2Status)status, category,
                             "%s", message);
}

static fmi2Status refuse(fmi2Component c, const char *what) {
    inst_log(INST, ST_ERROR, "logStatusError", "%s is not supported by this FMU", what);
    return fmi2Error;
}

const char *fmi2GetTypesPlatform(void) { return fmi2TypesPlatform; }
const char *fmi2GetVersion(void) { return fmi2Version; }

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean on, size_t n,
                               const fmi2String categories[]) {
    (void)n; (void)categories;
    INST->logging = on;
    return fmi2OK;
}

fmi2Component fmi2Instantiate(fmi2String name, fmi2Type type, fmi2String guid,
                              fmi2String location, const fmi2CallbackFunctions *functions,
                              fmi2Boolean visible, fmi2Boolean logging) {
    Instance *s;
    (void)location; (void)visible;
    if (!functions || !functions->allocateMemory || !functions->freeMemory) return NULL;
    if (type != fmi2CoSimulation || !guid || strcmp(guid, GUID) != 0) {
        if (functions->logger)
            functions->logger(functions->componentEnvironment, name, fmi2Error, "logStatusError",
                              type != fmi2CoSimulation ? "only co-simulation is supported"
                                                       : "wrong GUID (expected %s)", GUID);
        return NULL;
    }
    s = functions->allocateMemory(1, sizeof *s);
    if (!s) return NULL;
    s->name = functions->allocateMemory(strlen(name ? name : "") + 1, 1);
    if (!s->name) {
        functions->freeMemory(s);
        return NULL;
    }
    strcpy(s->name, name ? name : "");
    s->callbacks = functions;
    s->log = log_fmi2;
    s->logging = logging;
    inst_reset(s);
    return s;
}

void fmi2FreeInstance(fmi2Component c) {
    const fmi2CallbackFunctions *f;
    if (!c) return;
    f = INST->callbacks;
    f->freeMemory(INST->name);
    f->freeMemory(c);
}

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean tolerance_defined,
                               fmi2Real tolerance, fmi2Real start, fmi2Boolean stop_defined,
                               fmi2Real stop) {
    (void)tolerance_defined; (void)tolerance;
    if (INST->c.phase != PH_INSTANTIATED) return fmi2Error;
    if (stop_defined) INST->stop = stop;
    INST->c.start = start;
    INST->c.m.time = start;
    return fmi2OK;
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c) {
    return (fmi2Status)inst_enter_init(INST, INST->c.start);
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c) {
    return (fmi2Status)inst_exit_init(INST);
}

fmi2Status fmi2Terminate(fmi2Component c) {
    INST->c.phase = PH_TERMINATED;
    return fmi2OK;
}

fmi2Status fmi2Reset(fmi2Component c) {
    inst_reset(INST);
    return fmi2OK;
}

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                       fmi2Real value[]) {
    size_t i;
    for (i = 0; i < n; i++)
        if (inst_get(INST, vr[i], 1, &value[i]) != ST_OK) return fmi2Error;
    return fmi2OK;
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                       const fmi2Real value[]) {
    size_t i;
    for (i = 0; i < n; i++)
        if (inst_set(INST, vr[i], 1, &value[i]) != ST_OK) return fmi2Error;
    return fmi2OK;
}

/* no Integer, Boolean or String variables: any reference to one is an error */
fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                          fmi2Integer value[]) {
    (void)vr; (void)value;
    return n ? refuse(c, "an Integer variable") : fmi2OK;
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                          fmi2Boolean value[]) {
    (void)vr; (void)value;
    return n ? refuse(c, "a Boolean variable") : fmi2OK;
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                         fmi2String value[]) {
    (void)vr; (void)value;
    return n ? refuse(c, "a String variable") : fmi2OK;
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                          const fmi2Integer value[]) {
    (void)vr; (void)value;
    return n ? refuse(c, "an Integer variable") : fmi2OK;
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                          const fmi2Boolean value[]) {
    (void)vr; (void)value;
    return n ? refuse(c, "a Boolean variable") : fmi2OK;
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t n,
                         const fmi2String value[]) {
    (void)vr; (void)value;
    return n ? refuse(c, "a String variable") : fmi2OK;
}

/* FMU state: a copy of the instance's Core */
fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *state) {
    const fmi2CallbackFunctions *f = INST->callbacks;
    if (!*state) *state = f->allocateMemory(1, sizeof(Core));
    if (!*state) return fmi2Error;
    memcpy(*state, &INST->c, sizeof(Core));
    return fmi2OK;
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate state) {
    if (!state) return fmi2Error;
    memcpy(&INST->c, state, sizeof(Core));
    return fmi2OK;
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *state) {
    const fmi2CallbackFunctions *f = INST->callbacks;
    if (state && *state) {
        f->freeMemory(*state);
        *state = NULL;
    }
    return fmi2OK;
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate state, size_t *size) {
    (void)c; (void)state;
    *size = sizeof(Core);
    return fmi2OK;
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate state, fmi2Byte bytes[],
                                 size_t size) {
    (void)c;
    if (size < sizeof(Core)) return fmi2Error;
    memcpy(bytes, state, sizeof(Core));
    return fmi2OK;
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte bytes[], size_t size,
                                   fmi2FMUstate *state) {
    if (size != sizeof(Core)) return fmi2Error;
    if (fmi2GetFMUstate(c, state) != fmi2OK) return fmi2Error;
    memcpy(*state, bytes, sizeof(Core));
    return fmi2OK;
}

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference u[],
                                        size_t nu, const fmi2ValueReference z[], size_t nz,
                                        const fmi2Real dv[], fmi2Real dz[]) {
    (void)u; (void)nu; (void)z; (void)nz; (void)dv; (void)dz;
    return refuse(c, "fmi2GetDirectionalDerivative");
}

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                       size_t n, const fmi2Integer order[],
                                       const fmi2Real value[]) {
    (void)vr; (void)n; (void)order; (void)value;
    return refuse(c, "fmi2SetRealInputDerivatives");
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                        size_t n, const fmi2Integer order[],
                                        fmi2Real value[]) {
    (void)vr; (void)n; (void)order; (void)value;
    return refuse(c, "fmi2GetRealOutputDerivatives");
}

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real t, fmi2Real h, fmi2Boolean new_step) {
    (void)new_step;
    return (fmi2Status)inst_step(INST, t, h);
}

fmi2Status fmi2CancelStep(fmi2Component c) { return refuse(c, "fmi2CancelStep"); }

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind kind, fmi2Status *value) {
    (void)kind; (void)value;
    return refuse(c, "fmi2GetStatus (doStep never runs asynchronously)");
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind kind, fmi2Real *value) {
    if (kind != fmi2LastSuccessfulTime) return refuse(c, "this fmi2GetRealStatus kind");
    *value = INST->c.m.time;
    return fmi2OK;
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind kind,
                                fmi2Integer *value) {
    (void)kind; (void)value;
    return refuse(c, "fmi2GetIntegerStatus");
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind kind,
                                fmi2Boolean *value) {
    if (kind != fmi2Terminated) return refuse(c, "this fmi2GetBooleanStatus kind");
    *value = fmi2False;
    return fmi2OK;
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind kind, fmi2String *value) {
    (void)kind; (void)value;
    return refuse(c, "fmi2GetStringStatus");
}
