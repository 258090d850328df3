/*
 * FMU harness: loads the two FMU binaries with dlopen, like an importer, and drives them through
 * the FMI 2.0 Co-Simulation and Model Exchange APIs. It knows nothing of fmu/common: value
 * references, names, the GUID and the continuous states (<ModelStructure><Derivatives>) come from
 * each FMU's modelDescription.xml; the allowed states of every function are typed in again below
 * from the FMI 2.0.4 state tables (sections 4.2.4 and 3.2.3). Run it under ASan and UBSan
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
 *
 * Model Exchange (the same binaries): the lifecycle of section 3.2.3 with the value of every call
 * (states = q0, qd0 in initialization mode, nominals > 0, no events); derivatives = librrr's
 * rrr_plant_accel bit for bit and dq/dt = qd; RK4 through setContinuousStates/getDerivatives =
 * the Co-Simulation plant in fixed-step mode (adaptive = false) bit for bit; controller
 * outputs = Co-Simulation = rrr_ctc bit for bit;
 * every function (Co-Simulation ones included) from every Model Exchange state, refused where
 * the table does not allow it (message naming function and state, serialized FMU state
 * unchanged) and accepted where it does; refused arguments (NaN/Inf states and time, wrong nx/ni,
 * NULL arrays, outputs, fixed parameters after initialization); FMU state set/serialize with a
 * bit-identical continuation; Co-Simulation and Model Exchange snapshots refused by each other.
 *
 * The checks the FMI 3.0 harness makes as well are in fmu_harness_common.c, run through this
 * harness's adapter of the FMI 2.0 calls (ops2); what is here is FMI 2.0's own.
 */
#define _POSIX_C_SOURCE 200809L

#include <ctype.h>
#include <math.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <time.h>
#include <unistd.h>

#include "fmi2FunctionTypes.h"
#include "rrr/rrr.h"
#include "fmu_state_forge.h"
#include "rrr_fmi_funcs.h"
#include "rrr_fmi_import.h"
#include "fmu_harness_common.h"
#include "rrr_test.h"

#define H 1e-3 /* communication step, s */
#define MAX_STATES 16 /* most continuous states the harness handles */

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
    rrr_fmi_lib lib;
    rrr_fmi_md md;   /* modelDescription.xml, parsed by c_src/fmi_import */
    char id[64];     /* modelIdentifier */
    char guid[128];
    char resources[1100]; /* fmuResourceLocation: file://<unzip dir>/resources */
#define DECLARE(F) fmi2##F##TYPE *F;
    RRR_FMI2_FUNCTIONS(DECLARE)
#undef DECLARE
    /* continuous states from <ModelStructure><Derivatives>, in that order (the state vector) */
    size_t nx;                            /* number of continuous states */
    size_t ni;                            /* numberOfEventIndicators */
    char x_name[MAX_STATES][RRR_FMI_NAME_MAX];  /* state variable, e.g. "q[1]" */
    char dx_name[MAX_STATES][RRR_FMI_NAME_MAX]; /* its derivative, e.g. "qd[1]" */
    fmi2ValueReference x_vr[MAX_STATES];
    fmi2ValueReference dx_vr[MAX_STATES];
} fmu_api;

/* Value reference of a variable from the XML; aborts the test run if it is missing. */
static fmi2ValueReference vr_of(const fmu_api *api, const char *name)
{
    return fh_md_vr(&api->md, name);
}

/* The k-th (1-based, the XML's index) variable of <ModelVariables>, or NULL. */
static const rrr_fmi_var *var_at(const fmu_api *api, const char *index)
{
    const unsigned long k = strtoul(index, NULL, 10);
    return k > 0 && k <= api->md.nvars ? &api->md.vars[k - 1] : NULL;
}

/* The continuous states in the order of <ModelStructure><Derivatives> (FMI 2.0.4 section 3.3:
 * that order is the state vector of fmi2GetContinuousStates and friends): each listed variable
 * is a derivative whose attribute derivative="k" names its state. Returns 0 when parsed. */
static int parse_states(fmu_api *api)
{
    char buf[32];
    const char *end = api->md.xml + api->md.len;
    rrr_fmi_tag t;
    api->nx = 0;
    api->ni = 0;
    if (rrr_fmi_find_tag(api->md.xml, end, "fmiModelDescription", &t) == RRR_FMI_OK &&
        rrr_fmi_attr(&t, "numberOfEventIndicators", buf, sizeof buf) == RRR_FMI_OK) {
        api->ni = strtoul(buf, NULL, 10);
    }
    if (rrr_fmi_find_tag(api->md.xml, end, "Derivatives", &t) != RRR_FMI_OK) {
        return 0; /* no continuous states */
    }
    for (const char *p = t.end; rrr_fmi_next_tag(p, end, &t) == RRR_FMI_OK; p = t.end) {
        if (t.closing) {
            return strncmp(t.name, "Derivatives", t.name_len) == 0 ? 0 : 1;
        }
        const size_t k = api->nx;
        if (k == MAX_STATES || rrr_fmi_attr(&t, "index", buf, sizeof buf) != RRR_FMI_OK) {
            return 1;
        }
        const rrr_fmi_var *dv = var_at(api, buf);
        if (dv == NULL || rrr_fmi_var_attr(dv, "derivative", buf, sizeof buf) != RRR_FMI_OK) {
            return 1;
        }
        const rrr_fmi_var *sv = var_at(api, buf);
        if (sv == NULL) {
            return 1;
        }
        snprintf(api->dx_name[k], sizeof api->dx_name[k], "%s", dv->name);
        snprintf(api->x_name[k], sizeof api->x_name[k], "%s", sv->name);
        api->dx_vr[k] = (fmi2ValueReference)dv->vr;
        api->x_vr[k] = (fmi2ValueReference)sv->vr;
        api->nx = k + 1;
    }
    return 1; /* the text ends or a tag is cut off inside <Derivatives> */
}

static int fmu_load(fmu_api *api, const char *dir)
{
    char err[512];
    memset(api, 0, sizeof *api);
    if (fh_open(&api->md, &api->lib, dir, 2, api->id, api->guid) != 0) {
        return 1;
    }
    snprintf(api->resources, sizeof api->resources, "file://%s/resources", dir);
#define LOAD(F)                                                                                  \
    if (rrr_fmi_lib_sym(&api->lib, "fmi2" #F, &api->F, sizeof api->F, err, sizeof err) != 0) { \
        fprintf(stderr, "%s: %s\n", api->id, err);                                              \
        return 1;                                                                                \
    }
    RRR_FMI2_FUNCTIONS(LOAD)
#undef LOAD
    /* one binary, both interface types: <ModelExchange> names the same modelIdentifier */
    if (strcmp(api->md.me_id, api->id) != 0 || parse_states(api) != 0) {
        fprintf(stderr, "%s: no <ModelExchange> for the same binary, or unreadable "
                        "<Derivatives> in %s\n", api->id, dir);
        return 1;
    }
    return 0;
}

static void fmu_unload(fmu_api *api)
{
    fh_close(&api->md, &api->lib);
    memset(api, 0, sizeof *api);
}

/* ---- instances with their own log sink ---------------------------------------------------------- */

typedef fh_log_sink log_sink;

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status,
                   fmi2String category, fmi2String message, ...)
{
    (void)instance;
    log_sink *s = env;
    va_list ap;
    va_start(ap, message);
    vsnprintf(s->last, sizeof s->last, message, ap);
    va_end(ap);
    fh_log_record(s, (int)status, category);
    if (getenv("RRR_HARNESS_VERBOSE") != NULL) {
        fprintf(stderr, "  [%s %d %s] %s\n", instance ? instance : "?", (int)status,
                category ? category : "?", s->last);
    }
}

typedef struct inst {
    const fmu_api *api;
    fmi2Component c;
    fmi2Type type;
    log_sink log;
    fmi2CallbackFunctions cb;
} inst;

static void log_clear(inst *x)
{
    memset(&x->log, 0, sizeof x->log);
}

/* Instantiate (x must not move afterwards: the log sink is its componentEnvironment). */
static int inst_new_type(inst *x, const fmu_api *api, const char *name, fmi2Type type)
{
    memset(x, 0, sizeof *x);
    x->api = api;
    x->cb.logger = logger;
    x->cb.allocateMemory = count_calloc;
    x->cb.freeMemory = count_free;
    x->cb.stepFinished = NULL;
    x->cb.componentEnvironment = &x->log;
    x->type = type;
    x->c = api->Instantiate(name, type, api->guid, api->resources, &x->cb, fmi2False,
                            fmi2False);
    CHECK(x->c != NULL);
    return x->c == NULL;
}

/* Instantiate a Co-Simulation instance with another resource location (NULL allowed). */
static int inst_new_at(inst *x, const fmu_api *api, const char *name, const char *resources)
{
    memset(x, 0, sizeof *x);
    x->api = api;
    x->cb.logger = logger;
    x->cb.allocateMemory = count_calloc;
    x->cb.freeMemory = count_free;
    x->cb.componentEnvironment = &x->log;
    x->c = api->Instantiate(name, fmi2CoSimulation, api->guid, resources, &x->cb, fmi2False,
                            fmi2False);
    CHECK(x->c != NULL);
    return x->c == NULL;
}

/* A Co-Simulation instance. */
static int inst_new(inst *x, const fmu_api *api, const char *name)
{
    return inst_new_type(x, api, name, fmi2CoSimulation);
}

/* A Model Exchange instance of the same binary. */
static int inst_new_me(inst *x, const fmu_api *api, const char *name)
{
    return inst_new_type(x, api, name, fmi2ModelExchange);
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

static fmi2Status set_bool(inst *x, const char *name, fmi2Boolean v)
{
    const fmi2ValueReference vr = vr_of(x->api, name);
    return x->api->SetBoolean(x->c, &vr, 1, &v);
}

static double get1(inst *x, const char *name)
{
    const fmi2ValueReference vr = vr_of(x->api, name);
    double v = (double)NAN;
    CHECK(x->api->GetReal(x->c, &vr, 1, &v) == fmi2OK);
    return v;
}

/* ---- the adapter of fmu_harness_common.c: the FMI 2.0 calls on an inst ------------------------ */

static int drive_to_init(inst *x);
static int drive_to_step(inst *x);
static void check_stepping(void *x, int discarded, const char *where);

static const void *a2_api(const void *x)
{
    return ((const inst *)x)->api;
}

static int a2_get_real(void *x, const unsigned int *vr, size_t n, double *v)
{
    inst *i = x;
    return (int)i->api->GetReal(i->c, vr, n, v);
}

static const char *a2_id(const void *api)
{
    return ((const fmu_api *)api)->id;
}

static int a2_set_real(void *x, const unsigned int *vr, size_t n, const double *v)
{
    inst *i = x;
    return (int)i->api->SetReal(i->c, vr, n, v);
}

static const rrr_fmi_md *a2_md(const void *api)
{
    return &((const fmu_api *)api)->md;
}

static int a2_get_bool(void *x, unsigned int vr, int *v)
{
    inst *i = x;
    fmi2Boolean b = *v;
    const fmi2Status s = i->api->GetBoolean(i->c, &vr, 1, &b);
    *v = b;
    return (int)s;
}

static const char *a2_where(const void *x)
{
    return ((const inst *)x)->type == fmi2ModelExchange ? "Model Exchange" : "Co-Simulation";
}

static int a2_setup(void *x)
{
    inst *i = x;
    return (int)i->api->SetupExperiment(i->c, fmi2False, 0.0, 0.0, fmi2False, 0.0);
}

static fh_log_sink *a2_log(void *x)
{
    return &((inst *)x)->log;
}

static int a2_enter_init(void *x)
{
    inst *i = x;
    return (int)i->api->EnterInitializationMode(i->c);
}

static void *a2_new_cs(const void *api, const char *name)
{
    inst *x = malloc(sizeof *x);
    if (x != NULL && inst_new(x, api, name) != 0) {
        free(x);
        x = NULL;
    }
    return x;
}

static int a2_exit_init(void *x)
{
    inst *i = x;
    return (int)i->api->ExitInitializationMode(i->c);
}

static void a2_del(void *x)
{
    if (x != NULL) {
        inst_free(x);
        free(x);
    }
}

/* FMI 2.0 reports lastSuccessfulTime through fmi2GetRealStatus, not fmi2DoStep */
static int a2_do_step(void *x, double t, double h, double *last_time)
{
    inst *i = x;
    if (last_time != NULL) {
        *last_time = (double)NAN;
    }
    return (int)i->api->DoStep(i->c, t, h, fmi2True);
}

static int a2_drive_init(void *x)
{
    return drive_to_init(x);
}

static int a2_drive_step(void *x)
{
    return drive_to_step(x);
}

static int a2_set_bool(void *x, unsigned int vr, int v)
{
    inst *i = x;
    const fmi2Boolean b = v;
    return (int)i->api->SetBoolean(i->c, &vr, 1, &b);
}

static int a2_terminate(void *x)
{
    inst *i = x;
    return (int)i->api->Terminate(i->c);
}

static int a2_reset(void *x)
{
    inst *i = x;
    return (int)i->api->Reset(i->c);
}

static int a2_get_state(void *x, void **s)
{
    inst *i = x;
    return (int)i->api->GetFMUstate(i->c, s);
}

static int a2_set_state(void *x, void *s)
{
    inst *i = x;
    return (int)i->api->SetFMUstate(i->c, s);
}

static int a2_free_state(void *x, void **s)
{
    inst *i = x;
    return (int)i->api->FreeFMUstate(i->c, s);
}

static int a2_state_size(void *x, void *s, size_t *n)
{
    inst *i = x;
    return (int)i->api->SerializedFMUstateSize(i->c, s, n);
}

static int a2_serialize(void *x, void *s, unsigned char *buf, size_t n)
{
    inst *i = x;
    return (int)i->api->SerializeFMUstate(i->c, s, (fmi2Byte *)buf, n);
}

static int a2_deserialize(void *x, const unsigned char *buf, size_t n, void **s)
{
    inst *i = x;
    return (int)i->api->DeSerializeFMUstate(i->c, (const fmi2Byte *)buf, n, s);
}

static const fh_ops ops2 = {
    .fmi = "fmi2", .set_real_name = "fmi2SetReal", .step_reports_time = 0,
    .drive_step = a2_drive_step, .check_stepping = check_stepping, .set_bool = a2_set_bool,
    .terminate = a2_terminate, .reset = a2_reset, .api = a2_api, .id = a2_id, .md = a2_md,
    .where = a2_where, .log = a2_log, .new_cs = a2_new_cs, .del = a2_del,
    .drive_init = a2_drive_init, .get_real = a2_get_real, .set_real = a2_set_real,
    .get_bool = a2_get_bool, .setup = a2_setup, .enter_init = a2_enter_init,
    .exit_init = a2_exit_init, .do_step = a2_do_step, .get_state = a2_get_state,
    .set_state = a2_set_state, .free_state = a2_free_state, .state_size = a2_state_size,
    .serialize = a2_serialize, .deserialize = a2_deserialize,
};

/* Value references of three joint variables, e.g. "q" -> q[1], q[2], q[3]. */
static void vrs3(const fmu_api *api, const char *base, fmi2ValueReference vr[3])
{
    fh_vrs3(&ops2, api, base, vr);
}

/* ---- start values = XML start = librrr defaults ---------------------------------------------- */

static void test_defaults(const fmu_api *plant, const fmu_api *ctrl)
{
    inst p, c;
    if (inst_new(&p, plant, "defaults_plant") || inst_new(&c, ctrl, "defaults_ctrl")) {
        return;
    }
    CHECK(plant->EnterInitializationMode(p.c) == fmi2OK);
    CHECK(ctrl->EnterInitializationMode(c.c) == fmi2OK);
    fh_check_defaults(&ops2, &p, &c);
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

/* FMI 2.0's lastSuccessfulTime after the loop's second */
static void check_last_time(fh_loop *L)
{
    const inst *p = L->p;
    fmi2Real last_t = -1.0;
    CHECK(p->api->GetRealStatus(p->c, fmi2LastSuccessfulTime, &last_t) == fmi2OK);
    CHECK(fabs(last_t - 1.0) < 1e-12);
}

static void test_closed_loop(const fmu_api *plant, const fmu_api *ctrl)
{
    inst p, c;
    if (inst_new(&p, plant, "plant") || inst_new(&c, ctrl, "controller")) {
        return;
    }
    fh_loop L;
    fh_loop_new(&L, &ops2, &p, &c);
    static double rec1[1000][9], rec2[1000][9];
    fh_loop_twice(&L, rec1, rec2, "closed loop", check_last_time, NULL);
    inst_free(&p);
    inst_free(&c);
}

/* ---- illegal call sequences ------------------------------------------------------------------- */

enum { ST_INST, ST_INIT, ST_DONE, ST_FAILED, ST_TERM, ST_ERR, ST_COUNT };
static const char *const state_names[ST_COUNT] = {"Instantiated", "InitializationMode",
                                                  "StepComplete", "StepFailed", "Terminated",
                                                  "Error"};
/* the states as bits of a mask */
enum {
    S_I = 1 << ST_INST, S_IN = 1 << ST_INIT, S_SC = 1 << ST_DONE, S_SF = 1 << ST_FAILED,
    S_T = 1 << ST_TERM, S_E = 1 << ST_ERR, S_ALL = (1 << ST_COUNT) - 1
};

/* A parameter of the FMU whose value -1 exitInitializationMode refuses. */
static const char *bad_param(const fmu_api *a)
{
    if (strcmp(a->id, "rrr_plant") == 0) {
        return "a2";
    }
    return strcmp(a->id, "rrr_reference") == 0 ? "lookahead" : "kp[1]";
}

/* Put a fresh instance into a state; returns 1 when the state is not reachable for this FMU. */
static int drive(inst *x, int state)
{
    const fmu_api *a = x->api;
    const int is_plant = strcmp(a->id, "rrr_plant") == 0;
    if (state == ST_INST) {
        return 0;
    }
    if (state == ST_FAILED && !is_plant) {
        return 1; /* the controller and the reference never discard a step */
    }
    if (state == ST_ERR) {
        /* an invalid parameter makes exitInitializationMode fail */
        CHECK(set1(x, bad_param(a), -1.0) == fmi2OK);
    }
    if (state == ST_FAILED) {
        /* the step below cannot be taken with the fixed-step RK4 (the adaptive default would
         * integrate it) */
        CHECK(set_bool(x, "adaptive", fmi2False) == fmi2OK);
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
        /* fixed step: 1e4 s at h_int = 1e-4 s needs 1e8 substeps: doStep discards */
        CHECK(a->DoStep(x->c, H, 1e4, fmi2True) == fmi2Discard);
    } else if (state == ST_TERM) {
        CHECK(a->Terminate(x->c) == fmi2OK);
    }
    return 0;
}

static int drive_to_init(inst *x)
{
    return drive(x, ST_INIT);
}

static int drive_to_step(inst *x)
{
    return drive(x, ST_DONE);
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

/* StepComplete or (discarded) StepFailed, by the fingerprint */
static void check_stepping(void *x, int discarded, const char *where)
{
    const unsigned fp = fingerprint(x), want = expected_fingerprint[discarded ? ST_FAILED : ST_DONE];
    if (fp != want) {
        fprintf(stderr, "%s %s: fingerprint %u, expected %u\n", ((inst *)x)->api->id, where, fp,
                want);
    }
    CHECK(fp == want);
}

typedef fmi2Status (*caller)(inst *x);

#define CALLER(NAME, ...) FH_CALLER(fmi2Status, fmu_api, NAME, __VA_ARGS__)

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

CALLER(SetFMUstate, fmi2FMUstate s = NULL; fmi2Status st = a->GetFMUstate(x->c, &s);
       if (s != NULL) { st = a->SetFMUstate(x->c, s); a->FreeFMUstate(x->c, &s); } return st;)
CALLER(SerializedFMUstateSize, fmi2FMUstate s = NULL; size_t n = 0;
       fmi2Status st = a->GetFMUstate(x->c, &s);
       if (s != NULL) { st = a->SerializedFMUstateSize(x->c, s, &n); a->FreeFMUstate(x->c, &s); }
       return st;)
CALLER(SerializeFMUstate, fmi2FMUstate s = NULL; fmi2Byte b[8];
       fmi2Status st = a->GetFMUstate(x->c, &s);
       if (s != NULL) {
           st = a->SerializeFMUstate(x->c, s, b, sizeof b); /* too small: refused, not illegal */
           a->FreeFMUstate(x->c, &s);
       }
       return st;)
CALLER(DeSerializeFMUstate, fmi2FMUstate s = NULL; const fmi2Byte b[8] = {0};
       const fmi2Status st = a->DeSerializeFMUstate(x->c, b, sizeof b, &s);
       if (s != NULL) { a->FreeFMUstate(x->c, &s); } return st;)
/* Model Exchange: well-formed arguments (nx and ni from the XML), so that only the state counts */
CALLER(EnterEventMode, return a->EnterEventMode(x->c);)
CALLER(NewDiscreteStates, fmi2EventInfo ev; memset(&ev, 0, sizeof ev);
       return a->NewDiscreteStates(x->c, &ev);)
CALLER(EnterContinuousTimeMode, return a->EnterContinuousTimeMode(x->c);)
CALLER(CompletedIntegratorStep, fmi2Boolean e = fmi2False; fmi2Boolean t = fmi2False;
       return a->CompletedIntegratorStep(x->c, fmi2True, &e, &t);)
CALLER(SetTime, return a->SetTime(x->c, 0.0);)
CALLER(SetContinuousStates, const fmi2Real v[MAX_STATES] = {0};
       return a->SetContinuousStates(x->c, v, a->nx);)
CALLER(GetDerivatives, fmi2Real v[MAX_STATES]; return a->GetDerivatives(x->c, v, a->nx);)
CALLER(GetEventIndicators, fmi2Real v[MAX_STATES];
       return a->GetEventIndicators(x->c, v, a->ni < MAX_STATES ? a->ni : MAX_STATES);)
CALLER(GetContinuousStates, fmi2Real v[MAX_STATES];
       return a->GetContinuousStates(x->c, v, a->nx);)
CALLER(GetNominalsOfContinuousStates, fmi2Real v[MAX_STATES];
       return a->GetNominalsOfContinuousStates(x->c, v, a->nx);)

/* ---- Model Exchange states ------------------------------------------------------------------- */

enum { MS_INST, MS_INIT, MS_EVENT, MS_CONT, MS_TERM, MS_ERR, MS_COUNT };
static const char *const me_state_names[MS_COUNT] = {"Instantiated", "InitializationMode",
                                                     "EventMode",    "ContinuousTimeMode",
                                                     "Terminated",   "Error"};
enum {
    M_I = 1 << MS_INST, M_IN = 1 << MS_INIT, M_EV = 1 << MS_EVENT, M_CT = 1 << MS_CONT,
    M_T = 1 << MS_TERM, M_E = 1 << MS_ERR, M_ALL = (1 << MS_COUNT) - 1
};

/* Put a fresh Model Exchange instance into a state (all six are reachable for both FMUs). */
static int drive_me(inst *x, int state)
{
    const fmu_api *a = x->api;
    if (state == MS_INST) {
        return 0;
    }
    if (state == MS_ERR) {
        CHECK(set1(x, bad_param(a), -1.0) == fmi2OK);
    }
    CHECK(a->SetupExperiment(x->c, fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2OK);
    CHECK(a->EnterInitializationMode(x->c) == fmi2OK);
    if (state == MS_INIT) {
        return 0;
    }
    if (state == MS_ERR) {
        CHECK(a->ExitInitializationMode(x->c) == fmi2Error);
        return 0;
    }
    CHECK(a->ExitInitializationMode(x->c) == fmi2OK); /* -> EventMode */
    if (state == MS_EVENT) {
        return 0;
    }
    fmi2EventInfo ev;
    memset(&ev, 0, sizeof ev);
    CHECK(a->NewDiscreteStates(x->c, &ev) == fmi2OK && ev.newDiscreteStatesNeeded == fmi2False);
    CHECK(a->EnterContinuousTimeMode(x->c) == fmi2OK);
    if (state == MS_TERM) {
        CHECK(a->Terminate(x->c) == fmi2OK);
    }
    return 0;
}

/* Which of four probes are accepted (FMI 2.0.4 section 3.2.3): getReal (not in Instantiated),
 * setReal (Instantiated to ContinuousTimeMode), setInteger (not in ContinuousTimeMode) and
 * newDiscreteStates (EventMode only; this FMU has no discrete states, so it changes nothing).
 * Terminated and Error share a fingerprint; the serialized FMU state tells them apart. */
static unsigned fingerprint_me(inst *x)
{
    const fmu_api *a = x->api;
    fmi2EventInfo ev;
    memset(&ev, 0, sizeof ev);
    unsigned f = 0;
    f |= (a->GetReal(x->c, NULL, 0, NULL) == fmi2OK) ? 1u : 0u;
    f |= (a->SetReal(x->c, NULL, 0, NULL) == fmi2OK) ? 2u : 0u;
    f |= (a->SetInteger(x->c, NULL, 0, NULL) == fmi2OK) ? 4u : 0u;
    f |= (a->NewDiscreteStates(x->c, &ev) == fmi2OK) ? 8u : 0u;
    return f;
}

static const unsigned expected_fingerprint_me[MS_COUNT] = {6u, 7u, 15u, 3u, 1u, 1u};

/* The serialized FMU state of x (malloc'd, *n bytes), or NULL: a byte-exact picture of the
 * instance (machine state, time, flags, all variables) to show that a refused call changed
 * nothing. Taking it changes nothing either (get, size, serialize, free). */
static unsigned char *state_bytes(inst *x, size_t *n)
{
    return fh_state_bytes(&ops2, x, n);
}

static int same_state(inst *x, const unsigned char *before, size_t n)
{
    size_t m = 0;
    unsigned char *now = state_bytes(x, &m);
    const int same = before != NULL && now != NULL && m == n && memcmp(before, now, n) == 0;
    free(now);
    return same;
}

/* The first state name of FMI 2.0 that a message mentions as a word, or "": the state the
 * message reports the instance to be in (an illegal-call message names it before any list of
 * allowed states; "EventMode" inside "fmi2EnterEventMode" is not a word). */
static const char *first_state_named(const char *msg)
{
    static const char *const names[] = {"StartAndEnd",  "Instantiated",   "InitializationMode",
                                        "EventMode",    "ContinuousTimeMode", "StepComplete",
                                        "StepInProgress", "StepFailed",   "StepCanceled",
                                        "Terminated",   "Error",          "Fatal"};
    const char *best = "";
    const char *best_at = NULL;
    for (size_t k = 0; k < sizeof names / sizeof names[0]; ++k) {
        const size_t len = strlen(names[k]);
        for (const char *p = strstr(msg, names[k]); p != NULL; p = strstr(p + 1, names[k])) {
            const int word = (p == msg || !isalnum((unsigned char)p[-1])) &&
                             !isalnum((unsigned char)p[len]);
            if (word) {
                if (best_at == NULL || p < best_at) {
                    best_at = p;
                    best = names[k];
                }
                break;
            }
        }
    }
    return best;
}

/* The allowed states of every function, typed in again from FMI 2.0.4: section 4.2.4
 * (Co-Simulation, column cs, states S_*) and section 3.2.3 (Model Exchange, column me, states
 * M_*; "7" of the error column counts as allowed). A function of one interface type is allowed in
 * no state of the other: the Model Exchange functions are not in the Co-Simulation table and
 * vice versa. The Model Exchange cells where the 2.0.x releases moved: fmi2GetDerivatives is
 * allowed in Initialization Mode (x since 2.0), fmi2GetNominalsOfContinuousStates in
 * Instantiated (since 2.0) and Initialization Mode (since 2.0.3). fmi2CancelStep needs
 * StepInProgress, which a synchronous FMU never enters. */
static const struct {
    const char *name;
    unsigned cs, me;
    caller call;
} functions[] = {
    {"fmi2SetDebugLogging", S_ALL, M_ALL, call_SetDebugLogging},
    {"fmi2SetupExperiment", S_I, M_I, call_SetupExperiment},
    {"fmi2EnterInitializationMode", S_I, M_I, call_EnterInitializationMode},
    {"fmi2ExitInitializationMode", S_IN, M_IN, call_ExitInitializationMode},
    {"fmi2Terminate", S_SC | S_SF, M_EV | M_CT, call_Terminate},
    {"fmi2Reset", S_ALL, M_ALL, call_Reset},
    {"fmi2GetReal", S_IN | S_SC | S_SF | S_T | S_E, M_IN | M_EV | M_CT | M_T | M_E, call_GetReal},
    {"fmi2GetInteger", S_IN | S_SC | S_SF | S_T | S_E, M_IN | M_EV | M_CT | M_T | M_E,
     call_GetInteger},
    {"fmi2GetBoolean", S_IN | S_SC | S_SF | S_T | S_E, M_IN | M_EV | M_CT | M_T | M_E,
     call_GetBoolean},
    {"fmi2GetString", S_IN | S_SC | S_SF | S_T | S_E, M_IN | M_EV | M_CT | M_T | M_E,
     call_GetString},
    {"fmi2SetReal", S_I | S_IN | S_SC, M_I | M_IN | M_EV | M_CT, call_SetReal},
    {"fmi2SetInteger", S_I | S_IN | S_SC, M_I | M_IN | M_EV, call_SetInteger},
    {"fmi2SetBoolean", S_I | S_IN | S_SC, M_I | M_IN | M_EV, call_SetBoolean},
    {"fmi2SetString", S_I | S_IN | S_SC, M_I | M_IN | M_EV, call_SetString},
    {"fmi2GetFMUstate", S_ALL, M_ALL, call_GetFMUstate},
    {"fmi2SetFMUstate", S_ALL, M_ALL, call_SetFMUstate},
    {"fmi2FreeFMUstate", S_ALL, M_ALL, call_FreeFMUstate},
    {"fmi2SerializedFMUstateSize", S_ALL, M_ALL, call_SerializedFMUstateSize},
    {"fmi2SerializeFMUstate", S_ALL, M_ALL, call_SerializeFMUstate},
    {"fmi2DeSerializeFMUstate", S_ALL, M_ALL, call_DeSerializeFMUstate},
    {"fmi2GetDirectionalDerivative", S_IN | S_SC | S_SF | S_T | S_E,
     M_IN | M_EV | M_CT | M_T | M_E, call_GetDirectionalDerivative},
    /* Co-Simulation only */
    {"fmi2SetRealInputDerivatives", S_I | S_IN | S_SC, 0u, call_SetRealInputDerivatives},
    {"fmi2GetRealOutputDerivatives", S_SC | S_SF | S_T | S_E, 0u, call_GetRealOutputDerivatives},
    {"fmi2DoStep", S_SC, 0u, call_DoStep},
    {"fmi2CancelStep", 0u, 0u, call_CancelStep},
    {"fmi2GetStatus", S_SC | S_SF | S_T, 0u, call_GetStatus},
    {"fmi2GetRealStatus", S_SC | S_SF | S_T, 0u, call_GetRealStatus},
    {"fmi2GetIntegerStatus", S_SC | S_SF | S_T, 0u, call_GetIntegerStatus},
    {"fmi2GetBooleanStatus", S_SC | S_SF | S_T, 0u, call_GetBooleanStatus},
    {"fmi2GetStringStatus", S_SC | S_SF | S_T, 0u, call_GetStringStatus},
    /* Model Exchange only */
    {"fmi2EnterEventMode", 0u, M_EV | M_CT, call_EnterEventMode},
    {"fmi2NewDiscreteStates", 0u, M_EV, call_NewDiscreteStates},
    {"fmi2EnterContinuousTimeMode", 0u, M_EV, call_EnterContinuousTimeMode},
    {"fmi2CompletedIntegratorStep", 0u, M_CT, call_CompletedIntegratorStep},
    {"fmi2SetTime", 0u, M_EV | M_CT, call_SetTime},
    {"fmi2SetContinuousStates", 0u, M_CT, call_SetContinuousStates},
    {"fmi2GetEventIndicators", 0u, M_IN | M_EV | M_CT | M_T | M_E, call_GetEventIndicators},
    {"fmi2GetContinuousStates", 0u, M_IN | M_EV | M_CT | M_T | M_E, call_GetContinuousStates},
    {"fmi2GetDerivatives", 0u, M_IN | M_EV | M_CT | M_T | M_E, call_GetDerivatives},
    {"fmi2GetNominalsOfContinuousStates", 0u, M_I | M_IN | M_EV | M_CT | M_T | M_E,
     call_GetNominalsOfContinuousStates},
};

/* One state machine of the harness: its states, how to reach them and how to recognise them. */
typedef struct machine {
    const char *what;                 /* "Co-Simulation" or "Model Exchange" */
    fmi2Type type;
    int is_me;                        /* use column me of functions[] */
    int n_states;
    const char *const *names;
    int (*drive)(inst *x, int state); /* 1: state not reachable for this FMU */
    unsigned (*fingerprint)(inst *x);
    const unsigned *expected;
} machine;

static const machine cs_machine = {"Co-Simulation", fmi2CoSimulation, 0, ST_COUNT, state_names,
                                   drive, fingerprint, expected_fingerprint};
static const machine me_machine = {"Model Exchange", fmi2ModelExchange, 1, MS_COUNT,
                                   me_state_names, drive_me, fingerprint_me,
                                   expected_fingerprint_me};

/* Every function from every reachable state: where the standard does not allow it, fmi2Error,
 * one error message naming the function and the state, and nothing changed (the serialized FMU
 * state is byte-identical and the probes still recognise the state); where it allows it, no
 * illegal-call-sequence message (the call may still refuse its arguments or say "not
 * provided"). */
static void test_illegal_sequences(const fmu_api *api, const machine *m)
{
    int tried = 0;
    int accepted = 0;
    for (int st = 0; st < m->n_states; ++st) {
        for (size_t f = 0; f < sizeof functions / sizeof functions[0]; ++f) {
            const unsigned allowed = m->is_me ? functions[f].me : functions[f].cs;
            inst x;
            if (inst_new_type(&x, api, "illegal", m->type)) {
                return;
            }
            if (m->drive(&x, st)) {
                inst_free(&x);
                continue;
            }
            size_t nb = 0;
            unsigned char *before = state_bytes(&x, &nb);
            CHECK(before != NULL);
            log_clear(&x);
            const fmi2Status s = functions[f].call(&x);
            if (allowed & (1u << st)) {
                if (x.log.illegal != 0) {
                    fprintf(stderr, "%s %s: %s is allowed in state %s but was refused: \"%s\"\n",
                            api->id, m->what, functions[f].name, m->names[st],
                            x.log.last_error);
                    rrr_test_failures++;
                }
                ++accepted;
            } else {
                const int ok = s == fmi2Error && x.log.count[fmi2Error] == 1 &&
                               x.log.illegal == 1 &&
                               strstr(x.log.last_error, functions[f].name) != NULL &&
                               strcmp(first_state_named(x.log.last_error), m->names[st]) == 0;
                const log_sink seen = x.log; /* before the probes add their messages */
                const int unchanged = same_state(&x, before, nb);
                const unsigned fp = m->fingerprint(&x);
                if (!ok || !unchanged || fp != m->expected[st]) {
                    fprintf(stderr,
                            "%s %s: %s in state %s returned %d, %d error message(s) \"%s\"; "
                            "FMU state %s; state fingerprint %u, expected %u\n",
                            api->id, m->what, functions[f].name, m->names[st], (int)s,
                            seen.count[fmi2Error], seen.last_error,
                            unchanged ? "unchanged" : "CHANGED", fp, m->expected[st]);
                    rrr_test_failures++;
                }
                /* Co-Simulation: Terminated and StepFailed share a fingerprint: only StepFailed
                 * may terminate */
                if (!m->is_me && (st == ST_FAILED || st == ST_TERM)) {
                    CHECK((api->Terminate(x.c) == fmi2OK) == (st == ST_FAILED));
                }
                ++tried;
            }
            free(before);
            inst_free(&x);
        }
    }
    printf("%s %s: %d illegal (function, state) pairs refused with fmi2Error and a message, "
           "FMU state unchanged; %d allowed pairs accepted\n",
           api->id, m->what, tried, accepted);
    CHECK(tried >= 50);
    CHECK(accepted >= 50);
}


/* ---- refused values ---------------------------------------------------------------------------- */

/* ---- partial derivatives ------------------------------------------------------------------------ */

/* A refused fmi2GetDirectionalDerivative: fmi2Error, one error message containing needle,
 * dvUnknown untouched, the instance still answering (the state machine unchanged). */
static void expect_refused_dd(inst *x, const fmi2ValueReference *u, size_t nu,
                              const fmi2ValueReference *k, size_t nk, const double *seed,
                              const char *needle)
{
    double out[8];
    for (size_t i = 0; i < 8; ++i) {
        out[i] = FH_UNTOUCHED;
    }
    log_clear(x);
    const fmi2Status s = x->api->GetDirectionalDerivative(x->c, u, nu, k, nk, seed, out);
    fh_expect_refused_out(&ops2, x, (int)s, "fmi2GetDirectionalDerivative", needle, out, 8);
}

/* The plant (Co-Simulation and Model Exchange) and the controller: the directional derivatives
 * equal librrr's rrr_plant_jacobian / rrr_ctc_jacobian bit for bit (unit seeds), a NaN or Inf
 * seed, an unknown value reference, a parameter as known and an input as unknown are refused;
 * the reference FMU refuses the call as not provided. */
static void test_directional_derivatives(const fmu_api *plant, const fmu_api *ctrl,
                                         const fmu_api *ref)
{
    rrr_model m;
    rrr_model_default(&m);
    int refused = 0;
    for (int me = 0; me < 2; ++me) {
        inst x;
        if ((me ? inst_new_me : inst_new)(&x, plant, "derivatives")) {
            return;
        }
        const double u[3] = {-20.0, 0.8, 2.5}; /* u[1] beyond the limit */
        fmi2ValueReference vu[3], vqdd[3], vq[3], vqd[3];
        vrs3(plant, "u", vu);
        vrs3(plant, "qdd", vqdd);
        vrs3(plant, "q", vq);
        vrs3(plant, "qd", vqd);
        CHECK(set1(&x, "q0[2]", 0.6) == fmi2OK);
        CHECK(set1(&x, "qd0[3]", -0.3) == fmi2OK);
        if (me) {
            drive_me(&x, MS_CONT);
        } else {
            drive(&x, ST_DONE);
        }
        CHECK(plant->SetReal(x.c, vu, 3, u) == fmi2OK);
        rrr_plant_state s;
        CHECK(plant->GetReal(x.c, vq, 3, s.q) == fmi2OK);
        CHECK(plant->GetReal(x.c, vqd, 3, s.qd) == fmi2OK);
        rrr_plant_derivatives d;
        CHECK(rrr_plant_jacobian(&m, &s, u, &d) == RRR_OK);
        for (int j = 0; j < 3; ++j) {
            const double one = 1.0;
            double col[3];
            CHECK(plant->GetDirectionalDerivative(x.c, vqdd, 3, &vu[j], 1, &one, col) == fmi2OK);
            for (int i = 0; i < 3; ++i) {
                CHECK(col[i] == d.dqdd_du[i][j]);
            }
            CHECK(plant->GetDirectionalDerivative(x.c, vqdd, 3, &vq[j], 1, &one, col) == fmi2OK);
            for (int i = 0; i < 3; ++i) {
                CHECK(col[i] == d.dqdd_dq[i][j]);
            }
            CHECK(plant->GetDirectionalDerivative(x.c, vqdd, 3, &vqd[j], 1, &one, col) == fmi2OK);
            for (int i = 0; i < 3; ++i) {
                CHECK(col[i] == d.dqdd_dqd[i][j]);
            }
        }
        const fmi2ValueReference a2 = vr_of(plant, "a2"), bad = 100000u;
        const double one = 1.0, nan = (double)NAN, inf = -(double)INFINITY;
        expect_refused_dd(&x, vqdd, 1, &a2, 1, &one, "InitializationMode");
        expect_refused_dd(&x, vu, 1, vq, 1, &one, "not an unknown");
        expect_refused_dd(&x, vqdd, 1, &bad, 1, &one, "not a value reference");
        expect_refused_dd(&x, vqdd, 1, vu, 1, &nan, "seed[0]");
        expect_refused_dd(&x, vqdd, 1, vu, 1, &inf, "seed[0]");
        expect_refused_dd(&x, vqdd, 1, NULL, 1, &one, "NULL");
        refused += 6;
        double col[3];
        CHECK(plant->GetDirectionalDerivative(x.c, vqdd, 3, vu, 1, &one, col) == fmi2OK);
        inst_free(&x);
    }
    inst c;
    if (inst_new(&c, ctrl, "derivatives")) {
        return;
    }
    drive(&c, ST_DONE);
    fmi2ValueReference vqref[3], vun[3], vq[3];
    vrs3(ctrl, "q_ref", vqref);
    vrs3(ctrl, "u_n", vun);
    vrs3(ctrl, "q", vq);
    const double q_ref[3] = {0.2, 0.7, -0.4}, zero[3] = {0.0, 0.0, 0.0};
    CHECK(ctrl->SetReal(c.c, vqref, 3, q_ref) == fmi2OK);
    CHECK(ctrl->SetReal(c.c, vq, 3, q_ref) == fmi2OK);
    rrr_ctc_gains g;
    rrr_ctc_gains_default(&g);
    rrr_ctc_derivatives d;
    CHECK(rrr_ctc_jacobian(&m, &g, q_ref, zero, zero, q_ref, zero, &d) == RRR_OK);
    for (int j = 0; j < 3; ++j) {
        const double one = 1.0;
        double col[3];
        CHECK(ctrl->GetDirectionalDerivative(c.c, vun, 3, &vqref[j], 1, &one, col) == fmi2OK);
        for (int i = 0; i < 3; ++i) {
            CHECK(col[i] == d.du_n[RRR_CTC_Q_REF][i][j]);
        }
    }
    const double one = 1.0;
    expect_refused_dd(&c, vun, 1, &vun[1], 1, &one, "not a known");
    refused += 1;
    inst_free(&c);
    if (ref != NULL) {
        inst r;
        if (inst_new(&r, ref, "derivatives")) {
            return;
        }
        drive(&r, ST_DONE);
        const fmi2ValueReference v0 = 0u;
        expect_refused_dd(&r, &v0, 1, &v0, 1, &one, "not provided");
        refused += 1;
        inst_free(&r);
    }
    printf("fmi2GetDirectionalDerivative: equal to librrr bit for bit (plant CS and ME, "
           "controller), %d refused calls\n", refused);
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
    fh_refused_in_init(&ops2, &p, &c);
    fh_refused_multi(&ops2, &p);
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
    /* a good set still works; step complete: parameters are fixed, inputs are checked */
    fh_refused_stepping(&ops2, &p, &c, "InitializationMode");
    {
        const fmi2ValueReference ff = vr_of(ctrl, "feedforward");
        const fmi2Boolean off = fmi2False;
        CHECK(ctrl->SetBoolean(c.c, &ff, 1, &off) == fmi2Error);
    }
    /* still stepping normally: nothing was corrupted */
    fh_still_stepping(&ops2, &p, &c);

    /* doStep arguments: refused, state unchanged */
    log_clear(&p);
    CHECK(plant->DoStep(p.c, H, 0.0, fmi2True) == fmi2Error);
    CHECK(plant->DoStep(p.c, H, -H, fmi2True) == fmi2Error);
    CHECK(plant->DoStep(p.c, H, (double)NAN, fmi2True) == fmi2Error);
    CHECK(strstr(p.log.last_error, "communicationStepSize") != NULL);
    CHECK(plant->DoStep(p.c, 0.5, H, fmi2True) == fmi2Error);
    CHECK(strstr(p.log.last_error, "currentCommunicationPoint") != NULL);
    CHECK(plant->DoStep(p.c, (double)NAN, H, fmi2True) == fmi2Error);
    /* a point at the low end of the tolerance with a shorter step would move time backwards */
    CHECK(plant->DoStep(p.c, H * (1.0 - 5e-10), H * 1e-10, fmi2True) == fmi2Error);
    CHECK(strstr(p.log.last_error, "not a finite time after the FMU time") != NULL);
    CHECK(plant->DoStep(p.c, H * (1.0 + 1e-12), H, fmi2True) == fmi2OK); /* within tolerance */
    fmi2Real now = 0.0;
    CHECK(plant->GetRealStatus(p.c, fmi2LastSuccessfulTime, &now) == fmi2OK);
    CHECK(now == H * (1.0 + 1e-12) + H);
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
    expect_invalid(plant, "rtol", 0.0, "rtol");
    expect_invalid(plant, "rtol", 0.5, "rtol");
    expect_invalid(plant, "atol", 1e-16, "atol");
    expect_invalid(ctrl, "b[1]", -0.5, "b[1]");
    expect_invalid(ctrl, "kp[2]", -1.0, "kp[2]");
    expect_invalid(ctrl, "kd[3]", -1.0, "kd[3]");
    expect_invalid(ctrl, "g", -9.81, "g");
}

/* The FMU time stays finite: a step whose end overflows is refused and changes nothing. */
static void test_time_overflow(const fmu_api *plant)
{
    inst p;
    if (inst_new(&p, plant, "overflow")) {
        return;
    }
    const double t0 = 1.5e308;
    CHECK(plant->SetupExperiment(p.c, fmi2False, 0.0, (double)INFINITY, fmi2False, 0.0) == fmi2Error);
    /* a defined tolerance must be finite and > 0; an undefined one is ignored */
    log_clear(&p);
    CHECK(plant->SetupExperiment(p.c, fmi2True, (double)NAN, 0.0, fmi2False, 0.0) == fmi2Error);
    CHECK(strstr(p.log.last_error, "tolerance") != NULL);
    CHECK(plant->SetupExperiment(p.c, fmi2True, -1.0, 0.0, fmi2False, 0.0) == fmi2Error);
    CHECK(plant->SetupExperiment(p.c, fmi2True, (double)INFINITY, 0.0, fmi2False, 0.0) ==
          fmi2Error);
    CHECK(plant->SetupExperiment(p.c, fmi2False, (double)NAN, t0, fmi2False, 0.0) == fmi2OK);
    CHECK(plant->EnterInitializationMode(p.c) == fmi2OK);
    CHECK(plant->ExitInitializationMode(p.c) == fmi2OK);
    log_clear(&p);
    CHECK(plant->DoStep(p.c, t0, t0, fmi2True) == fmi2Error);
    CHECK(strstr(p.log.last_error, "not a finite time") != NULL);
    fmi2Real now = 0.0;
    CHECK(plant->GetRealStatus(p.c, fmi2LastSuccessfulTime, &now) == fmi2OK && now == t0);
    inst_free(&p);
}

/* A step that cannot be taken (here 1e8 substeps of the fixed-step RK4) is discarded with a
 * message naming the cause: state StepFailed, the plant state unchanged. */
static void test_discard(const fmu_api *plant)
{
    inst p;
    if (inst_new(&p, plant, "discard")) {
        return;
    }
    CHECK(set_bool(&p, "adaptive", fmi2False) == fmi2OK);
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


static void test_fmu_state(const fmu_api *plant, const fmu_api *ctrl)
{
    fh_loop L;
    fh_saved S;
    if (fh_state_begin(&ops2, plant, ctrl, &L, &S, NULL) != 0) {
        return;
    }
    inst *p = L.p;
    CHECK(fingerprint(p) == expected_fingerprint[ST_DONE]);

    /* getFMUstate into an existing state overwrites it */
    CHECK(plant->GetFMUstate(p->c, &S.sp) == fmi2OK);
    CHECK(plant->SetFMUstate(p->c, S.sp) == fmi2OK);
    double t_now = 0.0;
    CHECK(plant->GetRealStatus(p->c, fmi2LastSuccessfulTime, &t_now) == fmi2OK);
    CHECK(fabs(t_now - L.t) < 1e-12);
    CHECK(plant->SetFMUstate(p->c, S.sp) == fmi2OK);
    CHECK(plant->DoStep(p->c, L.t, H, fmi2True) == fmi2OK);
    fh_state_end(&L, &S);
    fh_state_undoes_discard(&ops2, plant);
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

/* ==== Model Exchange ========================================================================= */

static int bits_equal(const double *a, const double *b, size_t n)
{
    return n == 0 || memcmp(a, b, n * sizeof *a) == 0;
}

/* The fingerprint without its refused probes in the log sink. */
static unsigned fingerprint_me_quiet(inst *x)
{
    const log_sink saved = x->log;
    const unsigned f = fingerprint_me(x);
    x->log = saved;
    return f;
}

/* A call that must be refused as a bad argument: fmi2Error, one error message naming the function
 * (and the needle, if any), no illegal-call-sequence message, the serialized FMU state
 * byte-identical before and after. */
static void check_refused(inst *x, fmi2Status s, const unsigned char *before, size_t nb,
                          const char *fn, const char *needle, const char *expr, int line)
{
    const int ok = s == fmi2Error && x->log.count[fmi2Error] == 1 && x->log.illegal == 0 &&
                   strstr(x->log.last_error, fn) != NULL &&
                   (needle == NULL || strstr(x->log.last_error, needle) != NULL);
    const int unchanged = same_state(x, before, nb);
    if (!ok || !unchanged) {
        fprintf(stderr, "%s:%d: %s: %s returned %d, %d error message(s) \"%s\"; FMU state %s\n",
                __FILE__, line, x->api->id, expr, (int)s, x->log.count[fmi2Error],
                x->log.last_error, unchanged ? "unchanged" : "CHANGED");
        rrr_test_failures++;
    }
}

#define REFUSED(X, EXPR, FN, NEEDLE)                                                          \
    do {                                                                                      \
        size_t nb_ = 0;                                                                       \
        unsigned char *before_ = state_bytes((X), &nb_);                                      \
        log_clear(X);                                                                         \
        const fmi2Status s_ = (EXPR);                                                         \
        check_refused((X), s_, before_, nb_, (FN), (NEEDLE), #EXPR, __LINE__);                \
        free(before_);                                                                        \
    } while (0)

/* One classic RK4 step of length dt through the Model Exchange interface, from (t, x) to
 * (t + dt, x): the stages and the order of operations of librrr's rk4 in rrr_plant_step
 * (rrr_plant.c), over the whole state vector. Returns nonzero on a failed call. */
static int me_rk4(inst *p, double t, double dt, double x[], size_t nx)
{
    const fmu_api *a = p->api;
    double k1[MAX_STATES], k2[MAX_STATES], k3[MAX_STATES], k4[MAX_STATES], xa[MAX_STATES];
    int bad = 0;
    bad |= a->SetTime(p->c, t) != fmi2OK;
    bad |= a->SetContinuousStates(p->c, x, nx) != fmi2OK;
    bad |= a->GetDerivatives(p->c, k1, nx) != fmi2OK;
    for (size_t i = 0; i < nx && !bad; ++i) {
        xa[i] = x[i] + 0.5 * dt * k1[i];
    }
    bad |= a->SetTime(p->c, t + 0.5 * dt) != fmi2OK;
    bad |= a->SetContinuousStates(p->c, xa, nx) != fmi2OK;
    bad |= a->GetDerivatives(p->c, k2, nx) != fmi2OK;
    for (size_t i = 0; i < nx && !bad; ++i) {
        xa[i] = x[i] + 0.5 * dt * k2[i];
    }
    bad |= a->SetContinuousStates(p->c, xa, nx) != fmi2OK;
    bad |= a->GetDerivatives(p->c, k3, nx) != fmi2OK;
    for (size_t i = 0; i < nx && !bad; ++i) {
        xa[i] = x[i] + dt * k3[i];
    }
    bad |= a->SetTime(p->c, t + dt) != fmi2OK;
    bad |= a->SetContinuousStates(p->c, xa, nx) != fmi2OK;
    bad |= a->GetDerivatives(p->c, k4, nx) != fmi2OK;
    if (bad) {
        return 1;
    }
    for (size_t i = 0; i < nx; ++i) {
        x[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
    fmi2Boolean enter = fmi2True, stop = fmi2True;
    bad |= a->SetContinuousStates(p->c, x, nx) != fmi2OK;
    bad |= a->CompletedIntegratorStep(p->c, fmi2True, &enter, &stop) != fmi2OK;
    bad |= enter != fmi2False || stop != fmi2False;
    return bad;
}

/* The lifecycle of FMI 2.0.4 section 3.2.3, with the values each call must give. */
static void test_me_lifecycle(const fmu_api *api)
{
    const int is_plant = strcmp(api->id, "rrr_plant") == 0;
    const long blocks_before = n_live_blocks;
    /* the state vector the XML declares: (q, qd) with derivatives (qd, qdd); none for the
     * controller; no event indicators */
    CHECK(api->nx == (is_plant ? 6u : 0u));
    CHECK(api->ni == 0u);
    if (is_plant && api->nx == 6u) {
        static const char *const xn[6] = {"q[1]", "q[2]", "q[3]", "qd[1]", "qd[2]", "qd[3]"};
        static const char *const dxn[6] = {"qd[1]",  "qd[2]",  "qd[3]",
                                           "qdd[1]", "qdd[2]", "qdd[3]"};
        for (size_t i = 0; i < 6; ++i) {
            CHECK(strcmp(api->x_name[i], xn[i]) == 0 && strcmp(api->dx_name[i], dxn[i]) == 0);
        }
    }
    const size_t nx = api->nx;
    inst x;
    if (inst_new_me(&x, api, "me_lifecycle")) {
        return;
    }
    CHECK(fingerprint_me_quiet(&x) == expected_fingerprint_me[MS_INST]);

    /* Instantiated: the nominals, all > 0 */
    double nom[MAX_STATES], xs0[MAX_STATES] = {0}, xv[MAX_STATES] = {0}, dx[MAX_STATES] = {0};
    double ref[MAX_STATES] = {0}, v3[3] = {0};
    for (size_t i = 0; i < MAX_STATES; ++i) {
        nom[i] = -1.0;
    }
    CHECK(api->GetNominalsOfContinuousStates(x.c, nom, nx) == fmi2OK);
    for (size_t i = 0; i < nx; ++i) {
        CHECK(isfinite(nom[i]) && nom[i] > 0.0);
    }

    rrr_model m;
    CHECK(rrr_model_default(&m) == RRR_OK);
    const double q0[3] = {0.3, -0.4, 0.9}, qd0[3] = {0.5, -1.0, 0.25}, u[3] = {1.5, -2.0, 0.7};
    fmi2ValueReference vq0[3], vqd0[3], vu[3], vq[3], vqd[3], vqdd[3];
    rrr_plant_state ps;
    if (is_plant) {
        vrs3(api, "q0", vq0);
        vrs3(api, "qd0", vqd0);
        vrs3(api, "u", vu);
        vrs3(api, "q", vq);
        vrs3(api, "qd", vqd);
        vrs3(api, "qdd", vqdd);
        CHECK(api->SetReal(x.c, vq0, 3, q0) == fmi2OK);
        CHECK(api->SetReal(x.c, vqd0, 3, qd0) == fmi2OK);
        CHECK(api->SetReal(x.c, vu, 3, u) == fmi2OK);
        memcpy(xs0, q0, sizeof q0);
        memcpy(xs0 + 3, qd0, sizeof qd0);
        memcpy(ps.q, q0, sizeof q0);
        memcpy(ps.qd, qd0, sizeof qd0);
        memcpy(ref, qd0, sizeof qd0);
        CHECK(rrr_plant_accel(&m, &ps, u, ref + 3) == RRR_OK);
    }
    CHECK(api->SetupExperiment(x.c, fmi2False, 0.0, 0.25, fmi2False, 0.0) == fmi2OK);
    CHECK(api->EnterInitializationMode(x.c) == fmi2OK);
    CHECK(fingerprint_me_quiet(&x) == expected_fingerprint_me[MS_INIT]);
    /* initialization mode: the states are the start values q0, qd0, and so are the derivatives */
    CHECK(api->GetContinuousStates(x.c, xv, nx) == fmi2OK && bits_equal(xv, xs0, nx));
    CHECK(api->GetDerivatives(x.c, dx, nx) == fmi2OK && bits_equal(dx, ref, nx));
    CHECK(api->GetEventIndicators(x.c, NULL, 0) == fmi2OK);
    CHECK(api->GetNominalsOfContinuousStates(x.c, nom, nx) == fmi2OK);
    CHECK(api->ExitInitializationMode(x.c) == fmi2OK);
    CHECK(fingerprint_me_quiet(&x) == expected_fingerprint_me[MS_EVENT]);

    /* event mode: the initial states; no discrete states, no event, no time event */
    CHECK(api->GetContinuousStates(x.c, xv, nx) == fmi2OK && bits_equal(xv, xs0, nx));
    fmi2EventInfo ev;
    ev.newDiscreteStatesNeeded = fmi2True;
    ev.terminateSimulation = fmi2True;
    ev.nominalsOfContinuousStatesChanged = fmi2True;
    ev.valuesOfContinuousStatesChanged = fmi2True;
    ev.nextEventTimeDefined = fmi2True;
    ev.nextEventTime = -1.0;
    CHECK(api->NewDiscreteStates(x.c, &ev) == fmi2OK);
    CHECK(ev.newDiscreteStatesNeeded == fmi2False && ev.terminateSimulation == fmi2False &&
          ev.nominalsOfContinuousStatesChanged == fmi2False &&
          ev.valuesOfContinuousStatesChanged == fmi2False && ev.nextEventTimeDefined == fmi2False);
    CHECK(api->EnterContinuousTimeMode(x.c) == fmi2OK);
    CHECK(fingerprint_me_quiet(&x) == expected_fingerprint_me[MS_CONT]);

    /* continuous-time mode: time, states and derivatives (FMI 2 cannot read the time back:
     * the XML of FMI 2 lists no independent variable) */
    CHECK(api->SetTime(x.c, 0.3) == fmi2OK);
    const double x1[6] = {-0.2, 0.6, -1.1, 0.8, 0.3, -0.6};
    CHECK(api->SetContinuousStates(x.c, x1, nx) == fmi2OK);
    CHECK(api->GetContinuousStates(x.c, xv, nx) == fmi2OK && bits_equal(xv, x1, nx));
    CHECK(api->GetDerivatives(x.c, dx, nx) == fmi2OK);
    if (is_plant) {
        /* the state variables and their derivatives are the outputs q, qd, qdd */
        CHECK(api->GetReal(x.c, vq, 3, v3) == fmi2OK && bits_equal(v3, x1, 3));
        CHECK(api->GetReal(x.c, vqd, 3, v3) == fmi2OK && bits_equal(v3, x1 + 3, 3));
        CHECK(bits_equal(dx, x1 + 3, 3)); /* dq/dt = qd */
        memcpy(ps.q, x1, sizeof ps.q);
        memcpy(ps.qd, x1 + 3, sizeof ps.qd);
        CHECK(rrr_plant_accel(&m, &ps, u, ref + 3) == RRR_OK);
        CHECK(bits_equal(dx + 3, ref + 3, 3));
        CHECK(api->GetReal(x.c, vqdd, 3, v3) == fmi2OK && bits_equal(v3, dx + 3, 3));
    }
    CHECK(api->GetEventIndicators(x.c, NULL, 0) == fmi2OK);
    fmi2Boolean enter = fmi2True, stop = fmi2True;
    CHECK(api->CompletedIntegratorStep(x.c, fmi2True, &enter, &stop) == fmi2OK);
    CHECK(enter == fmi2False && stop == fmi2False);

    /* an external event: event mode and back; the states do not jump */
    CHECK(api->EnterEventMode(x.c) == fmi2OK);
    CHECK(fingerprint_me_quiet(&x) == expected_fingerprint_me[MS_EVENT]);
    CHECK(api->SetTime(x.c, 0.35) == fmi2OK);
    CHECK(api->GetContinuousStates(x.c, xv, nx) == fmi2OK && bits_equal(xv, x1, nx));
    CHECK(api->NewDiscreteStates(x.c, &ev) == fmi2OK && ev.valuesOfContinuousStatesChanged ==
                                                            fmi2False);
    CHECK(api->EnterContinuousTimeMode(x.c) == fmi2OK);

    /* terminated: the final values can still be read */
    CHECK(api->Terminate(x.c) == fmi2OK);
    CHECK(fingerprint_me_quiet(&x) == expected_fingerprint_me[MS_TERM]);
    double dx2[MAX_STATES] = {0};
    CHECK(api->GetContinuousStates(x.c, xv, nx) == fmi2OK && bits_equal(xv, x1, nx));
    CHECK(api->GetDerivatives(x.c, dx2, nx) == fmi2OK && bits_equal(dx2, dx, nx));
    CHECK(api->GetNominalsOfContinuousStates(x.c, nom, nx) == fmi2OK);
    CHECK(x.log.count[fmi2Error] == 0 && x.log.count[fmi2Warning] == 0 &&
          x.log.count[fmi2Discard] == 0);

    /* reset: Instantiated again, and a second run initializes from the start values */
    CHECK(api->Reset(x.c) == fmi2OK);
    CHECK(fingerprint_me_quiet(&x) == expected_fingerprint_me[MS_INST]);
    CHECK(drive_me(&x, MS_EVENT) == 0);
    if (is_plant) {
        CHECK(api->GetContinuousStates(x.c, xv, nx) == fmi2OK);
        for (size_t i = 0; i < nx; ++i) {
            CHECK(xv[i] == 0.0); /* q0 = qd0 = 0 after reset */
        }
    }
    inst_free(&x);
    CHECK(n_live_blocks == blocks_before);
}

/* The derivatives are librrr's rrr_plant_accel, bit for bit: the FMU links the same object code
 * of librrr as this harness (rrr_obj), and fmi2GetDerivatives hands the state and the input
 * unchanged to rrr_plant_accel, so the same operations on the same doubles give the same bits
 * (C11 mode: no contraction into FMA). */
static void test_me_derivatives(const fmu_api *api)
{
    enum { N = 2000 };
    if (api->nx != 6u) {
        CHECK(0 && "the plant declares 6 continuous states");
        return;
    }
    int n_diff = 0, n_dq = 0, n_sat = 0, total = 0;
    double max_rel = 0.0;
    fmi2ValueReference vu[3];
    vrs3(api, "u", vu);
    for (int cfg = 0; cfg < 2; ++cfg) {
        rrr_model m;
        CHECK(rrr_model_default(&m) == RRR_OK);
        inst x;
        if (inst_new_me(&x, api, "me_derivatives")) {
            return;
        }
        if (cfg == 1) {
            /* other parameters reach the derivatives as well */
            m.g = 3.71;
            m.kt[1] *= 1.25;
            m.b[2] *= 2.0;
            CHECK(set1(&x, "g", m.g) == fmi2OK);
            CHECK(set1(&x, "kt[2]", m.kt[1]) == fmi2OK);
            CHECK(set1(&x, "b[3]", m.b[2]) == fmi2OK);
        }
        CHECK(drive_me(&x, MS_CONT) == 0);
        rrr_rng rng = {cfg == 0 ? UINT64_C(0x9E3779B97F4A7C15) : UINT64_C(0x2545F4914F6CDD1D)};
        for (int k = 0; k < N; ++k) {
            double xv[6], u[3], dx[6], qdd[3];
            for (int i = 0; i < 3; ++i) {
                xv[i] = rrr_rng_uniform(&rng, -3.141592653589793, 3.141592653589793);
                xv[3 + i] = rrr_rng_uniform(&rng, -4.0, 4.0);
                u[i] = rrr_rng_uniform(&rng, -1.5 * m.u_max, 1.5 * m.u_max);
                n_sat += fabs(u[i]) > m.u_max;
            }
            if (api->SetReal(x.c, vu, 3, u) != fmi2OK ||
                api->SetContinuousStates(x.c, xv, 6) != fmi2OK ||
                api->GetDerivatives(x.c, dx, 6) != fmi2OK) {
                CHECK(0 && "SetReal/SetContinuousStates/GetDerivatives failed");
                break;
            }
            rrr_plant_state ps;
            memcpy(ps.q, xv, sizeof ps.q);
            memcpy(ps.qd, xv + 3, sizeof ps.qd);
            CHECK(rrr_plant_accel(&m, &ps, u, qdd) == RRR_OK);
            n_dq += !bits_equal(dx, xv + 3, 3);
            for (int i = 0; i < 3; ++i) {
                n_diff += !bits_equal(dx + 3 + i, qdd + i, 1);
                max_rel = fmax(max_rel, fabs(dx[3 + i] - qdd[i]) / fmax(1.0, fabs(qdd[i])));
            }
            ++total;
        }
        CHECK(x.log.count[fmi2Error] == 0);
        inst_free(&x);
    }
    printf("rrr_plant Model Exchange derivatives vs librrr rrr_plant_accel: %d random states and "
           "inputs (2 parameter sets, %d saturated voltages): %d of %d qdd values differ "
           "(max relative difference %.3g), dq/dt differs from qd in %d\n",
           total, n_sat, n_diff, 3 * total, max_rel, n_dq);
    CHECK(total == 2 * N);
    CHECK(n_diff == 0 && n_dq == 0);
    CHECK(n_sat > 0 && n_sat < 3 * total);
}

/* Explicit RK4 through the Model Exchange interface (h = 1e-4 s, 0.5 s, constant voltages)
 * against the Co-Simulation plant in fixed-step mode (adaptive = false, h_int = 1e-4 s, doStep
 * of 1 ms = 10 RK4 substeps of 1e-3 / 10 s): the same method on the same right-hand side. */
static void test_me_rk4_vs_cs(const fmu_api *api)
{
    enum { STEPS = 500, SUB = 10 };
    const double dt = H / SUB;
    const double q0[3] = {0.1, 0.3, -0.8}, qd0[3] = {0.0, 0.2, -0.1}, u[3] = {2.0, -1.5, 1.0};
    inst me, cs;
    if (inst_new_me(&me, api, "me_rk4") || inst_new(&cs, api, "cs_rk4")) {
        return;
    }
    fmi2ValueReference vq0[3], vqd0[3], vu[3], vq[3], vqd[3];
    vrs3(api, "q0", vq0);
    vrs3(api, "qd0", vqd0);
    vrs3(api, "u", vu);
    vrs3(api, "q", vq);
    vrs3(api, "qd", vqd);
    inst *both[2] = {&me, &cs};
    for (int k = 0; k < 2; ++k) {
        CHECK(api->SetReal(both[k]->c, vq0, 3, q0) == fmi2OK);
        CHECK(api->SetReal(both[k]->c, vqd0, 3, qd0) == fmi2OK);
        CHECK(api->SetReal(both[k]->c, vu, 3, u) == fmi2OK);
    }
    CHECK(set1(&cs, "h_int", 1e-4) == fmi2OK);
    CHECK(set_bool(&cs, "adaptive", fmi2False) == fmi2OK);
    CHECK(drive_me(&me, MS_CONT) == 0);
    CHECK(drive(&cs, ST_INIT) == 0);
    CHECK(api->ExitInitializationMode(cs.c) == fmi2OK);
    double x[6] = {0}, x0[6] = {0};
    CHECK(api->GetContinuousStates(me.c, x, 6) == fmi2OK);
    memcpy(x0, x, sizeof x);
    double max_diff = 0.0, moved = 0.0;
    int n_bits = 0, n_cmp = 0;
    for (int k = 0; k < STEPS; ++k) {
        for (int j = 0; j < SUB; ++j) {
            if (me_rk4(&me, (double)(k * SUB + j) * dt, dt, x, 6)) {
                CHECK(0 && "RK4 step through Model Exchange failed");
                k = STEPS;
                break;
            }
        }
        double y[6];
        if (api->DoStep(cs.c, k * H, H, fmi2True) != fmi2OK ||
            api->GetReal(cs.c, vq, 3, y) != fmi2OK || api->GetReal(cs.c, vqd, 3, y + 3) != fmi2OK) {
            CHECK(0 && "Co-Simulation step failed");
            break;
        }
        for (int i = 0; i < 6; ++i) {
            max_diff = fmax(max_diff, fabs(x[i] - y[i]));
            n_bits += !bits_equal(x + i, y + i, 1);
            moved = fmax(moved, fabs(x[i] - x0[i]));
            ++n_cmp;
        }
    }
    printf("rrr_plant RK4 through Model Exchange (h = %g s) vs Co-Simulation (h_int = 1e-4 s, "
           "1 ms steps), 0.5 s: max |x_ME - x_CS| = %.3g over %d values, %d differ in any bit "
           "(the state moved by up to %.3g)\n",
           dt, max_diff, n_cmp, n_bits, moved);
    CHECK(n_cmp == STEPS * 6);
    CHECK(n_bits == 0 && max_diff == 0.0);
    CHECK(moved > 0.1);
    CHECK(me.log.count[fmi2Error] == 0 && cs.log.count[fmi2Error] == 0);
    inst_free(&me);
    inst_free(&cs);
}

/* The controller (no states, direct feedthrough) gives the same outputs in Model Exchange
 * (event and continuous-time mode) as in Co-Simulation and as librrr's rrr_ctc. */
static void test_me_controller(const fmu_api *api)
{
    enum { N = 400 };
    fmi2ValueReference in[15], out[9];
    fh_vrs(&ops2, api, fh_ctrl_inputs, 5, in);
    vrs3(api, "u", out);
    vrs3(api, "u_n", out + 3);
    vrs3(api, "u_c", out + 6);
    const fmi2ValueReference vff = vr_of(api, "feedforward");
    int n_diff = 0, n_lib = 0, n_sat = 0, total = 0, in_ct = 0;
    for (int cfg = 0; cfg < 2; ++cfg) {
        rrr_model m;
        rrr_ctc_gains g;
        CHECK(rrr_model_default(&m) == RRR_OK && rrr_ctc_gains_default(&g) == RRR_OK);
        inst me, cs;
        if (inst_new_me(&me, api, "me_ctrl") || inst_new(&cs, api, "cs_ctrl")) {
            return;
        }
        if (cfg == 1) {
            const fmi2Boolean off = fmi2False;
            g.feedforward = 0;
            g.kp[1] = 7.5;
            g.kd[2] = 0.4;
            inst *both[2] = {&me, &cs};
            for (int k = 0; k < 2; ++k) {
                CHECK(api->SetBoolean(both[k]->c, &vff, 1, &off) == fmi2OK);
                CHECK(set1(both[k], "kp[2]", g.kp[1]) == fmi2OK);
                CHECK(set1(both[k], "kd[3]", g.kd[2]) == fmi2OK);
            }
        }
        CHECK(drive_me(&me, MS_EVENT) == 0);
        CHECK(drive(&cs, ST_INIT) == 0);
        CHECK(api->ExitInitializationMode(cs.c) == fmi2OK);
        rrr_rng rng = {cfg == 0 ? UINT64_C(0xC0FFEE) : UINT64_C(0xBADC0DE)};
        for (int k = 0; k < N; ++k) {
            if (k == N / 2) { /* the second half in continuous-time mode */
                fmi2EventInfo ev;
                CHECK(api->NewDiscreteStates(me.c, &ev) == fmi2OK);
                CHECK(api->EnterContinuousTimeMode(me.c) == fmi2OK);
                CHECK(fingerprint_me_quiet(&me) == expected_fingerprint_me[MS_CONT]);
            }
            double v[15], a[9], b[9], r[9];
            for (int i = 0; i < 3; ++i) {
                v[i] = rrr_rng_uniform(&rng, -2.0, 2.0);
                v[3 + i] = rrr_rng_uniform(&rng, -3.0, 3.0);
                v[6 + i] = rrr_rng_uniform(&rng, -4.0, 4.0);
                v[9 + i] = v[i] + rrr_rng_uniform(&rng, -0.2, 0.2);
                v[12 + i] = v[3 + i] + rrr_rng_uniform(&rng, -0.5, 0.5);
            }
            if (api->SetReal(me.c, in, 15, v) != fmi2OK ||
                api->GetReal(me.c, out, 9, a) != fmi2OK ||
                api->SetReal(cs.c, in, 15, v) != fmi2OK ||
                api->GetReal(cs.c, out, 9, b) != fmi2OK) {
                CHECK(0 && "controller set/get failed");
                break;
            }
            rrr_ctc_output o;
            CHECK(rrr_ctc(&m, &g, v, v + 3, v + 6, v + 9, v + 12, &o) == RRR_OK);
            memcpy(r, o.u, sizeof o.u);
            memcpy(r + 3, o.u_n, sizeof o.u_n);
            memcpy(r + 6, o.u_c, sizeof o.u_c);
            n_diff += !bits_equal(a, b, 9);
            n_lib += !bits_equal(a, r, 9);
            n_sat += o.saturated != 0u;
            in_ct += k >= N / 2;
            ++total;
        }
        CHECK(me.log.count[fmi2Error] == 0 && cs.log.count[fmi2Error] == 0);
        inst_free(&me);
        inst_free(&cs);
    }
    printf("rrr_controller Model Exchange vs Co-Simulation: %d random input sets (%d in "
           "ContinuousTimeMode, 2 parameter sets, %d saturated): u, u_n, u_c differ in %d sets, "
           "differ from librrr rrr_ctc in %d (bit for bit)\n",
           total, in_ct, n_sat, n_diff, n_lib);
    CHECK(total == 2 * N);
    CHECK(n_diff == 0 && n_lib == 0);
    CHECK(n_sat > 0 && n_sat < total);
}

/* Refused Model Exchange arguments: nothing changes. */
static void test_me_bad_values(const fmu_api *plant, const fmu_api *ctrl)
{
    inst p, c;
    if (inst_new_me(&p, plant, "me_bad_plant") || inst_new_me(&c, ctrl, "me_bad_ctrl")) {
        return;
    }
    CHECK(set1(&p, "u[1]", 1.0) == fmi2OK);
    CHECK(drive_me(&p, MS_CONT) == 0 && drive_me(&c, MS_CONT) == 0);
    double x0[6] = {0}, dx0[6] = {0}, xb[6], buf[6];
    CHECK(plant->SetContinuousStates(p.c, (const double[6]){0.2, -0.3, 0.4, 0.5, -0.6, 0.7}, 6) ==
          fmi2OK);
    CHECK(plant->GetContinuousStates(p.c, x0, 6) == fmi2OK);
    CHECK(plant->GetDerivatives(p.c, dx0, 6) == fmi2OK);

    /* non-finite states: refused as a whole (every other element changed too) */
    const struct {
        size_t i;
        double v;
    } bad_x[] = {{0, (double)NAN}, {4, (double)INFINITY}, {5, -(double)INFINITY}};
    for (size_t k = 0; k < sizeof bad_x / sizeof bad_x[0]; ++k) {
        for (size_t i = 0; i < 6; ++i) {
            xb[i] = x0[i] + 0.5;
        }
        xb[bad_x[k].i] = bad_x[k].v;
        REFUSED(&p, plant->SetContinuousStates(p.c, xb, 6), "fmi2SetContinuousStates",
                plant->x_name[bad_x[k].i]);
        CHECK(plant->GetContinuousStates(p.c, buf, 6) == fmi2OK && bits_equal(buf, x0, 6));
        CHECK(plant->GetDerivatives(p.c, buf, 6) == fmi2OK && bits_equal(buf, dx0, 6));
    }
    /* non-finite time (the serialized FMU state holds the time: unchanged) */
    REFUSED(&p, plant->SetTime(p.c, (double)NAN), "fmi2SetTime", NULL);
    REFUSED(&p, plant->SetTime(p.c, (double)INFINITY), "fmi2SetTime", NULL);
    REFUSED(&p, plant->SetTime(p.c, -(double)INFINITY), "fmi2SetTime", NULL);

    /* wrong nx and ni: refused before any element is read or written (the arrays hold 6) */
    for (size_t i = 0; i < 6; ++i) {
        buf[i] = -7.0;
    }
    REFUSED(&p, plant->SetContinuousStates(p.c, x0, 5), "fmi2SetContinuousStates", NULL);
    REFUSED(&p, plant->SetContinuousStates(p.c, x0, 0), "fmi2SetContinuousStates", NULL);
    REFUSED(&p, plant->GetContinuousStates(p.c, buf, 7), "fmi2GetContinuousStates", NULL);
    REFUSED(&p, plant->GetDerivatives(p.c, buf, 5), "fmi2GetDerivatives", NULL);
    REFUSED(&p, plant->GetDerivatives(p.c, buf, 7), "fmi2GetDerivatives", NULL);
    REFUSED(&p, plant->GetNominalsOfContinuousStates(p.c, buf, 5),
            "fmi2GetNominalsOfContinuousStates", NULL);
    REFUSED(&p, plant->GetEventIndicators(p.c, buf, 1), "fmi2GetEventIndicators", NULL);
    for (size_t i = 0; i < 6; ++i) {
        CHECK(buf[i] == -7.0);
    }
    /* NULL arrays */
    fmi2Boolean flag = fmi2False;
    REFUSED(&p, plant->SetContinuousStates(p.c, NULL, 6), "fmi2SetContinuousStates", "NULL");
    REFUSED(&p, plant->GetContinuousStates(p.c, NULL, 6), "fmi2GetContinuousStates", "NULL");
    REFUSED(&p, plant->GetDerivatives(p.c, NULL, 6), "fmi2GetDerivatives", "NULL");
    REFUSED(&p, plant->GetNominalsOfContinuousStates(p.c, NULL, 6),
            "fmi2GetNominalsOfContinuousStates", "NULL");
    REFUSED(&p, plant->CompletedIntegratorStep(p.c, fmi2True, NULL, &flag),
            "fmi2CompletedIntegratorStep", "NULL");
    REFUSED(&p, plant->CompletedIntegratorStep(p.c, fmi2True, &flag, NULL),
            "fmi2CompletedIntegratorStep", "NULL");
    CHECK(plant->GetEventIndicators(p.c, NULL, 0) == fmi2OK); /* no indicators, no array */

    /* outputs are never set; inputs in continuous-time mode, finite only */
    fh_expect_refused(&ops2, &p, "q[1]", 1.0, "q[1]");
    fh_expect_refused(&ops2, &p, "qdd[2]", 0.0, "qdd[2]");
    fh_expect_refused(&ops2, &p, "tip.x", 0.0, "tip.x");
    fh_expect_refused(&ops2, &p, "u[2]", (double)INFINITY, "u[2]");
    fh_expect_refused(&ops2, &p, "kt[1]", 0.5, "ContinuousTimeMode"); /* a fixed parameter */
    CHECK(set1(&p, "u[2]", -2.5) == fmi2OK);
    CHECK(plant->GetDerivatives(p.c, buf, 6) == fmi2OK);
    CHECK(bits_equal(buf, dx0, 3) && !bits_equal(buf + 3, dx0 + 3, 3)); /* qdd follows u */

    /* event mode: fixed parameters are refused, naming the state */
    CHECK(plant->EnterEventMode(p.c) == fmi2OK);
    fmi2EventInfo *no_info = NULL;
    REFUSED(&p, plant->NewDiscreteStates(p.c, no_info), "fmi2NewDiscreteStates", "NULL");
    fh_expect_refused(&ops2, &p, "a2", 0.5, "EventMode");
    fh_expect_refused(&ops2, &p, "q0[1]", 0.5, "EventMode");
    fh_expect_refused(&ops2, &p, "h_int", 1e-3, "EventMode");
    fh_expect_refused(&ops2, &p, "p[3]", 1.0, "EventMode");
    fh_expect_refused(&ops2, &p, "qd[3]", 0.0, "qd[3]"); /* a state, but an output */
    CHECK(fingerprint_me_quiet(&p) == expected_fingerprint_me[MS_EVENT]);
    CHECK(plant->GetContinuousStates(p.c, buf, 6) == fmi2OK && bits_equal(buf, x0, 6));

    /* the controller: no states, no indicators */
    double one[1] = {0.0};
    CHECK(ctrl->SetContinuousStates(c.c, NULL, 0) == fmi2OK);
    CHECK(ctrl->GetDerivatives(c.c, NULL, 0) == fmi2OK);
    CHECK(ctrl->GetNominalsOfContinuousStates(c.c, NULL, 0) == fmi2OK);
    REFUSED(&c, ctrl->SetContinuousStates(c.c, one, 1), "fmi2SetContinuousStates", NULL);
    REFUSED(&c, ctrl->GetContinuousStates(c.c, one, 1), "fmi2GetContinuousStates", NULL);
    REFUSED(&c, ctrl->GetDerivatives(c.c, one, 1), "fmi2GetDerivatives", NULL);
    REFUSED(&c, ctrl->GetEventIndicators(c.c, one, 1), "fmi2GetEventIndicators", NULL);
    REFUSED(&c, ctrl->SetTime(c.c, (double)NAN), "fmi2SetTime", NULL);
    fh_expect_refused(&ops2, &c, "u_c[3]", 1.0, "u_c[3]");
    fh_expect_refused(&ops2, &c, "q_ref[1]", (double)NAN, "q_ref[1]");
    CHECK(ctrl->EnterEventMode(c.c) == fmi2OK);
    fh_expect_refused(&ops2, &c, "kp[1]", 5.0, "EventMode");
    fh_expect_refused(&ops2, &c, "g", 9.0, "EventMode");
    {
        const fmi2ValueReference ff = vr_of(ctrl, "feedforward");
        const fmi2Boolean off = fmi2False;
        fmi2Boolean b = fmi2False;
        REFUSED(&c, ctrl->SetBoolean(c.c, &ff, 1, &off), "fmi2SetBoolean", "EventMode");
        CHECK(ctrl->GetBoolean(c.c, &ff, 1, &b) == fmi2OK && b == fmi2True);
    }
    CHECK(fingerprint_me_quiet(&c) == expected_fingerprint_me[MS_EVENT]);
    CHECK(plant->Terminate(p.c) == fmi2OK && ctrl->Terminate(c.c) == fmi2OK);
    inst_free(&p);
    inst_free(&c);
}

/* Run n RK4 steps of dt from time t and the instance's own states, recording the states. */
static void me_run(inst *p, double t, int n, double dt, double (*rec)[6])
{
    double x[6];
    if (p->api->GetContinuousStates(p->c, x, 6) != fmi2OK) {
        CHECK(0 && "GetContinuousStates failed");
        return;
    }
    for (int k = 0; k < n; ++k) {
        if (me_rk4(p, t + k * dt, dt, x, 6)) {
            CHECK(0 && "RK4 step through Model Exchange failed");
            return;
        }
        memcpy(rec[k], x, sizeof x);
    }
}

/* FMU state of Model Exchange instances: a bit-identical continuation after set and after
 * serialize/deserialize; Model Exchange and Co-Simulation snapshots do not mix. */
static void test_me_fmu_state(const fmu_api *plant, const fmu_api *ctrl)
{
    enum { N = 300 };
    const double dt = 1e-4;
    static double rec1[N][6], rec2[N][6], rec3[N][6];
    inst p, cs, c;
    if (inst_new_me(&p, plant, "me_state") || inst_new(&cs, plant, "cs_state") ||
        inst_new_me(&c, ctrl, "me_state_ctrl")) {
        return;
    }
    CHECK(set1(&p, "u[1]", 2.0) == fmi2OK && set1(&p, "u[3]", -1.0) == fmi2OK);
    CHECK(set1(&p, "q0[2]", 0.4) == fmi2OK);
    CHECK(drive_me(&p, MS_CONT) == 0);
    me_run(&p, 0.0, 100, dt, rec1);
    const double t1 = 100 * dt;
    fmi2FMUstate s = NULL;
    CHECK(plant->GetFMUstate(p.c, &s) == fmi2OK && s != NULL);
    size_t n = 0;
    CHECK(plant->SerializedFMUstateSize(p.c, s, &n) == fmi2OK && n > 0);
    fmi2Byte *bytes = malloc(n);
    if (bytes == NULL) {
        CHECK(0 && "out of memory");
        return;
    }
    CHECK(plant->SerializeFMUstate(p.c, s, bytes, n) == fmi2OK);
    me_run(&p, t1, N, dt, rec1);
    CHECK(!same_state(&p, (unsigned char *)bytes, n)); /* it moved on */

    /* set back: the instance serializes to the snapshot's bytes (time, states, mode); rerun:
     * bit-identical */
    CHECK(plant->SetFMUstate(p.c, s) == fmi2OK);
    CHECK(same_state(&p, (unsigned char *)bytes, n));
    CHECK(fingerprint_me_quiet(&p) == expected_fingerprint_me[MS_CONT]);
    me_run(&p, t1, N, dt, rec2);
    CHECK(memcmp(rec1, rec2, sizeof rec1) == 0);

    /* free, deserialize, set, rerun: bit-identical */
    CHECK(plant->FreeFMUstate(p.c, &s) == fmi2OK && s == NULL);
    CHECK(plant->DeSerializeFMUstate(p.c, bytes, n, &s) == fmi2OK && s != NULL);
    CHECK(plant->SetFMUstate(p.c, s) == fmi2OK);
    CHECK(same_state(&p, (unsigned char *)bytes, n));
    me_run(&p, t1, N, dt, rec3);
    CHECK(memcmp(rec1, rec3, sizeof rec1) == 0);

    /* a snapshot taken in event mode brings event mode back */
    fmi2FMUstate s_event = NULL;
    fmi2EventInfo ev;
    CHECK(plant->EnterEventMode(p.c) == fmi2OK);
    CHECK(plant->GetFMUstate(p.c, &s_event) == fmi2OK);
    CHECK(plant->NewDiscreteStates(p.c, &ev) == fmi2OK);
    CHECK(plant->EnterContinuousTimeMode(p.c) == fmi2OK);
    CHECK(plant->SetFMUstate(p.c, s_event) == fmi2OK);
    CHECK(fingerprint_me_quiet(&p) == expected_fingerprint_me[MS_EVENT]);
    CHECK(plant->FreeFMUstate(p.c, &s_event) == fmi2OK);

    /* Co-Simulation and Model Exchange snapshots of the same binary do not mix */
    CHECK(drive(&cs, ST_DONE) == 0);
    fmi2FMUstate s_cs = NULL, junk = NULL;
    size_t n_cs = 0, size = 0;
    CHECK(plant->GetFMUstate(cs.c, &s_cs) == fmi2OK && s_cs != NULL);
    CHECK(plant->SerializedFMUstateSize(cs.c, s_cs, &n_cs) == fmi2OK);
    fmi2Byte *bytes_cs = malloc(n_cs > 0 ? n_cs : 1);
    if (bytes_cs == NULL) {
        CHECK(0 && "out of memory");
        return;
    }
    CHECK(plant->SerializeFMUstate(cs.c, s_cs, bytes_cs, n_cs) == fmi2OK);
    REFUSED(&p, plant->SetFMUstate(p.c, s_cs), "fmi2SetFMUstate", "interface");
    REFUSED(&p, plant->DeSerializeFMUstate(p.c, bytes_cs, n_cs, &junk), "fmi2DeSerializeFMUstate",
            "interface");
    CHECK(junk == NULL);
    if (junk != NULL) {
        plant->FreeFMUstate(p.c, &junk);
    }
    REFUSED(&p, plant->SerializedFMUstateSize(p.c, s_cs, &size), "fmi2SerializedFMUstateSize",
            "interface");
    REFUSED(&p, plant->FreeFMUstate(p.c, &s_cs), "fmi2FreeFMUstate", NULL);
    CHECK(s_cs != NULL); /* not freed by the wrong instance */
    CHECK(fingerprint_me_quiet(&p) == expected_fingerprint_me[MS_EVENT]);
    /* ... and the other way round */
    REFUSED(&cs, plant->SetFMUstate(cs.c, s), "fmi2SetFMUstate", "interface");
    REFUSED(&cs, plant->DeSerializeFMUstate(cs.c, bytes, n, &junk), "fmi2DeSerializeFMUstate",
            "interface");
    CHECK(junk == NULL);
    if (junk != NULL) {
        plant->FreeFMUstate(cs.c, &junk);
    }
    CHECK(fingerprint(&cs) == expected_fingerprint[ST_DONE]);
    CHECK(plant->FreeFMUstate(cs.c, &s_cs) == fmi2OK && s_cs == NULL);
    CHECK(plant->FreeFMUstate(p.c, &s) == fmi2OK && s == NULL);

    /* the controller: a snapshot restores inputs and outputs */
    fmi2ValueReference vin[3], vout[3];
    vrs3(ctrl, "q_ref", vin);
    vrs3(ctrl, "u", vout);
    const double ra[3] = {0.2, -0.1, 0.4}, rb[3] = {-0.5, 0.3, 0.1};
    double ua[3], ub[3], uc[3];
    CHECK(drive_me(&c, MS_CONT) == 0);
    CHECK(ctrl->SetReal(c.c, vin, 3, ra) == fmi2OK && ctrl->GetReal(c.c, vout, 3, ua) == fmi2OK);
    fmi2FMUstate sc = NULL;
    CHECK(ctrl->GetFMUstate(c.c, &sc) == fmi2OK);
    CHECK(ctrl->SetReal(c.c, vin, 3, rb) == fmi2OK && ctrl->GetReal(c.c, vout, 3, ub) == fmi2OK);
    CHECK(!bits_equal(ua, ub, 3));
    CHECK(ctrl->SetFMUstate(c.c, sc) == fmi2OK && ctrl->GetReal(c.c, vout, 3, uc) == fmi2OK);
    CHECK(bits_equal(ua, uc, 3));
    REFUSED(&c, ctrl->SetFMUstate(c.c, NULL), "fmi2SetFMUstate", NULL);
    CHECK(ctrl->FreeFMUstate(c.c, &sc) == fmi2OK && sc == NULL);

    free(bytes);
    free(bytes_cs);
    inst_free(&p);
    inst_free(&cs);
    inst_free(&c);
}

/* ==== forged FMU states ========================================================================
 * A state with a valid checksum whose fields were overwritten (fmu_state_forge.h) is refused by
 * DeSerializeFMUstate, and by SetFMUstate when the importer overwrote a state block it holds,
 * with fmi2Error, a message naming the field, and the instance unchanged. */

/* Samples of the table in <resources>/reference.csv (resources = "file://<dir>"). */
static size_t table_samples(const char *resources)
{
    char path[4096];
    snprintf(path, sizeof path, "%.4000s/reference.csv", resources + strlen("file://"));
    FILE *f = fopen(path, "r");
    size_t lines = 0;
    int c, last = '\n';
    while (f != NULL && (c = fgetc(f)) != EOF) {
        lines += c == '\n';
        last = c;
    }
    lines += last != '\n';
    if (f != NULL) {
        fclose(f);
    }
    return lines > 0 ? lines - 1 : 0;
}

static void test_forged_states(const fmu_api *api, const forge_case *cases, size_t n_cases,
                               size_t data_size)
{
    inst x;
    if (inst_new(&x, api, "forged")) {
        return;
    }
    CHECK(drive(&x, ST_DONE) == 0);
    CHECK(api->DoStep(x.c, H, H, fmi2True) == fmi2OK);
    fh_forged_states(&ops2, &x, cases, n_cases, data_size, NULL, 2 * H);
    inst_free(&x);
}

/* A state the checks cannot refuse (every field finite and in range) but far from any motion
 * the arm makes: joint velocities of 1e3 to 1e12 rad/s, whose Coriolis terms make the plant
 * arbitrarily stiff. Integrated at a bounded cost: doStep ends within its step budget
 * (PLANT_FMU_MAX_STEPS internal steps) with OK or a Discard that says why, the state kept. */
static double now_s(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (double)t.tv_sec + 1e-9 * (double)t.tv_nsec;
}

static void test_forged_fast_state(const fmu_api *api)
{
    inst x;
    if (inst_new(&x, api, "forged_fast")) {
        return;
    }
    CHECK(drive(&x, ST_DONE) == 0);
    size_t n = 0;
    unsigned char *good = state_bytes(&x, &n);
    if (good == NULL || !forge_layout_ok(n, sizeof(forge_plant))) {
        CHECK(0 && "plant FMU state layout");
        free(good);
        inst_free(&x);
        return;
    }
    double worst = 0.0;
    int discarded = 0;
    for (double qd = 1e3; qd <= 1e12; qd *= 1e3) {
        forge_f64(good, FORGE_PLANT(x.qd[1]), qd);
        forge_f64(good, FORGE_PLANT(x.qd[2]), -qd);
        forge_reseal(good, n);
        fmi2FMUstate s = NULL;
        CHECK(api->DeSerializeFMUstate(x.c, (const fmi2Byte *)good, n, &s) == fmi2OK);
        CHECK(api->SetFMUstate(x.c, s) == fmi2OK);
        log_clear(&x);
        const double t0 = now_s();
        const fmi2Status st = api->DoStep(x.c, H, H, fmi2True);
        const double took = now_s() - t0;
        worst = took > worst ? took : worst;
        CHECK(st == fmi2OK || st == fmi2Discard);
        if (st == fmi2Discard) {
            ++discarded;
            CHECK(strstr(x.log.last, "internal steps") != NULL ||
                  strstr(x.log.last, "failed") != NULL);
        }
        CHECK(api->SetFMUstate(x.c, s) == fmi2OK); /* out of StepFailed, if it failed */
        CHECK(api->FreeFMUstate(x.c, &s) == fmi2OK);
    }
    /* the budget bounds the work (a step count), not the time: printed, not checked (about
     * 0.3 s natively; without the budget a step would run for hours, past CTest's timeout) */
    printf("rrr_plant: forged velocities up to 1e12 rad/s: every doStep within %.3f s (%d "
           "discarded within the step budget)\n", worst, discarded);
    free(good);
    inst_free(&x);
}

/* The reference: its cases for the FMU's own table, another table's hash, and a cursor that is
 * a valid interval (accepted: it is a hint of where the look-up starts). */
static void test_forged_reference(const fmu_api *api)
{
    const size_t n_samples = table_samples(api->resources);
    CHECK(n_samples >= 2);
    const forge_case cases[] = {
        FORGE_REFERENCE_CASES(n_samples),
        {"cursor = the number of samples", {U8(FORGE_REF(cursor), n_samples), NONE}, "cursor"},
    };
    test_forged_states(api, cases, sizeof cases / sizeof cases[0], sizeof(forge_reference));
    inst x;
    if (inst_new(&x, api, "forged_ref")) {
        return;
    }
    CHECK(drive(&x, ST_DONE) == 0);
    size_t n = 0;
    unsigned char *good = state_bytes(&x, &n);
    if (good != NULL && forge_layout_ok(n, sizeof(forge_reference))) {
        const uint64_t hash = forge_get_u64(good, FORGE_REF(table_hash));
        forge_u64(good, FORGE_REF(table_hash), hash ^ 2u);
        forge_reseal(good, n);
        fmi2FMUstate s = NULL;
        log_clear(&x);
        CHECK(api->DeSerializeFMUstate(x.c, (const fmi2Byte *)good, n, &s) == fmi2Error && s == NULL);
        CHECK(strstr(x.log.last_error, "another reference table") != NULL);
        forge_u64(good, FORGE_REF(table_hash), hash);
        forge_u64(good, FORGE_REF(cursor), n_samples - 2u); /* the last interval */
        forge_reseal(good, n);
        CHECK(api->DeSerializeFMUstate(x.c, (const fmi2Byte *)good, n, &s) == fmi2OK && s != NULL);
        CHECK(api->SetFMUstate(x.c, s) == fmi2OK);
        CHECK(api->DoStep(x.c, H, H, fmi2True) == fmi2OK);
        CHECK(api->FreeFMUstate(x.c, &s) == fmi2OK);
    } else {
        CHECK(0 && "reference FMU state layout");
    }
    free(good);
    inst_free(&x);
}

/* ==== the reference FMU (rrr_reference) ======================================================= */

static const char ref_header[] =
    "t,q_ref[1],q_ref[2],q_ref[3],qd_ref[1],qd_ref[2],qd_ref[3],qdd_ref[1],qdd_ref[2],"
    "qdd_ref[3],x_ref.x,x_ref.y,x_ref.z,xd_ref.x,xd_ref.y,xd_ref.z,xdd_ref.x,xdd_ref.y,"
    "xdd_ref.z\n";

/* A folder <tmp>/<name>/resources/ holding reference.csv with `body` after the header (no
 * header when header is 0); uri receives file://<folder>/resources with spaces as %20. */
static int ref_folder(const char *tmp, const char *name, int header, const char *body,
                      char *uri, size_t n)
{
    char dir[700];
    char path[800];
    snprintf(dir, sizeof dir, "%s/%s", tmp, name);
    if (mkdir(dir, 0700) != 0) {
        return 1;
    }
    snprintf(path, sizeof path, "%s/resources", dir);
    if (mkdir(path, 0700) != 0) {
        return 1;
    }
    snprintf(path, sizeof path, "%s/resources/reference.csv", dir);
    FILE *f = fopen(path, "w");
    if (f == NULL) {
        return 1;
    }
    fprintf(f, "%s%s", header ? ref_header : "", body);
    fclose(f);
    size_t k = (size_t)snprintf(uri, n, "file://");
    for (const char *p = dir; *p != '\0' && k + 4 < n; ++p) {
        if (*p == ' ') {
            memcpy(uri + k, "%20", 3);
            k += 3;
        } else {
            uri[k++] = *p;
        }
    }
    snprintf(uri + k, n - k, "/resources");
    return 0;
}

static void rm_folder(const char *tmp, const char *name)
{
    char path[800];
    snprintf(path, sizeof path, "%s/%s/resources/reference.csv", tmp, name);
    remove(path);
    snprintf(path, sizeof path, "%s/%s/resources", tmp, name);
    rmdir(path);
    snprintf(path, sizeof path, "%s/%s", tmp, name);
    rmdir(path);
}

/* exitInitializationMode of an instance at `uri`: its status and (in msg) its last error. */
static fmi2Status ref_init(const fmu_api *api, const char *uri, char *msg, size_t n)
{
    inst x;
    if (inst_new_at(&x, api, "ref_init", uri)) {
        return fmi2Fatal;
    }
    CHECK(api->SetupExperiment(x.c, fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2OK);
    CHECK(api->EnterInitializationMode(x.c) == fmi2OK);
    const fmi2Status st = api->ExitInitializationMode(x.c);
    snprintf(msg, n, "%s", x.log.last_error);
    if (st == fmi2Error) {
        CHECK(api->DoStep(x.c, 0.0, H, fmi2True) == fmi2Error); /* Error state: no step */
    }
    inst_free(&x);
    return st;
}

#define REF_ROW(T, Q) #T "," #Q ",0.2,0.3,1,0,0,0,0,0,0.5,-0.25,0.4,0,0,0,0,0,0\n"

/* <dir>/resources/start_values.csv holding `len` bytes of `body`; uri receives its location. */
static int start_folder(const char *dir, const char *body, size_t len, char *uri, size_t n)
{
    char path[800];
    snprintf(path, sizeof path, "%s/resources", dir);
    (void)mkdir(path, 0700);
    snprintf(path, sizeof path, "%s/resources/start_values.csv", dir);
    FILE *f = fopen(path, "wb");
    if (f == NULL) {
        return 1;
    }
    const int ok = fwrite(body, 1, len, f) == len;
    fclose(f);
    snprintf(uri, n, "file://%s/resources", dir);
    return !ok;
}

/* resources/start_values.csv: its values replace the compiled start values at instantiation and
 * reset; a malformed file stops the instantiation with a message naming the line. */
static void test_start_file(const fmu_api *api)
{
    char dir[] = "/tmp/rrr_start_harness_XXXXXX";
    if (mkdtemp(dir) == NULL) {
        CHECK(0);
        return;
    }
    char uri[1100];
    static const char good[] = "# one system's values\nname,value\nkp[2],123.5\r\n\n"
                               "f[1,2],0.25\nfeedforward,false\n";
    if (start_folder(dir, good, sizeof good - 1, uri, sizeof uri) != 0) {
        CHECK(0);
        return;
    }
    inst x;
    if (inst_new_at(&x, api, "start_file", uri) == 0) {
        CHECK(api->SetupExperiment(x.c, fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2OK);
        CHECK(api->EnterInitializationMode(x.c) == fmi2OK);
        CHECK(get1(&x, "kp[2]") == 123.5 && get1(&x, "f[1,2]") == 0.25);
        const fmi2ValueReference ff = vr_of(api, "feedforward");
        fmi2Boolean b = fmi2True;
        CHECK(api->GetBoolean(x.c, &ff, 1, &b) == fmi2OK && b == fmi2False);
        CHECK(api->Reset(x.c) == fmi2OK);
        CHECK(set1(&x, "kp[2]", 7.0) == fmi2OK);
        CHECK(api->Reset(x.c) == fmi2OK);
        CHECK(api->SetupExperiment(x.c, fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2OK);
        CHECK(api->EnterInitializationMode(x.c) == fmi2OK);
        CHECK(get1(&x, "kp[2]") == 123.5); /* the file's again after Reset */
        inst_free(&x);
    }
    static char big[70000];
    memset(big, '#', sizeof big);
    static const struct {
        const char *body;
        size_t len; /* 0: strlen(body) */
        const char *needle;
    } bad[] = {
        {"kp[2],1\n", 0, "line 1: the header name,value expected"},
        {"name,value\nkp[2]\n", 0, "line 2: expected name,value"},
        {"name,value\nkq[2],1\n", 0, "has no parameter or input \"kq[2]\""},
        {"name,value\nu[1],1\n", 0, "has no parameter or input \"u[1]\""},
        {"name,value\nkp[2],1.5x\n", 0, "kp[2]: a number expected, got \"1.5x\""},
        {"name,value\nkp[2],nan\n", 0, "kp[2] must be finite"},
        {"name,value\nkp[2],-1e999\n", 0, "kp[2] must be finite"},
        {"name,value\nfeedforward,yes\n", 0, "true or false expected"},
        {"name,value\nkp[2],1\0\n", 19, "not text"},
        {big, sizeof big, "is larger than 65536 bytes"},
    };
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; ++k) {
        const size_t len = bad[k].len != 0 ? bad[k].len : strlen(bad[k].body);
        if (start_folder(dir, bad[k].body, len, uri, sizeof uri) != 0) {
            CHECK(0);
            continue;
        }
        inst y;
        memset(&y, 0, sizeof y);
        y.api = api;
        y.cb.logger = logger;
        y.cb.allocateMemory = count_calloc;
        y.cb.freeMemory = count_free;
        y.cb.componentEnvironment = &y.log;
        y.c = api->Instantiate("start_bad", fmi2CoSimulation, api->guid, uri, &y.cb, fmi2False,
                               fmi2False);
        if (y.c != NULL || strstr(y.log.last_error, bad[k].needle) == NULL ||
            strstr(y.log.last_error, "start_values.csv") == NULL) {
            fprintf(stderr, "start file %zu: instance %p, message \"%s\", expected \"%s\"\n", k,
                    (void *)y.c, y.log.last_error, bad[k].needle);
            rrr_test_failures++;
            inst_free(&y);
        }
    }
    char path[800];
    snprintf(path, sizeof path, "%s/resources/start_values.csv", dir);
    remove(path);
    snprintf(path, sizeof path, "%s/resources", dir);
    rmdir(path);
    rmdir(dir);
}

/* Tables in resources/: missing, malformed ones refused at exitInitializationMode with a message
 * naming the problem; a percent-escaped resource URI; FMU state set into a fresh instance (the
 * table is read on first use) and refused by an instance with another table. */
static void test_reference(const fmu_api *api)
{
    char tmp[] = "/tmp/rrr ref harness XXXXXX"; /* a space: the URI escapes it */
    if (mkdtemp(tmp) == NULL) {
        CHECK(0);
        return;
    }
    char uri[1100];
    char msg[1024];
    static const struct {
        const char *name;
        int header;
        const char *body;
        const char *needle;
    } bad[] = {
        {"nan", 1, REF_ROW(0, 0.1) "0.01,nan,0.2,0.3,1,0,0,0,0,0,0.5,-0.25,0.4,0,0,0,0,0,0\n",
         "line 3, column q_ref[1]: \"nan\" is not a finite decimal number"},
        {"unsorted", 1, REF_ROW(0.02, 0.1) REF_ROW(0.01, 0.2),
         "line 3: t = 0.01 is not after t = 0.02 of line 2"},
        {"columns", 1, "0,1,2\n1,2,3\n", "line 2 has 3 values, expected 19"},
        {"header", 0, REF_ROW(0, 0.1) REF_ROW(0.01, 0.2), "line 1: column 1 must be \"t\""},
        {"one row", 1, REF_ROW(0, 0.1), "has 1 sample(s)"},
        {"empty", 0, "", "is empty (no header)"},
        {"extra", 1, "0,0.1,0.2,0.3,1,0,0,0,0,0,0.5,-0.25,0.4,0,0,0,0,0,0,7\n" REF_ROW(1, 0),
         "line 2 has more than 19 values"},
        {"blank", 1, REF_ROW(0, 0.1) "\n" REF_ROW(0.01, 0.2), "line 3 is empty"},
        {"comma", 1, REF_ROW(0, 0.1) "0.01,0\xef\xbc\x8c" "2,0.2,0.3,1,0,0,0,0,0,0.5,-0.25,0.4,"
                     "0,0,0,0,0,0\n", "is not a finite decimal number"},
    };
    for (size_t k = 0; k < sizeof bad / sizeof bad[0]; ++k) {
        if (ref_folder(tmp, bad[k].name, bad[k].header, bad[k].body, uri, sizeof uri) != 0) {
            CHECK(0);
            continue;
        }
        const fmi2Status st = ref_init(api, uri, msg, sizeof msg);
        if (st != fmi2Error || strstr(msg, bad[k].needle) == NULL) {
            fprintf(stderr, "reference table %s: status %d, message \"%s\", expected \"%s\"\n",
                    bad[k].name, (int)st, msg, bad[k].needle);
            rrr_test_failures++;
        }
        rm_folder(tmp, bad[k].name);
    }
    /* no table, no resource location, a location that is not a local folder */
    snprintf(uri, sizeof uri, "file://%s/nothing/resources", tmp);
    CHECK(ref_init(api, uri, msg, sizeof msg) == fmi2Error &&
          strstr(msg, "cannot open the reference table") != NULL);
    CHECK(ref_init(api, NULL, msg, sizeof msg) == fmi2Error &&
          strstr(msg, "no reference table") != NULL);
    CHECK(ref_init(api, "http://example.invalid/resources", msg, sizeof msg) == fmi2Error &&
          strstr(msg, "no reference table") != NULL);

    /* a good table behind a percent-escaped URI, played at 2 ms steps */
    CHECK(ref_folder(tmp, "good", 1, REF_ROW(0, 0.1) REF_ROW(0.01, 0.2) REF_ROW(0.02, 0.4),
                     uri, sizeof uri) == 0);
    char other[1100];
    CHECK(ref_folder(tmp, "other", 1, REF_ROW(0, 0.1) REF_ROW(0.01, 0.3), other,
                     sizeof other) == 0);
    inst a;
    inst b;
    inst c;
    if (inst_new_at(&a, api, "ref_a", uri) == 0 && inst_new_at(&b, api, "ref_b", uri) == 0 &&
        inst_new_at(&c, api, "ref_c", other) == 0) {
        CHECK(api->SetupExperiment(a.c, fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2OK);
        CHECK(api->EnterInitializationMode(a.c) == fmi2OK);
        CHECK(get1(&a, "q_ref[1]") == 0.1 && get1(&a, "qd_ref[1]") == 1.0);
        CHECK(api->ExitInitializationMode(a.c) == fmi2OK);
        CHECK(api->DoStep(a.c, 0.0, 0.005, fmi2True) == fmi2OK);
        const double mid = get1(&a, "q_ref[1]");
        CHECK(mid > 0.1 && mid < 0.2);
        fmi2FMUstate s = NULL;
        CHECK(api->GetFMUstate(a.c, &s) == fmi2OK);
        size_t n = 0;
        CHECK(api->SerializedFMUstateSize(a.c, s, &n) == fmi2OK && n > 0);
        fmi2Byte *bytes = malloc(n);
        CHECK(bytes != NULL && api->SerializeFMUstate(a.c, s, bytes, n) == fmi2OK);
        CHECK(api->DoStep(a.c, 0.005, 0.01, fmi2True) == fmi2OK);
        const double later = get1(&a, "q_ref[1]");
        CHECK(get1(&a, "q_ref[1]") != mid);
        /* into a fresh instance with the same table: the same continuation */
        fmi2FMUstate sb = NULL;
        CHECK(bytes != NULL && api->DeSerializeFMUstate(b.c, bytes, n, &sb) == fmi2OK);
        CHECK(api->SetFMUstate(b.c, sb) == fmi2OK);
        CHECK(get1(&b, "q_ref[1]") == mid);
        CHECK(api->DoStep(b.c, 0.005, 0.01, fmi2True) == fmi2OK && get1(&b, "q_ref[1]") == later);
        /* into an instance with another table: refused at once, the instance unchanged */
        fmi2FMUstate sc = NULL;
        log_clear(&c);
        CHECK(bytes != NULL && api->DeSerializeFMUstate(c.c, bytes, n, &sc) == fmi2Error &&
              sc == NULL);
        CHECK(strstr(c.log.last_error, "another reference table") != NULL);
        api->FreeFMUstate(a.c, &s);
        api->FreeFMUstate(b.c, &sb);
        api->FreeFMUstate(c.c, &sc);
        free(bytes);
        /* reset forgets the table and reads it again */
        CHECK(api->Reset(a.c) == fmi2OK);
        CHECK(api->SetupExperiment(a.c, fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2OK);
        CHECK(api->EnterInitializationMode(a.c) == fmi2OK);
        CHECK(api->ExitInitializationMode(a.c) == fmi2OK && get1(&a, "q_ref[1]") == 0.1);
    }
    inst_free(&a);
    inst_free(&b);
    inst_free(&c);
    rm_folder(tmp, "good");
    rm_folder(tmp, "other");
    rmdir(tmp);
    printf("rrr_reference: %zu malformed tables and 3 missing ones refused with a message; FMU "
           "state across instances and tables checked\n",
           sizeof bad / sizeof bad[0]);
}

int main(int argc, char **argv)
{
    if (argc != 3 && argc != 4) {
        fprintf(stderr, "usage: %s <plant unzip dir> <controller unzip dir> [<reference unzip "
                "dir>]\n", argv[0]);
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
    test_illegal_sequences(&plant, &cs_machine);
    test_illegal_sequences(&ctrl, &cs_machine);
    test_start_file(&ctrl);
    test_bad_values(&plant, &ctrl);
    test_validation(&plant, &ctrl);
    test_discard(&plant);
    test_time_overflow(&plant);
    test_fmu_state(&plant, &ctrl);
    test_forged_states(&plant, forge_plant_cases,
                       sizeof forge_plant_cases / sizeof forge_plant_cases[0], sizeof(forge_plant));
    test_forged_states(&ctrl, forge_controller_cases,
                       sizeof forge_controller_cases / sizeof forge_controller_cases[0],
                       sizeof(forge_controller));
    test_forged_fast_state(&plant);
    fh_two_instances(&ops2, &plant); /* nothing shared between two instances */
    test_logging(&plant);
    test_logging(&ctrl);

    /* Model Exchange */
    test_me_lifecycle(&plant);
    test_me_lifecycle(&ctrl);
    test_me_derivatives(&plant);
    test_me_rk4_vs_cs(&plant);
    test_me_controller(&ctrl);
    test_illegal_sequences(&plant, &me_machine);
    test_illegal_sequences(&ctrl, &me_machine);
    test_me_bad_values(&plant, &ctrl);
    test_me_fmu_state(&plant, &ctrl);

    if (argc != 4) {
        test_directional_derivatives(&plant, &ctrl, NULL);
    }
    if (argc == 4) {
        fmu_api ref;
        if (fmu_load(&ref, argv[3])) {
            return 2;
        }
        CHECK(strcmp(ref.id, "rrr_reference") == 0);
        test_directional_derivatives(&plant, &ctrl, &ref);
        test_instantiate(&ref);
        test_illegal_sequences(&ref, &cs_machine);
        test_illegal_sequences(&ref, &me_machine);
        test_logging(&ref);
        test_reference(&ref);
        test_forged_reference(&ref);
        fmu_unload(&ref);
    }

    if (n_live_blocks != 0) {
        fprintf(stderr, "%ld block(s) allocated through the callbacks were not freed\n",
                n_live_blocks);
        rrr_test_failures++;
    }
    fmu_unload(&plant);
    fmu_unload(&ctrl);
    return rrr_test_report("test_fmu_harness");
}
