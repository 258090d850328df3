/* The vector kernels of rrr_batch.h, compiled once per instruction set (c_src/rrr/CMakeLists.txt:
 * -mavx2 -mfma, or -mavx512f -mavx512dq -mfma, with -fopenmp-simd -fno-builtin-sin
 * -fno-builtin-cos) with RRR_SIMD_ISA its name. The generated closed form is included here under
 * other names, so that GCC inlines it into a loop over the states that it vectorises; sin and
 * cos are declared with simd clones, which glibc's libmvec provides (_ZGVdN4v_sin, ...). No
 * allocation, no I/O, no globals. */
#include <math.h>
#include <stddef.h>

#include "rrr_simd.h"

/* the generated code, under names of this file's own (it is also librrr's scalar code) */
#define RRR_SIMD_CAT2(a, b) a##_##b
#define RRR_SIMD_CAT(a, b) RRR_SIMD_CAT2(a, b)
#define rrr_gen_bias RRR_SIMD_CAT(rrr_simd_gen_bias, RRR_SIMD_ISA)
#define rrr_gen_coriolis RRR_SIMD_CAT(rrr_simd_gen_coriolis, RRR_SIMD_ISA)
#define rrr_gen_gravity RRR_SIMD_CAT(rrr_simd_gen_gravity, RRR_SIMD_ISA)
#define rrr_gen_inverse_dynamics RRR_SIMD_CAT(rrr_simd_gen_inverse_dynamics, RRR_SIMD_ISA)
#define rrr_gen_mass_matrix RRR_SIMD_CAT(rrr_simd_gen_mass_matrix, RRR_SIMD_ISA)
#define rrr_gen_potential RRR_SIMD_CAT(rrr_simd_gen_potential, RRR_SIMD_ISA)
#define rrr_gen_regressor RRR_SIMD_CAT(rrr_simd_gen_regressor, RRR_SIMD_ISA)
#define rrr_gen_tau_jacobian RRR_SIMD_CAT(rrr_simd_gen_tau_jacobian, RRR_SIMD_ISA)
#define rrr_gen_tau_param_jacobian RRR_SIMD_CAT(rrr_simd_gen_tau_param_jacobian, RRR_SIMD_ISA)
#include "rrr_dynamics_gen.c"

/* glibc's vector variants (libmvec): "notinbranch" clones of sin and cos */
__attribute__((simd("notinbranch"))) double sin(double);
__attribute__((simd("notinbranch"))) double cos(double);

/* The finiteness probe of the kernels: the sum of a[i] * 0.0, which is 0 when every a[i] is
 * finite and NaN when one is not (Inf * 0 and NaN * 0 are NaN; no sum of zeros overflows).
 * Summed over a kernel's inputs and outputs in its vector loop (a reduction), it tells
 * rrr_batch.c in one number whether a row needs the scalar call, without a second pass over
 * the rows. */
static inline __attribute__((always_inline)) double probe(const double *a, int len)
{
    double z = 0.0;
    for (int i = 0; i < len; ++i) {
        z += a[i] * 0.0;
    }
    return z;
}

/* probe of a[0 .. len), a contiguous array: for the outputs of many numbers a row (R, Y), whose
 * probe in the kernel's loop would be a gather per number */
static double probe_span(const double *a, size_t len)
{
    double z = 0.0;
#pragma omp simd reduction(+ : z)
    for (size_t i = 0; i < len; ++i) {
        z += a[i] * 0.0;
    }
    return z;
}

__attribute__((flatten)) /* the generated call inlined, so that the loop vectorises */
int RRR_SIMD_CAT(rrr_simd_inverse_dynamics, RRR_SIMD_ISA)(const rrr_model *mp, size_t n,
                                                         const double *restrict q,
                                                         const double *restrict qd,
                                                         const double *restrict qdd,
                                                         double *restrict tau)
{
    const rrr_model model = *mp; /* a local copy: no store to tau can change it */
    const rrr_model *m = &model;
    double z = 0.0;
#pragma omp simd reduction(+ : z)
    for (size_t k = 0; k < n; ++k) {
        const rrr_trig t = rrr_trig_of(&q[3 * k]); /* inlined: vector sin, cos */
        rrr_gen_inverse_dynamics(m, &t, &qd[3 * k], &qdd[3 * k], &tau[3 * k]);
        z += probe(&q[3 * k], 3) + probe(&qd[3 * k], 3) + probe(&qdd[3 * k], 3) +
             probe(&tau[3 * k], 3);
    }
    return z == 0.0;
}

__attribute__((flatten)) /* the generated call inlined, so that the loop vectorises */
int RRR_SIMD_CAT(rrr_simd_regressor, RRR_SIMD_ISA)(const rrr_model *mp, size_t n,
                                                  const double *restrict q,
                                                  const double *restrict qd,
                                                  const double *restrict qdd,
                                                  double *restrict Y)
{
    const rrr_model model = *mp;
    const rrr_model *m = &model;
    double z = 0.0;
#pragma omp simd reduction(+ : z)
    for (size_t k = 0; k < n; ++k) {
        const rrr_trig t = rrr_trig_of(&q[3 * k]); /* inlined: vector sin, cos */
        rrr_gen_regressor(m, &t, &qd[3 * k], &qdd[3 * k],
                          (double(*)[RRR_NP])(void *)&Y[3 * RRR_NP * k]);
        z += probe(&q[3 * k], 3) + probe(&qd[3 * k], 3) + probe(&qdd[3 * k], 3);
    }
    return z + probe_span(Y, 3 * RRR_NP * n) == 0.0;
}

/* rrr_fk's formulas, written as rrr_kinematics.c writes them: the tip of row k, and the
 * rotation when R is not NULL (one loop each way, so that neither tests R per state) */
static inline __attribute__((always_inline)) void fk_row(const rrr_model *m, const double *q,
                                                        double *x, double *R)
{
    const double e = m->d2 + m->d3;
    const double s1 = sin(q[0]), c1 = cos(q[0]);
    const rrr_trig t = rrr_trig_of(q);
    const double r = m->a2 * t.c2 + m->a3 * t.c23;
    x[0] = c1 * r + e * s1;
    x[1] = s1 * r - e * c1;
    x[2] = m->a2 * t.s2 + m->a3 * t.s23 + m->d1;
    if (R != NULL) {
        R[0] = c1 * t.c23;
        R[1] = -c1 * t.s23;
        R[2] = s1;
        R[3] = s1 * t.c23;
        R[4] = -s1 * t.s23;
        R[5] = -c1;
        R[6] = t.s23;
        R[7] = t.c23;
        R[8] = 0.0;
    }
}

int RRR_SIMD_CAT(rrr_simd_fk, RRR_SIMD_ISA)(const rrr_model *mp, size_t n,
                                           const double *restrict q, double *restrict x,
                                           double *restrict R)
{
    const rrr_model model = *mp;
    const rrr_model *m = &model;
    double z = 0.0;
    if (R == NULL) {
#pragma omp simd reduction(+ : z)
        for (size_t k = 0; k < n; ++k) {
            fk_row(m, &q[3 * k], &x[3 * k], NULL);
            z += probe(&q[3 * k], 3) + probe(&x[3 * k], 3);
        }
        return z == 0.0;
    }
#pragma omp simd reduction(+ : z)
    for (size_t k = 0; k < n; ++k) {
        fk_row(m, &q[3 * k], &x[3 * k], &R[9 * k]);
        z += probe(&q[3 * k], 3) + probe(&x[3 * k], 3);
    }
    return z + probe_span(R, 9 * n) == 0.0;
}

/* rrr_fd_factorize_trig and rrr_fd_solve without their branches: a pivot that is not positive
 * gives a NaN (sqrt) or an Inf (division), which rrr_batch.c hands to the scalar call (sqrt
 * vectorises for -fno-math-errno). Blocks of RRR_SIMD_FD_BLOCK states: D and the bias of a
 * block in a buffer on the stack, then the solves. (A per-state local D in one loop would be a
 * per-lane array of the simd loop, which GCC does not vectorise; a buffer row is 16 numbers, a
 * power of two, because GCC 12 vectorises groups of loads of such sizes or of 3 only.) */
enum { RRR_SIMD_FD_BLOCK = 64 };

typedef struct {
    double D[3][3];
    double bias[3];
    double pad[4];
} rrr_simd_fd_row;

__attribute__((flatten)) /* the two generated calls inlined, so that the loop vectorises */
int RRR_SIMD_CAT(rrr_simd_forward_dynamics, RRR_SIMD_ISA)(const rrr_model *mp, size_t n,
                                                         const double *restrict q,
                                                         const double *restrict qd,
                                                         const double *restrict tau,
                                                         double *restrict qdd)
{
    const rrr_model model = *mp;
    const rrr_model *m = &model;
    rrr_simd_fd_row buf[RRR_SIMD_FD_BLOCK];
    double z = 0.0;
    for (size_t base = 0; base < n; base += RRR_SIMD_FD_BLOCK) {
        const size_t nb = n - base < RRR_SIMD_FD_BLOCK ? n - base : RRR_SIMD_FD_BLOCK;
        const double *restrict qb = &q[3 * base];
        const double *restrict qdb = &qd[3 * base];
#pragma omp simd reduction(+ : z)
        for (size_t k = 0; k < nb; ++k) {
            const rrr_trig t = rrr_trig_of(&qb[3 * k]); /* inlined: vector sin, cos */
            rrr_gen_bias(m, &t, &qdb[3 * k], buf[k].bias);
            rrr_gen_mass_matrix(m, &t, buf[k].D);
            buf[k].pad[0] = buf[k].pad[1] = buf[k].pad[2] = buf[k].pad[3] = 0.0;
            z += probe(&qb[3 * k], 3) + probe(&qdb[3 * k], 3);
        }
        const double *restrict taub = &tau[3 * base];
        double *restrict out = &qdd[3 * base];
#pragma omp simd reduction(+ : z)
        for (size_t k = 0; k < nb; ++k) {
            const rrr_simd_fd_row *r = &buf[k];
            const double(*D)[3] = r->D;
            const double *bias = r->bias;
            const double l00 = sqrt(D[0][0]);
            const double l10 = D[1][0] / l00;
            const double l20 = D[2][0] / l00;
            const double l11 = sqrt(D[1][1] - l10 * l10);
            const double l21 = (D[2][1] - l20 * l10) / l11;
            const double l22 = sqrt(D[2][2] - l20 * l20 - l21 * l21);
            const double y0 = (taub[3 * k] - bias[0]) / l00;
            const double y1 = (taub[3 * k + 1] - bias[1] - l10 * y0) / l11;
            const double y2 = (taub[3 * k + 2] - bias[2] - l20 * y0 - l21 * y1) / l22;
            const double x2 = y2 / l22;
            const double x1 = (y1 - l21 * x2) / l11;
            const double x0 = (y0 - l10 * x1 - l20 * x2) / l00;
            out[3 * k + 2] = x2;
            out[3 * k + 1] = x1;
            out[3 * k] = x0;
            z += probe(&taub[3 * k], 3) + (x0 * 0.0 + x1 * 0.0 + x2 * 0.0);
        }
    }
    return z == 0.0;
}

/* The IK kernels compiled with -fno-trapping-math: GCC speculates no floating-point operation
 * that might trap (the products of a snapped c3, the turn of a wrapped angle), so with trapping
 * math it would not if-convert the loop, which then does not vectorise. The option changes no
 * result (round to nearest, no signalling NaNs here), only which operations may be moved. */
#pragma GCC push_options
#pragma GCC optimize("no-trapping-math")

/* glibc's vector atan2 (libmvec: _ZGVdN4vv_atan2, _ZGVeN8vv_atan2) */
__attribute__((simd("notinbranch"))) double atan2(double, double);

/* wrap_pi of rrr_kinematics.c, and NaN (the scalar call's row) for an angle within 1e-12 rad
 * of +-pi, where the vector atan2's rounding could put it on the other side of the wrap. The
 * turn is added whatever the side (a - 2 pi under a condition is not if-converted, as it may
 * trap): a + 0.0 is a but for a = -0.0, which gives +0.0. */
static inline __attribute__((always_inline)) double ik_wrap(double a)
{
    const double turn = a > RRR_PI ? -2.0 * RRR_PI : (a <= -RRR_PI ? 2.0 * RRR_PI : 0.0);
    return fabs(fabs(a) - RRR_PI) < 1e-12 ? (double)NAN : a + turn;
}

/* ik_geometry and ik_solve_branch of rrr_kinematics.c without branches, on one posture: the
 * same operations in the same order (librrr is compiled as ISO C, where GCC contracts nothing
 * into FMA), so that rho2, c3 and the reachability are the scalar call's bit for bit and only
 * atan2 rounds differently. An unreachable target gives NaN. */
static inline __attribute__((always_inline)) int ik_rows(const rrr_model *mp, size_t n,
                                                        const double *restrict x,
                                                        double *restrict q, const int front,
                                                        const int down)
{
    const rrr_model model = *mp;
    const double a2 = model.a2, a3 = model.a3, e = model.d2 + model.d3, d1 = model.d1;
    const double L = a2 + a3 + fabs(e);
    const double rho2_min = -RRR_IK_BOUNDARY_TOL * L * L;
    const double c3_max = 1.0 + RRR_IK_BOUNDARY_TOL;
    const double two_a2a3 = 2.0 * a2 * a3;
    const double a2sq = a2 * a2, a3sq = a3 * a3;
    const double gamma_b0 = copysign(RRR_PI, e);
    const double nan = (double)NAN;
    double z = 0.0;
#pragma omp simd reduction(+ : z)
    for (size_t k = 0; k < n; ++k) {
        const double x0 = x[3 * k], x1 = x[3 * k + 1], x2 = x[3 * k + 2];
        double rho2 = x0 * x0 + x1 * x1 - e * e;
        const int out_cyl = rho2 < rho2_min;
        rho2 = rho2 < 0.0 ? 0.0 : rho2;
        const double pwv = x2 - d1;
        double c3 = (rho2 + pwv * pwv - a2sq - a3sq) / two_a2a3;
        const int out_sph = fabs(c3) > c3_max;
        /* c3 snapped onto +-1 beyond them, as ik_geometry does: 1 - c3^2 >= 0 for
         * |c3| <= 1, so the scalar fmax(0, 1 - c3^2) is that, and 0 for a snapped c3; a3 c3
         * of a snapped c3 is +-a3 exactly */
        const int snap = fabs(c3) > 1.0;
        const double s3sq = 1.0 - c3 * c3, a3c3 = a3 * c3;
        const double s3abs = sqrt(snap ? 0.0 : s3sq);
        const double a3c3s = snap ? copysign(a3, c3) : a3c3;
        c3 = snap ? copysign(1.0, c3) : c3;
        const double rabs = sqrt(rho2);
        const double psi = atan2(x1, x0);
        const double gamma_f = atan2(e, rabs);
        const double phi_f = atan2(pwv, rabs);
        const double beta_down = atan2(a3 * s3abs, a2 + a3c3s);
        const double q3_down = atan2(s3abs, c3);
        const double gamma = front ? gamma_f : gamma_b0 - gamma_f;
        const double phi = front ? phi_f : copysign(RRR_PI, pwv) - phi_f;
        const int out = out_cyl | out_sph;
        const double q0 = ik_wrap(psi + gamma);
        const double q1 = ik_wrap(phi - (down ? beta_down : -beta_down));
        const double q2 = ik_wrap(down ? q3_down : -q3_down);
        const double r0 = out ? nan : q0, r1 = out ? nan : q1, r2 = out ? nan : q2;
        q[3 * k] = r0;
        q[3 * k + 1] = r1;
        q[3 * k + 2] = r2;
        z += (x0 * 0.0 + x1 * 0.0 + x2 * 0.0) + (r0 * 0.0 + r1 * 0.0 + r2 * 0.0);
    }
    return z == 0.0;
}

int RRR_SIMD_CAT(rrr_simd_ik, RRR_SIMD_ISA)(const rrr_model *mp, size_t n,
                                           const double *restrict x, rrr_shoulder shoulder,
                                           rrr_elbow elbow, double *restrict q)
{
    /* one loop per posture, the branch choices constants in each */
    const int front = shoulder == RRR_SHOULDER_FRONT, down = elbow == RRR_ELBOW_DOWN;
    if (front && down) {
        return ik_rows(mp, n, x, q, 1, 1);
    }
    if (front) {
        return ik_rows(mp, n, x, q, 1, 0);
    }
    if (down) {
        return ik_rows(mp, n, x, q, 0, 1);
    }
    return ik_rows(mp, n, x, q, 0, 0);
}

#pragma GCC pop_options
