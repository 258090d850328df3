/* The smooth joint reference that the FMU harnesses and tests/c/fmu_run drive the closed loop
 * along: q_ref, qd_ref, qdd_ref at t (one definition, so their runs stay comparable). */
#ifndef FMU_TEST_REFERENCE_H
#define FMU_TEST_REFERENCE_H

#include <math.h>

static void reference(double t, double r[9])
{
    const double q0[3] = {0.1, 0.3, -0.8};
    const double a[3] = {0.6, 0.4, 0.5};
    const double w[3] = {3.0, 4.5, 4.0};
    for (int i = 0; i < 3; ++i) {
        r[i] = q0[i] + a[i] * sin(w[i] * t);
        r[3 + i] = a[i] * w[i] * cos(w[i] * t);
        r[6 + i] = -a[i] * w[i] * w[i] * sin(w[i] * t);
    }
}

#endif /* FMU_TEST_REFERENCE_H */
