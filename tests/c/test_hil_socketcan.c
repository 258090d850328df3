/* The SocketCAN transport down to the socket call. Where the kernel has no AF_CAN (this CI) the
 * open fails with a message that names the cause and the alternative; where AF_CAN exists but
 * there is no vcan0, it names the interface; where vcan0 exists, a frame goes round trip through
 * two sockets (CAN_RAW loopback). Bad arguments are refused before any system call. */
#define _POSIX_C_SOURCE 200809L

#include <errno.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "hil_transport.h"
#include "rrr_test.h"

#ifndef AF_CAN
#define AF_CAN 29
#endif

int main(void)
{
    rrr_hil_socketcan t;
    CHECK(rrr_hil_socketcan_open(&t, "", NULL, 0) == -1);
    CHECK(strstr(t.base.last_error, "bad interface name") != NULL);
    CHECK(rrr_hil_socketcan_open(&t, "an-interface-name-too-long", NULL, 0) == -1);
    const uint32_t ids[17] = {0};
    CHECK(rrr_hil_socketcan_open(&t, "vcan0", ids, 17) == -1);
    CHECK(strstr(t.base.last_error, "filters") != NULL);

    const int probe = socket(AF_CAN, SOCK_RAW, 1);
    const int have_af_can = probe >= 0;
    if (probe >= 0) {
        close(probe);
    }
    const uint32_t rx[] = {0x100, 0x080};
    const int rc = rrr_hil_socketcan_open(&t, "vcan0", rx, 2);
    printf("socketcan open(vcan0): %s\n", rc == 0 ? "ok" : t.base.last_error);
    if (!have_af_can) {
        CHECK(rc == -1);
        CHECK(strstr(t.base.last_error, "socket(PF_CAN, SOCK_RAW, CAN_RAW)") != NULL);
        CHECK(strstr(t.base.last_error, "use the socketcand transport") != NULL);
        CHECK(t.fd == -1);
        rrr_hil_frame f = {0x100, 0, 1, {0}};
        CHECK(rrr_hil_send(&t.base, &f) == RRR_HIL_IO_ERROR); /* closed: refused, no crash */
        CHECK(rrr_hil_recv(&t.base, &f, 0) == RRR_HIL_IO_ERROR);
    } else if (rc != 0) {
        CHECK(strstr(t.base.last_error, "vcan0") != NULL);
    } else {
        rrr_hil_socketcan peer;
        CHECK(rrr_hil_socketcan_open(&peer, "vcan0", NULL, 0) == 0);
        rrr_hil_frame f = {0x100, 0, 8, {1, 2, 3, 4, 5, 6, 7, 8}}, g;
        CHECK(rrr_hil_send(&peer.base, &f) == RRR_HIL_IO_OK);
        CHECK(rrr_hil_recv(&t.base, &g, 1000000) == RRR_HIL_IO_OK);
        CHECK(g.id == 0x100 && g.dlc == 8 && memcmp(g.data, f.data, 8) == 0);
        f.id = 0x300; /* filtered out */
        CHECK(rrr_hil_send(&peer.base, &f) == RRR_HIL_IO_OK);
        CHECK(rrr_hil_recv(&t.base, &g, 100000) == RRR_HIL_IO_TIMEOUT);
        rrr_hil_close(&peer.base);
        rrr_hil_close(&t.base);
    }
    rrr_hil_close(&t.base);
    if (have_af_can && rc == 0) {
        /* CAN FD: vcan0 (MTU 16) refuses it; on vcan1 (MTU 72) an FD frame goes round trip and a
         * classical frame is dropped and counted by the FD socket (the CAN test guest has both) */
        rrr_hil_socketcan a, b, c;
        CHECK(rrr_hil_socketcan_open(&a, "vcan0", NULL, 0) == 0);
        CHECK(rrr_hil_socketcan_enable_fd(&a, "vcan0") == -1);
        CHECK(strstr(a.base.last_error, "not a CAN FD interface (MTU 16") != NULL);
        CHECK(a.fd == -1);
        rrr_hil_close(&a.base);
        if (rrr_hil_socketcan_open(&a, "vcan1", rx, 2) == 0) {
            printf("socketcan: CAN FD on vcan1\n");
            CHECK(rrr_hil_socketcan_enable_fd(&a, "vcan1") == 0);
            CHECK(strcmp(a.base.name, "socketcan-fd") == 0);
            CHECK(rrr_hil_socketcan_open(&b, "vcan1", NULL, 0) == 0);
            CHECK(rrr_hil_socketcan_enable_fd(&b, "vcan1") == 0);
            CHECK(rrr_hil_socketcan_open(&c, "vcan1", NULL, 0) == 0); /* classical */
            rrr_hil_frame f = {0x100, 0, 8, {1, 2, 3, 4, 5, 6, 7, 8}}, g;
            CHECK(rrr_hil_send(&c.base, &f) == RRR_HIL_IO_OK);     /* classical: dropped */
            CHECK(rrr_hil_recv(&a.base, &g, 100000) == RRR_HIL_IO_TIMEOUT);
            CHECK(a.base.err.rx_malformed == 1 && a.base.err.rx_frames == 0);
            f.data[0] = 42;
            CHECK(rrr_hil_send(&b.base, &f) == RRR_HIL_IO_OK);     /* FD: delivered */
            CHECK(rrr_hil_recv(&a.base, &g, 1000000) == RRR_HIL_IO_OK);
            CHECK(g.id == 0x100 && g.dlc == 8 && memcmp(g.data, f.data, 8) == 0);
            CHECK(rrr_hil_recv(&c.base, &g, 100000) == RRR_HIL_IO_TIMEOUT); /* the kernel keeps
                                                                  FD frames from classical sockets */
            rrr_hil_close(&c.base);
            rrr_hil_close(&b.base);
            rrr_hil_close(&a.base);
        }
    }
    return rrr_test_report("test_hil_socketcan");
}
