/* An FMI 3.0 co-simulation FMU that is an FMI-LS-BUS CAN bus simulation for two nodes, written for
 * twmr-cosim's tests; it behaves as the Modelica Association's demo bus simulation
 * (fmi-ls-bus-examples: can-bus-simulation) describes its own, in code of our own.
 *
 * Terminals Node1 and Node2, each Rx_Data (Binary input, clocked by Rx_Clock, triggered), Tx_Data
 * (Binary output, clocked by Tx_Clock, an input countdown clock). CAN Transmit operations received
 * from a node are queued (per node, in order); Configuration of the CAN baud rate sets the bus's
 * (default 200000 bit/s until a node configures one). When the bus is idle and a frame waits, the
 * frame with the lowest identifier among the queue heads wins arbitration and occupies the bus for
 * (44 + 8 n) bits at the baud rate (n data bytes; no stuffing bits): both Tx clocks get that interval
 * (fmi3GetIntervalDecimal, changed). When the importer activates them, the sender's Tx data is a
 * Confirm of the frame's identifier and the other node's is the CAN Transmit; the losing frames
 * stay queued (BUFFER_AND_RETRANSMIT) and the next is scheduled after the event.
 * Outputs: frames (Int32, frames transmitted), baud (UInt32, the bus baud rate in bit/s).
 * Byte layout as in cannode.c. */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include "fmi3Functions.h"

enum { NODES = 2, BUF = 2048, QUEUE = 64, VR_FRAMES = 20, VR_BAUD = 21, VR_TIME = 1024 };
typedef enum { M_INSTANTIATED, M_INIT, M_EVENT, M_STEP, M_TERMINATED } Mode;
typedef struct { unsigned id, len; unsigned char data[64]; } Frame;
typedef struct {
    unsigned char rx[BUF], tx[BUF];
    size_t rx_len, tx_len;
    int rx_active, tx_active, changed;
    Frame queue[QUEUE];
    int head, count;
} Node;
typedef struct {
    double time, interval;
    unsigned baud;
    int frames, in_flight, sender, built;
    Frame flying;
    Node node[NODES];
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
/* which node and member a value reference is: member 0 Rx_Data, 1 Tx_Data, 2 Rx_Clock, 3 Tx_Clock */
static int node_of(fmi3ValueReference vr, int *member) { *member = vr % 4; return vr < 8 ? (int)(vr / 4) : -1; }

static void op(Node *n, unsigned code, const unsigned char *body, size_t len) {
    if (n->tx_len + 8 + len > BUF) return;
    unsigned char *p = n->tx + n->tx_len;
    put32(p, code); put32(p + 4, (unsigned)(8 + len)); memcpy(p + 8, body, len);
    n->tx_len += 8 + len;
}
static void receive(Inst *c, Node *n) {
    size_t at = 0;
    while (at + 8 <= n->rx_len) {
        const unsigned char *p = n->rx + at;
        unsigned code = get32(p), len = get32(p + 4);
        if (len < 8 || at + len > n->rx_len) break;
        if (code == 0x10 && len >= 16 && n->count < QUEUE) {
            Frame *f = &n->queue[(n->head + n->count++) % QUEUE];
            f->id = get32(p + 8); f->len = get16(p + 14);
            if (f->len > 64 || 16 + f->len > len) f->len = 0;
            memcpy(f->data, p + 16, f->len);
        } else if (code == 0x40 && len == 13 && p[8] == 0x01) c->baud = get32(p + 9);
        at += len;
    }
}
static void schedule(Inst *c) {
    int best = -1;
    for (int i = 0; i < NODES; i++)
        if (c->node[i].count && (best < 0 || c->node[i].queue[c->node[i].head].id < c->node[best].queue[c->node[best].head].id))
            best = i;
    if (best < 0) return;
    c->flying = c->node[best].queue[c->node[best].head];
    c->node[best].head = (c->node[best].head + 1) % QUEUE; c->node[best].count--;
    c->sender = best; c->in_flight = 1; c->built = 0;
    c->interval = (44.0 + 8.0 * c->flying.len) / c->baud;
    for (int i = 0; i < NODES; i++) c->node[i].changed = 1;
}
static void deliver(Inst *c) {
    if (!c->in_flight || c->built) return;
    for (int i = 0; i < NODES; i++) {
        unsigned char body[12 + 64];
        put32(body, c->flying.id);
        if (i == c->sender) { op(&c->node[i], 0x20, body, 4); continue; }
        body[4] = 0; body[5] = 0; body[6] = c->flying.len & 0xff; body[7] = c->flying.len >> 8;
        memcpy(body + 8, c->flying.data, c->flying.len);
        op(&c->node[i], 0x10, body, 8 + c->flying.len);
    }
    c->built = 1; c->frames++;
}

const char *fmi3GetVersion(void) { return fmi3Version; }
fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean on, size_t n, const fmi3String cat[]) { return fmi3OK; }
fmi3Instance fmi3InstantiateCoSimulation(fmi3String name, fmi3String token, fmi3String res,
    fmi3Boolean visible, fmi3Boolean log, fmi3Boolean eventModeUsed, fmi3Boolean earlyReturn,
    const fmi3ValueReference req[], size_t nreq, fmi3InstanceEnvironment env,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback update) {
    if (!eventModeUsed) {
        if (logMessage) logMessage(env, fmi3Error, "logStatusError", "canbus: needs eventModeUsed");
        return NULL;
    }
    Inst *c = (Inst *)calloc(1, sizeof(Inst));
    if (!c) return NULL;
    c->env = env; c->log = logMessage; c->baud = 200000; c->mode = M_INSTANTIATED;
    return c;
}
void fmi3FreeInstance(fmi3Instance c) { free(c); }
fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean tolDef, fmi3Float64 tol,
    fmi3Float64 start, fmi3Boolean stopDef, fmi3Float64 stop) {
    ((Inst *)c)->time = start; ((Inst *)c)->mode = M_INIT; return fmi3OK;
}
fmi3Status fmi3ExitInitializationMode(fmi3Instance c) { ((Inst *)c)->mode = M_EVENT; return fmi3OK; }
fmi3Status fmi3EnterEventMode(fmi3Instance c) { ((Inst *)c)->mode = M_EVENT; return fmi3OK; }
fmi3Status fmi3EnterStepMode(fmi3Instance c) { ((Inst *)c)->mode = M_STEP; return fmi3OK; }
fmi3Status fmi3Terminate(fmi3Instance c) { ((Inst *)c)->mode = M_TERMINATED; return fmi3OK; }
fmi3Status fmi3Reset(fmi3Instance c) { return fmi3Error; }

fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Float64 v[], size_t nv) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_TIME) return bad_vr(i, "fmi3GetFloat64", vr[j]);
        v[j] = i->time;
    }
    return fmi3OK;
}
fmi3Status fmi3GetInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Int32 v[], size_t nv) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_FRAMES) return bad_vr(i, "fmi3GetInt32", vr[j]);
        v[j] = i->frames;
    }
    return fmi3OK;
}
fmi3Status fmi3GetUInt32(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3UInt32 v[], size_t nv) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (vr[j] != VR_BAUD) return bad_vr(i, "fmi3GetUInt32", vr[j]);
        v[j] = i->baud;
    }
    return fmi3OK;
}
fmi3Status fmi3GetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t n, size_t sizes[],
    fmi3Binary v[], size_t nv) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        int m, k = node_of(vr[j], &m);
        if (k < 0 || m != 1) return bad_vr(i, "fmi3GetBinary", vr[j]);
        if (i->mode != M_EVENT || !i->node[k].tx_active)
            return fail(i, "fmi3GetBinary: Tx_Data is readable only in event mode while its Tx_Clock ticks");
        v[j] = i->node[k].tx; sizes[j] = i->node[k].tx_len;
    }
    return fmi3OK;
}
fmi3Status fmi3SetBinary(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const size_t sizes[],
    const fmi3Binary v[], size_t nv) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        int m, k = node_of(vr[j], &m);
        if (k < 0 || m != 0) return bad_vr(i, "fmi3SetBinary", vr[j]);
        Node *nd = &i->node[k];
        if (i->mode != M_EVENT || !nd->rx_active)
            return fail(i, "fmi3SetBinary: Rx_Data is settable only in event mode after its Rx_Clock was activated");
        if (nd->rx_len + sizes[j] > BUF) return fail(i, "fmi3SetBinary: Rx_Data longer than 2048 bytes");
        memcpy(nd->rx + nd->rx_len, v[j], sizes[j]); nd->rx_len += sizes[j];
    }
    return fmi3OK;
}
fmi3Status fmi3SetClock(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Clock v[]) {
    Inst *i = (Inst *)c;
    if (i->mode != M_EVENT) return fail(i, "fmi3SetClock: clocks can only be set in event mode");
    for (size_t j = 0; j < n; j++) {
        int m, k = node_of(vr[j], &m);
        if (k < 0 || (m != 2 && m != 3)) return bad_vr(i, "fmi3SetClock", vr[j]);
        if (!v[j]) continue;
        if (m == 2) i->node[k].rx_active = 1;
        else { i->node[k].tx_active = 1; deliver(i); }
    }
    return fmi3OK;
}
fmi3Status fmi3GetIntervalDecimal(fmi3Instance c, const fmi3ValueReference vr[], size_t n,
    fmi3Float64 intervals[], fmi3IntervalQualifier q[]) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        int m, k = node_of(vr[j], &m);
        if (k < 0 || m != 3) return bad_vr(i, "fmi3GetIntervalDecimal", vr[j]);
        q[j] = i->node[k].changed ? fmi3IntervalChanged : fmi3IntervalNotYetKnown;
        intervals[j] = i->node[k].changed ? i->interval : 0;
        i->node[k].changed = 0;
    }
    return fmi3OK;
}
fmi3Status fmi3UpdateDiscreteStates(fmi3Instance c, fmi3Boolean *needUpdate, fmi3Boolean *terminate,
    fmi3Boolean *nominalsChanged, fmi3Boolean *valuesChanged, fmi3Boolean *nextDefined, fmi3Float64 *next) {
    Inst *i = (Inst *)c;
    if (i->mode != M_EVENT) return fail(i, "fmi3UpdateDiscreteStates called outside event mode");
    int ticked = 0;
    for (int k = 0; k < NODES; k++) {
        Node *nd = &i->node[k];
        if (nd->rx_active) receive(i, nd);
        if (nd->tx_active) { ticked = 1; nd->tx_len = 0; }
        nd->rx_active = nd->tx_active = 0; nd->rx_len = 0;
    }
    if (ticked && i->built) i->in_flight = 0;
    if (!i->in_flight) schedule(i);
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
