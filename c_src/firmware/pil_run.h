/**
 * @file pil_run.h
 * @brief The run block: what the controller needs besides its code, written by `rrr hil pil`
 *        (rrr_robot.hil.pil.run_block) and placed in flash beside the image (under QEMU:
 *        `-device loader,file=run.bin,addr=0x00100000`; on a board: flashed to the linker
 *        script's RUN region). The gains, the model parameters that differ from the default
 *        robot, the timeout and the reference table (one row per period), as the Linux node
 *        takes them from --kp, --kd, --no-feedforward, --set, --timeout-ms and --reference.
 *
 * Layout, little-endian, every double at a multiple of 8 bytes:
 *
 *   offset  size          field
 *   0       8             magic "RRRPIL01"
 *   8       4             total size of the block in bytes (with the CRC)
 *   12      4             periods n (>= 1)
 *   16      4             model parameter assignments m (<= RRR_N_PARAMS)
 *   20      4             feedforward (0 or 1)
 *   24      4             timeout, ms: the longest wait for the plant's next state (>= 1)
 *   28      4             0
 *   32      48            kp[3], kd[3] (double)
 *   80      16 m          m x {uint32 row of the parameter table (rrr_params.h), uint32 0,
 *                         double value}
 *   80+16m  80 n          t[n], q[n][3], qd[n][3], qdd[n][3] (double), as columns
 *   end-8   8             CRC-32 (zlib's) of everything before it, then 4 bytes 0
 *
 * Pure: no I/O, no allocation, no globals.
 */
#ifndef PIL_RUN_H
#define PIL_RUN_H

#include <stddef.h>
#include <stdint.h>

#include "rrr/rrr_control.h"
#include "rrr/rrr_model.h"

#define PIL_RUN_MAGIC "RRRPIL01"
#define PIL_RUN_HEADER_BYTES 80u

/** One model parameter assignment: row of the parameter table and value. */
typedef struct pil_run_set {
    uint32_t row;
    double value;
} pil_run_set;

/** A checked run block; the arrays point into it. */
typedef struct pil_run {
    uint32_t periods;
    uint32_t n_sets;
    uint32_t timeout_ms;
    rrr_ctc_gains gains;
    const unsigned char *sets; ///< n_sets entries of 16 bytes (pil_run_get_set)
    const double *t;           ///< (n,) s
    const double (*q)[3];      ///< (n, 3) rad
    const double (*qd)[3];     ///< (n, 3) rad/s
    const double (*qdd)[3];    ///< (n, 3) rad/s2
} pil_run;

/** CRC-32 of n bytes (zlib's crc32: reflected 0xEDB88320, init and xorout 0xFFFFFFFF). */
uint32_t pil_crc32(const unsigned char *p, size_t n);

/**
 * @brief Check the block at @p base (at most @p cap bytes, 8-byte aligned) and describe it.
 * @return 0, or -1 with *why naming what is wrong (no magic: nothing was loaded; a size that
 *         does not add up; a CRC mismatch; a value out of range)
 */
int pil_run_open(const void *base, size_t cap, pil_run *run, const char **why);

/** Assignment i of the block. */
pil_run_set pil_run_get_set(const pil_run *run, uint32_t i);

/** The default robot with the block's assignments, validated: 0, or -1 with *why set. */
int pil_run_model(const pil_run *run, rrr_model *m, const char **why);

#endif /* PIL_RUN_H */
