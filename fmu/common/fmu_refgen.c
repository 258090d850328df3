/*
 * Build-time tool: the reference result of an FMU's default experiment, as the Reference-FMUs
 * ship theirs (the layered standard FMI-LS-REF: extra/org.fmi-standard.fmi-ls-ref/ holds
 * fmi-ls-manifest.xml and <modelIdentifier>_out.csv).
 *
 * Usage: <model>_refgen --csv OUT.csv --manifest OUT.xml [--resources DIR]
 *
 * Linked from the same sources as the FMU's binary (the FMI 2.0 adapter, the model, the core,
 * librrr), it runs the FMU through its own FMI 2.0 Co-Simulation functions, in this process:
 * instantiated with its instantiation token, every start value as the model description gives
 * it, from the DefaultExperiment's start to its stop time in steps of its step size. The CSV has
 * a header "time,<every output, in value-reference order>" and one line per communication
 * point, every value as %.17g (it reads back to the same double). FMI 3.0 gives the same
 * results bit for bit, so both archives of a model carry this file. Any FMI status but OK is a
 * failure: message on stderr, exit status 1.
 */
#include "fmi2Functions.h"
#include "fmu_model.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

static void logger(fmi2ComponentEnvironment env, fmi2String instance, fmi2Status status,
                   fmi2String category, fmi2String message, ...)
{
    (void)env;
    if (status == fmi2OK) {
        return;
    }
    va_list args;
    va_start(args, message);
    fprintf(stderr, "%s [%s]: ", instance, category);
    vfprintf(stderr, message, args);
    fputc('\n', stderr);
    va_end(args);
}

static int write_manifest(const char *path, const char *csv_name)
{
    FILE *f = fopen(path, "w");
    if (f == NULL) {
        perror(path);
        return 1;
    }
    fprintf(f,
            "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n"
            "<fmiReferences\n"
            "    xmlns:xsi=\"http://www.w3.org/2001/XMLSchema-instance\"\n"
            "    xmlns:fmi-ls=\"http://fmi-standard.org/fmi-ls-manifest\"\n"
            "    fmi-ls:fmi-ls-name=\"org.fmi-standard.fmi-ls-ref\"\n"
            "    fmi-ls:fmi-ls-version=\"1.0.0-alpha.1\">\n"
            "    <Related type=\"text/csv\" source=\"%s\" role=\"result\" "
            "description=\"Output of the default experiment\"/>\n"
            "</fmiReferences>\n",
            csv_name);
    if (fclose(f) != 0) {
        perror(path);
        return 1;
    }
    return 0;
}

/* The default experiment through the FMI 2.0 Co-Simulation functions, into f. */
static int simulate(const fmu_model *m, const char *resource_uri, FILE *f)
{
    void *data = calloc(1, m->data_size);
    if (data == NULL || m->set_defaults(data) > FMU_WARNING) {
        fprintf(stderr, "%s: could not compute the start values\n", m->identifier);
        free(data);
        return 1;
    }
    char token[FMU_TOKEN_SIZE];
    fmu_model_token(m, data, token);
    free(data);
    fmi2CallbackFunctions cb = {logger, calloc, free, NULL, NULL};
    fmi2Component c = fmi2Instantiate(m->identifier, fmi2CoSimulation, token, resource_uri, &cb,
                                      fmi2False, fmi2False);
    if (c == NULL) {
        fprintf(stderr, "%s: fmi2Instantiate failed\n", m->identifier);
        return 1;
    }
    const double h = m->default_step_size, stop = m->default_stop_time;
    const long n = (long)(stop / h + 0.5);
    fmi2ValueReference vr[256];
    size_t n_out = 0;
    fprintf(f, "time");
    for (size_t i = 0; i < m->n_vars && n_out < sizeof vr / sizeof vr[0]; ++i) {
        if (m->vars[i].causality == FMU_OUTPUT && m->vars[i].type == FMU_REAL) {
            vr[n_out++] = m->vars[i].vr;
            fprintf(f, ",%s", m->vars[i].name);
        }
    }
    fputc('\n', f);
    int rc = fmi2SetupExperiment(c, fmi2False, 0.0, 0.0, fmi2True, stop) != fmi2OK ||
             fmi2EnterInitializationMode(c) != fmi2OK || fmi2ExitInitializationMode(c) != fmi2OK;
    double value[256];
    for (long k = 0; rc == 0 && k <= n; ++k) {
        const double t = (double)k * h;
        rc = fmi2GetReal(c, vr, n_out, value) != fmi2OK;
        fprintf(f, "%.17g", t);
        for (size_t j = 0; j < n_out; ++j) {
            fprintf(f, ",%.17g", value[j]);
        }
        fputc('\n', f);
        if (rc == 0 && k < n) {
            rc = fmi2DoStep(c, t, h, fmi2True) != fmi2OK;
        }
    }
    if (rc != 0) {
        fprintf(stderr, "%s: the default experiment failed (an FMI call did not return OK)\n",
                m->identifier);
    } else {
        rc = fmi2Terminate(c) != fmi2OK;
    }
    fmi2FreeInstance(c);
    return rc;
}

int main(int argc, char **argv)
{
    const char *csv = NULL, *manifest = NULL, *resources = NULL;
    for (int i = 1; i + 1 < argc; i += 2) {
        if (strcmp(argv[i], "--csv") == 0) {
            csv = argv[i + 1];
        } else if (strcmp(argv[i], "--manifest") == 0) {
            manifest = argv[i + 1];
        } else if (strcmp(argv[i], "--resources") == 0) {
            resources = argv[i + 1];
        } else {
            csv = NULL;
            break;
        }
    }
    if (csv == NULL || manifest == NULL || argc % 2 == 0) {
        fprintf(stderr, "usage: %s --csv OUT.csv --manifest OUT.xml [--resources DIR]\n",
                argv[0]);
        return 2;
    }
    char uri[4096] = "";
    if (resources != NULL &&
        (size_t)snprintf(uri, sizeof uri, "file://%s/", resources) >= sizeof uri) {
        fprintf(stderr, "%s: resource folder name too long\n", argv[0]);
        return 2;
    }
    FILE *f = fopen(csv, "w");
    if (f == NULL) {
        perror(csv);
        return 1;
    }
    int rc = simulate(&FMU_MODEL, resources != NULL ? uri : NULL, f);
    if (fclose(f) != 0) {
        perror(csv);
        rc = 1;
    }
    const char *slash = strrchr(csv, '/');
    rc |= write_manifest(manifest, slash != NULL ? slash + 1 : csv);
    if (rc != 0) {
        remove(csv);
    }
    return rc;
}
