/*
 * Fuzz target of the LS-BUS network FMUs' receive path: arbitrary Rx_Data values fed to one node
 * (the model this file is compiled with: fmu/plant_can or fmu/controller_can, with the FMI 3.0
 * adapter) in Event Mode through the FMI API, as an importer delivers them, with steps between
 * them. Every value is walked by its operations' length (fmu_lsbus.c) and answered as the
 * standard says; ASan and UBSan watch the memory, the checks below the rest (a violation traps):
 *  - fmi3SetBinary of Rx_Data returns OK for a value up to its maxSize, Error above it;
 *  - whatever the node releases on Tx_Data is a sequence of well-formed operations, each of
 *    them a CAN Transmit of at most 8 bytes, a Configuration or a Format Error;
 *  - a Format Error carries a prefix of the value received (the operation that caused it);
 *  - every Float64 output stays finite.
 *
 * Input layout: byte 0: bit 0 BusNotifications, bits 1..2 steps between values (0..3); then
 * values, each a 2-byte little-endian length (taken modulo 2304, so some exceed maxSize 2048)
 * and that many bytes (fewer at the end of the input).
 *
 * libFuzzer (clang):  cmake -DRRR_FMU_FUZZ=ON -DCMAKE_C_COMPILER=clang ...; ./fuzz_lsbus_rx_<model>
 * Without clang, tests/c/test_lsbus_rx_smoke.c drives the same function (CTest, ASan and UBSan).
 */
#include "config.h" /* the model's: first (fmu_model.h) */

#include <math.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <string.h>

#include "fmi3Functions.h"
#include "fmu_lsbus.h"

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size);

#define REQUIRE(cond)                                                                         \
    do {                                                                                      \
        if (!(cond)) {                                                                        \
            fprintf(stderr, "fuzz_lsbus_rx: %s:%d: %s\n", __FILE__, __LINE__, #cond);         \
            __builtin_trap();                                                                 \
        }                                                                                     \
    } while (0)

static void log_discard(fmi3InstanceEnvironment env, fmi3Status status, fmi3String category,
                        fmi3String message)
{
    (void)env;
    (void)status;
    (void)category;
    (void)message;
}

/* Read what the node releases now, check it; the value received last is `rx` (n bytes). */
static void check_tx(fmi3Instance c, fmi3ValueReference txc, fmi3ValueReference tx,
                     const uint8_t *rx, size_t rx_n)
{
    fmi3Clock active = false;
    REQUIRE(fmi3GetClock(c, &txc, 1, &active) == fmi3OK);
    if (!active) {
        return;
    }
    size_t n = 0;
    fmi3Binary v = NULL;
    REQUIRE(fmi3GetBinary(c, &tx, 1, &n, &v, 1) == fmi3OK);
    size_t pos = 0;
    fmu_lsbus_op op;
    fmu_lsbus_result r;
    while ((r = fmu_lsbus_next(v, n, &pos, &op)) != FMU_LSBUS_END) {
        REQUIRE(r == FMU_LSBUS_OK);
        REQUIRE(op.opcode == FMU_LSBUS_OP_CAN_TRANSMIT || op.opcode == FMU_LSBUS_OP_FORMAT_ERROR ||
                op.opcode == FMU_LSBUS_OP_CONFIGURATION);
        if (op.opcode == FMU_LSBUS_OP_CAN_TRANSMIT) {
            REQUIRE(op.data_length <= 8u);
        }
        if (op.opcode == FMU_LSBUS_OP_FORMAT_ERROR && op.data_length > 0u) {
            int found = 0; /* a piece of the value received */
            for (size_t at = 0; at + op.data_length <= rx_n && !found; ++at) {
                found = memcmp(rx + at, op.data, op.data_length) == 0;
            }
            REQUIRE(found);
        }
    }
}

static void check_outputs(fmi3Instance c)
{
    for (size_t i = 0; i < FMU_MODEL.n_vars; ++i) {
        const fmu_variable *v = &FMU_MODEL.vars[i];
        if (v->type == FMU_REAL && v->causality == FMU_OUTPUT) {
            double x = 0.0;
            REQUIRE(fmi3GetFloat64(c, &v->vr, 1, &x, 1) == fmi3OK && isfinite(x));
        }
    }
}

int LLVMFuzzerTestOneInput(const uint8_t *data, size_t size)
{
    if (size < 1) {
        return 0;
    }
    static char token[FMU_TOKEN_SIZE];
    static char resources[4096];
    if (token[0] == '\0') {
        _Alignas(16) static uint8_t d[1u << 16];
        REQUIRE(FMU_MODEL.data_size <= sizeof d && FMU_MODEL.set_defaults(d) == FMU_OK);
        fmu_model_token(&FMU_MODEL, d, token);
        snprintf(resources, sizeof resources, "%s/", FUZZ_RESOURCES_DIR);
    }
    const fmi3ValueReference tx = (fmi3ValueReference)FMU_MODEL.n_vars, rx = tx + 1,
                             txc = tx + 2, rxc = tx + 3;
    fmi3Instance c = fmi3InstantiateCoSimulation("fuzz", token, resources, false, false, true,
                                                 false, NULL, 0, NULL, log_discard, NULL);
    REQUIRE(c != NULL);
    const fmi3ValueReference vn = FMU_MODEL.bus->vr_notifications;
    const fmi3Boolean notify = (data[0] & 1u) != 0u;
    REQUIRE(fmi3SetBoolean(c, &vn, 1, &notify, 1) == fmi3OK);
    REQUIRE(fmi3EnterInitializationMode(c, false, 0.0, 0.0, false, 0.0) == fmi3OK);
    REQUIRE(fmi3ExitInitializationMode(c) == fmi3OK);
    const unsigned steps = (data[0] >> 1) & 3u;
    double t = 0.0;
    size_t at = 1;
    for (int round = 0; round < 64 && at + 2 <= size; ++round) {
        size_t n = ((size_t)data[at] | (size_t)data[at + 1] << 8) % 2304u;
        at += 2;
        if (n > size - at) {
            n = size - at;
        }
        const uint8_t *value = data + at;
        at += n;
        const fmi3Clock on = true;
        REQUIRE(fmi3SetClock(c, &rxc, 1, &on) == fmi3OK);
        const fmi3Status st = fmi3SetBinary(c, &rx, 1, &n, &value, 1);
        REQUIRE(st == (n <= 2048u ? fmi3OK : fmi3Error));
        check_tx(c, txc, tx, value, n);
        check_outputs(c);
        for (unsigned s = 0; s < steps; ++s) {
            fmi3Boolean need = false, term = false, nom = false, val = false, next = false;
            fmi3Float64 at_t = 0.0, last = 0.0;
            REQUIRE(fmi3UpdateDiscreteStates(c, &need, &term, &nom, &val, &next, &at_t) == fmi3OK);
            REQUIRE(fmi3EnterStepMode(c) == fmi3OK);
            fmi3Boolean event = false, early = false;
            REQUIRE(fmi3DoStep(c, t, 1e-3, false, &event, &term, &early, &last) == fmi3OK);
            t += 1e-3;
            REQUIRE(fmi3EnterEventMode(c) == fmi3OK);
            check_tx(c, txc, tx, value, 0);
        }
    }
    fmi3FreeInstance(c);
    return 0;
}
