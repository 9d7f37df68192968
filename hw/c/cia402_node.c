/* The host side of two CiA 402 drives in a controller FMU (node.h), with the PDO mapping
 * twmr.hw.cia402_link configures (RPDO1: controlword + target torque; TPDO1: statusword +
 * velocity actual, on every SYNC): at the start NMT "start remote node" to each drive; every
 * period RPDO1 to each drive — the controlword that walks it toward OPERATION ENABLED
 * (cia402_next_controlword of its last statusword, fault reset on a rising edge) and, once
 * enabled, the target torque limited to drive.torque_limit in per mille of drive.rated_torque —
 * then one SYNC (the stop: RPDO1 with zero torque and SHUTDOWN, or DISABLE VOLTAGE on a fault,
 * to each drive, then SYNC); each TPDO1 received gives that drive's statusword and wheel speed, and the
 * period's feedback is complete when both drives' came since the last RPDOs. The SDO
 * configuration (cyclic synchronous torque mode, the PDO mapping) is the drive's own (its DCF,
 * or `twmr` run once with the can_drive block): the FMU sends no SDO. s[i] is drive i's last
 * statusword, s[2 + i] the controlword last sent to it, s[4 + i] whether its TPDO1 came. */
#include <math.h>
#include "cia402.h"
#include "node.h"

static unsigned node_id(const Model *m, int i) { return (unsigned)m->v[V_drive_node_ids + i]; }

static void sync(LsbusBuffer *tx) {
    CanFrame f = {0};
    f.id = CIA402_SYNC;
    lsbus_transmit(tx, &f);
}

const char *node_check(const Model *m) {
    int i;
    double rated = m->v[V_drive_rated_torque];
    for (i = 0; i < 2; i++) {
        double n = m->v[V_drive_node_ids + i];
        if (n != floor(n) || n < 1 || n > 126)
            return "drive.node_ids: a CiA 402 node id is a whole number 1..126";
    }
    if (node_id(m, 0) == node_id(m, 1))
        return "drive.node_ids repeat: one drive would get both wheels' torque";
    if (rated != floor(rated) || rated < 1)
        return "drive.rated_torque: a whole number of mN.m, at least 1";
    return NULL;
}

void node_start(const Model *m, double *s, LsbusBuffer *tx) {
    unsigned char d[2];
    CanFrame f = {0};
    int i;
    (void)s;
    f.id = CIA402_NMT;
    f.length = 2;
    f.data = d;
    for (i = 0; i < 2; i++) {
        d[0] = CIA402_NMT_START;
        d[1] = (unsigned char)node_id(m, i);
        lsbus_transmit(tx, &f);
    }
}

int node_receive(Model *m, double *s, const CanFrame *f) {
    unsigned status;
    long rpm;
    int i;
    if (f->ide || f->rtr || (f->id & 0x780) != CIA402_TPDO1 || f->length < 6) return 0;
    for (i = 0; i < 2; i++) {
        if ((f->id & 0x7F) != node_id(m, i)) continue;
        cia402_decode_tpdo1(f->data, &status, &rpm);
        s[i] = status;
        m->v[V_wheel_speed + i] = cia402_velocity_to_si(rpm, m->v[V_drive_gear], 1.0);
        if (s[4 + i] != 0.0) return 0;  /* a second TPDO1 of this drive in one period */
        s[4 + i] = 1.0;
        return s[4] != 0.0 && s[5] != 0.0;
    }
    return 0;
}

void node_transmit(const Model *m, double *s, LsbusBuffer *tx) {
    const double *v = m->v;
    double lim = v[V_drive_torque_limit];
    long rated = (long)v[V_drive_rated_torque];
    unsigned char d[8];
    CanFrame f = {0};
    int i;
    s[4] = s[5] = 0.0;
    for (i = 0; i < 2; i++) {
        int state = cia402_state((unsigned)s[i]);
        unsigned word = cia402_next_controlword(state);
        double tau = state == CIA402_OPERATION_ENABLED ? fmin(lim, fmax(-lim, v[V_torque + i]))
                                                       : 0.0;
        if (word == CIA402_FAULT_RESET && s[2 + i] == CIA402_FAULT_RESET) word = 0;
        s[2 + i] = word;
        f.id = CIA402_RPDO1 + node_id(m, i);
        f.data = d;
        f.length = cia402_encode_rpdo1(word, cia402_torque_to_permille(tau, v[V_drive_gear],
                                                                       rated), d);
        lsbus_transmit(tx, &f);
    }
    sync(tx);
}

void node_stop(const Model *m, double *s, LsbusBuffer *tx, int fault) {
    unsigned word = fault ? CIA402_DISABLE_VOLTAGE : CIA402_SHUTDOWN;
    unsigned char d[8];
    CanFrame f = {0};
    int i;
    for (i = 0; i < 2; i++) {
        s[2 + i] = word;
        f.id = CIA402_RPDO1 + node_id(m, i);
        f.data = d;
        f.length = cia402_encode_rpdo1(word, 0, d);
        lsbus_transmit(tx, &f);
    }
    sync(tx);
}
