/**
 * @file config.h
 * @brief The computed-torque controller FMU (rrr_controller): identifier, value references,
 *        model data.
 *
 * Direct feedthrough: the outputs u, u_n, u_c are rrr_ctc() of the current inputs (reference
 * q_ref, qd_ref, qdd_ref and measurement q, qd), recomputed whenever an input or parameter has
 * changed and an output is read. With lead > 0 the law acts on the measured state carried lead
 * seconds forward along qd and the measured qdd (rrr_predict_state): for masters that pass the
 * plant's outputs on one step late. The controller has its own copy of the model parameters, with
 * the plant's names, so a model mismatch is set per FMU.
 */
#ifndef RRR_FMU_CONTROLLER_CONFIG_H
#define RRR_FMU_CONTROLLER_CONFIG_H

#include "rrr_model_vars.h" /* first: it includes fmu_model.h */
#include "rrr/rrr.h"

#define MODEL_IDENTIFIER "rrr_controller"

/** Value references (= rows of the variable table in model.c). */
typedef enum controller_vr {
    vr_q_ref = 0,                              ///< q_ref[1..3], input, rad
    vr_qd_ref = vr_q_ref + RRR_NJ,             ///< qd_ref[1..3], input, rad/s
    vr_qdd_ref = vr_qd_ref + RRR_NJ,           ///< qdd_ref[1..3], input, rad/s2
    vr_q = vr_qdd_ref + RRR_NJ,                ///< q[1..3], input (measured), rad
    vr_qd = vr_q + RRR_NJ,                     ///< qd[1..3], input (measured), rad/s
    vr_u = vr_qd + RRR_NJ,                     ///< u[1..3], output, V
    vr_u_n = vr_u + RRR_NJ,                    ///< u_n[1..3], output, V
    vr_u_c = vr_u_n + RRR_NJ,                  ///< u_c[1..3], output, V
    vr_kp = vr_u_c + RRR_NJ,                   ///< kp[1..3], parameter, V/rad
    vr_kd = vr_kp + RRR_NJ,                    ///< kd[1..3], parameter, V s/rad
    vr_feedforward = vr_kd + RRR_NJ,           ///< feedforward, Boolean parameter
    vr_model,                                  ///< first of the RRR_MV_COUNT model parameters
    vr_qdd = vr_model + RRR_MV_COUNT,          ///< qdd[1..3], input (measured), rad/s2
    vr_lead = vr_qdd + RRR_NJ,                 ///< lead, parameter, s (measurement predictor)
    vr_time,                                   ///< time, independent variable, s
    vr_count
} controller_vr;

/** Model data of one controller instance (plain old data: copied into FMU state snapshots). */
typedef struct controller_data {
    rrr_model model;                           ///< the controller's copy of the model parameters
    rrr_ctc_gains gains;                       ///< kp, kd, feedforward
    double q_ref[RRR_NJ];                      ///< reference position, rad
    double qd_ref[RRR_NJ];                     ///< reference velocity, rad/s
    double qdd_ref[RRR_NJ];                    ///< reference acceleration, rad/s2
    double q[RRR_NJ];                          ///< measured position, rad
    double qd[RRR_NJ];                         ///< measured velocity, rad/s
    double qdd[RRR_NJ];                        ///< measured acceleration, rad/s2 (for lead)
    double lead;                               ///< the law acts on (q, qd) carried lead s
                                               ///< forward (rrr_predict_state); 0: as measured
    rrr_ctc_output out;                        ///< u, u_n, u_c of the current inputs
} controller_data;

#endif /* RRR_FMU_CONTROLLER_CONFIG_H */
