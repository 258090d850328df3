/* Batch calls (rrr_batch.h): every available path against the one-state call over random states
 * (multi-turn angles included), for inverse dynamics, the regressor, FK and forward dynamics:
 * the scalar path bit for bit, the vector kernels within 1e-13 absolute; rows the scalar call refuses give its status at the first such row, with the rows before
 * it written; unavailable paths and NULL are refused; the path names. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "rrr/rrr.h"
#include "rrr_test.h"

enum { N = 4099 }; /* not a multiple of a vector width: the loop's remainder is covered */

static double q[3 * N], qd[3 * N], qdd[3 * N], ref[3 * N], out[3 * N];
/* the other calls' references and outputs: regressor blocks, rotations, torques */
static double yref[3 * RRR_NP * N], yout[3 * RRR_NP * N], rref[9 * N], rout[9 * N], tq[3 * N];

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

/* The largest |a - b| over n numbers. */
static double max_diff(const double *a, const double *b, size_t n)
{
    double worst = 0.0;
    for (size_t i = 0; i < n; ++i) {
        worst = fmax(worst, fabs(a[i] - b[i]));
    }
    return worst;
}

/* One call's paths against its scalar reference: `run` fills the outputs on a path. */
typedef rrr_status (*batch_run)(const rrr_model *m, size_t n, rrr_simd path, size_t *done);

static rrr_status run_regressor(const rrr_model *m, size_t n, rrr_simd path, size_t *done)
{
    return rrr_regressor_batch(m, n, q, qd, qdd, yout, path, done);
}

static rrr_status run_fk(const rrr_model *m, size_t n, rrr_simd path, size_t *done)
{
    return rrr_fk_batch(m, n, q, out, rout, path, done);
}

static rrr_status run_fk_x(const rrr_model *m, size_t n, rrr_simd path, size_t *done)
{
    return rrr_fk_batch(m, n, q, out, NULL, path, done);
}

static rrr_status run_fd(const rrr_model *m, size_t n, rrr_simd path, size_t *done)
{
    return rrr_forward_dynamics_batch(m, n, q, qd, tq, out, path, done);
}

/* every path of `run` against the reference (ref_a: n_a numbers in out_a; ref_b optional) */
static void check_paths(const rrr_model *m, const char *what, batch_run run, const double *ref_a,
                        double *out_a, size_t n_a, const double *ref_b, double *out_b,
                        size_t n_b)
{
    for (int p = RRR_SIMD_AUTO; p <= RRR_SIMD_AVX512; ++p) {
        size_t done = 12345;
        memset(out_a, 0, n_a * sizeof *out_a);
        if (out_b != NULL) {
            memset(out_b, 0, n_b * sizeof *out_b);
        }
        if (!rrr_simd_available((rrr_simd)p)) {
            CHECK_STATUS(run(m, N, (rrr_simd)p, &done), RRR_BAD_INPUT);
            CHECK(done == 0 && out_a[0] == 0.0);
            continue;
        }
        CHECK_STATUS(run(m, N, (rrr_simd)p, &done), RRR_OK);
        CHECK(done == N);
        const rrr_simd used = p == RRR_SIMD_AUTO ? rrr_simd_best() : (rrr_simd)p;
        if (used == RRR_SIMD_SCALAR) {
            CHECK(memcmp(out_a, ref_a, n_a * sizeof *out_a) == 0); /* bit for bit */
            CHECK(ref_b == NULL || memcmp(out_b, ref_b, n_b * sizeof *out_b) == 0);
        } else {
            double worst = max_diff(out_a, ref_a, n_a);
            if (ref_b != NULL) {
                worst = fmax(worst, max_diff(out_b, ref_b, n_b));
            }
            printf("test_batch: %s: %s: max |batch - scalar| = %.3g over %d states\n", what,
                   rrr_simd_name(used), worst, N);
            CHECK(worst <= 1e-13);
        }
    }
}

/* A NaN in row 777 (and an Inf in row 900): the scalar call's status at row 777, the rows
 * before it written; an invalid model: the scalar call's status at row 0. */
static void check_refusal(const rrr_model *m, batch_run run, double *arr, rrr_status at_777,
                          rrr_model *broken, rrr_status at_0)
{
    for (int p = RRR_SIMD_AUTO; p <= RRR_SIMD_AVX512; ++p) {
        if (!rrr_simd_available((rrr_simd)p)) {
            continue;
        }
        const double keep777 = arr[3 * 777 + 1], keep900 = arr[3 * 900 + 2];
        arr[3 * 777 + 1] = (double)NAN;
        arr[3 * 900 + 2] = (double)INFINITY;
        size_t done = 0;
        CHECK_STATUS(run(m, N, (rrr_simd)p, &done), at_777);
        CHECK(done == 777);
        arr[3 * 777 + 1] = keep777;
        arr[3 * 900 + 2] = keep900;
        done = 5;
        CHECK_STATUS(run(broken, N, (rrr_simd)p, &done), at_0);
        CHECK(done == 0);
        CHECK_STATUS(run(m, 0, (rrr_simd)p, &done), RRR_OK);
        CHECK(done == 0);
    }
    CHECK_STATUS(run(NULL, N, RRR_SIMD_AUTO, NULL), RRR_BAD_INPUT);
    CHECK_STATUS(run(m, N, (rrr_simd)42, NULL), RRR_BAD_INPUT);
}

static void test_other_calls(const rrr_model *m)
{
    for (int k = 0; k < N; ++k) {
        CHECK_STATUS(rrr_regressor(m, &q[3 * k], &qd[3 * k], &qdd[3 * k],
                                   (double(*)[RRR_NP])(void *)&yref[3 * RRR_NP * k]),
                     RRR_OK);
    }
    check_paths(m, "regressor", run_regressor, yref, yout, 3 * RRR_NP * N, NULL, NULL, 0);
    static double xref[3 * N];
    for (int k = 0; k < N; ++k) {
        CHECK_STATUS(rrr_fk(m, &q[3 * k], &xref[3 * k], (double(*)[3])(void *)&rref[9 * k]),
                     RRR_OK);
    }
    check_paths(m, "fk", run_fk, xref, out, 3 * N, rref, rout, 9 * N);
    check_paths(m, "fk (x only)", run_fk_x, xref, out, 3 * N, NULL, NULL, 0);
    /* forward dynamics of the torques of (q, qd, qdd): the reference is the scalar call */
    for (int k = 0; k < N; ++k) {
        CHECK_STATUS(rrr_inverse_dynamics(m, &q[3 * k], &qd[3 * k], &qdd[3 * k], &tq[3 * k]),
                     RRR_OK);
    }
    for (int k = 0; k < N; ++k) {
        CHECK_STATUS(rrr_forward_dynamics(m, &q[3 * k], &qd[3 * k], &tq[3 * k], &ref[3 * k]),
                     RRR_OK);
    }
    check_paths(m, "forward_dynamics", run_fd, ref, out, 3 * N, NULL, NULL, 0);

    double one[3 * RRR_NP];
    const double nan3[3] = {0.1, (double)NAN, 0.2};
    rrr_model broken = *m;
    /* regressor: the NaN in qd; a model with a NaN a2 */
    broken.a2 = (double)NAN;
    check_refusal(m, run_regressor, qd,
                  rrr_regressor(m, q, nan3, qdd, (double(*)[RRR_NP])(void *)one), &broken,
                  rrr_regressor(&broken, q, qd, qdd, (double(*)[RRR_NP])(void *)one));
    /* fk: the NaN in q; a model with a3 < 0 (finite: only rrr_fk's checks refuse it) */
    broken = *m;
    broken.a3 = -0.2;
    check_refusal(m, run_fk, q, rrr_fk(m, nan3, one, NULL), &broken,
                  rrr_fk(&broken, q, one, NULL));
    check_refusal(m, run_fk_x, q, rrr_fk(m, nan3, one, NULL), &broken,
                  rrr_fk(&broken, q, one, NULL));
    /* forward dynamics: the NaN in tau; a model whose D is not positive definite */
    broken = *m;
    for (int i = 0; i < RRR_NP; ++i) {
        broken.p[i] = -m->p[i];
    }
    check_refusal(m, run_fd, tq, rrr_forward_dynamics(m, q, qd, nan3, one), &broken,
                  rrr_forward_dynamics(&broken, q, qd, tq, one));
    CHECK(rrr_forward_dynamics(&broken, q, qd, tq, one) == RRR_NOT_POSITIVE_DEFINITE);
    /* rows whose D is not positive definite in the middle of a batch: p7 (the constant of
     * D[0][0]) lowered so that D[0][0] <= 0 at the states whose rest of D[0][0] is below
     * row 0's; the first such row is the status's, as on the scalar path */
    double D[3][3], base0 = 0.0, lowest = 0.0;
    for (int k = 0; k < N; ++k) {
        CHECK_STATUS(rrr_mass_matrix(m, &q[3 * k], D), RRR_OK);
        const double rest = D[0][0] - m->p[6];
        if (k == 0) {
            base0 = lowest = rest;
        }
        lowest = fmin(lowest, rest);
    }
    CHECK(lowest < base0);
    broken = *m;
    broken.p[6] = -(lowest + 0.01 * (base0 - lowest)); /* row 0 positive definite, few not */
    size_t first = 0;
    const rrr_status scalar_st =
        rrr_forward_dynamics_batch(&broken, N, q, qd, tq, ref, RRR_SIMD_SCALAR, &first);
    CHECK_STATUS(scalar_st, RRR_NOT_POSITIVE_DEFINITE);
    CHECK(first > 0 && first < N);
    for (int p = RRR_SIMD_AUTO; p <= RRR_SIMD_AVX512; ++p) {
        if (rrr_simd_available((rrr_simd)p)) {
            size_t done = 0;
            CHECK_STATUS(rrr_forward_dynamics_batch(&broken, N, q, qd, tq, out, (rrr_simd)p,
                                                    &done),
                         scalar_st);
            CHECK(done == first);
            CHECK(max_diff(out, ref, 3 * first) <= 1e-13);
        }
    }
    printf("test_batch: forward_dynamics: first row not positive definite: %zu\n", first);
    CHECK_STATUS(rrr_fk_batch(m, N, q, NULL, rout, RRR_SIMD_AUTO, NULL), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_fk_batch(m, 0, NULL, NULL, NULL, RRR_SIMD_AUTO, NULL), RRR_OK);
    CHECK_STATUS(rrr_regressor_batch(m, N, q, qd, NULL, yout, RRR_SIMD_AUTO, NULL),
                 RRR_BAD_INPUT);
    CHECK_STATUS(rrr_forward_dynamics_batch(m, N, q, qd, tq, NULL, RRR_SIMD_SCALAR, NULL),
                 RRR_BAD_INPUT);
}

int main(void)
{
    rrr_model m;
    rrr_model_default(&m);
    fill();
    test_paths(&m);
    test_refusals(&m);
    test_other_calls(&m);
    return rrr_test_report("test_batch");
}
