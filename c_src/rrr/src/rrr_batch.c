/* Batch calls (rrr_batch.h): the path chosen from the CPU's features, the vector kernels of
 * c_src/rrr/simd/ where this librrr has them (RRR_HAVE_SIMD_X86, set by CMake for GCC on x86-64
 * Linux), and every row the vector kernels cannot vouch for handed to the scalar call. */
#include <math.h>
#include <stddef.h>

#include "rrr/rrr_batch.h"
#include "rrr/rrr_dynamics.h"
#include "rrr_internal.h"

#ifdef RRR_HAVE_SIMD_X86
#include "rrr_simd.h"
#endif

int rrr_simd_available(rrr_simd path)
{
    switch (path) {
    case RRR_SIMD_AUTO:
    case RRR_SIMD_SCALAR:
        return 1;
#ifdef RRR_HAVE_SIMD_X86
    case RRR_SIMD_AVX2:
        return __builtin_cpu_supports("avx2") && __builtin_cpu_supports("fma");
    case RRR_SIMD_AVX512:
        return __builtin_cpu_supports("avx512f") && __builtin_cpu_supports("avx512dq") &&
               __builtin_cpu_supports("fma");
#else
    case RRR_SIMD_AVX2:
    case RRR_SIMD_AVX512:
        return 0;
#endif
    }
    return 0;
}

rrr_simd rrr_simd_best(void)
{
    if (rrr_simd_available(RRR_SIMD_AVX512)) {
        return RRR_SIMD_AVX512;
    }
    if (rrr_simd_available(RRR_SIMD_AVX2)) {
        return RRR_SIMD_AVX2;
    }
    return RRR_SIMD_SCALAR;
}

const char *rrr_simd_name(rrr_simd path)
{
    switch (path) {
    case RRR_SIMD_AUTO:
        return "auto";
    case RRR_SIMD_SCALAR:
        return "scalar";
    case RRR_SIMD_AVX2:
        return "avx2";
    case RRR_SIMD_AVX512:
        return "avx512";
    }
    return "?";
}

/* The rows from `from` on, one scalar call each; RRR_OK or the first failure (at *done). */
static rrr_status scalar_rows(const rrr_model *m, size_t from, size_t n, const double q[],
                              const double qd[], const double qdd[], double tau[],
                              size_t *done)
{
    for (size_t k = from; k < n; ++k) {
        const rrr_status st =
            rrr_inverse_dynamics(m, &q[3 * k], &qd[3 * k], &qdd[3 * k], &tau[3 * k]);
        if (st != RRR_OK) {
            *done = k;
            return st;
        }
    }
    *done = n;
    return RRR_OK;
}

rrr_status rrr_inverse_dynamics_batch(const rrr_model *m, size_t n, const double q[],
                                      const double qd[], const double qdd[], double tau[],
                                      rrr_simd path, size_t *done)
{
    size_t ok = 0;
    if (done != NULL) {
        *done = 0;
    }
    if (m == NULL || (n > 0 && (q == NULL || qd == NULL || qdd == NULL || tau == NULL)) ||
        !rrr_simd_available(path)) {
        return RRR_BAD_INPUT;
    }
    if (path == RRR_SIMD_AUTO) {
        path = rrr_simd_best();
    }
    rrr_status st = RRR_OK;
    if (path == RRR_SIMD_SCALAR) {
        st = scalar_rows(m, 0, n, q, qd, qdd, tau, &ok);
    } else {
        int clean = 0; /* every number finite: the kernel's probe (rrr_simd.h) */
#ifdef RRR_HAVE_SIMD_X86
        if (path == RRR_SIMD_AVX512) {
            clean = rrr_simd_inverse_dynamics_avx512(m, n, q, qd, qdd, tau);
        } else {
            clean = rrr_simd_inverse_dynamics_avx2(m, n, q, qd, qdd, tau);
        }
#endif
        /* a row with a non-finite input or result is the scalar call's to judge (it gives the
         * status, or recomputes a row that is fine after all) */
        ok = n;
        for (size_t k = 0; !clean && k < n; ++k) {
            if (!rrr_finite_n(&q[3 * k], 3) || !rrr_finite_n(&qd[3 * k], 3) ||
                !rrr_finite_n(&qdd[3 * k], 3) || !rrr_finite_n(&tau[3 * k], 3)) {
                st = rrr_inverse_dynamics(m, &q[3 * k], &qd[3 * k], &qdd[3 * k], &tau[3 * k]);
                if (st != RRR_OK) {
                    ok = k;
                    break;
                }
            }
        }
    }
    if (done != NULL) {
        *done = ok;
    }
    return st;
}

/* The common checks of a batch call: done = 0, the pointers, the path (AUTO resolved). 0 when
 * the call goes on. */
static int batch_start(const rrr_model *m, size_t n, const void *const *ptrs, int nptrs,
                       rrr_simd *path, size_t *done)
{
    if (done != NULL) {
        *done = 0;
    }
    if (m == NULL || !rrr_simd_available(*path)) {
        return -1;
    }
    for (int i = 0; i < nptrs; ++i) {
        if (n > 0 && ptrs[i] == NULL) {
            return -1;
        }
    }
    if (*path == RRR_SIMD_AUTO) {
        *path = rrr_simd_best();
    }
    return 0;
}

/* A row of the vector kernels is kept when its inputs and outputs are finite; the others are
 * the scalar call's (which the caller runs). */
static int row_finite(const double *a, const double *b, const double *c, const double *out,
                      size_t nout)
{
    return rrr_finite_n(a, 3) && (b == NULL || rrr_finite_n(b, 3)) &&
           (c == NULL || rrr_finite_n(c, 3)) && rrr_finite_n(out, nout);
}

rrr_status rrr_regressor_batch(const rrr_model *m, size_t n, const double q[],
                               const double qd[], const double qdd[], double Y[],
                               rrr_simd path, size_t *done)
{
    const void *ptrs[4] = {q, qd, qdd, Y};
    if (batch_start(m, n, ptrs, 4, &path, done) != 0) {
        return RRR_BAD_INPUT;
    }
    enum { NY = 3 * RRR_NP };
    size_t k = 0;
    rrr_status st = RRR_OK;
    if (path != RRR_SIMD_SCALAR && n > 0) {
        /* row 0 first by the scalar call: the model checks (a model it refuses is refused at
         * row 0, as the scalar path would) */
        st = rrr_regressor(m, q, qd, qdd, (double(*)[RRR_NP])(void *)Y);
        if (st != RRR_OK) {
            return st;
        }
        int clean = 0; /* every number finite: the kernel's probe (rrr_simd.h) */
#ifdef RRR_HAVE_SIMD_X86
        if (path == RRR_SIMD_AVX512) {
            clean = rrr_simd_regressor_avx512(m, n - 1, q + 3, qd + 3, qdd + 3, Y + NY);
        } else {
            clean = rrr_simd_regressor_avx2(m, n - 1, q + 3, qd + 3, qdd + 3, Y + NY);
        }
#endif
        for (k = clean ? n : 1; k < n; ++k) {
            if (!row_finite(&q[3 * k], &qd[3 * k], &qdd[3 * k], &Y[NY * k], NY)) {
                st = rrr_regressor(m, &q[3 * k], &qd[3 * k], &qdd[3 * k],
                                   (double(*)[RRR_NP])(void *)&Y[NY * k]);
                if (st != RRR_OK) {
                    break;
                }
            }
        }
    } else {
        for (k = 0; k < n; ++k) {
            st = rrr_regressor(m, &q[3 * k], &qd[3 * k], &qdd[3 * k],
                               (double(*)[RRR_NP])(void *)&Y[NY * k]);
            if (st != RRR_OK) {
                break;
            }
        }
    }
    if (done != NULL) {
        *done = k;
    }
    return st;
}

rrr_status rrr_fk_batch(const rrr_model *m, size_t n, const double q[], double x[], double R[],
                        rrr_simd path, size_t *done)
{
    const void *ptrs[2] = {q, x};
    if (batch_start(m, n, ptrs, 2, &path, done) != 0) {
        return RRR_BAD_INPUT;
    }
    size_t k = 0;
    rrr_status st = RRR_OK;
    if (path != RRR_SIMD_SCALAR && n > 0) {
        /* row 0 first by the scalar call: the model checks (rrr_fk's kinematic ones) */
        st = rrr_fk(m, q, x, (double(*)[3])(void *)R);
        if (st != RRR_OK) {
            return st;
        }
        int clean = 0; /* every number finite: the kernel's probe (rrr_simd.h) */
#ifdef RRR_HAVE_SIMD_X86
        if (path == RRR_SIMD_AVX512) {
            clean = rrr_simd_fk_avx512(m, n - 1, q + 3, x + 3, R != NULL ? R + 9 : NULL);
        } else {
            clean = rrr_simd_fk_avx2(m, n - 1, q + 3, x + 3, R != NULL ? R + 9 : NULL);
        }
#endif
        for (k = clean ? n : 1; k < n; ++k) {
            if (!row_finite(&q[3 * k], NULL, NULL, &x[3 * k], 3) ||
                (R != NULL && !rrr_finite_n(&R[9 * k], 9))) {
                st = rrr_fk(m, &q[3 * k], &x[3 * k],
                            R != NULL ? (double(*)[3])(void *)&R[9 * k] : NULL);
                if (st != RRR_OK) {
                    break;
                }
            }
        }
    } else {
        for (k = 0; k < n; ++k) {
            st = rrr_fk(m, &q[3 * k], &x[3 * k],
                        R != NULL ? (double(*)[3])(void *)&R[9 * k] : NULL);
            if (st != RRR_OK) {
                break;
            }
        }
    }
    if (done != NULL) {
        *done = k;
    }
    return st;
}

rrr_status rrr_forward_dynamics_batch(const rrr_model *m, size_t n, const double q[],
                                      const double qd[], const double tau[], double qdd[],
                                      rrr_simd path, size_t *done)
{
    const void *ptrs[4] = {q, qd, tau, qdd};
    if (batch_start(m, n, ptrs, 4, &path, done) != 0) {
        return RRR_BAD_INPUT;
    }
    size_t k = 0;
    rrr_status st = RRR_OK;
    if (path != RRR_SIMD_SCALAR && n > 0) {
        /* row 0 first by the scalar call: a model it refuses is refused at row 0 */
        st = rrr_forward_dynamics(m, q, qd, tau, qdd);
        if (st != RRR_OK) {
            return st;
        }
        int clean = 0; /* every number finite: the kernel's probe (rrr_simd.h) */
#ifdef RRR_HAVE_SIMD_X86
        if (path == RRR_SIMD_AVX512) {
            clean = rrr_simd_forward_dynamics_avx512(m, n - 1, q + 3, qd + 3, tau + 3, qdd + 3);
        } else {
            clean = rrr_simd_forward_dynamics_avx2(m, n - 1, q + 3, qd + 3, tau + 3, qdd + 3);
        }
#endif
        /* a D that is not positive definite shows as a non-finite row */
        for (k = clean ? n : 1; k < n; ++k) {
            if (!row_finite(&q[3 * k], &qd[3 * k], &tau[3 * k], &qdd[3 * k], 3)) {
                st = rrr_forward_dynamics(m, &q[3 * k], &qd[3 * k], &tau[3 * k], &qdd[3 * k]);
                if (st != RRR_OK) {
                    break;
                }
            }
        }
    } else {
        for (k = 0; k < n; ++k) {
            st = rrr_forward_dynamics(m, &q[3 * k], &qd[3 * k], &tau[3 * k], &qdd[3 * k]);
            if (st != RRR_OK) {
                break;
            }
        }
    }
    if (done != NULL) {
        *done = k;
    }
    return st;
}

rrr_status rrr_ik_batch(const rrr_model *m, size_t n, const double x[], rrr_shoulder shoulder,
                        rrr_elbow elbow, double q[], rrr_status status[], rrr_simd path,
                        size_t *done)
{
    const void *ptrs[2] = {x, q};
    if (batch_start(m, n, ptrs, 2, &path, done) != 0 ||
        (shoulder != RRR_SHOULDER_FRONT && shoulder != RRR_SHOULDER_BACK) ||
        (elbow != RRR_ELBOW_UP && elbow != RRR_ELBOW_DOWN)) {
        return RRR_BAD_INPUT;
    }
    /* a model rrr_ik_branch refuses is refused on every row, by the scalar call */
    const int vector = path != RRR_SIMD_SCALAR && n > 0 && rrr_kin_ok(m);
    int clean = 0; /* every number finite: the kernel's probe (rrr_simd.h) */
#ifdef RRR_HAVE_SIMD_X86
    if (vector) {
        if (path == RRR_SIMD_AVX512) {
            clean = rrr_simd_ik_avx512(m, n, x, shoulder, elbow, q);
        } else {
            clean = rrr_simd_ik_avx2(m, n, x, shoulder, elbow, q);
        }
    }
#endif
    if (clean) {
        for (size_t k = 0; status != NULL && k < n; ++k) {
            status[k] = RRR_OK;
        }
        if (done != NULL) {
            *done = n;
        }
        return RRR_OK;
    }
    /* the vector kernels leave NaN in a row they cannot vouch for (unreachable, near the wrap
     * of an angle): such a row, or one with a non-finite target, is the scalar call's */
    size_t first = n;
    rrr_status st = RRR_OK;
    for (size_t k = 0; k < n; ++k) {
        rrr_status row = RRR_OK;
        if (!vector || !row_finite(&x[3 * k], NULL, NULL, &q[3 * k], 3)) {
            row = rrr_ik_branch(m, &x[3 * k], shoulder, elbow, &q[3 * k]);
        }
        if (row != RRR_OK) {
            const double nan = (double)NAN;
            q[3 * k] = q[3 * k + 1] = q[3 * k + 2] = nan;
            if (first == n) {
                first = k;
                st = row;
            }
        }
        if (status != NULL) {
            status[k] = row;
        }
    }
    if (done != NULL) {
        *done = first;
    }
    return st;
}
