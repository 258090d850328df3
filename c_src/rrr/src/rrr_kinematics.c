/* Closed-form kinematics (paper eqs 3-6), IK valid in the whole workspace (docs/conventions.md#inverse-kinematics). */
#include <string.h>

#include "rrr_internal.h"

/* RRR_IK_BOUNDARY_TOL (the snapping onto the workspace boundary) is in rrr_internal.h: the
 * batch IK kernels (c_src/rrr/simd/rrr_simd_kernels.c) decide reachability as ik_geometry does. */

rrr_status rrr_fk(const rrr_model *m, const double q[3], double x[3], double R[3][3])
{
    if (m == NULL || q == NULL || x == NULL || !rrr_finite_n(q, 3) || !rrr_kin_ok(m)) {
        return RRR_BAD_INPUT;
    }
    const double s1 = sin(q[0]), c1 = cos(q[0]);
    const rrr_trig t = rrr_trig_of(q);
    const double e = m->d2 + m->d3;
    const double r = m->a2 * t.c2 + m->a3 * t.c23; /* planar reach */
    x[0] = c1 * r + e * s1;
    x[1] = s1 * r - e * c1;
    x[2] = m->a2 * t.s2 + m->a3 * t.s23 + m->d1;
    if (R != NULL) {
        R[0][0] = c1 * t.c23;
        R[0][1] = -c1 * t.s23;
        R[0][2] = s1;
        R[1][0] = s1 * t.c23;
        R[1][1] = -s1 * t.s23;
        R[1][2] = -c1;
        R[2][0] = t.s23;
        R[2][1] = t.c23;
        R[2][2] = 0.0;
    }
    return RRR_OK;
}

/* One homogeneous transform from a rotation (row-major) and a position. */
static void set_frame(double T[4][4], const double R[3][3], const double p[3])
{
    for (int i = 0; i < 3; ++i) {
        T[i][0] = R[i][0];
        T[i][1] = R[i][1];
        T[i][2] = R[i][2];
        T[i][3] = p[i];
        T[3][i] = 0.0;
    }
    T[3][3] = 1.0;
}

rrr_status rrr_fk_frames(const rrr_model *m, const double q[3], double T[RRR_NFRAMES][4][4])
{
    if (m == NULL || q == NULL || T == NULL || !rrr_finite_n(q, 3) || !rrr_kin_ok(m)) {
        return RRR_BAD_INPUT;
    }
    const double s1 = sin(q[0]), c1 = cos(q[0]);
    const rrr_trig t = rrr_trig_of(q);
    const double R0[3][3] = {{1.0, 0.0, 0.0}, {0.0, 1.0, 0.0}, {0.0, 0.0, 1.0}};
    const double p0[3] = {0.0, 0.0, 0.0};
    /* frame 1: Rz(q1) Tz(d1) Rx(pi/2) */
    const double R1[3][3] = {{c1, 0.0, s1}, {s1, 0.0, -c1}, {0.0, 1.0, 0.0}};
    const double p1[3] = {0.0, 0.0, m->d1};
    /* frame 2: frame 1 Rz(q2) Tz(d2) Tx(a2) */
    const double r2 = m->a2 * t.c2;
    const double R2[3][3] = {{c1 * t.c2, -c1 * t.s2, s1}, {s1 * t.c2, -s1 * t.s2, -c1},
                             {t.s2, t.c2, 0.0}};
    const double p2[3] = {c1 * r2 + m->d2 * s1, s1 * r2 - m->d2 * c1, m->a2 * t.s2 + m->d1};
    /* frame 3, the tool: frame 2 Rz(q3) Tz(d3) Tx(a3), written as rrr_fk writes it */
    double p3[3], R3[3][3];
    (void)rrr_fk(m, q, p3, R3);
    set_frame(T[0], R0, p0);
    set_frame(T[1], R1, p1);
    set_frame(T[2], R2, p2);
    set_frame(T[3], (const double(*)[3])R3, p3);
    return RRR_OK;
}

rrr_status rrr_jacobian(const rrr_model *m, const double q[3], double J[3][3])
{
    if (m == NULL || q == NULL || J == NULL || !rrr_finite_n(q, 3) || !rrr_kin_ok(m)) {
        return RRR_BAD_INPUT;
    }
    const double s1 = sin(q[0]), c1 = cos(q[0]);
    const rrr_trig t = rrr_trig_of(q);
    const double e = m->d2 + m->d3;
    const double r = m->a2 * t.c2 + m->a3 * t.c23;
    const double dr2 = -(m->a2 * t.s2 + m->a3 * t.s23); /* d r / d q2 */
    const double dr3 = -m->a3 * t.s23;                  /* d r / d q3 */
    J[0][0] = -s1 * r + e * c1;
    J[1][0] = c1 * r + e * s1;
    J[2][0] = 0.0;
    J[0][1] = c1 * dr2;
    J[1][1] = s1 * dr2;
    J[2][1] = r;
    J[0][2] = c1 * dr3;
    J[1][2] = s1 * dr3;
    J[2][2] = m->a3 * t.c23;
    return RRR_OK;
}

/* Tip velocity and acceleration by differentiating eq 5 twice (qdd may be zero for Jd qd). */
static void tip_motion(const rrr_model *m, const double q[3], const double qd[3],
                       const double qdd[3], double xd[3], double xdd[3])
{
    const double s1 = sin(q[0]), c1 = cos(q[0]);
    const rrr_trig t = rrr_trig_of(q);
    const double a2 = m->a2, a3 = m->a3, e = m->d2 + m->d3;
    const double qd23 = qd[1] + qd[2], qdd23 = qdd[1] + qdd[2];
    const double r = a2 * t.c2 + a3 * t.c23;
    const double rd = -(a2 * t.s2 * qd[1] + a3 * t.s23 * qd23);
    const double zd = a2 * t.c2 * qd[1] + a3 * t.c23 * qd23;
    const double rdd = -(a2 * t.c2 * qd[1] * qd[1] + a3 * t.c23 * qd23 * qd23) -
                       (a2 * t.s2 * qdd[1] + a3 * t.s23 * qdd23);
    const double zdd = -(a2 * t.s2 * qd[1] * qd[1] + a3 * t.s23 * qd23 * qd23) +
                       (a2 * t.c2 * qdd[1] + a3 * t.c23 * qdd23);
    const double w = qd[0], wd = qdd[0];
    xd[0] = -s1 * w * r + c1 * rd + e * c1 * w;
    xd[1] = c1 * w * r + s1 * rd + e * s1 * w;
    xd[2] = zd;
    xdd[0] = -c1 * w * w * r - s1 * wd * r - 2.0 * s1 * w * rd + c1 * rdd - e * s1 * w * w +
             e * c1 * wd;
    xdd[1] = -s1 * w * w * r + c1 * wd * r + 2.0 * c1 * w * rd + s1 * rdd + e * c1 * w * w +
             e * s1 * wd;
    xdd[2] = zdd;
}

rrr_status rrr_tip_motion(const rrr_model *m, const double q[3], const double qd[3],
                          const double qdd[3], double xd[3], double xdd[3])
{
    if (m == NULL || q == NULL || qd == NULL || qdd == NULL || !rrr_kin_ok(m) ||
        !rrr_finite_n(q, 3) || !rrr_finite_n(qd, 3) || !rrr_finite_n(qdd, 3)) {
        return RRR_BAD_INPUT;
    }
    double v[3], a[3];
    tip_motion(m, q, qd, qdd, v, a);
    if (!rrr_finite_n(v, 3) || !rrr_finite_n(a, 3)) {
        return RRR_NUMERIC;
    }
    if (xd != NULL) {
        memcpy(xd, v, sizeof v);
    }
    if (xdd != NULL) {
        memcpy(xdd, a, sizeof a);
    }
    return RRR_OK;
}

/* Solve J y = b by the adjugate; returns 0 when |det J| is below the singularity threshold. */
static int solve3(const double J[3][3], const double b[3], double thresh, double y[3])
{
    const double c00 = J[1][1] * J[2][2] - J[1][2] * J[2][1];
    const double c01 = J[1][2] * J[2][0] - J[1][0] * J[2][2];
    const double c02 = J[1][0] * J[2][1] - J[1][1] * J[2][0];
    const double det = J[0][0] * c00 + J[0][1] * c01 + J[0][2] * c02;
    if (!(fabs(det) > thresh)) {
        return 0;
    }
    const double inv[3][3] = {
        {c00, J[0][2] * J[2][1] - J[0][1] * J[2][2], J[0][1] * J[1][2] - J[0][2] * J[1][1]},
        {c01, J[0][0] * J[2][2] - J[0][2] * J[2][0], J[0][2] * J[1][0] - J[0][0] * J[1][2]},
        {c02, J[0][1] * J[2][0] - J[0][0] * J[2][1], J[0][0] * J[1][1] - J[0][1] * J[1][0]},
    };
    for (int i = 0; i < 3; ++i) {
        y[i] = (inv[i][0] * b[0] + inv[i][1] * b[1] + inv[i][2] * b[2]) / det;
    }
    return 1;
}

rrr_status rrr_joint_motion(const rrr_model *m, const double q[3], const double xd[3],
                            const double xdd[3], double qd[3], double qdd[3])
{
    if (m == NULL || q == NULL || xd == NULL || xdd == NULL || qd == NULL || qdd == NULL ||
        !rrr_kin_ok(m) || !rrr_finite_n(q, 3) || !rrr_finite_n(xd, 3) || !rrr_finite_n(xdd, 3)) {
        return RRR_BAD_INPUT;
    }
    double J[3][3];
    (void)rrr_jacobian(m, q, J);
    const double L = m->a2 + m->a3;
    const double thresh = 1e-12 * L * L * L;
    double v[3], a[3], bias[3], unused[3];
    const double zero[3] = {0.0, 0.0, 0.0};
    if (!solve3((const double(*)[3])J, xd, thresh, v)) {
        return RRR_SINGULAR;
    }
    tip_motion(m, q, v, zero, unused, bias); /* bias = Jd qd */
    const double rhs[3] = {xdd[0] - bias[0], xdd[1] - bias[1], xdd[2] - bias[2]};
    (void)solve3((const double(*)[3])J, rhs, thresh, a);
    if (!rrr_finite_n(v, 3) || !rrr_finite_n(a, 3)) {
        return RRR_NUMERIC;
    }
    memcpy(qd, v, sizeof v);
    memcpy(qdd, a, sizeof a);
    return RRR_OK;
}

/* An angle in [-2 pi, 2 pi] mapped to (-pi, pi]. */
static double wrap_pi(double a)
{
    if (a > RRR_PI) {
        return a - 2.0 * RRR_PI;
    }
    if (a <= -RRR_PI) {
        return a + 2.0 * RRR_PI;
    }
    return a;
}

/*
 * Everything the four branches of one target share. With r = +/-|r| the planar reach and
 * e = d2 + d3, eq 5 says (x, y) is (r, -e) turned by q1, (r, z - d1) is (A, B) turned by q2 with
 * A = a2 + a3 c3, B = a3 s3. So q1 = atan2(y, x) + atan2(e, r), q2 = atan2(z - d1, r) -
 * atan2(B, A), q3 = atan2(s3, c3), and the back shoulder and the other elbow follow from the
 * front/down angles by atan2(y, -x) = copysign(pi, y) - atan2(y, x) and atan2(-y, x) =
 * -atan2(y, x): five atan2 calls serve all four branches.
 */
typedef struct ik_geom {
    double rabs;      /* |r| = sqrt(x^2 + y^2 - e^2) */
    double s3abs;     /* |sin q3| */
    double psi;       /* atan2(y, x) */
    double gamma_f;   /* atan2(e, |r|) */
    double gamma_b;   /* atan2(e, -|r|) */
    double phi_f;     /* atan2(z - d1, |r|) */
    double phi_b;     /* atan2(z - d1, -|r|) */
    double beta_down; /* atan2(a3 |s3|, a2 + a3 c3) */
    double q3_down;   /* atan2(|s3|, c3) */
} ik_geom;

static rrr_status ik_geometry(const rrr_model *m, const double x[3], ik_geom *g)
{
    if (m == NULL || x == NULL || !rrr_kin_ok(m) || !rrr_finite_n(x, 3)) {
        return RRR_BAD_INPUT;
    }
    const double a2 = m->a2, a3 = m->a3, e = m->d2 + m->d3;
    const double L = a2 + a3 + fabs(e);
    double rho2 = x[0] * x[0] + x[1] * x[1] - e * e;
    if (rho2 < 0.0) {
        if (rho2 < -RRR_IK_BOUNDARY_TOL * L * L) {
            return RRR_UNREACHABLE; /* inside the shoulder cylinder */
        }
        rho2 = 0.0;
    }
    const double pwv = x[2] - m->d1;
    double c3 = (rho2 + pwv * pwv - a2 * a2 - a3 * a3) / (2.0 * a2 * a3);
    if (fabs(c3) > 1.0) {
        if (fabs(c3) > 1.0 + RRR_IK_BOUNDARY_TOL) {
            return RRR_UNREACHABLE; /* beyond the outer or inside the inner sphere */
        }
        c3 = c3 > 0.0 ? 1.0 : -1.0;
    }
    g->rabs = sqrt(rho2);
    g->s3abs = sqrt(fmax(0.0, 1.0 - c3 * c3));
    g->psi = atan2(x[1], x[0]);
    g->gamma_f = atan2(e, g->rabs);
    g->gamma_b = copysign(RRR_PI, e) - g->gamma_f;
    g->phi_f = atan2(pwv, g->rabs);
    g->phi_b = copysign(RRR_PI, pwv) - g->phi_f;
    g->beta_down = atan2(a3 * g->s3abs, a2 + a3 * c3);
    g->q3_down = atan2(g->s3abs, c3);
    return RRR_OK;
}

static void ik_solve_branch(const ik_geom *g, rrr_shoulder shoulder, rrr_elbow elbow,
                            double q[3])
{
    const int front = shoulder == RRR_SHOULDER_FRONT, down = elbow == RRR_ELBOW_DOWN;
    q[0] = wrap_pi(g->psi + (front ? g->gamma_f : g->gamma_b));
    q[1] = wrap_pi((front ? g->phi_f : g->phi_b) - (down ? g->beta_down : -g->beta_down));
    q[2] = wrap_pi(down ? g->q3_down : -g->q3_down);
}

rrr_status rrr_ik_branch(const rrr_model *m, const double x[3], rrr_shoulder shoulder,
                         rrr_elbow elbow, double q[3])
{
    if (q == NULL || (shoulder != RRR_SHOULDER_FRONT && shoulder != RRR_SHOULDER_BACK) ||
        (elbow != RRR_ELBOW_UP && elbow != RRR_ELBOW_DOWN)) {
        return RRR_BAD_INPUT;
    }
    ik_geom g;
    const rrr_status st = ik_geometry(m, x, &g);
    if (st != RRR_OK) {
        return st;
    }
    ik_solve_branch(&g, shoulder, elbow, q);
    return RRR_OK;
}

rrr_status rrr_ik(const rrr_model *m, const double x[3], rrr_ik_set *sol)
{
    if (sol == NULL) {
        return RRR_BAD_INPUT;
    }
    ik_geom g;
    const rrr_status st = ik_geometry(m, x, &g);
    if (st != RRR_OK) {
        return st;
    }
    rrr_ik_set out;
    memset(&out, 0, sizeof out);
    /* branches that coincide (r = 0 or sin q3 = 0) are returned once */
    const int n_sh = g.rabs > 0.0 ? 2 : 1;
    const int n_el = g.s3abs > 0.0 ? 2 : 1;
    for (int s = 0; s < n_sh; ++s) {
        for (int k = 0; k < n_el; ++k) {
            ik_solve_branch(&g, (rrr_shoulder)s, (rrr_elbow)k, out.q[out.n]);
            out.branch[out.n] = s * 2 + k;
            out.n++;
        }
    }
    *sol = out;
    return RRR_OK;
}

rrr_status rrr_ik_nearest(const rrr_model *m, const double x[3], const double q_prev[3],
                          double q[3], int *branch)
{
    if (q_prev == NULL || q == NULL || !rrr_finite_n(q_prev, 3) ||
        fabs(q_prev[0]) > RRR_Q_UNWRAP_MAX || fabs(q_prev[1]) > RRR_Q_UNWRAP_MAX ||
        fabs(q_prev[2]) > RRR_Q_UNWRAP_MAX) {
        return RRR_BAD_INPUT;
    }
    rrr_ik_set set;
    const rrr_status st = rrr_ik(m, x, &set);
    if (st != RRR_OK) {
        return st;
    }
    double best[3] = {0.0, 0.0, 0.0};
    double best_d = (double)INFINITY;
    int best_b = 0;
    for (int i = 0; i < set.n; ++i) {
        double cand[3], d = 0.0;
        for (int j = 0; j < 3; ++j) {
            /* unwrap by whole turns towards q_prev (joints turn without limit) */
            const double turns = nearbyint((q_prev[j] - set.q[i][j]) / (2.0 * RRR_PI));
            cand[j] = set.q[i][j] + 2.0 * RRR_PI * turns;
            d += (cand[j] - q_prev[j]) * (cand[j] - q_prev[j]);
        }
        if (d < best_d) {
            best_d = d;
            memcpy(best, cand, sizeof best);
            best_b = set.branch[i];
        }
    }
    /* a joint left undetermined at a singular target keeps its previous value */
    const double e = m->d2 + m->d3;
    if (x[0] == 0.0 && x[1] == 0.0 && e == 0.0) {
        best[0] = q_prev[0];
    }
    if (!rrr_finite_n(best, 3)) {
        return RRR_NUMERIC;
    }
    memcpy(q, best, sizeof best);
    if (branch != NULL) {
        *branch = best_b;
    }
    return RRR_OK;
}

rrr_status rrr_singularity_classify(const rrr_model *m, const double q[3], double tol,
                                    rrr_singularity *s)
{
    if (m == NULL || q == NULL || s == NULL || !rrr_kin_ok(m) || !rrr_finite_n(q, 3) ||
        !isfinite(tol) || tol < 0.0) {
        return RRR_BAD_INPUT;
    }
    const rrr_trig t = rrr_trig_of(q);
    const double r = m->a2 * t.c2 + m->a3 * t.c23;
    rrr_singularity out;
    out.flags = 0u;
    out.elbow_margin = fabs(t.s3);
    out.shoulder_margin = fabs(r);
    out.det_jacobian = -m->a2 * m->a3 * t.s3 * r;
    if (out.elbow_margin <= tol) {
        out.flags |= t.c3 > 0.0 ? RRR_SING_ELBOW_STRETCHED : RRR_SING_ELBOW_FOLDED;
    }
    if (out.shoulder_margin <= tol * (m->a2 + m->a3)) {
        out.flags |= RRR_SING_SHOULDER;
    }
    *s = out;
    return RRR_OK;
}

rrr_status rrr_workspace_margin(const rrr_model *m, const double x[3], double *margin,
                                unsigned *flags)
{
    if (m == NULL || x == NULL || margin == NULL || !rrr_kin_ok(m) || !rrr_finite_n(x, 3)) {
        return RRR_BAD_INPUT;
    }
    const double e = fabs(m->d2 + m->d3);
    const double rxy = hypot(x[0], x[1]);
    /* r = sqrt(rxy^2 - e^2), written so that it cannot overflow for any finite target */
    const double r = rxy > e ? rxy * sqrt((1.0 - e / rxy) * (1.0 + e / rxy)) : 0.0;
    const double dist = hypot(r, x[2] - m->d1); /* wrist distance from the shoulder joint */
    double mg = m->a2 + m->a3 - dist;
    mg = fmin(mg, dist - fabs(m->a2 - m->a3));
    mg = fmin(mg, rxy - e);
    if (!isfinite(mg)) {
        return RRR_NUMERIC; /* a target within a factor 2 of the largest double */
    }
    *margin = mg;
    if (flags != NULL) {
        *flags = mg < 0.0 ? RRR_SING_OUT_OF_REACH : 0u;
    }
    return RRR_OK;
}
