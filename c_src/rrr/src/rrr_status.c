/* Status names and the library's version string. */
#include "rrr/rrr_status.h"
#include "rrr/rrr_version.h"

const char *rrr_status_str(rrr_status s)
{
    switch (s) {
    case RRR_OK: return "RRR_OK";
    case RRR_BAD_INPUT: return "RRR_BAD_INPUT";
    case RRR_BAD_MODEL: return "RRR_BAD_MODEL";
    case RRR_NOT_POSITIVE_DEFINITE: return "RRR_NOT_POSITIVE_DEFINITE";
    case RRR_UNREACHABLE: return "RRR_UNREACHABLE";
    case RRR_SINGULAR: return "RRR_SINGULAR";
    case RRR_NUMERIC: return "RRR_NUMERIC";
    case RRR_TOO_STIFF: return "RRR_TOO_STIFF";
    }
    return "RRR_UNKNOWN_STATUS";
}

const char *rrr_version(void)
{
    return RRR_VERSION_STRING;
}
