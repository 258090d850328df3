/**
 * @file hil_common.h
 * @brief What every layer of the CAN bench shares, whatever the bus profile: the CAN frame as the
 *        transports carry it, the bench's period, and the safety policy's output stage (the 0 V
 *        and fault latch) that the DBC supervisor (dbc/hil_supervisor.h) and each CiA 402 drive
 *        (canopen/hil_canopen.h) put their faults into.
 *
 * Pure: no I/O, no allocation, no globals (the latch is implemented in hil_latch.c).
 */
#ifndef RRR_HIL_COMMON_H
#define RRR_HIL_COMMON_H

#include <stdint.h>

#include "rrr/rrr_control.h" /* RRR_SAMPLE_TIME_DEFAULT (a macro: nothing to link) */

/** Period of the bench, s (GenMsgCycleTime 1 ms in the DBC; one SYNC per period in CANopen). */
#define RRR_HIL_PERIOD_S RRR_SAMPLE_TIME_DEFAULT

/** A classical CAN frame as the transports carry it. */
typedef struct rrr_hil_frame {
    uint32_t id;      ///< 11-bit (or 29-bit when extended) identifier, without flag bits
    uint8_t extended; ///< 1 for a 29-bit identifier
    uint8_t dlc;      ///< data length, 0..8
    uint8_t data[8];  ///< payload; bytes beyond dlc are 0
} rrr_hil_frame;

/**
 * @brief The safety policy's output stage, one piece of code for both bench profiles: the DBC
 *        supervisor (rrr_hil_sup, dbc/hil_supervisor.h) and each CiA 402 drive of the CANopen
 *        profile (rrr_co_node, canopen/hil_canopen.h).
 *
 * - rrr_hil_latch_fault latches a fault with its code (a new fault while latched replaces the
 *   code and is counted too);
 * - while a fault is latched, or while the caller's stop input is set (a honoured StopCmd, the
 *   supervisor's command timeout, a 402 QUICK STOP ACTIVE), the output stage applies 0 V
 *   (rrr_hil_latch_output zeroes the outputs of the period and counts the period);
 * - nothing but rrr_hil_latch_reset, the explicit reset event, clears the latch: the DBC
 *   supervisor's completed fault-reset sequence, the 402 fault reset (rising edge of controlword
 *   bit 7 in FAULT). A reset while nothing is latched has no effect and is not counted.
 * What a fault is and what the reset event is stay with the caller (the protocol); what
 * happens to the voltage is decided here. Pure: no I/O, no allocation, no globals.
 */
typedef struct rrr_hil_latch {
    uint8_t latched;       ///< 1: a fault is latched (0 V until rrr_hil_latch_reset)
    uint8_t zero;          ///< 0 V was forced over the last period (rrr_hil_latch_output)
    uint16_t code;         ///< the latched fault's code (0 when none): the supervisor's
                           ///< RRR_HIL_FAULT_* bits, a drive's EMCY error code
    uint32_t fault_events; ///< faults latched (a fault while latched counts too)
    uint32_t resets;       ///< latches cleared by rrr_hil_latch_reset
    uint32_t zero_periods; ///< periods with 0 V forced by a latched fault or the stop input
} rrr_hil_latch;

/** Nothing latched, counters 0. */
void rrr_hil_latch_init(rrr_hil_latch *l);

/** Latch a fault with its code and count it. */
void rrr_hil_latch_fault(rrr_hil_latch *l, uint16_t code);

/** The explicit reset event: clears a latched fault (code 0) and counts it; returns 1 then,
 *  0 (and changes nothing) when nothing is latched. */
int rrr_hil_latch_reset(rrr_hil_latch *l);

/** 1 when the output stage forces 0 V now: a fault is latched or @p stop is set. */
int rrr_hil_latch_blocks(const rrr_hil_latch *l, int stop);

/**
 * @brief Close one period: the outputs u[0..n) stay as the caller computed them, or are set to
 *        0 when rrr_hil_latch_blocks(l, stop); such a period is counted in zero_periods and
 *        l->zero tells it until the next call.
 * @return 1 when 0 V was forced, else 0
 */
int rrr_hil_latch_output(rrr_hil_latch *l, int stop, double *u, unsigned n);

#endif /* RRR_HIL_COMMON_H */
