/*
 * fmu_run: a small portable FMI importer. One C11 source for Linux (dlopen) and Windows
 * (LoadLibraryA/GetProcAddress, built with mingw-w64 and run under wine by CTest), so that the
 * Linux and the Windows binaries of the same FMUs can be run over the same scenarios and their
 * results compared (tests/c/fmu_run/compare_runs.py).
 *
 * Usage: fmu_run <2|3> <plant unzip dir> <controller unzip dir> [seconds]
 *
 * Reads each modelDescription.xml through c_src/fmi_import (modelIdentifier, guid /
 * instantiationToken, value references
 * by name), loads binaries/<platform>/<modelIdentifier>.<so|dll> (platform chosen at compile
 * time: linux64 / x86_64-linux, win64 / x86_64-windows) and runs Co-Simulation at 1 ms over
 * [0, seconds] (default 1 s):
 *   plant: the plant alone under time-varying motor voltages;
 *   loop:  controller -> plant (Gauss-Seidel) along a smooth joint reference.
 * Prints CSV to stdout: per scenario a header line ("scenario,t,<variable names>") and one line
 * per communication point t_k = k * 1 ms, k = 0..N, with every signal as %.17g.
 * Every FMI call is checked (only OK is accepted); on any failure a message goes to stderr and
 * the exit status is nonzero. Everything is freed on every path.
 */
#ifdef _WIN32
#define __USE_MINGW_ANSI_STDIO 1 /* C99 printf (%.17g) instead of msvcrt's */
#define WIN32_LEAN_AND_MEAN
#else
#define _POSIX_C_SOURCE 200809L
#endif

#include <float.h>
#include <math.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#ifdef _WIN32
#include <fcntl.h>
#include <io.h>
#endif

#include "fmi2FunctionTypes.h"
#include "fmi3FunctionTypes.h"
#include "rrr_fmi_import.h"
#include "../fmu_test_reference.h"

#define STEP 1e-3        /* communication step, s */
#define MAX_STEPS 100000 /* at most 100 s */
#define PATH_LEN 4096

/* ---- an FMU: its XML, its binary, one instance -------------------------------------------------- */

typedef enum var_type { VT_REAL, VT_BOOL } var_type;

typedef struct fmu {
    int fmi; /* 2 or 3 */
    rrr_fmi_md md;   /* modelDescription.xml (c_src/fmi_import) */
    const char *id;  /* md.id: the modelIdentifier */
    char resource_uri[PATH_LEN + 32];
    rrr_fmi_lib dl;
    void *inst; /* fmi2Component or fmi3Instance */
    char inst_name[64];
    /* FMI 2.0 */
    fmi2GetVersionTYPE *f2GetVersion;
    fmi2GetTypesPlatformTYPE *f2GetTypesPlatform;
    fmi2InstantiateTYPE *f2Instantiate;
    fmi2FreeInstanceTYPE *f2FreeInstance;
    fmi2SetupExperimentTYPE *f2SetupExperiment;
    fmi2EnterInitializationModeTYPE *f2EnterInitializationMode;
    fmi2ExitInitializationModeTYPE *f2ExitInitializationMode;
    fmi2TerminateTYPE *f2Terminate;
    fmi2GetRealTYPE *f2GetReal;
    fmi2SetRealTYPE *f2SetReal;
    fmi2GetBooleanTYPE *f2GetBoolean;
    fmi2SetBooleanTYPE *f2SetBoolean;
    fmi2DoStepTYPE *f2DoStep;
    fmi2CallbackFunctions f2cb;
    /* FMI 3.0 */
    fmi3GetVersionTYPE *f3GetVersion;
    fmi3InstantiateCoSimulationTYPE *f3InstantiateCoSimulation;
    fmi3FreeInstanceTYPE *f3FreeInstance;
    fmi3EnterInitializationModeTYPE *f3EnterInitializationMode;
    fmi3ExitInitializationModeTYPE *f3ExitInitializationMode;
    fmi3TerminateTYPE *f3Terminate;
    fmi3GetFloat64TYPE *f3GetFloat64;
    fmi3SetFloat64TYPE *f3SetFloat64;
    fmi3GetBooleanTYPE *f3GetBoolean;
    fmi3SetBooleanTYPE *f3SetBoolean;
    fmi3DoStepTYPE *f3DoStep;
} fmu;

/* ---- callbacks ------------------------------------------------------------------------------------ */

static long n_live_blocks = 0; /* FMI 2: blocks the FMUs allocated and did not free */

static void *cb_calloc(size_t nobj, size_t size)
{
    void *p = calloc(nobj, size);
    if (p != NULL) {
        ++n_live_blocks;
    }
    return p;
}

static void cb_free(void *p)
{
    if (p != NULL) {
        --n_live_blocks;
    }
    free(p);
}

static void log2_cb(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status,
                    fmi2String category, fmi2String message, ...)
{
    (void)env;
    char text[2048];
    va_list ap;
    va_start(ap, message);
    vsnprintf(text, sizeof text, message != NULL ? message : "", ap);
    va_end(ap);
    fprintf(stderr, "[%s status %d %s] %s\n", instance != NULL ? instance : "?", (int)status,
            category != NULL ? category : "?", text);
}

static void log3_cb(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category,
                    fmi3String message)
{
    const fmu *f = env;
    fprintf(stderr, "[%s status %d %s] %s\n", f != NULL ? f->inst_name : "?", (int)status,
            category != NULL ? category : "?", message != NULL ? message : "");
}

/* ---- status checks -------------------------------------------------------------------------------- */

/* 0 when status is OK; otherwise names the call and returns 1. The status of either version
 * (fmi2Status, fmi3Status: enums without negative values, fmi2OK == fmi3OK == 0). */
static int check(const fmu *f, const char *call, unsigned int status)
{
    if (status == 0) {
        return 0;
    }
    static const char *const names[] = {"OK", "Warning", "Discard", "Error", "Fatal", "Pending"};
    const char *name = status < 6 ? names[status] : "(invalid status)";
    fprintf(stderr, "fmu_run: %s: fmi%d%s returned %s (%u)\n", f->inst_name, f->fmi, call, name,
            status);
    return 1;
}

/* ---- loading ------------------------------------------------------------------------------------- */

#define SYM(FIELD, NAME) sym(f, NAME, &f->FIELD, sizeof f->FIELD)

static int sym(fmu *f, const char *name, void *dst, size_t size)
{
    char err[256];
    if (rrr_fmi_lib_sym(&f->dl, name, dst, size, err, sizeof err) != 0) {
        fprintf(stderr, "fmu_run: %s\n", err);
        return 1;
    }
    return 0;
}

static int fmu_load(fmu *f, int fmi, const char *dir, const char *inst_name)
{
    char path[PATH_LEN];
    char err[512];
    memset(f, 0, sizeof *f);
    f->fmi = fmi;
    f->id = "";
    snprintf(f->inst_name, sizeof f->inst_name, "%s", inst_name);
    if (rrr_fmi_md_load(&f->md, dir, err, sizeof err) != 0) {
        fprintf(stderr, "fmu_run: %s\n", err);
        return 1;
    }
    if (f->md.fmi != fmi) {
        fprintf(stderr, "fmu_run: %s/modelDescription.xml is not an FMI %d.0 model description\n",
                dir, fmi);
        return 1;
    }
    f->id = f->md.id;
    /* resources: FMI 2 wants a URI, FMI 3 a path; this FMU has none, but pass them properly */
    if (rrr_fmi_resource_uri(f->resource_uri, sizeof f->resource_uri, dir) != 0 ||
        rrr_fmi_binary_path(path, sizeof path, dir, fmi, f->id) != 0) {
        fprintf(stderr, "fmu_run: path too long: %s\n", dir);
        return 1;
    }
    if (rrr_fmi_lib_open(&f->dl, path, err, sizeof err) != 0) {
        fprintf(stderr, "fmu_run: %s\n", err);
        return 1;
    }
    int bad = 0;
    if (fmi == 2) {
        bad |= SYM(f2GetVersion, "fmi2GetVersion");
        bad |= SYM(f2GetTypesPlatform, "fmi2GetTypesPlatform");
        bad |= SYM(f2Instantiate, "fmi2Instantiate");
        bad |= SYM(f2FreeInstance, "fmi2FreeInstance");
        bad |= SYM(f2SetupExperiment, "fmi2SetupExperiment");
        bad |= SYM(f2EnterInitializationMode, "fmi2EnterInitializationMode");
        bad |= SYM(f2ExitInitializationMode, "fmi2ExitInitializationMode");
        bad |= SYM(f2Terminate, "fmi2Terminate");
        bad |= SYM(f2GetReal, "fmi2GetReal");
        bad |= SYM(f2SetReal, "fmi2SetReal");
        bad |= SYM(f2GetBoolean, "fmi2GetBoolean");
        bad |= SYM(f2SetBoolean, "fmi2SetBoolean");
        bad |= SYM(f2DoStep, "fmi2DoStep");
    } else {
        bad |= SYM(f3GetVersion, "fmi3GetVersion");
        bad |= SYM(f3InstantiateCoSimulation, "fmi3InstantiateCoSimulation");
        bad |= SYM(f3FreeInstance, "fmi3FreeInstance");
        bad |= SYM(f3EnterInitializationMode, "fmi3EnterInitializationMode");
        bad |= SYM(f3ExitInitializationMode, "fmi3ExitInitializationMode");
        bad |= SYM(f3Terminate, "fmi3Terminate");
        bad |= SYM(f3GetFloat64, "fmi3GetFloat64");
        bad |= SYM(f3SetFloat64, "fmi3SetFloat64");
        bad |= SYM(f3GetBoolean, "fmi3GetBoolean");
        bad |= SYM(f3SetBoolean, "fmi3SetBoolean");
        bad |= SYM(f3DoStep, "fmi3DoStep");
    }
    if (bad) {
        return 1;
    }
    const char *v = fmi == 2 ? f->f2GetVersion() : f->f3GetVersion();
    if (v == NULL || strncmp(v, fmi == 2 ? "2.0" : "3.0", 3) != 0) {
        fprintf(stderr, "fmu_run: %s: GetVersion returned \"%s\"\n", f->id, v != NULL ? v : "");
        return 1;
    }
    if (fmi == 2 && strcmp(f->f2GetTypesPlatform(), fmi2TypesPlatform) != 0) {
        fprintf(stderr, "fmu_run: %s: fmi2GetTypesPlatform is not \"%s\"\n", f->id,
                fmi2TypesPlatform);
        return 1;
    }
    return 0;
}

/* Frees the instance, if any (the binary stays loaded). */
static void free_instance(fmu *f)
{
    if (f->inst != NULL) {
        if (f->fmi == 2) {
            f->f2FreeInstance(f->inst);
        } else {
            f->f3FreeInstance(f->inst);
        }
        f->inst = NULL;
    }
}

/* Frees the instance, unloads the binary, frees the XML; safe on a partial or no load. */
static void fmu_unload(fmu *f)
{
    free_instance(f);
    rrr_fmi_lib_close(&f->dl);
    rrr_fmi_md_free(&f->md);
}

/* Value reference of the variable called name with the given type; 1 when there is none. */
static int fmu_vr(const fmu *f, const char *name, var_type type, unsigned *vr)
{
    char err[512];
    unsigned long v = 0;
    if (rrr_fmi_md_vr(&f->md, name, type == VT_REAL ? "Real" : "Boolean", &v, err,
                      sizeof err) != 0) {
        fprintf(stderr, "fmu_run: %s\n", err);
        return 1;
    }
    *vr = (unsigned)v;
    return 0;
}

/* Value references of n names (Real/Float64). */
static int fmu_vrs(const fmu *f, const char *const *names, size_t n, unsigned *vr)
{
    int bad = 0;
    for (size_t i = 0; i < n; ++i) {
        bad |= fmu_vr(f, names[i], VT_REAL, &vr[i]);
    }
    return bad;
}

/* ---- the calls, one per FMI version --------------------------------------------------------------- */

static int fmu_instantiate(fmu *f)
{
    if (f->fmi == 2) {
        f->f2cb.logger = log2_cb;
        f->f2cb.allocateMemory = cb_calloc;
        f->f2cb.freeMemory = cb_free;
        f->f2cb.stepFinished = NULL;
        f->f2cb.componentEnvironment = f;
        f->inst = f->f2Instantiate(f->inst_name, fmi2CoSimulation, f->md.token, f->resource_uri,
                                   &f->f2cb, fmi2False, fmi2False);
    } else {
        f->inst = f->f3InstantiateCoSimulation(f->inst_name, f->md.token, NULL, fmi3False,
                                               fmi3False,
                                               fmi3False, fmi3False, NULL, 0, f, log3_cb, NULL);
    }
    if (f->inst == NULL) {
        fprintf(stderr, "fmu_run: %s: instantiation of %s failed\n", f->inst_name, f->id);
        return 1;
    }
    return 0;
}

static int fmu_enter_init(fmu *f, double t0, double t_stop)
{
    if (f->fmi == 2) {
        return check(f, "SetupExperiment",
                     f->f2SetupExperiment(f->inst, fmi2False, 0.0, t0, fmi2True, t_stop)) ||
               check(f, "EnterInitializationMode", f->f2EnterInitializationMode(f->inst));
    }
    return check(f, "EnterInitializationMode",
                 f->f3EnterInitializationMode(f->inst, fmi3False, 0.0, t0, fmi3True, t_stop));
}

static int fmu_exit_init(fmu *f)
{
    if (f->fmi == 2) {
        return check(f, "ExitInitializationMode", f->f2ExitInitializationMode(f->inst));
    }
    return check(f, "ExitInitializationMode", f->f3ExitInitializationMode(f->inst));
}

static int fmu_terminate(fmu *f)
{
    if (f->fmi == 2) {
        return check(f, "Terminate", f->f2Terminate(f->inst));
    }
    return check(f, "Terminate", f->f3Terminate(f->inst));
}

static int fmu_set_real(fmu *f, const unsigned *vr, size_t n, const double *v)
{
    if (f->fmi == 2) {
        return check(f, "SetReal", f->f2SetReal(f->inst, vr, n, v));
    }
    return check(f, "SetFloat64", f->f3SetFloat64(f->inst, vr, n, v, n));
}

static int fmu_get_real(fmu *f, const unsigned *vr, size_t n, double *v)
{
    int bad;
    if (f->fmi == 2) {
        bad = check(f, "GetReal", f->f2GetReal(f->inst, vr, n, v));
    } else {
        bad = check(f, "GetFloat64", f->f3GetFloat64(f->inst, vr, n, v, n));
    }
    for (size_t i = 0; i < n && !bad; ++i) {
        if (!(fabs(v[i]) <= DBL_MAX)) { /* not isfinite: mingw-w64's warns under -Wconversion */
            fprintf(stderr, "fmu_run: %s: value reference %u is not finite\n", f->inst_name,
                    vr[i]);
            bad = 1;
        }
    }
    return bad;
}

static int fmu_set_bool(fmu *f, unsigned vr, int value)
{
    if (f->fmi == 2) {
        const fmi2Boolean b = value ? fmi2True : fmi2False;
        return check(f, "SetBoolean", f->f2SetBoolean(f->inst, &vr, 1, &b));
    }
    const fmi3Boolean b = value != 0;
    return check(f, "SetBoolean", f->f3SetBoolean(f->inst, &vr, 1, &b, 1));
}

/* 1 when the call fails or the Boolean is not value. */
static int fmu_expect_bool(fmu *f, unsigned vr, int value)
{
    int v;
    if (f->fmi == 2) {
        fmi2Boolean b = fmi2False;
        if (check(f, "GetBoolean", f->f2GetBoolean(f->inst, &vr, 1, &b))) {
            return 1;
        }
        v = b != fmi2False;
    } else {
        fmi3Boolean b = false;
        if (check(f, "GetBoolean", f->f3GetBoolean(f->inst, &vr, 1, &b, 1))) {
            return 1;
        }
        v = b;
    }
    if (v != (value != 0)) {
        fprintf(stderr, "fmu_run: %s: Boolean %u is %d, set to %d\n", f->inst_name, vr, v, value);
        return 1;
    }
    return 0;
}

static int fmu_do_step(fmu *f, double t, double h)
{
    if (f->fmi == 2) {
        return check(f, "DoStep", f->f2DoStep(f->inst, t, h, fmi2True));
    }
    fmi3Boolean event = false, terminate = false, early = false;
    fmi3Float64 last = -1.0;
    if (check(f, "DoStep", f->f3DoStep(f->inst, t, h, fmi3True, &event, &terminate, &early, &last))) {
        return 1;
    }
    if (event || terminate || early || fabs(last - (t + h)) > 1e-12) {
        fprintf(stderr,
                "fmu_run: %s: fmi3DoStep(%.17g, %.17g): eventHandlingNeeded %d, "
                "terminateSimulation %d, earlyReturn %d, lastSuccessfulTime %.17g\n",
                f->inst_name, t, h, (int)event, (int)terminate, (int)early, last);
        return 1;
    }
    return 0;
}

/* ---- output ------------------------------------------------------------------------------------------ */

static void print_header(const char *const *names, size_t n)
{
    printf("scenario,t");
    for (size_t i = 0; i < n; ++i) {
        printf(",%s", names[i]);
    }
    printf("\n");
}

static void print_row(const char *scenario, double t, const double *v, size_t n)
{
    printf("%s,%.17g", scenario, t);
    for (size_t i = 0; i < n; ++i) {
        printf(",%.17g", v[i]);
    }
    printf("\n");
}

/* ---- the scenarios ------------------------------------------------------------------------------------ */

/* Plant outputs read in both scenarios. */
static const char *const plant_out_names[] = {"q[1]",   "q[2]",   "q[3]",   "qd[1]", "qd[2]",
                                              "qd[3]",  "qdd[1]", "qdd[2]", "qdd[3]", "tip.x",
                                              "tip.y",  "tip.z"};
#define N_PLANT_OUT 12

static const char *const joint3[][3] = {
    {"u[1]", "u[2]", "u[3]"},    {"q0[1]", "q0[2]", "q0[3]"},
    {"qd0[1]", "qd0[2]", "qd0[3]"}, {"q_ref[1]", "q_ref[2]", "q_ref[3]"},
    {"qd_ref[1]", "qd_ref[2]", "qd_ref[3]"}, {"qdd_ref[1]", "qdd_ref[2]", "qdd_ref[3]"},
    {"q[1]", "q[2]", "q[3]"},    {"qd[1]", "qd[2]", "qd[3]"}};
enum { J_U, J_Q0, J_QD0, J_QREF, J_QDREF, J_QDDREF, J_Q, J_QD };

/* Motor voltages of the plant-alone scenario: smooth, different per joint, within the limit
 * u_max; the arm, started in motion, swings under them and gravity. */
static void voltages(double t, double u[3])
{
    const double pi = 3.14159265358979323846;
    u[0] = 0.5 + 1.0 * sin(2.0 * pi * 1.5 * t);
    u[1] = 2.6 + 1.5 * cos(2.0 * pi * 2.0 * t);
    u[2] = 0.8 + 1.2 * sin(2.0 * pi * 3.0 * t + 0.5);
}

/* (a) the plant alone, from a non-trivial initial state, under voltages(t). */
static int run_plant(fmu *plant, int n_steps)
{
    unsigned vr_u[3], vr_q0[3], vr_qd0[3], vr_out[N_PLANT_OUT];
    if (fmu_vrs(plant, joint3[J_U], 3, vr_u) || fmu_vrs(plant, joint3[J_Q0], 3, vr_q0) ||
        fmu_vrs(plant, joint3[J_QD0], 3, vr_qd0) ||
        fmu_vrs(plant, plant_out_names, N_PLANT_OUT, vr_out)) {
        return 1;
    }
    const double q0[3] = {0.2, -0.4, 0.9};
    const double qd0[3] = {0.0, 0.5, -1.0};
    const double t_end = n_steps * STEP;
    if (fmu_instantiate(plant) || fmu_set_real(plant, vr_q0, 3, q0) ||
        fmu_set_real(plant, vr_qd0, 3, qd0) || fmu_enter_init(plant, 0.0, t_end) ||
        fmu_exit_init(plant)) {
        return 1;
    }
    const char *names[3 + N_PLANT_OUT];
    memcpy(names, joint3[J_U], sizeof joint3[J_U]);
    memcpy(names + 3, plant_out_names, sizeof plant_out_names);
    print_header(names, 3 + N_PLANT_OUT);
    for (int k = 0; k <= n_steps; ++k) {
        const double t = k * STEP;
        double row[3 + N_PLANT_OUT];
        voltages(t, row);
        if (fmu_set_real(plant, vr_u, 3, row) || fmu_get_real(plant, vr_out, N_PLANT_OUT, row + 3)) {
            return 1;
        }
        print_row("plant", t, row, 3 + N_PLANT_OUT);
        if (k < n_steps && fmu_do_step(plant, t, STEP)) {
            return 1;
        }
    }
    return fmu_terminate(plant);
}

/* (b) controller -> plant, the plant started on the reference. */
static int run_loop(fmu *plant, fmu *ctrl, int n_steps)
{
    unsigned p_u[3], p_q0[3], p_qd0[3], p_out[N_PLANT_OUT], c_ref[9], c_q[3], c_qd[3], c_u[3];
    unsigned c_ff = 0;
    if (fmu_vrs(plant, joint3[J_U], 3, p_u) || fmu_vrs(plant, joint3[J_Q0], 3, p_q0) ||
        fmu_vrs(plant, joint3[J_QD0], 3, p_qd0) ||
        fmu_vrs(plant, plant_out_names, N_PLANT_OUT, p_out) ||
        fmu_vrs(ctrl, joint3[J_QREF], 3, c_ref) || fmu_vrs(ctrl, joint3[J_QDREF], 3, c_ref + 3) ||
        fmu_vrs(ctrl, joint3[J_QDDREF], 3, c_ref + 6) || fmu_vrs(ctrl, joint3[J_Q], 3, c_q) ||
        fmu_vrs(ctrl, joint3[J_QD], 3, c_qd) || fmu_vrs(ctrl, joint3[J_U], 3, c_u) ||
        fmu_vr(ctrl, "feedforward", VT_BOOL, &c_ff)) {
        return 1;
    }
    const double t_end = n_steps * STEP;
    double r[9];
    reference(0.0, r);
    if (fmu_instantiate(plant) || fmu_instantiate(ctrl) || fmu_set_real(plant, p_q0, 3, r) ||
        fmu_set_real(plant, p_qd0, 3, r + 3) || fmu_set_bool(ctrl, c_ff, 1) ||
        fmu_enter_init(plant, 0.0, t_end) || fmu_enter_init(ctrl, 0.0, t_end) ||
        fmu_expect_bool(ctrl, c_ff, 1) || fmu_exit_init(plant) || fmu_exit_init(ctrl)) {
        return 1;
    }
    /* columns: the reference, the controller output, the plant outputs */
    enum { N_ROW = 9 + 3 + N_PLANT_OUT };
    const char *names[N_ROW];
    memcpy(names, joint3[J_QREF], sizeof joint3[J_QREF]);
    memcpy(names + 3, joint3[J_QDREF], sizeof joint3[J_QDREF]);
    memcpy(names + 6, joint3[J_QDDREF], sizeof joint3[J_QDDREF]);
    memcpy(names + 9, joint3[J_U], sizeof joint3[J_U]);
    memcpy(names + 12, plant_out_names, sizeof plant_out_names);
    print_header(names, N_ROW);
    for (int k = 0; k <= n_steps; ++k) {
        const double t = k * STEP;
        double row[N_ROW];
        double *const ref = row, *const u = row + 9, *const out = row + 12;
        reference(t, ref);
        /* q, qd from the plant; reference, q, qd into the controller; u into the plant */
        if (fmu_get_real(plant, p_out, 6, out) || fmu_set_real(ctrl, c_ref, 9, ref) ||
            fmu_set_real(ctrl, c_q, 3, out) || fmu_set_real(ctrl, c_qd, 3, out + 3) ||
            fmu_get_real(ctrl, c_u, 3, u) || fmu_set_real(plant, p_u, 3, u) ||
            fmu_get_real(plant, p_out, N_PLANT_OUT, out)) {
            return 1;
        }
        print_row("loop", t, row, N_ROW);
        if (k < n_steps && (fmu_do_step(plant, t, STEP) || fmu_do_step(ctrl, t, STEP))) {
            return 1;
        }
    }
    return fmu_terminate(plant) || fmu_terminate(ctrl);
}

static int usage(void)
{
    fprintf(stderr, "usage: fmu_run <2|3> <plant unzip dir> <controller unzip dir> [seconds]\n"
                    "  runs the FMUs' binaries/%s|%s/*%s over [0, seconds] (default 1) at 1 ms\n",
            rrr_fmi_platform(2), rrr_fmi_platform(3), rrr_fmi_lib_ext());
    return 2;
}

int main(int argc, char **argv)
{
    if (argc < 4 || argc > 5 || (strcmp(argv[1], "2") != 0 && strcmp(argv[1], "3") != 0)) {
        return usage();
    }
    const int fmi = argv[1][0] - '0';
    double seconds = 1.0;
    if (argc == 5) {
        char *tail = NULL;
        seconds = strtod(argv[4], &tail);
        if (tail == argv[4] || *tail != '\0' || !(seconds >= STEP && seconds <= MAX_STEPS * STEP)) {
            fprintf(stderr, "fmu_run: seconds must be in [%g, %g], got \"%s\"\n", STEP,
                    MAX_STEPS * STEP, argv[4]);
            return usage();
        }
    }
    const int n_steps = (int)lround(seconds / STEP);
    if (fabs(n_steps * STEP - seconds) > 1e-9) {
        fprintf(stderr, "fmu_run: seconds must be a multiple of the step %g s, got %s\n", STEP,
                argv[4]);
        return usage();
    }
#ifdef _WIN32
    /* "\n", not "\r\n": the same bytes as on Linux */
    if (_setmode(_fileno(stdout), _O_BINARY) == -1) {
        fprintf(stderr, "fmu_run: cannot set stdout to binary mode\n");
        return 1;
    }
#endif

    fmu plant, ctrl;
    memset(&plant, 0, sizeof plant);
    memset(&ctrl, 0, sizeof ctrl);
    int bad = fmu_load(&plant, fmi, argv[2], "plant");
    bad = bad || fmu_load(&ctrl, fmi, argv[3], "controller");
    if (!bad) {
        bad = run_plant(&plant, n_steps);
        free_instance(&plant);
    }
    if (!bad) {
        bad = run_loop(&plant, &ctrl, n_steps);
    }
    fmu_unload(&ctrl);
    fmu_unload(&plant);
    if (n_live_blocks != 0) {
        fprintf(stderr, "fmu_run: the FMUs left %ld blocks allocated\n", n_live_blocks);
        bad = 1;
    }
    if (fflush(stdout) != 0 || ferror(stdout)) {
        fprintf(stderr, "fmu_run: error writing the output\n");
        bad = 1;
    }
    if (bad) {
        fprintf(stderr, "fmu_run: FAILED (FMI %d, %s, %s)\n", fmi, argv[2], argv[3]);
    }
    return bad ? 1 : 0;
}
