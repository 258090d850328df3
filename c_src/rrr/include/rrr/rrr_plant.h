/**
 * @file rrr_plant.h
 * @brief The plant: voltages in, joint motion out. Motor mapping (eq 8), friction (eq 9) and
 *        rigid-body dynamics (eq 7), integrated over a communication interval with the input
 *        voltage held constant (and saturated).
 *
 * One call, rrr_plant_step, advances the state by an interval h: the FMU's doStep calls exactly
 * this, and so should a native closed loop (one call per sample period, the state struct kept
 * between calls). Two methods, chosen by rrr_plant_integrator.adaptive:
 *
 * - Adaptive (the default): the Dormand-Prince 5(4) pair (DOPRI5, Hairer, Norsett and Wanner,
 *   Solving ODEs I, section II.5 and II.4) with first-same-as-last (6 new right-hand-side
 *   evaluations per step, the last one is the next step's first and the end state's qdd) and the
 *   PI step-size controller of Hairer's DOPRI5 (exponents 0.17 and 0.04, safety 0.9, step ratio in
 *   [0.2, 10], no growth right after a rejection). Error test: the embedded 4th-order solution's
 *   difference, scaled per component by atol + rtol max(|x_i|, |x_new,i|) over the six components
 *   (q in rad, qd in rad/s), root mean square <= 1. The interval is split into equal internal
 *   steps no longer than the controller's proposal (a step may stretch by 1 % to end on the
 *   interval); the proposal after the last step is kept in the state (h_guess, with the PI
 *   memory err_prev), so the next call starts from it. Why this pair: the right-hand side is
 *   smooth (tanh friction) and only mildly stiff: the steepest friction slope of the default
 *   robot, k_t f w / D_ii, gives |lambda| of about 600 1/s on joint 3, so a 1 ms step has
 *   |lambda| h = 0.6, well inside DOPRI5's stability region (it reaches 3.3 on the negative real
 *   axis); an implicit or Rosenbrock method would buy nothing but Jacobians. Accuracy of 1e-8 rad
 *   needs local errors near 1e-11, where a 5th-order method takes far larger steps than a
 *   3rd-order one (Bogacki-Shampine); among the 5(4) pairs DOPRI5 is the standard one (ode45,
 *   Hairer's dopri5), and its FSAL stage delivers the output qdd for free. At the default
 *   tolerances a 1 ms communication step is one internal step, 7 evaluations, against the 41 of
 *   ten RK4 substeps. The five inner stages take sin and cos of q2, q3 from those at the step's
 *   start by the angle-sum identities (the differences, at most 1/64 rad, by their Taylor
 *   series; libm beyond): absolute error below 2^-52, a sixth of the stage's cost; the first and
 *   the end stage use libm, so the output qdd is rrr_plant_accel's at the end state bit for bit.
 * - Fixed step: classic Runge-Kutta 4 in n = ceil(h / h_int) equal substeps; 4th order (global
 *   error O(h_int^4)); real-axis stability reaches |lambda| h_int <= 2.78, so h_int = 1e-4 s has
 *   |lambda| h_int near 0.06 on the default robot. h_guess and err_prev are not used (kept).
 *
 * Both are deterministic: the same model, settings, input, interval and state (h_guess and
 * err_prev included) give bit-identical results.
 */
#ifndef RRR_PLANT_H
#define RRR_PLANT_H

#ifdef __cplusplus
extern "C" {
#endif

#include <stddef.h>

#include "rrr_model.h"

/** Default fixed-step substep upper bound, s (used when adaptive is 0). */
#define RRR_PLANT_H_INT_DEFAULT 1e-4
/** Default relative tolerance of the adaptive method. */
#define RRR_PLANT_RTOL_DEFAULT 1e-9
/** Default absolute tolerance of the adaptive method (rad for q, rad/s for qd). */
#define RRR_PLANT_ATOL_DEFAULT 1e-10
///@{
/** Range of rtol and of atol: [RRR_PLANT_TOL_MIN, RRR_PLANT_TOL_MAX]. Below 1e-14 the error
 *  estimate is round-off; above 1e-2 the result is not worth having. */
#define RRR_PLANT_TOL_MIN 1e-14
#define RRR_PLANT_TOL_MAX 1e-2
///@}
/** Default most internal steps one call may take (fixed step: substeps, refused before any work
 *  with RRR_BAD_INPUT; adaptive: attempted steps, accepted or rejected, RRR_NUMERIC when reached):
 *  a guard against an interval that would not finish. */
#define RRR_PLANT_MAX_STEPS_DEFAULT 10000000L

/** Largest stiffness estimate (rrr_plant_stiffness) of a plant that is accepted for simulation,
 *  1/s. The adaptive method is stable for |lambda| h <= 3.3, so a plant of stiffness lambda costs
 *  at least lambda / 3.3 internal steps (6 evaluations each) per simulated second whatever the
 *  tolerances: at this limit about 3e5 steps, 1.8e6 evaluations (docs/limits.md has the
 *  measured seconds). The default robot's estimate is about 1.6e3 1/s. */
#define RRR_PLANT_STIFFNESS_MAX 1e6

/** @brief How the plant integrates (plain data; rrr_plant_integrator_default fills it). */
typedef struct rrr_plant_integrator {
    int adaptive;        ///< nonzero (default): Dormand-Prince 5(4), error-controlled;
                         ///< 0: fixed-step RK4
    double rtol;         ///< adaptive: relative tolerance, in [RRR_PLANT_TOL_MIN,
                         ///< RRR_PLANT_TOL_MAX]
    double atol;         ///< adaptive: absolute tolerance, rad and rad/s, in the same range
    double h_int;        ///< fixed step: substep upper bound, s, > 0 and finite
    long max_steps;      ///< most internal steps per call, >= 1
} rrr_plant_integrator;

/** @brief State of the plant: the motion and the adaptive step-size controller's memory. */
typedef struct rrr_plant_state {
    double q[3];                 ///< joint positions, rad (unwrapped, any real value)
    double qd[3];                ///< joint velocities, rad/s
    double h_guess;              ///< adaptive: proposed next internal step, s; 0 = none yet (the
                                 ///< first call estimates one); finite, >= 0
    double err_prev;             ///< adaptive: scaled error of the last accepted step (PI control);
                                 ///< 0 = none yet; finite, >= 0
} rrr_plant_state;

/** @brief Work done by one rrr_plant_step call. */
typedef struct rrr_plant_stats {
    long steps;                  ///< internal steps accepted (fixed step: substeps)
    long rejected;               ///< internal steps rejected by the error test (adaptive)
    long evals;                  ///< right-hand-side evaluations (one = rrr_plant_accel's work),
                                 ///< the end state's qdd included
} rrr_plant_stats;

/**
 * @brief The default settings: adaptive, rtol = RRR_PLANT_RTOL_DEFAULT,
 *        atol = RRR_PLANT_ATOL_DEFAULT, h_int = RRR_PLANT_H_INT_DEFAULT,
 *        max_steps = RRR_PLANT_MAX_STEPS_DEFAULT.
 * @return RRR_OK, RRR_BAD_INPUT (NULL)
 */
RRR_API rrr_status rrr_plant_integrator_default(rrr_plant_integrator *s);

/**
 * @brief Check settings against the ranges above.
 * @param[out] field if not NULL, on RRR_BAD_INPUT the name of the first bad field ("rtol", "atol",
 *                   "h_int", "max_steps"; the FMU parameters have the same names), else ""
 * @return RRR_OK, RRR_BAD_INPUT
 */
RRR_API rrr_status rrr_plant_integrator_check(const rrr_plant_integrator *s, const char **field);

/**
 * @brief A state at (q0, qd0) with no step-size history (h_guess = err_prev = 0).
 * @return RRR_OK, RRR_BAD_INPUT (NULL or non-finite); x untouched unless RRR_OK
 */
RRR_API rrr_status rrr_plant_state_init(const double q0[3], const double qd0[3],
                                        rrr_plant_state *x);

/**
 * @brief Derivative of the plant state under input voltage u (saturated): qdd, rad/s^2.
 *        Only x->q and x->qd are read.
 * @return RRR_OK, RRR_BAD_INPUT, RRR_NOT_POSITIVE_DEFINITE
 */
RRR_API rrr_status rrr_plant_accel(const rrr_model *m, const rrr_plant_state *x, const double u[3],
                                   double qdd[3]);

/**
 * @brief Stiffness estimate of the plant, |d qdd / d qd|, and the check against
 *        RRR_PLANT_STIFFNESS_MAX: what makes a parameter set too costly to integrate.
 *
 * d qdd / d qd = -D(q)^-1 (d tau / d qd + diag(k_t,i u_f,i'(qd_i))) (rrr_derivatives.h). The
 * friction slope u_f,i' = b_i + sum_k f_ik w_ik (1 - tanh^2(w_ik qd_i)) is at most
 * s_i = b_i + sum_k |f_ik| w_ik (reached at qd_i = 0 when every f_ik >= 0), and the Coriolis part
 * vanishes at rest, so the estimate is
 *     lambda = max over (q2, q3) of max_i sum_j |D(q)^-1_ij| k_t,j s_j
 * (the infinity norm of the matrix at rest, an upper bound of its spectral radius), maximised
 * over a 32 x 32 grid of (q2, q3) (D does not depend on q1). Costs about 0.1 ms.
 * @param[out] lambda if not NULL, the estimate, 1/s (written unless RRR_BAD_INPUT/RRR_BAD_MODEL)
 * @param[out] field  if not NULL, on RRR_TOO_STIFF the name of the parameter with the largest
 *                    share of the stiffest row ("w[1,1]", "b[2]", ...; a static string of the
 *                    parameter table), else ""
 * @return RRR_OK (lambda <= RRR_PLANT_STIFFNESS_MAX), RRR_TOO_STIFF, RRR_BAD_INPUT (NULL),
 *         RRR_BAD_MODEL (non-finite or out-of-range friction or motor parameters),
 *         RRR_NOT_POSITIVE_DEFINITE (D(q) singular at a grid point)
 */
RRR_API rrr_status rrr_plant_stiffness(const rrr_model *m, double *lambda, const char **field);

/**
 * @brief Advance the state by h seconds under constant input voltage u.
 * @param[in]     s     integrator settings (e.g. from rrr_plant_integrator_default)
 * @param[in]     u     input voltage, V (saturated to +/- u_max inside)
 * @param[in]     h     interval, s, > 0 and finite
 * @param[in,out] x     state (q, qd and, adaptive, h_guess and err_prev); updated only on RRR_OK
 * @param[out]    qdd   if not NULL, acceleration at the end of the interval under u, rad/s^2
 *                      (bit-identical to rrr_plant_accel of the new state)
 * @param[out]    stats if not NULL, the work done (written only on RRR_OK)
 * @return RRR_OK; RRR_BAD_INPUT (NULL, non-finite, h <= 0, settings outside their ranges, an
 *         invalid h_guess or err_prev, fixed step: more than max_steps substeps);
 *         RRR_NUMERIC (fixed step: the state became non-finite; adaptive: max_steps attempts or
 *         the step size underflowed without reaching the end of the interval);
 *         RRR_NOT_POSITIVE_DEFINITE. Nothing is written unless RRR_OK.
 */
RRR_API rrr_status rrr_plant_step(const rrr_model *m, const rrr_plant_integrator *s,
                                  const double u[3], double h, rrr_plant_state *x, double qdd[3],
                                  rrr_plant_stats *stats);

/**
 * @brief Open loop in one call: n consecutive rrr_plant_step calls of h seconds each, step k
 *        under the input voltage row u[3k .. 3k+2], the state after each step written to row k
 *        of the outputs. The results are those of the n rrr_plant_step calls, bit for bit (the
 *        first half of each step's right-hand side is reused from the previous step's end, as
 *        the plant FMU does); a caller may split a long input table into several calls on the
 *        same state (a Python caller does, to handle Ctrl-C between them) with the same results.
 * @param[in]     n     number of steps (0: nothing happens, RRR_OK)
 * @param[in]     u     n rows of 3 input voltages, V (each saturated to +/- u_max inside)
 * @param[in]     h     every step's interval, s, > 0 and finite
 * @param[in,out] x     the state: on return the state after the last step that succeeded
 * @param[out]    q     n rows of 3: joint positions after each step, rad
 * @param[out]    qd    if not NULL, n rows of 3: joint velocities after each step, rad/s
 * @param[out]    qdd   if not NULL, n rows of 3: accelerations at the end of each step under its
 *                      input (rrr_plant_step's qdd), rad/s^2
 * @param[out]    done  if not NULL, the number of steps done and rows written (n on RRR_OK,
 *                      the step that failed otherwise)
 * @param[out]    stats if not NULL, the work of the steps done, summed
 * @return RRR_OK; RRR_BAD_INPUT (NULL m, x, or u or q with n > 0); otherwise rrr_plant_step's
 *         status at step *done, with x, the rows before it and stats as they were after the
 *         last step that succeeded (nothing is lost).
 */
RRR_API rrr_status rrr_plant_rollout(const rrr_model *m, const rrr_plant_integrator *s, size_t n,
                                     const double u[], double h, rrr_plant_state *x, double q[],
                                     double qd[], double qdd[], size_t *done,
                                     rrr_plant_stats *stats);

#ifdef __cplusplus
}
#endif
#endif /* RRR_PLANT_H */
