/*
 * modelDescription.xml from a model's variable table (FMI 2.0, co-simulation).
 * The element order is the one the XSD requires: CoSimulation, UnitDefinitions, LogCategories,
 * DefaultExperiment, ModelVariables, ModelStructure.
 */
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmu_internal.h"
#include "fmu_xml.h"

/* Shortest "%.*g" text that reads back as the same double. */
static void fmt_real(char *buf, size_t n, double v)
{
    for (int prec = 1; prec <= 17; ++prec) {
        snprintf(buf, n, "%.*g", prec, v);
        if (strtod(buf, NULL) == v) {
            return;
        }
    }
}

static int unit_used(const fmu_model *m, const char *unit)
{
    for (size_t i = 0; i < m->n_vars; ++i) {
        if (m->vars[i].unit != NULL && strcmp(m->vars[i].unit, unit) == 0) {
            return 1;
        }
    }
    return 0;
}

static void write_units(const fmu_model *m, FILE *f)
{
    static const char *const base[] = {"kg", "m", "s", "A", "rad"};
    fprintf(f, "  <UnitDefinitions>\n");
    for (size_t i = 0; i < fmu_n_units; ++i) {
        const fmu_unit *u = &fmu_units[i];
        if (!unit_used(m, u->name)) {
            continue;
        }
        const int exps[] = {u->kg, u->m, u->s, u->A, u->rad};
        fprintf(f, "    <Unit name=\"%s\">\n      <BaseUnit", u->name);
        for (size_t k = 0; k < sizeof exps / sizeof exps[0]; ++k) {
            if (exps[k] != 0) {
                fprintf(f, " %s=\"%d\"", base[k], exps[k]);
            }
        }
        fprintf(f, "/>\n    </Unit>\n");
    }
    fprintf(f, "  </UnitDefinitions>\n");
}

static void write_variables(const fmu_model *m, const void *data, FILE *f)
{
    fprintf(f, "  <ModelVariables>\n");
    for (size_t i = 0; i < m->n_vars; ++i) {
        const fmu_variable *v = &m->vars[i];
        fprintf(f, "    <!-- index %zu -->\n", i + 1);
        fprintf(f,
                "    <ScalarVariable name=\"%s\" valueReference=\"%u\" causality=\"%s\" "
                "variability=\"%s\"",
                v->name, (unsigned)v->vr, fmu_causality_name(v->causality),
                fmu_variability_name(v->variability));
        if (v->causality == FMU_PARAMETER) {
            fprintf(f, " initial=\"exact\"");
        } else if (v->causality == FMU_OUTPUT) {
            fprintf(f, " initial=\"calculated\"");
        }
        fprintf(f, "\n      description=\"%s\">\n", v->description);
        fprintf(f, "      <%s", fmu_type_name(v->type));
        if (v->unit != NULL) {
            fprintf(f, " unit=\"%s\"", v->unit);
        }
        if (v->causality != FMU_OUTPUT) {
            const void *p = (const char *)data + v->offset;
            if (v->type == FMU_REAL) {
                double d;
                char buf[40];
                memcpy(&d, p, sizeof d);
                fmt_real(buf, sizeof buf, d);
                fprintf(f, " start=\"%s\"", buf);
            } else {
                int b;
                memcpy(&b, p, sizeof b);
                fprintf(f, " start=\"%s\"", b ? "true" : "false");
            }
        }
        fprintf(f, "/>\n    </ScalarVariable>\n");
    }
    fprintf(f, "  </ModelVariables>\n");
}

static void write_structure(const fmu_model *m, FILE *f)
{
    fprintf(f, "  <ModelStructure>\n    <Outputs>\n");
    for (size_t i = 0; i < m->n_vars; ++i) {
        const fmu_variable *o = &m->vars[i];
        if (o->causality != FMU_OUTPUT) {
            continue;
        }
        fprintf(f, "      <Unknown index=\"%zu\" dependencies=\"", i + 1);
        int first = 1;
        for (size_t k = 0; k < m->n_vars; ++k) {
            if (m->vars[k].causality == FMU_INPUT && m->depends(o->vr, m->vars[k].vr)) {
                fprintf(f, "%s%zu", first ? "" : " ", k + 1);
                first = 0;
            }
        }
        fprintf(f, "\"/>\n");
    }
    fprintf(f, "    </Outputs>\n    <InitialUnknowns>\n");
    for (size_t i = 0; i < m->n_vars; ++i) {
        if (m->vars[i].causality == FMU_OUTPUT) {
            fprintf(f, "      <Unknown index=\"%zu\"/>\n", i + 1);
        }
    }
    fprintf(f, "    </InitialUnknowns>\n  </ModelStructure>\n");
}

int fmu_write_xml(const fmu_model *m, FILE *f)
{
    const char *problem = NULL;
    size_t row = 0;
    if (fmu_model_check(m, &problem, &row) != 0) {
        fprintf(stderr, "%s: broken variable table at row %zu: %s\n", m->identifier, row, problem);
        return 1;
    }
    void *data = calloc(1, m->data_size);
    if (data == NULL || m->set_defaults(data) > FMU_WARNING) {
        fprintf(stderr, "%s: could not compute the start values\n", m->identifier);
        free(data);
        return 1;
    }
    char token[FMU_TOKEN_SIZE];
    char stop[40];
    char step[40];
    fmu_model_token(m, data, token);
    fmt_real(stop, sizeof stop, m->default_stop_time);
    fmt_real(step, sizeof step, m->default_step_size);

    fprintf(f, "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    fprintf(f, "<!-- Generated from the variable table of %s by fmu/common/fmu_xml.c; do not edit.\n"
               "     To update the committed copy, build the CMake target rrr_fmu_update_xml. -->\n",
            m->identifier);
    fprintf(f,
            "<fmiModelDescription\n"
            "  fmiVersion=\"2.0\"\n"
            "  modelName=\"%s\"\n"
            "  guid=\"%s\"\n"
            "  description=\"%s\"\n"
            "  generationTool=\"rrr fmu/common/fmu_xml.c\"\n"
            "  variableNamingConvention=\"structured\"\n"
            "  numberOfEventIndicators=\"0\">\n",
            m->identifier, token, m->description);
    fprintf(f,
            "  <CoSimulation\n"
            "    modelIdentifier=\"%s\"\n"
            "    canHandleVariableCommunicationStepSize=\"true\"\n"
            "    canGetAndSetFMUstate=\"true\"\n"
            "    canSerializeFMUstate=\"true\"/>\n",
            m->identifier);
    write_units(m, f);
    fprintf(f, "  <LogCategories>\n");
    for (size_t i = 0; i < FMU_LOG_CATEGORY_COUNT; ++i) {
        fprintf(f, "    <Category name=\"%s\" description=\"%s\"/>\n", fmu_log_categories[i].name,
                fmu_log_categories[i].description);
    }
    fprintf(f, "  </LogCategories>\n");
    fprintf(f, "  <DefaultExperiment startTime=\"0\" stopTime=\"%s\" stepSize=\"%s\"/>\n", stop,
            step);
    write_variables(m, data, f);
    write_structure(m, f);
    fprintf(f, "</fmiModelDescription>\n");
    free(data);
    return ferror(f) ? 1 : 0;
}
