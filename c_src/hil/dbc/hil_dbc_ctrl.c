/* The DBC controller's frame logic without I/O (hil_dbc_ctrl.h). */
#include "hil_dbc_ctrl.h"

#include <string.h>

void rrr_hil_dbc_ctrl_init(rrr_hil_dbc_ctrl *d, int lockstep)
{
    memset(d, 0, sizeof *d);
    d->lockstep = lockstep;
}

/* Lockstep: the plant sends each JointState once per period, so one of a joint already received
 * for the state being assembled, or one of the state just completed, is a repeat (replayed or
 * forged): -1 with d->tampered set; 0 otherwise. */
static int repeat(rrr_hil_dbc_ctrl *d, const rrr_hil_joint_state *js, uint32_t period)
{
    const int again = (js->counter == d->pending && d->have[js->joint]) ||
                      (d->done_valid && js->counter == d->done);
    if (!d->lockstep || !again) {
        return 0;
    }
    ++d->repeated;
    (void)snprintf(d->tampered, sizeof d->tampered,
                   "joint %u: two JointState%u with alive counter %u in period %u",
                   (unsigned)js->joint + 1u, (unsigned)js->joint + 1u, (unsigned)js->counter,
                   (unsigned)period);
    return -1;
}

int rrr_hil_dbc_ctrl_rx(rrr_hil_dbc_ctrl *d, const rrr_hil_frame *f, uint32_t period)
{
    rrr_hil_msg m;
    const rrr_hil_rx rx = rrr_hil_decode(f, &m);
    ++d->rx_bad[rx];
    if (rx != RRR_HIL_RX_OK) {
        return 0;
    }
    if (m.kind == RRR_HIL_PLANT_STATUS) {
        d->status = m.u.status;
        if (m.u.status.faults != 0u) {
            ++d->status_faulty;
        }
        if (m.u.status.zero_voltage != 0u) {
            ++d->status_zero;
        }
        return 0;
    }
    if (m.kind != RRR_HIL_JOINT_STATE) {
        return 0;
    }
    const rrr_hil_joint_state *js = &m.u.joint;
    if (repeat(d, js, period) != 0) {
        return -1;
    }
    if (js->counter != d->pending || (d->have[0] | d->have[1] | d->have[2]) == 0u) {
        if (d->have[0] | d->have[1] | d->have[2]) {
            ++d->out_of_order; /* an incomplete state was overtaken */
        }
        memset(d->have, 0, sizeof d->have);
        d->pending = js->counter;
    }
    d->have[js->joint] = 1;
    d->pq[js->joint] = js->q_rad;
    d->pqd[js->joint] = js->qd_rad_s;
    if (d->have[0] && d->have[1] && d->have[2]) {
        memcpy(d->q, d->pq, sizeof d->q);
        memcpy(d->qd, d->pqd, sizeof d->qd);
        memset(d->have, 0, sizeof d->have);
        d->done = d->pending;
        d->done_valid = 1u;
        ++d->states;
        return 1;
    }
    return 0;
}

int rrr_hil_dbc_ctrl_heartbeat(rrr_hil_dbc_ctrl *d, uint8_t nmt, rrr_hil_frame *f)
{
    const rrr_hil_heartbeat hb = {1u, nmt, d->hb_counter++};
    return rrr_hil_encode_heartbeat(&hb, f);
}

rrr_hil_voltage_cmd rrr_hil_dbc_ctrl_command(uint32_t k, int enable, const double u_V[3])
{
    rrr_hil_voltage_cmd cmd;
    cmd.counter = (uint8_t)(k & 15u);
    cmd.enable = (uint8_t)(enable != 0);
    cmd.reset_fault = 0;
    memcpy(cmd.u_V, u_V, sizeof cmd.u_V);
    return cmd;
}

void rrr_hil_dbc_ctrl_sent(rrr_hil_dbc_ctrl *d, const rrr_hil_voltage_cmd *cmd)
{
    d->last_cmd_counter = cmd->counter;
    ++d->cmds_sent;
}

rrr_hil_stop_cmd rrr_hil_dbc_ctrl_stop(const rrr_hil_dbc_ctrl *d, rrr_hil_stop_reason reason)
{
    const rrr_hil_stop_cmd stop = {
        (uint8_t)(d->cmds_sent > 0u ? (d->last_cmd_counter + 1u) & 15u : 0u), (uint8_t)reason};
    return stop;
}

void rrr_hil_dbc_ctrl_json(FILE *out, const rrr_hil_dbc_ctrl *d)
{
    fprintf(out,
            "\"states\": %u, \"rx_bad_crc\": %u, \"rx_bad_dlc\": %u, \"rx_unknown_id\": %u, "
            "\"out_of_order\": %u, \"plant_faults\": %u, \"plant_status_faulty\": %u, "
            "\"plant_status_zero\": %u, \"repeated\": %u, \"tampered\": \"%s\", ",
            (unsigned)d->states, (unsigned)d->rx_bad[RRR_HIL_RX_BAD_CRC],
            (unsigned)d->rx_bad[RRR_HIL_RX_BAD_DLC], (unsigned)d->rx_bad[RRR_HIL_RX_UNKNOWN_ID],
            (unsigned)d->out_of_order, (unsigned)d->status.faults, (unsigned)d->status_faulty,
            (unsigned)d->status_zero, (unsigned)d->repeated, d->tampered);
}
