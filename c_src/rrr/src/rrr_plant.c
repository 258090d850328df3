/* The plant: voltages in, joint motion out, integrated by Dormand-Prince 5(4) with step-size
 * control or by fixed-step RK4 (see rrr_plant.h). */
#include <string.h>

#include "rrr_internal.h"

void rrr_plant_prepare(const rrr_model *m, int params_ok, const double q[3], const double qd[3],
                       rrr_plant_prep *p)
{
    memcpy(p->q, q, sizeof p->q);
    memcpy(p->qd, qd, sizeof p->qd);
    p->input_ok = rrr_actuator_friction(m, params_ok, qd, p->uf);
    if (p->input_ok) {
        rrr_fd_factorize(m, q, qd, &p->fd);
    }
}

void rrr_plant_prepare_trig(const rrr_model *m, int params_ok, const double q[3],
                            const rrr_trig *t, const double qd[3], rrr_plant_prep *p)
{
    memcpy(p->q, q, sizeof p->q);
    memcpy(p->qd, qd, sizeof p->qd);
    p->input_ok = rrr_actuator_friction(m, params_ok, qd, p->uf);
    if (p->input_ok) {
        rrr_fd_factorize_trig(m, q, t, qd, &p->fd);
    }
}

/* rrr_torque_from_voltage then rrr_forward_dynamics, with their statuses in their order */
rrr_status rrr_plant_accel_prepared(const rrr_model *m, const rrr_plant_prep *p,
                                    const double u[3], double qdd[3])
{
    if (!p->input_ok) {
        return RRR_BAD_INPUT;
    }
    double tau[3];
    const rrr_status st = rrr_actuator_torque(m, p->uf, u, tau);
    if (st != RRR_OK) {
        return st;
    }
    return rrr_fd_solve(m, p->q, p->qd, &p->fd, tau, qdd);
}

/* What every evaluation of the right-hand side within one call shares: the model, whether its
 * actuator parameters are valid (checked once per call, not per evaluation) and the input. */
typedef struct rhs {
    const rrr_model *m;
    int params_ok;
    const double *u;
} rhs;

static rhs rhs_of(const rrr_model *m, const double u[3])
{
    const rhs r = {m, rrr_actuator_params_ok(m), u};
    return r;
}

static rrr_status accel(const rhs *r, const double q[3], const double qd[3], double qdd[3])
{
    rrr_plant_prep p;
    rrr_plant_prepare(r->m, r->params_ok, q, qd, &p);
    return rrr_plant_accel_prepared(r->m, &p, r->u, qdd);
}

rrr_status rrr_plant_accel(const rrr_model *m, const rrr_plant_state *x, const double u[3],
                           double qdd[3])
{
    if (m == NULL || x == NULL || u == NULL || qdd == NULL) {
        return RRR_BAD_INPUT;
    }
    const rhs r = rhs_of(m, u);
    return accel(&r, x->q, x->qd, qdd);
}

/* One classic Runge-Kutta 4 step of length dt on (q, qd). */
static rrr_status rk4(const rhs *r, double dt, double q[3], double qd[3])
{
    double k1v[3], k2v[3], k3v[3], k4v[3]; /* accelerations */
    double qa[3], va[3];
    rrr_status st = accel(r, q, qd, k1v);
    for (int i = 0; i < 3 && st == RRR_OK; ++i) {
        qa[i] = q[i] + 0.5 * dt * qd[i];
        va[i] = qd[i] + 0.5 * dt * k1v[i];
    }
    double k2q[3];
    memcpy(k2q, va, sizeof va);
    if (st == RRR_OK) {
        st = accel(r, qa, va, k2v);
    }
    for (int i = 0; i < 3 && st == RRR_OK; ++i) {
        qa[i] = q[i] + 0.5 * dt * k2q[i];
        va[i] = qd[i] + 0.5 * dt * k2v[i];
    }
    double k3q[3];
    memcpy(k3q, va, sizeof va);
    if (st == RRR_OK) {
        st = accel(r, qa, va, k3v);
    }
    for (int i = 0; i < 3 && st == RRR_OK; ++i) {
        qa[i] = q[i] + dt * k3q[i];
        va[i] = qd[i] + dt * k3v[i];
    }
    double k4q[3];
    memcpy(k4q, va, sizeof va);
    if (st == RRR_OK) {
        st = accel(r, qa, va, k4v);
    }
    if (st != RRR_OK) {
        return st;
    }
    for (int i = 0; i < 3; ++i) {
        q[i] += dt / 6.0 * (qd[i] + 2.0 * k2q[i] + 2.0 * k3q[i] + k4q[i]);
        qd[i] += dt / 6.0 * (k1v[i] + 2.0 * k2v[i] + 2.0 * k3v[i] + k4v[i]);
    }
    return RRR_OK;
}

/* ---- settings and state ------------------------------------------------------------------ */

rrr_status rrr_plant_integrator_default(rrr_plant_integrator *s)
{
    if (s == NULL) {
        return RRR_BAD_INPUT;
    }
    s->adaptive = 1;
    s->rtol = RRR_PLANT_RTOL_DEFAULT;
    s->atol = RRR_PLANT_ATOL_DEFAULT;
    s->h_int = RRR_PLANT_H_INT_DEFAULT;
    s->max_steps = RRR_PLANT_MAX_STEPS_DEFAULT;
    return RRR_OK;
}

static int tol_ok(double tol)
{
    return tol >= RRR_PLANT_TOL_MIN && tol <= RRR_PLANT_TOL_MAX; /* false for NaN */
}

rrr_status rrr_plant_integrator_check(const rrr_plant_integrator *s, const char **field)
{
    const char *bad = NULL;
    if (s == NULL) {
        bad = "settings";
    } else if (!tol_ok(s->rtol)) {
        bad = "rtol";
    } else if (!tol_ok(s->atol)) {
        bad = "atol";
    } else if (!isfinite(s->h_int) || !(s->h_int > 0.0)) {
        bad = "h_int";
    } else if (s->max_steps < 1) {
        bad = "max_steps";
    }
    if (field != NULL) {
        *field = bad != NULL ? bad : "";
    }
    return bad != NULL ? RRR_BAD_INPUT : RRR_OK;
}

rrr_status rrr_plant_state_init(const double q0[3], const double qd0[3], rrr_plant_state *x)
{
    if (q0 == NULL || qd0 == NULL || x == NULL || !rrr_finite_n(q0, 3) || !rrr_finite_n(qd0, 3)) {
        return RRR_BAD_INPUT;
    }
    rrr_plant_state s;
    memcpy(s.q, q0, sizeof s.q);
    memcpy(s.qd, qd0, sizeof s.qd);
    s.h_guess = 0.0;
    s.err_prev = 0.0;
    *x = s;
    return RRR_OK;
}

/* ---- fixed step: RK4 --------------------------------------------------------------------- */

static rrr_status step_fixed(const rhs *r, const rrr_plant_integrator *s, double h,
                             rrr_plant_state *x, double qdd[3], rrr_plant_stats *stats)
{
    /* 1e-3 / 1e-4 is 10 substeps, not 11 */
    const double n_real = ceil(h / s->h_int * (1.0 - 1e-12));
    if (!(n_real <= (double)s->max_steps)) {
        return RRR_BAD_INPUT;
    }
    const long n = n_real < 1.0 ? 1L : (long)n_real;
    const double dt = h / (double)n;
    double q[3], qd[3], a[3];
    memcpy(q, x->q, sizeof q);
    memcpy(qd, x->qd, sizeof qd);
    for (long k = 0; k < n; ++k) {
        const rrr_status st = rk4(r, dt, q, qd);
        if (st != RRR_OK) {
            return st;
        }
        if (!rrr_finite_n(q, 3) || !rrr_finite_n(qd, 3)) {
            return RRR_NUMERIC;
        }
    }
    const rrr_status st = accel(r, q, qd, a);
    if (st != RRR_OK) {
        return st;
    }
    memcpy(x->q, q, sizeof q);
    memcpy(x->qd, qd, sizeof qd);
    if (qdd != NULL) {
        memcpy(qdd, a, sizeof a);
    }
    if (stats != NULL) {
        stats->steps = n;
        stats->rejected = 0;
        stats->evals = 4 * n + 1;
    }
    return RRR_OK;
}

/* ---- adaptive: Dormand-Prince 5(4) ---------------------------------------------------------- */

/* y = (q, qd), f(y) = (qd, qdd): six components. */
enum { NY = 6 };

/* f(y) under u. RRR_NUMERIC when y is not finite (a trial stage ran away: the caller rejects the
 * step), otherwise the status of the acceleration. */
static rrr_status deriv(const rhs *r, const double y[NY], double f[NY])
{
    if (!rrr_finite_n(y, NY)) {
        return RRR_NUMERIC;
    }
    memcpy(f, y + 3, 3 * sizeof f[0]);
    return accel(r, y, y + 3, f + 3);
}

/* deriv at a stage y of a step from y0, whose trig is t0: the trig of y from t0
 * (rrr_trig_near), not from libm. For the inner stages only: the end state's evaluation (the
 * output qdd and the next step's first stage) takes libm's, as rrr_plant_accel does. */
static rrr_status deriv_near(const rhs *r, const double y[NY], const rrr_trig *t0,
                             const double y0[NY], double f[NY])
{
    if (!rrr_finite_n(y, NY)) {
        return RRR_NUMERIC;
    }
    memcpy(f, y + 3, 3 * sizeof f[0]);
    const rrr_trig t = rrr_trig_near(t0, y0, y);
    rrr_plant_prep p;
    rrr_plant_prepare_trig(r->m, r->params_ok, y, &t, y + 3, &p);
    return rrr_plant_accel_prepared(r->m, &p, r->u, f + 3);
}

/* deriv, leaving the first half of the right-hand side at y in *p (when y is finite) */
static rrr_status deriv_keep(const rhs *r, const double y[NY], double f[NY], rrr_plant_prep *p)
{
    if (!rrr_finite_n(y, NY)) {
        return RRR_NUMERIC;
    }
    memcpy(f, y + 3, 3 * sizeof f[0]);
    rrr_plant_prepare(r->m, r->params_ok, y, y + 3, p);
    return rrr_plant_accel_prepared(r->m, p, r->u, f + 3);
}

/* Error-test scale of component i. */
static double scale(const rrr_plant_integrator *s, double a, double b)
{
    return s->atol + s->rtol * fmax(fabs(a), fabs(b));
}

/* Dormand and Prince's coefficients (Hairer, Norsett, Wanner, Table II.5.2). */
#define A21 (1.0 / 5.0)
#define A31 (3.0 / 40.0)
#define A32 (9.0 / 40.0)
#define A41 (44.0 / 45.0)
#define A42 (-56.0 / 15.0)
#define A43 (32.0 / 9.0)
#define A51 (19372.0 / 6561.0)
#define A52 (-25360.0 / 2187.0)
#define A53 (64448.0 / 6561.0)
#define A54 (-212.0 / 729.0)
#define A61 (9017.0 / 3168.0)
#define A62 (-355.0 / 33.0)
#define A63 (46732.0 / 5247.0)
#define A64 (49.0 / 176.0)
#define A65 (-5103.0 / 18656.0)
#define B1 (35.0 / 384.0) /* 5th-order weights = the 7th stage's row (FSAL); b2 = b7 = 0 */
#define B3 (500.0 / 1113.0)
#define B4 (125.0 / 192.0)
#define B5 (-2187.0 / 6784.0)
#define B6 (11.0 / 84.0)
#define E1 (71.0 / 57600.0) /* b - b_hat (4th order), e2 = 0 */
#define E3 (-71.0 / 16695.0)
#define E4 (71.0 / 1920.0)
#define E5 (-17253.0 / 339200.0)
#define E6 (22.0 / 525.0)
#define E7 (-1.0 / 40.0)

/* One trial step of length h from y (ty: its trig), k1 = f(y): the 5th-order y5, k7 = f(y5) (and
 * its first half in *p7) and the scaled RMS error. Stages 2-6 take their trig from ty
 * (deriv_near); k7 from libm, so the end state's qdd and first half are those of a fresh
 * evaluation there. A stage that is not finite or whose acceleration is RRR_NUMERIC makes err infinite (the
 * step is rejected); any other failure is returned. */
static rrr_status dp5_trial(const rhs *r, const rrr_plant_integrator *s, double h, const double y[NY], const rrr_trig *ty, const double k1[NY], double y5[NY],
                            double k7[NY], rrr_plant_prep *p7, double *err)
{
    double k2[NY], k3[NY], k4[NY], k5[NY], k6[NY], ys[NY];
    rrr_status st;
    for (int i = 0; i < NY; ++i) {
        ys[i] = y[i] + h * (A21 * k1[i]);
    }
    st = deriv_near(r, ys, ty, y, k2);
    if (st == RRR_OK) {
        for (int i = 0; i < NY; ++i) {
            ys[i] = y[i] + h * (A31 * k1[i] + A32 * k2[i]);
        }
        st = deriv_near(r, ys, ty, y, k3);
    }
    if (st == RRR_OK) {
        for (int i = 0; i < NY; ++i) {
            ys[i] = y[i] + h * (A41 * k1[i] + A42 * k2[i] + A43 * k3[i]);
        }
        st = deriv_near(r, ys, ty, y, k4);
    }
    if (st == RRR_OK) {
        for (int i = 0; i < NY; ++i) {
            ys[i] = y[i] + h * (A51 * k1[i] + A52 * k2[i] + A53 * k3[i] + A54 * k4[i]);
        }
        st = deriv_near(r, ys, ty, y, k5);
    }
    if (st == RRR_OK) {
        for (int i = 0; i < NY; ++i) {
            ys[i] = y[i] + h * (A61 * k1[i] + A62 * k2[i] + A63 * k3[i] + A64 * k4[i] +
                                A65 * k5[i]);
        }
        st = deriv_near(r, ys, ty, y, k6);
    }
    if (st == RRR_OK) {
        for (int i = 0; i < NY; ++i) {
            y5[i] = y[i] + h * (B1 * k1[i] + B3 * k3[i] + B4 * k4[i] + B5 * k5[i] + B6 * k6[i]);
        }
        st = deriv_keep(r, y5, k7, p7);
    }
    if (st == RRR_NUMERIC) {
        *err = (double)INFINITY;
        return RRR_OK;
    }
    if (st != RRR_OK) {
        return st;
    }
    double sum = 0.0;
    for (int i = 0; i < NY; ++i) {
        const double e = h * (E1 * k1[i] + E3 * k3[i] + E4 * k4[i] + E5 * k5[i] + E6 * k6[i] +
                              E7 * k7[i]);
        const double ratio = e / scale(s, y[i], y5[i]);
        sum += ratio * ratio;
    }
    *err = sqrt(sum / (double)NY); /* NaN cannot pass the error test either */
    return RRR_OK;
}

/* Starting step when the state has no proposal (Hairer's hinit for order 5): a step that would
 * change y by 1 % of its scale at the initial slope, checked against a second derivative from
 * one explicit Euler step, capped by 100 times the first guess and by the interval. */
static double initial_step(const rhs *r, const rrr_plant_integrator *s, double interval, const double y[NY], const double f0[NY],
                           long *evals)
{
    double dnf = 0.0, dny = 0.0;
    for (int i = 0; i < NY; ++i) {
        const double sk = scale(s, y[i], y[i]);
        dnf += (f0[i] / sk) * (f0[i] / sk);
        dny += (y[i] / sk) * (y[i] / sk);
    }
    double h = (dnf <= 1e-10 || dny <= 1e-10) ? 1e-6 : sqrt(dny / dnf) * 0.01;
    h = fmin(h, interval);
    double y1[NY], f1[NY];
    for (int i = 0; i < NY; ++i) {
        y1[i] = y[i] + h * f0[i];
    }
    ++*evals;
    if (deriv(r, y1, f1) != RRR_OK) {
        return h; /* the step-size control takes it from here */
    }
    double der2 = 0.0;
    for (int i = 0; i < NY; ++i) {
        const double d = (f1[i] - f0[i]) / scale(s, y[i], y[i]);
        der2 += d * d;
    }
    const double der12 = fmax(sqrt(der2) / h, sqrt(dnf));
    const double h1 = der12 <= 1e-15 ? fmax(1e-6, h * 1e-3) : pow(0.01 / der12, 0.2);
    return fmin(fmin(100.0 * h, h1), interval);
}

/* Step-size controller (Hairer's DOPRI5): h_new = h / fac, fac = err^0.17 / err_prev^0.04 / 0.9
 * clamped to [1/10, 5], i.e. the step grows at most 10 times and shrinks at most 5 times. */
#define PI_ALPHA 0.17
#define PI_BETA 0.04
#define SAFETY 0.9
#define FAC_SHRINK 5.0   /* 1 / smallest step ratio */
#define FAC_GROW 0.1     /* 1 / largest step ratio */
#define ERR_PREV_MIN 1e-4
#define STRETCH 1.01     /* a step may stretch by 1 % to end the interval */

/* `prep`: the first half of the right-hand side at x's state, reused when it is that state's;
 * on success it holds the end state's (a trial's k7 evaluation, kept while the step is tried). */
static rrr_status step_adaptive(const rhs *r, const rrr_plant_integrator *s, double interval,
                                rrr_plant_state *x, double qdd[3], rrr_plant_stats *stats,
                                rrr_plant_prep *prep)
{
    double y[NY], k1[NY], y5[NY], k7[NY];
    memcpy(y, x->q, sizeof x->q);
    memcpy(y + 3, x->qd, sizeof x->qd);
    long evals = 1, steps = 0, rejected = 0, attempts = 0;
    rrr_status st;
    if (memcmp(prep->q, x->q, sizeof x->q) == 0 && memcmp(prep->qd, x->qd, sizeof x->qd) == 0) {
        memcpy(k1, y + 3, 3 * sizeof k1[0]); /* deriv's work, the first half already done */
        st = rrr_plant_accel_prepared(r->m, prep, r->u, k1 + 3);
    } else {
        st = deriv_keep(r, y, k1, prep);
    }
    rrr_plant_prep trial;
    if (st != RRR_OK) {
        return st == RRR_NUMERIC ? RRR_BAD_INPUT : st; /* y was checked finite: not reached */
    }
    double h = x->h_guess > 0.0 ? x->h_guess : initial_step(r, s, interval, y, k1, &evals);
    double err_prev = x->err_prev > 0.0 ? x->err_prev : ERR_PREV_MIN;
    double t = 0.0;
    int after_reject = 0;
    for (;;) {
        if (attempts >= s->max_steps) {
            return RRR_NUMERIC;
        }
        /* the rest of the interval in equal steps no longer than h (1 % stretch allowed) */
        const double rest = interval - t;
        const double ratio = rest / h;
        const int last = ratio <= STRETCH;
        const double hs = last ? rest : rest / ceil(ratio);
        if (!(t + hs > t)) {
            return RRR_NUMERIC; /* the step size underflowed */
        }
        double err = 0.0;
        st = dp5_trial(r, s, hs, y, &prep->fd.t, k1, y5, k7, &trial, &err);
        ++attempts;
        evals += 6;
        if (st != RRR_OK) {
            return st;
        }
        if (err <= 1.0) {
            memcpy(y, y5, sizeof y);
            memcpy(k1, k7, sizeof k1); /* FSAL */
            *prep = trial;
            ++steps;
            const double fac11 = pow(err, PI_ALPHA);
            const double fac = fmax(FAC_GROW, fmin(FAC_SHRINK,
                                                   fac11 / pow(err_prev, PI_BETA) / SAFETY));
            h = hs / fac;
            if (after_reject) {
                h = fmin(h, hs);
            }
            err_prev = fmax(err, ERR_PREV_MIN);
            after_reject = 0;
            if (last) {
                break;
            }
            t += hs;
        } else {
            /* err is > 1, +Inf or NaN: shrink (NaN and Inf by the largest factor) */
            const double fac11 = pow(err, PI_ALPHA);
            h = hs / (isfinite(fac11) ? fmin(FAC_SHRINK, fac11 / SAFETY) : FAC_SHRINK);
            after_reject = 1;
            ++rejected;
        }
    }
    memcpy(x->q, y, sizeof x->q);
    memcpy(x->qd, y + 3, sizeof x->qd);
    x->h_guess = h;
    x->err_prev = err_prev;
    if (qdd != NULL) {
        memcpy(qdd, k1 + 3, 3 * sizeof qdd[0]); /* f at the end state: FSAL */
    }
    if (stats != NULL) {
        stats->steps = steps;
        stats->rejected = rejected;
        stats->evals = evals;
    }
    return RRR_OK;
}

rrr_status rrr_plant_step_prepared(const rrr_model *m, const rrr_plant_integrator *s,
                                   const double u[3], double h, rrr_plant_state *x,
                                   double qdd[3], rrr_plant_stats *stats, rrr_plant_prep *prep)
{
    if (m == NULL || u == NULL || x == NULL || rrr_plant_integrator_check(s, NULL) != RRR_OK ||
        !isfinite(h) || !(h > 0.0) || !rrr_finite_n(u, 3) || !rrr_finite_n(x->q, 3) ||
        !rrr_finite_n(x->qd, 3) || !isfinite(x->h_guess) || !(x->h_guess >= 0.0) ||
        !isfinite(x->err_prev) || !(x->err_prev >= 0.0)) {
        return RRR_BAD_INPUT;
    }
    /* work on copies: x (and *prep) are written only on success */
    rrr_plant_state w = *x;
    rrr_plant_prep p = *prep;
    double a[3];
    rrr_plant_stats st_work = {0, 0, 0};
    const rhs r = rhs_of(m, u);
    const rrr_status st = s->adaptive ? step_adaptive(&r, s, h, &w, a, &st_work, &p)
                                      : step_fixed(&r, s, h, &w, a, &st_work);
    if (st != RRR_OK) {
        return st;
    }
    *x = w;
    *prep = p;
    if (qdd != NULL) {
        memcpy(qdd, a, sizeof a);
    }
    if (stats != NULL) {
        *stats = st_work;
    }
    return RRR_OK;
}

rrr_status rrr_plant_step(const rrr_model *m, const rrr_plant_integrator *s, const double u[3],
                          double h, rrr_plant_state *x, double qdd[3], rrr_plant_stats *stats)
{
    rrr_plant_prep none;
    memset(&none, 0, sizeof none);
    none.q[0] = (double)NAN; /* belongs to no state: x's first half is computed */
    return rrr_plant_step_prepared(m, s, u, h, x, qdd, stats, &none);
}

rrr_status rrr_plant_rollout(const rrr_model *m, const rrr_plant_integrator *s, size_t n,
                             const double u[], double h, rrr_plant_state *x, double q[],
                             double qd[], double qdd[], size_t *done, rrr_plant_stats *stats)
{
    if (done != NULL) {
        *done = 0;
    }
    if (stats != NULL) {
        memset(stats, 0, sizeof *stats);
    }
    if (m == NULL || x == NULL || (n > 0 && (u == NULL || q == NULL))) {
        return RRR_BAD_INPUT;
    }
    rrr_plant_prep prep;
    memset(&prep, 0, sizeof prep);
    prep.q[0] = (double)NAN; /* belongs to no state: the first step computes x's */
    rrr_plant_stats total = {0, 0, 0};
    for (size_t k = 0; k < n; ++k) {
        double a[3];
        rrr_plant_stats one;
        const rrr_status st = rrr_plant_step_prepared(m, s, &u[3 * k], h, x, a, &one, &prep);
        if (st != RRR_OK) { /* x is the state after step k - 1; rows < k are written */
            if (done != NULL) {
                *done = k;
            }
            if (stats != NULL) {
                *stats = total;
            }
            return st;
        }
        memcpy(&q[3 * k], x->q, sizeof x->q);
        if (qd != NULL) {
            memcpy(&qd[3 * k], x->qd, sizeof x->qd);
        }
        if (qdd != NULL) {
            memcpy(&qdd[3 * k], a, sizeof a);
        }
        total.steps += one.steps;
        total.rejected += one.rejected;
        total.evals += one.evals;
    }
    if (done != NULL) {
        *done = n;
    }
    if (stats != NULL) {
        *stats = total;
    }
    return RRR_OK;
}

/* ---- stiffness ------------------------------------------------------------------------------ */

/* Grid of (q2, q3) over which the stiffness estimate is maximised. */
#define STIFF_GRID 32

/* Inverse of a symmetric positive definite 3 x 3 matrix by its adjugate; 0 when it is not
 * positive definite (a leading minor <= 0) or the inverse is not finite. */
static int spd_inverse3(double D[3][3], double Di[3][3])
{
    const double c00 = D[1][1] * D[2][2] - D[1][2] * D[2][1];
    const double c01 = D[1][2] * D[2][0] - D[1][0] * D[2][2];
    const double c02 = D[1][0] * D[2][1] - D[1][1] * D[2][0];
    const double det = D[0][0] * c00 + D[0][1] * c01 + D[0][2] * c02;
    const double m2 = D[0][0] * D[1][1] - D[0][1] * D[1][0];
    if (!(D[0][0] > 0.0) || !(m2 > 0.0) || !(det > 0.0)) {
        return 0;
    }
    Di[0][0] = c00 / det;
    Di[0][1] = (D[0][2] * D[2][1] - D[0][1] * D[2][2]) / det;
    Di[0][2] = (D[0][1] * D[1][2] - D[0][2] * D[1][1]) / det;
    Di[1][0] = c01 / det;
    Di[1][1] = (D[0][0] * D[2][2] - D[0][2] * D[2][0]) / det;
    Di[1][2] = (D[0][2] * D[1][0] - D[0][0] * D[1][2]) / det;
    Di[2][0] = c02 / det;
    Di[2][1] = (D[0][1] * D[2][0] - D[0][0] * D[2][1]) / det;
    Di[2][2] = m2 / det;
    return rrr_finite_n(&Di[0][0], 9);
}

rrr_status rrr_plant_stiffness(const rrr_model *m, double *lambda, const char **field)
{
    if (field != NULL) {
        *field = "";
    }
    if (m == NULL) {
        return RRR_BAD_INPUT;
    }
    /* the largest friction slope of each joint, k_t times it, and its largest term */
    double k[3];
    int top[3]; /* 0..2: the term k of f/w with the largest |f| w; 3: b */
    for (int i = 0; i < 3; ++i) {
        if (!isfinite(m->kt[i]) || !(m->kt[i] > 0.0) || !isfinite(m->b[i]) || !(m->b[i] >= 0.0)) {
            return RRR_BAD_MODEL;
        }
        double s = m->b[i];
        double best = m->b[i];
        top[i] = 3;
        for (int t = 0; t < RRR_NF; ++t) {
            const double fw = fabs(m->f[i][t]) * m->w[i][t];
            if (!isfinite(m->f[i][t]) || !isfinite(m->w[i][t]) || !(m->w[i][t] >= 0.0)) {
                return RRR_BAD_MODEL;
            }
            s += fw;
            if (fw > best) {
                best = fw;
                top[i] = t;
            }
        }
        k[i] = m->kt[i] * s;
        if (!isfinite(k[i])) {
            k[i] = HUGE_VAL; /* beyond any limit: too stiff */
        }
    }
    double worst = 0.0;
    int worst_col = 0;
    for (int a = 0; a < STIFF_GRID; ++a) {
        for (int b = 0; b < STIFF_GRID; ++b) {
            const double q[3] = {0.0, -RRR_PI + 2.0 * RRR_PI * a / STIFF_GRID,
                                 -RRR_PI + 2.0 * RRR_PI * b / STIFF_GRID};
            double D[3][3], Di[3][3];
            const rrr_status st = rrr_mass_matrix(m, q, D);
            if (st == RRR_BAD_INPUT) {
                return RRR_BAD_MODEL; /* a non-finite a2 or p */
            }
            if (st != RRR_OK || !spd_inverse3(D, Di)) {
                return RRR_NOT_POSITIVE_DEFINITE;
            }
            for (int i = 0; i < 3; ++i) {
                double row = 0.0;
                double share = 0.0;
                int col = 0;
                for (int j = 0; j < 3; ++j) {
                    const double v = fabs(Di[i][j]) * k[j];
                    row += v;
                    if (v > share) {
                        share = v;
                        col = j;
                    }
                }
                if (row > worst || isnan(row)) {
                    worst = isnan(row) ? HUGE_VAL : row;
                    worst_col = col;
                }
            }
        }
    }
    if (lambda != NULL) {
        *lambda = worst;
    }
    if (!(worst <= RRR_PLANT_STIFFNESS_MAX)) {
        if (field != NULL) {
            /* the row of w[i,k] or b[i] in the parameter table (read-only, no pointers) */
            const size_t w0 = offsetof(rrr_model, w) / sizeof(double);
            const size_t b0 = offsetof(rrr_model, b) / sizeof(double);
            const int t = top[worst_col];
            const size_t row = t < 3 ? w0 + (size_t)(3 * worst_col + t) : b0 + (size_t)worst_col;
            *field = rrr_param_table(NULL)[row].name;
        }
        return RRR_TOO_STIFF;
    }
    return RRR_OK;
}
