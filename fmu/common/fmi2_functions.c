/*
 * The FMI 2.0 API (Co-Simulation and Model Exchange): a thin adapter in the shape of the
 * Reference-FMUs' src/fmi2Functions.c over the version-neutral instance of fmu_instance.c.
 * Every function with a component starts with BEGIN_FUNCTION, which checks the component and
 * the state mask of the FMI 2.0.4 state machines (sections 3.2.3 and 4.2.4), and ends in
 * END_FUNCTION, the single exit.
 *
 * Two kinds of failure:
 *  - a refusal (illegal call sequence, bad argument, a value that may not be set): fmi2Error with
 *    a log message; nothing changes, not even the state, so the instance stays usable;
 *  - a failure of the model (CALL of a model hook): the worst status is kept; fmi2Discard from
 *    doStep moves to StepFailed, fmi2Error to the Error state, fmi2Fatal to the Fatal state.
 */
#include "fmu_adapter.h" /* first: see fmu_model.h */
#include "fmi2Functions.h"

#include <math.h>
#include <stdio.h>
#include <string.h>

_Static_assert(sizeof(fmi2ValueReference) == sizeof(fmu_vr), "value references are 32-bit");
_Static_assert(sizeof(fmi2Boolean) == sizeof(int), "fmi2Boolean is an int");

/* ---- allowed states of every function ---------------------------------------------------------
 * FMI 2.0.4, tables in sections 3.2.3 (Model Exchange) and 4.2.4 (Co-Simulation). StartAndEnd
 * only allows fmi2Instantiate, fmi2GetTypesPlatform and fmi2GetVersion, which take no component.
 * The Co-Simulation states (StepComplete = FMU_STEP_MODE, ...) and the Model Exchange states
 * (EventMode, ContinuousTimeMode) never meet in one instance. Instantiated, InitializationMode,
 * Terminated and Error are shared, so a function of one interface type is masked out in an
 * instance of the other (ME_ONLY, CS_ONLY: each table lists only its own functions).
 */

#define MASK_ANY_INSTANCE                                                                     \
    (FMU_INSTANTIATED | FMU_INIT_MODE | FMU_EVENT_MODE | FMU_CONT_TIME_MODE | FMU_STEP_MODE |  \
     FMU_STEP_IN_PROGRESS | FMU_STEP_FAILED | FMU_STEP_CANCELED | FMU_TERMINATED |             \
     FMU_ERROR_STATE)

/* common functions */
#define MASK_fmi2SetDebugLogging MASK_ANY_INSTANCE
#define MASK_fmi2FreeInstance (MASK_ANY_INSTANCE & ~(unsigned)FMU_STEP_IN_PROGRESS)
#define MASK_fmi2SetupExperiment FMU_INSTANTIATED
#define MASK_fmi2EnterInitializationMode FMU_INSTANTIATED
#define MASK_fmi2ExitInitializationMode FMU_INIT_MODE
#define MASK_fmi2Terminate (FMU_EVENT_MODE | FMU_CONT_TIME_MODE | FMU_STEP_MODE | FMU_STEP_FAILED)
#define MASK_fmi2Reset MASK_fmi2FreeInstance
#define MASK_fmi2GetReal                                                                      \
    (FMU_INIT_MODE | FMU_EVENT_MODE | FMU_CONT_TIME_MODE | FMU_STEP_MODE | FMU_STEP_FAILED |   \
     FMU_STEP_CANCELED | FMU_TERMINATED | FMU_ERROR_STATE)
#define MASK_fmi2GetInteger MASK_fmi2GetReal
#define MASK_fmi2GetBoolean MASK_fmi2GetReal
#define MASK_fmi2GetString MASK_fmi2GetReal
#define MASK_fmi2SetReal                                                                      \
    (FMU_INSTANTIATED | FMU_INIT_MODE | FMU_EVENT_MODE | FMU_CONT_TIME_MODE | FMU_STEP_MODE)
#define MASK_fmi2SetInteger (FMU_INSTANTIATED | FMU_INIT_MODE | FMU_EVENT_MODE | FMU_STEP_MODE)
#define MASK_fmi2SetBoolean MASK_fmi2SetInteger
#define MASK_fmi2SetString MASK_fmi2SetInteger
#define MASK_fmi2GetFMUstate MASK_fmi2FreeInstance
#define MASK_fmi2SetFMUstate MASK_fmi2FreeInstance
#define MASK_fmi2FreeFMUstate MASK_fmi2FreeInstance
#define MASK_fmi2SerializedFMUstateSize MASK_fmi2FreeInstance
#define MASK_fmi2SerializeFMUstate MASK_fmi2FreeInstance
#define MASK_fmi2DeSerializeFMUstate MASK_fmi2FreeInstance
#define MASK_fmi2GetDirectionalDerivative MASK_fmi2GetReal

/* model exchange functions (fmi2GetDerivatives: "x" in Initialization Mode since FMI 2.0;
 * fmi2GetNominalsOfContinuousStates: Initialization Mode added in FMI 2.0.3) */
#define MASK_fmi2EnterEventMode ME_ONLY(FMU_EVENT_MODE | FMU_CONT_TIME_MODE)
#define MASK_fmi2NewDiscreteStates ME_ONLY(FMU_EVENT_MODE)
#define MASK_fmi2EnterContinuousTimeMode ME_ONLY(FMU_EVENT_MODE)
#define MASK_fmi2CompletedIntegratorStep ME_ONLY(FMU_CONT_TIME_MODE)
#define MASK_fmi2SetTime ME_ONLY(FMU_EVENT_MODE | FMU_CONT_TIME_MODE)
#define MASK_fmi2SetContinuousStates ME_ONLY(FMU_CONT_TIME_MODE)
#define MASK_fmi2GetEventIndicators                                                           \
    ME_ONLY(FMU_INIT_MODE | FMU_EVENT_MODE | FMU_CONT_TIME_MODE | FMU_TERMINATED |             \
            FMU_ERROR_STATE)
#define MASK_fmi2GetContinuousStates MASK_fmi2GetEventIndicators
#define MASK_fmi2GetDerivatives MASK_fmi2GetEventIndicators
#define MASK_fmi2GetNominalsOfContinuousStates                                                \
    ME_ONLY(FMU_INSTANTIATED | FMU_INIT_MODE | FMU_EVENT_MODE | FMU_CONT_TIME_MODE |           \
            FMU_TERMINATED | FMU_ERROR_STATE)

/* co-simulation functions */
#define MASK_fmi2SetRealInputDerivatives CS_ONLY(FMU_INSTANTIATED | FMU_INIT_MODE | FMU_STEP_MODE)
#define MASK_fmi2GetRealOutputDerivatives                                                     \
    CS_ONLY(FMU_STEP_MODE | FMU_STEP_FAILED | FMU_STEP_CANCELED | FMU_TERMINATED |             \
            FMU_ERROR_STATE)
#define MASK_fmi2DoStep CS_ONLY(FMU_STEP_MODE)
#define MASK_fmi2CancelStep CS_ONLY(FMU_STEP_IN_PROGRESS)
#define MASK_fmi2GetStatus                                                                    \
    CS_ONLY(FMU_STEP_MODE | FMU_STEP_IN_PROGRESS | FMU_STEP_FAILED | FMU_TERMINATED)
#define MASK_fmi2GetRealStatus MASK_fmi2GetStatus
#define MASK_fmi2GetIntegerStatus MASK_fmi2GetStatus
#define MASK_fmi2GetBooleanStatus MASK_fmi2GetStatus
#define MASK_fmi2GetStringStatus MASK_fmi2GetStatus

/* ---- the adapter macros (fmu_adapter.h) ------------------------------------------------------ */

#define BEGIN_FUNCTION(F) FMU_BEGIN(c, MASK_fmi2##F, "fmi2" #F, fmi2Error)
#define END_FUNCTION() FMU_END(fmi2Status)

/* ---- inquire platform and version ------------------------------------------------------------ */

const char *fmi2GetTypesPlatform(void)
{
    return fmi2TypesPlatform;
}

const char *fmi2GetVersion(void)
{
    return fmi2Version;
}

/* ---- creation, destruction, debug logging ---------------------------------------------------- */

/* The importer's logger formats like printf: pass the text as an argument, never as the format. */
static void host_log(const fmu_instance *S, fmu_status status, const char *category,
                     const char *message)
{
    const fmi2CallbackLogger logger = (fmi2CallbackLogger)S->host.logger;
    if (logger != NULL) {
        logger(S->host.env, S->name, (fmi2Status)status, category, "%s", message);
    }
}

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn)
{
    (void)visible; /* no user interface */
    fmu_host host;
    memset(&host, 0, sizeof host);
    host.log = host_log;
    host.resources = fmuResourceLocation; /* a URI (file:///.../resources) */
    host.resources_is_uri = 1;
    if (functions != NULL) {
        host.logger = (void (*)(void))functions->logger;
        host.env = functions->componentEnvironment;
        host.alloc = functions->allocateMemory;
        host.release = functions->freeMemory;
    }
    if (fmuType != fmi2CoSimulation && fmuType != fmi2ModelExchange) {
        fmu_instance tmp;
        memset(&tmp, 0, sizeof tmp);
        tmp.host = host;
        tmp.name = (char *)(instanceName != NULL ? instanceName : "?");
        tmp.log_mask = 1u << FMU_LOG_ERROR;
        fmu_log(&tmp, FMU_ERROR, FMU_LOG_ERROR,
                "fmi2Instantiate: fmuType must be fmi2ModelExchange (%d) or fmi2CoSimulation "
                "(%d), got %d",
                (int)fmi2ModelExchange, (int)fmi2CoSimulation, (int)fmuType);
        return NULL;
    }
    return fmu_create("fmi2Instantiate", &host, 2,
                      fmuType == fmi2ModelExchange ? FMU_MODEL_EXCHANGE : FMU_CO_SIMULATION,
                      instanceName, fmuGUID, loggingOn != fmi2False);
}

void fmi2FreeInstance(fmi2Component c)
{
    fmu_instance *S = (fmu_instance *)c;
    if (S == NULL || !fmu_allowed_state(S, MASK_fmi2FreeInstance, "fmi2FreeInstance")) {
        return;
    }
    fmu_destroy(S);
}

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    BEGIN_FUNCTION(SetDebugLogging)
    TRACE("fmi2SetDebugLogging(loggingOn=%d, nCategories=%zu)", (int)loggingOn, nCategories);
    CHECKED(fmu_set_logging(S, "fmi2SetDebugLogging", loggingOn != fmi2False, nCategories,
                            categories));
    END_FUNCTION()
}

/* ---- initialization, termination, reset ------------------------------------------------------ */

fmi2Status fmi2SetupExperiment(fmi2Component c, fmi2Boolean toleranceDefined, fmi2Real tolerance,
                               fmi2Real startTime, fmi2Boolean stopTimeDefined, fmi2Real stopTime)
{
    BEGIN_FUNCTION(SetupExperiment)
    TRACE("fmi2SetupExperiment(toleranceDefined=%d, tolerance=%.17g, startTime=%.17g, "
          "stopTimeDefined=%d, stopTime=%.17g)",
          (int)toleranceDefined, tolerance, startTime, (int)stopTimeDefined, stopTime);
    /* no iteration inside the model: nothing to tighten, but a defined tolerance is checked */
    CHECKED(fmu_check_tolerance(S, "fmi2SetupExperiment", toleranceDefined != fmi2False,
                                tolerance));
    CHECKED(fmu_setup_experiment(S, "fmi2SetupExperiment", startTime, stopTimeDefined != fmi2False,
                                 stopTime));
    END_FUNCTION()
}

fmi2Status fmi2EnterInitializationMode(fmi2Component c)
{
    BEGIN_FUNCTION(EnterInitializationMode)
    TRACE("fmi2EnterInitializationMode()");
    S->state = FMU_INIT_MODE;
    S->dirty = 1;
    END_FUNCTION()
}

fmi2Status fmi2ExitInitializationMode(fmi2Component c)
{
    BEGIN_FUNCTION(ExitInitializationMode)
    TRACE("fmi2ExitInitializationMode()");
    status = fmu_exit_initialization(S);
    END_FUNCTION()
}

fmi2Status fmi2Terminate(fmi2Component c)
{
    BEGIN_FUNCTION(Terminate)
    TRACE("fmi2Terminate()");
    S->state = FMU_TERMINATED;
    END_FUNCTION()
}

fmi2Status fmi2Reset(fmi2Component c)
{
    BEGIN_FUNCTION(Reset)
    TRACE("fmi2Reset()");
    CALL(fmu_reset_instance(S));
    END_FUNCTION()
}

/* ---- getting and setting variable values ----------------------------------------------------- */

/* A Get/Set of a type the models do not use: refused unless empty. */
#define NO_VARIABLES_OF_TYPE(TYPE)                                                            \
    do {                                                                                      \
        if (nvr > 0) {                                                                        \
            ASSERT_NOT_NULL(vr);                                                              \
            REFUSE("%s: %s has no " TYPE " variables (vr %u requested)", fn_,                 \
                   S->model->identifier, (unsigned)vr[0]);                                    \
        }                                                                                     \
    } while (0)

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[])
{
    BEGIN_FUNCTION(GetReal)
    TRACE("fmi2GetReal(nvr=%zu)", nvr);
    if (nvr > 0) {
        ASSERT_NOT_NULL(vr);
        ASSERT_NOT_NULL(value);
    }
    if (fmu_needs_update(S, vr, nvr)) {
        CALL(fmu_update(S));
    }
    CHECKED(fmu_get_values(S, "fmi2GetReal", FMU_REAL, vr, nvr, value, FMU_BOOL_INT));
    END_FUNCTION()
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[])
{
    BEGIN_FUNCTION(GetInteger)
    TRACE("fmi2GetInteger(nvr=%zu)", nvr);
    (void)value;
    NO_VARIABLES_OF_TYPE("Integer");
    END_FUNCTION()
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[])
{
    BEGIN_FUNCTION(GetBoolean)
    TRACE("fmi2GetBoolean(nvr=%zu)", nvr);
    if (nvr > 0) {
        ASSERT_NOT_NULL(vr);
        ASSERT_NOT_NULL(value);
    }
    if (fmu_needs_update(S, vr, nvr)) {
        CALL(fmu_update(S));
    }
    CHECKED(fmu_get_values(S, "fmi2GetBoolean", FMU_BOOLEAN, vr, nvr, value, FMU_BOOL_INT));
    END_FUNCTION()
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[])
{
    BEGIN_FUNCTION(GetString)
    TRACE("fmi2GetString(nvr=%zu)", nvr);
    (void)value;
    NO_VARIABLES_OF_TYPE("String");
    END_FUNCTION()
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[])
{
    BEGIN_FUNCTION(SetReal)
    TRACE("fmi2SetReal(nvr=%zu)", nvr);
    if (nvr > 0) {
        ASSERT_NOT_NULL(vr);
        ASSERT_NOT_NULL(value);
    }
    CHECKED(fmu_set_values(S, "fmi2SetReal", FMU_REAL, vr, nvr, value, FMU_BOOL_INT));
    END_FUNCTION()
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[])
{
    BEGIN_FUNCTION(SetInteger)
    TRACE("fmi2SetInteger(nvr=%zu)", nvr);
    (void)value;
    NO_VARIABLES_OF_TYPE("Integer");
    END_FUNCTION()
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[])
{
    BEGIN_FUNCTION(SetBoolean)
    TRACE("fmi2SetBoolean(nvr=%zu)", nvr);
    if (nvr > 0) {
        ASSERT_NOT_NULL(vr);
        ASSERT_NOT_NULL(value);
    }
    CHECKED(fmu_set_values(S, "fmi2SetBoolean", FMU_BOOLEAN, vr, nvr, value, FMU_BOOL_INT));
    END_FUNCTION()
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[])
{
    BEGIN_FUNCTION(SetString)
    TRACE("fmi2SetString(nvr=%zu)", nvr);
    (void)value;
    NO_VARIABLES_OF_TYPE("String");
    END_FUNCTION()
}

/* ---- FMU state ------------------------------------------------------------------------------- */

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    BEGIN_FUNCTION(GetFMUstate)
    TRACE("fmi2GetFMUstate()");
    ASSERT_NOT_NULL(FMUstate);
    CHECKED(fmu_snapshot_get(S, "fmi2GetFMUstate", FMUstate));
    END_FUNCTION()
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate)
{
    BEGIN_FUNCTION(SetFMUstate)
    TRACE("fmi2SetFMUstate(FMUstate=%p)", FMUstate);
    CHECKED(fmu_snapshot_set(S, "fmi2SetFMUstate", FMUstate));
    END_FUNCTION()
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    BEGIN_FUNCTION(FreeFMUstate)
    TRACE("fmi2FreeFMUstate()");
    ASSERT_NOT_NULL(FMUstate);
    CHECKED(fmu_snapshot_free(S, "fmi2FreeFMUstate", FMUstate));
    END_FUNCTION()
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size)
{
    BEGIN_FUNCTION(SerializedFMUstateSize)
    TRACE("fmi2SerializedFMUstateSize(FMUstate=%p)", FMUstate);
    ASSERT_NOT_NULL(size);
    CHECKED(fmu_snapshot_size(S, "fmi2SerializedFMUstateSize", FMUstate, size));
    END_FUNCTION()
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate,
                                 fmi2Byte serializedState[], size_t size)
{
    BEGIN_FUNCTION(SerializeFMUstate)
    TRACE("fmi2SerializeFMUstate(FMUstate=%p, size=%zu)", FMUstate, size);
    ASSERT_NOT_NULL(serializedState);
    CHECKED(fmu_snapshot_serialize(S, "fmi2SerializeFMUstate", FMUstate,
                                   (unsigned char *)serializedState, size));
    END_FUNCTION()
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate)
{
    BEGIN_FUNCTION(DeSerializeFMUstate)
    TRACE("fmi2DeSerializeFMUstate(size=%zu)", size);
    ASSERT_NOT_NULL(serializedState);
    ASSERT_NOT_NULL(FMUstate);
    CHECKED(fmu_snapshot_deserialize(S, "fmi2DeSerializeFMUstate",
                                     (const unsigned char *)serializedState, size, FMUstate));
    END_FUNCTION()
}

/* ---- partial derivatives (fmu_derivative.c; providesDirectionalDerivative from the model) ---- */

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                        size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[])
{
    BEGIN_FUNCTION(GetDirectionalDerivative)
    TRACE("fmi2GetDirectionalDerivative(nUnknown=%zu, nKnown=%zu)", nUnknown, nKnown);
    if (S->model->partials != NULL && nUnknown > 0 && vUnknown_ref != NULL &&
        fmu_needs_update(S, vUnknown_ref, nUnknown)) {
        CALL(fmu_update(S)); /* the outputs the derivatives belong to */
    }
    CHECKED(fmu_get_derivative(S, fn_, 0, vUnknown_ref, nUnknown, vKnown_ref, nKnown, dvKnown,
                               nKnown, dvUnknown, nUnknown));
    END_FUNCTION()
}

/* ---- not provided (capability flags false in the XML) ------------------------------------------ */

fmi2Status fmi2SetRealInputDerivatives(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                                       const fmi2Integer order[], const fmi2Real value[])
{
    BEGIN_FUNCTION(SetRealInputDerivatives)
    TRACE("fmi2SetRealInputDerivatives(nvr=%zu)", nvr);
    (void)vr;
    (void)order;
    (void)value;
    REFUSE("fmi2SetRealInputDerivatives: not provided (canInterpolateInputs=false)");
    END_FUNCTION()
}

fmi2Status fmi2GetRealOutputDerivatives(fmi2Component c, const fmi2ValueReference vr[],
                                        size_t nvr, const fmi2Integer order[], fmi2Real value[])
{
    BEGIN_FUNCTION(GetRealOutputDerivatives)
    TRACE("fmi2GetRealOutputDerivatives(nvr=%zu)", nvr);
    (void)vr;
    (void)order;
    (void)value;
    REFUSE("fmi2GetRealOutputDerivatives: not provided (maxOutputDerivativeOrder=0)");
    END_FUNCTION()
}

/* ---- model exchange ---------------------------------------------------------------------------- */

fmi2Status fmi2EnterEventMode(fmi2Component c)
{
    BEGIN_FUNCTION(EnterEventMode)
    TRACE("fmi2EnterEventMode()");
    S->state = FMU_EVENT_MODE;
    END_FUNCTION()
}

fmi2Status fmi2NewDiscreteStates(fmi2Component c, fmi2EventInfo *eventInfo)
{
    BEGIN_FUNCTION(NewDiscreteStates)
    TRACE("fmi2NewDiscreteStates()");
    ASSERT_NOT_NULL(eventInfo);
    /* no discrete states, no time events, no state events */
    eventInfo->newDiscreteStatesNeeded = fmi2False;
    eventInfo->terminateSimulation = fmi2False;
    eventInfo->nominalsOfContinuousStatesChanged = fmi2False;
    eventInfo->valuesOfContinuousStatesChanged = fmi2False;
    eventInfo->nextEventTimeDefined = fmi2False;
    eventInfo->nextEventTime = 0.0;
    END_FUNCTION()
}

fmi2Status fmi2EnterContinuousTimeMode(fmi2Component c)
{
    BEGIN_FUNCTION(EnterContinuousTimeMode)
    TRACE("fmi2EnterContinuousTimeMode()");
    S->state = FMU_CONT_TIME_MODE;
    END_FUNCTION()
}

fmi2Status fmi2CompletedIntegratorStep(fmi2Component c, fmi2Boolean noSetFMUStatePriorToCurrentPoint,
                                       fmi2Boolean *enterEventMode, fmi2Boolean *terminateSimulation)
{
    BEGIN_FUNCTION(CompletedIntegratorStep)
    TRACE("fmi2CompletedIntegratorStep(noSetFMUStatePriorToCurrentPoint=%d)",
          (int)noSetFMUStatePriorToCurrentPoint);
    ASSERT_NOT_NULL(enterEventMode);
    ASSERT_NOT_NULL(terminateSimulation);
    *enterEventMode = fmi2False;
    *terminateSimulation = fmi2False;
    END_FUNCTION()
}

fmi2Status fmi2SetTime(fmi2Component c, fmi2Real time)
{
    BEGIN_FUNCTION(SetTime)
    TRACE("fmi2SetTime(time=%.17g)", time);
    CHECKED(fmu_me_set_time(S, "fmi2SetTime", time));
    END_FUNCTION()
}

fmi2Status fmi2SetContinuousStates(fmi2Component c, const fmi2Real x[], size_t nx)
{
    BEGIN_FUNCTION(SetContinuousStates)
    TRACE("fmi2SetContinuousStates(nx=%zu)", nx);
    if (nx > 0) {
        ASSERT_NOT_NULL(x);
    }
    CHECKED(fmu_me_set_states(S, "fmi2SetContinuousStates", x, nx));
    END_FUNCTION()
}

fmi2Status fmi2GetDerivatives(fmi2Component c, fmi2Real derivatives[], size_t nx)
{
    BEGIN_FUNCTION(GetDerivatives)
    TRACE("fmi2GetDerivatives(nx=%zu)", nx);
    if (nx > 0) {
        ASSERT_NOT_NULL(derivatives);
    }
    CHECKED(fmu_me_check_count(S, "fmi2GetDerivatives", nx));
    CALL(fmu_me_get_derivatives(S, derivatives, nx));
    END_FUNCTION()
}

fmi2Status fmi2GetEventIndicators(fmi2Component c, fmi2Real eventIndicators[], size_t ni)
{
    BEGIN_FUNCTION(GetEventIndicators)
    TRACE("fmi2GetEventIndicators(ni=%zu)", ni);
    (void)eventIndicators;
    CHECKED(fmu_me_get_event_indicators(S, "fmi2GetEventIndicators", ni));
    END_FUNCTION()
}

fmi2Status fmi2GetContinuousStates(fmi2Component c, fmi2Real x[], size_t nx)
{
    BEGIN_FUNCTION(GetContinuousStates)
    TRACE("fmi2GetContinuousStates(nx=%zu)", nx);
    if (nx > 0) {
        ASSERT_NOT_NULL(x);
    }
    CHECKED(fmu_me_get_states(S, "fmi2GetContinuousStates", x, nx));
    END_FUNCTION()
}

fmi2Status fmi2GetNominalsOfContinuousStates(fmi2Component c, fmi2Real x_nominal[], size_t nx)
{
    BEGIN_FUNCTION(GetNominalsOfContinuousStates)
    TRACE("fmi2GetNominalsOfContinuousStates(nx=%zu)", nx);
    if (nx > 0) {
        ASSERT_NOT_NULL(x_nominal);
    }
    CHECKED(fmu_me_get_nominals(S, "fmi2GetNominalsOfContinuousStates", x_nominal, nx));
    END_FUNCTION()
}

/* ---- co-simulation: stepping -------------------------------------------------------------------- */

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize, fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    BEGIN_FUNCTION(DoStep)
    TRACE("fmi2DoStep(currentCommunicationPoint=%.17g, communicationStepSize=%.17g, "
          "noSetFMUStatePriorToCurrentPoint=%d)",
          currentCommunicationPoint, communicationStepSize, (int)noSetFMUStatePriorToCurrentPoint);
    CHECKED(fmu_check_step(S, "fmi2DoStep", currentCommunicationPoint, communicationStepSize));
    status = fmu_do_step(S, currentCommunicationPoint, communicationStepSize);
    END_FUNCTION()
}

fmi2Status fmi2CancelStep(fmi2Component c)
{
    BEGIN_FUNCTION(CancelStep)
    TRACE("fmi2CancelStep()");
    REFUSE("fmi2CancelStep: unreachable, fmi2DoStep is synchronous");
    END_FUNCTION()
}

fmi2Status fmi2GetStatus(fmi2Component c, const fmi2StatusKind s, fmi2Status *value)
{
    BEGIN_FUNCTION(GetStatus)
    TRACE("fmi2GetStatus(s=%d)", (int)s);
    (void)value;
    REFUSE("fmi2GetStatus: status kind %d not provided (fmi2DoStep never returns fmi2Pending)",
           (int)s);
    END_FUNCTION()
}

fmi2Status fmi2GetRealStatus(fmi2Component c, const fmi2StatusKind s, fmi2Real *value)
{
    BEGIN_FUNCTION(GetRealStatus)
    TRACE("fmi2GetRealStatus(s=%d)", (int)s);
    ASSERT_NOT_NULL(value);
    if (s != fmi2LastSuccessfulTime) {
        REFUSE("fmi2GetRealStatus: status kind %d not provided (only fmi2LastSuccessfulTime = %d)",
               (int)s, (int)fmi2LastSuccessfulTime);
    }
    *value = S->time;
    END_FUNCTION()
}

fmi2Status fmi2GetIntegerStatus(fmi2Component c, const fmi2StatusKind s, fmi2Integer *value)
{
    BEGIN_FUNCTION(GetIntegerStatus)
    TRACE("fmi2GetIntegerStatus(s=%d)", (int)s);
    (void)value;
    REFUSE("fmi2GetIntegerStatus: status kind %d not provided", (int)s);
    END_FUNCTION()
}

fmi2Status fmi2GetBooleanStatus(fmi2Component c, const fmi2StatusKind s, fmi2Boolean *value)
{
    BEGIN_FUNCTION(GetBooleanStatus)
    TRACE("fmi2GetBooleanStatus(s=%d)", (int)s);
    ASSERT_NOT_NULL(value);
    if (s != fmi2Terminated) {
        REFUSE("fmi2GetBooleanStatus: status kind %d not provided (only fmi2Terminated = %d)",
               (int)s, (int)fmi2Terminated);
    }
    *value = fmi2False; /* the model never asks to end the simulation */
    END_FUNCTION()
}

fmi2Status fmi2GetStringStatus(fmi2Component c, const fmi2StatusKind s, fmi2String *value)
{
    BEGIN_FUNCTION(GetStringStatus)
    TRACE("fmi2GetStringStatus(s=%d)", (int)s);
    (void)value;
    REFUSE("fmi2GetStringStatus: status kind %d not provided", (int)s);
    END_FUNCTION()
}
