/*
 * The bench nodes as processes: how they end, and why they say they end.
 *
 * Part 1 drives the real plant node (rrr_hil_plant) with a scripted controller made of the
 * library's socketcand client and codec: the fault reset needs the whole sequence (a single
 * reset frame only arms it); unauthenticated stop requests (bad CRC, stale counter, wrong DLC,
 * the heartbeat "stopped") are ignored and counted while the run goes on; an extra client is
 * refused while the controller is connected; the authenticated StopCmd ends the run with
 * status 0, 7 when the safety policy fired during the run (a fault latched, even if reset, or
 * 0 V forced), or 6 when its reason is not the end of the run; a controller that stops talking or
 * hangs up mid-run ends it with status 3; SIGTERM with 4.
 * Part 2 runs the lockstep bench (both nodes, as tests/c/test_hil_lockstep.cmake does) and
 * stops it in the middle: SIGINT or SIGKILL to the controller, SIGTERM to the plant, a fault of
 * the controller (a voltage it cannot encode). Every ending is a documented non-zero status and
 * one line on stderr "PROG: exit N (name) at period K: reason".
 *
 * usage: test_hil_nodes PLANT CONTROLLER FMU_DIR WORK_DIR
 */
#define _POSIX_C_SOURCE 200809L

#include <arpa/inet.h>
#include <fcntl.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "hil_codec.h"
#include "hil_transport.h"
#include "rrr_test.h"

static const char *plant_exe, *ctrl_exe, *fmu_dir, *work;

/* ---- processes ------------------------------------------------------------------------------ */

typedef struct proc {
    pid_t pid;
    char out[512]; /* stdout file */
    char err[512]; /* stderr file */
} proc;

static int64_t ms_now(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000 + ts.tv_nsec / 1000000;
}

static void sleep_ms(int ms)
{
    const struct timespec d = {ms / 1000, (long)(ms % 1000) * 1000000L};
    nanosleep(&d, NULL);
}

/* Start argv[0] with stdout and stderr in WORK/NAME.out and .err. */
static int start(proc *p, const char *name, char *const argv[])
{
    snprintf(p->out, sizeof p->out, "%s/%s.out", work, name);
    snprintf(p->err, sizeof p->err, "%s/%s.err", work, name);
    (void)unlink(p->out); /* not a previous run's "listening on" line */
    (void)unlink(p->err);
    fflush(NULL);
    p->pid = fork();
    if (p->pid < 0) {
        return -1;
    }
    if (p->pid == 0) {
        const int o = open(p->out, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        const int e = open(p->err, O_WRONLY | O_CREAT | O_TRUNC, 0644);
        if (o < 0 || e < 0 || dup2(o, 1) < 0 || dup2(e, 2) < 0) {
            _exit(127);
        }
        execv(argv[0], argv);
        _exit(127);
    }
    return 0;
}

/* Exit status (128 + signal when killed), or -1 if it did not end within wait_ms (killed). */
static int finish(proc *p, int wait_ms)
{
    const int64_t end = ms_now() + wait_ms;
    int status = 0;
    while (waitpid(p->pid, &status, WNOHANG) == 0) {
        if (ms_now() > end) {
            kill(p->pid, SIGKILL);
            waitpid(p->pid, &status, 0);
            fprintf(stderr, "%s: did not end within %d ms\n", p->out, wait_ms);
            return -1;
        }
        sleep_ms(5);
    }
    return WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
}

static size_t slurp(const char *path, char *buf, size_t cap)
{
    size_t n = 0;
    const int fd = open(path, O_RDONLY);
    if (fd >= 0) {
        ssize_t got;
        while (n + 1u < cap && (got = read(fd, buf + n, cap - 1u - n)) > 0) {
            n += (size_t)got;
        }
        close(fd);
    }
    buf[n] = '\0';
    return n;
}

/* The file contains `what`; prints the file when it does not. */
static int has(const char *path, const char *what)
{
    static char buf[1 << 16];
    slurp(path, buf, sizeof buf);
    if (strstr(buf, what) != NULL) {
        return 1;
    }
    fprintf(stderr, "%s lacks '%s':\n%s\n", path, what, buf);
    return 0;
}

/* The exit line: exactly one line of stderr starts with "PROG: exit CODE (" and contains why. */
static int exit_line(const proc *p, const char *prog, int code, const char *why)
{
    static char buf[1 << 16];
    slurp(p->err, buf, sizeof buf);
    char head[96];
    snprintf(head, sizeof head, "%s: exit %d (", prog, code);
    int lines = 0, ok = 0;
    for (char *line = strtok(buf, "\n"); line != NULL; line = strtok(NULL, "\n")) {
        if (strstr(line, ": exit ") != NULL && strncmp(line, prog, strlen(prog)) == 0) {
            ++lines;
            ok = strncmp(line, head, strlen(head)) == 0 && strstr(line, why) != NULL;
        }
    }
    if (lines != 1 || !ok) {
        slurp(p->err, buf, sizeof buf);
        fprintf(stderr, "%s: expected one line '%s...%s', got:\n%s\n", p->err, head, why, buf);
    }
    return lines == 1 && ok;
}

/* The plant's port, from its "listening on 127.0.0.1:PORT" line. */
static uint16_t port_of(const proc *p)
{
    char buf[4096];
    for (int64_t end = ms_now() + 20000; ms_now() < end; sleep_ms(10)) {
        slurp(p->out, buf, sizeof buf);
        const char *at = strstr(buf, "listening on 127.0.0.1:");
        if (at != NULL && strchr(at, '\n') != NULL) {
            return (uint16_t)strtoul(at + 23, NULL, 10);
        }
    }
    return 0;
}

static int lines_of(const char *path)
{
    static char buf[1 << 20];
    const size_t n = slurp(path, buf, sizeof buf);
    int k = 0;
    for (size_t i = 0; i < n; ++i) {
        k += buf[i] == '\n';
    }
    return k;
}

/* Wait until the file has more than `lines` lines (the run is under way). */
static int wait_lines(const char *path, int lines, int wait_ms)
{
    for (int64_t end = ms_now() + wait_ms; ms_now() < end; sleep_ms(10)) {
        if (lines_of(path) > lines) {
            return 0;
        }
    }
    fprintf(stderr, "%s: not more than %d lines within %d ms\n", path, lines, wait_ms);
    return -1;
}

static int start_plant(proc *p, const char *name, const char *extra)
{
    char log[512];
    snprintf(log, sizeof log, "%s/%s.csv", work, name);
    (void)unlink(log);
    char *argv[16] = {(char *)plant_exe, "--fmu", (char *)fmu_dir, "--listen", "127.0.0.1:0",
                      "--q0", "0.25,0.75,-1.15", "--log", log, NULL};
    if (extra != NULL) {
        argv[9] = "--idle-timeout-ms";
        argv[10] = (char *)extra;
        argv[11] = NULL;
    }
    return start(p, name, argv);
}

/* ---- a scripted controller ------------------------------------------------------------------ */

typedef struct fake {
    rrr_hil_scd c;
    uint32_t k;              /* periods the plant advanced */
    uint8_t counter;         /* alive counter of the next command */
    rrr_hil_plant_status st; /* PlantStatus of period k */
} fake;

static int fake_send(fake *f, const rrr_hil_frame *fr)
{
    return rrr_hil_send(&f->c.base, fr) == RRR_HIL_IO_OK ? 0 : -1;
}

/* Read frames until the PlantStatus of period k. */
static int fake_status(fake *f, uint32_t k)
{
    for (int64_t end = ms_now() + 10000; ms_now() < end;) {
        rrr_hil_frame fr;
        rrr_hil_msg m;
        if (rrr_hil_recv(&f->c.base, &fr, 100000) == RRR_HIL_IO_OK &&
            rrr_hil_decode(&fr, &m) == RRR_HIL_RX_OK && m.kind == RRR_HIL_PLANT_STATUS &&
            m.u.status.counter == (k & 15u)) {
            f->st = m.u.status;
            return 0;
        }
    }
    fprintf(stderr, "no PlantStatus of period %u\n", k);
    return -1;
}

static int fake_start(fake *f, uint16_t port)
{
    memset(f, 0, sizeof *f);
    if (rrr_hil_scd_connect(&f->c, "127.0.0.1", port, "bench0", 5000) != 0) {
        fprintf(stderr, "fake controller: %s\n", f->c.base.last_error);
        return -1;
    }
    rrr_hil_frame fr;
    const rrr_hil_heartbeat hb = {1, RRR_HIL_NMT_OPERATIONAL, 0};
    if (rrr_hil_encode_heartbeat(&hb, &fr) != 0 || fake_send(f, &fr) != 0) {
        return -1;
    }
    return fake_status(f, 0);
}

static int fake_cmd(fake *f, uint8_t enable, uint8_t reset)
{
    const rrr_hil_voltage_cmd c = {(uint8_t)(f->counter++ & 15u), enable, reset, {0.5, -0.5, 0.25}};
    rrr_hil_frame fr;
    return rrr_hil_encode_voltage_cmd(&c, &fr) == 0 ? fake_send(f, &fr) : -1;
}

/* Sync(k): the plant advances one period; its new status. */
static int fake_sync(fake *f)
{
    const rrr_hil_sync s = {f->k};
    rrr_hil_frame fr;
    if (rrr_hil_encode_sync(&s, &fr) != 0 || fake_send(f, &fr) != 0) {
        return -1;
    }
    ++f->k;
    return fake_status(f, f->k);
}

/* One normal period; 0 when the plant answered with no fault. */
static int fake_period(fake *f)
{
    return fake_cmd(f, 1, 0) == 0 && fake_sync(f) == 0 && f->st.faults == 0u ? 0 : -1;
}

static int fake_stop(fake *f, uint8_t counter, uint8_t reason)
{
    const rrr_hil_stop_cmd s = {(uint8_t)(counter & 15u), reason};
    rrr_hil_frame fr;
    return rrr_hil_encode_stop_cmd(&s, &fr) == 0 ? fake_send(f, &fr) : -1;
}

static int raw_connect(uint16_t port)
{
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in a;
    memset(&a, 0, sizeof a);
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    inet_pton(AF_INET, "127.0.0.1", &a.sin_addr);
    if (fd < 0 || connect(fd, (struct sockaddr *)&a, sizeof a) != 0) {
        if (fd >= 0) {
            close(fd);
        }
        return -1;
    }
    return fd;
}

/* What the server sent until it closed the connection. */
static void read_to_eof(int fd, char *buf, size_t cap)
{
    size_t n = 0;
    for (int64_t end = ms_now() + 5000; ms_now() < end && n + 1u < cap;) {
        struct pollfd pfd = {.fd = fd, .events = POLLIN};
        if (poll(&pfd, 1, 100) <= 0) {
            continue;
        }
        const ssize_t got = read(fd, buf + n, cap - 1u - n);
        if (got <= 0) {
            break;
        }
        n += (size_t)got;
    }
    buf[n] = '\0';
}

/* ---- part 1: the plant node and a scripted controller ---------------------------------------- */

static void test_reset_stop_extra_client(void)
{
    proc plant;
    CHECK(start_plant(&plant, "plant_stop", NULL) == 0);
    const uint16_t port = port_of(&plant);
    fake f;
    CHECK(port != 0 && fake_start(&f, port) == 0);
    for (int i = 0; i < 5; ++i) {
        CHECK(fake_period(&f) == 0 && f.st.state == RRR_HIL_PLANT_RUNNING);
    }
    /* a latched fault: a corrupted command */
    const rrr_hil_voltage_cmd c = {(uint8_t)(f.counter++ & 15u), 1, 0, {0.5, 0.5, 0.5}};
    rrr_hil_frame fr;
    CHECK(rrr_hil_encode_voltage_cmd(&c, &fr) == 0);
    fr.data[3] ^= 0x01;
    CHECK(fake_send(&f, &fr) == 0 && fake_sync(&f) == 0);
    CHECK(f.st.faults == RRR_HIL_FAULT_CRC && f.st.state == RRR_HIL_PLANT_FAULT && f.st.zero_voltage);
    /* the single reset frame only arms the reset */
    CHECK(fake_cmd(&f, 0, 1) == 0 && fake_sync(&f) == 0);
    CHECK(f.st.faults == RRR_HIL_FAULT_CRC && f.st.state == RRR_HIL_PLANT_RESET && f.st.zero_voltage);
    /* the fresh enable: the latch clears with the 3rd consecutive enabling command */
    for (int i = 0; i < 2; ++i) {
        CHECK(fake_cmd(&f, 1, 0) == 0 && fake_sync(&f) == 0);
        CHECK(f.st.faults == RRR_HIL_FAULT_CRC && f.st.zero_voltage);
    }
    CHECK(fake_cmd(&f, 1, 0) == 0 && fake_sync(&f) == 0);
    CHECK(f.st.faults == 0 && f.st.state == RRR_HIL_PLANT_RUNNING && f.st.zero_voltage == 0);

    /* unauthenticated stop requests: ignored (counted), the run goes on */
    const uint8_t last = (uint8_t)((f.counter - 1u) & 15u);
    const rrr_hil_stop_cmd good = {(uint8_t)((last + 1u) & 15u), RRR_HIL_STOP_END_OF_RUN};
    CHECK(rrr_hil_encode_stop_cmd(&good, &fr) == 0);
    fr.data[0] ^= 0x40; /* bad CRC */
    CHECK(fake_send(&f, &fr) == 0);
    CHECK(fake_stop(&f, last, RRR_HIL_STOP_END_OF_RUN) == 0); /* stale counter */
    CHECK(rrr_hil_encode_stop_cmd(&good, &fr) == 0);
    fr.dlc = 3; /* wrong DLC */
    CHECK(fake_send(&f, &fr) == 0);
    const rrr_hil_heartbeat hb = {1, RRR_HIL_NMT_STOPPED, 1}; /* no E2E at all */
    CHECK(rrr_hil_encode_heartbeat(&hb, &fr) == 0 && fake_send(&f, &fr) == 0);
    CHECK(fake_period(&f) == 0);
    /* an extra client while the controller is connected: refused, the run goes on */
    const int x = raw_connect(port);
    char buf[256];
    CHECK(x >= 0);
    read_to_eof(x, buf, sizeof buf);
    CHECK(strcmp(buf, "< error session in use: one client at a time >") == 0);
    close(x);
    CHECK(fake_period(&f) == 0 && fake_period(&f) == 0);
    /* the authenticated stop: the next counter of the command sequence */
    CHECK(fake_stop(&f, f.counter, RRR_HIL_STOP_END_OF_RUN) == 0);
    /* the run completed, but a fault latched (and 0 V was forced) on the way: status 7 */
    CHECK(finish(&plant, 20000) == 7);
    CHECK(exit_line(&plant, "rrr_hil_plant", 7, "the controller's StopCmd: end of run; the "
                    "safety policy fired: 1 fault events, faults latched 0x00, 4 periods at 0 V"));
    CHECK(has(plant.out, "\"exit\": 7,"));
    CHECK(has(plant.out, "\"stop_rejected\": 3,") && has(plant.out, "\"refused\": 1,"));
    CHECK(has(plant.out, "\"resets\": 1,") && has(plant.out, "\"stop_reason\": 0,"));
    CHECK(has(plant.out, "\"crc\": 1,") && has(plant.out, "\"bus\": 0,"));
    rrr_hil_close(&f.c.base);
}

/* how: 0 stops talking, 1 hangs up, 2 StopCmd "interrupted", 3 SIGTERM to the plant */
static void test_plant_ends(int how)
{
    static const char *const names[] = {"plant_silent", "plant_hangup", "plant_aborted",
                                        "plant_sigterm"};
    proc plant;
    CHECK(start_plant(&plant, names[how], how == 0 ? "300" : NULL) == 0);
    fake f;
    CHECK(fake_start(&f, port_of(&plant)) == 0);
    for (int i = 0; i < 4; ++i) {
        CHECK(fake_period(&f) == 0);
    }
    const int64_t t0 = ms_now();
    if (how == 1) {
        rrr_hil_close(&f.c.base);
    } else if (how == 2) {
        CHECK(fake_stop(&f, f.counter, RRR_HIL_STOP_INTERRUPTED) == 0);
    } else if (how == 3) {
        kill(plant.pid, SIGTERM);
    }
    const int rc = finish(&plant, 20000);
    if (how == 0) {
        CHECK(rc == 3 && ms_now() - t0 >= 250);
        CHECK(exit_line(&plant, "rrr_hil_plant", 3, "controller lost: "));
        CHECK(has(plant.err, "idle timeout") && has(plant.out, "\"bus\": 1,"));
        CHECK(has(plant.out, "\"idle_timeouts\": 1"));
    } else if (how == 1) {
        CHECK(rc == 3);
        CHECK(exit_line(&plant, "rrr_hil_plant", 3,
                        "controller lost: transport disconnected: socketcand: the client closed"));
    } else if (how == 2) {
        CHECK(rc == 6);
        CHECK(exit_line(&plant, "rrr_hil_plant", 6, "the controller's StopCmd: interrupted"));
    } else {
        CHECK(rc == 4);
        CHECK(exit_line(&plant, "rrr_hil_plant", 4, "at period 4: SIGTERM"));
        rrr_hil_frame fr;
        CHECK(rrr_hil_recv(&f.c.base, &fr, 5000000) == RRR_HIL_IO_DISCONNECTED);
    }
    rrr_hil_close(&f.c.base);
}

/* ---- part 2: the lockstep bench, stopped in the middle --------------------------------------- */

/* A reference of n periods holding q, jumping to q_far from period `jump` on (n: no jump). */
static void write_reference(const char *path, int n, int jump)
{
    FILE *fp = fopen(path, "w");
    CHECK(fp != NULL);
    if (fp == NULL) {
        return;
    }
    /* the reference FMU's table (19 columns; the controller reads the first 10 by name) */
    fprintf(fp, "t,q_ref[1],q_ref[2],q_ref[3],qd_ref[1],qd_ref[2],qd_ref[3],qdd_ref[1],"
                "qdd_ref[2],qdd_ref[3],x_ref.x,x_ref.y,x_ref.z,xd_ref.x,xd_ref.y,xd_ref.z,"
                "xdd_ref.x,xdd_ref.y,xdd_ref.z\n");
    for (int k = 0; k < n; ++k) {
        fprintf(fp, "%.17g,%s,0,0,0,0,0,0,0.4,0,0.3,0,0,0,0,0,0\n", k * 1e-3,
                k < jump ? "0.2,0.8,-1.2" : "2.5,2.5,2.5");
    }
    fclose(fp);
}

/* how: 0 SIGINT to the controller, 1 SIGKILL to the controller, 2 SIGTERM to the plant,
 * 3 the controller's fault (u_max 40 V: a voltage VoltageCmd cannot carry) */
static void test_bench_stopped(int how)
{
    static const char *const names[] = {"bench_sigint", "bench_sigkill", "bench_sigterm",
                                        "bench_fault"};
    char ref[512], pname[64], cname[64], ctrl_log[512];
    snprintf(ref, sizeof ref, "%s/%s.ref.csv", work, names[how]);
    snprintf(pname, sizeof pname, "%s_plant", names[how]);
    snprintf(cname, sizeof cname, "%s_ctrl", names[how]);
    snprintf(ctrl_log, sizeof ctrl_log, "%s/%s.csv", work, cname);
    write_reference(ref, 30000, how == 3 ? 50 : 30000);
    (void)unlink(ctrl_log); /* wait_lines must see this run's log */
    proc plant, ctrl;
    CHECK(start_plant(&plant, pname, NULL) == 0);
    char conn[64];
    snprintf(conn, sizeof conn, "127.0.0.1:%u", (unsigned)port_of(&plant));
    char *argv[] = {(char *)ctrl_exe, "--reference", ref, "--connect", conn, "--log", ctrl_log,
                    how == 3 ? "--set" : NULL, "u_max=40", NULL};
    CHECK(start(&ctrl, cname, argv) == 0);
    if (how != 3) {
        CHECK(wait_lines(ctrl_log, 100, 30000) == 0); /* mid-run */
        kill(how == 2 ? plant.pid : ctrl.pid, how == 0 ? SIGINT : how == 1 ? SIGKILL : SIGTERM);
    }
    const int rc_ctrl = finish(&ctrl, 30000);
    const int rc_plant = finish(&plant, 30000);
    if (how == 0) {
        CHECK(rc_ctrl == 4 && rc_plant == 6);
        CHECK(exit_line(&ctrl, "rrr_hil_controller", 4, ": SIGINT"));
        CHECK(exit_line(&plant, "rrr_hil_plant", 6, "the controller's StopCmd: interrupted"));
    } else if (how == 1) {
        CHECK(rc_ctrl == 128 + SIGKILL && rc_plant == 3);
        CHECK(exit_line(&plant, "rrr_hil_plant", 3, "controller lost: transport disconnected"));
        CHECK(has(plant.out, "\"bus\": 1,"));
    } else if (how == 2) {
        CHECK(rc_plant == 4 && rc_ctrl == 3);
        CHECK(exit_line(&plant, "rrr_hil_plant", 4, ": SIGTERM"));
        CHECK(exit_line(&ctrl, "rrr_hil_controller", 3, "plant lost: "));
    } else {
        CHECK(rc_ctrl == 5 && rc_plant == 6);
        CHECK(exit_line(&ctrl, "rrr_hil_controller", 5, "at period 50: VoltageCmd cannot be encoded"));
        CHECK(exit_line(&plant, "rrr_hil_plant", 6, "the controller's StopCmd: fault"));
        CHECK(has(plant.out, "\"periods\": 50,")); /* Sync 0..49, then u_50 is 40 V */
    }
}

int main(int argc, char **argv)
{
    if (argc != 5) {
        fprintf(stderr, "usage: test_hil_nodes PLANT CONTROLLER FMU_DIR WORK_DIR\n");
        return 2;
    }
    plant_exe = argv[1];
    ctrl_exe = argv[2];
    fmu_dir = argv[3];
    work = argv[4];
    (void)mkdir(work, 0755);
    signal(SIGPIPE, SIG_IGN);
    test_reset_stop_extra_client();
    for (int how = 0; how < 4; ++how) {
        test_plant_ends(how);
    }
    for (int how = 0; how < 4; ++how) {
        test_bench_stopped(how);
    }
    return rrr_test_report("test_hil_nodes");
}
