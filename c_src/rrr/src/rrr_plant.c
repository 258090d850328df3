/* The plant: voltages in, joint motion out, integrated by fixed-step RK4 (see rrr_plant.h). */
#include <string.h>

#include "rrr_internal.h"

static rrr_status accel(const rrr_model *m, const double q[3], const double qd[3],
                        const double u[3], double qdd[3])
{
    double tau[3];
    const rrr_status st = rrr_torque_from_voltage(m, qd, u, tau);
    if (st != RRR_OK) {
        return st;
    }
    return rrr_forward_dynamics(m, q, qd, tau, qdd);
}

rrr_status rrr_plant_accel(const rrr_model *m, const rrr_plant_state *x, const double u[3],
                           double qdd[3])
{
    if (m == NULL || x == NULL || u == NULL || qdd == NULL) {
        return RRR_BAD_INPUT;
    }
    return accel(m, x->q, x->qd, u, qdd);
}

/* One classic Runge-Kutta 4 step of length dt on (q, qd). */
static rrr_status rk4(const rrr_model *m, const double u[3], double dt, double q[3],
                      double qd[3])
{
    double k1v[3], k2v[3], k3v[3], k4v[3]; /* accelerations */
    double qa[3], va[3];
    rrr_status st = accel(m, q, qd, u, k1v);
    for (int i = 0; i < 3 && st == RRR_OK; ++i) {
        qa[i] = q[i] + 0.5 * dt * qd[i];
        va[i] = qd[i] + 0.5 * dt * k1v[i];
    }
    double k2q[3];
    memcpy(k2q, va, sizeof va);
    if (st == RRR_OK) {
        st = accel(m, qa, va, u, k2v);
    }
    for (int i = 0; i < 3 && st == RRR_OK; ++i) {
        qa[i] = q[i] + 0.5 * dt * k2q[i];
        va[i] = qd[i] + 0.5 * dt * k2v[i];
    }
    double k3q[3];
    memcpy(k3q, va, sizeof va);
    if (st == RRR_OK) {
        st = accel(m, qa, va, u, k3v);
    }
    for (int i = 0; i < 3 && st == RRR_OK; ++i) {
        qa[i] = q[i] + dt * k3q[i];
        va[i] = qd[i] + dt * k3v[i];
    }
    double k4q[3];
    memcpy(k4q, va, sizeof va);
    if (st == RRR_OK) {
        st = accel(m, qa, va, u, k4v);
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

rrr_status rrr_plant_step(const rrr_model *m, double h_int, const double u[3], double h,
                          rrr_plant_state *x, double qdd[3])
{
    if (m == NULL || u == NULL || x == NULL || !isfinite(h_int) || !(h_int > 0.0) ||
        !isfinite(h) || !(h > 0.0) || !rrr_finite_n(u, 3) || !rrr_finite_n(x->q, 3) ||
        !rrr_finite_n(x->qd, 3)) {
        return RRR_BAD_INPUT;
    }
    const double n_real = ceil(h / h_int * (1.0 - 1e-12)); /* 1e-3 / 1e-4 is 10 substeps, not 11 */
    if (!(n_real <= RRR_PLANT_MAX_SUBSTEPS)) {
        return RRR_BAD_INPUT;
    }
    const long n = n_real < 1.0 ? 1L : (long)n_real;
    const double dt = h / (double)n;
    double q[3], qd[3], a[3];
    memcpy(q, x->q, sizeof q);
    memcpy(qd, x->qd, sizeof qd);
    for (long k = 0; k < n; ++k) {
        const rrr_status st = rk4(m, u, dt, q, qd);
        if (st != RRR_OK) {
            return st;
        }
        if (!rrr_finite_n(q, 3) || !rrr_finite_n(qd, 3)) {
            return RRR_NUMERIC;
        }
    }
    const rrr_status st = accel(m, q, qd, u, a);
    if (st != RRR_OK) {
        return st;
    }
    memcpy(x->q, q, sizeof q);
    memcpy(x->qd, qd, sizeof qd);
    if (qdd != NULL) {
        memcpy(qdd, a, sizeof a);
    }
    return RRR_OK;
}
