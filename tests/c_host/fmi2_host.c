/* A minimal FMI 2.0 Co-Simulation host in C, for testing the ujfmu FMUs outside Python (tests/test_c_host.py).
 *
 * usage: fmi2_host BINARY GUID RESOURCE_URI STEP_SIZE N_STEPS
 * stdin:  line 1: n_in vr_in...   line 2: n_out vr_out...   then N_STEPS lines of n_in input values
 * stdout: N_STEPS lines of n_out output values (%.17g), read after each fmi2DoStep
 * Exit status 0 on success; 2 if an FMI call does not return fmi2OK (the status and the FMU log are on stderr).
 * On Linux the pythonfmu binary needs libpython preloaded: LD_PRELOAD=.../libpython3.X.so fmi2_host ...
 */
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

#include "fmi2Functions.h"

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status, fmi2String category,
                   fmi2String message, ...) {
    (void)env;
    va_list args;   /* the message is a printf format (FMI 2.0, fmi2CallbackLogger): '%%' is a literal '%' */
    va_start(args, message);
    fprintf(stderr, "[%d] %s %s: ", (int)status, instance, category);
    vfprintf(stderr, message, args);
    fputc('\n', stderr);
    va_end(args);
}

#define LOAD(name) \
    name##TYPE *name = (name##TYPE *)dlsym(lib, #name); \
    if (!name) { fprintf(stderr, "missing %s\n", #name); return 1; }
#define CHECK(call) \
    do { fmi2Status s_ = (call); if (s_ != fmi2OK) { fprintf(stderr, "%s returned %d\n", #call, (int)s_); \
         return 2; } } while (0)

int main(int argc, char **argv) {
    if (argc != 6) {
        fprintf(stderr, "usage: %s BINARY GUID RESOURCE_URI STEP_SIZE N_STEPS\n", argv[0]);
        return 1;
    }
    void *lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) { fprintf(stderr, "dlopen: %s\n", dlerror()); return 1; }
    LOAD(fmi2Instantiate) LOAD(fmi2SetupExperiment) LOAD(fmi2EnterInitializationMode)
    LOAD(fmi2ExitInitializationMode) LOAD(fmi2SetReal) LOAD(fmi2GetReal) LOAD(fmi2DoStep)
    LOAD(fmi2Terminate) LOAD(fmi2FreeInstance)

    double h = atof(argv[4]);
    long n_steps = atol(argv[5]);
    size_t n_in, n_out;
    if (scanf("%zu", &n_in) != 1) return 1;
    fmi2ValueReference *vr_in = calloc(n_in + 1, sizeof *vr_in);
    for (size_t i = 0; i < n_in; i++) if (scanf("%u", &vr_in[i]) != 1) return 1;
    if (scanf("%zu", &n_out) != 1) return 1;
    fmi2ValueReference *vr_out = calloc(n_out + 1, sizeof *vr_out);
    for (size_t i = 0; i < n_out; i++) if (scanf("%u", &vr_out[i]) != 1) return 1;
    fmi2Real *in = calloc(n_in + 1, sizeof *in), *out = calloc(n_out + 1, sizeof *out);

    fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
    fmi2Component c = fmi2Instantiate("c_host", fmi2CoSimulation, argv[2], argv[3], &callbacks, fmi2False,
                                      fmi2True);
    if (!c) { fprintf(stderr, "fmi2Instantiate failed\n"); return 2; }
    CHECK(fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0));
    CHECK(fmi2EnterInitializationMode(c));
    CHECK(fmi2ExitInitializationMode(c));
    for (long k = 0; k < n_steps; k++) {
        for (size_t i = 0; i < n_in; i++) if (scanf("%lf", &in[i]) != 1) return 1;
        CHECK(fmi2SetReal(c, vr_in, n_in, in));
        CHECK(fmi2DoStep(c, k * h, h, fmi2True));
        CHECK(fmi2GetReal(c, vr_out, n_out, out));
        for (size_t i = 0; i < n_out; i++) printf(i + 1 < n_out ? "%.17g " : "%.17g\n", out[i]);
    }
    CHECK(fmi2Terminate(c));
    fmi2FreeInstance(c);
    free(vr_in); free(vr_out); free(in); free(out);
    return 0;
}
