/**
 * @file hil_dbc_ctrl.h
 * @brief The DBC controller's frame logic without I/O, one source for every place the controller
 *        runs: the Linux node's loops (hil_dbc_controller.c) and the firmware (c_src/firmware,
 *        `rrr hil pil`). It decodes what the plant sends (E2E checked by the codec), assembles
 *        the measured state from JointState1..3 of one alive counter, applies the lockstep
 *        repeat rule (a second JointState of a joint in one period is tampered input), keeps the
 *        newest PlantStatus and counts those that report the safety policy firing, and builds
 *        the frames the controller sends with their alive counters (VoltageCmd, the heartbeats,
 *        StopCmd as the next command of the VoltageCmd sequence).
 *
 * Pure: no I/O, no allocation, no globals (rrr_hil_dbc_ctrl_json writes to the stream it is
 * given).
 */
#ifndef RRR_HIL_DBC_CTRL_H
#define RRR_HIL_DBC_CTRL_H

#include <stdint.h>
#include <stdio.h>

#include "hil_codec.h"

/** The controller's view of the bus. */
typedef struct rrr_hil_dbc_ctrl {
    uint8_t have[3];        ///< joint j received for the counter in `pending`
    uint8_t pending;        ///< alive counter of the state being assembled
    double pq[3], pqd[3];   ///< state being assembled
    double q[3], qd[3];     ///< newest complete state, rad, rad/s
    uint32_t states;        ///< complete states assembled
    uint32_t rx_bad[RRR_HIL_RX_COUNT]; ///< frames by decode result (rx_bad[RRR_HIL_RX_OK]: good)
    uint32_t out_of_order;  ///< incomplete states overtaken by another alive counter
    rrr_hil_plant_status status; ///< newest PlantStatus
    uint32_t status_faulty; ///< PlantStatus frames with a latched fault
    uint32_t status_zero;   ///< PlantStatus frames with ZeroVoltage
    uint8_t hb_counter;     ///< the next heartbeat's counter
    uint8_t last_cmd_counter; ///< alive counter of the last VoltageCmd sent
    uint32_t cmds_sent;     ///< VoltageCmd frames sent (rrr_hil_dbc_ctrl_sent)
    int lockstep;           ///< one JointState per joint and period (the repeat rule)
    uint8_t done;           ///< alive counter of the last complete state
    uint8_t done_valid;     ///< 1 once a state was complete
    uint32_t repeated;      ///< JointState frames repeated in one period (the first ends a run)
    char tampered[96];      ///< what made rrr_hil_dbc_ctrl_rx return -1, "" until then
} rrr_hil_dbc_ctrl;

/** Nothing received, counters 0; @p lockstep: the repeat rule applies. */
void rrr_hil_dbc_ctrl_init(rrr_hil_dbc_ctrl *d, int lockstep);

/**
 * @brief Feed one received frame.
 * @param period the controller's period (for the message of a repeat)
 * @return 1 when it completed the state of alive counter d->pending (then in d->q, d->qd),
 *         -1 for a repeated JointState in lockstep (d->tampered says which), 0 otherwise
 */
int rrr_hil_dbc_ctrl_rx(rrr_hil_dbc_ctrl *d, const rrr_hil_frame *f, uint32_t period);

/** The heartbeat frame with NMT state @p nmt (its counter advances): 0, or -1. */
int rrr_hil_dbc_ctrl_heartbeat(rrr_hil_dbc_ctrl *d, uint8_t nmt, rrr_hil_frame *f);

/** VoltageCmd(k): alive counter k mod 16, @p enable, the voltages @p u_V. */
rrr_hil_voltage_cmd rrr_hil_dbc_ctrl_command(uint32_t k, int enable, const double u_V[3]);

/** A VoltageCmd was sent: the StopCmd continues its alive counter. */
void rrr_hil_dbc_ctrl_sent(rrr_hil_dbc_ctrl *d, const rrr_hil_voltage_cmd *cmd);

/** StopCmd with @p reason: the alive counter after the last VoltageCmd sent (0 if none). */
rrr_hil_stop_cmd rrr_hil_dbc_ctrl_stop(const rrr_hil_dbc_ctrl *d, rrr_hil_stop_reason reason);

/** The counts of a run as JSON members (no braces, a trailing ", "): "states", "rx_bad_crc",
 *  "rx_bad_dlc", "rx_unknown_id", "out_of_order", "plant_faults", "plant_status_faulty",
 *  "plant_status_zero", "repeated", "tampered" (the node's RRR_HIL_SUMMARY line). */
void rrr_hil_dbc_ctrl_json(FILE *out, const rrr_hil_dbc_ctrl *d);

#endif /* RRR_HIL_DBC_CTRL_H */
