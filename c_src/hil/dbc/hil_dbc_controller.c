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

#include "hil_controller.h"
#include "hil_dbc_ctrl.h"

#define PROG "rrr_hil_controller"
#define STALE_PERIODS 3u

/* The node's state beside the frame logic it shares with the firmware (hil_dbc_ctrl.h). */
typedef struct dbc_ctrl {
    rrr_hil_ctrl *c;
    rrr_hil_dbc_ctrl bus;   /* the frames: the measured state, PlantStatus, the repeat rule */
    uint32_t state_age;     /* periods since the last complete state (real time) */
    uint32_t stale;         /* periods with a stale state (real time) */
} dbc_ctrl;

static int send_heartbeat(dbc_ctrl *d, uint8_t nmt)
{
    rrr_hil_frame f;
    if (rrr_hil_dbc_ctrl_heartbeat(&d->bus, nmt, &f) != 0) {
        return rrr_hil_run_end(&d->c->run, RRR_HIL_EXIT_FAULT, "heartbeat cannot be encoded");
    }
    return rrr_hil_ctrl_send(d->c, &f, "send heartbeat");
}

/* Feed one frame (rrr_hil_dbc_ctrl_rx); a complete state becomes the node's measured state. */
static int handle(dbc_ctrl *d, const rrr_hil_frame *f)
{
    const int h = rrr_hil_dbc_ctrl_rx(&d->bus, f, d->c->run.k);
    if (h > 0) {
        memcpy(d->c->q, d->bus.q, sizeof d->c->q);
        memcpy(d->c->qd, d->bus.qd, sizeof d->c->qd);
        ++d->c->states;
    }
    return h;
}

/* VoltageCmd(k): u_k from the reference row k and the current state; 0 V (enable 0) if rrr_ctc
 * fails. */
static void command(dbc_ctrl *d, const rrr_hil_ctrl_opts *o, size_t k, int enable,
                    rrr_hil_voltage_cmd *cmd)
{
    double u[3];
    enable = rrr_hil_ctrl_law(d->c, o, k, enable, u);
    *cmd = rrr_hil_dbc_ctrl_command((uint32_t)k, enable, u);
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
    rrr_hil_dbc_ctrl_sent(&d->bus, cmd);
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
    const rrr_hil_stop_cmd stop = rrr_hil_dbc_ctrl_stop(&d->bus, reason);
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
    if (rrr_hil_dbc_ctrl_heartbeat(&d->bus, RRR_HIL_NMT_STOPPED, &f) == 0) {
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
                                   d->bus.tampered);
        }
        if (h ? (want < 0 || d->bus.pending == (uint8_t)want) : want < 0) {
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
    const rrr_hil_dbc_ctrl *b = &d->bus;
    fprintf(stderr,
            PROG ": %u joint states received; rejected frames: %u bad CRC, %u wrong DLC, %u unknown "
                 "id; %u incomplete states overtaken; %u stale periods; plant status faults 0x%02X "
                 "(%u faulty status frames); rrr_ctc failures %u\n",
            c->states, b->rx_bad[RRR_HIL_RX_BAD_CRC], b->rx_bad[RRR_HIL_RX_BAD_DLC],
            b->rx_bad[RRR_HIL_RX_UNKNOWN_ID], b->out_of_order, d->stale,
            (unsigned)b->status.faults, b->status_faulty, c->ctc_failed);
    printf("RRR_HIL_SUMMARY {\"node\": \"controller\", \"exit\": %d, \"stale\": %u, "
           "\"ctc_failed\": %u, ",
           rc, d->stale, c->ctc_failed);
    rrr_hil_dbc_ctrl_json(stdout, b);
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
    rrr_hil_dbc_ctrl_init(&d.bus, !o->realtime);
    int rc = o->realtime ? run_realtime(&d, o, latency_log) : run_lockstep(&d, o);
    /* a completed run while the plant reported its safety policy firing (PlantStatus: a latched
     * fault, or 0 V forced) ends with its own status, as the plant does */
    if (d.bus.status_faulty != 0u || d.bus.status_zero != 0u) {
        rc = rrr_hil_run_safety(&c->run, rc,
                                "the plant's safety policy fired: %u PlantStatus frames with a "
                                "fault, %u with 0 V",
                                d.bus.status_faulty, d.bus.status_zero);
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
