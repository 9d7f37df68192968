/* An FMI 3.0 co-simulation FMU that is a CAN node after FMI-LS-BUS (network abstraction), written
 * for twmr-cosim's tests; it behaves as the Modelica Association's demo CAN nodes describe theirs
 * (fmi-ls-bus-examples: can-node-triggered-output, can-node-countdown), in code of our own.
 *
 * Bus terminal CanChannel: Rx_Data (Binary input clocked by Rx_Clock), Tx_Data (Binary output
 * clocked by Tx_Clock), Rx_Clock (triggered input clock), Tx_Clock: a triggered output clock, or
 * built with -DCOUNTDOWN an input countdown clock whose interval the FMU gives.
 * At instantiation the Tx buffer holds two Configuration operations (CAN baud rate `bitrate`, start
 * 100000 bit/s, arbitration lost behaviour BUFFER_AND_RETRANSMIT). At `delay` + k `period` seconds (k = 1, 2, ...; delay 0 unless set) the node
 * appends a CAN Transmit of identifier `id` with the 4 data bytes of its Binary input `payload`
 * (start 01 02 03 04, shorter or longer values cut or padded to 4).
 * Triggered: the Tx clock ticks at the end of the step holding the transmit time; with early return
 * allowed the step returns early at that time instead. Countdown: the importer activates Tx_Clock
 * after the interval (period) the FMU reports through fmi3GetIntervalDecimal after each tick.
 * Received operations (decoded when Rx_Clock ticked, in fmi3UpdateDiscreteStates): CAN Transmit
 * counts in rx_frames and sets rx_id, rx_time (the time of the event) and rx_payload; Confirm counts
 * in confirms; Bus Error counts in bus_errors; Configuration, Status and Arbitration Lost are
 * ignored; anything else
 * counts in rx_unknown. Parameter `fault` writes malformed operations instead: 1 a transmit whose
 * length field is one byte too long, 2 an unknown operation code 0x99.
 * Byte layout: header opcode (uint32) and total length (uint32), then the fields, packed,
 * little-endian. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "fmi3Functions.h"

enum { VR_RX_DATA = 0, VR_TX_DATA = 1, VR_RX_CLOCK = 2, VR_TX_CLOCK = 3, VR_ID = 10, VR_PERIOD = 11, VR_DELAY = 15,
       VR_FAULT = 12, VR_PAYLOAD = 13, VR_BITRATE = 14, VR_RX_FRAMES = 20, VR_RX_ID = 21, VR_RX_TIME = 22,
       VR_RX_PAYLOAD = 23, VR_CONFIRMS = 24, VR_RX_UNKNOWN = 25, VR_TX_FRAMES = 26, VR_TX_TIME = 27, VR_BUS_ERRORS = 28,
       VR_TIME = 1024 };
enum { BUF = 2048 };
typedef enum { M_INSTANTIATED, M_INIT, M_EVENT, M_STEP, M_TERMINATED } Mode;

typedef struct {
    double time, period, delay, next_tx, rx_time, tx_time;
    unsigned id, rx_id, bitrate;
    int fault, bus_errors, rx_frames, confirms, rx_unknown, tx_frames, event_mode_used, early_allowed;
    unsigned char tx[BUF], rx[BUF], payload[4], rx_payload[64];
    size_t tx_len, rx_len, rx_payload_len;
    int tx_active, tx_reported, rx_active, interval_changed;
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
static void put32(unsigned char *p, unsigned v) { p[0] = v; p[1] = v >> 8; p[2] = v >> 16; p[3] = v >> 24; }
static unsigned get32(const unsigned char *p) { return p[0] | p[1] << 8 | p[2] << 16 | (unsigned)p[3] << 24; }
static unsigned get16(const unsigned char *p) { return p[0] | p[1] << 8; }

static void op(Inst *c, unsigned code, const unsigned char *body, size_t n) {
    if (c->tx_len + 8 + n > BUF) { fail(c, "cannode: Tx buffer full"); return; }
    unsigned char *p = c->tx + c->tx_len;
    put32(p, code); put32(p + 4, (unsigned)(8 + n)); memcpy(p + 8, body, n);
    c->tx_len += 8 + n;
}
static void configure(Inst *c) {
    unsigned char baud[5] = {0x01}, behaviour[2] = {0x04, 0x01};
    put32(baud + 1, c->bitrate);
    op(c, 0x40, baud, 5); op(c, 0x40, behaviour, 2);
    c->tx_active = 1;
}
static void transmit(Inst *c, double at) {
    unsigned char body[12] = {0};
    put32(body, c->id); body[4] = 0; body[5] = 0; body[6] = 4; body[7] = 0;
    memcpy(body + 8, c->payload, 4);
    if (c->fault == 2) op(c, 0x99, body, 12);
    else {
        op(c, 0x10, body, 12);
        if (c->fault == 1) put32(c->tx + c->tx_len - 20 + 4, 21);
    }
    c->tx_frames++; c->tx_time = at; c->tx_active = 1;
}
static void receive(Inst *c) {
    size_t at = 0;
    while (at + 8 <= c->rx_len) {
        const unsigned char *p = c->rx + at;
        unsigned code = get32(p), len = get32(p + 4);
        if (len < 8 || at + len > c->rx_len) { c->rx_unknown++; break; }
        if (code == 0x10 && len >= 16) {
            unsigned n = get16(p + 14);
            c->rx_frames++; c->rx_id = get32(p + 8); c->rx_time = c->time;
            c->rx_payload_len = n <= 64 && 16 + n <= len ? n : 0;
            memcpy(c->rx_payload, p + 16, c->rx_payload_len);
        } else if (code == 0x20) c->confirms++;
        else if (code == 0x31) c->bus_errors++;
        else if (code != 0x40 && code != 0x41 && code != 0x30) c->rx_unknown++;
        at += len;
    }
}
static void reconfigure(Inst *c) {
    c->tx_len = 0;
    configure(c);
#ifdef COUNTDOWN
    c->tx_active = 0; /* the configuration goes out with the first tick of Tx_Clock */
#endif
}
static void defaults(Inst *c) {
    static const unsigned char start[4] = {1, 2, 3, 4};
    c->time = 0; c->period = 0.3; c->delay = 0; c->id = 1; c->bitrate = 100000; c->fault = 0; c->bus_errors = 0; memcpy(c->payload, start, 4);
    c->rx_frames = c->confirms = c->rx_unknown = c->tx_frames = 0; c->rx_id = 0; c->rx_time = -1;
    c->tx_time = -1; c->rx_payload_len = 0; c->tx_len = c->rx_len = 0; c->rx_active = 0;
    c->tx_reported = 0; c->interval_changed = 1; c->mode = M_INSTANTIATED;
    reconfigure(c);
}

const char *fmi3GetVersion(void) { return fmi3Version; }
fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean on, size_t n, const fmi3String cat[]) { return fmi3OK; }

fmi3Instance fmi3InstantiateCoSimulation(fmi3String name, fmi3String token, fmi3String res,
    fmi3Boolean visible, fmi3Boolean log, fmi3Boolean eventModeUsed, fmi3Boolean earlyReturn,
    const fmi3ValueReference req[], size_t nreq, fmi3InstanceEnvironment env,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback update) {
    Inst *c = (Inst *)calloc(1, sizeof(Inst));
    if (!c) return NULL;
    c->env = env; c->log = logMessage;
    if (!eventModeUsed) {
        if (logMessage) logMessage(env, fmi3Error, "logStatusError", "cannode: needs eventModeUsed");
        free(c);
        return NULL;
    }
    c->event_mode_used = eventModeUsed; c->early_allowed = earlyReturn;
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
    if (!(i->period > 0)) return fail(i, "cannode: period must be positive");
    i->next_tx = i->time + i->delay + i->period;
    i->mode = M_EVENT;
    return fmi3OK;
}
fmi3Status fmi3EnterEventMode(fmi3Instance c) { ((Inst *)c)->mode = M_EVENT; return fmi3OK; }
fmi3Status fmi3EnterStepMode(fmi3Instance c) {
    Inst *i = (Inst *)c;
    if (i->mode != M_EVENT) return fail(i, "fmi3EnterStepMode called outside event mode");
    i->mode = M_STEP;
    return fmi3OK;
}
fmi3Status fmi3Terminate(fmi3Instance c) { ((Inst *)c)->mode = M_TERMINATED; return fmi3OK; }
fmi3Status fmi3Reset(fmi3Instance c) { defaults((Inst *)c); return fmi3OK; }

fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Float64 v[], size_t nv) {
    Inst *i = (Inst *)c;
    if (nv != n) return fail(i, "fmi3GetFloat64: nValues must equal nValueReferences (no arrays)");
    for (size_t j = 0; j < n; j++) {
        switch (vr[j]) {
        case VR_TIME: v[j] = i->time; break;
        case VR_PERIOD: v[j] = i->period; break;
        case VR_DELAY: v[j] = i->delay; break;
        case VR_RX_TIME: v[j] = i->rx_time; break;
        case VR_TX_TIME: v[j] = i->tx_time; break;
        default: return bad_vr(i, "fmi3GetFloat64", vr[j]);
        }
    }
    return fmi3OK;
}
fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Float64 v[], size_t nv) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_PERIOD && vr[j] != VR_DELAY) return bad_vr(i, "fmi3SetFloat64", vr[j]);
        if (i->mode != M_INSTANTIATED && i->mode != M_INIT) return fail(i, "period and delay are fixed");
        if (vr[j] == VR_PERIOD) i->period = v[j]; else i->delay = v[j];
    }
    return fmi3OK;
}
fmi3Status fmi3GetUInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3UInt32 v[], size_t nv) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] == VR_ID) v[j] = i->id;
        else if (vr[j] == VR_BITRATE) v[j] = i->bitrate;
        else if (vr[j] == VR_RX_ID) v[j] = i->rx_id;
        else return bad_vr(i, "fmi3GetUInt32", vr[j]);
    }
    return fmi3OK;
}
fmi3Status fmi3SetUInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3UInt32 v[], size_t nv) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] == VR_BITRATE) {
            if (i->mode != M_INSTANTIATED && i->mode != M_INIT) return fail(i, "bitrate is fixed");
            i->bitrate = v[j]; reconfigure(i);
        } else if (vr[j] == VR_ID) i->id = v[j];
        else return bad_vr(i, "fmi3SetUInt32", vr[j]);
    }
    return fmi3OK;
}
fmi3Status fmi3GetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Int32 v[], size_t nv) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        switch (vr[j]) {
        case VR_FAULT: v[j] = i->fault; break;
        case VR_RX_FRAMES: v[j] = i->rx_frames; break;
        case VR_CONFIRMS: v[j] = i->confirms; break;
        case VR_RX_UNKNOWN: v[j] = i->rx_unknown; break;
        case VR_TX_FRAMES: v[j] = i->tx_frames; break;
        case VR_BUS_ERRORS: v[j] = i->bus_errors; break;
        default: return bad_vr(i, "fmi3GetInt32", vr[j]);
        }
    }
    return fmi3OK;
}
fmi3Status fmi3SetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Int32 v[], size_t nv) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_FAULT) return bad_vr(i, "fmi3SetInt32", vr[j]);
        i->fault = v[j];
    }
    return fmi3OK;
}
fmi3Status fmi3GetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t n, size_t sizes[],
    fmi3Binary v[], size_t nv) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] == VR_TX_DATA) {
            if (i->mode != M_EVENT || !i->tx_active)
                return fail(i, "fmi3GetBinary: Tx_Data is readable only in event mode while Tx_Clock ticks");
            v[j] = i->tx; sizes[j] = i->tx_len;
        } else if (vr[j] == VR_RX_PAYLOAD) { v[j] = i->rx_payload; sizes[j] = i->rx_payload_len; }
        else if (vr[j] == VR_PAYLOAD) { v[j] = i->payload; sizes[j] = 4; }
        else return bad_vr(i, "fmi3GetBinary", vr[j]);
    }
    return fmi3OK;
}
fmi3Status fmi3SetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const size_t sizes[],
    const fmi3Binary v[], size_t nv) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] == VR_RX_DATA) {
            if (i->mode != M_EVENT || !i->rx_active)
                return fail(i, "fmi3SetBinary: Rx_Data is settable only in event mode after Rx_Clock was activated");
            if (i->rx_len + sizes[j] > BUF) return fail(i, "fmi3SetBinary: Rx_Data longer than 2048 bytes");
            memcpy(i->rx + i->rx_len, v[j], sizes[j]); i->rx_len += sizes[j];
        } else if (vr[j] == VR_PAYLOAD) {
            memset(i->payload, 0, 4); memcpy(i->payload, v[j], sizes[j] < 4 ? sizes[j] : 4);
        } else return bad_vr(i, "fmi3SetBinary", vr[j]);
    }
    return fmi3OK;
}
fmi3Status fmi3SetClock(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Clock v[]) {
    Inst *i = (Inst *)c;
    if (i->mode != M_EVENT) return fail(i, "fmi3SetClock: clocks can only be set in event mode");
    for (size_t j = 0; j < n; j++) {
        if (vr[j] == VR_RX_CLOCK) { if (v[j]) i->rx_active = 1; }
#ifdef COUNTDOWN
        else if (vr[j] == VR_TX_CLOCK) { if (v[j]) { transmit(i, i->time); } }
#endif
        else return bad_vr(i, "fmi3SetClock", vr[j]);
    }
    return fmi3OK;
}
fmi3Status fmi3GetClock(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Clock v[]) {
    Inst *i = (Inst *)c;
    if (i->mode != M_EVENT) return fail(i, "fmi3GetClock: clocks can only be got in event mode");
    for (size_t j = 0; j < n; j++) {
#ifndef COUNTDOWN
        if (vr[j] == VR_TX_CLOCK) { v[j] = i->tx_active && !i->tx_reported; i->tx_reported = i->tx_active; continue; }
#endif
        return bad_vr(i, "fmi3GetClock", vr[j]);
    }
    return fmi3OK;
}
fmi3Status fmi3GetIntervalDecimal(fmi3Instance c, const fmi3ValueReference vr[], size_t n,
    fmi3Float64 intervals[], fmi3IntervalQualifier q[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
#ifdef COUNTDOWN
        if (vr[j] == VR_TX_CLOCK) {
            q[j] = i->interval_changed ? fmi3IntervalChanged : fmi3IntervalUnchanged;
            intervals[j] = i->interval_changed ? i->period : 0;
            i->interval_changed = 0;
            continue;
        }
#endif
        return bad_vr(i, "fmi3GetIntervalDecimal", vr[j]);
    }
    return fmi3OK;
}
fmi3Status fmi3UpdateDiscreteStates(fmi3Instance c, fmi3Boolean *needUpdate, fmi3Boolean *terminate,
    fmi3Boolean *nominalsChanged, fmi3Boolean *valuesChanged, fmi3Boolean *nextDefined, fmi3Float64 *next) {
    Inst *i = (Inst *)c;
    if (i->mode != M_EVENT) return fail(i, "fmi3UpdateDiscreteStates called outside event mode");
    if (i->rx_active) receive(i);
    i->rx_active = 0; i->rx_len = 0;
    if (i->tx_active) {
#ifdef COUNTDOWN
        i->interval_changed = 1;
#endif
        i->tx_len = 0;
    }
    i->tx_active = 0; i->tx_reported = 0;
    *needUpdate = fmi3False; *terminate = fmi3False; *nominalsChanged = fmi3False;
    *valuesChanged = fmi3False; *nextDefined = fmi3False; *next = 0;
    return fmi3OK;
}
fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 t, fmi3Float64 h, fmi3Boolean noSetPrior,
    fmi3Boolean *eventNeeded, fmi3Boolean *terminate, fmi3Boolean *early, fmi3Float64 *last) {
    Inst *i = (Inst *)c;
    double end = t + h, eps = 1e-9 * (1 + (end < 0 ? -end : end));
    if (i->mode != M_STEP) return fail(i, "fmi3DoStep called outside step mode");
    *eventNeeded = fmi3False; *terminate = fmi3False; *early = fmi3False; *last = end;
#ifndef COUNTDOWN
    if (i->next_tx <= end + eps) {
        if (i->early_allowed && i->next_tx < end - eps) {
            i->time = i->next_tx; transmit(i, i->time); i->next_tx += i->period;
            *early = fmi3True; *last = i->time; *eventNeeded = fmi3True;
            return fmi3OK;
        }
        while (i->next_tx <= end + eps) { transmit(i, i->next_tx); i->next_tx += i->period; }
        *eventNeeded = fmi3True;
    }
#endif
    i->time = end;
    return fmi3OK;
}
/* FMU state: a copy of the instance (canGetAndSetFMUState; not serialisable) */
fmi3Status fmi3GetFMUState(fmi3Instance c, fmi3FMUState *state) {
    Inst *copy = *state ? (Inst *)*state : (Inst *)malloc(sizeof(Inst));
    if (!copy) return fail((Inst *)c, "cannode: out of memory saving the state");
    memcpy(copy, c, sizeof(Inst));
    *state = copy;
    return fmi3OK;
}
fmi3Status fmi3SetFMUState(fmi3Instance c, fmi3FMUState state) {
    if (!state) return fail((Inst *)c, "cannode: no state given");
    memcpy(c, state, sizeof(Inst));
    return fmi3OK;
}
fmi3Status fmi3FreeFMUState(fmi3Instance c, fmi3FMUState *state) {
    free(*state);
    *state = NULL;
    return fmi3OK;
}
