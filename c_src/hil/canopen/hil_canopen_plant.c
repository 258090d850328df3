/*
 * The plant node's CANopen profile (rrr_hil_plant --profile canopen, docs/canopen.md): the axes as
 * three CiA 402 drives in cyclic synchronous torque (hil_canopen.h), node ids --node-ids. The
 * master's SYNC steps the plant: the first SYNC in operational only starts, each later one
 * applies the torques (u = tau / k_t, eq 8) over the period it closes, then the drives send their
 * TPDOs. Heartbeats (producer and consumer) run in wall-clock time. The run ends when the master
 * hangs up or falls silent: with no drive in NMT operational that is the end of the run (exit 0,
 * 7 if a drive latched a fault), else the master is lost (exit 3).
 */
#define _POSIX_C_SOURCE 200809L

#include <stdio.h>
#include <string.h>
#include <time.h>

#include "hil_canopen.h"
#include "hil_plant.h"

#define PROG "rrr_hil_plant"

/* The CANopen profile's state beside the node's. */
typedef struct co_plant {
    rrr_hil_plant *p;
    rrr_co_node co[3];
    int synced;           /* the first SYNC in operational was seen (it does not step) */
    uint32_t co_faults;   /* faults latched by the drives over the run */
    const char *rt_setup; /* --realtime: what rrr_hil_rt_init applied (NULL: lockstep) */
} co_plant;

static int64_t now_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000 + ts.tv_nsec / 1000;
}

static void co_send(co_plant *c, const rrr_co_out *out)
{
    for (unsigned i = 0; i < out->n; ++i) {
        (void)rrr_hil_send(c->p->tr, &out->f[i]);
    }
}

/* Axis i's settings: its node id, its rated torque from the FMU's k_t and u_max (0x6076 =
 * k_t,i u_max, mN m). 0, or -1 with a message. */
static int axis_config(const rrr_hil_plant *p, const rrr_hil_plant_opts *o, int i,
                       rrr_co_config *cfg)
{
    const double rated = p->kt[i] * p->u_max_V * 1000.0;
    const rrr_co_config c = {o->node_ids[i], (uint32_t)(rated + 0.5)};
    rrr_co_node probe;
    if (!(rated >= 1.0 && rated < 4.0e9) || rrr_co_init(&probe, &c) != 0) {
        fprintf(stderr, PROG ": axis %d: k_t u_max = %g mN m is not a rated torque 0x6076 "
                        "can hold (1 .. 4e9)\n", i + 1, rated);
        return -1;
    }
    *cfg = c;
    return 0;
}

/* The drives' rated torques can be served: 0 or -1 with a message. */
static int setup(rrr_hil_plant *p, const rrr_hil_plant_opts *o)
{
    if (rrr_hil_plant_read_kt(p) != 0) {
        return -1;
    }
    for (int i = 0; i < 3; ++i) {
        rrr_co_config cfg;
        if (axis_config(p, o, i, &cfg) != 0) {
            return -1;
        }
    }
    return 0;
}

static int co_any_operational(const co_plant *c)
{
    for (int i = 0; i < 3; ++i) {
        if (c->co[i].nmt == RRR_CO_NMT_OPERATIONAL) {
            return 1;
        }
    }
    return 0;
}

/* One SYNC fed to the drives: the period it closes (the first SYNC only starts), then TPDOs. */
static int co_sync(co_plant *c)
{
    rrr_hil_plant *p = c->p;
    if (c->synced) {
        p->log_zero = 0;
        p->log_faults = 0;
        for (int i = 0; i < 3; ++i) {
            p->u[i] = rrr_co_torque_Nm(&c->co[i]) / p->kt[i]; /* eq 8: u = tau / k_t */
            p->log_zero |= c->co[i].s402 != RRR_CO_402_OPERATION_ENABLED;
            p->log_faults |= (uint8_t)((c->co[i].s402 == RRR_CO_402_FAULT) << i);
        }
        if (rrr_hil_plant_step(p) != 0) {
            return -1;
        }
    }
    c->synced = 1;
    for (int i = 0; i < 3; ++i) {
        rrr_co_out out = {0};
        rrr_co_set_feedback(&c->co[i], p->x[i], p->x[3 + i]);
        rrr_co_transmit(&c->co[i], &out);
        co_send(c, &out);
    }
    return 0;
}

static int run_canopen(co_plant *c, const rrr_hil_plant_opts *o)
{
    rrr_hil_plant *p = c->p;
    const int idle_ms = rrr_hil_link_idle_ms(&o->link);
    for (int i = 0; i < 3; ++i) { /* power on: boot-up messages (a socketcand server drops them
                                   * before its client's first frame: a master resets the nodes) */
        rrr_co_out out = {0};
        rrr_co_boot(&c->co[i], &out);
        co_send(c, &out);
    }
    int64_t last_us = now_us();
    int was_operational = 0; /* some drive has been in NMT operational */
    for (;;) {
        if (rrr_hil_stop_requested()) {
            return rrr_hil_run_interrupted(&p->run);
        }
        rrr_hil_frame f;
        const rrr_hil_io io = rrr_hil_recv(p->tr, &f, 10000);
        const int64_t t = now_us();
        for (int i = 0; i < 3; ++i) { /* heartbeat producer and consumer, in wall-clock time */
            rrr_co_out out = {0};
            const uint32_t faults = c->co[i].latch.fault_events;
            rrr_co_advance(&c->co[i], (uint32_t)(t - last_us), &out);
            co_send(c, &out);
            c->co_faults += c->co[i].latch.fault_events - faults; /* a lost master heartbeat */
        }
        last_us = t;
        if (io == RRR_HIL_IO_TIMEOUT) {
            const int64_t silent_ms = rrr_hil_now_ms() - p->last_rx_ms;
            if (p->started && o->end_after_stop_ms > 0 && was_operational &&
                !co_any_operational(c) && silent_ms >= o->end_after_stop_ms) {
                return rrr_hil_run_end(&p->run, RRR_HIL_EXIT_OK,
                                       "the master stopped the drives and fell silent "
                                       "(--end-after-stop-ms)");
            }
            if (p->started && silent_ms >= idle_ms) {
                return co_any_operational(c)
                           ? rrr_hil_plant_silence_lost(p, idle_ms, "")
                           : rrr_hil_run_end(&p->run, RRR_HIL_EXIT_OK,
                                             "the master fell silent with no drive "
                                             "in NMT operational");
            }
            continue;
        }
        if (io != RRR_HIL_IO_OK) {
            if (p->started && !co_any_operational(c)) {
                return rrr_hil_run_end(&p->run, RRR_HIL_EXIT_OK,
                                       "the master hung up with no drive in NMT operational");
            }
            return rrr_hil_plant_transport_lost(p, io, "");
        }
        p->started = 1;
        p->last_rx_ms = rrr_hil_now_ms();
        const int is_sync = !f.extended && f.id == 0x080u && f.dlc <= 1u;
        int sync_applied = 0;
        for (int i = 0; i < 3; ++i) {
            rrr_co_out out = {0};
            const uint32_t faults = c->co[i].latch.fault_events;
            rrr_co_on_frame(&c->co[i], &f, &out);
            sync_applied |= c->co[i].tx_pending;
            co_send(c, &out);
            c->co_faults += c->co[i].latch.fault_events - faults;
        }
        was_operational |= co_any_operational(c);
        if (is_sync && sync_applied && co_sync(c) != 0) {
            return RRR_HIL_EXIT_FAULT;
        }
    }
}

static void co_summary(const co_plant *c, int rc)
{
    const rrr_hil_plant *p = c->p;
    fprintf(stderr, PROG ": --profile canopen: %u periods; faults latched by the drives %u\n",
            p->run.k, c->co_faults);
    printf("RRR_HIL_SUMMARY {\"node\": \"plant\", \"profile\": \"canopen\", \"exit\": %d, "
           "\"periods\": %u, \"drive_faults\": %u, \"drives\": [", rc, p->run.k, c->co_faults);
    for (int i = 0; i < 3; ++i) {
        const rrr_co_node *n = &c->co[i];
        const rrr_co_err *e = &n->err;
        printf("%s{\"node_id\": %u, \"nmt\": %u, \"state\": \"%s\", \"error_register\": %u, "
               "\"error_code\": %u, \"faults\": %u, \"fault_resets\": %u, "
               "\"zero_periods\": %u, \"emcy\": %u, "
               "\"sdo_aborts\": %u, \"hb_lost\": %u, \"rpdo_timeouts\": %u, \"rpdo_short\": %u, "
               "\"nmt_ignored\": %u, \"sync_bad\": %u, \"out_overflow\": %u, "
               "\"sdo_timeouts\": %u}",
               i ? ", " : "", (unsigned)n->cfg.node_id, (unsigned)n->nmt,
               rrr_co_402_str((rrr_co_402)n->s402), (unsigned)n->v[RRR_CO_OD_ERROR_REGISTER],
               (unsigned)n->v[RRR_CO_OD_ERROR_CODE], n->latch.fault_events, n->latch.resets,
               n->latch.zero_periods, e->emcy_sent,
               e->sdo_aborts, e->hb_lost, e->rpdo_timeouts, e->rpdo_short, e->nmt_ignored,
               e->sync_bad, e->out_overflow, e->sdo_timeouts);
    }
    printf("], ");
    if (c->rt_setup != NULL) {
        printf("\"rt_setup\": \"%s\", ", c->rt_setup);
    }
    rrr_hil_link_json(stdout, p->tr);
    printf("}\n");
    fflush(stdout);
}

static int check(const rrr_hil_plant_opts *o)
{
    if (o->realtime && (o->duration_s > 0.0 || o->rt.latency_log != NULL)) {
        fprintf(stderr, PROG ": --profile canopen is stepped by the master's SYNC: with "
                             "--realtime it takes --fifo, --mlock and --cpu only (no --duration, "
                             "no --latency-log: the SYNC times are in the frame log)\n");
        return -1;
    }
    return 0;
}

/* Every identifier: the master's heartbeat id is configured by SDO. */
static unsigned rx_ids(const rrr_hil_plant_opts *o, uint32_t *ids)
{
    (void)o;
    (void)ids;
    return 0u;
}

static int run(rrr_hil_plant *p, const rrr_hil_plant_opts *o, FILE *latency_log,
               rrr_hil_framelog *frames)
{
    static co_plant c;
    memset(&c, 0, sizeof c);
    c.p = p;
    for (int i = 0; i < 3; ++i) {
        rrr_co_config cfg;
        (void)axis_config(p, o, i, &cfg); /* checked by setup */
        (void)rrr_co_init(&c.co[i], &cfg);
    }
    static rrr_hil_rt rt; /* --realtime: the setup only (SCHED_FIFO, mlockall, CPU) */
    if (o->realtime && rrr_hil_rt_init(&rt, RRR_HIL_PERIOD_S, 1u, &o->rt, NULL, PROG) != 0) {
        return rrr_hil_run_end(&p->run, RRR_HIL_EXIT_SETUP, "out of memory");
    }
    c.rt_setup = o->realtime ? rt.setup : NULL;
    p->last_rx_ms = rrr_hil_now_ms();
    int rc = run_canopen(&c, o);
    rrr_hil_rt_free(&rt);
    if (c.co_faults != 0u) {
        rc = rrr_hil_run_safety(&p->run, rc, "the drives latched %u faults", c.co_faults);
    }
    if (latency_log != NULL) {
        fclose(latency_log);
    }
    (void)rrr_hil_framelog_close(frames); /* reported in the summary */
    co_summary(&c, rc);
    return rc;
}

const rrr_hil_plant_profile rrr_hil_canopen_plant = {
    "canopen",
    "  --profile canopen: the axes as three CiA 402 drives (CST) with node ids\n"
    "  --node-ids (default 1,2,3), stepped by the master's SYNC (docs/canopen.md);\n"
    "  with --realtime: SCHED_FIFO, mlockall, the CPU (--fifo, --mlock, --cpu) applied,\n"
    "  still stepped by each SYNC; the master's heartbeat consumer in wall-clock time;\n"
    "  --end-after-stop-ms N: end (exit 0) N ms after the master's last frame once it has\n"
    "  taken every drive out of NMT operational (a bus with no hang-up: SocketCAN)\n",
    check, setup, rx_ids, run};
