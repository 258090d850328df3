/* Exact partial derivatives of the dynamics, the plant and the computed-torque law
 * (rrr_derivatives.h): the generated d tau / d q, d tau / d qd (rrr_dynamics_gen.c), the
 * friction slope (rrr_actuator.c) and the plant's own Cholesky factor of D(q). */
#include <string.h>

#include "rrr_dynamics_gen.h"
#include "rrr_internal.h"

rrr_status rrr_inverse_dynamics_jacobian(const rrr_model *m, const double q[3],
                                         const double qd[3], const double qdd[3],
                                         double dtau_dq[3][3], double dtau_dqd[3][3])
{
    if (m == NULL || q == NULL || qd == NULL || qdd == NULL || dtau_dq == NULL ||
        dtau_dqd == NULL) {
        return RRR_BAD_INPUT;
    }
    if (!isfinite(m->a2) || !isfinite(m->g) || !rrr_finite_n(m->p, RRR_NP) ||
        !rrr_finite_n(q, 3) || !rrr_finite_n(qd, 3) || !rrr_finite_n(qdd, 3)) {
        return RRR_BAD_INPUT;
    }
    const rrr_trig t = rrr_trig_of(q);
    double a[3][3], b[3][3];
    rrr_gen_tau_jacobian(m, &t, qd, qdd, a, b);
    if (!rrr_finite_n(&a[0][0], 9) || !rrr_finite_n(&b[0][0], 9)) {
        return RRR_NUMERIC;
    }
    memcpy(dtau_dq, a, sizeof a);
    memcpy(dtau_dqd, b, sizeof b);
    return RRR_OK;
}

/* x = D^-1 r with the factor D = L L^T of rrr_fd_factorize (the operations of rrr_fd_solve) */
static void chol_solve(const rrr_fd_factor *f, const double r[3], double x[3])
{
    const double y0 = r[0] / f->l00;
    const double y1 = (r[1] - f->l10 * y0) / f->l11;
    const double y2 = (r[2] - f->l20 * y0 - f->l21 * y1) / f->l22;
    x[2] = y2 / f->l22;
    x[1] = (y1 - f->l21 * x[2]) / f->l11;
    x[0] = (y0 - f->l10 * x[1] - f->l20 * x[2]) / f->l00;
}

/* X = D^-1 B column by column (B, X 3 x 3; B is read only; X may not alias B) */
static void chol_solve_cols(const rrr_fd_factor *f, double B[3][3], double X[3][3])
{
    for (int j = 0; j < 3; ++j) {
        const double r[3] = {B[0][j], B[1][j], B[2][j]};
        double x[3];
        chol_solve(f, r, x);
        X[0][j] = x[0];
        X[1][j] = x[1];
        X[2][j] = x[2];
    }
}

/* bit j set when the clamp of rrr_saturate changes u_j (|u_j| > u_max) */
static unsigned clamped_bits(const rrr_model *m, const double u[3])
{
    unsigned bits = 0u;
    for (int j = 0; j < RRR_NJ; ++j) {
        if (u[j] > m->u_max || u[j] < -m->u_max) {
            bits |= 1u << j;
        }
    }
    return bits;
}

rrr_status rrr_plant_jacobian(const rrr_model *m, const rrr_plant_state *x, const double u[3],
                              rrr_plant_derivatives *d)
{
    if (m == NULL || x == NULL || u == NULL || d == NULL) {
        return RRR_BAD_INPUT;
    }
    /* qdd exactly as rrr_plant_accel computes it (the same two halves), with its statuses */
    rrr_plant_prep p;
    rrr_plant_prepare(m, rrr_actuator_params_ok(m), x->q, x->qd, &p);
    rrr_plant_derivatives o;
    memset(&o, 0, sizeof o);
    rrr_status st = rrr_plant_accel_prepared(m, &p, u, o.qdd);
    if (st != RRR_OK) {
        return st;
    }
    double slope[3];
    st = rrr_friction_slope(m, x->qd, slope);
    if (st != RRR_OK) {
        return st;
    }
    double dq[3][3], dqd[3][3];
    rrr_gen_tau_jacobian(m, &p.fd.t, x->qd, o.qdd, dq, dqd);
    o.saturated = clamped_bits(m, u);
    double rhs_q[3][3], rhs_qd[3][3], rhs_u[3][3];
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            rhs_q[i][j] = -dq[i][j];
            rhs_qd[i][j] = -dqd[i][j] - (i == j ? m->kt[i] * slope[i] : 0.0);
            rhs_u[i][j] = (i == j && !(o.saturated & (1u << j))) ? m->kt[i] : 0.0;
        }
    }
    chol_solve_cols(&p.fd, rhs_q, o.dqdd_dq);
    chol_solve_cols(&p.fd, rhs_qd, o.dqdd_dqd);
    chol_solve_cols(&p.fd, rhs_u, o.dqdd_du);
    for (int i = 0; i < 3; ++i) {
        o.dqdd_dq[i][0] = 0.0; /* exactly: D, c and h do not depend on q1 */
    }
    if (!rrr_finite_n(&o.dqdd_dq[0][0], 9) || !rrr_finite_n(&o.dqdd_dqd[0][0], 9) ||
        !rrr_finite_n(&o.dqdd_du[0][0], 9)) {
        return RRR_NUMERIC;
    }
    *d = o;
    return RRR_OK;
}

rrr_status rrr_ctc_jacobian(const rrr_model *m, const rrr_ctc_gains *gains,
                            const double q_ref[3], const double qd_ref[3],
                            const double qdd_ref[3], const double q[3], const double qd[3],
                            rrr_ctc_derivatives *d)
{
    if (d == NULL) {
        return RRR_BAD_INPUT;
    }
    rrr_ctc_derivatives o;
    memset(&o, 0, sizeof o);
    rrr_status st = rrr_ctc(m, gains, q_ref, qd_ref, qdd_ref, q, qd, &o.out);
    if (st != RRR_OK) {
        return st; /* also every NULL and non-finite argument */
    }
    if (gains->feedforward) {
        double D[3][3], dq[3][3], dqd[3][3], slope[3];
        st = rrr_mass_matrix(m, q_ref, D);
        if (st == RRR_OK) {
            st = rrr_inverse_dynamics_jacobian(m, q_ref, qd_ref, qdd_ref, dq, dqd);
        }
        if (st == RRR_OK) {
            st = rrr_friction_slope(m, qd_ref, slope);
        }
        if (st != RRR_OK) {
            return st;
        }
        for (int i = 0; i < 3; ++i) {
            for (int j = 0; j < 3; ++j) {
                o.du_n[RRR_CTC_Q_REF][i][j] = dq[i][j] / m->kt[i];
                o.du_n[RRR_CTC_QD_REF][i][j] = dqd[i][j] / m->kt[i] + (i == j ? slope[i] : 0.0);
                o.du_n[RRR_CTC_QDD_REF][i][j] = D[i][j] / m->kt[i];
            }
        }
    }
    for (int i = 0; i < 3; ++i) {
        o.du_c[RRR_CTC_Q_REF][i][i] = gains->kp[i];
        o.du_c[RRR_CTC_QD_REF][i][i] = gains->kd[i];
        o.du_c[RRR_CTC_Q][i][i] = -gains->kp[i];
        o.du_c[RRR_CTC_QD][i][i] = -gains->kd[i];
    }
    for (int k = 0; k < RRR_CTC_INPUT_COUNT; ++k) {
        for (int i = 0; i < 3; ++i) {
            const int free_i = !(o.out.saturated & (1u << i));
            for (int j = 0; j < 3; ++j) {
                o.du[k][i][j] = free_i ? o.du_n[k][i][j] + o.du_c[k][i][j] : 0.0;
            }
        }
    }
    if (!rrr_finite_n(&o.du[0][0][0], sizeof o.du / sizeof(double)) ||
        !rrr_finite_n(&o.du_n[0][0][0], sizeof o.du_n / sizeof(double))) {
        return RRR_NUMERIC;
    }
    *d = o;
    return RRR_OK;
}

/* ---- with respect to the model parameters ------------------------------------------------------ */

/* column of a model field: its index among the doubles of rrr_model (= the parameter table's row,
 * tests/c/test_model.c) */
#define COL(MEMBER) ((int)(offsetof(rrr_model, MEMBER) / sizeof(double)))
_Static_assert(sizeof(rrr_model) == RRR_N_PARAMS * sizeof(double),
               "rrr_model is the parameter table's doubles");

rrr_status rrr_plant_param_jacobian(const rrr_model *m, const rrr_plant_state *x,
                                    const double u[3], double dqdd_dparam[3][RRR_N_PARAMS])
{
    if (m == NULL || x == NULL || u == NULL || dqdd_dparam == NULL) {
        return RRR_BAD_INPUT;
    }
    rrr_plant_prep p;
    rrr_plant_prepare(m, rrr_actuator_params_ok(m), x->q, x->qd, &p);
    double qdd[3];
    const rrr_status st = rrr_plant_accel_prepared(m, &p, u, qdd);
    if (st != RRR_OK) {
        return st;
    }
    /* D dqdd = d(k_t (sat(u) - u_f)) - d tau, tau = R(q, qd, qdd) p at the point's qdd */
    double Y[3][RRR_NP], da2[3], dg[3], th[3][RRR_NF];
    rrr_gen_regressor(m, &p.fd.t, x->qd, qdd, Y);
    rrr_gen_tau_param_jacobian(m, &p.fd.t, x->qd, qdd, da2, dg);
    rrr_actuator_friction_tanh(m, x->qd, th);
    double rhs[3][RRR_N_PARAMS];
    memset(rhs, 0, sizeof rhs);
    for (int i = 0; i < RRR_NJ; ++i) {
        const double kt = m->kt[i];
        const int clamped = u[i] > m->u_max || u[i] < -m->u_max;
        const double sat = clamped ? copysign(m->u_max, u[i]) : u[i];
        rhs[i][COL(a2)] = -da2[i];
        rhs[i][COL(g)] = -dg[i];
        for (int l = 0; l < RRR_NP; ++l) {
            rhs[i][COL(p) + l] = -Y[i][l];
        }
        rhs[i][COL(kt) + i] = sat - p.uf[i];
        for (int k = 0; k < RRR_NF; ++k) {
            rhs[i][COL(f) + RRR_NF * i + k] = -kt * th[i][k];
            rhs[i][COL(w) + RRR_NF * i + k] =
                -kt * m->f[i][k] * x->qd[i] * (1.0 - th[i][k] * th[i][k]);
        }
        rhs[i][COL(b) + i] = -kt * x->qd[i];
        rhs[i][COL(u_max)] = clamped ? copysign(kt, u[i]) : 0.0;
    }
    double out[3][RRR_N_PARAMS];
    for (int c = 0; c < RRR_N_PARAMS; ++c) {
        const double r[3] = {rhs[0][c], rhs[1][c], rhs[2][c]};
        double v[3];
        chol_solve(&p.fd, r, v);
        out[0][c] = v[0];
        out[1][c] = v[1];
        out[2][c] = v[2];
    }
    if (!rrr_finite_n(&out[0][0], 3 * RRR_N_PARAMS)) {
        return RRR_NUMERIC;
    }
    memcpy(dqdd_dparam, out, sizeof out);
    return RRR_OK;
}

rrr_status rrr_fk_param_jacobian(const rrr_model *m, const double q[3],
                                 double dx_dparam[3][RRR_N_PARAMS])
{
    double x[3];
    if (dx_dparam == NULL) {
        return RRR_BAD_INPUT;
    }
    const rrr_status st = rrr_fk(m, q, x, NULL); /* its checks and statuses */
    if (st != RRR_OK) {
        return st;
    }
    /* x = c1 r + e s1, y = s1 r - e c1, z = a2 s2 + a3 s23 + d1, r = a2 c2 + a3 c23,
     * e = d2 + d3: affine in each length */
    const double s1 = sin(q[0]), c1 = cos(q[0]);
    const rrr_trig t = rrr_trig_of(q);
    double out[3][RRR_N_PARAMS];
    memset(out, 0, sizeof out);
    out[2][COL(d1)] = 1.0;
    out[0][COL(a2)] = c1 * t.c2;
    out[1][COL(a2)] = s1 * t.c2;
    out[2][COL(a2)] = t.s2;
    out[0][COL(a3)] = c1 * t.c23;
    out[1][COL(a3)] = s1 * t.c23;
    out[2][COL(a3)] = t.s23;
    out[0][COL(d2)] = out[0][COL(d3)] = s1;
    out[1][COL(d2)] = out[1][COL(d3)] = -c1;
    memcpy(dx_dparam, out, sizeof out);
    return RRR_OK;
}

rrr_status rrr_ctc_param_jacobian(const rrr_model *m, const rrr_ctc_gains *gains,
                                  const double q_ref[3], const double qd_ref[3],
                                  const double qdd_ref[3], const double q[3], const double qd[3],
                                  rrr_ctc_param_derivatives *d)
{
    if (d == NULL) {
        return RRR_BAD_INPUT;
    }
    rrr_ctc_output o;
    rrr_status st = rrr_ctc(m, gains, q_ref, qd_ref, qdd_ref, q, qd, &o);
    if (st != RRR_OK) {
        return st; /* also every NULL and non-finite argument */
    }
    rrr_ctc_param_derivatives r;
    memset(&r, 0, sizeof r);
    if (gains->feedforward) {
        double tau[3];
        st = rrr_inverse_dynamics(m, q_ref, qd_ref, qdd_ref, tau);
        if (st != RRR_OK) {
            return st;
        }
        const rrr_trig t = rrr_trig_of(q_ref);
        double Y[3][RRR_NP], da2[3], dg[3], th[3][RRR_NF];
        rrr_gen_regressor(m, &t, qd_ref, qdd_ref, Y);
        rrr_gen_tau_param_jacobian(m, &t, qd_ref, qdd_ref, da2, dg);
        rrr_actuator_friction_tanh(m, qd_ref, th);
        for (int i = 0; i < RRR_NJ; ++i) {
            const double kt = m->kt[i];
            r.du_n[i][COL(a2)] = da2[i] / kt;
            r.du_n[i][COL(g)] = dg[i] / kt;
            for (int l = 0; l < RRR_NP; ++l) {
                r.du_n[i][COL(p) + l] = Y[i][l] / kt;
            }
            r.du_n[i][COL(kt) + i] = -tau[i] / (kt * kt);
            for (int k = 0; k < RRR_NF; ++k) {
                r.du_n[i][COL(f) + RRR_NF * i + k] = th[i][k];
                r.du_n[i][COL(w) + RRR_NF * i + k] =
                    m->f[i][k] * qd_ref[i] * (1.0 - th[i][k] * th[i][k]);
            }
            r.du_n[i][COL(b) + i] = qd_ref[i];
        }
    }
    for (int i = 0; i < RRR_NJ; ++i) {
        const int free_i = !(o.saturated & (1u << i));
        r.du_c_dkp[i] = q_ref[i] - q[i];
        r.du_c_dkd[i] = qd_ref[i] - qd[i];
        r.du_dkp[i] = free_i ? r.du_c_dkp[i] : 0.0;
        r.du_dkd[i] = free_i ? r.du_c_dkd[i] : 0.0;
        for (int c = 0; c < RRR_N_PARAMS; ++c) {
            r.du[i][c] = free_i ? r.du_n[i][c] : 0.0;
        }
        r.du[i][COL(u_max)] = free_i ? 0.0 : (o.u[i] > 0.0 ? 1.0 : -1.0);
    }
    if (!rrr_finite_n(&r.du[0][0], 3 * RRR_N_PARAMS) ||
        !rrr_finite_n(&r.du_n[0][0], 3 * RRR_N_PARAMS)) {
        return RRR_NUMERIC;
    }
    *d = r;
    return RRR_OK;
}
