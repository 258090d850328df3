/**
 * @file config.h
 * @brief The plant as an FMI-LS-BUS CAN node (rrr_plant_can): identifier, value references,
 *        model data.
 *
 * The C plant node of the CAN bench (c_src/hil/dbc/hil_dbc_plant.c) as an FMI 3.0 Co-Simulation
 * network FMU: the same frames of rrr_bench.dbc (JointState1..3, PlantStatus, heartbeats out;
 * VoltageCmd, Sync, StopCmd, the controller's heartbeat in), the same codec and E2E protection
 * (c_src/hil/dbc/hil_codec.c) and the same supervisor (hil_supervisor.c: missing or bad commands
 * give 0 V and latch the fault), carried as CAN Transmit operations on one CAN terminal. The
 * dynamics are librrr's rrr_plant_step with the plant FMU's integrator settings, one period of
 * RRR_SAMPLE_TIME_DEFAULT at a time.
 */
#ifndef RRR_FMU_PLANT_CAN_CONFIG_H
#define RRR_FMU_PLANT_CAN_CONFIG_H

#include "rrr_model_vars.h" /* first: it includes fmu_model.h */
#include "fmu_bus.h"
#include "hil_supervisor.h"
#include "rrr/rrr.h"

#ifndef MODEL_IDENTIFIER
#define MODEL_IDENTIFIER "rrr_plant_can"
#endif
/* The kind of Tx clock: FMU_BUS_TX_TRIGGERED (rrr_plant_can) or FMU_BUS_TX_COUNTDOWN (the
 * build defines it for rrr_plant_can_countdown, from the same sources). */
#ifndef RRR_LSBUS_TX_CLOCK
#define RRR_LSBUS_TX_CLOCK FMU_BUS_TX_TRIGGERED
#endif

/** The internal-step budget of one doStep (as the plant FMU's, fmu/plant/config.h). */
#define PLANT_CAN_MAX_STEPS 100000L

/** The node's counters, outputs "status.<name>" (the C plant node's summary keys). */
#define PLANT_CAN_STATUS(X)                                                                   \
    X(faults, "latched fault bits (RRR_HIL_FAULT_*: 1 timeout, 2 CRC, 4 counter, 8 range, "   \
              "16 format, 32 sync, 64 bus)")                                                  \
    X(fault_events, "fault events (a fault while latched counts too)")                        \
    X(crc, "commands with a wrong E2E CRC")                                                   \
    X(counter, "commands with a repeated or jumping alive counter")                           \
    X(range, "commands with a voltage out of range")                                          \
    X(format, "commands with a wrong DLC")                                                    \
    X(sync, "Syncs with an unexpected cycle index")                                           \
    X(bus, "bus faults (Bus Error operations with BusNotifications)")                         \
    X(timeout, "command timeouts (max_missed periods without a valid command)")               \
    X(cmd_missed, "periods without a valid command")                                          \
    X(zero_periods, "periods at 0 V forced by a fault, a timeout or a stop")                  \
    X(resets, "latches cleared by a fault-reset sequence")                                    \
    X(stop_rejected, "StopCmd frames ignored")                                                \
    X(stop_reason, "the honoured StopCmd's reason (-1: none)")                                \
    X(periods, "periods advanced")                                                            \
    X(state_out_of_range, "states that could not be encoded (outside the DBC range)")        \
    X(rx_unknown_id, "frames of an identifier not in the DBC")                                \
    X(rx_bad_dlc, "frames with a wrong DLC")                                                  \
    X(rx_bad_crc, "frames with a wrong E2E CRC")                                              \
    X(rx_out_of_range, "frames with a signal out of range")                                   \
    X(rx_ignored, "frames of the bench not meant for the plant")                              \
    X(frames_received, "CAN frames received")                                                 \
    X(frames_sent, "CAN frames sent")                                                         \
    X(format_errors_sent, "malformed operations received, answered with a Format Error")      \
    X(format_errors_received, "Format Errors received")                                       \
    X(notifications_ignored, "Confirm, Arbitration Lost, Bus Error ignored (BusNotifications " \
                             "false)")                                                        \
    X(tx_overflow, "operations dropped: Tx_Data full")                                        \
    X(peer_baudrate, "the CAN baud rate the other node configured, bit/s (0: none)")

#define PLANT_CAN_STATUS_ENUM(NAME, DESC) ps_##NAME,
enum { PLANT_CAN_STATUS(PLANT_CAN_STATUS_ENUM) PLANT_CAN_STATUS_COUNT };

/** Value references (= rows of the variable table in model.c); the terminal's four variables
 *  follow (fmu_bus.h). */
typedef enum plant_can_vr {
    vr_q = 0,                                  ///< q[1..3], output, rad
    vr_qd = vr_q + RRR_NJ,                     ///< qd[1..3], output, rad/s
    vr_qdd = vr_qd + RRR_NJ,                   ///< qdd[1..3], output, rad/s2
    vr_tip = vr_qdd + RRR_NJ,                  ///< tip.x, tip.y, tip.z, output, m
    vr_u = vr_tip + 3,                         ///< u[1..3], output: applied voltage, V
    vr_zero = vr_u + RRR_NJ,                   ///< zero, output: 0 V forced over the period
    vr_status,                                 ///< status.*, outputs: the counters
    vr_model = vr_status + PLANT_CAN_STATUS_COUNT, ///< the RRR_MV_COUNT model parameters
    vr_q0 = vr_model + RRR_MV_COUNT,           ///< q0[1..3], parameter, rad
    vr_qd0 = vr_q0 + RRR_NJ,                   ///< qd0[1..3], parameter, rad/s
    vr_h_int = vr_qd0 + RRR_NJ,                ///< h_int, parameter, s
    vr_adaptive,                               ///< adaptive, Boolean parameter
    vr_rtol,                                   ///< rtol, parameter
    vr_atol,                                   ///< atol, parameter
    vr_max_missed,                             ///< max_missed, parameter (supervisor)
    vr_max_delta_counter,                      ///< max_delta_counter, parameter (supervisor)
    vr_baudrate,                               ///< baudrate, parameter, bit/s
    vr_notifications,                          ///< BusNotifications, Boolean parameter
    vr_time,                                   ///< time, independent variable, s
    vr_count
} plant_can_vr;

/** Model data of one instance (plain old data: copied into FMU state snapshots). */
typedef struct plant_can_data {
    rrr_model model;                 ///< parameters
    rrr_plant_integrator integ;      ///< adaptive, rtol, atol, h_int, max_steps
    double q0[RRR_NJ];               ///< initial position, rad
    double qd0[RRR_NJ];              ///< initial velocity, rad/s
    double max_missed;               ///< supervisor: periods without a command before 0 V
    double max_delta_counter;        ///< supervisor: largest alive-counter step
    double baudrate;                 ///< the CAN baud rate, bit/s (Configuration)
    int notifications;               ///< BusNotifications
    rrr_plant_state x;               ///< q, qd (outputs) and the step-size memory
    double qdd[RRR_NJ];              ///< acceleration at x under u, rad/s2
    double tip[3];                   ///< tip position, m
    double u[RRR_NJ];                ///< voltage applied over the current period, V
    double zero;                     ///< 1: 0 V forced over the current period
    double status[PLANT_CAN_STATUS_COUNT]; ///< the counters as outputs
    rrr_hil_sup sup;                 ///< the command supervisor (hil_supervisor.h)
    double period_start;             ///< s: the start of the current period
    uint32_t k;                      ///< periods advanced
    uint32_t tx_state_range;         ///< states that could not be encoded
    uint32_t rx_bad[RRR_HIL_RX_COUNT]; ///< decode results of all frames
    uint32_t rx_ignored;             ///< bench frames not meant for the plant
    uint8_t period_open;             ///< the supervisor decided u for the current period
    uint8_t publish_due;             ///< publish the state of period k at the next event
    uint8_t booted;                  ///< the boot-up heartbeat was sent
    uint8_t hb_counter;              ///< heartbeat counter
    uint8_t ctrl_nmt;                ///< the controller's last NMT state (255: none)
    fmu_bus_state bus;               ///< the CAN terminal (fmu_bus.h)
} plant_can_data;

#endif /* RRR_FMU_PLANT_CAN_CONFIG_H */
