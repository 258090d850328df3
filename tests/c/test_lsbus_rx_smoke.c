/* Drives the LS-BUS receive fuzz target (fmu/fuzz/fuzz_lsbus_rx.c, compiled with one network
 * FMU's model) without libFuzzer, so that its checks run under ASan and UBSan in CTest with any
 * compiler: every hostile kind of operation (unknown OP Code, a length past the end, zero
 * length, a data length above 8 and above 64, concatenations cut at every byte), valid frames of
 * the bench with single-byte mutations, and N seeded random inputs. The coverage-guided run is
 * libFuzzer (RRR_FMU_FUZZ=ON, clang; scripts/run_tests.sh runs it briefly). */
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmu_lsbus.h"
#include "rrr_test.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

static uint32_t next(rrr_rng *r)
{
    return (uint32_t)(rrr_rng_uniform(r, 0.0, 4294967296.0));
}

/* One input of a single value: flags, the 2-byte length, the bytes. */
static void one(uint8_t flags, const uint8_t *v, size_t n)
{
    static uint8_t buf[3 + 4096];
    buf[0] = flags;
    buf[1] = (uint8_t)n;
    buf[2] = (uint8_t)(n >> 8);
    memcpy(buf + 3, v, n);
    LLVMFuzzerTestOneInput(buf, 3 + n);
}

int main(int argc, char **argv)
{
    const long n_random = argc > 1 ? strtol(argv[1], NULL, 10) : 1000;
    long runs = 0;
    uint8_t v[2200];
    /* the hostile kinds, each with both notification settings and a step after */
    static const uint8_t unknown[] = {0x77, 0, 0, 0, 0x0a, 0, 0, 0, 1, 2};
    static const uint8_t past[] = {0x10, 0, 0, 0, 0xff, 0, 0, 0, 0, 1, 0, 0, 0, 0, 8, 0};
    static const uint8_t zero[] = {0x10, 0, 0, 0, 0, 0, 0, 0, 0x10, 0, 0, 0, 8, 0, 0, 0};
    static const uint8_t nine[25] = {0x10, 0, 0, 0, 25, 0, 0, 0, 0x10, 1, 0, 0, 0, 0, 9, 0};
    static const uint8_t fd65[17 + 65] = {0x11, 0, 0, 0, 17 + 65, 0, 0, 0, 0x10, 1, 0, 0, 0, 1, 0, 65, 0};
    static const uint8_t bus_error[15] = {0x31, 0, 0, 0, 0x0f, 0, 0, 0, 0x10, 0x01, 0, 0, 4, 1, 1};
    const struct {
        const uint8_t *p;
        size_t n;
    } kinds[] = {{unknown, sizeof unknown}, {past, sizeof past}, {zero, sizeof zero},
                 {nine, sizeof nine}, {fd65, sizeof fd65}, {bus_error, sizeof bus_error}};
    for (size_t k = 0; k < sizeof kinds / sizeof kinds[0]; ++k) {
        for (uint8_t flags = 0; flags < 4; ++flags) {
            one(flags, kinds[k].p, kinds[k].n);
            ++runs;
        }
    }
    /* a concatenation of bench-like frames cut at every byte */
    size_t len = 0;
    const uint8_t frame[8] = {0x42, 0x10, 0x27, 0, 0x10, 0x27, 0, 0x01};
    for (uint32_t id = 0x200; id < 0x204; ++id) {
        len += fmu_lsbus_put_can_transmit(v + len, sizeof v - len, id, 0, 0, frame, 8);
    }
    len += fmu_lsbus_put_config_baudrate(v + len, sizeof v - len, 1, 250000u);
    for (size_t cut = 0; cut <= len; ++cut) {
        one(2, v, cut);
        ++runs;
    }
    /* single-byte mutations of it */
    rrr_rng rng = {20261205u};
    for (size_t i = 0; i < len; ++i) {
        uint8_t m[128];
        memcpy(m, v, len);
        m[i] = (uint8_t)next(&rng);
        one((uint8_t)(next(&rng) & 7u), m, len);
        ++runs;
    }
    /* random inputs of several values */
    for (long r = 0; r < n_random; ++r) {
        static uint8_t buf[4096];
        const size_t n = 1 + next(&rng) % 1024u; /* a few values of a few hundred bytes */
        for (size_t i = 0; i < n; ++i) {
            buf[i] = (uint8_t)next(&rng);
        }
        LLVMFuzzerTestOneInput(buf, n);
        ++runs;
    }
    CHECK(runs > n_random);
    printf("test_lsbus_rx_smoke: %ld inputs without a trap\n", runs);
    return rrr_test_failures == 0 ? 0 : 1;
}
