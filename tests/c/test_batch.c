/* Batch calls (rrr_batch.h): every available path against the one-state call over random states
 * (multi-turn angles included): the scalar path bit for bit, the vector kernels within 1e-13
 * N m; rows the scalar call refuses give its status at the first such row, with the rows before
 * it written; unavailable paths and NULL are refused; the path names. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "rrr/rrr.h"
#include "rrr_test.h"

enum { N = 4099 }; /* not a multiple of a vector width: the loop's remainder is covered */

static double q[3 * N], qd[3 * N], qdd[3 * N], ref[3 * N], out[3 * N];

/* xorshift64*: a reproducible uniform in [lo, hi) */
static double uniform(unsigned long long *s, double lo, double hi)
{
    *s ^= *s >> 12;
    *s ^= *s << 25;
    *s ^= *s >> 27;
    const unsigned long long r = *s * 2685821657736338717ULL;
    return lo + (hi - lo) * (double)(r >> 11) * (1.0 / 9007199254740992.0);
}

static void fill(void)
{
    unsigned long long s = 88172645463325252ULL;
    for (int i = 0; i < 3 * N; ++i) {
        /* a tenth of the rows multi-turn (|q| up to 1e4 rad), the rest within a turn */
        const double span = (i / 3) % 10 == 0 ? 1e4 : 3.2;
        q[i] = uniform(&s, -span, span);
        qd[i] = uniform(&s, -5.0, 5.0);
        qdd[i] = uniform(&s, -20.0, 20.0);
    }
}

static void test_paths(const rrr_model *m)
{
    for (int k = 0; k < N; ++k) {
        CHECK_STATUS(rrr_inverse_dynamics(m, &q[3 * k], &qd[3 * k], &qdd[3 * k], &ref[3 * k]),
                     RRR_OK);
    }
    const rrr_simd paths[] = {RRR_SIMD_AUTO, RRR_SIMD_SCALAR, RRR_SIMD_AVX2, RRR_SIMD_AVX512};
    int vector_paths = 0;
    for (size_t p = 0; p < sizeof paths / sizeof paths[0]; ++p) {
        size_t done = 12345;
        memset(out, 0, sizeof out);
        if (!rrr_simd_available(paths[p])) {
            CHECK_STATUS(rrr_inverse_dynamics_batch(m, N, q, qd, qdd, out, paths[p], &done),
                         RRR_BAD_INPUT);
            CHECK(done == 0 && out[0] == 0.0);
            continue;
        }
        CHECK_STATUS(rrr_inverse_dynamics_batch(m, N, q, qd, qdd, out, paths[p], &done), RRR_OK);
        CHECK(done == N);
        const rrr_simd used = paths[p] == RRR_SIMD_AUTO ? rrr_simd_best() : paths[p];
        if (used == RRR_SIMD_SCALAR) {
            CHECK(memcmp(out, ref, sizeof out) == 0); /* bit for bit */
        } else {
            ++vector_paths;
            double worst = 0.0;
            for (int i = 0; i < 3 * N; ++i) {
                worst = fmax(worst, fabs(out[i] - ref[i]));
            }
            printf("test_batch: %s: max |tau - scalar| = %.3g N m over %d states\n",
                   rrr_simd_name(used), worst, N);
            CHECK(worst <= 1e-13);
        }
    }
    printf("test_batch: best path here: %s (%d vector path runs)\n",
           rrr_simd_name(rrr_simd_best()), vector_paths);
}

static void test_refusals(const rrr_model *m)
{
    static double bad[3 * N];
    for (int p = RRR_SIMD_AUTO; p <= RRR_SIMD_AVX512; ++p) {
        if (!rrr_simd_available((rrr_simd)p)) {
            continue;
        }
        /* a NaN in row 777's qd, an Inf in row 900's q: the first is the status's row */
        memcpy(bad, qd, sizeof bad);
        bad[3 * 777 + 1] = (double)NAN;
        static double qbad[3 * N];
        memcpy(qbad, q, sizeof qbad);
        qbad[3 * 900 + 2] = (double)INFINITY;
        size_t done = 0;
        memset(out, 0, sizeof out);
        const rrr_status st =
            rrr_inverse_dynamics_batch(m, N, qbad, bad, qdd, out, (rrr_simd)p, &done);
        double one[3];
        CHECK_STATUS(st, rrr_inverse_dynamics(m, &q[3 * 777], &bad[3 * 777], &qdd[3 * 777], one));
        CHECK(st != RRR_OK && done == 777);
        for (int i = 0; i < 3 * 777; ++i) {
            CHECK(fabs(out[i] - ref[i]) <= 1e-13);
        }
        /* an invalid model: the scalar call's status at row 0 */
        rrr_model broken = *m;
        broken.p[3] = (double)NAN;
        const rrr_status scalar = rrr_inverse_dynamics(&broken, q, qd, qdd, one);
        CHECK(scalar != RRR_OK);
        CHECK_STATUS(rrr_inverse_dynamics_batch(&broken, N, q, qd, qdd, out, (rrr_simd)p, &done),
                     scalar);
        CHECK(done == 0);
    }
    size_t done = 1;
    CHECK_STATUS(rrr_inverse_dynamics_batch(NULL, N, q, qd, qdd, out, RRR_SIMD_AUTO, &done),
                 RRR_BAD_INPUT);
    CHECK(done == 0);
    CHECK_STATUS(rrr_inverse_dynamics_batch(m, N, NULL, qd, qdd, out, RRR_SIMD_AUTO, NULL),
                 RRR_BAD_INPUT);
    CHECK_STATUS(rrr_inverse_dynamics_batch(m, N, q, qd, qdd, NULL, RRR_SIMD_SCALAR, NULL),
                 RRR_BAD_INPUT);
    CHECK_STATUS(rrr_inverse_dynamics_batch(m, 0, NULL, NULL, NULL, NULL, RRR_SIMD_AUTO, &done),
                 RRR_OK);
    CHECK(done == 0);
    CHECK_STATUS(rrr_inverse_dynamics_batch(m, N, q, qd, qdd, out, (rrr_simd)42, NULL),
                 RRR_BAD_INPUT);
    CHECK(!rrr_simd_available((rrr_simd)42) && strcmp(rrr_simd_name((rrr_simd)42), "?") == 0);
    CHECK(strcmp(rrr_simd_name(RRR_SIMD_AVX2), "avx2") == 0);
    CHECK(rrr_simd_available(RRR_SIMD_SCALAR) && rrr_simd_available(RRR_SIMD_AUTO));
    CHECK(rrr_simd_available(rrr_simd_best()));
}

int main(void)
{
    rrr_model m;
    rrr_model_default(&m);
    fill();
    test_paths(&m);
    test_refusals(&m);
    return rrr_test_report("test_batch");
}
