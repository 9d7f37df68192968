/* The host side of two ODrive axes (CAN Simple) in a controller FMU (node.h), as
 * twmr.hw.odrive_link does it: at the start Clear_Errors, Set_Limits (the wheel speed limit, the
 * current limit drive.torque_limit / (gear K_t)), Set_Controller_Mode (torque, passthrough) and
 * Set_Axis_State (closed loop) to each axis; every period Set_Input_Torque with the torque limited
 * to drive.torque_limit, and a remote request of Get_Encoder_Estimates (encoder: polled); each
 * Get_Encoder_Estimates received gives that axis's wheel speed (non-finite ones are dropped),
 * and the period's feedback is complete when both axes' came since the last torques (s[i]: axis
 * i's came). The stop: zero torque, then Set_Axis_State (idle), or Estop on a fault, to each
 * axis. ODRIVE_LINE (5 or 6) is the firmware line. The axis watchdog is not set (no RxSdo
 * here). */
#include <math.h>
#include "node.h"
#include "odrive.h"

static unsigned node_id(const Model *m, int i) { return (unsigned)m->v[V_drive_node_ids + i]; }

static void send(LsbusBuffer *tx, unsigned node, unsigned cmd, const unsigned char *data,
                 unsigned n) {
    CanFrame f = {0};
    f.id = odrive_can_id(node, cmd);
    f.length = n;
    f.data = data;
    lsbus_transmit(tx, &f);
}

const char *node_check(const Model *m) {
    int i;
    for (i = 0; i < 2; i++) {
        double n = m->v[V_drive_node_ids + i];
        if (n != floor(n) || n < 0 || n > 63)
            return "drive.node_ids: an ODrive node id is a whole number 0..63";
    }
    if (node_id(m, 0) == node_id(m, 1))
        return "drive.node_ids repeat: one drive would get both wheels' torque";
    return NULL;
}

void node_start(const Model *m, double *s, LsbusBuffer *tx) {
    const double *v = m->v;
    double gear = v[V_drive_gear];
    double current = v[V_drive_torque_limit] / (gear * v[V_drive_torque_constant]);
    unsigned char d[8];
    int i;
    (void)s;
    for (i = 0; i < 2; i++) {
        unsigned n = node_id(m, i);
        send(tx, n, ODRIVE_CLEAR_ERRORS, d, odrive_encode_clear_errors(ODRIVE_LINE, d));
        send(tx, n, ODRIVE_SET_LIMITS, d,
             odrive_encode_limits(v[V_drive_speed_limit], current, gear, d));
        send(tx, n, ODRIVE_SET_CONTROLLER_MODE, d,
             odrive_encode_controller_mode(ODRIVE_CONTROL_TORQUE, ODRIVE_INPUT_PASSTHROUGH, d));
        send(tx, n, ODRIVE_SET_AXIS_STATE, d,
             odrive_encode_axis_state(ODRIVE_AXIS_CLOSED_LOOP, d));
    }
}

int node_receive(Model *m, double *s, const CanFrame *f) {
    unsigned node, cmd;
    double angle, speed;
    int i;
    odrive_split_id(f->id, &node, &cmd);
    if (f->ide || f->rtr || cmd != ODRIVE_GET_ENCODER_ESTIMATES || f->length < 8) return 0;
    for (i = 0; i < 2; i++) {
        if (node != node_id(m, i)) continue;
        odrive_decode_encoder(f->data, m->v[V_drive_gear], &angle, &speed);
        if (!isfinite(speed)) return 0;
        m->v[V_wheel_speed + i] = speed;
        if (s[i] != 0.0) return 0;  /* a second estimate of this axis in one period */
        s[i] = 1.0;
        return s[0] != 0.0 && s[1] != 0.0;
    }
    return 0;
}

void node_transmit(const Model *m, double *s, LsbusBuffer *tx) {
    const double *v = m->v;
    double lim = v[V_drive_torque_limit];
    unsigned char d[8];
    CanFrame request = {0};
    int i;
    s[0] = s[1] = 0.0;
    for (i = 0; i < 2; i++) {
        double tau = fmin(lim, fmax(-lim, v[V_torque + i]));
        send(tx, node_id(m, i), ODRIVE_SET_INPUT_TORQUE, d,
             odrive_encode_torque(tau, v[V_drive_gear], d));
    }
    request.rtr = 1;
    request.length = 8;
    for (i = 0; i < 2; i++) {
        request.id = odrive_can_id(node_id(m, i), ODRIVE_GET_ENCODER_ESTIMATES);
        lsbus_transmit(tx, &request);
    }
}

void node_stop(const Model *m, double *s, LsbusBuffer *tx, int fault) {
    unsigned char d[8];
    int i;
    (void)s;
    for (i = 0; i < 2; i++) {
        unsigned n = node_id(m, i);
        send(tx, n, ODRIVE_SET_INPUT_TORQUE, d, odrive_encode_torque(0.0, m->v[V_drive_gear], d));
        if (fault)
            send(tx, n, ODRIVE_ESTOP, d, 0);
        else
            send(tx, n, ODRIVE_SET_AXIS_STATE, d, odrive_encode_axis_state(ODRIVE_AXIS_IDLE, d));
    }
}
