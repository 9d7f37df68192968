/* One FMU instance, apart from the FMI version: variable access, life cycle, time keeping. */
#ifndef TWMR_INSTANCE_H
#define TWMR_INSTANCE_H

#include <stddef.h>
#include "kernel.h"
#ifdef BUS_TERMINAL
#include "lsbus.h"
#endif

enum { ST_OK = 0, ST_WARNING = 1, ST_ERROR = 3 };  /* same codes in FMI 2.0 and 3.0 */
enum { PH_INSTANTIATED, PH_INITIALIZATION, PH_STEP, PH_TERMINATED };

/* What a saved FMU state holds: everything a step changes. */
typedef struct {
    Model m;
    int phase;
    int dirty;       /* inputs changed since the feedthrough outputs were computed */
    double start;    /* time kept as start + k h while h is constant, like the master */
    double h;
    long k;
#ifdef BUS_TERMINAL
    LsbusBuffer tx;  /* what the next tick of Tx_Clock carries */
    double node[NODE_NS];  /* the protocol's own state (node.h) */
    int event_mode, tx_active, tx_reported, rx_active;
    int sent;  /* frames of a period were sent since the step began */
    int fault;  /* a fault was seen: the drives were stopped, the FMU asks to terminate */
    long quiet;  /* steps in a row that ended without the drives' feedback */
#endif
} Core;

typedef struct Instance Instance;
typedef void (*LogFn)(Instance *s, int status, const char *category, const char *message);

struct Instance {
    Core c;
    char *name;
    LogFn log;
    double stop;         /* the experiment's stop time (INFINITY: not given) */
    void *env;           /* the importer's environment and callbacks */
    const void *callbacks;
    int logging;
};

void inst_reset(Instance *s);
void inst_log(Instance *s, int status, const char *category, const char *fmt, ...);
int inst_set(Instance *s, size_t index, size_t n, const double *values);
int inst_get(Instance *s, size_t index, size_t n, double *values);
int inst_enter_init(Instance *s, double start);
int inst_exit_init(Instance *s);
int inst_step(Instance *s, double t, double h);

#endif
