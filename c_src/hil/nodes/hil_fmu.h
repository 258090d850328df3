/**
 * @file hil_fmu.h
 * @brief A minimal FMI 2.0 co-simulation importer for the plant node: reads modelIdentifier,
 *        guid and value references from the unzipped FMU's modelDescription.xml (through
 *        c_src/fmi_import, the project's one importer), dlopens
 *        binaries/linux64/<id>.so and drives it (instantiate, set reals by name, initialise,
 *        doStep, get reals). Lifecycle: rrr_hil_fmu_open -> set/init -> step/get -> close.
 */
#ifndef RRR_HIL_FMU_H
#define RRR_HIL_FMU_H

#include <stddef.h>

#include "fmi2FunctionTypes.h"
#include "rrr_fmi_import.h"

/** A loaded FMU instance. */
typedef struct rrr_hil_fmu {
    rrr_fmi_lib lib;           ///< the loaded binary
    rrr_fmi_md md;             ///< modelDescription.xml, parsed (c_src/fmi_import)
    char id[64];               ///< modelIdentifier
    fmi2Component c;           ///< instance
    double time;               ///< current communication point, s
    char last_error[512];      ///< text of the last failure
    fmi2InstantiateTYPE *Instantiate;
    fmi2FreeInstanceTYPE *FreeInstance;
    fmi2SetupExperimentTYPE *SetupExperiment;
    fmi2EnterInitializationModeTYPE *EnterInitializationMode;
    fmi2ExitInitializationModeTYPE *ExitInitializationMode;
    fmi2TerminateTYPE *Terminate;
    fmi2GetRealTYPE *GetReal;
    fmi2SetRealTYPE *SetReal;
    fmi2DoStepTYPE *DoStep;
} rrr_hil_fmu;

/** Load and instantiate the co-simulation FMU unzipped in @p dir. 0 or -1 (last_error set). */
int rrr_hil_fmu_open(rrr_hil_fmu *f, const char *dir, const char *instance_name);
/** Value reference of variable @p name; -1 (last_error set) if there is none. */
long rrr_hil_fmu_vr(rrr_hil_fmu *f, const char *name);
/** Set a real by name (before rrr_hil_fmu_init: parameters and start values). 0 or -1. */
int rrr_hil_fmu_set_by_name(rrr_hil_fmu *f, const char *name, double v);
/** SetupExperiment(t0), Enter/ExitInitializationMode. 0 or -1. */
int rrr_hil_fmu_init(rrr_hil_fmu *f, double t0);
/** Set / get n reals by value reference. 0 or -1. */
int rrr_hil_fmu_set(rrr_hil_fmu *f, const fmi2ValueReference *vr, size_t n, const double *v);
int rrr_hil_fmu_get(rrr_hil_fmu *f, const fmi2ValueReference *vr, size_t n, double *v);
/** DoStep from f->time over h. 0 or -1. */
int rrr_hil_fmu_step(rrr_hil_fmu *f, double h);
/** Terminate, free the instance, dlclose (idempotent). */
void rrr_hil_fmu_close(rrr_hil_fmu *f);

#endif /* RRR_HIL_FMU_H */
