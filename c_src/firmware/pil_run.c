/* The run block (pil_run.h). */
#include "pil_run.h"

#include <math.h>
#include <string.h>

#include "rrr/rrr_params.h"

uint32_t pil_crc32(const unsigned char *p, size_t n)
{
    uint32_t crc = 0xFFFFFFFFu;
    for (size_t i = 0; i < n; ++i) {
        crc ^= p[i];
        for (int b = 0; b < 8; ++b) {
            crc = (crc >> 1) ^ (0xEDB88320u & (0u - (crc & 1u)));
        }
    }
    return crc ^ 0xFFFFFFFFu;
}

static uint32_t u32_at(const unsigned char *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static double f64_at(const unsigned char *p)
{
    double v;
    memcpy(&v, p, sizeof v); /* the block is little-endian, as both targets and the host are */
    return v;
}

int pil_run_open(const void *base, size_t cap, pil_run *run, const char **why)
{
    const unsigned char *b = base;
    if (cap < PIL_RUN_HEADER_BYTES + 8u || memcmp(b, PIL_RUN_MAGIC, 8) != 0) {
        *why = "no run block (magic RRRPIL01) at its address: was it loaded?";
        return -1;
    }
    const uint32_t total = u32_at(b + 8), n = u32_at(b + 12), m = u32_at(b + 16);
    if (n == 0u || n > cap / 80u || m > RRR_N_PARAMS) {
        *why = "run block: periods or parameter count out of range";
        return -1;
    }
    const size_t need = PIL_RUN_HEADER_BYTES + 16u * (size_t)m + 80u * (size_t)n + 8u;
    if (total != need || total > cap) {
        *why = "run block: its size does not match its periods and parameters";
        return -1;
    }
    if (pil_crc32(b, total - 8u) != u32_at(b + total - 8u)) {
        *why = "run block: CRC-32 mismatch (corrupt or cut short)";
        return -1;
    }
    const uint32_t ff = u32_at(b + 20), timeout = u32_at(b + 24);
    if (ff > 1u || timeout == 0u) {
        *why = "run block: feedforward not 0 or 1, or a timeout of 0 ms";
        return -1;
    }
    pil_run r;
    memset(&r, 0, sizeof r);
    r.periods = n;
    r.n_sets = m;
    r.timeout_ms = timeout;
    for (int i = 0; i < 3; ++i) {
        r.gains.kp[i] = f64_at(b + 32 + 8 * i);
        r.gains.kd[i] = f64_at(b + 56 + 8 * i);
    }
    r.gains.feedforward = (int)ff;
    r.sets = b + PIL_RUN_HEADER_BYTES;
    const unsigned char *rows = r.sets + 16u * m;
    /* the columns: doubles at multiples of 8 from an 8-byte aligned base */
    r.t = (const double *)(const void *)rows;
    r.q = (const double(*)[3])(const void *)(rows + 8u * (size_t)n);
    r.qd = (const double(*)[3])(const void *)(rows + 32u * (size_t)n);
    r.qdd = (const double(*)[3])(const void *)(rows + 56u * (size_t)n);
    *run = r;
    return 0;
}

pil_run_set pil_run_get_set(const pil_run *run, uint32_t i)
{
    const unsigned char *p = run->sets + 16u * i;
    const pil_run_set s = {u32_at(p), f64_at(p + 8)};
    return s;
}

int pil_run_model(const pil_run *run, rrr_model *m, const char **why)
{
    (void)rrr_model_default(m);
    for (uint32_t i = 0; i < run->n_sets; ++i) {
        const pil_run_set s = pil_run_get_set(run, i);
        if (s.row >= RRR_N_PARAMS || !isfinite(s.value) ||
            rrr_param_set(m, s.row, s.value) != RRR_OK) {
            *why = "run block: a model parameter assignment is out of range (rrr_param_set)";
            return -1;
        }
    }
    const char *field = "";
    if (rrr_model_validate(m, &field) != RRR_OK) {
        *why = "run block: the parameters give an invalid model (rrr_model_validate)";
        return -1;
    }
    return 0;
}
