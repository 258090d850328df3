/* The floor of a batch of inverse dynamics: librrr's rrr_inverse_dynamics in a plain C loop over
 * n rows, the work Model.inverse_dynamics does for an (n, 3) batch without anything of Python.
 * Built and called (one ctypes call per batch) by bench/bench_python.py. */
#include "rrr/rrr.h"

long batch_floor_inverse_dynamics(const rrr_model *m, const double *q, const double *qd,
                                  const double *qdd, double *tau, long n);

/* The first failing row, or -1. */
long batch_floor_inverse_dynamics(const rrr_model *m, const double *q, const double *qd,
                                  const double *qdd, double *tau, long n)
{
    for (long i = 0; i < n; ++i) {
        if (rrr_inverse_dynamics(m, q + 3 * i, qd + 3 * i, qdd + 3 * i, tau + 3 * i) != RRR_OK) {
            return i;
        }
    }
    return -1;
}
