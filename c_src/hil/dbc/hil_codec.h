/**
 * @file hil_codec.h
 * @brief Frames of the CAN bench in SI units: encode and decode on top of the cantools code
 *        generated from python/rrr_robot/data/rrr_bench.dbc (gen/rrr_bench.[ch]), plus the
 *        AUTOSAR E2E profile 2 protection (CRC-8/AUTOSAR with a DataID, 4-bit alive counter).
 *
 * Pure functions: no I/O, no allocation, no globals. Decoders accept any (id, dlc, bytes) and
 * never read beyond dlc (they are fuzzed: fuzz_hil_decode.c).
 */
#ifndef RRR_HIL_CODEC_H
#define RRR_HIL_CODEC_H

#include <stddef.h>
#include <stdint.h>

#include "hil_common.h" /* rrr_hil_frame, RRR_HIL_PERIOD_S */
#include "rrr_bench.h"

/** Controller and plant heartbeat period, in periods. */
#define RRR_HIL_HEARTBEAT_PERIODS 100u

/** E2E DataIDs, mixed into the CRC (one per protected message; see the DBC comment). */
#define RRR_HIL_DATA_ID_VOLTAGE_CMD 0x10u
#define RRR_HIL_DATA_ID_STOP_CMD 0x11u
#define RRR_HIL_DATA_ID_JOINT_STATE1 0x21u  ///< + joint index 0..2
#define RRR_HIL_DATA_ID_PLANT_STATUS 0x30u

/** CANopen NMT states carried by the heartbeats. */
#define RRR_HIL_NMT_BOOT 0u
#define RRR_HIL_NMT_STOPPED 4u
#define RRR_HIL_NMT_OPERATIONAL 5u
#define RRR_HIL_NMT_PREOPERATIONAL 127u

/** Latched fault bits of PlantStatus.Faults. */
enum {
    RRR_HIL_FAULT_TIMEOUT = 1u,  ///< no valid command for max_missed consecutive periods
    RRR_HIL_FAULT_CRC = 2u,      ///< command with a wrong E2E CRC
    RRR_HIL_FAULT_COUNTER = 4u,  ///< repeated alive counter or a jump > max_delta_counter
    RRR_HIL_FAULT_RANGE = 8u,    ///< a voltage outside the DBC range [-30, 30] V
    RRR_HIL_FAULT_FORMAT = 16u,  ///< command with a wrong DLC
    RRR_HIL_FAULT_SYNC = 32u,    ///< lockstep Sync with an unexpected cycle index
    RRR_HIL_FAULT_BUS = 64u      ///< bus-off, or the controller disconnected
};

/** PlantStatus.State values. */
enum {
    RRR_HIL_PLANT_INIT = 0,    ///< not started
    RRR_HIL_PLANT_RUNNING = 1, ///< no fault latched
    RRR_HIL_PLANT_FAULT = 2,   ///< a fault is latched: 0 V
    RRR_HIL_PLANT_RESET = 3    ///< a fault is latched (0 V) and a fault reset is armed
};

/** StopCmd.Reason values: why the controller ends the run. */
typedef enum rrr_hil_stop_reason {
    RRR_HIL_STOP_END_OF_RUN = 0,  ///< the reference is complete
    RRR_HIL_STOP_INTERRUPTED = 1, ///< SIGINT or SIGTERM
    RRR_HIL_STOP_FAULT = 2,       ///< the controller cannot go on (e.g. a command it cannot encode)
    RRR_HIL_STOP_PLANT_LOST = 3,  ///< no joint state from the plant in time
    RRR_HIL_STOP_REASON_COUNT
} rrr_hil_stop_reason;

/** Kinds of bench messages. */
typedef enum rrr_hil_kind {
    RRR_HIL_SYNC = 0,
    RRR_HIL_VOLTAGE_CMD,
    RRR_HIL_JOINT_STATE,
    RRR_HIL_PLANT_STATUS,
    RRR_HIL_HEARTBEAT,
    RRR_HIL_STOP_CMD, ///< appended: the values above are mirrored by the Python binding
    RRR_HIL_KIND_COUNT
} rrr_hil_kind;

/** Result of decoding one frame. */
typedef enum rrr_hil_rx {
    RRR_HIL_RX_OK = 0,
    RRR_HIL_RX_UNKNOWN_ID,   ///< not a frame of the bench (or an extended id)
    RRR_HIL_RX_BAD_DLC,      ///< dlc differs from the DBC length
    RRR_HIL_RX_BAD_CRC,      ///< E2E CRC mismatch
    RRR_HIL_RX_OUT_OF_RANGE, ///< a signal outside its DBC range
    RRR_HIL_RX_COUNT
} rrr_hil_rx;

/** Sync (controller -> plant): start of period `cycle` in lockstep mode. */
typedef struct rrr_hil_sync {
    uint32_t cycle; ///< period index k
} rrr_hil_sync;

/** VoltageCmd (controller -> plant). */
typedef struct rrr_hil_voltage_cmd {
    uint8_t counter;     ///< alive counter 0..15
    uint8_t enable;      ///< 1: apply u_V; 0: apply 0 V
    uint8_t reset_fault; ///< 1 with enable = 0: clear latched faults
    double u_V[3];       ///< voltages, V, within [-30, 30]; quantised to 1 mV
} rrr_hil_voltage_cmd;

/**
 * StopCmd (controller -> plant): end the run. E2E protected like VoltageCmd (CRC-8 with its own
 * DataID), and its alive counter continues the VoltageCmd sequence, so the supervisor honours it
 * only as the next command of that sequence (rrr_hil_sup_on_stop).
 */
typedef struct rrr_hil_stop_cmd {
    uint8_t counter; ///< alive counter 0..15: the one after the last VoltageCmd's
    uint8_t reason;  ///< rrr_hil_stop_reason
} rrr_hil_stop_cmd;

/** JointState1..3 (plant -> controller). */
typedef struct rrr_hil_joint_state {
    uint8_t joint;   ///< 0, 1, 2
    uint8_t counter; ///< alive counter = period index mod 16
    double q_rad;    ///< position, rad, |q| <= 2147.48; quantised to 1e-6 rad
    double qd_rad_s; ///< velocity, rad/s, |qd| <= 52.4; quantised to 1e-4 rad/s
} rrr_hil_joint_state;

/** PlantStatus (plant -> controller). */
typedef struct rrr_hil_plant_status {
    uint8_t counter;      ///< alive counter
    uint8_t state;        ///< RRR_HIL_PLANT_*
    uint8_t faults;       ///< latched RRR_HIL_FAULT_* bits
    uint8_t zero_voltage; ///< 1 when 0 V was applied over the last period
    uint16_t fault_count; ///< fault events since start (saturating)
    uint16_t cmd_missed;  ///< periods without a valid command since start (saturating)
} rrr_hil_plant_status;

/** HeartbeatCtrl (node 1) or HeartbeatPlant (node 2). */
typedef struct rrr_hil_heartbeat {
    uint8_t node;      ///< 1 controller, 2 plant
    uint8_t nmt_state; ///< RRR_HIL_NMT_*
    uint8_t counter;   ///< increments with every heartbeat
} rrr_hil_heartbeat;

/** Any decoded bench message. */
typedef struct rrr_hil_msg {
    rrr_hil_kind kind; ///< which member is valid
    union {
        rrr_hil_sync sync;
        rrr_hil_voltage_cmd cmd;
        rrr_hil_joint_state joint;
        rrr_hil_plant_status status;
        rrr_hil_heartbeat heartbeat;
        rrr_hil_stop_cmd stop;
    } u;
} rrr_hil_msg;

/** CRC-8/AUTOSAR (poly 0x2F, init 0xFF, xorout 0xFF) of data[0..n) followed by data_id. */
uint8_t rrr_hil_crc8_e2e(const uint8_t *data, size_t n, uint8_t data_id);

/**
 * @brief Decode one frame.
 * @param[in]  f   frame (dlc > 8 is treated as a wrong DLC)
 * @param[out] out the message, written only on RRR_HIL_RX_OK; for RRR_HIL_RX_BAD_CRC,
 *                 RRR_HIL_RX_BAD_DLC and RRR_HIL_RX_OUT_OF_RANGE, out->kind still names the message
 *                 the id belongs to
 * @return RRR_HIL_RX_OK or the reason the frame was rejected
 */
rrr_hil_rx rrr_hil_decode(const rrr_hil_frame *f, rrr_hil_msg *out);

/** @brief Encoders; each returns 0, or -1 (frame untouched) if a value is outside its DBC range
 *  or not finite. The E2E CRC is filled in. */
int rrr_hil_encode_sync(const rrr_hil_sync *m, rrr_hil_frame *f);
int rrr_hil_encode_voltage_cmd(const rrr_hil_voltage_cmd *m, rrr_hil_frame *f);
int rrr_hil_encode_joint_state(const rrr_hil_joint_state *m, rrr_hil_frame *f);
int rrr_hil_encode_plant_status(const rrr_hil_plant_status *m, rrr_hil_frame *f);
int rrr_hil_encode_heartbeat(const rrr_hil_heartbeat *m, rrr_hil_frame *f);
int rrr_hil_encode_stop_cmd(const rrr_hil_stop_cmd *m, rrr_hil_frame *f);

/** Static name of a decode result ("ok", "unknown id", ...). */
const char *rrr_hil_rx_str(rrr_hil_rx rx);

/** Static name of a stop reason ("end of run", "interrupted", "fault", "plant lost"). */
const char *rrr_hil_stop_reason_str(unsigned reason);

#endif /* RRR_HIL_CODEC_H */
