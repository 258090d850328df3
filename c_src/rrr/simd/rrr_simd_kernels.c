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
        const rrr_trig t = rrr_trig_of(&q[3 * k]); /* inlined: vector sin, cos */
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
        const rrr_trig t = rrr_trig_of(&q[3 * k]); /* inlined: vector sin, cos */
        rrr_gen_regressor(m, &t, &qd[3 * k], &qdd[3 * k],
                          (double(*)[RRR_NP])(void *)&Y[3 * RRR_NP * k]);
    }
}

/* rrr_fk's formulas, written as rrr_kinematics.c writes them: the tip of row k, and the
 * rotation when R is not NULL (one loop each way, so that neither tests R per state) */
static inline __attribute__((always_inline)) void fk_row(const rrr_model *m, const double *q,
                                                        double *x, double *R)
{
    const double e = m->d2 + m->d3;
    const double s1 = sin(q[0]), c1 = cos(q[0]);
    const rrr_trig t = rrr_trig_of(q);
    const double r = m->a2 * t.c2 + m->a3 * t.c23;
    x[0] = c1 * r + e * s1;
    x[1] = s1 * r - e * c1;
    x[2] = m->a2 * t.s2 + m->a3 * t.s23 + m->d1;
    if (R != NULL) {
        R[0] = c1 * t.c23;
        R[1] = -c1 * t.s23;
        R[2] = s1;
        R[3] = s1 * t.c23;
        R[4] = -s1 * t.s23;
        R[5] = -c1;
        R[6] = t.s23;
        R[7] = t.c23;
        R[8] = 0.0;
    }
}

void RRR_SIMD_CAT(rrr_simd_fk, RRR_SIMD_ISA)(const rrr_model *mp, size_t n,
                                            const double *restrict q, double *restrict x,
                                            double *restrict R)
{
    const rrr_model model = *mp;
    const rrr_model *m = &model;
    if (R == NULL) {
#pragma omp simd
        for (size_t k = 0; k < n; ++k) {
            fk_row(m, &q[3 * k], &x[3 * k], NULL);
        }
        return;
    }
#pragma omp simd
    for (size_t k = 0; k < n; ++k) {
        fk_row(m, &q[3 * k], &x[3 * k], &R[9 * k]);
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
            const rrr_trig t = rrr_trig_of(&qb[3 * k]); /* inlined: vector sin, cos */
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
