/*
 * Cost of the plant FMU's fmi2DoStep under several settings (or binaries), measured in
 * interleaved blocks in one process: block b runs every configuration once over the same input
 * sequence from the same FMU state (fmi2SetFMUstate to a snapshot taken after initialization),
 * the order of the configurations reversed every other block. Only the fmi2DoStep calls are
 * timed (CLOCK_MONOTONIC around each call). Built and run by bench_plant_step.py, which prints
 * the tables; output: one JSON line per (block, configuration), then one per configuration with
 * the end state.
 *
 * usage: bench_plant_step BLOCKS STEP INPUT_FILE CONFIG...
 *   INPUT_FILE: doubles, native byte order: n, then n rows of u[1..3] (V)
 *   CONFIG:     label|path/to/rrr_plant.so|guid|resource_dir|vr=value,...
 *               a value "true"/"false" sets a Boolean, anything else a Real
 */
#define _DEFAULT_SOURCE /* strsep, clock_gettime */
#include <dlfcn.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "fmi2Functions.h"

#define MAX_CONFIGS 8
#define MAX_SETS 32

typedef struct config {
    char label[64];
    void *lib;
    fmi2InstantiateTYPE *Instantiate;
    fmi2FreeInstanceTYPE *FreeInstance;
    fmi2SetupExperimentTYPE *SetupExperiment;
    fmi2EnterInitializationModeTYPE *EnterInitializationMode;
    fmi2ExitInitializationModeTYPE *ExitInitializationMode;
    fmi2SetRealTYPE *SetReal;
    fmi2GetRealTYPE *GetReal;
    fmi2SetBooleanTYPE *SetBoolean;
    fmi2DoStepTYPE *DoStep;
    fmi2GetFMUstateTYPE *GetFMUstate;
    fmi2SetFMUstateTYPE *SetFMUstate;
    fmi2FreeFMUstateTYPE *FreeFMUstate;
    fmi2Component c;
    fmi2FMUstate s0;
    double q_end[3];
} config;

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                   fmi2String category, fmi2String message, ...)
{
    (void)env;
    va_list ap;
    va_start(ap, message);
    fprintf(stderr, "[%s %d %s] ", name, (int)status, category);
    vfprintf(stderr, message, ap);
    fputc('\n', stderr);
    va_end(ap);
}

static double now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

static void *sym(void *lib, const char *name)
{
    void *p = dlsym(lib, name);
    if (p == NULL) {
        fprintf(stderr, "missing %s\n", name);
        exit(2);
    }
    return p;
}

/* POSIX: a function pointer from dlsym through an object pointer of the same representation */
#define LOAD(F) (*(void **)(&k->F) = sym(k->lib, "fmi2" #F))

static const fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};

static void open_config(config *k, char *spec)
{
    char *fields[5] = {0};
    for (int i = 0; i < 5; ++i) {
        fields[i] = strsep(&spec, "|");
        if (fields[i] == NULL) {
            fprintf(stderr, "bad config\n");
            exit(2);
        }
    }
    snprintf(k->label, sizeof k->label, "%s", fields[0]);
    k->lib = dlopen(fields[1], RTLD_NOW | RTLD_LOCAL);
    if (k->lib == NULL) {
        fprintf(stderr, "dlopen %s: %s\n", fields[1], dlerror());
        exit(2);
    }
    LOAD(Instantiate);
    LOAD(FreeInstance);
    LOAD(SetupExperiment);
    LOAD(EnterInitializationMode);
    LOAD(ExitInitializationMode);
    LOAD(SetReal);
    LOAD(GetReal);
    LOAD(SetBoolean);
    LOAD(DoStep);
    LOAD(GetFMUstate);
    LOAD(SetFMUstate);
    LOAD(FreeFMUstate);
    k->c = k->Instantiate(k->label, fmi2CoSimulation, fields[2], fields[3], &callbacks,
                          fmi2False, fmi2False);
    if (k->c == NULL) {
        fprintf(stderr, "%s: instantiate failed\n", k->label);
        exit(2);
    }
    int ok = k->SetupExperiment(k->c, fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2OK;
    for (char *set = strsep(&fields[4], ","); set != NULL && *set != '\0';
         set = strsep(&fields[4], ",")) {
        char *eq = strchr(set, '=');
        if (eq == NULL) {
            fprintf(stderr, "bad setting %s\n", set);
            exit(2);
        }
        *eq = '\0';
        const fmi2ValueReference vr = (fmi2ValueReference)strtoul(set, NULL, 10);
        if (strcmp(eq + 1, "true") == 0 || strcmp(eq + 1, "false") == 0) {
            const fmi2Boolean b = strcmp(eq + 1, "true") == 0 ? fmi2True : fmi2False;
            ok &= k->SetBoolean(k->c, &vr, 1, &b) == fmi2OK;
        } else {
            const fmi2Real v = strtod(eq + 1, NULL);
            ok &= k->SetReal(k->c, &vr, 1, &v) == fmi2OK;
        }
    }
    ok &= k->EnterInitializationMode(k->c) == fmi2OK;
    ok &= k->ExitInitializationMode(k->c) == fmi2OK;
    ok &= k->GetFMUstate(k->c, &k->s0) == fmi2OK;
    if (!ok) {
        fprintf(stderr, "%s: initialization failed\n", k->label);
        exit(2);
    }
}

int main(int argc, char **argv)
{
    if (argc < 5 || argc - 4 > MAX_CONFIGS) {
        fprintf(stderr, "usage: %s BLOCKS STEP INPUT_FILE CONFIG...\n", argv[0]);
        return 2;
    }
    const int blocks = atoi(argv[1]);
    const double step = strtod(argv[2], NULL);
    FILE *f = fopen(argv[3], "rb");
    double nd = 0.0;
    if (f == NULL || fread(&nd, sizeof nd, 1, f) != 1 || !(nd >= 1.0 && nd < 1e8)) {
        fprintf(stderr, "cannot read %s\n", argv[3]);
        return 2;
    }
    const size_t n = (size_t)nd;
    double *u = malloc(3 * n * sizeof *u);
    if (u == NULL || fread(u, sizeof *u, 3 * n, f) != 3 * n) {
        fprintf(stderr, "short input %s\n", argv[3]);
        return 2;
    }
    fclose(f);
    const int nk = argc - 4;
    static config cfg[MAX_CONFIGS];
    for (int i = 0; i < nk; ++i) {
        open_config(&cfg[i], argv[4 + i]);
    }
    const fmi2ValueReference vu[3] = {0, 1, 2}, vq[3] = {3, 4, 5};
    for (int b = 0; b < blocks; ++b) {
        for (int j = 0; j < nk; ++j) {
            config *k = &cfg[b % 2 == 0 ? j : nk - 1 - j];
            if (k->SetFMUstate(k->c, k->s0) != fmi2OK) {
                fprintf(stderr, "%s: setFMUstate failed\n", k->label);
                return 1;
            }
            double busy = 0.0;
            for (size_t s = 0; s < n; ++s) {
                if (k->SetReal(k->c, vu, 3, u + 3 * s) != fmi2OK) {
                    return 1;
                }
                const double t0 = now();
                const fmi2Status st = k->DoStep(k->c, (double)s * step, step, fmi2True);
                busy += now() - t0;
                if (st != fmi2OK) {
                    fprintf(stderr, "%s: doStep failed at step %zu\n", k->label, s);
                    return 1;
                }
            }
            double q[3];
            if (k->GetReal(k->c, vq, 3, q) != fmi2OK) {
                return 1;
            }
            if (b > 0 && memcmp(q, k->q_end, sizeof q) != 0) {
                fprintf(stderr, "%s: block %d ended elsewhere: not deterministic\n", k->label, b);
                return 1;
            }
            memcpy(k->q_end, q, sizeof q);
            printf("{\"block\": %d, \"label\": \"%s\", \"us_per_step\": %.6f}\n", b, k->label,
                   1e6 * busy / (double)n);
        }
    }
    for (int j = 0; j < nk; ++j) {
        config *k = &cfg[j];
        printf("{\"label\": \"%s\", \"q_end\": [%.17g, %.17g, %.17g]}\n", k->label, k->q_end[0],
               k->q_end[1], k->q_end[2]);
        k->FreeFMUstate(k->c, &k->s0);
        k->FreeInstance(k->c);
    }
    free(u);
    return 0;
}
