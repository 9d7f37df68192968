/* The vdp2 Van der Pol oscillator as an FMI 3.0 co-simulation FMU: der(x0) = x1,
 * der(x1) = mu (1 - x0^2) x1 - x0 (mu = 1, x0 = 2, x1 = 0 by default); every doStep is one
 * classic RK4 step of the communication step size. No state get/set.
 * Written for twmr-cosim's tests; built at test time against the FMI 3.0 headers fmpy ships. */
#include <stdlib.h>
#include "fmi3Functions.h"

enum { VR_TIME = 0, VR_X0 = 1, VR_X1 = 2, VR_MU = 3 };
typedef struct { double x0, x1, mu, time; int initialized; } Inst;

static void rhs(double mu, double x0, double x1, double *d0, double *d1) {
    *d0 = x1;
    *d1 = mu * (1.0 - x0 * x0) * x1 - x0;
}

const char *fmi3GetVersion(void) { return fmi3Version; }
fmi3Status fmi3SetDebugLogging(fmi3Instance c, fmi3Boolean on, size_t n, const fmi3String cat[]) { return fmi3OK; }

fmi3Instance fmi3InstantiateCoSimulation(fmi3String name, fmi3String token, fmi3String res,
    fmi3Boolean visible, fmi3Boolean log, fmi3Boolean eventMode, fmi3Boolean earlyReturn,
    const fmi3ValueReference req[], size_t nreq, fmi3InstanceEnvironment env,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback update) {
    Inst *c = (Inst *)calloc(1, sizeof(Inst));
    if (c) { c->x0 = 2.0; c->x1 = 0.0; c->mu = 1.0; }
    return c;
}
void fmi3FreeInstance(fmi3Instance c) { free(c); }
fmi3Status fmi3EnterInitializationMode(fmi3Instance c, fmi3Boolean tolDef, fmi3Float64 tol,
    fmi3Float64 start, fmi3Boolean stopDef, fmi3Float64 stop) { ((Inst *)c)->time = start; return fmi3OK; }
fmi3Status fmi3ExitInitializationMode(fmi3Instance c) { ((Inst *)c)->initialized = 1; return fmi3OK; }
fmi3Status fmi3Terminate(fmi3Instance c) { return fmi3OK; }
fmi3Status fmi3Reset(fmi3Instance c) { return fmi3OK; }

fmi3Status fmi3GetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, fmi3Float64 v[], size_t nv) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        switch (vr[j]) {
        case VR_TIME: v[j] = i->time; break;
        case VR_X0: v[j] = i->x0; break;
        case VR_X1: v[j] = i->x1; break;
        case VR_MU: v[j] = i->mu; break;
        default: return fmi3Error;
        }
    }
    return fmi3OK;
}
fmi3Status fmi3SetFloat64(fmi3Instance c, const fmi3ValueReference vr[], size_t n, const fmi3Float64 v[], size_t nv) {
    Inst *i = (Inst *)c;
    for (size_t j = 0; j < n; j++) {
        if (i->initialized) return fmi3Error;
        switch (vr[j]) {
        case VR_X0: i->x0 = v[j]; break;
        case VR_X1: i->x1 = v[j]; break;
        case VR_MU: i->mu = v[j]; break;
        default: return fmi3Error;
        }
    }
    return fmi3OK;
}
fmi3Status fmi3DoStep(fmi3Instance c, fmi3Float64 t, fmi3Float64 h, fmi3Boolean noSetPrior,
    fmi3Boolean *eventNeeded, fmi3Boolean *terminate, fmi3Boolean *early, fmi3Float64 *last) {
    Inst *i = (Inst *)c;
    double mu = i->mu, a0 = i->x0, a1 = i->x1, k1a, k1b, k2a, k2b, k3a, k3b, k4a, k4b;
    rhs(mu, a0, a1, &k1a, &k1b);
    rhs(mu, a0 + 0.5 * h * k1a, a1 + 0.5 * h * k1b, &k2a, &k2b);
    rhs(mu, a0 + 0.5 * h * k2a, a1 + 0.5 * h * k2b, &k3a, &k3b);
    rhs(mu, a0 + h * k3a, a1 + h * k3b, &k4a, &k4b);
    i->x0 = a0 + h / 6.0 * (k1a + 2 * k2a + 2 * k3a + k4a);
    i->x1 = a1 + h / 6.0 * (k1b + 2 * k2b + 2 * k3b + k4b);
    i->time = t + h;
    *eventNeeded = fmi3False; *terminate = fmi3False; *early = fmi3False; *last = t + h;
    return fmi3OK;
}
