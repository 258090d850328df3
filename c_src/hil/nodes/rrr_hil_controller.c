/*
 * rrr_hil_controller: the controller node of the CAN bench. Runs the core's computed-torque law
 * (rrr_ctc, eq 15) at 1 kHz along a reference table (the reference FMU's CSV, its columns t,
 * q_ref, qd_ref, qdd_ref found by name, one row per period; `rrr hil export-reference` writes
 * it) on the joint states it receives, and sends its commands every period over the bus profile
 * --profile names (the table below, from RRR_HIL_PROFILES in c_src/hil/CMakeLists.txt):
 * dbc/hil_dbc_controller.c (the default: VoltageCmd, Sync in lockstep, StopCmd at the end) or
 * canopen/hil_canopen_controller.c (a CANopen master of three CiA 402 drives). By default it
 * connects to the plant node as a socketcand client. This file reads the command line, sets up
 * the model, the reference, the logs and the transport, runs the profile and reports the end.
 *
 * Output: a summary on stderr and "RRR_HIL_SUMMARY {json}" on stdout, then one line on stderr
 * that says how the run ended ("rrr_hil_controller: exit 4 (interrupted) at period 17: SIGINT");
 * with --log, one CSV row per period (k, t, measured q and qd, u, u_n, u_c).
 * Exit status (rrr_hil_exit, hil_node.h): 0 every period done and StopCmd sent; 1 usage; 2 setup
 * failed (or the --log could not be written); 3 the plant was lost (hang-up, no joint state
 * within --timeout-ms, transport error); 4 SIGINT/SIGTERM; 5 a fault of the controller (a command
 * it cannot encode); 7 completed, but a PlantStatus frame reported a latched fault or 0 V (the
 * plant's safety policy fired); 8 tampered input (a frame the plant never sends: the profile's).
 */
#define _POSIX_C_SOURCE 200809L

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hil_controller.h"
#include "hil_profiles.h" /* generated: RRR_HIL_PROFILES(X), one X(name) per profile */
#include "rrr_hil_logs.h"

#define PROG "rrr_hil_controller"

#define RRR_HIL_DECLARE(name) extern const rrr_hil_ctrl_profile rrr_hil_##name##_controller;
RRR_HIL_PROFILES(RRR_HIL_DECLARE)
#define RRR_HIL_ROW(name) &rrr_hil_##name##_controller,
static const rrr_hil_ctrl_profile *const PROFILES[] = {RRR_HIL_PROFILES(RRR_HIL_ROW)};
#define N_PROFILES (sizeof PROFILES / sizeof PROFILES[0])

static void usage(void)
{
    fprintf(stderr,
            "usage: " PROG " --reference REF.csv (--connect HOST:PORT | --listen HOST:PORT |\n"
            "       --socketcan IF)\n" RRR_HIL_LINK_USAGE
            "       [--realtime [--fifo PRIO] [--mlock] [--cpu N] [--spin-us N]\n"
            "       [--latency-log FILE.csv]]\n"
            "       [--kp a,b,c] [--kd a,b,c] [--no-feedforward] [--set NAME=VALUE]...\n"
            "       [--timeout-ms N] [--log FILE.csv] [--profile ");
    for (size_t i = 0; i < N_PROFILES; ++i) {
        fprintf(stderr, "%s%s", i ? "|" : "", PROFILES[i]->name);
    }
    fprintf(stderr,
            "]\n"
            "       [--node-ids a,b,c] [--consumer-ms MS] [--rpdo-timeout N]\n"
            "  the model is the default robot (rrr_model_default) with the --set parameters\n"
            "  (named as in the FMUs: d1, a2, a3, d2, d3, g, u_max, p[k], kt[i], b[i], f[i,k],\n"
            "  w[i,k]), so the controller's model may differ from the plant's; gains default\n"
            "  to rrr_ctc_gains_default; --timeout-ms (5000): longest wait for a joint state\n");
    for (size_t i = 0; i < N_PROFILES; ++i) {
        fputs(PROFILES[i]->usage, stderr);
    }
    fprintf(stderr,
            RRR_HIL_RT_USAGE
            "  exit: 0 completed, 1 usage, 2 setup, 3 plant lost, 4 SIGINT/SIGTERM, 5 fault,\n"
            "  7 completed but the plant's safety policy fired (PlantStatus: a fault latched or\n"
            "  0 V forced), 8 tampered input: a frame the plant never sends (a second one of a\n"
            "  kind in one period, a wrong length), named (docs/can-bench.md, Exit statuses)\n");
}

static int parse_args(int argc, char **argv, rrr_hil_ctrl_opts *o)
{
    memset(o, 0, sizeof *o);
    (void)rrr_ctc_gains_default(&o->gains);
    o->timeout_ms = 5000;
    rrr_hil_rt_opts_default(&o->rt);
    o->node_ids[0] = 1;
    o->node_ids[1] = 2;
    o->node_ids[2] = 3;
    const char *profile_names[N_PROFILES];
    for (size_t i = 0; i < N_PROFILES; ++i) {
        profile_names[i] = PROFILES[i]->name;
    }
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
            } else if ((r = rrr_hil_profile_arg(a, v, profile_names, N_PROFILES, &o->profile,
                                                o->node_ids, PROG)) != 0) {
                if (r < 0) {
                    return -1;
                }
            } else if (strcmp(a, "--consumer-ms") == 0 || strcmp(a, "--rpdo-timeout") == 0) {
                const int is_consumer = a[2] == 'c';
                const long hi = is_consumer ? 65535 : 255;
                const long x = strtol(v, &end, 10);
                if (end == v || *end != '\0' || x < 1 || x > hi) {
                    fprintf(stderr, PROG ": %s: expected an integer 1..%ld, got '%s'\n", a, hi,
                            v);
                    return -1;
                }
                *(is_consumer ? &o->consumer_ms : &o->rpdo_timeout) = (uint32_t)x;
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
    const rrr_hil_ctrl_profile *p = PROFILES[o->profile];
    return p->check != NULL ? p->check(o) : 0;
}

int main(int argc, char **argv)
{
    rrr_hil_ctrl_opts o;
    if (parse_args(argc, argv, &o) != 0) {
        usage();
        return RRR_HIL_EXIT_USAGE;
    }
    const rrr_hil_ctrl_profile *profile = PROFILES[o.profile];
    rrr_hil_install_signals();
    static rrr_hil_ctrl c;
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
    uint32_t rx_ids[RRR_HIL_CTRL_MAX_RX_IDS];
    const unsigned n_rx = profile->rx_ids(&o, rx_ids);
    int rc = rrr_hil_run_end(&c.run, RRR_HIL_EXIT_SETUP, "the transport did not open");
    if (rrr_hil_link_open(&o.link, &link, rx_ids, n_rx, PROG, &frames) == 0) {
        c.tr = &link.base;
        rc = profile->run(&c, &o, latency_log, &frames);
        latency_log = NULL; /* the profile's run owns it */
        rrr_hil_close(c.tr);
    }
    if (latency_log != NULL) {
        fclose(latency_log);
    }
    rc = rrr_hil_log_close(c.log, o.log_path, &c.run, rc);
    rrr_hil_reference_free(&c.ref);
    return rrr_hil_run_report(PROG, rc, &c.run);
}
