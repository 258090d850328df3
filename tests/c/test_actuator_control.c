/* Actuator (eqs 8, 9) and computed-torque law (eq 15). */
#include <string.h>

#include "rrr/rrr.h"
#include "rrr_test.h"

static void test_friction(const rrr_model *m)
{
    const double qd[3] = {0.3, -0.004, 2.0};
    double uf[3];
    CHECK_STATUS(rrr_friction(m, qd, uf), RRR_OK);
    for (int i = 0; i < 3; ++i) {
        double ref = m->b[i] * qd[i];
        for (int k = 0; k < 3; ++k) {
            /* eq 9 as printed: 1 - 2 / (e^{2 w qd} + 1) */
            ref += m->f[i][k] * (1.0 - 2.0 / (exp(2.0 * m->w[i][k] * qd[i]) + 1.0));
        }
        CHECK_CLOSE(uf[i], ref, 1e-15);
    }
    /* odd in the velocity, zero at rest, finite at extreme speed */
    const double neg[3] = {-0.3, 0.004, -2.0}, zero[3] = {0.0, 0.0, 0.0};
    const double huge[3] = {1e300, -1e300, 1e10};
    double un[3], u0[3], uh[3];
    rrr_friction(m, neg, un);
    rrr_friction(m, zero, u0);
    for (int i = 0; i < 3; ++i) {
        CHECK_CLOSE(un[i], -uf[i], 1e-16);
        CHECK_CLOSE(u0[i], 0.0, 0.0);
    }
    CHECK_STATUS(rrr_friction(m, huge, uh), RRR_OK); /* tanh saturates: no overflow in eq 9 */
    CHECK_CLOSE(uh[2], m->b[2] * 1e10 + m->f[2][0] + m->f[2][1] + m->f[2][2], 1e-6);
}

static void test_voltage_torque(const rrr_model *m)
{
    const double qd[3] = {0.5, -1.0, 0.1}, tau[3] = {3.0, -20.0, 4.0};
    double u[3], back[3];
    CHECK_STATUS(rrr_voltage_from_torque(m, qd, tau, u), RRR_OK);
    CHECK_STATUS(rrr_torque_from_voltage(m, qd, u, back), RRR_OK);
    for (int i = 0; i < 3; ++i) {
        CHECK_CLOSE(back[i], tau[i], 1e-12);
    }
    /* beyond the limit the torque is that of u_max */
    const double big[3] = {50.0, -50.0, 0.0};
    double t_big[3], t_lim[3];
    const double lim[3] = {m->u_max, -m->u_max, 0.0};
    rrr_torque_from_voltage(m, qd, big, t_big);
    rrr_torque_from_voltage(m, qd, lim, t_lim);
    for (int i = 0; i < 3; ++i) {
        CHECK_CLOSE(t_big[i], t_lim[i], 0.0);
    }
    unsigned sat = 0u;
    double us[3];
    CHECK_STATUS(rrr_saturate(m, big, us, &sat), RRR_OK);
    CHECK(sat == 3u && us[0] == m->u_max && us[1] == -m->u_max && us[2] == 0.0);
    const double nan_u[3] = {0.0, (double)NAN, 0.0};
    double keep[3] = {7.0, 7.0, 7.0};
    CHECK_STATUS(rrr_saturate(m, nan_u, keep, NULL), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_torque_from_voltage(m, qd, nan_u, keep), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_voltage_from_torque(m, nan_u, tau, keep), RRR_BAD_INPUT);
    CHECK(keep[0] == 7.0 && keep[1] == 7.0);
    rrr_model bad = *m;
    bad.kt[0] = 0.0;
    CHECK_STATUS(rrr_voltage_from_torque(&bad, qd, tau, keep), RRR_BAD_INPUT);
    CHECK(keep[0] == 7.0);
}

static void test_ctc(const rrr_model *m)
{
    rrr_ctc_gains k;
    CHECK_STATUS(rrr_ctc_gains_default(&k), RRR_OK);
    const double qr[3] = {0.3, 0.4, 1.2}, qdr[3] = {0.2, -0.3, 0.5}, qddr[3] = {1.0, 2.0, -1.5};
    const double q[3] = {0.31, 0.38, 1.21}, qd[3] = {0.25, -0.2, 0.45};
    rrr_ctc_output o;
    CHECK_STATUS(rrr_ctc(m, &k, qr, qdr, qddr, q, qd, &o), RRR_OK);
    double tau[3], un[3];
    rrr_inverse_dynamics(m, qr, qdr, qddr, tau);
    rrr_voltage_from_torque(m, qdr, tau, un);
    for (int i = 0; i < 3; ++i) {
        CHECK_CLOSE(o.u_n[i], un[i], 1e-14);
        const double uc = k.kp[i] * (qr[i] - q[i]) + k.kd[i] * (qdr[i] - qd[i]);
        CHECK_CLOSE(o.u_c[i], uc, 1e-14);
        CHECK_CLOSE(o.u[i], fmax(-m->u_max, fmin(m->u_max, un[i] + uc)), 1e-14);
    }
    /* feedforward off: PD only, u_n reported as zero */
    k.feedforward = 0;
    CHECK_STATUS(rrr_ctc(m, &k, qr, qdr, qddr, q, qd, &o), RRR_OK);
    for (int i = 0; i < 3; ++i) {
        CHECK_CLOSE(o.u_n[i], 0.0, 0.0);
        CHECK_CLOSE(o.u[i], o.u_c[i], 0.0);
    }
    /* a large error saturates and is flagged */
    const double far[3] = {q[0] + 5.0, q[1], q[2]};
    CHECK_STATUS(rrr_ctc(m, &k, far, qdr, qddr, q, qd, &o), RRR_OK);
    CHECK(o.u[0] == m->u_max && (o.saturated & 1u) != 0u);
    /* bad input leaves the output untouched */
    rrr_ctc_output keep;
    memset(&keep, 0, sizeof keep);
    keep.u[0] = 7.0;
    const double nan_q[3] = {(double)NAN, 0.0, 0.0};
    CHECK_STATUS(rrr_ctc(m, &k, qr, qdr, qddr, nan_q, qd, &keep), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_ctc(m, &k, qr, nan_q, qddr, q, qd, &keep), RRR_BAD_INPUT);
    k.kp[1] = -1.0;
    CHECK_STATUS(rrr_ctc(m, &k, qr, qdr, qddr, q, qd, &keep), RRR_BAD_INPUT);
    k.kp[1] = (double)NAN;
    CHECK_STATUS(rrr_ctc(m, &k, qr, qdr, qddr, q, qd, &keep), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_ctc(m, NULL, qr, qdr, qddr, q, qd, &keep), RRR_BAD_INPUT);
    CHECK(keep.u[0] == 7.0);
}

int main(void)
{
    rrr_model m;
    CHECK_STATUS(rrr_model_default(&m), RRR_OK);
    test_friction(&m);
    test_voltage_torque(&m);
    test_ctc(&m);
    return rrr_test_report("test_actuator_control");
}
