/* Private helpers of librrr (not installed). */
#ifndef RRR_INTERNAL_H
#define RRR_INTERNAL_H

#include <math.h>
#include <stddef.h>
#include <stdint.h>
#include <string.h>
#include "rrr/rrr.h"

/** pi (M_PI is not part of strict C11). */
#define RRR_PI 3.14159265358979323846

/* Default torque constants, N m / V: calibrated to the paper's eq 16 (tools/calibrate_kt.py). */
#define RRR_DEFAULT_KT1 12.0
#define RRR_DEFAULT_KT2 11.0
#define RRR_DEFAULT_KT3 4.7

/** 1 when every one of the n values is finite: a double is Inf or NaN exactly when its exponent
 *  bits are all ones. Integer, branch-free and vectorisable (it sits on every hot path, where n
 *  isfinite() branches cost several ns). */
static inline int rrr_finite_n(const double *v, size_t n)
{
    const uint64_t exp_mask = 0x7ff0000000000000ULL;
    uint64_t bad = 0u;
    for (size_t i = 0; i < n; ++i) {
        uint64_t bits;
        memcpy(&bits, &v[i], sizeof bits);
        bad |= (uint64_t)((bits & exp_mask) == exp_mask);
    }
    return bad == 0u;
}

/** Relative tolerance under which an IK target on the workspace boundary is snapped onto it
 *  (rrr_kinematics.c, and the batch IK kernels of c_src/rrr/simd/). */
#define RRR_IK_BOUNDARY_TOL 1e-12

/** 1 when the kinematic lengths of m are usable (finite d1, a2, a3, d2 + d3; a2, a3 > 0). */
static inline int rrr_kin_ok(const rrr_model *m)
{
    const double k[4] = {m->d1, m->a2, m->a3, m->d2 + m->d3};
    return rrr_finite_n(k, 4) && m->a2 > 0.0 && m->a3 > 0.0;
}

/** sin/cos of q2, q3 and q2 + q3, the only trigonometric inputs of the dynamics. */
typedef struct rrr_trig {
    double s2, c2, s3, c3, s23, c23;
} rrr_trig;

static inline rrr_trig rrr_trig_of(const double q[3])
{
    rrr_trig t;
    t.s2 = sin(q[1]);
    t.c2 = cos(q[1]);
    t.s3 = sin(q[2]);
    t.c3 = cos(q[2]);
    /* angle-sum identities: two products instead of two more libm calls */
    t.s23 = t.s2 * t.c3 + t.c2 * t.s3;
    t.c23 = t.c2 * t.c3 - t.s2 * t.s3;
    return t;
}

/** Largest |q_i - q0_i| (rad) for which rrr_trig_near uses the series. */
#define RRR_TRIG_NEAR_MAX 0.015625

/* sin d and cos d - 1 for |d| <= RRR_TRIG_NEAR_MAX: Taylor series through d^7 and d^8 (the first
 * omitted terms, d^9/9! and d^10/10!, are below 1e-21 of the result), in Horner form. */
static inline void rrr_sincos_small(double d, double *s, double *cm1)
{
    const double z = d * d;
    *s = d * (1.0 - z / 6.0 * (1.0 - z / 20.0 * (1.0 - z / 42.0)));
    *cm1 = -0.5 * z * (1.0 - z / 12.0 * (1.0 - z / 30.0 * (1.0 - z / 56.0)));
}

/* sin/cos of a + d from those of a: sin a + (sin a (cos d - 1) + cos a sin d), and the same for
 * cos; the correction is of the size of d, so the result is within about 1 ulp of libm's. */
static inline void rrr_angle_step(double s0, double c0, double d, double *s, double *c)
{
    double sd, cm1;
    rrr_sincos_small(d, &sd, &cm1);
    *s = s0 + (s0 * cm1 + c0 * sd);
    *c = c0 + (c0 * cm1 - s0 * sd);
}

/**
 * The trig of q from that of a nearby q0 (t0 = rrr_trig_of(q0) or rrr_trig_near): the
 * angle-sum identities with the sines and cosines of q - q0 by their series, about a tenth of
 * the cost of libm's sin and cos; rrr_trig_of(q) when a difference exceeds RRR_TRIG_NEAR_MAX
 * or is not finite. Used for the inner stages of the plant's Runge-Kutta steps, whose states
 * differ from the step's start by a step times a velocity.
 */
static inline rrr_trig rrr_trig_near(const rrr_trig *t0, const double q0[3], const double q[3])
{
    const double d2 = q[1] - q0[1];
    const double d3 = q[2] - q0[2];
    if (!(fabs(d2) <= RRR_TRIG_NEAR_MAX && fabs(d3) <= RRR_TRIG_NEAR_MAX)) {
        return rrr_trig_of(q); /* also NaN */
    }
    rrr_trig t;
    rrr_angle_step(t0->s2, t0->c2, d2, &t.s2, &t.c2);
    rrr_angle_step(t0->s3, t0->c3, d3, &t.s3, &t.c3);
    t.s23 = t.s2 * t.c3 + t.c2 * t.s3;
    t.c23 = t.c2 * t.c3 - t.s2 * t.s3;
    return t;
}

/* ---- the plant's right-hand side in two halves ------------------------------------------------
 * Forward dynamics and the motor mapping split into what depends on the state (q, qd) only and
 * what the input adds: the plant evaluates both halves each time, except that a caller that
 * knows the state did not change (the closed loop in C, between communication steps) reuses the
 * first half under a new input. The same code either way, so the numbers are the same bits. */

/** The state-only half of rrr_forward_dynamics: bias c + h and the Cholesky factor of D. */
typedef struct rrr_fd_factor {
    rrr_trig t;    /* the sines and cosines of q it was made with (set unless q1 is not finite) */
    double bias[3];
    double l00, l10, l20, l11, l21, l22;
    rrr_status st; /* RRR_OK; RRR_BAD_INPUT (q1); RRR_NUMERIC (the bias is not finite: the solve
                    * classifies it with tau, as rrr_forward_dynamics does); RRR_NOT_POSITIVE_DEFINITE */
} rrr_fd_factor;

/** Fill f for (q, qd); m, q, qd non-NULL. */
void rrr_fd_factorize(const rrr_model *m, const double q[3], const double qd[3], rrr_fd_factor *f);

/** rrr_fd_factorize with the trig of q given (rrr_trig_of or rrr_trig_near of the same q). */
void rrr_fd_factorize_trig(const rrr_model *m, const double q[3], const rrr_trig *t,
                           const double qd[3], rrr_fd_factor *f);

/** qdd = D^-1 (tau - bias) from f (of the same m, q, qd), with rrr_forward_dynamics' statuses. */
rrr_status rrr_fd_solve(const rrr_model *m, const double q[3], const double qd[3],
                        const rrr_fd_factor *f, const double tau[3], double qdd[3]);

/** 1 when the actuator parameters (k_t, b, f, w, u_max) are valid: what rrr_torque_from_voltage
 *  checks of the model, checked once by a caller that evaluates it many times. */
int rrr_actuator_params_ok(const rrr_model *m);

/** The state-only half of rrr_torque_from_voltage: 1 and the friction voltage uf at qd when
 *  params_ok (rrr_actuator_params_ok(m)) and qd is finite, else 0 (uf unset). */
int rrr_actuator_friction(const rrr_model *m, int params_ok, const double qd[3], double uf[3]);

/** The tanh terms of eq 9, th[i][k] = tanh(w_ik qd_i), with the friction's own tanh (the
 *  derivatives with respect to f, w and b are built from them); m valid, qd finite. */
void rrr_actuator_friction_tanh(const rrr_model *m, const double qd[3], double th[3][RRR_NF]);

/** tau from the input u and the friction uf of rrr_actuator_friction (which returned 1), with
 *  rrr_torque_from_voltage's statuses for u and the result. */
rrr_status rrr_actuator_torque(const rrr_model *m, const double uf[3], const double u[3],
                               double tau[3]);

/** The plant's right-hand side at one state, before the input: rrr_plant_prepare fills it
 *  (params_ok: rrr_actuator_params_ok(m)), rrr_plant_accel_prepared finishes it for an input u. */
typedef struct rrr_plant_prep {
    double q[3], qd[3];  /* the state it belongs to */
    int input_ok;        /* rrr_actuator_friction's verdict */
    double uf[3];
    rrr_fd_factor fd;
} rrr_plant_prep;

void rrr_plant_prepare(const rrr_model *m, int params_ok, const double q[3], const double qd[3],
                       rrr_plant_prep *p);
/** rrr_plant_prepare with the trig of q given (as rrr_fd_factorize_trig). */
void rrr_plant_prepare_trig(const rrr_model *m, int params_ok, const double q[3],
                            const rrr_trig *t, const double qd[3], rrr_plant_prep *p);
rrr_status rrr_plant_accel_prepared(const rrr_model *m, const rrr_plant_prep *p,
                                    const double u[3], double qdd[3]);

/** rrr_plant_step that reuses, when it belongs to x's state (bit for bit), the right-hand side's
 *  first half in *prep, and leaves there the one of the end state (adaptive integration; the
 *  fixed step ignores it). prep->q must be NaN (or another state) when it holds nothing. The
 *  caller keeps m the same between calls sharing a prep. The results are those of
 *  rrr_plant_step, bit for bit. */
rrr_status rrr_plant_step_prepared(const rrr_model *m, const rrr_plant_integrator *s,
                                   const double u[3], double h, rrr_plant_state *x,
                                   double qdd[3], rrr_plant_stats *stats, rrr_plant_prep *prep);

#endif /* RRR_INTERNAL_H */
