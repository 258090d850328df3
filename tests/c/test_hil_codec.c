/* The bench codec: E2E CRC against the cantools/crccheck vector, round trips of every message
 * (StopCmd: every counter and reason, every bit error, every DLC),
 * quantisation bounds, refused values, and the decoder's verdict on wrong DLC, unknown ids,
 * extended ids, every single-bit corruption and out-of-range voltages. */
#include <string.h>

#include "hil_codec.h"
#include "rrr_test.h"

static void test_crc(void)
{
    /* docs/dbc.md#e2e-protection: payload 5a15393080f32c01 with DataID 0x42 (same bytes from crccheck in Python) */
    const uint8_t p[8] = {0x5a, 0x15, 0x39, 0x30, 0x80, 0xf3, 0x2c, 0x01};
    CHECK(rrr_hil_crc8_e2e(p + 1, 7, 0x42) == 0x5a);
    /* CRC-8/AUTOSAR check value: "12345678" followed by '9' as the "DataID" -> 0xDF */
    CHECK(rrr_hil_crc8_e2e((const uint8_t *)"12345678", 8, '9') == 0xDF);
}

static void test_voltage_roundtrip(void)
{
    rrr_rng rng = {12345u};
    for (int n = 0; n < 20000; ++n) {
        rrr_hil_voltage_cmd c = {(uint8_t)(n & 15), (uint8_t)(n & 1), 0, {0, 0, 0}};
        for (int i = 0; i < 3; ++i) {
            c.u_V[i] = rrr_rng_uniform(&rng, -30.0, 30.0);
        }
        rrr_hil_frame f;
        CHECK(rrr_hil_encode_voltage_cmd(&c, &f) == 0);
        CHECK(f.id == 0x100u && f.dlc == 8u && !f.extended);
        rrr_hil_msg m;
        CHECK(rrr_hil_decode(&f, &m) == RRR_HIL_RX_OK);
        CHECK(m.kind == RRR_HIL_VOLTAGE_CMD);
        CHECK(m.u.cmd.counter == c.counter && m.u.cmd.enable == c.enable);
        for (int i = 0; i < 3; ++i) {
            CHECK_CLOSE(m.u.cmd.u_V[i], c.u_V[i], 0.5e-3 + 1e-12);
        }
        /* every single-bit error is caught (CRC-8 has Hamming distance >= 2) */
        const int bit = n % 64;
        f.data[bit / 8] ^= (uint8_t)(1u << (bit % 8));
        CHECK(rrr_hil_decode(&f, &m) == RRR_HIL_RX_BAD_CRC);
    }
    rrr_hil_voltage_cmd bad = {0, 1, 0, {30.001, 0, 0}};
    rrr_hil_frame f;
    memset(&f, 0xAB, sizeof f);
    CHECK(rrr_hil_encode_voltage_cmd(&bad, &f) == -1);
    CHECK(f.id == 0xABABABABu); /* untouched */
    bad.u_V[0] = (double)NAN;
    CHECK(rrr_hil_encode_voltage_cmd(&bad, &f) == -1);
    bad.u_V[0] = 0.0;
    bad.counter = 16;
    CHECK(rrr_hil_encode_voltage_cmd(&bad, &f) == -1);
}

static void test_voltage_out_of_range(void)
{
    /* raw 30001 mV in U2 with a valid CRC: decoded as out of range, not clipped */
    rrr_hil_voltage_cmd c = {3, 1, 0, {1.0, 0.0, -1.0}};
    rrr_hil_frame f;
    CHECK(rrr_hil_encode_voltage_cmd(&c, &f) == 0);
    f.data[4] = (uint8_t)(30001 & 0xFF);
    f.data[5] = (uint8_t)(30001 >> 8);
    f.data[0] = rrr_hil_crc8_e2e(f.data + 1, 7, RRR_HIL_DATA_ID_VOLTAGE_CMD);
    rrr_hil_msg m;
    m.kind = RRR_HIL_KIND_COUNT;
    CHECK(rrr_hil_decode(&f, &m) == RRR_HIL_RX_OUT_OF_RANGE);
    CHECK(m.kind == RRR_HIL_VOLTAGE_CMD);
}

static void test_joint_state(void)
{
    rrr_rng rng = {777u};
    for (int n = 0; n < 20000; ++n) {
        const uint8_t j = (uint8_t)(n % 3);
        const double range = n < 100 ? 2147.0 : 10.0;
        rrr_hil_joint_state s = {j, (uint8_t)(n & 15), rrr_rng_uniform(&rng, -range, range),
                                 rrr_rng_uniform(&rng, -52.4, 52.4)};
        rrr_hil_frame f;
        CHECK(rrr_hil_encode_joint_state(&s, &f) == 0);
        CHECK(f.id == 0x201u + j);
        rrr_hil_msg m;
        CHECK(rrr_hil_decode(&f, &m) == RRR_HIL_RX_OK);
        CHECK(m.kind == RRR_HIL_JOINT_STATE && m.u.joint.joint == j);
        CHECK(m.u.joint.counter == s.counter);
        CHECK_CLOSE(m.u.joint.q_rad, s.q_rad, 0.5e-6 * (1.0 + 1e-9));
        CHECK_CLOSE(m.u.joint.qd_rad_s, s.qd_rad_s, 0.5e-4 * (1.0 + 1e-9));
        /* the DataID differs per joint: a frame moved to another joint's id fails the CRC */
        f.id = 0x201u + (uint8_t)((j + 1u) % 3u);
        CHECK(rrr_hil_decode(&f, &m) == RRR_HIL_RX_BAD_CRC);
    }
    const rrr_hil_joint_state far = {0, 0, 2147.5, 0.0};
    const rrr_hil_joint_state fast = {0, 0, 0.0, 52.43};
    rrr_hil_frame f;
    CHECK(rrr_hil_encode_joint_state(&far, &f) == -1);
    CHECK(rrr_hil_encode_joint_state(&fast, &f) == -1);
}

static void test_other_messages(void)
{
    rrr_hil_frame f;
    rrr_hil_msg m;
    const rrr_hil_sync s = {0xDEADBEEFu};
    CHECK(rrr_hil_encode_sync(&s, &f) == 0 && f.id == 0x80u && f.dlc == 4u);
    CHECK(rrr_hil_decode(&f, &m) == RRR_HIL_RX_OK && m.u.sync.cycle == 0xDEADBEEFu);
    const rrr_hil_plant_status st = {7, RRR_HIL_PLANT_FAULT, 0x45, 1, 65535, 12};
    CHECK(rrr_hil_encode_plant_status(&st, &f) == 0);
    CHECK(rrr_hil_decode(&f, &m) == RRR_HIL_RX_OK);
    CHECK(m.u.status.counter == 7 && m.u.status.state == RRR_HIL_PLANT_FAULT);
    CHECK(m.u.status.faults == 0x45 && m.u.status.zero_voltage == 1);
    CHECK(m.u.status.fault_count == 65535 && m.u.status.cmd_missed == 12);
    for (uint8_t node = 1; node <= 2; ++node) {
        const rrr_hil_heartbeat hb = {node, RRR_HIL_NMT_STOPPED, 200};
        CHECK(rrr_hil_encode_heartbeat(&hb, &f) == 0 && f.id == 0x700u + node && f.dlc == 2u);
        CHECK(rrr_hil_decode(&f, &m) == RRR_HIL_RX_OK && m.kind == RRR_HIL_HEARTBEAT);
        CHECK(m.u.heartbeat.node == node && m.u.heartbeat.nmt_state == 4 && m.u.heartbeat.counter == 200);
    }
    const rrr_hil_heartbeat bad = {3, 0, 0};
    CHECK(rrr_hil_encode_heartbeat(&bad, &f) == -1);
}

static void test_stop_cmd(void)
{
    rrr_hil_frame f;
    rrr_hil_msg m;
    for (uint8_t counter = 0; counter < 16u; ++counter) {
        for (uint8_t reason = 0; reason < (uint8_t)RRR_HIL_STOP_REASON_COUNT; ++reason) {
            const rrr_hil_stop_cmd s = {counter, reason};
            CHECK(rrr_hil_encode_stop_cmd(&s, &f) == 0);
            CHECK(f.id == 0x090u && f.dlc == 2u && !f.extended);
            CHECK(f.data[1] == (uint8_t)(counter | (reason << 4)));
            CHECK(f.data[0] == rrr_hil_crc8_e2e(f.data + 1, 1, RRR_HIL_DATA_ID_STOP_CMD));
            CHECK(rrr_hil_decode(&f, &m) == RRR_HIL_RX_OK && m.kind == RRR_HIL_STOP_CMD);
            CHECK(m.u.stop.counter == counter && m.u.stop.reason == reason);
            for (int bit = 0; bit < 16; ++bit) { /* every single-bit error is caught */
                rrr_hil_frame g = f;
                g.data[bit / 8] ^= (uint8_t)(1u << (bit % 8));
                CHECK(rrr_hil_decode(&g, &m) == RRR_HIL_RX_BAD_CRC);
            }
            for (uint8_t dlc = 0; dlc <= 15u; ++dlc) {
                rrr_hil_frame g = f;
                g.dlc = dlc;
                m.kind = RRR_HIL_KIND_COUNT;
                CHECK(rrr_hil_decode(&g, &m) == (dlc == 2u ? RRR_HIL_RX_OK : RRR_HIL_RX_BAD_DLC));
                CHECK(m.kind == RRR_HIL_STOP_CMD);
            }
        }
    }
    /* the vector of cantools: encode({AliveCounter 5, Reason 1}) = 00 15, compute_profile2_crc
     * with DataID 0x11 = 0xDF */
    const rrr_hil_stop_cmd vec = {5, RRR_HIL_STOP_INTERRUPTED};
    CHECK(rrr_hil_encode_stop_cmd(&vec, &f) == 0 && f.data[0] == 0xDF && f.data[1] == 0x15);
    /* the DataID is its own: a StopCmd payload with VoltageCmd's DataID fails */
    f.data[0] = rrr_hil_crc8_e2e(f.data + 1, 1, RRR_HIL_DATA_ID_VOLTAGE_CMD);
    CHECK(rrr_hil_decode(&f, &m) == RRR_HIL_RX_BAD_CRC);
    /* reasons 4..15 with a valid CRC: out of the DBC range, not a stop */
    f.data[1] = (uint8_t)(3u | (7u << 4));
    f.data[0] = rrr_hil_crc8_e2e(f.data + 1, 1, RRR_HIL_DATA_ID_STOP_CMD);
    CHECK(rrr_hil_decode(&f, &m) == RRR_HIL_RX_OUT_OF_RANGE && m.kind == RRR_HIL_STOP_CMD);
    const rrr_hil_stop_cmd bad_reason = {0, 4}, bad_counter = {16, 0};
    memset(&f, 0xAB, sizeof f);
    CHECK(rrr_hil_encode_stop_cmd(&bad_reason, &f) == -1);
    CHECK(rrr_hil_encode_stop_cmd(&bad_counter, &f) == -1);
    CHECK(f.id == 0xABABABABu); /* untouched */
    CHECK(strcmp(rrr_hil_stop_reason_str(RRR_HIL_STOP_END_OF_RUN), "end of run") == 0);
    CHECK(strcmp(rrr_hil_stop_reason_str(99), "invalid stop reason") == 0);
    /* PlantStatus carries the reset state */
    const rrr_hil_plant_status st = {1, RRR_HIL_PLANT_RESET, 2, 1, 1, 0};
    CHECK(rrr_hil_encode_plant_status(&st, &f) == 0);
    CHECK(rrr_hil_decode(&f, &m) == RRR_HIL_RX_OK && m.u.status.state == RRR_HIL_PLANT_RESET);
}

static void test_rejects(void)
{
    rrr_hil_frame f;
    rrr_hil_msg m;
    const rrr_hil_voltage_cmd c = {0, 1, 0, {0.5, 0.5, 0.5}};
    CHECK(rrr_hil_encode_voltage_cmd(&c, &f) == 0);
    for (uint8_t dlc = 0; dlc <= 15; ++dlc) {
        f.dlc = dlc;
        CHECK(rrr_hil_decode(&f, &m) == (dlc == 8 ? RRR_HIL_RX_OK : RRR_HIL_RX_BAD_DLC));
    }
    f.dlc = 8;
    f.extended = 1;
    CHECK(rrr_hil_decode(&f, &m) == RRR_HIL_RX_UNKNOWN_ID);
    f.extended = 0;
    f.id = 0x101;
    CHECK(rrr_hil_decode(&f, &m) == RRR_HIL_RX_UNKNOWN_ID);
    CHECK(strcmp(rrr_hil_rx_str(RRR_HIL_RX_BAD_CRC), "E2E CRC mismatch") == 0);
    CHECK(strcmp(rrr_hil_rx_str((rrr_hil_rx)99), "invalid rrr_hil_rx") == 0);
}

int main(void)
{
    test_crc();
    test_voltage_roundtrip();
    test_voltage_out_of_range();
    test_joint_state();
    test_other_messages();
    test_stop_cmd();
    test_rejects();
    return rrr_test_report("test_hil_codec");
}
