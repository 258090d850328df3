/**
 * @file fmu_lsbus.h
 * @brief FMI-LS-BUS 1.0 CAN bus operations as bytes: the walk over a received Rx_Data value and
 *        the operations the network FMUs send. Pure: no I/O, no allocation, no globals; any
 *        input is accepted and never read past its end (fuzzed: fmu/fuzz/fuzz_lsbus_ops.c).
 *
 * An operation is little-endian and packed: u32 opCode, u32 length (the whole operation, header
 * included), then the arguments (the standard's byte table; the packed structs of the vendored
 * third_party/fmi-ls-bus/headers/fmi3LsBusCan.h, whose sizes fmu_lsbus.c checks). Several
 * operations may be concatenated in one Binary value: fmu_lsbus_next walks them by `length`.
 *
 * What is a malformed ("corrupt") operation, answered with a Format Error that carries it
 * (FMI-LS-BUS 1.0, 4.3.1 "Format Error": an unknown OP Code or an invalid length):
 *  - a length below the 8-byte header or past the end of the value: the rest of the value cannot
 *    be delimited, so the walk stops there (FMU_LSBUS_CUT);
 *  - an unknown OP Code, or a known one whose length does not match its arguments (a CAN
 *    Transmit whose Data Length is not length - 16 or above 8 bytes, a CAN FD Transmit above 64
 *    bytes, a Configuration of an unknown parameter, ...): the walk goes on after it
 *    (FMU_LSBUS_BAD).
 */
#ifndef FMU_LSBUS_H
#define FMU_LSBUS_H

#include <stddef.h>
#include <stdint.h>

/** The operation codes (the values of fmi3LsBus.h and fmi3LsBusCan.h). */
enum {
    FMU_LSBUS_OP_FORMAT_ERROR = 0x0001u,
    FMU_LSBUS_OP_CAN_TRANSMIT = 0x0010u,
    FMU_LSBUS_OP_CANFD_TRANSMIT = 0x0011u,
    FMU_LSBUS_OP_CANXL_TRANSMIT = 0x0012u,
    FMU_LSBUS_OP_CONFIRM = 0x0020u,
    FMU_LSBUS_OP_ARBITRATION_LOST = 0x0030u,
    FMU_LSBUS_OP_BUS_ERROR = 0x0031u,
    FMU_LSBUS_OP_CONFIGURATION = 0x0040u,
    FMU_LSBUS_OP_STATUS = 0x0041u,
    FMU_LSBUS_OP_WAKEUP = 0x0042u
};

/** Configuration parameters (fmi3LsBusCan.h). */
enum {
    FMU_LSBUS_CONFIG_CAN_BAUDRATE = 0x01u,
    FMU_LSBUS_CONFIG_CANFD_BAUDRATE = 0x02u,
    FMU_LSBUS_CONFIG_CANXL_BAUDRATE = 0x03u,
    FMU_LSBUS_CONFIG_ARBITRATION_LOST_BEHAVIOR = 0x04u
};

/** Status kinds (fmi3LsBusCan.h). */
enum {
    FMU_LSBUS_STATUS_ERROR_ACTIVE = 0x01u,
    FMU_LSBUS_STATUS_ERROR_PASSIVE = 0x02u,
    FMU_LSBUS_STATUS_BUS_OFF = 0x03u
};

/** Bytes of the header and of each fixed-size operation (the standard's byte table). */
#define FMU_LSBUS_HEADER 8u
#define FMU_LSBUS_CAN_TRANSMIT_HEADER 16u   ///< + data
#define FMU_LSBUS_CANFD_TRANSMIT_HEADER 17u ///< + data
#define FMU_LSBUS_CANXL_TRANSMIT_HEADER 22u ///< + data
#define FMU_LSBUS_FORMAT_ERROR_HEADER 10u   ///< + the offending operation
#define FMU_LSBUS_CONFIRM_LENGTH 12u
#define FMU_LSBUS_ARBITRATION_LOST_LENGTH 12u
#define FMU_LSBUS_BUS_ERROR_LENGTH 15u
#define FMU_LSBUS_CONFIG_BAUDRATE_LENGTH 13u
#define FMU_LSBUS_CONFIG_BEHAVIOR_LENGTH 10u
#define FMU_LSBUS_STATUS_LENGTH 9u
#define FMU_LSBUS_WAKEUP_LENGTH 8u
/** Largest data of a CAN and a CAN FD frame, bytes. */
#define FMU_LSBUS_CAN_MAX_DATA 8u
#define FMU_LSBUS_CANFD_MAX_DATA 64u
#define FMU_LSBUS_CANXL_MAX_DATA 2048u

/** What fmu_lsbus_next made of the operation at the read position. */
typedef enum fmu_lsbus_result {
    FMU_LSBUS_END = 0,  ///< no bytes left: the walk is complete
    FMU_LSBUS_OK,       ///< a well-formed operation of a known OP Code (op filled)
    FMU_LSBUS_BAD,      ///< delimited by its length but malformed or unknown (op.bytes, op.length)
    FMU_LSBUS_CUT       ///< a length below 8 or past the end: op.bytes/op.length are the rest of
                        ///< the value, and the walk ends
} fmu_lsbus_result;

/** One operation, decoded (the fields of its OP Code; the others 0). */
typedef struct fmu_lsbus_op {
    uint32_t opcode;       ///< OP Code (as read, also for a malformed operation when present)
    uint32_t length;       ///< bytes of the operation (for FMU_LSBUS_CUT: the bytes left)
    const uint8_t *bytes;  ///< the whole operation in the value
    uint32_t id;           ///< CAN identifier (Transmit, Confirm, Arbitration Lost, Bus Error)
    uint8_t ide;           ///< 1: extended (29-bit) identifier (Transmit)
    uint8_t rtr;           ///< remote request (CAN Transmit)
    uint8_t brs, esi;      ///< CAN FD Transmit
    uint16_t data_length;  ///< bytes of data (Transmit, Format Error)
    const uint8_t *data;   ///< the data (Transmit, Format Error)
    uint8_t parameter;     ///< Configuration: FMU_LSBUS_CONFIG_*
    uint32_t baudrate;     ///< Configuration of a baud rate, bit/s
    uint8_t behavior;      ///< Configuration of the arbitration-lost behaviour
    uint8_t error_code, error_flag, is_sender; ///< Bus Error
    uint8_t status;        ///< Status: FMU_LSBUS_STATUS_*
} fmu_lsbus_op;

/**
 * @brief The operation at buf[*pos..n): decodes it into op and moves *pos past it (for
 *        FMU_LSBUS_CUT to n). Never reads outside buf[0..n).
 * @return FMU_LSBUS_END when *pos >= n, else the kind of operation found
 */
fmu_lsbus_result fmu_lsbus_next(const uint8_t *buf, size_t n, size_t *pos, fmu_lsbus_op *op);

/** @brief 1 for the notifications a node may wait for when BusNotifications is true (Confirm,
 *         Arbitration Lost, Bus Error), which it must ignore silently otherwise. */
int fmu_lsbus_is_notification(uint32_t opcode);

/**
 * @brief Append a CAN Transmit (id, ide, rtr, n data bytes) to out[0..room).
 * @return bytes written (16 + n), or 0 when it does not fit or n > 8 (nothing written)
 */
size_t fmu_lsbus_put_can_transmit(uint8_t *out, size_t room, uint32_t id, int ide, int rtr,
                                  const uint8_t *data, size_t n);

/** @brief Append a Configuration of a baud rate (parameter FMU_LSBUS_CONFIG_*_BAUDRATE):
 *         13 bytes, or 0 when they do not fit. */
size_t fmu_lsbus_put_config_baudrate(uint8_t *out, size_t room, uint8_t parameter,
                                     uint32_t baudrate);

/** @brief Append a Format Error that carries the n bytes of the offending operation (at most
 *         65535): 10 + n bytes, or 0 when they do not fit. */
size_t fmu_lsbus_put_format_error(uint8_t *out, size_t room, const uint8_t *op, size_t n);

/** @brief Static name of an OP Code ("CAN Transmit", ...; "unknown" for others). */
const char *fmu_lsbus_op_name(uint32_t opcode);

#endif /* FMU_LSBUS_H */
