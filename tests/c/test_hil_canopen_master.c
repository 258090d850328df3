/* The CANopen master's frames (hil_canopen_master.h) against the slave core (hil_canopen.h):
 * NMT, expedited SDO downloads and uploads and their aborts, a segmented answer refused, the 402
 * state machine driven by the master's controlwords, RPDO1 + SYNC and the TPDOs decoded (which
 * TPDO a frame is, their mapped length), EMCY, the target-torque rounding and the argument
 * checks. */
#include <math.h>
#include <string.h>

#include "hil_canopen.h"
#include "hil_canopen_master.h"
#include "rrr_test.h"

#define ID 3u
#define RATED 47000u /* mN m */

static rrr_co_out out;

/* Feed one master frame to the slave; the slave's answer, if exactly one, into *reply. */
static int exchange(rrr_co_node *n, const rrr_hil_frame *f, rrr_hil_frame *reply)
{
    out.n = 0;
    rrr_co_on_frame(n, f, &out);
    if (out.n >= 1u && reply != NULL) {
        *reply = out.f[0];
    }
    return (int)out.n;
}

static rrr_com_sdo_answer sdo(rrr_co_node *n, uint16_t index, uint8_t sub, unsigned size,
                              uint32_t *value)
{
    rrr_hil_frame f, r;
    memset(&r, 0, sizeof r);
    CHECK((size == 0u ? rrr_com_sdo_upload(ID, index, sub, &f)
                      : rrr_com_sdo_download(ID, index, sub, *value, size, &f)) == 0);
    CHECK(f.id == 0x600u + ID && f.dlc == 8u);
    CHECK(exchange(n, &f, &r) == 1);
    /* an answer to another object, or of another node, is not this one's */
    uint32_t other = 0;
    CHECK(rrr_com_sdo_reply(&r, ID, (uint16_t)(index + 1u), sub, size == 0u, &other) ==
          RRR_COM_SDO_OTHER);
    CHECK(rrr_com_sdo_reply(&r, ID + 1u, index, sub, size == 0u, &other) == RRR_COM_SDO_OTHER);
    return rrr_com_sdo_reply(&r, ID, index, sub, size == 0u, value);
}

static void test_frames(void)
{
    rrr_hil_frame f;
    rrr_com_nmt(RRR_COM_NMT_START, 0u, &f);
    CHECK(f.id == 0u && f.dlc == 2u && f.data[0] == 1u && f.data[1] == 0u);
    rrr_com_sync(&f);
    CHECK(f.id == 0x080u && f.dlc == 0u);
    rrr_com_heartbeat(RRR_COM_MASTER_ID, 0x05u, &f); /* the real-time master's heartbeat */
    CHECK(f.id == 0x77Fu && f.dlc == 1u && f.data[0] == 0x05u && !f.extended);
    CHECK(RRR_COM_HEARTBEAT_MS < RRR_COM_CONSUMER_MS && RRR_COM_CONSUMER_MS <= 0xFFFFu);
    CHECK(rrr_com_sdo_download(ID, 0x6040u, 0u, 0x0Fu, 2u, &f) == 0);
    CHECK(f.data[0] == 0x2Bu && f.data[1] == 0x40u && f.data[2] == 0x60u && f.data[4] == 0x0Fu);
    CHECK(rrr_com_sdo_download(ID, 0x6060u, 0u, 10u, 1u, &f) == 0 && f.data[0] == 0x2Fu);
    CHECK(rrr_com_sdo_download(ID, 0x1017u, 0u, 100u, 4u, &f) == 0 && f.data[0] == 0x23u);
    CHECK(rrr_com_sdo_download(ID, 0x6040u, 0u, 0u, 3u, &f) == -1);
    CHECK(rrr_com_sdo_download(0u, 0x6040u, 0u, 0u, 2u, &f) == -1);
    CHECK(rrr_com_sdo_upload(128u, 0x6041u, 0u, &f) == -1);
    rrr_com_rpdo1(ID, 0x0Fu, -5, &f);
    CHECK(f.id == 0x200u + ID && f.dlc == 4u && f.data[0] == 0x0Fu && f.data[2] == 0xFBu &&
          f.data[3] == 0xFFu);
    /* target torque: k_t u in per mille of the rated torque, half away from zero, clamped */
    CHECK(rrr_com_torque_pm(10.0, 12.0, 120000u) == 1000);
    CHECK(rrr_com_torque_pm(-0.005, 12.0, 120000u) == -1);
    CHECK(rrr_com_torque_pm(0.005, 12.0, 120000u) == 1);
    CHECK(rrr_com_torque_pm(50.0, 12.0, 120000u) == 1000);
    CHECK(rrr_com_torque_pm(-50.0, 12.0, 120000u) == -1000);
    CHECK(rrr_com_torque_pm((double)NAN, 12.0, 120000u) == 0);
    CHECK(rrr_com_torque_pm((double)INFINITY, 12.0, 120000u) == 0);
    CHECK(rrr_com_inc_to_rad(1 << 20, 1u << 20) == 2.0 * 3.14159265358979323846);
    CHECK(rrr_com_inc_to_rad(rrr_co_rad_to_inc(0.25, 1u << 20), 1u << 20) ==
          (double)rrr_co_rad_to_inc(0.25, 1u << 20) * (2.0 * 3.14159265358979323846) /
              (double)(1u << 20));
}

static void test_against_the_slave(void)
{
    rrr_co_node n;
    const rrr_co_config cfg = {ID, RATED};
    CHECK(rrr_co_init(&n, &cfg) == 0);
    out.n = 0;
    rrr_co_boot(&n, &out);
    rrr_hil_frame f, r;
    /* NMT reset node to all: a boot-up */
    rrr_com_nmt(RRR_COM_NMT_RESET_NODE, 0u, &f);
    out.n = 0;
    rrr_co_on_frame(&n, &f, &out);
    CHECK(out.n == 1u && out.f[0].id == 0x700u + ID && out.f[0].dlc == 1u &&
          out.f[0].data[0] == 0u);

    /* configuration as the master does it */
    uint32_t v = RRR_COM_MODE_CST;
    CHECK(sdo(&n, 0x6060u, 0u, 1u, &v) == RRR_COM_SDO_DONE);
    CHECK(sdo(&n, 0x6061u, 0u, 0u, &v) == RRR_COM_SDO_DONE && v == RRR_COM_MODE_CST);
    CHECK(sdo(&n, 0x6076u, 0u, 0u, &v) == RRR_COM_SDO_DONE && v == RATED);
    CHECK(sdo(&n, 0x1A00u, 1u, 0u, &v) == RRR_COM_SDO_DONE && v == 0x60410010u);
    CHECK(sdo(&n, 0x1800u, 1u, 0u, &v) == RRR_COM_SDO_DONE && v == 0x180u + ID);
    /* aborts: their codes */
    v = 1u;
    CHECK(sdo(&n, 0x1018u, 1u, 4u, &v) == RRR_COM_SDO_ABORT && v == RRR_CO_ABORT_READ_ONLY);
    CHECK(sdo(&n, 0x2345u, 0u, 0u, &v) == RRR_COM_SDO_ABORT && v == RRR_CO_ABORT_NO_OBJECT);
    CHECK(sdo(&n, 0x1018u, 9u, 0u, &v) == RRR_COM_SDO_ABORT && v == RRR_CO_ABORT_NO_SUB);
    /* a segmented upload (the device name, longer than 4 bytes) is not what this master reads */
    CHECK(sdo(&n, 0x1008u, 0u, 0u, &v) == RRR_COM_SDO_BAD);
    rrr_co_node again;
    CHECK(rrr_co_init(&again, &cfg) == 0); /* and abort that transfer: start afresh */
    n = again;
    out.n = 0;
    rrr_co_boot(&n, &out);

    /* the 402 state machine by SDO, then operational */
    static const uint16_t cw[3] = {0x06u, 0x07u, 0x0Fu}, sw[3] = {0x21u, 0x23u, 0x27u};
    v = RRR_COM_MODE_CST;
    CHECK(sdo(&n, 0x6060u, 0u, 1u, &v) == RRR_COM_SDO_DONE);
    for (int s = 0; s < 3; ++s) {
        v = cw[s];
        CHECK(sdo(&n, 0x6040u, 0u, 2u, &v) == RRR_COM_SDO_DONE);
        CHECK(sdo(&n, 0x6041u, 0u, 0u, &v) == RRR_COM_SDO_DONE && (v & 0x6Fu) == sw[s]);
    }
    rrr_com_nmt(RRR_COM_NMT_START, 0u, &f);
    (void)exchange(&n, &f, NULL);
    CHECK(n.nmt == RRR_CO_NMT_OPERATIONAL);

    /* RPDO1 + SYNC: the TPDOs carry the feedback, decoded */
    rrr_co_set_feedback(&n, 0.5, -1.25);
    rrr_com_rpdo1(ID, 0x0Fu, 100, &f);
    (void)exchange(&n, &f, NULL);
    rrr_com_sync(&f);
    (void)exchange(&n, &f, NULL);
    out.n = 0;
    rrr_co_transmit(&n, &out);
    rrr_com_feedback fb;
    memset(&fb, 0, sizeof fb);
    int tpdos = 0;
    for (unsigned i = 0; i < out.n; ++i) {
        tpdos += rrr_com_tpdo(&out.f[i], ID, &fb) == 1;
        CHECK(rrr_com_tpdo(&out.f[i], ID + 1u, &fb) == 0);
    }
    CHECK(tpdos == 2 && fb.have == 3u && (fb.statusword & 0x6Fu) == 0x27u);
    CHECK(fb.position_inc == rrr_co_rad_to_inc(0.5, 1u << 20));
    CHECK(fb.velocity_inc == rrr_co_rad_to_inc(-1.25, 1u << 20));
    CHECK(n.v[rrr_co_od_find(0x6071u, 0u)] == 100u);
    /* a TPDO of the wrong length is refused, not decoded; which TPDO a frame is, by COB-ID */
    r = out.f[0];
    r.dlc = 5u;
    CHECK(rrr_com_tpdo(&r, ID, &fb) == -1);
    r.dlc = 8u;
    CHECK(rrr_com_tpdo(&r, ID, &fb) == -1);
    for (unsigned i = 0; i < out.n; ++i) {
        const unsigned which = rrr_com_tpdo_number(&out.f[i], ID);
        CHECK(which == (out.f[i].id == 0x180u + ID ? 1u : out.f[i].id == 0x280u + ID ? 2u : 0u));
        CHECK(which == 0u || rrr_com_tpdo(&out.f[i], ID, &fb) == 1); /* the drive's lengths */
        CHECK(rrr_com_tpdo_number(&out.f[i], ID + 1u) == 0u);
    }
    r.extended = 1u; /* a 29-bit identifier is no TPDO */
    CHECK(rrr_com_tpdo_number(&r, ID) == 0u && rrr_com_tpdo(&r, ID, &fb) == 0);

    /* a fault: its EMCY names the node and the code */
    out.n = 0;
    rrr_co_raise_fault(&n, RRR_CO_EMCY_RPDO_TIMEOUT, RRR_CO_ERR_COMM, &out);
    uint16_t code = 0;
    int emcy = 0;
    for (unsigned i = 0; i < out.n; ++i) {
        if (rrr_com_emcy(&out.f[i], &code) == ID) {
            emcy = 1;
            CHECK(code == RRR_CO_EMCY_RPDO_TIMEOUT);
        }
    }
    CHECK(emcy);
    rrr_com_sync(&f);
    CHECK(rrr_com_emcy(&f, &code) == 0u); /* the SYNC (0x080) is no EMCY */
}

static void test_hostile_answers(void)
{
    rrr_hil_frame r;
    memset(&r, 0, sizeof r);
    uint32_t v = 7u;
    r.id = 0x580u + ID;
    r.dlc = 8u;
    r.data[1] = 0x41u;
    r.data[2] = 0x60u;
    r.data[0] = 0x4Fu; /* expedited upload, 1 byte */
    r.data[4] = 0x27u;
    r.data[5] = 0xAAu; /* beyond the indicated size: ignored */
    CHECK(rrr_com_sdo_reply(&r, ID, 0x6041u, 0u, 1, &v) == RRR_COM_SDO_DONE && v == 0x27u);
    CHECK(rrr_com_sdo_reply(&r, ID, 0x6041u, 0u, 0, &v) == RRR_COM_SDO_BAD); /* not a 0x60 */
    r.dlc = 7u;
    CHECK(rrr_com_sdo_reply(&r, ID, 0x6041u, 0u, 1, &v) == RRR_COM_SDO_BAD);
    r.dlc = 3u;
    CHECK(rrr_com_sdo_reply(&r, ID, 0x6041u, 0u, 1, &v) == RRR_COM_SDO_OTHER);
    r.dlc = 8u;
    r.extended = 1u;
    CHECK(rrr_com_sdo_reply(&r, ID, 0x6041u, 0u, 1, &v) == RRR_COM_SDO_OTHER);
    r.extended = 0u;
    r.data[0] = 0x80u;
    r.dlc = 6u; /* an abort without its code */
    CHECK(rrr_com_sdo_reply(&r, ID, 0x6041u, 0u, 1, &v) == RRR_COM_SDO_BAD);
    r.data[0] = 0x41u; /* segmented upload initiate */
    r.dlc = 8u;
    CHECK(rrr_com_sdo_reply(&r, ID, 0x6041u, 0u, 1, &v) == RRR_COM_SDO_BAD);
}

int main(void)
{
    test_frames();
    test_against_the_slave();
    test_hostile_answers();
    return rrr_test_report("test_hil_canopen_master");
}
