/* The pieces of the bench nodes' real-time mode and frame log that need no peer: percentiles
 * (nearest rank), the real-time options (ranges), a short sleep-then-spin loop (latencies
 * recorded, none negative: not a timing test), its per-period latency log, and the frame log's
 * record layout and file (hil_framelog.h), which rrr_robot.hil.logs.frames reads; the reference
 * table reader (the reference FMU's 19-column table, its columns found by name). */
#define _GNU_SOURCE /* CPU_SETSIZE */

#include <sched.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include "hil_framelog.h"
#include "hil_node.h"
#include "rrr_test.h"

static int parse(rrr_hil_rt_opts *o, const char *opt, const char *value)
{
    char a0[] = "prog";
    char a1[32], a2[32];
    snprintf(a1, sizeof a1, "%s", opt);
    snprintf(a2, sizeof a2, "%s", value ? value : "");
    char *argv[] = {a0, a1, a2, NULL};
    int i = 1;
    return rrr_hil_rt_arg(o, value ? 3 : 2, argv, &i, "test");
}

static void test_percentiles(void)
{
    int64_t v[1000];
    for (int i = 0; i < 1000; ++i) {
        v[i] = i + 1;
    }
    CHECK(rrr_hil_percentile(v, 1000, 0.50) == 500);
    CHECK(rrr_hil_percentile(v, 1000, 0.99) == 990);
    CHECK(rrr_hil_percentile(v, 1000, 0.999) == 999);
    CHECK(rrr_hil_percentile(v, 1000, 1.0) == 1000);
    CHECK(rrr_hil_percentile(v, 1, 0.99) == 1);
    CHECK(rrr_hil_percentile(v, 0, 0.5) == 0);
    CHECK(rrr_hil_percentile(v, 10, 0.0) == 1);
}

static void test_options(void)
{
    rrr_hil_rt_opts o;
    rrr_hil_rt_opts_default(&o);
    CHECK(o.cpu == -1 && o.fifo_prio == 0 && o.spin_us == 0 && o.mlock == 0);
    CHECK(parse(&o, "--fifo", "80") == 1 && o.fifo_prio == 80);
    CHECK(parse(&o, "--fifo", "100") == -1 && o.fifo_prio == 80);
    CHECK(parse(&o, "--cpu", "1") == 1 && o.cpu == 1);
    CHECK(parse(&o, "--cpu", "x") == -1);
    CHECK(parse(&o, "--spin-us", "250") == 1 && o.spin_us == 250);
    CHECK(parse(&o, "--spin-us", "251") == -1 && o.spin_us == 250);
    CHECK(parse(&o, "--spin-us", "-1") == -1);
    CHECK(parse(&o, "--mlock", NULL) == 1 && o.mlock == 1);
    CHECK(parse(&o, "--latency-log", "") == -1);
    CHECK(parse(&o, "--other", "1") == 0);
}

static void test_loop(const char *dir)
{
    char path[512];
    snprintf(path, sizeof path, "%s/latency.csv", dir);
    FILE *log = fopen(path, "w");
    CHECK(log != NULL);
    rrr_hil_rt_opts o;
    rrr_hil_rt_opts_default(&o);
    o.spin_us = 100;
    rrr_hil_rt rt;
    CHECK(rrr_hil_rt_init(&rt, 1e-3, 20u, &o, log, "test") == 0);
    for (int k = 0; k < 25; ++k) { /* more periods than recorded: the extra are not */
        rrr_hil_rt_wait(&rt);
        rrr_hil_rt_done(&rt);
    }
    CHECK(rt.n == 20u && rt.n_work == 20u);
    for (uint32_t k = 0; k < rt.n; ++k) {
        CHECK(rt.lat_ns[k] >= 0); /* the spin never ends before the release */
    }
    CHECK(strstr(rt.setup, "sleep, then spin 100 us") != NULL);
    FILE *json = tmpfile();
    rrr_hil_rt_report(&rt, json, "test");
    CHECK(rt.latency_log_ok == 1 && rt.latency_log == NULL);
    rewind(json);
    char buf[2048] = {0};
    CHECK(fread(buf, 1, sizeof buf - 1, json) > 0);
    CHECK(strstr(buf, "\"rt_latency_p999_us\"") != NULL && strstr(buf, "\"rt_periods\": 20") != NULL);
    fclose(json);
    rrr_hil_rt_free(&rt);
    FILE *in = fopen(path, "r");
    int lines = 0;
    char line[128];
    while (in != NULL && fgets(line, sizeof line, in) != NULL) {
        ++lines;
    }
    CHECK(lines == 21); /* header + one row per recorded period */
    if (in != NULL) {
        fclose(in);
    }
}

/* What is refused falls back with a warning: a CPU that does not exist, and SCHED_FIFO without
 * the privilege (a child that drops it: RLIMIT_RTPRIO 0, and not root). (mlockall is not
 * checked: this VM's kernel grants it even then.) */
static void test_fallbacks(void)
{
    rrr_hil_rt_opts o;
    rrr_hil_rt_opts_default(&o);
    o.cpu = CPU_SETSIZE - 1;
    rrr_hil_rt rt;
    CHECK(rrr_hil_rt_init(&rt, 1e-3, 4u, &o, NULL, "test") == 0);
    CHECK(rt.cpu == -1 && strstr(rt.setup, "CPU 1023: ") != NULL &&
          strstr(rt.setup, "CPU 1023: yes") == NULL);
    rrr_hil_rt_free(&rt);

    const pid_t pid = fork();
    if (pid == 0) {
        const struct rlimit zero = {0, 0};
        (void)setrlimit(RLIMIT_RTPRIO, &zero);
        if (getuid() == 0 && (setgid(65534) != 0 || setuid(65534) != 0)) {
            _exit(3);
        }
        rrr_hil_rt_opts_default(&o);
        o.fifo_prio = 10;
        if (rrr_hil_rt_init(&rt, 1e-3, 4u, &o, NULL, "test") != 0) {
            _exit(4);
        }
        const int ok = rt.fifo == 0 &&
                       strstr(rt.setup, "SCHED_FIFO 10: Operation not permitted") != NULL &&
                       sched_getscheduler(0) != SCHED_FIFO;
        rrr_hil_rt_wait(&rt); /* the loop still runs, under the default scheduler */
        rrr_hil_rt_done(&rt);
        rrr_hil_rt_free(&rt);
        _exit(ok ? 0 : 5);
    }
    int status = -1;
    CHECK(pid > 0 && waitpid(pid, &status, 0) == pid);
    CHECK(WIFEXITED(status) && WEXITSTATUS(status) == 0);
}

static void test_framelog(const char *dir)
{
    uint8_t rec[RRR_HIL_FRAMELOG_RECORD];
    rrr_hil_frame f = {0x123u, 0u, 3u, {0xAA, 0xBB, 0xCC, 0, 0, 0, 0, 0}};
    rrr_hil_framelog_pack(rec, 0x0102030405060708LL, &f, RRR_HIL_FRAME_TX);
    const uint8_t want[RRR_HIL_FRAMELOG_RECORD] = {8, 7, 6, 5, 4, 3, 2, 1, 0x23, 0x01, 0, 0,
                                                   3, 1, 0, 0, 0xAA, 0xBB, 0xCC, 0, 0, 0, 0, 0};
    CHECK(memcmp(rec, want, sizeof rec) == 0);
    rrr_hil_frame e = {0x1ABCDEFu, 1u, 8u, {1, 2, 3, 4, 5, 6, 7, 8}};
    rrr_hil_framelog_pack(rec, 1, &e, RRR_HIL_FRAME_RX);
    CHECK(rec[8] == 0xEF && rec[9] == 0xCD && rec[10] == 0xAB && rec[11] == 0x81);
    CHECK(rec[12] == 8 && rec[13] == 0 && rec[23] == 8);

    char path[512];
    snprintf(path, sizeof path, "%s/frames.rrrcan", dir);
    rrr_hil_framelog l;
    char err[256];
    CHECK(rrr_hil_framelog_open(&l, path, err, sizeof err) == 0);
    for (int i = 0; i < 5; ++i) {
        rrr_hil_framelog_put(&l, &f, i & 1);
    }
    CHECK(l.frames == 5u && rrr_hil_framelog_close(&l) == 0);
    rrr_hil_framelog_put(&l, &f, 0); /* closed: ignored */
    CHECK(l.frames == 5u && rrr_hil_framelog_close(&l) == 0);
    FILE *in = fopen(path, "rb");
    uint8_t buf[256];
    const size_t got = in != NULL ? fread(buf, 1, sizeof buf, in) : 0u;
    CHECK(got == 8u + 5u * RRR_HIL_FRAMELOG_RECORD);
    CHECK(memcmp(buf, RRR_HIL_FRAMELOG_MAGIC, 8) == 0);
    if (in != NULL) {
        fclose(in);
    }
    snprintf(path, sizeof path, "%s/no/such/folder/frames.rrrcan", dir);
    CHECK(rrr_hil_framelog_open(&l, path, err, sizeof err) == -1);
    CHECK(strstr(err, "cannot write the frame log") != NULL && l.fp == NULL);
}

/* Write text to dir/name; the path in path. */
static void write_text(const char *dir, const char *name, const char *text, char *path, size_t n)
{
    snprintf(path, n, "%s/%s", dir, name);
    FILE *fp = fopen(path, "w");
    CHECK(fp != NULL);
    if (fp != NULL) {
        fputs(text, fp);
        fclose(fp);
    }
}

#define REF19                                                                                  \
    "t,q_ref[1],q_ref[2],q_ref[3],qd_ref[1],qd_ref[2],qd_ref[3],qdd_ref[1],qdd_ref[2],"          \
    "qdd_ref[3],x_ref.x,x_ref.y,x_ref.z,xd_ref.x,xd_ref.y,xd_ref.z,xdd_ref.x,xdd_ref.y,"        \
    "xdd_ref.z\n"

/* The reference table: the reference FMU's 19 columns, or any order of them (by name); a
 * missing column, a short row or a bad number is an error naming it. */
static void test_reference(const char *dir)
{
    char path[512], err[512];
    rrr_hil_reference r;
    write_text(dir, "ref19.csv",
               REF19 "0,0.1,0.2,0.3,1,2,3,10,20,30,0.4,0.5,0.6,0,0,0,0,0,0\n"
                     "0.001,0.11,0.21,0.31,1.1,2.1,3.1,11,21,31,0.4,0.5,0.6,0,0,0,0,0,0\r\n",
               path, sizeof path);
    CHECK(rrr_hil_reference_load(path, &r, err, sizeof err) == 0);
    CHECK(r.n == 2u && r.t[1] == 0.001 && r.q[0][2] == 0.3 && r.qd[1][0] == 1.1 &&
          r.qdd[1][2] == 31.0);
    rrr_hil_reference_free(&r);
    /* the columns in another order, a tip column first */
    write_text(dir, "ref_order.csv",
               "x_ref.x,qdd_ref[3],qdd_ref[2],qdd_ref[1],qd_ref[3],qd_ref[2],qd_ref[1],q_ref[3],"
               "q_ref[2],q_ref[1],t\n"
               "9,30,20,10,3,2,1,0.3,0.2,0.1,0\n9,30,20,10,3,2,1,0.3,0.2,0.1,0.001\n",
               path, sizeof path);
    CHECK(rrr_hil_reference_load(path, &r, err, sizeof err) == 0);
    CHECK(r.n == 2u && r.t[1] == 0.001 && r.q[0][0] == 0.1 && r.qd[0][2] == 3.0 &&
          r.qdd[1][1] == 20.0);
    rrr_hil_reference_free(&r);
    static const struct {
        const char *text, *message;
    } bad[] = {
        {"t,q_ref[1],q_ref[2],q_ref[3],qd_ref[1],qd_ref[2],qd_ref[3],qdd_ref[1],qdd_ref[2]\n0,0,0,"
         "0,0,0,0,0,0\n",
         "no column 'qdd_ref[3]'"},
        {REF19 "0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0\n", ":2: 18 values, the header has 19"},
        {REF19 "0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,1\n", ":2: more values than"},
        {REF19 "0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,nan\n", "column 19 (xdd_ref.z) is not a"},
        {REF19 "0,0,x,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0\n", "column 3 (q_ref[2]) is not a"},
        {"t,t,q_ref[1]\n", "the column 't' appears twice"},
        {"", "empty"},
        {REF19 "0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0\n0.5,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0\n",
         "t steps by 0.5 s"},
        {REF19 "0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0,0\n", "at least two samples"},
    };
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
        write_text(dir, "ref_bad.csv", bad[i].text, path, sizeof path);
        err[0] = '\0';
        CHECK(rrr_hil_reference_load(path, &r, err, sizeof err) == -1);
        if (strstr(err, bad[i].message) == NULL) {
            fprintf(stderr, "case %zu: '%s' does not say '%s'\n", i, err, bad[i].message);
            CHECK(0);
        }
        CHECK(r.n == 0u && r.t == NULL);
    }
}

int main(int argc, char **argv)
{
    const char *dir = argc > 1 ? argv[1] : ".";
    test_percentiles();
    test_options();
    test_loop(dir);
    test_fallbacks();
    test_framelog(dir);
    test_reference(dir);
    if (rrr_test_failures) {
        fprintf(stderr, "%d checks failed\n", rrr_test_failures);
        return 1;
    }
    printf("test_hil_rt: all checks passed\n");
    return 0;
}
