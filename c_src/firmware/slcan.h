/**
 * @file slcan.h
 * @brief SLCAN, the serial-line CAN protocol of Lawicel and CANable-type USB adapters, from the
 *        adapter's side: the firmware speaks it on a UART so that a PC reaches the controller
 *        as it reaches a bus through such an adapter (python-can's `slcan` interface).
 *
 * Lines end with CR. Commands (the reply is CR for OK, BEL for an error):
 *  - `O` open the channel (normal), `L` open listen-only (the node stays silent), `C` close;
 *  - `S0`..`S8` the bit rate (10 k .. 1 Mbit/s), `sBBBB` a BTR register pair (only while closed;
 *    remembered, nothing else: the line is not a bus), an empty line (python-can sends one for
 *    "no data bit rate");
 *  - `V` hardware and software version (`V1013`), `v` software version, `N` serial number,
 *    `F` status flags (`F00`), `Z0` no timestamps;
 *  - `tIIILDD..` a classical frame with an 11-bit id, `TIIIIIIIILDD..` with a 29-bit id (L: the
 *    DLC 0..8, DD: L data bytes in hex): delivered to the node when the channel is open (reply
 *    `z` / `Z` then CR); remote (`r`, `R`) and CAN FD (`d`, `D`, `b`, `B`) frames are refused.
 * Frames the node sends go out as `t`/`T` lines while the channel is open (not listen-only).
 *
 * Pure: no I/O, no allocation, no globals; the host's CTest fuzzes it (tests in
 * c_src/firmware/host).
 */
#ifndef PIL_SLCAN_H
#define PIL_SLCAN_H

#include <stddef.h>
#include <stdint.h>

#include "hil_common.h" /* rrr_hil_frame */

/** Longest line: `T` + 8 + 1 + 16 characters (the CR not stored). */
#define PIL_SLCAN_LINE_MAX 26u
/** Longest reply of pil_slcan_feed (with its CR). */
#define PIL_SLCAN_REPLY_MAX 8u

/** The adapter's state. */
typedef struct pil_slcan {
    char line[PIL_SLCAN_LINE_MAX]; ///< the line being received
    unsigned len;         ///< characters in line
    int overflow;         ///< the line is longer than PIL_SLCAN_LINE_MAX (refused at its CR)
    int open;             ///< 1: open (O), 2: open listen-only (L), 0: closed
    int bitrate;          ///< the S command's digit, -1 until one came
    uint32_t commands;    ///< lines answered with OK
    uint32_t refused;     ///< lines answered with BEL (bad syntax, wrong state, unsupported)
    uint32_t rx_frames;   ///< frames delivered to the node
    uint32_t closes;      ///< C commands received while open
} pil_slcan;

/** What a line was. */
typedef enum pil_slcan_event {
    PIL_SLCAN_NONE = 0, ///< no complete line yet, or a command (its reply in reply)
    PIL_SLCAN_FRAME,    ///< a frame for the node (in f; the reply in reply)
    PIL_SLCAN_OPENED,   ///< the channel was opened (the reply in reply)
    PIL_SLCAN_CLOSED    ///< an open channel was closed (the reply in reply)
} pil_slcan_event;

/** Closed, nothing received. */
void pil_slcan_init(pil_slcan *s);

/**
 * @brief Feed one received character.
 * @param[out] f         the frame, for PIL_SLCAN_FRAME
 * @param[out] reply     the reply to send back (PIL_SLCAN_REPLY_MAX bytes), *reply_len of them
 *                       (0 while a line is incomplete)
 * @return what the character completed
 */
pil_slcan_event pil_slcan_feed(pil_slcan *s, char c, rrr_hil_frame *f, char *reply,
                               size_t *reply_len);

/** 1 when the node may send (open, not listen-only). */
int pil_slcan_can_send(const pil_slcan *s);

/** The line of a frame ("t1008DDDDDDDDDDDDDDDD\r"; `T` for an extended id) into out (at least
 *  PIL_SLCAN_LINE_MAX + 1 bytes): its length, or 0 for a frame with dlc > 8. */
size_t pil_slcan_format(const rrr_hil_frame *f, char *out);

#endif /* PIL_SLCAN_H */
