/* Every FMI 3.0 variable type, fed through: an FMI 3.0 FMU for co-simulation and model exchange
 * (no continuous states, no event indicators, no clocks).
 * Written for twmr-cosim's tests; built at test time against the FMI 3.0 headers fmpy ships
 * (tests/fmu_build.py adds stubs returning fmi3Error for the FMI 3.0 functions not defined here).
 *
 * For each type T of Float32, Float64, Int8, UInt8, Int16, UInt16, Int32, UInt32, Int64, UInt64,
 * Boolean, String, Binary and Enumeration: output T_output = input T_input (direct feedthrough).
 * Arrays: vec_out = 2 vec_in (fixed size 3); scaled[i] = gains[i] vec_in[i] for i < n, where the
 * structural parameter n (1..NMAX, start 3) sizes gains and scaled. n can be set in the instantiated
 * state and in configuration mode; gains (a fixed parameter) before initialization is done.
 * Array values are passed flattened: nValues must be the total number of elements of the variables
 * addressed, otherwise the call fails with fmi3Error. Calls that fail change nothing. */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "fmi3Functions.h"

#define NMAX 5
enum {
    VR_TIME = 0,
    VR_F32_IN = 1, VR_F32_OUT = 2, VR_F64_IN = 3, VR_F64_OUT = 4,
    VR_I8_IN = 5, VR_I8_OUT = 6, VR_U8_IN = 7, VR_U8_OUT = 8,
    VR_I16_IN = 9, VR_I16_OUT = 10, VR_U16_IN = 11, VR_U16_OUT = 12,
    VR_I32_IN = 13, VR_I32_OUT = 14, VR_U32_IN = 15, VR_U32_OUT = 16,
    VR_I64_IN = 17, VR_I64_OUT = 18, VR_U64_IN = 19, VR_U64_OUT = 20,
    VR_BOOL_IN = 21, VR_BOOL_OUT = 22, VR_STR_IN = 23, VR_STR_OUT = 24,
    VR_BIN_IN = 25, VR_BIN_OUT = 26, VR_ENUM_IN = 27, VR_ENUM_OUT = 28,
    VR_VEC_IN = 29, VR_VEC_OUT = 30, VR_N = 31, VR_GAINS = 32, VR_SCALED = 33
};

typedef enum { M_INSTANTIATED, M_CONFIG, M_INIT, M_EVENT, M_CONT, M_STEP, M_TERMINATED } Mode;

typedef struct {
    fmi3Float32 f32; fmi3Float64 f64;
    fmi3Int8 i8; fmi3UInt8 u8; fmi3Int16 i16; fmi3UInt16 u16;
    fmi3Int32 i32; fmi3UInt32 u32; fmi3Int64 i64; fmi3UInt64 u64;
    fmi3Boolean b; char *str; fmi3Byte *bin; size_t bin_size; fmi3Int64 en;
    double vec[3]; fmi3UInt64 n; double gains[NMAX];
    double time;
    Mode mode;
    int cs;
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
static fmi3Status bad_count(Inst *c, const char *fn) {
    char msg[160];
    snprintf(msg, sizeof msg, "%s: nValues does not match the sizes of the variables", fn);
    return fail(c, msg);
}
static int input_settable(const Inst *c) { return c->mode != M_CONFIG && c->mode != M_TERMINATED; }
static int before_init_done(const Inst *c) { return c->mode == M_INSTANTIATED || c->mode == M_INIT; }

static int set_binary(Inst *c, const fmi3Byte *data, size_t size) {
    fmi3Byte *p = (fmi3Byte *)malloc(size ? size : 1);
    if (!p) return 0;
    if (size) memcpy(p, data, size);
    free(c->bin); c->bin = p; c->bin_size = size;
    return 1;
}
static int set_string(Inst *c, const char *s) {
    size_t n = strlen(s) + 1;
    char *p = (char *)malloc(n);
    if (!p) return 0;
    memcpy(p, s, n);
    free(c->str); c->str = p;
    return 1;
}
static int defaults(Inst *c) {
    static const fmi3Byte bin0[] = {0x0a, 0x0b};
    c->f32 = 1.5f; c->f64 = 2.25; c->i8 = -8; c->u8 = 200; c->i16 = -300; c->u16 = 60000;
    c->i32 = -70000; c->u32 = 4000000000u; c->i64 = -7; c->u64 = 9000000000ull; c->b = fmi3True;
    c->en = 2;
    c->vec[0] = 1; c->vec[1] = 2; c->vec[2] = 3;
    c->n = 3;
    for (int j = 0; j < NMAX; j++) c->gains[j] = 1.0;
    c->time = 0;
    c->mode = M_INSTANTIATED;
    return set_string(c, "abc") && set_binary(c, bin0, sizeof bin0);
}
static Inst *create(fmi3InstanceEnvironment env, fmi3LogMessageCallback log, int cs) {
    Inst *c = (Inst *)calloc(1, sizeof(Inst));
    if (!c) return NULL;
    c->env = env; c->log = log; c->cs = cs;
    if (!defaults(c)) { free(c->str); free(c->bin); free(c); return NULL; }
    return c;
}

const char *fmi3GetVersion(void) { return fmi3Version; }
fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean on, size_t n, const fmi3String cat[]) { return fmi3OK; }

fmi3Instance fmi3InstantiateModelExchange(fmi3String name, fmi3String token, fmi3String res,
    fmi3Boolean visible, fmi3Boolean log, fmi3InstanceEnvironment env, fmi3LogMessageCallback logMessage) {
    return create(env, logMessage, 0);
}
fmi3Instance fmi3InstantiateCoSimulation(fmi3String name, fmi3String token, fmi3String res,
    fmi3Boolean visible, fmi3Boolean log, fmi3Boolean eventModeUsed, fmi3Boolean earlyReturn,
    const fmi3ValueReference req[], size_t nreq, fmi3InstanceEnvironment env,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback update) {
    return create(env, logMessage, 1);
}
void fmi3FreeInstance(fmi3Instance inst) {
    Inst *c = (Inst *)inst;
    if (!c) return;
    free(c->str); free(c->bin); free(c);
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance inst) {
    Inst *c = (Inst *)inst;
    if (c->mode != M_INSTANTIATED) return fail(c, "fmi3EnterConfigurationMode: only from the instantiated state");
    c->mode = M_CONFIG;
    return fmi3OK;
}
fmi3Status fmi3ExitConfigurationMode(fmi3Instance inst) {
    Inst *c = (Inst *)inst;
    if (c->mode != M_CONFIG) return fail(c, "fmi3ExitConfigurationMode: not in configuration mode");
    c->mode = M_INSTANTIATED;
    return fmi3OK;
}
fmi3Status fmi3EnterInitializationMode(fmi3Instance inst, fmi3Boolean tolDef, fmi3Float64 tol,
    fmi3Float64 start, fmi3Boolean stopDef, fmi3Float64 stop) {
    Inst *c = (Inst *)inst;
    if (c->mode != M_INSTANTIATED) return fail(c, "fmi3EnterInitializationMode: only from the instantiated state");
    c->time = start; c->mode = M_INIT;
    return fmi3OK;
}
fmi3Status fmi3ExitInitializationMode(fmi3Instance inst) {
    Inst *c = (Inst *)inst;
    if (c->mode != M_INIT) return fail(c, "fmi3ExitInitializationMode: not in initialization mode");
    c->mode = c->cs ? M_STEP : M_EVENT;
    return fmi3OK;
}
fmi3Status fmi3EnterEventMode(fmi3Instance inst) { ((Inst *)inst)->mode = M_EVENT; return fmi3OK; }
fmi3Status fmi3Terminate(fmi3Instance inst) { ((Inst *)inst)->mode = M_TERMINATED; return fmi3OK; }
fmi3Status fmi3Reset(fmi3Instance inst) {
    Inst *c = (Inst *)inst;
    return defaults(c) ? fmi3OK : fail(c, "out of memory");
}

/* ---- scalar integer and Boolean types: T_output = T_input ---- */
#define GET_SCALAR(FN, FIELD, VIN, VOUT)                                          \
    Inst *c = (Inst *)inst;                                                       \
    if (nv != n) return bad_count(c, FN);                                         \
    for (size_t j = 0; j < n; j++) {                                              \
        if (vr[j] != VIN && vr[j] != VOUT) return bad_vr(c, FN, vr[j]);           \
        v[j] = c->FIELD;                                                          \
    }                                                                             \
    return fmi3OK;
#define SET_SCALAR(FN, FIELD, VIN)                                                \
    Inst *c = (Inst *)inst;                                                       \
    if (nv != n) return bad_count(c, FN);                                         \
    for (size_t j = 0; j < n; j++) {                                              \
        if (vr[j] != VIN) return bad_vr(c, FN, vr[j]);                            \
        if (!input_settable(c)) return fail(c, FN ": inputs cannot be set now");  \
    }                                                                             \
    for (size_t j = 0; j < n; j++) c->FIELD = v[j];                               \
    return fmi3OK;

fmi3Status fmi3GetFloat32(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, fmi3Float32 v[], size_t nv) { GET_SCALAR("fmi3GetFloat32", f32, VR_F32_IN, VR_F32_OUT) }
fmi3Status fmi3SetFloat32(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, const fmi3Float32 v[], size_t nv) { SET_SCALAR("fmi3SetFloat32", f32, VR_F32_IN) }
fmi3Status fmi3GetInt8(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, fmi3Int8 v[], size_t nv) { GET_SCALAR("fmi3GetInt8", i8, VR_I8_IN, VR_I8_OUT) }
fmi3Status fmi3SetInt8(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, const fmi3Int8 v[], size_t nv) { SET_SCALAR("fmi3SetInt8", i8, VR_I8_IN) }
fmi3Status fmi3GetUInt8(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, fmi3UInt8 v[], size_t nv) { GET_SCALAR("fmi3GetUInt8", u8, VR_U8_IN, VR_U8_OUT) }
fmi3Status fmi3SetUInt8(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, const fmi3UInt8 v[], size_t nv) { SET_SCALAR("fmi3SetUInt8", u8, VR_U8_IN) }
fmi3Status fmi3GetInt16(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, fmi3Int16 v[], size_t nv) { GET_SCALAR("fmi3GetInt16", i16, VR_I16_IN, VR_I16_OUT) }
fmi3Status fmi3SetInt16(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, const fmi3Int16 v[], size_t nv) { SET_SCALAR("fmi3SetInt16", i16, VR_I16_IN) }
fmi3Status fmi3GetUInt16(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, fmi3UInt16 v[], size_t nv) { GET_SCALAR("fmi3GetUInt16", u16, VR_U16_IN, VR_U16_OUT) }
fmi3Status fmi3SetUInt16(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, const fmi3UInt16 v[], size_t nv) { SET_SCALAR("fmi3SetUInt16", u16, VR_U16_IN) }
fmi3Status fmi3GetInt32(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, fmi3Int32 v[], size_t nv) { GET_SCALAR("fmi3GetInt32", i32, VR_I32_IN, VR_I32_OUT) }
fmi3Status fmi3SetInt32(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, const fmi3Int32 v[], size_t nv) { SET_SCALAR("fmi3SetInt32", i32, VR_I32_IN) }
fmi3Status fmi3GetUInt32(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, fmi3UInt32 v[], size_t nv) { GET_SCALAR("fmi3GetUInt32", u32, VR_U32_IN, VR_U32_OUT) }
fmi3Status fmi3SetUInt32(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, const fmi3UInt32 v[], size_t nv) { SET_SCALAR("fmi3SetUInt32", u32, VR_U32_IN) }
fmi3Status fmi3GetBoolean(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, fmi3Boolean v[], size_t nv) { GET_SCALAR("fmi3GetBoolean", b, VR_BOOL_IN, VR_BOOL_OUT) }
fmi3Status fmi3SetBoolean(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, const fmi3Boolean v[], size_t nv) { SET_SCALAR("fmi3SetBoolean", b, VR_BOOL_IN) }

/* Int64 carries Int64_input/output and the Enumeration variables (items 1..3) */
fmi3Status fmi3GetInt64(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, fmi3Int64 v[], size_t nv) {
    Inst *c = (Inst *)inst;
    if (nv != n) return bad_count(c, "fmi3GetInt64");
    for (size_t j = 0; j < n; j++) {
        if (vr[j] == VR_I64_IN || vr[j] == VR_I64_OUT) v[j] = c->i64;
        else if (vr[j] == VR_ENUM_IN || vr[j] == VR_ENUM_OUT) v[j] = c->en;
        else return bad_vr(c, "fmi3GetInt64", vr[j]);
    }
    return fmi3OK;
}
fmi3Status fmi3SetInt64(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, const fmi3Int64 v[], size_t nv) {
    Inst *c = (Inst *)inst;
    if (nv != n) return bad_count(c, "fmi3SetInt64");
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_I64_IN && vr[j] != VR_ENUM_IN) return bad_vr(c, "fmi3SetInt64", vr[j]);
        if (!input_settable(c)) return fail(c, "fmi3SetInt64: inputs cannot be set now");
        if (vr[j] == VR_ENUM_IN && (v[j] < 1 || v[j] > 3))
            return fail(c, "fmi3SetInt64: Enumeration_input must be one of the items 1, 2, 3");
    }
    for (size_t j = 0; j < n; j++) {
        if (vr[j] == VR_I64_IN) c->i64 = v[j]; else c->en = v[j];
    }
    return fmi3OK;
}
/* UInt64 carries UInt64_input/output and the structural parameter n */
fmi3Status fmi3GetUInt64(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, fmi3UInt64 v[], size_t nv) {
    Inst *c = (Inst *)inst;
    if (nv != n) return bad_count(c, "fmi3GetUInt64");
    for (size_t j = 0; j < n; j++) {
        if (vr[j] == VR_U64_IN || vr[j] == VR_U64_OUT) v[j] = c->u64;
        else if (vr[j] == VR_N) v[j] = c->n;
        else return bad_vr(c, "fmi3GetUInt64", vr[j]);
    }
    return fmi3OK;
}
fmi3Status fmi3SetUInt64(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, const fmi3UInt64 v[], size_t nv) {
    Inst *c = (Inst *)inst;
    if (nv != n) return bad_count(c, "fmi3SetUInt64");
    for (size_t j = 0; j < n; j++) {
        if (vr[j] == VR_U64_IN) {
            if (!input_settable(c)) return fail(c, "fmi3SetUInt64: inputs cannot be set now");
        } else if (vr[j] == VR_N) {
            if (c->mode != M_INSTANTIATED && c->mode != M_CONFIG)
                return fail(c, "fmi3SetUInt64: n can only be set in the instantiated state or configuration mode");
            if (v[j] < 1 || v[j] > NMAX) return fail(c, "fmi3SetUInt64: n must be in 1..5");
        } else return bad_vr(c, "fmi3SetUInt64", vr[j]);
    }
    for (size_t j = 0; j < n; j++) {
        if (vr[j] == VR_U64_IN) c->u64 = v[j]; else c->n = v[j];
    }
    return fmi3OK;
}

/* ---- Float64: scalars and arrays ---- */
static size_t f64_size(const Inst *c, fmi3ValueReference vr) {
    switch (vr) {
    case VR_TIME: case VR_F64_IN: case VR_F64_OUT: return 1;
    case VR_VEC_IN: case VR_VEC_OUT: return 3;
    case VR_GAINS: case VR_SCALED: return (size_t)c->n;
    default: return 0;
    }
}
fmi3Status fmi3GetFloat64(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, fmi3Float64 v[], size_t nv) {
    Inst *c = (Inst *)inst;
    size_t total = 0;
    for (size_t j = 0; j < n; j++) {
        size_t s = f64_size(c, vr[j]);
        if (!s) return bad_vr(c, "fmi3GetFloat64", vr[j]);
        total += s;
    }
    if (total != nv) return bad_count(c, "fmi3GetFloat64");
    size_t k = 0;
    for (size_t j = 0; j < n; j++) {
        switch (vr[j]) {
        case VR_TIME: v[k++] = c->time; break;
        case VR_F64_IN: case VR_F64_OUT: v[k++] = c->f64; break;
        case VR_VEC_IN: for (int i = 0; i < 3; i++) v[k++] = c->vec[i]; break;
        case VR_VEC_OUT: for (int i = 0; i < 3; i++) v[k++] = 2 * c->vec[i]; break;
        case VR_GAINS: for (size_t i = 0; i < c->n; i++) v[k++] = c->gains[i]; break;
        default: /* scaled: gains[i] vec_in[i]; vec_in has 3 elements, beyond them vec_in counts as 0 */
            for (size_t i = 0; i < c->n; i++) v[k++] = c->gains[i] * (i < 3 ? c->vec[i] : 0.0);
            break;
        }
    }
    return fmi3OK;
}
fmi3Status fmi3SetFloat64(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, const fmi3Float64 v[], size_t nv) {
    Inst *c = (Inst *)inst;
    size_t total = 0;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] == VR_F64_IN || vr[j] == VR_VEC_IN) {
            if (!input_settable(c)) return fail(c, "fmi3SetFloat64: inputs cannot be set now");
        } else if (vr[j] == VR_GAINS) {
            if (!before_init_done(c)) return fail(c, "fmi3SetFloat64: gains can only be set before initialization is done");
        } else return bad_vr(c, "fmi3SetFloat64", vr[j]);
        total += f64_size(c, vr[j]);
    }
    if (total != nv) return bad_count(c, "fmi3SetFloat64");
    size_t k = 0;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] == VR_F64_IN) c->f64 = v[k++];
        else if (vr[j] == VR_VEC_IN) for (int i = 0; i < 3; i++) c->vec[i] = v[k++];
        else for (size_t i = 0; i < c->n; i++) c->gains[i] = v[k++];
    }
    return fmi3OK;
}

/* ---- String and Binary ---- */
fmi3Status fmi3GetString(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, fmi3String v[], size_t nv) {
    Inst *c = (Inst *)inst;
    if (nv != n) return bad_count(c, "fmi3GetString");
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_STR_IN && vr[j] != VR_STR_OUT) return bad_vr(c, "fmi3GetString", vr[j]);
        v[j] = c->str; /* valid until String_input is set again */
    }
    return fmi3OK;
}
fmi3Status fmi3SetString(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, const fmi3String v[], size_t nv) {
    Inst *c = (Inst *)inst;
    if (nv != n) return bad_count(c, "fmi3SetString");
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_STR_IN) return bad_vr(c, "fmi3SetString", vr[j]);
        if (!input_settable(c)) return fail(c, "fmi3SetString: inputs cannot be set now");
        if (!v[j]) return fail(c, "fmi3SetString: NULL string");
    }
    for (size_t j = 0; j < n; j++)
        if (!set_string(c, v[j])) return fail(c, "out of memory");
    return fmi3OK;
}
fmi3Status fmi3GetBinary(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, size_t sizes[],
                         fmi3Binary v[], size_t nv) {
    Inst *c = (Inst *)inst;
    if (nv != n) return bad_count(c, "fmi3GetBinary");
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_BIN_IN && vr[j] != VR_BIN_OUT) return bad_vr(c, "fmi3GetBinary", vr[j]);
        sizes[j] = c->bin_size;
        v[j] = c->bin; /* valid until Binary_input is set again */
    }
    return fmi3OK;
}
fmi3Status fmi3SetBinary(fmi3Instance inst, const fmi3ValueReference vr[], size_t n, const size_t sizes[],
                         const fmi3Binary v[], size_t nv) {
    Inst *c = (Inst *)inst;
    if (nv != n) return bad_count(c, "fmi3SetBinary");
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_BIN_IN) return bad_vr(c, "fmi3SetBinary", vr[j]);
        if (!input_settable(c)) return fail(c, "fmi3SetBinary: inputs cannot be set now");
        if (!v[j] && sizes[j]) return fail(c, "fmi3SetBinary: NULL data");
    }
    for (size_t j = 0; j < n; j++)
        if (!set_binary(c, v[j], sizes[j])) return fail(c, "out of memory");
    return fmi3OK;
}

/* ---- model exchange: no continuous states, no event indicators ---- */
fmi3Status fmi3UpdateDiscreteStates(fmi3Instance inst, fmi3Boolean *needUpdate, fmi3Boolean *terminate,
    fmi3Boolean *nominalsChanged, fmi3Boolean *valuesChanged, fmi3Boolean *nextDefined, fmi3Float64 *next) {
    Inst *c = (Inst *)inst;
    if (c->mode != M_EVENT) return fail(c, "fmi3UpdateDiscreteStates called outside event mode");
    *needUpdate = fmi3False; *terminate = fmi3False; *nominalsChanged = fmi3False;
    *valuesChanged = fmi3False; *nextDefined = fmi3False; *next = 0;
    return fmi3OK;
}
fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance inst) { ((Inst *)inst)->mode = M_CONT; return fmi3OK; }
fmi3Status fmi3CompletedIntegratorStep(fmi3Instance inst, fmi3Boolean noSet, fmi3Boolean *enter, fmi3Boolean *term) {
    *enter = fmi3False; *term = fmi3False; return fmi3OK;
}
fmi3Status fmi3SetTime(fmi3Instance inst, fmi3Float64 t) { ((Inst *)inst)->time = t; return fmi3OK; }
fmi3Status fmi3SetContinuousStates(fmi3Instance inst, const fmi3Float64 x[], size_t n) {
    return n ? fail((Inst *)inst, "fmi3SetContinuousStates: the model has no continuous states") : fmi3OK;
}
fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance inst, fmi3Float64 dx[], size_t n) {
    return n ? fail((Inst *)inst, "fmi3GetContinuousStateDerivatives: the model has no continuous states") : fmi3OK;
}
fmi3Status fmi3GetEventIndicators(fmi3Instance inst, fmi3Float64 z[], size_t n) {
    return n ? fail((Inst *)inst, "fmi3GetEventIndicators: the model has no event indicators") : fmi3OK;
}
fmi3Status fmi3GetContinuousStates(fmi3Instance inst, fmi3Float64 x[], size_t n) {
    return n ? fail((Inst *)inst, "fmi3GetContinuousStates: the model has no continuous states") : fmi3OK;
}
fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance inst, fmi3Float64 x[], size_t n) {
    return n ? fail((Inst *)inst, "fmi3GetNominalsOfContinuousStates: the model has no continuous states") : fmi3OK;
}
fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance inst, size_t *n) { *n = 0; return fmi3OK; }
fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance inst, size_t *n) { *n = 0; return fmi3OK; }

/* ---- co-simulation ---- */
fmi3Status fmi3EnterStepMode(fmi3Instance inst) { ((Inst *)inst)->mode = M_STEP; return fmi3OK; }
fmi3Status fmi3DoStep(fmi3Instance inst, fmi3Float64 t, fmi3Float64 h, fmi3Boolean noSetPrior,
    fmi3Boolean *eventNeeded, fmi3Boolean *terminate, fmi3Boolean *early, fmi3Float64 *last) {
    Inst *c = (Inst *)inst;
    if (c->mode != M_STEP) return fail(c, "fmi3DoStep called outside step mode");
    if (!(h >= 0)) return fail(c, "fmi3DoStep: negative step size");
    c->time = t + h;
    *eventNeeded = fmi3False; *terminate = fmi3False; *early = fmi3False; *last = t + h;
    return fmi3OK;
}
