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

/* eq 9: 1 - 2 / (e^{2x} + 1) = tanh(x), which does not overflow for large |x| */
static void friction(const rrr_model *m, const double qd[3], double uf[3])
{
    for (int i = 0; i < RRR_NJ; ++i) {
        double v = m->b[i] * qd[i];
        for (int k = 0; k < RRR_NF; ++k) {
            v += m->f[i][k] * tanh(m->w[i][k] * qd[i]);
        }
        uf[i] = v;
    }
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

rrr_status rrr_saturate(const rrr_model *m, const double u_in[3], double u_out[3],
                        unsigned *saturated)
{
    if (m == NULL || u_in == NULL || u_out == NULL || !rrr_finite_n(u_in, 3) ||
        !isfinite(m->u_max) || !(m->u_max > 0.0)) {
        return RRR_BAD_INPUT;
    }
    unsigned bits = 0u;
    double v[3];
    for (int i = 0; i < RRR_NJ; ++i) {
        v[i] = u_in[i];
        if (v[i] > m->u_max) {
            v[i] = m->u_max;
            bits |= 1u << i;
        } else if (v[i] < -m->u_max) {
            v[i] = -m->u_max;
            bits |= 1u << i;
        }
    }
    memcpy(u_out, v, sizeof v);
    if (saturated != NULL) {
        *saturated = bits;
    }
    return RRR_OK;
}

rrr_status rrr_torque_from_voltage(const rrr_model *m, const double qd[3], const double u[3],
                                   double tau[3])
{
    if (m == NULL || qd == NULL || u == NULL || tau == NULL || !actuator_ok(m) ||
        !rrr_finite_n(qd, 3) || !rrr_finite_n(u, 3)) {
        return RRR_BAD_INPUT;
    }
    double us[3], uf[3], t[3];
    (void)rrr_saturate(m, u, us, NULL);
    friction(m, qd, uf);
    for (int i = 0; i < RRR_NJ; ++i) {
        t[i] = m->kt[i] * (us[i] - uf[i]);
    }
    if (!rrr_finite_n(t, 3)) {
        return RRR_NUMERIC;
    }
    memcpy(tau, t, sizeof t);
    return RRR_OK;
}
