/*
 * The descriptive files of an FMU from a model's variable table: modelDescription.xml for FMI 2.0
 * and 3.0, the FMI 3.0 buildDescription.xml and documentation/index.html.
 * Element order is the one the XSDs require: FMI 2: ModelExchange, CoSimulation,
 * UnitDefinitions, LogCategories, DefaultExperiment, ModelVariables, ModelStructure (Outputs,
 * Derivatives, InitialUnknowns); FMI 3: ModelExchange, CoSimulation, UnitDefinitions,
 * LogCategories, DefaultExperiment, ModelVariables, ModelStructure (Output,
 * ContinuousStateDerivative, InitialUnknown).
 *
 * FMI 3 uses the FMI 2 scalar variables with the same names and value references (no arrays),
 * so a system wired for one version works with the other unchanged.
 */
#include "fmu_internal.h"
#include "fmu_bus.h"
#include "fmu_xml.h"

#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "rrr/rrr_version.h"

/* generationTool and version of every modelDescription.xml: the toolkit's one version */
#define GENERATOR "rrr_robot " RRR_VERSION_STRING " (fmu/common/fmu_xml.c)"

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

/* The model data after set_defaults, or NULL (message on stderr). */
static void *start_values(const fmu_model *m)
{
    const char *problem = NULL;
    size_t row = 0;
    if (fmu_model_check(m, &problem, &row) != 0) {
        fprintf(stderr, "%s: broken variable table at row %zu: %s\n", m->identifier, row, problem);
        return NULL;
    }
    void *data = calloc(1, m->data_size);
    if (data == NULL || m->set_defaults(data) > FMU_WARNING) {
        fprintf(stderr, "%s: could not compute the start values\n", m->identifier);
        free(data);
        return NULL;
    }
    return data;
}

/* Start value text of row v ("" for outputs and the independent variable). */
static void start_text(const fmu_variable *v, const void *data, char *buf, size_t n)
{
    buf[0] = '\0';
    if (v->causality != FMU_PARAMETER && v->causality != FMU_INPUT) {
        return;
    }
    const void *p = (const char *)data + v->offset;
    if (v->type == FMU_REAL) {
        double d;
        memcpy(&d, p, sizeof d);
        fmt_real(buf, n, d);
    } else {
        int b;
        memcpy(&b, p, sizeof b);
        snprintf(buf, n, "%s", b ? "true" : "false");
    }
}

static int is_known(const fmu_model *m, const fmu_variable *v)
{
    return v->causality == FMU_INPUT || fmu_state_index(m, v->vr) >= 0;
}

/* ---- shared parts --------------------------------------------------------------------------- */

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

static void write_log_categories(FILE *f)
{
    fprintf(f, "  <LogCategories>\n");
    for (size_t i = 0; i < FMU_LOG_CATEGORY_COUNT; ++i) {
        fprintf(f, "    <Category name=\"%s\" description=\"%s\"/>\n", fmu_log_categories[i].name,
                fmu_log_categories[i].description);
    }
    fprintf(f, "  </LogCategories>\n");
}

static void write_default_experiment(const fmu_model *m, FILE *f)
{
    char stop[40], step[40], tol[40];
    fmt_real(stop, sizeof stop, m->default_stop_time);
    fmt_real(step, sizeof step, m->default_step_size);
    fmt_real(tol, sizeof tol, m->default_tolerance);
    fprintf(f,
            "  <DefaultExperiment startTime=\"0\" stopTime=\"%s\" tolerance=\"%s\" "
            "stepSize=\"%s\"/>\n",
            stop, tol, step);
}

static void write_header(const fmu_model *m, FILE *f)
{
    fprintf(f, "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    fprintf(f, "<!-- Generated from the variable table of %s by fmu/common/fmu_xml.c; do not edit.\n"
               "     To update the committed copy, build the CMake target rrr_fmu_update_xml. -->\n",
            m->identifier);
}

static const char *dependency_kind_name(int kind)
{
    switch (kind) {
    case FMU_DEP_CONSTANT:
        return "constant";
    case FMU_DEP_FIXED:
        return "fixed";
    case FMU_DEP_TUNABLE:
        return "tunable";
    default:
        return "dependent";
    }
}

/* A known of the InitialUnknowns: an input or a parameter (initial = "exact"). */
static int is_initial_known(const fmu_variable *v)
{
    return v->causality == FMU_INPUT || v->causality == FMU_PARAMETER;
}

/* dependencies=" a b c" and dependenciesKind=" k k k" of unknown u: the knowns (1-based indices
 * in FMI 2, value references in FMI 3) for which dep(u, known) is not FMU_DEP_NONE; in
 * Initialization Mode (initial = 1) the knowns are the inputs and parameters. */
static void write_dependencies(const fmu_model *m, const fmu_variable *u, int fmi_version,
                               int initial, FILE *f)
{
    int (*const dep)(fmu_vr, fmu_vr) = initial ? m->depends_initial : m->depends;
    for (int pass = 0; pass < 2; ++pass) {
        fprintf(f, pass == 0 ? " dependencies=\"" : " dependenciesKind=\"");
        int first = 1;
        for (size_t k = 0; k < m->n_vars; ++k) {
            const fmu_variable *kv = &m->vars[k];
            const int known = initial ? is_initial_known(kv) : is_known(m, kv);
            const int kind = known ? dep(u->vr, kv->vr) : FMU_DEP_NONE;
            if (kind == FMU_DEP_NONE) {
                continue;
            }
            if (pass == 0) {
                fprintf(f, "%s%zu", first ? "" : " ", fmi_version == 3 ? (size_t)kv->vr : k + 1);
            } else {
                fprintf(f, "%s%s", first ? "" : " ", dependency_kind_name(kind));
            }
            first = 0;
        }
        fprintf(f, "\"");
    }
}

/* unit, start, nominal (continuous states) and derivative (state derivatives) of row v; the
 * derivative names its state by 1-based index (FMI 2) or value reference (FMI 3). */
static void write_value_attributes(const fmu_model *m, const fmu_variable *v, const void *data,
                                   int fmi_version, FILE *f)
{
    if (v->unit != NULL) {
        fprintf(f, " unit=\"%s\"", v->unit);
    }
    char buf[40];
    start_text(v, data, buf, sizeof buf);
    if (buf[0] != '\0') {
        fprintf(f, " start=\"%s\"", buf);
    }
    const int xs = fmu_state_index(m, v->vr);
    if (xs >= 0) {
        fmt_real(buf, sizeof buf, m->states[xs].nominal);
        fprintf(f, " nominal=\"%s\"", buf);
    }
    const int xd = fmu_derivative_index(m, v->vr);
    if (xd >= 0) {
        /* value references are the row indices: index = vr + 1 */
        const unsigned state = (unsigned)m->states[xd].state;
        fprintf(f, " derivative=\"%u\"", fmi_version == 3 ? state : state + 1u);
    }
}

/* ---- FMI 2.0 -------------------------------------------------------------------------------- */

static void write_sources2(fmu_sources src, FILE *f)
{
    fprintf(f, "    <SourceFiles>\n");
    for (size_t i = 0; i < src.n; ++i) {
        fprintf(f, "      <File name=\"%s\"/>\n", src.files[i]);
    }
    fprintf(f, "    </SourceFiles>\n");
}

static void write_interfaces2(const fmu_model *m, fmu_sources src, FILE *f)
{
    fprintf(f,
            "  <ModelExchange\n"
            "    modelIdentifier=\"%s\"\n"
            "    completedIntegratorStepNotNeeded=\"true\"\n"
            "    canGetAndSetFMUstate=\"true\"\n"
            "    canSerializeFMUstate=\"true\"\n"
            "    providesDirectionalDerivative=\"%s\"%s\n",
            m->identifier, m->partials != NULL ? "true" : "false", src.n > 0 ? ">" : "/>");
    if (src.n > 0) {
        write_sources2(src, f);
        fprintf(f, "  </ModelExchange>\n");
    }
    fprintf(f,
            "  <CoSimulation\n"
            "    modelIdentifier=\"%s\"\n"
            "    canHandleVariableCommunicationStepSize=\"true\"\n"
            "    canGetAndSetFMUstate=\"true\"\n"
            "    canSerializeFMUstate=\"true\"\n"
            "    providesDirectionalDerivative=\"%s\"%s\n",
            m->identifier, m->partials != NULL ? "true" : "false", src.n > 0 ? ">" : "/>");
    if (src.n > 0) {
        write_sources2(src, f);
        fprintf(f, "  </CoSimulation>\n");
    }
}

static void write_variables2(const fmu_model *m, const void *data, FILE *f)
{
    fprintf(f, "  <ModelVariables>\n");
    for (size_t i = 0; i < m->n_vars; ++i) {
        const fmu_variable *v = &m->vars[i];
        if (v->causality == FMU_INDEPENDENT) {
            /* optional in FMI 2, and the FMI Library rejects one without a start value (which the
             * standard forbids); it is the last row, so no index moves */
            continue;
        }
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
        write_value_attributes(m, v, data, 2, f);
        fprintf(f, "/>\n    </ScalarVariable>\n");
    }
    fprintf(f, "  </ModelVariables>\n");
}

static void write_structure2(const fmu_model *m, FILE *f)
{
    fprintf(f, "  <ModelStructure>\n    <Outputs>\n");
    for (size_t i = 0; i < m->n_vars; ++i) {
        if (m->vars[i].causality == FMU_OUTPUT) {
            fprintf(f, "      <Unknown index=\"%zu\"", i + 1);
            write_dependencies(m, &m->vars[i], 2, 0, f);
            fprintf(f, "/>\n");
        }
    }
    fprintf(f, "    </Outputs>\n");
    if (m->n_states > 0) {
        fprintf(f, "    <Derivatives>\n");
        for (size_t i = 0; i < m->n_states; ++i) {
            const fmu_vr d = m->states[i].derivative;
            fprintf(f, "      <Unknown index=\"%u\"", (unsigned)d + 1u);
            write_dependencies(m, fmu_find_var(m, d), 2, 0, f);
            fprintf(f, "/>\n");
        }
        fprintf(f, "    </Derivatives>\n");
    }
    fprintf(f, "    <InitialUnknowns>\n");
    for (size_t i = 0; i < m->n_vars; ++i) {
        if (m->vars[i].causality == FMU_OUTPUT) {
            fprintf(f, "      <Unknown index=\"%zu\"", i + 1);
            if (m->depends_initial != NULL) {
                write_dependencies(m, &m->vars[i], 2, 1, f);
            }
            fprintf(f, "/>\n");
        }
    }
    fprintf(f, "    </InitialUnknowns>\n  </ModelStructure>\n");
}

static void write_xml2(const fmu_model *m, const void *data, const char *token, fmu_sources src,
                       FILE *f)
{
    fprintf(f,
            "<fmiModelDescription\n"
            "  fmiVersion=\"2.0\"\n"
            "  modelName=\"%s\"\n"
            "  guid=\"%s\"\n"
            "  description=\"%s\"\n"
            "  version=\"" RRR_VERSION_STRING "\"\n"
            "  generationTool=\"" GENERATOR "\"\n"
            "  variableNamingConvention=\"structured\"\n"
            "  numberOfEventIndicators=\"0\">\n",
            m->identifier, token, m->description);
    write_interfaces2(m, src, f);
    write_units(m, f);
    write_log_categories(f);
    write_default_experiment(m, f);
    write_variables2(m, data, f);
    write_structure2(m, f);
    fprintf(f, "</fmiModelDescription>\n");
}

/* ---- FMI 3.0 -------------------------------------------------------------------------------- */

/* The MIME type of the terminal's Binary variables, as XML text. */
#define LSBUS_MIME "application/org.fmi-standard.fmi-ls-bus.can; version=&quot;1.0.0&quot;"

/* The four variables of the CAN terminal (fmu_bus.h), after the table's rows. */
static void write_bus_variables3(const fmu_model *m, FILE *f)
{
    const fmu_bus *b = m->bus;
    const unsigned tx = (unsigned)fmu_bus_vr(m, FMU_BUS_TX_DATA);
    const unsigned rx = (unsigned)fmu_bus_vr(m, FMU_BUS_RX_DATA);
    const unsigned txc = (unsigned)fmu_bus_vr(m, FMU_BUS_TX_CLOCK);
    const unsigned rxc = (unsigned)fmu_bus_vr(m, FMU_BUS_RX_CLOCK);
    fprintf(f,
            "    <Binary name=\"%s.Tx_Data\" valueReference=\"%u\" causality=\"output\" "
            "variability=\"discrete\" initial=\"calculated\" clocks=\"%u\"\n"
            "      description=\"the bus operations this node sends (FMI-LS-BUS 1.0 CAN)\"\n"
            "      mimeType=\"" LSBUS_MIME "\" maxSize=\"%u\"/>\n",
            b->terminal, tx, txc, FMU_BUS_TX_MAX);
    fprintf(f,
            "    <Binary name=\"%s.Rx_Data\" valueReference=\"%u\" causality=\"input\" "
            "variability=\"discrete\" clocks=\"%u\"\n"
            "      description=\"the bus operations this node receives (FMI-LS-BUS 1.0 CAN)\"\n"
            "      mimeType=\"" LSBUS_MIME "\" maxSize=\"%u\">\n"
            "      <Start value=\"\"/>\n    </Binary>\n",
            b->terminal, rx, rxc, FMU_BUS_RX_MAX);
    if (b->tx_clock == FMU_BUS_TX_TRIGGERED) {
        fprintf(f,
                "    <Clock name=\"%s.Tx_Clock\" valueReference=\"%u\" causality=\"output\" "
                "variability=\"discrete\" intervalVariability=\"triggered\"\n"
                "      description=\"active when Tx_Data holds operations to send\"/>\n",
                b->terminal, txc);
    } else {
        fprintf(f,
                "    <Clock name=\"%s.Tx_Clock\" valueReference=\"%u\" causality=\"input\" "
                "variability=\"discrete\" intervalVariability=\"countdown\"\n"
                "      description=\"the node's communication points: fmi3GetIntervalDecimal "
                "announces the next one\"/>\n",
                b->terminal, txc);
    }
    fprintf(f,
            "    <Clock name=\"%s.Rx_Clock\" valueReference=\"%u\" causality=\"input\" "
            "variability=\"discrete\" intervalVariability=\"triggered\"\n"
            "      description=\"active when Rx_Data holds received operations\"/>\n",
            b->terminal, rxc);
}

static void write_variables3(const fmu_model *m, const void *data, FILE *f)
{
    fprintf(f, "  <ModelVariables>\n");
    for (size_t i = 0; i < m->n_vars; ++i) {
        const fmu_variable *v = &m->vars[i];
        fprintf(f, "    <%s name=\"%s\" valueReference=\"%u\" causality=\"%s\" variability=\"%s\"",
                v->type == FMU_REAL ? "Float64" : "Boolean", v->name, (unsigned)v->vr,
                fmu_causality_name(v->causality), fmu_variability_name(v->variability));
        if (v->causality == FMU_PARAMETER) {
            fprintf(f, " initial=\"exact\"");
        } else if (v->causality == FMU_OUTPUT) {
            fprintf(f, " initial=\"calculated\"");
        }
        fprintf(f, "\n      description=\"%s\"", v->description);
        write_value_attributes(m, v, data, 3, f);
        fprintf(f, "/>\n");
    }
    if (m->bus != NULL) {
        write_bus_variables3(m, f);
    }
    fprintf(f, "  </ModelVariables>\n");
}

static void write_structure3(const fmu_model *m, FILE *f)
{
    fprintf(f, "  <ModelStructure>\n");
    for (size_t i = 0; i < m->n_vars; ++i) {
        if (m->vars[i].causality == FMU_OUTPUT) {
            fprintf(f, "    <Output valueReference=\"%u\"", (unsigned)m->vars[i].vr);
            write_dependencies(m, &m->vars[i], 3, 0, f);
            fprintf(f, "/>\n");
        }
    }
    if (m->bus != NULL) {
        fprintf(f, "    <Output valueReference=\"%u\"/>\n",
                (unsigned)fmu_bus_vr(m, FMU_BUS_TX_DATA));
        if (m->bus->tx_clock == FMU_BUS_TX_TRIGGERED) {
            fprintf(f, "    <Output valueReference=\"%u\"/>\n",
                    (unsigned)fmu_bus_vr(m, FMU_BUS_TX_CLOCK));
        }
    }
    for (size_t i = 0; i < m->n_states; ++i) {
        const fmu_vr d = m->states[i].derivative;
        fprintf(f, "    <ContinuousStateDerivative valueReference=\"%u\"", (unsigned)d);
        write_dependencies(m, fmu_find_var(m, d), 3, 0, f);
        fprintf(f, "/>\n");
    }
    for (size_t i = 0; i < m->n_vars; ++i) {
        if (m->vars[i].causality == FMU_OUTPUT) {
            fprintf(f, "    <InitialUnknown valueReference=\"%u\"", (unsigned)m->vars[i].vr);
            if (m->depends_initial != NULL) {
                write_dependencies(m, &m->vars[i], 3, 1, f);
            }
            fprintf(f, "/>\n");
        }
    }
    if (m->bus != NULL && m->bus->tx_clock == FMU_BUS_TX_TRIGGERED) {
        /* an output clock is an initial unknown (Tx_Data, clocked, is not) */
        fprintf(f, "    <InitialUnknown valueReference=\"%u\"/>\n",
                (unsigned)fmu_bus_vr(m, FMU_BUS_TX_CLOCK));
    }
    fprintf(f, "  </ModelStructure>\n");
}

static void write_xml3(const fmu_model *m, const void *data, const char *token, FILE *f)
{
    const char *const flag = m->partials != NULL ? "true" : "false";
    fprintf(f,
            "<fmiModelDescription\n"
            "  fmiVersion=\"3.0\"\n"
            "  modelName=\"%s\"\n"
            "  instantiationToken=\"%s\"\n"
            "  description=\"%s\"\n"
            "  version=\"" RRR_VERSION_STRING "\"\n"
            "  generationTool=\"" GENERATOR "\"\n"
            "  variableNamingConvention=\"structured\">\n",
            m->identifier, token, m->description);
    if (m->bus != NULL) { /* a network FMU: Co-Simulation with event mode only */
        fprintf(f,
                "  <CoSimulation\n"
                "    modelIdentifier=\"%s\"\n"
                "    canHandleVariableCommunicationStepSize=\"true\"\n"
                "    canGetAndSetFMUState=\"true\"\n"
                "    canSerializeFMUState=\"true\"\n"
                "    hasEventMode=\"true\"/>\n",
                m->identifier);
    } else {
    fprintf(f,
            "  <ModelExchange\n"
            "    modelIdentifier=\"%s\"\n"
            "    needsCompletedIntegratorStep=\"false\"\n"
            "    canGetAndSetFMUState=\"true\"\n"
            "    canSerializeFMUState=\"true\"\n"
            "    providesDirectionalDerivatives=\"%s\"\n"
            "    providesAdjointDerivatives=\"%s\"/>\n"
            "  <CoSimulation\n"
            "    modelIdentifier=\"%s\"\n"
            "    canHandleVariableCommunicationStepSize=\"true\"\n"
            "    canGetAndSetFMUState=\"true\"\n"
            "    canSerializeFMUState=\"true\"\n"
            "    providesDirectionalDerivatives=\"%s\"\n"
            "    providesAdjointDerivatives=\"%s\"\n"
            "    hasEventMode=\"false\"/>\n",
            m->identifier, flag, flag, m->identifier, flag, flag);
    }
    write_units(m, f);
    write_log_categories(f);
    write_default_experiment(m, f);
    write_variables3(m, data, f);
    write_structure3(m, f);
    fprintf(f, "</fmiModelDescription>\n");
}

int fmu_write_xml(const fmu_model *m, int fmi_version, fmu_sources src, FILE *f)
{
    if (fmi_version != 2 && fmi_version != 3) {
        fprintf(stderr, "FMI version must be 2 or 3, got %d\n", fmi_version);
        return 1;
    }
    void *data = start_values(m);
    if (data == NULL) {
        return 1;
    }
    char token[FMU_TOKEN_SIZE];
    fmu_model_token(m, data, token);
    write_header(m, f);
    if (fmi_version == 2) {
        write_xml2(m, data, token, src, f);
    } else {
        write_xml3(m, data, token, f);
    }
    free(data);
    return ferror(f) ? 1 : 0;
}

int fmu_write_build_description(const fmu_model *m, fmu_sources src, FILE *f)
{
    fprintf(f, "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    fprintf(f, "<!-- Generated by fmu/common/fmu_xml.c; do not edit. -->\n");
    fprintf(f, "<fmiBuildDescription fmiVersion=\"3.0\">\n");
    fprintf(f,
            "  <BuildConfiguration modelIdentifier=\"%s\"\n"
            "    description=\"the binary of %s from these sources: any C11 compiler, no options "
            "needed; hidden symbol visibility keeps the exports to the FMI functions\">\n",
            m->identifier, m->identifier);
    fprintf(f, "    <SourceFileSet language=\"C11\">\n");
    for (size_t i = 0; i < src.n; ++i) {
        fprintf(f, "      <SourceFile name=\"%s\"/>\n", src.files[i]);
    }
    fprintf(f, "    </SourceFileSet>\n");
    fprintf(f, "    <Library name=\"m\" external=\"true\" description=\"the C math library "
               "(link with -lm where it is separate)\"/>\n");
    fprintf(f, "  </BuildConfiguration>\n</fmiBuildDescription>\n");
    return ferror(f) ? 1 : 0;
}

/* ---- FMI-LS-BUS: terminalsAndIcons.xml and the layered standard's manifest ------------------- */

int fmu_write_terminals(const fmu_model *m, FILE *f)
{
    const fmu_bus *b = m->bus;
    if (b == NULL) {
        fprintf(stderr, "%s has no bus terminal\n", m->identifier);
        return 1;
    }
    static const char *const members[FMU_BUS_VAR_COUNT] = {"Tx_Data", "Rx_Data", "Tx_Clock",
                                                           "Rx_Clock"};
    fprintf(f, "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    fprintf(f, "<!-- Generated from the bus terminal of %s by fmu/common/fmu_xml.c; do not edit. "
               "-->\n",
            m->identifier);
    fprintf(f, "<fmiTerminalsAndIcons fmiVersion=\"3.0\">\n  <Terminals>\n");
    fprintf(f,
            "    <Terminal terminalKind=\"org.fmi-ls-bus.network-terminal\" "
            "matchingRule=\"org.fmi-ls-bus.transceiver\" name=\"%s\"\n"
            "      description=\"%s\">\n",
            b->terminal, b->description);
    for (unsigned k = 0; k < FMU_BUS_VAR_COUNT; ++k) {
        fprintf(f,
                "      <TerminalMemberVariable variableKind=\"signal\" variableName=\"%s.%s\" "
                "memberName=\"%s\"/>\n",
                b->terminal, members[k], members[k]);
    }
    fprintf(f, "    </Terminal>\n  </Terminals>\n</fmiTerminalsAndIcons>\n");
    return ferror(f) ? 1 : 0;
}

int fmu_write_lsbus_manifest(const fmu_model *m, FILE *f)
{
    if (m->bus == NULL) {
        fprintf(stderr, "%s has no bus terminal\n", m->identifier);
        return 1;
    }
    fprintf(f, "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n");
    fprintf(f, "<!-- Generated for %s by fmu/common/fmu_xml.c; do not edit. -->\n",
            m->identifier);
    fprintf(f, "<fmiLayeredStandardManifest\n"
               "  xmlns:fmi-ls=\"http://fmi-standard.org/fmi-ls-manifest\"\n"
               "  fmi-ls:fmi-ls-name=\"org.fmi-standard.fmi-ls-bus\"\n"
               "  fmi-ls:fmi-ls-version=\"1.0.0\"\n"
               "  fmi-ls:fmi-ls-description=\"Layered Standard for the simulation of bus "
               "communication on a Physical Signal Abstraction or Network Abstraction based "
               "level.\"\n"
               "  isBusSimulationFMU=\"false\"/>\n");
    return ferror(f) ? 1 : 0;
}

/* ---- documentation/index.html ---------------------------------------------------------------- */

static void write_doc_variables(const fmu_model *m, const void *data, FILE *f)
{
    fprintf(f, "<table>\n<tr><th>name</th><th>value reference</th><th>causality</th>"
               "<th>variability</th><th>type</th><th>unit</th><th>default</th>"
               "<th>description</th></tr>\n");
    for (size_t i = 0; i < m->n_vars; ++i) {
        const fmu_variable *v = &m->vars[i];
        char start[40];
        start_text(v, data, start, sizeof start);
        const int xs = fmu_state_index(m, v->vr);
        const int xd = fmu_derivative_index(m, v->vr);
        fprintf(f, "<tr><td><code>%s</code></td><td>%u</td><td>%s</td><td>%s</td><td>%s</td>"
                   "<td>%s</td><td>%s</td><td>%s",
                v->name, (unsigned)v->vr, fmu_causality_name(v->causality),
                fmu_variability_name(v->variability), fmu_type_name(v->type),
                v->unit ? v->unit : "", start[0] != '\0' ? start : "(calculated)",
                v->description);
        if (xs >= 0) {
            fprintf(f, "; continuous state (Model Exchange), nominal %g", m->states[xs].nominal);
        }
        if (xd >= 0) {
            fprintf(f, "; derivative of <code>%s</code>",
                    fmu_find_var(m, m->states[xd].state)->name);
        }
        fprintf(f, "</td></tr>\n");
    }
    if (m->bus != NULL) {
        static const char *const rows[FMU_BUS_VAR_COUNT][3] = {
            {"Tx_Data", "output", "Binary: the bus operations sent (CAN Transmit, Configuration, "
                                  "Format Error)"},
            {"Rx_Data", "input", "Binary: the bus operations received, walked by length"},
            {"Tx_Clock", "", "Clock of Tx_Data"},
            {"Rx_Clock", "input", "Clock of Rx_Data (triggered)"}};
        for (unsigned k = 0; k < FMU_BUS_VAR_COUNT; ++k) {
            const char *caus = rows[k][1];
            if (k == FMU_BUS_TX_CLOCK) {
                caus = m->bus->tx_clock == FMU_BUS_TX_TRIGGERED ? "output (triggered)"
                                                                 : "input (countdown)";
            }
            fprintf(f, "<tr><td><code>%s.%s</code></td><td>%u</td><td>%s</td><td>discrete</td>"
                       "<td>%s</td><td></td><td></td><td>%s</td></tr>\n",
                    m->bus->terminal, rows[k][0], (unsigned)fmu_bus_vr(m, k), caus,
                    k < 2 ? "Binary" : "Clock", rows[k][2]);
        }
    }
    fprintf(f, "</table>\n");
}

/* "<code>a</code>, <code>b</code> and <code>c</code>" of the comma-separated list, into buf. */
static void platform_list(const char *platforms, char *buf, size_t n)
{
    size_t count = 1;
    for (const char *c = platforms; *c != '\0'; ++c) {
        count += *c == ',';
    }
    size_t used = 0;
    buf[0] = '\0';
    const char *item = platforms;
    for (size_t k = 0; k < count && used < n; ++k) {
        const char *end = strchr(item, ',');
        const int len = (int)(end != NULL ? (size_t)(end - item) : strlen(item));
        const char *sep = k == 0 ? "" : (k + 1 == count ? " and " : ", ");
        const int w = snprintf(buf + used, n - used, "%s<code>%.*s</code>", sep, len, item);
        used += w > 0 ? (size_t)w : 0;
        item = end != NULL ? end + 1 : item;
    }
}

int fmu_write_doc(const fmu_model *m, int fmi_version, const char *equations_html,
                  const char *conventions_html, const char *platforms, FILE *f)
{
    void *data = start_values(m);
    if (data == NULL) {
        return 1;
    }
    char token[FMU_TOKEN_SIZE];
    fmu_model_token(m, data, token);
    char platform_dirs[512];
    platform_list(platforms, platform_dirs, sizeof platform_dirs);
    const char *a64_note = fmi_version == 2 && strstr(platforms, "aarch64-linux") != NULL
                               ? "; the FMI 2.0 archive for aarch64 Linux hosts carries the "
                                 "aarch64 binary in <code>linux64</code>, where importers look "
                                 "for it"
                               : "";
    fprintf(f, "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\">\n"
               "<title>%s (FMI %d.0)</title>\n"
               "<style>body{font-family:sans-serif;max-width:70em;margin:2em auto;line-height:1.4}"
               "table{border-collapse:collapse}td,th{border:1px solid #bbb;padding:2px 6px;"
               "text-align:left;vertical-align:top}code{font-size:95%%}</style>\n"
               "</head>\n<body>\n",
            m->identifier, fmi_version);
    fprintf(f, "<h1><code>%s</code>, FMI %d.0</h1>\n<p>%s.</p>\n", m->identifier, fmi_version,
            m->description);
    fprintf(f, "<p>Generated from the variable table of the model by <code>fmu/common/fmu_xml.c"
               "</code>, like this FMU's <code>modelDescription.xml</code> (instantiation token "
               "<code>%s</code>).</p>\n",
            token);
    if (equations_html != NULL) {
        fprintf(f, "<h2>What it computes</h2>\n%s\n", equations_html);
    } else {
        fprintf(f, "<h2>What it computes</h2>\n<p>See the section <code>%s</code> of the rrr_robot "
                   "manual's page on the FMUs (<code>docs/fmus.md</code>).</p>\n",
                m->identifier);
    }
    if (m->bus != NULL) {
        fprintf(f, "<h2>Interfaces</h2>\n<ul>\n"
                   "<li><b>Co-Simulation</b> with event mode (FMI 3.0 only): a network FMU of "
                   "FMI-LS-BUS 1.0 (network abstraction) with one CAN terminal <code>%s</code> "
                   "(<code>terminalsAndIcons/terminalsAndIcons.xml</code>, manifest in "
                   "<code>extra/org.fmi-standard.fmi-ls-bus/</code>). Tx_Clock is %s; Rx_Clock "
                   "is a triggered input clock. The communication period is %g s.</li>\n"
                   "<li>Received operations are walked by their length: a malformed one (unknown "
                   "OP Code, a length that does not match its arguments, cut off) is answered "
                   "with a Format Error; Confirm, Arbitration Lost and Bus Error are ignored "
                   "unless <code>BusNotifications</code> is true.</li>\n"
                   "<li>Every function checks the FMI 3.0 state machine; FMU state get/set and "
                   "serialization hold the queued bus operations.</li>\n"
                   "<li>Binaries in <code>binaries/</code>: %s.</li>\n</ul>\n",
                m->bus->terminal,
                m->bus->tx_clock == FMU_BUS_TX_TRIGGERED
                    ? "a triggered output clock, active when operations are queued"
                    : "a countdown input clock: fmi3GetIntervalDecimal announces the next "
                      "communication point",
                m->bus->period, platform_dirs);
    } else {
    fprintf(f, "<h2>Interfaces</h2>\n<ul>\n"
               "<li><b>Co-Simulation</b>: variable communication steps; inputs are held over a "
               "step. FMU state get/set and serialization are supported.</li>\n"
               "<li><b>Model Exchange</b>: %zu continuous state(s)%s, no event indicators, no "
               "time events; the importer's solver integrates. FMU state get/set and "
               "serialization are supported.</li>\n"
               "<li>Every function checks the FMI %d.0 state machine: a call in a state where it "
               "is not allowed returns Error with a log message and changes nothing. Every Real "
               "that is set must be finite: NaN and Inf are refused and the old value kept.</li>\n"
               "%s"
               "<li>Log categories: <code>logStatusWarning</code>, <code>logStatusDiscard</code>, "
               "<code>logStatusError</code>, <code>logStatusFatal</code> (on by default) and "
               "<code>logCalls</code> (every FMI call with its arguments).</li>\n"
               "<li>Binaries in <code>binaries/</code>: %s (the platforms this build had a "
               "compiler for%s).</li>\n"
               "</ul>\n",
            m->n_states, m->n_states > 0 ? " (listed in the table below)" : "", fmi_version,
            m->partials == NULL
                ? ""
                : "<li><b>Partial derivatives</b>: exact directional derivatives (and, FMI 3.0, "
                  "adjoint derivatives) of the outputs and state derivatives by the inputs and "
                  "continuous states, and in Initialization Mode by the parameters, from the "
                  "closed-form model (no finite differences); a clamped voltage has derivative "
                  "0. The ModelStructure lists the dependencies and their kinds exactly.</li>\n",
            platform_dirs, a64_note);
    }
    fprintf(f, "<h2>Variables</h2>\n<p>Value references are the same in the FMI 2.0 and FMI 3.0 "
               "builds; FMI 3.0 uses the same scalar variables (no arrays).</p>\n");
    write_doc_variables(m, data, f);
    fprintf(f, "<h2>Conventions</h2>\n%s\n", conventions_html);
    fprintf(f, "<h2>Building the binary from the sources</h2>\n<p>The folder <code>sources/"
               "</code> holds every file the binary is built from (%s). With any C11 compiler, "
               "from the unzipped FMU:</p>\n<pre>\n"
               "cc -std=c11 -O2 -shared -fPIC -fvisibility=hidden -o %s.so sources/*.c -lm\n"
               "x86_64-w64-mingw32-gcc -std=c11 -O2 -shared -static-libgcc -o %s.dll sources/*.c\n"
               "</pre>\n<p>or <code>fmpy compile</code> on the FMU. No include path or "
               "preprocessor definition is needed.</p>\n",
            fmi_version == 3 ? "listed in <code>sources/buildDescription.xml</code>"
                             : "listed in <code>SourceFiles</code> of <code>modelDescription.xml"
                               "</code>",
            m->identifier, m->identifier);
    fprintf(f, "</body>\n</html>\n");
    free(data);
    return ferror(f) ? 1 : 0;
}
