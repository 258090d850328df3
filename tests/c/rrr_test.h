/* Minimal test support shared by the C tests: CHECK macros and a seeded RNG. */
#ifndef RRR_TEST_H
#define RRR_TEST_H

#include <math.h>
#include <stdint.h>
#include <stdio.h>

/* The counters: one per program; a test of several translation units (the FMU harnesses with
 * fmu_harness_common.c) defines RRR_TEST_SHARED_COUNTERS in each and RRR_TEST_DEFINE_COUNTERS
 * in the one that holds them. */
#if defined(RRR_TEST_SHARED_COUNTERS) && !defined(RRR_TEST_DEFINE_COUNTERS)
extern int rrr_test_failures;
extern long rrr_test_checks;
#elif defined(RRR_TEST_SHARED_COUNTERS)
int rrr_test_failures = 0;
long rrr_test_checks = 0; /* checks evaluated (CHECK, CHECK_CLOSE, CHECK_STATUS) */
#else
static int rrr_test_failures = 0;
static long rrr_test_checks = 0; /* checks evaluated (CHECK, CHECK_CLOSE, CHECK_STATUS) */
#endif

#define CHECK(cond)                                                                          \
    do {                                                                                     \
        rrr_test_checks++;                                                                   \
        if (!(cond)) {                                                                       \
            fprintf(stderr, "%s:%d: CHECK failed: %s\n", __FILE__, __LINE__, #cond);         \
            rrr_test_failures++;                                                             \
        }                                                                                    \
    } while (0)

#define CHECK_CLOSE(a, b, tol)                                                               \
    do {                                                                                     \
        const double ca_ = (a), cb_ = (b);                                                   \
        rrr_test_checks++;                                                                   \
        if (!(fabs(ca_ - cb_) <= (tol))) {                                                   \
            fprintf(stderr, "%s:%d: CHECK_CLOSE failed: %s = %.17g, %s = %.17g, tol %g\n",  \
                    __FILE__, __LINE__, #a, ca_, #b, cb_, (double)(tol));                    \
            rrr_test_failures++;                                                             \
        }                                                                                    \
    } while (0)

#define CHECK_STATUS(expr, expected)                                                         \
    do {                                                                                     \
        const rrr_status cs_ = (expr);                                                       \
        rrr_test_checks++;                                                                   \
        if (cs_ != (expected)) {                                                             \
            fprintf(stderr, "%s:%d: %s returned %s, expected %s\n", __FILE__, __LINE__,      \
                    #expr, rrr_status_str(cs_), rrr_status_str(expected));                   \
            rrr_test_failures++;                                                             \
        }                                                                                    \
    } while (0)

/* xorshift64*: deterministic across platforms. */
typedef struct rrr_rng {
    uint64_t s;
} rrr_rng;

static inline double rrr_rng_uniform(rrr_rng *r, double lo, double hi)
{
    r->s ^= r->s >> 12;
    r->s ^= r->s << 25;
    r->s ^= r->s >> 27;
    const uint64_t v = r->s * 2685821657736338717ULL;
    return lo + (hi - lo) * ((double)(v >> 11) * (1.0 / 9007199254740992.0));
}

static inline int rrr_test_report(const char *name)
{
    if (rrr_test_failures == 0) {
        printf("%s: all checks passed (%ld checks)\n", name, rrr_test_checks);
        return 0;
    }
    printf("%s: %d check(s) failed (of %ld checks)\n", name, rrr_test_failures, rrr_test_checks);
    return 1;
}

#endif
