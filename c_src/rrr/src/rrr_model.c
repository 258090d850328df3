/* Model parameters: defaults, validation, base parameters from inertial parameters (eq 12). */
#include <string.h>

#include "rrr_dynamics_gen.h"
#include "rrr_internal.h"

/*
 * The default robot: a direct-drive arm like the paper's. The paper prints no numbers, so each
 * value is a proposal (slender-bar and sizing estimates); python/rrr_robot/data/default_robot.toml
 * carries the same numbers with their reasoning, and a test checks the two agree.
 * k_t is calibrated so that the writing task's RMS feedforward voltages land near the paper's
 * eq 16 (see tools/calibrate_kt.py and the README).
 */
rrr_status rrr_inertial_default(rrr_inertial *in)
{
    if (in == NULL) {
        return RRR_BAD_INPUT;
    }
    memset(in, 0, sizeof *in);
    /* link 1: only its inertia about the vertical (joint-1) axis, which is y1, matters */
    in->link[0].mass = 8.0;
    in->link[0].com[1] = -0.15;
    in->link[0].inertia_com[0][0] = 0.12;
    in->link[0].inertia_com[1][1] = 0.20;
    in->link[0].inertia_com[2][2] = 0.12;
    /* link 2: upper arm, COM behind the distal frame origin (x2 < 0) */
    in->link[1].mass = 6.0;
    in->link[1].com[0] = -0.20;
    in->link[1].com[2] = 0.05;
    in->link[1].inertia_com[0][0] = 0.02;
    in->link[1].inertia_com[1][1] = 0.10;
    in->link[1].inertia_com[2][2] = 0.10;
    /* link 3: forearm */
    in->link[2].mass = 2.5;
    in->link[2].com[0] = -0.15;
    in->link[2].com[2] = 0.02;
    in->link[2].inertia_com[0][0] = 0.005;
    in->link[2].inertia_com[1][1] = 0.03;
    in->link[2].inertia_com[2][2] = 0.03;
    /* rotor + encoder + slip rings */
    in->rotor_inertia[0] = 0.02;
    in->rotor_inertia[1] = 0.02;
    in->rotor_inertia[2] = 0.01;
    return RRR_OK;
}

rrr_status rrr_model_default(rrr_model *m)
{
    if (m == NULL) {
        return RRR_BAD_INPUT;
    }
    rrr_model d;
    memset(&d, 0, sizeof d);
    d.d1 = 0.50;
    d.a2 = 0.40;
    d.a3 = 0.35;
    d.d2 = 0.15;
    d.d3 = -0.05;
    d.g = 9.81;
    d.kt[0] = RRR_DEFAULT_KT1;
    d.kt[1] = RRR_DEFAULT_KT2;
    d.kt[2] = RRR_DEFAULT_KT3;
    static const double f_row[RRR_NF] = {0.08, 0.04, -0.02};
    static const double w_row[RRR_NF] = {100.0, 10.0, 1.0};
    for (int i = 0; i < RRR_NJ; ++i) {
        for (int k = 0; k < RRR_NF; ++k) {
            d.f[i][k] = f_row[k];
            d.w[i][k] = w_row[k];
        }
        d.b[i] = 0.02;
    }
    d.u_max = 10.0;
    rrr_inertial in;
    (void)rrr_inertial_default(&in);
    rrr_status st = rrr_bps_from_inertia(&d, &in, d.p);
    if (st != RRR_OK) {
        return st;
    }
    *m = d;
    return RRR_OK;
}

/* Inertia about the frame origin, with products as integrals (I_xy = int x y dm). */
typedef struct origin_inertia {
    double xx, yy, zz, xy, xz, yz;
} origin_inertia;

static origin_inertia to_origin(const rrr_link_inertia *l)
{
    const double *c = l->com;
    const double m = l->mass;
    const double cc = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
    double io[3][3];
    for (int r = 0; r < 3; ++r) {
        for (int k = 0; k < 3; ++k) {
            /* parallel-axis theorem: I_O = I_c + m (|c|^2 E - c c^T) */
            io[r][k] = l->inertia_com[r][k] + m * ((r == k ? cc : 0.0) - c[r] * c[k]);
        }
    }
    origin_inertia o;
    o.xx = io[0][0];
    o.yy = io[1][1];
    o.zz = io[2][2];
    o.xy = -io[0][1];
    o.xz = -io[0][2];
    o.yz = -io[1][2];
    return o;
}

static int link_ok(const rrr_link_inertia *l)
{
    if (!isfinite(l->mass) || l->mass < 0.0 || !rrr_finite_n(l->com, 3)) {
        return 0;
    }
    for (int r = 0; r < 3; ++r) {
        if (!rrr_finite_n(l->inertia_com[r], 3)) {
            return 0;
        }
    }
    return 1;
}

rrr_status rrr_bps_from_inertia(const rrr_model *m, const rrr_inertial *in, double p[RRR_NP])
{
    if (m == NULL || in == NULL || p == NULL) {
        return RRR_BAD_INPUT;
    }
    const double kin[4] = {m->a2, m->a3, m->d2, m->d3};
    if (!rrr_finite_n(kin, 4) || !rrr_finite_n(in->rotor_inertia, 3)) {
        return RRR_BAD_INPUT;
    }
    for (int i = 0; i < RRR_NJ; ++i) {
        if (!link_ok(&in->link[i]) || in->rotor_inertia[i] < 0.0) {
            return RRR_BAD_INPUT;
        }
    }
    const double a2 = m->a2, a3 = m->a3, d2 = m->d2, e = m->d2 + m->d3;
    const origin_inertia i1 = to_origin(&in->link[0]);
    const origin_inertia i2 = to_origin(&in->link[1]);
    const origin_inertia i3 = to_origin(&in->link[2]);
    const double m2 = in->link[1].mass, m3 = in->link[2].mass;
    const double x2 = in->link[1].com[0], y2 = in->link[1].com[1], z2 = in->link[1].com[2];
    const double x3 = in->link[2].com[0], y3 = in->link[2].com[1], z3 = in->link[2].com[2];
    const double *jm = in->rotor_inertia;
    double r[RRR_NP];
    /* eq 12 with the corrections of docs/conventions.md#typos-in-the-printed-eq-12 (p9: z3, p12: I_zz, p13: I_zz) */
    r[0] = a2 * a2 * m3 + a2 * m2 * (a2 + 2.0 * x2) - i2.xx + i2.yy;
    r[1] = -2.0 * (a2 * m2 * y2 + i2.xy);
    r[2] = m3 * (a3 + x3);
    r[3] = m3 * y3;
    r[4] = a3 * m3 * (a3 + 2.0 * x3) - i3.xx + i3.yy;
    r[5] = 2.0 * (a3 * m3 * y3 + i3.xy);
    r[6] = 2.0 * d2 * m2 * z2 + d2 * d2 * m2 + 2.0 * e * m3 * z3 + e * e * m3 + i1.yy + i2.xx +
           i3.xx + jm[0];
    r[7] = -e * m3 * y3 - i3.yz;
    r[8] = -a3 * m3 * (z3 + e) - e * m3 * x3 - i3.xz;
    r[9] = -d2 * m2 * y2 - i2.yz;
    r[10] = -a2 * (m3 * (z3 + e) + m2 * (d2 + z2)) - d2 * m2 * x2 - i2.xz;
    r[11] = (a2 * a2 + a3 * a3 + 2.0 * a3 * x3) * m3 + a2 * m2 * (a2 + 2.0 * x2) + i2.zz + i3.zz +
            jm[1];
    r[12] = a3 * m3 * (a3 + 2.0 * x3) + i3.zz;
    r[13] = r[12] + jm[2];
    r[14] = m2 * (x2 + a2) + m3 * a2;
    r[15] = m2 * y2;
    if (!rrr_finite_n(r, RRR_NP)) {
        return RRR_BAD_INPUT;
    }
    memcpy(p, r, sizeof r);
    return RRR_OK;
}

static rrr_status fail(const char **field, const char *name, rrr_status st)
{
    if (field != NULL) {
        *field = name;
    }
    return st;
}

/* Smallest Cholesky pivot of D at the angles of t (D does not depend on q1): D is positive
 * definite exactly where it is > 0. Returns at the first pivot that is not positive (or NaN). */
static double min_pivot_at(const rrr_model *m, const rrr_trig *t)
{
    double D[3][3];
    rrr_gen_mass_matrix(m, t, D);
    const double d00 = D[0][0];
    if (!(d00 > 0.0)) {
        return fmin(d00, 0.0); /* a NaN pivot counts as 0: not positive definite */
    }
    const double d11 = D[1][1] - D[1][0] * D[1][0] / d00;
    if (!(d11 > 0.0)) {
        return fmin(d11, 0.0);
    }
    const double s21 = D[2][1] - D[2][0] * D[1][0] / d00;
    const double d22 = D[2][2] - D[2][0] * D[2][0] / d00 - s21 * s21 / d11;
    if (!(d22 > 0.0)) {
        return fmin(d22, 0.0);
    }
    return fmin(fmin(d00, d11), d22);
}

static double min_pivot(const rrr_model *m, double q2, double q3)
{
    const double q[3] = {0.0, q2, q3};
    const rrr_trig t = rrr_trig_of(q);
    return min_pivot_at(m, &t);
}

/* Pattern search for the minimum of min_pivot from (q2, q3), steps halved down to 1e-9 rad;
 * returns the least value seen. */
static double refine_min_pivot(const rrr_model *m, double q2, double q3, double step)
{
    double best = min_pivot(m, q2, q3);
    while (step > 1e-9 && best > 0.0) {
        double cand_best = best, c2 = q2, c3 = q3;
        for (int a = -1; a <= 1; ++a) {
            for (int b = -1; b <= 1; ++b) {
                if (a == 0 && b == 0) {
                    continue;
                }
                const double v = min_pivot(m, q2 + a * step, q3 + b * step);
                if (v < cand_best) {
                    cand_best = v;
                    c2 = q2 + a * step;
                    c3 = q3 + b * step;
                }
            }
        }
        if (cand_best < best) {
            best = cand_best;
            q2 = c2;
            q3 = c3;
        } else {
            step *= 0.5;
        }
    }
    return best;
}

enum { PD_GRID = 64 }; /* grid points per angle over the torus */

/* min_pivot along q2 = angle i of the grid, for every q3 of the grid (sin and cos of the grid
 * angles given: s = sin, c = cos; the sums as rrr_trig_of forms them) */
static void pivot_row(const rrr_model *m, int i, const double s[PD_GRID],
                      const double c[PD_GRID], double row[PD_GRID])
{
    for (int k = 0; k < PD_GRID; ++k) {
        rrr_trig t;
        t.s2 = s[i];
        t.c2 = c[i];
        t.s3 = s[k];
        t.c3 = c[k];
        t.s23 = t.s2 * t.c3 + t.c2 * t.s3;
        t.c23 = t.c2 * t.c3 - t.s2 * t.s3;
        row[k] = min_pivot_at(m, &t);
    }
}

/* 1 when D(q) is positive definite for every q: D's entries are trigonometric polynomials of
 * degree 2 in q2 and q3, so its smallest Cholesky pivot is smooth with basins wide against a
 * 64 x 64 grid over the torus; every grid point is checked, and from every grid point not
 * above its four neighbours (the grid wraps around) a pattern search finds the bottom of that
 * basin (a grid alone misses a thin negative dip between grid points). Each grid value is
 * computed once, from the sines and cosines of the 64 grid angles, three rows at a time (no
 * large stack frame). The model's parameters are finite here (range-checked first). */
static int mass_matrix_pd_everywhere(const rrr_model *m)
{
    const double h = 2.0 * RRR_PI / (double)PD_GRID;
    double s[PD_GRID], c[PD_GRID];
    for (int i = 0; i < PD_GRID; ++i) {
        const double q = -RRR_PI + i * h;
        s[i] = sin(q);
        c[i] = cos(q);
    }
    double first[PD_GRID], last[PD_GRID], rows[3][PD_GRID];
    pivot_row(m, 0, s, c, first);
    pivot_row(m, PD_GRID - 1, s, c, last);
    const double *prev = last, *cur = first;
    for (int i = 0; i < PD_GRID; ++i) {
        const double *next;
        if (i + 1 == PD_GRID) {
            next = first;
        } else if (i + 1 == PD_GRID - 1) {
            next = last;
        } else {
            double *r = rows[i % 3];
            pivot_row(m, i + 1, s, c, r);
            next = r;
        }
        for (int k = 0; k < PD_GRID; ++k) {
            const double v = cur[k];
            if (!(v > 0.0)) {
                return 0;
            }
            const int kp = (k + 1) % PD_GRID, km = (k + PD_GRID - 1) % PD_GRID;
            const int local_min = v <= next[k] && v <= prev[k] && v <= cur[kp] && v <= cur[km];
            if (local_min &&
                !(refine_min_pivot(m, -RRR_PI + i * h, -RRR_PI + k * h, 0.5 * h) > 0.0)) {
                return 0;
            }
        }
        prev = cur;
        cur = next;
    }
    return 1;
}

rrr_status rrr_model_validate(const rrr_model *m, const char **field)
{
    if (m == NULL) {
        return fail(field, "model", RRR_BAD_INPUT);
    }
    size_t n = 0;
    const rrr_param_info *table = rrr_param_table(&n);
    for (size_t i = 0; i < n; ++i) {
        if (!rrr_param_in_range(i, rrr_param_get(m, i))) {
            return fail(field, table[i].name, RRR_BAD_MODEL);
        }
    }
    if (!mass_matrix_pd_everywhere(m)) {
        return fail(field, "p", RRR_NOT_POSITIVE_DEFINITE);
    }
    return fail(field, "", RRR_OK);
}
