/* Plant integrator: the adaptive Dormand-Prince 5(4) default against a tight reference (open
 * loop 2 s), energy conservation without friction and input (both methods), 4th-order
 * convergence of the fixed-step RK4, determinism and the step-size history in the state, the
 * work per 1 ms step, the friction's tanh against libm, input saturation, and bad input leaving
 * the state untouched. */
#include <math.h>
#include <string.h>

#include "rrr/rrr.h"
#include "rrr_internal.h"
#include "rrr_test.h"

static double total_energy(const rrr_model *m, const rrr_plant_state *x, double *kin)
{
    double k = 0.0, v = 0.0;
    CHECK_STATUS(rrr_energy(m, x->q, x->qd, &k, &v), RRR_OK);
    if (kin != NULL) {
        *kin = k;
    }
    return k + v;
}

static rrr_model frictionless(void)
{
    rrr_model m;
    rrr_model_default(&m);
    memset(m.f, 0, sizeof m.f);
    memset(m.b, 0, sizeof m.b);
    return m;
}

static rrr_plant_integrator adaptive_default(void)
{
    rrr_plant_integrator s;
    CHECK_STATUS(rrr_plant_integrator_default(&s), RRR_OK);
    return s;
}

static rrr_plant_integrator fixed(double h_int)
{
    rrr_plant_integrator s = adaptive_default();
    s.adaptive = 0;
    s.h_int = h_int;
    return s;
}

static rrr_plant_state state(double q1, double q2, double q3, double qd1, double qd2, double qd3)
{
    const double q[3] = {q1, q2, q3}, qd[3] = {qd1, qd2, qd3};
    rrr_plant_state x;
    memset(&x, 0xff, sizeof x); /* every field must be written */
    CHECK_STATUS(rrr_plant_state_init(q, qd, &x), RRR_OK);
    return x;
}

static const double ZERO[3] = {0.0, 0.0, 0.0};

/* t_end in 1 ms calls */
static rrr_plant_state run(const rrr_model *m, const rrr_plant_integrator *s,
                           const rrr_plant_state *x0, const double u[3], double t_end)
{
    rrr_plant_state x = *x0;
    const int n = (int)(t_end / 1e-3 + 0.5);
    for (int k = 0; k < n; ++k) {
        CHECK_STATUS(rrr_plant_step(m, s, u, 1e-3, &x, NULL, NULL), RRR_OK);
    }
    return x;
}

static double energy_drift(const rrr_plant_integrator *s, const char *what)
{
    const rrr_model m = frictionless();
    rrr_plant_state x = state(0.2, 0.3, 0.9, 1.0, -0.5, 0.8);
    double kin0 = 0.0;
    const double e0 = total_energy(&m, &x, &kin0);
    double worst = 0.0, kin_max = kin0;
    long evals = 0;
    for (int k = 0; k < 10000; ++k) { /* 10 s */
        rrr_plant_stats st;
        CHECK_STATUS(rrr_plant_step(&m, s, ZERO, 1e-3, &x, NULL, &st), RRR_OK);
        evals += st.evals;
        double kin = 0.0;
        worst = fmax(worst, fabs(total_energy(&m, &x, &kin) - e0));
        kin_max = fmax(kin_max, kin);
    }
    /* relative to the energy that sloshes between kinetic and potential */
    const double rel = worst / kin_max;
    printf("%s: energy drift over 10 s: %.3g J, %.3g relative to max kinetic energy %.3g J "
           "(%.1f evaluations per 1 ms step)\n",
           what, worst, rel, kin_max, (double)evals / 1e4);
    return rel;
}

static void test_energy(void)
{
    const rrr_plant_integrator a = adaptive_default(), f = fixed(RRR_PLANT_H_INT_DEFAULT);
    CHECK(energy_drift(&a, "adaptive DOPRI5 (default rtol, atol)") < 1e-8);
    CHECK(energy_drift(&f, "fixed-step RK4 (h_int 1e-4 s)") < 1e-8);
}

static void test_order(void)
{
    /* RK4: global error ~ C h^4, so each halving of h_int shrinks the change by about 16.
     * 10 s of a swing about the hanging posture while the waist spins (regular, not chaotic
     * motion, so the error does not grow exponentially and the order shows over the run). */
    const rrr_model m = frictionless();
    const rrr_plant_state x0 = state(0.2, -1.57, 0.0, 4.0, 2.0, -3.0);
    const double hs[3] = {1e-3, 5e-4, 2.5e-4};
    rrr_plant_state xs[3];
    for (int i = 0; i < 3; ++i) {
        const rrr_plant_integrator s = fixed(hs[i]);
        xs[i] = run(&m, &s, &x0, ZERO, 10.0);
    }
    const rrr_plant_integrator sa = fixed(RRR_PLANT_H_INT_DEFAULT);
    const rrr_plant_integrator sb = fixed(RRR_PLANT_H_INT_DEFAULT / 2.0);
    const rrr_plant_state a = run(&m, &sa, &x0, ZERO, 10.0);
    const rrr_plant_state b = run(&m, &sb, &x0, ZERO, 10.0);
    double d01 = 0.0, d12 = 0.0, dab = 0.0;
    for (int j = 0; j < 3; ++j) {
        d01 = fmax(d01, fabs(xs[0].q[j] - xs[1].q[j]));
        d12 = fmax(d12, fabs(xs[1].q[j] - xs[2].q[j]));
        dab = fmax(dab, fabs(a.q[j] - b.q[j]));
    }
    const double ratio = d01 / d12;
    printf("RK4, 10 s: |q(1 ms) - q(0.5 ms)| = %.3g rad, |q(0.5 ms) - q(0.25 ms)| = %.3g rad, "
           "ratio %.1f (4th order: 16)\n", d01, d12, ratio);
    CHECK(ratio > 12.0 && ratio < 20.0);
    /* error constant from the coarse pair: d01 = C (h0^4 - h1^4); prediction for h_int vs
     * h_int / 2, plus the accumulated round-off floor (1e5 steps x 1e-16 x |q|) */
    const double C = d01 / (pow(hs[0], 4) - pow(hs[1], 4));
    const double h = RRR_PLANT_H_INT_DEFAULT;
    const double predicted = C * (pow(h, 4) - pow(h / 2.0, 4));
    const double floor_roundoff = 1e-11;
    printf("RK4, default h_int %.0e vs half over 10 s: %.3g rad; 4th order predicts %.3g rad "
           "(round-off floor %.0e)\n", h, dab, predicted, floor_roundoff);
    CHECK(dab <= 1.5 * predicted + floor_roundoff);
}

/* The accuracy target: 2 s open loop under u = [0.5, 1, 0.3] V from q0 = (0.1, 0.4, 1.0), at
 * rest, default robot (friction on), 1 ms calls, against RK4 at h_int = 1e-5 s (its own error,
 * bounded by comparing it with h_int = 5e-6 s, is far below the target). Every 1 ms sample of q
 * within 1e-8 rad. A second case starts the waist spinning through zero velocity (the friction's
 * steep tanh, |lambda| ~ 600 1/s on joint 3 at rest) under a sign-changing input. */
static double max_q_error(const rrr_model *m, const rrr_plant_integrator *s,
                          const rrr_plant_state *x0, const double u[3], double t_end,
                          double *qd_err, double *evals_per_step)
{
    const rrr_plant_integrator sr = fixed(1e-5);
    rrr_plant_state x = *x0, r = *x0;
    double worst = 0.0, worst_v = 0.0;
    long evals = 0;
    const int n = (int)(t_end / 1e-3 + 0.5);
    for (int k = 0; k < n; ++k) {
        rrr_plant_stats st;
        CHECK_STATUS(rrr_plant_step(m, s, u, 1e-3, &x, NULL, &st), RRR_OK);
        CHECK_STATUS(rrr_plant_step(m, &sr, u, 1e-3, &r, NULL, NULL), RRR_OK);
        evals += st.evals;
        for (int j = 0; j < 3; ++j) {
            worst = fmax(worst, fabs(x.q[j] - r.q[j]));
            worst_v = fmax(worst_v, fabs(x.qd[j] - r.qd[j]));
        }
    }
    *qd_err = worst_v;
    *evals_per_step = (double)evals / n;
    return worst;
}

static void test_accuracy(void)
{
    rrr_model m;
    rrr_model_default(&m);
    const rrr_plant_state x0 = state(0.1, 0.4, 1.0, 0.0, 0.0, 0.0);
    const double u[3] = {0.5, 1.0, 0.3};
    /* the reference's own error */
    const rrr_plant_integrator r1 = fixed(1e-5), r2 = fixed(5e-6);
    const rrr_plant_state a = run(&m, &r1, &x0, u, 2.0), b = run(&m, &r2, &x0, u, 2.0);
    double ref_err = 0.0;
    for (int j = 0; j < 3; ++j) {
        ref_err = fmax(ref_err, fabs(a.q[j] - b.q[j]));
    }
    printf("reference RK4 1e-5 s vs 5e-6 s after 2 s: %.3g rad\n", ref_err);
    CHECK(ref_err < 1e-11);

    const rrr_plant_integrator def = adaptive_default(), old = fixed(RRR_PLANT_H_INT_DEFAULT);
    double ev = 0.0, qd_err = 0.0;
    const double e_def = max_q_error(&m, &def, &x0, u, 2.0, &qd_err, &ev);
    printf("open loop 2 s, u = [0.5, 1, 0.3] V: adaptive default max |q - q_ref| = %.3g rad, "
           "|qd - qd_ref| = %.3g rad/s, %.2f evaluations per 1 ms step\n", e_def, qd_err, ev);
    CHECK(e_def <= 1e-8);
    CHECK(ev < 41.0 / 3.0);
    const double e_old = max_q_error(&m, &old, &x0, u, 2.0, &qd_err, &ev);
    printf("open loop 2 s: fixed RK4 h_int 1e-4 s max |q - q_ref| = %.3g rad, %.2f evaluations "
           "per 1 ms step\n", e_old, ev);

    /* through zero velocity: the waist spins back against a reversed voltage */
    const rrr_plant_state x1 = state(0.0, 0.3, 1.2, 0.4, -0.2, 0.05);
    const double u1[3] = {-0.6, 0.9, 0.25};
    const double e_zero = max_q_error(&m, &def, &x1, u1, 2.0, &qd_err, &ev);
    printf("through zero velocity, 2 s: adaptive default max |q - q_ref| = %.3g rad, %.2f "
           "evaluations per 1 ms step\n", e_zero, ev);
    CHECK(e_zero <= 1e-8);

    /* tighter tolerances converge to the reference */
    rrr_plant_integrator tight = def;
    tight.rtol = 1e-11;
    tight.atol = 1e-13;
    const double e_tight = max_q_error(&m, &tight, &x0, u, 2.0, &qd_err, &ev);
    printf("open loop 2 s: rtol 1e-11, atol 1e-13: max |q - q_ref| = %.3g rad, %.2f evaluations "
           "per 1 ms step\n", e_tight, ev);
    CHECK(e_tight <= 1e-10);
}

/* Same inputs and state -> bit-identical outputs; the step-size history (h_guess, err_prev)
 * travels in the state, so a run continued from a copy of the state equals the uninterrupted
 * run bit for bit; a whole interval in one call agrees with 1 ms calls to the tolerance. */
static void test_determinism(void)
{
    rrr_model m;
    rrr_model_default(&m);
    const rrr_plant_integrator s = adaptive_default();
    const double u[3] = {0.5, 1.0, 0.3};
    const rrr_plant_state x0 = state(0.1, 0.4, 1.0, 0.0, 0.0, 0.0);
    const rrr_plant_state a = run(&m, &s, &x0, u, 0.5);
    const rrr_plant_state b = run(&m, &s, &x0, u, 0.5);
    CHECK(memcmp(&a, &b, sizeof a) == 0);
    CHECK(a.h_guess > 0.0 && a.err_prev > 0.0);
    /* snapshot at 0.25 s, continue */
    const rrr_plant_state half = run(&m, &s, &x0, u, 0.25);
    const rrr_plant_state c = run(&m, &s, &half, u, 0.25);
    CHECK(memcmp(&a, &c, sizeof a) == 0);
    /* one call over 0.5 s */
    rrr_plant_state d = x0;
    rrr_plant_stats st;
    double qdd[3], qdd_ref[3];
    CHECK_STATUS(rrr_plant_step(&m, &s, u, 0.5, &d, qdd, &st), RRR_OK);
    CHECK_STATUS(rrr_plant_accel(&m, &d, u, qdd_ref), RRR_OK);
    CHECK(memcmp(qdd, qdd_ref, sizeof qdd) == 0); /* the FSAL stage is the end state's qdd */
    double diff = 0.0;
    for (int j = 0; j < 3; ++j) {
        diff = fmax(diff, fabs(d.q[j] - a.q[j]));
    }
    printf("0.5 s in one call (%ld steps, %ld rejected, %ld evaluations) vs 500 calls of 1 ms: "
           "%.3g rad\n", st.steps, st.rejected, st.evals, diff);
    CHECK(diff < 1e-8);
    CHECK(st.steps > 1 && st.evals == 1 + 1 + 6 * (st.steps + st.rejected)); /* + initial step */
}

static void test_equilibrium_and_friction(void)
{
    /* holding gravity: the gravity voltage keeps the arm at rest */
    rrr_model m;
    rrr_model_default(&m);
    const rrr_plant_integrator s = adaptive_default();
    rrr_plant_state x = state(0.1, 0.4, 0.7, 0.0, 0.0, 0.0);
    const rrr_plant_state x0 = x;
    double h[3], u[3];
    rrr_gravity(&m, x.q, h);
    rrr_voltage_from_torque(&m, ZERO, h, u);
    for (int k = 0; k < 1000; ++k) {
        CHECK_STATUS(rrr_plant_step(&m, &s, u, 1e-3, &x, NULL, NULL), RRR_OK);
    }
    for (int j = 0; j < 3; ++j) {
        CHECK_CLOSE(x.q[j], x0.q[j], 1e-9);
    }
    /* with friction and no input, a spinning waist (gravity-free joint) slows down */
    rrr_plant_state sp = state(0.0, 0.3, 1.0, 2.0, 0.0, 0.0);
    double uh[3];
    rrr_gravity(&m, sp.q, h);
    rrr_voltage_from_torque(&m, ZERO, h, uh);
    uh[0] = 0.0;
    for (int k = 0; k < 500; ++k) {
        CHECK_STATUS(rrr_plant_step(&m, &s, uh, 1e-3, &sp, NULL, NULL), RRR_OK);
    }
    CHECK(fabs(sp.qd[0]) < 2.0);
}

/* ulp distance of x from the long double r, in units of the ulp of r rounded to double */
static double ulps(double x, long double r)
{
    const double rd = fabs((double)r);
    const double ulp = rd == 0.0 ? 4.9406564584124654e-324 : nextafter(rd, (double)INFINITY) - rd;
    return (double)(fabsl((long double)x - r) / (long double)ulp);
}

/* The friction's tanh (through rrr_friction with one unit term, w = 1, b = 0, so u_f = tanh(qd)
 * exactly) against libm's tanh and the x87 long double tanhl (64-bit mantissa) over the whole
 * double range: log-uniform magnitudes from the smallest subnormal to 1e300, and uniform samples
 * in each branch ([0, 1], [1, 19.1], around the thresholds). */
static void test_tanh(void)
{
    rrr_model m;
    rrr_model_default(&m);
    memset(m.f, 0, sizeof m.f);
    memset(m.w, 0, sizeof m.w);
    memset(m.b, 0, sizeof m.b);
    m.f[0][0] = 1.0;
    m.w[0][0] = 1.0;
    rrr_rng rng = {0x9e3779b97f4a7c15ULL};
    double worst_l = 0.0, worst_m = 0.0, at_l = 0.0, at_m = 0.0;
    long n = 0;
    for (int i = 0; i < 3000000; ++i) {
        double x;
        const double r = rrr_rng_uniform(&rng, 0.0, 1.0);
        switch (i % 6) {
        case 0: x = exp(rrr_rng_uniform(&rng, -744.0, 690.0)); break;
        case 1: x = r; break;
        case 2: x = 1.0 + 18.1 * r; break;
        case 3: x = 0.95 + 0.1 * r; break;
        case 4: x = 19.0 + 0.2 * r; break;
        default: x = exp(rrr_rng_uniform(&rng, -40.0, 0.0)); break;
        }
        if (i & 1) {
            x = -x;
        }
        const double qd[3] = {x, 0.0, 0.0};
        double uf[3];
        CHECK_STATUS(rrr_friction(&m, qd, uf), RRR_OK);
        const double el = ulps(uf[0], tanhl((long double)x));
        const double em = ulps(uf[0], (long double)tanh(x));
        if (el > worst_l) {
            worst_l = el;
            at_l = x;
        }
        if (em > worst_m) {
            worst_m = em;
            at_m = x;
        }
        ++n;
    }
    /* special values: +-0, the smallest subnormal, the largest double, the branch points */
    const double special[] = {0.0, -0.0, 4.9406564584124654e-324, 2.2250738585072014e-308,
                              1e-300, 1.0, nextafter(1.0, 0.0), 19.1, nextafter(19.1, 0.0),
                              1.7976931348623157e308};
    for (size_t i = 0; i < sizeof special / sizeof special[0]; ++i) {
        for (int sgn = -1; sgn <= 1; sgn += 2) {
            const double qd[3] = {sgn * special[i], 0.0, 0.0};
            double uf[3];
            CHECK_STATUS(rrr_friction(&m, qd, uf), RRR_OK);
            const double em = ulps(uf[0], (long double)tanh(qd[0]));
            worst_m = fmax(worst_m, em);
            worst_l = fmax(worst_l, ulps(uf[0], tanhl((long double)qd[0])));
            ++n;
        }
    }
    printf("friction tanh over %ld values: at most %.3f ulp from tanhl (at %.17g), %.3f ulp from "
           "libm tanh (at %.17g)\n", n, worst_l, at_l, worst_m, at_m);
    CHECK(worst_l <= 1.5);
    CHECK(worst_m <= 2.0);
}

/* The inner Runge-Kutta stages' trig (rrr_trig_near: angle sums from a nearby state) against
 * the x87 sinl/cosl, next to libm's own error, over random angles in [-100, 100] rad and
 * differences up to the series' limit: the absolute error, in units of 2^-52 (one ulp of 1.0),
 * the error that an angle rounded to double (ulp >= 2^-52 beyond 1 rad) carries anyway; the
 * relative error near a zero of sin or cos is larger than libm's there. Beyond the limit (and
 * for NaN) it is libm's bit for bit. */
static void test_trig_near(void)
{
    rrr_rng rng = {0x2545f4914f6cdd1dULL};
    double worst = 0.0, worst_libm = 0.0;
    for (int i = 0; i < 400000; ++i) {
        const double q0[3] = {0.0, rrr_rng_uniform(&rng, -100.0, 100.0),
                              rrr_rng_uniform(&rng, -100.0, 100.0)};
        const double lim = (i % 4 == 0) ? RRR_TRIG_NEAR_MAX : 2e-3;
        const double q[3] = {0.0, q0[1] + rrr_rng_uniform(&rng, -lim, lim),
                             q0[2] + rrr_rng_uniform(&rng, -lim, lim)};
        const rrr_trig t0 = rrr_trig_of(q0);
        const rrr_trig t = rrr_trig_near(&t0, q0, q);
        const rrr_trig ref = rrr_trig_of(q);
        const double got[4] = {t.s2, t.c2, t.s3, t.c3};
        const double lib[4] = {ref.s2, ref.c2, ref.s3, ref.c3};
        const long double exact[4] = {sinl((long double)q[1]), cosl((long double)q[1]),
                                      sinl((long double)q[2]), cosl((long double)q[2])};
        for (int k = 0; k < 4; ++k) {
            worst = fmax(worst, (double)(fabsl((long double)got[k] - exact[k]) / 0x1p-52L));
            worst_libm = fmax(worst_libm,
                              (double)(fabsl((long double)lib[k] - exact[k]) / 0x1p-52L));
        }
    }
    printf("trig near a state over 400000 pairs: |error| at most %.3f x 2^-52 against sinl/cosl "
           "(libm: %.3f)\n", worst, worst_libm);
    CHECK(worst <= 1.0);
    const double q0[3] = {0.0, 0.3, -1.2};
    const rrr_trig t0 = rrr_trig_of(q0);
    const double far[3] = {0.0, 0.3 + 2.0 * RRR_TRIG_NEAR_MAX, -1.2};
    const double nan3[3] = {0.0, (double)NAN, -1.2};
    const rrr_trig a = rrr_trig_near(&t0, q0, far), b = rrr_trig_of(far);
    CHECK(memcmp(&a, &b, sizeof a) == 0);
    const rrr_trig c = rrr_trig_near(&t0, q0, nan3);
    CHECK(isnan(c.s2) && isnan(c.c2) && isnan(c.s23));
}

/* The qdd a step returns is that of a fresh rrr_plant_accel at its end state, bit for bit (the
 * end stage takes libm's trig), along a 2 s open-loop run. */
static void test_step_qdd_is_accel(void)
{
    rrr_model m;
    rrr_model_default(&m);
    rrr_plant_integrator s;
    rrr_plant_integrator_default(&s);
    const double q0[3] = {0.1, 0.4, 1.0}, qd0[3] = {0.0, 0.0, 0.0}, u[3] = {0.5, 1.0, 0.3};
    rrr_plant_state x;
    CHECK_STATUS(rrr_plant_state_init(q0, qd0, &x), RRR_OK);
    int same = 1;
    for (int k = 0; k < 2000; ++k) {
        double qdd[3], again[3];
        CHECK_STATUS(rrr_plant_step(&m, &s, u, 1e-3, &x, qdd, NULL), RRR_OK);
        CHECK_STATUS(rrr_plant_accel(&m, &x, u, again), RRR_OK);
        same = same && memcmp(qdd, again, sizeof qdd) == 0;
    }
    CHECK(same);
}

static void test_bad_input(void)
{
    rrr_model m;
    rrr_model_default(&m);
    const rrr_plant_state X0 = state(0.2, 0.3, 0.9, 1.0, -0.5, 0.8);
    rrr_plant_state x = X0;
    const double u_nan[3] = {0.0, (double)NAN, 0.0}, u[3] = {1.0, 2.0, 3.0};
    double qdd[3] = {7.0, 7.0, 7.0};
    rrr_plant_stats st = {-1, -1, -1};
    const rrr_plant_integrator a = adaptive_default();
    const rrr_plant_integrator f = fixed(1e-4);
    for (int mode = 0; mode < 2; ++mode) {
        const rrr_plant_integrator *s = mode ? &f : &a;
        CHECK_STATUS(rrr_plant_step(&m, s, u_nan, 1e-3, &x, qdd, &st), RRR_BAD_INPUT);
        CHECK_STATUS(rrr_plant_step(&m, s, u, 0.0, &x, qdd, &st), RRR_BAD_INPUT);
        CHECK_STATUS(rrr_plant_step(&m, s, u, -1e-3, &x, qdd, &st), RRR_BAD_INPUT);
        CHECK_STATUS(rrr_plant_step(&m, s, u, (double)INFINITY, &x, qdd, &st), RRR_BAD_INPUT);
        CHECK_STATUS(rrr_plant_step(NULL, s, u, 1e-3, &x, qdd, &st), RRR_BAD_INPUT);
        CHECK_STATUS(rrr_plant_step(&m, s, NULL, 1e-3, &x, qdd, &st), RRR_BAD_INPUT);
        CHECK_STATUS(rrr_plant_step(&m, s, u, 1e-3, NULL, qdd, &st), RRR_BAD_INPUT);
        rrr_model bad = m;
        memset(bad.p, 0, sizeof bad.p);
        CHECK_STATUS(rrr_plant_step(&bad, s, u, 1e-3, &x, qdd, &st), RRR_NOT_POSITIVE_DEFINITE);
        rrr_plant_state nan_state = X0;
        nan_state.qd[2] = (double)INFINITY;
        CHECK_STATUS(rrr_plant_step(&m, s, u, 1e-3, &nan_state, qdd, &st), RRR_BAD_INPUT);
        /* the step-size history must be finite and >= 0 */
        rrr_plant_state bad_h = X0;
        bad_h.h_guess = -1e-3;
        CHECK_STATUS(rrr_plant_step(&m, s, u, 1e-3, &bad_h, qdd, &st), RRR_BAD_INPUT);
        bad_h.h_guess = (double)NAN;
        CHECK_STATUS(rrr_plant_step(&m, s, u, 1e-3, &bad_h, qdd, &st), RRR_BAD_INPUT);
        bad_h = X0;
        bad_h.err_prev = (double)INFINITY;
        CHECK_STATUS(rrr_plant_step(&m, s, u, 1e-3, &bad_h, qdd, &st), RRR_BAD_INPUT);
    }
    CHECK_STATUS(rrr_plant_step(&m, NULL, u, 1e-3, &x, qdd, &st), RRR_BAD_INPUT);
    /* settings outside their ranges, each named */
    const char *field = "x";
    struct {
        rrr_plant_integrator s;
        const char *name;
    } bad_settings[] = {
        {a, "rtol"}, {a, "rtol"}, {a, "rtol"}, {a, "atol"}, {a, "atol"},
        {a, "h_int"}, {a, "h_int"}, {a, "max_steps"},
    };
    bad_settings[0].s.rtol = 0.0;
    bad_settings[1].s.rtol = 0.1;
    bad_settings[2].s.rtol = (double)NAN;
    bad_settings[3].s.atol = 1e-15;
    bad_settings[4].s.atol = (double)INFINITY;
    bad_settings[5].s.h_int = 0.0;
    bad_settings[6].s.h_int = (double)INFINITY;
    bad_settings[7].s.max_steps = 0;
    for (size_t i = 0; i < sizeof bad_settings / sizeof bad_settings[0]; ++i) {
        CHECK_STATUS(rrr_plant_integrator_check(&bad_settings[i].s, &field), RRR_BAD_INPUT);
        CHECK(strcmp(field, bad_settings[i].name) == 0);
        CHECK_STATUS(rrr_plant_step(&m, &bad_settings[i].s, u, 1e-3, &x, qdd, &st),
                     RRR_BAD_INPUT);
    }
    CHECK_STATUS(rrr_plant_integrator_check(&a, &field), RRR_OK);
    CHECK(strcmp(field, "") == 0);
    CHECK_STATUS(rrr_plant_integrator_check(NULL, NULL), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_plant_integrator_default(NULL), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_plant_state_init(u_nan, u, &x), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_plant_state_init(u, u, NULL), RRR_BAD_INPUT);
    /* fixed step: more substeps than max_steps is refused before any work */
    rrr_plant_integrator many = fixed(1e-12);
    CHECK_STATUS(rrr_plant_step(&m, &many, u, 1e3, &x, qdd, &st), RRR_BAD_INPUT); /* 1e15 */
    many = fixed(1e-4);
    many.max_steps = 9;
    CHECK_STATUS(rrr_plant_step(&m, &many, u, 1e-3, &x, qdd, &st), RRR_BAD_INPUT);
    /* adaptive: an interval that max_steps attempts do not finish is RRR_NUMERIC */
    rrr_plant_integrator few = a;
    few.max_steps = 5;
    CHECK_STATUS(rrr_plant_step(&m, &few, u, 1.0, &x, qdd, &st), RRR_NUMERIC);
    CHECK(memcmp(&x, &X0, sizeof x) == 0);
    CHECK(qdd[0] == 7.0 && st.steps == -1 && st.evals == -1);
    /* variable communication steps are accepted */
    for (int mode = 0; mode < 2; ++mode) {
        x = X0;
        CHECK_STATUS(rrr_plant_step(&m, mode ? &f : &a, u, 2.5e-4, &x, qdd, &st), RRR_OK);
        CHECK(qdd[0] != 7.0 && st.steps >= 1);
        CHECK(mode ? x.h_guess == 0.0 : x.h_guess > 0.0); /* fixed step keeps the history */
        qdd[0] = 7.0;
    }
    CHECK_STATUS(rrr_plant_step(&m, &f, u, 2.5e-4, &x, NULL, NULL), RRR_OK); /* NULL outputs */
}

/* The stiffness estimate: the infinity norm of d qdd / d qd at rest (rrr_plant_jacobian, the
 * exact derivatives) maximised over (q2, q3); the default robot is far below the limit, the
 * reporter's f[1,1] = w[1,1] = 1e4 far above it, named. */
static void test_stiffness(void)
{
    rrr_model m;
    rrr_model_default(&m);
    double lambda = 0.0;
    const char *field = "x";
    CHECK_STATUS(rrr_plant_stiffness(&m, &lambda, &field), RRR_OK);
    CHECK(strcmp(field, "") == 0);
    CHECK(lambda > 10.0 && lambda < RRR_PLANT_STIFFNESS_MAX / 100.0);
    printf("stiffness estimate of the default robot: %.4g 1/s (limit %.0e 1/s)\n", lambda,
           RRR_PLANT_STIFFNESS_MAX);
    /* with every f >= 0 the friction slope is largest at qd = 0 and equals b + sum f w: the
     * estimate is the largest row sum of |d qdd / d qd| at rest over the grid */
    rrr_model pos = m;
    for (int i = 0; i < 3; ++i) {
        for (int k = 0; k < 3; ++k) {
            pos.f[i][k] = fabs(pos.f[i][k]);
        }
    }
    double est = 0.0;
    CHECK_STATUS(rrr_plant_stiffness(&pos, &est, NULL), RRR_OK);
    double worst = 0.0;
    for (int a = 0; a < 32; ++a) {
        for (int b = 0; b < 32; ++b) {
            const rrr_plant_state x = {{0.0, -RRR_PI + 2.0 * RRR_PI * a / 32,
                                        -RRR_PI + 2.0 * RRR_PI * b / 32},
                                       {0.0, 0.0, 0.0}, 0.0, 0.0};
            const double u[3] = {0.0, 0.0, 0.0};
            rrr_plant_derivatives d;
            CHECK_STATUS(rrr_plant_jacobian(&pos, &x, u, &d), RRR_OK);
            for (int i = 0; i < 3; ++i) {
                const double row = fabs(d.dqdd_dqd[i][0]) + fabs(d.dqdd_dqd[i][1]) +
                                   fabs(d.dqdd_dqd[i][2]);
                worst = row > worst ? row : worst;
            }
        }
    }
    CHECK(fabs(est - worst) <= 1e-9 * worst);
    /* the reporter's set: every value within the robot file's bounds, 1e6 times too stiff */
    rrr_model stiff = m;
    stiff.f[0][0] = 1e4;
    stiff.w[0][0] = 1e4;
    CHECK_STATUS(rrr_plant_stiffness(&stiff, &lambda, &field), RRR_TOO_STIFF);
    CHECK(strcmp(field, "w[1,1]") == 0 && lambda > 1e8);
    printf("f[1,1] = w[1,1] = 1e4: %.4g 1/s, %s named\n", lambda, field);
    stiff = m;
    stiff.b[2] = 1e6;
    CHECK_STATUS(rrr_plant_stiffness(&stiff, &lambda, &field), RRR_TOO_STIFF);
    CHECK(strcmp(field, "b[3]") == 0);
    stiff = m;
    stiff.w[1][2] = (double)INFINITY;
    CHECK_STATUS(rrr_plant_stiffness(&stiff, &lambda, &field), RRR_BAD_MODEL);
    stiff = m;
    stiff.p[0] = -1e3;
    CHECK_STATUS(rrr_plant_stiffness(&stiff, &lambda, &field), RRR_NOT_POSITIVE_DEFINITE);
    CHECK_STATUS(rrr_plant_stiffness(NULL, &lambda, &field), RRR_BAD_INPUT);
    CHECK(strcmp(rrr_status_str(RRR_TOO_STIFF), "RRR_TOO_STIFF") == 0);
}

/* rrr_plant_rollout: n steps in one call equal n rrr_plant_step calls bit for bit (both methods,
 * outputs and the final state, in one call or split in two), NULL optional outputs are
 * skipped, and a bad row stops the rollout with the rows and the state before it intact. */
static void test_rollout(void)
{
    rrr_model m;
    rrr_model_default(&m);
    enum { N = 400 };
    static double u[3 * N], q[3 * N], qd[3 * N], qdd[3 * N];
    static double q2[3 * N], qd2[3 * N], qdd2[3 * N];
    for (int k = 0; k < N; ++k) {
        u[3 * k + 0] = 3.0 * sin(0.01 * k);
        u[3 * k + 1] = 8.0 * cos(0.013 * k);
        u[3 * k + 2] = 50.0 * sin(0.02 * k); /* beyond u_max: saturated inside */
    }
    const rrr_plant_integrator a = adaptive_default(), f = fixed(2.5e-4);
    for (int mode = 0; mode < 2; ++mode) {
        const rrr_plant_integrator *s = mode ? &f : &a;
        const rrr_plant_state X0 = state(0.2, 0.3, 0.9, 1.0, -0.5, 0.8);
        rrr_plant_state x = X0, y = X0;
        rrr_plant_stats total = {0, 0, 0}, st;
        for (int k = 0; k < N; ++k) {
            rrr_plant_stats one;
            CHECK_STATUS(rrr_plant_step(&m, s, &u[3 * k], 1e-3, &x, &qdd[3 * k], &one), RRR_OK);
            memcpy(&q[3 * k], x.q, sizeof x.q);
            memcpy(&qd[3 * k], x.qd, sizeof x.qd);
            total.steps += one.steps;
            total.rejected += one.rejected;
            total.evals += one.evals;
        }
        size_t done = 0;
        CHECK_STATUS(rrr_plant_rollout(&m, s, 150, u, 1e-3, &y, q2, qd2, qdd2, &done, &st),
                     RRR_OK);
        CHECK(done == 150);
        CHECK_STATUS(rrr_plant_rollout(&m, s, N - 150, &u[3 * 150], 1e-3, &y, &q2[3 * 150],
                                       &qd2[3 * 150], &qdd2[3 * 150], &done, NULL),
                     RRR_OK);
        CHECK(done == N - 150);
        CHECK(memcmp(q, q2, sizeof q) == 0 && memcmp(qd, qd2, sizeof qd) == 0);
        CHECK(memcmp(qdd, qdd2, sizeof qdd) == 0);
        CHECK(memcmp(&x, &y, sizeof x) == 0);
        /* in one call, the stats summed; qd and qdd not asked for */
        y = X0;
        CHECK_STATUS(rrr_plant_rollout(&m, s, N, u, 1e-3, &y, q2, NULL, NULL, &done, &st),
                     RRR_OK);
        CHECK(done == N && memcmp(q, q2, sizeof q) == 0 && memcmp(&x, &y, sizeof x) == 0);
        CHECK(st.steps == total.steps && st.rejected == total.rejected &&
              st.evals == total.evals);
        /* a NaN in row 200: rows 0..199 and the state after step 199 kept, done = 200 */
        static double ubad[3 * N];
        memcpy(ubad, u, sizeof u);
        ubad[3 * 200 + 1] = (double)NAN;
        memset(q2, 0, sizeof q2);
        y = X0;
        CHECK_STATUS(rrr_plant_rollout(&m, s, N, ubad, 1e-3, &y, q2, qd2, NULL, &done, &st),
                     RRR_BAD_INPUT);
        CHECK(done == 200 && memcmp(q, q2, 200 * 3 * sizeof(double)) == 0);
        CHECK(memcmp(y.q, &q[3 * 199], sizeof y.q) == 0 &&
              memcmp(y.qd, &qd[3 * 199], sizeof y.qd) == 0);
        CHECK(q2[3 * 200] == 0.0 && st.steps > 0);
        /* bad arguments: nothing done; n = 0 is a no-op */
        y = X0;
        CHECK_STATUS(rrr_plant_rollout(&m, s, N, u, 0.0, &y, q2, NULL, NULL, &done, NULL),
                     RRR_BAD_INPUT);
        CHECK(done == 0 && memcmp(&y, &X0, sizeof y) == 0);
        CHECK_STATUS(rrr_plant_rollout(NULL, s, N, u, 1e-3, &y, q2, NULL, NULL, &done, NULL),
                     RRR_BAD_INPUT);
        CHECK_STATUS(rrr_plant_rollout(&m, s, N, NULL, 1e-3, &y, q2, NULL, NULL, &done, NULL),
                     RRR_BAD_INPUT);
        CHECK_STATUS(rrr_plant_rollout(&m, s, N, u, 1e-3, &y, NULL, NULL, NULL, &done, NULL),
                     RRR_BAD_INPUT);
        CHECK_STATUS(rrr_plant_rollout(&m, s, N, u, 1e-3, NULL, q2, NULL, NULL, &done, NULL),
                     RRR_BAD_INPUT);
        CHECK_STATUS(rrr_plant_rollout(&m, NULL, N, u, 1e-3, &y, q2, NULL, NULL, &done, NULL),
                     RRR_BAD_INPUT);
        CHECK_STATUS(rrr_plant_rollout(&m, s, 0, NULL, 1e-3, &y, NULL, NULL, NULL, &done, NULL),
                     RRR_OK);
        CHECK(done == 0 && memcmp(&y, &X0, sizeof y) == 0);
    }
}

int main(void)
{
    test_stiffness();
    test_tanh();
    test_trig_near();
    test_step_qdd_is_accel();
    test_energy();
    test_order();
    test_accuracy();
    test_determinism();
    test_equilibrium_and_friction();
    test_bad_input();
    test_rollout();
    return rrr_test_report("test_plant");
}
