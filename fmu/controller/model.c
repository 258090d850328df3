/*
 * The computed-torque controller FMU: its variable table and the call into librrr (rrr_ctc,
 * eq 15). No control law here.
 */
#include "config.h"

#include <string.h>

#define T controller_data
#define RRR_MV_BASE vr_model

#define JOINT_INPUTS(VR, N, WHAT, UNIT, M)                                                     \
    FMU_ROW((VR) + 0, FMU_REAL, FMU_INPUT, FMU_CONTINUOUS, N "[1]", WHAT " of joint 1", UNIT, T, \
            M[0]),                                                                             \
    FMU_ROW((VR) + 1, FMU_REAL, FMU_INPUT, FMU_CONTINUOUS, N "[2]", WHAT " of joint 2", UNIT, T, \
            M[1]),                                                                             \
    FMU_ROW((VR) + 2, FMU_REAL, FMU_INPUT, FMU_CONTINUOUS, N "[3]", WHAT " of joint 3", UNIT, T, \
            M[2])
#define JOINT_OUTPUTS(VR, N, WHAT, M)                                                          \
    FMU_ROW((VR) + 0, FMU_REAL, FMU_OUTPUT, FMU_CONTINUOUS, N "[1]", WHAT " of joint 1", "V",  \
            T, M[0]),                                                                          \
    FMU_ROW((VR) + 1, FMU_REAL, FMU_OUTPUT, FMU_CONTINUOUS, N "[2]", WHAT " of joint 2", "V",  \
            T, M[1]),                                                                          \
    FMU_ROW((VR) + 2, FMU_REAL, FMU_OUTPUT, FMU_CONTINUOUS, N "[3]", WHAT " of joint 3", "V",  \
            T, M[2])
#define JOINT_PARAMS(VR, N, WHAT, UNIT, M)                                                     \
    FMU_PARAM((VR) + 0, N "[1]", WHAT " of joint 1", UNIT, T, M[0]),                           \
    FMU_PARAM((VR) + 1, N "[2]", WHAT " of joint 2", UNIT, T, M[1]),                           \
    FMU_PARAM((VR) + 2, N "[3]", WHAT " of joint 3", UNIT, T, M[2])

static const fmu_variable controller_vars[] = {
    JOINT_INPUTS(vr_q_ref, "q_ref", "reference position", "rad", q_ref),
    JOINT_INPUTS(vr_qd_ref, "qd_ref", "reference velocity", "rad/s", qd_ref),
    JOINT_INPUTS(vr_qdd_ref, "qdd_ref", "reference acceleration", "rad/s2", qdd_ref),
    JOINT_INPUTS(vr_q, "q", "measured position", "rad", q),
    JOINT_INPUTS(vr_qd, "qd", "measured velocity", "rad/s", qd),
    JOINT_OUTPUTS(vr_u, "u", "applied voltage sat(u_n + u_c)", out.u),
    JOINT_OUTPUTS(vr_u_n, "u_n",
                  "feedforward voltage (eq 10 along the reference; 0 if feedforward is off)",
                  out.u_n),
    JOINT_OUTPUTS(vr_u_c, "u_c", "PD voltage kp (q_ref - q) + kd (qd_ref - qd), q and qd predicted by lead",
                  out.u_c),
    JOINT_PARAMS(vr_kp, "kp", "proportional gain", "V/rad", gains.kp),
    JOINT_PARAMS(vr_kd, "kd", "derivative gain", "V.s/rad", gains.kd),
    FMU_ROW(vr_feedforward, FMU_BOOLEAN, FMU_PARAMETER, FMU_FIXED, "feedforward",
            "add the model feedforward u_n (computed-torque); false: PD only", NULL, T,
            gains.feedforward),
    RRR_MODEL_VARS
    JOINT_INPUTS(vr_qdd, "qdd", "measured acceleration (used when lead > 0)", "rad/s2", qdd),
    FMU_PARAM(vr_lead, "lead",
              "predictor: the law acts on q + lead qd + lead^2/2 qdd and qd + lead qdd, in [0, "
              "1]; one communication step compensates a master that passes the plant's "
              "outputs on one step late; 0: q and qd as measured",
              "s", T, lead),
    FMU_TIME_ROW(vr_time),
};

_Static_assert(sizeof controller_vars / sizeof controller_vars[0] == vr_count,
               "one table row per value reference");

static controller_data *data_of(fmu_instance *inst)
{
    return (controller_data *)inst->data;
}

static fmu_status set_defaults(void *d)
{
    controller_data *c = d;
    memset(c, 0, sizeof *c);
    if (rrr_model_default(&c->model) != RRR_OK || rrr_ctc_gains_default(&c->gains) != RRR_OK) {
        return FMU_ERROR;
    }
    return FMU_OK;
}

/* Names the first negative gain (rrr_ctc only says RRR_BAD_INPUT). */
static fmu_status check_gains_of(fmu_instance *inst, const controller_data *c, const char *fn)
{
    for (int i = 0; i < RRR_NJ; ++i) {
        if (!(c->gains.kp[i] >= 0.0) || !(c->gains.kd[i] >= 0.0)) {
            const int bad_kp = !(c->gains.kp[i] >= 0.0);
            fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR, "%s: parameter %s[%d] must be >= 0, got %.17g",
                    fn, bad_kp ? "kp" : "kd", i + 1, bad_kp ? c->gains.kp[i] : c->gains.kd[i]);
            return FMU_ERROR;
        }
    }
    return FMU_OK;
}

static fmu_status check_gains(fmu_instance *inst, const char *fn)
{
    return check_gains_of(inst, data_of(inst), fn);
}

/* The parameters as ExitInitializationMode accepts them; logs the one at fault under fn. */
static fmu_status check_parameters(fmu_instance *inst, const controller_data *c, const char *fn)
{
    const char *field = "";
    const rrr_status st = rrr_model_validate(&c->model, &field);
    if (st != RRR_OK) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: parameter %s is invalid (%s)%s", fn, field, rrr_status_str(st),
                st == RRR_NOT_POSITIVE_DEFINITE
                    ? ": p[1]..p[16] give an inertia matrix D(q) that is not positive definite"
                    : "");
        return FMU_ERROR;
    }
    if (!(c->lead >= 0.0 && c->lead <= 1.0)) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR, "%s: parameter lead must be in [0, 1] s, got %.17g",
                fn, c->lead);
        return FMU_ERROR;
    }
    return check_gains_of(inst, c, fn);
}

static fmu_status initialize(fmu_instance *inst)
{
    return check_parameters(inst, data_of(inst), FMU_FN(inst, "ExitInitializationMode"));
}

/* An FMU state's data (the glue has checked every table row finite and feedforward 0 or 1):
 * the saturation bits name joints 1..3 only, and once initialized the parameters are as
 * ExitInitializationMode accepts them (skipped when they are the ones this initialized instance
 * holds: those were accepted). */
static fmu_status check_state(fmu_instance *inst, const void *data, fmu_state state,
                              const char *fn)
{
    const controller_data *c = data;
    if (c->out.saturated > 7u) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: the FMU state holds saturation bits 0x%x: only joints 1..3 (0x7) exist", fn,
                c->out.saturated);
        return FMU_ERROR;
    }
    if (!fmu_state_initialized(state)) {
        return FMU_OK; /* the parameters are checked when initialization ends */
    }
    const controller_data *now = data_of(inst);
    if (fmu_state_initialized(inst->state) &&
        memcmp(&c->model, &now->model, sizeof c->model) == 0 &&
        memcmp(&c->gains, &now->gains, sizeof c->gains) == 0 && c->lead == now->lead) {
        return FMU_OK;
    }
    return check_parameters(inst, c, fn);
}

static fmu_status calculate(fmu_instance *inst)
{
    controller_data *c = data_of(inst);
    if (check_gains(inst, MODEL_IDENTIFIER) != FMU_OK) {
        return FMU_ERROR;
    }
    rrr_ctc_output out;
    double q[RRR_NJ];
    double qd[RRR_NJ];
    rrr_status st = rrr_predict_state(c->q, c->qd, c->qdd, c->lead, q, qd);
    if (st == RRR_OK) {
        st = rrr_ctc(&c->model, &c->gains, c->q_ref, c->qd_ref, c->qdd_ref, q, qd, &out);
    }
    if (st != RRR_OK) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: rrr_ctc failed at t = %.17g: %s (q_ref = [%.17g, %.17g, %.17g], q = [%.17g, "
                "%.17g, %.17g])",
                MODEL_IDENTIFIER, inst->time, rrr_status_str(st), c->q_ref[0], c->q_ref[1],
                c->q_ref[2], c->q[0], c->q[1], c->q[2]);
        return FMU_ERROR;
    }
    c->out = out;
    return FMU_OK;
}

/* Stateless (no continuous states in Model Exchange either): a step only has to leave the
 * outputs consistent with the inputs. */
static fmu_status do_step(fmu_instance *inst, double h)
{
    (void)h;
    return inst->dirty ? calculate(inst) : FMU_OK;
}

/* u_n = k_t^-1 R(q_ref, qd_ref, qdd_ref) p + u_f(qd_ref): every joint of qd_ref and qdd_ref
 * and q_ref[2], q_ref[3] (the dynamics do not depend on q1); u_c(i) = kp_i (q_ref_i - q_p,i) +
 * kd_i (qd_ref_i - qd_p,i) with the predicted q_p = q + lead qd + lead^2/2 qdd, qd_p = qd +
 * lead qdd: linear in joint i's q_ref, qd_ref, q, qd and qdd with factors of the fixed
 * parameters kp, kd and lead ("fixed"; the qdd factor is 0 when lead = 0); u = sat(u_n + u_c) on
 * both sets. Unsigned wrap-around: vr - first < n  <=>  first <= vr < first + n.
 * tests/python/fmu/test_fmu_derivatives.py checks every entry against the numbers. */
_Static_assert(vr_q_ref % RRR_NJ == 0 && vr_q % RRR_NJ == 0 && vr_qdd % RRR_NJ == 0 &&
                   vr_u % RRR_NJ == 0 && vr_u_n % RRR_NJ == 0 && vr_u_c % RRR_NJ == 0,
               "joint i of every vector at a value reference = i - 1 (mod 3)");

/* 1 when u_n depends on input in_vr */
static int feedforward_input(fmu_vr in_vr)
{
    return (in_vr - vr_q_ref < RRR_NJ && in_vr != vr_q_ref) || in_vr - vr_qd_ref < 2 * RRR_NJ;
}

/* 1 when u_c of the joint of out_vr depends on input in_vr */
static int pd_input(fmu_vr out_vr, fmu_vr in_vr)
{
    const int same_joint = in_vr % RRR_NJ == out_vr % RRR_NJ;
    return same_joint && (in_vr - vr_q_ref < 2 * RRR_NJ || in_vr - vr_q < 2 * RRR_NJ ||
                          in_vr - vr_qdd < RRR_NJ);
}

static int depends(fmu_vr out_vr, fmu_vr in_vr)
{
    const int ff = feedforward_input(in_vr);
    const int pd = pd_input(out_vr, in_vr);
    if (out_vr - vr_u_n < RRR_NJ) {
        return ff ? FMU_DEP_DEPENDENT : FMU_DEP_NONE;
    }
    if (out_vr - vr_u_c < RRR_NJ) {
        return pd ? FMU_DEP_FIXED : FMU_DEP_NONE;
    }
    return ff || pd ? FMU_DEP_DEPENDENT : FMU_DEP_NONE; /* u */
}

/* In Initialization Mode the parameters are knowns too: u_n(i) uses feedforward, a2, the base
 * parameters and gravity that enter tau_i (rrr_regressor_structure: g and p12..p16 do not act
 * on joint 1, for one), kt_i and joint i's friction; u_c(i) kp_i, kd_i and lead; u both and
 * u_max. */
static int depends_initial(fmu_vr out_vr, fmu_vr in_vr)
{
    const int joint = (int)(out_vr % RRR_NJ);
    const size_t off = rrr_mv_offset(in_vr, vr_model);
    unsigned p_cols[3] = {0u, 0u, 0u}, g_rows = 0u;
    (void)rrr_regressor_structure(p_cols, &g_rows);
    const int p_used = RRR_MV_IN(off, p) &&
                       ((p_cols[joint] >> ((off - offsetof(rrr_model, p)) / sizeof(double))) & 1u);
    const int g_used = RRR_MV_IN(off, g) && ((g_rows >> joint) & 1u);
    const int ff = feedforward_input(in_vr) || in_vr == vr_feedforward ||
                   RRR_MV_IN(off, a2) || g_used || p_used ||
                   (RRR_MV_IN(off, kt) && RRR_MV_JOINT(off, kt) == joint) ||
                   (RRR_MV_IN(off, f) && RRR_MV_JOINT(off, f) == joint) ||
                   (RRR_MV_IN(off, w) && RRR_MV_JOINT(off, w) == joint) ||
                   (RRR_MV_IN(off, b) && RRR_MV_JOINT(off, b) == joint);
    const int pd = pd_input(out_vr, in_vr) || in_vr == vr_kp + (fmu_vr)joint ||
                   in_vr == vr_kd + (fmu_vr)joint || in_vr == vr_lead;
    if (out_vr - vr_u_n < RRR_NJ) {
        return ff ? FMU_DEP_DEPENDENT : FMU_DEP_NONE;
    }
    if (out_vr - vr_u_c < RRR_NJ) {
        return pd ? FMU_DEP_DEPENDENT : FMU_DEP_NONE;
    }
    return ff || pd || RRR_MV_IN(off, u_max) ? FMU_DEP_DEPENDENT : FMU_DEP_NONE; /* u */
}

/* In Initialization Mode the parameters are knowns too: the model (rrr_ctc_param_jacobian: the
 * feedforward and u_max), kp and kd, and lead through the predictor (d q_p / d lead = qd +
 * lead qdd, d qd_p / d lead = qdd). */
static fmu_status parameter_partials(fmu_instance *inst, const double q[3], const double qd[3],
                                     const rrr_ctc_derivatives *d, fmu_partials *P)
{
    const controller_data *c = data_of(inst);
    rrr_ctc_param_derivatives pd;
    const rrr_status st = rrr_ctc_param_jacobian(&c->model, &c->gains, c->q_ref, c->qd_ref,
                                                 c->qdd_ref, q, qd, &pd);
    if (st != RRR_OK) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: rrr_ctc_param_jacobian failed at t = %.17g: %s", MODEL_IDENTIFIER,
                inst->time, rrr_status_str(st));
        return FMU_ERROR;
    }
    const double l = c->lead;
    for (fmu_vr i = 0; i < RRR_NJ; ++i) {
        for (fmu_vr m = 0; m < RRR_MV_COUNT; ++m) {
            fmu_partial_set(P, vr_u + i, vr_model + m, pd.du[i][m]);
            fmu_partial_set(P, vr_u_n + i, vr_model + m, pd.du_n[i][m]);
        }
        fmu_partial_set(P, vr_u + i, vr_kp + i, pd.du_dkp[i]);
        fmu_partial_set(P, vr_u + i, vr_kd + i, pd.du_dkd[i]);
        fmu_partial_set(P, vr_u_c + i, vr_kp + i, pd.du_c_dkp[i]);
        fmu_partial_set(P, vr_u_c + i, vr_kd + i, pd.du_c_dkd[i]);
        double du = 0.0, du_c = 0.0;
        for (int j = 0; j < RRR_NJ; ++j) {
            const double dq = c->qd[j] + l * c->qdd[j], dqd = c->qdd[j];
            du += d->du[RRR_CTC_Q][i][j] * dq + d->du[RRR_CTC_QD][i][j] * dqd;
            du_c += d->du_c[RRR_CTC_Q][i][j] * dq + d->du_c[RRR_CTC_QD][i][j] * dqd;
        }
        fmu_partial_set(P, vr_u + i, vr_lead, du);
        fmu_partial_set(P, vr_u_c + i, vr_lead, du_c);
    }
    return FMU_OK;
}

/* The exact partial derivatives of u, u_n and u_c with respect to every input: rrr_ctc_jacobian
 * at the predicted state, chained through the predictor (rrr_ctc_jacobian's note). */
static fmu_status partials(fmu_instance *inst, fmu_partials *P)
{
    const controller_data *c = data_of(inst);
    double q[RRR_NJ];
    double qd[RRR_NJ];
    rrr_ctc_derivatives d;
    rrr_status st = rrr_predict_state(c->q, c->qd, c->qdd, c->lead, q, qd);
    if (st == RRR_OK) {
        st = rrr_ctc_jacobian(&c->model, &c->gains, c->q_ref, c->qd_ref, c->qdd_ref, q, qd, &d);
    }
    if (st != RRR_OK) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: rrr_ctc_jacobian failed at t = %.17g: %s", MODEL_IDENTIFIER, inst->time,
                rrr_status_str(st));
        return FMU_ERROR;
    }
    const double l = c->lead;
    const fmu_vr first[RRR_CTC_INPUT_COUNT] = {vr_q_ref, vr_qd_ref, vr_qdd_ref, vr_q, vr_qd};
    const fmu_vr out_first[3] = {vr_u, vr_u_n, vr_u_c};
    for (int o = 0; o < 3; ++o) {
        double(*const dv)[3][3] = o == 0 ? d.du : o == 1 ? d.du_n : d.du_c;
        for (fmu_vr i = 0; i < RRR_NJ; ++i) {
            for (fmu_vr j = 0; j < RRR_NJ; ++j) {
                const fmu_vr out = out_first[o] + i;
                for (int k = 0; k < RRR_CTC_INPUT_COUNT; ++k) {
                    double v = dv[k][i][j];
                    if (k == RRR_CTC_QD) { /* qd_p = qd + l qdd, q_p = q + l qd + ... */
                        v += l * dv[RRR_CTC_Q][i][j];
                    }
                    fmu_partial_set(P, out, first[k] + j, v);
                }
                fmu_partial_set(P, out, vr_qdd + j,
                                0.5 * l * l * dv[RRR_CTC_Q][i][j] + l * dv[RRR_CTC_QD][i][j]);
            }
        }
    }
    return P->parameters ? parameter_partials(inst, q, qd, &d, P) : FMU_OK;
}

const fmu_model FMU_MODEL = {
    .identifier = MODEL_IDENTIFIER,
    .description = "Computed-torque controller of the RRR arm (eq 15): model feedforward plus PD, "
                   "saturated; direct feedthrough",
    .vars = controller_vars,
    .n_vars = sizeof controller_vars / sizeof controller_vars[0],
    .data_size = sizeof(controller_data),
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
