/*
 * rrr_hil_plant: the plant node of the CAN bench. Runs the plant FMU (the same rrr_plant binary
 * the Python co-simulation uses, loaded with dlopen) behind the bus profile --profile names (the
 * table below, from RRR_HIL_PROFILES in c_src/hil/CMakeLists.txt): dbc/hil_dbc_plant.c (the
 * default: the DBC's frames through the command supervisor) or canopen/hil_canopen_plant.c (three
 * CiA 402 drives). By default it is the socketcand server the controller (C node or python-can)
 * connects to. This file reads the command line, sets up the FMU, the logs and the transport, runs
 * the profile and reports the end.
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

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hil_plant.h"
#include "hil_profiles.h" /* generated: RRR_HIL_PROFILES(X), one X(name) per profile */
#include "rrr_hil_logs.h"

#define PROG "rrr_hil_plant"
#define MAX_SETS RRR_HIL_PLANT_MAX_SETS

#define RRR_HIL_DECLARE(name) extern const rrr_hil_plant_profile rrr_hil_##name##_plant;
RRR_HIL_PROFILES(RRR_HIL_DECLARE)
#define RRR_HIL_ROW(name) &rrr_hil_##name##_plant,
static const rrr_hil_plant_profile *const PROFILES[] = {RRR_HIL_PROFILES(RRR_HIL_ROW)};
#define N_PROFILES (sizeof PROFILES / sizeof PROFILES[0])

static void usage(void)
{
    fprintf(stderr,
            "usage: " PROG " --fmu DIR (--listen HOST:PORT | --connect HOST:PORT | --socketcan IF)\n"
            RRR_HIL_LINK_USAGE
            "       [--realtime --duration S [--fifo PRIO] [--mlock] [--cpu N] [--spin-us N]\n"
            "       [--latency-log FILE.csv]]\n"
            "       [--q0 a,b,c] [--qd0 a,b,c] [--set NAME=VALUE]... [--max-missed N]\n"
            "       [--max-delta-counter N] [--log FILE.csv] [--profile ");
    for (size_t i = 0; i < N_PROFILES; ++i) {
        fprintf(stderr, "%s%s", i ? "|" : "", PROFILES[i]->name);
    }
    fprintf(stderr,
            "]\n"
            "       [--node-ids a,b,c] [--end-after-stop-ms N]\n"
            "  DIR: the unzipped plant FMU (modelDescription.xml, binaries/linux64/rrr_plant.so)\n");
    for (size_t i = 0; i < N_PROFILES; ++i) {
        fputs(PROFILES[i]->usage, stderr);
    }
    fprintf(stderr,
            RRR_HIL_RT_USAGE
            "  exit: 0 end of run (the controller's StopCmd), 1 usage, 2 setup, 3 controller lost,\n"
            "  4 SIGINT/SIGTERM, 5 FMU failed, 6 the controller stopped early, 7 end of run but the\n"
            "  safety policy fired (a fault latched or 0 V forced; docs/can-bench.md, Exit statuses)\n");
}

static int parse_args(int argc, char **argv, rrr_hil_plant_opts *o)
{
    memset(o, 0, sizeof *o);
    o->node_ids[0] = 1;
    o->node_ids[1] = 2;
    o->node_ids[2] = 3;
    o->max_missed = -1;
    o->max_delta_counter = -1;
    rrr_hil_rt_opts_default(&o->rt);
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
        } else if ((r = rrr_hil_profile_arg(a, v, profile_names, N_PROFILES, &o->profile,
                                            o->node_ids, PROG)) != 0) {
            if (r < 0) {
                return -1;
            }
        } else if (strcmp(a, "--end-after-stop-ms") == 0) {
            const long x = strtol(v, &end, 10);
            if (*end != '\0' || x < 1 || x > 3600000) {
                fprintf(stderr, PROG ": --end-after-stop-ms: expected milliseconds 1..3600000, "
                                     "got '%s'\n", v);
                return -1;
            }
            o->end_after_stop_ms = (int)x;
        } else if (strcmp(a, "--max-missed") == 0 || strcmp(a, "--max-delta-counter") == 0) {
            const long x = strtol(v, &end, 10);
            if (*end != '\0' || x < 0 || x > 99) {
                fprintf(stderr, PROG ": %s: expected an integer 0..99, got '%s'\n", a, v);
                return -1;
            }
            if (a[6] == 'm') {
                o->max_missed = (int)x;
            } else {
                o->max_delta_counter = (int)x;
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
    const rrr_hil_plant_profile *p = PROFILES[o->profile];
    if (p->check != NULL && p->check(o) != 0) {
        return -1;
    }
    /* the DBC supervisor's settings (-1: its default, 3) */
    if (o->max_missed == 0 || o->max_delta_counter == 0 || o->max_delta_counter > 15) {
        fprintf(stderr, PROG ": --max-missed must be >= 1 and --max-delta-counter in 1..15\n");
        return -1;
    }
    return 0;
}

int main(int argc, char **argv)
{
    rrr_hil_plant_opts o;
    if (parse_args(argc, argv, &o) != 0) {
        usage();
        return RRR_HIL_EXIT_USAGE;
    }
    const rrr_hil_plant_profile *profile = PROFILES[o.profile];
    rrr_hil_install_signals();
    static rrr_hil_plant p;
    memset(&p, 0, sizeof p);
    if (rrr_hil_plant_setup_fmu(&p, &o) != 0 ||
        (profile->setup != NULL && profile->setup(&p, &o) != 0)) {
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
        rrr_hil_plant_log_row(&p);
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
    uint32_t rx_ids[RRR_HIL_PLANT_MAX_RX_IDS];
    const unsigned n_rx = profile->rx_ids(&o, rx_ids);
    if (rrr_hil_link_open(&o.link, &link, rx_ids, n_rx, PROG, &frames) != 0) {
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
    int rc = profile->run(&p, &o, latency_log, &frames); /* owns latency_log */
    rrr_hil_close(p.tr);
    rc = rrr_hil_log_close(p.log, o.log_path, &p.run, rc);
    rrr_hil_fmu_close(&p.fmu);
    return rrr_hil_run_report(PROG, rc, &p.run);
}
