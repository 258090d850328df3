/* The closed loop in C, in the co-simulation master's order (rrr_sim.h). */
#include "rrr_internal.h"

/* The plant outputs the FMU would report: q, qd, qdd, tip. */
static void put_plant(double row[RRR_SIM_PLANT_COLS], const rrr_plant_state *x,
                      const double qdd[3], const double tip[3])
{
    memcpy(row, x->q, 3 * sizeof(double));
    memcpy(row + 3, x->qd, 3 * sizeof(double));
    memcpy(row + 6, qdd, 3 * sizeof(double));
    memcpy(row + 9, tip, 3 * sizeof(double));
}

/* The setup of the FMUs' initialization: the models validated (the plant's stiffness too, as the
 * plant FMU checks it), the plant at (q0, qd0) with its first outputs under u = 0. */
static rrr_status setup(const rrr_model *plant, const rrr_model *ctrl, const double q0[3],
                        const double qd0[3], rrr_sim_carry *c)
{
    rrr_status st = rrr_model_validate(plant, NULL);
    if (st == RRR_OK) {
        st = rrr_model_validate(ctrl, NULL);
    }
    if (st == RRR_OK) {
        st = rrr_plant_stiffness(plant, NULL, NULL);
    }
    if (st == RRR_OK) {
        st = rrr_plant_state_init(q0, qd0, &c->x);
    }
    const double u0[3] = {0.0, 0.0, 0.0};
    if (st == RRR_OK) {
        st = rrr_plant_accel(plant, &c->x, u0, c->qdd);
    }
    if (st == RRR_OK) {
        st = rrr_fk(plant, c->x.q, c->tip, NULL);
    }
    return st;
}

rrr_status rrr_sim_closed_loop_part(const rrr_model *plant, const rrr_plant_integrator *integ,
                                    const double q0[3], const double qd0[3],
                                    const rrr_model *ctrl, const rrr_ctc_gains *gains, size_t n,
                                    double step, const double ref[], double plant_out[],
                                    double ctrl_out[], size_t count, rrr_sim_carry *carry,
                                    size_t *done)
{
    if (done != NULL) {
        *done = carry != NULL && carry->next <= n ? carry->next : 0;
    }
    if (plant == NULL || integ == NULL || q0 == NULL || qd0 == NULL || ctrl == NULL ||
        gains == NULL || ref == NULL || plant_out == NULL || ctrl_out == NULL || n == 0 ||
        count == 0 || carry == NULL || carry->next > n || !isfinite(step) || !(step > 0.0) ||
        rrr_plant_integrator_check(integ, NULL) != RRR_OK) {
        return RRR_BAD_INPUT;
    }
    rrr_status st = RRR_OK;
    if (carry->next == 0) {
        rrr_sim_carry c;
        memset(&c, 0, sizeof c);
        st = setup(plant, ctrl, q0, qd0, &c);
        if (st != RRR_OK) {
            return st;
        }
        *carry = c;
    }
    rrr_plant_state x = carry->x;
    double qdd[3], tip[3];
    memcpy(qdd, carry->qdd, sizeof qdd);
    memcpy(tip, carry->tip, sizeof tip);
    /* rrr_plant_accel in its two halves: the state's half is reused by the next step (and each
     * step leaves its end state's for the next one), the same numbers as computing it again,
     * which a part does for its first sample */
    rrr_plant_prep prep;
    rrr_plant_prepare(plant, rrr_actuator_params_ok(plant), x.q, x.qd, &prep);
    const size_t end = count < n - carry->next ? carry->next + count : n;
    for (size_t k = carry->next; k < end; ++k) {
        const double *r = ref + k * RRR_SIM_REF_COLS;
        double *c = ctrl_out + k * RRR_SIM_CTRL_COLS;
        put_plant(plant_out + k * RRR_SIM_PLANT_COLS, &x, qdd, tip);
        rrr_ctc_output out;
        st = rrr_ctc(ctrl, gains, r, r + 3, r + 6, x.q, x.qd, &out);
        if (st != RRR_OK) {
            break;
        }
        memcpy(c, out.u, 3 * sizeof(double));
        memcpy(c + 3, out.u_n, 3 * sizeof(double));
        memcpy(c + 6, out.u_c, 3 * sizeof(double));
        if (k == 0) {
            /* row 0's qdd under row 0's input, as the master reads it from the plant FMU after
             * setting that input (the plant's first outputs had it under u = 0) */
            double qdd0[3];
            st = rrr_plant_accel_prepared(plant, &prep, out.u, qdd0);
            if (st != RRR_OK) {
                break;
            }
            memcpy(plant_out + 6, qdd0, sizeof qdd0);
        }
        if (k + 1 < n) {
            /* the plant FMU's doStep: the state and its outputs change only on success */
            rrr_plant_state next = x;
            double qdd_next[3], tip_next[3];
            st = rrr_plant_step_prepared(plant, integ, out.u, step, &next, qdd_next, NULL, &prep);
            if (st == RRR_OK) {
                st = rrr_fk(plant, next.q, tip_next, NULL);
            }
            if (st != RRR_OK) {
                carry->next = k + 1; /* row k is complete; the run cannot go on */
                break;
            }
            x = next;
            memcpy(qdd, qdd_next, sizeof qdd);
            memcpy(tip, tip_next, sizeof tip);
        }
        carry->next = k + 1;
        carry->x = x;
        memcpy(carry->qdd, qdd, sizeof qdd);
        memcpy(carry->tip, tip, sizeof tip);
    }
    if (done != NULL) {
        *done = carry->next;
    }
    return st;
}

rrr_status rrr_sim_closed_loop(const rrr_model *plant, const rrr_plant_integrator *integ,
                               const double q0[3], const double qd0[3], const rrr_model *ctrl,
                               const rrr_ctc_gains *gains, size_t n, double step,
                               const double ref[], double plant_out[], double ctrl_out[],
                               size_t *done)
{
    rrr_sim_carry carry;
    memset(&carry, 0, sizeof carry);
    return rrr_sim_closed_loop_part(plant, integ, q0, qd0, ctrl, gains, n, step, ref, plant_out,
                                    ctrl_out, n == 0 ? 1 : n, &carry, done);
}
