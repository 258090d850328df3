/**
 * @file rrr_control.h
 * @brief Computed-torque law of eq 15: u = u_n(q_ref, qd_ref, qdd_ref) + Kp e + Kd e_dot, saturated.
 */
#ifndef RRR_CONTROL_H
#define RRR_CONTROL_H

#ifdef __cplusplus
extern "C" {
#endif

#include "rrr_model.h"

/** Sample period of the control loop, s: the communication step of the FMUs' default experiment,
 *  the period of the CAN bench and the default `sample_time` of a robot file. */
#define RRR_SAMPLE_TIME_DEFAULT 1e-3

/** @brief RRR_SAMPLE_TIME_DEFAULT, for bindings that cannot read a macro. */
RRR_API double rrr_sample_time_default(void);

/** @brief Gains and switches of the computed-torque law. */
typedef struct rrr_ctc_gains {
    double kp[3];                ///< proportional gains, V/rad, >= 0
    double kd[3];                ///< derivative gains, V s/rad, >= 0
    int feedforward;             ///< nonzero: add the model feedforward u_n (eq 10 along the reference)
} rrr_ctc_gains;

/** @brief Output of one evaluation of the law. */
typedef struct rrr_ctc_output {
    double u[3];                 ///< applied voltage sat(u_n + u_c), V
    double u_n[3];               ///< nominal (feedforward) part, V; 0 when feedforward is off
    double u_c[3];               ///< PD part Kp (q_ref - q) + Kd (qd_ref - qd), V
    unsigned saturated;          ///< bit i set when u_i was clamped to +/- u_max
} rrr_ctc_output;

/** @brief Default gains of the default robot (python/rrr_robot/data/default_robot.toml [control]). */
RRR_API rrr_status rrr_ctc_gains_default(rrr_ctc_gains *gains);

/**
 * @brief Evaluate eq 15. u_n = k_t^-1 R(q_ref, qd_ref, qdd_ref) p + u_f(qd_ref) (eq 10).
 * @return RRR_OK, RRR_BAD_INPUT (NULL, non-finite input, negative or non-finite gain)
 */
RRR_API rrr_status rrr_ctc(const rrr_model *m, const rrr_ctc_gains *gains, const double q_ref[3],
                   const double qd_ref[3], const double qdd_ref[3], const double q[3],
                   const double qd[3], rrr_ctc_output *out);

/**
 * @brief The measured state carried `lead` seconds forward along its own velocity and
 *        acceleration: q_pred = q + lead qd + lead^2 / 2 qdd, qd_pred = qd + lead qdd.
 *
 * The predictor of a sampled loop whose measurement arrives one sample late (a co-simulation
 * master that passes every output on only at the next step): with lead = one sample, the law
 * acts on the state at the time its output is applied. lead = 0 gives q and qd exactly.
 * @param q          measured position, rad
 * @param qd         measured velocity, rad/s
 * @param qdd        measured acceleration, rad/s2
 * @param lead       s, finite and >= 0
 * @param[out] q_pred  the predicted position (may alias q)
 * @param[out] qd_pred the predicted velocity (may alias qd)
 * @return RRR_OK, RRR_BAD_INPUT (NULL, non-finite input, lead negative or not finite)
 */
RRR_API rrr_status rrr_predict_state(const double q[3], const double qd[3], const double qdd[3],
                                     double lead, double q_pred[3], double qd_pred[3]);

#ifdef __cplusplus
}
#endif
#endif /* RRR_CONTROL_H */
