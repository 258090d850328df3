/* What every profile's plant loop shares (hil_plant.h). */
#include "hil_plant.h"

#include <stdio.h>

#include "rrr_hil_logs.h"

#define PROG "rrr_hil_plant"

/* The value references of n variables by name; -1 (the FMU's last_error says which) if one is
 * missing. */
static int resolve_vrs(rrr_hil_fmu *fmu, const char *const *names, int n, fmi2ValueReference *vr)
{
    for (int i = 0; i < n; ++i) {
        const long v = rrr_hil_fmu_vr(fmu, names[i]);
        if (v < 0) {
            return -1;
        }
        vr[i] = (fmi2ValueReference)v;
    }
    return 0;
}

int rrr_hil_plant_setup_fmu(rrr_hil_plant *p, const rrr_hil_plant_opts *o)
{
    if (rrr_hil_fmu_open(&p->fmu, o->fmu_dir, "plant") != 0) {
        fprintf(stderr, PROG ": %s\n", p->fmu.last_error);
        return -1;
    }
    static const char *const xn[6] = {"q[1]", "q[2]", "q[3]", "qd[1]", "qd[2]", "qd[3]"};
    static const char *const un[3] = {"u[1]", "u[2]", "u[3]"};
    static const char *const yn[6] = {"qdd[1]", "qdd[2]", "qdd[3]", "tip.x", "tip.y", "tip.z"};
    if (resolve_vrs(&p->fmu, yn, 6, p->vr_y) != 0 || resolve_vrs(&p->fmu, xn, 6, p->vr_x) != 0 ||
        resolve_vrs(&p->fmu, un, 3, p->vr_u) != 0) {
        fprintf(stderr, PROG ": %s\n", p->fmu.last_error);
        return -1;
    }
    char name[16];
    for (int i = 0; i < 3; ++i) {
        snprintf(name, sizeof name, "q0[%d]", i + 1);
        if (o->have_q0 && rrr_hil_fmu_set_by_name(&p->fmu, name, o->q0[i]) != 0) {
            fprintf(stderr, PROG ": %s\n", p->fmu.last_error);
            return -1;
        }
        snprintf(name, sizeof name, "qd0[%d]", i + 1);
        if (o->have_qd0 && rrr_hil_fmu_set_by_name(&p->fmu, name, o->qd0[i]) != 0) {
            fprintf(stderr, PROG ": %s\n", p->fmu.last_error);
            return -1;
        }
    }
    for (int i = 0; i < o->n_set; ++i) {
        if (rrr_hil_fmu_set_by_name(&p->fmu, o->set_name[i], o->set_value[i]) != 0) {
            fprintf(stderr, PROG ": --set: %s\n", p->fmu.last_error);
            return -1;
        }
    }
    if (rrr_hil_fmu_init(&p->fmu, 0.0) != 0 || rrr_hil_fmu_get(&p->fmu, p->vr_x, 6, p->x) != 0 ||
        rrr_hil_fmu_get(&p->fmu, p->vr_y, 6, p->y) != 0) {
        fprintf(stderr, PROG ": %s\n", p->fmu.last_error);
        return -1;
    }
    return 0;
}

int rrr_hil_plant_read_kt(rrr_hil_plant *p)
{
    static const char *const ktn[3] = {"kt[1]", "kt[2]", "kt[3]"};
    fmi2ValueReference vr[4];
    double v[4];
    const long vu = rrr_hil_fmu_vr(&p->fmu, "u_max");
    if (resolve_vrs(&p->fmu, ktn, 3, vr) != 0 || vu < 0) {
        fprintf(stderr, PROG ": %s\n", p->fmu.last_error);
        return -1;
    }
    vr[3] = (fmi2ValueReference)vu;
    if (rrr_hil_fmu_get(&p->fmu, vr, 4, v) != 0) {
        fprintf(stderr, PROG ": %s\n", p->fmu.last_error);
        return -1;
    }
    for (int i = 0; i < 3; ++i) {
        p->kt[i] = v[i];
    }
    p->u_max_V = v[3];
    return 0;
}

/* The row below: k, t, q[3], qd[3], u[3], zero, faults, qdd[3], tip[3] (rrr_hil_logs.h). */
_Static_assert(RRR_HIL_PLANT_LOG_COLUMNS == 2 + 6 + 3 + 2 + 6,
               "log_row writes the plant log's columns (rrr_robot.hil.logs.specs)");

void rrr_hil_plant_log_row(rrr_hil_plant *p)
{
    if (p->log == NULL) {
        return;
    }
    fprintf(p->log, "%u,%.17g", p->run.k, p->fmu.time);
    for (int i = 0; i < 6; ++i) {
        fprintf(p->log, ",%.17g", p->x[i]);
    }
    for (int i = 0; i < 3; ++i) {
        fprintf(p->log, ",%.17g", p->u[i]);
    }
    fprintf(p->log, ",%u,%u", (unsigned)p->log_zero, (unsigned)p->log_faults);
    for (int i = 0; i < 6; ++i) {
        fprintf(p->log, ",%.17g", p->y[i]);
    }
    fputc('\n', p->log);
}

int rrr_hil_plant_step(rrr_hil_plant *p)
{
    if (rrr_hil_fmu_set(&p->fmu, p->vr_u, 3, p->u) != 0 ||
        rrr_hil_fmu_step(&p->fmu, RRR_HIL_PERIOD_S) != 0 ||
        rrr_hil_fmu_get(&p->fmu, p->vr_x, 6, p->x) != 0 ||
        (p->log != NULL && rrr_hil_fmu_get(&p->fmu, p->vr_y, 6, p->y) != 0)) {
        (void)rrr_hil_run_end(&p->run, RRR_HIL_EXIT_FAULT, "the FMU failed: %s",
                              p->fmu.last_error);
        return -1;
    }
    ++p->run.k;
    rrr_hil_plant_log_row(p);
    return 0;
}

int rrr_hil_plant_lost(rrr_hil_plant *p, const char *what, const char *note)
{
    return rrr_hil_run_end(&p->run, RRR_HIL_EXIT_PEER_LOST, "controller lost%s: %s%s",
                           p->started ? "" : " before its first frame", what, note);
}

int rrr_hil_plant_transport_lost(rrr_hil_plant *p, rrr_hil_io io, const char *note)
{
    char what[260];
    snprintf(what, sizeof what, "transport %s: %s", rrr_hil_io_str(io), p->tr->last_error);
    return rrr_hil_plant_lost(p, what, note);
}

int rrr_hil_plant_silence_lost(rrr_hil_plant *p, int idle_ms, const char *note)
{
    char what[96];
    snprintf(what, sizeof what, "no frame for %d ms (--idle-timeout-ms)", idle_ms);
    return rrr_hil_plant_lost(p, what, note);
}
