/* The closed loop in C (rrr_sim.h): refusals, the first rows, tracking of a smooth reference, and
 * equality bit for bit with the same loop written over the public API (rrr_ctc, rrr_plant_step,
 * rrr_fk: what the FMUs call), which it must match although it reuses each step's end-state
 * half of the right-hand side. Its equality with the FMUs driven by the co-simulation master is
 * checked from Python (tests/python/model/test_native_engine.py), where the master lives. */
#include <math.h>
#include <string.h>

#include "rrr/rrr.h"
#include "rrr_test.h"

#define N 1000
#define STEP 1e-3

static double ref[N][RRR_SIM_REF_COLS], pout[N][RRR_SIM_PLANT_COLS], cout_[N][RRR_SIM_CTRL_COLS];

static void reference(void)
{
    for (int k = 0; k < N; ++k) {
        const double t = k * STEP;
        for (int i = 0; i < 3; ++i) {
            const double a = 0.3 + 0.1 * i, w = 2.0 + i;
            ref[k][i] = 0.2 * i + a * sin(w * t);
            ref[k][3 + i] = a * w * cos(w * t);
            ref[k][6 + i] = -a * w * w * sin(w * t);
        }
    }
}

static double pub_p[N][RRR_SIM_PLANT_COLS], pub_c[N][RRR_SIM_CTRL_COLS];

/* The master's loop over the public API (rrr_sim.h's steps 1-3); 0 when a call fails. */
static int public_loop(const rrr_model *m, const rrr_plant_integrator *s, const rrr_ctc_gains *g)
{
    rrr_plant_state x;
    const double u0[3] = {0.0, 0.0, 0.0};
    double qdd[3], tip[3];
    if (rrr_plant_state_init(ref[0], ref[0] + 3, &x) != RRR_OK ||
        rrr_plant_accel(m, &x, u0, qdd) != RRR_OK || rrr_fk(m, x.q, tip, NULL) != RRR_OK) {
        return 0;
    }
    for (int k = 0; k < N; ++k) {
        memcpy(pub_p[k], x.q, sizeof x.q);
        memcpy(pub_p[k] + 3, x.qd, sizeof x.qd);
        memcpy(pub_p[k] + 6, qdd, sizeof qdd);
        memcpy(pub_p[k] + 9, tip, sizeof tip);
        rrr_ctc_output o;
        if (rrr_ctc(m, g, ref[k], ref[k] + 3, ref[k] + 6, x.q, x.qd, &o) != RRR_OK) {
            return 0;
        }
        memcpy(pub_c[k], o.u, sizeof o.u);
        memcpy(pub_c[k] + 3, o.u_n, sizeof o.u_n);
        memcpy(pub_c[k] + 6, o.u_c, sizeof o.u_c);
        if (k == 0) { /* row 0: the acceleration under row 0's input */
            double qdd0[3];
            if (rrr_plant_accel(m, &x, o.u, qdd0) != RRR_OK) {
                return 0;
            }
            memcpy(pub_p[0] + 6, qdd0, sizeof qdd0);
        }
        if (k + 1 < N && (rrr_plant_step(m, s, o.u, STEP, &x, qdd, NULL) != RRR_OK ||
                          rrr_fk(m, x.q, tip, NULL) != RRR_OK)) {
            return 0;
        }
    }
    return 1;
}

static void equals_the_public_loop(const rrr_model *m, rrr_plant_integrator s,
                                   const rrr_ctc_gains *g, const char *what)
{
    size_t done = 0;
    CHECK_STATUS(rrr_sim_closed_loop(m, &s, ref[0], ref[0] + 3, m, g, N, STEP, ref[0], pout[0],
                                     cout_[0], &done),
                 RRR_OK);
    CHECK(public_loop(m, &s, g));
    const int same = memcmp(pout, pub_p, sizeof pout) == 0 && memcmp(cout_, pub_c, sizeof cout_) == 0;
    if (!same) {
        fprintf(stderr, "not bit for bit: %s\n", what);
    }
    CHECK(same);
}

int main(void)
{
    rrr_model m;
    rrr_ctc_gains g;
    rrr_plant_integrator s;
    CHECK(rrr_model_default(&m) == RRR_OK && rrr_ctc_gains_default(&g) == RRR_OK);
    CHECK(rrr_plant_integrator_default(&s) == RRR_OK);
    reference();
    size_t done = 99;
    CHECK_STATUS(rrr_sim_closed_loop(&m, &s, ref[0], ref[0] + 3, &m, &g, N, STEP, ref[0],
                                     pout[0], cout_[0], &done),
                 RRR_OK);
    CHECK(done == N);
    /* row 0: the initial state; the controller sees it */
    CHECK(memcmp(pout[0], ref[0], 3 * sizeof(double)) == 0);
    double err = 0.0;
    for (int k = 0; k < N; ++k) {
        for (int i = 0; i < 3; ++i) {
            err = fmax(err, fabs(pout[k][i] - ref[k][i]));
        }
    }
    CHECK(err < 1e-3);
    /* the first controller row equals rrr_ctc at the initial state */
    rrr_ctc_output o;
    CHECK(rrr_ctc(&m, &g, ref[0], ref[0] + 3, ref[0] + 6, pout[0], pout[0] + 3, &o) == RRR_OK);
    CHECK(memcmp(cout_[0], o.u, sizeof o.u) == 0 && memcmp(cout_[0] + 3, o.u_n, sizeof o.u_n) == 0);

    /* the same numbers as the loop over the public API, adaptive and fixed-step */
    equals_the_public_loop(&m, s, &g, "adaptive: rrr_sim_closed_loop == the public API's loop");
    rrr_plant_integrator fixed = s;
    fixed.adaptive = 0;
    equals_the_public_loop(&m, fixed, &g, "fixed step: rrr_sim_closed_loop == the public loop");

    /* in parts of 1, 7 and 999 samples: bit for bit the one call */
    static double part_p[N][RRR_SIM_PLANT_COLS], part_c[N][RRR_SIM_CTRL_COLS];
    const size_t counts[3] = {1, 7, N - 1};
    for (int c = 0; c < 3; ++c) {
        for (int a = 0; a < 2; ++a) {
            rrr_plant_integrator sa = s;
            sa.adaptive = a;
            CHECK_STATUS(rrr_sim_closed_loop(&m, &sa, ref[0], ref[0] + 3, &m, &g, N, STEP,
                                             ref[0], pout[0], cout_[0], &done),
                         RRR_OK);
            memset(part_p, 0, sizeof part_p);
            memset(part_c, 0, sizeof part_c);
            rrr_sim_carry carry;
            memset(&carry, 0, sizeof carry);
            size_t calls = 0;
            rrr_status st = RRR_OK;
            while (st == RRR_OK && carry.next < N && calls < N + 1) {
                st = rrr_sim_closed_loop_part(&m, &sa, ref[0], ref[0] + 3, &m, &g, N, STEP,
                                              ref[0], part_p[0], part_c[0], counts[c], &carry,
                                              &done);
                ++calls;
                CHECK(done == carry.next);
            }
            CHECK(st == RRR_OK && carry.next == N);
            CHECK(calls == (N + counts[c] - 1) / counts[c]);
            CHECK(memcmp(part_p, pout, sizeof pout) == 0 && memcmp(part_c, cout_, sizeof cout_) == 0);
            /* a complete run: a further part does nothing */
            CHECK_STATUS(rrr_sim_closed_loop_part(&m, &sa, ref[0], ref[0] + 3, &m, &g, N, STEP,
                                                  ref[0], part_p[0], part_c[0], 5, &carry, &done),
                         RRR_OK);
            CHECK(done == N);
        }
    }
    rrr_sim_carry carry;
    memset(&carry, 0, sizeof carry);
    CHECK_STATUS(rrr_sim_closed_loop_part(&m, &s, ref[0], ref[0] + 3, &m, &g, N, STEP, ref[0],
                                          pout[0], cout_[0], 0, &carry, &done),
                 RRR_BAD_INPUT);
    CHECK_STATUS(rrr_sim_closed_loop_part(&m, &s, ref[0], ref[0] + 3, &m, &g, N, STEP, ref[0],
                                          pout[0], cout_[0], 3, NULL, &done),
                 RRR_BAD_INPUT);
    carry.next = N + 1;
    CHECK_STATUS(rrr_sim_closed_loop_part(&m, &s, ref[0], ref[0] + 3, &m, &g, N, STEP, ref[0],
                                          pout[0], cout_[0], 3, &carry, &done),
                 RRR_BAD_INPUT);
    /* a plant too stiff for its integrator is refused before any sample */
    rrr_model stiff = m;
    stiff.f[0][0] = 1e4;
    stiff.w[0][0] = 1e4;
    CHECK_STATUS(rrr_sim_closed_loop(&stiff, &s, ref[0], ref[0] + 3, &m, &g, N, STEP, ref[0],
                                     pout[0], cout_[0], &done),
                 RRR_TOO_STIFF);
    CHECK(done == 0);

    /* refusals */
    CHECK_STATUS(rrr_sim_closed_loop(&m, &s, ref[0], ref[0] + 3, &m, &g, 0, STEP, ref[0], pout[0],
                                     cout_[0], &done),
                 RRR_BAD_INPUT);
    CHECK_STATUS(rrr_sim_closed_loop(&m, &s, ref[0], ref[0] + 3, &m, &g, N, (double)NAN, ref[0], pout[0],
                                     cout_[0], &done),
                 RRR_BAD_INPUT);
    CHECK_STATUS(rrr_sim_closed_loop(&m, &s, ref[0], ref[0] + 3, &m, &g, N, STEP, NULL, pout[0],
                                     cout_[0], &done),
                 RRR_BAD_INPUT);
    rrr_model bad = m;
    bad.kt[1] = 0.0;
    CHECK_STATUS(rrr_sim_closed_loop(&m, &s, ref[0], ref[0] + 3, &bad, &g, N, STEP, ref[0],
                                     pout[0], cout_[0], &done),
                 RRR_BAD_MODEL);
    rrr_plant_integrator bs = s;
    bs.rtol = 0.5;
    CHECK_STATUS(rrr_sim_closed_loop(&m, &bs, ref[0], ref[0] + 3, &m, &g, N, STEP, ref[0],
                                     pout[0], cout_[0], &done),
                 RRR_BAD_INPUT);
    /* a non-finite reference at sample 500: the loop stops there, earlier rows are valid */
    ref[500][4] = (double)NAN;
    CHECK_STATUS(rrr_sim_closed_loop(&m, &s, ref[0], ref[0] + 3, &m, &g, N, STEP, ref[0],
                                     pout[0], cout_[0], &done),
                 RRR_BAD_INPUT);
    CHECK(done == 500);
    return rrr_test_report("test_sim");
}
