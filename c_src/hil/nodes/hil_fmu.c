/* A minimal FMI 2.0 co-simulation importer (see hil_fmu.h). */
#include "hil_fmu.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void fmu_logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status,
                       fmi2String category, fmi2String message, ...)
{
    (void)env;
    if (status == fmi2OK) {
        return;
    }
    va_list ap;
    va_start(ap, message);
    fprintf(stderr, "[fmu %s %s status %d] ", instance ? instance : "?", category ? category : "",
            (int)status);
    vfprintf(stderr, message, ap);
    fputc('\n', stderr);
    va_end(ap);
}

static const fmi2CallbackFunctions callbacks = {fmu_logger, calloc, free, NULL, NULL};

#define LOAD(F) rrr_fmi_lib_sym(&f->lib, "fmi2" #F, &f->F, sizeof f->F, f->last_error, \
                               sizeof f->last_error)

int rrr_hil_fmu_open(rrr_hil_fmu *f, const char *dir, const char *instance_name)
{
    memset(f, 0, sizeof *f);
    char why[300];
    if (rrr_fmi_md_load(&f->md, dir, why, sizeof why) != 0 || f->md.fmi != 2) {
        snprintf(f->last_error, sizeof f->last_error, "%.250s (--fmu must name an unzipped FMI 2.0 "
                 "FMU directory: %.200s)", f->md.fmi == 2 || f->md.xml == NULL ? why :
                 "not FMI 2.0", dir);
        rrr_hil_fmu_close(f);
        return -1;
    }
    snprintf(f->id, sizeof f->id, "%s", f->md.id);
    char path[4096];
    char resources[4096 + 32];
    if (rrr_fmi_binary_path(path, sizeof path, dir, 2, f->id) != 0 ||
        rrr_fmi_resource_uri(resources, sizeof resources, dir) != 0) {
        snprintf(f->last_error, sizeof f->last_error, "path too long: %.200s", dir);
        rrr_hil_fmu_close(f);
        return -1;
    }
    if (rrr_fmi_lib_open(&f->lib, path, f->last_error, sizeof f->last_error) != 0) {
        rrr_hil_fmu_close(f);
        return -1;
    }
    if (LOAD(Instantiate) || LOAD(FreeInstance) || LOAD(SetupExperiment) ||
        LOAD(EnterInitializationMode) || LOAD(ExitInitializationMode) || LOAD(Terminate) ||
        LOAD(GetReal) || LOAD(SetReal) || LOAD(DoStep)) {
        rrr_hil_fmu_close(f);
        return -1;
    }
    f->c = f->Instantiate(instance_name, fmi2CoSimulation, f->md.token, resources, &callbacks,
                          fmi2False, fmi2False);
    if (f->c == NULL) {
        snprintf(f->last_error, sizeof f->last_error, "FMU %s: fmi2Instantiate failed", f->id);
        rrr_hil_fmu_close(f);
        return -1;
    }
    return 0;
}

long rrr_hil_fmu_vr(rrr_hil_fmu *f, const char *name)
{
    unsigned long vr = 0;
    if (rrr_fmi_md_vr(&f->md, name, "Real", &vr, f->last_error, sizeof f->last_error) != 0) {
        return -1;
    }
    return vr <= 0x7FFFFFFFul ? (long)vr : -1;
}

int rrr_hil_fmu_set(rrr_hil_fmu *f, const fmi2ValueReference *vr, size_t n, const double *v)
{
    if (f->SetReal(f->c, vr, n, v) > fmi2Warning) {
        snprintf(f->last_error, sizeof f->last_error, "FMU %s: fmi2SetReal failed at t = %.17g",
                 f->id, f->time);
        return -1;
    }
    return 0;
}

int rrr_hil_fmu_get(rrr_hil_fmu *f, const fmi2ValueReference *vr, size_t n, double *v)
{
    if (f->GetReal(f->c, vr, n, v) > fmi2Warning) {
        snprintf(f->last_error, sizeof f->last_error, "FMU %s: fmi2GetReal failed at t = %.17g",
                 f->id, f->time);
        return -1;
    }
    return 0;
}

int rrr_hil_fmu_set_by_name(rrr_hil_fmu *f, const char *name, double v)
{
    const long vr = rrr_hil_fmu_vr(f, name);
    if (vr < 0) {
        return -1;
    }
    const fmi2ValueReference r = (fmi2ValueReference)vr;
    if (rrr_hil_fmu_set(f, &r, 1, &v) != 0) {
        snprintf(f->last_error, sizeof f->last_error, "FMU %s refused %s = %.17g", f->id, name, v);
        return -1;
    }
    return 0;
}

int rrr_hil_fmu_init(rrr_hil_fmu *f, double t0)
{
    if (f->SetupExperiment(f->c, fmi2False, 0.0, t0, fmi2False, 0.0) > fmi2Warning ||
        f->EnterInitializationMode(f->c) > fmi2Warning ||
        f->ExitInitializationMode(f->c) > fmi2Warning) {
        snprintf(f->last_error, sizeof f->last_error,
                 "FMU %s: initialisation failed (see its log above)", f->id);
        return -1;
    }
    f->time = t0;
    return 0;
}

int rrr_hil_fmu_step(rrr_hil_fmu *f, double h)
{
    if (f->DoStep(f->c, f->time, h, fmi2True) > fmi2Warning) {
        snprintf(f->last_error, sizeof f->last_error,
                 "FMU %s: fmi2DoStep(t = %.17g, h = %.17g) failed", f->id, f->time, h);
        return -1;
    }
    f->time += h;
    return 0;
}

void rrr_hil_fmu_close(rrr_hil_fmu *f)
{
    if (f->c != NULL) {
        (void)f->Terminate(f->c);
        f->FreeInstance(f->c);
        f->c = NULL;
    }
    rrr_fmi_lib_close(&f->lib);
    rrr_fmi_md_free(&f->md);
}
