/* librrr's calls in plain C loops: the C side of run_bench.py's rows against the Robotics
 * Toolbox. Each function runs one call per input row over n rows, `reps` passes, and is called
 * once per timed block through ctypes, so the call overhead (about a microsecond) is spread over
 * thousands of librrr calls. Built by bench/CMakeLists.txt against the same librrr as
 * bench_core; bench_python.py builds it against the package's librrr.so for the floor of a
 * batch (loops_inverse_dynamics, one pass). Each returns the first failing row, or -1. */
#include <stddef.h>

#include "rrr/rrr.h"

void loops_sizes(size_t *model, size_t *inertial, size_t *ik_set);
int loops_defaults(rrr_model *m, rrr_inertial *in);
long loops_ik(const rrr_model *m, const double *x, rrr_ik_set *sol, long n, long reps);
long loops_ik_branch(const rrr_model *m, const double *x, double *q, long n, long reps);
long loops_inverse_dynamics(const rrr_model *m, const double *q, const double *qd,
                            const double *qdd, double *tau, long n, long reps);
long loops_forward_dynamics(const rrr_model *m, const double *q, const double *qd,
                            const double *tau, double *qdd, long n, long reps);

/* sizeof of the structures Python allocates, to check its ctypes mirrors against */
void loops_sizes(size_t *model, size_t *inertial, size_t *ik_set)
{
    *model = sizeof(rrr_model);
    *inertial = sizeof(rrr_inertial);
    *ik_set = sizeof(rrr_ik_set);
}

/* the default robot of this librrr: 0 on success */
int loops_defaults(rrr_model *m, rrr_inertial *in)
{
    return rrr_model_default(m) != RRR_OK || rrr_inertial_default(in) != RRR_OK;
}

/* rrr_ik of each target x[i] (every branch) into sol[i] */
long loops_ik(const rrr_model *m, const double *x, rrr_ik_set *sol, long n, long reps)
{
    for (long r = 0; r < reps; ++r) {
        for (long i = 0; i < n; ++i) {
            if (rrr_ik(m, x + 3 * i, sol + i) != RRR_OK) {
                return i;
            }
        }
    }
    return -1;
}

/* rrr_ik_branch (front shoulder, elbow up) of each target x[i] into q[i] */
long loops_ik_branch(const rrr_model *m, const double *x, double *q, long n, long reps)
{
    for (long r = 0; r < reps; ++r) {
        for (long i = 0; i < n; ++i) {
            if (rrr_ik_branch(m, x + 3 * i, RRR_SHOULDER_FRONT, RRR_ELBOW_UP, q + 3 * i) !=
                RRR_OK) {
                return i;
            }
        }
    }
    return -1;
}

/* f(m, q[i], qd[i], in[i], out[i]) over the rows: inlined into both callers below, where f is a
 * constant, so the calls are direct */
typedef rrr_status (*dynamics_fn)(const rrr_model *m, const double q[3], const double qd[3],
                                  const double in[3], double out[3]);

static long loop_dynamics(dynamics_fn f, const rrr_model *m, const double *q, const double *qd,
                          const double *in, double *out, long n, long reps)
{
    for (long r = 0; r < reps; ++r) {
        for (long i = 0; i < n; ++i) {
            if (f(m, q + 3 * i, qd + 3 * i, in + 3 * i, out + 3 * i) != RRR_OK) {
                return i;
            }
        }
    }
    return -1;
}

long loops_inverse_dynamics(const rrr_model *m, const double *q, const double *qd,
                            const double *qdd, double *tau, long n, long reps)
{
    return loop_dynamics(rrr_inverse_dynamics, m, q, qd, qdd, tau, n, reps);
}

long loops_forward_dynamics(const rrr_model *m, const double *q, const double *qd,
                            const double *tau, double *qdd, long n, long reps)
{
    return loop_dynamics(rrr_forward_dynamics, m, q, qd, tau, qdd, n, reps);
}
