/*
 * FMI-LS-BUS 1.0 CAN operations as bytes (fmu_lsbus.h). Every field is read and written byte by
 * byte in little-endian order, so the code does not depend on the host's byte order or
 * alignment; the standard's packed structs (the vendored fmi3LsBusCan.h) fix the sizes, which
 * the assertions below check against the lengths used here.
 */
#include "fmu_lsbus.h"

#include <string.h>

#include "fmi3LsBusCan.h"

_Static_assert(sizeof(fmi3LsBusOperationHeader) == FMU_LSBUS_HEADER, "header");
_Static_assert(sizeof(fmi3LsBusCanOperationCanTransmit) == FMU_LSBUS_CAN_TRANSMIT_HEADER,
               "CAN Transmit");
_Static_assert(sizeof(fmi3LsBusCanOperationCanFdTransmit) == FMU_LSBUS_CANFD_TRANSMIT_HEADER,
               "CAN FD Transmit");
_Static_assert(sizeof(fmi3LsBusCanOperationCanXlTransmit) == FMU_LSBUS_CANXL_TRANSMIT_HEADER,
               "CAN XL Transmit");
_Static_assert(sizeof(fmi3LsBusOperationFormatError) == FMU_LSBUS_FORMAT_ERROR_HEADER,
               "Format Error");
_Static_assert(sizeof(fmi3LsBusCanOperationConfirm) == FMU_LSBUS_CONFIRM_LENGTH, "Confirm");
_Static_assert(sizeof(fmi3LsBusCanOperationArbitrationLost) == FMU_LSBUS_ARBITRATION_LOST_LENGTH,
               "Arbitration Lost");
_Static_assert(sizeof(fmi3LsBusCanOperationBusError) == FMU_LSBUS_BUS_ERROR_LENGTH, "Bus Error");
_Static_assert(sizeof(fmi3LsBusCanOperationStatus) == FMU_LSBUS_STATUS_LENGTH, "Status");
_Static_assert(sizeof(fmi3LsBusCanOperationWakeup) == FMU_LSBUS_WAKEUP_LENGTH, "Wakeup");
_Static_assert(FMI3_LS_BUS_OP_FORMAT_ERROR == FMU_LSBUS_OP_FORMAT_ERROR &&
                   FMI3_LS_BUS_CAN_OP_CAN_TRANSMIT == FMU_LSBUS_OP_CAN_TRANSMIT &&
                   FMI3_LS_BUS_CAN_OP_CANFD_TRANSMIT == FMU_LSBUS_OP_CANFD_TRANSMIT &&
                   FMI3_LS_BUS_CAN_OP_CANXL_TRANSMIT == FMU_LSBUS_OP_CANXL_TRANSMIT &&
                   FMI3_LS_BUS_CAN_OP_CONFIRM == FMU_LSBUS_OP_CONFIRM &&
                   FMI3_LS_BUS_CAN_OP_ARBITRATION_LOST == FMU_LSBUS_OP_ARBITRATION_LOST &&
                   FMI3_LS_BUS_CAN_OP_BUS_ERROR == FMU_LSBUS_OP_BUS_ERROR &&
                   FMI3_LS_BUS_CAN_OP_CONFIGURATION == FMU_LSBUS_OP_CONFIGURATION &&
                   FMI3_LS_BUS_CAN_OP_STATUS == FMU_LSBUS_OP_STATUS &&
                   FMI3_LS_BUS_CAN_OP_WAKEUP == FMU_LSBUS_OP_WAKEUP,
               "the OP Codes of the standard's headers");
_Static_assert(FMI3_LS_BUS_CAN_CONFIG_PARAM_TYPE_CAN_BAUDRATE == FMU_LSBUS_CONFIG_CAN_BAUDRATE &&
                   FMI3_LS_BUS_CAN_CONFIG_PARAM_TYPE_CANFD_BAUDRATE ==
                       FMU_LSBUS_CONFIG_CANFD_BAUDRATE &&
                   FMI3_LS_BUS_CAN_CONFIG_PARAM_TYPE_CANXL_BAUDRATE ==
                       FMU_LSBUS_CONFIG_CANXL_BAUDRATE &&
                   FMI3_LS_BUS_CAN_CONFIG_PARAM_TYPE_ARBITRATION_LOST_BEHAVIOR ==
                       FMU_LSBUS_CONFIG_ARBITRATION_LOST_BEHAVIOR,
               "the Configuration parameters of the standard's headers");

static uint32_t get32(const uint8_t *p)
{
    return (uint32_t)p[0] | (uint32_t)p[1] << 8 | (uint32_t)p[2] << 16 | (uint32_t)p[3] << 24;
}

static uint16_t get16(const uint8_t *p)
{
    return (uint16_t)(p[0] | p[1] << 8);
}

static void put32(uint8_t *p, uint32_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    p[2] = (uint8_t)(v >> 16);
    p[3] = (uint8_t)(v >> 24);
}

static void put16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
}

/* The arguments of a delimited operation (len bytes at p, len >= 8): FMU_LSBUS_OK when they
 * match the OP Code, else FMU_LSBUS_BAD. */
static fmu_lsbus_result decode(const uint8_t *p, uint32_t len, fmu_lsbus_op *op)
{
    switch (op->opcode) {
    case FMU_LSBUS_OP_CAN_TRANSMIT:
        if (len < FMU_LSBUS_CAN_TRANSMIT_HEADER) {
            return FMU_LSBUS_BAD;
        }
        op->id = get32(p + 8);
        op->ide = p[12];
        op->rtr = p[13];
        op->data_length = get16(p + 14);
        op->data = p + FMU_LSBUS_CAN_TRANSMIT_HEADER;
        return op->data_length == len - FMU_LSBUS_CAN_TRANSMIT_HEADER &&
                       op->data_length <= FMU_LSBUS_CAN_MAX_DATA && op->ide <= 1u && op->rtr <= 1u
                   ? FMU_LSBUS_OK
                   : FMU_LSBUS_BAD;
    case FMU_LSBUS_OP_CANFD_TRANSMIT:
        if (len < FMU_LSBUS_CANFD_TRANSMIT_HEADER) {
            return FMU_LSBUS_BAD;
        }
        op->id = get32(p + 8);
        op->ide = p[12];
        op->brs = p[13];
        op->esi = p[14];
        op->data_length = get16(p + 15);
        op->data = p + FMU_LSBUS_CANFD_TRANSMIT_HEADER;
        return op->data_length == len - FMU_LSBUS_CANFD_TRANSMIT_HEADER &&
                       op->data_length <= FMU_LSBUS_CANFD_MAX_DATA && op->ide <= 1u &&
                       op->brs <= 1u && op->esi <= 1u
                   ? FMU_LSBUS_OK
                   : FMU_LSBUS_BAD;
    case FMU_LSBUS_OP_CANXL_TRANSMIT:
        if (len < FMU_LSBUS_CANXL_TRANSMIT_HEADER) {
            return FMU_LSBUS_BAD;
        }
        op->id = get32(p + 8);
        op->ide = p[12];
        op->data_length = get16(p + 20);
        op->data = p + FMU_LSBUS_CANXL_TRANSMIT_HEADER;
        return op->data_length == len - FMU_LSBUS_CANXL_TRANSMIT_HEADER &&
                       op->data_length >= 1u && op->data_length <= FMU_LSBUS_CANXL_MAX_DATA
                   ? FMU_LSBUS_OK
                   : FMU_LSBUS_BAD;
    case FMU_LSBUS_OP_FORMAT_ERROR:
        if (len < FMU_LSBUS_FORMAT_ERROR_HEADER) {
            return FMU_LSBUS_BAD;
        }
        op->data_length = get16(p + 8);
        op->data = p + FMU_LSBUS_FORMAT_ERROR_HEADER;
        return op->data_length == len - FMU_LSBUS_FORMAT_ERROR_HEADER ? FMU_LSBUS_OK
                                                                      : FMU_LSBUS_BAD;
    case FMU_LSBUS_OP_CONFIRM:
    case FMU_LSBUS_OP_ARBITRATION_LOST:
        if (len != FMU_LSBUS_CONFIRM_LENGTH) {
            return FMU_LSBUS_BAD;
        }
        op->id = get32(p + 8);
        return FMU_LSBUS_OK;
    case FMU_LSBUS_OP_BUS_ERROR:
        if (len != FMU_LSBUS_BUS_ERROR_LENGTH) {
            return FMU_LSBUS_BAD;
        }
        op->id = get32(p + 8);
        op->error_code = p[12];
        op->error_flag = p[13];
        op->is_sender = p[14];
        return FMU_LSBUS_OK;
    case FMU_LSBUS_OP_CONFIGURATION:
        if (len < FMU_LSBUS_HEADER + 1u) {
            return FMU_LSBUS_BAD;
        }
        op->parameter = p[8];
        if (op->parameter >= FMU_LSBUS_CONFIG_CAN_BAUDRATE &&
            op->parameter <= FMU_LSBUS_CONFIG_CANXL_BAUDRATE) {
            if (len != FMU_LSBUS_CONFIG_BAUDRATE_LENGTH) {
                return FMU_LSBUS_BAD;
            }
            op->baudrate = get32(p + 9);
            return FMU_LSBUS_OK;
        }
        if (op->parameter == FMU_LSBUS_CONFIG_ARBITRATION_LOST_BEHAVIOR &&
            len == FMU_LSBUS_CONFIG_BEHAVIOR_LENGTH) {
            op->behavior = p[9];
            return FMU_LSBUS_OK;
        }
        return FMU_LSBUS_BAD;
    case FMU_LSBUS_OP_STATUS:
        if (len != FMU_LSBUS_STATUS_LENGTH) {
            return FMU_LSBUS_BAD;
        }
        op->status = p[8];
        return op->status >= FMU_LSBUS_STATUS_ERROR_ACTIVE && op->status <= FMU_LSBUS_STATUS_BUS_OFF
                   ? FMU_LSBUS_OK
                   : FMU_LSBUS_BAD;
    case FMU_LSBUS_OP_WAKEUP:
        return len == FMU_LSBUS_WAKEUP_LENGTH ? FMU_LSBUS_OK : FMU_LSBUS_BAD;
    default:
        return FMU_LSBUS_BAD; /* an unknown OP Code */
    }
}

fmu_lsbus_result fmu_lsbus_next(const uint8_t *buf, size_t n, size_t *pos, fmu_lsbus_op *op)
{
    memset(op, 0, sizeof *op);
    if (buf == NULL || *pos >= n) {
        *pos = n;
        return FMU_LSBUS_END;
    }
    const uint8_t *p = buf + *pos;
    const size_t left = n - *pos;
    op->bytes = p;
    if (left < FMU_LSBUS_HEADER) {
        op->opcode = 0u;
        op->length = (uint32_t)left;
        *pos = n;
        return FMU_LSBUS_CUT;
    }
    op->opcode = get32(p);
    const uint32_t len = get32(p + 4);
    if (len < FMU_LSBUS_HEADER || len > left) {
        op->length = (uint32_t)(left > UINT32_MAX ? UINT32_MAX : left);
        *pos = n;
        return FMU_LSBUS_CUT;
    }
    op->length = len;
    *pos += len;
    const fmu_lsbus_result r = decode(p, len, op);
    if (r != FMU_LSBUS_OK) {
        /* keep what a Format Error needs: the operation's bytes and OP Code */
        const uint32_t code = op->opcode;
        memset(op, 0, sizeof *op);
        op->opcode = code;
        op->length = len;
        op->bytes = p;
    }
    return r;
}

int fmu_lsbus_is_notification(uint32_t opcode)
{
    return opcode == FMU_LSBUS_OP_CONFIRM || opcode == FMU_LSBUS_OP_ARBITRATION_LOST ||
           opcode == FMU_LSBUS_OP_BUS_ERROR;
}

size_t fmu_lsbus_put_can_transmit(uint8_t *out, size_t room, uint32_t id, int ide, int rtr,
                                  const uint8_t *data, size_t n)
{
    const size_t len = FMU_LSBUS_CAN_TRANSMIT_HEADER + n;
    if (out == NULL || n > FMU_LSBUS_CAN_MAX_DATA || len > room || (n > 0u && data == NULL)) {
        return 0u;
    }
    put32(out, FMU_LSBUS_OP_CAN_TRANSMIT);
    put32(out + 4, (uint32_t)len);
    put32(out + 8, id);
    out[12] = ide ? 1u : 0u;
    out[13] = rtr ? 1u : 0u;
    put16(out + 14, (uint16_t)n);
    if (n > 0u) {
        memcpy(out + FMU_LSBUS_CAN_TRANSMIT_HEADER, data, n);
    }
    return len;
}

size_t fmu_lsbus_put_config_baudrate(uint8_t *out, size_t room, uint8_t parameter,
                                     uint32_t baudrate)
{
    if (out == NULL || room < FMU_LSBUS_CONFIG_BAUDRATE_LENGTH ||
        parameter < FMU_LSBUS_CONFIG_CAN_BAUDRATE || parameter > FMU_LSBUS_CONFIG_CANXL_BAUDRATE) {
        return 0u;
    }
    put32(out, FMU_LSBUS_OP_CONFIGURATION);
    put32(out + 4, FMU_LSBUS_CONFIG_BAUDRATE_LENGTH);
    out[8] = parameter;
    put32(out + 9, baudrate);
    return FMU_LSBUS_CONFIG_BAUDRATE_LENGTH;
}

size_t fmu_lsbus_put_format_error(uint8_t *out, size_t room, const uint8_t *op, size_t n)
{
    const size_t len = FMU_LSBUS_FORMAT_ERROR_HEADER + n;
    if (out == NULL || n > UINT16_MAX || len > room || (n > 0u && op == NULL)) {
        return 0u;
    }
    put32(out, FMU_LSBUS_OP_FORMAT_ERROR);
    put32(out + 4, (uint32_t)len);
    put16(out + 8, (uint16_t)n);
    if (n > 0u) {
        memmove(out + FMU_LSBUS_FORMAT_ERROR_HEADER, op, n);
    }
    return len;
}

const char *fmu_lsbus_op_name(uint32_t opcode)
{
    switch (opcode) {
    case FMU_LSBUS_OP_FORMAT_ERROR:
        return "Format Error";
    case FMU_LSBUS_OP_CAN_TRANSMIT:
        return "CAN Transmit";
    case FMU_LSBUS_OP_CANFD_TRANSMIT:
        return "CAN FD Transmit";
    case FMU_LSBUS_OP_CANXL_TRANSMIT:
        return "CAN XL Transmit";
    case FMU_LSBUS_OP_CONFIRM:
        return "Confirm";
    case FMU_LSBUS_OP_ARBITRATION_LOST:
        return "Arbitration Lost";
    case FMU_LSBUS_OP_BUS_ERROR:
        return "Bus Error";
    case FMU_LSBUS_OP_CONFIGURATION:
        return "Configuration";
    case FMU_LSBUS_OP_STATUS:
        return "Status";
    case FMU_LSBUS_OP_WAKEUP:
        return "Wakeup";
    default:
        return "unknown";
    }
}
