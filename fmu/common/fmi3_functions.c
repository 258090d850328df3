/*
 * The FMI 3.0 API (Co-Simulation and Model Exchange): a thin adapter over the version-neutral
 * instance of fmu_instance.c, the twin of fmi2_functions.c. Every function with an instance starts
 * with BEGIN_FUNCTION, which checks the instance and the state mask of the FMI 3.0 state
 * machines (sections 3.2 and 4.2), and ends in END_FUNCTION, the single exit.
 *
 * The same two kinds of failure as in FMI 2: a refusal (fmi3Error, a log message, nothing
 * changes) and a model failure (worst status kept; Discard from doStep moves to StepDiscarded,
 * Error to the Error state, Fatal to the Fatal state). Errors are logged by default, as in the
 * FMI 2 build; fmi3SetDebugLogging switches categories off and on.
 *
 * Not provided (capability flags false or absent in the XML): scheduled execution, intermediate
 * update, configuration mode, directional and adjoint derivatives where the model has none,
 * output derivatives, per-element dependencies, fmi3EvaluateDiscreteStates, and variables of any
 * type other than Float64, Boolean and, for a model with a CAN terminal, its Binary and Clock
 * variables. Event mode in Co-Simulation and the clocks (fmi3GetClock, fmi3SetClock,
 * fmi3GetIntervalDecimal) belong to a model with a CAN terminal (fmu_bus.h: the LS-BUS network
 * FMUs), instantiated with eventModeUsed; for the others each refuses with fmi3Error and says so.
 */
#include "fmu_adapter.h" /* first: see fmu_model.h */
#include "fmi3Functions.h"
#include "fmu_bus.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

_Static_assert(sizeof(fmi3ValueReference) == sizeof(fmu_vr), "value references are 32-bit");

/* ---- allowed states of every function ---------------------------------------------------------
 * FMI 3.0, state machines of sections 3.2 (Model Exchange) and 4.2 (Co-Simulation), in our state
 * bits (fmu_model.h): StepMode = FMU_STEP_MODE, StepDiscarded = FMU_STEP_FAILED. A mask of 0
 * marks a function whose states this FMU never enters (configuration mode, clock activation,
 * event mode in Co-Simulation): every call is an illegal call sequence.
 * The Model Exchange functions "can only be called in Model Exchange" and fmi3GetOutputDerivatives
 * is "not allowed in Model Exchange" (FMI 3.0, 2.3): ME_ONLY and CS_ONLY clear their masks for an
 * instance of the other interface type (evaluated in BEGIN_FUNCTION, where S is the instance).
 */

#define MASK_ANY_INSTANCE                                                                     \
    (FMU_INSTANTIATED | FMU_INIT_MODE | FMU_EVENT_MODE | FMU_CONT_TIME_MODE | FMU_STEP_MODE |  \
     FMU_STEP_FAILED | FMU_TERMINATED | FMU_ERROR_STATE)
#define MASK_GETTERS MASK_ANY_INSTANCE
#define MASK_AFTER_INIT                                                                       \
    (FMU_INIT_MODE | FMU_EVENT_MODE | FMU_CONT_TIME_MODE | FMU_STEP_MODE | FMU_STEP_FAILED |   \
     FMU_TERMINATED | FMU_ERROR_STATE)

/* common functions */
#define MASK_fmi3SetDebugLogging MASK_ANY_INSTANCE
#define MASK_fmi3FreeInstance MASK_ANY_INSTANCE
#define MASK_fmi3EnterInitializationMode FMU_INSTANTIATED
#define MASK_fmi3ExitInitializationMode FMU_INIT_MODE
/* Co-Simulation with event mode (a model with a CAN terminal, eventModeUsed): Event Mode after
 * initialization and whenever the importer enters it from Step Mode (fmu_bus.h) */
#define CS_EVENTS(mask) (S->event_mode_used ? (unsigned)(mask) : 0u)
#define MASK_fmi3EnterEventMode (FMU_CONT_TIME_MODE | CS_EVENTS(FMU_STEP_MODE))
#define MASK_fmi3Terminate (FMU_EVENT_MODE | FMU_CONT_TIME_MODE | FMU_STEP_MODE | FMU_STEP_FAILED)
#define MASK_fmi3Reset MASK_ANY_INSTANCE
#define MASK_fmi3GetFloat64 MASK_GETTERS
#define MASK_fmi3GetBoolean MASK_GETTERS
#define MASK_fmi3GetOther MASK_GETTERS
#define MASK_fmi3SetFloat64                                                                   \
    (FMU_INSTANTIATED | FMU_INIT_MODE | FMU_EVENT_MODE | FMU_CONT_TIME_MODE | FMU_STEP_MODE)
#define MASK_fmi3SetBoolean (FMU_INSTANTIATED | FMU_INIT_MODE | FMU_EVENT_MODE | FMU_STEP_MODE)
#define MASK_fmi3SetOther MASK_fmi3SetBoolean
#define MASK_fmi3GetBinary MASK_GETTERS
#define MASK_fmi3SetBinary MASK_fmi3SetOther
#define MASK_fmi3GetClock FMU_EVENT_MODE
#define MASK_fmi3SetClock FMU_EVENT_MODE
#define MASK_fmi3GetIntervalDecimal (FMU_INIT_MODE | FMU_EVENT_MODE)
#define MASK_fmi3GetNumberOfVariableDependencies MASK_ANY_INSTANCE
#define MASK_fmi3GetVariableDependencies MASK_ANY_INSTANCE
#define MASK_fmi3GetFMUState MASK_ANY_INSTANCE
#define MASK_fmi3SetFMUState MASK_ANY_INSTANCE
#define MASK_fmi3FreeFMUState MASK_ANY_INSTANCE
#define MASK_fmi3SerializedFMUStateSize MASK_ANY_INSTANCE
#define MASK_fmi3SerializeFMUState MASK_ANY_INSTANCE
#define MASK_fmi3DeserializeFMUState MASK_ANY_INSTANCE
#define MASK_fmi3GetDirectionalDerivative MASK_AFTER_INIT
#define MASK_fmi3GetAdjointDerivative MASK_AFTER_INIT
#define MASK_fmi3EnterConfigurationMode (FMU_INSTANTIATED | FMU_EVENT_MODE | FMU_STEP_MODE)
#define MASK_fmi3ExitConfigurationMode 0u
#define MASK_fmi3Clocks 0u
#define MASK_fmi3EvaluateDiscreteStates (FMU_EVENT_MODE | FMU_STEP_MODE)
#define MASK_fmi3UpdateDiscreteStates FMU_EVENT_MODE

/* model exchange functions */
#define MASK_fmi3EnterContinuousTimeMode FMU_EVENT_MODE
#define MASK_fmi3CompletedIntegratorStep FMU_CONT_TIME_MODE
/* lenient where the Reference-FMUs are, for importers tested against them: fmi3SetTime also in
 * EventMode (as in FMI 2.0) and the counts in every state; neither changes the model's state */
#define MASK_fmi3SetTime ME_ONLY(FMU_EVENT_MODE | FMU_CONT_TIME_MODE)
#define MASK_fmi3SetContinuousStates FMU_CONT_TIME_MODE
#define MASK_fmi3GetContinuousStateDerivatives                                                \
    ME_ONLY(FMU_INIT_MODE | FMU_EVENT_MODE | FMU_CONT_TIME_MODE | FMU_TERMINATED | FMU_ERROR_STATE)
#define MASK_fmi3GetEventIndicators MASK_fmi3GetContinuousStateDerivatives
#define MASK_fmi3GetContinuousStates MASK_fmi3GetContinuousStateDerivatives
#define MASK_fmi3GetNominalsOfContinuousStates MASK_fmi3GetContinuousStateDerivatives
#define MASK_fmi3GetNumberOfEventIndicators ME_ONLY(MASK_ANY_INSTANCE)
#define MASK_fmi3GetNumberOfContinuousStates ME_ONLY(MASK_ANY_INSTANCE)

/* co-simulation functions */
#define MASK_fmi3EnterStepMode CS_EVENTS(FMU_EVENT_MODE)
#define MASK_fmi3GetOutputDerivatives                                                         \
    CS_ONLY(FMU_STEP_MODE | FMU_STEP_FAILED | FMU_TERMINATED | FMU_ERROR_STATE)
#define MASK_fmi3DoStep FMU_STEP_MODE

/* scheduled execution */
#define MASK_fmi3ActivateModelPartition 0u

/* ---- the adapter macros (fmu_adapter.h) ------------------------------------------------------ */

/* MASK names the state mask; FN the function name in messages. */
#define BEGIN_FUNCTION_MASK(MASK, FN) FMU_BEGIN(instance, MASK, FN, fmi3Error)
#define BEGIN_FUNCTION(F) BEGIN_FUNCTION_MASK(MASK_fmi3##F, "fmi3" #F)
#define END_FUNCTION() FMU_END(fmi3Status)

/* Every variable is a scalar: nValues must equal nValueReferences. */
#define ASSERT_SCALARS(nvr, nValues)                                                          \
    do {                                                                                      \
        if ((nValues) != (nvr)) {                                                             \
            REFUSE("%s: nValues = %zu differs from nValueReferences = %zu (every variable of "  \
                   "%s is a scalar)",                                                         \
                   fn_, (size_t)(nValues), (size_t)(nvr), S->model->identifier);              \
        }                                                                                     \
    } while (0)

/* ---- inquire version, creation, destruction, debug logging ---------------------------------- */

const char *fmi3GetVersion(void)
{
    return fmi3Version;
}

static void host_log(const fmu_instance *S, fmu_status status, const char *category,
                     const char *message)
{
    const fmi3LogMessageCallback log_message = (fmi3LogMessageCallback)S->host.logger;
    if (log_message != NULL) {
        log_message(S->host.env, (fmi3Status)status, category, message);
    }
}

static fmu_host make_host(fmi3InstanceEnvironment env, fmi3LogMessageCallback log_message,
                          fmi3String resource_path)
{
    fmu_host host;
    memset(&host, 0, sizeof host);
    host.resources = resource_path; /* a path (FMI 3.0 section 2.3.1) */
    host.log = host_log;
    host.logger = (void (*)(void))log_message;
    host.env = env;
    host.alloc = calloc;
    host.release = free;
    return host;
}

/* An instantiation refused before an instance exists. */
static void refuse_early(const fmu_host *host, fmi3String name, const char *msg)
{
    fmu_instance tmp;
    memset(&tmp, 0, sizeof tmp);
    tmp.host = *host;
    tmp.fmi_version = 3;
    tmp.name = (char *)(name != NULL ? name : "?");
    tmp.log_mask = 1u << FMU_LOG_ERROR;
    fmu_log(&tmp, FMU_ERROR, FMU_LOG_ERROR, "%s", msg);
}

fmi3Instance fmi3InstantiateModelExchange(fmi3String instanceName, fmi3String instantiationToken,
                                          fmi3String resourcePath, fmi3Boolean visible,
                                          fmi3Boolean loggingOn,
                                          fmi3InstanceEnvironment instanceEnvironment,
                                          fmi3LogMessageCallback logMessage)
{
    (void)visible; /* no user interface */
    const fmu_host host = make_host(instanceEnvironment, logMessage, resourcePath);
    return fmu_create("fmi3InstantiateModelExchange", &host, 3, FMU_MODEL_EXCHANGE, instanceName,
                      instantiationToken, loggingOn);
}

fmi3Instance fmi3InstantiateCoSimulation(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3Boolean eventModeUsed,
    fmi3Boolean earlyReturnAllowed, const fmi3ValueReference requiredIntermediateVariables[],
    size_t nRequiredIntermediateVariables, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3IntermediateUpdateCallback intermediateUpdate)
{
    (void)visible;
    (void)earlyReturnAllowed; /* a permission: this FMU never returns early */
    (void)requiredIntermediateVariables;
    (void)intermediateUpdate;
    const fmu_host host = make_host(instanceEnvironment, logMessage, resourcePath);
    if (eventModeUsed && FMU_MODEL.bus == NULL) {
        refuse_early(&host, instanceName,
                     "fmi3InstantiateCoSimulation: eventModeUsed must be false (hasEventMode="
                     "false: the model has no events)");
        return NULL;
    }
    if (nRequiredIntermediateVariables > 0) {
        refuse_early(&host, instanceName,
                     "fmi3InstantiateCoSimulation: nRequiredIntermediateVariables must be 0 (no "
                     "intermediate update)");
        return NULL;
    }
    fmu_instance *S = fmu_create("fmi3InstantiateCoSimulation", &host, 3, FMU_CO_SIMULATION,
                                 instanceName, instantiationToken, loggingOn);
    if (S != NULL) {
        S->event_mode_used = eventModeUsed ? 1 : 0;
    }
    return S;
}

fmi3Instance fmi3InstantiateScheduledExecution(
    fmi3String instanceName, fmi3String instantiationToken, fmi3String resourcePath,
    fmi3Boolean visible, fmi3Boolean loggingOn, fmi3InstanceEnvironment instanceEnvironment,
    fmi3LogMessageCallback logMessage, fmi3ClockUpdateCallback clockUpdate,
    fmi3LockPreemptionCallback lockPreemption, fmi3UnlockPreemptionCallback unlockPreemption)
{
    (void)instantiationToken;
    (void)resourcePath;
    (void)visible;
    (void)loggingOn;
    (void)clockUpdate;
    (void)lockPreemption;
    (void)unlockPreemption;
    const fmu_host host = make_host(instanceEnvironment, logMessage, NULL);
    refuse_early(&host, instanceName,
                 "fmi3InstantiateScheduledExecution: not provided (the FMU implements Model "
                 "Exchange and Co-Simulation)");
    return NULL;
}

void fmi3FreeInstance(fmi3Instance instance)
{
    fmu_instance *S = (fmu_instance *)instance;
    if (S == NULL || !fmu_allowed_state(S, MASK_fmi3FreeInstance, "fmi3FreeInstance")) {
        return;
    }
    fmu_destroy(S);
}

fmi3Status fmi3SetDebugLogging(fmi3Instance instance, fmi3Boolean loggingOn, size_t nCategories,
                               const fmi3String categories[])
{
    BEGIN_FUNCTION(SetDebugLogging)
    TRACE("fmi3SetDebugLogging(loggingOn=%d, nCategories=%zu)", (int)loggingOn, nCategories);
    CHECKED(fmu_set_logging(S, fn_, loggingOn, nCategories, categories));
    END_FUNCTION()
}

/* ---- initialization, events, termination, reset ---------------------------------------------- */

fmi3Status fmi3EnterInitializationMode(fmi3Instance instance, fmi3Boolean toleranceDefined,
                                       fmi3Float64 tolerance, fmi3Float64 startTime,
                                       fmi3Boolean stopTimeDefined, fmi3Float64 stopTime)
{
    BEGIN_FUNCTION(EnterInitializationMode)
    TRACE("fmi3EnterInitializationMode(toleranceDefined=%d, tolerance=%.17g, startTime=%.17g, "
          "stopTimeDefined=%d, stopTime=%.17g)",
          (int)toleranceDefined, tolerance, startTime, (int)stopTimeDefined, stopTime);
    /* no iteration inside the model: nothing to tighten, but a defined tolerance is checked */
    CHECKED(fmu_check_tolerance(S, fn_, toleranceDefined, tolerance));
    CHECKED(fmu_setup_experiment(S, fn_, startTime, stopTimeDefined, stopTime));
    S->state = FMU_INIT_MODE;
    S->dirty = 1;
    END_FUNCTION()
}

fmi3Status fmi3ExitInitializationMode(fmi3Instance instance)
{
    BEGIN_FUNCTION(ExitInitializationMode)
    TRACE("fmi3ExitInitializationMode()");
    status = fmu_exit_initialization(S);
    END_FUNCTION()
}

fmi3Status fmi3EnterEventMode(fmi3Instance instance)
{
    BEGIN_FUNCTION(EnterEventMode)
    TRACE("fmi3EnterEventMode()");
    S->state = FMU_EVENT_MODE;
    if (S->model->bus != NULL && S->interface == FMU_CO_SIMULATION) {
        S->model->bus->glue->enter_event_mode(S); /* what the node sends at this time */
    }
    END_FUNCTION()
}

fmi3Status fmi3Terminate(fmi3Instance instance)
{
    BEGIN_FUNCTION(Terminate)
    TRACE("fmi3Terminate()");
    S->state = FMU_TERMINATED;
    END_FUNCTION()
}

fmi3Status fmi3Reset(fmi3Instance instance)
{
    BEGIN_FUNCTION(Reset)
    TRACE("fmi3Reset()");
    CALL(fmu_reset_instance(S));
    END_FUNCTION()
}

/* ---- getting and setting variable values ----------------------------------------------------- */

fmi3Status fmi3GetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Float64 values[], size_t nValues)
{
    BEGIN_FUNCTION(GetFloat64)
    TRACE("fmi3GetFloat64(nValueReferences=%zu)", nValueReferences);
    ASSERT_SCALARS(nValueReferences, nValues);
    if (nValueReferences > 0) {
        ASSERT_NOT_NULL(valueReferences);
        ASSERT_NOT_NULL(values);
    }
    if (fmu_needs_update(S, valueReferences, nValueReferences)) {
        CALL(fmu_update(S));
    }
    CHECKED(fmu_get_values(S, fn_, FMU_REAL, valueReferences, nValueReferences, values,
                           FMU_BOOL_C99));
    END_FUNCTION()
}

fmi3Status fmi3GetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, fmi3Boolean values[], size_t nValues)
{
    BEGIN_FUNCTION(GetBoolean)
    TRACE("fmi3GetBoolean(nValueReferences=%zu)", nValueReferences);
    ASSERT_SCALARS(nValueReferences, nValues);
    if (nValueReferences > 0) {
        ASSERT_NOT_NULL(valueReferences);
        ASSERT_NOT_NULL(values);
    }
    if (fmu_needs_update(S, valueReferences, nValueReferences)) {
        CALL(fmu_update(S));
    }
    CHECKED(fmu_get_values(S, fn_, FMU_BOOLEAN, valueReferences, nValueReferences, values,
                           FMU_BOOL_C99));
    END_FUNCTION()
}

fmi3Status fmi3SetFloat64(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Float64 values[], size_t nValues)
{
    BEGIN_FUNCTION(SetFloat64)
    TRACE("fmi3SetFloat64(nValueReferences=%zu)", nValueReferences);
    ASSERT_SCALARS(nValueReferences, nValues);
    if (nValueReferences > 0) {
        ASSERT_NOT_NULL(valueReferences);
        ASSERT_NOT_NULL(values);
    }
    CHECKED(fmu_set_values(S, fn_, FMU_REAL, valueReferences, nValueReferences, values,
                           FMU_BOOL_C99));
    END_FUNCTION()
}

fmi3Status fmi3SetBoolean(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                          size_t nValueReferences, const fmi3Boolean values[], size_t nValues)
{
    BEGIN_FUNCTION(SetBoolean)
    TRACE("fmi3SetBoolean(nValueReferences=%zu)", nValueReferences);
    ASSERT_SCALARS(nValueReferences, nValues);
    if (nValueReferences > 0) {
        ASSERT_NOT_NULL(valueReferences);
        ASSERT_NOT_NULL(values);
    }
    CHECKED(fmu_set_values(S, fn_, FMU_BOOLEAN, valueReferences, nValueReferences, values,
                           FMU_BOOL_C99));
    END_FUNCTION()
}

/* Get/Set of a type the models do not have: only an empty call is accepted. PARAMS is the
 * parenthesised rest of the parameter list, UNUSED the statements that mark it used. */
#define UNPAREN(...) __VA_ARGS__
#define NO_VARIABLES_OF_TYPE(KIND, NAME, TYPE, PARAMS, UNUSED)                                \
    fmi3Status NAME(fmi3Instance instance, const fmi3ValueReference valueReferences[],         \
                    size_t nValueReferences, UNPAREN PARAMS)                                  \
    {                                                                                         \
        BEGIN_FUNCTION_MASK(MASK_fmi3##KIND, #NAME)                                           \
        UNUSED                                                                                \
        TRACE("%s(nValueReferences=%zu)", fn_, nValueReferences);                             \
        if (nValueReferences > 0) {                                                           \
            ASSERT_NOT_NULL(valueReferences);                                                 \
            REFUSE("%s: %s has no " TYPE " variables (vr %u requested)", fn_,                 \
                   S->model->identifier, (unsigned)valueReferences[0]);                       \
        }                                                                                     \
        END_FUNCTION()                                                                        \
    }
#define ARRAY_U (void)values; (void)nValues;

NO_VARIABLES_OF_TYPE(GetOther, fmi3GetFloat32, "Float32", (fmi3Float32 values[], size_t nValues), ARRAY_U)
NO_VARIABLES_OF_TYPE(GetOther, fmi3GetInt8, "Int8", (fmi3Int8 values[], size_t nValues), ARRAY_U)
NO_VARIABLES_OF_TYPE(GetOther, fmi3GetUInt8, "UInt8", (fmi3UInt8 values[], size_t nValues), ARRAY_U)
NO_VARIABLES_OF_TYPE(GetOther, fmi3GetInt16, "Int16", (fmi3Int16 values[], size_t nValues), ARRAY_U)
NO_VARIABLES_OF_TYPE(GetOther, fmi3GetUInt16, "UInt16", (fmi3UInt16 values[], size_t nValues), ARRAY_U)
NO_VARIABLES_OF_TYPE(GetOther, fmi3GetInt32, "Int32", (fmi3Int32 values[], size_t nValues), ARRAY_U)
NO_VARIABLES_OF_TYPE(GetOther, fmi3GetUInt32, "UInt32", (fmi3UInt32 values[], size_t nValues), ARRAY_U)
NO_VARIABLES_OF_TYPE(GetOther, fmi3GetInt64, "Int64", (fmi3Int64 values[], size_t nValues), ARRAY_U)
NO_VARIABLES_OF_TYPE(GetOther, fmi3GetUInt64, "UInt64", (fmi3UInt64 values[], size_t nValues), ARRAY_U)
NO_VARIABLES_OF_TYPE(GetOther, fmi3GetString, "String", (fmi3String values[], size_t nValues), ARRAY_U)
NO_VARIABLES_OF_TYPE(SetOther, fmi3SetFloat32, "Float32", (const fmi3Float32 values[], size_t nValues), ARRAY_U)
NO_VARIABLES_OF_TYPE(SetOther, fmi3SetInt8, "Int8", (const fmi3Int8 values[], size_t nValues), ARRAY_U)
NO_VARIABLES_OF_TYPE(SetOther, fmi3SetUInt8, "UInt8", (const fmi3UInt8 values[], size_t nValues), ARRAY_U)
NO_VARIABLES_OF_TYPE(SetOther, fmi3SetInt16, "Int16", (const fmi3Int16 values[], size_t nValues), ARRAY_U)
NO_VARIABLES_OF_TYPE(SetOther, fmi3SetUInt16, "UInt16", (const fmi3UInt16 values[], size_t nValues), ARRAY_U)
NO_VARIABLES_OF_TYPE(SetOther, fmi3SetInt32, "Int32", (const fmi3Int32 values[], size_t nValues), ARRAY_U)
NO_VARIABLES_OF_TYPE(SetOther, fmi3SetUInt32, "UInt32", (const fmi3UInt32 values[], size_t nValues), ARRAY_U)
NO_VARIABLES_OF_TYPE(SetOther, fmi3SetInt64, "Int64", (const fmi3Int64 values[], size_t nValues), ARRAY_U)
NO_VARIABLES_OF_TYPE(SetOther, fmi3SetUInt64, "UInt64", (const fmi3UInt64 values[], size_t nValues), ARRAY_U)
NO_VARIABLES_OF_TYPE(SetOther, fmi3SetString, "String", (const fmi3String values[], size_t nValues), ARRAY_U)

/* ---- the CAN terminal (fmu_bus.h): Binary and Clock variables ---------------------------------- */

/* A model without a terminal has no Binary or Clock variables: an empty call is accepted. */
#define NEEDS_BUS(TYPE)                                                                       \
    do {                                                                                      \
        if (S->model->bus == NULL) {                                                          \
            if (nValueReferences > 0) {                                                       \
                ASSERT_NOT_NULL(valueReferences);                                             \
                REFUSE("%s: %s has no " TYPE " variables (vr %u requested)", fn_,             \
                       S->model->identifier, (unsigned)valueReferences[0]);                   \
            }                                                                                 \
            goto END;                                                                         \
        }                                                                                     \
        if (nValueReferences > 0) {                                                           \
            ASSERT_NOT_NULL(valueReferences);                                                 \
        }                                                                                     \
    } while (0)

fmi3Status fmi3GetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, size_t valueSizes[], fmi3Binary values[],
                         size_t nValues)
{
    BEGIN_FUNCTION(GetBinary)
    TRACE("fmi3GetBinary(nValueReferences=%zu)", nValueReferences);
    NEEDS_BUS("Binary");
    ASSERT_SCALARS(nValueReferences, nValues);
    if (nValueReferences > 0) {
        ASSERT_NOT_NULL(valueSizes);
        ASSERT_NOT_NULL(values);
    }
    for (size_t i = 0; i < nValueReferences; ++i) {
        const uint8_t *v = NULL;
        size_t n = 0;
        CHECKED(S->model->bus->glue->get_binary(S, fn_, valueReferences[i], &n, &v));
        valueSizes[i] = n;
        values[i] = v;
    }
    END_FUNCTION()
}

fmi3Status fmi3SetBinary(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                         size_t nValueReferences, const size_t valueSizes[],
                         const fmi3Binary values[], size_t nValues)
{
    BEGIN_FUNCTION(SetBinary)
    TRACE("fmi3SetBinary(nValueReferences=%zu)", nValueReferences);
    NEEDS_BUS("Binary");
    ASSERT_SCALARS(nValueReferences, nValues);
    if (nValueReferences > 0) {
        ASSERT_NOT_NULL(valueSizes);
        ASSERT_NOT_NULL(values);
    }
    for (size_t i = 0; i < nValueReferences; ++i) {
        CHECKED(S->model->bus->glue->set_binary(S, fn_, valueReferences[i], valueSizes[i],
                                                values[i]));
    }
    END_FUNCTION()
}

fmi3Status fmi3GetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, fmi3Clock values[])
{
    BEGIN_FUNCTION(GetClock)
    TRACE("fmi3GetClock(nValueReferences=%zu)", nValueReferences);
    NEEDS_BUS("Clock");
    if (nValueReferences > 0) {
        ASSERT_NOT_NULL(values);
    }
    for (size_t i = 0; i < nValueReferences; ++i) {
        int active = 0;
        CHECKED(S->model->bus->glue->get_clock(S, fn_, valueReferences[i], &active));
        values[i] = active != 0;
    }
    END_FUNCTION()
}

fmi3Status fmi3SetClock(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                        size_t nValueReferences, const fmi3Clock values[])
{
    BEGIN_FUNCTION(SetClock)
    TRACE("fmi3SetClock(nValueReferences=%zu)", nValueReferences);
    NEEDS_BUS("Clock");
    if (nValueReferences > 0) {
        ASSERT_NOT_NULL(values);
    }
    for (size_t i = 0; i < nValueReferences; ++i) {
        CHECKED(S->model->bus->glue->set_clock(S, fn_, valueReferences[i], values[i] ? 1 : 0));
    }
    END_FUNCTION()
}

fmi3Status fmi3GetIntervalDecimal(fmi3Instance instance, const fmi3ValueReference valueReferences[],
                                  size_t nValueReferences, fmi3Float64 intervals[],
                                  fmi3IntervalQualifier qualifiers[])
{
    BEGIN_FUNCTION(GetIntervalDecimal)
    TRACE("fmi3GetIntervalDecimal(nValueReferences=%zu)", nValueReferences);
    NEEDS_BUS("Clock");
    if (nValueReferences > 0) {
        ASSERT_NOT_NULL(intervals);
        ASSERT_NOT_NULL(qualifiers);
    }
    for (size_t i = 0; i < nValueReferences; ++i) {
        int changed = 0;
        CHECKED(S->model->bus->glue->get_interval(S, fn_, valueReferences[i], &intervals[i],
                                                  &changed));
        qualifiers[i] = changed ? fmi3IntervalChanged : fmi3IntervalUnchanged;
    }
    END_FUNCTION()
}

/* ---- dependencies, derivatives, configuration, clocks: not provided --------------------------- */

/* A function this FMU does not provide (its capability is off in the XML). */
#define NOT_PROVIDED(F, WHY)                                                                  \
    do {                                                                                      \
        TRACE("fmi3" #F "()");                                                                \
        REFUSE("fmi3" #F ": not provided (" WHY ")");                                         \
    } while (0)

fmi3Status fmi3GetNumberOfVariableDependencies(fmi3Instance instance,
                                               fmi3ValueReference valueReference,
                                               size_t *nDependencies)
{
    BEGIN_FUNCTION(GetNumberOfVariableDependencies)
    (void)valueReference;
    (void)nDependencies;
    NOT_PROVIDED(GetNumberOfVariableDependencies,
                 "providesPerElementDependencies=false; see ModelStructure");
    END_FUNCTION()
}

fmi3Status fmi3GetVariableDependencies(fmi3Instance instance, fmi3ValueReference dependent,
                                       size_t elementIndicesOfDependent[],
                                       fmi3ValueReference independents[],
                                       size_t elementIndicesOfIndependents[],
                                       fmi3DependencyKind dependencyKinds[], size_t nDependencies)
{
    BEGIN_FUNCTION(GetVariableDependencies)
    (void)dependent;
    (void)elementIndicesOfDependent;
    (void)independents;
    (void)elementIndicesOfIndependents;
    (void)dependencyKinds;
    (void)nDependencies;
    NOT_PROVIDED(GetVariableDependencies,
                 "providesPerElementDependencies=false; see ModelStructure");
    END_FUNCTION()
}

fmi3Status fmi3GetDirectionalDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[],
                                        size_t nUnknowns, const fmi3ValueReference knowns[],
                                        size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
                                        fmi3Float64 sensitivity[], size_t nSensitivity)
{
    BEGIN_FUNCTION(GetDirectionalDerivative)
    TRACE("fmi3GetDirectionalDerivative(nUnknowns=%zu, nKnowns=%zu)", nUnknowns, nKnowns);
    if (S->model->partials != NULL && nUnknowns > 0 && unknowns != NULL &&
        fmu_needs_update(S, unknowns, nUnknowns)) {
        CALL(fmu_update(S)); /* the outputs the derivatives belong to */
    }
    CHECKED(fmu_get_derivative(S, fn_, 0, unknowns, nUnknowns, knowns, nKnowns, seed, nSeed,
                               sensitivity, nSensitivity));
    END_FUNCTION()
}

fmi3Status fmi3GetAdjointDerivative(fmi3Instance instance, const fmi3ValueReference unknowns[],
                                    size_t nUnknowns, const fmi3ValueReference knowns[],
                                    size_t nKnowns, const fmi3Float64 seed[], size_t nSeed,
                                    fmi3Float64 sensitivity[], size_t nSensitivity)
{
    BEGIN_FUNCTION(GetAdjointDerivative)
    TRACE("fmi3GetAdjointDerivative(nUnknowns=%zu, nKnowns=%zu)", nUnknowns, nKnowns);
    if (S->model->partials != NULL && nUnknowns > 0 && unknowns != NULL &&
        fmu_needs_update(S, unknowns, nUnknowns)) {
        CALL(fmu_update(S)); /* the outputs the derivatives belong to */
    }
    CHECKED(fmu_get_derivative(S, fn_, 1, unknowns, nUnknowns, knowns, nKnowns, seed, nSeed,
                               sensitivity, nSensitivity));
    END_FUNCTION()
}

fmi3Status fmi3EnterConfigurationMode(fmi3Instance instance)
{
    BEGIN_FUNCTION(EnterConfigurationMode)
    NOT_PROVIDED(EnterConfigurationMode, "the FMU has no structural parameters");
    END_FUNCTION()
}

fmi3Status fmi3ExitConfigurationMode(fmi3Instance instance)
{
    BEGIN_FUNCTION(ExitConfigurationMode)
    NOT_PROVIDED(ExitConfigurationMode, "the FMU has no structural parameters");
    END_FUNCTION()
}

#define NO_CLOCKS(F, PARAMS, UNUSED)                                                          \
    fmi3Status fmi3##F(fmi3Instance instance, const fmi3ValueReference valueReferences[],      \
                       size_t nValueReferences, UNPAREN PARAMS)                               \
    {                                                                                         \
        BEGIN_FUNCTION_MASK(MASK_fmi3Clocks, "fmi3" #F)                                       \
        (void)valueReferences;                                                                \
        (void)nValueReferences;                                                               \
        UNUSED                                                                                \
        NOT_PROVIDED(F, "the FMU has no clocks");                                             \
        END_FUNCTION()                                                                        \
    }

NO_CLOCKS(GetIntervalFraction,
          (fmi3UInt64 counters[], fmi3UInt64 resolutions[], fmi3IntervalQualifier qualifiers[]),
          (void)counters; (void)resolutions; (void)qualifiers;)
NO_CLOCKS(GetShiftDecimal, (fmi3Float64 shifts[]), (void)shifts;)
NO_CLOCKS(GetShiftFraction, (fmi3UInt64 counters[], fmi3UInt64 resolutions[]),
          (void)counters; (void)resolutions;)
NO_CLOCKS(SetIntervalDecimal, (const fmi3Float64 intervals[]), (void)intervals;)
NO_CLOCKS(SetIntervalFraction, (const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]),
          (void)counters; (void)resolutions;)
NO_CLOCKS(SetShiftDecimal, (const fmi3Float64 shifts[]), (void)shifts;)
NO_CLOCKS(SetShiftFraction, (const fmi3UInt64 counters[], const fmi3UInt64 resolutions[]),
          (void)counters; (void)resolutions;)

fmi3Status fmi3EvaluateDiscreteStates(fmi3Instance instance)
{
    BEGIN_FUNCTION(EvaluateDiscreteStates)
    NOT_PROVIDED(EvaluateDiscreteStates, "providesEvaluateDiscreteStates=false");
    END_FUNCTION()
}

fmi3Status fmi3UpdateDiscreteStates(fmi3Instance instance, fmi3Boolean *discreteStatesNeedUpdate,
                                    fmi3Boolean *terminateSimulation,
                                    fmi3Boolean *nominalsOfContinuousStatesChanged,
                                    fmi3Boolean *valuesOfContinuousStatesChanged,
                                    fmi3Boolean *nextEventTimeDefined, fmi3Float64 *nextEventTime)
{
    BEGIN_FUNCTION(UpdateDiscreteStates)
    TRACE("fmi3UpdateDiscreteStates()");
    ASSERT_NOT_NULL(discreteStatesNeedUpdate);
    ASSERT_NOT_NULL(terminateSimulation);
    ASSERT_NOT_NULL(nominalsOfContinuousStatesChanged);
    ASSERT_NOT_NULL(valuesOfContinuousStatesChanged);
    ASSERT_NOT_NULL(nextEventTimeDefined);
    ASSERT_NOT_NULL(nextEventTime);
    /* no discrete states, no time events, no state events; a CAN terminal ends an event
     * iteration and asks for another after it sent (fmu_bus.h) */
    *discreteStatesNeedUpdate = false;
    if (S->model->bus != NULL && S->interface == FMU_CO_SIMULATION) {
        *discreteStatesNeedUpdate = S->model->bus->glue->update(S) != 0;
    }
    *terminateSimulation = false;
    *nominalsOfContinuousStatesChanged = false;
    *valuesOfContinuousStatesChanged = false;
    *nextEventTimeDefined = false;
    *nextEventTime = 0.0;
    END_FUNCTION()
}

/* ---- FMU state ------------------------------------------------------------------------------- */

fmi3Status fmi3GetFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    BEGIN_FUNCTION(GetFMUState)
    TRACE("fmi3GetFMUState()");
    ASSERT_NOT_NULL(FMUState);
    CHECKED(fmu_snapshot_get(S, fn_, FMUState));
    END_FUNCTION()
}

fmi3Status fmi3SetFMUState(fmi3Instance instance, fmi3FMUState FMUState)
{
    BEGIN_FUNCTION(SetFMUState)
    TRACE("fmi3SetFMUState(FMUState=%p)", FMUState);
    CHECKED(fmu_snapshot_set(S, fn_, FMUState));
    END_FUNCTION()
}

fmi3Status fmi3FreeFMUState(fmi3Instance instance, fmi3FMUState *FMUState)
{
    BEGIN_FUNCTION(FreeFMUState)
    TRACE("fmi3FreeFMUState()");
    ASSERT_NOT_NULL(FMUState);
    CHECKED(fmu_snapshot_free(S, fn_, FMUState));
    END_FUNCTION()
}

fmi3Status fmi3SerializedFMUStateSize(fmi3Instance instance, fmi3FMUState FMUState, size_t *size)
{
    BEGIN_FUNCTION(SerializedFMUStateSize)
    TRACE("fmi3SerializedFMUStateSize(FMUState=%p)", FMUState);
    ASSERT_NOT_NULL(size);
    CHECKED(fmu_snapshot_size(S, fn_, FMUState, size));
    END_FUNCTION()
}

fmi3Status fmi3SerializeFMUState(fmi3Instance instance, fmi3FMUState FMUState,
                                 fmi3Byte serializedState[], size_t size)
{
    BEGIN_FUNCTION(SerializeFMUState)
    TRACE("fmi3SerializeFMUState(FMUState=%p, size=%zu)", FMUState, size);
    ASSERT_NOT_NULL(serializedState);
    CHECKED(fmu_snapshot_serialize(S, fn_, FMUState, serializedState, size));
    END_FUNCTION()
}

fmi3Status fmi3DeserializeFMUState(fmi3Instance instance, const fmi3Byte serializedState[],
                                   size_t size, fmi3FMUState *FMUState)
{
    BEGIN_FUNCTION(DeserializeFMUState)
    TRACE("fmi3DeserializeFMUState(size=%zu)", size);
    ASSERT_NOT_NULL(serializedState);
    ASSERT_NOT_NULL(FMUState);
    CHECKED(fmu_snapshot_deserialize(S, fn_, serializedState, size, FMUState));
    END_FUNCTION()
}

/* ---- model exchange ---------------------------------------------------------------------------- */

fmi3Status fmi3EnterContinuousTimeMode(fmi3Instance instance)
{
    BEGIN_FUNCTION(EnterContinuousTimeMode)
    TRACE("fmi3EnterContinuousTimeMode()");
    S->state = FMU_CONT_TIME_MODE;
    END_FUNCTION()
}

fmi3Status fmi3CompletedIntegratorStep(fmi3Instance instance,
                                       fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi3Boolean *enterEventMode,
                                       fmi3Boolean *terminateSimulation)
{
    BEGIN_FUNCTION(CompletedIntegratorStep)
    TRACE("fmi3CompletedIntegratorStep(noSetFMUStatePriorToCurrentPoint=%d)",
          (int)noSetFMUStatePriorToCurrentPoint);
    ASSERT_NOT_NULL(enterEventMode);
    ASSERT_NOT_NULL(terminateSimulation);
    *enterEventMode = false;
    *terminateSimulation = false;
    END_FUNCTION()
}

fmi3Status fmi3SetTime(fmi3Instance instance, fmi3Float64 time)
{
    BEGIN_FUNCTION(SetTime)
    TRACE("fmi3SetTime(time=%.17g)", time);
    CHECKED(fmu_me_set_time(S, fn_, time));
    END_FUNCTION()
}

fmi3Status fmi3SetContinuousStates(fmi3Instance instance, const fmi3Float64 continuousStates[],
                                   size_t nContinuousStates)
{
    BEGIN_FUNCTION(SetContinuousStates)
    TRACE("fmi3SetContinuousStates(nContinuousStates=%zu)", nContinuousStates);
    if (nContinuousStates > 0) {
        ASSERT_NOT_NULL(continuousStates);
    }
    CHECKED(fmu_me_set_states(S, fn_, continuousStates, nContinuousStates));
    END_FUNCTION()
}

fmi3Status fmi3GetContinuousStateDerivatives(fmi3Instance instance, fmi3Float64 derivatives[],
                                             size_t nContinuousStates)
{
    BEGIN_FUNCTION(GetContinuousStateDerivatives)
    TRACE("fmi3GetContinuousStateDerivatives(nContinuousStates=%zu)", nContinuousStates);
    if (nContinuousStates > 0) {
        ASSERT_NOT_NULL(derivatives);
    }
    CHECKED(fmu_me_check_count(S, fn_, nContinuousStates));
    CALL(fmu_me_get_derivatives(S, derivatives, nContinuousStates));
    END_FUNCTION()
}

fmi3Status fmi3GetEventIndicators(fmi3Instance instance, fmi3Float64 eventIndicators[],
                                  size_t nEventIndicators)
{
    BEGIN_FUNCTION(GetEventIndicators)
    TRACE("fmi3GetEventIndicators(nEventIndicators=%zu)", nEventIndicators);
    (void)eventIndicators;
    CHECKED(fmu_me_get_event_indicators(S, fn_, nEventIndicators));
    END_FUNCTION()
}

fmi3Status fmi3GetContinuousStates(fmi3Instance instance, fmi3Float64 continuousStates[],
                                   size_t nContinuousStates)
{
    BEGIN_FUNCTION(GetContinuousStates)
    TRACE("fmi3GetContinuousStates(nContinuousStates=%zu)", nContinuousStates);
    if (nContinuousStates > 0) {
        ASSERT_NOT_NULL(continuousStates);
    }
    CHECKED(fmu_me_get_states(S, fn_, continuousStates, nContinuousStates));
    END_FUNCTION()
}

fmi3Status fmi3GetNominalsOfContinuousStates(fmi3Instance instance, fmi3Float64 nominals[],
                                             size_t nContinuousStates)
{
    BEGIN_FUNCTION(GetNominalsOfContinuousStates)
    TRACE("fmi3GetNominalsOfContinuousStates(nContinuousStates=%zu)", nContinuousStates);
    if (nContinuousStates > 0) {
        ASSERT_NOT_NULL(nominals);
    }
    CHECKED(fmu_me_get_nominals(S, fn_, nominals, nContinuousStates));
    END_FUNCTION()
}

fmi3Status fmi3GetNumberOfEventIndicators(fmi3Instance instance, size_t *nEventIndicators)
{
    BEGIN_FUNCTION(GetNumberOfEventIndicators)
    TRACE("fmi3GetNumberOfEventIndicators()");
    ASSERT_NOT_NULL(nEventIndicators);
    *nEventIndicators = 0;
    END_FUNCTION()
}

fmi3Status fmi3GetNumberOfContinuousStates(fmi3Instance instance, size_t *nContinuousStates)
{
    BEGIN_FUNCTION(GetNumberOfContinuousStates)
    TRACE("fmi3GetNumberOfContinuousStates()");
    ASSERT_NOT_NULL(nContinuousStates);
    *nContinuousStates = S->model->n_states;
    END_FUNCTION()
}

/* ---- co-simulation ------------------------------------------------------------------------------ */

fmi3Status fmi3EnterStepMode(fmi3Instance instance)
{
    BEGIN_FUNCTION(EnterStepMode)
    TRACE("fmi3EnterStepMode()");
    S->model->bus->glue->enter_step_mode(S); /* the mask admits bus models only */
    S->state = FMU_STEP_MODE;
    END_FUNCTION()
}

fmi3Status fmi3GetOutputDerivatives(fmi3Instance instance,
                                    const fmi3ValueReference valueReferences[],
                                    size_t nValueReferences, const fmi3Int32 orders[],
                                    fmi3Float64 values[], size_t nValues)
{
    BEGIN_FUNCTION(GetOutputDerivatives)
    (void)valueReferences;
    (void)nValueReferences;
    (void)orders;
    (void)values;
    (void)nValues;
    NOT_PROVIDED(GetOutputDerivatives, "maxOutputDerivativeOrder=0");
    END_FUNCTION()
}

fmi3Status fmi3DoStep(fmi3Instance instance, fmi3Float64 currentCommunicationPoint,
                      fmi3Float64 communicationStepSize,
                      fmi3Boolean noSetFMUStatePriorToCurrentPoint,
                      fmi3Boolean *eventHandlingNeeded, fmi3Boolean *terminateSimulation,
                      fmi3Boolean *earlyReturn, fmi3Float64 *lastSuccessfulTime)
{
    BEGIN_FUNCTION(DoStep)
    TRACE("fmi3DoStep(currentCommunicationPoint=%.17g, communicationStepSize=%.17g, "
          "noSetFMUStatePriorToCurrentPoint=%d)",
          currentCommunicationPoint, communicationStepSize, (int)noSetFMUStatePriorToCurrentPoint);
    ASSERT_NOT_NULL(eventHandlingNeeded);
    ASSERT_NOT_NULL(terminateSimulation);
    ASSERT_NOT_NULL(earlyReturn);
    ASSERT_NOT_NULL(lastSuccessfulTime);
    CHECKED(fmu_check_step(S, fn_, currentCommunicationPoint, communicationStepSize));
    status = fmu_do_step(S, currentCommunicationPoint, communicationStepSize);
    *eventHandlingNeeded = S->event_mode_used && status <= FMU_WARNING &&
                           S->model->bus->glue->event_needed(S);
    *terminateSimulation = false;
    *earlyReturn = false;
    *lastSuccessfulTime = S->time;
    END_FUNCTION()
}

/* ---- scheduled execution ------------------------------------------------------------------------- */

fmi3Status fmi3ActivateModelPartition(fmi3Instance instance, fmi3ValueReference clockReference,
                                      fmi3Float64 activationTime)
{
    BEGIN_FUNCTION(ActivateModelPartition)
    (void)clockReference;
    (void)activationTime;
    NOT_PROVIDED(ActivateModelPartition, "no scheduled execution");
    END_FUNCTION()
}
