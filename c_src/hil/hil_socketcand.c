/*
 * The socketcand ASCII protocol (linux-can/socketcand doc/protocol.md, rawmode subset) over TCP,
 * as server or client. Messages are "< word args... >"; frames go as
 *   client -> server: < send ID DLC B0 B1 ... >      (ID hex, 3 digits = 11 bit; bytes unpadded hex)
 *   server -> client: < frame ID SEC.USEC HEXBYTES > (bytes as one padded upper-case hex string)
 */
#define _POSIX_C_SOURCE 200809L

#include <arpa/inet.h>
#include <errno.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <poll.h>
#include <stdio.h>
#include <string.h>
#include <sys/socket.h>
#include <time.h>
#include <unistd.h>

#include "hil_transport.h"

/* ---- the pure parser ------------------------------------------------------------------------- */

static int hexval(char c)
{
    if (c >= '0' && c <= '9') {
        return c - '0';
    }
    if (c >= 'a' && c <= 'f') {
        return c - 'a' + 10;
    }
    if (c >= 'A' && c <= 'F') {
        return c - 'A' + 10;
    }
    return -1;
}

/* Next space-separated token of [*p, end): start and length; 0 if none. */
static unsigned next_token(const char **p, const char *end, const char **tok)
{
    const char *s = *p;
    while (s < end && *s == ' ') {
        ++s;
    }
    const char *e = s;
    while (e < end && *e != ' ') {
        ++e;
    }
    *tok = s;
    *p = e;
    return (unsigned)(e - s);
}

/* Hex number of 1..max_digits digits. */
static int parse_hex(const char *s, unsigned n, unsigned max_digits, uint32_t *v)
{
    if (n == 0u || n > max_digits) {
        return -1;
    }
    uint32_t x = 0;
    for (unsigned i = 0; i < n; ++i) {
        const int h = hexval(s[i]);
        if (h < 0) {
            return -1;
        }
        x = (x << 4) | (uint32_t)h;
    }
    *v = x;
    return 0;
}

static int parse_id(const char *s, unsigned n, rrr_hil_frame *f)
{
    uint32_t id;
    if (parse_hex(s, n, 8u, &id) != 0) {
        return -1;
    }
    f->extended = n > 3u;
    if ((!f->extended && id > 0x7FFu) || id > 0x1FFFFFFFu) {
        return -1;
    }
    f->id = id;
    return 0;
}

int rrr_hil_scd_parse(const char *line, unsigned n, rrr_hil_frame *f, char word[16])
{
    word[0] = '\0';
    if (n < 4u || line[0] != '<' || line[n - 1] != '>' || line[1] != ' ' || line[n - 2] != ' ') {
        return -1;
    }
    const char *p = line + 1;
    const char *end = line + n - 1;
    const char *tok;
    unsigned k = next_token(&p, end, &tok);
    if (k == 0u || k >= 16u) {
        return -1;
    }
    memcpy(word, tok, k);
    word[k] = '\0';
    const int is_send = strcmp(word, "send") == 0;
    if (!is_send && strcmp(word, "frame") != 0) {
        return 0;
    }
    rrr_hil_frame g;
    memset(&g, 0, sizeof g);
    k = next_token(&p, end, &tok);
    if (parse_id(tok, k, &g) != 0) {
        return -1;
    }
    if (is_send) {
        uint32_t dlc;
        k = next_token(&p, end, &tok);
        if (parse_hex(tok, k, 1u, &dlc) != 0 || dlc > 8u) {
            return -1;
        }
        g.dlc = (uint8_t)dlc;
        for (unsigned i = 0; i < dlc; ++i) {
            uint32_t b;
            k = next_token(&p, end, &tok);
            if (parse_hex(tok, k, 2u, &b) != 0) {
                return -1;
            }
            g.data[i] = (uint8_t)b;
        }
    } else {
        k = next_token(&p, end, &tok); /* time stamp: digits '.' digits */
        unsigned dots = 0;
        for (unsigned i = 0; i < k; ++i) {
            if (tok[i] == '.') {
                ++dots;
            } else if (tok[i] < '0' || tok[i] > '9') {
                return -1;
            }
        }
        if (k == 0u || dots > 1u) {
            return -1;
        }
        k = next_token(&p, end, &tok); /* data, may be empty (dlc 0) */
        if (k % 2u != 0u || k > 16u) {
            return -1;
        }
        g.dlc = (uint8_t)(k / 2u);
        for (unsigned i = 0; i < g.dlc; ++i) {
            uint32_t b;
            if (parse_hex(tok + 2u * i, 2u, 2u, &b) != 0) {
                return -1;
            }
            g.data[i] = (uint8_t)b;
        }
    }
    if (next_token(&p, end, &tok) != 0u) {
        return -1; /* trailing tokens */
    }
    *f = g;
    return 1;
}

/* ---- I/O ------------------------------------------------------------------------------------ */

static void set_error(rrr_hil_scd *t, const char *what, int errnum)
{
    snprintf(t->base.last_error, sizeof t->base.last_error, "socketcand: %s: %s (errno %d)", what,
             strerror(errnum), errnum);
}

static int64_t now_us(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (int64_t)ts.tv_sec * 1000000 + ts.tv_nsec / 1000;
}

static int write_all(rrr_hil_scd *t, const char *s, size_t n)
{
    while (n > 0u) {
        const ssize_t w = send(t->fd, s, n, MSG_NOSIGNAL);
        if (w < 0) {
            if (errno == EINTR) {
                continue;
            }
            set_error(t, "send", errno);
            return -1;
        }
        s += w;
        n -= (size_t)w;
    }
    return 0;
}

static void drop_peer(rrr_hil_scd *t)
{
    if (t->fd >= 0) {
        close(t->fd);
        t->fd = -1;
        ++t->base.err.disconnects;
    }
    t->len = 0;
    t->phase = 0;
}

static void tune(int fd)
{
    const int one = 1;
    (void)setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
}

/* Server side of the handshake; 0 on a handled message, -1 on a protocol error. */
static int server_control(rrr_hil_scd *t, const char *word, const char *line, unsigned n)
{
    char open_msg[64];
    const int k = snprintf(open_msg, sizeof open_msg, "< open %s >", t->channel);
    if (t->phase == 0 && strcmp(word, "open") == 0) {
        if (k > 0 && (unsigned)k == n && memcmp(open_msg, line, n) == 0) {
            t->phase = 1;
            return write_all(t, "< ok >", 6);
        }
        ++t->base.err.rx_malformed;
        snprintf(t->base.last_error, sizeof t->base.last_error,
                 "socketcand: client asked for a bus other than '%s': %.*s", t->channel, (int)n,
                 line);
        return write_all(t, "< error could not open bus >", 28);
    }
    if (t->phase == 1 && strcmp(word, "rawmode") == 0) {
        t->phase = 2;
        return write_all(t, "< ok >", 6);
    }
    ++t->base.err.rx_malformed;
    snprintf(t->base.last_error, sizeof t->base.last_error,
             "socketcand: unexpected message in handshake phase %d: %.*s", t->phase, (int)n, line);
    return 0;
}

/* Take one complete message out of buf: 1 frame, 0 none (need more bytes), -1 connection error. */
static int take_message(rrr_hil_scd *t, rrr_hil_frame *f)
{
    for (;;) {
        unsigned start = 0;
        while (start < t->len && t->buf[start] != '<') {
            if (t->buf[start] != ' ' && t->buf[start] != '\n' && t->buf[start] != '\r') {
                ++t->base.err.rx_malformed; /* garbage outside < > */
            }
            ++start;
        }
        unsigned end = start;
        while (end < t->len && t->buf[end] != '>') {
            ++end;
        }
        if (end >= t->len) { /* incomplete */
            if (start > 0u) {
                memmove(t->buf, t->buf + start, t->len - start);
                t->len -= start;
            }
            if (t->len >= sizeof t->buf || t->len > RRR_HIL_SCD_MAX_LINE) {
                ++t->base.err.rx_malformed;
                snprintf(t->base.last_error, sizeof t->base.last_error,
                         "socketcand: message longer than %d bytes discarded", RRR_HIL_SCD_MAX_LINE);
                t->len = 0;
            }
            return 0;
        }
        const unsigned n = end - start + 1u;
        char line[sizeof t->buf];
        memcpy(line, t->buf + start, n);
        memmove(t->buf, t->buf + end + 1, t->len - end - 1u);
        t->len -= end + 1u;
        char word[16];
        const int r = rrr_hil_scd_parse(line, n, f, word);
        if (r < 0) {
            ++t->base.err.rx_malformed;
            snprintf(t->base.last_error, sizeof t->base.last_error,
                     "socketcand: malformed message: %.*s", (int)(n > 120u ? 120u : n), line);
            continue;
        }
        if (r == 1) {
            if (t->server && strcmp(word, "send") != 0) {
                ++t->base.err.rx_malformed;
                continue;
            }
            if (t->server && t->phase < 2) {
                ++t->base.err.rx_malformed;
                snprintf(t->base.last_error, sizeof t->base.last_error,
                         "socketcand: frame before the handshake finished");
                continue;
            }
            if (!t->server && strcmp(word, "frame") != 0) {
                ++t->base.err.rx_malformed;
                continue;
            }
            if (t->server) {
                t->phase = 3;
            }
            return 1;
        }
        if (t->server) {
            if (server_control(t, word, line, n) != 0) {
                return -1;
            }
        } else if (strcmp(word, "error") == 0) {
            ++t->base.err.bus_errors;
            snprintf(t->base.last_error, sizeof t->base.last_error, "socketcand: server: %.*s",
                     (int)n, line);
        } else if (strcmp(word, "ok") != 0 && strcmp(word, "hi") != 0) {
            ++t->base.err.rx_malformed;
        }
    }
}

/* Accept a client if one is waiting (server without a peer). */
static int try_accept(rrr_hil_scd *t)
{
    const int fd = accept(t->listen_fd, NULL, NULL);
    if (fd < 0) {
        if (errno == EAGAIN || errno == EWOULDBLOCK || errno == EINTR || errno == ECONNABORTED) {
            return 0;
        }
        set_error(t, "accept", errno);
        return -1;
    }
    tune(fd);
    t->fd = fd;
    t->len = 0;
    t->phase = 0;
    ++t->base.err.connects;
    if (write_all(t, "< hi >", 6) != 0) {
        drop_peer(t);
    }
    return 0;
}

static rrr_hil_io scd_recv(rrr_hil_transport *base, rrr_hil_frame *f, int timeout_us)
{
    rrr_hil_scd *t = (rrr_hil_scd *)base;
    const int64_t deadline = timeout_us < 0 ? -1 : now_us() + timeout_us;
    for (;;) {
        if (t->fd >= 0) {
            const int r = take_message(t, f);
            if (r == 1) {
                ++t->base.err.rx_frames;
                return RRR_HIL_IO_OK;
            }
            if (r < 0) {
                drop_peer(t);
                return RRR_HIL_IO_DISCONNECTED;
            }
        }
        int wait_ms = -1;
        if (deadline >= 0) {
            const int64_t left = deadline - now_us();
            wait_ms = left <= 0 ? 0 : (int)((left + 999) / 1000);
        }
        struct pollfd pfd = {.fd = t->fd >= 0 ? t->fd : t->listen_fd, .events = POLLIN};
        if (pfd.fd < 0) {
            snprintf(t->base.last_error, sizeof t->base.last_error, "socketcand: not connected");
            return RRR_HIL_IO_ERROR;
        }
        const int pr = poll(&pfd, 1, wait_ms);
        if (pr < 0) {
            if (errno == EINTR) {
                continue;
            }
            set_error(t, "poll", errno);
            return RRR_HIL_IO_ERROR;
        }
        if (pr == 0) {
            if (deadline >= 0 && now_us() >= deadline) {
                return RRR_HIL_IO_TIMEOUT;
            }
            continue;
        }
        if (t->fd < 0) {
            if (try_accept(t) != 0) {
                return RRR_HIL_IO_ERROR;
            }
            continue;
        }
        const ssize_t got = read(t->fd, t->buf + t->len, sizeof t->buf - t->len);
        if (got < 0 && errno == EINTR) {
            continue;
        }
        if (got <= 0) {
            if (got < 0) {
                set_error(t, "read", errno);
            } else {
                snprintf(t->base.last_error, sizeof t->base.last_error,
                         "socketcand: the peer closed the connection");
            }
            drop_peer(t);
            return RRR_HIL_IO_DISCONNECTED;
        }
        t->len += (unsigned)got;
    }
}

static rrr_hil_io scd_send(rrr_hil_transport *base, const rrr_hil_frame *f)
{
    rrr_hil_scd *t = (rrr_hil_scd *)base;
    if (t->fd < 0) {
        ++t->base.err.tx_dropped;
        return RRR_HIL_IO_DISCONNECTED;
    }
    if (f->dlc > 8u) {
        ++t->base.err.tx_failed;
        snprintf(t->base.last_error, sizeof t->base.last_error, "socketcand: send: dlc %u > 8",
                 (unsigned)f->dlc);
        return RRR_HIL_IO_ERROR;
    }
    if (t->server && t->phase < 3) {
        ++t->base.err.tx_dropped; /* the handshake pitfall: nothing before the client's frame */
        return RRR_HIL_IO_OK;
    }
    char msg[96];
    int n;
    const int idw = f->extended ? 8 : 3;
    if (t->server) {
        struct timespec ts;
        clock_gettime(CLOCK_REALTIME, &ts);
        n = snprintf(msg, sizeof msg, "< frame %0*X %lld.%06ld ", idw, (unsigned)f->id,
                     (long long)ts.tv_sec, ts.tv_nsec / 1000);
        for (unsigned i = 0; i < f->dlc; ++i) {
            n += snprintf(msg + n, sizeof msg - (size_t)n, "%02X", f->data[i]);
        }
        n += snprintf(msg + n, sizeof msg - (size_t)n, " >");
    } else {
        n = snprintf(msg, sizeof msg, "< send %0*X %X ", idw, (unsigned)f->id, (unsigned)f->dlc);
        for (unsigned i = 0; i < f->dlc; ++i) {
            n += snprintf(msg + n, sizeof msg - (size_t)n, "%x ", f->data[i]);
        }
        n += snprintf(msg + n, sizeof msg - (size_t)n, ">");
    }
    if (write_all(t, msg, (size_t)n) != 0) {
        ++t->base.err.tx_failed;
        drop_peer(t);
        return RRR_HIL_IO_DISCONNECTED;
    }
    ++t->base.err.tx_frames;
    return RRR_HIL_IO_OK;
}

static void scd_close(rrr_hil_transport *base)
{
    rrr_hil_scd *t = (rrr_hil_scd *)base;
    if (t->fd >= 0) {
        close(t->fd);
        t->fd = -1;
    }
    if (t->listen_fd >= 0) {
        close(t->listen_fd);
        t->listen_fd = -1;
    }
}

static const rrr_hil_transport_vt scd_vt = {scd_send, scd_recv, scd_close};

static int init_common(rrr_hil_scd *t, int server, const char *channel)
{
    memset(t, 0, sizeof *t);
    t->base.vt = NULL;
    t->base.name = "socketcand";
    t->server = server;
    t->listen_fd = -1;
    t->fd = -1;
    const size_t n = strlen(channel);
    if (n == 0u || n >= sizeof t->channel || strpbrk(channel, " <>") != NULL) {
        snprintf(t->base.last_error, sizeof t->base.last_error,
                 "socketcand: bad channel name '%.40s' (1..31 characters, no blanks or <>)",
                 channel);
        return -1;
    }
    memcpy(t->channel, channel, n + 1u);
    return 0;
}

static int make_addr(rrr_hil_scd *t, const char *host, uint16_t port, struct sockaddr_in *a)
{
    memset(a, 0, sizeof *a);
    a->sin_family = AF_INET;
    a->sin_port = htons(port);
    if (inet_pton(AF_INET, host, &a->sin_addr) != 1) {
        snprintf(t->base.last_error, sizeof t->base.last_error,
                 "socketcand: host '%.60s' is not an IPv4 address", host);
        return -1;
    }
    return 0;
}

int rrr_hil_scd_listen(rrr_hil_scd *t, const char *host, uint16_t port, const char *channel)
{
    struct sockaddr_in a;
    if (init_common(t, 1, channel) != 0 || make_addr(t, host, port, &a) != 0) {
        return -1;
    }
    t->listen_fd = socket(AF_INET, SOCK_STREAM, 0);
    if (t->listen_fd < 0) {
        set_error(t, "socket(AF_INET)", errno);
        return -1;
    }
    const int one = 1;
    (void)setsockopt(t->listen_fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
    socklen_t alen = sizeof a;
    if (bind(t->listen_fd, (struct sockaddr *)&a, sizeof a) != 0) {
        char what[96];
        snprintf(what, sizeof what, "bind(%s:%u)", host, (unsigned)port);
        set_error(t, what, errno);
        scd_close(&t->base);
        return -1;
    }
    if (listen(t->listen_fd, 1) != 0 || getsockname(t->listen_fd, (struct sockaddr *)&a, &alen) != 0) {
        set_error(t, "listen", errno);
        scd_close(&t->base);
        return -1;
    }
    t->port = ntohs(a.sin_port);
    t->base.vt = &scd_vt;
    return 0;
}

/* Client: wait for one control message and check its word. */
static int expect(rrr_hil_scd *t, const char *want, int wait_ms)
{
    const int64_t deadline = now_us() + (int64_t)wait_ms * 1000;
    for (;;) {
        unsigned start = 0;
        while (start < t->len && t->buf[start] != '<') {
            ++start;
        }
        unsigned end = start;
        while (end < t->len && t->buf[end] != '>') {
            ++end;
        }
        if (end < t->len) {
            rrr_hil_frame f;
            char word[16];
            const unsigned n = end - start + 1u;
            const int r = rrr_hil_scd_parse(t->buf + start, n, &f, word);
            char line[RRR_HIL_SCD_MAX_LINE];
            const unsigned m = n < sizeof line - 1u ? n : (unsigned)sizeof line - 1u;
            memcpy(line, t->buf + start, m);
            line[m] = '\0';
            memmove(t->buf, t->buf + end + 1, t->len - end - 1u);
            t->len -= end + 1u;
            if (r == 0 && strcmp(word, want) == 0) {
                return 0;
            }
            snprintf(t->base.last_error, sizeof t->base.last_error,
                     "socketcand: handshake: expected '< %s >', got '%.120s'", want, line);
            return -1;
        }
        if (t->len >= RRR_HIL_SCD_MAX_LINE) {
            snprintf(t->base.last_error, sizeof t->base.last_error,
                     "socketcand: handshake: no '>' in %u bytes", t->len);
            return -1;
        }
        const int64_t left = deadline - now_us();
        struct pollfd pfd = {.fd = t->fd, .events = POLLIN};
        const int pr = left > 0 ? poll(&pfd, 1, (int)((left + 999) / 1000)) : 0;
        if (pr <= 0) {
            snprintf(t->base.last_error, sizeof t->base.last_error,
                     "socketcand: handshake: no '< %s >' within %d ms", want, wait_ms);
            return -1;
        }
        const ssize_t got = read(t->fd, t->buf + t->len, sizeof t->buf - t->len);
        if (got <= 0) {
            snprintf(t->base.last_error, sizeof t->base.last_error,
                     "socketcand: handshake: the server closed the connection");
            return -1;
        }
        t->len += (unsigned)got;
    }
}

int rrr_hil_scd_connect(rrr_hil_scd *t, const char *host, uint16_t port, const char *channel,
                        int wait_ms)
{
    struct sockaddr_in a;
    if (init_common(t, 0, channel) != 0 || make_addr(t, host, port, &a) != 0) {
        return -1;
    }
    t->port = port;
    const int64_t deadline = now_us() + (int64_t)wait_ms * 1000;
    for (;;) {
        t->fd = socket(AF_INET, SOCK_STREAM, 0);
        if (t->fd < 0) {
            set_error(t, "socket(AF_INET)", errno);
            return -1;
        }
        if (connect(t->fd, (struct sockaddr *)&a, sizeof a) == 0) {
            break;
        }
        const int e = errno;
        close(t->fd);
        t->fd = -1;
        if (now_us() >= deadline) {
            char what[96];
            snprintf(what, sizeof what, "connect(%s:%u) for %d ms", host, (unsigned)port, wait_ms);
            set_error(t, what, e);
            return -1;
        }
        const struct timespec pause = {0, 20 * 1000 * 1000};
        nanosleep(&pause, NULL);
    }
    tune(t->fd);
    char open_msg[64];
    const int n = snprintf(open_msg, sizeof open_msg, "< open %s >", t->channel);
    if (expect(t, "hi", wait_ms) != 0 || write_all(t, open_msg, (size_t)n) != 0 ||
        expect(t, "ok", wait_ms) != 0 || write_all(t, "< rawmode >", 11) != 0 ||
        expect(t, "ok", wait_ms) != 0) {
        scd_close(&t->base);
        return -1;
    }
    t->phase = 3;
    ++t->base.err.connects;
    t->base.vt = &scd_vt;
    return 0;
}
