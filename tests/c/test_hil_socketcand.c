/* The socketcand transport: the message parser on good and bad input, then a server and
 * clients (forked) exchanging frames through the real TCP code: handshake, the rule that the
 * server sends nothing before the client's first frame, malformed input counted, disconnects;
 * the server's one session: a silent client (handshake timeout, never blocks the real one), a
 * client that stops talking or reading mid-session (idle timeout), extra clients refused with
 * the protocol's error while the controller's session goes on, and nobody after it. */
#define _POSIX_C_SOURCE 200809L

#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <signal.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <time.h>
#include <unistd.h>

#include "hil_transport.h"
#include "rrr_test.h"

static int parse(const char *s, rrr_hil_frame *f, char word[16])
{
    return rrr_hil_scd_parse(s, (unsigned)strlen(s), f, word);
}

static void test_parser(void)
{
    rrr_hil_frame f;
    char w[16];
    CHECK(parse("< send 100 8 39 30 80 f3 0 0 0 0 >", &f, w) == 1);
    CHECK(strcmp(w, "send") == 0 && f.id == 0x100 && f.dlc == 8 && !f.extended);
    CHECK(f.data[0] == 0x39 && f.data[3] == 0xf3 && f.data[7] == 0);
    CHECK(parse("< frame 201 1795299831.423300 87130000000000AB >", &f, w) == 1);
    CHECK(f.id == 0x201 && f.dlc == 8 && f.data[0] == 0x87 && f.data[7] == 0xAB);
    CHECK(parse("< send 12345678 2 1 2 >", &f, w) == 1 && f.extended && f.id == 0x12345678u);
    CHECK(parse("< frame 080 1.5  >", &f, w) == 1 && f.dlc == 0);
    CHECK(parse("< send 080 0 >", &f, w) == 1 && f.dlc == 0);
    CHECK(parse("< ok >", &f, w) == 0 && strcmp(w, "ok") == 0);
    CHECK(parse("< open bench0 >", &f, w) == 0 && strcmp(w, "open") == 0);
    const char *bad[] = {
        "", "<>", "< >", "<send 100 1 1 >", "< send 100 1 1>", "< send 800 1 1 >",
        "< send 100 9 1 2 3 4 5 6 7 8 9 >", "< send 100 2 1 >", "< send 100 1 1 2 >",
        "< send 100 1 123 >", "< send 100 1 zz >", "< send 123456789 1 1 >", "< send >",
        "< send 100 >", "< frame 100 1.2 ABC >", "< frame 100 x.2 AB >", "< frame 100 1.2.3 AB >",
        "< frame 100 1 0102030405060708090A >", "< frame 100 1 AB CD >", "< frame 100 >",
        "< averyveryverylongword >", "< send 3FFFFFFF 1 1 >"};
    for (size_t i = 0; i < sizeof bad / sizeof bad[0]; ++i) {
        memset(&f, 0x5A, sizeof f);
        const int r = parse(bad[i], &f, w);
        if (r != -1) {
            fprintf(stderr, "accepted: '%s'\n", bad[i]);
        }
        CHECK(r == -1);
        CHECK(f.id == 0x5A5A5A5Au); /* untouched */
    }
}

/* ---- helpers for the forked clients -------------------------------------------------------- */

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

/* A raw TCP connection to the server (rcvbuf > 0: a small receive buffer), -1 on failure. */
static int raw_connect(uint16_t port, int rcvbuf)
{
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    if (fd < 0) {
        return -1;
    }
    if (rcvbuf > 0) {
        (void)setsockopt(fd, SOL_SOCKET, SO_RCVBUF, &rcvbuf, sizeof rcvbuf);
    }
    struct sockaddr_in a;
    memset(&a, 0, sizeof a);
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    inet_pton(AF_INET, "127.0.0.1", &a.sin_addr);
    if (connect(fd, (struct sockaddr *)&a, sizeof a) != 0) {
        close(fd);
        return -1;
    }
    return fd;
}

/* Everything the server sends until it closes the connection (or wait_ms pass): its length,
 * -1 if the connection was still open after wait_ms. */
static int read_until_eof(int fd, char *buf, size_t cap, int wait_ms)
{
    size_t n = 0;
    const int64_t end = ms_now() + wait_ms;
    for (;;) {
        const int64_t left = end - ms_now();
        struct pollfd pfd = {.fd = fd, .events = POLLIN};
        if (left <= 0 || poll(&pfd, 1, (int)left) <= 0) {
            buf[n] = '\0';
            return -1;
        }
        const ssize_t got = read(fd, buf + n, cap - 1u - n);
        if (got <= 0) {
            buf[n] = '\0';
            return (int)n;
        }
        n += (size_t)got;
    }
}

static int send_text(int fd, const char *s)
{
    return write(fd, s, strlen(s)) == (ssize_t)strlen(s) ? 0 : -1;
}

/* One ping-pong of the library client: frame 0x100 with data[0] = i, reply 0x201 expected. */
static int ping(rrr_hil_scd *c, uint32_t i)
{
    rrr_hil_frame f = {0x100, 0, 8, {(uint8_t)i, 1, 2, 3, 4, 5, 6, 7}};
    rrr_hil_frame g;
    if (rrr_hil_send(&c->base, &f) != RRR_HIL_IO_OK ||
        rrr_hil_recv(&c->base, &g, 3000000) != RRR_HIL_IO_OK || g.id != 0x201 || g.dlc != 8 ||
        g.data[0] != (uint8_t)i || g.data[7] != 0xEE) {
        return -1;
    }
    return 0;
}

/* The server's side of a ping-pong: 0, or -1. */
static int pong(rrr_hil_scd *s, uint32_t i)
{
    rrr_hil_frame g;
    if (rrr_hil_recv(&s->base, &g, 3000000) != RRR_HIL_IO_OK || g.id != 0x100 ||
        g.data[0] != (uint8_t)i) {
        return -1;
    }
    rrr_hil_frame r = {0x201, 0, 8, {g.data[0], 0, 0, 0, 0, 0, 0, 0xEE}};
    return rrr_hil_send(&s->base, &r) == RRR_HIL_IO_OK ? 0 : -1;
}

static pid_t spawn(int (*fn)(uint16_t), uint16_t port, rrr_hil_scd *server)
{
    fflush(NULL);
    const pid_t pid = fork();
    if (pid == 0) {
        rrr_hil_close(&server->base);
        _exit(fn(port));
    }
    return pid;
}

static void reap(pid_t pid, const char *what)
{
    int status = -1;
    waitpid(pid, &status, 0);
    const int ok = WIFEXITED(status) && WEXITSTATUS(status) == 0;
    if (!ok) {
        fprintf(stderr, "%s: child exit status %d\n", what, WIFEXITED(status) ? WEXITSTATUS(status) : -1);
    }
    CHECK(ok);
}

/* The server's `recv` until a frame arrives or wait_ms pass (the handshakes run meanwhile). */
static rrr_hil_io recv_within(rrr_hil_scd *s, rrr_hil_frame *g, int wait_ms)
{
    const int64_t end = ms_now() + wait_ms;
    rrr_hil_io io;
    while ((io = rrr_hil_recv(&s->base, g, 100000)) == RRR_HIL_IO_TIMEOUT && ms_now() < end) {
    }
    return io;
}

/* ---- a misbehaving raw client, then the library client (each a server of its own) ---------- */

static int child_basic(uint16_t port)
{
    /* 1: a raw socket: handshake by hand, garbage, one frame, then a hang-up */
    int fd = raw_connect(port, 0);
    if (fd < 0) {
        return 10;
    }
    char buf[256];
    ssize_t n = read(fd, buf, sizeof buf);
    if (n != 6 || memcmp(buf, "< hi >", 6) != 0) {
        return 11;
    }
    if (send_text(fd, "< open bench0 >") != 0 || read(fd, buf, sizeof buf) != 6) {
        return 12;
    }
    if (send_text(fd, "< rawmode >") != 0 || read(fd, buf, sizeof buf) != 6) {
        return 13;
    }
    if (send_text(fd, "junk< send 100 9 1 >< send 1 1 zz >< send 701 2 5 0 >") != 0) {
        return 14;
    }
    /* wait for the server's reply frame, then hang up */
    n = read(fd, buf, sizeof buf);
    if (n <= 0 || strncmp(buf, "< frame 702 ", 12) != 0) {
        return 15;
    }
    close(fd);

    /* 2: the same server refuses everybody now: its one session is over */
    rrr_hil_scd c;
    if (rrr_hil_scd_connect(&c, "127.0.0.1", port, "bench0", 3000) == 0 ||
        strstr(c.base.last_error, "< error session over >") == NULL) {
        fprintf(stderr, "child: %s\n", c.base.last_error);
        return 16;
    }

    /* 3: the library client on a second server (port + 1 is not known: read it from stdin) */
    uint16_t port2 = 0;
    if (read(0, &port2, sizeof port2) != (ssize_t)sizeof port2) {
        return 19;
    }
    if (rrr_hil_scd_connect(&c, "127.0.0.1", port2, "bench0", 3000) != 0) {
        fprintf(stderr, "child: %s\n", c.base.last_error);
        return 20;
    }
    for (uint32_t i = 0; i < 100; ++i) {
        if (ping(&c, i) != 0) {
            return 22;
        }
    }
    rrr_hil_close(&c.base);
    rrr_hil_close(&c.base); /* idempotent */
    return 0;
}

static void test_server_client(void)
{
    rrr_hil_scd s, s2;
    CHECK(rrr_hil_scd_listen(&s, "not-an-ip", 0, "bench0") == -1);
    CHECK(strstr(s.base.last_error, "not an IPv4 address") != NULL);
    CHECK(rrr_hil_scd_listen(&s, "127.0.0.1", 0, "bad name") == -1);
    CHECK(rrr_hil_scd_listen(&s, "127.0.0.1", 0, "bench0") == 0);
    CHECK(rrr_hil_scd_listen(&s2, "127.0.0.1", 0, "bench0") == 0);
    CHECK(s.port != 0 && s2.port != 0);
    CHECK(s.handshake_timeout_ms == RRR_HIL_SCD_HANDSHAKE_TIMEOUT_MS);
    CHECK(s.idle_timeout_ms == RRR_HIL_SCD_IDLE_TIMEOUT_MS);
    CHECK(rrr_hil_scd_set_timeouts(&s, 0, 100) == -1 && s.handshake_timeout_ms == 2000);
    CHECK(rrr_hil_scd_set_timeouts(&s, 100, RRR_HIL_SCD_TIMEOUT_MAX_MS + 1) == -1);
    int to_child[2];
    CHECK(pipe(to_child) == 0);
    fflush(NULL);
    const pid_t pid = fork();
    if (pid == 0) {
        rrr_hil_close(&s.base);
        rrr_hil_close(&s2.base);
        dup2(to_child[0], 0);
        close(to_child[1]);
        _exit(child_basic(s.port));
    }
    close(to_child[0]);
    /* session 1: garbage counted; the frame before the client's first one is dropped */
    rrr_hil_frame f = {0x702, 0, 2, {5, 0}};
    CHECK(rrr_hil_send(&s.base, &f) == RRR_HIL_IO_DISCONNECTED); /* no client yet */
    rrr_hil_frame g;
    CHECK(recv_within(&s, &g, 3000) == RRR_HIL_IO_OK);
    CHECK(g.id == 0x701 && g.dlc == 2 && g.data[0] == 5);
    CHECK(s.base.err.rx_malformed >= 3); /* "junk" (4 chars), dlc 9, "zz" */
    CHECK(rrr_hil_send(&s.base, &f) == RRR_HIL_IO_OK);
    CHECK(rrr_hil_recv(&s.base, &g, 3000000) == RRR_HIL_IO_DISCONNECTED);
    CHECK(s.base.err.disconnects == 1 && s.session == RRR_HIL_SCD_SESSION_OVER);
    /* over: recv says so at once, and the next client gets the protocol's error */
    const int64_t t0 = ms_now();
    while (s.base.err.refused == 0 && ms_now() - t0 < 3000) {
        CHECK(rrr_hil_recv(&s.base, &g, 3000000) == RRR_HIL_IO_DISCONNECTED);
        sleep_ms(5);
    }
    CHECK(s.base.err.refused == 1 && s.base.err.connects == 1);
    CHECK(rrr_hil_send(&s.base, &f) == RRR_HIL_IO_DISCONNECTED);
    /* session 2 on the second server: the library client, 100 ping-pongs */
    CHECK(write(to_child[1], &s2.port, sizeof s2.port) == (ssize_t)sizeof s2.port);
    for (uint32_t i = 0; i < 100; ++i) {
        if (pong(&s2, i) != 0) {
            CHECK(0);
            break;
        }
    }
    CHECK(rrr_hil_recv(&s2.base, &g, 3000000) == RRR_HIL_IO_DISCONNECTED);
    CHECK(rrr_hil_recv(&s2.base, &g, 0) == RRR_HIL_IO_DISCONNECTED);
    CHECK(s2.base.err.connects == 1 && s2.base.err.disconnects == 1 && s2.base.err.refused == 0);
    reap(pid, "test_server_client");
    close(to_child[1]);
    rrr_hil_close(&s.base);
    rrr_hil_close(&s2.base);
    CHECK(rrr_hil_send(&s.base, &f) == RRR_HIL_IO_ERROR);
    /* a client with nobody listening: a clear error after the retry time */
    rrr_hil_scd c;
    CHECK(rrr_hil_scd_connect(&c, "127.0.0.1", s.port, "bench0", 100) == -1);
    CHECK(strstr(c.base.last_error, "connect(127.0.0.1:") != NULL);
}

/* ---- a silent client never blocks the bench ------------------------------------------------- */

#define SILENT_HANDSHAKE_MS 300

static int child_silent(uint16_t port)
{
    char buf[512];
    /* 1: connects and says nothing: "< hi >", then the handshake timeout closes it */
    int64_t t0 = ms_now();
    int fd = raw_connect(port, 0);
    int n = fd < 0 ? -1 : read_until_eof(fd, buf, sizeof buf, 3000);
    const int64_t took = ms_now() - t0;
    if (n < 0 || strcmp(buf, "< hi >< error handshake timeout >") != 0 ||
        took < SILENT_HANDSHAKE_MS - 50) { /* not before its timeout (later on a busy machine) */
        fprintf(stderr, "child_silent 1: '%s' after %lld ms\n", buf, (long long)took);
        return 30;
    }
    close(fd);
    /* 2: opens the bus, then stops before rawmode: the same */
    fd = raw_connect(port, 0);
    if (fd < 0 || read(fd, buf, 6) != 6 || send_text(fd, "< open bench0 >") != 0) {
        return 31;
    }
    n = read_until_eof(fd, buf, sizeof buf, 3000);
    if (n < 0 || strcmp(buf, "< ok >< error handshake timeout >") != 0) {
        fprintf(stderr, "child_silent 2: '%s'\n", buf);
        return 32;
    }
    close(fd);
    /* 3: five silent connections at once (one more than the handshake slots), then the real
     * client: it gets the session without waiting for their handshake timeout (the parent
     * counts two handshake timeouts, those of 1 and 2); the silent ones are refused */
    int quiet[RRR_HIL_SCD_MAX_PENDING + 1];
    for (unsigned i = 0; i <= RRR_HIL_SCD_MAX_PENDING; ++i) {
        quiet[i] = raw_connect(port, 0);
        if (quiet[i] < 0) {
            return 33;
        }
    }
    rrr_hil_scd c;
    if (rrr_hil_scd_connect(&c, "127.0.0.1", port, "bench0", 3000) != 0) {
        fprintf(stderr, "child_silent 3: %s\n", c.base.last_error);
        return 34;
    }
    if (ping(&c, 7) != 0) {
        return 35;
    }
    for (unsigned i = 0; i <= RRR_HIL_SCD_MAX_PENDING; ++i) {
        n = read_until_eof(quiet[i], buf, sizeof buf, 3000);
        if (n < 0 || strncmp(buf, "< hi >< error ", 14) != 0) {
            fprintf(stderr, "child_silent 3, quiet %u: '%s'\n", i, buf);
            return 36;
        }
        close(quiet[i]);
    }
    rrr_hil_close(&c.base);
    return 0;
}

static void test_silent_client(void)
{
    rrr_hil_scd s;
    CHECK(rrr_hil_scd_listen(&s, "127.0.0.1", 0, "bench0") == 0);
    CHECK(rrr_hil_scd_set_timeouts(&s, SILENT_HANDSHAKE_MS, 5000) == 0);
    const pid_t pid = spawn(child_silent, s.port, &s);
    rrr_hil_frame g;
    CHECK(recv_within(&s, &g, 10000) == RRR_HIL_IO_OK && g.id == 0x100 && g.data[0] == 7);
    CHECK(s.base.err.handshake_timeouts == 2 && s.base.err.connects == 1);
    /* the 5th silent connection evicted the 1st; the session refused the other 4 */
    CHECK(s.base.err.refused == RRR_HIL_SCD_MAX_PENDING + 1u);
    rrr_hil_frame r = {0x201, 0, 8, {7, 0, 0, 0, 0, 0, 0, 0xEE}};
    CHECK(rrr_hil_send(&s.base, &r) == RRR_HIL_IO_OK);
    CHECK(rrr_hil_recv(&s.base, &g, 5000000) == RRR_HIL_IO_DISCONNECTED);
    reap(pid, "test_silent_client");
    rrr_hil_close(&s.base);
}

/* ---- a client that stops in the middle of its session --------------------------------------- */

#define IDLE_MS 300

static int child_stops_talking(uint16_t port)
{
    rrr_hil_scd c;
    if (rrr_hil_scd_connect(&c, "127.0.0.1", port, "bench0", 3000) != 0) {
        return 40;
    }
    for (uint32_t i = 0; i < 5; ++i) {
        if (ping(&c, i) != 0) {
            return 41;
        }
    }
    /* silence: the server ends the session after its idle timeout and says why */
    const int64_t t0 = ms_now();
    rrr_hil_frame g;
    const rrr_hil_io io = rrr_hil_recv(&c.base, &g, 5000000);
    const int64_t took = ms_now() - t0;
    if (io != RRR_HIL_IO_DISCONNECTED || strstr(c.base.last_error, "idle timeout") == NULL ||
        took < IDLE_MS - 50) { /* not before the timeout (later on a busy machine) */
        fprintf(stderr, "child_stops_talking: %s after %lld ms: %s\n", rrr_hil_io_str(io),
                (long long)took, c.base.last_error);
        return 42;
    }
    rrr_hil_close(&c.base);
    /* nobody takes its place */
    if (rrr_hil_scd_connect(&c, "127.0.0.1", port, "bench0", 3000) == 0 ||
        strstr(c.base.last_error, "< error session over >") == NULL) {
        return 43;
    }
    return 0;
}

/* Connects, handshakes, sends one frame, then reads nothing ever again. */
static int child_stops_reading(uint16_t port)
{
    const int fd = raw_connect(port, 2048);
    char buf[64];
    if (fd < 0 || read(fd, buf, 6) != 6 || send_text(fd, "< open bench0 >") != 0 ||
        read(fd, buf, 6) != 6 || send_text(fd, "< rawmode >") != 0 || read(fd, buf, 6) != 6 ||
        send_text(fd, "< send 701 2 5 0 >") != 0) {
        return 50;
    }
    sleep_ms(20000); /* killed by the parent when it is done */
    return 51;
}

static void test_client_stops_mid_session(void)
{
    /* it stops talking */
    rrr_hil_scd s;
    CHECK(rrr_hil_scd_listen(&s, "127.0.0.1", 0, "bench0") == 0);
    CHECK(rrr_hil_scd_set_timeouts(&s, 2000, IDLE_MS) == 0);
    pid_t pid = spawn(child_stops_talking, s.port, &s);
    rrr_hil_frame g;
    CHECK(recv_within(&s, &g, 5000) == RRR_HIL_IO_OK && g.data[0] == 0);
    rrr_hil_frame r = {0x201, 0, 8, {0, 0, 0, 0, 0, 0, 0, 0xEE}};
    CHECK(rrr_hil_send(&s.base, &r) == RRR_HIL_IO_OK);
    for (uint32_t i = 1; i < 5; ++i) {
        CHECK(pong(&s, i) == 0);
    }
    int64_t t0 = ms_now();
    CHECK(rrr_hil_recv(&s.base, &g, 10000000) == RRR_HIL_IO_DISCONNECTED);
    const int64_t took = ms_now() - t0;
    CHECK(took >= IDLE_MS - 50); /* not before the idle timeout; later on a busy machine */
    CHECK(s.base.err.idle_timeouts == 1 && s.base.err.disconnects == 1);
    CHECK(strstr(s.base.last_error, "idle timeout") != NULL);
    t0 = ms_now();
    while (s.base.err.refused == 0 && ms_now() - t0 < 3000) {
        CHECK(rrr_hil_recv(&s.base, &g, 100000) == RRR_HIL_IO_DISCONNECTED);
        sleep_ms(5);
    }
    CHECK(s.base.err.refused == 1);
    reap(pid, "test_client_stops_mid_session (talking)");
    rrr_hil_close(&s.base);

    /* it stops reading: the server's sends give up after the idle timeout instead of blocking */
    CHECK(rrr_hil_scd_listen(&s, "127.0.0.1", 0, "bench0") == 0);
    CHECK(rrr_hil_scd_set_timeouts(&s, 2000, IDLE_MS) == 0);
    pid = spawn(child_stops_reading, s.port, &s);
    CHECK(recv_within(&s, &g, 5000) == RRR_HIL_IO_OK && g.id == 0x701);
    rrr_hil_io io = RRR_HIL_IO_OK;
    uint32_t sent = 0;
    t0 = ms_now();
    while (io == RRR_HIL_IO_OK && ms_now() - t0 < 30000) {
        io = rrr_hil_send(&s.base, &r);
        sent += io == RRR_HIL_IO_OK;
    }
    CHECK(io == RRR_HIL_IO_DISCONNECTED && sent > 10u);
    CHECK(strstr(s.base.last_error, "read nothing for 300 ms") != NULL);
    CHECK(s.base.err.tx_failed == 1 && rrr_hil_send(&s.base, &r) == RRR_HIL_IO_DISCONNECTED);
    CHECK(rrr_hil_recv(&s.base, &g, 0) == RRR_HIL_IO_DISCONNECTED); /* nothing more queued */
    CHECK(s.session == RRR_HIL_SCD_SESSION_OVER && s.base.err.tx_failed == 1);
    kill(pid, SIGKILL);
    int status;
    waitpid(pid, &status, 0);
    rrr_hil_close(&s.base);
}

/* ---- an extra client while the controller is connected -------------------------------------- */

static int child_extra(uint16_t port)
{
    rrr_hil_scd c;
    if (rrr_hil_scd_connect(&c, "127.0.0.1", port, "bench0", 3000) != 0) {
        return 60;
    }
    for (uint32_t i = 0; i < 10; ++i) {
        if (ping(&c, i) != 0) {
            return 61;
        }
    }
    /* six intruders, raw and library ones: each gets the protocol's error and is closed */
    char buf[256];
    for (int i = 0; i < 6; ++i) {
        if (i % 2 == 0) {
            const int fd = raw_connect(port, 0);
            if (fd < 0 || read_until_eof(fd, buf, sizeof buf, 3000) < 0 ||
                strcmp(buf, "< error session in use: one client at a time >") != 0) {
                fprintf(stderr, "child_extra: '%s'\n", buf);
                return 62;
            }
            close(fd);
        } else {
            rrr_hil_scd x;
            if (rrr_hil_scd_connect(&x, "127.0.0.1", port, "bench0", 3000) == 0 ||
                strstr(x.base.last_error, "session in use") == NULL) {
                return 63;
            }
        }
        if (ping(&c, 10u + (uint32_t)i) != 0) { /* the controller's session goes on */
            return 64;
        }
    }
    for (uint32_t i = 16; i < 20; ++i) {
        if (ping(&c, i) != 0) {
            return 65;
        }
    }
    rrr_hil_close(&c.base);
    return 0;
}

static void test_extra_client(void)
{
    rrr_hil_scd s;
    CHECK(rrr_hil_scd_listen(&s, "127.0.0.1", 0, "bench0") == 0);
    const pid_t pid = spawn(child_extra, s.port, &s);
    rrr_hil_frame g;
    CHECK(recv_within(&s, &g, 5000) == RRR_HIL_IO_OK && g.data[0] == 0);
    rrr_hil_frame r = {0x201, 0, 8, {0, 0, 0, 0, 0, 0, 0, 0xEE}};
    CHECK(rrr_hil_send(&s.base, &r) == RRR_HIL_IO_OK);
    for (uint32_t i = 1; i < 20; ++i) {
        if (pong(&s, i) != 0) {
            CHECK(0);
            break;
        }
    }
    CHECK(s.base.err.refused == 6 && s.base.err.connects == 1 && s.base.err.disconnects == 0);
    CHECK(s.base.err.rx_frames == 20);
    CHECK(rrr_hil_recv(&s.base, &g, 3000000) == RRR_HIL_IO_DISCONNECTED);
    reap(pid, "test_extra_client");
    rrr_hil_close(&s.base);
}

int main(void)
{
    test_parser();
    test_server_client();
    test_silent_client();
    test_client_stops_mid_session();
    test_extra_client();
    return rrr_test_report("test_hil_socketcand");
}
