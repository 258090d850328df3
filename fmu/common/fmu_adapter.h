/**
 * @file fmu_adapter.h
 * @brief The macros of the FMI adapters (fmi2_functions.c, fmi3_functions.c): one body shape for
 *        every exported function, in the style of the Reference-FMUs.
 *
 *     fmiXStatus fmiXFoo(fmiXInstance inst, ...)
 *     {
 *         BEGIN_FUNCTION(Foo)      // adapter macro over FMU_BEGIN: NULL instance, state mask
 *         TRACE("fmiXFoo(...)");   // category logCalls
 *         ASSERT_NOT_NULL(arg);    // refusal: Error and a message, nothing changes
 *         CHECKED(fmu_...(S, ...)); // an instance-level operation that may refuse
 *         CALL(hook(S));           // a model hook: Error/Fatal move the state machine
 *         END_FUNCTION()           // the single exit: returns the worst status
 *     }
 *
 * Inside a body: S is the instance, status the worst status so far, fn_ the function's name.
 */
#ifndef FMU_ADAPTER_H
#define FMU_ADAPTER_H

#include "fmu_internal.h"

/* Start a function of instance INST: a NULL instance returns NULL_STATUS, a state outside MASK
 * is an illegal call sequence (Error and a message naming FN and the state). */
#define FMU_BEGIN(INST, MASK, FN, NULL_STATUS)                                                \
    fmu_status status = FMU_OK;                                                               \
    fmu_instance *S = (fmu_instance *)(INST);                                                 \
    const char *const fn_ = (FN);                                                             \
    if (S == NULL) {                                                                          \
        return (NULL_STATUS);                                                                 \
    }                                                                                         \
    if (!fmu_allowed_state(S, (MASK), fn_)) {                                                 \
        status = FMU_ERROR;                                                                   \
        goto END;                                                                             \
    }

/* The single exit, returning status as the version's status type. */
#define FMU_END(STATUS_TYPE)                                                                  \
    END:                                                                                      \
    return (STATUS_TYPE)status;

/* Trace an accepted call with its arguments (category logCalls, off by default). */
#define TRACE(...) fmu_log(S, FMU_OK, FMU_LOG_CALLS, __VA_ARGS__)

/* Refuse the call (nothing changes) with an error message naming the function. */
#define REFUSE(...)                                                                           \
    do {                                                                                      \
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, __VA_ARGS__);                                    \
        status = FMU_ERROR;                                                                   \
        goto END;                                                                             \
    } while (0)

/* A pointer argument that must not be NULL. */
#define ASSERT_NOT_NULL(p)                                                                    \
    do {                                                                                      \
        if ((p) == NULL) {                                                                    \
            REFUSE("%s: argument " #p " must not be NULL", fn_);                              \
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

/* The state mask of a function of one interface type (see FMU_ME_ONLY, FMU_CS_ONLY). */
#define ME_ONLY(mask) FMU_ME_ONLY(S, mask)
#define CS_ONLY(mask) FMU_CS_ONLY(S, mask)

#endif /* FMU_ADAPTER_H */
