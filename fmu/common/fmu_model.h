/**
 * @file fmu_model.h
 * @brief The contract between the shared FMI 2.0 co-simulation glue (fmu/common) and one model
 *        (fmu/plant, fmu/controller), in the shape of the Reference-FMUs' include/model.h.
 *
 * A model provides exactly one constant descriptor, FMU_MODEL: its identifier, its variable
 * table and four hooks. The glue does everything else: the FMI state machine, argument checks,
 * logging, get/set by value reference through the table, the GUID, FMU state snapshots and the
 * modelDescription.xml (fmu_xml.c prints it from the same table, so value references, names,
 * units and start values have one source of truth).
 *
 * Rules the glue derives from the table (never written per variable):
 *  - initial: "exact" for parameters and inputs (start = the value after set_defaults),
 *    "calculated" for outputs (no start; listed in InitialUnknowns);
 *  - settable: inputs in Instantiated, InitializationMode and StepComplete; fixed parameters in
 *    Instantiated and InitializationMode; tunable parameters also in StepComplete; outputs never;
 *  - every Real must be finite: a NaN or Inf set is refused and the old value kept.
 */
#ifndef FMU_MODEL_H
#define FMU_MODEL_H

#include <stddef.h>

#include "fmi2Functions.h"

/** @brief Internal status, ordered by severity; values equal the fmi2Status ones. */
typedef enum fmu_status {
    FMU_OK = 0,       ///< fmi2OK
    FMU_WARNING = 1,  ///< fmi2Warning
    FMU_DISCARD = 2,  ///< fmi2Discard: this step cannot be taken, the state is unchanged
    FMU_ERROR = 3,    ///< fmi2Error
    FMU_FATAL = 4     ///< fmi2Fatal
} fmu_status;

/** @brief States of the FMI 2.0 co-simulation state machine (FMI 2.0.4 section 4.2.4), as bits. */
typedef enum fmu_state {
    FMU_START_END = 1u << 0,          ///< before fmi2Instantiate / after fmi2FreeInstance
    FMU_INSTANTIATED = 1u << 1,       ///< after fmi2Instantiate or fmi2Reset
    FMU_INIT_MODE = 1u << 2,          ///< between fmi2Enter- and fmi2ExitInitializationMode
    FMU_STEP_COMPLETE = 1u << 3,      ///< initialized, or the last fmi2DoStep succeeded
    FMU_STEP_IN_PROGRESS = 1u << 4,   ///< asynchronous step (never entered: synchronous doStep)
    FMU_STEP_FAILED = 1u << 5,        ///< the last fmi2DoStep returned fmi2Discard
    FMU_STEP_CANCELED = 1u << 6,      ///< fmi2CancelStep was called (never entered)
    FMU_TERMINATED = 1u << 7,         ///< after fmi2Terminate
    FMU_ERROR_STATE = 1u << 8,        ///< a model hook returned fmi2Error
    FMU_FATAL_STATE = 1u << 9         ///< a model hook returned fmi2Fatal
} fmu_state;

/** Number of fmu_state bits. */
#define FMU_STATE_COUNT 10

/** @brief Base type of a variable. */
typedef enum fmu_type { FMU_REAL, FMU_BOOLEAN } fmu_type;

/** @brief Causality of a variable (the subset this project uses). */
typedef enum fmu_causality { FMU_PARAMETER, FMU_INPUT, FMU_OUTPUT } fmu_causality;

/** @brief Variability of a variable (the subset this project uses). */
typedef enum fmu_variability { FMU_FIXED, FMU_TUNABLE, FMU_CONTINUOUS } fmu_variability;

/** @brief One row of a model's variable table. */
typedef struct fmu_variable {
    fmi2ValueReference vr;            ///< value reference = row index (fmu_model_check)
    fmu_type type;                    ///< Real (double in the data) or Boolean (int in the data)
    fmu_causality causality;          ///< parameter, input or output
    fmu_variability variability;      ///< fixed or tunable (parameters), continuous (inputs, outputs)
    const char *name;                 ///< structured name, e.g. "u[1]", "f[2,3]", "tip.x"
    const char *description;          ///< one line, no '"', '<' or '&'
    const char *unit;                 ///< unit name declared in fmu_units (fmu_xml.c), or NULL
    size_t offset;                    ///< byte offset of the value in the model data
} fmu_variable;

typedef struct fmu_instance fmu_instance;

/** Size of an instantiation token (GUID) buffer including the terminating NUL. */
#define FMU_TOKEN_SIZE 39

/** @brief What one model provides to the glue. */
typedef struct fmu_model {
    const char *identifier;           ///< modelIdentifier = file name of the binary, e.g. "rrr_plant"
    const char *description;          ///< one-line model description for the XML
    const fmu_variable *vars;         ///< the variable table
    size_t n_vars;                    ///< number of rows
    size_t data_size;                 ///< sizeof the model data (plain old data, no pointers)
    double default_stop_time;         ///< DefaultExperiment stopTime, s
    double default_step_size;         ///< DefaultExperiment stepSize (communication step), s

    /** Fill the data with the start values (called at instantiate, reset, and by the XML generator). */
    fmu_status (*set_defaults)(void *data);
    /** fmi2ExitInitializationMode: validate parameters (log which one is wrong), set up the state. */
    fmu_status (*initialize)(fmu_instance *inst);
    /** Bring every output up to date with the current inputs and parameters. */
    fmu_status (*calculate)(fmu_instance *inst);
    /** Advance by h > 0 seconds; FMU_DISCARD leaves the data as it was. Outputs up to date on FMU_OK. */
    fmu_status (*do_step)(fmu_instance *inst, double h);
    /** 1 when output out_vr depends directly on input in_vr (ModelStructure/Outputs, XML only). */
    int (*depends)(fmi2ValueReference out_vr, fmi2ValueReference in_vr);
} fmu_model;

/** The one model linked into this binary (defined in fmu/<model>/model.c). */
extern const fmu_model FMU_MODEL;

/** @brief One instance. Models read `data`, `state` and `time`; everything else belongs to the glue. */
struct fmu_instance {
    const fmu_model *model;           ///< &FMU_MODEL
    fmi2CallbackFunctions cb;         ///< copy of the importer's callbacks
    char *name;                       ///< instance name (owned, allocated with cb.allocateMemory)
    fmu_state state;                  ///< exactly one bit
    unsigned log_mask;                ///< enabled log categories, bit i = fmu_log_categories[i]
    double time;                      ///< current communication point, s
    double start_time;                ///< from fmi2SetupExperiment, s
    double stop_time;                 ///< from fmi2SetupExperiment when stop_time_defined, s
    int stop_time_defined;            ///< nonzero when stop_time applies
    int dirty;                        ///< nonzero: outputs may be stale (input/parameter set)
    char token[FMU_TOKEN_SIZE];       ///< the instantiation token (GUID) of this model
    void *data;                       ///< model data, data_size bytes (cb.allocateMemory)
};

/** @brief Log categories declared in the XML, indices of fmu_instance.log_mask bits. */
typedef enum fmu_category {
    FMU_LOG_WARNING = 0,              ///< "logStatusWarning"
    FMU_LOG_DISCARD,                  ///< "logStatusDiscard"
    FMU_LOG_ERROR,                    ///< "logStatusError"
    FMU_LOG_FATAL,                    ///< "logStatusFatal"
    FMU_LOG_CALLS,                    ///< "logCalls": every FMI call with its arguments (debug)
    FMU_LOG_CATEGORY_COUNT
} fmu_category;

/** @brief Name and description of each category (the XML's LogCategories, in this order). */
typedef struct fmu_log_category {
    const char *name;                 ///< category name, e.g. "logStatusError"
    const char *description;          ///< one line for the XML
} fmu_log_category;

/** The declared categories, FMU_LOG_CATEGORY_COUNT entries; "logAll" is accepted as well. */
extern const fmu_log_category fmu_log_categories[FMU_LOG_CATEGORY_COUNT];

/**
 * @brief Log a message through the importer's logger if its category is enabled.
 *        Errors, discards, warnings and fatals are enabled by default.
 */
#if defined(__GNUC__)
__attribute__((format(printf, 4, 5)))
#endif
void fmu_log(const fmu_instance *inst, fmu_status status, fmu_category category, const char *fmt,
             ...);

/** @brief Name of a state bit ("Instantiated", ...). */
const char *fmu_state_name(fmu_state s);

/**
 * @brief Check a model descriptor: value references dense and equal to the row index, names
 *        unique, types, causality/variability combinations and units known.
 * @param[out] msg receives a static description of the first problem
 * @param[out] row receives the table row of the problem
 * @return 0 when the descriptor is sound
 */
int fmu_model_check(const fmu_model *m, const char **msg, size_t *row);

/**
 * @brief The instantiation token (GUID) of a model: a hash of its identifier and table (value
 *        references, names, types, causality, variability, units and start values), written
 *        like a GUID, "{xxxxxxxx-xxxx-xxxx-xxxx-xxxxxxxxxxxx}".
 * @param[in]  data the model data after set_defaults (start values), data_size bytes
 * @param[out] out  at least FMU_TOKEN_SIZE bytes
 */
void fmu_model_token(const fmu_model *m, const void *data, char out[]);

/** @brief Address of the value of row v in data (double for Real, int for Boolean). */
static inline void *fmu_var_ptr(void *data, const fmu_variable *v)
{
    return (char *)data + v->offset;
}

#endif /* FMU_MODEL_H */
