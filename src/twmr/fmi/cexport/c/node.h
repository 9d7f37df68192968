/* A CAN drive protocol's host side in a controller FMU on an FMI-LS-BUS CAN terminal (twmr-cosim
 * C export, `twmr export KIND --fmi 3 --can PROTOCOL`). The FMI wrapper (fmi3.c with
 * BUS_TERMINAL) calls these; the protocol's C file beside its Python (hw/c/<protocol>_node.c)
 * implements them on the kernel's values: V_torque the wheel torques it sends, V_wheel_speed the
 * wheel speeds its drives' frames give, V_drive_* its own parameters; `s` its own state (NODE_NS
 * values, saved with the FMU state). */
#ifndef TWMR_NODE_H
#define TWMR_NODE_H

#include "kernel.h"
#include "lsbus.h"

/* NULL, or why the parameters are refused (checked when initialization ends) */
const char *node_check(const Model *m);
/* the frames that configure and enable the drives (sent with the first tick, before any torque) */
void node_start(const Model *m, double *s, LsbusBuffer *tx);
/* one frame received: take what it carries into m (and s); 1 when with it every drive's
 * feedback came since the last node_transmit (the period's feedback is complete) */
int node_receive(Model *m, double *s, const CanFrame *f);
/* the frames of one controller period: the torques of m */
void node_transmit(const Model *m, double *s, LsbusBuffer *tx);
/* the frames that stop the drives: zero torque, then disable (`fault` 0: the normal stop,
 * else the stop on a fault), as the protocol's Link.disable sends them */
void node_stop(const Model *m, double *s, LsbusBuffer *tx, int fault);

#endif
