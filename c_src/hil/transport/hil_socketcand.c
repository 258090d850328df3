/*
 * The socketcand ASCII protocol (linux-can/socketcand doc/protocol.md, rawmode subset) over TCP,
 * as server or client. Messages are "< word args... >"; frames go as
 *   client -> server: < send ID DLC B0 B1 ... >      (ID hex, 3 digits = 11 bit; bytes unpadded hex)
 *   server -> client: < frame ID SEC.USEC HEXBYTES > (bytes as one padded upper-case hex string)
 */
#define _POSIX_C_SOURCE 200809L

#include <arpa/inet.h>
#include <errno.h>
#include <fcntl.h>
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

/* poll() wait in ms until `until_us` (-1: forever), rounded up; 0 once it is past. */
static int wait_ms_until(int64_t until_us, int64_t now)
{
    if (until_us < 0) {
        return -1;
    }
    if (until_us <= now) {
        return 0;
    }
    const int64_t ms = (until_us - now + 999) / 1000;
    return ms > RRR_HIL_SCD_TIMEOUT_MAX_MS ? RRR_HIL_SCD_TIMEOUT_MAX_MS : (int)ms;
}

/* The earlier of two deadlines, -1 meaning none. */
static int64_t earlier(int64_t a, int64_t b)
{
    if (a < 0) {
        return b;
    }
    return (b < 0 || a < b) ? a : b;
}

/* Write all n bytes to fd; a peer that accepts nothing for timeout_ms (0: not at all) fails the
 * write with ETIMEDOUT. Never blocks longer. 0, or -1 with the errno value in *err. */
static int write_fd(int fd, const char *s, size_t n, int timeout_ms, int *err)
{
    while (n > 0u) {
        const ssize_t w = send(fd, s, n, MSG_NOSIGNAL | MSG_DONTWAIT);
        if (w >= 0) {
            s += w;
            n -= (size_t)w;
            continue;
        }
        if (errno == EINTR) {
            continue;
        }
        if (errno != EAGAIN && errno != EWOULDBLOCK) {
            *err = errno;
            return -1;
        }
        struct pollfd pfd = {.fd = fd, .events = POLLOUT};
        const int pr = timeout_ms > 0 ? poll(&pfd, 1, timeout_ms) : 0;
        if (pr < 0 && errno == EINTR) {
            continue;
        }
        if (pr <= 0) {
            *err = pr == 0 ? ETIMEDOUT : errno;
            return -1;
        }
    }
    return 0;
}

/* Write to the connection; a peer that reads nothing for the idle timeout is lost. */
static int write_all(rrr_hil_scd *t, const char *s, size_t n)
{
    int e = 0;
    if (write_fd(t->fd, s, n, t->idle_timeout_ms, &e) == 0) {
        return 0;
    }
    if (e == ETIMEDOUT) {
        snprintf(t->base.last_error, sizeof t->base.last_error,
                 "socketcand: send: the peer read nothing for %d ms (idle timeout)",
                 t->idle_timeout_ms);
    } else {
        set_error(t, "send", e);
    }
    return -1;
}

/* Close a connection after a last message, best effort and without blocking: the message, a
 * FIN, then whatever the peer had sent is read away so that close() does not turn into a reset
 * that could destroy the message before the peer reads it. */
static void close_with(int fd, const char *msg)
{
    int e = 0;
    if (msg != NULL) {
        (void)write_fd(fd, msg, strlen(msg), 0, &e);
    }
    (void)shutdown(fd, SHUT_WR);
    char sink[256];
    for (int i = 0; i < 16 && recv(fd, sink, sizeof sink, MSG_DONTWAIT) > 0; ++i) {
    }
    close(fd);
}

static void refuse(rrr_hil_scd *t, int fd, const char *msg)
{
    close_with(fd, msg);
    ++t->base.err.refused;
}

static const char REFUSE_IN_USE[] = "< error session in use: one client at a time >";
static const char REFUSE_OVER[] = "< error session over >";
static const char REFUSE_BUSY[] = "< error too many clients in handshake >";

/* The connection is gone. A server's one session is then over for good. */
static void drop_peer(rrr_hil_scd *t)
{
    if (t->fd >= 0) {
        close(t->fd);
        t->fd = -1;
        ++t->base.err.disconnects;
    }
    t->len = 0;
    t->phase = 0;
    t->tx_broken = 0;
    if (t->server && t->session == RRR_HIL_SCD_SESSION_ACTIVE) {
        t->session = RRR_HIL_SCD_SESSION_OVER;
    }
}

static void tune(int fd)
{
    const int one = 1;
    (void)setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
}

/* Find the next "< ... >" in buf[0..*len): its start and length; garbage before it is counted
 * and dropped. 1 found, 0 incomplete (buf compacted; an over-long message is dropped). */
static int next_message(rrr_hil_scd *t, char *buf, unsigned *len, unsigned cap, unsigned *start,
                        unsigned *n)
{
    unsigned s = 0;
    while (s < *len && buf[s] != '<') {
        if (buf[s] != ' ' && buf[s] != '\n' && buf[s] != '\r') {
            ++t->base.err.rx_malformed; /* garbage outside < > */
        }
        ++s;
    }
    unsigned e = s;
    while (e < *len && buf[e] != '>') {
        ++e;
    }
    if (e < *len) {
        *start = s;
        *n = e - s + 1u;
        return 1;
    }
    if (s > 0u) {
        memmove(buf, buf + s, *len - s);
        *len -= s;
    }
    if (*len >= cap || *len > RRR_HIL_SCD_MAX_LINE) {
        ++t->base.err.rx_malformed;
        snprintf(t->base.last_error, sizeof t->base.last_error,
                 "socketcand: message longer than %d bytes discarded", RRR_HIL_SCD_MAX_LINE);
        *len = 0;
    }
    return 0;
}

/* Take one complete message out of the session's (or the client's) buffer: 1 frame, 0 none
 * (need more bytes). */
static int take_message(rrr_hil_scd *t, rrr_hil_frame *f)
{
    unsigned start, n;
    while (next_message(t, t->buf, &t->len, (unsigned)sizeof t->buf, &start, &n)) {
        char line[sizeof t->buf];
        memcpy(line, t->buf + start, n);
        memmove(t->buf, t->buf + start + n, t->len - start - n);
        t->len -= start + n;
        char word[16];
        const int r = rrr_hil_scd_parse(line, n, f, word);
        if (r < 0) {
            ++t->base.err.rx_malformed;
            snprintf(t->base.last_error, sizeof t->base.last_error,
                     "socketcand: malformed message: %.*s", (int)(n > 120u ? 120u : n), line);
            continue;
        }
        if (t->server) {
            t->last_rx_us = now_us(); /* a well-formed message: the client is alive */
            if (r == 1 && strcmp(word, "send") == 0) {
                t->phase = 3;
                return 1;
            }
            ++t->base.err.rx_malformed;
            snprintf(t->base.last_error, sizeof t->base.last_error,
                     "socketcand: unexpected message in the session: %.*s",
                     (int)(n > 120u ? 120u : n), line);
            continue;
        }
        if (r == 1) {
            if (strcmp(word, "frame") == 0) {
                return 1;
            }
            ++t->base.err.rx_malformed;
        } else if (strcmp(word, "error") == 0) {
            ++t->base.err.bus_errors;
            snprintf(t->base.last_error, sizeof t->base.last_error, "socketcand: server: %.*s",
                     (int)(n > 120u ? 120u : n), line);
        } else if (strcmp(word, "ok") != 0 && strcmp(word, "hi") != 0) {
            ++t->base.err.rx_malformed;
        }
    }
    return 0;
}

/* ---- server: handshakes and the one session ------------------------------------------------ */

static void pending_close(rrr_hil_scd_pending *p)
{
    if (p->fd >= 0) {
        close(p->fd);
    }
    p->fd = -1;
    p->len = 0;
    p->phase = 0;
}

/* Every handshake in progress is refused (a session started, or the server's session is over). */
static void refuse_pending(rrr_hil_scd *t, const char *msg)
{
    for (unsigned i = 0; i < RRR_HIL_SCD_MAX_PENDING; ++i) {
        rrr_hil_scd_pending *p = &t->pending[i];
        if (p->fd >= 0) {
            refuse(t, p->fd, msg);
            p->fd = -1;
            pending_close(p);
        }
    }
}

/* A handshake completed: its connection becomes the session, with the bytes that followed
 * `< rawmode >`; every other handshake is refused. */
static void start_session(rrr_hil_scd *t, rrr_hil_scd_pending *p)
{
    t->fd = p->fd;
    memcpy(t->buf, p->buf, p->len);
    t->len = p->len;
    t->phase = 2;
    t->session = RRR_HIL_SCD_SESSION_ACTIVE;
    t->last_rx_us = now_us();
    ++t->base.err.connects;
    p->fd = -1;
    pending_close(p);
    refuse_pending(t, REFUSE_IN_USE);
}

/* Reply to a handshaking connection; 0, or -1 when it cannot take even that (then closed). */
static int pending_reply(rrr_hil_scd_pending *p, const char *msg)
{
    int e = 0;
    if (write_fd(p->fd, msg, strlen(msg), 0, &e) != 0) {
        pending_close(p);
        return -1;
    }
    return 0;
}

/* Parse what a handshaking connection sent: `< open CHANNEL >` then `< rawmode >`; anything else
 * is counted and ignored. Returns 1 when the handshake is complete. */
static int pending_input(rrr_hil_scd *t, rrr_hil_scd_pending *p)
{
    unsigned start, n;
    while (p->fd >= 0 && next_message(t, p->buf, &p->len, (unsigned)sizeof p->buf, &start, &n)) {
        char line[sizeof p->buf];
        memcpy(line, p->buf + start, n);
        memmove(p->buf, p->buf + start + n, p->len - start - n);
        p->len -= start + n;
        rrr_hil_frame f;
        char word[16];
        const int r = rrr_hil_scd_parse(line, n, &f, word);
        const int shown = (int)(n > 120u ? 120u : n);
        if (r == 0 && p->phase == 0 && strcmp(word, "open") == 0) {
            char open_msg[64];
            const int k = snprintf(open_msg, sizeof open_msg, "< open %s >", t->channel);
            if (k > 0 && (unsigned)k == n && memcmp(open_msg, line, n) == 0) {
                p->phase = 1;
                (void)pending_reply(p, "< ok >");
                continue;
            }
            ++t->base.err.rx_malformed;
            snprintf(t->base.last_error, sizeof t->base.last_error,
                     "socketcand: client asked for a bus other than '%s': %.*s", t->channel, shown,
                     line);
            (void)pending_reply(p, "< error could not open bus >");
            continue;
        }
        if (r == 0 && p->phase == 1 && strcmp(word, "rawmode") == 0) {
            return pending_reply(p, "< ok >") == 0 ? 1 : 0;
        }
        ++t->base.err.rx_malformed;
        if (r == 1) {
            snprintf(t->base.last_error, sizeof t->base.last_error,
                     "socketcand: frame before the handshake finished: %.*s", shown, line);
        } else {
            snprintf(t->base.last_error, sizeof t->base.last_error,
                     "socketcand: unexpected message in handshake phase %d: %.*s", p->phase,
                     shown, line);
        }
    }
    return 0;
}

/* Accept every waiting connection: a handshake slot for it while no session exists, else the
 * protocol's error. 0, or -1 when accept fails for a reason other than "nothing waiting". */
static int accept_clients(rrr_hil_scd *t)
{
    for (;;) {
        const int fd = accept(t->listen_fd, NULL, NULL);
        if (fd < 0) {
            if (errno == EAGAIN || errno == EWOULDBLOCK) {
                return 0;
            }
            if (errno == EINTR || errno == ECONNABORTED) {
                continue;
            }
            set_error(t, "accept", errno);
            return -1;
        }
        tune(fd);
        if (t->session != RRR_HIL_SCD_NO_SESSION) {
            refuse(t, fd, t->session == RRR_HIL_SCD_SESSION_ACTIVE ? REFUSE_IN_USE : REFUSE_OVER);
            continue;
        }
        /* a free slot, else the oldest handshake makes room: a burst of silent connections
         * cannot keep out a client that handshakes at once */
        rrr_hil_scd_pending *p = &t->pending[0];
        for (unsigned i = 0; i < RRR_HIL_SCD_MAX_PENDING && p->fd >= 0; ++i) {
            if (t->pending[i].fd < 0 || t->pending[i].deadline_us < p->deadline_us) {
                p = &t->pending[i];
            }
        }
        if (p->fd >= 0) {
            refuse(t, p->fd, REFUSE_BUSY);
            p->fd = -1;
            pending_close(p);
        }
        p->fd = fd;
        p->phase = 0;
        p->len = 0;
        p->deadline_us = now_us() + (int64_t)t->handshake_timeout_ms * 1000;
        (void)pending_reply(p, "< hi >");
    }
}

/* Close the handshakes past their deadline. */
static void expire_handshakes(rrr_hil_scd *t, int64_t now)
{
    for (unsigned i = 0; i < RRR_HIL_SCD_MAX_PENDING; ++i) {
        rrr_hil_scd_pending *p = &t->pending[i];
        if (p->fd >= 0 && now >= p->deadline_us) {
            close_with(p->fd, "< error handshake timeout >");
            p->fd = -1;
            pending_close(p);
            ++t->base.err.handshake_timeouts;
            snprintf(t->base.last_error, sizeof t->base.last_error,
                     "socketcand: a client did not finish the handshake within %d ms: closed",
                     t->handshake_timeout_ms);
        }
    }
}

/* Read what a connection sent into buf. 1 bytes read, 0 nothing now, -1 closed or failed. */
static int read_into(int fd, char *buf, unsigned *len, unsigned cap, int *err)
{
    const ssize_t got = read(fd, buf + *len, cap - *len);
    if (got < 0 && (errno == EINTR || errno == EAGAIN || errno == EWOULDBLOCK)) {
        return 0;
    }
    if (got <= 0) {
        *err = got < 0 ? errno : 0;
        return -1;
    }
    *len += (unsigned)got;
    return 1;
}

/* The session is lost (hang-up, read error, idle timeout): it is over for good. */
static rrr_hil_io session_lost(rrr_hil_scd *t)
{
    drop_peer(t);
    refuse_pending(t, REFUSE_OVER);
    return RRR_HIL_IO_DISCONNECTED;
}

/* The client stopped taking our frames: deliver what it had sent already (its last frames, a
 * StopCmd among them, may still be queued), then the session is over. */
static rrr_hil_io drain_broken_session(rrr_hil_scd *t, rrr_hil_frame *f)
{
    for (;;) {
        if (take_message(t, f) == 1) {
            ++t->base.err.rx_frames;
            return RRR_HIL_IO_OK;
        }
        struct pollfd q = {.fd = t->fd, .events = POLLIN};
        int e = 0;
        if (poll(&q, 1, 0) <= 0 ||
            read_into(t->fd, t->buf, &t->len, (unsigned)sizeof t->buf, &e) <= 0) {
            return session_lost(t); /* last_error still says why the send failed */
        }
    }
}

static rrr_hil_io server_recv(rrr_hil_scd *t, rrr_hil_frame *f, int timeout_us)
{
    const int64_t deadline = timeout_us < 0 ? -1 : now_us() + timeout_us;
    for (int polled = 0;; polled = 1) {
        if (t->session == RRR_HIL_SCD_SESSION_OVER) {
            (void)accept_clients(t); /* newcomers get the protocol's error, not a hang */
            return RRR_HIL_IO_DISCONNECTED;
        }
        if (t->fd >= 0 && t->tx_broken) {
            return drain_broken_session(t, f);
        }
        if (t->fd >= 0 && take_message(t, f) == 1) {
            ++t->base.err.rx_frames;
            return RRR_HIL_IO_OK;
        }
        const int64_t now = now_us();
        expire_handshakes(t, now);
        int64_t wake = deadline;
        if (t->fd >= 0) {
            int64_t idle_end = t->last_rx_us + (int64_t)t->idle_timeout_ms * 1000;
            if (now >= idle_end) {
                /* bytes may wait unread (the caller was busy): read them before judging */
                struct pollfd q = {.fd = t->fd, .events = POLLIN};
                int e = 0;
                if (poll(&q, 1, 0) > 0 &&
                    read_into(t->fd, t->buf, &t->len, (unsigned)sizeof t->buf, &e) < 0) {
                    snprintf(t->base.last_error, sizeof t->base.last_error,
                             "socketcand: the client closed the connection");
                    return session_lost(t);
                }
                if (take_message(t, f) == 1) {
                    ++t->base.err.rx_frames;
                    return RRR_HIL_IO_OK;
                }
                idle_end = t->last_rx_us + (int64_t)t->idle_timeout_ms * 1000;
            }
            if (now >= idle_end) {
                close_with(t->fd, "< error idle timeout >");
                t->fd = -1;
                ++t->base.err.disconnects;
                ++t->base.err.idle_timeouts;
                snprintf(t->base.last_error, sizeof t->base.last_error,
                         "socketcand: the client sent nothing for %d ms (idle timeout): session "
                         "closed", t->idle_timeout_ms);
                return session_lost(t);
            }
            wake = earlier(wake, idle_end);
        }
        if (polled && deadline >= 0 && now >= deadline) {
            return RRR_HIL_IO_TIMEOUT;
        }
        struct pollfd pfd[2 + RRR_HIL_SCD_MAX_PENDING];
        rrr_hil_scd_pending *who[2 + RRR_HIL_SCD_MAX_PENDING];
        nfds_t nfd = 0;
        pfd[nfd] = (struct pollfd){.fd = t->listen_fd, .events = POLLIN};
        who[nfd++] = NULL;
        if (t->fd >= 0) {
            pfd[nfd] = (struct pollfd){.fd = t->fd, .events = POLLIN};
            who[nfd++] = NULL;
        }
        for (unsigned i = 0; i < RRR_HIL_SCD_MAX_PENDING; ++i) {
            if (t->pending[i].fd >= 0) {
                pfd[nfd] = (struct pollfd){.fd = t->pending[i].fd, .events = POLLIN};
                who[nfd++] = &t->pending[i];
                wake = earlier(wake, t->pending[i].deadline_us);
            }
        }
        const int pr = poll(pfd, nfd, wait_ms_until(wake, now));
        if (pr < 0) {
            if (errno == EINTR) {
                continue;
            }
            set_error(t, "poll", errno);
            return RRR_HIL_IO_ERROR;
        }
        for (nfds_t i = 1; i < nfd && pr > 0; ++i) {
            if ((pfd[i].revents & (POLLIN | POLLHUP | POLLERR)) == 0) {
                continue;
            }
            int e = 0;
            if (who[i] == NULL) { /* the session */
                if (t->fd >= 0 && read_into(t->fd, t->buf, &t->len, (unsigned)sizeof t->buf, &e) < 0) {
                    if (e != 0) {
                        set_error(t, "read", e);
                    } else {
                        snprintf(t->base.last_error, sizeof t->base.last_error,
                                 "socketcand: the client closed the connection");
                    }
                    return session_lost(t);
                }
                continue;
            }
            rrr_hil_scd_pending *p = who[i];
            if (p->fd < 0) {
                continue; /* refused meanwhile: another handshake finished first */
            }
            if (read_into(p->fd, p->buf, &p->len, (unsigned)sizeof p->buf, &e) < 0) {
                pending_close(p); /* left during the handshake: not a session */
                continue;
            }
            if (pending_input(t, p) == 1 && t->session == RRR_HIL_SCD_NO_SESSION) {
                start_session(t, p);
            }
        }
        if (pr > 0 && (pfd[0].revents & POLLIN) != 0 && accept_clients(t) != 0) {
            return RRR_HIL_IO_ERROR;
        }
    }
}

/* ---- client ---------------------------------------------------------------------------------- */

static rrr_hil_io client_recv(rrr_hil_scd *t, rrr_hil_frame *f, int timeout_us)
{
    const int64_t deadline = timeout_us < 0 ? -1 : now_us() + timeout_us;
    for (;;) {
        if (t->fd < 0) {
            snprintf(t->base.last_error, sizeof t->base.last_error, "socketcand: not connected");
            return RRR_HIL_IO_DISCONNECTED;
        }
        if (take_message(t, f) == 1) {
            ++t->base.err.rx_frames;
            return RRR_HIL_IO_OK;
        }
        const int64_t now = now_us();
        struct pollfd pfd = {.fd = t->fd, .events = POLLIN};
        const int pr = poll(&pfd, 1, wait_ms_until(deadline, now));
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
        int e = 0;
        if (read_into(t->fd, t->buf, &t->len, (unsigned)sizeof t->buf, &e) < 0) {
            if (e != 0) {
                set_error(t, "read", e);
            } else if (strncmp(t->base.last_error, "socketcand: server: ", 20) == 0) {
                char said[120];
                snprintf(said, sizeof said, "%s", t->base.last_error + 20);
                snprintf(t->base.last_error, sizeof t->base.last_error,
                         "socketcand: the server closed the connection after '%.*s'",
                         (int)(sizeof said - 1u), said);
            } else {
                snprintf(t->base.last_error, sizeof t->base.last_error,
                         "socketcand: the server closed the connection");
            }
            drop_peer(t);
            return RRR_HIL_IO_DISCONNECTED;
        }
    }
}

static rrr_hil_io scd_recv(rrr_hil_transport *base, rrr_hil_frame *f, int timeout_us)
{
    rrr_hil_scd *t = (rrr_hil_scd *)base;
    return t->server ? server_recv(t, f, timeout_us) : client_recv(t, f, timeout_us);
}

static rrr_hil_io scd_send(rrr_hil_transport *base, const rrr_hil_frame *f)
{
    rrr_hil_scd *t = (rrr_hil_scd *)base;
    if (t->fd < 0 || t->tx_broken) {
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
        if (t->server) {
            t->tx_broken = 1; /* recv still delivers what the client had sent, then ends it */
        } else {
            drop_peer(t);
        }
        return RRR_HIL_IO_DISCONNECTED;
    }
    ++t->base.err.tx_frames;
    return RRR_HIL_IO_OK;
}

/* Close without a reset: our FIN, then the peer's frames are read away until it closes too
 * (at most wait_ms), so that it reads everything we sent (a StopCmd last of all) instead of
 * losing it to the reset that closing with unread data would cause. */
static void linger_close(int fd, int wait_ms)
{
    (void)shutdown(fd, SHUT_WR);
    const int64_t end = now_us() + (int64_t)wait_ms * 1000;
    char sink[512];
    for (;;) {
        const int64_t now = now_us();
        struct pollfd q = {.fd = fd, .events = POLLIN};
        if (now >= end || poll(&q, 1, wait_ms_until(end, now)) <= 0 ||
            read(fd, sink, sizeof sink) <= 0) {
            break;
        }
    }
    close(fd);
}

static void scd_close(rrr_hil_transport *base)
{
    rrr_hil_scd *t = (rrr_hil_scd *)base;
    if (t->fd >= 0) {
        linger_close(t->fd, t->idle_timeout_ms < 500 ? t->idle_timeout_ms : 500);
        t->fd = -1;
    }
    for (unsigned i = 0; i < RRR_HIL_SCD_MAX_PENDING; ++i) {
        pending_close(&t->pending[i]);
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
    for (unsigned i = 0; i < RRR_HIL_SCD_MAX_PENDING; ++i) {
        t->pending[i].fd = -1;
    }
    t->handshake_timeout_ms = RRR_HIL_SCD_HANDSHAKE_TIMEOUT_MS;
    t->idle_timeout_ms = RRR_HIL_SCD_IDLE_TIMEOUT_MS;
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

int rrr_hil_scd_set_timeouts(rrr_hil_scd *t, int handshake_timeout_ms, int idle_timeout_ms)
{
    if (handshake_timeout_ms < 1 || handshake_timeout_ms > RRR_HIL_SCD_TIMEOUT_MAX_MS ||
        idle_timeout_ms < 1 || idle_timeout_ms > RRR_HIL_SCD_TIMEOUT_MAX_MS) {
        snprintf(t->base.last_error, sizeof t->base.last_error,
                 "socketcand: timeouts must be 1..%d ms, got handshake %d, idle %d",
                 RRR_HIL_SCD_TIMEOUT_MAX_MS, handshake_timeout_ms, idle_timeout_ms);
        return -1;
    }
    t->handshake_timeout_ms = handshake_timeout_ms;
    t->idle_timeout_ms = idle_timeout_ms;
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
    /* non-blocking: a connection reset between poll() and accept() must not block the bench */
    const int fl = fcntl(t->listen_fd, F_GETFL);
    if (fl < 0 || fcntl(t->listen_fd, F_SETFL, fl | O_NONBLOCK) != 0 ||
        listen(t->listen_fd, 8) != 0 || getsockname(t->listen_fd, (struct sockaddr *)&a, &alen) != 0) {
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
