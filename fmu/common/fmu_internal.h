/**
 * @file fmu_internal.h
 * @brief Declarations shared by the files of fmu/common (not used by the models).
 */
#ifndef FMU_INTERNAL_H
#define FMU_INTERNAL_H

#include <stdint.h>

#include "fmu_model.h"

/** @brief A unit of the XML's UnitDefinitions: name and exponents of the SI base units. */
typedef struct fmu_unit {
    const char *name;                 ///< unit name used by fmu_variable.unit, e.g. "rad/s2"
    signed char kg, m, s, A, rad;     ///< exponents of kg, m, s, A, rad
} fmu_unit;

/** The units a variable may use. */
extern const fmu_unit fmu_units[];
/** Number of entries of fmu_units. */
extern const size_t fmu_n_units;

/** @brief The row of value reference vr, or NULL. */
const fmu_variable *fmu_find_var(const fmu_model *m, fmi2ValueReference vr);

/** @brief "Real" or "Boolean". */
const char *fmu_type_name(fmu_type t);
/** @brief "parameter", "input" or "output". */
const char *fmu_causality_name(fmu_causality c);
/** @brief "fixed", "tunable" or "continuous". */
const char *fmu_variability_name(fmu_variability v);

/** @brief States in which row v may be set (derived from its causality and variability). */
unsigned fmu_settable_states(const fmu_variable *v);

/**
 * @brief Write the names of the state bits in mask as "A|B|C" into buf (truncated to n bytes).
 */
void fmu_states_str(unsigned mask, char *buf, size_t n);

/** @brief 64-bit FNV-1a hash of n bytes, continuing from h (start with FMU_FNV_OFFSET). */
uint64_t fmu_fnv1a(uint64_t h, const void *bytes, size_t n);

/** FNV-1a 64-bit offset basis. */
#define FMU_FNV_OFFSET 14695981039346656037ull

/* ---- instances (fmu_instance.c) ---------------------------------------------------------- */

/** Log categories enabled in every new instance: warnings, discards, errors, fatals. */
#define FMU_LOG_DEFAULT_MASK                                                                 \
    ((1u << FMU_LOG_WARNING) | (1u << FMU_LOG_DISCARD) | (1u << FMU_LOG_ERROR) |              \
     (1u << FMU_LOG_FATAL))
/** Every log category. */
#define FMU_LOG_ALL_MASK ((1u << FMU_LOG_CATEGORY_COUNT) - 1u)

/** @brief fmi2Instantiate: check the arguments and token, allocate, set the start values. */
fmu_instance *fmu_create(fmi2String name, fmi2Type type, fmi2String guid,
                         const fmi2CallbackFunctions *functions, fmi2Boolean logging_on);
/** @brief fmi2FreeInstance. */
void fmu_destroy(fmu_instance *S);
/** @brief fmi2Reset: start values, state Instantiated, time 0. */
fmu_status fmu_reset_instance(fmu_instance *S);
/** @brief fmi2SetDebugLogging: all names are checked before anything changes. */
fmu_status fmu_set_logging(fmu_instance *S, fmi2Boolean on, size_t n, const fmi2String cats[]);

/** @brief 1 when one of the n value references is an output and the outputs are stale. */
int fmu_needs_update(const fmu_instance *S, const fmi2ValueReference vr[], size_t n);
/** @brief Recompute the outputs through the model's calculate hook (if stale). */
fmu_status fmu_update(fmu_instance *S);
/** @brief Read n values of type t (double or fmi2Boolean array); refuses unknown or mistyped vrs. */
fmu_status fmu_get_values(fmu_instance *S, const char *fn, fmu_type t,
                          const fmi2ValueReference vr[], size_t n, void *values);
/**
 * @brief Write n values of type t. Every value is checked first (known, right type, settable in
 *        this state, finite); if any is refused, nothing is written.
 */
fmu_status fmu_set_values(fmu_instance *S, const char *fn, fmu_type t,
                          const fmi2ValueReference vr[], size_t n, const void *values);

/* ---- FMU state snapshots (fmu_instance.c) -------------------------------------------------- */

/** @brief fmi2GetFMUstate: copy the instance into a new snapshot or overwrite *state. */
fmu_status fmu_snapshot_get(fmu_instance *S, fmi2FMUstate *state);
/** @brief fmi2SetFMUstate: check the snapshot (magic, version, model, size, checksum), restore. */
fmu_status fmu_snapshot_set(fmu_instance *S, fmi2FMUstate state);
/** @brief fmi2FreeFMUstate: free *state (NULL is fine) and set it to NULL. */
fmu_status fmu_snapshot_free(fmu_instance *S, fmi2FMUstate *state);
/** @brief fmi2SerializedFMUstateSize. */
fmu_status fmu_snapshot_size(fmu_instance *S, fmi2FMUstate state, size_t *size);
/** @brief fmi2SerializeFMUstate: the snapshot bytes, header included. */
fmu_status fmu_snapshot_serialize(fmu_instance *S, fmi2FMUstate state, fmi2Byte buf[],
                                  size_t size);
/** @brief fmi2DeSerializeFMUstate: check the bytes like fmu_snapshot_set, then copy. */
fmu_status fmu_snapshot_deserialize(fmu_instance *S, const fmi2Byte buf[], size_t size,
                                    fmi2FMUstate *state);

#endif /* FMU_INTERNAL_H */
