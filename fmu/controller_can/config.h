/**
 * @file config.h
 * @brief The controller as an FMI-LS-BUS CAN node (rrr_controller_can): identifier, value
 *        references, model data.
 *
 * The C controller node of the CAN bench (c_src/hil/dbc/hil_dbc_controller.c) as an FMI 3.0
 * Co-Simulation network FMU: the computed-torque law (rrr_ctc, eq 15) on the reference table
 * resources/reference.csv (hil_reference.c, the C node's --reference) and the joint state the
 * plant's JointState frames carry; its VoltageCmd (and Sync, heartbeats, StopCmd) through the
 * same codec (hil_codec.c), as CAN Transmit operations on one CAN terminal.
 */
#ifndef RRR_FMU_CONTROLLER_CAN_CONFIG_H
#define RRR_FMU_CONTROLLER_CAN_CONFIG_H

#include "rrr_model_vars.h" /* first: it includes fmu_model.h */
#include "fmu_bus.h"
#include "hil_codec.h"
#include "rrr/rrr.h"

#ifndef MODEL_IDENTIFIER
#define MODEL_IDENTIFIER "rrr_controller_can"
#endif
/* The kind of Tx clock (as in fmu/plant_can/config.h). */
#ifndef RRR_LSBUS_TX_CLOCK
#define RRR_LSBUS_TX_CLOCK FMU_BUS_TX_TRIGGERED
#endif

/** The reference table in the FMU's resources/ (the C controller node's --reference). */
#define CONTROLLER_CAN_REFERENCE "reference.csv"
/** A joint state older than this many periods is stale: the command is Enable = 0 (0 V), as the
 *  C controller node's in real time. */
#define CONTROLLER_CAN_STALE_PERIODS 3u

/** The node's counters, outputs "status.<name>" (the C controller node's summary keys). */
#define CONTROLLER_CAN_STATUS(X)                                                              \
    X(states, "complete joint states received")                                               \
    X(commands, "VoltageCmd frames sent")                                                     \
    X(rx_bad_crc, "frames with a wrong E2E CRC")                                              \
    X(rx_bad_dlc, "frames with a wrong DLC")                                                  \
    X(rx_unknown_id, "frames of an identifier not in the DBC")                                \
    X(out_of_order, "incomplete states overtaken by a newer one")                             \
    X(stale, "commands sent with Enable = 0: the newest state was stale")                     \
    X(repeated, "JointState frames repeated in one period")                                   \
    X(plant_faults, "the fault bits of the newest PlantStatus")                               \
    X(plant_status_faulty, "PlantStatus frames with a latched fault")                         \
    X(plant_status_zero, "PlantStatus frames with 0 V")                                       \
    X(ctc_failed, "periods in which rrr_ctc failed (0 V commanded)")                          \
    X(stop_sent, "1 once the StopCmd was sent (the end of the reference)")                    \
    X(frames_received, "CAN frames received")                                                 \
    X(frames_sent, "CAN frames sent")                                                         \
    X(format_errors_sent, "malformed operations received, answered with a Format Error")      \
    X(format_errors_received, "Format Errors received")                                       \
    X(notifications_ignored, "Confirm, Arbitration Lost, Bus Error ignored (BusNotifications " \
                             "false)")                                                        \
    X(tx_overflow, "operations dropped: Tx_Data full")                                        \
    X(peer_baudrate, "the CAN baud rate the other node configured, bit/s (0: none)")

#define CONTROLLER_CAN_STATUS_ENUM(NAME, DESC) cs_##NAME,
enum { CONTROLLER_CAN_STATUS(CONTROLLER_CAN_STATUS_ENUM) CONTROLLER_CAN_STATUS_COUNT };

/** Value references (= rows of the variable table in model.c); the terminal's four variables
 *  follow (fmu_bus.h). */
typedef enum controller_can_vr {
    vr_u = 0,                                  ///< u[1..3], output: the commanded voltage, V
    vr_u_n = vr_u + RRR_NJ,                    ///< u_n[1..3], output, V
    vr_u_c = vr_u_n + RRR_NJ,                  ///< u_c[1..3], output, V
    vr_q = vr_u_c + RRR_NJ,                    ///< q[1..3], output: the measured position, rad
    vr_qd = vr_q + RRR_NJ,                     ///< qd[1..3], output: the measured velocity, rad/s
    vr_period = vr_qd + RRR_NJ,                ///< period, output: k of the last command
    vr_enable,                                 ///< enable, output: its Enable bit
    vr_status,                                 ///< status.*, outputs: the counters
    vr_kp = vr_status + CONTROLLER_CAN_STATUS_COUNT, ///< kp[1..3], parameter
    vr_kd = vr_kp + RRR_NJ,                    ///< kd[1..3], parameter
    vr_feedforward = vr_kd + RRR_NJ,           ///< feedforward, Boolean parameter
    vr_model,                                  ///< the RRR_MV_COUNT model parameters
    vr_sync = vr_model + RRR_MV_COUNT,         ///< sync, Boolean parameter: send Sync frames
    vr_baudrate,                               ///< baudrate, parameter, bit/s
    vr_notifications,                          ///< BusNotifications, Boolean parameter
    vr_time,                                   ///< time, independent variable, s
    vr_count
} controller_can_vr;

/** Model data of one instance (plain old data: copied into FMU state snapshots; the reference
 *  table is in fmu_instance.work, read from resources/ at initialization, with its size and hash
 *  here). */
typedef struct controller_can_data {
    rrr_model model;                 ///< the controller's model parameters
    rrr_ctc_gains gains;             ///< kp, kd, feedforward
    int sync;                        ///< send Sync(k) after VoltageCmd(k) (lockstep schedule)
    double baudrate;                 ///< the CAN baud rate, bit/s (Configuration)
    int notifications;               ///< BusNotifications
    double u[RRR_NJ], u_n[RRR_NJ], u_c[RRR_NJ]; ///< the last command's law, V
    double q[RRR_NJ], qd[RRR_NJ];    ///< the newest complete measured state
    double period;                   ///< k of the last command (-1: none yet)
    double enable;                   ///< its Enable bit
    double status[CONTROLLER_CAN_STATUS_COUNT]; ///< the counters as outputs
    double pq[RRR_NJ], pqd[RRR_NJ];  ///< the state being assembled
    uint64_t ref_hash;               ///< hash of the reference table (0: not read yet)
    uint32_t ref_n;                  ///< its rows
    uint32_t states, commands, stale, ctc_failed, out_of_order, repeated;
    uint32_t status_faulty, status_zero;
    uint32_t rx_bad[RRR_HIL_RX_COUNT];
    uint8_t have[RRR_NJ];            ///< joint j of the state being assembled received
    uint8_t pending;                 ///< its alive counter
    uint8_t done, done_valid;        ///< the alive counter of the last complete state
    uint8_t plant_faults;            ///< the newest PlantStatus's faults
    uint8_t hb_counter;              ///< heartbeat counter
    uint8_t last_cmd_counter;        ///< alive counter of the last VoltageCmd
    uint8_t started;                 ///< the first heartbeat was sent
    uint8_t stop_sent;               ///< the StopCmd was sent
    fmu_bus_state bus;               ///< the CAN terminal (fmu_bus.h)
} controller_can_data;

#endif /* RRR_FMU_CONTROLLER_CAN_CONFIG_H */
