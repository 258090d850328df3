/* A minimal FMI 2.0 co-simulation importer (see hil_fmu.h). */
#define _DEFAULT_SOURCE /* realpath; implies POSIX.1-2008 */

#include "hil_fmu.h"

#include <dlfcn.h>
#include <limits.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static char *read_text(const char *path)
{
    FILE *fp = fopen(path, "rb");
    if (fp == NULL) {
        return NULL;
    }
    char *buf = NULL;
    if (fseek(fp, 0, SEEK_END) == 0) {
        const long n = ftell(fp);
        if (n > 0 && fseek(fp, 0, SEEK_SET) == 0) {
            buf = malloc((size_t)n + 1u);
            if (buf != NULL && fread(buf, 1, (size_t)n, fp) == (size_t)n) {
                buf[n] = '\0';
            } else {
                free(buf);
                buf = NULL;
            }
        }
    }
    fclose(fp);
    return buf;
}

/* Value of the first attribute ` attr="..."` at or after from, before the element's end. */
static int xml_attr(const char *from, const char *attr, char *out, size_t n)
{
    char key[80];
    snprintf(key, sizeof key, " %s=\"", attr);
    const char *p = strstr(from, key);
    const char *gt = strchr(from, '>');
    if (p == NULL || (gt != NULL && p > gt)) {
        return -1;
    }
    p += strlen(key);
    const char *e = strchr(p, '"');
    if (e == NULL || (size_t)(e - p) >= n) {
        return -1;
    }
    memcpy(out, p, (size_t)(e - p));
    out[e - p] = '\0';
    return 0;
}

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

static int load_sym(rrr_hil_fmu *f, const char *name, void *dst, size_t size)
{
    void *p = dlsym(f->dl, name);
    if (p == NULL || size != sizeof p) {
        snprintf(f->last_error, sizeof f->last_error, "FMU %s: missing symbol %s", f->id, name);
        return -1;
    }
    memcpy(dst, &p, sizeof p); /* object pointer to function pointer, the POSIX way */
    return 0;
}

#define LOAD(F) load_sym(f, "fmi2" #F, &f->F, sizeof f->F)

int rrr_hil_fmu_open(rrr_hil_fmu *f, const char *dir, const char *instance_name)
{
    memset(f, 0, sizeof *f);
    char path[PATH_MAX + 64];
    char guid[128];
    snprintf(path, sizeof path, "%s/modelDescription.xml", dir);
    f->xml = read_text(path);
    const char *cs = f->xml ? strstr(f->xml, "<CoSimulation") : NULL;
    if (f->xml == NULL || cs == NULL || xml_attr(cs, "modelIdentifier", f->id, sizeof f->id) != 0 ||
        xml_attr(strstr(f->xml, "<fmiModelDescription"), "guid", guid, sizeof guid) != 0) {
        snprintf(f->last_error, sizeof f->last_error,
                 "cannot read the CoSimulation modelIdentifier and the guid from %.200s "
                 "(--fmu must name an unzipped FMU directory)", path);
        rrr_hil_fmu_close(f);
        return -1;
    }
    snprintf(path, sizeof path, "%s/binaries/linux64/%s.so", dir, f->id);
    f->dl = dlopen(path, RTLD_NOW | RTLD_LOCAL);
    if (f->dl == NULL) {
        snprintf(f->last_error, sizeof f->last_error, "dlopen %.200s: %s", path, dlerror());
        rrr_hil_fmu_close(f);
        return -1;
    }
    if (LOAD(Instantiate) || LOAD(FreeInstance) || LOAD(SetupExperiment) ||
        LOAD(EnterInitializationMode) || LOAD(ExitInitializationMode) || LOAD(Terminate) ||
        LOAD(GetReal) || LOAD(SetReal) || LOAD(DoStep)) {
        rrr_hil_fmu_close(f);
        return -1;
    }
    char abs_dir[PATH_MAX];
    char resources[PATH_MAX + 32];
    snprintf(resources, sizeof resources, "file://%s/resources",
             realpath(dir, abs_dir) ? abs_dir : dir);
    f->c = f->Instantiate(instance_name, fmi2CoSimulation, guid, resources, &callbacks, fmi2False,
                          fmi2False);
    if (f->c == NULL) {
        snprintf(f->last_error, sizeof f->last_error, "FMU %s: fmi2Instantiate failed", f->id);
        rrr_hil_fmu_close(f);
        return -1;
    }
    return 0;
}

long rrr_hil_fmu_vr(rrr_hil_fmu *f, const char *name)
{
    char key[128];
    char buf[32];
    snprintf(key, sizeof key, "<ScalarVariable name=\"%s\"", name);
    const char *p = strstr(f->xml, key);
    if (p == NULL || xml_attr(p, "valueReference", buf, sizeof buf) != 0) {
        snprintf(f->last_error, sizeof f->last_error, "FMU %s has no variable '%s'", f->id, name);
        return -1;
    }
    char *end;
    const unsigned long v = strtoul(buf, &end, 10);
    return (*end == '\0' && v <= 0x7FFFFFFFul) ? (long)v : -1;
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
    if (f->dl != NULL) {
        dlclose(f->dl);
        f->dl = NULL;
    }
    free(f->xml);
    f->xml = NULL;
}
