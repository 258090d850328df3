/* The SocketCAN transport's frame conversion (rrr_hil_sc_to_wire / rrr_hil_sc_from_wire), which
 * needs no kernel CAN stack: the bytes written for classical and CAN FD frames (flags, lengths,
 * identifiers), the round trip, and what a read may hold that is not a bench frame: a wrong
 * length, a DLC > 8, an FD frame of more than 8 bytes, a remote frame, an error frame, and a
 * frame of the other format (a classical frame on a CAN FD bench and vice versa). */
#include <linux/can.h>
#include <string.h>

#include "hil_codec.h"
#include "hil_transport.h"
#include "rrr_test.h"

static struct canfd_frame as_fd(const unsigned char *wire)
{
    struct canfd_frame cf;
    memcpy(&cf, wire, sizeof cf);
    return cf;
}

int main(void)
{
    unsigned char wire[RRR_HIL_SC_WIRE_MAX];
    rrr_hil_frame f = {0x100, 0, 8, {1, 2, 3, 4, 5, 6, 7, 8}}, g;
    int brs = -1;

    /* the bench's VoltageCmd as the codec encodes it, classical and CAN FD */
    rrr_hil_voltage_cmd cmd = {.counter = 5, .enable = 1, .reset_fault = 0,
                               .u_V = {1.25, -3.5, 0.001}};
    CHECK(rrr_hil_encode_voltage_cmd(&cmd, &f) == 0);
    CHECK(f.id == 0x100 && f.dlc == 8);

    CHECK(rrr_hil_sc_to_wire(&f, 0, 1, wire) == CAN_MTU); /* classical: brs ignored */
    struct canfd_frame cf = as_fd(wire);
    CHECK(cf.can_id == 0x100 && cf.len == 8 && cf.flags == 0);
    CHECK(memcmp(cf.data, f.data, 8) == 0);
    CHECK(rrr_hil_sc_from_wire(wire, CAN_MTU, 0, &g, &brs) == RRR_HIL_SC_FRAME);
    CHECK(memcmp(&g, &f, sizeof g) == 0 && brs == 0);

    CHECK(rrr_hil_sc_to_wire(&f, 1, 1, wire) == CANFD_MTU);
    cf = as_fd(wire);
    CHECK(cf.can_id == 0x100 && cf.len == 8 && cf.flags == (CANFD_FDF | CANFD_BRS));
    CHECK(memcmp(cf.data, f.data, 8) == 0);
    for (unsigned i = 8; i < CANFD_MAX_DLEN; ++i) {
        CHECK(cf.data[i] == 0);
    }
    CHECK(rrr_hil_sc_from_wire(wire, CANFD_MTU, 1, &g, &brs) == RRR_HIL_SC_FRAME);
    CHECK(memcmp(&g, &f, sizeof g) == 0 && brs == 1);
    rrr_hil_voltage_cmd back;
    rrr_hil_msg m;
    CHECK(rrr_hil_decode(&g, &m) == RRR_HIL_RX_OK && m.kind == RRR_HIL_VOLTAGE_CMD);
    back = m.u.cmd;
    CHECK(back.counter == 5 && back.enable == 1 && back.u_V[1] == cmd.u_V[1]);

    CHECK(rrr_hil_sc_to_wire(&f, 1, 0, wire) == CANFD_MTU); /* without bit-rate switch */
    CHECK(as_fd(wire).flags == CANFD_FDF);
    CHECK(rrr_hil_sc_from_wire(wire, CANFD_MTU, 1, &g, &brs) == RRR_HIL_SC_FRAME && brs == 0);

    /* extended identifiers and short frames keep their flag and length */
    rrr_hil_frame e = {0x1ABCDEF, 1, 3, {9, 8, 7}};
    CHECK(rrr_hil_sc_to_wire(&e, 1, 1, wire) == CANFD_MTU);
    CHECK(as_fd(wire).can_id == (0x1ABCDEFu | CAN_EFF_FLAG));
    CHECK(rrr_hil_sc_from_wire(wire, CANFD_MTU, 1, &g, NULL) == RRR_HIL_SC_FRAME);
    CHECK(g.extended == 1 && g.id == 0x1ABCDEF && g.dlc == 3 && g.data[2] == 7 && g.data[3] == 0);

    /* a frame the codec cannot send: nothing to write */
    rrr_hil_frame big = f;
    big.dlc = 9;
    CHECK(rrr_hil_sc_to_wire(&big, 0, 1, wire) == 0);
    CHECK(rrr_hil_sc_to_wire(&big, 1, 1, wire) == 0);

    /* the other format: an FD frame on a classical bench, a classical one on an FD bench */
    CHECK(rrr_hil_sc_to_wire(&f, 1, 1, wire) == CANFD_MTU);
    CHECK(rrr_hil_sc_from_wire(wire, CANFD_MTU, 0, &g, NULL) == RRR_HIL_SC_WRONG_FORMAT);
    CHECK(rrr_hil_sc_to_wire(&f, 0, 1, wire) == CAN_MTU);
    CHECK(rrr_hil_sc_from_wire(wire, CAN_MTU, 1, &g, NULL) == RRR_HIL_SC_WRONG_FORMAT);

    /* wrong lengths of a read: neither CAN_MTU nor CANFD_MTU */
    const long bad_len[] = {-1, 0, 1, 8, CAN_MTU - 1, CAN_MTU + 1, 64, CANFD_MTU - 1};
    for (size_t i = 0; i < sizeof bad_len / sizeof bad_len[0]; ++i) {
        CHECK(rrr_hil_sc_from_wire(wire, bad_len[i], 0, &g, NULL) == RRR_HIL_SC_MALFORMED);
        CHECK(rrr_hil_sc_from_wire(wire, bad_len[i], 1, &g, NULL) == RRR_HIL_SC_MALFORMED);
    }

    /* an FD frame with more than 8 data bytes (no bench frame has them), a classical DLC > 8 */
    memset(&cf, 0, sizeof cf);
    cf.can_id = 0x100;
    cf.flags = CANFD_FDF | CANFD_BRS;
    cf.len = 12;
    memcpy(wire, &cf, sizeof cf);
    CHECK(rrr_hil_sc_from_wire(wire, CANFD_MTU, 1, &g, NULL) == RRR_HIL_SC_MALFORMED);
    cf.len = 64;
    memcpy(wire, &cf, sizeof cf);
    CHECK(rrr_hil_sc_from_wire(wire, CANFD_MTU, 1, &g, NULL) == RRR_HIL_SC_MALFORMED);
    cf.len = 255;
    memcpy(wire, &cf, sizeof cf);
    CHECK(rrr_hil_sc_from_wire(wire, CANFD_MTU, 1, &g, NULL) == RRR_HIL_SC_MALFORMED);
    struct can_frame cc;
    memset(&cc, 0, sizeof cc);
    memset(wire, 0, sizeof wire);
    cc.can_id = 0x100;
    cc.can_dlc = 9;
    memcpy(wire, &cc, sizeof cc);
    CHECK(rrr_hil_sc_from_wire(wire, CAN_MTU, 0, &g, NULL) == RRR_HIL_SC_MALFORMED);

    /* an FD frame as older kernels deliver it (no CANFD_FDF on receive) is an FD frame */
    memset(&cf, 0, sizeof cf);
    cf.can_id = 0x080;
    cf.len = 4;
    cf.flags = CANFD_BRS;
    memcpy(wire, &cf, sizeof cf);
    CHECK(rrr_hil_sc_from_wire(wire, CANFD_MTU, 1, &g, &brs) == RRR_HIL_SC_FRAME && brs == 1);
    CHECK(g.id == 0x080 && g.dlc == 4);

    /* remote frames (both formats' lengths) and error frames */
    memset(wire, 0, sizeof wire);
    cc.can_id = 0x100 | CAN_RTR_FLAG;
    cc.can_dlc = 8;
    memcpy(wire, &cc, sizeof cc);
    CHECK(rrr_hil_sc_from_wire(wire, CAN_MTU, 0, &g, NULL) == RRR_HIL_SC_MALFORMED);
    CHECK(rrr_hil_sc_from_wire(wire, CAN_MTU, 1, &g, NULL) == RRR_HIL_SC_MALFORMED);
    cc.can_id = CAN_ERR_FLAG | 0x40u; /* CAN_ERR_BUSOFF */
    memcpy(wire, &cc, sizeof cc);
    CHECK(rrr_hil_sc_from_wire(wire, CAN_MTU, 0, &g, NULL) == RRR_HIL_SC_ERROR_FRAME);
    CHECK(rrr_hil_sc_from_wire(wire, CAN_MTU, 1, &g, NULL) == RRR_HIL_SC_ERROR_FRAME);
    memset(&cf, 0, sizeof cf); /* an error flag on a frame of FD length: not an error frame */
    cf.can_id = CAN_ERR_FLAG | 0x40u;
    memcpy(wire, &cf, sizeof cf);
    CHECK(rrr_hil_sc_from_wire(wire, CANFD_MTU, 1, &g, NULL) == RRR_HIL_SC_MALFORMED);

    /* CAN FD on a socket that is not open is refused with a message, no system call */
    rrr_hil_socketcan t;
    memset(&t, 0, sizeof t);
    t.fd = -1;
    CHECK(rrr_hil_socketcan_enable_fd(&t, "vcan1") == -1);
    CHECK(strstr(t.base.last_error, "not open") != NULL);
    return rrr_test_report("test_hil_sc_wire");
}
