/**
 * @file hil_reference.h
 * @brief The reference table of the CAN bench's controller (rrr_hil_controller --reference, and
 *        the LS-BUS controller FMU's resources/reference.csv): one row per period. Reads a file;
 *        no other I/O, no globals.
 */
#ifndef RRR_HIL_REFERENCE_H
#define RRR_HIL_REFERENCE_H

#include <stddef.h>

/** Reference samples, one per period: t, q_ref, qd_ref, qdd_ref. */
typedef struct rrr_hil_reference {
    size_t n;        ///< samples
    double *t;       ///< (n,) s
    double (*q)[3];  ///< (n, 3) rad
    double (*qd)[3]; ///< (n, 3) rad/s
    double (*qdd)[3]; ///< (n, 3) rad/s2
} rrr_hil_reference;

/** Columns the controller reads from the reference table: t, q_ref[1..3], qd_ref[1..3],
 *  qdd_ref[1..3]. */
#define RRR_HIL_REF_NEEDED 10
/** Most columns and longest line (characters) of a reference table. */
#define RRR_HIL_REF_MAX_COLUMNS 64
#define RRR_HIL_REF_LINE_MAX 4096

/**
 * @brief Read the reference table: the reference FMU's format (docs/fmus.md "rrr_reference";
 *        fmu/reference/resources/reference.csv): a header naming the columns, then one
 *        row of finite numbers per period (uniform step RRR_HIL_PERIOD_S, relative tolerance
 *        1e-6). The columns t, q_ref[1..3], qd_ref[1..3], qdd_ref[1..3] are found by name (in
 *        any order; the others, the tip's x_ref, xd_ref, xdd_ref, are read and not used).
 * @return 0, or -1 with a message naming the file, the line and the column (a missing column
 *         by its name) in err.
 */
int rrr_hil_reference_load(const char *path, rrr_hil_reference *r, char *err, size_t err_len);
void rrr_hil_reference_free(rrr_hil_reference *r);

#endif /* RRR_HIL_REFERENCE_H */
