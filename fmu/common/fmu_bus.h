/**
 * @file fmu_bus.h
 * @brief A CAN network terminal of FMI-LS-BUS 1.0 (network abstraction, "Low Cut") for an FMI
 *        3.0 Co-Simulation model: the four variables of the terminal, the operations queued for
 *        Tx_Data, the walk over each Rx_Data value, and the clocks (fmu_bus.c).
 *
 * A model with a terminal sets fmu_model.bus to an fmu_bus descriptor. Its four variables come
 * after the variable table: value references n_vars + FMU_BUS_TX_DATA ... FMU_BUS_RX_CLOCK, in
 * the XML (fmu_xml.c) and in terminalsAndIcons/terminalsAndIcons.xml (terminal `terminal`, kind
 * org.fmi-ls-bus.network-terminal, matching rule org.fmi-ls-bus.transceiver). The model data
 * holds an fmu_bus_state at `state_offset` (so FMU state snapshots hold the queued operations);
 * the table has a fixed Boolean parameter BusNotifications (`vr_notifications`) and a fixed Real
 * parameter with the CAN baud rate (`vr_baudrate`, sent in a Configuration operation before
 * anything else).
 *
 * What the glue does for the model:
 *  - Tx: the model queues CAN frames (fmu_bus_send) whenever it has them; a Tx_Clock that is a
 *    triggered output clock (FMU_BUS_TX_TRIGGERED) is active whenever operations are queued
 *    (fmi3GetClock), a countdown clock (FMU_BUS_TX_COUNTDOWN) ticks every `period` seconds
 *    (fmi3GetIntervalDecimal announces the next communication point) and carries what was queued
 *    by then. Tx_Data is what the last active clock released, until the next
 *    fmi3UpdateDiscreteStates or fmi3EnterStepMode;
 *  - Rx: each Rx_Data value is walked by `length` when it is set: a well-formed
 *    CAN Transmit goes to the model's `frame` hook; Confirm, Arbitration Lost and Bus Error go to
 *    its `notification` hook when BusNotifications is true and are ignored silently otherwise; a
 *    malformed operation (unknown OP Code, a length that does not match its arguments, below the
 *    header or past the end of the value, data above 8 bytes) is answered with a Format Error
 *    carrying it, and a length that cannot be trusted ends the walk;
 *  - events: the model's `event` hook runs when the FMU enters Event Mode (after
 *    initialization and after each fmi3DoStep): there it queues what it sends at this time.
 *    fmi3DoStep asks for an event (eventHandlingNeeded) at every multiple of `period` with a
 *    triggered Tx clock.
 */
#ifndef FMU_BUS_H
#define FMU_BUS_H

#include <stddef.h>
#include <stdint.h>

#include "fmu_lsbus.h"
#include "fmu_model.h"

/** Bytes of Tx_Data (its maxSize: a period's frames take about 150) and of Rx_Data (its
 *  maxSize). A received value is walked when it is set, so only Tx needs room in the state. */
#define FMU_BUS_TX_MAX 1024u
#define FMU_BUS_RX_MAX 2048u

/** The terminal's variables, value reference n_vars + each. */
enum {
    FMU_BUS_TX_DATA = 0,
    FMU_BUS_RX_DATA = 1,
    FMU_BUS_TX_CLOCK = 2,
    FMU_BUS_RX_CLOCK = 3,
    FMU_BUS_VAR_COUNT = 4
};

/** The kind of Tx_Clock. */
typedef enum fmu_bus_tx_clock {
    FMU_BUS_TX_TRIGGERED = 0, ///< output clock, active when operations are queued
    FMU_BUS_TX_COUNTDOWN = 1  ///< input clock the importer schedules every `period`
} fmu_bus_tx_clock;

/** What the terminal keeps in the model data (plain old data: FMU state snapshots copy it). */
typedef struct fmu_bus_state {
    uint32_t tx_len;          ///< bytes queued in tx
    uint32_t tx_sent;         ///< bytes of tx released by the last active Tx_Clock (Tx_Data)
    uint8_t tx_clock;         ///< Tx_Clock active in this event iteration
    uint8_t rx_clock;         ///< Rx_Clock active in this event iteration
    uint8_t sent;             ///< Tx released since the last fmi3UpdateDiscreteStates
    uint8_t configured;       ///< the Configuration (baud rate) was queued
    uint32_t ops_received;    ///< well-formed operations received
    uint32_t frames_received; ///< of them CAN Transmit (and CAN FD Transmit up to 8 bytes)
    uint32_t frames_sent;     ///< CAN Transmit operations queued
    uint32_t format_errors_sent;     ///< malformed operations answered with a Format Error
    uint32_t format_errors_received; ///< Format Errors received (our operations, refused)
    uint32_t notifications;          ///< Confirm, Arbitration Lost, Bus Error passed on
    uint32_t notifications_ignored;  ///< the same while BusNotifications is false
    uint32_t other_ops;       ///< well-formed operations with nothing to do (Status, Wakeup,
                              ///< CAN FD above 8 bytes, CAN XL)
    uint32_t tx_overflow;     ///< operations dropped: Tx_Data full (FMU_BUS_TX_MAX)
    uint32_t peer_baudrate;   ///< the last Configuration CAN baud rate received (0: none)
    uint8_t tx[FMU_BUS_TX_MAX];
} fmu_bus_state;

struct fmu_bus_glue;

/** A model's CAN network terminal. */
typedef struct fmu_bus {
    const char *terminal;        ///< terminal name, the prefix of its variables ("CAN")
    const char *description;     ///< one line for the XML
    fmu_bus_tx_clock tx_clock;   ///< the kind of Tx_Clock
    double period;               ///< s: the node's communication period (countdown interval;
                                 ///< triggered: an event at each multiple)
    size_t state_offset;         ///< offset of the fmu_bus_state in the model data
    fmu_vr vr_notifications;     ///< the BusNotifications parameter (Boolean, fixed)
    fmu_vr vr_baudrate;          ///< the baud-rate parameter (Real, fixed, bit/s)
    /** A well-formed CAN Transmit received (op->id, ide, data, data_length <= 8). */
    void (*frame)(fmu_instance *inst, const fmu_lsbus_op *op);
    /** Optional: a Confirm, Arbitration Lost or Bus Error received while BusNotifications is
     *  true. */
    void (*notification)(fmu_instance *inst, const fmu_lsbus_op *op);
    /** The FMU entered Event Mode at inst->time (after initialization, after a step): queue
     *  what is sent now. */
    void (*event)(fmu_instance *inst);
    /** The implementation (fmu_bus.c): &fmu_bus_glue_impl; the adapter reaches it through
     *  here, so that FMUs without a terminal link none of it. */
    const struct fmu_bus_glue *glue;
} fmu_bus;

/** The functions of the FMI 3.0 adapter for a terminal (fmi3_functions.c calls them when the
 *  model has one; each logs and returns FMU_ERROR on a refusal). */
typedef struct fmu_bus_glue {
    fmu_status (*get_binary)(fmu_instance *S, const char *fn, fmu_vr vr, size_t *size,
                             const uint8_t **value);
    fmu_status (*set_binary)(fmu_instance *S, const char *fn, fmu_vr vr, size_t size,
                             const uint8_t *value);
    fmu_status (*get_clock)(fmu_instance *S, const char *fn, fmu_vr vr, int *active);
    fmu_status (*set_clock)(fmu_instance *S, const char *fn, fmu_vr vr, int active);
    fmu_status (*get_interval)(fmu_instance *S, const char *fn, fmu_vr vr, double *interval,
                               int *changed);
    /** Event Mode entered (after initialization or a step). */
    void (*enter_event_mode)(fmu_instance *S);
    /** fmi3UpdateDiscreteStates: the end of an event iteration; 1 when another is needed. */
    int (*update)(fmu_instance *S);
    /** fmi3EnterStepMode: the clocks go inactive, released operations are dropped. */
    void (*enter_step_mode)(fmu_instance *S);
    /** After a step to inst->time: 1 when the node needs an event now. */
    int (*event_needed)(const fmu_instance *S);
    /** The bus state of an FMU state snapshot (counts and flags in range): FMU_OK or FMU_ERROR
     *  (logged under fn). */
    fmu_status (*check_state)(fmu_instance *S, const void *data, const char *fn);
} fmu_bus_glue;

/** The implementation of fmu_bus.c. */
extern const fmu_bus_glue fmu_bus_glue_impl;

/** @brief Value reference of terminal variable k (FMU_BUS_TX_DATA, ...) of model m. */
static inline fmu_vr fmu_bus_vr(const fmu_model *m, unsigned k)
{
    return (fmu_vr)(m->n_vars + k);
}

/** @brief The terminal state in the model data of inst. */
fmu_bus_state *fmu_bus_of(fmu_instance *inst);

/**
 * @brief Queue a CAN Transmit of a classical frame (n <= 8 data bytes) for the next Tx; the
 *        Configuration with the baud rate goes first, once. 0, or -1 when Tx_Data is full
 *        (counted in tx_overflow).
 */
int fmu_bus_send(fmu_instance *inst, uint32_t id, int extended, const uint8_t *data, size_t n);

#endif /* FMU_BUS_H */
