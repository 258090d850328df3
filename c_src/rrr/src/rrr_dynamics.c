/**
 * @file rrr_dynamics.c
 * @brief Public dynamics API (rrr_dynamics.h): argument checks around the generated closed form
 *        of rrr_dynamics_gen.c, and forward dynamics by a 3 x 3 Cholesky factorisation.
 *
 * Every function checks its pointers and the finiteness of its inputs (including the model fields
 * it uses), computes into locals, checks that the results are finite, and only then writes the
 * outputs: on any error the outputs are untouched.
 */
#include "rrr/rrr_dynamics.h"

#include <math.h>

#include "rrr_dynamics_gen.h"
#include "rrr_internal.h"

/** Model fields a function reads. */
enum { USES_A2 = 1, USES_G = 2, USES_P = 4 };

/** 1 when the model fields named in @p uses are finite. */
static int model_finite(const rrr_model *m, int uses)
{
    if ((uses & USES_A2) && !isfinite(m->a2)) {
        return 0;
    }
    if ((uses & USES_G) && !isfinite(m->g)) {
        return 0;
    }
    if ((uses & USES_P) && !rrr_finite_n(m->p, RRR_NP)) {
        return 0;
    }
    return 1;
}

/*
 * The two hot paths (inverse dynamics for the controller, forward dynamics inside the plant's
 * RK4) check only what cannot reach their result (q1) up front, compute, and classify a
 * non-finite result afterwards: every other input (q2, q3, qd, qdd, tau, a2, g and all 16 p,
 * each of which the generated expressions contain with a structurally nonzero factor) turns the
 * result NaN or Inf when it is NaN or Inf. The statuses are those of checking first.
 */
static rrr_status classify(const rrr_model *m, const double a[3], const double b[3],
                           const double c[3])
{
    if (!model_finite(m, USES_A2 | USES_G | USES_P) || !rrr_finite_n(a, 3)
        || !rrr_finite_n(b, 3) || !rrr_finite_n(c, 3)) {
        return RRR_BAD_INPUT;
    }
    return RRR_NUMERIC;
}

rrr_status rrr_regressor(const rrr_model *m, const double q[3], const double qd[3],
                         const double qdd[3], double Y[3][RRR_NP])
{
    if (m == NULL || q == NULL || qd == NULL || qdd == NULL || Y == NULL) {
        return RRR_BAD_INPUT;
    }
    if (!model_finite(m, USES_A2 | USES_G) || !rrr_finite_n(q, 3) || !rrr_finite_n(qd, 3)
        || !rrr_finite_n(qdd, 3)) {
        return RRR_BAD_INPUT;
    }
    const rrr_trig t = rrr_trig_of(q);
    double y[3][RRR_NP];
    rrr_gen_regressor(m, &t, qd, qdd, y);
    if (!rrr_finite_n(&y[0][0], 3 * RRR_NP)) {
        return RRR_NUMERIC;
    }
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < RRR_NP; ++j) {
            Y[i][j] = y[i][j];
        }
    }
    return RRR_OK;
}

rrr_status rrr_inverse_dynamics(const rrr_model *m, const double q[3], const double qd[3],
                                const double qdd[3], double tau[3])
{
    if (m == NULL || q == NULL || qd == NULL || qdd == NULL || tau == NULL || !isfinite(q[0])) {
        return RRR_BAD_INPUT;
    }
    const rrr_trig t = rrr_trig_of(q);
    double out[3];
    rrr_gen_inverse_dynamics(m, &t, qd, qdd, out);
    if (!rrr_finite_n(out, 3)) {
        return classify(m, q, qd, qdd);
    }
    tau[0] = out[0];
    tau[1] = out[1];
    tau[2] = out[2];
    return RRR_OK;
}

rrr_status rrr_mass_matrix(const rrr_model *m, const double q[3], double D[3][3])
{
    if (m == NULL || q == NULL || D == NULL) {
        return RRR_BAD_INPUT;
    }
    if (!model_finite(m, USES_A2 | USES_P) || !rrr_finite_n(q, 3)) {
        return RRR_BAD_INPUT;
    }
    const rrr_trig t = rrr_trig_of(q);
    double d[3][3];
    rrr_gen_mass_matrix(m, &t, d);
    if (!rrr_finite_n(&d[0][0], 9)) {
        return RRR_NUMERIC;
    }
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            D[i][j] = d[i][j];
        }
    }
    return RRR_OK;
}

rrr_status rrr_coriolis(const rrr_model *m, const double q[3], const double qd[3], double c[3])
{
    if (m == NULL || q == NULL || qd == NULL || c == NULL) {
        return RRR_BAD_INPUT;
    }
    if (!model_finite(m, USES_A2 | USES_P) || !rrr_finite_n(q, 3) || !rrr_finite_n(qd, 3)) {
        return RRR_BAD_INPUT;
    }
    const rrr_trig t = rrr_trig_of(q);
    double out[3];
    rrr_gen_coriolis(m, &t, qd, out);
    if (!rrr_finite_n(out, 3)) {
        return RRR_NUMERIC;
    }
    c[0] = out[0];
    c[1] = out[1];
    c[2] = out[2];
    return RRR_OK;
}

rrr_status rrr_gravity(const rrr_model *m, const double q[3], double h[3])
{
    if (m == NULL || q == NULL || h == NULL) {
        return RRR_BAD_INPUT;
    }
    if (!model_finite(m, USES_G | USES_P) || !rrr_finite_n(q, 3)) {
        return RRR_BAD_INPUT;
    }
    const rrr_trig t = rrr_trig_of(q);
    double out[3];
    rrr_gen_gravity(m, &t, out);
    if (!rrr_finite_n(out, 3)) {
        return RRR_NUMERIC;
    }
    h[0] = out[0];
    h[1] = out[1];
    h[2] = out[2];
    return RRR_OK;
}

/** 1 when a Cholesky pivot is usable (strictly positive and finite). */
static int pivot_ok(double v)
{
    return v > 0.0 && isfinite(v);
}

void rrr_fd_factorize(const rrr_model *m, const double q[3], const double qd[3],
                      rrr_fd_factor *f)
{
    if (!isfinite(q[0])) {
        f->st = RRR_BAD_INPUT;
        return;
    }
    const rrr_trig t = rrr_trig_of(q);
    rrr_fd_factorize_trig(m, q, &t, qd, f);
}

void rrr_fd_factorize_trig(const rrr_model *m, const double q[3], const rrr_trig *tq,
                           const double qd[3], rrr_fd_factor *f)
{
    f->st = RRR_OK;
    if (!isfinite(q[0])) {
        f->st = RRR_BAD_INPUT;
        return;
    }
    f->t = *tq;
    const rrr_trig t = *tq;
    /* bias c(q, qd) + h(q) = tau(q, qd, 0): one fused generated call (82 operations against
     * the 132 of tau with qdd = 0). A non-finite input shows in the bias or in D (the inertial
     * parameters that multiply qdd only, in D): both are checked before the pivots, where a NaN
     * would look like a failed one, and rrr_fd_solve classifies it with tau. */
    rrr_gen_bias(m, &t, qd, f->bias);
    double D[3][3];
    rrr_gen_mass_matrix(m, &t, D);
    if (!rrr_finite_n(f->bias, 3) || !rrr_finite_n(D[0], 3) || !rrr_finite_n(D[1], 3) ||
        !rrr_finite_n(D[2], 3)) {
        f->st = RRR_NUMERIC;
        return;
    }

    /* D = L L^T */
    const double d00 = D[0][0];
    if (!pivot_ok(d00)) {
        f->st = RRR_NOT_POSITIVE_DEFINITE;
        return;
    }
    f->l00 = sqrt(d00);
    f->l10 = D[1][0] / f->l00;
    f->l20 = D[2][0] / f->l00;
    const double d11 = D[1][1] - f->l10 * f->l10;
    if (!pivot_ok(d11)) {
        f->st = RRR_NOT_POSITIVE_DEFINITE;
        return;
    }
    f->l11 = sqrt(d11);
    f->l21 = (D[2][1] - f->l20 * f->l10) / f->l11;
    const double d22 = D[2][2] - f->l20 * f->l20 - f->l21 * f->l21;
    if (!pivot_ok(d22)) {
        f->st = RRR_NOT_POSITIVE_DEFINITE;
        return;
    }
    f->l22 = sqrt(d22);
}

rrr_status rrr_fd_solve(const rrr_model *m, const double q[3], const double qd[3],
                        const rrr_fd_factor *f, const double tau[3], double qdd[3])
{
    if (f->st == RRR_NUMERIC) {
        return classify(m, q, qd, tau);
    }
    if (f->st != RRR_OK) {
        return f->st;
    }
    /* L y = tau - bias, then L^T x = y */
    const double r0 = tau[0] - f->bias[0];
    const double r1 = tau[1] - f->bias[1];
    const double r2 = tau[2] - f->bias[2];
    const double y0 = r0 / f->l00;
    const double y1 = (r1 - f->l10 * y0) / f->l11;
    const double y2 = (r2 - f->l20 * y0 - f->l21 * y1) / f->l22;
    double x[3];
    x[2] = y2 / f->l22;
    x[1] = (y1 - f->l21 * x[2]) / f->l11;
    x[0] = (y0 - f->l10 * x[1] - f->l20 * x[2]) / f->l00;
    if (!rrr_finite_n(x, 3)) {
        return classify(m, q, qd, tau);
    }
    qdd[0] = x[0];
    qdd[1] = x[1];
    qdd[2] = x[2];
    return RRR_OK;
}

rrr_status rrr_forward_dynamics(const rrr_model *m, const double q[3], const double qd[3],
                                const double tau[3], double qdd[3])
{
    if (m == NULL || q == NULL || qd == NULL || tau == NULL || qdd == NULL) {
        return RRR_BAD_INPUT;
    }
    rrr_fd_factor f;
    rrr_fd_factorize(m, q, qd, &f);
    return rrr_fd_solve(m, q, qd, &f, tau, qdd);
}

rrr_status rrr_energy(const rrr_model *m, const double q[3], const double qd[3],
                      double *kinetic, double *potential)
{
    if (m == NULL || q == NULL || qd == NULL || kinetic == NULL || potential == NULL) {
        return RRR_BAD_INPUT;
    }
    if (!model_finite(m, USES_A2 | USES_G | USES_P) || !rrr_finite_n(q, 3)
        || !rrr_finite_n(qd, 3)) {
        return RRR_BAD_INPUT;
    }
    const rrr_trig t = rrr_trig_of(q);
    double D[3][3];
    rrr_gen_mass_matrix(m, &t, D);
    double ke = 0.0;
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) {
            ke += qd[i] * D[i][j] * qd[j];
        }
    }
    ke *= 0.5;
    const double pe = rrr_gen_potential(m, &t);
    if (!isfinite(ke) || !isfinite(pe)) {
        return RRR_NUMERIC;
    }
    *kinetic = ke;
    *potential = pe;
    return RRR_OK;
}

rrr_status rrr_regressor_structure(unsigned p_cols[3], unsigned *g_rows)
{
    if (p_cols == NULL || g_rows == NULL) {
        return RRR_BAD_INPUT;
    }
    static const unsigned cols[3] = RRR_GEN_REGRESSOR_COLS;
    p_cols[0] = cols[0];
    p_cols[1] = cols[1];
    p_cols[2] = cols[2];
    *g_rows = RRR_GEN_GRAVITY_ROWS;
    return RRR_OK;
}
