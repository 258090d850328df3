/* Exact partial derivatives (rrr_derivatives.h) against central finite differences of the
 * functions they differentiate, on random states: d tau / d(q, qd), the friction slope, the
 * plant's d qdd / d(q, qd, u) (saturated inputs included), the computed-torque law's
 * d(u, u_n, u_c) / d(q_ref, qd_ref, qdd_ref, q, qd), and d qdd, d tip, d u by every model
 * parameter and gain. Prints the worst relative error per block. */
#include <string.h>

#include "rrr/rrr.h"
#include "rrr_test.h"

#define N_SAMPLES 1000
/* central differences with the step h_j = H_REL max(1, |x_j|): truncation h^2 f'''/6 and
 * rounding eps |f| / h both stay near 1e-10 relative on the default robot (friction slopes up to
 * w = 100 s/rad) */
#define H_REL 1e-6
#define TOL 1e-6

/* worst error of a block relative to the block's largest finite-difference entry */
static double block_error(const double *a, const double *fd, int n)
{
    double num = 0.0, den = 0.0;
    for (int k = 0; k < n; ++k) {
        num = fmax(num, fabs(a[k] - fd[k]));
        den = fmax(den, fabs(fd[k]));
    }
    return den > 0.0 ? num / den : num;
}

static double worst[16];
static const char *const worst_name[16] = {
    "dtau/dq",   "dtau/dqd",  "duf/dqd",    "dqdd/dq",     "dqdd/dqd", "dqdd/du",
    "du/dq_ref", "du/dqd_ref", "du/dqdd_ref", "du/dq",      "du/dqd",   "du_n/dq_ref",
    "du_n/dqd_ref", "du_n/dqdd_ref", "du_c/dq_ref", "du_c/dqd"};

static void record(int slot, double err)
{
    worst[slot] = fmax(worst[slot], err);
    if (!(err <= TOL)) {
        fprintf(stderr, "%s: relative error %.3g > %g\n", worst_name[slot], err, TOL);
        rrr_test_failures++;
    }
}

static double step_of(double x)
{
    return H_REL * fmax(1.0, fabs(x));
}

static void test_inverse_dynamics(const rrr_model *m, const double q[3], const double qd[3],
                                  const double qdd[3])
{
    double a[3][3], b[3][3], fq[3][3], fqd[3][3];
    CHECK_STATUS(rrr_inverse_dynamics_jacobian(m, q, qd, qdd, a, b), RRR_OK);
    for (int j = 0; j < 3; ++j) {
        double xp[3], xm[3], tp[3], tm[3];
        const double h = step_of(q[j]);
        memcpy(xp, q, sizeof xp);
        memcpy(xm, q, sizeof xm);
        xp[j] += h;
        xm[j] -= h;
        rrr_inverse_dynamics(m, xp, qd, qdd, tp);
        rrr_inverse_dynamics(m, xm, qd, qdd, tm);
        for (int i = 0; i < 3; ++i) {
            fq[i][j] = (tp[i] - tm[i]) / (xp[j] - xm[j]);
        }
        const double hv = step_of(qd[j]);
        memcpy(xp, qd, sizeof xp);
        memcpy(xm, qd, sizeof xm);
        xp[j] += hv;
        xm[j] -= hv;
        rrr_inverse_dynamics(m, q, xp, qdd, tp);
        rrr_inverse_dynamics(m, q, xm, qdd, tm);
        for (int i = 0; i < 3; ++i) {
            fqd[i][j] = (tp[i] - tm[i]) / (xp[j] - xm[j]);
        }
    }
    record(0, block_error(&a[0][0], &fq[0][0], 9));
    record(1, block_error(&b[0][0], &fqd[0][0], 9));
    CHECK(a[0][0] == 0.0 && a[1][0] == 0.0 && a[2][0] == 0.0);
}

static void test_friction_slope(const rrr_model *m, const double qd[3])
{
    double s[3], fd[3];
    CHECK_STATUS(rrr_friction_slope(m, qd, s), RRR_OK);
    for (int j = 0; j < 3; ++j) {
        double xp[3], xm[3], up[3], um[3];
        memcpy(xp, qd, sizeof xp);
        memcpy(xm, qd, sizeof xm);
        xp[j] += step_of(qd[j]);
        xm[j] -= step_of(qd[j]);
        rrr_friction(m, xp, up);
        rrr_friction(m, xm, um);
        fd[j] = (up[j] - um[j]) / (xp[j] - xm[j]);
        /* the friction of joint i depends on qd_i only */
        for (int i = 0; i < 3; ++i) {
            if (i != j) {
                CHECK(up[i] == um[i]);
            }
        }
    }
    record(2, block_error(s, fd, 3));
}

/* column j of d qdd / d (one of q, qd, u) by central differences of rrr_plant_accel */
static void plant_fd(const rrr_model *m, const rrr_plant_state *x0, const double u0[3], int which,
                     double fd[3][3])
{
    for (int j = 0; j < 3; ++j) {
        rrr_plant_state xp = *x0, xm = *x0;
        double up[3], um[3], ap[3], am[3];
        memcpy(up, u0, sizeof up);
        memcpy(um, u0, sizeof um);
        double *vp = which == 0 ? xp.q : which == 1 ? xp.qd : up;
        double *vm = which == 0 ? xm.q : which == 1 ? xm.qd : um;
        const double h = step_of(vp[j]);
        vp[j] += h;
        vm[j] -= h;
        CHECK_STATUS(rrr_plant_accel(m, &xp, up, ap), RRR_OK);
        CHECK_STATUS(rrr_plant_accel(m, &xm, um, am), RRR_OK);
        for (int i = 0; i < 3; ++i) {
            fd[i][j] = (ap[i] - am[i]) / (vp[j] - vm[j]);
        }
    }
}

static void test_plant(const rrr_model *m, const rrr_plant_state *x, const double u[3])
{
    rrr_plant_derivatives d;
    CHECK_STATUS(rrr_plant_jacobian(m, x, u, &d), RRR_OK);
    double qdd[3];
    CHECK_STATUS(rrr_plant_accel(m, x, u, qdd), RRR_OK);
    CHECK(memcmp(qdd, d.qdd, sizeof qdd) == 0); /* the same qdd, bit for bit */
    double fd[3][3];
    plant_fd(m, x, u, 0, fd);
    record(3, block_error(&d.dqdd_dq[0][0], &fd[0][0], 9));
    plant_fd(m, x, u, 1, fd);
    record(4, block_error(&d.dqdd_dqd[0][0], &fd[0][0], 9));
    plant_fd(m, x, u, 2, fd);
    record(5, block_error(&d.dqdd_du[0][0], &fd[0][0], 9));
    for (int j = 0; j < 3; ++j) {
        const int clamped = fabs(u[j]) > m->u_max;
        CHECK(((d.saturated >> j) & 1u) == (unsigned)clamped);
        if (clamped) {
            CHECK(d.dqdd_du[0][j] == 0.0 && d.dqdd_du[1][j] == 0.0 && d.dqdd_du[2][j] == 0.0);
        }
    }
}

typedef struct ctc_point {
    double in[RRR_CTC_INPUT_COUNT][3];
} ctc_point;

static void ctc_eval(const rrr_model *m, const rrr_ctc_gains *k, const ctc_point *p,
                     rrr_ctc_output *o)
{
    CHECK_STATUS(rrr_ctc(m, k, p->in[RRR_CTC_Q_REF], p->in[RRR_CTC_QD_REF],
                         p->in[RRR_CTC_QDD_REF], p->in[RRR_CTC_Q], p->in[RRR_CTC_QD], o),
                 RRR_OK);
}

static void test_ctc(const rrr_model *m, const rrr_ctc_gains *k, const ctc_point *p)
{
    rrr_ctc_derivatives d;
    CHECK_STATUS(rrr_ctc_jacobian(m, k, p->in[RRR_CTC_Q_REF], p->in[RRR_CTC_QD_REF],
                                  p->in[RRR_CTC_QDD_REF], p->in[RRR_CTC_Q], p->in[RRR_CTC_QD],
                                  &d),
                 RRR_OK);
    rrr_ctc_output o;
    ctc_eval(m, k, p, &o);
    CHECK(memcmp(&o, &d.out, sizeof o) == 0);
    for (int in = 0; in < RRR_CTC_INPUT_COUNT; ++in) {
        double fu[3][3], fn[3][3], fc[3][3];
        for (int j = 0; j < 3; ++j) {
            ctc_point pp = *p, pm = *p;
            const double h = step_of(p->in[in][j]);
            pp.in[in][j] += h;
            pm.in[in][j] -= h;
            rrr_ctc_output op, om;
            ctc_eval(m, k, &pp, &op);
            ctc_eval(m, k, &pm, &om);
            const double dx = pp.in[in][j] - pm.in[in][j];
            for (int i = 0; i < 3; ++i) {
                fu[i][j] = (op.u[i] - om.u[i]) / dx;
                fn[i][j] = (op.u_n[i] - om.u_n[i]) / dx;
                fc[i][j] = (op.u_c[i] - om.u_c[i]) / dx;
            }
        }
        record(6 + in, block_error(&d.du[in][0][0], &fu[0][0], 9));
        if (in <= RRR_CTC_QDD_REF) {
            record(11 + in, block_error(&d.du_n[in][0][0], &fn[0][0], 9));
        }
        if (in == RRR_CTC_Q_REF || in == RRR_CTC_QD) {
            record(in == RRR_CTC_Q_REF ? 14 : 15, block_error(&d.du_c[in][0][0], &fc[0][0], 9));
        }
    }
}

/* d/d(model parameter c) by central differences: the model with parameter c moved */
static rrr_model moved(const rrr_model *m, int c, double h)
{
    rrr_model x = *m;
    double v[RRR_N_PARAMS];
    memcpy(v, &x, sizeof v);
    v[c] += h;
    memcpy(&x, v, sizeof v);
    return x;
}

static double param_value(const rrr_model *m, int c)
{
    double v[RRR_N_PARAMS];
    memcpy(v, m, sizeof v);
    return v[c];
}

static double worst_param[3];

static void record_param(int slot, double err, const char *what)
{
    worst_param[slot] = fmax(worst_param[slot], err);
    if (!(err <= TOL)) {
        fprintf(stderr, "%s: relative error %.3g > %g\n", what, err, TOL);
        rrr_test_failures++;
    }
}

static void test_params(const rrr_model *m, const rrr_ctc_gains *k, const rrr_plant_state *x,
                        const double u[3], const ctc_point *pt)
{
    double dqdd[3][RRR_N_PARAMS], dx[3][RRR_N_PARAMS], fq[3][RRR_N_PARAMS], fx[3][RRR_N_PARAMS];
    double fu[3][RRR_N_PARAMS], fn[3][RRR_N_PARAMS];
    rrr_ctc_param_derivatives cd;
    CHECK_STATUS(rrr_plant_param_jacobian(m, x, u, dqdd), RRR_OK);
    CHECK_STATUS(rrr_fk_param_jacobian(m, x->q, dx), RRR_OK);
    CHECK_STATUS(rrr_ctc_param_jacobian(m, k, pt->in[RRR_CTC_Q_REF], pt->in[RRR_CTC_QD_REF],
                                        pt->in[RRR_CTC_QDD_REF], pt->in[RRR_CTC_Q],
                                        pt->in[RRR_CTC_QD], &cd),
                 RRR_OK);
    for (int c = 0; c < RRR_N_PARAMS; ++c) {
        const double h = step_of(param_value(m, c));
        const rrr_model mp = moved(m, c, h), mm = moved(m, c, -h);
        const double dp = param_value(&mp, c) - param_value(&mm, c);
        double ap[3], am[3], xp[3], xm[3];
        CHECK_STATUS(rrr_plant_accel(&mp, x, u, ap), RRR_OK);
        CHECK_STATUS(rrr_plant_accel(&mm, x, u, am), RRR_OK);
        CHECK_STATUS(rrr_fk(&mp, x->q, xp, NULL), RRR_OK);
        CHECK_STATUS(rrr_fk(&mm, x->q, xm, NULL), RRR_OK);
        rrr_ctc_output op, om;
        ctc_eval(&mp, k, pt, &op);
        ctc_eval(&mm, k, pt, &om);
        for (int i = 0; i < 3; ++i) {
            fq[i][c] = (ap[i] - am[i]) / dp;
            fx[i][c] = (xp[i] - xm[i]) / dp;
            fu[i][c] = (op.u[i] - om.u[i]) / dp;
            fn[i][c] = (op.u_n[i] - om.u_n[i]) / dp;
        }
    }
    record_param(0, block_error(&dqdd[0][0], &fq[0][0], 3 * RRR_N_PARAMS), "dqdd/dparam");
    record_param(1, block_error(&dx[0][0], &fx[0][0], 3 * RRR_N_PARAMS), "dtip/dparam");
    record_param(2, fmax(block_error(&cd.du[0][0], &fu[0][0], 3 * RRR_N_PARAMS),
                         block_error(&cd.du_n[0][0], &fn[0][0], 3 * RRR_N_PARAMS)),
                 "du/dparam");
    /* the gains: u_c is linear in kp and kd */
    for (int i = 0; i < 3; ++i) {
        rrr_ctc_gains kp = *k, km = *k;
        const double h = step_of(k->kp[i]);
        kp.kp[i] += h;
        km.kp[i] -= h;
        rrr_ctc_output op, om;
        ctc_eval(m, &kp, pt, &op);
        ctc_eval(m, &km, pt, &om);
        const double fd = (op.u[i] - om.u[i]) / (kp.kp[i] - km.kp[i]);
        record_param(2, fabs(cd.du_dkp[i] - fd) / fmax(fabs(fd), 1.0), "du/dkp");
        kp = *k;
        km = *k;
        kp.kd[i] += step_of(k->kd[i]);
        km.kd[i] -= step_of(k->kd[i]);
        ctc_eval(m, &kp, pt, &op);
        ctc_eval(m, &km, pt, &om);
        const double fdd = (op.u_c[i] - om.u_c[i]) / (kp.kd[i] - km.kd[i]);
        record_param(2, fabs(cd.du_c_dkd[i] - fdd) / fmax(fabs(fdd), 1.0), "du_c/dkd");
    }
}

static void test_refusals(const rrr_model *m, const rrr_ctc_gains *k)
{
    const double z[3] = {0.0, 0.0, 0.0}, bad[3] = {0.0, (double)NAN, 0.0};
    double a[3][3], b[3][3], s[3];
    CHECK_STATUS(rrr_inverse_dynamics_jacobian(NULL, z, z, z, a, b), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_inverse_dynamics_jacobian(m, bad, z, z, a, b), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_inverse_dynamics_jacobian(m, z, z, bad, a, b), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_inverse_dynamics_jacobian(m, z, z, z, NULL, b), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_friction_slope(m, bad, s), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_friction_slope(m, z, NULL), RRR_BAD_INPUT);
    rrr_plant_state x;
    CHECK_STATUS(rrr_plant_state_init(z, z, &x), RRR_OK);
    rrr_plant_derivatives d, keep;
    memset(&d, 0x5a, sizeof d);
    keep = d;
    CHECK_STATUS(rrr_plant_jacobian(m, &x, bad, &d), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_plant_jacobian(m, NULL, z, &d), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_plant_jacobian(m, &x, z, NULL), RRR_BAD_INPUT);
    x.qd[2] = (double)INFINITY;
    CHECK_STATUS(rrr_plant_jacobian(m, &x, z, &d), RRR_BAD_INPUT);
    CHECK(memcmp(&d, &keep, sizeof d) == 0); /* nothing written */
    rrr_model broken = *m;
    broken.p[6] = -1.0; /* D(q) not positive definite */
    CHECK(rrr_plant_jacobian(&broken, &x, z, &d) != RRR_OK);
    rrr_ctc_derivatives c;
    CHECK_STATUS(rrr_ctc_jacobian(m, k, z, z, bad, z, z, &c), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_ctc_jacobian(m, k, z, z, z, z, z, NULL), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_ctc_jacobian(m, NULL, z, z, z, z, z, &c), RRR_BAD_INPUT);
    double dp[3][RRR_N_PARAMS];
    rrr_ctc_param_derivatives cp;
    CHECK_STATUS(rrr_plant_param_jacobian(m, &x, z, dp), RRR_BAD_INPUT); /* x.qd[2] = Inf */
    CHECK_STATUS(rrr_plant_param_jacobian(m, &x, z, NULL), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_fk_param_jacobian(m, bad, dp), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_ctc_param_jacobian(m, k, z, bad, z, z, z, &cp), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_ctc_param_jacobian(m, k, z, z, z, z, z, NULL), RRR_BAD_INPUT);
}

int main(void)
{
    rrr_model m;
    rrr_model_default(&m);
    rrr_ctc_gains k;
    rrr_ctc_gains_default(&k);
    rrr_ctc_gains pd = k;
    pd.feedforward = 0;
    rrr_rng rng = {0x25a5eedULL};
    for (int n = 0; n < N_SAMPLES; ++n) {
        double q[3], qd[3], qdd[3], u[3];
        for (int i = 0; i < 3; ++i) {
            q[i] = rrr_rng_uniform(&rng, -4.0, 4.0);
            qd[i] = rrr_rng_uniform(&rng, -3.0, 3.0);
            qdd[i] = rrr_rng_uniform(&rng, -20.0, 20.0);
            /* every fourth sample has inputs beyond the limit (by far more than a step) */
            u[i] = rrr_rng_uniform(&rng, -0.98, 0.98) * m.u_max * (n % 4 == 3 ? 1.5 : 1.0);
            if (n % 4 == 3 && fabs(u[i]) < 1.02 * m.u_max) {
                u[i] = copysign(1.2 * m.u_max, u[i]);
            }
        }
        test_inverse_dynamics(&m, q, qd, qdd);
        test_friction_slope(&m, qd);
        rrr_plant_state x;
        rrr_plant_state_init(q, qd, &x);
        test_plant(&m, &x, u);
        ctc_point p;
        for (int i = 0; i < 3; ++i) {
            p.in[RRR_CTC_Q_REF][i] = q[i];
            p.in[RRR_CTC_QD_REF][i] = qd[i];
            p.in[RRR_CTC_QDD_REF][i] = 0.1 * qdd[i];
            /* tracking errors small enough for the law to stay unsaturated most of the time */
            p.in[RRR_CTC_Q][i] = q[i] + rrr_rng_uniform(&rng, -0.02, 0.02);
            p.in[RRR_CTC_QD][i] = qd[i] + rrr_rng_uniform(&rng, -0.2, 0.2);
        }
        rrr_ctc_output o;
        ctc_eval(&m, &k, &p, &o);
        int near_kink = 0;
        for (int i = 0; i < 3; ++i) {
            near_kink |= fabs(fabs(o.u_n[i] + o.u_c[i]) - m.u_max) < 1e-3;
        }
        if (!near_kink) {
            test_ctc(&m, n % 5 == 4 ? &pd : &k, &p);
            if (n % 10 == 0 || n % 20 == 3) { /* 47 parameters: every tenth state, and
                                                 * saturated inputs (n % 4 == 3) */
                test_params(&m, n % 20 == 0 ? &k : &pd, &x, u, &p);
            }
        }
    }
    test_refusals(&m, &k);
    for (int s = 0; s < 16; ++s) {
        printf("  %-14s worst relative error %.2e\n", worst_name[s], worst[s]);
    }
    printf("  dqdd/dparam    worst relative error %.2e\n", worst_param[0]);
    printf("  dtip/dparam    worst relative error %.2e\n", worst_param[1]);
    printf("  du/dparam      worst relative error %.2e (model parameters and gains)\n",
           worst_param[2]);
    return rrr_test_report("test_derivatives");
}
