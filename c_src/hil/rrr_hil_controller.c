/*
 * rrr_hil_controller: the controller node of the CAN bench. Runs the core's computed-torque law
 * (rrr_ctc, eq 15) at 1 kHz along a reference table (CSV: t, q_ref, qd_ref, qdd_ref, one row per
 * period; `rrr hil export-reference` writes it) on the joint states it receives, and sends
 * VoltageCmd + Sync every period. By default it connects to the plant node as a socketcand
 * client.
 *
 * Lockstep (default): heartbeat "operational" first; then for k = 0 .. n-1: wait for the three
 * JointState frames of period k (alive counter k mod 16), compute u_k, send VoltageCmd(k) and,
 * for k < n-1, Sync(k). At the end: heartbeat "stopped". Same sequence as the FMPy master
 * (cosim.run_cosim): the controller sees the plant's state at t_k, the plant integrates over
 * [t_k, t_k+1] with u_k held.
 * Real time: every 1 ms of CLOCK_MONOTONIC (clock_nanosleep TIMER_ABSTIME) with the newest
 * complete joint state; a state older than 3 periods is stale: the controller then sends
 * Enable = 0 (0 V). Jitter and deadline misses are printed at exit.
 *
 * Output: a summary on stderr and "RRR_HIL_SUMMARY {json}" on stdout; with --log, one CSV row per
 * period (k, t, measured q and qd, u, u_n, u_c).
 * Exit status: 0 finished; 1 usage; 2 setup failed; 3 the plant was lost or stayed silent.
 */
#define _POSIX_C_SOURCE 200809L

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hil_codec.h"
#include "hil_node.h"
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
    int fifo_prio;
    int mlock;
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
    uint8_t hb_counter;
    FILE *log;
} ctrl;

static void usage(void)
{
    fprintf(stderr,
            "usage: " PROG " --reference REF.csv (--connect HOST:PORT | --listen HOST:PORT |\n"
            "       --socketcan IF) [--channel NAME] [--realtime [--fifo PRIO] [--mlock]]\n"
            "       [--kp a,b,c] [--kd a,b,c] [--no-feedforward] [--set NAME=VALUE]...\n"
            "       [--timeout-ms N] [--log FILE.csv]\n"
            "  the model is the default robot (rrr_model_default) with the --set parameters\n"
            "  (named as in the FMUs: d1, a2, a3, d2, d3, g, u_max, p[k], kt[i], b[i], f[i,k],\n"
            "  w[i,k]), so the controller's model may differ from the plant's; gains default\n"
            "  to rrr_ctc_gains_default\n");
}

static int parse_args(int argc, char **argv, opts *o)
{
    memset(o, 0, sizeof *o);
    (void)rrr_ctc_gains_default(&o->gains);
    o->timeout_ms = 5000;
    for (int i = 1; i < argc; ++i) {
        const int r = rrr_hil_link_arg(&o->link, argc, argv, &i, PROG);
        if (r < 0) {
            return -1;
        }
        if (r > 0) {
            continue;
        }
        const char *a = argv[i];
        if (strcmp(a, "--realtime") == 0) {
            o->realtime = 1;
        } else if (strcmp(a, "--mlock") == 0) {
            o->mlock = 1;
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
            } else if (strcmp(a, "--timeout-ms") == 0 || strcmp(a, "--fifo") == 0) {
                const long x = strtol(v, &end, 10);
                if (*end != '\0' || x < 0 || x > 3600000) {
                    fprintf(stderr, PROG ": %s: expected a non-negative integer, got '%s'\n", a, v);
                    return -1;
                }
                *(a[2] == 't' ? &o->timeout_ms : &o->fifo_prio) = (int)x;
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

static int send_frame(ctrl *c, const rrr_hil_frame *f)
{
    const rrr_hil_io io = rrr_hil_send(c->tr, f);
    if (io != RRR_HIL_IO_OK) {
        fprintf(stderr, PROG ": send: %s: %s\n", rrr_hil_io_str(io), c->tr->last_error);
        return -1;
    }
    return 0;
}

static int send_heartbeat(ctrl *c, uint8_t nmt)
{
    rrr_hil_frame f;
    const rrr_hil_heartbeat hb = {1u, nmt, c->hb_counter++};
    return rrr_hil_encode_heartbeat(&hb, &f) == 0 ? send_frame(c, &f) : -1;
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

static int send_period(ctrl *c, const rrr_hil_voltage_cmd *cmd, uint32_t k, int with_sync)
{
    rrr_hil_frame f;
    if (rrr_hil_encode_voltage_cmd(cmd, &f) != 0 || send_frame(c, &f) != 0) {
        return -1;
    }
    const rrr_hil_sync s = {k};
    if (with_sync && (rrr_hil_encode_sync(&s, &f) != 0 || send_frame(c, &f) != 0)) {
        return -1;
    }
    if (k % RRR_HIL_HEARTBEAT_PERIODS == 0u && k > 0u) {
        return send_heartbeat(c, RRR_HIL_NMT_OPERATIONAL);
    }
    return 0;
}

/* As a socketcand server, the controller may send nothing before the client's first frame (the
 * plant's boot-up heartbeat): wait for it. */
static int wait_for_peer(ctrl *c, const opts *o)
{
    if (o->link.kind != 1) {
        return 0;
    }
    rrr_hil_frame f;
    for (;;) {
        const rrr_hil_io io = rrr_hil_recv(c->tr, &f, o->timeout_ms * 1000);
        if (io == RRR_HIL_IO_OK) {
            (void)handle(c, &f);
            return 0;
        }
        if (io != RRR_HIL_IO_DISCONNECTED) {
            fprintf(stderr, PROG ": no plant connected within %d ms (%s)\n", o->timeout_ms,
                    rrr_hil_io_str(io));
            return -1;
        }
    }
}

static int run_lockstep(ctrl *c, const opts *o)
{
    if (wait_for_peer(c, o) != 0 || send_heartbeat(c, RRR_HIL_NMT_OPERATIONAL) != 0) {
        return 3;
    }
    for (size_t k = 0; k < c->ref.n && !rrr_hil_stop_requested(); ++k) {
        const uint8_t want = (uint8_t)(k & 15u);
        int complete = 0;
        while (!complete) {
            rrr_hil_frame f;
            const rrr_hil_io io = rrr_hil_recv(c->tr, &f, o->timeout_ms * 1000);
            if (io != RRR_HIL_IO_OK) {
                fprintf(stderr, PROG ": period %zu: waiting for the joint state: %s%s%s\n", k,
                        rrr_hil_io_str(io), c->tr->last_error[0] ? ": " : "", c->tr->last_error);
                return 3;
            }
            complete = handle(c, &f) && c->pending == want;
        }
        rrr_hil_voltage_cmd cmd;
        command(c, o, k, 1, &cmd);
        if (send_period(c, &cmd, (uint32_t)k, k + 1u < c->ref.n) != 0) {
            return 3;
        }
    }
    return send_heartbeat(c, RRR_HIL_NMT_STOPPED) == 0 ? 0 : 3;
}

static int run_realtime(ctrl *c, const opts *o)
{
    rrr_hil_rt rt;
    if (rrr_hil_rt_init(&rt, RRR_HIL_PERIOD_S, (uint32_t)c->ref.n, o->fifo_prio, o->mlock) != 0) {
        return 2;
    }
    int rc = (wait_for_peer(c, o) == 0 && send_heartbeat(c, RRR_HIL_NMT_OPERATIONAL) == 0) ? 0 : 3;
    c->state_age = STALE_PERIODS + 1u; /* no state yet */
    for (size_t k = 0; k < c->ref.n && rc == 0 && !rrr_hil_stop_requested(); ++k) {
        rrr_hil_rt_wait(&rt);
        rrr_hil_frame f;
        rrr_hil_io io;
        int fresh = 0;
        while ((io = rrr_hil_recv(c->tr, &f, 0)) == RRR_HIL_IO_OK) {
            fresh |= handle(c, &f);
        }
        if (io != RRR_HIL_IO_TIMEOUT) {
            fprintf(stderr, PROG ": period %zu: transport %s: %s\n", k, rrr_hil_io_str(io),
                    c->tr->last_error);
            rc = 3;
            break;
        }
        c->state_age = fresh ? 0u : c->state_age + 1u;
        const int ok = c->state_age <= STALE_PERIODS;
        if (!ok) {
            ++c->stale;
        }
        rrr_hil_voltage_cmd cmd;
        command(c, o, k, ok, &cmd);
        if (send_period(c, &cmd, (uint32_t)k, 1) != 0) {
            rc = 3;
        }
        rrr_hil_rt_done(&rt);
    }
    if (rc == 0 && send_heartbeat(c, RRR_HIL_NMT_STOPPED) != 0) {
        rc = 3;
    }
    printf("RRR_HIL_RT {");
    rrr_hil_rt_report(&rt, stdout, PROG);
    printf("}\n");
    rrr_hil_rt_free(&rt);
    return rc;
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
           "\"stale\": %u, \"plant_faults\": %u, \"ctc_failed\": %u, ",
           rc, c->states, c->rx_bad[RRR_HIL_RX_BAD_CRC], c->rx_bad[RRR_HIL_RX_BAD_DLC],
           c->rx_bad[RRR_HIL_RX_UNKNOWN_ID], c->out_of_order, c->stale,
           (unsigned)c->status.faults, c->ctc_failed);
    rrr_hil_link_json(stdout, c->tr);
    printf("}\n");
    fflush(stdout);
}

int main(int argc, char **argv)
{
    opts o;
    if (parse_args(argc, argv, &o) != 0) {
        usage();
        return 1;
    }
    rrr_hil_install_signals();
    static ctrl c;
    memset(&c, 0, sizeof c);
    char err[512];
    (void)rrr_model_default(&c.model);
    for (int i = 0; i < o.n_sets; ++i) {
        if (rrr_hil_set_model_param(&c.model, o.sets[i], err, sizeof err) != 0) {
            fprintf(stderr, PROG ": --set: %s\n", err);
            return 2;
        }
    }
    const char *field = "";
    const rrr_status valid = rrr_model_validate(&c.model, &field);
    if (valid != RRR_OK) {
        fprintf(stderr, PROG ": the controller's model is invalid: parameter %s (%s)\n", field,
                rrr_status_str(valid));
        return 2;
    }
    if (rrr_hil_reference_load(o.ref_path, &c.ref, err, sizeof err) != 0) {
        fprintf(stderr, PROG ": %s\n", err);
        return 2;
    }
    if (o.log_path != NULL) {
        c.log = fopen(o.log_path, "w");
        if (c.log == NULL) {
            fprintf(stderr, PROG ": cannot write %s\n", o.log_path);
            rrr_hil_reference_free(&c.ref);
            return 2;
        }
        fprintf(c.log, "k,t,q[1],q[2],q[3],qd[1],qd[2],qd[3],u[1],u_n[1],u_c[1],u[2],u_n[2],"
                       "u_c[2],u[3],u_n[3],u_c[3],enable\n");
    }
    static rrr_hil_link link;
    const uint32_t rx_ids[] = {RRR_BENCH_JOINT_STATE1_FRAME_ID, RRR_BENCH_JOINT_STATE2_FRAME_ID,
                               RRR_BENCH_JOINT_STATE3_FRAME_ID, RRR_BENCH_PLANT_STATUS_FRAME_ID,
                               RRR_BENCH_HEARTBEAT_PLANT_FRAME_ID};
    int rc = 2;
    if (rrr_hil_link_open(&o.link, &link, rx_ids, 5u, PROG) == 0) {
        c.tr = &link.base;
        rc = o.realtime ? run_realtime(&c, &o) : run_lockstep(&c, &o);
        summary(&c, rc);
        rrr_hil_close(c.tr);
    }
    if (c.log) {
        fclose(c.log);
    }
    rrr_hil_reference_free(&c.ref);
    return rc;
}
