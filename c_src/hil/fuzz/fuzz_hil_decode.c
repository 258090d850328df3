/*
 * Fuzz target of the bench's input parsers: the frame decoder (every id, dlc, payload), the
 * supervisor fed with whatever the decoder returns, and the socketcand message parser.
 * Input layout: byte 0 selects the parser; the rest is the frame (id from 2 bytes, dlc, data)
 * or the text of one socketcand message.
 *
 * libFuzzer (clang):  cmake -DRRR_HIL_FUZZ=ON -DCMAKE_C_COMPILER=clang ...; ./fuzz_hil_decode
 * Without clang, tests/c/test_hil_fuzz_smoke.c drives the same function with random inputs.
 */
#include <stddef.h>
#include <stdint.h>
#include <string.h>

#include "hil_codec.h"
#include "hil_supervisor.h"
#include "hil_transport.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1u) {
        return 0;
    }
    if ((data[0] & 1u) == 0u) {
        rrr_hil_frame f;
        memset(&f, 0, sizeof f);
        if (size >= 4u) {
            f.id = (uint32_t)(data[1] | ((uint32_t)data[2] << 8)) & 0x7FFu;
            f.extended = (data[0] >> 1) & 1u;
            f.dlc = data[3]; /* may exceed 8: must be refused, not read */
            const size_t n = size - 4u < 8u ? size - 4u : 8u;
            memcpy(f.data, data + 4, n);
        }
        rrr_hil_msg m;
        const rrr_hil_rx rx = rrr_hil_decode(&f, &m);
        if (rx == RRR_HIL_RX_OK && m.kind == RRR_HIL_VOLTAGE_CMD) {
            /* a decoded command re-encodes to the same signal bits (bits 14, 15 are unused) */
            rrr_hil_frame g;
            if (rrr_hil_encode_voltage_cmd(&m.u.cmd, &g) != 0 ||
                ((g.data[1] ^ f.data[1]) & 0x3Fu) != 0u || memcmp(g.data + 2, f.data + 2, 6) != 0) {
                __builtin_trap();
            }
        }
        rrr_hil_sup s;
        const rrr_hil_sup_config cfg = rrr_hil_sup_config_default();
        (void)rrr_hil_sup_init(&s, &cfg);
        const int is_cmd = rx == RRR_HIL_RX_OK && m.kind == RRR_HIL_VOLTAGE_CMD;
        if (is_cmd || rx == RRR_HIL_RX_BAD_CRC || rx == RRR_HIL_RX_BAD_DLC) {
            rrr_hil_sup_on_command(&s, rx, is_cmd ? &m.u.cmd : NULL);
        }
        double u[3];
        (void)rrr_hil_sup_next_period(&s, u);
        (void)rrr_hil_rx_str(rx);
    } else {
        rrr_hil_frame f;
        char word[16];
        const unsigned n = size - 1u > 512u ? 512u : (unsigned)(size - 1u);
        (void)rrr_hil_scd_parse((const char *)data + 1, n, &f, word);
    }
    return 0;
}
