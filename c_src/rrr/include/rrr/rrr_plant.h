/**
 * @file rrr_plant.h
 * @brief The plant: voltages in, joint motion out. Motor mapping (eq 8), friction (eq 9) and
 *        rigid-body dynamics (eq 7) integrated by classic fixed-step Runge-Kutta 4.
 *
 * Method: RK4 on x = (q, qd) with the communication interval h split into
 * n = ceil(h / h_int) equal substeps. It is 4th order (global error O(h_int^4)), and its
 * stability interval on the real axis reaches |lambda| h_int <= 2.78; the steepest friction
 * slope of the default robot, k_t f w / D_ii, gives |lambda| of about 600 1/s on joint 3, so the
 * default h_int = 1e-4 s keeps |lambda| h_int near 0.06, well inside it, and resolves the
 * tanh transition near zero velocity (width 1/w = 10 mrad/s) with several substeps.
 * The input voltage is held constant (and saturated) over h.
 */
#ifndef RRR_PLANT_H
#define RRR_PLANT_H

#ifdef __cplusplus
extern "C" {
#endif

#include "rrr_model.h"

/** Default internal integration step, s. */
#define RRR_PLANT_H_INT_DEFAULT 1e-4

/** Most substeps one rrr_plant_step call takes (a guard against an h / h_int that would not
 *  finish): a longer interval is refused with RRR_BAD_INPUT. */
#define RRR_PLANT_MAX_SUBSTEPS 1e7

/** @brief State of the plant. */
typedef struct rrr_plant_state {
    double q[3];                 ///< joint positions, rad (unwrapped, any real value)
    double qd[3];                ///< joint velocities, rad/s
} rrr_plant_state;

/**
 * @brief Derivative of the plant state under input voltage u (saturated): qdd, rad/s^2.
 * @return RRR_OK, RRR_BAD_INPUT, RRR_NOT_POSITIVE_DEFINITE
 */
RRR_API rrr_status rrr_plant_accel(const rrr_model *m, const rrr_plant_state *x, const double u[3],
                           double qdd[3]);

/**
 * @brief Advance the state by h seconds under constant input voltage u.
 * @param[in]     h_int internal step upper bound, s, > 0 (e.g. RRR_PLANT_H_INT_DEFAULT)
 * @param[in]     u     input voltage, V (saturated to +/- u_max inside)
 * @param[in]     h     interval, s, > 0
 * @param[in,out] x     state; updated only on RRR_OK
 * @param[out]    qdd   if not NULL, acceleration at the end of the interval, rad/s^2
 * @return RRR_OK, RRR_BAD_INPUT (NULL, non-finite, h <= 0, h_int <= 0, more than RRR_PLANT_MAX_SUBSTEPS substeps),
 *         RRR_NUMERIC (the state became non-finite) or RRR_NOT_POSITIVE_DEFINITE; x untouched unless RRR_OK
 */
RRR_API rrr_status rrr_plant_step(const rrr_model *m, double h_int, const double u[3], double h,
                          rrr_plant_state *x, double qdd[3]);

#ifdef __cplusplus
}
#endif
#endif /* RRR_PLANT_H */
