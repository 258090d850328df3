/*
 * rrr_hil_controller: the controller node of the CAN bench. Runs the core's computed-torque law
 * (rrr_ctc, eq 15) at 1 kHz along a reference table (the reference FMU's CSV, its columns t,
 * q_ref, qd_ref, qdd_ref found by name, one row per period; `rrr hil export-reference` writes
 * it) on the joint states it receives, and sends
 * VoltageCmd (+ Sync in lockstep) every period. By default it connects to the plant node as a socketcand
 * client.
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
 * the bus load of the schedule within 70 % of 1 Mbit/s, `rrr hil busload`); a state older than 3 periods is stale: the controller then sends
 * Enable = 0 (0 V). Jitter and deadline misses are printed at exit.
 *
 * Output: a summary on stderr and "RRR_HIL_SUMMARY {json}" on stdout, then one line on stderr
 * that says how the run ended ("rrr_hil_controller: exit 4 (interrupted) at period 17: SIGINT");
 * with --log, one CSV row per period (k, t, measured q and qd, u, u_n, u_c).
 * Exit status (rrr_hil_exit, hil_node.h): 0 every period done and StopCmd sent; 1 usage; 2 setup
 * failed; 3 the plant was lost (hang-up, no joint state within --timeout-ms, transport error);
 * 4 SIGINT/SIGTERM; 5 a fault of the controller (a command it cannot encode); 7 completed, but a
 * PlantStatus frame reported a latched fault or 0 V (the plant's safety policy fired).
 */
#define _POSIX_C_SOURCE 200809L

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "hil_codec.h"
#include "hil_node.h"
#include "rrr_hil_logs.h"
#include "rrr/rrr.h"

#define PROG "rrr_hil_controller"
#define STALE_PERIODS 3u

typedef struct opts {
    rrr_hil_link_opts link;
    const char *ref_path;
    const char *log_path;
    int realtime;
    int timeout_ms;
    rrr_ctc_gains gains;
    rrr_hil_rt_opts rt;
    const char *sets[64]; /* "NAME=VALUE" model parameters (--set), applied in order */
    int n_sets;
} opts;

typedef struct ctrl {
    rrr_model model;
    rrr_hil_reference ref;
    rrr_hil_transport *tr;
    double q[3], qd[3];     /* newest complete measured state */
    uint8_t have[3];        /* joint j received for the counter in `pending` */
    uint8_t pending;        /* alive counter of the state being assembled */
    double pq[3], pqd[3];   /* state being assembled */
    uint32_t states;        /* complete states received */
    uint32_t state_age;     /* periods since the last complete state (real time) */
    uint32_t stale;         /* periods with a stale state (real time) */
    uint32_t rx_bad[RRR_HIL_RX_COUNT];
    uint32_t out_of_order;  /* joint frames of another counter than the one assembled */
    uint32_t ctc_failed;
    rrr_hil_plant_status status; /* newest PlantStatus */
    uint32_t status_faulty;  /* PlantStatus frames with a fault */
    uint32_t status_zero;    /* PlantStatus frames with ZeroVoltage */
    uint8_t hb_counter;
    uint8_t last_cmd_counter; /* alive counter of the last VoltageCmd sent */
    uint32_t cmds_sent;     /* VoltageCmd frames sent */
    uint32_t k;             /* current period (for the exit line) */
    char why[320];          /* how the run ended (the exit line) */
    FILE *log;
} ctrl;

static void usage(void)
{
    fprintf(stderr,
            "usage: " PROG " --reference REF.csv (--connect HOST:PORT | --listen HOST:PORT |\n"
            "       --socketcan IF)\n" RRR_HIL_LINK_USAGE
            "       [--realtime [--fifo PRIO] [--mlock] [--cpu N] [--spin-us N]\n"
            "       [--latency-log FILE.csv]]\n"
            "       [--kp a,b,c] [--kd a,b,c] [--no-feedforward] [--set NAME=VALUE]...\n"
            "       [--timeout-ms N] [--log FILE.csv]\n"
            "  the model is the default robot (rrr_model_default) with the --set parameters\n"
            "  (named as in the FMUs: d1, a2, a3, d2, d3, g, u_max, p[k], kt[i], b[i], f[i,k],\n"
            "  w[i,k]), so the controller's model may differ from the plant's; gains default\n"
            "  to rrr_ctc_gains_default; --timeout-ms (5000): longest wait for a joint state\n"
            "  real time: Sync is not sent (it is the lockstep time base)\n"
            RRR_HIL_RT_USAGE
            "  exit: 0 completed, 1 usage, 2 setup, 3 plant lost, 4 SIGINT/SIGTERM, 5 fault,\n"
            "  7 completed but the plant's safety policy fired (PlantStatus: a fault latched or\n"
            "  0 V forced; docs/can.md, Exit statuses)\n");
}

static int parse_args(int argc, char **argv, opts *o)
{
    memset(o, 0, sizeof *o);
    (void)rrr_ctc_gains_default(&o->gains);
    o->timeout_ms = 5000;
    rrr_hil_rt_opts_default(&o->rt);
    for (int i = 1; i < argc; ++i) {
        int r = rrr_hil_link_arg(&o->link, argc, argv, &i, PROG);
        if (r == 0) {
            r = rrr_hil_rt_arg(&o->rt, argc, argv, &i, PROG);
        }
        if (r < 0) {
            return -1;
        }
        if (r > 0) {
            continue;
        }
        const char *a = argv[i];
        if (strcmp(a, "--realtime") == 0) {
            o->realtime = 1;
        } else if (strcmp(a, "--no-feedforward") == 0) {
            o->gains.feedforward = 0;
        } else if (strcmp(a, "-h") == 0 || strcmp(a, "--help") == 0) {
            usage();
            exit(0);
        } else if (i + 1 >= argc) {
            fprintf(stderr, PROG ": unknown option or missing value: %s\n", a);
            return -1;
        } else {
            const char *v = argv[++i];
            char *end;
            if (strcmp(a, "--reference") == 0) {
                o->ref_path = v;
            } else if (strcmp(a, "--log") == 0) {
                o->log_path = v;
            } else if (strcmp(a, "--set") == 0) {
                if (o->n_sets >= (int)(sizeof o->sets / sizeof o->sets[0])) {
                    fprintf(stderr, PROG ": --set: at most %d parameters\n",
                            (int)(sizeof o->sets / sizeof o->sets[0]));
                    return -1;
                }
                o->sets[o->n_sets++] = v;
            } else if (strcmp(a, "--kp") == 0 || strcmp(a, "--kd") == 0) {
                if (rrr_hil_parse_vec3(v, a[3] == 'p' ? o->gains.kp : o->gains.kd) != 0) {
                    fprintf(stderr, PROG ": %s: expected three numbers a,b,c, got '%s'\n", a, v);
                    return -1;
                }
            } else if (strcmp(a, "--timeout-ms") == 0) {
                const long x = strtol(v, &end, 10);
                if (*end != '\0' || x < 0 || x > 3600000) {
                    fprintf(stderr, PROG ": %s: expected a non-negative integer, got '%s'\n", a, v);
                    return -1;
                }
                o->timeout_ms = (int)x;
            } else {
                fprintf(stderr, PROG ": unknown option %s\n", a);
                return -1;
            }
        }
    }
    if (o->ref_path == NULL) {
        fprintf(stderr, PROG ": --reference REF.csv is required\n");
        return -1;
    }
    return 0;
}

static int64_t now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

/* Record how the run ends; returns code. */
static int end_run(ctrl *c, int code, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
static int end_run(ctrl *c, int code, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    (void)vsnprintf(c->why, sizeof c->why, fmt, ap);
    va_end(ap);
    return code;
}

static int interrupted(ctrl *c)
{
    return end_run(c, RRR_HIL_EXIT_INTERRUPTED, "%s", rrr_hil_stop_signal_name());
}

static int plant_lost(ctrl *c, const char *what, rrr_hil_io io)
{
    return end_run(c, RRR_HIL_EXIT_PEER_LOST, "plant lost: %s: %s%s%s", what, rrr_hil_io_str(io),
                   c->tr->last_error[0] ? ": " : "", c->tr->last_error);
}

/* Send one frame; 0, or RRR_HIL_EXIT_PEER_LOST with why set. */
static int send_frame(ctrl *c, const rrr_hil_frame *f, const char *what)
{
    const rrr_hil_io io = rrr_hil_send(c->tr, f);
    return io == RRR_HIL_IO_OK ? 0 : plant_lost(c, what, io);
}

static int send_heartbeat(ctrl *c, uint8_t nmt)
{
    rrr_hil_frame f;
    const rrr_hil_heartbeat hb = {1u, nmt, c->hb_counter++};
    if (rrr_hil_encode_heartbeat(&hb, &f) != 0) {
        return end_run(c, RRR_HIL_EXIT_FAULT, "heartbeat cannot be encoded");
    }
    return send_frame(c, &f, "send heartbeat");
}

/* Feed one frame; returns 1 when it completed the state with alive counter `counter`. */
static int handle(ctrl *c, const rrr_hil_frame *f)
{
    rrr_hil_msg m;
    const rrr_hil_rx rx = rrr_hil_decode(f, &m);
    ++c->rx_bad[rx];
    if (rx != RRR_HIL_RX_OK) {
        return 0;
    }
    if (m.kind == RRR_HIL_PLANT_STATUS) {
        c->status = m.u.status;
        if (m.u.status.faults != 0u) {
            ++c->status_faulty;
        }
        if (m.u.status.zero_voltage != 0u) {
            ++c->status_zero;
        }
        return 0;
    }
    if (m.kind != RRR_HIL_JOINT_STATE) {
        return 0;
    }
    const rrr_hil_joint_state *js = &m.u.joint;
    if (js->counter != c->pending || (c->have[0] | c->have[1] | c->have[2]) == 0u) {
        if (c->have[0] | c->have[1] | c->have[2]) {
            ++c->out_of_order; /* an incomplete state was overtaken */
        }
        memset(c->have, 0, sizeof c->have);
        c->pending = js->counter;
    }
    c->have[js->joint] = 1;
    c->pq[js->joint] = js->q_rad;
    c->pqd[js->joint] = js->qd_rad_s;
    if (c->have[0] && c->have[1] && c->have[2]) {
        memcpy(c->q, c->pq, sizeof c->q);
        memcpy(c->qd, c->pqd, sizeof c->qd);
        memset(c->have, 0, sizeof c->have);
        ++c->states;
        return 1;
    }
    return 0;
}

/* u_k from the reference row k and the current state; 0 V (enable 0) if rrr_ctc fails. */
static void command(ctrl *c, const opts *o, size_t k, int enable, rrr_hil_voltage_cmd *cmd)
{
    rrr_ctc_output out;
    memset(&out, 0, sizeof out);
    if (enable && rrr_ctc(&c->model, &o->gains, c->ref.q[k], c->ref.qd[k], c->ref.qdd[k], c->q,
                          c->qd, &out) != RRR_OK) {
        ++c->ctc_failed;
        enable = 0;
        memset(&out, 0, sizeof out);
    }
    cmd->counter = (uint8_t)(k & 15u);
    cmd->enable = (uint8_t)enable;
    cmd->reset_fault = 0;
    memcpy(cmd->u_V, out.u, sizeof cmd->u_V);
    /* k, t, q[3], qd[3], (u, u_n, u_c) per joint, enable (rrr_hil_logs.h) */
    _Static_assert(RRR_HIL_CONTROLLER_LOG_COLUMNS == 2 + 3 + 3 + 3 * 3 + 1,
                   "the controller log's row (rrr_robot.hil.logspec)");
    if (c->log != NULL) {
        fprintf(c->log, "%zu,%.17g", k, c->ref.t[k]);
        for (int i = 0; i < 3; ++i) {
            fprintf(c->log, ",%.17g", c->q[i]);
        }
        for (int i = 0; i < 3; ++i) {
            fprintf(c->log, ",%.17g", c->qd[i]);
        }
        for (int i = 0; i < 3; ++i) {
            fprintf(c->log, ",%.17g,%.17g,%.17g", out.u[i], out.u_n[i], out.u_c[i]);
        }
        fprintf(c->log, ",%d\n", enable);
    }
}

/* VoltageCmd(k) and, with_sync, Sync(k): 0, or an exit status with why set. */
static int send_period(ctrl *c, const rrr_hil_voltage_cmd *cmd, uint32_t k, int with_sync)
{
    rrr_hil_frame f;
    if (rrr_hil_encode_voltage_cmd(cmd, &f) != 0) {
        return end_run(c, RRR_HIL_EXIT_FAULT,
                       "VoltageCmd cannot be encoded: u = (%.6g, %.6g, %.6g) V outside the DBC "
                       "range [-30, 30] V (is u_max above 30 V?)",
                       cmd->u_V[0], cmd->u_V[1], cmd->u_V[2]);
    }
    int rc = send_frame(c, &f, "send VoltageCmd");
    if (rc != 0) {
        return rc;
    }
    c->last_cmd_counter = cmd->counter;
    ++c->cmds_sent;
    const rrr_hil_sync s = {k};
    if (with_sync) {
        if (rrr_hil_encode_sync(&s, &f) != 0) {
            return end_run(c, RRR_HIL_EXIT_FAULT, "Sync cannot be encoded");
        }
        rc = send_frame(c, &f, "send Sync");
    }
    if (rc == 0 && k % RRR_HIL_HEARTBEAT_PERIODS == 0u && k > 0u) {
        rc = send_heartbeat(c, RRR_HIL_NMT_OPERATIONAL);
    }
    return rc;
}

/* The end of every run that got a transport: StopCmd (the next alive counter of the command
 * sequence, the reason from the exit status), then the heartbeat "stopped". After a complete run
 * a StopCmd that cannot be sent loses the plant; otherwise both are best effort. */
static int finish(ctrl *c, int rc)
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
        (uint8_t)(c->cmds_sent > 0u ? (c->last_cmd_counter + 1u) & 15u : 0u), (uint8_t)reason};
    rrr_hil_frame f;
    if (rrr_hil_encode_stop_cmd(&stop, &f) != 0) {
        return rc == RRR_HIL_EXIT_OK ? end_run(c, RRR_HIL_EXIT_FAULT, "StopCmd cannot be encoded")
                                     : rc;
    }
    const rrr_hil_io io = rrr_hil_send(c->tr, &f);
    if (io != RRR_HIL_IO_OK && rc == RRR_HIL_EXIT_OK) {
        rc = plant_lost(c, "send StopCmd", io);
    }
    const rrr_hil_heartbeat hb = {1u, RRR_HIL_NMT_STOPPED, c->hb_counter++};
    if (rrr_hil_encode_heartbeat(&hb, &f) == 0) {
        (void)rrr_hil_send(c->tr, &f); /* informational: the plant may be gone already */
    }
    return rc;
}

/* Wait up to --timeout-ms for a frame, in slices so that SIGINT/SIGTERM end the wait at once.
 * want < 0: any frame of the bench; else the complete joint state with alive counter `want`.
 * 0, or an exit status with why set. */
static int wait_frames(ctrl *c, const opts *o, int want, const char *what)
{
    const int64_t deadline = now_ms() + o->timeout_ms;
    for (;;) {
        if (rrr_hil_stop_requested()) {
            return interrupted(c);
        }
        const int64_t left = deadline - now_ms();
        if (left <= 0) {
            return end_run(c, RRR_HIL_EXIT_PEER_LOST, "plant lost: no %s within %d ms (--timeout-ms)",
                           what, o->timeout_ms);
        }
        rrr_hil_frame f;
        const rrr_hil_io io = rrr_hil_recv(c->tr, &f, (int)(left < 100 ? left : 100) * 1000);
        if (io == RRR_HIL_IO_TIMEOUT) {
            continue;
        }
        if (io != RRR_HIL_IO_OK) {
            return plant_lost(c, what, io);
        }
        if (handle(c, &f) ? (want < 0 || c->pending == (uint8_t)want) : want < 0) {
            return 0;
        }
    }
}

/* As a socketcand server, the controller may send nothing before the client's first frame (the
 * plant's boot-up heartbeat): wait for it. */
static int wait_for_peer(ctrl *c, const opts *o)
{
    return o->link.kind == 1 ? wait_frames(c, o, -1, "plant connected") : 0;
}

static int run_lockstep(ctrl *c, const opts *o)
{
    int rc = wait_for_peer(c, o);
    if (rc == 0) {
        rc = send_heartbeat(c, RRR_HIL_NMT_OPERATIONAL);
    }
    for (size_t k = 0; k < c->ref.n && rc == 0; ++k) {
        c->k = (uint32_t)k;
        rc = wait_frames(c, o, (int)(k & 15u), "joint state");
        if (rc == 0) {
            rrr_hil_voltage_cmd cmd;
            command(c, o, k, 1, &cmd);
            rc = send_period(c, &cmd, (uint32_t)k, k + 1u < c->ref.n);
        }
    }
    if (rc == 0) {
        c->k = (uint32_t)c->ref.n;
        rc = end_run(c, RRR_HIL_EXIT_OK, "all %zu periods of the reference", c->ref.n);
    }
    return finish(c, rc);
}

static int run_realtime(ctrl *c, const opts *o, FILE *latency_log)
{
    rrr_hil_rt rt;
    if (rrr_hil_rt_init(&rt, RRR_HIL_PERIOD_S, (uint32_t)c->ref.n, &o->rt, latency_log, PROG) !=
        0) {
        return end_run(c, RRR_HIL_EXIT_SETUP, "out of memory");
    }
    int rc = wait_for_peer(c, o);
    if (rc == 0) {
        rc = send_heartbeat(c, RRR_HIL_NMT_OPERATIONAL);
    }
    c->state_age = STALE_PERIODS + 1u; /* no state yet */
    for (size_t k = 0; k < c->ref.n && rc == 0; ++k) {
        c->k = (uint32_t)k;
        if (rrr_hil_stop_requested()) {
            rc = interrupted(c);
            break;
        }
        rrr_hil_rt_wait(&rt);
        rrr_hil_frame f;
        rrr_hil_io io;
        int fresh = 0;
        while ((io = rrr_hil_recv(c->tr, &f, 0)) == RRR_HIL_IO_OK) {
            fresh |= handle(c, &f);
        }
        if (io != RRR_HIL_IO_TIMEOUT) {
            rc = plant_lost(c, "receive", io);
            break;
        }
        c->state_age = fresh ? 0u : c->state_age + 1u;
        const int ok = c->state_age <= STALE_PERIODS;
        if (!ok) {
            ++c->stale;
        }
        rrr_hil_voltage_cmd cmd;
        command(c, o, k, ok, &cmd);
        rc = send_period(c, &cmd, (uint32_t)k, 0); /* no Sync: the plant keeps its own time */
        rrr_hil_rt_done(&rt);
    }
    if (rc == 0) {
        c->k = (uint32_t)c->ref.n;
        rc = end_run(c, RRR_HIL_EXIT_OK, "all %zu periods of the reference", c->ref.n);
    }
    rc = finish(c, rc);
    printf("RRR_HIL_RT {");
    rrr_hil_rt_report(&rt, stdout, PROG);
    printf("}\n");
    rrr_hil_rt_free(&rt);
    return rc;
}

/* A run that completed (exit 0) while the plant reported the safety policy firing (PlantStatus:
 * a latched fault, or 0 V forced) ends with its own status, as the plant does. */
static int safety_status(ctrl *c, int rc)
{
    if (rc != RRR_HIL_EXIT_OK || (c->status_faulty == 0u && c->status_zero == 0u)) {
        return rc;
    }
    const size_t n = strlen(c->why);
    (void)snprintf(c->why + n, sizeof c->why - n,
                   "; the plant's safety policy fired: %u PlantStatus frames with a fault, %u "
                   "with 0 V",
                   c->status_faulty, c->status_zero);
    return RRR_HIL_EXIT_SAFETY;
}

static void summary(const ctrl *c, int rc)
{
    fprintf(stderr,
            PROG ": %u joint states received; rejected frames: %u bad CRC, %u wrong DLC, %u unknown "
                 "id; %u incomplete states overtaken; %u stale periods; plant status faults 0x%02X "
                 "(%u faulty status frames); rrr_ctc failures %u\n",
            c->states, c->rx_bad[RRR_HIL_RX_BAD_CRC], c->rx_bad[RRR_HIL_RX_BAD_DLC],
            c->rx_bad[RRR_HIL_RX_UNKNOWN_ID], c->out_of_order, c->stale,
            (unsigned)c->status.faults, c->status_faulty, c->ctc_failed);
    printf("RRR_HIL_SUMMARY {\"node\": \"controller\", \"exit\": %d, \"states\": %u, "
           "\"rx_bad_crc\": %u, \"rx_bad_dlc\": %u, \"rx_unknown_id\": %u, \"out_of_order\": %u, "
           "\"stale\": %u, \"plant_faults\": %u, \"plant_status_faulty\": %u, "
           "\"plant_status_zero\": %u, \"ctc_failed\": %u, ",
           rc, c->states, c->rx_bad[RRR_HIL_RX_BAD_CRC], c->rx_bad[RRR_HIL_RX_BAD_DLC],
           c->rx_bad[RRR_HIL_RX_UNKNOWN_ID], c->out_of_order, c->stale,
           (unsigned)c->status.faults, c->status_faulty, c->status_zero, c->ctc_failed);
    rrr_hil_link_json(stdout, c->tr);
    printf("}\n");
    fflush(stdout);
}

int main(int argc, char **argv)
{
    opts o;
    if (parse_args(argc, argv, &o) != 0) {
        usage();
        return RRR_HIL_EXIT_USAGE;
    }
    rrr_hil_install_signals();
    static ctrl c;
    memset(&c, 0, sizeof c);
    char err[512];
    (void)rrr_model_default(&c.model);
    for (int i = 0; i < o.n_sets; ++i) {
        if (rrr_hil_set_model_param(&c.model, o.sets[i], err, sizeof err) != 0) {
            return rrr_hil_report_exit(PROG, RRR_HIL_EXIT_SETUP, 0, "--set: %s", err);
        }
    }
    const char *field = "";
    const rrr_status valid = rrr_model_validate(&c.model, &field);
    if (valid != RRR_OK) {
        return rrr_hil_report_exit(PROG, RRR_HIL_EXIT_SETUP, 0,
                                   "the controller's model is invalid: parameter %s (%s)", field,
                                   rrr_status_str(valid));
    }
    if (rrr_hil_reference_load(o.ref_path, &c.ref, err, sizeof err) != 0) {
        return rrr_hil_report_exit(PROG, RRR_HIL_EXIT_SETUP, 0, "%s", err);
    }
    if (o.log_path != NULL) {
        c.log = fopen(o.log_path, "w");
        if (c.log == NULL) {
            rrr_hil_reference_free(&c.ref);
            return rrr_hil_report_exit(PROG, RRR_HIL_EXIT_SETUP, 0, "cannot write %s",
                                       o.log_path);
        }
        fputs(RRR_HIL_CONTROLLER_LOG_HEADER, c.log); /* gen/rrr_hil_logs.h */
    }
    int log_failed = 0;
    FILE *latency_log = rrr_hil_rt_open_log(&o.rt, o.realtime, PROG, &log_failed);
    if (log_failed) {
        if (c.log) {
            fclose(c.log);
        }
        rrr_hil_reference_free(&c.ref);
        return rrr_hil_report_exit(PROG, RRR_HIL_EXIT_SETUP, 0, "cannot write %s",
                                   o.rt.latency_log);
    }
    static rrr_hil_link link;
    static rrr_hil_framelog frames;
    const uint32_t rx_ids[] = {RRR_BENCH_JOINT_STATE1_FRAME_ID, RRR_BENCH_JOINT_STATE2_FRAME_ID,
                               RRR_BENCH_JOINT_STATE3_FRAME_ID, RRR_BENCH_PLANT_STATUS_FRAME_ID,
                               RRR_BENCH_HEARTBEAT_PLANT_FRAME_ID};
    int rc = end_run(&c, RRR_HIL_EXIT_SETUP, "the transport did not open");
    if (rrr_hil_link_open(&o.link, &link, rx_ids, 5u, PROG, &frames) == 0) {
        c.tr = &link.base;
        rc = safety_status(&c, o.realtime ? run_realtime(&c, &o, latency_log)
                                          : run_lockstep(&c, &o));
        latency_log = NULL; /* the real-time loop owns it */
        (void)rrr_hil_framelog_close(&frames); /* reported in the summary */
        summary(&c, rc);
        rrr_hil_close(c.tr);
    }
    if (latency_log != NULL) {
        fclose(latency_log);
    }
    if (c.log) {
        fclose(c.log);
    }
    rrr_hil_reference_free(&c.ref);
    return rrr_hil_report_exit(PROG, rc, c.k, "%s", c.why);
}
