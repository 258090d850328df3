/**
 * @file rrr_actuator.h
 * @brief Motor / current-inverter mapping (paper eq 8) and neural-network friction (eq 9).
 *
 * u = tau_m / k_t + u_f(qd), with tau_m = R p the motor torque (rigid body + rotor inertia),
 * u_f,i = sum_k f_ik tanh(w_ik qd_i) + b_i qd_i (1 - 2/(e^{2x}+1) = tanh x).
 */
#ifndef RRR_ACTUATOR_H
#define RRR_ACTUATOR_H

#ifdef __cplusplus
extern "C" {
#endif

#include "rrr_model.h"

/** @brief Friction voltage u_f(qd) of eq 9, V. */
RRR_API rrr_status rrr_friction(const rrr_model *m, const double qd[3], double uf[3]);

/**
 * @brief Voltage that produces motor torque tau at velocity qd (eq 8/10), V, NOT saturated.
 * @return RRR_OK or RRR_BAD_INPUT
 */
RRR_API rrr_status rrr_voltage_from_torque(const rrr_model *m, const double qd[3], const double tau[3],
                                   double u[3]);

/**
 * @brief Motor torque produced by input voltage u at velocity qd: tau = k_t (sat(u) - u_f(qd)), N m.
 *        The input is saturated to [-u_max, u_max] first (the inverter's range).
 */
RRR_API rrr_status rrr_torque_from_voltage(const rrr_model *m, const double qd[3], const double u[3],
                                   double tau[3]);

/**
 * @brief Clamp voltages to [-u_max, u_max].
 * @param[out] saturated if not NULL, bit i set when joint i was clamped
 * @return RRR_OK or RRR_BAD_INPUT (non-finite voltage)
 */
RRR_API rrr_status rrr_saturate(const rrr_model *m, const double u_in[3], double u_out[3],
                        unsigned *saturated);

#ifdef __cplusplus
}
#endif
#endif /* RRR_ACTUATOR_H */
