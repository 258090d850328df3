/**
 * @file rrr_model_vars.h
 * @brief Variable-table rows of the rrr_model parameters, shared by the plant and the controller
 *        so both FMUs name, describe and unit them identically.
 *
 * RRR_MODEL_VARS(T, M, B) expands to RRR_MV_COUNT rows for the rrr_model at member path M of the
 * model data type T, with value references B + RRR_MV_* (the RRR_MV_* offsets below).
 * Rows are fixed parameters, start = rrr_model_default(). f[i,k] and w[i,k] are row-major
 * (joint i, term k).
 */
#ifndef RRR_MODEL_VARS_H
#define RRR_MODEL_VARS_H

#include "fmu_model.h"
#include "rrr/rrr_model.h"

#include <stddef.h>

/** Offsets of the model parameters from the first value reference B. */
enum rrr_model_var_offset {
    RRR_MV_D1 = 0,
    RRR_MV_A2,
    RRR_MV_A3,
    RRR_MV_D2,
    RRR_MV_D3,
    RRR_MV_G,
    RRR_MV_P,                                  ///< p[1] .. p[16]
    RRR_MV_KT = RRR_MV_P + RRR_NP,             ///< kt[1] .. kt[3]
    RRR_MV_F = RRR_MV_KT + RRR_NJ,             ///< f[1,1], f[1,2], .. f[3,3]
    RRR_MV_W = RRR_MV_F + RRR_NJ * RRR_NF,     ///< w[1,1] .. w[3,3]
    RRR_MV_B = RRR_MV_W + RRR_NJ * RRR_NF,     ///< b[1] .. b[3]
    RRR_MV_U_MAX = RRR_MV_B + RRR_NJ,
    RRR_MV_COUNT
};

/** One row of the table. */
#define FMU_ROW(VR, TYPE, CAUS, VARIAB, NAME, DESC, UNIT, T, MEMBER)                          \
    {(VR), TYPE, CAUS, VARIAB, NAME, DESC, UNIT, offsetof(T, MEMBER)}

/** A fixed Real parameter. */
#define FMU_PARAM(VR, NAME, DESC, UNIT, T, MEMBER)                                            \
    FMU_ROW(VR, FMU_REAL, FMU_PARAMETER, FMU_FIXED, NAME, DESC, UNIT, T, MEMBER)

#define RRR_MV_P_ROW(T, M, B, i, U)                                                            \
    FMU_PARAM((B) + RRR_MV_P + (i) - 1, "p[" #i "]",                                          \
              "base parameter p" #i " of eq 12, " U, \
              NULL, T, M.p[(i) - 1])
#define RRR_MV_KT_ROW(T, M, B, i)                                                              \
    FMU_PARAM((B) + RRR_MV_KT + (i) - 1, "kt[" #i "]",                                        \
              "torque constant of motor " #i " with its current inverter (eq 8)", "N.m/V", T,   \
              M.kt[(i) - 1])
#define RRR_MV_F_ROW(T, M, B, i, k)                                                            \
    FMU_PARAM((B) + RRR_MV_F + 3 * ((i) - 1) + (k) - 1, "f[" #i "," #k "]",                   \
              "friction amplitude of term " #k " of joint " #i " (eq 9)", "V", T,               \
              M.f[(i) - 1][(k) - 1])
#define RRR_MV_W_ROW(T, M, B, i, k)                                                            \
    FMU_PARAM((B) + RRR_MV_W + 3 * ((i) - 1) + (k) - 1, "w[" #i "," #k "]",                   \
              "friction slope of term " #k " of joint " #i " (eq 9), >= 0", "s/rad", T,         \
              M.w[(i) - 1][(k) - 1])
#define RRR_MV_B_ROW(T, M, B, i)                                                               \
    FMU_PARAM((B) + RRR_MV_B + (i) - 1, "b[" #i "]",                                          \
              "viscous friction of joint " #i " (eq 9), >= 0", "V.s/rad", T, M.b[(i) - 1])

/** The RRR_MV_COUNT rows of the model parameters. */
#define RRR_MODEL_VARS(T, M, B)                                                                \
    FMU_PARAM((B) + RRR_MV_D1, "d1", "DH offset of joint 1 (shoulder height)", "m", T, M.d1),  \
    FMU_PARAM((B) + RRR_MV_A2, "a2", "DH length of link 2 (upper arm), > 0", "m", T, M.a2),    \
    FMU_PARAM((B) + RRR_MV_A3, "a3", "DH length of link 3 (forearm), > 0", "m", T, M.a3),      \
    FMU_PARAM((B) + RRR_MV_D2, "d2", "DH offset of joint 2", "m", T, M.d2),                    \
    FMU_PARAM((B) + RRR_MV_D3, "d3", "DH offset of joint 3", "m", T, M.d3),                    \
    FMU_PARAM((B) + RRR_MV_G, "g", "gravitational acceleration along -z0, >= 0", "m/s2", T,   \
              M.g),                                                                            \
    RRR_MV_P_ROW(T, M, B, 1, "kg m2"), RRR_MV_P_ROW(T, M, B, 2, "kg m2"),                      \
    RRR_MV_P_ROW(T, M, B, 3, "kg m"), RRR_MV_P_ROW(T, M, B, 4, "kg m"),                        \
    RRR_MV_P_ROW(T, M, B, 5, "kg m2"), RRR_MV_P_ROW(T, M, B, 6, "kg m2"),                      \
    RRR_MV_P_ROW(T, M, B, 7, "kg m2"), RRR_MV_P_ROW(T, M, B, 8, "kg m2"),                      \
    RRR_MV_P_ROW(T, M, B, 9, "kg m2"), RRR_MV_P_ROW(T, M, B, 10, "kg m2"),                     \
    RRR_MV_P_ROW(T, M, B, 11, "kg m2"), RRR_MV_P_ROW(T, M, B, 12, "kg m2"),                    \
    RRR_MV_P_ROW(T, M, B, 13, "kg m2"), RRR_MV_P_ROW(T, M, B, 14, "kg m2"),                    \
    RRR_MV_P_ROW(T, M, B, 15, "kg m"), RRR_MV_P_ROW(T, M, B, 16, "kg m"),                      \
    RRR_MV_KT_ROW(T, M, B, 1), RRR_MV_KT_ROW(T, M, B, 2), RRR_MV_KT_ROW(T, M, B, 3),          \
    RRR_MV_F_ROW(T, M, B, 1, 1), RRR_MV_F_ROW(T, M, B, 1, 2), RRR_MV_F_ROW(T, M, B, 1, 3),    \
    RRR_MV_F_ROW(T, M, B, 2, 1), RRR_MV_F_ROW(T, M, B, 2, 2), RRR_MV_F_ROW(T, M, B, 2, 3),    \
    RRR_MV_F_ROW(T, M, B, 3, 1), RRR_MV_F_ROW(T, M, B, 3, 2), RRR_MV_F_ROW(T, M, B, 3, 3),    \
    RRR_MV_W_ROW(T, M, B, 1, 1), RRR_MV_W_ROW(T, M, B, 1, 2), RRR_MV_W_ROW(T, M, B, 1, 3),    \
    RRR_MV_W_ROW(T, M, B, 2, 1), RRR_MV_W_ROW(T, M, B, 2, 2), RRR_MV_W_ROW(T, M, B, 2, 3),    \
    RRR_MV_W_ROW(T, M, B, 3, 1), RRR_MV_W_ROW(T, M, B, 3, 2), RRR_MV_W_ROW(T, M, B, 3, 3),    \
    RRR_MV_B_ROW(T, M, B, 1), RRR_MV_B_ROW(T, M, B, 2), RRR_MV_B_ROW(T, M, B, 3),             \
    FMU_PARAM((B) + RRR_MV_U_MAX, "u_max", "input voltage limit (symmetric), > 0", "V", T,    \
              M.u_max)

#endif /* RRR_MODEL_VARS_H */
