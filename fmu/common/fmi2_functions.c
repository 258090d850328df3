/*
 * The FMI 2.0 co-simulation API: a thin adapter in the shape of the Reference-FMUs'
 * src/fmi2Functions.c. Every function with a component starts with BEGIN_FUNCTION, which checks
 * the component and the state mask of the FMI 2.0.4 state machine (section 4.2.4), and ends in
 * END_FUNCTION, the single exit.
 *
 * Two kinds of failure:
 *  - a refusal (illegal call sequence, bad argument, a value that may not be set): fmi2Error with
 *    a log message; nothing changes, not even the state, so the instance stays usable;
 *  - a failure of the model (CALL of a model hook): the worst status is kept; fmi2Discard from
 *    doStep moves to StepFailed, fmi2Error to the Error state, fmi2Fatal to the Fatal state.
 */
#include <math.h>
#include <stdio.h>
#include <string.h>

#include "fmu_internal.h"

/* ---- allowed states of every function ---------------------------------------------------------
 * FMI 2.0.4, table in section 4.2.4 ("calling sequence for co-simulation"). StartAndEnd only
 * allows fmi2Instantiate, fmi2GetTypesPlatform and fmi2GetVersion, which take no component.
 */

#define MASK_ANY_INSTANCE                                                                     \
    (FMU_INSTANTIATED | FMU_INIT_MODE | FMU_STEP_COMPLETE | FMU_STEP_IN_PROGRESS |            \
     FMU_STEP_FAILED | FMU_STEP_CANCELED | FMU_TERMINATED | FMU_ERROR_STATE)

/* common functions */
#define MASK_fmi2SetDebugLogging MASK_ANY_INSTANCE
#define MASK_fmi2FreeInstance                                                                 \
    (FMU_INSTANTIATED | FMU_INIT_MODE | FMU_STEP_COMPLETE | FMU_STEP_FAILED |                  \
     FMU_STEP_CANCELED | FMU_TERMINATED | FMU_ERROR_STATE)
#define MASK_fmi2SetupExperiment FMU_INSTANTIATED
#define MASK_fmi2EnterInitializationMode FMU_INSTANTIATED
#define MASK_fmi2ExitInitializationMode FMU_INIT_MODE
#define MASK_fmi2Terminate (FMU_STEP_COMPLETE | FMU_STEP_FAILED)
#define MASK_fmi2Reset MASK_fmi2FreeInstance
#define MASK_fmi2GetReal                                                                      \
    (FMU_INIT_MODE | FMU_STEP_COMPLETE | FMU_STEP_FAILED | FMU_STEP_CANCELED | FMU_TERMINATED | \
     FMU_ERROR_STATE)
#define MASK_fmi2GetInteger MASK_fmi2GetReal
#define MASK_fmi2GetBoolean MASK_fmi2GetReal
#define MASK_fmi2GetString MASK_fmi2GetReal
#define MASK_fmi2SetReal (FMU_INSTANTIATED | FMU_INIT_MODE | FMU_STEP_COMPLETE)
#define MASK_fmi2SetInteger MASK_fmi2SetReal
#define MASK_fmi2SetBoolean MASK_fmi2SetReal
#define MASK_fmi2SetString MASK_fmi2SetReal
#define MASK_fmi2GetFMUstate MASK_fmi2FreeInstance
#define MASK_fmi2SetFMUstate MASK_fmi2FreeInstance
#define MASK_fmi2FreeFMUstate MASK_fmi2FreeInstance
#define MASK_fmi2SerializedFMUstateSize MASK_fmi2FreeInstance
#define MASK_fmi2SerializeFMUstate MASK_fmi2FreeInstance
#define MASK_fmi2DeSerializeFMUstate MASK_fmi2FreeInstance
#define MASK_fmi2GetDirectionalDerivative MASK_fmi2GetReal

/* co-simulation functions */
#define MASK_fmi2SetRealInputDerivatives (FMU_INSTANTIATED | FMU_INIT_MODE | FMU_STEP_COMPLETE)
#define MASK_fmi2GetRealOutputDerivatives                                                     \
    (FMU_STEP_COMPLETE | FMU_STEP_FAILED | FMU_STEP_CANCELED | FMU_TERMINATED | FMU_ERROR_STATE)
#define MASK_fmi2DoStep FMU_STEP_COMPLETE
#define MASK_fmi2CancelStep FMU_STEP_IN_PROGRESS
#define MASK_fmi2GetStatus                                                                    \
    (FMU_STEP_COMPLETE | FMU_STEP_IN_PROGRESS | FMU_STEP_FAILED | FMU_TERMINATED)
#define MASK_fmi2GetRealStatus MASK_fmi2GetStatus
#define MASK_fmi2GetIntegerStatus MASK_fmi2GetStatus
#define MASK_fmi2GetBooleanStatus MASK_fmi2GetStatus
#define MASK_fmi2GetStringStatus MASK_fmi2GetStatus

/* Relative tolerance on currentCommunicationPoint (importers count time differently). */
#define FMU_TIME_RTOL 1e-9

/* ---- the adapter macros ---------------------------------------------------------------------- */

static int allowed_state(fmu_instance *S, unsigned mask, const char *fn)
{
    if ((mask & (unsigned)S->state) != 0u) {
        return 1;
    }
    char states[160];
    fmu_states_str(mask, states, sizeof states);
    fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
            "%s: illegal call sequence: not allowed in state %s (allowed in: %s)", fn,
            fmu_state_name(S->state), states);
    return 0;
}

#define BEGIN_FUNCTION(F)                                                                     \
    fmu_status status = FMU_OK;                                                               \
    fmu_instance *S = (fmu_instance *)c;                                                      \
    if (S == NULL) {                                                                          \
        return fmi2Error;                                                                     \
    }                                                                                         \
    if (!allowed_state(S, MASK_fmi2##F, "fmi2" #F)) {                                         \
        status = FMU_ERROR;                                                                   \
        goto END;                                                                             \
    }

#define END_FUNCTION()                                                                        \
    END:                                                                                      \
    return (fmi2Status)status;

/* Trace an accepted call with its arguments (category logCalls, off by default). */
#define TRACE(...) fmu_log(S, FMU_OK, FMU_LOG_CALLS, __VA_ARGS__)

/* Refuse the call (nothing changes) with an error message naming the function. */
#define REFUSE(...)                                                                           \
    do {                                                                                      \
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, __VA_ARGS__);                                    \
        status = FMU_ERROR;                                                                   \
        goto END;                                                                             \
    } while (0)

/* A pointer argument that must not be NULL (when n values are passed). */
#define ASSERT_NOT_NULL(F, p)                                                                 \
    do {                                                                                      \
        if ((p) == NULL) {                                                                    \
            REFUSE("fmi2" #F ": argument " #p " must not be NULL");                           \
        }                                                                                     \
    } while (0)

/* An instance-level operation that refuses on error: status, no state change. */
#define CHECKED(x)                                                                            \
    do {                                                                                      \
        const fmu_status s_ = (x);                                                            \
        if (s_ > status) {                                                                    \
            status = s_;                                                                      \
        }                                                                                     \
        if (status > FMU_WARNING) {                                                           \
            goto END;                                                                         \
        }                                                                                     \
    } while (0)

/* A model hook: keep the worst status; Error and Fatal move the state machine. */
#define CALL(x)                                                                               \
    do {                                                                                      \
        const fmu_status s_ = (x);                                                            \
        if (s_ > status) {                                                                    \
            status = s_;                                                                      \
        }                                                                                     \
        if (status == FMU_ERROR) {                                                            \
            S->state = FMU_ERROR_STATE;                                                       \
        } else if (status == FMU_FATAL) {                                                     \
            S->state = FMU_FATAL_STATE;                                                       \
        }                                                                                     \
        if (status > FMU_WARNING) {                                                           \
            goto END;                                                                         \
        }                                                                                     \
    } while (0)

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

fmi2Component fmi2Instantiate(fmi2String instanceName, fmi2Type fmuType, fmi2String fmuGUID,
                              fmi2String fmuResourceLocation,
                              const fmi2CallbackFunctions *functions, fmi2Boolean visible,
                              fmi2Boolean loggingOn)
{
    (void)fmuResourceLocation; /* no resources */
    (void)visible;             /* no user interface */
    return fmu_create(instanceName, fmuType, fmuGUID, functions, loggingOn);
}

void fmi2FreeInstance(fmi2Component c)
{
    fmu_instance *S = (fmu_instance *)c;
    if (S == NULL || !allowed_state(S, MASK_fmi2FreeInstance, "fmi2FreeInstance")) {
        return;
    }
    fmu_destroy(S);
}

fmi2Status fmi2SetDebugLogging(fmi2Component c, fmi2Boolean loggingOn, size_t nCategories,
                               const fmi2String categories[])
{
    BEGIN_FUNCTION(SetDebugLogging)
    TRACE("fmi2SetDebugLogging(loggingOn=%d, nCategories=%zu)", (int)loggingOn, nCategories);
    CHECKED(fmu_set_logging(S, loggingOn, nCategories, categories));
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
    (void)toleranceDefined; /* fixed-step integration: no tolerance */
    (void)tolerance;
    if (!isfinite(startTime)) {
        REFUSE("fmi2SetupExperiment: startTime must be finite, got %.17g", startTime);
    }
    if (stopTimeDefined && !(isfinite(stopTime) && stopTime >= startTime)) {
        REFUSE("fmi2SetupExperiment: stopTime must be finite and >= startTime = %.17g, got %.17g",
               startTime, stopTime);
    }
    S->start_time = startTime;
    S->time = startTime;
    S->stop_time_defined = stopTimeDefined ? 1 : 0;
    S->stop_time = stopTimeDefined ? stopTime : 0.0;
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
    CALL(S->model->initialize(S));
    S->state = FMU_STEP_COMPLETE;
    S->dirty = 1;
    CALL(fmu_update(S));
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

fmi2Status fmi2GetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       fmi2Real value[])
{
    BEGIN_FUNCTION(GetReal)
    TRACE("fmi2GetReal(nvr=%zu)", nvr);
    if (nvr > 0) {
        ASSERT_NOT_NULL(GetReal, vr);
        ASSERT_NOT_NULL(GetReal, value);
    }
    if (fmu_needs_update(S, vr, nvr)) {
        CALL(fmu_update(S));
    }
    CHECKED(fmu_get_values(S, "fmi2GetReal", FMU_REAL, vr, nvr, value));
    END_FUNCTION()
}

fmi2Status fmi2GetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Integer value[])
{
    BEGIN_FUNCTION(GetInteger)
    TRACE("fmi2GetInteger(nvr=%zu)", nvr);
    (void)value;
    if (nvr > 0) {
        ASSERT_NOT_NULL(GetInteger, vr);
        REFUSE("fmi2GetInteger: %s has no Integer variables (vr %u requested)",
               S->model->identifier, (unsigned)vr[0]);
    }
    END_FUNCTION()
}

fmi2Status fmi2GetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          fmi2Boolean value[])
{
    BEGIN_FUNCTION(GetBoolean)
    TRACE("fmi2GetBoolean(nvr=%zu)", nvr);
    if (nvr > 0) {
        ASSERT_NOT_NULL(GetBoolean, vr);
        ASSERT_NOT_NULL(GetBoolean, value);
    }
    if (fmu_needs_update(S, vr, nvr)) {
        CALL(fmu_update(S));
    }
    CHECKED(fmu_get_values(S, "fmi2GetBoolean", FMU_BOOLEAN, vr, nvr, value));
    END_FUNCTION()
}

fmi2Status fmi2GetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         fmi2String value[])
{
    BEGIN_FUNCTION(GetString)
    TRACE("fmi2GetString(nvr=%zu)", nvr);
    (void)value;
    if (nvr > 0) {
        ASSERT_NOT_NULL(GetString, vr);
        REFUSE("fmi2GetString: %s has no String variables (vr %u requested)",
               S->model->identifier, (unsigned)vr[0]);
    }
    END_FUNCTION()
}

fmi2Status fmi2SetReal(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                       const fmi2Real value[])
{
    BEGIN_FUNCTION(SetReal)
    TRACE("fmi2SetReal(nvr=%zu)", nvr);
    if (nvr > 0) {
        ASSERT_NOT_NULL(SetReal, vr);
        ASSERT_NOT_NULL(SetReal, value);
    }
    CHECKED(fmu_set_values(S, "fmi2SetReal", FMU_REAL, vr, nvr, value));
    END_FUNCTION()
}

fmi2Status fmi2SetInteger(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Integer value[])
{
    BEGIN_FUNCTION(SetInteger)
    TRACE("fmi2SetInteger(nvr=%zu)", nvr);
    (void)value;
    if (nvr > 0) {
        ASSERT_NOT_NULL(SetInteger, vr);
        REFUSE("fmi2SetInteger: %s has no Integer variables (vr %u requested)",
               S->model->identifier, (unsigned)vr[0]);
    }
    END_FUNCTION()
}

fmi2Status fmi2SetBoolean(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                          const fmi2Boolean value[])
{
    BEGIN_FUNCTION(SetBoolean)
    TRACE("fmi2SetBoolean(nvr=%zu)", nvr);
    if (nvr > 0) {
        ASSERT_NOT_NULL(SetBoolean, vr);
        ASSERT_NOT_NULL(SetBoolean, value);
    }
    CHECKED(fmu_set_values(S, "fmi2SetBoolean", FMU_BOOLEAN, vr, nvr, value));
    END_FUNCTION()
}

fmi2Status fmi2SetString(fmi2Component c, const fmi2ValueReference vr[], size_t nvr,
                         const fmi2String value[])
{
    BEGIN_FUNCTION(SetString)
    TRACE("fmi2SetString(nvr=%zu)", nvr);
    (void)value;
    if (nvr > 0) {
        ASSERT_NOT_NULL(SetString, vr);
        REFUSE("fmi2SetString: %s has no String variables (vr %u requested)",
               S->model->identifier, (unsigned)vr[0]);
    }
    END_FUNCTION()
}

/* ---- FMU state ------------------------------------------------------------------------------- */

fmi2Status fmi2GetFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    BEGIN_FUNCTION(GetFMUstate)
    TRACE("fmi2GetFMUstate()");
    ASSERT_NOT_NULL(GetFMUstate, FMUstate);
    CHECKED(fmu_snapshot_get(S, FMUstate));
    END_FUNCTION()
}

fmi2Status fmi2SetFMUstate(fmi2Component c, fmi2FMUstate FMUstate)
{
    BEGIN_FUNCTION(SetFMUstate)
    TRACE("fmi2SetFMUstate(FMUstate=%p)", FMUstate);
    CHECKED(fmu_snapshot_set(S, FMUstate));
    END_FUNCTION()
}

fmi2Status fmi2FreeFMUstate(fmi2Component c, fmi2FMUstate *FMUstate)
{
    BEGIN_FUNCTION(FreeFMUstate)
    TRACE("fmi2FreeFMUstate()");
    ASSERT_NOT_NULL(FreeFMUstate, FMUstate);
    CHECKED(fmu_snapshot_free(S, FMUstate));
    END_FUNCTION()
}

fmi2Status fmi2SerializedFMUstateSize(fmi2Component c, fmi2FMUstate FMUstate, size_t *size)
{
    BEGIN_FUNCTION(SerializedFMUstateSize)
    TRACE("fmi2SerializedFMUstateSize(FMUstate=%p)", FMUstate);
    ASSERT_NOT_NULL(SerializedFMUstateSize, size);
    CHECKED(fmu_snapshot_size(S, FMUstate, size));
    END_FUNCTION()
}

fmi2Status fmi2SerializeFMUstate(fmi2Component c, fmi2FMUstate FMUstate,
                                 fmi2Byte serializedState[], size_t size)
{
    BEGIN_FUNCTION(SerializeFMUstate)
    TRACE("fmi2SerializeFMUstate(FMUstate=%p, size=%zu)", FMUstate, size);
    ASSERT_NOT_NULL(SerializeFMUstate, serializedState);
    CHECKED(fmu_snapshot_serialize(S, FMUstate, serializedState, size));
    END_FUNCTION()
}

fmi2Status fmi2DeSerializeFMUstate(fmi2Component c, const fmi2Byte serializedState[], size_t size,
                                   fmi2FMUstate *FMUstate)
{
    BEGIN_FUNCTION(DeSerializeFMUstate)
    TRACE("fmi2DeSerializeFMUstate(size=%zu)", size);
    ASSERT_NOT_NULL(DeSerializeFMUstate, serializedState);
    ASSERT_NOT_NULL(DeSerializeFMUstate, FMUstate);
    CHECKED(fmu_snapshot_deserialize(S, serializedState, size, FMUstate));
    END_FUNCTION()
}

/* ---- not provided (capability flags false in the XML) ------------------------------------------ */

fmi2Status fmi2GetDirectionalDerivative(fmi2Component c, const fmi2ValueReference vUnknown_ref[],
                                        size_t nUnknown, const fmi2ValueReference vKnown_ref[],
                                        size_t nKnown, const fmi2Real dvKnown[],
                                        fmi2Real dvUnknown[])
{
    BEGIN_FUNCTION(GetDirectionalDerivative)
    TRACE("fmi2GetDirectionalDerivative(nUnknown=%zu, nKnown=%zu)", nUnknown, nKnown);
    (void)vUnknown_ref;
    (void)vKnown_ref;
    (void)dvKnown;
    (void)dvUnknown;
    REFUSE("fmi2GetDirectionalDerivative: not provided (providesDirectionalDerivative=false)");
    END_FUNCTION()
}

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

/* ---- stepping -------------------------------------------------------------------------------- */

fmi2Status fmi2DoStep(fmi2Component c, fmi2Real currentCommunicationPoint,
                      fmi2Real communicationStepSize, fmi2Boolean noSetFMUStatePriorToCurrentPoint)
{
    BEGIN_FUNCTION(DoStep)
    TRACE("fmi2DoStep(currentCommunicationPoint=%.17g, communicationStepSize=%.17g, "
          "noSetFMUStatePriorToCurrentPoint=%d)",
          currentCommunicationPoint, communicationStepSize, (int)noSetFMUStatePriorToCurrentPoint);
    const double t = currentCommunicationPoint;
    const double h = communicationStepSize;
    if (!(isfinite(h) && h > 0.0)) {
        REFUSE("fmi2DoStep: communicationStepSize must be finite and > 0, got %.17g", h);
    }
    if (!(fabs(t - S->time) <= FMU_TIME_RTOL * fmax(1.0, fabs(S->time)))) {
        REFUSE("fmi2DoStep: currentCommunicationPoint %.17g differs from the FMU time %.17g "
               "(tolerance %.3g)",
               t, S->time, FMU_TIME_RTOL * fmax(1.0, fabs(S->time)));
    }
    if (S->stop_time_defined && t + h > S->stop_time + FMU_TIME_RTOL * fmax(1.0, S->stop_time)) {
        REFUSE("fmi2DoStep: the step to %.17g goes past stopTime %.17g", t + h, S->stop_time);
    }
    const fmu_status st = S->model->do_step(S, h);
    if (st == FMU_DISCARD) {
        S->state = FMU_STEP_FAILED; /* time stays at the last successful point */
    }
    CALL(st);
    S->time = t + h; /* the master's clock is authoritative: no drift from summing h */
    S->dirty = 0;    /* do_step leaves the outputs up to date */
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
    ASSERT_NOT_NULL(GetRealStatus, value);
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
    ASSERT_NOT_NULL(GetBooleanStatus, value);
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
