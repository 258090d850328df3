/* Kinematics: FK against eq 5, Jacobian and tip motion against finite differences, IK round
 * trips on every branch over the whole joint range, nearest-branch unwrapping, singularities,
 * bad input. */
#include <string.h>

#include "rrr/rrr.h"
#include "rrr_test.h"

static const double PI = 3.14159265358979323846;

static double wrap(double a)
{
    return a - 2.0 * PI * nearbyint(a / (2.0 * PI));
}

static void test_fk(const rrr_model *m, rrr_rng *rng)
{
    for (int n = 0; n < 1000; ++n) {
        const double q[3] = {rrr_rng_uniform(rng, -PI, PI), rrr_rng_uniform(rng, -PI, PI),
                             rrr_rng_uniform(rng, -PI, PI)};
        double x[3], R[3][3];
        CHECK_STATUS(rrr_fk(m, q, x, R), RRR_OK);
        const double e = m->d2 + m->d3;
        const double rr = m->a3 * cos(q[1] + q[2]) + m->a2 * cos(q[1]);
        CHECK_CLOSE(x[0], cos(q[0]) * rr + e * sin(q[0]), 1e-15);
        CHECK_CLOSE(x[1], sin(q[0]) * rr - e * cos(q[0]), 1e-15);
        CHECK_CLOSE(x[2], m->a3 * sin(q[1] + q[2]) + m->a2 * sin(q[1]) + m->d1, 1e-15);
        /* R is a rotation: R R^T = I */
        for (int i = 0; i < 3; ++i) {
            for (int j = 0; j < 3; ++j) {
                const double d = R[i][0] * R[j][0] + R[i][1] * R[j][1] + R[i][2] * R[j][2];
                CHECK_CLOSE(d, i == j ? 1.0 : 0.0, 1e-14);
            }
        }
        CHECK_CLOSE(R[0][2], sin(q[0]), 1e-15); /* eq 4: o13 = sin q1 */
    }
}

static void test_jacobian_and_motion(const rrr_model *m, rrr_rng *rng)
{
    const double hstep = 1e-6;
    for (int n = 0; n < 200; ++n) {
        double q[3], qd[3], qdd[3];
        for (int i = 0; i < 3; ++i) {
            q[i] = rrr_rng_uniform(rng, -PI, PI);
            qd[i] = rrr_rng_uniform(rng, -2.0, 2.0);
            qdd[i] = rrr_rng_uniform(rng, -5.0, 5.0);
        }
        double J[3][3];
        CHECK_STATUS(rrr_jacobian(m, q, J), RRR_OK);
        for (int j = 0; j < 3; ++j) {
            double qp[3], qm[3], xp[3], xm[3];
            memcpy(qp, q, sizeof qp);
            memcpy(qm, q, sizeof qm);
            qp[j] += hstep;
            qm[j] -= hstep;
            rrr_fk(m, qp, xp, NULL);
            rrr_fk(m, qm, xm, NULL);
            for (int i = 0; i < 3; ++i) {
                CHECK_CLOSE(J[i][j], (xp[i] - xm[i]) / (2.0 * hstep), 1e-8);
            }
        }
        /* tip motion against finite differences of FK along q(t) = q + qd t + qdd t^2 / 2 */
        double xd[3], xdd[3];
        CHECK_STATUS(rrr_tip_motion(m, q, qd, qdd, xd, xdd), RRR_OK);
        const double dt = 1e-4;
        double xs[3][3];
        for (int k = -1; k <= 1; ++k) {
            double qt[3];
            for (int i = 0; i < 3; ++i) {
                qt[i] = q[i] + qd[i] * k * dt + 0.5 * qdd[i] * k * k * dt * dt;
            }
            rrr_fk(m, qt, xs[k + 1], NULL);
        }
        for (int i = 0; i < 3; ++i) {
            CHECK_CLOSE(xd[i], (xs[2][i] - xs[0][i]) / (2.0 * dt), 1e-6);
            CHECK_CLOSE(xdd[i], (xs[2][i] - 2.0 * xs[1][i] + xs[0][i]) / (dt * dt), 1e-4);
        }
        /* joint motion inverts tip motion away from singularities */
        rrr_singularity s;
        rrr_singularity_classify(m, q, 0.0, &s);
        if (s.elbow_margin > 0.1 && s.shoulder_margin > 0.05) {
            double qd2[3], qdd2[3];
            CHECK_STATUS(rrr_joint_motion(m, q, xd, xdd, qd2, qdd2), RRR_OK);
            for (int i = 0; i < 3; ++i) {
                CHECK_CLOSE(qd2[i], qd[i], 1e-9);
                CHECK_CLOSE(qdd2[i], qdd[i], 1e-8);
            }
        }
    }
    /* at a stretched elbow the inverse does not exist */
    const double qs[3] = {0.3, 0.2, 0.0}, v[3] = {0.1, 0.0, 0.0};
    double o1[3] = {7.0, 7.0, 7.0}, o2[3] = {7.0, 7.0, 7.0};
    CHECK_STATUS(rrr_joint_motion(m, qs, v, v, o1, o2), RRR_SINGULAR);
    CHECK(o1[0] == 7.0 && o2[2] == 7.0);
}

static void test_ik_round_trip(const rrr_model *m, rrr_rng *rng)
{
    double worst_fk = 0.0, worst_q = 0.0;
    int recovered = 0, checked = 0;
    for (int n = 0; n < 20000; ++n) {
        const double q[3] = {rrr_rng_uniform(rng, -PI, PI), rrr_rng_uniform(rng, -PI, PI),
                             rrr_rng_uniform(rng, -PI, PI)};
        double x[3];
        rrr_fk(m, q, x, NULL);
        rrr_ik_set set;
        CHECK_STATUS(rrr_ik(m, x, &set), RRR_OK);
        CHECK(set.n >= 1 && set.n <= 4);
        for (int b = 0; b < set.n; ++b) {
            double xb[3];
            rrr_fk(m, set.q[b], xb, NULL);
            for (int i = 0; i < 3; ++i) {
                worst_fk = fmax(worst_fk, fabs(xb[i] - x[i]));
                CHECK(set.q[b][i] > -PI && set.q[b][i] <= PI);
            }
        }
        /* the generating configuration's own branch gives it back */
        rrr_singularity s;
        rrr_singularity_classify(m, q, 0.0, &s);
        const double rr = m->a2 * cos(q[1]) + m->a3 * cos(q[1] + q[2]);
        const rrr_shoulder sh = rr >= 0.0 ? RRR_SHOULDER_FRONT : RRR_SHOULDER_BACK;
        const rrr_elbow el = sin(q[2]) <= 0.0 ? RRR_ELBOW_UP : RRR_ELBOW_DOWN;
        double qb[3];
        CHECK_STATUS(rrr_ik_branch(m, x, sh, el, qb), RRR_OK);
        if (s.elbow_margin > 1e-3 && s.shoulder_margin > 1e-3) {
            checked++;
            double err = 0.0;
            for (int i = 0; i < 3; ++i) {
                err = fmax(err, fabs(wrap(qb[i] - q[i])));
            }
            worst_q = fmax(worst_q, err);
            recovered += err < 1e-10;
        }
    }
    printf("IK: worst |FK(IK(x)) - x| = %.3g m, worst |q_branch - q| = %.3g rad (%d of %d)\n",
           worst_fk, worst_q, recovered, checked);
    CHECK(worst_fk < 1e-12);
    CHECK(worst_q < 1e-10);
    CHECK(recovered == checked);
}

static void test_ik_nearest(const rrr_model *m)
{
    /* a configuration several turns away is followed without a jump */
    const double q[3] = {0.4 + 6.0 * PI, -0.7 - 4.0 * PI, 1.1 + 2.0 * PI};
    double x[3], out[3];
    rrr_fk(m, q, x, NULL);
    const double prev[3] = {q[0] + 0.01, q[1] - 0.02, q[2] + 0.015};
    int branch = -1;
    CHECK_STATUS(rrr_ik_nearest(m, x, prev, out, &branch), RRR_OK);
    for (int i = 0; i < 3; ++i) {
        CHECK_CLOSE(out[i], q[i], 1e-9);
    }
    CHECK(branch == 1); /* front shoulder, elbow down (sin q3 > 0) */
    /* continuity along a path that goes round joint 1 twice */
    double qp[3] = {0.0, 0.3, 1.2};
    double xq[3];
    for (int k = 1; k <= 2000; ++k) {
        const double qt[3] = {4.0 * PI * k / 2000.0, 0.3, 1.2};
        rrr_fk(m, qt, xq, NULL);
        double qn[3];
        CHECK_STATUS(rrr_ik_nearest(m, xq, qp, qn, NULL), RRR_OK);
        CHECK(fabs(qn[0] - qp[0]) < 0.01);
        memcpy(qp, qn, sizeof qp);
    }
    CHECK_CLOSE(qp[0], 4.0 * PI, 1e-9);
}

static void test_singular_and_bad(const rrr_model *m)
{
    rrr_singularity s;
    const double stretched[3] = {0.2, 0.3, 0.0}, folded[3] = {0.2, 0.3, PI};
    CHECK_STATUS(rrr_singularity_classify(m, stretched, 1e-9, &s), RRR_OK);
    CHECK(s.flags == RRR_SING_ELBOW_STRETCHED);
    CHECK_STATUS(rrr_singularity_classify(m, folded, 1e-9, &s), RRR_OK);
    CHECK(s.flags == RRR_SING_ELBOW_FOLDED);
    /* r = a2 c2 + a3 c23 = 0: q2 = pi/2, q3 = 0 puts the tip straight above the shoulder */
    const double up[3] = {0.2, PI / 2.0, 0.5};
    const double q2 = atan2(m->a2 + m->a3 * cos(0.5), m->a3 * sin(0.5)); /* (a2 + a3 c3) c2 = a3 s3 s2 */
    const double on_cyl[3] = {0.2, q2, 0.5};
    CHECK_STATUS(rrr_singularity_classify(m, on_cyl, 1e-9, &s), RRR_OK);
    CHECK((s.flags & RRR_SING_SHOULDER) != 0u);
    CHECK_CLOSE(s.det_jacobian, 0.0, 1e-12);
    CHECK_STATUS(rrr_singularity_classify(m, up, 1e-9, &s), RRR_OK);
    CHECK(s.flags == 0u);
    /* at a stretched elbow the two elbow branches coincide and are returned once */
    double x[3];
    rrr_fk(m, stretched, x, NULL);
    rrr_ik_set set;
    CHECK_STATUS(rrr_ik(m, x, &set), RRR_OK);
    CHECK(set.n == 2);

    /* unreachable targets: too far, inside the inner sphere is impossible here (a2 > a3 but
     * the inner radius is |a2 - a3|), inside the shoulder cylinder, NaN and Inf */
    const double far[3] = {2.0, 0.0, 0.5};
    const double inner[3] = {0.1, -0.02, 0.52};
    const double cyl[3] = {0.01, 0.01, 0.9};
    const double nan_x[3] = {(double)NAN, 0.0, 0.5}, inf_x[3] = {0.3, (double)INFINITY, 0.5};
    double margin = 0.0;
    unsigned flags = 0u;
    CHECK_STATUS(rrr_workspace_margin(m, far, &margin, &flags), RRR_OK);
    CHECK(margin < 0.0 && flags == RRR_SING_OUT_OF_REACH);
    rrr_fk(m, up, x, NULL);
    CHECK_STATUS(rrr_workspace_margin(m, x, &margin, &flags), RRR_OK);
    CHECK(margin > 0.0 && flags == 0u);
    /* far but finite targets: a finite margin (no overflow of rxy^2), or RRR_NUMERIC with the
     * output untouched when even the margin cannot be a finite number */
    const double huge[3] = {1e154, 1e154, 1e154}, edge[3] = {-1.7e308, 1.7e308, 0.0};
    CHECK_STATUS(rrr_workspace_margin(m, huge, &margin, &flags), RRR_OK);
    CHECK(isfinite(margin) && margin < -1e154 && flags == RRR_SING_OUT_OF_REACH);
    margin = 42.0;
    CHECK_STATUS(rrr_workspace_margin(m, edge, &margin, &flags), RRR_NUMERIC);
    CHECK(margin == 42.0);
    const double *bad[] = {far, inner, cyl};
    for (int i = 0; i < 3; ++i) {
        rrr_ik_set keep;
        keep.n = 99;
        double qk[3] = {7.0, 7.0, 7.0};
        CHECK_STATUS(rrr_ik(m, bad[i], &keep), RRR_UNREACHABLE);
        CHECK(keep.n == 99);
        CHECK_STATUS(rrr_ik_nearest(m, bad[i], stretched, qk, NULL), RRR_UNREACHABLE);
        CHECK_STATUS(rrr_ik_branch(m, bad[i], RRR_SHOULDER_FRONT, RRR_ELBOW_UP, qk),
                     RRR_UNREACHABLE);
        CHECK(qk[0] == 7.0 && qk[1] == 7.0 && qk[2] == 7.0);
    }
    double qk[3] = {7.0, 7.0, 7.0};
    rrr_ik_set keep;
    CHECK_STATUS(rrr_ik(m, nan_x, &keep), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_ik(m, inf_x, &keep), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_ik(NULL, far, &keep), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_ik(m, far, NULL), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_fk(m, nan_x, qk, NULL), RRR_BAD_INPUT);
    CHECK(qk[0] == 7.0);
    CHECK_STATUS(rrr_ik_branch(m, up, (rrr_shoulder)5, RRR_ELBOW_UP, qk), RRR_BAD_INPUT);
    const double prev_nan[3] = {0.0, (double)NAN, 0.0};
    rrr_fk(m, up, x, NULL);
    CHECK_STATUS(rrr_ik_nearest(m, x, prev_nan, qk, NULL), RRR_BAD_INPUT);
    /* beyond RRR_Q_UNWRAP_MAX a double cannot hold the unwrapped angle: refused, not wrong */
    const double prev_far[3] = {2.0 * RRR_Q_UNWRAP_MAX, 0.0, 0.0};
    CHECK_STATUS(rrr_ik_nearest(m, x, prev_far, qk, NULL), RRR_BAD_INPUT);
    const double prev_edge[3] = {RRR_Q_UNWRAP_MAX, 0.3, -0.2};
    double q_edge[3], x_edge[3];
    CHECK_STATUS(rrr_ik_nearest(m, x, prev_edge, q_edge, NULL), RRR_OK);
    rrr_fk(m, q_edge, x_edge, NULL);
    CHECK_CLOSE(x_edge[0], x[0], 1e-9);
    CHECK_CLOSE(x_edge[2], x[2], 1e-9);
    CHECK(qk[0] == 7.0);
    CHECK_STATUS(rrr_jacobian(m, nan_x, NULL), RRR_BAD_INPUT);
    rrr_model broken = *m;
    broken.a2 = -0.1;
    CHECK_STATUS(rrr_fk(&broken, up, qk, NULL), RRR_BAD_INPUT);
    CHECK(qk[0] == 7.0);
}

/* out = a b for 4 x 4 transforms */
static void mul44(const double a[4][4], const double b[4][4], double out[4][4])
{
    for (int i = 0; i < 4; ++i) {
        for (int j = 0; j < 4; ++j) {
            out[i][j] = a[i][0] * b[0][j] + a[i][1] * b[1][j] + a[i][2] * b[2][j] +
                        a[i][3] * b[3][j];
        }
    }
}

/* The standard DH transform Rz(theta) Tz(d) Tx(a) Rx(alpha), built as the URDF builds the chain:
 * the joint's rotation about z, then the fixed placement of the next joint. */
static void dh44(double theta, double d, double a, double alpha, double T[4][4])
{
    const double ct = cos(theta), st = sin(theta), ca = cos(alpha), sa = sin(alpha);
    const double rz[4][4] = {{ct, -st, 0, 0}, {st, ct, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
    const double fixed[4][4] = {{1, 0, 0, a}, {0, ca, -sa, 0}, {0, sa, ca, d}, {0, 0, 0, 1}};
    mul44(rz, fixed, T);
}

/* rrr_fk_frames against a generic DH chain (the URDF's joint/placement product) and rrr_fk */
static void test_fk_frames(const rrr_model *m, rrr_rng *rng)
{
    const double d[3] = {m->d1, m->d2, m->d3}, a[3] = {0.0, m->a2, m->a3};
    const double alpha[3] = {PI / 2.0, 0.0, 0.0};
    for (int n = 0; n < 1000; ++n) {
        const double q[3] = {rrr_rng_uniform(rng, -4.0, 4.0), rrr_rng_uniform(rng, -4.0, 4.0),
                             rrr_rng_uniform(rng, -4.0, 4.0)};
        double T[RRR_NFRAMES][4][4];
        memset(T, 0xff, sizeof T); /* NaN everywhere: every entry must be written */
        CHECK_STATUS(rrr_fk_frames(m, q, T), RRR_OK);
        double chain[4][4] = {{1, 0, 0, 0}, {0, 1, 0, 0}, {0, 0, 1, 0}, {0, 0, 0, 1}};
        for (int k = 0; k < RRR_NFRAMES; ++k) {
            if (k > 0) {
                double step[4][4], next[4][4];
                dh44(q[k - 1], d[k - 1], a[k - 1], alpha[k - 1], step);
                mul44((const double(*)[4])chain, (const double(*)[4])step, next);
                memcpy(chain, next, sizeof chain);
            }
            for (int i = 0; i < 4; ++i) {
                for (int j = 0; j < 4; ++j) {
                    CHECK_CLOSE(T[k][i][j], chain[i][j], 1e-15);
                }
            }
            CHECK(T[k][3][0] == 0.0 && T[k][3][1] == 0.0 && T[k][3][2] == 0.0 &&
                  T[k][3][3] == 1.0);
        }
        double x[3], R[3][3];
        CHECK_STATUS(rrr_fk(m, q, x, R), RRR_OK);
        for (int i = 0; i < 3; ++i) {
            CHECK(T[3][i][3] == x[i]); /* the tool is rrr_fk, bit for bit */
            for (int j = 0; j < 3; ++j) {
                CHECK(T[3][i][j] == R[i][j]);
            }
        }
    }
    double T[RRR_NFRAMES][4][4];
    memset(T, 0, sizeof T);
    const double q_nan[3] = {0.1, (double)NAN, 0.3}, q_inf[3] = {(double)INFINITY, 0.0, 0.0};
    const double q_ok[3] = {0.1, 0.2, 0.3};
    CHECK_STATUS(rrr_fk_frames(m, q_nan, T), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_fk_frames(m, q_inf, T), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_fk_frames(NULL, q_ok, T), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_fk_frames(m, NULL, T), RRR_BAD_INPUT);
    CHECK_STATUS(rrr_fk_frames(m, q_ok, NULL), RRR_BAD_INPUT);
    CHECK(T[0][0][0] == 0.0 && T[3][3][3] == 0.0); /* untouched on error */
    rrr_model bad = *m;
    bad.a2 = 0.0;
    CHECK_STATUS(rrr_fk_frames(&bad, q_ok, T), RRR_BAD_INPUT);
}

int main(void)
{
    rrr_model m;
    CHECK_STATUS(rrr_model_default(&m), RRR_OK);
    rrr_rng rng = {0x9E3779B97F4A7C15ULL};
    test_fk(&m, &rng);
    test_jacobian_and_motion(&m, &rng);
    test_ik_round_trip(&m, &rng);
    /* also with a robot whose forearm is longer than the upper arm and a negative offset */
    rrr_model m2 = m;
    m2.a2 = 0.3;
    m2.a3 = 0.55;
    m2.d2 = -0.2;
    m2.d3 = 0.05;
    test_ik_round_trip(&m2, &rng);
    test_fk_frames(&m, &rng);
    test_fk_frames(&m2, &rng);
    test_ik_nearest(&m);
    test_singular_and_bad(&m);
    return rrr_test_report("test_kinematics");
}
