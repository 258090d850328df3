/**
 * @file hil_supervisor.h
 * @brief The plant's command supervisor: which voltage the plant applies over the next period,
 *        given the frames received during the last one, when a latched fault may be cleared and
 *        whether a stop request is honoured. Pure logic: no I/O, no allocation, no globals
 *        (unit-tested in tests/c/test_hil_supervisor.c, fuzzed by fuzz/fuzz_hil_decode.c, and
 *        bound from Python through librrr_hil_supervisor.so).
 *
 * Policy (also stated in the DBC comments of VoltageCmd and StopCmd):
 * - a valid command (CRC, DLC, counter delta 1..max_delta_counter, voltages in range) is
 *   applied, or 0 V when its Enable bit is 0; the newest valid command of a period wins;
 * - a period without a valid command holds the last applied voltage; the max_missed-th
 *   consecutive such period applies 0 V and latches RRR_HIL_FAULT_TIMEOUT (default 3: a silent
 *   controller gives 0 V at the 3rd period);
 * - a command with a wrong CRC, a repeated counter (delta 0) or a jump > max_delta_counter, a
 *   voltage out of range or a wrong DLC latches the matching fault at once; so do a lockstep Sync
 *   with an unexpected cycle index and a bus-off or disconnect;
 * - while any fault is latched the plant applies 0 V. Only a deliberate sequence clears the
 *   latch, as the fault reset of CiA 402 (never a single frame):
 *   1. reset request: a valid command with ResetFault = 1 and Enable = 0 arms the reset
 *      (PlantStatus.State = RRR_HIL_PLANT_RESET); it may be repeated;
 *   2. fresh enable: RRR_HIL_RESET_ENABLE_FRAMES valid commands with Enable = 1 and
 *      ResetFault = 0, each alive counter exactly 1 above the previous command's (the first
 *      above the last reset request's). The last of them clears the latch and its voltage is
 *      applied from the next period; the ones before it still give 0 V.
 *   Once armed, the sequence is aborted (back to 1) by a counter step other than exactly 1
 *   (which also latches RRR_HIL_FAULT_COUNTER), by any invalid frame or new fault (they latch
 *   theirs), by Enable = 0 with ResetFault = 0, and by Enable = 1 with ResetFault = 1. A
 *   ResetFault while nothing is latched has no effect;
 * - a stop request (StopCmd) is honoured only with the E2E protection of a command: a valid CRC
 *   and DLC, a known reason, and an alive counter 1..max_delta_counter above the last valid
 *   command's (it continues the VoltageCmd sequence; before the first valid command there is
 *   nothing to check it against). Any other StopCmd is ignored and counted (err.stop_rejected),
 *   without latching a fault. Once a stop is honoured the plant applies 0 V.
 * Every event is counted in err (counters only grow).
 *
 * The 0 V and the latch are rrr_hil_latch's (hil_common.h): faults (its code), zero_applied (its zero)
 * and err.fault_events, err.resets, err.zero_periods (its counters) are that latch's storage,
 * loaded into an rrr_hil_latch and stored back around each call (hil_supervisor.c), so that the
 * layout the Python binding knows stays as it is.
 *
 * ABI note: rrr_hil_sup, rrr_hil_sup_config and rrr_hil_sup_err are mirrored field by field by
 * the Python binding (ctypes). The fields added for the reset sequence and the stop request sit
 * in what was padding and at the end of err, so the size (128 bytes on LP64) and the offsets of
 * the older fields did not change (checked in hil_supervisor.c).
 */
#ifndef RRR_HIL_SUPERVISOR_H
#define RRR_HIL_SUPERVISOR_H

#include <stdint.h>

#include "hil_codec.h"

/** Valid enabling commands with consecutive alive counters that complete a fault reset. */
#define RRR_HIL_RESET_ENABLE_FRAMES 3u

/** Steps of the fault-reset sequence (rrr_hil_sup.reset_step). */
enum {
    RRR_HIL_RESET_IDLE = 0,  ///< no reset armed
    RRR_HIL_RESET_ARMED = 1  ///< a reset request was accepted; counting enabling commands
};

/** Supervisor settings. */
typedef struct rrr_hil_sup_config {
    unsigned max_missed;        ///< consecutive periods without a valid command before 0 V, >= 1 (3)
    unsigned max_delta_counter; ///< largest accepted alive-counter increment, 1..15 (3)
} rrr_hil_sup_config;

/** Event counters (only grow). */
typedef struct rrr_hil_sup_err {
    uint32_t crc;         ///< commands with a wrong CRC
    uint32_t counter;     ///< repeated or jumping alive counters (and broken reset sequences)
    uint32_t range;       ///< commands with a voltage out of range
    uint32_t format;      ///< commands with a wrong DLC
    uint32_t sync;        ///< Syncs with an unexpected cycle index
    uint32_t bus;         ///< bus-off or disconnect events
    uint32_t timeout;     ///< timeouts (max_missed consecutive periods without a command)
    uint32_t cmd_missed;  ///< periods without a valid command
    uint32_t fault_events; ///< sum of the fault events above (crc + counter + range + format + sync + bus + timeout)
    uint32_t resets;      ///< latches cleared by a complete fault-reset sequence
    uint32_t zero_periods; ///< periods with 0 V applied because of a fault, a timeout or a stop
    uint32_t stop_rejected; ///< StopCmd frames ignored: wrong CRC or DLC, bad reason, stale counter
} rrr_hil_sup_err;

/** Supervisor state. */
typedef struct rrr_hil_sup {
    rrr_hil_sup_config cfg;  ///< settings
    uint8_t faults;          ///< latched RRR_HIL_FAULT_* bits
    uint8_t have_counter;    ///< a valid command was seen (last_counter is meaningful)
    uint8_t last_counter;    ///< alive counter of the last valid command (or honoured stop)
    uint8_t pending;         ///< a valid command arrived in the current period
    uint8_t reset_step;      ///< RRR_HIL_RESET_IDLE or RRR_HIL_RESET_ARMED
    uint8_t reset_enables;   ///< enabling commands counted since the reset was armed
    uint8_t stop;            ///< 1 once a StopCmd was honoured
    uint8_t stop_reason;     ///< its rrr_hil_stop_reason (valid when stop = 1)
    rrr_hil_voltage_cmd cmd; ///< newest valid command of the current period
    double u_hold_V[3];      ///< voltage applied over the last period
    unsigned missed_in_row;  ///< consecutive periods without a valid command
    uint8_t zero_applied;    ///< 0 V was forced over the last period
    rrr_hil_sup_err err;     ///< event counters
} rrr_hil_sup;

/** Default settings: max_missed 3, max_delta_counter 3. */
rrr_hil_sup_config rrr_hil_sup_config_default(void);

/** Start with no command, 0 V held, no fault. Returns -1 on invalid settings. */
int rrr_hil_sup_init(rrr_hil_sup *s, const rrr_hil_sup_config *cfg);

/** Feed the decode result of a frame with the VoltageCmd id (rx != RRR_HIL_RX_OK: cmd unused,
 *  may be NULL; RRR_HIL_RX_OK with cmd NULL counts as a format fault). */
void rrr_hil_sup_on_command(rrr_hil_sup *s, rrr_hil_rx rx, const rrr_hil_voltage_cmd *cmd);

/**
 * @brief Feed the decode result of a frame with the StopCmd id.
 * @param rx   its decode result; anything but RRR_HIL_RX_OK is rejected
 * @param stop the decoded request (used only when rx is RRR_HIL_RX_OK; may be NULL otherwise)
 * @return 1 when the stop is honoured (s->stop = 1, s->stop_reason set, 0 V from now on), 0 when
 *         it is ignored (counted in err.stop_rejected; no fault is latched)
 */
int rrr_hil_sup_on_stop(rrr_hil_sup *s, rrr_hil_rx rx, const rrr_hil_stop_cmd *stop);

/** Latch an external fault (RRR_HIL_FAULT_SYNC, RRR_HIL_FAULT_BUS) and count it. */
void rrr_hil_sup_raise(rrr_hil_sup *s, uint8_t fault);

/**
 * @brief Close the current period: decide the voltage for the next one.
 * @param[out] u_V voltage to apply over the next period, V
 * @return 1 when 0 V is forced by a fault, a timeout or a stop, else 0
 */
int rrr_hil_sup_next_period(rrr_hil_sup *s, double u_V[3]);

/** PlantStatus fields from the supervisor (counter filled by the caller). */
void rrr_hil_sup_status(const rrr_hil_sup *s, rrr_hil_plant_status *st);

#endif /* RRR_HIL_SUPERVISOR_H */
