/* Variable tables: lookup, settable-ness, sanity checks, the token (GUID), units and names.
 * Independent of the FMI version. */
#include "fmu_internal.h"
#include "fmu_bus.h"

#include <stdio.h>
#include <string.h>

const fmu_log_category fmu_log_categories[FMU_LOG_CATEGORY_COUNT] = {
    {"logStatusWarning", "Messages of calls that return Warning"},
    {"logStatusDiscard", "Messages of calls that return Discard (a step that cannot be taken)"},
    {"logStatusError", "Messages of calls that return Error (illegal call, bad argument, bad value)"},
    {"logStatusFatal", "Messages of calls that return Fatal"},
    {"logCalls", "Debug: every FMI function call with its arguments"},
};

/* Exponents of kg, m, s, A, rad. V = kg m2 s-3 A-1; N m / V = s A. */
const fmu_unit fmu_units[] = {
    {"rad", 0, 0, 0, 0, 1},
    {"rad/s", 0, 0, -1, 0, 1},
    {"rad/s2", 0, 0, -2, 0, 1},
    {"V", 1, 2, -3, -1, 0},
    {"V/rad", 1, 2, -3, -1, -1},
    {"V.s/rad", 1, 2, -2, -1, -1},
    {"s/rad", 0, 0, 1, 0, -1},
    {"N.m/V", 0, 0, 1, 1, 0},
    {"kg.m2", 1, 2, 0, 0, 0},
    {"kg.m", 1, 1, 0, 0, 0},
    {"m", 0, 1, 0, 0, 0},
    {"m/s2", 0, 1, -2, 0, 0},
    {"s", 0, 0, 1, 0, 0},
};
const size_t fmu_n_units = sizeof fmu_units / sizeof fmu_units[0];

const fmu_variable *fmu_find_var(const fmu_model *m, fmu_vr vr)
{
    /* value references are the row indices (fmu_model_check) */
    if (vr < m->n_vars && m->vars[vr].vr == vr) {
        return &m->vars[vr];
    }
    return NULL;
}

const char *fmu_type_name(fmu_type t)
{
    return t == FMU_BOOLEAN ? "Boolean" : "Real";
}

const char *fmu_causality_name(fmu_causality c)
{
    switch (c) {
    case FMU_PARAMETER:
        return "parameter";
    case FMU_INPUT:
        return "input";
    case FMU_OUTPUT:
        return "output";
    case FMU_INDEPENDENT:
        return "independent";
    }
    return "?";
}

const char *fmu_variability_name(fmu_variability v)
{
    switch (v) {
    case FMU_FIXED:
        return "fixed";
    case FMU_TUNABLE:
        return "tunable";
    case FMU_CONTINUOUS:
        return "continuous";
    }
    return "?";
}

unsigned fmu_settable_states(const fmu_variable *v)
{
    switch (v->causality) {
    case FMU_INPUT:
        return FMU_INSTANTIATED | FMU_INIT_MODE | FMU_STEP_MODE | FMU_EVENT_MODE |
               FMU_CONT_TIME_MODE;
    case FMU_PARAMETER:
        return v->variability == FMU_TUNABLE
                   ? (unsigned)(FMU_INSTANTIATED | FMU_INIT_MODE | FMU_STEP_MODE | FMU_EVENT_MODE)
                   : (unsigned)(FMU_INSTANTIATED | FMU_INIT_MODE);
    case FMU_OUTPUT:
    case FMU_INDEPENDENT:
        return 0u;
    }
    return 0u;
}

int fmu_state_index(const fmu_model *m, fmu_vr vr)
{
    for (size_t i = 0; i < m->n_states; ++i) {
        if (m->states[i].state == vr) {
            return (int)i;
        }
    }
    return -1;
}

int fmu_derivative_index(const fmu_model *m, fmu_vr vr)
{
    for (size_t i = 0; i < m->n_states; ++i) {
        if (m->states[i].derivative == vr) {
            return (int)i;
        }
    }
    return -1;
}

const char *fmu_state_name(int fmi_version, fmu_state s)
{
    const int v3 = fmi_version == 3;
    switch (s) {
    case FMU_START_END:
        return "StartAndEnd";
    case FMU_INSTANTIATED:
        return "Instantiated";
    case FMU_INIT_MODE:
        return "InitializationMode";
    case FMU_EVENT_MODE:
        return "EventMode";
    case FMU_CONT_TIME_MODE:
        return "ContinuousTimeMode";
    case FMU_STEP_MODE:
        return v3 ? "StepMode" : "StepComplete";
    case FMU_STEP_IN_PROGRESS:
        return "StepInProgress";
    case FMU_STEP_FAILED:
        return v3 ? "StepDiscarded" : "StepFailed";
    case FMU_STEP_CANCELED:
        return "StepCanceled";
    case FMU_TERMINATED:
        return "Terminated";
    case FMU_ERROR_STATE:
        return "Error";
    case FMU_FATAL_STATE:
        return "Fatal";
    }
    return "Unknown";
}

void fmu_states_str(int fmi_version, unsigned mask, char *buf, size_t n)
{
    size_t used = 0;
    if (n == 0) {
        return;
    }
    buf[0] = '\0';
    for (unsigned bit = 0; bit < FMU_STATE_COUNT; ++bit) {
        const unsigned s = 1u << bit;
        if ((mask & s) == 0u || used + 1 >= n) {
            continue;
        }
        const int k = snprintf(buf + used, n - used, "%s%s", used ? "|" : "",
                               fmu_state_name(fmi_version, (fmu_state)s));
        if (k < 0) {
            return;
        }
        used += (size_t)k < n - used ? (size_t)k : n - used - 1;
    }
    if (used == 0) {
        snprintf(buf, n, "none");
    }
}

uint64_t fmu_fnv1a(uint64_t h, const void *bytes, size_t n)
{
    const unsigned char *b = bytes;
    for (size_t i = 0; i < n; ++i) {
        h ^= b[i];
        h *= 1099511628211ull;
    }
    return h;
}

static int unit_known(const char *u)
{
    for (size_t i = 0; i < fmu_n_units; ++i) {
        if (strcmp(fmu_units[i].name, u) == 0) {
            return 1;
        }
    }
    return 0;
}

static int text_ok(const char *s)
{
    return s != NULL && s[0] != '\0' && strpbrk(s, "\"<&#") == NULL;
}

int fmu_model_check(const fmu_model *m, const char **msg, size_t *row)
{
    static const char *const ok = "";
    *msg = ok;
    *row = 0;
    if (m->vars == NULL || m->n_vars == 0 || !text_ok(m->identifier) || !text_ok(m->description)) {
        *msg = "identifier, description and variable table must be set";
        return 1;
    }
    size_t n_independent = 0;
    for (size_t i = 0; i < m->n_vars; ++i) {
        const fmu_variable *v = &m->vars[i];
        *row = i;
        if (v->vr != i) {
            *msg = "value references must equal the row index";
            return 1;
        }
        if (!text_ok(v->name) || !text_ok(v->description)) {
            *msg = "every variable needs a name and a description without \" < & #";
            return 1;
        }
        if (v->unit != NULL && (v->type != FMU_REAL || !unit_known(v->unit))) {
            *msg = "a unit must be declared in fmu_units and belong to a Real";
            return 1;
        }
        if (v->causality == FMU_INDEPENDENT) {
            ++n_independent;
            if (v->type != FMU_REAL || v->variability != FMU_CONTINUOUS) {
                *msg = "the independent variable is a continuous Real";
                return 1;
            }
            continue;
        }
        const int param = v->causality == FMU_PARAMETER;
        const int cont = v->variability == FMU_CONTINUOUS;
        if (param == cont || (cont && v->type != FMU_REAL)) {
            *msg = "parameters are fixed or tunable; inputs and outputs are continuous Reals";
            return 1;
        }
        if (v->offset + (v->type == FMU_REAL ? sizeof(double) : sizeof(int)) > m->data_size) {
            *msg = "a variable offset lies outside the model data";
            return 1;
        }
        for (size_t k = 0; k < i; ++k) {
            if (strcmp(m->vars[k].name, v->name) == 0) {
                *msg = "variable names must be unique";
                return 1;
            }
        }
    }
    if (n_independent != 1) {
        *msg = "exactly one variable must be the independent variable (FMU_TIME_ROW)";
        return 1;
    }
    for (size_t i = 0; i < m->n_states; ++i) {
        const fmu_continuous_state *x = &m->states[i];
        const fmu_variable *sv = fmu_find_var(m, x->state);
        const fmu_variable *dv = fmu_find_var(m, x->derivative);
        *row = i;
        if (sv == NULL || dv == NULL || sv->causality != FMU_OUTPUT ||
            dv->causality != FMU_OUTPUT || !(x->nominal > 0.0) ||
            fmu_state_index(m, x->state) != (int)i || fmu_derivative_index(m, x->derivative) != (int)i) {
            *msg = "continuous states and their derivatives are distinct outputs with a nominal > 0";
            return 1;
        }
    }
    const struct fmu_bus *b = m->bus;
    if (b != NULL) {
        const fmu_variable *nv = fmu_find_var(m, b->vr_notifications);
        const fmu_variable *bv = fmu_find_var(m, b->vr_baudrate);
        *row = m->n_vars;
        if (!text_ok(b->terminal) || !text_ok(b->description) || !(b->period > 0.0) ||
            b->frame == NULL || b->event == NULL || b->glue == NULL || m->n_states != 0 ||
            b->state_offset + sizeof(fmu_bus_state) > m->data_size || nv == NULL ||
            nv->type != FMU_BOOLEAN || nv->causality != FMU_PARAMETER || bv == NULL ||
            bv->type != FMU_REAL || bv->causality != FMU_PARAMETER) {
            *msg = "a bus terminal needs a name, a period > 0, the frame and event hooks, its "
                   "state inside the model data, a Boolean BusNotifications and a Real baud-rate "
                   "parameter, and no continuous states (Co-Simulation only)";
            return 1;
        }
    }
    return 0;
}

/* The token hashes a canonical text of the table, so it changes whenever the XML would. */
void fmu_model_token(const fmu_model *m, const void *data, char out[])
{
    uint64_t h1 = FMU_FNV_OFFSET;
    uint64_t h2 = FMU_FNV_OFFSET ^ 0x5bd1e9955bd1e995ull; /* a second, independent stream */
    char line[512];
    int n = snprintf(line, sizeof line, "%s\n", m->identifier);
    h1 = fmu_fnv1a(h1, line, (size_t)n);
    h2 = fmu_fnv1a(h2, line, (size_t)n);
    for (size_t i = 0; i < m->n_vars; ++i) {
        const fmu_variable *v = &m->vars[i];
        char start[32] = "";
        if (v->causality == FMU_PARAMETER || v->causality == FMU_INPUT) {
            const void *p = (const char *)data + v->offset;
            if (v->type == FMU_REAL) {
                double d;
                memcpy(&d, p, sizeof d);
                snprintf(start, sizeof start, "%.17g", d);
            } else {
                int b;
                memcpy(&b, p, sizeof b);
                snprintf(start, sizeof start, "%s", b ? "true" : "false");
            }
        }
        n = snprintf(line, sizeof line, "%u|%s|%s|%s|%s|%s|%s\n", (unsigned)v->vr, v->name,
                     fmu_type_name(v->type), fmu_causality_name(v->causality),
                     fmu_variability_name(v->variability), v->unit ? v->unit : "", start);
        if (n < 0) {
            n = 0;
        }
        const size_t len = (size_t)n < sizeof line ? (size_t)n : sizeof line - 1;
        h1 = fmu_fnv1a(h1, line, len);
        h2 = fmu_fnv1a(h2, line, len);
    }
    if (m->bus != NULL) { /* the terminal: its name and the kind of its Tx clock */
        n = snprintf(line, sizeof line, "bus|%s|%d\n", m->bus->terminal, (int)m->bus->tx_clock);
        const size_t len = n > 0 && (size_t)n < sizeof line ? (size_t)n : 0u;
        h1 = fmu_fnv1a(h1, line, len);
        h2 = fmu_fnv1a(h2, line, len);
    }
    snprintf(out, FMU_TOKEN_SIZE, "{%08x-%04x-%04x-%04x-%04x%08x}", (unsigned)(h1 >> 32),
             (unsigned)((h1 >> 16) & 0xffffu), (unsigned)(h1 & 0xffffu),
             (unsigned)(h2 >> 48), (unsigned)((h2 >> 32) & 0xffffu), (unsigned)(h2 & 0xffffffffu));
}
