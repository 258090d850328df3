/*
 * Instances: creation, logging, table-driven get/set, Model Exchange states, FMU state
 * snapshots, and the checks both FMI adapters share. Independent of the FMI version: the
 * adapters (fmi2_functions.c, fmi3_functions.c) own the state machines and translate types;
 * nothing here checks call sequences.
 */
#include "fmu_internal.h"
#include "fmu_bus.h"

#include <ctype.h>
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

/* ---- logging --------------------------------------------------------------------------------- */

static void vlog(const fmu_instance *inst, fmu_status status, const char *category,
                 const char *fmt, va_list ap)
{
    char buf[1024];
    vsnprintf(buf, sizeof buf, fmt, ap);
    inst->host.log(inst, status, category, buf);
}

void fmu_log(const fmu_instance *inst, fmu_status status, fmu_category category, const char *fmt,
             ...)
{
    if (inst == NULL || inst->host.log == NULL || (unsigned)category >= FMU_LOG_CATEGORY_COUNT ||
        (inst->log_mask & (1u << category)) == 0u) {
        return;
    }
    va_list ap;
    va_start(ap, fmt);
    vlog(inst, status, fmu_log_categories[category].name, fmt, ap);
    va_end(ap);
}

/* Before an instance exists (instantiation failures): a stand-in with the host and the name. */
#if defined(__MINGW32__) /* C99 printf: __USE_MINGW_ANSI_STDIO above */
__attribute__((format(gnu_printf, 4, 5)))
#elif defined(__GNUC__)
__attribute__((format(printf, 4, 5)))
#endif
static void log_early(const fmu_host *host, int fmi_version, const char *name, const char *fmt,
                      ...)
{
    if (host == NULL || host->log == NULL) {
        return;
    }
    fmu_instance tmp;
    memset(&tmp, 0, sizeof tmp);
    tmp.host = *host;
    tmp.fmi_version = fmi_version;
    tmp.name = (char *)(name != NULL ? name : "?");
    va_list ap;
    va_start(ap, fmt);
    vlog(&tmp, FMU_ERROR, fmu_log_categories[FMU_LOG_ERROR].name, fmt, ap);
    va_end(ap);
}

/* ---- lifecycle ------------------------------------------------------------------------------- */

/* 1 when s has no character that is not white space (FMI 2.0 and 3.0: not a valid instanceName). */
static int blank(const char *s)
{
    for (; *s != '\0'; ++s) {
        if (!isspace((unsigned char)*s)) {
            return 0;
        }
    }
    return 1;
}

/* The local folder of the importer's resource location, ending in a separator, allocated with
 * host->alloc; NULL when there is none, or (FMI 2) it is not a local file URI: "file:///p",
 * "file://localhost/p" or "file:/p", percent-escapes decoded; on Windows "file:///C:/p" is
 * "C:/p". FMI 3 passes a path, taken as it is. */
static char *resource_folder(const fmu_host *host)
{
    const char *loc = host->resources;
    if (loc == NULL || loc[0] == '\0') {
        return NULL;
    }
    if (host->resources_is_uri) {
        static const char scheme[] = "file:";
        for (size_t i = 0; i + 1 < sizeof scheme; ++i) {
            if (tolower((unsigned char)loc[i]) != scheme[i]) {
                return NULL;
            }
        }
        loc += sizeof scheme - 1;
        if (loc[0] == '/' && loc[1] == '/') {
            loc += 2;
            if (strncmp(loc, "localhost/", 10) == 0) {
                loc += 9;
            }
            if (loc[0] != '/') {
                return NULL; /* another host */
            }
        }
        if (loc[0] != '/') {
            return NULL;
        }
#if defined(_WIN32)
        if (isalpha((unsigned char)loc[1]) && loc[2] == ':') {
            ++loc; /* /C:/... */
        }
#endif
    }
    const size_t n = strlen(loc);
    char *out = host->alloc(n + 2, 1);
    if (out == NULL) {
        return NULL;
    }
    size_t k = 0;
    for (size_t i = 0; i < n; ++i) {
        if (host->resources_is_uri && loc[i] == '%' && i + 2 < n &&
            isxdigit((unsigned char)loc[i + 1]) && isxdigit((unsigned char)loc[i + 2])) {
            const char hex[3] = {loc[i + 1], loc[i + 2], '\0'};
            out[k++] = (char)strtol(hex, NULL, 16);
            i += 2;
        } else {
            out[k++] = loc[i];
        }
    }
    if (k == 0 || (out[k - 1] != '/' && out[k - 1] != '\\')) {
        out[k++] = '/';
    }
    out[k] = '\0';
    return out;
}

/* ---- start values from resources/ ------------------------------------------------------------ */

/* One line of resources/FMU_START_FILE, "name,value" (split at the last comma: names such as
 * "f[1,2]" hold commas, numbers never do), applied as SetReal/SetBoolean would in state
 * Instantiated (the same checks: a parameter or an input, finite). 0, or -1 logged. */
static int start_line(fmu_instance *S, const char *fn, size_t line_no, char *line)
{
    char *comma = strrchr(line, ',');
    if (comma == NULL) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "%s: resources/%s line %zu: expected name,value",
                fn, FMU_START_FILE, line_no);
        return -1;
    }
    *comma = '\0';
    const char *name = line;
    const char *text = comma + 1;
    const fmu_variable *v = NULL;
    for (size_t i = 0; i < S->model->n_vars && v == NULL; ++i) {
        if (strcmp(S->model->vars[i].name, name) == 0) {
            v = &S->model->vars[i];
        }
    }
    if (v == NULL || (v->causality != FMU_PARAMETER && v->causality != FMU_INPUT)) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: resources/%s line %zu: %s has no parameter or input \"%.64s\"", fn,
                FMU_START_FILE, line_no, S->model->identifier, name);
        return -1;
    }
    if (v->type == FMU_REAL) {
        char *end = NULL;
        const double d = strtod(text, &end);
        if (end == text || *end != '\0') {
            fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                    "%s: resources/%s line %zu: %s: a number expected, got \"%.64s\"", fn,
                    FMU_START_FILE, line_no, v->name, text);
            return -1;
        }
        if (!isfinite(d)) {
            fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                    "%s: resources/%s line %zu: %s must be finite, got \"%.64s\"", fn,
                    FMU_START_FILE, line_no, v->name, text);
            return -1;
        }
        return fmu_set_values(S, fn, FMU_REAL, &v->vr, 1, &d, FMU_BOOL_INT) <= FMU_WARNING ? 0
                                                                                           : -1;
    }
    const int b = strcmp(text, "true") == 0 || strcmp(text, "1") == 0;
    if (!b && strcmp(text, "false") != 0 && strcmp(text, "0") != 0) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: resources/%s line %zu: %s: true or false expected, got \"%.64s\"", fn,
                FMU_START_FILE, line_no, v->name, text);
        return -1;
    }
    return fmu_set_values(S, fn, FMU_BOOLEAN, &v->vr, 1, &b, FMU_BOOL_INT) <= FMU_WARNING ? 0 : -1;
}

/* The start values of resources/FMU_START_FILE, when the FMU has one: a CSV with the header
 * "name,value" and one line per variable (blank lines and lines starting with '#' skipped), at
 * most FMU_START_FILE_MAX bytes, lines of at most FMU_START_LINE_MAX characters. A tool that
 * writes an FMU for one system (rrr ssp) puts the system's values there, so that an importer
 * that sets no parameter runs the same system. Nothing when there is no resources/ folder or no
 * such file; an unreadable or malformed file is an error (logged: which line, what). */
static fmu_status apply_start_file(fmu_instance *S, const char *fn)
{
    if (S->resources == NULL) {
        return FMU_OK;
    }
    const size_t plen = strlen(S->resources) + sizeof FMU_START_FILE;
    char *path = S->host.alloc(plen, 1);
    char *text = S->host.alloc(FMU_START_FILE_MAX + 2, 1);
    if (path == NULL || text == NULL) {
        S->host.release(path);
        S->host.release(text);
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "%s: out of memory", fn);
        return FMU_ERROR;
    }
    snprintf(path, plen, "%s%s", S->resources, FMU_START_FILE);
    FILE *f = fopen(path, "rb");
    size_t n = 0;
    if (f != NULL) {
        n = fread(text, 1, FMU_START_FILE_MAX + 1, f);
        const int failed = ferror(f);
        fclose(f);
        if (failed) {
            fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "%s: cannot read resources/%s", fn,
                    FMU_START_FILE);
            n = FMU_START_FILE_MAX + 2; /* refused below */
        }
    }
    S->host.release(path);
    fmu_status st = FMU_OK;
    if (f != NULL && n > FMU_START_FILE_MAX) {
        if (n == FMU_START_FILE_MAX + 1) {
            fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "%s: resources/%s is larger than %d bytes", fn,
                    FMU_START_FILE, FMU_START_FILE_MAX);
        }
        st = FMU_ERROR;
    }
    size_t line_no = 0;
    int header = 0;
    for (size_t at = 0; f != NULL && st == FMU_OK && at < n;) {
        size_t end = at;
        while (end < n && text[end] != '\n') {
            ++end;
        }
        ++line_no;
        char *line = text + at;
        size_t len = end - at;
        at = end + 1;
        if (len > 0 && line[len - 1] == '\r') {
            --len;
        }
        line[len] = '\0';
        if (len > FMU_START_LINE_MAX || strlen(line) != len) {
            fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                    "%s: resources/%s line %zu: longer than %d characters or not text", fn,
                    FMU_START_FILE, line_no, FMU_START_LINE_MAX);
            st = FMU_ERROR;
        } else if (len == 0 || line[0] == '#') {
            continue;
        } else if (!header) {
            if (strcmp(line, "name,value") != 0) {
                fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                        "%s: resources/%s line %zu: the header name,value expected", fn,
                        FMU_START_FILE, line_no);
                st = FMU_ERROR;
            }
            header = 1;
        } else if (start_line(S, fn, line_no, line) != 0) {
            st = FMU_ERROR;
        }
    }
    S->host.release(text);
    return st;
}

fmu_instance *fmu_create(const char *fn, const fmu_host *host, int fmi_version,
                         fmu_interface interface, const char *name, const char *token,
                         int logging_on)
{
    const fmu_model *m = &FMU_MODEL;
    if (host->alloc == NULL || host->release == NULL) {
        log_early(host, fmi_version, name,
                  "%s: functions, functions->allocateMemory and functions->freeMemory must not "
                  "be NULL", fn);
        return NULL;
    }
    if (name == NULL || blank(name)) {
        log_early(host, fmi_version, name,
                  "%s: instanceName must be a non-empty string with a character that is not "
                  "white space", fn);
        return NULL;
    }
    if (token == NULL) {
        log_early(host, fmi_version, name, "%s: the instantiation token (GUID) must not be NULL",
                  fn);
        return NULL;
    }
    const char *problem = NULL;
    size_t row = 0;
    if (fmu_model_check(m, &problem, &row) != 0) {
        log_early(host, fmi_version, name, "%s: variable table of %s is broken at row %zu: %s",
                  fn, m->identifier, row, problem);
        return NULL;
    }

    fmu_instance *S = host->alloc(1, sizeof *S);
    const size_t name_len = strlen(name) + 1;
    char *name_copy = host->alloc(name_len, 1);
    void *data = host->alloc(1, m->data_size);
    if (S == NULL || name_copy == NULL || data == NULL) {
        log_early(host, fmi_version, name, "%s: out of memory", fn);
        host->release(S);
        host->release(name_copy);
        host->release(data);
        return NULL;
    }
    memcpy(name_copy, name, name_len);
    S->model = m;
    S->host = *host;
    S->fmi_version = fmi_version;
    S->interface = interface;
    S->name = name_copy;
    S->data = data;
    S->resources = resource_folder(host);
    S->host.resources = NULL; /* borrowed: valid during instantiation only */
    S->log_mask = logging_on ? FMU_LOG_ALL_MASK : FMU_LOG_DEFAULT_MASK;
    if (fmu_reset_instance(S) > FMU_WARNING) {
        log_early(host, fmi_version, name, "%s: %s could not set its start values", fn,
                  m->identifier);
        fmu_destroy(S);
        return NULL;
    }
    fmu_model_token(m, S->data, S->token);
    if (strcmp(token, S->token) != 0) {
        log_early(host, fmi_version, name,
                  "%s: wrong %s: %s expects \"%s\", got \"%s\" (is the modelDescription.xml "
                  "from another build?)",
                  fn, fmi_version == 3 ? "instantiationToken" : "GUID", m->identifier, S->token,
                  token);
        fmu_destroy(S);
        return NULL;
    }
    /* the token is the table's and the compiled start values'; a resources/ file of start
     * values changes the values, not the binary the XML belongs to */
    if (apply_start_file(S, fn) > FMU_WARNING) {
        fmu_destroy(S);
        return NULL;
    }
    return S;
}

void fmu_destroy(fmu_instance *S)
{
    if (S == NULL) {
        return;
    }
    void (*release)(void *) = S->host.release;
    if (S->model->release != NULL) {
        S->model->release(S);
    }
    release(S->data);
    release(S->name);
    release(S->resources);
    if (S->valid_state != NULL) {
        release(S->valid_state);
    }
    memset(S, 0, sizeof *S);
    release(S);
}

fmu_status fmu_reset_instance(fmu_instance *S)
{
    if (S->model->release != NULL) {
        S->model->release(S); /* e.g. a table read from resources/: read again when needed */
    }
    if (S->valid_state != NULL) {
        S->host.release(S->valid_state);
        S->valid_state = NULL;
    }
    memset(S->data, 0, S->model->data_size);
    S->state = FMU_INSTANTIATED;
    S->time = 0.0;
    S->start_time = 0.0;
    S->stop_time = 0.0;
    S->stop_time_defined = 0;
    S->dirty = 1;
    fmu_status st = S->model->set_defaults(S->data);
    if (st <= FMU_WARNING && S->token[0] != '\0') { /* Reset: the start values again */
        const fmu_status sf = apply_start_file(S, "Reset");
        st = sf > st ? sf : st;
    }
    return st;
}

fmu_status fmu_set_logging(fmu_instance *S, const char *fn, int on, size_t n,
                           const char *const cats[])
{
    if (n == 0) {
        S->log_mask = on ? FMU_LOG_ALL_MASK : FMU_LOG_DEFAULT_MASK;
        return FMU_OK;
    }
    if (cats == NULL) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: categories must not be NULL when nCategories = %zu", fn, n);
        return FMU_ERROR;
    }
    unsigned bits = 0;
    for (size_t i = 0; i < n; ++i) {
        unsigned bit = 0;
        if (cats[i] != NULL && strcmp(cats[i], "logAll") == 0) {
            bit = FMU_LOG_ALL_MASK;
        }
        for (unsigned k = 0; k < FMU_LOG_CATEGORY_COUNT && cats[i] != NULL; ++k) {
            if (strcmp(cats[i], fmu_log_categories[k].name) == 0) {
                bit = 1u << k;
            }
        }
        if (bit == 0u) {
            fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                    "%s: unknown log category \"%s\" (categories[%zu]); known: "
                    "logStatusWarning, logStatusDiscard, logStatusError, logStatusFatal, "
                    "logCalls, logAll",
                    fn, cats[i] ? cats[i] : "(null)", i);
            return FMU_ERROR;
        }
        bits |= bit;
    }
    S->log_mask = on ? (S->log_mask | bits) : (S->log_mask & ~bits);
    return FMU_OK;
}

/* ---- variables ------------------------------------------------------------------------------- */

int fmu_needs_update(const fmu_instance *S, const fmu_vr vr[], size_t n)
{
    if (!S->dirty) {
        return 0;
    }
    for (size_t i = 0; i < n; ++i) {
        const fmu_variable *v = fmu_find_var(S->model, vr[i]);
        if (v != NULL && v->causality == FMU_OUTPUT) {
            return 1;
        }
    }
    return 0;
}

fmu_status fmu_update(fmu_instance *S)
{
    if (!S->dirty) {
        return FMU_OK;
    }
    const fmu_status st = S->model->calculate(S);
    if (st <= FMU_WARNING) {
        S->dirty = 0;
    }
    return st;
}

/* The row of vr if it exists and has type t; logs and returns NULL otherwise. */
static const fmu_variable *typed_var(fmu_instance *S, const char *fn, fmu_type t, fmu_vr vr)
{
    const fmu_variable *v = fmu_find_var(S->model, vr);
    if (v == NULL) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: unknown value reference %u (%s has 0..%zu)", fn, (unsigned)vr,
                S->model->identifier, S->model->n_vars - 1);
        return NULL;
    }
    if (v->type != t) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "%s: variable %s (vr %u) is a %s, not a %s", fn,
                v->name, (unsigned)vr, fmu_type_name(v->type), fmu_type_name(t));
        return NULL;
    }
    return v;
}

/* Boolean i of an importer's array, and writing one, in either layout. */
static int bool_at(const void *values, size_t i, fmu_bool_layout bl)
{
    if (bl == FMU_BOOL_C99) {
        return ((const _Bool *)values)[i] ? 1 : 0;
    }
    return ((const int *)values)[i] != 0;
}

static void bool_put(void *values, size_t i, fmu_bool_layout bl, int b)
{
    if (bl == FMU_BOOL_C99) {
        ((_Bool *)values)[i] = b != 0;
    } else {
        ((int *)values)[i] = b != 0;
    }
}

fmu_status fmu_get_values(fmu_instance *S, const char *fn, fmu_type t, const fmu_vr vr[],
                          size_t n, void *values, fmu_bool_layout bl)
{
    for (size_t i = 0; i < n; ++i) {
        const fmu_variable *v = typed_var(S, fn, t, vr[i]);
        if (v == NULL) {
            return FMU_ERROR;
        }
        if (v->causality == FMU_INDEPENDENT) {
            ((double *)values)[i] = S->time;
        } else if (t == FMU_REAL) {
            memcpy((double *)values + i, fmu_var_ptr(S->data, v), sizeof(double));
        } else {
            int b;
            memcpy(&b, fmu_var_ptr(S->data, v), sizeof b);
            bool_put(values, i, bl, b);
        }
    }
    return FMU_OK;
}

/* Log why row v cannot be set now, or return 1 when it can. */
static int settable(fmu_instance *S, const char *fn, const fmu_variable *v)
{
    const unsigned allowed = fmu_settable_states(v);
    if ((allowed & (unsigned)S->state) != 0u) {
        return 1;
    }
    if (allowed == 0u) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: variable %s (vr %u) is %s and cannot be set", fn, v->name,
                (unsigned)v->vr,
                v->causality == FMU_INDEPENDENT ? "the independent variable" : "an output");
    } else {
        char states[160];
        fmu_states_str(S->fmi_version, allowed, states, sizeof states);
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: %s %s %s (vr %u) can be set in %s only, not in state %s", fn,
                fmu_variability_name(v->variability), fmu_causality_name(v->causality), v->name,
                (unsigned)v->vr, states, fmu_state_name(S->fmi_version, S->state));
    }
    return 0;
}

fmu_status fmu_set_values(fmu_instance *S, const char *fn, fmu_type t, const fmu_vr vr[],
                          size_t n, const void *values, fmu_bool_layout bl)
{
    /* check everything first: a refused call changes nothing */
    for (size_t i = 0; i < n; ++i) {
        const fmu_variable *v = typed_var(S, fn, t, vr[i]);
        if (v == NULL || !settable(S, fn, v)) {
            return FMU_ERROR;
        }
        if (t == FMU_REAL && !isfinite(((const double *)values)[i])) {
            fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                    "%s: %s (vr %u) must be finite, got %.17g; the value stays %.17g", fn,
                    v->name, (unsigned)v->vr, ((const double *)values)[i],
                    *(const double *)fmu_var_ptr(S->data, v));
            return FMU_ERROR;
        }
    }
    for (size_t i = 0; i < n; ++i) {
        const fmu_variable *v = fmu_find_var(S->model, vr[i]);
        if (t == FMU_REAL) {
            memcpy(fmu_var_ptr(S->data, v), (const double *)values + i, sizeof(double));
        } else {
            const int b = bool_at(values, i, bl);
            memcpy(fmu_var_ptr(S->data, v), &b, sizeof b);
        }
    }
    if (n > 0) {
        S->dirty = 1;
    }
    return FMU_OK;
}

/* ---- Model Exchange ----------------------------------------------------------------------------- */

fmu_status fmu_me_set_time(fmu_instance *S, const char *fn, double t)
{
    if (!isfinite(t)) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "%s: time must be finite, got %.17g; it stays %.17g",
                fn, t, S->time);
        return FMU_ERROR;
    }
    S->time = t;
    return FMU_OK;
}

static int count_ok(fmu_instance *S, const char *fn, const char *what, size_t n, size_t expected)
{
    if (n == expected) {
        return 1;
    }
    fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "%s: %s has %zu %s, got %zu", fn, S->model->identifier,
            expected, what, n);
    return 0;
}

static double *state_ptr(fmu_instance *S, fmu_vr vr)
{
    return (double *)fmu_var_ptr(S->data, fmu_find_var(S->model, vr));
}

fmu_status fmu_me_get_states(fmu_instance *S, const char *fn, double x[], size_t n)
{
    if (!count_ok(S, fn, "continuous states", n, S->model->n_states)) {
        return FMU_ERROR;
    }
    if (S->state == FMU_INIT_MODE) {
        /* the states follow the start values until initialization ends */
        const fmu_status st = fmu_update(S);
        if (st > FMU_WARNING) {
            return st;
        }
    }
    for (size_t i = 0; i < n; ++i) {
        x[i] = *state_ptr(S, S->model->states[i].state);
    }
    return FMU_OK;
}

fmu_status fmu_me_set_states(fmu_instance *S, const char *fn, const double x[], size_t n)
{
    if (!count_ok(S, fn, "continuous states", n, S->model->n_states)) {
        return FMU_ERROR;
    }
    for (size_t i = 0; i < n; ++i) {
        if (!isfinite(x[i])) {
            fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                    "%s: state %zu (%s) must be finite, got %.17g; no state was changed", fn, i,
                    fmu_find_var(S->model, S->model->states[i].state)->name, x[i]);
            return FMU_ERROR;
        }
    }
    for (size_t i = 0; i < n; ++i) {
        *state_ptr(S, S->model->states[i].state) = x[i];
    }
    if (n > 0) {
        S->dirty = 1;
    }
    return FMU_OK;
}

fmu_status fmu_me_check_count(fmu_instance *S, const char *fn, size_t n)
{
    return count_ok(S, fn, "continuous states", n, S->model->n_states) ? FMU_OK : FMU_ERROR;
}

fmu_status fmu_me_get_derivatives(fmu_instance *S, double dx[], size_t n)
{
    const fmu_status st = fmu_update(S);
    if (st > FMU_WARNING) {
        return st;
    }
    for (size_t i = 0; i < n; ++i) {
        dx[i] = *state_ptr(S, S->model->states[i].derivative);
    }
    return st;
}

fmu_status fmu_me_get_nominals(fmu_instance *S, const char *fn, double nominals[], size_t n)
{
    if (!count_ok(S, fn, "continuous states", n, S->model->n_states)) {
        return FMU_ERROR;
    }
    for (size_t i = 0; i < n; ++i) {
        nominals[i] = S->model->states[i].nominal;
    }
    return FMU_OK;
}

fmu_status fmu_me_get_event_indicators(fmu_instance *S, const char *fn, size_t n)
{
    return count_ok(S, fn, "event indicators", n, 0) ? FMU_OK : FMU_ERROR;
}

/* ---- checks the adapters share ----------------------------------------------------------------- */

int fmu_allowed_state(fmu_instance *S, unsigned mask, const char *fn)
{
    if ((mask & (unsigned)S->state) != 0u) {
        return 1;
    }
    char states[200];
    fmu_states_str(S->fmi_version, mask, states, sizeof states);
    fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
            "%s: illegal call sequence: not allowed in state %s (allowed in: %s%s%s)", fn,
            fmu_state_name(S->fmi_version, S->state), states, mask != 0u ? "" : " for ",
            mask != 0u ? ""
            : S->interface == FMU_MODEL_EXCHANGE ? "Model Exchange"
                                                  : "Co-Simulation");
    return 0;
}

fmu_status fmu_check_tolerance(fmu_instance *S, const char *fn, int defined, double tolerance)
{
    if (defined && !(isfinite(tolerance) && tolerance > 0.0)) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: tolerance must be finite and > 0 when toleranceDefined is true, got %.17g",
                fn, tolerance);
        return FMU_ERROR;
    }
    return FMU_OK;
}

fmu_status fmu_setup_experiment(fmu_instance *S, const char *fn, double start, int stop_defined,
                                double stop)
{
    if (!isfinite(start)) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "%s: startTime must be finite, got %.17g", fn, start);
        return FMU_ERROR;
    }
    if (stop_defined && !(isfinite(stop) && stop >= start)) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: stopTime must be finite and >= startTime = %.17g, got %.17g", fn, start,
                stop);
        return FMU_ERROR;
    }
    S->start_time = start;
    S->time = start;
    S->stop_time_defined = stop_defined ? 1 : 0;
    S->stop_time = stop_defined ? stop : 0.0;
    return FMU_OK;
}

fmu_status fmu_check_step(fmu_instance *S, const char *fn, double t, double h)
{
    const double tol = FMU_TIME_RTOL * fmax(1.0, fabs(S->time));
    if (!(isfinite(h) && h > 0.0)) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: communicationStepSize must be finite and > 0, got %.17g", fn, h);
        return FMU_ERROR;
    }
    if (!(fabs(t - S->time) <= tol)) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: currentCommunicationPoint %.17g differs from the FMU time %.17g "
                "(tolerance %.3g)",
                fn, t, S->time, tol);
        return FMU_ERROR;
    }
    const double end = t + h;
    if (!isfinite(end) || !(end > S->time)) {
        /* a communication point at the low end of the tolerance with a step shorter than the
         * gap would move the clock backwards; an overflow would make it infinite */
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: the step from %.17g over %.17g ends at %.17g, which is not a finite time "
                "after the FMU time %.17g",
                fn, t, h, end, S->time);
        return FMU_ERROR;
    }
    if (S->stop_time_defined && end > S->stop_time + FMU_TIME_RTOL * fmax(1.0, S->stop_time)) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "%s: the step to %.17g goes past stopTime %.17g", fn,
                end, S->stop_time);
        return FMU_ERROR;
    }
    return FMU_OK;
}

fmu_status fmu_do_step(fmu_instance *S, double t, double h)
{
    const fmu_status st = S->model->do_step(S, h);
    switch (st) {
    case FMU_OK:
    case FMU_WARNING:
        S->time = t + h; /* the master's clock is authoritative: no drift from summing h */
        S->dirty = 0;    /* do_step leaves the outputs up to date */
        break;
    case FMU_DISCARD:
        S->state = FMU_STEP_FAILED; /* time stays at the last successful point */
        break;
    case FMU_ERROR:
        S->state = FMU_ERROR_STATE;
        break;
    case FMU_FATAL:
        S->state = FMU_FATAL_STATE;
        break;
    }
    return st;
}

fmu_status fmu_exit_initialization(fmu_instance *S)
{
    fmu_status st = S->model->initialize(S);
    if (st <= FMU_WARNING) {
        S->state = S->interface == FMU_MODEL_EXCHANGE || S->event_mode_used ? FMU_EVENT_MODE
                                                                             : FMU_STEP_MODE;
        S->dirty = 1;
        const fmu_status su = fmu_update(S);
        st = su > st ? su : st;
        if (st <= FMU_WARNING && S->event_mode_used) {
            S->model->bus->glue->enter_event_mode(S); /* what the node sends at the start */
        }
    }
    if (st >= FMU_FATAL) {
        S->state = FMU_FATAL_STATE;
    } else if (st >= FMU_DISCARD) {
        S->state = FMU_ERROR_STATE;
        st = FMU_ERROR;
    }
    return st;
}

/* ---- FMU state snapshots ----------------------------------------------------------------------
 * A snapshot is one block: header, instance fields, model data. Serialising copies the block;
 * deserialising checks the magic, format version, model (hash of the token), total size and a
 * checksum of everything after the header. The bytes are native (same binary, same platform).
 */

#define FMU_SNAPSHOT_MAGIC 0x53525252u /* "RRRS" little-endian */
#define FMU_SNAPSHOT_VERSION 1u

typedef struct snapshot_header {
    uint32_t magic;       /* FMU_SNAPSHOT_MAGIC */
    uint32_t version;     /* FMU_SNAPSHOT_VERSION */
    uint64_t size;        /* bytes of the whole block */
    uint64_t model_hash;  /* FNV-1a of the instantiation token */
    uint64_t checksum;    /* FNV-1a of the bytes after the header */
} snapshot_header;

typedef struct snapshot_fields {
    uint32_t state;
    int32_t dirty;
    int32_t stop_time_defined;
    uint32_t reserved;
    double time;
    double start_time;
    double stop_time;
} snapshot_fields;

/* States a snapshot may hold (those in which one may be taken). */
#define SNAPSHOT_STATES                                                                       \
    (FMU_INSTANTIATED | FMU_INIT_MODE | FMU_EVENT_MODE | FMU_CONT_TIME_MODE | FMU_STEP_MODE |    \
     FMU_STEP_FAILED | FMU_STEP_CANCELED | FMU_TERMINATED | FMU_ERROR_STATE)

static size_t snapshot_size(const fmu_instance *S)
{
    return sizeof(snapshot_header) + sizeof(snapshot_fields) + S->model->data_size;
}

/* The model, the FMI version and the interface type: a snapshot of an FMI 2 Co-Simulation
 * instance is refused by an FMI 3 or a Model Exchange instance of the same model. */
static uint64_t model_hash(const fmu_instance *S)
{
    const unsigned char kind[2] = {(unsigned char)S->fmi_version, (unsigned char)S->interface};
    return fmu_fnv1a(fmu_fnv1a(FMU_FNV_OFFSET, S->token, strlen(S->token)), kind, sizeof kind);
}

static uint64_t payload_checksum(const unsigned char *block, size_t size)
{
    return fmu_fnv1a(FMU_FNV_OFFSET, block + sizeof(snapshot_header),
                     size - sizeof(snapshot_header));
}

/* The machine states a snapshot of an instance of this interface type may hold: those it can
 * enter and take a snapshot in (StepCanceled and StepInProgress are never entered). */
static unsigned snapshot_states(const fmu_instance *S)
{
    const unsigned shared = FMU_INSTANTIATED | FMU_INIT_MODE | FMU_TERMINATED | FMU_ERROR_STATE;
    const unsigned cs = FMU_STEP_MODE | FMU_STEP_FAILED | (S->event_mode_used ? FMU_EVENT_MODE : 0u);
    return shared | (S->interface == FMU_MODEL_EXCHANGE ? (FMU_EVENT_MODE | FMU_CONT_TIME_MODE)
                                                         : cs);
}

/* Every field of a snapshot whose header and checksum are right, against the model: the
 * instance fields, each table row (Reals finite, Booleans 0 or 1), then the model's own checks
 * (check_state hook). The checksum only detects accidents: the bytes may have been forged.
 * 0 when the state is one this instance could have been in; logs the field otherwise. */
static int snapshot_validate(fmu_instance *S, const char *fn, const snapshot_fields *f,
                             const unsigned char *data)
{
    const fmu_model *m = S->model;
    if ((f->state & snapshot_states(S)) == 0u) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: the FMU state holds the machine state %s, which a %s instance is never in",
                fn, fmu_state_name(S->fmi_version, (fmu_state)f->state),
                S->interface == FMU_MODEL_EXCHANGE ? "Model Exchange" : "Co-Simulation");
        return 1;
    }
    if ((f->dirty != 0 && f->dirty != 1) || (f->stop_time_defined != 0 &&
                                              f->stop_time_defined != 1) || f->reserved != 0u) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: the FMU state holds invalid flags (dirty %d, stop time defined %d, reserved "
                "%u; each must be 0 or 1, reserved 0)",
                fn, (int)f->dirty, (int)f->stop_time_defined, (unsigned)f->reserved);
        return 1;
    }
    if (!isfinite(f->time) || !isfinite(f->start_time) || !isfinite(f->stop_time) ||
        (f->stop_time_defined && !(f->stop_time >= f->start_time))) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: the FMU state holds an invalid time (time %.17g, start time %.17g, stop time "
                "%.17g%s): each must be finite, the stop time not before the start time",
                fn, f->time, f->start_time, f->stop_time,
                f->stop_time_defined ? "" : " undefined");
        return 1;
    }
    for (size_t i = 0; i < m->n_vars; ++i) {
        const fmu_variable *v = &m->vars[i];
        if (v->causality == FMU_INDEPENDENT) {
            continue;
        }
        if (v->type == FMU_REAL) {
            double x;
            memcpy(&x, data + v->offset, sizeof x);
            if (!isfinite(x)) {
                fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                        "%s: the FMU state holds %s = %.17g: every Real must be finite", fn,
                        v->name, x);
                return 1;
            }
        } else {
            int b;
            memcpy(&b, data + v->offset, sizeof b);
            if (b != 0 && b != 1) {
                fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                        "%s: the FMU state holds the Boolean %s = %d: it must be 0 or 1", fn,
                        v->name, b);
                return 1;
            }
        }
    }
    if (m->bus != NULL && m->bus->glue->check_state(S, data, fn) != FMU_OK) {
        return 1;
    }
    if (m->check_state != NULL &&
        m->check_state(S, data, (fmu_state)f->state, fn) != FMU_OK) {
        return 1;
    }
    return 0;
}

/* 0 when the n bytes at block are a snapshot of this model; logs the reason otherwise. With
 * deep nonzero (a state that is about to be restored or was passed in as bytes) every field is
 * validated as well (snapshot_validate). */
static int snapshot_check(fmu_instance *S, const char *fn, const unsigned char *block, size_t n,
                          int deep)
{
    snapshot_header h;
    snapshot_fields f;
    if (block == NULL || n < sizeof h + sizeof f) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: not an FMU state of %s (%zu bytes, need at least %zu)", fn,
                S->model->identifier, n, sizeof h + sizeof f);
        return 1;
    }
    memcpy(&h, block, sizeof h);
    memcpy(&f, block + sizeof h, sizeof f);
    if (h.magic != FMU_SNAPSHOT_MAGIC) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: not an FMU state of %s (magic 0x%08x, expected 0x%08x)", fn,
                S->model->identifier, (unsigned)h.magic, FMU_SNAPSHOT_MAGIC);
        return 1;
    }
    if (h.version != FMU_SNAPSHOT_VERSION) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "%s: FMU state format version %u, expected %u", fn,
                (unsigned)h.version, FMU_SNAPSHOT_VERSION);
        return 1;
    }
    if (h.model_hash != model_hash(S)) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: the FMU state belongs to another model, build, FMI version or interface "
                "type (hash differs from %s %s, FMI %d %s)",
                fn, S->model->identifier, S->token, S->fmi_version,
                S->interface == FMU_MODEL_EXCHANGE ? "Model Exchange" : "Co-Simulation");
        return 1;
    }
    if (h.size != n || n != snapshot_size(S)) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: FMU state size %zu (header says %llu), expected %zu", fn, n,
                (unsigned long long)h.size, snapshot_size(S));
        return 1;
    }
    if (h.checksum != payload_checksum(block, n)) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "%s: FMU state checksum mismatch (corrupted bytes)",
                fn);
        return 1;
    }
    if (f.state == 0u || (f.state & (f.state - 1u)) != 0u || (f.state & SNAPSHOT_STATES) == 0u) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "%s: FMU state holds an invalid machine state 0x%x",
                fn, (unsigned)f.state);
        return 1;
    }
    if (deep) {
        const size_t payload = n - sizeof h;
        if (S->valid_state != NULL && memcmp(S->valid_state, block + sizeof h, payload) == 0) {
            return 0; /* these very bytes passed before */
        }
        if (snapshot_validate(S, fn, &f, block + sizeof h + sizeof f) != 0) {
            return 1;
        }
        if (S->valid_state == NULL) {
            S->valid_state = S->host.alloc(1, payload); /* NULL: no memory, no cache */
        }
        if (S->valid_state != NULL) {
            memcpy(S->valid_state, block + sizeof h, payload);
        }
    }
    return 0;
}

static void snapshot_fill(const fmu_instance *S, unsigned char *block)
{
    const size_t n = snapshot_size(S);
    snapshot_fields f;
    memset(&f, 0, sizeof f);
    f.state = (uint32_t)S->state;
    f.dirty = S->dirty;
    f.stop_time_defined = S->stop_time_defined;
    f.time = S->time;
    f.start_time = S->start_time;
    f.stop_time = S->stop_time;
    memcpy(block + sizeof(snapshot_header), &f, sizeof f);
    memcpy(block + sizeof(snapshot_header) + sizeof f, S->data, S->model->data_size);
    snapshot_header h;
    h.magic = FMU_SNAPSHOT_MAGIC;
    h.version = FMU_SNAPSHOT_VERSION;
    h.size = n;
    h.model_hash = model_hash(S);
    h.checksum = payload_checksum(block, n);
    memcpy(block, &h, sizeof h);
}

fmu_status fmu_snapshot_get(fmu_instance *S, const char *fn, void **state)
{
    const size_t n = snapshot_size(S);
    unsigned char *block = *state;
    if (block != NULL) {
        /* overwrite a snapshot the importer got from us before: it must be ours */
        snapshot_header h;
        memcpy(&h, block, sizeof h);
        if (h.magic != FMU_SNAPSHOT_MAGIC || h.model_hash != model_hash(S) || h.size != n) {
            fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                    "%s: *FMUstate is neither NULL nor an FMU state of %s", fn,
                    S->model->identifier);
            return FMU_ERROR;
        }
    } else {
        block = S->host.alloc(1, n);
        if (block == NULL) {
            fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "%s: out of memory (%zu bytes)", fn, n);
            return FMU_ERROR;
        }
    }
    snapshot_fill(S, block);
    *state = block;
    return FMU_OK;
}

fmu_status fmu_snapshot_set(fmu_instance *S, const char *fn, const void *state)
{
    const unsigned char *block = state;
    snapshot_header h;
    if (block == NULL) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "%s: FMUstate must not be NULL", fn);
        return FMU_ERROR;
    }
    memcpy(&h, block, sizeof h);
    if (h.magic != FMU_SNAPSHOT_MAGIC || h.size != snapshot_size(S)) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "%s: not an FMU state of %s", fn,
                S->model->identifier);
        return FMU_ERROR;
    }
    if (snapshot_check(S, fn, block, (size_t)h.size, 1) != 0) {
        return FMU_ERROR;
    }
    snapshot_fields f;
    memcpy(&f, block + sizeof h, sizeof f);
    S->state = (fmu_state)f.state;
    S->dirty = f.dirty;
    S->stop_time_defined = f.stop_time_defined;
    S->time = f.time;
    S->start_time = f.start_time;
    S->stop_time = f.stop_time;
    memcpy(S->data, block + sizeof h + sizeof f, S->model->data_size);
    return FMU_OK;
}

fmu_status fmu_snapshot_free(fmu_instance *S, const char *fn, void **state)
{
    if (*state == NULL) {
        return FMU_OK;
    }
    snapshot_header h;
    memcpy(&h, *state, sizeof h);
    if (h.magic != FMU_SNAPSHOT_MAGIC || h.model_hash != model_hash(S)) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: *FMUstate is not an FMU state of %s; not freed", fn,
                S->model->identifier);
        return FMU_ERROR;
    }
    h.magic = 0u; /* a second free of the same block is then refused, not executed */
    memcpy(*state, &h, sizeof h);
    S->host.release(*state);
    *state = NULL;
    return FMU_OK;
}

fmu_status fmu_snapshot_size(fmu_instance *S, const char *fn, const void *state, size_t *size)
{
    if (state == NULL) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "%s: FMUstate must not be NULL", fn);
        return FMU_ERROR;
    }
    if (snapshot_check(S, fn, state, snapshot_size(S), 0) != 0) {
        return FMU_ERROR;
    }
    *size = snapshot_size(S);
    return FMU_OK;
}

fmu_status fmu_snapshot_serialize(fmu_instance *S, const char *fn, const void *state,
                                  unsigned char buf[], size_t size)
{
    const size_t n = snapshot_size(S);
    if (state == NULL) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "%s: FMUstate must not be NULL", fn);
        return FMU_ERROR;
    }
    if (snapshot_check(S, fn, state, n, 0) != 0) {
        return FMU_ERROR;
    }
    if (size < n) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: buffer of %zu bytes is too small, need %zu", fn, size, n);
        return FMU_ERROR;
    }
    memcpy(buf, state, n);
    return FMU_OK;
}

fmu_status fmu_snapshot_deserialize(fmu_instance *S, const char *fn, const unsigned char buf[],
                                    size_t size, void **state)
{
    if (snapshot_check(S, fn, buf, size, 1) != 0) {
        return FMU_ERROR;
    }
    unsigned char *block = *state;
    if (block != NULL) {
        /* reuse a snapshot the importer got from us before (FMI 2.0: it may pass one) */
        snapshot_header h;
        memcpy(&h, block, sizeof h);
        if (h.magic != FMU_SNAPSHOT_MAGIC || h.model_hash != model_hash(S) || h.size != size) {
            fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                    "%s: *FMUstate is neither NULL nor an FMU state of %s", fn,
                    S->model->identifier);
            return FMU_ERROR;
        }
    } else {
        block = S->host.alloc(1, size);
        if (block == NULL) {
            fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "%s: out of memory (%zu bytes)", fn, size);
            return FMU_ERROR;
        }
    }
    memcpy(block, buf, size);
    *state = block;
    return FMU_OK;
}
