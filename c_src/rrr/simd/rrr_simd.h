/* The vector kernels of rrr_batch.c (private to librrr): one definition in rrr_simd_kernels.c,
 * compiled once per instruction set with RRR_SIMD_ISA set to its name. */
#ifndef RRR_SIMD_H
#define RRR_SIMD_H

#include <stddef.h>

#include "rrr/rrr_kinematics.h"
#include "rrr/rrr_model.h"

/* tau rows of n states, every row computed. Each kernel returns 1 when every number it read and
 * wrote is finite (then no row needs the scalar call), else 0: rrr_batch.c then checks the rows. */
int rrr_simd_inverse_dynamics_avx2(const rrr_model *m, size_t n, const double *q,
                                   const double *qd, const double *qdd, double *tau);
int rrr_simd_inverse_dynamics_avx512(const rrr_model *m, size_t n, const double *q,
                                     const double *qd, const double *qdd, double *tau);

/* Y blocks (3 x RRR_NP), tip positions (and rotations if R is not NULL), accelerations. */
int rrr_simd_regressor_avx2(const rrr_model *m, size_t n, const double *q, const double *qd,
                            const double *qdd, double *Y);
int rrr_simd_regressor_avx512(const rrr_model *m, size_t n, const double *q, const double *qd,
                              const double *qdd, double *Y);
int rrr_simd_fk_avx2(const rrr_model *m, size_t n, const double *q, double *x, double *R);
int rrr_simd_fk_avx512(const rrr_model *m, size_t n, const double *q, double *x, double *R);
int rrr_simd_forward_dynamics_avx2(const rrr_model *m, size_t n, const double *q,
                                   const double *qd, const double *tau, double *qdd);
int rrr_simd_forward_dynamics_avx512(const rrr_model *m, size_t n, const double *q,
                                     const double *qd, const double *tau, double *qdd);

/* rrr_ik_branch's angles of n targets on one posture; NaN in a row that is unreachable, has a
 * non-finite target or an angle within 1e-12 rad of the (-pi, pi] wrap (the scalar call's). */
int rrr_simd_ik_avx2(const rrr_model *m, size_t n, const double *x, rrr_shoulder shoulder,
                     rrr_elbow elbow, double *q);
int rrr_simd_ik_avx512(const rrr_model *m, size_t n, const double *x, rrr_shoulder shoulder,
                       rrr_elbow elbow, double *q);

#endif /* RRR_SIMD_H */
