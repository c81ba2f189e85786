/* A minimal FMI 3.0 Co-Simulation host in C, for testing the ujfmu FMI 3.0 FMUs outside Python
 * (tests/fmu3/test_c_host3.py).
 *
 * usage: fmi3_host BINARY INSTANTIATION_TOKEN RESOURCE_PATH STEP_SIZE N_STEPS
 * stdin:  line 1: n_in vr_in...   line 2: n_out vr_out...   then N_STEPS lines of n_in input values
 * stdout: N_STEPS lines of n_out output values (%.17g), read after each fmi3DoStep
 * Exit status 0 on success; 2 if an FMI call does not return fmi3OK (the status and the FMU log are on stderr).
 * On Linux the pythonfmu3 binary needs libpython preloaded: LD_PRELOAD=.../libpython3.X.so fmi3_host ...
 */
#include <dlfcn.h>
#include <stdio.h>
#include <stdlib.h>

#include "fmi3Functions.h"

static void logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category, fmi3String message) {
    (void)env;
    fprintf(stderr, "[%d] %s: %s\n", (int)status, category, message);
}

#define LOAD(name) \
    name##TYPE *name = (name##TYPE *)dlsym(lib, #name); \
    if (!name) { fprintf(stderr, "missing %s\n", #name); return 1; }
#define CHECK(call) \
    do { fmi3Status s_ = (call); if (s_ != fmi3OK) { fprintf(stderr, "%s returned %d\n", #call, (int)s_); \
         return 2; } } while (0)

int main(int argc, char **argv) {
    if (argc != 6) {
        fprintf(stderr, "usage: %s BINARY INSTANTIATION_TOKEN RESOURCE_PATH STEP_SIZE N_STEPS\n", argv[0]);
        return 1;
    }
    void *lib = dlopen(argv[1], RTLD_NOW | RTLD_LOCAL);
    if (!lib) { fprintf(stderr, "dlopen: %s\n", dlerror()); return 1; }
    LOAD(fmi3InstantiateCoSimulation) LOAD(fmi3EnterInitializationMode) LOAD(fmi3ExitInitializationMode)
    LOAD(fmi3SetFloat64) LOAD(fmi3GetFloat64) LOAD(fmi3DoStep) LOAD(fmi3Terminate) LOAD(fmi3FreeInstance)

    double h = atof(argv[4]);
    long n_steps = atol(argv[5]);
    size_t n_in, n_out;
    if (scanf("%zu", &n_in) != 1) return 1;
    fmi3ValueReference *vr_in = calloc(n_in + 1, sizeof *vr_in);
    for (size_t i = 0; i < n_in; i++) if (scanf("%u", &vr_in[i]) != 1) return 1;
    if (scanf("%zu", &n_out) != 1) return 1;
    fmi3ValueReference *vr_out = calloc(n_out + 1, sizeof *vr_out);
    for (size_t i = 0; i < n_out; i++) if (scanf("%u", &vr_out[i]) != 1) return 1;
    fmi3Float64 *in = calloc(n_in + 1, sizeof *in), *out = calloc(n_out + 1, sizeof *out);

    fmi3Instance c = fmi3InstantiateCoSimulation("c_host", argv[2], argv[3], fmi3False, fmi3True, fmi3False,
                                                 fmi3False, NULL, 0, NULL, logger, NULL);
    if (!c) { fprintf(stderr, "fmi3InstantiateCoSimulation failed\n"); return 2; }
    CHECK(fmi3EnterInitializationMode(c, fmi3False, 0.0, 0.0, fmi3False, 0.0));
    CHECK(fmi3ExitInitializationMode(c));
    fmi3Boolean event, terminate, early;
    fmi3Float64 last;
    for (long k = 0; k < n_steps; k++) {
        for (size_t i = 0; i < n_in; i++) if (scanf("%lf", &in[i]) != 1) return 1;
        CHECK(fmi3SetFloat64(c, vr_in, n_in, in, n_in));
        CHECK(fmi3DoStep(c, k * h, h, fmi3True, &event, &terminate, &early, &last));
        CHECK(fmi3GetFloat64(c, vr_out, n_out, out, n_out));
        for (size_t i = 0; i < n_out; i++) printf(i + 1 < n_out ? "%.17g " : "%.17g\n", out[i]);
    }
    CHECK(fmi3Terminate(c));
    fmi3FreeInstance(c);
    free(vr_in); free(vr_out); free(in); free(out);
    return 0;
}
