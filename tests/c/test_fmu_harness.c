/*
 * FMU harness: loads the two FMU binaries with dlopen, like an importer, and drives them through
 * the FMI 2.0 co-simulation API. It knows nothing of fmu/common: value references, names and the
 * GUID come from each FMU's modelDescription.xml; the allowed states of every function are
 * typed in again below from the FMI 2.0.4 state table. Run it under ASan and UBSan
 * (-DRRR_SANITIZE=ON).
 *
 * Usage: test_fmu_harness <plant unzip dir> <controller unzip dir>
 *        (each holding modelDescription.xml and binaries/linux64/<modelIdentifier>.so)
 *
 * Checks: instantiation arguments and GUID; start values = XML start = librrr defaults; a full
 * closed-loop lifecycle, reset and rerun; every function from every reachable state it is not
 * allowed in (fmi2Error, a log message, state unchanged); NaN/Inf and other refused sets (old
 * value kept); parameter validation naming the field; doStep arguments and a discarded step;
 * FMU state get/set/serialize/deserialize (bit-identical reruns, corrupted buffers refused);
 * two instances in one process; log categories; every allocation freed.
 */
#define _POSIX_C_SOURCE 200809L

#include <dlfcn.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2FunctionTypes.h"
#include "rrr/rrr.h"
#include "rrr_test.h"

#define H 1e-3 /* communication step, s */

/* ---- memory callbacks: count what the FMUs allocate ------------------------------------------ */

static long n_live_blocks = 0; /* allocated minus freed; 0 when everything was released */

static void *count_calloc(size_t nobj, size_t size)
{
    void *p = calloc(nobj, size);
    if (p != NULL) {
        ++n_live_blocks;
    }
    return p;
}

static void count_free(void *p)
{
    if (p != NULL) {
        --n_live_blocks;
    }
    free(p);
}

/* ---- an FMU loaded like an importer does ------------------------------------------------------ */

typedef struct fmu_api {
    void *dl;
    char *xml;       /* modelDescription.xml */
    char id[64];     /* modelIdentifier */
    char guid[64];
    fmi2GetTypesPlatformTYPE *GetTypesPlatform;
    fmi2GetVersionTYPE *GetVersion;
    fmi2SetDebugLoggingTYPE *SetDebugLogging;
    fmi2InstantiateTYPE *Instantiate;
    fmi2FreeInstanceTYPE *FreeInstance;
    fmi2SetupExperimentTYPE *SetupExperiment;
    fmi2EnterInitializationModeTYPE *EnterInitializationMode;
    fmi2ExitInitializationModeTYPE *ExitInitializationMode;
    fmi2TerminateTYPE *Terminate;
    fmi2ResetTYPE *Reset;
    fmi2GetRealTYPE *GetReal;
    fmi2GetIntegerTYPE *GetInteger;
    fmi2GetBooleanTYPE *GetBoolean;
    fmi2GetStringTYPE *GetString;
    fmi2SetRealTYPE *SetReal;
    fmi2SetIntegerTYPE *SetInteger;
    fmi2SetBooleanTYPE *SetBoolean;
    fmi2SetStringTYPE *SetString;
    fmi2GetFMUstateTYPE *GetFMUstate;
    fmi2SetFMUstateTYPE *SetFMUstate;
    fmi2FreeFMUstateTYPE *FreeFMUstate;
    fmi2SerializedFMUstateSizeTYPE *SerializedFMUstateSize;
    fmi2SerializeFMUstateTYPE *SerializeFMUstate;
    fmi2DeSerializeFMUstateTYPE *DeSerializeFMUstate;
    fmi2GetDirectionalDerivativeTYPE *GetDirectionalDerivative;
    fmi2SetRealInputDerivativesTYPE *SetRealInputDerivatives;
    fmi2GetRealOutputDerivativesTYPE *GetRealOutputDerivatives;
    fmi2DoStepTYPE *DoStep;
    fmi2CancelStepTYPE *CancelStep;
    fmi2GetStatusTYPE *GetStatus;
    fmi2GetRealStatusTYPE *GetRealStatus;
    fmi2GetIntegerStatusTYPE *GetIntegerStatus;
    fmi2GetBooleanStatusTYPE *GetBooleanStatus;
    fmi2GetStringStatusTYPE *GetStringStatus;
} fmu_api;

static char *read_file(const char *path)
{
    FILE *f = fopen(path, "rb");
    if (f == NULL) {
        return NULL;
    }
    char *buf = NULL;
    if (fseek(f, 0, SEEK_END) == 0) {
        const long n = ftell(f);
        if (n > 0 && fseek(f, 0, SEEK_SET) == 0) {
            buf = malloc((size_t)n + 1);
            if (buf != NULL && fread(buf, 1, (size_t)n, f) == (size_t)n) {
                buf[n] = '\0';
            } else {
                free(buf);
                buf = NULL;
            }
        }
    }
    fclose(f);
    return buf;
}

/* Value of the first attribute `attr="..."` at or after from. */
static int xml_attr(const char *from, const char *attr, char *out, size_t n)
{
    char key[80];
    snprintf(key, sizeof key, " %s=\"", attr);
    const char *p = strstr(from, key);
    if (p == NULL) {
        return 1;
    }
    p += strlen(key);
    const char *e = strchr(p, '"');
    if (e == NULL || (size_t)(e - p) >= n) {
        return 1;
    }
    memcpy(out, p, (size_t)(e - p));
    out[e - p] = '\0';
    return 0;
}

/* The <ScalarVariable ...> element of a variable, or NULL. */
static const char *xml_var(const fmu_api *api, const char *name)
{
    char key[96];
    snprintf(key, sizeof key, "<ScalarVariable name=\"%s\"", name);
    return strstr(api->xml, key);
}

/* Value reference of a variable from the XML; aborts the test run if it is missing. */
static fmi2ValueReference vr_of(const fmu_api *api, const char *name)
{
    char buf[32];
    const char *v = xml_var(api, name);
    if (v == NULL || xml_attr(v, "valueReference", buf, sizeof buf) != 0) {
        fprintf(stderr, "%s: no variable %s in modelDescription.xml\n", api->id, name);
        exit(2);
    }
    return (fmi2ValueReference)strtoul(buf, NULL, 10);
}

/* Start attribute of a variable (within its element), "" when it has none. */
static void start_of(const fmu_api *api, const char *name, char *out, size_t n)
{
    const char *v = xml_var(api, name);
    const char *end = v ? strstr(v, "</ScalarVariable>") : NULL;
    out[0] = '\0';
    if (v != NULL && end != NULL) {
        const char *s = strstr(v, " start=\"");
        if (s != NULL && s < end) {
            xml_attr(s, "start", out, n);
        }
    }
}

static void load_sym(fmu_api *api, const char *name, void *dst, size_t size)
{
    void *p = dlsym(api->dl, name);
    if (p == NULL || size != sizeof p) {
        fprintf(stderr, "%s: missing symbol %s\n", api->id, name);
        exit(2);
    }
    memcpy(dst, &p, sizeof p); /* object pointer to function pointer, the POSIX way */
}

#define LOAD(F) load_sym(api, "fmi2" #F, &api->F, sizeof api->F)

static int fmu_load(fmu_api *api, const char *dir)
{
    char path[1024];
    memset(api, 0, sizeof *api);
    snprintf(path, sizeof path, "%s/modelDescription.xml", dir);
    api->xml = read_file(path);
    if (api->xml == NULL || xml_attr(api->xml, "modelIdentifier", api->id, sizeof api->id) != 0 ||
        xml_attr(api->xml, "guid", api->guid, sizeof api->guid) != 0) {
        fprintf(stderr, "cannot read modelIdentifier and guid from %s\n", path);
        return 1;
    }
    snprintf(path, sizeof path, "%s/binaries/linux64/%s.so", dir, api->id);
    api->dl = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (api->dl == NULL) {
        fprintf(stderr, "dlopen %s: %s\n", path, dlerror());
        return 1;
    }
    LOAD(GetTypesPlatform);
    LOAD(GetVersion);
    LOAD(SetDebugLogging);
    LOAD(Instantiate);
    LOAD(FreeInstance);
    LOAD(SetupExperiment);
    LOAD(EnterInitializationMode);
    LOAD(ExitInitializationMode);
    LOAD(Terminate);
    LOAD(Reset);
    LOAD(GetReal);
    LOAD(GetInteger);
    LOAD(GetBoolean);
    LOAD(GetString);
    LOAD(SetReal);
    LOAD(SetInteger);
    LOAD(SetBoolean);
    LOAD(SetString);
    LOAD(GetFMUstate);
    LOAD(SetFMUstate);
    LOAD(FreeFMUstate);
    LOAD(SerializedFMUstateSize);
    LOAD(SerializeFMUstate);
    LOAD(DeSerializeFMUstate);
    LOAD(GetDirectionalDerivative);
    LOAD(SetRealInputDerivatives);
    LOAD(GetRealOutputDerivatives);
    LOAD(DoStep);
    LOAD(CancelStep);
    LOAD(GetStatus);
    LOAD(GetRealStatus);
    LOAD(GetIntegerStatus);
    LOAD(GetBooleanStatus);
    LOAD(GetStringStatus);
    return 0;
}

static void fmu_unload(fmu_api *api)
{
    if (api->dl != NULL) {
        dlclose(api->dl);
    }
    free(api->xml);
    memset(api, 0, sizeof *api);
}

/* ---- instances with their own log sink ---------------------------------------------------------- */

typedef struct log_sink {
    int count[6];        /* messages per fmi2Status */
    int illegal;         /* messages that report an illegal call sequence */
    int calls;           /* messages of category logCalls */
    char last[1024];     /* the last message */
    char last_error[1024]; /* the last message with status >= fmi2Error */
} log_sink;

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status,
                   fmi2String category, fmi2String message, ...)
{
    (void)instance;
    log_sink *s = env;
    va_list ap;
    va_start(ap, message);
    vsnprintf(s->last, sizeof s->last, message, ap);
    va_end(ap);
    if ((unsigned)status < 6u) {
        s->count[status]++;
    }
    if (status >= fmi2Error) {
        memcpy(s->last_error, s->last, sizeof s->last_error);
    }
    if (strstr(s->last, "illegal call sequence") != NULL) {
        s->illegal++;
    }
    if (category != NULL && strcmp(category, "logCalls") == 0) {
        s->calls++;
    }
    if (getenv("RRR_HARNESS_VERBOSE") != NULL) {
        fprintf(stderr, "  [%s %d %s] %s\n", instance ? instance : "?", (int)status,
                category ? category : "?", s->last);
    }
}

typedef struct inst {
    const fmu_api *api;
    fmi2Component c;
    log_sink log;
    fmi2CallbackFunctions cb;
} inst;

static void log_clear(inst *x)
{
    memset(&x->log, 0, sizeof x->log);
}

/* Instantiate (x must not move afterwards: the log sink is its componentEnvironment). */
static int inst_new(inst *x, const fmu_api *api, const char *name)
{
    memset(x, 0, sizeof *x);
    x->api = api;
    x->cb.logger = logger;
    x->cb.allocateMemory = count_calloc;
    x->cb.freeMemory = count_free;
    x->cb.stepFinished = NULL;
    x->cb.componentEnvironment = &x->log;
    x->c = api->Instantiate(name, fmi2CoSimulation, api->guid, "file:///nonexistent/resources",
                            &x->cb, fmi2False, fmi2False);
    CHECK(x->c != NULL);
    return x->c == NULL;
}

static void inst_free(inst *x)
{
    if (x->c != NULL) {
        x->api->FreeInstance(x->c);
        x->c = NULL;
    }
}

static fmi2Status set1(inst *x, const char *name, double v)
{
    const fmi2ValueReference vr = vr_of(x->api, name);
    return x->api->SetReal(x->c, &vr, 1, &v);
}

static double get1(inst *x, const char *name)
{
    const fmi2ValueReference vr = vr_of(x->api, name);
    double v = NAN;
    CHECK(x->api->GetReal(x->c, &vr, 1, &v) == fmi2OK);
    return v;
}

/* Names of three joint variables, e.g. "q" -> q[1], q[2], q[3]. */
static void vrs3(const fmu_api *api, const char *base, fmi2ValueReference vr[3])
{
    for (int i = 0; i < 3; ++i) {
        char name[32];
        snprintf(name, sizeof name, "%s[%d]", base, i + 1);
        vr[i] = vr_of(api, name);
    }
}

/* ---- the model parameters, named as in both FMUs ------------------------------------------------ */

#define N_MODEL_PARAMS (6 + RRR_NP + 3 + 9 + 9 + 3 + 1)

static void model_params(const rrr_model *m, char names[N_MODEL_PARAMS][16],
                         double values[N_MODEL_PARAMS])
{
    int k = 0;
    const char *scalars[] = {"d1", "a2", "a3", "d2", "d3", "g"};
    const double sv[] = {m->d1, m->a2, m->a3, m->d2, m->d3, m->g};
    for (int i = 0; i < 6; ++i, ++k) {
        snprintf(names[k], 16, "%s", scalars[i]);
        values[k] = sv[i];
    }
    for (int i = 0; i < RRR_NP; ++i, ++k) {
        snprintf(names[k], 16, "p[%d]", i + 1);
        values[k] = m->p[i];
    }
    for (int i = 0; i < 3; ++i, ++k) {
        snprintf(names[k], 16, "kt[%d]", i + 1);
        values[k] = m->kt[i];
    }
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j, ++k) {
            snprintf(names[k], 16, "f[%d,%d]", i + 1, j + 1);
            values[k] = m->f[i][j];
        }
    }
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j, ++k) {
            snprintf(names[k], 16, "w[%d,%d]", i + 1, j + 1);
            values[k] = m->w[i][j];
        }
    }
    for (int i = 0; i < 3; ++i, ++k) {
        snprintf(names[k], 16, "b[%d]", i + 1);
        values[k] = m->b[i];
    }
    snprintf(names[k], 16, "u_max");
    values[k] = m->u_max;
}

/* Value after instantiation (read in initialization mode) = XML start = expected. */
static void check_default(inst *x, const char *name, double expected)
{
    char start[64];
    start_of(x->api, name, start, sizeof start);
    const double v = get1(x, name);
    if (!(v == expected) || start[0] == '\0' || !(strtod(start, NULL) == expected)) {
        fprintf(stderr, "%s: %s = %.17g, XML start \"%s\", librrr default %.17g\n", x->api->id,
                name, v, start, expected);
        rrr_test_failures++;
    }
}

static void test_defaults(const fmu_api *plant, const fmu_api *ctrl)
{
    rrr_model m;
    rrr_ctc_gains g;
    CHECK(rrr_model_default(&m) == RRR_OK);
    CHECK(rrr_ctc_gains_default(&g) == RRR_OK);
    char names[N_MODEL_PARAMS][16];
    double values[N_MODEL_PARAMS];
    model_params(&m, names, values);

    inst p, c;
    if (inst_new(&p, plant, "defaults_plant") || inst_new(&c, ctrl, "defaults_ctrl")) {
        return;
    }
    CHECK(plant->EnterInitializationMode(p.c) == fmi2OK);
    CHECK(ctrl->EnterInitializationMode(c.c) == fmi2OK);
    for (int k = 0; k < N_MODEL_PARAMS; ++k) {
        check_default(&p, names[k], values[k]);
        check_default(&c, names[k], values[k]);
    }
    check_default(&p, "h_int", RRR_PLANT_H_INT_DEFAULT);
    for (int i = 0; i < 3; ++i) {
        char name[32];
        const char *zero_plant[] = {"u", "q0", "qd0"};
        const char *zero_ctrl[] = {"q_ref", "qd_ref", "qdd_ref", "q", "qd"};
        for (size_t k = 0; k < 3; ++k) {
            snprintf(name, sizeof name, "%s[%d]", zero_plant[k], i + 1);
            check_default(&p, name, 0.0);
        }
        for (size_t k = 0; k < 5; ++k) {
            snprintf(name, sizeof name, "%s[%d]", zero_ctrl[k], i + 1);
            check_default(&c, name, 0.0);
        }
        snprintf(name, sizeof name, "kp[%d]", i + 1);
        check_default(&c, name, g.kp[i]);
        snprintf(name, sizeof name, "kd[%d]", i + 1);
        check_default(&c, name, g.kd[i]);
    }
    const fmi2ValueReference ff = vr_of(ctrl, "feedforward");
    fmi2Boolean b = fmi2False;
    char start[16];
    start_of(ctrl, "feedforward", start, sizeof start);
    CHECK(ctrl->GetBoolean(c.c, &ff, 1, &b) == fmi2OK);
    CHECK((b != fmi2False) == (g.feedforward != 0));
    CHECK(strcmp(start, g.feedforward ? "true" : "false") == 0);
    inst_free(&p);
    inst_free(&c);
}

/* ---- instantiation ------------------------------------------------------------------------------ */

static void test_instantiate(const fmu_api *api)
{
    CHECK(strcmp(api->GetTypesPlatform(), "default") == 0);
    CHECK(strcmp(api->GetVersion(), "2.0") == 0);
    log_sink sink;
    memset(&sink, 0, sizeof sink);
    fmi2CallbackFunctions cb = {logger, count_calloc, count_free, NULL, &sink};

    CHECK(api->Instantiate("x", fmi2CoSimulation, "{not-the-guid}", "", &cb, 0, 0) == NULL);
    CHECK(sink.count[fmi2Error] == 1 && strstr(sink.last_error, "GUID") != NULL);
    fmi2Component me = api->Instantiate("x", fmi2ModelExchange, api->guid, "", &cb, 0, 0);
    CHECK(me != NULL); /* one binary, both interface types */
    api->FreeInstance(me);
    CHECK(api->Instantiate("x", (fmi2Type)7, api->guid, "", &cb, 0, 0) == NULL);
    CHECK(sink.count[fmi2Error] == 2 && strstr(sink.last_error, "fmuType") != NULL);
    CHECK(api->Instantiate("", fmi2CoSimulation, api->guid, "", &cb, 0, 0) == NULL);
    CHECK(sink.count[fmi2Error] == 3 && strstr(sink.last_error, "instanceName") != NULL);
    CHECK(api->Instantiate(NULL, fmi2CoSimulation, api->guid, "", &cb, 0, 0) == NULL);
    CHECK(api->Instantiate("x", fmi2CoSimulation, NULL, "", &cb, 0, 0) == NULL);
    CHECK(api->Instantiate("x", fmi2CoSimulation, api->guid, "", NULL, 0, 0) == NULL);
    fmi2CallbackFunctions no_alloc = {logger, NULL, count_free, NULL, &sink};
    CHECK(api->Instantiate("x", fmi2CoSimulation, api->guid, "", &no_alloc, 0, 0) == NULL);
    CHECK(strstr(sink.last_error, "allocateMemory") != NULL);
    fmi2CallbackFunctions no_logger = {NULL, count_calloc, count_free, NULL, NULL};
    CHECK(api->Instantiate("x", fmi2CoSimulation, "{wrong}", "", &no_logger, 0, 0) == NULL);

    /* a NULL component is refused by every function */
    CHECK(api->Terminate(NULL) == fmi2Error);
    CHECK(api->DoStep(NULL, 0.0, H, fmi2True) == fmi2Error);
    api->FreeInstance(NULL);
}

/* ---- closed loop: controller -> plant, Gauss-Seidel, 1 kHz ------------------------------------ */

typedef struct loop {
    inst *p, *c;
    fmi2ValueReference p_u[3], p_q[3], p_qd[3], c_ref[9], c_q[3], c_qd[3], c_u[3];
    double t;
} loop;

static void loop_vrs(loop *L)
{
    vrs3(L->p->api, "u", L->p_u);
    vrs3(L->p->api, "q", L->p_q);
    vrs3(L->p->api, "qd", L->p_qd);
    vrs3(L->c->api, "q_ref", L->c_ref);
    vrs3(L->c->api, "qd_ref", L->c_ref + 3);
    vrs3(L->c->api, "qdd_ref", L->c_ref + 6);
    vrs3(L->c->api, "q", L->c_q);
    vrs3(L->c->api, "qd", L->c_qd);
    vrs3(L->c->api, "u", L->c_u);
}

/* Smooth reference: q_ref, qd_ref, qdd_ref at t. */
static void reference(double t, double r[9])
{
    const double q0[3] = {0.1, 0.3, -0.8};
    const double a[3] = {0.6, 0.4, 0.5};
    const double w[3] = {3.0, 4.5, 4.0};
    for (int i = 0; i < 3; ++i) {
        r[i] = q0[i] + a[i] * sin(w[i] * t);
        r[3 + i] = a[i] * w[i] * cos(w[i] * t);
        r[6 + i] = -a[i] * w[i] * w[i] * sin(w[i] * t);
    }
}

/* Instantiate-to-StepComplete for both, plant started on the reference. */
static int loop_init(loop *L)
{
    double r[9];
    reference(0.0, r);
    fmi2ValueReference q0[3], qd0[3];
    vrs3(L->p->api, "q0", q0);
    vrs3(L->p->api, "qd0", qd0);
    int bad = 0;
    bad |= L->p->api->SetupExperiment(L->p->c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK;
    bad |= L->c->api->SetupExperiment(L->c->c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK;
    bad |= L->p->api->SetReal(L->p->c, q0, 3, r) != fmi2OK;
    bad |= L->p->api->SetReal(L->p->c, qd0, 3, r + 3) != fmi2OK;
    bad |= L->p->api->EnterInitializationMode(L->p->c) != fmi2OK;
    bad |= L->c->api->EnterInitializationMode(L->c->c) != fmi2OK;
    bad |= L->p->api->ExitInitializationMode(L->p->c) != fmi2OK;
    bad |= L->c->api->ExitInitializationMode(L->c->c) != fmi2OK;
    L->t = 0.0;
    CHECK(!bad);
    return bad;
}

/* One macro step; rec (9 values: q, qd, u) may be NULL. */
static int loop_step(loop *L, double rec[9])
{
    double r[9], q[3], qd[3], u[3];
    reference(L->t, r);
    int bad = 0;
    bad |= L->p->api->GetReal(L->p->c, L->p_q, 3, q) != fmi2OK;
    bad |= L->p->api->GetReal(L->p->c, L->p_qd, 3, qd) != fmi2OK;
    bad |= L->c->api->SetReal(L->c->c, L->c_ref, 9, r) != fmi2OK;
    bad |= L->c->api->SetReal(L->c->c, L->c_q, 3, q) != fmi2OK;
    bad |= L->c->api->SetReal(L->c->c, L->c_qd, 3, qd) != fmi2OK;
    bad |= L->c->api->GetReal(L->c->c, L->c_u, 3, u) != fmi2OK;
    bad |= L->p->api->SetReal(L->p->c, L->p_u, 3, u) != fmi2OK;
    bad |= L->p->api->DoStep(L->p->c, L->t, H, fmi2True) != fmi2OK;
    bad |= L->c->api->DoStep(L->c->c, L->t, H, fmi2True) != fmi2OK;
    L->t += H;
    if (rec != NULL) {
        memcpy(rec, q, sizeof q);
        memcpy(rec + 3, qd, sizeof qd);
        memcpy(rec + 6, u, sizeof u);
    }
    return bad;
}

static double loop_run(loop *L, int n, double (*rec)[9])
{
    double err = 0.0;
    for (int k = 0; k < n; ++k) {
        double row[9], r[9];
        if (loop_step(L, row)) {
            CHECK(!"loop_step failed");
            return INFINITY;
        }
        reference(L->t - H, r);
        for (int i = 0; i < 3; ++i) {
            err = fmax(err, fabs(row[i] - r[i]));
        }
        if (rec != NULL) {
            memcpy(rec[k], row, sizeof row);
        }
    }
    return err;
}

static void test_closed_loop(const fmu_api *plant, const fmu_api *ctrl)
{
    inst p, c;
    if (inst_new(&p, plant, "plant") || inst_new(&c, ctrl, "controller")) {
        return;
    }
    loop L = {&p, &c, {0}, {0}, {0}, {0}, {0}, {0}, {0}, 0.0};
    loop_vrs(&L);
    static double rec1[1000][9], rec2[1000][9];
    if (!loop_init(&L)) {
        const double err = loop_run(&L, 1000, rec1);
        printf("closed loop (PD + feedforward), 1 s at 1 kHz: max |q - q_ref| = %.3g rad\n", err);
        CHECK(err < 1e-3);
        CHECK(fabs(L.t - 1.0) < 1e-12);
    }
    fmi2Real last_t = -1.0;
    CHECK(plant->GetRealStatus(p.c, fmi2LastSuccessfulTime, &last_t) == fmi2OK);
    CHECK(fabs(last_t - 1.0) < 1e-12);
    CHECK(plant->Terminate(p.c) == fmi2OK);
    CHECK(ctrl->Terminate(c.c) == fmi2OK);
    /* reset and run again: the same trajectory, bit for bit */
    CHECK(plant->Reset(p.c) == fmi2OK);
    CHECK(ctrl->Reset(c.c) == fmi2OK);
    if (!loop_init(&L)) {
        loop_run(&L, 1000, rec2);
        CHECK(memcmp(rec1, rec2, sizeof rec1) == 0);
    }
    CHECK(p.log.count[fmi2Error] == 0 && c.log.count[fmi2Error] == 0);
    CHECK(plant->Terminate(p.c) == fmi2OK);
    CHECK(ctrl->Terminate(c.c) == fmi2OK);
    inst_free(&p);
    inst_free(&c);
}

/* ---- illegal call sequences ------------------------------------------------------------------- */

enum { ST_INST, ST_INIT, ST_DONE, ST_FAILED, ST_TERM, ST_ERR, ST_COUNT };
static const char *const state_names[ST_COUNT] = {"Instantiated", "InitializationMode",
                                                  "StepComplete", "StepFailed", "Terminated",
                                                  "Error"};
#define S_I (1u << ST_INST)
#define S_IN (1u << ST_INIT)
#define S_SC (1u << ST_DONE)
#define S_SF (1u << ST_FAILED)
#define S_T (1u << ST_TERM)
#define S_E (1u << ST_ERR)
#define S_ALL (S_I | S_IN | S_SC | S_SF | S_T | S_E)

/* Put a fresh instance into a state; returns 1 when the state is not reachable for this FMU. */
static int drive(inst *x, int state)
{
    const fmu_api *a = x->api;
    const int is_plant = strcmp(a->id, "rrr_plant") == 0;
    if (state == ST_INST) {
        return 0;
    }
    if (state == ST_FAILED && !is_plant) {
        return 1; /* the controller never discards a step */
    }
    if (state == ST_ERR) {
        /* an invalid parameter makes exitInitializationMode fail */
        CHECK(set1(x, is_plant ? "a2" : "kp[1]", -1.0) == fmi2OK);
    }
    CHECK(a->SetupExperiment(x->c, fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2OK);
    CHECK(a->EnterInitializationMode(x->c) == fmi2OK);
    if (state == ST_INIT) {
        return 0;
    }
    if (state == ST_ERR) {
        CHECK(a->ExitInitializationMode(x->c) == fmi2Error);
        return 0;
    }
    CHECK(a->ExitInitializationMode(x->c) == fmi2OK);
    CHECK(a->DoStep(x->c, 0.0, H, fmi2True) == fmi2OK);
    if (state == ST_FAILED) {
        /* 1e4 s at h_int = 1e-4 s needs 1e8 substeps: rrr_plant_step refuses, doStep discards */
        CHECK(a->DoStep(x->c, H, 1e4, fmi2True) == fmi2Discard);
    } else if (state == ST_TERM) {
        CHECK(a->Terminate(x->c) == fmi2OK);
    }
    return 0;
}

/* Which of three side-effect-free probes are accepted: identifies the state. */
static unsigned fingerprint(inst *x)
{
    const fmu_api *a = x->api;
    fmi2Real r = 0.0;
    unsigned f = 0;
    f |= (a->GetReal(x->c, NULL, 0, NULL) == fmi2OK) ? 1u : 0u;
    f |= (a->SetReal(x->c, NULL, 0, NULL) == fmi2OK) ? 2u : 0u;
    f |= (a->GetRealStatus(x->c, fmi2LastSuccessfulTime, &r) == fmi2OK) ? 4u : 0u;
    return f;
}

static const unsigned expected_fingerprint[ST_COUNT] = {2u, 3u, 7u, 5u, 5u, 1u};

typedef fmi2Status (*caller)(inst *x);

#define CALLER(NAME, ...)                                                                     \
    static fmi2Status call_##NAME(inst *x)                                                    \
    {                                                                                         \
        const fmu_api *a = x->api;                                                            \
        __VA_ARGS__                                                                           \
    }

CALLER(SetDebugLogging, return a->SetDebugLogging(x->c, fmi2False, 0, NULL);)
CALLER(SetupExperiment, return a->SetupExperiment(x->c, fmi2False, 0.0, 0.0, fmi2False, 0.0);)
CALLER(EnterInitializationMode, return a->EnterInitializationMode(x->c);)
CALLER(ExitInitializationMode, return a->ExitInitializationMode(x->c);)
CALLER(Terminate, return a->Terminate(x->c);)
CALLER(Reset, return a->Reset(x->c);)
CALLER(GetReal, const fmi2ValueReference vr = 0; fmi2Real v = 0.0;
       return a->GetReal(x->c, &vr, 1, &v);)
CALLER(GetInteger, return a->GetInteger(x->c, NULL, 0, NULL);)
CALLER(GetBoolean, return a->GetBoolean(x->c, NULL, 0, NULL);)
CALLER(GetString, return a->GetString(x->c, NULL, 0, NULL);)
CALLER(SetReal, const fmi2ValueReference vr = 0; const fmi2Real v = 0.0;
       return a->SetReal(x->c, &vr, 1, &v);)
CALLER(SetInteger, return a->SetInteger(x->c, NULL, 0, NULL);)
CALLER(SetBoolean, return a->SetBoolean(x->c, NULL, 0, NULL);)
CALLER(SetString, return a->SetString(x->c, NULL, 0, NULL);)
CALLER(GetFMUstate, fmi2FMUstate s = NULL; fmi2Status st = a->GetFMUstate(x->c, &s);
       if (s != NULL) { a->FreeFMUstate(x->c, &s); } return st;)
CALLER(FreeFMUstate, fmi2FMUstate s = NULL; return a->FreeFMUstate(x->c, &s);)
CALLER(GetDirectionalDerivative,
       return a->GetDirectionalDerivative(x->c, NULL, 0, NULL, 0, NULL, NULL);)
CALLER(SetRealInputDerivatives, return a->SetRealInputDerivatives(x->c, NULL, 0, NULL, NULL);)
CALLER(GetRealOutputDerivatives, return a->GetRealOutputDerivatives(x->c, NULL, 0, NULL, NULL);)
CALLER(DoStep, return a->DoStep(x->c, 0.0, H, fmi2True);)
CALLER(CancelStep, return a->CancelStep(x->c);)
CALLER(GetStatus, fmi2Status v; return a->GetStatus(x->c, fmi2DoStepStatus, &v);)
CALLER(GetRealStatus, fmi2Real v; return a->GetRealStatus(x->c, fmi2LastSuccessfulTime, &v);)
CALLER(GetIntegerStatus, fmi2Integer v; return a->GetIntegerStatus(x->c, fmi2DoStepStatus, &v);)
CALLER(GetBooleanStatus, fmi2Boolean v; return a->GetBooleanStatus(x->c, fmi2Terminated, &v);)
CALLER(GetStringStatus, fmi2String v; return a->GetStringStatus(x->c, fmi2PendingStatus, &v);)

/* FMI 2.0.4 section 4.2.4: the reachable states in which each function may be called.
 * fmi2Set/SerializeFMUstate etc. are allowed in every reachable state, so they never appear
 * as illegal here; fmi2CancelStep needs StepInProgress, which a synchronous FMU never enters. */
static const struct {
    const char *name;
    unsigned allowed;
    caller call;
} functions[] = {
    {"fmi2SetDebugLogging", S_ALL, call_SetDebugLogging},
    {"fmi2SetupExperiment", S_I, call_SetupExperiment},
    {"fmi2EnterInitializationMode", S_I, call_EnterInitializationMode},
    {"fmi2ExitInitializationMode", S_IN, call_ExitInitializationMode},
    {"fmi2Terminate", S_SC | S_SF, call_Terminate},
    {"fmi2Reset", S_ALL, call_Reset},
    {"fmi2GetReal", S_IN | S_SC | S_SF | S_T | S_E, call_GetReal},
    {"fmi2GetInteger", S_IN | S_SC | S_SF | S_T | S_E, call_GetInteger},
    {"fmi2GetBoolean", S_IN | S_SC | S_SF | S_T | S_E, call_GetBoolean},
    {"fmi2GetString", S_IN | S_SC | S_SF | S_T | S_E, call_GetString},
    {"fmi2SetReal", S_I | S_IN | S_SC, call_SetReal},
    {"fmi2SetInteger", S_I | S_IN | S_SC, call_SetInteger},
    {"fmi2SetBoolean", S_I | S_IN | S_SC, call_SetBoolean},
    {"fmi2SetString", S_I | S_IN | S_SC, call_SetString},
    {"fmi2GetFMUstate", S_ALL, call_GetFMUstate},
    {"fmi2FreeFMUstate", S_ALL, call_FreeFMUstate},
    {"fmi2GetDirectionalDerivative", S_IN | S_SC | S_SF | S_T | S_E, call_GetDirectionalDerivative},
    {"fmi2SetRealInputDerivatives", S_I | S_IN | S_SC, call_SetRealInputDerivatives},
    {"fmi2GetRealOutputDerivatives", S_SC | S_SF | S_T | S_E, call_GetRealOutputDerivatives},
    {"fmi2DoStep", S_SC, call_DoStep},
    {"fmi2CancelStep", 0u, call_CancelStep},
    {"fmi2GetStatus", S_SC | S_SF | S_T, call_GetStatus},
    {"fmi2GetRealStatus", S_SC | S_SF | S_T, call_GetRealStatus},
    {"fmi2GetIntegerStatus", S_SC | S_SF | S_T, call_GetIntegerStatus},
    {"fmi2GetBooleanStatus", S_SC | S_SF | S_T, call_GetBooleanStatus},
    {"fmi2GetStringStatus", S_SC | S_SF | S_T, call_GetStringStatus},
};

static void test_illegal_sequences(const fmu_api *api)
{
    int tried = 0;
    for (int st = 0; st < ST_COUNT; ++st) {
        for (size_t f = 0; f < sizeof functions / sizeof functions[0]; ++f) {
            if (functions[f].allowed & (1u << st)) {
                continue;
            }
            inst x;
            if (inst_new(&x, api, "illegal")) {
                return;
            }
            if (drive(&x, st)) {
                inst_free(&x);
                continue;
            }
            log_clear(&x);
            const fmi2Status s = functions[f].call(&x);
            const int ok = s == fmi2Error && x.log.count[fmi2Error] == 1 && x.log.illegal == 1 &&
                           strstr(x.log.last_error, functions[f].name) != NULL &&
                           strstr(x.log.last_error, state_names[st]) != NULL;
            const unsigned fp = fingerprint(&x);
            if (!ok || fp != expected_fingerprint[st]) {
                fprintf(stderr,
                        "%s: %s in state %s returned %d, %d error message(s) \"%s\"; state "
                        "fingerprint %u, expected %u\n",
                        api->id, functions[f].name, state_names[st], (int)s,
                        x.log.count[fmi2Error], x.log.last_error, fp, expected_fingerprint[st]);
                rrr_test_failures++;
            }
            /* Terminated and StepFailed share a fingerprint: only StepFailed may terminate */
            if (st == ST_FAILED || st == ST_TERM) {
                CHECK((api->Terminate(x.c) == fmi2OK) == (st == ST_FAILED));
            }
            ++tried;
            inst_free(&x);
        }
    }
    printf("%s: %d illegal (function, state) pairs refused with fmi2Error and a message\n",
           api->id, tried);
    CHECK(tried >= 50);
}

/* ---- refused values ---------------------------------------------------------------------------- */

static void expect_refused(inst *x, const char *name, double v, const char *needle)
{
    const double before = get1(x, name);
    log_clear(x);
    const fmi2Status s = set1(x, name, v);
    const double after = get1(x, name);
    if (s != fmi2Error || x->log.count[fmi2Error] != 1 || strstr(x->log.last_error, needle) == NULL ||
        memcmp(&before, &after, sizeof before) != 0) {
        fprintf(stderr, "%s: set %s = %g returned %d, message \"%s\", value %.17g -> %.17g\n",
                x->api->id, name, v, (int)s, x->log.last_error, before, after);
        rrr_test_failures++;
    }
}

static void test_bad_values(const fmu_api *plant, const fmu_api *ctrl)
{
    inst p, c;
    if (inst_new(&p, plant, "bad_plant") || inst_new(&c, ctrl, "bad_ctrl")) {
        return;
    }
    /* initialization mode: parameters and inputs */
    CHECK(plant->EnterInitializationMode(p.c) == fmi2OK);
    CHECK(ctrl->EnterInitializationMode(c.c) == fmi2OK);
    expect_refused(&p, "u[1]", NAN, "u[1]");
    expect_refused(&p, "d1", INFINITY, "d1");
    expect_refused(&p, "p[7]", -INFINITY, "p[7]");
    expect_refused(&p, "h_int", NAN, "h_int");
    expect_refused(&p, "q[2]", 1.0, "q[2]");       /* an output */
    expect_refused(&c, "q_ref[3]", NAN, "q_ref[3]");
    expect_refused(&c, "kp[2]", INFINITY, "kp[2]");
    expect_refused(&c, "f[2,3]", NAN, "f[2,3]");
    expect_refused(&c, "u_n[1]", 0.5, "u_n[1]");   /* an output */

    /* a multi-value set with one bad value changes nothing */
    {
        fmi2ValueReference vr[3];
        vrs3(plant, "u", vr);
        const double v[3] = {1.0, NAN, 2.0};
        double got[3] = {-1.0, -1.0, -1.0};
        CHECK(plant->SetReal(p.c, vr, 3, v) == fmi2Error);
        CHECK(plant->GetReal(p.c, vr, 3, got) == fmi2OK);
        CHECK(got[0] == 0.0 && got[1] == 0.0 && got[2] == 0.0);
    }
    /* unknown value reference, wrong type, NULL arrays */
    {
        const fmi2ValueReference bad = 100000;
        double v = 0.0;
        fmi2Boolean b = fmi2True;
        const fmi2ValueReference u1 = vr_of(plant, "u[1]");
        log_clear(&p);
        CHECK(plant->GetReal(p.c, &bad, 1, &v) == fmi2Error);
        CHECK(strstr(p.log.last_error, "100000") != NULL);
        CHECK(plant->SetReal(p.c, &bad, 1, &v) == fmi2Error);
        CHECK(plant->SetBoolean(p.c, &u1, 1, &b) == fmi2Error);
        CHECK(strstr(p.log.last_error, "u[1]") != NULL);
        CHECK(plant->GetInteger(p.c, &u1, 1, (fmi2Integer *)&b) == fmi2Error);
        CHECK(plant->GetReal(p.c, &u1, 1, NULL) == fmi2Error);
        CHECK(plant->SetReal(p.c, NULL, 1, &v) == fmi2Error);
        CHECK(strstr(p.log.last_error, "NULL") != NULL);
    }
    /* a good set still works after the refusals */
    CHECK(set1(&p, "u[1]", 0.25) == fmi2OK);
    CHECK(get1(&p, "u[1]") == 0.25);

    /* step complete: parameters are fixed, inputs are checked */
    CHECK(plant->ExitInitializationMode(p.c) == fmi2OK);
    CHECK(ctrl->ExitInitializationMode(c.c) == fmi2OK);
    expect_refused(&p, "u[2]", INFINITY, "u[2]");
    expect_refused(&p, "a3", 0.3, "InitializationMode"); /* fixed parameter after init */
    expect_refused(&c, "qd[1]", NAN, "qd[1]");
    expect_refused(&c, "kd[3]", 1.0, "kd[3]");
    {
        const fmi2ValueReference ff = vr_of(ctrl, "feedforward");
        const fmi2Boolean off = fmi2False;
        CHECK(ctrl->SetBoolean(c.c, &ff, 1, &off) == fmi2Error);
    }
    /* still stepping normally: nothing was corrupted */
    CHECK(plant->DoStep(p.c, 0.0, H, fmi2True) == fmi2OK);
    CHECK(ctrl->DoStep(c.c, 0.0, H, fmi2True) == fmi2OK);
    CHECK(isfinite(get1(&p, "q[1]")) && isfinite(get1(&c, "u[1]")));

    /* doStep arguments: refused, state unchanged */
    log_clear(&p);
    CHECK(plant->DoStep(p.c, H, 0.0, fmi2True) == fmi2Error);
    CHECK(plant->DoStep(p.c, H, -H, fmi2True) == fmi2Error);
    CHECK(plant->DoStep(p.c, H, NAN, fmi2True) == fmi2Error);
    CHECK(strstr(p.log.last_error, "communicationStepSize") != NULL);
    CHECK(plant->DoStep(p.c, 0.5, H, fmi2True) == fmi2Error);
    CHECK(strstr(p.log.last_error, "currentCommunicationPoint") != NULL);
    CHECK(plant->DoStep(p.c, NAN, H, fmi2True) == fmi2Error);
    CHECK(plant->DoStep(p.c, H * (1.0 + 1e-12), H, fmi2True) == fmi2OK); /* within tolerance */
    CHECK(fingerprint(&p) == expected_fingerprint[ST_DONE]);
    inst_free(&p);
    inst_free(&c);
}

/* Invalid parameters are named at exitInitializationMode. */
static void expect_invalid(const fmu_api *api, const char *name, double v, const char *needle)
{
    inst x;
    if (inst_new(&x, api, "invalid")) {
        return;
    }
    CHECK(set1(&x, name, v) == fmi2OK);
    CHECK(api->EnterInitializationMode(x.c) == fmi2OK);
    log_clear(&x);
    const fmi2Status s = api->ExitInitializationMode(x.c);
    if (s != fmi2Error || strstr(x.log.last_error, needle) == NULL) {
        fprintf(stderr, "%s: %s = %g: exitInitializationMode returned %d, message \"%s\"\n",
                api->id, name, v, (int)s, x.log.last_error);
        rrr_test_failures++;
    }
    CHECK(fingerprint(&x) == expected_fingerprint[ST_ERR]);
    /* reset recovers from the error state */
    CHECK(api->Reset(x.c) == fmi2OK);
    CHECK(api->EnterInitializationMode(x.c) == fmi2OK);
    CHECK(api->ExitInitializationMode(x.c) == fmi2OK);
    inst_free(&x);
}

static void test_validation(const fmu_api *plant, const fmu_api *ctrl)
{
    expect_invalid(plant, "a2", -0.1, "a2");
    expect_invalid(plant, "kt[2]", 0.0, "kt[2]");
    expect_invalid(plant, "w[3,1]", -1.0, "w[3,1]");
    expect_invalid(plant, "u_max", 0.0, "u_max");
    expect_invalid(plant, "p[7]", -10.0, "p[1]..p[16]");
    expect_invalid(plant, "h_int", 0.0, "h_int");
    expect_invalid(ctrl, "b[1]", -0.5, "b[1]");
    expect_invalid(ctrl, "kp[2]", -1.0, "kp[2]");
    expect_invalid(ctrl, "kd[3]", -1.0, "kd[3]");
    expect_invalid(ctrl, "g", -9.81, "g");
}

/* A step that cannot be taken (here 1e8 substeps) is discarded with a message naming the cause:
 * state StepFailed, the plant state unchanged. */
static void test_discard(const fmu_api *plant)
{
    inst p;
    if (inst_new(&p, plant, "discard")) {
        return;
    }
    CHECK(drive(&p, ST_DONE) == 0);
    const double q_before = get1(&p, "q[2]");
    log_clear(&p);
    CHECK(plant->DoStep(p.c, H, 1e4, fmi2True) == fmi2Discard);
    CHECK(p.log.count[fmi2Discard] == 1 && strstr(p.log.last, "substeps of h_int") != NULL);
    double t = -1.0;
    CHECK(plant->GetRealStatus(p.c, fmi2LastSuccessfulTime, &t) == fmi2OK && t == H);
    const double q_after = get1(&p, "q[2]");
    CHECK(memcmp(&q_before, &q_after, sizeof q_before) == 0);
    CHECK(plant->DoStep(p.c, H, H, fmi2True) == fmi2Error); /* not from StepFailed */
    CHECK(plant->Terminate(p.c) == fmi2OK);
    inst_free(&p);
}

/* ---- FMU state --------------------------------------------------------------------------------- */

#define N_REPLAY 300

static void test_fmu_state(const fmu_api *plant, const fmu_api *ctrl)
{
    inst p, c;
    if (inst_new(&p, plant, "state_plant") || inst_new(&c, ctrl, "state_ctrl")) {
        return;
    }
    loop L = {&p, &c, {0}, {0}, {0}, {0}, {0}, {0}, {0}, 0.0};
    loop_vrs(&L);
    static double rec1[N_REPLAY][9], rec2[N_REPLAY][9], rec3[N_REPLAY][9];
    if (loop_init(&L)) {
        return;
    }
    loop_run(&L, 200, NULL);
    const double t1 = L.t;
    fmi2FMUstate sp = NULL, sc = NULL;
    CHECK(plant->GetFMUstate(p.c, &sp) == fmi2OK && sp != NULL);
    CHECK(ctrl->GetFMUstate(c.c, &sc) == fmi2OK && sc != NULL);
    loop_run(&L, N_REPLAY, rec1);

    /* set back and rerun: bit-identical */
    CHECK(plant->SetFMUstate(p.c, sp) == fmi2OK);
    CHECK(ctrl->SetFMUstate(c.c, sc) == fmi2OK);
    L.t = t1;
    loop_run(&L, N_REPLAY, rec2);
    CHECK(memcmp(rec1, rec2, sizeof rec1) == 0);

    /* serialize, free, deserialize, set, rerun: bit-identical */
    size_t np = 0, nc = 0;
    CHECK(plant->SerializedFMUstateSize(p.c, sp, &np) == fmi2OK && np > 0);
    CHECK(ctrl->SerializedFMUstateSize(c.c, sc, &nc) == fmi2OK && nc > 0);
    fmi2Byte *bp = malloc(np);
    fmi2Byte *bc = malloc(nc);
    fmi2Byte *bad = malloc(np + 8);
    if (bp == NULL || bc == NULL || bad == NULL) {
        CHECK(!"out of memory");
        return;
    }
    CHECK(plant->SerializeFMUstate(p.c, sp, bp, np) == fmi2OK);
    CHECK(ctrl->SerializeFMUstate(c.c, sc, bc, nc) == fmi2OK);
    CHECK(plant->SerializeFMUstate(p.c, sp, bad, np - 1) == fmi2Error); /* buffer too small */
    CHECK(plant->FreeFMUstate(p.c, &sp) == fmi2OK && sp == NULL);
    CHECK(ctrl->FreeFMUstate(c.c, &sc) == fmi2OK && sc == NULL);
    CHECK(plant->DeSerializeFMUstate(p.c, bp, np, &sp) == fmi2OK && sp != NULL);
    CHECK(ctrl->DeSerializeFMUstate(c.c, bc, nc, &sc) == fmi2OK && sc != NULL);
    CHECK(plant->SetFMUstate(p.c, sp) == fmi2OK);
    CHECK(ctrl->SetFMUstate(c.c, sc) == fmi2OK);
    L.t = t1;
    loop_run(&L, N_REPLAY, rec3);
    CHECK(memcmp(rec1, rec3, sizeof rec1) == 0);

    /* corrupted, truncated or foreign bytes are refused and change nothing */
    fmi2FMUstate junk = NULL;
    memcpy(bad, bp, np);
    bad[np / 2] ^= 0x10;
    log_clear(&p);
    CHECK(plant->DeSerializeFMUstate(p.c, bad, np, &junk) == fmi2Error && junk == NULL);
    CHECK(strstr(p.log.last_error, "checksum") != NULL);
    CHECK(plant->DeSerializeFMUstate(p.c, bp, np - 8, &junk) == fmi2Error && junk == NULL);
    memcpy(bad, bp, np);
    memset(bad + np, 0, 8);
    CHECK(plant->DeSerializeFMUstate(p.c, bad, np + 8, &junk) == fmi2Error && junk == NULL);
    memcpy(bad, bp, np);
    bad[0] ^= 0x01;
    CHECK(plant->DeSerializeFMUstate(p.c, bad, np, &junk) == fmi2Error && junk == NULL);
    CHECK(strstr(p.log.last_error, "magic") != NULL);
    CHECK(ctrl->DeSerializeFMUstate(c.c, bp, np, &junk) == fmi2Error && junk == NULL);
    CHECK(ctrl->SetFMUstate(c.c, sp) == fmi2Error); /* a plant state into the controller */
    CHECK(plant->DeSerializeFMUstate(p.c, bp, 3, &junk) == fmi2Error && junk == NULL);
    CHECK(plant->SetFMUstate(p.c, NULL) == fmi2Error);
    CHECK(fingerprint(&p) == expected_fingerprint[ST_DONE]);

    /* getFMUstate into an existing state overwrites it */
    CHECK(plant->GetFMUstate(p.c, &sp) == fmi2OK);
    CHECK(plant->SetFMUstate(p.c, sp) == fmi2OK);
    double t_now = 0.0;
    CHECK(plant->GetRealStatus(p.c, fmi2LastSuccessfulTime, &t_now) == fmi2OK);
    CHECK(fabs(t_now - L.t) < 1e-12);

    /* a state saved in StepComplete brings a failed step back to StepComplete */
    CHECK(plant->DoStep(p.c, L.t, 1e4, fmi2True) == fmi2Discard);
    CHECK(fingerprint(&p) == expected_fingerprint[ST_FAILED]);
    CHECK(plant->SetFMUstate(p.c, sp) == fmi2OK);
    CHECK(plant->DoStep(p.c, L.t, H, fmi2True) == fmi2OK);

    fmi2FMUstate none = NULL;
    CHECK(plant->FreeFMUstate(p.c, &none) == fmi2OK);
    CHECK(plant->FreeFMUstate(p.c, &sp) == fmi2OK && sp == NULL);
    CHECK(ctrl->FreeFMUstate(c.c, &sc) == fmi2OK && sc == NULL);
    free(bp);
    free(bc);
    free(bad);
    inst_free(&p);
    inst_free(&c);
}

/* Two instances of one FMU in one process do not share anything. */
static void test_two_instances(const fmu_api *plant)
{
    enum { N = 200 };
    static double q1[N][3], q2[N][3], q3[N][3];
    inst a, b, solo;
    if (inst_new(&a, plant, "a") || inst_new(&b, plant, "b")) {
        return;
    }
    fmi2ValueReference u[3], q[3];
    vrs3(plant, "u", u);
    vrs3(plant, "q", q);
    const double ua[3] = {1.0, 0.0, 0.0}, ub[3] = {0.0, -1.5, 0.5};
    CHECK(set1(&b, "q0[2]", 0.7) == fmi2OK);
    CHECK(drive(&a, ST_INIT) == 0 && drive(&b, ST_INIT) == 0);
    CHECK(plant->ExitInitializationMode(a.c) == fmi2OK);
    CHECK(plant->ExitInitializationMode(b.c) == fmi2OK);
    CHECK(plant->SetReal(a.c, u, 3, ua) == fmi2OK);
    CHECK(plant->SetReal(b.c, u, 3, ub) == fmi2OK);
    for (int k = 0; k < N; ++k) {
        CHECK(plant->DoStep(a.c, k * H, H, fmi2True) == fmi2OK);
        CHECK(plant->DoStep(b.c, k * H, H, fmi2True) == fmi2OK);
        CHECK(plant->GetReal(a.c, q, 3, q1[k]) == fmi2OK);
        CHECK(plant->GetReal(b.c, q, 3, q2[k]) == fmi2OK);
    }
    inst_free(&b);
    if (inst_new(&solo, plant, "solo")) {
        return;
    }
    CHECK(drive(&solo, ST_INIT) == 0);
    CHECK(plant->ExitInitializationMode(solo.c) == fmi2OK);
    CHECK(plant->SetReal(solo.c, u, 3, ua) == fmi2OK);
    for (int k = 0; k < N; ++k) {
        CHECK(plant->DoStep(solo.c, k * H, H, fmi2True) == fmi2OK);
        CHECK(plant->GetReal(solo.c, q, 3, q3[k]) == fmi2OK);
    }
    CHECK(memcmp(q1, q3, sizeof q1) == 0);
    CHECK(memcmp(q1, q2, sizeof q1) != 0);
    inst_free(&a);
    inst_free(&solo);
}

/* ---- logging ----------------------------------------------------------------------------------- */

static void test_logging(const fmu_api *api)
{
    inst x;
    if (inst_new(&x, api, "logging")) {
        return;
    }
    const fmi2String unknown[] = {"logStatusError", "logNoSuchThing"};
    CHECK(api->SetDebugLogging(x.c, fmi2True, 2, unknown) == fmi2Error);
    CHECK(strstr(x.log.last_error, "logNoSuchThing") != NULL);
    CHECK(api->SetDebugLogging(x.c, fmi2True, 1, NULL) == fmi2Error);

    const fmi2String calls[] = {"logCalls"};
    log_clear(&x);
    CHECK(api->SetDebugLogging(x.c, fmi2True, 1, calls) == fmi2OK);
    CHECK(api->SetupExperiment(x.c, fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2OK);
    CHECK(x.log.calls >= 1 && strstr(x.log.last, "fmi2SetupExperiment") != NULL);
    CHECK(api->SetDebugLogging(x.c, fmi2False, 1, calls) == fmi2OK);
    log_clear(&x);
    CHECK(api->EnterInitializationMode(x.c) == fmi2OK);
    CHECK(x.log.calls == 0);

    /* errors are logged by default and can be switched off explicitly */
    const fmi2String errors[] = {"logStatusError"};
    CHECK(api->SetDebugLogging(x.c, fmi2False, 1, errors) == fmi2OK);
    log_clear(&x);
    CHECK(api->DoStep(x.c, 0.0, H, fmi2True) == fmi2Error);
    CHECK(x.log.count[fmi2Error] == 0);
    const fmi2String all[] = {"logAll"};
    CHECK(api->SetDebugLogging(x.c, fmi2True, 1, all) == fmi2OK);
    CHECK(api->DoStep(x.c, 0.0, H, fmi2True) == fmi2Error);
    CHECK(x.log.count[fmi2Error] == 1);
    CHECK(api->SetDebugLogging(x.c, fmi2False, 0, NULL) == fmi2OK);
    log_clear(&x);
    CHECK(api->ExitInitializationMode(x.c) == fmi2OK && x.log.calls == 0);
    inst_free(&x);
}

int main(int argc, char **argv)
{
    if (argc != 3) {
        fprintf(stderr, "usage: %s <plant unzip dir> <controller unzip dir>\n", argv[0]);
        return 2;
    }
    fmu_api plant, ctrl;
    if (fmu_load(&plant, argv[1]) || fmu_load(&ctrl, argv[2])) {
        return 2;
    }
    CHECK(strcmp(plant.id, "rrr_plant") == 0);
    CHECK(strcmp(ctrl.id, "rrr_controller") == 0);

    test_instantiate(&plant);
    test_instantiate(&ctrl);
    test_defaults(&plant, &ctrl);
    test_closed_loop(&plant, &ctrl);
    test_illegal_sequences(&plant);
    test_illegal_sequences(&ctrl);
    test_bad_values(&plant, &ctrl);
    test_validation(&plant, &ctrl);
    test_discard(&plant);
    test_fmu_state(&plant, &ctrl);
    test_two_instances(&plant);
    test_logging(&plant);
    test_logging(&ctrl);

    if (n_live_blocks != 0) {
        fprintf(stderr, "%ld block(s) allocated through the callbacks were not freed\n",
                n_live_blocks);
        rrr_test_failures++;
    }
    fmu_unload(&plant);
    fmu_unload(&ctrl);
    return rrr_test_report("test_fmu_harness");
}
