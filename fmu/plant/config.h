/**
 * @file config.h
 * @brief The plant FMU (rrr_plant): identifier, value references, model data.
 *
 * Inputs: motor voltages u. Outputs: joint motion q, qd, qdd and the tip position.
 * Parameters: the rrr_model (same names as the controller's), the initial state q0, qd0 and the
 * integrator settings (adaptive, rtol, atol; h_int for the fixed step). Co-Simulation: doStep
 * calls rrr_plant_step (Dormand-Prince 5(4) with error control, or fixed-step RK4; input held
 * over the step). Model Exchange: continuous states q and qd, derivatives qd and qdd.
 */
#ifndef RRR_FMU_PLANT_CONFIG_H
#define RRR_FMU_PLANT_CONFIG_H

#include "rrr_model_vars.h" /* first: it includes fmu_model.h */
#include "rrr/rrr.h"

#define MODEL_IDENTIFIER "rrr_plant"

/** The step budget of one doStep: at most this many internal steps (adaptive: attempted steps;
 *  fixed step: substeps, refused before any work), then Discard with the reason logged and the
 *  state unchanged. About 7 evaluations each: at most about 0.3 s of work per doStep on a
 *  desktop core (docs/limits.md). A plant the FMU accepts (RRR_PLANT_STIFFNESS_MAX) needs
 *  about 3e5 steps per simulated second at most for stability, so a 1 ms step takes about 300;
 *  the budget matters only for states far from the accepted ones (velocities of 1e6 rad/s
 *  and more) and for long communication steps. */
#define PLANT_FMU_MAX_STEPS 100000L

/** Value references (= rows of the variable table in model.c). */
typedef enum plant_vr {
    vr_u = 0,                                  ///< u[1..3], input, V
    vr_q = vr_u + RRR_NJ,                      ///< q[1..3], output, rad
    vr_qd = vr_q + RRR_NJ,                     ///< qd[1..3], output, rad/s
    vr_qdd = vr_qd + RRR_NJ,                   ///< qdd[1..3], output, rad/s2
    vr_tip = vr_qdd + RRR_NJ,                  ///< tip.x, tip.y, tip.z, output, m
    vr_model = vr_tip + 3,                     ///< first of the RRR_MV_COUNT model parameters
    vr_q0 = vr_model + RRR_MV_COUNT,           ///< q0[1..3], parameter, rad
    vr_qd0 = vr_q0 + RRR_NJ,                   ///< qd0[1..3], parameter, rad/s
    vr_h_int = vr_qd0 + RRR_NJ,                ///< h_int, parameter, s
    vr_adaptive,                               ///< adaptive, Boolean parameter
    vr_rtol,                                   ///< rtol, parameter
    vr_atol,                                   ///< atol, parameter
    vr_time,                                   ///< time, independent variable, s
    vr_count
} plant_vr;

/** Model data of one plant instance (plain old data: copied into FMU state snapshots). */
typedef struct plant_data {
    rrr_model model;                           ///< parameters
    rrr_plant_integrator integ;                ///< adaptive, rtol, atol, h_int, max_steps
    double q0[RRR_NJ];                         ///< initial joint positions, rad
    double qd0[RRR_NJ];                        ///< initial joint velocities, rad/s
    double u[RRR_NJ];                          ///< input voltages, V (saturated inside the core)
    rrr_plant_state x;                         ///< state: q (output), qd (output), and the
                                               ///< step-size controller's h_guess, err_prev
    double qdd[RRR_NJ];                        ///< acceleration at x under the current u, rad/s2
    double tip[3];                             ///< tip position in frame 0, m
} plant_data;

#endif /* RRR_FMU_PLANT_CONFIG_H */
