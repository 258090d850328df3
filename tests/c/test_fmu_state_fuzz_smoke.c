/* Drives the forged-state fuzz target (fmu/fuzz/fuzz_fmu_state.c, compiled with one FMU's model)
 * without libFuzzer, so that its invariants run under ASan and UBSan in CTest with any compiler:
 * first every single-word forgery (each 8-byte word of the state's payload, each op, from each
 * of the 8 instances and states: the reporter's look-up cursor 2^64-1 among them), then N
 * seeded random inputs of up to 6 writes. The coverage-guided run is libFuzzer (RRR_FMU_FUZZ=ON,
 * clang; scripts/run_tests.sh runs it briefly). */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rrr_test.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);
void fuzz_fmu_state_release(void);
size_t fuzz_fmu_state_words(void);

static uint32_t next(rrr_rng *r)
{
    return (uint32_t)(rrr_rng_uniform(r, 0.0, 4294967296.0));
}

int main(int argc, char **argv)
{
    const long n = argc > 1 ? strtol(argv[1], NULL, 10) : 1000;
    /* argv[2], a stride (default 1): instance sel forges the words sel mod stride, sel mod
     * stride + stride, ...: with a stride of at most 8 the 8 instances still cover every word
     * (the LS-BUS nodes, whose states hold a Tx buffer, use 4) */
    const unsigned long given = argc > 2 ? strtoul(argv[2], NULL, 10) : 1ul;
    const unsigned stride = given >= 1ul && given <= 8ul ? (unsigned)given : 1u;
    const unsigned words = (unsigned)fuzz_fmu_state_words();
    uint8_t buf[1 + 6 * 11];
    long runs = 0;
    /* every word of every instance's state: other bits, NaN, -1.0, all ones (the reporter's
     * cursor 2^64-1), a small count into the low half of the word (an int field) */
    static const struct {
        uint8_t op;
        uint64_t value;
    } ops[5] = {{0, 0x0123456789ABCDEFull}, {1, 0}, {4, 0xFF}, {5, 0}, {6, 3}};
    for (unsigned sel = 0; sel < 8u; ++sel) {
        for (unsigned w = sel % stride; w < words; w += stride) {
            for (unsigned o = 0; o < sizeof ops / sizeof ops[0]; ++o) {
                buf[0] = (uint8_t)sel;
                buf[1] = (uint8_t)(w & 0xFFu);
                buf[2] = (uint8_t)(w >> 8);
                buf[3] = ops[o].op;
                memcpy(buf + 4, &ops[o].value, 8); /* op 4: the double of (int8) byte 0 */
                LLVMFuzzerTestOneInput(buf, 12);
                ++runs;
            }
        }
    }
    rrr_rng rng = {0x2545F4914F6CDD1DULL};
    for (long i = 0; i < n; ++i) {
        const size_t k = next(&rng) % 7u;
        buf[0] = (uint8_t)next(&rng);
        for (size_t r = 0; r < k; ++r) {
            uint8_t *p = buf + 1 + 11 * r;
            const uint32_t w = next(&rng) % words;
            p[0] = (uint8_t)w;
            p[1] = 0;
            p[2] = (uint8_t)next(&rng);
            for (int b = 0; b < 8; ++b) {
                p[3 + b] = (uint8_t)next(&rng);
            }
            if (next(&rng) % 2u) { /* a small number, not random bits */
                memset(p + 4, 0, 7);
            }
        }
        LLVMFuzzerTestOneInput(buf, 1 + 11 * k);
        ++runs;
    }
    fuzz_fmu_state_release();
    printf("%ld forged FMU states with valid checksums: no crash, no sanitizer report, every "
           "invariant held\n", runs);
    return 0;
}
