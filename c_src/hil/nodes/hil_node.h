/**
 * @file hil_node.h
 * @brief What both bench nodes share: exit statuses, command-line pieces, opening the transport
 *        they name, the real-time loop with its statistics, and the reference table of the
 *        controller.
 */
#ifndef RRR_HIL_NODE_H
#define RRR_HIL_NODE_H

#include <stdint.h>
#include <stdio.h>
#include <time.h>

#include "hil_framelog.h"
#include "hil_reference.h"
#include "hil_transport.h"
#include "rrr/rrr_model.h"

/* ---- exit statuses --------------------------------------------------------------------------- */

/** Exit status of rrr_hil_plant and rrr_hil_controller. A node that ends before it completes
 *  never exits 0, and prints why in one line (rrr_hil_report_exit). */
typedef enum rrr_hil_exit {
    RRR_HIL_EXIT_OK = 0,          ///< completed: controller: every period of the reference, then
                                  ///< StopCmd (end of run); plant: the controller's StopCmd (end of
                                  ///< run), or --duration in real time
    RRR_HIL_EXIT_USAGE = 1,       ///< bad command line
    RRR_HIL_EXIT_SETUP = 2,       ///< setup failed (FMU, reference, model, log file, transport)
    RRR_HIL_EXIT_PEER_LOST = 3,   ///< the peer hung up, stayed silent past the timeout, or the
                                  ///< transport failed (bus-off, I/O error)
    RRR_HIL_EXIT_INTERRUPTED = 4, ///< SIGINT or SIGTERM
    RRR_HIL_EXIT_FAULT = 5,       ///< a fault of the node itself: the FMU failed (plant), a command
                                  ///< that cannot be encoded (controller)
    RRR_HIL_EXIT_STOPPED_EARLY = 6, ///< plant: the controller's StopCmd gave a reason other than
                                    ///< the end of the run (it was interrupted, faulted, lost us)
    RRR_HIL_EXIT_SAFETY = 7, ///< the run completed (as for 0), but the safety policy fired: plant:
                             ///< a fault latched (even if reset later) or 0 V was forced for at
                             ///< least one period; controller: a PlantStatus frame reported a
                             ///< latched fault or 0 V (docs/can-bench.md, "Exit statuses")
    RRR_HIL_EXIT_TAMPERED = 8 ///< controller: a frame its bus profile never sends came, so the
                              ///< inputs were tampered with (or a node is broken): a second frame
                              ///< of one kind in one period (a duplicated TPDO, JointState), or
                              ///< a TPDO whose length is not its mapping's; the run ends at once
} rrr_hil_exit;

/** Static name of an exit status ("completed", "peer lost", ...). */
const char *rrr_hil_exit_str(int code);

/**
 * @brief Print the one line that says how the node ended, on stderr:
 *        "PROG: exit CODE (NAME) at period K: REASON". Control characters in the reason (it may
 *        quote what a peer sent) are replaced by '?', so it stays one line.
 * @return code
 */
int rrr_hil_report_exit(const char *prog, int code, uint32_t period, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 4, 5)))
#endif
    ;

/* ---- how a run ends (both nodes, every profile) ---------------------------------------------- */

/** How a node's run ends: the period it reached and why it ended, for the exit line. */
typedef struct rrr_hil_run {
    uint32_t k;    ///< the current period ("at period K" in the exit line)
    char why[320]; ///< why the run ended (rrr_hil_run_end), "" until then
} rrr_hil_run;

/** Record why the run ends (printf format, into r->why); returns @p code. */
int rrr_hil_run_end(rrr_hil_run *r, int code, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
/** The run ends on SIGINT or SIGTERM: RRR_HIL_EXIT_INTERRUPTED, the signal's name as the reason. */
int rrr_hil_run_interrupted(rrr_hil_run *r);
/** A run that completed (@p rc is RRR_HIL_EXIT_OK) while the safety policy fired: "; " and the
 *  text are appended to r->why and RRR_HIL_EXIT_SAFETY is returned; any other @p rc as it is. */
int rrr_hil_run_safety(rrr_hil_run *r, int rc, const char *fmt, ...)
#if defined(__GNUC__)
    __attribute__((format(printf, 3, 4)))
#endif
    ;
/** Close the node's --log @p fp (NULL: none) written to @p path: a write that failed (a full
 *  disk) turns a run that completed (@p rc 0 or RRR_HIL_EXIT_SAFETY) into RRR_HIL_EXIT_SETUP
 *  with "cannot write the log PATH: REASON" (a log cut short is never taken for a whole one);
 *  any other @p rc as it is. */
int rrr_hil_log_close(FILE *fp, const char *path, rrr_hil_run *r, int rc);
/** The exit line of the run (rrr_hil_report_exit with r's period and reason); returns @p rc. */
int rrr_hil_run_report(const char *prog, int rc, const rrr_hil_run *r);
/** CLOCK_MONOTONIC, ms. */
int64_t rrr_hil_now_ms(void);

/* ---- transport from the command line --------------------------------------------------------- */

/** Which transport, from --listen HOST:PORT, --connect HOST:PORT or --socketcan IF. */
typedef struct rrr_hil_link_opts {
    int kind;          ///< 0 none given, 1 socketcand server, 2 socketcand client, 3 SocketCAN
    char host[64];     ///< IPv4 address
    uint16_t port;     ///< TCP port (server: 0 = any free port)
    char ifname[32];   ///< SocketCAN interface
    char channel[32];  ///< socketcand bus name (--channel, default "bench0")
    int connect_wait_ms; ///< client: how long to retry connecting (5000)
    int handshake_timeout_ms; ///< socketcand server: --handshake-timeout-ms (0: default, 2000)
    int idle_timeout_ms;      ///< --idle-timeout-ms (0: default, 5000): socketcand idle timeout,
                              ///< and the plant's limit on a silent controller
    const char *frame_log;    ///< --frame-log FILE: every frame sent and received (hil_framelog.h)
    int can_fd;               ///< --fd: CAN FD frames with bit-rate switch (SocketCAN only)
} rrr_hil_link_opts;

/** Storage for any transport. */
typedef union rrr_hil_link {
    rrr_hil_transport base;
    rrr_hil_scd scd;
    rrr_hil_socketcan sc;
} rrr_hil_link;

/** SIGINT and SIGTERM ask the node to stop (see rrr_hil_stop_requested); SIGPIPE is ignored
 *  (a peer that hangs up shows as a send error). */
void rrr_hil_install_signals(void);
/** 1 once SIGINT or SIGTERM arrived. */
int rrr_hil_stop_requested(void);
/** Name of the stop signal that arrived ("SIGINT", "SIGTERM"), "" if none. */
const char *rrr_hil_stop_signal_name(void);

/** Parse "HOST:PORT". 0 or -1. */
int rrr_hil_parse_hostport(const char *s, char host[64], uint16_t *port);
/** Parse "a,b,c" into three finite doubles. 0 or -1. */
int rrr_hil_parse_vec3(const char *s, double v[3]);
/** The options both nodes share for their bus profile: "--profile NAME" (one of the @p n_names
 *  @p names, its index into *profile) and "--node-ids a,b,c" (the CANopen drives: three distinct
 *  node ids 1..127, into ids). @p a is the option, @p v its value. 1 consumed, 0 not one of them,
 *  -1 a bad value (message printed). */
int rrr_hil_profile_arg(const char *a, const char *v, const char *const *names, unsigned n_names,
                        int *profile, uint8_t ids[3], const char *prog);
/** Apply "NAME=VALUE" to a model, NAME as the FMUs name the parameters: d1, a2, a3, d2, d3, g,
 *  u_max, p[1..16], kt[i], b[i], f[i,k], w[i,k] (i, k = 1..3). The value must be finite; the
 *  model is not validated here (call rrr_model_validate after the last one). 0, or -1 with a
 *  message in err. */
int rrr_hil_set_model_param(rrr_model *m, const char *assignment, char *err, size_t err_len);
/** Handle a transport option (argv[*i] and its value: --listen, --connect, --socketcan,
 *  --channel, --handshake-timeout-ms, --idle-timeout-ms, --frame-log, --fd); 1 consumed, 0 not a
 *  transport option, -1 bad value (message printed). */
int rrr_hil_link_arg(rrr_hil_link_opts *o, int argc, char **argv, int *i, const char *prog);
/** Open the frame log of --frame-log (before the transport: a path that cannot be written fails
 *  before anything listens or connects) and then the transport, which logs into @p log; SocketCAN
 *  receives only @p rx_ids. Prints "PROG: listening on H:P" for a server. 0 or -1 (message
 *  printed to stderr; nothing left open). Close the log with rrr_hil_framelog_close after the
 *  run, before rrr_hil_link_json reports it. */
int rrr_hil_link_open(const rrr_hil_link_opts *o, rrr_hil_link *l, const uint32_t *rx_ids,
                      unsigned n_rx, const char *prog, rrr_hil_framelog *log);
/** The idle timeout in effect, ms (--idle-timeout-ms or RRR_HIL_SCD_IDLE_TIMEOUT_MS). */
int rrr_hil_link_idle_ms(const rrr_hil_link_opts *o);
/** Usage lines of the transport options. */
#define RRR_HIL_LINK_USAGE                                                                        \
    "       [--channel NAME] [--handshake-timeout-ms N] [--idle-timeout-ms N]\n"                \
    "  socketcand server: one session; a client must finish the handshake within\n"            \
    "  --handshake-timeout-ms (2000) and may stay silent at most --idle-timeout-ms (5000)\n"    \
    "       [--frame-log FILE]: every frame sent and received, timestamped (hil_framelog.h)\n"  \
    "       [--fd]: with --socketcan, every frame as a CAN FD frame with bit-rate switch (the\n" \
    "  interface needs MTU 72); classical frames received are dropped and counted\n"
/** Print the transport's counters, and its frame log's, as JSON members (no braces). */
void rrr_hil_link_json(FILE *out, const rrr_hil_transport *t);

/* ---- real-time loop -------------------------------------------------------------------------- */

/** Real-time options of a node (--fifo, --mlock, --cpu, --spin-us, --latency-log). */
typedef struct rrr_hil_rt_opts {
    int fifo_prio;           ///< SCHED_FIFO priority 1..99, 0: the default scheduler
    int mlock;               ///< mlockall(MCL_CURRENT | MCL_FUTURE)
    int cpu;                 ///< pin to this CPU (sched_setaffinity), -1: no affinity
    int spin_us;             ///< sleep until this long before each release, then spin on
                             ///< CLOCK_MONOTONIC up to it (0: sleep only)
    const char *latency_log; ///< CSV of every period's wake-up latency and work time
} rrr_hil_rt_opts;

/** No SCHED_FIFO, no mlockall, no affinity, no spin, no log. */
void rrr_hil_rt_opts_default(rrr_hil_rt_opts *o);
/** Handle a real-time option (argv[*i] and its value); 1 consumed, 0 not one, -1 bad value. */
int rrr_hil_rt_arg(rrr_hil_rt_opts *o, int argc, char **argv, int *i, const char *prog);
/** Usage lines of the real-time options. */
#define RRR_HIL_RT_USAGE                                                                          \
    "       [--fifo PRIO] [--mlock] [--cpu N] [--spin-us N] [--latency-log FILE.csv]\n"         \
    "  real time: SCHED_FIFO priority 1..99, mlockall, pinned to CPU N, clock_nanosleep to N us\n" \
    "  before each release and then a spin on CLOCK_MONOTONIC (each when permitted: a warning\n"  \
    "  and the fallback otherwise); the latency log has one row per period\n"

/** Open --latency-log for writing when @p realtime (NULL when not asked for); on failure print
 *  "PROG: cannot write FILE: ..." and set *failed. */
FILE *rrr_hil_rt_open_log(const rrr_hil_rt_opts *o, int realtime, const char *prog, int *failed);

/** Largest --spin-us (a quarter of the 1 ms period). */
#define RRR_HIL_RT_MAX_SPIN_US 250

/** Periodic loop on CLOCK_MONOTONIC with absolute-time sleeps and its statistics. */
typedef struct rrr_hil_rt {
    int64_t period_ns;   ///< period
    int64_t spin_ns;     ///< spin before each release (sleep-then-spin), 0: sleep only
    struct timespec next; ///< next release time
    int64_t *lat_ns;     ///< wake-up latency of each period (heap, cap entries)
    int64_t *work_ns;    ///< work time of each period (heap, cap entries)
    uint32_t n, cap;     ///< periods recorded, capacity
    uint32_t n_work;     ///< work times recorded
    uint32_t misses;     ///< periods whose work ended after the next release (deadline misses)
    uint32_t skipped;    ///< releases skipped to catch up after a miss
    int64_t work_max_ns; ///< longest work time of a period
    struct timespec woke; ///< wake-up time of the current period
    int fifo, mlocked, cpu; ///< applied: SCHED_FIFO priority (0: no), mlockall, CPU (-1: none)
    FILE *latency_log;   ///< written and closed by rrr_hil_rt_report
    int latency_log_ok;  ///< 1 once written completely
    char setup[320];     ///< what was applied: SCHED_FIFO, mlockall, affinity, timer slack, spin
} rrr_hil_rt;

/**
 * @brief Prepare: timer slack 1 ns, then what @p o asks (SCHED_FIFO, mlockall, CPU affinity,
 *        spin). What is refused (EPERM without root / CAP_SYS_NICE / CAP_IPC_LOCK, a CPU that
 *        is not ours) is printed as one warning line on stderr ("PROG: warning: ...") and the
 *        node goes on without it; rt->setup says what was applied. @p latency_log (may be NULL)
 *        is an open file for the per-period log, owned by rt from here on.
 * @return 0 or -1 (no memory).
 */
int rrr_hil_rt_init(rrr_hil_rt *rt, double period_s, uint32_t max_periods,
                    const rrr_hil_rt_opts *o, FILE *latency_log, const char *prog);
/** Move every later release by @p shift_s (phase against another node's loop). */
void rrr_hil_rt_shift(rrr_hil_rt *rt, double shift_s);
/** Wait for the next release (clock_nanosleep TIMER_ABSTIME, to spin_ns before it and then a
 *  spin on CLOCK_MONOTONIC when spin_ns > 0) and record the wake-up latency. */
void rrr_hil_rt_wait(rrr_hil_rt *rt);
/** End of the period's work: record its time, count a miss if it ended after the next release. */
void rrr_hil_rt_done(rrr_hil_rt *rt);
/** Write the latency log (if any), then print p50/p99/p99.9/max latency and misses as text on
 *  stderr and as JSON members on out. */
void rrr_hil_rt_report(rrr_hil_rt *rt, FILE *out, const char *prog);
/** rrr_hil_rt_report as the one line "RRR_HIL_RT {...}" on stdout. */
void rrr_hil_rt_print(rrr_hil_rt *rt, const char *prog);
/** Free the statistics buffers (and close a latency log not written). */
void rrr_hil_rt_free(rrr_hil_rt *rt);
/** Percentile @p p (0..1) of n sorted values: the value of rank ceil(p n) (nearest rank). */
int64_t rrr_hil_percentile(const int64_t *sorted, uint32_t n, double p);

#endif /* RRR_HIL_NODE_H */
