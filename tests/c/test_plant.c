/* Plant integrator: energy conservation without friction and input, 4th-order convergence,
 * input saturation, bad input leaves the state untouched. */
#include <string.h>

#include "rrr/rrr.h"
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

static const rrr_plant_state X0 = {{0.2, 0.3, 0.9}, {1.0, -0.5, 0.8}};

static rrr_plant_state run(const rrr_model *m, const rrr_plant_state *x0, double h_int,
                           double t_end)
{
    rrr_plant_state x = *x0;
    const double u[3] = {0.0, 0.0, 0.0};
    const int n = (int)(t_end / 1e-3 + 0.5);
    for (int k = 0; k < n; ++k) {
        CHECK_STATUS(rrr_plant_step(m, h_int, u, 1e-3, &x, NULL), RRR_OK);
    }
    return x;
}

static void test_energy(void)
{
    const rrr_model m = frictionless();
    rrr_plant_state x = X0;
    double kin0 = 0.0;
    const double e0 = total_energy(&m, &x, &kin0);
    double worst = 0.0, kin_max = kin0;
    const double u[3] = {0.0, 0.0, 0.0};
    for (int k = 0; k < 10000; ++k) { /* 10 s */
        CHECK_STATUS(rrr_plant_step(&m, RRR_PLANT_H_INT_DEFAULT, u, 1e-3, &x, NULL), RRR_OK);
        double kin = 0.0;
        worst = fmax(worst, fabs(total_energy(&m, &x, &kin) - e0));
        kin_max = fmax(kin_max, kin);
    }
    /* relative to the energy that sloshes between kinetic and potential */
    const double rel = worst / kin_max;
    printf("energy drift over 10 s: %.3g J, %.3g relative to max kinetic energy %.3g J\n", worst,
           rel, kin_max);
    CHECK(rel < 1e-8);
}

static void test_order(void)
{
    /* RK4: global error ~ C h^4, so each halving of h_int shrinks the change by about 16.
     * 10 s of a swing about the hanging posture while the waist spins (regular, not chaotic
     * motion, so the error does not grow exponentially and the order shows over the run). */
    const rrr_model m = frictionless();
    const rrr_plant_state x0 = {{0.2, -1.57, 0.0}, {4.0, 2.0, -3.0}};
    const double hs[3] = {1e-3, 5e-4, 2.5e-4};
    rrr_plant_state xs[3];
    for (int i = 0; i < 3; ++i) {
        xs[i] = run(&m, &x0, hs[i], 10.0);
    }
    const rrr_plant_state a = run(&m, &x0, RRR_PLANT_H_INT_DEFAULT, 10.0);
    const rrr_plant_state b = run(&m, &x0, RRR_PLANT_H_INT_DEFAULT / 2.0, 10.0);
    double d01 = 0.0, d12 = 0.0, dab = 0.0;
    for (int j = 0; j < 3; ++j) {
        d01 = fmax(d01, fabs(xs[0].q[j] - xs[1].q[j]));
        d12 = fmax(d12, fabs(xs[1].q[j] - xs[2].q[j]));
        dab = fmax(dab, fabs(a.q[j] - b.q[j]));
    }
    const double ratio = d01 / d12;
    printf("10 s: |q(1 ms) - q(0.5 ms)| = %.3g rad, |q(0.5 ms) - q(0.25 ms)| = %.3g rad, "
           "ratio %.1f (4th order: 16)\n", d01, d12, ratio);
    CHECK(ratio > 12.0 && ratio < 20.0);
    /* error constant from the coarse pair: d01 = C (h0^4 - h1^4); prediction for h_int vs
     * h_int / 2, plus the accumulated round-off floor (1e5 steps x 1e-16 x |q|) */
    const double C = d01 / (pow(hs[0], 4) - pow(hs[1], 4));
    const double h = RRR_PLANT_H_INT_DEFAULT;
    const double predicted = C * (pow(h, 4) - pow(h / 2.0, 4));
    const double floor_roundoff = 1e-11;
    printf("default h_int %.0e vs half over 10 s: %.3g rad; 4th order predicts %.3g rad "
           "(round-off floor %.0e)\n", h, dab, predicted, floor_roundoff);
    CHECK(dab <= 1.5 * predicted + floor_roundoff);
}

static void test_equilibrium_and_friction(void)
{
    /* holding gravity: the gravity voltage keeps the arm at rest */
    rrr_model m;
    rrr_model_default(&m);
    rrr_plant_state x = {{0.1, 0.4, 0.7}, {0.0, 0.0, 0.0}};
    const rrr_plant_state x0 = x;
    double h[3], u[3];
    const double zero[3] = {0.0, 0.0, 0.0};
    rrr_gravity(&m, x.q, h);
    rrr_voltage_from_torque(&m, zero, h, u);
    for (int k = 0; k < 1000; ++k) {
        CHECK_STATUS(rrr_plant_step(&m, RRR_PLANT_H_INT_DEFAULT, u, 1e-3, &x, NULL), RRR_OK);
    }
    for (int j = 0; j < 3; ++j) {
        CHECK_CLOSE(x.q[j], x0.q[j], 1e-9);
    }
    /* with friction and no input, a spinning waist (gravity-free joint) slows down */
    rrr_plant_state s = {{0.0, 0.3, 1.0}, {2.0, 0.0, 0.0}};
    double uh[3];
    rrr_gravity(&m, s.q, h);
    rrr_voltage_from_torque(&m, zero, h, uh);
    uh[0] = 0.0;
    for (int k = 0; k < 500; ++k) {
        CHECK_STATUS(rrr_plant_step(&m, RRR_PLANT_H_INT_DEFAULT, uh, 1e-3, &s, NULL), RRR_OK);
    }
    CHECK(fabs(s.qd[0]) < 2.0);
}

static void test_bad_input(void)
{
    rrr_model m;
    rrr_model_default(&m);
    rrr_plant_state x = X0;
    const double u_nan[3] = {0.0, NAN, 0.0}, u[3] = {1.0, 2.0, 3.0};
    double qdd[3] = {7.0, 7.0, 7.0};
    CHECK_STATUS(rrr_plant_step(&m, 1e-4, u_nan, 1e-3, &x, qdd), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_plant_step(&m, 1e-4, u, 0.0, &x, qdd), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_plant_step(&m, 1e-4, u, -1e-3, &x, qdd), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_plant_step(&m, 0.0, u, 1e-3, &x, qdd), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_plant_step(&m, NAN, u, 1e-3, &x, qdd), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_plant_step(&m, 1e-12, u, 1e3, &x, qdd), RRR_BAD_INPUT); /* 1e15 substeps */
    CHECK_STATUS(rrr_plant_step(NULL, 1e-4, u, 1e-3, &x, qdd), RRR_BAD_INPUT);
    rrr_model bad = m;
    memset(bad.p, 0, sizeof bad.p);
    CHECK_STATUS(rrr_plant_step(&bad, 1e-4, u, 1e-3, &x, qdd), RRR_NOT_POSITIVE_DEFINITE);
    rrr_plant_state nan_state = X0;
    nan_state.qd[2] = INFINITY;
    CHECK_STATUS(rrr_plant_step(&m, 1e-4, u, 1e-3, &nan_state, qdd), RRR_BAD_INPUT);
    CHECK(memcmp(&x, &X0, sizeof x) == 0);
    CHECK(qdd[0] == 7.0);
    /* variable communication steps are accepted and split into equal substeps */
    CHECK_STATUS(rrr_plant_step(&m, 1e-4, u, 2.5e-4, &x, qdd), RRR_OK);
    CHECK(qdd[0] != 7.0);
}

int main(void)
{
    test_energy();
    test_order();
    test_equilibrium_and_friction();
    test_bad_input();
    return rrr_test_report("test_plant");
}
