/**
 * @file config.h
 * @brief The reference FMU (rrr_reference): identifier, value references, model data.
 *
 * Plays a sampled joint reference read from the table resources/reference.csv inside the FMU
 * (written by `rrr ssp`, format in model.c and docs/ssp.md): outputs q_ref, qd_ref, qdd_ref and
 * the tip reference x_ref at the time t + lookahead, interpolated between the samples by
 * quintic Hermite polynomials (qd_ref and qdd_ref are the exact derivatives of the q_ref
 * interpolant and equal the samples at the sample times). No inputs, no states, no model.
 */
#ifndef RRR_FMU_REFERENCE_CONFIG_H
#define RRR_FMU_REFERENCE_CONFIG_H

#include "fmu_model.h" /* first: see fmu_model.h */

#include <stdint.h>

#define MODEL_IDENTIFIER "rrr_reference"

/** Joints and tip coordinates of the reference. */
#define REF_NJ 3

/** The table's file in the FMU's resources/ folder. */
#define REF_TABLE_FILE "reference.csv"

/** Columns of the table: t, then (q, qd, qdd) of the 3 joints, then (x, xd, xdd) of the tip. */
#define REF_COLUMNS 19

/** Most samples a table may have (1000 s at 0.5 ms). */
#define REF_MAX_ROWS 2000001u

/** Value references (= rows of the variable table in model.c). */
typedef enum reference_vr {
    vr_q_ref = 0,                              ///< q_ref[1..3], output, rad
    vr_qd_ref = vr_q_ref + REF_NJ,             ///< qd_ref[1..3], output, rad/s
    vr_qdd_ref = vr_qd_ref + REF_NJ,           ///< qdd_ref[1..3], output, rad/s2
    vr_x_ref = vr_qdd_ref + REF_NJ,            ///< x_ref.x, x_ref.y, x_ref.z, output, m
    vr_lookahead = vr_x_ref + 3,               ///< lookahead, parameter, s
    vr_time,                                   ///< time, independent variable, s
    vr_count
} reference_vr;

/** Model data of one instance (plain old data: copied into FMU state snapshots; the table
 *  itself is in fmu_instance.work, read once from resources/). */
typedef struct reference_data {
    double lookahead;                          ///< the outputs are the reference at t + lookahead, s
    double q_ref[REF_NJ];                      ///< joint positions, rad
    double qd_ref[REF_NJ];                     ///< joint velocities, rad/s
    double qdd_ref[REF_NJ];                    ///< joint accelerations, rad/s2
    double x_ref[3];                           ///< tip position, m
    uint64_t table_hash;                       ///< hash of the table the outputs came from (0: none)
    uint64_t cursor;                           ///< interval of the last look-up
} reference_data;

#endif /* RRR_FMU_REFERENCE_CONFIG_H */
