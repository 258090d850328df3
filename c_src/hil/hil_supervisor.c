/* The plant's command supervisor (policy in hil_supervisor.h). */
#include "hil_supervisor.h"

#include <string.h>

rrr_hil_sup_config rrr_hil_sup_config_default(void)
{
    const rrr_hil_sup_config c = {3u, 3u};
    return c;
}

int rrr_hil_sup_init(rrr_hil_sup *s, const rrr_hil_sup_config *cfg)
{
    if (cfg->max_missed < 1u || cfg->max_delta_counter < 1u || cfg->max_delta_counter > 15u) {
        return -1;
    }
    memset(s, 0, sizeof *s);
    s->cfg = *cfg;
    return 0;
}

static void latch(rrr_hil_sup *s, uint8_t fault, uint32_t *counter)
{
    ++*counter;
    ++s->err.fault_events;
    s->faults |= fault;
    s->pending = 0;
}

void rrr_hil_sup_raise(rrr_hil_sup *s, uint8_t fault)
{
    latch(s, fault, fault == RRR_HIL_FAULT_SYNC ? &s->err.sync : &s->err.bus);
}

void rrr_hil_sup_on_command(rrr_hil_sup *s, rrr_hil_rx rx, const rrr_hil_voltage_cmd *cmd)
{
    switch (rx) {
    case RRR_HIL_RX_OK:
        break;
    case RRR_HIL_RX_BAD_CRC:
        latch(s, RRR_HIL_FAULT_CRC, &s->err.crc);
        return;
    case RRR_HIL_RX_OUT_OF_RANGE:
        latch(s, RRR_HIL_FAULT_RANGE, &s->err.range);
        return;
    case RRR_HIL_RX_BAD_DLC:
    case RRR_HIL_RX_UNKNOWN_ID:
    case RRR_HIL_RX_COUNT:
    default:
        latch(s, RRR_HIL_FAULT_FORMAT, &s->err.format);
        return;
    }
    if (s->have_counter) {
        const unsigned delta = (unsigned)(cmd->counter - s->last_counter) & 15u;
        if (delta == 0u || delta > s->cfg.max_delta_counter) {
            s->last_counter = cmd->counter; /* resynchronise on the next command */
            latch(s, RRR_HIL_FAULT_COUNTER, &s->err.counter);
            return;
        }
    }
    s->have_counter = 1;
    s->last_counter = cmd->counter;
    if (cmd->reset_fault && !cmd->enable && s->faults != 0u) {
        s->faults = 0;
        ++s->err.resets;
    }
    s->cmd = *cmd;
    s->pending = 1;
}

int rrr_hil_sup_next_period(rrr_hil_sup *s, double u_V[3])
{
    int zero = 0;
    if (s->pending) {
        s->missed_in_row = 0;
        for (int i = 0; i < 3; ++i) {
            s->u_hold_V[i] = s->cmd.enable ? s->cmd.u_V[i] : 0.0;
        }
    } else {
        ++s->err.cmd_missed;
        if (++s->missed_in_row == s->cfg.max_missed) {
            latch(s, RRR_HIL_FAULT_TIMEOUT, &s->err.timeout);
        }
        if (s->missed_in_row >= s->cfg.max_missed) {
            zero = 1;
        }
    }
    s->pending = 0;
    if (s->faults != 0u) {
        zero = 1;
    }
    if (zero) {
        memset(s->u_hold_V, 0, sizeof s->u_hold_V);
        ++s->err.zero_periods;
    }
    memcpy(u_V, s->u_hold_V, sizeof s->u_hold_V);
    s->zero_applied = (uint8_t)zero;
    return zero;
}

static uint16_t sat16(uint32_t v)
{
    return v > 0xFFFFu ? (uint16_t)0xFFFFu : (uint16_t)v;
}

void rrr_hil_sup_status(const rrr_hil_sup *s, rrr_hil_plant_status *st)
{
    st->state = s->faults != 0u ? RRR_HIL_PLANT_FAULT : RRR_HIL_PLANT_RUNNING;
    st->faults = s->faults;
    st->zero_voltage = s->zero_applied;
    st->fault_count = sat16(s->err.fault_events);
    st->cmd_missed = sat16(s->err.cmd_missed);
}
