/*
 * The controller's path in pil_real (pil_law.h). Each function follows librrr's in the order of
 * its operations (rrr_control.c rrr_ctc, rrr_dynamics.c rrr_inverse_dynamics, rrr_actuator.c
 * tanh_fast, friction, rrr_voltage_from_torque, rrr_saturate), so that the double build equals
 * librrr bit for bit; the status of a failure may be coarser (any failure gives 0 V).
 */
#include "pil_law.h"

#include "pil_dynamics_gen.h"

static int finite_n(const pil_real *v, int n)
{
    for (int i = 0; i < n; ++i) {
        if (!isfinite(v[i])) {
            return 0;
        }
    }
    return 1;
}

void pil_model_from(const rrr_model *m, pil_model *out)
{
    out->a2 = (pil_real)m->a2;
    out->g = (pil_real)m->g;
    for (int k = 0; k < RRR_NP; ++k) {
        out->p[k] = (pil_real)m->p[k];
    }
    for (int i = 0; i < RRR_NJ; ++i) {
        out->kt[i] = (pil_real)m->kt[i];
        out->b[i] = (pil_real)m->b[i];
        for (int k = 0; k < RRR_NF; ++k) {
            out->f[i][k] = (pil_real)m->f[i][k];
            out->w[i][k] = (pil_real)m->w[i][k];
        }
    }
    out->u_max = (pil_real)m->u_max;
}

void pil_gains_from(const rrr_ctc_gains *g, pil_gains *out)
{
    for (int i = 0; i < 3; ++i) {
        out->kp[i] = (pil_real)g->kp[i];
        out->kd[i] = (pil_real)g->kd[i];
    }
    out->feedforward = g->feedforward;
}

static int gains_ok(const pil_gains *k)
{
    for (int i = 0; i < RRR_NJ; ++i) {
        if (!isfinite(k->kp[i]) || !isfinite(k->kd[i]) || k->kp[i] < PIL_C(0.0) ||
            k->kd[i] < PIL_C(0.0)) {
            return 0;
        }
    }
    return 1;
}

static int actuator_ok(const pil_model *m)
{
    if (!finite_n(m->kt, RRR_NJ) || !finite_n(m->b, RRR_NJ) || !isfinite(m->u_max) ||
        !(m->u_max > PIL_C(0.0))) {
        return 0;
    }
    for (int i = 0; i < RRR_NJ; ++i) {
        if (!(m->kt[i] > PIL_C(0.0)) || !finite_n(m->f[i], RRR_NF) || !finite_n(m->w[i], RRR_NF)) {
            return 0;
        }
    }
    return 1;
}

/* librrr's tanh_fast (rrr_actuator.c), term for term. In float the integer coefficients above
 * 2^24 round (relative 3e-8, below float's own rounding of the result). */
static pil_real tanh_fast(pil_real x)
{
    const pil_real a = PIL_FABS(x);
    pil_real r;
    if (a < PIL_C(1.0)) {
        const pil_real z = a * a;
        const pil_real p =
            (((PIL_C(44.0) * z + PIL_C(12870.0)) * z + PIL_C(810810.0)) * z + PIL_C(11486475.0)) *
            z;
        const pil_real q = (((PIL_C(45.0) * z + PIL_C(13860.0)) * z + PIL_C(945945.0)) * z +
                            PIL_C(16216200.0)) *
                               z +
                           PIL_C(34459425.0);
        r = a - a * (p / q);
    } else if (a >= PIL_C(19.1)) {
        r = PIL_C(1.0);
    } else {
        r = PIL_C(1.0) - PIL_C(2.0) / (PIL_EXP(PIL_C(2.0) * a) + PIL_C(1.0));
    }
    return PIL_COPYSIGN(r, x);
}

/* eq 9 */
static void friction(const pil_model *m, const pil_real qd[3], pil_real uf[3])
{
    for (int i = 0; i < RRR_NJ; ++i) {
        pil_real v = m->b[i] * qd[i];
        for (int k = 0; k < RRR_NF; ++k) {
            v += m->f[i][k] * tanh_fast(m->w[i][k] * qd[i]);
        }
        uf[i] = v;
    }
}

/* eq 10 along the reference: tau(q, qd, qdd) / kt + u_f(qd) */
static rrr_status feedforward(const pil_model *m, const pil_real q[3], const pil_real qd[3],
                              const pil_real qdd[3], pil_real u_n[3])
{
    if (!isfinite(q[0])) {
        return RRR_BAD_INPUT;
    }
    pil_trig t;
    t.s2 = PIL_SIN(q[1]);
    t.c2 = PIL_COS(q[1]);
    t.s3 = PIL_SIN(q[2]);
    t.c3 = PIL_COS(q[2]);
    t.s23 = t.s2 * t.c3 + t.c2 * t.s3;
    t.c23 = t.c2 * t.c3 - t.s2 * t.s3;
    pil_real tau[3];
    pil_gen_inverse_dynamics(m, &t, qd, qdd, tau);
    if (!finite_n(tau, 3)) {
        return RRR_NUMERIC;
    }
    if (!actuator_ok(m) || !finite_n(qd, 3)) {
        return RRR_BAD_INPUT;
    }
    pil_real v[3];
    friction(m, qd, v);
    for (int i = 0; i < RRR_NJ; ++i) {
        v[i] += tau[i] / m->kt[i];
    }
    if (!finite_n(v, 3)) {
        return RRR_NUMERIC;
    }
    for (int i = 0; i < RRR_NJ; ++i) {
        u_n[i] = v[i];
    }
    return RRR_OK;
}

rrr_status pil_ctc(const pil_model *m, const pil_gains *gains, const pil_real q_ref[3],
                   const pil_real qd_ref[3], const pil_real qdd_ref[3], const pil_real q[3],
                   const pil_real qd[3], pil_ctc_output *out)
{
    if (!gains_ok(gains) || !finite_n(q_ref, 3) || !finite_n(qd_ref, 3) ||
        !finite_n(qdd_ref, 3) || !finite_n(q, 3) || !finite_n(qd, 3)) {
        return RRR_BAD_INPUT;
    }
    pil_ctc_output o = {{PIL_C(0.0)}, {PIL_C(0.0)}, {PIL_C(0.0)}, 0u};
    if (gains->feedforward) {
        const rrr_status st = feedforward(m, q_ref, qd_ref, qdd_ref, o.u_n);
        if (st != RRR_OK) {
            return st;
        }
    }
    pil_real u[3];
    for (int i = 0; i < RRR_NJ; ++i) {
        o.u_c[i] = gains->kp[i] * (q_ref[i] - q[i]) + gains->kd[i] * (qd_ref[i] - qd[i]);
        u[i] = o.u_n[i] + o.u_c[i];
    }
    if (!finite_n(u, 3)) {
        return RRR_NUMERIC;
    }
    if (!isfinite(m->u_max) || !(m->u_max > PIL_C(0.0))) {
        return RRR_BAD_INPUT;
    }
    for (int i = 0; i < RRR_NJ; ++i) {
        o.u[i] = u[i];
        if (o.u[i] > m->u_max) {
            o.u[i] = m->u_max;
            o.saturated |= 1u << i;
        } else if (o.u[i] < -m->u_max) {
            o.u[i] = -m->u_max;
            o.saturated |= 1u << i;
        }
    }
    *out = o;
    return RRR_OK;
}
