/*
 * The controller node's CANopen profile (rrr_hil_controller --profile canopen, docs/canopen.md): a
 * CANopen (CiA 301) master of three CiA 402 drives, its frames from hil_canopen_master.h. It
 * boots, configures (SDO: the mode CST, the rated torque, the encoder resolution, the PDO mapping
 * read back) and enables the drives (the 402 state machine to OPERATION ENABLED), then per period
 * sends the target torques k_t u_k (eq 8, in per mille of the rated torque) in the RPDOs and one
 * SYNC, and reads the state from the TPDOs; lockstep, or with --realtime SYNC on the clock every
 * 1 ms with the master's heartbeat and each drive's consumer of it (--consumer-ms) and, if given,
 * each drive's RPDO timeout (--rpdo-timeout). An EMCY, or a drive that left OPERATION ENABLED,
 * ends the run with exit status 7 (the drive's safety reaction fired); a TPDO that a drive never
 * sends (a second one of a kind in one SYNC, a length other than its mapping's) ends it at once
 * with exit status 8 (tampered input), naming the drive and the frame.
 */
#define _POSIX_C_SOURCE 200809L

#include <stdio.h>
#include <string.h>
#include <time.h>

#include "hil_canopen_master.h"
#include "hil_controller.h"

#define PROG "rrr_hil_controller"

/* The CANopen profile's state beside the node's. */
typedef struct co_master {
    rrr_hil_ctrl *c;
    uint32_t rated_mNm[3];   /* 0x6076 of each drive */
    uint32_t increments[3];  /* 0x608F sub 1 (per revolution, sub 2 = 1) */
    rrr_com_feedback fb[3];  /* TPDO1/TPDO2 of the current SYNC */
    uint32_t syncs;          /* SYNCs sent */
    uint32_t sdo_transfers;  /* SDO transfers confirmed */
    uint32_t tpdo_bad_length; /* TPDOs of a wrong length (the first ends the run) */
    uint32_t tpdo_duplicates; /* TPDOs beyond one per drive and SYNC (the first ends the run) */
    char tampered[128];       /* what ended the run as tampered input, "" if nothing */
    int16_t pm_max[3];       /* largest |target torque| sent, per mille */
    uint32_t late_tpdos;     /* real time: SYNCs whose TPDOs had not all come by the deadline */
    uint32_t tpdo_n[3][2];   /* TPDO1, TPDO2 of each drive received so far */
    uint8_t tpdo_bytes[3][2]; /* TPDO1, TPDO2 of each drive: their length by the mapping read */
    uint32_t heartbeats;     /* real time: the master's heartbeats sent */
} co_master;

/* The PDO mapping this master decodes, as 0x1600/0x1A00/0x1A01 hold it (index << 16 | sub << 8 |
 * bits), and the COB-IDs of RPDO1, TPDO1, TPDO2 (0x1400/0x1800/0x1801 sub 1) less the node id. */
static const struct {
    uint16_t map_index, comm_index, cob_base;
    uint32_t count, entries[3];
} CO_PDOS[3] = {{0x1600u, 0x1400u, 0x200u, 2u, {0x60400010u, 0x60710010u, 0u}},
                {0x1A00u, 0x1800u, 0x180u, 3u, {0x60410010u, 0x60640020u, 0x60610008u}},
                {0x1A01u, 0x1801u, 0x280u, 2u, {0x606C0020u, 0x60770010u, 0u}}};
#define CO_SW_MASK 0x6Fu

/* One expedited SDO transfer (download: size 1, 2 or 4 bytes of *value; upload: size 0, the
 * value into *value). 0, or an exit status with why set: an abort or an answer this master cannot
 * use is a setup failure, no answer within --timeout-ms a lost plant. */
static int co_sdo(co_master *m, const rrr_hil_ctrl_opts *o, uint8_t node, uint16_t index,
                  uint8_t sub, unsigned size, uint32_t *value)
{
    char what[96];
    const int upload = size == 0u;
    (void)snprintf(what, sizeof what, "answer to the SDO %s of drive %u, 0x%04X sub %u",
                   upload ? "upload" : "download", (unsigned)node, (unsigned)index, (unsigned)sub);
    rrr_hil_frame f;
    if ((upload ? rrr_com_sdo_upload(node, index, sub, &f)
                : rrr_com_sdo_download(node, index, sub, *value, size, &f)) != 0) {
        return rrr_hil_run_end(&m->c->run, RRR_HIL_EXIT_FAULT,
                               "SDO request of drive %u cannot be encoded", (unsigned)node);
    }
    int rc = rrr_hil_ctrl_send(m->c, &f, "send an SDO request");
    const int64_t deadline = rrr_hil_now_ms() + o->timeout_ms;
    while (rc == 0) {
        rc = rrr_hil_ctrl_recv_until(m->c, deadline, o, what, &f);
        uint32_t v = 0;
        const rrr_com_sdo_answer a =
            rc == 0 ? rrr_com_sdo_reply(&f, node, index, sub, upload, &v) : RRR_COM_SDO_OTHER;
        if (a == RRR_COM_SDO_DONE) {
            ++m->sdo_transfers;
            if (upload) {
                *value = v;
            }
            return 0;
        }
        if (a == RRR_COM_SDO_ABORT) {
            return rrr_hil_run_end(&m->c->run, RRR_HIL_EXIT_SETUP,
                                   "drive %u: SDO %s of 0x%04X sub %u aborted: "
                                   "code 0x%08X (CiA 301)", (unsigned)node,
                                   upload ? "upload" : "download", (unsigned)index, (unsigned)sub,
                                   v);
        }
        if (a == RRR_COM_SDO_BAD) {
            return rrr_hil_run_end(&m->c->run, RRR_HIL_EXIT_SETUP,
                                   "drive %u: the %s is not an expedited SDO "
                                   "answer this master handles (command byte 0x%02X, DLC %u)",
                                   (unsigned)node, what, (unsigned)f.data[0], (unsigned)f.dlc);
        }
    }
    return rc;
}

static int co_read(co_master *m, const rrr_hil_ctrl_opts *o, uint8_t node, uint16_t index,
                   uint8_t sub, uint32_t *value)
{
    return co_sdo(m, o, node, index, sub, 0u, value);
}

static int co_write(co_master *m, const rrr_hil_ctrl_opts *o, uint8_t node, uint16_t index,
                    uint8_t sub, uint32_t value, unsigned size)
{
    return co_sdo(m, o, node, index, sub, size, &value);
}

static int co_send_nmt(co_master *m, uint8_t command_)
{
    rrr_hil_frame f;
    rrr_com_nmt(command_, 0u, &f);
    return rrr_hil_ctrl_send(m->c, &f, "send NMT");
}

/* NMT reset node (a socketcand server drops the power-on boot-up): every drive's boot-up. The
 * drives that sent none within --timeout-ms are named (a wrong --node-ids: exit status 2). */
static int co_boot(co_master *m, const rrr_hil_ctrl_opts *o)
{
    int rc = co_send_nmt(m, RRR_COM_NMT_RESET_NODE);
    const int64_t deadline = rrr_hil_now_ms() + o->timeout_ms;
    unsigned want = 7u;
    while (rc == 0 && want != 0u) {
        rrr_hil_frame f;
        rc = rrr_hil_ctrl_recv_until(m->c, deadline, o,
                                     "boot-up message of every drive after NMT reset node", &f);
        for (unsigned j = 0; rc == 0 && j < 3u; ++j) {
            if (!f.extended && f.id == 0x700u + o->node_ids[j] && f.dlc == 1u && f.data[0] == 0u) {
                want &= ~(1u << j);
            }
        }
    }
    if (rc == RRR_HIL_EXIT_PEER_LOST && want != 0u && rrr_hil_now_ms() >= deadline) {
        char ids[16] = "";
        for (unsigned j = 0, n = 0; j < 3u; ++j) {
            if (want & (1u << j)) {
                n += (unsigned)snprintf(ids + n, sizeof ids - n, "%s%u", n ? ", " : "",
                                        (unsigned)o->node_ids[j]);
            }
        }
        rc = rrr_hil_run_end(&m->c->run, RRR_HIL_EXIT_SETUP,
                             "drive(s) %s sent no boot-up within %d ms after NMT reset node: no "
                             "such node id on the bus? (--node-ids)", ids, o->timeout_ms);
    }
    return rc;
}

/* SDO: the mode CST, the rated torque, the encoder resolution, the PDO mapping and COB-IDs. */
static int co_configure(co_master *m, const rrr_hil_ctrl_opts *o)
{
    int rc = 0;
    for (unsigned j = 0; rc == 0 && j < 3u; ++j) {
        const uint8_t id = o->node_ids[j];
        uint32_t mode = 0, rev = 0;
        rc = co_write(m, o, id, 0x6060u, 0u, RRR_COM_MODE_CST, 1u);
        if (rc == 0) {
            rc = co_read(m, o, id, 0x6061u, 0u, &mode);
        }
        if (rc == 0 && mode != RRR_COM_MODE_CST) {
            rc = rrr_hil_run_end(&m->c->run, RRR_HIL_EXIT_SETUP,
                                 "drive %u: mode of operation display 0x6061 = "
                                 "%u, not %d (cyclic synchronous torque)", (unsigned)id, mode,
                                 RRR_COM_MODE_CST);
        }
        if (rc == 0) {
            rc = co_read(m, o, id, 0x6076u, 0u, &m->rated_mNm[j]);
        }
        if (rc == 0) {
            rc = co_read(m, o, id, 0x608Fu, 1u, &m->increments[j]);
        }
        if (rc == 0) {
            rc = co_read(m, o, id, 0x608Fu, 2u, &rev);
        }
        if (rc == 0 && (m->rated_mNm[j] == 0u || m->increments[j] == 0u ||
                        m->increments[j] > 0x7FFFFFFFu || rev != 1u)) {
            rc = rrr_hil_run_end(&m->c->run, RRR_HIL_EXIT_SETUP,
                                 "drive %u: rated torque %u mN m, encoder %u/%u: "
                                 "not a configuration this master handles", (unsigned)id,
                                 m->rated_mNm[j], m->increments[j], rev);
        }
        for (unsigned p = 0; rc == 0 && p < 3u; ++p) {
            uint32_t count = 0, entry = 0, cob = 0;
            rc = co_read(m, o, id, CO_PDOS[p].map_index, 0u, &count);
            for (uint8_t e = 0; rc == 0 && e < CO_PDOS[p].count; ++e) {
                rc = co_read(m, o, id, CO_PDOS[p].map_index, (uint8_t)(e + 1u), &entry);
                if (rc == 0 && (count != CO_PDOS[p].count || entry != CO_PDOS[p].entries[e])) {
                    rc = rrr_hil_run_end(&m->c->run, RRR_HIL_EXIT_SETUP,
                                         "drive %u: PDO mapping 0x%04X: %u entries, sub %u = "
                                         "0x%08X; this master decodes %u: 0x%08X, 0x%08X%s",
                                         (unsigned)id, (unsigned)CO_PDOS[p].map_index, count,
                                         (unsigned)e + 1u, entry, CO_PDOS[p].count,
                                         CO_PDOS[p].entries[0], CO_PDOS[p].entries[1],
                                         CO_PDOS[p].count > 2u ? ", 0x60610008" : "");
                }
            }
            if (rc == 0) {
                rc = co_read(m, o, id, CO_PDOS[p].comm_index, 1u, &cob);
            }
            if (rc == 0 && cob != CO_PDOS[p].cob_base + id) {
                rc = rrr_hil_run_end(&m->c->run, RRR_HIL_EXIT_SETUP,
                                     "drive %u: COB-ID 0x%04X sub 1 = 0x%08X, "
                                     "not the valid default 0x%03X", (unsigned)id,
                                     (unsigned)CO_PDOS[p].comm_index, cob,
                                     (unsigned)(CO_PDOS[p].cob_base + id));
            }
            uint32_t bits = 0; /* the TPDO's length: the mapping read, as checked above */
            for (uint32_t e = 0; rc == 0 && p > 0u && e < count; ++e) {
                bits += CO_PDOS[p].entries[e] & 0xFFu;
            }
            if (rc == 0 && p > 0u) {
                m->tpdo_bytes[j][p - 1u] = (uint8_t)(bits / 8u);
            }
        }
    }
    return rc;
}

/* The 402 state machine to OPERATION ENABLED by SDO, in pre-operational (no SYNC: the plant is
 * held at its initial state): shutdown, switch on, enable operation, each checked on the
 * statusword; then NMT start of all nodes. */
static int co_enable(co_master *m, const rrr_hil_ctrl_opts *o)
{
    static const struct {
        uint16_t controlword, statusword;
        const char *state;
    } steps[3] = {{0x06u, 0x21u, "READY TO SWITCH ON"},
                  {0x07u, 0x23u, "SWITCHED ON"},
                  {0x0Fu, 0x27u, "OPERATION ENABLED"}};
    int rc = 0;
    for (unsigned j = 0; rc == 0 && j < 3u; ++j) {
        for (unsigned s = 0; rc == 0 && s < 3u; ++s) {
            uint32_t sw = 0, code = 0;
            rc = co_write(m, o, o->node_ids[j], 0x6040u, 0u, steps[s].controlword, 2u);
            if (rc == 0) {
                rc = co_read(m, o, o->node_ids[j], 0x6041u, 0u, &sw);
            }
            if (rc == 0 && (sw & CO_SW_MASK) != steps[s].statusword) {
                (void)co_read(m, o, o->node_ids[j], 0x603Fu, 0u, &code);
                rc = rrr_hil_run_end(&m->c->run, RRR_HIL_EXIT_SETUP,
                                     "drive %u did not reach %s after controlword "
                                     "0x%02X: statusword 0x%04X, error code 0x%04X",
                                     (unsigned)o->node_ids[j], steps[s].state,
                                     (unsigned)steps[s].controlword, sw, code);
            }
        }
    }
    return rc == 0 ? co_send_nmt(m, RRR_COM_NMT_START) : rc;
}

/* A frame of the drives while the master waits for the TPDOs of SYNC @p k (m->syncs SYNCs sent):
 * a TPDO is stored into m->fb and counted. A drive answers each SYNC with one TPDO1 and one
 * TPDO2 of their mapped lengths (m->tpdo_bytes), so a TPDO of another length, or one more than
 * SYNCs were sent (a second in one SYNC: forged or replayed), is tampered input: it is not used,
 * and the run ends at once with RRR_HIL_EXIT_TAMPERED naming the drive and the frame. An EMCY
 * ends the run (the drive's safety reaction). 0, or an exit status with why set. */
static int co_feed(co_master *m, const rrr_hil_ctrl_opts *o, const rrr_hil_frame *f, uint32_t k)
{
    uint16_t code = 0;
    const uint8_t from = rrr_com_emcy(f, &code);
    if (from != 0u) {
        return rrr_hil_run_end(&m->c->run, RRR_HIL_EXIT_SAFETY, "SYNC %u: EMCY 0x%04X from drive %u",
                               (unsigned)k, (unsigned)code, (unsigned)from);
    }
    for (unsigned j = 0; j < 3u; ++j) {
        const unsigned which = rrr_com_tpdo_number(f, o->node_ids[j]);
        if (which == 0u) {
            continue;
        }
        const unsigned mapped = m->tpdo_bytes[j][which - 1u];
        if (f->dlc != mapped) {
            ++m->tpdo_bad_length;
            (void)snprintf(m->tampered, sizeof m->tampered, "drive %u: TPDO%u of %u bytes, %u "
                           "mapped", (unsigned)o->node_ids[j], which, (unsigned)f->dlc, mapped);
        } else if (++m->tpdo_n[j][which - 1u] > m->syncs) {
            ++m->tpdo_duplicates;
            (void)snprintf(m->tampered, sizeof m->tampered, "drive %u: two TPDO%u in SYNC %u",
                           (unsigned)o->node_ids[j], which, (unsigned)k);
        } else {
            (void)rrr_com_tpdo(f, o->node_ids[j], &m->fb[j]);
            return 0;
        }
        return rrr_hil_run_end(&m->c->run, RRR_HIL_EXIT_TAMPERED,
                               "%s: a frame the drives never send (tampered input?)",
                               m->tampered);
    }
    return 0;
}

/* The RPDO1 of each drive (controlword 0x0F, target torque), one SYNC, then the six TPDOs: the
 * decoded state into the node's q, qd. An EMCY, or a drive that left OPERATION ENABLED, ends the
 * run: the drive's safety reaction fired. 0, or an exit status with why set. */
static int co_period(co_master *m, const rrr_hil_ctrl_opts *o, const int16_t pm[3], uint32_t k)
{
    rrr_hil_frame f;
    int rc = 0;
    for (unsigned j = 0; rc == 0 && j < 3u; ++j) {
        rrr_com_rpdo1(o->node_ids[j], 0x0Fu, pm[j], &f);
        rc = rrr_hil_ctrl_send(m->c, &f, "send RPDO1");
        const int16_t a = (int16_t)(pm[j] < 0 ? -pm[j] : pm[j]);
        if (a > m->pm_max[j]) {
            m->pm_max[j] = a;
        }
    }
    if (rc == 0) {
        rrr_com_sync(&f);
        rc = rrr_hil_ctrl_send(m->c, &f, "send SYNC");
    }
    if (rc != 0) {
        return rc;
    }
    ++m->syncs;
    memset(m->fb, 0, sizeof m->fb);
    const int64_t deadline = rrr_hil_now_ms() + o->timeout_ms;
    char what[64];
    (void)snprintf(what, sizeof what, "TPDOs of SYNC %u", (unsigned)k);
    while ((m->fb[0].have & m->fb[1].have & m->fb[2].have) != 3u) {
        rc = rrr_hil_ctrl_recv_until(m->c, deadline, o, what, &f);
        if (rc == 0) {
            rc = co_feed(m, o, &f, k);
        }
        if (rc != 0) {
            return rc;
        }
    }
    for (unsigned j = 0; j < 3u; ++j) {
        if ((m->fb[j].statusword & CO_SW_MASK) != 0x27u) {
            return rrr_hil_run_end(&m->c->run, RRR_HIL_EXIT_SAFETY,
                                   "SYNC %u: drive %u left OPERATION ENABLED "
                                   "(statusword 0x%04X)", (unsigned)k, (unsigned)o->node_ids[j],
                                   (unsigned)m->fb[j].statusword);
        }
        m->c->q[j] = rrr_com_inc_to_rad(m->fb[j].position_inc, m->increments[j]);
        m->c->qd[j] = rrr_com_inc_to_rad(m->fb[j].velocity_inc, m->increments[j]);
    }
    ++m->c->states;
    return 0;
}

/* us before the next release: the real-time master stops waiting for a SYNC's TPDOs, runs the
 * law on the newest it has and sends the RPDOs (as the Python master's RPDO_GUARD_US). */
#define CO_RPDO_GUARD_US 200

static int64_t co_ns(const struct timespec *t)
{
    return (int64_t)t->tv_sec * 1000000000 + t->tv_nsec;
}

static int64_t co_now_ns(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return co_ns(&ts);
}

static int co_send_heartbeat(co_master *m)
{
    rrr_hil_frame f;
    rrr_com_heartbeat(RRR_COM_MASTER_ID, 0x05u, &f);
    ++m->heartbeats;
    return rrr_hil_ctrl_send(m->c, &f, "send the master's heartbeat");
}

/* Each drive's heartbeat consumer 0x1016 sub 1 of the master (node id << 16 | ms; 0: off). */
static int co_consumer(co_master *m, const rrr_hil_ctrl_opts *o, uint32_t ms)
{
    int rc = 0;
    for (unsigned j = 0; rc == 0 && j < 3u; ++j) {
        rc = co_write(m, o, o->node_ids[j], 0x1016u, 1u,
                      ms ? ((uint32_t)RRR_COM_MASTER_ID << 16) | ms : 0u, 4u);
    }
    return rc;
}

static int co_tpdos_reach(const co_master *m, uint32_t want)
{
    for (unsigned j = 0; j < 3u; ++j) {
        if (m->tpdo_n[j][0] < want || m->tpdo_n[j][1] < want) {
            return 0;
        }
    }
    return 1;
}

/* The frames of the drives until every TPDO has come k + 1 times (those of SYNC k: a SYNC's
 * TPDOs that come late are counted, so the next SYNC's are not mistaken for them) or
 * @p deadline_ns: 1 complete, 0 not (the newest state stays), or an exit status (< 0 negated)
 * with why set. */
static int co_take(co_master *m, const rrr_hil_ctrl_opts *o, int64_t deadline_ns, uint32_t k)
{
    while (!co_tpdos_reach(m, k + 1u)) {
        if (rrr_hil_stop_requested()) {
            return -rrr_hil_run_interrupted(&m->c->run);
        }
        const int64_t left_us = (deadline_ns - co_now_ns()) / 1000;
        if (left_us <= 0) {
            return 0;
        }
        rrr_hil_frame f;
        const rrr_hil_io io = rrr_hil_recv(m->c->tr, &f,
                                           (int)(left_us < 100000 ? left_us : 100000));
        if (io == RRR_HIL_IO_TIMEOUT) {
            continue;
        }
        if (io != RRR_HIL_IO_OK) {
            return -rrr_hil_ctrl_lost(m->c, "receive", io);
        }
        const int rc = co_feed(m, o, &f, k);
        if (rc != 0) {
            return -rc;
        }
    }
    for (unsigned j = 0; j < 3u; ++j) {
        if ((m->fb[j].statusword & CO_SW_MASK) != 0x27u) {
            return -rrr_hil_run_end(&m->c->run, RRR_HIL_EXIT_SAFETY,
                                    "SYNC %u: drive %u left OPERATION ENABLED "
                                    "(statusword 0x%04X)", (unsigned)k, (unsigned)o->node_ids[j],
                                    (unsigned)m->fb[j].statusword);
        }
        m->c->q[j] = rrr_com_inc_to_rad(m->fb[j].position_inc, m->increments[j]);
        m->c->qd[j] = rrr_com_inc_to_rad(m->fb[j].velocity_inc, m->increments[j]);
    }
    ++m->c->states;
    return 1;
}

/* Real time (--realtime): the master's heartbeat (RRR_COM_HEARTBEAT_MS) and the drives'
 * consumer of it (--consumer-ms, default RRR_COM_CONSUMER_MS), each drive's RPDO timeout 0x2001
 * (--rpdo-timeout, when given); then per period on the rrr_hil_rt clock: the heartbeat
 * when due, one SYNC at the release, the TPDOs of that SYNC until CO_RPDO_GUARD_US before the
 * next release (later ones: a late SYNC, the law on the newest state), the law and the RPDOs;
 * at the end the TPDOs still on their way. */
static int co_run_realtime(co_master *m, const rrr_hil_ctrl_opts *o, rrr_hil_rt *rt)
{
    int rc = co_send_heartbeat(m);
    if (rc == 0) {
        rc = co_consumer(m, o, o->consumer_ms ? o->consumer_ms : RRR_COM_CONSUMER_MS);
    }
    for (unsigned j = 0; rc == 0 && o->rpdo_timeout != 0u && j < 3u; ++j) {
        rc = co_write(m, o, o->node_ids[j], 0x2001u, 0u, o->rpdo_timeout, 1u);
    }
    const int16_t zero[3] = {0, 0, 0};
    rrr_hil_frame f;
    for (unsigned j = 0; rc == 0 && j < 3u; ++j) {
        rrr_com_rpdo1(o->node_ids[j], 0x0Fu, zero[j], &f);
        rc = rrr_hil_ctrl_send(m->c, &f, "send RPDO1");
    }
    const int64_t period_ns = rt->period_ns;
    for (size_t k = 0; k < m->c->ref.n && rc == 0; ++k) {
        m->c->run.k = (uint32_t)k;
        rrr_hil_rt_wait(rt);
        const int64_t release = co_ns(&rt->next);
        if (k % RRR_COM_HEARTBEAT_MS == 0u && k > 0u) {
            rc = co_send_heartbeat(m);
        }
        if (rc == 0) {
            rrr_com_sync(&f);
            rc = rrr_hil_ctrl_send(m->c, &f, "send SYNC");
        }
        if (rc != 0) {
            break;
        }
        ++m->syncs;
        const int got = co_take(m, o, k ? release + period_ns - CO_RPDO_GUARD_US * 1000
                                        : release + (int64_t)o->timeout_ms * 1000000, (uint32_t)k);
        if (got < 0) {
            rc = -got;
            break;
        }
        if (got == 0) {
            if (k == 0u) {
                rc = rrr_hil_run_end(&m->c->run, RRR_HIL_EXIT_PEER_LOST,
                                     "plant lost: no TPDOs of SYNC 0 within "
                                     "%d ms (--timeout-ms)", o->timeout_ms);
                break;
            }
            ++m->late_tpdos;
        }
        double u_V[3];
        (void)rrr_hil_ctrl_law(m->c, o, k, 1, u_V);
        for (unsigned j = 0; rc == 0 && j < 3u && k + 1u < m->c->ref.n; ++j) {
            const int16_t pm = rrr_com_torque_pm(u_V[j], m->c->model.kt[j], m->rated_mNm[j]);
            const int16_t a = (int16_t)(pm < 0 ? -pm : pm);
            if (a > m->pm_max[j]) {
                m->pm_max[j] = a;
            }
            rrr_com_rpdo1(o->node_ids[j], 0x0Fu, pm, &f);
            rc = rrr_hil_ctrl_send(m->c, &f, "send RPDO1");
        }
        rrr_hil_rt_done(rt);
    }
    /* The answers still on their way (the drives' TPDOs may lag behind the clock, and a repeat
     * among them shows only once each count can pass the SYNCs sent): read for one heartbeat
     * period after a heartbeat, so that no consumer misses it. */
    if (rc == 0) {
        rc = co_send_heartbeat(m);
    }
    if (rc == 0) {
        const uint32_t states = m->c->states; /* the states the law used */
        const int got = co_take(m, o, co_now_ns() + (int64_t)RRR_COM_HEARTBEAT_MS * 1000000,
                                m->syncs - 1u);
        m->c->states = states;
        rc = got < 0 ? -got : 0;
    }
    if (rc == 0) { /* the consumers off before the heartbeat stops */
        rc = co_consumer(m, o, 0u);
    }
    return rc;
}

/* As the Python master (rrr_robot.hil.canopen.master): boot, configure, enable; the first SYNC
 * gives the initial state (no step); then for k = 0 .. n-1: u_k = ctc(state of SYNC k), the
 * target torques k_t u_k in per mille and, for k < n-1, SYNC k+1. At the end: controlword 0
 * (disable voltage) by SDO and NMT stop; after a failed run NMT stop only, best effort. */
static int run_canopen(co_master *m, const rrr_hil_ctrl_opts *o, rrr_hil_rt *rt)
{
    int rc = co_boot(m, o);
    if (rc == 0) {
        rc = co_configure(m, o);
    }
    if (rc == 0) {
        rc = co_enable(m, o);
    }
    if (rt != NULL) {
        if (rc == 0) {
            rc = co_run_realtime(m, o, rt);
        }
    } else if (rc == 0) {
        const int16_t zero[3] = {0, 0, 0};
        rc = co_period(m, o, zero, 0u);
    }
    for (size_t k = 0; rt == NULL && k < m->c->ref.n && rc == 0; ++k) {
        m->c->run.k = (uint32_t)k;
        double u_V[3];
        (void)rrr_hil_ctrl_law(m->c, o, k, 1, u_V);
        int16_t pm[3];
        for (unsigned j = 0; j < 3u; ++j) {
            pm[j] = rrr_com_torque_pm(u_V[j], m->c->model.kt[j], m->rated_mNm[j]);
        }
        if (k + 1u < m->c->ref.n) {
            rc = co_period(m, o, pm, (uint32_t)(k + 1u));
        }
    }
    if (rc == 0) {
        m->c->run.k = (uint32_t)m->c->ref.n;
        for (unsigned j = 0; rc == 0 && j < 3u; ++j) {
            rc = co_write(m, o, o->node_ids[j], 0x6040u, 0u, 0u, 2u);
        }
        if (rc == 0) {
            rc = co_send_nmt(m, RRR_COM_NMT_STOP);
        }
        if (rc == 0) {
            rc = rrr_hil_run_end(&m->c->run, RRR_HIL_EXIT_OK, "all %zu periods of the reference",
                                 m->c->ref.n);
        }
    } else { /* best effort, the reason kept: the plant may be gone */
        rrr_hil_frame f;
        rrr_com_nmt(RRR_COM_NMT_STOP, 0u, &f);
        (void)rrr_hil_send(m->c->tr, &f);
    }
    return rc;
}

static void co_summary(const co_master *m, const rrr_hil_ctrl_opts *o, int rc)
{
    fprintf(stderr, PROG ": CANopen master of drives %u, %u, %u: %u SYNCs, %u states, %u SDO "
                         "transfers, %u TPDOs of a wrong length, %u duplicated%s%s; rrr_ctc "
                         "failures %u\n",
            (unsigned)o->node_ids[0], (unsigned)o->node_ids[1], (unsigned)o->node_ids[2],
            m->syncs, m->c->states, m->sdo_transfers, m->tpdo_bad_length, m->tpdo_duplicates,
            m->tampered[0] ? ": " : "", m->tampered, m->c->ctc_failed);
    printf("RRR_HIL_SUMMARY {\"node\": \"controller\", \"profile\": \"canopen\", \"exit\": %d, "
           "\"node_ids\": [%u, %u, %u], \"syncs\": %u, \"states\": %u, \"sdo_transfers\": %u, "
           "\"tpdo_bad_length\": %u, \"tpdo_duplicates\": %u, \"tampered\": \"%s\", "
           "\"ctc_failed\": %u, "
           "\"rated_torque_mNm\": [%u, %u, %u], \"increments_per_revolution\": [%u, %u, %u], "
           "\"target_torque_per_mille_max_abs\": [%d, %d, %d], \"late_tpdos\": %u, "
           "\"heartbeats\": %u, \"consumer_ms\": %u, \"rpdo_timeout\": %u, ",
           rc, (unsigned)o->node_ids[0], (unsigned)o->node_ids[1], (unsigned)o->node_ids[2],
           m->syncs, m->c->states, m->sdo_transfers, m->tpdo_bad_length, m->tpdo_duplicates,
           m->tampered, m->c->ctc_failed, m->rated_mNm[0], m->rated_mNm[1], m->rated_mNm[2], m->increments[0], m->increments[1],
           m->increments[2], m->pm_max[0], m->pm_max[1], m->pm_max[2], m->late_tpdos,
           m->heartbeats,
           o->realtime ? (o->consumer_ms ? o->consumer_ms : RRR_COM_CONSUMER_MS) : 0u,
           o->rpdo_timeout);
    rrr_hil_link_json(stdout, m->c->tr);
    printf("}\n");
    fflush(stdout);
}

static int check(const rrr_hil_ctrl_opts *o)
{
    if (!o->realtime && (o->consumer_ms != 0u || o->rpdo_timeout != 0u)) {
        fprintf(stderr, PROG ": --consumer-ms, --rpdo-timeout: options of --profile canopen "
                             "--realtime (the drives' watchdogs of the master's heartbeat and "
                             "RPDOs)\n");
        return -1;
    }
    if (o->consumer_ms != 0u && o->consumer_ms <= RRR_COM_HEARTBEAT_MS) {
        fprintf(stderr, PROG ": --consumer-ms %u: the consumer time must be above the master's "
                             "heartbeat period of %u ms (CiA 301)\n", o->consumer_ms,
                RRR_COM_HEARTBEAT_MS);
        return -1;
    }
    if (o->realtime) {
        for (unsigned j = 0; j < 3u; ++j) {
            if (o->node_ids[j] == RRR_COM_MASTER_ID) {
                fprintf(stderr, PROG ": --profile canopen --realtime: node id %u is the master's "
                                     "own (its heartbeat): give the drives others\n",
                        (unsigned)RRR_COM_MASTER_ID);
                return -1;
            }
        }
    }
    return 0;
}

/* per drive: TPDO1, TPDO2, SDO answers, heartbeat / boot-up, EMCY */
static unsigned rx_ids(const rrr_hil_ctrl_opts *o, uint32_t *ids)
{
    for (unsigned j = 0; j < 3u; ++j) {
        const uint32_t base[5] = {0x180u, 0x280u, 0x580u, 0x700u, 0x080u};
        for (unsigned b = 0; b < 5u; ++b) {
            ids[5u * j + b] = base[b] + o->node_ids[j];
        }
    }
    return 15u;
}

static int run(rrr_hil_ctrl *c, const rrr_hil_ctrl_opts *o, FILE *latency_log,
               rrr_hil_framelog *frames)
{
    static co_master m;
    memset(&m, 0, sizeof m);
    m.c = c;
    int rc;
    if (o->realtime) {
        static rrr_hil_rt rt;
        if (rrr_hil_rt_init(&rt, RRR_HIL_PERIOD_S, (uint32_t)c->ref.n, &o->rt, latency_log,
                            PROG) != 0) {
            rc = rrr_hil_run_end(&c->run, RRR_HIL_EXIT_SETUP, "out of memory");
        } else {
            rc = run_canopen(&m, o, &rt);
            rrr_hil_rt_print(&rt, PROG);
            rrr_hil_rt_free(&rt);
        }
    } else {
        rc = run_canopen(&m, o, NULL);
        if (latency_log != NULL) {
            fclose(latency_log);
        }
    }
    (void)rrr_hil_framelog_close(frames); /* reported in the summary */
    co_summary(&m, o, rc);
    return rc;
}

const rrr_hil_ctrl_profile rrr_hil_canopen_controller = {
    "canopen",
    "  --profile canopen: a CANopen master of three CiA 402 drives (node ids --node-ids,\n"
    "  default 1,2,3): NMT, SDO configuration (CST), the 402 state machine to\n"
    "  OPERATION ENABLED, then one SYNC per period with the target torques (lockstep;\n"
    "  with --realtime: SYNC on the clock every 1 ms, the master's heartbeat (node 127,\n"
    "  20 ms) and each drive's consumer 0x1016 of it (--consumer-ms, 21..65535, default\n"
    "  100), each drive's RPDO timeout 0x2001 if --rpdo-timeout N (1..255 SYNC periods;\n"
    "  default: the drive's own); docs/canopen.md). A TPDO that is not the drives' (a\n"
    "  second one in a SYNC, a wrong length) ends the run with exit status 8\n",
    check, rx_ids, run};
