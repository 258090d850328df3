/* The safety policy's output stage: the 0 V and fault latch (hil_common.h). */
#include "hil_common.h"

#include <string.h>

void rrr_hil_latch_init(rrr_hil_latch *l)
{
    memset(l, 0, sizeof *l);
}

void rrr_hil_latch_fault(rrr_hil_latch *l, uint16_t code)
{
    l->latched = 1;
    l->code = code;
    ++l->fault_events;
}

int rrr_hil_latch_reset(rrr_hil_latch *l)
{
    if (!l->latched) {
        return 0;
    }
    l->latched = 0;
    l->code = 0;
    ++l->resets;
    return 1;
}

int rrr_hil_latch_blocks(const rrr_hil_latch *l, int stop)
{
    return l->latched || stop;
}

int rrr_hil_latch_output(rrr_hil_latch *l, int stop, double *u, unsigned n)
{
    const int zero = rrr_hil_latch_blocks(l, stop);
    if (zero) {
        for (unsigned i = 0; i < n; ++i) {
            u[i] = 0.0;
        }
        ++l->zero_periods;
    }
    l->zero = (uint8_t)zero;
    return zero;
}
