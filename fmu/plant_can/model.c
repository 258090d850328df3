/*
 * The plant as an FMI-LS-BUS CAN node: its variable table, the bus node of the C plant node
 * (c_src/hil/dbc/hil_dbc_plant.c: the same frames, codec and supervisor) and the calls into
 * librrr. No protocol and no physics of its own: the frames are hil_codec's, the safety policy
 * hil_supervisor's, the dynamics rrr_plant_step's.
 *
 * A period: at its first fmi3DoStep the supervisor decides the voltage from the commands received
 * since the previous period (rrr_hil_sup_next_period, as the C plant at each Sync); the steps
 * integrate with it held; at the Event Mode after the period's last step the node publishes the
 * new state (JointState1..3, PlantStatus, every 100 periods the heartbeat), as the C plant after
 * each Sync. At the Event Mode after initialization it sends the boot-up heartbeat and the state
 * of period 0.
 */
#include "config.h"

#include <math.h>
#include <string.h>

#define T plant_can_data
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
#define STATUS_ROW(NAME, DESC) OUTPUT(vr_status + ps_##NAME, "status." #NAME, DESC, NULL, status[ps_##NAME]),

static const fmu_variable plant_can_vars[] = {
    JOINT_OUTPUTS(vr_q, "q", "position", "rad", x.q),
    JOINT_OUTPUTS(vr_qd, "qd", "velocity", "rad/s", x.qd),
    JOINT_OUTPUTS(vr_qdd, "qdd", "acceleration under the applied voltage", "rad/s2", qdd),
    OUTPUT(vr_tip + 0, "tip.x", "tip position x in the base frame", "m", tip[0]),
    OUTPUT(vr_tip + 1, "tip.y", "tip position y in the base frame", "m", tip[1]),
    OUTPUT(vr_tip + 2, "tip.z", "tip position z in the base frame (z0 up)", "m", tip[2]),
    JOINT_OUTPUTS(vr_u, "u", "voltage applied over the current period (the supervisor's)", "V",
                  u),
    OUTPUT(vr_zero, "zero", "1 when the supervisor forced 0 V over the current period", NULL,
           zero),
    PLANT_CAN_STATUS(STATUS_ROW)
    RRR_MODEL_VARS
    JOINT_PARAMS(vr_q0, "q0", "initial position", "rad", q0),
    JOINT_PARAMS(vr_qd0, "qd0", "initial velocity", "rad/s", qd0),
    FMU_PARAM(vr_h_int, "h_int", "fixed-step mode (adaptive = false): RK4 substep upper bound, > 0",
              "s", T, integ.h_int),
    FMU_ROW(vr_adaptive, FMU_BOOLEAN, FMU_PARAMETER, FMU_FIXED, "adaptive",
            "integrator inside doStep: true = Dormand-Prince 5(4) with step-size control to rtol "
            "and atol; false = fixed-step RK4 in substeps of at most h_int",
            NULL, T, integ.adaptive),
    FMU_PARAM(vr_rtol, "rtol", "adaptive: relative tolerance, in [1e-14, 1e-2]", NULL, T,
              integ.rtol),
    FMU_PARAM(vr_atol, "atol", "adaptive: absolute tolerance, in [1e-14, 1e-2]", NULL, T,
              integ.atol),
    FMU_PARAM(vr_max_missed, "max_missed",
              "supervisor: consecutive periods without a valid command before 0 V and the "
              "timeout fault, an integer >= 1",
              NULL, T, max_missed),
    FMU_PARAM(vr_max_delta_counter, "max_delta_counter",
              "supervisor: largest accepted alive-counter step, an integer in 1..15", NULL, T,
              max_delta_counter),
    FMU_PARAM(vr_baudrate, "baudrate",
              "CAN baud rate sent in the Configuration operation, bit/s, an integer in [1e4, "
              "1e6]",
              NULL, T, baudrate),
    FMU_ROW(vr_notifications, FMU_BOOLEAN, FMU_PARAMETER, FMU_FIXED, "BusNotifications",
            "FMI-LS-BUS: true = Bus Error operations latch the bus fault; false = Confirm, "
            "Arbitration Lost and Bus Error are ignored (fire and forget)",
            NULL, T, notifications),
    FMU_TIME_ROW(vr_time),
};

_Static_assert(sizeof plant_can_vars / sizeof plant_can_vars[0] == vr_count,
               "one table row per value reference");

static plant_can_data *data_of(fmu_instance *inst)
{
    return (plant_can_data *)inst->data;
}

static fmu_status set_defaults(void *d)
{
    plant_can_data *p = d;
    memset(p, 0, sizeof *p);
    if (rrr_model_default(&p->model) != RRR_OK ||
        rrr_plant_integrator_default(&p->integ) != RRR_OK) {
        return FMU_ERROR;
    }
    p->integ.max_steps = PLANT_CAN_MAX_STEPS;
    const rrr_hil_sup_config cfg = rrr_hil_sup_config_default();
    p->max_missed = (double)cfg.max_missed;
    p->max_delta_counter = (double)cfg.max_delta_counter;
    p->baudrate = 1e6;
    p->ctrl_nmt = 255u;
    p->status[ps_stop_reason] = -1.0;
    return FMU_OK;
}

/* 1 when x is an integer in [lo, hi]. */
static int integer_in(double x, double lo, double hi)
{
    return x >= lo && x <= hi && x == floor(x);
}

/* The parameters as ExitInitializationMode accepts them; logs the one at fault under fn. */
static fmu_status check_parameters(fmu_instance *inst, const plant_can_data *p, const char *fn)
{
    const char *field = "";
    rrr_status st = rrr_model_validate(&p->model, &field);
    if (st == RRR_OK) {
        st = rrr_plant_integrator_check(&p->integ, &field);
    }
    double lambda = 0.0;
    if (st == RRR_OK) {
        st = rrr_plant_stiffness(&p->model, &lambda, &field);
    }
    if (st != RRR_OK) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR, "%s: parameter %s is invalid (%s)", fn, field,
                rrr_status_str(st));
        return FMU_ERROR;
    }
    if (!integer_in(p->max_missed, 1.0, 1e6) || !integer_in(p->max_delta_counter, 1.0, 15.0)) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: max_missed must be an integer >= 1 and max_delta_counter one in 1..15, got "
                "%.17g and %.17g",
                fn, p->max_missed, p->max_delta_counter);
        return FMU_ERROR;
    }
    if (!integer_in(p->baudrate, 1e4, 1e6)) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: baudrate must be an integer in [10000, 1000000] bit/s, got %.17g", fn,
                p->baudrate);
        return FMU_ERROR;
    }
    return FMU_OK;
}

/* The counters into the outputs status.*. */
static void refresh(plant_can_data *p)
{
    const rrr_hil_sup_err *e = &p->sup.err;
    double *s = p->status;
    s[ps_faults] = p->sup.faults;
    s[ps_fault_events] = e->fault_events;
    s[ps_crc] = e->crc;
    s[ps_counter] = e->counter;
    s[ps_range] = e->range;
    s[ps_format] = e->format;
    s[ps_sync] = e->sync;
    s[ps_bus] = e->bus;
    s[ps_timeout] = e->timeout;
    s[ps_cmd_missed] = e->cmd_missed;
    s[ps_zero_periods] = e->zero_periods;
    s[ps_resets] = e->resets;
    s[ps_stop_rejected] = e->stop_rejected;
    s[ps_stop_reason] = p->sup.stop ? (double)p->sup.stop_reason : -1.0;
    s[ps_periods] = p->k;
    s[ps_state_out_of_range] = p->tx_state_range;
    s[ps_rx_unknown_id] = p->rx_bad[RRR_HIL_RX_UNKNOWN_ID];
    s[ps_rx_bad_dlc] = p->rx_bad[RRR_HIL_RX_BAD_DLC];
    s[ps_rx_bad_crc] = p->rx_bad[RRR_HIL_RX_BAD_CRC];
    s[ps_rx_out_of_range] = p->rx_bad[RRR_HIL_RX_OUT_OF_RANGE];
    s[ps_rx_ignored] = p->rx_ignored;
    s[ps_frames_received] = p->bus.frames_received;
    s[ps_frames_sent] = p->bus.frames_sent;
    s[ps_format_errors_sent] = p->bus.format_errors_sent;
    s[ps_format_errors_received] = p->bus.format_errors_received;
    s[ps_notifications_ignored] = p->bus.notifications_ignored;
    s[ps_tx_overflow] = p->bus.tx_overflow;
    s[ps_peer_baudrate] = p->bus.peer_baudrate;
    p->zero = p->sup.zero_applied;
}

static fmu_status initialize(fmu_instance *inst)
{
    plant_can_data *p = data_of(inst);
    if (check_parameters(inst, p, FMU_FN(inst, "ExitInitializationMode")) != FMU_OK) {
        return FMU_ERROR;
    }
    const rrr_hil_sup_config cfg = {(unsigned)p->max_missed, (unsigned)p->max_delta_counter};
    if (rrr_hil_sup_init(&p->sup, &cfg) != 0 ||
        rrr_plant_state_init(p->q0, p->qd0, &p->x) != RRR_OK) {
        return FMU_ERROR; /* checked above: not reached */
    }
    p->period_start = inst->start_time;
    refresh(p);
    return FMU_OK;
}

static void send(fmu_instance *inst, const rrr_hil_frame *f)
{
    (void)fmu_bus_send(inst, f->id, f->extended, f->data, f->dlc);
}

static void heartbeat(fmu_instance *inst, plant_can_data *p, uint8_t nmt)
{
    rrr_hil_frame f;
    const rrr_hil_heartbeat hb = {2u, nmt, p->hb_counter++};
    if (rrr_hil_encode_heartbeat(&hb, &f) == 0) {
        send(inst, &f);
    }
}

/* The state of period k: JointState1..3, PlantStatus, every 100 periods the heartbeat
 * (hil_dbc_plant.c's publish). */
static void publish(fmu_instance *inst, plant_can_data *p)
{
    rrr_hil_frame f;
    const uint8_t counter = (uint8_t)(p->k & 15u);
    for (uint8_t j = 0; j < 3u; ++j) {
        const rrr_hil_joint_state js = {j, counter, p->x.q[j], p->x.qd[j]};
        if (rrr_hil_encode_joint_state(&js, &f) != 0) {
            ++p->tx_state_range;
            continue;
        }
        send(inst, &f);
    }
    rrr_hil_plant_status st;
    rrr_hil_sup_status(&p->sup, &st);
    st.counter = counter;
    if (rrr_hil_encode_plant_status(&st, &f) == 0) {
        send(inst, &f);
    }
    if (p->k % RRR_HIL_HEARTBEAT_PERIODS == 0u) {
        heartbeat(inst, p, RRR_HIL_NMT_OPERATIONAL);
    }
}

/* Event Mode: the boot-up and the state of period 0 at the start; the new state after a period. */
static void on_event(fmu_instance *inst)
{
    plant_can_data *p = data_of(inst);
    if (!p->booted) {
        p->booted = 1u;
        heartbeat(inst, p, RRR_HIL_NMT_BOOT);
        publish(inst, p);
    } else if (p->publish_due) {
        publish(inst, p);
    }
    p->publish_due = 0u;
    refresh(p);
}

/* A received frame (hil_dbc_plant.c's handle): commands and stops through the supervisor. */
static void on_frame(fmu_instance *inst, const fmu_lsbus_op *op)
{
    plant_can_data *p = data_of(inst);
    rrr_hil_frame f;
    memset(&f, 0, sizeof f);
    f.id = op->id;
    f.extended = op->ide;
    f.dlc = (uint8_t)op->data_length;
    memcpy(f.data, op->data, op->data_length);
    rrr_hil_msg m;
    const rrr_hil_rx rx = rrr_hil_decode(&f, &m);
    ++p->rx_bad[rx];
    if (rx == RRR_HIL_RX_UNKNOWN_ID) {
        return;
    }
    if (m.kind == RRR_HIL_VOLTAGE_CMD) {
        rrr_hil_sup_on_command(&p->sup, rx, rx == RRR_HIL_RX_OK ? &m.u.cmd : NULL);
    } else if (m.kind == RRR_HIL_STOP_CMD) { /* honoured only with its E2E protection */
        (void)rrr_hil_sup_on_stop(&p->sup, rx, rx == RRR_HIL_RX_OK ? &m.u.stop : NULL);
    } else if (rx != RRR_HIL_RX_OK) {
        return;
    } else if (m.kind == RRR_HIL_HEARTBEAT && m.u.heartbeat.node == 1u) {
        p->ctrl_nmt = m.u.heartbeat.nmt_state; /* informational */
    } else if (m.kind == RRR_HIL_SYNC) {
        if (m.u.sync.cycle != p->k) {
            rrr_hil_sup_raise(&p->sup, RRR_HIL_FAULT_SYNC);
        }
    } else {
        ++p->rx_ignored;
    }
    refresh(p);
}

/* With BusNotifications: a Bus Error latches the bus fault (0 V until a fault reset). */
static void on_notification(fmu_instance *inst, const fmu_lsbus_op *op)
{
    plant_can_data *p = data_of(inst);
    if (op->opcode == FMU_LSBUS_OP_BUS_ERROR) {
        rrr_hil_sup_raise(&p->sup, RRR_HIL_FAULT_BUS);
        refresh(p);
    }
}

/* qdd and tip at the state under the applied voltage (before initialization: at q0, qd0). */
static fmu_status calculate(fmu_instance *inst)
{
    plant_can_data *p = data_of(inst);
    if (inst->state == FMU_INSTANTIATED || inst->state == FMU_INIT_MODE) {
        memcpy(p->x.q, p->q0, sizeof p->x.q);
        memcpy(p->x.qd, p->qd0, sizeof p->x.qd);
    }
    rrr_status st = rrr_plant_accel(&p->model, &p->x, p->u, p->qdd);
    if (st == RRR_OK) {
        st = rrr_fk(&p->model, p->x.q, p->tip, NULL);
    }
    if (st != RRR_OK) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR, "%s: cannot compute qdd and tip: %s",
                MODEL_IDENTIFIER, rrr_status_str(st));
        return FMU_ERROR;
    }
    refresh(p);
    return FMU_OK;
}

/* Integrate over h with u held: one rrr_plant_step (the plant FMU's doStep). */
static fmu_status integrate(fmu_instance *inst, plant_can_data *p, double h)
{
    rrr_plant_state x = p->x;
    double qdd[RRR_NJ];
    double tip[3];
    if (!p->integ.adaptive && h / p->integ.h_int > (double)p->integ.max_steps) {
        fmu_log(inst, FMU_DISCARD, FMU_LOG_DISCARD,
                "%s: a step of %.17g s needs more than %ld substeps of h_int = %.17g s",
                FMU_FN(inst, "DoStep"), h, p->integ.max_steps, p->integ.h_int);
        return FMU_DISCARD;
    }
    rrr_status st = rrr_plant_step(&p->model, &p->integ, p->u, h, &x, qdd, NULL);
    if (st == RRR_OK) {
        st = rrr_fk(&p->model, x.q, tip, NULL);
    }
    if (st != RRR_OK) {
        fmu_log(inst, FMU_DISCARD, FMU_LOG_DISCARD,
                "%s: rrr_plant_step from t = %.17g over h = %.17g failed: %s; the state stays "
                "at t",
                FMU_FN(inst, "DoStep"), inst->time, h, rrr_status_str(st));
        return FMU_DISCARD;
    }
    p->x = x;
    memcpy(p->qdd, qdd, sizeof qdd);
    memcpy(p->tip, tip, sizeof tip);
    return FMU_OK;
}

/* One step of h: periods begin with the supervisor's decision and end with a state to publish.
 * A step that ends on the period's end (to 1e-9 relative) is taken as it is: a 1 ms step is
 * one rrr_plant_step of the importer's h, as in the C plant node. */
static fmu_status do_step(fmu_instance *inst, double h)
{
    plant_can_data *p = data_of(inst);
    const plant_can_data saved = *p; /* a Discard leaves the data as it was */
    const double period = RRR_HIL_PERIOD_S;
    double t = inst->time;
    double left = h;
    while (left > 0.0) {
        if (!p->period_open) {
            (void)rrr_hil_sup_next_period(&p->sup, p->u);
            p->period_open = 1u;
            p->period_start = t;
        }
        const double end = inst->start_time + (double)(p->k + 1u) * period;
        const double tol = 1e-9 * fmax(1.0, fabs(end));
        double seg = left;
        int closes = fabs(t + left - end) <= tol;
        if (!closes && t + left > end) {
            seg = end - t;
            closes = 1;
        }
        const fmu_status st = integrate(inst, p, seg);
        if (st != FMU_OK) {
            *p = saved;
            return st;
        }
        t += seg;
        left = closes && seg != left ? left - seg : 0.0;
        if (closes) {
            ++p->k;
            p->period_open = 0u;
            p->publish_due = 1u;
        }
    }
    refresh(p);
    return FMU_OK;
}

static int depends(fmu_vr unknown, fmu_vr known)
{
    (void)unknown;
    (void)known;
    return FMU_DEP_NONE; /* no Real inputs: everything comes over the bus */
}

/* An FMU state's data (the glue has checked every table row and the bus terminal): the
 * integrator budget, the step-size memory, the supervisor's settings and flags, and once
 * initialized the parameters. */
static fmu_status check_state(fmu_instance *inst, const void *data, fmu_state state,
                              const char *fn)
{
    const plant_can_data *p = data;
    const rrr_hil_sup *s = &p->sup;
    if (p->integ.max_steps != PLANT_CAN_MAX_STEPS || !isfinite(p->x.h_guess) ||
        !(p->x.h_guess >= 0.0) || !isfinite(p->x.err_prev) || !(p->x.err_prev >= 0.0) ||
        !isfinite(p->period_start) || p->period_open > 1u || p->publish_due > 1u ||
        p->booted > 1u || s->faults > 0x7Fu || s->reset_step > 1u || s->stop > 1u ||
        s->stop_reason >= RRR_HIL_STOP_REASON_COUNT || s->pending > 1u ||
        s->have_counter > 1u || s->zero_applied > 1u || s->last_counter > 15u ||
        !isfinite(s->u_hold_V[0]) || !isfinite(s->u_hold_V[1]) || !isfinite(s->u_hold_V[2]) ||
        (fmu_state_initialized(state) &&
         (s->cfg.max_missed < 1u || s->cfg.max_delta_counter < 1u ||
          s->cfg.max_delta_counter > 15u))) {
        fmu_log(inst, FMU_ERROR, FMU_LOG_ERROR,
                "%s: the FMU state holds an invalid integrator, period or supervisor state", fn);
        return FMU_ERROR;
    }
    if (!fmu_state_initialized(state)) {
        return FMU_OK;
    }
    const plant_can_data *now = data_of(inst);
    if (fmu_state_initialized(inst->state) &&
        memcmp(&p->model, &now->model, sizeof p->model) == 0 &&
        memcmp(&p->integ, &now->integ, sizeof p->integ) == 0 &&
        p->max_missed == now->max_missed && p->max_delta_counter == now->max_delta_counter &&
        p->baudrate == now->baudrate) {
        return FMU_OK;
    }
    return check_parameters(inst, p, fn);
}

static const fmu_bus plant_can_bus = {
    .terminal = "CAN",
    .description = "the plant's CAN bus terminal (rrr_bench.dbc frames as CAN Transmit)",
    .tx_clock = RRR_LSBUS_TX_CLOCK,
    .period = RRR_HIL_PERIOD_S,
    .state_offset = offsetof(plant_can_data, bus),
    .vr_notifications = vr_notifications,
    .vr_baudrate = vr_baudrate,
    .frame = on_frame,
    .notification = on_notification,
    .event = on_event,
    .glue = &fmu_bus_glue_impl,
};

const fmu_model FMU_MODEL = {
    .identifier = MODEL_IDENTIFIER,
    .description = "RRR robot arm plant as an FMI-LS-BUS CAN node: the CAN bench's plant node "
                   "(rrr_bench.dbc frames, E2E protection, the command supervisor) around "
                   "librrr's dynamics",
    .vars = plant_can_vars,
    .n_vars = sizeof plant_can_vars / sizeof plant_can_vars[0],
    .data_size = sizeof(plant_can_data),
    .default_stop_time = 1.0,
    .default_step_size = RRR_SAMPLE_TIME_DEFAULT,
    .default_tolerance = 1e-8,
    .set_defaults = set_defaults,
    .initialize = initialize,
    .calculate = calculate,
    .do_step = do_step,
    .depends = depends,
    .check_state = check_state,
    .bus = &plant_can_bus,
};
