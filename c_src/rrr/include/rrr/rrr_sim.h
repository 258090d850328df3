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
 * @param[in]  q0         the plant's initial position
 * @param[in]  qd0        the plant's initial velocity
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

/**
 * @brief Where a closed loop run in parts (rrr_sim_closed_loop_part) stands: caller-owned plain
 *        data, zero-filled before the first part.
 */
typedef struct rrr_sim_carry {
    rrr_plant_state x;    ///< the plant's state at sample `next`
    double qdd[3];        ///< the plant's qdd output at that sample (before the controller)
    double tip[3];        ///< its tip output
    size_t next;          ///< samples fully written so far (0: the run has not started)
} rrr_sim_carry;

/**
 * @brief rrr_sim_closed_loop in parts of at most `count` samples, so that a caller can do
 *        something between them (a Python caller handles Ctrl-C and SIGTERM there, a GUI
 *        reports progress): the parts together write exactly what one rrr_sim_closed_loop call
 *        writes, bit for bit. No allocation: the state between parts is in *carry.
 *
 * The first call (carry->next = 0) checks the arguments and the models as
 * rrr_sim_closed_loop does, then runs samples 0 .. min(count, n) - 1; each further call, with
 * the same arguments and carry, runs the next `count` samples. The run is complete when
 * carry->next = n (a further call then does nothing and returns RRR_OK).
 * @param[in]     count at least 1 sample per call
 * @param[in,out] carry where the run stands; carry->next is the number of samples written
 * @param[out]    done  if not NULL, carry->next after the call (the sample that failed on an
 *                      error, as rrr_sim_closed_loop's done)
 * @return rrr_sim_closed_loop's statuses; RRR_BAD_INPUT also for count = 0, a NULL carry or
 *         carry->next > n
 */
RRR_API rrr_status rrr_sim_closed_loop_part(const rrr_model *plant,
                                            const rrr_plant_integrator *integ,
                                            const double q0[3], const double qd0[3],
                                            const rrr_model *ctrl, const rrr_ctc_gains *gains,
                                            size_t n, double step, const double ref[],
                                            double plant_out[], double ctrl_out[], size_t count,
                                            rrr_sim_carry *carry, size_t *done);

#ifdef __cplusplus
}
#endif
#endif /* RRR_SIM_H */
