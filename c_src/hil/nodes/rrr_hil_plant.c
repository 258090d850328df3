/*
 * rrr_hil_plant: the plant node of the CAN bench. Runs the plant FMU (the same rrr_plant binary
 * the Python co-simulation uses, loaded with dlopen) and exchanges the DBC's frames over a
 * transport. By default it is the socketcand server the controller (C node or python-can)
 * connects to.
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
 *
 * Output: a summary on stderr and one line "RRR_HIL_SUMMARY {json}" on stdout at exit, then one
 * line on stderr that says how the run ended ("rrr_hil_plant: exit 3 (peer lost) at period 57:
 * ..."); with --log, one CSV row per period (k, t, q, qd, applied u, zero, faults, and the FMU's
 * qdd and tip).
 * Exit status (rrr_hil_exit, hil_node.h): 0 the controller's StopCmd "end of run" (or --duration
 * in real time); 1 usage; 2 setup failed (FMU, transport); 3 the controller was lost (hang-up,
 * silence, transport error); 4 SIGINT/SIGTERM; 5 the FMU failed; 6 the controller's StopCmd
 * gave another reason (interrupted, fault, plant lost); 7 the run ended as for 0, but the safety
 * policy fired (a fault latched, even if reset later, or 0 V forced for at least one period).
 */
#define _POSIX_C_SOURCE 200809L

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>

#include "hil_canopen.h"
#include "hil_codec.h"
#include "hil_fmu.h"
#include "hil_node.h"
#include "hil_supervisor.h"
#include "rrr_hil_logs.h"

#define PROG "rrr_hil_plant"
#define MAX_SETS 64

typedef struct opts {
    rrr_hil_link_opts link;
    const char *fmu_dir;
    const char *log_path;
    int realtime;
    double duration_s;
    double q0[3], qd0[3];
    int have_q0, have_qd0;
    const char *set_name[MAX_SETS];
    double set_value[MAX_SETS];
    int n_set;
    rrr_hil_sup_config sup;
    rrr_hil_rt_opts rt;
    int canopen;         /* --profile canopen: three CiA 402 drives (docs/canopen.md) */
    uint8_t node_ids[3]; /* --node-ids a,b,c (default 1,2,3) */
} opts;

typedef struct plant {
    rrr_hil_fmu fmu;
    fmi2ValueReference vr_u[3];
    fmi2ValueReference vr_x[6]; /* q[1..3], qd[1..3] */
    fmi2ValueReference vr_y[6]; /* qdd[1..3], tip.x, tip.y, tip.z (logged only) */
    double x[6];
    double y[6];
    double u[3];
    rrr_hil_sup sup;
    rrr_hil_transport *tr;
    uint32_t k;           /* periods advanced */
    uint32_t tx_state_range; /* states that could not be encoded (outside the DBC range) */
    uint8_t hb_counter;
    uint8_t ctrl_nmt;     /* last NMT state of the controller heartbeat, 255 before any */
    int started;          /* the controller's first frame arrived (lockstep) */
    int64_t last_rx_ms;   /* CLOCK_MONOTONIC time of the last frame received, ms */
    char why[320];        /* how the run ended (the exit line) */
    uint32_t rx_bad[RRR_HIL_RX_COUNT]; /* decode results of all frames */
    uint32_t rx_ignored;  /* frames of the bench not meant for the plant */
    FILE *log;
    uint8_t log_zero;     /* logged: 0 V forced over the last period */
    uint8_t log_faults;   /* logged: latched faults (DBC: RRR_HIL_FAULT_*; CANopen: bit i axis i) */
    /* --profile canopen */
    rrr_co_node co[3];
    double kt[3];         /* torque constants of the plant (u = tau / k_t, eq 8) */
    int synced;           /* the first SYNC in operational was seen (it does not step) */
    uint32_t co_faults;   /* faults latched by the drives over the run */
    const char *rt_setup; /* --realtime: what rrr_hil_rt_init applied (NULL: lockstep) */
} plant;

/* What handle() made of a frame. */
enum { EV_NONE = 0, EV_SYNC, EV_STOP };

static void usage(void)
{
    fprintf(stderr,
            "usage: " PROG " --fmu DIR (--listen HOST:PORT | --connect HOST:PORT | --socketcan IF)\n"
            RRR_HIL_LINK_USAGE
            "       [--realtime --duration S [--fifo PRIO] [--mlock] [--cpu N] [--spin-us N]\n"
            "       [--latency-log FILE.csv]]\n"
            "       [--q0 a,b,c] [--qd0 a,b,c] [--set NAME=VALUE]... [--max-missed N]\n"
            "       [--max-delta-counter N] [--log FILE.csv] [--profile dbc|canopen]\n"
            "       [--node-ids a,b,c]\n"
            "  DIR: the unzipped plant FMU (modelDescription.xml, binaries/linux64/rrr_plant.so)\n"
            "  --profile canopen: the axes as three CiA 402 drives (CST) with node ids\n"
            "  --node-ids (default 1,2,3), stepped by the master's SYNC (docs/canopen.md);\n"
            "  with --realtime: SCHED_FIFO, mlockall, the CPU (--fifo, --mlock, --cpu) applied,\n"
            "  still stepped by each SYNC; the master's heartbeat consumer in wall-clock time\n"
            RRR_HIL_RT_USAGE
            "  exit: 0 end of run (the controller's StopCmd), 1 usage, 2 setup, 3 controller lost,\n"
            "  4 SIGINT/SIGTERM, 5 FMU failed, 6 the controller stopped early, 7 end of run but the\n"
            "  safety policy fired (a fault latched or 0 V forced; docs/can.md, Exit statuses)\n");
}

static int parse_args(int argc, char **argv, opts *o)
{
    memset(o, 0, sizeof *o);
    o->node_ids[0] = 1;
    o->node_ids[1] = 2;
    o->node_ids[2] = 3;
    o->sup = rrr_hil_sup_config_default();
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
            continue;
        }
        if (strcmp(a, "-h") == 0 || strcmp(a, "--help") == 0) {
            usage();
            exit(0);
        }
        if (i + 1 >= argc) {
            fprintf(stderr, PROG ": unknown option or missing value: %s\n", a);
            return -1;
        }
        const char *v = argv[++i];
        char *end = NULL;
        if (strcmp(a, "--fmu") == 0) {
            o->fmu_dir = v;
        } else if (strcmp(a, "--log") == 0) {
            o->log_path = v;
        } else if (strcmp(a, "--duration") == 0) {
            o->duration_s = strtod(v, &end);
            if (*end != '\0' || !(o->duration_s > 0.0) || o->duration_s > 1e6) {
                fprintf(stderr, PROG ": --duration: expected seconds in (0, 1e6], got '%s'\n", v);
                return -1;
            }
        } else if (strcmp(a, "--q0") == 0 || strcmp(a, "--qd0") == 0) {
            const int is_q0 = a[3] == '0';
            if (rrr_hil_parse_vec3(v, is_q0 ? o->q0 : o->qd0) != 0) {
                fprintf(stderr, PROG ": %s: expected three numbers a,b,c, got '%s'\n", a, v);
                return -1;
            }
            *(is_q0 ? &o->have_q0 : &o->have_qd0) = 1;
        } else if (strcmp(a, "--set") == 0) {
            const char *eq = strchr(v, '=');
            double x = eq ? strtod(eq + 1, &end) : 0.0;
            if (eq == NULL || eq == v || end == eq + 1 || *end != '\0' || o->n_set >= MAX_SETS) {
                fprintf(stderr, PROG ": --set: expected NAME=VALUE (at most %d), got '%s'\n",
                        MAX_SETS, v);
                return -1;
            }
            static char names[MAX_SETS][64];
            const size_t n = (size_t)(eq - v) < 63u ? (size_t)(eq - v) : 63u;
            memcpy(names[o->n_set], v, n);
            names[o->n_set][n] = '\0';
            o->set_name[o->n_set] = names[o->n_set];
            o->set_value[o->n_set++] = x;
        } else if ((r = rrr_hil_profile_arg(a, v, &o->canopen, o->node_ids, PROG)) != 0) {
            if (r < 0) {
                return -1;
            }
        } else if (strcmp(a, "--max-missed") == 0 || strcmp(a, "--max-delta-counter") == 0) {
            const long x = strtol(v, &end, 10);
            if (*end != '\0' || x < 0 || x > 99) {
                fprintf(stderr, PROG ": %s: expected an integer 0..99, got '%s'\n", a, v);
                return -1;
            }
            if (a[6] == 'm') {
                o->sup.max_missed = (unsigned)x;
            } else {
                o->sup.max_delta_counter = (unsigned)x;
            }
        } else {
            fprintf(stderr, PROG ": unknown option %s\n", a);
            return -1;
        }
    }
    if (o->fmu_dir == NULL) {
        fprintf(stderr, PROG ": --fmu DIR is required\n");
        return -1;
    }
    if (o->canopen && o->realtime && (o->duration_s > 0.0 || o->rt.latency_log != NULL)) {
        fprintf(stderr, PROG ": --profile canopen is stepped by the master's SYNC: with "
                             "--realtime it takes --fifo, --mlock and --cpu only (no --duration, "
                             "no --latency-log: the SYNC times are in the frame log)\n");
        return -1;
    }
    if (o->realtime && !o->canopen && o->duration_s <= 0.0) {
        fprintf(stderr, PROG ": --realtime needs --duration S\n");
        return -1;
    }
    if (o->sup.max_missed < 1u || o->sup.max_delta_counter < 1u || o->sup.max_delta_counter > 15u) {
        fprintf(stderr, PROG ": --max-missed must be >= 1 and --max-delta-counter in 1..15\n");
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
static int end_run(plant *p, int code, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
static int end_run(plant *p, int code, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    (void)vsnprintf(p->why, sizeof p->why, fmt, ap);
    va_end(ap);
    return code;
}

/* The controller is gone: latch the bus fault and say why. */
static int lost(plant *p, const char *what)
{
    rrr_hil_sup_raise(&p->sup, RRR_HIL_FAULT_BUS);
    return end_run(p, RRR_HIL_EXIT_PEER_LOST, "controller lost%s: %s%s",
                   p->started ? "" : " before its first frame", what,
                   p->ctrl_nmt == RRR_HIL_NMT_STOPPED
                       ? " (its heartbeat said 'stopped', but no valid StopCmd arrived)"
                       : "");
}

static int transport_lost(plant *p, rrr_hil_io io)
{
    char what[260];
    snprintf(what, sizeof what, "transport %s: %s", rrr_hil_io_str(io), p->tr->last_error);
    return lost(p, what);
}

static int silence_lost(plant *p, int idle_ms)
{
    char what[96];
    snprintf(what, sizeof what, "no frame for %d ms (--idle-timeout-ms)", idle_ms);
    return lost(p, what);
}

/* The controller's StopCmd was honoured. */
static int stopped(plant *p)
{
    const unsigned r = p->sup.stop_reason;
    return end_run(p, r == RRR_HIL_STOP_END_OF_RUN ? RRR_HIL_EXIT_OK : RRR_HIL_EXIT_STOPPED_EARLY,
                   "the controller's StopCmd: %s", rrr_hil_stop_reason_str(r));
}

/* A run that completed (exit 0) in which the safety policy fired (a fault latched, even if reset
 * later, or 0 V forced for a period) ends with its own status, so that a bench job fails. */
static int safety_status(plant *p, int rc)
{
    const rrr_hil_sup_err *e = &p->sup.err;
    if (rc != RRR_HIL_EXIT_OK ||
        (p->sup.faults == 0u && e->fault_events == 0u && e->zero_periods == 0u)) {
        return rc;
    }
    const size_t n = strlen(p->why);
    (void)snprintf(p->why + n, sizeof p->why - n,
                   "; the safety policy fired: %u fault events, faults latched 0x%02X, %u "
                   "periods at 0 V",
                   e->fault_events, (unsigned)p->sup.faults, e->zero_periods);
    return RRR_HIL_EXIT_SAFETY;
}

static int interrupted(plant *p)
{
    return end_run(p, RRR_HIL_EXIT_INTERRUPTED, "%s", rrr_hil_stop_signal_name());
}

/* The value references of n variables by name; -1 (the FMU's last_error says which) if one is
 * missing. */
static int resolve_vrs(rrr_hil_fmu *fmu, const char *const *names, int n, fmi2ValueReference *vr)
{
    for (int i = 0; i < n; ++i) {
        const long v = rrr_hil_fmu_vr(fmu, names[i]);
        if (v < 0) {
            return -1;
        }
        vr[i] = (fmi2ValueReference)v;
    }
    return 0;
}

static int setup_fmu(plant *p, const opts *o)
{
    if (rrr_hil_fmu_open(&p->fmu, o->fmu_dir, "plant") != 0) {
        fprintf(stderr, PROG ": %s\n", p->fmu.last_error);
        return -1;
    }
    static const char *const xn[6] = {"q[1]", "q[2]", "q[3]", "qd[1]", "qd[2]", "qd[3]"};
    static const char *const un[3] = {"u[1]", "u[2]", "u[3]"};
    static const char *const yn[6] = {"qdd[1]", "qdd[2]", "qdd[3]", "tip.x", "tip.y", "tip.z"};
    if (resolve_vrs(&p->fmu, yn, 6, p->vr_y) != 0 || resolve_vrs(&p->fmu, xn, 6, p->vr_x) != 0 ||
        resolve_vrs(&p->fmu, un, 3, p->vr_u) != 0) {
        fprintf(stderr, PROG ": %s\n", p->fmu.last_error);
        return -1;
    }
    char name[16];
    for (int i = 0; i < 3; ++i) {
        snprintf(name, sizeof name, "q0[%d]", i + 1);
        if (o->have_q0 && rrr_hil_fmu_set_by_name(&p->fmu, name, o->q0[i]) != 0) {
            fprintf(stderr, PROG ": %s\n", p->fmu.last_error);
            return -1;
        }
        snprintf(name, sizeof name, "qd0[%d]", i + 1);
        if (o->have_qd0 && rrr_hil_fmu_set_by_name(&p->fmu, name, o->qd0[i]) != 0) {
            fprintf(stderr, PROG ": %s\n", p->fmu.last_error);
            return -1;
        }
    }
    for (int i = 0; i < o->n_set; ++i) {
        if (rrr_hil_fmu_set_by_name(&p->fmu, o->set_name[i], o->set_value[i]) != 0) {
            fprintf(stderr, PROG ": --set: %s\n", p->fmu.last_error);
            return -1;
        }
    }
    if (rrr_hil_fmu_init(&p->fmu, 0.0) != 0 || rrr_hil_fmu_get(&p->fmu, p->vr_x, 6, p->x) != 0 ||
        rrr_hil_fmu_get(&p->fmu, p->vr_y, 6, p->y) != 0) {
        fprintf(stderr, PROG ": %s\n", p->fmu.last_error);
        return -1;
    }
    return 0;
}

/* The row below: k, t, q[3], qd[3], u[3], zero, faults, qdd[3], tip[3] (rrr_hil_logs.h). */
_Static_assert(RRR_HIL_PLANT_LOG_COLUMNS == 2 + 6 + 3 + 2 + 6,
               "log_row writes the plant log's columns (rrr_robot.hil.logspec)");

static void log_row(plant *p)
{
    if (p->log == NULL) {
        return;
    }
    fprintf(p->log, "%u,%.17g", p->k, p->fmu.time);
    for (int i = 0; i < 6; ++i) {
        fprintf(p->log, ",%.17g", p->x[i]);
    }
    for (int i = 0; i < 3; ++i) {
        fprintf(p->log, ",%.17g", p->u[i]);
    }
    fprintf(p->log, ",%u,%u", (unsigned)p->log_zero, (unsigned)p->log_faults);
    for (int i = 0; i < 6; ++i) {
        fprintf(p->log, ",%.17g", p->y[i]);
    }
    fputc('\n', p->log);
}

/* Publish the state of period k: JointState1..3 then PlantStatus. */
static void publish(plant *p)
{
    rrr_hil_frame f;
    const uint8_t counter = (uint8_t)(p->k & 15u);
    for (uint8_t j = 0; j < 3u; ++j) {
        const rrr_hil_joint_state js = {j, counter, p->x[j], p->x[3 + j]};
        if (rrr_hil_encode_joint_state(&js, &f) != 0) {
            ++p->tx_state_range;
            continue;
        }
        (void)rrr_hil_send(p->tr, &f);
    }
    rrr_hil_plant_status st;
    rrr_hil_sup_status(&p->sup, &st);
    st.counter = counter;
    if (rrr_hil_encode_plant_status(&st, &f) == 0) {
        (void)rrr_hil_send(p->tr, &f);
    }
    if (p->k % RRR_HIL_HEARTBEAT_PERIODS == 0u) {
        const rrr_hil_heartbeat hb = {2u, RRR_HIL_NMT_OPERATIONAL, p->hb_counter++};
        if (rrr_hil_encode_heartbeat(&hb, &f) == 0) {
            (void)rrr_hil_send(p->tr, &f);
        }
    }
}

/* Advance one period: supervisor decision, FMU step, new state. 0 or -1 (FMU failed: why set). */
static int step(plant *p)
{
    if (rrr_hil_fmu_set(&p->fmu, p->vr_u, 3, p->u) != 0 ||
        rrr_hil_fmu_step(&p->fmu, RRR_HIL_PERIOD_S) != 0 ||
        rrr_hil_fmu_get(&p->fmu, p->vr_x, 6, p->x) != 0 ||
        (p->log != NULL && rrr_hil_fmu_get(&p->fmu, p->vr_y, 6, p->y) != 0)) {
        (void)end_run(p, RRR_HIL_EXIT_FAULT, "the FMU failed: %s", p->fmu.last_error);
        return -1;
    }
    ++p->k;
    log_row(p);
    return 0;
}

static int advance(plant *p)
{
    (void)rrr_hil_sup_next_period(&p->sup, p->u);
    p->log_zero = p->sup.zero_applied;
    p->log_faults = p->sup.faults;
    return step(p);
}

/* Handle one received frame: EV_SYNC for a lockstep Sync (period to advance), EV_STOP for an
 * honoured StopCmd, else EV_NONE. */
static int handle(plant *p, const rrr_hil_frame *f, int lockstep)
{
    rrr_hil_msg m;
    const rrr_hil_rx rx = rrr_hil_decode(f, &m);
    ++p->rx_bad[rx];
    p->last_rx_ms = now_ms();
    if (rx == RRR_HIL_RX_UNKNOWN_ID) {
        return EV_NONE;
    }
    p->started = 1;
    if (m.kind == RRR_HIL_VOLTAGE_CMD) {
        rrr_hil_sup_on_command(&p->sup, rx, rx == RRR_HIL_RX_OK ? &m.u.cmd : NULL);
        return EV_NONE;
    }
    if (m.kind == RRR_HIL_STOP_CMD) { /* honoured only with its E2E protection */
        return rrr_hil_sup_on_stop(&p->sup, rx, rx == RRR_HIL_RX_OK ? &m.u.stop : NULL) ? EV_STOP
                                                                                        : EV_NONE;
    }
    if (rx != RRR_HIL_RX_OK) {
        return EV_NONE;
    }
    if (m.kind == RRR_HIL_HEARTBEAT && m.u.heartbeat.node == 1u) {
        p->ctrl_nmt = m.u.heartbeat.nmt_state; /* informational: "stopped" stops nothing */
        return EV_NONE;
    }
    if (m.kind == RRR_HIL_SYNC && lockstep) {
        if (m.u.sync.cycle != p->k) {
            rrr_hil_sup_raise(&p->sup, RRR_HIL_FAULT_SYNC);
        }
        return EV_SYNC;
    }
    if (m.kind != RRR_HIL_SYNC) {
        ++p->rx_ignored;
    }
    return EV_NONE;
}

static int run_lockstep(plant *p, const opts *o)
{
    const int idle_ms = rrr_hil_link_idle_ms(&o->link);
    int published0 = 0;
    for (;;) {
        if (rrr_hil_stop_requested()) {
            return interrupted(p);
        }
        rrr_hil_frame f;
        const rrr_hil_io io = rrr_hil_recv(p->tr, &f, 200000);
        if (io == RRR_HIL_IO_TIMEOUT) {
            if (p->started && now_ms() - p->last_rx_ms >= idle_ms) {
                return silence_lost(p, idle_ms);
            }
            continue; /* before the first frame: wait for a controller as long as it takes */
        }
        if (io != RRR_HIL_IO_OK) {
            return transport_lost(p, io);
        }
        const int ev = handle(p, &f, 1);
        if (p->started && !published0) {
            publish(p); /* the state of period 0, after the controller's first frame */
            published0 = 1;
        }
        if (ev == EV_STOP) {
            return stopped(p);
        }
        if (ev == EV_SYNC) {
            if (advance(p) != 0) {
                return RRR_HIL_EXIT_FAULT;
            }
            publish(p);
        }
    }
}

static int run_realtime(plant *p, const opts *o, FILE *latency_log)
{
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
            rc = interrupted(p);
        } else if (io == RRR_HIL_IO_OK) {
            (void)handle(p, &f, 0); /* no StopCmd can be honoured before a command */
        } else if (io != RRR_HIL_IO_TIMEOUT) {
            rc = transport_lost(p, io);
        } else if (waited_ms > (int)(o->duration_s * 1000.0)) {
            rc = lost(p, "no controller within --duration");
        }
    }
    if (rc >= 0) {
        if (latency_log != NULL) {
            fclose(latency_log); /* nothing to log: the loop never started */
        }
        return rc;
    }
    if (rrr_hil_rt_init(&rt, RRR_HIL_PERIOD_S, n, &o->rt, latency_log, PROG) != 0) {
        return end_run(p, RRR_HIL_EXIT_SETUP, "out of memory");
    }
    /* the controller's loop started when it sent that frame: run half a period out of phase,
     * so that its command reaches us before our release and our state reaches it before its */
    rrr_hil_rt_shift(&rt, 0.5 * RRR_HIL_PERIOD_S);
    for (uint32_t k = 0; k < n && rc < 0; ++k) {
        if (rrr_hil_stop_requested()) {
            rc = interrupted(p);
            break;
        }
        rrr_hil_rt_wait(&rt);
        rrr_hil_frame f;
        rrr_hil_io io = RRR_HIL_IO_TIMEOUT;
        int ev = EV_NONE;
        while (ev != EV_STOP && (io = rrr_hil_recv(p->tr, &f, 0)) == RRR_HIL_IO_OK) {
            ev = handle(p, &f, 0);
        }
        if (ev == EV_STOP) {
            rc = stopped(p);
        } else if (io != RRR_HIL_IO_TIMEOUT) {
            rc = transport_lost(p, io);
        } else if (now_ms() - p->last_rx_ms >= idle_ms) {
            rc = silence_lost(p, idle_ms);
        } else if (advance(p) != 0) {
            rc = RRR_HIL_EXIT_FAULT;
        } else {
            publish(p);
            rrr_hil_rt_done(&rt);
        }
    }
    if (rc < 0) {
        rc = end_run(p, RRR_HIL_EXIT_OK, "--duration %g s elapsed", o->duration_s);
    }
    printf("RRR_HIL_RT {");
    rrr_hil_rt_report(&rt, stdout, PROG);
    printf("}\n");
    rrr_hil_rt_free(&rt);
    return rc;
}

/* ---- --profile canopen: the axes as three CiA 402 drives (hil_canopen.h, docs/canopen.md) ---- */

static int64_t now_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000 + ts.tv_nsec / 1000;
}

static void co_send(plant *p, const rrr_co_out *out)
{
    for (unsigned i = 0; i < out->n; ++i) {
        (void)rrr_hil_send(p->tr, &out->f[i]);
    }
}

/* The drives' rated torques from the FMU's k_t and u_max (0x6076 = k_t,i u_max, mN m); 0 or
 * -1 with a message. */
static int co_setup(plant *p, const opts *o)
{
    static const char *const ktn[3] = {"kt[1]", "kt[2]", "kt[3]"};
    fmi2ValueReference vr[4];
    double v[4];
    const long vu = rrr_hil_fmu_vr(&p->fmu, "u_max");
    if (resolve_vrs(&p->fmu, ktn, 3, vr) != 0 || vu < 0) {
        fprintf(stderr, PROG ": %s\n", p->fmu.last_error);
        return -1;
    }
    vr[3] = (fmi2ValueReference)vu;
    if (rrr_hil_fmu_get(&p->fmu, vr, 4, v) != 0) {
        fprintf(stderr, PROG ": %s\n", p->fmu.last_error);
        return -1;
    }
    for (int i = 0; i < 3; ++i) {
        const double rated = v[i] * v[3] * 1000.0;
        const rrr_co_config cfg = {o->node_ids[i], (uint32_t)(rated + 0.5)};
        if (!(rated >= 1.0 && rated < 4.0e9) || rrr_co_init(&p->co[i], &cfg) != 0) {
            fprintf(stderr, PROG ": axis %d: k_t u_max = %g mN m is not a rated torque 0x6076 "
                            "can hold (1 .. 4e9)\n", i + 1, rated);
            return -1;
        }
        p->kt[i] = v[i];
    }
    return 0;
}

static int co_any_operational(const plant *p)
{
    for (int i = 0; i < 3; ++i) {
        if (p->co[i].nmt == RRR_CO_NMT_OPERATIONAL) {
            return 1;
        }
    }
    return 0;
}

/* One SYNC fed to the drives: the period it closes (the first SYNC only starts), then TPDOs. */
static int co_sync(plant *p)
{
    if (p->synced) {
        p->log_zero = 0;
        p->log_faults = 0;
        for (int i = 0; i < 3; ++i) {
            p->u[i] = rrr_co_torque_Nm(&p->co[i]) / p->kt[i]; /* eq 8: u = tau / k_t */
            p->log_zero |= p->co[i].s402 != RRR_CO_402_OPERATION_ENABLED;
            p->log_faults |= (uint8_t)((p->co[i].s402 == RRR_CO_402_FAULT) << i);
        }
        if (step(p) != 0) {
            return -1;
        }
    }
    p->synced = 1;
    for (int i = 0; i < 3; ++i) {
        rrr_co_out out = {0};
        rrr_co_set_feedback(&p->co[i], p->x[i], p->x[3 + i]);
        rrr_co_transmit(&p->co[i], &out);
        co_send(p, &out);
    }
    return 0;
}

static int run_canopen(plant *p, const opts *o)
{
    const int idle_ms = rrr_hil_link_idle_ms(&o->link);
    for (int i = 0; i < 3; ++i) { /* power on: boot-up messages (a socketcand server drops them
                                   * before its client's first frame: a master resets the nodes) */
        rrr_co_out out = {0};
        rrr_co_boot(&p->co[i], &out);
        co_send(p, &out);
    }
    int64_t last_us = now_us();
    for (;;) {
        if (rrr_hil_stop_requested()) {
            return interrupted(p);
        }
        rrr_hil_frame f;
        const rrr_hil_io io = rrr_hil_recv(p->tr, &f, 10000);
        const int64_t t = now_us();
        for (int i = 0; i < 3; ++i) { /* heartbeat producer and consumer, in wall-clock time */
            rrr_co_out out = {0};
            const uint32_t faults = p->co[i].latch.fault_events;
            rrr_co_advance(&p->co[i], (uint32_t)(t - last_us), &out);
            co_send(p, &out);
            p->co_faults += p->co[i].latch.fault_events - faults; /* a lost master heartbeat */
        }
        last_us = t;
        if (io == RRR_HIL_IO_TIMEOUT) {
            if (p->started && now_ms() - p->last_rx_ms >= idle_ms) {
                return co_any_operational(p) ? silence_lost(p, idle_ms)
                                             : end_run(p, RRR_HIL_EXIT_OK,
                                                       "the master fell silent with no drive "
                                                       "in NMT operational");
            }
            continue;
        }
        if (io != RRR_HIL_IO_OK) {
            if (p->started && !co_any_operational(p)) {
                return end_run(p, RRR_HIL_EXIT_OK,
                               "the master hung up with no drive in NMT operational");
            }
            return transport_lost(p, io);
        }
        p->started = 1;
        p->last_rx_ms = now_ms();
        const int is_sync = !f.extended && f.id == 0x080u && f.dlc <= 1u;
        int sync_applied = 0;
        for (int i = 0; i < 3; ++i) {
            rrr_co_out out = {0};
            const uint32_t faults = p->co[i].latch.fault_events;
            rrr_co_on_frame(&p->co[i], &f, &out);
            sync_applied |= p->co[i].tx_pending;
            co_send(p, &out);
            p->co_faults += p->co[i].latch.fault_events - faults;
        }
        if (is_sync && sync_applied && co_sync(p) != 0) {
            return RRR_HIL_EXIT_FAULT;
        }
    }
}

static void co_summary(const plant *p, int rc)
{
    fprintf(stderr, PROG ": --profile canopen: %u periods; faults latched by the drives %u\n",
            p->k, p->co_faults);
    printf("RRR_HIL_SUMMARY {\"node\": \"plant\", \"profile\": \"canopen\", \"exit\": %d, "
           "\"periods\": %u, \"drive_faults\": %u, \"drives\": [", rc, p->k, p->co_faults);
    for (int i = 0; i < 3; ++i) {
        const rrr_co_node *n = &p->co[i];
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
    if (p->rt_setup != NULL) {
        printf("\"rt_setup\": \"%s\", ", p->rt_setup);
    }
    rrr_hil_link_json(stdout, p->tr);
    printf("}\n");
    fflush(stdout);
}

static void summary(const plant *p, int rc)
{
    const rrr_hil_sup_err *e = &p->sup.err;
    fprintf(stderr,
            PROG ": %u periods; faults latched 0x%02X; fault events %u (crc %u, counter %u, "
                 "range %u, format %u, sync %u, bus %u, timeout %u); periods without command %u, "
                 "at 0 V %u; resets %u; stop requests ignored %u; states out of DBC range %u\n",
            p->k, (unsigned)p->sup.faults, e->fault_events, e->crc, e->counter, e->range,
            e->format, e->sync, e->bus, e->timeout, e->cmd_missed, e->zero_periods, e->resets,
            e->stop_rejected, p->tx_state_range);
    printf("RRR_HIL_SUMMARY {\"node\": \"plant\", \"exit\": %d, \"periods\": %u, \"faults\": %u, "
           "\"fault_events\": %u, \"crc\": %u, \"counter\": %u, \"range\": %u, \"format\": %u, "
           "\"sync\": %u, \"bus\": %u, \"timeout\": %u, \"cmd_missed\": %u, \"zero_periods\": %u, "
           "\"resets\": %u, \"stop_rejected\": %u, \"stop_reason\": %d, "
           "\"state_out_of_range\": %u, \"rx_unknown_id\": %u, \"rx_bad_dlc\": %u, "
           "\"rx_bad_crc\": %u, \"rx_out_of_range\": %u, \"rx_ignored\": %u, ",
           rc, p->k, (unsigned)p->sup.faults, e->fault_events, e->crc, e->counter, e->range,
           e->format, e->sync, e->bus, e->timeout, e->cmd_missed, e->zero_periods, e->resets,
           e->stop_rejected, p->sup.stop ? (int)p->sup.stop_reason : -1, p->tx_state_range,
           p->rx_bad[RRR_HIL_RX_UNKNOWN_ID], p->rx_bad[RRR_HIL_RX_BAD_DLC],
           p->rx_bad[RRR_HIL_RX_BAD_CRC], p->rx_bad[RRR_HIL_RX_OUT_OF_RANGE], p->rx_ignored);
    rrr_hil_link_json(stdout, p->tr);
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
    static plant p;
    memset(&p, 0, sizeof p);
    p.ctrl_nmt = 255u;
    if (rrr_hil_sup_init(&p.sup, &o.sup) != 0 || setup_fmu(&p, &o) != 0 ||
        (o.canopen && co_setup(&p, &o) != 0)) {
        rrr_hil_fmu_close(&p.fmu);
        return rrr_hil_report_exit(PROG, RRR_HIL_EXIT_SETUP, 0, "the plant could not be set up");
    }
    if (o.log_path != NULL) {
        p.log = fopen(o.log_path, "w");
        if (p.log == NULL) {
            rrr_hil_fmu_close(&p.fmu);
            return rrr_hil_report_exit(PROG, RRR_HIL_EXIT_SETUP, 0, "cannot write %s",
                                       o.log_path);
        }
        fputs(RRR_HIL_PLANT_LOG_HEADER, p.log); /* gen/rrr_hil_logs.h */
        log_row(&p);
    }
    int log_failed = 0;
    FILE *latency_log = rrr_hil_rt_open_log(&o.rt, o.realtime, PROG, &log_failed);
    if (log_failed) {
        if (p.log) {
            fclose(p.log);
        }
        rrr_hil_fmu_close(&p.fmu);
        return rrr_hil_report_exit(PROG, RRR_HIL_EXIT_SETUP, 0, "cannot write %s",
                                   o.rt.latency_log);
    }
    static rrr_hil_link link;
    static rrr_hil_framelog frames;
    const uint32_t rx_ids[] = {RRR_BENCH_SYNC_FRAME_ID, RRR_BENCH_VOLTAGE_CMD_FRAME_ID,
                               RRR_BENCH_STOP_CMD_FRAME_ID, RRR_BENCH_HEARTBEAT_CTRL_FRAME_ID};
    /* CANopen: every identifier (the master's heartbeat id is configured by SDO) */
    if (rrr_hil_link_open(&o.link, &link, rx_ids, o.canopen ? 0u : 4u, PROG, &frames) != 0) {
        if (latency_log != NULL) {
            fclose(latency_log);
        }
        if (p.log) {
            fclose(p.log);
        }
        rrr_hil_fmu_close(&p.fmu);
        return rrr_hil_report_exit(PROG, RRR_HIL_EXIT_SETUP, 0, "the transport did not open");
    }
    p.tr = &link.base;
    if (o.canopen) {
        static rrr_hil_rt rt; /* --realtime: the setup only (SCHED_FIFO, mlockall, CPU) */
        if (o.realtime && rrr_hil_rt_init(&rt, RRR_HIL_PERIOD_S, 1u, &o.rt, NULL, PROG) != 0) {
            return rrr_hil_report_exit(PROG, RRR_HIL_EXIT_SETUP, 0, "out of memory");
        }
        p.rt_setup = o.realtime ? rt.setup : NULL;
        p.last_rx_ms = now_ms();
        int rc = run_canopen(&p, &o);
        rrr_hil_rt_free(&rt);
        if (rc == RRR_HIL_EXIT_OK && p.co_faults != 0u) {
            const size_t n = strlen(p.why);
            (void)snprintf(p.why + n, sizeof p.why - n,
                           "; the drives latched %u faults", p.co_faults);
            rc = RRR_HIL_EXIT_SAFETY;
        }
        if (latency_log != NULL) {
            fclose(latency_log);
        }
        (void)rrr_hil_framelog_close(&frames);
        co_summary(&p, rc);
        rrr_hil_close(p.tr);
        if (p.log) {
            fclose(p.log);
        }
        rrr_hil_fmu_close(&p.fmu);
        return rrr_hil_report_exit(PROG, rc, p.k, "%s", p.why);
    }
    {   /* CANopen-style boot-up message (dropped by a socketcand server without a client) */
        rrr_hil_frame f;
        const rrr_hil_heartbeat hb = {2u, RRR_HIL_NMT_BOOT, p.hb_counter++};
        if (rrr_hil_encode_heartbeat(&hb, &f) == 0) {
            (void)rrr_hil_send(p.tr, &f);
        }
    }
    p.last_rx_ms = now_ms();
    const int rc =
        safety_status(&p, o.realtime ? run_realtime(&p, &o, latency_log) : run_lockstep(&p, &o));
    (void)rrr_hil_framelog_close(&frames); /* reported in the summary */
    summary(&p, rc);
    rrr_hil_close(p.tr);
    if (p.log) {
        fclose(p.log);
    }
    rrr_hil_fmu_close(&p.fmu);
    return rrr_hil_report_exit(PROG, rc, p.k, "%s", p.why);
}
