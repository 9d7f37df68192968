/* A minimal FMI co-simulation host written for the tests: loads an FMU's binary with dlopen,
 * instantiates it twice, sets an input (1.0 in the first instance, 2.0 in the second), steps
 * both, gets an output, terminates and frees both; repeated REPS times, every repetition must
 * give the same numbers. Compiled as FMI 2.0, or as FMI 3.0 with -DFMI3.
 *
 * usage: fmi_host LIBRARY GUID REPS STEPS VR_IN VR_OUT   (VR_IN -1: no input)
 * prints: "ok Y1 Y2" (the output of both instances after the last repetition) and exits 0. */
#include <dlfcn.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#ifdef FMI3
#include "fmi3Functions.h"
#else
#include "fmi2Functions.h"
#endif

#define H 1e-3

static void *lib;

static void *get(const char *name) {
    void *f = dlsym(lib, name);
    if (!f) {
        fprintf(stderr, "missing %s\n", name);
        exit(2);
    }
    return f;
}

static void check(int status, const char *what) {
    if (status > 1) {  /* worse than a warning */
        fprintf(stderr, "%s failed with status %d\n", what, status);
        exit(3);
    }
}

#ifdef FMI3
typedef fmi3Instance Instance;

static void logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category,
                   fmi3String message) {
    (void)env;
    if (status > fmi3Warning) fprintf(stderr, "[%s] %s\n", category, message);
}

static Instance create(const char *name, const char *guid) {
    fmi3InstantiateCoSimulationTYPE *inst = get("fmi3InstantiateCoSimulation");
    Instance c = inst(name, guid, NULL, fmi3False, fmi3False, fmi3False, fmi3False, NULL, 0,
                      NULL, logger, NULL);
    if (!c) exit(4);
    check(((fmi3EnterInitializationModeTYPE *)get("fmi3EnterInitializationMode"))(
        c, fmi3False, 0.0, 0.0, fmi3False, 0.0), "fmi3EnterInitializationMode");
    check(((fmi3ExitInitializationModeTYPE *)get("fmi3ExitInitializationMode"))(c),
          "fmi3ExitInitializationMode");
    return c;
}

static void set(Instance c, unsigned vr, double v) {
    check(((fmi3SetFloat64TYPE *)get("fmi3SetFloat64"))(c, &vr, 1, &v, 1), "fmi3SetFloat64");
}

static double value(Instance c, unsigned vr) {
    double v;
    check(((fmi3GetFloat64TYPE *)get("fmi3GetFloat64"))(c, &vr, 1, &v, 1), "fmi3GetFloat64");
    return v;
}

static void step(Instance c, double t) {
    fmi3Boolean event, terminate, early;
    fmi3Float64 last;
    check(((fmi3DoStepTYPE *)get("fmi3DoStep"))(c, t, H, fmi3True, &event, &terminate, &early,
                                                 &last), "fmi3DoStep");
}

static void finish(Instance c) {
    check(((fmi3TerminateTYPE *)get("fmi3Terminate"))(c), "fmi3Terminate");
    ((fmi3FreeInstanceTYPE *)get("fmi3FreeInstance"))(c);
}
#else
typedef fmi2Component Instance;

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...) {
    va_list args;
    (void)env; (void)name;
    if (status <= fmi2Warning) return;
    fprintf(stderr, "[%s] ", category);
    va_start(args, message);
    vfprintf(stderr, message, args);
    va_end(args);
    fputc('\n', stderr);
}

static const fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};

static Instance create(const char *name, const char *guid) {
    fmi2InstantiateTYPE *inst = get("fmi2Instantiate");
    Instance c = inst(name, fmi2CoSimulation, guid, "", &callbacks, fmi2False, fmi2False);
    if (!c) exit(4);
    check(((fmi2SetupExperimentTYPE *)get("fmi2SetupExperiment"))(c, fmi2False, 0.0, 0.0,
                                                                  fmi2False, 0.0),
          "fmi2SetupExperiment");
    check(((fmi2EnterInitializationModeTYPE *)get("fmi2EnterInitializationMode"))(c),
          "fmi2EnterInitializationMode");
    check(((fmi2ExitInitializationModeTYPE *)get("fmi2ExitInitializationMode"))(c),
          "fmi2ExitInitializationMode");
    return c;
}

static void set(Instance c, unsigned vr, double v) {
    check(((fmi2SetRealTYPE *)get("fmi2SetReal"))(c, &vr, 1, &v), "fmi2SetReal");
}

static double value(Instance c, unsigned vr) {
    double v;
    check(((fmi2GetRealTYPE *)get("fmi2GetReal"))(c, &vr, 1, &v), "fmi2GetReal");
    return v;
}

static void step(Instance c, double t) {
    check(((fmi2DoStepTYPE *)get("fmi2DoStep"))(c, t, H, fmi2True), "fmi2DoStep");
}

static void finish(Instance c) {
    check(((fmi2TerminateTYPE *)get("fmi2Terminate"))(c), "fmi2Terminate");
    ((fmi2FreeInstanceTYPE *)get("fmi2FreeInstance"))(c);
}
#endif

int main(int argc, char **argv) {
    int reps, steps, vr_in, vr_out, rep, k;
    double first[2] = {NAN, NAN};
    if (argc != 7) {
        fprintf(stderr, "usage: %s LIBRARY GUID REPS STEPS VR_IN VR_OUT\n", argv[0]);
        return 1;
    }
    reps = atoi(argv[3]);
    steps = atoi(argv[4]);
    vr_in = atoi(argv[5]);
    vr_out = atoi(argv[6]);
    lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) {
        fprintf(stderr, "dlopen: %s\n", dlerror());
        return 5;
    }
    for (rep = 0; rep < reps; rep++) {
        Instance a = create("a", argv[2]), b = create("b", argv[2]);
        double y[2];
        for (k = 0; k < steps; k++) {
            if (vr_in >= 0) {
                set(a, (unsigned)vr_in, 1.0);
                set(b, (unsigned)vr_in, 2.0);
            }
            step(a, k * H);
            step(b, k * H);
        }
        y[0] = value(a, (unsigned)vr_out);
        y[1] = value(b, (unsigned)vr_out);
        finish(a);
        finish(b);
        if (!isfinite(y[0]) || !isfinite(y[1])) return 6;
        if (rep == 0) {
            first[0] = y[0];
            first[1] = y[1];
        } else if (y[0] != first[0] || y[1] != first[1]) {
            fprintf(stderr, "repetition %d gave %.17g %.17g, the first %.17g %.17g\n", rep,
                    y[0], y[1], first[0], first[1]);
            return 7;
        }
    }
    dlclose(lib);
    printf("ok %.17g %.17g\n", first[0], first[1]);
    return 0;
}
