/* The run block (c_src/firmware/pil_run.h): a block written by the layout opens, and every
 * kind of damage is refused with a reason; the model assignments reach the model. */
#include <stdlib.h>
#include <string.h>

#include "pil_run.h"
#include "rrr/rrr.h"
#include "rrr_test.h"

#define N 7u
#define SETS 2u
#define TOTAL (PIL_RUN_HEADER_BYTES + 16u * SETS + 80u * N + 8u)

static _Alignas(8) unsigned char block[TOTAL + 64u];

static void put32(unsigned char *p, uint32_t v)
{
    for (int i = 0; i < 4; ++i) {
        p[i] = (unsigned char)(v >> (8 * i));
    }
}

static void put64(unsigned char *p, double v)
{
    memcpy(p, &v, 8); /* the host is little-endian, as the layout */
}

static void seal(void)
{
    put32(block + TOTAL - 8u, pil_crc32(block, TOTAL - 8u));
    put32(block + TOTAL - 4u, 0u);
}

/* A block of N periods: t = k ms, q = (k, 2k, 3k) / 100, qd = q / 10, qdd = q / 100; gains
 * kp = (1, 2, 3), kd = (0.1, 0.2, 0.3); a2 = 0.5, g = 9.5. */
static void build(void)
{
    memset(block, 0, sizeof block);
    memcpy(block, PIL_RUN_MAGIC, 8);
    put32(block + 8, TOTAL);
    put32(block + 12, N);
    put32(block + 16, SETS);
    put32(block + 20, 1u);
    put32(block + 24, 5000u);
    for (int i = 0; i < 3; ++i) {
        put64(block + 32 + 8 * i, i + 1.0);
        put64(block + 56 + 8 * i, 0.1 * (i + 1));
    }
    put32(block + PIL_RUN_HEADER_BYTES, (uint32_t)rrr_param_index("a2"));
    put64(block + PIL_RUN_HEADER_BYTES + 8, 0.5);
    put32(block + PIL_RUN_HEADER_BYTES + 16, (uint32_t)rrr_param_index("g"));
    put64(block + PIL_RUN_HEADER_BYTES + 24, 9.5);
    unsigned char *rows = block + PIL_RUN_HEADER_BYTES + 16u * SETS;
    for (unsigned k = 0; k < N; ++k) {
        put64(rows + 8u * k, 0.001 * k);
        for (unsigned j = 0; j < 3; ++j) {
            const double q = (j + 1.0) * k / 100.0;
            put64(rows + 8u * N + 24u * k + 8u * j, q);
            put64(rows + 32u * N + 24u * k + 8u * j, q / 10.0);
            put64(rows + 56u * N + 24u * k + 8u * j, q / 100.0);
        }
    }
    seal();
}

static void test_good_block(void)
{
    build();
    pil_run r;
    const char *why = "";
    CHECK(pil_run_open(block, sizeof block, &r, &why) == 0);
    CHECK(r.periods == N && r.n_sets == SETS && r.timeout_ms == 5000u && r.gains.feedforward);
    CHECK(r.gains.kp[2] == 3.0 && r.gains.kd[1] == 0.2);
    CHECK(r.t[N - 1] == 0.001 * (N - 1) && r.q[4][2] == 3.0 * 4 / 100.0);
    CHECK(r.qd[6][0] == 6.0 / 100.0 / 10.0 && r.qdd[1][1] == 2.0 / 100.0 / 100.0);
    rrr_model m;
    CHECK(pil_run_model(&r, &m, &why) == 0);
    CHECK(m.a2 == 0.5 && m.g == 9.5);
}

static void test_damage(void)
{
    pil_run r;
    const char *why = "";
    build();
    CHECK(pil_run_open(block, 40, &r, &why) != 0 && strstr(why, "magic") != NULL);
    block[0] = 'X';
    CHECK(pil_run_open(block, sizeof block, &r, &why) != 0 && strstr(why, "magic") != NULL);
    build();
    block[PIL_RUN_HEADER_BYTES + 100] ^= 1u; /* a bit of the reference */
    CHECK(pil_run_open(block, sizeof block, &r, &why) != 0 && strstr(why, "CRC") != NULL);
    build();
    CHECK(pil_run_open(block, TOTAL - 1u, &r, &why) != 0 && strstr(why, "size") != NULL);
    put32(block + 12, N + 1u); /* periods that do not match the size */
    seal();
    CHECK(pil_run_open(block, sizeof block, &r, &why) != 0 && strstr(why, "size") != NULL);
    build();
    put32(block + 16, RRR_N_PARAMS + 1u);
    CHECK(pil_run_open(block, sizeof block, &r, &why) != 0);
    build();
    put32(block + 20, 2u); /* feedforward not 0 or 1 */
    seal();
    CHECK(pil_run_open(block, sizeof block, &r, &why) != 0);
    build();
    put32(block + 24, 0u); /* no timeout */
    seal();
    CHECK(pil_run_open(block, sizeof block, &r, &why) != 0);
    /* a parameter out of its range, an unknown row: the block opens, the model is refused */
    build();
    put64(block + PIL_RUN_HEADER_BYTES + 8, -1.0); /* a2 > 0 */
    seal();
    rrr_model m;
    CHECK(pil_run_open(block, sizeof block, &r, &why) == 0);
    CHECK(pil_run_model(&r, &m, &why) != 0 && strstr(why, "model") != NULL);
    build();
    put32(block + PIL_RUN_HEADER_BYTES, RRR_N_PARAMS);
    seal();
    CHECK(pil_run_open(block, sizeof block, &r, &why) == 0 && pil_run_model(&r, &m, &why) != 0);
}

int main(void)
{
    /* zlib's crc32 of "123456789" */
    CHECK(pil_crc32((const unsigned char *)"123456789", 9) == 0xCBF43926u);
    test_good_block();
    test_damage();
    return rrr_test_report("test_pil_run");
}
