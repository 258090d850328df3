/*
 * FMI 3.0 harness: loads the two FMI 3.0 FMU binaries with dlopen, like an importer, and drives
 * them through the FMI 3.0 API, Co-Simulation and Model Exchange. It knows nothing of fmu/common:
 * value references, names, start values, the continuous states and the instantiation token come
 * from each FMU's modelDescription.xml, and the allowed states of every function are typed in
 * again below from the state machines of the FMI 3.0 standard (section 2.3, common states; 3.2,
 * Model Exchange; 4.2, Co-Simulation). Run it under ASan and UBSan (-DRRR_SANITIZE=ON); FMI 3.0
 * has no allocator callbacks, so leaks are LeakSanitizer's to find (ASAN_OPTIONS=detect_leaks=1).
 *
 * Usage: test_fmu3_harness <plant unzip dir> <controller unzip dir>
 *                          [<FMI 2 plant unzip dir> <FMI 2 controller unzip dir>]
 *        (each FMI 3 dir holding modelDescription.xml and binaries/x86_64-linux/<id>.so; the
 *        optional FMI 2 dirs binaries/linux64/<id>.so: the FMI 3 results must equal theirs bit
 *        for bit)
 *
 * Checks: the XML (same names, value references and token as the FMI 2 build); instantiation
 * arguments and token; a NULL instance refused by every function; start values = XML start =
 * librrr defaults; a closed loop (Co-Simulation) with lastSuccessfulTime, reset and rerun, equal
 * to the FMI 2 loop; every function from every reachable state it is not allowed in (fmi3Error,
 * one message naming function and state, state unchanged), for both interface types; functions
 * that are not provided; NaN/Inf and other refused sets (old value kept); doStep arguments and a
 * discarded step; parameter validation; Model Exchange: lifecycle, derivatives = rrr_plant_accel,
 * refused states and times, an RK4 integration against the fixed-step Co-Simulation plant;
 * FMU state get/set/serialize/deserialize (bit-identical reruns, corrupted, truncated and
 * foreign bytes refused, interface types kept apart); two instances in one process; log
 * categories; no FMI 3 message that names an FMI 2 function.
 *
 * The checks the FMI 2.0 harness makes as well are in fmu_harness_common.c, run through this
 * harness's adapter of the FMI 3.0 calls (ops3); what is here is FMI 3.0's own.
 */
#define _POSIX_C_SOURCE 200809L

#include <ctype.h>
#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2FunctionTypes.h"
#include "fmi3FunctionTypes.h"
#include "rrr/rrr.h"
#include "fmu_state_forge.h"
#include "rrr_fmi_funcs.h"
#include "rrr_fmi_import.h"
#include "fmu_harness_common.h"
#include "fmu_test_reference.h"
#include "rrr_test.h"

#define H 1e-3          /* communication step, s */
#define MAX_VARS 128    /* variables per FMU */
#define MAX_STATES 8    /* continuous states per FMU */

/* ---- modelDescription.xml: through c_src/fmi_import -------------------------------------------- */

/* The function pointer, copied from the binary; aborts the run when it is missing. */
static void load_sym(const rrr_fmi_lib *lib, const char *id, const char *name, void *dst,
                     size_t size)
{
    char err[256];
    if (rrr_fmi_lib_sym(lib, name, dst, size, err, sizeof err) != 0) {
        fprintf(stderr, "%s: %s\n", id, err);
        exit(2);
    }
}

/* ---- an FMI 3.0 FMU loaded like an importer does --------------------------------------------- */

/* Every function of fmi3Functions.h (RRR_FMI3_FUNCTIONS): each must be exported. */
#define FMI3_FUNCTIONS(X) RRR_FMI3_FUNCTIONS(X)

typedef struct xml_var {
    char name[RRR_FMI_NAME_MAX];
    fmi3ValueReference vr;
    int is_bool;            /* <Boolean> (else <Float64>) */
    const rrr_fmi_var *var; /* the importer's entry (start, derivative, nominal) */
} xml_var;

/* Attribute attr of v's element: 0 when found. */
static int var_attr(const xml_var *v, const char *attr, char *out, size_t n)
{
    return rrr_fmi_var_attr(v->var, attr, out, n) != RRR_FMI_OK;
}

typedef struct fmu3 {
    rrr_fmi_lib lib;
    rrr_fmi_md md;
    char id[64];
    char token[128];
    int is_plant;
    xml_var vars[MAX_VARS];
    size_t nvars;
    size_t n_other_elements;         /* variables of types other than Float64 and Boolean */
    size_t nx;                       /* continuous states (<ContinuousStateDerivative> elements) */
    size_t x_var[MAX_STATES];        /* index in vars of state i */
    size_t dx_var[MAX_STATES];       /* index in vars of its derivative */
    double nominal[MAX_STATES];      /* nominal of state i (XML, default 1) */
    fmi3ValueReference input_vr;     /* the first input */
    fmi3ValueReference time_vr;      /* the independent variable */
#define DECLARE(F) fmi3##F##TYPE *F;
    FMI3_FUNCTIONS(DECLARE)
#undef DECLARE
} fmu3;

static const xml_var *find_var(const fmu3 *api, const char *name)
{
    for (size_t i = 0; i < api->nvars; ++i) {
        if (strcmp(api->vars[i].name, name) == 0) {
            return &api->vars[i];
        }
    }
    return NULL;
}

/* Value reference of a variable from the XML; aborts the run if it is missing. */
static fmi3ValueReference vr_of(const fmu3 *api, const char *name)
{
    const xml_var *v = find_var(api, name);
    if (v == NULL) {
        fprintf(stderr, "%s: no variable %s in modelDescription.xml\n", api->id, name);
        exit(2);
    }
    return v->vr;
}

static int parse_vars(fmu3 *api)
{
    for (size_t i = 0; i < api->md.nvars; ++i) {
        const rrr_fmi_var *iv = &api->md.vars[i];
        const int f64 = strcmp(iv->type, "Float64") == 0;
        const int b = strcmp(iv->type, "Boolean") == 0;
        if (!f64 && !b) {
            api->n_other_elements++;
            continue;
        }
        if (api->nvars == MAX_VARS) {
            return 1;
        }
        xml_var *v = &api->vars[api->nvars++];
        v->is_bool = b;
        v->var = iv;
        v->vr = (fmi3ValueReference)iv->vr;
        snprintf(v->name, sizeof v->name, "%s", iv->name);
        if (strcmp(iv->causality, "input") == 0 && api->input_vr == (fmi3ValueReference)-1) {
            api->input_vr = v->vr;
        }
        if (strcmp(iv->causality, "independent") == 0) {
            api->time_vr = v->vr;
        }
    }
    return 0;
}

static const xml_var *var_by_vr(const fmu3 *api, fmi3ValueReference vr)
{
    for (size_t i = 0; i < api->nvars; ++i) {
        if (api->vars[i].vr == vr) {
            return &api->vars[i];
        }
    }
    return NULL;
}

/* The continuous states: <ModelStructure><ContinuousStateDerivative valueReference=d>, in order;
 * variable d has derivative="x", the state. */
static int parse_states(fmu3 *api)
{
    const char *end = api->md.xml + api->md.len;
    rrr_fmi_tag t;
    if (rrr_fmi_find_tag(api->md.xml, end, "ModelStructure", &t) != RRR_FMI_OK) {
        return 0;
    }
    char buf[32];
    while (rrr_fmi_find_tag(t.end, end, "ContinuousStateDerivative", &t) == RRR_FMI_OK) {
        if (api->nx == MAX_STATES || rrr_fmi_attr(&t, "valueReference", buf, sizeof buf) != 0) {
            return 1;
        }
        const xml_var *d = var_by_vr(api, (fmi3ValueReference)strtoul(buf, NULL, 10));
        if (d == NULL || var_attr(d, "derivative", buf, sizeof buf) != 0) {
            return 1;
        }
        const xml_var *x = var_by_vr(api, (fmi3ValueReference)strtoul(buf, NULL, 10));
        if (x == NULL) {
            return 1;
        }
        char nominal[32];
        const int has_nominal = var_attr(x, "nominal", nominal, sizeof nominal) == 0;
        api->nominal[api->nx] = has_nominal ? strtod(nominal, NULL) : 1.0;
        api->x_var[api->nx] = (size_t)(x - api->vars);
        api->dx_var[api->nx] = (size_t)(d - api->vars);
        api->nx++;
    }
    return 0;
}

static int fmu3_load(fmu3 *api, const char *dir)
{
    memset(api, 0, sizeof *api);
    api->input_vr = (fmi3ValueReference)-1;
    api->time_vr = (fmi3ValueReference)-1;
    if (fh_open(&api->md, &api->lib, dir, 3, api->id, api->token) != 0) {
        return 1;
    }
    if (strcmp(api->md.me_id, api->md.id) != 0 || parse_vars(api) != 0 || parse_states(api) != 0 ||
        api->input_vr == (fmi3ValueReference)-1 || api->time_vr == (fmi3ValueReference)-1) {
        fprintf(stderr, "%s: not an FMI 3.0 modelDescription.xml with Model Exchange and "
                        "Co-Simulation of one modelIdentifier, inputs and a time variable\n",
                dir);
        return 1;
    }
    api->is_plant = strcmp(api->id, "rrr_plant") == 0;
#define LOAD(F) load_sym(&api->lib, api->id, "fmi3" #F, &api->F, sizeof api->F);
    FMI3_FUNCTIONS(LOAD)
#undef LOAD
    return 0;
}

static void fmu3_unload(fmu3 *api)
{
    fh_close(&api->md, &api->lib);
    memset(api, 0, sizeof *api);
}

/* ---- the FMI 2.0 build, for comparisons ------------------------------------------------------ */

typedef struct fmu2 {
    rrr_fmi_lib lib;
    rrr_fmi_md md;
    char id[64];
    char guid[128];
    fmi2InstantiateTYPE *Instantiate;
    fmi2FreeInstanceTYPE *FreeInstance;
    fmi2SetupExperimentTYPE *SetupExperiment;
    fmi2EnterInitializationModeTYPE *EnterInitializationMode;
    fmi2ExitInitializationModeTYPE *ExitInitializationMode;
    fmi2TerminateTYPE *Terminate;
    fmi2GetRealTYPE *GetReal;
    fmi2SetRealTYPE *SetReal;
    fmi2DoStepTYPE *DoStep;
    fmi2GetFMUstateTYPE *GetFMUstate;
    fmi2FreeFMUstateTYPE *FreeFMUstate;
    fmi2SerializedFMUstateSizeTYPE *SerializedFMUstateSize;
    fmi2SerializeFMUstateTYPE *SerializeFMUstate;
} fmu2;

static int fmu2_load(fmu2 *api, const char *dir)
{
    memset(api, 0, sizeof *api);
    if (fh_open(&api->md, &api->lib, dir, 2, api->id, api->guid) != 0) {
        return 1;
    }
#define LOAD2(F) load_sym(&api->lib, api->id, "fmi2" #F, &api->F, sizeof api->F);
    LOAD2(Instantiate) LOAD2(FreeInstance) LOAD2(SetupExperiment) LOAD2(EnterInitializationMode)
    LOAD2(ExitInitializationMode) LOAD2(Terminate) LOAD2(GetReal) LOAD2(SetReal) LOAD2(DoStep)
    LOAD2(GetFMUstate) LOAD2(FreeFMUstate) LOAD2(SerializedFMUstateSize) LOAD2(SerializeFMUstate)
#undef LOAD2
    return 0;
}

static void fmu2_unload(fmu2 *api)
{
    fh_close(&api->md, &api->lib);
    memset(api, 0, sizeof *api);
}

static fmi2ValueReference vr2_of(const fmu2 *api, const char *name)
{
    return fh_md_vr(&api->md, name);
}

static int fmi2_errors = 0;

static void logger2(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status,
                    fmi2String category, fmi2String message, ...)
{
    (void)env;
    (void)category;
    if (status >= fmi2Error) {
        char buf[1024];
        va_list ap;
        va_start(ap, message);
        vsnprintf(buf, sizeof buf, message, ap);
        va_end(ap);
        fprintf(stderr, "  [FMI 2 %s] %s\n", instance ? instance : "?", buf);
        ++fmi2_errors;
    }
}

static fmi2Component inst2_new(const fmu2 *api, const char *name)
{
    static const fmi2CallbackFunctions cb = {logger2, calloc, free, NULL, NULL};
    fmi2Component c = api->Instantiate(name, fmi2CoSimulation, api->guid, "", &cb, fmi2False,
                                       fmi2False);
    CHECK(c != NULL);
    return c;
}

/* ---- FMI 3 instances with their own log sink ------------------------------------------------- */

typedef fh_log_sink log_sink;

static int n_fmi2_mentions = 0;      /* FMI 3 messages that name an FMI 2 function */
static char first_fmi2_mention[1024];

static void logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category,
                   fmi3String message)
{
    log_sink *s = env;
    if (s == NULL) {
        fprintf(stderr, "logMessage called with the wrong instanceEnvironment\n");
        rrr_test_failures++;
        return;
    }
    snprintf(s->last, sizeof s->last, "%s", message != NULL ? message : "(null)");
    fh_log_record(s, (int)status, category);
    if (strstr(s->last, "fmi2") != NULL && n_fmi2_mentions++ == 0) {
        memcpy(first_fmi2_mention, s->last, sizeof first_fmi2_mention);
    }
    if (getenv("RRR_HARNESS_VERBOSE") != NULL) {
        fprintf(stderr, "  [%d %s] %s\n", (int)status, category ? category : "?", s->last);
    }
}

typedef struct inst {
    const fmu3 *api;
    fmi3Instance c;
    int me; /* Model Exchange (else Co-Simulation) */
    log_sink log;
} inst;

static void log_clear(inst *x)
{
    memset(&x->log, 0, sizeof x->log);
}

static fmi3Instance instantiate(const fmu3 *api, const char *name, int me, const char *token,
                                bool logging_on, log_sink *sink)
{
    if (me) {
        return api->InstantiateModelExchange(name, token, NULL, false, logging_on, sink, logger);
    }
    return api->InstantiateCoSimulation(name, token, NULL, false, logging_on, false, false, NULL, 0,
                                        sink, logger, NULL);
}

/* Instantiate (x must not move afterwards: its log sink is the instanceEnvironment). */
static int inst_new(inst *x, const fmu3 *api, const char *name, int me)
{
    memset(x, 0, sizeof *x);
    x->api = api;
    x->me = me;
    x->c = instantiate(api, name, me, api->token, false, &x->log);
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

static fmi3Status enter_init(inst *x)
{
    return x->api->EnterInitializationMode(x->c, false, 0.0, 0.0, false, 0.0);
}

static fmi3Status set1(inst *x, const char *name, double v)
{
    const fmi3ValueReference vr = vr_of(x->api, name);
    return x->api->SetFloat64(x->c, &vr, 1, &v, 1);
}

static fmi3Status set_bool(inst *x, const char *name, fmi3Boolean v)
{
    const fmi3ValueReference vr = vr_of(x->api, name);
    return x->api->SetBoolean(x->c, &vr, 1, &v, 1);
}

static double get1(inst *x, const char *name)
{
    const fmi3ValueReference vr = vr_of(x->api, name);
    double v = (double)NAN;
    CHECK(x->api->GetFloat64(x->c, &vr, 1, &v, 1) == fmi3OK);
    return v;
}

static fmi3Status do_step(inst *x, double t, double h, double *last)
{
    fmi3Boolean event = true, terminate = true, early = true;
    double last_ = -1.0;
    const fmi3Status s = x->api->DoStep(x->c, t, h, true, &event, &terminate, &early, &last_);
    if (s == fmi3OK || s == fmi3Discard) {
        CHECK(!event && !terminate && !early);
    }
    if (last != NULL) {
        *last = last_;
    }
    return s;
}

/* ---- the adapter of fmu_harness_common.c: the FMI 3.0 calls on an inst ----------------------- */

static const char *const interface_names[2] = {"Co-Simulation", "Model Exchange"};


#define A3(x) (((const inst *)(x))->api)
#define C3(x) (((const inst *)(x))->c)

static int drive_to_init(inst *x);
static int drive_to_step(inst *x);
static void check_stepping(void *x, int discarded, const char *where);

static fh_log_sink *a3_log(void *x) { return &((inst *)x)->log; }
static const char *a3_where(const void *x) { return interface_names[((const inst *)x)->me]; }
static const rrr_fmi_md *a3_md(const void *api) { return &((const fmu3 *)api)->md; }
static const char *a3_id(const void *api) { return ((const fmu3 *)api)->id; }
static const void *a3_api(const void *x) { return A3(x); }
static int a3_drive_init(void *x) { return drive_to_init(x); }
static int a3_drive_step(void *x) { return drive_to_step(x); }
static int a3_terminate(void *x) { return (int)A3(x)->Terminate(C3(x)); }
static int a3_reset(void *x) { return (int)A3(x)->Reset(C3(x)); }
static int a3_enter_init(void *x) { return (int)enter_init(x); }
static int a3_exit_init(void *x) { return (int)A3(x)->ExitInitializationMode(C3(x)); }

static int a3_get_real(void *x, const unsigned int *vr, size_t n, double *v)
{
    return (int)A3(x)->GetFloat64(C3(x), vr, n, v, n);
}

static int a3_set_real(void *x, const unsigned int *vr, size_t n, const double *v)
{
    return (int)A3(x)->SetFloat64(C3(x), vr, n, v, n);
}

static int a3_get_bool(void *x, unsigned int vr, int *v)
{
    fmi3Boolean b = *v != 0;
    const fmi3Status s = A3(x)->GetBoolean(C3(x), &vr, 1, &b, 1);
    *v = b;
    return (int)s;
}

static int a3_set_bool(void *x, unsigned int vr, int v)
{
    const fmi3Boolean b = v != 0;
    return (int)A3(x)->SetBoolean(C3(x), &vr, 1, &b, 1);
}

static int a3_do_step(void *x, double t, double h, double *last_time)
{
    return (int)do_step(x, t, h, last_time);
}

static void *a3_new_cs(const void *api, const char *name)
{
    inst *x = malloc(sizeof *x);
    if (x != NULL && inst_new(x, api, name, 0) != 0) {
        free(x);
        return NULL;
    }
    return x;
}

static void a3_del(void *x)
{
    if (x == NULL) {
        return;
    }
    inst_free(x);
    free(x);
}

static int a3_get_state(void *x, void **s) { return (int)A3(x)->GetFMUState(C3(x), s); }
static int a3_set_state(void *x, void *s) { return (int)A3(x)->SetFMUState(C3(x), s); }
static int a3_free_state(void *x, void **s) { return (int)A3(x)->FreeFMUState(C3(x), s); }

static int a3_state_size(void *x, void *s, size_t *n)
{
    return (int)A3(x)->SerializedFMUStateSize(C3(x), s, n);
}

static int a3_serialize(void *x, void *s, unsigned char *buf, size_t n)
{
    return (int)A3(x)->SerializeFMUState(C3(x), s, buf, n);
}

static int a3_deserialize(void *x, const unsigned char *buf, size_t n, void **s)
{
    return (int)A3(x)->DeserializeFMUState(C3(x), buf, n, s);
}

static const fh_ops ops3 = {
    .fmi = "fmi3", .set_real_name = "fmi3SetFloat64", .step_reports_time = 1, .setup = NULL,
    .drive_step = a3_drive_step, .check_stepping = check_stepping, .set_bool = a3_set_bool,
    .terminate = a3_terminate, .reset = a3_reset, .api = a3_api, .id = a3_id,
    .md = a3_md, .where = a3_where, .log = a3_log, .new_cs = a3_new_cs, .del = a3_del,
    .drive_init = a3_drive_init, .get_real = a3_get_real, .set_real = a3_set_real,
    .get_bool = a3_get_bool, .enter_init = a3_enter_init, .exit_init = a3_exit_init,
    .do_step = a3_do_step, .get_state = a3_get_state, .set_state = a3_set_state,
    .free_state = a3_free_state, .state_size = a3_state_size, .serialize = a3_serialize,
    .deserialize = a3_deserialize,
};

static void vrs3(const fmu3 *api, const char *base, fmi3ValueReference vr[3])
{
    fh_vrs3(&ops3, api, base, vr);
}

/* ---- the XML --------------------------------------------------------------------------------- */

/* Same names, types and value references as the FMI 2 build, one token, the states. */
static void test_xml(const fmu3 *api, const fmu2 *v2)
{
    CHECK(api->n_other_elements == 0); /* only Float64 and Boolean variables */
    CHECK(api->nx == (api->is_plant ? 6u : 0u));
    for (size_t i = 0; i < api->nx; ++i) {
        /* the plant's states are q and qd, their derivatives qd and qdd */
        const char *x = api->vars[api->x_var[i]].name;
        const char *dx = api->vars[api->dx_var[i]].name;
        char want_x[16], want_dx[16];
        snprintf(want_x, sizeof want_x, "%s[%zu]", i < 3 ? "q" : "qd", i % 3 + 1);
        snprintf(want_dx, sizeof want_dx, "%s[%zu]", i < 3 ? "qd" : "qdd", i % 3 + 1);
        CHECK(strcmp(x, want_x) == 0 && strcmp(dx, want_dx) == 0);
        CHECK(api->nominal[i] > 0.0);
    }
    if (v2 == NULL) {
        return;
    }
    CHECK(strcmp(api->id, v2->id) == 0);
    CHECK(strcmp(api->token, v2->guid) == 0); /* the token names the model, not the binary */
    CHECK(v2->md.nvars + 1 == api->nvars); /* FMI 3 adds the independent variable */
    for (size_t i = 0; i < api->nvars; ++i) {
        const xml_var *v = &api->vars[i];
        if (v->vr == api->time_vr) {
            continue;
        }
        const rrr_fmi_var *e2 = rrr_fmi_md_var(&v2->md, v->name);
        if (e2 == NULL || e2->vr != v->vr ||
            strcmp(e2->type, v->is_bool ? "Boolean" : "Real") != 0) {
            fprintf(stderr, "%s: %s (vr %u) differs between the FMI 2 and FMI 3 XML\n", api->id,
                    v->name, (unsigned)v->vr);
            rrr_test_failures++;
        }
    }
}

/* ---- the allowed states of every function, from the FMI 3.0 standard ----------------------------
 *
 * States this harness reaches: Instantiated, InitializationMode, EventMode and ContinuousTimeMode
 * (Model Exchange), StepMode and StepDiscarded (Co-Simulation; StepDiscarded: the plant only),
 * Terminated, and Error (exitInitializationMode failed on an invalid parameter). FMI 3.0 (2.2.3):
 * after fmi3Error the instance may still be reset, freed, restored, and (2.3, Terminated) read
 * "for debugging purposes": Error allows what Terminated allows.
 *
 * Per state, the "Allowed Function Calls" of the standard:
 *  - every state after instantiation (super state FMUStateSetable): fmi3SetDebugLogging,
 *    fmi3Reset, fmi3FreeInstance, fmi3Get/Set/FreeFMUState, fmi3SerializedFMUStateSize,
 *    fmi3Serialize/DeserializeFMUState; fmi3Get{VariableType} (Instantiated: start values);
 *    fmi3GetNumberOfVariableDependencies and fmi3GetVariableDependencies (not bound to a state);
 *  - Instantiated: fmi3Set{VariableType} (initial exact/approx), fmi3EnterInitializationMode,
 *    fmi3EnterConfigurationMode, and (Model Exchange) fmi3GetNumberOfContinuousStates and
 *    fmi3GetNumberOfEventIndicators;
 *  - InitializationMode: fmi3Set{VariableType} (initial exact, inputs), fmi3ExitInitializationMode,
 *    fmi3GetDirectionalDerivative, fmi3GetAdjointDerivative, the clock intervals and shifts, and
 *    (Model Exchange) fmi3GetContinuousStateDerivatives, fmi3GetContinuousStates,
 *    fmi3GetNominalsOfContinuousStates, fmi3GetEventIndicators;
 *  - super state Initialized: fmi3Terminate;
 *  - EventMode (Model Exchange here: eventModeUsed must be false in Co-Simulation): fmi3Set
 *    (inputs, tunable parameters), fmi3UpdateDiscreteStates, fmi3EnterContinuousTimeMode,
 *    fmi3EnterConfigurationMode, fmi3GetContinuousStates, fmi3GetContinuousStateDerivatives,
 *    fmi3GetEventIndicators, fmi3GetNominalsOfContinuousStates, fmi3GetNumberOfContinuousStates,
 *    fmi3GetNumberOfEventIndicators, fmi3GetDirectionalDerivative, fmi3GetAdjointDerivative,
 *    fmi3GetClock/SetClock, the clock intervals; (no fmi3SetTime: the time of an event is fixed);
 *  - ContinuousTimeMode: fmi3Set (continuous-time inputs only: Float64), fmi3SetTime,
 *    fmi3SetContinuousStates, fmi3GetContinuousStateDerivatives, fmi3GetEventIndicators,
 *    fmi3GetContinuousStates, fmi3GetNominalsOfContinuousStates, fmi3CompletedIntegratorStep,
 *    fmi3EnterEventMode, fmi3GetDirectionalDerivative, fmi3GetAdjointDerivative;
 *  - StepMode: fmi3Set (inputs, tunable parameters), fmi3DoStep, fmi3GetOutputDerivatives,
 *    fmi3GetDirectionalDerivative, fmi3GetAdjointDerivative, fmi3EnterConfigurationMode,
 *    fmi3EvaluateDiscreteStates;
 *  - StepDiscarded: fmi3Terminate, getters (fmi3GetOutputDerivatives, directional and adjoint
 *    derivatives included) and the FMUStateSetable functions;
 *  - Terminated (and Error): getters, fmi3GetContinuousStateDerivatives, fmi3GetContinuousStates,
 *    fmi3GetNominalsOfContinuousStates, fmi3GetEventIndicators, fmi3GetDirectionalDerivative,
 *    fmi3GetAdjointDerivative, fmi3GetOutputDerivatives ("not allowed in Model Exchange").
 * The Model Exchange functions "can only be called in Model Exchange" (no Co-Simulation state
 * allows them), fmi3DoStep, fmi3EnterStepMode and fmi3GetOutputDerivatives only in Co-Simulation;
 * fmi3EnterStepMode needs event mode, fmi3ExitConfigurationMode a configuration mode and
 * fmi3ActivateModelPartition Scheduled Execution: never allowed here.
 * "Allowed" is about the call sequence only: a capability the XML does not declare (directional
 * derivatives, configuration mode, ...) is refused as "not provided" (test_not_provided).
 * Two deliberate departures, where the FMU is as lenient as the modelica Reference-FMUs (which
 * importers are tested against) and the call changes no state: fmi3SetTime is also accepted in
 * EventMode (as FMI 2.0 allows), and the two fmi3GetNumberOf... queries in every state of a Model
 * Exchange instance. The table below encodes the FMU's promise, these two included.
 */

enum { ST_INST, ST_INIT, ST_EVENT, ST_CONT, ST_STEP, ST_DISCARDED, ST_TERM, ST_ERR, ST_COUNT };
static const char *const state_names[ST_COUNT] = {
    "Instantiated", "InitializationMode", "EventMode", "ContinuousTimeMode",
    "StepMode",     "StepDiscarded",      "Terminated", "Error"};
#define S_I (1u << ST_INST)
#define S_IN (1u << ST_INIT)
#define S_EM (1u << ST_EVENT)
#define S_CT (1u << ST_CONT)
#define S_SM (1u << ST_STEP)
#define S_SD (1u << ST_DISCARDED)
#define S_T (1u << ST_TERM)
#define S_E (1u << ST_ERR)
#define S_ALL (S_I | S_IN | S_EM | S_CT | S_SM | S_SD | S_T | S_E)
#define S_ME_EVAL (S_IN | S_EM | S_CT | S_T | S_E) /* derivatives, states, nominals, indicators */


/* 1 when an instance of this FMU and interface type can be brought into state st. */
static int reachable(const fmu3 *api, int me, int st)
{
    switch (st) {
    case ST_EVENT:
    case ST_CONT:
        return me;
    case ST_STEP:
        return !me;
    case ST_DISCARDED:
        return !me && api->is_plant; /* the controller never discards a step */
    default:
        return 1;
    }
}

/* Put a fresh instance into a reachable state. */
static void drive(inst *x, int st)
{
    const fmu3 *a = x->api;
    if (st == ST_INST) {
        return;
    }
    if (st == ST_ERR) {
        /* an invalid parameter makes exitInitializationMode fail */
        CHECK(set1(x, a->is_plant ? "a2" : "kp[1]", -1.0) == fmi3OK);
    }
    if (st == ST_DISCARDED) {
        /* the step below cannot be taken with the fixed-step RK4 (the adaptive default would
         * integrate it) */
        CHECK(set_bool(x, "adaptive", false) == fmi3OK);
    }
    CHECK(enter_init(x) == fmi3OK);
    if (st == ST_INIT) {
        return;
    }
    if (st == ST_ERR) {
        CHECK(a->ExitInitializationMode(x->c) == fmi3Error);
        return;
    }
    CHECK(a->ExitInitializationMode(x->c) == fmi3OK);
    if (x->me) {
        if (st == ST_EVENT) {
            return;
        }
        CHECK(a->EnterContinuousTimeMode(x->c) == fmi3OK);
    } else {
        CHECK(do_step(x, 0.0, H, NULL) == fmi3OK);
        if (st == ST_DISCARDED) {
            /* fixed step: 1e4 s at h_int = 1e-4 s needs 1e8 substeps: doStep discards */
            CHECK(do_step(x, H, 1e4, NULL) == fmi3Discard);
        }
    }
    if (st == ST_TERM) {
        CHECK(a->Terminate(x->c) == fmi3OK);
    }
}

/* drive(x, ST_INIT), drive(x, ST_STEP): 1 when one of its checks failed */
static int drive_to_init(inst *x)
{
    const int failures = rrr_test_failures;
    drive(x, ST_INIT);
    return rrr_test_failures != failures;
}

static int drive_to_step(inst *x)
{
    const int failures = rrr_test_failures;
    drive(x, ST_STEP);
    return rrr_test_failures != failures;
}

typedef fmi3Status (*caller)(inst *x);

#define CALLER(NAME, ...) FH_CALLER(fmi3Status, fmu3, NAME, __VA_ARGS__)

/* The arguments are valid: only the state (or a missing capability) makes a call fail. */
CALLER(SetDebugLogging, return a->SetDebugLogging(x->c, false, 0, NULL);)
CALLER(EnterInitializationMode,
       return a->EnterInitializationMode(x->c, false, 0.0, 0.0, false, 0.0);)
CALLER(ExitInitializationMode, return a->ExitInitializationMode(x->c);)
CALLER(EnterEventMode, return a->EnterEventMode(x->c);)
CALLER(Terminate, return a->Terminate(x->c);)
CALLER(Reset, return a->Reset(x->c);)
CALLER(GetFloat64, const fmi3ValueReference vr = a->time_vr; fmi3Float64 v = 0.0;
       return a->GetFloat64(x->c, &vr, 1, &v, 1);)
CALLER(GetBoolean, return a->GetBoolean(x->c, NULL, 0, NULL, 0);)
#define EMPTY_CALL(F) CALLER(F, return a->F(x->c, NULL, 0, NULL, 0);)
EMPTY_CALL(GetFloat32)
EMPTY_CALL(GetInt8)
EMPTY_CALL(GetUInt8)
EMPTY_CALL(GetInt16)
EMPTY_CALL(GetUInt16)
EMPTY_CALL(GetInt32)
EMPTY_CALL(GetUInt32)
EMPTY_CALL(GetInt64)
EMPTY_CALL(GetUInt64)
EMPTY_CALL(GetString)
EMPTY_CALL(SetFloat32)
EMPTY_CALL(SetInt8)
EMPTY_CALL(SetUInt8)
EMPTY_CALL(SetInt16)
EMPTY_CALL(SetUInt16)
EMPTY_CALL(SetInt32)
EMPTY_CALL(SetUInt32)
EMPTY_CALL(SetInt64)
EMPTY_CALL(SetUInt64)
EMPTY_CALL(SetString)
EMPTY_CALL(SetBoolean)
CALLER(GetBinary, return a->GetBinary(x->c, NULL, 0, NULL, NULL, 0);)
CALLER(SetBinary, return a->SetBinary(x->c, NULL, 0, NULL, NULL, 0);)
CALLER(GetClock, return a->GetClock(x->c, NULL, 0, NULL);)
CALLER(SetClock, return a->SetClock(x->c, NULL, 0, NULL);)
CALLER(SetFloat64, const fmi3ValueReference vr = a->input_vr; const fmi3Float64 v = 0.0;
       return a->SetFloat64(x->c, &vr, 1, &v, 1);)
CALLER(GetNumberOfVariableDependencies, size_t n = 0;
       return a->GetNumberOfVariableDependencies(x->c, a->input_vr, &n);)
CALLER(GetVariableDependencies,
       return a->GetVariableDependencies(x->c, a->input_vr, NULL, NULL, NULL, NULL, 0);)
CALLER(GetFMUState, fmi3FMUState s = NULL; const fmi3Status st = a->GetFMUState(x->c, &s);
       if (s != NULL) { a->FreeFMUState(x->c, &s); } return st;)
CALLER(SetFMUState, return a->SetFMUState(x->c, NULL);)
CALLER(FreeFMUState, fmi3FMUState s = NULL; return a->FreeFMUState(x->c, &s);)
CALLER(SerializedFMUStateSize, size_t n = 0; return a->SerializedFMUStateSize(x->c, NULL, &n);)
CALLER(SerializeFMUState, fmi3Byte b[8]; return a->SerializeFMUState(x->c, NULL, b, sizeof b);)
CALLER(DeserializeFMUState, const fmi3Byte b[8] = {0}; fmi3FMUState s = NULL;
       return a->DeserializeFMUState(x->c, b, sizeof b, &s);)
CALLER(GetDirectionalDerivative,
       return a->GetDirectionalDerivative(x->c, NULL, 0, NULL, 0, NULL, 0, NULL, 0);)
CALLER(GetAdjointDerivative,
       return a->GetAdjointDerivative(x->c, NULL, 0, NULL, 0, NULL, 0, NULL, 0);)
CALLER(EnterConfigurationMode, return a->EnterConfigurationMode(x->c);)
CALLER(ExitConfigurationMode, return a->ExitConfigurationMode(x->c);)
CALLER(GetIntervalDecimal, return a->GetIntervalDecimal(x->c, NULL, 0, NULL, NULL);)
CALLER(GetIntervalFraction, return a->GetIntervalFraction(x->c, NULL, 0, NULL, NULL, NULL);)
CALLER(GetShiftDecimal, return a->GetShiftDecimal(x->c, NULL, 0, NULL);)
CALLER(GetShiftFraction, return a->GetShiftFraction(x->c, NULL, 0, NULL, NULL);)
CALLER(SetIntervalDecimal, return a->SetIntervalDecimal(x->c, NULL, 0, NULL);)
CALLER(SetIntervalFraction, return a->SetIntervalFraction(x->c, NULL, 0, NULL, NULL);)
CALLER(SetShiftDecimal, return a->SetShiftDecimal(x->c, NULL, 0, NULL);)
CALLER(SetShiftFraction, return a->SetShiftFraction(x->c, NULL, 0, NULL, NULL);)
CALLER(EvaluateDiscreteStates, return a->EvaluateDiscreteStates(x->c);)
CALLER(UpdateDiscreteStates, fmi3Boolean b[5]; fmi3Float64 t = 0.0;
       return a->UpdateDiscreteStates(x->c, &b[0], &b[1], &b[2], &b[3], &b[4], &t);)
CALLER(EnterContinuousTimeMode, return a->EnterContinuousTimeMode(x->c);)
CALLER(CompletedIntegratorStep, fmi3Boolean e = false, t = false;
       return a->CompletedIntegratorStep(x->c, true, &e, &t);)
CALLER(SetTime, return a->SetTime(x->c, 0.0);)
CALLER(SetContinuousStates, const fmi3Float64 v[MAX_STATES] = {0};
       return a->SetContinuousStates(x->c, v, a->nx);)
CALLER(GetContinuousStateDerivatives, fmi3Float64 v[MAX_STATES];
       return a->GetContinuousStateDerivatives(x->c, v, a->nx);)
CALLER(GetEventIndicators, return a->GetEventIndicators(x->c, NULL, 0);)
CALLER(GetContinuousStates, fmi3Float64 v[MAX_STATES];
       return a->GetContinuousStates(x->c, v, a->nx);)
CALLER(GetNominalsOfContinuousStates, fmi3Float64 v[MAX_STATES];
       return a->GetNominalsOfContinuousStates(x->c, v, a->nx);)
CALLER(GetNumberOfEventIndicators, size_t n = 0; return a->GetNumberOfEventIndicators(x->c, &n);)
CALLER(GetNumberOfContinuousStates, size_t n = 0;
       return a->GetNumberOfContinuousStates(x->c, &n);)
CALLER(EnterStepMode, return a->EnterStepMode(x->c);)
CALLER(GetOutputDerivatives, return a->GetOutputDerivatives(x->c, NULL, 0, NULL, NULL, 0);)
CALLER(DoStep, fmi3Boolean b[3]; fmi3Float64 t = 0.0;
       return a->DoStep(x->c, 0.0, H, true, &b[0], &b[1], &b[2], &t);)
CALLER(ActivateModelPartition, return a->ActivateModelPartition(x->c, 0, 0.0);)

typedef struct fn_entry {
    const char *name;
    unsigned allowed[2]; /* states, Co-Simulation and Model Exchange */
    caller call;
} fn_entry;

#define FN(F, CS, ME) {"fmi3" #F, {(CS), (ME)}, call_##F}
#define GETTER(F) FN(F, S_ALL, S_ALL)
#define SETTER(F) FN(F, S_I | S_IN | S_SM, S_I | S_IN | S_EM)
#define CLOCK_TIMING(F) FN(F, S_IN, S_IN | S_EM)

static const fn_entry functions[] = {
    FN(SetDebugLogging, S_ALL, S_ALL),
    FN(EnterInitializationMode, S_I, S_I),
    FN(ExitInitializationMode, S_IN, S_IN),
    FN(EnterEventMode, 0u, S_CT),
    FN(Terminate, S_SM | S_SD, S_EM | S_CT),
    FN(Reset, S_ALL, S_ALL),
    GETTER(GetFloat32),
    GETTER(GetFloat64),
    GETTER(GetInt8),
    GETTER(GetUInt8),
    GETTER(GetInt16),
    GETTER(GetUInt16),
    GETTER(GetInt32),
    GETTER(GetUInt32),
    GETTER(GetInt64),
    GETTER(GetUInt64),
    GETTER(GetBoolean),
    GETTER(GetString),
    GETTER(GetBinary),
    FN(GetClock, 0u, S_EM),
    FN(SetFloat32, S_I | S_IN | S_SM, S_I | S_IN | S_EM | S_CT),
    FN(SetFloat64, S_I | S_IN | S_SM, S_I | S_IN | S_EM | S_CT),
    SETTER(SetInt8),
    SETTER(SetUInt8),
    SETTER(SetInt16),
    SETTER(SetUInt16),
    SETTER(SetInt32),
    SETTER(SetUInt32),
    SETTER(SetInt64),
    SETTER(SetUInt64),
    SETTER(SetBoolean),
    SETTER(SetString),
    SETTER(SetBinary),
    FN(SetClock, 0u, S_EM),
    FN(GetNumberOfVariableDependencies, S_ALL, S_ALL),
    FN(GetVariableDependencies, S_ALL, S_ALL),
    FN(GetFMUState, S_ALL, S_ALL),
    FN(SetFMUState, S_ALL, S_ALL),
    FN(FreeFMUState, S_ALL, S_ALL),
    FN(SerializedFMUStateSize, S_ALL, S_ALL),
    FN(SerializeFMUState, S_ALL, S_ALL),
    FN(DeserializeFMUState, S_ALL, S_ALL),
    FN(GetDirectionalDerivative, S_IN | S_SM | S_SD | S_T | S_E, S_ME_EVAL),
    FN(GetAdjointDerivative, S_IN | S_SM | S_SD | S_T | S_E, S_ME_EVAL),
    FN(EnterConfigurationMode, S_I | S_SM, S_I | S_EM),
    FN(ExitConfigurationMode, 0u, 0u),
    CLOCK_TIMING(GetIntervalDecimal),
    CLOCK_TIMING(GetIntervalFraction),
    CLOCK_TIMING(GetShiftDecimal),
    CLOCK_TIMING(GetShiftFraction),
    CLOCK_TIMING(SetIntervalDecimal),
    CLOCK_TIMING(SetIntervalFraction),
    CLOCK_TIMING(SetShiftDecimal),
    CLOCK_TIMING(SetShiftFraction),
    FN(EvaluateDiscreteStates, S_SM, S_EM),
    FN(UpdateDiscreteStates, 0u, S_EM),
    FN(EnterContinuousTimeMode, 0u, S_EM),
    FN(CompletedIntegratorStep, 0u, S_CT),
    FN(SetTime, 0u, S_EM | S_CT), /* lenient: also EventMode (see below) */
    FN(SetContinuousStates, 0u, S_CT),
    FN(GetContinuousStateDerivatives, 0u, S_ME_EVAL),
    FN(GetEventIndicators, 0u, S_ME_EVAL),
    FN(GetContinuousStates, 0u, S_ME_EVAL),
    FN(GetNominalsOfContinuousStates, 0u, S_ME_EVAL),
    FN(GetNumberOfEventIndicators, 0u, S_ALL), /* lenient: every state (see below) */
    FN(GetNumberOfContinuousStates, 0u, S_ALL),
    FN(EnterStepMode, 0u, 0u),
    FN(GetOutputDerivatives, S_SM | S_SD | S_T | S_E, 0u),
    FN(DoStep, S_SM, 0u),
    FN(ActivateModelPartition, 0u, 0u),
};
#define N_FUNCTIONS (sizeof functions / sizeof functions[0])

static const fn_entry *find_fn(const char *name)
{
    for (size_t f = 0; f < N_FUNCTIONS; ++f) {
        if (strcmp(functions[f].name, name) == 0) {
            return &functions[f];
        }
    }
    fprintf(stderr, "no function %s in the table\n", name);
    exit(2);
}

static int allowed(const char *fn, int me, int st)
{
    return (find_fn(fn)->allowed[me ? 1 : 0] & (1u << st)) != 0u;
}

/* ---- the state of an instance, seen from outside ------------------------------------------------
 * Side-effect-free probes that are accepted in some states and not in others, plus the state the
 * FMU names when it refuses fmi3ExitConfigurationMode (allowed in no state it can reach).
 */
static const char *const probes[] = {
    "fmi3SetFloat64",       "fmi3SetBoolean",
    "fmi3UpdateDiscreteStates", "fmi3CompletedIntegratorStep",
    "fmi3GetNominalsOfContinuousStates", "fmi3GetNumberOfContinuousStates"};
#define N_PROBES (sizeof probes / sizeof probes[0])

static unsigned fingerprint(inst *x)
{
    const fmu3 *a = x->api;
    fmi3Boolean b[5];
    fmi3Float64 t = 0.0, v[MAX_STATES];
    size_t n = 0;
    unsigned f = 0;
    f |= a->SetFloat64(x->c, NULL, 0, NULL, 0) == fmi3OK ? 1u : 0u;
    f |= a->SetBoolean(x->c, NULL, 0, NULL, 0) == fmi3OK ? 2u : 0u;
    f |= a->UpdateDiscreteStates(x->c, &b[0], &b[1], &b[2], &b[3], &b[4], &t) == fmi3OK ? 4u : 0u;
    f |= a->CompletedIntegratorStep(x->c, false, &b[0], &b[1]) == fmi3OK ? 8u : 0u;
    f |= a->GetNominalsOfContinuousStates(x->c, v, a->nx) == fmi3OK ? 16u : 0u;
    f |= a->GetNumberOfContinuousStates(x->c, &n) == fmi3OK ? 32u : 0u;
    x->log.last_error[0] = '\0';
    if (a->ExitConfigurationMode(x->c) == fmi3Error) {
        const char *s = strstr(x->log.last_error, "in state ");
        for (int st = 0; st < ST_COUNT && s != NULL; ++st) {
            const size_t k = strlen(state_names[st]);
            if (strncmp(s + 9, state_names[st], k) == 0 && !isalnum((unsigned char)s[9 + k])) {
                f |= (unsigned)(st + 1) << 8;
            }
        }
    }
    return f;
}

static unsigned expected_fingerprint(int me, int st)
{
    unsigned f = (unsigned)(st + 1) << 8;
    for (size_t k = 0; k < N_PROBES; ++k) {
        f |= allowed(probes[k], me, st) ? 1u << k : 0u;
    }
    return f;
}

static void check_state(inst *x, int st, const char *where)
{
    const unsigned fp = fingerprint(x);
    const unsigned want = expected_fingerprint(x->me, st);
    if (fp != want) {
        fprintf(stderr, "%s (%s): %s: state fingerprint 0x%x, expected 0x%x (state %s)\n",
                x->api->id, interface_names[x->me], where, fp, want, state_names[st]);
        rrr_test_failures++;
    }
}

static void check_stepping(void *x, int discarded, const char *where)
{
    check_state(x, discarded ? ST_DISCARDED : ST_STEP, where);
}

/* ---- instantiation --------------------------------------------------------------------------- */

static void expect_no_instance(fmi3Instance c, const fmu3 *api, log_sink *sink, const char *needle,
                               const char *what)
{
    const int ok = c == NULL && sink->count[fmi3Error] == 1 && strstr(sink->last_error, needle);
    if (!ok) {
        fprintf(stderr, "%s: %s: instance %p, %d error message(s), last \"%s\" (want \"%s\")\n",
                api->id, what, c, sink->count[fmi3Error], sink->last_error, needle);
        rrr_test_failures++;
    }
    if (c != NULL) {
        api->FreeInstance(c);
    }
    memset(sink, 0, sizeof *sink);
}

static void test_instantiate(const fmu3 *api)
{
    log_sink sink;
    memset(&sink, 0, sizeof sink);
    CHECK(strcmp(api->GetVersion(), "3.0") == 0);
    for (int me = 0; me < 2; ++me) {
        fmi3Instance c = instantiate(api, "x", me, api->token, false, &sink);
        CHECK(c != NULL && sink.count[fmi3Error] == 0); /* one binary, both interface types */
        api->FreeInstance(c);
        expect_no_instance(instantiate(api, "x", me, "{not-the-token}", false, &sink), api, &sink,
                           "instantiationToken", "wrong token");
        expect_no_instance(instantiate(api, "x", me, NULL, false, &sink), api, &sink, "token",
                           "NULL token");
        expect_no_instance(instantiate(api, NULL, me, api->token, false, &sink), api, &sink,
                           "instanceName", "NULL name");
        expect_no_instance(instantiate(api, "", me, api->token, false, &sink), api, &sink,
                           "instanceName", "empty name");
        /* FMI 3.0 (2.3.1): "must have at least one character that is not a white space" */
        expect_no_instance(instantiate(api, " \t", me, api->token, false, &sink), api, &sink,
                           "instanceName", "white-space name");
    }
    const fmi3ValueReference req = api->input_vr;
    expect_no_instance(api->InstantiateCoSimulation("x", api->token, NULL, false, false, true,
                                                    false, NULL, 0, &sink, logger, NULL),
                       api, &sink, "eventModeUsed", "eventModeUsed = true");
    expect_no_instance(api->InstantiateCoSimulation("x", api->token, NULL, false, false, false,
                                                    false, &req, 1, &sink, logger, NULL),
                       api, &sink, "nRequiredIntermediateVariables", "intermediate variables");
    expect_no_instance(api->InstantiateScheduledExecution("x", api->token, NULL, false, false,
                                                          &sink, logger, NULL, NULL, NULL),
                       api, &sink, "fmi3InstantiateScheduledExecution", "Scheduled Execution");
    /* no logger: refused quietly; earlyReturnAllowed is a permission, not a demand */
    CHECK(api->InstantiateCoSimulation("x", "{wrong}", NULL, false, false, false, false, NULL, 0,
                                       NULL, NULL, NULL) == NULL);
    fmi3Instance c = api->InstantiateCoSimulation("x", api->token, NULL, false, false, false, true,
                                                  NULL, 0, &sink, logger, NULL);
    CHECK(c != NULL);
    api->FreeInstance(c);
}

/* A NULL instance is refused by every function, without a crash. */
static void test_null_instance(const fmu3 *api)
{
    inst x;
    memset(&x, 0, sizeof x);
    x.api = api;
    for (int me = 0; me < 2; ++me) {
        x.me = me;
        for (size_t f = 0; f < N_FUNCTIONS; ++f) {
            if (functions[f].call(&x) != fmi3Error) {
                fprintf(stderr, "%s: %s(NULL) was not refused\n", api->id, functions[f].name);
                rrr_test_failures++;
            }
        }
    }
    api->FreeInstance(NULL);
}

/* ---- start values --------------------------------------------------------------------------- */

static void test_defaults(const fmu3 *plant, const fmu3 *ctrl)
{
    for (int me = 0; me < 2; ++me) {
        inst p, c;
        if (inst_new(&p, plant, "defaults_plant", me) || inst_new(&c, ctrl, "defaults_ctrl", me)) {
            return;
        }
        CHECK(enter_init(&p) == fmi3OK);
        CHECK(enter_init(&c) == fmi3OK);
        fh_check_defaults(&ops3, &p, &c);
        /* the Booleans are <Boolean> elements with a start value */
        const xml_var *ad = find_var(plant, "adaptive");
        const xml_var *ff = find_var(ctrl, "feedforward");
        char start[16] = "";
        CHECK(ad != NULL && ad->is_bool && var_attr(ad, "start", start, sizeof start) == 0);
        CHECK(ff != NULL && ff->is_bool && var_attr(ff, "start", start, sizeof start) == 0);
        /* the independent variable has no start value; it is the startTime */
        CHECK(var_attr(find_var(plant, "time"), "start", start, sizeof start) != 0);
        CHECK(get1(&p, "time") == 0.0 && get1(&c, "time") == 0.0);
        inst_free(&p);
        inst_free(&c);
    }
}

/* ---- closed loop: controller -> plant, Gauss-Seidel, 1 kHz ----------------------------------- */

#define N_LOOP 1000

/* The same loop through the FMI 2.0 binaries. */
static void loop_run_fmi2(const fmu2 *p2, const fmu2 *c2, double (*rec)[9])
{
    fmi2Component p = inst2_new(p2, "plant2"), c = inst2_new(c2, "controller2");
    if (p == NULL || c == NULL) {
        return;
    }
    fmi2ValueReference p_u[3], p_q[3], p_qd[3], q0[3], qd0[3], c_ref[9], c_q[3], c_qd[3], c_u[3];
    const char *pn[3] = {"u", "q", "qd"};
    fmi2ValueReference *pv[3] = {p_u, p_q, p_qd};
    const char *cn[6] = {"q_ref", "qd_ref", "qdd_ref", "q", "qd", "u"};
    fmi2ValueReference *cv[6] = {c_ref, c_ref + 3, c_ref + 6, c_q, c_qd, c_u};
    for (int i = 0; i < 3; ++i) {
        char name[32];
        for (int k = 0; k < 3; ++k) {
            snprintf(name, sizeof name, "%s[%d]", pn[k], i + 1);
            pv[k][i] = vr2_of(p2, name);
        }
        for (int k = 0; k < 6; ++k) {
            snprintf(name, sizeof name, "%s[%d]", cn[k], i + 1);
            cv[k][i] = vr2_of(c2, name);
        }
        snprintf(name, sizeof name, "q0[%d]", i + 1);
        q0[i] = vr2_of(p2, name);
        snprintf(name, sizeof name, "qd0[%d]", i + 1);
        qd0[i] = vr2_of(p2, name);
    }
    double r[9];
    reference(0.0, r);
    int bad = 0;
    bad |= p2->SetupExperiment(p, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK;
    bad |= c2->SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) != fmi2OK;
    bad |= p2->SetReal(p, q0, 3, r) != fmi2OK;
    bad |= p2->SetReal(p, qd0, 3, r + 3) != fmi2OK;
    bad |= p2->EnterInitializationMode(p) != fmi2OK || c2->EnterInitializationMode(c) != fmi2OK;
    bad |= p2->ExitInitializationMode(p) != fmi2OK || c2->ExitInitializationMode(c) != fmi2OK;
    double t = 0.0;
    for (int k = 0; k < N_LOOP && !bad; ++k) {
        double q[3], qd[3], u[3];
        reference(t, r);
        bad |= p2->GetReal(p, p_q, 3, q) != fmi2OK || p2->GetReal(p, p_qd, 3, qd) != fmi2OK;
        bad |= c2->SetReal(c, c_ref, 9, r) != fmi2OK || c2->SetReal(c, c_q, 3, q) != fmi2OK;
        bad |= c2->SetReal(c, c_qd, 3, qd) != fmi2OK || c2->GetReal(c, c_u, 3, u) != fmi2OK;
        bad |= p2->SetReal(p, p_u, 3, u) != fmi2OK;
        bad |= p2->DoStep(p, t, H, fmi2True) != fmi2OK || c2->DoStep(c, t, H, fmi2True) != fmi2OK;
        t += H;
        memcpy(rec[k], q, sizeof q);
        memcpy(rec[k] + 3, qd, sizeof qd);
        memcpy(rec[k] + 6, u, sizeof u);
    }
    CHECK(!bad);
    p2->FreeInstance(p);
    c2->FreeInstance(c);
}

/* the independent variable at the end of the loop */
static void check_loop_time(fh_loop *L)
{
    CHECK(get1(L->p, "time") == L->t && get1(L->c, "time") == L->t);
}

static void check_reset(fh_loop *L)
{
    check_state(L->p, ST_INST, "after fmi3Reset");
    log_clear(L->p);
}

static void test_closed_loop(const fmu3 *plant, const fmu3 *ctrl, const fmu2 *p2, const fmu2 *c2)
{
    inst p, c;
    if (inst_new(&p, plant, "plant", 0) || inst_new(&c, ctrl, "controller", 0)) {
        return;
    }
    fh_loop L;
    fh_loop_new(&L, &ops3, &p, &c);
    static double rec1[N_LOOP][9], rec2[N_LOOP][9], rec3[N_LOOP][9];
    fh_loop_twice(&L, rec1, rec2, "FMI 3 closed loop", check_loop_time, check_reset);
    inst_free(&p);
    inst_free(&c);
    if (p2 != NULL && c2 != NULL) {
        loop_run_fmi2(p2, c2, rec3);
        const int same = memcmp(rec1, rec3, sizeof rec1) == 0;
        printf("FMI 3 closed loop %s the FMI 2 closed loop bit for bit\n",
               same ? "equals" : "DIFFERS FROM");
        CHECK(same);
        CHECK(fmi2_errors == 0);
    }
}

/* ---- illegal call sequences ------------------------------------------------------------------ */

static void test_illegal_sequences(const fmu3 *api, int me)
{
    int tried = 0;
    for (int st = 0; st < ST_COUNT; ++st) {
        if (!reachable(api, me, st)) {
            continue;
        }
        for (size_t f = 0; f < N_FUNCTIONS; ++f) {
            if (functions[f].allowed[me] & (1u << st)) {
                continue;
            }
            inst x;
            if (inst_new(&x, api, "illegal", me)) {
                return;
            }
            drive(&x, st);
            log_clear(&x);
            const fmi3Status s = functions[f].call(&x);
            const int ok = s == fmi3Error && x.log.count[fmi3Error] == 1 &&
                           x.log.count[fmi3Warning] == 0 && x.log.count[fmi3OK] == 0 &&
                           x.log.illegal == 1 && fh_names_word(x.log.last_error, functions[f].name) &&
                           fh_names_word(x.log.last_error, state_names[st]);
            if (!ok) {
                fprintf(stderr,
                        "%s (%s): %s in state %s returned %d, %d error message(s), last \"%s\"\n",
                        api->id, interface_names[me], functions[f].name, state_names[st], (int)s,
                        x.log.count[fmi3Error], x.log.last_error);
                rrr_test_failures++;
            }
            char where[128];
            snprintf(where, sizeof where, "after the refused %s", functions[f].name);
            check_state(&x, st, where);
            ++tried;
            inst_free(&x);
        }
    }
    printf("%s (%s): %d illegal (function, state) pairs refused with fmi3Error, one message "
           "naming function and state, state unchanged\n",
           api->id, interface_names[me], tried);
    CHECK(tried >= 150);
}

/* Functions allowed by the state machine whose capability the XML does not declare. */
static void test_not_provided(const fmu3 *api)
{
    enum { CS = 0, ME = 1 }; /* the interface type: interface_names[me] */
    static const struct {
        const char *name;
        int me;
        int st;
    } cases[] = {
        {"fmi3GetNumberOfVariableDependencies", CS, ST_INST},
        {"fmi3GetVariableDependencies", ME, ST_INIT},
        {"fmi3EnterConfigurationMode", CS, ST_INST},
        {"fmi3EnterConfigurationMode", ME, ST_EVENT},
        {"fmi3GetOutputDerivatives", CS, ST_STEP},
        {"fmi3EvaluateDiscreteStates", CS, ST_STEP},
        {"fmi3EvaluateDiscreteStates", ME, ST_EVENT},
    };
    int tried = 0;
    for (size_t k = 0; k < sizeof cases / sizeof cases[0]; ++k) {
        CHECK(allowed(cases[k].name, cases[k].me, cases[k].st));
        inst x;
        if (inst_new(&x, api, "not_provided", cases[k].me)) {
            return;
        }
        drive(&x, cases[k].st);
        log_clear(&x);
        const fmi3Status s = find_fn(cases[k].name)->call(&x);
        if (!(s == fmi3Error && x.log.count[fmi3Error] == 1 && x.log.not_provided == 1 &&
              fh_names_word(x.log.last_error, cases[k].name))) {
            fprintf(stderr, "%s (%s): %s in %s returned %d, message \"%s\" (want \"not "
                            "provided\")\n",
                    api->id, interface_names[cases[k].me], cases[k].name,
                    state_names[cases[k].st], (int)s, x.log.last_error);
            rrr_test_failures++;
        }
        check_state(&x, cases[k].st, cases[k].name);
        ++tried;
        inst_free(&x);
    }
    printf("%s: %d calls of functions that are not provided refused\n", api->id, tried);
}

/* the plant's knowns in the order of its Jacobian: u, q, qd */
static const char *const plant_knowns[3] = {"u", "q", "qd"};

/* ---- partial derivatives ----------------------------------------------------------------------- */

/* One refused derivative call: fmi3Error, one error message containing needle, the state
 * unchanged, the sensitivity untouched. */
static void expect_refused_derivative(inst *x, int st, int adjoint, const fmi3ValueReference *u,
                                      size_t nu, const fmi3ValueReference *k, size_t nk,
                                      const double *seed, size_t n_seed, size_t n_sens,
                                      const char *needle)
{
    double sens[16];
    for (size_t i = 0; i < 16; ++i) {
        sens[i] = FH_UNTOUCHED;
    }
    log_clear(x);
    const fmi3Status s = adjoint ? x->api->GetAdjointDerivative(x->c, u, nu, k, nk, seed, n_seed,
                                                                 sens, n_sens)
                                 : x->api->GetDirectionalDerivative(x->c, u, nu, k, nk, seed,
                                                                    n_seed, sens, n_sens);
    fh_expect_refused_out(&ops3, x, (int)s, adjoint ? "adjoint" : "directional", needle, sens, 16);
    check_state(x, st, "after a refused derivative");
}

/* d(unknowns)/d(knowns) of one FMU, column by column with unit seeds (forward) and row by row
 * (adjoint): the two agree bit for bit, and equal librrr's rrr_plant_jacobian /
 * rrr_ctc_jacobian at the same point bit for bit (the FMU multiplies by 1 and adds zeros). */
static void test_derivative_values(inst *x, const fmi3ValueReference *u, size_t nu,
                                   const fmi3ValueReference *k, size_t nk, double *J)
{
    const fmu3 *a = x->api;
    double seed[32], sens[32];
    for (size_t j = 0; j < nk; ++j) {
        for (size_t m = 0; m < nk; ++m) {
            seed[m] = m == j ? 1.0 : 0.0;
        }
        CHECK(a->GetDirectionalDerivative(x->c, u, nu, k, nk, seed, nk, sens, nu) == fmi3OK);
        for (size_t i = 0; i < nu; ++i) {
            J[i * nk + j] = sens[i];
        }
    }
    for (size_t i = 0; i < nu; ++i) {
        for (size_t m = 0; m < nu; ++m) {
            seed[m] = m == i ? 1.0 : 0.0;
        }
        CHECK(a->GetAdjointDerivative(x->c, u, nu, k, nk, seed, nu, sens, nk) == fmi3OK);
        for (size_t j = 0; j < nk; ++j) {
            if (sens[j] != J[i * nk + j]) {
                fprintf(stderr, "%s: adjoint [%zu][%zu] = %.17g, forward %.17g\n", a->id, i, j,
                        sens[j], J[i * nk + j]);
                rrr_test_failures++;
            }
        }
    }
}

static void test_derivatives(const fmu3 *plant, const fmu3 *ctrl)
{
    rrr_model m;
    rrr_model_default(&m);
    int checked = 0;
    for (int me = 0; me < 2; ++me) {
        /* the plant: qdd by u, q, qd at q0, qd0 (Initialization Mode) and after a step */
        for (int pass = 0; pass < 2; ++pass) {
            const int st = pass == 0 ? ST_INIT : me ? ST_CONT : ST_STEP;
            inst x;
            if (inst_new(&x, plant, "derivatives", me)) {
                return;
            }
            const double q0[3] = {0.3, -0.7, 1.1}, qd0[3] = {0.2, -0.05, 0.4};
            const double u[3] = {1.5, -2.0, 30.0}; /* u[3] beyond the limit */
            fmi3ValueReference vq0[3], vqd0[3], vu[3], uk[3], kn[9];
            vrs3(plant, "q0", vq0);
            vrs3(plant, "qd0", vqd0);
            vrs3(plant, "u", vu);
            vrs3(plant, "qdd", uk);
            fh_vrs(&ops3, plant, plant_knowns, 3, kn);
            CHECK(plant->SetFloat64(x.c, vq0, 3, q0, 3) == fmi3OK);
            CHECK(plant->SetFloat64(x.c, vqd0, 3, qd0, 3) == fmi3OK);
            drive(&x, st);
            CHECK(plant->SetFloat64(x.c, vu, 3, u, 3) == fmi3OK);
            rrr_plant_state s;
            if (pass == 0) {
                rrr_plant_state_init(q0, qd0, &s);
            } else {
                fmi3ValueReference vq[3], vqd[3];
                vrs3(plant, "q", vq);
                vrs3(plant, "qd", vqd);
                CHECK(plant->GetFloat64(x.c, vq, 3, s.q, 3) == fmi3OK);
                CHECK(plant->GetFloat64(x.c, vqd, 3, s.qd, 3) == fmi3OK);
            }
            rrr_plant_derivatives d;
            CHECK(rrr_plant_jacobian(&m, &s, u, &d) == RRR_OK);
            double J[3 * 9];
            test_derivative_values(&x, uk, 3, kn, 9, J);
            for (int i = 0; i < 3; ++i) {
                for (int j = 0; j < 3; ++j) {
                    CHECK(J[i * 9 + j] == d.dqdd_du[i][j]);
                    CHECK(J[i * 9 + 3 + j] == d.dqdd_dq[i][j]);
                    CHECK(J[i * 9 + 6 + j] == d.dqdd_dqd[i][j]);
                }
                CHECK(J[i * 9 + 2] == 0.0); /* u[3] is clamped */
            }
            /* the parameters: knowns in Initialization Mode (the start value q0 like q, the
             * model parameters as rrr_plant_param_jacobian), refused afterwards */
            const fmi3ValueReference a2 = vr_of(plant, "a2"), bad = 100000u;
            const double one = 1.0, nan = (double)NAN, inf = (double)INFINITY;
            if (pass == 0) {
                double dp[3][RRR_N_PARAMS];
                CHECK(rrr_plant_param_jacobian(&m, &s, u, dp) == RRR_OK);
                const fmi3ValueReference pk[3] = {a2, vr_of(plant, "p[7]"), vr_of(plant, "u_max")};
                const int pc[3] = {rrr_param_index("a2"), rrr_param_index("p[7]"),
                                   rrr_param_index("u_max")};
                double Jp[3 * 3];
                test_derivative_values(&x, uk, 3, pk, 3, Jp);
                for (int i = 0; i < 3; ++i) {
                    for (int j = 0; j < 3; ++j) {
                        CHECK(Jp[i * 3 + j] == dp[i][pc[j]]);
                    }
                }
                CHECK(Jp[0 * 3 + 2] != 0.0); /* u[3] is clamped: u_max acts */
                double Jq[3 * 3];
                test_derivative_values(&x, uk, 3, vq0, 3, Jq);
                for (int i = 0; i < 3; ++i) {
                    for (int j = 0; j < 3; ++j) {
                        CHECK(Jq[i * 3 + j] == d.dqdd_dq[i][j]);
                    }
                }
            } else {
                expect_refused_derivative(&x, st, 0, uk, 1, &a2, 1, &one, 1, 1,
                                          "InitializationMode");
                expect_refused_derivative(&x, st, 1, uk, 1, &a2, 1, &one, 1, 1,
                                          "InitializationMode");
            }
            expect_refused_derivative(&x, st, 0, vu, 1, kn, 1, &one, 1, 1, "not an unknown");
            expect_refused_derivative(&x, st, 0, uk, 1, &bad, 1, &one, 1, 1,
                                      "not a value reference");
            expect_refused_derivative(&x, st, 0, &bad, 1, kn, 1, &one, 1, 1,
                                      "not a value reference");
            expect_refused_derivative(&x, st, 0, uk, 1, kn, 1, &nan, 1, 1, "seed[0]");
            expect_refused_derivative(&x, st, 1, uk, 1, kn, 1, &inf, 1, 1, "seed[0]");
            expect_refused_derivative(&x, st, 0, uk, 1, kn, 1, &one, 2, 1, "nSeed");
            expect_refused_derivative(&x, st, 1, uk, 2, kn, 1, &one, 1, 1, "nSeed");
            expect_refused_derivative(&x, st, 0, uk, 1, NULL, 1, &one, 1, 1, "NULL");
            expect_refused_derivative(&x, st, 0, uk, 1, kn, 1, NULL, 1, 1, "NULL");
            checked += pass == 0 ? 9 : 11;
            inst_free(&x);
        }
        /* the controller: every output by every input, against rrr_ctc_jacobian (lead = 0) */
        inst x;
        if (inst_new(&x, ctrl, "derivatives", me)) {
            return;
        }
        drive(&x, me ? ST_CONT : ST_STEP);
        const char *in_names[5] = {"q_ref", "qd_ref", "qdd_ref", "q", "qd"};
        const char *out_names[3] = {"u", "u_n", "u_c"};
        const double in_values[5][3] = {{0.1, 0.5, -0.3}, {0.4, -0.2, 0.1}, {1.0, 2.0, -1.0},
                                        {0.11, 0.49, -0.31}, {0.39, -0.21, 0.12}};
        fmi3ValueReference kn[15], un[9];
        for (int k = 0; k < 5; ++k) {
            vrs3(ctrl, in_names[k], kn + 3 * k);
            CHECK(ctrl->SetFloat64(x.c, kn + 3 * k, 3, in_values[k], 3) == fmi3OK);
        }
        for (int o = 0; o < 3; ++o) {
            vrs3(ctrl, out_names[o], un + 3 * o);
        }
        rrr_ctc_gains g;
        rrr_ctc_gains_default(&g);
        rrr_ctc_derivatives d;
        CHECK(rrr_ctc_jacobian(&m, &g, in_values[0], in_values[1], in_values[2], in_values[3],
                               in_values[4], &d) == RRR_OK);
        double J[9 * 15];
        test_derivative_values(&x, un, 9, kn, 15, J);
        for (int o = 0; o < 3; ++o) {
            double(*const dv)[3][3] = o == 0 ? d.du : o == 1 ? d.du_n : d.du_c;
            for (int i = 0; i < 3; ++i) {
                for (int k = 0; k < 5; ++k) {
                    for (int j = 0; j < 3; ++j) {
                        CHECK(J[(3 * o + i) * 15 + 3 * k + j] == dv[k][i][j]);
                    }
                }
            }
        }
        const double one = 1.0;
        expect_refused_derivative(&x, me ? ST_CONT : ST_STEP, 0, un, 1, &un[1], 1, &one, 1, 1,
                                  "not a known");
        checked += 1;
        inst_free(&x);
    }
    printf("partial derivatives: forward = adjoint = librrr bit for bit (plant in "
           "Initialization Mode and after a step, controller), %d refused calls\n", checked);
}

/* ---- refused values -------------------------------------------------------------------------- */

/* One refused call: fmi3Error and exactly one error message holding every needle. */
static void expect_error(inst *x, fmi3Status s, const char *what, const char *n1, const char *n2)
{
    fh_expect_error(&ops3, x, (int)s, what, n1, n2);
}

/* The typed getters and setters of the types the FMUs have no variables of: refused for a
 * non-empty call, naming the function and the value reference. */
static void test_other_types(inst *x)
{
    const fmu3 *a = x->api;
    const fmi3ValueReference vr = a->input_vr;
    char vr_text[32];
    snprintf(vr_text, sizeof vr_text, "vr %u", (unsigned)vr);
    union {
        fmi3Float32 f32;
        fmi3Int8 i8;
        fmi3UInt8 u8;
        fmi3Int16 i16;
        fmi3UInt16 u16;
        fmi3Int32 i32;
        fmi3UInt32 u32;
        fmi3Int64 i64;
        fmi3UInt64 u64;
        fmi3String s;
        fmi3Binary bin;
        fmi3Clock clk;
    } v;
    memset(&v, 0, sizeof v);
    size_t size = 0;
    const double before = get1(x, a->vars[0].name);
    log_clear(x);
#define OTHER(F, FIELD)                                                                       \
    expect_error(x, a->F(x->c, &vr, 1, &v.FIELD, 1), "fmi3" #F " on one variable", "fmi3" #F, \
                 vr_text)
    OTHER(GetFloat32, f32);
    OTHER(GetInt8, i8);
    OTHER(GetUInt8, u8);
    OTHER(GetInt16, i16);
    OTHER(GetUInt16, u16);
    OTHER(GetInt32, i32);
    OTHER(GetUInt32, u32);
    OTHER(GetInt64, i64);
    OTHER(GetUInt64, u64);
    OTHER(GetString, s);
    OTHER(SetFloat32, f32);
    OTHER(SetInt8, i8);
    OTHER(SetUInt8, u8);
    OTHER(SetInt16, i16);
    OTHER(SetUInt16, u16);
    OTHER(SetInt32, i32);
    OTHER(SetUInt32, u32);
    OTHER(SetInt64, i64);
    OTHER(SetUInt64, u64);
    OTHER(SetString, s);
#undef OTHER
    expect_error(x, a->GetBinary(x->c, &vr, 1, &size, &v.bin, 1), "fmi3GetBinary", "fmi3GetBinary",
                 vr_text);
    expect_error(x, a->SetBinary(x->c, &vr, 1, &size, &v.bin, 1), "fmi3SetBinary", "fmi3SetBinary",
                 vr_text);
    /* clocks: none, and no state of this FMU allows clock access */
    expect_error(x, a->GetClock(x->c, &vr, 1, &v.clk), "fmi3GetClock", "fmi3GetClock", NULL);
    expect_error(x, a->SetClock(x->c, &vr, 1, &v.clk), "fmi3SetClock", "fmi3SetClock", NULL);
    const double after = get1(x, a->vars[0].name);
    CHECK(memcmp(&before, &after, sizeof before) == 0);
    log_clear(x);
}

static void test_bad_values(const fmu3 *plant, const fmu3 *ctrl)
{
    inst p, c;
    if (inst_new(&p, plant, "bad_plant", 0) || inst_new(&c, ctrl, "bad_ctrl", 0)) {
        return;
    }
    /* initialization mode: parameters and inputs */
    CHECK(enter_init(&p) == fmi3OK);
    CHECK(enter_init(&c) == fmi3OK);
    fh_refused_in_init(&ops3, &p, &c);
    fh_expect_refused(&ops3, &p, "time", 1.0, "time"); /* the independent variable */

    /* a multi-value set with one bad value changes nothing, nor one with an output */
    fh_refused_multi(&ops3, &p);
    {
        fmi3ValueReference vr[3];
        vrs3(plant, "u", vr);
        double got[3] = {-1.0, -1.0, -1.0};
        const double w[3] = {1.0, 2.0, 3.0};
        fmi3ValueReference mixed[3] = {vr[0], vr[1], vr_of(plant, "q[1]")};
        CHECK(plant->SetFloat64(p.c, mixed, 3, w, 3) == fmi3Error); /* one output among inputs */
        CHECK(plant->GetFloat64(p.c, vr, 3, got, 3) == fmi3OK);
        CHECK(got[0] == 0.0 && got[1] == 0.0 && got[2] == 0.0);
    }
    /* unknown value reference, wrong type, nValues, NULL arrays */
    {
        const fmi3ValueReference bad = 100000;
        const fmi3ValueReference u1 = vr_of(plant, "u[1]");
        const fmi3ValueReference ff = vr_of(ctrl, "feedforward");
        double v = 0.0, two[2] = {0.0, 0.0};
        fmi3Boolean b = true;
        log_clear(&p);
        expect_error(&p, plant->GetFloat64(p.c, &bad, 1, &v, 1), "GetFloat64 of vr 100000",
                     "100000", NULL);
        expect_error(&p, plant->SetFloat64(p.c, &bad, 1, &v, 1), "SetFloat64 of vr 100000",
                     "100000", NULL);
        expect_error(&p, plant->SetBoolean(p.c, &u1, 1, &b, 1), "SetBoolean on a Float64",
                     "fmi3SetBoolean", "u[1]");
        expect_error(&p, plant->GetBoolean(p.c, &u1, 1, &b, 1), "GetBoolean on a Float64",
                     "fmi3GetBoolean", "u[1]");
        log_clear(&c);
        expect_error(&c, ctrl->GetFloat64(c.c, &ff, 1, &v, 1), "GetFloat64 on a Boolean",
                     "fmi3GetFloat64", "feedforward");
        expect_error(&c, ctrl->SetFloat64(c.c, &ff, 1, &v, 1), "SetFloat64 on a Boolean",
                     "fmi3SetFloat64", "feedforward");
        expect_error(&p, plant->SetFloat64(p.c, &u1, 1, two, 2), "SetFloat64, nValues 2 for 1",
                     "nValues", NULL);
        expect_error(&p, plant->GetFloat64(p.c, &u1, 1, two, 0), "GetFloat64, nValues 0 for 1",
                     "nValues", NULL);
        expect_error(&c, ctrl->SetBoolean(c.c, &ff, 1, &b, 2), "SetBoolean, nValues 2 for 1",
                     "nValues", NULL);
        expect_error(&p, plant->GetFloat64(p.c, &u1, 1, NULL, 1), "GetFloat64 into NULL", "NULL",
                     NULL);
        expect_error(&p, plant->SetFloat64(p.c, NULL, 1, &v, 1), "SetFloat64 of NULL vrs", "NULL",
                     NULL);
        expect_error(&p, plant->SetFloat64(p.c, &u1, 1, NULL, 1), "SetFloat64 of NULL values",
                     "NULL", NULL);
        expect_error(&c, ctrl->GetBoolean(c.c, &ff, 1, NULL, 1), "GetBoolean into NULL", "NULL",
                     NULL);
        CHECK(get1(&p, "u[1]") == 0.0);
    }
    test_other_types(&p);
    test_other_types(&c);
    /* a good set still works; step mode: parameters are fixed, inputs are checked */
    fh_refused_stepping(&ops3, &p, &c, "StepMode");
    {
        const fmi3ValueReference ff = vr_of(ctrl, "feedforward");
        const fmi3Boolean off = false;
        fmi3Boolean now = false;
        log_clear(&c);
        expect_error(&c, ctrl->SetBoolean(c.c, &ff, 1, &off, 1), "SetBoolean of a fixed parameter",
                     "feedforward", "StepMode");
        CHECK(ctrl->GetBoolean(c.c, &ff, 1, &now, 1) == fmi3OK && now);
    }
    test_other_types(&p);
    /* still stepping normally: nothing was corrupted */
    fh_still_stepping(&ops3, &p, &c);

    /* doStep arguments: refused, state unchanged */
    {
        fmi3Boolean b[3];
        double last = 0.0;
        log_clear(&p);
        expect_error(&p, do_step(&p, H, 0.0, NULL), "doStep h = 0", "communicationStepSize", NULL);
        expect_error(&p, do_step(&p, H, -H, NULL), "doStep h < 0", "communicationStepSize", NULL);
        expect_error(&p, do_step(&p, H, (double)NAN, NULL), "doStep h NaN", "communicationStepSize", NULL);
        expect_error(&p, do_step(&p, H, (double)INFINITY, NULL), "doStep h Inf", "communicationStepSize",
                     NULL);
        expect_error(&p, do_step(&p, 0.5, H, NULL), "doStep t wrong", "currentCommunicationPoint",
                     NULL);
        expect_error(&p, do_step(&p, (double)NAN, H, NULL), "doStep t NaN", "currentCommunicationPoint",
                     NULL);
        expect_error(&p, plant->DoStep(p.c, H, H, true, NULL, &b[1], &b[2], &last),
                     "doStep with eventHandlingNeeded NULL", "NULL", NULL);
        expect_error(&p, plant->DoStep(p.c, H, H, true, &b[0], &b[1], &b[2], NULL),
                     "doStep with lastSuccessfulTime NULL", "NULL", NULL);
        /* a point at the low end of the tolerance with a shorter step would move time back */
        expect_error(&p, do_step(&p, H * (1.0 - 5e-10), H * 1e-10, NULL), "doStep backwards",
                     "not a finite time after the FMU time", NULL);
        CHECK(get1(&p, "time") == H);
        check_state(&p, ST_STEP, "after refused doStep arguments");
        CHECK(do_step(&p, H * (1.0 + 1e-12), H, &last) == fmi3OK); /* within tolerance */
        CHECK(last == H * (1.0 + 1e-12) + H);
    }
    check_state(&p, ST_STEP, "after the refused values");
    inst_free(&p);
    inst_free(&c);

    /* enterInitializationMode arguments and the stop time */
    {
        inst x;
        if (inst_new(&x, plant, "stop_time", 0)) {
            return;
        }
        expect_error(&x, plant->EnterInitializationMode(x.c, false, 0.0, (double)NAN, false, 0.0),
                     "startTime NaN", "startTime", NULL);
        expect_error(&x, plant->EnterInitializationMode(x.c, false, 0.0, 1.0, true, 0.5),
                     "stopTime < startTime", "stopTime", NULL);
        expect_error(&x, plant->EnterInitializationMode(x.c, false, 0.0, 0.0, true, (double)INFINITY),
                     "stopTime Inf", "stopTime", NULL);
        /* a defined tolerance must be finite and > 0; an undefined one is ignored */
        expect_error(&x, plant->EnterInitializationMode(x.c, true, (double)NAN, 0.0, false, 0.0),
                     "tolerance NaN", "tolerance", NULL);
        expect_error(&x, plant->EnterInitializationMode(x.c, true, (double)INFINITY, 0.0, false,
                                                        0.0),
                     "tolerance Inf", "tolerance", NULL);
        expect_error(&x, plant->EnterInitializationMode(x.c, true, -1e-6, 0.0, false, 0.0),
                     "tolerance < 0", "tolerance", NULL);
        expect_error(&x, plant->EnterInitializationMode(x.c, true, 0.0, 0.0, false, 0.0),
                     "tolerance 0", "tolerance", NULL);
        check_state(&x, ST_INST, "after refused enterInitializationMode arguments");
        CHECK(plant->EnterInitializationMode(x.c, false, (double)NAN, 0.0, true, 2 * H) == fmi3OK);
        CHECK(plant->Reset(x.c) == fmi3OK);
        CHECK(plant->EnterInitializationMode(x.c, true, 1e-6, 0.0, true, 2 * H) == fmi3OK);
        CHECK(plant->ExitInitializationMode(x.c) == fmi3OK);
        CHECK(do_step(&x, 0.0, H, NULL) == fmi3OK);
        log_clear(&x);
        expect_error(&x, do_step(&x, H, 2 * H, NULL), "a step past stopTime", "stopTime", NULL);
        CHECK(do_step(&x, H, H, NULL) == fmi3OK);
        inst_free(&x);
    }
}

/* Invalid parameters are named at exitInitializationMode; Error allows reset. */
static void expect_invalid(const fmu3 *api, int me, const char *name, double v, const char *needle)
{
    inst x;
    if (inst_new(&x, api, "invalid", me)) {
        return;
    }
    CHECK(set1(&x, name, v) == fmi3OK);
    CHECK(enter_init(&x) == fmi3OK);
    log_clear(&x);
    const fmi3Status s = api->ExitInitializationMode(x.c);
    if (s != fmi3Error || x.log.count[fmi3Error] < 1 || strstr(x.log.last_error, needle) == NULL) {
        fprintf(stderr, "%s (%s): %s = %g: exitInitializationMode returned %d, message \"%s\"\n",
                api->id, interface_names[me], name, v, (int)s, x.log.last_error);
        rrr_test_failures++;
    }
    check_state(&x, ST_ERR, "after a failed exitInitializationMode");
    /* reset recovers from the error state */
    CHECK(api->Reset(x.c) == fmi3OK);
    check_state(&x, ST_INST, "after fmi3Reset from Error");
    CHECK(enter_init(&x) == fmi3OK);
    CHECK(api->ExitInitializationMode(x.c) == fmi3OK);
    inst_free(&x);
}

static void test_validation(const fmu3 *plant, const fmu3 *ctrl)
{
    for (int me = 0; me < 2; ++me) {
        expect_invalid(plant, me, "a2", -0.1, "a2");
        expect_invalid(plant, me, "kt[2]", 0.0, "kt[2]");
        expect_invalid(plant, me, "w[3,1]", -1.0, "w[3,1]");
        expect_invalid(plant, me, "u_max", 0.0, "u_max");
        expect_invalid(plant, me, "p[7]", -10.0, "p[1]..p[16]");
        expect_invalid(plant, me, "h_int", 0.0, "h_int");
        expect_invalid(plant, me, "rtol", 0.0, "rtol");
        expect_invalid(plant, me, "atol", 0.5, "atol");
        expect_invalid(ctrl, me, "b[1]", -0.5, "b[1]");
        expect_invalid(ctrl, me, "kp[2]", -1.0, "kp[2]");
        expect_invalid(ctrl, me, "kd[3]", -1.0, "kd[3]");
        expect_invalid(ctrl, me, "g", -9.81, "g");
    }
}

/* A step that cannot be taken (here 1e8 substeps of the fixed-step RK4) is discarded with a
 * message naming the cause: state StepDiscarded, lastSuccessfulTime and the plant state at the
 * last communication point. */
static void test_discard(const fmu3 *plant)
{
    inst p;
    if (inst_new(&p, plant, "discard", 0)) {
        return;
    }
    CHECK(set_bool(&p, "adaptive", false) == fmi3OK);
    drive(&p, ST_STEP);
    const double q_before = get1(&p, "q[2]");
    double last = -1.0;
    log_clear(&p);
    CHECK(do_step(&p, H, 1e4, &last) == fmi3Discard);
    CHECK(p.log.count[fmi3Discard] == 1 && strstr(p.log.last, "substeps of h_int") != NULL);
    CHECK(fh_names_word(p.log.last, "fmi3DoStep"));
    CHECK(last == H);
    CHECK(get1(&p, "time") == H);
    const double q_after = get1(&p, "q[2]");
    CHECK(memcmp(&q_before, &q_after, sizeof q_before) == 0);
    check_state(&p, ST_DISCARDED, "after a discarded step");
    log_clear(&p);
    expect_error(&p, do_step(&p, H, H, NULL), "doStep in StepDiscarded", "StepDiscarded", NULL);
    CHECK(plant->Terminate(p.c) == fmi3OK);
    check_state(&p, ST_TERM, "after fmi3Terminate from StepDiscarded");
    inst_free(&p);
}

/* ---- FMU state ------------------------------------------------------------------------------- */


static void check_time_t1(fh_loop *L, double t1)
{
    CHECK(get1(L->p, "time") == t1);
}

static void test_fmu_state(const fmu3 *plant, const fmu3 *ctrl, const fmu2 *p2)
{
    fh_loop L;
    fh_saved S;
    if (fh_state_begin(&ops3, plant, ctrl, &L, &S, check_time_t1) != 0) {
        return;
    }
    inst *p = L.p;
    fmi3FMUState junk = NULL;
    const double t_now = get1(p, "time");
    log_clear(p);
    expect_error(p, plant->DeserializeFMUState(p->c, NULL, S.np, &junk), "deserialize NULL",
                 "NULL", NULL);
    if (p2 != NULL) {
        /* the FMI 2 plant's state bytes are foreign to the FMI 3 plant */
        fmi2Component c2 = inst2_new(p2, "state_plant2");
        fmi2FMUstate s2 = NULL;
        size_t n2 = 0;
        if (c2 != NULL && p2->GetFMUstate(c2, &s2) == fmi2OK &&
            p2->SerializedFMUstateSize(c2, s2, &n2) == fmi2OK) {
            fmi2Byte *b2 = malloc(n2);
            CHECK(b2 != NULL && p2->SerializeFMUstate(c2, s2, b2, n2) == fmi2OK);
            if (b2 != NULL) {
                expect_error(p, plant->DeserializeFMUState(p->c, (const fmi3Byte *)b2, n2, &junk),
                             "FMI 2 bytes", "FMI version", NULL);
            }
            free(b2);
            p2->FreeFMUstate(c2, &s2);
        } else {
            CHECK(0 && "FMI 2 state");
        }
        if (c2 != NULL) {
            p2->FreeInstance(c2);
        }
    }
    CHECK(junk == NULL);
    CHECK(get1(p, "time") == t_now);
    check_state(p, ST_STEP, "after refused FMU states");

    /* getFMUState into an existing state overwrites it */
    CHECK(plant->GetFMUState(p->c, &S.sp) == fmi3OK);
    CHECK(plant->SetFMUState(p->c, S.sp) == fmi3OK);
    CHECK(get1(p, "time") == L.t);

    CHECK(do_step(p, L.t, H, NULL) == fmi3OK);

    fh_state_end(&L, &S);
    fh_state_undoes_discard(&ops3, plant);
}

/* ---- Model Exchange -------------------------------------------------------------------------- */

/* The plant's state vector x (XML order) as an rrr_plant_state, and its derivative from librrr. */
static void plant_xdot(const fmu3 *api, const rrr_model *m, const double x[], const double u[3],
                       double dx[])
{
    rrr_plant_state s;
    memset(&s, 0, sizeof s);
    for (size_t i = 0; i < api->nx; ++i) {
        const char *name = api->vars[api->x_var[i]].name;
        const int j = name[strlen(name) - 2] - '1';
        if (j < 0 || j > 2) {
            CHECK(0 && "plant states are q[1..3] and qd[1..3]");
            return;
        }
        (strncmp(name, "qd[", 3) == 0 ? s.qd : s.q)[j] = x[i];
    }
    double qdd[3] = {(double)NAN, (double)NAN, (double)NAN};
    CHECK(rrr_plant_accel(m, &s, u, qdd) == RRR_OK);
    for (size_t i = 0; i < api->nx; ++i) {
        const char *name = api->vars[api->dx_var[i]].name;
        const int j = name[strlen(name) - 2] - '1';
        dx[i] = j < 0 || j > 2 ? (double)NAN : strncmp(name, "qdd[", 4) == 0 ? qdd[j] : s.qd[j];
    }
}

static void test_model_exchange(const fmu3 *plant, const fmu3 *ctrl)
{
    rrr_model m;
    rrr_ctc_gains g;
    CHECK(rrr_model_default(&m) == RRR_OK);
    CHECK(rrr_ctc_gains_default(&g) == RRR_OK);
    rrr_rng rng = {0x9E3779B97F4A7C15ull};
    const size_t nx = plant->nx;
    if (nx != 6) {
        CHECK(0 && "the plant has 6 continuous states");
        return;
    }
    inst p;
    if (inst_new(&p, plant, "me_plant", 1)) {
        return;
    }
    size_t n = 99, ni = 99;
    CHECK(plant->GetNumberOfContinuousStates(p.c, &n) == fmi3OK && n == nx && n == 6);
    CHECK(plant->GetNumberOfEventIndicators(p.c, &ni) == fmi3OK && ni == 0);

    /* initial state from the parameters q0, qd0 */
    double x0[MAX_STATES], x[MAX_STATES], dx[MAX_STATES], want[MAX_STATES], nom[MAX_STATES];
    for (size_t i = 0; i < nx; ++i) {
        const char *name = plant->vars[plant->x_var[i]].name;
        char param[16];
        snprintf(param, sizeof param, "%s0[%c]", strncmp(name, "qd[", 3) == 0 ? "qd" : "q",
                 name[strlen(name) - 2]);
        x0[i] = rrr_rng_uniform(&rng, -1.0, 1.0);
        CHECK(set1(&p, param, x0[i]) == fmi3OK);
    }
    CHECK(enter_init(&p) == fmi3OK);
    CHECK(plant->GetContinuousStates(p.c, x, nx) == fmi3OK);
    CHECK(memcmp(x, x0, nx * sizeof x[0]) == 0);
    CHECK(plant->GetNominalsOfContinuousStates(p.c, nom, nx) == fmi3OK);
    CHECK(memcmp(nom, plant->nominal, nx * sizeof nom[0]) == 0);
    const double u0[3] = {0.0, 0.0, 0.0};
    plant_xdot(plant, &m, x0, u0, want);
    CHECK(plant->GetContinuousStateDerivatives(p.c, dx, nx) == fmi3OK);
    CHECK(memcmp(dx, want, nx * sizeof dx[0]) == 0);

    CHECK(plant->ExitInitializationMode(p.c) == fmi3OK);
    check_state(&p, ST_EVENT, "after exitInitializationMode");
    {
        fmi3Boolean b[5] = {true, true, true, true, true};
        double next = -1.0;
        CHECK(plant->UpdateDiscreteStates(p.c, &b[0], &b[1], &b[2], &b[3], &b[4], &next) ==
              fmi3OK);
        CHECK(!b[0] && !b[1] && !b[2] && !b[3] && !b[4]);
        log_clear(&p);
        expect_error(&p, plant->UpdateDiscreteStates(p.c, NULL, &b[1], &b[2], &b[3], &b[4], &next),
                     "updateDiscreteStates with a NULL flag", "NULL", NULL);
    }
    CHECK(plant->GetContinuousStates(p.c, x, nx) == fmi3OK);
    CHECK(memcmp(x, x0, nx * sizeof x[0]) == 0);
    CHECK(get1(&p, "time") == 0.0);
    CHECK(plant->EnterContinuousTimeMode(p.c) == fmi3OK);
    check_state(&p, ST_CONT, "after enterContinuousTimeMode");

    /* derivatives = rrr_plant_accel for random states, inputs and times */
    fmi3ValueReference vu[3], vdx[MAX_STATES];
    vrs3(plant, "u", vu);
    for (size_t i = 0; i < nx; ++i) {
        vdx[i] = plant->vars[plant->dx_var[i]].vr;
    }
    for (int trial = 0; trial < 20; ++trial) {
        double u[3], outs[MAX_STATES];
        const double t = rrr_rng_uniform(&rng, 0.0, 10.0);
        for (size_t i = 0; i < nx; ++i) {
            x[i] = rrr_rng_uniform(&rng, i < 3 ? -3.0 : -4.0, i < 3 ? 3.0 : 4.0);
        }
        for (int i = 0; i < 3; ++i) {
            u[i] = rrr_rng_uniform(&rng, -1.5 * m.u_max, 1.5 * m.u_max); /* saturation included */
        }
        CHECK(plant->SetTime(p.c, t) == fmi3OK);
        CHECK(plant->SetFloat64(p.c, vu, 3, u, 3) == fmi3OK);
        CHECK(plant->SetContinuousStates(p.c, x, nx) == fmi3OK);
        CHECK(plant->GetContinuousStateDerivatives(p.c, dx, nx) == fmi3OK);
        plant_xdot(plant, &m, x, u, want);
        for (size_t i = 0; i < nx; ++i) {
            if (memcmp(&dx[i], &want[i], sizeof dx[i]) != 0) {
                fprintf(stderr, "rrr_plant (Model Exchange): d%s/dt = %.17g, rrr_plant_accel "
                                "gives %.17g (trial %d)\n",
                        plant->vars[plant->x_var[i]].name, dx[i], want[i], trial);
                rrr_test_failures++;
            }
        }
        CHECK(plant->GetFloat64(p.c, vdx, nx, outs, nx) == fmi3OK); /* the same as outputs */
        CHECK(memcmp(outs, dx, nx * sizeof dx[0]) == 0);
        CHECK(get1(&p, "time") == t);
        double back[MAX_STATES];
        CHECK(plant->GetContinuousStates(p.c, back, nx) == fmi3OK);
        CHECK(memcmp(back, x, nx * sizeof x[0]) == 0);
    }

    /* refused: non-finite states and times, wrong counts, NULL arrays; nothing changes */
    {
        const double specials[3] = {(double)NAN, (double)INFINITY, -(double)INFINITY};
        double before[MAX_STATES], after[MAX_STATES], bad_x[MAX_STATES + 1];
        const double t_before = get1(&p, "time");
        CHECK(plant->GetContinuousStates(p.c, before, nx) == fmi3OK);
        log_clear(&p);
        for (size_t i = 0; i < nx; i += nx - 1) {
            for (int k = 0; k < 3; ++k) {
                memcpy(bad_x, before, nx * sizeof bad_x[0]);
                for (size_t j = 0; j < nx; ++j) {
                    bad_x[j] += 0.5; /* every other state would change */
                }
                bad_x[i] = specials[k];
                expect_error(&p, plant->SetContinuousStates(p.c, bad_x, nx),
                             "setContinuousStates with a NaN/Inf",
                             plant->vars[plant->x_var[i]].name, NULL);
            }
        }
        memcpy(bad_x, before, nx * sizeof bad_x[0]);
        bad_x[nx] = 0.0;
        expect_error(&p, plant->SetContinuousStates(p.c, bad_x, nx - 1), "5 states for 6", NULL,
                     NULL);
        expect_error(&p, plant->SetContinuousStates(p.c, bad_x, nx + 1), "7 states for 6", NULL,
                     NULL);
        expect_error(&p, plant->SetContinuousStates(p.c, NULL, nx), "NULL states", "NULL", NULL);
        for (int k = 0; k < 3; ++k) {
            expect_error(&p, plant->SetTime(p.c, specials[k]), "setTime NaN/Inf", "time", NULL);
        }
        expect_error(&p, plant->GetContinuousStateDerivatives(p.c, dx, nx - 1),
                     "5 derivatives for 6", NULL, NULL);
        expect_error(&p, plant->GetContinuousStateDerivatives(p.c, NULL, nx), "NULL derivatives",
                     "NULL", NULL);
        expect_error(&p, plant->GetContinuousStates(p.c, after, nx + 1), "7 states out of 6", NULL,
                     NULL);
        expect_error(&p, plant->GetNominalsOfContinuousStates(p.c, nom, 1), "1 nominal for 6", NULL,
                     NULL);
        expect_error(&p, plant->GetEventIndicators(p.c, nom, 1), "an event indicator", NULL, NULL);
        CHECK(plant->GetEventIndicators(p.c, NULL, 0) == fmi3OK);
        CHECK(plant->GetContinuousStates(p.c, after, nx) == fmi3OK);
        CHECK(memcmp(before, after, nx * sizeof before[0]) == 0);
        CHECK(get1(&p, "time") == t_before);
        fh_expect_refused(&ops3, &p, "u[1]", (double)NAN, "u[1]");
        fh_expect_refused(&ops3, &p, "q0[1]", 1.0, "ContinuousTimeMode"); /* fixed after initialization */
        fh_expect_refused(&ops3, &p, "qdd[1]", 1.0, "qdd[1]");             /* an output */
        check_state(&p, ST_CONT, "after the refusals");
    }
    {
        fmi3Boolean enter = true, terminate = true;
        CHECK(plant->CompletedIntegratorStep(p.c, true, &enter, &terminate) == fmi3OK);
        CHECK(!enter && !terminate);
        log_clear(&p);
        expect_error(&p, plant->CompletedIntegratorStep(p.c, true, NULL, &terminate),
                     "completedIntegratorStep(NULL)", "NULL", NULL);
    }
    CHECK(plant->EnterEventMode(p.c) == fmi3OK);
    check_state(&p, ST_EVENT, "after enterEventMode");
    CHECK(plant->EnterContinuousTimeMode(p.c) == fmi3OK);
    CHECK(plant->GetContinuousStates(p.c, x0, nx) == fmi3OK);
    CHECK(plant->Terminate(p.c) == fmi3OK);
    check_state(&p, ST_TERM, "after terminate");
    CHECK(plant->GetContinuousStates(p.c, x, nx) == fmi3OK); /* final values */
    CHECK(memcmp(x, x0, nx * sizeof x[0]) == 0);
    CHECK(plant->GetContinuousStateDerivatives(p.c, dx, nx) == fmi3OK);
    CHECK(p.log.count[fmi3Warning] == 0);
    inst_free(&p);

    /* the controller: no continuous states, outputs = rrr_ctc of the inputs */
    inst c;
    if (inst_new(&c, ctrl, "me_ctrl", 1)) {
        return;
    }
    CHECK(ctrl->GetNumberOfContinuousStates(c.c, &n) == fmi3OK && n == 0 && ctrl->nx == 0);
    CHECK(ctrl->GetNumberOfEventIndicators(c.c, &ni) == fmi3OK && ni == 0);
    drive(&c, ST_CONT);
    fmi3ValueReference in[15], vu_c[3];
    fh_vrs(&ops3, ctrl, fh_ctrl_inputs, 5, in);
    vrs3(ctrl, "u", vu_c);
    for (int trial = 0; trial < 10; ++trial) {
        double v[15], u[3];
        for (int i = 0; i < 15; ++i) {
            v[i] = rrr_rng_uniform(&rng, -2.0, 2.0);
        }
        rrr_ctc_output out;
        CHECK(rrr_ctc(&m, &g, v, v + 3, v + 6, v + 9, v + 12, &out) == RRR_OK);
        CHECK(ctrl->SetTime(c.c, 0.1 * trial) == fmi3OK);
        CHECK(ctrl->SetFloat64(c.c, in, 15, v, 15) == fmi3OK);
        CHECK(ctrl->GetFloat64(c.c, vu_c, 3, u, 3) == fmi3OK);
        CHECK(memcmp(u, out.u, sizeof u) == 0);
    }
    CHECK(ctrl->GetContinuousStateDerivatives(c.c, NULL, 0) == fmi3OK);
    CHECK(ctrl->GetContinuousStates(c.c, NULL, 0) == fmi3OK);
    CHECK(ctrl->SetContinuousStates(c.c, NULL, 0) == fmi3OK);
    log_clear(&c);
    expect_error(&c, ctrl->SetContinuousStates(c.c, x, 1), "1 state for 0", NULL, NULL);
    CHECK(ctrl->Terminate(c.c) == fmi3OK);
    inst_free(&c);
}

/* RK4 at 1e-4 s on the Model Exchange plant against the Co-Simulation plant in fixed-step mode
 * (adaptive = false: its own RK4 at h_int = 1e-4 s inside doStep), the same piecewise-constant
 * input, 0.2 s. */
#define ME_TOL 1e-9

static void rk4_stage(inst *x, double t, const double xs[], double k[])
{
    const fmu3 *a = x->api;
    CHECK(a->SetTime(x->c, t) == fmi3OK);
    CHECK(a->SetContinuousStates(x->c, xs, a->nx) == fmi3OK);
    CHECK(a->GetContinuousStateDerivatives(x->c, k, a->nx) == fmi3OK);
}

static void test_me_against_cs(const fmu3 *plant)
{
    inst me, cs;
    const size_t nx = plant->nx;
    if (nx != 6 || inst_new(&me, plant, "rk4_me", 1) || inst_new(&cs, plant, "rk4_cs", 0)) {
        CHECK(nx == 6);
        return;
    }
    const char *init[6] = {"q0[1]", "q0[2]", "q0[3]", "qd0[1]", "qd0[2]", "qd0[3]"};
    const double init_v[6] = {0.2, -0.4, 0.9, 0.5, -1.0, 0.3};
    for (int i = 0; i < 6; ++i) {
        CHECK(set1(&me, init[i], init_v[i]) == fmi3OK && set1(&cs, init[i], init_v[i]) == fmi3OK);
    }
    drive(&me, ST_CONT);
    CHECK(set_bool(&cs, "adaptive", false) == fmi3OK);
    CHECK(enter_init(&cs) == fmi3OK && plant->ExitInitializationMode(cs.c) == fmi3OK);
    fmi3ValueReference vu[3], vx[MAX_STATES];
    vrs3(plant, "u", vu);
    for (size_t i = 0; i < nx; ++i) {
        vx[i] = plant->vars[plant->x_var[i]].vr;
    }
    double x[MAX_STATES];
    CHECK(plant->GetContinuousStates(me.c, x, nx) == fmi3OK);
    double err = 0.0;
    const int sub = 10;
    const double dt = H / sub;
    for (int k = 0; k < 200; ++k) {
        const double t0 = k * H;
        const double u[3] = {3.0 * sin(7.0 * t0), -2.0 * cos(5.0 * t0), 1.5 * sin(11.0 * t0 + 1.0)};
        CHECK(plant->SetFloat64(me.c, vu, 3, u, 3) == fmi3OK);
        CHECK(plant->SetFloat64(cs.c, vu, 3, u, 3) == fmi3OK);
        CHECK(do_step(&cs, t0, H, NULL) == fmi3OK);
        for (int s = 0; s < sub; ++s) {
            const double t = t0 + s * dt;
            double k1[MAX_STATES], k2[MAX_STATES], k3[MAX_STATES], k4[MAX_STATES], y[MAX_STATES];
            rk4_stage(&me, t, x, k1);
            for (size_t i = 0; i < nx; ++i) {
                y[i] = x[i] + 0.5 * dt * k1[i];
            }
            rk4_stage(&me, t + 0.5 * dt, y, k2);
            for (size_t i = 0; i < nx; ++i) {
                y[i] = x[i] + 0.5 * dt * k2[i];
            }
            rk4_stage(&me, t + 0.5 * dt, y, k3);
            for (size_t i = 0; i < nx; ++i) {
                y[i] = x[i] + dt * k3[i];
            }
            rk4_stage(&me, t + dt, y, k4);
            for (size_t i = 0; i < nx; ++i) {
                x[i] += dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
            }
            fmi3Boolean enter = true, terminate = true;
            CHECK(plant->SetTime(me.c, t + dt) == fmi3OK);
            CHECK(plant->SetContinuousStates(me.c, x, nx) == fmi3OK);
            CHECK(plant->CompletedIntegratorStep(me.c, true, &enter, &terminate) == fmi3OK);
            CHECK(!enter && !terminate);
        }
        double xc[MAX_STATES];
        CHECK(plant->GetFloat64(cs.c, vx, nx, xc, nx) == fmi3OK);
        for (size_t i = 0; i < nx; ++i) {
            err = fmax(err, fabs(x[i] - xc[i]));
        }
    }
    printf("Model Exchange plant, RK4 at 1e-4 s, against the Co-Simulation plant over 0.2 s: "
           "max |x_ME - x_CS| = %.3g (tolerance %.0e)\n",
           err, ME_TOL);
    CHECK(err <= ME_TOL);
    CHECK(me.log.count[fmi3Error] == 0 && cs.log.count[fmi3Error] == 0);
    inst_free(&me);
    inst_free(&cs);
}

/* FMU state of a Model Exchange instance; Co-Simulation and Model Exchange states kept apart. */
static void test_me_fmu_state(const fmu3 *plant)
{
    enum { N = 50 };
    inst me, cs;
    if (inst_new(&me, plant, "state_me", 1) || inst_new(&cs, plant, "state_cs", 0)) {
        return;
    }
    const size_t nx = plant->nx;
    CHECK(set1(&me, "qd0[2]", 0.8) == fmi3OK);
    drive(&me, ST_CONT);
    drive(&cs, ST_STEP);
    static double r1[N][MAX_STATES], r2[N][MAX_STATES];
    fmi3FMUState s_me = NULL, s_cs = NULL;
    CHECK(plant->GetFMUState(me.c, &s_me) == fmi3OK && s_me != NULL);
    CHECK(plant->GetFMUState(cs.c, &s_cs) == fmi3OK && s_cs != NULL);
    double (*rec)[MAX_STATES] = r1;
    for (int pass = 0; pass < 2; ++pass) {
        double x[MAX_STATES], dx[MAX_STATES];
        CHECK(plant->GetContinuousStates(me.c, x, nx) == fmi3OK);
        for (int k = 0; k < N; ++k) { /* explicit Euler, 1 ms */
            CHECK(plant->GetContinuousStateDerivatives(me.c, dx, nx) == fmi3OK);
            for (size_t i = 0; i < nx; ++i) {
                x[i] += H * dx[i];
            }
            CHECK(plant->SetTime(me.c, (k + 1) * H) == fmi3OK);
            CHECK(plant->SetContinuousStates(me.c, x, nx) == fmi3OK);
            memcpy(rec[k], x, sizeof rec[k]);
        }
        CHECK(plant->SetFMUState(me.c, s_me) == fmi3OK);
        CHECK(get1(&me, "time") == 0.0);
        check_state(&me, ST_CONT, "after setFMUState");
        rec = r2;
    }
    CHECK(memcmp(r1, r2, sizeof r1) == 0);

    size_t n_me = 0, n_cs = 0;
    CHECK(plant->SerializedFMUStateSize(me.c, s_me, &n_me) == fmi3OK);
    CHECK(plant->SerializedFMUStateSize(cs.c, s_cs, &n_cs) == fmi3OK);
    fmi3Byte *b_me = malloc(n_me), *b_cs = malloc(n_cs);
    fmi3FMUState junk = NULL, s_back = NULL;
    if (b_me != NULL && b_cs != NULL) {
        CHECK(plant->SerializeFMUState(me.c, s_me, b_me, n_me) == fmi3OK);
        CHECK(plant->SerializeFMUState(cs.c, s_cs, b_cs, n_cs) == fmi3OK);
        log_clear(&me);
        log_clear(&cs);
        expect_error(&me, plant->SetFMUState(me.c, s_cs),
                     "a Co-Simulation state into Model Exchange", "interface type", NULL);
        expect_error(&me, plant->DeserializeFMUState(me.c, b_cs, n_cs, &junk),
                     "Co-Simulation bytes into Model Exchange", "interface type", NULL);
        expect_error(&cs, plant->SetFMUState(cs.c, s_me),
                     "a Model Exchange state into Co-Simulation", "interface type", NULL);
        expect_error(&cs, plant->DeserializeFMUState(cs.c, b_me, n_me, &junk),
                     "Model Exchange bytes into Co-Simulation", "interface type", NULL);
        CHECK(junk == NULL);
        check_state(&me, ST_CONT, "after refused foreign states");
        check_state(&cs, ST_STEP, "after refused foreign states");
        CHECK(plant->DeserializeFMUState(me.c, b_me, n_me, &s_back) == fmi3OK);
        CHECK(plant->EnterEventMode(me.c) == fmi3OK);
        CHECK(plant->SetFMUState(me.c, s_back) == fmi3OK); /* back to ContinuousTimeMode */
        check_state(&me, ST_CONT, "after setFMUState of deserialized bytes");
    } else {
        CHECK(0 && "out of memory");
    }
    CHECK(plant->FreeFMUState(me.c, &s_back) == fmi3OK);
    CHECK(plant->FreeFMUState(me.c, &s_me) == fmi3OK);
    CHECK(plant->FreeFMUState(cs.c, &s_cs) == fmi3OK);
    free(b_me);
    free(b_cs);
    inst_free(&me);
    inst_free(&cs);
}

/* Two instances of one FMU in one process do not share anything. */
/* Forged FMU states (fmu_state_forge.h): the bytes of a good state with fields overwritten and
 * the checksum made valid again are refused by fmi3DeserializeFMUState, and by fmi3SetFMUState
 * when the importer overwrote a state block it holds, with fmi3Error, a message naming the
 * field, and the instance unchanged; in Model Exchange too (me: ContinuousTimeMode, where
 * the Co-Simulation StepMode case is the foreign one). */
/* StepMode in a forged Co-Simulation case is the Model Exchange one's state never entered */
static void forged_for_me(forge_case *fc)
{
    if (fc->w[0].at == FORGE_STATE && fc->w[0].bits == (1u << 3)) {
        fc->w[0].bits = 1u << 5; /* StepMode: never entered by Model Exchange */
    }
}

static void test_forged_states(const fmu3 *api, int me, const forge_case *cases,
                               size_t n_cases, size_t data_size)
{
    inst x;
    if (inst_new(&x, api, "forged", me)) {
        return;
    }
    drive(&x, me ? ST_CONT : ST_STEP);
    fh_forged_states(&ops3, &x, cases, n_cases, data_size, me ? forged_for_me : NULL,
                     me ? -1.0 : H);
    inst_free(&x);
}

/* ---- logging --------------------------------------------------------------------------------- */

static void test_logging(const fmu3 *api)
{
    inst x;
    if (inst_new(&x, api, "logging", 0)) {
        return;
    }
    const fmi3String unknown[] = {"logStatusError", "logNoSuchThing"};
    log_clear(&x);
    expect_error(&x, api->SetDebugLogging(x.c, true, 2, unknown), "an unknown log category",
                 "logNoSuchThing", NULL);
    expect_error(&x, api->SetDebugLogging(x.c, true, 1, NULL), "categories NULL", "NULL", NULL);

    /* errors are logged by default */
    expect_error(&x, api->DoStep(x.c, 0.0, H, true, NULL, NULL, NULL, NULL),
                 "doStep in Instantiated", "illegal call sequence", NULL);

    const fmi3String calls[] = {"logCalls"};
    CHECK(api->SetDebugLogging(x.c, true, 1, calls) == fmi3OK);
    log_clear(&x);
    CHECK(enter_init(&x) == fmi3OK);
    CHECK(x.log.calls >= 1 && strstr(x.log.last, "fmi3EnterInitializationMode") != NULL);
    CHECK(x.log.count[fmi3Error] == 0);
    CHECK(api->SetDebugLogging(x.c, false, 1, calls) == fmi3OK);
    log_clear(&x);
    CHECK(get1(&x, "u_max") > 0.0);
    CHECK(x.log.calls == 0);

    /* errors can be switched off explicitly, and on again */
    const fmi3String errors[] = {"logStatusError"};
    CHECK(api->SetDebugLogging(x.c, false, 1, errors) == fmi3OK);
    log_clear(&x);
    CHECK(call_DoStep(&x) == fmi3Error);
    CHECK(x.log.count[fmi3Error] == 0);
    const fmi3String all[] = {"logAll"};
    CHECK(api->SetDebugLogging(x.c, true, 1, all) == fmi3OK);
    CHECK(call_DoStep(&x) == fmi3Error);
    CHECK(x.log.count[fmi3Error] == 1);
    CHECK(get1(&x, "u_max") > 0.0 && x.log.calls >= 1);
    CHECK(api->SetDebugLogging(x.c, false, 0, NULL) == fmi3OK);
    log_clear(&x);
    CHECK(api->ExitInitializationMode(x.c) == fmi3OK && x.log.calls == 0);
    /* errors: logged again (the default) */
    CHECK(call_EnterInitializationMode(&x) == fmi3Error && x.log.count[fmi3Error] == 1);
    inst_free(&x);

    /* loggingOn at instantiation: every call traced; no logger: no crash */
    log_sink sink;
    memset(&sink, 0, sizeof sink);
    fmi3Instance c = instantiate(api, "logging_on", 1, api->token, true, &sink);
    CHECK(c != NULL);
    if (c != NULL) {
        CHECK(api->EnterInitializationMode(c, false, 0.0, 0.0, false, 0.0) == fmi3OK);
        CHECK(sink.calls >= 1 && strstr(sink.last, "fmi3EnterInitializationMode") != NULL);
        api->FreeInstance(c);
    }
    c = api->InstantiateModelExchange("quiet", api->token, NULL, false, true, NULL, NULL);
    CHECK(c != NULL);
    if (c != NULL) {
        CHECK(api->ExitInitializationMode(c) == fmi3Error); /* refused, nobody to tell */
        CHECK(api->EnterInitializationMode(c, false, 0.0, 0.0, false, 0.0) == fmi3OK);
        api->FreeInstance(c);
    }
}

int main(int argc, char **argv)
{
    if (argc != 3 && argc != 5) {
        fprintf(stderr,
                "usage: %s <plant unzip dir> <controller unzip dir> [<FMI 2 plant unzip dir> "
                "<FMI 2 controller unzip dir>]\n",
                argv[0]);
        return 2;
    }
    static fmu3 plant, ctrl;
    static fmu2 plant2, ctrl2;
    if (fmu3_load(&plant, argv[1]) || fmu3_load(&ctrl, argv[2])) {
        return 2;
    }
    const int with2 = argc == 5;
    if (with2 && (fmu2_load(&plant2, argv[3]) || fmu2_load(&ctrl2, argv[4]))) {
        return 2;
    }
    CHECK(strcmp(plant.id, "rrr_plant") == 0);
    CHECK(strcmp(ctrl.id, "rrr_controller") == 0);
    CHECK(strcmp(plant.token, ctrl.token) != 0);

    test_xml(&plant, with2 ? &plant2 : NULL);
    test_xml(&ctrl, with2 ? &ctrl2 : NULL);
    test_instantiate(&plant);
    test_instantiate(&ctrl);
    test_null_instance(&plant);
    test_null_instance(&ctrl);
    test_defaults(&plant, &ctrl);
    test_closed_loop(&plant, &ctrl, with2 ? &plant2 : NULL, with2 ? &ctrl2 : NULL);
    for (int me = 0; me < 2; ++me) {
        test_illegal_sequences(&plant, me);
        test_illegal_sequences(&ctrl, me);
    }
    test_not_provided(&plant);
    test_not_provided(&ctrl);
    test_derivatives(&plant, &ctrl);
    test_bad_values(&plant, &ctrl);
    test_validation(&plant, &ctrl);
    test_discard(&plant);
    test_fmu_state(&plant, &ctrl, with2 ? &plant2 : NULL);
    test_model_exchange(&plant, &ctrl);
    test_me_against_cs(&plant);
    test_me_fmu_state(&plant);
    for (int me = 0; me < 2; ++me) {
        test_forged_states(&plant, me, forge_plant_cases,
                           sizeof forge_plant_cases / sizeof forge_plant_cases[0],
                           sizeof(forge_plant));
        test_forged_states(&ctrl, me, forge_controller_cases,
                           sizeof forge_controller_cases / sizeof forge_controller_cases[0],
                           sizeof(forge_controller));
    }
    fh_two_instances(&ops3, &plant); /* nothing shared between two instances */
    test_logging(&plant);
    test_logging(&ctrl);

    if (n_fmi2_mentions != 0) {
        fprintf(stderr, "%d FMI 3 message(s) name an FMI 2 function, e.g. \"%s\"\n",
                n_fmi2_mentions, first_fmi2_mention);
        rrr_test_failures++;
    }
    if (!with2) {
        printf("(no FMI 2 binaries given: the FMI 2 comparisons were not run)\n");
    }
    fmu3_unload(&plant);
    fmu3_unload(&ctrl);
    if (with2) {
        fmu2_unload(&plant2);
        fmu2_unload(&ctrl2);
    }
    return rrr_test_report("test_fmu3_harness");
}
