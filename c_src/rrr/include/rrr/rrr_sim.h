/**
 * @file rrr_sim.h
 * @brief The closed loop of the writing task in C: reference -> computed-torque controller ->
 *        plant, with exactly the calls and the order of the co-simulation master that drives the
 *        controller and plant FMUs, so both give bit-identical results.
 *
 * Per sample k = 0 .. n-1 (the master's loop):
 *  1. record the plant outputs (q, qd, qdd, tip) at t_k;
 *  2. the controller: rrr_ctc(ctrl, gains, ref_k, q, qd) -> (u, u_n, u_c), recorded; at k = 0
 *     row 0's qdd is replaced by rrr_plant_accel under that u (the master reads the plant FMU's
 *     qdd again after setting its first input: row 0 shows the acceleration of row 0's input);
 *  3. unless k = n-1: the plant over [t_k, t_k + step] with u held: rrr_plant_step, then rrr_fk
 *     (what the plant FMU's doStep calls). Row k > 0's qdd is the end of that step's, under
 *     u[k-1].
 * Before the loop, as the FMUs' initialization does: both models validated, the integrator
 * settings checked, the plant state (q0, qd0) with no step-size history, its first qdd under the
 * FMU's start input u = 0 (checked, then replaced as above) and its first tip position.
 */
#ifndef RRR_SIM_H
#define RRR_SIM_H

#ifdef __cplusplus
extern "C" {
#endif

#include <stddef.h>

#include "rrr_control.h"
#include "rrr_model.h"
#include "rrr_plant.h"

/** Columns of a plant row: q[3], qd[3], qdd[3], tip[3]. */
#define RRR_SIM_PLANT_COLS 12
/** Columns of a controller row: u[3], u_n[3], u_c[3]. */
#define RRR_SIM_CTRL_COLS 9
/** Columns of a reference row: q_ref[3], qd_ref[3], qdd_ref[3]. */
#define RRR_SIM_REF_COLS 9

/**
 * @brief Run the closed loop over n samples at the communication step `step`.
 * @param[in]  plant      the plant's model (the plant FMU's parameters)
 * @param[in]  integ      the plant's integrator settings
 * @param[in]  q0, qd0    the plant's initial state
 * @param[in]  ctrl       the controller's own model (may differ from the plant's)
 * @param[in]  gains      the controller's gains and feedforward switch
 * @param[in]  n          number of samples, >= 1
 * @param[in]  step       communication step, s, > 0 and finite
 * @param[in]  ref        n rows of RRR_SIM_REF_COLS doubles
 * @param[out] plant_out  n rows of RRR_SIM_PLANT_COLS doubles
 * @param[out] ctrl_out   n rows of RRR_SIM_CTRL_COLS doubles
 * @param[out] done       if not NULL, the number of samples fully written (n on RRR_OK; the
 *                        sample that failed otherwise)
 * @return RRR_OK; RRR_BAD_INPUT (NULL, n = 0, bad step, q0/qd0, reference or settings);
 *         RRR_BAD_MODEL or RRR_NOT_POSITIVE_DEFINITE (a model is invalid); a status of the
 *         controller or the plant at sample *done. Rows before *done are valid either way.
 */
RRR_API rrr_status rrr_sim_closed_loop(const rrr_model *plant, const rrr_plant_integrator *integ,
                                       const double q0[3], const double qd0[3],
                                       const rrr_model *ctrl, const rrr_ctc_gains *gains, size_t n,
                                       double step, const double ref[], double plant_out[],
                                       double ctrl_out[], size_t *done);

#ifdef __cplusplus
}
#endif
#endif /* RRR_SIM_H */
