/*
 * Bench frames in SI units over the cantools-generated pack/unpack (gen/rrr_bench.c), with the
 * AUTOSAR E2E profile 2 CRC in byte 0 and the alive counter in the low nibble of byte 1.
 */
#include "hil_codec.h"

#include <math.h>
#include <string.h>

uint8_t rrr_hil_crc8_e2e(const uint8_t *data, size_t n, uint8_t data_id)
{
    uint8_t crc = 0xFFu;
    for (size_t i = 0; i <= n; ++i) {
        crc = (uint8_t)(crc ^ ((i < n) ? data[i] : data_id));
        for (int b = 0; b < 8; ++b) {
            const unsigned c = crc;
            crc = (uint8_t)(((c << 1) ^ ((c & 0x80u) ? 0x2Fu : 0u)) & 0xFFu);
        }
    }
    return (uint8_t)(crc ^ 0xFFu);
}

/* CRC over bytes 1..7 and the DataID, as cantools.autosar.end_to_end.compute_profile2_crc. */
static uint8_t e2e_crc(const uint8_t data[8], uint8_t data_id)
{
    return rrr_hil_crc8_e2e(data + 1, 7u, data_id);
}

/* The same over bytes 1..len-1 of a shorter message (StopCmd: len 2). */
static uint8_t e2e_crc_len(const uint8_t *data, size_t len, uint8_t data_id)
{
    return rrr_hil_crc8_e2e(data + 1, len - 1u, data_id);
}

static void frame_init(rrr_hil_frame *f, uint32_t id, uint8_t dlc)
{
    memset(f, 0, sizeof *f);
    f->id = id;
    f->dlc = dlc;
}

static int in_range(double v, double lim)
{
    return isfinite(v) && fabs(v) <= lim;
}

int rrr_hil_encode_sync(const rrr_hil_sync *m, rrr_hil_frame *f)
{
    struct rrr_bench_sync_t s = {.cycle = m->cycle};
    rrr_hil_frame g;
    frame_init(&g, RRR_BENCH_SYNC_FRAME_ID, RRR_BENCH_SYNC_LENGTH);
    if (rrr_bench_sync_pack(g.data, &s, sizeof g.data) != (int)RRR_BENCH_SYNC_LENGTH) {
        return -1;
    }
    *f = g;
    return 0;
}

int rrr_hil_encode_voltage_cmd(const rrr_hil_voltage_cmd *m, rrr_hil_frame *f)
{
    for (int i = 0; i < 3; ++i) {
        if (!in_range(m->u_V[i], 30.0)) {
            return -1;
        }
    }
    if (m->counter > 15u || m->enable > 1u || m->reset_fault > 1u) {
        return -1;
    }
    struct rrr_bench_voltage_cmd_t s = {
        .crc = 0,
        .alive_counter = m->counter,
        .enable = m->enable,
        .reset_fault = m->reset_fault,
        .u1 = rrr_bench_voltage_cmd_u1_encode(m->u_V[0]),
        .u2 = rrr_bench_voltage_cmd_u2_encode(m->u_V[1]),
        .u3 = rrr_bench_voltage_cmd_u3_encode(m->u_V[2]),
    };
    rrr_hil_frame g;
    frame_init(&g, RRR_BENCH_VOLTAGE_CMD_FRAME_ID, RRR_BENCH_VOLTAGE_CMD_LENGTH);
    if (rrr_bench_voltage_cmd_pack(g.data, &s, sizeof g.data) != 8) {
        return -1;
    }
    g.data[0] = e2e_crc(g.data, RRR_HIL_DATA_ID_VOLTAGE_CMD);
    *f = g;
    return 0;
}

/* The three JointState messages share one layout (checked below); joint 1's code packs all. */
_Static_assert(sizeof(struct rrr_bench_joint_state1_t) == sizeof(struct rrr_bench_joint_state2_t) &&
                   sizeof(struct rrr_bench_joint_state1_t) == sizeof(struct rrr_bench_joint_state3_t),
               "JointState1..3 must have the same layout");

int rrr_hil_encode_joint_state(const rrr_hil_joint_state *m, rrr_hil_frame *f)
{
    if (m->joint > 2u || m->counter > 15u || !in_range(m->q_rad, 2147.483647) ||
        !in_range(m->qd_rad_s, 52.4287)) {
        return -1;
    }
    struct rrr_bench_joint_state1_t s = {
        .crc = 0,
        .alive_counter = m->counter,
        .qd = rrr_bench_joint_state1_qd_encode(m->qd_rad_s),
        .q = rrr_bench_joint_state1_q_encode(m->q_rad),
    };
    rrr_hil_frame g;
    frame_init(&g, RRR_BENCH_JOINT_STATE1_FRAME_ID + m->joint, RRR_BENCH_JOINT_STATE1_LENGTH);
    if (rrr_bench_joint_state1_pack(g.data, &s, sizeof g.data) != 8) {
        return -1;
    }
    g.data[0] = e2e_crc(g.data, (uint8_t)(RRR_HIL_DATA_ID_JOINT_STATE1 + m->joint));
    *f = g;
    return 0;
}

int rrr_hil_encode_plant_status(const rrr_hil_plant_status *m, rrr_hil_frame *f)
{
    if (m->counter > 15u || m->state > 15u || m->zero_voltage > 1u) {
        return -1;
    }
    struct rrr_bench_plant_status_t s = {
        .crc = 0,
        .alive_counter = m->counter,
        .state = m->state,
        .faults = m->faults,
        .zero_voltage = m->zero_voltage,
        .fault_count = m->fault_count,
        .cmd_missed = m->cmd_missed,
    };
    rrr_hil_frame g;
    frame_init(&g, RRR_BENCH_PLANT_STATUS_FRAME_ID, RRR_BENCH_PLANT_STATUS_LENGTH);
    if (rrr_bench_plant_status_pack(g.data, &s, sizeof g.data) != 8) {
        return -1;
    }
    g.data[0] = e2e_crc(g.data, RRR_HIL_DATA_ID_PLANT_STATUS);
    *f = g;
    return 0;
}

int rrr_hil_encode_heartbeat(const rrr_hil_heartbeat *m, rrr_hil_frame *f)
{
    rrr_hil_frame g;
    int n;
    if (m->node == 1u) {
        struct rrr_bench_heartbeat_ctrl_t s = {.nmt_state = m->nmt_state, .counter = m->counter};
        frame_init(&g, RRR_BENCH_HEARTBEAT_CTRL_FRAME_ID, RRR_BENCH_HEARTBEAT_CTRL_LENGTH);
        n = rrr_bench_heartbeat_ctrl_pack(g.data, &s, sizeof g.data);
    } else if (m->node == 2u) {
        struct rrr_bench_heartbeat_plant_t s = {.nmt_state = m->nmt_state, .counter = m->counter};
        frame_init(&g, RRR_BENCH_HEARTBEAT_PLANT_FRAME_ID, RRR_BENCH_HEARTBEAT_PLANT_LENGTH);
        n = rrr_bench_heartbeat_plant_pack(g.data, &s, sizeof g.data);
    } else {
        return -1;
    }
    if (n != 2) {
        return -1;
    }
    *f = g;
    return 0;
}

int rrr_hil_encode_stop_cmd(const rrr_hil_stop_cmd *m, rrr_hil_frame *f)
{
    if (m->counter > 15u || m->reason >= (unsigned)RRR_HIL_STOP_REASON_COUNT) {
        return -1;
    }
    struct rrr_bench_stop_cmd_t s = {.crc = 0, .alive_counter = m->counter, .reason = m->reason};
    rrr_hil_frame g;
    frame_init(&g, RRR_BENCH_STOP_CMD_FRAME_ID, RRR_BENCH_STOP_CMD_LENGTH);
    if (rrr_bench_stop_cmd_pack(g.data, &s, sizeof g.data) != (int)RRR_BENCH_STOP_CMD_LENGTH) {
        return -1;
    }
    g.data[0] = e2e_crc_len(g.data, RRR_BENCH_STOP_CMD_LENGTH, RRR_HIL_DATA_ID_STOP_CMD);
    *f = g;
    return 0;
}

static rrr_hil_rx decode_stop_cmd(const rrr_hil_frame *f, rrr_hil_msg *out)
{
    struct rrr_bench_stop_cmd_t s;
    if (rrr_bench_stop_cmd_unpack(&s, f->data, f->dlc) != 0) {
        return RRR_HIL_RX_BAD_DLC;
    }
    if (s.crc != e2e_crc_len(f->data, RRR_BENCH_STOP_CMD_LENGTH, RRR_HIL_DATA_ID_STOP_CMD)) {
        return RRR_HIL_RX_BAD_CRC;
    }
    if (!rrr_bench_stop_cmd_reason_is_in_range(s.reason)) {
        return RRR_HIL_RX_OUT_OF_RANGE;
    }
    out->u.stop.counter = s.alive_counter;
    out->u.stop.reason = s.reason;
    return RRR_HIL_RX_OK;
}

static rrr_hil_rx decode_voltage_cmd(const rrr_hil_frame *f, rrr_hil_msg *out)
{
    struct rrr_bench_voltage_cmd_t s;
    if (rrr_bench_voltage_cmd_unpack(&s, f->data, f->dlc) != 0) {
        return RRR_HIL_RX_BAD_DLC;
    }
    if (s.crc != e2e_crc(f->data, RRR_HIL_DATA_ID_VOLTAGE_CMD)) {
        return RRR_HIL_RX_BAD_CRC;
    }
    if (!rrr_bench_voltage_cmd_u1_is_in_range(s.u1) || !rrr_bench_voltage_cmd_u2_is_in_range(s.u2) ||
        !rrr_bench_voltage_cmd_u3_is_in_range(s.u3)) {
        return RRR_HIL_RX_OUT_OF_RANGE;
    }
    rrr_hil_voltage_cmd *c = &out->u.cmd;
    c->counter = s.alive_counter;
    c->enable = s.enable;
    c->reset_fault = s.reset_fault;
    c->u_V[0] = rrr_bench_voltage_cmd_u1_decode(s.u1);
    c->u_V[1] = rrr_bench_voltage_cmd_u2_decode(s.u2);
    c->u_V[2] = rrr_bench_voltage_cmd_u3_decode(s.u3);
    return RRR_HIL_RX_OK;
}

static rrr_hil_rx decode_joint_state(const rrr_hil_frame *f, uint8_t joint, rrr_hil_msg *out)
{
    struct rrr_bench_joint_state1_t s;
    if (rrr_bench_joint_state1_unpack(&s, f->data, f->dlc) != 0) {
        return RRR_HIL_RX_BAD_DLC;
    }
    if (s.crc != e2e_crc(f->data, (uint8_t)(RRR_HIL_DATA_ID_JOINT_STATE1 + joint))) {
        return RRR_HIL_RX_BAD_CRC;
    }
    rrr_hil_joint_state *j = &out->u.joint;
    j->joint = joint;
    j->counter = s.alive_counter;
    j->q_rad = rrr_bench_joint_state1_q_decode(s.q);
    j->qd_rad_s = rrr_bench_joint_state1_qd_decode(s.qd);
    return RRR_HIL_RX_OK;
}

static rrr_hil_rx decode_plant_status(const rrr_hil_frame *f, rrr_hil_msg *out)
{
    struct rrr_bench_plant_status_t s;
    if (rrr_bench_plant_status_unpack(&s, f->data, f->dlc) != 0) {
        return RRR_HIL_RX_BAD_DLC;
    }
    if (s.crc != e2e_crc(f->data, RRR_HIL_DATA_ID_PLANT_STATUS)) {
        return RRR_HIL_RX_BAD_CRC;
    }
    rrr_hil_plant_status *p = &out->u.status;
    p->counter = s.alive_counter;
    p->state = s.state;
    p->faults = s.faults;
    p->zero_voltage = s.zero_voltage;
    p->fault_count = s.fault_count;
    p->cmd_missed = s.cmd_missed;
    return RRR_HIL_RX_OK;
}

/* Known id -> kind, and the DBC length every frame of that id must have (an exact match: a
 * longer frame is as suspect as a shorter one). */
static int lookup(uint32_t id, rrr_hil_kind *kind, uint8_t *len)
{
    switch (id) {
    case RRR_BENCH_SYNC_FRAME_ID:
        *kind = RRR_HIL_SYNC;
        *len = RRR_BENCH_SYNC_LENGTH;
        return 1;
    case RRR_BENCH_VOLTAGE_CMD_FRAME_ID:
        *kind = RRR_HIL_VOLTAGE_CMD;
        *len = RRR_BENCH_VOLTAGE_CMD_LENGTH;
        return 1;
    case RRR_BENCH_STOP_CMD_FRAME_ID:
        *kind = RRR_HIL_STOP_CMD;
        *len = RRR_BENCH_STOP_CMD_LENGTH;
        return 1;
    case RRR_BENCH_JOINT_STATE1_FRAME_ID:
    case RRR_BENCH_JOINT_STATE2_FRAME_ID:
    case RRR_BENCH_JOINT_STATE3_FRAME_ID:
        *kind = RRR_HIL_JOINT_STATE;
        *len = RRR_BENCH_JOINT_STATE1_LENGTH;
        return 1;
    case RRR_BENCH_PLANT_STATUS_FRAME_ID:
        *kind = RRR_HIL_PLANT_STATUS;
        *len = RRR_BENCH_PLANT_STATUS_LENGTH;
        return 1;
    case RRR_BENCH_HEARTBEAT_CTRL_FRAME_ID:
    case RRR_BENCH_HEARTBEAT_PLANT_FRAME_ID:
        *kind = RRR_HIL_HEARTBEAT;
        *len = RRR_BENCH_HEARTBEAT_CTRL_LENGTH;
        return 1;
    default:
        return 0;
    }
}

rrr_hil_rx rrr_hil_decode(const rrr_hil_frame *f, rrr_hil_msg *out)
{
    rrr_hil_kind kind;
    uint8_t len;
    if (f->extended || !lookup(f->id, &kind, &len)) {
        return RRR_HIL_RX_UNKNOWN_ID;
    }
    out->kind = kind;
    if (f->dlc != len) {
        return RRR_HIL_RX_BAD_DLC;
    }
    rrr_hil_msg m;
    m.kind = kind;
    rrr_hil_rx rx = RRR_HIL_RX_OK;
    switch (kind) {
    case RRR_HIL_SYNC: {
        struct rrr_bench_sync_t s;
        if (rrr_bench_sync_unpack(&s, f->data, f->dlc) != 0) {
            return RRR_HIL_RX_BAD_DLC;
        }
        m.u.sync.cycle = s.cycle;
        break;
    }
    case RRR_HIL_VOLTAGE_CMD:
        rx = decode_voltage_cmd(f, &m);
        break;
    case RRR_HIL_JOINT_STATE:
        rx = decode_joint_state(f, (uint8_t)(f->id - RRR_BENCH_JOINT_STATE1_FRAME_ID), &m);
        break;
    case RRR_HIL_PLANT_STATUS:
        rx = decode_plant_status(f, &m);
        break;
    case RRR_HIL_STOP_CMD:
        rx = decode_stop_cmd(f, &m);
        break;
    case RRR_HIL_HEARTBEAT:
        m.u.heartbeat.node = (uint8_t)(f->id - 0x700u);
        m.u.heartbeat.nmt_state = f->data[0];
        m.u.heartbeat.counter = f->data[1];
        break;
    case RRR_HIL_KIND_COUNT:
    default:
        return RRR_HIL_RX_UNKNOWN_ID;
    }
    if (rx == RRR_HIL_RX_OK) {
        *out = m;
    }
    return rx;
}

const char *rrr_hil_rx_str(rrr_hil_rx rx)
{
    switch (rx) {
    case RRR_HIL_RX_OK:
        return "ok";
    case RRR_HIL_RX_UNKNOWN_ID:
        return "unknown id";
    case RRR_HIL_RX_BAD_DLC:
        return "wrong DLC";
    case RRR_HIL_RX_BAD_CRC:
        return "E2E CRC mismatch";
    case RRR_HIL_RX_OUT_OF_RANGE:
        return "signal out of range";
    case RRR_HIL_RX_COUNT:
    default:
        return "invalid rrr_hil_rx";
    }
}

const char *rrr_hil_stop_reason_str(unsigned reason)
{
    switch (reason) {
    case RRR_HIL_STOP_END_OF_RUN:
        return "end of run";
    case RRR_HIL_STOP_INTERRUPTED:
        return "interrupted";
    case RRR_HIL_STOP_FAULT:
        return "fault";
    case RRR_HIL_STOP_PLANT_LOST:
        return "plant lost";
    default:
        return "invalid stop reason";
    }
}
