/* Dispatch of the transport interface, and the SocketCAN implementation (raw AF_CAN socket). */
#define _DEFAULT_SOURCE /* struct ifreq, IFNAMSIZ (net/if.h); implies POSIX.1-2008 */

#include "hil_transport.h"
#include "hil_framelog.h"

#include <errno.h>
#include <linux/can.h>
#include <linux/can/error.h>
#include <linux/can/raw.h>
#include <net/if.h>
#include <poll.h>
#include <stdio.h>
#include <string.h>
#include <sys/ioctl.h>
#include <sys/socket.h>
#include <unistd.h>

rrr_hil_io rrr_hil_send(rrr_hil_transport *t, const rrr_hil_frame *f)
{
    if (t->vt == NULL) {
        snprintf(t->last_error, sizeof t->last_error, "%s: send on a closed transport",
                 t->name ? t->name : "transport");
        return RRR_HIL_IO_ERROR;
    }
    const uint64_t sent = t->err.tx_frames;
    const rrr_hil_io io = t->vt->send(t, f);
    if (io == RRR_HIL_IO_OK && t->err.tx_frames != sent) {
        rrr_hil_framelog_put(t->framelog, f, RRR_HIL_FRAME_TX);
    }
    return io;
}

rrr_hil_io rrr_hil_recv(rrr_hil_transport *t, rrr_hil_frame *f, int timeout_us)
{
    if (t->vt == NULL) {
        snprintf(t->last_error, sizeof t->last_error, "%s: recv on a closed transport",
                 t->name ? t->name : "transport");
        return RRR_HIL_IO_ERROR;
    }
    const rrr_hil_io io = t->vt->recv(t, f, timeout_us);
    if (io == RRR_HIL_IO_OK) {
        rrr_hil_framelog_put(t->framelog, f, RRR_HIL_FRAME_RX);
    }
    return io;
}

void rrr_hil_close(rrr_hil_transport *t)
{
    if (t->vt != NULL) {
        t->vt->close(t);
        t->vt = NULL;
    }
}

const char *rrr_hil_io_str(rrr_hil_io io)
{
    switch (io) {
    case RRR_HIL_IO_OK:
        return "ok";
    case RRR_HIL_IO_TIMEOUT:
        return "timeout";
    case RRR_HIL_IO_DISCONNECTED:
        return "disconnected";
    case RRR_HIL_IO_BUS_OFF:
        return "bus-off";
    case RRR_HIL_IO_ERROR:
    default:
        return "error";
    }
}

/* ---- SocketCAN ------------------------------------------------------------------------------- */

static void sc_error(rrr_hil_socketcan *t, const char *what, int e)
{
    snprintf(t->base.last_error, sizeof t->base.last_error, "socketcan: %s: %s (errno %d)%s", what,
             strerror(e), e,
             e == EAFNOSUPPORT ? ": this kernel has no SocketCAN (AF_CAN); use the socketcand "
                                 "transport (--listen / --connect)"
                               : "");
}

unsigned rrr_hil_sc_to_wire(const rrr_hil_frame *f, int can_fd, int brs, unsigned char *wire)
{
    memset(wire, 0, RRR_HIL_SC_WIRE_MAX);
    if (f->dlc > 8u) {
        return 0u;
    }
    struct canfd_frame cf; /* its first 16 bytes are a struct can_frame's layout */
    memset(&cf, 0, sizeof cf);
    cf.can_id = f->extended ? (f->id & CAN_EFF_MASK) | CAN_EFF_FLAG : f->id & CAN_SFF_MASK;
    cf.len = f->dlc;
    if (can_fd) {
        cf.flags = (uint8_t)(CANFD_FDF | (brs ? CANFD_BRS : 0));
    }
    memcpy(cf.data, f->data, f->dlc);
    memcpy(wire, &cf, sizeof cf);
    return can_fd ? (unsigned)CANFD_MTU : (unsigned)CAN_MTU;
}

rrr_hil_sc_wire rrr_hil_sc_from_wire(const unsigned char *wire, long got, int can_fd,
                                     rrr_hil_frame *f, int *brs)
{
    if (got != (long)CAN_MTU && got != (long)CANFD_MTU) {
        return RRR_HIL_SC_MALFORMED;
    }
    struct canfd_frame cf;
    memset(&cf, 0, sizeof cf);
    memcpy(&cf, wire, (size_t)got);
    const int is_fd = got == (long)CANFD_MTU;
    if (!is_fd && (cf.can_id & CAN_ERR_FLAG)) {
        return RRR_HIL_SC_ERROR_FRAME;
    }
    /* an FD frame is one of CANFD_MTU bytes (kernels before 6.0 do not set CANFD_FDF on
     * receive) */
    if ((cf.can_id & (CAN_RTR_FLAG | CAN_ERR_FLAG)) != 0u || cf.len > 8u) {
        return RRR_HIL_SC_MALFORMED;
    }
    if (is_fd != (can_fd != 0)) {
        return RRR_HIL_SC_WRONG_FORMAT;
    }
    memset(f, 0, sizeof *f);
    f->extended = (cf.can_id & CAN_EFF_FLAG) != 0u;
    f->id = cf.can_id & (f->extended ? CAN_EFF_MASK : CAN_SFF_MASK);
    f->dlc = cf.len;
    memcpy(f->data, cf.data, cf.len);
    if (brs != NULL) {
        *brs = is_fd && (cf.flags & CANFD_BRS) != 0u;
    }
    return RRR_HIL_SC_FRAME;
}

static rrr_hil_io sc_send(rrr_hil_transport *base, const rrr_hil_frame *f)
{
    rrr_hil_socketcan *t = (rrr_hil_socketcan *)base;
    unsigned char wire[RRR_HIL_SC_WIRE_MAX];
    const unsigned n = rrr_hil_sc_to_wire(f, t->can_fd, 1, wire);
    if (n == 0u) {
        ++t->base.err.tx_failed;
        return RRR_HIL_IO_ERROR;
    }
    const ssize_t w = write(t->fd, wire, n);
    if (w != (ssize_t)n) {
        ++t->base.err.tx_failed;
        sc_error(t, "write", w < 0 ? errno : EIO);
        return (w < 0 && errno == ENETDOWN) ? RRR_HIL_IO_BUS_OFF : RRR_HIL_IO_ERROR;
    }
    ++t->base.err.tx_frames;
    return RRR_HIL_IO_OK;
}

static rrr_hil_io sc_recv(rrr_hil_transport *base, rrr_hil_frame *f, int timeout_us)
{
    rrr_hil_socketcan *t = (rrr_hil_socketcan *)base;
    for (;;) {
        struct pollfd pfd = {.fd = t->fd, .events = POLLIN};
        const int pr = poll(&pfd, 1, timeout_us < 0 ? -1 : (timeout_us + 999) / 1000);
        if (pr < 0 && errno == EINTR) {
            continue;
        }
        if (pr < 0) {
            sc_error(t, "poll", errno);
            return RRR_HIL_IO_ERROR;
        }
        if (pr == 0) {
            return RRR_HIL_IO_TIMEOUT;
        }
        unsigned char wire[RRR_HIL_SC_WIRE_MAX];
        const ssize_t got = read(t->fd, wire, sizeof wire);
        if (got < 0) {
            sc_error(t, "read", errno);
            return errno == ENETDOWN ? RRR_HIL_IO_BUS_OFF : RRR_HIL_IO_ERROR;
        }
        switch (rrr_hil_sc_from_wire(wire, (long)got, t->can_fd, f, NULL)) {
        case RRR_HIL_SC_FRAME:
            ++t->base.err.rx_frames;
            return RRR_HIL_IO_OK;
        case RRR_HIL_SC_ERROR_FRAME: {
            canid_t id;
            memcpy(&id, wire, sizeof id);
            if (id & CAN_ERR_BUSOFF) {
                ++t->base.err.bus_off;
                snprintf(t->base.last_error, sizeof t->base.last_error, "socketcan: bus-off");
                return RRR_HIL_IO_BUS_OFF;
            }
            ++t->base.err.bus_errors;
            continue;
        }
        case RRR_HIL_SC_MALFORMED:
        case RRR_HIL_SC_WRONG_FORMAT:
        default:
            ++t->base.err.rx_malformed;
            continue;
        }
    }
}

static void sc_close(rrr_hil_transport *base)
{
    rrr_hil_socketcan *t = (rrr_hil_socketcan *)base;
    if (t->fd >= 0) {
        close(t->fd);
        t->fd = -1;
    }
}

static const rrr_hil_transport_vt sc_vt = {sc_send, sc_recv, sc_close};

#define RRR_HIL_MAX_FILTERS 16u

int rrr_hil_socketcan_open(rrr_hil_socketcan *t, const char *ifname, const uint32_t *ids,
                           unsigned n_ids)
{
    memset(t, 0, sizeof *t);
    t->base.name = "socketcan";
    t->fd = -1;
    if (ifname == NULL || strlen(ifname) == 0u || strlen(ifname) >= IFNAMSIZ) {
        snprintf(t->base.last_error, sizeof t->base.last_error,
                 "socketcan: bad interface name (1..%d characters)", IFNAMSIZ - 1);
        return -1;
    }
    if (n_ids > RRR_HIL_MAX_FILTERS) {
        snprintf(t->base.last_error, sizeof t->base.last_error,
                 "socketcan: %u filters, at most %u", n_ids, RRR_HIL_MAX_FILTERS);
        return -1;
    }
    t->fd = socket(PF_CAN, SOCK_RAW, CAN_RAW);
    if (t->fd < 0) {
        sc_error(t, "socket(PF_CAN, SOCK_RAW, CAN_RAW)", errno);
        return -1;
    }
    struct ifreq ifr;
    memset(&ifr, 0, sizeof ifr);
    memcpy(ifr.ifr_name, ifname, strlen(ifname));
    if (ioctl(t->fd, SIOCGIFINDEX, &ifr) != 0) {
        char what[64];
        snprintf(what, sizeof what, "SIOCGIFINDEX(%s)", ifname);
        sc_error(t, what, errno);
        sc_close(&t->base);
        return -1;
    }
    struct can_filter filters[RRR_HIL_MAX_FILTERS];
    for (unsigned i = 0; i < n_ids; ++i) {
        filters[i].can_id = ids[i] & CAN_SFF_MASK;
        filters[i].can_mask = CAN_SFF_MASK | CAN_EFF_FLAG | CAN_RTR_FLAG;
    }
    const can_err_mask_t err_mask = CAN_ERR_BUSOFF | CAN_ERR_CRTL | CAN_ERR_RESTARTED;
    if ((n_ids > 0u && setsockopt(t->fd, SOL_CAN_RAW, CAN_RAW_FILTER, filters,
                                  (socklen_t)(n_ids * sizeof filters[0])) != 0) ||
        setsockopt(t->fd, SOL_CAN_RAW, CAN_RAW_ERR_FILTER, &err_mask, sizeof err_mask) != 0) {
        sc_error(t, "setsockopt(CAN_RAW_FILTER / CAN_RAW_ERR_FILTER)", errno);
        sc_close(&t->base);
        return -1;
    }
    struct sockaddr_can addr;
    memset(&addr, 0, sizeof addr);
    addr.can_family = AF_CAN;
    addr.can_ifindex = ifr.ifr_ifindex;
    if (bind(t->fd, (struct sockaddr *)&addr, sizeof addr) != 0) {
        sc_error(t, "bind", errno);
        sc_close(&t->base);
        return -1;
    }
    t->base.vt = &sc_vt;
    return 0;
}

int rrr_hil_socketcan_enable_fd(rrr_hil_socketcan *t, const char *ifname)
{
    if (t->base.vt == NULL || t->fd < 0) {
        snprintf(t->base.last_error, sizeof t->base.last_error,
                 "socketcan: CAN FD on a socket that is not open");
        return -1;
    }
    struct ifreq ifr;
    memset(&ifr, 0, sizeof ifr);
    if (ifname == NULL || strlen(ifname) == 0u || strlen(ifname) >= IFNAMSIZ) {
        snprintf(t->base.last_error, sizeof t->base.last_error,
                 "socketcan: bad interface name (1..%d characters)", IFNAMSIZ - 1);
        rrr_hil_close(&t->base);
        return -1;
    }
    memcpy(ifr.ifr_name, ifname, strlen(ifname));
    if (ioctl(t->fd, SIOCGIFMTU, &ifr) != 0) {
        char what[64];
        snprintf(what, sizeof what, "SIOCGIFMTU(%s)", ifname);
        sc_error(t, what, errno);
        rrr_hil_close(&t->base);
        return -1;
    }
    if (ifr.ifr_mtu != (int)CANFD_MTU) {
        snprintf(t->base.last_error, sizeof t->base.last_error,
                 "socketcan: %s is not a CAN FD interface (MTU %d, CAN FD needs %u: ip link set "
                 "%s mtu %u)", ifname, ifr.ifr_mtu, (unsigned)CANFD_MTU, ifname,
                 (unsigned)CANFD_MTU);
        rrr_hil_close(&t->base);
        return -1;
    }
    const int on = 1;
    if (setsockopt(t->fd, SOL_CAN_RAW, CAN_RAW_FD_FRAMES, &on, sizeof on) != 0) {
        sc_error(t, "setsockopt(CAN_RAW_FD_FRAMES)", errno);
        rrr_hil_close(&t->base);
        return -1;
    }
    t->can_fd = 1;
    t->base.name = "socketcan-fd";
    return 0;
}
