/* The vector kernels of rrr_batch.c (private to librrr): one definition in rrr_simd_kernels.c,
 * compiled once per instruction set with RRR_SIMD_ISA set to its name. */
#ifndef RRR_SIMD_H
#define RRR_SIMD_H

#include <stddef.h>

#include "rrr/rrr_model.h"

/* tau rows of n states, every row computed (no checks: rrr_batch.c checks the rows after). */
void rrr_simd_inverse_dynamics_avx2(const rrr_model *m, size_t n, const double *q,
                                    const double *qd, const double *qdd, double *tau);
void rrr_simd_inverse_dynamics_avx512(const rrr_model *m, size_t n, const double *q,
                                      const double *qd, const double *qdd, double *tau);

#endif /* RRR_SIMD_H */
