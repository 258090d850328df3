/* The parameter table of rrr_model (rrr_params.h): rows expanded from RRR_MODEL_PARAMS. */
#include "rrr_internal.h"

#define RRR_PARAM_ROW(NAME, MEMBER, UNIT, BOUND, DESC)                                        \
    {NAME, UNIT, offsetof(rrr_model, MEMBER), BOUND, DESC},

/* Read-only data: character arrays and numbers, no pointers (no relocations, no globals). */
static const rrr_param_info params[RRR_N_PARAMS] = {RRR_MODEL_PARAMS(RRR_PARAM_ROW)};

#define RRR_PARAM_ONE(NAME, MEMBER, UNIT, BOUND, DESC) +1
_Static_assert(0 RRR_MODEL_PARAMS(RRR_PARAM_ONE) == RRR_N_PARAMS, "RRR_N_PARAMS rows");

const rrr_param_info *rrr_param_table(size_t *n)
{
    if (n != NULL) {
        *n = RRR_N_PARAMS;
    }
    return params;
}

int rrr_param_index(const char *name)
{
    if (name == NULL) {
        return -1;
    }
    for (int i = 0; i < RRR_N_PARAMS; ++i) {
        if (strcmp(params[i].name, name) == 0) {
            return i;
        }
    }
    return -1;
}

double rrr_param_get(const rrr_model *m, size_t i)
{
    if (m == NULL || i >= RRR_N_PARAMS) {
        return (double)NAN;
    }
    double v;
    memcpy(&v, (const char *)m + params[i].offset, sizeof v);
    return v;
}

rrr_status rrr_param_set(rrr_model *m, size_t i, double value)
{
    if (m == NULL || i >= RRR_N_PARAMS || !isfinite(value)) {
        return RRR_BAD_INPUT;
    }
    memcpy((char *)m + params[i].offset, &value, sizeof value);
    return RRR_OK;
}

int rrr_param_in_range(size_t i, double value)
{
    if (i >= RRR_N_PARAMS || !isfinite(value)) {
        return 0;
    }
    switch (params[i].bound) {
    case RRR_PARAM_ANY:
        return 1;
    case RRR_PARAM_NONNEG:
        return value >= 0.0;
    case RRR_PARAM_POS:
        return value > 0.0;
    }
    return 0;
}
