/**
 * @file rrr_status.h
 * @brief Status codes returned by every function of the core.
 */
#ifndef RRR_STATUS_H
#define RRR_STATUS_H

#ifdef __cplusplus
extern "C" {
#endif

/** Marks the public functions of librrr: exported (default visibility) when the shared library
 *  is built (RRR_BUILDING_LIBRARY, set by CMake); plain declarations everywhere else, e.g. when
 *  the sources are compiled into an FMU binary, which exports only the FMI functions. */
#if defined(RRR_BUILDING_LIBRARY) && (defined(__GNUC__) || defined(__clang__)) && !defined(_WIN32)
#define RRR_API __attribute__((visibility("default")))
#else
#define RRR_API
#endif

/** @brief Result of a core call; outputs are written only when the status is RRR_OK. */
typedef enum rrr_status {
    RRR_OK = 0,                 ///< success, outputs written
    RRR_BAD_INPUT = 1,          ///< NULL pointer, NaN/Inf or out-of-range argument; outputs untouched
    RRR_BAD_MODEL = 2,          ///< a model parameter is non-finite or out of range; outputs untouched
    RRR_NOT_POSITIVE_DEFINITE = 3, ///< inertia matrix D(q) not positive definite; outputs untouched
    RRR_UNREACHABLE = 4,        ///< IK target outside the workspace; outputs untouched
    RRR_SINGULAR = 5,           ///< singular configuration where a unique answer does not exist; outputs untouched
    RRR_NUMERIC = 6,            ///< a result would be non-finite (e.g. the integration diverged); outputs untouched
    RRR_TOO_STIFF = 7           ///< the plant is too stiff for its integrator at a bounded cost
                                ///< (rrr_plant_stiffness); outputs untouched
} rrr_status;

/** Number of status codes. */
#define RRR_STATUS_COUNT 8

/** @brief Human-readable name of a status ("RRR_OK", ...); "RRR_UNKNOWN_STATUS" for other values. */
RRR_API const char *rrr_status_str(rrr_status s);

#ifdef __cplusplus
}
#endif
#endif /* RRR_STATUS_H */
