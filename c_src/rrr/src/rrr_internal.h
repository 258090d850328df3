/* Private helpers of librrr (not installed). */
#ifndef RRR_INTERNAL_H
#define RRR_INTERNAL_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include "rrr/rrr.h"

/** pi (M_PI is not part of strict C11). */
#define RRR_PI 3.14159265358979323846

/* Default torque constants, N m / V: calibrated to the paper's eq 16 (tools/calibrate_kt.py). */
#define RRR_DEFAULT_KT1 12.0
#define RRR_DEFAULT_KT2 11.0
#define RRR_DEFAULT_KT3 4.7

/** 1 when every one of the n values is finite: a double is Inf or NaN exactly when its exponent
 *  bits are all ones. Integer, branch-free and vectorisable (it sits on every hot path, where n
 *  isfinite() branches cost several ns). */
static inline int rrr_finite_n(const double *v, size_t n)
{
    const uint64_t exp_mask = 0x7ff0000000000000ULL;
    uint64_t bad = 0u;
    for (size_t i = 0; i < n; ++i) {
        uint64_t bits;
        memcpy(&bits, &v[i], sizeof bits);
        bad |= (uint64_t)((bits & exp_mask) == exp_mask);
    }
    return bad == 0u;
}

/** sin/cos of q2, q3 and q2 + q3, the only trigonometric inputs of the dynamics. */
typedef struct rrr_trig {
    double s2, c2, s3, c3, s23, c23;
} rrr_trig;

static inline rrr_trig rrr_trig_of(const double q[3])
{
    rrr_trig t;
    t.s2 = sin(q[1]);
    t.c2 = cos(q[1]);
    t.s3 = sin(q[2]);
    t.c3 = cos(q[2]);
    /* angle-sum identities: two products instead of two more libm calls */
    t.s23 = t.s2 * t.c3 + t.c2 * t.s3;
    t.c23 = t.c2 * t.c3 - t.s2 * t.s3;
    return t;
}

#endif /* RRR_INTERNAL_H */
