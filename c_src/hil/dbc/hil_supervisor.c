/* The plant's command supervisor (policy in hil_supervisor.h). */
#include "hil_supervisor.h"

#include <stddef.h>
#include <string.h>

/* The Python binding mirrors these structures; the reset and stop fields went into padding
 * and the tail of err, so nothing it knows moved (see the ABI note in hil_supervisor.h). */
#if UINTPTR_MAX == UINT64_MAX
_Static_assert(sizeof(rrr_hil_sup) == 128u, "rrr_hil_sup changed size: update the ctypes mirror");
_Static_assert(offsetof(rrr_hil_sup, cmd) == 16u && offsetof(rrr_hil_sup, u_hold_V) == 48u &&
                   offsetof(rrr_hil_sup, missed_in_row) == 72u &&
                   offsetof(rrr_hil_sup, zero_applied) == 76u && offsetof(rrr_hil_sup, err) == 80u,
               "rrr_hil_sup fields moved: update the ctypes mirror");
#endif

/* The supervisor's latch lives in the fields the Python binding mirrors (the ABI note in
 * hil_supervisor.h): loaded before and stored after each latch call. */
static rrr_hil_latch load_latch(const rrr_hil_sup *s)
{
    rrr_hil_latch l;
    l.latched = s->faults != 0u;
    l.zero = s->zero_applied;
    l.code = s->faults;
    l.fault_events = s->err.fault_events;
    l.resets = s->err.resets;
    l.zero_periods = s->err.zero_periods;
    return l;
}

static void store_latch(rrr_hil_sup *s, const rrr_hil_latch *l)
{
    s->faults = l->latched ? (uint8_t)l->code : 0u;
    s->zero_applied = l->zero;
    s->err.fault_events = l->fault_events;
    s->err.resets = l->resets;
    s->err.zero_periods = l->zero_periods;
}

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

static void disarm_reset(rrr_hil_sup *s)
{
    s->reset_step = RRR_HIL_RESET_IDLE;
    s->reset_enables = 0;
}

static void latch(rrr_hil_sup *s, uint8_t fault, uint32_t *counter)
{
    ++*counter;
    rrr_hil_latch l = load_latch(s);
    rrr_hil_latch_fault(&l, (uint16_t)(s->faults | fault)); /* the code: every fault bit latched */
    store_latch(s, &l);
    s->pending = 0;
    disarm_reset(s); /* a new fault aborts a fault reset in progress */
}

void rrr_hil_sup_raise(rrr_hil_sup *s, uint8_t fault)
{
    latch(s, fault, fault == RRR_HIL_FAULT_SYNC ? &s->err.sync : &s->err.bus);
}

/* One valid command while a fault is latched: a step of the fault-reset sequence (policy in
 * hil_supervisor.h). delta is its alive-counter step. Returns -1 when the command breaks an
 * armed sequence with a counter gap (the caller drops it: the counter fault is latched). */
static int reset_step(rrr_hil_sup *s, const rrr_hil_voltage_cmd *c, unsigned delta)
{
    if (s->reset_step == RRR_HIL_RESET_ARMED && delta != 1u) {
        latch(s, RRR_HIL_FAULT_COUNTER, &s->err.counter);
        return -1;
    }
    if (c->reset_fault && !c->enable) { /* a reset request: arms, or re-arms (held) */
        s->reset_step = RRR_HIL_RESET_ARMED;
        s->reset_enables = 0;
        return 0;
    }
    if (s->reset_step != RRR_HIL_RESET_ARMED) {
        return 0; /* latched, nothing armed: the command changes nothing (0 V) */
    }
    if (c->enable && !c->reset_fault) {
        if (++s->reset_enables >= RRR_HIL_RESET_ENABLE_FRAMES) {
            rrr_hil_latch l = load_latch(s);
            (void)rrr_hil_latch_reset(&l); /* the explicit reset event */
            store_latch(s, &l);
            disarm_reset(s);
        }
        return 0;
    }
    disarm_reset(s); /* Enable = 0 without ResetFault, or both set: not a reset */
    return 0;
}

void rrr_hil_sup_on_command(rrr_hil_sup *s, rrr_hil_rx rx, const rrr_hil_voltage_cmd *cmd)
{
    if (s->stop) {
        return; /* stopped: nothing changes the 0 V any more */
    }
    if (rx == RRR_HIL_RX_OK && cmd == NULL) {
        rx = RRR_HIL_RX_BAD_DLC; /* a caller error: no command to read */
    }
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
    unsigned delta = 1u; /* the first command has nothing to be compared with */
    if (s->have_counter) {
        delta = (unsigned)(cmd->counter - s->last_counter) & 15u;
        if (delta == 0u || delta > s->cfg.max_delta_counter) {
            s->last_counter = cmd->counter; /* resynchronise on the next command */
            latch(s, RRR_HIL_FAULT_COUNTER, &s->err.counter);
            return;
        }
    }
    s->have_counter = 1;
    s->last_counter = cmd->counter;
    if (s->faults != 0u && reset_step(s, cmd, delta) != 0) {
        return;
    }
    s->cmd = *cmd;
    s->pending = 1;
}

int rrr_hil_sup_on_stop(rrr_hil_sup *s, rrr_hil_rx rx, const rrr_hil_stop_cmd *stop)
{
    if (s->stop) {
        return 1; /* already stopped */
    }
    if (rx != RRR_HIL_RX_OK || stop == NULL || stop->reason >= (unsigned)RRR_HIL_STOP_REASON_COUNT ||
        !s->have_counter) {
        ++s->err.stop_rejected;
        return 0;
    }
    const unsigned delta = (unsigned)(stop->counter - s->last_counter) & 15u;
    if (delta == 0u || delta > s->cfg.max_delta_counter) {
        ++s->err.stop_rejected; /* stale or replayed: not the next frame of the command stream */
        return 0;
    }
    s->last_counter = stop->counter;
    s->stop = 1;
    s->stop_reason = stop->reason;
    s->pending = 0;
    disarm_reset(s);
    return 1;
}

int rrr_hil_sup_next_period(rrr_hil_sup *s, double u_V[3])
{
    int stop = s->stop; /* 0 V for ever once a stop was honoured */
    if (!stop && s->pending) {
        s->missed_in_row = 0;
        for (int i = 0; i < 3; ++i) {
            s->u_hold_V[i] = s->cmd.enable ? s->cmd.u_V[i] : 0.0;
        }
    } else if (!stop) {
        ++s->err.cmd_missed;
        if (++s->missed_in_row == s->cfg.max_missed) {
            latch(s, RRR_HIL_FAULT_TIMEOUT, &s->err.timeout);
        }
        stop = s->missed_in_row >= s->cfg.max_missed;
    }
    s->pending = 0;
    rrr_hil_latch l = load_latch(s);
    const int zero = rrr_hil_latch_output(&l, stop, s->u_hold_V, 3u); /* 0 V if latched */
    store_latch(s, &l);
    memcpy(u_V, s->u_hold_V, sizeof s->u_hold_V);
    return zero;
}

static uint16_t sat16(uint32_t v)
{
    return v > 0xFFFFu ? (uint16_t)0xFFFFu : (uint16_t)v;
}

void rrr_hil_sup_status(const rrr_hil_sup *s, rrr_hil_plant_status *st)
{
    if (s->faults == 0u) {
        st->state = RRR_HIL_PLANT_RUNNING;
    } else {
        st->state = s->reset_step == RRR_HIL_RESET_ARMED ? RRR_HIL_PLANT_RESET : RRR_HIL_PLANT_FAULT;
    }
    st->faults = s->faults;
    st->zero_voltage = s->zero_applied;
    st->fault_count = sat16(s->err.fault_events);
    st->cmd_missed = sat16(s->err.cmd_missed);
}
