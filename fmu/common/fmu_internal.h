/**
 * @file fmu_internal.h
 * @brief Declarations shared by the files of fmu/common (not used by the models). Independent of
 *        the FMI version: the adapters (fmi2_functions.c, fmi3_functions.c) translate.
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

/** The optional file of start values in the FMU's resources/ (CSV "name,value"), applied at
 *  instantiation and reset over the compiled ones: written by tools that ship an FMU for one
 *  system (rrr ssp), so that an importer that sets no parameter runs that system. */
#define FMU_START_FILE "start_values.csv"
/** Its largest size in bytes and its longest line in characters. */
#define FMU_START_FILE_MAX 65536
#define FMU_START_LINE_MAX 256

/** @brief The row of value reference vr, or NULL. */
const fmu_variable *fmu_find_var(const fmu_model *m, fmu_vr vr);

/** @brief "Real" or "Boolean". */
const char *fmu_type_name(fmu_type t);
/** @brief "parameter", "input", "output" or "independent". */
const char *fmu_causality_name(fmu_causality c);
/** @brief "fixed", "tunable" or "continuous". */
const char *fmu_variability_name(fmu_variability v);

/** @brief States in which row v may be set (derived from its causality and variability). */
unsigned fmu_settable_states(const fmu_variable *v);

/** @brief Index in m->states of the continuous state with value reference vr, or -1. */
int fmu_state_index(const fmu_model *m, fmu_vr vr);

/** @brief Index in m->states of the state whose derivative has value reference vr, or -1. */
int fmu_derivative_index(const fmu_model *m, fmu_vr vr);

/**
 * @brief Write the names of the state bits in mask as "A|B|C" (FMI version's wording) into buf
 *        (truncated to n bytes).
 */
void fmu_states_str(int fmi_version, unsigned mask, char *buf, size_t n);

/* ---- instances (fmu_instance.c) ---------------------------------------------------------- */

/** Log categories enabled in every new instance: warnings, discards, errors, fatals. */
#define FMU_LOG_DEFAULT_MASK                                                                 \
    ((1u << FMU_LOG_WARNING) | (1u << FMU_LOG_DISCARD) | (1u << FMU_LOG_ERROR) |              \
     (1u << FMU_LOG_FATAL))
/** Every log category. */
#define FMU_LOG_ALL_MASK ((1u << FMU_LOG_CATEGORY_COUNT) - 1u)

/**
 * @brief Instantiate: check the arguments and token, allocate, set the start values.
 * @param fn  name of the calling FMI function, for messages
 * @return the instance, or NULL after logging the reason through host
 */
fmu_instance *fmu_create(const char *fn, const fmu_host *host, int fmi_version,
                         fmu_interface interface, const char *name, const char *token,
                         int logging_on);
/** @brief FreeInstance. */
void fmu_destroy(fmu_instance *S);
/** @brief Reset: start values, state Instantiated, time 0. */
fmu_status fmu_reset_instance(fmu_instance *S);
/** @brief SetDebugLogging: all names are checked before anything changes. */
fmu_status fmu_set_logging(fmu_instance *S, const char *fn, int on, size_t n,
                           const char *const cats[]);

/** @brief How Boolean values are laid out in the importer's array. */
typedef enum fmu_bool_layout {
    FMU_BOOL_INT,                     ///< int per value (fmi2Boolean)
    FMU_BOOL_C99                      ///< bool per value (fmi3Boolean)
} fmu_bool_layout;

/** @brief 1 when one of the n value references is an output and the outputs are stale. */
int fmu_needs_update(const fmu_instance *S, const fmu_vr vr[], size_t n);
/** @brief Recompute the outputs through the model's calculate hook (if stale). */
fmu_status fmu_update(fmu_instance *S);
/** @brief Read n values of type t (double array, or Booleans in layout bl); refuses unknown or
 *         mistyped value references. */
fmu_status fmu_get_values(fmu_instance *S, const char *fn, fmu_type t, const fmu_vr vr[],
                          size_t n, void *values, fmu_bool_layout bl);
/**
 * @brief Write n values of type t. Every value is checked first (known, right type, settable in
 *        this state, finite); if any is refused, nothing is written.
 */
fmu_status fmu_set_values(fmu_instance *S, const char *fn, fmu_type t, const fmu_vr vr[],
                          size_t n, const void *values, fmu_bool_layout bl);

/* ---- Model Exchange (fmu_instance.c) ------------------------------------------------------- */

/** @brief Set the time (finite); outputs go stale. */
fmu_status fmu_me_set_time(fmu_instance *S, const char *fn, double t);
/** @brief Copy the n continuous states into x (n must equal the model's count). */
fmu_status fmu_me_get_states(fmu_instance *S, const char *fn, double x[], size_t n);
/** @brief Set the n continuous states (all finite, n = the model's count; else nothing changes). */
fmu_status fmu_me_set_states(fmu_instance *S, const char *fn, const double x[], size_t n);
/** @brief FMU_OK when n equals the number of continuous states; logs and FMU_ERROR otherwise. */
fmu_status fmu_me_check_count(fmu_instance *S, const char *fn, size_t n);
/** @brief The n state derivatives at the current time, states and inputs (n checked before:
 *         fmu_me_check_count); a failure is the model's (the calculate hook). */
fmu_status fmu_me_get_derivatives(fmu_instance *S, double dx[], size_t n);
/** @brief The n nominal values of the continuous states. */
fmu_status fmu_me_get_nominals(fmu_instance *S, const char *fn, double nominals[], size_t n);
/** @brief Event indicators: the model has none, so n must be 0. */
fmu_status fmu_me_get_event_indicators(fmu_instance *S, const char *fn, size_t n);

/* ---- partial derivatives (fmu_derivative.c) --------------------------------------------------- */

/**
 * @brief fmiXGetDirectionalDerivative (adjoint = 0: sensitivity = J seed, n_seed = nk,
 *        n_sensitivity = nu) and fmi3GetAdjointDerivative (adjoint = 1: sensitivity = J^T seed,
 *        n_seed = nu, n_sensitivity = nk), J = d unknowns / d knowns from the model's partials
 *        hook. Refused (FMU_ERROR, nothing written): no hook; an unknown that is not an output
 *        or state derivative of type Real, a known that is not an input or continuous state of
 *        type Real (in Initialization Mode a Real parameter is a known too), an unknown value
 *        reference, a seed that is not finite, wrong counts. A failure of the hook is the model's (FMU_ERROR from the hook).
 */
fmu_status fmu_get_derivative(fmu_instance *S, const char *fn, int adjoint,
                              const fmu_vr unknowns[], size_t nu, const fmu_vr knowns[],
                              size_t nk, const double seed[], size_t n_seed,
                              double sensitivity[], size_t n_sensitivity);

/** @brief 1 when vr is an unknown of the partial derivatives: a Real output (the state
 *         derivatives of these models are outputs too). */
int fmu_is_unknown(const fmu_model *m, const fmu_variable *v);

/** @brief 1 when vr is a known of the partial derivatives: a Real input or continuous state,
 *         and in Initialization Mode (init nonzero) also a Real parameter. */
int fmu_is_known(const fmu_model *m, const fmu_variable *v, int init);

/* ---- FMU state snapshots (fmu_instance.c) -------------------------------------------------- */

/** @brief GetFMUstate: copy the instance into a new snapshot or overwrite *state. */
fmu_status fmu_snapshot_get(fmu_instance *S, const char *fn, void **state);
/** @brief SetFMUstate: check the snapshot (magic, version, model, size, checksum), restore. */
fmu_status fmu_snapshot_set(fmu_instance *S, const char *fn, const void *state);
/** @brief FreeFMUstate: free *state (NULL is fine) and set it to NULL. */
fmu_status fmu_snapshot_free(fmu_instance *S, const char *fn, void **state);
/** @brief SerializedFMUstateSize. */
fmu_status fmu_snapshot_size(fmu_instance *S, const char *fn, const void *state, size_t *size);
/** @brief SerializeFMUstate: the snapshot bytes, header included. */
fmu_status fmu_snapshot_serialize(fmu_instance *S, const char *fn, const void *state,
                                  unsigned char buf[], size_t size);
/** @brief DeSerializeFMUstate: check the bytes like fmu_snapshot_set, then copy. */
fmu_status fmu_snapshot_deserialize(fmu_instance *S, const char *fn, const unsigned char buf[],
                                    size_t size, void **state);

/* ---- shared checks of the adapters (fmu_instance.c) ----------------------------------------- */

/**
 * @brief 1 when the instance's state is in mask; otherwise logs "<fn>: illegal call sequence:
 *        not allowed in state X (allowed in: ...)" in the FMI version's wording and returns 0.
 */
int fmu_allowed_state(fmu_instance *S, unsigned mask, const char *fn);

/** The state mask of a function of one interface type: its mask in an instance of that type, no
 *  state at all in an instance of the other (the states Instantiated, InitializationMode,
 *  Terminated and Error are shared, so the masks alone cannot keep the interfaces apart). */
#define FMU_ME_ONLY(inst, mask) ((inst)->interface == FMU_MODEL_EXCHANGE ? (unsigned)(mask) : 0u)
#define FMU_CS_ONLY(inst, mask) ((inst)->interface == FMU_CO_SIMULATION ? (unsigned)(mask) : 0u)

/** Relative tolerance on a communication point (importers count time differently). */
#define FMU_TIME_RTOL 1e-9

/**
 * @brief Check the arguments of a co-simulation step: h finite and > 0, t equal to the FMU
 *        time (FMU_TIME_RTOL), not past the stop time. Logs and returns FMU_ERROR otherwise.
 */
fmu_status fmu_check_step(fmu_instance *S, const char *fn, double t, double h);

/**
 * @brief Check the tolerance of setup or initialization: when defined (a nonzero `defined`) it
 *        must be finite and > 0 (the models iterate nothing, so its value is not used); an
 *        undefined one is ignored, as the standard says. Logs and returns FMU_ERROR otherwise.
 */
fmu_status fmu_check_tolerance(fmu_instance *S, const char *fn, int defined, double tolerance);

/**
 * @brief Check a start/stop time pair of setup or initialization, then store it and set the time.
 */
fmu_status fmu_setup_experiment(fmu_instance *S, const char *fn, double start, int stop_defined,
                                double stop);

/**
 * @brief Take a co-simulation step through the model's hook: FMU_DISCARD moves to StepFailed
 *        (time unchanged), FMU_ERROR/FMU_FATAL to the Error/Fatal state; on success the time
 *        becomes t + h (the master's clock is authoritative) and the outputs are up to date.
 */
fmu_status fmu_do_step(fmu_instance *S, double t, double h);

/** @brief ExitInitializationMode: initialize hook, then StepMode (CS) or EventMode (ME). */
fmu_status fmu_exit_initialization(fmu_instance *S);

#endif /* FMU_INTERNAL_H */
