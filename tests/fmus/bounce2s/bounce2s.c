/* bounce2 (tests/fmus/bounce2) with its state: the same ball, FMI 2.0, model exchange and
 * co-simulation, whose instance can get, set and serialise its state (the model's values: h, v,
 * g, e, time, bounces, the at-rest flag and the mode). Written for twmr-cosim's tests.
 * bounce2.c is compiled in as it is; its six FMU-state functions, which refuse, are renamed out of
 * the way by the macros below (after the header, whose own macros name them) and defined
 * again after it. */
#include <stddef.h>
#include "fmi2Functions.h"
#undef fmi2GetFMUstate
#define fmi2GetFMUstate bounce2_no_GetFMUstate
#undef fmi2SetFMUstate
#define fmi2SetFMUstate bounce2_no_SetFMUstate
#undef fmi2FreeFMUstate
#define fmi2FreeFMUstate bounce2_no_FreeFMUstate
#undef fmi2SerializedFMUstateSize
#define fmi2SerializedFMUstateSize bounce2_no_SerializedFMUstateSize
#undef fmi2SerializeFMUstate
#define fmi2SerializeFMUstate bounce2_no_SerializeFMUstate
#undef fmi2DeSerializeFMUstate
#define fmi2DeSerializeFMUstate bounce2_no_DeSerializeFMUstate
#include "../bounce2/bounce2.c"
#undef fmi2GetFMUstate
#undef fmi2SetFMUstate
#undef fmi2FreeFMUstate
#undef fmi2SerializedFMUstateSize
#undef fmi2SerializeFMUstate
#undef fmi2DeSerializeFMUstate

/* the saved part of an instance: everything before the callbacks */
#define SAVED offsetof(Inst, cb)

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *s) {
    if (*s == NULL) *s = malloc(SAVED);
    if (*s == NULL) return fail((Inst *)c, "fmi2GetFMUstate: out of memory");
    memcpy(*s, c, SAVED);
    return fmi2OK;
}
fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate s) {
    if (s == NULL) return fail((Inst *)c, "fmi2SetFMUstate: no state");
    memcpy(c, s, SAVED);
    return fmi2OK;
}
fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *s) {
    free(*s);
    *s = NULL;
    return fmi2OK;
}
fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate s, size_t *n) {
    *n = SAVED;
    return fmi2OK;
}
fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate s, fmi2Byte b[], size_t n) {
    if (n != SAVED) return fail((Inst *)c, "fmi2SerializeFMUstate: wrong buffer size");
    memcpy(b, s, SAVED);
    return fmi2OK;
}
fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte b[], size_t n, fmi2FMUstate *s) {
    if (n != SAVED) return fail((Inst *)c, "fmi2DeSerializeFMUstate: wrong size (not a bounce2s state)");
    *s = malloc(SAVED);
    if (*s == NULL) return fail((Inst *)c, "fmi2DeSerializeFMUstate: out of memory");
    memcpy(*s, b, SAVED);
    return fmi2OK;
}
