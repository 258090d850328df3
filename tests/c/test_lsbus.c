/* FMI-LS-BUS 1.0 CAN operations (fmu/common/fmu_lsbus.c) against the standard's byte table,
 * hostile operations (unknown OP Code, a length past the end, zero length, a data length above
 * 8 and above 64, concatenations cut in the middle) walked without reading outside the value,
 * and the plant's network FMU (fmu/plant_can, linked in with the FMI 3.0 adapter) answering
 * them as the standard says: a Format Error carrying the operation, notifications ignored while
 * BusNotifications is false, and the safety policy (no command -> 0 V and the latched fault).
 * Runs under ASan and UBSan in CTest. */
#include "config.h" /* plant_can's: first (fmu_model.h) */

#include <stdarg.h>
#include <stdbool.h>
#include <stdio.h>
#include <string.h>

#include "fmi3Functions.h"
#include "fmu_lsbus.h"
#include "rrr_test.h"

/* ---- the byte table ------------------------------------------------------------------------ */

static int same(const uint8_t *a, const uint8_t *b, size_t n)
{
    return memcmp(a, b, n) == 0;
}

static void test_golden_bytes(void)
{
    uint8_t out[64];
    /* FMI-LS-BUS 1.0, CAN Transmit: OP Code 0x10, length 16 + n, id, ide, rtr, u16 n, data */
    static const uint8_t data[8] = {0x5a, 0x15, 0x39, 0x30, 0x80, 0xf3, 0x2c, 0x01};
    static const uint8_t transmit[24] = {0x10, 0x00, 0x00, 0x00, 0x18, 0x00, 0x00, 0x00,
                                         0x00, 0x01, 0x00, 0x00, 0x00, 0x00, 0x08, 0x00,
                                         0x5a, 0x15, 0x39, 0x30, 0x80, 0xf3, 0x2c, 0x01};
    CHECK(fmu_lsbus_put_can_transmit(out, sizeof out, 0x100, 0, 0, data, 8) == 24);
    CHECK(same(out, transmit, 24));
    /* an extended identifier, no data */
    static const uint8_t ext[16] = {0x10, 0, 0, 0, 0x10, 0, 0, 0, 0x78, 0x56, 0x34, 0x12, 1, 0, 0, 0};
    CHECK(fmu_lsbus_put_can_transmit(out, sizeof out, 0x12345678u, 1, 0, NULL, 0) == 16);
    CHECK(same(out, ext, 16));
    /* Configuration: OP Code 0x40, length 13, parameter 0x01 (CAN baud rate), u32 baud rate */
    static const uint8_t config[13] = {0x40, 0, 0, 0, 0x0d, 0, 0, 0, 0x01, 0x40, 0x42, 0x0f, 0x00};
    CHECK(fmu_lsbus_put_config_baudrate(out, sizeof out, FMU_LSBUS_CONFIG_CAN_BAUDRATE,
                                        1000000u) == 13);
    CHECK(same(out, config, 13));
    static const uint8_t config250[13] = {0x40, 0, 0, 0, 0x0d, 0, 0, 0, 0x01, 0x90, 0xd0, 0x03, 0};
    CHECK(fmu_lsbus_put_config_baudrate(out, sizeof out, FMU_LSBUS_CONFIG_CAN_BAUDRATE,
                                        250000u) == 13);
    CHECK(same(out, config250, 13));
    /* Format Error: OP Code 0x01, length 10 + n, u16 n, the offending operation */
    static const uint8_t bad[8] = {0x99, 0, 0, 0, 0x08, 0, 0, 0};
    static const uint8_t format_error[18] = {0x01, 0, 0, 0, 0x12, 0, 0, 0, 0x08, 0x00,
                                             0x99, 0, 0, 0, 0x08, 0, 0, 0};
    CHECK(fmu_lsbus_put_format_error(out, sizeof out, bad, 8) == 18);
    CHECK(same(out, format_error, 18));
    /* writers refuse what does not fit or is not a classical frame, writing nothing */
    memset(out, 0xAA, sizeof out);
    CHECK(fmu_lsbus_put_can_transmit(out, 23, 0x100, 0, 0, data, 8) == 0);
    CHECK(fmu_lsbus_put_can_transmit(out, sizeof out, 0x100, 0, 0, data, 9) == 0);
    CHECK(fmu_lsbus_put_config_baudrate(out, 12, 1, 1000000u) == 0);
    CHECK(fmu_lsbus_put_config_baudrate(out, sizeof out, 4, 1000000u) == 0);
    CHECK(out[0] == 0xAA);

    /* reading every operation of the byte table back */
    static const uint8_t ops[] = {
        0x10, 0, 0, 0, 0x18, 0, 0, 0, 0x00, 0x01, 0, 0, 0, 0, 0x08, 0,           /* Transmit */
        0x5a, 0x15, 0x39, 0x30, 0x80, 0xf3, 0x2c, 0x01,
        0x11, 0, 0, 0, 0x13, 0, 0, 0, 0x01, 0x02, 0, 0, 0, 1, 0, 0x02, 0, 0xAB, 0xCD, /* FD */
        0x20, 0, 0, 0, 0x0c, 0, 0, 0, 0x00, 0x01, 0, 0,                         /* Confirm */
        0x30, 0, 0, 0, 0x0c, 0, 0, 0, 0x02, 0x01, 0, 0,                         /* Arb. lost */
        0x31, 0, 0, 0, 0x0f, 0, 0, 0, 0x10, 0x01, 0, 0, 0x04, 0x01, 0x01,       /* Bus Error */
        0x40, 0, 0, 0, 0x0a, 0, 0, 0, 0x04, 0x02,                               /* Config arb */
        0x41, 0, 0, 0, 0x09, 0, 0, 0, 0x03,                                     /* Status */
        0x42, 0, 0, 0, 0x08, 0, 0, 0,                                           /* Wakeup */
        0x40, 0, 0, 0, 0x0d, 0, 0, 0, 0x01, 0x40, 0x42, 0x0f, 0x00};            /* Config */
    static const uint32_t codes[] = {0x10, 0x11, 0x20, 0x30, 0x31, 0x40, 0x41, 0x42, 0x40};
    size_t pos = 0;
    fmu_lsbus_op op;
    for (size_t i = 0; i < sizeof codes / sizeof codes[0]; ++i) {
        CHECK(fmu_lsbus_next(ops, sizeof ops, &pos, &op) == FMU_LSBUS_OK);
        CHECK(op.opcode == codes[i]);
        if (i == 0) {
            CHECK(op.id == 0x100 && op.ide == 0 && op.data_length == 8 && same(op.data, data, 8));
        } else if (i == 1) {
            CHECK(op.id == 0x201 && op.brs == 1 && op.esi == 0 && op.data_length == 2 &&
                  op.data[0] == 0xAB && op.data[1] == 0xCD);
        } else if (i == 2 || i == 3) {
            CHECK(op.id == (i == 2 ? 0x100u : 0x102u));
        } else if (i == 4) {
            CHECK(op.id == 0x110 && op.error_code == 4 && op.error_flag == 1 && op.is_sender == 1);
        } else if (i == 5) {
            CHECK(op.parameter == 4 && op.behavior == 2);
        } else if (i == 6) {
            CHECK(op.status == FMU_LSBUS_STATUS_BUS_OFF);
        } else if (i == 8) {
            CHECK(op.parameter == 1 && op.baudrate == 1000000u);
        }
    }
    CHECK(pos == sizeof ops);
    CHECK(fmu_lsbus_next(ops, sizeof ops, &pos, &op) == FMU_LSBUS_END);
    CHECK(fmu_lsbus_is_notification(0x20) && fmu_lsbus_is_notification(0x30) &&
          fmu_lsbus_is_notification(0x31) && !fmu_lsbus_is_notification(0x10) &&
          !fmu_lsbus_is_notification(0x41));
}

/* ---- hostile operations -------------------------------------------------------------------- */

/* Walk buf; the kinds found, in order, into kinds (at most 16); returns their count. */
static size_t walk(const uint8_t *buf, size_t n, fmu_lsbus_result kinds[16])
{
    size_t pos = 0, count = 0;
    fmu_lsbus_op op;
    fmu_lsbus_result r;
    while ((r = fmu_lsbus_next(buf, n, &pos, &op)) != FMU_LSBUS_END && count < 16) {
        CHECK(pos <= n);
        CHECK(op.bytes >= buf && op.bytes + op.length <= buf + n);
        kinds[count++] = r;
    }
    return count;
}

static void test_hostile(void)
{
    fmu_lsbus_result k[16];
    /* unknown OP Code with a valid length: BAD, and the walk goes on */
    const uint8_t unknown[] = {0x77, 0, 0, 0, 0x0a, 0, 0, 0, 1, 2, 0x42, 0, 0, 0, 8, 0, 0, 0};
    CHECK(walk(unknown, sizeof unknown, k) == 2 && k[0] == FMU_LSBUS_BAD && k[1] == FMU_LSBUS_OK);
    /* a length past the end: CUT, the rest cannot be delimited */
    const uint8_t past[] = {0x10, 0, 0, 0, 0xff, 0, 0, 0, 0, 1, 0, 0, 0, 0, 8, 0};
    CHECK(walk(past, sizeof past, k) == 1 && k[0] == FMU_LSBUS_CUT);
    /* zero length (and any below the header): CUT, never a loop */
    const uint8_t zero[] = {0x10, 0, 0, 0, 0, 0, 0, 0, 0x42, 0, 0, 0, 8, 0, 0, 0};
    CHECK(walk(zero, sizeof zero, k) == 1 && k[0] == FMU_LSBUS_CUT);
    const uint8_t seven[] = {0x42, 0, 0, 0, 7, 0, 0, 0};
    CHECK(walk(seven, sizeof seven, k) == 1 && k[0] == FMU_LSBUS_CUT);
    /* a CAN Transmit with 9 data bytes, and one of 65 (above CAN FD's 64): BAD */
    uint8_t nine[25] = {0x10, 0, 0, 0, 25, 0, 0, 0, 0, 1, 0, 0, 0, 0, 9, 0};
    CHECK(walk(nine, sizeof nine, k) == 1 && k[0] == FMU_LSBUS_BAD);
    uint8_t fd65[17 + 65] = {0x11, 0, 0, 0, 17 + 65, 0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 65, 0};
    CHECK(walk(fd65, sizeof fd65, k) == 1 && k[0] == FMU_LSBUS_BAD);
    uint8_t fd64[17 + 64] = {0x11, 0, 0, 0, 17 + 64, 0, 0, 0, 0, 1, 0, 0, 0, 1, 0, 64, 0};
    CHECK(walk(fd64, sizeof fd64, k) == 1 && k[0] == FMU_LSBUS_OK);
    /* a data length that disagrees with the operation's length */
    const uint8_t liar[] = {0x10, 0, 0, 0, 0x10, 0, 0, 0, 0, 1, 0, 0, 0, 0, 8, 0};
    CHECK(walk(liar, sizeof liar, k) == 1 && k[0] == FMU_LSBUS_BAD);
    /* a concatenation cut in the middle of its second operation, and in its header */
    uint8_t two[24 + 12];
    CHECK(fmu_lsbus_put_can_transmit(two, sizeof two, 0x100, 0, 0, two, 8) == 24);
    memcpy(two + 24, two, 12);
    CHECK(walk(two, sizeof two, k) == 2 && k[0] == FMU_LSBUS_OK && k[1] == FMU_LSBUS_CUT);
    CHECK(walk(two, 24 + 5, k) == 2 && k[1] == FMU_LSBUS_CUT);
    for (size_t n = 0; n < 24; ++n) { /* every cut of one operation */
        const size_t found = walk(two, n, k);
        CHECK(found == (n == 0 ? 0u : 1u) && (n == 0 || k[0] == FMU_LSBUS_CUT));
    }
    /* Status of an unknown kind, Configuration of an unknown parameter: BAD */
    const uint8_t status9[] = {0x41, 0, 0, 0, 9, 0, 0, 0, 9};
    CHECK(walk(status9, sizeof status9, k) == 1 && k[0] == FMU_LSBUS_BAD);
    const uint8_t config7[] = {0x40, 0, 0, 0, 13, 0, 0, 0, 7, 0, 0, 0, 0};
    CHECK(walk(config7, sizeof config7, k) == 1 && k[0] == FMU_LSBUS_BAD);
    /* NULL and empty */
    size_t pos = 0;
    fmu_lsbus_op op;
    CHECK(fmu_lsbus_next(NULL, 5, &pos, &op) == FMU_LSBUS_END);
    CHECK(walk(two, 0, k) == 0);
}

/* ---- the plant's network FMU ----------------------------------------------------------------- */

static int warnings;
static char last[512];

static void logger(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category,
                   fmi3String message)
{
    (void)env;
    (void)category;
    warnings += status == fmi3Warning;
    snprintf(last, sizeof last, "%s", message);
}

static char token[FMU_TOKEN_SIZE];

static fmi3Instance node(void)
{
    static plant_can_data d;
    CHECK(FMU_MODEL.set_defaults(&d) == FMU_OK);
    fmu_model_token(&FMU_MODEL, &d, token);
    fmi3Instance c = fmi3InstantiateCoSimulation("plant", token, NULL, false, false, true, false,
                                                 NULL, 0, NULL, logger, NULL);
    CHECK(c != NULL);
    CHECK(fmi3EnterInitializationMode(c, false, 0.0, 0.0, false, 0.0) == fmi3OK);
    return c;
}

static const fmi3ValueReference TX = vr_count + 0, RX = vr_count + 1, TXC = vr_count + 2,
                                RXC = vr_count + 3;

/* The operations the FMU releases now (Tx clock read, then Tx_Data), walked into codes. */
static size_t sent(fmi3Instance c, uint32_t codes[64], uint8_t copy[4096], size_t *len)
{
    fmi3Clock active = false;
    CHECK(fmi3GetClock(c, &TXC, 1, &active) == fmi3OK);
    if (!active) {
        return 0; /* an importer reads Tx_Data when its clock ticks */
    }
    size_t n = 0;
    fmi3Binary v = NULL;
    CHECK(fmi3GetBinary(c, &TX, 1, &n, &v, 1) == fmi3OK);
    CHECK(n > 0);
    if (len != NULL) {
        *len = n;
        memcpy(copy, v, n);
    }
    size_t pos = 0, count = 0;
    fmu_lsbus_op op;
    fmu_lsbus_result r;
    while ((r = fmu_lsbus_next(v, n, &pos, &op)) != FMU_LSBUS_END && count < 64) {
        CHECK(r == FMU_LSBUS_OK); /* what a node sends is well-formed */
        codes[count++] = op.opcode;
    }
    return count;
}

static void receive(fmi3Instance c, const uint8_t *v, size_t n)
{
    const fmi3Clock on = true;
    CHECK(fmi3SetClock(c, &RXC, 1, &on) == fmi3OK);
    CHECK(fmi3SetBinary(c, &RX, 1, &n, &v, 1) == fmi3OK);
}

static double output(fmi3Instance c, fmi3ValueReference vr)
{
    double x = -1.0;
    CHECK(fmi3GetFloat64(c, &vr, 1, &x, 1) == fmi3OK);
    return x;
}

static void end_event_and_step(fmi3Instance c, double t)
{
    fmi3Boolean need = false, term = false, nom = false, val = false, next = false;
    fmi3Float64 at = 0.0;
    CHECK(fmi3UpdateDiscreteStates(c, &need, &term, &nom, &val, &next, &at) == fmi3OK);
    CHECK(fmi3EnterStepMode(c) == fmi3OK);
    fmi3Boolean event = false, early = false;
    fmi3Float64 last_t = 0.0;
    CHECK(fmi3DoStep(c, t, 1e-3, false, &event, &term, &early, &last_t) == fmi3OK);
    CHECK(event); /* the period ended: the node publishes at the next event */
    CHECK(fmi3EnterEventMode(c) == fmi3OK);
}

static void test_plant_node(void)
{
    fmi3Instance c = node();
    CHECK(fmi3ExitInitializationMode(c) == fmi3OK); /* into Event Mode: the first operations */
    uint32_t codes[64];
    uint8_t bytes[4096];
    size_t len = 0;
    size_t n = sent(c, codes, bytes, &len);
    /* Configuration first, then the boot-up heartbeat, JointState1..3, PlantStatus, heartbeat */
    CHECK(n == 7 && codes[0] == FMU_LSBUS_OP_CONFIGURATION);
    for (size_t i = 1; i < n; ++i) {
        CHECK(codes[i] == FMU_LSBUS_OP_CAN_TRANSMIT);
    }
    /* the clock is not active again for the same operations */
    CHECK(sent(c, codes, NULL, NULL) == 0);

    /* hostile operations, each answered with one Format Error that carries it */
    uint8_t hostile[64] = {0x77, 0, 0, 0, 0x0a, 0, 0, 0, 1, 2,             /* unknown */
                           0x10, 0, 0, 0, 0x10, 0, 0, 0, 0, 1, 0, 0, 0, 0, 8, 0, /* liar */
                           0x10, 0, 0, 0, 0xff, 0, 0, 0, 0, 1};           /* past the end */
    const size_t hn = 10 + 16 + 10;
    warnings = 0;
    receive(c, hostile, hn);
    CHECK(warnings == 3);
    n = sent(c, codes, bytes, &len);
    CHECK(n == 3 && codes[0] == FMU_LSBUS_OP_FORMAT_ERROR && codes[1] == FMU_LSBUS_OP_FORMAT_ERROR &&
          codes[2] == FMU_LSBUS_OP_FORMAT_ERROR);
    size_t pos = 0;
    fmu_lsbus_op op;
    CHECK(fmu_lsbus_next(bytes, len, &pos, &op) == FMU_LSBUS_OK && op.data_length == 10 &&
          same(op.data, hostile, 10));
    CHECK(fmu_lsbus_next(bytes, len, &pos, &op) == FMU_LSBUS_OK && op.data_length == 16 &&
          same(op.data, hostile + 10, 16));
    CHECK(fmu_lsbus_next(bytes, len, &pos, &op) == FMU_LSBUS_OK && op.data_length == 10 &&
          same(op.data, hostile + 26, 10));
    /* zero length: one Format Error, the walk stops */
    const uint8_t zero[16] = {0x10, 0, 0, 0, 0, 0, 0, 0, 0x10, 0, 0, 0, 8, 0, 0, 0};
    receive(c, zero, sizeof zero);
    CHECK(sent(c, codes, NULL, NULL) == 1 && codes[0] == FMU_LSBUS_OP_FORMAT_ERROR);
    /* a value above Rx_Data's maxSize is refused with Error, not received */
    static uint8_t big[FMU_BUS_RX_MAX + 1];
    size_t bn = sizeof big;
    const uint8_t *bp = big;
    CHECK(fmi3SetBinary(c, &RX, 1, &bn, &bp, 1) == fmi3Error);

    /* notifications: ignored silently while BusNotifications is false (no warning, no fault) */
    const uint8_t bus_error[15] = {0x31, 0, 0, 0, 0x0f, 0, 0, 0, 0x10, 0x01, 0, 0, 4, 1, 1};
    const uint8_t confirm[12] = {0x20, 0, 0, 0, 0x0c, 0, 0, 0, 0x10, 0x01, 0, 0};
    warnings = 0;
    receive(c, bus_error, sizeof bus_error);
    receive(c, confirm, sizeof confirm);
    CHECK(warnings == 0 && sent(c, codes, NULL, NULL) == 0);
    CHECK(output(c, vr_status + ps_notifications_ignored) == 2.0);
    CHECK(output(c, vr_status + ps_faults) == 0.0);

    /* the safety policy: no command for max_missed (3) periods -> 0 V and the timeout latched */
    for (int k = 0; k < 4; ++k) {
        end_event_and_step(c, k * 1e-3);
        (void)sent(c, codes, NULL, NULL);
    }
    CHECK(output(c, vr_status + ps_timeout) == 1.0);
    CHECK(((unsigned)output(c, vr_status + ps_faults) & RRR_HIL_FAULT_TIMEOUT) != 0u);
    CHECK(output(c, vr_zero) == 1.0);
    fmi3FreeInstance(c);

    /* with BusNotifications: a Bus Error latches the bus fault */
    c = node();
    const fmi3ValueReference vn = vr_notifications;
    const fmi3Boolean yes = true;
    CHECK(fmi3SetBoolean(c, &vn, 1, &yes, 1) == fmi3OK);
    CHECK(fmi3ExitInitializationMode(c) == fmi3OK);
    (void)sent(c, codes, NULL, NULL);
    receive(c, bus_error, sizeof bus_error);
    CHECK(((unsigned)output(c, vr_status + ps_faults) & RRR_HIL_FAULT_BUS) != 0u);
    fmi3FreeInstance(c);

    /* without event mode (an importer without clocks): clocks are an illegal call sequence */
    plant_can_data d;
    CHECK(FMU_MODEL.set_defaults(&d) == FMU_OK);
    c = fmi3InstantiateCoSimulation("plant", token, NULL, false, false, false, false, NULL, 0,
                                    NULL, logger, NULL);
    CHECK(c != NULL);
    CHECK(fmi3EnterInitializationMode(c, false, 0.0, 0.0, false, 0.0) == fmi3OK);
    CHECK(fmi3ExitInitializationMode(c) == fmi3OK);
    fmi3Clock a = false;
    CHECK(fmi3GetClock(c, &TXC, 1, &a) == fmi3Error && strstr(last, "illegal call") != NULL);
    fmi3FreeInstance(c);
}

int main(void)
{
    test_golden_bytes();
    test_hostile();
    test_plant_node();
    printf("test_lsbus: %ld checks, %d failures\n", rrr_test_checks, rrr_test_failures);
    return rrr_test_failures == 0 ? 0 : 1;
}
