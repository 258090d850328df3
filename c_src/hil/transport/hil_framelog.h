/**
 * @file hil_framelog.h
 * @brief The frame log of a bench node: every frame its transport sent or received, with a
 *        timestamp, in a compact binary file that rrr_robot.hil.logs.frames converts to the
 *        standard formats (Vector ASC and BLF through python-can).
 *
 * File: the 8 bytes "RRRCAN1\n", then one 24-byte record per frame, little-endian:
 *   int64  t_ns     CLOCK_REALTIME when the transport call returned, ns since the epoch
 *   uint32 id       identifier; bit 31 set for a 29-bit (extended) identifier
 *   uint8  dlc      0..8
 *   uint8  dir      0 received, 1 sent (by this node)
 *   uint8  pad[2]   0
 *   uint8  data[8]  payload, bytes beyond dlc 0
 * Records go through a stdio buffer (RRR_HIL_FRAMELOG_BUFFER bytes: one write(2) per 2730
 * frames); a failed write is remembered and reported by rrr_hil_framelog_close.
 */
#ifndef RRR_HIL_FRAMELOG_H
#define RRR_HIL_FRAMELOG_H

#include <stddef.h>
#include <stdint.h>
#include <stdio.h>

#include "hil_common.h"

#define RRR_HIL_FRAMELOG_MAGIC "RRRCAN1\n"
#define RRR_HIL_FRAMELOG_RECORD 24u
#define RRR_HIL_FRAMELOG_BUFFER 65536u

/** Direction of a logged frame, seen from the logging node. */
enum { RRR_HIL_FRAME_RX = 0, RRR_HIL_FRAME_TX = 1 };

/** An open frame log (fp NULL: none, or closed). */
typedef struct rrr_hil_framelog {
    FILE *fp;
    uint64_t frames; ///< records written
    int error;       ///< errno of the first failed write, 0 if none
} rrr_hil_framelog;

/** Create (truncate) @p path and write the magic. 0, or -1 with a message in err. */
int rrr_hil_framelog_open(rrr_hil_framelog *l, const char *path, char *err, size_t err_len);
/** Append one frame (no-op when closed), timestamped now (CLOCK_REALTIME). */
void rrr_hil_framelog_put(rrr_hil_framelog *l, const rrr_hil_frame *f, int dir);
/** Pack one record into 24 bytes (pure; used by put, and tested). */
void rrr_hil_framelog_pack(uint8_t out[RRR_HIL_FRAMELOG_RECORD], int64_t t_ns,
                           const rrr_hil_frame *f, int dir);
/** Flush and close (idempotent). 0, or -1 when a write or the close failed (errno in error). */
int rrr_hil_framelog_close(rrr_hil_framelog *l);

#endif /* RRR_HIL_FRAMELOG_H */
