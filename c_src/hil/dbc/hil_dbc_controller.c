/*
 * The controller node's DBC profile (rrr_hil_controller --profile dbc, the default): the frames of
 * python/rrr_robot/data/rrr_bench.dbc. By default the node connects to the plant node as a
 * socketcand client; each period it sends VoltageCmd (+ Sync in lockstep) computed from the joint
 * states it receives.
 *
 * Lockstep (default): heartbeat "operational" first; then for k = 0 .. n-1: wait for the three
 * JointState frames of period k (alive counter k mod 16), compute u_k, send VoltageCmd(k) and,
 * for k < n-1, Sync(k). At the end: StopCmd (E2E protected, the next alive counter of the
 * command sequence, reason "end of run"), then the heartbeat "stopped" (informational). Same
 * sequence as the FMPy master (cosim.run_cosim): the controller sees the plant's state at t_k,
 * the plant integrates over [t_k, t_k+1] with u_k held. A run that ends early (signal, fault,
 * plant lost) still sends StopCmd, with the reason, when it can.
 * Real time: every 1 ms of CLOCK_MONOTONIC (hil_node.h: clock_nanosleep TIMER_ABSTIME, optionally
 * sleep-then-spin, SCHED_FIFO, mlockall, a CPU) with the newest complete joint state, VoltageCmd
 * only (no Sync: the lockstep time base is not needed on a timed bus, and leaving it out keeps
 * the bus load of the schedule within 70 % of 1 Mbit/s, `rrr hil busload`); a state older than
 * 3 periods is stale: the controller then sends Enable = 0 (0 V). Jitter and deadline misses are
 * printed at exit.
 * Exit status 7: the run completed, but a PlantStatus frame reported a latched fault or 0 V (the
 * plant's safety policy fired). Exit status 8 (lockstep): a second JointState of a joint in one
 * period, which the plant never sends (a repeat or a forgery), ends the run at once.
 */
#define _POSIX_C_SOURCE 200809L

#include <stdio.h>
#include <string.h>

#include "hil_codec.h"
#include "hil_controller.h"

#define PROG "rrr_hil_controller"
#define STALE_PERIODS 3u

/* The DBC profile's state beside the node's. */
typedef struct dbc_ctrl {
    rrr_hil_ctrl *c;
    uint8_t have[3];        /* joint j received for the counter in `pending` */
    uint8_t pending;        /* alive counter of the state being assembled */
    double pq[3], pqd[3];   /* state being assembled */
    uint32_t state_age;     /* periods since the last complete state (real time) */
    uint32_t stale;         /* periods with a stale state (real time) */
    uint32_t rx_bad[RRR_HIL_RX_COUNT];
    uint32_t out_of_order;  /* joint frames of another counter than the one assembled */
    rrr_hil_plant_status status; /* newest PlantStatus */
    uint32_t status_faulty;  /* PlantStatus frames with a fault */
    uint32_t status_zero;    /* PlantStatus frames with ZeroVoltage */
    uint8_t hb_counter;
    uint8_t last_cmd_counter; /* alive counter of the last VoltageCmd sent */
    uint32_t cmds_sent;     /* VoltageCmd frames sent */
    int lockstep;           /* one JointState per joint and period (the repeat rule) */
    uint8_t done;           /* alive counter of the last complete state */
    uint8_t done_valid;     /* 1 once a state was complete */
    uint32_t repeated;      /* JointState frames repeated in one period (the first ends it) */
    char tampered[96];      /* what ended the run as tampered input, "" if nothing */
} dbc_ctrl;

static int send_heartbeat(dbc_ctrl *d, uint8_t nmt)
{
    rrr_hil_frame f;
    const rrr_hil_heartbeat hb = {1u, nmt, d->hb_counter++};
    if (rrr_hil_encode_heartbeat(&hb, &f) != 0) {
        return rrr_hil_run_end(&d->c->run, RRR_HIL_EXIT_FAULT, "heartbeat cannot be encoded");
    }
    return rrr_hil_ctrl_send(d->c, &f, "send heartbeat");
}

/* Lockstep: the plant sends each JointState once per period, so one of a joint already received
 * for the state being assembled, or one of the state just completed, is a repeat (replayed or
 * forged): -1 with d->tampered set; 0 otherwise. */
static int repeat(dbc_ctrl *d, const rrr_hil_joint_state *js)
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
                   (unsigned)d->c->run.k);
    return -1;
}

/* Feed one frame; returns 1 when it completed the state with alive counter `counter`, -1 for a
 * repeated JointState in lockstep (repeat: d->tampered says which). */
static int handle(dbc_ctrl *d, const rrr_hil_frame *f)
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
    if (repeat(d, js) != 0) {
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
        memcpy(d->c->q, d->pq, sizeof d->c->q);
        memcpy(d->c->qd, d->pqd, sizeof d->c->qd);
        memset(d->have, 0, sizeof d->have);
        d->done = d->pending;
        d->done_valid = 1u;
        ++d->c->states;
        return 1;
    }
    return 0;
}

/* VoltageCmd(k): u_k from the reference row k and the current state; 0 V (enable 0) if rrr_ctc
 * fails. */
static void command(dbc_ctrl *d, const rrr_hil_ctrl_opts *o, size_t k, int enable,
                    rrr_hil_voltage_cmd *cmd)
{
    cmd->counter = (uint8_t)(k & 15u);
    cmd->enable = (uint8_t)rrr_hil_ctrl_law(d->c, o, k, enable, cmd->u_V);
    cmd->reset_fault = 0;
}

/* VoltageCmd(k) and, with_sync, Sync(k): 0, or an exit status with why set. */
static int send_period(dbc_ctrl *d, const rrr_hil_voltage_cmd *cmd, uint32_t k, int with_sync)
{
    rrr_hil_frame f;
    if (rrr_hil_encode_voltage_cmd(cmd, &f) != 0) {
        return rrr_hil_run_end(&d->c->run, RRR_HIL_EXIT_FAULT,
                               "VoltageCmd cannot be encoded: u = (%.6g, %.6g, %.6g) V outside "
                               "the DBC range [-30, 30] V (is u_max above 30 V?)",
                               cmd->u_V[0], cmd->u_V[1], cmd->u_V[2]);
    }
    int rc = rrr_hil_ctrl_send(d->c, &f, "send VoltageCmd");
    if (rc != 0) {
        return rc;
    }
    d->last_cmd_counter = cmd->counter;
    ++d->cmds_sent;
    const rrr_hil_sync s = {k};
    if (with_sync) {
        if (rrr_hil_encode_sync(&s, &f) != 0) {
            return rrr_hil_run_end(&d->c->run, RRR_HIL_EXIT_FAULT, "Sync cannot be encoded");
        }
        rc = rrr_hil_ctrl_send(d->c, &f, "send Sync");
    }
    if (rc == 0 && k % RRR_HIL_HEARTBEAT_PERIODS == 0u && k > 0u) {
        rc = send_heartbeat(d, RRR_HIL_NMT_OPERATIONAL);
    }
    return rc;
}

/* The end of every run that got a transport: StopCmd (the next alive counter of the command
 * sequence, the reason from the exit status), then the heartbeat "stopped". After a complete run
 * a StopCmd that cannot be sent loses the plant; otherwise both are best effort. */
static int finish(dbc_ctrl *d, int rc)
{
    rrr_hil_stop_reason reason = RRR_HIL_STOP_PLANT_LOST;
    if (rc == RRR_HIL_EXIT_OK) {
        reason = RRR_HIL_STOP_END_OF_RUN;
    } else if (rc == RRR_HIL_EXIT_INTERRUPTED) {
        reason = RRR_HIL_STOP_INTERRUPTED;
    } else if (rc == RRR_HIL_EXIT_FAULT) {
        reason = RRR_HIL_STOP_FAULT;
    }
    const rrr_hil_stop_cmd stop = {
        (uint8_t)(d->cmds_sent > 0u ? (d->last_cmd_counter + 1u) & 15u : 0u), (uint8_t)reason};
    rrr_hil_frame f;
    if (rrr_hil_encode_stop_cmd(&stop, &f) != 0) {
        return rc == RRR_HIL_EXIT_OK
                   ? rrr_hil_run_end(&d->c->run, RRR_HIL_EXIT_FAULT, "StopCmd cannot be encoded")
                   : rc;
    }
    const rrr_hil_io io = rrr_hil_send(d->c->tr, &f);
    if (io != RRR_HIL_IO_OK && rc == RRR_HIL_EXIT_OK) {
        rc = rrr_hil_ctrl_lost(d->c, "send StopCmd", io);
    }
    const rrr_hil_heartbeat hb = {1u, RRR_HIL_NMT_STOPPED, d->hb_counter++};
    if (rrr_hil_encode_heartbeat(&hb, &f) == 0) {
        (void)rrr_hil_send(d->c->tr, &f); /* informational: the plant may be gone already */
    }
    return rc;
}

/* Wait up to --timeout-ms for a frame. want < 0: any frame of the bench; else the complete joint
 * state with alive counter `want`. 0, or an exit status with why set. */
static int wait_frames(dbc_ctrl *d, const rrr_hil_ctrl_opts *o, int want, const char *what)
{
    const int64_t deadline = rrr_hil_now_ms() + o->timeout_ms;
    for (;;) {
        rrr_hil_frame f;
        const int rc = rrr_hil_ctrl_recv_until(d->c, deadline, o, what, &f);
        if (rc != 0) {
            return rc;
        }
        const int h = handle(d, &f);
        if (h < 0) {
            return rrr_hil_run_end(&d->c->run, RRR_HIL_EXIT_TAMPERED,
                                   "%s: a frame the plant never sends (tampered input?)",
                                   d->tampered);
        }
        if (h ? (want < 0 || d->pending == (uint8_t)want) : want < 0) {
            return 0;
        }
    }
}

/* As a socketcand server, the controller may send nothing before the client's first frame (the
 * plant's boot-up heartbeat): wait for it. */
static int wait_for_peer(dbc_ctrl *d, const rrr_hil_ctrl_opts *o)
{
    return o->link.kind == 1 ? wait_frames(d, o, -1, "plant connected") : 0;
}

static int run_lockstep(dbc_ctrl *d, const rrr_hil_ctrl_opts *o)
{
    rrr_hil_ctrl *c = d->c;
    int rc = wait_for_peer(d, o);
    if (rc == 0) {
        rc = send_heartbeat(d, RRR_HIL_NMT_OPERATIONAL);
    }
    for (size_t k = 0; k < c->ref.n && rc == 0; ++k) {
        c->run.k = (uint32_t)k;
        rc = wait_frames(d, o, (int)(k & 15u), "joint state");
        if (rc == 0) {
            rrr_hil_voltage_cmd cmd;
            command(d, o, k, 1, &cmd);
            rc = send_period(d, &cmd, (uint32_t)k, k + 1u < c->ref.n);
        }
    }
    if (rc == 0) {
        c->run.k = (uint32_t)c->ref.n;
        rc = rrr_hil_run_end(&c->run, RRR_HIL_EXIT_OK, "all %zu periods of the reference",
                             c->ref.n);
    }
    return finish(d, rc);
}

static int run_realtime(dbc_ctrl *d, const rrr_hil_ctrl_opts *o, FILE *latency_log)
{
    rrr_hil_ctrl *c = d->c;
    rrr_hil_rt rt;
    if (rrr_hil_rt_init(&rt, RRR_HIL_PERIOD_S, (uint32_t)c->ref.n, &o->rt, latency_log, PROG) !=
        0) {
        return rrr_hil_run_end(&c->run, RRR_HIL_EXIT_SETUP, "out of memory");
    }
    int rc = wait_for_peer(d, o);
    if (rc == 0) {
        rc = send_heartbeat(d, RRR_HIL_NMT_OPERATIONAL);
    }
    d->state_age = STALE_PERIODS + 1u; /* no state yet */
    for (size_t k = 0; k < c->ref.n && rc == 0; ++k) {
        c->run.k = (uint32_t)k;
        if (rrr_hil_stop_requested()) {
            rc = rrr_hil_run_interrupted(&c->run);
            break;
        }
        rrr_hil_rt_wait(&rt);
        rrr_hil_frame f;
        rrr_hil_io io;
        int fresh = 0;
        while ((io = rrr_hil_recv(c->tr, &f, 0)) == RRR_HIL_IO_OK) {
            fresh |= handle(d, &f) > 0;
        }
        if (io != RRR_HIL_IO_TIMEOUT) {
            rc = rrr_hil_ctrl_lost(c, "receive", io);
            break;
        }
        d->state_age = fresh ? 0u : d->state_age + 1u;
        const int ok = d->state_age <= STALE_PERIODS;
        if (!ok) {
            ++d->stale;
        }
        rrr_hil_voltage_cmd cmd;
        command(d, o, k, ok, &cmd);
        rc = send_period(d, &cmd, (uint32_t)k, 0); /* no Sync: the plant keeps its own time */
        rrr_hil_rt_done(&rt);
    }
    if (rc == 0) {
        c->run.k = (uint32_t)c->ref.n;
        rc = rrr_hil_run_end(&c->run, RRR_HIL_EXIT_OK, "all %zu periods of the reference",
                             c->ref.n);
    }
    rc = finish(d, rc);
    rrr_hil_rt_print(&rt, PROG);
    rrr_hil_rt_free(&rt);
    return rc;
}

static void summary(const dbc_ctrl *d, int rc)
{
    const rrr_hil_ctrl *c = d->c;
    fprintf(stderr,
            PROG ": %u joint states received; rejected frames: %u bad CRC, %u wrong DLC, %u unknown "
                 "id; %u incomplete states overtaken; %u stale periods; plant status faults 0x%02X "
                 "(%u faulty status frames); rrr_ctc failures %u\n",
            c->states, d->rx_bad[RRR_HIL_RX_BAD_CRC], d->rx_bad[RRR_HIL_RX_BAD_DLC],
            d->rx_bad[RRR_HIL_RX_UNKNOWN_ID], d->out_of_order, d->stale,
            (unsigned)d->status.faults, d->status_faulty, c->ctc_failed);
    printf("RRR_HIL_SUMMARY {\"node\": \"controller\", \"exit\": %d, \"states\": %u, "
           "\"rx_bad_crc\": %u, \"rx_bad_dlc\": %u, \"rx_unknown_id\": %u, \"out_of_order\": %u, "
           "\"stale\": %u, \"plant_faults\": %u, \"plant_status_faulty\": %u, "
           "\"plant_status_zero\": %u, \"ctc_failed\": %u, \"repeated\": %u, "
           "\"tampered\": \"%s\", ",
           rc, c->states, d->rx_bad[RRR_HIL_RX_BAD_CRC], d->rx_bad[RRR_HIL_RX_BAD_DLC],
           d->rx_bad[RRR_HIL_RX_UNKNOWN_ID], d->out_of_order, d->stale,
           (unsigned)d->status.faults, d->status_faulty, d->status_zero, c->ctc_failed,
           d->repeated, d->tampered);
    rrr_hil_link_json(stdout, c->tr);
    printf("}\n");
    fflush(stdout);
}

static unsigned rx_ids(const rrr_hil_ctrl_opts *o, uint32_t *ids)
{
    (void)o;
    const uint32_t dbc_ids[] = {RRR_BENCH_JOINT_STATE1_FRAME_ID, RRR_BENCH_JOINT_STATE2_FRAME_ID,
                                RRR_BENCH_JOINT_STATE3_FRAME_ID, RRR_BENCH_PLANT_STATUS_FRAME_ID,
                                RRR_BENCH_HEARTBEAT_PLANT_FRAME_ID};
    memcpy(ids, dbc_ids, sizeof dbc_ids);
    return 5u;
}

static int run(rrr_hil_ctrl *c, const rrr_hil_ctrl_opts *o, FILE *latency_log,
               rrr_hil_framelog *frames)
{
    static dbc_ctrl d;
    memset(&d, 0, sizeof d);
    d.c = c;
    d.lockstep = !o->realtime;
    int rc = o->realtime ? run_realtime(&d, o, latency_log) : run_lockstep(&d, o);
    /* a completed run while the plant reported its safety policy firing (PlantStatus: a latched
     * fault, or 0 V forced) ends with its own status, as the plant does */
    if (d.status_faulty != 0u || d.status_zero != 0u) {
        rc = rrr_hil_run_safety(&c->run, rc,
                                "the plant's safety policy fired: %u PlantStatus frames with a "
                                "fault, %u with 0 V",
                                d.status_faulty, d.status_zero);
    }
    (void)rrr_hil_framelog_close(frames); /* reported in the summary */
    summary(&d, rc);
    return rc;
}

static int check(const rrr_hil_ctrl_opts *o)
{
    if (o->consumer_ms != 0u || o->rpdo_timeout != 0u) {
        fprintf(stderr, PROG ": --consumer-ms, --rpdo-timeout: options of --profile canopen\n");
        return -1;
    }
    return 0;
}

const rrr_hil_ctrl_profile rrr_hil_dbc_controller = {
    "dbc", "  real time: Sync is not sent (it is the lockstep time base)\n", check, rx_ids, run};
