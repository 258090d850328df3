/*
 * Partial derivatives of an FMU (FMI 2.0.4 section 2.1.9, FMI 3.0 section 2.2.11), independent of
 * the FMI version: the arguments are checked, the model's partials hook fills the dense matrix
 * J = d unknowns / d knowns at the current values (exact, from librrr), and the seed is
 * multiplied with J (directional derivative) or with J^T (adjoint derivative).
 *
 * Unknowns are the Real outputs (the continuous states and their derivatives are outputs in
 * these models, fmu_model_check); knowns are the Real inputs and the continuous states, in every
 * state where the call is allowed, and in Initialization Mode also the Real parameters (FMI:
 * there the knowns are the inputs and the variables with initial = "exact"; the derivative is
 * taken at the start values, which is what the model's outputs are computed from). A parameter
 * as a known after initialization is refused with a message saying why.
 */
#include "fmu_internal.h"

#include <math.h>
#include <string.h>

/* the largest table and matrix the partials are built for (the models here: < 85 rows, at most
 * 12 x 65 entries in Initialization Mode); a bigger model is refused, not overrun */
#define FMU_PARTIALS_MAX_VARS 256
#define FMU_PARTIALS_MAX_ENTRIES 1024

void fmu_partial_set(fmu_partials *P, fmu_vr unknown, fmu_vr known, double value)
{
    if (unknown < P->n_vars && known < P->n_vars && P->row[unknown] >= 0 &&
        P->col[known] >= 0) {
        P->J[(size_t)P->row[unknown] * P->n_cols + (size_t)P->col[known]] = value;
    }
}

int fmu_is_unknown(const fmu_model *m, const fmu_variable *v)
{
    (void)m;
    return v->type == FMU_REAL && v->causality == FMU_OUTPUT;
}

int fmu_is_known(const fmu_model *m, const fmu_variable *v, int init)
{
    return v->type == FMU_REAL && (v->causality == FMU_INPUT || fmu_state_index(m, v->vr) >= 0 ||
                                   (init && v->causality == FMU_PARAMETER));
}

/* FMU_OK when every value reference names a variable of the kind `want` (1: unknown, 0: known);
 * logs the first that does not and returns FMU_ERROR */
static fmu_status check_refs(fmu_instance *S, const char *fn, const char *arg, const fmu_vr vr[],
                             size_t n, int want_unknown)
{
    const fmu_model *m = S->model;
    const int init = S->state == FMU_INIT_MODE;
    for (size_t i = 0; i < n; ++i) {
        const fmu_variable *v = fmu_find_var(m, vr[i]);
        if (v == NULL) {
            fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                    "%s: %s[%zu] = %u is not a value reference of %s", fn, arg, i,
                    (unsigned)vr[i], m->identifier);
            return FMU_ERROR;
        }
        const int ok = want_unknown ? fmu_is_unknown(m, v) : fmu_is_known(m, v, init);
        if (!ok && !want_unknown && v->type == FMU_REAL && v->causality == FMU_PARAMETER) {
            fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                    "%s: %s[%zu] = %u (%s) is a parameter: parameters are knowns only in "
                    "InitializationMode (they do not change afterwards); the knowns now are the "
                    "Real inputs and the continuous states",
                    fn, arg, i, (unsigned)vr[i], v->name);
            return FMU_ERROR;
        }
        if (!ok) {
            fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                    "%s: %s[%zu] = %u (%s, %s %s) is not %s", fn, arg, i, (unsigned)vr[i],
                    v->name, fmu_type_name(v->type), fmu_causality_name(v->causality),
                    want_unknown ? "an unknown: the unknowns are the Real outputs (the continuous "
                                   "states and their derivatives among them)"
                                 : "a known: the knowns are the Real inputs and the continuous "
                                   "states, and in InitializationMode the Real parameters");
            return FMU_ERROR;
        }
    }
    return FMU_OK;
}

fmu_status fmu_get_derivative(fmu_instance *S, const char *fn, int adjoint,
                              const fmu_vr unknowns[], size_t nu, const fmu_vr knowns[],
                              size_t nk, const double seed[], size_t n_seed,
                              double sensitivity[], size_t n_sensitivity)
{
    const fmu_model *m = S->model;
    const char *const kind = adjoint ? "providesAdjointDerivatives" : (S->fmi_version == 3
                                                                           ? "providesDirectionalDerivatives"
                                                                           : "providesDirectionalDerivative");
    if (m->partials == NULL) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "%s: not provided by %s (%s=false)", fn,
                m->identifier, kind);
        return FMU_ERROR;
    }
    const size_t want_seed = adjoint ? nu : nk;
    const size_t want_sens = adjoint ? nk : nu;
    if (n_seed != want_seed || n_sensitivity != want_sens) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: nSeed must be %zu and nSensitivity %zu (nUnknowns = %zu, nKnowns = %zu), "
                "got %zu and %zu",
                fn, want_seed, want_sens, nu, nk, n_seed, n_sensitivity);
        return FMU_ERROR;
    }
    if ((nu > 0 && unknowns == NULL) || (nk > 0 && knowns == NULL) ||
        (n_seed > 0 && seed == NULL) || (n_sensitivity > 0 && sensitivity == NULL)) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: the arrays of unknowns, knowns, seed and sensitivity must not be NULL "
                "when their counts are > 0",
                fn);
        return FMU_ERROR;
    }
    if (n_sensitivity > FMU_PARTIALS_MAX_VARS) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: at most %d sensitivities per call (the model has %zu variables), got %zu",
                fn, FMU_PARTIALS_MAX_VARS, m->n_vars, n_sensitivity);
        return FMU_ERROR;
    }
    if (check_refs(S, fn, "unknowns", unknowns, nu, 1) != FMU_OK ||
        check_refs(S, fn, "knowns", knowns, nk, 0) != FMU_OK) {
        return FMU_ERROR;
    }
    for (size_t i = 0; i < n_seed; ++i) {
        if (!isfinite(seed[i])) {
            fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "%s: seed[%zu] must be finite, got %.17g", fn,
                    i, seed[i]);
            return FMU_ERROR;
        }
    }
    if (nu == 0 || nk == 0) {
        for (size_t i = 0; i < n_sensitivity; ++i) {
            sensitivity[i] = 0.0;
        }
        return FMU_OK;
    }

    /* the rows and columns of J: every unknown and every known of the model, in table order */
    int row[FMU_PARTIALS_MAX_VARS], col[FMU_PARTIALS_MAX_VARS];
    size_t n_rows = 0, n_cols = 0;
    if (m->n_vars > FMU_PARTIALS_MAX_VARS) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "%s: %s has %zu variables, more than the %d the "
                "partial derivatives are built for", fn, m->identifier, m->n_vars,
                FMU_PARTIALS_MAX_VARS);
        return FMU_ERROR;
    }
    const int init = S->state == FMU_INIT_MODE;
    for (size_t k = 0; k < m->n_vars; ++k) {
        row[k] = fmu_is_unknown(m, &m->vars[k]) ? (int)n_rows++ : -1;
        col[k] = fmu_is_known(m, &m->vars[k], init) ? (int)n_cols++ : -1;
    }
    double J[FMU_PARTIALS_MAX_ENTRIES];
    if (n_rows * n_cols > FMU_PARTIALS_MAX_ENTRIES) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "%s: %s has %zu x %zu partial derivatives, more "
                "than the %d they are built for", fn, m->identifier, n_rows, n_cols,
                FMU_PARTIALS_MAX_ENTRIES);
        return FMU_ERROR;
    }
    memset(J, 0, n_rows * n_cols * sizeof J[0]);
    fmu_partials P = {J, row, col, m->n_vars, n_cols, init};
    const fmu_status st = m->partials(S, &P);
    if (st > FMU_WARNING) {
        return st; /* the model logged why */
    }
    double acc[FMU_PARTIALS_MAX_VARS];
    for (size_t i = 0; i < n_sensitivity; ++i) {
        acc[i] = 0.0;
    }
    for (size_t i = 0; i < nu; ++i) {
        const size_t r = (size_t)row[unknowns[i]];
        for (size_t j = 0; j < nk; ++j) {
            const double a = J[r * n_cols + (size_t)col[knowns[j]]];
            if (adjoint) {
                acc[j] += a * seed[i];
            } else {
                acc[i] += a * seed[j];
            }
        }
    }
    for (size_t i = 0; i < n_sensitivity; ++i) {
        if (!isfinite(acc[i])) {
            fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                    "%s: sensitivity[%zu] is not finite (%.17g): the seed is too large for "
                    "the partial derivatives at this point",
                    fn, i, acc[i]);
            return FMU_ERROR;
        }
    }
    memcpy(sensitivity, acc, n_sensitivity * sizeof acc[0]);
    return FMU_OK;
}
