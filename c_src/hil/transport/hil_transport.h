/**
 * @file hil_transport.h
 * @brief How the bench nodes move CAN frames: a small interface (send, receive with a timeout,
 *        close) with two implementations:
 *  - SocketCAN: a raw AF_CAN socket bound to an interface (vcan0, can0), with receive filters and
 *    error frames (bus-off, controller problems) reported as RRR_HIL_IO_BUS_OFF / counted;
 *    classical CAN, or CAN FD (the same frames as CAN FD frames with bit-rate switch);
 *  - socketcand: the ASCII protocol of linux-can/socketcand over TCP, as the server (a node
 *    that python-can's built-in `socketcand` interface connects to) or as the client (a node
 *    that connects to a socketcand server: the other C node, or a real socketcand daemon).
 *
 * Lifecycle: rrr_hil_<impl>_open -> send/recv ... -> rrr_hil_close. Not thread-safe.
 * Errors: calls return a rrr_hil_io code; the transport keeps counters that only grow and the
 * text of the last error (function, argument, errno text).
 */
#ifndef RRR_HIL_TRANSPORT_H
#define RRR_HIL_TRANSPORT_H

#include <stdint.h>

#include "hil_common.h"

/** Outcome of a transport call. */
typedef enum rrr_hil_io {
    RRR_HIL_IO_OK = 0,       ///< a frame was sent / received
    RRR_HIL_IO_TIMEOUT,      ///< nothing received before the timeout
    RRR_HIL_IO_DISCONNECTED, ///< the peer is gone (TCP: closed, reset, idle timeout; a server's
                             ///< one session is over: it never accepts another)
    RRR_HIL_IO_BUS_OFF,      ///< the CAN controller went bus-off (SocketCAN error frame)
    RRR_HIL_IO_ERROR         ///< a system call failed: see last_error
} rrr_hil_io;

/** Counters of a transport (only grow). */
typedef struct rrr_hil_transport_err {
    uint64_t rx_frames;    ///< frames received
    uint64_t tx_frames;    ///< frames sent
    uint32_t rx_malformed; ///< unparsable input (socketcand line, short read, bad DLC)
    uint32_t tx_dropped;   ///< frames not sent: no peer, or before the peer's first frame
    uint32_t tx_failed;    ///< send errors (ENOBUFS, broken pipe, ...)
    uint32_t bus_off;      ///< bus-off error frames
    uint32_t bus_errors;   ///< other error frames (controller, protocol, restarted)
    uint32_t disconnects;  ///< peers lost
    uint32_t connects;     ///< sessions started (server: handshakes completed; client: connected)
    uint32_t refused;      ///< server: connections refused with "< error ... >" (a session exists
                           ///< or is over, too many handshakes at once, another client won)
    uint32_t handshake_timeouts; ///< server: connections closed for not finishing the handshake
    uint32_t idle_timeouts; ///< server: sessions ended because the client stopped talking
} rrr_hil_transport_err;

typedef struct rrr_hil_transport rrr_hil_transport;
struct rrr_hil_framelog;

/** Implementation hooks. */
typedef struct rrr_hil_transport_vt {
    rrr_hil_io (*send)(rrr_hil_transport *t, const rrr_hil_frame *f);
    rrr_hil_io (*recv)(rrr_hil_transport *t, rrr_hil_frame *f, int timeout_us);
    void (*close)(rrr_hil_transport *t);
} rrr_hil_transport_vt;

/** Base of every transport (first member of each implementation's struct). */
struct rrr_hil_transport {
    const rrr_hil_transport_vt *vt; ///< implementation; NULL once closed
    const char *name;               ///< "socketcan", "socketcan-fd" (CAN FD) or "socketcand"
    rrr_hil_transport_err err;      ///< counters
    char last_error[200];           ///< text of the last error, "" if none
    struct rrr_hil_framelog *framelog; ///< every frame sent or received is logged here (NULL:
                                    ///< none; set after open, which clears the struct)
};

/** Send one frame (logged in framelog when it went out: a server's frame dropped before its
 *  client's first frame is not). */
rrr_hil_io rrr_hil_send(rrr_hil_transport *t, const rrr_hil_frame *f);
/** Receive one frame (logged in framelog); timeout_us < 0 blocks, 0 polls. */
rrr_hil_io rrr_hil_recv(rrr_hil_transport *t, rrr_hil_frame *f, int timeout_us);
/** Close (idempotent). socketcand: a lingering close (our FIN, then the peer's data is read away
 *  until it closes, at most 500 ms), so the peer reads our last frames rather than a reset. */
void rrr_hil_close(rrr_hil_transport *t);
/** Static name of an io code. */
const char *rrr_hil_io_str(rrr_hil_io io);

/* ---- SocketCAN ------------------------------------------------------------------------------- */

/** A raw CAN socket. */
typedef struct rrr_hil_socketcan {
    rrr_hil_transport base; ///< must be first
    int fd;                 ///< socket, -1 when closed
    int can_fd;             ///< 1: CAN FD mode (rrr_hil_socketcan_enable_fd), 0: classical
} rrr_hil_socketcan;

/** Bytes of the largest frame read from or written to a raw CAN socket (struct canfd_frame). */
#define RRR_HIL_SC_WIRE_MAX 72u

/** What one read() from a raw CAN socket held (rrr_hil_sc_from_wire). */
typedef enum rrr_hil_sc_wire {
    RRR_HIL_SC_FRAME = 0,    ///< a data frame of the bus's format: converted
    RRR_HIL_SC_ERROR_FRAME,  ///< an error frame (CAN_ERR_FLAG, classical length): not converted
    RRR_HIL_SC_MALFORMED,    ///< a length that is neither 16 nor 72 bytes, a classical DLC > 8,
                             ///< an FD frame of more than 8 data bytes (no bench frame has them),
                             ///< a remote frame, an error flag on an FD frame
    RRR_HIL_SC_WRONG_FORMAT  ///< a classical frame on a CAN FD bench, or an FD frame on a
                             ///< classical one
} rrr_hil_sc_wire;

/**
 * @brief The bytes to write() for frame @p f: a struct can_frame (16 bytes), or in CAN FD mode
 *        (@p can_fd) a struct canfd_frame (72 bytes) with CANFD_FDF and, with @p brs,
 *        CANFD_BRS (bit-rate switch). Pure (unit-tested).
 * @param[out] wire at least RRR_HIL_SC_WIRE_MAX bytes; unused bytes are 0
 * @return the number of bytes to write, 0 when f->dlc > 8 (nothing to send)
 */
unsigned rrr_hil_sc_to_wire(const rrr_hil_frame *f, int can_fd, int brs, unsigned char *wire);

/**
 * @brief The frame in the @p got bytes a read() returned, for a socket in classical or CAN FD
 *        mode (@p can_fd). A classical socket never receives FD frames from the kernel (it
 *        drops them), an FD socket receives both formats: a frame of the other format is
 *        RRR_HIL_SC_WRONG_FORMAT, so a CAN FD bench acts only on CAN FD frames. Pure.
 * @param[out] f the frame (only for RRR_HIL_SC_FRAME; bytes beyond its dlc are 0)
 * @param[out] brs its bit-rate switch flag (may be NULL)
 */
rrr_hil_sc_wire rrr_hil_sc_from_wire(const unsigned char *wire, long got, int can_fd,
                                     rrr_hil_frame *f, int *brs);

/**
 * @brief Open a raw CAN socket on interface @p ifname, receiving only @p ids (n_ids of them, exact
 *        11-bit match; n_ids = 0: everything) plus bus-off, controller and restart error frames.
 * @return 0, or -1 with t->base.last_error set (e.g. "socket(PF_CAN, SOCK_RAW, CAN_RAW): Address
 *         family not supported by protocol (errno 97): this kernel has no SocketCAN; use the
 *         socketcand transport") and the socket closed.
 */
int rrr_hil_socketcan_open(rrr_hil_socketcan *t, const char *ifname, const uint32_t *ids,
                           unsigned n_ids);

/**
 * @brief Switch an open socket to CAN FD (setsockopt CAN_RAW_FD_FRAMES): from then on it sends
 *        every frame as a CAN FD frame with bit-rate switch (same identifier and data), and drops
 *        the classical frames it receives, counting them in rx_malformed; its name becomes
 *        "socketcan-fd".
 * @param ifname the interface the socket is bound to: its MTU must be CANFD_MTU (72).
 * @return 0, or -1 with last_error set (e.g. "socketcan: vcan0 is not a CAN FD interface (MTU
 *         16, CAN FD needs 72: ip link set vcan0 mtu 72)") and the socket closed.
 */
int rrr_hil_socketcan_enable_fd(rrr_hil_socketcan *t, const char *ifname);

/* ---- socketcand (TCP, ASCII) --------------------------------------------------------------- */

/** Maximum length of one socketcand message "< ... >" we accept. */
#define RRR_HIL_SCD_MAX_LINE 256
/** Default handshake timeout of a server, ms: a connection must complete `< open CHANNEL >` and
 *  `< rawmode >` within this time after it was accepted, else it gets `< error handshake
 *  timeout >` and is closed. */
#define RRR_HIL_SCD_HANDSHAKE_TIMEOUT_MS 2000
/** Default idle timeout, ms. Server: a session whose client sent no well-formed message for
 *  this long gets `< error idle timeout >` and is closed (the session is then over). Both roles:
 *  a send that makes no progress for this long (the peer stopped reading) loses the peer. */
#define RRR_HIL_SCD_IDLE_TIMEOUT_MS 5000
/** Largest accepted timeout, ms (one hour). */
#define RRR_HIL_SCD_TIMEOUT_MAX_MS 3600000
/** Connections a server handshakes with at the same time; the first to finish gets the session. */
#define RRR_HIL_SCD_MAX_PENDING 4

/** A server's connection that has not finished the handshake yet. */
typedef struct rrr_hil_scd_pending {
    int fd;              ///< socket, -1 when the slot is free
    int phase;           ///< 0 wait `< open CHANNEL >`, 1 wait `< rawmode >`
    int64_t deadline_us; ///< CLOCK_MONOTONIC time by which the handshake must be complete, us
    unsigned len;        ///< bytes in buf
    char buf[2 * RRR_HIL_SCD_MAX_LINE]; ///< received bytes not yet parsed
} rrr_hil_scd_pending;

/** The session of a socketcand server: at most one in its lifetime. */
typedef enum rrr_hil_scd_session {
    RRR_HIL_SCD_NO_SESSION = 0, ///< no client finished the handshake yet
    RRR_HIL_SCD_SESSION_ACTIVE, ///< one client holds the session; every other one is refused
    RRR_HIL_SCD_SESSION_OVER    ///< the session ended: every client is refused
} rrr_hil_scd_session;

/** A socketcand-protocol endpoint (server: exactly one session; or client). */
typedef struct rrr_hil_scd {
    rrr_hil_transport base;   ///< must be first
    int server;               ///< 1: server (listens), 0: client
    int listen_fd;            ///< server: listening socket, -1 otherwise
    int fd;                   ///< connection (server: the session's client), -1 when none
    int phase;                ///< server session: 2 raw, 3 peer sent a frame (client: 3)
    uint16_t port;            ///< bound port (server: the real one when 0 was asked)
    char channel[32];         ///< bus name ("bench0")
    char buf[4 * RRR_HIL_SCD_MAX_LINE]; ///< received bytes not yet parsed
    unsigned len;             ///< bytes in buf
    int handshake_timeout_ms; ///< server: see RRR_HIL_SCD_HANDSHAKE_TIMEOUT_MS
    int idle_timeout_ms;      ///< see RRR_HIL_SCD_IDLE_TIMEOUT_MS
    rrr_hil_scd_session session; ///< server: state of its one session
    int64_t last_rx_us;       ///< server: CLOCK_MONOTONIC time of the session's last message, us
    int tx_broken;            ///< server: a send to the session failed; recv delivers what the
                              ///< client had sent, then the session is over
    rrr_hil_scd_pending pending[RRR_HIL_SCD_MAX_PENDING]; ///< server: handshakes in progress
} rrr_hil_scd;

/**
 * @brief Listen on host:port (port 0: any free port, read back in t->port) as a socketcand
 *        server serving bus @p channel, with the default timeouts.
 *
 * Connections are accepted inside recv. Each gets `< hi >`; `< open CHANNEL >` and `< rawmode >`
 * are answered with `< ok >` (a wrong bus with `< error could not open bus >`). Up to
 * RRR_HIL_SCD_MAX_PENDING connections may handshake at once, each within the handshake timeout
 * (one more evicts the oldest with `< error too many clients in handshake >`, so a burst of
 * silent connections cannot keep out a client that handshakes at once); the first to finish
 * gets the server's one session, and from then on every other connection,
 * pending or new, gets `< error ... >` and is closed: an extra client never replaces the first,
 * and a silent one never blocks the bench. The session ends when its client hangs up or sends
 * no message for the idle timeout; after that recv returns RRR_HIL_IO_DISCONNECTED and every
 * newcomer is refused. The server sends no frame before the session's first `< send >`
 * (python-can's handshake reads a single recv() and fails if a frame follows the last `< ok >`
 * in the same segment).
 * @return 0, or -1 with last_error set.
 */
int rrr_hil_scd_listen(rrr_hil_scd *t, const char *host, uint16_t port, const char *channel);

/**
 * @brief Set the handshake and idle timeouts (ms, 1..RRR_HIL_SCD_TIMEOUT_MAX_MS); the client role
 *        uses only the idle timeout (for sends).
 * @return 0, or -1 with last_error set (nothing changed).
 */
int rrr_hil_scd_set_timeouts(rrr_hil_scd *t, int handshake_timeout_ms, int idle_timeout_ms);

/**
 * @brief Connect to a socketcand server at host:port, retrying for up to @p wait_ms, and do the
 *        handshake (open @p channel, rawmode).
 * @return 0, or -1 with last_error set.
 */
int rrr_hil_scd_connect(rrr_hil_scd *t, const char *host, uint16_t port, const char *channel,
                        int wait_ms);

/**
 * @brief Parse one socketcand message ("< send ID DLC B0 .. >" or "< frame ID SEC.USEC HEX >").
 *        Pure (unit-tested and fuzzed).
 * @param[in]  line  the message, from '<' to '>' inclusive, not NUL-terminated
 * @param[in]  n     its length
 * @param[out] f     the frame
 * @return 1 frame parsed, 0 another valid message (kind in *word, e.g. "ok"), -1 malformed
 */
int rrr_hil_scd_parse(const char *line, unsigned n, rrr_hil_frame *f, char word[16]);

#endif /* RRR_HIL_TRANSPORT_H */
