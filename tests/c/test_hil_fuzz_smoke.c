/* Drives the fuzz target (c_src/hil/fuzz/fuzz_hil_decode.c) with N seeded random inputs and
 * mutations of valid frames (StopCmd among them), of socketcand lines and of fault-reset
 * sequences through one supervisor, so the decoders and the supervisor's invariants are
 * exercised under ASan and UBSan with any compiler. The coverage-guided run is libFuzzer
 * (RRR_HIL_FUZZ=ON, clang). */
#include <stdlib.h>
#include <string.h>

#include "hil_codec.h"
#include "hil_transport.h"
#include "rrr_test.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static uint32_t next(rrr_rng *r)
{
    return (uint32_t)(rrr_rng_uniform(r, 0.0, 4294967296.0));
}

/* A sequence-mode input (see fuzz_hil_decode.c): a fault reset (a request, then enabling
 * commands with consecutive counters) and a stop, with a few records disturbed. */
static size_t reset_sequence(rrr_rng *rng, uint8_t *buf, size_t cap)
{
    size_t len = 1;
    buf[0] = 4;
    const uint8_t c0 = (uint8_t)(next(rng) & 15u);
    for (unsigned i = 0; i < 7u && len + 12u <= cap; ++i, len += 12u) {
        uint8_t *r = buf + len;
        memset(r, 0, 12);
        r[0] = 0x51; /* VoltageCmd, valid CRC, feed and close the period */
        r[3] = 8;
        const unsigned enable = i >= 1u && i <= 3u ? 1u : 0u, reset = i == 0u ? 1u : 0u;
        r[5] = (uint8_t)(((c0 + i) & 15u) | (enable << 4) | (reset << 5));
        if (i == 4u) { /* then a StopCmd with the next counter */
            r[0] = 0x61;
            r[3] = 2;
            r[5] = (uint8_t)((c0 + i) & 15u);
        }
        if (i > 4u) {
            r[0] = (uint8_t)next(rng); /* anything */
            r[5] = (uint8_t)next(rng);
        }
    }
    const uint32_t disturb = next(rng) % 6u; /* 0: the sequence as it is */
    uint8_t *r = buf + 1 + 12u * (next(rng) % 6u);
    if (disturb == 1u) {
        r[5] = (uint8_t)((r[5] & 0xF0u) | ((r[5] + 2u) & 15u)); /* counter gap */
    } else if (disturb == 2u) {
        r[0] &= (uint8_t)~0x40u; /* its CRC left as it is: wrong */
        r[4] = (uint8_t)next(rng);
    } else if (disturb == 3u) {
        r[5] ^= (uint8_t)(1u << (4u + next(rng) % 4u)); /* Enable / ResetFault / spare bits */
    } else if (disturb == 4u) {
        r[3] = (uint8_t)(next(rng) % 16u); /* DLC */
    } else if (disturb == 5u) {
        r[0] = (uint8_t)(2u + (next(rng) & 1u) + 4u * (next(rng) & 1u)); /* period or raise */
    }
    return len;
}

int main(int argc, char **argv)
{
    const long n = argc > 1 ? strtol(argv[1], NULL, 10) : 100000;
    rrr_rng rng = {0x9E3779B97F4A7C15ULL};
    static const char *const lines[] = {"< send 100 8 39 30 80 f3 0 0 0 0 >",
                                        "< frame 201 1795299831.423300 87130000000000AB >",
                                        "< open bench0 >", "< rawmode >", "< ok >"};
    uint8_t buf[96];
    for (long i = 0; i < n; ++i) {
        size_t len;
        const uint32_t mode = next(&rng) % 6u;
        if (mode == 0u) { /* random bytes */
            len = next(&rng) % sizeof buf;
            for (size_t k = 0; k < len; ++k) {
                buf[k] = (uint8_t)next(&rng);
            }
        } else if (mode == 1u) { /* a valid frame of the bench, then a few flipped bits */
            rrr_hil_frame f;
            const rrr_hil_voltage_cmd c = {(uint8_t)(next(&rng) & 15u), 1, 0,
                                           {rrr_rng_uniform(&rng, -30, 30), 0.0, -1.0}};
            const rrr_hil_joint_state j = {(uint8_t)(next(&rng) % 3u), 1,
                                           rrr_rng_uniform(&rng, -2000, 2000), 1.0};
            const rrr_hil_stop_cmd st = {(uint8_t)(next(&rng) & 15u), (uint8_t)(next(&rng) % 4u)};
            const uint32_t which = next(&rng) % 3u;
            if (which == 0u) {
                (void)rrr_hil_encode_voltage_cmd(&c, &f);
            } else if (which == 1u) {
                (void)rrr_hil_encode_joint_state(&j, &f);
            } else {
                (void)rrr_hil_encode_stop_cmd(&st, &f);
            }
            buf[0] = 0;
            buf[1] = (uint8_t)(f.id & 0xFFu);
            buf[2] = (uint8_t)(f.id >> 8);
            buf[3] = (next(&rng) % 8u) == 0u ? (uint8_t)(next(&rng) % 16u) : f.dlc;
            memcpy(buf + 4, f.data, 8);
            len = 12;
            for (uint32_t k = next(&rng) % 3u; k > 0u; --k) {
                const uint32_t bit = next(&rng) % 96u;
                buf[bit / 8u] ^= (uint8_t)(1u << (bit % 8u));
            }
            buf[0] &= 0xF2u; /* one frame */
        } else if (mode == 4u) { /* a fault reset through one supervisor */
            len = reset_sequence(&rng, buf, sizeof buf);
        } else if (mode == 5u) { /* a socket read: a frame's bytes, classical or CAN FD, bits
                                  * flipped, and sometimes of another length */
            rrr_hil_frame f = {(uint32_t)(next(&rng) & 0x7FFu), 0, (uint8_t)(next(&rng) % 9u),
                               {0}};
            for (unsigned k = 0; k < 8u; ++k) {
                f.data[k] = k < f.dlc ? (uint8_t)next(&rng) : 0u;
            }
            const int fd = (int)(next(&rng) & 1u);
            len = 1u + rrr_hil_sc_to_wire(&f, fd, (int)(next(&rng) & 1u), buf + 1);
            buf[0] = (uint8_t)(8u | ((next(&rng) & 1u) << 1));
            for (uint32_t k = next(&rng) % 3u; k > 0u; --k) {
                const uint32_t bit = 8u + next(&rng) % (8u * (uint32_t)(len - 1u));
                buf[bit / 8u] ^= (uint8_t)(1u << (bit % 8u));
            }
            if ((next(&rng) % 8u) == 0u) {
                len = 1u + next(&rng) % 80u;
            }
        } else { /* a socketcand line, truncated or with a byte replaced */
            const char *s = lines[next(&rng) % 5u];
            len = 1 + strlen(s);
            buf[0] = 1;
            memcpy(buf + 1, s, len - 1);
            if (next(&rng) & 1u) {
                buf[1 + next(&rng) % (len - 1)] = (uint8_t)next(&rng);
            } else {
                len = 1 + next(&rng) % (len - 1);
            }
        }
        LLVMFuzzerTestOneInput(buf, len);
    }
    printf("test_hil_fuzz_smoke: %ld inputs\n", n);
    return rrr_test_report("test_hil_fuzz_smoke");
}
