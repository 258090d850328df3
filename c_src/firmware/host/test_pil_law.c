/*
 * The firmware's law (c_src/firmware/law/pil_law.h) against librrr's rrr_ctc on random states:
 *  - built in double (test_pil_law): equal bit for bit (u, u_n, u_c, the saturated bits), with
 *    and without feedforward, inside and beyond the saturation, and the inputs rrr_ctc refuses
 *    are refused too;
 *  - built in float (test_pil_law_float, PIL_REAL_FLOAT): within PIL_FLOAT_BOUND_V of it over
 *    the writing task's range of states (the bound docs/microcontroller.md states).
 */
#include <math.h>
#include <string.h>

#include "pil_law.h"
#include "rrr/rrr.h"
#include "rrr_test.h"

/** The float law's largest difference to rrr_ctc, V: a tenth of the VoltageCmd's 1 mV step. */
#define PIL_FLOAT_BOUND_V 1e-4

typedef struct state {
    double q_ref[3], qd_ref[3], qdd_ref[3], q[3], qd[3];
} state;

/* The writing task's range: |q| <= pi, |qd| <= 5 rad/s, |qdd| <= 50 rad/s2, the measured state
 * within 0.02 rad and 0.2 rad/s of the reference (wide: 20 times the worst tracking error);
 * with `wide`, 20 times that (the law saturates). */
static state random_state(rrr_rng *r, int wide)
{
    state s;
    const double e = wide ? 20.0 : 1.0;
    for (int i = 0; i < 3; ++i) {
        s.q_ref[i] = rrr_rng_uniform(r, -3.14159, 3.14159);
        s.qd_ref[i] = rrr_rng_uniform(r, -5.0, 5.0);
        s.qdd_ref[i] = rrr_rng_uniform(r, -50.0, 50.0);
        s.q[i] = s.q_ref[i] + e * rrr_rng_uniform(r, -0.02, 0.02);
        s.qd[i] = s.qd_ref[i] + e * rrr_rng_uniform(r, -0.2, 0.2);
    }
    return s;
}

static rrr_status law(const pil_model *m, const pil_gains *g, const state *s, pil_ctc_output *o)
{
    pil_real v[5][3];
    for (int i = 0; i < 3; ++i) {
        v[0][i] = (pil_real)s->q_ref[i];
        v[1][i] = (pil_real)s->qd_ref[i];
        v[2][i] = (pil_real)s->qdd_ref[i];
        v[3][i] = (pil_real)s->q[i];
        v[4][i] = (pil_real)s->qd[i];
    }
    return pil_ctc(m, g, v[0], v[1], v[2], v[3], v[4], o);
}

int main(void)
{
    rrr_model model;
    rrr_ctc_gains gains;
    CHECK_STATUS(rrr_model_default(&model), RRR_OK);
    CHECK_STATUS(rrr_ctc_gains_default(&gains), RRR_OK);
    pil_model pm;
    pil_model_from(&model, &pm);
    rrr_rng rng = {0x12345678u};
    double worst = 0.0;
    unsigned saturated = 0u;
    for (int n = 0; n < 200000; ++n) {
        rrr_ctc_gains g = gains;
        g.feedforward = n % 5 != 0;
        pil_gains pg;
        pil_gains_from(&g, &pg);
        const int wide = n % 3 == 0;
        const state s = random_state(&rng, wide);
        rrr_ctc_output ref;
        pil_ctc_output out;
        const rrr_status a = rrr_ctc(&model, &g, s.q_ref, s.qd_ref, s.qdd_ref, s.q, s.qd, &ref);
        const rrr_status b = law(&pm, &pg, &s, &out);
        CHECK(a == RRR_OK && b == RRR_OK);
        saturated += ref.saturated != 0u;
#ifdef PIL_REAL_FLOAT
        for (int i = 0; i < 3; ++i) {
            if (!wide) { /* beyond the range the bound is not claimed */
                worst = fmax(worst, fabs((double)out.u[i] - ref.u[i]));
                worst = fmax(worst, fabs((double)out.u_n[i] - ref.u_n[i]));
                worst = fmax(worst, fabs((double)out.u_c[i] - ref.u_c[i]));
            }
        }
#else
        CHECK(memcmp(out.u, ref.u, sizeof ref.u) == 0 && memcmp(out.u_n, ref.u_n, sizeof ref.u_n) == 0 &&
              memcmp(out.u_c, ref.u_c, sizeof ref.u_c) == 0 && out.saturated == ref.saturated);
#endif
    }
    CHECK(saturated > 1000u); /* the saturation was exercised */
    /* what rrr_ctc refuses is refused: non-finite inputs, negative gains, an unusable model */
    state s = random_state(&rng, 0);
    pil_gains pg;
    pil_gains_from(&gains, &pg);
    pil_ctc_output out;
    s.qd[1] = NAN;
    CHECK(law(&pm, &pg, &s, &out) != RRR_OK);
    s = random_state(&rng, 0);
    s.qdd_ref[2] = INFINITY;
    CHECK(law(&pm, &pg, &s, &out) != RRR_OK);
    s = random_state(&rng, 0);
    pg.kd[0] = -1.0f;
    CHECK(law(&pm, &pg, &s, &out) != RRR_OK);
    pil_gains_from(&gains, &pg);
    pil_model bad = pm;
    bad.kt[1] = 0.0f;
    CHECK(law(&bad, &pg, &s, &out) != RRR_OK);
    bad = pm;
    bad.u_max = -1.0f;
    CHECK(law(&bad, &pg, &s, &out) != RRR_OK);
#ifdef PIL_REAL_FLOAT
    printf("test_pil_law_float: largest |u_float - u_double| %.3e V (bound %.0e V)\n", worst,
           PIL_FLOAT_BOUND_V);
    CHECK(worst > 0.0 && worst <= PIL_FLOAT_BOUND_V);
    return rrr_test_report("test_pil_law_float");
#else
    (void)worst;
    return rrr_test_report("test_pil_law");
#endif
}
