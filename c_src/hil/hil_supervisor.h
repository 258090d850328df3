/**
 * @file hil_supervisor.h
 * @brief The plant's command supervisor: which voltage the plant applies over the next period,
 *        given the frames received during the last one. Pure logic, no I/O (unit-tested in
 *        tests/c/test_hil_supervisor.c).
 *
 * Policy (also stated in the DBC comment of VoltageCmd):
 * - a valid command (CRC, counter delta 1..max_delta_counter, voltages in range) is applied,
 *   or 0 V when its Enable bit is 0; the newest valid command of a period wins;
 * - a period without a valid command holds the last applied voltage; the max_missed-th
 *   consecutive such period applies 0 V and latches RRR_HIL_FAULT_TIMEOUT (default 3: a silent
 *   controller gives 0 V at the 3rd period);
 * - a command with a wrong CRC, a repeated counter (delta 0) or a jump > max_delta_counter, a
 *   voltage out of range or a wrong DLC latches the matching fault at once; so do a lockstep Sync
 *   with an unexpected cycle index and a bus-off or disconnect;
 * - while any fault is latched the plant applies 0 V; a valid command with ResetFault = 1 and
 *   Enable = 0 clears the latch.
 * Every event is counted in err (counters only grow).
 */
#ifndef RRR_HIL_SUPERVISOR_H
#define RRR_HIL_SUPERVISOR_H

#include <stdint.h>

#include "hil_codec.h"

/** Supervisor settings. */
typedef struct rrr_hil_sup_config {
    unsigned max_missed;        ///< consecutive periods without a valid command before 0 V, >= 1 (3)
    unsigned max_delta_counter; ///< largest accepted alive-counter increment, 1..15 (3)
} rrr_hil_sup_config;

/** Event counters (only grow). */
typedef struct rrr_hil_sup_err {
    uint32_t crc;         ///< commands with a wrong CRC
    uint32_t counter;     ///< repeated or jumping alive counters
    uint32_t range;       ///< commands with a voltage out of range
    uint32_t format;      ///< commands with a wrong DLC
    uint32_t sync;        ///< Syncs with an unexpected cycle index
    uint32_t bus;         ///< bus-off or disconnect events
    uint32_t timeout;     ///< timeouts (max_missed consecutive periods without a command)
    uint32_t cmd_missed;  ///< periods without a valid command
    uint32_t fault_events; ///< sum of the fault events above (crc + counter + range + format + sync + bus + timeout)
    uint32_t resets;      ///< latches cleared by ResetFault
    uint32_t zero_periods; ///< periods with 0 V applied because of a fault or timeout
} rrr_hil_sup_err;

/** Supervisor state. */
typedef struct rrr_hil_sup {
    rrr_hil_sup_config cfg;  ///< settings
    uint8_t faults;          ///< latched RRR_HIL_FAULT_* bits
    uint8_t have_counter;    ///< a valid command was seen (last_counter is meaningful)
    uint8_t last_counter;    ///< alive counter of the last valid command
    uint8_t pending;         ///< a valid command arrived in the current period
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

/** Feed the decode result of a frame with the VoltageCmd id (rx != RRR_HIL_RX_OK: msg unused). */
void rrr_hil_sup_on_command(rrr_hil_sup *s, rrr_hil_rx rx, const rrr_hil_voltage_cmd *cmd);

/** Latch an external fault (RRR_HIL_FAULT_SYNC, RRR_HIL_FAULT_BUS) and count it. */
void rrr_hil_sup_raise(rrr_hil_sup *s, uint8_t fault);

/**
 * @brief Close the current period: decide the voltage for the next one.
 * @param[out] u_V voltage to apply over the next period, V
 * @return 1 when 0 V is forced by a fault or timeout, else 0
 */
int rrr_hil_sup_next_period(rrr_hil_sup *s, double u_V[3]);

/** PlantStatus fields from the supervisor (counter filled by the caller). */
void rrr_hil_sup_status(const rrr_hil_sup *s, rrr_hil_plant_status *st);

#endif /* RRR_HIL_SUPERVISOR_H */
