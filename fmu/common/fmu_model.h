/**
 * @file fmu_model.h
 * @brief The contract between the shared FMI glue (fmu/common) and one model (fmu/plant,
 *        fmu/controller), in the shape of the Reference-FMUs' include/model.h.
 *
 * A model provides exactly one constant descriptor, FMU_MODEL: its identifier, its variable
 * table, its continuous states and four hooks. The glue does everything else, for FMI 2.0 and
 * FMI 3.0, Co-Simulation and Model Exchange alike: the state machines, argument checks, logging,
 * get/set by value reference through the table, the instantiation token, FMU state snapshots,
 * and the modelDescription.xml, buildDescription.xml and documentation (fmu_xml.c prints them
 * from the same table, so value references, names, units and start values have one source of
 * truth).
 *
 * This header is independent of the FMI version: fmi2_functions.c and fmi3_functions.c adapt it
 * to one version each, and one FMU binary links exactly one of them.
 *
 * Rules the glue derives from the table (never written per variable):
 *  - initial: "exact" for parameters and inputs (start = the value after set_defaults),
 *    "calculated" for outputs (no start; listed in InitialUnknowns);
 *  - settable: inputs in Instantiated, InitializationMode, StepMode (Co-Simulation), EventMode
 *    and ContinuousTimeMode (Model Exchange); fixed parameters in Instantiated and
 *    InitializationMode; tunable parameters also in StepMode and EventMode; outputs and the
 *    independent variable never;
 *  - every Real must be finite: a NaN or Inf set is refused and the old value kept.
 */
#ifndef FMU_MODEL_H
#define FMU_MODEL_H

/* Windows (mingw-w64): the C99 printf family, so that %zu and %.17g mean the same as on Linux;
 * the instantiation token hashes start values printed with %.17g. Every file of the glue and of
 * the models includes this header before any system header. */
#if defined(__MINGW32__) && !defined(__USE_MINGW_ANSI_STDIO)
#define __USE_MINGW_ANSI_STDIO 1
#endif

#include <stddef.h>
#include <stdint.h>

/** @brief A value reference (fmi2ValueReference and fmi3ValueReference are both 32-bit). */
typedef uint32_t fmu_vr;

/** @brief Internal status, ordered by severity; values equal the fmi2Status and fmi3Status ones. */
typedef enum fmu_status {
    FMU_OK = 0,       ///< fmi2OK, fmi3OK
    FMU_WARNING = 1,  ///< fmi2Warning, fmi3Warning
    FMU_DISCARD = 2,  ///< fmi2Discard, fmi3Discard: this step cannot be taken, the state is unchanged
    FMU_ERROR = 3,    ///< fmi2Error, fmi3Error
    FMU_FATAL = 4     ///< fmi2Fatal, fmi3Fatal
} fmu_status;

/** @brief The interface type of an instance. */
typedef enum fmu_interface {
    FMU_CO_SIMULATION = 0,            ///< the FMU integrates itself (doStep)
    FMU_MODEL_EXCHANGE = 1            ///< the importer integrates the continuous states
} fmu_interface;

/**
 * @brief States of the FMI state machines, as bits (FMI 2.0.4 sections 3.2.3 and 4.2.4, FMI 3.0
 *        sections 3.2 and 4.2). One set for both versions and both interfaces: a state that an
 *        interface never enters is simply never set. Names differ by version where the standard
 *        renamed them (fmu_state_name).
 */
typedef enum fmu_state {
    FMU_START_END = 1u << 0,          ///< before instantiation / after fmiXFreeInstance
    FMU_INSTANTIATED = 1u << 1,       ///< after instantiation or fmiXReset
    FMU_INIT_MODE = 1u << 2,          ///< between fmiXEnter- and fmiXExitInitializationMode
    FMU_EVENT_MODE = 1u << 3,         ///< Model Exchange: event mode
    FMU_CONT_TIME_MODE = 1u << 4,     ///< Model Exchange: continuous-time mode
    FMU_STEP_MODE = 1u << 5,          ///< Co-Simulation: "StepComplete" (FMI 2), "StepMode" (FMI 3)
    FMU_STEP_IN_PROGRESS = 1u << 6,   ///< FMI 2 asynchronous step (never entered: synchronous doStep)
    FMU_STEP_FAILED = 1u << 7,        ///< doStep discarded: "StepFailed" (FMI 2), "StepDiscarded" (FMI 3)
    FMU_STEP_CANCELED = 1u << 8,      ///< FMI 2 fmi2CancelStep (never entered)
    FMU_TERMINATED = 1u << 9,         ///< after fmiXTerminate
    FMU_ERROR_STATE = 1u << 10,       ///< a model hook returned an error
    FMU_FATAL_STATE = 1u << 11        ///< a model hook returned a fatal status
} fmu_state;

/** Number of fmu_state bits. */
#define FMU_STATE_COUNT 12

/** @brief Base type of a variable. */
typedef enum fmu_type { FMU_REAL, FMU_BOOLEAN } fmu_type;

/** @brief Causality of a variable (the subset this project uses). */
typedef enum fmu_causality {
    FMU_PARAMETER,
    FMU_INPUT,
    FMU_OUTPUT,
    FMU_INDEPENDENT                   ///< the time; its value is the instance's time
} fmu_causality;

/** @brief Variability of a variable (the subset this project uses). */
typedef enum fmu_variability { FMU_FIXED, FMU_TUNABLE, FMU_CONTINUOUS } fmu_variability;

/** @brief One row of a model's variable table. */
typedef struct fmu_variable {
    fmu_vr vr;                        ///< value reference = row index (fmu_model_check)
    fmu_type type;                    ///< Real (double in the data) or Boolean (int in the data)
    fmu_causality causality;          ///< parameter, input, output or independent
    fmu_variability variability;      ///< fixed or tunable (parameters), continuous (the others)
    const char *name;                 ///< structured name, e.g. "u[1]", "f[2,3]", "tip.x"
    const char *description;          ///< one line, no '"', '<', '&' or '#'
    const char *unit;                 ///< unit name declared in fmu_units (fmu_table.c), or NULL
    size_t offset;                    ///< byte offset of the value in the model data (unused for
                                      ///< the independent variable)
} fmu_variable;

/** @brief One continuous state (Model Exchange): a variable and the variable that is its derivative. */
typedef struct fmu_continuous_state {
    fmu_vr state;                     ///< value reference of the state, e.g. q[1]
    fmu_vr derivative;                ///< value reference of d(state)/dt, e.g. qd[1]
    double nominal;                   ///< magnitude for the solver's error scaling, > 0
} fmu_continuous_state;

typedef struct fmu_instance fmu_instance;
struct fmu_bus; /* fmu_bus.h: a CAN network terminal (FMI-LS-BUS), FMI 3.0 Co-Simulation only */

/**
 * @brief How an unknown depends on a known (the ModelStructure's dependenciesKind, FMI 2.0 and
 *        3.0 alike); FMU_DEP_NONE: not at all. The order is not a ranking.
 */
typedef enum fmu_dependency {
    FMU_DEP_NONE = 0,       ///< no dependency (not listed)
    FMU_DEP_DEPENDENT = 1,  ///< "dependent": no particular structure, f(v)
    FMU_DEP_CONSTANT,       ///< "constant": a constant factor, c v
    FMU_DEP_FIXED,          ///< "fixed": a factor that depends on fixed parameters only
    FMU_DEP_TUNABLE         ///< "tunable": a factor that depends on tunable parameters only
} fmu_dependency;

/**
 * @brief Where a model's partials hook writes: the partial derivatives of the unknowns (outputs
 *        and state derivatives) with respect to the knowns (inputs and continuous states), a
 *        dense matrix the glue owns (zeros before the hook runs). Write through fmu_partial_set.
 */
typedef struct fmu_partials {
    double *J;                        ///< n_rows x n_cols, row-major: J[row * n_cols + col]
    const int *row;                   ///< row of value reference vr, or -1 (n_vars entries)
    const int *col;                   ///< column of value reference vr, or -1 (n_vars entries)
    size_t n_vars;                    ///< entries of row and col (the table's rows)
    size_t n_cols;                    ///< number of knowns
    int parameters;                   ///< nonzero in Initialization Mode: the Real parameters
                                      ///< are knowns too (their columns exist)
} fmu_partials;

/** @brief J[unknown][known] = value; ignored unless unknown is an unknown and known a known. */
void fmu_partial_set(fmu_partials *P, fmu_vr unknown, fmu_vr known, double value);

/** Size of an instantiation token (GUID) buffer including the terminating NUL. */
#define FMU_TOKEN_SIZE 39

/** @brief What one model provides to the glue. */
typedef struct fmu_model {
    const char *identifier;           ///< modelIdentifier = file name of the binary, e.g. "rrr_plant"
    const char *description;          ///< one-line model description for the XML
    const fmu_variable *vars;         ///< the variable table
    size_t n_vars;                    ///< number of rows
    const fmu_continuous_state *states; ///< continuous states (Model Exchange), or NULL
    size_t n_states;                  ///< number of continuous states
    size_t data_size;                 ///< sizeof the model data (plain old data, no pointers)
    double default_stop_time;         ///< DefaultExperiment stopTime, s
    double default_step_size;         ///< DefaultExperiment stepSize (communication step), s
    double default_tolerance;         ///< DefaultExperiment tolerance (Model Exchange solvers)

    /** Fill the data with the start values (called at instantiate, reset, and by the XML generator). */
    fmu_status (*set_defaults)(void *data);
    /** ExitInitializationMode: validate parameters (log which one is wrong), set up the state. */
    fmu_status (*initialize)(fmu_instance *inst);
    /** Bring every output (and state derivative) up to date with the inputs, states and parameters. */
    fmu_status (*calculate)(fmu_instance *inst);
    /** Co-Simulation: advance by h > 0 seconds; FMU_DISCARD leaves the data as it was. Outputs
     *  up to date on FMU_OK. */
    fmu_status (*do_step)(fmu_instance *inst, double h);
    /** How unknown (an output or a state derivative) depends directly on known (an input or a
     *  continuous state), an fmu_dependency (1 = FMU_DEP_DEPENDENT, 0 = none): the
     *  ModelStructure's dependencies and dependenciesKind of Outputs and Derivatives. */
    int (*depends)(fmu_vr unknown, fmu_vr known);
    /** Optional (NULL: the InitialUnknowns list no dependencies, i.e. on every known): the same
     *  in Initialization Mode, where the knowns are the inputs and the parameters (initial =
     *  exact); the kinds allowed there are FMU_DEP_DEPENDENT and FMU_DEP_CONSTANT. */
    int (*depends_initial)(fmu_vr unknown, fmu_vr known);
    /** Optional (NULL: no directional or adjoint derivatives; the capability flags say so):
     *  the partial derivatives of every unknown with respect to every known at the current
     *  values (in Initialization Mode: the start values, and the knowns include the Real
     *  parameters, P->parameters), written with fmu_partial_set; entries not written are 0.
     *  Exact, not finite differences: what fmiXGetDirectionalDerivative and
     *  fmi3GetAdjointDerivative multiply with the seed. */
    fmu_status (*partials)(fmu_instance *inst, fmu_partials *P);
    /** Optional (NULL: none): free what the model keeps in fmu_instance.work (memory outside
     *  the model data, e.g. a table read from resources/) and set work to NULL; called at
     *  reset and when the instance is freed. */
    void (*release)(fmu_instance *inst);
    /** Optional (NULL: the glue's checks only): check the model data of an FMU state before
     *  SetFMUstate or DeSerializeFMUstate accepts it. The glue has already checked the header,
     *  the checksum, the instance fields and every table row (Reals finite, Booleans 0 or 1);
     *  the hook checks what the table does not say: the fields outside the table (indices,
     *  counters, step-size memory), ranges, and, for a state in which the parameters have
     *  passed `initialize` (`state` after initialization), the parameters as `initialize`
     *  checks them. A checksum only detects accidents: every field is untrusted input. Logs the
     *  field at fault under function name fn and returns FMU_ERROR, or FMU_OK. */
    fmu_status (*check_state)(fmu_instance *inst, const void *data, fmu_state state,
                              const char *fn);
    /** Optional (NULL: none): the model's CAN network terminal of FMI-LS-BUS 1.0 (fmu_bus.h).
     *  A model with one is built for FMI 3.0 Co-Simulation only, with event mode. */
    const struct fmu_bus *bus;
} fmu_model;

/** @brief 1 when an instance in machine state s has passed initialization (its parameters were
 *         accepted by the initialize hook): every state after ExitInitializationMode except
 *         the Error state (which a failed initialization enters too). */
static inline int fmu_state_initialized(fmu_state s)
{
    return (s & (FMU_EVENT_MODE | FMU_CONT_TIME_MODE | FMU_STEP_MODE | FMU_STEP_IN_PROGRESS |
                 FMU_STEP_FAILED | FMU_STEP_CANCELED | FMU_TERMINATED)) != 0u;
}

/** The one model linked into this binary (defined in fmu/<model>/model.c). */
extern const fmu_model FMU_MODEL;

/**
 * @brief How an instance talks to its importer; filled by the FMI adapter at instantiation.
 *        The core calls `log` and the allocator only, so it needs no FMI header.
 */
typedef struct fmu_host {
    /** Forwards one message to the importer's logger (set by the adapter; NULL: no logger). */
    void (*log)(const fmu_instance *inst, fmu_status status, const char *category,
                const char *message);
    void (*logger)(void);             ///< the importer's logger callback; the adapter casts it back
    void *env;                        ///< the importer's environment pointer for the logger
    void *(*alloc)(size_t n, size_t size); ///< zero-filling allocator (importer's or calloc)
    void (*release)(void *p);         ///< its deallocator
    /** The importer's resource location as it passed it (borrowed, may be NULL): a URI
     *  ("file:///C:/fmu/resources", FMI 2) or a path ending in a separator (FMI 3). */
    const char *resources;
    int resources_is_uri;             ///< nonzero: `resources` is a file URI (FMI 2)
} fmu_host;

/** @brief One instance. Models read `data`, `state` and `time`; everything else belongs to the glue. */
struct fmu_instance {
    const fmu_model *model;           ///< &FMU_MODEL
    fmu_host host;                    ///< importer callbacks (see fmu_host)
    int fmi_version;                  ///< 2 or 3: the adapter this instance was created by
    int event_mode_used;              ///< FMI 3.0 Co-Simulation with event mode (a model with a
                                      ///< bus terminal: eventModeUsed at instantiation)
    fmu_interface interface;          ///< Co-Simulation or Model Exchange
    char *name;                       ///< instance name (owned, allocated with host.alloc)
    fmu_state state;                  ///< exactly one bit
    unsigned log_mask;                ///< enabled log categories, bit i = fmu_log_categories[i]
    double time;                      ///< current time (communication point or ME time), s
    double start_time;                ///< from setup/enter initialization, s
    double stop_time;                 ///< when stop_time_defined, s
    int stop_time_defined;            ///< nonzero when stop_time applies
    int dirty;                        ///< nonzero: outputs may be stale (input/state/parameter set)
    char token[FMU_TOKEN_SIZE];       ///< the instantiation token (GUID) of this model
    void *data;                       ///< model data, data_size bytes (host.alloc)
    /** The FMU's resources/ folder as a local path ending in '/' (owned), or NULL when the
     *  importer passed no resource location or one that is not a local file URI. */
    char *resources;
    /** Memory the model owns outside `data` (host.alloc; freed by the model's release hook):
     *  not part of FMU state snapshots, which hold `data` only. NULL until the model sets it. */
    void *work;
    /** The payload (instance fields and data) of the last FMU state this instance validated in
     *  full (host.alloc, glue-owned; NULL: none): a state with exactly these bytes is accepted
     *  without validating it again (DeserializeFMUstate then SetFMUstate of the same bytes).
     *  Forgotten at reset (the model's tables may change). */
    unsigned char *valid_state;
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
#if defined(__MINGW32__) /* C99 printf: __USE_MINGW_ANSI_STDIO above */
__attribute__((format(gnu_printf, 4, 5)))
#elif defined(__GNUC__)
__attribute__((format(printf, 4, 5)))
#endif
void fmu_log(const fmu_instance *inst, fmu_status status, fmu_category category, const char *fmt,
             ...);

/** The name of FMI function NAME as the importer of inst called it, e.g.
 *  FMU_FN(inst, "DoStep") is "fmi2DoStep" or "fmi3DoStep" (for the models' messages). */
#define FMU_FN(inst, NAME) ((inst)->fmi_version == 3 ? "fmi3" NAME : "fmi2" NAME)

/** @brief Name of a state bit in the wording of FMI version 2 or 3 ("Instantiated", ...). */
const char *fmu_state_name(int fmi_version, fmu_state s);

/**
 * @brief Check a model descriptor: value references dense and equal to the row index, names
 *        unique, types, causality/variability combinations and units known, one independent
 *        variable, continuous states that name distinct Real variables.
 * @param[out] msg receives a static description of the first problem
 * @param[out] row receives the table row of the problem
 * @return 0 when the descriptor is sound
 */
int fmu_model_check(const fmu_model *m, const char **msg, size_t *row);

/**
 * @brief The instantiation token (GUID) of a model: a hash of its identifier and table (value
 *        references, names, types, causality, variability, units and start values), written
 *        like a GUID, "{xxxxxxxx-xxxx-xxxx-xxxx-xxxxxxxxxxxx}". The same for FMI 2 and 3: it
 *        names the model, not the binary.
 * @param[in]  data the model data after set_defaults (start values), data_size bytes
 * @param[out] out  at least FMU_TOKEN_SIZE bytes
 */
void fmu_model_token(const fmu_model *m, const void *data, char out[]);

/** @brief 64-bit FNV-1a hash of n bytes, continuing from h (start with FMU_FNV_OFFSET). */
uint64_t fmu_fnv1a(uint64_t h, const void *bytes, size_t n);

/** FNV-1a 64-bit offset basis. */
#define FMU_FNV_OFFSET 14695981039346656037ull

/** @brief Address of the value of row v in data (double for Real, int for Boolean). */
static inline void *fmu_var_ptr(void *data, const fmu_variable *v)
{
    return (char *)data + v->offset;
}

/** One row of a model's table: value reference VR, the type, causality and variability, the
 *  name, description and unit, and the value at member MEMBER of the model data type T. */
#define FMU_ROW(VR, TYPE, CAUS, VARIAB, NAME, DESC, UNIT, T, MEMBER)                          \
    {(VR), TYPE, CAUS, VARIAB, NAME, DESC, UNIT, offsetof(T, MEMBER)}

/** A fixed Real parameter (a row of FMU_ROW). */
#define FMU_PARAM(VR, NAME, DESC, UNIT, T, MEMBER)                                            \
    FMU_ROW(VR, FMU_REAL, FMU_PARAMETER, FMU_FIXED, NAME, DESC, UNIT, T, MEMBER)

/** The row of the independent variable "time" (value reference VR), last in every table. */
#define FMU_TIME_ROW(VR)                                                                      \
    {(VR), FMU_REAL, FMU_INDEPENDENT, FMU_CONTINUOUS, "time", "simulation time", "s", 0}

#endif /* FMU_MODEL_H */
