/* What the FMI 2 and FMI 3 harnesses share beyond the importer (c_src/fmi_import): the closed
 * loop's reference and the model parameters by FMU variable name. */
#ifndef FMU_HARNESS_COMMON_H
#define FMU_HARNESS_COMMON_H

#include <stdio.h>

#include "fmu_test_reference.h"
#include "rrr/rrr.h"

/* Every parameter of rrr_model with its FMU variable name. */
#define N_MODEL_PARAMS (6 + RRR_NP + 3 + 9 + 9 + 3 + 1)

static void model_params(const rrr_model *m, char names_[N_MODEL_PARAMS][16],
                         double values[N_MODEL_PARAMS])
{
    int k = 0;
    const char *scalars[] = {"d1", "a2", "a3", "d2", "d3", "g"};
    const double sv[] = {m->d1, m->a2, m->a3, m->d2, m->d3, m->g};
    for (int i = 0; i < 6; ++i, ++k) {
        snprintf(names_[k], 16, "%s", scalars[i]);
        values[k] = sv[i];
    }
    for (int i = 0; i < RRR_NP; ++i, ++k) {
        snprintf(names_[k], 16, "p[%d]", i + 1);
        values[k] = m->p[i];
    }
    for (int i = 0; i < 3; ++i, ++k) {
        snprintf(names_[k], 16, "kt[%d]", i + 1);
        values[k] = m->kt[i];
    }
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j, ++k) {
            snprintf(names_[k], 16, "f[%d,%d]", i + 1, j + 1);
            values[k] = m->f[i][j];
        }
    }
    for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j, ++k) {
            snprintf(names_[k], 16, "w[%d,%d]", i + 1, j + 1);
            values[k] = m->w[i][j];
        }
    }
    for (int i = 0; i < 3; ++i, ++k) {
        snprintf(names_[k], 16, "b[%d]", i + 1);
        values[k] = m->b[i];
    }
    snprintf(names_[k], 16, "u_max");
    values[k] = m->u_max;
}

#endif /* FMU_HARNESS_COMMON_H */
