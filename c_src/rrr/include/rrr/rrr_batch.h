/**
 * @file rrr_batch.h
 * @brief Calls over many states at once (n rows of 3), with kernels vectorised over the states
 *        (AVX2, AVX-512) chosen at run time from the CPU's features, and the portable scalar
 *        path kept and selectable for bit-exact comparisons.
 *
 * The vector kernels compute the same closed form as the scalar calls (the same generated code,
 * compiled for 4 or 8 states per instruction, with glibc's vector sin and cos from libmvec), so
 * their results are not bit-identical to the scalar path: they differ by rounding, within 1e-13
 * absolute for the default robot (torques of up to about 50 N m, regressor entries, tip
 * positions in m, accelerations; tests/c/test_batch.c checks each call over random states,
 * multi-turn angles included; IK joint angles in rad). A row the scalar call would refuse
 * (non-finite input, an invalid model) is handed to the scalar call, so statuses are the scalar
 * path's. The vector kernels exist in librrr built with GCC for x86-64 Linux (glibc); elsewhere
 * only RRR_SIMD_SCALAR is available and RRR_SIMD_AUTO means it.
 */
#ifndef RRR_BATCH_H
#define RRR_BATCH_H

#ifdef __cplusplus
extern "C" {
#endif

#include <stddef.h>

#include "rrr_kinematics.h"
#include "rrr_model.h"

/** @brief Which kernels a batch call uses. */
typedef enum rrr_simd {
    RRR_SIMD_AUTO = 0,   ///< the widest available here (rrr_simd_best)
    RRR_SIMD_SCALAR = 1, ///< the scalar calls row by row: bit for bit the one-state calls
    RRR_SIMD_AVX2 = 2,   ///< 4 states per vector (AVX2 and FMA)
    RRR_SIMD_AVX512 = 3  ///< 8 states per vector (AVX-512 F and DQ)
} rrr_simd;

/** @brief 1 when this librrr has the kernels of `path` and this CPU can run them (AUTO and
 *         SCALAR: always 1), else 0. */
RRR_API int rrr_simd_available(rrr_simd path);

/** @brief The widest path available here: RRR_SIMD_AVX512, RRR_SIMD_AVX2 or RRR_SIMD_SCALAR. */
RRR_API rrr_simd rrr_simd_best(void);

/** @brief A static name of a path: "auto", "scalar", "avx2", "avx512"; "?" for other values. */
RRR_API const char *rrr_simd_name(rrr_simd path);

/**
 * @brief rrr_inverse_dynamics of n states: row k of tau = R(q_k, qd_k, qdd_k) p.
 * @param[in]  n    number of states (0: nothing happens, RRR_OK)
 * @param[in]  q    n rows of 3 joint positions
 * @param[in]  qd   n rows of 3 joint velocities
 * @param[in]  qdd  n rows of 3 joint accelerations
 * @param[out] tau  n rows of 3
 * @param[in]  path the kernels (RRR_SIMD_AUTO: the best available)
 * @param[out] done if not NULL, the rows written (n on RRR_OK; the first row whose scalar call
 *                  fails otherwise: the rows before it are valid, the others unspecified)
 * @return RRR_OK; RRR_BAD_INPUT (NULL with n > 0, a path that is not available here: see
 *         rrr_simd_available); otherwise the status rrr_inverse_dynamics gives row *done.
 */
RRR_API rrr_status rrr_inverse_dynamics_batch(const rrr_model *m, size_t n, const double q[],
                                              const double qd[], const double qdd[],
                                              double tau[], rrr_simd path, size_t *done);

/**
 * @brief rrr_regressor of n states: row k of Y is R(q_k, qd_k, qdd_k), 3 x RRR_NP row-major.
 * @param[in]  n    number of states (0: nothing happens, RRR_OK)
 * @param[in]  q    n rows of 3 joint positions
 * @param[in]  qd   n rows of 3 joint velocities
 * @param[in]  qdd  n rows of 3 joint accelerations
 * @param[out] Y    n blocks of 3 x RRR_NP (3 * RRR_NP numbers each)
 * @param[in]  path the kernels (RRR_SIMD_AUTO: the best available)
 * @param[out] done if not NULL, the rows written (n on RRR_OK; the first row whose scalar call
 *                  fails otherwise: the rows before it are valid, the others unspecified)
 * @return RRR_OK; RRR_BAD_INPUT (NULL with n > 0, a path that is not available here); otherwise
 *         the status rrr_regressor gives row *done.
 */
RRR_API rrr_status rrr_regressor_batch(const rrr_model *m, size_t n, const double q[],
                                       const double qd[], const double qdd[], double Y[],
                                       rrr_simd path, size_t *done);

/**
 * @brief rrr_fk of n states: tip positions, and if R is not NULL the tool orientations.
 * @param[in]  n    number of states (0: nothing happens, RRR_OK)
 * @param[in]  q    n rows of 3
 * @param[out] x    n rows of 3 (m)
 * @param[out] R    NULL, or n row-major 3 x 3 rotations (9 numbers each)
 * @param[in]  path the kernels (RRR_SIMD_AUTO: the best available)
 * @param[out] done if not NULL, the rows written (n on RRR_OK; the first row whose scalar call
 *                  fails otherwise: the rows before it are valid, the others unspecified)
 * @return RRR_OK; RRR_BAD_INPUT (NULL with n > 0, a path that is not available here); otherwise
 *         the status rrr_fk gives row *done.
 */
RRR_API rrr_status rrr_fk_batch(const rrr_model *m, size_t n, const double q[], double x[],
                                double R[], rrr_simd path, size_t *done);

/**
 * @brief rrr_forward_dynamics of n states: row k of qdd = D(q_k)^-1 (tau_k - c - h).
 *
 * The vector kernels factorise D by the same 3 x 3 Cholesky steps without branches; a row whose
 * D is not positive definite, or with a non-finite input or result, is the scalar call's.
 * @param[in]  n    number of states (0: nothing happens, RRR_OK)
 * @param[in]  q    n rows of 3 joint positions
 * @param[in]  qd   n rows of 3 joint velocities
 * @param[in]  tau  n rows of 3 motor torques
 * @param[out] qdd  n rows of 3
 * @param[in]  path the kernels (RRR_SIMD_AUTO: the best available)
 * @param[out] done if not NULL, the rows written (n on RRR_OK; the first row whose scalar call
 *                  fails otherwise: the rows before it are valid, the others unspecified)
 * @return RRR_OK; RRR_BAD_INPUT (NULL with n > 0, a path that is not available here); otherwise
 *         the status rrr_forward_dynamics gives row *done.
 */
RRR_API rrr_status rrr_forward_dynamics_batch(const rrr_model *m, size_t n, const double q[],
                                              const double qd[], const double tau[],
                                              double qdd[], rrr_simd path, size_t *done);

/**
 * @brief rrr_ik_branch of n targets on one posture branch, with a status per row.
 *
 * Unlike the other batch calls it does not stop at a failing row: every row is solved, so that
 * a batch with unreachable targets (a workspace sweep) gives the solutions of the others. The
 * vector kernels decide reachability with the scalar call's operations (the same roundings:
 * no contraction into FMA), so the per-row statuses are the scalar path's on every path; their
 * angles differ from it by the rounding of libmvec's atan2 (within 1e-13 rad; a row whose angle
 * falls within 1e-12 rad of the (-pi, pi] wrap, or is not finite, is the scalar call's).
 * @param[in]  n        number of targets (0: nothing happens, RRR_OK)
 * @param[in]  x        n rows of 3 (m)
 * @param[in]  shoulder RRR_SHOULDER_FRONT or RRR_SHOULDER_BACK
 * @param[in]  elbow    RRR_ELBOW_UP or RRR_ELBOW_DOWN
 * @param[out] q        n rows of 3 (rad, each in (-pi, pi]); a row that fails is NaN (never
 *                      without its status: see status and done)
 * @param[out] status   NULL, or n statuses: what rrr_ik_branch gives each row (RRR_OK,
 *                      RRR_BAD_INPUT for a non-finite target or a model it refuses,
 *                      RRR_UNREACHABLE)
 * @param[in]  path     the kernels (RRR_SIMD_AUTO: the best available)
 * @param[out] done     if not NULL, the first row whose status is not RRR_OK (n when every row
 *                      is): the rows before it are valid, as for the other batch calls
 * @return RRR_BAD_INPUT with nothing written (NULL with n > 0, a posture that is not one of the
 *         enums, a path that is not available here); otherwise RRR_OK when every row is solved,
 *         else the status of row *done.
 */
RRR_API rrr_status rrr_ik_batch(const rrr_model *m, size_t n, const double x[],
                                rrr_shoulder shoulder, rrr_elbow elbow, double q[],
                                rrr_status status[], rrr_simd path, size_t *done);

#ifdef __cplusplus
}
#endif
#endif /* RRR_BATCH_H */
