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
    return rrr_test_report("test_hil_socketcan");
}
