/* Batch calls (rrr_batch.h): every available path against the one-state call over random states
 * (multi-turn angles included), for inverse dynamics, the regressor, FK and forward dynamics:
 * the scalar path bit for bit, the vector kernels within 1e-13 absolute; rows the scalar call refuses give its status at the first such row, with the rows before
 * it written; unavailable paths and NULL are refused; the path names. IK (rrr_ik_batch): every
 * path and posture against rrr_ik_branch row by row over reachable, boundary, singular,
 * wrap-edge, unreachable and non-finite targets: the same status on every row, the scalar path
 * bit for bit, the vector kernels within 1e-13 rad, failing rows NaN. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "rrr/rrr.h"
#include "rrr_test.h"

#define PI_ 3.14159265358979323846

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

/* IK targets: FK of random angles (a tenth multi-turn), with special rows written over some */
static double ikx[3 * N], ikq[3 * N], ikref[3 * N];
static rrr_status ikst[N], ikst_ref[N];

static void ik_targets(const rrr_model *m)
{
    for (int k = 0; k < N; ++k) {
        CHECK_STATUS(rrr_fk(m, &q[3 * k], &ikx[3 * k], NULL), RRR_OK);
    }
    const double e = m->d2 + m->d3;
    int k = 10;
    /* boundaries and singular sets: stretched and folded elbow, the shoulder cylinder, q1 at
     * the wrap (+-pi), a target on the z axis side, signed zeros */
    const double qs[][3] = {{0.3, 0.2, 0.0},   {0.3, 0.2, PI_},  {1.0, -0.4, -PI_},
                            {PI_, 0.5, 1.0}, {-PI_, 0.5, -1.0}, {0.0, 0.0, 0.0},
                            {0.2, PI_ / 2, 0.3}, {0.0, -PI_ / 2, 0.0}, {2.0, PI_, 0.5},
                            {-0.7, 1.2, 1e-9}};
    for (size_t i = 0; i < sizeof qs / sizeof qs[0]; ++i, k += 37) {
        CHECK_STATUS(rrr_fk(m, qs[i], &ikx[3 * k], NULL), RRR_OK);
    }
    /* on the shoulder cylinder (r = 0) exactly and just inside the snapping tolerance */
    ikx[3 * k] = 0.0, ikx[3 * k + 1] = -e, ikx[3 * k + 2] = m->d1 + 0.3, k += 37;
    ikx[3 * k] = -e, ikx[3 * k + 1] = -0.0, ikx[3 * k + 2] = m->d1 - 0.2, k += 37;
    ikx[3 * k] = 0.0, ikx[3 * k + 1] = e * (1.0 - 1e-14), ikx[3 * k + 2] = 0.4, k += 37;
    /* unreachable: far out, inside the inner sphere, well inside the cylinder */
    ikx[3 * k] = 5.0, ikx[3 * k + 1] = 1.0, ikx[3 * k + 2] = 0.0, k += 37;
    ikx[3 * k] = 0.0, ikx[3 * k + 1] = 0.0, ikx[3 * k + 2] = m->d1, k += 37;
    ikx[3 * k] = 1e-3, ikx[3 * k + 1] = 1e-3, ikx[3 * k + 2] = 0.9, k += 37;
    ikx[3 * k] = 1e200, ikx[3 * k + 1] = 1.0, ikx[3 * k + 2] = 0.0, k += 37;
    /* non-finite targets */
    ikx[3 * k + 1] = (double)NAN, k += 37;
    ikx[3 * k + 2] = (double)INFINITY, k += 37;
    ikx[3 * k] = -(double)INFINITY, k += 37;
    CHECK(k < N);
    /* the outer sphere: targets pushed out by multiples of its snapping tolerance */
    for (int j = 0; j < 8; ++j, k += 37) {
        const double qq[3] = {0.1 * j, 0.3, 0.0};
        CHECK_STATUS(rrr_fk(m, qq, &ikx[3 * k], NULL), RRR_OK);
        const double grow = 1.0 + (j - 4) * 3e-13;
        ikx[3 * k] *= grow, ikx[3 * k + 1] *= grow, ikx[3 * k + 2] = m->d1 + (ikx[3 * k + 2] - m->d1) * grow;
    }
    CHECK(k < N);
}

static void test_ik(const rrr_model *m)
{
    ik_targets(m);
    int failed_rows = 0, vector_runs = 0;
    double worst = 0.0, worst_fk = 0.0;
    for (int s = 0; s < 2; ++s) {
        for (int el = 0; el < 2; ++el) {
            const rrr_shoulder sh = (rrr_shoulder)s;
            const rrr_elbow eb = (rrr_elbow)el;
            size_t first = N;
            for (int k = 0; k < N; ++k) {
                ikref[3 * k] = ikref[3 * k + 1] = ikref[3 * k + 2] = (double)NAN;
                ikst_ref[k] = rrr_ik_branch(m, &ikx[3 * k], sh, eb, &ikref[3 * k]);
                if (ikst_ref[k] != RRR_OK && first == N) {
                    first = (size_t)k;
                }
            }
            CHECK(first < N);
            for (int p = RRR_SIMD_AUTO; p <= RRR_SIMD_AVX512; ++p) {
                size_t done = 12345;
                memset(ikq, 0, sizeof ikq);
                if (!rrr_simd_available((rrr_simd)p)) {
                    CHECK_STATUS(rrr_ik_batch(m, N, ikx, sh, eb, ikq, ikst, (rrr_simd)p, &done),
                                 RRR_BAD_INPUT);
                    CHECK(done == 0 && ikq[0] == 0.0);
                    continue;
                }
                CHECK_STATUS(rrr_ik_batch(m, N, ikx, sh, eb, ikq, ikst, (rrr_simd)p, &done),
                             ikst_ref[first]);
                CHECK(done == first);
                const rrr_simd used = p == RRR_SIMD_AUTO ? rrr_simd_best() : (rrr_simd)p;
                vector_runs += used != RRR_SIMD_SCALAR;
                for (int k = 0; k < N; ++k) {
                    CHECK_STATUS(ikst[k], ikst_ref[k]);
                    if (ikst_ref[k] != RRR_OK) {
                        failed_rows += p == RRR_SIMD_SCALAR;
                        CHECK(isnan(ikq[3 * k]) && isnan(ikq[3 * k + 1]) && isnan(ikq[3 * k + 2]));
                    } else if (used == RRR_SIMD_SCALAR) {
                        CHECK(memcmp(&ikq[3 * k], &ikref[3 * k], 3 * sizeof ikq[0]) == 0);
                    } else {
                        const double d = max_diff(&ikq[3 * k], &ikref[3 * k], 3);
                        worst = fmax(worst, d);
                        CHECK(d <= 1e-13);
                        if (!(d <= 1e-13)) {
                            printf("test_batch: ik %d%d %s row %d: x = %.17g %.17g %.17g: "
                                   "diff %.3g\n", s, el, rrr_simd_name(used), k, ikx[3 * k],
                                   ikx[3 * k + 1], ikx[3 * k + 2], d);
                        }
                        double xb[3];
                        CHECK_STATUS(rrr_fk(m, &ikq[3 * k], xb, NULL), RRR_OK);
                        worst_fk = fmax(worst_fk, max_diff(xb, &ikx[3 * k], 3));
                    }
                }
                /* status NULL: the same angles, the same return and done */
                static double ikq2[3 * N];
                CHECK_STATUS(rrr_ik_batch(m, N, ikx, sh, eb, ikq2, NULL, (rrr_simd)p, &done),
                             ikst_ref[first]);
                CHECK(done == first && memcmp(ikq2, ikq, sizeof ikq) == 0);
                /* the reachable rows before the first failing one only: RRR_OK, done = n */
                CHECK_STATUS(rrr_ik_batch(m, first, ikx, sh, eb, ikq2, ikst, (rrr_simd)p, &done),
                             RRR_OK);
                CHECK(done == first);
            }
        }
    }
    printf("test_batch: ik: max |q - scalar| = %.3g rad (%d vector runs), max |fk(ik(x)) - x| = "
           "%.3g m, %d failing rows per posture and path\n",
           worst, vector_runs, worst_fk, failed_rows / 4);
    CHECK(failed_rows / 4 >= 7);
    CHECK(worst_fk <= 1e-12);
    /* a model rrr_ik_branch refuses: every row RRR_BAD_INPUT on every path */
    rrr_model broken = *m;
    broken.a2 = -0.1;
    for (int p = RRR_SIMD_AUTO; p <= RRR_SIMD_AVX512; ++p) {
        if (rrr_simd_available((rrr_simd)p)) {
            size_t done = 7;
            CHECK_STATUS(rrr_ik_batch(&broken, N, ikx, RRR_SHOULDER_FRONT, RRR_ELBOW_UP, ikq,
                                      ikst, (rrr_simd)p, &done),
                         RRR_BAD_INPUT);
            CHECK(done == 0 && ikst[N - 1] == RRR_BAD_INPUT && isnan(ikq[3 * N - 1]));
            CHECK_STATUS(rrr_ik_batch(m, 0, NULL, RRR_SHOULDER_FRONT, RRR_ELBOW_UP, NULL, NULL,
                                      (rrr_simd)p, &done),
                         RRR_OK);
            CHECK(done == 0);
        }
    }
    /* refusals with nothing written */
    size_t done = 3;
    ikst[0] = RRR_NUMERIC;
    CHECK_STATUS(rrr_ik_batch(NULL, N, ikx, RRR_SHOULDER_FRONT, RRR_ELBOW_UP, ikq, ikst,
                              RRR_SIMD_AUTO, &done),
                 RRR_BAD_INPUT);
    CHECK(done == 0 && ikst[0] == RRR_NUMERIC);
    CHECK_STATUS(rrr_ik_batch(m, N, NULL, RRR_SHOULDER_FRONT, RRR_ELBOW_UP, ikq, ikst,
                              RRR_SIMD_AUTO, NULL),
                 RRR_BAD_INPUT);
    CHECK_STATUS(rrr_ik_batch(m, N, ikx, RRR_SHOULDER_FRONT, RRR_ELBOW_UP, NULL, ikst,
                              RRR_SIMD_SCALAR, NULL),
                 RRR_BAD_INPUT);
    CHECK_STATUS(rrr_ik_batch(m, N, ikx, (rrr_shoulder)2, RRR_ELBOW_UP, ikq, ikst,
                              RRR_SIMD_AUTO, NULL),
                 RRR_BAD_INPUT);
    CHECK_STATUS(rrr_ik_batch(m, N, ikx, RRR_SHOULDER_BACK, (rrr_elbow)-1, ikq, ikst,
                              RRR_SIMD_SCALAR, NULL),
                 RRR_BAD_INPUT);
    CHECK_STATUS(rrr_ik_batch(m, N, ikx, RRR_SHOULDER_BACK, RRR_ELBOW_UP, ikq, ikst,
                              (rrr_simd)42, NULL),
                 RRR_BAD_INPUT);
    CHECK(ikst[0] == RRR_NUMERIC);
}

int main(void)
{
    rrr_model m;
    rrr_model_default(&m);
    fill();
    test_paths(&m);
    test_refusals(&m);
    test_other_calls(&m);
    test_ik(&m);
    return rrr_test_report("test_batch");
}
