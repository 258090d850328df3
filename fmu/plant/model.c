/*
 * The plant FMU: its variable table and the calls into librrr. No physics here: the dynamics,
 * the integrator and the kinematics are rrr_plant_step, rrr_plant_accel and rrr_fk; doStep is
 * one rrr_plant_step call with the settings in `integ` and the state in `x`, which is what a
 * native closed loop calls as well.
 */
#include "config.h"

#include <math.h>
#include <string.h>

#define T plant_data
#define RRR_MV_BASE vr_model

#define INPUT(VR, NAME, JOINT, MEMBER)                                                         \
    FMU_ROW(VR, FMU_REAL, FMU_INPUT, FMU_CONTINUOUS, NAME,                                     \
            "motor voltage of joint " JOINT ", held over the step, saturated to u_max", "V", T,  \
            MEMBER)
#define OUTPUT(VR, NAME, DESC, UNIT, MEMBER)                                                   \
    FMU_ROW(VR, FMU_REAL, FMU_OUTPUT, FMU_CONTINUOUS, NAME, DESC, UNIT, T, MEMBER)
#define JOINT_OUTPUTS(VR, N, WHAT, UNIT, M)                                                    \
    OUTPUT((VR) + 0, N "[1]", WHAT " of joint 1", UNIT, M[0]),                                 \
    OUTPUT((VR) + 1, N "[2]", WHAT " of joint 2", UNIT, M[1]),                                 \
    OUTPUT((VR) + 2, N "[3]", WHAT " of joint 3", UNIT, M[2])
#define JOINT_PARAMS(VR, N, WHAT, UNIT, M)                                                     \
    FMU_PARAM((VR) + 0, N "[1]", WHAT " of joint 1", UNIT, T, M[0]),                           \
    FMU_PARAM((VR) + 1, N "[2]", WHAT " of joint 2", UNIT, T, M[1]),                           \
    FMU_PARAM((VR) + 2, N "[3]", WHAT " of joint 3", UNIT, T, M[2])

static const fmu_variable plant_vars[] = {
    INPUT(vr_u + 0, "u[1]", "1", u[0]),
    INPUT(vr_u + 1, "u[2]", "2", u[1]),
    INPUT(vr_u + 2, "u[3]", "3", u[2]),
    JOINT_OUTPUTS(vr_q, "q", "position", "rad", x.q),
    JOINT_OUTPUTS(vr_qd, "qd", "velocity", "rad/s", x.qd),
    JOINT_OUTPUTS(vr_qdd, "qdd", "acceleration under the current input", "rad/s2", qdd),
    OUTPUT(vr_tip + 0, "tip.x", "tip position x in the base frame", "m", tip[0]),
    OUTPUT(vr_tip + 1, "tip.y", "tip position y in the base frame", "m", tip[1]),
    OUTPUT(vr_tip + 2, "tip.z", "tip position z in the base frame (z0 up)", "m", tip[2]),
    RRR_MODEL_VARS
    JOINT_PARAMS(vr_q0, "q0", "initial position", "rad", q0),
    JOINT_PARAMS(vr_qd0, "qd0", "initial velocity", "rad/s", qd0),
    FMU_PARAM(vr_h_int, "h_int",
              "fixed-step mode (adaptive = false): RK4 substep upper bound, > 0 (a step of h "
              "takes ceil(h/h_int) equal substeps); unused when adaptive",
              "s", T, integ.h_int),
    FMU_ROW(vr_adaptive, FMU_BOOLEAN, FMU_PARAMETER, FMU_FIXED, "adaptive",
            "integrator inside doStep: true = Dormand-Prince 5(4) with step-size control to rtol "
            "and atol; false = fixed-step RK4 in substeps of at most h_int",
            NULL, T, integ.adaptive),
    FMU_PARAM(vr_rtol, "rtol",
              "adaptive: relative tolerance of the local error test, in [1e-14, 1e-2]",
              NULL, T, integ.rtol),
    FMU_PARAM(vr_atol, "atol",
              "adaptive: absolute tolerance of the local error test (rad for q, rad/s for qd), "
              "in [1e-14, 1e-2]",
              NULL, T, integ.atol),
    FMU_TIME_ROW(vr_time),
};

_Static_assert(sizeof plant_vars / sizeof plant_vars[0] == vr_count,
               "one table row per value reference");

/* Model Exchange: x = (q, qd), dx/dt = (qd, qdd). Nominals: the arm moves within a few rad at up
 * to a few rad/s (writing task peaks: 1.2 rad/s), so 1 rad and 1 rad/s scale the solver's
 * absolute tolerance. */
static const fmu_continuous_state plant_states[] = {
    {vr_q + 0, vr_qd + 0, 1.0},  {vr_q + 1, vr_qd + 1, 1.0},  {vr_q + 2, vr_qd + 2, 1.0},
    {vr_qd + 0, vr_qdd + 0, 1.0}, {vr_qd + 1, vr_qdd + 1, 1.0}, {vr_qd + 2, vr_qdd + 2, 1.0},
};

static plant_data *data_of(fmu_instance *inst)
{
    return (plant_data *)inst->data;
}

static fmu_status set_defaults(void *d)
{
    plant_data *p = d;
    memset(p, 0, sizeof *p);
    if (rrr_model_default(&p->model) != RRR_OK) {
        return FMU_ERROR;
    }
    if (rrr_plant_integrator_default(&p->integ) != RRR_OK) {
        return FMU_ERROR;
    }
    p->integ.max_steps = PLANT_FMU_MAX_STEPS;
    return FMU_OK;
}

/* The parameters as ExitInitializationMode accepts them (the model, the integrator settings, a
 * stiffness the integrator can afford); logs the parameter at fault under fn. */
static fmu_status check_parameters(fmu_instance *inst, const plant_data *p, const char *fn)
{
    const char *field = "";
    rrr_status st = rrr_model_validate(&p->model, &field);
    if (st != RRR_OK) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: parameter %s is invalid (%s)%s", fn, field, rrr_status_str(st),
                st == RRR_NOT_POSITIVE_DEFINITE
                    ? ": p[1]..p[16] give an inertia matrix D(q) that is not positive definite"
                    : "");
        return FMU_ERROR;
    }
    if (rrr_plant_integrator_check(&p->integ, &field) != RRR_OK) {
        if (strcmp(field, "rtol") == 0 || strcmp(field, "atol") == 0) {
            fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                    "%s: parameter %s must be in [%g, %g], got %.17g", fn, field,
                    RRR_PLANT_TOL_MIN, RRR_PLANT_TOL_MAX,
                    field[0] == 'r' ? p->integ.rtol : p->integ.atol);
        } else {
            fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR, "%s: parameter h_int must be > 0, got %.17g",
                    fn, p->integ.h_int);
        }
        return FMU_ERROR;
    }
    double lambda = 0.0;
    st = rrr_plant_stiffness(&p->model, &lambda, &field);
    if (st != RRR_OK) {
        const int j = field[0] != '\0' ? field[2] - '1' : 0;
        const int k = field[0] == 'w' ? field[4] - '1' : -1;
        if (st == RRR_TOO_STIFF && k >= 0) {
            fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                    "%s: parameters f[%d,%d] = %.6g and w[%d,%d] = %.6g make the plant too stiff "
                    "for its integrator: its stiffness |d qdd/d qd| reaches %.3g 1/s (the "
                    "friction slope k_t |f| w over the inertia), more than the %.0e 1/s it "
                    "accepts (an integration would cost more than %.0e internal steps per "
                    "simulated second)",
                    fn, j + 1, k + 1, p->model.f[j][k], j + 1, k + 1, p->model.w[j][k], lambda,
                    RRR_PLANT_STIFFNESS_MAX, RRR_PLANT_STIFFNESS_MAX / 3.3);
        } else if (st == RRR_TOO_STIFF) {
            fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                    "%s: parameter b[%d] = %.6g makes the plant too stiff for its integrator: "
                    "its stiffness |d qdd/d qd| reaches %.3g 1/s, more than the %.0e 1/s it "
                    "accepts",
                    fn, j + 1, p->model.b[j], lambda, RRR_PLANT_STIFFNESS_MAX);
        } else {
            fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR, "%s: the stiffness of the plant: %s", fn,
                    rrr_status_str(st));
        }
        return FMU_ERROR;
    }
    return FMU_OK;
}

static fmu_status initialize(fmu_instance *inst)
{
    plant_data *p = data_of(inst);
    if (check_parameters(inst, p, FMU_FN(inst, "ExitInitializationMode")) != FMU_OK) {
        return FMU_ERROR;
    }
    /* the step-size history starts empty: the first doStep estimates a step */
    if (rrr_plant_state_init(p->q0, p->qd0, &p->x) != RRR_OK) {
        return FMU_ERROR; /* q0, qd0 are finite (the glue refuses others): not reached */
    }
    return FMU_OK;
}

/* An FMU state's data (the glue has checked every table row finite and adaptive 0 or 1): the
 * integrator's budget is the FMU's (never a variable), the step-size memory finite and >= 0, and
 * once initialized the parameters as ExitInitializationMode accepts them (skipped when they are
 * the ones this initialized instance holds: those were accepted). */
static fmu_status check_state(fmu_instance *inst, const void *data, fmu_state state,
                              const char *fn)
{
    const plant_data *p = data;
    if (p->integ.max_steps != PLANT_FMU_MAX_STEPS) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: the FMU state holds an integrator budget of %ld internal steps per doStep; "
                "this FMU's is %ld",
                fn, p->integ.max_steps, (long)PLANT_FMU_MAX_STEPS);
        return FMU_ERROR;
    }
    if (!isfinite(p->x.h_guess) || !(p->x.h_guess >= 0.0) || !isfinite(p->x.err_prev) ||
        !(p->x.err_prev >= 0.0)) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: the FMU state holds an invalid step-size memory (h_guess %.17g s, err_prev "
                "%.17g): both must be finite and >= 0",
                fn, p->x.h_guess, p->x.err_prev);
        return FMU_ERROR;
    }
    if (!fmu_state_initialized(state)) {
        return FMU_OK; /* the parameters are checked when initialization ends */
    }
    const plant_data *now = data_of(inst);
    if (fmu_state_initialized(inst->state) &&
        memcmp(&p->model, &now->model, sizeof p->model) == 0 &&
        memcmp(&p->integ, &now->integ, sizeof p->integ) == 0) {
        return FMU_OK;
    }
    return check_parameters(inst, p, fn);
}

/* qdd and tip from the state and the current input; before initialization the state is
 * (q0, qd0). */
static fmu_status calculate(fmu_instance *inst)
{
    plant_data *p = data_of(inst);
    if (inst->state == FMU_INSTANTIATED || inst->state == FMU_INIT_MODE) {
        memcpy(p->x.q, p->q0, sizeof p->x.q);
        memcpy(p->x.qd, p->qd0, sizeof p->x.qd);
    }
    double qdd[RRR_NJ];
    double tip[3];
    rrr_status st = rrr_plant_accel(&p->model, &p->x, p->u, qdd);
    if (st == RRR_OK) {
        st = rrr_fk(&p->model, p->x.q, tip, NULL);
    }
    if (st != RRR_OK) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: cannot compute qdd and tip at q = [%.17g, %.17g, %.17g], qd = [%.17g, "
                "%.17g, %.17g]: %s (check the parameters)",
                MODEL_IDENTIFIER, p->x.q[0], p->x.q[1], p->x.q[2], p->x.qd[0], p->x.qd[1],
                p->x.qd[2], rrr_status_str(st));
        return FMU_ERROR;
    }
    memcpy(p->qdd, qdd, sizeof qdd);
    memcpy(p->tip, tip, sizeof tip);
    return FMU_OK;
}

static fmu_status do_step(fmu_instance *inst, double h)
{
    plant_data *p = data_of(inst);
    rrr_plant_state x = p->x;
    double qdd[RRR_NJ];
    double tip[3];
    if (!p->integ.adaptive && h / p->integ.h_int > (double)p->integ.max_steps) {
        fmu_log(inst, FMU_DISCARD, FMU_LOG_DISCARD,
                "%s: a communication step of %.17g s needs %.3g substeps of h_int = "
                "%.17g s, more than the %.0e one step may take: use shorter communication "
                "steps or a larger h_int; the state stays at t = %.17g",
                FMU_FN(inst, "DoStep"), h, h / p->integ.h_int, p->integ.h_int,
                (double)p->integ.max_steps, inst->time);
        return FMU_DISCARD;
    }
    rrr_status st = rrr_plant_step(&p->model, &p->integ, p->u, h, &x, qdd, NULL);
    if (st == RRR_OK) {
        st = rrr_fk(&p->model, x.q, tip, NULL);
    }
    if (st == RRR_NUMERIC && p->integ.adaptive) {
        fmu_log(inst, FMU_DISCARD, FMU_LOG_DISCARD,
                "%s: rrr_plant_step from t = %.17g over h = %.17g failed: %s (no step size met "
                "rtol = %.3g and atol = %.3g within the %.0e internal steps one doStep may take, "
                "or the motion diverged); the state stays at t (q = [%.17g, %.17g, %.17g], "
                "qd = [%.17g, %.17g, %.17g])",
                FMU_FN(inst, "DoStep"), inst->time, h, rrr_status_str(st), p->integ.rtol,
                p->integ.atol, (double)p->integ.max_steps, p->x.q[0], p->x.q[1], p->x.q[2],
                p->x.qd[0], p->x.qd[1], p->x.qd[2]);
        return FMU_DISCARD;
    }
    if (st != RRR_OK) {
        fmu_log(inst, FMU_DISCARD, FMU_LOG_DISCARD,
                "%s: rrr_plant_step from t = %.17g over h = %.17g failed: %s; the state "
                "stays at t (q = [%.17g, %.17g, %.17g], qd = [%.17g, %.17g, %.17g])",
                FMU_FN(inst, "DoStep"), inst->time, h, rrr_status_str(st), p->x.q[0], p->x.q[1],
                p->x.q[2], p->x.qd[0], p->x.qd[1], p->x.qd[2]);
        return FMU_DISCARD;
    }
    p->x = x;
    memcpy(p->qdd, qdd, sizeof qdd);
    memcpy(p->tip, tip, sizeof tip);
    return FMU_OK;
}

/* Direct dependencies of the unknowns on the knowns (inputs u and continuous states q, qd):
 * q[i] and qd[i] are states (no feedthrough from u), each its own identity (constant); qdd =
 * D(q)^-1 (k_t (sat(u) - u_f(qd)) - c - h) couples every input and velocity into every
 * acceleration, and D, c and h depend on q2 and q3 only; the tip depends on q, tip.z on q2 and
 * q3 only (z = d1 + a2 s2 + a3 s23). Unsigned wrap-around: vr - first < n  <=>  first <= vr <
 * first + n. tests/python/fmu/test_fmu_derivatives.py checks every entry against the numbers. */
static int depends(fmu_vr unknown, fmu_vr known)
{
    const int is_u = known - vr_u < RRR_NJ;
    const int is_q = known - vr_q < RRR_NJ;
    const int is_qd = known - vr_qd < RRR_NJ;
    if (unknown - vr_q < RRR_NJ || unknown - vr_qd < RRR_NJ) {
        return known == unknown ? FMU_DEP_CONSTANT : FMU_DEP_NONE;
    }
    if (unknown - vr_qdd < RRR_NJ) {
        return is_u || is_qd || (is_q && known != vr_q) ? FMU_DEP_DEPENDENT : FMU_DEP_NONE;
    }
    if (unknown - vr_tip < 3) {
        const int q1 = known == vr_q;
        return is_q && !(unknown == vr_tip + 2 && q1) ? FMU_DEP_DEPENDENT : FMU_DEP_NONE;
    }
    return FMU_DEP_NONE;
}

/* In Initialization Mode (knowns: u and the parameters): the state starts at q0, qd0; qdd uses
 * the dynamics' parameters (a2, g, p, k_t, friction, u_max; not d1, a3, d2, d3, which only the
 * kinematics uses) and the tip the kinematic ones (tip.x and tip.y: a2, a3, d2, d3 and q0;
 * tip.z: d1, a2, a3, q0[2], q0[3]). The integrator settings act only inside doStep. */
static int depends_initial(fmu_vr unknown, fmu_vr known)
{
    const size_t off = rrr_mv_offset(known, vr_model);
    if (unknown - vr_q < RRR_NJ) {
        return known == vr_q0 + (unknown - vr_q) ? FMU_DEP_CONSTANT : FMU_DEP_NONE;
    }
    if (unknown - vr_qd < RRR_NJ) {
        return known == vr_qd0 + (unknown - vr_qd) ? FMU_DEP_CONSTANT : FMU_DEP_NONE;
    }
    if (unknown - vr_qdd < RRR_NJ) {
        const int dyn = RRR_MV_IN(off, a2) || RRR_MV_IN(off, g) || RRR_MV_IN(off, p) ||
                        RRR_MV_IN(off, kt) || RRR_MV_IN(off, f) || RRR_MV_IN(off, w) ||
                        RRR_MV_IN(off, b) || RRR_MV_IN(off, u_max);
        const int state = (known - vr_q0 < RRR_NJ && known != vr_q0) || known - vr_qd0 < RRR_NJ;
        return dyn || state || known - vr_u < RRR_NJ ? FMU_DEP_DEPENDENT : FMU_DEP_NONE;
    }
    if (unknown - vr_tip < 3) {
        const int z = unknown == vr_tip + 2;
        const int kin = RRR_MV_IN(off, a2) || RRR_MV_IN(off, a3) ||
                        (z ? RRR_MV_IN(off, d1) : RRR_MV_IN(off, d2) || RRR_MV_IN(off, d3));
        const int q = known - vr_q0 < RRR_NJ && !(z && known == vr_q0);
        return kin || q ? FMU_DEP_DEPENDENT : FMU_DEP_NONE;
    }
    return FMU_DEP_NONE;
}

/* In Initialization Mode the parameters are knowns too: the state is (q0, qd0), so the
 * derivatives by q0 and qd0 are those by q and qd; by the model parameters
 * rrr_plant_param_jacobian and rrr_fk_param_jacobian; the integrator settings act only inside
 * doStep (0). */
static fmu_status parameter_partials(fmu_instance *inst, const rrr_plant_state *x,
                                     const rrr_plant_derivatives *d, double J[3][3],
                                     fmu_partials *P)
{
    const plant_data *p = data_of(inst);
    double dqdd[3][RRR_N_PARAMS], dtip[3][RRR_N_PARAMS];
    rrr_status st = rrr_plant_param_jacobian(&p->model, x, p->u, dqdd);
    if (st == RRR_OK) {
        st = rrr_fk_param_jacobian(&p->model, x->q, dtip);
    }
    if (st != RRR_OK) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: cannot compute the derivatives by the parameters: %s", MODEL_IDENTIFIER,
                rrr_status_str(st));
        return FMU_ERROR;
    }
    for (fmu_vr i = 0; i < RRR_NJ; ++i) {
        fmu_partial_set(P, vr_q + i, vr_q0 + i, 1.0);
        fmu_partial_set(P, vr_qd + i, vr_qd0 + i, 1.0);
        for (fmu_vr j = 0; j < RRR_NJ; ++j) {
            fmu_partial_set(P, vr_qdd + i, vr_q0 + j, d->dqdd_dq[i][j]);
            fmu_partial_set(P, vr_qdd + i, vr_qd0 + j, d->dqdd_dqd[i][j]);
            fmu_partial_set(P, vr_tip + i, vr_q0 + j, J[i][j]);
        }
        for (fmu_vr c = 0; c < RRR_MV_COUNT; ++c) {
            fmu_partial_set(P, vr_qdd + i, vr_model + c, dqdd[i][c]);
            fmu_partial_set(P, vr_tip + i, vr_model + c, dtip[i][c]);
        }
    }
    return FMU_OK;
}

/* The exact partial derivatives of the unknowns with respect to u, q and qd: rrr_plant_jacobian
 * (qdd) and rrr_jacobian (tip), at the state the outputs are computed from. */
static fmu_status partials(fmu_instance *inst, fmu_partials *P)
{
    const plant_data *p = data_of(inst);
    rrr_plant_state x = p->x;
    if (inst->state == FMU_INSTANTIATED || inst->state == FMU_INIT_MODE) {
        memcpy(x.q, p->q0, sizeof x.q);
        memcpy(x.qd, p->qd0, sizeof x.qd);
    }
    rrr_plant_derivatives d;
    double J[3][3];
    rrr_status st = rrr_plant_jacobian(&p->model, &x, p->u, &d);
    if (st == RRR_OK) {
        st = rrr_jacobian(&p->model, x.q, J);
    }
    if (st != RRR_OK) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: cannot compute the partial derivatives at q = [%.17g, %.17g, %.17g], qd = "
                "[%.17g, %.17g, %.17g]: %s (check the parameters)",
                MODEL_IDENTIFIER, x.q[0], x.q[1], x.q[2], x.qd[0], x.qd[1], x.qd[2],
                rrr_status_str(st));
        return FMU_ERROR;
    }
    for (fmu_vr i = 0; i < RRR_NJ; ++i) {
        fmu_partial_set(P, vr_q + i, vr_q + i, 1.0);
        fmu_partial_set(P, vr_qd + i, vr_qd + i, 1.0);
        for (fmu_vr j = 0; j < RRR_NJ; ++j) {
            fmu_partial_set(P, vr_qdd + i, vr_u + j, d.dqdd_du[i][j]);
            fmu_partial_set(P, vr_qdd + i, vr_q + j, d.dqdd_dq[i][j]);
            fmu_partial_set(P, vr_qdd + i, vr_qd + j, d.dqdd_dqd[i][j]);
            fmu_partial_set(P, vr_tip + i, vr_q + j, J[i][j]);
        }
    }
    return P->parameters ? parameter_partials(inst, &x, &d, J, P) : FMU_OK;
}

const fmu_model FMU_MODEL = {
    .identifier = MODEL_IDENTIFIER,
    .description = "RRR robot arm plant: motor voltages in, joint motion and tip position out "
                   "(closed-form dynamics of librrr; Dormand-Prince 5(4) with error control or "
                   "fixed-step RK4 inside doStep, or continuous states for a solver)",
    .vars = plant_vars,
    .n_vars = sizeof plant_vars / sizeof plant_vars[0],
    .states = plant_states,
    .n_states = sizeof plant_states / sizeof plant_states[0],
    .data_size = sizeof(plant_data),
    .default_stop_time = 1.0,
    .default_step_size = RRR_SAMPLE_TIME_DEFAULT,
    .default_tolerance = 1e-8,
    .set_defaults = set_defaults,
    .initialize = initialize,
    .calculate = calculate,
    .do_step = do_step,
    .depends = depends,
    .depends_initial = depends_initial,
    .partials = partials,
    .check_state = check_state,
};
