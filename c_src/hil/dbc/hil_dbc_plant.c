/*
 * The plant node's DBC profile (rrr_hil_plant --profile dbc, the default): the frames of
 * python/rrr_robot/data/rrr_bench.dbc, every command through the supervisor (hil_supervisor.h).
 *
 * Lockstep (default): the plant publishes its state (JointState1..3, PlantStatus) at period 0
 * after the controller's first frame, then advances exactly one period per Sync frame, applying
 * the voltage its supervisor decides from the VoltageCmd frames received since the previous
 * Sync, and publishes the new state. The run ends with the controller's StopCmd, honoured only
 * with its E2E protection (hil_supervisor.h); the heartbeat "stopped" is informational.
 * Real time: the same every 1 ms of CLOCK_MONOTONIC (clock_nanosleep TIMER_ABSTIME), half a
 * period out of phase with the controller's loop (which starts with its first frame); Sync
 * frames are ignored; the run lasts --duration seconds or until the controller's StopCmd.
 * Either mode: a controller that hangs up, or sends nothing for --idle-timeout-ms after its
 * first frame, is lost (bus fault latched).
 * Exit status 6: the controller's StopCmd gave a reason other than the end of the run; 7: the
 * run ended as for 0, but the safety policy fired (a fault latched, even if reset later, or 0 V
 * forced for at least one period).
 */
#define _POSIX_C_SOURCE 200809L

#include <stdio.h>
#include <string.h>

#include "hil_codec.h"
#include "hil_plant.h"
#include "hil_supervisor.h"

#define PROG "rrr_hil_plant"

/* The DBC profile's state beside the node's. */
typedef struct dbc_plant {
    rrr_hil_plant *p;
    rrr_hil_sup sup;
    uint32_t tx_state_range; /* states that could not be encoded (outside the DBC range) */
    uint8_t hb_counter;
    uint8_t ctrl_nmt;     /* last NMT state of the controller heartbeat, 255 before any */
    uint32_t rx_bad[RRR_HIL_RX_COUNT]; /* decode results of all frames */
    uint32_t rx_ignored;  /* frames of the bench not meant for the plant */
} dbc_plant;

/* What handle() made of a frame. */
enum { EV_NONE = 0, EV_SYNC, EV_STOP };

/* The controller is gone: latch the bus fault; the note for the exit line. */
static const char *lose_controller(dbc_plant *d)
{
    rrr_hil_sup_raise(&d->sup, RRR_HIL_FAULT_BUS);
    return d->ctrl_nmt == RRR_HIL_NMT_STOPPED
               ? " (its heartbeat said 'stopped', but no valid StopCmd arrived)"
               : "";
}

/* The controller's StopCmd was honoured. */
static int stopped(dbc_plant *d)
{
    const unsigned r = d->sup.stop_reason;
    return rrr_hil_run_end(&d->p->run,
                           r == RRR_HIL_STOP_END_OF_RUN ? RRR_HIL_EXIT_OK
                                                        : RRR_HIL_EXIT_STOPPED_EARLY,
                           "the controller's StopCmd: %s", rrr_hil_stop_reason_str(r));
}

/* Publish the state of period k: JointState1..3 then PlantStatus. */
static void publish(dbc_plant *d)
{
    rrr_hil_plant *p = d->p;
    rrr_hil_frame f;
    const uint8_t counter = (uint8_t)(p->run.k & 15u);
    for (uint8_t j = 0; j < 3u; ++j) {
        const rrr_hil_joint_state js = {j, counter, p->x[j], p->x[3 + j]};
        if (rrr_hil_encode_joint_state(&js, &f) != 0) {
            ++d->tx_state_range;
            continue;
        }
        (void)rrr_hil_send(p->tr, &f);
    }
    rrr_hil_plant_status st;
    rrr_hil_sup_status(&d->sup, &st);
    st.counter = counter;
    if (rrr_hil_encode_plant_status(&st, &f) == 0) {
        (void)rrr_hil_send(p->tr, &f);
    }
    if (p->run.k % RRR_HIL_HEARTBEAT_PERIODS == 0u) {
        const rrr_hil_heartbeat hb = {2u, RRR_HIL_NMT_OPERATIONAL, d->hb_counter++};
        if (rrr_hil_encode_heartbeat(&hb, &f) == 0) {
            (void)rrr_hil_send(p->tr, &f);
        }
    }
}

/* Advance one period: supervisor decision, FMU step, new state. 0 or -1 (FMU failed: why set). */
static int advance(dbc_plant *d)
{
    (void)rrr_hil_sup_next_period(&d->sup, d->p->u);
    d->p->log_zero = d->sup.zero_applied;
    d->p->log_faults = d->sup.faults;
    return rrr_hil_plant_step(d->p);
}

/* Handle one received frame: EV_SYNC for a lockstep Sync (period to advance), EV_STOP for an
 * honoured StopCmd, else EV_NONE. */
static int handle(dbc_plant *d, const rrr_hil_frame *f, int lockstep)
{
    rrr_hil_msg m;
    const rrr_hil_rx rx = rrr_hil_decode(f, &m);
    ++d->rx_bad[rx];
    d->p->last_rx_ms = rrr_hil_now_ms();
    if (rx == RRR_HIL_RX_UNKNOWN_ID) {
        return EV_NONE;
    }
    d->p->started = 1;
    if (m.kind == RRR_HIL_VOLTAGE_CMD) {
        rrr_hil_sup_on_command(&d->sup, rx, rx == RRR_HIL_RX_OK ? &m.u.cmd : NULL);
        return EV_NONE;
    }
    if (m.kind == RRR_HIL_STOP_CMD) { /* honoured only with its E2E protection */
        return rrr_hil_sup_on_stop(&d->sup, rx, rx == RRR_HIL_RX_OK ? &m.u.stop : NULL) ? EV_STOP
                                                                                        : EV_NONE;
    }
    if (rx != RRR_HIL_RX_OK) {
        return EV_NONE;
    }
    if (m.kind == RRR_HIL_HEARTBEAT && m.u.heartbeat.node == 1u) {
        d->ctrl_nmt = m.u.heartbeat.nmt_state; /* informational: "stopped" stops nothing */
        return EV_NONE;
    }
    if (m.kind == RRR_HIL_SYNC && lockstep) {
        if (m.u.sync.cycle != d->p->run.k) {
            rrr_hil_sup_raise(&d->sup, RRR_HIL_FAULT_SYNC);
        }
        return EV_SYNC;
    }
    if (m.kind != RRR_HIL_SYNC) {
        ++d->rx_ignored;
    }
    return EV_NONE;
}

static int run_lockstep(dbc_plant *d, const rrr_hil_plant_opts *o)
{
    rrr_hil_plant *p = d->p;
    const int idle_ms = rrr_hil_link_idle_ms(&o->link);
    int published0 = 0;
    for (;;) {
        if (rrr_hil_stop_requested()) {
            return rrr_hil_run_interrupted(&p->run);
        }
        rrr_hil_frame f;
        const rrr_hil_io io = rrr_hil_recv(p->tr, &f, 200000);
        if (io == RRR_HIL_IO_TIMEOUT) {
            if (p->started && rrr_hil_now_ms() - p->last_rx_ms >= idle_ms) {
                return rrr_hil_plant_silence_lost(p, idle_ms, lose_controller(d));
            }
            continue; /* before the first frame: wait for a controller as long as it takes */
        }
        if (io != RRR_HIL_IO_OK) {
            return rrr_hil_plant_transport_lost(p, io, lose_controller(d));
        }
        const int ev = handle(d, &f, 1);
        if (p->started && !published0) {
            publish(d); /* the state of period 0, after the controller's first frame */
            published0 = 1;
        }
        if (ev == EV_STOP) {
            return stopped(d);
        }
        if (ev == EV_SYNC) {
            if (advance(d) != 0) {
                return RRR_HIL_EXIT_FAULT;
            }
            publish(d);
        }
    }
}

static int run_realtime(dbc_plant *d, const rrr_hil_plant_opts *o, FILE *latency_log)
{
    rrr_hil_plant *p = d->p;
    const uint32_t n = (uint32_t)(o->duration_s / RRR_HIL_PERIOD_S + 0.5);
    const int idle_ms = rrr_hil_link_idle_ms(&o->link);
    rrr_hil_rt rt;
    int rc = -1;
    /* the plant is held (brakes on, not integrated) until the controller's first frame */
    for (int waited_ms = 0; !p->started && rc < 0; waited_ms += 200) {
        rrr_hil_frame f;
        const rrr_hil_io io =
            rrr_hil_stop_requested() ? RRR_HIL_IO_TIMEOUT : rrr_hil_recv(p->tr, &f, 200000);
        if (rrr_hil_stop_requested()) {
            rc = rrr_hil_run_interrupted(&p->run);
        } else if (io == RRR_HIL_IO_OK) {
            (void)handle(d, &f, 0); /* no StopCmd can be honoured before a command */
        } else if (io != RRR_HIL_IO_TIMEOUT) {
            rc = rrr_hil_plant_transport_lost(p, io, lose_controller(d));
        } else if (waited_ms > (int)(o->duration_s * 1000.0)) {
            rc = rrr_hil_plant_lost(p, "no controller within --duration", lose_controller(d));
        }
    }
    if (rc >= 0) {
        if (latency_log != NULL) {
            fclose(latency_log); /* nothing to log: the loop never started */
        }
        return rc;
    }
    if (rrr_hil_rt_init(&rt, RRR_HIL_PERIOD_S, n, &o->rt, latency_log, PROG) != 0) {
        return rrr_hil_run_end(&p->run, RRR_HIL_EXIT_SETUP, "out of memory");
    }
    /* the controller's loop started when it sent that frame: run half a period out of phase,
     * so that its command reaches us before our release and our state reaches it before its */
    rrr_hil_rt_shift(&rt, 0.5 * RRR_HIL_PERIOD_S);
    for (uint32_t k = 0; k < n && rc < 0; ++k) {
        if (rrr_hil_stop_requested()) {
            rc = rrr_hil_run_interrupted(&p->run);
            break;
        }
        rrr_hil_rt_wait(&rt);
        rrr_hil_frame f;
        rrr_hil_io io = RRR_HIL_IO_TIMEOUT;
        int ev = EV_NONE;
        while (ev != EV_STOP && (io = rrr_hil_recv(p->tr, &f, 0)) == RRR_HIL_IO_OK) {
            ev = handle(d, &f, 0);
        }
        if (ev == EV_STOP) {
            rc = stopped(d);
        } else if (io != RRR_HIL_IO_TIMEOUT) {
            rc = rrr_hil_plant_transport_lost(p, io, lose_controller(d));
        } else if (rrr_hil_now_ms() - p->last_rx_ms >= idle_ms) {
            rc = rrr_hil_plant_silence_lost(p, idle_ms, lose_controller(d));
        } else if (advance(d) != 0) {
            rc = RRR_HIL_EXIT_FAULT;
        } else {
            publish(d);
            rrr_hil_rt_done(&rt);
        }
    }
    if (rc < 0) {
        rc = rrr_hil_run_end(&p->run, RRR_HIL_EXIT_OK, "--duration %g s elapsed", o->duration_s);
    }
    rrr_hil_rt_print(&rt, PROG);
    rrr_hil_rt_free(&rt);
    return rc;
}

static void summary(const dbc_plant *d, int rc)
{
    const rrr_hil_plant *p = d->p;
    const rrr_hil_sup_err *e = &d->sup.err;
    fprintf(stderr,
            PROG ": %u periods; faults latched 0x%02X; fault events %u (crc %u, counter %u, "
                 "range %u, format %u, sync %u, bus %u, timeout %u); periods without command %u, "
                 "at 0 V %u; resets %u; stop requests ignored %u; states out of DBC range %u\n",
            p->run.k, (unsigned)d->sup.faults, e->fault_events, e->crc, e->counter, e->range,
            e->format, e->sync, e->bus, e->timeout, e->cmd_missed, e->zero_periods, e->resets,
            e->stop_rejected, d->tx_state_range);
    printf("RRR_HIL_SUMMARY {\"node\": \"plant\", \"exit\": %d, \"periods\": %u, \"faults\": %u, "
           "\"fault_events\": %u, \"crc\": %u, \"counter\": %u, \"range\": %u, \"format\": %u, "
           "\"sync\": %u, \"bus\": %u, \"timeout\": %u, \"cmd_missed\": %u, \"zero_periods\": %u, "
           "\"resets\": %u, \"stop_rejected\": %u, \"stop_reason\": %d, "
           "\"state_out_of_range\": %u, \"rx_unknown_id\": %u, \"rx_bad_dlc\": %u, "
           "\"rx_bad_crc\": %u, \"rx_out_of_range\": %u, \"rx_ignored\": %u, ",
           rc, p->run.k, (unsigned)d->sup.faults, e->fault_events, e->crc, e->counter, e->range,
           e->format, e->sync, e->bus, e->timeout, e->cmd_missed, e->zero_periods, e->resets,
           e->stop_rejected, d->sup.stop ? (int)d->sup.stop_reason : -1, d->tx_state_range,
           d->rx_bad[RRR_HIL_RX_UNKNOWN_ID], d->rx_bad[RRR_HIL_RX_BAD_DLC],
           d->rx_bad[RRR_HIL_RX_BAD_CRC], d->rx_bad[RRR_HIL_RX_OUT_OF_RANGE], d->rx_ignored);
    rrr_hil_link_json(stdout, p->tr);
    printf("}\n");
    fflush(stdout);
}

static int check(const rrr_hil_plant_opts *o)
{
    if (o->realtime && o->duration_s <= 0.0) {
        fprintf(stderr, PROG ": --realtime needs --duration S\n");
        return -1;
    }
    if (o->end_after_stop_ms > 0) {
        fprintf(stderr, PROG ": --end-after-stop-ms is for --profile canopen (a DBC controller "
                             "ends the run with its StopCmd)\n");
        return -1;
    }
    return 0;
}

static unsigned rx_ids(const rrr_hil_plant_opts *o, uint32_t *ids)
{
    (void)o;
    const uint32_t dbc_ids[] = {RRR_BENCH_SYNC_FRAME_ID, RRR_BENCH_VOLTAGE_CMD_FRAME_ID,
                                RRR_BENCH_STOP_CMD_FRAME_ID, RRR_BENCH_HEARTBEAT_CTRL_FRAME_ID};
    memcpy(ids, dbc_ids, sizeof dbc_ids);
    return 4u;
}

static int run(rrr_hil_plant *p, const rrr_hil_plant_opts *o, FILE *latency_log,
               rrr_hil_framelog *frames)
{
    static dbc_plant d;
    memset(&d, 0, sizeof d);
    d.p = p;
    d.ctrl_nmt = 255u;
    rrr_hil_sup_config cfg = rrr_hil_sup_config_default();
    if (o->max_missed >= 0) {
        cfg.max_missed = (unsigned)o->max_missed;
    }
    if (o->max_delta_counter >= 0) {
        cfg.max_delta_counter = (unsigned)o->max_delta_counter;
    }
    (void)rrr_hil_sup_init(&d.sup, &cfg); /* the node checked the settings */
    {   /* CANopen-style boot-up message (dropped by a socketcand server without a client) */
        rrr_hil_frame f;
        const rrr_hil_heartbeat hb = {2u, RRR_HIL_NMT_BOOT, d.hb_counter++};
        if (rrr_hil_encode_heartbeat(&hb, &f) == 0) {
            (void)rrr_hil_send(p->tr, &f);
        }
    }
    p->last_rx_ms = rrr_hil_now_ms();
    int rc = o->realtime ? run_realtime(&d, o, latency_log) : run_lockstep(&d, o);
    /* a run that completed in which the safety policy fired (a fault latched, even if reset
     * later, or 0 V forced for a period) ends with its own status, so that a bench job fails */
    const rrr_hil_sup_err *e = &d.sup.err;
    if (d.sup.faults != 0u || e->fault_events != 0u || e->zero_periods != 0u) {
        rc = rrr_hil_run_safety(&p->run, rc,
                                "the safety policy fired: %u fault events, faults latched 0x%02X, "
                                "%u periods at 0 V",
                                e->fault_events, (unsigned)d.sup.faults, e->zero_periods);
    }
    (void)rrr_hil_framelog_close(frames); /* reported in the summary */
    summary(&d, rc);
    return rc;
}

const rrr_hil_plant_profile rrr_hil_dbc_plant = {"dbc", "", check, NULL, rx_ids, run};
