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

#include "hil_canopen_master.h"
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
    int canopen;         /* --profile canopen: master of three CiA 402 drives */
    uint8_t node_ids[3]; /* --node-ids a,b,c (default 1,2,3) */
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
    /* --profile canopen */
    uint32_t rated_mNm[3];   /* 0x6076 of each drive */
    uint32_t increments[3];  /* 0x608F sub 1 (per revolution, sub 2 = 1) */
    rrr_com_feedback fb[3];  /* TPDO1/TPDO2 of the current SYNC */
    uint32_t syncs;          /* SYNCs sent */
    uint32_t sdo_transfers;  /* SDO transfers confirmed */
    int16_t pm_max[3];       /* largest |target torque| sent, per mille */
    uint32_t late_tpdos;     /* real time: SYNCs whose TPDOs had not all come by the deadline */
    uint32_t tpdo_n[3][2];   /* real time: TPDO1, TPDO2 of each drive received so far */
    uint32_t heartbeats;     /* real time: the master's heartbeats sent */
} ctrl;

static void usage(void)
{
    fprintf(stderr,
            "usage: " PROG " --reference REF.csv (--connect HOST:PORT | --listen HOST:PORT |\n"
            "       --socketcan IF)\n" RRR_HIL_LINK_USAGE
            "       [--realtime [--fifo PRIO] [--mlock] [--cpu N] [--spin-us N]\n"
            "       [--latency-log FILE.csv]]\n"
            "       [--kp a,b,c] [--kd a,b,c] [--no-feedforward] [--set NAME=VALUE]...\n"
            "       [--timeout-ms N] [--log FILE.csv] [--profile dbc|canopen]\n"
            "       [--node-ids a,b,c]\n"
            "  the model is the default robot (rrr_model_default) with the --set parameters\n"
            "  (named as in the FMUs: d1, a2, a3, d2, d3, g, u_max, p[k], kt[i], b[i], f[i,k],\n"
            "  w[i,k]), so the controller's model may differ from the plant's; gains default\n"
            "  to rrr_ctc_gains_default; --timeout-ms (5000): longest wait for a joint state\n"
            "  real time: Sync is not sent (it is the lockstep time base)\n"
            "  --profile canopen: a CANopen master of three CiA 402 drives (node ids --node-ids,\n"
            "  default 1,2,3): NMT, SDO configuration (CST), the 402 state machine to\n"
            "  OPERATION ENABLED, then one SYNC per period with the target torques (lockstep;\n"
            "  with --realtime: SYNC on the clock every 1 ms, the master's heartbeat (node 127,\n"
            "  20 ms) and each drive's consumer 0x1016 of it (100 ms); docs/canopen.md)\n"
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
    o->node_ids[0] = 1;
    o->node_ids[1] = 2;
    o->node_ids[2] = 3;
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
            } else if ((r = rrr_hil_profile_arg(a, v, &o->canopen, o->node_ids, PROG)) != 0) {
                if (r < 0) {
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
    if (o->canopen && o->realtime) {
        for (unsigned j = 0; j < 3u; ++j) {
            if (o->node_ids[j] == RRR_COM_MASTER_ID) {
                fprintf(stderr, PROG ": --profile canopen --realtime: node id %u is the master's "
                                     "own (its heartbeat): give the drives others\n",
                        (unsigned)RRR_COM_MASTER_ID);
                return -1;
            }
        }
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

/* The next frame before the deadline (ms of now_ms), waiting in slices so that SIGINT/SIGTERM end
 * the wait at once; 0, or an exit status with why set. */
static int recv_until(ctrl *c, int64_t deadline, const opts *o, const char *what,
                      rrr_hil_frame *f)
{
    for (;;) {
        if (rrr_hil_stop_requested()) {
            return interrupted(c);
        }
        const int64_t left = deadline - now_ms();
        if (left <= 0) {
            return end_run(c, RRR_HIL_EXIT_PEER_LOST, "plant lost: no %s within %d ms (--timeout-ms)",
                           what, o->timeout_ms);
        }
        const rrr_hil_io io = rrr_hil_recv(c->tr, f, (int)(left < 100 ? left : 100) * 1000);
        if (io == RRR_HIL_IO_OK) {
            return 0;
        }
        if (io != RRR_HIL_IO_TIMEOUT) {
            return plant_lost(c, what, io);
        }
    }
}

/* Wait up to --timeout-ms for a frame. want < 0: any frame of the bench; else the complete joint
 * state with alive counter `want`. 0, or an exit status with why set. */
static int wait_frames(ctrl *c, const opts *o, int want, const char *what)
{
    const int64_t deadline = now_ms() + o->timeout_ms;
    for (;;) {
        rrr_hil_frame f;
        const int rc = recv_until(c, deadline, o, what, &f);
        if (rc != 0) {
            return rc;
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

/* ---- --profile canopen: a CANopen master of three CiA 402 drives (docs/canopen.md) ---------- */

/* The PDO mapping this master decodes, as 0x1600/0x1A00/0x1A01 hold it (index << 16 | sub << 8 |
 * bits), and the COB-IDs of RPDO1, TPDO1, TPDO2 (0x1400/0x1800/0x1801 sub 1) less the node id. */
static const struct {
    uint16_t map_index, comm_index, cob_base;
    uint32_t entries[2];
} CO_PDOS[3] = {{0x1600u, 0x1400u, 0x200u, {0x60400010u, 0x60710010u}},
                {0x1A00u, 0x1800u, 0x180u, {0x60410010u, 0x60640020u}},
                {0x1A01u, 0x1801u, 0x280u, {0x606C0020u, 0x60770010u}}};
#define CO_SW_MASK 0x6Fu

/* One expedited SDO transfer (download: size 1, 2 or 4 bytes of *value; upload: size 0, the
 * value into *value). 0, or an exit status with why set: an abort or an answer this master cannot
 * use is a setup failure, no answer within --timeout-ms a lost plant. */
static int co_sdo(ctrl *c, const opts *o, uint8_t node, uint16_t index, uint8_t sub,
                  unsigned size, uint32_t *value)
{
    char what[96];
    const int upload = size == 0u;
    (void)snprintf(what, sizeof what, "answer to the SDO %s of drive %u, 0x%04X sub %u",
                   upload ? "upload" : "download", (unsigned)node, (unsigned)index, (unsigned)sub);
    rrr_hil_frame f;
    if ((upload ? rrr_com_sdo_upload(node, index, sub, &f)
                : rrr_com_sdo_download(node, index, sub, *value, size, &f)) != 0) {
        return end_run(c, RRR_HIL_EXIT_FAULT, "SDO request of drive %u cannot be encoded",
                       (unsigned)node);
    }
    int rc = send_frame(c, &f, "send an SDO request");
    const int64_t deadline = now_ms() + o->timeout_ms;
    while (rc == 0) {
        rc = recv_until(c, deadline, o, what, &f);
        uint32_t v = 0;
        const rrr_com_sdo_answer a =
            rc == 0 ? rrr_com_sdo_reply(&f, node, index, sub, upload, &v) : RRR_COM_SDO_OTHER;
        if (a == RRR_COM_SDO_DONE) {
            ++c->sdo_transfers;
            if (upload) {
                *value = v;
            }
            return 0;
        }
        if (a == RRR_COM_SDO_ABORT) {
            return end_run(c, RRR_HIL_EXIT_SETUP, "drive %u: SDO %s of 0x%04X sub %u aborted: "
                           "code 0x%08X (CiA 301)", (unsigned)node, upload ? "upload" : "download",
                           (unsigned)index, (unsigned)sub, v);
        }
        if (a == RRR_COM_SDO_BAD) {
            return end_run(c, RRR_HIL_EXIT_SETUP, "drive %u: the %s is not an expedited SDO "
                           "answer this master handles (command byte 0x%02X, DLC %u)",
                           (unsigned)node, what, (unsigned)f.data[0], (unsigned)f.dlc);
        }
    }
    return rc;
}

static int co_read(ctrl *c, const opts *o, uint8_t node, uint16_t index, uint8_t sub,
                   uint32_t *value)
{
    return co_sdo(c, o, node, index, sub, 0u, value);
}

static int co_write(ctrl *c, const opts *o, uint8_t node, uint16_t index, uint8_t sub,
                    uint32_t value, unsigned size)
{
    return co_sdo(c, o, node, index, sub, size, &value);
}

static int co_send_nmt(ctrl *c, uint8_t command_)
{
    rrr_hil_frame f;
    rrr_com_nmt(command_, 0u, &f);
    return send_frame(c, &f, "send NMT");
}

/* NMT reset node (a socketcand server drops the power-on boot-up): every drive's boot-up. */
static int co_boot(ctrl *c, const opts *o)
{
    int rc = co_send_nmt(c, RRR_COM_NMT_RESET_NODE);
    const int64_t deadline = now_ms() + o->timeout_ms;
    unsigned want = 7u;
    while (rc == 0 && want != 0u) {
        rrr_hil_frame f;
        rc = recv_until(c, deadline, o, "boot-up message of every drive after NMT reset node", &f);
        for (unsigned j = 0; rc == 0 && j < 3u; ++j) {
            if (!f.extended && f.id == 0x700u + o->node_ids[j] && f.dlc == 1u && f.data[0] == 0u) {
                want &= ~(1u << j);
            }
        }
    }
    return rc;
}

/* SDO: the mode CST, the rated torque, the encoder resolution, the PDO mapping and COB-IDs. */
static int co_configure(ctrl *c, const opts *o)
{
    int rc = 0;
    for (unsigned j = 0; rc == 0 && j < 3u; ++j) {
        const uint8_t id = o->node_ids[j];
        uint32_t mode = 0, rev = 0;
        rc = co_write(c, o, id, 0x6060u, 0u, RRR_COM_MODE_CST, 1u);
        if (rc == 0) {
            rc = co_read(c, o, id, 0x6061u, 0u, &mode);
        }
        if (rc == 0 && mode != RRR_COM_MODE_CST) {
            rc = end_run(c, RRR_HIL_EXIT_SETUP, "drive %u: mode of operation display 0x6061 = "
                         "%u, not %d (cyclic synchronous torque)", (unsigned)id, mode,
                         RRR_COM_MODE_CST);
        }
        if (rc == 0) {
            rc = co_read(c, o, id, 0x6076u, 0u, &c->rated_mNm[j]);
        }
        if (rc == 0) {
            rc = co_read(c, o, id, 0x608Fu, 1u, &c->increments[j]);
        }
        if (rc == 0) {
            rc = co_read(c, o, id, 0x608Fu, 2u, &rev);
        }
        if (rc == 0 && (c->rated_mNm[j] == 0u || c->increments[j] == 0u ||
                        c->increments[j] > 0x7FFFFFFFu || rev != 1u)) {
            rc = end_run(c, RRR_HIL_EXIT_SETUP, "drive %u: rated torque %u mN m, encoder %u/%u: "
                         "not a configuration this master handles", (unsigned)id,
                         c->rated_mNm[j], c->increments[j], rev);
        }
        for (unsigned p = 0; rc == 0 && p < 3u; ++p) {
            uint32_t count = 0, entry = 0, cob = 0;
            rc = co_read(c, o, id, CO_PDOS[p].map_index, 0u, &count);
            for (uint8_t e = 0; rc == 0 && e < 2u; ++e) {
                rc = co_read(c, o, id, CO_PDOS[p].map_index, (uint8_t)(e + 1u), &entry);
                if (rc == 0 && (count != 2u || entry != CO_PDOS[p].entries[e])) {
                    rc = end_run(c, RRR_HIL_EXIT_SETUP, "drive %u: PDO mapping 0x%04X: %u "
                                 "entries, sub %u = 0x%08X; this master decodes 0x%08X, 0x%08X",
                                 (unsigned)id, (unsigned)CO_PDOS[p].map_index, count,
                                 (unsigned)e + 1u, entry, CO_PDOS[p].entries[0],
                                 CO_PDOS[p].entries[1]);
                }
            }
            if (rc == 0) {
                rc = co_read(c, o, id, CO_PDOS[p].comm_index, 1u, &cob);
            }
            if (rc == 0 && cob != CO_PDOS[p].cob_base + id) {
                rc = end_run(c, RRR_HIL_EXIT_SETUP, "drive %u: COB-ID 0x%04X sub 1 = 0x%08X, "
                             "not the valid default 0x%03X", (unsigned)id,
                             (unsigned)CO_PDOS[p].comm_index, cob,
                             (unsigned)(CO_PDOS[p].cob_base + id));
            }
        }
    }
    return rc;
}

/* The 402 state machine to OPERATION ENABLED by SDO, in pre-operational (no SYNC: the plant is
 * held at its initial state): shutdown, switch on, enable operation, each checked on the
 * statusword; then NMT start of all nodes. */
static int co_enable(ctrl *c, const opts *o)
{
    static const struct {
        uint16_t controlword, statusword;
        const char *state;
    } steps[3] = {{0x06u, 0x21u, "READY TO SWITCH ON"},
                  {0x07u, 0x23u, "SWITCHED ON"},
                  {0x0Fu, 0x27u, "OPERATION ENABLED"}};
    int rc = 0;
    for (unsigned j = 0; rc == 0 && j < 3u; ++j) {
        for (unsigned s = 0; rc == 0 && s < 3u; ++s) {
            uint32_t sw = 0, code = 0;
            rc = co_write(c, o, o->node_ids[j], 0x6040u, 0u, steps[s].controlword, 2u);
            if (rc == 0) {
                rc = co_read(c, o, o->node_ids[j], 0x6041u, 0u, &sw);
            }
            if (rc == 0 && (sw & CO_SW_MASK) != steps[s].statusword) {
                (void)co_read(c, o, o->node_ids[j], 0x603Fu, 0u, &code);
                rc = end_run(c, RRR_HIL_EXIT_SETUP, "drive %u did not reach %s after controlword "
                             "0x%02X: statusword 0x%04X, error code 0x%04X", (unsigned)o->node_ids[j],
                             steps[s].state, (unsigned)steps[s].controlword, sw, code);
            }
        }
    }
    return rc == 0 ? co_send_nmt(c, RRR_COM_NMT_START) : rc;
}

/* The RPDO1 of each drive (controlword 0x0F, target torque), one SYNC, then the six TPDOs: the
 * decoded state into c->q, c->qd. An EMCY, or a drive that left OPERATION ENABLED, ends the run:
 * the drive's safety reaction fired. 0, or an exit status with why set. */
static int co_period(ctrl *c, const opts *o, const int16_t pm[3], uint32_t k)
{
    rrr_hil_frame f;
    int rc = 0;
    for (unsigned j = 0; rc == 0 && j < 3u; ++j) {
        rrr_com_rpdo1(o->node_ids[j], 0x0Fu, pm[j], &f);
        rc = send_frame(c, &f, "send RPDO1");
        const int16_t a = (int16_t)(pm[j] < 0 ? -pm[j] : pm[j]);
        if (a > c->pm_max[j]) {
            c->pm_max[j] = a;
        }
    }
    if (rc == 0) {
        rrr_com_sync(&f);
        rc = send_frame(c, &f, "send SYNC");
    }
    if (rc != 0) {
        return rc;
    }
    ++c->syncs;
    memset(c->fb, 0, sizeof c->fb);
    const int64_t deadline = now_ms() + o->timeout_ms;
    char what[64];
    (void)snprintf(what, sizeof what, "TPDOs of SYNC %u", (unsigned)k);
    while ((c->fb[0].have & c->fb[1].have & c->fb[2].have) != 3u) {
        rc = recv_until(c, deadline, o, what, &f);
        if (rc != 0) {
            return rc;
        }
        uint16_t code = 0;
        const uint8_t from = rrr_com_emcy(&f, &code);
        if (from != 0u) {
            return end_run(c, RRR_HIL_EXIT_SAFETY, "SYNC %u: EMCY 0x%04X from drive %u",
                           (unsigned)k, (unsigned)code, (unsigned)from);
        }
        for (unsigned j = 0; j < 3u; ++j) {
            if (rrr_com_tpdo(&f, o->node_ids[j], &c->fb[j]) < 0) {
                ++c->rx_bad[RRR_HIL_RX_BAD_DLC];
            }
        }
    }
    for (unsigned j = 0; j < 3u; ++j) {
        if ((c->fb[j].statusword & CO_SW_MASK) != 0x27u) {
            return end_run(c, RRR_HIL_EXIT_SAFETY, "SYNC %u: drive %u left OPERATION ENABLED "
                           "(statusword 0x%04X)", (unsigned)k, (unsigned)o->node_ids[j],
                           (unsigned)c->fb[j].statusword);
        }
        c->q[j] = rrr_com_inc_to_rad(c->fb[j].position_inc, c->increments[j]);
        c->qd[j] = rrr_com_inc_to_rad(c->fb[j].velocity_inc, c->increments[j]);
    }
    ++c->states;
    return 0;
}

/* us before the next release: the real-time master stops waiting for a SYNC's TPDOs, runs the
 * law on the newest it has and sends the RPDOs (as the Python master's RPDO_GUARD_US). */
#define CO_RPDO_GUARD_US 200

static int64_t co_ns(const struct timespec *t)
{
    return (int64_t)t->tv_sec * 1000000000 + t->tv_nsec;
}

static int64_t co_now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return co_ns(&ts);
}

static int co_send_heartbeat(ctrl *c)
{
    rrr_hil_frame f;
    rrr_com_heartbeat(RRR_COM_MASTER_ID, 0x05u, &f);
    ++c->heartbeats;
    return send_frame(c, &f, "send the master's heartbeat");
}

/* Each drive's heartbeat consumer 0x1016 sub 1 of the master (node id << 16 | ms; 0: off). */
static int co_consumer(ctrl *c, const opts *o, uint32_t ms)
{
    int rc = 0;
    for (unsigned j = 0; rc == 0 && j < 3u; ++j) {
        rc = co_write(c, o, o->node_ids[j], 0x1016u, 1u,
                      ms ? ((uint32_t)RRR_COM_MASTER_ID << 16) | ms : 0u, 4u);
    }
    return rc;
}

static int co_tpdos_reach(const ctrl *c, uint32_t want)
{
    for (unsigned j = 0; j < 3u; ++j) {
        if (c->tpdo_n[j][0] < want || c->tpdo_n[j][1] < want) {
            return 0;
        }
    }
    return 1;
}

/* The frames of the drives until every TPDO has come k + 1 times (those of SYNC k: a SYNC's
 * TPDOs that come late are counted, so the next SYNC's are not mistaken for them) or
 * @p deadline_ns: 1 complete, 0 not (the newest state stays), or an exit status (< 0 negated)
 * with why set. */
static int co_take(ctrl *c, const opts *o, int64_t deadline_ns, uint32_t k)
{
    while (!co_tpdos_reach(c, k + 1u)) {
        if (rrr_hil_stop_requested()) {
            return -interrupted(c);
        }
        const int64_t left_us = (deadline_ns - co_now_ns()) / 1000;
        if (left_us <= 0) {
            return 0;
        }
        rrr_hil_frame f;
        const rrr_hil_io io = rrr_hil_recv(c->tr, &f, (int)(left_us < 100000 ? left_us : 100000));
        if (io == RRR_HIL_IO_TIMEOUT) {
            continue;
        }
        if (io != RRR_HIL_IO_OK) {
            return -plant_lost(c, "receive", io);
        }
        uint16_t code = 0;
        const uint8_t from = rrr_com_emcy(&f, &code);
        if (from != 0u) {
            return -end_run(c, RRR_HIL_EXIT_SAFETY, "SYNC %u: EMCY 0x%04X from drive %u",
                            (unsigned)k, (unsigned)code, (unsigned)from);
        }
        for (unsigned j = 0; j < 3u; ++j) {
            const int r = rrr_com_tpdo(&f, o->node_ids[j], &c->fb[j]);
            if (r < 0) {
                ++c->rx_bad[RRR_HIL_RX_BAD_DLC];
            } else if (r > 0) {
                ++c->tpdo_n[j][f.id == 0x180u + o->node_ids[j] ? 0 : 1];
            }
        }
    }
    for (unsigned j = 0; j < 3u; ++j) {
        if ((c->fb[j].statusword & CO_SW_MASK) != 0x27u) {
            return -end_run(c, RRR_HIL_EXIT_SAFETY, "SYNC %u: drive %u left OPERATION ENABLED "
                            "(statusword 0x%04X)", (unsigned)k, (unsigned)o->node_ids[j],
                            (unsigned)c->fb[j].statusword);
        }
        c->q[j] = rrr_com_inc_to_rad(c->fb[j].position_inc, c->increments[j]);
        c->qd[j] = rrr_com_inc_to_rad(c->fb[j].velocity_inc, c->increments[j]);
    }
    ++c->states;
    return 1;
}

/* Real time (--realtime): the master's heartbeat (RRR_COM_HEARTBEAT_MS) and the drives'
 * consumer of it (RRR_COM_CONSUMER_MS); then per period on the rrr_hil_rt clock: the heartbeat
 * when due, one SYNC at the release, the TPDOs of that SYNC until CO_RPDO_GUARD_US before the
 * next release (later ones: a late SYNC, the law on the newest state), the law and the RPDOs. */
static int co_run_realtime(ctrl *c, const opts *o, rrr_hil_rt *rt)
{
    int rc = co_send_heartbeat(c);
    if (rc == 0) {
        rc = co_consumer(c, o, RRR_COM_CONSUMER_MS);
    }
    const int16_t zero[3] = {0, 0, 0};
    rrr_hil_frame f;
    for (unsigned j = 0; rc == 0 && j < 3u; ++j) {
        rrr_com_rpdo1(o->node_ids[j], 0x0Fu, zero[j], &f);
        rc = send_frame(c, &f, "send RPDO1");
    }
    const int64_t period_ns = rt->period_ns;
    for (size_t k = 0; k < c->ref.n && rc == 0; ++k) {
        c->k = (uint32_t)k;
        rrr_hil_rt_wait(rt);
        const int64_t release = co_ns(&rt->next);
        if (k % RRR_COM_HEARTBEAT_MS == 0u && k > 0u) {
            rc = co_send_heartbeat(c);
        }
        if (rc == 0) {
            rrr_com_sync(&f);
            rc = send_frame(c, &f, "send SYNC");
        }
        if (rc != 0) {
            break;
        }
        ++c->syncs;
        const int got = co_take(c, o, k ? release + period_ns - CO_RPDO_GUARD_US * 1000
                                        : release + (int64_t)o->timeout_ms * 1000000, (uint32_t)k);
        if (got < 0) {
            rc = -got;
            break;
        }
        if (got == 0) {
            if (k == 0u) {
                rc = end_run(c, RRR_HIL_EXIT_PEER_LOST, "plant lost: no TPDOs of SYNC 0 within "
                             "%d ms (--timeout-ms)", o->timeout_ms);
                break;
            }
            ++c->late_tpdos;
        }
        rrr_hil_voltage_cmd cmd;
        command(c, o, k, 1, &cmd);
        for (unsigned j = 0; rc == 0 && j < 3u && k + 1u < c->ref.n; ++j) {
            const int16_t pm = rrr_com_torque_pm(cmd.u_V[j], c->model.kt[j], c->rated_mNm[j]);
            const int16_t a = (int16_t)(pm < 0 ? -pm : pm);
            if (a > c->pm_max[j]) {
                c->pm_max[j] = a;
            }
            rrr_com_rpdo1(o->node_ids[j], 0x0Fu, pm, &f);
            rc = send_frame(c, &f, "send RPDO1");
        }
        rrr_hil_rt_done(rt);
    }
    if (rc == 0) { /* the consumers off before the heartbeat stops */
        rc = co_consumer(c, o, 0u);
    }
    return rc;
}

/* As the Python master (rrr_robot.hil.canopen_master): boot, configure, enable; the first SYNC
 * gives the initial state (no step); then for k = 0 .. n-1: u_k = ctc(state of SYNC k), the
 * target torques k_t u_k in per mille and, for k < n-1, SYNC k+1. At the end: controlword 0
 * (disable voltage) by SDO and NMT stop; after a failed run NMT stop only, best effort. */
static int run_canopen(ctrl *c, const opts *o, rrr_hil_rt *rt)
{
    int rc = co_boot(c, o);
    if (rc == 0) {
        rc = co_configure(c, o);
    }
    if (rc == 0) {
        rc = co_enable(c, o);
    }
    if (rt != NULL) {
        if (rc == 0) {
            rc = co_run_realtime(c, o, rt);
        }
    } else if (rc == 0) {
        const int16_t zero[3] = {0, 0, 0};
        rc = co_period(c, o, zero, 0u);
    }
    for (size_t k = 0; rt == NULL && k < c->ref.n && rc == 0; ++k) {
        c->k = (uint32_t)k;
        rrr_hil_voltage_cmd cmd;
        command(c, o, k, 1, &cmd);
        int16_t pm[3];
        for (unsigned j = 0; j < 3u; ++j) {
            pm[j] = rrr_com_torque_pm(cmd.u_V[j], c->model.kt[j], c->rated_mNm[j]);
        }
        if (k + 1u < c->ref.n) {
            rc = co_period(c, o, pm, (uint32_t)(k + 1u));
        }
    }
    if (rc == 0) {
        c->k = (uint32_t)c->ref.n;
        for (unsigned j = 0; rc == 0 && j < 3u; ++j) {
            rc = co_write(c, o, o->node_ids[j], 0x6040u, 0u, 0u, 2u);
        }
        if (rc == 0) {
            rc = co_send_nmt(c, RRR_COM_NMT_STOP);
        }
        if (rc == 0) {
            rc = end_run(c, RRR_HIL_EXIT_OK, "all %zu periods of the reference", c->ref.n);
        }
    } else {
        (void)co_send_nmt(c, RRR_COM_NMT_STOP); /* best effort: the plant may be gone */
    }
    return rc;
}

static void co_summary(const ctrl *c, const opts *o, int rc)
{
    fprintf(stderr, PROG ": CANopen master of drives %u, %u, %u: %u SYNCs, %u states, %u SDO "
                         "transfers, %u TPDOs of a wrong length; rrr_ctc failures %u\n",
            (unsigned)o->node_ids[0], (unsigned)o->node_ids[1], (unsigned)o->node_ids[2],
            c->syncs, c->states, c->sdo_transfers, c->rx_bad[RRR_HIL_RX_BAD_DLC], c->ctc_failed);
    printf("RRR_HIL_SUMMARY {\"node\": \"controller\", \"profile\": \"canopen\", \"exit\": %d, "
           "\"node_ids\": [%u, %u, %u], \"syncs\": %u, \"states\": %u, \"sdo_transfers\": %u, "
           "\"tpdo_bad_length\": %u, \"ctc_failed\": %u, "
           "\"rated_torque_mNm\": [%u, %u, %u], \"increments_per_revolution\": [%u, %u, %u], "
           "\"target_torque_per_mille_max_abs\": [%d, %d, %d], \"late_tpdos\": %u, "
           "\"heartbeats\": %u, ",
           rc, (unsigned)o->node_ids[0], (unsigned)o->node_ids[1], (unsigned)o->node_ids[2],
           c->syncs, c->states, c->sdo_transfers, c->rx_bad[RRR_HIL_RX_BAD_DLC], c->ctc_failed,
           c->rated_mNm[0], c->rated_mNm[1], c->rated_mNm[2], c->increments[0], c->increments[1],
           c->increments[2], c->pm_max[0], c->pm_max[1], c->pm_max[2], c->late_tpdos,
           c->heartbeats);
    rrr_hil_link_json(stdout, c->tr);
    printf("}\n");
    fflush(stdout);
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
    const uint32_t dbc_ids[] = {RRR_BENCH_JOINT_STATE1_FRAME_ID, RRR_BENCH_JOINT_STATE2_FRAME_ID,
                                RRR_BENCH_JOINT_STATE3_FRAME_ID, RRR_BENCH_PLANT_STATUS_FRAME_ID,
                                RRR_BENCH_HEARTBEAT_PLANT_FRAME_ID};
    uint32_t co_ids[15]; /* per drive: TPDO1, TPDO2, SDO answers, heartbeat / boot-up, EMCY */
    for (unsigned j = 0; j < 3u; ++j) {
        const uint32_t base[5] = {0x180u, 0x280u, 0x580u, 0x700u, 0x080u};
        for (unsigned b = 0; b < 5u; ++b) {
            co_ids[5u * j + b] = base[b] + o.node_ids[j];
        }
    }
    int rc = end_run(&c, RRR_HIL_EXIT_SETUP, "the transport did not open");
    if (rrr_hil_link_open(&o.link, &link, o.canopen ? co_ids : dbc_ids, o.canopen ? 15u : 5u,
                          PROG, &frames) == 0) {
        c.tr = &link.base;
        if (o.canopen && o.realtime) {
            static rrr_hil_rt rt;
            if (rrr_hil_rt_init(&rt, RRR_HIL_PERIOD_S, (uint32_t)c.ref.n, &o.rt, latency_log,
                                PROG) != 0) {
                rc = end_run(&c, RRR_HIL_EXIT_SETUP, "out of memory");
            } else {
                rc = run_canopen(&c, &o, &rt);
                printf("RRR_HIL_RT {");
                rrr_hil_rt_report(&rt, stdout, PROG);
                printf("}\n");
                rrr_hil_rt_free(&rt);
            }
            latency_log = NULL; /* the real-time loop owns it */
        } else if (o.canopen) {
            rc = run_canopen(&c, &o, NULL);
        } else {
            rc = safety_status(&c, o.realtime ? run_realtime(&c, &o, latency_log)
                                              : run_lockstep(&c, &o));
            latency_log = NULL; /* the real-time loop owns it */
        }
        (void)rrr_hil_framelog_close(&frames); /* reported in the summary */
        if (o.canopen) {
            co_summary(&c, &o, rc);
        } else {
            summary(&c, rc);
        }
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
