/* Drives the fuzz target (c_src/hil/fuzz/fuzz_hil_decode.c) with N seeded random inputs and
 * mutations of valid frames and socketcand lines, so the decoders are exercised under ASan and
 * UBSan with any compiler. The coverage-guided run is libFuzzer (RRR_HIL_FUZZ=ON, clang). */
#include <stdlib.h>
#include <string.h>

#include "hil_codec.h"
#include "rrr_test.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static uint32_t next(rrr_rng *r)
{
    return (uint32_t)(rrr_rng_uniform(r, 0.0, 4294967296.0));
}

int main(int argc, char **argv)
{
    const long n = argc > 1 ? strtol(argv[1], NULL, 10) : 100000;
    rrr_rng rng = {0x9E3779B97F4A7C15ULL};
    static const char *const lines[] = {"< send 100 8 39 30 80 f3 0 0 0 0 >",
                                        "< frame 201 1795299831.423300 87130000000000AB >",
                                        "< open bench0 >", "< rawmode >", "< ok >"};
    uint8_t buf[80];
    for (long i = 0; i < n; ++i) {
        size_t len;
        const uint32_t mode = next(&rng) % 4u;
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
            if (next(&rng) & 1u) {
                (void)rrr_hil_encode_voltage_cmd(&c, &f);
            } else {
                (void)rrr_hil_encode_joint_state(&j, &f);
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
            buf[0] &= 0xFEu;
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
