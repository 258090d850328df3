/* Computed-torque law (eq 15) with the model feedforward of eq 10. */
#include <string.h>

#include "rrr_internal.h"

rrr_status rrr_ctc_gains_default(rrr_ctc_gains *gains)
{
    if (gains == NULL) {
        return RRR_BAD_INPUT;
    }
    const rrr_ctc_gains d = {{40.0, 100.0, 40.0}, {1.5, 4.0, 1.5}, 1};
    *gains = d;
    return RRR_OK;
}

static int gains_ok(const rrr_ctc_gains *k)
{
    for (int i = 0; i < RRR_NJ; ++i) {
        if (!isfinite(k->kp[i]) || !isfinite(k->kd[i]) || k->kp[i] < 0.0 || k->kd[i] < 0.0) {
            return 0;
        }
    }
    return 1;
}

rrr_status rrr_ctc(const rrr_model *m, const rrr_ctc_gains *gains, const double q_ref[3],
                   const double qd_ref[3], const double qdd_ref[3], const double q[3],
                   const double qd[3], rrr_ctc_output *out)
{
    if (m == NULL || gains == NULL || q_ref == NULL || qd_ref == NULL || qdd_ref == NULL ||
        q == NULL || qd == NULL || out == NULL || !gains_ok(gains) || !rrr_finite_n(q_ref, 3) ||
        !rrr_finite_n(qd_ref, 3) || !rrr_finite_n(qdd_ref, 3) || !rrr_finite_n(q, 3) ||
        !rrr_finite_n(qd, 3)) {
        return RRR_BAD_INPUT;
    }
    rrr_ctc_output o;
    memset(&o, 0, sizeof o);
    if (gains->feedforward) {
        double tau[3];
        rrr_status st = rrr_inverse_dynamics(m, q_ref, qd_ref, qdd_ref, tau);
        if (st == RRR_OK) {
            st = rrr_voltage_from_torque(m, qd_ref, tau, o.u_n); /* eq 10 */
        }
        if (st != RRR_OK) {
            return st;
        }
    }
    double u[3];
    for (int i = 0; i < RRR_NJ; ++i) {
        o.u_c[i] = gains->kp[i] * (q_ref[i] - q[i]) + gains->kd[i] * (qd_ref[i] - qd[i]);
        u[i] = o.u_n[i] + o.u_c[i];
    }
    if (!rrr_finite_n(u, 3)) {
        return RRR_NUMERIC;
    }
    const rrr_status st = rrr_saturate(m, u, o.u, &o.saturated);
    if (st != RRR_OK) {
        return st;
    }
    *out = o;
    return RRR_OK;
}

rrr_status rrr_predict_state(const double q[3], const double qd[3], const double qdd[3],
                             double lead, double q_pred[3], double qd_pred[3])
{
    if (q == NULL || qd == NULL || qdd == NULL || q_pred == NULL || qd_pred == NULL ||
        !(isfinite(lead) && lead >= 0.0) || !rrr_finite_n(q, 3) || !rrr_finite_n(qd, 3) ||
        !rrr_finite_n(qdd, 3)) {
        return RRR_BAD_INPUT;
    }
    double qp[3];
    double qdp[3];
    for (int i = 0; i < RRR_NJ; ++i) {
        qp[i] = lead == 0.0 ? q[i] : q[i] + lead * (qd[i] + 0.5 * lead * qdd[i]);
        qdp[i] = lead == 0.0 ? qd[i] : qd[i] + lead * qdd[i];
    }
    if (!rrr_finite_n(qp, 3) || !rrr_finite_n(qdp, 3)) {
        return RRR_NUMERIC;
    }
    memcpy(q_pred, qp, sizeof qp);
    memcpy(qd_pred, qdp, sizeof qdp);
    return RRR_OK;
}

double rrr_sample_time_default(void)
{
    return RRR_SAMPLE_TIME_DEFAULT;
}
