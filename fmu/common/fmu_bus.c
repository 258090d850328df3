/*
 * The CAN network terminal of an FMI-LS-BUS 1.0 network FMU (fmu_bus.h): Tx_Data and Rx_Data,
 * Tx_Clock and Rx_Clock, the walk over received operations (fmu_lsbus.c) with the Format Error
 * answer, and the bus state FMU state snapshots carry. Linked only into FMUs with a terminal;
 * the FMI 3.0 adapter reaches it through fmu_bus.glue.
 */
#include "fmu_bus.h"

#include <math.h>
#include <string.h>

#include "fmu_internal.h"

fmu_bus_state *fmu_bus_of(fmu_instance *inst)
{
    return (fmu_bus_state *)((char *)inst->data + inst->model->bus->state_offset);
}

/* The value of the model's Boolean parameter BusNotifications. */
static int notifications_on(fmu_instance *S)
{
    const fmu_variable *v = fmu_find_var(S->model, S->model->bus->vr_notifications);
    int b = 0;
    if (v != NULL && v->type == FMU_BOOLEAN) {
        memcpy(&b, fmu_var_ptr(S->data, v), sizeof b);
    }
    return b != 0;
}

/* The baud rate parameter, bit/s (checked by the model's initialize: an integer in range). */
static uint32_t baudrate_of(fmu_instance *S)
{
    const fmu_variable *v = fmu_find_var(S->model, S->model->bus->vr_baudrate);
    double d = 0.0;
    if (v != NULL && v->type == FMU_REAL) {
        memcpy(&d, fmu_var_ptr(S->data, v), sizeof d);
    }
    return d >= 1.0 && d <= 4294967295.0 ? (uint32_t)d : 0u;
}

/* Append n bytes made by put (0: they did not fit): 0 or -1 (counted). */
static int queued(fmu_bus_state *b, size_t n)
{
    if (n == 0u) {
        ++b->tx_overflow;
        return -1;
    }
    b->tx_len += (uint32_t)n;
    return 0;
}

/* The Configuration with the baud rate, once, before the first frame. */
static void configure(fmu_instance *S, fmu_bus_state *b)
{
    if (b->configured) {
        return;
    }
    b->configured = 1u;
    (void)queued(b, fmu_lsbus_put_config_baudrate(b->tx + b->tx_len, FMU_BUS_TX_MAX - b->tx_len,
                                                  FMU_LSBUS_CONFIG_CAN_BAUDRATE, baudrate_of(S)));
}

int fmu_bus_send(fmu_instance *inst, uint32_t id, int extended, const uint8_t *data, size_t n)
{
    fmu_bus_state *b = fmu_bus_of(inst);
    configure(inst, b);
    const int rc = queued(b, fmu_lsbus_put_can_transmit(b->tx + b->tx_len,
                                                        FMU_BUS_TX_MAX - b->tx_len, id, extended,
                                                        0, data, n));
    if (rc == 0) {
        ++b->frames_sent;
    }
    return rc;
}

/* A malformed operation: a Format Error that carries it (as much of it as Tx_Data holds). */
static void format_error(fmu_bus_state *b, const fmu_lsbus_op *op)
{
    size_t n = op->length;
    const size_t room = FMU_BUS_TX_MAX - b->tx_len;
    if (room < FMU_LSBUS_FORMAT_ERROR_HEADER) {
        ++b->tx_overflow;
        return;
    }
    if (n > room - FMU_LSBUS_FORMAT_ERROR_HEADER) {
        n = room - FMU_LSBUS_FORMAT_ERROR_HEADER; /* the start of it: Tx_Data is full */
    }
    if (queued(b, fmu_lsbus_put_format_error(b->tx + b->tx_len, room, op->bytes, n)) == 0) {
        ++b->format_errors_sent;
    }
}

/* Walk one received Rx_Data value (n bytes) by length. */
static void receive(fmu_instance *S, const uint8_t *value, size_t n)
{
    fmu_bus_state *b = fmu_bus_of(S);
    const fmu_bus *bus = S->model->bus;
    const int notify = notifications_on(S);
    size_t pos = 0;
    fmu_lsbus_op op;
    for (;;) {
        const fmu_lsbus_result r = fmu_lsbus_next(value, n, &pos, &op);
        if (r == FMU_LSBUS_END) {
            break;
        }
        if (r != FMU_LSBUS_OK) {
            fmu_log(S, FMU_WARNING, FMU_LOG_WARNING,
                    "%s: %s operation (OP Code 0x%04x, %u bytes) at t = %.17g: answered with a "
                    "Format Error%s",
                    S->model->identifier,
                    r == FMU_LSBUS_CUT ? "a cut-off" : "a malformed or unknown", (unsigned)op.opcode,
                    (unsigned)op.length, S->time,
                    r == FMU_LSBUS_CUT ? "; the rest of the Rx_Data value cannot be delimited" : "");
            format_error(b, &op);
            continue;
        }
        ++b->ops_received;
        switch (op.opcode) {
        case FMU_LSBUS_OP_CAN_TRANSMIT:
        case FMU_LSBUS_OP_CANFD_TRANSMIT:
            if (op.data_length <= FMU_LSBUS_CAN_MAX_DATA) {
                ++b->frames_received;
                bus->frame(S, &op);
            } else {
                ++b->other_ops; /* a CAN FD frame above 8 bytes: none of the bench's */
            }
            break;
        case FMU_LSBUS_OP_CONFIRM:
        case FMU_LSBUS_OP_ARBITRATION_LOST:
        case FMU_LSBUS_OP_BUS_ERROR:
            if (notify && bus->notification != NULL) {
                ++b->notifications;
                bus->notification(S, &op);
            } else {
                ++b->notifications_ignored; /* fire and forget: ignored silently */
            }
            break;
        case FMU_LSBUS_OP_FORMAT_ERROR:
            ++b->format_errors_received; /* never answered: no ping-pong of errors */
            break;
        case FMU_LSBUS_OP_CONFIGURATION:
            if (op.parameter == FMU_LSBUS_CONFIG_CAN_BAUDRATE) {
                b->peer_baudrate = op.baudrate;
            } else {
                ++b->other_ops;
            }
            break;
        default:
            ++b->other_ops;
            break;
        }
    }
}

static int is_var(const fmu_instance *S, fmu_vr vr, unsigned k)
{
    return vr == fmu_bus_vr(S->model, k);
}

static fmu_status refuse(fmu_instance *S, const char *fn, fmu_vr vr, const char *what)
{
    fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "%s: value reference %u of %s is not %s", fn,
            (unsigned)vr, S->model->identifier, what);
    return FMU_ERROR;
}

static fmu_status get_binary(fmu_instance *S, const char *fn, fmu_vr vr, size_t *size,
                             const uint8_t **value)
{
    fmu_bus_state *b = fmu_bus_of(S);
    if (is_var(S, vr, FMU_BUS_TX_DATA)) {
        *size = b->tx_clock ? b->tx_sent : 0u;
        *value = b->tx;
        return FMU_OK;
    }
    if (is_var(S, vr, FMU_BUS_RX_DATA)) {
        *size = 0u; /* walked when it was set: nothing is kept */
        *value = b->tx;
        return FMU_OK;
    }
    return refuse(S, fn, vr, "a Binary variable (its Binary variables are the terminal's "
                             "Tx_Data and Rx_Data)");
}

static fmu_status set_binary(fmu_instance *S, const char *fn, fmu_vr vr, size_t size,
                             const uint8_t *value)
{
    fmu_bus_state *b = fmu_bus_of(S);
    if (is_var(S, vr, FMU_BUS_TX_DATA)) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "%s: Tx_Data (vr %u) is an output and cannot be set",
                fn, (unsigned)vr);
        return FMU_ERROR;
    }
    if (!is_var(S, vr, FMU_BUS_RX_DATA)) {
        return refuse(S, fn, vr, "a Binary variable that can be set (Rx_Data)");
    }
    if (size > FMU_BUS_RX_MAX) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: an Rx_Data value of %zu bytes is longer than its maxSize %u; not received",
                fn, size, FMU_BUS_RX_MAX);
        return FMU_ERROR;
    }
    if (size > 0u && value == NULL) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR, "%s: values[i] is NULL for %zu bytes", fn, size);
        return FMU_ERROR;
    }
    (void)b;
    receive(S, value, size); /* the importer sets a clocked input with its clock active */
    S->dirty = 1;
    return FMU_OK;
}

/* Drop the operations the last active Tx clock released (they have been read). */
static void drop_released(fmu_bus_state *b)
{
    if (b->tx_clock && b->tx_sent > 0u) {
        memmove(b->tx, b->tx + b->tx_sent, b->tx_len - b->tx_sent);
        b->tx_len -= b->tx_sent;
    }
    b->tx_sent = 0u;
    b->tx_clock = 0u;
}

static fmu_status get_clock(fmu_instance *S, const char *fn, fmu_vr vr, int *active)
{
    fmu_bus_state *b = fmu_bus_of(S);
    if (is_var(S, vr, FMU_BUS_TX_CLOCK) && S->model->bus->tx_clock == FMU_BUS_TX_TRIGGERED) {
        /* an output clock: active when operations are queued; reading it releases them to
         * Tx_Data (and resets it: the next read is active only for newer operations) */
        *active = b->tx_len > b->tx_sent;
        if (*active) {
            drop_released(b); /* a second tick in one instant releases only what is new */
            b->tx_sent = b->tx_len;
            b->tx_clock = 1u;
            b->sent = 1u;
        }
        return FMU_OK;
    }
    if (is_var(S, vr, FMU_BUS_TX_CLOCK) || is_var(S, vr, FMU_BUS_RX_CLOCK)) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: %s (vr %u) is an input clock: the importer sets it, fmi3GetClock is for "
                "output clocks",
                fn, is_var(S, vr, FMU_BUS_RX_CLOCK) ? "Rx_Clock" : "Tx_Clock", (unsigned)vr);
        return FMU_ERROR;
    }
    return refuse(S, fn, vr, "a Clock");
}

static fmu_status set_clock(fmu_instance *S, const char *fn, fmu_vr vr, int active)
{
    fmu_bus_state *b = fmu_bus_of(S);
    if (is_var(S, vr, FMU_BUS_RX_CLOCK)) {
        b->rx_clock = active ? 1u : 0u;
        return FMU_OK;
    }
    if (is_var(S, vr, FMU_BUS_TX_CLOCK) && S->model->bus->tx_clock == FMU_BUS_TX_COUNTDOWN) {
        if (active && !b->tx_clock) {
            configure(S, b); /* the first tick carries the Configuration at least */
            b->tx_sent = b->tx_len;
            b->tx_clock = 1u;
            b->sent = b->tx_sent > 0u;
        } else if (!active) {
            drop_released(b); /* what the tick released has been sent */
        }
        return FMU_OK;
    }
    if (is_var(S, vr, FMU_BUS_TX_CLOCK)) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: Tx_Clock (vr %u) is a triggered output clock: the FMU activates it", fn,
                (unsigned)vr);
        return FMU_ERROR;
    }
    return refuse(S, fn, vr, "a Clock");
}

/* The time from t to the next multiple of the period after it (relative to the start time). */
static double to_next_period(const fmu_instance *S)
{
    const double p = S->model->bus->period;
    const double k = floor((S->time - S->start_time) / p + 1e-9) + 1.0;
    return S->start_time + k * p - S->time;
}

static fmu_status get_interval(fmu_instance *S, const char *fn, fmu_vr vr, double *interval,
                               int *changed)
{
    if (!is_var(S, vr, FMU_BUS_TX_CLOCK) || S->model->bus->tx_clock != FMU_BUS_TX_COUNTDOWN) {
        return refuse(S, fn, vr, "a countdown clock (only a countdown Tx_Clock has an interval)");
    }
    *interval = to_next_period(S);
    *changed = 1;
    return FMU_OK;
}

static void enter_event_mode(fmu_instance *S)
{
    /* the Configuration with the baud rate at the first event, before anything else: a bus
     * simulation carries no frame until every node has configured the same baud rate */
    configure(S, fmu_bus_of(S));
    S->model->bus->event(S);
}

/* Drop what the last active Tx clock released; the clocks go inactive. */
static void end_iteration(fmu_bus_state *b)
{
    drop_released(b);
    b->rx_clock = 0u;
}

static int update(fmu_instance *S)
{
    fmu_bus_state *b = fmu_bus_of(S);
    /* another iteration when operations went out (the answer may come back in this instant) or
     * wait for a triggered clock to be read */
    const int again = b->sent || (S->model->bus->tx_clock == FMU_BUS_TX_TRIGGERED &&
                                  b->tx_len > b->tx_sent);
    end_iteration(b);
    b->sent = 0u;
    return again;
}

static void enter_step_mode(fmu_instance *S)
{
    fmu_bus_state *b = fmu_bus_of(S);
    end_iteration(b);
    b->sent = 0u;
}

static int event_needed(const fmu_instance *S)
{
    if (S->model->bus->tx_clock != FMU_BUS_TX_TRIGGERED) {
        return 0; /* the importer schedules the countdown clock */
    }
    const double p = S->model->bus->period;
    const double k = floor((S->time - S->start_time) / p + 0.5);
    return fabs(S->time - (S->start_time + k * p)) <= 1e-9 * fmax(1.0, fabs(S->time));
}

static fmu_status check_state(fmu_instance *S, const void *data, const char *fn)
{
    fmu_bus_state b;
    memcpy(&b, (const char *)data + S->model->bus->state_offset, sizeof b);
    if (b.tx_len > FMU_BUS_TX_MAX || b.tx_sent > b.tx_len || b.tx_clock > 1u ||
        b.rx_clock > 1u || b.sent > 1u || b.configured > 1u) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: the FMU state holds an invalid bus terminal (Tx %u of %u bytes released, "
                "clocks %u %u, flags %u %u): lengths within maxSize, flags 0 or 1",
                fn, (unsigned)b.tx_sent, (unsigned)b.tx_len, (unsigned)b.tx_clock,
                (unsigned)b.rx_clock, (unsigned)b.sent, (unsigned)b.configured);
        return FMU_ERROR;
    }
    /* the queued operations are ours: each one well-formed */
    size_t pos = 0;
    fmu_lsbus_op op;
    fmu_lsbus_result r;
    while ((r = fmu_lsbus_next(b.tx, b.tx_len, &pos, &op)) == FMU_LSBUS_OK) {
    }
    if (r != FMU_LSBUS_END) {
        fmu_log(S, FMU_ERROR, FMU_LOG_ERROR,
                "%s: the FMU state's queued Tx operations are malformed at byte %zu", fn,
                (size_t)(op.bytes - b.tx));
        return FMU_ERROR;
    }
    return FMU_OK;
}

const fmu_bus_glue fmu_bus_glue_impl = {
    get_binary, set_binary,   get_clock,    set_clock,   get_interval,
    enter_event_mode, update, enter_step_mode, event_needed, check_state,
};
