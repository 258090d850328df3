/* The CANopen slave of one simulated CiA 402 axis (hil_canopen.h). */
#include "hil_canopen.h"

#include <math.h>
#include <stddef.h>
#include <string.h>

#define CO_PI 3.14159265358979323846
#define COB_NMT 0x000u
#define COB_SDO_RX 0x600u
#define COB_SDO_TX 0x580u
#define COB_HEARTBEAT 0x700u
#define PDO_INVALID 0x80000000u
#define PDO_ID_BITS_11_29 0x3FFFF800u /* bit 29: 29-bit frame; 11..28: its high bits */

/* ---- the dictionary ------------------------------------------------------------------------ */

int rrr_co_od_find(uint16_t index, uint8_t sub)
{
    const uint32_t key = ((uint32_t)index << 8) | sub;
    int lo = 0, hi = (int)RRR_CO_OD_COUNT - 1;
    while (lo <= hi) {
        const int mid = lo + (hi - lo) / 2;
        const uint32_t k = ((uint32_t)rrr_co_od[mid].index << 8) | rrr_co_od[mid].subindex;
        if (k == key) {
            return mid;
        }
        if (k < key) {
            lo = mid + 1;
        } else {
            hi = mid - 1;
        }
    }
    for (unsigned i = 0; i < RRR_CO_OD_COUNT; ++i) {
        if (rrr_co_od[i].index == index) {
            return -2;
        }
    }
    return -1;
}

static int is_signed(uint8_t dtype)
{
    return dtype == RRR_CO_T_INTEGER8 || dtype == RRR_CO_T_INTEGER16 || dtype == RRR_CO_T_INTEGER32;
}

static uint32_t size_mask(unsigned size)
{
    return size >= 4 ? 0xFFFFFFFFu : ((1u << (8u * size)) - 1u);
}

/* The value of raw bits as a signed or unsigned number. */
static int64_t as_number(const rrr_co_od_entry *e, uint32_t raw)
{
    if (!is_signed(e->dtype)) {
        return (int64_t)raw;
    }
    const unsigned bits = 8u * e->size;
    const uint32_t sign = 1u << (bits - 1u);
    raw &= size_mask(e->size);
    return (raw & sign) ? (int64_t)raw - ((int64_t)1 << bits) : (int64_t)raw;
}

static void reset_range(rrr_co_node *n, uint16_t lo, uint16_t hi)
{
    for (unsigned i = 0; i < RRR_CO_OD_COUNT; ++i) {
        const rrr_co_od_entry *e = &rrr_co_od[i];
        if (e->index >= lo && e->index <= hi) {
            n->v[i] = e->def + (e->node_id ? n->cfg.node_id : 0u);
        }
    }
    if (lo <= 0x6076u && hi >= 0x6076u) {
        n->v[RRR_CO_OD_RATED_TORQUE] = n->cfg.rated_torque_mNm;
    }
}

int rrr_co_restricted_id(uint32_t can_id)
{
    /* CiA 301's table of restricted CAN-IDs: 0x000 (NMT), 0x001..0x07F, 0x101..0x180,
     * 0x581..0x5FF and 0x601..0x67F (the default SDOs), 0x6E0..0x6FF, 0x701..0x77F (NMT error
     * control), 0x780..0x7FF (0x7E4/0x7E5: LSS); and the broadcast objects of the predefined
     * connection set it leaves configurable but these drives do not: 0x080 (SYNC, 0x1005 is
     * read-only), 0x081..0x0FF (EMCY, 0x1014 read-only), 0x100 (TIME) */
    return can_id <= 0x180u || (can_id >= 0x581u && can_id <= 0x5FFu) ||
           (can_id >= 0x601u && can_id <= 0x67Fu) || (can_id >= 0x6E0u && can_id <= 0x6FFu) ||
           (can_id >= 0x701u && can_id <= 0x7FFu) || can_id > 0x7FFu;
}

/* ---- output -------------------------------------------------------------------------------- */

static rrr_hil_frame *push(rrr_co_node *n, rrr_co_out *out, uint32_t id, uint8_t dlc)
{
    if (out->n >= RRR_CO_MAX_OUT) {
        n->err.out_overflow++;
        return NULL;
    }
    rrr_hil_frame *f = &out->f[out->n++];
    memset(f, 0, sizeof *f);
    f->id = id & 0x7FFu;
    f->dlc = dlc;
    return f;
}

void rrr_co_put_le(uint8_t *p, uint32_t v, unsigned size)
{
    for (unsigned i = 0; i < size; ++i) {
        p[i] = (uint8_t)(v >> (8u * i));
    }
}

uint32_t rrr_co_get_le(const uint8_t *p, unsigned size)
{
    uint32_t v = 0;
    for (unsigned i = 0; i < size; ++i) {
        v |= (uint32_t)p[i] << (8u * i);
    }
    return v;
}

static void emcy(rrr_co_node *n, uint16_t code, rrr_co_out *out)
{
    if (n->nmt == RRR_CO_NMT_INIT || n->nmt == RRR_CO_NMT_STOPPED) {
        return; /* CiA 301: no EMCY in stopped */
    }
    rrr_hil_frame *f = push(n, out, n->v[RRR_CO_OD_EMCY_COBID], 8);
    if (f) {
        rrr_co_put_le(f->data, code, 2);
        f->data[2] = (uint8_t)n->v[RRR_CO_OD_ERROR_REGISTER];
        n->err.emcy_sent++;
    }
}

/* ---- CiA 402 ------------------------------------------------------------------------------- */

uint16_t rrr_co_statusword(rrr_co_402 s)
{
    static const uint16_t sw[RRR_CO_402_COUNT] = {0x0000u, 0x0040u, 0x0031u, 0x0033u,
                                                  0x0037u, 0x0017u, 0x0008u};
    return (uint16_t)((s < RRR_CO_402_COUNT ? sw[s] : 0x0008u) | 0x0200u);
}

const char *rrr_co_402_str(rrr_co_402 s)
{
    static const char *const names[RRR_CO_402_COUNT] = {
        "NOT READY TO SWITCH ON", "SWITCH ON DISABLED", "READY TO SWITCH ON", "SWITCHED ON",
        "OPERATION ENABLED", "QUICK STOP ACTIVE", "FAULT"};
    return s < RRR_CO_402_COUNT ? names[s] : "?";
}

static void set_state(rrr_co_node *n, rrr_co_402 s)
{
    n->s402 = (uint8_t)s;
    n->v[RRR_CO_OD_STATUSWORD] = rrr_co_statusword(s);
    if (s != RRR_CO_402_OPERATION_ENABLED) {
        n->syncs_without_rpdo = 0;
    }
}

/* A fault: the latch (0 torque until its reset event), the 402 state FAULT, 0x1001, 0x603F and
 * the EMCY. */
static void fault(rrr_co_node *n, uint16_t code, uint8_t reg, rrr_co_out *out)
{
    rrr_hil_latch_fault(&n->latch, code);
    n->v[RRR_CO_OD_ERROR_REGISTER] |= (uint32_t)(reg | RRR_CO_ERR_GENERIC);
    n->v[RRR_CO_OD_ERROR_CODE] = n->latch.code;
    set_state(n, RRR_CO_402_FAULT);
    emcy(n, code, out);
}

void rrr_co_raise_fault(rrr_co_node *n, uint16_t code, uint8_t reg_bits, rrr_co_out *out)
{
    fault(n, code, reg_bits, out);
}

/* 0x605A: 1 for the codes that stay in QUICK STOP ACTIVE (5, 6), 0 for those that end in SWITCH
 * ON DISABLED (0, 1, 2); -1 for a code the drive does not support. */
static int quick_stop_option(uint32_t raw)
{
    switch ((int16_t)(uint16_t)raw) {
    case RRR_CO_QS_DISABLE:
    case RRR_CO_QS_SLOW_DOWN:
    case RRR_CO_QS_QUICK:
        return 0;
    case RRR_CO_QS_SLOW_DOWN_STAY:
    case RRR_CO_QS_QUICK_STAY:
        return 1;
    default:
        return -1;
    }
}

static int quick_stop_stays(uint32_t raw)
{
    return quick_stop_option(raw) == 1;
}

static void controlword(rrr_co_node *n, uint16_t cw, rrr_co_out *out)
{
    const uint16_t prev = n->last_cw;
    n->last_cw = cw;
    const rrr_co_402 s = (rrr_co_402)n->s402;
    if (cw & 0x80u) { /* fault reset: only its rising edge, only when a fault is latched (FAULT) */
        if (!(prev & 0x80u) && rrr_hil_latch_reset(&n->latch)) {
            n->v[RRR_CO_OD_ERROR_REGISTER] = 0;
            n->v[RRR_CO_OD_ERROR_CODE] = 0;
            n->hb_seen = 0; /* monitoring restarts with the next heartbeat */
            set_state(n, RRR_CO_402_SWITCH_ON_DISABLED);
            emcy(n, RRR_CO_EMCY_RESET, out);
        }
        return;
    }
    if (s == RRR_CO_402_FAULT || s == RRR_CO_402_NOT_READY) {
        return;
    }
    const int on_states = s == RRR_CO_402_READY || s == RRR_CO_402_SWITCHED_ON ||
                          s == RRR_CO_402_OPERATION_ENABLED;
    if (!(cw & 0x2u)) { /* disable voltage (transitions 7, 9, 10, 12) */
        if (on_states || s == RRR_CO_402_QUICK_STOP) {
            set_state(n, RRR_CO_402_SWITCH_ON_DISABLED);
        }
    } else if (!(cw & 0x4u)) { /* quick stop (7, 10, 11) */
        if (s == RRR_CO_402_OPERATION_ENABLED) {
            /* 11, and with the option codes 0..2 at once 12: the torque is 0 from now on, so
             * the stop (ramp) is complete now */
            set_state(n, quick_stop_stays(n->v[RRR_CO_OD_QUICK_STOP_OPTION])
                             ? RRR_CO_402_QUICK_STOP
                             : RRR_CO_402_SWITCH_ON_DISABLED);
        } else if (s == RRR_CO_402_READY || s == RRR_CO_402_SWITCHED_ON) {
            set_state(n, RRR_CO_402_SWITCH_ON_DISABLED);
        }
    } else if (!(cw & 0x1u)) { /* shutdown (2, 6, 8) */
        if (s == RRR_CO_402_SWITCH_ON_DISABLED || s == RRR_CO_402_SWITCHED_ON ||
            s == RRR_CO_402_OPERATION_ENABLED) {
            set_state(n, RRR_CO_402_READY);
        }
    } else if (!(cw & 0x8u)) { /* switch on (3), disable operation (5) */
        if (s == RRR_CO_402_READY || s == RRR_CO_402_OPERATION_ENABLED) {
            set_state(n, RRR_CO_402_SWITCHED_ON);
        }
    } else { /* enable operation (4; 3 + 4 from READY; 16 from QUICK STOP ACTIVE) */
        if (s == RRR_CO_402_SWITCHED_ON || s == RRR_CO_402_READY || s == RRR_CO_402_QUICK_STOP) {
            set_state(n, RRR_CO_402_OPERATION_ENABLED);
        }
    }
}

/* ---- writes (SDO and RPDO) ---------------------------------------------------------------- */

/* Slots of the three PDOs: comm COB-ID, mapping count; direction. */
typedef struct pdo_desc {
    int cob, type, map_n;
    int rx;
} pdo_desc;

static const pdo_desc PDOS[] = {
    {RRR_CO_OD_RPDO1_COBID, RRR_CO_OD_RPDO1_TYPE, RRR_CO_OD_RPDO1_MAP_N, 1},
    {RRR_CO_OD_TPDO1_COBID, RRR_CO_OD_TPDO1_TYPE, RRR_CO_OD_TPDO1_MAP_N, 0},
    {RRR_CO_OD_TPDO2_COBID, RRR_CO_OD_TPDO2_TYPE, RRR_CO_OD_TPDO2_MAP_N, 0},
};
#define N_PDOS (sizeof PDOS / sizeof PDOS[0])

/* The PDO whose comm or mapping record holds slot, or NULL; *what = 0 comm, 1 map count, 2 entry */
static const pdo_desc *pdo_of(int slot, int *what)
{
    for (unsigned i = 0; i < N_PDOS; ++i) {
        if (slot == PDOS[i].cob || slot == PDOS[i].type) {
            *what = 0;
            return &PDOS[i];
        }
        if (slot == PDOS[i].map_n) {
            *what = 1;
            return &PDOS[i];
        }
        if (slot > PDOS[i].map_n && slot <= PDOS[i].map_n + (int)RRR_CO_MAX_MAPPED) {
            *what = 2;
            return &PDOS[i];
        }
    }
    return NULL;
}

/* Check one mapping entry for a PDO: 0 (empty) or a mappable object of the right size and
 * direction. */
static uint32_t check_map_entry(const pdo_desc *p, uint32_t m)
{
    if (m == 0) {
        return 0;
    }
    const int slot = rrr_co_od_find((uint16_t)(m >> 16), (uint8_t)(m >> 8));
    if (slot < 0) {
        return RRR_CO_ABORT_NO_MAP;
    }
    const rrr_co_od_entry *e = &rrr_co_od[slot];
    const int dir_ok = p->rx ? (e->access == RRR_CO_RW || e->access == RRR_CO_WO)
                             : (e->access != RRR_CO_WO);
    if (!e->pdo || !dir_ok || (m & 0xFFu) != 8u * e->size) {
        return RRR_CO_ABORT_NO_MAP;
    }
    return 0;
}

static uint32_t check_limits(const rrr_co_od_entry *e, uint32_t raw)
{
    const int64_t x = as_number(e, raw);
    if (e->has_high && x > e->high) {
        return RRR_CO_ABORT_TOO_HIGH;
    }
    if (e->has_low && x < e->low) {
        return RRR_CO_ABORT_TOO_LOW;
    }
    return 0;
}

/* The table's limits and the checks that depend on the node's values: the target torque 0x6071
 * within +-0x6072 (the max torque, per mille of 0x6076), the max torque not below the target
 * torque in force, a quick stop option code 0x605A the drive supports. 0 or an abort code. */
static uint32_t check_value(const rrr_co_node *n, int slot, uint32_t raw)
{
    const uint32_t ab = check_limits(&rrr_co_od[slot], raw);
    if (ab) {
        return ab;
    }
    switch (slot) {
    case RRR_CO_OD_TARGET_TORQUE: {
        const int32_t t = (int16_t)(uint16_t)raw;
        const int32_t max = (int32_t)n->v[RRR_CO_OD_MAX_TORQUE];
        return t > max ? RRR_CO_ABORT_TOO_HIGH : t < -max ? RRR_CO_ABORT_TOO_LOW : 0u;
    }
    case RRR_CO_OD_MAX_TORQUE: {
        const int32_t t = (int16_t)(uint16_t)n->v[RRR_CO_OD_TARGET_TORQUE];
        return (uint32_t)(t < 0 ? -t : t) > raw ? RRR_CO_ABORT_TOO_LOW : 0u;
    }
    case RRR_CO_OD_QUICK_STOP_OPTION:
        return quick_stop_option(raw) < 0 ? RRR_CO_ABORT_VALUE : 0u;
    default:
        return 0;
    }
}

/* Write raw bits into slot with the side effects; returns 0 or an abort code (nothing
 * changed). The access check is the caller's. */
static uint32_t write_entry(rrr_co_node *n, int slot, uint32_t raw, rrr_co_out *out)
{
    const rrr_co_od_entry *e = &rrr_co_od[slot];
    raw &= size_mask(e->size);
    uint32_t ab = check_value(n, slot, raw);
    if (ab) {
        return ab;
    }
    int what = 0;
    const pdo_desc *p = pdo_of(slot, &what);
    if (p) {
        const uint32_t cob = n->v[p->cob];
        if (what == 0 && slot == p->cob) {
            const int valid = !(raw & PDO_INVALID);
            if (raw & PDO_ID_BITS_11_29) {
                return RRR_CO_ABORT_VALUE; /* a 29-bit identifier (bit 29), bits 11..28 */
            }
            if (valid && rrr_co_restricted_id(raw & 0x7FFu)) {
                return RRR_CO_ABORT_VALUE; /* NMT, SYNC, EMCY, TIME, SDO, heartbeat, LSS... */
            }
            if (!(cob & PDO_INVALID) && valid && (raw & 0x7FFu) != (cob & 0x7FFu)) {
                return RRR_CO_ABORT_VALUE; /* change the id only while the PDO is invalid */
            }
        } else if (what == 0 && p->rx && raw > 240u && raw < 254u) {
            return RRR_CO_ABORT_VALUE;
        } else if (what == 1) {
            if (!(cob & PDO_INVALID)) {
                return RRR_CO_ABORT_UNSUPPORTED;
            }
            if (raw > RRR_CO_MAX_MAPPED) {
                return RRR_CO_ABORT_TOO_HIGH;
            }
            uint32_t bits = 0;
            for (uint32_t i = 1; i <= raw; ++i) {
                const uint32_t m = n->v[p->map_n + (int)i];
                if ((ab = check_map_entry(p, m)) != 0) {
                    return ab;
                }
                bits += m & 0xFFu;
            }
            if (bits > 64u) {
                return RRR_CO_ABORT_MAP_LEN;
            }
        } else if (what == 2) {
            if (!(cob & PDO_INVALID) || n->v[p->map_n] != 0) {
                return RRR_CO_ABORT_UNSUPPORTED;
            }
            if ((ab = check_map_entry(p, raw)) != 0) {
                return ab;
            }
        }
    }
    switch (slot) {
    case RRR_CO_OD_FAULT_INJECT:
        fault(n, (uint16_t)raw, RRR_CO_ERR_MANUFACTURER, out);
        return 0; /* write-only: not stored */
    case RRR_CO_OD_HB_CONSUMER_1:
        n->hb_seen = 0;
        break;
    case RRR_CO_OD_HB_PRODUCER:
        n->hb_prod_us = 0;
        break;
    default:
        break;
    }
    n->v[slot] = raw;
    if (slot == RRR_CO_OD_CONTROLWORD) {
        controlword(n, (uint16_t)raw, out);
    } else if (slot == RRR_CO_OD_MODE) {
        n->v[RRR_CO_OD_MODE_DISPLAY] = raw;
    } else if (slot == RRR_CO_OD_QUICK_STOP_OPTION && n->s402 == RRR_CO_402_QUICK_STOP &&
               !quick_stop_stays(raw)) {
        set_state(n, RRR_CO_402_SWITCH_ON_DISABLED); /* 12: the stop is complete (0 torque) */
    }
    return 0;
}

/* ---- NMT ----------------------------------------------------------------------------------- */

static void leave_operational(rrr_co_node *n, rrr_co_out *out)
{
    if (n->nmt == RRR_CO_NMT_OPERATIONAL && n->s402 == RRR_CO_402_OPERATION_ENABLED) {
        fault(n, RRR_CO_EMCY_COMM, RRR_CO_ERR_COMM, out); /* sent before the state changes */
    }
}

static void reset_comm(rrr_co_node *n, rrr_co_out *out)
{
    leave_operational(n, out);
    const uint32_t reg = n->v[RRR_CO_OD_ERROR_REGISTER]; /* the errors stay until the fault reset */
    reset_range(n, 0x1000u, 0x1FFFu);
    n->v[RRR_CO_OD_ERROR_REGISTER] = n->s402 == RRR_CO_402_FAULT ? reg : 0u;
    n->rpdo_pending = 0;
    n->rpdo_seen = 0;
    n->tx_pending = 0;
    n->sync_count = 0;
    n->seg_active = 0;
    n->dl_active = 0;
    n->hb_seen = 0;
    n->hb_prod_us = 0;
    n->hb_cons_us = 0;
    n->nmt = RRR_CO_NMT_PREOPERATIONAL;
    rrr_hil_frame *f = push(n, out, COB_HEARTBEAT + n->cfg.node_id, 1);
    if (f) {
        f->data[0] = 0x00; /* boot-up */
    }
}

static void reset_node(rrr_co_node *n, rrr_co_out *out)
{
    leave_operational(n, out);
    (void)rrr_hil_latch_reset(&n->latch); /* the application restarts: a reset event (counted) */
    n->nmt = RRR_CO_NMT_INIT; /* the application restarts: no EMCY until the boot-up */
    reset_range(n, 0x0000u, 0xFFFFu);
    n->last_cw = 0;
    set_state(n, RRR_CO_402_NOT_READY);
    set_state(n, RRR_CO_402_SWITCH_ON_DISABLED); /* transition 1: initialisation done */
    reset_comm(n, out);
}

static void on_nmt(rrr_co_node *n, const rrr_hil_frame *f, rrr_co_out *out)
{
    if (f->dlc != 2) {
        n->err.nmt_ignored++;
        return;
    }
    if (f->data[1] != 0 && f->data[1] != n->cfg.node_id) {
        return;
    }
    switch (f->data[0]) {
    case 0x01:
        n->nmt = RRR_CO_NMT_OPERATIONAL;
        break;
    case 0x02:
        leave_operational(n, out);
        n->nmt = RRR_CO_NMT_STOPPED;
        n->seg_active = 0;
        n->dl_active = 0;
        break;
    case 0x80:
        leave_operational(n, out);
        n->nmt = RRR_CO_NMT_PREOPERATIONAL;
        break;
    case 0x81:
        reset_node(n, out);
        break;
    case 0x82:
        reset_comm(n, out);
        break;
    default:
        n->err.nmt_ignored++;
        break;
    }
}

/* ---- SDO ----------------------------------------------------------------------------------- */

static void sdo_abort(rrr_co_node *n, uint16_t index, uint8_t sub, uint32_t code, rrr_co_out *out)
{
    n->seg_active = 0;
    n->dl_active = 0;
    n->err.sdo_aborts++;
    rrr_hil_frame *f = push(n, out, COB_SDO_TX + n->cfg.node_id, 8);
    if (f) {
        f->data[0] = 0x80;
        rrr_co_put_le(f->data + 1, index, 2);
        f->data[3] = sub;
        rrr_co_put_le(f->data + 4, code, 4);
    }
}

static void on_sdo(rrr_co_node *n, const rrr_hil_frame *f, rrr_co_out *out)
{
    n->sdo_idle_us = 0; /* a request of the client: the server's timeout starts again */
    const uint8_t *d = f->data;
    const uint16_t index = (uint16_t)(f->dlc >= 3 ? d[1] | (d[2] << 8) : 0);
    const uint8_t sub = f->dlc >= 4 ? d[3] : 0;
    if (f->dlc != 8) {
        sdo_abort(n, index, sub, RRR_CO_ABORT_CS, out);
        return;
    }
    const unsigned ccs = d[0] >> 5;
    if (ccs == 4) { /* abort from the client */
        n->seg_active = 0;
        n->dl_active = 0;
        return;
    }
    if (ccs == 3) { /* upload segment */
        if (!n->seg_active) {
            sdo_abort(n, index, sub, RRR_CO_ABORT_CS, out);
            return;
        }
        const rrr_co_od_entry *e = &rrr_co_od[n->seg_slot];
        const unsigned t = (d[0] >> 4) & 1u;
        if (t != n->seg_toggle) {
            sdo_abort(n, e->index, e->subindex, RRR_CO_ABORT_TOGGLE, out);
            return;
        }
        const uint32_t left = e->size - n->seg_pos;
        const uint32_t k = left < 7u ? left : 7u;
        const int last = n->seg_pos + k >= e->size;
        rrr_hil_frame *r = push(n, out, COB_SDO_TX + n->cfg.node_id, 8);
        if (r) {
            r->data[0] = (uint8_t)((t << 4) | ((7u - k) << 1) | (last ? 1u : 0u));
            memcpy(r->data + 1, e->str + n->seg_pos, k);
        }
        n->seg_pos += k;
        n->seg_toggle ^= 1u;
        if (last) {
            n->seg_active = 0;
        }
        return;
    }
    if (ccs == 0) { /* download segment */
        if (!n->dl_active) {
            sdo_abort(n, index, sub, RRR_CO_ABORT_CS, out);
            return;
        }
        const rrr_co_od_entry *e = &rrr_co_od[n->seg_slot];
        const unsigned t = (d[0] >> 4) & 1u, k = 7u - ((d[0] >> 1) & 7u), last = d[0] & 1u;
        if (t != n->seg_toggle) {
            sdo_abort(n, e->index, e->subindex, RRR_CO_ABORT_TOGGLE, out);
            return;
        }
        if (n->seg_pos + k > e->size || (last && n->seg_pos + k != e->size)) {
            sdo_abort(n, e->index, e->subindex,
                      n->seg_pos + k > e->size ? RRR_CO_ABORT_LEN_HIGH : RRR_CO_ABORT_LEN_LOW, out);
            return;
        }
        memcpy(n->dl_buf + n->seg_pos, d + 1, k);
        n->seg_pos += k;
        n->seg_toggle ^= 1u;
        if (last) {
            n->dl_active = 0;
            const uint32_t ab = write_entry(n, n->seg_slot, rrr_co_get_le(n->dl_buf, e->size), out);
            if (ab) {
                sdo_abort(n, e->index, e->subindex, ab, out);
                return;
            }
        }
        rrr_hil_frame *r = push(n, out, COB_SDO_TX + n->cfg.node_id, 8);
        if (r) {
            r->data[0] = (uint8_t)(0x20u | (t << 4));
        }
        return;
    }
    if (ccs != 1 && ccs != 2) { /* block transfers, reserved */
        sdo_abort(n, index, sub, RRR_CO_ABORT_CS, out);
        return;
    }
    n->seg_active = 0;
    n->dl_active = 0;
    const int slot = rrr_co_od_find(index, sub);
    if (slot < 0) {
        sdo_abort(n, index, sub, slot == -1 ? RRR_CO_ABORT_NO_OBJECT : RRR_CO_ABORT_NO_SUB, out);
        return;
    }
    const rrr_co_od_entry *e = &rrr_co_od[slot];
    if (ccs == 2) { /* initiate upload */
        if (e->access == RRR_CO_WO) {
            sdo_abort(n, index, sub, RRR_CO_ABORT_WRITE_ONLY, out);
            return;
        }
        rrr_hil_frame *r = push(n, out, COB_SDO_TX + n->cfg.node_id, 8);
        if (!r) {
            return;
        }
        rrr_co_put_le(r->data + 1, index, 2);
        r->data[3] = sub;
        if (e->str && e->size > 4u) {
            r->data[0] = 0x41; /* segmented, size indicated */
            rrr_co_put_le(r->data + 4, e->size, 4);
            n->seg_active = 1;
            n->seg_toggle = 0;
            n->seg_slot = (uint16_t)slot;
            n->seg_pos = 0;
        } else {
            r->data[0] = (uint8_t)(0x43u | ((4u - e->size) << 2));
            if (e->str) {
                memcpy(r->data + 4, e->str, e->size);
            } else {
                rrr_co_put_le(r->data + 4, n->v[slot], e->size);
            }
        }
        return;
    }
    /* initiate download */
    if (e->access == RRR_CO_RO || e->access == RRR_CO_CONST) {
        sdo_abort(n, index, sub, RRR_CO_ABORT_READ_ONLY, out);
        return;
    }
    const int expedited = (d[0] >> 1) & 1u, sized = d[0] & 1u;
    uint32_t len = e->size;
    if (expedited && sized) {
        len = 4u - ((d[0] >> 2) & 3u);
    } else if (!expedited && sized) {
        len = rrr_co_get_le(d + 4, 4);
    }
    if (len != e->size) {
        sdo_abort(n, index, sub, len > e->size ? RRR_CO_ABORT_LEN_HIGH : RRR_CO_ABORT_LEN_LOW, out);
        return;
    }
    if (!expedited) { /* segmented: the data follow in segments */
        if (e->size > sizeof n->dl_buf) {
            sdo_abort(n, index, sub, RRR_CO_ABORT_UNSUPPORTED, out);
            return;
        }
        rrr_hil_frame *r = push(n, out, COB_SDO_TX + n->cfg.node_id, 8);
        if (r) {
            r->data[0] = 0x60;
            rrr_co_put_le(r->data + 1, index, 2);
            r->data[3] = sub;
            n->dl_active = 1;
            n->seg_toggle = 0;
            n->seg_slot = (uint16_t)slot;
            n->seg_pos = 0;
            memset(n->dl_buf, 0, sizeof n->dl_buf);
        }
        return;
    }
    const uint32_t ab = write_entry(n, slot, rrr_co_get_le(d + 4, e->size), out);
    if (ab) {
        sdo_abort(n, index, sub, ab, out);
        return;
    }
    rrr_hil_frame *r = push(n, out, COB_SDO_TX + n->cfg.node_id, 8);
    if (r) {
        r->data[0] = 0x60;
        rrr_co_put_le(r->data + 1, index, 2);
        r->data[3] = sub;
    }
}

/* ---- PDOs and SYNC ------------------------------------------------------------------------- */

static void apply_rpdo(rrr_co_node *n, rrr_co_out *out)
{
    const pdo_desc *p = &PDOS[0];
    unsigned off = 0;
    /* check every value first: a frame is applied whole or not at all */
    uint32_t vals[RRR_CO_MAX_MAPPED];
    int slots[RRR_CO_MAX_MAPPED];
    const uint32_t count = n->v[p->map_n];
    for (uint32_t i = 0; i < count; ++i) {
        const uint32_t m = n->v[p->map_n + 1 + (int)i];
        slots[i] = rrr_co_od_find((uint16_t)(m >> 16), (uint8_t)(m >> 8));
        const unsigned size = (m & 0xFFu) / 8u;
        vals[i] = rrr_co_get_le(n->rpdo_data + off, size);
        off += size;
        if (slots[i] >= 0 && check_value(n, slots[i], vals[i]) != 0) {
            fault(n, RRR_CO_EMCY_PARAM, RRR_CO_ERR_PROFILE, out);
            return;
        }
    }
    for (uint32_t i = 0; i < count; ++i) {
        if (slots[i] >= 0) {
            (void)write_entry(n, slots[i], vals[i], out);
        }
    }
}

static unsigned mapped_bytes(const rrr_co_node *n, const pdo_desc *p)
{
    unsigned bits = 0;
    for (uint32_t i = 1; i <= n->v[p->map_n]; ++i) {
        bits += n->v[p->map_n + (int)i] & 0xFFu;
    }
    return bits / 8u;
}

static void on_rpdo(rrr_co_node *n, const rrr_hil_frame *f, rrr_co_out *out)
{
    if (f->dlc < mapped_bytes(n, &PDOS[0])) {
        n->err.rpdo_short++;
        emcy(n, RRR_CO_EMCY_PDO_LENGTH, out);
        return;
    }
    memcpy(n->rpdo_data, f->data, 8);
    n->rpdo_seen = 1;
    if (n->v[PDOS[0].type] >= 254u) {
        apply_rpdo(n, out);
    } else {
        n->rpdo_pending = 1;
    }
}

int32_t rrr_co_rad_to_inc(double x, uint32_t increments)
{
    const double v = x * (double)increments / (2.0 * CO_PI);
    if (!(v == v)) {
        return 0;
    }
    if (v >= 2147483647.0) {
        return INT32_MAX;
    }
    if (v <= -2147483648.0) {
        return INT32_MIN;
    }
    return (int32_t)lround(v);
}

static void on_sync(rrr_co_node *n, const rrr_hil_frame *f, rrr_co_out *out)
{
    if (f->dlc > 1) {
        n->err.sync_bad++;
        emcy(n, RRR_CO_EMCY_SYNC_LENGTH, out);
        return;
    }
    if (n->nmt != RRR_CO_NMT_OPERATIONAL) {
        return;
    }
    n->sync_count++;
    if (n->rpdo_pending) {
        n->rpdo_pending = 0;
        apply_rpdo(n, out);
    }
    if (n->rpdo_seen) {
        n->syncs_without_rpdo = 0;
    } else if (n->s402 == RRR_CO_402_OPERATION_ENABLED && n->v[RRR_CO_OD_RPDO_TIMEOUT] != 0) {
        if (++n->syncs_without_rpdo >= n->v[RRR_CO_OD_RPDO_TIMEOUT]) {
            n->err.rpdo_timeouts++;
            fault(n, RRR_CO_EMCY_RPDO_TIMEOUT, RRR_CO_ERR_COMM, out);
        }
    }
    n->rpdo_seen = 0;
    n->tx_pending = 1;
    double tau = rrr_co_torque_Nm(n); /* the period this SYNC starts, through the output stage */
    (void)rrr_hil_latch_output(&n->latch, n->s402 == RRR_CO_402_QUICK_STOP, &tau, 1u);
}

void rrr_co_transmit(rrr_co_node *n, rrr_co_out *out)
{
    if (!n->tx_pending || n->nmt != RRR_CO_NMT_OPERATIONAL) {
        n->tx_pending = 0;
        return;
    }
    n->tx_pending = 0;
    /* sample the state of this SYNC */
    const uint32_t inc = n->v[RRR_CO_OD_ENCODER_INCREMENTS] /
                         (n->v[RRR_CO_OD_ENCODER_REVOLUTIONS] ? n->v[RRR_CO_OD_ENCODER_REVOLUTIONS] : 1u);
    n->v[RRR_CO_OD_POSITION_ACTUAL] = (uint32_t)rrr_co_rad_to_inc(n->q_rad, inc);
    n->v[RRR_CO_OD_VELOCITY_ACTUAL] = (uint32_t)rrr_co_rad_to_inc(n->qd_rad_s, inc);
    const double tau = rrr_co_torque_Nm(n);
    const double pm = tau * 1e6 / (double)n->v[RRR_CO_OD_RATED_TORQUE];
    n->v[RRR_CO_OD_TORQUE_ACTUAL] = (uint32_t)(uint16_t)(int16_t)lround(pm);
    for (unsigned k = 1; k < N_PDOS; ++k) {
        const pdo_desc *p = &PDOS[k];
        const uint32_t cob = n->v[p->cob], type = n->v[p->type];
        if ((cob & PDO_INVALID) || n->v[p->map_n] == 0u || type == 0u || type > 240u ||
            n->sync_count % type != 0u) { /* invalid, nothing mapped, or not due */
            continue;
        }
        rrr_hil_frame *r = push(n, out, cob, (uint8_t)mapped_bytes(n, p));
        if (!r) {
            continue;
        }
        unsigned off = 0;
        for (uint32_t i = 1; i <= n->v[p->map_n]; ++i) {
            const uint32_t m = n->v[p->map_n + (int)i];
            const int slot = rrr_co_od_find((uint16_t)(m >> 16), (uint8_t)(m >> 8));
            const unsigned size = (m & 0xFFu) / 8u;
            rrr_co_put_le(r->data + off, slot >= 0 ? n->v[slot] : 0u, size);
            off += size;
        }
    }
}

/* ---- the node ------------------------------------------------------------------------------ */

int rrr_co_init(rrr_co_node *n, const rrr_co_config *cfg)
{
    if (!n || !cfg || cfg->node_id < 1 || cfg->node_id > 127 || cfg->rated_torque_mNm == 0) {
        return -1;
    }
    memset(n, 0, sizeof *n);
    n->cfg = *cfg;
    rrr_hil_latch_init(&n->latch);
    n->nmt = RRR_CO_NMT_INIT;
    reset_range(n, 0x0000u, 0xFFFFu);
    set_state(n, RRR_CO_402_NOT_READY);
    return 0;
}

void rrr_co_boot(rrr_co_node *n, rrr_co_out *out)
{
    reset_node(n, out);
}

void rrr_co_on_frame(rrr_co_node *n, const rrr_hil_frame *f, rrr_co_out *out)
{
    if (n->nmt == RRR_CO_NMT_INIT || f->extended) {
        return;
    }
    const uint8_t id = n->cfg.node_id;
    if (f->id == COB_NMT) {
        on_nmt(n, f, out);
        return;
    }
    const uint32_t hb = n->v[RRR_CO_OD_HB_CONSUMER_1];
    if (((hb >> 16) & 0x7Fu) != 0 && f->id == COB_HEARTBEAT + ((hb >> 16) & 0x7Fu) && f->dlc >= 1) {
        n->hb_seen = 1;
        n->hb_cons_us = 0;
        return;
    }
    if (n->nmt == RRR_CO_NMT_STOPPED) {
        return;
    }
    if (f->id == COB_SDO_RX + id) {
        on_sdo(n, f, out);
    } else if (f->id == (n->v[RRR_CO_OD_SYNC_COBID] & 0x7FFu)) {
        on_sync(n, f, out);
    } else if (n->nmt == RRR_CO_NMT_OPERATIONAL && !(n->v[RRR_CO_OD_RPDO1_COBID] & PDO_INVALID) &&
               f->id == (n->v[RRR_CO_OD_RPDO1_COBID] & 0x7FFu)) {
        on_rpdo(n, f, out);
    }
}

void rrr_co_advance(rrr_co_node *n, uint32_t dt_us, rrr_co_out *out)
{
    if (n->nmt == RRR_CO_NMT_INIT) {
        return;
    }
    if (n->seg_active || n->dl_active) { /* the SDO server's timeout */
        n->sdo_idle_us = dt_us > RRR_CO_SDO_TIMEOUT_US - n->sdo_idle_us
                             ? RRR_CO_SDO_TIMEOUT_US + 1u
                             : n->sdo_idle_us + dt_us;
        if (n->sdo_idle_us > RRR_CO_SDO_TIMEOUT_US) {
            const rrr_co_od_entry *e = &rrr_co_od[n->seg_slot];
            n->err.sdo_timeouts++;
            sdo_abort(n, e->index, e->subindex, RRR_CO_ABORT_TIMEOUT, out);
            n->sdo_idle_us = 0;
        }
    }
    const uint32_t hb_us = n->v[RRR_CO_OD_HB_PRODUCER] * 1000u;
    if (hb_us != 0) {
        n->hb_prod_us += dt_us;
        if (n->hb_prod_us >= hb_us) {
            n->hb_prod_us = n->hb_prod_us - hb_us >= hb_us ? 0 : n->hb_prod_us - hb_us;
            rrr_hil_frame *f = push(n, out, COB_HEARTBEAT + n->cfg.node_id, 1);
            if (f) {
                f->data[0] = n->nmt;
            }
        }
    }
    const uint32_t hb = n->v[RRR_CO_OD_HB_CONSUMER_1];
    const uint32_t limit_us = (hb & 0xFFFFu) * 1000u;
    if (n->hb_seen && limit_us != 0 && ((hb >> 16) & 0x7Fu) != 0) {
        n->hb_cons_us += dt_us;
        if (n->hb_cons_us > limit_us) {
            n->hb_seen = 0;
            n->err.hb_lost++;
            fault(n, RRR_CO_EMCY_HEARTBEAT, RRR_CO_ERR_COMM, out);
        }
    }
}

void rrr_co_set_feedback(rrr_co_node *n, double q_rad, double qd_rad_s)
{
    n->q_rad = q_rad;
    n->qd_rad_s = qd_rad_s;
}

double rrr_co_torque_Nm(const rrr_co_node *n)
{
    double tau = 0.0; /* the drive function: the target torque, in OPERATION ENABLED only, and
                       * not while the halt bit (controlword bit 8, 0x605D: 0 torque at once) */
    if (n->nmt == RRR_CO_NMT_OPERATIONAL && n->s402 == RRR_CO_402_OPERATION_ENABLED &&
        !(n->v[RRR_CO_OD_CONTROLWORD] & RRR_CO_CW_HALT)) {
        const int16_t t = (int16_t)(uint16_t)n->v[RRR_CO_OD_TARGET_TORQUE];
        tau = (double)t * (double)n->v[RRR_CO_OD_RATED_TORQUE] * 1e-6;
    }
    /* the output stage of the safety policy: 0 while a fault is latched or in a quick stop */
    return rrr_hil_latch_blocks(&n->latch, n->s402 == RRR_CO_402_QUICK_STOP) ? 0.0 : tau;
}
