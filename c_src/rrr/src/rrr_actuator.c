/* Motor / current-inverter mapping (eq 8) and neural-network friction (eq 9). */
#include <string.h>

#include "rrr_internal.h"

static int actuator_ok(const rrr_model *m)
{
    if (!rrr_finite_n(m->kt, RRR_NJ) || !rrr_finite_n(m->b, RRR_NJ) || !isfinite(m->u_max) ||
        !(m->u_max > 0.0)) {
        return 0;
    }
    for (int i = 0; i < RRR_NJ; ++i) {
        if (!(m->kt[i] > 0.0) || !rrr_finite_n(m->f[i], RRR_NF) || !rrr_finite_n(m->w[i], RRR_NF)) {
            return 0;
        }
    }
    return 1;
}

/* tanh without libm's tanh: one exp, or none. Measured against the x87 tanhl over the whole
 * double range (tests/c/test_plant.c) its error is below 1.5 ulp (libm's own tanh: 2.2 ulp), and
 * it differs from libm's tanh by at most 2 ulp; along the writing task's velocities the friction
 * costs 0.46 of what it costs with libm's tanh.
 *  - |x| < 1: tanh x = x - x z P(z) / Q(z), z = x^2, with P/Q the 8th convergent of Lambert's
 *    continued fraction x / (1 + z / (3 + z / (5 + ...))) (integer coefficients, exact in double;
 *    truncation error below 2.6e-17 relative on [0, 1]). Written as x minus a correction of at
 *    most x/4, so the rounding errors of P/Q reach the result damped; no cancellation, exact
 *    for subnormal x (z underflows to 0).
 *  - 1 <= |x| < 19.1: tanh x = 1 - 2 / (e^{2|x|} + 1): the subtracted term is below 0.24, so
 *    the errors of exp and the division shrink in the result.
 *  - |x| >= 19.1: 1 - tanh|x| < 2 e^{-38.2} < 2^-54, so tanh x rounds to +-1.
 * The sign goes back on with copysign (odd function; tanh(-0) = -0). NaN propagates. */
static double tanh_fast(double x)
{
    const double a = fabs(x);
    double r;
    if (a < 1.0) {
        const double z = a * a;
        const double p = (((44.0 * z + 12870.0) * z + 810810.0) * z + 11486475.0) * z;
        const double q = (((45.0 * z + 13860.0) * z + 945945.0) * z + 16216200.0) * z + 34459425.0;
        r = a - a * (p / q);
    } else if (a >= 19.1) {
        r = 1.0;
    } else { /* also NaN, which exp propagates */
        r = 1.0 - 2.0 / (exp(2.0 * a) + 1.0);
    }
    return copysign(r, x);
}

/* eq 9 */
static void friction(const rrr_model *m, const double qd[3], double uf[3])
{
    for (int i = 0; i < RRR_NJ; ++i) {
        double v = m->b[i] * qd[i];
        for (int k = 0; k < RRR_NF; ++k) {
            v += m->f[i][k] * tanh_fast(m->w[i][k] * qd[i]);
        }
        uf[i] = v;
    }
}

/* d u_f,i / d qd_i of eq 9: b_i + sum_k f_ik w_ik (1 - tanh^2(w_ik qd_i)), with the tanh of the
 * friction itself */
static void friction_slope(const rrr_model *m, const double qd[3], double s[3])
{
    for (int i = 0; i < RRR_NJ; ++i) {
        double v = m->b[i];
        for (int k = 0; k < RRR_NF; ++k) {
            const double t = tanh_fast(m->w[i][k] * qd[i]);
            v += m->f[i][k] * m->w[i][k] * (1.0 - t * t);
        }
        s[i] = v;
    }
}

void rrr_actuator_friction_tanh(const rrr_model *m, const double qd[3], double th[3][RRR_NF])
{
    for (int i = 0; i < RRR_NJ; ++i) {
        for (int k = 0; k < RRR_NF; ++k) {
            th[i][k] = tanh_fast(m->w[i][k] * qd[i]);
        }
    }
}

rrr_status rrr_friction_slope(const rrr_model *m, const double qd[3], double duf_dqd[3])
{
    if (m == NULL || qd == NULL || duf_dqd == NULL || !actuator_ok(m) || !rrr_finite_n(qd, 3)) {
        return RRR_BAD_INPUT;
    }
    double v[3];
    friction_slope(m, qd, v);
    if (!rrr_finite_n(v, 3)) {
        return RRR_NUMERIC;
    }
    memcpy(duf_dqd, v, sizeof v);
    return RRR_OK;
}

rrr_status rrr_friction(const rrr_model *m, const double qd[3], double uf[3])
{
    if (m == NULL || qd == NULL || uf == NULL || !actuator_ok(m) || !rrr_finite_n(qd, 3)) {
        return RRR_BAD_INPUT;
    }
    double v[3];
    friction(m, qd, v);
    if (!rrr_finite_n(v, 3)) {
        return RRR_NUMERIC;
    }
    memcpy(uf, v, sizeof v);
    return RRR_OK;
}

rrr_status rrr_voltage_from_torque(const rrr_model *m, const double qd[3], const double tau[3],
                                   double u[3])
{
    if (m == NULL || qd == NULL || tau == NULL || u == NULL || !actuator_ok(m) ||
        !rrr_finite_n(qd, 3) || !rrr_finite_n(tau, 3)) {
        return RRR_BAD_INPUT;
    }
    double v[3];
    friction(m, qd, v);
    for (int i = 0; i < RRR_NJ; ++i) {
        v[i] += tau[i] / m->kt[i];
    }
    if (!rrr_finite_n(v, 3)) {
        return RRR_NUMERIC;
    }
    memcpy(u, v, sizeof v);
    return RRR_OK;
}

/* u_out = u_in clamped to +/- u_max; the bits of the joints that were clamped */
static unsigned clamp3(const rrr_model *m, const double u_in[3], double u_out[3])
{
    unsigned bits = 0u;
    for (int i = 0; i < RRR_NJ; ++i) {
        u_out[i] = u_in[i];
        if (u_out[i] > m->u_max) {
            u_out[i] = m->u_max;
            bits |= 1u << i;
        } else if (u_out[i] < -m->u_max) {
            u_out[i] = -m->u_max;
            bits |= 1u << i;
        }
    }
    return bits;
}

rrr_status rrr_saturate(const rrr_model *m, const double u_in[3], double u_out[3],
                        unsigned *saturated)
{
    if (m == NULL || u_in == NULL || u_out == NULL || !rrr_finite_n(u_in, 3) ||
        !isfinite(m->u_max) || !(m->u_max > 0.0)) {
        return RRR_BAD_INPUT;
    }
    double v[3];
    const unsigned bits = clamp3(m, u_in, v);
    memcpy(u_out, v, sizeof v);
    if (saturated != NULL) {
        *saturated = bits;
    }
    return RRR_OK;
}

int rrr_actuator_params_ok(const rrr_model *m)
{
    return actuator_ok(m);
}

int rrr_actuator_friction(const rrr_model *m, int params_ok, const double qd[3], double uf[3])
{
    if (!params_ok || !rrr_finite_n(qd, 3)) {
        return 0;
    }
    friction(m, qd, uf);
    return 1;
}

rrr_status rrr_actuator_torque(const rrr_model *m, const double uf[3], const double u[3],
                               double tau[3])
{
    if (!rrr_finite_n(u, 3)) {
        return RRR_BAD_INPUT;
    }
    double us[3], t[3];
    (void)clamp3(m, u, us); /* u_max is valid: rrr_actuator_friction's params_ok */
    for (int i = 0; i < RRR_NJ; ++i) {
        t[i] = m->kt[i] * (us[i] - uf[i]);
    }
    if (!rrr_finite_n(t, 3)) {
        return RRR_NUMERIC;
    }
    memcpy(tau, t, sizeof t);
    return RRR_OK;
}

rrr_status rrr_torque_from_voltage(const rrr_model *m, const double qd[3], const double u[3],
                                   double tau[3])
{
    double uf[3];
    if (m == NULL || qd == NULL || u == NULL || tau == NULL ||
        !rrr_actuator_friction(m, actuator_ok(m), qd, uf)) {
        return RRR_BAD_INPUT;
    }
    return rrr_actuator_torque(m, uf, u, tau);
}
