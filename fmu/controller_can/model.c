/*
 * The controller as an FMI-LS-BUS CAN node: its variable table, the bus node of the C controller
 * node (c_src/hil/dbc/hil_dbc_controller.c: the same frames and codec, the same law) and the
 * reference table of resources/ (hil_reference.c). No protocol and no control law of its own.
 *
 * Schedule (the lockstep bench's): when the three JointState frames of a period are complete,
 * the controller computes u_k from the reference row k of the current period and that state, and
 * sends VoltageCmd(k), Sync(k) (parameter sync, except after the last row), every 100 periods the
 * heartbeat; before its first command the heartbeat "operational"; after the command of the
 * reference's last row the StopCmd (end of run) and the heartbeat "stopped". At most one command
 * per period. A period that starts without a command in the one before (states delayed or lost
 * on the bus), and every period of a countdown Tx clock, is commanded at its start with the
 * newest state, Enable = 0 when that state is older than CONTROLLER_CAN_STALE_PERIODS.
 */
#include "config.h"

#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "hil_reference.h"

#define T controller_can_data
#define RRR_MV_BASE vr_model

#define OUTPUT(VR, NAME, DESC, UNIT, MEMBER)                                                   \
    FMU_ROW(VR, FMU_REAL, FMU_OUTPUT, FMU_CONTINUOUS, NAME, DESC, UNIT, T, MEMBER)
#define JOINT_OUTPUTS(VR, N, WHAT, UNIT, M)                                                    \
    OUTPUT((VR) + 0, N "[1]", WHAT " of joint 1", UNIT, M[0]),                                 \
    OUTPUT((VR) + 1, N "[2]", WHAT " of joint 2", UNIT, M[1]),                                 \
    OUTPUT((VR) + 2, N "[3]", WHAT " of joint 3", UNIT, M[2])
#define JOINT_PARAMS(VR, N, WHAT, UNIT, M)                                                     \
    FMU_PARAM((VR) + 0, N "[1]", WHAT " of joint 1", UNIT, T, M[0]),                           \
    FMU_PARAM((VR) + 1, N "[2]", WHAT " of joint 2", UNIT, T, M[1]),                           \
    FMU_PARAM((VR) + 2, N "[3]", WHAT " of joint 3", UNIT, T, M[2])
#define STATUS_ROW(NAME, DESC) OUTPUT(vr_status + cs_##NAME, "status." #NAME, DESC, NULL, status[cs_##NAME]),

static const fmu_variable controller_can_vars[] = {
    JOINT_OUTPUTS(vr_u, "u", "commanded voltage sat(u_n + u_c) of the last VoltageCmd", "V", u),
    JOINT_OUTPUTS(vr_u_n, "u_n", "feedforward part of the last command", "V", u_n),
    JOINT_OUTPUTS(vr_u_c, "u_c", "PD part of the last command", "V", u_c),
    JOINT_OUTPUTS(vr_q, "q", "measured position (the newest complete JointState)", "rad", q),
    JOINT_OUTPUTS(vr_qd, "qd", "measured velocity (the newest complete JointState)", "rad/s", qd),
    OUTPUT(vr_period, "period", "the period index k of the last VoltageCmd (-1: none yet)", NULL,
           period),
    OUTPUT(vr_enable, "enable", "the Enable bit of the last VoltageCmd", NULL, enable),
    CONTROLLER_CAN_STATUS(STATUS_ROW)
    JOINT_PARAMS(vr_kp, "kp", "proportional gain", "V/rad", gains.kp),
    JOINT_PARAMS(vr_kd, "kd", "derivative gain", "V.s/rad", gains.kd),
    FMU_ROW(vr_feedforward, FMU_BOOLEAN, FMU_PARAMETER, FMU_FIXED, "feedforward",
            "add the model feedforward u_n (computed-torque); false: PD only", NULL, T,
            gains.feedforward),
    RRR_MODEL_VARS
    FMU_ROW(vr_sync, FMU_BOOLEAN, FMU_PARAMETER, FMU_FIXED, "sync",
            "send Sync(k) after VoltageCmd(k), the lockstep schedule (true); false: the "
            "real-time schedule of VoltageCmd only",
            NULL, T, sync),
    FMU_PARAM(vr_baudrate, "baudrate",
              "CAN baud rate sent in the Configuration operation, bit/s, an integer in [1e4, "
              "1e6]",
              NULL, T, baudrate),
    FMU_ROW(vr_notifications, FMU_BOOLEAN, FMU_PARAMETER, FMU_FIXED, "BusNotifications",
            "FMI-LS-BUS: true = Confirm, Arbitration Lost and Bus Error are counted; false = "
            "ignored (fire and forget)",
            NULL, T, notifications),
    FMU_TIME_ROW(vr_time),
};

_Static_assert(sizeof controller_can_vars / sizeof controller_can_vars[0] == vr_count,
               "one table row per value reference");

static controller_can_data *data_of(fmu_instance *inst)
{
    return (controller_can_data *)inst->data;
}

static const rrr_hil_reference *table_of(fmu_instance *inst)
{
    return (const rrr_hil_reference *)inst->work;
}

static fmu_status set_defaults(void *d)
{
    controller_can_data *c = d;
    memset(c, 0, sizeof *c);
    if (rrr_model_default(&c->model) != RRR_OK || rrr_ctc_gains_default(&c->gains) != RRR_OK) {
        return FMU_ERROR;
    }
    c->sync = 1;
    c->baudrate = 1e6;
    c->period = -1.0;
    return FMU_OK;
}

static void release(fmu_instance *inst)
{
    rrr_hil_reference *r = inst->work;
    if (r != NULL) {
        rrr_hil_reference_free(r);
        inst->host.release(r);
        inst->work = NULL;
    }
}

/* FNV-1a of the table's numbers (n rows of t, q, qd, qdd). */
static uint64_t table_hash(const rrr_hil_reference *r)
{
    uint64_t h = fmu_fnv1a(FMU_FNV_OFFSET, &r->n, sizeof r->n);
    h = fmu_fnv1a(h, r->t, r->n * sizeof *r->t);
    h = fmu_fnv1a(h, r->q, r->n * sizeof *r->q);
    h = fmu_fnv1a(h, r->qd, r->n * sizeof *r->qd);
    return fmu_fnv1a(h, r->qdd, r->n * sizeof *r->qdd) | 1u;
}

/* resources/reference.csv into inst->work (once). */
static fmu_status read_table(fmu_instance *inst, const char *fn)
{
    if (inst->work != NULL) {
        return FMU_OK;
    }
    if (inst->resources == NULL) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: no resources folder: the controller reads its reference from resources/%s",
                fn, CONTROLLER_CAN_REFERENCE);
        return FMU_ERROR;
    }
    char path[4096];
    const int n = snprintf(path, sizeof path, "%s%s", inst->resources, CONTROLLER_CAN_REFERENCE);
    rrr_hil_reference *r = inst->host.alloc(1, sizeof *r);
    char err[512] = "";
    if (n < 0 || (size_t)n >= sizeof path || r == NULL ||
        rrr_hil_reference_load(path, r, err, sizeof err) != 0) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR, "%s: %s", fn,
                err[0] != '\0' ? err : "the reference path is too long, or out of memory");
        inst->host.release(r);
        return FMU_ERROR;
    }
    inst->work = r;
    return FMU_OK;
}

/* The parameters as ExitInitializationMode accepts them; logs the one at fault under fn. */
static fmu_status check_parameters(fmu_instance *inst, const controller_can_data *c,
                                   const char *fn)
{
    const char *field = "";
    const rrr_status st = rrr_model_validate(&c->model, &field);
    if (st != RRR_OK) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR, "%s: parameter %s is invalid (%s)", fn, field,
                rrr_status_str(st));
        return FMU_ERROR;
    }
    for (int i = 0; i < RRR_NJ; ++i) {
        if (!(c->gains.kp[i] >= 0.0) || !(c->gains.kd[i] >= 0.0)) {
            fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR, "%s: kp[%d] and kd[%d] must be >= 0", fn,
                    i + 1, i + 1);
            return FMU_ERROR;
        }
    }
    if (!(c->baudrate >= 1e4 && c->baudrate <= 1e6 && c->baudrate == floor(c->baudrate))) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: baudrate must be an integer in [10000, 1000000] bit/s, got %.17g", fn,
                c->baudrate);
        return FMU_ERROR;
    }
    return FMU_OK;
}

static void refresh(controller_can_data *c)
{
    double *s = c->status;
    s[cs_states] = c->states;
    s[cs_commands] = c->commands;
    s[cs_rx_bad_crc] = c->rx_bad[RRR_HIL_RX_BAD_CRC];
    s[cs_rx_bad_dlc] = c->rx_bad[RRR_HIL_RX_BAD_DLC];
    s[cs_rx_unknown_id] = c->rx_bad[RRR_HIL_RX_UNKNOWN_ID];
    s[cs_out_of_order] = c->out_of_order;
    s[cs_stale] = c->stale;
    s[cs_repeated] = c->repeated;
    s[cs_plant_faults] = c->plant_faults;
    s[cs_plant_status_faulty] = c->status_faulty;
    s[cs_plant_status_zero] = c->status_zero;
    s[cs_ctc_failed] = c->ctc_failed;
    s[cs_stop_sent] = c->stop_sent;
    s[cs_frames_received] = c->bus.frames_received;
    s[cs_frames_sent] = c->bus.frames_sent;
    s[cs_format_errors_sent] = c->bus.format_errors_sent;
    s[cs_format_errors_received] = c->bus.format_errors_received;
    s[cs_notifications_ignored] = c->bus.notifications_ignored;
    s[cs_tx_overflow] = c->bus.tx_overflow;
    s[cs_peer_baudrate] = c->bus.peer_baudrate;
}

static fmu_status initialize(fmu_instance *inst)
{
    controller_can_data *c = data_of(inst);
    const char *fn = FMU_FN(inst, "ExitInitializationMode");
    if (check_parameters(inst, c, fn) != FMU_OK || read_table(inst, fn) != FMU_OK) {
        return FMU_ERROR;
    }
    const rrr_hil_reference *r = table_of(inst);
    if (r->n > UINT32_MAX) {
        return FMU_ERROR;
    }
    c->ref_n = (uint32_t)r->n;
    c->ref_hash = table_hash(r);
    refresh(c);
    return FMU_OK;
}

static void send(fmu_instance *inst, const rrr_hil_frame *f)
{
    (void)fmu_bus_send(inst, f->id, f->extended, f->data, f->dlc);
}

static void heartbeat(fmu_instance *inst, controller_can_data *c, uint8_t nmt)
{
    rrr_hil_frame f;
    const rrr_hil_heartbeat hb = {1u, nmt, c->hb_counter++};
    if (rrr_hil_encode_heartbeat(&hb, &f) == 0) {
        send(inst, &f);
    }
}

/* The period index of the current time. */
static long period_now(const fmu_instance *inst)
{
    return lround((inst->time - inst->start_time) / RRR_HIL_PERIOD_S);
}

/* StopCmd (the next alive counter of the command sequence) and the heartbeat "stopped". */
static void stop(fmu_instance *inst, controller_can_data *c, rrr_hil_stop_reason reason)
{
    rrr_hil_frame f;
    const rrr_hil_stop_cmd s = {
        (uint8_t)(c->commands > 0u ? (c->last_cmd_counter + 1u) & 15u : 0u), (uint8_t)reason};
    if (rrr_hil_encode_stop_cmd(&s, &f) == 0) {
        send(inst, &f);
    }
    heartbeat(inst, c, RRR_HIL_NMT_STOPPED);
    c->stop_sent = 1u;
}

/* VoltageCmd(k) from reference row k and the newest state (hil_dbc_controller.c's command and
 * send_period, with rrr_hil_ctrl_law's law), once per period. */
static void command(fmu_instance *inst, controller_can_data *c)
{
    const rrr_hil_reference *r = table_of(inst);
    const long k = period_now(inst);
    if (r == NULL || c->stop_sent || k < 0 || (double)k <= c->period || (size_t)k >= r->n) {
        return;
    }
    if (!c->started) {
        c->started = 1u;
        heartbeat(inst, c, RRR_HIL_NMT_OPERATIONAL);
    }
    int enable = c->done_valid && ((unsigned)(k - c->done) & 15u) <= CONTROLLER_CAN_STALE_PERIODS;
    if (!enable) {
        ++c->stale;
    }
    rrr_ctc_output out;
    memset(&out, 0, sizeof out);
    if (enable &&
        rrr_ctc(&c->model, &c->gains, r->q[k], r->qd[k], r->qdd[k], c->q, c->qd, &out) != RRR_OK) {
        ++c->ctc_failed;
        enable = 0;
        memset(&out, 0, sizeof out);
    }
    rrr_hil_voltage_cmd cmd;
    cmd.counter = (uint8_t)(k & 15);
    cmd.enable = (uint8_t)enable;
    cmd.reset_fault = 0;
    memcpy(cmd.u_V, out.u, sizeof cmd.u_V);
    rrr_hil_frame f;
    if (rrr_hil_encode_voltage_cmd(&cmd, &f) != 0) {
        fmu_log(inst, FMU_WARNING, FMU_LOG_WARNING,
                "%s: VoltageCmd cannot be encoded: u = (%.6g, %.6g, %.6g) V outside the DBC "
                "range [-30, 30] V (is u_max above 30 V?); the run is stopped",
                MODEL_IDENTIFIER, cmd.u_V[0], cmd.u_V[1], cmd.u_V[2]);
        stop(inst, c, RRR_HIL_STOP_FAULT);
        return;
    }
    send(inst, &f);
    ++c->commands;
    c->last_cmd_counter = cmd.counter;
    c->period = (double)k;
    c->enable = enable;
    memcpy(c->u, out.u, sizeof c->u);
    memcpy(c->u_n, out.u_n, sizeof c->u_n);
    memcpy(c->u_c, out.u_c, sizeof c->u_c);
    if (c->sync && (size_t)k + 1u < r->n) {
        const rrr_hil_sync s = {(uint32_t)k};
        if (rrr_hil_encode_sync(&s, &f) == 0) {
            send(inst, &f);
        }
    }
    if (k % (long)RRR_HIL_HEARTBEAT_PERIODS == 0 && k > 0) {
        heartbeat(inst, c, RRR_HIL_NMT_OPERATIONAL);
    }
    if ((size_t)k + 1u == r->n) {
        stop(inst, c, RRR_HIL_STOP_END_OF_RUN);
    }
}

/* A received frame (hil_dbc_controller.c's handle): PlantStatus and the joint state. */
static void on_frame(fmu_instance *inst, const fmu_lsbus_op *op)
{
    controller_can_data *c = data_of(inst);
    rrr_hil_frame f;
    memset(&f, 0, sizeof f);
    f.id = op->id;
    f.extended = op->ide;
    f.dlc = (uint8_t)op->data_length;
    memcpy(f.data, op->data, op->data_length);
    rrr_hil_msg m;
    const rrr_hil_rx rx = rrr_hil_decode(&f, &m);
    ++c->rx_bad[rx];
    if (rx != RRR_HIL_RX_OK) {
        refresh(c);
        return;
    }
    if (m.kind == RRR_HIL_PLANT_STATUS) {
        c->plant_faults = m.u.status.faults;
        c->status_faulty += m.u.status.faults != 0u;
        c->status_zero += m.u.status.zero_voltage != 0u;
    } else if (m.kind == RRR_HIL_JOINT_STATE) {
        const rrr_hil_joint_state *js = &m.u.joint;
        if ((js->counter == c->pending && c->have[js->joint]) ||
            (c->done_valid && js->counter == c->done)) {
            ++c->repeated; /* the plant sends each once a period: a replay or a forgery */
        } else {
            if (js->counter != c->pending || (c->have[0] | c->have[1] | c->have[2]) == 0u) {
                if (c->have[0] | c->have[1] | c->have[2]) {
                    ++c->out_of_order;
                }
                memset(c->have, 0, sizeof c->have);
                c->pending = js->counter;
            }
            c->have[js->joint] = 1u;
            c->pq[js->joint] = js->q_rad;
            c->pqd[js->joint] = js->qd_rad_s;
            if (c->have[0] && c->have[1] && c->have[2]) {
                memcpy(c->q, c->pq, sizeof c->q);
                memcpy(c->qd, c->pqd, sizeof c->qd);
                memset(c->have, 0, sizeof c->have);
                c->done = c->pending;
                c->done_valid = 1u;
                ++c->states;
                if (RRR_LSBUS_TX_CLOCK == FMU_BUS_TX_TRIGGERED) {
                    command(inst, c);
                }
            }
        }
    }
    refresh(c);
}

/* The start of an event: with a countdown Tx clock every period is commanded here; with a
 * triggered one only a period after one without a command (states late or lost). */
static void on_event(fmu_instance *inst)
{
    controller_can_data *c = data_of(inst);
    const long k = period_now(inst);
    if (RRR_LSBUS_TX_CLOCK == FMU_BUS_TX_COUNTDOWN || (c->started && (double)k - 1.0 > c->period)) {
        command(inst, c);
    }
    refresh(c);
}

/* Stateless between events: the outputs are the last command's. */
static fmu_status calculate(fmu_instance *inst)
{
    refresh(data_of(inst));
    return FMU_OK;
}

static fmu_status do_step(fmu_instance *inst, double h)
{
    (void)h;
    refresh(data_of(inst));
    return FMU_OK;
}

static int depends(fmu_vr unknown, fmu_vr known)
{
    (void)unknown;
    (void)known;
    return FMU_DEP_NONE; /* no Real inputs: everything comes over the bus */
}

/* An FMU state's data: the assembly of a state and the flags in range, the reference the state
 * was taken with (its size and hash) the one this instance reads, the parameters once
 * initialized. */
static fmu_status check_state(fmu_instance *inst, const void *data, fmu_state state,
                              const char *fn)
{
    const controller_can_data *c = data;
    if (c->have[0] > 1u || c->have[1] > 1u || c->have[2] > 1u || c->pending > 15u ||
        c->done > 15u || c->done_valid > 1u || c->last_cmd_counter > 15u || c->started > 1u ||
        c->stop_sent > 1u || (c->sync != 0 && c->sync != 1) ||
        !(c->period >= -1.0 && c->period == floor(c->period))) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: the FMU state holds an invalid joint-state assembly or command state", fn);
        return FMU_ERROR;
    }
    if (!fmu_state_initialized(state)) {
        return FMU_OK;
    }
    if (read_table(inst, fn) != FMU_OK) {
        return FMU_ERROR;
    }
    const rrr_hil_reference *r = table_of(inst);
    if (c->ref_n != r->n || c->ref_hash != table_hash(r) || c->period >= (double)r->n) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: the FMU state was taken with another reference table (%u rows) than "
                "resources/%s (%zu rows)",
                fn, (unsigned)c->ref_n, CONTROLLER_CAN_REFERENCE, r->n);
        return FMU_ERROR;
    }
    return check_parameters(inst, c, fn);
}

static const fmu_bus controller_can_bus = {
    .terminal = "CAN",
    .description = "the controller's CAN bus terminal (rrr_bench.dbc frames as CAN Transmit)",
    .tx_clock = RRR_LSBUS_TX_CLOCK,
    .period = RRR_HIL_PERIOD_S,
    .state_offset = offsetof(controller_can_data, bus),
    .vr_notifications = vr_notifications,
    .vr_baudrate = vr_baudrate,
    .frame = on_frame,
    .notification = NULL,
    .event = on_event,
    .glue = &fmu_bus_glue_impl,
};

const fmu_model FMU_MODEL = {
    .identifier = MODEL_IDENTIFIER,
    .description = "Computed-torque controller of the RRR arm as an FMI-LS-BUS CAN node: the CAN "
                   "bench's controller node (rrr_bench.dbc frames, E2E protection) on the "
                   "reference table of its resources",
    .vars = controller_can_vars,
    .n_vars = sizeof controller_can_vars / sizeof controller_can_vars[0],
    .data_size = sizeof(controller_can_data),
    .default_stop_time = 1.0,
    .default_step_size = RRR_SAMPLE_TIME_DEFAULT,
    .default_tolerance = 1e-8,
    .set_defaults = set_defaults,
    .initialize = initialize,
    .calculate = calculate,
    .do_step = do_step,
    .depends = depends,
    .release = release,
    .check_state = check_state,
    .bus = &controller_can_bus,
};
