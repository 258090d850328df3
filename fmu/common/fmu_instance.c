/*
 * Instances: creation, logging, table-driven get/set, FMU state snapshots.
 * The FMI state machine lives in fmi2_functions.c; nothing here checks call sequences.
 */
#include <math.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "fmu_internal.h"

/* ---- logging --------------------------------------------------------------------------------- */

void fmu_log(const fmu_instance *inst, fmu_status status, fmu_category category, const char *fmt,
             ...)
{
    if (inst == NULL || inst->cb.logger == NULL || (unsigned)category >= FMU_LOG_CATEGORY_COUNT ||
        (inst->log_mask & (1u << category)) == 0u) {
        return;
    }
    char buf[1024];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    /* the logger formats like printf: pass the text as an argument, never as the format */
    inst->cb.logger(inst->cb.componentEnvironment, inst->name, (fmi2Status)status,
                    fmu_log_categories[category].name, "%s", buf);
}

/* Before an instance exists (fmi2Instantiate failures). */
#if defined(__GNUC__)
__attribute__((format(printf, 3, 4)))
#endif
static void log_early(const fmi2CallbackFunctions *f, fmi2String name, const char *fmt, ...)
{
    if (f == NULL || f->logger == NULL) {
        return;
    }
    char buf[512];
    va_list ap;
    va_start(ap, fmt);
    vsnprintf(buf, sizeof buf, fmt, ap);
    va_end(ap);
    f->logger(f->componentEnvironment, name ? name : "?", fmi2Error,
              fmu_log_categories[FMU_LOG_ERROR].name, "%s", buf);
}

/* ---- lifecycle ------------------------------------------------------------------------------- */

fmu_instance *fmu_create(fmi2String name, fmi2Type type, fmi2String guid,
                         const fmi2CallbackFunctions *functions, fmi2Boolean logging_on)
{
    const fmu_model *m = &FMU_MODEL;
    if (functions == NULL || functions->allocateMemory == NULL || functions->freeMemory == NULL) {
        log_early(functions, name,
                  "fmi2Instantiate: functions, functions->allocateMemory and "
                  "functions->freeMemory must not be NULL");
        return NULL;
    }
    if (name == NULL || name[0] == '\0') {
        log_early(functions, name, "fmi2Instantiate: instanceName must be a non-empty string");
        return NULL;
    }
    if (type != fmi2CoSimulation) {
        log_early(functions, name,
                  "fmi2Instantiate: %s supports fmuType fmi2CoSimulation (%d) only, got %d",
                  m->identifier, (int)fmi2CoSimulation, (int)type);
        return NULL;
    }
    if (guid == NULL) {
        log_early(functions, name, "fmi2Instantiate: fmuGUID must not be NULL");
        return NULL;
    }
    const char *problem = NULL;
    size_t row = 0;
    if (fmu_model_check(m, &problem, &row) != 0) {
        log_early(functions, name, "fmi2Instantiate: variable table of %s is broken at row %zu: %s",
                  m->identifier, row, problem);
        return NULL;
    }

    fmu_instance *S = functions->allocateMemory(1, sizeof *S);
    const size_t name_len = strlen(name) + 1;
    char *name_copy = functions->allocateMemory(name_len, 1);
    void *data = functions->allocateMemory(1, m->data_size);
    if (S == NULL || name_copy == NULL || data == NULL) {
        log_early(functions, name, "fmi2Instantiate: out of memory");
        functions->freeMemory(S);
        functions->freeMemory(name_copy);
        functions->freeMemory(data);
        return NULL;
    }
    memcpy(name_copy, name, name_len);
    S->model = m;
    S->cb = *functions;
    S->name = name_copy;
    S->data = data;
    S->log_mask = logging_on ? FMU_LOG_ALL_MASK : FMU_LOG_DEFAULT_MASK;
    if (fmu_reset_instance(S) > FMU_WARNING) {
        log_early(functions, name, "fmi2Instantiate: %s could not set its start values",
                  m->identifier);
        fmu_destroy(S);
        return NULL;
    }
    fmu_model_token(m, S->data, S->token);
    if (strcmp(guid, S->token) != 0) {
        log_early(functions, name,
                  "fmi2Instantiate: wrong GUID: %s expects \"%s\", got \"%s\" (is the "
                  "modelDescription.xml from another build?)",
                  m->identifier, S->token, guid);
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
    const fmi2CallbackFreeMemory release = S->cb.freeMemory;
    release(S->data);
    release(S->name);
    memset(S, 0, sizeof *S);
    release(S);
}

fmu_status fmu_reset_instance(fmu_instance *S)
{
    memset(S->data, 0, S->model->data_size);
    S->state = FMU_INSTANTIATED;
    S->time = 0.0;
    S->start_time = 0.0;
    S->stop_time = 0.0;
    S->stop_time_defined = 0;
    S->dirty = 1;
    return S->model->set_defaults(S->data);
}

fmu_status fmu_set_logging(fmu_instance *S, fmi2Boolean on, size_t n, const fmi2String cats[])
{
    if (n == 0) {
        S->log_mask = on ? FMU_LOG_ALL_MASK : FMU_LOG_DEFAULT_MASK;
        return FMU_OK;
    }
    if (cats == NULL) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "fmi2SetDebugLogging: categories must not be NULL when nCategories = %zu", n);
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
                    "fmi2SetDebugLogging: unknown log category \"%s\" (categories[%zu]); known: "
                    "logStatusWarning, logStatusDiscard, logStatusError, logStatusFatal, "
                    "logCalls, logAll",
                    cats[i] ? cats[i] : "(null)", i);
            return FMU_ERROR;
        }
        bits |= bit;
    }
    S->log_mask = on ? (S->log_mask | bits) : (S->log_mask & ~bits);
    return FMU_OK;
}

/* ---- variables ------------------------------------------------------------------------------- */

int fmu_needs_update(const fmu_instance *S, const fmi2ValueReference vr[], size_t n)
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
static const fmu_variable *typed_var(fmu_instance *S, const char *fn, fmu_type t,
                                     fmi2ValueReference vr)
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

fmu_status fmu_get_values(fmu_instance *S, const char *fn, fmu_type t,
                          const fmi2ValueReference vr[], size_t n, void *values)
{
    for (size_t i = 0; i < n; ++i) {
        const fmu_variable *v = typed_var(S, fn, t, vr[i]);
        if (v == NULL) {
            return FMU_ERROR;
        }
        if (t == FMU_REAL) {
            memcpy((double *)values + i, fmu_var_ptr(S->data, v), sizeof(double));
        } else {
            int b;
            memcpy(&b, fmu_var_ptr(S->data, v), sizeof b);
            ((fmi2Boolean *)values)[i] = b ? fmi2True : fmi2False;
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
                "%s: variable %s (vr %u) is an %s and cannot be set", fn, v->name,
                (unsigned)v->vr, fmu_causality_name(v->causality));
    } else {
        char states[128];
        fmu_states_str(allowed, states, sizeof states);
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: %s %s %s (vr %u) can be set in %s only, not in state %s", fn,
                fmu_variability_name(v->variability), fmu_causality_name(v->causality), v->name,
                (unsigned)v->vr, states, fmu_state_name(S->state));
    }
    return 0;
}

fmu_status fmu_set_values(fmu_instance *S, const char *fn, fmu_type t,
                          const fmi2ValueReference vr[], size_t n, const void *values)
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
            const int b = ((const fmi2Boolean *)values)[i] != fmi2False;
            memcpy(fmu_var_ptr(S->data, v), &b, sizeof b);
        }
    }
    if (n > 0) {
        S->dirty = 1;
    }
    return FMU_OK;
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

/* States in which a snapshot may be taken (FMI 2.0.4 table in 4.2.4). */
#define SNAPSHOT_STATES                                                                       \
    (FMU_INSTANTIATED | FMU_INIT_MODE | FMU_STEP_COMPLETE | FMU_STEP_FAILED | FMU_STEP_CANCELED | \
     FMU_TERMINATED | FMU_ERROR_STATE)

static size_t snapshot_size(const fmu_instance *S)
{
    return sizeof(snapshot_header) + sizeof(snapshot_fields) + S->model->data_size;
}

static uint64_t model_hash(const fmu_instance *S)
{
    return fmu_fnv1a(FMU_FNV_OFFSET, S->token, strlen(S->token));
}

static uint64_t payload_checksum(const unsigned char *block, size_t size)
{
    return fmu_fnv1a(FMU_FNV_OFFSET, block + sizeof(snapshot_header),
                     size - sizeof(snapshot_header));
}

/* 0 when the n bytes at block are a snapshot of this model; logs the reason otherwise. */
static int snapshot_check(fmu_instance *S, const char *fn, const unsigned char *block, size_t n)
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
                "%s: the FMU state belongs to another model or build (GUID hash differs from "
                "%s %s)",
                fn, S->model->identifier, S->token);
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

fmu_status fmu_snapshot_get(fmu_instance *S, fmi2FMUstate *state)
{
    const size_t n = snapshot_size(S);
    unsigned char *block = *state;
    if (block != NULL) {
        /* overwrite a snapshot the importer got from us before: it must be ours */
        snapshot_header h;
        memcpy(&h, block, sizeof h);
        if (h.magic != FMU_SNAPSHOT_MAGIC || h.model_hash != model_hash(S) || h.size != n) {
            fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                    "fmi2GetFMUstate: *FMUstate is neither NULL nor an FMU state of %s",
                    S->model->identifier);
            return FMU_ERROR;
        }
    } else {
        block = S->cb.allocateMemory(1, n);
        if (block == NULL) {
            fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "fmi2GetFMUstate: out of memory (%zu bytes)", n);
            return FMU_ERROR;
        }
    }
    snapshot_fill(S, block);
    *state = block;
    return FMU_OK;
}

fmu_status fmu_snapshot_set(fmu_instance *S, fmi2FMUstate state)
{
    const unsigned char *block = state;
    snapshot_header h;
    if (block == NULL) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "fmi2SetFMUstate: FMUstate must not be NULL");
        return FMU_ERROR;
    }
    memcpy(&h, block, sizeof h);
    if (h.magic != FMU_SNAPSHOT_MAGIC || h.size != snapshot_size(S)) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "fmi2SetFMUstate: not an FMU state of %s",
                S->model->identifier);
        return FMU_ERROR;
    }
    if (snapshot_check(S, "fmi2SetFMUstate", block, (size_t)h.size) != 0) {
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

fmu_status fmu_snapshot_free(fmu_instance *S, fmi2FMUstate *state)
{
    if (*state == NULL) {
        return FMU_OK;
    }
    snapshot_header h;
    memcpy(&h, *state, sizeof h);
    if (h.magic != FMU_SNAPSHOT_MAGIC || h.model_hash != model_hash(S)) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "fmi2FreeFMUstate: *FMUstate is not an FMU state of %s; not freed",
                S->model->identifier);
        return FMU_ERROR;
    }
    h.magic = 0u; /* a second free of the same block is then refused, not executed */
    memcpy(*state, &h, sizeof h);
    S->cb.freeMemory(*state);
    *state = NULL;
    return FMU_OK;
}

fmu_status fmu_snapshot_size(fmu_instance *S, fmi2FMUstate state, size_t *size)
{
    if (state == NULL) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "fmi2SerializedFMUstateSize: FMUstate must not be NULL");
        return FMU_ERROR;
    }
    if (snapshot_check(S, "fmi2SerializedFMUstateSize", state, snapshot_size(S)) != 0) {
        return FMU_ERROR;
    }
    *size = snapshot_size(S);
    return FMU_OK;
}

fmu_status fmu_snapshot_serialize(fmu_instance *S, fmi2FMUstate state, fmi2Byte buf[],
                                  size_t size)
{
    const size_t n = snapshot_size(S);
    if (state == NULL) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "fmi2SerializeFMUstate: FMUstate must not be NULL");
        return FMU_ERROR;
    }
    if (snapshot_check(S, "fmi2SerializeFMUstate", state, n) != 0) {
        return FMU_ERROR;
    }
    if (size < n) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "fmi2SerializeFMUstate: buffer of %zu bytes is too small, need %zu", size, n);
        return FMU_ERROR;
    }
    memcpy(buf, state, n);
    return FMU_OK;
}

fmu_status fmu_snapshot_deserialize(fmu_instance *S, const fmi2Byte buf[], size_t size,
                                    fmi2FMUstate *state)
{
    if (snapshot_check(S, "fmi2DeSerializeFMUstate", (const unsigned char *)buf, size) != 0) {
        return FMU_ERROR;
    }
    unsigned char *block = *state;
    if (block != NULL) {
        /* reuse a snapshot the importer got from us before (FMI 2.0: it may pass one) */
        snapshot_header h;
        memcpy(&h, block, sizeof h);
        if (h.magic != FMU_SNAPSHOT_MAGIC || h.model_hash != model_hash(S) || h.size != size) {
            fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                    "fmi2DeSerializeFMUstate: *FMUstate is neither NULL nor an FMU state of %s",
                    S->model->identifier);
            return FMU_ERROR;
        }
    } else {
        block = S->cb.allocateMemory(1, size);
        if (block == NULL) {
            fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                    "fmi2DeSerializeFMUstate: out of memory (%zu bytes)", size);
            return FMU_ERROR;
        }
    }
    memcpy(block, buf, size);
    *state = block;
    return FMU_OK;
}
