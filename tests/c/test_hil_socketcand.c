/* The socketcand transport: the message parser on good and bad input, then a server and a
 * client (forked) exchanging frames through the real TCP code: handshake, the rule that the
 * server sends nothing before the client's first frame, malformed input counted, disconnects. */
#define _POSIX_C_SOURCE 200809L

#include <arpa/inet.h>
#include <netinet/in.h>
#include <string.h>
#include <sys/socket.h>
#include <sys/wait.h>
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

/* The child: a raw TCP client that misbehaves a little, then a proper client. */
static int child(uint16_t port)
{
    /* 1: a raw socket: handshake by hand, garbage, one frame, then a hang-up */
    int fd = socket(AF_INET, SOCK_STREAM, 0);
    struct sockaddr_in a;
    memset(&a, 0, sizeof a);
    a.sin_family = AF_INET;
    a.sin_port = htons(port);
    inet_pton(AF_INET, "127.0.0.1", &a.sin_addr);
    if (connect(fd, (struct sockaddr *)&a, sizeof a) != 0) {
        return 10;
    }
    char buf[256];
    ssize_t n = read(fd, buf, sizeof buf);
    if (n != 6 || memcmp(buf, "< hi >", 6) != 0) {
        return 11;
    }
    const char *script = "< open bench0 >";
    if (write(fd, script, strlen(script)) < 0 || read(fd, buf, sizeof buf) != 6) {
        return 12;
    }
    script = "< rawmode >";
    if (write(fd, script, strlen(script)) < 0 || read(fd, buf, sizeof buf) != 6) {
        return 13;
    }
    script = "junk< send 100 9 1 >< send 1 1 zz >< send 701 2 5 0 >";
    if (write(fd, script, strlen(script)) < 0) {
        return 14;
    }
    /* wait for the server's reply frame, then hang up */
    n = read(fd, buf, sizeof buf);
    if (n <= 0 || strncmp(buf, "< frame 702 ", 12) != 0) {
        return 15;
    }
    close(fd);

    /* 2: the library client */
    rrr_hil_scd c;
    if (rrr_hil_scd_connect(&c, "127.0.0.1", port, "bench0", 3000) != 0) {
        fprintf(stderr, "child: %s\n", c.base.last_error);
        return 20;
    }
    for (uint32_t i = 0; i < 100; ++i) {
        rrr_hil_frame f = {0x100, 0, 8, {(uint8_t)i, 1, 2, 3, 4, 5, 6, 7}};
        if (rrr_hil_send(&c.base, &f) != RRR_HIL_IO_OK) {
            return 21;
        }
        rrr_hil_frame g;
        if (rrr_hil_recv(&c.base, &g, 2000000) != RRR_HIL_IO_OK || g.id != 0x201 || g.dlc != 8 ||
            g.data[0] != (uint8_t)i || g.data[7] != 0xEE) {
            return 22;
        }
    }
    rrr_hil_close(&c.base);
    rrr_hil_close(&c.base); /* idempotent */
    return 0;
}

static void test_server_client(void)
{
    rrr_hil_scd s;
    CHECK(rrr_hil_scd_listen(&s, "not-an-ip", 0, "bench0") == -1);
    CHECK(strstr(s.base.last_error, "not an IPv4 address") != NULL);
    CHECK(rrr_hil_scd_listen(&s, "127.0.0.1", 0, "bad name") == -1);
    CHECK(rrr_hil_scd_listen(&s, "127.0.0.1", 0, "bench0") == 0);
    CHECK(s.port != 0);
    fflush(NULL);
    const pid_t pid = fork();
    if (pid == 0) {
        rrr_hil_close(&s.base);
        _exit(child(s.port));
    }
    /* session 1: garbage counted; the frame before the client's first one is dropped */
    rrr_hil_frame f = {0x702, 0, 2, {5, 0}};
    CHECK(rrr_hil_send(&s.base, &f) == RRR_HIL_IO_DISCONNECTED); /* no client yet */
    rrr_hil_frame g;
    CHECK(rrr_hil_recv(&s.base, &g, 3000000) == RRR_HIL_IO_OK);
    CHECK(g.id == 0x701 && g.dlc == 2 && g.data[0] == 5);
    CHECK(s.base.err.rx_malformed >= 3); /* "junk" (4 chars), dlc 9, "zz" */
    CHECK(rrr_hil_send(&s.base, &f) == RRR_HIL_IO_OK);
    CHECK(rrr_hil_recv(&s.base, &g, 3000000) == RRR_HIL_IO_DISCONNECTED);
    CHECK(s.base.err.disconnects == 1);
    /* session 2: the library client, 100 ping-pongs */
    for (int i = 0; i < 100; ++i) {
        if (rrr_hil_recv(&s.base, &g, 3000000) != RRR_HIL_IO_OK) {
            CHECK(0);
            break;
        }
        CHECK(g.id == 0x100 && g.data[0] == (uint8_t)i);
        rrr_hil_frame r = {0x201, 0, 8, {g.data[0], 0, 0, 0, 0, 0, 0, 0xEE}};
        CHECK(rrr_hil_send(&s.base, &r) == RRR_HIL_IO_OK);
    }
    CHECK(rrr_hil_recv(&s.base, &g, 3000000) == RRR_HIL_IO_DISCONNECTED);
    CHECK(rrr_hil_recv(&s.base, &g, 0) == RRR_HIL_IO_TIMEOUT);
    CHECK(s.base.err.connects == 2 && s.base.err.disconnects == 2);
    int status = -1;
    waitpid(pid, &status, 0);
    CHECK(WIFEXITED(status) && WEXITSTATUS(status) == 0);
    if (!WIFEXITED(status) || WEXITSTATUS(status) != 0) {
        fprintf(stderr, "child exit status %d\n", WEXITSTATUS(status));
    }
    rrr_hil_close(&s.base);
    CHECK(rrr_hil_send(&s.base, &f) == RRR_HIL_IO_ERROR);
    /* a client with nobody listening: a clear error after the retry time */
    rrr_hil_scd c;
    CHECK(rrr_hil_scd_connect(&c, "127.0.0.1", s.port, "bench0", 100) == -1);
    CHECK(strstr(c.base.last_error, "connect(127.0.0.1:") != NULL);
}

int main(void)
{
    test_parser();
    test_server_client();
    return rrr_test_report("test_hil_socketcand");
}
