/**
 * @file hil_transport.h
 * @brief How the bench nodes move CAN frames: a small interface (send, receive with a timeout,
 *        close) with two implementations:
 *  - SocketCAN: a raw AF_CAN socket bound to an interface (vcan0, can0), with receive filters and
 *    error frames (bus-off, controller problems) reported as RRR_HIL_IO_BUS_OFF / counted;
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

#include "hil_codec.h"

/** Outcome of a transport call. */
typedef enum rrr_hil_io {
    RRR_HIL_IO_OK = 0,       ///< a frame was sent / received
    RRR_HIL_IO_TIMEOUT,      ///< nothing received before the timeout
    RRR_HIL_IO_DISCONNECTED, ///< the peer closed the connection (TCP); the server accepts again
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
    uint32_t connects;     ///< peers accepted or connected
} rrr_hil_transport_err;

typedef struct rrr_hil_transport rrr_hil_transport;

/** Implementation hooks. */
typedef struct rrr_hil_transport_vt {
    rrr_hil_io (*send)(rrr_hil_transport *t, const rrr_hil_frame *f);
    rrr_hil_io (*recv)(rrr_hil_transport *t, rrr_hil_frame *f, int timeout_us);
    void (*close)(rrr_hil_transport *t);
} rrr_hil_transport_vt;

/** Base of every transport (first member of each implementation's struct). */
struct rrr_hil_transport {
    const rrr_hil_transport_vt *vt; ///< implementation; NULL once closed
    const char *name;               ///< "socketcan" or "socketcand"
    rrr_hil_transport_err err;      ///< counters
    char last_error[200];           ///< text of the last error, "" if none
};

/** Send one frame. */
rrr_hil_io rrr_hil_send(rrr_hil_transport *t, const rrr_hil_frame *f);
/** Receive one frame; timeout_us < 0 blocks, 0 polls. */
rrr_hil_io rrr_hil_recv(rrr_hil_transport *t, rrr_hil_frame *f, int timeout_us);
/** Close (idempotent). */
void rrr_hil_close(rrr_hil_transport *t);
/** Static name of an io code. */
const char *rrr_hil_io_str(rrr_hil_io io);

/* ---- SocketCAN ------------------------------------------------------------------------------- */

/** A raw CAN socket. */
typedef struct rrr_hil_socketcan {
    rrr_hil_transport base; ///< must be first
    int fd;                 ///< socket, -1 when closed
} rrr_hil_socketcan;

/**
 * @brief Open a raw CAN socket on interface @p ifname, receiving only @p ids (n_ids of them, exact
 *        11-bit match; n_ids = 0: everything) plus bus-off, controller and restart error frames.
 * @return 0, or -1 with t->base.last_error set (e.g. "socket(PF_CAN, SOCK_RAW, CAN_RAW): Address
 *         family not supported by protocol (errno 97): this kernel has no SocketCAN; use the
 *         socketcand transport") and the socket closed.
 */
int rrr_hil_socketcan_open(rrr_hil_socketcan *t, const char *ifname, const uint32_t *ids,
                           unsigned n_ids);

/* ---- socketcand (TCP, ASCII) --------------------------------------------------------------- */

/** Maximum length of one socketcand message "< ... >" we accept. */
#define RRR_HIL_SCD_MAX_LINE 256

/** A socketcand-protocol endpoint (server: one client at a time; or client). */
typedef struct rrr_hil_scd {
    rrr_hil_transport base;   ///< must be first
    int server;               ///< 1: server (listens), 0: client
    int listen_fd;            ///< server: listening socket, -1 otherwise
    int fd;                   ///< connection, -1 when none
    int phase;                ///< server handshake: 0 wait open, 1 wait rawmode, 2 raw, 3 peer sent a frame
    uint16_t port;            ///< bound port (server: the real one when 0 was asked)
    char channel[32];         ///< bus name ("bench0")
    char buf[4 * RRR_HIL_SCD_MAX_LINE]; ///< received bytes not yet parsed
    unsigned len;             ///< bytes in buf
} rrr_hil_scd;

/**
 * @brief Listen on host:port (port 0: any free port, read back in t->port) as a socketcand
 *        server serving bus @p channel. A client is accepted inside recv (one at a time); the
 *        server sends `< hi >`, accepts `< open CHANNEL >` and `< rawmode >` with `< ok >`, and
 *        sends no frame before the client's first `< send >` (python-can's handshake reads a
 *        single recv() and fails if a frame follows the last `< ok >` in the same segment).
 * @return 0, or -1 with last_error set.
 */
int rrr_hil_scd_listen(rrr_hil_scd *t, const char *host, uint16_t port, const char *channel);

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
