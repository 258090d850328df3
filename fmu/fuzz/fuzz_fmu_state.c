/*
 * Fuzz target of the FMU state readers: forged FMU states WITH VALID CHECKSUMS fed to one FMU
 * (the model this file is compiled with: FUZZ_MODEL_DIR's model.c, both FMI adapters linked in),
 * through the FMI API as an importer calls it: fmi2DeSerializeFMUstate / fmi3DeserializeFMUState,
 * then fmi2SetFMUstate / fmi3SetFMUState, then the calls that use the restored data (every Real
 * read, a doStep, the derivatives). The checksum is no secret, so every field of a state is
 * untrusted input: a forged state must be refused with Error (and change nothing) or be a state
 * the FMU can run; ASan and UBSan watch the rest.
 *
 * Input layout: byte 0 selects the instance: bit 0 the FMI version (0: 2.0, 1: 3.0), bit 1 the
 * interface (0: Co-Simulation, 1: Model Exchange), bit 2 the state forged from (0: one taken
 * after initialization and a step, 1: one taken before initialization). Then records of 11
 * bytes, each one write into the state's payload (everything after the header): word (2 bytes,
 * little-endian: an 8-byte word of the payload, modulo their number), op, value (8 bytes).
 * op & 7: 0 the value's bytes, 1 NaN, 2 +Inf, 3 -Inf, 4 the double (int8) value[0], 5 all ones
 * (2^64 - 1), 6 the value's low 4 bytes into the word's low half, 7 into its high half; op & 8:
 * XOR instead of overwrite. The checksum is recomputed after the writes.
 *
 * Invariants (a violation traps): a refused state leaves the instance as it was; a state that
 * DeserializeFMUState accepts, SetFMUState accepts too; after an accepted state every Real that
 * GetReal/GetFloat64 returns with OK is finite, and a doStep or GetDerivatives that returns OK
 * gives finite values.
 *
 * libFuzzer (clang):  cmake -DRRR_FMU_FUZZ=ON -DCMAKE_C_COMPILER=clang ...; ./fuzz_fmu_state_<model>
 * Without clang, tests/c/test_fmu_state_fuzz_smoke.c drives the same function with random and
 * targeted inputs (CTest, under ASan and UBSan with any compiler).
 */
#include "config.h" /* the model's: first (fmu_model.h) */

#include <math.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmi2Functions.h"
#include "fmi3Functions.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#ifndef FUZZ_RESOURCES_DIR
#define FUZZ_RESOURCES_DIR FUZZ_MODEL_DIR "/resources"
#endif

#define HEADER 32u      /* the state's header (fmu_instance.c): magic .. checksum */
#define CHECKSUM_AT 24u
#define RECORD 11u
#define MAX_VARS 256u

static void log2_discard(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status,
                         fmi2String category, fmi2String message, ...)
{
    (void)env;
    (void)name;
    (void)status;
    (void)category;
    (void)message;
}

static void log3_discard(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category,
                         fmi3String message)
{
    (void)env;
    (void)status;
    (void)category;
    (void)message;
}

static const fmi2CallbackFunctions callbacks2 = {log2_discard, calloc, free, NULL, NULL};

/* One instance per (version, interface), with the bytes of a state taken after initialization and
 * a step (post) and of one taken at instantiation (pre). */
typedef struct slot {
    void *c;
    unsigned char *post, *pre;
    size_t n;
} slot;

static slot slots[2][2];
static char token[64];
static char uri[1200], path[1200];

/* The instantiation token: computed from the table and the start values (fmu_model_token), the
 * same for both versions. */
static void token_of_model(void)
{
    void *d = calloc(1, FMU_MODEL.data_size);
    if (d == NULL || FMU_MODEL.set_defaults(d) != FMU_OK) {
        __builtin_trap();
    }
    fmu_model_token(&FMU_MODEL, d, token);
    free(d);
}

static unsigned char *bytes_of(int v3, void *c, size_t *n)
{
    unsigned char *buf = NULL;
    if (v3) {
        fmi3FMUState s = NULL;
        if (fmi3GetFMUState(c, &s) == fmi3OK && fmi3SerializedFMUStateSize(c, s, n) == fmi3OK) {
            buf = malloc(*n);
            if (buf == NULL || fmi3SerializeFMUState(c, s, buf, *n) != fmi3OK) {
                __builtin_trap();
            }
        }
        fmi3FreeFMUState(c, &s);
    } else {
        fmi2FMUstate s = NULL;
        if (fmi2GetFMUstate(c, &s) == fmi2OK && fmi2SerializedFMUstateSize(c, s, n) == fmi2OK) {
            buf = malloc(*n);
            if (buf == NULL || fmi2SerializeFMUstate(c, s, (fmi2Byte *)buf, *n) != fmi2OK) {
                __builtin_trap();
            }
        }
        fmi2FreeFMUstate(c, &s);
    }
    if (buf == NULL) {
        __builtin_trap();
    }
    return buf;
}

static void *instantiate(int v3, int me)
{
    if (v3) {
        return me ? fmi3InstantiateModelExchange("fuzz", token, path, false, false, NULL,
                                                 log3_discard)
                  : fmi3InstantiateCoSimulation("fuzz", token, path, false, false, false, false,
                                                NULL, 0, NULL, log3_discard, NULL);
    }
    return fmi2Instantiate("fuzz", me ? fmi2ModelExchange : fmi2CoSimulation, token, uri,
                           &callbacks2, fmi2False, fmi2False);
}

/* Initialize, and take a step (Co-Simulation) or enter continuous-time mode (Model Exchange). */
static void initialize(int v3, int me, void *c)
{
    int ok;
    if (v3) {
        ok = fmi3EnterInitializationMode(c, false, 0.0, 0.0, false, 0.0) == fmi3OK &&
             fmi3ExitInitializationMode(c) == fmi3OK;
        if (ok && me) {
            ok = fmi3EnterContinuousTimeMode(c) == fmi3OK;
        } else if (ok) {
            bool event = false, terminate = false, early = false;
            double last = 0.0;
            ok = fmi3DoStep(c, 0.0, 1e-3, true, &event, &terminate, &early, &last) == fmi3OK;
        }
    } else {
        ok = fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2False, 0.0) == fmi2OK &&
             fmi2EnterInitializationMode(c) == fmi2OK && fmi2ExitInitializationMode(c) == fmi2OK;
        if (ok && me) {
            ok = fmi2EnterContinuousTimeMode(c) == fmi2OK;
        } else if (ok) {
            ok = fmi2DoStep(c, 0.0, 1e-3, fmi2True) == fmi2OK;
        }
    }
    if (!ok) {
        __builtin_trap();
    }
}

static void setup(void)
{
    static int done = 0;
    if (done) {
        return;
    }
    done = 1;
    token_of_model();
    /* the model's resources/ in the source tree (the reference FMU's table; the LS-BUS
     * controller's comes from the reference FMU's folder: FUZZ_RESOURCES_DIR) */
    snprintf(uri, sizeof uri, "file://%s", FUZZ_RESOURCES_DIR);
    snprintf(path, sizeof path, "%s/", FUZZ_RESOURCES_DIR);
    for (int v3 = 0; v3 < 2; ++v3) {
        for (int me = 0; me < 2; ++me) {
            slot *s = &slots[v3][me];
            void *fresh = instantiate(v3, me);
            s->c = instantiate(v3, me);
            if (fresh == NULL || s->c == NULL) {
                __builtin_trap();
            }
            s->pre = bytes_of(v3, fresh, &s->n);
            if (v3) {
                fmi3FreeInstance(fresh);
            } else {
                fmi2FreeInstance(fresh);
            }
            initialize(v3, me, s->c);
            size_t n = 0;
            s->post = bytes_of(v3, s->c, &n);
            if (n != s->n) {
                __builtin_trap();
            }
        }
    }
}

static uint64_t fnv1a(const unsigned char *p, size_t n)
{
    uint64_t h = 14695981039346656037ull;
    for (size_t i = 0; i < n; ++i) {
        h = (h ^ p[i]) * 1099511628211ull;
    }
    return h;
}

/* Apply the records to a copy of the good state and reseal it. */
static void forge(unsigned char *buf, size_t n, const uint8_t *rec, size_t n_rec)
{
    const size_t words = (n - HEADER) / 8u;
    for (size_t r = 0; r < n_rec; ++r, rec += RECORD) {
        const size_t at = HEADER + 8u * ((size_t)(rec[0] | (rec[1] << 8)) % words);
        const unsigned op = rec[2];
        uint64_t v;
        memcpy(&v, rec + 3, sizeof v);
        uint64_t old;
        memcpy(&old, buf + at, sizeof old);
        double d;
        switch (op & 7u) {
        case 1: d = (double)NAN; memcpy(&v, &d, sizeof v); break;
        case 2: d = (double)INFINITY; memcpy(&v, &d, sizeof v); break;
        case 3: d = -(double)INFINITY; memcpy(&v, &d, sizeof v); break;
        case 4: d = (double)(int8_t)rec[3]; memcpy(&v, &d, sizeof v); break;
        case 5: v = UINT64_MAX; break;
        case 6: v = (old & 0xFFFFFFFF00000000ull) | (v & 0xFFFFFFFFull); break;
        case 7: v = (old & 0xFFFFFFFFull) | (v << 32); break;
        default: break;
        }
        if (op & 8u) {
            v ^= old;
        }
        memcpy(buf + at, &v, sizeof v);
    }
    const uint64_t h = fnv1a(buf + HEADER, n - HEADER);
    memcpy(buf + CHECKSUM_AT, &h, sizeof h);
}

/* Every Real of the table read at once: OK means finite. */
static void read_all(int v3, void *c)
{
    fmu_vr vr[MAX_VARS];
    double x[MAX_VARS];
    size_t n = 0;
    for (size_t i = 0; i < FMU_MODEL.n_vars && n < MAX_VARS; ++i) {
        if (FMU_MODEL.vars[i].type == FMU_REAL) {
            vr[n++] = FMU_MODEL.vars[i].vr;
        }
    }
    const int ok = v3 ? fmi3GetFloat64(c, vr, n, x, n) == fmi3OK
                      : fmi2GetReal(c, vr, n, x) == fmi2OK;
    for (size_t i = 0; ok && i < n; ++i) {
        if (!isfinite(x[i])) {
            __builtin_trap();
        }
    }
}

/* What an importer does next with a restored state. */
static void use(int v3, int me, void *c)
{
    read_all(v3, c);
    double dx[16], t = 0.0;
    const size_t ns = FMU_MODEL.n_states;
    if (v3) {
        if (fmi3GetFloat64(c, &(fmu_vr){(fmu_vr)(FMU_MODEL.n_vars - 1)}, 1, &t, 1) != fmi3OK) {
            return;
        }
        if (me) {
            if (fmi3GetContinuousStateDerivatives(c, dx, ns) == fmi3OK) {
                for (size_t i = 0; i < ns; ++i) {
                    if (!isfinite(dx[i])) {
                        __builtin_trap();
                    }
                }
            }
        } else {
            bool event = false, terminate = false, early = false;
            double last = 0.0;
            if (fmi3DoStep(c, t, 1e-3, true, &event, &terminate, &early, &last) == fmi3OK) {
                read_all(v3, c);
            }
        }
    } else {
        if (fmi2GetReal(c, &(fmu_vr){(fmu_vr)(FMU_MODEL.n_vars - 1)}, 1, &t) != fmi2OK) {
            return;
        }
        if (me) {
            if (fmi2GetDerivatives(c, dx, ns) == fmi2OK) {
                for (size_t i = 0; i < ns; ++i) {
                    if (!isfinite(dx[i])) {
                        __builtin_trap();
                    }
                }
            }
        } else if (fmi2DoStep(c, t, 1e-3, fmi2True) == fmi2OK) {
            read_all(v3, c);
        }
    }
}

static int restore(int v3, void *c, const unsigned char *bytes, size_t n)
{
    if (v3) {
        fmi3FMUState s = NULL;
        int ok = fmi3DeserializeFMUState(c, bytes, n, &s) == fmi3OK;
        if (ok && fmi3SetFMUState(c, s) != fmi3OK) {
            __builtin_trap(); /* accepted once, refused the second time */
        }
        fmi3FreeFMUState(c, &s);
        return ok;
    }
    fmi2FMUstate s = NULL;
    int ok = fmi2DeSerializeFMUstate(c, (const fmi2Byte *)bytes, n, &s) == fmi2OK;
    if (ok && fmi2SetFMUstate(c, s) != fmi2OK) {
        __builtin_trap();
    }
    fmi2FreeFMUstate(c, &s);
    return ok;
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1) {
        return 0;
    }
    setup();
    const int v3 = data[0] & 1u, me = (data[0] >> 1) & 1u, pre = (data[0] >> 2) & 1u;
    slot *s = &slots[v3][me];
    const unsigned char *good = pre ? s->pre : s->post;
    /* the instance at the good state (whatever the last input left) */
    if (!restore(v3, s->c, s->post, s->n)) {
        __builtin_trap();
    }
    unsigned char *buf = malloc(s->n);
    if (buf == NULL) {
        return 0;
    }
    memcpy(buf, good, s->n);
    forge(buf, s->n, data + 1, (size - 1) / RECORD);
    if (restore(v3, s->c, buf, s->n)) {
        use(v3, me, s->c);
    } else {
        /* refused: the instance is as it was */
        size_t n = 0;
        unsigned char *now = bytes_of(v3, s->c, &n);
        if (n != s->n || memcmp(now, s->post, n) != 0) {
            __builtin_trap();
        }
        free(now);
    }
    free(buf);
    return 0;
}

/* The number of 8-byte words of a state's payload (the smoke test forges each once). */
size_t fuzz_fmu_state_words(void);
size_t fuzz_fmu_state_words(void)
{
    setup();
    return (slots[0][0].n - HEADER) / 8u;
}

/* Free the instances (the smoke test calls it at the end, so LeakSanitizer sees no leak). */
void fuzz_fmu_state_release(void);
void fuzz_fmu_state_release(void)
{
    for (int v3 = 0; v3 < 2; ++v3) {
        for (int me = 0; me < 2; ++me) {
            slot *s = &slots[v3][me];
            if (s->c != NULL) {
                if (v3) {
                    fmi3FreeInstance(s->c);
                } else {
                    fmi2FreeInstance(s->c);
                }
                s->c = NULL;
            }
            free(s->pre);
            free(s->post);
            s->pre = s->post = NULL;
        }
    }
}
