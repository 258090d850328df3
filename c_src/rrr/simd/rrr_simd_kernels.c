/* The vector kernels of rrr_batch.h, compiled once per instruction set (c_src/rrr/CMakeLists.txt:
 * -mavx2 -mfma, or -mavx512f -mavx512dq -mfma, with -fopenmp-simd -fno-builtin-sin
 * -fno-builtin-cos) with RRR_SIMD_ISA its name. The generated closed form is included here under
 * other names, so that GCC inlines it into a loop over the states that it vectorises; sin and
 * cos are declared with simd clones, which glibc's libmvec provides (_ZGVdN4v_sin, ...). No
 * allocation, no I/O, no globals. */
#include <math.h>
#include <stddef.h>

#include "rrr_simd.h"

/* the generated code, under names of this file's own (it is also librrr's scalar code) */
#define RRR_SIMD_CAT2(a, b) a##_##b
#define RRR_SIMD_CAT(a, b) RRR_SIMD_CAT2(a, b)
#define rrr_gen_bias RRR_SIMD_CAT(rrr_simd_gen_bias, RRR_SIMD_ISA)
#define rrr_gen_coriolis RRR_SIMD_CAT(rrr_simd_gen_coriolis, RRR_SIMD_ISA)
#define rrr_gen_gravity RRR_SIMD_CAT(rrr_simd_gen_gravity, RRR_SIMD_ISA)
#define rrr_gen_inverse_dynamics RRR_SIMD_CAT(rrr_simd_gen_inverse_dynamics, RRR_SIMD_ISA)
#define rrr_gen_mass_matrix RRR_SIMD_CAT(rrr_simd_gen_mass_matrix, RRR_SIMD_ISA)
#define rrr_gen_potential RRR_SIMD_CAT(rrr_simd_gen_potential, RRR_SIMD_ISA)
#define rrr_gen_regressor RRR_SIMD_CAT(rrr_simd_gen_regressor, RRR_SIMD_ISA)
#define rrr_gen_tau_jacobian RRR_SIMD_CAT(rrr_simd_gen_tau_jacobian, RRR_SIMD_ISA)
#define rrr_gen_tau_param_jacobian RRR_SIMD_CAT(rrr_simd_gen_tau_param_jacobian, RRR_SIMD_ISA)
#include "rrr_dynamics_gen.c"

/* glibc's vector variants (libmvec): "notinbranch" clones of sin and cos */
__attribute__((simd("notinbranch"))) double sin(double);
__attribute__((simd("notinbranch"))) double cos(double);

void RRR_SIMD_CAT(rrr_simd_inverse_dynamics, RRR_SIMD_ISA)(const rrr_model *mp, size_t n,
                                                          const double *restrict q,
                                                          const double *restrict qd,
                                                          const double *restrict qdd,
                                                          double *restrict tau)
{
    const rrr_model model = *mp; /* a local copy: no store to tau can change it */
    const rrr_model *m = &model;
#pragma omp simd
    for (size_t k = 0; k < n; ++k) {
        /* rrr_trig_of's formulas (the angle-sum identities for q2 + q3) */
        rrr_trig t;
        t.s2 = sin(q[3 * k + 1]);
        t.c2 = cos(q[3 * k + 1]);
        t.s3 = sin(q[3 * k + 2]);
        t.c3 = cos(q[3 * k + 2]);
        t.s23 = t.s2 * t.c3 + t.c2 * t.s3;
        t.c23 = t.c2 * t.c3 - t.s2 * t.s3;
        rrr_gen_inverse_dynamics(m, &t, &qd[3 * k], &qdd[3 * k], &tau[3 * k]);
    }
}

void RRR_SIMD_CAT(rrr_simd_regressor, RRR_SIMD_ISA)(const rrr_model *mp, size_t n,
                                                   const double *restrict q,
                                                   const double *restrict qd,
                                                   const double *restrict qdd,
                                                   double *restrict Y)
{
    const rrr_model model = *mp;
    const rrr_model *m = &model;
#pragma omp simd
    for (size_t k = 0; k < n; ++k) {
        rrr_trig t;
        t.s2 = sin(q[3 * k + 1]);
        t.c2 = cos(q[3 * k + 1]);
        t.s3 = sin(q[3 * k + 2]);
        t.c3 = cos(q[3 * k + 2]);
        t.s23 = t.s2 * t.c3 + t.c2 * t.s3;
        t.c23 = t.c2 * t.c3 - t.s2 * t.s3;
        rrr_gen_regressor(m, &t, &qd[3 * k], &qdd[3 * k],
                          (double(*)[RRR_NP])(void *)&Y[3 * RRR_NP * k]);
    }
}

/* rrr_fk's formulas, written as rrr_kinematics.c writes them */
void RRR_SIMD_CAT(rrr_simd_fk, RRR_SIMD_ISA)(const rrr_model *mp, size_t n,
                                            const double *restrict q, double *restrict x,
                                            double *restrict R)
{
    const double a2 = mp->a2, a3 = mp->a3, d1 = mp->d1, e = mp->d2 + mp->d3;
    if (R == NULL) {
#pragma omp simd
        for (size_t k = 0; k < n; ++k) {
            const double s1 = sin(q[3 * k]), c1 = cos(q[3 * k]);
            const double s2 = sin(q[3 * k + 1]), c2 = cos(q[3 * k + 1]);
            const double s3 = sin(q[3 * k + 2]), c3 = cos(q[3 * k + 2]);
            const double s23 = s2 * c3 + c2 * s3, c23 = c2 * c3 - s2 * s3;
            const double r = a2 * c2 + a3 * c23;
            x[3 * k] = c1 * r + e * s1;
            x[3 * k + 1] = s1 * r - e * c1;
            x[3 * k + 2] = a2 * s2 + a3 * s23 + d1;
        }
        return;
    }
#pragma omp simd
    for (size_t k = 0; k < n; ++k) {
        const double s1 = sin(q[3 * k]), c1 = cos(q[3 * k]);
        const double s2 = sin(q[3 * k + 1]), c2 = cos(q[3 * k + 1]);
        const double s3 = sin(q[3 * k + 2]), c3 = cos(q[3 * k + 2]);
        const double s23 = s2 * c3 + c2 * s3, c23 = c2 * c3 - s2 * s3;
        const double r = a2 * c2 + a3 * c23;
        x[3 * k] = c1 * r + e * s1;
        x[3 * k + 1] = s1 * r - e * c1;
        x[3 * k + 2] = a2 * s2 + a3 * s23 + d1;
        double *Rk = &R[9 * k];
        Rk[0] = c1 * c23;
        Rk[1] = -c1 * s23;
        Rk[2] = s1;
        Rk[3] = s1 * c23;
        Rk[4] = -s1 * s23;
        Rk[5] = -c1;
        Rk[6] = s23;
        Rk[7] = c23;
        Rk[8] = 0.0;
    }
}

/* rrr_fd_factorize_trig and rrr_fd_solve without their branches: a pivot that is not positive
 * gives a NaN (sqrt) or an Inf (division), which rrr_batch.c hands to the scalar call (sqrt
 * vectorises for -fno-math-errno). Blocks of RRR_SIMD_FD_BLOCK states: D and the bias of a
 * block in a buffer on the stack, then the solves. (A per-state local D in one loop would be a
 * per-lane array of the simd loop, which GCC does not vectorise; a buffer row is 16 numbers, a
 * power of two, because GCC 12 vectorises groups of loads of such sizes or of 3 only.) */
enum { RRR_SIMD_FD_BLOCK = 64 };

typedef struct {
    double D[3][3];
    double bias[3];
    double pad[4];
} rrr_simd_fd_row;

__attribute__((flatten)) /* the two generated calls inlined, so that the loop vectorises */
void RRR_SIMD_CAT(rrr_simd_forward_dynamics, RRR_SIMD_ISA)(const rrr_model *mp, size_t n,
                                                          const double *restrict q,
                                                          const double *restrict qd,
                                                          const double *restrict tau,
                                                          double *restrict qdd)
{
    const rrr_model model = *mp;
    const rrr_model *m = &model;
    rrr_simd_fd_row buf[RRR_SIMD_FD_BLOCK];
    for (size_t base = 0; base < n; base += RRR_SIMD_FD_BLOCK) {
        const size_t nb = n - base < RRR_SIMD_FD_BLOCK ? n - base : RRR_SIMD_FD_BLOCK;
        const double *restrict qb = &q[3 * base];
        const double *restrict qdb = &qd[3 * base];
#pragma omp simd
        for (size_t k = 0; k < nb; ++k) {
            rrr_trig t;
            t.s2 = sin(qb[3 * k + 1]);
            t.c2 = cos(qb[3 * k + 1]);
            t.s3 = sin(qb[3 * k + 2]);
            t.c3 = cos(qb[3 * k + 2]);
            t.s23 = t.s2 * t.c3 + t.c2 * t.s3;
            t.c23 = t.c2 * t.c3 - t.s2 * t.s3;
            rrr_gen_bias(m, &t, &qdb[3 * k], buf[k].bias);
            rrr_gen_mass_matrix(m, &t, buf[k].D);
            buf[k].pad[0] = buf[k].pad[1] = buf[k].pad[2] = buf[k].pad[3] = 0.0;
        }
        const double *restrict taub = &tau[3 * base];
        double *restrict out = &qdd[3 * base];
#pragma omp simd
        for (size_t k = 0; k < nb; ++k) {
            const rrr_simd_fd_row *r = &buf[k];
            const double(*D)[3] = r->D;
            const double *bias = r->bias;
            const double l00 = sqrt(D[0][0]);
            const double l10 = D[1][0] / l00;
            const double l20 = D[2][0] / l00;
            const double l11 = sqrt(D[1][1] - l10 * l10);
            const double l21 = (D[2][1] - l20 * l10) / l11;
            const double l22 = sqrt(D[2][2] - l20 * l20 - l21 * l21);
            const double y0 = (taub[3 * k] - bias[0]) / l00;
            const double y1 = (taub[3 * k + 1] - bias[1] - l10 * y0) / l11;
            const double y2 = (taub[3 * k + 2] - bias[2] - l20 * y0 - l21 * y1) / l22;
            const double x2 = y2 / l22;
            const double x1 = (y1 - l21 * x2) / l11;
            out[3 * k + 2] = x2;
            out[3 * k + 1] = x1;
            out[3 * k] = (y0 - l10 * x1 - l20 * x2) / l00;
        }
    }
}
