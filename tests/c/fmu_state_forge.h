/*
 * Forged FMU states for the harnesses (tests/c/test_fmu_harness.c, test_fmu3_harness.c): the
 * bytes of a serialised state of fmu/common/fmu_instance.c with some fields overwritten and the
 * checksum made valid again, as an attacker (or a buggy tool) can do, since the checksum is no
 * secret. Every such state must be refused with Error and a message naming the field.
 *
 * The layout is typed in again here (header, instance fields, model data as each model's
 * config.h declares it); forge_layout_ok checks it against the size the FMU reports, so a
 * change of either side fails the tests instead of forging the wrong bytes.
 */
#ifndef RRR_FMU_STATE_FORGE_H
#define RRR_FMU_STATE_FORGE_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "rrr/rrr.h"

/* header: magic, version (u32 each), size, model hash, checksum (u64 each) */
#define FORGE_CHECKSUM_AT 24u
#define FORGE_HEADER 32u
/* instance fields after the header */
#define FORGE_STATE (FORGE_HEADER + 0u)       /* u32 machine state (one bit) */
#define FORGE_DIRTY (FORGE_HEADER + 4u)       /* i32 */
#define FORGE_STOP_DEF (FORGE_HEADER + 8u)    /* i32 */
#define FORGE_RESERVED (FORGE_HEADER + 12u)   /* u32 */
#define FORGE_TIME (FORGE_HEADER + 16u)       /* double */
#define FORGE_START (FORGE_HEADER + 24u)      /* double */
#define FORGE_STOP (FORGE_HEADER + 32u)       /* double */
#define FORGE_DATA (FORGE_HEADER + 40u)       /* the model data */

/* The model data of each FMU (fmu/<model>/config.h). */
typedef struct forge_plant {
    rrr_model model;
    rrr_plant_integrator integ;
    double q0[3], qd0[3], u[3];
    rrr_plant_state x;
    double qdd[3], tip[3];
} forge_plant;

typedef struct forge_controller {
    rrr_model model;
    rrr_ctc_gains gains;
    double q_ref[3], qd_ref[3], qdd_ref[3], q[3], qd[3], qdd[3];
    double lead;
    rrr_ctc_output out;
} forge_controller;

typedef struct forge_reference {
    double lookahead;
    double q_ref[3], qd_ref[3], qdd_ref[3], x_ref[3];
    uint64_t table_hash;
    uint64_t cursor;
} forge_reference;

#define FORGE_PLANT(M) (FORGE_DATA + offsetof(forge_plant, M))
#define FORGE_CTRL(M) (FORGE_DATA + offsetof(forge_controller, M))
#define FORGE_REF(M) (FORGE_DATA + offsetof(forge_reference, M))

/* 1 when n bytes are a state of a model whose data has data_size bytes. */
static inline int forge_layout_ok(size_t n, size_t data_size)
{
    return n == FORGE_DATA + data_size;
}

static inline uint64_t forge_fnv1a(const unsigned char *p, size_t n)
{
    uint64_t h = 14695981039346656037ull;
    for (size_t i = 0; i < n; ++i) {
        h = (h ^ p[i]) * 1099511628211ull;
    }
    return h;
}

/* Make the checksum valid for the bytes as they are now. */
static inline void forge_reseal(unsigned char *buf, size_t n)
{
    const uint64_t h = forge_fnv1a(buf + FORGE_HEADER, n - FORGE_HEADER);
    memcpy(buf + FORGE_CHECKSUM_AT, &h, sizeof h);
}

static inline void forge_f64(unsigned char *buf, size_t at, double v)
{
    memcpy(buf + at, &v, sizeof v);
}

static inline void forge_u64(unsigned char *buf, size_t at, uint64_t v)
{
    memcpy(buf + at, &v, sizeof v);
}

static inline void forge_u32(unsigned char *buf, size_t at, uint32_t v)
{
    memcpy(buf + at, &v, sizeof v);
}

static inline uint64_t forge_get_u64(const unsigned char *buf, size_t at)
{
    uint64_t v;
    memcpy(&v, buf + at, sizeof v);
    return v;
}

/* One forged case: up to two writes (width 8: u64 bits, width 4: u32 bits, 0: unused), and a
 * word the refusal's message must hold. */
typedef struct forge_write {
    size_t at;
    unsigned width;
    int is_double; /* 1: write v (8 bytes), 0: write bits */
    uint64_t bits;
    double v;
} forge_write;

typedef struct forge_case {
    const char *what;
    forge_write w[2];
    const char *needle;
} forge_case;

static inline uint64_t forge_bits(double v)
{
    uint64_t b;
    memcpy(&b, &v, sizeof b);
    return b;
}

/* Apply a case to a copy of the good bytes and reseal it. */
static inline void forge_apply(const forge_case *c, const unsigned char *good, unsigned char *out,
                               size_t n)
{
    memcpy(out, good, n);
    for (int i = 0; i < 2; ++i) {
        if (c->w[i].width == 8u && c->w[i].is_double) {
            forge_f64(out, c->w[i].at, c->w[i].v);
        } else if (c->w[i].width == 8u) {
            forge_u64(out, c->w[i].at, c->w[i].bits);
        } else if (c->w[i].width == 4u) {
            forge_u32(out, c->w[i].at, (uint32_t)c->w[i].bits);
        }
    }
    forge_reseal(out, n);
}

#define F8(AT, V) {(AT), 8u, 1, 0u, (double)(V)}
#define U8(AT, V) {(AT), 8u, 0, (uint64_t)(V), 0.0}
#define U4(AT, V) {(AT), 4u, 0, (uint64_t)(V), 0.0}
#define NONE {0u, 0u, 0, 0u, 0.0}

/* The cases every model shares: the instance fields (a Co-Simulation state in StepMode). */
#define FORGE_COMMON_CASES                                                                    \
    {"machine state StepCanceled (never entered)", {U4(FORGE_STATE, 1u << 8), NONE},          \
     "machine state"},                                                                        \
    {"machine state EventMode in Co-Simulation", {U4(FORGE_STATE, 1u << 3), NONE},            \
     "machine state"},                                                                        \
    {"dirty flag 2", {U4(FORGE_DIRTY, 2), NONE}, "flags"},                                    \
    {"reserved bits", {U4(FORGE_RESERVED, 0xFFFFFFFFu), NONE}, "flags"},                      \
    {"time NaN", {F8(FORGE_TIME, NAN), NONE}, "time"},                                  \
    {"start time Inf", {F8(FORGE_START, INFINITY), NONE}, "time"},                           \
    {"stop time before the start", {U4(FORGE_STOP_DEF, 1), F8(FORGE_STOP, -1e300)}, "time"}

static const forge_case forge_plant_cases[] = {
    FORGE_COMMON_CASES,
    {"q[1] NaN", {F8(FORGE_PLANT(x.q[0]), NAN), NONE}, "q[1]"},
    {"qd[3] -Inf", {F8(FORGE_PLANT(x.qd[2]), -INFINITY), NONE}, "qd[3]"},
    {"u[2] Inf", {F8(FORGE_PLANT(u[1]), INFINITY), NONE}, "u[2]"},
    {"adaptive 2", {U4(FORGE_PLANT(integ.adaptive), 2), NONE}, "adaptive"},
    {"negative step budget", {U8(FORGE_PLANT(integ.max_steps), (uint64_t)(int64_t)-1), NONE},
     "budget"},
    {"step budget 2^62", {U8(FORGE_PLANT(integ.max_steps), 1ull << 62), NONE}, "budget"},
    {"h_guess -1", {F8(FORGE_PLANT(x.h_guess), -1.0), NONE}, "step-size"},
    {"err_prev NaN", {F8(FORGE_PLANT(x.err_prev), NAN), NONE}, "step-size"},
    {"f[1,1] = w[1,1] = 1e4 (too stiff)",
     {F8(FORGE_PLANT(model.f[0][0]), 1e4), F8(FORGE_PLANT(model.w[0][0]), 1e4)}, "too stiff"},
    {"kt[1] = -1", {F8(FORGE_PLANT(model.kt[0]), -1.0), NONE}, "kt[1]"},
    {"w[2,3] = -1", {F8(FORGE_PLANT(model.w[1][2]), -1.0), NONE}, "w[2,3]"},
    {"p[1] = -1e3 (D not positive definite)", {F8(FORGE_PLANT(model.p[0]), -1e3), NONE},
     "positive definite"},
    {"rtol = 1", {F8(FORGE_PLANT(integ.rtol), 1.0), NONE}, "rtol"},
    {"h_int = 0", {F8(FORGE_PLANT(integ.h_int), 0.0), NONE}, "h_int"},
};

static const forge_case forge_controller_cases[] = {
    FORGE_COMMON_CASES,
    {"saturation bits 0xffffffff", {U4(FORGE_CTRL(out.saturated), 0xFFFFFFFFu), NONE},
     "saturation"},
    {"lead = 5", {F8(FORGE_CTRL(lead), 5.0), NONE}, "lead"},
    {"kp[1] = -1", {F8(FORGE_CTRL(gains.kp[0]), -1.0), NONE}, "kp[1]"},
    {"kd[3] NaN", {F8(FORGE_CTRL(gains.kd[2]), NAN), NONE}, "kd[3]"},
    {"feedforward = 7", {U4(FORGE_CTRL(gains.feedforward), 7), NONE}, "feedforward"},
    {"q[1] NaN", {F8(FORGE_CTRL(q[0]), NAN), NONE}, "q[1]"},
    {"u_n[2] Inf", {F8(FORGE_CTRL(out.u_n[1]), INFINITY), NONE}, "u_n[2]"},
    {"u_max = 0", {F8(FORGE_CTRL(model.u_max), 0.0), NONE}, "u_max"},
};

/* The reference's cases for a table of n_samples samples. */
#define FORGE_REFERENCE_CASES(N_SAMPLES)                                                      \
    FORGE_COMMON_CASES,                                                                       \
    {"cursor 2^64-1", {U8(FORGE_REF(cursor), UINT64_MAX), NONE}, "cursor"},                   \
    {"cursor = the number of samples - 1", {U8(FORGE_REF(cursor), (N_SAMPLES) - 1u), NONE},   \
     "cursor"},                                                                               \
    {"cursor without a table", {U8(FORGE_REF(table_hash), 0), U8(FORGE_REF(cursor), 1)},      \
     "cursor"},                                                                               \
    {"lookahead = 2", {F8(FORGE_REF(lookahead), 2.0), NONE}, "lookahead"},                    \
    {"q_ref[2] NaN", {F8(FORGE_REF(q_ref[1]), NAN), NONE}, "q_ref[2]"},                 \
    {"x_ref.z Inf", {F8(FORGE_REF(x_ref[2]), INFINITY), NONE}, "x_ref.z"}

#endif /* RRR_FMU_STATE_FORGE_H */
