/* The checks that the FMI 2 and FMI 3 harnesses share (fmu_harness_common.h): written once
 * against the adapter fh_ops, run by each harness with its version's calls. */
#define _POSIX_C_SOURCE 200809L
#define RRR_TEST_DEFINE_COUNTERS

#include "fmu_harness_common.h"

#include <ctype.h>
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "fmu_test_reference.h"
#include "rrr_test.h"

void fh_model_params(const rrr_model *m, char names_[N_MODEL_PARAMS][16],
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

/* ---- an FMU ---------------------------------------------------------------------------------- */

int fh_open(rrr_fmi_md *md, rrr_fmi_lib *lib, const char *dir, int fmi, char id[64],
            char token[128])
{
    char path[1024];
    char err[512];
    if (rrr_fmi_md_load(md, dir, err, sizeof err) != 0 || md->fmi != fmi) {
        fprintf(stderr, "%s: %s\n", dir, md->xml == NULL ? err : "not the expected FMI version");
        return 1;
    }
    snprintf(id, 64, "%s", md->id);
    snprintf(token, 128, "%s", md->token);
    if (rrr_fmi_binary_path(path, sizeof path, dir, fmi, id) != 0 ||
        rrr_fmi_lib_open(lib, path, err, sizeof err) != 0) {
        fprintf(stderr, "%s\n", err);
        return 1;
    }
    return 0;
}

void fh_close(rrr_fmi_md *md, rrr_fmi_lib *lib)
{
    rrr_fmi_lib_close(lib);
    rrr_fmi_md_free(md);
}

unsigned int fh_md_vr(const rrr_fmi_md *md, const char *name)
{
    char err[256];
    unsigned long vr = 0;
    if (rrr_fmi_md_vr(md, name, NULL, &vr, err, sizeof err) != 0) {
        fprintf(stderr, "FMI %d: %s\n", md->fmi, err);
        exit(2);
    }
    return (unsigned int)vr;
}

/* ---- logging --------------------------------------------------------------------------------- */

void fh_log_record(fh_log_sink *s, int status, const char *category)
{
    if (status >= 0 && status < FH_NSTATUS) {
        s->count[status]++;
    }
    if (status >= FH_ERROR) {
        memcpy(s->last_error, s->last, sizeof s->last_error);
    }
    if (strstr(s->last, "illegal call sequence") != NULL) {
        s->illegal++;
    }
    if (strstr(s->last, "not provided") != NULL) {
        s->not_provided++;
    }
    if (category != NULL && strcmp(category, "logCalls") == 0) {
        s->calls++;
    }
}

/* ---- instances ------------------------------------------------------------------------------- */

void fh_vrs3(const fh_ops *ops, const void *api, const char *base, unsigned int vr[3])
{
    for (int i = 0; i < 3; ++i) {
        char name[32];
        snprintf(name, sizeof name, "%s[%d]", base, i + 1);
        vr[i] = fh_md_vr(ops->md(api), name);
    }
}

const char *const fh_ctrl_inputs[5] = {"q_ref", "qd_ref", "qdd_ref", "q", "qd"};

void fh_vrs(const fh_ops *ops, const void *api, const char *const *bases, size_t n,
            unsigned int *vr)
{
    for (size_t k = 0; k < n; ++k) {
        fh_vrs3(ops, api, bases[k], vr + 3 * k);
    }
}

int fh_names_word(const char *msg, const char *word)
{
    const size_t n = strlen(word);
    for (const char *p = strstr(msg, word); p != NULL; p = strstr(p + 1, word)) {
        const int before = p == msg || !isalnum((unsigned char)p[-1]);
        const int after = !isalnum((unsigned char)p[n]);
        if (before && after) {
            return 1;
        }
    }
    return 0;
}

double fh_get1(const fh_ops *ops, void *x, const char *name)
{
    const unsigned int vr = fh_md_vr(ops->md(ops->api(x)), name);
    double v = (double)NAN;
    CHECK(ops->get_real(x, &vr, 1, &v) == FH_OK);
    return v;
}

int fh_set1(const fh_ops *ops, void *x, const char *name, double v)
{
    const unsigned int vr = fh_md_vr(ops->md(ops->api(x)), name);
    return ops->set_real(x, &vr, 1, &v);
}

void fh_expect_error(const fh_ops *ops, void *x, int st, const char *what, const char *n1,
                     const char *n2)
{
    fh_log_sink *log = ops->log(x);
    const int ok = st == FH_ERROR && log->count[FH_ERROR] == 1 &&
                   (n1 == NULL || strstr(log->last_error, n1)) &&
                   (n2 == NULL || strstr(log->last_error, n2));
    if (!ok) {
        fprintf(stderr, "%s (%s): %s returned %d, %d error message(s), last \"%s\"\n",
                ops->id(ops->api(x)), ops->where(x), what, st, log->count[FH_ERROR],
                log->last_error);
        rrr_test_failures++;
    }
    memset(log, 0, sizeof *log);
}

void fh_expect_refused(const fh_ops *ops, void *x, const char *name, double v, const char *needle)
{
    fh_log_sink *log = ops->log(x);
    const double before = fh_get1(ops, x, name);
    memset(log, 0, sizeof *log);
    const int s = fh_set1(ops, x, name, v);
    const double after = fh_get1(ops, x, name);
    if (s != FH_ERROR || log->count[FH_ERROR] != 1 || !strstr(log->last_error, needle) ||
        !fh_names_word(log->last_error, ops->set_real_name) ||
        memcmp(&before, &after, sizeof before) != 0) {
        fprintf(stderr, "%s (%s): set %s = %g returned %d, message \"%s\", value %.17g -> %.17g\n",
                ops->id(ops->api(x)), ops->where(x), name, v, s, log->last_error, before, after);
        rrr_test_failures++;
    }
}

void fh_expect_refused_out(const fh_ops *ops, void *x, int st, const char *what,
                           const char *needle, const double *out, size_t n)
{
    const fh_log_sink *log = ops->log(x);
    int untouched = 1;
    for (size_t i = 0; i < n; ++i) {
        untouched &= out[i] == FH_UNTOUCHED;
    }
    if (!(st == FH_ERROR && log->count[FH_ERROR] == 1 && strstr(log->last_error, needle) &&
          untouched)) {
        fprintf(stderr, "%s (%s): refused %s: status %d, %d error message(s), last \"%s\" "
                        "(want \"%s\"), output %s\n",
                ops->id(ops->api(x)), ops->where(x), what, st, log->count[FH_ERROR],
                log->last_error, needle, untouched ? "untouched" : "written");
        rrr_test_failures++;
    }
}

unsigned char *fh_state_bytes(const fh_ops *ops, void *x, size_t *n)
{
    void *s = NULL;
    unsigned char *buf = NULL;
    *n = 0;
    if (ops->get_state(x, &s) == FH_OK && ops->state_size(x, s, n) == FH_OK && *n > 0) {
        buf = malloc(*n);
        if (buf != NULL && ops->serialize(x, s, buf, *n) != FH_OK) {
            free(buf);
            buf = NULL;
        }
    }
    if (s != NULL) {
        ops->free_state(x, &s);
    }
    return buf;
}

/* ---- start values ---------------------------------------------------------------------------- */

void fh_check_default(const fh_ops *ops, void *x, const char *name, double expected)
{
    char start[64] = "";
    const void *api = ops->api(x);
    const int has_start = rrr_fmi_md_start(ops->md(api), name, start, sizeof start) == 0 &&
                          start[0] != '\0';
    const double got = fh_get1(ops, x, name);
    if (!(got == expected) || !has_start || !(strtod(start, NULL) == expected)) {
        fprintf(stderr, "%s (%s): %s = %.17g, XML start \"%s\", librrr default %.17g\n",
                ops->id(api), ops->where(x), name, got, start, expected);
        rrr_test_failures++;
    }
}

void fh_check_bool_default(const fh_ops *ops, void *x, const char *name, int expected)
{
    const rrr_fmi_md *md = ops->md(ops->api(x));
    char start[16] = "";
    int v = !expected;
    CHECK(ops->get_bool(x, fh_md_vr(md, name), &v) == FH_OK);
    CHECK((v != 0) == (expected != 0));
    (void)rrr_fmi_md_start(md, name, start, sizeof start);
    CHECK(strcmp(start, expected ? "true" : "false") == 0);
}

void fh_check_defaults(const fh_ops *ops, void *p, void *c)
{
    rrr_model m;
    rrr_ctc_gains g;
    CHECK(rrr_model_default(&m) == RRR_OK);
    CHECK(rrr_ctc_gains_default(&g) == RRR_OK);
    char pnames[N_MODEL_PARAMS][16];
    double values[N_MODEL_PARAMS];
    fh_model_params(&m, pnames, values);
    for (int k = 0; k < N_MODEL_PARAMS; ++k) {
        fh_check_default(ops, p, pnames[k], values[k]);
        fh_check_default(ops, c, pnames[k], values[k]);
    }
    fh_check_default(ops, p, "h_int", RRR_PLANT_H_INT_DEFAULT);
    fh_check_default(ops, p, "rtol", RRR_PLANT_RTOL_DEFAULT);
    fh_check_default(ops, p, "atol", RRR_PLANT_ATOL_DEFAULT);
    /* the plant integrates adaptively unless told otherwise */
    fh_check_bool_default(ops, p, "adaptive", 1);
    for (int i = 0; i < 3; ++i) {
        char name[32];
        const char *zero_plant[] = {"u", "q0", "qd0"};
        const char *zero_ctrl[] = {"q_ref", "qd_ref", "qdd_ref", "q", "qd"};
        for (size_t k = 0; k < 3; ++k) {
            snprintf(name, sizeof name, "%s[%d]", zero_plant[k], i + 1);
            fh_check_default(ops, p, name, 0.0);
        }
        for (size_t k = 0; k < 5; ++k) {
            snprintf(name, sizeof name, "%s[%d]", zero_ctrl[k], i + 1);
            fh_check_default(ops, c, name, 0.0);
        }
        snprintf(name, sizeof name, "kp[%d]", i + 1);
        fh_check_default(ops, c, name, g.kp[i]);
        snprintf(name, sizeof name, "kd[%d]", i + 1);
        fh_check_default(ops, c, name, g.kd[i]);
    }
    fh_check_bool_default(ops, c, "feedforward", g.feedforward != 0);
}

/* ---- closed loop ----------------------------------------------------------------------------- */

void fh_loop_new(fh_loop *L, const fh_ops *ops, void *p, void *c)
{
    memset(L, 0, sizeof *L);
    L->ops = ops;
    L->p = p;
    L->c = c;
    const void *pa = ops->api(p), *ca = ops->api(c);
    fh_vrs3(ops, pa, "u", L->p_u);
    fh_vrs3(ops, pa, "q", L->p_q);
    fh_vrs3(ops, pa, "qd", L->p_qd);
    fh_vrs3(ops, ca, "q_ref", L->c_ref);
    fh_vrs3(ops, ca, "qd_ref", L->c_ref + 3);
    fh_vrs3(ops, ca, "qdd_ref", L->c_ref + 6);
    fh_vrs3(ops, ca, "q", L->c_q);
    fh_vrs3(ops, ca, "qd", L->c_qd);
    fh_vrs3(ops, ca, "u", L->c_u);
}

int fh_loop_init(fh_loop *L)
{
    const fh_ops *o = L->ops;
    double r[9];
    reference(0.0, r);
    unsigned int q0[3], qd0[3];
    fh_vrs3(o, o->api(L->p), "q0", q0);
    fh_vrs3(o, o->api(L->p), "qd0", qd0);
    int bad = 0;
    if (o->setup != NULL) {
        bad |= o->setup(L->p) != FH_OK;
        bad |= o->setup(L->c) != FH_OK;
    }
    bad |= o->set_real(L->p, q0, 3, r) != FH_OK;
    bad |= o->set_real(L->p, qd0, 3, r + 3) != FH_OK;
    bad |= o->enter_init(L->p) != FH_OK;
    bad |= o->enter_init(L->c) != FH_OK;
    bad |= o->exit_init(L->p) != FH_OK;
    bad |= o->exit_init(L->c) != FH_OK;
    L->t = 0.0;
    CHECK(!bad);
    return bad;
}

int fh_loop_step(fh_loop *L, double rec[9])
{
    const fh_ops *o = L->ops;
    double r[9], q[3], qd[3], u[3], last_p = -1.0, last_c = -1.0;
    reference(L->t, r);
    int bad = 0;
    bad |= o->get_real(L->p, L->p_q, 3, q) != FH_OK;
    bad |= o->get_real(L->p, L->p_qd, 3, qd) != FH_OK;
    bad |= o->set_real(L->c, L->c_ref, 9, r) != FH_OK;
    bad |= o->set_real(L->c, L->c_q, 3, q) != FH_OK;
    bad |= o->set_real(L->c, L->c_qd, 3, qd) != FH_OK;
    bad |= o->get_real(L->c, L->c_u, 3, u) != FH_OK;
    bad |= o->set_real(L->p, L->p_u, 3, u) != FH_OK;
    bad |= o->do_step(L->p, L->t, FH_H, &last_p) != FH_OK;
    bad |= o->do_step(L->c, L->t, FH_H, &last_c) != FH_OK;
    if (o->step_reports_time) {
        /* lastSuccessfulTime: the end of the step, computed as the master computes it */
        bad |= !(last_p == L->t + FH_H && last_c == L->t + FH_H);
    }
    L->t += FH_H;
    if (rec != NULL) {
        memcpy(rec, q, sizeof q);
        memcpy(rec + 3, qd, sizeof qd);
        memcpy(rec + 6, u, sizeof u);
    }
    return bad;
}

double fh_loop_run(fh_loop *L, int n, double (*rec)[9])
{
    double err = 0.0;
    for (int k = 0; k < n; ++k) {
        double row[9], r[9];
        if (fh_loop_step(L, row)) {
            CHECK(0 && "loop_step failed");
            return (double)INFINITY;
        }
        reference(L->t - FH_H, r);
        for (int i = 0; i < 3; ++i) {
            err = fmax(err, fabs(row[i] - r[i]));
        }
        if (rec != NULL) {
            memcpy(rec[k], row, sizeof row);
        }
    }
    return err;
}

int fh_loop_first(fh_loop *L, double (*rec)[9], const char *label)
{
    if (fh_loop_init(L)) {
        return 1;
    }
    const double err = fh_loop_run(L, 1000, rec);
    printf("%s (PD + feedforward), 1 s at 1 kHz: max |q - q_ref| = %.3g rad\n", label, err);
    CHECK(err < 1e-3);
    CHECK(fabs(L->t - 1.0) < 1e-12);
    return 0;
}

void fh_loop_again(fh_loop *L, double (*rec)[9], double (*rec_again)[9])
{
    if (!fh_loop_init(L)) {
        fh_loop_run(L, 1000, rec_again);
        CHECK(memcmp(rec, rec_again, 1000 * sizeof rec[0]) == 0);
    }
}

void fh_loop_twice(fh_loop *L, double (*rec)[9], double (*rec_again)[9], const char *label,
                   void (*after_first)(fh_loop *L), void (*after_reset)(fh_loop *L))
{
    const fh_ops *o = L->ops;
    const fh_log_sink *lp = o->log(L->p), *lc = o->log(L->c);
    if (fh_loop_first(L, rec, label) == 0 && after_first != NULL) {
        after_first(L);
    }
    CHECK(o->terminate(L->p) == FH_OK);
    CHECK(o->terminate(L->c) == FH_OK);
    CHECK(lp->count[FH_ERROR] == 0 && lc->count[FH_ERROR] == 0);
    CHECK(lp->count[FH_WARNING] == 0 && lc->count[FH_WARNING] == 0);
    /* reset and run again: the same trajectory, bit for bit */
    CHECK(o->reset(L->p) == FH_OK);
    CHECK(o->reset(L->c) == FH_OK);
    if (after_reset != NULL) {
        after_reset(L);
    }
    fh_loop_again(L, rec, rec_again);
    CHECK(lp->count[FH_ERROR] == 0 && lc->count[FH_ERROR] == 0);
    CHECK(o->terminate(L->p) == FH_OK);
    CHECK(o->terminate(L->c) == FH_OK);
}

/* ---- refused values -------------------------------------------------------------------------- */

void fh_refused_in_init(const fh_ops *ops, void *p, void *c)
{
    fh_expect_refused(ops, p, "u[1]", (double)NAN, "u[1]");
    fh_expect_refused(ops, p, "u[3]", -(double)INFINITY, "u[3]");
    fh_expect_refused(ops, p, "d1", (double)INFINITY, "d1");
    fh_expect_refused(ops, p, "p[7]", -(double)INFINITY, "p[7]");
    fh_expect_refused(ops, p, "h_int", (double)NAN, "h_int");
    fh_expect_refused(ops, p, "rtol", (double)INFINITY, "rtol");
    fh_expect_refused(ops, p, "atol", (double)NAN, "atol");
    fh_expect_refused(ops, p, "q0[2]", (double)INFINITY, "q0[2]");
    fh_expect_refused(ops, p, "q[2]", 1.0, "q[2]"); /* an output */
    fh_expect_refused(ops, c, "q_ref[3]", (double)NAN, "q_ref[3]");
    fh_expect_refused(ops, c, "kp[2]", (double)INFINITY, "kp[2]");
    fh_expect_refused(ops, c, "f[2,3]", (double)NAN, "f[2,3]");
    fh_expect_refused(ops, c, "u_n[1]", 0.5, "u_n[1]"); /* an output */
}

void fh_refused_multi(const fh_ops *ops, void *p)
{
    unsigned int vr[3];
    fh_vrs3(ops, ops->api(p), "u", vr);
    const double v[3] = {1.0, (double)NAN, 2.0};
    double got[3] = {-1.0, -1.0, -1.0};
    CHECK(ops->set_real(p, vr, 3, v) == FH_ERROR);
    CHECK(ops->get_real(p, vr, 3, got) == FH_OK);
    CHECK(got[0] == 0.0 && got[1] == 0.0 && got[2] == 0.0);
}

void fh_refused_stepping(const fh_ops *ops, void *p, void *c, const char *fixed_needle)
{
    /* a good set still works after the refusals */
    CHECK(fh_set1(ops, p, "u[1]", 0.25) == FH_OK);
    CHECK(fh_get1(ops, p, "u[1]") == 0.25);
    CHECK(ops->exit_init(p) == FH_OK);
    CHECK(ops->exit_init(c) == FH_OK);
    fh_expect_refused(ops, p, "u[2]", (double)INFINITY, "u[2]");
    fh_expect_refused(ops, p, "a3", 0.3, fixed_needle); /* fixed parameter after initialization */
    fh_expect_refused(ops, p, "q0[1]", 0.3, "q0[1]");
    fh_expect_refused(ops, c, "qd[1]", (double)NAN, "qd[1]");
    fh_expect_refused(ops, c, "kd[3]", 1.0, "kd[3]");
}

void fh_still_stepping(const fh_ops *ops, void *p, void *c)
{
    CHECK(ops->do_step(p, 0.0, FH_H, NULL) == FH_OK);
    CHECK(ops->do_step(c, 0.0, FH_H, NULL) == FH_OK);
    CHECK(isfinite(fh_get1(ops, p, "q[1]")) && isfinite(fh_get1(ops, c, "u[1]")));
}

/* ---- FMU state ------------------------------------------------------------------------------- */

int fh_state_replay(fh_loop *L, fh_saved *S, void (*after_set)(fh_loop *L, double t1))
{
    static double rec1[FH_N_REPLAY][9], rec2[FH_N_REPLAY][9], rec3[FH_N_REPLAY][9];
    const fh_ops *o = L->ops;
    memset(S, 0, sizeof *S);
    if (fh_loop_init(L)) {
        return 1;
    }
    fh_loop_run(L, 200, NULL);
    S->t1 = L->t;
    CHECK(o->get_state(L->p, &S->sp) == FH_OK && S->sp != NULL);
    CHECK(o->get_state(L->c, &S->sc) == FH_OK && S->sc != NULL);
    fh_loop_run(L, FH_N_REPLAY, rec1);

    /* set back and rerun: bit-identical */
    CHECK(o->set_state(L->p, S->sp) == FH_OK);
    CHECK(o->set_state(L->c, S->sc) == FH_OK);
    if (after_set != NULL) {
        after_set(L, S->t1);
    }
    L->t = S->t1;
    fh_loop_run(L, FH_N_REPLAY, rec2);
    CHECK(memcmp(rec1, rec2, sizeof rec1) == 0);

    /* serialize, free, deserialize, set, rerun: bit-identical */
    CHECK(o->state_size(L->p, S->sp, &S->np) == FH_OK && S->np > 0);
    CHECK(o->state_size(L->c, S->sc, &S->nc) == FH_OK && S->nc > 0);
    S->bp = malloc(S->np);
    S->bc = malloc(S->nc);
    if (S->bp == NULL || S->bc == NULL) {
        CHECK(0 && "out of memory");
        fh_saved_free(L, S);
        return 1;
    }
    CHECK(o->serialize(L->p, S->sp, S->bp, S->np) == FH_OK);
    CHECK(o->serialize(L->c, S->sc, S->bc, S->nc) == FH_OK);
    CHECK(o->free_state(L->p, &S->sp) == FH_OK && S->sp == NULL);
    CHECK(o->free_state(L->c, &S->sc) == FH_OK && S->sc == NULL);
    CHECK(o->deserialize(L->p, S->bp, S->np, &S->sp) == FH_OK && S->sp != NULL);
    CHECK(o->deserialize(L->c, S->bc, S->nc, &S->sc) == FH_OK && S->sc != NULL);
    CHECK(o->set_state(L->p, S->sp) == FH_OK);
    CHECK(o->set_state(L->c, S->sc) == FH_OK);
    L->t = S->t1;
    fh_loop_run(L, FH_N_REPLAY, rec3);
    CHECK(memcmp(rec1, rec3, sizeof rec1) == 0);
    return 0;
}

void fh_state_refusals(fh_loop *L, fh_saved *S)
{
    const fh_ops *o = L->ops;
    const size_t np = S->np;
    unsigned char *bad = malloc(np + 8);
    size_t n_before = 0;
    unsigned char *before = fh_state_bytes(o, L->p, &n_before);
    if (bad == NULL || before == NULL) {
        CHECK(0 && "out of memory");
        free(bad);
        free(before);
        return;
    }
    memset(o->log(L->p), 0, sizeof(fh_log_sink));
    memset(o->log(L->c), 0, sizeof(fh_log_sink));
    fh_expect_error(o, L->p, o->serialize(L->p, S->sp, bad, np - 1),
                    "serialize, buffer too small", "small", NULL);
    void *junk = NULL;
    memcpy(bad, S->bp, np);
    bad[np / 2] ^= 0x10;
    fh_expect_error(o, L->p, o->deserialize(L->p, bad, np, &junk), "a flipped bit", "checksum",
                    NULL);
    CHECK(junk == NULL);
    fh_expect_error(o, L->p, o->deserialize(L->p, S->bp, np - 8, &junk), "truncated bytes", NULL,
                    NULL);
    CHECK(junk == NULL);
    memcpy(bad, S->bp, np);
    memset(bad + np, 0, 8);
    fh_expect_error(o, L->p, o->deserialize(L->p, bad, np + 8, &junk), "8 bytes too many", NULL,
                    NULL);
    CHECK(junk == NULL);
    memcpy(bad, S->bp, np);
    bad[0] ^= 0x01;
    fh_expect_error(o, L->p, o->deserialize(L->p, bad, np, &junk), "a wrong magic", "magic",
                    NULL);
    CHECK(junk == NULL);
    fh_expect_error(o, L->p, o->deserialize(L->p, S->bp, 3, &junk), "3 bytes", NULL, NULL);
    CHECK(junk == NULL);
    fh_expect_error(o, L->p, o->set_state(L->p, NULL), "setFMUState(NULL)", "NULL", NULL);
    fh_expect_error(o, L->c, o->deserialize(L->c, S->bp, np, &junk),
                    "plant bytes to the controller", NULL, NULL);
    CHECK(junk == NULL);
    fh_expect_error(o, L->c, o->set_state(L->c, S->sp), "a plant state into the controller", NULL,
                    NULL);
    size_t n_after = 0;
    unsigned char *after = fh_state_bytes(o, L->p, &n_after);
    CHECK(after != NULL && n_after == n_before && memcmp(before, after, n_before) == 0);
    free(after);
    free(before);
    free(bad);
}

void fh_saved_free(fh_loop *L, fh_saved *S)
{
    if (S->sp != NULL) {
        CHECK(L->ops->free_state(L->p, &S->sp) == FH_OK && S->sp == NULL);
    }
    if (S->sc != NULL) {
        CHECK(L->ops->free_state(L->c, &S->sc) == FH_OK && S->sc == NULL);
    }
    free(S->bp);
    free(S->bc);
    S->bp = NULL;
    S->bc = NULL;
}

int fh_state_begin(const fh_ops *ops, const void *plant, const void *ctrl, fh_loop *L,
                   fh_saved *S, void (*after_set)(fh_loop *L, double t1))
{
    void *p = ops->new_cs(plant, "state_plant");
    void *c = ops->new_cs(ctrl, "state_ctrl");
    CHECK(p != NULL && c != NULL);
    memset(S, 0, sizeof *S);
    if (p == NULL || c == NULL) {
        ops->del(p);
        ops->del(c);
        return 1;
    }
    fh_loop_new(L, ops, p, c);
    if (fh_state_replay(L, S, after_set) != 0) {
        fh_state_end(L, S);
        return 1;
    }
    /* corrupted, truncated or foreign bytes are refused and change nothing */
    fh_state_refusals(L, S);
    return 0;
}

void fh_state_end(fh_loop *L, fh_saved *S)
{
    void *none = NULL;
    CHECK(L->ops->free_state(L->p, &none) == FH_OK);
    fh_saved_free(L, S);
    CHECK(S->sp == NULL && S->sc == NULL);
    L->ops->del(L->p);
    L->ops->del(L->c);
    L->p = L->c = NULL;
}

void fh_state_undoes_discard(const fh_ops *ops, const void *plant)
{
    void *f = ops->new_cs(plant, "state_discard");
    CHECK(f != NULL);
    if (f == NULL) {
        return;
    }
    void *sf = NULL;
    CHECK(ops->set_bool(f, fh_md_vr(ops->md(plant), "adaptive"), 0) == FH_OK);
    CHECK(ops->drive_step(f) == 0);
    CHECK(ops->get_state(f, &sf) == FH_OK);
    CHECK(ops->do_step(f, FH_H, 1e4, NULL) == FH_DISCARD);
    ops->check_stepping(f, 1, "after a discarded step");
    CHECK(ops->set_state(f, sf) == FH_OK);
    ops->check_stepping(f, 0, "after setFMUState");
    CHECK(ops->do_step(f, FH_H, FH_H, NULL) == FH_OK);
    CHECK(ops->free_state(f, &sf) == FH_OK && sf == NULL);
    ops->del(f);
}

void fh_forged_states(const fh_ops *ops, void *x, const forge_case *cases, size_t n_cases,
                      size_t data_size, void (*adjust)(forge_case *fc), double step_t)
{
    const char *id = ops->id(ops->api(x));
    fh_log_sink *log = ops->log(x);
    size_t n = 0;
    unsigned char *good = fh_state_bytes(ops, x, &n);
    unsigned char *buf = malloc(n + 1);
    CHECK(good != NULL && buf != NULL && forge_layout_ok(n, data_size));
    if (good == NULL || buf == NULL || !forge_layout_ok(n, data_size)) {
        fprintf(stderr, "%s: FMU state of %zu bytes, the forger expects %zu\n", id, n,
                (size_t)FORGE_DATA + data_size);
        free(good);
        free(buf);
        return;
    }
    /* the good bytes, resealed: accepted (the forger writes the checksum right) */
    memcpy(buf, good, n);
    forge_reseal(buf, n);
    CHECK(memcmp(buf, good, n) == 0);
    void *s = NULL;
    CHECK(ops->deserialize(x, buf, n, &s) == FH_OK && s != NULL);
    size_t refused = 0;
    for (size_t i = 0; i < n_cases && s != NULL; ++i) {
        forge_case fc = cases[i];
        if (adjust != NULL) {
            adjust(&fc);
        }
        forge_apply(&fc, good, buf, n);
        memset(log, 0, sizeof *log);
        void *junk = NULL;
        const int st = ops->deserialize(x, buf, n, &junk);
        const int named = strstr(log->last_error, fc.needle) != NULL;
        /* the importer overwrites a state block it holds: setFMUState checks it again */
        memcpy(s, buf, n);
        memset(log, 0, sizeof *log);
        const int st_set = ops->set_state(x, s);
        const int named_set = strstr(log->last_error, fc.needle) != NULL;
        if (st != FH_ERROR || junk != NULL || !named || st_set != FH_ERROR || !named_set) {
            fprintf(stderr, "%s %s forged state \"%s\": deserialize %d, set %d, message \"%s\" "
                    "(expected %sError naming \"%s\")\n",
                    id, ops->where(x), fc.what, st, st_set, log->last_error, ops->fmi,
                    fc.needle);
            rrr_test_failures++;
        } else {
            ++refused;
        }
        if (junk != NULL) {
            ops->free_state(x, &junk);
        }
        size_t m = 0;
        unsigned char *now = fh_state_bytes(ops, x, &m);
        CHECK(now != NULL && m == n && memcmp(now, good, n) == 0);
        free(now);
    }
    /* the block restored: accepted, and the instance steps on */
    if (s != NULL) {
        memcpy(s, good, n);
        CHECK(ops->set_state(x, s) == FH_OK);
        if (step_t >= 0.0) {
            CHECK(ops->do_step(x, step_t, FH_H, NULL) == FH_OK);
        }
        CHECK(ops->free_state(x, &s) == FH_OK);
    }
    free(good);
    free(buf);
    printf("%s %s: %zu of %zu forged FMU states with valid checksums refused, naming the "
           "field\n", id, ops->where(x), refused, n_cases);
}

void fh_two_instances(const fh_ops *ops, const void *plant)
{
    enum { N = 200 };
    static double q1[N][3], q2[N][3], q3[N][3];
    void *a = ops->new_cs(plant, "a");
    void *b = ops->new_cs(plant, "b");
    CHECK(a != NULL && b != NULL);
    if (a == NULL || b == NULL) {
        ops->del(a);
        ops->del(b);
        return;
    }
    unsigned int u[3], q[3];
    fh_vrs3(ops, plant, "u", u);
    fh_vrs3(ops, plant, "q", q);
    const double ua[3] = {1.0, 0.0, 0.0}, ub[3] = {0.0, -1.5, 0.5};
    CHECK(fh_set1(ops, b, "q0[2]", 0.7) == FH_OK);
    CHECK(ops->drive_init(a) == 0 && ops->drive_init(b) == 0);
    CHECK(ops->exit_init(a) == FH_OK);
    CHECK(ops->exit_init(b) == FH_OK);
    CHECK(ops->set_real(a, u, 3, ua) == FH_OK);
    CHECK(ops->set_real(b, u, 3, ub) == FH_OK);
    for (int k = 0; k < N; ++k) {
        CHECK(ops->do_step(a, k * FH_H, FH_H, NULL) == FH_OK);
        CHECK(ops->do_step(b, k * FH_H, FH_H, NULL) == FH_OK);
        CHECK(ops->get_real(a, q, 3, q1[k]) == FH_OK);
        CHECK(ops->get_real(b, q, 3, q2[k]) == FH_OK);
    }
    ops->del(b);
    void *solo = ops->new_cs(plant, "solo");
    CHECK(solo != NULL);
    if (solo == NULL) {
        ops->del(a);
        return;
    }
    CHECK(ops->drive_init(solo) == 0);
    CHECK(ops->exit_init(solo) == FH_OK);
    CHECK(ops->set_real(solo, u, 3, ua) == FH_OK);
    for (int k = 0; k < N; ++k) {
        CHECK(ops->do_step(solo, k * FH_H, FH_H, NULL) == FH_OK);
        CHECK(ops->get_real(solo, q, 3, q3[k]) == FH_OK);
    }
    CHECK(memcmp(q1, q3, sizeof q1) == 0);
    CHECK(memcmp(q1, q2, sizeof q1) != 0);
    ops->del(a);
    ops->del(solo);
}
