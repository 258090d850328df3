/* Shared pieces of the bench nodes (see hil_node.h). */
#define _GNU_SOURCE /* prctl(PR_SET_TIMERSLACK), sched_setscheduler */

#include "hil_node.h"
#include "rrr/rrr_params.h"

#include <errno.h>
#include <stdarg.h>
#include <stddef.h>
#include <stdio.h>
#include <math.h>
#include <sched.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/mman.h>
#include <sys/prctl.h>

#include "hil_common.h"
#include "rrr_hil_logs.h"

/* ---- command line ---------------------------------------------------------------------------- */

int rrr_hil_parse_hostport(const char *s, char host[64], uint16_t *port)
{
    const char *colon = strrchr(s, ':');
    if (colon == NULL || colon == s || (size_t)(colon - s) >= 64u) {
        return -1;
    }
    char *end;
    errno = 0;
    const unsigned long p = strtoul(colon + 1, &end, 10);
    if (errno != 0 || end == colon + 1 || *end != '\0' || p > 65535ul) {
        return -1;
    }
    memcpy(host, s, (size_t)(colon - s));
    host[colon - s] = '\0';
    *port = (uint16_t)p;
    return 0;
}

int rrr_hil_parse_vec3(const char *s, double v[3])
{
    const char *p = s;
    for (int i = 0; i < 3; ++i) {
        char *end;
        errno = 0;
        const double x = strtod(p, &end);
        if (end == p || errno != 0 || !isfinite(x) || *end != (i < 2 ? ',' : '\0')) {
            return -1;
        }
        v[i] = x;
        p = end + 1;
    }
    return 0;
}

static int parse_node_ids(const char *s, uint8_t ids[3])
{
    double v[3];
    int ok = rrr_hil_parse_vec3(s, v) == 0;
    for (int j = 0; ok && j < 3; ++j) {
        ok = v[j] >= 1.0 && v[j] <= 127.0 && v[j] == (double)(int)v[j];
        ids[j] = ok ? (uint8_t)v[j] : 0u;
    }
    return ok && ids[0] != ids[1] && ids[0] != ids[2] && ids[1] != ids[2] ? 0 : -1;
}

int rrr_hil_profile_arg(const char *a, const char *v, const char *const *names, unsigned n_names,
                        int *profile, uint8_t ids[3], const char *prog)
{
    if (strcmp(a, "--profile") == 0) {
        for (unsigned i = 0; i < n_names; ++i) {
            if (strcmp(v, names[i]) == 0) {
                *profile = (int)i;
                return 1;
            }
        }
        fprintf(stderr, "%s: --profile: expected ", prog);
        for (unsigned i = 0; i < n_names; ++i) {
            fprintf(stderr, "%s'%s'", i == 0u ? "" : i + 1u == n_names ? " or " : ", ", names[i]);
        }
        fprintf(stderr, ", got '%s'\n", v);
        return -1;
    }
    if (strcmp(a, "--node-ids") == 0) {
        if (parse_node_ids(v, ids) != 0) {
            fprintf(stderr, "%s: --node-ids: expected three distinct node ids 1..127 a,b,c, "
                            "got '%s'\n", prog, v);
            return -1;
        }
        return 1;
    }
    return 0;
}

/* ---- exit statuses --------------------------------------------------------------------------- */

const char *rrr_hil_exit_str(int code)
{
    switch (code) {
    case RRR_HIL_EXIT_OK:
        return "completed";
    case RRR_HIL_EXIT_USAGE:
        return "usage";
    case RRR_HIL_EXIT_SETUP:
        return "setup failed";
    case RRR_HIL_EXIT_PEER_LOST:
        return "peer lost";
    case RRR_HIL_EXIT_INTERRUPTED:
        return "interrupted";
    case RRR_HIL_EXIT_FAULT:
        return "fault";
    case RRR_HIL_EXIT_STOPPED_EARLY:
        return "stopped early by the controller";
    case RRR_HIL_EXIT_SAFETY:
        return "completed, safety policy fired";
    case RRR_HIL_EXIT_TAMPERED:
        return "tampered input";
    default:
        return "unknown";
    }
}

int rrr_hil_report_exit(const char *prog, int code, uint32_t period, const char *fmt, ...)
{
    char reason[400];
    va_list ap;
    va_start(ap, fmt);
    (void)vsnprintf(reason, sizeof reason, fmt, ap);
    va_end(ap);
    for (char *c = reason; *c != '\0'; ++c) {
        if ((unsigned char)*c < 0x20u || (unsigned char)*c == 0x7Fu) {
            *c = '?';
        }
    }
    fprintf(stderr, "%s: exit %d (%s) at period %u: %s\n", prog, code, rrr_hil_exit_str(code),
            period, reason);
    fflush(stderr);
    return code;
}

/* ---- how a run ends ------------------------------------------------------------------------- */

int rrr_hil_run_end(rrr_hil_run *r, int code, const char *fmt, ...)
{
    va_list ap;
    va_start(ap, fmt);
    (void)vsnprintf(r->why, sizeof r->why, fmt, ap);
    va_end(ap);
    return code;
}

int rrr_hil_run_interrupted(rrr_hil_run *r)
{
    return rrr_hil_run_end(r, RRR_HIL_EXIT_INTERRUPTED, "%s", rrr_hil_stop_signal_name());
}

int rrr_hil_run_safety(rrr_hil_run *r, int rc, const char *fmt, ...)
{
    if (rc != RRR_HIL_EXIT_OK) {
        return rc;
    }
    char text[sizeof r->why];
    va_list ap;
    va_start(ap, fmt);
    (void)vsnprintf(text, sizeof text, fmt, ap);
    va_end(ap);
    const size_t n = strlen(r->why);
    (void)snprintf(r->why + n, sizeof r->why - n, "; %s", text);
    return RRR_HIL_EXIT_SAFETY;
}

int rrr_hil_log_close(FILE *fp, const char *path, rrr_hil_run *r, int rc)
{
    if (fp == NULL) {
        return rc;
    }
    const int failed = ferror(fp) != 0;
    const int closed = fclose(fp);
    const int e = errno;
    if ((failed || closed != 0) && (rc == RRR_HIL_EXIT_OK || rc == RRR_HIL_EXIT_SAFETY)) {
        return rrr_hil_run_end(r, RRR_HIL_EXIT_SETUP,
                               "cannot write the log %s: %s: free space, or write it elsewhere",
                               path, e != 0 ? strerror(e) : "a write failed");
    }
    return rc;
}

int rrr_hil_run_report(const char *prog, int rc, const rrr_hil_run *r)
{
    return rrr_hil_report_exit(prog, rc, r->k, "%s", r->why);
}

int64_t rrr_hil_now_ms(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

/* The one piece of process state of a node: set from the signal handler (the signal number). */
static volatile sig_atomic_t stop_flag = 0;

static void on_stop_signal(int sig)
{
    stop_flag = sig;
}

void rrr_hil_install_signals(void)
{
    signal(SIGINT, on_stop_signal);
    signal(SIGTERM, on_stop_signal);
    signal(SIGPIPE, SIG_IGN);
}

int rrr_hil_stop_requested(void)
{
    return stop_flag != 0;
}

const char *rrr_hil_stop_signal_name(void)
{
    switch (stop_flag) {
    case 0:
        return "";
    case SIGINT:
        return "SIGINT";
    case SIGTERM:
        return "SIGTERM";
    default:
        return "signal";
    }
}

int rrr_hil_set_model_param(rrr_model *m, const char *assignment, char *err, size_t err_len)
{
    const char *eq = strchr(assignment, '=');
    char name[32];
    const size_t len = eq == NULL ? 0u : (size_t)(eq - assignment);
    if (eq == NULL || len == 0u || len >= sizeof name) {
        snprintf(err, err_len, "expected NAME=VALUE, got '%s'", assignment);
        return -1;
    }
    memcpy(name, assignment, len);
    name[len] = '\0';
    const int row = rrr_param_index(name); /* librrr's one parameter table (rrr_params.h) */
    if (row < 0) {
        snprintf(err, err_len, "unknown model parameter '%s' (d1, a2, a3, d2, d3, g, u_max, "
                 "p[1..16], kt[i], b[i], f[i,k], w[i,k])", name);
        return -1;
    }
    char *end;
    errno = 0;
    const double v = strtod(eq + 1, &end);
    if (end == eq + 1 || *end != '\0' || errno != 0 || !isfinite(v)) {
        snprintf(err, err_len, "%s: expected a finite number, got '%s'", name, eq + 1);
        return -1;
    }
    return rrr_param_set(m, (size_t)row, v) == RRR_OK ? 0 : -1; /* v is finite: RRR_OK */
}

/* The value after the option argv[*i] (*i moves to it); -1 with a message when there is none. */
static int option_value(int argc, char **argv, int *i, const char *prog, const char **v)
{
    if (*i + 1 >= argc) {
        fprintf(stderr, "%s: %s needs a value\n", prog, argv[*i]);
        return -1;
    }
    *v = argv[++*i];
    return 0;
}

/* A path option's value: not empty. 1 (taken) or -1 with a message. */
static int path_value(const char *prog, const char *option, const char *v, const char **out)
{
    if (v[0] == '\0') {
        fprintf(stderr, "%s: %s: empty path\n", prog, option);
        return -1;
    }
    *out = v;
    return 1;
}

int rrr_hil_link_arg(rrr_hil_link_opts *o, int argc, char **argv, int *i, const char *prog)
{
    const char *a = argv[*i];
    const int is_listen = strcmp(a, "--listen") == 0;
    const int is_connect = strcmp(a, "--connect") == 0;
    const int is_sc = strcmp(a, "--socketcan") == 0;
    const int is_channel = strcmp(a, "--channel") == 0;
    const int is_handshake = strcmp(a, "--handshake-timeout-ms") == 0;
    const int is_idle = strcmp(a, "--idle-timeout-ms") == 0;
    const int is_log = strcmp(a, "--frame-log") == 0;
    if (strcmp(a, "--fd") == 0) {
        o->can_fd = 1;
        return 1;
    }
    if (!is_listen && !is_connect && !is_sc && !is_channel && !is_handshake && !is_idle &&
        !is_log) {
        return 0;
    }
    const char *v;
    if (option_value(argc, argv, i, prog, &v) != 0) {
        return -1;
    }
    if (is_log) {
        return path_value(prog, a, v, &o->frame_log);
    }
    if (is_handshake || is_idle) {
        char *end;
        errno = 0;
        const long ms = strtol(v, &end, 10);
        if (end == v || *end != '\0' || errno != 0 || ms < 1 || ms > RRR_HIL_SCD_TIMEOUT_MAX_MS) {
            fprintf(stderr, "%s: %s: expected milliseconds 1..%d, got '%s'\n", prog, a,
                    RRR_HIL_SCD_TIMEOUT_MAX_MS, v);
            return -1;
        }
        *(is_idle ? &o->idle_timeout_ms : &o->handshake_timeout_ms) = (int)ms;
        return 1;
    }
    if (is_channel) {
        if (strlen(v) == 0u || strlen(v) >= sizeof o->channel) {
            fprintf(stderr, "%s: --channel: 1..31 characters\n", prog);
            return -1;
        }
        strcpy(o->channel, v);
        return 1;
    }
    if (o->kind != 0) {
        fprintf(stderr, "%s: give only one of --listen, --connect, --socketcan\n", prog);
        return -1;
    }
    if (is_sc) {
        if (strlen(v) == 0u || strlen(v) >= sizeof o->ifname) {
            fprintf(stderr, "%s: --socketcan: bad interface name '%s'\n", prog, v);
            return -1;
        }
        strcpy(o->ifname, v);
        o->kind = 3;
        return 1;
    }
    if (rrr_hil_parse_hostport(v, o->host, &o->port) != 0) {
        fprintf(stderr, "%s: %s: expected HOST:PORT (e.g. 127.0.0.1:29536), got '%s'\n", prog, a,
                v);
        return -1;
    }
    o->kind = is_listen ? 1 : 2;
    return 1;
}

int rrr_hil_link_open(const rrr_hil_link_opts *o, rrr_hil_link *l, const uint32_t *rx_ids,
                      unsigned n_rx, const char *prog, rrr_hil_framelog *log)
{
    memset(log, 0, sizeof *log);
    if (o->frame_log != NULL) {
        char err[320];
        if (rrr_hil_framelog_open(log, o->frame_log, err, sizeof err) != 0) {
            fprintf(stderr, "%s: %s\n", prog, err);
            return -1;
        }
    }
    const char *channel = o->channel[0] ? o->channel : "bench0";
    if (o->can_fd && o->kind != 3) {
        fprintf(stderr, "%s: --fd needs --socketcan IF: the socketcand protocol carries "
                        "classical CAN frames only\n", prog);
        (void)rrr_hil_framelog_close(log);
        return -1;
    }
    const int handshake_ms =
        o->handshake_timeout_ms > 0 ? o->handshake_timeout_ms : RRR_HIL_SCD_HANDSHAKE_TIMEOUT_MS;
    int rc;
    switch (o->kind) {
    case 1:
        rc = rrr_hil_scd_listen(&l->scd, o->host, o->port, channel);
        if (rc == 0 && rrr_hil_scd_set_timeouts(&l->scd, handshake_ms, rrr_hil_link_idle_ms(o)) != 0) {
            rrr_hil_close(&l->base);
            rc = -1;
        }
        if (rc == 0) {
            printf("%s: listening on %s:%u (socketcand, bus %s)\n", prog, o->host,
                   (unsigned)l->scd.port, channel);
            fflush(stdout);
        }
        break;
    case 2:
        rc = rrr_hil_scd_connect(&l->scd, o->host, o->port, channel,
                                 o->connect_wait_ms > 0 ? o->connect_wait_ms : 5000);
        if (rc == 0 && rrr_hil_scd_set_timeouts(&l->scd, handshake_ms, rrr_hil_link_idle_ms(o)) != 0) {
            rrr_hil_close(&l->base);
            rc = -1;
        }
        break;
    case 3:
        rc = rrr_hil_socketcan_open(&l->sc, o->ifname, rx_ids, n_rx);
        if (rc == 0 && o->can_fd) {
            rc = rrr_hil_socketcan_enable_fd(&l->sc, o->ifname);
        }
        break;
    default:
        fprintf(stderr, "%s: no transport: give --listen HOST:PORT, --connect HOST:PORT or "
                        "--socketcan IF\n", prog);
        return -1;
    }
    if (rc != 0) {
        fprintf(stderr, "%s: %s\n", prog, l->base.last_error);
        (void)rrr_hil_framelog_close(log);
        return -1;
    }
    l->base.framelog = o->frame_log != NULL ? log : NULL;
    return 0;
}

int rrr_hil_link_idle_ms(const rrr_hil_link_opts *o)
{
    return o->idle_timeout_ms > 0 ? o->idle_timeout_ms : RRR_HIL_SCD_IDLE_TIMEOUT_MS;
}

void rrr_hil_link_json(FILE *out, const rrr_hil_transport *t)
{
    const rrr_hil_transport_err *e = &t->err;
    fprintf(out,
            "\"transport\": \"%s\", \"rx_frames\": %llu, \"tx_frames\": %llu, "
            "\"rx_malformed\": %u, \"tx_dropped\": %u, \"tx_failed\": %u, \"bus_off\": %u, "
            "\"bus_errors\": %u, \"disconnects\": %u, \"connects\": %u, \"refused\": %u, "
            "\"handshake_timeouts\": %u, \"idle_timeouts\": %u",
            t->name ? t->name : "", (unsigned long long)e->rx_frames,
            (unsigned long long)e->tx_frames, e->rx_malformed, e->tx_dropped, e->tx_failed,
            e->bus_off, e->bus_errors, e->disconnects, e->connects, e->refused,
            e->handshake_timeouts, e->idle_timeouts);
    if (t->framelog != NULL) {
        fprintf(out, ", \"frames_logged\": %llu, \"frame_log_error\": \"%s\"",
                (unsigned long long)t->framelog->frames,
                t->framelog->error != 0 ? strerror(t->framelog->error) : "");
    }
}

/* ---- real time ------------------------------------------------------------------------------- */

static int64_t ts_ns(const struct timespec *t)
{
    return (int64_t)t->tv_sec * 1000000000 + t->tv_nsec;
}

static void ts_add(struct timespec *t, int64_t ns)
{
    const int64_t v = ts_ns(t) + ns;
    t->tv_sec = (time_t)(v / 1000000000);
    t->tv_nsec = (long)(v % 1000000000);
}

void rrr_hil_rt_opts_default(rrr_hil_rt_opts *o)
{
    memset(o, 0, sizeof *o);
    o->cpu = -1;
}

int rrr_hil_rt_arg(rrr_hil_rt_opts *o, int argc, char **argv, int *i, const char *prog)
{
    const char *a = argv[*i];
    if (strcmp(a, "--mlock") == 0) {
        o->mlock = 1;
        return 1;
    }
    const int is_fifo = strcmp(a, "--fifo") == 0;
    const int is_cpu = strcmp(a, "--cpu") == 0;
    const int is_spin = strcmp(a, "--spin-us") == 0;
    const int is_log = strcmp(a, "--latency-log") == 0;
    if (!is_fifo && !is_cpu && !is_spin && !is_log) {
        return 0;
    }
    const char *v;
    if (option_value(argc, argv, i, prog, &v) != 0) {
        return -1;
    }
    if (is_log) {
        return path_value(prog, a, v, &o->latency_log);
    }
    const long lo = is_fifo ? 0 : is_cpu ? -1 : 0;
    const long hi = is_fifo ? 99 : is_cpu ? CPU_SETSIZE - 1 : RRR_HIL_RT_MAX_SPIN_US;
    char *end;
    errno = 0;
    const long x = strtol(v, &end, 10);
    if (end == v || *end != '\0' || errno != 0 || x < lo || x > hi) {
        fprintf(stderr, "%s: %s: expected an integer %ld..%ld, got '%s'\n", prog, a, lo, hi, v);
        return -1;
    }
    *(is_fifo ? &o->fifo_prio : is_cpu ? &o->cpu : &o->spin_us) = (int)x;
    return 1;
}

FILE *rrr_hil_rt_open_log(const rrr_hil_rt_opts *o, int realtime, const char *prog, int *failed)
{
    *failed = 0;
    if (!realtime || o->latency_log == NULL) {
        return NULL;
    }
    FILE *fp = fopen(o->latency_log, "w");
    if (fp == NULL) {
        fprintf(stderr, "%s: cannot write %s: %s\n", prog, o->latency_log, strerror(errno));
        *failed = 1;
    }
    return fp;
}

static int64_t now_ns(void)
{
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return ts_ns(&t);
}

/* Append to rt->setup. */
static void setup_note(rrr_hil_rt *rt, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 2, 3)))
#endif
    ;
static void setup_note(rrr_hil_rt *rt, const char *fmt, ...)
{
    const size_t used = strlen(rt->setup);
    if (used + 1u >= sizeof rt->setup) {
        return;
    }
    va_list ap;
    va_start(ap, fmt);
    (void)vsnprintf(rt->setup + used, sizeof rt->setup - used, fmt, ap);
    va_end(ap);
}

static const char *perm_hint(int e)
{
    return e == EPERM ? " (needs root, or CAP_SYS_NICE / CAP_IPC_LOCK and a limit: ulimit -r, -l)"
                      : "";
}

int rrr_hil_rt_init(rrr_hil_rt *rt, double period_s, uint32_t max_periods,
                    const rrr_hil_rt_opts *o, FILE *latency_log, const char *prog)
{
    memset(rt, 0, sizeof *rt);
    rt->cpu = -1;
    rt->latency_log = latency_log;
    rt->period_ns = (int64_t)llround(period_s * 1e9);
    rt->spin_ns = (int64_t)o->spin_us * 1000;
    rt->cap = max_periods;
    rt->lat_ns = calloc(max_periods > 0u ? max_periods : 1u, sizeof *rt->lat_ns);
    rt->work_ns = calloc(max_periods > 0u ? max_periods : 1u, sizeof *rt->work_ns);
    if (rt->lat_ns == NULL || rt->work_ns == NULL) {
        rrr_hil_rt_free(rt);
        return -1;
    }
    setup_note(rt, "timer slack 1 ns: %s",
               prctl(PR_SET_TIMERSLACK, 1UL, 0UL, 0UL, 0UL) == 0 ? "yes" : strerror(errno));
    if (o->cpu >= 0) {
        cpu_set_t set;
        CPU_ZERO(&set);
        CPU_SET((size_t)o->cpu, &set);
        if (sched_setaffinity(0, sizeof set, &set) == 0) {
            rt->cpu = o->cpu;
            setup_note(rt, "; CPU %d: yes", o->cpu);
        } else {
            const int e = errno;
            setup_note(rt, "; CPU %d: %s", o->cpu, strerror(e));
            fprintf(stderr, "%s: warning: cannot pin to CPU %d: %s; running on any CPU\n", prog,
                    o->cpu, strerror(e));
        }
    }
    if (o->mlock) {
        if (mlockall(MCL_CURRENT | MCL_FUTURE) == 0) {
            rt->mlocked = 1;
            setup_note(rt, "; mlockall: yes");
            /* touch the statistics now, so that the loop takes no page fault on them */
            memset(rt->lat_ns, 0, (size_t)rt->cap * sizeof *rt->lat_ns);
            memset(rt->work_ns, 0, (size_t)rt->cap * sizeof *rt->work_ns);
        } else {
            const int e = errno;
            setup_note(rt, "; mlockall: %s", strerror(e));
            fprintf(stderr, "%s: warning: mlockall refused: %s%s; memory may be paged\n", prog,
                    strerror(e), perm_hint(e));
        }
    }
    if (o->fifo_prio > 0) {
        struct sched_param sp;
        memset(&sp, 0, sizeof sp);
        sp.sched_priority = o->fifo_prio;
        if (sched_setscheduler(0, SCHED_FIFO, &sp) == 0) {
            rt->fifo = o->fifo_prio;
            setup_note(rt, "; SCHED_FIFO %d: yes", o->fifo_prio);
        } else {
            const int e = errno;
            setup_note(rt, "; SCHED_FIFO %d: %s", o->fifo_prio, strerror(e));
            fprintf(stderr, "%s: warning: SCHED_FIFO %d refused: %s%s; running under the default "
                            "scheduler\n", prog, o->fifo_prio, strerror(e), perm_hint(e));
        }
    }
    setup_note(rt, "; wake-up: %s", rt->spin_ns > 0 ? "sleep, then spin" : "sleep");
    if (rt->spin_ns > 0) {
        setup_note(rt, " %d us", o->spin_us);
    }
    clock_gettime(CLOCK_MONOTONIC, &rt->next);
    ts_add(&rt->next, rt->period_ns);
    return 0;
}

void rrr_hil_rt_shift(rrr_hil_rt *rt, double shift_s)
{
    ts_add(&rt->next, (int64_t)llround(shift_s * 1e9));
}

void rrr_hil_rt_wait(rrr_hil_rt *rt)
{
    const int64_t release = ts_ns(&rt->next);
    struct timespec wake = rt->next;
    ts_add(&wake, -rt->spin_ns);
    while (clock_nanosleep(CLOCK_MONOTONIC, TIMER_ABSTIME, &wake, NULL) == EINTR) {
    }
    int64_t now = now_ns();
    while (now < release) { /* the spin: at most spin_ns when the sleep woke in time */
        now = now_ns();
    }
    rt->woke.tv_sec = (time_t)(now / 1000000000);
    rt->woke.tv_nsec = (long)(now % 1000000000);
    if (rt->n < rt->cap) {
        rt->lat_ns[rt->n++] = now - release;
    }
}

void rrr_hil_rt_done(rrr_hil_rt *rt)
{
    const int64_t now = now_ns();
    const int64_t work = now - ts_ns(&rt->woke);
    if (work > rt->work_max_ns) {
        rt->work_max_ns = work;
    }
    if (rt->n_work < rt->cap) {
        rt->work_ns[rt->n_work++] = work;
    }
    ts_add(&rt->next, rt->period_ns);
    if (now > ts_ns(&rt->next)) {
        ++rt->misses;
        /* catch up: skip the releases already past instead of bursting through them */
        while (now > ts_ns(&rt->next)) {
            ts_add(&rt->next, rt->period_ns);
            ++rt->skipped;
        }
    }
}

static int cmp_i64(const void *a, const void *b)
{
    const int64_t x = *(const int64_t *)a;
    const int64_t y = *(const int64_t *)b;
    return (x > y) - (x < y);
}

int64_t rrr_hil_percentile(const int64_t *sorted, uint32_t n, double p)
{
    if (n == 0u) {
        return 0;
    }
    double rank = ceil(p * (double)n);
    if (rank < 1.0) {
        rank = 1.0;
    }
    if (rank > (double)n) {
        rank = (double)n;
    }
    return sorted[(uint32_t)rank - 1u];
}

static void write_latency_log(rrr_hil_rt *rt)
{
    if (rt->latency_log == NULL) {
        return;
    }
    _Static_assert(RRR_HIL_LATENCY_LOG_COLUMNS == 3, "k, latency_ns, work_ns (rrr_hil_logs.h)");
    int ok = fputs(RRR_HIL_LATENCY_LOG_HEADER, rt->latency_log) >= 0; /* gen/rrr_hil_logs.h */
    for (uint32_t k = 0; k < rt->n && ok; ++k) {
        ok = fprintf(rt->latency_log, "%u,%lld,%lld\n", k, (long long)rt->lat_ns[k],
                     k < rt->n_work ? (long long)rt->work_ns[k] : -1LL) > 0;
    }
    rt->latency_log_ok = (fclose(rt->latency_log) == 0) && ok;
    rt->latency_log = NULL;
}

void rrr_hil_rt_print(rrr_hil_rt *rt, const char *prog)
{
    printf("RRR_HIL_RT {");
    rrr_hil_rt_report(rt, stdout, prog);
    printf("}\n");
}

void rrr_hil_rt_report(rrr_hil_rt *rt, FILE *out, const char *prog)
{
    write_latency_log(rt); /* before the sort below: one row per period, in order */
    double p50 = 0.0, p99 = 0.0, p999 = 0.0, mx = 0.0;
    if (rt->n > 0u) {
        qsort(rt->lat_ns, rt->n, sizeof *rt->lat_ns, cmp_i64);
        p50 = (double)rrr_hil_percentile(rt->lat_ns, rt->n, 0.50) * 1e-3;
        p99 = (double)rrr_hil_percentile(rt->lat_ns, rt->n, 0.99) * 1e-3;
        p999 = (double)rrr_hil_percentile(rt->lat_ns, rt->n, 0.999) * 1e-3;
        mx = (double)rt->lat_ns[rt->n - 1u] * 1e-3;
    }
    fprintf(stderr,
            "%s: real time: %u periods of %.0f us; wake-up latency p50 %.1f us, p99 %.1f us, "
            "p99.9 %.1f us, max %.1f us; %u deadline misses (%u releases skipped); longest work "
            "%.1f us; %s\n",
            prog, rt->n, (double)rt->period_ns * 1e-3, p50, p99, p999, mx, rt->misses,
            rt->skipped, (double)rt->work_max_ns * 1e-3, rt->setup);
    fprintf(out,
            "\"rt_periods\": %u, \"rt_latency_p50_us\": %.3f, \"rt_latency_p99_us\": %.3f, "
            "\"rt_latency_p999_us\": %.3f, \"rt_latency_max_us\": %.3f, \"rt_deadline_misses\": "
            "%u, \"rt_skipped\": %u, \"rt_work_max_us\": %.3f, \"rt_fifo\": %d, \"rt_mlock\": %d, "
            "\"rt_cpu\": %d, \"rt_spin_us\": %.3f, \"rt_latency_log_ok\": %d, \"rt_setup\": \"%s\"",
            rt->n, p50, p99, p999, mx, rt->misses, rt->skipped, (double)rt->work_max_ns * 1e-3,
            rt->fifo, rt->mlocked, rt->cpu, (double)rt->spin_ns * 1e-3, rt->latency_log_ok,
            rt->setup);
}

void rrr_hil_rt_free(rrr_hil_rt *rt)
{
    free(rt->lat_ns);
    free(rt->work_ns);
    rt->lat_ns = NULL;
    rt->work_ns = NULL;
    if (rt->latency_log != NULL) {
        fclose(rt->latency_log);
        rt->latency_log = NULL;
    }
}
