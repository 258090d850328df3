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
