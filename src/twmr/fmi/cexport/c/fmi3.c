/* FMI 3.0 co-simulation interface of a twmr-cosim block kernel: every element is one scalar
 * Float64 variable; the other types, model exchange, clocks and events are refused. Built with
 * BUS_TERMINAL (a controller exported with --can), the FMU is also an FMI-LS-BUS CAN node with
 * the terminal CanChannel (node.h): it runs in event mode, the frames received on Rx_Data go to
 * the protocol's node_receive, and Tx_Clock (a triggered output clock) ticks when
 * initialization ends (the drives' start-up frames and the first torques), in the event where
 * the drives' feedback of a period is complete (the torques from the inputs at that point, as
 * the block's evaluate), and at the end of a doStep in which nothing was sent (the torques
 * from the inputs held over the step: a lost answer does not stop the exchange). The drives
 * are stopped (node_stop: zero torque, then disabled) at fmi3Terminate from step or event
 * mode, those frames readable on Tx_Data in the Terminated state, and on any fault the node
 * sees: a Bus Error or a bus-off Status on Rx_Data, malformed Rx_Data, or drive.watchdog_periods
 * steps in a row without the drives' feedback (the host watchdog). A fault is latched: no
 * torque is sent after it, and doStep and fmi3UpdateDiscreteStates ask to terminate. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "fmi3Functions.h"
#include "instance.h"
#ifdef BUS_TERMINAL
#include "node.h"
#endif

#define INST ((Instance *)instance)

static void log_fmi3(Instance *s, int status, const char *category, const char *message) {
    fmi3LogMessageCallback f = (fmi3LogMessageCallback)s->callbacks;
    if (f) f(s->env, (fmi3Status)status, category, message);
}

static fmi3Status unsupported(fmi3Instance instance, const char *what) {
    inst_log(INST, ST_ERROR, "logStatusError", "%s is not supported by this FMU", what);
    return fmi3Error;
}

const char *fmi3GetVersion(void) { return fmi3Version; }

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean on, size_t n,
                               const fmi3String categories[]) {
    (void)n; (void)categories;
    INST->logging = on;
    return fmi3OK;
}

fmi3Instance fmi3InstantiateCoSimulation(
    fmi3String name, fmi3String token, fmi3String resources, fmi3Boolean visible,
    fmi3Boolean logging, fmi3Boolean event_mode, fmi3Boolean early_return,
    const fmi3ValueReference intermediate[], size_t n_intermediate, fmi3InstanceEnvironment env,
    fmi3LogMessageCallback log, fmi3IntermediateUpdateCallback update) {
    Instance *s;
    (void)resources; (void)visible; (void)intermediate; (void)n_intermediate; (void)update;
    (void)early_return;
#ifdef BUS_TERMINAL
    if (!token || strcmp(token, GUID) != 0 || !event_mode) {
        if (log) log(env, fmi3Error, "logStatusError", !event_mode
                     ? "a bus node needs event mode (eventModeUsed = true)"
                     : "wrong instantiation token");
        return NULL;
    }
#else
    if (!token || strcmp(token, GUID) != 0 || event_mode) {
        if (log) log(env, fmi3Error, "logStatusError", event_mode
                     ? "event mode is not supported" : "wrong instantiation token");
        return NULL;
    }
#endif
    s = calloc(1, sizeof *s);
    if (!s) return NULL;
    s->name = malloc(strlen(name ? name : "") + 1);
    if (!s->name) {
        free(s);
        return NULL;
    }
    strcpy(s->name, name ? name : "");
    s->env = env;
    s->callbacks = (const void *)log;
    s->log = log_fmi3;
    s->logging = logging;
    inst_reset(s);
    return s;
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String name, fmi3String token,
                                          fmi3String resources, fmi3Boolean visible,
                                          fmi3Boolean logging, fmi3InstanceEnvironment env,
                                          fmi3LogMessageCallback log) {
    (void)name; (void)token; (void)resources; (void)visible; (void)logging;
    if (log) log(env, fmi3Error, "logStatusError", "only co-simulation is supported");
    return NULL;
}

fmi3Instance fmi3InstantiateScheduledExecution(
    fmi3String name, fmi3String token, fmi3String resources, fmi3Boolean visible,
    fmi3Boolean logging, fmi3InstanceEnvironment env, fmi3LogMessageCallback log,
    fmi3ClockUpdateCallback clock, fmi3LockPreemptionCallback lock,
    fmi3UnlockPreemptionCallback unlock) {
    (void)name; (void)token; (void)resources; (void)visible; (void)logging; (void)clock;
    (void)lock; (void)unlock;
    if (log) log(env, fmi3Error, "logStatusError", "only co-simulation is supported");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance) {
    if (!instance) return;
    free(INST->name);
    free(instance);
}

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean tolerance_defined,
                                       fmi3Float64 tolerance, fmi3Float64 start,
                                       fmi3Boolean stop_defined, fmi3Float64 stop) {
    (void)tolerance_defined; (void)tolerance;
    if (stop_defined) INST->stop = stop;
    return (fmi3Status)inst_enter_init(INST, start);
}

#ifdef BUS_TERMINAL
/* the frames of one controller period, sent at the next tick of Tx_Clock (none after a
 * fault) */
static void transmit(Instance *s) {
    if (s->c.fault) return;
    kernel_eval(&s->c.m);
    s->c.dirty = 0;
    node_transmit(&s->c.m, s->c.node, &s->c.tx);
    s->c.tx_active = 1;
    s->c.sent = 1;
    if (s->c.tx.overflow) {
        inst_log(s, ST_WARNING, "logStatusWarning", "%d bus operations did not fit in Tx_Data "
                 "(%d bytes) and were dropped", s->c.tx.overflow, LSBUS_TX_BYTES);
        s->c.tx.overflow = 0;
    }
}

/* the frames that stop the drives, in place of any not yet sent, at the next tick */
static void stop_drives(Instance *s) {
    s->c.tx.n = 0;
    node_stop(&s->c.m, s->c.node, &s->c.tx, s->c.fault);
    s->c.tx_active = 1;
    s->c.tx_reported = 0;
    s->c.sent = 1;
}

/* a fault seen on the bus: latched, the drives stopped, the simulation asked to end */
static void fault(Instance *s, const char *what) {
    if (s->c.fault) return;
    s->c.fault = 1;
    stop_drives(s);
    inst_log(s, ST_ERROR, "logStatusError", "%s at t = %.9g s: the drives were sent zero torque "
             "and the protocol's stop on a fault; the FMU asks to terminate", what, s->c.m.time);
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    const char *why;
    if (INST->c.phase != PH_INITIALIZATION) return fmi3Error;
    why = node_check(&INST->c.m);
    if (why) {
        inst_log(INST, ST_ERROR, "logStatusError", "%s", why);
        return fmi3Error;
    }
    if (inst_exit_init(INST) != ST_OK) return fmi3Error;
    INST->c.event_mode = 1;
    node_start(&INST->c.m, INST->c.node, &INST->c.tx);
    transmit(INST);
    return fmi3OK;
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance) {
    if (INST->c.phase != PH_STEP) return unsupported(instance, "event mode outside step mode");
    INST->c.event_mode = 1;
    return fmi3OK;
}

fmi3Status fmi3EnterStepMode(fmi3Instance instance) {
    if (INST->c.phase != PH_STEP || !INST->c.event_mode) return fmi3Error;
    INST->c.event_mode = 0;
    return fmi3OK;
}

static fmi3Status bad_vr(fmi3Instance instance, const char *fn, fmi3ValueReference vr) {
    inst_log(INST, ST_ERROR, "logStatusError", "%s: value reference %u is not one of its "
             "type", fn, (unsigned)vr);
    return fmi3Error;
}

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t n,
                         size_t sizes[], fmi3Binary values[], size_t n_values) {
    size_t i;
    (void)n_values;
    for (i = 0; i < n; i++) {
        if (vr[i] != VR_TX_DATA) return bad_vr(instance, "fmi3GetBinary", vr[i]);
        if (!INST->c.tx_active || (!INST->c.event_mode && INST->c.phase != PH_TERMINATED)) {
            inst_log(INST, ST_ERROR, "logStatusError", "CanChannel.Tx_Data is readable only in "
                     "event mode while CanChannel.Tx_Clock ticks, and after fmi3Terminate");
            return fmi3Error;
        }
        values[i] = INST->c.tx.b;
        sizes[i] = INST->c.tx.n;
    }
    return fmi3OK;
}

/* the operations received: each CAN Transmit to the protocol, a Bus Error or a bus-off Status
 * a fault, the others ignored; the period's frames sent when they completed its feedback */
static fmi3Status receive(Instance *s, const unsigned char *bytes, size_t size) {
    long at = 0;
    unsigned code;
    int complete = 0;
    char what[96];
    CanFrame f;
    while ((at = lsbus_next(bytes, size, (size_t)at, &code, &f)) > 0) {
        if (code == LSBUS_CAN_TRANSMIT) {
            complete |= node_receive(&s->c.m, s->c.node, &f);
        } else if (code == LSBUS_BUS_ERROR && f.length >= 7) {
            sprintf(what, "a bus error (code %u) on frame 0x%lx", f.data[4],
                    f.data[0] | (unsigned long)f.data[1] << 8 | (unsigned long)f.data[2] << 16 |
                    (unsigned long)f.data[3] << 24);
            fault(s, what);
        } else if (code == LSBUS_STATUS && f.length >= 1 && f.data[0] == LSBUS_BUS_OFF) {
            fault(s, "bus-off");
        }
    }
    if (at < 0) {
        fault(s, "malformed bus operations on CanChannel.Rx_Data");
        return fmi3Error;
    }
    s->c.dirty = 1;
    if (complete) {
        s->c.quiet = 0;
        transmit(s);
    }
    return fmi3OK;
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference vr[], size_t n,
                         const size_t sizes[], const fmi3Binary values[], size_t n_values) {
    size_t i;
    (void)n_values;
    for (i = 0; i < n; i++) {
        if (vr[i] != VR_RX_DATA) return bad_vr(instance, "fmi3SetBinary", vr[i]);
        if (!INST->c.event_mode || !INST->c.rx_active) {
            inst_log(INST, ST_ERROR, "logStatusError", "CanChannel.Rx_Data is settable only in "
                     "event mode after CanChannel.Rx_Clock was activated");
            return fmi3Error;
        }
        if (receive(INST, values[i], sizes[i]) != fmi3OK) return fmi3Error;
    }
    return fmi3OK;
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t n,
                        const fmi3Clock values[]) {
    size_t i;
    if (!INST->c.event_mode) return unsupported(instance, "setting a clock outside event mode");
    for (i = 0; i < n; i++) {
        if (vr[i] != VR_RX_CLOCK) return bad_vr(instance, "fmi3SetClock", vr[i]);
        if (values[i]) INST->c.rx_active = 1;
    }
    return fmi3OK;
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference vr[], size_t n,
                        fmi3Clock values[]) {
    size_t i;
    if (!INST->c.event_mode) return unsupported(instance, "getting a clock outside event mode");
    for (i = 0; i < n; i++) {
        if (vr[i] != VR_TX_CLOCK) return bad_vr(instance, "fmi3GetClock", vr[i]);
        values[i] = INST->c.tx_active && !INST->c.tx_reported;
        INST->c.tx_reported = INST->c.tx_active;
    }
    return fmi3OK;
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *need_update,
                                    fmi3Boolean *terminate, fmi3Boolean *nominals_changed,
                                    fmi3Boolean *values_changed, fmi3Boolean *next_defined,
                                    fmi3Float64 *next_time) {
    if (!INST->c.event_mode) return unsupported(instance, "fmi3UpdateDiscreteStates outside "
                                                "event mode");
    if (INST->c.tx_active) INST->c.tx.n = 0;
    INST->c.tx_active = INST->c.tx_reported = INST->c.rx_active = 0;
    *need_update = *nominals_changed = *values_changed = *next_defined = fmi3False;
    *terminate = INST->c.fault != 0;
    *next_time = 0.0;
    return fmi3OK;
}
#else
fmi3Status fmi3ExitInitializationMode(fmi3Instance instance) {
    return (fmi3Status)inst_exit_init(INST);
}

fmi3Status fmi3EnterStepMode(fmi3Instance instance) {
    return INST->c.phase == PH_STEP ? fmi3OK : fmi3Error;
}
#endif

fmi3Status fmi3Terminate(fmi3Instance instance) {
#ifdef BUS_TERMINAL
    if (INST->c.phase == PH_STEP) stop_drives(INST);
#endif
    INST->c.phase = PH_TERMINATED;
    return fmi3OK;
}

fmi3Status fmi3Reset(fmi3Instance instance) {
    inst_reset(INST);
    return fmi3OK;
}

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference vr[], size_t n,
                          fmi3Float64 values[], size_t n_values) {
    size_t i;
    if (n_values != n) return unsupported(instance, "an array variable");
    for (i = 0; i < n; i++) {
        if (vr[i] == NV)  /* the independent variable */
            values[i] = INST->c.m.time;
        else if (inst_get(INST, vr[i], 1, &values[i]) != ST_OK)
            return fmi3Error;
    }
    return fmi3OK;
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference vr[], size_t n,
                          const fmi3Float64 values[], size_t n_values) {
    size_t i;
    if (n_values != n) return unsupported(instance, "an array variable");
    for (i = 0; i < n; i++)
        if (inst_set(INST, vr[i], 1, &values[i]) != ST_OK) return fmi3Error;
    return fmi3OK;
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 t, fmi3Float64 h,
                      fmi3Boolean no_set_prior, fmi3Boolean *event_handling_needed,
                      fmi3Boolean *terminate, fmi3Boolean *early_return,
                      fmi3Float64 *last_time) {
    fmi3Status status;
    (void)no_set_prior;
#ifdef BUS_TERMINAL
    if (INST->c.event_mode) return unsupported(instance, "fmi3DoStep in event mode");
#endif
    status = (fmi3Status)inst_step(INST, t, h);
    *event_handling_needed = fmi3False;
#ifdef BUS_TERMINAL
    if (status == fmi3OK) {  /* nothing sent in this step: the outputs at t + h, inputs held */
        if (!INST->c.sent && !INST->c.fault) {
            if (++INST->c.quiet >= (long)INST->c.m.v[V_drive_watchdog_periods])
                fault(INST, "host watchdog: no feedback from the drives for "
                      "drive.watchdog_periods steps");
            else
                transmit(INST);
            *event_handling_needed = fmi3True;
        }
        INST->c.sent = 0;
    }
    *terminate = INST->c.fault != 0;
#else
    *terminate = fmi3False;
#endif
    *early_return = fmi3False;
    *last_time = status == fmi3OK ? t + h : t;
    return status;
}

/* FMU state: a copy of the instance's Core */
fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *state) {
    if (!*state) *state = malloc(sizeof(Core));
    if (!*state) return fmi3Error;
    memcpy(*state, &INST->c, sizeof(Core));
    return fmi3OK;
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState state) {
    if (!state) return fmi3Error;
    memcpy(&INST->c, state, sizeof(Core));
    return fmi3OK;
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *state) {
    (void)instance;
    if (state) {
        free(*state);
        *state = NULL;
    }
    return fmi3OK;
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState state, size_t *size) {
    (void)instance; (void)state;
    *size = sizeof(Core);
    return fmi3OK;
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState state,
                                 fmi3Byte bytes[], size_t size) {
    (void)instance;
    if (size < sizeof(Core)) return fmi3Error;
    memcpy(bytes, state, sizeof(Core));
    return fmi3OK;
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte bytes[], size_t size,
                                   fmi3FMUState *state) {
    if (size != sizeof(Core)) return fmi3Error;
    *state = NULL;
    if (fmi3GetFMUState(instance, state) != fmi3OK) return fmi3Error;
    memcpy(*state, bytes, sizeof(Core));
    return fmi3OK;
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance) {
    return unsupported(instance, "configuration mode (no structural parameters)");
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance) {
    return unsupported(instance, "configuration mode (no structural parameters)");
}

/* the rest of FMI 3.0: other variable types, model exchange, clocks, derivatives */
#define UNSUPPORTED(f, params) fmi3Status f params { return unsupported(instance, #f); }
#ifndef BUS_TERMINAL
UNSUPPORTED(fmi3EnterEventMode, (fmi3Instance instance))
UNSUPPORTED(fmi3GetBinary, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, size_t valueSizes[], fmi3Binary values[], size_t nValues))
UNSUPPORTED(fmi3GetClock, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Clock values[]))
UNSUPPORTED(fmi3SetBinary, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const size_t valueSizes[], const fmi3Binary values[], size_t nValues))
UNSUPPORTED(fmi3SetClock, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Clock values[]))
UNSUPPORTED(fmi3UpdateDiscreteStates, (fmi3Instance instance, fmi3Boolean* discreteStatesNeedUpdate, fmi3Boolean* terminateSimulation, fmi3Boolean* nominalsOfContinuousStatesChanged, fmi3Boolean* valuesOfContinuousStatesChanged, fmi3Boolean* nextEventTimeDefined, fmi3Float64* nextEventTime))
#endif
UNSUPPORTED(fmi3GetFloat32, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Float32 values[], size_t nValues))
UNSUPPORTED(fmi3GetInt8, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Int8 values[], size_t nValues))
UNSUPPORTED(fmi3GetUInt8, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3UInt8 values[], size_t nValues))
UNSUPPORTED(fmi3GetInt16, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Int16 values[], size_t nValues))
UNSUPPORTED(fmi3GetUInt16, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3UInt16 values[], size_t nValues))
UNSUPPORTED(fmi3GetInt32, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Int32 values[], size_t nValues))
UNSUPPORTED(fmi3GetUInt32, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3UInt32 values[], size_t nValues))
UNSUPPORTED(fmi3GetInt64, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Int64 values[], size_t nValues))
UNSUPPORTED(fmi3GetUInt64, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3UInt64 values[], size_t nValues))
UNSUPPORTED(fmi3GetBoolean, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Boolean values[], size_t nValues))
UNSUPPORTED(fmi3GetString, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3String values[], size_t nValues))
UNSUPPORTED(fmi3SetFloat32, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Float32 values[], size_t nValues))
UNSUPPORTED(fmi3SetInt8, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Int8 values[], size_t nValues))
UNSUPPORTED(fmi3SetUInt8, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3UInt8 values[], size_t nValues))
UNSUPPORTED(fmi3SetInt16, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Int16 values[], size_t nValues))
UNSUPPORTED(fmi3SetUInt16, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3UInt16 values[], size_t nValues))
UNSUPPORTED(fmi3SetInt32, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Int32 values[], size_t nValues))
UNSUPPORTED(fmi3SetUInt32, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3UInt32 values[], size_t nValues))
UNSUPPORTED(fmi3SetInt64, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Int64 values[], size_t nValues))
UNSUPPORTED(fmi3SetUInt64, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3UInt64 values[], size_t nValues))
UNSUPPORTED(fmi3SetBoolean, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Boolean values[], size_t nValues))
UNSUPPORTED(fmi3SetString, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3String values[], size_t nValues))
UNSUPPORTED(fmi3GetNumberOfVariableDependencies, (fmi3Instance instance, fmi3ValueReference valueReference, size_t* nDependencies))
UNSUPPORTED(fmi3GetVariableDependencies, (fmi3Instance instance, fmi3ValueReference dependent, size_t elementIndicesOfDependent[], fmi3ValueReference independents[], size_t elementIndicesOfIndependents[], fmi3DependencyKind dependencyKinds[], size_t nDependencies))
UNSUPPORTED(fmi3GetDirectionalDerivative, (fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns, const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[], size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity))
UNSUPPORTED(fmi3GetAdjointDerivative, (fmi3Instance instance, const fmi3ValueReference unknowns[], size_t nUnknowns, const fmi3ValueReference knowns[], size_t nKnowns, const fmi3Float64 seed[], size_t nSeed, fmi3Float64 sensitivity[], size_t nSensitivity))
UNSUPPORTED(fmi3GetIntervalDecimal, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Float64 intervals[], fmi3IntervalQualifier qualifiers[]))
UNSUPPORTED(fmi3GetIntervalFraction, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[], fmi3IntervalQualifier qualifiers[]))
UNSUPPORTED(fmi3GetShiftDecimal, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3Float64 shifts[]))
UNSUPPORTED(fmi3GetShiftFraction, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, fmi3UInt64 counters[], fmi3UInt64 resolutions[]))
UNSUPPORTED(fmi3SetIntervalDecimal, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Float64 intervals[]))
UNSUPPORTED(fmi3SetIntervalFraction, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]))
UNSUPPORTED(fmi3SetShiftDecimal, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Float64 shifts[]))
UNSUPPORTED(fmi3SetShiftFraction, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]))
UNSUPPORTED(fmi3EvaluateDiscreteStates, (fmi3Instance instance))
UNSUPPORTED(fmi3EnterContinuousTimeMode, (fmi3Instance instance))
UNSUPPORTED(fmi3CompletedIntegratorStep, (fmi3Instance instance, fmi3Boolean noSetFMUStatePriorToCurrentPoint, fmi3Boolean* enterEventMode, fmi3Boolean* terminateSimulation))
UNSUPPORTED(fmi3SetTime, (fmi3Instance instance, fmi3Float64 time))
UNSUPPORTED(fmi3SetContinuousStates, (fmi3Instance instance, const fmi3Float64 continuousStates[], size_t nContinuousStates))
UNSUPPORTED(fmi3GetContinuousStateDerivatives, (fmi3Instance instance, fmi3Float64 derivatives[], size_t nContinuousStates))
UNSUPPORTED(fmi3GetEventIndicators, (fmi3Instance instance, fmi3Float64 eventIndicators[], size_t nEventIndicators))
UNSUPPORTED(fmi3GetContinuousStates, (fmi3Instance instance, fmi3Float64 continuousStates[], size_t nContinuousStates))
UNSUPPORTED(fmi3GetNominalsOfContinuousStates, (fmi3Instance instance, fmi3Float64 nominals[], size_t nContinuousStates))
UNSUPPORTED(fmi3GetNumberOfEventIndicators, (fmi3Instance instance, size_t* nEventIndicators))
UNSUPPORTED(fmi3GetNumberOfContinuousStates, (fmi3Instance instance, size_t* nContinuousStates))
UNSUPPORTED(fmi3GetOutputDerivatives, (fmi3Instance instance, const fmi3ValueReference valueReferences[], size_t nValueReferences, const fmi3Int32 orders[], fmi3Float64 values[], size_t nValues))
UNSUPPORTED(fmi3ActivateModelPartition, (fmi3Instance instance, fmi3ValueReference clockReference, fmi3Float64 activationTime))
