/*
 * Tests of the closed-form dynamics (rrr_dynamics.h) on random, physically consistent robots:
 *   tau = D qdd + c + h; D column by column from inverse dynamics; D symmetric; h = dV/dq and
 *   dE/dt = qd . tau by central differences; c = tau(q, qd, 0) - h; forward dynamics inverts
 *   inverse dynamics; the regressor equals the clean regressor of docs/conventions.md#regressor
 *   typed in by hand (with double-angle libm calls, independent of the generated product forms)
 *   and R p = tau;
 *   bad inputs give RRR_BAD_INPUT / RRR_NUMERIC / RRR_NOT_POSITIVE_DEFINITE with outputs untouched.
 *
 * Base parameters come from a local copy of eq 12 (corrected:
 * docs/conventions.md#base-parameter-set), so this test does not depend on rrr_bps_from_inertia(). Exit status 0 on success; every failure is printed.
 */
#include <math.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "rrr/rrr_dynamics.h"

static int g_failures = 0;
static int g_checks = 0;

#define CHECK(cond, ...)                                                     \
    do {                                                                     \
        ++g_checks;                                                          \
        if (!(cond)) {                                                       \
            ++g_failures;                                                    \
            fprintf(stderr, "FAIL %s:%d: %s: ", __FILE__, __LINE__, #cond); \
            fprintf(stderr, __VA_ARGS__);                                    \
            fputc('\n', stderr);                                             \
        }                                                                    \
    } while (0)

/* ------------------------------------------------------------------------------------------ */
/* Deterministic random numbers (splitmix64)                                                   */
/* ------------------------------------------------------------------------------------------ */
static uint64_t g_rng = 0x2545F4914F6CDD1DULL;

static double urand(double lo, double hi)
{
    uint64_t z = (g_rng += 0x9E3779B97F4A7C15ULL);
    z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
    z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
    z ^= z >> 31;
    const double u = (double)(z >> 11) * 0x1.0p-53;
    return lo + (hi - lo) * u;
}

/* ------------------------------------------------------------------------------------------ */
/* Local eq 12 (corrected: docs/conventions.md#base-parameter-set) from masses, COMs and inertia  */
/* tensors about the COM                                                                          */
/* ------------------------------------------------------------------------------------------ */
typedef struct link_data {
    double m;          /* mass */
    double c[3];       /* COM in DH frame i */
    double ic[3][3];   /* inertia tensor about the COM, frame-i axes */
} link_data;

static void bps_local(const rrr_model *mdl, const link_data L[3], const double jm[3],
                      double p[RRR_NP])
{
    double Ixx[3], Iyy[3], Izz[3], Ixy[3], Ixz[3], Iyz[3], x[3], y[3], z[3], m[3];
    for (int i = 0; i < 3; ++i) {
        const double *c = L[i].c;
        const double cc = c[0] * c[0] + c[1] * c[1] + c[2] * c[2];
        double io[3][3];
        for (int r = 0; r < 3; ++r) {
            for (int k = 0; k < 3; ++k) {
                io[r][k] = L[i].ic[r][k] + L[i].m * ((r == k ? cc : 0.0) - c[r] * c[k]);
            }
        }
        Ixx[i] = io[0][0];
        Iyy[i] = io[1][1];
        Izz[i] = io[2][2];
        Ixy[i] = -io[0][1]; /* products as integrals: the tensor entry is -I_xy */
        Ixz[i] = -io[0][2];
        Iyz[i] = -io[1][2];
        x[i] = c[0];
        y[i] = c[1];
        z[i] = c[2];
        m[i] = L[i].m;
    }
    const double a2 = mdl->a2, a3 = mdl->a3, d2 = mdl->d2, e = mdl->d2 + mdl->d3;
    const double m2 = m[1], m3 = m[2], x2 = x[1], x3 = x[2], y2 = y[1], y3 = y[2], z2 = z[1],
                 z3 = z[2];
    p[0] = a2 * a2 * m3 + a2 * m2 * (a2 + 2.0 * x2) - Ixx[1] + Iyy[1];
    p[1] = -2.0 * (a2 * m2 * y2 + Ixy[1]);
    p[2] = m3 * (a3 + x3);
    p[3] = m3 * y3;
    p[4] = a3 * m3 * (a3 + 2.0 * x3) - Ixx[2] + Iyy[2];
    p[5] = 2.0 * (a3 * m3 * y3 + Ixy[2]);
    p[6] = 2.0 * d2 * m2 * z2 + d2 * d2 * m2 + 2.0 * e * m3 * z3 + e * e * m3 + Iyy[0] + Ixx[1]
         + Ixx[2] + jm[0];
    p[7] = -e * m3 * y3 - Iyz[2];
    p[8] = -a3 * m3 * (z3 + e) - e * m3 * x3 - Ixz[2];
    p[9] = -d2 * m2 * y2 - Iyz[1];
    p[10] = -a2 * (m3 * (z3 + e) + m2 * (d2 + z2)) - d2 * m2 * x2 - Ixz[1];
    p[11] = (a2 * a2 + a3 * a3 + 2.0 * a3 * x3) * m3 + a2 * m2 * (a2 + 2.0 * x2) + Izz[1] + Izz[2]
          + jm[1];
    p[12] = a3 * m3 * (a3 + 2.0 * x3) + Izz[2];
    p[13] = p[12] + jm[2];
    p[14] = m2 * (x2 + a2) + m3 * a2;
    p[15] = m2 * y2;
}

/* Random physically consistent link: I_c = tr(S) E - S with S = Q diag(s) Q^T, s > 0. */
static void random_link(link_data *L)
{
    L->m = urand(0.5, 10.0);
    for (int k = 0; k < 3; ++k) {
        L->c[k] = urand(-0.3, 0.3);
    }
    double qw = urand(-1, 1), qx = urand(-1, 1), qy = urand(-1, 1), qz = urand(-1, 1);
    const double n = sqrt(qw * qw + qx * qx + qy * qy + qz * qz);
    qw /= n;
    qx /= n;
    qy /= n;
    qz /= n;
    const double Q[3][3] = {
        {1 - 2 * (qy * qy + qz * qz), 2 * (qx * qy - qz * qw), 2 * (qx * qz + qy * qw)},
        {2 * (qx * qy + qz * qw), 1 - 2 * (qx * qx + qz * qz), 2 * (qy * qz - qx * qw)},
        {2 * (qx * qz - qy * qw), 2 * (qy * qz + qx * qw), 1 - 2 * (qx * qx + qy * qy)}};
    const double s[3] = {urand(0.001, 0.05) * L->m, urand(0.001, 0.05) * L->m,
                         urand(0.001, 0.05) * L->m};
    double S[3][3];
    double tr = 0.0;
    for (int r = 0; r < 3; ++r) {
        for (int k = 0; k < 3; ++k) {
            S[r][k] = Q[r][0] * s[0] * Q[k][0] + Q[r][1] * s[1] * Q[k][1]
                    + Q[r][2] * s[2] * Q[k][2];
        }
        tr += S[r][r];
    }
    for (int r = 0; r < 3; ++r) {
        for (int k = 0; k < 3; ++k) {
            L->ic[r][k] = (r == k ? tr : 0.0) - S[r][k];
        }
    }
}

static rrr_model random_model(void)
{
    rrr_model m;
    memset(&m, 0, sizeof m);
    m.d1 = urand(-0.6, 0.6);
    m.a2 = urand(0.2, 0.6);
    m.a3 = urand(0.2, 0.6);
    m.d2 = urand(-0.3, 0.3);
    m.d3 = urand(-0.3, 0.3);
    m.g = 9.81;
    for (int i = 0; i < 3; ++i) {
        m.kt[i] = 1.0;
    }
    m.u_max = 10.0;
    link_data L[3];
    double jm[3];
    for (int i = 0; i < 3; ++i) {
        random_link(&L[i]);
        jm[i] = urand(0.0, 0.05);
    }
    bps_local(&m, L, jm, m.p);
    return m;
}

static void random_vec(double v[3], double scale)
{
    for (int i = 0; i < 3; ++i) {
        v[i] = urand(-scale, scale);
    }
}

static double max3(double a, double b, double c)
{
    return fmax(a, fmax(b, c));
}

/* |a - b| <= tol (1 + max|.|) */
static int close_to(double a, double b, double tol)
{
    return fabs(a - b) <= tol * (1.0 + fmax(fabs(a), fabs(b)));
}

/* ------------------------------------------------------------------------------------------ */
/* The clean regressor (docs/conventions.md#regressor), by hand, with libm double angles         */
/* ------------------------------------------------------------------------------------------ */
static void notes_regressor(double a2, double g, const double q[3], const double qd[3],
                            const double qdd[3], double R[3][RRR_NP])
{
    const double q2 = q[1], q3 = q[2];
    const double s2 = sin(q2), c2 = cos(q2), s3 = sin(q3), c3 = cos(q3);
    const double s23 = sin(q2 + q3), c23 = cos(q2 + q3);
    const double sin2q2 = sin(2 * q2), cos2q2 = cos(2 * q2);
    const double sin2q2q3 = sin(2 * q2 + q3), cos2q2q3 = cos(2 * q2 + q3);
    const double sin2q23 = sin(2 * q2 + 2 * q3), cos2q23 = cos(2 * q2 + 2 * q3);
    const double qd1 = qd[0], qd2 = qd[1], qd3 = qd[2], qdd1 = qdd[0], qdd2 = qdd[1],
                 qdd3 = qdd[2];
    const double qd23 = qd2 + qd3, qdd23 = qdd2 + qdd3;
    memset(R, 0, 3 * sizeof R[0]);
    R[0][0] = qdd1 * c2 * c2 - qd1 * qd2 * sin2q2;
    R[0][1] = 0.5 * qdd1 * sin2q2 + qd1 * qd2 * cos2q2;
    R[0][2] = 2 * a2 * ((qdd1 * c23 - qd1 * qd3 * s23) * c2 - qd1 * qd2 * sin2q2q3);
    R[0][3] = -2 * a2 * ((qdd1 * s23 + qd1 * qd3 * c23) * c2 + qd1 * qd2 * cos2q2q3);
    R[0][4] = qdd1 * c23 * c23 - qd1 * qd23 * sin2q23;
    R[0][5] = -0.5 * qdd1 * sin2q23 - qd1 * qd23 * cos2q23;
    R[0][6] = qdd1;
    R[0][7] = qdd23 * c23 - qd23 * qd23 * s23;
    R[0][8] = qdd23 * s23 + qd23 * qd23 * c23;
    R[0][9] = qdd2 * c2 - qd2 * qd2 * s2;
    R[0][10] = qdd2 * s2 + qd2 * qd2 * c2;
    R[1][0] = 0.5 * qd1 * qd1 * sin2q2;
    R[1][1] = -0.5 * qd1 * qd1 * cos2q2;
    R[1][2] = 2 * a2
                * ((qdd2 + 0.5 * qdd3) * c3 - (qd2 * qd3 + 0.5 * qd3 * qd3) * s3
                   + 0.5 * qd1 * qd1 * sin2q2q3)
            + g * c23;
    R[1][3] = -2 * a2
                * ((qdd2 + 0.5 * qdd3) * s3 + (qd2 * qd3 + 0.5 * qd3 * qd3) * c3
                   - 0.5 * qd1 * qd1 * cos2q2q3)
            - g * s23;
    R[1][4] = 0.5 * qd1 * qd1 * sin2q23;
    R[1][5] = 0.5 * qd1 * qd1 * cos2q23;
    R[1][7] = qdd1 * c23;
    R[1][8] = qdd1 * s23;
    R[1][9] = qdd1 * c2;
    R[1][10] = qdd1 * s2;
    R[1][11] = qdd2;
    R[1][12] = qdd3;
    R[1][14] = g * c2;
    R[1][15] = -g * s2;
    R[2][2] = a2 * (qdd2 * c3 + qd2 * qd2 * s3 + qd1 * qd1 * c2 * s23) + g * c23;
    R[2][3] = a2 * (-qdd2 * s3 + qd2 * qd2 * c3 + qd1 * qd1 * c2 * c23) - g * s23;
    R[2][4] = 0.5 * qd1 * qd1 * sin2q23;
    R[2][5] = 0.5 * qd1 * qd1 * cos2q23;
    R[2][7] = qdd1 * c23;
    R[2][8] = qdd1 * s23;
    R[2][12] = qdd2;
    R[2][13] = qdd3;
}

/* ------------------------------------------------------------------------------------------ */
/* Sentinels: outputs must stay untouched on any error                                        */
/* ------------------------------------------------------------------------------------------ */
#define SENTINEL 12345.678

static void fill(double *v, size_t n)
{
    for (size_t i = 0; i < n; ++i) {
        v[i] = SENTINEL;
    }
}

/* bitwise equality (no float ==, so the test also builds with -Wfloat-equal) */
static int same_bits(double a, double b)
{
    return memcmp(&a, &b, sizeof a) == 0;
}

static int untouched(const double *v, size_t n)
{
    for (size_t i = 0; i < n; ++i) {
        if (!same_bits(v[i], SENTINEL)) {
            return 0;
        }
    }
    return 1;
}

/* ------------------------------------------------------------------------------------------ */
/* Property tests on random robots and states                                                   */
/* ------------------------------------------------------------------------------------------ */
static double energy(const rrr_model *m, const double q[3], const double qd[3])
{
    double ke = (double)NAN, pe = (double)NAN;
    CHECK(rrr_energy(m, q, qd, &ke, &pe) == RRR_OK, "energy");
    return ke + pe;
}

static void test_one_state(const rrr_model *m, int robot, int state)
{
    double q[3], qd[3], qdd[3];
    random_vec(q, 3.2);
    random_vec(qd, 3.0);
    random_vec(qdd, 10.0);

    double tau[3], D[3][3], c[3], h[3], Y[3][RRR_NP], Rn[3][RRR_NP];
    CHECK(rrr_inverse_dynamics(m, q, qd, qdd, tau) == RRR_OK, "robot %d state %d", robot, state);
    CHECK(rrr_mass_matrix(m, q, D) == RRR_OK, "robot %d", robot);
    CHECK(rrr_coriolis(m, q, qd, c) == RRR_OK, "robot %d", robot);
    CHECK(rrr_gravity(m, q, h) == RRR_OK, "robot %d", robot);
    CHECK(rrr_regressor(m, q, qd, qdd, Y) == RRR_OK, "robot %d", robot);

    /* tau = D qdd + c + h, and tau = Y p */
    for (int i = 0; i < 3; ++i) {
        const double sum = D[i][0] * qdd[0] + D[i][1] * qdd[1] + D[i][2] * qdd[2] + c[i] + h[i];
        CHECK(close_to(tau[i], sum, 1e-12), "robot %d state %d: tau[%d] %.17g vs D qdd + c + h %.17g",
              robot, state, i, tau[i], sum);
        double yp = 0.0;
        for (int k = 0; k < RRR_NP; ++k) {
            yp += Y[i][k] * m->p[k];
        }
        CHECK(close_to(tau[i], yp, 1e-12), "robot %d state %d: tau[%d] %.17g vs Y p %.17g", robot,
              state, i, tau[i], yp);
    }

    /* regressor = clean regressor of docs/conventions.md#regressor */
    notes_regressor(m->a2, m->g, q, qd, qdd, Rn);
    double worst = 0.0;
    for (int i = 0; i < 3; ++i) {
        for (int k = 0; k < RRR_NP; ++k) {
            worst = fmax(worst, fabs(Y[i][k] - Rn[i][k]) / (1.0 + fabs(Rn[i][k])));
        }
    }
    CHECK(worst <= 1e-12, "robot %d state %d: regressor vs docs/conventions.md#regressor, max rel diff %.3g", robot,
          state, worst);

    /* D symmetric, and D column by column from inverse dynamics with qd = 0, g = 0 */
    rrr_model m0 = *m;
    m0.g = 0.0;
    const double zero[3] = {0.0, 0.0, 0.0};
    for (int j = 0; j < 3; ++j) {
        double e[3] = {0.0, 0.0, 0.0}, col[3];
        e[j] = 1.0;
        CHECK(rrr_inverse_dynamics(&m0, q, zero, e, col) == RRR_OK, "column %d", j);
        for (int i = 0; i < 3; ++i) {
            CHECK(close_to(col[i], D[i][j], 1e-12), "robot %d: D[%d][%d] %.17g vs column %.17g",
                  robot, i, j, D[i][j], col[i]);
            CHECK(same_bits(D[i][j], D[j][i]), "robot %d: D not symmetric at %d,%d", robot, i, j);
        }
    }

    /* c(q, qd) = tau(q, qd, 0) - h(q) */
    double b[3];
    CHECK(rrr_inverse_dynamics(m, q, qd, zero, b) == RRR_OK, "bias");
    for (int i = 0; i < 3; ++i) {
        CHECK(close_to(c[i], b[i] - h[i], 1e-12), "robot %d: c[%d] %.17g vs tau(qdd=0) - h %.17g",
              robot, i, c[i], b[i] - h[i]);
    }

    /* h = dV/dq by central differences */
    const double step = 1e-5;
    for (int i = 0; i < 3; ++i) {
        double qp[3] = {q[0], q[1], q[2]}, qm[3] = {q[0], q[1], q[2]};
        qp[i] += step;
        qm[i] -= step;
        double kp, vp, km, vm;
        CHECK(rrr_energy(m, qp, zero, &kp, &vp) == RRR_OK, "energy +");
        CHECK(rrr_energy(m, qm, zero, &km, &vm) == RRR_OK, "energy -");
        const double fd = (vp - vm) / (2.0 * step);
        CHECK(close_to(fd, h[i], 1e-6), "robot %d: dV/dq%d %.12g vs h %.12g", robot, i + 1, fd,
              h[i]);
    }

    /* power balance: d/dt (T + V) = qd . tau along q(t) = q + t qd + t^2/2 qdd */
    {
        double qa[3], qb[3], va[3], vb[3];
        for (int i = 0; i < 3; ++i) {
            qa[i] = q[i] + step * qd[i] + 0.5 * step * step * qdd[i];
            qb[i] = q[i] - step * qd[i] + 0.5 * step * step * qdd[i];
            va[i] = qd[i] + step * qdd[i];
            vb[i] = qd[i] - step * qdd[i];
        }
        const double dedt = (energy(m, qa, va) - energy(m, qb, vb)) / (2.0 * step);
        const double power = qd[0] * tau[0] + qd[1] * tau[1] + qd[2] * tau[2];
        CHECK(close_to(dedt, power, 1e-6), "robot %d: dE/dt %.12g vs qd.tau %.12g", robot, dedt,
              power);
    }

    /* forward dynamics inverts inverse dynamics */
    double qdd2[3];
    CHECK(rrr_forward_dynamics(m, q, qd, tau, qdd2) == RRR_OK, "forward dynamics");
    const double err = max3(fabs(qdd2[0] - qdd[0]), fabs(qdd2[1] - qdd[1]), fabs(qdd2[2] - qdd[2]));
    CHECK(err <= 1e-10 * (1.0 + max3(fabs(qdd[0]), fabs(qdd[1]), fabs(qdd[2]))),
          "robot %d state %d: forward(inverse(qdd)) error %.3g", robot, state, err);
}

/* ------------------------------------------------------------------------------------------ */
/* Error handling                                                                               */
/* ------------------------------------------------------------------------------------------ */
/* Expected statuses of one call of every function (they read different arguments). */
typedef struct expect {
    rrr_status inv;    /* inverse dynamics and forward dynamics (read everything) */
    rrr_status reg;    /* regressor (reads a2, g, not p) */
    rrr_status cor;    /* coriolis (reads q, qd, a2, p) */
    rrr_status energy; /* energy (reads q, qd, a2, g, p) */
} expect;

static expect all_are(rrr_status s)
{
    const expect e = {s, s, s, s};
    return e;
}

/* Calls every function with (m, q, qd, acc) and checks the statuses; on an error the outputs
 * must be untouched. acc is qdd for inverse dynamics / regressor and tau for forward dynamics. */
static void expect_all(const rrr_model *m, const double *q, const double *qd, const double *acc,
                       expect want, const char *what)
{
    double tau[3], c[3], Y[3][RRR_NP], qdd[3], ke = SENTINEL, pe = SENTINEL;
    fill(tau, 3);
    fill(c, 3);
    fill(&Y[0][0], 3 * RRR_NP);
    fill(qdd, 3);
    rrr_status s;
    s = rrr_inverse_dynamics(m, q, qd, acc, tau);
    CHECK(s == want.inv && (s == RRR_OK || untouched(tau, 3)), "%s: inverse_dynamics -> %d",
          what, (int)s);
    s = rrr_forward_dynamics(m, q, qd, acc, qdd);
    CHECK(s == want.inv && (s == RRR_OK || untouched(qdd, 3)), "%s: forward_dynamics -> %d",
          what, (int)s);
    s = rrr_regressor(m, q, qd, acc, Y);
    CHECK(s == want.reg && (s == RRR_OK || untouched(&Y[0][0], 3 * RRR_NP)),
          "%s: regressor -> %d", what, (int)s);
    s = rrr_coriolis(m, q, qd, c);
    CHECK(s == want.cor && (s == RRR_OK || untouched(c, 3)), "%s: coriolis -> %d", what, (int)s);
    s = rrr_energy(m, q, qd, &ke, &pe);
    CHECK(s == want.energy && (s == RRR_OK || (same_bits(ke, SENTINEL) && same_bits(pe, SENTINEL))),
          "%s: energy -> %d", what, (int)s);
}

static void test_errors(const rrr_model *good)
{
    const double q[3] = {0.1, -0.4, 0.9}, qd[3] = {0.3, -0.2, 0.5}, acc[3] = {1.0, -2.0, 0.5};
    const expect bad_acc = {RRR_BAD_INPUT, RRR_BAD_INPUT, RRR_OK, RRR_OK};
    expect_all(good, q, qd, acc, all_are(RRR_OK), "good inputs");
    expect_all(NULL, q, qd, acc, all_are(RRR_BAD_INPUT), "NULL model");
    expect_all(good, NULL, qd, acc, all_are(RRR_BAD_INPUT), "NULL q");
    expect_all(good, q, NULL, acc, all_are(RRR_BAD_INPUT), "NULL qd");
    expect_all(good, q, qd, NULL, bad_acc, "NULL qdd/tau");

    /* NULL outputs */
    double out[3], D[3][3], ke;
    CHECK(rrr_inverse_dynamics(good, q, qd, acc, NULL) == RRR_BAD_INPUT, "NULL tau out");
    CHECK(rrr_regressor(good, q, qd, acc, NULL) == RRR_BAD_INPUT, "NULL Y");
    CHECK(rrr_mass_matrix(good, q, NULL) == RRR_BAD_INPUT, "NULL D");
    CHECK(rrr_mass_matrix(NULL, q, D) == RRR_BAD_INPUT, "NULL model (mass matrix)");
    CHECK(rrr_mass_matrix(good, NULL, D) == RRR_BAD_INPUT, "NULL q (mass matrix)");
    CHECK(rrr_coriolis(good, q, qd, NULL) == RRR_BAD_INPUT, "NULL c");
    CHECK(rrr_gravity(good, q, NULL) == RRR_BAD_INPUT, "NULL h");
    CHECK(rrr_gravity(NULL, q, out) == RRR_BAD_INPUT, "NULL model (gravity)");
    CHECK(rrr_gravity(good, NULL, out) == RRR_BAD_INPUT, "NULL q (gravity)");
    CHECK(rrr_forward_dynamics(good, q, qd, acc, NULL) == RRR_BAD_INPUT, "NULL qdd out");
    CHECK(rrr_energy(good, q, qd, NULL, &ke) == RRR_BAD_INPUT, "NULL kinetic");
    CHECK(rrr_energy(good, q, qd, &ke, NULL) == RRR_BAD_INPUT, "NULL potential");

    /* NaN / Inf in each input component */
    const double bad[2] = {(double)NAN, (double)INFINITY};
    for (int b = 0; b < 2; ++b) {
        for (int i = 0; i < 3; ++i) {
            double qb[3] = {q[0], q[1], q[2]}, qdb[3] = {qd[0], qd[1], qd[2]},
                   ab[3] = {acc[0], acc[1], acc[2]};
            qb[i] = bad[b];
            qdb[i] = bad[b];
            ab[i] = -bad[b];
            expect_all(good, qb, qd, acc, all_are(RRR_BAD_INPUT), "bad q");
            expect_all(good, q, qdb, acc, all_are(RRR_BAD_INPUT), "bad qd");
            expect_all(good, q, qd, ab, bad_acc, "bad qdd/tau");
            double Dm[3][3], h[3];
            fill(&Dm[0][0], 9);
            fill(h, 3);
            CHECK(rrr_mass_matrix(good, qb, Dm) == RRR_BAD_INPUT && untouched(&Dm[0][0], 9),
                  "bad q (mass matrix)");
            CHECK(rrr_gravity(good, qb, h) == RRR_BAD_INPUT && untouched(h, 3), "bad q (gravity)");
        }
        /* non-finite model fields that the functions read */
        rrr_model mb = *good;
        mb.a2 = bad[b];
        expect_all(&mb, q, qd, acc, all_are(RRR_BAD_INPUT), "bad a2");
        mb = *good;
        mb.g = bad[b];
        const expect bad_g = {RRR_BAD_INPUT, RRR_BAD_INPUT, RRR_OK, RRR_BAD_INPUT};
        expect_all(&mb, q, qd, acc, bad_g, "bad g");
        for (int k = 0; k < RRR_NP; ++k) {
            mb = *good;
            mb.p[k] = bad[b];
            const expect bad_p = {RRR_BAD_INPUT, RRR_OK, RRR_BAD_INPUT, RRR_BAD_INPUT};
            expect_all(&mb, q, qd, acc, bad_p, "bad p");
            double Dm[3][3], h[3];
            fill(&Dm[0][0], 9);
            fill(h, 3);
            CHECK(rrr_mass_matrix(&mb, q, Dm) == RRR_BAD_INPUT && untouched(&Dm[0][0], 9),
                  "bad p[%d] (mass matrix)", k);
            CHECK(rrr_gravity(&mb, q, h) == RRR_BAD_INPUT && untouched(h, 3),
                  "bad p[%d] (gravity)", k);
        }
    }

    /* the hot paths classify after computing: a non-finite parameter must show even where
     * every factor it meets is zero (robot at rest, zero acceleration or torque) */
    const double rest[3] = {0.0, 0.0, 0.0};
    for (int b = 0; b < 2; ++b) {
        rrr_model mb = *good;
        mb.a2 = bad[b];
        expect_all(&mb, rest, rest, rest, all_are(RRR_BAD_INPUT), "bad a2 at rest");
        mb = *good;
        mb.g = bad[b];
        const expect bad_g = {RRR_BAD_INPUT, RRR_BAD_INPUT, RRR_OK, RRR_BAD_INPUT};
        expect_all(&mb, rest, rest, rest, bad_g, "bad g at rest");
        for (int k = 0; k < RRR_NP; ++k) {
            mb = *good;
            mb.p[k] = bad[b];
            const expect bad_p = {RRR_BAD_INPUT, RRR_OK, RRR_BAD_INPUT, RRR_BAD_INPUT};
            expect_all(&mb, rest, rest, rest, bad_p, "bad p at rest");
        }
    }

    /* finite inputs whose result overflows: RRR_NUMERIC, outputs untouched */
    rrr_model huge = *good;
    for (int k = 0; k < RRR_NP; ++k) {
        huge.p[k] = 1e300;
    }
    const double fast[3] = {1e10, 1e10, 1e10};
    fill(out, 3);
    CHECK(rrr_inverse_dynamics(&huge, q, fast, acc, out) == RRR_NUMERIC && untouched(out, 3),
          "overflow -> RRR_NUMERIC");
    fill(out, 3);
    CHECK(rrr_coriolis(&huge, q, fast, out) == RRR_NUMERIC && untouched(out, 3),
          "overflow (coriolis) -> RRR_NUMERIC");

    /* a parameter vector with D not positive definite */
    rrr_model zero = *good;
    memset(zero.p, 0, sizeof zero.p);
    fill(out, 3);
    CHECK(rrr_forward_dynamics(&zero, q, qd, acc, out) == RRR_NOT_POSITIVE_DEFINITE
              && untouched(out, 3),
          "p = 0 -> RRR_NOT_POSITIVE_DEFINITE");
    rrr_model neg = *good;
    neg.p[13] = -1.0; /* D33 = p14 < 0 */
    fill(out, 3);
    CHECK(rrr_forward_dynamics(&neg, q, qd, acc, out) == RRR_NOT_POSITIVE_DEFINITE
              && untouched(out, 3),
          "p14 < 0 -> RRR_NOT_POSITIVE_DEFINITE");
}

int main(void)
{
    const int robots = 40, states = 25;
    rrr_model first = random_model();
    for (int r = 0; r < robots; ++r) {
        const rrr_model m = r == 0 ? first : random_model();
        for (int s = 0; s < states; ++s) {
            test_one_state(&m, r, s);
        }
    }
    test_errors(&first);
    if (g_failures != 0) {
        fprintf(stderr, "test_dynamics: %d of %d checks FAILED\n", g_failures, g_checks);
        return 1;
    }
    printf("test_dynamics: all %d checks passed\n", g_checks);
    return 0;
}
