/* A downstream program of librrr: forward kinematics, every inverse-kinematics branch and the
 * inverse dynamics of the default robot, checked against each other. Exit status 0 when every
 * check holds, 1 otherwise. */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include <rrr/rrr.h>

int main(void)
{
    rrr_model m;
    if (rrr_model_default(&m) != RRR_OK) {
        fprintf(stderr, "rrr_model_default failed\n");
        return 1;
    }
#ifdef RRR_PACKAGE_VERSION
    if (strcmp(RRR_VERSION_STRING, RRR_PACKAGE_VERSION) != 0) {
        fprintf(stderr, "rrr.h says %s, the CMake package %s\n", RRR_VERSION_STRING,
                RRR_PACKAGE_VERSION);
        return 1;
    }
#endif
    const double q[3] = {0.3, 0.4, -1.1};
    const double qd[3] = {0.5, -0.2, 0.7};
    const double qdd[3] = {1.0, 2.0, -3.0};
    double x[3], R[3][3], tau[3];
    rrr_status st = rrr_fk(&m, q, x, R);
    if (st != RRR_OK) {
        fprintf(stderr, "rrr_fk: %s\n", rrr_status_str(st));
        return 1;
    }
    rrr_ik_set sol;
    st = rrr_ik(&m, x, &sol);
    if (st != RRR_OK) {
        fprintf(stderr, "rrr_ik: %s\n", rrr_status_str(st));
        return 1;
    }
    double worst = 0.0;
    for (int k = 0; k < sol.n; ++k) {
        double xk[3], Rk[3][3];
        if (rrr_fk(&m, sol.q[k], xk, Rk) != RRR_OK) {
            return 1;
        }
        for (int i = 0; i < 3; ++i) {
            worst = fmax(worst, fabs(xk[i] - x[i]));
        }
    }
    st = rrr_inverse_dynamics(&m, q, qd, qdd, tau);
    if (st != RRR_OK) {
        fprintf(stderr, "rrr_inverse_dynamics: %s\n", rrr_status_str(st));
        return 1;
    }
    printf("librrr %s: tip (%.6f, %.6f, %.6f) m, %d IK branches, |FK(IK(x)) - x| = %.1e m, "
           "tau (%.4f, %.4f, %.4f) N m\n",
           RRR_VERSION_STRING, x[0], x[1], x[2], sol.n, worst, tau[0], tau[1], tau[2]);
    return (sol.n == 4 && worst < 1e-12) ? 0 : 1;
}
