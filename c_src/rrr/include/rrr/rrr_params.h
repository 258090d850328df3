/**
 * @file rrr_params.h
 * @brief The parameter table of rrr_model: every scalar parameter with its name, place, unit,
 *        valid range and description, defined ONCE (RRR_MODEL_PARAMS) and used by librrr's
 *        validation messages and lookup (rrr_param_*), the FMUs' variable rows and XML, the CAN
 *        nodes' --set option and the Python package.
 *
 * Names are those of the FMU variables: "d1", "p[3]", "kt[2]", "f[1,3]" (joint 1, term 3),
 * "u_max". Ranges: every value must be finite and satisfy its lower bound (RRR_PARAM_ANY: none;
 * RRR_PARAM_NONNEG: >= 0; RRR_PARAM_POS: > 0). The base parameters must in addition give a
 * positive definite inertia matrix everywhere (rrr_model_validate).
 */
#ifndef RRR_PARAMS_H
#define RRR_PARAMS_H

#ifdef __cplusplus
extern "C" {
#endif

#include <stddef.h>

#include "rrr_model.h"

/** @brief Lower bound of a parameter (every parameter must also be finite). */
typedef enum rrr_param_bound {
    RRR_PARAM_ANY = 0,             ///< any finite value
    RRR_PARAM_NONNEG = 1,          ///< >= 0
    RRR_PARAM_POS = 2              ///< > 0
} rrr_param_bound;

///@{
/** Units of the table (the FMUs' unit names). */
#define RRR_U_M "m"
#define RRR_U_G "m/s2"
#define RRR_U_P2 "kg.m2"
#define RRR_U_P1 "kg.m"
#define RRR_U_KT "N.m/V"
#define RRR_U_V "V"
#define RRR_U_W "s/rad"
#define RRR_U_B "V.s/rad"
///@}

///@{
/** Helpers of RRR_MODEL_PARAMS: the rows of a 3-vector, of a 3 x 3 matrix (joint i, term k)
 *  and of base parameter p_i. */
#define RRR_PARAMS_J(X, N, M, U, B, D)                                                        \
    X(N "[1]", M[0], U, B, D " of joint 1")                                                  \
    X(N "[2]", M[1], U, B, D " of joint 2")                                                  \
    X(N "[3]", M[2], U, B, D " of joint 3")
#define RRR_PARAMS_JK1(X, N, M, U, B, D, i)                                                   \
    X(N "[" #i ",1]", M[i - 1][0], U, B, D " term 1 of joint " #i)                           \
    X(N "[" #i ",2]", M[i - 1][1], U, B, D " term 2 of joint " #i)                           \
    X(N "[" #i ",3]", M[i - 1][2], U, B, D " term 3 of joint " #i)
#define RRR_PARAMS_JK(X, N, M, U, B, D)                                                       \
    RRR_PARAMS_JK1(X, N, M, U, B, D, 1)                                                      \
    RRR_PARAMS_JK1(X, N, M, U, B, D, 2)                                                      \
    RRR_PARAMS_JK1(X, N, M, U, B, D, 3)
#define RRR_PARAMS_P(X, i, U) X("p[" #i "]", p[i - 1], U, RRR_PARAM_ANY, "base parameter p" #i " of eq 12")
///@}

/**
 * @brief The table: X(NAME, MEMBER, UNIT, BOUND, DESCRIPTION) for each of the RRR_N_PARAMS
 *        scalars, in this order (it is the order of the FMU value references). MEMBER designates
 *        the value inside rrr_model (for offsetof).
 */
#define RRR_MODEL_PARAMS(X)                                                                   \
    X("d1", d1, RRR_U_M, RRR_PARAM_ANY, "DH offset of joint 1 (shoulder height)")            \
    X("a2", a2, RRR_U_M, RRR_PARAM_POS, "DH length of link 2 (upper arm)")                   \
    X("a3", a3, RRR_U_M, RRR_PARAM_POS, "DH length of link 3 (forearm)")                     \
    X("d2", d2, RRR_U_M, RRR_PARAM_ANY, "DH offset of joint 2")                              \
    X("d3", d3, RRR_U_M, RRR_PARAM_ANY, "DH offset of joint 3")                              \
    X("g", g, RRR_U_G, RRR_PARAM_NONNEG, "gravitational acceleration along -z0")             \
    RRR_PARAMS_P(X, 1, RRR_U_P2) RRR_PARAMS_P(X, 2, RRR_U_P2) RRR_PARAMS_P(X, 3, RRR_U_P1)    \
    RRR_PARAMS_P(X, 4, RRR_U_P1) RRR_PARAMS_P(X, 5, RRR_U_P2) RRR_PARAMS_P(X, 6, RRR_U_P2)    \
    RRR_PARAMS_P(X, 7, RRR_U_P2) RRR_PARAMS_P(X, 8, RRR_U_P2) RRR_PARAMS_P(X, 9, RRR_U_P2)    \
    RRR_PARAMS_P(X, 10, RRR_U_P2) RRR_PARAMS_P(X, 11, RRR_U_P2) RRR_PARAMS_P(X, 12, RRR_U_P2) \
    RRR_PARAMS_P(X, 13, RRR_U_P2) RRR_PARAMS_P(X, 14, RRR_U_P2) RRR_PARAMS_P(X, 15, RRR_U_P1) \
    RRR_PARAMS_P(X, 16, RRR_U_P1)                                                             \
    RRR_PARAMS_J(X, "kt", kt, RRR_U_KT, RRR_PARAM_POS,                                        \
                 "torque constant of the motor and current inverter (eq 8)")                 \
    RRR_PARAMS_JK(X, "f", f, RRR_U_V, RRR_PARAM_ANY, "friction amplitude (eq 9),")           \
    RRR_PARAMS_JK(X, "w", w, RRR_U_W, RRR_PARAM_NONNEG, "friction slope (eq 9),")            \
    RRR_PARAMS_J(X, "b", b, RRR_U_B, RRR_PARAM_NONNEG, "viscous friction (eq 9)")            \
    X("u_max", u_max, RRR_U_V, RRR_PARAM_POS, "input voltage limit (symmetric)")

/** Number of scalar parameters of rrr_model (6 + 16 + 3 + 9 + 9 + 3 + 1). */
#define RRR_N_PARAMS 47

/** @brief One row of the table (plain data in read-only memory: no pointers). */
typedef struct rrr_param_info {
    char name[8];                  ///< e.g. "p[12]", "f[2,3]"
    char unit[8];                  ///< e.g. "kg.m2", "N.m/V"
    size_t offset;                 ///< byte offset of the double inside rrr_model
    rrr_param_bound bound;         ///< lower bound
    char description[80];          ///< one line
} rrr_param_info;

/**
 * @brief The table: RRR_N_PARAMS rows in RRR_MODEL_PARAMS order.
 * @param[out] n if not NULL, receives RRR_N_PARAMS
 */
RRR_API const rrr_param_info *rrr_param_table(size_t *n);

/**
 * @brief Index of the parameter called name (exact match, e.g. "p[3]").
 * @return the row, or -1 when there is none
 */
RRR_API int rrr_param_index(const char *name);

/** @brief Value of row i of the table in m (NaN for a bad row or NULL model). */
RRR_API double rrr_param_get(const rrr_model *m, size_t i);

/**
 * @brief Set row i of the table in m (no range check: rrr_model_validate checks the model).
 * @return RRR_OK, RRR_BAD_INPUT (NULL model, row out of range, non-finite value)
 */
RRR_API rrr_status rrr_param_set(rrr_model *m, size_t i, double value);

/** @brief 1 when value satisfies row i's range (finite, lower bound), else 0. */
RRR_API int rrr_param_in_range(size_t i, double value);

#ifdef __cplusplus
}
#endif
#endif /* RRR_PARAMS_H */
